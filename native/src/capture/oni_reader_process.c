/* The recording reader's process and the channel to it: oni_reader_process.h says what, the
 * POSIX and the Windows way. */
#define _GNU_SOURCE
#include "oni_reader_process.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#ifdef _WIN32
#define WIN32_LEAN_AND_MEAN
#include <windows.h>

#include "core/file.h"
#else
#include <dlfcn.h>
#include <fcntl.h>
#include <limits.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>
#endif

#include "oni_reader_protocol.h"

double tsk_oni_now_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

#ifndef _WIN32

extern char** environ;

static void sleep_s(double s) {
    struct timespec ts = {(time_t)s, (long)((s - (double)(time_t)s) * 1e9)};
    nanosleep(&ts, NULL);
}

tsk_oni_process tsk_oni_process_of(int pid) { return pid > 0 ? (pid_t)pid : -1; }

int tsk_oni_process_id(tsk_oni_process process) { return process > 0 ? (int)process : -1; }

void tsk_oni_process_reap(tsk_oni_process* process, double grace, char* how, size_t cap) {
    if (how && cap) how[0] = '\0';
    if (*process <= 0) return;
    int st = 0;
    pid_t r = 0;
    const double t0 = tsk_oni_now_s();
    while ((r = waitpid(*process, &st, WNOHANG)) == 0 && tsk_oni_now_s() - t0 < grace)
        sleep_s(0.002);
    if (r == 0) {
        kill(*process, SIGKILL);
        while ((r = waitpid(*process, &st, 0)) < 0 && errno == EINTR) {}
        if (how && cap) snprintf(how, cap, "did not answer and was stopped");
    } else if (r > 0 && how && cap) {
        if (WIFSIGNALED(st))
            snprintf(how, cap, "crashed (signal %d, %s)", WTERMSIG(st), strsignal(WTERMSIG(st)));
        else if (WIFEXITED(st) && WEXITSTATUS(st) != 0)
            snprintf(how, cap, "stopped with exit code %d", WEXITSTATUS(st));
    }
    *process = -1;
}

void tsk_oni_process_kill(tsk_oni_process* process) {
    if (*process <= 0) return;
    kill(*process, SIGKILL);
    waitpid(*process, NULL, 0);
    *process = -1;
}

int tsk_oni_channel_recv(tsk_oni_channel ch, void* buf, size_t n, double deadline) {
    unsigned char* b = buf;
    size_t got = 0;
    while (got < n) {
        const double left = deadline - tsk_oni_now_s();
        if (left <= 0.0) return -1;
        struct pollfd pfd = {ch, POLLIN, 0};
        const int pr = poll(&pfd, 1, (int)(left * 1000.0) + 1);
        if (pr < 0 && errno == EINTR) continue;
        if (pr <= 0) return -1;
        const ssize_t r = read(ch, b + got, n - got);
        if (r < 0 && (errno == EINTR || errno == EAGAIN)) continue;
        if (r <= 0) return -1;
        got += (size_t)r;
    }
    return 0;
}

int tsk_oni_channel_send(tsk_oni_channel ch, const void* buf, size_t n) {
    const unsigned char* b = buf;
    size_t sent = 0;
    while (sent < n) {
        const ssize_t r = send(ch, b + sent, n - sent, MSG_NOSIGNAL); /* never SIGPIPE */
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) return -1;
        sent += (size_t)r;
    }
    return 0;
}

void tsk_oni_channel_close(tsk_oni_channel ch) { close(ch); }

/* The reader's path: $TSK_ONI_READER, else beside the binary holding this code. */
static int reader_path(char* out, size_t cap) {
    const char* env = getenv("TSK_ONI_READER");
    if (env && env[0]) return snprintf(out, cap, "%s", env) < (int)cap;
    char dir[PATH_MAX];
    dir[0] = '\0';
    Dl_info info;
    if (dladdr((void*)&tsk_oni_reader_start, &info) && info.dli_fname &&
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

tsk_status tsk_oni_reader_start(const char* path, tsk_oni_channel* ch, tsk_oni_process* process) {
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
    *ch = sv[0];
    *process = pid;
    return TSK_OK;
}

#else /* Windows */

enum { ANSWER_BUFFER = 1 << 20 }; /* bytes the answers' pipe holds: a 640x480 frame fits */

static volatile LONG g_pipe_serial;

int tsk_oni_channel_pair(tsk_oni_channel* ours, tsk_oni_channel* theirs, int inheritable) {
    SECURITY_ATTRIBUTES sa = {sizeof sa, NULL, inheritable ? TRUE : FALSE};
    /* the answers: a named pipe, the only kind that reads with a timeout (overlapped) */
    char name[128];
    snprintf(name, sizeof name, "\\\\.\\pipe\\tussock-oni-%lu-%ld-%llu",
             (unsigned long)GetCurrentProcessId(), (long)InterlockedIncrement(&g_pipe_serial),
             (unsigned long long)GetTickCount64());
    wchar_t wname[128];
    for (size_t i = 0; i < sizeof name; ++i) wname[i] = (wchar_t)(unsigned char)name[i];
    HANDLE answers = CreateNamedPipeW(
        wname, PIPE_ACCESS_INBOUND | FILE_FLAG_OVERLAPPED | FILE_FLAG_FIRST_PIPE_INSTANCE,
        PIPE_TYPE_BYTE | PIPE_READMODE_BYTE | PIPE_WAIT | PIPE_REJECT_REMOTE_CLIENTS, 1, 0,
        ANSWER_BUFFER, 0, NULL);
    if (answers == INVALID_HANDLE_VALUE) return -1;
    HANDLE their_answers = CreateFileW(wname, GENERIC_WRITE, 0, &sa, OPEN_EXISTING, 0, NULL);
    if (their_answers == INVALID_HANDLE_VALUE) {
        const DWORD e = GetLastError();
        CloseHandle(answers);
        SetLastError(e);
        return -1;
    }
    /* the requests: an anonymous pipe; only the reader's end is inherited */
    HANDLE their_requests = NULL, requests = NULL;
    if (!CreatePipe(&their_requests, &requests, &sa, 0) ||
        !SetHandleInformation(requests, HANDLE_FLAG_INHERIT, 0)) {
        const DWORD e = GetLastError();
        if (their_requests) CloseHandle(their_requests);
        if (requests) CloseHandle(requests);
        CloseHandle(their_answers);
        CloseHandle(answers);
        SetLastError(e);
        return -1;
    }
    ours->answers = answers;
    ours->requests = requests;
    theirs->answers = their_answers;
    theirs->requests = their_requests;
    return 0;
}

tsk_oni_process tsk_oni_process_of(int pid) {
    if (pid <= 0) return NULL;
    return OpenProcess(SYNCHRONIZE | PROCESS_TERMINATE | PROCESS_QUERY_LIMITED_INFORMATION, FALSE,
                       (DWORD)pid);
}

int tsk_oni_process_id(tsk_oni_process process) {
    return process != NULL ? (int)GetProcessId(process) : -1;
}

/* An exception code as the reason a process ended: the common ones by name. */
static const char* exception_name(DWORD code) {
    switch (code) {
        case EXCEPTION_ACCESS_VIOLATION:
            return "access violation";
        case EXCEPTION_STACK_OVERFLOW:
            return "stack overflow";
        case EXCEPTION_ILLEGAL_INSTRUCTION:
            return "illegal instruction";
        case EXCEPTION_INT_DIVIDE_BY_ZERO:
            return "integer division by zero";
        case EXCEPTION_IN_PAGE_ERROR:
            return "in-page error";
        case 0xC0000409: /* STATUS_STACK_BUFFER_OVERRUN, also abort() and fast-fail */
            return "stack buffer overrun or abort";
        default:
            return "exception";
    }
}

void tsk_oni_process_reap(tsk_oni_process* process, double grace, char* how, size_t cap) {
    if (how && cap) how[0] = '\0';
    if (*process == NULL) return;
    const DWORD ms = grace > 0.0 ? (DWORD)(grace * 1000.0) + 1 : 0;
    if (WaitForSingleObject(*process, ms) != WAIT_OBJECT_0) {
        TerminateProcess(*process, 1);
        WaitForSingleObject(*process, 5000);
        if (how && cap) snprintf(how, cap, "did not answer and was stopped");
    } else if (how && cap) {
        DWORD code = 0;
        if (GetExitCodeProcess(*process, &code) && code >= 0xC0000000u)
            snprintf(how, cap, "crashed (exception 0x%08lX, %s)", (unsigned long)code,
                     exception_name(code));
        else if (code != 0) snprintf(how, cap, "stopped with exit code %lu", (unsigned long)code);
    }
    CloseHandle(*process);
    *process = NULL;
}

void tsk_oni_process_kill(tsk_oni_process* process) {
    if (*process == NULL) return;
    TerminateProcess(*process, 1);
    WaitForSingleObject(*process, 5000);
    CloseHandle(*process);
    *process = NULL;
}

int tsk_oni_channel_recv(tsk_oni_channel ch, void* buf, size_t n, double deadline) {
    HANDLE event = CreateEventW(NULL, TRUE, FALSE, NULL);
    if (event == NULL) return -1;
    unsigned char* b = buf;
    size_t got = 0;
    int rc = 0;
    while (got < n) {
        const double left = deadline - tsk_oni_now_s();
        if (left <= 0.0) {
            rc = -1;
            break;
        }
        OVERLAPPED ov;
        memset(&ov, 0, sizeof ov);
        ov.hEvent = event;
        const DWORD want = n - got < ((size_t)1 << 30) ? (DWORD)(n - got) : (DWORD)1 << 30;
        DWORD r = 0;
        if (!ReadFile(ch.answers, b + got, want, NULL, &ov)) {
            if (GetLastError() != ERROR_IO_PENDING) { /* ERROR_BROKEN_PIPE: the stream ended */
                rc = -1;
                break;
            }
            if (WaitForSingleObject(event, (DWORD)(left * 1000.0) + 1) != WAIT_OBJECT_0) {
                CancelIoEx(ch.answers, &ov);
                GetOverlappedResult(ch.answers, &ov, &r, TRUE); /* ov is the kernel's until then */
                rc = -1;
                break;
            }
        }
        if (!GetOverlappedResult(ch.answers, &ov, &r, FALSE) || r == 0) {
            rc = -1;
            break;
        }
        got += r;
    }
    CloseHandle(event);
    return rc;
}

int tsk_oni_channel_send(tsk_oni_channel ch, const void* buf, size_t n) {
    const unsigned char* b = buf;
    while (n > 0) {
        const DWORD want = n < ((size_t)1 << 30) ? (DWORD)n : (DWORD)1 << 30;
        DWORD w = 0;
        if (!WriteFile(ch.requests, b, want, &w, NULL) || w == 0) return -1;
        b += w;
        n -= w;
    }
    return 0;
}

void tsk_oni_channel_close(tsk_oni_channel ch) {
    if (ch.answers != NULL) CloseHandle(ch.answers);
    if (ch.requests != NULL) CloseHandle(ch.requests);
}

/* `w` as UTF-8 into out (cap bytes), for messages. */
static const char* narrow(const wchar_t* w, char* out, int cap) {
    if (WideCharToMultiByte(CP_UTF8, 0, w, -1, out, cap, NULL, NULL) <= 0) snprintf(out, cap, "?");
    return out;
}

enum { WPATH = 4096 };

/* The reader's path: %TSK_ONI_READER%, else beside the module (the add-on's .pyd, or a test
 * program) that holds this code. */
static int reader_path(wchar_t* out, size_t cap) {
    const wchar_t* env = _wgetenv(L"TSK_ONI_READER");
    if (env && env[0]) {
        if (wcslen(env) >= cap) return 0;
        wcscpy(out, env);
        return 1;
    }
    HMODULE module = NULL;
    if (!GetModuleHandleExW(
            GET_MODULE_HANDLE_EX_FLAG_FROM_ADDRESS | GET_MODULE_HANDLE_EX_FLAG_UNCHANGED_REFCOUNT,
            (LPCWSTR)(void*)&tsk_oni_reader_start, &module))
        return 0;
    const DWORD n = GetModuleFileNameW(module, out, (DWORD)cap);
    if (n == 0 || n >= cap) return 0;
    wchar_t* slash = wcsrchr(out, L'\\');
    if (slash == NULL) return 0;
    *slash = L'\0';
    const wchar_t* name = L"\\" TSK_ONI_READER_NAME L".exe";
    if (wcslen(out) + wcslen(name) >= cap) return 0;
    wcscat(out, name);
    return 1;
}

/* Appends `arg` to the command line `cmd` (capacity cap) quoted as CommandLineToArgvW and the
 * C runtime read it back; 0 if it does not fit. */
static int append_quoted(wchar_t* cmd, size_t cap, const wchar_t* arg) {
    size_t n = wcslen(cmd);
#define PUT(c)                      \
    do {                            \
        if (n + 1 >= cap) return 0; \
        cmd[n++] = (c);             \
    } while (0)
    if (n > 0) PUT(L' ');
    PUT(L'"');
    for (const wchar_t* p = arg;; ++p) {
        size_t backslashes = 0;
        while (*p == L'\\') ++p, ++backslashes;
        /* backslashes are literal except before a quote or the closing quote: doubled there */
        const size_t times = *p == L'\0' || *p == L'"' ? 2 * backslashes : backslashes;
        for (size_t i = 0; i < times; ++i) PUT(L'\\');
        if (*p == L'\0') break;
        if (*p == L'"') PUT(L'\\');
        PUT(*p);
    }
    PUT(L'"');
#undef PUT
    cmd[n] = L'\0';
    return 1;
}

/* An inheritable handle to the null device for the reader's standard handles. */
static HANDLE open_null(DWORD access) {
    SECURITY_ATTRIBUTES sa = {sizeof sa, NULL, TRUE};
    return CreateFileW(L"NUL", access, FILE_SHARE_READ | FILE_SHARE_WRITE, &sa, OPEN_EXISTING, 0,
                       NULL);
}

static tsk_status start_error(tsk_status status, const char* what, const wchar_t* reader) {
    char r[WPATH * 3];
    const DWORD e = GetLastError();
    return tsk_error(status, "%s '%s': %s", what, narrow(reader, r, (int)sizeof r),
                     strerror(tsk_errno_from_windows(e)));
}

tsk_status tsk_oni_reader_start(const char* path, tsk_oni_channel* ch, tsk_oni_process* process) {
    wchar_t reader[WPATH];
    if (!reader_path(reader, WPATH))
        return tsk_error(TSK_ERR_INTERNAL, "cannot locate the OpenNI2 recording reader");
    const DWORD attributes = GetFileAttributesW(reader);
    if (attributes == INVALID_FILE_ATTRIBUTES || (attributes & FILE_ATTRIBUTE_DIRECTORY)) {
        char r[WPATH * 3];
        return tsk_error(TSK_ERR_INTERNAL,
                         "the OpenNI2 recording reader '%s' is missing or not executable "
                         "(rebuild with ./build.sh build, or reinstall the add-on)",
                         narrow(reader, r, (int)sizeof r));
    }
    wchar_t* wpath = tsk_utf8_to_wide(path);
    if (wpath == NULL)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "path", "'%s' is not valid UTF-8", path);
    tsk_oni_channel theirs;
    if (tsk_oni_channel_pair(ch, &theirs, 1) != 0) {
        free(wpath);
        return start_error(TSK_ERR_IO, "cannot create pipes for the recording reader", reader);
    }
    /* the command line: the reader, the recording, the handles of its ends of the channel
     * (requests, answers; TSK_ONI_READER_HANDLES) */
    enum { CMD = 3 * WPATH + 64 };
    wchar_t* cmd = calloc(CMD, sizeof *cmd);
    wchar_t handles[64];
    swprintf(handles, 64, L"%llu %llu", (unsigned long long)(uintptr_t)theirs.requests,
             (unsigned long long)(uintptr_t)theirs.answers);
    const int fits = cmd != NULL && append_quoted(cmd, CMD, reader) &&
                     append_quoted(cmd, CMD, wpath) && wcslen(cmd) + 1 + wcslen(handles) < CMD;
    free(wpath);
    if (!fits) {
        free(cmd);
        tsk_oni_channel_close(*ch);
        tsk_oni_channel_close(theirs);
        return tsk_error_arg(TSK_ERR_LIMIT, "path", "'%s' is too long for the recording reader",
                             path);
    }
    wcscat(cmd, L" ");
    wcscat(cmd, handles);
    /* standard handles: the null device (its messages come back as statuses), or this
     * process's standard error for TSK_ONI_READER_STDERR */
    HANDLE null_in = open_null(GENERIC_READ), null_out = open_null(GENERIC_WRITE), err = NULL;
    if (getenv("TSK_ONI_READER_STDERR") != NULL)
        DuplicateHandle(GetCurrentProcess(), GetStdHandle(STD_ERROR_HANDLE), GetCurrentProcess(),
                        &err, 0, TRUE, DUPLICATE_SAME_ACCESS);
    /* the reader inherits these handles and no other (PROC_THREAD_ATTRIBUTE_HANDLE_LIST) */
    HANDLE inherit[5] = {theirs.requests, theirs.answers};
    DWORD count = 2;
    if (null_in != INVALID_HANDLE_VALUE) inherit[count++] = null_in;
    if (null_out != INVALID_HANDLE_VALUE) inherit[count++] = null_out;
    if (err != NULL) inherit[count++] = err;
    STARTUPINFOEXW si;
    memset(&si, 0, sizeof si);
    si.StartupInfo.cb = sizeof si;
    si.StartupInfo.dwFlags = STARTF_USESTDHANDLES;
    si.StartupInfo.hStdInput = null_in;
    si.StartupInfo.hStdOutput = null_out;
    si.StartupInfo.hStdError = err != NULL ? err : null_out;
    SIZE_T list_size = 0;
    InitializeProcThreadAttributeList(NULL, 1, 0, &list_size);
    si.lpAttributeList = malloc(list_size);
    BOOL ok = si.lpAttributeList != NULL &&
              InitializeProcThreadAttributeList(si.lpAttributeList, 1, 0, &list_size);
    const BOOL list_made = ok;
    ok = ok && UpdateProcThreadAttribute(si.lpAttributeList, 0, PROC_THREAD_ATTRIBUTE_HANDLE_LIST,
                                         inherit, count * sizeof(HANDLE), NULL, NULL);
    PROCESS_INFORMATION pi;
    memset(&pi, 0, sizeof pi);
    ok = ok && CreateProcessW(reader, cmd, NULL, NULL, TRUE,
                              EXTENDED_STARTUPINFO_PRESENT | CREATE_NO_WINDOW, NULL, NULL,
                              &si.StartupInfo, &pi);
    const DWORD e = GetLastError();
    if (list_made) DeleteProcThreadAttributeList(si.lpAttributeList);
    free(si.lpAttributeList);
    free(cmd);
    for (DWORD i = 2; i < count; ++i) CloseHandle(inherit[i]);
    tsk_oni_channel_close(theirs); /* the reader's ends are the reader's now */
    if (!ok) {
        tsk_oni_channel_close(*ch);
        SetLastError(e);
        return start_error(TSK_ERR_INTERNAL, "cannot start the OpenNI2 recording reader", reader);
    }
    CloseHandle(pi.hThread);
    *process = pi.hProcess;
    return TSK_OK;
}

#endif
