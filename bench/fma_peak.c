/* The FMA peak of one core, measured: twelve independent chains of fused multiply-adds (more than
 * the FMA latency times the ports, so every port is busy every cycle), in 512-bit and 256-bit
 * vectors. Prints GFLOP/s (an FMA is 2 FLOP) per width. Built and run by bench_flops.py. */
#include <immintrin.h>
#include <stdio.h>
#include <time.h>

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t); /* CPU time: robust to a shared machine */
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

#define CHAINS(T, SET) T x0 = SET(0), x1 = SET(1), x2 = SET(2), x3 = SET(3), x4 = SET(4), x5 = SET(5), \
    x6 = SET(6), x7 = SET(7), x8 = SET(8), x9 = SET(9), x10 = SET(10), x11 = SET(11)
#define STEP(F) x0 = F(x0, m, a); x1 = F(x1, m, a); x2 = F(x2, m, a); x3 = F(x3, m, a); x4 = F(x4, m, a); \
    x5 = F(x5, m, a); x6 = F(x6, m, a); x7 = F(x7, m, a); x8 = F(x8, m, a); x9 = F(x9, m, a); \
    x10 = F(x10, m, a); x11 = F(x11, m, a)
#define SUM(ADD) ADD(ADD(ADD(ADD(x0, x1), ADD(x2, x3)), ADD(ADD(x4, x5), ADD(x6, x7))), \
    ADD(ADD(x8, x9), ADD(x10, x11)))

/* One width's peak: LANES floats a vector of type T; the sum of the chains is stored so that the
 * compiler keeps them. */
#define PEAK(NAME, TARGET, T, LANES, SET1, FMADD, ADD, STOREU) \
    __attribute__((target(TARGET))) static double NAME(long rounds) \
    { \
        CHAINS(T, SET1); \
        const T m = SET1(0.9999f), a = SET1(1e-7f); \
        double t0 = now(); \
        for (long k = 0; k < rounds; k++) { \
            STEP(FMADD); \
            __asm__ volatile(""); \
        } \
        double t = now() - t0; \
        float out[LANES]; \
        STOREU(out, SUM(ADD)); \
        volatile float sink = out[0]; \
        (void)sink; \
        return rounds * 12.0 * LANES * 2 / t * 1e-9; \
    }

PEAK(peak512, "avx512f,fma", __m512, 16, _mm512_set1_ps, _mm512_fmadd_ps, _mm512_add_ps, _mm512_storeu_ps)
PEAK(peak256, "avx2,fma", __m256, 8, _mm256_set1_ps, _mm256_fmadd_ps, _mm256_add_ps, _mm256_storeu_ps)

int main(int argc, char **argv)
{
    int avx512 = argc > 1 && argv[1][0] == '1';
    long rounds = 100000000;
    for (int i = 0; i < 3; i++) /* the best of three: the peak, not the machine's noise */
        printf("%s %.2f\n", avx512 ? "avx512" : "avx2", avx512 ? peak512(rounds) : peak256(rounds));
    return 0;
}
