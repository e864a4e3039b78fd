/* Deep zoom (issue 18): the object's local point u is the fractal's point p = anchor + u 10^-zoom.
 *
 * Precision. The march itself stays in the kernels' float32, in local units: there the camera,
 * the pixel footprint and the hit threshold have the sizes they have at zoom 0, so float32
 * resolves the pixel as well as it does today. Only the distance estimate has to see the fractal
 * at 10^-zoom, and it runs in double, in one of two paths chosen per object and
 * render from the hit threshold in fractal units (ub_zoom_choose_path):
 *   - double: z0 = Q + 10^-zoom B u iterated in double, while the threshold is above 2^-36 of the
 *     fractal's coordinates (about zoom 7 at a pixel threshold);
 *   - perturbation past that: a reference orbit Z_k of the anchor's quaternion Q computed once in
 *     fixed point (288 fraction bits, ~86 digits), stored in double, and per point the difference
 *     delta_k = z_k - Z_k in double: delta_{k+1} = Z delta + delta Z + delta^2 (+ delta_c for the
 *     Mandelbrot set): exact, the quaternions' order kept. Where |Z_k + delta_k| < |delta_k| the
 *     reference no longer serves (glitch) and the point is rebased onto the critical orbit
 *     (0, mu, mu^2 + mu, ...) with delta = z (Zhuoran's rebasing).
 * The kernels run it lane-parallel in double (zoom_lanes.h, compiled per kernel); zoom.c keeps the
 * scalar reference (ub_zoom_estimate: start, iterations, finish) the tests compare them with. Only IEEE
 * + - * / sqrt (never fused) and the core's own log (ubmath.h) reach the results, so every kernel and
 * the reference agree bit for bit, and the anchor's arithmetic is integer (the same bits on every
 * platform).
 *
 * Why fixed point and not quad-double or mpmath: the anchor and the reference orbits are bounded
 * (|z| <= bailout), so a fixed binary point loses nothing; integer limbs have no rounding modes,
 * no renormalisation, and parse and print decimals exactly; mpmath would put Python on the
 * render's path. */
#ifndef UNBOUND_ZOOM_H
#define UNBOUND_ZOOM_H

#include <stdint.h>

/* Fixed point: two's complement, limb[0] most significant; 2 integer limbs (|x| < 2^63), 9
 * fraction limbs (2^-288 ~ 2e-87). */
#define UB_FIXED_LIMBS 11
#define UB_FIXED_INT_LIMBS 2
typedef struct {
    uint32_t limb[UB_FIXED_LIMBS];
} ub_fixed;

/* Deepest zoom: the anchor and reference keep 86 digits; the deltas need zoom + ~20 of them. */
#define UB_MAX_ZOOM 60.0
/* Longest anchor string (three numbers of up to ~100 digits each, with room to spare). */
#define UB_MAX_ANCHOR 512
/* Reference orbits are stored for at most this many iterations; a zoomed object's iteration
 * count is clamped to it. */
#define UB_ZOOM_MAX_ORBIT 1024
/* Iterations that follow the zoom: max_iterations + ceil(UB_ZOOM_ITERATIONS_PER_DECADE zoom).
 * Near a Julia surface the escape count grows about 6 per decade (issue 18, measured for
 * mu = -0.2+0.8i: 40, 104, 160, 254 at zoom 10, 20, 30, 45); 3.3 on the unit ball (mu = 0:
 * |z| = 1 + d escapes after log2(log 4 / d) iterations). 7 keeps a margin over both. */
#define UB_ZOOM_ITERATIONS_PER_DECADE 7.0
/* A zoomed object is drawn within this radius (object units) of its local origin, the anchor:
 * the whole set's bounding ball is 10^zoom local units across, far beyond float32's reach. */
#define UB_ZOOM_VIEW_RADIUS 64.0

/* Skip table: entry K holds the first K iterations of the perturbation as a quadratic map of the
 * start's delta (the series approximation, to second order: delta_K = A_K delta + B_K(delta, delta),
 * + delta_c's share for the Mandelbrot set), for every K (no stride: a point skips as far as its own
 * delta allows). What the second order drops per iteration is 2 a b + b^2 (a, b the first- and
 * second-order parts); it is below UB_ZOOM_SKIP_TOLERANCE of the linear term Z delta + delta Z
 * while |b_j| <= that fraction of |Z_j| / 2, i.e. while |delta_j| is below about
 * sqrt(UB_ZOOM_SKIP_TOLERANCE) = 2^-15 of |Z_j|, where a first-order table stops at 2^-30: some 24
 * iterations further at zoom 30 (delta gains ~0.6 bits an iteration). Per iteration the relative
 * error is the same 2^-30 as the first-order table's: ~1e-9 of what is kept, as if the point moved by
 * ~1e-7 of its local offset over a hundred skipped iterations, below float32's resolution of that
 * offset (measured: the referee's figures do not change from 2^-40 to 2^-30). */
#define UB_ZOOM_SKIP_TOLERANCE 0x1p-30
/* A point whose delta has grown to UB_ZOOM_DIRECT_RATIO of its orbit's scale leaves the reference
 * and iterates z <- z^2 + c directly in double (cheaper: no reference, no glitch test). With
 * |delta|^2 >= 2^-34 (|z|^2 + |c|^2), a step's rounding (2^-53 of |z|^2 + |c|) is at most ~2^-36 of
 * delta: 64 times below UB_ZOOM_SKIP_TOLERANCE. |c| is in the scale because the rounding of + c is
 * absolute: a delta tiny beside c (an orbit near 0, a glitch) must stay on a reference (rebased).
 * After the second-order skip delta is ~2^-15 of |Z|, so the points leave the reference at once. */
#define UB_ZOOM_DIRECT_RATIO 0x1p-34

/* The pairs a <= b of a quaternion's components: the second-order coefficients per component. */
#define UB_ZOOM_PAIRS 10
static const int zoom_pair[UB_ZOOM_PAIRS][2] = {{0, 0}, {0, 1}, {0, 2}, {0, 3}, {1, 1},
                                                {1, 2}, {1, 3}, {2, 2}, {2, 3}, {3, 3}};

/* The formula kinds (Mandelbulb, Mandelbox, KIFS, hybrid: zoom_formulas.c) zoom in double only:
 * their maps are no polynomials in the point (folds, the triplex angles), so no perturbation
 * carries them past double. Double rounds the point and each step to ~2^-53 of the coordinates,
 * some 1e-15 of fractal units over an orbit (|p| ~ 1, a few ulps' growth); the path is right while
 * that stays about 1 % of the hit threshold. A pixel threshold is ~1e-3 local units (a 2000-pixel
 * frame seen from 3 units away), 10^-(zoom + 3) fractal units: 1e-15 is 1 % of it at zoom 10. The
 * quaternion kinds' switch (2^-36 of the coordinates, ub_zoom_choose_path) is 100 times stricter
 * because there the perturbation takes over at no visible cost; here there is nothing to switch
 * to, and 1 % of a threshold is below what depth or the gradient normals show (measured:
 * README, Deep zoom: at zoom 10 the estimate near the surface is within 5e-7 local units of long double). */
#define UB_ZOOM_FORMULA_MAX 10.0
#define UB_ZOOM_FORMULA_LIMIT_MESSAGE                                                                      \
    "zoom: the Mandelbulb, Mandelbox, KIFS and hybrid kinds zoom to 10 at most (double precision; past "  \
    "it double no longer resolves a pixel, and only the quaternion kinds go deeper, by perturbation)"
#define UB_ZOOM_KINDS_MESSAGE                                                                              \
    "zoom and zoom_anchor apply to the quaternion Julia and Mandelbrot kinds (to 60) and the Mandelbulb, " \
    "Mandelbox, KIFS and hybrid kinds (to 10) only: Julia stacks, the cubic locus and IFS take no zoom"

typedef enum { UB_ZOOM_OFF = 0, UB_ZOOM_DOUBLE, UB_ZOOM_PERTURBATION } ub_zoom_path;

/* What a zoomed object carries (ub_object.zoom). */
typedef struct {
    int enabled;          /* zoom != 0 or anchor != 0; else the object is today's, untouched */
    double zoom;          /* log10 of the magnification */
    double scale;         /* 10^-zoom: fractal units per local unit */
    double mu[4];         /* the mu every path iterates: the float32 kernels' (float)mu, exactly */
    double anchor_q[4];   /* the anchor's quaternion Q = slice_origin + B anchor, rounded to double */
    double magnitude;     /* max(1, |Q|): the size of the fractal coordinates near the anchor */
    /* Reference orbits in double: ref from the anchor (Julia: Z_0 = Q; Mandelbrot: Z_0 = 0,
     * Z_1 = Q), crit from the critical point 0 (Julia: 0, mu, ...; Mandelbrot: the same as ref).
     * *_length: the entries stored (the orbit stops after its escape or at the capacity). */
    int ref_length, crit_length;
    double ref[UB_ZOOM_MAX_ORBIT + 1][4];
    double crit[UB_ZOOM_MAX_ORBIT + 1][4];
    /* The perturbation's start, skipped (zoom.c: skip_table): entry K covers the first K
     * iterations from the reference's start (Julia: entry 0; Mandelbrot: entry 1, delta_1 =
     * delta_c), valid for |delta_start| = |x| <= radius: delta_{start+K} = matrix x + sum over the
     * pairs a <= b of quad[.][pair] x_a x_b (UB_ZOOM_PAIRS, in zoom.c's pair order), and what the
     * skipped iterations add to the estimate's bookkeeping, to first order in x. */
    int skip_count;
    struct {
        double matrix[4][4];
        double quad[4][UB_ZOOM_PAIRS]; /* B_K: the coefficient of x_a x_b (a <= b) in component r */
        double dr2;       /* Julia: prod 4 |Z_j|^2; Mandelbrot: Milnor's dm <- 2 |Z_j| dm + 1 (from 1) */
        double dr2_slope[4]; /* Julia: d log(dr2) / dx; Mandelbrot: d dm / dx (|z_j| is not |Z_j|) */
        double radius;    /* largest |x| for which the dropped terms stay below UB_ZOOM_SKIP_TOLERANCE */
        double trap;      /* min |Z_j|^2 over the start and the K iterations */
    } skip[UB_ZOOM_MAX_ORBIT + 1];
    /* The lanes' search (zoom_lanes.h): per binary exponent e + 1023 of |delta_start| (e in
     * [-1023, 1024]), the largest K whose radius holds 2^(e+1), a lower bound of the K the point
     * takes; a few steps up from there find it. The scalar code's binary search is the reference. */
    double skip_first[2048];
} ub_zoom;

/* Decimal text <-> fixed point. Parse: "[+-]digits[.digits][e[+-]digits]"; returns NULL or why
 * not. */
const char *ub_fixed_parse(const char **text, ub_fixed *out);
/* x with `digits` digits after the point (rounded), trailing zeros dropped; returns the length. */
int ub_fixed_format(const ub_fixed *x, int digits, char *out, int size);
void ub_fixed_from_double(double x, ub_fixed *out);
double ub_fixed_to_double(const ub_fixed *x);

/* "x y z" -> three fixed-point numbers, each within [-1e3, 1e3]; NULL or a message. */
const char *ub_anchor_parse(const char *text, ub_fixed anchor[3]);

#endif
