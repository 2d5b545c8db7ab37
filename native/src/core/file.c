/* Files by path (core/file.h says why): the POSIX calls, and their Windows counterparts on
 * wide paths. */
#define _POSIX_C_SOURCE 200809L
#include "core/file.h"

#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#ifdef _WIN32
#define WIN32_LEAN_AND_MEAN
#include <io.h>
#include <windows.h>
#else
#include <sys/statvfs.h>
#endif

#ifndef _WIN32

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

FILE* tsk_fopen(const char* path, const char* mode) { return fopen(path, mode); }

int tsk_open(const char* path, int flags) { return open(path, flags, 0644); }

int tsk_fsync(int fd) { return fsync(fd); }

int tsk_rename_over(const char* from, const char* to) { return rename(from, to); }

int tsk_unlink(const char* path) { return unlink(path); }

int tsk_path_exists(const char* path) {
    struct stat st;
    return stat(path, &st) == 0;
}

int tsk_file_size(FILE* f, uint64_t* size) {
    struct stat st;
    if (fstat(fileno(f), &st) != 0) return -1;
    *size = (uint64_t)st.st_size;
    return 0;
}

int tsk_fseek_set(FILE* f, uint64_t offset) { return fseek(f, (long)offset, SEEK_SET); }

int tsk_free_bytes(const char* dir, uint64_t* bytes) {
    struct statvfs vfs;
    if (statvfs(dir, &vfs) != 0) return -1;
    *bytes = (uint64_t)vfs.f_bavail * vfs.f_frsize;
    return 0;
}

long tsk_process_id(void) { return (long)getpid(); }

const char* tsk_last_separator(const char* path) { return strrchr(path, '/'); }

#else /* Windows */

int tsk_errno_from_windows(unsigned long error) {
    int e;
    switch (error) {
        case ERROR_FILE_NOT_FOUND:
        case ERROR_PATH_NOT_FOUND:
        case ERROR_INVALID_NAME:
        case ERROR_BAD_PATHNAME:
        case ERROR_INVALID_DRIVE:
        case ERROR_BAD_NETPATH:
        case ERROR_BAD_NET_NAME:
            e = ENOENT;
            break;
        case ERROR_ACCESS_DENIED:
        case ERROR_SHARING_VIOLATION:
        case ERROR_LOCK_VIOLATION:
        case ERROR_PIPE_BUSY:
            e = EACCES;
            break;
        case ERROR_WRITE_PROTECT:
            e = EROFS;
            break;
        case ERROR_FILE_EXISTS:
        case ERROR_ALREADY_EXISTS:
            e = EEXIST;
            break;
        case ERROR_DISK_FULL:
        case ERROR_HANDLE_DISK_FULL:
            e = ENOSPC;
            break;
        case ERROR_NOT_ENOUGH_MEMORY:
        case ERROR_OUTOFMEMORY:
            e = ENOMEM;
            break;
        case ERROR_FILENAME_EXCED_RANGE:
            e = ENAMETOOLONG;
            break;
        case ERROR_DIRECTORY:
            e = ENOTDIR;
            break;
        case ERROR_NOT_SAME_DEVICE:
            e = EXDEV;
            break;
        case ERROR_NO_UNICODE_TRANSLATION:
            e = EILSEQ;
            break;
        default:
            e = EIO;
    }
    errno = e;
    return e;
}

wchar_t* tsk_utf8_to_wide(const char* path) {
    const int n = MultiByteToWideChar(CP_UTF8, MB_ERR_INVALID_CHARS, path, -1, NULL, 0);
    if (n <= 0) {
        tsk_errno_from_windows(GetLastError());
        return NULL;
    }
    wchar_t* w = malloc((size_t)n * sizeof *w);
    if (w == NULL) {
        errno = ENOMEM;
        return NULL;
    }
    MultiByteToWideChar(CP_UTF8, MB_ERR_INVALID_CHARS, path, -1, w, n);
    return w;
}

/* What GetFileType and the attributes say a handle is, or NULL for a regular file. */
static const char* kind_of(HANDLE h) {
    switch (GetFileType(h)) {
        case FILE_TYPE_DISK: {
            BY_HANDLE_FILE_INFORMATION info;
            if (!GetFileInformationByHandle(h, &info)) return "not a regular file";
            return (info.dwFileAttributes & FILE_ATTRIBUTE_DIRECTORY) ? "a folder" : NULL;
        }
        case FILE_TYPE_CHAR:
            return "a character device";
        case FILE_TYPE_PIPE:
            return "a pipe";
        default:
            return "not a regular file";
    }
}

tsk_status tsk_fopen_regular(const char* path, const char* arg, FILE** out) {
    *out = NULL;
    if (path == NULL || path[0] == '\0') return tsk_error_arg(TSK_ERR_ARGUMENT, arg, "is empty");
    wchar_t* w = tsk_utf8_to_wide(path);
    if (w == NULL)
        return tsk_error_arg(TSK_ERR_IO, arg, "cannot open '%s' (%s)", path, strerror(errno));
    /* FILE_FLAG_BACKUP_SEMANTICS opens a folder too, so that the message can name it; opening
     * a named pipe or a device never waits (a busy pipe fails with ERROR_PIPE_BUSY) */
    HANDLE h = CreateFileW(w, GENERIC_READ, FILE_SHARE_READ | FILE_SHARE_WRITE | FILE_SHARE_DELETE,
                           NULL, OPEN_EXISTING, FILE_FLAG_BACKUP_SEMANTICS, NULL);
    free(w);
    if (h == INVALID_HANDLE_VALUE)
        return tsk_error_arg(TSK_ERR_IO, arg, "cannot open '%s' (%s)", path,
                             strerror(tsk_errno_from_windows(GetLastError())));
    const char* kind = kind_of(h);
    if (kind != NULL) {
        CloseHandle(h);
        return tsk_error_arg(TSK_ERR_IO, arg, "'%s' is %s, not a file Tussock can read", path,
                             kind);
    }
    const int fd = _open_osfhandle((intptr_t)h, _O_RDONLY | _O_BINARY);
    if (fd < 0) CloseHandle(h);
    FILE* f = fd >= 0 ? _fdopen(fd, "rb") : NULL;
    if (f == NULL) {
        if (fd >= 0) _close(fd);
        return tsk_error_arg(TSK_ERR_IO, arg, "cannot read '%s'", path);
    }
    *out = f;
    return TSK_OK;
}

FILE* tsk_fopen(const char* path, const char* mode) {
    wchar_t wmode[16];
    size_t n = 0;
    int binary = 0;
    for (; mode[n] != '\0' && n < 14; ++n) {
        wmode[n] = (wchar_t)(unsigned char)mode[n];
        binary |= mode[n] == 'b';
    }
    if (!binary) wmode[n++] = L'b'; /* never text mode's \n -> \r\n */
    wmode[n] = L'\0';
    wchar_t* w = tsk_utf8_to_wide(path);
    if (w == NULL) return NULL;
    FILE* f = _wfopen(w, wmode);
    free(w);
    return f;
}

int tsk_open(const char* path, int flags) {
    wchar_t* w = tsk_utf8_to_wide(path);
    if (w == NULL) return -1;
    const int fd = _wopen(w, flags | _O_BINARY | _O_NOINHERIT, _S_IREAD | _S_IWRITE);
    free(w);
    return fd;
}

int tsk_fsync(int fd) { return _commit(fd); }

int tsk_rename_over(const char* from, const char* to) {
    wchar_t* wf = tsk_utf8_to_wide(from);
    wchar_t* wt = wf != NULL ? tsk_utf8_to_wide(to) : NULL;
    int rc = -1;
    if (wt != NULL) {
        /* replaces `to` in one step (a reader sees the old or the new file) and returns once
         * the rename is on the disk */
        if (MoveFileExW(wf, wt, MOVEFILE_REPLACE_EXISTING | MOVEFILE_WRITE_THROUGH)) rc = 0;
        else tsk_errno_from_windows(GetLastError());
    }
    free(wf);
    free(wt);
    return rc;
}

int tsk_unlink(const char* path) {
    wchar_t* w = tsk_utf8_to_wide(path);
    if (w == NULL) return -1;
    const int rc = _wunlink(w);
    free(w);
    return rc;
}

int tsk_path_exists(const char* path) {
    wchar_t* w = tsk_utf8_to_wide(path);
    if (w == NULL) return 0;
    const DWORD attributes = GetFileAttributesW(w);
    free(w);
    return attributes != INVALID_FILE_ATTRIBUTES;
}

int tsk_file_size(FILE* f, uint64_t* size) {
    struct _stati64 st;
    if (_fstati64(_fileno(f), &st) != 0) return -1;
    *size = (uint64_t)st.st_size;
    return 0;
}

int tsk_fseek_set(FILE* f, uint64_t offset) { return _fseeki64(f, (__int64)offset, SEEK_SET); }

int tsk_free_bytes(const char* dir, uint64_t* bytes) {
    wchar_t* w = tsk_utf8_to_wide(dir);
    if (w == NULL) return -1;
    ULARGE_INTEGER available;
    const BOOL ok = GetDiskFreeSpaceExW(w, &available, NULL, NULL);
    free(w);
    if (!ok) {
        tsk_errno_from_windows(GetLastError());
        return -1;
    }
    *bytes = available.QuadPart;
    return 0;
}

long tsk_process_id(void) { return (long)GetCurrentProcessId(); }

const char* tsk_last_separator(const char* path) {
    const char* slash = strrchr(path, '/');
    const char* backslash = strrchr(path, '\\');
    return slash == NULL || (backslash != NULL && backslash > slash) ? backslash : slash;
}

#endif
