/* How fast the Julia set's iteration loop runs with 1 to 4 packets interleaved (issue 21), every
 * lane busy: the loop of estimators.h's de_quaternion_body (want 0: z <- z^2 + mu with 2b, 2c, 2d
 * and |v|^2 carried, the derivative and |z|^2 frozen at the escape by masks, the escape count),
 * written again here in AVX-512 intrinsics so that it runs alone, without the render around it.
 * One packet is the single march and bench_flops.py's --ceiling; two are de_julia_pair (the
 * camera rays' paired march, the normals' differences). mu = -1/2 and points near its attracting
 * fixed point, so no lane escapes. Prints, per packet count, GFLOP/s at issue 21's 24 FLOP an
 * iteration (16 lanes): compare with fma_peak.c's 512-bit figure.
 *
 *     cc -O3 -ffp-contract=off bench/loop_interleave.c -o loop_interleave && ./loop_interleave */
#include <immintrin.h>
#include <stdio.h>
#include <time.h>

#define FLOP_PER_ITERATION 24
#define LANES 16
#define MAX_PACKETS 4

typedef struct {
    __m512 a, b2, c2, d2, v2, r2, dr2, n;
    __mmask16 active;
} orbit;

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t); /* CPU time: robust to a shared machine */
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

/* One iteration of one packet, operation for operation de_quaternion_body's (want 0). */
__attribute__((target("avx512f"), always_inline)) static inline void iterate(orbit *o, __m512 mu0, __m512 mu1,
                                                                          __m512 bail2)
{
    const __m512 four = _mm512_set1_ps(4.0f), one = _mm512_set1_ps(1.0f);
    __m512 na = _mm512_sub_ps(_mm512_fmadd_ps(o->a, o->a, mu0), o->v2);
    __m512 nb = _mm512_fmadd_ps(o->a, o->b2, mu1);
    __m512 nc = _mm512_fmadd_ps(o->a, o->c2, mu1);
    __m512 nd = _mm512_fmadd_ps(o->a, o->d2, mu1);
    o->dr2 = _mm512_mask_mul_ps(o->dr2, o->active, o->dr2, _mm512_mul_ps(four, o->r2));
    __m512 nv2 = _mm512_fmadd_ps(nb, nb, _mm512_fmadd_ps(nc, nc, _mm512_mul_ps(nd, nd)));
    __m512 nr2 = _mm512_fmadd_ps(na, na, nv2);
    o->a = na;
    o->v2 = nv2;
    o->b2 = _mm512_add_ps(nb, nb);
    o->c2 = _mm512_add_ps(nc, nc);
    o->d2 = _mm512_add_ps(nd, nd);
    o->r2 = _mm512_mask_mov_ps(o->r2, o->active, nr2);
    o->n = _mm512_mask_add_ps(o->n, o->active, o->n, one);
    o->active = _kandn_mask16(_mm512_cmp_ps_mask(nr2, bail2, _CMP_GT_OQ), o->active);
}

/* Seconds per loop iteration with `packets` orbits interleaved in one loop. */
#define RUN(K) \
    __attribute__((target("avx512f"))) static double run##K(long iterations, float *check) \
    { \
        const __m512 mu0 = _mm512_set1_ps(-0.5f), mu1 = _mm512_setzero_ps(), bail2 = _mm512_set1_ps(16.0f); \
        orbit o[K]; \
        for (int j = 0; j < K; j++) \
            o[j] = (orbit){_mm512_set1_ps(-0.36f + 0.001f * j), _mm512_set1_ps(0.01f), _mm512_set1_ps(0.01f), \
                           _mm512_set1_ps(0.01f), _mm512_set1_ps(7.5e-5f), _mm512_set1_ps(0.13f), \
                           _mm512_set1_ps(1.0f), _mm512_setzero_ps(), 0xffff}; \
        double t0 = now(); \
        for (long i = 0; i < iterations; i++) { \
            __mmask16 any = 0; \
            for (int j = 0; j < K; j++) { \
                iterate(&o[j], mu0, mu1, bail2); \
                any |= o[j].active; \
            } \
            if (!any) \
                break; \
        } \
        double t = now() - t0; \
        float out[LANES]; \
        _mm512_storeu_ps(out, o[K - 1].n); \
        *check = out[0]; /* every lane iterated: n == iterations */ \
        return t / iterations; \
    }
RUN(1)
RUN(2)
RUN(3)
RUN(4)

int main(void)
{
    if (!__builtin_cpu_supports("avx512f")) {
        puts("no AVX-512F on this CPU");
        return 0;
    }
    const long iterations = 10000000; /* below 2^24: the float escape count stays exact */
    double (*const runs[MAX_PACKETS])(long, float *) = {run1, run2, run3, run4};
    for (int k = 1; k <= MAX_PACKETS; k++) {
        float check;
        double best = 1e30;
        for (int round = 0; round < 3; round++) {
            double t = runs[k - 1](iterations, &check);
            best = t < best ? t : best;
        }
        printf("%d packet(s): %.2f ns an iteration of all, %.1f GFLOP/s%s\n", k, best * 1e9,
               k * FLOP_PER_ITERATION * LANES / best * 1e-9, check == (float)iterations ? "" : " (a lane escaped)");
    }
    return 0;
}
