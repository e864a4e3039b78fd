/* 8-lane float vectors in portable C: the bit-exact twin of simd_avx2.h for CPUs without
 * AVX2/FMA and for other architectures. Both kernels' results stay identical because every
 * fused multiply-add rounds once, as IEEE's fma: where the target has the instruction
 * (__FP_FAST_FMAF: arm64, x86-64 built with FMA) fmaf() is that one instruction; elsewhere not
 * libm's fmaf, which is a slow or, on mingw, not even correctly rounded emulation, but
 * ubmath.h's exact ub_fmaf. */
#ifndef UNBOUND_SIMD_PORTABLE_H
#define UNBOUND_SIMD_PORTABLE_H
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

/* Doubles for the deep zoom's estimate (zoom_lanes.h): 4 per vector, two per packet, in plain C;
 * the bit-exact twin of simd_avx2.h's (IEEE + - * sqrt, no fused multiply-add). */
#define VD_LANES 4
typedef struct { double v[4]; } vd;
typedef struct { int64_t v[4]; } vdm; /* -1 = true, 0 = false */
#define VD_LOOP(i) for (int i = 0; i < 4; i++)
static inline vd vd_set1(double x) { vd r; VD_LOOP(i) r.v[i] = x; return r; }
static inline vd vd_load(const double *p) { vd r; memcpy(r.v, p, sizeof r.v); return r; }
static inline void vd_store(double *p, vd a) { memcpy(p, a.v, sizeof a.v); }
static inline vd vd_add(vd a, vd b) { VD_LOOP(i) a.v[i] = a.v[i] + b.v[i]; return a; }
static inline vd vd_sub(vd a, vd b) { VD_LOOP(i) a.v[i] = a.v[i] - b.v[i]; return a; }
static inline vd vd_mul(vd a, vd b) { VD_LOOP(i) a.v[i] = a.v[i] * b.v[i]; return a; }
static inline vd vd_sqrt(vd a) { VD_LOOP(i) a.v[i] = sqrt(a.v[i]); return a; }
static inline vd vd_div(vd a, vd b) { VD_LOOP(i) a.v[i] = a.v[i] / b.v[i]; return a; }
static inline vd vd_floor(vd a) { VD_LOOP(i) a.v[i] = floor(a.v[i]); return a; }
static inline vd vd_min(vd a, vd b) { VD_LOOP(i) a.v[i] = a.v[i] < b.v[i] ? a.v[i] : b.v[i]; return a; }
static inline vd vd_max(vd a, vd b) { VD_LOOP(i) a.v[i] = a.v[i] > b.v[i] ? a.v[i] : b.v[i]; return a; }
static inline vdm vd_lt(vd a, vd b) { vdm r; VD_LOOP(i) r.v[i] = a.v[i] < b.v[i] ? -1 : 0; return r; }
static inline vdm vd_gt(vd a, vd b) { vdm r; VD_LOOP(i) r.v[i] = a.v[i] > b.v[i] ? -1 : 0; return r; }
static inline vdm vd_ge(vd a, vd b) { vdm r; VD_LOOP(i) r.v[i] = a.v[i] >= b.v[i] ? -1 : 0; return r; }
static inline vdm vdm_and(vdm a, vdm b) { VD_LOOP(i) a.v[i] &= b.v[i]; return a; }
static inline vdm vdm_or(vdm a, vdm b) { VD_LOOP(i) a.v[i] |= b.v[i]; return a; }
static inline vdm vdm_andnot(vdm a, vdm b) { VD_LOOP(i) a.v[i] = ~a.v[i] & b.v[i]; return a; }
static inline int vdm_bits(vdm a) { int b = 0; VD_LOOP(i) b |= (a.v[i] ? 1 : 0) << i; return b; }
static inline vdm vdm_from_bits(int bits) { vdm r; VD_LOOP(i) r.v[i] = (bits >> i) & 1 ? -1 : 0; return r; }
static inline vd vd_select(vdm m, vd a, vd b) { VD_LOOP(i) a.v[i] = m.v[i] ? a.v[i] : b.v[i]; return a; }
static inline vd vd_gather(vd src, vdm m, const void *base, vd offset)
{
    VD_LOOP(i) if (m.v[i]) memcpy(&src.v[i], (const char *)base + (ptrdiff_t)offset.v[i], sizeof(double));
    return src;
}
/* Positive normal x = m 2^e, m in [1, 2), by its bits (e exact, as a double). */
static inline void vd_split_exponent(vd x, vd *m, vd *e)
{
    VD_LOOP(i) {
        uint64_t b;
        memcpy(&b, &x.v[i], 8);
        e->v[i] = (double)(int)(b >> 52) - 1023.0;
        b = (b & 0x000fffffffffffffull) | 0x3ff0000000000000ull;
        memcpy(&m->v[i], &b, 8);
    }
}
#endif
