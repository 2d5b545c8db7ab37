/* Parallel-for over fixed chunks on a small pool of sleeping worker threads. Chunking
 * depends only on (count, grain), so results never depend on how many threads run.
 *
 * Why not an OpenMP parallel region: Blender links libgomp itself and starts it before the
 * add-on can set OMP_WAIT_POLICY, and libgomp's default waiters spin (~300,000 pause
 * instructions, milliseconds on recent CPUs) after every region. Inside Blender those
 * spinning waiters took the cores from Blender's own threads: on 2 cores a tree's deform
 * was slower with 2 threads than with 1, and Blender's depsgraph slowed down as well
 * (docs/performance.md). These workers sleep on a condition variable between loops: POSIX
 * threads, or on Windows its own slim locks and condition variables (which wait in user
 * space; MinGW's winpthreads would wait on kernel events). */
#define _GNU_SOURCE /* sched_getaffinity */
#include "tussock/core.h"

#include <stdatomic.h>
#ifdef _WIN32
#define WIN32_LEAN_AND_MEAN
#include <windows.h>
#else
#include <pthread.h>
#include <sched.h>
#include <unistd.h>
#endif

/* ---- the threads, locks and condition variables of the platform ---- */
#ifdef _WIN32
typedef SRWLOCK tsk_mutex;
typedef CONDITION_VARIABLE tsk_cond;
#define TSK_MUTEX_INIT SRWLOCK_INIT
#define TSK_COND_INIT CONDITION_VARIABLE_INIT
static void mutex_lock(tsk_mutex* m) { AcquireSRWLockExclusive(m); }
static void mutex_unlock(tsk_mutex* m) { ReleaseSRWLockExclusive(m); }
static int mutex_trylock(tsk_mutex* m) { return TryAcquireSRWLockExclusive(m) ? 0 : 1; }
static void cond_wait(tsk_cond* c, tsk_mutex* m) { SleepConditionVariableSRW(c, m, INFINITE, 0); }
static void cond_signal(tsk_cond* c) { WakeConditionVariable(c); }
static void cond_broadcast(tsk_cond* c) { WakeAllConditionVariable(c); }
#else
typedef pthread_mutex_t tsk_mutex;
typedef pthread_cond_t tsk_cond;
#define TSK_MUTEX_INIT PTHREAD_MUTEX_INITIALIZER
#define TSK_COND_INIT PTHREAD_COND_INITIALIZER
static void mutex_lock(tsk_mutex* m) { pthread_mutex_lock(m); }
static void mutex_unlock(tsk_mutex* m) { pthread_mutex_unlock(m); }
static int mutex_trylock(tsk_mutex* m) { return pthread_mutex_trylock(m); }
static void cond_wait(tsk_cond* c, tsk_mutex* m) { pthread_cond_wait(c, m); }
static void cond_signal(tsk_cond* c) { pthread_cond_signal(c); }
static void cond_broadcast(tsk_cond* c) { pthread_cond_broadcast(c); }
#endif

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

static tsk_mutex g_mutex = TSK_MUTEX_INIT; /* guards everything below */
static tsk_cond g_work = TSK_COND_INIT; /* a new job was posted */
static tsk_cond g_done = TSK_COND_INIT; /* a worker left a job */
static tsk_mutex g_caller = TSK_MUTEX_INIT; /* one parallel loop at a time */
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
#if defined(_WIN32)
    /* asked once: every loop asks, and the query is a system call (under wine a round trip to
     * its server); a process whose threads span processor groups gets no masks: then all
     * processors */
    static atomic_int cpus; /* 0: not asked yet */
    n = atomic_load_explicit(&cpus, memory_order_relaxed);
    if (n <= 0) {
        DWORD_PTR mask = 0, system_mask = 0;
        if (GetProcessAffinityMask(GetCurrentProcess(), &mask, &system_mask))
            n = __builtin_popcountll((unsigned long long)mask);
        if (n <= 0) n = (int)GetActiveProcessorCount(ALL_PROCESSOR_GROUPS);
        atomic_store_explicit(&cpus, n, memory_order_relaxed);
    }
#else
#if defined(__linux__)
    cpu_set_t set;
    if (sched_getaffinity(0, sizeof set, &set) == 0) n = CPU_COUNT(&set);
#endif
    if (n <= 0) n = (int)sysconf(_SC_NPROCESSORS_ONLN);
#endif
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

static void worker_loop(void) {
    t_inside = 1; /* a loop started from inside a chunk runs serially */
    unsigned long seen = 0;
    mutex_lock(&g_mutex);
    seen = g_generation;
    for (;;) {
        while (g_generation == seen) cond_wait(&g_work, &g_mutex);
        seen = g_generation;
        job* j = g_job;
        if (j == NULL || j->joined >= j->max_workers) continue;
        j->joined++;
        j->active++;
        mutex_unlock(&g_mutex);
        run_chunks(j);
        mutex_lock(&g_mutex);
        if (--j->active == 0) cond_signal(&g_done);
    }
}

#ifdef _WIN32
static DWORD WINAPI worker_main(LPVOID arg) {
    (void)arg;
    worker_loop();
    return 0;
}

/* Starts a worker that is never joined; 0 on success. */
static int start_worker(void) {
    HANDLE th = CreateThread(NULL, 0, worker_main, NULL, 0, NULL);
    if (th == NULL) return -1;
    CloseHandle(th);
    return 0;
}
#else
static void* worker_main(void* arg) {
    (void)arg;
    worker_loop();
    return NULL;
}

/* Starts a worker that is never joined; 0 on success. */
static int start_worker(void) {
    pthread_t th;
    pthread_attr_t attr;
    pthread_attr_init(&attr);
    pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED);
    const int rc = pthread_create(&th, &attr, worker_main, NULL);
    pthread_attr_destroy(&attr);
    return rc;
}
#endif

/* Starts workers up to `want` (under g_mutex); returns how many exist. */
static int ensure_workers(int want) {
    if (want > MAX_WORKERS) want = MAX_WORKERS;
    while (g_workers < want) {
        if (start_worker() != 0) break; /* fewer threads: still correct */
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
    if (threads <= 1 || chunks == 1 || t_inside || mutex_trylock(&g_caller) != 0) {
        run_serial(count, grain, chunks, fn, ctx);
        return;
    }
    job j;
    j.fn = fn, j.ctx = ctx, j.count = count, j.grain = grain, j.chunks = chunks;
    atomic_init(&j.next, 0);
    j.joined = 0, j.active = 0;
    const size_t helpers = chunks - 1 < (size_t)(threads - 1) ? chunks - 1 : (size_t)(threads - 1);
    mutex_lock(&g_mutex);
    const int have = ensure_workers((int)helpers);
    j.max_workers = have < (int)helpers ? have : (int)helpers;
    g_job = &j;
    g_generation++;
    cond_broadcast(&g_work);
    mutex_unlock(&g_mutex);

    t_inside = 1;
    run_chunks(&j);
    t_inside = 0;

    mutex_lock(&g_mutex);
    g_job = NULL; /* late risers skip this job */
    while (j.active > 0) cond_wait(&g_done, &g_mutex);
    mutex_unlock(&g_mutex);
    mutex_unlock(&g_caller);
}
