/* 8-lane float vectors in portable C: the bit-exact twin of simd_avx2.h for CPUs without
 * AVX2/FMA and for other architectures. Both kernels' results stay identical because every
 * fused multiply-add rounds once, as IEEE's fma: where the target has the instruction
 * (__FP_FAST_FMAF: arm64, x86-64 built with FMA) fmaf() is that one instruction; elsewhere not
 * libm's fmaf, which is a slow or, on mingw, not even correctly rounded emulation, but
 * ubmath.h's exact ub_fmaf. */
#ifndef UNBOUND_SIMD_PORTABLE_H
#define UNBOUND_SIMD_PORTABLE_H
/* The march calls the Julia set's estimate (march.h, march_de): inlined, the portable build
 * measured 4 % slower on x86-64. */
#define UB_INLINE_JULIA_MARCH 0
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "ubmath.h"

#ifdef __FP_FAST_FMAF
#define V_FMAF(a, b, c) fmaf(a, b, c)
#else
#define V_FMAF(a, b, c) ub_fmaf(a, b, c)
#endif

typedef struct { float v[8]; } vf;
typedef struct { int32_t v[8]; } vm; /* -1 = true, 0 = false */

#define V_LOOP(i) for (int i = 0; i < 8; i++)

static inline vf v_set1(float x) { vf r; V_LOOP(i) r.v[i] = x; return r; }
static inline vf v_load(const float *p) { vf r; memcpy(r.v, p, sizeof r.v); return r; }
static inline void v_store(float *p, vf a) { memcpy(p, a.v, sizeof a.v); }
static inline vf v_add(vf a, vf b) { V_LOOP(i) a.v[i] = a.v[i] + b.v[i]; return a; }
static inline vf v_sub(vf a, vf b) { V_LOOP(i) a.v[i] = a.v[i] - b.v[i]; return a; }
static inline vf v_mul(vf a, vf b) { V_LOOP(i) a.v[i] = a.v[i] * b.v[i]; return a; }
static inline vf v_div(vf a, vf b) { V_LOOP(i) a.v[i] = a.v[i] / b.v[i]; return a; }
static inline vf v_sqrt(vf a) { V_LOOP(i) a.v[i] = sqrtf(a.v[i]); return a; }
static inline vf v_fma(vf a, vf b, vf c) { V_LOOP(i) a.v[i] = V_FMAF(a.v[i], b.v[i], c.v[i]); return a; }
static inline vf v_fms(vf a, vf b, vf c) { V_LOOP(i) a.v[i] = V_FMAF(a.v[i], b.v[i], -c.v[i]); return a; }
static inline vf v_min(vf a, vf b) { V_LOOP(i) a.v[i] = a.v[i] < b.v[i] ? a.v[i] : b.v[i]; return a; }
static inline vf v_max(vf a, vf b) { V_LOOP(i) a.v[i] = a.v[i] > b.v[i] ? a.v[i] : b.v[i]; return a; }
static inline vm v_lt(vf a, vf b) { vm r; V_LOOP(i) r.v[i] = a.v[i] < b.v[i] ? -1 : 0; return r; }
static inline vm v_le(vf a, vf b) { vm r; V_LOOP(i) r.v[i] = a.v[i] <= b.v[i] ? -1 : 0; return r; }
static inline vm v_gt(vf a, vf b) { vm r; V_LOOP(i) r.v[i] = a.v[i] > b.v[i] ? -1 : 0; return r; }
static inline vm m_and(vm a, vm b) { V_LOOP(i) a.v[i] &= b.v[i]; return a; }
static inline vm m_or(vm a, vm b) { V_LOOP(i) a.v[i] |= b.v[i]; return a; }
static inline vm m_andnot(vm a, vm b) { V_LOOP(i) a.v[i] = ~a.v[i] & b.v[i]; return a; }
static inline vm m_false(void) { vm r; V_LOOP(i) r.v[i] = 0; return r; }
static inline int m_bits(vm a) { int b = 0; V_LOOP(i) b |= (a.v[i] ? 1 : 0) << i; return b; }
static inline vm m_andnot_gt(vf a, vf b, vm lanes) { return m_andnot(v_gt(a, b), lanes); }
static inline int m_either(vm a, vm b) { return m_bits(m_or(a, b)) != 0; }
static inline vm m_from_bits(int bits) { vm r; V_LOOP(i) r.v[i] = (bits >> i) & 1 ? -1 : 0; return r; }
/* The bit word of the lanes l where a[l] == value (a: an int per lane). */
static inline int lanes_int_eq(const int *a, int value) { int b = 0; V_LOOP(i) b |= (a[i] == value) << i; return b; }
static inline vf v_select(vm m, vf a, vf b) { V_LOOP(i) a.v[i] = m.v[i] ? a.v[i] : b.v[i]; return a; }
/* p's lanes m take a, the others keep theirs (simd_avx2.h). */
static inline void v_store_lanes(float *p, vm m, vf a) { v_store(p, v_select(m, a, v_load(p))); }
static inline vf v_count(vf a, vm m) { V_LOOP(i) a.v[i] = a.v[i] + (m.v[i] ? 1.0f : 0.0f); return a; }

/* v_log's reduction (estimators.h): x = 2^k z with z in [0.699, 1.398), and the table entries
 * invc[i], logc[i] of z's interval i (its top mantissa bits, glibc logf's layout). */
static inline void v_log_reduce(vf x, const float invc[16], const float logc[16], vf *z, vf *k, vf *ic, vf *lc)
{
    V_LOOP(l) {
        uint32_t xi, zi;
        memcpy(&xi, &x.v[l], 4);
        const uint32_t t = xi - 0x3f330000u, i = (t >> 19) & 15u;
        zi = xi - (t & 0xff800000u);
        memcpy(&z->v[l], &zi, 4);
        /* the arithmetic shift of t as a signed word, spelled without one */
        const int32_t e = (int32_t)(t >> 23) - ((t & 0x80000000u) ? 512 : 0);
        k->v[l] = (float)e;
        ic->v[l] = invc[i];
        lc->v[l] = logc[i];
    }
}

#endif
