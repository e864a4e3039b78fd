/* The render kernel, written once against the vf/vm vector interface and compiled twice
 * (kernel_avx2.c, kernel_portable.c). A packet is UB_LANES pixels: a block of 4 x 4 or 4 x 2 where
 * camera rays are marched (chunk_primary) and shaded in one phase (shade_chunk), a run of a row
 * where the two-phase render shades from the hit buffer; each lane follows its own ray and the
 * packet runs until all lanes are done. Lanes never interact, so a pixel's value does not depend
 * on the packet, tile or thread that computed it.
 *
 * A render runs, for each anti-aliasing sample, two phases over the film: phase 0 marches the
 * camera rays into a hit buffer (the r^2 memory of the paper, plus a one-pixel apron), phase 1
 * shades every hit (normals, lights, shadows, AO, reflections, fog, glow) and accumulates the
 * passes. The Z-buffer normals of eq. 12-14 read the neighbours' hits from the buffer; without
 * them one phase marches and shades each packet in turn (UB_PHASE_TRACE_AND_SHADE). */
#ifndef KERNEL_SUFFIX
#error "define KERNEL_SUFFIX and include a simd_*.h header before kernel.h"
#endif

#include "scene.h"
#include "camera_projection.h"
#include "ubmath.h" /* exp, pow, sin: the same bits on every platform */

#include <float.h>
#include <math.h>
#include <string.h>

/* Each kernel file is its own translation unit, so everything here is static and keeps its
 * plain name; only the entry points scene.h declares get the kernel's suffix (_avx2, _portable),
 * as Cycles' kernel_arch.h suffixes only its entry points. */
#define UB_CAT2(a, b) a##b
#define UB_CAT(a, b) UB_CAT2(a, b)
#define UB_ENTRY(name) UB_CAT(name, KERNEL_SUFFIX)

/* Whether the render was cancelled. Every loop whose body can be long polls it, so the work
 * between two polls stays bounded at any setting the parameter table allows (issue 16: a
 * packet's normals, AO, sea waves and shadows, a march's steps and bisection, the IFS search);
 * tests/native/test_cancel_grid.py holds it to 100 ms at the limits. After a cancel the
 * results are garbage and are discarded (the caller returns at its next poll). */
static inline int cancelled(const ub_scene *sc)
{
    return __atomic_load_n(sc->cancel, __ATOMIC_RELAXED) != 0;
}

#include "estimators.h"
#include "march.h"
#include "cone.h"
#include "bsdf.h"
#include "shading.h"

/* One anti-aliasing sample: its index and its sub-pixel offset (the same for every pixel). */
typedef struct {
    int index;
    double off[2];
} sample_point;

static sample_point sample_point_of(int sample)
{
    sample_point sp = {sample, {0.0, 0.0}};
    ub_sample_offset(sample, &sp.off[0], &sp.off[1]);
    return sp;
}

/* The full-image pixel of each lane of a packet: its random numbers are the pixel's (a row's
 * packet, or a block of rows: chunk_primary). */
typedef struct {
    int px[UB_LANES], py[UB_LANES];
} ub_lane_pixels;

/* Lane l < n is full-image pixel (px0 + step l, py); padding lanes repeat the last one. */
static void row_pixels(int px0, int py, int step, int n, ub_lane_pixels *pix)
{
    for (int l = 0; l < UB_LANES; l++) {
        pix->px[l] = px0 + step * (l < n ? l : n - 1);
        pix->py[l] = py;
    }
}

/* Camera ray of full-image pixel (px, py) in sample `sp`: at its sub-pixel offset and, with depth
 * of field, through the pixel's lens sample; 0 where a panoramic camera sees nothing. */
static int pixel_ray(const ub_camera *cam, int px, int py, const sample_point *sp, double o[3], double d[3],
                     double *t_min, double *t_max)
{
    double lens[2];
    if (cam->aperture > 0.0)
        ub_lens_sample(sp->index, px, py, lens);
    return ub_camera_ray(cam, px + sp->off[0], py + sp->off[1], cam->aperture > 0.0 ? lens : NULL, o, d, t_min,
                         t_max);
}

/* Camera rays of a projection camera without depth of field through image points (px[l], py[l]):
 * the lane loop of ub_camera_ray's arithmetic (camera_projection.h), which the compiler turns into
 * double-precision vector code, so the rays have ub_camera_ray's bits at a fraction of the cost of
 * one call per lane (issue 21: the rays' divides and square roots, lane by lane, took 12 % of a
 * render). Each lane's row terms come from its own py, so a packet may span rows (a block).
 * with_range 0: the t range is not wanted and left empty, which saves two of the three divides
 * and one of the two square roots; by_ratio: t_max from the camera's clip_depth_ratio (one of each).
 * Always inlined, so that `orthographic`, `with_range` and `by_ratio` are constants and the loop
 * has no branch. */
static inline __attribute__((always_inline)) void projection_packet(const ub_camera *restrict cam, int orthographic,
                                                                    int with_range, int by_ratio,
                                                                    const double px[UB_LANES],
                                                                    const double py[UB_LANES],
                                                                    ub_packet_rays *restrict pr)
{
    const double depth_ratio = cam->clip_depth_ratio;
    /* Local copies of what the lanes share: nothing the lanes write can alias them, so the
     * vectoriser loads them once (a copy of the whole camera cost a store-forwarding stall). */
    const ub_clip_plane_map clip_start = cam->clip_start, clip_end = cam->clip_end;
    double cam_to_world[3][4];
    memcpy(cam_to_world, cam->cam_to_world, sizeof cam_to_world);
    for (int l = 0; l < UB_LANES; l++) {
        double ov[3], dv[3], o[3], d[3], t_min, t_max;
        projection_row row;
        projection_row_of(&clip_start, &clip_end, py[l], &row);
        projection_ray_in_row(&row, orthographic, by_ratio, depth_ratio, px[l], ov, dv, &t_min, &t_max);
        pr->t_min[l] = with_range ? t_min : 0.0; /* unused: the compiler drops its arithmetic */
        pr->t_max[l] = with_range ? t_max : 0.0;
        view_to_world(cam_to_world, ov, dv, o, d);
        for (int i = 0; i < 3; i++) {
            pr->origin[i][l] = o[i];
            pr->dir[i][l] = d[i];
        }
        pr->t_base[l] = 0.0f;
    }
}

/* Camera rays of the full-image pixels (px[l], py[l]) (padding lanes repeat a real pixel: their
 * results are discarded). Returns the lanes whose pixel sees the scene: outside a panoramic
 * camera's lens a lane gets the view axis and an empty t range, and is not traced. with_range 0
 * (the shading phase, whose camera rays are not traced: their hits are in the hit buffer): a
 * projection camera's rays may come with an empty t range. */
static int camera_rays(const ub_camera *cam, const int px[UB_LANES], const int py[UB_LANES], const sample_point *sp,
                       int with_range, ub_packet_rays *pr)
{
    if (cam->panorama == UB_PANORAMA_NONE && !(cam->aperture > 0.0)) {
        double image_x[UB_LANES], image_y[UB_LANES];
        for (int l = 0; l < UB_LANES; l++) {
            image_x[l] = px[l] + sp->off[0];
            image_y[l] = py[l] + sp->off[1];
        }
        if (cam->orthographic && with_range)
            projection_packet(cam, 1, 1, 0, image_x, image_y, pr);
        else if (cam->orthographic)
            projection_packet(cam, 1, 0, 0, image_x, image_y, pr);
        else if (with_range && cam->clip_depth_ratio > 0.0)
            projection_packet(cam, 0, 1, 1, image_x, image_y, pr);
        else if (with_range)
            projection_packet(cam, 0, 1, 0, image_x, image_y, pr);
        else
            projection_packet(cam, 0, 0, 0, image_x, image_y, pr);
        return UB_ALL_LANES;
    }
    int seen = 0;
    for (int l = 0; l < UB_LANES; l++) {
        double o[3], d[3];
        if (pixel_ray(cam, px[l], py[l], sp, o, d, &pr->t_min[l], &pr->t_max[l]))
            seen |= 1 << l;
        else
            for (int i = 0; i < 3; i++)
                d[i] = cam->forward[i];
        for (int i = 0; i < 3; i++) {
            pr->origin[i][l] = o[i];
            pr->dir[i][l] = d[i];
        }
        pr->t_base[l] = 0.0f;
    }
    return seen;
}

/* Packets of camera rays are blocks of UB_BLOCK_W x UB_BLOCK_H pixels (4 x 4 with 16 lanes, 4 x 2
 * with 8), marched, shaded and written as blocks (issue 21). A packet runs until its last lane is
 * done, so its lanes are only as busy as its rays are alike: on the peer frame a pair of the rows'
 * packets of 16 kept 52 % of its lanes marching a step, a pair of 4 x 4 blocks 72 % (8 lanes: 66 %
 * and 77 %; each pixel's camera ray's steps, counted over the frame), and the shadow, World and
 * reflection rays of a block's hits are alike in the same way. Each lane's ray, march, random
 * numbers (its own pixel's) and shading are its own, so every pass has the bits it has in any
 * other packet. (The blocks used to take their rays from the rows' packets and give their paths
 * back to them for the passes: those copies were 5 % of the peer render.) */
#if UB_LANES >= 16
#define UB_BLOCK_H 4
#else
#define UB_BLOCK_H 2
#endif
#define UB_BLOCK_W (UB_LANES / UB_BLOCK_H)
/* A chunk: UB_BLOCK_H rows of 2 UB_LANES pixels, 2 UB_BLOCK_H blocks side by side. */
#define UB_CHUNK_BLOCKS (2 * UB_BLOCK_H)

typedef struct {
    ub_packet_rays bp[UB_CHUNK_BLOCKS];
    ub_trace_result bt[UB_CHUNK_BLOCKS];
    /* The pixels each block holds (rows and columns from its corner; 0: the tile ends before
     * it), and its lanes that are pixels (valid), of which `seen` see the scene and `traced`
     * are marched. */
    int rows[UB_CHUNK_BLOCKS], cols[UB_CHUNK_BLOCKS];
    int valid[UB_CHUNK_BLOCKS], block_seen[UB_CHUNK_BLOCKS], block_traced[UB_CHUNK_BLOCKS];
    /* Every ray of the block lies in empty cones: no rays, no trace (skip_background). */
    int background[UB_CHUNK_BLOCKS];
} ub_chunk;

/* The column and row (of the chunk's grid, from its pixel (x, y)) of lane l of block b. */
static inline int block_column(int x, int b, int l)
{
    return x + b * UB_BLOCK_W + l % UB_BLOCK_W;
}

static inline int block_row(int y, int l)
{
    return y + l / UB_BLOCK_W;
}

/* The lanes of `rows` rows of `cols` pixels in a packet whose rows are `stride` lanes apart. */
static inline int grid_lanes(int rows, int cols, int stride)
{
    int lanes = 0;
    for (int r = 0; r < rows; r++)
        lanes |= ((1 << cols) - 1) << (r * stride);
    return lanes;
}

/* The full-image pixels (x0 + step column, y0 + step row) of block b of the chunk at (x, y), whose
 * pixels are rows x cols; padding lanes repeat the nearest pixel of the block. Not unrolled: GCC
 * unrolled the lane loop into a store per lane, which camera_rays' vector loads of px and py then
 * waited on; as a loop it is vector code (issue 21: the peer render 1.008-1.018x, AVX2 1.008x). */
static void block_pixels(int x0, int y0, int step, int x, int y, int b, int rows, int cols, ub_lane_pixels *pix)
{
    const int last_col = cols - 1, last_row = rows - 1, px0 = x0 + step * (x + b * UB_BLOCK_W), py0 = y0 + step * y;
    _Pragma("GCC unroll 1")
    for (int l = 0; l < UB_LANES; l++) {
        const int lc = l % UB_BLOCK_W, lr = l / UB_BLOCK_W;
        pix->px[l] = px0 + step * (lc < last_col ? lc : last_col);
        pix->py[l] = py0 + step * (lr < last_row ? lr : last_row);
    }
}

/* The camera rays of the chunk's blocks (hit-buffer pixels from (x, y), up to x_end, y_end), from
 * their shared first steps. With skip_background, blocks all of whose rays lie in empty cones
 * (UB_CONE_EMPTY) get none. */
static void chunk_rays(const ub_scene *sc, const sample_point *sp, int skip_background, int x, int y, int x_end,
                       int y_end, ub_chunk *ch)
{
    const ub_hit_buffer *hb = sc->hits;
    const int rows = y_end - y < UB_BLOCK_H ? y_end - y : UB_BLOCK_H;
    for (int b = 0; b < UB_CHUNK_BLOCKS; b++) {
        const int left = x_end - (x + b * UB_BLOCK_W);
        const int cols = left <= 0 ? 0 : (left < UB_BLOCK_W ? left : UB_BLOCK_W);
        ch->rows[b] = rows;
        ch->cols[b] = cols;
        ch->valid[b] = grid_lanes(rows, cols, UB_BLOCK_W);
        ch->block_seen[b] = ch->block_traced[b] = ch->background[b] = 0;
        if (!cols)
            continue;
        ub_lane_pixels pix;
        block_pixels(hb->x0, hb->y0, hb->step, x, y, b, rows, cols, &pix);
        double start[UB_LANES];
        int empty = 0;
        if (sc->cones) { /* shared first steps: each ray starts where its cone is empty */
            empty = lane_starts(sc->cones, pix.px, pix.py, start);
        }
        ch->background[b] = skip_background && (empty & ch->valid[b]) == ch->valid[b];
        if (ch->background[b])
            continue;
        ub_packet_rays *pr = &ch->bp[b];
        const int seen = camera_rays(sc->camera, pix.px, pix.py, sp, 1, pr);
        /* Lanes outside a panoramic camera's lens, or in an empty cone, come back as misses
         * (UB_HIT_NONE). */
        if (sc->cones)
            cone_start_rays(start, pr);
        ch->block_seen[b] = ch->valid[b] & seen;
        ch->block_traced[b] = ch->valid[b] & seen & ~empty;
    }
}

/* The camera rays and hits of the chunk at hit-buffer pixel (x, y), in its blocks, marched two
 * blocks at a time where pairs pay (pair_traceable); blocks with rays to march are paired with
 * each other, wherever they are in the chunk. */
static void chunk_primary(const ub_scene *sc, const ub_de_params *dps, const sample_point *sp, int pairs,
                          int skip_background, int x, int y, int x_end, int y_end, ub_chunk *ch, ub_counters *cnt)
{
    chunk_rays(sc, sp, skip_background, x, y, x_end, y_end, ch);
    int busy[UB_CHUNK_BLOCKS], n_busy = 0;
    const unsigned flags = sc->shading->sea ? UB_TRACE_SEA : 0;
    for (int b = 0; b < UB_CHUNK_BLOCKS; b++) {
        if (!ch->valid[b] || ch->background[b])
            continue;
        if (ch->block_traced[b] && pairs)
            busy[n_busy++] = b;
        else /* nothing to march (the misses' results), or no pairs */
            trace(sc, dps, &ch->bp[b], ch->block_traced[b], flags, NULL, &ch->bt[b], cnt);
    }
    /* Four at a time (two interleaved pairs), then a pair, then the odd one out. */
    for (int i = 0; i < n_busy;) {
        const int n = n_busy - i >= 4 ? 4 : (n_busy - i >= 2 ? 2 : 1);
        if (n == 1) {
            trace(sc, dps, &ch->bp[busy[i]], ch->block_traced[busy[i]], flags, NULL, &ch->bt[busy[i]], cnt);
            break;
        }
        const ub_packet_rays *group[4];
        ub_trace_result *group_tr[4];
        int group_lanes[4];
        for (int j = 0; j < n; j++) {
            group[j] = &ch->bp[busy[i + j]];
            group_tr[j] = &ch->bt[busy[i + j]];
            group_lanes[j] = ch->block_traced[busy[i + j]];
        }
        if (n == 4)
            trace_two_pairs(sc, dps, group, group_lanes, flags, group_tr, cnt);
        else
            trace_pair(sc, dps, group, group_lanes, flags, group_tr, cnt);
        i += n;
    }
    for (int b = 0; b < UB_CHUNK_BLOCKS; b++) {
        if (!ch->valid[b] || ch->background[b]) /* (the background blocks' rays count in tile_shade) */
            continue;
        uint64_t steps = 0;
        for (int l = 0; l < UB_LANES; l++) /* a sum of selects: vector code */
            steps += (ch->valid[b] >> l) & 1 ? (uint64_t)ch->bt[b].steps[l] : 0;
        cnt->rays += (uint64_t)__builtin_popcount((unsigned)ch->valid[b]);
        cnt->steps += steps;
    }
}

/* The de_params of the scene's objects, for one tile. */
static void tile_de_params(const ub_scene *sc, ub_de_params dps[UB_MAX_OBJECTS])
{
    for (int k = 0; k < sc->object_count; k++) {
        de_params(&sc->objects[k], sc->camera, &dps[k]);
        dps[k].cancel = sc->cancel;
    }
}

static void tile_primary(const ub_scene *sc, int sample, int tx0, int ty0, int tx1, int ty1,
                                ub_counters *cnt)
{
    const ub_hit_buffer *hb = sc->hits;
    ub_de_params dps[UB_MAX_OBJECTS];
    tile_de_params(sc, dps);
    const sample_point sp = sample_point_of(sample);
    if (sc->cones)
        cone_fill(sc, dps, tx0, ty0, tx1, ty1, cnt);
    const int pairs = pair_traceable(sc, dps);
    ub_chunk ch;
    for (int y = ty0; y < ty1; y += UB_BLOCK_H) {
        for (int x = tx0; x < tx1; x += 2 * UB_LANES) {
            if (__atomic_load_n(sc->cancel, __ATOMIC_RELAXED))
                return;
            chunk_primary(sc, dps, &sp, pairs, 0, x, y, tx1, ty1, &ch, cnt);
            for (int b = 0; b < UB_CHUNK_BLOCKS; b++)
                for (int l = 0; l < UB_LANES; l++) {
                    if (!((ch.valid[b] >> l) & 1))
                        continue;
                    const ub_trace_result *tr = &ch.bt[b];
                    hb->hits[(size_t)block_row(y, l) * hb->w + block_column(x, b, l)] =
                        (ub_hit){tr->t[l], tr->iters[l], tr->dist[l], tr->steps[l], (int16_t)tr->object[l],
                                 (int16_t)tr->out_of_steps[l]};
                }
        }
    }
}

/* World position of the hit of buffer pixel (bx, by), or 0 if it is not a hit on `object`. */
static int buffer_point(const ub_scene *sc, const sample_point *sp, int bx, int by, int object, double p[3],
                               float *t)
{
    const ub_hit_buffer *hb = sc->hits;
    if (bx < 0 || by < 0 || bx >= hb->w || by >= hb->h)
        return 0;
    const ub_hit *h = &hb->hits[(size_t)by * hb->w + bx];
    if (h->object != object)
        return 0;
    double o[3], d[3], t0, t1;
    if (!pixel_ray(sc->camera, hb->x0 + hb->step * bx, hb->y0 + hb->step * by, sp, o, d, &t0, &t1))
        return 0;
    for (int i = 0; i < 3; i++)
        p[i] = o[i] + (double)h->t * d[i];
    *t = h->t;
    return 1;
}

/* Eq. 12-14 with the neighbours' actual hit points (exact under perspective): the normal of the
 * plane through the hit and its right/up neighbours. Of the two neighbours on an axis, the one
 * nearer in depth on the same object is used, so silhouettes do not bend the normal. */
static int zbuffer_normal(const ub_scene *sc, const sample_point *sp, int bx, int by, int object, const double p[3],
                                 float t, const double dir[3], double n[3])
{
    double e[2][3];
    for (int axis = 0; axis < 2; axis++) {
        double best = HUGE_VAL;
        int found = 0;
        for (int side = 1; side >= -1; side -= 2) {
            double q[3];
            float tq;
            int ok = axis == 0 ? buffer_point(sc, sp, bx + side, by, object, q, &tq)
                               : buffer_point(sc, sp, bx, by + side, object, q, &tq);
            if (!ok || !(fabs((double)tq - t) < best))
                continue;
            best = fabs((double)tq - t);
            for (int i = 0; i < 3; i++)
                e[axis][i] = side * (q[i] - p[i]);
            found = 1;
        }
        if (!found)
            return 0;
    }
    n[0] = e[0][1] * e[1][2] - e[0][2] * e[1][1];
    n[1] = e[0][2] * e[1][0] - e[0][0] * e[1][2];
    n[2] = e[0][0] * e[1][1] - e[0][1] * e[1][0];
    double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(len > 0.0) || !isfinite(len))
        return 0;
    double s = (n[0] * dir[0] + n[1] * dir[1] + n[2] * dir[2]) > 0.0 ? -1.0 / len : 1.0 / len;
    for (int i = 0; i < 3; i++)
        n[i] *= s;
    return 1;
}

/* Gradient step of eq. 15 for the default delta = 1: h = alpha t (ub_pow(t, 1) is t itself,
 * without its tests per lane), world units. Of alpha, not the object: a lane loop over it, with
 * alpha in a local, is vector code (read from the object it was not: 0.970x). */
static inline double gradient_step_linear(double alpha, double t)
{
    return alpha * (t > 0.0 ? t : 0.0);
}

/* Gradient step of eq. 15, h = alpha Gamma(t), Gamma(t) = t^delta (Table 1), world units. */
static inline double gradient_step(const ub_object *o, double t)
{
    if (o->normal_delta == 1.0)
        return gradient_step_linear(o->normal_alpha, t);
    return o->normal_alpha * ub_pow(t > 0.0 ? t : 0.0, o->normal_delta);
}

/* Per-lane state of one bounce of the shading phase. */
typedef struct {
    double p[3][UB_LANES];  /* hit point, world */
    float n[3][UB_LANES];   /* unit normal facing the incoming ray */
    float albedo[3][UB_LANES];
    float trap[UB_LANES];
    float reflectivity[UB_LANES];
    float bias[UB_LANES];   /* offset of secondary ray origins off the surface */
    /* Lanes on an object with a material: its BSDF, emission and alpha there. */
    int bsdf_lanes;
    ub_bsdf bsdf[UB_LANES];
    float emission[3][UB_LANES];
    float alpha[UB_LANES];
} ub_surface;

/* The BSDF, emission and alpha of the lanes on objects with a material, from the attributes at
 * their hits (after the normals: a material can read them). The albedo (ambient light, the
 * Denoising Albedo pass) is the base colour. */
static void surface_materials(const ub_scene *sc, const ub_trace_result *tr, ub_surface *sf)
{
    for (int l = 0; l < UB_LANES; l++) {
        if (!((sf->bsdf_lanes >> l) & 1))
            continue;
        const ub_object *o = &sc->objects[tr->object[l]];
        ub_hit_attributes h = {sf->trap[l], tr->iters[l], tr->dist[l], {sf->p[0][l], sf->p[1][l], sf->p[2][l]},
                               {sf->n[0][l], sf->n[1][l], sf->n[2][l]}};
        bsdf_at(o, &h, &sf->bsdf[l]);
        for (int i = 0; i < 3; i++) {
            sf->albedo[i][l] = (float)sf->bsdf[l].base[i];
            sf->emission[i][l] = o->material.emission[i];
        }
        sf->alpha[l] = o->material.alpha;
    }
}

/* Normals, colour and trap of the hits in `hit_lanes` of one bounce. */
static void surface(const ub_scene *sc, const ub_de_params *dps, const sample_point *sp, int bounce, int fx,
                           int fy, const ub_packet_rays *pr, const ub_trace_result *tr,
                           int hit_lanes, int want_trap, ub_surface *sf, ub_counters *cnt)
{
    const ub_shading *sh = sc->shading;
    const ub_hit_buffer *hb = sc->hits;
    double nw[3][UB_LANES];
    int have_normal = 0, sea_lanes = 0;
    sf->bsdf_lanes = 0;
    /* The hit points: every lane, then a select (issue 21: with a branch a lane, GCC left this
     * loop scalar, 1.5 % of the peer render), each as origin + t dir. */
#ifdef VD_LANES
    for (int h = 0; h < UB_LANES; h += VD_LANES) {
        const vdm hit = vdm_lanes_at(hit_lanes, h);
        const vd t = vd_load_floats(tr->t + h);
        for (int i = 0; i < 3; i++)
            vd_store(sf->p[i] + h, vd_select(hit, vd_add(vd_load(pr->origin[i] + h), vd_mul(t, vd_load(pr->dir[i] + h))),
                                            vd_set1(0.0)));
    }
#else
    for (int l = 0; l < UB_LANES; l++)
        for (int i = 0; i < 3; i++)
            sf->p[i][l] = ((hit_lanes >> l) & 1) ? pr->origin[i][l] + (double)tr->t[l] * pr->dir[i][l] : 0.0;
#endif
    for (int l = 0; l < UB_LANES; l++) {
        for (int i = 0; i < 3; i++) {
            nw[i][l] = 0.0;
            /* Every lane has a value: add_surface_light computes all of them (and keeps the hits'). */
            sf->albedo[i][l] = sf->emission[i][l] = 0.0f;
        }
        sf->trap[l] = 0.0f;
        sf->reflectivity[l] = 0.0f;
        sf->bias[l] = 0.0f;
        sf->alpha[l] = 1.0f;
    }
    if (sh->sea)
        sea_lanes = hit_lanes & lanes_int_eq(tr->object, UB_HIT_SEA);
    for (int k = 0; k < sc->object_count; k++) {
        if (cancelled(sc))
            return;
        const ub_object *o = &sc->objects[k];
        const int mine = hit_lanes & lanes_int_eq(tr->object, k);
        if (!mine)
            continue;
        float hb_[UB_LANES], e0[UB_LANES], e1[UB_LANES];
        double back_p[3][UB_LANES];
        int simd_lanes = mine;
        v_store(e0, dps[k].eps0);
        v_store(e1, dps[k].eps1);
        /* Normals and the orbit trap are evaluated a few float ulps of the object's size back
         * along the ray: a hit right where the ray enters the bounding ball (mu = 0: the ball is
         * the set) otherwise lands inside by rounding half the time, where the orbit collapses to
         * 0 and the Jacobian with it. Far below the gradient step, so eq. 15 does not notice.
         * A zoomed object's size near its anchor is its local unit, not the view's cut ball. */
        const double size = o->zoom.enabled ? 1.0 : fabs(o->bound_radius);
        const double back = 1e-6 * o->sigma_min * (1.0 + size);
        /* Every lane at once, without branches (vector code; issue 21: lane by lane with a
         * branch each, this loop was 3 % of the peer render); lanes of other objects keep what
         * they have and take any finite step. */
        const double alpha = o->normal_alpha, sigma_min = o->sigma_min;
        const int linear = o->normal_delta == 1.0;
        const float reflectivity = o->reflectivity;
        float bias[UB_LANES];
        UB_VECTOR_LOOP
        for (int l = 0; l < UB_LANES; l++) {
            for (int i = 0; i < 3; i++)
                back_p[i][l] = sf->p[i][l] - back * pr->dir[i][l];
            const int m = (mine >> l) & 1;
            const double path = (double)pr->t_base[l] + tr->t[l];
            hb_[l] = m ? (float)(gradient_step_linear(alpha, path) / sigma_min) : 1.0f; /* delta 1; else below */
            /* Secondary rays start a few hit thresholds off the surface. */
            bias[l] = 4.0f * (e0[l] + e1[l] * (float)path);
        }
        /* (stored through v_store_lanes, not `x = m ? y : x` in the loop: simd_avx2.h) */
        const vm mine_mask = m_from_bits(mine);
        v_store_lanes(sf->bias, mine_mask, v_load(bias));
        v_store_lanes(sf->reflectivity, mine_mask, v_set1(reflectivity));
        const int zbuffer = o->normal_method == UB_NORMAL_ZBUFFER && bounce == 0;
        for (int l = 0; l < UB_LANES && (!linear || zbuffer); l++) {
            if (!((mine >> l) & 1))
                continue;
            if (!linear)
                hb_[l] = (float)(gradient_step(o, (double)pr->t_base[l] + tr->t[l]) / o->sigma_min);
            if (zbuffer) {
                double p[3] = {sf->p[0][l], sf->p[1][l], sf->p[2][l]}, n[3];
                double d[3] = {pr->dir[0][l], pr->dir[1][l], pr->dir[2][l]};
                if (zbuffer_normal(sc, sp, fx + l + hb->apron_x, fy + hb->apron_y, k,
                                          p, tr->t[l], d, n)) {
                    for (int i = 0; i < 3; i++)
                        nw[i][l] = n[i];
                    simd_lanes &= ~(1 << l);
                    have_normal |= 1 << l;
                }
            }
        }
        vf qv[4];
        quaternion_lanes(o, back_p, qv);
        if (simd_lanes) {
            vf g[3];
            object_normal(o, &dps[k], m_from_bits(simd_lanes), qv, v_load(hb_), g, &cnt->normal_iterations);
            float gb[3][UB_LANES];
            for (int a = 0; a < 3; a++)
                v_store(gb[a], g[a]);
            /* Normals transform with the inverse transpose of object -> world: every lane, then
             * a select, in double vectors where the kernel has them (issue 21: GCC left the lane
             * loop scalar, 1.9 % of the peer render), each sum in the lane loop's order. */
            const double(*w)[4] = o->world_to_object;
#ifdef VD_LANES
            for (int h = 0; h < UB_LANES; h += VD_LANES) {
                const vd gd[3] = {vd_load_floats(gb[0] + h), vd_load_floats(gb[1] + h), vd_load_floats(gb[2] + h)};
                const vdm keep = vdm_lanes_at(simd_lanes, h);
                for (int i = 0; i < 3; i++) {
                    const double column[3] = {w[0][i], w[1][i], w[2][i]};
                    vd_store_lanes(nw[i] + h, keep, vd_row_dot(column, gd));
                }
            }
#else
            for (int l = 0; l < UB_LANES; l++)
                for (int i = 0; i < 3; i++) {
                    const double n = w[0][i] * gb[0][l] + w[1][i] * gb[1][l] + w[2][i] * gb[2][l];
                    nw[i][l] = (simd_lanes >> l) & 1 ? n : nw[i][l];
                }
#endif
            have_normal |= simd_lanes;
        }
        const ub_material *mat = &o->material;
        int need_trap = want_trap || o->color_mode == UB_COLOR_ORBIT_TRAP
                     || (mat->enabled && (mat->base_color_map.source == UB_ATTRIBUTE_ORBIT_TRAP
                                          || mat->metallic_map.source == UB_ATTRIBUTE_ORBIT_TRAP
                                          || mat->roughness_map.source == UB_ATTRIBUTE_ORBIT_TRAP));
        float tb[UB_LANES] = {0};
        if (need_trap) {
            vf dist, it;
            ub_de_extra x;
            de_ext(&dps[k], m_from_bits(mine), qv[0], qv[1], qv[2], qv[3], UB_WANT_TRAP, &dist, &it, &x);
            v_store(tb, x.trap);
        }
        for (int l = 0; l < UB_LANES; l++) {
            if (!((mine >> l) & 1))
                continue;
            sf->trap[l] = tb[l];
            float c[3];
            albedo(o, tb[l], tr->iters[l], c);
            for (int i = 0; i < 3; i++)
                sf->albedo[i][l] = c[i];
            if (mat->enabled)
                sf->bsdf_lanes |= 1 << l;
        }
    }
    if (sea_lanes) {
        float sn[3][UB_LANES];
        sea_normal(sc, dps, sf->p, sn);
        for (int l = 0; l < UB_LANES; l++) {
            if (!((sea_lanes >> l) & 1))
                continue;
            for (int i = 0; i < 3; i++) {
                nw[i][l] = sn[i][l];
                sf->albedo[i][l] = sh->sea_color[i];
            }
            sf->reflectivity[l] = sh->sea_reflectivity;
            sf->bias[l] = (float)(1e-4 * (1.0 + (double)pr->t_base[l] + tr->t[l]));
            have_normal |= 1 << l;
        }
    }
    /* Unit normals facing the ray, every lane at once (a loop of selects the compiler vectorises;
     * lanes that hit nothing get the flat one): issue 21, lane by lane with branches this was a
     * quarter of surface()'s time. */
    for (int l = 0; l < UB_LANES; l++) {
        const double d[3] = {pr->dir[0][l], pr->dir[1][l], pr->dir[2][l]};
        double n[3] = {nw[0][l], nw[1][l], nw[2][l]};
        double len2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
        /* Flat estimate (deep inside the set, or no normal): face the viewer. */
        const int flat = !((have_normal >> l) & 1) || !(len2 > 0.0) || len2 == INFINITY;
        for (int i = 0; i < 3; i++)
            n[i] = flat ? -d[i] : n[i];
        len2 = flat ? 1.0 : len2;
        const double inv = 1.0 / sqrt(len2);
        const double facing = n[0] * d[0] + n[1] * d[1] + n[2] * d[2] > 0.0 ? -inv : inv;
        for (int i = 0; i < 3; i++)
            sf->n[i][l] = (float)(n[i] * facing);
    }
    if (sf->bsdf_lanes)
        surface_materials(sc, tr, sf);
}

/* The material's BSDF at lane l's hit (bsdf_eval, its cosine included) toward unit wi, seen along
 * the lane's ray. */
static void lane_bsdf_eval(const ub_surface *sf, const ub_packet_rays *pr, int l, const double wi[3], double f[3])
{
    const float n[3] = {sf->n[0][l], sf->n[1][l], sf->n[2][l]};
    const double wo[3] = {-pr->dir[0][l], -pr->dir[1][l], -pr->dir[2][l]};
    bsdf_eval(&sf->bsdf[l], n, wo, wi, f);
}

#include "world.h"

/* Unit directions toward the light at the eye from each lane's hit: back along the camera ray at
 * the first bounce, against the view axis for an orthographic camera, else toward the camera's
 * position. One loop per case, each without branches. */
static void axle_directions(const ub_camera *cam, int bounce, const ub_packet_rays *pr, const ub_surface *sf,
                            double toward[3][UB_LANES])
{
    if (bounce == 0 || cam->orthographic) {
        for (int i = 0; i < 3; i++)
            for (int l = 0; l < UB_LANES; l++)
                toward[i][l] = bounce == 0 ? -pr->dir[i][l] : -cam->forward[i];
        return;
    }
    for (int l = 0; l < UB_LANES; l++) {
        double t[3], len = 0.0;
        for (int i = 0; i < 3; i++) {
            t[i] = cam->position[i] - sf->p[i][l];
            len += t[i] * t[i];
        }
        len = sqrt(len);
        for (int i = 0; i < 3; i++)
            toward[i][l] = len > 0.0 ? t[i] / len : 0.0;
    }
}

/* Direct light at the hits of one bounce: the axle light and the scene's lights, Lambertian
 * (albedo / pi per unit of irradiance; the axle light is in units of the paper's shading,
 * albedo * cos), with shadow rays toward each light. `world` (or NULL): a packet of the world's
 * shadow rays, marched with the first light whose shadows are hard where the kernel pairs
 * packets (world->traced then says so, and world->st holds what they hit). */
static void direct_light(const ub_scene *sc, const ub_de_params *dps, int bounce, int lanes,
                                const ub_packet_rays *pr, const ub_trace_result *tr,
                                const ub_surface *sf, ub_world_rays *world, float direct[3][UB_LANES],
                                float shadow[UB_LANES], ub_counters *cnt)
{
    const ub_shading *sh = sc->shading;
    const ub_camera *cam = sc->camera;
    float lit[UB_LANES] = {0}, unshadowed[UB_LANES] = {0};
    for (int l = 0; l < UB_LANES; l++)
        for (int i = 0; i < 3; i++)
            direct[i][l] = 0.0f;
    if (sh->axle_light != 0.0f) {
        /* The Lambertian lanes at once, as selects (issue 21: lane by lane with branches this was
         * most of direct_light's time on the peer scene); the lanes with a material through their
         * BSDF, one by one. Two loops the compiler vectorises: each lane's light first (-0 where
         * none: x + -0 is x, bit for bit), then the sums. As one loop, `direct = lit ? direct +
         * light : direct`, GCC 12 made the store conditional and kept the loop scalar (AVX2
         * 1.02x; AVX-512 1.00x). */
        double toward[3][UB_LANES];
        axle_directions(cam, bounce, pr, sf, toward);
        const int plain = lanes & ~sf->bsdf_lanes, material = lanes & sf->bsdf_lanes;
        const double axle = sh->axle_light;
        float axle_lit[UB_LANES];
        for (int l = 0; l < UB_LANES; l++) {
            const double c = sf->n[0][l] * toward[0][l] + sf->n[1][l] * toward[1][l] + sf->n[2][l] * toward[2][l];
            const float light = (float)(axle * c);
            axle_lit[l] = ((plain >> l) & 1) && c > 0.0 ? light : -0.0f;
        }
        for (int i = 0; i < 3; i++)
            for (int l = 0; l < UB_LANES; l++)
                direct[i][l] += axle_lit[l];
        for (int l = 0; material >> l; l++) {
            if (!((material >> l) & 1))
                continue;
            /* In the paper's units: pi times the BSDF, which is albedo * cos for Lambert. */
            const double wi[3] = {toward[0][l], toward[1][l], toward[2][l]};
            double f[3];
            lane_bsdf_eval(sf, pr, l, wi, f);
            for (int i = 0; i < 3; i++)
                direct[i][l] += (float)(sh->axle_light * M_PI * f[i]);
        }
    }
    for (int j = 0; j < sh->light_count && !cancelled(sc); j++) {
        const ub_light *L = &sh->lights[j];
        double E[3][UB_LANES], cosv[UB_LANES];
        int cand = 0;
        ub_packet_rays sr;
        float tan_angle[UB_LANES];
        for (int l = 0; l < UB_LANES; l++) {
            sr.t_base[l] = 0.0f;
            sr.t_min[l] = 0.0;
            sr.t_max[l] = 0.0;
            tan_angle[l] = 0.0f;
            for (int i = 0; i < 3; i++)
                sr.origin[i][l] = sr.dir[i][l] = 0.0;
            sr.dir[2][l] = 1.0;
            cosv[l] = 0.0; /* (read, not used, by the sums' vector code below) */
            for (int i = 0; i < 3; i++)
                E[i][l] = 0.0;
            if (!((lanes >> l) & 1))
                continue;
            double p[3] = {sf->p[0][l], sf->p[1][l], sf->p[2][l]}, dl[3], dist, e[3], ta;
            if (!light_sample(L, p, dl, &dist, e, &ta))
                continue;
            double c = sf->n[0][l] * dl[0] + sf->n[1][l] * dl[1] + sf->n[2][l] * dl[2];
            if (!(c > 0.0))
                continue;
            /* The sea is opaque: a light below it does not reach a point above it. */
            if (sh->sea && p[2] > sh->sea_height + sf->bias[l]
                && (dist == HUGE_VAL ? dl[2] < 0.0 : p[2] + dist * dl[2] < sh->sea_height))
                continue;
            cand |= 1 << l;
            cosv[l] = c;
            for (int i = 0; i < 3; i++)
                E[i][l] = e[i] * M_1_PI;
            if ((sf->bsdf_lanes >> l) & 1) {
                /* The material's BSDF (its cosine included) instead of Lambert's albedo / pi. */
                double f[3];
                lane_bsdf_eval(sf, pr, l, dl, f);
                cosv[l] = 1.0;
                for (int i = 0; i < 3; i++)
                    E[i][l] = e[i] * f[i];
            }
            for (int i = 0; i < 3; i++) {
                sr.origin[i][l] = p[i] + sf->bias[l] * sf->n[i][l];
                sr.dir[i][l] = dl[i];
            }
            sr.t_min[l] = sf->bias[l];
            sr.t_max[l] = dist == HUGE_VAL ? 1e30 : dist;
            sr.t_base[l] = pr->t_base[l] + tr->t[l];
            tan_angle[l] = (float)ta;
        }
        if (!cand)
            continue;
        float vis[UB_LANES];
        for (int l = 0; l < UB_LANES; l++)
            vis[l] = 1.0f;
        if (sh->shadows != UB_SHADOWS_NONE && L->cast_shadow) {
            ub_trace_result st;
            int soft = sh->shadows == UB_SHADOWS_SOFT;
            if (world && world->cand && !soft && pair_traceable(sc, dps)) {
                /* The world's packet of shadow rays with this light's, in one loop (trace_pair). */
                const ub_packet_rays *const both[2] = {&sr, &world->sr};
                const int both_lanes[2] = {cand, world->cand};
                ub_trace_result *const both_st[2] = {&st, &world->st};
                trace_pair(sc, dps, both, both_lanes, UB_TRACE_ANY_HIT, both_st, cnt);
                world->traced = 1;
                world = NULL;
            } else {
                trace(sc, dps, &sr, cand, UB_TRACE_ANY_HIT, soft ? tan_angle : NULL, &st, cnt);
            }
            for (int l = 0; l < UB_LANES; l++) {
                if (!((cand >> l) & 1))
                    continue;
                cnt->steps += (uint64_t)st.steps[l];
                if (st.object[l] != UB_HIT_NONE)
                    vis[l] = 0.0f;
                else if (soft && tan_angle[l] > 0.0f)
                    vis[l] = st.penumbra[l] * st.penumbra[l] * (3.0f - 2.0f * st.penumbra[l]);
            }
        }
        /* The candidates' sums: every lane computed, the candidates' stored (v_store_lanes). */
        float direct_sum[3][UB_LANES], unshadowed_sum[UB_LANES], lit_sum[UB_LANES];
        UB_VECTOR_LOOP
        for (int l = 0; l < UB_LANES; l++) {
            float sum = 0.0f;
            for (int i = 0; i < 3; i++) {
                float e = (float)(E[i][l] * cosv[l]);
                direct_sum[i][l] = direct[i][l] + e * vis[l];
                sum += e;
            }
            unshadowed_sum[l] = unshadowed[l] + sum;
            lit_sum[l] = lit[l] + sum * vis[l];
        }
        const vm cand_mask = m_from_bits(cand);
        for (int i = 0; i < 3; i++)
            v_store_lanes(direct[i], cand_mask, v_load(direct_sum[i]));
        v_store_lanes(unshadowed, cand_mask, v_load(unshadowed_sum));
        v_store_lanes(lit, cand_mask, v_load(lit_sum));
    }
    for (int l = 0; l < UB_LANES; l++)
        shadow[l] = unshadowed[l] > 0.0f ? lit[l] / unshadowed[l] : 1.0f;
}

/* The lights' and the world's direct light at the hits of one bounce (direct_light, world_light).
 * Where the world's light is one packet of shadowed samples (world_single_packet: the add-on's
 * default grey World), its shadow rays are marched with the first hard-shadowed light's in one
 * loop (issue 21: on an artist's first scene, where the shadow rays take most of the time, F12
 * 1.10x). The same sums in the same order as direct_light, then world_light. */
static void lights_and_world(const ub_scene *sc, const ub_de_params *dps, const sample_point *sp,
                             const ub_lane_pixels *pix, int bounce, int lanes, const ub_packet_rays *pr,
                             const ub_trace_result *tr, const ub_surface *sf, const ub_bounce_density *bounces,
                             float direct[3][UB_LANES], float shadow[UB_LANES], ub_counters *cnt)
{
    if (!world_single_packet(sc, bounces)) {
        direct_light(sc, dps, bounce, lanes, pr, tr, sf, NULL, direct, shadow, cnt);
        world_light(sc, dps, sp, pix, bounce, lanes, pr, tr, sf, bounces, direct, cnt);
        return;
    }
    ub_world_rays wr;
    world_sample_rays(sc, sp, pix, bounce, lanes, pr, tr, sf, bounces, 0, 1, &wr);
    direct_light(sc, dps, bounce, lanes, pr, tr, sf, &wr, direct, shadow, cnt);
    if (!wr.cand)
        return;
    if (!wr.traced) /* no light took them along */
        trace(sc, dps, &wr.sr, wr.cand, UB_TRACE_ANY_HIT, NULL, &wr.st, cnt);
    world_sample_add(sc, &wr, &wr.st, direct, cnt);
}

/* The film pixels of a packet's lanes: `rows` rows of `cols` pixels from pixel index idx on, the
 * film's rows `pitch` pixels apart; lane r * stride + c is pixel idx + r * pitch + c (a row's
 * packet: one row, stride UB_LANES; a block: stride UB_BLOCK_W). */
typedef struct {
    size_t idx, pitch;
    int rows, cols;
} ub_pixel_run;

/* Writes (sample 0) or accumulates (later samples) one pass's values of a packet's pixels, run u
 * (rows `stride` lanes apart): v[c][l] is channel c of lane l. The last sample divides by the
 * sample count. Data passes (depth, normal, position, ...) come from sample 0 alone: the pixel
 * centre, as with one sample. Always inlined with a constant channel count and stride, so that a
 * pass is a run of stores, not a call per pixel (issue 21: the calls, each testing its buffer,
 * kind and sample, were a third of the shading phase's own time). */
typedef enum { PASS_DATA = 0, PASS_AVERAGED = 1 } pass_kind;

/* put_lanes fetches this many packets' pixels ahead along the row, in cache lines of this many
 * floats. */
#define UB_PASS_PREFETCH 4
#define UB_CACHE_LINE_FLOATS 16

/* The pass's memory UB_PASS_PREFETCH packets on from a row's pixels at p (count x chans floats),
 * fetched for writing now: a frame's passes are far larger than the caches, and stores that miss
 * them stalled the packets' work (issue 21: the background's packets took 3x as long with
 * combined, alpha and depth as with combined alone, and the stores were 13 % of the peer render;
 * with the prefetch the peer render measured 1.27x faster). A prefetch never faults, past the
 * buffer's end too. */
static inline __attribute__((always_inline)) void prefetch_ahead(const float *p, int count, int chans)
{
    const float *ahead = p + (size_t)UB_PASS_PREFETCH * UB_LANES * (size_t)chans;
    for (int f = 0; f < count * chans; f += UB_CACHE_LINE_FLOATS)
        __builtin_prefetch(ahead + f, 1, 3);
}

static inline __attribute__((always_inline)) void put_lanes(float *restrict buf, const ub_pixel_run *u, int stride,
                                                            int chans, const float v[][UB_LANES], int sample,
                                                            int samples, pass_kind kind)
{
    if (!buf || (kind == PASS_DATA && sample != 0))
        return;
    if (sample == 0 && u->cols == stride && u->rows == UB_LANES / stride) {
#ifdef UB_HAVE_STORE_RGBA
        if (chans == 4) {
            /* Four lanes' pixels are 16 consecutive floats of a row (stride is a multiple of 4):
             * one interleaving in registers (issue 21: GCC's lane-by-lane stores of the combined
             * pass were 3 % of the peer render). */
            float *dst[UB_LANES / 4];
            for (int k = 0; k < UB_LANES / 4; k++)
                dst[k] = buf + (u->idx + (size_t)(4 * k / stride) * u->pitch + (size_t)(4 * k % stride)) * 4;
            for (int r = 0; r < UB_LANES / stride; r++)
                prefetch_ahead(buf + (u->idx + (size_t)r * u->pitch) * 4, stride, 4);
            v_store_rgba(dst, v_load(v[0]), v_load(v[1]), v_load(v[2]), v_load(v[3]));
            return;
        }
#endif
        /* The whole packet: a constant count of inline stores, not loops or a call to memcpy. */
        for (int r = 0; r < UB_LANES / stride; r++) {
            float *restrict p = buf + (u->idx + (size_t)r * u->pitch) * (size_t)chans;
            prefetch_ahead(p, stride, chans);
            for (int l = 0; l < stride; l++)
                for (int c = 0; c < chans; c++)
                    p[l * chans + c] = v[c][r * stride + l];
        }
        return;
    }
    const int last = sample == samples - 1;
    const float scale = 1.0f / (float)samples;
    for (int r = 0; r < u->rows; r++) {
        float *restrict p = buf + (u->idx + (size_t)r * u->pitch) * (size_t)chans;
        const int l0 = r * stride;
        prefetch_ahead(p, stride, chans);
        if (sample == 0) {
            for (int l = 0; l < u->cols; l++)
                for (int c = 0; c < chans; c++)
                    p[l * chans + c] = v[c][l0 + l];
            continue;
        }
        for (int l = 0; l < u->cols; l++) /* sample > 0 here, so samples > 1 */
            for (int c = 0; c < chans; c++) {
                float acc = p[l * chans + c] + v[c][l0 + l];
                p[l * chans + c] = last ? acc * scale : acc;
            }
    }
}

/* One packet's paths through its bounces: radiance L += W * (local light), W the path's
 * throughput after fog and reflectivity, Wr the throughput without the first segment's fog (for
 * the Reflection pass, whose sum is R); and what the camera rays found, kept for the passes. */
typedef struct {
    float L[3][UB_LANES], W[UB_LANES], Wr[UB_LANES], R[3][UB_LANES];
    /* Global illumination: the colour of the path's throughput (W x tint; 1 without), its
     * bounces so far by kind, and the density its last bounce ray was drawn with (0: a mirror or
     * the camera, whose rays see the world in full). */
    float tint[3][UB_LANES];
    int diffuse_count[UB_LANES], glossy_count[UB_LANES];
    double bounce_density[UB_LANES];
    float pass_ao[UB_LANES], pass_shadow[UB_LANES], pass_trap[UB_LANES];
    float coverage[UB_LANES]; /* the first hit's alpha (a material's Alpha; 1 without) */
    float pass_diffuse[3][UB_LANES], pass_ambient[3][UB_LANES];
    double pos0[3][UB_LANES];
    float nrm0[3][UB_LANES];
    float albedo0[3][UB_LANES];
    float primary_steps[UB_LANES], primary_iters[UB_LANES], primary_dist[UB_LANES];
    int primary_obj[UB_LANES], primary_out_of_steps[UB_LANES];
    int unseen;             /* lanes outside a panoramic camera's lens */
} ub_paths;

/* The camera rays' hits of packet (x, y) from the hit buffer into tr, as trace gave them;
 * padding lanes repeat the last real pixel. */
static void buffered_hits(const ub_hit_buffer *hb, int x, int y, int n, ub_trace_result *tr)
{
    for (int l = 0; l < UB_LANES; l++) {
        int lx = x + (l < n ? l : n - 1);
        const ub_hit *h = &hb->hits[(size_t)(y + hb->apron_y) * hb->w + (lx + hb->apron_x)];
        tr->t[l] = h->t;
        tr->iters[l] = h->iterations;
        tr->dist[l] = h->distance;
        tr->steps[l] = h->steps;
        tr->object[l] = h->object;
        tr->out_of_steps[l] = h->out_of_steps;
    }
}

/* The empty paths of a packet whose camera rays found tr. */
static void start_paths(const ub_trace_result *tr, ub_paths *ps)
{
    for (int l = 0; l < UB_LANES; l++) {
        ps->W[l] = 1.0f;
        ps->Wr[l] = 0.0f;
        ps->pass_ao[l] = 1.0f;
        ps->pass_shadow[l] = 1.0f;
        ps->pass_trap[l] = 0.0f;
        ps->coverage[l] = 1.0f;
        ps->diffuse_count[l] = ps->glossy_count[l] = 0;
        ps->bounce_density[l] = 0.0;
        for (int i = 0; i < 3; i++) {
            ps->tint[i][l] = 1.0f;
            ps->L[i][l] = ps->R[i][l] = 0.0f;
            ps->pass_diffuse[i][l] = ps->pass_ambient[i][l] = 0.0f;
            ps->pos0[i][l] = 0.0;
            ps->nrm0[i][l] = 0.0f;
            ps->albedo0[i][l] = 0.0f;
        }
    }
    /* The camera rays' own results, kept for the passes: later bounces reuse tr. */
    memcpy(ps->primary_steps, tr->steps, sizeof ps->primary_steps);
    memcpy(ps->primary_iters, tr->iters, sizeof ps->primary_iters);
    memcpy(ps->primary_dist, tr->dist, sizeof ps->primary_dist);
    memcpy(ps->primary_obj, tr->object, sizeof ps->primary_obj);
    memcpy(ps->primary_out_of_steps, tr->out_of_steps, sizeof ps->primary_out_of_steps);
}

/* What a ray sees of the world along direction d: the background colour, or the world map (times
 * the background's alpha for camera rays: a transparent film hides the world from the camera, not
 * from reflections, as in Cycles). */
static void background_along(const ub_scene *sc, int bounce, const double d[3], float seen[3])
{
    const ub_film *film = sc->film;
    for (int i = 0; i < 3; i++)
        seen[i] = film->background[i];
    if (sc->world) {
        world_radiance(sc->world, d, seen);
        for (int i = 0; i < 3 && bounce == 0; i++)
            seen[i] *= film->background[3];
    }
}

/* Lanes of `alive` that missed everything see the world (unfogged, background_along); returns the
 * lanes that hit something. */
static int add_background(const ub_scene *sc, int bounce, int alive, const ub_packet_rays *pr,
                          const ub_trace_result *tr, ub_paths *ps)
{
    const int hit_lanes = alive & ~lanes_int_eq(tr->object, UB_HIT_NONE);
    const int missed = alive & ~hit_lanes;
    if (!sc->world) {
        /* The film's background colour alone: the same sums for every missed lane, as vector
         * selects (issue 21: the lane-by-lane calls were 4 % of the peer render, two thirds of
         * whose pixels miss; GCC left the lane loop that replaced them scalar). */
        const ub_film *film = sc->film;
        const vm m = m_from_bits(missed);
        for (int i = 0; i < 3; i++) {
            const vf background = v_set1(film->background[i]), tint = v_load(ps->tint[i]);
            const vf L = v_load(ps->L[i]);
            v_store_lanes(ps->L[i], m, v_add(L, v_mul(v_mul(v_load(ps->W), tint), background)));
            if (bounce > 0) {
                const vf R = v_load(ps->R[i]);
                v_store_lanes(ps->R[i], m, v_add(R, v_mul(v_mul(v_load(ps->Wr), tint), background)));
            }
        }
        return hit_lanes;
    }
    for (int l = 0; l < UB_LANES; l++) {
        if (!((missed >> l) & 1))
            continue;
        const double d[3] = {pr->dir[0][l], pr->dir[1][l], pr->dir[2][l]};
        float seen[3];
        background_along(sc, bounce, d, seen);
        /* A path's diffuse or glossy bounce ray: world_light sampled the map for the rest. */
        if (ps->bounce_density[l] > 0.0) {
            float share = (float)world_bounce_share(sc, d, ps->bounce_density[l]);
            for (int i = 0; i < 3; i++)
                seen[i] *= share;
        }
        for (int i = 0; i < 3; i++) {
            ps->L[i][l] += ps->W[l] * ps->tint[i][l] * seen[i];
            if (bounce > 0)
                ps->R[i][l] += ps->Wr[l] * ps->tint[i][l] * seen[i];
        }
    }
    return hit_lanes;
}

/* ---- Global illumination (shading use_gi): at every hit, after the lights and the world
 * (next-event estimation), the path goes on in one direction drawn from the surface: mirrored
 * with the surface's reflectivity (a glossy bounce), else from its BSDF (bsdf.h: cosine for
 * Lambert, diffuse or GGX lobe for a material), its throughput times BSDF x cos / density.
 * Bounces are limited as Cycles' Light Paths limit them; from the fourth on, Russian roulette
 * ends weak paths (throughput below 1) with the chance 1 - throughput and divides the survivors
 * by the rest. Every random number is random_uniform of the pixel, sample and a dimension of
 * its own, so paths do not depend on threads or tiles. */

enum { GI_STOP = 0, GI_MIRROR, GI_BSDF };
enum { GI_RR_START = 3, GI_DIM = 0x47490000 }; /* dimensions GI_DIM + 8 bounce + 0..4 */

typedef struct {
    int kind[UB_LANES];
    int glossy[UB_LANES];         /* GI_BSDF: drawn from the specular lobe */
    float mirror[UB_LANES];       /* the surface's mirrored fraction (0 where no mirror bounce is left) */
    float weight[3][UB_LANES];    /* throughput factor of the bounce */
    double dir[3][UB_LANES];      /* GI_BSDF: the drawn direction */
    double density[UB_LANES];     /* GI_BSDF: its density (bsdf.h bounce_density) */
    ub_bounce_density bd[UB_LANES]; /* what could have been drawn, for world_light */
} gi_plan;

/* The next bounce of each hit lane (of full-image pixel pix). */
static void gi_plan_bounces(const ub_shading *sh, const sample_point *sp, const ub_lane_pixels *pix, int bounce,
                            int hit_lanes, const ub_packet_rays *pr, const ub_surface *sf, const ub_paths *ps,
                            gi_plan *plan)
{
    for (int l = 0; l < UB_LANES; l++) {
        plan->kind[l] = GI_STOP;
        plan->glossy[l] = 0;
        plan->mirror[l] = 0.0f;
        plan->density[l] = 0.0;
        plan->bd[l] = (ub_bounce_density){0.0, 0.0, 0, 0};
        if (!((hit_lanes >> l) & 1))
            continue;
        int px = pix->px[l], py = pix->py[l], dim = GI_DIM + 8 * bounce;
        int more = bounce < sh->max_bounces;
        int glossy_ok = more && ps->glossy_count[l] < sh->glossy_bounces;
        int diffuse_ok = more && ps->diffuse_count[l] < sh->diffuse_bounces;
        float r = glossy_ok ? sf->reflectivity[l] : 0.0f;
        plan->mirror[l] = r;
        const ub_bsdf *b = (sf->bsdf_lanes >> l) & 1 ? &sf->bsdf[l] : NULL;
        double p_specular = b ? bsdf_specular_probability(b) : 0.0;
        double q = 1.0;
        if (bounce >= GI_RR_START) {
            float strongest = 0.0f;
            for (int i = 0; i < 3; i++)
                strongest = fmaxf(strongest, ps->W[l] * ps->tint[i][l]);
            q = strongest < 1.0f ? strongest : 1.0;
        }
        ub_bounce_density *bd = &plan->bd[l];
        bd->p_specular = p_specular;
        bd->diffuse_allowed = diffuse_ok && p_specular < 1.0;
        bd->specular_allowed = glossy_ok && p_specular > 0.0;
        bd->scale = bd->diffuse_allowed || bd->specular_allowed ? q * (1.0 - r) : 0.0;
        if (random_uniform(px, py, sp->index, dim + 1) >= q)
            continue; /* Russian roulette */
        if (random_uniform(px, py, sp->index, dim) < r) {
            plan->kind[l] = GI_MIRROR;
            for (int i = 0; i < 3; i++)
                plan->weight[i][l] = (float)(1.0 / q);
            continue;
        }
        if (!(bd->scale > 0.0))
            continue;
        int specular = random_uniform(px, py, sp->index, dim + 2) < p_specular;
        if (specular ? !bd->specular_allowed : !bd->diffuse_allowed)
            continue;
        float n[3] = {sf->n[0][l], sf->n[1][l], sf->n[2][l]};
        double wo[3] = {-pr->dir[0][l], -pr->dir[1][l], -pr->dir[2][l]}, wi[3], f[3];
        double r3 = random_uniform(px, py, sp->index, dim + 3), r4 = random_uniform(px, py, sp->index, dim + 4);
        if (specular) {
            if (!bsdf_ggx_sample(b, n, wo, r3, r4, wi))
                continue;
        } else {
            diffuse_sample(n, r3, r4, NULL, wi);
        }
        double density = bounce_density(bd, b, n, wo, wi);
        if (!(density > 0.0))
            continue;
        if (b) {
            bsdf_eval(b, n, wo, wi, f);
        } else {
            double c = diffuse_response(n, wi);
            for (int i = 0; i < 3; i++)
                f[i] = sf->albedo[i][l] * c;
        }
        plan->kind[l] = GI_BSDF;
        plan->glossy[l] = specular; /* Cycles counts a bounce by the lobe it drew from */
        plan->density[l] = density;
        for (int i = 0; i < 3; i++) {
            plan->dir[i][l] = wi[i];
            plan->weight[i][l] = (float)((1.0 - r) * f[i] / density);
        }
    }
}

/* The path of lane l after its planned bounce: its tint, counts and the density the world seen
 * next is weighed with. Returns 0 where the path ends. */
static int gi_continue(const gi_plan *plan, int l, ub_paths *ps)
{
    int kind = plan->kind[l];
    ps->bounce_density[l] = kind == GI_BSDF ? plan->density[l] : 0.0;
    if (kind == GI_STOP)
        return 0;
    for (int i = 0; i < 3; i++)
        ps->tint[i][l] *= plan->weight[i][l];
    if (kind == GI_MIRROR || plan->glossy[l])
        ps->glossy_count[l]++;
    else
        ps->diffuse_count[l]++;
    return 1;
}

/* What add_surface_light needs lane by lane through calls: the fog's transmittance 1 - f along
 * each hit lane's ray, and the world behind a material's alpha (zero elsewhere). */
static void surface_light_calls(const ub_scene *sc, int bounce, int hit_lanes, const ub_surface *sf,
                                const ub_trace_result *tr, const ub_packet_rays *pr, float fog[UB_LANES],
                                float behind[3][UB_LANES])
{
    const ub_shading *sh = sc->shading;
    for (int l = 0; l < UB_LANES; l++) {
        fog[l] = 0.0f;
        for (int i = 0; i < 3; i++)
            behind[i][l] = 0.0f;
    }
    if (sh->fog_density > 0.0)
        for (int l = 0; l < UB_LANES; l++)
            if ((hit_lanes >> l) & 1)
                fog[l] = (float)(1.0 - ub_exp(-sh->fog_density * tr->t[l]));
    const int see_through = hit_lanes & sf->bsdf_lanes;
    for (int l = 0; l < UB_LANES; l++) {
        /* A material's alpha: the surface covers that fraction; the world behind it (the
         * background colour or the World's map along the ray) shows through the rest. */
        if (!((see_through >> l) & 1) || !(sf->alpha[l] < 1.0f))
            continue;
        const double d[3] = {pr->dir[0][l], pr->dir[1][l], pr->dir[2][l]};
        float seen[3];
        background_along(sc, bounce, d, seen);
        for (int i = 0; i < 3; i++)
            behind[i][l] = seen[i];
    }
}

/* The local light of each hit lane (diffuse and ambient, fogged) into the paths, the first
 * bounce's passes, and the mirrored rays of the lanes that go on; returns those lanes. The light
 * is added to every lane at once and kept only in the hit lanes (a loop of selects the compiler
 * vectorises; issue 21: lane by lane with branches it was the largest part of shading the peer
 * scene); the calls (surface_light_calls) and the next rays stay lane by lane. */
static int add_surface_light(const ub_scene *sc, int bounce, int hit_lanes, const ub_surface *sf,
                             const float direct[3][UB_LANES], const float shadow[UB_LANES],
                             const float ao[UB_LANES], const ub_trace_result *tr, const gi_plan *plan,
                             ub_packet_rays *pr, ub_paths *ps)
{
    const ub_shading *sh = sc->shading;
    const int last = bounce >= sh->reflection_depth;
    /* With global illumination the bounces bring the light of the surroundings: no ambient term. */
    const float ambient_on = plan ? 0.0f : 1.0f;
    float fog[UB_LANES], behind[3][UB_LANES];
    surface_light_calls(sc, bounce, hit_lanes, sf, tr, pr, fog, behind);
    /* Each lane's reflected share r: without a further bounce the surface shows its own colour in
     * full. */
    float r[UB_LANES];
    for (int l = 0; l < UB_LANES; l++)
        r[l] = plan ? plan->mirror[l] : (last ? 0.0f : sf->reflectivity[l]);
    float dif[3][UB_LANES], amb[3][UB_LANES], light[3][UB_LANES];
    for (int i = 0; i < 3; i++) {
        const float ambient = sh->ambient[i], fog_color = sh->fog_color[i];
        for (int l = 0; l < UB_LANES; l++) {
            const float f = fog[l], a = sf->alpha[l], keep = 1.0f - r[l];
            /* Both ways for every lane, then one taken (a select, not a branch). With a material
             * the direct light went through its BSDF, colour included. */
            const float dif_material = keep * a * direct[i][l], dif_plain = keep * sf->albedo[i][l] * direct[i][l];
            const float amb_plain = keep * sf->albedo[i][l] * ambient * ao[l] * ambient_on, amb_material = amb_plain * a;
            const float local_plain = dif_plain + amb_plain;
            const float local_material = dif_material + amb_material + a * sf->emission[i][l] + (1.0f - a) * behind[i][l];
            const int mat = (sf->bsdf_lanes >> l) & 1;
            dif[i][l] = mat ? dif_material : dif_plain;
            amb[i][l] = mat ? amb_material : amb_plain;
            const float local = mat ? local_material : local_plain;
            light[i][l] = f * fog_color + (1.0f - f) * local;
        }
    }
    /* The hit lanes' sums as vectors (GCC left these lane loops scalar: issue 21), each lane's
     * L + (W tint) light in the lane loop's order. */
    const vm hit_mask = m_from_bits(hit_lanes);
    for (int i = 0; i < 3; i++) {
        const vf L = v_load(ps->L[i]), tint = v_load(ps->tint[i]), lit = v_load(light[i]);
        v_store_lanes(ps->L[i], hit_mask, v_add(L, v_mul(v_mul(v_load(ps->W), tint), lit)));
        if (bounce > 0) {
            const vf R = v_load(ps->R[i]);
            v_store_lanes(ps->R[i], hit_mask, v_add(R, v_mul(v_mul(v_load(ps->Wr), tint), lit)));
        } else {
            v_store_lanes(ps->pass_diffuse[i], hit_mask, v_load(dif[i]));
            v_store_lanes(ps->pass_ambient[i], hit_mask, v_load(amb[i]));
        }
    }
    /* The hit lanes' new weights, stored by v_store_lanes. */
    float new_wr[UB_LANES], new_w[UB_LANES];
    for (int l = 0; l < UB_LANES; l++) {
        const int mat = (sf->bsdf_lanes >> l) & 1;
        const float a = sf->alpha[l], kept = (1.0f - fog[l]) * (plan ? 1.0f : r[l]);
        /* With global illumination the Reflection pass follows the mirrored paths. */
        const float wr0 = plan ? (plan->kind[l] == GI_MIRROR ? 1.0f : 0.0f) : r[l], wr1 = ps->Wr[l] * kept;
        const float wr = bounce == 0 ? wr0 : wr1, wr_material = wr * a;
        /* Global illumination: the bounce's weight is in the tint (its chances included). */
        const float w = ps->W[l] * kept, w_material = w * a;
        new_wr[l] = mat ? wr_material : wr;
        new_w[l] = mat ? w_material : w;
    }
    v_store_lanes(ps->Wr, hit_mask, v_load(new_wr));
    v_store_lanes(ps->W, hit_mask, v_load(new_w));
    if (bounce == 0) {
        /* The first hit's data for the passes, as vector selects (issue 21: clang made the lane
         * loop scalar, a branch-free copy of one lane at a time). */
        for (int i = 0; i < 3; i++) {
            v_store_lanes(ps->nrm0[i], hit_mask, v_load(sf->n[i]));
            v_store_lanes(ps->albedo0[i], hit_mask, v_load(sf->albedo[i]));
#ifdef VD_LANES
            for (int h = 0; h < UB_LANES; h += VD_LANES)
                vd_store_lanes(ps->pos0[i] + h, vdm_lanes_at(hit_lanes, h), vd_load(sf->p[i] + h));
#else
            for (int l = 0; l < UB_LANES; l++)
                ps->pos0[i][l] = (hit_lanes >> l) & 1 ? sf->p[i][l] : ps->pos0[i][l];
#endif
        }
        v_store_lanes(ps->pass_ao, hit_mask, v_load(ao));
        v_store_lanes(ps->pass_shadow, hit_mask, v_load(shadow));
        v_store_lanes(ps->pass_trap, hit_mask, v_load(sf->trap));
        v_store_lanes(ps->coverage, hit_mask, v_load(sf->alpha));
    }
    /* The lanes whose paths go on: first as a bit word, so that a packet none of whose paths goes
     * on (no reflection) skips the loop, which the compiler otherwise runs as vectors over every
     * lane (issue 21: that was a quarter of the peer render with -fno-trapping-math). */
    int going = m_bits(v_gt(v_load(ps->W), v_set1(0.0f))) & hit_lanes, next = 0;
    for (int l = 0; going >> l; l++) {
        if (!((going >> l) & 1) || (plan && !gi_continue(plan, l, ps)))
            continue;
        /* Mirror reflection about the normal (which faces the incoming ray), or GI's drawn direction. */
        double d[3] = {pr->dir[0][l], pr->dir[1][l], pr->dir[2][l]};
        double dn = d[0] * sf->n[0][l] + d[1] * sf->n[1][l] + d[2] * sf->n[2][l];
        int drawn = plan && plan->kind[l] == GI_BSDF;
        for (int i = 0; i < 3; i++) {
            pr->dir[i][l] = drawn ? plan->dir[i][l] : d[i] - 2.0 * dn * sf->n[i][l];
            pr->origin[i][l] = sf->p[i][l] + sf->bias[l] * sf->n[i][l];
        }
        pr->t_base[l] += tr->t[l];
        pr->t_min[l] = sf->bias[l];
        pr->t_max[l] = 1e30;
        next |= 1 << l;
    }
    return next;
}

/* World-space unit vector n in Cycles' camera space (x right, y up, z along the view axis: the
 * space of Cycles' Denoising Normal pass), from the camera matrix's unit columns (camera.c). */
static void to_camera_space(const ub_camera *cam, const float n[3], float out[3])
{
    const double(*m)[4] = cam->cam_to_world;
    out[0] = (float)(n[0] * m[0][0] + n[1] * m[1][0] + n[2] * m[2][0]);
    out[1] = (float)(n[0] * m[0][1] + n[1] * m[1][1] + n[2] * m[2][1]);
    out[2] = (float)(n[0] * cam->forward[0] + n[1] * cam->forward[1] + n[2] * cam->forward[2]);
}

/* Every pass of the packet's pixels, run u (rows `stride` lanes apart), in sample `sample`; counts
 * the camera rays that ran out of steps. Each pass that is on is computed for all lanes at once
 * (loops the compiler vectorises), then written as a run; passes that are off cost nothing. */
static inline __attribute__((always_inline)) void write_passes_body(const ub_scene *sc, int sample,
                                                                    const ub_pixel_run *u, int stride,
                                                                    const ub_paths *ps, ub_counters *cnt)
{
    const ub_camera *cam = sc->camera;
    const ub_film *film = sc->film;
    const ub_shading *sh = sc->shading;
    float *const *pass = film->pass;
    const int S = sh->samples;
    const int lanes = grid_lanes(u->rows, u->cols, stride);
    const int hit_bits = UB_ALL_LANES & ~lanes_int_eq(ps->primary_obj, UB_HIT_NONE);
    int hit[UB_LANES];
    for (int l = 0; l < UB_LANES; l++)
        hit[l] = ps->primary_obj[l] != UB_HIT_NONE;
    /* Lanes outside a panoramic camera's lens were not traced: never out of steps. Counted from a
     * bit word, not by reading back the pass's lanes just stored one at a time: a vector load of
     * those stores waits for them to reach the cache (issue 21: that wait was a quarter of this
     * function's time on the peer scene). */
    const int gave_up = UB_ALL_LANES & ~lanes_int_eq(ps->primary_out_of_steps, 0) & ~ps->unseen;
    cnt->out_of_steps += (uint64_t)__builtin_popcount((unsigned)(gave_up & lanes));
    if (pass[UB_PASS_MAX_STEPS]) {
        float out_of_steps[1][UB_LANES];
        for (int l = 0; l < UB_LANES; l++)
            out_of_steps[0][l] = (gave_up >> l) & 1 ? 1.0f : 0.0f;
        put_lanes(pass[UB_PASS_MAX_STEPS], u, stride, 1, out_of_steps, sample, S, PASS_AVERAGED);
    }

    float glow[3][UB_LANES];
    if (pass[UB_PASS_COMBINED] || pass[UB_PASS_GLOW]) {
        const float glow_scale = 1.0f / 64.0f;
        if (sh->glow_strength > 0.0f)
            for (int l = 0; l < UB_LANES; l++) {
                float g = sh->glow_strength * (1.0f - ub_expf(-ps->primary_steps[l] * glow_scale));
                for (int i = 0; i < 3; i++)
                    glow[i][l] = g * sh->glow_color[i];
            }
        else /* what the loop above gives for g = 0: the colour is finite and not negative */
            memset(glow, 0, sizeof glow);
        put_lanes(pass[UB_PASS_GLOW], u, stride, 3, glow, sample, S, PASS_AVERAGED);
    }
    if (pass[UB_PASS_COMBINED] || pass[UB_PASS_ALPHA]) {
        float rgba[4][UB_LANES], alpha[1][UB_LANES];
        const vf bg_alpha = v_set1(film->background[3]), one = v_set1(1.0f), coverage = v_load(ps->coverage);
        /* Outside a panoramic camera's lens Cycles traces nothing and shows opaque black (with a
         * transparent film too): no background there. A material's alpha: the background's share
         * shows. As vectors (GCC left the lane loop scalar: issue 21). */
        const vm hit_mask = m_from_bits(hit_bits), covered = m_and(hit_mask, v_lt(coverage, one));
        const vf a = v_select(covered, coverage, v_select(hit_mask, one, v_set1(0.0f)));
        v_store(alpha[0], a);
        v_store(rgba[3], v_select(covered, v_add(a, v_mul(v_sub(one, a), bg_alpha)),
                                  v_select(m_or(hit_mask, m_from_bits(ps->unseen)), one, bg_alpha)));
        if (pass[UB_PASS_COMBINED]) {
            for (int i = 0; i < 3; i++) /* (as a lane loop GCC made it scalar) */
                v_store(rgba[i], v_add(v_load(ps->L[i]), v_load(glow[i])));
            put_lanes(pass[UB_PASS_COMBINED], u, stride, 4, rgba, sample, S, PASS_AVERAGED);
        }
        put_lanes(pass[UB_PASS_ALPHA], u, stride, 1, alpha, sample, S, PASS_AVERAGED);
    }
    if (pass[UB_PASS_DEPTH] && sample == 0) {
        /* Along the view axis, or for panoramic cameras the distance from the camera (Cycles'
         * camera_z_depth). */
        float depth[1][UB_LANES], real_z[UB_LANES];
        double d[UB_LANES];
        const double *c = cam->position, *f = cam->forward;
        /* Two loops, each without branches: vector code. */
        if (cam->panorama == UB_PANORAMA_NONE)
            for (int l = 0; l < UB_LANES; l++)
                d[l] = 0.0 + (ps->pos0[0][l] - c[0]) * f[0] + (ps->pos0[1][l] - c[1]) * f[1]
                     + (ps->pos0[2][l] - c[2]) * f[2];
        else
            for (int l = 0; l < UB_LANES; l++) {
                double r[3] = {ps->pos0[0][l] - c[0], ps->pos0[1][l] - c[1], ps->pos0[2][l] - c[2]};
                d[l] = sqrt(0.0 + r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
            }
        /* With it, the nearest hit's depth, a minimum per lane (a vector select: no reduction across
         * the lanes here; a NaN depth is no hit's). One loop: a second one reloaded the depths just
         * stored, a vector load of stores the compiler had partly made lane by lane, which waited
         * for them to reach the cache (issue 21). */
        UB_VECTOR_LOOP
        for (int l = 0; l < UB_LANES; l++) {
            const float z = hit[l] ? (float)d[l] : UB_BACKGROUND_DEPTH;
            const int real = ((lanes >> l) & 1) && hit[l] && z < 0.5f * UB_BACKGROUND_DEPTH;
            depth[0][l] = z;
            real_z[l] = real ? z : INFINITY;
        }
        /* min(real_z, nearest) = real && z < nearest ? z : nearest (v_min: a < b ? a : b), no
         * select of the stored value (a masked store, slow on AMD's cores) */
        v_store(cnt->nearest_lanes, v_min(v_load(real_z), v_load(cnt->nearest_lanes)));
        put_lanes(pass[UB_PASS_DEPTH], u, stride, 1, depth, sample, S, PASS_DATA);
    }
    /* The first hit's data, zero where the camera ray missed. */
    float v[3][UB_LANES];
    if (pass[UB_PASS_NORMAL] && sample == 0) {
        for (int i = 0; i < 3; i++)
            for (int l = 0; l < UB_LANES; l++)
                v[i][l] = hit[l] ? ps->nrm0[i][l] : 0.0f;
        put_lanes(pass[UB_PASS_NORMAL], u, stride, 3, v, sample, S, PASS_DATA);
    }
    if (pass[UB_PASS_POSITION] && sample == 0) {
        for (int i = 0; i < 3; i++)
            for (int l = 0; l < UB_LANES; l++)
                v[i][l] = hit[l] ? (float)ps->pos0[i][l] : 0.0f;
        put_lanes(pass[UB_PASS_POSITION], u, stride, 3, v, sample, S, PASS_DATA);
    }
    if (pass[UB_PASS_ITERATIONS] && sample == 0) {
        for (int l = 0; l < UB_LANES; l++)
            v[0][l] = hit[l] ? ps->primary_iters[l] : 0.0f;
        put_lanes(pass[UB_PASS_ITERATIONS], u, stride, 1, v, sample, S, PASS_DATA);
    }
    if (pass[UB_PASS_DISTANCE] && sample == 0) {
        for (int l = 0; l < UB_LANES; l++)
            v[0][l] = hit[l] ? ps->primary_dist[l] : 0.0f;
        put_lanes(pass[UB_PASS_DISTANCE], u, stride, 1, v, sample, S, PASS_DATA);
    }
    if (pass[UB_PASS_DENOISING_ALBEDO]) {
        for (int i = 0; i < 3; i++)
            for (int l = 0; l < UB_LANES; l++)
                v[i][l] = hit[l] ? ps->albedo0[i][l] : 0.0f;
        put_lanes(pass[UB_PASS_DENOISING_ALBEDO], u, stride, 3, v, sample, S, PASS_AVERAGED);
    }
    if (pass[UB_PASS_DENOISING_NORMAL]) {
        for (int l = 0; l < UB_LANES; l++) {
            const float normal[3] = {ps->nrm0[0][l], ps->nrm0[1][l], ps->nrm0[2][l]};
            float camera_normal[3];
            to_camera_space(cam, normal, camera_normal);
            for (int i = 0; i < 3; i++)
                v[i][l] = hit[l] ? camera_normal[i] : 0.0f;
        }
        put_lanes(pass[UB_PASS_DENOISING_NORMAL], u, stride, 3, v, sample, S, PASS_AVERAGED);
    }
    /* The rest as the paths left them. */
    put_lanes(pass[UB_PASS_STEPS], u, stride, 1, &ps->primary_steps, sample, S, PASS_AVERAGED);
    put_lanes(pass[UB_PASS_AO], u, stride, 1, &ps->pass_ao, sample, S, PASS_AVERAGED);
    put_lanes(pass[UB_PASS_SHADOW], u, stride, 1, &ps->pass_shadow, sample, S, PASS_AVERAGED);
    put_lanes(pass[UB_PASS_DIFFUSE], u, stride, 3, ps->pass_diffuse, sample, S, PASS_AVERAGED);
    put_lanes(pass[UB_PASS_AMBIENT], u, stride, 3, ps->pass_ambient, sample, S, PASS_AVERAGED);
    put_lanes(pass[UB_PASS_REFLECTION], u, stride, 3, ps->R, sample, S, PASS_AVERAGED);
    put_lanes(pass[UB_PASS_ORBIT_TRAP], u, stride, 1, &ps->pass_trap, sample, S, PASS_AVERAGED);
}

/* write_passes_body for a row's packet of n pixels at film row y, columns x.., and for block b of
 * the chunk at film pixel (x, y), whose pixels are rows x cols: each with its stride a constant. */
static void write_row_passes(const ub_scene *sc, int sample, int x, int y, int n, const ub_paths *ps,
                             ub_counters *cnt)
{
    const ub_pixel_run u = {(size_t)y * (size_t)sc->film->w + (size_t)x, (size_t)sc->film->w, 1, n};
    write_passes_body(sc, sample, &u, UB_LANES, ps, cnt);
}

static void write_block_passes(const ub_scene *sc, int sample, int x, int y, int b, int rows, int cols,
                               const ub_paths *ps, ub_counters *cnt)
{
    const size_t pitch = (size_t)sc->film->w;
    const ub_pixel_run u = {(size_t)y * pitch + (size_t)(x + b * UB_BLOCK_W), pitch, rows, cols};
    write_passes_body(sc, sample, &u, UB_BLOCK_W, ps, cnt);
}

/* The paths of a packet none of whose camera rays is traced (chunk_rays), without a World map
 * or with a constant one (Blender's default World): what tile_shade makes of its trace results
 * (nothing hit, no step) and the background, which then does not depend on the rays. Issue 21:
 * most of a frame's background is such packets, and their camera rays, clipping and paths were a
 * third of the peer render. */
static void background_paths(const ub_scene *sc, ub_paths *ps)
{
    ub_trace_result missed;
    memset(&missed, 0, sizeof missed);
    ub_packet_rays any; /* a constant World's radiance is the same along every direction */
    memset(&any, 0, sizeof any);
    for (int l = 0; l < UB_LANES; l++) {
        missed.object[l] = UB_HIT_NONE;
        for (int i = 0; i < 3; i++)
            any.dir[i][l] = sc->camera->forward[i];
    }
    start_paths(&missed, ps);
    ps->unseen = 0;
    add_background(sc, 0, UB_ALL_LANES, &any, &missed, ps);
}

/* What tile_shade's packets share. */
typedef struct {
    const ub_scene *sc;
    const ub_de_params *dps;
    sample_point sp;
    int sample, want_trap, use_ao;
} ub_tile_shading;

/* One packet's paths, bounce by bounce, into ps: lanes `lanes` (pixels pix) from their camera rays
 * pr and hits tr (both reused for the later bounces), of which `seen` see the scene. (fx, fy):
 * the hit-buffer pixel of lane 0 of a row's packet, which only the Z-buffer normals read (in the
 * two-phase render, whose packets are rows). Returns 0 when the render was cancelled. */
static int shade_paths(const ub_tile_shading *ts, const ub_lane_pixels *pix, int fx, int fy, int lanes, int seen,
                       ub_packet_rays *pr, ub_trace_result *tr, ub_paths *ps, ub_counters *cnt)
{
    const ub_scene *sc = ts->sc;
    const ub_de_params *dps = ts->dps;
    const ub_shading *sh = sc->shading;
    start_paths(tr, ps);
    int alive = lanes & seen;
    ps->unseen = ~seen;
    for (int bounce = 0; alive; bounce++) {
        if (bounce > 0) {
            trace(sc, dps, pr, alive, sh->sea ? UB_TRACE_SEA : 0, NULL, tr, cnt);
            for (int l = 0; l < UB_LANES; l++)
                if ((alive >> l) & 1)
                    cnt->steps += (uint64_t)tr->steps[l];
            if (cancelled(sc))
                return 0;
        }
        int hit_lanes = add_background(sc, bounce, alive, pr, tr, ps);
        if (!hit_lanes)
            break;
        ub_surface sf;
        surface(sc, dps, &ts->sp, bounce, fx, fy, pr, tr, hit_lanes, ts->want_trap && bounce == 0, &sf, cnt);
        if (cancelled(sc))
            return 0;
        float direct[3][UB_LANES], shadow[UB_LANES], ao[UB_LANES];
        gi_plan plan;
        if (sh->gi)
            gi_plan_bounces(sh, &ts->sp, pix, bounce, hit_lanes, pr, &sf, ps, &plan);
        lights_and_world(sc, dps, &ts->sp, pix, bounce, hit_lanes, pr, tr, &sf, sh->gi ? plan.bd : NULL, direct,
                         shadow, cnt);
        if (ts->use_ao)
            ambient_occlusion(sc, dps, hit_lanes, sf.p, sf.n, ao);
        else
            for (int l = 0; l < UB_LANES; l++)
                ao[l] = 1.0f;
        if (cancelled(sc))
            return 0;
        alive = add_surface_light(sc, bounce, hit_lanes, &sf, direct, shadow, ao, tr, sh->gi ? &plan : NULL, pr, ps);
    }
    return 1;
}

/* What write_row_passes stores for a row packet of `background` (background_paths) in sample
 * 0, where it stores the packet's values as they are: UB_LANES pixels of each pass that is on,
 * all alike, written once into a film of one row. Its runs are then copies of these pixels
 * (issue 21: most of a frame is background, and each run computed every pass again). Sample 0
 * only: later samples add into the film. */
typedef struct {
    int count, pass[UB_PASS_COUNT]; /* the passes that are on */
    float pixels[UB_PASS_COUNT][4 * UB_LANES];
} ub_background_row;

static void background_row(const ub_scene *sc, const ub_paths *background, ub_background_row *row)
{
    ub_film one_row = *sc->film;
    one_row.x0 = one_row.y0 = 0;
    one_row.w = UB_LANES;
    one_row.h = one_row.step = 1;
    row->count = 0;
    for (int k = 0; k < UB_PASS_COUNT; k++) {
        one_row.pass[k] = sc->film->pass[k] ? row->pixels[k] : NULL;
        if (sc->film->pass[k])
            row->pass[row->count++] = k;
    }
    ub_scene scene = *sc;
    scene.film = &one_row;
    ub_counters unused; /* a background packet counts nothing (no hit, never out of steps) */
    memset(&unused, 0, sizeof unused);
    write_row_passes(&scene, 0, 0, 0, UB_LANES, background, &unused);
}

/* background_row's pixels into the film's run of n pixels at (x, y). */
static void copy_background_run(const ub_film *film, const ub_background_row *row, int x, int y, int n)
{
    const size_t idx = (size_t)y * (size_t)film->w + (size_t)x;
    for (int j = 0; j < row->count; j++) {
        const int k = row->pass[j], chans = ub_pass_channels[k];
        float *restrict dst = film->pass[k] + idx * (size_t)chans;
        prefetch_ahead(dst, n, chans);
        /* A whole row packet (most runs) as copies of a size known when compiled: vector moves
         * inline, not a call to memcpy. */
        if (n == UB_LANES && chans == 4)
            memcpy(dst, row->pixels[k], 4 * UB_LANES * sizeof(float));
        else if (n == UB_LANES && chans == 1)
            memcpy(dst, row->pixels[k], UB_LANES * sizeof(float));
        else
            for (int f = 0; f < n * chans; f++)
                dst[f] = row->pixels[k][f];
    }
}

/* The passes of the chunk's background blocks (chunk_rays), at film pixel (x, y): row by row, a
 * run of adjacent blocks at a time, up to a row packet's UB_LANES pixels, since the lanes of
 * `background` are all alike (issue 21: most of a frame is such blocks, and a row of 16 pixels
 * is written with fewer instructions than four rows of four). With `row` (sample 0), copies of
 * its pixels. */
static void write_background_runs(const ub_tile_shading *ts, int x, int y, const ub_chunk *ch,
                                  const ub_paths *background, const ub_background_row *row, ub_counters *cnt)
{
    for (int r = 0; r < UB_BLOCK_H; r++)
        for (int b = 0; b < UB_CHUNK_BLOCKS;) {
            if (!ch->valid[b] || !ch->background[b] || r >= ch->rows[b]) {
                b++;
                continue;
            }
            const int x0 = x + b * UB_BLOCK_W;
            int n = 0;
            for (; b < UB_CHUNK_BLOCKS && ch->valid[b] && ch->background[b] && n + ch->cols[b] <= UB_LANES; b++)
                n += ch->cols[b];
            if (row)
                copy_background_run(ts->sc->film, row, x0, y + r, n);
            else
                write_row_passes(ts->sc, ts->sample, x0, y + r, n, background, cnt);
        }
}

/* Shades the chunk's blocks at film pixel (x, y) and writes their passes; blocks that see only the
 * film's background (chunk_rays) take theirs from `background`. Returns 0 when the render was
 * cancelled. */
static int shade_chunk(const ub_tile_shading *ts, int x, int y, ub_chunk *ch, const ub_paths *background,
                       const ub_background_row *row, ub_counters *cnt)
{
    const ub_scene *sc = ts->sc;
    const ub_film *film = sc->film;
    for (int b = 0; b < UB_CHUNK_BLOCKS; b++) {
        if (!ch->valid[b])
            continue;
        if (ch->background[b]) { /* (the traced blocks' rays count in chunk_primary) */
            cnt->rays += (uint64_t)__builtin_popcount((unsigned)ch->valid[b]);
            continue;
        }
        ub_lane_pixels pix;
        block_pixels(film->x0, film->y0, film->step, x, y, b, ch->rows[b], ch->cols[b], &pix);
        ub_paths ps; /* (its later bounces reuse the block's rays and hits) */
        if (!shade_paths(ts, &pix, x, y, ch->valid[b], ch->block_seen[b], &ch->bp[b], &ch->bt[b], &ps, cnt))
            return 0;
        write_block_passes(sc, ts->sample, x, y, b, ch->rows[b], ch->cols[b], &ps, cnt);
    }
    write_background_runs(ts, x, y, ch, background, row, cnt);
    return 1;
}

/* Phase 1 over one tile: each packet's paths bounce by bounce (shade_paths), then its passes.
 * The camera rays' hits come from the hit buffer, or with `trace_first`
 * (UB_PHASE_TRACE_AND_SHADE) from marching them right here, a chunk of blocks at a time
 * (chunk_primary, shade_chunk): the same hits (the buffer keeps trace's values exactly), without
 * the round trip of 20 bytes a pixel through memory and with one camera ray per pixel instead of
 * two. */
static void tile_shade(const ub_scene *sc, int trace_first, int sample, int tx0, int ty0, int tx1, int ty1,
                       ub_counters *cnt)
{
    const ub_camera *cam = sc->camera;
    const ub_film *film = sc->film;
    const ub_shading *sh = sc->shading;
    ub_de_params dps[UB_MAX_OBJECTS];
    tile_de_params(sc, dps);
    ub_tile_shading ts = {sc, dps, sample_point_of(sample), sample, film->pass[UB_PASS_ORBIT_TRAP] != NULL, 0};
    /* AO only changes the ambient term: without ambient light it is needed for its pass alone. */
    ts.use_ao = sh->ao_strength > 0.0f
             && ((!sh->gi && (sh->ambient[0] > 0.0f || sh->ambient[1] > 0.0f || sh->ambient[2] > 0.0f))
                 || film->pass[UB_PASS_AO] != NULL);
    if (!trace_first) {
        for (int y = ty0; y < ty1; y++)
            for (int x = tx0; x < tx1; x += UB_LANES) {
                if (cancelled(sc))
                    return;
                const int n = tx1 - x < UB_LANES ? tx1 - x : UB_LANES;
                const int px0 = film->x0 + film->step * x, py = film->y0 + film->step * y;
                ub_packet_rays pr;
                ub_trace_result tr;
                ub_lane_pixels pix;
                row_pixels(px0, py, film->step, n, &pix);
                int seen = camera_rays(cam, pix.px, pix.py, &ts.sp, 0, &pr);
                buffered_hits(sc->hits, x, y, n, &tr);
                ub_paths ps;
                if (!shade_paths(&ts, &pix, x, y, (1 << n) - 1, seen, &pr, &tr, &ps, cnt))
                    return;
                write_row_passes(sc, sample, x, y, n, &ps, cnt);
            }
        return;
    }
    if (sc->cones)
        cone_fill(sc, dps, tx0, ty0, tx1, ty1, cnt);
    const int pairs = pair_traceable(sc, dps);
    /* The paths of a packet that sees only the film's background (chunk_rays), made once. */
    const int background_only = sc->cones && (!sc->world || world_is_constant(sc->world));
    ub_paths background;
    ub_background_row row, *background_row_or_null = NULL;
    if (background_only) {
        background_paths(sc, &background);
        if (sample == 0) {
            background_row(sc, &background, &row);
            background_row_or_null = &row;
        }
    }
    ub_chunk ch;
    for (int y = ty0; y < ty1; y += UB_BLOCK_H)
        for (int x = tx0; x < tx1; x += 2 * UB_LANES) {
            if (cancelled(sc))
                return;
            chunk_primary(sc, dps, &ts.sp, pairs, background_only, x, y, tx1, ty1, &ch, cnt);
            if (cancelled(sc) || !shade_chunk(&ts, x, y, &ch, &background, background_row_or_null, cnt))
                return;
        }
}

void UB_ENTRY(ub_render_tile)(const ub_scene *sc, int phase, int sample, int tx0, int ty0, int tx1, int ty1,
                           ub_counters *cnt)
{
    if (phase == UB_PHASE_TRACE)
        tile_primary(sc, sample, tx0, ty0, tx1, ty1, cnt);
    else
        tile_shade(sc, phase == UB_PHASE_TRACE_AND_SHADE, sample, tx0, ty0, tx1, ty1, cnt);
}

/* ub_estimate's output of one packet's estimates (n points from base). */
static void estimate_store(const ub_object *o, const float *xyz, size_t base, size_t n, vf dist, vf it,
                           float *estimate, float *iterations)
{
    float db[UB_LANES], ib[UB_LANES];
    v_store(db, dist);
    v_store(ib, it);
    for (size_t l = 0; l < n; l++) {
        estimate[base + l] = db[l];
        iterations[base + l] = ib[l];
        /* Far points overflow float32 in the first iterations: inf/inf (NaN) or inf in the
         * estimate, or inf - inf in the orbit, which then never "escapes" and reads as a hit (0).
         * All impossible outside the bounding ball, where the set is not; the distance to the
         * ball is a lower bound there, and the orbit escaped at once. (Renders never ask: rays
         * are clipped to the ball.) */
        if (!(db[l] > 0.0f && db[l] < INFINITY)) {
            const float *p = xyz + 3 * (base + l);
            double rel[3] = {p[0] - o->bound_center[0], p[1] - o->bound_center[1], p[2] - o->bound_center[2]};
            double outside = sqrt(rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2]) - o->bound_radius;
            if (outside > 0.0) {
                /* Beyond float32's range the distance rounds down to its largest value. */
                estimate[base + l] = (float)fmin(outside, FLT_MAX);
                iterations[base + l] = 0.0f;
            }
        }
    }
}

/* The estimates at points, a packet at a time; a Julia set's (julia_only) two packets at a time
 * through de_julia_pair, as the march takes them, the same bits as de()'s one at a time: one
 * packet's iteration is a chain of dependent operations that leaves half of a Xeon's two 512-bit
 * FMA ports idle, which the second packet's fills (issue 21: bench_flops.py --ceiling reads the
 * loop the render runs). */
void UB_ENTRY(ub_estimate)(const ub_object *o, const float *xyz, size_t count, float *estimate, float *iterations)
{
    ub_de_params dp;
    de_params(o, NULL, &dp);
    const int packets = julia_only(&dp) ? 2 : 1;
    for (size_t base = 0; base < count; base += (size_t)packets * UB_LANES) {
        float q[2][4][UB_LANES];
        size_t n[2] = {0, 0}; /* points of each packet; the second only with packets = 2 */
        for (int k = 0; k < packets; k++) {
            size_t start = base + (size_t)k * UB_LANES;
            n[k] = start >= count ? 0 : count - start < UB_LANES ? count - start : UB_LANES;
        }
        vf z[2][4], dist[2], it[2];
        for (int k = 0; k < 2 && n[k]; k++) {
            point_packet(o, xyz, base + (size_t)k * UB_LANES, n[k], q[k]);
            for (int c = 0; c < 4; c++)
                z[k][c] = v_load(q[k][c]);
        }
        if (n[1])
            de_julia_pair(&dp, m_from_bits(UB_ALL_LANES), z[0], z[1], dist, it);
        else
            de(&dp, m_from_bits(UB_ALL_LANES), z[0][0], z[0][1], z[0][2], z[0][3], &dist[0], &it[0]);
        for (int k = 0; k < 2; k++)
            if (n[k])
                estimate_store(o, xyz, base + (size_t)k * UB_LANES, n[k], dist[k], it[k], estimate, iterations);
    }
}

void UB_ENTRY(ub_normals)(const ub_object *o, const float *xyz, const float *t, size_t count, float *normals)
{
    ub_de_params dp;
    de_params(o, NULL, &dp);
    for (size_t base = 0; base < count; base += UB_LANES) {
        float q[4][UB_LANES], h[UB_LANES];
        size_t n = count - base < UB_LANES ? count - base : UB_LANES;
        for (size_t l = 0; l < UB_LANES; l++) {
            size_t i = base + (l < n ? l : n - 1);
            double pd[3] = {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]};
            float ql[4];
            to_quaternion(o, pd, ql);
            for (int k = 0; k < 4; k++)
                q[k][l] = ql[k];
            h[l] = (float)(gradient_step(o, t[i]) / o->sigma_min);
        }
        vf qv[4] = {v_load(q[0]), v_load(q[1]), v_load(q[2]), v_load(q[3])}, g[3];
        object_normal(o, &dp, m_from_bits(UB_ALL_LANES), qv, v_load(h), g, NULL);
        float gb[3][UB_LANES];
        for (int a = 0; a < 3; a++)
            v_store(gb[a], g[a]);
        for (size_t l = 0; l < n; l++) {
            double len = sqrt((double)gb[0][l] * gb[0][l] + (double)gb[1][l] * gb[1][l] + (double)gb[2][l] * gb[2][l]);
            for (int a = 0; a < 3; a++)
                normals[3 * (base + l) + a] = len > 0.0 ? (float)(gb[a][l] / len) : 0.0f;
        }
    }
}

void UB_ENTRY(ub_zoom_probe)(const ub_object *o, int path, int want, int scalar, const float *xyz, size_t count,
                             double *out)
{
    for (size_t base = 0; base < count; base += UB_LANES) {
        float q[4][UB_LANES];
        size_t n = count - base < UB_LANES ? count - base : UB_LANES;
        point_packet(o, xyz, base, n, q);
        zoom_out r;
        if (scalar)
            zoom_lanes_scalar(o, path, (1 << n) - 1, q, want, &r);
        else
            zoom_lanes(o, path, (1 << n) - 1, q, want, &r);
        for (size_t l = 0; l < n; l++) {
            double *row = out + UB_ZOOM_PROBE_VALUES * (base + l);
            row[0] = r.dist[l];
            row[1] = r.iterations[l];
            /* Only what `want` asks for is computed. */
            row[2] = (want & UB_WANT_TRAP) ? r.trap[l] : 0.0;
            row[3] = (want & UB_WANT_POTENTIAL) ? r.potential[l] : 0.0;
            for (int a = 0; a < 3; a++)
                row[4 + a] = (want & UB_WANT_JACOBIAN) ? r.normal[a][l] : 0.0;
            row[7] = r.rebases[l];
        }
    }
}
