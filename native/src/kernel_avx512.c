/* The render kernel for x86-64 CPUs with AVX-512 (F, CD, BW, DQ, VL: x86-64-v4's set, which every
 * AVX-512 CPU but the Xeon Phi has), chosen at run time (render.c): packets of 16 rays,
 * bit-identical to the AVX2 and portable kernels' 8. */
#if defined(__x86_64__) || defined(_M_X64)
/* The system headers first, untouched by the target attribute below. */
#include <float.h>
#include <immintrin.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
/* Every function below is compiled for AVX-512 F, CD, BW, DQ and VL (FMA included). VL and DQ let
 * the compiler's own 128- and 256-bit code (the shading's per-lane loops) use all 32 vector
 * registers and the mask registers; no instruction they add rounds differently, so the bits are
 * the same (issue 21: peer scene 1.011x over 16 rounds, same digest of every pass). Clang (zig cc,
 * Apple clang) ignores `#pragma GCC target`; it takes the attribute pushed onto each function
 * instead. */
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx512f,avx512cd,avx512bw,avx512dq,avx512vl,avx2,fma"))), apply_to = function)
#else
#pragma GCC target("avx512f,avx512cd,avx512bw,avx512dq,avx512vl,avx2,fma")
#endif
#include "simd_avx512.h"
#define KERNEL_SUFFIX _avx512
#include "kernel.h"
#if defined(__clang__)
#pragma clang attribute pop
#endif
#else
/* Other architectures: the portable kernel is the only one. */
#include "scene.h"
void ub_render_tile_avx512(const ub_scene *s, int p, int k, int a, int b, int c, int d, ub_counters *n)
{
    ub_render_tile_portable(s, p, k, a, b, c, d, n);
}
void ub_estimate_avx512(const ub_object *o, const float *x, size_t n, float *e, float *i)
{
    ub_estimate_portable(o, x, n, e, i);
}
void ub_normals_avx512(const ub_object *o, const float *x, const float *t, size_t n, float *out)
{
    ub_normals_portable(o, x, t, n, out);
}
void ub_zoom_probe_avx512(const ub_object *o, int path, int want, int scalar, const float *x, size_t n, double *out)
{
    ub_zoom_probe_portable(o, path, want, scalar, x, n, out);
}
#endif
