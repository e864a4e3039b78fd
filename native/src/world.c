/* The World's map as a light: the distribution its samples are drawn from (scene.h, ub_world),
 * built once per render, serially, so every thread and kernel reads the same numbers. */
#include "scene.h"
#include "ubmath.h"

#include <stdlib.h>

/* Running sums of `n` weights into cdf[0..n], normalised to end at 1; an all-zero row gets the
 * uniform CDF (never sampled: the marginal gives it no weight). Returns the total. */
static double build_cdf(const double *weights, int n, float *cdf)
{
    double total = 0.0;
    for (int i = 0; i < n; i++)
        total += weights[i];
    double running = 0.0;
    cdf[0] = 0.0f;
    for (int i = 0; i < n; i++) {
        running += weights[i];
        cdf[i + 1] = total > 0.0 ? (float)(running / total) : (float)((double)(i + 1) / n);
    }
    cdf[n] = 1.0f;
    return total;
}

const char *ub_world_prepare(ub_world *world, const float *rgb, int w, int h)
{
    world->w = w;
    world->h = h;
    world->rgb = rgb;
    world->sum = 0.0;
    world->row_cdf = malloc((size_t)(h + 1) * sizeof(float));
    world->col_cdf = malloc((size_t)h * (size_t)(w + 1) * sizeof(float));
    world->row_sin = malloc((size_t)h * sizeof(float));
    double *weights = malloc((size_t)(w > h ? w : h) * sizeof(double));
    double *row_weight = malloc((size_t)h * sizeof(double));
    if (!world->row_cdf || !world->col_cdf || !world->row_sin || !weights || !row_weight) {
        free(weights);
        free(row_weight);
        ub_world_release(world);
        return "out of memory for the world map's distribution";
    }
    for (int j = 0; j < h; j++) {
        /* Row j's centre lies at polar angle pi (1 - (j + 0.5) / h) (row 0 the nadir's). */
        double s = ub_sin(M_PI * (j + 0.5) / h);
        world->row_sin[j] = (float)s;
        /* Luminance only shapes the distribution; the estimate stays unbiased whatever the
         * weights, as long as a lit texel has a positive one. */
        for (int i = 0; i < w; i++) {
            const float *t = rgb + ((size_t)j * w + i) * 3;
            weights[i] = ub_luminance(t[0], t[1], t[2]) * s;
        }
        row_weight[j] = build_cdf(weights, w, world->col_cdf + (size_t)j * (w + 1));
    }
    world->sum = build_cdf(row_weight, h, world->row_cdf);
    free(weights);
    free(row_weight);
    return NULL;
}

void ub_world_release(ub_world *world)
{
    free(world->row_cdf);
    free(world->col_cdf);
    free(world->row_sin);
    world->row_cdf = world->col_cdf = world->row_sin = NULL;
}
