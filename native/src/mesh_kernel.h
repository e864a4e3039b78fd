/* The estimate with the orbit trap at mesh vertices, compiled twice like kernel.h (mesh_avx2.c,
 * mesh_portable.c): the kernels' own arithmetic, identical bits on both. */
#ifndef KERNEL_SUFFIX
#error "define KERNEL_SUFFIX and include a simd_*.h header before mesh_kernel.h"
#endif
#include "scene.h"

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
        for (size_t l = 0; l < UB_LANES; l++) {
            const float *p = xyz + 3 * (base + (l < n ? l : n - 1));
            double pd[3] = {p[0], p[1], p[2]};
            float ql[4];
            to_quaternion(o, pd, ql);
            for (int k = 0; k < 4; k++)
                q[k][l] = ql[k];
        }
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
