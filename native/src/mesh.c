/* Convert to Mesh: the surface {estimate = epsilon} of one object as a closed, manifold triangle
 * mesh, in object space, without a dense grid.
 *
 * The lattice: L = resolution + 2 cells per axis over the bounding ball's cube padded by one cell
 * (cell size h = 2 R / resolution), so every lattice point on its boundary lies outside the
 * ball. A lattice point is *inside* when it lies within R + h/2 of the ball's centre and the
 * estimate there is below epsilon; every other point is outside. Signs are strictly binary.
 *
 * 1. Seeds (narrow band by scan lines): lattice lines along the three axes every `seed_spacing`
 *    cells are walked from outside with the estimate's unbounding steps (as the renderer marches
 *    a ray), cell by cell inside; each sign change along a line gives a seed cell.
 * 2. Boundary tracking: breadth-first from the seeds over cells. A cell whose eight corners do
 *    not all agree is active; the neighbour across each of its faces with mixed corners is
 *    visited next. The active cells are closed under that rule, which makes the surface
 *    watertight whatever the seeds found; only pieces no scan line meets can be missed. The
 *    corner signs live in a hash table (memory grows with the surface, not the volume).
 * 3. Marching tetrahedra on the Kuhn split of each active cell into six tetrahedra along its
 *    main diagonal (the split is the same in every cell, so shared faces match): the surface of
 *    a piecewise-linear sign field with no zero is a closed 2-manifold, each edge in exactly two
 *    triangles. Triangles are oriented outward by exact integer arithmetic on the edges'
 *    midpoints. One vertex per lattice edge with a sign change.
 * 4. Projection: each vertex is bisected along its lattice edge between the inside and the
 *    outside end down to h / 2^14 (the estimate is only a lower bound of the distance, so no
 *    Newton step along it: bisection on its sign is what stays on the edge and is safe); the
 *    vertex is the bracket's outside end, where the estimate is >= epsilon and within float
 *    precision of the crossing.
 * 5. Pieces smaller than min_faces are removed; orbit trap, escape count and the estimate at the
 *    vertices are computed with the kernel's own arithmetic.
 *
 * The quaternion Julia and Mandelbrot kinds (without deep zoom) take every sign, every bisection
 * step and the vertex attributes from a float64 estimate (mesh_kernel.h, ub_mesh_estimate64):
 * the float32 orbit strays from the float64 one near the set, and left 1.8% of the vertices
 * inside the float64 surface at 256 cells; now each vertex is outside it and within a bracket of
 * a point inside. The points are float32 (the lattice's, the bisection's midpoints), so a
 * vertex's estimate is that of the point stored.
 *
 * Cancel: the caller's thread polls between chunks of every parallel loop and every 4096 items of
 * every serial stretch (serial_poll); big buffers freed after a cancel are freed by a helper
 * thread after the return (bury, reap). A cancel returns within milliseconds in every phase.
 *
 * Deterministic: cells are sorted before triangulation and every value is a pure function of a
 * point, so the output is the same bytes for any thread count and ISA. */
#include "mesh.h"

#include "port.h"
#include "render.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>


#define KEY_BITS 20
#define KEY_MASK ((1ull << KEY_BITS) - 1)
#define EMPTY_KEY (~0ull)

static inline uint64_t pack(int64_t i, int64_t j, int64_t k)
{
    return (uint64_t)i | ((uint64_t)j << KEY_BITS) | ((uint64_t)k << (2 * KEY_BITS));
}
static inline void unpack(uint64_t key, int64_t ijk[3])
{
    ijk[0] = (int64_t)(key & KEY_MASK);
    ijk[1] = (int64_t)((key >> KEY_BITS) & KEY_MASK);
    ijk[2] = (int64_t)((key >> (2 * KEY_BITS)) & KEY_MASK);
}
static const uint64_t AXIS_STEP[3] = {1ull, 1ull << KEY_BITS, 1ull << (2 * KEY_BITS)};

/* ---------------------------------------------------------------- context, memory */

#define BURY_MAX 64 /* buffers buried at most; more are freed at once */

typedef struct {
    const ub_object *o;
    const ub_mesh_options *opt;
    int use_avx2, threads;
    /* The quaternion kinds (without deep zoom, whose estimate is double already): every sign and
     * every vertex from the float64 estimate (mesh_kernel.h, ub_mesh_estimate64). */
    int float64;
    double origin[3], h, R, center[3], eps;
    float epsf;
    int64_t L; /* cells per axis; lattice points 0..L */
    size_t bytes, peak;
    int failed; /* out of memory */
    volatile int cancel;
    double next_poll, progress_lo, progress_hi;
    int64_t evaluations; /* atomic */
    /* Large buffers freed after a cancel, to be given back by a helper thread (bury, reap). */
    void *buried[BURY_MAX];
    int buried_count;
} mctx;

static void *m_realloc(mctx *c, void *p, size_t old, size_t size)
{
    void *q = realloc(p, size ? size : 1);
    if (!q) {
        c->failed = 1;
        return NULL;
    }
    c->bytes = c->bytes - old + size;
    if (c->bytes > c->peak)
        c->peak = c->bytes;
    return q;
}
/* Once cancelled, a buffer of a megabyte or more is not freed here but buried: handing a gigabyte
 * back to the system takes 50 ms (the pages are unmapped one by one), 0.2 s at 2048 cells, and
 * the cancelled extraction should return at once. */
#define BURY_BYTES ((size_t)1 << 20)
static void bury(mctx *c, void *p, size_t size)
{
    if (p && size >= BURY_BYTES && c->buried_count < BURY_MAX)
        c->buried[c->buried_count++] = p;
    else
        free(p);
}
static void m_free(mctx *c, void *p, size_t size)
{
    if (c->cancel)
        bury(c, p, size);
    else
        free(p);
    c->bytes -= size;
}

#define REAP_DELAY_MS 200
typedef struct {
    void *buffers[BURY_MAX];
    int count;
} grave;

UB_THREAD_ENTRY(reap_grave, arg)
{
    grave *g = arg;
    ub_sleep_ms(REAP_DELAY_MS);
    for (int i = 0; i < g->count; i++)
        free(g->buffers[i]);
    free(g);
    UB_THREAD_RETURN;
}

/* The buried buffers go back to the system on a thread of their own, REAP_DELAY_MS after the
 * return: unmapping holds the process's memory-map lock, and freeing at once made the caller's
 * own page faults wait for it (a cancel at 1024 cells returned 40 ms late). Here if no thread can
 * be made. */
static void reap(mctx *c)
{
    if (!c->buried_count)
        return;
    grave *g = malloc(sizeof *g);
    ub_thread t;
    if (g) {
        g->count = c->buried_count;
        memcpy(g->buffers, c->buried, sizeof g->buffers);
        if (ub_thread_start(&t, reap_grave, g)) {
            ub_thread_detach(t);
            c->buried_count = 0;
            return;
        }
        free(g);
    }
    for (int i = 0; i < c->buried_count; i++)
        free(c->buried[i]);
    c->buried_count = 0;
}

/* A growable array of fixed-size items. */
typedef struct {
    char *data;
    size_t n, cap, item;
} vec;

static int vec_reserve(mctx *c, vec *v, size_t want)
{
    if (want <= v->cap)
        return 0;
    size_t cap = v->cap ? v->cap : 1024;
    while (cap < want)
        cap *= 2;
    char *d = m_realloc(c, v->data, v->cap * v->item, cap * v->item);
    if (!d)
        return -1;
    v->data = d;
    v->cap = cap;
    return 0;
}
static void *vec_push(mctx *c, vec *v)
{
    if (vec_reserve(c, v, v->n + 1))
        return NULL;
    return v->data + v->item * v->n++;
}
static void vec_free(mctx *c, vec *v)
{
    m_free(c, v->data, v->cap * v->item);
    v->data = NULL;
    v->n = v->cap = 0;
}
#define VEC(type) ((vec){NULL, 0, 0, sizeof(type)})
#define AT(v, type, i) (((type *)(v).data)[i])

static inline int serial_poll(mctx *c, size_t i);

/* Sets n bytes to value in pieces, polling between them: the hash maps of a 2048-cell extraction
 * are gigabytes, and touching them for the first time takes a good part of a second. Returns
 * whether to stop (cancelled). */
static int chunked_memset(mctx *c, void *p, int value, size_t n)
{
    const size_t piece = (size_t)1 << 22;
    for (size_t at = 0; at < n; at += piece) {
        if (serial_poll(c, 0))
            return -1;
        memset((char *)p + at, value, n - at < piece ? n - at : piece);
    }
    return 0;
}

/* Open addressing, linear probing: u64 key -> u32 value. */
typedef struct {
    uint64_t *keys;
    uint32_t *vals;
    size_t cap, count;
} hmap;

static inline size_t hash64(uint64_t x)
{
    x ^= x >> 31;
    x *= 0x7fb5d329728ea185ull;
    x ^= x >> 27;
    x *= 0x81dadef4bc2dd44dull;
    x ^= x >> 33;
    return (size_t)x;
}

/* -1: out of memory or cancelled, and m is an empty map (hmap_free may still be called). */
static int hmap_init(mctx *c, hmap *m, size_t cap)
{
    m->cap = cap;
    m->count = 0;
    m->keys = m_realloc(c, NULL, 0, cap * sizeof(uint64_t));
    m->vals = m_realloc(c, NULL, 0, cap * sizeof(uint32_t));
    if (m->keys && m->vals && !chunked_memset(c, m->keys, 0xff, cap * sizeof(uint64_t)))
        return 0;
    m_free(c, m->keys, m->keys ? cap * sizeof(uint64_t) : 0);
    m_free(c, m->vals, m->vals ? cap * sizeof(uint32_t) : 0);
    m->keys = NULL;
    m->vals = NULL;
    m->cap = 0;
    return -1;
}
static void hmap_free(mctx *c, hmap *m)
{
    m_free(c, m->keys, m->cap * sizeof(uint64_t));
    m_free(c, m->vals, m->cap * sizeof(uint32_t));
    m->keys = NULL;
    m->vals = NULL;
    m->cap = m->count = 0;
}
/* Pointer to the value of key, or NULL. */
static inline uint32_t *hmap_get(const hmap *m, uint64_t key)
{
    size_t mask = m->cap - 1, i = hash64(key) & mask;
    for (;;) {
        uint64_t k = m->keys[i];
        if (k == key)
            return &m->vals[i];
        if (k == EMPTY_KEY)
            return NULL;
        i = (i + 1) & mask;
    }
}
/* Doubles the map; -1: out of memory or cancelled (the map is left as it was). */
static int hmap_grow(mctx *c, hmap *m)
{
    hmap n;
    if (hmap_init(c, &n, m->cap * 2))
        return -1;
    size_t mask = n.cap - 1;
    for (size_t s = 0; s < m->cap; s++) {
        if (serial_poll(c, s)) { /* a rehash of tens of millions of keys takes a second */
            hmap_free(c, &n);
            return -1;
        }
        uint64_t k = m->keys[s];
        if (k == EMPTY_KEY)
            continue;
        size_t i = hash64(k) & mask;
        while (n.keys[i] != EMPTY_KEY)
            i = (i + 1) & mask;
        n.keys[i] = k;
        n.vals[i] = m->vals[s];
    }
    n.count = m->count;
    hmap_free(c, m);
    *m = n;
    return 0;
}
/* Inserts key with value v if absent. Returns 1 if inserted, 0 if present, -1 out of memory;
 * *slot points at the value either way. */
static int hmap_put(mctx *c, hmap *m, uint64_t key, uint32_t v, uint32_t **slot)
{
    if (2 * (m->count + 1) > m->cap && hmap_grow(c, m))
        return -1;
    size_t mask = m->cap - 1, i = hash64(key) & mask;
    for (;;) {
        uint64_t k = m->keys[i];
        if (k == key) {
            *slot = &m->vals[i];
            return 0;
        }
        if (k == EMPTY_KEY)
            break;
        i = (i + 1) & mask;
    }
    m->keys[i] = key;
    m->vals[i] = v;
    m->count++;
    *slot = &m->vals[i];
    return 1;
}

/* ---------------------------------------------------------------- parallel loop with polls */

typedef void (*range_fn)(mctx *c, void *arg, size_t lo, size_t hi);

typedef struct {
    mctx *c;
    range_fn fn;
    void *arg;
    size_t count, chunk;
    size_t next, done; /* atomic */
} pjob;

static void pjob_loop(pjob *j, int caller)
{
    mctx *c = j->c;
    for (;;) {
        if (__atomic_load_n(&c->cancel, __ATOMIC_RELAXED))
            break;
        size_t lo = __atomic_fetch_add(&j->next, j->chunk, __ATOMIC_RELAXED);
        if (lo >= j->count)
            break;
        size_t hi = lo + j->chunk < j->count ? lo + j->chunk : j->count;
        j->fn(c, j->arg, lo, hi);
        size_t done = __atomic_add_fetch(&j->done, hi - lo, __ATOMIC_RELAXED);
        if (caller && c->opt->poll) {
            double now = ub_monotonic_seconds();
            if (now >= c->next_poll) {
                c->next_poll = now + c->opt->poll_interval;
                double f = c->progress_lo + (c->progress_hi - c->progress_lo) * (double)done / (double)j->count;
                if (c->opt->poll(c->opt->poll_data, f))
                    __atomic_store_n(&c->cancel, 1, __ATOMIC_RELAXED);
            }
        }
    }
}

UB_THREAD_ENTRY(pjob_worker, arg)
{
    uint64_t fp = ub_fp_enter();
    pjob_loop(arg, 0);
    ub_fp_leave(fp);
    UB_THREAD_RETURN;
}

static void parallel_for(mctx *c, size_t count, size_t chunk, range_fn fn, void *arg)
{
    if (count == 0 || c->cancel)
        return;
    pjob j = {c, fn, arg, count, chunk, 0, 0};
    int extra = c->threads - 1;
    size_t chunks = (count + chunk - 1) / chunk;
    if ((size_t)extra > chunks - 1)
        extra = (int)(chunks - 1);
    ub_thread th[UB_MAX_THREADS];
    int started[UB_MAX_THREADS] = {0};
    for (int i = 0; i < extra; i++)
        started[i] = ub_thread_start(&th[i], pjob_worker, &j);
    pjob_loop(&j, 1);
    for (int i = 0; i < extra; i++)
        if (started[i])
            ub_thread_join(th[i]);
}

/* Items a chunk of a parallel loop, for `items` at the default 16 iterations: fewer for more
 * iterations, since a chunk is what a cancel waits for (the UI allows 10000 iterations, and a
 * point inside the set runs them all). Chunks change no result: each item is its own. */
static size_t chunk_items(const mctx *c, size_t items)
{
    size_t scaled = items * 16 / (size_t)(c->o->max_iterations > 16 ? c->o->max_iterations : 16);
    return scaled > 16 ? scaled : 16;
}

/* A poll between phases (no parallel loop running). */
static void poll_now(mctx *c, double f)
{
    if (c->opt->poll && !c->cancel) {
        c->next_poll = ub_monotonic_seconds() + c->opt->poll_interval;
        if (c->opt->poll(c->opt->poll_data, f))
            c->cancel = 1;
    }
}

/* A poll inside a long serial stretch of the caller's thread (no parallel loop running), looked at
 * every 4096 items (a few milliseconds of hash-map work at most): the flood fill's per-wave
 * bookkeeping, hash-map growth, the sort and the crumbs run for seconds between parallel loops at
 * 2048 cells, and a cancel must stop within the poll interval there too. Returns whether to stop. */
static inline int serial_poll(mctx *c, size_t i)
{
    if ((i & 4095) == 0 && c->opt->poll && ub_monotonic_seconds() >= c->next_poll)
        poll_now(c, c->progress_hi); /* where the last parallel loop's progress ended */
    return c->cancel;
}

/* ---------------------------------------------------------------- the estimate at points */

static inline void lattice_point(const mctx *c, uint64_t key, double p[3])
{
    int64_t ijk[3];
    unpack(key, ijk);
    for (int a = 0; a < 3; a++)
        p[a] = c->origin[a] + c->h * (double)ijk[a];
}

static inline int in_ball(const mctx *c, const double p[3])
{
    double s = 0.0;
    for (int a = 0; a < 3; a++)
        s += (p[a] - c->center[a]) * (p[a] - c->center[a]);
    double r = c->R + 0.5 * c->h;
    return s <= r * r;
}

/* inside[i] = point i (double, 3 per point) is inside; n <= 1024. */
static void classify(mctx *c, const double *pts, size_t n, uint8_t *inside, float *est_out)
{
    float xyz[3 * 1024], est[1024], it[1024];
    size_t idx[1024], m = 0;
    for (size_t i = 0; i < n; i++) {
        inside[i] = 0;
        if (est_out)
            est_out[i] = INFINITY;
        if (!in_ball(c, pts + 3 * i))
            continue;
        for (int a = 0; a < 3; a++)
            xyz[3 * m + a] = (float)pts[3 * i + a];
        idx[m++] = i;
    }
    if (!m)
        return;
    __atomic_add_fetch(&c->evaluations, (int64_t)m, __ATOMIC_RELAXED);
    if (c->float64) {
        double est64[1024];
        (c->use_avx2 ? ub_mesh_estimate64_avx2 : ub_mesh_estimate64_portable)(c->o, xyz, m, est64, NULL, NULL);
        for (size_t q = 0; q < m; q++) {
            inside[idx[q]] = est64[q] < c->eps;
            if (est_out)
                est_out[idx[q]] = (float)est64[q];
        }
        return;
    }
    (c->use_avx2 ? ub_estimate_avx2 : ub_estimate_portable)(c->o, xyz, m, est, it);
    for (size_t q = 0; q < m; q++) {
        inside[idx[q]] = est[q] < c->epsf;
        if (est_out)
            est_out[idx[q]] = est[q];
    }
}

/* ---------------------------------------------------------------- 1. seeds by scan lines */

typedef struct {
    int spacing;
    int64_t per_axis; /* lines per side */
    vec *out;         /* one vec of seed cell keys per chunk of lines */
    size_t chunk;
} seed_job;

static void scan_line(mctx *c, int axis, int64_t u, int64_t v, vec *out)
{
    int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    int64_t ijk[3];
    ijk[a1] = u;
    ijk[a2] = v;
    int64_t t = 0, L = c->L;
    int state = 0; /* outside at t = 0 */
    double pts[8 * 3];
    uint8_t in[8];
    float est[8];
    while (t <= L) {
        int n = 0;
        for (; n < 8 && t + n <= L; n++) {
            ijk[axis] = t + n;
            lattice_point(c, pack(ijk[0], ijk[1], ijk[2]), pts + 3 * n);
        }
        classify(c, pts, (size_t)n, in, est);
        for (int k = 0; k < n; k++) {
            if (in[k] != state) {
                state = in[k];
                int64_t cell[3] = {ijk[0], ijk[1], ijk[2]};
                cell[axis] = t + k - 1;
                /* The four cells around the edge (t+k-1, t+k): one suffices to start tracking,
                 * but take the one inside the lattice. */
                if (cell[axis] >= 0 && cell[a1] < L && cell[a2] < L) {
                    uint64_t *s = vec_push(c, out);
                    if (!s)
                        return;
                    *s = pack(cell[0], cell[1], cell[2]);
                }
            }
        }
        int64_t next = t + n;
        if (!state && est[n - 1] < INFINITY) {
            /* Unbounding step from the last point, as the renderer marches (0.9 of it). */
            double jump = 0.9 * ((double)est[n - 1] - c->eps) / c->h;
            if (jump > 1.0)
                next = t + n - 1 + (int64_t)(jump < (double)L ? jump : (double)L);
        } else if (!state && !(est[n - 1] < INFINITY)) {
            /* Outside the ball: jump to where the line enters it (or past the end). */
            double p[3];
            lattice_point(c, pack(ijk[0], ijk[1], ijk[2]), p);
            double s = 0.0;
            for (int a = 0; a < 3; a++)
                if (a != axis)
                    s += (p[a] - c->center[a]) * (p[a] - c->center[a]);
            double r = c->R + 0.5 * c->h;
            if (s > r * r)
                break; /* the line misses the ball */
            double enter = c->center[axis] - sqrt(r * r - s);
            int64_t te = (int64_t)floor((enter - c->origin[axis]) / c->h);
            if (te > next)
                next = te;
            if (p[axis] > c->center[axis])
                break; /* past the ball */
        }
        t = next;
    }
}

static void seed_range(mctx *c, void *arg, size_t lo, size_t hi)
{
    seed_job *sj = arg;
    vec *out = &sj->out[lo / sj->chunk];
    for (size_t line = lo; line < hi; line++) {
        int axis = (int)(line / (size_t)(sj->per_axis * sj->per_axis));
        size_t r = line % (size_t)(sj->per_axis * sj->per_axis);
        int64_t u = 1 + (int64_t)(r / (size_t)sj->per_axis) * sj->spacing;
        int64_t v = 1 + (int64_t)(r % (size_t)sj->per_axis) * sj->spacing;
        scan_line(c, axis, u, v, out);
    }
}

/* ---------------------------------------------------------------- 2. boundary tracking */

typedef struct {
    const uint64_t *keys;
    uint8_t *inside;
} eval_job;

static void eval_range(mctx *c, void *arg, size_t lo, size_t hi)
{
    eval_job *ej = arg;
    double pts[3 * 256];
    for (size_t b = lo; b < hi; b += 256) {
        size_t n = hi - b < 256 ? hi - b : 256;
        for (size_t i = 0; i < n; i++)
            lattice_point(c, ej->keys[b + i], pts + 3 * i);
        classify(c, pts, n, ej->inside + b, NULL);
    }
}

typedef struct {
    uint64_t key;
    uint32_t mask; /* bit x | y<<1 | z<<2: that corner is inside */
    uint32_t pad;
} cell_rec;

static const uint64_t CORNER_OFFSET[8] = {
    0, 1ull, 1ull << KEY_BITS, 1ull | (1ull << KEY_BITS), 1ull << (2 * KEY_BITS), 1ull | (1ull << (2 * KEY_BITS)),
    (1ull << KEY_BITS) | (1ull << (2 * KEY_BITS)), 1ull | (1ull << KEY_BITS) | (1ull << (2 * KEY_BITS)),
};

/* Corners of the face of a cube normal to `axis` on side `side`: the corner bits with that
 * axis bit equal to side. */
static inline uint32_t face_mask(int axis, int side)
{
    uint32_t m = 0;
    for (int k = 0; k < 8; k++)
        if (((k >> axis) & 1) == side)
            m |= 1u << k;
    return m;
}

static int track(mctx *c, vec *seeds, vec *active, int64_t *visited_count)
{
    hmap corners = {0}, visited = {0};
    vec frontier = VEC(uint64_t), next = VEC(uint64_t), todo = VEC(uint64_t), flags = VEC(uint8_t);
    int rc = -1;
    uint32_t *slot;
    if (hmap_init(c, &corners, 1 << 16) || hmap_init(c, &visited, 1 << 16))
        goto out;
    for (size_t i = 0; i < seeds->n; i++) {
        uint64_t k = AT(*seeds, uint64_t, i);
        int r = hmap_put(c, &visited, k, 0, &slot);
        if (r < 0)
            goto out;
        if (r == 1) {
            uint64_t *s = vec_push(c, &frontier);
            if (!s)
                goto out;
            *s = k;
        }
    }
    uint32_t fm[3][2];
    for (int a = 0; a < 3; a++)
        for (int s = 0; s < 2; s++)
            fm[a][s] = face_mask(a, s);
    int wave = 0;
    while (frontier.n && !c->cancel) {
        /* Corners not yet known: evaluate them all at once. */
        todo.n = 0;
        for (size_t i = 0; i < frontier.n && !serial_poll(c, i); i++) {
            uint64_t cell = AT(frontier, uint64_t, i);
            for (int k = 0; k < 8; k++) {
                uint64_t p = cell + CORNER_OFFSET[k];
                int r = hmap_put(c, &corners, p, (uint32_t)todo.n, &slot);
                if (r < 0)
                    goto out;
                if (r == 1) {
                    uint64_t *s = vec_push(c, &todo);
                    if (!s)
                        goto out;
                    *s = p;
                }
            }
        }
        if (vec_reserve(c, &flags, todo.n))
            goto out;
        eval_job ej = {(const uint64_t *)todo.data, (uint8_t *)flags.data};
        c->progress_lo = 0.15 + 0.45 * (1.0 - 1.0 / (1.0 + wave / 8.0));
        c->progress_hi = 0.15 + 0.45 * (1.0 - 1.0 / (1.0 + (wave + 1) / 8.0));
        parallel_for(c, todo.n, chunk_items(c, 4096), eval_range, &ej);
        if (c->cancel)
            break;
        /* The values are now the inside flags. */
        for (size_t i = 0; i < todo.n && !serial_poll(c, i); i++)
            *hmap_get(&corners, AT(todo, uint64_t, i)) = 0x80000000u | AT(flags, uint8_t, i);
        if (c->cancel)
            break;
        next.n = 0;
        for (size_t i = 0; i < frontier.n && !serial_poll(c, i); i++) {
            uint64_t cell = AT(frontier, uint64_t, i);
            uint32_t mask = 0;
            for (int k = 0; k < 8; k++)
                mask |= (*hmap_get(&corners, cell + CORNER_OFFSET[k]) & 1u) << k;
            if (mask == 0 || mask == 0xff)
                continue;
            cell_rec *r = vec_push(c, active);
            if (!r)
                goto out;
            r->key = cell;
            r->mask = mask;
            r->pad = 0;
            int64_t ijk[3];
            unpack(cell, ijk);
            for (int a = 0; a < 3; a++)
                for (int s = 0; s < 2; s++) {
                    uint32_t f = mask & fm[a][s];
                    if (f == 0 || f == fm[a][s])
                        continue;
                    /* Lattice points on the border are outside, so mixed faces never lie there. */
                    if ((s == 0 && ijk[a] == 0) || (s == 1 && ijk[a] + 1 >= c->L))
                        continue;
                    uint64_t nb = s ? cell + AXIS_STEP[a] : cell - AXIS_STEP[a];
                    int pr = hmap_put(c, &visited, nb, 0, &slot);
                    if (pr < 0)
                        goto out;
                    if (pr == 1) {
                        uint64_t *q = vec_push(c, &next);
                        if (!q)
                            goto out;
                        *q = nb;
                    }
                }
        }
        vec t = frontier;
        frontier = next;
        next = t;
        wave++;
    }
    *visited_count = (int64_t)visited.count;
    rc = 0;
out:
    vec_free(c, &frontier);
    vec_free(c, &next);
    vec_free(c, &todo);
    vec_free(c, &flags);
    hmap_free(c, &corners);
    hmap_free(c, &visited);
    return rc;
}

/* LSD radix sort of the cells by key (11-bit digits over the 60 key bits), polling as it goes (a
 * third of a second at 1024 cells, serial). -1: out of memory or cancelled (cells unsorted). */
static int sort_cells(mctx *c, vec *cells)
{
    size_t n = cells->n;
    cell_rec *a = (cell_rec *)cells->data, *spare = m_realloc(c, NULL, 0, n * sizeof(cell_rec)), *b = spare;
    if (!spare)
        return -1;
    size_t count[2048];
    int rc = 0;
    for (int shift = 0; shift < 3 * KEY_BITS && rc == 0; shift += 11) {
        memset(count, 0, sizeof count);
        for (size_t i = 0; i < n && !serial_poll(c, i); i++)
            count[(a[i].key >> shift) & 2047]++;
        size_t sum = 0;
        for (int d = 0; d < 2048; d++) {
            size_t t = count[d];
            count[d] = sum;
            sum += t;
        }
        for (size_t i = 0; i < n && !serial_poll(c, i); i++)
            b[count[(a[i].key >> shift) & 2047]++] = a[i];
        cell_rec *t = a;
        a = b;
        b = t;
        rc = c->cancel ? -1 : 0;
    }
    /* Six passes: the sorted data is back in the original buffer; the spare one goes (cancelled
     * half way, the cells' order no longer matters). */
    m_free(c, spare, n * sizeof(cell_rec));
    return rc;
}

/* ---------------------------------------------------------------- 3. marching tetrahedra */

typedef struct {
    uint64_t key; /* lower lattice point << 3 | direction bits */
    uint32_t lower_inside;
    uint32_t pad;
} edge_rec;

/* ---------------------------------------------------------------- 4. projection by bisection */

#define BISECTIONS 14

typedef struct {
    const edge_rec *edges;
    float *vertices;
} bisect_job;

static void bisect_range(mctx *c, void *arg, size_t lo, size_t hi)
{
    bisect_job *bj = arg;
    enum { B = 128 };
    double in_p[B][3], out_p[B][3], mid[B * 3];
    uint8_t flag[B];
    for (size_t base = lo; base < hi; base += B) {
        size_t n = hi - base < B ? hi - base : B;
        for (size_t i = 0; i < n; i++) {
            const edge_rec *e = &bj->edges[base + i];
            double p[3], q[3];
            lattice_point(c, e->key >> 3, p);
            int dir = (int)(e->key & 7);
            for (int a = 0; a < 3; a++)
                q[a] = p[a] + (((dir >> a) & 1) ? c->h : 0.0);
            for (int a = 0; a < 3; a++) {
                in_p[i][a] = e->lower_inside ? p[a] : q[a];
                out_p[i][a] = e->lower_inside ? q[a] : p[a];
            }
        }
        for (int it = 0; it < BISECTIONS; it++) {
            for (size_t i = 0; i < n; i++)
                for (int a = 0; a < 3; a++)
                    mid[3 * i + a] = 0.5 * (in_p[i][a] + out_p[i][a]);
            classify(c, mid, n, flag, NULL);
            for (size_t i = 0; i < n; i++)
                for (int a = 0; a < 3; a++) {
                    if (flag[i])
                        in_p[i][a] = mid[3 * i + a];
                    else
                        out_p[i][a] = mid[3 * i + a];
                }
        }
        for (size_t i = 0; i < n; i++)
            for (int a = 0; a < 3; a++)
                bj->vertices[3 * (base + i) + a] = (float)out_p[i][a];
    }
}

/* Projects the pending edges into vertices base.. (parallel), then forgets them. */
static int flush_edges(mctx *c, vec *pend, size_t *base, vec *verts, double done)
{
    if (vec_reserve(c, verts, 3 * (*base + pend->n)))
        return -1;
    bisect_job bj = {(const edge_rec *)pend->data, (float *)verts->data + 3 * *base};
    c->progress_lo = c->progress_hi;
    c->progress_hi = 0.62 + 0.33 * done;
    parallel_for(c, pend->n, chunk_items(c, 1024), bisect_range, &bj);
    *base += pend->n;
    verts->n = 3 * *base;
    pend->n = 0;
    return 0;
}

static void hmap_clear(hmap *m)
{
    memset(m->keys, 0xff, m->cap * sizeof(uint64_t));
    m->count = 0;
}

static int flush_edges(mctx *c, vec *pend, size_t *base, vec *verts, double done);

/* Cells sorted by (k, j, i): an edge whose lower end lies on layer z is used only by cells of
 * layers z - 1 and z, so two layer maps (edge -> vertex) suffice, and the edges found are
 * projected in batches as they come: memory follows one layer of the surface, not all of it. */
static int triangulate(mctx *c, const vec *cells, vec *verts, vec *faces)
{
    hmap maps[2];
    if (hmap_init(c, &maps[0], 1 << 12) || hmap_init(c, &maps[1], 1 << 12))
        return -1;
    vec pend = VEC(edge_rec), *edges = &pend;
    size_t base = 0; /* vertex number of pend[0] */
    int64_t layer = -2;
    int cur = 0;
    static const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    int rc = -1;
    for (size_t ci = 0; ci < cells->n; ci++) {
        if (serial_poll(c, ci)) /* a flush comes every 2^18 edges only: a tenth of a second loaded */
            goto out;
        const cell_rec *cr = &AT(*cells, cell_rec, ci);
        int64_t k = (int64_t)(cr->key >> (2 * KEY_BITS));
        if (k != layer) {
            hmap_clear(&maps[cur]);
            cur ^= 1;
            if (k != layer + 1)
                hmap_clear(&maps[cur]);
            layer = k;
            if (pend.n >= (1u << 18) && flush_edges(c, &pend, &base, verts, (double)ci / (double)cells->n))
                goto out;
            if (c->cancel)
                goto out;
        }
        for (int t = 0; t < 6; t++) {
            int v[4] = {0, 1 << perms[t][0], (1 << perms[t][0]) | (1 << perms[t][1]), 7};
            int ins[4], nin = 0;
            for (int q = 0; q < 4; q++) {
                ins[q] = (cr->mask >> v[q]) & 1;
                nin += ins[q];
            }
            if (nin == 0 || nin == 4)
                continue;
            /* Edges (as pairs of tet vertex indices) of the triangle or quad, in cyclic order. */
            int e[4][2], ne;
            int in_set[4], out_set[4], ni = 0, no = 0;
            for (int q = 0; q < 4; q++) {
                if (ins[q])
                    in_set[ni++] = q;
                else
                    out_set[no++] = q;
            }
            if (ni == 1 || no == 1) {
                int lone = ni == 1 ? in_set[0] : out_set[0];
                const int *others = ni == 1 ? out_set : in_set;
                for (int q = 0; q < 3; q++) {
                    e[q][0] = lone;
                    e[q][1] = others[q];
                }
                ne = 3;
            } else {
                int a = in_set[0], b = in_set[1], cc = out_set[0], d = out_set[1];
                e[0][0] = a, e[0][1] = cc;
                e[1][0] = a, e[1][1] = d;
                e[2][0] = b, e[2][1] = d;
                e[3][0] = b, e[3][1] = cc;
                ne = 4;
            }
            /* Orientation: doubled midpoints in the cube's integer coordinates. */
            int64_t m[4][3];
            for (int q = 0; q < ne; q++)
                for (int ax = 0; ax < 3; ax++)
                    m[q][ax] = ((v[e[q][0]] >> ax) & 1) + ((v[e[q][1]] >> ax) & 1);
            int64_t u[3], w[3], n[3], dir[3] = {0, 0, 0};
            for (int ax = 0; ax < 3; ax++) {
                u[ax] = m[1][ax] - m[0][ax];
                w[ax] = m[2][ax] - m[0][ax];
            }
            n[0] = u[1] * w[2] - u[2] * w[1];
            n[1] = u[2] * w[0] - u[0] * w[2];
            n[2] = u[0] * w[1] - u[1] * w[0];
            /* outward: from the inside corners' centroid to the outside corners' (times ni*no) */
            for (int ax = 0; ax < 3; ax++) {
                int64_t so = 0, si = 0;
                for (int q = 0; q < no; q++)
                    so += (v[out_set[q]] >> ax) & 1;
                for (int q = 0; q < ni; q++)
                    si += (v[in_set[q]] >> ax) & 1;
                dir[ax] = so * ni - si * no;
            }
            int flip = n[0] * dir[0] + n[1] * dir[1] + n[2] * dir[2] < 0;
            uint32_t vid[4];
            for (int q = 0; q < ne; q++) {
                int lo = v[e[q][0]], hi = v[e[q][1]], lo_in = ins[e[q][0]];
                if (lo > hi) { /* Kuhn chain: the smaller corner index is the lower endpoint */
                    int s = lo;
                    lo = hi;
                    hi = s;
                    lo_in = ins[e[q][1]];
                }
                uint64_t key = ((cr->key + CORNER_OFFSET[lo]) << 3) | (uint64_t)(lo ^ hi);
                uint32_t *slot;
                hmap *emap = &maps[(lo >> 2) ? cur ^ 1 : cur];
                int r = hmap_put(c, emap, key, (uint32_t)(base + edges->n), &slot);
                if (r < 0)
                    goto out;
                if (r == 1) {
                    edge_rec *er = vec_push(c, edges);
                    if (!er)
                        goto out;
                    er->key = key;
                    er->lower_inside = (uint32_t)lo_in;
                    er->pad = 0;
                }
                vid[q] = *slot;
            }
            int tris = ne == 3 ? 1 : 2;
            static const int tri_idx[2][3] = {{0, 1, 2}, {0, 2, 3}};
            for (int tr = 0; tr < tris; tr++) {
                int32_t *f = NULL;
                for (int q = 0; q < 3; q++) {
                    int32_t *s = vec_push(c, faces);
                    if (!s)
                        goto out;
                    if (q == 0)
                        f = s;
                }
                f = (int32_t *)faces->data + faces->n - 3;
                f[0] = (int32_t)vid[tri_idx[tr][0]];
                f[1] = (int32_t)vid[flip ? tri_idx[tr][2] : tri_idx[tr][1]];
                f[2] = (int32_t)vid[flip ? tri_idx[tr][1] : tri_idx[tr][2]];
            }
        }
    }
    rc = flush_edges(c, &pend, &base, verts, 1.0);
out:
    hmap_free(c, &maps[0]);
    hmap_free(c, &maps[1]);
    vec_free(c, &pend);
    return rc;
}

/* ---------------------------------------------------------------- 5. attributes */

typedef struct {
    const float *vertices;
    float *trap, *iterations, *estimate;
} attr_job;

static void attr_range(mctx *c, void *arg, size_t lo, size_t hi)
{
    attr_job *aj = arg;
    if (c->float64) {
        double est64[1024];
        for (size_t b = lo; b < hi; b += 1024) {
            size_t n = hi - b < 1024 ? hi - b : 1024;
            (c->use_avx2 ? ub_mesh_estimate64_avx2 : ub_mesh_estimate64_portable)(
                c->o, aj->vertices + 3 * b, n, est64, aj->iterations + b, aj->trap + b);
            for (size_t i = 0; i < n; i++)
                aj->estimate[b + i] = (float)est64[i];
        }
        return;
    }
    (c->use_avx2 ? ub_mesh_attributes_avx2 : ub_mesh_attributes_portable)(
        c->o, aj->vertices + 3 * lo, hi - lo, aj->estimate + lo, aj->iterations + lo, aj->trap + lo);
}

/* ---------------------------------------------------------------- crumbs */

static uint32_t uf_find(uint32_t *parent, uint32_t x)
{
    while (parent[x] != x) {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    return x;
}

/* Removes pieces with fewer than min_faces faces; counts the pieces. Compacts in order. Serial,
 * half a second at 1024 cells: it polls. -1: out of memory or cancelled. */
static int remove_crumbs(mctx *c, vec *faces, float **vertices, size_t *nv, int64_t min_faces, int64_t *pieces,
                         int64_t *removed)
{
    size_t v = *nv, nf = faces->n / 3;
    int rc = -1;
    uint32_t *parent = m_realloc(c, NULL, 0, v * sizeof(uint32_t));
    uint32_t *size = m_realloc(c, NULL, 0, v * sizeof(uint32_t));
    if (!parent || !size)
        goto out;
    int32_t *f = (int32_t *)faces->data;
    for (size_t i = 0; i < v && !serial_poll(c, i); i++) {
        parent[i] = (uint32_t)i;
        size[i] = 0;
    }
    for (size_t t = 0; t < nf && !serial_poll(c, t); t++) {
        uint32_t a = uf_find(parent, (uint32_t)f[3 * t]);
        for (int k = 1; k < 3; k++) {
            uint32_t b = uf_find(parent, (uint32_t)f[3 * t + k]);
            if (a != b) {
                if (a < b)
                    parent[b] = a;
                else {
                    parent[a] = b;
                    a = b;
                }
            }
        }
    }
    for (size_t t = 0; t < nf && !serial_poll(c, t); t++)
        size[uf_find(parent, (uint32_t)f[3 * t])]++;
    if (c->cancel)
        goto out;
    int64_t np = 0, nr = 0;
    for (size_t i = 0; i < v && !serial_poll(c, i); i++)
        if (parent[i] == i && size[i] > 0) {
            np++;
            if ((int64_t)size[i] < min_faces)
                nr++;
        }
    if (c->cancel)
        goto out;
    *pieces = np;
    *removed = nr;
    if (nr) {
        /* New vertex numbers in the old order; size[] becomes the map (UINT32_MAX: dropped). */
        uint32_t *map = parent; /* reuse after reading roots into size[] */
        for (size_t i = 0; i < v && !serial_poll(c, i); i++) {
            uint32_t r = uf_find(parent, (uint32_t)i);
            /* store keep flag in the high bit of size of vertex i (temporary) */
            size[i] = (size[r] & 0x7fffffffu) >= (uint64_t)min_faces ? (size[i] | 0x80000000u) : (size[i] & 0x7fffffffu);
        }
        if (c->cancel)
            goto out;
        /* size[i] >> 31 now tells whether vertex i is kept */
        uint32_t next = 0;
        float *vv = *vertices;
        for (size_t i = 0; i < v && !serial_poll(c, i); i++) {
            if (size[i] >> 31) {
                map[i] = next;
                for (int a = 0; a < 3; a++)
                    vv[3 * next + a] = vv[3 * i + a];
                next++;
            } else
                map[i] = UINT32_MAX;
        }
        size_t out = 0;
        for (size_t t = 0; t < nf && !serial_poll(c, t); t++) {
            if (map[f[3 * t]] == UINT32_MAX)
                continue;
            for (int k = 0; k < 3; k++)
                f[3 * out + k] = (int32_t)map[f[3 * t + k]];
            out++;
        }
        if (c->cancel) /* compacted half way: the caller discards it all */
            goto out;
        faces->n = 3 * out;
        *nv = next;
    }
    rc = 0;
out:
    m_free(c, parent, parent ? v * sizeof(uint32_t) : 0);
    m_free(c, size, size ? v * sizeof(uint32_t) : 0);
    return rc;
}

/* ---------------------------------------------------------------- entry */

void ub_mesh_free(ub_mesh_result *r)
{
    free(r->vertices);
    free(r->faces);
    free(r->trap);
    free(r->iterations);
    free(r->estimate);
    r->vertices = NULL;
    r->faces = NULL;
    r->trap = r->iterations = r->estimate = NULL;
}

const char *ub_extract_mesh(const ub_object *o, const ub_mesh_options *opt, ub_mesh_result *out)
{
    memset(out, 0, sizeof *out);
    double t0 = ub_monotonic_seconds();
    if (opt->resolution < 2 || (int64_t)opt->resolution + 3 >= (int64_t)KEY_MASK)
        return "resolution must be between 2 and 1000000";
    mctx c;
    memset(&c, 0, sizeof c);
    c.o = o;
    c.opt = opt;
    c.use_avx2 = opt->use_avx2;
    c.float64 = (o->kind == UB_KIND_QUATERNION_JULIA || o->kind == UB_KIND_QUATERNION_MANDELBROT) && !o->zoom.enabled;
    c.threads = opt->threads > 0 ? opt->threads : ub_cpu_count();
    if (c.threads > UB_MAX_THREADS)
        c.threads = UB_MAX_THREADS;
    out->threads = c.threads;
    if (!(o->bound_radius > 0.0)) { /* the slice misses the set: an empty mesh */
        out->seconds = ub_monotonic_seconds() - t0;
        return NULL;
    }
    c.R = o->bound_radius;
    for (int a = 0; a < 3; a++)
        c.center[a] = o->bound_center[a];
    c.h = 2.0 * c.R / opt->resolution;
    for (int a = 0; a < 3; a++)
        c.origin[a] = c.center[a] - c.R - c.h;
    c.L = opt->resolution + 2;
    c.eps = opt->epsilon > 0.0 ? opt->epsilon : c.h / 64.0;
    c.epsf = (float)c.eps;
    out->epsilon = c.eps;
    out->cell_size = c.h;
    c.next_poll = t0 + opt->poll_interval;
    uint64_t fp = ub_fp_enter();

    const char *err = NULL;
    vec seeds = VEC(uint64_t), cells = VEC(cell_rec), faces = VEC(int32_t), vv = VEC(float);
    float *verts = NULL;
    size_t nv = 0;

    /* 1. seeds */
    int spacing = opt->seed_spacing > 0 ? opt->seed_spacing : 4;
    if (spacing < (opt->resolution + 255) / 256)
        spacing = (opt->resolution + 255) / 256;
    int64_t per_axis = (c.L - 2 + spacing - 1) / spacing;
    /* Eight lines a chunk at 16 iterations, down to one at 128 or more: a chunk is what a cancel
     * waits for, and a line crosses thousands of cells at the operator's 8192; the seeds come out
     * in line order whatever the chunk. */
    size_t lines = (size_t)(3 * per_axis * per_axis), chunk = chunk_items(&c, 128) / 16;
    size_t nchunks = (lines + chunk - 1) / chunk;
    vec *chunks = m_realloc(&c, NULL, 0, nchunks * sizeof(vec));
    if (!chunks)
        goto oom;
    for (size_t i = 0; i < nchunks; i++)
        chunks[i] = VEC(uint64_t);
    seed_job sj = {spacing, per_axis, chunks, chunk};
    c.progress_lo = 0.0;
    c.progress_hi = 0.15;
    parallel_for(&c, lines, chunk, seed_range, &sj);
    for (size_t i = 0; i < nchunks && !c.failed; i++) {
        if (vec_reserve(&c, &seeds, seeds.n + chunks[i].n))
            break;
        if (chunks[i].n) /* an empty chunk has no buffer: memcpy from NULL is undefined even for 0 bytes */
            memcpy(seeds.data + seeds.n * sizeof(uint64_t), chunks[i].data, chunks[i].n * sizeof(uint64_t));
        seeds.n += chunks[i].n;
    }
    for (size_t i = 0; i < nchunks; i++)
        vec_free(&c, &chunks[i]);
    m_free(&c, chunks, nchunks * sizeof(vec));
    if (c.failed)
        goto oom;
    out->seeds = (int64_t)seeds.n;
    out->phase_seconds[0] = ub_monotonic_seconds() - t0;
    if (c.cancel)
        goto cancelled;

    /* 2. boundary tracking */
    if (track(&c, &seeds, &cells, &out->cells))
        goto oom;
    vec_free(&c, &seeds);
    if (c.cancel)
        goto cancelled;
    out->active_cells = (int64_t)cells.n;
    out->phase_seconds[1] = ub_monotonic_seconds() - t0;
    c.progress_hi = 0.61; /* what the sort's polls report: past every wave's (< 0.6) */
    if (sort_cells(&c, &cells))
        goto oom;
    poll_now(&c, 0.62);

    /* 3-4. triangles, projection */
    c.progress_hi = 0.62;
    if (triangulate(&c, &cells, &vv, &faces))
        goto oom;
    vec_free(&c, &cells);
    out->phase_seconds[2] = out->phase_seconds[3] = ub_monotonic_seconds() - t0;
    if (c.cancel)
        goto cancelled;
    if (vv.n / 3 >= (size_t)INT32_MAX) {
        err = "the mesh has too many vertices: lower the resolution";
        goto done;
    }
    nv = vv.n / 3;
    verts = (float *)vv.data;

    /* 5. crumbs, attributes */
    c.progress_hi = 0.955; /* what the crumbs' polls report */
    if (remove_crumbs(&c, &faces, &verts, &nv, opt->min_faces, &out->pieces, &out->pieces_removed))
        goto oom;
    out->vertex_count = (int64_t)nv;
    out->face_count = (int64_t)(faces.n / 3);
    /* The buffers become the result's (the caller frees them with ub_mesh_free). */
    out->vertices = verts;
    out->faces = (int32_t *)faces.data;
    vv.data = faces.data = NULL;
    vv.n = vv.cap = faces.n = faces.cap = 0;
    out->trap = malloc(nv * sizeof(float) + 1);
    out->iterations = malloc(nv * sizeof(float) + 1);
    out->estimate = malloc(nv * sizeof(float) + 1);
    if (!out->trap || !out->iterations || !out->estimate)
        goto oom;
    c.bytes += 3 * nv * sizeof(float);
    if (c.bytes > c.peak)
        c.peak = c.bytes;
    out->phase_seconds[4] = ub_monotonic_seconds() - t0;
    attr_job aj = {out->vertices, out->trap, out->iterations, out->estimate};
    c.progress_lo = 0.96;
    c.progress_hi = 1.0;
    parallel_for(&c, nv, chunk_items(&c, 4096), attr_range, &aj);
    if (c.cancel)
        goto cancelled;
    goto done;

oom:
    if (c.cancel) /* the serial stretches stop half way and return like a failure when cancelled */
        goto cancelled;
    err = "out of memory while extracting the mesh: lower the resolution";
    goto done;
cancelled:
    out->cancelled = 1;
done:
    vec_free(&c, &seeds);
    vec_free(&c, &cells);
    vec_free(&c, &faces);
    vec_free(&c, &vv);
    if (err || out->cancelled) {
        if (out->cancelled) { /* the result's buffers, where handed over already */
            size_t per_vertex = (size_t)out->vertex_count * sizeof(float);
            bury(&c, out->vertices, 3 * per_vertex);
            bury(&c, out->faces, 3 * (size_t)out->face_count * sizeof(int32_t));
            bury(&c, out->trap, per_vertex);
            bury(&c, out->iterations, per_vertex);
            bury(&c, out->estimate, per_vertex);
            out->vertices = NULL;
            out->faces = NULL;
            out->trap = out->iterations = out->estimate = NULL;
        }
        ub_mesh_free(out);
        out->vertex_count = out->face_count = 0;
    }
    reap(&c);
    ub_fp_leave(fp);
    out->evaluations = c.evaluations;
    out->peak_bytes = c.peak;
    out->seconds = ub_monotonic_seconds() - t0;
    return err;
}
