/* 8-lane float vectors on AVX2 + FMA. Every operation here has an exact twin in
 * simd_portable.h (IEEE add/mul/div/sqrt and fused multiply-add are correctly rounded on both),
 * so the two kernels produce identical bits. Compile the including file with
 * `#pragma GCC target("avx2,fma")` (not -march=native: the wheel must run on any x86-64). */
#ifndef UNBOUND_SIMD_AVX2_H
#define UNBOUND_SIMD_AVX2_H
/* The march inlines the Julia set's iteration (march.h, march_de): the vector registers hold the
 * march's state across it. */
#define UB_INLINE_JULIA_MARCH 1
#include <immintrin.h>
#include <stdint.h>

typedef __m256 vf;   /* 8 floats */
typedef __m256 vm;   /* 8 lane masks: all bits set = true */

static inline vf v_set1(float x) { return _mm256_set1_ps(x); }
static inline vf v_load(const float *p) { return _mm256_loadu_ps(p); }
static inline void v_store(float *p, vf a) { _mm256_storeu_ps(p, a); }
static inline vf v_add(vf a, vf b) { return _mm256_add_ps(a, b); }
static inline vf v_sub(vf a, vf b) { return _mm256_sub_ps(a, b); }
static inline vf v_mul(vf a, vf b) { return _mm256_mul_ps(a, b); }
static inline vf v_div(vf a, vf b) { return _mm256_div_ps(a, b); }
static inline vf v_sqrt(vf a) { return _mm256_sqrt_ps(a); }
/* a*b + c and a*b - c with a single rounding. */
static inline vf v_fma(vf a, vf b, vf c) { return _mm256_fmadd_ps(a, b, c); }
static inline vf v_fms(vf a, vf b, vf c) { return _mm256_fmsub_ps(a, b, c); }
/* min(a, b) = a < b ? a : b and max(a, b) = a > b ? a : b, NaN-semantics included. */
static inline vf v_min(vf a, vf b) { return _mm256_min_ps(a, b); }
static inline vf v_max(vf a, vf b) { return _mm256_max_ps(a, b); }
static inline vm v_lt(vf a, vf b) { return _mm256_cmp_ps(a, b, _CMP_LT_OQ); }
static inline vm v_le(vf a, vf b) { return _mm256_cmp_ps(a, b, _CMP_LE_OQ); }
static inline vm v_gt(vf a, vf b) { return _mm256_cmp_ps(a, b, _CMP_GT_OQ); }
static inline vm m_and(vm a, vm b) { return _mm256_and_ps(a, b); }
static inline vm m_or(vm a, vm b) { return _mm256_or_ps(a, b); }
static inline vm m_andnot(vm a, vm b) { return _mm256_andnot_ps(a, b); } /* !a & b */
static inline vm m_false(void) { return _mm256_setzero_ps(); }
static inline int m_bits(vm a) { return _mm256_movemask_ps(a); }
static inline vm m_andnot_gt(vf a, vf b, vm lanes) { return _mm256_andnot_ps(v_gt(a, b), lanes); }
/* The lanes where a > b does not hold (NaN included). */
static inline vm m_not_gt(vf a, vf b) { return _mm256_cmp_ps(a, b, _CMP_NGT_UQ); }
/* With 16 vector registers the pair estimate's loop (estimators.h, de_julia_pair_body) reads each
 * orbit's lane mask off its r2 instead of carrying it: one vector fewer a packet, so fewer of its
 * accumulators go through memory. */
#define UB_ESCAPE_MASK_FROM_R2 1
static inline int m_either(vm a, vm b) { return m_bits(m_or(a, b)) != 0; }
static inline vm m_from_bits(int bits)
{
    const __m256i lane = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    __m256i b = _mm256_and_si256(_mm256_set1_epi32(bits), lane);
    return _mm256_castsi256_ps(_mm256_cmpeq_epi32(b, lane));
}
/* The bit word of the lanes l where a[l] == value (a: an int per lane): a compare and its sign
 * bits (issue 21: GCC left such lane loops scalar). */
static inline int lanes_int_eq(const int *a, int value)
{
    const __m256i eq = _mm256_cmpeq_epi32(_mm256_loadu_si256((const __m256i *)a), _mm256_set1_epi32(value));
    return _mm256_movemask_ps(_mm256_castsi256_ps(eq));
}
/* m ? a : b */
static inline vf v_select(vm m, vf a, vf b) { return _mm256_blendv_ps(b, a, m); }
/* p's lanes m take a, the others keep theirs: a load, a blend and a full store. The empty asm
 * hides the blend from the compilers, which make a masked store (vmaskmovps) of this pattern and of
 * lane loops such as `x[l] = m ? a : x[l]`; AMD's cores run that store in microcode, about 17 cycles
 * against 2 (issue 21: clang's release build 8 % slower than GCC's on the Zen 3 host). */
static inline void v_store_lanes(float *p, vm m, vf a)
{
    vf r = _mm256_blendv_ps(_mm256_loadu_ps(p), a, m);
    __asm__("" : "+x"(r));
    _mm256_storeu_ps(p, r);
}
/* a + (m ? 1 : 0) */
static inline vf v_count(vf a, vm m) { return _mm256_add_ps(a, _mm256_and_ps(m, _mm256_set1_ps(1.0f))); }

/* table[i] of a 16-entry table per lane (i in the low 4 bits): two 8-entry permutes (they read the
 * low 3 bits), bit 3 of i (the sign bit of `upper`) choosing between them. */
static inline vf v_table16(const float table[16], __m256i i, vf upper)
{
    return _mm256_blendv_ps(_mm256_permutevar8x32_ps(_mm256_loadu_ps(table), i),
                            _mm256_permutevar8x32_ps(_mm256_loadu_ps(table + 8), i), upper);
}
/* v_log's reduction (estimators.h): x = 2^k z with z in [0.699, 1.398), and the table entries
 * invc[i], logc[i] of z's interval i (its top mantissa bits, glibc logf's layout). */
static inline void v_log_reduce(vf x, const float invc[16], const float logc[16], vf *z, vf *k, vf *ic, vf *lc)
{
    const __m256i xi = _mm256_castps_si256(x);
    const __m256i t = _mm256_sub_epi32(xi, _mm256_set1_epi32(0x3f330000));
    const __m256i i = _mm256_srli_epi32(t, 19); /* the interval in its low 4 bits */
    const vf upper = _mm256_castsi256_ps(_mm256_slli_epi32(i, 28)); /* bit 3 of i as the sign */
    *z = _mm256_castsi256_ps(_mm256_sub_epi32(xi, _mm256_and_si256(t, _mm256_set1_epi32((int)0xff800000u))));
    *k = _mm256_cvtepi32_ps(_mm256_srai_epi32(t, 23));
    *ic = v_table16(invc, i, upper);
    *lc = v_table16(logc, i, upper);
}

/* Doubles for the deep zoom's estimate (zoom_lanes.h): 4 per vector, two per packet. Only IEEE
 * + - * / sqrt, min, max and compares, no fused multiply-add: the bits of zoom.c's scalar code
 * (compiled without FMA, and -ffp-contract=off keeps the compiler from fusing these). */
#define VD_LANES 4
typedef __m256d vd;
typedef __m256d vdm; /* all bits set = true */
static inline vd vd_set1(double x) { return _mm256_set1_pd(x); }
static inline vd vd_load(const double *p) { return _mm256_loadu_pd(p); }
static inline void vd_store(double *p, vd a) { _mm256_storeu_pd(p, a); }
/* VD_LANES floats widened to doubles (exact). */
static inline vd vd_load_floats(const float *p) { return _mm256_cvtps_pd(_mm_loadu_ps(p)); }
/* VD_LANES doubles rounded to floats (to nearest, as a C cast). */
static inline void vd_store_floats(float *p, vd a) { _mm_storeu_ps(p, _mm256_cvtpd_ps(a)); }
static inline vd vd_add(vd a, vd b) { return _mm256_add_pd(a, b); }
static inline vd vd_sub(vd a, vd b) { return _mm256_sub_pd(a, b); }
static inline vd vd_mul(vd a, vd b) { return _mm256_mul_pd(a, b); }
static inline vd vd_sqrt(vd a) { return _mm256_sqrt_pd(a); }
static inline vd vd_div(vd a, vd b) { return _mm256_div_pd(a, b); }
static inline vd vd_floor(vd a) { return _mm256_floor_pd(a); }
/* a < b ? a : b and a > b ? a : b (NaN: b), as vminpd / vmaxpd. */
static inline vd vd_min(vd a, vd b) { return _mm256_min_pd(a, b); }
static inline vd vd_max(vd a, vd b) { return _mm256_max_pd(a, b); }
static inline vdm vd_lt(vd a, vd b) { return _mm256_cmp_pd(a, b, _CMP_LT_OQ); }
static inline vdm vd_gt(vd a, vd b) { return _mm256_cmp_pd(a, b, _CMP_GT_OQ); }
static inline vdm vd_ge(vd a, vd b) { return _mm256_cmp_pd(a, b, _CMP_GE_OQ); }
static inline vdm vdm_and(vdm a, vdm b) { return _mm256_and_pd(a, b); }
static inline vdm vdm_or(vdm a, vdm b) { return _mm256_or_pd(a, b); }
static inline vdm vdm_andnot(vdm a, vdm b) { return _mm256_andnot_pd(a, b); } /* !a & b */
static inline int vdm_bits(vdm a) { return _mm256_movemask_pd(a); }
static inline vdm vdm_from_bits(int bits)
{
    const __m256i lane = _mm256_setr_epi64x(1, 2, 4, 8);
    return _mm256_castsi256_pd(_mm256_cmpeq_epi64(_mm256_and_si256(_mm256_set1_epi64x(bits), lane), lane));
}
static inline vd vd_select(vdm m, vd a, vd b) { return _mm256_blendv_pd(b, a, m); } /* m ? a : b */
/* v_store_lanes of doubles. */
static inline void vd_store_lanes(double *p, vdm m, vd a)
{
    vd r = _mm256_blendv_pd(_mm256_loadu_pd(p), a, m);
    __asm__("" : "+x"(r));
    _mm256_storeu_pd(p, r);
}
/* The double at byte offset `offset` (an integer below 2^31) from base, in the lanes of m; the
 * others keep src. */
static inline vd vd_gather(vd src, vdm m, const void *base, vd offset)
{
    return _mm256_mask_i32gather_pd(src, (const double *)base, _mm256_cvttpd_epi32(offset), m, 1);
}
/* Positive normal x = m 2^e, m in [1, 2), by its bits (e exact, as a double). */
static inline void vd_split_exponent(vd x, vd *m, vd *e)
{
    const __m256i b = _mm256_castpd_si256(x), two52 = _mm256_set1_epi64x(0x4330000000000000ll);
    *e = _mm256_sub_pd(_mm256_castsi256_pd(_mm256_or_si256(_mm256_srli_epi64(b, 52), two52)), _mm256_set1_pd(0x1p52 + 1023.0));
    *m = _mm256_castsi256_pd(_mm256_or_si256(_mm256_and_si256(b, _mm256_set1_epi64x(0x000fffffffffffffll)),
                                             _mm256_set1_epi64x(0x3ff0000000000000ll)));
}
#endif
