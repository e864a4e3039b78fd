/* The World as a background and a light (scene.h: ub_world; its distribution: world.c). Included
 * by kernel.h after shading.h.
 *
 * Missed rays see the map, bilinearly filtered (Cycles' Linear interpolation). At every hit the
 * world's light is estimated with world_samples pairs of directions, one drawn from the map's
 * distribution, one from the surface's (cosine-weighted for Lambert; for a material its BSDF's,
 * the diffuse or the GGX lobe), combined by the balance heuristic of multiple importance
 * sampling: each pair adds L f / (p_map + p_surface) for both of its directions, f the surface's
 * response (Veach 1997, ch. 9). The light seen there is the map's texel (piecewise constant,
 * as the distribution is), with a shadow ray marched toward it. */

/* lowbias32 (C. Wellons): a 32-bit integer hash with good avalanche. */
static inline uint32_t hash_u32(uint32_t x)
{
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

/* Counter-based random number in [0, 1) of full-image pixel (px, py), anti-aliasing sample
 * `sample` and dimension `dim`: the same bits whatever thread, tile, window, stride or kernel
 * computes the pixel. */
static inline double random_uniform(int px, int py, int sample, int dim)
{
    uint32_t h = hash_u32((uint32_t)dim + 0x9e3779b9u);
    h = hash_u32((uint32_t)sample ^ h);
    h = hash_u32((uint32_t)py ^ h);
    h = hash_u32((uint32_t)px ^ h);
    return (double)(h >> 8) * (1.0 / 16777216.0);
}

/* Dimensions of random_uniform: a world-light pair's two directions use ((bounce N + s) 2 +
 * technique) 2 + 0..1 (below 2^18), a material's lobe choice WORLD_LOBE_DIM + bounce N + s, apart
 * from those and from global illumination's (kernel.h GI_DIM). */
enum { WORLD_LOBE_DIM = 0x574C0000 };

/* Unit direction of map point (u, v) and the sine of its polar angle. */
static void world_direction(double u, double v, double d[3], double *sin_polar)
{
    double phi = 2.0 * M_PI * (u - 0.5), lat = M_PI * (v - 0.5);
    double sl, cl, sp, cp;
    ub_sincos(lat, &sl, &cl);
    ub_sincos(phi, &sp, &cp);
    d[0] = cp * cl;
    d[1] = -sp * cl;
    d[2] = sl;
    *sin_polar = cl;
}

static inline double clamp_unit(double x)
{
    return x < -1.0 ? -1.0 : (x > 1.0 ? 1.0 : x);
}

/* Map point (u, v) of direction d (any length > 0): u = atan2(-y, x) / 2 pi + 0.5, v = 1 -
 * polar / pi, by the core's own acos (the same bits everywhere). */
static void world_uv(const double d[3], double *u, double *v)
{
    double r = ub_hypot(d[0], d[1]), len = ub_hypot(r, d[2]);
    double phi = r > 0.0 ? ub_acos(clamp_unit(d[0] / r)) : 0.0;
    if (d[1] > 0.0)
        phi = -phi;
    *u = phi * (0.5 / M_PI) + 0.5;
    *v = len > 0.0 ? 1.0 - ub_acos(clamp_unit(d[2] / len)) / M_PI : 0.5;
}

static inline int clamp_index(int i, int n)
{
    return i < 0 ? 0 : (i >= n ? n - 1 : i);
}

static inline int wrap_index(int i, int n)
{
    i %= n;
    return i < 0 ? i + n : i;
}

/* Texel (i, j) that map point (u, v) lies in. */
static inline void world_texel(const ub_world *wd, double u, double v, int *i, int *j)
{
    *i = wrap_index((int)floor(u * wd->w), wd->w);
    *j = clamp_index((int)floor(v * wd->h), wd->h);
}

/* A constant World: a 1x1 map, whose radiance world_radiance gives along every direction. */
static inline int world_is_constant(const ub_world *wd)
{
    return wd->w == 1 && wd->h == 1;
}

/* The map seen along direction d, bilinear: wraps around in u, clamps at the poles. */
static void world_radiance(const ub_world *wd, const double d[3], float out[3])
{
    if (world_is_constant(wd)) {
        /* A constant World (a 1x1 map): all four corners are the one texel, so the blend below
         * is t + fx (t - t) = t + 0 for any direction; the same bits without the two arc
         * cosines of world_uv (a third of a missed ray's cost). */
        for (int k = 0; k < 3; k++)
            out[k] = wd->rgb[k] + 0.0f;
        return;
    }
    double u, v;
    world_uv(d, &u, &v);
    double x = u * wd->w - 0.5, y = v * wd->h - 0.5;
    double x0 = floor(x), y0 = floor(y);
    float fx = (float)(x - x0), fy = (float)(y - y0);
    int i0 = wrap_index((int)x0, wd->w), i1 = wrap_index((int)x0 + 1, wd->w);
    int j0 = clamp_index((int)y0, wd->h), j1 = clamp_index((int)y0 + 1, wd->h);
    const float *a = wd->rgb + ((size_t)j0 * wd->w + i0) * 3, *b = wd->rgb + ((size_t)j0 * wd->w + i1) * 3;
    const float *c = wd->rgb + ((size_t)j1 * wd->w + i0) * 3, *e = wd->rgb + ((size_t)j1 * wd->w + i1) * 3;
    for (int k = 0; k < 3; k++) {
        float bottom = a[k] + fx * (b[k] - a[k]), top = c[k] + fx * (e[k] - c[k]);
        out[k] = bottom + fy * (top - bottom);
    }
}

/* Density, per steradian, of the map's distribution at texel (i, j) along a direction whose
 * polar angle has sine sin_polar: the texel's probability times w h over the unit square, over
 * the Jacobian 2 pi^2 sin(polar) of the map. */
static double world_pdf(const ub_world *wd, int i, int j, double sin_polar)
{
    if (!(wd->sum > 0.0) || !(sin_polar > 0.0))
        return 0.0;
    const float *t = wd->rgb + ((size_t)j * wd->w + i) * 3;
    double f = ub_luminance(t[0], t[1], t[2]) * wd->row_sin[j];
    return f * wd->w * wd->h / wd->sum / (2.0 * M_PI * M_PI * sin_polar);
}

/* The last index k < n with cdf[k] <= r: its interval [cdf[k], cdf[k + 1]) holds r and has a
 * positive width (r < 1 = cdf[n]). */
static int find_interval(const float *cdf, int n, double r)
{
    int lo = 0, hi = n - 1;
    while (lo < hi) {
        int mid = (lo + hi + 1) / 2;
        if ((double)cdf[mid] <= r)
            lo = mid;
        else
            hi = mid - 1;
    }
    return lo;
}

/* A direction drawn from the map's distribution by (r1, r2) in [0, 1)^2; its texel and density.
 * Returns 0 if it has none (a black map, a pole). */
static int world_sample(const ub_world *wd, double r1, double r2, double d[3], int *ti, int *tj, double *pdf)
{
    int j = find_interval(wd->row_cdf, wd->h, r1);
    const float *cc = wd->col_cdf + (size_t)j * (wd->w + 1);
    int i = find_interval(cc, wd->w, r2);
    double rw = (double)wd->row_cdf[j + 1] - wd->row_cdf[j], cw = (double)cc[i + 1] - cc[i];
    double dv = rw > 0.0 ? (r1 - wd->row_cdf[j]) / rw : 0.5, du = cw > 0.0 ? (r2 - cc[i]) / cw : 0.5;
    double sin_polar;
    world_direction((i + du) / wd->w, (j + dv) / wd->h, d, &sin_polar);
    *ti = i;
    *tj = j;
    *pdf = world_pdf(wd, i, j, sin_polar);
    return *pdf > 0.0;
}

/* The Lambertian surface's response to light arriving along unit wi: cos / pi (times the albedo,
 * which add_surface_light applies). The one place a richer BSDF would answer instead. */
static inline double diffuse_response(const float n[3], const double wi[3])
{
    double c = n[0] * wi[0] + n[1] * wi[1] + n[2] * wi[2];
    return c > 0.0 ? c * M_1_PI : 0.0;
}

/* The azimuth of diffuse_sample's direction for the random number r2. */
static inline double diffuse_azimuth(double r2)
{
    return 2.0 * M_PI * r2;
}

/* Its sampling: a cosine-weighted direction about n by (r1, r2), density cos / pi (Malley's
 * method, in the frame of Duff et al. 2017). `azimuth`: the sine and cosine of
 * diffuse_azimuth(r2) (sincos_lanes), or NULL to compute them here. */
static double diffuse_sample(const float n[3], double r1, double r2, const double azimuth[2], double wi[3])
{
    double t[3], s[3];
    bsdf_frame(n, t, s);
    double r = sqrt(r1);
    double sp, cp;
    if (azimuth) {
        sp = azimuth[0];
        cp = azimuth[1];
    } else {
        ub_sincos(diffuse_azimuth(r2), &sp, &cp);
    }
    double x = r * cp, y = r * sp, z = sqrt(1.0 - r1 > 0.0 ? 1.0 - r1 : 0.0);
    for (int k = 0; k < 3; k++)
        wi[k] = x * t[k] + y * s[k] + z * n[k];
    return z * M_1_PI;
}

#ifdef VD_LANES
/* ubmath.h's double-double steps in double vectors, operation for operation (the same bits). */
static inline vd vd_neg(vd a) { return vd_mul(a, vd_set1(-1.0)); }

static inline vd vd_two_sum(vd a, vd b, vd *e)
{
    vd s = vd_add(a, b), bb = vd_sub(s, a);
    *e = vd_add(vd_sub(a, vd_sub(s, bb)), vd_sub(b, bb));
    return s;
}

static inline vd vd_fast_two_sum(vd a, vd b, vd *e)
{
    vd s = vd_add(a, b);
    *e = vd_sub(b, vd_sub(s, a));
    return s;
}

static inline void vd_split(vd a, vd *hi, vd *lo)
{
    vd t = vd_mul(vd_set1(134217729.0), a); /* 2^27 + 1 */
    *hi = vd_sub(t, vd_sub(t, a));
    *lo = vd_sub(a, *hi);
}

static inline vd vd_two_prod(vd a, vd b, vd *e)
{
    vd p = vd_mul(a, b), ah, al, bh, bl;
    vd_split(a, &ah, &al);
    vd_split(b, &bh, &bl);
    *e = vd_add(vd_add(vd_add(vd_sub(vd_mul(ah, bh), p), vd_mul(ah, bl)), vd_mul(al, bh)), vd_mul(al, bl));
    return p;
}

/* ub__sin_kernel and ub__cos_kernel in double vectors. */
static inline vd vd_sin_kernel(vd rh, vd rl)
{
    const double *q = ub__sin_series;
    const vd six = vd_set1(6.0);
    vd zl, zh = vd_two_prod(rh, rh, &zl);
    vd cl, ch = vd_two_prod(rh, zh, &cl);
    cl = vd_add(cl, vd_mul(rh, zl));
    vd sixth = vd_div(ch, six), pl, ph = vd_two_prod(sixth, six, &pl);
    vd sixth_lo = vd_div(vd_add(vd_sub(vd_sub(ch, ph), pl), cl), six);
    vd p = vd_set1(q[7]);
    for (int i = 6; i >= 0; i--)
        p = vd_add(vd_mul(p, zh), vd_set1(q[i]));
    vd e, h = vd_two_sum(rh, vd_neg(sixth), &e);
    vd tail = vd_add(vd_sub(e, sixth_lo), vd_mul(vd_mul(vd_mul(rh, zh), zh), p));
    return vd_add(h, vd_add(tail, vd_mul(rl, vd_sub(vd_set1(1.0), vd_mul(vd_set1(0.5), zh)))));
}

static inline vd vd_cos_kernel(vd rh, vd rl)
{
    const double *c = ub__cos_series;
    const vd one = vd_set1(1.0), half = vd_set1(0.5);
    vd zl, zh = vd_two_prod(rh, rh, &zl);
    vd p = vd_set1(c[8]);
    for (int i = 7; i >= 0; i--)
        p = vd_add(vd_mul(p, zh), vd_set1(c[i]));
    vd hz = vd_mul(half, zh), w = vd_sub(one, hz);
    vd err = vd_sub(vd_sub(one, w), hz);
    vd poly = vd_sub(vd_sub(vd_mul(vd_mul(zh, zh), p), vd_mul(half, zl)), vd_mul(rh, rl));
    return vd_add(w, vd_add(err, poly));
}
#endif

/* ub_sincos of every lane: in the kernels' double vectors where they have them, ub__reduce's
 * Cody-Waite steps and its branches as selects, the same operations in the same order (the same
 * bits); lanes past its range (|x| >= 2^20, inf, NaN) and the portable kernel call ub_sincos.
 * Issue 21: the World's sample directions, lane by lane, were 7.5 % of an artist's first F12. */
static void sincos_lanes(const double x[UB_LANES], double sine[UB_LANES], double cosine[UB_LANES])
{
    int wide = UB_ALL_LANES;
#ifdef VD_LANES
    wide = 0;
    const vd zero = vd_set1(0.0), quarter_pi = vd_set1(0x1.921fb54442d18p-1);
    for (int h = 0; h < UB_LANES; h += VD_LANES) {
        const vd v = vd_load(x + h), ax = vd_select(vd_lt(v, zero), vd_neg(v), v);
        wide |= vdm_bits(vdm_andnot(vd_lt(ax, vd_set1(0x1p20)), vdm_from_bits((1 << VD_LANES) - 1))) << h;
        const vdm small = vd_ge(quarter_pi, ax);
        const vd shifter = vd_set1(UB__ROUND_SHIFTER);
        vd nd = vd_sub(vd_add(vd_mul(v, vd_set1(UB__2_OVER_PI)), shifter), shifter);
        nd = vd_select(small, zero, nd);
        const vd neg_nd = vd_neg(nd);
        const vd t = vd_sub(v, vd_mul(nd, vd_set1(UB__PIO2_1)));
        vd e1, e2, lo;
        const vd h1 = vd_two_sum(t, vd_mul(neg_nd, vd_set1(UB__PIO2_2)), &e1);
        const vd h2 = vd_two_sum(h1, vd_mul(neg_nd, vd_set1(UB__PIO2_3)), &e2);
        const vd hi = vd_fast_two_sum(h2, vd_sub(vd_add(e1, e2), vd_mul(nd, vd_set1(UB__PIO2_4))), &lo);
        const vd rh = vd_select(small, v, hi), rl = vd_select(small, zero, lo);
        /* n mod 4 of the whole number nd (|nd| < 2^20: every step exact) */
        const vd quadrant = vd_sub(nd, vd_mul(vd_set1(4.0), vd_floor(vd_mul(nd, vd_set1(0.25)))));
        const vd odd = vd_sub(quadrant, vd_mul(vd_set1(2.0), vd_floor(vd_mul(quadrant, vd_set1(0.5)))));
        const vd s = vd_sin_kernel(rh, rl), c = vd_cos_kernel(rh, rl);
        const vdm swap = vd_gt(odd, vd_set1(0.5));
        const vd s1 = vd_select(swap, c, s), c1 = vd_select(swap, s, c);
        const vd sn = vd_select(vd_gt(quadrant, vd_set1(1.5)), vd_neg(s1), s1);
        const vdm flip = vdm_and(vd_gt(quadrant, vd_set1(0.5)), vd_lt(quadrant, vd_set1(2.5)));
        const vdm tiny = vdm_and(vd_lt(v, vd_set1(0x1p-26)), vd_gt(v, vd_set1(-0x1p-26)));
        vd_store(sine + h, vd_select(tiny, v, sn));
        vd_store(cosine + h, vd_select(flip, vd_neg(c1), c1));
    }
#endif
    for (int l = 0; l < UB_LANES; l++)
        if ((wide >> l) & 1)
            ub_sincos(x[l], &sine[l], &cosine[l]);
}

/* Density per steradian of the map's distribution along direction d, and the texel (i, j) d sees. */
static double world_pdf_along(const ub_world *wd, const double d[3], int *i, int *j)
{
    if (world_is_constant(wd)) { /* a constant World: texel (0, 0) whatever the direction */
        *i = *j = 0;
        return world_pdf(wd, 0, 0, ub_hypot(d[0], d[1]));
    }
    double u, v;
    world_uv(d, &u, &v);
    world_texel(wd, u, v, i, j);
    return world_pdf(wd, *i, *j, ub_hypot(d[0], d[1]));
}

/* The surface technique of a material without a bounce to weigh against: its BSDF's own mixture
 * (bsdf.h: the diffuse lobe's cosine or the GGX lobe's visible normals, chosen by their rough
 * weights, as global illumination draws), so that a sharp metal's narrow lobe, which the map and
 * the cosine rarely hit, is found. Its density is bounce_density's with nothing else in play. */
static ub_bounce_density material_world_density(const ub_bsdf *b)
{
    double p_specular = bsdf_specular_probability(b);
    return (ub_bounce_density){1.0, p_specular, p_specular < 1.0, p_specular > 0.0};
}

/* A direction drawn from the surface technique by (r1, r2), the lobe chosen by r_lobe (material
 * lanes only); its density, 0 if none (below the surface). Lambert: the cosine. */
static double surface_sample(const ub_bsdf *b, const float n[3], const double wo[3], double r_lobe, double r1,
                             double r2, const double azimuth[2], double d[3])
{
    if (!b)
        return diffuse_sample(n, r1, r2, azimuth, d);
    ub_bounce_density own = material_world_density(b);
    if (r_lobe < own.p_specular) {
        if (!bsdf_ggx_sample(b, n, wo, r1, r2, d))
            return 0.0;
    } else {
        diffuse_sample(n, r1, r2, azimuth, d);
    }
    return bounce_density(&own, b, n, wo, d);
}

/* The surface technique's density toward d: the material's mixture, or the cosine for Lambert. */
static double surface_density(const ub_bsdf *b, const float n[3], const double wo[3], const double d[3])
{
    if (b) {
        ub_bounce_density own = material_world_density(b);
        return bounce_density(&own, b, n, wo, d);
    }
    return diffuse_response(n, d);
}

/* One direction of a world-light pair at lane l: its radiance over (p_map + p_surface) times the
 * surface's response (Lambert's cos / pi, or the material's BSDF `b` seen from wo, its colour
 * included); 0 if nothing can arrive. technique 0 draws from the map, 1 from the surface
 * (surface_sample; r_lobe picks a material's lobe). With global illumination (bd not NULL) the
 * path's own next bounce is the second technique: the map's N samples are weighed against its
 * density, p_surface = density / N (balance heuristic over N + 1 samples; see world_bounce_share).
 * `surface_only` (a constant World, world_light): the surface's direction alone, L f / p_surface. */
static int world_direction_weight(const ub_world *wd, const float n[3], const ub_bsdf *b, const double wo[3],
                                  int technique, int surface_only, double r_lobe, double r1, double r2,
                                  const double azimuth[2], const ub_bounce_density *bd, int N, double d[3],
                                  double weight[3])
{
    double p_map, p_surface;
    int i, j;
    if (technique == 0) {
        if (!world_sample(wd, r1, r2, d, &i, &j, &p_map))
            return 0;
        p_surface = bd ? bounce_density(bd, b, n, wo, d) / N : surface_density(b, n, wo, d);
    } else {
        p_surface = surface_sample(b, n, wo, r_lobe, r1, r2, azimuth, d);
        if (!(p_surface > 0.0))
            return 0;
        if (surface_only) {
            i = j = 0;
            p_map = 0.0;
        } else {
            p_map = world_pdf_along(wd, d, &i, &j);
        }
    }
    double response[3];
    if (b) {
        if (!(n[0] * d[0] + n[1] * d[1] + n[2] * d[2] > 0.0))
            return 0;
        bsdf_eval(b, n, wo, d, response);
    } else {
        response[0] = response[1] = response[2] = diffuse_response(n, d);
    }
    if (!(p_map + p_surface > 0.0))
        return 0;
    const float *L = wd->rgb + ((size_t)j * wd->w + i) * 3;
    for (int k = 0; k < 3; k++)
        weight[k] = L[k] * response[k] / (p_map + p_surface);
    return weight[0] > 0.0 || weight[1] > 0.0 || weight[2] > 0.0;
}

/* The share of the world seen along a path's bounce ray drawn with density `density` (direction
 * d): the balance heuristic against world_light's N map samples, density / (N p_map + density),
 * so that the two add up to the world's light once. 1 where the world lights nothing. */
static double world_bounce_share(const ub_scene *sc, const double d[3], double density)
{
    const ub_world *wd = sc->world;
    const int N = sc->shading->world_samples;
    if (!wd || N <= 0 || !(wd->sum > 0.0))
        return 1.0;
    int i, j;
    double p_map = world_pdf_along(wd, d, &i, &j);
    return density > 0.0 ? density / (N * p_map + density) : 0.0;
}

/* One packet of the world's light samples (world_light): sample s, technique t, of each lane of
 * `lanes` that takes one, with its shadow ray and its weight. */
typedef struct {
    ub_packet_rays sr;
    float weight[3][UB_LANES];
    int cand; /* the lanes with a sample */
    int traced;         /* their shadow rays traced (by direct_light, with a light's) into st */
    ub_trace_result st;
} ub_world_rays;

/* Whether the world's light comes in one packet of shadowed samples a bounce (world_light: a
 * constant World, one sample, no global illumination), which direct_light can then trace with a
 * light's shadow rays (world_sample_rays with s = 0, technique 1). */
static int world_single_packet(const ub_scene *sc, const ub_bounce_density *bounces)
{
    const ub_world *wd = sc->world;
    return wd && sc->shading->world_samples == 1 && wd->sum > 0.0 && world_is_constant(wd) && !bounces
        && sc->shading->shadows != UB_SHADOWS_NONE;
}

/* Sample s, technique `technique` of each lane of `lanes` into wr (none traced yet). */
static void world_sample_rays(const ub_scene *sc, const sample_point *sp, const ub_lane_pixels *pix, int bounce,
                              int lanes, const ub_packet_rays *pr, const ub_trace_result *tr, const ub_surface *sf,
                              const ub_bounce_density *bounces, int s, int technique, ub_world_rays *wr)
{
    const ub_shading *sh = sc->shading;
    const ub_world *wd = sc->world;
    const int N = sh->world_samples;
    /* Issue 21: a constant World (a 1x1 map, the add-on's for a World of one colour) sends the
     * same radiance from everywhere, so the integrand is L times the surface's response, which the
     * surface's own sampling follows (exactly, for Lambert: each sample is L rho, whatever the
     * direction, when unoccluded). Its N samples come from the surface alone: half the shadow rays
     * of N pairs, and less noise. The same expectation; with global illumination, lanes that
     * bounce keep the map's samples (the bounce's MIS reads them: world_bounce_share). */
    const int constant = world_is_constant(wd);
    ub_packet_rays *sr = &wr->sr;
    wr->cand = wr->traced = 0;
    /* The lanes that draw a sample and their random numbers first; then, for the surface
     * technique, the azimuths of them all at once (sincos_lanes). */
    int drawing = 0;
    double r1[UB_LANES], r2[UB_LANES], azimuth[UB_LANES], sine[UB_LANES], cosine[UB_LANES];
    for (int l = 0; l < UB_LANES; l++) {
        const int bd = bounces && bounces[l].scale > 0.0;
        const int skip = (bd && technique == 1) || (constant && !bd && technique == 0);
        drawing |= (((lanes >> l) & 1) && !skip) << l;
    }
    /* Every lane's numbers, then the drawing lanes' kept: integer hashes in a loop without
     * branches, vector code. */
    const int dim = ((bounce * N + s) * 2 + technique) * 2;
    for (int l = 0; l < UB_LANES; l++) {
        const double u1 = random_uniform(pix->px[l], pix->py[l], sp->index, dim);
        const double u2 = random_uniform(pix->px[l], pix->py[l], sp->index, dim + 1);
        r1[l] = (drawing >> l) & 1 ? u1 : 0.0;
        r2[l] = (drawing >> l) & 1 ? u2 : 0.0;
    }
    if (technique == 1 && drawing) {
        for (int l = 0; l < UB_LANES; l++)
            azimuth[l] = diffuse_azimuth(r2[l]);
        sincos_lanes(azimuth, sine, cosine);
    }
    for (int l = 0; l < UB_LANES; l++) {
        sr->t_base[l] = 0.0f;
        sr->t_min[l] = sr->t_max[l] = 0.0;
        for (int i = 0; i < 3; i++)
            sr->origin[i][l] = sr->dir[i][l] = 0.0;
        sr->dir[2][l] = 1.0;
        if (!((drawing >> l) & 1))
            continue;
        const ub_bounce_density *bd = bounces && bounces[l].scale > 0.0 ? &bounces[l] : NULL;
        const int surface_only = constant && !bd;
        const ub_bsdf *b = (sf->bsdf_lanes >> l) & 1 ? &sf->bsdf[l] : NULL;
        /* A material's lobe: a dimension of its own, so Lambert's pairs keep their bits. */
        double r_lobe = technique == 1 && b ? random_uniform(pix->px[l], pix->py[l], sp->index,
                                                             WORLD_LOBE_DIM + bounce * N + s)
                                            : 0.0;
        float n[3] = {sf->n[0][l], sf->n[1][l], sf->n[2][l]};
        double wo[3] = {-pr->dir[0][l], -pr->dir[1][l], -pr->dir[2][l]}, d[3], w[3];
        const double *lane_azimuth = technique == 1 ? (const double[2]){sine[l], cosine[l]} : NULL;
        if (!world_direction_weight(wd, n, b, wo, technique, surface_only, r_lobe, r1[l], r2[l], lane_azimuth,
                                    bd, N, d, w))
            continue;
        /* The sea is opaque: the sky below it does not reach a point above it. */
        if (sh->sea && sf->p[2][l] > sh->sea_height + sf->bias[l] && d[2] < 0.0)
            continue;
        wr->cand |= 1 << l;
        for (int i = 0; i < 3; i++) {
            wr->weight[i][l] = (float)w[i];
            sr->origin[i][l] = sf->p[i][l] + sf->bias[l] * sf->n[i][l];
            sr->dir[i][l] = d[i];
        }
        sr->t_min[l] = sf->bias[l];
        sr->t_max[l] = 1e30;
        sr->t_base[l] = pr->t_base[l] + tr->t[l];
    }
}

/* The samples of wr whose shadow rays found nothing (st, or all of them without shadows) into
 * `direct`. */
static void world_sample_add(const ub_scene *sc, const ub_world_rays *wr, const ub_trace_result *st,
                             float direct[3][UB_LANES], ub_counters *cnt)
{
    const float scale = 1.0f / (float)sc->shading->world_samples;
    int visible = wr->cand;
    if (st)
        for (int l = 0; l < UB_LANES; l++) {
            if (!((wr->cand >> l) & 1))
                continue;
            cnt->steps += (uint64_t)st->steps[l];
            if (st->object[l] != UB_HIT_NONE)
                visible &= ~(1 << l);
        }
    for (int l = 0; l < UB_LANES; l++)
        if ((visible >> l) & 1)
            for (int i = 0; i < 3; i++)
                direct[i][l] += wr->weight[i][l] * scale;
}

/* The world's light at the hits `lanes` of one bounce, added to `direct` as direct_light adds the
 * lights' (irradiance / pi, or through a material's BSDF): world_samples pairs per hit, shadows marched as for the lights (any hit; the
 * sea blocks what comes from below it). Lane l is full-image pixel pix[l]. With
 * global illumination, lanes whose path may bounce on (bounce[l].scale > 0) draw from the map
 * alone, weighed against that bounce (world_bounce_share). */
static void world_light(const ub_scene *sc, const ub_de_params *dps, const sample_point *sp,
                        const ub_lane_pixels *pix, int bounce, int lanes, const ub_packet_rays *pr,
                        const ub_trace_result *tr, const ub_surface *sf, const ub_bounce_density *bounces,
                        float direct[3][UB_LANES], ub_counters *cnt)
{
    const ub_shading *sh = sc->shading;
    const ub_world *wd = sc->world;
    const int N = sh->world_samples;
    if (!wd || N <= 0 || !(wd->sum > 0.0))
        return;
    for (int s = 0; s < N && !cancelled(sc); s++) {
        for (int technique = 0; technique < 2; technique++) {
            ub_world_rays wr;
            world_sample_rays(sc, sp, pix, bounce, lanes, pr, tr, sf, bounces, s, technique, &wr);
            if (!wr.cand)
                continue;
            if (sh->shadows != UB_SHADOWS_NONE) {
                ub_trace_result st;
                trace(sc, dps, &wr.sr, wr.cand, UB_TRACE_ANY_HIT, NULL, &st, cnt);
                world_sample_add(sc, &wr, &st, direct, cnt);
            } else {
                world_sample_add(sc, &wr, NULL, direct, cnt);
            }
        }
    }
}
