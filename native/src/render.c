/* Tiles of the film handed to a pool of threads; the calling thread polls progress/cancel. */
#include "render.h"

#include "params.h"
#include "port.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The CPU's features, detected once: CPUID traps to the hypervisor in a virtual machine (about
 * 7 us each, five of them a detection), and every render call, an F12 band or a viewport sub-grid
 * among them, resolves its kernel (issue 21: 1.3 % of a 640x360 animation's F12s). Bit 0 AVX2 +
 * FMA, bit 1 AVX-512 (F, CD, BW, DQ, VL); -1 not detected yet (threads that race both store the
 * same value). */
static int cpu_features = -1;

static int detected_features(void)
{
    int f = __atomic_load_n(&cpu_features, __ATOMIC_RELAXED);
    if (f < 0) {
        f = (ub_detect_avx2_fma() ? 1 : 0) | (ub_detect_avx512() ? 2 : 0);
        __atomic_store_n(&cpu_features, f, __ATOMIC_RELAXED);
    }
    return f;
}

int ub_cpu_has_avx2_fma(void)
{
    return (detected_features() & 1) != 0;
}

int ub_cpu_has_avx512(void)
{
    return (detected_features() & 2) != 0;
}

const char *ub_resolve_isa(ub_isa isa, ub_isa *kernel)
{
    int avx2 = ub_cpu_has_avx2_fma(), avx512 = avx2 && ub_cpu_has_avx512();
    switch (isa) {
    case UB_ISA_AVX512:
        *kernel = UB_ISA_AVX512;
        return avx512 ? NULL : "simd='avx512' requested but this CPU lacks AVX-512 (F, CD, BW, DQ and VL)";
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
    /* Read once: sysconf opens and reads /sys/devices/system/cpu/online on Linux, 40 us a call
     * on a cold cache, every frame of an animation (issue 21); Blender reads its count once too. */
    static int cached;
    int n = __atomic_load_n(&cached, __ATOMIC_RELAXED);
    if (!n) {
        n = ub_online_cpus();
        n = n > UB_MAX_THREADS ? UB_MAX_THREADS : n;
        __atomic_store_n(&cached, n, __ATOMIC_RELAXED);
    }
    return n;
}

static void cone_cache_free(ub_cone_cache *c);

/* A worker's own state, alone on its cache lines: the kernels bump the counters for every pixel,
 * and two threads writing one line would pass it back and forth between their cores (false
 * sharing). 256 bytes each, so that whatever calloc's alignment, no aligned pair of 64-byte lines
 * (what the adjacent-line prefetcher fetches together) holds two workers' state. */
typedef union {
    struct {
        ub_counters counters;
        /* The worker's run of the current job's tiles, [next, end) packed as end << 32 | next
         * (run_take, run_steal): atomic, as other workers cut runs too. */
        uint64_t run;
        int tiles_done; /* atomic: written by the worker, read for the progress */
    };
    char line[256];
} ub_worker_state;
_Static_assert(sizeof(ub_counters) + 16 <= 128, "a worker's state fits 128 bytes of its 256");

/* Counters before the first tile: zero, and no depth seen in any lane. */
static void ub_counters_start(ub_counters *c)
{
    memset(c, 0, sizeof *c);
    for (int l = 0; l < UB_MAX_LANES; l++)
        c->nearest_lanes[l] = INFINITY;
}

/* A thread's counters into the render's (both begun by ub_counters_start): sums, and each lane's
 * nearest depth. */
static void ub_counters_add(ub_counters *total, const ub_counters *c)
{
    total->rays += c->rays;
    total->steps += c->steps;
    total->iterations += c->iterations;
    total->normal_iterations += c->normal_iterations;
    total->out_of_steps += c->out_of_steps;
    for (int l = 0; l < UB_MAX_LANES; l++)
        total->nearest_lanes[l] = fminf(total->nearest_lanes[l], c->nearest_lanes[l]);
}

/* The render's threads (a crew's, below: kept between renders; issue 21), handed one job after
 * another: a phase of a sample, cut into tiles. */
typedef struct {
    const ub_scene *scene;
    ub_tile_kernel kernel;
    ub_worker_state *per_thread;
    ub_mutex lock;
    ub_cond wake;     /* broadcast: a new job, or the render is over */
    ub_cond finished; /* signalled when a worker is done with the job */
    unsigned job_number; /* guarded by lock: the current job's; every worker runs every job once */
    int over;         /* guarded by lock: no more jobs, workers exit */
    int busy;         /* guarded by lock: workers not yet done with the current job */
    /* The current job, written by the calling thread while no worker is busy. */
    int phase, sample;
    int width, height; /* region tiled: the hit buffer (UB_PHASE_TRACE) or the film */
    int tile, tiles_x, tile_count;
    int workers; /* started: the runs of tiles (work_on_job) */
    /* Film jobs with clear_unfinished: 1 per tile finished before any cancel; else NULL. */
    unsigned char *tile_finished;
} ub_pool;

typedef struct {
    ub_pool *pool;
    int index;
    unsigned first_job; /* the job number when the thread was started: its first job is the next one */
    ub_thread thread;
} ub_worker;

/* The workers, kept from one render to the next (issue 21): a render's threads started and joined
 * cost 0.1-0.2 ms of CPU a thread and call (the clone, the stack pages glibc hands back at a
 * thread's exit faulted in again, the TLB shootdowns), 1 % of an animation frame at 640x360 and
 * more of the viewport's many small calls and of F12's bands. One crew is kept; a render takes it
 * by atomic exchange (a render beside it, the viewport beside F12, gets a crew of its own, whose
 * threads end with it) and starts threads as it needs more. Between renders the workers sleep on
 * a condition variable, with no timeout: no CPU at all. */
typedef struct {
    ub_pool pool;
    ub_worker workers[UB_MAX_THREADS];
    int started;
} ub_crew;

static ub_crew *kept_crew;

static void run_tile(ub_pool *pool, int t, int y0, int y1, ub_counters *cnt)
{
    int tx = (t % pool->tiles_x) * pool->tile;
    int tx1 = tx + pool->tile < pool->width ? tx + pool->tile : pool->width;
    pool->kernel(pool->scene, pool->phase, pool->sample, tx, y0, tx1, y1, cnt);
}

static void tile_rows(const ub_pool *pool, int t, int *ty, int *ty1)
{
    *ty = (t / pool->tiles_x) * pool->tile;
    *ty1 = *ty + pool->tile < pool->height ? *ty + pool->tile : pool->height;
}

/* A tile counts as finished only when no cancel came before its end: a cancel cuts the kernel
 * short anywhere in the tile (kernel.h, cancelled), and the flag never goes back to 0. */
static void mark_finished(ub_pool *pool, int t)
{
    if (pool->tile_finished && !__atomic_load_n(pool->scene->cancel, __ATOMIC_RELAXED))
        pool->tile_finished[t] = 1;
}

static uint64_t run_of(uint32_t next, uint32_t end)
{
    return (uint64_t)end << 32 | next;
}

static uint32_t run_left(uint64_t run)
{
    uint32_t next = (uint32_t)run, end = (uint32_t)(run >> 32);
    return end > next ? end - next : 0;
}

/* The first tile of a run, taken; -1 when the run is empty. */
static int run_take(uint64_t *run)
{
    uint64_t r = __atomic_load_n(run, __ATOMIC_RELAXED);
    while (run_left(r)) {
        if (__atomic_compare_exchange_n(run, &r, r + 1, 1, __ATOMIC_RELAXED, __ATOMIC_RELAXED))
            return (int)(uint32_t)r;
    }
    return -1;
}

/* A worker whose run is empty takes the back half of the longest other run (the last tile of a
 * run of one) as its own run; returns 0 when every run is empty. */
static int run_steal(ub_pool *pool, int worker)
{
    uint64_t *own = &pool->per_thread[worker].run;
    for (;;) {
        int victim = -1;
        uint32_t most = 0;
        for (int w = 0; w < pool->workers; w++) {
            uint32_t left = run_left(__atomic_load_n(&pool->per_thread[w].run, __ATOMIC_RELAXED));
            if (w != worker && left > most) {
                most = left;
                victim = w;
            }
        }
        if (victim < 0)
            return 0;
        uint64_t *run = &pool->per_thread[victim].run;
        uint64_t r = __atomic_load_n(run, __ATOMIC_RELAXED);
        uint32_t next = (uint32_t)r, end = (uint32_t)(r >> 32);
        if (end <= next)
            continue;
        uint32_t middle = next + (end - next) / 2;
        if (__atomic_compare_exchange_n(run, &r, run_of(next, middle), 0, __ATOMIC_RELAXED, __ATOMIC_RELAXED)) {
            __atomic_store_n(own, run_of(middle, end), __ATOMIC_RELAXED);
            return 1;
        }
    }
}

/* A worker's share of the current job: the tiles of its own run, in row-major order, then runs
 * cut from the others' (run_steal), until no tile is left or the render is cancelled. Runs, not
 * one queue of tiles: with one queue two threads mostly work on side by side tiles, and they
 * pass cache lines back and forth where each row of the passes crosses their common edge (a
 * caller's rows need not start on a line) and where a core's prefetchers run on along the rows
 * into the other's tile; along a run of its own a thread meets its own lines (issue 21: on the
 * peer scene 2 threads took 2.6-5 % more CPU than 1 thread with one queue, 0-1 % with runs). */
static void work_on_job(ub_pool *pool, int worker)
{
    ub_worker_state *me = &pool->per_thread[worker];
    while (!__atomic_load_n(pool->scene->cancel, __ATOMIC_RELAXED)) {
        int t = run_take(&me->run);
        if (t < 0) {
            if (!run_steal(pool, worker))
                break;
            continue;
        }
        int ty, ty1;
        tile_rows(pool, t, &ty, &ty1);
        run_tile(pool, t, ty, ty1, &me->counters);
        mark_finished(pool, t);
        __atomic_store_n(&me->tiles_done, me->tiles_done + 1, __ATOMIC_RELEASE);
    }
}

/* The tiles the workers have finished so far in the current job. */
static int tiles_done(const ub_pool *pool)
{
    int done = 0;
    for (int w = 0; w < pool->workers; w++)
        done += __atomic_load_n(&pool->per_thread[w].tiles_done, __ATOMIC_ACQUIRE);
    return done;
}

/* A worker runs every job of the renders that hold its crew, once, where its index is below the
 * job's worker count (a render may use fewer threads than the crew has), until the crew ends. */
UB_THREAD_ENTRY(worker_main, arg)
{
    ub_worker *w = arg;
    ub_pool *pool = w->pool;
    uint64_t fp = ub_fp_enter();
    unsigned last_job = w->first_job;
    ub_mutex_lock(&pool->lock);
    for (;;) {
        while (!pool->over && pool->job_number == last_job)
            ub_cond_wait(&pool->wake, &pool->lock);
        if (pool->over)
            break;
        last_job = pool->job_number;
        if (w->index >= pool->workers)
            continue;
        ub_mutex_unlock(&pool->lock);
        work_on_job(pool, w->index);
        ub_mutex_lock(&pool->lock);
        pool->busy--;
        ub_cond_signal(&pool->finished);
    }
    ub_mutex_unlock(&pool->lock);
    ub_fp_leave(fp);
    UB_THREAD_RETURN;
}

#if !defined(_WIN32)
/* A child of fork() has none of its parent's threads: it forgets the kept crew (its memory stays
 * with the child, unused). */
static void crew_forget_in_child(void)
{
    kept_crew = NULL;
}
#endif

/* The kept crew, or a new one (NULL only when out of memory), with up to `threads` workers
 * started; crew->started may stay below (no thread could be created: the calling thread renders). */
static ub_crew *crew_take(int threads)
{
    ub_crew *crew = __atomic_exchange_n(&kept_crew, NULL, __ATOMIC_ACQ_REL);
    if (!crew) {
#if !defined(_WIN32)
        static int atfork_set;
        if (!__atomic_exchange_n(&atfork_set, 1, __ATOMIC_ACQ_REL))
            pthread_atfork(NULL, NULL, crew_forget_in_child);
#endif
        crew = calloc(1, sizeof *crew);
        if (!crew)
            return NULL;
        ub_mutex_init(&crew->pool.lock);
        ub_cond_init(&crew->pool.wake);
        ub_cond_init(&crew->pool.finished);
    }
    while (crew->started < threads) {
        ub_worker *w = &crew->workers[crew->started];
        w->pool = &crew->pool;
        w->index = crew->started;
        w->first_job = crew->pool.job_number; /* no job runs now: the crew is this render's */
        if (!ub_thread_start(&w->thread, worker_main, w))
            break;
        crew->started++;
    }
    return crew;
}

/* Ends a crew's threads and frees it. */
static void crew_end(ub_crew *crew)
{
    ub_pool *pool = &crew->pool;
    ub_mutex_lock(&pool->lock);
    pool->over = 1;
    ub_cond_broadcast(&pool->wake);
    ub_mutex_unlock(&pool->lock);
    for (int i = 0; i < crew->started; i++)
        ub_thread_join(crew->workers[i].thread);
    ub_cond_destroy(&pool->finished);
    ub_cond_destroy(&pool->wake);
    ub_mutex_destroy(&pool->lock);
    free(crew);
}

/* After a render: its crew kept for the next one, unless one is kept already (a render beside it
 * gave its crew back first), then this one ends. */
static void crew_give_back(ub_crew *crew)
{
    ub_crew *none = NULL;
    if (!__atomic_compare_exchange_n(&kept_crew, &none, crew, 0, __ATOMIC_ACQ_REL, __ATOMIC_ACQUIRE))
        crew_end(crew);
}

static int report_progress(const ub_render_options *opt, double fraction, volatile int *cancel)
{
    if (opt->poll && opt->poll(opt->poll_data, fraction)) {
        __atomic_store_n(cancel, 1, __ATOMIC_RELAXED);
        return 1;
    }
    return 0;
}

/* No thread could be created (a pids or RLIMIT_NPROC limit, no address space for a stack): the
 * calling thread renders the job, one row of a tile at a time, polling between them, so progress
 * and cancel are seen as with workers (issue 16, defect 5). Pixels do not depend on how the film
 * is cut, so the image is the same. */
static void run_job_on_caller(ub_pool *pool, const ub_render_options *opt, int job_index, int job_total)
{
    volatile int *cancel = pool->scene->cancel;
    uint64_t fp = ub_fp_enter();
    double last_poll = ub_monotonic_seconds();
    for (int t = 0; t < pool->tile_count && !__atomic_load_n(cancel, __ATOMIC_RELAXED); t++) {
        int ty, ty1;
        tile_rows(pool, t, &ty, &ty1);
        for (int y = ty; y < ty1 && !__atomic_load_n(cancel, __ATOMIC_RELAXED); y++) {
            run_tile(pool, t, y, y + 1, &pool->per_thread[0].counters);
            double now = ub_monotonic_seconds();
            if (opt->poll && now - last_poll >= 1e-9 * (double)opt->poll_interval_ns) {
                last_poll = now;
                double frac = (t + (double)(y + 1 - ty) / (ty1 - ty)) / pool->tile_count;
                ub_fp_leave(fp); /* the callback runs Python in the caller's own FP mode */
                report_progress(opt, (job_index + frac) / job_total, cancel);
                fp = ub_fp_enter();
            }
        }
        mark_finished(pool, t);
    }
    ub_fp_leave(fp);
}

/* Runs one phase of one sample over its region on the pool's `started` workers while the calling
 * thread polls progress (reported as job_index + fraction of this job, over job_total) and cancel. */
static void run_job(ub_pool *pool, int started, const ub_render_options *opt, int job_index, int job_total)
{
    pool->tiles_x = (pool->width + pool->tile - 1) / pool->tile;
    pool->tile_count = pool->tiles_x * ((pool->height + pool->tile - 1) / pool->tile);
    /* One run of row-major tiles a worker (work_on_job). */
    for (int w = 0; w < started; w++) {
        pool->per_thread[w].run = run_of((uint32_t)((int64_t)pool->tile_count * w / started),
                                             (uint32_t)((int64_t)pool->tile_count * (w + 1) / started));
        pool->per_thread[w].tiles_done = 0;
    }
    if (pool->tile_finished)
        memset(pool->tile_finished, 0, (size_t)pool->tile_count);
    if (!started) {
        run_job_on_caller(pool, opt, job_index, job_total);
        return;
    }
    ub_mutex_lock(&pool->lock);
    /* The job's worker count with its number, under the lock: a worker of the crew left out of
     * the last job may wake only now, and must not read the next job's count for the last one. */
    pool->workers = started;
    pool->busy = started;
    pool->job_number++;
    ub_cond_broadcast(&pool->wake);
    while (pool->busy > 0) {
        ub_cond_wait_ns(&pool->finished, &pool->lock, opt->poll_interval_ns);
        if (pool->busy > 0 && opt->poll) {
            ub_mutex_unlock(&pool->lock);
            double frac = (double)tiles_done(pool) / pool->tile_count;
            report_progress(opt, (job_index + frac) / job_total, pool->scene->cancel);
            ub_mutex_lock(&pool->lock);
        }
    }
    ub_mutex_unlock(&pool->lock);
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

/* The grid of blocks of shared first steps (issue 21) under the hit buffer's pixels into c
 * (cones not allocated: cone_cache_alloc); 0 where the cone does not apply: panoramic cameras (rays not
 * through a plane) and depth of field (rays from all over the lens), which keep their rays as
 * they were, and renders that ask for none (shared_steps 0). */
static int cone_grid(const ub_scene *sc, const ub_hit_buffer *hb, int wanted, ub_cone_cache *c)
{
    memset(c, 0, sizeof *c);
    const ub_camera *cam = sc->camera;
    if (!wanted || cam->panorama != UB_PANORAMA_NONE || cam->aperture > 0.0 || sc->object_count == 0 || hb->w <= 0
        || hb->h <= 0)
        return 0;
    c->bx0 = hb->x0 / UB_CONE_BLOCK;
    c->by0 = hb->y0 / UB_CONE_BLOCK;
    c->nbx = (hb->x0 + hb->step * (hb->w - 1)) / UB_CONE_BLOCK - c->bx0 + 1;
    c->nby = (hb->y0 + hb->step * (hb->h - 1)) / UB_CONE_BLOCK - c->by0 + 1;
    return 1;
}

/* The cones of c's grid (cone_grid), none computed yet; 0 when memory ran out. */
static int cone_cache_alloc(ub_cone_cache *c)
{
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

struct ub_kept_cones {
    int busy;            /* atomic: 1 while a render holds them */
    ub_cone_cache cones; /* start NULL: none kept */
    /* What the kept cones were marched for: the cones read nothing else (cone.h). */
    ub_camera camera;
    ub_object *objects;
    int object_count;
    int sea;
    double sea_height;
};

ub_kept_cones *ub_kept_cones_new(void)
{
    return calloc(1, sizeof(ub_kept_cones));
}

static void kept_cones_forget(ub_kept_cones *kept)
{
    cone_cache_free(&kept->cones);
    free(kept->objects);
    kept->objects = NULL;
    kept->object_count = 0;
}

void ub_kept_cones_free(ub_kept_cones *kept)
{
    if (kept) {
        kept_cones_forget(kept);
        free(kept);
    }
}

/* Whether the kept cones are those of this render: the same blocks, and the same bytes of
 * everything a cone's march reads (the records are zeroed before they are filled, padding too). */
static int kept_cones_match(const ub_kept_cones *kept, const ub_scene *sc, const ub_cone_cache *c)
{
    const ub_cone_cache *k = &kept->cones;
    return k->start && k->bx0 == c->bx0 && k->by0 == c->by0 && k->nbx == c->nbx && k->nby == c->nby
        && kept->object_count == sc->object_count && kept->sea == sc->shading->sea
        && (!kept->sea || kept->sea_height == sc->shading->sea_height)
        && !memcmp(&kept->camera, sc->camera, sizeof kept->camera)
        && !memcmp(kept->objects, sc->objects, (size_t)sc->object_count * sizeof *sc->objects);
}

/* The render's cones (c: their grid, cone_grid): the kept ones where they match. Returns whether
 * they did. */
static int kept_cones_take(ub_kept_cones *kept, const ub_scene *sc, ub_cone_cache *c)
{
    if (!kept_cones_match(kept, sc, c))
        return 0;
    *c = kept->cones;
    memset(&kept->cones, 0, sizeof kept->cones);
    return 1;
}

/* After the render: its cones (complete or not, each block's start is final once ready) kept for
 * the next call, with what they were marched for (copied unless they were the kept ones). */
static void kept_cones_give_back(ub_kept_cones *kept, const ub_scene *sc, ub_cone_cache *c, int taken)
{
    if (!taken) {
        kept_cones_forget(kept);
        size_t bytes = (size_t)sc->object_count * sizeof *sc->objects;
        kept->objects = c->start && sc->object_count ? malloc(bytes) : NULL;
        if (!kept->objects) { /* nothing to keep, or no memory to keep it with */
            cone_cache_free(c);
            return;
        }
        memcpy(kept->objects, sc->objects, bytes);
        kept->object_count = sc->object_count;
        kept->camera = *sc->camera;
        kept->sea = sc->shading->sea;
        kept->sea_height = sc->shading->sea_height;
    }
    kept->cones = *c;
    memset(c, 0, sizeof *c);
}

/* The render's end: its cones to `kept` (NULL: freed) and `kept` free for the next render. */
static void kept_cones_release(ub_kept_cones *kept, const ub_scene *sc, ub_cone_cache *c, int taken)
{
    if (kept) {
        kept_cones_give_back(kept, sc, c, taken);
        __atomic_store_n(&kept->busy, 0, __ATOMIC_RELEASE);
    }
    cone_cache_free(c);
}

/* Zeroes every pass of the film over the tiles of the film's grid not marked in `finished` (all of
 * them when the film job never ran): what a render cancelled in its first sample did not reach
 * is transparent black, as if the caller had cleared its buffers before the render. */
static void clear_unfinished_tiles(const ub_film *film, int tile, const unsigned char *finished)
{
    const int tiles_x = (film->w + tile - 1) / tile, tiles_y = (film->h + tile - 1) / tile;
    for (int t = 0; t < tiles_x * tiles_y; t++) {
        if (finished[t])
            continue;
        const int x0 = (t % tiles_x) * tile, y0 = (t / tiles_x) * tile;
        const int x1 = x0 + tile < film->w ? x0 + tile : film->w, y1 = y0 + tile < film->h ? y0 + tile : film->h;
        for (int p = 0; p < UB_PASS_COUNT; p++) {
            if (!film->pass[p])
                continue;
            const size_t ch = (size_t)ub_pass_channels[p];
            for (int y = y0; y < y1; y++)
                memset(film->pass[p] + ((size_t)y * (size_t)film->w + (size_t)x0) * ch, 0,
                       (size_t)(x1 - x0) * ch * sizeof(float));
        }
    }
}

const char *ub_render(const ub_scene *scene_in, const ub_render_options *opt, ub_render_stats *stats)
{
    memset(stats, 0, sizeof *stats);
    ub_counters_start(&stats->counters);
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
    /* Only the Z-buffer normals read other pixels' hits: without them each packet is shaded right
     * after its camera rays are marched, in one phase, and no hit buffer is needed (issue 21: the
     * buffer's 20 bytes a pixel, written and read back from memory, and a second camera ray per
     * pixel were a tenth of a render). */
    const int phases = apron ? 2 : 1;
    hb.hits = apron ? hit_buffer_take((size_t)hb.w * (size_t)hb.h) : NULL;
    ub_scene scene = *scene_in;
    scene.hits = &hb;
    /* The cones: the kept ones where they are this render's (unless another render holds them
     * now), else fresh ones. */
    ub_kept_cones *kept = opt->kept_cones && !__atomic_exchange_n(&opt->kept_cones->busy, 1, __ATOMIC_ACQUIRE)
                              ? opt->kept_cones : NULL;
    ub_cone_cache cones;
    int taken = 0, cones_ok = 1;
    if (cone_grid(scene_in, &hb, opt->shared_steps, &cones)) {
        taken = kept && kept_cones_take(kept, scene_in, &cones);
        cones_ok = taken || cone_cache_alloc(&cones);
    }
    scene.cones = cones.start ? &cones : NULL;
    int threads = opt->threads > 0 ? opt->threads : ub_cpu_count();
    ub_worker_state *per_thread = calloc((size_t)threads, sizeof(ub_worker_state));
    /* The tiles the first sample finished, when a cancel there is to clear the others: marked
     * during sample 0's film job only, so a cancel in a later sample finds them all marked. */
    const int first = opt->sample_count > 0 ? opt->first_sample : 0;
    const int count = opt->sample_count > 0 ? opt->sample_count : scene.shading->samples;
    const int clearing = opt->clear_unfinished && first == 0;
    const int film_tiles = ((film->w + opt->tile_size - 1) / opt->tile_size)
                         * ((film->h + opt->tile_size - 1) / opt->tile_size);
    unsigned char *finished = clearing ? calloc((size_t)film_tiles, 1) : NULL;
    for (int i = 0; per_thread && i < threads; i++)
        ub_counters_start(&per_thread[i].counters);
    /* No more workers than the hit buffer has tiles (the film has no more than it). */
    int tiles = ((hb.w + opt->tile_size - 1) / opt->tile_size) * ((hb.h + opt->tile_size - 1) / opt->tile_size);
    int wanted = threads < tiles ? threads : (tiles > 0 ? tiles : 1);
    ub_crew *crew = per_thread ? crew_take(wanted) : NULL;
    if (!per_thread || !crew || (apron && !hb.hits) || !cones_ok || (clearing && !finished)) {
        if (crew)
            crew_give_back(crew);
        free(per_thread);
        free(finished);
        hit_buffer_give_back(hb.hits);
        kept_cones_release(kept, scene_in, &cones, taken);
        return "out of memory (the image is too large for this machine)";
    }
    double t0 = ub_monotonic_seconds();
    /* This render's jobs on the crew (no worker is busy between renders). */
    ub_pool *pool = &crew->pool;
    pool->scene = &scene;
    pool->kernel = ub_tile_kernel_of(kernel);
    pool->per_thread = per_thread;
    pool->tile = opt->tile_size;
    int started = crew->started < wanted ? crew->started : wanted;
    for (int s = first; s < first + count && !__atomic_load_n(scene.cancel, __ATOMIC_RELAXED); s++) {
        for (int phase = 0; phase < phases && !__atomic_load_n(scene.cancel, __ATOMIC_RELAXED); phase++) {
            pool->phase = phases == 1 ? UB_PHASE_TRACE_AND_SHADE : phase;
            pool->tile_finished = s == 0 && pool->phase != UB_PHASE_TRACE ? finished : NULL;
            pool->sample = s;
            /* One phase: the hit buffer's grid is the film's. */
            pool->width = pool->phase == UB_PHASE_TRACE ? hb.w : film->w;
            pool->height = pool->phase == UB_PHASE_TRACE ? hb.h : film->h;
            run_job(pool, started, opt, phases * (s - first) + phase, phases * count);
        }
    }
    stats->seconds = ub_monotonic_seconds() - t0;
    pool->tile_finished = NULL;
    pool->per_thread = NULL;
    pool->scene = NULL;
    crew_give_back(crew);
    for (int i = 0; i < threads; i++)
        ub_counters_add(&stats->counters, &per_thread[i].counters);
    stats->threads = started ? started : 1;
    stats->isa = ub_isa_names[kernel];
    stats->cancelled = __atomic_load_n(scene.cancel, __ATOMIC_RELAXED) != 0;
    if (finished && stats->cancelled)
        clear_unfinished_tiles(film, opt->tile_size, finished);
    free(finished);
    free(per_thread);
    hit_buffer_give_back(hb.hits);
    kept_cones_release(kept, scene_in, &cones, taken);
    return NULL;
}
