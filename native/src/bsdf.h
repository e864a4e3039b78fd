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
    double cos_o = n[0] * wo[0] + n[1] * wo[1] + n[2] * wo[2];
    double cos_i = n[0] * wi[0] + n[1] * wi[1] + n[2] * wi[2];
    for (int c = 0; c < 3; c++)
        out[c] = 0.0;
    if (!(cos_i > 0.0))
        return;
    cos_o = cos_o > 1e-6 ? (cos_o < 1.0 ? cos_o : 1.0) : 1e-6;
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
            double cos_nh = (n[0] * h[0] + n[1] * h[1] + n[2] * h[2]) / len;
            cos_h = bsdf_clamp01((wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2]) / len);
            double c2 = cos_nh * cos_nh < 1.0 ? cos_nh * cos_nh : 1.0;
            double d = 1.0 - c2 + alpha2 * c2;
            double D = alpha2 / (M_PI * d * d);
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

#endif
