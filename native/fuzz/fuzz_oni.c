/* Fuzz target: what Tussock receives from its OpenNI2 recording reader process
 * (src/capture/oni_reader_protocol.h). The reader runs third-party code that a damaged
 * recording can crash or confuse, so every answer it gives is checked; here the answers are
 * the fuzzer's bytes: a hello, then replies and frames for a sequence of reads and seeks.
 * Nothing may crash, hang or leak, and every frame accepted must hold finite depths >= 0. */
#include "fuzz.h"

#include <sys/socket.h>

#include "capture/depth_internal.h"
#include "tussock/capture.h"

#define FZ_ONI_MAX_INPUT (96 * 1024)

int LLVMFuzzerInitialize(int* argc, char*** argv) {
    (void)argc;
    (void)argv;
    fz_init();
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size > FZ_ONI_MAX_INPUT) return 0;
    int sv[2];
    if (socketpair(AF_UNIX, SOCK_STREAM, 0, sv) != 0) return 0;
    const int buf = 4 * FZ_ONI_MAX_INPUT;
    setsockopt(sv[1], SOL_SOCKET, SO_SNDBUF, &buf, sizeof buf);
    setsockopt(sv[0], SOL_SOCKET, SO_RCVBUF, &buf, sizeof buf);
    if (size > 0 && write(sv[1], data, size) != (ssize_t)size) {
        close(sv[0]);
        close(sv[1]);
        return 0;
    }
    shutdown(sv[1], SHUT_WR); /* the reader's answers end here; its end still takes requests */
    tsk_depth_source* src = NULL;
    if (tsk_depth_attach_oni_reader(sv[0], "fuzz.oni", &src) == TSK_OK) {
        tsk_depth_info info;
        if (tsk_depth_get_info(src, &info) != TSK_OK) abort();
        if (info.width <= 0 || info.height <= 0 || info.frame_count <= 0) abort();
        const size_t n = (size_t)info.width * (size_t)info.height;
        float* depth = malloc(n * sizeof *depth);
        tsk_depth_frame fr;
        for (int i = 0; i < 6 && depth != NULL; ++i) {
            tsk_status s = (i == 3) ? tsk_depth_seek(src, 0) : tsk_depth_read(src, depth, n, &fr);
            if (s != TSK_OK) {
                if (tsk_last_error()[0] == '\0') abort();
                continue; /* a broken conversation stays broken: later calls fail too */
            }
            if (i != 3 && fr.is_new) {
                if (fr.index < 0 || fr.index >= info.frame_count) abort();
                for (size_t k = 0; k < n; ++k)
                    if (!(depth[k] >= 0.0f) || !isfinite(depth[k])) abort();
            }
        }
        free(depth);
        tsk_depth_close(src);
    }
    close(sv[1]);
    fz_check_leaks("oni");
    return 0;
}
