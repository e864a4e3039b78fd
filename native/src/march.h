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
            oo[i] = vd_add(vd_add(vd_add(vd_mul(vd_set1(w[i][0]), ro[0]), vd_mul(vd_set1(w[i][1]), ro[1])),
                                  vd_mul(vd_set1(w[i][2]), ro[2])),
                           vd_set1(w[i][3]));
            od[i] = vd_add(vd_add(vd_mul(vd_set1(w[i][0]), rd[0]), vd_mul(vd_set1(w[i][1]), rd[1])),
                           vd_mul(vd_set1(w[i][2]), rd[2]));
            rel[i] = vd_sub(oo[i], vd_set1(center[i]));
        }
        /* |oo + t od - c|^2 = R^2 */
        const vd qa = vd_add(vd_add(vd_mul(od[0], od[0]), vd_mul(od[1], od[1])), vd_mul(od[2], od[2]));
        const vd qb = vd_add(vd_add(vd_mul(rel[0], od[0]), vd_mul(rel[1], od[1])), vd_mul(rel[2], od[2]));
        const vd qc = vd_sub(vd_add(vd_add(vd_mul(rel[0], rel[0]), vd_mul(rel[1], rel[1])), vd_mul(rel[2], rel[2])),
                             vd_set1(radius2));
        const vd disc = vd_sub(vd_mul(qb, qb), vd_mul(qa, qc)), sq = vd_sqrt(disc), neg_b = vd_mul(qb, minus_one);
        const vd near = vd_div(vd_sub(neg_b, sq), qa), far = vd_div(vd_add(neg_b, sq), qa);
        const vd t_min = vd_load(r->t_min + h), t_lim = vd_load(limit + h);
        const vdm crosses = vdm_and(vdm_from_bits((lanes_in >> h) & ((1 << VD_LANES) - 1)), vd_ge(disc, zero));
        vd t0 = vd_select(crosses, vd_select(vd_gt(near, t_min), near, t_min), zero);
        vd t1 = vd_select(crosses, vd_select(vd_lt(far, t_lim), far, t_lim), minus_one);
        const vdm touches = vd_ge(t1, t0);
        lanes |= vdm_bits(touches) << h;
        t0 = vd_select(touches, t0, t_min);
        t1 = vd_select(touches, t1, t0);
        vd pe[3];
        for (int i = 0; i < 3; i++)
            pe[i] = vd_add(oo[i], vd_mul(t0, od[i]));
        for (int c = 0; c < 4; c++) {
            const vd b0 = vd_set1(b[c][0]), b1 = vd_set1(b[c][1]), b2 = vd_set1(b[c][2]);
            vd_store(q_enter[c] + h, vd_add(vd_add(vd_add(vd_set1(origin_q[c]), vd_mul(b0, pe[0])), vd_mul(b1, pe[1])),
                                            vd_mul(b2, pe[2])));
            vd_store(q_dir[c] + h, vd_add(vd_add(vd_mul(b0, od[0]), vd_mul(b1, od[1])), vd_mul(b2, od[2])));
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

/* March one object's rays by unbounding spheres (section 3): step by the distance estimate
 * (times step_factor, at most max_step), a hit when it drops below the threshold. Section 3.3's
 * thin sets come for free: the threshold is the minimum increment, so a dendrite thinner than
 * it still stops the ray. With `penumbra` (shadow rays), also tracks min d / (t tan(angle)):
 * how nearly the ray missed, relative to the light's apparent size (soft shadows). */
static inline __attribute__((always_inline)) void march_rays(const ub_scene *sc, const ub_object *o,
        const ub_de_params *dp, const ub_object_rays *r, vf t_base, int lanes, int refine_hits, const int relax,
        const int julia, ub_march_result *res, vf *steps, vf *penumbra, vf tan_angle, ub_counters *cnt)
{
    vf q0[4], qd[4];
    for (int k = 0; k < 4; k++) {
        q0[k] = v_load(r->q_enter[k]);
        qd[k] = v_load(r->q_dir[k]);
    }
    const vf te = v_load(r->t_enter), s_max = v_load(r->s_max);
    const vf tb = v_add(te, t_base);
    const vf sigma = v_set1((float)o->sigma_min);
    const vf factor = v_set1((float)o->step_factor);
    const vf max_step = v_set1((float)o->max_step);
    /* A lane's s and prev freeze when it stops (hit or out of the ball): after the loop they are
     * the hit and the last sample before it, without per-step bookkeeping. */
    vf s = v_set1(0.0f), prev = s, iter_sum = s, dist = s, iters = s, dw = s;
    vm active = m_from_bits(lanes), hit = m_false();
    /* Over-relaxed steps (`relax`, issue 21; Keinert et al. 2014, enhanced sphere tracing): a lane
     * steps UB_OVER_RELAXATION times the plain step while the unbounding spheres at consecutive
     * samples overlap, (s - prev) <= dw(prev) + dw(s): their union then holds the whole segment, so
     * no point of the set lies between the two samples (section 3's certificate, from two balls
     * instead of one). Where they do not overlap, the lane goes back to prev, discards the sample
     * at s, and takes plain steps from there on. */
    vf omega = v_set1(relax ? UB_OVER_RELAXATION : 1.0f);
    vf prev_dw = s, prev_dist = s, prev_iters = s, last_step = s;
    vm relaxed_last = m_false(); /* lanes whose last step was over-relaxed: their sample is checked */
    /* A cancelled march returns no hits (its caller still reads the result). */
    res->hit = res->out_of_steps = hit;
    res->s = res->iters = res->dist = s;
    for (int step = 0; step < o->max_steps && m_bits(active); step++) {
        if (cancelled(sc))
            return;
        /* Only the lanes still marching are evaluated; a stopped lane keeps its last estimate and
         * escape count (those at its frozen s, where the hit lanes stopped). */
        vf new_dist, new_iters;
        march_de(dp, julia, active, v_fma(s, qd[0], q0[0]), v_fma(s, qd[1], q0[1]), v_fma(s, qd[2], q0[2]),
                 v_fma(s, qd[3], q0[3]), &new_dist, &new_iters);
        dist = v_select(active, new_dist, dist);
        iters = v_select(active, new_iters, iters);
        dw = v_mul(dist, sigma);
        vf eps = threshold(dp, v_add(tb, s));
        if (relax) {
            vm gap = m_and(relaxed_last, v_gt(last_step, v_add(prev_dw, dw)));
            if (m_bits(gap)) { /* back to prev and its estimate; plain steps from there on */
                s = v_select(gap, prev, s);
                dist = v_select(gap, prev_dist, dist);
                iters = v_select(gap, prev_iters, iters);
                dw = v_select(gap, prev_dw, dw);
                eps = threshold(dp, v_add(tb, s));
                omega = v_select(gap, v_set1(1.0f), omega);
            }
        }
        *steps = v_count(*steps, active);
        iter_sum = v_add(iter_sum, v_select(active, iters, v_set1(0.0f)));
        vm is_hit = m_and(active, v_lt(dw, eps));
        /* Issue 18: a step moves s by at least its resolution wherever the estimate allows it
         * (a step_factor or max_step below the resolution would stall the ray otherwise), never
         * by more than the estimate, so it never passes the set. Where the estimate itself is so
         * small that s + step rounds back to s (a fixed epsilon of 1e-7 a few units into the
         * ball), the ray can get no closer in float32: the estimate is below half an ulp of s
         * (a step of at least min(d, resolution) did not move it), s is the closest point float32
         * represents, and that is the hit (at the resolution limit), not a ray that stalls until
         * it runs out of steps and shows the background where the set is. Rays that still move
         * march on exactly as before. */
        vf factored = v_mul(dw, factor), least = v_min(dw, resolution(s));
        vf step_len = v_max(v_min(factored, max_step), least);
        vm relaxing = m_false();
        if (relax) {
            /* A relaxed step past s_max (out of the ball, or past the light) would end where no
             * sample checks it: only the sphere at s would certify it, which a relaxed step
             * outruns. Such a step is taken plainly. */
            vf longer = v_max(v_min(v_mul(factored, omega), max_step), least);
            relaxing = m_and(v_gt(omega, v_set1(1.0f)), v_le(v_add(s, longer), s_max));
            step_len = v_select(relaxing, longer, step_len);
        }
        vf next = v_add(s, step_len);
        is_hit = m_or(is_hit, m_and(active, v_le(next, s)));
        if (penumbra) {
            /* NaN (0/0 for a point source at the origin) leaves the minimum unchanged. */
            vf ratio = v_div(v_sub(dw, eps), v_mul(tan_angle, v_add(te, s)));
            *penumbra = v_select(active, v_min(ratio, *penumbra), *penumbra);
        }
        hit = m_or(hit, is_hit);
        active = m_andnot(is_hit, active);
        if (relax) {
            prev_dw = v_select(active, dw, prev_dw);
            prev_dist = v_select(active, dist, prev_dist);
            prev_iters = v_select(active, iters, prev_iters);
            last_step = v_select(active, v_sub(next, s), last_step);
            relaxed_last = m_and(active, relaxing);
        }
        prev = v_select(active, s, prev);
        s = v_select(active, next, s);
        active = m_and(active, v_le(s, s_max));
    }
    /* dist and iters are every lane's last evaluation, at its frozen s: a hit lane's estimate and
     * escape count. */
    res->hit = hit;
    /* A cancel returns above, so lanes still active here ran out of steps (where s froze). */
    res->out_of_steps = active;
    res->iters = iters;
    res->dist = dw;
    /* Optional refinement: bisect between the last sample outside the threshold and the hit.
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
    vm refine = refine_hits ? hit : m_false();
    vf lo = prev, hi = s;
    const vf fraction = v_set1(1.0f / 32.0f);
    for (int k = 0; k < o->bisection_steps && !cancelled(sc); k++) {
        vf width_limit = v_max(v_mul(threshold(dp, v_add(tb, hi)), fraction), resolution(hi));
        refine = m_and(refine, v_gt(v_sub(hi, lo), width_limit));
        if (!m_bits(refine))
            break;
        vf mid = v_mul(v_add(lo, hi), v_set1(0.5f));
        march_de(dp, julia, refine, v_fma(mid, qd[0], q0[0]), v_fma(mid, qd[1], q0[1]),
                 v_fma(mid, qd[2], q0[2]), v_fma(mid, qd[3], q0[3]), &dist, &iters);
        vf dw = v_mul(dist, sigma);
        vm inside = m_and(refine, v_lt(dw, threshold(dp, v_add(tb, mid))));
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

/* Two packets of camera rays against one Julia set at once (issue 21): march_rays with plain
 * steps and refined hits (relax 0, no penumbra, refine_hits 1) for each, in one loop whose
 * estimates are de_julia_pair's, so that one packet's iteration and step fill the vector ports
 * while the other's wait on their loop-carried paths (a single packet's march is a chain of
 * dependent operations: the iteration, the logarithm, the step, the next point). Each lane's
 * operations are march_rays', in the same order, so each ray has the same bits and counts. A
 * packet with no lane left marching rides along at no cost: the other one takes de_julia's
 * single estimate. A change to march_rays' plain step or bisection belongs here too: the
 * identity tests (tile widths that pair against ones that do not, the portable kernel against
 * the vector ones) fail otherwise. */
static inline __attribute__((always_inline)) void julia_estimates(const ub_de_params *dp, const vm lanes[2],
                                                                  const vf z[2][4], vf dist[2], vf iters[2])
{
    const int busy0 = m_bits(lanes[0]) != 0, busy1 = m_bits(lanes[1]) != 0;
    if (busy0 && busy1) {
        de_julia_pair_body(dp, lanes, z[0], z[1], dist, iters);
    } else {
        const int k = busy1;
        ub_de_extra unused;
        de_quaternion_inline(dp, lanes[k], z[k][0], z[k][1], z[k][2], z[k][3], &dist[k], &iters[k], &unused);
    }
}

static void march_julia_pair(const ub_scene *sc, const ub_object *o, const ub_de_params *dp,
                             const ub_object_rays *const r[2], const vf t_base[2], const int lanes[2], ub_march_result res[2],
                             vf *const steps[2], ub_counters *cnt)
{
    vf q0[2][4], qd[2][4], s_max[2], tb[2], s[2], prev[2], iter_sum[2], dist[2], iters[2], dw[2];
    vm active[2], hit[2];
    const vf sigma = v_set1((float)o->sigma_min);
    const vf factor = v_set1((float)o->step_factor);
    const vf max_step = v_set1((float)o->max_step);
    for (int k = 0; k < 2; k++) {
        for (int c = 0; c < 4; c++) {
            q0[k][c] = v_load(r[k]->q_enter[c]);
            qd[k][c] = v_load(r[k]->q_dir[c]);
        }
        s_max[k] = v_load(r[k]->s_max);
        tb[k] = v_add(v_load(r[k]->t_enter), t_base[k]);
        s[k] = prev[k] = iter_sum[k] = dist[k] = iters[k] = dw[k] = v_set1(0.0f);
        active[k] = m_from_bits(lanes[k]);
        hit[k] = m_false();
        res[k].hit = res[k].out_of_steps = m_false();
        res[k].s = res[k].iters = res[k].dist = v_set1(0.0f);
    }
    for (int step = 0; step < o->max_steps && m_bits(m_or(active[0], active[1])); step++) {
        if (cancelled(sc))
            return;
        vf z[2][4], new_dist[2], new_iters[2];
        for (int k = 0; k < 2; k++)
            for (int c = 0; c < 4; c++)
                z[k][c] = v_fma(s[k], qd[k][c], q0[k][c]);
        julia_estimates(dp, active, z, new_dist, new_iters);
        for (int k = 0; k < 2; k++) {
            dist[k] = v_select(active[k], new_dist[k], dist[k]);
            iters[k] = v_select(active[k], new_iters[k], iters[k]);
            dw[k] = v_mul(dist[k], sigma);
            vf eps = threshold(dp, v_add(tb[k], s[k]));
            *steps[k] = v_count(*steps[k], active[k]);
            iter_sum[k] = v_add(iter_sum[k], v_select(active[k], iters[k], v_set1(0.0f)));
            vm is_hit = m_and(active[k], v_lt(dw[k], eps));
            vf factored = v_mul(dw[k], factor), least = v_min(dw[k], resolution(s[k]));
            vf next = v_add(s[k], v_max(v_min(factored, max_step), least));
            is_hit = m_or(is_hit, m_and(active[k], v_le(next, s[k])));
            hit[k] = m_or(hit[k], is_hit);
            active[k] = m_andnot(is_hit, active[k]);
            prev[k] = v_select(active[k], s[k], prev[k]);
            s[k] = v_select(active[k], next, s[k]);
            active[k] = m_and(active[k], v_le(s[k], s_max[k]));
        }
    }
    vm refine[2];
    vf lo[2], hi[2];
    for (int k = 0; k < 2; k++) {
        res[k].hit = hit[k];
        res[k].out_of_steps = active[k];
        res[k].iters = iters[k];
        res[k].dist = dw[k];
        refine[k] = hit[k];
        lo[k] = prev[k];
        hi[k] = s[k];
    }
    /* march_rays' bisection, both packets at once. */
    const vf fraction = v_set1(1.0f / 32.0f);
    for (int b = 0; b < o->bisection_steps && !cancelled(sc); b++) {
        vf z[2][4], mid[2], bdist[2], biters[2];
        for (int k = 0; k < 2; k++) {
            vf width_limit = v_max(v_mul(threshold(dp, v_add(tb[k], hi[k])), fraction), resolution(hi[k]));
            refine[k] = m_and(refine[k], v_gt(v_sub(hi[k], lo[k]), width_limit));
        }
        if (!m_bits(m_or(refine[0], refine[1])))
            break;
        for (int k = 0; k < 2; k++) {
            mid[k] = v_mul(v_add(lo[k], hi[k]), v_set1(0.5f));
            for (int c = 0; c < 4; c++)
                z[k][c] = v_fma(mid[k], qd[k][c], q0[k][c]);
        }
        julia_estimates(dp, refine, z, bdist, biters);
        for (int k = 0; k < 2; k++) {
            vf bdw = v_mul(bdist[k], sigma);
            vm inside = m_and(refine[k], v_lt(bdw, threshold(dp, v_add(tb[k], mid[k]))));
            vm outside = m_andnot(inside, refine[k]);
            iter_sum[k] = v_add(iter_sum[k], v_select(refine[k], biters[k], v_set1(0.0f)));
            hi[k] = v_select(inside, mid[k], hi[k]);
            lo[k] = v_select(outside, mid[k], lo[k]);
            res[k].iters = v_select(inside, biters[k], res[k].iters);
            res[k].dist = v_select(inside, bdw, res[k].dist);
        }
    }
    for (int k = 0; k < 2; k++) {
        res[k].s = hi[k];
        float it[UB_LANES];
        v_store(it, iter_sum[k]);
        for (int l = 0; l < UB_LANES; l++)
            cnt->iterations += (uint64_t)it[l];
    }
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
    for (int l = 0; l < UB_LANES; l++) {
        ts->gave_up_t[l] = INFINITY;
        out->object[l] = UB_HIT_NONE;
        out->iters[l] = out->dist[l] = 0.0f;
        out->penumbra[l] = 1.0f;
        ts->best_t[l] = (float)pr->t_max[l];
        if (sea && ((lanes >> l) & 1)) {
            double o[3] = {pr->origin[0][l], pr->origin[1][l], pr->origin[2][l]};
            double d[3] = {pr->dir[0][l], pr->dir[1][l], pr->dir[2][l]};
            double ts_ = sea_t(sc->shading, o, d);
            if (ts_ >= pr->t_min[l] && ts_ <= pr->t_max[l]) {
                ts->best_t[l] = (float)ts_;
                out->object[l] = UB_HIT_SEA;
            }
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

/* trace() of two packets of camera rays (no UB_TRACE_ANY_HIT, no penumbra) at once:
 * each Julia set's march takes both packets' rays together (march_julia_pair). The same hits and
 * counts as two trace() calls. */
static void trace_pair(const ub_scene *sc, const ub_de_params *dps, const ub_packet_rays pr[2], const int lanes[2],
                       unsigned flags, ub_trace_result out[2], ub_counters *cnt)
{
    ub_trace_state ts[2];
    vf tb[2];
    for (int j = 0; j < 2; j++) {
        trace_begin(sc, &pr[j], lanes[j], flags, &out[j], &ts[j]);
        tb[j] = v_load(pr[j].t_base);
    }
    for (int k = 0; k < sc->object_count && (ts[0].open || ts[1].open); k++) {
        const ub_object *o = &sc->objects[k];
        ub_object_rays orays[2];
        int active[2];
        ub_march_result res[2];
        for (int j = 0; j < 2; j++)
            active[j] = object_rays(o, &pr[j], ts[j].best_t, ts[j].open, &orays[j]);
        if (active[0] && active[1] && julia_only(&dps[k])) {
            const ub_object_rays *const both[2] = {&orays[0], &orays[1]};
            vf *const steps[2] = {&ts[0].steps, &ts[1].steps};
            march_julia_pair(sc, o, &dps[k], both, tb, active, res, steps, cnt);
        } else {
            for (int j = 0; j < 2; j++)
                if (active[j])
                    march(sc, o, &dps[k], &orays[j], tb[j], active[j], 1, &res[j], &ts[j].steps, NULL,
                          v_set1(0.0f), cnt);
        }
        for (int j = 0; j < 2; j++)
            if (active[j])
                trace_take(k, &orays[j], active[j], &res[j], 0, &out[j], &ts[j]);
    }
    for (int j = 0; j < 2; j++)
        trace_end(&ts[j], &out[j]);
}
