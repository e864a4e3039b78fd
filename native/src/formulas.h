/* The community formulas of issue 22: the Mandelbulb (White and Nylander's triplex power) and
 * the Mandelbox (Lowe's box and sphere folds), with the vector functions they need. Included by
 * estimators.h, compiled once per SIMD flavour.
 *
 * Transcendental functions are our own, built only from the interface's correctly rounded
 * operations (add, mul, div, sqrt, fma, min, max, compare, select), so both kernels and every
 * platform agree bit for bit; no libm. Accuracy against double-precision libm over 250000
 * vectors (tools/formulas_accuracy.c, the portable twin):
 *   v_atan2   Cephes' atanf polynomial after reduction to [0, tan(pi/8)]: absolute <= 2.8e-7
 *             (about one ulp of pi)
 *   v_sincos  Cody-Waite reduction by pi/2 in three parts, Cephes' sinf/cosf polynomials on
 *             [-pi/4, pi/4]: absolute <= 9e-8 for |x| <= 64 (n theta for n <= 32 stays within)
 *   v_exp2    Cephes' exp2f polynomial on [-1/2, 1/2] times an exact power of two: relative
 *             <= 7.7e-8 (under one ulp)
 * so r^n = exp2(n log2 r) (with v_log of estimators.h) is within about n |log r| 1e-7 relative.
 * Whole powers need none of them (bulb_step: de Moivre by binary powers). The whole estimate is
 * within 2e-3 relative of float64 (tests/native/test_formulas.py). Measured, 60000 points in the
 * ball, 12 iterations, where the float64 estimate exceeds 1e-3 of the radius: power 8 (whole
 * path) median 1.9e-7, 99th percentile 6.3e-6, largest 1.3e-3 (the angle path it replaced:
 * 1.6e-7, 8.2e-6, 2.7e-3; the largest are points where the orbit nearly fails to escape); power
 * 32: 2.7e-7, 2.2e-5, 2.6e-4 (angles: 1.3e-7, 1.1e-5, 6.9e-5). */

/* Round to the nearest integer (ties to even), |x| < 2^22: two exact-then-rounded adds. */
static inline vf v_round_int(vf x)
{
    const vf magic = v_set1(12582912.0f); /* 1.5 * 2^23 */
    return v_sub(v_add(x, magic), magic);
}

static inline vf v_neg_if(vm m, vf x)
{
    return v_select(m, v_sub(v_set1(0.0f), x), x);
}

/* atan(t) for t in [0, 1]. */
static inline vf v_atan01(vf t)
{
    vm big = v_gt(t, v_set1(0.41421356237f));
    vf x = v_select(big, v_div(v_sub(t, v_set1(1.0f)), v_add(t, v_set1(1.0f))), t);
    vf z = v_mul(x, x);
    vf p = v_set1(8.05374449538e-2f);
    p = v_fma(p, z, v_set1(-1.38776856032e-1f));
    p = v_fma(p, z, v_set1(1.99777106478e-1f));
    p = v_fma(p, z, v_set1(-3.33329491539e-1f));
    vf y = v_fma(v_mul(p, z), x, x);
    return v_add(y, v_select(big, v_set1(0.785398163397f), v_set1(0.0f)));
}

/* atan2(y, x) in [-pi, pi]; atan2(0, 0) = 0; y = -0 counts as positive. */
static inline vf v_atan2(vf y, vf x)
{
    vf ax = v_abs(x), ay = v_abs(y);
    vf hi = v_max(ax, ay), lo = v_min(ax, ay);
    vm some = v_gt(hi, v_set1(0.0f));
    vf t = v_select(some, v_div(lo, v_select(some, hi, v_set1(1.0f))), v_set1(0.0f));
    vf a = v_atan01(t);
    a = v_select(v_gt(ay, ax), v_sub(v_set1(1.57079632679f), a), a);
    a = v_select(v_lt(x, v_set1(0.0f)), v_sub(v_set1(3.14159265359f), a), a);
    return v_neg_if(v_lt(y, v_set1(0.0f)), a);
}

/* sin and cos of x, |x| <= 128 (larger arguments lose accuracy, never determinism). */
static inline void v_sincos(vf x, vf *s, vf *c)
{
    vf k = v_round_int(v_mul(x, v_set1(0.636619772368f))); /* x / (pi/2) */
    vf r = v_fma(k, v_set1(-1.5703125f), x);
    r = v_fma(k, v_set1(-4.837512969970703125e-4f), r);
    r = v_fma(k, v_set1(-7.54978995489188216e-8f), r);
    vf z = v_mul(r, r);
    vf ps = v_set1(-1.9515295891e-4f);
    ps = v_fma(ps, z, v_set1(8.3321608736e-3f));
    ps = v_fma(ps, z, v_set1(-1.6666654611e-1f));
    ps = v_fma(v_mul(ps, z), r, r);
    vf pc = v_set1(2.443315711809948e-5f);
    pc = v_fma(pc, z, v_set1(-1.388731625493765e-3f));
    pc = v_fma(pc, z, v_set1(4.166664568298827e-2f));
    pc = v_fma(v_mul(pc, z), z, v_fms(v_set1(-0.5f), z, v_set1(-1.0f)));
    /* Quadrant j = k mod 4, from the exact integer k. */
    vf q = v_mul(k, v_set1(0.25f));
    vf fl = v_round_int(q);
    fl = v_select(v_gt(fl, q), v_sub(fl, v_set1(1.0f)), fl);
    vf j = v_fms(v_set1(-4.0f), fl, v_sub(v_set1(0.0f), k)); /* k - 4 fl */
    vm odd = m_or(m_and(v_gt(j, v_set1(0.5f)), v_lt(j, v_set1(1.5f))), v_gt(j, v_set1(2.5f)));
    vm sin_neg = v_gt(j, v_set1(1.5f));
    vm cos_neg = m_and(v_gt(j, v_set1(0.5f)), v_lt(j, v_set1(2.5f)));
    *s = v_neg_if(sin_neg, v_select(odd, pc, ps));
    *c = v_neg_if(cos_neg, v_select(odd, ps, pc));
}

/* 2^k for whole numbers k in [-126, 127]: a product of exact powers of two. */
static inline vf v_exp2_int(vf k)
{
    vf ak = v_abs(k), p = v_set1(1.0f);
    static const float weight[7] = {64.0f, 32.0f, 16.0f, 8.0f, 4.0f, 2.0f, 1.0f};
    static const float power[7] = {1.8446744073709552e19f, 4294967296.0f, 65536.0f, 256.0f, 16.0f, 4.0f, 2.0f};
    for (int b = 0; b < 7; b++) {
        vm take = v_gt(ak, v_set1(weight[b] - 0.5f));
        ak = v_select(take, v_sub(ak, v_set1(weight[b])), ak);
        p = v_select(take, v_mul(p, v_set1(power[b])), p);
    }
    return v_select(v_lt(k, v_set1(0.0f)), v_div(v_set1(1.0f), p), p);
}

/* 2^x, x clamped to [-126, 126]. */
static inline vf v_exp2(vf x)
{
    x = v_min(v_max(x, v_set1(-126.0f)), v_set1(126.0f));
    vf k = v_round_int(x);
    vf f = v_sub(x, k); /* exact, in [-1/2, 1/2] */
    vf p = v_set1(1.535336188319500e-4f);
    p = v_fma(p, f, v_set1(1.339887440266574e-3f));
    p = v_fma(p, f, v_set1(9.618437357674640e-3f));
    p = v_fma(p, f, v_set1(5.550332471162809e-2f));
    p = v_fma(p, f, v_set1(2.402264791363012e-1f));
    p = v_fma(p, f, v_set1(6.931472028550421e-1f));
    p = v_fma(p, f, v_set1(1.0f));
    return v_mul(p, v_exp2_int(k));
}

/* A unit complex number a + i sqrt(k) b, k >= 0 the same for all of them (the Mandelbulb's
 * polar angle keeps sqrt(k) = rho, the distance from the z axis, outside its powers, so that no
 * square root sits on the orbit's critical path). Squared by the double-angle formulas
 * cos 2t = 2 cos^2 t - 1, sin 2t = 2 sin t cos t (one rounding on the real part). */
static inline void unit_square(vf *a, vf *b)
{
    vf a2 = v_add(*a, *a); /* exact */
    *b = v_mul(a2, *b);
    *a = v_fms(a2, *a, v_set1(1.0f));
}

/* (a + i sqrt(k) b) (a1 + i sqrt(k) b1) */
static inline void unit_mul(vf k, vf *a, vf *b, vf a1, vf b1)
{
    vf na = v_fms(*a, a1, v_mul(k, v_mul(*b, b1)));
    *b = v_fma(*a, b1, v_mul(a1, *b));
    *a = na;
}

/* (a1 + i sqrt(k) b1)^n for whole n >= 2 by left-to-right binary powers, starting from the
 * square (a2, b2), which the caller computes directly from the coordinates (no root, one
 * rounding fewer than squaring the first power). */
static inline void unit_pow(int n, vf k, vf a1, vf b1, vf a2, vf b2, vf *an, vf *bn)
{
    int top = 1; /* n >> top == 1 */
    while (n >> (top + 1))
        top++;
    vf a = a2, b = b2;
    if ((n >> (top - 1)) & 1)
        unit_mul(k, &a, &b, a1, b1);
    for (int bit = top - 2; bit >= 0; bit--) {
        unit_square(&a, &b);
        if ((n >> bit) & 1)
            unit_mul(k, &a, &b, a1, b1);
    }
    *an = a;
    *bn = b;
}

/* x^n for whole n >= 0 by binary powers (an overflow gives +inf). */
static inline vf v_pow_int(vf x, int n)
{
    vf p = v_set1(1.0f);
    for (; n; n >>= 1, x = v_mul(x, x))
        if (n & 1)
            p = v_mul(p, x);
    return p;
}

/* The Mandelbulb's constants in kernel precision. */
typedef struct {
    int whole; /* the power when it is a whole number (2..32), else 0 */
    vf n;
    vf cap; /* r^n is capped at 2^60, so that |z| stays far inside float range */
} ub_bulb_consts;

static inline void bulb_consts(const ub_object *o, ub_bulb_consts *b)
{
    b->whole = o->power == floor(o->power) ? (int)o->power : 0;
    b->n = v_set1((float)o->power);
    b->cap = v_set1(1152921504606846976.0f); /* 2^60 */
}

/* One Mandelbulb step z^n + c, the triplex power z = r (sin t cos p, sin t sin p, cos t) ->
 * r^n (sin nt cos np, sin nt sin np, cos nt) (t the angle from +z, p the azimuth), with r^(n-1)
 * for the running derivative; r2 = |z|^2. r = 0 gives 0, and rho = 0 (on the z axis) the azimuth 0.
 *
 * Whole n (the default 8 and the common case), by de Moivre instead of angles:
 * cos nt + i sin nt = (cos t + i sin t)^n and cos np + i sin np = (cos p + i sin p)^n, from
 * cos t = z / r, sin t = rho / r, cos p = x / rho, sin p = y / rho, and their squares
 * ((z^2 - rho^2) + 2 i z rho) / r^2 and ((x^2 - y^2) + 2 i x y) / rho^2, with r^n by binary
 * powers of r^2. The same map as the angles', algebraically; its rounding differs (the
 * double-angle steps keep the error within a few ulps times n, as the angle path's atan2 and
 * sincos do; tests/native/test_formulas.py holds both to float64).
 *
 * Other n: theta = atan2(rho, z), p = atan2(y, x), r^n = exp2(n log2 r), all our own. */
static inline void bulb_step(const ub_bulb_consts *bc, vf x, vf y, vf z, vf r2, vf cx, vf cy, vf cz, vf *nx, vf *ny,
                             vf *nz, vf *rn1)
{
    const vf zero = v_set1(0.0f), one = v_set1(1.0f);
    const vm nonzero = v_gt(r2, zero);
    vf rho2 = v_fma(x, x, v_mul(y, y));
    vf r = v_sqrt(r2), rho = v_sqrt(rho2);
    if (bc->whole) {
        const int n = bc->whole;
        vf inv_r2 = v_select(nonzero, v_div(one, r2), zero);
        vf inv_rho2 = v_select(v_gt(rho2, zero), v_div(one, rho2), zero);
        vf inv_r = v_mul(r, inv_r2), inv_rho = v_mul(rho, inv_rho2);
        /* polar angle: cos + i sin = a + i rho b, so sin nt = rho bt */
        vf ct, bt, cp, sp;
        unit_pow(n, rho2, v_mul(z, inv_r), inv_r, v_mul(v_fms(z, z, rho2), inv_r2), v_mul(v_add(z, z), inv_r2),
                 &ct, &bt);
        unit_pow(n, one, v_mul(x, inv_rho), v_mul(y, inv_rho), v_mul(v_fms(x, x, v_mul(y, y)), inv_rho2),
                 v_mul(v_mul(v_add(x, x), y), inv_rho2), &cp, &sp);
        vf rn = v_pow_int(r2, n >> 1);
        if (n & 1)
            rn = v_mul(rn, r);
        rn = v_min(rn, bc->cap);
        vf rs = v_mul(v_mul(rn, rho), bt); /* r^n sin nt */
        *nx = v_fma(rs, cp, cx);
        *ny = v_fma(rs, sp, cy);
        *nz = v_fma(rn, ct, cz);
        *rn1 = v_mul(rn, inv_r);
        return;
    }
    /* log2 r = ln(r^2) / (2 ln 2) */
    vf lg = v_mul(v_log(v_select(nonzero, r2, one)), v_set1(0.721347520444f));
    vf rn = v_select(nonzero, v_exp2(v_min(v_mul(bc->n, lg), v_set1(60.0f))), zero);
    *rn1 = v_select(nonzero, v_div(rn, v_select(nonzero, r, one)), zero);
    vf st, ct, sp, cp;
    v_sincos(v_mul(bc->n, v_atan2(rho, z)), &st, &ct);
    v_sincos(v_mul(bc->n, v_atan2(y, x)), &sp, &cp);
    vf rs = v_mul(rn, st);
    *nx = v_fma(rs, cp, cx);
    *ny = v_fma(rs, sp, cy);
    *nz = v_fma(rn, ct, cz);
}

/* The Mandelbulb: z <- z^n + c in White and Nylander's triplex algebra (bulb_step).
 * Mandelbrot mode: z0 = c = the point; Julia mode: z0 = the point, c fixed. The estimate is the
 * analytic running derivative's, 0.5 log(r) r / dr with dr <- n r^(n-1) dr (+ 1 in Mandelbrot
 * mode): the Hubbard-Douady estimate the triplex map inherits without its proof (the map is not
 * conformal), so the kind is empirical. The potential is log r / n^k. */
static inline void de_mandelbulb(const ub_de_params *p, vm lanes, vf x, vf y, vf z, const int want, vf *dist, vf *iters,
                                 ub_de_extra *ex)
{
    const ub_object *o = p->obj;
    const int julia = o->julia_mode;
    const vf cx = julia ? v_set1((float)o->julia_c[0]) : x;
    const vf cy = julia ? v_set1((float)o->julia_c[1]) : y;
    const vf cz = julia ? v_set1((float)o->julia_c[2]) : z;
    const vf zero = v_set1(0.0f), one = v_set1(1.0f);
    const vf dr_add = julia ? zero : one;
    ub_bulb_consts bc;
    bulb_consts(o, &bc);
    vf r2 = v_fma(x, x, v_fma(y, y, v_mul(z, z)));
    vf dr = one, cnt = zero, trap = r2, gscale = one;
    const vf gstep = v_set1((float)(1.0 / o->power));
    vm active = lanes;
    for (int it = 0; it < p->max_iterations; it++) {
        vf nx, ny, nz, rn1;
        bulb_step(&bc, x, y, z, r2, cx, cy, cz, &nx, &ny, &nz, &rn1);
        dr = v_select(active, v_fma(v_mul(bc.n, rn1), dr, dr_add), dr);
        vf nr2 = v_fma(nx, nx, v_fma(ny, ny, v_mul(nz, nz)));
        x = v_select(active, nx, x);
        y = v_select(active, ny, y);
        z = v_select(active, nz, z);
        active = orbit_step(p, want, active, nr2, &r2, &cnt, &trap, &gscale, gstep);
        if (!m_bits(active))
            break;
    }
    vm escaped = v_gt(r2, p->bail2);
    vf lr2 = v_log(r2);
    vf est = v_div(v_mul(v_mul(v_sqrt(r2), lr2), v_set1(0.25f)), dr);
    /* An overflowed derivative (a point within float range of the set) is a hit, never a NaN step. */
    *dist = v_select(m_and(escaped, v_lt(est, v_set1(HUGE_VALF))), est, zero);
    *iters = cnt;
    if (want & UB_WANT_TRAP)
        ex->trap = v_sqrt(trap);
    if (want & UB_WANT_POTENTIAL)
        ex->potential = v_select(escaped, v_mul(v_mul(lr2, v_set1(0.5f)), gscale), zero);
    if (want & UB_WANT_JACOBIAN)
        ex->normal[0] = ex->normal[1] = ex->normal[2] = zero;
}

/* The Mandelbox's constants in kernel precision. */
typedef struct {
    vf L, nL;       /* box fold limits +-L */
    vf min2, fix2;  /* squared sphere fold radii */
    vf s, abs_s;    /* scale */
} ub_box_consts;

static inline void box_consts(const ub_object *o, ub_box_consts *b)
{
    b->L = v_set1((float)o->box_fold);
    b->nL = v_set1((float)-o->box_fold);
    b->min2 = v_set1((float)(o->min_radius * o->min_radius));
    b->fix2 = v_set1((float)(o->fixed_radius * o->fixed_radius));
    b->s = v_set1((float)o->box_scale);
    b->abs_s = v_set1((float)fabs(o->box_scale));
}

/* One Mandelbox step: the box fold (each coordinate beyond +-L reflected back: 2 clamp(x) - x),
 * the sphere fold k = fixed^2 / clamp(r^2, min^2, fixed^2) (1 outside the fixed radius, the
 * inversion between the radii, the constant fixed^2 / min^2 inside), then z <- s k fold(z) + c,
 * and the running scale's factor |s| k. Written as k (s fold(z)) + c, so that the scaling runs
 * beside the fold's root-free division instead of after it: the iteration is a chain of
 * dependent operations, and its length is the Mandelbox's speed. */
static inline void box_step(const ub_box_consts *b, vf x, vf y, vf z, vf cx, vf cy, vf cz, vf *nx, vf *ny, vf *nz,
                            vf *scale)
{
    const vf two = v_set1(2.0f);
    vf fx = v_fms(two, v_min(v_max(x, b->nL), b->L), x);
    vf fy = v_fms(two, v_min(v_max(y, b->nL), b->L), y);
    vf fz = v_fms(two, v_min(v_max(z, b->nL), b->L), z);
    vf f2 = v_fma(fx, fx, v_fma(fy, fy, v_mul(fz, fz)));
    vf k = v_div(b->fix2, v_min(v_max(f2, b->min2), b->fix2));
    *nx = v_fma(k, v_mul(b->s, fx), cx);
    *ny = v_fma(k, v_mul(b->s, fy), cy);
    *nz = v_fma(k, v_mul(b->s, fz), cz);
    *scale = v_mul(b->abs_s, k);
}

/* The Mandelbox (box_step): Mandelbrot mode: z0 = c = the point; Julia mode: c fixed. The
 * estimate is the running scale's, |z_n| / dr_n, dr <- |s| k dr (+ 1): the folds are isometries
 * or similarities piece by piece, but no proof bounds the distance by it, so the kind is
 * empirical. No potential. */
static inline void de_mandelbox(const ub_de_params *p, vm lanes, vf x, vf y, vf z, const int want, vf *dist, vf *iters,
                                ub_de_extra *ex)
{
    const ub_object *o = p->obj;
    const int julia = o->julia_mode;
    const vf cx = julia ? v_set1((float)o->julia_c[0]) : x;
    const vf cy = julia ? v_set1((float)o->julia_c[1]) : y;
    const vf cz = julia ? v_set1((float)o->julia_c[2]) : z;
    const vf zero = v_set1(0.0f), one = v_set1(1.0f);
    const vf dr_add = julia ? zero : one;
    ub_box_consts b;
    box_consts(o, &b);
    vf r2 = v_fma(x, x, v_fma(y, y, v_mul(z, z)));
    vf dr = one, cnt = zero, trap = r2, gscale = one;
    vm active = lanes;
    for (int it = 0; it < p->max_iterations; it++) {
        vf scale;
        box_step(&b, x, y, z, cx, cy, cz, &x, &y, &z, &scale);
        /* Stopped lanes iterate on unused (r2 and dr, all the result depends on, stay frozen):
         * a select per coordinate would lengthen the chain. */
        dr = v_select(active, v_fma(scale, dr, dr_add), dr);
        vf nr2 = v_fma(x, x, v_fma(y, y, v_mul(z, z)));
        active = orbit_step(p, want, active, nr2, &r2, &cnt, &trap, &gscale, one);
        if (!m_bits(active))
            break;
    }
    vm escaped = v_gt(r2, p->bail2);
    vf est = v_div(v_sqrt(r2), dr);
    *dist = v_select(m_and(escaped, v_lt(est, v_set1(HUGE_VALF))), est, zero);
    *iters = cnt;
    if (want & UB_WANT_TRAP)
        ex->trap = v_sqrt(trap);
    if (want & UB_WANT_POTENTIAL)
        ex->potential = zero;
    if (want & UB_WANT_JACOBIAN)
        ex->normal[0] = ex->normal[1] = ex->normal[2] = zero;
}

/* ------------------------------------------------------------------ kaleidoscopic IFS */

/* One KIFS step's constants in kernel precision (Knighty's formulation, 2010): fold planes
 * (unit n, offset d), the rotation R, the scale s and s o - o = o (s - 1). */
typedef struct {
    int planes, rotate;
    vf n[UB_MAX_KIFS_PLANES][4];
    vf r[9];
    vf s, os[3];
} ub_kifs_consts;

static inline void kifs_consts(const ub_object *o, ub_kifs_consts *k)
{
    k->planes = o->kifs_plane_count;
    for (int i = 0; i < k->planes; i++)
        for (int c = 0; c < 4; c++)
            k->n[i][c] = v_set1((float)o->kifs_planes[i][c]);
    k->rotate = o->kifs_rotate;
    for (int i = 0; i < 9; i++)
        k->r[i] = v_set1((float)o->kifs_rotation[i / 3][i % 3]);
    k->s = v_set1((float)o->kifs_scale);
    for (int c = 0; c < 3; c++)
        k->os[c] = v_set1((float)(o->kifs_offset[c] * (o->kifs_scale - 1.0)));
}

/* z <- s R F(z) - o (s - 1), F the folds in order: t = min(n.z - d, 0), z <- z - 2 t n (the
 * reflection in the plane of the points with n.z < d, the others unchanged). */
static inline void kifs_step(const ub_kifs_consts *k, vf *px, vf *py, vf *pz)
{
    vf x = *px, y = *py, z = *pz;
    const vf zero = v_set1(0.0f), m2 = v_set1(-2.0f);
    for (int i = 0; i < k->planes; i++) {
        const vf *n = k->n[i];
        vf t = v_mul(m2, v_min(v_sub(v_fma(n[0], x, v_fma(n[1], y, v_mul(n[2], z))), n[3]), zero));
        x = v_fma(t, n[0], x);
        y = v_fma(t, n[1], y);
        z = v_fma(t, n[2], z);
    }
    if (k->rotate) {
        const vf *r = k->r;
        vf rx = v_fma(r[0], x, v_fma(r[1], y, v_mul(r[2], z)));
        vf ry = v_fma(r[3], x, v_fma(r[4], y, v_mul(r[5], z)));
        vf rz = v_fma(r[6], x, v_fma(r[7], y, v_mul(r[8], z)));
        x = rx, y = ry, z = rz;
    }
    *px = v_fms(k->s, x, k->os[0]);
    *py = v_fms(k->s, y, k->os[1]);
    *pz = v_fms(k->s, z, k->os[2]);
}

/* Signed distance bound (1-Lipschitz, exact or below) of the KIFS's final shape. */
static inline vf kifs_shape_distance(const ub_object *o, vf x, vf y, vf z)
{
    const vf size = v_set1((float)o->kifs_size), zero = v_set1(0.0f);
    const vf inv_sqrt3 = v_set1(0.577350269190f);
    switch (o->kifs_shape) {
    case UB_KIFS_BOX: {
        vf qx = v_sub(v_abs(x), size), qy = v_sub(v_abs(y), size), qz = v_sub(v_abs(z), size);
        vf ox = v_max(qx, zero), oy = v_max(qy, zero), oz = v_max(qz, zero);
        vf outside = v_sqrt(v_fma(ox, ox, v_fma(oy, oy, v_mul(oz, oz))));
        return v_add(outside, v_min(v_max(qx, v_max(qy, qz)), zero));
    }
    case UB_KIFS_TETRAHEDRON: {
        /* Faces -x-y-z, -x+y+z, x-y+z, x+y-z = size: vertices (size, size, size) and its sign flips
         * in pairs. Each face's form has gradient length sqrt 3. */
        vf a = v_sub(v_sub(v_sub(zero, x), y), z);
        vf b = v_add(v_sub(y, x), z), c = v_add(v_sub(x, y), z), d = v_sub(v_add(x, y), z);
        return v_mul(v_sub(v_max(v_max(a, b), v_max(c, d)), size), inv_sqrt3);
    }
    case UB_KIFS_OCTAHEDRON:
        return v_mul(v_sub(v_add(v_add(v_abs(x), v_abs(y)), v_abs(z)), size), inv_sqrt3);
    default:
        return v_sub(v_sqrt(v_fma(x, x, v_fma(y, y, v_mul(z, z)))), size);
    }
}

/* The kaleidoscopic IFS: n = max_iterations steps of f(z) = s R F(z) - o (s - 1), then the
 * final shape S's distance bound D, divided by the running scale s^n. Exact, by this argument:
 * every fold is 1-Lipschitz (points on one side of the plane keep their distance; a pair on
 * opposite sides comes closer), R is an isometry, so f is s-Lipschitz and f^n s^n-Lipschitz;
 * D is 1-Lipschitz and <= 0 on S. Hence g(p) = D(f^n(p)) / s^n is 1-Lipschitz and <= 0 on the
 * level-n set A_n = {p : f^n(p) in S}, so g(p) <= |p - q| for every q in A_n: g never
 * oversteps A_n, which is what is drawn. An orbit that passes the escape radius (>= rho, see
 * scene.c) at step k < n is at least (|z_k| - rho) / s^k from A_n: f^k sends A_n into
 * A_(n-k), which lies in |z| <= rho. Where the maps send S into itself (the Menger sponge in a
 * box, the Sierpinski tetrahedron in a tetrahedron, the octahedral flake in an octahedron),
 * A_n holds the limit attractor as well, so the bound is one for the attractor too. The
 * escape count is the steps taken, the orbit trap min |z_k|; no potential. */
static inline void de_kifs(const ub_de_params *p, vm lanes, vf x, vf y, vf z, const int want, vf *dist, vf *iters,
                           ub_de_extra *ex)
{
    const ub_object *o = p->obj;
    ub_kifs_consts k;
    kifs_consts(o, &k);
    const vf zero = v_set1(0.0f), one = v_set1(1.0f);
    vf r2 = v_fma(x, x, v_fma(y, y, v_mul(z, z)));
    vf dr = one, cnt = zero, trap = r2, gscale = one;
    vm active = lanes;
    for (int it = 0; it < p->max_iterations; it++) {
        vf nx = x, ny = y, nz = z;
        kifs_step(&k, &nx, &ny, &nz);
        dr = v_select(active, v_mul(dr, k.s), dr);
        vf nr2 = v_fma(nx, nx, v_fma(ny, ny, v_mul(nz, nz)));
        x = v_select(active, nx, x);
        y = v_select(active, ny, y);
        z = v_select(active, nz, z);
        active = orbit_step(p, want, active, nr2, &r2, &cnt, &trap, &gscale, one);
        if (!m_bits(active))
            break;
    }
    vm escaped = v_gt(r2, p->bail2);
    vf ball = v_sub(v_sqrt(r2), v_set1((float)o->kifs_rho));
    vf d = v_select(escaped, ball, kifs_shape_distance(o, x, y, z));
    /* s^n past float range (a point that never escaped over ~80 steps): a hit, never a NaN. */
    *dist = v_select(v_lt(dr, v_set1(HUGE_VALF)), v_div(d, dr), zero);
    *iters = cnt;
    if (want & UB_WANT_TRAP)
        ex->trap = v_sqrt(trap);
    if (want & UB_WANT_POTENTIAL)
        ex->potential = zero;
    if (want & UB_WANT_JACOBIAN)
        ex->normal[0] = ex->normal[1] = ex->normal[2] = zero;
}

/* ------------------------------------------------------------------ hybrids */

/* A hybrid: the entries (formula, count) applied in turn, cycling, max_iterations steps in all,
 * one orbit and one running derivative dr through them: a Mandelbulb step z <- z^n + c,
 * dr <- n r^(n-1) dr (+1), a Mandelbox step z <- s k fold(z) + c, dr <- |s| k dr (+1), a KIFS
 * step z <- s R F(z) - o (s - 1), dr <- s dr (no c), each with its own kind's parameters; c the
 * point (Mandelbrot form) or julia_c. The estimate is the Mandelbulb's 0.5 log r r / dr when a
 * Mandelbulb step is among them, else the folds' r / dr. Nothing proves either for a mixture:
 * the kind is empirical and marched with the empirical kinds' guards. */
static inline void de_hybrid(const ub_de_params *p, vm lanes, vf x, vf y, vf z, const int want, vf *dist, vf *iters,
                             ub_de_extra *ex)
{
    const ub_object *o = p->obj;
    const int julia = o->julia_mode;
    const vf cx = julia ? v_set1((float)o->julia_c[0]) : x;
    const vf cy = julia ? v_set1((float)o->julia_c[1]) : y;
    const vf cz = julia ? v_set1((float)o->julia_c[2]) : z;
    const vf zero = v_set1(0.0f), one = v_set1(1.0f);
    const vf dr_add = julia ? zero : one;
    ub_bulb_consts bc;
    bulb_consts(o, &bc);
    ub_box_consts b;
    box_consts(o, &b);
    ub_kifs_consts k;
    kifs_consts(o, &k);
    vf r2 = v_fma(x, x, v_fma(y, y, v_mul(z, z)));
    vf dr = one, cnt = zero, trap = r2, gscale = one;
    vm active = lanes;
    int entry = 0, done = 0;
    for (int it = 0; it < p->max_iterations; it++) {
        vf nx, ny, nz, ndr;
        switch (o->hybrid_formula[entry]) {
        case UB_HYBRID_MANDELBULB: {
            vf rn1;
            bulb_step(&bc, x, y, z, r2, cx, cy, cz, &nx, &ny, &nz, &rn1);
            ndr = v_fma(v_mul(bc.n, rn1), dr, dr_add);
            break;
        }
        case UB_HYBRID_MANDELBOX: {
            vf scale;
            box_step(&b, x, y, z, cx, cy, cz, &nx, &ny, &nz, &scale);
            ndr = v_fma(scale, dr, dr_add);
            break;
        }
        default:
            nx = x, ny = y, nz = z;
            kifs_step(&k, &nx, &ny, &nz);
            ndr = v_mul(dr, k.s);
            break;
        }
        dr = v_select(active, ndr, dr);
        vf nr2 = v_fma(nx, nx, v_fma(ny, ny, v_mul(nz, nz)));
        x = v_select(active, nx, x);
        y = v_select(active, ny, y);
        z = v_select(active, nz, z);
        active = orbit_step(p, want, active, nr2, &r2, &cnt, &trap, &gscale, one);
        if (!m_bits(active))
            break;
        if (++done >= o->hybrid_repeat[entry]) {
            done = 0;
            entry = entry + 1 < o->hybrid_count ? entry + 1 : 0;
        }
    }
    vm escaped = v_gt(r2, p->bail2);
    vf r = v_sqrt(r2);
    vf est = o->hybrid_has_bulb ? v_div(v_mul(v_mul(r, v_log(r2)), v_set1(0.25f)), dr) : v_div(r, dr);
    *dist = v_select(m_and(escaped, v_lt(est, v_set1(HUGE_VALF))), est, zero);
    *iters = cnt;
    if (want & UB_WANT_TRAP)
        ex->trap = v_sqrt(trap);
    if (want & UB_WANT_POTENTIAL)
        ex->potential = zero;
    if (want & UB_WANT_JACOBIAN)
        ex->normal[0] = ex->normal[1] = ex->normal[2] = zero;
}
