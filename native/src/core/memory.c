/* Memory budget: the largest memory estimate one request may have (a fraction of the
 * machine's physical memory), so that a meadow, tree, picture or capture that would not
 * fit is refused with a message instead of the process being killed by the kernel. */
#define _DEFAULT_SOURCE
#include "tussock/core.h"

#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#ifdef _WIN32
#define WIN32_LEAN_AND_MEAN
#include <windows.h>
#else
#include <unistd.h>
#endif

static _Atomic uint64_t g_budget; /* 0 = default */

uint64_t tsk_physical_memory(void) {
#ifdef _WIN32
    /* asked once: memory checks run per step, and the query is a system call (under wine a
     * round trip to its server) */
    static _Atomic uint64_t total; /* 0: not asked yet */
    uint64_t t = atomic_load(&total);
    if (t == 0) {
        MEMORYSTATUSEX status;
        status.dwLength = sizeof status;
        t = GlobalMemoryStatusEx(&status) ? (uint64_t)status.ullTotalPhys : 0;
        atomic_store(&total, t);
    }
    return t;
#else
    const long pages = sysconf(_SC_PHYS_PAGES);
    const long page = sysconf(_SC_PAGESIZE);
    if (pages <= 0 || page <= 0) return 0;
    return (uint64_t)pages * (uint64_t)page;
#endif
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

/* "12 MiB", "3.5 GiB", "40 KiB": a size a person reads at a glance */
static void human(double bytes, char* out, size_t n) {
    if (bytes >= 1073741824.0 * 1024.0) snprintf(out, n, "%.0f GiB", bytes / 1073741824.0);
    else if (bytes >= 1073741824.0) snprintf(out, n, "%.1f GiB", bytes / 1073741824.0);
    else if (bytes >= 1048576.0) snprintf(out, n, "%.0f MiB", bytes / 1048576.0);
    else snprintf(out, n, "%.0f KiB", bytes / 1024.0);
}

tsk_status tsk_memory_check(double bytes, const char* what) {
    const uint64_t budget = tsk_memory_budget();
    if (bytes == bytes && bytes <= (double)budget) return TSK_OK; /* NaN is refused too */
    const int is_default = atomic_load(&g_budget) == 0;
    char need[32], have[32];
    human(bytes == bytes ? bytes : 0.0, need, sizeof need);
    human((double)budget, have, sizeof have);
    return tsk_error_arg(TSK_ERR_LIMIT, what ? what : "request",
                         "needs about %s, more than the memory budget of %s (%s)", need, have,
                         is_default ? "half of this machine's memory" : "as set");
}
