/* Camera rays from Blender's camera description: camera matrix and projection matrix. */
#include "params.h"
#include "scene.h"

#include <math.h>
#include <string.h>

static int invert4(const double m[4][4], double out[4][4])
{
    double a[4][8];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 8; j++)
            a[i][j] = j < 4 ? m[i][j] : (j - 4 == i ? 1.0 : 0.0);
    for (int c = 0; c < 4; c++) {
        int piv = c;
        for (int r = c + 1; r < 4; r++)
            if (fabs(a[r][c]) > fabs(a[piv][c]))
                piv = r;
        if (!(fabs(a[piv][c]) > 1e-300))
            return 0;
        for (int j = 0; j < 8; j++) {
            double t = a[c][j]; a[c][j] = a[piv][j]; a[piv][j] = t;
        }
        double inv = 1.0 / a[c][c];
        for (int j = 0; j < 8; j++)
            a[c][j] *= inv;
        for (int r = 0; r < 4; r++)
            if (r != c) {
                double f = a[r][c];
                for (int j = 0; j < 8; j++)
                    a[r][j] -= f * a[c][j];
            }
    }
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            out[i][j] = a[i][j + 4];
    return 1;
}

const char *ub_camera_prepare(ub_camera *cam, const double cam_to_world[4][4],
                              const double projection[4][4])
{
    /* Like Cycles, ignore the camera object's scale: normalise the rotation columns. */
    for (int c = 0; c < 3; c++) {
        double len = sqrt(cam_to_world[0][c] * cam_to_world[0][c] + cam_to_world[1][c] * cam_to_world[1][c]
                          + cam_to_world[2][c] * cam_to_world[2][c]);
        if (!(len > 1e-12))
            return "camera.matrix must have a non-degenerate rotation";
        for (int r = 0; r < 3; r++)
            cam->cam_to_world[r][c] = cam_to_world[r][c] / len;
    }
    for (int r = 0; r < 3; r++) {
        cam->cam_to_world[r][3] = cam_to_world[r][3];
        cam->position[r] = cam_to_world[r][3];
        cam->forward[r] = -cam->cam_to_world[r][2];
    }
    if (!invert4(projection, cam->inv_projection))
        return "camera.projection must be invertible";
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            if (!isfinite(cam->inv_projection[i][j]))
                return "camera.projection must be invertible";
    /* A perspective projection's last row is (0, 0, -1, 0); an orthographic one's (0, 0, 0, 1). */
    cam->orthographic = projection[3][2] == 0.0;
    if (!(projection[0][0] != 0.0 && projection[1][1] != 0.0))
        return "camera.projection must have non-zero [0][0] and [1][1]";
    /* Pixel footprint: width of one pixel on the plane at unit distance (perspective) or on the
     * image plane (orthographic); the smaller of the pixel's two sides when pixels are not square. */
    double fx = 2.0 / (cam->width * fabs(projection[0][0]));
    double fy = 2.0 / (cam->height * fabs(projection[1][1]));
    double f = fmin(fx, fy);
    cam->footprint0 = cam->orthographic ? f : 0.0;
    cam->footprint1 = cam->orthographic ? 0.0 : f;
    /* Clip planes: an infinite far plane (a projection whose clip end sits at w = 0) would put
     * infinite depths and positions into the passes. Clip planes are planes, so the image's
     * corners and centre bound every pixel's clip range. */
    static const double corners[5][2] = {{0, 0}, {1, 0}, {0, 1}, {1, 1}, {0.5, 0.5}};
    for (int i = 0; i < 5; i++) {
        double o[3], d[3], t0, t1;
        ub_camera_ray(cam, corners[i][0] * cam->width, corners[i][1] * cam->height, o, d, &t0, &t1);
        if (!(isfinite(t0) && isfinite(t1) && t0 >= 0.0 && t1 > t0 && t1 < 1e30))
            return "camera.projection must have finite clip planes, 0 <= clip start < clip end";
    }
    return NULL;
}

static void unproject(const ub_camera *cam, double nx, double ny, double nz, double out[3])
{
    const double(*m)[4] = cam->inv_projection;
    double v[4];
    for (int i = 0; i < 4; i++)
        v[i] = m[i][0] * nx + m[i][1] * ny + m[i][2] * nz + m[i][3];
    for (int i = 0; i < 3; i++)
        out[i] = v[i] / v[3];
}

void ub_camera_ray(const ub_camera *cam, double px, double py, double origin[3], double dir[3],
                   double *t_min, double *t_max)
{
    /* Normalised device coordinates of the pixel centre; y = -1 is the bottom row. */
    double nx = 2.0 * px / cam->width - 1.0;
    double ny = 2.0 * py / cam->height - 1.0;
    double pn[3], pf[3], dv[3], ov[3];
    unproject(cam, nx, ny, -1.0, pn); /* on the clip-start plane */
    unproject(cam, nx, ny, 1.0, pf);  /* on the clip-end plane */
    if (!cam->orthographic) {
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
    for (int r = 0; r < 3; r++) {
        const double *row = cam->cam_to_world[r];
        dir[r] = row[0] * dv[0] + row[1] * dv[1] + row[2] * dv[2];
        origin[r] = row[0] * ov[0] + row[1] * ov[1] + row[2] * ov[2] + row[3];
    }
}

const char *ub_camera_from_input(ub_camera *cam, const ub_camera_input *in)
{
    memset(cam, 0, sizeof *cam);
    cam->width = in->width;
    cam->height = in->height;
    return ub_camera_prepare(cam, in->matrix, in->projection);
}

double ub_pixel_footprint(const ub_camera *cam, double t)
{
    return cam->footprint0 + cam->footprint1 * t;
}
