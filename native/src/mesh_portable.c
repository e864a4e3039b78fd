/* Mesh vertex attributes in portable C (see mesh_kernel.h). */
#include "simd_portable.h"
#define KERNEL_SUFFIX _portable
#include "mesh_kernel.h"
