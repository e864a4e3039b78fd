/* The Principled BSDF of a fractal's material, as Cycles 4.x evaluates it for light arriving from
 * one direction (svm_node_closure_bsdf, CLOSURE_BSDF_PRINCIPLED_ID, without sheen, coat,
 * subsurface, transmission or anisotropy), in layers from the top:
 *   metal       metallic x GGX microfacet reflection, F82-tint Fresnel with F0 = base colour and a
 *               white tint (which is Schlick's F0 + (1 - F0)(1 - cos)^5);
 *   specular    (1 - metallic) x GGX reflection with the dielectric Fresnel of the IOR (after
 *               Specular IOR Level), over
 *   diffuse     (1 - metallic)(1 - albedo of the specular layer from this view) x base / pi.
 * Both GGX lobes are Cycles' multiple-scattering GGX: the single-scattering lobe (Smith's
 * height-correlated G2) scaled by 1 + Fms (1 - E) / E, E the lobe's directional albedo and Fms the
 * multiply-bounced Fresnel (Kulla and Conty 2017, as microfacet_ggx_preserve_energy). The albedo
 * tables are bsdf_tables.h (tools/bsdf_tables.py computes them; within 1.5e-3 of Cycles' own).
 *
 * Scalar double-precision code of + - * / and sqrt only: the same bits on every platform. Needs
 * scene.h (ub_material) and M_PI. */
#ifndef UNBOUND_BSDF_H
#define UNBOUND_BSDF_H

#include <math.h>

#include "bsdf_tables.h"

/* A material's BSDF at one hit: its inputs after the attributes (bsdf_at). */
typedef struct {
    double base[3], metallic, roughness, eta, specular_f0;
} ub_bsdf;

static inline double bsdf_clamp01(double x)
{
    return x < 0.0 ? 0.0 : (x > 1.0 ? 1.0 : x);
}

/* Linear interpolation in a table row of n entries sampled at 0, 1/(n-1), ..., 1. */
static inline double bsdf_row(const float *row, int n, double x)
{
    x = bsdf_clamp01(x) * (n - 1);
    int i = (int)x;
    if (i > n - 1)
        i = n - 1;
    int j = i + 1 < n ? i + 1 : n - 1;
    double t = x - i;
    return (1.0 - t) * row[i] + t * row[j];
}

/* Bilinear: rows of nx entries, ny rows; x along a row, y across rows. */
static inline double bsdf_table2(const float *table, int nx, int ny, double x, double y)
{
    y = bsdf_clamp01(y) * (ny - 1);
    int i = (int)y;
    if (i > ny - 1)
        i = ny - 1;
    int j = i + 1 < ny ? i + 1 : ny - 1;
    double t = y - i;
    return (1.0 - t) * bsdf_row(table + nx * i, nx, x) + t * bsdf_row(table + nx * j, nx, x);
}

/* Cycles' fresnel_dielectric_cos: unpolarised reflectance at cosine c for relative IOR eta. */
static inline double bsdf_fresnel_dielectric(double c, double eta)
{
    c = fabs(c);
    double g = eta * eta - 1.0 + c * c;
    if (!(g > 0.0))
        return 1.0; /* total internal reflection */
    g = sqrt(g);
    double a = (g - c) / (g + c), b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    return 0.5 * a * a * (1.0 + b * b);
}

/* Kulla and Conty's fit of the cosine-weighted average dielectric reflectance (Cycles'
 * fresnel_dielectric_Fss). */
static inline double bsdf_fresnel_average(double eta)
{
    if (eta < 1.0)
        return 0.997118 + eta * (0.1014 - eta * (0.965241 + eta * 0.130607));
    return (eta - 1.0) / (4.08567 + 1.00071 * eta);
}

/* Smith's Lambda of GGX at cosine c. */
static inline double bsdf_lambda(double alpha2, double c)
{
    double c2 = c * c;
    double tan2 = c2 > 0.0 ? 1.0 / c2 - 1.0 : 0.0;
    return 0.5 * (sqrt(1.0 + alpha2 * (tan2 > 0.0 ? tan2 : 0.0)) - 1.0);
}

/* GGX's normal distribution D at the half vector h (unnormalised, of length len > 0). */
static inline double bsdf_ggx_D(double alpha2, const float n[3], const double h[3], double len)
{
    double cos_nh = (n[0] * h[0] + n[1] * h[1] + n[2] * h[2]) / len;
    double c2 = cos_nh * cos_nh < 1.0 ? cos_nh * cos_nh : 1.0;
    double d = 1.0 - c2 + alpha2 * c2;
    return alpha2 / (M_PI * d * d);
}

/* The view's cosine as the lobes use it: at least 1e-6 (grazing or back-facing views), at most 1. */
static inline double bsdf_view_cosine(const float n[3], const double wo[3])
{
    double cos_o = n[0] * wo[0] + n[1] * wo[1] + n[2] * wo[2];
    return cos_o > 1e-6 ? (cos_o < 1.0 ? cos_o : 1.0) : 1e-6;
}

/* The multiple-scattering factor 1 + Fms (1 - E) / E of a lobe with average single-scattering
 * Fresnel fss (per channel). */
static inline double bsdf_multiscatter(double fss, double E, double E_avg)
{
    double fms = fss * E_avg / (1.0 - fss * (1.0 - E_avg));
    return E > 0.0 ? 1.0 + fms * (1.0 - E) / E : 1.0;
}

/* The BSDF times the cosine at the light: reflected radiance toward wo (unit, toward the viewer)
 * per unit of irradiance arriving from wi (unit, toward the light) at a surface of unit normal n
 * facing the viewer. 0 where the light is behind the surface. */
static void bsdf_eval(const ub_bsdf *b, const float n[3], const double wo[3], const double wi[3], double out[3])
{
    double cos_i = n[0] * wi[0] + n[1] * wi[1] + n[2] * wi[2];
    for (int c = 0; c < 3; c++)
        out[c] = 0.0;
    if (!(cos_i > 0.0))
        return;
    const double cos_o = bsdf_view_cosine(n, wo);
    double alpha = b->roughness * b->roughness, alpha2 = alpha * alpha;
    double weight = 1.0 - b->metallic; /* what the layers below the metal get */
    /* The microfacet lobes' shared single-scattering part, D G2 / (4 cos_o) (cosine at the light
     * included), and the half vector's cosine with the view. Below alpha^2 = 2e-10 Cycles treats
     * the lobes as perfect mirrors, which a light direction never hits. */
    double spec = 0.0, cos_h = 1.0;
    if (alpha2 > 2e-10) {
        double h[3] = {wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]};
        double len = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
        if (len > 0.0) {
            cos_h = bsdf_clamp01((wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2]) / len);
            double D = bsdf_ggx_D(alpha2, n, h, len);
            spec = D * 0.25 / cos_o / (1.0 + bsdf_lambda(alpha2, cos_o) + bsdf_lambda(alpha2, cos_i));
        }
    }
    double E = bsdf_table2(ggx_E, 32, 32, b->roughness, cos_o);
    double E_avg = bsdf_row(ggx_Eavg, 32, b->roughness);
    if (b->metallic > 0.0) {
        double m = 1.0 - cos_h, m5 = m * m * m * m * m;
        for (int c = 0; c < 3; c++) {
            double f0 = bsdf_clamp01(b->base[c]);
            double F = f0 + (1.0 - f0) * m5;
            double fss = f0 + (1.0 - f0) / 21.0;
            out[c] += b->metallic * bsdf_multiscatter(fss, E, E_avg) * F * spec;
        }
    }
    if (b->eta != 1.0) {
        /* Fresnel between F0 and 1 as the real dielectric curve goes from its F0 to 1. */
        double eta = b->eta, f0 = bsdf_clamp01(b->specular_f0);
        double real_f0 = (eta - 1.0) / (eta + 1.0) * ((eta - 1.0) / (eta + 1.0));
        double span = 1.0 - real_f0;
        double s = span > 0.0 ? bsdf_clamp01((bsdf_fresnel_dielectric(cos_h, eta) - real_f0) / span) : 1.0;
        double s_avg = span > 0.0 ? bsdf_clamp01((bsdf_fresnel_average(eta) - real_f0) / span) : 1.0;
        double F = f0 + (1.0 - f0) * s, fss = f0 + (1.0 - f0) * s_avg;
        double scale = bsdf_multiscatter(fss, E, E_avg);
        for (int c = 0; c < 3; c++)
            out[c] += weight * scale * F * spec;
        /* The diffuse base gets what the specular layer's albedo from this view leaves: Cycles'
         * closure_layering_weight with bsdf_albedo, whose weight carries the lobe's darkening
         * (scale / (1 + (1 - E) / E)) but not its energy compensation. */
        double z = sqrt(fabs((eta - 1.0) / (eta + 1.0)));
        double S = bsdf_clamp01(z) * 15.0, t;
        int k = (int)S;
        if (k > 15)
            k = 15;
        int k1 = k + 1 < 16 ? k + 1 : 15;
        t = S - k;
        double s_dir = (1.0 - t) * bsdf_table2(ggx_ior_s + 256 * k, 16, 16, b->roughness, cos_o)
                     + t * bsdf_table2(ggx_ior_s + 256 * k1, 16, 16, b->roughness, cos_o);
        double albedo = scale * E * (f0 + (1.0 - f0) * s_dir);
        weight *= bsdf_clamp01(1.0 - albedo);
    }
    for (int c = 0; c < 3; c++)
        out[c] += weight * b->base[c] * cos_i * M_1_PI;
}

/* ---- Sampling, for path tracing (kernel.h gi_plan_bounces) and the world light's surface technique
 * (world.h surface_sample): a direction is drawn from the diffuse lobe (cosine) or the GGX lobe
 * (visible normals, Heitz 2018), chosen by their rough weights; its density is the mixture's, so
 * any direction's throughput is bsdf_eval / density.
 * Perfectly smooth lobes (alpha^2 <= 2e-10, which bsdf_eval treats as mirrors no light direction
 * hits) are not sampled. Needs ub_sincos (ubmath.h). */

/* An orthonormal frame (t, s, n) about unit n (Duff et al. 2017). */
static inline void bsdf_frame(const float n[3], double t[3], double s[3])
{
    double sign = n[2] >= 0.0f ? 1.0 : -1.0;
    double a = -1.0 / (sign + n[2]), b = n[0] * n[1] * a;
    t[0] = 1.0 + sign * n[0] * n[0] * a;
    t[1] = sign * b;
    t[2] = -sign * n[0];
    s[0] = b;
    s[1] = sign + n[1] * n[1] * a;
    s[2] = -(double)n[1];
}

/* Probability of drawing from the GGX lobe: the specular layers' rough share of the light (the
 * metal's whole weight, the dielectric's F0) against the diffuse base's (luminance of the base
 * colour); between 0.1 and 0.9 where both lobes reflect, so neither is starved. */
static inline double bsdf_specular_probability(const ub_bsdf *b)
{
    double alpha = b->roughness * b->roughness;
    if (!(alpha * alpha > 2e-10))
        return 0.0;
    double specular = b->metallic + (1.0 - b->metallic) * (b->eta != 1.0 ? bsdf_clamp01(b->specular_f0) : 0.0);
    double diffuse = (1.0 - b->metallic) * ub_luminance(b->base[0], b->base[1], b->base[2]);
    if (!(specular > 0.0))
        return 0.0;
    if (!(diffuse > 0.0))
        return 1.0;
    double p = specular / (specular + diffuse);
    return p < 0.1 ? 0.1 : (p > 0.9 ? 0.9 : p);
}

/* Density per steradian of GGX visible-normal sampling from wo toward wi (reflection):
 * D(h) G1(wo) / (4 cos_o), with bsdf_eval's clamp of cos_o. */
static double bsdf_ggx_pdf(const ub_bsdf *b, const float n[3], const double wo[3], const double wi[3])
{
    double cos_i = n[0] * wi[0] + n[1] * wi[1] + n[2] * wi[2];
    if (!(cos_i > 0.0))
        return 0.0;
    const double cos_o = bsdf_view_cosine(n, wo);
    double alpha = b->roughness * b->roughness, alpha2 = alpha * alpha;
    double h[3] = {wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]};
    double len = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
    if (!(alpha2 > 2e-10) || !(len > 0.0))
        return 0.0;
    return bsdf_ggx_D(alpha2, n, h, len) / (1.0 + bsdf_lambda(alpha2, cos_o)) / (4.0 * cos_o);
}

/* A GGX visible normal for wo by (r1, r2) in [0, 1)^2 (Heitz 2018, isotropic), and wo mirrored
 * about it into wi. Returns 0 if wi falls below the surface. */
static int bsdf_ggx_sample(const ub_bsdf *b, const float n[3], const double wo[3], double r1, double r2,
                           double wi[3])
{
    double t[3], s[3];
    bsdf_frame(n, t, s);
    double alpha = b->roughness * b->roughness;
    double lo[3] = {t[0] * wo[0] + t[1] * wo[1] + t[2] * wo[2], s[0] * wo[0] + s[1] * wo[1] + s[2] * wo[2],
                    n[0] * wo[0] + n[1] * wo[1] + n[2] * wo[2]};
    if (!(lo[2] > 0.0))
        lo[2] = 1e-6;
    double vh[3] = {alpha * lo[0], alpha * lo[1], lo[2]};
    double vlen = sqrt(vh[0] * vh[0] + vh[1] * vh[1] + vh[2] * vh[2]);
    for (int k = 0; k < 3; k++)
        vh[k] /= vlen;
    double lensq = vh[0] * vh[0] + vh[1] * vh[1];
    double T1[3] = {1.0, 0.0, 0.0};
    if (lensq > 0.0) {
        double inv = 1.0 / sqrt(lensq);
        T1[0] = -vh[1] * inv;
        T1[1] = vh[0] * inv;
    }
    double T2[3] = {vh[1] * T1[2] - vh[2] * T1[1], vh[2] * T1[0] - vh[0] * T1[2], vh[0] * T1[1] - vh[1] * T1[0]};
    double r = sqrt(r1), phi = 2.0 * M_PI * r2, sp, cp;
    ub_sincos(phi, &sp, &cp);
    double p1 = r * cp, p2 = r * sp, half = 0.5 * (1.0 + vh[2]);
    double rest = 1.0 - p1 * p1;
    p2 = (1.0 - half) * sqrt(rest > 0.0 ? rest : 0.0) + half * p2;
    double up = 1.0 - p1 * p1 - p2 * p2;
    up = sqrt(up > 0.0 ? up : 0.0);
    double nh[3];
    for (int k = 0; k < 3; k++)
        nh[k] = p1 * T1[k] + p2 * T2[k] + up * vh[k];
    double m[3] = {alpha * nh[0], alpha * nh[1], nh[2] > 0.0 ? nh[2] : 0.0};
    double mlen = sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
    if (!(mlen > 0.0))
        return 0;
    double mw[3];
    for (int k = 0; k < 3; k++)
        mw[k] = (m[0] * t[k] + m[1] * s[k] + m[2] * n[k]) / mlen;
    double dot = wo[0] * mw[0] + wo[1] * mw[1] + wo[2] * mw[2];
    for (int k = 0; k < 3; k++)
        wi[k] = 2.0 * dot * mw[k] - wo[k];
    return n[0] * wi[0] + n[1] * wi[1] + n[2] * wi[2] > 0.0;
}

/* What a path's next bounce may draw at one hit, and how likely: the density of the bounce
 * technique is scale x ((1 - p_specular) diffuse_allowed cos / pi + p_specular specular_allowed
 * ggx_pdf); scale holds the chances of going on at all (not mirrored, Russian roulette). The
 * world's light (world.h) weighs its map samples against it. */
typedef struct {
    double scale, p_specular;
    int diffuse_allowed, specular_allowed;
} ub_bounce_density;

/* That density toward unit wi (b NULL: Lambert, the diffuse lobe alone). */
static double bounce_density(const ub_bounce_density *bd, const ub_bsdf *b, const float n[3], const double wo[3],
                             const double wi[3])
{
    double c = n[0] * wi[0] + n[1] * wi[1] + n[2] * wi[2];
    if (!(c > 0.0))
        return 0.0;
    double p = bd->diffuse_allowed ? (1.0 - bd->p_specular) * c * M_1_PI : 0.0;
    if (b && bd->specular_allowed && bd->p_specular > 0.0)
        p += bd->p_specular * bsdf_ggx_pdf(b, n, wo, wi);
    return bd->scale * p;
}

#endif
