/* The estimate with the orbit trap at mesh vertices, compiled twice like kernel.h (mesh_avx2.c,
 * mesh_portable.c): the kernels' own arithmetic, identical bits on both. */
#ifndef KERNEL_SUFFIX
#error "define KERNEL_SUFFIX and include a simd_*.h header before mesh_kernel.h"
#endif
#include "scene.h"
#include "ubmath.h"

#include <float.h>
#include <math.h>
#include <string.h>

#define UB_CAT2(a, b) a##b
#define UB_CAT(a, b) UB_CAT2(a, b)
#define UB_ENTRY(name) UB_CAT(name, KERNEL_SUFFIX)

#include "estimators.h"

void UB_ENTRY(ub_mesh_attributes)(const ub_object *o, const float *xyz, size_t count, float *estimate,
                                  float *iterations, float *trap)
{
    ub_de_params dp;
    de_params(o, NULL, &dp);
    for (size_t base = 0; base < count; base += UB_LANES) {
        size_t n = count - base < UB_LANES ? count - base : UB_LANES;
        float q[4][UB_LANES];
        point_packet(o, xyz, base, n, q);
        vf dist, it;
        ub_de_extra x;
        de_ext(&dp, m_from_bits(UB_ALL_LANES), v_load(q[0]), v_load(q[1]), v_load(q[2]), v_load(q[3]), UB_WANT_TRAP, &dist, &it, &x);
        float db[UB_LANES], ib[UB_LANES], tb[UB_LANES];
        v_store(db, dist);
        v_store(ib, it);
        v_store(tb, x.trap);
        for (size_t l = 0; l < n; l++) {
            estimate[base + l] = db[l];
            iterations[base + l] = ib[l];
            trap[base + l] = tb[l];
        }
    }
}

/* The quaternion kinds' estimate in float64 (issue 20: the mesh lies on the float64 surface; the
 * float32 orbit departs from it by a twentieth of a cell in the median at 1024 cells, 16
 * squarings amplifying its rounding). The same orbit as de_quaternion (Julia: z0 = the point, mu
 * fixed, |f'|^2 <- 4|z|^2|f'|^2; Mandelbrot: z0 = mu = the point, |f'| <- 2|z||f'| + 1), the
 * estimate sqrt(r2 / dr2) log(r2) / 4 at the escape (0 for orbits that stay), the escape count
 * and the orbit trap sqrt(min |z_k|^2). At float32 points (a vertex is stored in float32: its
 * estimate is that of the point stored), mapped to the slice in double.
 *
 * Plain IEEE + - * / sqrt and ub_log on GCC vectors of four doubles (clang has them too; the AVX2
 * build makes each one register, the portable one two SSE2 or NEON halves), two vectors at a
 * time to hide the latency of the orbit's chain: with -ffp-contract=off every lane rounds as
 * scalar code would, so every ISA gives the same bits. */
typedef double ub_v4d __attribute__((vector_size(32)));
typedef int64_t ub_v4m __attribute__((vector_size(32))); /* lane masks: 0 or -1 */

/* A macro, not a function: a function passing 32-byte vectors has an ABI that depends on AVX. */
#define V4D_SELECT(m, yes, no) ((ub_v4d)(((m) & (ub_v4m)(yes)) | (~(m) & (ub_v4m)(no))))

void UB_ENTRY(ub_mesh_estimate64)(const ub_object *o, const float *xyz, size_t count, double *estimate,
                                  float *iterations, float *trap)
{
    enum { V = 2, L = 4 * V }; /* vectors and lanes a block */
    const int mandel = o->kind == UB_KIND_QUATERNION_MANDELBROT;
    const double bail2 = o->bailout * o->bailout;
    const ub_v4d one = {1.0, 1.0, 1.0, 1.0}, two = one + one, four = two + two, bail = bail2 * one;
    for (size_t base = 0; base < count; base += L) {
        size_t n = count - base < L ? count - base : L;
        ub_v4d z[4][V], mu[4][V], r2[V], dr2[V], dm[V], tr[V], it[V];
        ub_v4m active[V];
        for (int v = 0; v < V; v++) {
            for (int l = 0; l < 4; l++) {
                size_t i = (size_t)(4 * v + l) < n ? (size_t)(4 * v + l) : n - 1;
                const float *p = xyz + 3 * (base + i);
                for (int k = 0; k < 4; k++) {
                    const double *b = o->slice_basis[k];
                    z[k][v][l] = o->slice_origin[k] + b[0] * (double)p[0] + b[1] * (double)p[1] + b[2] * (double)p[2];
                    mu[k][v][l] = mandel ? z[k][v][l] : o->mu[k];
                }
            }
            r2[v] = z[0][v] * z[0][v] + z[1][v] * z[1][v] + z[2][v] * z[2][v] + z[3][v] * z[3][v];
            dr2[v] = dm[v] = one;
            tr[v] = r2[v];
            it[v] = one - one;
            active[v] = (ub_v4m){-1, -1, -1, -1};
        }
        for (int i = 0; i < o->max_iterations; i++) {
            ub_v4m any = {0, 0, 0, 0};
            for (int v = 0; v < V; v++) {
                const ub_v4d a = z[0][v], a2 = a + a;
                const ub_v4d na = (a * a + mu[0][v]) - (z[1][v] * z[1][v] + z[2][v] * z[2][v] + z[3][v] * z[3][v]);
                const ub_v4d nb = a2 * z[1][v] + mu[1][v], nc = a2 * z[2][v] + mu[2][v], nd = a2 * z[3][v] + mu[3][v];
                const ub_v4d nr2 = na * na + nb * nb + nc * nc + nd * nd;
                const ub_v4m act = active[v];
                if (mandel) {
                    ub_v4d root;
                    for (int l = 0; l < 4; l++)
                        root[l] = sqrt(r2[v][l]);
                    dm[v] = V4D_SELECT(act, two * root * dm[v] + one, dm[v]);
                } else {
                    dr2[v] = V4D_SELECT(act, dr2[v] * (four * r2[v]), dr2[v]);
                }
                /* Escaped lanes iterate on (to inf or NaN, harmless): what is read froze at the escape. */
                z[0][v] = na;
                z[1][v] = nb;
                z[2][v] = nc;
                z[3][v] = nd;
                r2[v] = V4D_SELECT(act, nr2, r2[v]);
                tr[v] = V4D_SELECT(act & (ub_v4m)(nr2 < tr[v]), nr2, tr[v]);
                it[v] = V4D_SELECT(act, it[v] + one, it[v]);
                active[v] = act & ~(ub_v4m)(nr2 > bail);
                any |= active[v];
            }
            if (!(any[0] | any[1] | any[2] | any[3]))
                break;
        }
        for (size_t i = 0; i < n; i++) {
            const int v = (int)(i / 4), l = (int)(i % 4);
            const double r = r2[v][l], d2 = mandel ? dm[v][l] * dm[v][l] : dr2[v][l];
            estimate[base + i] = r > bail2 ? sqrt(r / d2) * ub_log(r) * 0.25 : 0.0;
            if (iterations)
                iterations[base + i] = (float)it[v][l];
            if (trap)
                trap[base + i] = (float)sqrt(tr[v][l]);
        }
    }
}
