/* A tiny test runner, no framework: TEST functions, CHECK macros, a name filter and the
 * closing line "N passed, N failed" that DESIGN.md asks every suite to print. */
#ifndef TSK_TEST_H
#define TSK_TEST_H

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct tsk_test_case {
    const char* name;
    void (*fn)(void);
    const char* skip_why; /* not NULL: this build cannot run the test (TEST_NEEDS, TEST_POSIX) */
} tsk_test_case;

static int tsk_test_failed_checks;

#define TEST(name) static void name(void)
#define TEST_ENTRY(name) \
    { #name, name, NULL }

/* The entry of a test that needs a third-party library: TEST_NEEDS(name, OpenCV), and so
 * for OpenSubdiv and OpenNI2 (a token, not a string: it names the reason below). A build
 * without the library (CMake option TSK_WITH_OPENCV=OFF, TSK_WITH_OPENSUBDIV=OFF or
 * TSK_WITH_OPENNI2=OFF, which defines TSK_TEST_WITHOUT_OPENCV, ..._OPENSUBDIV or ..._OPENNI2)
 * skips it with the line "skip NAME (built without LIBRARY)"; every other build runs it as a
 * TEST_ENTRY. (A constant per library, because TEST_MAIN's table of cases is static.) */
#ifdef TSK_TEST_WITHOUT_OPENCV
#define TSK_TEST_WHY_OpenCV "built without OpenCV"
#else
#define TSK_TEST_WHY_OpenCV NULL
#endif
#ifdef TSK_TEST_WITHOUT_OPENSUBDIV
#define TSK_TEST_WHY_OpenSubdiv "built without OpenSubdiv"
#else
#define TSK_TEST_WHY_OpenSubdiv NULL
#endif
#ifdef TSK_TEST_WITHOUT_OPENNI2
#define TSK_TEST_WHY_OpenNI2 "built without OpenNI2"
#else
#define TSK_TEST_WHY_OpenNI2 NULL
#endif
#define TEST_NEEDS(name, library) \
    { #name, name, TSK_TEST_WHY_##library }

/* The entry of a test of what only POSIX systems have (file-size limits, FIFOs, sockets as
 * files): Windows builds skip it with "skip NAME (POSIX only)", and compile its function
 * only on POSIX (#ifndef _WIN32 around it). TEST_POSIX_NEEDS: the same for a test that also
 * needs a library. */
#ifdef _WIN32
#define TEST_POSIX(name) \
    { #name, NULL, "POSIX only" }
#define TEST_POSIX_NEEDS(name, library) TEST_POSIX(name)
#else
#define TEST_POSIX(name) TEST_ENTRY(name)
#define TEST_POSIX_NEEDS(name, library) TEST_NEEDS(name, library)
#endif

#define CHECK(cond)                                                                    \
    do {                                                                               \
        if (!(cond)) {                                                                 \
            fprintf(stderr, "  %s:%d: CHECK(%s) failed\n", __FILE__, __LINE__, #cond); \
            ++tsk_test_failed_checks;                                                  \
        }                                                                              \
    } while (0)

#define CHECK_MSG(cond, ...)                                                           \
    do {                                                                               \
        if (!(cond)) {                                                                 \
            fprintf(stderr, "  %s:%d: CHECK(%s) failed: ", __FILE__, __LINE__, #cond); \
            fprintf(stderr, __VA_ARGS__);                                              \
            fputc('\n', stderr);                                                       \
            ++tsk_test_failed_checks;                                                  \
        }                                                                              \
    } while (0)

#define CHECK_NEAR(a, b, tol)                                                                      \
    do {                                                                                           \
        double tsk_a_ = (double)(a), tsk_b_ = (double)(b), tsk_t_ = (double)(tol);                 \
        if (!(fabs(tsk_a_ - tsk_b_) <= tsk_t_)) {                                                  \
            fprintf(stderr, "  %s:%d: |%s - %s| = |%.9g - %.9g| > %.3g\n", __FILE__, __LINE__, #a, \
                    #b, tsk_a_, tsk_b_, tsk_t_);                                                   \
            ++tsk_test_failed_checks;                                                              \
        }                                                                                          \
    } while (0)

/* Checks that a call returns the expected status and that the message mentions `needle`. */
#define CHECK_STATUS(call, expected, needle)                                             \
    do {                                                                                 \
        tsk_clear_error();                                                               \
        tsk_status tsk_s_ = (call);                                                      \
        CHECK_MSG(tsk_s_ == (expected), "%s returned %s, expected %s (%s)", #call,       \
                  tsk_status_name(tsk_s_), tsk_status_name(expected), tsk_last_error()); \
        CHECK_MSG(strstr(tsk_last_error(), (needle)) != NULL, "message '%s' lacks '%s'", \
                  tsk_last_error(), (needle));                                           \
    } while (0)

/* FNV-1a over n bytes from h (TSK_TEST_FNV_START to begin): the golden hashes of kernel
 * outputs. A golden hash is a constant checked in, so a change of any byte a kernel writes
 * (a reordered sum, a contraction, a new instruction path) fails a test, even when every
 * path changed alike; a deliberate change updates the constant in the same commit. */
#define TSK_TEST_FNV_START 1469598103934665603ull
static inline uint64_t tsk_test_fnv(const void* p, size_t n, uint64_t h) {
    const unsigned char* b = p;
    for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
    return h;
}

/* 1 if `name` contains one of the comma-separated substrings of `list`. */
/* An allocator for tsk_set_allocator that fails once the count at `allocs_left` (an int the
 * test owns) runs out: each allocation takes one, then every further one returns NULL. */
static inline void* tsk_test_failing_alloc(size_t size, void* allocs_left) {
    int* n = allocs_left;
    return (*n)-- > 0 ? malloc(size) : NULL;
}
static inline void tsk_test_plain_free(void* p, void* user) {
    (void)user;
    free(p);
}

static int tsk_test_listed(const char* name, const char* list) {
    while (list && *list) {
        const char* end = strchr(list, ',');
        const size_t n = end ? (size_t)(end - list) : strlen(list);
        char part[128];
        if (n > 0 && n < sizeof part) {
            memcpy(part, list, n);
            part[n] = '\0';
            if (strstr(name, part) != NULL) return 1;
        }
        list = end ? end + 1 : NULL;
    }
    return 0;
}

/* argv[1]: run only tests whose name contains it. Environment TSK_TEST_SKIP: comma-separated
 * name parts to leave out (the valgrind run skips long numeric tests this way). A test that
 * this build cannot run (TEST_NEEDS, TEST_POSIX) prints a "skip" line and counts neither way. */
static int tsk_test_run(int argc, char** argv, const tsk_test_case* cases, size_t count) {
    const char* filter = argc > 1 ? argv[1] : NULL;
    const char* skip = getenv("TSK_TEST_SKIP");
    int passed = 0, failed = 0;
    for (size_t i = 0; i < count; ++i) {
        if (filter && strstr(cases[i].name, filter) == NULL) continue;
        if (skip && tsk_test_listed(cases[i].name, skip)) continue;
        if (cases[i].skip_why != NULL) {
            printf("skip %s (%s)\n", cases[i].name, cases[i].skip_why);
            fflush(stdout);
            continue;
        }
        int before = tsk_test_failed_checks;
        cases[i].fn();
        if (tsk_test_failed_checks == before) {
            ++passed;
            printf("ok   %s\n", cases[i].name);
        } else {
            ++failed;
            printf("FAIL %s\n", cases[i].name);
        }
        fflush(stdout);
    }
    printf("%d passed, %d failed\n", passed, failed);
    return failed == 0 ? 0 : 1;
}

#define TEST_MAIN(...)                                                          \
    int main(int argc, char** argv) {                                           \
        static const tsk_test_case cases[] = {__VA_ARGS__};                     \
        return tsk_test_run(argc, argv, cases, sizeof cases / sizeof cases[0]); \
    }

#endif
