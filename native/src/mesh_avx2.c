/* Mesh vertex attributes for x86-64 CPUs with AVX2 and FMA (see mesh_kernel.h, kernel_avx2.c). */
#if defined(__x86_64__) || defined(_M_X64)
/* The system headers first, untouched by the target attribute below. */
#include <float.h>
#include <immintrin.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
/* Every function below is compiled for AVX2 + FMA. Clang (zig cc, Apple clang) ignores
 * `#pragma GCC target`; it takes the attribute pushed onto each function instead. */
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2,fma"))), apply_to = function)
#else
#pragma GCC target("avx2,fma")
#endif
#include "simd_avx2.h"
#define KERNEL_SUFFIX _avx2
#include "mesh_kernel.h"
#if defined(__clang__)
#pragma clang attribute pop
#endif
#else
/* Other architectures: the portable one only. */
#include "mesh.h"
void ub_mesh_attributes_avx2(const ub_object *o, const float *x, size_t n, float *e, float *i, float *t)
{
    ub_mesh_attributes_portable(o, x, n, e, i, t);
}
void ub_mesh_estimate64_avx2(const ub_object *o, const float *x, size_t n, double *e, float *i, float *t)
{
    ub_mesh_estimate64_portable(o, x, n, e, i, t);
}
#endif
