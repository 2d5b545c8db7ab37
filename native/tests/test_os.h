/* The few POSIX calls the tests make, on Windows too (MinGW-w64 has most of them: dirent,
 * stat, access, unlink, truncate, getpid, clock_gettime): folders, the environment, aligned
 * blocks and the folder for temporary files. */
#ifndef TSK_TEST_OS_H
#define TSK_TEST_OS_H

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#ifdef _WIN32
#define WIN32_LEAN_AND_MEAN
#include <direct.h>
#include <malloc.h>
#include <windows.h>
#undef near /* windows.h's 16-bit pointer qualifiers, names of variables here */
#undef far

/* no links to keep from following */
#define lstat(path, st) stat(path, st)

static inline int setenv(const char* name, const char* value, int overwrite) {
    if (!overwrite && getenv(name) != NULL) return 0;
    return _putenv_s(name, value) == 0 ? 0 : -1;
}
static inline int unsetenv(const char* name) { return _putenv_s(name, "") == 0 ? 0 : -1; }
#endif

/* mkdir(path, mode); Windows folders have no mode. */
static inline int test_mkdir(const char* path, int mode) {
#ifdef _WIN32
    (void)mode;
    return _mkdir(path);
#else
    return mkdir(path, (mode_t)mode);
#endif
}

/* posix_memalign and its free. */
static inline void* test_aligned_alloc(size_t alignment, size_t size) {
#ifdef _WIN32
    return _aligned_malloc(size, alignment);
#else
    void* p = NULL;
    return posix_memalign(&p, alignment, size) == 0 ? p : NULL;
#endif
}
static inline void test_aligned_free(void* p) {
#ifdef _WIN32
    _aligned_free(p);
#else
    free(p);
#endif
}

/* The folder for temporary files, without a trailing separator: /tmp, or Windows' own. */
static inline const char* test_tmp_root(void) {
#ifdef _WIN32
    static char root[MAX_PATH + 1];
    if (root[0] == '\0') {
        const DWORD n = GetTempPathA(sizeof root, root);
        if (n == 0 || n >= sizeof root) snprintf(root, sizeof root, ".");
        const size_t len = strlen(root);
        if (len > 1 && (root[len - 1] == '\\' || root[len - 1] == '/')) root[len - 1] = '\0';
    }
    return root;
#else
    return "/tmp";
#endif
}

#endif
