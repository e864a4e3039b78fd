/* Marching rays through the scene by unbounding spheres (section 3): clipping to each object's
 * bounding ball (section 3.4), the march itself with bisection of the hit, and the union of
 * several objects and the sea plane. Included by kernel.h, compiled once per SIMD flavour. */

/* A packet of world-space rays, one per lane, in double precision. t_base is the distance the
 * path had already travelled before this ray started (secondary rays): pixel-relative hit
 * thresholds grow with the whole path, like a ray cone. */
typedef struct {
    double origin[3][UB_LANES], dir[3][UB_LANES];
    double t_min[UB_LANES], t_max[UB_LANES];
    float t_base[UB_LANES];
} ub_packet_rays;

/* Per-lane state of rays against one object, prepared in double precision. */
typedef struct {
    float q_enter[4][UB_LANES]; /* quaternion point where the ray enters the bounding ball */
    float q_dir[4][UB_LANES];   /* quaternion-space change per unit of world distance */
    float t_enter[UB_LANES];    /* world distance along the ray at entry */
    float s_max[UB_LANES];      /* distance marched from entry before giving up */
} ub_object_rays;

/* Clip each lane's ray against the object's bounding ball; returns the lanes that touch it. The
 * same operations in the same order for every lane, in double vectors where the kernel has them
 * (issue 21: the lane-by-lane loop was 8.6 % of the peer render), else lane by lane: only + - * / sqrt
 * and comparisons, correctly rounded at any width, so every kernel keeps the same bits. A lane that
 * misses computes the roots of a negative discriminant too (NaN) and discards them. */
static int object_rays(const ub_object *o, const ub_packet_rays *restrict r, const float *restrict t_limit,
                       int lanes_in, ub_object_rays *restrict out)
{
    const double(*w)[4] = o->world_to_object, (*b)[3] = o->slice_basis;
    const double *center = o->bound_center, *origin_q = o->slice_origin;
    const double radius2 = o->bound_radius * o->bound_radius;
    if (!(o->bound_radius >= 0.0))
        lanes_in = 0;
    double q_enter[4][UB_LANES], q_dir[4][UB_LANES], t_enter[UB_LANES], s_max[UB_LANES], limit[UB_LANES];
    for (int l = 0; l < UB_LANES; l++)
        limit[l] = (double)t_limit[l];
    int lanes = 0;
#ifdef VD_LANES
    const vd zero = vd_set1(0.0), minus_one = vd_set1(-1.0);
    for (int h = 0; h < UB_LANES; h += VD_LANES) {
        vd ro[3], rd[3], oo[3], od[3], rel[3];
        for (int i = 0; i < 3; i++) {
            ro[i] = vd_load(r->origin[i] + h);
            rd[i] = vd_load(r->dir[i] + h);
        }
        for (int i = 0; i < 3; i++) {
            oo[i] = vd_add(vd_row_dot(w[i], ro), vd_set1(w[i][3]));
            od[i] = vd_row_dot(w[i], rd);
            rel[i] = vd_sub(oo[i], vd_set1(center[i]));
        }
        /* |oo + t od - c|^2 = R^2 */
        const vd qa = vd_add(vd_add(vd_mul(od[0], od[0]), vd_mul(od[1], od[1])), vd_mul(od[2], od[2]));
        const vd qb = vd_add(vd_add(vd_mul(rel[0], od[0]), vd_mul(rel[1], od[1])), vd_mul(rel[2], od[2]));
        const vd qc = vd_sub(vd_add(vd_add(vd_mul(rel[0], rel[0]), vd_mul(rel[1], rel[1])), vd_mul(rel[2], rel[2])),
                             vd_set1(radius2));
        const vd disc = vd_sub(vd_mul(qb, qb), vd_mul(qa, qc));
        const vd t_min = vd_load(r->t_min + h), t_lim = vd_load(limit + h);
        const vdm crosses = vdm_and(vdm_lanes_at(lanes_in, h), vd_ge(disc, zero));
        vd t0 = t_min, t1 = t_min; /* what a lane that does not touch the ball gets */
        /* Only where some lane's line crosses the ball are its roots wanted: the square root and
         * the two divides are most of the clip's time, and most camera rays of a frame miss. */
        if (vdm_bits(crosses)) {
            const vd sq = vd_sqrt(disc), neg_b = vd_mul(qb, minus_one);
            const vd near = vd_div(vd_sub(neg_b, sq), qa), far = vd_div(vd_add(neg_b, sq), qa);
            vd c0 = vd_select(crosses, vd_select(vd_gt(near, t_min), near, t_min), zero);
            vd c1 = vd_select(crosses, vd_select(vd_lt(far, t_lim), far, t_lim), minus_one);
            const vdm touches = vd_ge(c1, c0);
            lanes |= vdm_bits(touches) << h;
            t0 = vd_select(touches, c0, t_min);
            t1 = vd_select(touches, c1, t0);
        }
        vd pe[3];
        for (int i = 0; i < 3; i++)
            pe[i] = vd_add(oo[i], vd_mul(t0, od[i]));
        for (int c = 0; c < 4; c++) {
            vd_store(q_enter[c] + h, vd_offset_dot(origin_q[c], b[c], pe));
            vd_store(q_dir[c] + h, vd_row_dot(b[c], od));
        }
        vd_store(t_enter + h, t0);
        vd_store(s_max + h, vd_sub(t1, t0));
    }
#else
    for (int l = 0; l < UB_LANES; l++) {
        double oo[3], od[3], rel[3];
        for (int i = 0; i < 3; i++) {
            oo[i] = w[i][0] * r->origin[0][l] + w[i][1] * r->origin[1][l] + w[i][2] * r->origin[2][l] + w[i][3];
            od[i] = w[i][0] * r->dir[0][l] + w[i][1] * r->dir[1][l] + w[i][2] * r->dir[2][l];
            rel[i] = oo[i] - center[i];
        }
        const double qa = od[0] * od[0] + od[1] * od[1] + od[2] * od[2];
        const double qb = rel[0] * od[0] + rel[1] * od[1] + rel[2] * od[2];
        const double qc = rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2] - radius2;
        const double disc = qb * qb - qa * qc, sq = sqrt(disc), neg_b = qb * -1.0;
        const double near = (neg_b - sq) / qa, far = (neg_b + sq) / qa;
        const double t_min = r->t_min[l], t_lim = limit[l];
        const int crosses = ((lanes_in >> l) & 1) && disc >= 0.0;
        double t0 = crosses ? (near > t_min ? near : t_min) : 0.0;
        double t1 = crosses ? (far < t_lim ? far : t_lim) : -1.0;
        const int touches = t1 >= t0;
        lanes |= touches << l;
        t0 = touches ? t0 : t_min;
        t1 = touches ? t1 : t0;
        const double pe[3] = {oo[0] + t0 * od[0], oo[1] + t0 * od[1], oo[2] + t0 * od[2]};
        for (int c = 0; c < 4; c++) {
            q_enter[c][l] = origin_q[c] + b[c][0] * pe[0] + b[c][1] * pe[1] + b[c][2] * pe[2];
            q_dir[c][l] = b[c][0] * od[0] + b[c][1] * od[1] + b[c][2] * od[2];
        }
        t_enter[l] = t0;
        s_max[l] = t1 - t0;
    }
#endif
    for (int l = 0; l < UB_LANES; l++) {
        for (int c = 0; c < 4; c++) {
            out->q_enter[c][l] = (float)q_enter[c][l];
            out->q_dir[c][l] = (float)q_dir[c][l];
        }
        out->t_enter[l] = (float)t_enter[l];
        out->s_max[l] = (float)s_max[l];
    }
    return lanes;
}

typedef struct {
    vf s;      /* distance from entry of the hit */
    vf iters;  /* escape count there */
    vf dist;   /* world-space estimate there */
    vm hit;
    vm out_of_steps; /* still marching after max_steps: neither a hit nor out of the ball */
} ub_march_result;

/* How much longer than the plain step an over-relaxed step is (march below). */
#define UB_OVER_RELAXATION 1.5f

static inline vf threshold(const ub_de_params *p, vf t)
{
    return v_fma(p->eps1, t, p->eps0);
}

/* The float32 resolution of the marching parameter s: at least one ulp of s (FLT_EPSILON s is
 * between one and two), so s + resolution(s) > s always. */
static inline vf resolution(vf s)
{
    return v_mul(s, v_set1(FLT_EPSILON));
}

/* The march's estimate: with `julia` (known when compiled; julia_only(dp), in the kernels that
 * define UB_INLINE_JULIA_MARCH), the Julia set's iteration inlined into the march, so that the
 * march's state stays in registers across it: a call spills and reloads it every step (issue 21:
 * peer scene 1.036x with AVX-512, 1.044x with AVX2; the "everything" scene 1.026x). Same bits:
 * the same operations in the same order. Else de(). */
static inline __attribute__((always_inline)) void march_de(const ub_de_params *dp, const int julia, vm lanes, vf a,
                                                           vf b, vf c, vf d, vf *dist, vf *iters)
{
    if (julia) {
        ub_de_extra unused;
        de_quaternion_inline(dp, lanes, a, b, c, d, dist, iters, &unused);
    } else {
        de(dp, lanes, a, b, c, d, dist, iters);
    }
}

/* One packet's march against one object (march_rays below): the rays, where each lane is, and
 * what it has found. A lane's s and prev freeze when it stops (hit or out of the ball): after the
 * march they are the hit and the last sample before it, without per-step bookkeeping. */
typedef struct {
    vf q0[4], qd[4];
    vf te, tb, s_max;
    vf s, prev, iter_sum, dist, iters, dw;
    vm active, hit;
    /* Over-relaxed steps (`relax`, issue 21; Keinert et al. 2014, enhanced sphere tracing): a lane
     * steps UB_OVER_RELAXATION times the plain step while the unbounding spheres at consecutive
     * samples overlap, (s - prev) <= dw(prev) + dw(s): their union then holds the whole segment, so
     * no point of the set lies between the two samples (section 3's certificate, from two balls
     * instead of one). Where they do not overlap, the lane goes back to prev, discards the sample
     * at s, and takes plain steps from there on. */
    vf omega, prev_dw, prev_dist, prev_iters, last_step;
    vm relaxed_last; /* lanes whose last step was over-relaxed: their sample is checked */
    /* The bisection of the hits: the bracket [lo, hi] and the lanes still refining. */
    vf lo, hi;
    vm refine;
} ub_march_state;

/* The constants of one object's march. */
typedef struct {
    vf sigma, factor, max_step;
} ub_march_step;

static inline __attribute__((always_inline)) void march_begin(const ub_object_rays *r, vf t_base, int lanes,
                                                              const int relax, ub_march_state *m,
                                                              ub_march_result *res)
{
    for (int k = 0; k < 4; k++) {
        m->q0[k] = v_load(r->q_enter[k]);
        m->qd[k] = v_load(r->q_dir[k]);
    }
    m->te = v_load(r->t_enter);
    m->s_max = v_load(r->s_max);
    m->tb = v_add(m->te, t_base);
    m->s = m->prev = m->iter_sum = m->dist = m->iters = m->dw = v_set1(0.0f);
    m->active = m_from_bits(lanes);
    m->hit = m_false();
    m->omega = v_set1(relax ? UB_OVER_RELAXATION : 1.0f);
    m->prev_dw = m->prev_dist = m->prev_iters = m->last_step = v_set1(0.0f);
    m->relaxed_last = m_false();
    /* A cancelled march returns no hits (its caller still reads the result). */
    res->hit = res->out_of_steps = m_false();
    res->s = res->iters = res->dist = v_set1(0.0f);
}

/* The quaternion points at distance s from entry along each lane's ray. */
static inline __attribute__((always_inline)) void march_point(const ub_march_state *m, vf s, vf z[4])
{
    for (int k = 0; k < 4; k++)
        z[k] = v_fma(s, m->qd[k], m->q0[k]);
}

/* One step of the march from the estimate at s (new_dist, new_iters of the lanes still marching):
 * a hit when it drops below the threshold, else a step by the estimate (times step_factor, at most
 * max_step). Section 3.3's thin sets come for free: the threshold is the minimum increment, so a
 * dendrite thinner than it still stops the ray. With `penumbra` (shadow rays), also tracks
 * min d / (t tan(angle)): how nearly the ray missed, relative to the light's apparent size. */
static inline __attribute__((always_inline)) void march_advance(const ub_de_params *dp, const ub_march_step *c,
                                                                const int relax, vf new_dist, vf new_iters,
                                                                vf *steps, vf *penumbra, vf tan_angle,
                                                                ub_march_state *m)
{
    /* A stopped lane keeps its last estimate and escape count (those at its frozen s). */
    m->dist = v_select(m->active, new_dist, m->dist);
    m->iters = v_select(m->active, new_iters, m->iters);
    m->dw = v_mul(m->dist, c->sigma);
    vf eps = threshold(dp, v_add(m->tb, m->s));
    if (relax) {
        vm gap = m_and(m->relaxed_last, v_gt(m->last_step, v_add(m->prev_dw, m->dw)));
        if (m_bits(gap)) { /* back to prev and its estimate; plain steps from there on */
            m->s = v_select(gap, m->prev, m->s);
            m->dist = v_select(gap, m->prev_dist, m->dist);
            m->iters = v_select(gap, m->prev_iters, m->iters);
            m->dw = v_select(gap, m->prev_dw, m->dw);
            eps = threshold(dp, v_add(m->tb, m->s));
            m->omega = v_select(gap, v_set1(1.0f), m->omega);
        }
    }
    *steps = v_count(*steps, m->active);
    m->iter_sum = v_add(m->iter_sum, v_select(m->active, m->iters, v_set1(0.0f)));
    vm is_hit = m_and(m->active, v_lt(m->dw, eps));
    /* Issue 18: a step moves s by at least its resolution wherever the estimate allows it
     * (a step_factor or max_step below the resolution would stall the ray otherwise), never
     * by more than the estimate, so it never passes the set. Where the estimate itself is so
     * small that s + step rounds back to s (a fixed epsilon of 1e-7 a few units into the
     * ball), the ray can get no closer in float32: the estimate is below half an ulp of s
     * (a step of at least min(d, resolution) did not move it), s is the closest point float32
     * represents, and that is the hit (at the resolution limit), not a ray that stalls until
     * it runs out of steps and shows the background where the set is. Rays that still move
     * march on exactly as before. */
    vf factored = v_mul(m->dw, c->factor), least = v_min(m->dw, resolution(m->s));
    vf step_len = v_max(v_min(factored, c->max_step), least);
    vm relaxing = m_false();
    if (relax) {
        /* A relaxed step past s_max (out of the ball, or past the light) would end where no
         * sample checks it: only the sphere at s would certify it, which a relaxed step
         * outruns. Such a step is taken plainly. */
        vf longer = v_max(v_min(v_mul(factored, m->omega), c->max_step), least);
        relaxing = m_and(v_gt(m->omega, v_set1(1.0f)), v_le(v_add(m->s, longer), m->s_max));
        step_len = v_select(relaxing, longer, step_len);
    }
    vf next = v_add(m->s, step_len);
    is_hit = m_or(is_hit, m_and(m->active, v_le(next, m->s)));
    if (penumbra) {
        /* NaN (0/0 for a point source at the origin) leaves the minimum unchanged. */
        vf ratio = v_div(v_sub(m->dw, eps), v_mul(tan_angle, v_add(m->te, m->s)));
        *penumbra = v_select(m->active, v_min(ratio, *penumbra), *penumbra);
    }
    m->hit = m_or(m->hit, is_hit);
    m->active = m_andnot(is_hit, m->active);
    if (relax) {
        m->prev_dw = v_select(m->active, m->dw, m->prev_dw);
        m->prev_dist = v_select(m->active, m->dist, m->prev_dist);
        m->prev_iters = v_select(m->active, m->iters, m->prev_iters);
        m->last_step = v_select(m->active, v_sub(next, m->s), m->last_step);
        m->relaxed_last = m_and(m->active, relaxing);
    }
    m->prev = v_select(m->active, m->s, m->prev);
    m->s = v_select(m->active, next, m->s);
    m->active = m_and(m->active, v_le(m->s, m->s_max));
}

/* After the steps: what the march found, and the bisection's bracket. dist and iters are every
 * lane's last evaluation, at its frozen s: a hit lane's estimate and escape count. A cancel
 * returns before this, so lanes still active ran out of steps (where s froze).
 * Optional refinement: bisect between the last sample outside the threshold and the hit.
 * Shadow rays only ask whether something is hit, not where.
 * Issue 21: a lane stops refining, before bisection_steps (the maximum), once its bracket is
 * narrower than what the pixel can show:
 *   - 1/32 of the hit threshold there. The threshold is the resolution the render asks for
 *     (the pixel footprint / detail, or the fixed epsilon): every point within it of the set
 *     is surface, so the drawn surface is only defined to a threshold; placing it to 1/32 of
 *     one moves a hit by at most 1/(32 detail) of a pixel's footprint (measured on the peer
 *     scene: relative depth within 1.2e-4 of the float64 march's for 99 % of the hits, 2.2e-5
 *     of the full bisection's, and 0.6 % of the pixels' colours change by more than 1/255);
 *   - float32's resolution of s (resolution()): below it the midpoint rounds to lo or hi and
 *     further steps change nothing.
 * The initial bracket, the last step, is about a threshold long or more (the sample before
 * the hit was not within one), so with step_factor 1 about 5 or more of the default 10 steps
 * remain: on the peer scene 13.6 of its 81.7 iterations of f per ray are saved. */
static inline __attribute__((always_inline)) void march_found(int refine_hits, ub_march_state *m,
                                                              ub_march_result *res)
{
    res->hit = m->hit;
    res->out_of_steps = m->active;
    res->iters = m->iters;
    res->dist = m->dw;
    m->refine = refine_hits ? m->hit : m_false();
    m->lo = m->prev;
    m->hi = m->s;
}

/* The lanes whose bracket is still wider than the pixel can show (march_found). */
static inline __attribute__((always_inline)) int bisect_wanted(const ub_de_params *dp, ub_march_state *m)
{
    vf width_limit = v_max(v_mul(threshold(dp, v_add(m->tb, m->hi)), v_set1(1.0f / 32.0f)), resolution(m->hi));
    m->refine = m_and(m->refine, v_gt(v_sub(m->hi, m->lo), width_limit));
    return m_bits(m->refine) != 0;
}

static inline __attribute__((always_inline)) vf bisect_mid(const ub_march_state *m)
{
    return v_mul(v_add(m->lo, m->hi), v_set1(0.5f));
}

/* The bracket's half that holds the hit, from the estimate at mid. */
static inline __attribute__((always_inline)) void bisect_take(const ub_de_params *dp, const ub_march_step *c,
                                                              vf mid, vf dist, vf iters, ub_march_state *m,
                                                              ub_march_result *res)
{
    vf dw = v_mul(dist, c->sigma);
    vm inside = m_and(m->refine, v_lt(dw, threshold(dp, v_add(m->tb, mid))));
    vm outside = m_andnot(inside, m->refine);
    m->iter_sum = v_add(m->iter_sum, v_select(m->refine, iters, v_set1(0.0f)));
    m->hi = v_select(inside, mid, m->hi);
    m->lo = v_select(outside, mid, m->lo);
    res->iters = v_select(inside, iters, res->iters);
    res->dist = v_select(inside, dw, res->dist);
}

static inline __attribute__((always_inline)) void march_end(const ub_march_state *m, ub_march_result *res,
                                                            ub_counters *cnt)
{
    res->s = m->hi;
    float it[UB_LANES];
    v_store(it, m->iter_sum);
    for (int l = 0; l < UB_LANES; l++)
        cnt->iterations += (uint64_t)it[l];
}

static inline ub_march_step march_step_of(const ub_object *o)
{
    return (ub_march_step){v_set1((float)o->sigma_min), v_set1((float)o->step_factor), v_set1((float)o->max_step)};
}

/* March one object's rays by unbounding spheres (section 3), march_advance's steps, then
 * bisection of the hits (refine_hits). Only the lanes still marching are evaluated. */
static inline __attribute__((always_inline)) void march_rays(const ub_scene *sc, const ub_object *o,
        const ub_de_params *dp, const ub_object_rays *r, vf t_base, int lanes, int refine_hits, const int relax,
        const int julia, ub_march_result *res, vf *steps, vf *penumbra, vf tan_angle, ub_counters *cnt)
{
    const ub_march_step c = march_step_of(o);
    ub_march_state m;
    march_begin(r, t_base, lanes, relax, &m, res);
    for (int step = 0; step < o->max_steps && m_bits(m.active); step++) {
        if (cancelled(sc))
            return;
        vf z[4], new_dist, new_iters;
        march_point(&m, m.s, z);
        march_de(dp, julia, m.active, z[0], z[1], z[2], z[3], &new_dist, &new_iters);
        march_advance(dp, &c, relax, new_dist, new_iters, steps, penumbra, tan_angle, &m);
    }
    march_found(refine_hits, &m, res);
    for (int k = 0; k < o->bisection_steps && !cancelled(sc); k++) {
        if (!bisect_wanted(dp, &m))
            break;
        vf z[4], dist, iters, mid = bisect_mid(&m);
        march_point(&m, mid, z);
        march_de(dp, julia, m.refine, z[0], z[1], z[2], z[3], &dist, &iters);
        bisect_take(dp, &c, mid, dist, iters, &m, res);
    }
    march_end(&m, res, cnt);
}

/* march_rays with `relax` known when compiled, so that the plain march carries none of the
 * over-relaxation's bookkeeping. Over-relaxed: hard shadow rays (they only ask whether something
 * is hit: refine_hits = 0, no penumbra) through the kinds whose estimate is a proven bound
 * (o->exact; the empirical ones keep their step_factor's margin). Camera and reflection rays march
 * plainly: a hit there is also where the surface is drawn, and a relaxed step can pass within a
 * threshold of the set without stopping (the certificate covers the set, not its eps-shell),
 * which moved silhouette pixels and made a deep zoom's pixels pop where its path switches. Soft
 * shadows too: their penumbra is the least clearance over the samples, which fewer samples would
 * lighten. */
static void march(const ub_scene *sc, const ub_object *o, const ub_de_params *dp, const ub_object_rays *r,
                  vf t_base, int lanes, int refine_hits, ub_march_result *res, vf *steps, vf *penumbra,
                  vf tan_angle, ub_counters *cnt)
{
    const int relax = o->exact && !refine_hits && !penumbra;
    if (UB_INLINE_JULIA_MARCH && julia_only(dp)) {
        if (relax)
            march_rays(sc, o, dp, r, t_base, lanes, refine_hits, 1, 1, res, steps, penumbra, tan_angle, cnt);
        else
            march_rays(sc, o, dp, r, t_base, lanes, refine_hits, 0, 1, res, steps, penumbra, tan_angle, cnt);
    } else if (relax) {
        march_rays(sc, o, dp, r, t_base, lanes, refine_hits, 1, 0, res, steps, penumbra, tan_angle, cnt);
    } else {
        march_rays(sc, o, dp, r, t_base, lanes, refine_hits, 0, 0, res, steps, penumbra, tan_angle, cnt);
    }
}

/* Two packets of rays against one Julia set at once (issue 21): march_rays for each (camera rays:
 * plain steps, refined hits; hard shadow rays: any hit, over-relaxed steps as march() takes them;
 * no penumbra), through the same steps (march_advance, bisect_take), in one loop whose estimates
 * are de_julia_pair's, so that one packet's iteration and step fill the vector ports while the
 * other's wait on their loop-carried paths (a single packet's march is a chain of dependent
 * operations: the iteration, the logarithm, the step, the next point). Each lane's operations are
 * march_rays', in the same order, so each ray has the same bits and counts. A packet with no lane
 * left marching rides along at no cost: the other one takes de_julia's single estimate. */
static inline __attribute__((always_inline)) void julia_estimates(const ub_de_params *dp, const vm lanes[2],
                                                                  const vf z[2][4], vf dist[2], vf iters[2])
{
    const int busy0 = m_bits(lanes[0]) != 0, busy1 = m_bits(lanes[1]) != 0;
    if (busy0 && busy1) {
        de_julia_pair_body(dp, lanes, z[0], z[1], dist, iters);
    } else {
        /* Out of line (de_julia), not inlined as the pair's loop is: this copy of the loop in each
         * of the pairs' steps made the compiler spill more of the march's state in the pair's
         * own path (issue 21: peer scene 1.028x with AVX-512, "everything" 1.019x, "world"
         * 1.036x; AVX2 the same; same bits). */
        const int k = busy1;
        de_julia(dp, lanes[k], z[k][0], z[k][1], z[k][2], z[k][3], &dist[k], &iters[k]);
    }
}

/* One step of a pair of packets (march_julia_pair_body): the estimates at both packets' points in
 * one loop, then each packet's step. Returns whether a lane of the pair still marches. */
static inline __attribute__((always_inline)) int pair_step(const ub_de_params *dp, const ub_march_step *c,
        const int relax, ub_march_state *m0, ub_march_state *m1, vf *const steps[2])
{
    ub_march_state *const m[2] = {m0, m1};
    vf z[2][4], new_dist[2], new_iters[2];
    const vm active[2] = {m0->active, m1->active};
    for (int k = 0; k < 2; k++)
        march_point(m[k], m[k]->s, z[k]);
    julia_estimates(dp, active, z, new_dist, new_iters);
    for (int k = 0; k < 2; k++)
        march_advance(dp, c, relax, new_dist[k], new_iters[k], steps[k], NULL, v_set1(0.0f), m[k]);
    return m_either(m0->active, m1->active);
}

/* One bisection step of a pair's hits; returns 0, and takes none, once neither packet wants one. */
static inline __attribute__((always_inline)) int pair_bisect(const ub_de_params *dp, const ub_march_step *c,
        ub_march_state *m0, ub_march_state *m1, ub_march_result res[2])
{
    const int wanted0 = bisect_wanted(dp, m0), wanted1 = bisect_wanted(dp, m1);
    if (!wanted0 && !wanted1)
        return 0;
    ub_march_state *const m[2] = {m0, m1};
    vf z[2][4], mid[2], dist[2], iters[2];
    const vm refine[2] = {m0->refine, m1->refine};
    for (int k = 0; k < 2; k++) {
        mid[k] = bisect_mid(m[k]);
        march_point(m[k], mid[k], z[k]);
    }
    julia_estimates(dp, refine, z, dist, iters);
    for (int k = 0; k < 2; k++)
        bisect_take(dp, c, mid[k], dist[k], iters[k], m[k], &res[k]);
    return 1;
}

static inline __attribute__((always_inline)) void march_julia_pair_body(const ub_scene *sc, const ub_object *o,
        const ub_de_params *dp, const ub_object_rays *const r[2], const vf t_base[2], const int lanes[2],
        const int relax, const int refine_hits, ub_march_result res[2], vf *const steps[2], ub_counters *cnt)
{
    const ub_march_step c = march_step_of(o);
    /* Two locals, not an array of two: the compiler keeps each one's fields in registers. */
    ub_march_state m0, m1;
    ub_march_state *const m[2] = {&m0, &m1};
    for (int k = 0; k < 2; k++)
        march_begin(r[k], t_base[k], lanes[k], relax, m[k], &res[k]);
    int marching = m_either(m0.active, m1.active);
    for (int step = 0; step < o->max_steps && marching; step++) {
        if (cancelled(sc))
            return;
        marching = pair_step(dp, &c, relax, &m0, &m1, steps);
    }
    for (int k = 0; k < 2; k++)
        march_found(refine_hits, m[k], &res[k]);
    for (int b = 0; b < o->bisection_steps && !cancelled(sc); b++)
        if (!pair_bisect(dp, &c, &m0, &m1, res))
            break;
    for (int k = 0; k < 2; k++)
        march_end(m[k], &res[k], cnt);
}

/* Two pairs of packets (four blocks of camera rays) through march_julia_pair_body's steps, a step
 * of one pair, then a step of the other (issue 21). A pair's step ends in a chain of dependent
 * operations (after its loop: the logarithm, the division and the root of the estimate, the step,
 * the next point), about as long as the loop itself, which its next loop must wait for. The other
 * pair's loop does not: coming next in the program, it runs while that chain does, instead of
 * after it. Each pair takes march_julia_pair_body's steps and bisection steps in its order, so
 * each ray has the same bits and counts. */
static inline __attribute__((always_inline)) void march_julia_two_pairs_body(const ub_scene *sc,
        const ub_object *o, const ub_de_params *dp, const ub_object_rays *const r[4], const vf t_base[4],
        const int lanes[4], const int relax, const int refine_hits, ub_march_result res[4], vf *const steps[4],
        ub_counters *cnt)
{
    const ub_march_step c = march_step_of(o);
    ub_march_state a0, a1, b0, b1;
    ub_march_state *const m[4] = {&a0, &a1, &b0, &b1};
    for (int k = 0; k < 4; k++)
        march_begin(r[k], t_base[k], lanes[k], relax, m[k], &res[k]);
    int marching_a = m_either(a0.active, a1.active), marching_b = m_either(b0.active, b1.active);
    for (int step_a = 0, step_b = 0;;) {
        marching_a &= step_a < o->max_steps;
        marching_b &= step_b < o->max_steps;
        if (!marching_a && !marching_b)
            break;
        if (cancelled(sc))
            return;
        if (marching_a) {
            marching_a = pair_step(dp, &c, relax, &a0, &a1, steps);
            step_a++;
        }
        if (marching_b) {
            marching_b = pair_step(dp, &c, relax, &b0, &b1, steps + 2);
            step_b++;
        }
    }
    for (int k = 0; k < 4; k++)
        march_found(refine_hits, m[k], &res[k]);
    int refining_a = 1, refining_b = 1;
    for (int b = 0; b < o->bisection_steps && (refining_a || refining_b) && !cancelled(sc); b++) {
        if (refining_a)
            refining_a = pair_bisect(dp, &c, &a0, &a1, res);
        if (refining_b)
            refining_b = pair_bisect(dp, &c, &b0, &b1, res + 2);
    }
    for (int k = 0; k < 4; k++)
        march_end(m[k], &res[k], cnt);
}

/* march_julia_pair_body (pairs = 1) or march_julia_two_pairs_body (pairs = 2) for camera rays
 * (plain steps, refined hits) or hard shadow rays (any hit; over-relaxed steps through an exact
 * estimate, as march() takes them). */
static inline __attribute__((always_inline)) void march_julia_pairs_kind(const ub_scene *sc, const ub_object *o,
        const ub_de_params *dp, const ub_object_rays *const *r, const vf *t_base, const int *lanes, const int pairs,
        const int relax, const int refine_hits, ub_march_result *res, vf *const *steps, ub_counters *cnt)
{
    if (pairs == 2)
        march_julia_two_pairs_body(sc, o, dp, r, t_base, lanes, relax, refine_hits, res, steps, cnt);
    else
        march_julia_pair_body(sc, o, dp, r, t_base, lanes, relax, refine_hits, res, steps, cnt);
}

static inline __attribute__((always_inline)) void march_julia_pairs(const ub_scene *sc, const ub_object *o,
        const ub_de_params *dp, const ub_object_rays *const *r, const vf *t_base, const int *lanes, const int pairs,
        int any_hit, ub_march_result *res, vf *const *steps, ub_counters *cnt)
{
    if (!any_hit)
        march_julia_pairs_kind(sc, o, dp, r, t_base, lanes, pairs, 0, 1, res, steps, cnt);
    else if (o->exact)
        march_julia_pairs_kind(sc, o, dp, r, t_base, lanes, pairs, 1, 0, res, steps, cnt);
    else
        march_julia_pairs_kind(sc, o, dp, r, t_base, lanes, pairs, 0, 0, res, steps, cnt);
}

static void march_julia_pair(const ub_scene *sc, const ub_object *o, const ub_de_params *dp,
                             const ub_object_rays *const r[2], const vf t_base[2], const int lanes[2], int any_hit,
                             ub_march_result res[2], vf *const steps[2], ub_counters *cnt)
{
    march_julia_pairs(sc, o, dp, r, t_base, lanes, 1, any_hit, res, steps, cnt);
}

static void march_julia_two_pairs(const ub_scene *sc, const ub_object *o, const ub_de_params *dp,
                                  const ub_object_rays *const r[4], const vf t_base[4], const int lanes[4],
                                  int any_hit, ub_march_result res[4], vf *const steps[4], ub_counters *cnt)
{
    march_julia_pairs(sc, o, dp, r, t_base, lanes, 2, any_hit, res, steps, cnt);
}

/* What a packet of rays hit. */
typedef struct {
    float t[UB_LANES], iters[UB_LANES], dist[UB_LANES], steps[UB_LANES];
    float penumbra[UB_LANES]; /* shadow rays: visibility estimate of an unblocked ray, in [0, 1] */
    int object[UB_LANES];     /* index, UB_HIT_NONE or UB_HIT_SEA */
    /* An object's march ran out of max_steps in front of what the ray shows: the ray may have
     * missed a surface there (UB_PASS_MAX_STEPS, stats["out_of_steps"]). */
    int out_of_steps[UB_LANES];
} ub_trace_result;

/* Distance along each ray to the sea plane z = height (world), or +inf. */
static inline double sea_t(const ub_shading *sh, const double o[3], const double d[3])
{
    if (!sh->sea || d[2] == 0.0)
        return HUGE_VAL;
    double t = (sh->sea_height - o[2]) / d[2];
    return t > 0.0 ? t : HUGE_VAL;
}

/* What trace() looks for, as bits of its `flags` word. */
enum {
    UB_TRACE_SEA = 1 << 0,     /* the sea plane is in the scene as well as the fractal objects */
    UB_TRACE_ANY_HIT = 1 << 1, /* shadow rays: stop at the first hit found, not the nearest */
};

/* A packet's trace through the objects so far: the nearest hit of each lane, where marches gave up,
 * the steps and the penumbra, and the lanes still looking (trace below). */
typedef struct {
    float best_t[UB_LANES], gave_up_t[UB_LANES];
    vf steps, pen;
    int open;
} ub_trace_state;

/* trace's start: no hit yet but the sea's (UB_TRACE_SEA). */
static void trace_begin(const ub_scene *sc, const ub_packet_rays *pr, int lanes, unsigned flags,
                        ub_trace_result *out, ub_trace_state *ts)
{
    const int sea = (flags & UB_TRACE_SEA) != 0;
    /* Apart from the sea's loop: with its branch in the same loop, clang kept this one scalar
     * (issue 21: 0.9 % of the release build's peer render). */
    for (int l = 0; l < UB_LANES; l++) {
        ts->gave_up_t[l] = INFINITY;
        out->object[l] = UB_HIT_NONE;
        out->iters[l] = out->dist[l] = 0.0f;
        out->penumbra[l] = 1.0f;
        ts->best_t[l] = (float)pr->t_max[l];
    }
    for (int l = 0; l < UB_LANES && sea; l++) {
        if (!((lanes >> l) & 1))
            continue;
        double o[3] = {pr->origin[0][l], pr->origin[1][l], pr->origin[2][l]};
        double d[3] = {pr->dir[0][l], pr->dir[1][l], pr->dir[2][l]};
        double ts_ = sea_t(sc->shading, o, d);
        if (ts_ >= pr->t_min[l] && ts_ <= pr->t_max[l]) {
            ts->best_t[l] = (float)ts_;
            out->object[l] = UB_HIT_SEA;
        }
    }
    ts->steps = v_set1(0.0f);
    ts->pen = v_set1(1.0f);
    ts->open = lanes;
}

/* Object k's march (res, over the lanes `active` of orays) into the nearest hits so far. */
static void trace_take(int k, const ub_object_rays *orays, int active, const ub_march_result *res, int any_hit,
                       ub_trace_result *out, ub_trace_state *ts)
{
    int hits = m_bits(res->hit) & active, gave_up = m_bits(res->out_of_steps) & active;
    float s[UB_LANES], it[UB_LANES], di[UB_LANES];
    v_store(s, res->s);
    for (int l = 0; l < UB_LANES; l++)
        if ((gave_up >> l) & 1)
            ts->gave_up_t[l] = fminf(ts->gave_up_t[l], orays->t_enter[l] + s[l]);
    if (!hits)
        return;
    v_store(it, res->iters);
    v_store(di, res->dist);
    for (int l = 0; l < UB_LANES; l++) {
        if (!((hits >> l) & 1))
            continue;
        float t = orays->t_enter[l] + s[l];
        if (!(t < ts->best_t[l] || out->object[l] == UB_HIT_NONE))
            continue;
        ts->best_t[l] = t;
        out->object[l] = k;
        out->iters[l] = it[l];
        out->dist[l] = di[l];
        if (any_hit)
            ts->open &= ~(1 << l);
    }
}

/* trace's end: the nearest hits, steps, penumbra and whether a march gave up in front of them. */
static void trace_end(const ub_trace_state *ts, ub_trace_result *out)
{
    v_store(out->steps, ts->steps);
    float pb[UB_LANES];
    v_store(pb, ts->pen);
    for (int l = 0; l < UB_LANES; l++) {
        /* A hit nearer than where a march gave up shows what it would have shown anyway. */
        out->out_of_steps[l] = out->object[l] == UB_HIT_NONE ? ts->gave_up_t[l] < INFINITY
                                                             : ts->gave_up_t[l] < ts->best_t[l];
        out->t[l] = ts->best_t[l];
        float p = pb[l] < 0.0f ? 0.0f : (pb[l] > 1.0f ? 1.0f : pb[l]);
        out->penumbra[l] = out->object[l] == UB_HIT_NONE ? p : 0.0f;
    }
}

/* Trace a packet through the union of the scene's fractal objects (and the sea with
 * UB_TRACE_SEA): the nearest hit wins, and each object's march stops at the nearest hit found
 * so far. Shadow rays pass UB_TRACE_ANY_HIT and `tan_angle` (NULL: hard). */
static void trace(const ub_scene *sc, const ub_de_params *dps, const ub_packet_rays *pr, int lanes,
                  unsigned flags, const float *tan_angle, ub_trace_result *out, ub_counters *cnt)
{
    const int any_hit = (flags & UB_TRACE_ANY_HIT) != 0;
    ub_trace_state ts;
    trace_begin(sc, pr, lanes, flags, out, &ts);
    vf tanv = tan_angle ? v_load(tan_angle) : v_set1(0.0f);
    vf tb = v_load(pr->t_base);
    for (int k = 0; k < sc->object_count && ts.open; k++) {
        const ub_object *o = &sc->objects[k];
        ub_object_rays orays;
        int active = object_rays(o, pr, ts.best_t, ts.open, &orays);
        if (!active)
            continue;
        ub_march_result res;
        march(sc, o, &dps[k], &orays, tb, active, !any_hit, &res, &ts.steps, tan_angle ? &ts.pen : NULL, tanv, cnt);
        trace_take(k, &orays, active, &res, any_hit, out, &ts);
    }
    trace_end(&ts, out);
}

/* Whether trace_pair gains over two traces: the kernel inlines the Julia set's march and every
 * object is a Julia set on no deep-zoom path. */
static int pair_traceable(const ub_scene *sc, const ub_de_params *dps)
{
    if (!UB_INLINE_JULIA_MARCH)
        return 0;
    for (int k = 0; k < sc->object_count; k++)
        if (!julia_only(&dps[k]))
            return 0;
    return 1;
}

/* One Julia set's march of the packets j, j + 1 of a trace_packets group: together where both have
 * rays to march there, else each alone. */
static void march_pair_or_each(const ub_scene *sc, const ub_object *o, const ub_de_params *dp,
                               const ub_object_rays orays[2], const int active[2], const vf tb[2], int any_hit,
                               ub_march_result res[2], ub_trace_state ts[2], ub_counters *cnt)
{
    if (active[0] && active[1] && julia_only(dp)) {
        const ub_object_rays *const both[2] = {&orays[0], &orays[1]};
        vf *const steps[2] = {&ts[0].steps, &ts[1].steps};
        march_julia_pair(sc, o, dp, both, tb, active, any_hit, res, steps, cnt);
        return;
    }
    for (int j = 0; j < 2; j++)
        if (active[j])
            march(sc, o, dp, &orays[j], tb[j], active[j], !any_hit, &res[j], &ts[j].steps, NULL, v_set1(0.0f), cnt);
}

/* trace() of n = 2 or 4 packets at once, camera rays or hard shadow rays (UB_TRACE_ANY_HIT, no
 * penumbra): each Julia set's march takes two packets' rays together (march_julia_pair), and four
 * as two interleaved pairs (march_julia_two_pairs) where all four have rays to march there. The
 * same hits and counts as n trace() calls. */
static inline __attribute__((always_inline)) void trace_packets(const ub_scene *sc, const ub_de_params *dps,
        const ub_packet_rays *const *pr, const int n, const int *lanes, unsigned flags, ub_trace_result *const *out,
        ub_counters *cnt)
{
    const int any_hit = (flags & UB_TRACE_ANY_HIT) != 0;
    ub_trace_state ts[4];
    vf tb[4];
    int open = 0;
    for (int j = 0; j < n; j++) {
        trace_begin(sc, pr[j], lanes[j], flags, out[j], &ts[j]);
        tb[j] = v_load(pr[j]->t_base);
        open |= ts[j].open;
    }
    for (int k = 0; k < sc->object_count && open; k++) {
        const ub_object *o = &sc->objects[k];
        ub_object_rays orays[4];
        int active[4], all = 1;
        ub_march_result res[4];
        for (int j = 0; j < n; j++) {
            active[j] = ts[j].open ? object_rays(o, pr[j], ts[j].best_t, ts[j].open, &orays[j]) : 0;
            all &= active[j] != 0;
        }
        if (n == 4 && all && julia_only(&dps[k])) {
            const ub_object_rays *const each[4] = {&orays[0], &orays[1], &orays[2], &orays[3]};
            vf *const steps[4] = {&ts[0].steps, &ts[1].steps, &ts[2].steps, &ts[3].steps};
            march_julia_two_pairs(sc, o, &dps[k], each, tb, active, any_hit, res, steps, cnt);
        } else {
            for (int j = 0; j < n; j += 2)
                march_pair_or_each(sc, o, &dps[k], &orays[j], &active[j], &tb[j], any_hit, &res[j], &ts[j], cnt);
        }
        open = 0;
        for (int j = 0; j < n; j++) {
            if (active[j])
                trace_take(k, &orays[j], active[j], &res[j], any_hit, out[j], &ts[j]);
            open |= ts[j].open;
        }
    }
    for (int j = 0; j < n; j++)
        trace_end(&ts[j], out[j]);
}

/* trace() of two packets at once (trace_packets). */
static void trace_pair(const ub_scene *sc, const ub_de_params *dps, const ub_packet_rays *const pr[2],
                       const int lanes[2], unsigned flags, ub_trace_result *const out[2], ub_counters *cnt)
{
    trace_packets(sc, dps, pr, 2, lanes, flags, out, cnt);
}

/* trace() of four packets at once, as two interleaved pairs (trace_packets). */
static void trace_two_pairs(const ub_scene *sc, const ub_de_params *dps, const ub_packet_rays *const pr[4],
                            const int lanes[4], unsigned flags, ub_trace_result *const out[4], ub_counters *cnt)
{
    trace_packets(sc, dps, pr, 4, lanes, flags, out, cnt);
}
