/* .oni recordings read through the recording reader process (oni_reader_protocol.h says
 * why and how). This side spawns `tussock_oni_reader` with posix_spawn (safe in a
 * multi-threaded process such as Blender, unlike fork), talks to it over a socket pair, and
 * checks every byte it receives. A reader that crashes, hangs or answers nonsense becomes a
 * TSK_ERR_FORMAT naming the recording; the caller's process is never at risk.
 *
 * The reader is found at $TSK_ONI_READER, else beside the binary that holds this library
 * (the add-on's _tussock.abi3.so, or a test executable in the build folder). */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "depth_internal.h"
#include "oni_reader_protocol.h"

extern char** environ;

#define OPEN_TIMEOUT_S 20.0 /* the reader opens the recording and answers tsk_oni_hello */
#define READ_TIMEOUT_S 10.0 /* the reader itself gives up on a frame after 3 s */
#define SEEK_TIMEOUT_S 20.0 /* plus SEEK_PER_FRAME_S per frame read and dropped */
#define SEEK_PER_FRAME_S 0.05
#define QUIT_GRACE_S 1.0

struct tsk_oni_proxy {
    int fd;
    pid_t pid; /* -1 when there is no process (tsk_oni_proxy_attach for tests) */
    int broken; /* the conversation failed: every later call fails */
    char broken_why[TSK_ONI_MESSAGE + 256];
};

static double now_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void sleep_s(double s) {
    struct timespec ts = {(time_t)s, (long)((s - (double)(time_t)s) * 1e9)};
    nanosleep(&ts, NULL);
}

/* Reaps the reader, killing it if it has not ended within `grace` seconds. Writes how it
 * ended into `how` ("" if it exited with status 0 or there is no process). */
static void reap(tsk_oni_proxy* p, double grace, char* how, size_t cap) {
    if (how && cap) how[0] = '\0';
    if (p->pid <= 0) return;
    int st = 0;
    pid_t r = 0;
    const double t0 = now_s();
    while ((r = waitpid(p->pid, &st, WNOHANG)) == 0 && now_s() - t0 < grace) sleep_s(0.002);
    if (r == 0) {
        kill(p->pid, SIGKILL);
        while ((r = waitpid(p->pid, &st, 0)) < 0 && errno == EINTR) {}
        if (how && cap) snprintf(how, cap, "did not answer and was stopped");
    } else if (r > 0 && how && cap) {
        if (WIFSIGNALED(st))
            snprintf(how, cap, "crashed (signal %d, %s)", WTERMSIG(st), strsignal(WTERMSIG(st)));
        else if (WIFEXITED(st) && WEXITSTATUS(st) != 0)
            snprintf(how, cap, "stopped with exit code %d", WEXITSTATUS(st));
    }
    p->pid = -1;
}

/* Marks the conversation broken and sets the error: the reader's fate if it is known. */
static tsk_status fail(tsk_oni_proxy* p, const char* path, const char* what) {
    char how[160];
    reap(p, 2.0, how, sizeof how); /* a crashing reader is given time to end; a hung one is
                                      stopped ("did not answer") */
    if (how[0])
        snprintf(p->broken_why, sizeof p->broken_why,
                 "OpenNI2's recording reader %s while %s '%s': the recording is damaged or not "
                 "an OpenNI2 recording",
                 how, what, path);
    else
        snprintf(p->broken_why, sizeof p->broken_why,
                 "OpenNI2's recording reader failed while %s '%s': the recording is damaged "
                 "or not an OpenNI2 recording",
                 what, path);
    p->broken = 1;
    return tsk_error_arg(TSK_ERR_FORMAT, "path", "%s", p->broken_why);
}

/* Receives exactly n bytes before `deadline`; 0 on success, -1 on end of stream, error or
 * timeout (the reader is then treated as broken by the caller). */
static int recv_all(int fd, void* buf, size_t n, double deadline) {
    unsigned char* b = buf;
    size_t got = 0;
    while (got < n) {
        const double left = deadline - now_s();
        if (left <= 0.0) return -1;
        struct pollfd pfd = {fd, POLLIN, 0};
        const int pr = poll(&pfd, 1, (int)(left * 1000.0) + 1);
        if (pr < 0 && errno == EINTR) continue;
        if (pr <= 0) return -1;
        const ssize_t r = read(fd, b + got, n - got);
        if (r < 0 && (errno == EINTR || errno == EAGAIN)) continue;
        if (r <= 0) return -1;
        got += (size_t)r;
    }
    return 0;
}

static int send_all(int fd, const void* buf, size_t n) {
    const unsigned char* b = buf;
    size_t sent = 0;
    while (sent < n) {
        const ssize_t r = send(fd, b + sent, n - sent, MSG_NOSIGNAL); /* never SIGPIPE */
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) return -1;
        sent += (size_t)r;
    }
    return 0;
}

static int valid_status(int32_t s) { return s >= TSK_OK && s <= TSK_ERR_INTERNAL; }

tsk_status tsk_oni_proxy_attach(tsk_depth_source* src, int fd, int pid, const char* path) {
    tsk_oni_proxy* p = tsk_calloc(1, sizeof *p, "recording reader");
    if (p == NULL) {
        close(fd);
        if (pid > 0) {
            kill(pid, SIGKILL);
            waitpid(pid, NULL, 0);
        }
        return TSK_ERR_MEMORY;
    }
    p->fd = fd;
    p->pid = pid > 0 ? pid : -1;
    src->proxy = p;
    tsk_oni_hello h;
    if (recv_all(fd, &h, sizeof h, now_s() + OPEN_TIMEOUT_S) != 0) return fail(p, path, "opening");
    h.message[sizeof h.message - 1] = '\0';
    if (memcmp(h.magic, TSK_ONI_MAGIC, sizeof h.magic) != 0 || !valid_status(h.status))
        return fail(p, path, "opening (it answered in another format)");
    if (h.status != TSK_OK) {
        p->broken = 1;
        snprintf(p->broken_why, sizeof p->broken_why, "%s", h.message);
        return tsk_error((tsk_status)h.status, "%s",
                         h.message[0] ? h.message : "the recording could not be opened");
    }
    const double fx = h.fx, fy = h.fy, cx = h.cx, cy = h.cy;
    if (h.width <= 0 || h.height <= 0 || h.width > TSK_DEPTH_MAX_SIDE ||
        h.height > TSK_DEPTH_MAX_SIDE || h.frame_count <= 0 || (h.has_K != 0 && h.has_K != 1) ||
        !(fx > 0.0 && fx < 1e7) || !(fy > 0.0 && fy < 1e7) || !(fabs(cx) < 1e7) ||
        !(fabs(cy) < 1e7))
        return fail(p, path, "opening (its description of the recording is inconsistent)");
    src->width = h.width;
    src->height = h.height;
    src->frame_count = h.frame_count;
    src->has_K = h.has_K;
    src->K.fx = (float)fx;
    src->K.fy = (float)fy;
    src->K.cx = (float)cx;
    src->K.cy = (float)cy;
    src->cursor = 0;
    return TSK_OK;
}

/* The reader's path: $TSK_ONI_READER, else beside the binary holding this code. */
static int reader_path(char* out, size_t cap) {
    const char* env = getenv("TSK_ONI_READER");
    if (env && env[0]) return snprintf(out, cap, "%s", env) < (int)cap;
    char dir[PATH_MAX];
    dir[0] = '\0';
    Dl_info info;
    if (dladdr((void*)&tsk_oni_proxy_attach, &info) && info.dli_fname &&
        strstr(info.dli_fname, ".so") != NULL)
        snprintf(dir, sizeof dir, "%s", info.dli_fname);
    if (dir[0] == '\0') {
        const ssize_t n = readlink("/proc/self/exe", dir, sizeof dir - 1);
        if (n <= 0) return 0;
        dir[n] = '\0';
    }
    char* slash = strrchr(dir, '/');
    if (slash == NULL) return 0;
    *slash = '\0';
    return snprintf(out, cap, "%s/%s", dir, TSK_ONI_READER_NAME) < (int)cap;
}

tsk_status tsk_oni_proxy_open(tsk_depth_source* src, const char* path) {
    char reader[PATH_MAX];
    if (!reader_path(reader, sizeof reader))
        return tsk_error(TSK_ERR_INTERNAL, "cannot locate the OpenNI2 recording reader");
    if (access(reader, X_OK) != 0)
        return tsk_error(TSK_ERR_INTERNAL,
                         "the OpenNI2 recording reader '%s' is missing or not executable "
                         "(rebuild with ./build.sh build, or reinstall the add-on)",
                         reader);
    int sv[2];
    if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0)
        return tsk_error(TSK_ERR_IO, "cannot create a socket for the recording reader: %s",
                         strerror(errno));
    /* the reader's end must not already be TSK_ONI_READER_FD: dup2 onto itself would keep
     * its close-on-exec flag on older C libraries */
    if (sv[1] == TSK_ONI_READER_FD) {
        const int moved = fcntl(sv[1], F_DUPFD_CLOEXEC, 10);
        close(sv[1]);
        sv[1] = moved;
        if (moved < 0) {
            close(sv[0]);
            return tsk_error(TSK_ERR_IO, "cannot prepare the recording reader's socket");
        }
    }
    posix_spawn_file_actions_t fa;
    posix_spawnattr_t attr;
    posix_spawn_file_actions_init(&fa);
    posix_spawnattr_init(&attr);
    posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
    if (getenv("TSK_ONI_READER_STDERR") == NULL) /* its messages come back as statuses */
        posix_spawn_file_actions_addopen(&fa, 2, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_adddup2(&fa, sv[1], TSK_ONI_READER_FD);
    sigset_t none, all;
    sigemptyset(&none);
    sigfillset(&all);
    posix_spawnattr_setsigmask(&attr, &none);
    posix_spawnattr_setsigdefault(&attr, &all);
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
    char* argv[] = {reader, (char*)path, NULL};
    pid_t pid = -1;
    const int err = posix_spawn(&pid, reader, &fa, &attr, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    posix_spawnattr_destroy(&attr);
    close(sv[1]);
    if (err != 0) {
        close(sv[0]);
        return tsk_error(TSK_ERR_INTERNAL, "cannot start the OpenNI2 recording reader '%s': %s",
                         reader, strerror(err));
    }
    return tsk_oni_proxy_attach(src, sv[0], (int)pid, path);
}

static tsk_status check_usable(tsk_oni_proxy* p) {
    if (p->broken)
        return tsk_error_arg(TSK_ERR_FORMAT, "source", "%s",
                             p->broken_why[0] ? p->broken_why : "the recording reader has stopped");
    return TSK_OK;
}

/* Sends a request and receives the reply header, checked. */
static tsk_status ask(tsk_depth_source* src, int32_t op, int32_t index, double timeout,
                      tsk_oni_reply* r, const char* what) {
    tsk_oni_proxy* p = src->proxy;
    tsk_status s = check_usable(p);
    if (s != TSK_OK) return s;
    const tsk_oni_request q = {op, index};
    if (send_all(p->fd, &q, sizeof q) != 0 || recv_all(p->fd, r, sizeof *r, now_s() + timeout) != 0)
        return fail(p, src->description, what);
    r->message[sizeof r->message - 1] = '\0';
    if (!valid_status(r->status) || (r->is_new != 0 && r->is_new != 1) ||
        (r->end != 0 && r->end != 1) || r->index < 0 || r->index > src->frame_count ||
        !isfinite(r->timestamp))
        return fail(p, src->description, "answering with an inconsistent reply, reading");
    if (r->status != TSK_OK)
        return tsk_error_arg((tsk_status)r->status, "source", "%s",
                             r->message[0] ? r->message : "the recording reader failed");
    return TSK_OK;
}

tsk_status tsk_oni_proxy_read(tsk_depth_source* src, float* depth_m, size_t count,
                              tsk_depth_frame* frame) {
    tsk_oni_reply r;
    tsk_status s = ask(src, TSK_ONI_OP_READ, 0, READ_TIMEOUT_S, &r, "reading");
    if (s != TSK_OK) return s;
    tsk_oni_proxy* p = src->proxy;
    if (r.is_new) {
        if (r.index >= src->frame_count)
            return fail(p, src->description, "answering with a frame past the end, reading");
        if (recv_all(p->fd, depth_m, count * sizeof(float), now_s() + READ_TIMEOUT_S) != 0)
            return fail(p, src->description, "sending a frame of");
        for (size_t i = 0; i < count; ++i)
            if (!(depth_m[i] >= 0.0f && depth_m[i] < 1e6f))
                return fail(p, src->description, "sending an invalid depth value, reading");
        src->cursor = r.index + 1;
    }
    frame->index = r.index;
    frame->is_new = r.is_new;
    frame->end = r.end;
    frame->timestamp = r.timestamp;
    return TSK_OK;
}

tsk_status tsk_oni_proxy_seek(tsk_depth_source* src, int index) {
    tsk_oni_reply r;
    const double timeout = SEEK_TIMEOUT_S + SEEK_PER_FRAME_S * (double)index;
    tsk_status s = ask(src, TSK_ONI_OP_SEEK, index, timeout, &r, "seeking in");
    if (s != TSK_OK) return s;
    src->cursor = index;
    return TSK_OK;
}

void tsk_oni_proxy_close(tsk_depth_source* src) {
    tsk_oni_proxy* p = src->proxy;
    if (p == NULL) return;
    if (!p->broken && p->pid > 0) {
        const tsk_oni_request q = {TSK_ONI_OP_QUIT, 0};
        (void)send_all(p->fd, &q, sizeof q);
    }
    close(p->fd); /* the reader also ends when its socket closes */
    reap(p, QUIT_GRACE_S, NULL, 0);
    tsk_free(p);
    src->proxy = NULL;
}

int tsk_oni_proxy_pid(const tsk_depth_source* src) {
    return (src && src->proxy) ? (int)src->proxy->pid : -1;
}
