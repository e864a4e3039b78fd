/* The ray-marching kernel, written once against the vf/vm vector interface and compiled twice
 * (kernel_avx2.c, kernel_portable.c). A packet is UB_LANES horizontally adjacent pixels; each
 * lane marches its own ray and the packet runs until all lanes are done. Lanes never interact,
 * so a pixel's value does not depend on the packet, tile or thread that computed it. */
#ifndef KERNEL_SUFFIX
#error "define KERNEL_SUFFIX and include a simd_*.h header before kernel.h"
#endif

#include "scene.h"

#include <math.h>
#include <string.h>

#define UB_CAT2(a, b) a##b
#define UB_CAT(a, b) UB_CAT2(a, b)
#define UB_FN(name) UB_CAT(name, KERNEL_SUFFIX)

/* Natural logarithm of positive normal floats (Cephes' logf polynomial, ~1 ulp). Our own,
 * built only from the interface's correctly rounded operations, so both kernels agree. */
static inline vf UB_FN(v_log)(vf x)
{
    vf m, e;
    v_frexp_centered(x, &m, &e);
    vf f = v_sub(m, v_set1(1.0f));
    vf z = v_mul(f, f);
    vf y = v_set1(7.0376836292E-2f);
    y = v_fma(y, f, v_set1(-1.1514610310E-1f));
    y = v_fma(y, f, v_set1(1.1676998740E-1f));
    y = v_fma(y, f, v_set1(-1.2420140846E-1f));
    y = v_fma(y, f, v_set1(1.4249322787E-1f));
    y = v_fma(y, f, v_set1(-1.6668057665E-1f));
    y = v_fma(y, f, v_set1(2.0000714765E-1f));
    y = v_fma(y, f, v_set1(-2.4999993993E-1f));
    y = v_fma(y, f, v_set1(3.3333331174E-1f));
    y = v_mul(v_mul(y, f), z);
    y = v_fma(e, v_set1(-2.12194440e-4f), y);
    y = v_fma(z, v_set1(-0.5f), y);
    vf r = v_add(f, y);
    return v_fma(e, v_set1(0.693359375f), r);
}

/* Constants of one fractal object in kernel precision, derived once per tile. */
typedef struct {
    vf mu[4];
    vf bail2;
    int max_iterations;
    /* Hit threshold in world units at ray distance t: eps0 + eps1 * t (fixed mode: eps1 = 0). */
    vf eps0, eps1;
} UB_FN(ub_de_params);

static inline void UB_FN(de_params)(const ub_object *o, const ub_camera *cam, UB_FN(ub_de_params) *p)
{
    for (int i = 0; i < 4; i++)
        p->mu[i] = v_set1((float)o->mu[i]);
    p->bail2 = v_set1((float)(o->bailout * o->bailout));
    p->max_iterations = o->max_iterations;
    int fixed = o->epsilon_mode == UB_EPSILON_FIXED;
    if (!cam && !fixed) { /* estimate(): no camera, no threshold needed */
        p->eps0 = p->eps1 = v_set1(0.0f);
        return;
    }
    p->eps0 = v_set1((float)(fixed ? o->epsilon * o->sigma_min : cam->footprint0 / o->detail));
    p->eps1 = v_set1((float)(fixed ? 0.0 : cam->footprint1 / o->detail));
}

/* Distance estimate of section 3 at quaternion points q:
 *   d(z) = |f^n(z)| log|f^n(z)| / (2 |f^n'(z)|)
 * with f(z) = z^2 + mu iterated until |z| exceeds the escape radius or max_iterations is
 * reached. The running derivative obeys |f'| <- 2 |z| |f'| (|zh + hz| <= 2|z||h| in the
 * quaternions); we carry its square, 4 |z|^2 |f'|^2, to avoid a square root per iteration.
 * Points that never escape are in K_mu as far as we can tell: their estimate is 0 (a hit).
 * Writes the estimate (object units) and the escape count. */
static inline void UB_FN(de)(const UB_FN(ub_de_params) *p, vf a, vf b, vf c, vf d, vf *dist, vf *iters)
{
    vf r2 = v_fma(a, a, v_fma(b, b, v_fma(c, c, v_mul(d, d))));
    vf dr2 = v_set1(1.0f);
    vf n = v_set1(0.0f);
    vm active = m_from_bits(0xff);
    vm escaped = m_false();
    const vf four = v_set1(4.0f);
    for (int it = 0; it < p->max_iterations; it++) {
        /* z^2 = (a^2 - b^2 - c^2 - d^2, 2ab, 2ac, 2ad): the imaginary parts of z commute with
         * the real part, and v*v = -|v|^2 for a pure imaginary v (eq. 2-4). */
        vf a2 = v_add(a, a);
        vf na = v_sub(v_fma(a, a, p->mu[0]), v_fma(b, b, v_fma(c, c, v_mul(d, d))));
        vf nb = v_fma(a2, b, p->mu[1]);
        vf nc = v_fma(a2, c, p->mu[2]);
        vf nd = v_fma(a2, d, p->mu[3]);
        vf ndr2 = v_mul(dr2, v_mul(four, r2));
        vf nr2 = v_fma(na, na, v_fma(nb, nb, v_fma(nc, nc, v_mul(nd, nd))));
        a = v_select(active, na, a);
        b = v_select(active, nb, b);
        c = v_select(active, nc, c);
        d = v_select(active, nd, d);
        dr2 = v_select(active, ndr2, dr2);
        r2 = v_select(active, nr2, r2);
        n = v_count(n, active);
        vm out = m_and(active, v_gt(nr2, p->bail2));
        escaped = m_or(escaped, out);
        active = m_andnot(out, active);
        if (!m_bits(active))
            break;
    }
    /* |z| log|z| / (2|z'|) = sqrt(r2 / dr2) * log(r2) / 4. dr2 may overflow to +inf deep
     * inside long orbits: the estimate is then 0, which is what it tends to anyway. */
    vf est = v_mul(v_mul(v_sqrt(v_div(r2, dr2)), UB_FN(v_log)(r2)), v_set1(0.25f));
    *dist = v_select(escaped, est, v_set1(0.0f));
    *iters = n;
}

/* Per-lane state of rays against one object, prepared in double precision. */
typedef struct {
    float q_enter[4][UB_LANES]; /* quaternion point where the ray enters the bounding ball */
    float q_dir[4][UB_LANES];   /* quaternion-space change per unit of world distance */
    float t_enter[UB_LANES];    /* world distance along the ray at entry */
    float s_max[UB_LANES];      /* distance marched from entry before giving up */
} UB_FN(ub_object_rays);

typedef struct {
    double origin[3][UB_LANES], dir[3][UB_LANES];
    double t_min[UB_LANES], t_max[UB_LANES];
} UB_FN(ub_packet_rays);

/* Clip each lane's ray against the object's bounding ball; returns the lanes that touch it. */
static int UB_FN(object_rays)(const ub_object *o, const UB_FN(ub_packet_rays) *r, const float *t_limit,
                              int lanes_in, UB_FN(ub_object_rays) *out)
{
    int lanes = 0;
    for (int l = 0; l < UB_LANES; l++) {
        double oo[3], od[3];
        for (int i = 0; i < 3; i++) {
            const double *w = o->world_to_object[i];
            oo[i] = w[0] * r->origin[0][l] + w[1] * r->origin[1][l] + w[2] * r->origin[2][l] + w[3];
            od[i] = w[0] * r->dir[0][l] + w[1] * r->dir[1][l] + w[2] * r->dir[2][l];
        }
        /* |oo + t od - c|^2 = R^2 */
        double rel[3] = {oo[0] - o->bound_center[0], oo[1] - o->bound_center[1], oo[2] - o->bound_center[2]};
        double qa = od[0] * od[0] + od[1] * od[1] + od[2] * od[2];
        double qb = rel[0] * od[0] + rel[1] * od[1] + rel[2] * od[2];
        double qc = rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2] - o->bound_radius * o->bound_radius;
        double disc = qb * qb - qa * qc;
        double t0 = 0.0, t1 = -1.0;
        if (((lanes_in >> l) & 1) && o->bound_radius >= 0.0 && disc >= 0.0) {
            double sq = sqrt(disc);
            t0 = (-qb - sq) / qa;
            t1 = (-qb + sq) / qa;
            t0 = fmax(t0, r->t_min[l]);
            t1 = fmin(t1, (double)t_limit[l]);
        }
        if (t1 >= t0) {
            lanes |= 1 << l;
        } else {
            t0 = r->t_min[l];
            t1 = t0;
        }
        double pe[3] = {oo[0] + t0 * od[0], oo[1] + t0 * od[1], oo[2] + t0 * od[2]};
        for (int k = 0; k < 4; k++) {
            const double *b = o->slice_basis[k];
            out->q_enter[k][l] = (float)(o->slice_origin[k] + b[0] * pe[0] + b[1] * pe[1] + b[2] * pe[2]);
            out->q_dir[k][l] = (float)(b[0] * od[0] + b[1] * od[1] + b[2] * od[2]);
        }
        out->t_enter[l] = (float)t0;
        out->s_max[l] = (float)(t1 - t0);
    }
    return lanes;
}

typedef struct {
    vf s;      /* distance from entry of the hit */
    vf iters;  /* escape count there */
    vf dist;   /* world-space estimate there */
    vm hit;
} UB_FN(ub_march_result);

static inline vf UB_FN(threshold)(const UB_FN(ub_de_params) *p, vf t)
{
    return v_fma(p->eps1, t, p->eps0);
}

/* March one object's rays by unbounding spheres (section 3): step by the distance estimate
 * (times step_factor, at most max_step), a hit when it drops below the threshold. Section 3.3's
 * thin sets come for free: the threshold is the minimum increment, so a dendrite thinner than
 * it still stops the ray. */
static void UB_FN(march)(const ub_scene *sc, const ub_object *o, const UB_FN(ub_de_params) *dp,
                         const UB_FN(ub_object_rays) *r, int lanes, UB_FN(ub_march_result) *res,
                         vf *steps, ub_counters *cnt)
{
    vf q0[4], qd[4];
    for (int k = 0; k < 4; k++) {
        q0[k] = v_load(r->q_enter[k]);
        qd[k] = v_load(r->q_dir[k]);
    }
    const vf te = v_load(r->t_enter), s_max = v_load(r->s_max);
    const vf sigma = v_set1((float)o->sigma_min);
    const vf factor = v_set1((float)o->step_factor);
    const vf max_step = v_set1((float)o->max_step);
    vf s = v_set1(0.0f), prev = v_set1(0.0f);
    vf hit_prev = prev, iter_sum = v_set1(0.0f);
    vm active = m_from_bits(lanes);
    res->hit = m_false();
    res->s = s;
    res->iters = v_set1(0.0f);
    res->dist = v_set1(0.0f);
    for (int step = 0; step < o->max_steps && m_bits(active); step++) {
        if (__atomic_load_n(sc->cancel, __ATOMIC_RELAXED))
            return;
        vf dist, iters;
        UB_FN(de)(dp, v_fma(s, qd[0], q0[0]), v_fma(s, qd[1], q0[1]), v_fma(s, qd[2], q0[2]),
                  v_fma(s, qd[3], q0[3]), &dist, &iters);
        vf dw = v_mul(dist, sigma);
        vf eps = UB_FN(threshold)(dp, v_add(te, s));
        *steps = v_count(*steps, active);
        iter_sum = v_add(iter_sum, v_select(active, iters, v_set1(0.0f)));
        vm is_hit = m_and(active, v_lt(dw, eps));
        res->hit = m_or(res->hit, is_hit);
        res->s = v_select(is_hit, s, res->s);
        res->iters = v_select(is_hit, iters, res->iters);
        res->dist = v_select(is_hit, dw, res->dist);
        hit_prev = v_select(is_hit, prev, hit_prev);
        active = m_andnot(is_hit, active);
        vf step_len = v_min(v_mul(dw, factor), max_step);
        prev = v_select(active, s, prev);
        s = v_select(active, v_add(s, step_len), s);
        active = m_and(active, v_le(s, s_max));
    }
    /* Optional refinement: bisect between the last sample outside the threshold and the hit. */
    vm refine = res->hit;
    vf lo = hit_prev, hi = res->s;
    for (int k = 0; k < o->bisection_steps && m_bits(refine); k++) {
        vf mid = v_mul(v_add(lo, hi), v_set1(0.5f));
        vf dist, iters;
        UB_FN(de)(dp, v_fma(mid, qd[0], q0[0]), v_fma(mid, qd[1], q0[1]), v_fma(mid, qd[2], q0[2]),
                  v_fma(mid, qd[3], q0[3]), &dist, &iters);
        vf dw = v_mul(dist, sigma);
        vm inside = m_and(refine, v_lt(dw, UB_FN(threshold)(dp, v_add(te, mid))));
        vm outside = m_andnot(inside, refine);
        iter_sum = v_add(iter_sum, v_select(refine, iters, v_set1(0.0f)));
        hi = v_select(inside, mid, hi);
        lo = v_select(outside, mid, lo);
        res->iters = v_select(inside, iters, res->iters);
        res->dist = v_select(inside, dw, res->dist);
    }
    res->s = hi;
    float it[UB_LANES];
    v_store(it, iter_sum);
    for (int l = 0; l < UB_LANES; l++)
        cnt->iterations += (uint64_t)it[l];
}

/* Gradient of the distance estimate by central differences (eq. 15), in object space. */
static void UB_FN(gradient)(const ub_object *o, const UB_FN(ub_de_params) *dp, const vf q[4], vf h,
                            vm lanes, vf grad[3], vf *work)
{
    for (int axis = 0; axis < 3; axis++) {
        vf dpos, dneg, it, itn;
        vf off[4];
        for (int k = 0; k < 4; k++)
            off[k] = v_mul(h, v_set1((float)o->slice_basis[k][axis]));
        UB_FN(de)(dp, v_add(q[0], off[0]), v_add(q[1], off[1]), v_add(q[2], off[2]), v_add(q[3], off[3]),
                  &dpos, &it);
        UB_FN(de)(dp, v_sub(q[0], off[0]), v_sub(q[1], off[1]), v_sub(q[2], off[2]), v_sub(q[3], off[3]),
                  &dneg, &itn);
        grad[axis] = v_sub(dpos, dneg);
        *work = v_add(*work, v_add(v_select(lanes, it, v_set1(0.0f)), v_select(lanes, itn, v_set1(0.0f))));
    }
}

static void UB_FN(write_pixel)(const ub_scene *sc, int fx, int fy, int hit, const float rgba[4],
                               float depth, const float normal[3], const float pos[3], float iters,
                               float steps, float dist)
{
    const ub_film *f = sc->film;
    size_t idx = (size_t)fy * (size_t)f->w + (size_t)fx;
    float *p;
    if ((p = f->pass[UB_PASS_COMBINED]))
        memcpy(p + 4 * idx, rgba, 4 * sizeof(float));
    if ((p = f->pass[UB_PASS_ALPHA]))
        p[idx] = hit ? 1.0f : 0.0f;
    if ((p = f->pass[UB_PASS_DEPTH]))
        p[idx] = depth;
    if ((p = f->pass[UB_PASS_NORMAL]))
        memcpy(p + 3 * idx, normal, 3 * sizeof(float));
    if ((p = f->pass[UB_PASS_POSITION]))
        memcpy(p + 3 * idx, pos, 3 * sizeof(float));
    if ((p = f->pass[UB_PASS_ITERATIONS]))
        p[idx] = iters;
    if ((p = f->pass[UB_PASS_STEPS]))
        p[idx] = steps;
    if ((p = f->pass[UB_PASS_DISTANCE]))
        p[idx] = dist;
}

/* Render film pixels [tx0, tx1) x [ty0, ty1) (window coordinates). */
void UB_FN(ub_render_tile)(const ub_scene *sc, int tx0, int ty0, int tx1, int ty1, ub_counters *cnt)
{
    const ub_camera *cam = sc->camera;
    const ub_film *film = sc->film;
    UB_FN(ub_de_params) dps[UB_MAX_OBJECTS];
    for (int k = 0; k < sc->object_count; k++)
        UB_FN(de_params)(&sc->objects[k], cam, &dps[k]);

    for (int y = ty0; y < ty1; y++) {
        for (int x = tx0; x < tx1; x += UB_LANES) {
            if (__atomic_load_n(sc->cancel, __ATOMIC_RELAXED))
                return;
            int n = tx1 - x < UB_LANES ? tx1 - x : UB_LANES;
            int lanes = (1 << n) - 1;
            UB_FN(ub_packet_rays) pr;
            for (int l = 0; l < UB_LANES; l++) {
                /* Padding lanes repeat the last real pixel; their results are discarded. */
                int px = film->x0 + x + (l < n ? l : n - 1);
                double o[3], d[3];
                ub_camera_ray(cam, px + 0.5, film->y0 + y + 0.5, o, d, &pr.t_min[l], &pr.t_max[l]);
                for (int i = 0; i < 3; i++) {
                    pr.origin[i][l] = o[i];
                    pr.dir[i][l] = d[i];
                }
            }
            float best_t[UB_LANES], best_iters[UB_LANES], best_dist[UB_LANES];
            float best_q[4][UB_LANES];
            int best_obj[UB_LANES];
            for (int l = 0; l < UB_LANES; l++) {
                best_t[l] = (float)pr.t_max[l];
                best_obj[l] = -1;
                best_iters[l] = best_dist[l] = 0.0f;
            }
            vf steps = v_set1(0.0f);
            /* Several objects render as their union: the nearest hit wins, and each object's
             * march stops at the nearest hit found so far. */
            for (int k = 0; k < sc->object_count; k++) {
                const ub_object *o = &sc->objects[k];
                UB_FN(ub_object_rays) orays;
                int active = UB_FN(object_rays)(o, &pr, best_t, lanes, &orays);
                if (!active)
                    continue;
                UB_FN(ub_march_result) res;
                UB_FN(march)(sc, o, &dps[k], &orays, active, &res, &steps, cnt);
                int hits = m_bits(res.hit) & active;
                if (!hits)
                    continue;
                float s[UB_LANES], it[UB_LANES], di[UB_LANES];
                v_store(s, res.s);
                v_store(it, res.iters);
                v_store(di, res.dist);
                for (int l = 0; l < UB_LANES; l++) {
                    if (!((hits >> l) & 1))
                        continue;
                    float t = orays.t_enter[l] + s[l];
                    if (!(t < best_t[l] || best_obj[l] < 0))
                        continue;
                    best_t[l] = t;
                    best_obj[l] = k;
                    best_iters[l] = it[l];
                    best_dist[l] = di[l];
                    for (int c = 0; c < 4; c++)
                        best_q[c][l] = orays.q_enter[c][l] + s[l] * orays.q_dir[c][l];
                }
            }
            if (__atomic_load_n(sc->cancel, __ATOMIC_RELAXED))
                return;
            /* Normals: one vectorised gradient per object over its lanes. */
            float grad[3][UB_LANES];
            memset(grad, 0, sizeof grad);
            for (int k = 0; k < sc->object_count; k++) {
                int mine = 0;
                for (int l = 0; l < n; l++)
                    if (best_obj[l] == k)
                        mine |= 1 << l;
                if (!mine)
                    continue;
                const ub_object *o = &sc->objects[k];
                vf q[4], g[3];
                for (int c = 0; c < 4; c++)
                    q[c] = v_load(best_q[c]);
                /* Offset of the order of the hit threshold, in object units. */
                float hbuf[UB_LANES];
                for (int l = 0; l < UB_LANES; l++)
                    hbuf[l] = best_obj[l] == k ? best_t[l] : 1.0f;
                vf h = v_div(UB_FN(threshold)(&dps[k], v_load(hbuf)), v_set1((float)o->sigma_min));
                vf work = v_set1(0.0f);
                UB_FN(gradient)(o, &dps[k], q, h, m_from_bits(mine), g, &work);
                float wb[UB_LANES];
                v_store(wb, work);
                for (int l = 0; l < n; l++)
                    cnt->iterations += (uint64_t)wb[l];
                float gb[3][UB_LANES];
                for (int a = 0; a < 3; a++)
                    v_store(gb[a], g[a]);
                for (int l = 0; l < n; l++)
                    if ((mine >> l) & 1)
                        for (int a = 0; a < 3; a++)
                            grad[a][l] = gb[a][l];
            }
            float stp[UB_LANES];
            v_store(stp, steps);
            for (int l = 0; l < n; l++) {
                cnt->rays++;
                cnt->steps += (uint64_t)stp[l];
                if (best_obj[l] < 0) {
                    const float zero3[3] = {0.0f, 0.0f, 0.0f};
                    UB_FN(write_pixel)(sc, x + l, y, 0, film->background, UB_BACKGROUND_DEPTH, zero3, zero3,
                                       0.0f, stp[l], 0.0f);
                    continue;
                }
                const ub_object *o = &sc->objects[best_obj[l]];
                double t = best_t[l];
                double dw[3] = {pr.dir[0][l], pr.dir[1][l], pr.dir[2][l]};
                double hp[3], nw[3], depth = 0.0, len2 = 0.0;
                for (int i = 0; i < 3; i++) {
                    hp[i] = pr.origin[i][l] + t * dw[i];
                    depth += (hp[i] - cam->position[i]) * cam->forward[i];
                }
                /* Normals transform with the inverse transpose of object -> world. */
                for (int i = 0; i < 3; i++) {
                    nw[i] = o->world_to_object[0][i] * grad[0][l] + o->world_to_object[1][i] * grad[1][l]
                          + o->world_to_object[2][i] * grad[2][l];
                    len2 += nw[i] * nw[i];
                }
                if (!(len2 > 0.0) || !isfinite(len2)) {
                    /* Flat estimate (deep inside the set): face the camera. */
                    for (int i = 0; i < 3; i++)
                        nw[i] = -dw[i];
                    len2 = 1.0;
                }
                double inv = 1.0 / sqrt(len2), lambert = 0.0;
                float normal[3], pos[3];
                for (int i = 0; i < 3; i++) {
                    normal[i] = (float)(nw[i] * inv);
                    pos[i] = (float)hp[i];
                    lambert -= nw[i] * inv * dw[i];
                }
                /* Section 4: Lambertian diffuse with the light at the eye (the "axle light"). */
                if (lambert < 0.0)
                    lambert = 0.0;
                float rgba[4] = {(float)(o->color[0] * lambert), (float)(o->color[1] * lambert),
                                 (float)(o->color[2] * lambert), 1.0f};
                UB_FN(write_pixel)(sc, x + l, y, 1, rgba, (float)depth, normal, pos, best_iters[l], stp[l],
                                   best_dist[l]);
            }
        }
    }
}

void UB_FN(ub_estimate)(const ub_object *o, const float *xyz, size_t count, float *estimate, float *iterations)
{
    UB_FN(ub_de_params) dp;
    UB_FN(de_params)(o, NULL, &dp);
    for (size_t base = 0; base < count; base += UB_LANES) {
        float q[4][UB_LANES];
        size_t n = count - base < UB_LANES ? count - base : UB_LANES;
        for (size_t l = 0; l < UB_LANES; l++) {
            const float *p = xyz + 3 * (base + (l < n ? l : n - 1));
            for (int k = 0; k < 4; k++)
                q[k][l] = (float)(o->slice_origin[k] + o->slice_basis[k][0] * p[0] + o->slice_basis[k][1] * p[1]
                                  + o->slice_basis[k][2] * p[2]);
        }
        vf dist, it;
        UB_FN(de)(&dp, v_load(q[0]), v_load(q[1]), v_load(q[2]), v_load(q[3]), &dist, &it);
        float db[UB_LANES], ib[UB_LANES];
        v_store(db, dist);
        v_store(ib, it);
        for (size_t l = 0; l < n; l++) {
            estimate[base + l] = db[l];
            iterations[base + l] = ib[l];
        }
    }
}
