/* Shared first steps (issue 21): one cone per block of UB_CONE_BLOCK x UB_CONE_BLOCK pixels,
 * marched by unbounding spheres (section 3) until the spheres no longer hold the cone, then every
 * camera ray of the block starts there. Included by kernel.h after march.h.
 *
 * Why it is exact. Section 3's unbounding sphere: a lower bound L of the distance from a point c
 * to the set certifies that the ball B(c, L) holds no point of it. Every camera ray of a block is
 * p(l) = o + l u with |p(l) - c(l)| <= r(l) = spread0 + spread1 l, where c(l) = origin + l axis is
 * the cone's axis at the same distance l: |p(l) - c(l)| <= |o - origin| + l |u - axis|, and both
 * are largest at the block's corners (a projection maps the block's rectangle onto a plane
 * quadrilateral: the rays' origins are an affine image of it (orthographic), their directions
 * its central projection onto the unit sphere, a spherical polygon inside any cap that holds its
 * corners). Then for l in [t, t + g]: |p(l) - c(t)| <= |p(l) - p(t)| + |p(t) - c(t)|
 * <= g |u| + r(t), so with g = (L - r(t)) / |u|_max the whole piece [t, t + g] of every ray of
 * the block lies in B(c(t), L): no ray can meet the set there. By induction every ray is empty up
 * to the cone's last t, and may start there instead of at the clip plane; its march continues
 * unchanged. L is the smallest over the scene of:
 *   - per object, the larger of the distance to its bounding ball (section 3.4; the set is
 *     inside) and, near the ball and for objects with a proven bound (obj->exact), the distance
 *     estimate in world units as the march takes it (times step_factor, at most max_step), less
 *     the hit threshold at the far end of the ball: every point the cone skips is at least a
 *     threshold from the set, so a ray that would have stopped on a thin piece of the set (section
 *     3.3, a hit below the threshold) still meets it in its own march;
 *   - with the sea, the distance to its plane: the sea is hit analytically from the ray's t_min,
 *     which therefore never passes it.
 * Empirical estimates (section 5: stacks, cubic locus, Mandelbulb, Mandelbox, hybrids) are not
 * trusted off the ray: for them only the bounding ball counts, so the cone stops at their ball.
 *
 * Same bits everywhere: a block's start is a pure function of the block and the scene (never of
 * which of its pixels are rendered, the window, the band, the sub-grid step, the thread or the
 * lane it is computed in: lanes never interact, and every kernel gives the same estimate), so
 * any thread may compute it and they all write the same value. */

/* At most this many steps per cone (grazing cones creep past a surface in small steps). */
#define UB_CONE_MAX_STEPS 48
/* The start of a block no ray of which meets an object (march_cones). */
#define UB_CONE_EMPTY HUGE_VAL

/* An object's bounding ball in world space (centre, radius), grown by far more than rounding:
 * no point of the set is outside. The object's affine map is world_to_object's inverse. */
static void world_ball(const ub_object *o, double centre[3], double *radius)
{
    const double(*w)[4] = o->world_to_object;
    double det = w[0][0] * (w[1][1] * w[2][2] - w[1][2] * w[2][1]) - w[0][1] * (w[1][0] * w[2][2] - w[1][2] * w[2][0])
               + w[0][2] * (w[1][0] * w[2][1] - w[1][1] * w[2][0]);
    double b[3];
    for (int i = 0; i < 3; i++)
        b[i] = o->bound_center[i] - w[i][3];
    /* Cramer's rule: column j of w replaced by b. */
    for (int j = 0; j < 3; j++) {
        double m[3][3];
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++)
                m[r][c] = c == j ? b[r] : w[r][c];
        centre[j] = (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                     + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
                  / det;
    }
    double size = fabs(centre[0]) + fabs(centre[1]) + fabs(centre[2]) + o->bound_radius * o->sigma_max;
    *radius = o->bound_radius * o->sigma_max * (1.0 + 1e-6) + 1e-9 * size;
}

typedef struct {
    double origin[3][UB_LANES], axis[3][UB_LANES];
    double spread0[UB_LANES], spread1[UB_LANES]; /* r(t) = spread0 + spread1 t */
    double speed; /* largest |u| of a ray of any block: the camera's (camera_speed), the same for all */
    double beyond[UB_LANES]; /* past this t no ray of the block is in any object's bounding ball */
} block_cones;

static inline double distance3(const double a[3], const double b[3])
{
    double d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
    return sqrt(d0 * d0 + d1 * d1 + d2 * d2);
}

/* Largest |M v| over unit v of the camera's rotation columns: 1 for Blender's cameras (unit
 * columns, camera.c, at right angles); a sheared matrix gets the Frobenius norm, an upper bound. */
static double camera_speed(const ub_camera *cam)
{
    const double(*m)[4] = cam->cam_to_world;
    double frobenius = 0.0, skew = 0.0;
    for (int a = 0; a < 3; a++) {
        for (int r = 0; r < 3; r++)
            frobenius += m[r][a] * m[r][a];
        for (int b = a + 1; b < 3; b++)
            skew = ub_fmax(skew, fabs(m[0][a] * m[0][b] + m[1][a] * m[1][b] + m[2][a] * m[2][b]));
    }
    return skew < 1e-9 ? 1.0 + 1e-6 : sqrt(frobenius) * (1.0 + 1e-6);
}

/* Past which t no ray of a cone (axis c(t) = origin + t axis, radius r(t) = spread0 + spread1 t)
 * is in the ball (centre, radius): a ray point p(t) in it has |c(t) - centre| <= radius + r(t)
 * (|p(t) - c(t)| <= r(t)), a quadratic inequality in t,
 *   (|axis|^2 - spread1^2) t^2 + 2 (axis.rel - spread1 R) t + |rel|^2 - R^2 <= 0,
 * rel = origin - centre, R = radius + spread0, which holds only between its roots: beyond the
 * larger one (0 where it has none) no ray meets the ball. Grown by far more than its rounding;
 * HUGE_VAL where the cone is as wide as its axis is long (no t is certain). Without branches, so
 * that a lane loop over it is vector code: the other cases' values (a root of a negative number,
 * a division by 0) are computed and not chosen. */
static inline __attribute__((always_inline)) double cone_leaves_ball(const double origin[3], const double axis[3],
        double spread0, double spread1, const double centre[3], double radius)
{
    const double rel[3] = {origin[0] - centre[0], origin[1] - centre[1], origin[2] - centre[2]};
    const double R = radius + spread0;
    const double axis2 = axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2];
    const double qa = axis2 - spread1 * spread1;
    const double qb = axis[0] * rel[0] + axis[1] * rel[1] + axis[2] * rel[2] - spread1 * R;
    const double qc = rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2] - R * R;
    const double disc = qb * qb - qa * qc;
    const double far = (sqrt(disc) - qb) / qa;
    const double scale = sqrt(rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2]) + R;
    const double beyond = far > 0.0 ? far * (1.0 + 1e-6) + 1e-9 * scale / sqrt(qa) : 0.0;
    return !(qa > 1e-3 * axis2) ? HUGE_VAL : disc < 0.0 ? 0.0 : beyond;
}

/* Each lane's beyond grown to where its cone leaves the ball (centre, radius). A loop of its own,
 * the lanes innermost: vector code. */
static inline __attribute__((always_inline)) void cones_leave_ball(block_cones *bc, const double centre[3],
                                                                   double radius)
{
    for (int l = 0; l < UB_LANES; l++) {
        const double origin[3] = {bc->origin[0][l], bc->origin[1][l], bc->origin[2][l]};
        const double axis[3] = {bc->axis[0][l], bc->axis[1][l], bc->axis[2][l]};
        bc->beyond[l] = ub_fmax(bc->beyond[l],
                                cone_leaves_ball(origin, axis, bc->spread0[l], bc->spread1[l], centre, radius));
    }
}

/* A cone's spreads (block_cones_kind) grown to take the ray through image point (x, y): the
 * distances of its origin and direction from the cone's axis ray (origin, axis). */
static inline __attribute__((always_inline)) void corner_spread(const ub_camera *cam, const int orthographic,
        double x, double y, const double origin[3], const double axis[3], double *spread0, double *spread1)
{
    double ov[3], dv[3], t0, t1, o[3], d[3];
    projection_ray_view_kind(cam, orthographic, x, y, ov, dv, &t0, &t1);
    view_to_world(cam->cam_to_world, ov, dv, o, d);
    *spread0 = ub_fmax(*spread0, distance3(o, origin));
    *spread1 = ub_fmax(*spread1, distance3(d, axis));
}

/* The cones of the blocks (bx[l], by[l]) into bc's lanes: the axis through each block's centre,
 * the spreads from its corners (the pixels' areas: every sample offset in [0, 1) stays inside).
 * Lane loops over plain arrays, `orthographic` known when compiled: double-precision vector code
 * (issue 21: block by block, with five rays each, the cones were 2 % of a render). */
static inline __attribute__((always_inline)) void block_cones_kind(const ub_scene *sc,
        const double (*ball_centre)[3], const double *ball_radius, const double bx[UB_LANES],
        const double by[UB_LANES], const int orthographic, block_cones *bc)
{
    const ub_camera *cam = sc->camera;
    const double size = UB_CONE_BLOCK;
    for (int l = 0; l < UB_LANES; l++) {
        const double x0 = size * bx[l], y0 = size * by[l];
        double ov[3], dv[3], t0, t1, origin[3], axis[3];
        projection_ray_view_kind(cam, orthographic, x0 + 0.5 * size, y0 + 0.5 * size, ov, dv, &t0, &t1);
        view_to_world(cam->cam_to_world, ov, dv, origin, axis);
        /* The corners written out, not a loop: the lane loop is then the innermost one, which the
         * compiler vectorises. */
        double spread0 = 0.0, spread1 = 0.0;
        corner_spread(cam, orthographic, x0, y0, origin, axis, &spread0, &spread1);
        corner_spread(cam, orthographic, x0 + size, y0, origin, axis, &spread0, &spread1);
        corner_spread(cam, orthographic, x0, y0 + size, origin, axis, &spread0, &spread1);
        corner_spread(cam, orthographic, x0 + size, y0 + size, origin, axis, &spread0, &spread1);
        for (int i = 0; i < 3; i++) {
            bc->origin[i][l] = origin[i];
            bc->axis[i][l] = axis[i];
        }
        /* Margins far above the rounding of the pixels' own rays (a few 1e-16 relative). */
        double scale = 1.0 + fabs(origin[0]) + fabs(origin[1]) + fabs(origin[2]);
        bc->spread0[l] = spread0 * (1.0 + 1e-6) + 1e-12 * scale;
        bc->spread1[l] = spread1 * (1.0 + 1e-6) + 1e-12;
        bc->beyond[l] = 0.0;
    }
    for (int k = 0; k < sc->object_count; k++)
        if (ball_radius[k] >= 0.0)
            cones_leave_ball(bc, ball_centre[k], ball_radius[k]);
    bc->speed = camera_speed(cam);
}

/* Lower bounds of the distance from the points c (world) to object o, less its hit threshold,
 * into clear (smallest so far) for the lanes `open`; t: the points' distance along the cone. */
static void object_clearance(const ub_object *o, const ub_de_params *dp, int open, const double c[3][UB_LANES],
                             const double t[UB_LANES], double clear[UB_LANES], uint64_t iterations[UB_LANES])
{
    if (o->bound_radius < 0.0) /* the slice misses the set: no ray meets it (object_rays) */
        return;
    /* The points in object space, their distance to the bounding ball and their quaternions: only
     * + - * sqrt, in the same order in every lane (the same bits at any vector width, no
     * contraction), in double vectors where the kernel has them (as object_rays: issue 21, the
     * compiler's own code of these loops spilled and shuffled), else in lane loops. */
    const double(*w)[4] = o->world_to_object;
    double ball[UB_LANES];
    float q[4][UB_LANES];
#ifdef VD_LANES
    for (int h = 0; h < UB_LANES; h += VD_LANES) {
        vd cv[3], oc[3], rel[3];
        for (int i = 0; i < 3; i++)
            cv[i] = vd_load(c[i] + h);
        for (int i = 0; i < 3; i++) {
            oc[i] = vd_add(vd_row_dot(w[i], cv), vd_set1(w[i][3]));
            rel[i] = vd_sub(oc[i], vd_set1(o->bound_center[i]));
        }
        const vd r2 = vd_add(vd_add(vd_mul(rel[0], rel[0]), vd_mul(rel[1], rel[1])), vd_mul(rel[2], rel[2]));
        vd_store(ball + h, vd_sub(vd_sqrt(r2), vd_set1(o->bound_radius))); /* object units, < 0 inside */
        for (int k = 0; k < 4; k++) {
            double qk[VD_LANES];
            vd_store(qk, vd_offset_dot(o->slice_origin[k], o->slice_basis[k], oc));
            for (int l = 0; l < VD_LANES; l++)
                q[k][h + l] = (float)qk[l];
        }
    }
#else
    double oc[3][UB_LANES];
    for (int i = 0; i < 3; i++)
        for (int l = 0; l < UB_LANES; l++)
            oc[i][l] = w[i][0] * c[0][l] + w[i][1] * c[1][l] + w[i][2] * c[2][l] + w[i][3];
    for (int l = 0; l < UB_LANES; l++) {
        double r0 = oc[0][l] - o->bound_center[0], r1 = oc[1][l] - o->bound_center[1];
        double r2 = oc[2][l] - o->bound_center[2];
        ball[l] = sqrt(r0 * r0 + r1 * r1 + r2 * r2) - o->bound_radius; /* object units, < 0 inside */
    }
    for (int k = 0; k < 4; k++) {
        const double *b = o->slice_basis[k];
        for (int l = 0; l < UB_LANES; l++)
            q[k][l] = (float)(o->slice_origin[k] + b[0] * oc[0][l] + b[1] * oc[1][l] + b[2] * oc[2][l]);
    }
#endif
    /* The estimate only near the ball: far outside, float32 orbits overflow (kernel.h's
     * ub_estimate), and the ball's own distance is the better bound there anyway. */
    int near = 0;
    if (o->exact)
        for (int l = 0; l < UB_LANES; l++)
            if (((open >> l) & 1) && ball[l] <= o->bound_radius)
                near |= 1 << l;
    float dist[UB_LANES], iters[UB_LANES], e0[UB_LANES], e1[UB_LANES];
    if (near) {
        vf dv, iv;
        de(dp, m_from_bits(near), v_load(q[0]), v_load(q[1]), v_load(q[2]), v_load(q[3]), &dv, &iv);
        v_store(dist, dv);
        v_store(iters, iv);
    }
    v_store(e0, dp->eps0);
    v_store(e1, dp->eps1);
#ifdef VD_LANES
    /* The lane loop below in double vectors (issue 21: GCC left it scalar, 1.8 % of the peer
     * render): its comparisons as selects, in its order, so the same bits. */
    for (int l = 0; l < UB_LANES; l++)
        if ((near >> l) & 1)
            iterations[l] += (uint64_t)iters[l];
    const vd zero = vd_set1(0.0), sigma_min = vd_set1(o->sigma_min);
    const int bits = (1 << VD_LANES) - 1;
    for (int h = 0; h < UB_LANES; h += VD_LANES) {
        if (!((open >> h) & bits))
            continue;
        vd bound = vd_mul(vd_load(ball + h), sigma_min);
        if ((near >> h) & bits) {
            const vd d = vd_load_floats(dist + h);
            /* As the march steps (march.h); a non-finite estimate bounds nothing. */
            const vdm bounds = vdm_and(vdm_lanes_at(near, h),
                                       vdm_and(vd_gt(d, zero), vd_lt(d, vd_set1(INFINITY))));
            const vd scaled = vd_mul(vd_mul(d, sigma_min), vd_set1(o->step_factor));
            /* ub_fmin(scaled, max_step) (a NaN cap caps nothing), then ub_fmax(bound, that): vd_min
             * and vd_max are the same selects where the second operand is not NaN. */
            const vd capped = isnan(o->max_step) ? scaled : vd_min(scaled, vd_set1(o->max_step));
            bound = vd_select(bounds, vd_max(bound, capped), bound);
        }
        const vd ahead = vd_add(vd_load(t + h), vd_max(bound, zero));
        bound = vd_sub(bound, vd_add(vd_load_floats(e0 + h), vd_mul(vd_load_floats(e1 + h), ahead)));
        /* ub_fmin(clear, bound): a NaN bound leaves clear */
        vd_store_lanes(clear + h, vdm_and(vdm_lanes_at(open, h), vd_ge(bound, bound)),
                       vd_min(vd_load(clear + h), bound));
    }
#else
    for (int l = 0; l < UB_LANES; l++) {
        if (!((open >> l) & 1))
            continue;
        double bound = ball[l] * o->sigma_min;
        if ((near >> l) & 1) {
            iterations[l] += (uint64_t)iters[l];
            double d = dist[l];
            /* As the march steps (march.h); a non-finite estimate bounds nothing. */
            if (d > 0.0 && d < INFINITY)
                bound = ub_fmax(bound, ub_fmin(d * o->sigma_min * o->step_factor, o->max_step));
        }
        bound -= (double)e0[l] + (double)e1[l] * (t[l] + ub_fmax(bound, 0.0));
        clear[l] = ub_fmin(clear[l], bound);
    }
#endif
}

/* One step of the open cones: t += gain, the distance the unbounding sphere certifies for the
 * whole cone; a cone stops (its bit cleared, t kept) once the cone nearly fills the sphere and
 * further steps gain little, or once it is past every object's ball. Returns the lanes still open. */
static inline __attribute__((always_inline)) int cones_advance(const block_cones *bc, int open,
        const double clear[UB_LANES], double t[UB_LANES])
{
#ifdef VD_LANES
    /* Every lane's test at once, the open ones' t stored (issue 21: a branch a lane, which
     * mispredicts, was a third of the cones' time); the same operations as the lane loop. */
    int going = 0;
    for (int h = 0; h < UB_LANES; h += VD_LANES) {
        const vd tv = vd_load(t + h), cl = vd_load(clear + h);
        const vd gain = vd_div(vd_sub(cl, vd_add(vd_load(bc->spread0 + h), vd_mul(vd_load(bc->spread1 + h), tv))),
                               vd_set1(bc->speed));
        const vd ahead = vd_add(tv, gain);
        const vdm go = vdm_andnot(vd_ge(tv, vd_load(bc->beyond + h)),
                                  vdm_and(vd_gt(gain, vd_mul(vd_set1(0.125), cl)), vd_lt(ahead, vd_set1(HUGE_VAL))));
        const vdm step = vdm_and(go, vdm_lanes_at(open, h));
        vd_store_lanes(t + h, step, ahead);
        going |= vdm_bits(step) << h;
    }
    return going;
#else
    for (int l = 0; l < UB_LANES; l++) {
        if (!((open >> l) & 1))
            continue;
        double gain = (clear[l] - (bc->spread0[l] + bc->spread1[l] * t[l])) / bc->speed;
        if (!(gain > 0.125 * clear[l]) || !(t[l] + gain < HUGE_VAL) || t[l] >= bc->beyond[l]) {
            open &= ~(1 << l);
            continue;
        }
        t[l] += gain;
    }
    return open;
#endif
}

/* March the cones of bc's first n lanes; start[l]: where every ray of block l may start. */
static void march_cones(const ub_scene *sc, const ub_de_params *dps, const block_cones *bc, int n,
                        double start[UB_LANES], uint64_t iterations[UB_LANES])
{
    double t[UB_LANES];
    for (int l = 0; l < UB_LANES; l++) {
        t[l] = 0.0;
        iterations[l] = 0;
    }
    int open = (1 << n) - 1;
    for (int step = 0; step < UB_CONE_MAX_STEPS && open; step++) {
        if (cancelled(sc))
            return;
        double c[3][UB_LANES], clear[UB_LANES];
        for (int l = 0; l < UB_LANES; l++) {
            for (int i = 0; i < 3; i++)
                c[i][l] = bc->origin[i][l] + t[l] * bc->axis[i][l];
            clear[l] = HUGE_VAL;
            if (sc->shading->sea)
                clear[l] = fabs(c[2][l] - sc->shading->sea_height) * (1.0 - 1e-6);
        }
        for (int k = 0; k < sc->object_count; k++)
            object_clearance(&sc->objects[k], &dps[k], open, c, t, clear, iterations);
        open = cones_advance(bc, open, clear, t);
    }
    /* A block whose cone got past every object's ball (beyond) holds no hit at all: its start is
     * UB_CONE_EMPTY, and its camera rays are not traced (cone_start_rays). Not with the sea, whose
     * plane trace() meets from each ray's own t_min. */
    for (int l = 0; l < n; l++)
        start[l] = t[l] >= bc->beyond[l] && !sc->shading->sea ? UB_CONE_EMPTY : t[l];
}

/* Computes and publishes the cones of the blocks idx[0 .. n). */
static void cone_batch(const ub_scene *sc, const ub_de_params *dps, const int *idx, int n, ub_counters *cnt)
{
    ub_cone_cache *cc = sc->cones;
    block_cones bc;
    double centre[UB_MAX_OBJECTS][3], radius[UB_MAX_OBJECTS];
    for (int k = 0; k < sc->object_count; k++) {
        radius[k] = -1.0;
        if (sc->objects[k].bound_radius >= 0.0)
            world_ball(&sc->objects[k], centre[k], &radius[k]);
    }
    double bx[UB_LANES], by[UB_LANES];
    for (int l = 0; l < UB_LANES; l++) {
        int i = idx[l < n ? l : n - 1];
        bx[l] = cc->bx0 + i % cc->nbx;
        by[l] = cc->by0 + i / cc->nbx;
    }
    if (sc->camera->orthographic)
        block_cones_kind(sc, centre, radius, bx, by, 1, &bc);
    else
        block_cones_kind(sc, centre, radius, bx, by, 0, &bc);
    double start[UB_LANES];
    uint64_t iterations[UB_LANES];
    march_cones(sc, dps, &bc, n, start, iterations);
    if (cancelled(sc))
        return;
    for (int l = 0; l < n; l++) {
        /* Another thread may be writing the same block: it writes the same bits. The one that
         * publishes first counts its iterations, so the render's count is the same too. */
        __atomic_store(&cc->start[idx[l]], &start[l], __ATOMIC_RELAXED);
        if (__atomic_exchange_n(&cc->ready[idx[l]], 1, __ATOMIC_ACQ_REL) == 0)
            cnt->iterations += iterations[l];
    }
}

/* The cone of image pixel (px, py). No pixel coordinate is negative (the hit buffer's apron lies
 * inside the image), so unsigned arithmetic: a shift where a signed divide needs a fix-up for
 * negative numbers, and loops of it become vector code (lane_starts). */
static inline unsigned cone_index(const ub_cone_cache *cc, int px, int py)
{
    return ((unsigned)py / UB_CONE_BLOCK - (unsigned)cc->by0) * (unsigned)cc->nbx
         + ((unsigned)px / UB_CONE_BLOCK - (unsigned)cc->bx0);
}

/* Computes the cones of the blocks under the hit-buffer tile [tx0, tx1) x [ty0, ty1) that no
 * thread has computed yet, UB_LANES at a time. */
static void cone_fill(const ub_scene *sc, const ub_de_params *dps, int tx0, int ty0, int tx1, int ty1,
                      ub_counters *cnt)
{
    const ub_hit_buffer *hb = sc->hits;
    const ub_cone_cache *cc = sc->cones;
    int pending[UB_LANES], n = 0, last_row = -1;
    for (int y = ty0; y < ty1; y++) {
        int py = hb->y0 + hb->step * y;
        if (py / UB_CONE_BLOCK == last_row)
            continue;
        last_row = py / UB_CONE_BLOCK;
        int last_col = -1;
        for (int x = tx0; x < tx1; x++) {
            int px = hb->x0 + hb->step * x;
            if (px / UB_CONE_BLOCK == last_col)
                continue;
            last_col = px / UB_CONE_BLOCK;
            unsigned i = cone_index(cc, px, py);
            if (__atomic_load_n(&cc->ready[i], __ATOMIC_ACQUIRE))
                continue;
            pending[n++] = (int)i;
            if (n == UB_LANES) {
                cone_batch(sc, dps, pending, n, cnt);
                n = 0;
            }
        }
    }
    if (n)
        cone_batch(sc, dps, pending, n, cnt);
}

/* The lanes whose start is UB_CONE_EMPTY: past it no ray touches an object's bounding ball, so
 * trace() would clip every object away (object_rays) and find what it finds for a lane it is not
 * given: no hit, no step. Most of a frame's background is such blocks (issue 21: 61 % of the peer
 * scene's pixels take no step). */
static inline int empty_lanes(const double start[UB_LANES])
{
    int empty = 0;
    for (int l = 0; l < UB_LANES; l++)
        empty |= (start[l] == UB_CONE_EMPTY) << l;
    return empty;
}

/* The certified starts of the cones of a block's pixels (px[l], py[l]; lane 0 its top-left pixel,
 * the last lane its bottom-right one, as block_pixels lays them out), computed by cone_fill;
 * returns the empty lanes (empty_lanes). Cones are aligned blocks of pixels, so where the two
 * corners share a cone every pixel between them does (a block of 4 x 4 pixels inside a cone of
 * 8 x 8, mostly): one index, one load and one test for them all (issue 21: a load a lane was a
 * third of chunk_primary's time, and 16 indices and tests a block a further 2 % of the peer
 * render, most of whose blocks are background). Else one load a lane. No pixel coordinate is
 * negative. */
static int lane_starts(const ub_cone_cache *cc, const int px[UB_LANES], const int py[UB_LANES],
                       double start[UB_LANES])
{
    const unsigned first = cone_index(cc, px[0], py[0]);
    if (first == cone_index(cc, px[UB_LANES - 1], py[UB_LANES - 1])) {
        double shared;
        __atomic_load(&cc->start[first], &shared, __ATOMIC_RELAXED);
        for (int l = 0; l < UB_LANES; l++)
            start[l] = shared;
        return shared == UB_CONE_EMPTY ? (int)((1u << UB_LANES) - 1) : 0;
    }
    for (int l = 0; l < UB_LANES; l++)
        __atomic_load(&cc->start[cone_index(cc, px[l], py[l])], &start[l], __ATOMIC_RELAXED);
    return empty_lanes(start);
}

/* Raise the t_min of the packet's camera rays to their blocks' certified starts. */
static void cone_start_rays(const double start[UB_LANES], ub_packet_rays *pr)
{
#ifdef VD_LANES
    /* ub_fmax(t_min, start) as vectors: max where start is a number, else t_min kept */
    for (int h = 0; h < UB_LANES; h += VD_LANES) {
        const vd t_min = vd_load(pr->t_min + h), s = vd_load(start + h);
        vd_store_lanes(pr->t_min + h, vd_ge(s, s), vd_max(t_min, s));
    }
#else
    for (int l = 0; l < UB_LANES; l++)
        pr->t_min[l] = ub_fmax(pr->t_min[l], start[l]);
#endif
}
