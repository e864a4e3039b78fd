/* Distance estimators and densities of the quaternion Julia sets (sections 3 and 4.1), written
 * against the vf/vm vector interface; included by kernel.h, compiled once per SIMD flavour. */

#ifdef VD_LANES
/* The lanes h .. h + VD_LANES - 1 of a packet's bit word, as the mask of a double vector. */
static inline vdm vdm_lanes_at(int lanes, int h)
{
    return vdm_from_bits((lanes >> h) & ((1 << VD_LANES) - 1));
}

/* The sums of the lane loops' expressions, in their order, in double vectors (object_rays, the
 * cones' object_clearance, quaternion_lanes): row . p as (row0 p0 + row1 p1) + row2 p2, and offset + row . p as
 * ((offset + row0 p0) + row1 p1) + row2 p2. */
static inline vd vd_row_dot(const double row[3], const vd p[3])
{
    return vd_add(vd_add(vd_mul(vd_set1(row[0]), p[0]), vd_mul(vd_set1(row[1]), p[1])), vd_mul(vd_set1(row[2]), p[2]));
}

static inline vd vd_offset_dot(double offset, const double row[3], const vd p[3])
{
    return vd_add(vd_add(vd_add(vd_set1(offset), vd_mul(vd_set1(row[0]), p[0])), vd_mul(vd_set1(row[1]), p[1])),
                  vd_mul(vd_set1(row[2]), p[2]));
}
#endif

/* Natural logarithm of positive normal floats, within 1.8 ulp (1.71 the most measured, just below
 * the interval around 1; 1.09 for the escape estimate's x > 16), from a 16-entry table (the layout
 * of glibc's logf): x = 2^k z with z in [0.699, 1.398) cut into 16 intervals by its top mantissa
 * bits; interval i holds invc_i = 1/c_i rounded to float (c_i its midpoint) and logc_i =
 * -log(invc_i) rounded to float, so that log x = k log 2 + logc_i + log1p(r), r = z invc_i - 1,
 * |r| < 0.032 (one fma: r is z invc_i - 1 rounded once). The interval around 1 has invc = 1,
 * logc = 0: there r = z - 1 exactly and log x keeps its relative accuracy near 1. log1p(r) to
 * degree 5 (the next term, r^6 / 6, is below 2^-27 of r). The tables are constants, written in
 * hexadecimal, not computed at start-up: a platform's libm log could round them differently. Our
 * own, built from the interface's exact integer steps and correctly rounded float operations, so
 * every kernel agrees. Issue 21: the march's step waits on this logarithm (the escape estimate);
 * against Cephes' polynomial of degree 8 (26 vector operations) it is 18, with a shorter chain:
 * the peer render 1.05x faster with AVX-512, 1.02x with AVX2. */
static const float ub_log_invc[16] = {
    0x1.661ec6p+0f, 0x1.571ed4p+0f, 0x1.49539ep+0f, 0x1.3c995ap+0f, 0x1.30d19p+0f, 0x1.25e228p+0f,
    0x1.1bb4a4p+0f, 0x1.12358ep+0f, 0x1.0953f4p+0f, 0x1p+0f, 0x1.e573acp-1f, 0x1.ca4b3p-1f, 0x1.b20364p-1f,
    0x1.9c2d14p-1f, 0x1.886e6p-1f, 0x1.767dcep-1f};
static const float ub_log_logc[16] = {
    -0x1.57bf74p-2f, -0x1.2bef08p-2f, -0x1.01eae4p-2f, -0x1.b31d84p-3f, -0x1.6574ecp-3f, -0x1.1aa2bep-3f,
    -0x1.a4e764p-4f, -0x1.1973b6p-4f, -0x1.252f4p-5f, 0x0p+0f, 0x1.b42dep-5f, 0x1.c5e54cp-4f, 0x1.526e5ep-3f,
    0x1.bc286cp-3f, 0x1.1058bep-2f, 0x1.40430ap-2f};

/* The tables divided by 8 (exactly: the exponents 3 lower), for v_log_quarter_eighth. */
static const float ub_log_invc_eighth[16] = {
    0x1.661ec6p-3f, 0x1.571ed4p-3f, 0x1.49539ep-3f, 0x1.3c995ap-3f, 0x1.30d19p-3f, 0x1.25e228p-3f,
    0x1.1bb4a4p-3f, 0x1.12358ep-3f, 0x1.0953f4p-3f, 0x1p-3f, 0x1.e573acp-4f, 0x1.ca4b3p-4f,
    0x1.b20364p-4f, 0x1.9c2d14p-4f, 0x1.886e6p-4f, 0x1.767dcep-4f};
static const float ub_log_logc_eighth[16] = {
    -0x1.57bf74p-5f, -0x1.2bef08p-5f, -0x1.01eae4p-5f, -0x1.b31d84p-6f, -0x1.6574ecp-6f,
    -0x1.1aa2bep-6f, -0x1.a4e764p-7f, -0x1.1973b6p-7f, -0x1.252f4p-8f, 0x0p+0f, 0x1.b42dep-8f,
    0x1.c5e54cp-7f, 0x1.526e5ep-6f, 0x1.bc286cp-6f, 0x1.1058bep-5f, 0x1.40430ap-5f};

/* v_log's polynomial, from the reduction of x (v_log_reduce) and the exponent k it takes, times
 * `scale`, a power of 2 known when compiled (1, or 1/8 for v_log_quarter_eighth), with tables
 * invc and logc scaled by it. Every constant is scaled by a power of 2, so each rounding scales
 * with it and the result is exactly scale times the unscaled one (normal floats: |r| >= 2^-47
 * where it is not 0): r' = r scale, r'^2 = r^2 scale^2, and
 *   q scale = r' + r'^2 (p23 / scale + r'^2 p45 / scale^3),  p23 = -1/2 + r/3,  p45 = -1/4 + r/5,
 * the scaled terms each one fma of r'. With scale 1 these are the plain constants. */
static inline __attribute__((always_inline)) vf v_log_from(vf z, vf k, vf invc, vf logc, const float scale)
{
    vf r = v_fma(z, invc, v_set1(-1.0f * scale));
    vf r2 = v_mul(r, r);
    /* log1p(r) = r + r^2 ((-1/2 + r/3) + r^2 (-1/4 + r/5)) */
    vf p23 = v_fma(v_set1(1.0f / 3.0f / (scale * scale)), r, v_set1(-0.5f / scale));
    vf p45 = v_fma(v_set1(0.2f / (scale * scale * scale * scale)), r, v_set1(-0.25f / (scale * scale * scale)));
    vf q = v_fma(v_fma(p45, r2, p23), r2, r);
    return v_add(v_fma(k, v_set1(0.693147180559945f * scale), logc), q);
}

static inline vf v_log(vf x)
{
    vf z, k, invc, logc;
    v_log_reduce(x, ub_log_invc, ub_log_logc, &z, &k, &invc, &logc);
    return v_log_from(z, k, invc, logc, 1.0f);
}

/* v_log(x / 4) for x / 4 normal, with its bits: x / 4 has x's mantissa and an exponent 2 lower,
 * so the reduction takes k - 2 instead of a multiplication ahead of the logarithm's chain. */
static inline vf v_log_quarter(vf x)
{
    vf z, k, invc, logc;
    v_log_reduce(x, ub_log_invc, ub_log_logc, &z, &k, &invc, &logc);
    return v_log_from(z, v_sub(k, v_set1(2.0f)), invc, logc, 1.0f);
}

/* v_log_quarter(x) / 8, with its bits divided by 8 exactly (v_log_from's scale): issue 21, the
 * escape estimate's factor 1/8 folded in, one operation fewer in each step's tail. */
static inline vf v_log_quarter_eighth(vf x)
{
    vf z, k, invc, logc;
    v_log_reduce(x, ub_log_invc_eighth, ub_log_logc_eighth, &z, &k, &invc, &logc);
    return v_log_from(z, v_sub(k, v_set1(2.0f)), invc, logc, 0.125f);
}

/* The quaternion iteration in four numbers (issue 21). For z = (a, v), z^2 + mu = (a^2 - |v|^2 +
 * mu_0, 2a v + mu_v), so with t = 2a, |v|^2 and s = 2 v.mu_v
 *   a' = (a^2 + mu_0) - |v|^2,   |v'|^2 = t (t |v|^2 + s) + |mu_v|^2,   s' = t s + 2 |mu_v|^2:
 * the orbit's |z|^2 follows from a, |v|^2 and s alone, without b, c and d (their loop-carried
 * path was five dependent operations an iteration; now about two). Exact in real arithmetic; in
 * float32 |v'|^2 rounds differently from b^2 + c^2 + d^2 of the rounded b, c, d (2026-12-05, and
 * in Horner's form 2026-12-06: the float64 references' tests hold, the peer frame gains or loses
 * no hit). The numbers are carried scaled by powers of 2, which is exact: t = 2a itself (the
 * factor 2 of 2a v is where the orbit keeps it), 2|v|^2 and 2s, and the step yields 4|z'|^2,
 * the factor by which the running derivative |f'|^2 grows (4 |z|^2 |f'|^2). Each number is a
 * power of 2 times what the unscaled iteration rounds to, in the same order (4 (a^2 + mu_0) as
 * fma(t, t, 4 mu_0), 2a' = (4 (a^2 + mu_0)) / 2 - 2|v|^2 in one rounding), so every estimate
 * keeps its bits and the bailout test 4|z|^2 > 4 bailout^2 decides as |z|^2 > bailout^2. An
 * iteration takes 11 vector operations, where carrying a and |v|^2 took 12 (2a, and 4|z|^2 for
 * the derivative), and the start of an orbit two more: the render is bound by the vector ports'
 * throughput (2026-12-06: the peer render 1.019-1.024x with AVX-512, 1.005x with AVX2, the same
 * bits; 1.010x while each call derived the constants). */
typedef struct {
    vf t, v2x2, s2; /* 2a, 2|v|^2, 2s = 4 v.mu_v */
} doubled_orbit;

/* The doubled orbit's constants for mu (a Julia set's, derived once a tile in de_params; a
 * Mandelbrot slice's mu is the point): 4 mu_0, 2|mu_v|^2, 4|mu_v|^2, 4 mu_v (for 2s at the start)
 * and 4 bailout^2. */
typedef struct {
    vf mu0x4, m2x2, m2x4, mu_v4[3], bail2x4;
} doubled_constants;

static inline doubled_constants doubled_constants_of(const vf mu[4], vf bail2)
{
    const vf four = v_set1(4.0f);
    const vf m2 = v_fma(mu[1], mu[1], v_fma(mu[2], mu[2], v_mul(mu[3], mu[3])));
    const vf m2x2 = v_add(m2, m2);
    return (doubled_constants){v_mul(mu[0], four), m2x2, v_add(m2x2, m2x2),
                               {v_mul(mu[1], four), v_mul(mu[2], four), v_mul(mu[3], four)}, v_mul(bail2, four)};
}

/* Constants of one fractal object in kernel precision, derived once per tile. */
typedef struct {
    const ub_object *obj;
    vf mu[4];
    vf bail2;
    doubled_constants orbit; /* the Julia set's, of mu and bail2 */
    int max_iterations;
    /* Hit threshold in world units at ray distance t: eps0 + eps1 * t (fixed mode: eps1 = 0). */
    vf eps0, eps1;
    /* The render's cancel flag (NULL outside renders): estimators whose one call can be long (the
     * IFS search) poll it and cut their work short, still returning a lower bound. */
    volatile int *cancel;
    /* Deep zoom: the precision path of a zoomed quaternion object (zoom.h); UB_ZOOM_OFF else. */
    int zoom_path;
} ub_de_params;

/* The hit threshold in object units that picks a zoomed object's precision path: the fixed
 * epsilon, or the pixel footprint at the camera's distance from the object's origin (a lower
 * bound of it: the smaller threshold asks for the safer path). */
static inline double zoom_threshold(const ub_object *o, const ub_camera *cam)
{
    if (!cam || o->epsilon_mode == UB_EPSILON_FIXED)
        return o->epsilon;
    double r2 = 0.0;
    for (int i = 0; i < 3; i++) {
        const double *w = o->world_to_object[i];
        double c = w[0] * cam->position[0] + w[1] * cam->position[1] + w[2] * cam->position[2] + w[3];
        r2 += c * c;
    }
    double t = sqrt(r2) * o->sigma_min;
    return (cam->footprint0 + cam->footprint1 * t) / o->detail / o->sigma_max;
}

static inline void de_params(const ub_object *o, const ub_camera *cam, ub_de_params *p)
{
    p->obj = o;
    for (int i = 0; i < 4; i++)
        p->mu[i] = v_set1((float)o->mu[i]);
    p->bail2 = v_set1((float)(o->bailout * o->bailout));
    p->orbit = doubled_constants_of(p->mu, p->bail2);
    p->max_iterations = o->max_iterations;
    p->cancel = NULL;
    p->zoom_path = o->zoom.enabled ? (int)ub_zoom_choose_path(o, zoom_threshold(o, cam)) : UB_ZOOM_OFF;
    int fixed = o->epsilon_mode == UB_EPSILON_FIXED;
    if (!cam && !fixed) { /* estimate(): no camera, no threshold needed */
        p->eps0 = p->eps1 = v_set1(0.0f);
        return;
    }
    p->eps0 = v_set1((float)(fixed ? o->epsilon * o->sigma_min : cam->footprint0 / o->detail));
    p->eps1 = v_set1((float)(fixed ? 0.0 : cam->footprint1 / o->detail));
}

/* What de_ext() computes besides the distance estimate: UB_WANT_* (scene.h). The flags are
 * compile-time constants at every call site, so each use inlines into a loop with only the work
 * it asks for. */

typedef struct {
    vf trap;       /* min |z_k| over the orbit, k = 0..n */
    vf potential;  /* G = log|z_n| / 2^n (0 where the orbit does not escape) */
    vf normal[3];  /* object-space gradient of |z_n|^2: z_n . dz_n/dx_axis (unnormalised) */
} ub_de_extra;

/* The bookkeeping every escape-time iteration shares, after computing the next |z|^2 (nr2):
 * lanes still iterating take it, the orbit trap and the potential's scale follow (gstep: 1 /
 * degree), the escape count grows, and lanes with nr2 past bail2 stop (the escape radius squared;
 * the doubled orbit passes 4|z|^2 and 4 bailout^2). Returns the lanes still iterating. */
static inline vm orbit_step_within(vf bail2, const int want, vm active, vf nr2, vf *r2, vf *n, vf *trap,
                                   vf *gscale, vf gstep)
{
    *r2 = v_select(active, nr2, *r2);
    if (want & UB_WANT_TRAP)
        *trap = v_select(active, v_min(*trap, nr2), *trap);
    if (want & UB_WANT_POTENTIAL)
        *gscale = v_select(active, v_mul(*gscale, gstep), *gscale);
    *n = v_count(*n, active);
    return m_andnot_gt(nr2, bail2, active);
}

/* orbit_step_within with the object's escape radius. */
static inline vm orbit_step(const ub_de_params *p, const int want, vm active, vf nr2, vf *r2, vf *n,
                                   vf *trap, vf *gscale, vf gstep)
{
    return orbit_step_within(p->bail2, want, active, nr2, r2, n, trap, gscale, gstep);
}

/* The doubled orbit at z = (a, b, c, d), and its 4|z|^2. 2s = 4 (b mu_1 + c mu_2 + d mu_3) from
 * 4 mu_v, and 4|z|^2 = (2a)^2 + 2 (2|v|^2): each a power of 2 times the unscaled sums. */
static inline doubled_orbit doubled_start(const vf z[4], const doubled_constants *k, vf *r2x4)
{
    const vf t = v_add(z[0], z[0]), v2 = v_fma(z[1], z[1], v_fma(z[2], z[2], v_mul(z[3], z[3])));
    const vf v2x2 = v_add(v2, v2);
    *r2x4 = v_fma(t, t, v_add(v2x2, v2x2));
    return (doubled_orbit){t, v2x2, v_fma(z[1], k->mu_v4[0], v_fma(z[2], k->mu_v4[1], v_mul(z[3], k->mu_v4[2])))};
}

/* One iteration of the doubled orbit; returns the next 4|z|^2. 2|v'|^2 in Horner's form: one
 * operation fewer than t^2 |v|^2 + (t s + |mu_v|^2), the same depth of the chain from t. */
static inline __attribute__((always_inline)) vf doubled_step(doubled_orbit *w, const doubled_constants *k)
{
    const vf t = w->t;
    w->t = v_fms(v_fma(t, t, k->mu0x4), v_set1(0.5f), w->v2x2);
    w->v2x2 = v_fma(t, v_fma(t, w->v2x2, w->s2), k->m2x2);
    w->s2 = v_fma(t, w->s2, k->m2x4);
    return v_fma(w->t, w->t, v_add(w->v2x2, w->v2x2));
}

/* The escape-time distance estimate |z| log|z| / (2 |grad|) from r2 = |z|^2, its logarithm lr2 and
 * grad2 = |grad|^2: sqrt(r2 / grad2) lr2 / 4. */
static inline vf escape_estimate(vf r2, vf lr2, vf grad2)
{
    return v_mul(v_mul(v_sqrt(v_div(r2, grad2)), lr2), v_set1(0.25f));
}

/* escape_estimate from the doubled orbit's 4|z|^2 (doubled_step): sqrt(4 r2 / grad2) is exactly
 * twice sqrt(r2 / grad2), so the result has escape_estimate's bits. */
static inline vf doubled_escape_estimate(vf r2x4, vf lr2, vf grad2)
{
    return v_mul(v_mul(v_sqrt(v_div(r2x4, grad2)), lr2), v_set1(0.125f));
}

/* The quaternion iteration of section 3, for the Julia sets (z0 = the point, mu fixed) and,
 * with `mandel`, the Mandelbrot slices (z0 = mu = the point: the orbit from z1 = mu of the
 * critical point 0). Besides the distance estimate it yields the orbit trap, the potential G()
 * of section 4.1.2 and the Jacobian of f^n along the three slice axes. d(z q)/dx = z dq + dq z
 * for f = z^2 (plus dmu/dx for Mandelbrot), and for z = (a, v), h = (p, w):
 * zh + hz = (2(ap - v.w), 2(aw + pv)) (the cross products cancel). */
static inline __attribute__((always_inline)) void de_quaternion_body(const ub_de_params *p, vm lanes,
        const int mandel, vf a, vf b, vf c, vf d, const int want, vf *dist, vf *iters, ub_de_extra *x)
{
    const ub_object *o = p->obj;
    const vf mu[4] = {mandel ? a : p->mu[0], mandel ? b : p->mu[1], mandel ? c : p->mu[2], mandel ? d : p->mu[3]};
    /* The orbit doubled (doubled_step): 2a, 2|v|^2, 4 v.mu_v, and r2 = 4|z|^2, the trap too. */
    vf r2;
    const doubled_constants k4 = mandel ? doubled_constants_of(mu, p->bail2) : p->orbit;
    doubled_orbit w = doubled_start((const vf[4]){a, b, c, d}, &k4, &r2);
    /* Julia: |f^n'|^2 by |f'|^2 <- 4|z|^2 |f'|^2 (squared, no root per iteration). Mandelbrot:
     * the derivative in mu, |f'| <- 2|z||f'| + 1 (Milnor's estimate), which needs |z| itself. */
    vf dr2 = v_set1(1.0f), dm = v_set1(1.0f);
    vf n = v_set1(0.0f);
    vf trap = r2, gscale = v_set1(1.0f);
    vf j[3][4];
    if (want & UB_WANT_JACOBIAN)
        for (int k = 0; k < 3; k++)
            for (int c4 = 0; c4 < 4; c4++)
                j[k][c4] = v_set1((float)o->slice_basis[c4][k]);
    vm active = lanes;
    const vf two = v_set1(2.0f), half = v_set1(0.5f);
    for (int it = 0; it < p->max_iterations; it++) {
        if (want & UB_WANT_JACOBIAN) {
            a = v_mul(w.t, half);
            vf big = v_set1(0.0f);
            for (int k = 0; k < 3; k++) {
                vf p0 = j[k][0], p1 = j[k][1], p2 = j[k][2], p3 = j[k][3];
                vf vw = v_fma(b, p1, v_fma(c, p2, v_mul(d, p3)));
                vf n0 = v_mul(two, v_fms(a, p0, vw));
                vf n1 = v_mul(two, v_fma(a, p1, v_mul(p0, b)));
                vf n2 = v_mul(two, v_fma(a, p2, v_mul(p0, c)));
                vf n3 = v_mul(two, v_fma(a, p3, v_mul(p0, d)));
                if (mandel) {
                    n0 = v_add(n0, v_set1((float)o->slice_basis[0][k]));
                    n1 = v_add(n1, v_set1((float)o->slice_basis[1][k]));
                    n2 = v_add(n2, v_set1((float)o->slice_basis[2][k]));
                    n3 = v_add(n3, v_set1((float)o->slice_basis[3][k]));
                }
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
        /* One step of f(z) = z^2 + mu (doubled_step) into `next`, taken below by the lanes the
         * Jacobian freezes or by all; b, c and d only where the Jacobian reads them. */
        const vf t = w.t;
        doubled_orbit next = w;
        vf nr2 = doubled_step(&next, &k4);
        if (mandel) /* 2|z| = sqrt(4|z|^2), exactly */
            dm = v_select(active, v_fma(v_sqrt(r2), dm, v_set1(1.0f)), dm);
        else
            dr2 = v_select(active, v_mul(dr2, r2), dr2);
        if (want & UB_WANT_JACOBIAN) {
            /* The normal below reads z_n of each lane at its escape: freeze it. 2ab + mu_1 as
             * fma(2a, b, mu_1), the vector part of the step. */
            vf nb = v_fma(t, b, mu[1]), nc = v_fma(t, c, mu[2]), nd = v_fma(t, d, mu[3]);
            b = v_select(active, nb, b);
            c = v_select(active, nc, c);
            d = v_select(active, nd, d);
            w.t = v_select(active, next.t, w.t);
            w.v2x2 = v_select(active, next.v2x2, w.v2x2);
            w.s2 = v_select(active, next.s2, w.s2);
        } else {
            /* Nothing reads z after the loop: escaped lanes iterate on (to inf or NaN, harmless:
             * r2, the derivative and the trap froze at the escape), and no blend sits on the
             * loop-carried path of z (issue 21: 23.8 -> 13.8 cycles per iteration measured). */
            w = next;
        }
        active = orbit_step_within(k4.bail2x4, want, active, nr2, &r2, &n, &trap, &gscale, half);
        if (!m_bits(active))
            break;
    }
    /* A lane's r2 froze at its escape, the only way past the bailout (max_iterations >= 1). */
    vm escaped = v_gt(r2, k4.bail2x4);
    if (mandel)
        dr2 = v_mul(dm, dm);
    vf lr2 = v_log_quarter(r2);
    *dist = v_select(escaped, doubled_escape_estimate(r2, lr2, dr2), v_set1(0.0f));
    *iters = n;
    if (want & UB_WANT_TRAP) /* the least |z| = sqrt(4|z|^2) / 2 */
        x->trap = v_mul(v_sqrt(trap), half);
    if (want & UB_WANT_POTENTIAL) /* log|z| = log(r2) / 2 */
        x->potential = v_select(escaped, v_mul(v_mul(lr2, half), gscale), v_set1(0.0f));
    if (want & UB_WANT_JACOBIAN) {
        a = v_mul(w.t, half);
        for (int k = 0; k < 3; k++)
            x->normal[k] = v_fma(a, j[k][0], v_fma(b, j[k][1], v_fma(c, j[k][2], v_mul(d, j[k][3]))));
    }
}

/* de_quaternion_body where the compiler chooses whether to inline it (its uses in de_ext). */
static inline void de_quaternion(const ub_de_params *p, vm lanes, const int mandel, vf a, vf b, vf c, vf d,
                                 const int want, vf *dist, vf *iters, ub_de_extra *x)
{
    de_quaternion_body(p, lanes, mandel, a, b, c, d, want, dist, iters, x);
}

/* Julia set stacks (section 5.1): the point (x, y, w) is z = x + iy in the Julia set of
 * z^2 + c(u), u = w / height + 1/2 along the c-path. No distance underestimate is proven
 * (the paper); this one follows its hint and the Mandelbrot estimate: |z_n| log|z_n| / (2 |grad|)
 * with |grad|^2 = |dz_n/dz|^2 + |dz_n/dc|^2 |dc/dw|^2, the second term the Mandelbrot
 * derivative (|dz/dc| <- 2|z||dz/dc| + 1) times the path's speed. A constant path leaves the
 * exact planar estimate: a straight extrusion. Cut to the slab |w| <= height / 2. */
static inline void de_stack(const ub_de_params *p, vm lanes, vf x, vf y, vf w, const int want, vf *dist, vf *iters,
                                   ub_de_extra *ex)
{
    const ub_object *o = p->obj;
    float cr[UB_LANES], ci[UB_LANES], speed[UB_LANES], wl[UB_LANES];
    v_store(wl, w);
    const int last = o->path_count - 1;
    for (int l = 0; l < UB_LANES; l++) {
        double u = (double)wl[l] / o->stack_height + 0.5;
        /* Clamped so that NaN (a lane with no point: a missed ray's infinite t times 0) gives 0,
         * never an index outside the path. */
        u = u >= 0.0 ? (u <= 1.0 ? u : 1.0) : 0.0;
        double pos = u * last;
        int i = last > 0 ? (int)pos : 0;
        if (i >= last)
            i = last > 0 ? last - 1 : 0;
        double f = pos - i;
        const double *c0 = o->path[i], *c1 = o->path[last > 0 ? i + 1 : 0];
        cr[l] = (float)(c0[0] + f * (c1[0] - c0[0]));
        ci[l] = (float)(c0[1] + f * (c1[1] - c0[1]));
        speed[l] = (float)o->path_speed[i];
    }
    const vf c_re = v_load(cr), c_im = v_load(ci), cw = v_load(speed);
    const vf two = v_set1(2.0f), four = v_set1(4.0f), half = v_set1(0.5f), one = v_set1(1.0f);
    vf a = x, b = y;
    vf r2 = v_fma(a, a, v_mul(b, b)), dr2 = one, dm = v_set1(0.0f), n = v_set1(0.0f), trap = r2, gscale = one;
    vm active = lanes;
    for (int it = 0; it < p->max_iterations; it++) {
        vf na = v_fms(a, a, v_fms(b, b, c_re));
        vf nb = v_fma(v_add(a, a), b, c_im);
        dm = v_select(active, v_fma(v_mul(two, v_sqrt(r2)), dm, one), dm);
        dr2 = v_select(active, v_mul(dr2, v_mul(four, r2)), dr2);
        vf nr2 = v_fma(na, na, v_mul(nb, nb));
        a = v_select(active, na, a);
        b = v_select(active, nb, b);
        active = orbit_step(p, want, active, nr2, &r2, &n, &trap, &gscale, half);
        if (!m_bits(active))
            break;
    }
    vm escaped = v_gt(r2, p->bail2);
    vf lr2 = v_log(r2);
    vf dc = v_mul(dm, cw);
    vf est = escape_estimate(r2, lr2, v_fma(dc, dc, dr2));
    vf slab = v_sub(v_max(w, v_sub(v_set1(0.0f), w)), v_set1((float)(0.5 * o->stack_height)));
    *dist = v_max(v_select(escaped, est, v_set1(0.0f)), slab);
    *iters = n;
    if (want & UB_WANT_TRAP)
        ex->trap = v_sqrt(trap);
    if (want & UB_WANT_POTENTIAL)
        ex->potential = v_select(escaped, v_mul(v_mul(lr2, half), gscale), v_set1(0.0f));
    if (want & UB_WANT_JACOBIAN)
        ex->normal[0] = ex->normal[1] = ex->normal[2] = v_set1(0.0f);
}

/* One critical orbit of the cubic f(z) = z^3 - 3a^2 z + b (eq. 19) from z0 = sign * a, with
 * the derivatives P = dz/da, Q = dz/db (z is holomorphic in (a, b)):
 *   P <- f'(z) P - 6 a z,  Q <- f'(z) Q + 1,  f'(z) = 3z^2 - 3a^2,  P0 = sign, Q0 = 0.
 * Empirical estimate (section 5.2 knows none): |z_n| log|z_n| / (2 |grad|), the gradient over
 * the slice's three axes (Frobenius norm: never below the true gradient's length). */
static inline void cubic_orbit(const ub_de_params *p, vm lanes, float sign, vf ar, vf ai, vf br, vf bi,
                                      const int want, vf *dist, vf *iters, vf *trap_out, vf *potential)
{
    const ub_object *o = p->obj;
    const vf three = v_set1(3.0f), zero = v_set1(0.0f), third = v_set1(1.0f / 3.0f);
    const vf s = v_set1(sign);
    vf zr = v_mul(s, ar), zi = v_mul(s, ai);
    vf pr = s, pi = zero, qr = zero, qi = zero;
    /* 3 a^2 and 6 a */
    vf a2r = v_mul(three, v_fms(ar, ar, v_mul(ai, ai))), a2i = v_mul(three, v_mul(v_add(ar, ar), ai));
    vf a6r = v_mul(v_set1(6.0f), ar), a6i = v_mul(v_set1(6.0f), ai);
    vf r2 = v_fma(zr, zr, v_mul(zi, zi)), n = zero, trap = r2, gscale = v_set1(1.0f);
    vm active = lanes;
    for (int it = 0; it < p->max_iterations; it++) {
        vf z2r = v_fms(zr, zr, v_mul(zi, zi)), z2i = v_mul(v_add(zr, zr), zi);
        vf fpr = v_fms(three, z2r, a2r), fpi = v_fms(three, z2i, a2i); /* f'(z) */
        vf azr = v_fms(a6r, zr, v_mul(a6i, zi)), azi = v_fma(a6r, zi, v_mul(a6i, zr)); /* 6az */
        vf npr = v_sub(v_fms(fpr, pr, v_mul(fpi, pi)), azr), npi = v_sub(v_fma(fpr, pi, v_mul(fpi, pr)), azi);
        vf nqr = v_add(v_fms(fpr, qr, v_mul(fpi, qi)), v_set1(1.0f)), nqi = v_fma(fpr, qi, v_mul(fpi, qr));
        /* z^3 - 3a^2 z + b = z (z^2 - 3a^2) + b */
        vf wr = v_sub(z2r, a2r), wi = v_sub(z2i, a2i);
        vf nzr = v_add(v_fms(zr, wr, v_mul(zi, wi)), br), nzi = v_add(v_fma(zr, wi, v_mul(zi, wr)), bi);
        vf nr2 = v_fma(nzr, nzr, v_mul(nzi, nzi));
        zr = v_select(active, nzr, zr);
        zi = v_select(active, nzi, zi);
        pr = v_select(active, npr, pr);
        pi = v_select(active, npi, pi);
        qr = v_select(active, nqr, qr);
        qi = v_select(active, nqi, qi);
        active = orbit_step(p, want, active, nr2, &r2, &n, &trap, &gscale, third);
        if (!m_bits(active))
            break;
    }
    vf grad2 = zero;
    for (int k = 0; k < 3; k++) {
        /* dz/dx_k = P da_k + Q db_k, the slice axis k being (da_k, db_k) in C^2. */
        vf dar = v_set1((float)o->slice_basis[0][k]), dai = v_set1((float)o->slice_basis[1][k]);
        vf dbr = v_set1((float)o->slice_basis[2][k]), dbi = v_set1((float)o->slice_basis[3][k]);
        vf gr = v_fma(pr, dar, v_fms(qr, dbr, v_fma(pi, dai, v_mul(qi, dbi))));
        vf gi = v_fma(pr, dai, v_fma(pi, dar, v_fma(qr, dbi, v_mul(qi, dbr))));
        grad2 = v_fma(gr, gr, v_fma(gi, gi, grad2));
    }
    vm escaped = v_gt(r2, p->bail2);
    vf lr2 = v_log(r2);
    vf est = escape_estimate(r2, lr2, grad2);
    /* An overflowed gradient gives 0 (a hit) rather than a step too far. */
    *dist = v_select(escaped, v_select(v_lt(grad2, v_set1(HUGE_VALF)), est, zero), zero);
    *iters = n;
    *trap_out = trap;
    *potential = v_select(escaped, v_mul(v_mul(lr2, v_set1(0.5f)), gscale), zero);
}

/* The cubic connectedness locus (section 5.2) in the 4-D (a, b) space: C+, C-, their union
 * (min of the estimates) or their intersection (max), clipped to the ball |(a, b)| <= extent. */
static inline void de_cubic(const ub_de_params *p, vm lanes, vf ar, vf ai, vf br, vf bi, const int want, vf *dist,
                                   vf *iters, ub_de_extra *x)
{
    const ub_object *o = p->obj;
    vf d, n, trap, pot;
    int comp = o->cubic_component;
    cubic_orbit(p, lanes, comp == UB_CUBIC_MINUS ? -1.0f : 1.0f, ar, ai, br, bi, want, &d, &n, &trap, &pot);
    if (comp == UB_CUBIC_UNION || comp == UB_CUBIC_BOTH) {
        vf d2, n2, trap2, pot2;
        cubic_orbit(p, lanes, -1.0f, ar, ai, br, bi, want, &d2, &n2, &trap2, &pot2);
        vm second = comp == UB_CUBIC_UNION ? v_lt(d2, d) : v_gt(d2, d);
        d = v_select(second, d2, d);
        n = v_select(second, n2, n);
        trap = v_select(second, trap2, trap);
        pot = v_select(second, pot2, pot);
    }
    vf r = v_sqrt(v_fma(ar, ar, v_fma(ai, ai, v_fma(br, br, v_mul(bi, bi)))));
    *dist = v_max(d, v_sub(r, v_set1((float)o->extent)));
    *iters = n;
    if (want & UB_WANT_TRAP)
        x->trap = v_sqrt(trap);
    if (want & UB_WANT_POTENTIAL)
        x->potential = pot;
    if (want & UB_WANT_JACOBIAN)
        x->normal[0] = x->normal[1] = x->normal[2] = v_set1(0.0f);
}

/* |x| as max(x, -x): the same bits in every kernel (-0 gives +0, NaN stays NaN). */
static inline vf v_abs(vf x)
{
    return v_max(x, v_sub(v_set1(0.0f), x));
}

/* |p - u|^2 for the lanes' points p = (x, y, z) and one point u. */
static inline vf distance2_to(vf x, vf y, vf z, const float u[3])
{
    vf dx = v_sub(x, v_set1(u[0])), dy = v_sub(y, v_set1(u[1])), dz = v_sub(z, v_set1(u[2]));
    return v_fma(dx, dx, v_fma(dy, dy, v_mul(dz, dz)));
}

/* 3-D IFS with mirror-symmetric pieces (ifs.c, detect_mirror_pieces: the Sierpinski tetrahedron):
 * at each level the nearest leaf ball lies in the piece whose image of the centre is nearest, so
 * the estimate follows that one path, x <- (x - t_i) / s, and ends with its leaf ball's signed
 * distance s^depth (|x - c| - R): the distance to the union of all leaf balls, exactly what the
 * search of ub_ifs_distance bounds from below, in depth x map_count distances for all lanes at once
 * instead of a search per lane in double. Float rounding moves it by about 1e-6 of the ball's
 * radius (tests/native/test_ifs.py). */
static inline void de_ifs_mirror(const ub_object *o, vf x, vf y, vf z, const int want, vf *dist, vf *iters,
                                 ub_de_extra *ex)
{
    const int m = o->map_count;
    const vf inverse = v_set1(o->mirror_inverse);
    const float *c = o->mirror_root;
    vf root = v_sqrt(distance2_to(x, y, z, c));
    /* Beyond 1e6 radii the root ball's distance is the leaf balls' to float precision (within 2e-6
     * of it), and the path would overflow (detect_mirror_pieces). */
    vm far = v_gt(root, v_set1(1e6f * o->mirror_radius));
    vf address = v_set1(0.0f);
    float scale = 1.0f, span = 1.0f;
    for (int level = 0; level < o->ifs_depth; level++) {
        vf nearest2 = v_set1(INFINITY), index = v_set1(0.0f);
        vf tx = v_set1(o->mirror_offset[0][0]), ty = v_set1(o->mirror_offset[0][1]), tz = v_set1(o->mirror_offset[0][2]);
        for (int i = 0; i < m; i++) {
            const float *v = o->mirror_center[i], *t = o->mirror_offset[i];
            vf e2 = distance2_to(x, y, z, v);
            vm closer = v_lt(e2, nearest2); /* ties (and NaN) keep the lower index */
            nearest2 = v_select(closer, e2, nearest2);
            index = v_select(closer, v_set1((float)i), index);
            tx = v_select(closer, v_set1(t[0]), tx);
            ty = v_select(closer, v_set1(t[1]), ty);
            tz = v_select(closer, v_set1(t[2]), tz);
        }
        span /= (float)m;
        address = v_fma(index, v_set1(span), address);
        x = v_mul(v_sub(x, tx), inverse);
        y = v_mul(v_sub(y, ty), inverse);
        z = v_mul(v_sub(z, tz), inverse);
        scale *= o->mirror_ratio;
    }
    vf leaf = v_sub(v_sqrt(distance2_to(x, y, z, c)), v_set1(o->mirror_radius));
    *dist = v_select(far, v_sub(root, v_set1(o->mirror_radius)), v_mul(leaf, v_set1(scale)));
    /* As the search: a NaN or infinite point (never a hit) settles at depth 0. */
    vm finite = v_le(v_sub(*dist, *dist), v_set1(0.0f));
    *iters = v_select(finite, v_set1((float)o->ifs_depth), v_set1(0.0f));
    if (want & UB_WANT_TRAP)
        ex->trap = v_select(finite, v_fma(v_set1(0.5f), v_set1(span), address), v_set1(0.0f));
    if (want & UB_WANT_POTENTIAL)
        ex->potential = v_set1(0.0f);
    if (want & UB_WANT_JACOBIAN)
        ex->normal[0] = ex->normal[1] = ex->normal[2] = v_set1(0.0f);
}

/* 3-D IFS with the cube's symmetries (ifs.c, detect_folded_pieces: the Menger sponge): at each
 * level the point, relative to the centre, is folded into the wedge x >= y >= z >= 0 (abs and a
 * sorting network: exact in float), where the nearest leaf ball lies in the wedge piece whose
 * image of the centre is nearest (two for the sponge), and the estimate goes on in that piece's
 * frame, x <- (x - u_i) / s; it ends with the leaf ball's signed distance s^depth (|x| - R). The
 * same exact distance to the union of all leaf balls as de_ifs_mirror, whose path over all maps
 * is also exact here: it picks, before folding, the piece that the fold's wedge piece came from
 * (the fold's symmetry maps one onto the other with the point), so the same distance up to ties
 * and float rounding; that path alone knows the leaf's address, so it gives the orbit trap. A
 * level costs a fold and fold_count distances instead of map_count (20 for the sponge). */
static inline void de_ifs_folded(const ub_object *o, vf x, vf y, vf z, const int want, vf *dist, vf *iters,
                                 ub_de_extra *ex)
{
    const vf inverse = v_set1(o->mirror_inverse);
    const float *c = o->mirror_root;
    x = v_sub(x, v_set1(c[0]));
    y = v_sub(y, v_set1(c[1]));
    z = v_sub(z, v_set1(c[2]));
    vf root = v_sqrt(v_fma(x, x, v_fma(y, y, v_mul(z, z))));
    /* As de_ifs_mirror: beyond 1e6 radii the root ball's distance. */
    vm far = v_gt(root, v_set1(1e6f * o->mirror_radius));
    float scale = 1.0f;
    for (int level = 0; level < o->ifs_depth; level++) {
        x = v_abs(x);
        y = v_abs(y);
        z = v_abs(z);
        vf hi = v_max(x, y), lo = v_min(x, y);
        vf mid = v_max(lo, z);
        z = v_min(lo, z);
        x = v_max(hi, mid);
        y = v_min(hi, mid);
        const float *u = o->fold_center[0];
        vf ux = v_set1(u[0]), uy = v_set1(u[1]), uz = v_set1(u[2]);
        vf nearest2 = distance2_to(x, y, z, u);
        for (int i = 1; i < o->fold_count; i++) {
            u = o->fold_center[i];
            vf e2 = distance2_to(x, y, z, u);
            vm closer = v_lt(e2, nearest2); /* ties (and NaN) keep the lower index */
            nearest2 = v_select(closer, e2, nearest2);
            ux = v_select(closer, v_set1(u[0]), ux);
            uy = v_select(closer, v_set1(u[1]), uy);
            uz = v_select(closer, v_set1(u[2]), uz);
        }
        x = v_mul(v_sub(x, ux), inverse);
        y = v_mul(v_sub(y, uy), inverse);
        z = v_mul(v_sub(z, uz), inverse);
        scale *= o->mirror_ratio;
    }
    vf leaf = v_sub(v_sqrt(v_fma(x, x, v_fma(y, y, v_mul(z, z)))), v_set1(o->mirror_radius));
    *dist = v_select(far, v_sub(root, v_set1(o->mirror_radius)), v_mul(leaf, v_set1(scale)));
    vm finite = v_le(v_sub(*dist, *dist), v_set1(0.0f));
    *iters = v_select(finite, v_set1((float)o->ifs_depth), v_set1(0.0f));
    if (want & UB_WANT_POTENTIAL)
        ex->potential = v_set1(0.0f);
    if (want & UB_WANT_JACOBIAN)
        ex->normal[0] = ex->normal[1] = ex->normal[2] = v_set1(0.0f);
}

/* 3-D IFS (section 5.3): the bounding-ball hierarchy of ifs.c, lane by lane in double precision
 * (mirror-symmetric pieces: de_ifs_mirror; the cube's symmetries: de_ifs_folded). The bound is
 * signed (negative inside a leaf ball), so gradients give the leaves' normals. The escape count is
 * the depth that settled the bound, the orbit trap the leaf's address. */
static inline void de_ifs(const ub_de_params *p, vm lanes, vf x, vf y, vf z, const int want, vf *dist, vf *iters,
                                 ub_de_extra *ex)
{
    /* One path, every lane: they run side by side anyway. The folded path gives no address (the
     * fold loses which of the symmetric pieces it came from); the orbit trap, asked once per hit
     * or mesh vertex, takes the path over all maps, as exact (de_ifs_folded). */
    if (p->obj->ifs_folded && !(want & UB_WANT_TRAP)) {
        de_ifs_folded(p->obj, x, y, z, want, dist, iters, ex);
        return;
    }
    if (p->obj->ifs_mirror || p->obj->ifs_folded) {
        de_ifs_mirror(p->obj, x, y, z, want, dist, iters, ex);
        return;
    }
    float xs[UB_LANES], ys[UB_LANES], zs[UB_LANES], ds[UB_LANES] = {0}, ns[UB_LANES] = {0}, as[UB_LANES] = {0};
    v_store(xs, x);
    v_store(ys, y);
    v_store(zs, z);
    const int wanted = m_bits(lanes);
    for (int l = 0; l < UB_LANES; l++) {
        if (!((wanted >> l) & 1))
            continue;
        double pt[3] = {xs[l], ys[l], zs[l]}, address;
        int depth;
        ds[l] = (float)ub_ifs_distance(p->obj, pt, &address, &depth, p->cancel);
        ns[l] = (float)depth;
        as[l] = (float)address;
    }
    *dist = v_load(ds);
    *iters = v_load(ns);
    if (want & UB_WANT_TRAP)
        ex->trap = v_load(as);
    if (want & UB_WANT_POTENTIAL)
        ex->potential = v_set1(0.0f);
    if (want & UB_WANT_JACOBIAN)
        ex->normal[0] = ex->normal[1] = ex->normal[2] = v_set1(0.0f);
}

#include "formulas.h"

#include "zoom_lanes.h"

/* A zoomed estimate's lanes (zoom_out, double) as the kernels' float32 vectors: the lanes `wanted`,
 * the extras `want` asks for. */
static void zoom_out_vectors(const zoom_out *r, int wanted, const int want, vf *dist, vf *iters, ub_de_extra *x)
{
    float ds[UB_LANES] = {0}, ns[UB_LANES] = {0}, ts[UB_LANES] = {0}, ps[UB_LANES] = {0};
    float gs[3][UB_LANES] = {{0}};
    for (int l = 0; l < UB_LANES; l++) {
        if (!((wanted >> l) & 1))
            continue;
        ds[l] = (float)fmax(fmin(r->dist[l], FLT_MAX), -FLT_MAX);
        ns[l] = (float)r->iterations[l];
        if (want & UB_WANT_TRAP)
            ts[l] = (float)r->trap[l];
        if (want & UB_WANT_POTENTIAL)
            ps[l] = (float)r->potential[l];
        if (want & UB_WANT_JACOBIAN)
            for (int k = 0; k < 3; k++)
                gs[k][l] = (float)r->normal[k][l];
    }
    *dist = v_load(ds);
    *iters = v_load(ns);
    if (want & UB_WANT_TRAP)
        x->trap = v_load(ts);
    if (want & UB_WANT_POTENTIAL)
        x->potential = v_load(ps);
    if (want & UB_WANT_JACOBIAN)
        for (int k = 0; k < 3; k++)
            x->normal[k] = v_load(gs[k]);
}

/* A zoomed quaternion object: the double or perturbation estimate of zoom.c, lane-parallel in
 * double (zoom_lanes.h: the same bits in every kernel), for the lanes `lanes` only. */
static void de_zoom(const ub_de_params *p, vm lanes, vf a, vf b, vf c, vf d, const int want, vf *dist, vf *iters,
                    ub_de_extra *x)
{
    float q[4][UB_LANES];
    const int wanted = m_bits(lanes);
    v_store(q[0], a);
    v_store(q[1], b);
    v_store(q[2], c);
    v_store(q[3], d);
    zoom_out r;
    zoom_lanes(p->obj, p->zoom_path, wanted, q, want, &r);
    zoom_out_vectors(&r, wanted, want, dist, iters, x);
}

/* A zoomed formula kind (Mandelbulb, Mandelbox, KIFS, hybrid): zoom_formulas.c's scalar double
 * estimate, lane by lane (compiled once, so every kernel gets its bits), for the lanes `lanes`
 * only. No Jacobian: these kinds' normals are gradients of the estimate (the normal is 0 here). */
static void de_zoom_formula(const ub_de_params *p, vm lanes, vf a, vf b, vf c, const int want, vf *dist, vf *iters,
                            ub_de_extra *x)
{
    float u[3][UB_LANES];
    const int wanted = m_bits(lanes);
    v_store(u[0], a);
    v_store(u[1], b);
    v_store(u[2], c);
    zoom_out r; /* only the wanted lanes are filled, and read */
    for (int l = 0; l < UB_LANES; l++) {
        if (!((wanted >> l) & 1))
            continue;
        const double ul[3] = {u[0][l], u[1][l], u[2][l]};
        ub_zoom_result one;
        ub_zoom_formula_estimate(p->obj, ul, &one);
        zoom_out_put(&r, l, &one);
    }
    zoom_out_vectors(&r, wanted, want, dist, iters, x);
}

/* The Julia set's estimate alone, as the march and the normals' differences ask for it: flattened,
 * so that it has its own copy of the loop with the kind and the extras known when compiled (the
 * out-of-line de_quaternion tested them in every iteration), without inlining de_quaternion's
 * other uses as well (that made the "everything" scene 4 % slower). Issue 21: the peer scene 5 %
 * faster, the "everything" scene 2 %. */
static __attribute__((flatten)) void de_julia(const ub_de_params *p, vm lanes, vf a, vf b, vf c, vf d, vf *dist,
                                              vf *iters)
{
    ub_de_extra unused;
    de_quaternion(p, lanes, 0, a, b, c, d, 0, dist, iters, &unused);
}

/* de_julia's estimate inlined where it is called (the march: march_de). */
static inline __attribute__((always_inline)) void de_quaternion_inline(const ub_de_params *p, vm lanes, vf a, vf b,
        vf c, vf d, vf *dist, vf *iters, ub_de_extra *x)
{
    de_quaternion_body(p, lanes, 0, a, b, c, d, 0, dist, iters, x);
}

/* Two Julia estimates at once, points z0 in the lanes lanes[0] and z1 in lanes[1]: the two sides of
 * a central difference, or two packets of rays (march.h, march_julia_pair). One loop carries both
 * orbits, so the second one's operations fill the vector ports while the first waits on its
 * loop-carried path (t -> |v|^2 -> t, doubled_step). Each orbit is de_quaternion's
 * with want = 0, operation for operation, so each estimate has de_julia's bits; the loop runs until
 * both orbits' lanes have escaped (an escaped lane's z iterates on, harmless: r2 and the
 * derivative froze at its escape, as in de_quaternion). Issue 21: the normals' six estimates a hit
 * take three of these. */
static inline __attribute__((always_inline)) void de_julia_pair_body(const ub_de_params *p, const vm lanes[2],
        const vf z0[4], const vf z1[4], vf dist[2], vf iters[2])
{
    const vf *z[2] = {z0, z1};
    /* A local copy: read through p, the constants were loaded in every iteration (0.995x). */
    const doubled_constants k4v = p->orbit, *k4 = &k4v;
    doubled_orbit w[2];
    vf r2[2], dr2[2], n[2]; /* r2: 4|z|^2, as doubled_step gives it */
    vm active[2];
    for (int k = 0; k < 2; k++) {
        w[k] = doubled_start(z[k], k4, &r2[k]);
        dr2[k] = v_set1(1.0f);
        n[k] = v_set1(0.0f);
#ifdef UB_ESCAPE_MASK_FROM_R2
        /* A lane outside `lanes` starts as escaped (r2 past any bailout): then a lane iterates
         * exactly while its r2 has not passed the bailout, and each trip's mask is r2's compare
         * (simd_avx2.h; the lanes outside `lanes` get another estimate, which no caller reads). */
        r2[k] = v_select(lanes[k], r2[k], v_set1(INFINITY));
#endif
        active[k] = lanes[k];
    }
    for (int it = 0; it < p->max_iterations && m_either(active[0], active[1]); it++) {
        for (int k = 0; k < 2; k++) {
            vf nr2 = doubled_step(&w[k], k4);
            dr2[k] = v_select(active[k], v_mul(dr2[k], r2[k]), dr2[k]);
            r2[k] = v_select(active[k], nr2, r2[k]);
            n[k] = v_count(n[k], active[k]);
#ifdef UB_ESCAPE_MASK_FROM_R2
            active[k] = m_not_gt(r2[k], k4->bail2x4);
#else
            active[k] = m_andnot_gt(nr2, k4->bail2x4, active[k]);
#endif
        }
    }
    for (int k = 0; k < 2; k++) {
        vm escaped = v_gt(r2[k], k4->bail2x4);
        /* doubled_escape_estimate's bits: (s lr2) / 8 = s (lr2 / 8) exactly, no product over-
         * or underflowing (r2 < 2^90 with UB_MAX_BAILOUT, lr2 > 2^-24, grad2 a float). */
        vf lr2_eighth = v_log_quarter_eighth(r2[k]);
        dist[k] = v_select(escaped, v_mul(v_sqrt(v_div(r2[k], dr2[k])), lr2_eighth), v_set1(0.0f));
        iters[k] = n[k];
    }
}

/* de_julia_pair_body out of line, both orbits in the same lanes: the normals' differences. */
static __attribute__((flatten)) void de_julia_pair(const ub_de_params *p, vm lanes, const vf z0[4], const vf z1[4],
                                                   vf dist[2], vf iters[2])
{
    const vm both[2] = {lanes, lanes};
    de_julia_pair_body(p, both, z0, z1, dist, iters);
}

/* Whether de() of these parameters is de_julia: a Julia set not on a deep-zoom path. */
static inline int julia_only(const ub_de_params *p)
{
    return !p->zoom_path && p->obj->kind == UB_KIND_QUATERNION_JULIA;
}

/* The distance estimate of the object's kind, with the extras `want` asks for, in the lanes
 * `lanes`; the other lanes' outputs are unspecified (but never trap), and they cost nothing once
 * the wanted lanes are done: a packet whose rays have mostly hit iterates only for the rest. */
static inline void de_ext(const ub_de_params *p, vm lanes, vf a, vf b, vf c, vf d, const int want, vf *dist,
                                 vf *iters, ub_de_extra *x)
{
    if (p->zoom_path && ub_kind_is_formula(p->obj->kind)) {
        de_zoom_formula(p, lanes, a, b, c, want, dist, iters, x);
        return;
    }
    if (p->zoom_path) {
        de_zoom(p, lanes, a, b, c, d, want, dist, iters, x);
        return;
    }
    switch (p->obj->kind) {
    case UB_KIND_QUATERNION_MANDELBROT:
        de_quaternion(p, lanes, 1, a, b, c, d, want, dist, iters, x);
        break;
    case UB_KIND_JULIA_STACK:
        de_stack(p, lanes, a, b, c, want, dist, iters, x);
        break;
    case UB_KIND_CUBIC_LOCUS:
        de_cubic(p, lanes, a, b, c, d, want, dist, iters, x);
        break;
    case UB_KIND_IFS:
        de_ifs(p, lanes, a, b, c, want, dist, iters, x);
        break;
    case UB_KIND_MANDELBULB:
        de_mandelbulb(p, lanes, a, b, c, want, dist, iters, x);
        break;
    case UB_KIND_MANDELBOX:
        de_mandelbox(p, lanes, a, b, c, want, dist, iters, x);
        break;
    case UB_KIND_KIFS:
        de_kifs(p, lanes, a, b, c, want, dist, iters, x);
        break;
    case UB_KIND_HYBRID:
        de_hybrid(p, lanes, a, b, c, want, dist, iters, x);
        break;
    default:
        if (want)
            de_quaternion(p, lanes, 0, a, b, c, d, want, dist, iters, x);
        else
            de_julia(p, lanes, a, b, c, d, dist, iters);
        break;
    }
}

/* Distance estimate of section 3 at quaternion points q:
 *   d(z) = |f^n(z)| log|f^n(z)| / (2 |f^n'(z)|)
 * with f(z) = z^2 + mu iterated until |z| exceeds the escape radius or max_iterations is
 * reached. The running derivative obeys |f'| <- 2 |z| |f'| (|zh + hz| <= 2|z||h| in the
 * quaternions); we carry its square, 4 |z|^2 |f'|^2, to avoid a square root per iteration.
 * Points that never escape are in K_mu as far as we can tell: their estimate is 0 (a hit).
 * Writes the estimate (object units) and the escape count. */
static inline void de(const ub_de_params *p, vm lanes, vf a, vf b, vf c, vf d, vf *dist, vf *iters)
{
    /* want = 0: no extras (trap, derivatives) are gathered; GCC keeps de_ext out of line, and the
     * Julia benchmark runs as fast as with the earlier inlined loop (0.108 s, 640x512, 1 thread). */
    ub_de_extra unused;
    de_ext(p, lanes, a, b, c, d, 0, dist, iters, &unused);
}

/* Object-space point -> quaternion on the object's slice, in double then rounded. */
static inline void to_quaternion(const ub_object *o, const double p[3], float q[4])
{
    for (int k = 0; k < 4; k++) {
        const double *b = o->slice_basis[k];
        q[k] = (float)(o->slice_origin[k] + b[0] * p[0] + b[1] * p[1] + b[2] * p[2]);
    }
}

/* The quaternions of object-space points xyz[base .. base + n) (float32 x, y, z each), one per lane;
 * the lanes past n repeat the last point (an entry point's last, partial packet). */
static inline void point_packet(const ub_object *o, const float *xyz, size_t base, size_t n, float q[4][UB_LANES])
{
    for (size_t l = 0; l < UB_LANES; l++) {
        const float *p = xyz + 3 * (base + (l < n ? l : n - 1));
        double pd[3] = {p[0], p[1], p[2]};
        float ql[4];
        to_quaternion(o, pd, ql);
        for (int k = 0; k < 4; k++)
            q[k][l] = ql[k];
    }
}

static inline void world_to_object_point(const ub_object *o, const double p[3], double out[3])
{
    for (int i = 0; i < 3; i++) {
        const double *w = o->world_to_object[i];
        out[i] = w[0] * p[0] + w[1] * p[1] + w[2] * p[2] + w[3];
    }
}

/* A packet of world points -> the object's quaternions, one per lane. Always inlined, as GCC does
 * and clang (the release builds) did not: its packet returns in registers, not through memory. */
static inline __attribute__((always_inline)) void quaternion_lanes(const ub_object *o, const double p[3][UB_LANES],
                                                                   vf q[4])
{
    float qs[4][UB_LANES];
#ifdef VD_LANES
    /* world_to_object_point and to_quaternion in double vectors, each sum in their order (issue
     * 21: GCC left the lane loop scalar). */
    for (int h = 0; h < UB_LANES; h += VD_LANES) {
        const vd wp[3] = {vd_load(p[0] + h), vd_load(p[1] + h), vd_load(p[2] + h)};
        vd op[3];
        for (int i = 0; i < 3; i++)
            op[i] = vd_add(vd_row_dot(o->world_to_object[i], wp), vd_set1(o->world_to_object[i][3]));
        for (int c = 0; c < 4; c++)
            vd_store_floats(qs[c] + h, vd_offset_dot(o->slice_origin[c], o->slice_basis[c], op));
    }
#else
    for (int l = 0; l < UB_LANES; l++) {
        double wp[3] = {p[0][l], p[1][l], p[2][l]}, op[3];
        float ql[4];
        world_to_object_point(o, wp, op);
        to_quaternion(o, op, ql);
        for (int c = 0; c < 4; c++)
            qs[c][l] = ql[c];
    }
#endif
    for (int c = 0; c < 4; c++)
        q[c] = v_load(qs[c]);
}

/* Object-space normal at quaternion points q of the lanes `lanes` (the others' are unspecified), by the object's method:
 * eq. 15's central differences of d() or G() with the step h (object units), or the analytic
 * gradient. A degenerate gradient (all samples inside the set, or G flat) falls back to the
 * analytic normal, and that to zero (the caller then faces the normal to the viewer). The
 * differences' iterations of f in the lanes `lanes` add to *normal_iterations (NULL: not counted). */
static void object_normal(const ub_object *o, const ub_de_params *dp, vm lanes, const vf q[4], vf h, vf g[3],
                          uint64_t *normal_iterations)
{
    int method = (int)o->normal_method;
    vf dist, it;
    ub_de_extra x;
    vm good = m_andnot(lanes, m_from_bits(UB_ALL_LANES)); /* lanes with a usable gradient, or none wanted */
    /* Only the quaternion kinds carry a Jacobian, and the IFS has no potential: the others use
     * the distance gradient. */
    int quaternion = o->kind == UB_KIND_QUATERNION_JULIA || o->kind == UB_KIND_QUATERNION_MANDELBROT;
    /* Z-buffer normals come from the hit buffer; here (neighbours unknown) the distance gradient. */
    if (method == UB_NORMAL_ZBUFFER || (method == UB_NORMAL_ANALYTIC && !quaternion)
        || (method == UB_NORMAL_GRADIENT_POTENTIAL && (o->kind == UB_KIND_IFS || o->kind == UB_KIND_MANDELBOX
                                                        || o->kind == UB_KIND_KIFS || o->kind == UB_KIND_HYBRID)))
        method = UB_NORMAL_GRADIENT_DISTANCE;
    if (method != UB_NORMAL_ANALYTIC) {
        const int potential = method == UB_NORMAL_GRADIENT_POTENTIAL;
        vf iterations = v_set1(0.0f);
        for (int axis = 0; axis < 3; axis++) {
            vf off[4], v[2];
            for (int k = 0; k < 4; k++)
                off[k] = v_mul(h, v_set1((float)o->slice_basis[k][axis]));
            vf z[2][4];
            for (int side = 0; side < 2; side++)
                for (int k = 0; k < 4; k++)
                    z[side][k] = v_fma(v_set1(side ? -1.0f : 1.0f), off[k], q[k]);
            if (!potential && julia_only(dp)) {
                vf it2[2];
                de_julia_pair(dp, lanes, z[0], z[1], v, it2);
                iterations = v_add(iterations, v_add(it2[0], it2[1]));
                g[axis] = v_sub(v[0], v[1]);
                continue;
            }
            for (int side = 0; side < 2; side++) {
                vf a = z[side][0], b = z[side][1], c = z[side][2], d = z[side][3];
                if (potential) {
                    de_ext(dp, lanes, a, b, c, d, UB_WANT_POTENTIAL, &dist, &it, &x);
                    v[side] = x.potential;
                } else {
                    de(dp, lanes, a, b, c, d, &v[side], &it);
                }
                iterations = v_add(iterations, it);
            }
            g[axis] = v_sub(v[0], v[1]);
        }
        if (normal_iterations) {
            float counted[UB_LANES];
            v_store(counted, v_select(lanes, iterations, v_set1(0.0f)));
            for (int l = 0; l < UB_LANES; l++)
                *normal_iterations += (uint64_t)counted[l];
        }
        good = m_or(good, v_gt(v_fma(g[0], g[0], v_fma(g[1], g[1], v_mul(g[2], g[2]))), v_set1(0.0f)));
    }
    if (m_bits(good) == UB_ALL_LANES)
        return;
    if (!quaternion) {
        /* No analytic fallback for the other kinds: zero, without running their estimator again. */
        for (int k = 0; k < 3; k++)
            g[k] = v_select(good, g[k], v_set1(0.0f));
        return;
    }
    de_ext(dp, lanes, q[0], q[1], q[2], q[3], UB_WANT_JACOBIAN, &dist, &it, &x);
    for (int k = 0; k < 3; k++)
        g[k] = method == UB_NORMAL_ANALYTIC ? x.normal[k] : v_select(good, g[k], x.normal[k]);
}
