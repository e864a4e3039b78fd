/* Camera rays from Blender's camera description: camera matrix and projection matrix. */
#include "params.h"
#include "scene.h"
#include "camera_projection.h"

#include <math.h>
#include <string.h>

#include "ubmath.h" /* sin, cos: the same bits on every platform */

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

static void projection_ray(const ub_camera *cam, double px, double py, double origin[3], double dir[3],
                           double *t_min, double *t_max);

/* The inverse projection `inv` on the plane of NDC depth ndc_z as a map of the image point:
 * inv (2 px / width - 1, 2 py / height - 1, ndc_z, 1), its terms gathered by px, py and neither
 * (y = -1 is the bottom row). */
static void clip_plane_map(const double inv[4][4], int width, int height, double ndc_z, ub_clip_plane_map *map)
{
    for (int i = 0; i < 4; i++) {
        map->origin[i] = inv[i][3] + ndc_z * inv[i][2] - inv[i][0] - inv[i][1];
        map->per_x[i] = 2.0 * inv[i][0] / width;
        map->per_y[i] = 2.0 * inv[i][1] / height;
    }
}

/* The camera's clip_depth_ratio (scene.h): for a perspective projection whose NDC depth and w
 * depend on the view depth alone (no x or y terms in their rows, as in Blender's, lens shift
 * included), the clip planes are planes of constant view depth, which every ray from the eye
 * meets at distances in the ratio of their depths, clip end / clip start; else 0. */
static double clip_depth_ratio(const ub_camera *cam, const double projection[4][4])
{
    if (cam->orthographic || projection[2][0] != 0.0 || projection[2][1] != 0.0 || projection[3][0] != 0.0
        || projection[3][1] != 0.0)
        return 0.0;
    const double *v = cam->clip_start.origin, *w = cam->clip_end.origin; /* image point (0, 0) */
    const double ratio = (w[2] / w[3]) / (v[2] / v[3]);
    return isfinite(ratio) && ratio > 1.0 ? ratio : 0.0;
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
    double inv_projection[4][4];
    if (!invert4(projection, inv_projection))
        return "camera.projection must be invertible";
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            if (!isfinite(inv_projection[i][j]))
                return "camera.projection must be invertible";
    clip_plane_map(inv_projection, cam->width, cam->height, -1.0, &cam->clip_start);
    clip_plane_map(inv_projection, cam->width, cam->height, 1.0, &cam->clip_end);
    /* A perspective projection's last row is (0, 0, -1, 0); an orthographic one's (0, 0, 0, 1). */
    cam->orthographic = projection[3][2] == 0.0;
    cam->clip_depth_ratio = clip_depth_ratio(cam, projection);
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
        projection_ray(cam, corners[i][0] * cam->width, corners[i][1] * cam->height, o, d, &t0, &t1);
        if (!(isfinite(t0) && isfinite(t1) && t0 >= 0.0 && t1 > t0 && t1 < 1e30))
            return "camera.projection must have finite clip planes, 0 <= clip start < clip end";
    }
    return NULL;
}

static void projection_ray_view(const ub_camera *cam, double px, double py, double ov[3], double dv[3],
                                double *t_min, double *t_max)
{
    projection_ray_view_kind(cam, cam->orthographic, px, py, ov, dv, t_min, t_max);
}

static void projection_ray(const ub_camera *cam, double px, double py, double origin[3], double dir[3],
                           double *t_min, double *t_max)
{
    double ov[3], dv[3];
    projection_ray_view(cam, px, py, ov, dv, t_min, t_max);
    view_to_world(cam->cam_to_world, ov, dv, origin, dir);
}

/* The elementary functions of the panoramic mappings, one small function each: what reaches
 * pixels must not depend on the platform's libm, so they are ubmath.h's (the same bits on every
 * platform). Every other step below is + - * / and sqrt. */
static double pano_sin(double x)
{
    return ub_sin(x);
}

static double pano_cos(double x)
{
    return ub_cos(x);
}

/* A panoramic camera's direction in Blender's camera space (x right, y up, looking down -z) at
 * panorama coordinates (u, v) in the unit square, as Cycles' panorama_to_direction followed by
 * the turn Cycles' blender_camera_matrix gives panoramic cameras (Cycles' panorama space looks
 * along +x, the mirror ball along -y). Returns 0 outside the lens. Where Cycles takes an angle
 * back from its cosine (fisheyes: phi = acos(u / r); equisolid: theta = 2 asin(r / 2 lens)),
 * its sine and cosine are written directly: the same mapping without two round trips. */
static int panorama_direction(const ub_camera *cam, double u, double v, double d[3])
{
    switch (cam->panorama) {
    case UB_PANORAMA_EQUIRECTANGULAR: {
        double phi = cam->range[0] * u + cam->range[1];
        double theta = cam->range[2] * v + cam->range[3];
        double st = pano_sin(theta);
        /* Cycles' (sin theta cos phi, sin theta sin phi, cos theta), turned. */
        d[0] = -(st * pano_sin(phi));
        d[1] = pano_cos(theta);
        d[2] = -(st * pano_cos(phi));
        return 1;
    }
    case UB_PANORAMA_FISHEYE_EQUIDISTANT:
    case UB_PANORAMA_FISHEYE_EQUISOLID: {
        double a, b, r, sin_t, cos_t;
        if (cam->panorama == UB_PANORAMA_FISHEYE_EQUIDISTANT) {
            a = (u - 0.5) * 2.0;
            b = (v - 0.5) * 2.0;
            r = sqrt(a * a + b * b);
            if (r > 1.0)
                return 0;
            double theta = r * cam->half_fov;
            sin_t = pano_sin(theta);
            cos_t = pano_cos(theta);
        } else {
            a = (u - 0.5) * cam->sensor[0];
            b = (v - 0.5) * cam->sensor[1];
            r = sqrt(a * a + b * b);
            if (r > 2.0 * cam->lens * cam->sin_quarter_fov)
                return 0;
            /* theta = 2 asin(s): cos = 1 - 2 s^2, sin = 2 s sqrt(1 - s^2). */
            double s = r / (2.0 * cam->lens);
            cos_t = 1.0 - 2.0 * s * s;
            sin_t = 2.0 * s * sqrt(fmax(1.0 - s * s, 0.0));
        }
        if (r == 0.0) {
            d[0] = d[1] = 0.0;
            d[2] = -1.0;
            return 1;
        }
        /* Cycles' (cos theta, -cos phi sin theta, sin phi sin theta), cos phi = a / r, sin phi = b / r. */
        d[0] = a / r * sin_t;
        d[1] = b / r * sin_t;
        d[2] = -cos_t;
        return 1;
    }
    case UB_PANORAMA_MIRRORBALL: {
        /* The ball's point (a, -c, b) seen along +y reflects (0, 1, 0): (2 c a, 1 - 2 c^2, 2 c b). */
        double a = 2.0 * u - 1.0, b = 2.0 * v - 1.0;
        if (a * a + b * b > 1.0)
            return 0;
        double c = sqrt(fmax(1.0 - a * a - b * b, 0.0));
        d[0] = 2.0 * c * a;
        d[1] = 2.0 * c * b;
        d[2] = 1.0 - 2.0 * c * c;
        return 1;
    }
    default:
        return 0;
    }
}

/* Cycles' camera_sample_aperture: the point of the aperture that unit-square point uv picks, in
 * world units on the lens' plane (x right, y up): a disk by Shirley and Chiu's concentric map,
 * or a regular polygon (Cycles' regular_polygon_sample: a corner's triangle, then its turn); the
 * width divided by the anamorphic ratio. Only + - * / sqrt and ubmath's sin and cos. */
static void aperture_point(const ub_camera *cam, const double uv[2], double out[2])
{
    double x, y;
    if (cam->blades == 0) {
        double a = 2.0 * uv[0] - 1.0, b = 2.0 * uv[1] - 1.0, r, phi;
        if (a == 0.0 && b == 0.0) {
            r = phi = 0.0;
        } else if (a * a > b * b) {
            r = a;
            phi = M_PI_4 * (b / a);
        } else {
            r = b;
            phi = M_PI_2 - M_PI_4 * (a / b);
        }
        double sp, cp;
        ub_sincos(phi, &sp, &cp);
        x = r * cp;
        y = r * sp;
    } else {
        double n = cam->blades, scaled = uv[0] * n;
        double corner = floor(scaled);
        if (corner > n - 1.0) /* uv[0] * n can round up to n */
            corner = n - 1.0;
        double u = sqrt(scaled - corner), v = uv[1] * u;
        u = 1.0 - u;
        double tx = (u + v) * cam->blade_cos, ty = (u - v) * cam->blade_sin;
        double turn = cam->blade_rotation + corner * (2.0 * M_PI) / n;
        double c, s;
        ub_sincos(turn, &s, &c);
        x = c * tx - s * ty;
        y = s * tx + c * ty;
    }
    out[0] = x * cam->inv_ratio * cam->aperture;
    out[1] = y * cam->aperture;
}

static void normalize3(double v[3])
{
    double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int i = 0; i < 3; i++)
        v[i] /= l;
}

/* Camera-space ray (ov, dv) of the projection's camera moved to lens point `at` and aimed at
 * where the pinhole's ray meets the plane in focus, as Cycles' camera_sample_perspective and
 * camera_sample_orthographic do. Perspective: the plane at depth `focus`, the t range the
 * pinhole's (Cycles moves the ray's start by the pinhole ray's clip distance); orthographic: the
 * pixel's point at `focus` along the axis, the ray starting on the clip-start plane and running
 * the clip length. */
static void projection_lens(const ub_camera *cam, const double at[2], double ov[3], double dv[3], double *t_min,
                            double *t_max)
{
    double focal[3];
    for (int i = 0; i < 3; i++)
        focal[i] = cam->orthographic ? ov[i] + dv[i] * cam->focus : dv[i] * (cam->focus / -dv[2]);
    double pinhole_z = dv[2];
    ov[0] += at[0];
    ov[1] += at[1];
    for (int i = 0; i < 3; i++)
        dv[i] = focal[i] - ov[i];
    normalize3(dv);
    if (cam->orthographic) {
        double length = *t_max - *t_min;
        *t_min = *t_min * pinhole_z / dv[2];
        *t_max = *t_min + length;
    }
}

/* A panoramic camera's camera-space ray d (unit) moved to lens point `at` (origin o) and aimed
 * at its point at distance `focus`, as Cycles' camera_sample_panorama does: the lens lies across
 * the ray, its first axis the panorama's forward axis made perpendicular to the ray. */
static void panorama_lens(const ub_camera *cam, const double at[2], double o[3], double d[3])
{
    const double *a = cam->pano_axis;
    double along = a[0] * d[0] + a[1] * d[1] + a[2] * d[2];
    double u[3] = {a[0] - along * d[0], a[1] - along * d[1], a[2] - along * d[2]};
    if (!(u[0] * u[0] + u[1] * u[1] + u[2] * u[2] > 1e-20)) {
        /* A ray along the axis (Cycles divides 0 by 0 there): any direction across it will do. */
        double e[3] = {0.0, 0.0, 0.0};
        e[fabs(d[1]) < 0.5 ? 1 : 0] = 1.0;
        along = e[0] * d[0] + e[1] * d[1] + e[2] * d[2];
        for (int i = 0; i < 3; i++)
            u[i] = e[i] - along * d[i];
    }
    normalize3(u);
    double v[3] = {d[1] * u[2] - d[2] * u[1], d[2] * u[0] - d[0] * u[2], d[0] * u[1] - d[1] * u[0]};
    for (int i = 0; i < 3; i++) {
        o[i] = u[i] * at[0] + v[i] * cam->pano_handedness * at[1];
        d[i] = d[i] * cam->focus - o[i];
    }
    normalize3(d);
}

int ub_camera_ray(const ub_camera *cam, double px, double py, const double lens[2], double origin[3],
                  double dir[3], double *t_min, double *t_max)
{
    double at[2];
    int thin_lens = lens && cam->aperture > 0.0;
    if (thin_lens)
        aperture_point(cam, lens, at);
    if (cam->panorama == UB_PANORAMA_NONE) {
        if (!thin_lens) {
            projection_ray(cam, px, py, origin, dir, t_min, t_max);
            return 1;
        }
        double ov[3], dv[3];
        projection_ray_view(cam, px, py, ov, dv, t_min, t_max);
        projection_lens(cam, at, ov, dv, t_min, t_max);
        view_to_world(cam->cam_to_world, ov, dv, origin, dir);
        return 1;
    }
    const double *vp = cam->viewplane;
    double u = vp[0] + px / cam->width * (vp[1] - vp[0]);
    double v = vp[2] + py / cam->height * (vp[3] - vp[2]);
    double d[3];
    for (int r = 0; r < 3; r++)
        origin[r] = cam->position[r];
    if (!panorama_direction(cam, u, v, d)) {
        dir[0] = dir[1] = dir[2] = 0.0;
        *t_min = *t_max = 0.0;
        return 0;
    }
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (thin_lens) {
        double o[3];
        for (int i = 0; i < 3; i++)
            d[i] /= len;
        panorama_lens(cam, at, o, d);
        view_to_world(cam->cam_to_world, o, d, origin, dir);
    } else {
        for (int r = 0; r < 3; r++) {
            const double *row = cam->cam_to_world[r];
            dir[r] = (row[0] * d[0] + row[1] * d[1] + row[2] * d[2]) / len;
        }
    }
    /* Cycles starts a panoramic ray at the clip start along it and ends it at the clip end. */
    *t_min = cam->near;
    *t_max = cam->far;
    return 1;
}

/* A panoramic camera's constants from its input; NULL or a message. */
static const char *panorama_prepare(ub_camera *cam, const ub_camera_input *in)
{
    cam->panorama = (ub_panorama_type)in->panorama_type;
    cam->orthographic = 0;
    /* The clip distances: the projection's, at the image centre, where they are along the view axis. */
    double o[3], d[3], t0, t1;
    projection_ray(cam, 0.5 * cam->width, 0.5 * cam->height, o, d, &t0, &t1);
    cam->near = t0;
    cam->far = t1;
    memcpy(cam->viewplane, in->viewplane, sizeof cam->viewplane);
    cam->range[0] = in->longitude_min - in->longitude_max;
    cam->range[1] = -in->longitude_min;
    cam->range[2] = in->latitude_min - in->latitude_max;
    cam->range[3] = -in->latitude_min + M_PI_2;
    cam->half_fov = 0.5 * in->fisheye_fov;
    cam->lens = in->fisheye_lens;
    cam->sensor[0] = in->sensor_width;
    cam->sensor[1] = in->sensor_height;
    cam->sin_quarter_fov = pano_sin(0.25 * in->fisheye_fov);
    /* Pixel footprint: the angle one pixel spans at the image centre (the mappings' least), per
     * unit of distance; the smaller side of the pixel, as for the projection's cameras. */
    double du = fabs(cam->viewplane[1] - cam->viewplane[0]) / cam->width;
    double dv = fabs(cam->viewplane[3] - cam->viewplane[2]) / cam->height;
    double fx, fy;
    switch (cam->panorama) {
    case UB_PANORAMA_EQUIRECTANGULAR:
        fx = fabs(cam->range[0]) * du;
        fy = fabs(cam->range[2]) * dv;
        break;
    case UB_PANORAMA_FISHEYE_EQUIDISTANT:
        fx = 2.0 * cam->half_fov * du;
        fy = 2.0 * cam->half_fov * dv;
        break;
    case UB_PANORAMA_FISHEYE_EQUISOLID:
        fx = cam->sensor[0] / cam->lens * du;
        fy = cam->sensor[1] / cam->lens * dv;
        break;
    default: /* mirror ball: twice the ball's slope */
        fx = 4.0 * du;
        fy = 4.0 * dv;
        break;
    }
    double f = fx > 0.0 && fy > 0.0 ? fmin(fx, fy) : fmax(fx, fy);
    if (!(f > 0.0 && isfinite(f)))
        return "camera: the panorama's viewplane and latitude/longitude ranges must not both be empty";
    cam->footprint0 = 0.0;
    cam->footprint1 = f;
    return NULL;
}

/* The thin lens' constants, as Cycles' Camera::update makes them. */
static void lens_prepare(ub_camera *cam, const ub_camera_input *in)
{
    cam->aperture = in->aperture_size;
    /* Cycles' least focus distance; and beyond 1e30 the plane in focus is at infinity for any
     * scene, while the focal point's squared coordinates must stay finite. */
    cam->focus = fmin(fmax(in->focus_distance, 1e-5), 1e30);
    cam->inv_ratio = 1.0 / in->aperture_ratio;
    cam->blades = in->aperture_blades < 3 ? 0 : in->aperture_blades;
    cam->blade_rotation = in->aperture_rotation;
    cam->blade_cos = cam->blades ? ub_cos(M_PI / cam->blades) : 0.0;
    cam->blade_sin = cam->blades ? ub_sin(M_PI / cam->blades) : 0.0;
    /* Cycles' panorama space looks along +x; blender_camera_matrix turns it to look along -z
     * (a turn of determinant +1), the mirror ball's along -y (a reflection, determinant -1). */
    int mirror = cam->panorama == UB_PANORAMA_MIRRORBALL;
    cam->pano_axis[0] = mirror ? 1.0 : 0.0;
    cam->pano_axis[2] = mirror ? 0.0 : -1.0;
    cam->pano_handedness = mirror ? -1.0 : 1.0;
}

const char *ub_camera_from_input(ub_camera *cam, const ub_camera_input *in)
{
    memset(cam, 0, sizeof *cam);
    cam->width = in->width;
    cam->height = in->height;
    const char *err = ub_camera_prepare(cam, in->matrix, in->projection);
    if (!err && in->panorama_type != UB_PANORAMA_NONE)
        err = panorama_prepare(cam, in);
    if (!err)
        lens_prepare(cam, in);
    return err;
}

double ub_pixel_footprint(const ub_camera *cam, double t)
{
    return cam->footprint0 + cam->footprint1 * t;
}
