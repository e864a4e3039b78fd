/* A projection camera's ray of one point of the image, in view space and in world space: the
 * arithmetic that camera.c's ub_camera_ray and the kernels' camera packets share, so that a ray
 * has the same bits whichever of them computes it. Static inline: kernel.h includes it into each
 * SIMD kernel, where a lane loop over these functions vectorises in double precision (only + - *
 * / and sqrt, correctly rounded in any vector width; -ffp-contract=off keeps each product and sum
 * separately rounded). `orthographic` is a parameter rather than read from the camera so that a
 * caller passing a constant gets a loop without branches. */
#ifndef UB_CAMERA_PROJECTION_H
#define UB_CAMERA_PROJECTION_H

#include "scene.h"

#include <math.h>

/* View-space point of normalised device coordinates (nx, ny, nz). */
static inline void unproject(const double m[4][4], double nx, double ny, double nz, double out[3])
{
    double v[4];
    for (int i = 0; i < 4; i++)
        v[i] = m[i][0] * nx + m[i][1] * ny + m[i][2] * nz + m[i][3];
    for (int i = 0; i < 3; i++)
        out[i] = v[i] / v[3];
}

/* View-space ray (ov, dv) through image point (px, py) and its t range between the clip planes. */
static inline void projection_ray_view_kind(const ub_camera *cam, int orthographic, double px, double py,
                                            double ov[3], double dv[3], double *t_min, double *t_max)
{
    /* Normalised device coordinates of the pixel centre; y = -1 is the bottom row. */
    double nx = 2.0 * px / cam->width - 1.0;
    double ny = 2.0 * py / cam->height - 1.0;
    double pn[3], pf[3];
    unproject(cam->inv_projection, nx, ny, -1.0, pn); /* on the clip-start plane */
    unproject(cam->inv_projection, nx, ny, 1.0, pf);  /* on the clip-end plane */
    if (!orthographic) {
        double ln = sqrt(pn[0] * pn[0] + pn[1] * pn[1] + pn[2] * pn[2]);
        double lf = sqrt(pf[0] * pf[0] + pf[1] * pf[1] + pf[2] * pf[2]);
        for (int i = 0; i < 3; i++) {
            dv[i] = pn[i] / ln;
            ov[i] = 0.0;
        }
        /* Blender clips at view-axis depths, so t runs between the two planes along the ray. */
        *t_min = ln;
        *t_max = lf;
    } else {
        double d[3] = {pf[0] - pn[0], pf[1] - pn[1], pf[2] - pn[2]};
        double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        for (int i = 0; i < 3; i++)
            dv[i] = d[i] / l;
        /* Start rays on the camera plane so that t is the distance from the camera. */
        double s = pn[2] / dv[2];
        for (int i = 0; i < 3; i++)
            ov[i] = pn[i] - dv[i] * s;
        *t_min = s;
        *t_max = pf[2] / dv[2];
    }
}

static inline void view_to_world(const ub_camera *cam, const double ov[3], const double dv[3], double origin[3],
                                 double dir[3])
{
    for (int r = 0; r < 3; r++) {
        const double *row = cam->cam_to_world[r];
        dir[r] = row[0] * dv[0] + row[1] * dv[1] + row[2] * dv[2];
        origin[r] = row[0] * ov[0] + row[1] * ov[1] + row[2] * ov[2] + row[3];
    }
}

#endif
