/* The marching kernel in portable C: any CPU, bit-identical to the AVX2 kernel. */
#include "simd_portable.h"
#define KERNEL_SUFFIX _portable
#include "kernel.h"
