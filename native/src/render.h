#ifndef UNBOUND_RENDER_H
#define UNBOUND_RENDER_H
#include "scene.h"

#include <stdint.h>

/* The kernels (ub_isa_names: "auto", "avx2", "portable", "avx512"); every one gives the same bits. */
typedef enum { UB_ISA_AUTO = 0, UB_ISA_AVX2, UB_ISA_PORTABLE, UB_ISA_AVX512 } ub_isa;

/* Shared first steps kept from one render call to the next (issue 21): an F12 render of several
 * samples calls ub_render once a sample, and without them each call marched every block's cone
 * again (3 % of such a render). Used by one render at a time; reused only where everything the
 * cones depend on (camera, objects, sea, blocks) is the same bytes, else replaced. */
typedef struct ub_kept_cones ub_kept_cones;
ub_kept_cones *ub_kept_cones_new(void);
void ub_kept_cones_free(ub_kept_cones *kept);

typedef struct {
    int threads;     /* 0: one per CPU */
    int tile_size;   /* pixels per tile side */
    ub_isa isa;
    /* Called on the calling thread every poll_interval_ns with the fraction done; a non-zero
     * return cancels the render. May be NULL. */
    int (*poll)(void *data, double fraction);
    void *poll_data;
    int64_t poll_interval_ns;
    /* Render samples first_sample .. first_sample + sample_count - 1 of the shading's `samples`
     * into buffers that hold the earlier ones (their undivided sum): the viewport accumulates a
     * sample at a time, and the last one divides as a whole render does. sample_count 0: all. */
    int first_sample, sample_count;
    int shared_steps; /* shared first steps per block of pixels (kernel cone.h); 0: off */
    /* A cancel in the first sample (first_sample 0) zeroes the film's tiles that were not
     * finished (render.c, clear_unfinished_tiles): the caller's buffers need no clearing before a
     * render that may be cancelled. */
    int clear_unfinished;
    ub_kept_cones *kept_cones; /* NULL: the cones of this call alone */
} ub_render_options;

typedef struct {
    ub_counters counters;
    double seconds;
    int threads;
    const char *isa;
    int cancelled;
} ub_render_stats;

int ub_cpu_count(void);
/* The kernel that `isa` asks for on this CPU (*kernel: AVX512, AVX2 or PORTABLE; auto takes the
 * widest the CPU has); NULL, or an error message if a kernel is forced that the CPU lacks. */
const char *ub_resolve_isa(ub_isa isa, ub_isa *kernel);
/* The tile kernel of a resolved ISA. */
ub_tile_kernel ub_tile_kernel_of(ub_isa kernel);
/* Enter the kernels' floating-point environment on this thread (round to nearest, denormals
 * flushed, exceptions masked); returns the previous one for ub_fp_leave. */
uint64_t ub_fp_enter(void);
void ub_fp_leave(uint64_t previous);
/* Returns NULL on success or an error message (nothing rendered). */
const char *ub_render(const ub_scene *scene, const ub_render_options *opt, ub_render_stats *stats);
#endif
