/* Deep zoom (issue 18), lane-parallel: the iterations of zoom.c's ub_zoom_iterate for all the
 * lanes of a packet at once, in the double vectors (vd, VD_LANES per vector) of the kernel's
 * simd_*.h; included by estimators.h, so compiled once per kernel. The start (z0, the reference,
 * the skip table's linear start) and the finish (the log, the estimate, the normal) stay zoom.c's
 * scalar code, once per lane and estimate against the 20 to 250 iterations in between.
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

#define ZOOM_VECTORS (UB_LANES / VD_LANES)
#define ZOOM_ENTRY ((int)sizeof(double[4])) /* bytes per reference entry */

/* VD_LANES lanes' state: ub_zoom_state's fields, one lane per vector element. */
typedef struct {
    vd z[4], d[4], dc[4], c_full[4];
    vd ref[4];             /* the reference entry Z_index the next step starts from */
    vd r2, dr2, dm, trap, gscale, add_scale, n, rebases;
    vd offset, end;        /* byte offsets in ub_zoom of Z_index and of its orbit's end */
    vd j[3][4];
    vdm active;            /* still iterating */
    vdm direct;            /* no reference (delta is z) */
    int shared;            /* >= 0: every active lane with a reference is at this offset */
} zoom_vector;

/* Whether the active lanes that follow a reference share one entry (then `shared` is its offset;
 * -1 when there is none, or they differ). */
static inline void zoom_share(zoom_vector *v)
{
    double offset[VD_LANES];
    vd_store(offset, v->offset);
    const int following = vdm_bits(vdm_andnot(v->direct, v->active));
    v->shared = -1;
    for (int l = 0; l < VD_LANES; l++) {
        if (!((following >> l) & 1))
            continue;
        if (v->shared < 0) {
            v->shared = (int)offset[l];
        } else if ((int)offset[l] != v->shared) {
            v->shared = -1;
            return;
        }
    }
}

static inline vd zoom_norm2(const vd x[4])
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
static inline void zoom_square(const vd d[4], vd out[4])
{
    const vd two = vd_set1(2.0);
    const vd p = d[0];
    out[0] = vd_sub(vd_mul(p, p), vd_add(vd_add(vd_mul(d[1], d[1]), vd_mul(d[2], d[2])), vd_mul(d[3], d[3])));
    for (int k = 1; k < 4; k++)
        out[k] = vd_mul(vd_mul(two, p), d[k]);
}

/* One iteration of the active lanes of v (ub_zoom_iterate's loop body). */
static inline __attribute__((always_inline)) void zoom_step(const ub_object *o, zoom_vector *v, const int julia,
                                                            const int perturb, const int jacobian)
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
            for (int k = 0; k < 4; k++) {
                v->d[k] = vd_select(ending, v->z[k], v->d[k]);
                v->dc[k] = vd_select(ending, v->c_full[k], v->dc[k]);
            }
            v->direct = vdm_or(v->direct, ending);
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
        const vdm glitch = vdm_and(following, vd_lt(zoom_norm2(z), zoom_norm2(dn)));
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
    for (int k = 0; k < 4; k++) {
        v->z[k] = vd_select(act, z[k], v->z[k]);
        v->d[k] = vd_select(act, dn[k], v->d[k]);
    }
    v->r2 = vd_select(act, nr2, v->r2);
    v->trap = vd_select(act, vd_min(nr2, v->trap), v->trap); /* fmin(trap, nr2): a NaN nr2 leaves trap */
    v->gscale = vd_select(act, vd_mul(v->gscale, vd_set1(0.5)), v->gscale);
    v->n = vd_select(act, vd_add(v->n, vd_set1(1.0)), v->n);
    v->active = vdm_and(vdm_andnot(vd_gt(nr2, vd_set1(o->bailout * o->bailout)), act),
                        vd_lt(v->n, vd_set1((double)o->max_iterations)));
    /* Lanes that started at other entries may all have escaped now: broadcast again if so. */
    if (perturb && v->shared < 0 && vdm_bits(v->active) != vdm_bits(act))
        zoom_share(v);
}

/* Every vector of the packet to its end, side by side (two independent chains of dependent
 * operations keep the pipelines fuller than one). */
static inline __attribute__((always_inline)) void zoom_iterate_vectors(const ub_object *o,
                                                                       zoom_vector v[ZOOM_VECTORS], const int julia,
                                                                       const int perturb, const int jacobian)
{
    for (;;) {
        int running = 0;
        for (int h = 0; h < ZOOM_VECTORS; h++) {
            if (!vdm_bits(v[h].active))
                continue;
            zoom_step(o, &v[h], julia, perturb, jacobian);
            running |= vdm_bits(v[h].active);
        }
        if (!running)
            return;
    }
}

/* ub_zoom_state <-> vectors: lane l of the packet is lane l % VD_LANES of vector l / VD_LANES. */
#define ZOOM_PACK(dst, field)                                                                              \
    do {                                                                                                   \
        double t_[VD_LANES];                                                                               \
        for (int l = 0; l < VD_LANES; l++)                                                                 \
            t_[l] = (double)(s[l].field);                                                                  \
        (dst) = vd_load(t_);                                                                               \
    } while (0)
#define ZOOM_UNPACK(field, src, type)                                                                      \
    do {                                                                                                   \
        double t_[VD_LANES];                                                                               \
        vd_store(t_, (src));                                                                               \
        for (int l = 0; l < VD_LANES; l++)                                                                 \
            s[l].field = (type)t_[l];                                                                      \
    } while (0)

/* s: VD_LANES lanes' states from ub_zoom_start (zeroed where not wanted); bits: the lanes wanted. */
static void zoom_pack(const ub_object *o, const ub_zoom_state *s, int bits, zoom_vector *v)
{
    double offset[VD_LANES], end[VD_LANES];
    for (int l = 0; l < VD_LANES; l++) {
        double orbit = (double)(s[l].on_crit ? offsetof(ub_zoom, crit) : offsetof(ub_zoom, ref));
        offset[l] = orbit + (double)s[l].index * ZOOM_ENTRY;
        end[l] = orbit + (double)s[l].length * ZOOM_ENTRY;
    }
    v->offset = vd_load(offset);
    v->end = vd_load(end);
    for (int k = 0; k < 4; k++) {
        ZOOM_PACK(v->z[k], z[k]);
        ZOOM_PACK(v->d[k], delta[k]);
        ZOOM_PACK(v->dc[k], dc[k]);
        ZOOM_PACK(v->c_full[k], c_full[k]);
        for (int a = 0; a < 3; a++)
            ZOOM_PACK(v->j[a][k], j[a][k]);
    }
    ZOOM_PACK(v->r2, r2);
    ZOOM_PACK(v->dr2, dr2);
    ZOOM_PACK(v->dm, dm);
    ZOOM_PACK(v->trap, trap);
    ZOOM_PACK(v->gscale, gscale);
    ZOOM_PACK(v->add_scale, add_scale);
    ZOOM_PACK(v->n, n);
    ZOOM_PACK(v->rebases, rebases);
    int direct = 0;
    for (int l = 0; l < VD_LANES; l++)
        direct |= (s[l].direct ? 1 : 0) << l;
    v->direct = vdm_from_bits(direct);
    v->active = vdm_and(vdm_from_bits(bits), vd_lt(v->n, vd_set1((double)o->max_iterations)));
    /* Z_index of the lanes that follow a reference (the others' is never read). */
    const char *base = (const char *)&o->zoom;
    for (int k = 0; k < 4; k++)
        v->ref[k] = vd_gather(vd_set1(0.0), vdm_andnot(v->direct, v->active), base + k * sizeof(double), v->offset);
    zoom_share(v);
}

/* What ub_zoom_finish reads. */
static void zoom_unpack(const zoom_vector *v, ub_zoom_state *s)
{
    for (int k = 0; k < 4; k++) {
        ZOOM_UNPACK(z[k], v->z[k], double);
        for (int a = 0; a < 3; a++)
            ZOOM_UNPACK(j[a][k], v->j[a][k], double);
    }
    ZOOM_UNPACK(r2, v->r2, double);
    ZOOM_UNPACK(dr2, v->dr2, double);
    ZOOM_UNPACK(dm, v->dm, double);
    ZOOM_UNPACK(trap, v->trap, double);
    ZOOM_UNPACK(gscale, v->gscale, double);
    ZOOM_UNPACK(n, v->n, int);
    ZOOM_UNPACK(rebases, v->rebases, int);
}

/* The zoomed estimate by `path` at the lanes `bits` of the packet of quaternions q (B u, u
 * local), with the extras of `want`: res[l] for those lanes, as ub_zoom_estimate's. */
static void zoom_lanes(const ub_object *o, int path, int bits, const float q[4][UB_LANES], const int want,
                       ub_zoom_result res[UB_LANES])
{
    ub_zoom_state s[UB_LANES];
    memset(s, 0, sizeof s);
    for (int l = 0; l < UB_LANES; l++)
        if ((bits >> l) & 1) {
            const double uq[4] = {q[0][l], q[1][l], q[2][l], q[3][l]};
            ub_zoom_start(o, path, uq, want, &s[l]);
        }
    zoom_vector v[ZOOM_VECTORS];
    const int lane_bits = (1 << VD_LANES) - 1;
    for (int h = 0; h < ZOOM_VECTORS; h++)
        zoom_pack(o, s + h * VD_LANES, (bits >> (h * VD_LANES)) & lane_bits, &v[h]);
    /* The kind, the path and the Jacobian as constants: each combination its own loop. */
    const int julia = o->kind == UB_KIND_QUATERNION_JULIA, perturb = path == UB_ZOOM_PERTURBATION;
    const int jacobian = (want & UB_WANT_JACOBIAN) != 0;
#define ZOOM_CASE(J, P, D)                                                                                 \
    if (julia == J && perturb == P && jacobian == D)                                                       \
    zoom_iterate_vectors(o, v, J, P, D)
    ZOOM_CASE(1, 1, 0);
    else ZOOM_CASE(1, 0, 0);
    else ZOOM_CASE(0, 1, 0);
    else ZOOM_CASE(0, 0, 0);
    else ZOOM_CASE(1, 1, 1);
    else ZOOM_CASE(1, 0, 1);
    else ZOOM_CASE(0, 1, 1);
    else ZOOM_CASE(0, 0, 1);
#undef ZOOM_CASE
    for (int h = 0; h < ZOOM_VECTORS; h++)
        zoom_unpack(&v[h], s + h * VD_LANES);
    for (int l = 0; l < UB_LANES; l++)
        if ((bits >> l) & 1)
            ub_zoom_finish(o, &s[l], want, &res[l]);
}
