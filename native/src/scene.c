/* Per-object set-up: the slice of eq. 5-6, the bounding ball of section 3.4, transforms. */
#include "params.h"
#include "quat.h"
#include "scene.h"
#include "ubmath.h" /* acos, cos, sin, hypot: the same bits on every platform */

#include <float.h>
#include <math.h>
#include <string.h>

const char *const ub_pass_names[UB_PASS_COUNT] = {
    "combined", "alpha", "depth", "normal", "position", "iterations", "steps", "distance",
    "ao", "shadow", "diffuse", "ambient", "reflection", "orbit_trap", "glow", "max_steps",
    "denoising_albedo", "denoising_normal",
};
const int ub_pass_channels[UB_PASS_COUNT] = {4, 1, 1, 3, 3, 1, 1, 1, 1, 1, 3, 3, 3, 1, 3, 1, 3, 3};

/* Radical inverse in base b of i: the Halton sequence's coordinate. */
static double radical_inverse(int i, int b)
{
    double inv = 1.0 / b, f = inv, r = 0.0;
    while (i > 0) {
        r += f * (i % b);
        i /= b;
        f *= inv;
    }
    return r;
}

void ub_sample_offset(int sample, double *dx, double *dy)
{
    /* Halton points are stratified at every prefix length; the Cranley-Patterson shift by
     * (1/2, 1/2) puts sample 0 at the pixel centre, so one sample is the classic render. */
    double x = radical_inverse(sample, 2) + 0.5, y = radical_inverse(sample, 3) + 0.5;
    *dx = x - floor(x);
    *dy = y - floor(y);
}

/* A 32-bit integer hash (Wellons' lowbias32): every input bit changes about half the output bits. */
static uint32_t hash32(uint32_t x)
{
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

void ub_lens_sample(int sample, int px, int py, double uv[2])
{
    /* Halton's next two dimensions (bases 5 and 7; the pixel offset has 2 and 3), so a pixel's
     * lens samples are stratified at every prefix length; each pixel turns them by its own
     * Cranley-Patterson shift, a hash of its coordinates, so that neighbours do not look through
     * the same point of the lens at the same sample (a few samples would show as that many
     * sharp copies of the image; with the shift, as noise). Integer hashing and exact
     * fractional parts: the same bits on every platform and thread. */
    uint32_t h = hash32((uint32_t)px ^ hash32((uint32_t)py + 0x9e3779b9u));
    uint32_t h2 = hash32(h + 0x632be5abu);
    double x = radical_inverse(sample, 5) + h * 0x1p-32, y = radical_inverse(sample, 7) + h2 * 0x1p-32;
    uv[0] = x - floor(x);
    uv[1] = y - floor(y);
}

double ub_det3(const double m[3][3])
{
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
         - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
         + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

/* Extreme eigenvalues of a symmetric 3x3 matrix (closed form, Smith 1961). */
void ub_sym3_eigen_range(const double a[3][3], double *lmin, double *lmax)
{
    double p1 = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
    if (p1 == 0.0) {
        *lmin = fmin(a[0][0], fmin(a[1][1], a[2][2]));
        *lmax = fmax(a[0][0], fmax(a[1][1], a[2][2]));
        return;
    }
    double q = (a[0][0] + a[1][1] + a[2][2]) / 3.0;
    double p2 = (a[0][0] - q) * (a[0][0] - q) + (a[1][1] - q) * (a[1][1] - q)
              + (a[2][2] - q) * (a[2][2] - q) + 2.0 * p1;
    double p = sqrt(p2 / 6.0);
    double b[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            b[i][j] = (a[i][j] - (i == j ? q : 0.0)) / p;
    double r = ub_det3(b) / 2.0;
    double phi = r <= -1.0 ? M_PI / 3.0 : (r >= 1.0 ? 0.0 : ub_acos(r) / 3.0);
    /* The three roots are q + 2p cos(phi + 2k pi/3); k = 0 gives the largest, k = 1 the smallest. */
    *lmax = q + 2.0 * p * ub_cos(phi);
    *lmin = q + 2.0 * p * ub_cos(phi + 2.0 * M_PI / 3.0);
}

/* Smallest and largest singular value of a 3x3 matrix by one-sided Jacobi (Hestenes) in double:
 * plane rotations orthogonalise the columns, whose norms are then the singular values. Unlike
 * the eigenvalues of A^T A (which square the condition number and lose every digit of sigma_min
 * at a scale ratio of 1e8), it is backward stable: the error is at most a few ulps of sigma_max.
 * sigma_min scales every marching step, so an overestimate is an overstep: it is lowered by that
 * error bound (16 eps sigma_max), which leaves orthogonal columns (any rotation and scale
 * without shear) exact up to a few ulps. Issue 16, defect 6. */
static void singular_value_range(const double a[3][3], double *smin, double *smax)
{
    double u[3][3];
    memcpy(u, a, sizeof u);
    for (int sweep = 0; sweep < 64; sweep++) {
        int rotated = 0;
        for (int p = 0; p < 2; p++) {
            for (int q = p + 1; q < 3; q++) {
                double alpha = 0.0, beta = 0.0, gamma = 0.0;
                for (int i = 0; i < 3; i++) {
                    alpha += u[i][p] * u[i][p];
                    beta += u[i][q] * u[i][q];
                    gamma += u[i][p] * u[i][q];
                }
                if (!(fabs(gamma) > DBL_EPSILON * sqrt(alpha) * sqrt(beta)))
                    continue;
                rotated = 1;
                double zeta = (beta - alpha) / (2.0 * gamma);
                double t = fabs(zeta) > 1e150 ? 0.5 / zeta
                                              : (zeta >= 0.0 ? 1.0 : -1.0) / (fabs(zeta) + sqrt(1.0 + zeta * zeta));
                double c = 1.0 / sqrt(1.0 + t * t), s = c * t;
                for (int i = 0; i < 3; i++) {
                    double up = u[i][p], uq = u[i][q];
                    u[i][p] = c * up - s * uq;
                    u[i][q] = s * up + c * uq;
                }
            }
        }
        if (!rotated)
            break;
    }
    double lo = HUGE_VAL, hi = 0.0;
    for (int j = 0; j < 3; j++) {
        double n = sqrt(u[0][j] * u[0][j] + u[1][j] * u[1][j] + u[2][j] * u[2][j]);
        lo = fmin(lo, n);
        hi = fmax(hi, n);
    }
    *smax = hi;
    *smin = fmax(lo - 16.0 * DBL_EPSILON * hi, 0.0);
}

/* The ball |q| <= radius4 of the 4-D space cut by the slice q = O + B p: a 3-ball around
 * -B^T O of radius sqrt(R^2 - |O_perp|^2), or none (radius -1). */
static void slice_ball(ub_object *obj, double radius4)
{
    double along[3], along2 = 0.0;
    for (int c = 0; c < 3; c++) {
        along[c] = 0.0;
        for (int r = 0; r < 4; r++)
            along[c] += obj->slice_basis[r][c] * obj->slice_origin[r];
        along2 += along[c] * along[c];
        obj->bound_center[c] = -along[c];
    }
    double perp2 = ub_quat_norm2(obj->slice_origin) - along2;
    double r2 = radius4 * radius4 - fmax(perp2, 0.0);
    obj->bound_radius = r2 >= 0.0 ? sqrt(r2) : -1.0;
}

/* x^m for a whole number m >= 0, by multiplications only (no libm: bounds reach pixels). */
static double int_power(double x, int m)
{
    double r = 1.0;
    for (int i = 0; i < m; i++)
        r *= x;
    return r;
}

/* The Mandelbulb's ball and escape radius. |z^n| = |z|^n in the triplex algebra, and with
 * m = floor(n) >= 2, |z|^n >= |z|^m for |z| >= 1. Mandelbrot mode: with R^(m-1) >= 2 and
 * |c| <= R, |z| > R gives |f(z)| >= |z|^n - |c| > |z| (|z|^(n-1) - 1) > |z|, growing: the orbit
 * escapes, so the set lies in |c| <= R (z0 = c) and R is an escape radius. Julia mode: R >= 1
 * the root of R^m - R - |c| = 0; |z| > R gives |f(z)| - |z| >= |z|^m - |z| - |c| > 0, growing.
 * Bisection in double, taking the upper end. The escape radius used is also capped at
 * 2^floor(56/n), so that r^n stays far inside float32's range (never below R). */
static void mandelbulb_bound(ub_object *obj)
{
    int m = (int)floor(obj->power);
    double c = obj->julia_mode ? sqrt(obj->julia_c[0] * obj->julia_c[0] + obj->julia_c[1] * obj->julia_c[1]
                                      + obj->julia_c[2] * obj->julia_c[2])
                               : 0.0;
    double lo = 1.0, hi = 2.0 + c;
    for (int i = 0; i < 200; i++) {
        double mid = 0.5 * (lo + hi);
        double g = obj->julia_mode ? int_power(mid, m) - mid - c : int_power(mid, m - 1) - 2.0;
        if (g < 0.0)
            lo = mid;
        else
            hi = mid;
    }
    obj->bound_center[0] = obj->bound_center[1] = obj->bound_center[2] = 0.0;
    obj->bound_radius = hi;
    double cap = ldexp(1.0, (int)floor(56.0 / obj->power));
    obj->bailout = fmax(fmin(obj->bailout, cap), hi);
}

/* The Mandelbox's ball and escape radius, from the sup norm. The box fold moves a coordinate
 * by at most 2L toward 0 (|fold(x)| >= |x| - 2L) and the sphere fold only scales up (by
 * k >= 1, as min_radius <= fixed_radius), so the largest coordinate m of z gives
 * |f(z)|_inf >= |s| (m - 2L) - |c|_inf. Beyond m* = (2L|s| + |c|_inf) / (|s| - 1) that is
 * > m and f(z) - m* >= |s| (m - m*): the orbit escapes. Julia mode: the set lies in the cube
 * of half-width m* (proven). Mandelbrot mode (z0 = c): for |s| > 2, |c|_inf > 2L|s|/(|s| - 2)
 * already exceeds m*(c), so H = 2L|s|/(|s| - 2) (proven); for 1 < |s| <= 2 no such argument
 * holds and H = 2L(|s| + 1)/(|s| - 1), Lowe's cube for s > 1 (6 for s = 2), taken for s < -1
 * as well: not proven here, checked by sampling (tests/native/test_formulas.py). The escape
 * radius is sqrt(3) m* for the largest |c| the cube allows; the ball is the cube's. */
static const char *mandelbox_bound(ub_object *obj)
{
    double s = fabs(obj->box_scale), L = obj->box_fold;
    if (!(s > 1.0 + 1e-6))
        return "a Mandelbox needs |box_scale| > 1";
    if (obj->min_radius > obj->fixed_radius)
        return "a Mandelbox needs min_radius <= fixed_radius";
    double H, c;
    if (obj->julia_mode) {
        c = fmax(fabs(obj->julia_c[0]), fmax(fabs(obj->julia_c[1]), fabs(obj->julia_c[2])));
        H = (2.0 * L * s + c) / (s - 1.0);
    } else {
        H = s > 2.0 ? 2.0 * L * s / (s - 2.0) : 2.0 * L * (s + 1.0) / (s - 1.0);
        c = H;
    }
    double escape = fmax(H, (2.0 * L * s + c) / (s - 1.0));
    obj->bound_center[0] = obj->bound_center[1] = obj->bound_center[2] = 0.0;
    obj->bound_radius = sqrt(3.0) * H;
    obj->bailout = fmax(obj->bailout, sqrt(3.0) * escape);
    return NULL;
}

/* The KIFS's ball and escape radius. A fold in the plane n.z = d (|n| = 1) moves z with
 * n.z < d to z' = z + 2 (d - n.z) n, |z'|^2 = |z|^2 + 4 d (d - n.z): never shorter for d >= 0,
 * at most 2|d| shorter for d < 0 (the triangle inequality); R keeps |z|. So with
 * delta = 2 sum over d < 0 of |d|, |f(z)| >= s (|z| - delta) - |o| (s - 1), and
 * rho = (s delta + |o| (s - 1)) / (s - 1) gives |f(z)| - rho >= s (|z| - rho): past rho an
 * orbit grows geometrically. The final shape lies in |z| <= r_S (sphere, octahedron: size;
 * box, tetrahedron: sqrt 3 size), so every level's set A_n = {p : f^n(p) in S} lies in
 * |z| <= max(rho, r_S): proven for every fold set, rotation and offset. That radius is the
 * ball and the least escape radius (formulas.h's escaped-lane bound subtracts it). */
static const char *kifs_bound(ub_object *obj)
{
    double s = obj->kifs_scale;
    if (!(s > 1.0 + 1e-6))
        return "a KIFS needs kifs_scale > 1";
    double delta = 0.0;
    for (int i = 0; i < obj->kifs_plane_count; i++) {
        double *pl = obj->kifs_planes[i];
        double len = sqrt(pl[0] * pl[0] + pl[1] * pl[1] + pl[2] * pl[2]);
        if (!(len > 1e-9))
            return "a KIFS fold plane needs a non-zero normal";
        for (int c = 0; c < 4; c++)
            pl[c] /= len; /* the plane n.z = d unchanged, now with |n| = 1 */
        if (pl[3] < 0.0)
            delta -= 2.0 * pl[3];
    }
    const double *o = obj->kifs_offset;
    double on = sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
    double rho = (s * delta + on * (s - 1.0)) / (s - 1.0);
    double shape = obj->kifs_shape == UB_KIFS_BOX || obj->kifs_shape == UB_KIFS_TETRAHEDRON ? sqrt(3.0) * obj->kifs_size
                                                                                            : obj->kifs_size;
    obj->kifs_rho = fmax(rho, shape);
    obj->bound_center[0] = obj->bound_center[1] = obj->bound_center[2] = 0.0;
    obj->bound_radius = obj->kifs_rho;
    obj->bailout = fmax(obj->bailout, obj->kifs_rho);
    return NULL;
}

/* Blender's XYZ Euler rotation R = Rz Ry Rx (ub_sin, ub_cos: the same bits everywhere). */
static void euler_xyz(const double e[3], double r[3][3])
{
    double cx = ub_cos(e[0]), sx = ub_sin(e[0]), cy = ub_cos(e[1]), sy = ub_sin(e[1]), cz = ub_cos(e[2]),
           sz = ub_sin(e[2]);
    double m[3][3] = {{cy * cz, sx * sy * cz - cx * sz, cx * sy * cz + sx * sz},
                      {cy * sz, sx * sy * sz + cx * cz, cx * sy * sz - sx * cz},
                      {-sy, sx * cy, cx * cy}};
    memcpy(r, m, sizeof m);
}

/* The hybrid's entries, and its ball and escape radius: the largest of its formulas' (each
 * computed as for its own kind). Not proven for the mixture (the formulas' escape arguments use
 * different norms and constants): checked by sampling, float64 orbits from just outside escape
 * (tests/native/test_kifs_hybrid.py). */
static const char *hybrid_bound(ub_object *obj)
{
    int used[3] = {0, 0, 0}, total = 0;
    for (int i = 0; i < obj->hybrid_count; i++) {
        int f = obj->hybrid_formula[i], n = obj->hybrid_repeat[i];
        if (f < 0 || f > 2)
            return "hybrid_steps formulas are 0 (Mandelbulb), 1 (Mandelbox) or 2 (KIFS)";
        if (n < 1)
            return "hybrid_steps counts must be whole numbers >= 1";
        used[f] = 1;
        total += n;
    }
    if (total < 1)
        return "a hybrid needs at least one step";
    obj->hybrid_has_bulb = used[UB_HYBRID_MANDELBULB];
    double user = obj->bailout, radius = 0.0, bail = user;
    if (used[UB_HYBRID_MANDELBULB]) {
        obj->bailout = user;
        mandelbulb_bound(obj);
        radius = fmax(radius, obj->bound_radius);
        bail = fmax(bail, obj->bailout);
    }
    if (used[UB_HYBRID_MANDELBOX]) {
        obj->bailout = user;
        const char *err = mandelbox_bound(obj);
        if (err)
            return err;
        radius = fmax(radius, obj->bound_radius);
        bail = fmax(bail, obj->bailout);
    }
    if (used[UB_HYBRID_KIFS]) {
        obj->bailout = user;
        const char *err = kifs_bound(obj);
        if (err)
            return err;
        radius = fmax(radius, obj->bound_radius);
        bail = fmax(bail, obj->bailout);
    }
    obj->bound_center[0] = obj->bound_center[1] = obj->bound_center[2] = 0.0;
    obj->bound_radius = radius;
    obj->bailout = fmax(bail, radius);
    return NULL;
}

/* The kind's bounding ball (section 3.4), escape radius and exactness. */
static const char *prepare_kind(ub_object *obj)
{
    switch (obj->kind) {
    case UB_KIND_MANDELBULB:
        mandelbulb_bound(obj);
        obj->exact = 0;
        return NULL;
    case UB_KIND_MANDELBOX:
        obj->exact = 0;
        return mandelbox_bound(obj);
    case UB_KIND_KIFS:
        obj->exact = 1;
        return kifs_bound(obj);
    case UB_KIND_HYBRID:
        obj->exact = 0;
        return hybrid_bound(obj);
    case UB_KIND_QUATERNION_MANDELBROT:
        /* |mu| > 2 escapes, and once |z| > 2 >= |mu| the orbit escapes. */
        slice_ball(obj, 2.0);
        obj->bailout = fmax(obj->bailout, 2.0);
        obj->exact = 1;
        return NULL;
    case UB_KIND_JULIA_STACK: {
        if (obj->path_count < 1)
            return "a Julia stack needs a c-path of at least one point";
        /* Every c on the path's segments has |c| <= the largest vertex norm (convexity). */
        double c_max = 0.0;
        int last = obj->path_count - 1;
        for (int i = 0; i < obj->path_count; i++) {
            c_max = fmax(c_max, ub_hypot(obj->path[i][0], obj->path[i][1]));
            obj->path_speed[i] = i < last ? ub_hypot(obj->path[i + 1][0] - obj->path[i][0],
                                                  obj->path[i + 1][1] - obj->path[i][1]) * last / obj->stack_height
                                          : 0.0;
        }
        double radius = 0.5 * (1.0 + sqrt(1.0 + 4.0 * c_max)), h = 0.5 * obj->stack_height;
        obj->bound_center[0] = obj->bound_center[1] = obj->bound_center[2] = 0.0;
        obj->bound_radius = sqrt(radius * radius + h * h);
        obj->bailout = fmax(obj->bailout, radius);
        obj->exact = 0;
        return NULL;
    }
    case UB_KIND_CUBIC_LOCUS:
        /* With |a|, |b| <= E and |z| >= 2 + (1 + sqrt 3) E: |f(z)| >= |z| (|z|^2 - 3E^2) - E
         * >= 4|z| - E >= 3|z|, so the orbit escapes. */
        slice_ball(obj, obj->extent);
        obj->bailout = fmax(obj->bailout, 2.0 + (1.0 + sqrt(3.0)) * obj->extent);
        obj->exact = 0;
        return NULL;
    case UB_KIND_IFS: {
        const char *err = ub_ifs_prepare(obj);
        if (err)
            return err;
        for (int c = 0; c < 3; c++)
            obj->bound_center[c] = obj->ifs_center[c];
        obj->bound_radius = obj->ifs_radius;
        obj->exact = 1;
        return NULL;
    }
    default: {
        /* If |z| > R with R^2 - R - |mu| = 0 then |z^2 + mu| >= |z|^2 - |mu| > |z| and the orbit
         * escapes, so K_mu lies in |z| <= R (g_theta preserves norms, so for every theta). An
         * escape radius below R would call points of K_mu escaped; never use one. */
        double radius4 = 0.5 * (1.0 + sqrt(1.0 + 4.0 * sqrt(ub_quat_norm2(obj->mu))));
        slice_ball(obj, radius4);
        obj->bailout = fmax(obj->bailout, radius4);
        obj->exact = 1;
        return NULL;
    }
    }
}

const char *ub_object_prepare(ub_object *obj, double theta, const double slice_basis[4][3],
                              const double slice_origin[4], const double object_to_world[4][4])
{
    static const double identity_basis[4][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 0}};
    static const double zero_origin[4] = {0, 0, 0, 0};
    if (obj->kind == UB_KIND_JULIA_STACK || obj->kind == UB_KIND_IFS || obj->kind == UB_KIND_MANDELBULB
        || obj->kind == UB_KIND_MANDELBOX || obj->kind == UB_KIND_KIFS || obj->kind == UB_KIND_HYBRID) {
        /* Three-dimensional kinds: the "slice" is object space itself. */
        slice_basis = identity_basis;
        slice_origin = zero_origin;
        theta = 0.0;
    }
    /* The slice basis must be orthonormal: distances measured in object space then equal
     * distances in quaternion space, which the distance estimate is about. */
    for (int a = 0; a < 3; a++)
        for (int b = a; b < 3; b++) {
            double dot = 0.0;
            for (int r = 0; r < 4; r++)
                dot += slice_basis[r][a] * slice_basis[r][b];
            if (fabs(dot - (a == b ? 1.0 : 0.0)) > 1e-4)
                return "slice_basis columns must be orthonormal 4-vectors";
        }

    /* Eq. 5-6: f_{mu,theta} = g o f_mu o g^-1 with g(z) = e^{i theta} z, so
     * f^n_{mu,theta} = g o f^n_mu o g^-1. g is a linear isometry of R^4, hence
     * |f^n_{mu,theta}(z)| = |f^n_mu(g^-1 z)| and likewise for the derivative: the rotated set is
     * g(K_mu) and its distance estimate at z is the plain one at g^-1(z). We therefore fold
     * g^-1 (left multiplication by e^{-i theta}) into the slice map once, and the kernels
     * iterate plain z^2 + mu. theta is reduced modulo 2 pi so that 2 pi gives 0's exact bits. */
    double th = fmod(theta, 2.0 * M_PI); /* exact (C's fmod has no rounding) */
    double g_inv[4] = {ub_cos(th), -ub_sin(th), 0.0, 0.0};
    if (th == 0.0) { g_inv[0] = 1.0; g_inv[1] = 0.0; }
    ub_quat_mul(g_inv, slice_origin, obj->slice_origin);
    for (int c = 0; c < 3; c++) {
        double col[4] = {slice_basis[0][c], slice_basis[1][c], slice_basis[2][c], slice_basis[3][c]};
        double rot[4];
        ub_quat_mul(g_inv, col, rot);
        for (int r = 0; r < 4; r++)
            obj->slice_basis[r][c] = rot[r];
    }

    /* Object <-> world. Blender hands us a 4x4 affine matrix; the last row must be 0 0 0 1. */
    const double(*m)[4] = object_to_world;
    if (m[3][0] != 0.0 || m[3][1] != 0.0 || m[3][2] != 0.0 || m[3][3] != 1.0)
        return "object_to_world must be affine (last row 0, 0, 0, 1)";
    double lin[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            lin[i][j] = m[i][j];
    double det = ub_det3(lin);
    if (!isfinite(det) || fabs(det) < 1e-18)
        return "object_to_world must be invertible (zero scale?)";
    double inv[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            int i1 = (j + 1) % 3, i2 = (j + 2) % 3, j1 = (i + 1) % 3, j2 = (i + 2) % 3;
            inv[i][j] = (lin[i1][j1] * lin[i2][j2] - lin[i1][j2] * lin[i2][j1]) / det;
        }
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            obj->world_to_object[i][j] = inv[i][j];
        }
        obj->world_to_object[i][3] = -(inv[i][0] * m[0][3] + inv[i][1] * m[1][3] + inv[i][2] * m[2][3]);
    }
    singular_value_range(lin, &obj->sigma_min, &obj->sigma_max);
    if (!(obj->sigma_min > 1e-9))
        return "object_to_world must be invertible (zero scale?)";

    const char *err = prepare_kind(obj);
    if (err)
        return err;
    /* Section 5: where no distance underestimate is proven, the estimate is made safe by a
     * smaller step, a cap on any one step and the bisection of every hit (march.h). */
    if (!obj->exact) {
        obj->step_factor *= UB_EMPIRICAL_SAFETY;
        if (obj->bound_radius > 0.0)
            obj->max_step = fmin(obj->max_step, UB_EMPIRICAL_MAX_STEP * obj->bound_radius * obj->sigma_min);
    }
    return NULL;
}

static void to_float3(float out[3], const double in[3])
{
    for (int c = 0; c < 3; c++)
        out[c] = (float)in[c];
}

/* One attribute-driven material input; NULL or a message. */
static const char *material_map_from_input(ub_material_map *map, int source, int size, const double *table,
                                           int channels, double scale, double offset, const char *message)
{
    map->source = (ub_attribute)source;
    if (source == UB_ATTRIBUTE_NONE)
        return NULL;
    if (size < 2)
        return message;
    map->size = size;
    map->scale = (float)scale;
    map->offset = (float)offset;
    for (int i = 0; i < size; i++)
        for (int c = 0; c < 3; c++)
            map->table[i][c] = (float)table[i * channels + (channels == 3 ? c : 0)];
    return NULL;
}

/* Cycles' IOR and F0 from Specular IOR Level (svm_node_closure_bsdf, Principled): F0 scales by
 * 2 level, and the IOR follows from the scaled F0 (F0 at most 0.99). */
static void specular_ior(double ior, double level, double *eta, double *f0)
{
    ior = fmax(ior, 1e-5);
    *eta = ior;
    *f0 = (ior - 1.0) / (ior + 1.0) * ((ior - 1.0) / (ior + 1.0));
    if (level != 0.5) {
        *f0 *= 2.0 * level;
        double root = sqrt(fmin(fmax(*f0, 0.0), 0.99));
        *eta = (1.0 + root) / (1.0 - root);
        if (ior < 1.0)
            *eta = 1.0 / *eta;
    }
}

static const char *material_from_input(ub_material *m, const ub_object_input *in)
{
    m->enabled = in->use_material;
    if (!m->enabled)
        return NULL;
    to_float3(m->base_color, in->material_base_color);
    to_float3(m->emission, in->material_emission);
    m->metallic = (float)in->material_metallic;
    m->roughness = (float)in->material_roughness;
    m->alpha = (float)in->material_alpha;
    specular_ior(in->material_ior, in->material_specular_ior_level, &m->eta, &m->specular_f0);
    const char *err = material_map_from_input(
        &m->base_color_map, in->material_base_color_source, in->material_base_color_ramp_count,
        &in->material_base_color_ramp[0][0], 3, in->material_base_color_scale, in->material_base_color_offset,
        "material_base_color_source names an attribute but material_base_color_ramp is None");
    if (!err)
        err = material_map_from_input(
            &m->metallic_map, in->material_metallic_source, in->material_metallic_ramp_count,
            &in->material_metallic_ramp[0][0], 1, in->material_metallic_scale, in->material_metallic_offset,
            "material_metallic_source names an attribute but material_metallic_ramp is None");
    if (!err)
        err = material_map_from_input(
            &m->roughness_map, in->material_roughness_source, in->material_roughness_ramp_count,
            &in->material_roughness_ramp[0][0], 1, in->material_roughness_scale, in->material_roughness_offset,
            "material_roughness_source names an attribute but material_roughness_ramp is None");
    return err;
}

const char *ub_object_from_input(ub_object *obj, const ub_object_input *in)
{
    memset(obj, 0, sizeof *obj);
    obj->kind = (ub_fractal_kind)in->kind;
    memcpy(obj->mu, in->mu, sizeof obj->mu);
    obj->max_iterations = in->max_iterations;
    obj->bailout = in->bailout;
    obj->epsilon_mode = (ub_epsilon_mode)in->threshold_mode;
    obj->epsilon = in->epsilon;
    obj->detail = in->detail;
    obj->step_factor = in->step_factor;
    obj->max_step = in->max_step;
    obj->max_steps = in->max_steps;
    obj->bisection_steps = in->bisection_steps;
    to_float3(obj->color, in->color);
    obj->normal_method = (ub_normal_method)in->normal_method;
    obj->normal_alpha = in->normal_alpha;
    obj->normal_delta = in->normal_delta;
    obj->reflectivity = (float)in->reflectivity;
    obj->color_mode = (ub_color_mode)in->color_mode;
    obj->ramp_size = in->color_ramp_count;
    for (int i = 0; i < in->color_ramp_count; i++)
        to_float3(obj->ramp[i], in->color_ramp[i]);
    obj->ramp_scale = (float)in->ramp_scale;
    obj->ramp_offset = (float)in->ramp_offset;
    obj->path_count = in->path_count;
    memcpy(obj->path, in->path, sizeof obj->path);
    obj->stack_height = in->stack_height;
    obj->cubic_component = (ub_cubic_component)in->cubic_component;
    obj->extent = in->extent;
    obj->map_count = in->maps_count;
    memcpy(obj->maps, in->maps, sizeof obj->maps);
    obj->ifs_depth = in->ifs_depth;
    obj->julia_mode = in->julia_mode;
    memcpy(obj->julia_c, in->julia_c, sizeof obj->julia_c);
    obj->power = in->power;
    obj->box_scale = in->box_scale;
    obj->box_fold = in->box_fold;
    obj->min_radius = in->min_radius;
    obj->fixed_radius = in->fixed_radius;
    obj->kifs_plane_count = in->kifs_planes_count;
    memcpy(obj->kifs_planes, in->kifs_planes, sizeof obj->kifs_planes);
    obj->kifs_scale = in->kifs_scale;
    memcpy(obj->kifs_offset, in->kifs_offset, sizeof obj->kifs_offset);
    euler_xyz(in->kifs_rotation, obj->kifs_rotation);
    obj->kifs_rotate = in->kifs_rotation[0] != 0.0 || in->kifs_rotation[1] != 0.0 || in->kifs_rotation[2] != 0.0;
    obj->kifs_shape = in->kifs_shape;
    obj->kifs_size = in->kifs_size;
    obj->hybrid_count = in->hybrid_steps_count;
    for (int i = 0; i < in->hybrid_steps_count; i++) {
        double f = in->hybrid_steps[i][0], n = in->hybrid_steps[i][1];
        /* Whole numbers only: a fraction is refused by hybrid_bound (-1). */
        obj->hybrid_formula[i] = f == floor(f) ? (int)f : -1;
        obj->hybrid_repeat[i] = n == floor(n) ? (int)n : -1;
    }
    const char *err = material_from_input(&obj->material, in);
    if (!err)
        err = ub_object_prepare(obj, in->theta, in->slice_basis, in->slice_origin, in->matrix);
    if (!err)
        err = ub_zoom_prepare(obj, in->zoom, in->zoom_anchor);
    /* A zoomed formula kind's empirical step cap grew with the zoom (zoom_formulas.c); the user's
     * own Max Step still holds. */
    if (!err && obj->zoom.enabled)
        obj->max_step = fmin(obj->max_step, in->max_step);
    return err;
}

const char *ub_light_from_input(ub_light *L, const ub_light_input *in)
{
    memset(L, 0, sizeof *L);
    L->type = (ub_light_type)in->type;
    memcpy(L->position, in->position, sizeof L->position);
    to_float3(L->color, in->color);
    L->radius = in->radius;
    L->cast_shadow = in->cast_shadow;
    L->soft_falloff = in->soft_falloff;
    const double *dir = in->direction;
    double len = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    if (!(len > 1e-12) || !isfinite(len))
        return "direction must be a non-zero vector";
    for (int i = 0; i < 3; i++)
        L->direction[i] = dir[i] / len;
    /* Blender's spot: spot_size is the full cone angle, spot_blend the fraction of the cone's
     * cosine range over which it fades in. */
    L->spot_cos_outer = ub_cos(in->spot_size / 2);
    L->spot_cos_inner = L->spot_cos_outer + (1.0 - L->spot_cos_outer) * in->spot_blend;
    return NULL;
}

void ub_shading_from_input(ub_shading *sh, const ub_shading_input *in)
{
    /* The lights are converted one by one by the caller (ub_light_from_input names a bad one). */
    sh->samples = in->samples;
    sh->axle_light = (float)in->axle_light;
    to_float3(sh->ambient, in->ambient);
    sh->shadows = (ub_shadow_mode)in->shadows;
    sh->ao_strength = (float)in->ao_strength;
    sh->ao_distance = in->ao_distance;
    sh->ao_samples = in->ao_samples;
    sh->reflection_depth = in->reflection_depth;
    sh->fog_density = in->fog_density;
    to_float3(sh->fog_color, in->fog_color);
    sh->glow_strength = (float)in->glow_strength;
    to_float3(sh->glow_color, in->glow_color);
    sh->sea = in->use_sea;
    sh->sea_height = in->sea_height;
    sh->sea_wavelength = in->sea_wavelength;
    sh->sea_amplitude = in->sea_amplitude;
    to_float3(sh->sea_color, in->sea_color);
    sh->sea_reflectivity = (float)in->sea_reflectivity;
    sh->light_count = in->lights_count;
    sh->world_samples = in->world_samples;
    sh->gi = in->use_gi;
    sh->max_bounces = in->max_bounces;
    sh->diffuse_bounces = in->diffuse_bounces;
    sh->glossy_bounces = in->glossy_bounces;
}
