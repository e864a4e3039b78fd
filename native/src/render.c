/* Tiles of the film handed to a pool of threads; the calling thread polls progress/cancel. */
#include "render.h"

#include "params.h"
#include "port.h"

#include <stdlib.h>
#include <string.h>

int ub_cpu_has_avx2_fma(void)
{
    return ub_detect_avx2_fma();
}

int ub_cpu_has_avx512(void)
{
    return ub_detect_avx512();
}

const char *ub_resolve_isa(ub_isa isa, ub_isa *kernel)
{
    int avx2 = ub_cpu_has_avx2_fma(), avx512 = avx2 && ub_cpu_has_avx512();
    switch (isa) {
    case UB_ISA_AVX512:
        *kernel = UB_ISA_AVX512;
        return avx512 ? NULL : "simd='avx512' requested but this CPU lacks AVX-512F";
    case UB_ISA_AVX2:
        *kernel = UB_ISA_AVX2;
        return avx2 ? NULL : "simd='avx2' requested but this CPU lacks AVX2/FMA";
    case UB_ISA_PORTABLE:
        *kernel = UB_ISA_PORTABLE;
        return NULL;
    default:
        *kernel = avx512 ? UB_ISA_AVX512 : avx2 ? UB_ISA_AVX2 : UB_ISA_PORTABLE;
        return NULL;
    }
}

ub_tile_kernel ub_tile_kernel_of(ub_isa kernel)
{
    return kernel == UB_ISA_AVX512 ? ub_render_tile_avx512
         : kernel == UB_ISA_AVX2   ? ub_render_tile_avx2
                                   : ub_render_tile_portable;
}

uint64_t ub_fp_enter(void)
{
    return ub_fp_mode_enter();
}

void ub_fp_leave(uint64_t previous)
{
    ub_fp_mode_leave(previous);
}

int ub_cpu_count(void)
{
    int n = ub_online_cpus();
    return n > UB_MAX_THREADS ? UB_MAX_THREADS : n;
}

static void cone_cache_free(ub_cone_cache *c);

typedef struct {
    const ub_scene *scene;
    ub_tile_kernel kernel;
    int phase, sample;
    int width, height;        /* region tiled: the hit buffer (phase 0) or the film (phase 1) */
    int tile, tiles_x, tile_count;
    int next_tile;            /* atomic: next tile to hand out */
    int tiles_done;           /* atomic */
    int workers_running;      /* guarded by lock */
    ub_mutex lock;
    ub_cond finished;  /* signalled when a worker exits */
    ub_counters *per_thread;
} ub_job;

typedef struct {
    ub_job *job;
    int index;
    ub_thread thread;
    int started;
} ub_worker;

UB_THREAD_ENTRY(worker_main, arg)
{
    ub_worker *w = arg;
    ub_job *job = w->job;
    /* Restored on exit: with no thread available this runs on the caller's (Blender's) thread. */
    uint64_t fp = ub_fp_enter();
    for (;;) {
        if (__atomic_load_n(job->scene->cancel, __ATOMIC_RELAXED))
            break;
        int t = __atomic_fetch_add(&job->next_tile, 1, __ATOMIC_RELAXED);
        if (t >= job->tile_count)
            break;
        int tx = (t % job->tiles_x) * job->tile, ty = (t / job->tiles_x) * job->tile;
        int tx1 = tx + job->tile < job->width ? tx + job->tile : job->width;
        int ty1 = ty + job->tile < job->height ? ty + job->tile : job->height;
        job->kernel(job->scene, job->phase, job->sample, tx, ty, tx1, ty1, &job->per_thread[w->index]);
        __atomic_fetch_add(&job->tiles_done, 1, __ATOMIC_RELEASE);
    }
    ub_fp_leave(fp);
    ub_mutex_lock(&job->lock);
    job->workers_running--;
    ub_cond_signal(&job->finished);
    ub_mutex_unlock(&job->lock);
    UB_THREAD_RETURN;
}

/* Runs one phase of one sample over its region on `threads` workers while the calling thread
 * polls progress (reported as done_before + fraction of this job, over `total` jobs) and cancel.
 * Returns the number of threads that ran. */
static int run_job(ub_job *job, const ub_render_options *opt, int threads, ub_worker *workers, int job_index,
                   int job_total)
{
    job->tiles_x = (job->width + job->tile - 1) / job->tile;
    int tiles_y = (job->height + job->tile - 1) / job->tile;
    job->tile_count = job->tiles_x * tiles_y;
    job->next_tile = 0;
    job->tiles_done = 0;
    if (threads > job->tile_count)
        threads = job->tile_count;
    if (threads < 1)
        threads = 1;
    ub_mutex_init(&job->lock);
    ub_cond_init(&job->finished);
    job->workers_running = threads;
    int started = 0;
    for (int i = 0; i < threads; i++) {
        workers[i].job = job;
        workers[i].index = i;
        workers[i].started = 0;
        if (ub_thread_start(&workers[i].thread, worker_main, &workers[i])) {
            workers[i].started = 1;
            started++;
        } else {
            ub_mutex_lock(&job->lock);
            job->workers_running--;
            ub_mutex_unlock(&job->lock);
        }
    }
    if (!started) {
        /* No thread could be created (a pids or RLIMIT_NPROC limit, no address space for a stack):
         * render on the calling thread, one row of a tile at a time, polling between them, so
         * progress and cancel are seen as with workers (issue 16, defect 5). Pixels do not depend
         * on how the film is cut, so the image is the same. */
        uint64_t fp = ub_fp_enter();
        double last_poll = ub_monotonic_seconds();
        for (int t = 0; t < job->tile_count && !__atomic_load_n(job->scene->cancel, __ATOMIC_RELAXED); t++) {
            int tx = (t % job->tiles_x) * job->tile, ty = (t / job->tiles_x) * job->tile;
            int tx1 = tx + job->tile < job->width ? tx + job->tile : job->width;
            int ty1 = ty + job->tile < job->height ? ty + job->tile : job->height;
            for (int y = ty; y < ty1 && !__atomic_load_n(job->scene->cancel, __ATOMIC_RELAXED); y++) {
                job->kernel(job->scene, job->phase, job->sample, tx, y, tx1, y + 1, &job->per_thread[0]);
                double now = ub_monotonic_seconds();
                if (opt->poll && now - last_poll >= 1e-9 * (double)opt->poll_interval_ns) {
                    last_poll = now;
                    double frac = (t + (double)(y + 1 - ty) / (ty1 - ty)) / job->tile_count;
                    ub_fp_leave(fp); /* the callback runs Python in the caller's own FP mode */
                    if (opt->poll(opt->poll_data, (job_index + frac) / job_total))
                        __atomic_store_n(job->scene->cancel, 1, __ATOMIC_RELAXED);
                    fp = ub_fp_enter();
                }
            }
            job->tiles_done = t + 1;
        }
        ub_fp_leave(fp);
        job->workers_running = 0;
    }
    /* Poll: report progress and let the caller cancel, until the workers are done. */
    ub_mutex_lock(&job->lock);
    while (job->workers_running > 0) {
        ub_cond_wait_ns(&job->finished, &job->lock, opt->poll_interval_ns);
        if (job->workers_running > 0 && opt->poll) {
            ub_mutex_unlock(&job->lock);
            double frac = (double)__atomic_load_n(&job->tiles_done, __ATOMIC_ACQUIRE) / job->tile_count;
            if (opt->poll(opt->poll_data, (job_index + frac) / job_total))
                __atomic_store_n(job->scene->cancel, 1, __ATOMIC_RELAXED);
            ub_mutex_lock(&job->lock);
        }
    }
    ub_mutex_unlock(&job->lock);
    for (int i = 0; i < threads; i++)
        if (workers[i].started)
            ub_thread_join(workers[i].thread);
    ub_cond_destroy(&job->finished);
    ub_mutex_destroy(&job->lock);
    return started ? started : 1;
}

/* The hit buffer is kept between renders (one, at most UB_KEEP_HIT_BYTES): a fresh one of 26 MB at
 * 1280x1024 costs its page faults and the kernel's zeroing of every page on each render, about 3 % of
 * a render's CPU time (issue 21). Taken and given back by atomic exchange, so concurrent renders (the
 * viewport beside F12) each get their own; a block starts with its capacity in bytes. */
#define UB_KEEP_HIT_BYTES ((size_t)64 << 20)
#define UB_HIT_BLOCK_HEADER 16
static char *spare_hit_block;

static ub_hit *hit_buffer_take(size_t count)
{
    const size_t bytes = count * sizeof(ub_hit);
    char *block = __atomic_exchange_n(&spare_hit_block, NULL, __ATOMIC_ACQ_REL);
    if (block && *(size_t *)block >= bytes)
        return (ub_hit *)(block + UB_HIT_BLOCK_HEADER);
    free(block);
    block = malloc(UB_HIT_BLOCK_HEADER + bytes);
    if (!block)
        return NULL;
    *(size_t *)block = bytes;
    return (ub_hit *)(block + UB_HIT_BLOCK_HEADER);
}

static void hit_buffer_give_back(ub_hit *hits)
{
    if (!hits)
        return;
    char *block = (char *)hits - UB_HIT_BLOCK_HEADER;
    if (*(size_t *)block > UB_KEEP_HIT_BYTES) {
        free(block);
        return;
    }
    free(__atomic_exchange_n(&spare_hit_block, block, __ATOMIC_ACQ_REL));
}

/* The blocks of shared first steps (issue 21) under the hit buffer's pixels, all not yet
 * computed; none (start NULL) where the cone does not apply: panoramic cameras (rays not
 * through a plane) and depth of field (rays from all over the lens), which keep their rays as
 * they were, and renders that ask for none (shared_steps 0). Returns 0 only when memory ran out. */
static int cone_cache_alloc(const ub_scene *sc, const ub_hit_buffer *hb, int wanted, ub_cone_cache *c)
{
    memset(c, 0, sizeof *c);
    const ub_camera *cam = sc->camera;
    if (!wanted || cam->panorama != UB_PANORAMA_NONE || cam->aperture > 0.0 || sc->object_count == 0 || hb->w <= 0
        || hb->h <= 0)
        return 1;
    c->bx0 = hb->x0 / UB_CONE_BLOCK;
    c->by0 = hb->y0 / UB_CONE_BLOCK;
    c->nbx = (hb->x0 + hb->step * (hb->w - 1)) / UB_CONE_BLOCK - c->bx0 + 1;
    c->nby = (hb->y0 + hb->step * (hb->h - 1)) / UB_CONE_BLOCK - c->by0 + 1;
    size_t n = (size_t)c->nbx * (size_t)c->nby;
    c->start = malloc(n * sizeof *c->start);
    c->ready = calloc(n, sizeof *c->ready);
    if (!c->start || !c->ready) {
        cone_cache_free(c);
        return 0;
    }
    return 1;
}

static void cone_cache_free(ub_cone_cache *c)
{
    free(c->start);
    free(c->ready);
    c->start = NULL;
    c->ready = NULL;
}

const char *ub_render(const ub_scene *scene_in, const ub_render_options *opt, ub_render_stats *stats)
{
    memset(stats, 0, sizeof *stats);
    ub_isa kernel;
    const char *isa_error = ub_resolve_isa(opt->isa, &kernel);
    if (isa_error)
        return isa_error;
    const ub_film *film = scene_in->film;
    const ub_camera *cam = scene_in->camera;
    /* The hit buffer: the film plus a one-pixel apron inside the image, on the film's grid, when
     * an object's normals read the neighbouring pixels' hits (eq. 12-14); else the film alone, so
     * that a window or a band of the image traces no ray twice. */
    ub_hit_buffer hb;
    const int step = film->step;
    int apron = 0;
    for (int k = 0; k < scene_in->object_count; k++)
        apron |= scene_in->objects[k].normal_method == UB_NORMAL_ZBUFFER;
    int left = apron && film->x0 >= step, bottom = apron && film->y0 >= step;
    int right = apron && film->x0 + step * film->w < cam->width;
    int top = apron && film->y0 + step * film->h < cam->height;
    hb.step = step;
    hb.x0 = film->x0 - left * step;
    hb.y0 = film->y0 - bottom * step;
    hb.w = film->w + left + right;
    hb.h = film->h + bottom + top;
    hb.apron_x = left;
    hb.apron_y = bottom;
    hb.hits = hit_buffer_take((size_t)hb.w * (size_t)hb.h);
    ub_scene scene = *scene_in;
    scene.hits = &hb;
    ub_cone_cache cones;
    int cones_ok = cone_cache_alloc(scene_in, &hb, opt->shared_steps, &cones);
    scene.cones = cones.start ? &cones : NULL;
    int threads = opt->threads > 0 ? opt->threads : ub_cpu_count();
    ub_counters *per_thread = calloc((size_t)threads, sizeof(ub_counters));
    ub_worker *workers = calloc((size_t)threads, sizeof(ub_worker));
    if (!per_thread || !workers || !hb.hits || !cones_ok) {
        free(per_thread);
        free(workers);
        hit_buffer_give_back(hb.hits);
        cone_cache_free(&cones);
        return "out of memory (the image is too large for this machine)";
    }
    double t0 = ub_monotonic_seconds();
    int samples = scene.shading->samples, ran = 1;
    int first = opt->sample_count > 0 ? opt->first_sample : 0;
    int count = opt->sample_count > 0 ? opt->sample_count : samples;
    for (int s = first; s < first + count && !__atomic_load_n(scene.cancel, __ATOMIC_RELAXED); s++) {
        for (int phase = 0; phase < 2 && !__atomic_load_n(scene.cancel, __ATOMIC_RELAXED); phase++) {
            ub_job job;
            memset(&job, 0, sizeof job);
            job.scene = &scene;
            job.kernel = ub_tile_kernel_of(kernel);
            job.phase = phase;
            job.sample = s;
            job.width = phase == 0 ? hb.w : film->w;
            job.height = phase == 0 ? hb.h : film->h;
            job.tile = opt->tile_size;
            job.per_thread = per_thread;
            int r = run_job(&job, opt, threads, workers, 2 * (s - first) + phase, 2 * count);
            if (r > ran)
                ran = r;
        }
    }
    stats->seconds = ub_monotonic_seconds() - t0;
    for (int i = 0; i < threads; i++) {
        stats->counters.rays += per_thread[i].rays;
        stats->counters.steps += per_thread[i].steps;
        stats->counters.iterations += per_thread[i].iterations;
        stats->counters.out_of_steps += per_thread[i].out_of_steps;
    }
    stats->threads = ran;
    stats->isa = ub_isa_names[kernel];
    stats->cancelled = __atomic_load_n(scene.cancel, __ATOMIC_RELAXED) != 0;
    free(per_thread);
    free(workers);
    hit_buffer_give_back(hb.hits);
    cone_cache_free(&cones);
    return NULL;
}
