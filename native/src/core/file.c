/* tsk_fopen_regular: core/file.h says why. */
#define _POSIX_C_SOURCE 200809L
#include "core/file.h"

#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const char* kind_of(mode_t mode) {
    if (S_ISDIR(mode)) return "a folder";
    if (S_ISFIFO(mode)) return "a pipe (FIFO)";
    if (S_ISSOCK(mode)) return "a socket";
    if (S_ISCHR(mode)) return "a character device";
    if (S_ISBLK(mode)) return "a block device";
    return "not a regular file";
}

tsk_status tsk_fopen_regular(const char* path, const char* arg, FILE** out) {
    *out = NULL;
    if (path == NULL || path[0] == '\0') return tsk_error_arg(TSK_ERR_ARGUMENT, arg, "is empty");
    /* O_NONBLOCK: opening a FIFO for reading returns at once instead of waiting for a
     * writer; opening a socket fails (ENXIO) instead of anything else */
    const int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd < 0) {
        const int e = errno;
        struct stat st;
        if (e == ENXIO && stat(path, &st) == 0)
            return tsk_error_arg(TSK_ERR_IO, arg, "'%s' is %s, not a file Tussock can read", path,
                                 kind_of(st.st_mode));
        return tsk_error_arg(TSK_ERR_IO, arg, "cannot open '%s' (%s)", path, strerror(e));
    }
    struct stat st;
    const int stat_ok = fstat(fd, &st) == 0;
    if (!stat_ok || !S_ISREG(st.st_mode)) {
        close(fd);
        return tsk_error_arg(TSK_ERR_IO, arg, "'%s' is %s, not a file Tussock can read", path,
                             stat_ok ? kind_of(st.st_mode) : "not a regular file");
    }
    /* a regular file: reads block as usual from here on */
    const int flags = fcntl(fd, F_GETFL);
    FILE* f = flags >= 0 && fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) == 0 ? fdopen(fd, "rb") : NULL;
    if (f == NULL) {
        close(fd);
        return tsk_error_arg(TSK_ERR_IO, arg, "cannot read '%s'", path);
    }
    *out = f;
    return TSK_OK;
}
