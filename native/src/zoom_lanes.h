/* Deep zoom (issue 18), lane-parallel: zoom.c's ub_zoom_start, ub_zoom_iterate and ub_zoom_finish
 * for all the lanes of a packet at once, in the double vectors (vd, VD_LANES per vector) of the
 * AVX2 and AVX-512 kernels' simd_*.h; included by estimators.h, so compiled once per kernel. The
 * portable kernel runs zoom.c's scalar code lane by lane (zoom_lanes_scalar).
 *
 * Same bits: each lane runs the scalar loop's operations in its order, IEEE + - * sqrt, min and
 * max, never fused (-ffp-contract=off, no FMA intrinsic here), so the three kernels and the scalar
 * reference agree bit for bit (tests/native/test_deep_zoom.py compares them through _zoom_probe).
 *
 * Lanes diverge: they escape, glitch onto the critical orbit or outrun the reference at different
 * iterations, and the skip table starts them at different ones. Each lane keeps its reference
 * entry as a byte offset into the ub_zoom record (a row of ref or of crit): while the lanes of a
 * vector that follow a reference all sit on the same entry (the same skip, no glitch: the common
 * case) it is one broadcast load per component, else a gather. */

#include "ubmath.h" /* ub_log's series and constants */

/* What a packet's estimate yields, per lane (ub_zoom_result's fields). */
typedef struct {
    double dist[UB_LANES], iterations[UB_LANES], trap[UB_LANES], potential[UB_LANES], normal[3][UB_LANES];
    double rebases[UB_LANES];
} zoom_out;

/* One point's ub_zoom_result into lane l of out. */
static inline void zoom_out_put(zoom_out *out, int l, const ub_zoom_result *one)
{
    out->dist[l] = one->dist;
    out->iterations[l] = one->iterations;
    out->trap[l] = one->trap;
    out->potential[l] = one->potential;
    for (int a = 0; a < 3; a++)
        out->normal[a][l] = one->normal[a];
    out->rebases[l] = one->rebases;
}

/* zoom.c's scalar reference, lane by lane, for the lanes `bits` of the packet q: what the vectors
 * below must equal bit for bit (the probe compares them), and the portable kernel's own path: its
 * plain-C vectors of 4 doubles measured slower than the scalar code at zoom 30 (5.6 against 3.4 ns
 * CPU per iteration on x86-64), where the skip table leaves few iterations per call. */
static void zoom_lanes_scalar(const ub_object *o, int path, int bits, const float q[4][UB_LANES], const int want,
                              zoom_out *out)
{
    for (int l = 0; l < UB_LANES; l++) {
        if (!((bits >> l) & 1))
            continue;
        const double uq[4] = {q[0][l], q[1][l], q[2][l], q[3][l]};
        ub_zoom_result one;
        ub_zoom_estimate(o, path, uq, want, &one);
        zoom_out_put(out, l, &one);
    }
}

#ifndef VD_LANES /* the portable kernel */
#define zoom_lanes zoom_lanes_scalar
#else

#define ZOOM_VECTORS (UB_LANES / VD_LANES)
#define ZOOM_ENTRY ((int)sizeof(double[4])) /* bytes per reference entry */

/* VD_LANES lanes' state: ub_zoom_state's fields, one lane per vector element. */
typedef struct {
    vd z[4], d[4], dc[4], c_full[4];
    vd c2;                 /* |c_full|^2, for the switch to direct iteration (zoom_may_go_direct) */
    vd ref[4];             /* the reference entry Z_index the next step starts from */
    vd r2, dr2, dm, trap, add_scale, n, rebases;
    vd offset, end;        /* byte offsets in ub_zoom of Z_index and of its orbit's end */
    vd j[3][4];
    vdm active;            /* still iterating */
    vdm direct;            /* no reference (delta is z) */
    int shared;            /* >= 0: every active lane with a reference is at this offset */
} zoom_vector;

/* The byte offset the lanes `bits` of `offsets` all hold, or -1 when there is none or they differ. */
static inline __attribute__((always_inline)) int shared_offset(vd offsets, int bits)
{
    double offset[VD_LANES];
    vd_store(offset, offsets);
    int shared = -1;
    for (int l = 0; l < VD_LANES; l++) {
        if (!((bits >> l) & 1))
            continue;
        if (shared < 0)
            shared = (int)offset[l];
        else if ((int)offset[l] != shared)
            return -1;
    }
    return shared;
}

/* Whether the active lanes that follow a reference share one entry (then `shared` is its offset;
 * -1 when there is none, or they differ). */
static inline __attribute__((always_inline)) void zoom_share(zoom_vector *v)
{
    v->shared = shared_offset(v->offset, vdm_bits(vdm_andnot(v->direct, v->active)));
}

static inline __attribute__((always_inline)) vd zoom_norm2(const vd x[4])
{
    return vd_add(vd_add(vd_add(vd_mul(x[0], x[0]), vd_mul(x[1], x[1])), vd_mul(x[2], x[2])), vd_mul(x[3], x[3]));
}

/* The Jacobian's step, dz/dx <- z dz/dx + dz/dx z (+ dmu/dx), and its rescaling (ub_zoom_iterate). */
static inline __attribute__((always_inline)) void zoom_jacobian_step(const ub_object *o, zoom_vector *v,
                                                                     const int julia)
{
    const vdm act = v->active;
    const vd two = vd_set1(2.0);
    vd big = vd_set1(0.0);
    for (int a = 0; a < 3; a++) {
        vd *h = v->j[a], nj[4];
        vd vw = vd_add(vd_add(vd_mul(v->z[1], h[1]), vd_mul(v->z[2], h[2])), vd_mul(v->z[3], h[3]));
        nj[0] = vd_mul(two, vd_sub(vd_mul(v->z[0], h[0]), vw));
        for (int k = 1; k < 4; k++)
            nj[k] = vd_mul(two, vd_add(vd_mul(v->z[0], h[k]), vd_mul(h[0], v->z[k])));
        if (!julia)
            for (int k = 0; k < 4; k++)
                nj[k] = vd_add(nj[k], vd_mul(v->add_scale, vd_set1(o->slice_basis[k][a])));
        for (int k = 0; k < 4; k++)
            h[k] = vd_select(act, nj[k], h[k]);
        big = vd_max(zoom_norm2(nj), big); /* fmax(big, |nj|^2): a NaN leaves big */
    }
    const vdm huge = vdm_and(act, vd_gt(big, vd_set1(1e200)));
    if (vdm_bits(huge)) { /* only the direction matters */
        const vd tiny = vd_set1(1e-100);
        for (int a = 0; a < 3; a++)
            for (int k = 0; k < 4; k++)
                v->j[a][k] = vd_select(huge, vd_mul(v->j[a][k], tiny), v->j[a][k]);
        v->add_scale = vd_select(huge, vd_mul(v->add_scale, tiny), v->add_scale);
    }
}

/* delta^2 (+ what direct iteration adds, dc, after): the step without a reference. */
static inline __attribute__((always_inline)) void zoom_square(const vd d[4], vd out[4])
{
    const vd two = vd_set1(2.0);
    const vd p = d[0];
    out[0] = vd_sub(vd_mul(p, p), vd_add(vd_add(vd_mul(d[1], d[1]), vd_mul(d[2], d[2])), vd_mul(d[3], d[3])));
    for (int k = 1; k < 4; k++)
        out[k] = vd_mul(vd_mul(two, p), d[k]);
}

/* The lanes `leave` leave the reference (zoom.c: zoom_go_direct): delta becomes z (here `delta`, the
 * step's new delta, and z its point), and each step adds the full c. */
static inline __attribute__((always_inline)) void zoom_go_direct(zoom_vector *v, vdm leave, const vd z[4], vd delta[4])
{
    for (int k = 0; k < 4; k++) {
        delta[k] = vd_select(leave, z[k], delta[k]);
        v->dc[k] = vd_select(leave, v->c_full[k], v->dc[k]);
    }
    v->direct = vdm_or(v->direct, leave);
}

/* One iteration of the active lanes of v (ub_zoom_iterate's loop body). The potential's 2^-n is
 * not carried: zoom_unpack forms it from n, exactly (n <= 1024: 2^-n is a double). */
static inline __attribute__((always_inline)) void zoom_step(const ub_object *o, zoom_vector *v, const int julia,
                                                            const int perturb, const int jacobian, const int trap)
{
    const ub_zoom *zm = &o->zoom;
    const vdm act = v->active;
    const vd two = vd_set1(2.0);
    if (jacobian)
        zoom_jacobian_step(o, v, julia);
    if (julia)
        v->dr2 = vd_select(act, vd_mul(v->dr2, vd_mul(vd_set1(4.0), v->r2)), v->dr2);
    else
        v->dm = vd_select(act, vd_add(vd_mul(vd_mul(two, vd_sqrt(v->r2)), v->dm), vd_set1(1.0)), v->dm);
    vd nd[4], z[4];
    vdm following = vdm_andnot(v->direct, act);
    if (perturb && vdm_bits(following)) {
        /* The reference ends before these lanes escape: they go on directly. */
        const vdm ending = vdm_and(following, vd_ge(vd_add(v->offset, vd_set1(ZOOM_ENTRY)), v->end));
        if (vdm_bits(ending)) {
            zoom_go_direct(v, ending, v->z, v->d);
            following = vdm_andnot(ending, following);
        }
    }
    if (perturb && vdm_bits(following)) {
        /* (Z + delta)^2 - Z^2: real part p (2a + p) - w.(2v + w), vector part 2 (a + p) w + 2 p v. */
        const vd *ref = v->ref, *d = v->d, p = d[0];
        nd[0] = vd_mul(p, vd_add(vd_mul(two, ref[0]), p));
        for (int k = 1; k < 4; k++)
            nd[0] = vd_sub(nd[0], vd_mul(d[k], vd_add(vd_mul(two, ref[k]), d[k])));
        for (int k = 1; k < 4; k++)
            nd[k] = vd_mul(two, vd_add(vd_mul(vd_add(ref[0], p), d[k]), vd_mul(p, ref[k])));
        if (vdm_bits(vdm_and(v->direct, act))) {
            vd sq[4];
            zoom_square(d, sq);
            for (int k = 0; k < 4; k++)
                nd[k] = vd_select(v->direct, sq[k], nd[k]);
        }
    } else {
        zoom_square(v->d, nd);
    }
    vd dn[4];
    for (int k = 0; k < 4; k++)
        dn[k] = vd_add(nd[k], v->dc[k]);
    if (perturb && vdm_bits(following)) {
        /* The next entry: one broadcast while the lanes share it, else a gather. */
        const char *base = (const char *)zm;
        v->offset = vd_select(following, vd_add(v->offset, vd_set1(ZOOM_ENTRY)), v->offset);
        if (v->shared >= 0) {
            v->shared += ZOOM_ENTRY;
            const double *entry = (const double *)(base + v->shared);
            for (int k = 0; k < 4; k++)
                v->ref[k] = vd_set1(entry[k]);
        } else {
            for (int k = 0; k < 4; k++)
                v->ref[k] = vd_gather(v->ref[k], following, base + k * sizeof(double), v->offset);
        }
        for (int k = 0; k < 4; k++)
            z[k] = vd_select(v->direct, dn[k], vd_add(v->ref[k], dn[k]));
        /* Glitch: |Z + delta| < |delta|; rebase onto the critical orbit (entry 0: the critical
         * point 0), delta = z; the Julia dc (0 while following) becomes the critical orbit's 0. */
        const vd z2 = zoom_norm2(z), d2 = zoom_norm2(dn);
        const vdm leave = vdm_and(following, vd_ge(d2, vd_mul(vd_set1(UB_ZOOM_DIRECT_RATIO), vd_add(z2, v->c2))));
        if (vdm_bits(leave))
            zoom_go_direct(v, leave, z, dn);
        const vdm glitch = vdm_andnot(leave, vdm_and(following, vd_lt(z2, d2)));
        if (vdm_bits(glitch)) {
            const double crit = (double)offsetof(ub_zoom, crit);
            for (int k = 0; k < 4; k++) {
                dn[k] = vd_select(glitch, z[k], dn[k]);
                v->ref[k] = vd_select(glitch, vd_set1(zm->crit[0][k]), v->ref[k]);
                if (julia)
                    v->dc[k] = vd_select(glitch, vd_set1(0.0), v->dc[k]);
            }
            v->offset = vd_select(glitch, vd_set1(crit), v->offset);
            v->end = vd_select(glitch, vd_set1(crit + (double)zm->crit_length * ZOOM_ENTRY), v->end);
            v->rebases = vd_select(glitch, vd_add(v->rebases, vd_set1(1.0)), v->rebases);
            zoom_share(v);
        }
    } else {
        for (int k = 0; k < 4; k++)
            z[k] = dn[k];
    }
    const vd nr2 = zoom_norm2(z);
    if (jacobian) {
        /* The normal reads z_n of each lane at its escape: freeze it. */
        for (int k = 0; k < 4; k++) {
            v->z[k] = vd_select(act, z[k], v->z[k]);
            v->d[k] = vd_select(act, dn[k], v->d[k]);
        }
    } else {
        /* Nothing reads z or delta after the loop: escaped lanes iterate on (to inf or NaN,
         * harmless: every mask above is within the active lanes, their reference entry froze). */
        for (int k = 0; k < 4; k++) {
            v->z[k] = z[k];
            v->d[k] = dn[k];
        }
    }
    v->r2 = vd_select(act, nr2, v->r2);
    if (trap)
        v->trap = vd_select(act, vd_min(nr2, v->trap), v->trap); /* fmin(trap, nr2): a NaN nr2 leaves trap */
    v->n = vd_select(act, vd_add(v->n, vd_set1(1.0)), v->n);
    v->active = vdm_and(vdm_andnot(vd_gt(nr2, vd_set1(o->bailout * o->bailout)), act),
                        vd_lt(v->n, vd_set1((double)o->max_iterations)));
    /* Lanes that started at other entries may all have escaped now: broadcast again if so. */
    if (perturb && v->shared < 0 && vdm_bits(v->active) != vdm_bits(act))
        zoom_share(v);
}

/* One vector's lanes to their end; the state in locals (registers), not in the caller's array. */
static inline __attribute__((always_inline)) void zoom_iterate_vector(const ub_object *o, zoom_vector *out,
                                                                      const int julia, const int perturb,
                                                                      const int jacobian, const int trap)
{
    zoom_vector v = *out;
    while (vdm_bits(v.active))
        zoom_step(o, &v, julia, perturb, jacobian, trap);
    *out = v;
}

/* The kind, the path and the extras as constants: each combination its own loop. */
#define ZOOM_CASE(index)                                                                                      \
    case index:                                                                                               \
        for (int h = 0; h < ZOOM_VECTORS; h++)                                                                \
            zoom_iterate_vector(o, &v[h], (index) >> 3 & 1, (index) >> 2 & 1, (index) >> 1 & 1, (index) & 1); \
        break;
static void zoom_iterate_vectors(const ub_object *o, zoom_vector v[ZOOM_VECTORS], int julia, int perturb,
                                 int jacobian, int trap)
{
    switch (julia << 3 | perturb << 2 | jacobian << 1 | trap) {
        ZOOM_CASE(0) ZOOM_CASE(1) ZOOM_CASE(2) ZOOM_CASE(3) ZOOM_CASE(4) ZOOM_CASE(5) ZOOM_CASE(6) ZOOM_CASE(7)
        ZOOM_CASE(8) ZOOM_CASE(9) ZOOM_CASE(10) ZOOM_CASE(11) ZOOM_CASE(12) ZOOM_CASE(13) ZOOM_CASE(14) ZOOM_CASE(15)
    }
}
#undef ZOOM_CASE

/* Where the lanes' skip-table entries are: one entry for them all (a broadcast per coefficient; the
 * lanes of a vector mostly skip alike: 93 % of the vectors at zoom 30), else a gather. */
typedef struct {
    const char *base;  /* the table's first entry */
    const char *entry; /* the shared entry, or NULL */
    vdm lanes;
    vd at;             /* byte offsets of each lane's entry from base */
} skip_entry;

static inline __attribute__((always_inline)) skip_entry skip_entry_of(const ub_zoom *zm, vdm lanes, vd at)
{
    skip_entry e = {(const char *)zm->skip, NULL, lanes, vd_sub(at, vd_set1((double)offsetof(ub_zoom, skip)))};
    const int shared = shared_offset(e.at, vdm_bits(lanes));
    if (shared >= 0)
        e.entry = e.base + shared;
    return e;
}

/* The coefficient at `field` (a byte offset within an entry) of each lane's entry, `fallback` in the
 * lanes outside e->lanes where it is gathered (a broadcast fills every lane: the caller selects). */
static inline __attribute__((always_inline)) vd skip_coefficient(const skip_entry *e, size_t field, vd fallback)
{
    if (e->entry)
        return vd_set1(*(const double *)(e->entry + field));
    return vd_gather(fallback, e->lanes, e->base + field, e->at);
}

/* The start of ub_zoom_start for VD_LANES lanes: q, their quaternions B u (u local, float, the
 * lane's first at q[k][0]); bits, the lanes wanted. */
static void zoom_start(const ub_object *o, int path, int bits, const float *const q[4], const int want,
                       zoom_vector *v)
{
    const ub_zoom *zm = &o->zoom;
    const int julia = o->kind == UB_KIND_QUATERNION_JULIA, perturb = path == UB_ZOOM_PERTURBATION;
    const char *base = (const char *)zm;
    const double ref_at = (double)offsetof(ub_zoom, ref);
    const vd one = vd_set1(1.0), zero = vd_set1(0.0);
    vd offset[4];
    for (int k = 0; k < 4; k++) {
        double u[VD_LANES];
        for (int l = 0; l < VD_LANES; l++)
            u[l] = q[k][l];
        offset[k] = vd_mul(vd_set1(zm->scale), vd_load(u));
        v->z[k] = vd_add(vd_set1(zm->anchor_q[k]), offset[k]);
        const vd c = julia ? vd_set1(zm->mu[k]) : v->z[k]; /* the c of direct iteration */
        v->c_full[k] = c;
        v->d[k] = perturb ? offset[k] : v->z[k];
        v->dc[k] = perturb ? (julia ? zero : offset[k]) : c;
        v->ref[k] = zero;
        for (int a = 0; a < 3; a++)
            v->j[a][k] = vd_set1(o->slice_basis[k][a]);
    }
    v->direct = vdm_from_bits(perturb ? 0 : (1 << VD_LANES) - 1);
    v->offset = vd_set1(ref_at + (perturb && !julia ? ZOOM_ENTRY : 0));
    v->end = vd_set1(ref_at + (double)zm->ref_length * ZOOM_ENTRY);
    v->r2 = zoom_norm2(v->z);
    v->trap = v->r2;
    v->dr2 = v->dm = v->add_scale = one;
    v->n = v->rebases = zero;
    const vdm wanted = vdm_from_bits(bits);
    if (perturb && zm->skip_count > 0) {
        /* The largest skip whose radius holds delta_start (radii shrink with K): the scalar binary
         * search's answer, found from the table's lower bound for |delta_start|'s binary exponent
         * (skip_first) by steps up while the next radius still holds it: the same K. */
        const vd d0 = vd_sqrt(zoom_norm2(v->d));
        const double skip_at = (double)offsetof(ub_zoom, skip), skip_size = (double)sizeof zm->skip[0];
        const double radius_at = (double)offsetof(ub_zoom, skip[0].radius);
        const vd count = vd_set1((double)zm->skip_count);
        vd mantissa, exponent;
        vd_split_exponent(d0, &mantissa, &exponent); /* e + 1023 in [0, 2047] for any double */
        const vd bucket = vd_mul(vd_add(exponent, vd_set1(1023.0)), vd_set1((double)sizeof(double)));
        vd lo = vd_gather(zero, wanted, base + offsetof(ub_zoom, skip_first), bucket);
        for (vdm open = vdm_and(wanted, vd_lt(lo, count)); vdm_bits(open); open = vdm_and(open, vd_lt(lo, count))) {
            const vd next = vd_add(lo, one);
            const vd radius = vd_gather(zero, open, base, vd_add(vd_set1(radius_at), vd_mul(next, vd_set1(skip_size))));
            open = vdm_and(open, vd_ge(radius, d0));
            lo = vd_select(open, next, lo);
        }
        const vd K = lo;
        const vdm skip = vdm_and(vdm_and(wanted, vd_gt(K, zero)), vd_lt(K, vd_set1((double)o->max_iterations)));
        if (vdm_bits(skip)) {
            /* ub_zoom_start's series, the same operations in the same order. */
            const vd at = vd_add(vd_set1(skip_at), vd_mul(lo, vd_set1(skip_size)));
            const skip_entry entry = skip_entry_of(zm, skip, at);
            const size_t first = offsetof(ub_zoom, skip);
            const vd *x = v->d;
            vd m[4][4], pairs[UB_ZOOM_PAIRS], nd[4];
            for (int r = 0; r < 4; r++)
                for (int c = 0; c < 4; c++)
                    m[r][c] = skip_coefficient(&entry, offsetof(ub_zoom, skip[0].matrix[r][c]) - first, zero);
            for (int p = 0; p < UB_ZOOM_PAIRS; p++)
                pairs[p] = vd_mul(x[zoom_pair[p][0]], x[zoom_pair[p][1]]);
            for (int r = 0; r < 4; r++) {
                vd quad = zero;
                for (int p = 0; p < UB_ZOOM_PAIRS; p++)
                    quad = vd_add(quad, vd_mul(skip_coefficient(&entry, offsetof(ub_zoom, skip[0].quad[r][p]) - first, zero),
                                               pairs[p]));
                const vd linear = vd_add(vd_add(vd_add(vd_mul(m[r][0], x[0]), vd_mul(m[r][1], x[1])), vd_mul(m[r][2], x[2])),
                                         vd_mul(m[r][3], x[3]));
                nd[r] = vd_add(linear, quad);
            }
            vd slope[4];
            for (int c = 0; c < 4; c++)
                slope[c] = skip_coefficient(&entry, offsetof(ub_zoom, skip[0].dr2_slope[c]) - first, zero);
            const vd gx = vd_add(vd_add(vd_add(vd_mul(slope[0], x[0]), vd_mul(slope[1], x[1])), vd_mul(slope[2], x[2])),
                                 vd_mul(slope[3], x[3]));
            if (want & UB_WANT_JACOBIAN) /* the Jacobian follows the linear part (zoom.c) */
                for (int a = 0; a < 3; a++) {
                    vd *h = v->j[a], nj[4];
                    for (int r = 0; r < 4; r++)
                        nj[r] = vd_add(vd_add(vd_add(vd_mul(m[r][0], h[0]), vd_mul(m[r][1], h[1])), vd_mul(m[r][2], h[2])),
                                       vd_mul(m[r][3], h[3]));
                    for (int r = 0; r < 4; r++)
                        h[r] = vd_select(skip, nj[r], h[r]);
                }
            for (int r = 0; r < 4; r++)
                v->d[r] = vd_select(skip, nd[r], v->d[r]);
            v->n = vd_select(skip, K, v->n);
            v->offset = vd_select(skip, vd_add(v->offset, vd_mul(K, vd_set1(ZOOM_ENTRY))), v->offset);
            vd z[4];
            for (int k = 0; k < 4; k++)
                z[k] = vd_add(vd_gather(zero, skip, base + k * sizeof(double), v->offset), v->d[k]);
            for (int k = 0; k < 4; k++)
                v->z[k] = vd_select(skip, z[k], v->z[k]);
            v->r2 = vd_select(skip, zoom_norm2(z), v->r2);
            const vd bookkeeping = skip_coefficient(&entry, offsetof(ub_zoom, skip[0].dr2) - first, one);
            if (julia)
                v->dr2 = vd_select(skip, vd_mul(bookkeeping, vd_add(one, gx)), v->dr2);
            else
                v->dm = vd_select(skip, vd_add(bookkeeping, gx), v->dm);
            v->trap = vd_select(skip, skip_coefficient(&entry, offsetof(ub_zoom, skip[0].trap) - first, v->trap), v->trap);
        }
    }
    v->c2 = zoom_norm2(v->c_full);
    if (perturb) {
        const vdm leave = vdm_andnot(v->direct, vdm_and(wanted, vd_ge(zoom_norm2(v->d), vd_mul(vd_set1(UB_ZOOM_DIRECT_RATIO),
                                                                                                vd_add(zoom_norm2(v->z), v->c2)))));
        if (vdm_bits(leave))
            zoom_go_direct(v, leave, v->z, v->d);
    }
    v->active = vdm_and(wanted, vd_lt(v->n, vd_set1((double)o->max_iterations)));
    /* Z_index of the lanes that follow a reference (the others' is never read). */
    for (int k = 0; k < 4; k++)
        v->ref[k] = vd_gather(zero, vdm_andnot(v->direct, v->active), base + k * sizeof(double), v->offset);
    zoom_share(v);
}

/* ub_log (ubmath.h's ub__log_dd, then hi + lo) for finite x >= 2^-1022, every lane at once: the
 * same operations in the same order, so the same bits. */
static inline vd zoom_log(vd x)
{
    const vd one = vd_set1(1.0), two = vd_set1(2.0), splitter = vd_set1(134217729.0);
    vd m, kd;
    vd_split_exponent(x, &m, &kd);
    const vdm high = vd_gt(m, vd_set1(UB__SQRT2));
    m = vd_select(high, vd_mul(m, vd_set1(0.5)), m);
    kd = vd_select(high, vd_add(kd, one), kd);
    const vd f = vd_sub(m, one);
    const vd dh = vd_add(two, f), dl = vd_sub(f, vd_sub(dh, two)); /* fast two-sum */
    const vd sh = vd_div(f, dh);
    /* Dekker's product sh dh = p + pe */
    const vd p = vd_mul(sh, dh);
    vd t = vd_mul(splitter, sh);
    const vd ah = vd_sub(t, vd_sub(t, sh)), al = vd_sub(sh, ah);
    t = vd_mul(splitter, dh);
    const vd bh = vd_sub(t, vd_sub(t, dh)), bl = vd_sub(dh, bh);
    const vd pe = vd_add(vd_add(vd_add(vd_sub(vd_mul(ah, bh), p), vd_mul(ah, bl)), vd_mul(al, bh)), vd_mul(al, bl));
    const vd sl = vd_div(vd_sub(vd_sub(vd_sub(f, p), pe), vd_mul(sh, dl)), dh);
    const vd z = vd_mul(sh, sh);
    vd poly = vd_set1(ub__log_series[11]);
    for (int i = 10; i >= 0; i--)
        poly = vd_add(vd_mul(poly, z), vd_set1(ub__log_series[i]));
    const vd a = vd_mul(two, sh);
    const vd b = vd_add(vd_mul(two, sl), vd_add(vd_mul(vd_mul(sh, z), poly), vd_mul(vd_mul(two, z), sl)));
    const vd lmh = vd_add(a, b), lml = vd_sub(b, vd_sub(lmh, a));
    const vd c = vd_mul(kd, vd_set1(UB__LN2_HI));
    const vd h = vd_add(c, lmh), bb = vd_sub(h, c);
    const vd e = vd_add(vd_sub(c, vd_sub(h, bb)), vd_sub(lmh, bb)); /* two-sum */
    const vd rest = vd_add(vd_add(e, lml), vd_mul(kd, vd_set1(UB__LN2_LO)));
    const vd hi = vd_add(h, rest), lo = vd_sub(rest, vd_sub(hi, h));
    return vd_add(hi, lo);
}


/* ub_zoom_finish for VD_LANES lanes, into out's lanes from `first` on. */
static void zoom_finish(const ub_object *o, const zoom_vector *v, const int want, zoom_out *out, int first)
{
    const int julia = o->kind == UB_KIND_QUATERNION_JULIA;
    const vd zero = vd_set1(0.0);
    const vdm escaped = vd_gt(v->r2, vd_set1(o->bailout * o->bailout));
    /* Escaped lanes have r2 > bailout^2 >= 1: normal, or an infinity (ub_log(inf) = inf). */
    const vdm finite = vd_lt(v->r2, vd_set1(HUGE_VAL));
    const vd lr = vd_select(escaped, vd_select(finite, zoom_log(v->r2), v->r2), zero);
    const vd dr2 = julia ? v->dr2 : vd_mul(v->dm, v->dm);
    /* fractal units -> local units */
    const vd est = vd_div(vd_mul(vd_mul(vd_sqrt(vd_div(v->r2, dr2)), lr), vd_set1(0.25)), vd_set1(o->zoom.scale));
    vd_store(out->dist + first, vd_select(escaped, est, zero));
    vd_store(out->iterations + first, v->n);
    vd_store(out->rebases + first, v->rebases);
    if (want & UB_WANT_TRAP)
        vd_store(out->trap + first, vd_sqrt(v->trap));
    if (want & UB_WANT_POTENTIAL) {
        double g[VD_LANES], n[VD_LANES];
        vd_store(n, v->n);
        for (int l = 0; l < VD_LANES; l++)
            g[l] = ldexp(1.0, -(int)n[l]); /* 2^-n, exactly the scalar's halvings */
        vd_store(out->potential + first, vd_select(escaped, vd_mul(vd_mul(lr, vd_set1(0.5)), vd_load(g)), zero));
    }
    if (want & UB_WANT_JACOBIAN) {
        /* Only the direction is used: unit length, so float32 holds it. */
        vd g[3], len2 = zero;
        for (int a = 0; a < 3; a++) {
            const vd *h = v->j[a];
            g[a] = vd_add(vd_add(vd_add(vd_mul(v->z[0], h[0]), vd_mul(v->z[1], h[1])), vd_mul(v->z[2], h[2])),
                          vd_mul(v->z[3], h[3]));
            len2 = vd_add(len2, vd_mul(g[a], g[a]));
        }
        const vdm usable = vdm_and(vd_gt(len2, zero), vd_lt(len2, vd_set1(HUGE_VAL)));
        const vd inv = vd_select(usable, vd_div(vd_set1(1.0), vd_sqrt(len2)), zero);
        for (int a = 0; a < 3; a++)
            vd_store(out->normal[a] + first, vd_mul(g[a], inv));
    }
}

/* The zoomed estimate by `path` at the lanes `bits` of the packet of quaternions q (B u, u
 * local), with the extras of `want`, as ub_zoom_estimate's: out's lanes of `bits`. */
static void zoom_lanes(const ub_object *o, int path, int bits, const float q[4][UB_LANES], const int want,
                       zoom_out *out)
{
    zoom_vector v[ZOOM_VECTORS];
    const int lane_bits = (1 << VD_LANES) - 1;
    for (int h = 0; h < ZOOM_VECTORS; h++) {
        const float *const qh[4] = {q[0] + h * VD_LANES, q[1] + h * VD_LANES, q[2] + h * VD_LANES, q[3] + h * VD_LANES};
        zoom_start(o, path, (bits >> (h * VD_LANES)) & lane_bits, qh, want, &v[h]);
    }
    zoom_iterate_vectors(o, v, o->kind == UB_KIND_QUATERNION_JULIA, path == UB_ZOOM_PERTURBATION,
                         (want & UB_WANT_JACOBIAN) != 0, (want & UB_WANT_TRAP) != 0);
    for (int h = 0; h < ZOOM_VECTORS; h++)
        zoom_finish(o, &v[h], want, out, h * VD_LANES);
}
#endif /* VD_LANES */
