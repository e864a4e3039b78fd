/* Shading of section 4: normals, Lambertian lights with the paper's axle light, shadows,
 * ambient occlusion from the distance estimate, and the sea of Fig. 5. Included by kernel.h. */

/* World-space distance estimate of the union of the scene's objects at world points (those of
 * the lanes `lanes`; the others' are unspecified). */
static vf scene_distance(const ub_scene *sc, const ub_de_params *dps, vm lanes, const double p[3][UB_LANES])
{
    vf best = v_set1(HUGE_VALF);
    for (int k = 0; k < sc->object_count && !cancelled(sc); k++) {
        const ub_object *o = &sc->objects[k];
        if (o->bound_radius < 0.0)
            continue;
        vf q[4], d, it;
        quaternion_lanes(o, p, q);
        de(&dps[k], lanes, q[0], q[1], q[2], q[3], &d, &it);
        best = v_min(v_mul(d, v_set1((float)o->sigma_min)), best);
    }
    return best;
}

/* scene_distance at two sets of points p[0], p[1] at once, into d[0], d[1]: a Julia set's two
 * estimates in one loop (de_julia_pair, its bits de_julia's), whose iterations fill the vector ports
 * that one estimate's chain leaves idle (issue 21). The same values as two scene_distance calls. */
static void scene_distance_pair(const ub_scene *sc, const ub_de_params *dps, vm lanes,
                                const double p[2][3][UB_LANES], vf d[2])
{
    d[0] = d[1] = v_set1(HUGE_VALF);
    for (int k = 0; k < sc->object_count && !cancelled(sc); k++) {
        const ub_object *o = &sc->objects[k];
        if (o->bound_radius < 0.0)
            continue;
        vf q[2][4], dk[2], it[2];
        for (int j = 0; j < 2; j++)
            quaternion_lanes(o, p[j], q[j]);
        if (julia_only(&dps[k]))
            de_julia_pair(&dps[k], lanes, q[0], q[1], dk, it);
        else
            for (int j = 0; j < 2; j++)
                de(&dps[k], lanes, q[j][0], q[j][1], q[j][2], q[j][3], &dk[j], &it[j]);
        for (int j = 0; j < 2; j++)
            d[j] = v_min(v_mul(dk[j], v_set1((float)o->sigma_min)), d[j]);
    }
}

/* Ambient occlusion from the distance estimate: samples at h_i = i D / N along the normal. In
 * the open the estimate grows like the distance itself: near a quadratic Julia set's smooth
 * boundary d() is about half the true distance (exactly (1+h) log(1+h) / 2 >= h/2 off the unit
 * ball), so 2 d(p + h n) >= h there and the occlusion term max(0, 1 - 2 d / h) vanishes. In a
 * crease the estimate stays small and the term grows; nearer samples weigh more (2^-i). */
static void ambient_occlusion(const ub_scene *sc, const ub_de_params *dps, int lanes,
                                     const double p[3][UB_LANES], const float n[3][UB_LANES], float ao[UB_LANES])
{
    const ub_shading *sh = sc->shading;
    float occ[UB_LANES] = {0}, wsum = 0.0f;
    /* Two samples' estimates at a time (scene_distance_pair), added in order. */
    for (int i = 1; i <= sh->ao_samples && !cancelled(sc); i += 2) {
        const int both = i + 1 <= sh->ao_samples;
        double pts[2][3][UB_LANES], h[2];
        for (int j = 0; j < 1 + both; j++) {
            h[j] = sh->ao_distance * (i + j) / sh->ao_samples;
            for (int l = 0; l < UB_LANES; l++)
                for (int c = 0; c < 3; c++)
                    pts[j][c][l] = p[c][l] + h[j] * n[c][l];
        }
        float d[2][UB_LANES];
        if (both) {
            vf dv[2];
            scene_distance_pair(sc, dps, m_from_bits(lanes), pts, dv);
            v_store(d[0], dv[0]);
            v_store(d[1], dv[1]);
        } else {
            v_store(d[0], scene_distance(sc, dps, m_from_bits(lanes), pts[0]));
        }
        for (int j = 0; j < 1 + both; j++) {
            float w = ldexpf(1.0f, -(i + j)); /* exact: a power of two, no rounding on any libm */
            wsum += w;
            for (int l = 0; l < UB_LANES; l++) {
                float term = 1.0f - 2.0f * d[j][l] / (float)h[j];
                occ[l] += w * (term > 0.0f ? term : 0.0f);
            }
        }
    }
    for (int l = 0; l < UB_LANES; l++) {
        float a = 1.0f - sh->ao_strength * occ[l] / wsum;
        ao[l] = ((lanes >> l) & 1) ? (a < 0.0f ? 0.0f : (a > 1.0f ? 1.0f : a)) : 1.0f;
    }
}

/* The sea of Fig. 5: "waves are periodic functions of the distance estimate". The plane stays
 * flat; the wave height w = A sin(2 pi D / lambda), D the scene's distance estimate on the
 * plane, bends its normal: n = normalize(-dw/dx, -dw/dy, 1), by central differences. */
static void sea_normal(const ub_scene *sc, const ub_de_params *dps, const double p[3][UB_LANES],
                              float n[3][UB_LANES])
{
    const ub_shading *sh = sc->shading;
    double e = sh->sea_wavelength / 64.0;
    float w[4][UB_LANES];
    for (int s = 0; s < 4; s += 2) { /* the two sides of a difference at once */
        double pts[2][3][UB_LANES];
        for (int j = 0; j < 2; j++)
            for (int l = 0; l < UB_LANES; l++) {
                pts[j][0][l] = p[0][l] + (s + j == 0 ? e : (s + j == 1 ? -e : 0.0));
                pts[j][1][l] = p[1][l] + (s + j == 2 ? e : (s + j == 3 ? -e : 0.0));
                pts[j][2][l] = sh->sea_height;
            }
        vf d[2];
        scene_distance_pair(sc, dps, m_from_bits(UB_ALL_LANES), pts, d);
        v_store(w[s], d[0]);
        v_store(w[s + 1], d[1]);
    }
    for (int l = 0; l < UB_LANES; l++) {
        double k = 2.0 * M_PI / sh->sea_wavelength, a = sh->sea_amplitude;
        double dx = a * (ub_sin(k * w[0][l]) - ub_sin(k * w[1][l])) / (2.0 * e);
        double dy = a * (ub_sin(k * w[2][l]) - ub_sin(k * w[3][l])) / (2.0 * e);
        if (!isfinite(dx) || !isfinite(dy))
            dx = dy = 0.0; /* no object: a calm sea */
        double len = sqrt(dx * dx + dy * dy + 1.0);
        n[0][l] = (float)(-dx / len);
        n[1][l] = (float)(-dy / len);
        n[2][l] = (float)(1.0 / len);
    }
}

/* Direction to a light from p, its distance, the irradiance scale it sends (before the
 * surface's cosine) and the tangent of its apparent angular radius. Returns 0 if it sends
 * nothing to p. */
static int light_sample(const ub_light *L, const double p[3], double l[3], double *dist, double E[3],
                               double *tan_angle)
{
    if (L->type == UB_LIGHT_SUN) {
        for (int i = 0; i < 3; i++)
            l[i] = -L->direction[i];
        *dist = HUGE_VAL;
        for (int i = 0; i < 3; i++)
            E[i] = L->color[i];
        *tan_angle = L->radius;
        return 1;
    }
    double v[3] = {L->position[0] - p[0], L->position[1] - p[1], L->position[2] - p[2]};
    double r2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    if (!(r2 > 0.0))
        return 0;
    /* Soft falloff (Blender's default for point and spot lights since 4.1): Cycles lights the point
     * with a disk of the light's radius facing it, E = P cos / (4 pi (r^2 + radius^2)). */
    double r = sqrt(r2);
    double fall = 1.0 / (L->soft_falloff && L->type != UB_LIGHT_AREA ? r2 + L->radius * L->radius : r2);
    for (int i = 0; i < 3; i++)
        l[i] = v[i] / r;
    double cos_emit = -(l[0] * L->direction[0] + l[1] * L->direction[1] + l[2] * L->direction[2]);
    if (L->type == UB_LIGHT_SPOT) {
        double x = (cos_emit - L->spot_cos_outer) / fmax(L->spot_cos_inner - L->spot_cos_outer, 1e-12);
        if (L->spot_cos_inner <= L->spot_cos_outer) /* no blend: a sharp cone */
            x = cos_emit >= L->spot_cos_outer ? 1.0 : 0.0;
        x = x < 0.0 ? 0.0 : (x > 1.0 ? 1.0 : x);
        fall *= x * x * (3.0 - 2.0 * x);
    } else if (L->type == UB_LIGHT_AREA) {
        fall *= cos_emit > 0.0 ? cos_emit : 0.0; /* one-sided, cosine-weighted emitter */
    }
    if (!(fall > 0.0))
        return 0;
    *dist = r;
    for (int i = 0; i < 3; i++)
        E[i] = L->color[i] * fall;
    *tan_angle = L->radius / r;
    return 1;
}

/* A ramp of `size` >= 2 colours uniformly spaced over [0, 1] at value * scale + offset (clamped). */
static void ramp_lookup(const float (*ramp)[3], int size, float value, float scale, float offset, float out[3])
{
    float x = value * scale + offset;
    x = x < 0.0f ? 0.0f : (x > 1.0f ? 1.0f : x);
    float f = x * (float)(size - 1);
    int i = (int)f;
    if (i >= size - 1)
        i = size - 2;
    float w = f - (float)i;
    for (int c = 0; c < 3; c++)
        out[c] = ramp[i][c] * (1.0f - w) + ramp[i + 1][c] * w;
}

/* Colour of a fractal hit: the base colour, or the ramp at the orbit trap or iteration count. */
static void albedo(const ub_object *o, float trap, float iterations, float out[3])
{
    if (o->color_mode == UB_COLOR_BASE || o->ramp_size < 2) {
        for (int c = 0; c < 3; c++)
            out[c] = o->color[c];
        return;
    }
    float v = o->color_mode == UB_COLOR_ORBIT_TRAP ? trap : iterations / (float)o->max_iterations;
    ramp_lookup((const float (*)[3])o->ramp, o->ramp_size, v, o->ramp_scale, o->ramp_offset, out);
}

/* The fractal's quantities at a hit that a material can read (scene.h ub_attribute). */
typedef struct {
    float trap, iterations, distance;
    double p[3];   /* world position */
    float n[3];    /* world unit normal */
} ub_hit_attributes;

static float attribute_value(const ub_object *o, ub_attribute a, const ub_hit_attributes *h)
{
    switch (a) {
    case UB_ATTRIBUTE_ORBIT_TRAP:
        return h->trap;
    case UB_ATTRIBUTE_ITERATIONS:
        return h->iterations / (float)o->max_iterations;
    case UB_ATTRIBUTE_DISTANCE:
        return h->distance;
    case UB_ATTRIBUTE_POSITION: {
        double sum = 0.0; /* object space, the mean of x, y, z */
        for (int r = 0; r < 3; r++)
            sum += o->world_to_object[r][0] * h->p[0] + o->world_to_object[r][1] * h->p[1]
                 + o->world_to_object[r][2] * h->p[2] + o->world_to_object[r][3];
        return (float)(sum / 3.0);
    }
    case UB_ATTRIBUTE_NORMAL:
        return (h->n[0] + h->n[1] + h->n[2]) / 3.0f;
    default:
        return 0.0f;
    }
}

/* A material input: its constant, or its map's table at the attribute. */
static void material_input(const ub_object *o, const ub_material_map *map, const float *constant, int channels,
                           const ub_hit_attributes *h, double out[3])
{
    float v[3] = {constant[0], channels == 3 ? constant[1] : 0.0f, channels == 3 ? constant[2] : 0.0f};
    if (map->source != UB_ATTRIBUTE_NONE)
        ramp_lookup((const float (*)[3])map->table, map->size, attribute_value(o, map->source, h), map->scale,
                    map->offset, v);
    for (int c = 0; c < 3; c++)
        out[c] = v[c];
}

/* The BSDF of object o's material at a hit, as Cycles clamps the Principled inputs (base colour
 * >= 0, metallic and roughness in [0, 1]). */
static void bsdf_at(const ub_object *o, const ub_hit_attributes *h, ub_bsdf *b)
{
    const ub_material *m = &o->material;
    double v[3];
    material_input(o, &m->base_color_map, m->base_color, 3, h, b->base);
    for (int c = 0; c < 3; c++)
        b->base[c] = b->base[c] > 0.0 ? b->base[c] : 0.0;
    material_input(o, &m->metallic_map, &m->metallic, 1, h, v);
    b->metallic = bsdf_clamp01(v[0]);
    material_input(o, &m->roughness_map, &m->roughness, 1, h, v);
    b->roughness = bsdf_clamp01(v[0]);
    b->eta = m->eta;
    b->specular_f0 = m->specular_f0;
}
