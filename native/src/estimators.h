/* Distance estimators and densities of the quaternion Julia sets (sections 3 and 4.1), written
 * against the vf/vm vector interface; included by kernel.h, compiled once per SIMD flavour. */

/* Natural logarithm of positive normal floats (Cephes' logf polynomial, ~1 ulp). Our own,
 * built only from the interface's correctly rounded operations, so both kernels agree. */
static inline vf UB_FN(v_log)(vf x)
{
    vf m, e;
    v_frexp_centered(x, &m, &e);
    vf f = v_sub(m, v_set1(1.0f));
    vf z = v_mul(f, f);
    vf y = v_set1(7.0376836292E-2f);
    y = v_fma(y, f, v_set1(-1.1514610310E-1f));
    y = v_fma(y, f, v_set1(1.1676998740E-1f));
    y = v_fma(y, f, v_set1(-1.2420140846E-1f));
    y = v_fma(y, f, v_set1(1.4249322787E-1f));
    y = v_fma(y, f, v_set1(-1.6668057665E-1f));
    y = v_fma(y, f, v_set1(2.0000714765E-1f));
    y = v_fma(y, f, v_set1(-2.4999993993E-1f));
    y = v_fma(y, f, v_set1(3.3333331174E-1f));
    y = v_mul(v_mul(y, f), z);
    y = v_fma(e, v_set1(-2.12194440e-4f), y);
    y = v_fma(z, v_set1(-0.5f), y);
    vf r = v_add(f, y);
    return v_fma(e, v_set1(0.693359375f), r);
}

/* Constants of one fractal object in kernel precision, derived once per tile. */
typedef struct {
    vf mu[4];
    vf bail2;
    int max_iterations;
    /* Hit threshold in world units at ray distance t: eps0 + eps1 * t (fixed mode: eps1 = 0). */
    vf eps0, eps1;
} UB_FN(ub_de_params);

static inline void UB_FN(de_params)(const ub_object *o, const ub_camera *cam, UB_FN(ub_de_params) *p)
{
    for (int i = 0; i < 4; i++)
        p->mu[i] = v_set1((float)o->mu[i]);
    p->bail2 = v_set1((float)(o->bailout * o->bailout));
    p->max_iterations = o->max_iterations;
    int fixed = o->epsilon_mode == UB_EPSILON_FIXED;
    if (!cam && !fixed) { /* estimate(): no camera, no threshold needed */
        p->eps0 = p->eps1 = v_set1(0.0f);
        return;
    }
    p->eps0 = v_set1((float)(fixed ? o->epsilon * o->sigma_min : cam->footprint0 / o->detail));
    p->eps1 = v_set1((float)(fixed ? 0.0 : cam->footprint1 / o->detail));
}

/* What de_ext() computes besides the distance estimate. The flags are compile-time constants at
 * every call site, so each use inlines into a loop with only the work it asks for. */
enum { UB_WANT_TRAP = 1, UB_WANT_POTENTIAL = 2, UB_WANT_JACOBIAN = 4 };

typedef struct {
    vf trap;       /* min |z_k| over the orbit, k = 0..n */
    vf potential;  /* G = log|z_n| / 2^n (0 where the orbit does not escape) */
    vf normal[3];  /* object-space gradient of |z_n|^2: z_n . dz_n/dx_axis (unnormalised) */
} UB_FN(ub_de_extra);

/* The same iteration as de(), with the orbit trap, the potential G() of section 4.1.2 and the
 * Jacobian of f^n along the three slice axes. d(z q)/dx = z dq + dq z for f = z^2, and for
 * z = (a, v), h = (p, w): zh + hz = (2(ap - v.w), 2(aw + pv)) (the cross products cancel). */
static inline void UB_FN(de_ext)(const UB_FN(ub_de_params) *p, const ub_object *o, vf a, vf b, vf c, vf d,
                                 const int want, vf *dist, vf *iters, UB_FN(ub_de_extra) *x)
{
    vf r2 = v_fma(a, a, v_fma(b, b, v_fma(c, c, v_mul(d, d))));
    vf dr2 = v_set1(1.0f);
    vf n = v_set1(0.0f);
    vf trap = r2, gscale = v_set1(1.0f);
    vf j[3][4];
    if (want & UB_WANT_JACOBIAN)
        for (int k = 0; k < 3; k++)
            for (int c4 = 0; c4 < 4; c4++)
                j[k][c4] = v_set1((float)o->slice_basis[c4][k]);
    vm active = m_from_bits(0xff);
    const vf four = v_set1(4.0f), two = v_set1(2.0f), half = v_set1(0.5f);
    for (int it = 0; it < p->max_iterations; it++) {
        if (want & UB_WANT_JACOBIAN) {
            vf big = v_set1(0.0f);
            for (int k = 0; k < 3; k++) {
                vf p0 = j[k][0], p1 = j[k][1], p2 = j[k][2], p3 = j[k][3];
                vf vw = v_fma(b, p1, v_fma(c, p2, v_mul(d, p3)));
                vf n0 = v_mul(two, v_fms(a, p0, vw));
                vf n1 = v_mul(two, v_fma(a, p1, v_mul(p0, b)));
                vf n2 = v_mul(two, v_fma(a, p2, v_mul(p0, c)));
                vf n3 = v_mul(two, v_fma(a, p3, v_mul(p0, d)));
                j[k][0] = v_select(active, n0, p0);
                j[k][1] = v_select(active, n1, p1);
                j[k][2] = v_select(active, n2, p2);
                j[k][3] = v_select(active, n3, p3);
                big = v_max(big, v_fma(n0, n0, v_fma(n1, n1, v_fma(n2, n2, v_mul(n3, n3)))));
            }
            /* Only the direction matters: rescale before the derivatives overflow. */
            vm huge = v_gt(big, v_set1(1e30f));
            if (m_bits(huge)) {
                vf s = v_select(huge, v_set1(1e-15f), v_set1(1.0f));
                for (int k = 0; k < 3; k++)
                    for (int c4 = 0; c4 < 4; c4++)
                        j[k][c4] = v_mul(j[k][c4], s);
            }
        }
        vf a2 = v_add(a, a);
        vf na = v_sub(v_fma(a, a, p->mu[0]), v_fma(b, b, v_fma(c, c, v_mul(d, d))));
        vf nb = v_fma(a2, b, p->mu[1]);
        vf nc = v_fma(a2, c, p->mu[2]);
        vf nd = v_fma(a2, d, p->mu[3]);
        vf ndr2 = v_mul(dr2, v_mul(four, r2));
        vf nr2 = v_fma(na, na, v_fma(nb, nb, v_fma(nc, nc, v_mul(nd, nd))));
        a = v_select(active, na, a);
        b = v_select(active, nb, b);
        c = v_select(active, nc, c);
        d = v_select(active, nd, d);
        dr2 = v_select(active, ndr2, dr2);
        r2 = v_select(active, nr2, r2);
        if (want & UB_WANT_TRAP)
            trap = v_select(active, v_min(trap, nr2), trap);
        if (want & UB_WANT_POTENTIAL)
            gscale = v_select(active, v_mul(gscale, half), gscale);
        n = v_count(n, active);
        active = m_andnot(v_gt(nr2, p->bail2), active);
        if (!m_bits(active))
            break;
    }
    /* A lane's r2 froze at its escape, the only way past the bailout (max_iterations >= 1). */
    vm escaped = v_gt(r2, p->bail2);
    vf lr2 = UB_FN(v_log)(r2);
    vf est = v_mul(v_mul(v_sqrt(v_div(r2, dr2)), lr2), v_set1(0.25f));
    *dist = v_select(escaped, est, v_set1(0.0f));
    *iters = n;
    if (want & UB_WANT_TRAP)
        x->trap = v_sqrt(trap);
    if (want & UB_WANT_POTENTIAL) /* log|z| = log(r2) / 2 */
        x->potential = v_select(escaped, v_mul(v_mul(lr2, half), gscale), v_set1(0.0f));
    if (want & UB_WANT_JACOBIAN)
        for (int k = 0; k < 3; k++)
            x->normal[k] = v_fma(a, j[k][0], v_fma(b, j[k][1], v_fma(c, j[k][2], v_mul(d, j[k][3]))));
}

/* Distance estimate of section 3 at quaternion points q:
 *   d(z) = |f^n(z)| log|f^n(z)| / (2 |f^n'(z)|)
 * with f(z) = z^2 + mu iterated until |z| exceeds the escape radius or max_iterations is
 * reached. The running derivative obeys |f'| <- 2 |z| |f'| (|zh + hz| <= 2|z||h| in the
 * quaternions); we carry its square, 4 |z|^2 |f'|^2, to avoid a square root per iteration.
 * Points that never escape are in K_mu as far as we can tell: their estimate is 0 (a hit).
 * Writes the estimate (object units) and the escape count. */
static inline void UB_FN(de)(const UB_FN(ub_de_params) *p, vf a, vf b, vf c, vf d, vf *dist, vf *iters)
{
    /* want = 0: the compiler inlines de_ext down to the bare iteration (the marcher's hot loop). */
    UB_FN(ub_de_extra) unused;
    UB_FN(de_ext)(p, NULL, a, b, c, d, 0, dist, iters, &unused);
}

/* Object-space point -> quaternion on the object's slice, in double then rounded. */
static inline void UB_FN(to_quaternion)(const ub_object *o, const double p[3], float q[4])
{
    for (int k = 0; k < 4; k++) {
        const double *b = o->slice_basis[k];
        q[k] = (float)(o->slice_origin[k] + b[0] * p[0] + b[1] * p[1] + b[2] * p[2]);
    }
}

static inline void UB_FN(world_to_object_point)(const ub_object *o, const double p[3], double out[3])
{
    for (int i = 0; i < 3; i++) {
        const double *w = o->world_to_object[i];
        out[i] = w[0] * p[0] + w[1] * p[1] + w[2] * p[2] + w[3];
    }
}

/* A packet of world points -> the object's quaternions, one per lane. */
static inline void UB_FN(quaternion_lanes)(const ub_object *o, const double p[3][UB_LANES], vf q[4])
{
    float qs[4][UB_LANES];
    for (int l = 0; l < UB_LANES; l++) {
        double wp[3] = {p[0][l], p[1][l], p[2][l]}, op[3];
        float ql[4];
        UB_FN(world_to_object_point)(o, wp, op);
        UB_FN(to_quaternion)(o, op, ql);
        for (int c = 0; c < 4; c++)
            qs[c][l] = ql[c];
    }
    for (int c = 0; c < 4; c++)
        q[c] = v_load(qs[c]);
}

/* Object-space normal at quaternion points q (lanes in `lanes`), by the object's method:
 * eq. 15's central differences of d() or G() with the step h (object units), or the analytic
 * gradient. A degenerate gradient (all samples inside the set, or G flat) falls back to the
 * analytic normal, and that to zero (the caller then faces the normal to the viewer). */
static void UB_FN(object_normal)(const ub_object *o, const UB_FN(ub_de_params) *dp, const vf q[4], vf h, int method,
                                 vf g[3])
{
    vf dist, it;
    UB_FN(ub_de_extra) x;
    vm good = m_false(); /* lanes with a usable gradient */
    if (method != UB_NORMAL_ANALYTIC) {
        const int potential = method == UB_NORMAL_GRADIENT_POTENTIAL;
        for (int axis = 0; axis < 3; axis++) {
            vf off[4], v[2];
            for (int k = 0; k < 4; k++)
                off[k] = v_mul(h, v_set1((float)o->slice_basis[k][axis]));
            for (int side = 0; side < 2; side++) {
                vf sg = v_set1(side ? -1.0f : 1.0f);
                vf a = v_fma(sg, off[0], q[0]), b = v_fma(sg, off[1], q[1]), c = v_fma(sg, off[2], q[2]),
                   d = v_fma(sg, off[3], q[3]);
                if (potential) {
                    UB_FN(de_ext)(dp, o, a, b, c, d, UB_WANT_POTENTIAL, &dist, &it, &x);
                    v[side] = x.potential;
                } else {
                    UB_FN(de)(dp, a, b, c, d, &v[side], &it);
                }
            }
            g[axis] = v_sub(v[0], v[1]);
        }
        good = v_gt(v_fma(g[0], g[0], v_fma(g[1], g[1], v_mul(g[2], g[2]))), v_set1(0.0f));
    }
    if (m_bits(good) == 0xff)
        return;
    UB_FN(de_ext)(dp, o, q[0], q[1], q[2], q[3], UB_WANT_JACOBIAN, &dist, &it, &x);
    for (int k = 0; k < 3; k++)
        g[k] = method == UB_NORMAL_ANALYTIC ? x.normal[k] : v_select(good, g[k], x.normal[k]);
}
