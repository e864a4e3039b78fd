/* Deep zoom (issue 18): the anchor's fixed-point arithmetic, the reference orbits and the
 * distance estimate of the double and perturbation paths. See zoom.h for the design. */
#include "zoom.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "scene.h"
#include "ubmath.h"

#define N UB_FIXED_LIMBS
#define F (UB_FIXED_LIMBS - UB_FIXED_INT_LIMBS) /* fraction limbs */
#define UNITS (UB_FIXED_INT_LIMBS - 1)          /* the limb of weight 1 */

/* ------------------------------------------------------------------ fixed point */

static int fx_negative(const ub_fixed *x) { return (x->limb[0] >> 31) != 0; }

static void fx_add(const ub_fixed *a, const ub_fixed *b, ub_fixed *out)
{
    uint64_t carry = 0;
    for (int i = N - 1; i >= 0; i--) {
        uint64_t s = (uint64_t)a->limb[i] + b->limb[i] + carry;
        out->limb[i] = (uint32_t)s;
        carry = s >> 32;
    }
}

static void fx_neg(const ub_fixed *a, ub_fixed *out)
{
    uint64_t carry = 1;
    for (int i = N - 1; i >= 0; i--) {
        uint64_t s = (uint64_t)(uint32_t)~a->limb[i] + carry;
        out->limb[i] = (uint32_t)s;
        carry = s >> 32;
    }
}

static void fx_sub(const ub_fixed *a, const ub_fixed *b, ub_fixed *out)
{
    ub_fixed nb;
    fx_neg(b, &nb);
    fx_add(a, &nb, out);
}

static void fx_abs(const ub_fixed *a, ub_fixed *out)
{
    if (fx_negative(a))
        fx_neg(a, out);
    else
        *out = *a;
}

/* a b, the magnitude truncated to 2^-288 (toward zero: the same bits everywhere). The caller
 * keeps |a b| < 2^63. */
static void fx_mul(const ub_fixed *a, const ub_fixed *b, ub_fixed *out)
{
    ub_fixed ma, mb;
    fx_abs(a, &ma);
    fx_abs(b, &mb);
    uint32_t p[2 * N] = {0}; /* least significant first */
    for (int i = 0; i < N; i++) {
        uint64_t carry = 0, ai = ma.limb[N - 1 - i];
        for (int j = 0; j < N; j++) {
            uint64_t t = ai * mb.limb[N - 1 - j] + p[i + j] + carry;
            p[i + j] = (uint32_t)t;
            carry = t >> 32;
        }
        p[i + N] = (uint32_t)carry;
    }
    ub_fixed r;
    for (int i = 0; i < N; i++)
        r.limb[N - 1 - i] = p[i + F];
    if (fx_negative(a) != fx_negative(b))
        fx_neg(&r, out);
    else
        *out = r;
}

/* Non-negative x / d, truncated. */
static void fx_div_small(ub_fixed *x, uint32_t d)
{
    uint64_t rem = 0;
    for (int i = 0; i < N; i++) {
        uint64_t cur = (rem << 32) | x->limb[i];
        x->limb[i] = (uint32_t)(cur / d);
        rem = cur % d;
    }
}

void ub_fixed_from_double(double x, ub_fixed *out)
{
    /* Exact: ldexp and floor do not round; bits below 2^-288 are dropped. */
    double m = fabs(x);
    for (int i = 0; i < N; i++) {
        int e = 32 * (UNITS - i);
        double v = floor(ldexp(m, -e));
        out->limb[i] = (uint32_t)v;
        m -= ldexp(v, e);
    }
    if (x < 0.0)
        fx_neg(out, out);
}

double ub_fixed_to_double(const ub_fixed *x)
{
    ub_fixed m;
    fx_abs(x, &m);
    double r = 0.0;
    for (int i = 0; i < N; i++)
        r += ldexp((double)m.limb[i], 32 * (UNITS - i));
    return fx_negative(x) ? -r : r;
}

static int fx_is_zero(const ub_fixed *x)
{
    for (int i = 0; i < N; i++)
        if (x->limb[i])
            return 0;
    return 1;
}

#define MAX_DIGITS 400

/* What ub_fixed_parse says of a number it cannot read; ub_anchor_parse names the coordinate
 * with the same words from ANCHOR_ERRORS (static text: no per-thread buffer, which would need
 * thread-local storage and, on Linux, a link to the dynamic loader). */
#define FIXED_ERROR_LIST(prefix, suffix)                                                                 \
    {prefix "has too many digits (at most 400)" suffix, prefix "is not a decimal number" suffix,         \
     prefix "has an exponent without digits" suffix, prefix "has an exponent out of range" suffix,       \
     prefix "is out of range (at most 1000 in magnitude)" suffix}
#define FIXED_ERROR_COUNT 5
static const char *const FIXED_ERRORS[FIXED_ERROR_COUNT] = FIXED_ERROR_LIST("", "");
#define ANCHOR_HINT " (write x y z, e.g. '0.6 0.8 0')"
static const char *const ANCHOR_ERRORS[3][FIXED_ERROR_COUNT] = {
    FIXED_ERROR_LIST("zoom_anchor: number 1 ", ANCHOR_HINT),
    FIXED_ERROR_LIST("zoom_anchor: number 2 ", ANCHOR_HINT),
    FIXED_ERROR_LIST("zoom_anchor: number 3 ", ANCHOR_HINT),
};

const char *ub_fixed_parse(const char **text, ub_fixed *out)
{
    const char *s = *text;
    int negative = 0;
    if (*s == '+' || *s == '-')
        negative = *s++ == '-';
    char digits[MAX_DIGITS];
    int count = 0, point = -1, seen = 0;
    for (;; s++) {
        if (*s >= '0' && *s <= '9') {
            seen = 1;
            if (count == 0 && *s == '0' && point < 0)
                continue; /* leading zeros of the integer part */
            if (count >= MAX_DIGITS)
                return FIXED_ERRORS[0];
            digits[count++] = (char)(*s - '0');
        } else if (*s == '.' && point < 0) {
            point = count;
        } else {
            break;
        }
    }
    if (!seen)
        return FIXED_ERRORS[1];
    if (point < 0)
        point = count;
    if (*s == 'e' || *s == 'E') {
        s++;
        int esign = 1, e = 0, edigits = 0;
        if (*s == '+' || *s == '-')
            esign = *s++ == '-' ? -1 : 1;
        while (*s >= '0' && *s <= '9') {
            if (e < 100000)
                e = 10 * e + (*s - '0');
            s++;
            edigits++;
        }
        if (!edigits)
            return FIXED_ERRORS[2];
        if (e > 1000)
            return FIXED_ERRORS[3];
        point += esign * e;
    }
    /* Integer part: digits[0..point); at most 4 digits (|x| <= 1e3 is checked by the caller). */
    if (point > 4)
        return FIXED_ERRORS[4];
    uint32_t whole = 0;
    for (int i = 0; i < point; i++)
        whole = 10 * whole + (uint32_t)(i < count ? digits[i] : 0);
    /* Fraction by Horner from the last digit: f <- (f + d) / 10. */
    ub_fixed f;
    memset(&f, 0, sizeof f);
    for (int i = count - 1; i >= point; i--) {
        f.limb[UNITS] += (uint32_t)(i >= 0 ? digits[i] : 0);
        fx_div_small(&f, 10);
    }
    f.limb[UNITS] += whole;
    if (negative)
        fx_neg(&f, &f);
    *out = f;
    *text = s;
    return NULL;
}

int ub_fixed_format(const ub_fixed *x, int digits, char *out, int size)
{
    ub_fixed m, half;
    fx_abs(x, &m);
    /* Rounded to nearest (half away from zero): add half a unit of the last digit, 5 10^-(digits+1). */
    memset(&half, 0, sizeof half);
    half.limb[UNITS] = 5;
    for (int k = 0; k <= digits; k++)
        fx_div_small(&half, 10);
    fx_add(&m, &half, &m);
    uint64_t whole = ((uint64_t)m.limb[0] << 32) | m.limb[1];
    int len = snprintf(out, (size_t)size, "%s%llu", fx_negative(x) && !fx_is_zero(x) ? "-" : "",
                       (unsigned long long)whole);
    m.limb[0] = m.limb[1] = 0;
    int point = len;
    if (len + 1 < size)
        out[len++] = '.';
    for (int k = 0; k < digits && len + 1 < size; k++) {
        uint64_t carry = 0;
        for (int i = N - 1; i >= UB_FIXED_INT_LIMBS; i--) {
            uint64_t t = (uint64_t)m.limb[i] * 10 + carry;
            m.limb[i] = (uint32_t)t;
            carry = t >> 32;
        }
        out[len++] = (char)('0' + carry);
    }
    while (len > point + 1 && out[len - 1] == '0')
        len--;
    if (len == point + 1) /* no fraction digits left: drop the point */
        len--;
    out[len] = 0;
    /* "-0.000" truncated to zero prints as "0". */
    if (strcmp(out, "-0") == 0)
        memmove(out, out + 1, 2), len = 1;
    return len;
}

const char *ub_anchor_parse(const char *text, ub_fixed anchor[3])
{
    const char *s = text;
    for (int k = 0; k < 3; k++) {
        while (*s == ' ' || *s == '\t' || *s == ',')
            s++;
        if (!*s)
            return "zoom_anchor must hold three decimal numbers (x y z), e.g. '0.6 0.8 0'";
        const char *err = ub_fixed_parse(&s, &anchor[k]);
        if (err) {
            for (int e = 0; e < FIXED_ERROR_COUNT; e++)
                if (err == FIXED_ERRORS[e])
                    return ANCHOR_ERRORS[k][e];
            return err;
        }
        if (fabs(ub_fixed_to_double(&anchor[k])) > 1e3)
            return "zoom_anchor: each coordinate must be within [-1000, 1000]";
        if (*s && *s != ' ' && *s != '\t' && *s != ',')
            return "zoom_anchor must hold three decimal numbers separated by spaces, e.g. '0.6 0.8 0'";
    }
    while (*s == ' ' || *s == '\t' || *s == ',')
        s++;
    if (*s)
        return "zoom_anchor must hold exactly three numbers (x y z)";
    return NULL;
}

/* ------------------------------------------------------------------ reference orbits */

static double norm2_of(const double z[4]) { return z[0] * z[0] + z[1] * z[1] + z[2] * z[2] + z[3] * z[3]; }

/* z <- z^2 + c in the quaternions: (a^2 - |v|^2 + c0, 2 a v + c_v). */
static void fx_quat_step(ub_fixed z[4], const ub_fixed c[4])
{
    ub_fixed sq[4], n[4];
    for (int k = 0; k < 4; k++)
        fx_mul(&z[k], &z[k], &sq[k]);
    fx_sub(&sq[0], &sq[1], &n[0]);
    fx_sub(&n[0], &sq[2], &n[0]);
    fx_sub(&n[0], &sq[3], &n[0]);
    fx_add(&n[0], &c[0], &n[0]);
    for (int k = 1; k < 4; k++) {
        ub_fixed t;
        fx_mul(&z[0], &z[k], &t);
        fx_add(&t, &t, &t);
        fx_add(&t, &c[k], &n[k]);
    }
    memcpy(z, n, sizeof n);
}

/* The orbit of z0 under z^2 + c into out[0..], until its first entry past the bailout or
 * `count` entries; returns the entries stored. */
static int reference_orbit(const ub_fixed z0[4], const ub_fixed c[4], double bail2, int count, double (*out)[4])
{
    ub_fixed z[4];
    memcpy(z, z0, sizeof z);
    for (int k = 0; k < count; k++) {
        double r2 = 0.0;
        for (int i = 0; i < 4; i++) {
            out[k][i] = ub_fixed_to_double(&z[i]);
            r2 += out[k][i] * out[k][i];
        }
        if (r2 > bail2 || k + 1 == count)
            return k + 1;
        fx_quat_step(z, c);
    }
    return count;
}

/* The linear map delta -> Z delta + delta Z of one iteration at Z = (a, v) as a 4x4 matrix:
 * (2(a p - v.w), 2(a w + p v)) for delta = (p, w). */
static void linear_map(const double z[4], double m[4][4])
{
    memset(m, 0, 16 * sizeof(double));
    m[0][0] = 2.0 * z[0];
    for (int k = 1; k < 4; k++) {
        m[0][k] = -2.0 * z[k];
        m[k][0] = 2.0 * z[k];
        m[k][k] = 2.0 * z[0];
    }
}

/* The symmetric product (u v + v u) / 2 = (u0 v0 - u.v, u0 v + v0 u) (quaternions; the cross
 * products cancel): delta^2 = sym(delta, delta). */
static void sym_half(const double u[4], const double v[4], double out[4])
{
    out[0] = u[0] * v[0] - (u[1] * v[1] + u[2] * v[2] + u[3] * v[3]);
    for (int k = 1; k < 4; k++)
        out[k] = u[0] * v[k] + v[0] * u[k];
}

/* One iteration of the series: A' = L A (+ I), B' = L B + (A x)^2 as coefficients of x_a x_b (the
 * square of A x: sym(A_a, A_b) x_a x_b, twice for a < b). */
static void series_step(const double l[4][4], const double a[4][4], const double b[4][UB_ZOOM_PAIRS], int julia,
                        double na[4][4], double nb[4][UB_ZOOM_PAIRS])
{
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            na[r][c] = l[r][0] * a[0][c] + l[r][1] * a[1][c] + l[r][2] * a[2][c] + l[r][3] * a[3][c]
                       + (julia || r != c ? 0.0 : 1.0);
    for (int p = 0; p < UB_ZOOM_PAIRS; p++) {
        const int i = zoom_pair[p][0], k = zoom_pair[p][1];
        const double ui[4] = {a[0][i], a[1][i], a[2][i], a[3][i]}, uk[4] = {a[0][k], a[1][k], a[2][k], a[3][k]};
        double sq[4];
        sym_half(ui, uk, sq);
        for (int r = 0; r < 4; r++)
            nb[r][p] = l[r][0] * b[0][p] + l[r][1] * b[1][p] + l[r][2] * b[2][p] + l[r][3] * b[3][p]
                       + (i == k ? 1.0 : 2.0) * sq[r];
    }
}

/* A^T Z / |Z|^2: the first-order change of log |Z + A x|^2 is 2 x . that. */
static void log_slope(const double a[4][4], const double z[4], double out[4])
{
    const double z2 = norm2_of(z);
    for (int c = 0; c < 4; c++)
        out[c] = (a[0][c] * z[0] + a[1][c] * z[1] + a[2][c] * z[2] + a[3][c] * z[3]) / z2;
}

/* The perturbation's start as a series (zoom.h: the skip table): delta_j = A_j x + B_j(x, x) with
 * delta_{j+1} = L_j delta_j + delta_j^2 (+ delta_c = x for the Mandelbrot slice, where x =
 * delta_start = delta_1). Per iteration the terms dropped are 2 sym(a, b) + b^2 (a = A x, b =
 * B(x, x)): at most 2 |a| |b|, below UB_ZOOM_SKIP_TOLERANCE of the kept |Z| |a| while |b_j| <=
 * tolerance |Z_j| / 2; |B_j(x, x)| <= |B_j| |x|^2 with |B_j| the root of the sum over r of
 * (sum of |B_j[r][.]|)^2 (|x_a x_b| <= |x|^2). The entry also keeps |A_j x| <= |A_j|_F |x| below
 * sqrt(tolerance) |Z_j|, where the series ends anyway (b ~ a^2 / Z): far from a glitch (|z| <
 * |delta|), and the entry K lands on holds it too, so no glitch (ub_zoom_iterate's test after
 * each step) is skipped over. The bookkeeping follows the reference, to first order in x: Julia's
 * log dr2 = sum log 4 |Z_j + a_j|^2 gains 2 x . A_j^T Z_j / |Z_j|^2 an iteration; Mandelbrot's dm
 * <- 2 |z_j| dm + 1 gains the slope h <- 2 |Z_j| h + 2 dm A_j^T Z_j / |Z_j|. The second-order
 * remainder of either is (2^-15)^2, below the tolerance. Returns the entries filled; fills
 * skip_first, the lanes' shortcut into the table. */
static int skip_table(ub_zoom *zm, int julia)
{
    const int start = julia ? 0 : 1;
    double a[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
    double b[4][UB_ZOOM_PAIRS] = {{0}};
    const double root_tolerance = sqrt(UB_ZOOM_SKIP_TOLERANCE);
    double radius = root_tolerance * sqrt(norm2_of(zm->ref[start])) / 2.0; /* |I|_F = 2 */
    double dr2 = 1.0, trap = norm2_of(zm->ref[start]), slope[4] = {0, 0, 0, 0};
    int count = 0;
    for (int j = start; j + 1 < zm->ref_length; j++) {
        const double *z = zm->ref[j];
        double l[4][4], na[4][4], nb[4][UB_ZOOM_PAIRS], g[4];
        linear_map(z, l);
        log_slope(a, z, g);
        const double size = sqrt(norm2_of(z));
        for (int c = 0; c < 4; c++)
            slope[c] = julia ? slope[c] + 2.0 * g[c] : 2.0 * size * slope[c] + 2.0 * dr2 * size * g[c];
        dr2 = julia ? dr2 * 4.0 * norm2_of(z) : 2.0 * size * dr2 + 1.0;
        series_step(l, a, b, julia, na, nb);
        memcpy(a, na, sizeof a);
        memcpy(b, nb, sizeof b);
        double frob = 0.0, quad = 0.0;
        for (int r = 0; r < 4; r++) {
            double row = 0.0;
            for (int c = 0; c < 4; c++)
                frob += a[r][c] * a[r][c];
            for (int p = 0; p < UB_ZOOM_PAIRS; p++)
                row += fabs(b[r][p]);
            quad += row * row;
        }
        const double next = sqrt(norm2_of(zm->ref[j + 1]));
        radius = fmin(radius, root_tolerance * next / sqrt(frob));
        if (quad > 0.0)
            radius = fmin(radius, sqrt(UB_ZOOM_SKIP_TOLERANCE * next / (2.0 * sqrt(quad))));
        trap = fmin(trap, norm2_of(zm->ref[j + 1]));
        if (!(radius > 1e-300) || !(dr2 < 1e300))
            break; /* nothing more to skip (or about to overflow) */
        count = j + 1 - start;
        memcpy(zm->skip[count].matrix, a, sizeof a);
        memcpy(zm->skip[count].quad, b, sizeof b);
        memcpy(zm->skip[count].dr2_slope, slope, sizeof slope);
        zm->skip[count].radius = radius;
        zm->skip[count].dr2 = dr2;
        zm->skip[count].trap = trap;
    }
    /* Radii never grow with K, so the K for |delta| < 2^(e+1) falls as e rises. */
    int k = count;
    for (int b = 0; b < 2048; b++) {
        const double bound = ldexp(1.0, b - 1023 + 1);
        while (k > 0 && !(zm->skip[k].radius >= bound))
            k--;
        zm->skip_first[b] = k;
    }
    return count;
}

/* The bounding ball in local units, cut to UB_ZOOM_VIEW_RADIUS around the anchor (every zoomed
 * kind: the whole set's ball is 10^zoom local units across, far beyond float32's reach). */
void ub_zoom_view_ball(ub_object *obj, const ub_fixed anchor[3])
{
    const ub_zoom *zm = &obj->zoom;
    if (obj->bound_radius >= 0.0) {
        double center[3], dist2 = 0.0;
        for (int c = 0; c < 3; c++) {
            center[c] = (obj->bound_center[c] - ub_fixed_to_double(&anchor[c])) / zm->scale;
            dist2 += center[c] * center[c];
        }
        double radius = obj->bound_radius / zm->scale;
        if (sqrt(dist2) - radius > UB_ZOOM_VIEW_RADIUS) {
            obj->bound_radius = -1.0; /* the set is out of the zoomed view */
        } else if (radius > UB_ZOOM_VIEW_RADIUS) {
            obj->bound_center[0] = obj->bound_center[1] = obj->bound_center[2] = 0.0;
            obj->bound_radius = UB_ZOOM_VIEW_RADIUS;
        } else {
            memcpy(obj->bound_center, center, sizeof center);
            obj->bound_radius = radius;
        }
    }
}

const char *ub_zoom_prepare(ub_object *obj, double zoom, const char *anchor_text)
{
    ub_zoom *zm = &obj->zoom;
    ub_fixed anchor[3];
    const char *err = ub_anchor_parse(anchor_text, anchor);
    if (err)
        return err;
    zm->enabled = zoom != 0.0 || !fx_is_zero(&anchor[0]) || !fx_is_zero(&anchor[1]) || !fx_is_zero(&anchor[2]);
    if (!zm->enabled)
        return NULL; /* today's object, untouched */
    if (ub_kind_is_formula(obj->kind))
        return ub_zoom_formula_prepare(obj, zoom, anchor); /* double only, to UB_ZOOM_FORMULA_MAX */
    int julia = obj->kind == UB_KIND_QUATERNION_JULIA;
    if (!julia && obj->kind != UB_KIND_QUATERNION_MANDELBROT)
        return UB_ZOOM_KINDS_MESSAGE;
    zm->zoom = zoom;
    zm->scale = ub_pow(10.0, -zoom);
    /* The mu the float32 kernels iterate, exactly: every path must see the same set. */
    for (int k = 0; k < 4; k++)
        zm->mu[k] = (double)(float)obj->mu[k];
    /* The anchor's quaternion Q = slice_origin + B anchor, in fixed point. */
    ub_fixed q[4], mu[4];
    double q2 = 0.0;
    for (int r = 0; r < 4; r++) {
        ub_fixed_from_double(obj->slice_origin[r], &q[r]);
        for (int c = 0; c < 3; c++) {
            ub_fixed b, t;
            ub_fixed_from_double(obj->slice_basis[r][c], &b);
            fx_mul(&b, &anchor[c], &t);
            fx_add(&q[r], &t, &q[r]);
        }
        ub_fixed_from_double(zm->mu[r], &mu[r]);
        zm->anchor_q[r] = ub_fixed_to_double(&q[r]);
        q2 += zm->anchor_q[r] * zm->anchor_q[r];
    }
    zm->magnitude = fmax(1.0, sqrt(q2));
    /* Iterations that follow the zoom (zoom.h), within what the reference orbits hold. */
    int extra = (int)ceil(UB_ZOOM_ITERATIONS_PER_DECADE * zoom);
    obj->max_iterations = obj->max_iterations + extra;
    if (obj->max_iterations > UB_ZOOM_MAX_ORBIT)
        obj->max_iterations = UB_ZOOM_MAX_ORBIT;
    double bail2 = obj->bailout * obj->bailout;
    ub_fixed zero[4];
    memset(zero, 0, sizeof zero);
    if (julia) {
        zm->ref_length = reference_orbit(q, mu, bail2, obj->max_iterations + 1, zm->ref);
        zm->crit_length = reference_orbit(zero, mu, bail2, obj->max_iterations + 1, zm->crit);
    } else {
        /* Mandelbrot: z0 = c = the point (the kernels' convention) is entry 1 of 0's orbit. */
        zm->ref_length = reference_orbit(zero, q, bail2, obj->max_iterations + 2, zm->ref);
        zm->crit_length = zm->ref_length;
        memcpy(zm->crit, zm->ref, sizeof zm->ref);
    }
    zm->skip_count = skip_table(zm, julia);
    ub_zoom_view_ball(obj, anchor);
    /* The kernels' quaternion becomes the local offset B u; the estimate adds Q + 10^-zoom B u. */
    for (int r = 0; r < 4; r++)
        obj->slice_origin[r] = 0.0;
    return NULL;
}

ub_zoom_path ub_zoom_choose_path(const ub_object *o, double eps_local)
{
    if (!o->zoom.enabled)
        return UB_ZOOM_OFF;
    /* Double while the hit threshold spans 2^36 of double's units at the fractal's size: the
     * rounding of z0 (and its amplification along the orbit, which the distance shares) stays
     * below 1e-5 of the threshold. */
    double fractal_eps = eps_local * o->zoom.scale;
    return fractal_eps >= ldexp(o->zoom.magnitude, -36) ? UB_ZOOM_DOUBLE : UB_ZOOM_PERTURBATION;
}

/* ------------------------------------------------------------------ the estimate */

/* Whether the point's delta is large enough to iterate directly (UB_ZOOM_DIRECT_RATIO). */
static int zoom_may_go_direct(const double delta[4], const double z[4], const double c[4])
{
    return norm2_of(delta) >= UB_ZOOM_DIRECT_RATIO * (norm2_of(z) + norm2_of(c));
}

/* Leave the reference: delta becomes z itself, and each step adds the full c. */
static void zoom_go_direct(ub_zoom_state *s)
{
    memcpy(s->delta, s->z, sizeof s->delta);
    memcpy(s->dc, s->c_full, sizeof s->dc);
    s->direct = 1;
}

/* zh + hz = (2(ap - v.w), 2(aw + pv)) for z = (a, v), h = (p, w): the cross products cancel. */
static void sym_product(const double z[4], const double h[4], double out[4])
{
    double vw = z[1] * h[1] + z[2] * h[2] + z[3] * h[3];
    out[0] = 2.0 * (z[0] * h[0] - vw);
    for (int k = 1; k < 4; k++)
        out[k] = 2.0 * (z[0] * h[k] + h[0] * z[k]);
}


void ub_zoom_start(const ub_object *o, int path, const double u_q[4], int want, ub_zoom_state *s)
{
    const ub_zoom *zm = &o->zoom;
    const int julia = o->kind == UB_KIND_QUATERNION_JULIA;
    double offset[4];
    for (int k = 0; k < 4; k++) {
        offset[k] = zm->scale * u_q[k];
        s->z[k] = zm->anchor_q[k] + offset[k];
    }
    /* The reference the point follows (direct: none, delta is z itself) and what is added per
     * step on top of the reference's own step: dc. */
    s->direct = path != UB_ZOOM_PERTURBATION;
    s->on_crit = 0;
    s->length = zm->ref_length;
    s->index = 0;
    if (!s->direct) {
        s->index = julia ? 0 : 1;
        memcpy(s->delta, offset, sizeof s->delta);
        for (int k = 0; k < 4; k++)
            s->dc[k] = julia ? 0.0 : offset[k];
    } else {
        memcpy(s->delta, s->z, sizeof s->delta);
        for (int k = 0; k < 4; k++)
            s->dc[k] = julia ? zm->mu[k] : s->z[k];
    }
    /* The full c of direct iteration, should the reference end before the point escapes. */
    for (int k = 0; k < 4; k++)
        s->c_full[k] = julia ? zm->mu[k] : s->z[k];

    s->r2 = norm2_of(s->z);
    s->dr2 = 1.0;
    s->dm = 1.0;
    s->trap = s->r2;
    s->gscale = 1.0;
    s->add_scale = 1.0;
    if (want & UB_WANT_JACOBIAN)
        for (int a = 0; a < 3; a++)
            for (int k = 0; k < 4; k++)
                s->j[a][k] = o->slice_basis[k][a];
    s->n = 0;
    s->rebases = 0;
    if (!s->direct && zm->skip_count > 0) {
        /* The largest skip whose radius holds this point's delta_start (radii shrink with K). */
        double d0 = sqrt(norm2_of(s->delta));
        int lo = 0, hi = zm->skip_count;
        while (lo < hi) {
            int mid = (lo + hi + 1) / 2;
            if (zm->skip[mid].radius >= d0)
                lo = mid;
            else
                hi = mid - 1;
        }
        int K = lo;
        if (K > 0 && K < o->max_iterations) {
            const double(*m)[4] = zm->skip[lo].matrix;
            const double *x = s->delta;
            double nd[4], pairs[UB_ZOOM_PAIRS];
            for (int p = 0; p < UB_ZOOM_PAIRS; p++)
                pairs[p] = x[zoom_pair[p][0]] * x[zoom_pair[p][1]];
            for (int r = 0; r < 4; r++) {
                double quad = 0.0;
                for (int p = 0; p < UB_ZOOM_PAIRS; p++)
                    quad += zm->skip[lo].quad[r][p] * pairs[p];
                nd[r] = (m[r][0] * x[0] + m[r][1] * x[1] + m[r][2] * x[2] + m[r][3] * x[3]) + quad;
            }
            const double *g = zm->skip[lo].dr2_slope, gx = g[0] * x[0] + g[1] * x[1] + g[2] * x[2] + g[3] * x[3];
            if (want & UB_WANT_JACOBIAN) /* the Jacobian follows the linear part (Mandelbrot: J_1 = B = dc/du); the
                                         * second order's 2 B(x, .) is ~2^-15 of it: < 0.002 degrees of normal */
                for (int a = 0; a < 3; a++) {
                    double nj[4];
                    for (int r = 0; r < 4; r++)
                        nj[r] = m[r][0] * s->j[a][0] + m[r][1] * s->j[a][1] + m[r][2] * s->j[a][2]
                                + m[r][3] * s->j[a][3];
                    memcpy(s->j[a], nj, sizeof nj);
                }
            memcpy(s->delta, nd, sizeof s->delta);
            s->index += K;
            s->n = K;
            for (int k = 0; k < 4; k++)
                s->z[k] = zm->ref[s->index][k] + s->delta[k];
            s->r2 = norm2_of(s->z);
            if (julia)
                s->dr2 = zm->skip[lo].dr2 * (1.0 + gx);
            else
                s->dm = zm->skip[lo].dr2 + gx;
            s->trap = zm->skip[lo].trap;
            s->gscale = ldexp(1.0, -K);
        }
    }
    if (!s->direct && zoom_may_go_direct(s->delta, s->z, s->c_full))
        zoom_go_direct(s);
}

void ub_zoom_iterate(const ub_object *o, ub_zoom_state *s, int want)
{
    const ub_zoom *zm = &o->zoom;
    const int julia = o->kind == UB_KIND_QUATERNION_JULIA;
    const double bail2 = o->bailout * o->bailout;
    double *z = s->z, *delta = s->delta, *dc = s->dc, (*j)[4] = s->j;
    const double(*orbit)[4] = s->direct ? NULL : s->on_crit ? zm->crit : zm->ref;
    for (int it = s->n; it < o->max_iterations; it++) {
        if (want & UB_WANT_JACOBIAN) {
            double big = 0.0;
            for (int a = 0; a < 3; a++) {
                double nj[4];
                sym_product(z, j[a], nj);
                if (!julia)
                    for (int k = 0; k < 4; k++)
                        nj[k] += s->add_scale * o->slice_basis[k][a];
                memcpy(j[a], nj, sizeof nj);
                big = fmax(big, norm2_of(nj));
            }
            if (big > 1e200) { /* only the direction matters */
                for (int a = 0; a < 3; a++)
                    for (int k = 0; k < 4; k++)
                        j[a][k] *= 1e-100;
                s->add_scale *= 1e-100;
            }
        }
        if (julia)
            s->dr2 *= 4.0 * s->r2;
        else
            s->dm = 2.0 * sqrt(s->r2) * s->dm + 1.0;
        if (orbit && s->index + 1 >= s->length) {
            /* The reference escaped (or its storage ended) before this point: go on directly.
             * The point's orbit is the size of the escape radius here, where double's rounding
             * is harmless. */
            zoom_go_direct(s);
            orbit = NULL;
        }
        /* delta <- Z delta + delta Z + delta^2 + dc, with Z = 0 when there is no reference. */
        double nd[4];
        const double p = delta[0];
        if (orbit) {
            /* (Z + delta)^2 - Z^2 = Z delta + delta Z + delta^2 (Z = (a, v), delta = (p, w)):
             * real part p (2a + p) - w.(2v + w), vector part 2 (a + p) w + 2 p v. */
            const double *ref = orbit[s->index];
            nd[0] = p * (2.0 * ref[0] + p);
            for (int k = 1; k < 4; k++)
                nd[0] -= delta[k] * (2.0 * ref[k] + delta[k]);
            for (int k = 1; k < 4; k++)
                nd[k] = 2.0 * ((ref[0] + p) * delta[k] + p * ref[k]);
        } else {
            nd[0] = p * p - (delta[1] * delta[1] + delta[2] * delta[2] + delta[3] * delta[3]);
            for (int k = 1; k < 4; k++)
                nd[k] = 2.0 * p * delta[k];
        }
        for (int k = 0; k < 4; k++)
            delta[k] = nd[k] + dc[k];
        if (orbit) {
            s->index++;
            for (int k = 0; k < 4; k++)
                z[k] = orbit[s->index][k] + delta[k];
            if (zoom_may_go_direct(delta, z, s->c_full)) {
                zoom_go_direct(s);
                orbit = NULL;
            } else if (norm2_of(z) < norm2_of(delta)) {
                /* Glitch: rebase onto the critical orbit, whose entry 0 is the critical point 0
                 * (the Julia reference cannot serve; for the Mandelbrot set it is the anchor's own
                 * orbit from 0, and delta_c stays). */
                memcpy(delta, z, sizeof s->delta);
                orbit = zm->crit;
                s->on_crit = 1;
                s->length = zm->crit_length;
                s->index = 0;
                s->rebases++;
                if (julia)
                    for (int k = 0; k < 4; k++)
                        dc[k] = 0.0;
            }
        } else {
            memcpy(z, delta, sizeof s->z);
        }
        double nr2 = norm2_of(z);
        s->r2 = nr2;
        s->trap = fmin(s->trap, nr2);
        s->gscale *= 0.5;
        s->n++;
        if (nr2 > bail2)
            break;
    }
}

void ub_zoom_finish(const ub_object *o, const ub_zoom_state *s, int want, ub_zoom_result *res)
{
    const int julia = o->kind == UB_KIND_QUATERNION_JULIA;
    const double bail2 = o->bailout * o->bailout;
    const double r2 = s->r2;
    int escaped = r2 > bail2;
    double est = 0.0, lr2 = escaped ? ub_log(r2) : 0.0;
    if (escaped) {
        double dr2 = julia ? s->dr2 : s->dm * s->dm;
        est = sqrt(r2 / dr2) * lr2 * 0.25 / o->zoom.scale; /* fractal units -> local units */
    }
    res->dist = est;
    res->iterations = s->n;
    res->rebases = s->rebases;
    res->trap = sqrt(s->trap);
    res->potential = escaped ? lr2 * 0.5 * s->gscale : 0.0;
    if (want & UB_WANT_JACOBIAN) {
        /* Only the direction is used: unit length, so float32 holds it. */
        double len2 = 0.0;
        for (int a = 0; a < 3; a++) {
            res->normal[a] = s->z[0] * s->j[a][0] + s->z[1] * s->j[a][1] + s->z[2] * s->j[a][2] + s->z[3] * s->j[a][3];
            len2 += res->normal[a] * res->normal[a];
        }
        double inv = len2 > 0.0 && len2 < HUGE_VAL ? 1.0 / sqrt(len2) : 0.0;
        for (int a = 0; a < 3; a++)
            res->normal[a] *= inv;
    }
}

void ub_zoom_estimate(const ub_object *o, int path, const double u_q[4], int want, ub_zoom_result *res)
{
    ub_zoom_state s;
    ub_zoom_start(o, path, u_q, want, &s);
    ub_zoom_iterate(o, &s, want);
    ub_zoom_finish(o, &s, want, res);
}

const char *ub_zoom_anchor_move(const char *anchor_text, double zoom, const double u[3], int digits, char *out,
                                int size)
{
    ub_fixed anchor[3];
    const char *err = ub_anchor_parse(anchor_text, anchor);
    if (err)
        return err;
    /* The same 10^-zoom the estimate scales by; the offset's rounding in double is far below
     * the pixel it was picked in. */
    double scale = ub_pow(10.0, -zoom);
    int len = 0;
    for (int k = 0; k < 3; k++) {
        ub_fixed offset;
        ub_fixed_from_double(scale * u[k], &offset);
        fx_add(&anchor[k], &offset, &anchor[k]);
        if (k && len + 1 < size)
            out[len++] = ' ';
        len += ub_fixed_format(&anchor[k], digits, out + len, size - len);
        if (len >= size - 1)
            return "the anchor text is too long";
    }
    return NULL;
}
