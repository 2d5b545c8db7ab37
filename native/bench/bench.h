/* Benchmark helpers: a monotonic clock, medians over repeats, and the JSON line that
 * DESIGN.md specifies ({"name","value","unit","params"}), plus a name filter so that
 * `./build.sh bench NAME` runs only what is asked. */
#ifndef TSK_BENCH_H
#define TSK_BENCH_H

#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L /* clock_gettime under strict C17 */
#endif

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static inline double bench_now_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int bench_cmp_double(const void* a, const void* b) {
    double x = *(const double*)a, y = *(const double*)b;
    return (x > y) - (x < y);
}

/* Median of n samples (sorts them in place). */
static inline double bench_median(double* v, int n) {
    qsort(v, (size_t)n, sizeof(double), bench_cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* True when no names were given on the command line, or when `name` starts with one of
 * them (so `bench blade_sim_table1` also runs `blade_sim_table1_709`). */
static inline int bench_wanted(int argc, char** argv, const char* name) {
    if (argc <= 1) return 1;
    for (int i = 1; i < argc; ++i)
        if (strncmp(name, argv[i], strlen(argv[i])) == 0) return 1;
    return 0;
}

/* Prints one result line. `params_json` is the inside of the params object, e.g.
 * "\"threads\": 1, \"blades\": 5" (may be ""); `peer` is NULL for Tussock's own line. */
static inline void bench_emit(const char* name, double value, const char* unit,
                              const char* params_json, const char* peer) {
    printf("{\"name\": \"%s\", \"value\": %.6g, \"unit\": \"%s\", \"params\": {%s}", name, value,
           unit, params_json ? params_json : "");
    if (peer) printf(", \"peer\": \"%s\"", peer);
    printf("}\n");
    fflush(stdout);
}

#endif
