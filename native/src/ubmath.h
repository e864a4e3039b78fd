/* The core's own elementary functions: the same bits on every platform.
 *
 * Why: a frame rendered anywhere must be bit-identical to the x86-64 Linux frame. IEEE 754 makes
 * + - * / and sqrt correctly rounded, hence identical on every CPU (with SSE2/NEON arithmetic and
 * no contraction into fma), but libm's exp, sin, pow... are only "about 1 ulp": Windows UCRT,
 * macOS and musl/zig differ from glibc in the last bit on a few per cent of inputs, and mingw's
 * fmaf is not even correctly rounded. Everything that reaches pixels is therefore computed here,
 * from + - * / sqrt, comparisons and bit manipulation only (no libm transcendental, no fma, no
 * long double). fmod, sqrt, floor, fabs, fmin/fmax and ldexp are exact by the C standard (their
 * result is representable, so there is nothing to round) and may stay libm calls.
 *
 * Accuracy (checked against mpmath by tests/native/test_ubmath.py): every double function is
 * within 1 ulp of the true value, below 0.6 ulp over the ranges the core uses; ub_fmaf is
 * correctly rounded, ub_expf within 0.5 + 2^-28 ulp. The method throughout: the
 * leading terms in double-double (an unevaluated sum hi + lo, built with error-free transforms),
 * the small tail in plain double, one rounding at the end.
 *
 * NaN results are one canonical quiet NaN (0x7ff8000000000000): x86 and ARM make NaNs with
 * different sign bits and payloads, and the probe's golden vectors compare bits.
 *
 * The constants are exact hex floats printed by tools/gen_ubmath_constants.py. */
#ifndef UNBOUND_UBMATH_H
#define UNBOUND_UBMATH_H

#include <float.h>
#include <math.h> /* sqrt only: correctly rounded by IEEE 754 */
#include <stdint.h>
#include <string.h>

/* x87 arithmetic (extended precision intermediates) or contraction into fma would change the
 * roundings every function below relies on. GCC honours -ffp-contract=off from the build;
 * clang (zig cc) also honours the standard pragma, which keeps this header safe alone. */
#if FLT_EVAL_METHOD != 0
#error "ubmath.h needs FLT_EVAL_METHOD == 0 (SSE2/NEON arithmetic, not x87)"
#endif
#ifdef __clang__
#pragma STDC FP_CONTRACT OFF
#endif

#define UB__PIO2_1 0x1.921fb54400000p+0  /* pi/2 in four parts, the first three of 33 bits */
#define UB__PIO2_2 0x1.0b4611a600000p-34
#define UB__PIO2_3 0x1.3198a2e000000p-69
#define UB__PIO2_4 0x1.b839a252049c1p-104
#define UB__PIO2_HI 0x1.921fb54442d18p+0 /* pi/2 = HI + LO to 106 bits */
#define UB__PIO2_LO 0x1.1a62633145c07p-54
#define UB__2_OVER_PI 0x1.45f306dc9c883p-1
#define UB__LN2_HI 0x1.62e42ff000000p-1  /* 32 bits: k * LN2_HI is exact for |k| < 2^21 */
#define UB__LN2_LO (-0x1.718432a1b0e26p-35)
#define UB__INV_LN2 0x1.71547652b82fep+0
#define UB__SQRT2 0x1.6a09e667f3bcdp+0
/* Rounds |x| < 2^51 to an integer (ties to even) in the default rounding mode, which render.c
 * sets for every kernel call: adding 1.5 * 2^52 leaves no fraction bits. */
#define UB__ROUND_SHIFTER 0x1.8p52

/* ------------------------------------------------------------------ bits and error-free sums */

static inline uint64_t ub__bits(double x) { uint64_t b; memcpy(&b, &x, 8); return b; }
static inline double ub__from_bits(uint64_t b) { double x; memcpy(&x, &b, 8); return x; }
static inline double ub__nan(void) { return ub__from_bits(0x7ff8000000000000ull); }
static inline double ub__inf(void) { return ub__from_bits(0x7ff0000000000000ull); }
static inline int ub__is_nan(double x) { return x != x; }

/* fmax and fmin written out, the same results (a NaN argument gives the other one): x86-64 GCC
 * calls libm for them unless -ffinite-math-only, which is a call per lane where the cones' loops
 * and the camera rays' start take them (issue 21: 1.5 % of the peer render). Two selects, not
 * `a > b || ub__is_nan(b) ? a : b`: GCC 12 does not vectorise that `||` of two comparisons, so
 * every lane loop using these (the cones' corners and balls) stayed scalar code (issue 21: six more
 * loops vectorised in each kernel; peer 1.014x, world 1.013x, "everything" 1.015x with AVX-512,
 * peer 1.021x with AVX2; the same bits). */
static inline double ub_fmax(double a, double b)
{
    const double larger = a > b ? a : b;
    return ub__is_nan(b) ? a : larger;
}

static inline double ub_fmin(double a, double b)
{
    const double smaller = a < b ? a : b;
    return ub__is_nan(b) ? a : smaller;
}

/* 2^n for -1022 <= n <= 1023, by its bits (exact). */
static inline double ub__pow2(int n) { return ub__from_bits((uint64_t)(n + 1023) << 52); }

/* a + b = s + e exactly (Knuth's TwoSum, any order). */
static inline double ub__two_sum(double a, double b, double *e)
{
    double s = a + b, bb = s - a;
    *e = (a - (s - bb)) + (b - bb);
    return s;
}

/* a + b = s + e exactly, for |a| >= |b| (Dekker's FastTwoSum). */
static inline double ub__fast_two_sum(double a, double b, double *e)
{
    double s = a + b;
    *e = b - (s - a);
    return s;
}

/* Veltkamp's split of a into 26 + 27 bits: hi * hi etc. are exact. |a| < 2^995. */
static inline void ub__split(double a, double *hi, double *lo)
{
    double t = 134217729.0 * a; /* 2^27 + 1 */
    *hi = t - (t - a);
    *lo = a - *hi;
}

/* a * b = p + e exactly (Dekker's TwoProduct, no fma needed). |a|, |b| < 2^995. */
static inline double ub__two_prod(double a, double b, double *e)
{
    double p = a * b, ah, al, bh, bl;
    ub__split(a, &ah, &al);
    ub__split(b, &bh, &bl);
    *e = ((ah * bh - p) + ah * bl + al * bh) + al * bl;
    return p;
}

/* ------------------------------------------------------------------------------------ exp */

/* e^(xh + xl), |xl| <= ulp(xh), rounded once at the end (Tang's method): x = (32 m + j) ln2/32
 * + r, |r| <= ln2/64 + tiny, r in double-double; e^x = 2^m 2^(j/32) e^r with 2^(j/32) from a
 * double-double table and e^r - 1 = r + r^2 P(r) (Taylor to r^7/7!, truncation below 2^-62
 * relative; the r^2 P term is under 0.6 % of the result, so its roundings cost under 0.01 ulp). */
static inline double ub__exp_dd(double xh, double xl)
{
    static const double two_j32[32][2] = {
        {0x1.0000000000000p+0, 0x0.0p+0},
        {0x1.059b0d3158574p+0, 0x1.d73e2a475b465p-55},
        {0x1.0b5586cf9890fp+0, 0x1.8a62e4adc610bp-54},
        {0x1.11301d0125b51p+0, -0x1.6c51039449b3ap-54},
        {0x1.172b83c7d517bp+0, -0x1.19041b9d78a76p-55},
        {0x1.1d4873168b9aap+0, 0x1.e016e00a2643cp-54},
        {0x1.2387a6e756238p+0, 0x1.9b07eb6c70573p-54},
        {0x1.29e9df51fdee1p+0, 0x1.612e8afad1255p-55},
        {0x1.306fe0a31b715p+0, 0x1.6f46ad23182e4p-55},
        {0x1.371a7373aa9cbp+0, -0x1.63aeabf42eae2p-54},
        {0x1.3dea64c123422p+0, 0x1.ada0911f09ebcp-55},
        {0x1.44e086061892dp+0, 0x1.89b7a04ef80d0p-59},
        {0x1.4bfdad5362a27p+0, 0x1.d4397afec42e2p-56},
        {0x1.5342b569d4f82p+0, -0x1.07abe1db13cadp-55},
        {0x1.5ab07dd485429p+0, 0x1.6324c054647adp-54},
        {0x1.6247eb03a5585p+0, -0x1.383c17e40b497p-54},
        {0x1.6a09e667f3bcdp+0, -0x1.bdd3413b26456p-54},
        {0x1.71f75e8ec5f74p+0, -0x1.16e4786887a99p-55},
        {0x1.7a11473eb0187p+0, -0x1.41577ee04992fp-55},
        {0x1.82589994cce13p+0, -0x1.d4c1dd41532d8p-54},
        {0x1.8ace5422aa0dbp+0, 0x1.6e9f156864b27p-54},
        {0x1.93737b0cdc5e5p+0, -0x1.75fc781b57ebcp-57},
        {0x1.9c49182a3f090p+0, 0x1.c7c46b071f2bep-56},
        {0x1.a5503b23e255dp+0, -0x1.d2f6edb8d41e1p-54},
        {0x1.ae89f995ad3adp+0, 0x1.7a1cd345dcc81p-54},
        {0x1.b7f76f2fb5e47p+0, -0x1.5584f7e54ac3bp-56},
        {0x1.c199bdd85529cp+0, 0x1.11065895048ddp-55},
        {0x1.cb720dcef9069p+0, 0x1.503cbd1e949dbp-56},
        {0x1.d5818dcfba487p+0, 0x1.2ed02d75b3707p-55},
        {0x1.dfc97337b9b5fp+0, -0x1.1a5cd4f184b5cp-54},
        {0x1.ea4afa2a490dap+0, -0x1.e9c23179c2893p-54},
        {0x1.f50765b6e4540p+0, 0x1.9d3e12dd8a18bp-54}};
    static const double p[6] = {0x1.0000000000000p-1, 0x1.5555555555555p-3, 0x1.5555555555555p-5,
                                0x1.1111111111111p-7, 0x1.6c16c16c16c17p-10, 0x1.a01a01a01a01ap-13};
    if (ub__is_nan(xh))
        return ub__nan();
    if (xh > 709.79) /* e^709.79 > DBL_MAX */
        return ub__inf();
    if (xh < -746.0) /* e^-746 < 2^-1075: rounds to 0 */
        return 0.0;
    double kd = (xh * (32.0 * UB__INV_LN2) + UB__ROUND_SHIFTER) - UB__ROUND_SHIFTER;
    int k = (int)kd, j = k & 31, m = (k - j) / 32;
    /* exact: |k| < 2^16 times the 32-bit ln2/32 has <= 48 bits, and xh is close to it */
    double t = xh - kd * (UB__LN2_HI * 0x1p-5);
    double rl, rh = ub__two_sum(t, xl - kd * (UB__LN2_LO * 0x1p-5), &rl);
    double q = p[5];
    for (int i = 4; i >= 0; i--)
        q = q * rh + p[i];
    const double *T = two_j32[j];
    double y = T[0] + (T[1] + T[0] * (rh + (rl + rh * rh * q)));
    /* y in [0.98, 1.99]: times 2^m exactly, except where the result is subnormal (one rounding
     * there, so within 1 ulp of the subnormal spacing) or overflows. */
    if (m > 1023)
        return y * ub__pow2(m - 1) * 2.0;
    if (m < -1000)
        return y * ub__pow2(m + 64) * 0x1p-64;
    return y * ub__pow2(m);
}

/* e^x for every double x (NaN: canonical NaN, -inf: 0, +inf: inf). */
static inline double ub_exp(double x) { return ub__exp_dd(x, 0.0); }

/* e^x for a float, rounded once from ub_exp's double (within 2^-28 float ulp of the true
 * value): so within 0.5 + 2^-28 ulp, the same as a correctly rounded expf except within
 * 2^-28 ulp of a halfway point. */
static inline float ub_expf(float x) { return (float)ub_exp((double)x); }

/* ------------------------------------------------------------------------------------ log */

/* log x = hi + lo for finite x > 0, to about 2^-58 relative and 2^-59.5 absolute beyond k ln 2.
 * x = 2^k m, m in [sqrt(1/2), sqrt(2)); log m = 2 atanh(s) = 2s + s^3 T(s^2), s = f / (2 + f),
 * f = m - 1 (exact); s in double-double, T's Taylor series to s^25 (|s| <= 0.1716, truncation
 * below 2^-62 relative). */
/* The series of ub__log_dd (also zoom_lanes.h's lane-parallel twin): 2/(2i + 3), i = 0..11. */
static const double ub__log_series[12] = {
    0x1.5555555555555p-1, 0x1.999999999999ap-2, 0x1.2492492492492p-2, 0x1.c71c71c71c71cp-3,
    0x1.745d1745d1746p-3, 0x1.3b13b13b13b14p-3, 0x1.1111111111111p-3, 0x1.e1e1e1e1e1e1ep-4,
    0x1.af286bca1af28p-4, 0x1.8618618618618p-4, 0x1.642c8590b2164p-4, 0x1.47ae147ae147bp-4};

static inline double ub__log_dd(double x, double *lo)
{
    const double *series = ub__log_series;
    int k = 0;
    if (x < 0x1p-1022) { /* subnormal: scale into the normal range (exact) */
        x *= 0x1p54;
        k = -54;
    }
    uint64_t b = ub__bits(x);
    k += (int)(b >> 52) - 1023;
    double m = ub__from_bits((b & 0x000fffffffffffffull) | 0x3ff0000000000000ull);
    if (m > UB__SQRT2) {
        m *= 0.5;
        k += 1;
    }
    double f = m - 1.0; /* exact (Sterbenz) */
    double dl, dh = ub__fast_two_sum(2.0, f, &dl);
    double sh = f / dh;
    double pe, p = ub__two_prod(sh, dh, &pe);
    double sl = (((f - p) - pe) - sh * dl) / dh; /* f - p is exact: p is within an ulp of f */
    double z = sh * sh;
    double t = series[11];
    for (int i = 10; i >= 0; i--)
        t = t * z + series[i];
    double lml, lmh = ub__fast_two_sum(2.0 * sh, 2.0 * sl + (sh * z * t + 2.0 * z * sl), &lml);
    double kd = (double)k;
    double e, h = ub__two_sum(kd * UB__LN2_HI, lmh, &e);
    return ub__fast_two_sum(h, e + lml + kd * UB__LN2_LO, lo);
}

/* Natural logarithm (x < 0: NaN, 0: -inf, +inf: inf). */
static inline double ub_log(double x)
{
    if (ub__is_nan(x) || x < 0.0)
        return ub__nan();
    if (x == 0.0)
        return -ub__inf();
    if (x == ub__inf())
        return x;
    double lo, hi = ub__log_dd(x, &lo);
    return hi + lo;
}

/* ------------------------------------------------------------------------------------ pow */

/* x^y for x >= 0 (the core raises distances to powers; -0 counts as +0, x < 0 gives NaN).
 * e^(y log x) with log x and the product in double-double. Within 1 ulp for |y| <= 64: the
 * product's error grows with |y| (|y| 2^-59.5 absolute), far below an ulp for the core's
 * exponents (0 <= normal_delta <= 4). IEEE special cases as C's pow: x^0 = 1 and 1^y = 1 even for
 * NaN, 0^y = 0 (y > 0) or inf (y < 0), inf^y = inf or 0, x^(+-inf) = 0 or inf. */
static inline double ub_pow(double x, double y)
{
    if (y == 0.0 || x == 1.0)
        return 1.0;
    if (ub__is_nan(x) || ub__is_nan(y) || x < 0.0)
        return ub__nan();
    if (x == 0.0)
        return y > 0.0 ? 0.0 : ub__inf();
    if (x == ub__inf())
        return y > 0.0 ? ub__inf() : 0.0;
    if (y == ub__inf() || y == -ub__inf())
        return (x < 1.0) == (y > 0.0) ? 0.0 : ub__inf();
    /* The common exponents, correctly rounded by IEEE (and 4x faster than the general path). */
    if (y == 1.0)
        return x;
    if (y == 2.0)
        return x * x;
    if (y == 0.5)
        return sqrt(x);
    double ll, lh = ub__log_dd(x, &ll);
    double p = y * lh;
    /* Beyond these e^p overflows or underflows whatever the low parts; inside them |y| < 2^64
     * (|lh| >= 2^-54 for x != 1), so the split in two_prod cannot overflow. */
    if (p > 710.0)
        return ub__inf();
    if (p < -746.0)
        return 0.0;
    double pe, ph = ub__two_prod(y, lh, &pe);
    double el, eh = ub__fast_two_sum(ph, pe + y * ll, &el);
    return ub__exp_dd(eh, el);
}

/* ------------------------------------------------------------------------------------ sin, cos */

/* sin(rh + rl) for |rh| <= pi/4 + tiny, rl below half an ulp of rh. r - r^3/6 in double-double
 * (the cube by TwoProduct, the division by 6 with its remainder), then r^5 Q(r^2) (Taylor to
 * r^19/19!, at most 0.3 % of the result) and rl cos r in double: one rounding at the end. */
static const double ub__sin_series[8] = {
    0x1.1111111111111p-7, -0x1.a01a01a01a01ap-13, 0x1.71de3a556c734p-19,
    -0x1.ae64567f544e4p-26, 0x1.6124613a86d09p-33, -0x1.ae7f3e733b81fp-41,
    0x1.952c77030ad4ap-49, -0x1.2f49b46814157p-57}; /* (-1)^n/(2n+1)!, n = 2..9 */

static inline double ub__sin_kernel(double rh, double rl)
{
    const double *q = ub__sin_series;
    double zl, zh = ub__two_prod(rh, rh, &zl);
    double cl, ch = ub__two_prod(rh, zh, &cl); /* r^3 = ch + cl */
    cl += rh * zl;
    double sixth = ch / 6.0, pl, ph = ub__two_prod(sixth, 6.0, &pl);
    double sixth_lo = (((ch - ph) - pl) + cl) / 6.0; /* r^3/6 = sixth + sixth_lo */
    double p = q[7];
    for (int i = 6; i >= 0; i--)
        p = p * zh + q[i];
    double e, h = ub__two_sum(rh, -sixth, &e);
    return h + (((e - sixth_lo) + rh * zh * zh * p) + rl * (1.0 - 0.5 * zh));
}

/* cos(rh + rl) for |rh| <= pi/4 + tiny: 1 - r^2/2 in double-double (r^2 by TwoProduct), then
 * r^4 C(r^2) (Taylor to r^20/20!) and -rh rl in double. */
static const double ub__cos_series[9] = {
    0x1.5555555555555p-5, -0x1.6c16c16c16c17p-10, 0x1.a01a01a01a01ap-16,
    -0x1.27e4fb7789f5cp-22, 0x1.1eed8eff8d898p-29, -0x1.93974a8c07c9dp-37,
    0x1.ae7f3e733b81fp-45, -0x1.6827863b97d97p-53, 0x1.e542ba4020225p-62}; /* (-1)^n/(2n)!, n = 2..10 */

static inline double ub__cos_kernel(double rh, double rl)
{
    const double *c = ub__cos_series;
    double zl, zh = ub__two_prod(rh, rh, &zl);
    double p = c[8];
    for (int i = 7; i >= 0; i--)
        p = p * zh + c[i];
    double hz = 0.5 * zh, w = 1.0 - hz;
    double err = (1.0 - w) - hz; /* exact: w = 1 - hz rounded, hz <= 0.31 */
    return w + (err + (zh * zh * p - 0.5 * zl - rh * rl));
}

/* 64 x 64 -> 128-bit product, in 32-bit halves (portable, exact). */
static inline uint64_t ub__mul_64(uint64_t a, uint64_t b, uint64_t *hi)
{
    uint64_t a0 = a & 0xffffffffu, a1 = a >> 32, b0 = b & 0xffffffffu, b1 = b >> 32;
    uint64_t p00 = a0 * b0, p01 = a0 * b1, p10 = a1 * b0, p11 = a1 * b1;
    uint64_t mid = (p00 >> 32) + (p01 & 0xffffffffu) + (p10 & 0xffffffffu);
    *hi = p11 + (p01 >> 32) + (p10 >> 32) + (mid >> 32);
    return (mid << 32) | (p00 & 0xffffffffu);
}

/* 64 bits of the little-endian number w[0..n) from bit `at` up (bits outside it are 0). */
static inline uint64_t ub__bits_at(const uint64_t *w, int n, int at)
{
    uint64_t out = 0;
    for (int i = 0; i < 64; i += 1) { /* bit by bit: rare path, simple to check */
        int bit = at + i;
        if (bit >= 0 && bit < 64 * n && ((w[bit >> 6] >> (bit & 63)) & 1))
            out |= (uint64_t)1 << i;
    }
    return out;
}

/* Payne-Hanek reduction for |x| >= 2^20 (finite): x = n pi/2 + r, returns n mod 4 and
 * r = rh + rl (|r| <= pi/4), to 2^-137 quarter turns, so to 2^-75 relative even for the
 * doubles closest to a multiple of pi/2 (r ~ 2^-61). x = M 2^e (M a 53-bit integer); x 2/pi mod 4 needs 2/pi's
 * bits from 2^-(e-1) on (earlier ones give multiples of 4): 192 of them times M, exactly. */
static inline int ub__reduce_large(double x, double *rh, double *rl)
{
    static const uint64_t two_over_pi[19] = { /* bits 1..1216 of 2/pi after the point */
        0xa2f9836e4e441529u, 0xfc2757d1f534ddc0u, 0xdb6295993c439041u, 0xfe5163abdebbc561u,
        0xb7246e3a424dd2e0u, 0x06492eea09d1921cu, 0xfe1deb1cb129a73eu, 0xe88235f52ebb4484u,
        0xe99c7026b45f7e41u, 0x3991d639835339f4u, 0x9c845f8bbdf9283bu, 0x1ff897ffde05980fu,
        0xef2f118b5a0a6d1fu, 0x6d367ecf27cb09b7u, 0x4f463f669e5fea2du, 0x7527bac7ebe5f17bu,
        0x3d0739f78a5292eau, 0x6bfb5fb11f8d5d08u, 0x56033046fc7b6babu};
    uint64_t b = ub__bits(x);
    int negative = (int)(b >> 63);
    uint64_t M = (b & 0x000fffffffffffffull) | 0x0010000000000000ull;
    int e = (int)((b >> 52) & 0x7ff) - 1075; /* x = M 2^e, e >= -32 here */
    int s = e - 1 > 1 ? e - 1 : 1;           /* first bit of 2/pi needed */
    /* W = bits s .. s+191 of 2/pi as an integer (little-endian words); the table is big-endian
     * with bit i (1-based) at word (i-1)/64, bit 63 - (i-1)%64. */
    uint64_t W[3] = {0, 0, 0};
    for (int i = 0; i < 192; i++) {
        int bit = s + 191 - i; /* W's bit i */
        if (((two_over_pi[(bit - 1) >> 6] >> (63 - ((bit - 1) & 63))) & 1))
            W[i >> 6] |= (uint64_t)1 << (i & 63);
    }
    /* P = M W (4 words); x 2/pi = P 2^-shift, up to the 2/pi bits beyond the window, which
     * contribute under 2^(53 - shift + 2) <= 2^-137. */
    uint64_t P[4] = {0, 0, 0, 0}, carry = 0;
    for (int i = 0; i < 3; i++) {
        uint64_t hi, lo = ub__mul_64(M, W[i], &hi);
        P[i] = lo + carry;
        carry = hi + (P[i] < lo);
    }
    P[3] = carry;
    int shift = s + 191 - e;
    int n = (int)(ub__bits_at(P, 4, shift) & 3);
    uint64_t f[3] = {ub__bits_at(P, 4, shift - 192), ub__bits_at(P, 4, shift - 128),
                     ub__bits_at(P, 4, shift - 64)}; /* the fraction, little-endian */
    double sign = 1.0;
    if (f[2] >> 63) { /* fraction >= 1/2: round n up, r = fraction - 1 (negate the 192 bits) */
        n = (n + 1) & 3;
        sign = -1.0;
        f[0] = ~f[0] + 1;
        f[1] = ~f[1] + (f[0] == 0);
        f[2] = ~f[2] + (f[0] == 0 && f[1] == 0);
    }
    int lz = 0; /* normalize: the fraction is 0 only if x is an exact multiple of pi/2 (never) */
    while (lz < 192 && !((f[2 - (lz >> 6)] >> (63 - (lz & 63))) & 1))
        lz++;
    if (lz >= 128) {
        *rh = *rl = 0.0;
        return negative ? (4 - n) & 3 : n;
    }
    uint64_t t0 = ub__bits_at(f, 3, 128 - lz), t1 = ub__bits_at(f, 3, 64 - lz);
    /* fraction = (t0 2^-64 + t1 2^-128) 2^-lz: 53 + 53 bits of it, exactly, in two doubles */
    double fh = (double)(t0 >> 11) * 0x1p-53;
    double fl = (double)(((t0 & 0x7ffu) << 42) | (t1 >> 22)) * 0x1p-106;
    /* r = fraction pi/2, in double-double */
    double pe, ph = ub__two_prod(fh, UB__PIO2_HI, &pe);
    pe += fh * UB__PIO2_LO + fl * UB__PIO2_HI;
    double scale = sign * ub__pow2(-lz) * (negative ? -1.0 : 1.0);
    double lo, hi = ub__fast_two_sum(ph, pe, &lo);
    *rh = hi * scale;
    *rl = lo * scale;
    return negative ? (4 - n) & 3 : n;
}

/* x = n pi/2 + rh + rl, |rh| <= pi/4 + tiny; returns n mod 4. Cody-Waite for |x| < 2^20 (n <
 * 2^20, so n times each 33-bit part of pi/2 is exact; pi/2 to 152 bits), Payne-Hanek beyond. */
static inline int ub__reduce(double x, double *rh, double *rl)
{
    double ax = x < 0.0 ? -x : x;
    if (ax <= 0x1.921fb54442d18p-1) { /* pi/4 */
        *rh = x;
        *rl = 0.0;
        return 0;
    }
    if (ax >= 0x1p20)
        return ub__reduce_large(x, rh, rl);
    double nd = (x * UB__2_OVER_PI + UB__ROUND_SHIFTER) - UB__ROUND_SHIFTER;
    double t = x - nd * UB__PIO2_1; /* exact (Sterbenz) */
    double e1, h = ub__two_sum(t, -nd * UB__PIO2_2, &e1);
    double e2, h2 = ub__two_sum(h, -nd * UB__PIO2_3, &e2);
    *rh = ub__fast_two_sum(h2, (e1 + e2) - nd * UB__PIO2_4, rl);
    return (int)((int64_t)nd & 3);
}

/* Sine, for every double (inf, NaN: NaN). */
static inline double ub_sin(double x)
{
    if (ub__is_nan(x) || x - x != 0.0)
        return ub__nan();
    if (x < 0x1p-26 && x > -0x1p-26) /* x^3/6 is below half an ulp of x; keeps -0 */
        return x;
    double rh, rl;
    switch (ub__reduce(x, &rh, &rl)) {
    case 0: return ub__sin_kernel(rh, rl);
    case 1: return ub__cos_kernel(rh, rl);
    case 2: return -ub__sin_kernel(rh, rl);
    default: return -ub__cos_kernel(rh, rl);
    }
}

/* Cosine, for every double (inf, NaN: NaN). */
static inline double ub_cos(double x)
{
    if (ub__is_nan(x) || x - x != 0.0)
        return ub__nan();
    double rh, rl;
    switch (ub__reduce(x, &rh, &rl)) {
    case 0: return ub__cos_kernel(rh, rl);
    case 1: return -ub__sin_kernel(rh, rl);
    case 2: return -ub__cos_kernel(rh, rl);
    default: return ub__sin_kernel(rh, rl);
    }
}

/* Sine and cosine of one angle with one argument reduction (a sample's direction needs both):
 * the same bits as ub_sin(x) and ub_cos(x). */
static inline void ub_sincos(double x, double *sine, double *cosine)
{
    if (ub__is_nan(x) || x - x != 0.0) {
        *sine = *cosine = ub__nan();
        return;
    }
    double rh, rl, s, c;
    int quadrant = ub__reduce(x, &rh, &rl);
    s = ub__sin_kernel(rh, rl);
    c = ub__cos_kernel(rh, rl);
    switch (quadrant) {
    case 0: *sine = s; *cosine = c; break;
    case 1: *sine = c; *cosine = -s; break;
    case 2: *sine = -s; *cosine = -c; break;
    default: *sine = -c; *cosine = s; break;
    }
    if (x < 0x1p-26 && x > -0x1p-26) /* as ub_sin: x^3/6 is below half an ulp of x; keeps -0 */
        *sine = x;
}

/* ------------------------------------------------------------------------------------ acos */

/* asin(s) - s = s z R(z) for z = s^2 <= 1/4: R's Taylor series to z^27 (truncation below
 * 2^-64 relative). */
static inline double ub__asin_tail(double s, double z)
{
    static const double a[28] = {
        0x1.5555555555555p-3, 0x1.3333333333333p-4, 0x1.6db6db6db6db7p-5, 0x1.f1c71c71c71c7p-6,
        0x1.6e8ba2e8ba2e9p-6, 0x1.1c4ec4ec4ec4fp-6, 0x1.c99999999999ap-7, 0x1.7a87878787878p-7,
        0x1.3fde50d79435ep-7, 0x1.12ef3cf3cf3cfp-7, 0x1.df3bd37a6f4dfp-8, 0x1.a6863d70a3d71p-8,
        0x1.782dda12f684cp-8, 0x1.51ba308d3dcb1p-8, 0x1.31683bdef7bdfp-8, 0x1.15ee9d45d1746p-8,
        0x1.fcaf8fb6db6dbp-9, 0x1.d3d2a8e0dd67dp-9, 0x1.b026f57b13b14p-9, 0x1.90cb77f60c7cep-9,
        0x1.750de64d7d05fp-9, 0x1.5c5f56efaaaabp-9, 0x1.464c0950f7d47p-9, 0x1.3275586c5f2f0p-9,
        0x1.208d3570ae5a6p-9, 0x1.1052bc5fa960ap-9, 0x1.018f963c229bfp-9, 0x1.e82be60d9127ep-10};
    double p = a[27];
    for (int i = 26; i >= 0; i--)
        p = p * z + a[i];
    return s * z * p;
}

/* Arc cosine in [0, pi] (|x| > 1, NaN: NaN). As fdlibm: |x| <= 1/2: pi/2 - asin x; beyond,
 * with z = (1 - |x|)/2 (exact), acos |x| = 2 asin sqrt z and acos -|x| = pi - 2 asin sqrt z,
 * sqrt z split into 21 leading bits and a correction, so that its rounding error is carried. */
static inline double ub_acos(double x)
{
    if (ub__is_nan(x) || x > 1.0 || x < -1.0)
        return ub__nan();
    double e;
    if (x <= 0.5 && x >= -0.5) {
        double h = ub__two_sum(UB__PIO2_HI, -x, &e);
        return h + (e + (UB__PIO2_LO - ub__asin_tail(x, x * x)));
    }
    double z = (1.0 - (x < 0.0 ? -x : x)) * 0.5, s = sqrt(z);
    double df = ub__from_bits(ub__bits(s) & 0xffffffff00000000ull); /* df^2 exact */
    double c = s > 0.0 ? (z - df * df) / (s + df) : 0.0;             /* sqrt z = df + c */
    if (x < 0.0) {
        double h = ub__two_sum(2.0 * UB__PIO2_HI, -2.0 * df, &e);
        return h + (e - 2.0 * ((c + ub__asin_tail(s, z)) - UB__PIO2_LO));
    }
    return 2.0 * (df + (c + ub__asin_tail(s, z)));
}

/* ------------------------------------------------------------------------------------ hypot */

/* sqrt(x^2 + y^2) without undue overflow or underflow, within 0.52 ulp: the sum of squares in
 * double-double, its root corrected by one Newton step. hypot(+-inf, NaN) = inf as in C. */
static inline double ub_hypot(double x, double y)
{
    double ax = x < 0.0 ? -x : x, ay = y < 0.0 ? -y : y;
    if (ax == ub__inf() || ay == ub__inf())
        return ub__inf();
    if (ub__is_nan(ax) || ub__is_nan(ay))
        return ub__nan();
    if (ax < ay) {
        double t = ax;
        ax = ay;
        ay = t;
    }
    if (ay == 0.0 || ax > ay * 0x1p60) /* the smaller's square is below half an ulp */
        return ax + ay;
    double scale = 1.0; /* powers of two: exact, and the squares stay normal */
    if (ax > 0x1p500) {
        ax *= 0x1p-600;
        ay *= 0x1p-600;
        scale = 0x1p600;
    } else if (ax < 0x1p-500) {
        ax *= 0x1p600;
        ay *= 0x1p600;
        scale = 0x1p-600;
    }
    double e1, p1 = ub__two_prod(ax, ax, &e1);
    double e2, p2 = ub__two_prod(ay, ay, &e2);
    double t, sh = ub__two_sum(p1, p2, &t);
    double sl = t + e1 + e2;
    double r = sqrt(sh);
    double rre, rr = ub__two_prod(r, r, &rre);
    return (r + (((sh - rr) - rre) + sl) / (2.0 * r)) * scale;
}

/* ------------------------------------------------------------------------------------ fmaf */

/* a * b + c rounded once to float, as IEEE fma: the product is exact in double (24 + 24 bits),
 * the double sum rounds once, and TwoSum gives its error. Rounding that double to float again
 * would be wrong only where it lies exactly halfway between two floats; making the double
 * "round to odd" (nudged one ulp toward the exact value when inexact and even) fixes that, since
 * 53 >= 24 + 2 bits (Boldo & Melquiond 2008), subnormal and overflowing floats included. */
static inline float ub_fmaf(float a, float b, float c)
{
    double p = (double)a * (double)b, cd = c;
    double err, s = ub__two_sum(p, cd, &err);
    if (err != 0.0 && s - s == 0.0) { /* inexact and finite: s != 0 */
        uint64_t bits = ub__bits(s);
        if (!(bits & 1))
            bits += (err > 0.0) == (s > 0.0) ? 1 : (uint64_t)-1;
        s = ub__from_bits(bits);
    }
    return (float)s;
}

#endif
