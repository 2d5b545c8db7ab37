/* Parallel-for over fixed chunks with OpenMP. Chunking depends only on (count, grain),
 * so results never depend on how many threads run. */
#include "tussock/core.h"

#include <omp.h>

static int g_threads = 0; /* 0: not set yet, use all cores */

tsk_status tsk_set_threads(int count) {
    if (count < 0 || count > 256)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "threads", "must be 0 (all cores) to 256, got %d",
                             count);
    g_threads = count;
    return TSK_OK;
}

int tsk_get_threads(void) {
    if (g_threads > 0) return g_threads;
    int n = omp_get_num_procs();
    return n > 0 ? n : 1;
}

size_t tsk_chunk_count(size_t count, size_t grain) {
    if (grain == 0) grain = 1;
    return count / grain + (count % grain != 0);
}

void tsk_parallel_for(size_t count, size_t grain, tsk_range_fn* fn, void* ctx) {
    if (count == 0) return;
    if (grain == 0) grain = 1;
    const size_t chunks = tsk_chunk_count(count, grain);
    const int threads = tsk_get_threads();
    if (threads <= 1 || chunks == 1 || omp_in_parallel()) {
        for (size_t c = 0; c < chunks; ++c) {
            size_t b = c * grain, e = b + grain < count ? b + grain : count;
            fn(b, e, c, ctx);
        }
        return;
    }
    const long long nchunks = (long long)chunks;
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (long long c = 0; c < nchunks; ++c) {
        size_t b = (size_t)c * grain, e = b + grain < count ? b + grain : count;
        fn(b, e, (size_t)c, ctx);
    }
}
