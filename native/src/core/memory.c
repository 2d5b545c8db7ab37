/* Memory budget: the largest memory estimate one request may have (a fraction of the
 * machine's physical memory), so that a meadow, tree, picture or capture that would not
 * fit is refused with a message instead of the process being killed by the kernel. */
#define _DEFAULT_SOURCE
#include "tussock/core.h"

#include <stdatomic.h>
#include <stdlib.h>
#include <unistd.h>

static _Atomic uint64_t g_budget; /* 0 = default */

uint64_t tsk_physical_memory(void) {
    const long pages = sysconf(_SC_PHYS_PAGES);
    const long page = sysconf(_SC_PAGESIZE);
    if (pages <= 0 || page <= 0) return 0;
    return (uint64_t)pages * (uint64_t)page;
}

static uint64_t default_budget(void) {
    const char* env = getenv("TSK_MEMORY_BUDGET_MB");
    if (env != NULL && env[0] != '\0') {
        char* end = NULL;
        const unsigned long long mb = strtoull(env, &end, 10);
        if (end != env && *end == '\0' && mb > 0 && mb < (1ull << 44)) return mb << 20;
    }
    const uint64_t phys = tsk_physical_memory();
    if (phys == 0) return (uint64_t)4 << 30; /* unknown: assume a 8 GiB machine */
    return (uint64_t)((double)phys * TSK_MEMORY_FRACTION);
}

uint64_t tsk_memory_budget(void) {
    const uint64_t b = atomic_load(&g_budget);
    return b != 0 ? b : default_budget();
}

void tsk_set_memory_budget(uint64_t bytes) { atomic_store(&g_budget, bytes); }

tsk_status tsk_memory_check(double bytes, const char* what) {
    const uint64_t budget = tsk_memory_budget();
    if (bytes == bytes && bytes <= (double)budget) return TSK_OK; /* NaN is refused too */
    const int is_default = atomic_load(&g_budget) == 0;
    return tsk_error_arg(TSK_ERR_LIMIT, what ? what : "request",
                         "needs about %.0f MiB, more than the memory budget of %.0f MiB (%s)",
                         bytes / 1048576.0, (double)budget / 1048576.0,
                         is_default ? "half of this machine's memory" : "as set");
}
