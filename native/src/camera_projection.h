/* A projection camera's ray of one point of the image, in view space and in world space: the
 * arithmetic that camera.c's ub_camera_ray and the kernels' camera packets share, so that a ray
 * has the same bits whichever of them computes it. Static inline: kernel.h includes it into each
 * SIMD kernel, where a lane loop over these functions vectorises in double precision (only + - *
 * / and sqrt, correctly rounded in any vector width, and the exact fabs and copysign;
 * -ffp-contract=off keeps each product and sum separately rounded). `orthographic` is a
 * parameter rather than read from the camera so that a caller passing a constant gets a loop
 * without branches. */
#ifndef UB_CAMERA_PROJECTION_H
#define UB_CAMERA_PROJECTION_H

#include "scene.h"

#include <math.h>

/* What the rays of one image row py share: the homogeneous points of the row's point px = 0 on
 * both clip planes and their steps per unit of px. */
typedef struct {
    double start[4], start_per_x[4], end[4], end_per_x[4];
} projection_row;

static inline __attribute__((always_inline)) void projection_row_of(const ub_clip_plane_map *clip_start,
        const ub_clip_plane_map *clip_end, double py, projection_row *row)
{
    for (int i = 0; i < 4; i++) {
        row->start[i] = clip_start->origin[i] + py * clip_start->per_y[i];
        row->start_per_x[i] = clip_start->per_x[i];
        row->end[i] = clip_end->origin[i] + py * clip_end->per_y[i];
        row->end_per_x[i] = clip_end->per_x[i];
    }
}

/* View-space ray (ov, dv) through point px of the row and its t range between the clip planes
 * (always inlined: the kernels' lane loops over it must vectorise for both projections).
 * A pure function of (px, row): no step is carried from one pixel to the next, so a ray has the
 * same bits in any packet, tile, band or thread. Few divides (issue 21: 11 divides per ray made
 * the rays 13 % of a render): the points are homogeneous, v on the clip-start plane and w on the
 * clip-end plane, and the divide by their fourth coordinate cancels where it can. */
static inline __attribute__((always_inline)) void projection_ray_in_row(const projection_row *row, int orthographic,
                                                                        int by_ratio, double depth_ratio, double px,
                                                                        double ov[3], double dv[3], double *t_min,
                                                                        double *t_max)
{
    double v[4], w[4];
    for (int i = 0; i < 4; i++) {
        v[i] = row->start[i] + px * row->start_per_x[i];
        w[i] = row->end[i] + px * row->end_per_x[i];
    }
    if (!orthographic) {
        /* The ray from the eye through the point v.xyz / v3: its direction is v.xyz / |v.xyz| with
         * v3's sign, and it meets the planes at t = |v.xyz| / |v3| and |w.xyz| / |w3| (Blender
         * clips at view-axis depths, so t runs between the two planes along the ray). */
        double lv = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        double to_unit = copysign(1.0, v[3]) / lv;
        for (int i = 0; i < 3; i++) {
            dv[i] = v[i] * to_unit;
            ov[i] = 0.0;
        }
        *t_min = lv / fabs(v[3]);
        /* by_ratio: t_max from the camera's clip_depth_ratio, without w's root and divide (issue
         * 21: the peer render 1.015x): the planes' depths are in that ratio along every ray. */
        if (by_ratio) {
            *t_max = *t_min * depth_ratio;
        } else {
            double lw = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
            *t_max = lw / fabs(w[3]);
        }
    } else {
        /* Parallel rays from the point pn on the clip-start plane towards pf on the clip-end one
         * (w = 1 for Blender's orthographic matrices, where the divides are exact). */
        double to_start = 1.0 / v[3], to_end = 1.0 / w[3];
        double pn[3], pf[3], d[3];
        for (int i = 0; i < 3; i++) {
            pn[i] = v[i] * to_start;
            pf[i] = w[i] * to_end;
            d[i] = pf[i] - pn[i];
        }
        double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        double to_unit = 1.0 / l;
        for (int i = 0; i < 3; i++)
            dv[i] = d[i] * to_unit;
        /* Start rays on the camera plane (z = 0) so that t is the distance from the camera: t
         * per unit of view depth is 1 / dv[2] = l / d[2]. */
        double per_depth = l / d[2];
        double s = pn[2] * per_depth;
        for (int i = 0; i < 3; i++)
            ov[i] = pn[i] - dv[i] * s;
        *t_min = s;
        *t_max = pf[2] * per_depth;
    }
}

/* View-space ray (ov, dv) through image point (px, py) and its t range between the clip planes.
 * Always inlined: the cones call it in lane loops (cone.h, block_cones_kind), which stay scalar
 * around a call; clang (zig cc, the release builds) left it out of line where GCC inlines it
 * (issue 21: the release build 1.037x with AVX-512, the same bits). */
static inline __attribute__((always_inline)) void projection_ray_view_kind(const ub_camera *cam, int orthographic,
        double px, double py, double ov[3], double dv[3], double *t_min, double *t_max)
{
    projection_row row;
    projection_row_of(&cam->clip_start, &cam->clip_end, py, &row);
    projection_ray_in_row(&row, orthographic, cam->clip_depth_ratio > 0.0, cam->clip_depth_ratio, px, ov, dv, t_min,
                          t_max);
}

/* The view-space ray (ov, dv) in world space, by the camera's cam_to_world. */
static inline void view_to_world(const double cam_to_world[3][4], const double ov[3], const double dv[3],
                                 double origin[3], double dir[3])
{
    for (int r = 0; r < 3; r++) {
        const double *row = cam_to_world[r];
        dir[r] = row[0] * dv[0] + row[1] * dv[1] + row[2] * dv[2];
        origin[r] = row[0] * ov[0] + row[1] * ov[1] + row[2] * ov[2] + row[3];
    }
}

#endif
