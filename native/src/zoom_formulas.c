/* Deep zoom of the formula kinds (issue 22): the Mandelbulb, the Mandelbox, the KIFS and the
 * hybrid at p = anchor + 10^-zoom u, in scalar double.
 *
 * The same estimates as formulas.h's float32 kernels, step for step in meaning: the same
 * parameters (rounded to float first, as the kernels read them, so that every path iterates the
 * same set and a zoom of 0.001 draws what zoom 0 drew), iteration counts, escape radius, orbit
 * trap, escape count, potential and estimate formula; only the precision differs. Normals need
 * nothing here: these kinds take the distance gradient (or, the Mandelbulb, the potential's), and
 * the kernels' central differences call this estimate, in local units.
 *
 * No perturbation: the formulas are not polynomials in the point (folds, the triplex angles), so
 * there is no exact difference iteration; the path ends where double stops resolving the hit
 * threshold, UB_ZOOM_FORMULA_MAX (zoom.h). Compiled once, like zoom.c, so that every kernel gets
 * the same bits; only IEEE + - * / sqrt and the core's own ubmath.h functions (no libm, no fma:
 * the float32 kernels' fused a b + c is a b + c here, rounded twice in double). */
#include <math.h>
#include <string.h>

#include "scene.h"
#include "ubmath.h"
#include "zoom.h"

static double as_float(double x) { return (double)(float)x; }

static double norm2_of3(const double z[3]) { return z[0] * z[0] + z[1] * z[1] + z[2] * z[2]; }

static double clamp(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }

/* asin s for 0 <= s <= 1/sqrt 2: the series below 1/2, pi/2 - acos s above (well conditioned
 * there), both within an ulp or two of pi/2. */
static double asin_small(double s)
{
    if (s <= 0.5)
        return s + ub__asin_tail(s, s * s);
    return (UB__PIO2_HI - ub_acos(s)) + UB__PIO2_LO;
}

/* atan2(y, x) in [-pi, pi] from ubmath.h's arc sine: the angle of the smaller coordinate
 * (never acos of a cosine near 1, whose rounding would cost half the digits), then its octant.
 * atan2(0, 0) = 0; y = -0 counts as positive (as formulas.h's v_atan2). */
static double atan2_of(double y, double x)
{
    double ax = fabs(x), ay = fabs(y);
    double hi = fmax(ax, ay), lo = fmin(ax, ay);
    if (!(hi > 0.0))
        return 0.0;
    double h = ub_hypot(ax, ay);
    double a = asin_small(lo / h);
    if (ay > ax)
        a = (UB__PIO2_HI - a) + UB__PIO2_LO;
    if (x < 0.0)
        a = (2.0 * UB__PIO2_HI - a) + 2.0 * UB__PIO2_LO;
    return y < 0.0 ? -a : a;
}

/* ------------------------------------------------------------------ the Mandelbulb */

typedef struct {
    int whole; /* the power when it is a whole number, else 0 (formulas.h's bulb_consts) */
    double n, gstep, cap;
} bulb_consts;

static void bulb_consts_of(const ub_object *o, bulb_consts *b)
{
    b->whole = o->power == floor(o->power) ? (int)o->power : 0;
    b->n = as_float(o->power);
    b->gstep = as_float(1.0 / o->power);
    b->cap = 0x1p60;
}

/* (a + i sqrt(k) b)^2 and products: formulas.h's unit_square, unit_mul and unit_pow. */
static void unit_square(double *a, double *b)
{
    double a2 = *a + *a;
    *b = a2 * *b;
    *a = a2 * *a - 1.0;
}

static void unit_mul(double k, double *a, double *b, double a1, double b1)
{
    double na = *a * a1 - k * (*b * b1);
    *b = *a * b1 + a1 * *b;
    *a = na;
}

static void unit_pow(int n, double k, double a1, double b1, double a2, double b2, double *an, double *bn)
{
    int top = 1;
    while (n >> (top + 1))
        top++;
    double a = a2, b = b2;
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

static double pow_int(double x, int n)
{
    double p = 1.0;
    for (; n; n >>= 1, x = x * x)
        if (n & 1)
            p = p * x;
    return p;
}

/* One triplex step z^n + c (formulas.h's bulb_step: de Moivre for whole n, else the angles),
 * with r^(n-1) for the running derivative; r2 = |z|^2. */
static void bulb_step(const bulb_consts *bc, const double z[3], double r2, const double c[3], double out[3],
                      double *rn1)
{
    const double x = z[0], y = z[1], w = z[2];
    double rho2 = x * x + y * y;
    double r = sqrt(r2), rho = sqrt(rho2);
    if (bc->whole) {
        const int n = bc->whole;
        double inv_r2 = r2 > 0.0 ? 1.0 / r2 : 0.0, inv_rho2 = rho2 > 0.0 ? 1.0 / rho2 : 0.0;
        double inv_r = r * inv_r2, inv_rho = rho * inv_rho2;
        double ct, bt, cp, sp;
        unit_pow(n, rho2, w * inv_r, inv_r, (w * w - rho2) * inv_r2, (w + w) * inv_r2, &ct, &bt);
        unit_pow(n, 1.0, x * inv_rho, y * inv_rho, (x * x - y * y) * inv_rho2, ((x + x) * y) * inv_rho2, &cp, &sp);
        double rn = pow_int(r2, n >> 1);
        if (n & 1)
            rn = rn * r;
        rn = fmin(rn, bc->cap);
        double rs = rn * rho * bt; /* r^n sin nt */
        out[0] = rs * cp + c[0];
        out[1] = rs * sp + c[1];
        out[2] = rn * ct + c[2];
        *rn1 = rn * inv_r;
        return;
    }
    double rn = r2 > 0.0 ? fmin(ub_pow(r2, 0.5 * bc->n), bc->cap) : 0.0;
    *rn1 = r2 > 0.0 ? rn / r : 0.0;
    double t = bc->n * atan2_of(rho, w), p = bc->n * atan2_of(y, x);
    double rs = rn * ub_sin(t);
    out[0] = rs * ub_cos(p) + c[0];
    out[1] = rs * ub_sin(p) + c[1];
    out[2] = rn * ub_cos(t) + c[2];
}

/* ------------------------------------------------------------------ the Mandelbox */

typedef struct {
    double L, min2, fix2, s, abs_s;
} box_consts;

static void box_consts_of(const ub_object *o, box_consts *b)
{
    b->L = as_float(o->box_fold);
    b->min2 = as_float(o->min_radius * o->min_radius);
    b->fix2 = as_float(o->fixed_radius * o->fixed_radius);
    b->s = as_float(o->box_scale);
    b->abs_s = as_float(fabs(o->box_scale));
}

/* formulas.h's box_step: box fold, sphere fold, z <- k (s fold(z)) + c; returns |s| k. */
static double box_step(const box_consts *b, double z[3], const double c[3])
{
    double f[3];
    for (int i = 0; i < 3; i++)
        f[i] = 2.0 * clamp(z[i], -b->L, b->L) - z[i];
    double k = b->fix2 / clamp(norm2_of3(f), b->min2, b->fix2);
    for (int i = 0; i < 3; i++)
        z[i] = k * (b->s * f[i]) + c[i];
    return b->abs_s * k;
}

/* ------------------------------------------------------------------ the KIFS */

typedef struct {
    int planes, rotate;
    double n[UB_MAX_KIFS_PLANES][4], r[3][3], s, os[3];
} kifs_consts;

static void kifs_consts_of(const ub_object *o, kifs_consts *k)
{
    k->planes = o->kifs_plane_count;
    for (int i = 0; i < k->planes; i++)
        for (int c = 0; c < 4; c++)
            k->n[i][c] = as_float(o->kifs_planes[i][c]);
    k->rotate = o->kifs_rotate;
    for (int i = 0; i < 9; i++)
        k->r[i / 3][i % 3] = as_float(o->kifs_rotation[i / 3][i % 3]);
    k->s = as_float(o->kifs_scale);
    for (int c = 0; c < 3; c++)
        k->os[c] = as_float(o->kifs_offset[c] * (o->kifs_scale - 1.0));
}

/* formulas.h's kifs_step: z <- s R F(z) - o (s - 1). */
static void kifs_step(const kifs_consts *k, double z[3])
{
    for (int i = 0; i < k->planes; i++) {
        const double *n = k->n[i];
        double t = -2.0 * fmin(n[0] * z[0] + n[1] * z[1] + n[2] * z[2] - n[3], 0.0);
        for (int c = 0; c < 3; c++)
            z[c] = t * n[c] + z[c];
    }
    if (k->rotate) {
        double r[3];
        for (int i = 0; i < 3; i++)
            r[i] = k->r[i][0] * z[0] + k->r[i][1] * z[1] + k->r[i][2] * z[2];
        memcpy(z, r, sizeof r);
    }
    for (int c = 0; c < 3; c++)
        z[c] = k->s * z[c] - k->os[c];
}

/* formulas.h's kifs_shape_distance. */
static double kifs_shape_distance(const ub_object *o, const double z[3])
{
    const double size = as_float(o->kifs_size), inv_sqrt3 = 0.57735026918962576451;
    const double x = z[0], y = z[1], w = z[2];
    switch (o->kifs_shape) {
    case UB_KIFS_BOX: {
        double q[3] = {fabs(x) - size, fabs(y) - size, fabs(w) - size};
        double out[3] = {fmax(q[0], 0.0), fmax(q[1], 0.0), fmax(q[2], 0.0)};
        return sqrt(norm2_of3(out)) + fmin(fmax(q[0], fmax(q[1], q[2])), 0.0);
    }
    case UB_KIFS_TETRAHEDRON: {
        double a = -x - y - w, b = y - x + w, c = x - y + w, d = x + y - w;
        return (fmax(fmax(a, b), fmax(c, d)) - size) * inv_sqrt3;
    }
    case UB_KIFS_OCTAHEDRON:
        return (fabs(x) + fabs(y) + fabs(w) - size) * inv_sqrt3;
    default:
        return sqrt(norm2_of3(z)) - size;
    }
}

/* ------------------------------------------------------------------ the orbit */

/* The one formula of a non-hybrid kind (a hybrid's entries name theirs). */
static int formula_of_kind(ub_fractal_kind kind)
{
    return kind == UB_KIND_MANDELBULB ? UB_HYBRID_MANDELBULB
           : kind == UB_KIND_MANDELBOX ? UB_HYBRID_MANDELBOX
                                       : UB_HYBRID_KIFS;
}

/* One orbit of the object's formula (a hybrid's entries in turn, or its one formula every
 * step): the escape-time loop of formulas.h's de_* with orbit_step's bookkeeping. */
typedef struct {
    double z[3], r2, dr, trap, gscale;
    int count;
} orbit_state;

static void run_orbit(const ub_object *o, const double p[3], orbit_state *s)
{
    const int julia = o->julia_mode && o->kind != UB_KIND_KIFS;
    double c[3];
    for (int i = 0; i < 3; i++)
        c[i] = julia ? as_float(o->julia_c[i]) : p[i];
    const double dr_add = julia ? 0.0 : 1.0;
    const double bail2 = as_float(o->bailout * o->bailout);
    /* Every formula's constants, as de_hybrid does: a few dozen roundings, next to the orbit's
     * iterations nothing. */
    bulb_consts bc;
    box_consts b;
    kifs_consts k;
    bulb_consts_of(o, &bc);
    box_consts_of(o, &b);
    kifs_consts_of(o, &k);
    /* The potential's scale per step: 1 / power for the Mandelbulb alone (the others have none). */
    const double gstep = o->kind == UB_KIND_MANDELBULB ? bc.gstep : 1.0;

    memcpy(s->z, p, sizeof s->z);
    s->r2 = norm2_of3(p);
    s->dr = 1.0;
    s->trap = s->r2;
    s->gscale = 1.0;
    s->count = 0;
    const int hybrid = o->kind == UB_KIND_HYBRID, single = formula_of_kind(o->kind);
    int entry = 0, done = 0;
    for (int it = 0; it < o->max_iterations; it++) {
        int formula = hybrid ? o->hybrid_formula[entry] : single;
        switch (formula) {
        case UB_HYBRID_MANDELBULB: {
            double next[3], rn1;
            bulb_step(&bc, s->z, s->r2, c, next, &rn1);
            memcpy(s->z, next, sizeof next);
            s->dr = bc.n * rn1 * s->dr + dr_add;
            break;
        }
        case UB_HYBRID_MANDELBOX:
            s->dr = box_step(&b, s->z, c) * s->dr + dr_add;
            break;
        default:
            kifs_step(&k, s->z);
            s->dr = s->dr * k.s;
            break;
        }
        double nr2 = norm2_of3(s->z);
        s->r2 = nr2;
        s->trap = fmin(s->trap, nr2);
        s->gscale *= gstep;
        s->count++;
        if (nr2 > bail2)
            break;
        if (hybrid && ++done >= o->hybrid_repeat[entry]) {
            done = 0;
            entry = entry + 1 < o->hybrid_count ? entry + 1 : 0;
        }
    }
}

void ub_zoom_formula_estimate(const ub_object *o, const double u[3], ub_zoom_result *res)
{
    const ub_zoom *zm = &o->zoom;
    double p[3];
    for (int i = 0; i < 3; i++)
        p[i] = zm->anchor_q[i] + zm->scale * u[i];
    orbit_state s;
    run_orbit(o, p, &s);
    const int escaped = s.r2 > as_float(o->bailout * o->bailout);
    const int log_estimate = o->kind == UB_KIND_MANDELBULB || (o->kind == UB_KIND_HYBRID && o->hybrid_has_bulb);
    double lr2 = escaped ? ub_log(s.r2) : 0.0, dist;
    if (o->kind == UB_KIND_KIFS) {
        /* The level-n set's bound: an escaped orbit's ball, else the final shape's; s^n past
         * double range (never in practice: UB_MAX_ITERATIONS steps of s <= 10) is a hit. */
        double d = escaped ? sqrt(s.r2) - as_float(o->kifs_rho) : kifs_shape_distance(o, s.z);
        dist = s.dr < HUGE_VAL ? d / s.dr : 0.0;
    } else {
        double est = log_estimate ? sqrt(s.r2) * lr2 * 0.25 / s.dr : sqrt(s.r2) / s.dr;
        dist = escaped && est < HUGE_VAL ? est : 0.0;
    }
    res->dist = dist / zm->scale; /* fractal units -> local units */
    res->iterations = s.count;
    res->trap = sqrt(s.trap);
    res->potential = o->kind == UB_KIND_MANDELBULB && escaped ? lr2 * 0.5 * s.gscale : 0.0;
    res->normal[0] = res->normal[1] = res->normal[2] = 0.0; /* no Jacobian: gradient normals */
    res->rebases = 0; /* no perturbation, no glitches */
}

/* ------------------------------------------------------------------ set-up */

/* The growth of a point's distance from the set per step near its surface (the orbit's
 * derivative there). The folds: their scale |s| (the sphere fold only adds to it): a point 10
 * times closer needs ln 10 / ln |s| more steps (3.3 for s = 2; measured 2.4 per decade from 1e-3 to
 * 1e-12 of the default Mandelbox's surface, median escape count of 400 points). The KIFS: its
 * level-n set has detail down to s^-n, exactly. The Mandelbulb: its n r^(n-1) is n only at r = 1;
 * near the surface the orbit passes r < 1, and the measured growth is about sqrt n per step (power
 * 8: 1.9 per decade median, 2.3 at the 90th percentile, where ln 10 / ln 8 says 1.1), so sqrt n is
 * taken. */
static double growth_per_step(const ub_object *o, int formula)
{
    switch (formula) {
    case UB_HYBRID_MANDELBULB:
        return sqrt(as_float(o->power));
    case UB_HYBRID_MANDELBOX:
        return as_float(fabs(o->box_scale));
    default:
        return as_float(o->kifs_scale);
    }
}

/* Iterations that follow the zoom: max_iterations + ceil(zoom ln 10 / ln g), g the growth per
 * step (a hybrid's: the geometric mean over one cycle of its entries; measured for the default
 * Mandelbulb-Mandelbox cycle: 1.5 to 2 per decade, the rule gives 2.7). The level-n set the
 * kernels draw (the points still inside after n steps) lies within g^-n of the true set, in the
 * base count's view units; adding a decade of zoom and ln 10 / ln g steps keeps that distance the
 * same share of the view, so a fly-in shows the detail it showed at zoom 0 all the way down, and
 * each added step changes the set by less than the base count already left unresolved (sub-pixel
 * where the zoom 0 frame was resolved). Unlike the quadratic map's 7 per decade (zoom.h), these
 * rates are the formulas' own scales. */
static int zoom_iterations(const ub_object *o, double zoom)
{
    double log_growth = 0.0;
    if (o->kind == UB_KIND_HYBRID) {
        int steps = 0;
        for (int e = 0; e < o->hybrid_count; e++) {
            log_growth += o->hybrid_repeat[e] * ub_log(growth_per_step(o, o->hybrid_formula[e]));
            steps += o->hybrid_repeat[e];
        }
        log_growth /= steps;
    } else {
        log_growth = ub_log(growth_per_step(o, formula_of_kind(o->kind)));
    }
    double extra = ceil(zoom * ub_log(10.0) / log_growth);
    double total = o->max_iterations + (extra < UB_MAX_ITERATIONS ? extra : UB_MAX_ITERATIONS);
    return total < UB_MAX_ITERATIONS ? (int)total : UB_MAX_ITERATIONS;
}

const char *ub_zoom_formula_prepare(ub_object *obj, double zoom, const ub_fixed anchor[3])
{
    if (zoom > UB_ZOOM_FORMULA_MAX)
        return UB_ZOOM_FORMULA_LIMIT_MESSAGE;
    ub_zoom *zm = &obj->zoom;
    zm->zoom = zoom;
    zm->scale = ub_pow(10.0, -zoom);
    double p2 = 0.0;
    for (int k = 0; k < 3; k++) {
        zm->anchor_q[k] = ub_fixed_to_double(&anchor[k]);
        p2 += zm->anchor_q[k] * zm->anchor_q[k];
    }
    zm->anchor_q[3] = 0.0;
    zm->magnitude = fmax(1.0, sqrt(p2));
    obj->max_iterations = zoom_iterations(obj, zoom);
    /* The empirical kinds' cap on a step (scene.c: a share of the bounding radius, world units)
     * is about the fractal's size: in the zoomed view it is 10^zoom times as many local units,
     * as in the same view at zoom 0 with the camera flown in. Where it applied, it is raised by
     * that; ub_object_from_input then takes the user's own Max Step (world units of the view)
     * again: min(user, cap / scale). */
    if (!obj->exact && obj->bound_radius > 0.0) {
        double cap = UB_EMPIRICAL_MAX_STEP * obj->bound_radius * obj->sigma_min;
        if (obj->max_step >= cap)
            obj->max_step = cap / zm->scale;
    }
    ub_zoom_view_ball(obj, anchor);
    return NULL;
}
