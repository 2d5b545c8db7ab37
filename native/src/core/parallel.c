/* Parallel-for over fixed chunks on a small pool of sleeping worker threads. Chunking
 * depends only on (count, grain), so results never depend on how many threads run.
 *
 * Why not an OpenMP parallel region: Blender links libgomp itself and starts it before the
 * add-on can set OMP_WAIT_POLICY, and libgomp's default waiters spin (~300,000 pause
 * instructions, milliseconds on recent CPUs) after every region. Inside Blender those
 * spinning waiters took the cores from Blender's own threads: on 2 cores a tree's deform
 * was slower with 2 threads than with 1, and Blender's depsgraph slowed down as well
 * (docs/performance.md). These workers sleep on a condition variable between loops. */
#define _GNU_SOURCE /* sched_getaffinity */
#include "tussock/core.h"

#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <unistd.h>

enum { MAX_WORKERS = 255 };

typedef struct job {
    tsk_range_fn* fn;
    void* ctx;
    size_t count, grain, chunks;
    atomic_size_t next; /* next chunk to take */
    int max_workers; /* workers that may join (threads - 1) */
    int joined; /* workers that joined (under g_mutex) */
    int active; /* workers inside the job (under g_mutex) */
} job;

static int g_threads = 0; /* 0: not set yet, use all cores */

static pthread_mutex_t g_mutex = PTHREAD_MUTEX_INITIALIZER; /* guards everything below */
static pthread_cond_t g_work = PTHREAD_COND_INITIALIZER; /* a new job was posted */
static pthread_cond_t g_done = PTHREAD_COND_INITIALIZER; /* a worker left a job */
static pthread_mutex_t g_caller = PTHREAD_MUTEX_INITIALIZER; /* one parallel loop at a time */
static job* g_job = NULL;
static unsigned long g_generation = 0;
static int g_workers = 0; /* started worker threads */

static _Thread_local int t_inside = 0; /* 1 in workers and in a caller during its loop */

tsk_status tsk_set_threads(int count) {
    if (count < 0 || count > 256)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "threads", "must be 0 (all cores) to 256, got %d",
                             count);
    g_threads = count;
    return TSK_OK;
}

int tsk_get_threads(void) {
    if (g_threads > 0) return g_threads;
    /* the CPUs this process may run on (taskset, cgroups' cpusets), else those online */
    int n = 0;
#if defined(__linux__)
    cpu_set_t set;
    if (sched_getaffinity(0, sizeof set, &set) == 0) n = CPU_COUNT(&set);
#endif
    if (n <= 0) n = (int)sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? n : 1;
}

size_t tsk_chunk_count(size_t count, size_t grain) {
    if (grain == 0) grain = 1;
    return count / grain + (count % grain != 0);
}

static void run_chunks(job* j) {
    size_t c;
    while ((c = atomic_fetch_add_explicit(&j->next, 1, memory_order_relaxed)) < j->chunks) {
        const size_t b = c * j->grain, e = b + j->grain < j->count ? b + j->grain : j->count;
        j->fn(b, e, c, j->ctx);
    }
}

static void* worker_main(void* arg) {
    (void)arg;
    t_inside = 1; /* a loop started from inside a chunk runs serially */
    unsigned long seen = 0;
    pthread_mutex_lock(&g_mutex);
    seen = g_generation;
    for (;;) {
        while (g_generation == seen) pthread_cond_wait(&g_work, &g_mutex);
        seen = g_generation;
        job* j = g_job;
        if (j == NULL || j->joined >= j->max_workers) continue;
        j->joined++;
        j->active++;
        pthread_mutex_unlock(&g_mutex);
        run_chunks(j);
        pthread_mutex_lock(&g_mutex);
        if (--j->active == 0) pthread_cond_signal(&g_done);
    }
    return NULL;
}

/* Starts workers up to `want` (under g_mutex); returns how many exist. */
static int ensure_workers(int want) {
    if (want > MAX_WORKERS) want = MAX_WORKERS;
    while (g_workers < want) {
        pthread_t th;
        pthread_attr_t attr;
        pthread_attr_init(&attr);
        pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED);
        const int rc = pthread_create(&th, &attr, worker_main, NULL);
        pthread_attr_destroy(&attr);
        if (rc != 0) break; /* fewer threads: still correct */
        g_workers++;
    }
    return g_workers;
}

static void run_serial(size_t count, size_t grain, size_t chunks, tsk_range_fn* fn, void* ctx) {
    for (size_t c = 0; c < chunks; ++c) {
        size_t b = c * grain, e = b + grain < count ? b + grain : count;
        fn(b, e, c, ctx);
    }
}

void tsk_parallel_for(size_t count, size_t grain, tsk_range_fn* fn, void* ctx) {
    if (count == 0) return;
    if (grain == 0) grain = 1;
    const size_t chunks = tsk_chunk_count(count, grain);
    const int threads = tsk_get_threads();
    /* serial: one thread or chunk, nested, or another thread's loop is running */
    if (threads <= 1 || chunks == 1 || t_inside || pthread_mutex_trylock(&g_caller) != 0) {
        run_serial(count, grain, chunks, fn, ctx);
        return;
    }
    job j;
    j.fn = fn, j.ctx = ctx, j.count = count, j.grain = grain, j.chunks = chunks;
    atomic_init(&j.next, 0);
    j.joined = 0, j.active = 0;
    const size_t helpers = chunks - 1 < (size_t)(threads - 1) ? chunks - 1 : (size_t)(threads - 1);
    pthread_mutex_lock(&g_mutex);
    const int have = ensure_workers((int)helpers);
    j.max_workers = have < (int)helpers ? have : (int)helpers;
    g_job = &j;
    g_generation++;
    pthread_cond_broadcast(&g_work);
    pthread_mutex_unlock(&g_mutex);

    t_inside = 1;
    run_chunks(&j);
    t_inside = 0;

    pthread_mutex_lock(&g_mutex);
    g_job = NULL; /* late risers skip this job */
    while (j.active > 0) pthread_cond_wait(&g_done, &g_mutex);
    pthread_mutex_unlock(&g_mutex);
    pthread_mutex_unlock(&g_caller);
}
