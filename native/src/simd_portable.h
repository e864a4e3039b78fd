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
static inline vm m_from_bits(int bits) { vm r; V_LOOP(i) r.v[i] = (bits >> i) & 1 ? -1 : 0; return r; }
static inline vf v_select(vm m, vf a, vf b) { V_LOOP(i) a.v[i] = m.v[i] ? a.v[i] : b.v[i]; return a; }
static inline vf v_count(vf a, vm m) { V_LOOP(i) a.v[i] = a.v[i] + (m.v[i] ? 1.0f : 0.0f); return a; }

static inline void v_frexp_centered(vf x, vf *m, vf *e)
{
    V_LOOP(i) {
        uint32_t bits;
        memcpy(&bits, &x.v[i], 4);
        int32_t ex = (int32_t)(bits >> 23) - 127;
        uint32_t mb = (bits & 0x007fffffu) | 0x3f800000u;
        float mf;
        memcpy(&mf, &mb, 4);
        if (mf > 1.41421356f) {
            mf = mf * 0.5f;
            ex += 1;
        }
        m->v[i] = mf;
        e->v[i] = (float)ex;
    }
}

#endif
