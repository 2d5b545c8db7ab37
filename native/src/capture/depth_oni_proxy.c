/* .oni recordings read through the recording reader process (oni_reader_protocol.h says
 * why and how). This side starts `tussock_oni_reader` (oni_reader_process.c: posix_spawn and
 * a socket pair, or CreateProcessW and pipes on Windows), talks to it, and checks every byte
 * it receives. A reader that crashes, hangs or answers nonsense becomes a TSK_ERR_FORMAT
 * naming the recording; the caller's process is never at risk.
 *
 * The reader is found at $TSK_ONI_READER, else beside the binary that holds this library
 * (the add-on's _tussock.abi3.so, or a test executable in the build folder). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "depth_internal.h"
#include "oni_reader_process.h"
#include "oni_reader_protocol.h"

#define OPEN_TIMEOUT_S 20.0 /* the reader opens the recording and answers tsk_oni_hello */
#define READ_TIMEOUT_S 10.0 /* the reader itself gives up on a frame after 3 s */
#define SEEK_TIMEOUT_S 20.0 /* plus SEEK_PER_FRAME_S per frame read and dropped */
#define SEEK_PER_FRAME_S 0.05
#define QUIT_GRACE_S 1.0

struct tsk_oni_proxy {
    tsk_oni_channel ch;
    tsk_oni_process process; /* none when there is no process (tsk_oni_proxy_attach for tests) */
    int broken; /* the conversation failed: every later call fails */
    char broken_why[TSK_ONI_MESSAGE + 256];
};

/* Marks the conversation broken and sets the error: the reader's fate if it is known. */
static tsk_status fail(tsk_oni_proxy* p, const char* path, const char* what) {
    char how[160];
    /* a crashing reader is given time to end; a hung one is stopped ("did not answer") */
    tsk_oni_process_reap(&p->process, 2.0, how, sizeof how);
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

static int valid_status(int32_t s) { return s >= TSK_OK && s <= TSK_ERR_INTERNAL; }

static tsk_status attach(tsk_depth_source* src, tsk_oni_channel ch, tsk_oni_process process,
                         const char* path) {
    tsk_oni_proxy* p = tsk_calloc(1, sizeof *p, "recording reader");
    if (p == NULL) {
        tsk_oni_channel_close(ch);
        tsk_oni_process_kill(&process);
        return TSK_ERR_MEMORY;
    }
    p->ch = ch;
    p->process = process;
    src->proxy = p;
    tsk_oni_hello h;
    if (tsk_oni_channel_recv(ch, &h, sizeof h, tsk_oni_now_s() + OPEN_TIMEOUT_S) != 0)
        return fail(p, path, "opening");
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

tsk_status tsk_oni_proxy_attach(tsk_depth_source* src, tsk_oni_channel ch, int pid,
                                const char* path) {
    return attach(src, ch, tsk_oni_process_of(pid), path);
}

tsk_status tsk_oni_proxy_open(tsk_depth_source* src, const char* path) {
    tsk_oni_channel ch;
    tsk_oni_process process;
    const tsk_status s = tsk_oni_reader_start(path, &ch, &process);
    if (s != TSK_OK) return s;
    return attach(src, ch, process, path);
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
    if (tsk_oni_channel_send(p->ch, &q, sizeof q) != 0 ||
        tsk_oni_channel_recv(p->ch, r, sizeof *r, tsk_oni_now_s() + timeout) != 0)
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
        if (tsk_oni_channel_recv(p->ch, depth_m, count * sizeof(float),
                                 tsk_oni_now_s() + READ_TIMEOUT_S) != 0)
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
    if (!p->broken && tsk_oni_process_id(p->process) > 0) {
        const tsk_oni_request q = {TSK_ONI_OP_QUIT, 0};
        (void)tsk_oni_channel_send(p->ch, &q, sizeof q);
    }
    tsk_oni_channel_close(p->ch); /* the reader also ends when its channel closes */
    tsk_oni_process_reap(&p->process, QUIT_GRACE_S, NULL, 0);
    tsk_free(p);
    src->proxy = NULL;
}

int tsk_oni_proxy_pid(const tsk_depth_source* src) {
    return (src && src->proxy) ? tsk_oni_process_id(src->proxy->process) : -1;
}
