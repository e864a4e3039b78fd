/* ub_fmaf (native/src/ubmath.h) against the CPU's own fused multiply-add (x86 FMA3, correctly
 * rounded by IEEE 754) on random float triples: any bits, subnormals, products cancelled by c,
 * and constructed double-rounding traps, where a b + c rounded to double lands exactly on a
 * float halfway point but the exact value does not (a plain (float)((double)a * b + c) gets
 * about a fifth of those wrong). Built and run by test_ubmath.py where a C compiler and an FMA
 * CPU are present: cc -O2 -std=c11 -ffp-contract=off -I native/src ubmath_fmaf_check.c
 * Usage: ubmath_fmaf_check [triples]; exit status 1 if any result differs. */
#include "ubmath.h"

#include <immintrin.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

static uint64_t state = 88172645463325252ull;
static uint64_t next(void) /* xorshift64: the same triples every run */
{
    state ^= state << 13;
    state ^= state >> 7;
    state ^= state << 17;
    return state;
}

static float from_bits(uint32_t b) { float f; memcpy(&f, &b, 4); return f; }
static uint32_t to_bits(float f) { uint32_t b; memcpy(&b, &f, 4); return b; }

__attribute__((target("fma"))) static float hardware_fmaf(float a, float b, float c)
{
    return _mm_cvtss_f32(_mm_fmadd_ss(_mm_set_ss(a), _mm_set_ss(b), _mm_set_ss(c)));
}

static float random_float(void)
{
    uint64_t r = next();
    switch (r & 7) {
    case 0: return from_bits((uint32_t)(r >> 32));               /* any bits, NaN and inf too */
    case 1: return from_bits((uint32_t)((r >> 32) & 0x807fffff)); /* subnormal */
    default: {                                                     /* exponents within +-30 */
        uint32_t e = 127 + (uint32_t)((r >> 8) % 60) - 30;
        return from_bits((uint32_t)((r >> 63) << 31) | (e << 23) | (uint32_t)((r >> 20) & 0x7fffff));
    }
    }
}

int main(int argc, char **argv)
{
    long n = argc > 1 ? atol(argv[1]) : 1000000, differ = 0, traps = 0;
    for (long i = 0; i < n; i++) {
        float a = random_float(), b = random_float(), c;
        switch (next() % 4) {
        case 0: c = random_float(); break;
        case 1: c = -(float)((double)a * b); break; /* cancels the product to its rounding error */
        case 2: {
            double p = (double)a * b;
            c = -(float)(p - (double)(float)p); /* cancels all but the product's float part */
            break;
        }
        default: {
            /* a b = u/2 (1 - j^2 2^-46), u the float spacing at c: the double sum rounds to the
             * float midpoint c + u/2 (or c - u/2), the exact one lies just inside it. */
            int j = 1 + (int)(next() % 255), sign = next() & 1 ? 1 : -1;
            float cc = fabsf(random_float());
            if (!(cc > 1e-30f && cc < 1e30f))
                cc = 1.5f;
            float u = nextafterf(cc, INFINITY) - cc;
            a = 1.0f + (float)(sign * j) * 0x1p-23f;
            b = (u / 2) * (1.0f - (float)j * 0x1p-23f);
            c = cc;
            if (next() & 1) {
                a = -a;
                c = -c;
            }
            traps++;
        }
        }
        float mine = ub_fmaf(a, b, c), cpu = hardware_fmaf(a, b, c);
        if (to_bits(mine) != to_bits(cpu) && !(mine != mine && cpu != cpu) && differ++ < 10)
            printf("a=%a b=%a c=%a ub_fmaf=%a fma=%a\n", a, b, c, mine, cpu);
    }
    printf("%ld triples (%ld double-rounding traps): %ld differ\n", n, traps, differ);
    return differ != 0;
}
