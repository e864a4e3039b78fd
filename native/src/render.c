/* Tiles of the film handed to a pool of threads; the calling thread polls progress/cancel. */
#include "render.h"

#include <stdlib.h>
#include <string.h>
#include <time.h>
#if defined(__x86_64__) || defined(_M_X64)
#include <immintrin.h>
#endif
#include <pthread.h>
#include <unistd.h>

int ub_cpu_has_avx2_fma(void)
{
#if (defined(__x86_64__) || defined(_M_X64)) && defined(__GNUC__)
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
    return 0;
#endif
}

int ub_cpu_count(void)
{
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? (int)(n > UB_MAX_THREADS ? UB_MAX_THREADS : n) : 1;
}

typedef struct {
    const ub_scene *scene;
    ub_tile_kernel kernel;
    int tile, tiles_x, tile_count;
    int next_tile;            /* atomic: next tile to hand out */
    int tiles_done;           /* atomic */
    int workers_running;      /* guarded by lock */
    pthread_mutex_t lock;
    pthread_cond_t finished;  /* signalled when a worker exits */
    ub_counters *per_thread;
} ub_job;

typedef struct {
    ub_job *job;
    int index;
    pthread_t thread;
    int started;
} ub_worker;

static void *worker_main(void *arg)
{
    ub_worker *w = arg;
    ub_job *job = w->job;
#if defined(__x86_64__) || defined(_M_X64)
    /* Same floating-point environment in every worker, whatever the caller's: round to nearest,
     * denormals flushed (FTZ | DAZ), exceptions masked. Part of what makes pixels independent of
     * the thread that computes them. */
    _mm_setcsr(0x1f80 | 0x8040);
#endif
    const ub_film *film = job->scene->film;
    for (;;) {
        if (__atomic_load_n(job->scene->cancel, __ATOMIC_RELAXED))
            break;
        int t = __atomic_fetch_add(&job->next_tile, 1, __ATOMIC_RELAXED);
        if (t >= job->tile_count)
            break;
        int tx = (t % job->tiles_x) * job->tile, ty = (t / job->tiles_x) * job->tile;
        int tx1 = tx + job->tile < film->w ? tx + job->tile : film->w;
        int ty1 = ty + job->tile < film->h ? ty + job->tile : film->h;
        job->kernel(job->scene, tx, ty, tx1, ty1, &job->per_thread[w->index]);
        __atomic_fetch_add(&job->tiles_done, 1, __ATOMIC_RELEASE);
    }
    pthread_mutex_lock(&job->lock);
    job->workers_running--;
    pthread_cond_signal(&job->finished);
    pthread_mutex_unlock(&job->lock);
    return NULL;
}

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

const char *ub_render(const ub_scene *scene, const ub_render_options *opt, ub_render_stats *stats)
{
    memset(stats, 0, sizeof *stats);
    int use_avx2 = opt->isa == UB_ISA_AVX2 || (opt->isa == UB_ISA_AUTO && ub_cpu_has_avx2_fma());
    if (opt->isa == UB_ISA_AVX2 && !ub_cpu_has_avx2_fma())
        return "simd='avx2' requested but this CPU lacks AVX2/FMA";
    ub_job job;
    memset(&job, 0, sizeof job);
    job.scene = scene;
    job.kernel = use_avx2 ? ub_render_tile_avx2 : ub_render_tile_portable;
    job.tile = opt->tile_size;
    job.tiles_x = (scene->film->w + job.tile - 1) / job.tile;
    int tiles_y = (scene->film->h + job.tile - 1) / job.tile;
    job.tile_count = job.tiles_x * tiles_y;
    int threads = opt->threads > 0 ? opt->threads : ub_cpu_count();
    if (threads > job.tile_count)
        threads = job.tile_count;
    if (threads < 1)
        threads = 1;
    job.per_thread = calloc((size_t)threads, sizeof(ub_counters));
    ub_worker *workers = calloc((size_t)threads, sizeof(ub_worker));
    if (!job.per_thread || !workers) {
        free(job.per_thread);
        free(workers);
        return "out of memory";
    }
    double t0 = now_seconds();
    pthread_mutex_init(&job.lock, NULL);
    pthread_condattr_t cattr;
    pthread_condattr_init(&cattr);
    pthread_condattr_setclock(&cattr, CLOCK_MONOTONIC);
    pthread_cond_init(&job.finished, &cattr);
    pthread_condattr_destroy(&cattr);
    job.workers_running = threads;
    int started = 0;
    for (int i = 0; i < threads; i++) {
        workers[i].job = &job;
        workers[i].index = i;
        if (pthread_create(&workers[i].thread, NULL, worker_main, &workers[i]) == 0) {
            workers[i].started = 1;
            started++;
        } else {
            pthread_mutex_lock(&job.lock);
            job.workers_running--;
            pthread_mutex_unlock(&job.lock);
        }
    }
    if (!started) {
        /* No thread could be created: render on the calling thread. */
        job.workers_running = 1;
        workers[0].started = 0;
        worker_main(&workers[0]);
    }
    /* Poll: report progress and let the caller cancel, until the workers are done. */
    pthread_mutex_lock(&job.lock);
    while (job.workers_running > 0) {
        struct timespec deadline;
        clock_gettime(CLOCK_MONOTONIC, &deadline);
        deadline.tv_nsec += opt->poll_interval_ns;
        while (deadline.tv_nsec >= 1000000000L) {
            deadline.tv_nsec -= 1000000000L;
            deadline.tv_sec++;
        }
        pthread_cond_timedwait(&job.finished, &job.lock, &deadline);
        if (job.workers_running > 0 && opt->poll) {
            pthread_mutex_unlock(&job.lock);
            double frac = (double)__atomic_load_n(&job.tiles_done, __ATOMIC_ACQUIRE) / job.tile_count;
            if (opt->poll(opt->poll_data, frac))
                __atomic_store_n(scene->cancel, 1, __ATOMIC_RELAXED);
            pthread_mutex_lock(&job.lock);
        }
    }
    pthread_mutex_unlock(&job.lock);
    for (int i = 0; i < threads; i++)
        if (workers[i].started)
            pthread_join(workers[i].thread, NULL);
    stats->seconds = now_seconds() - t0;
    for (int i = 0; i < threads; i++) {
        stats->counters.rays += job.per_thread[i].rays;
        stats->counters.steps += job.per_thread[i].steps;
        stats->counters.iterations += job.per_thread[i].iterations;
    }
    stats->threads = started ? started : 1;
    stats->isa = use_avx2 ? "avx2" : "portable";
    stats->cancelled = __atomic_load_n(scene->cancel, __ATOMIC_RELAXED) != 0;
    pthread_cond_destroy(&job.finished);
    pthread_mutex_destroy(&job.lock);
    free(job.per_thread);
    free(workers);
    return NULL;
}
