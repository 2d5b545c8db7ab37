/* tussock_oni_reader: reads one OpenNI2 recording for Tussock, in a process of its own, so
 * that a damaged file that crashes OpenNI2's player (libOniFile) cannot crash Blender.
 * Usage: tussock_oni_reader RECORDING.oni, with a socket to Tussock on descriptor
 * TSK_ONI_READER_FD (Windows: RECORDING.oni REQUESTS ANSWERS, two pipe handles). It opens the
 * recording with the ordinary in-process code (tsk_depth_open_oni_local), sends
 * tsk_oni_hello, then answers requests until QUIT or until Tussock closes the channel
 * (src/capture/oni_reader_protocol.h). */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef _WIN32
#define WIN32_LEAN_AND_MEAN
#include <windows.h>
#include <shellapi.h>
#else
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>
#endif

#include "capture/depth_internal.h"
#include "capture/oni_reader_protocol.h"

#ifndef _WIN32

typedef int channel; /* the socket on TSK_ONI_READER_FD */

static int send_all(channel fd, const void* buf, size_t n) {
    const unsigned char* b = buf;
    while (n > 0) {
        const ssize_t r = send(fd, b, n, MSG_NOSIGNAL);
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) return -1;
        b += r;
        n -= (size_t)r;
    }
    return 0;
}

static int recv_all(channel fd, void* buf, size_t n) {
    unsigned char* b = buf;
    while (n > 0) {
        const ssize_t r = recv(fd, b, n, 0);
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) return -1;
        b += r;
        n -= (size_t)r;
    }
    return 0;
}

/* The recording's path from the command line, and the channel; NULL if the command line is
 * not Tussock's. */
static const char* open_channel(int argc, char** argv, channel* ch) {
    signal(SIGPIPE, SIG_IGN);
    *ch = TSK_ONI_READER_FD;
    return argc == 2 ? argv[1] : NULL;
}

static void free_path(const char* path) { (void)path; }

#else /* Windows */

typedef struct channel {
    HANDLE requests, answers;
} channel;

static int send_all(channel ch, const void* buf, size_t n) {
    const unsigned char* b = buf;
    while (n > 0) {
        const DWORD want = n < ((size_t)1 << 30) ? (DWORD)n : (DWORD)1 << 30;
        DWORD w = 0;
        if (!WriteFile(ch.answers, b, want, &w, NULL) || w == 0) return -1;
        b += w;
        n -= w;
    }
    return 0;
}

static int recv_all(channel ch, void* buf, size_t n) {
    unsigned char* b = buf;
    while (n > 0) {
        const DWORD want = n < ((size_t)1 << 30) ? (DWORD)n : (DWORD)1 << 30;
        DWORD r = 0;
        if (!ReadFile(ch.requests, b, want, &r, NULL) || r == 0) return -1;
        b += r;
        n -= r;
    }
    return 0;
}

/* The recording's path (UTF-8, malloc'd) from the wide command line, and the channel's
 * handles after it; NULL if the command line is not Tussock's. */
static const char* open_channel(int argc, char** argv, channel* ch) {
    (void)argc, (void)argv; /* the C runtime's argv is in the ANSI code page */
    /* a crash ends the process at once: no error dialog waits for a click */
    SetErrorMode(SEM_FAILCRITICALERRORS | SEM_NOGPFAULTERRORBOX | SEM_NOOPENFILEERRORBOX);
    int n = 0;
    wchar_t** wargv = CommandLineToArgvW(GetCommandLineW(), &n);
    char* path = NULL;
    if (wargv != NULL && n == 2 + TSK_ONI_READER_HANDLES) {
        ch->requests = (HANDLE)(uintptr_t)_wcstoui64(wargv[2], NULL, 10);
        ch->answers = (HANDLE)(uintptr_t)_wcstoui64(wargv[3], NULL, 10);
        const int bytes = WideCharToMultiByte(CP_UTF8, 0, wargv[1], -1, NULL, 0, NULL, NULL);
        path = bytes > 0 ? malloc((size_t)bytes) : NULL;
        if (path != NULL) WideCharToMultiByte(CP_UTF8, 0, wargv[1], -1, path, bytes, NULL, NULL);
    }
    LocalFree(wargv);
    return path;
}

static void free_path(const char* path) { free((void*)path); }

#endif

static void set_message(char* dst, tsk_status s) {
    const char* m = tsk_last_error();
    snprintf(dst, TSK_ONI_MESSAGE, "%s", (s != TSK_OK && m && m[0]) ? m : "");
}

int main(int argc, char** argv) {
    channel fd;
    const char* path = open_channel(argc, argv, &fd);
    if (path == NULL) {
        fprintf(stderr, "usage: %s RECORDING.oni (started by Tussock)\n", argv[0]);
        return 2;
    }
    tsk_oni_hello h;
    memset(&h, 0, sizeof h);
    memcpy(h.magic, TSK_ONI_MAGIC, sizeof h.magic);
    tsk_depth_source* src = NULL;
    tsk_status s = tsk_depth_open_oni_local(path, &src);
    tsk_depth_info info;
    memset(&info, 0, sizeof info);
    if (s == TSK_OK) s = tsk_depth_get_info(src, &info);
    h.status = (int32_t)s;
    set_message(h.message, s);
    if (s == TSK_OK) {
        h.width = info.width;
        h.height = info.height;
        h.frame_count = info.frame_count;
        h.has_K = info.has_device_intrinsics;
        h.fx = info.intrinsics.fx;
        h.fy = info.intrinsics.fy;
        h.cx = info.intrinsics.cx;
        h.cy = info.intrinsics.cy;
    }
    if (send_all(fd, &h, sizeof h) != 0 || s != TSK_OK) {
        tsk_depth_close(src);
        free_path(path);
        return s == TSK_OK ? 1 : 0;
    }
    const size_t n = (size_t)info.width * (size_t)info.height;
    float* depth = malloc(n * sizeof *depth);
    int rc = depth == NULL ? 1 : 0;
    tsk_oni_request q;
    while (depth != NULL && recv_all(fd, &q, sizeof q) == 0 && q.op != TSK_ONI_OP_QUIT) {
        tsk_oni_reply r;
        memset(&r, 0, sizeof r);
        tsk_depth_frame fr;
        memset(&fr, 0, sizeof fr);
        if (q.op == TSK_ONI_OP_READ) {
            s = tsk_depth_read(src, depth, n, &fr);
        } else if (q.op == TSK_ONI_OP_SEEK) {
            s = tsk_depth_seek(src, q.index);
            fr.index = q.index;
        } else {
            s = tsk_error(TSK_ERR_INTERNAL, "recording reader: unknown request %d", (int)q.op);
        }
        r.status = (int32_t)s;
        set_message(r.message, s);
        r.is_new = s == TSK_OK && q.op == TSK_ONI_OP_READ ? fr.is_new : 0;
        r.index = fr.index < 0 ? 0 : fr.index;
        r.end = fr.end ? 1 : 0;
        r.timestamp = fr.timestamp;
        if (send_all(fd, &r, sizeof r) != 0 ||
            (r.is_new && send_all(fd, depth, n * sizeof *depth) != 0)) {
            rc = 1;
            break;
        }
    }
    free(depth);
    tsk_depth_close(src);
    free_path(path);
    return rc;
}
