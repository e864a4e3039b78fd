/* 16-lane float vectors on AVX-512F, with lane masks in the mask registers. Every operation is
 * the exact twin of simd_avx2.h's (IEEE add/mul/div/sqrt and fused multiply-add, correctly
 * rounded), so the three kernels produce identical bits: each lane's arithmetic is the same, only
 * the packet is twice as wide. Compile the including file for AVX-512F (kernel_avx512.c). */
#ifndef UNBOUND_SIMD_AVX512_H
#define UNBOUND_SIMD_AVX512_H
/* The march inlines the Julia set's iteration (march.h, march_de): the vector registers hold the
 * march's state across it. */
#define UB_INLINE_JULIA_MARCH 1
#include <immintrin.h>
#include <stdint.h>

#define UB_LANES 16

typedef __m512 vf;     /* 16 floats */
typedef __mmask16 vm;  /* 16 lane masks, one bit each */

static inline vf v_set1(float x) { return _mm512_set1_ps(x); }
static inline vf v_load(const float *p) { return _mm512_loadu_ps(p); }
static inline void v_store(float *p, vf a) { _mm512_storeu_ps(p, a); }
static inline vf v_add(vf a, vf b) { return _mm512_add_ps(a, b); }
static inline vf v_sub(vf a, vf b) { return _mm512_sub_ps(a, b); }
static inline vf v_mul(vf a, vf b) { return _mm512_mul_ps(a, b); }
static inline vf v_div(vf a, vf b) { return _mm512_div_ps(a, b); }
static inline vf v_sqrt(vf a) { return _mm512_sqrt_ps(a); }
/* a*b + c and a*b - c with a single rounding. */
static inline vf v_fma(vf a, vf b, vf c) { return _mm512_fmadd_ps(a, b, c); }
static inline vf v_fms(vf a, vf b, vf c) { return _mm512_fmsub_ps(a, b, c); }
/* min(a, b) = a < b ? a : b and max(a, b) = a > b ? a : b, NaN-semantics included (as vminps). */
static inline vf v_min(vf a, vf b) { return _mm512_min_ps(a, b); }
static inline vf v_max(vf a, vf b) { return _mm512_max_ps(a, b); }
static inline vm v_lt(vf a, vf b) { return _mm512_cmp_ps_mask(a, b, _CMP_LT_OQ); }
static inline vm v_le(vf a, vf b) { return _mm512_cmp_ps_mask(a, b, _CMP_LE_OQ); }
static inline vm v_gt(vf a, vf b) { return _mm512_cmp_ps_mask(a, b, _CMP_GT_OQ); }
static inline vm m_and(vm a, vm b) { return (vm)(a & b); }
static inline vm m_or(vm a, vm b) { return (vm)(a | b); }
static inline vm m_andnot(vm a, vm b) { return (vm)(~a & b); } /* !a & b */
static inline vm m_false(void) { return 0; }
static inline int m_bits(vm a) { return (int)a; }
static inline vm m_from_bits(int bits) { return (vm)bits; }
/* The bit word of the lanes l where a[l] == value (a: an int per lane): one compare into a mask
 * (issue 21: GCC left such lane loops scalar). */
static inline int lanes_int_eq(const int *a, int value)
{
    return (int)_mm512_cmpeq_epi32_mask(_mm512_loadu_si512(a), _mm512_set1_epi32(value));
}
/* The lanes of `lanes` where a > b does not hold (NaN included): m_andnot(v_gt(a, b), lanes) as one
 * masked compare, not a compare and a mask instruction (issue 21: the iteration loops' escape test;
 * on the Xeons every mask instruction takes port 0, beside the FMAs). */
static inline vm m_andnot_gt(vf a, vf b, vm lanes) { return _mm512_mask_cmp_ps_mask(lanes, a, b, _CMP_NGT_UQ); }
/* Whether a lane of a or of b is set: one kortest, not two moves to integer registers and an or. */
static inline int m_either(vm a, vm b) { return !_kortestz_mask16_u8(a, b); }
/* m ? a : b */
static inline vf v_select(vm m, vf a, vf b) { return _mm512_mask_blend_ps(m, b, a); }
/* p's lanes m take a, the others keep theirs (simd_avx2.h): a blend by a mask register. */
static inline void v_store_lanes(float *p, vm m, vf a) { _mm512_storeu_ps(p, _mm512_mask_blend_ps(m, _mm512_loadu_ps(p), a)); }
/* a + (m ? 1 : 0) */
static inline vf v_count(vf a, vm m) { return _mm512_mask_add_ps(a, m, a, _mm512_set1_ps(1.0f)); }

/* Four channels of the 16 lanes interleaved (r g b a of lane 0, then lane 1, ...): lanes 4k..4k+3,
 * 16 floats, at dst[k]. Unpacks within 128-bit lanes, then a 4 x 4 transpose of those. */
#define UB_HAVE_STORE_RGBA 1
static inline void v_store_rgba(float *const dst[4], vf r, vf g, vf b, vf a)
{
    const __m512 t0 = _mm512_unpacklo_ps(r, g), t1 = _mm512_unpackhi_ps(r, g);
    const __m512 t2 = _mm512_unpacklo_ps(b, a), t3 = _mm512_unpackhi_ps(b, a);
    /* pixel 0 4 8 12, 1 5 9 13, 2 6 10 14, 3 7 11 15 */
    const __m512 u0 = _mm512_shuffle_ps(t0, t2, 0x44), u1 = _mm512_shuffle_ps(t0, t2, 0xee);
    const __m512 u2 = _mm512_shuffle_ps(t1, t3, 0x44), u3 = _mm512_shuffle_ps(t1, t3, 0xee);
    /* pixel 0 4 1 5, 2 6 3 7, 8 12 9 13, 10 14 11 15 */
    const __m512 v0 = _mm512_shuffle_f32x4(u0, u1, 0x44), v1 = _mm512_shuffle_f32x4(u2, u3, 0x44);
    const __m512 v2 = _mm512_shuffle_f32x4(u0, u1, 0xee), v3 = _mm512_shuffle_f32x4(u2, u3, 0xee);
    _mm512_storeu_ps(dst[0], _mm512_shuffle_f32x4(v0, v1, 0x88));
    _mm512_storeu_ps(dst[1], _mm512_shuffle_f32x4(v0, v1, 0xdd));
    _mm512_storeu_ps(dst[2], _mm512_shuffle_f32x4(v2, v3, 0x88));
    _mm512_storeu_ps(dst[3], _mm512_shuffle_f32x4(v2, v3, 0xdd));
}

/* v_log's reduction (estimators.h): x = 2^k z with z in [0.699, 1.398), and the table entries
 * invc[i], logc[i] of z's interval i (its top mantissa bits, glibc logf's layout). */
static inline void v_log_reduce(vf x, const float invc[16], const float logc[16], vf *z, vf *k, vf *ic, vf *lc)
{
    const __m512i xi = _mm512_castps_si512(x);
    const __m512i t = _mm512_sub_epi32(xi, _mm512_set1_epi32(0x3f330000));
    /* The interval's index: vpermps reads only an index's low 4 bits, so no mask (one operation
     * fewer in each estimate's tail). */
    const __m512i i = _mm512_srli_epi32(t, 19);
    *z = _mm512_castsi512_ps(_mm512_sub_epi32(xi, _mm512_and_si512(t, _mm512_set1_epi32((int)0xff800000u))));
    *k = _mm512_cvtepi32_ps(_mm512_srai_epi32(t, 23));
    *ic = _mm512_permutexvar_ps(i, _mm512_loadu_ps(invc));
    *lc = _mm512_permutexvar_ps(i, _mm512_loadu_ps(logc));
}

/* Doubles for the deep zoom's estimate (zoom_lanes.h): 8 per vector, two per packet. Only IEEE
 * + - * / sqrt, min, max and compares, no fused multiply-add: the bits of zoom.c's scalar code
 * (compiled without FMA, and -ffp-contract=off keeps the compiler from fusing these). */
#define VD_LANES 8
typedef __m512d vd;
typedef __mmask8 vdm;
static inline vd vd_set1(double x) { return _mm512_set1_pd(x); }
static inline vd vd_load(const double *p) { return _mm512_loadu_pd(p); }
static inline void vd_store(double *p, vd a) { _mm512_storeu_pd(p, a); }
/* VD_LANES floats widened to doubles (exact). */
static inline vd vd_load_floats(const float *p) { return _mm512_cvtps_pd(_mm256_loadu_ps(p)); }
/* VD_LANES doubles rounded to floats (to nearest, as a C cast). */
static inline void vd_store_floats(float *p, vd a) { _mm256_storeu_ps(p, _mm512_cvtpd_ps(a)); }
static inline vd vd_add(vd a, vd b) { return _mm512_add_pd(a, b); }
static inline vd vd_sub(vd a, vd b) { return _mm512_sub_pd(a, b); }
static inline vd vd_mul(vd a, vd b) { return _mm512_mul_pd(a, b); }
static inline vd vd_sqrt(vd a) { return _mm512_sqrt_pd(a); }
static inline vd vd_div(vd a, vd b) { return _mm512_div_pd(a, b); }
static inline vd vd_floor(vd a) { return _mm512_roundscale_pd(a, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC); }
/* a < b ? a : b and a > b ? a : b (NaN: b), as vminpd / vmaxpd. */
static inline vd vd_min(vd a, vd b) { return _mm512_min_pd(a, b); }
static inline vd vd_max(vd a, vd b) { return _mm512_max_pd(a, b); }
static inline vdm vd_lt(vd a, vd b) { return _mm512_cmp_pd_mask(a, b, _CMP_LT_OQ); }
static inline vdm vd_gt(vd a, vd b) { return _mm512_cmp_pd_mask(a, b, _CMP_GT_OQ); }
static inline vdm vd_ge(vd a, vd b) { return _mm512_cmp_pd_mask(a, b, _CMP_GE_OQ); }
static inline vdm vdm_and(vdm a, vdm b) { return (vdm)(a & b); }
static inline vdm vdm_or(vdm a, vdm b) { return (vdm)(a | b); }
static inline vdm vdm_andnot(vdm a, vdm b) { return (vdm)(~a & b); } /* !a & b */
static inline int vdm_bits(vdm a) { return (int)a; }
static inline vdm vdm_from_bits(int bits) { return (vdm)bits; }
static inline vd vd_select(vdm m, vd a, vd b) { return _mm512_mask_blend_pd(m, b, a); } /* m ? a : b */
static inline void vd_store_lanes(double *p, vdm m, vd a) { _mm512_storeu_pd(p, _mm512_mask_blend_pd(m, _mm512_loadu_pd(p), a)); }
/* The double at byte offset `offset` (an integer below 2^31) from base, in the lanes of m; the
 * others keep src. */
static inline vd vd_gather(vd src, vdm m, const void *base, vd offset)
{
    return _mm512_mask_i32gather_pd(src, m, _mm512_cvttpd_epi32(offset), base, 1);
}
/* Positive normal x = m 2^e, m in [1, 2), by its bits (e exact, as a double). */
static inline void vd_split_exponent(vd x, vd *m, vd *e)
{
    const __m512i b = _mm512_castpd_si512(x), two52 = _mm512_set1_epi64(0x4330000000000000ll);
    *e = _mm512_sub_pd(_mm512_castsi512_pd(_mm512_or_si512(_mm512_srli_epi64(b, 52), two52)), _mm512_set1_pd(0x1p52 + 1023.0));
    *m = _mm512_castsi512_pd(_mm512_or_si512(_mm512_and_si512(b, _mm512_set1_epi64(0x000fffffffffffffll)),
                                             _mm512_set1_epi64(0x3ff0000000000000ll)));
}
#endif
