/* Surface extraction from the distance estimate (Convert to Mesh): narrow band, no dense grid.
 * See mesh.c for the method. */
#ifndef UNBOUND_MESH_H
#define UNBOUND_MESH_H
#include "scene.h"

#include <stddef.h>
#include <stdint.h>

typedef struct {
    int resolution;        /* lattice cells across the bounding ball's diameter */
    double epsilon;        /* surface: estimate = epsilon (object units); <= 0: cell size / 64 */
    int64_t min_faces;     /* pieces with fewer faces are removed (0: keep every piece) */
    int seed_spacing;      /* cells between the seed scan lines; 0: automatic */
    int threads;           /* 0: one per CPU */
    int use_avx2;
    int (*poll)(void *data, double fraction); /* non-zero return cancels; on the calling thread */
    void *poll_data;
    double poll_interval;  /* seconds */
} ub_mesh_options;

typedef struct {
    float *vertices;       /* 3 per vertex, object space */
    int32_t *faces;        /* 3 per triangle, counter-clockwise seen from outside */
    float *trap, *iterations, *estimate; /* per vertex */
    int64_t vertex_count, face_count;
    /* statistics */
    int64_t cells, active_cells, evaluations, seeds, pieces, pieces_removed;
    double epsilon, cell_size, seconds;
    double phase_seconds[5]; /* since the start, at the end of: seeds, tracking, triangles, projection, crumbs */
    size_t peak_bytes;
    int threads, cancelled;
} ub_mesh_result;

void ub_mesh_attributes_avx2(const ub_object *, const float *, size_t, float *, float *, float *);
void ub_mesh_attributes_portable(const ub_object *, const float *, size_t, float *, float *, float *);
/* The quaternion kinds' estimate in float64 at float32 points (mesh_kernel.h): estimate, and
 * escape count and orbit trap where not NULL. */
void ub_mesh_estimate64_avx2(const ub_object *, const float *, size_t, double *, float *, float *);
void ub_mesh_estimate64_portable(const ub_object *, const float *, size_t, double *, float *, float *);

/* Returns NULL (result filled; free with ub_mesh_free) or an error message. */
const char *ub_extract_mesh(const ub_object *o, const ub_mesh_options *opt, ub_mesh_result *out);
void ub_mesh_free(ub_mesh_result *r);
#endif
