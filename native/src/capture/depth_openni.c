/* OpenNI2 back end of the depth sources, on the C API (OniCAPI.h): .oni recordings read
 * frame by frame (manual playback: no clock, each read takes the next frame; seek; frame
 * count) and live devices by URI with a latest-frame read that never blocks (a new-frame
 * callback counts arrivals; a read with nothing new returns at once). A device that
 * disconnects, or sends nothing for TSK_ONI_STALL_S seconds while started, is reported
 * as lost. OpenNI2 is initialised once per process and never shut down (re-initialising
 * it is not reliable). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

typedef struct _OniDevice _OniDevice;
typedef struct _OniStream _OniStream;
typedef struct _OniRecorder _OniRecorder;
#include <OniCAPI.h>

#include "depth_internal.h"

#define TSK_ONI_STALL_S 5.0 /* a started device silent this long is lost */
#define TSK_ONI_FILE_WAIT_MS 3000 /* a recording that gives no frame this long is broken */
#define MAX_OPEN 32

struct tsk_oni_state {
    OniDeviceHandle dev;
    OniStreamHandle stream;
    OniCallbackHandle frame_cb;
    int is_file;
    int started;
    int pixel_format;
    atomic_int arrived; /* frames announced by the new-frame callback */
    atomic_int lost;
    int seen; /* value of `arrived` at the last read */
    int arrived_at_start;
    int frames_read;
    double last_frame_s;
    double stopped_s; /* when the device stream was last stopped (0 = never started) */
    char uri[ONI_MAX_STR];
};

static pthread_mutex_t g_mu = PTHREAD_MUTEX_INITIALIZER;
static int g_init_done;
static OniStatus g_init_status;
static char g_init_error[512];
static tsk_oni_state* g_open[MAX_OPEN];
static OniCallbackHandle g_device_cb;

static double now_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void ONI_CALLBACK_TYPE on_disconnected(const OniDeviceInfo* info, void* cookie) {
    (void)cookie;
    pthread_mutex_lock(&g_mu);
    for (int i = 0; i < MAX_OPEN; ++i)
        if (g_open[i] && strncmp(g_open[i]->uri, info->uri, ONI_MAX_STR) == 0)
            atomic_store(&g_open[i]->lost, 1);
    pthread_mutex_unlock(&g_mu);
}

static void ONI_CALLBACK_TYPE on_new_frame(OniStreamHandle stream, void* cookie) {
    (void)stream;
    atomic_fetch_add(&((tsk_oni_state*)cookie)->arrived, 1);
}

static tsk_status init_openni(void) {
    pthread_mutex_lock(&g_mu);
    if (!g_init_done) {
        g_init_status = oniInitialize(ONI_API_VERSION);
        if (g_init_status != ONI_STATUS_OK) {
            snprintf(g_init_error, sizeof g_init_error, "%s", oniGetExtendedError());
        } else {
            OniDeviceCallbacks cbs;
            memset(&cbs, 0, sizeof cbs);
            cbs.deviceDisconnected = on_disconnected;
            oniRegisterDeviceCallbacks(&cbs, NULL, &g_device_cb);
        }
        g_init_done = 1;
    }
    const OniStatus st = g_init_status;
    pthread_mutex_unlock(&g_mu);
    if (st != ONI_STATUS_OK)
        return tsk_error(TSK_ERR_DEVICE, "OpenNI2 could not be initialised: %s", g_init_error);
    return TSK_OK;
}

static void registry_set(tsk_oni_state* st, int add) {
    pthread_mutex_lock(&g_mu);
    for (int i = 0; i < MAX_OPEN; ++i) {
        if (add && g_open[i] == NULL) {
            g_open[i] = st;
            break;
        }
        if (!add && g_open[i] == st) g_open[i] = NULL;
    }
    pthread_mutex_unlock(&g_mu);
}

static const char* oni_error(void) {
    const char* e = oniGetExtendedError();
    return e && e[0] ? e : "no details";
}

tsk_status tsk_oni_open(tsk_depth_source* src, const char* uri, int is_file) {
    tsk_status s = init_openni();
    if (s != TSK_OK) return s;
    tsk_oni_state* st = tsk_calloc(1, sizeof *st, "OpenNI2 state");
    if (st == NULL) return TSK_ERR_MEMORY;
    src->oni = st;
    st->is_file = is_file;
    const char* open_uri = (uri && uri[0]) ? uri : NULL;
    if (oniDeviceOpen(open_uri, &st->dev) != ONI_STATUS_OK) {
        st->dev = NULL;
        if (is_file)
            return tsk_error_arg(TSK_ERR_FORMAT, "path",
                                 "'%s' is not a readable OpenNI2 recording (%s)", uri, oni_error());
        return tsk_error_arg(TSK_ERR_DEVICE, "uri", "no depth device %s%s%s (%s)",
                             open_uri ? "'" : "", open_uri ? open_uri : "is connected",
                             open_uri ? "' could be opened" : "", oni_error());
    }
    OniDeviceInfo info;
    int size = (int)sizeof info;
    memset(&info, 0, sizeof info);
    if (oniDeviceGetInfo(st->dev, &info) == ONI_STATUS_OK)
        snprintf(st->uri, sizeof st->uri, "%s", info.uri);
    else snprintf(st->uri, sizeof st->uri, "%s", open_uri ? open_uri : "");
    (void)size;
    if (oniDeviceCreateStream(st->dev, ONI_SENSOR_DEPTH, &st->stream) != ONI_STATUS_OK) {
        st->stream = NULL;
        return tsk_error_arg(is_file ? TSK_ERR_FORMAT : TSK_ERR_DEVICE, is_file ? "path" : "uri",
                             "'%s' has no depth stream (%s)", st->uri, oni_error());
    }
    OniVideoMode mode;
    size = (int)sizeof mode;
    if (oniStreamGetProperty(st->stream, ONI_STREAM_PROPERTY_VIDEO_MODE, &mode, &size) !=
        ONI_STATUS_OK)
        return tsk_error_arg(TSK_ERR_DEVICE, "uri", "'%s': cannot read the depth video mode (%s)",
                             st->uri, oni_error());
    if (mode.pixelFormat != ONI_PIXEL_FORMAT_DEPTH_1_MM &&
        mode.pixelFormat != ONI_PIXEL_FORMAT_DEPTH_100_UM)
        return tsk_error_arg(TSK_ERR_FORMAT, "uri",
                             "'%s': depth pixel format %d is not millimetres or 100 µm", st->uri,
                             (int)mode.pixelFormat);
    if (mode.resolutionX <= 0 || mode.resolutionY <= 0 || mode.resolutionX > TSK_DEPTH_MAX_SIDE ||
        mode.resolutionY > TSK_DEPTH_MAX_SIDE)
        return tsk_error_arg(TSK_ERR_LIMIT, "uri", "'%s': depth size %dx%d outside 1..%d", st->uri,
                             mode.resolutionX, mode.resolutionY, TSK_DEPTH_MAX_SIDE);
    st->pixel_format = mode.pixelFormat;
    src->width = mode.resolutionX;
    src->height = mode.resolutionY;
    /* intrinsics from the reported field of view, where the device reports it */
    float hfov = 0.0f, vfov = 0.0f;
    int hs = (int)sizeof hfov, vs = (int)sizeof vfov;
    src->K = tsk_default_intrinsics(src->width, src->height);
    if (oniStreamGetProperty(st->stream, ONI_STREAM_PROPERTY_HORIZONTAL_FOV, &hfov, &hs) ==
            ONI_STATUS_OK &&
        oniStreamGetProperty(st->stream, ONI_STREAM_PROPERTY_VERTICAL_FOV, &vfov, &vs) ==
            ONI_STATUS_OK) {
        tsk_intrinsics k;
        if (tsk_intrinsics_from_fov(src->width, src->height, hfov, vfov, &k) == TSK_OK) {
            src->K = k;
            src->has_K = 1;
        }
    }
    tsk_clear_error();
    if (oniStreamRegisterNewFrameCallback(st->stream, on_new_frame, st, &st->frame_cb) !=
        ONI_STATUS_OK)
        st->frame_cb = NULL;
    if (is_file) {
        float speed = -1.0f; /* manual: a frame per read, no clock */
        OniBool repeat = 0;
        oniDeviceSetProperty(st->dev, ONI_DEVICE_PROPERTY_PLAYBACK_SPEED, &speed, sizeof speed);
        oniDeviceSetProperty(st->dev, ONI_DEVICE_PROPERTY_PLAYBACK_REPEAT_ENABLED, &repeat,
                             sizeof repeat);
        int frames = 0;
        size = (int)sizeof frames;
        if (oniStreamGetProperty(st->stream, ONI_STREAM_PROPERTY_NUMBER_OF_FRAMES, &frames,
                                 &size) != ONI_STATUS_OK ||
            frames <= 0)
            return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' holds no depth frame", uri);
        src->frame_count = frames;
        if (oniStreamStart(st->stream) != ONI_STATUS_OK)
            return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s': cannot start playback (%s)", uri,
                                 oni_error());
        st->started = 1;
    } else {
        src->frame_count = -1;
        snprintf(src->description, sizeof src->description, "%s", st->uri);
        registry_set(st, 1);
    }
    return TSK_OK;
}

tsk_status tsk_oni_start(tsk_depth_source* src) {
    tsk_oni_state* st = src->oni;
    if (atomic_load(&st->lost))
        return tsk_error_arg(TSK_ERR_DEVICE, "source", "device '%s' was lost", st->uri);
    if (st->started) return TSK_OK;
    if (oniStreamStart(st->stream) != ONI_STATUS_OK)
        return tsk_error_arg(TSK_ERR_DEVICE, "source", "cannot start the depth stream of '%s' (%s)",
                             st->uri, oni_error());
    st->started = 1;
    st->seen = atomic_load(&st->arrived);
    st->arrived_at_start = st->seen;
    st->last_frame_s = now_s();
    return TSK_OK;
}

/* The Dummy driver's frame thread sets its own "running" flag when it begins, so a stop
 * issued before the thread has begun is lost and the thread runs on forever. Before
 * stopping a device stream, wait (at most TSK_ONI_START_GRACE_S) for its first frame. */
#define TSK_ONI_START_GRACE_S 0.5
static void wait_first_frame(const tsk_oni_state* st) {
    const double t0 = now_s();
    while (atomic_load(&((tsk_oni_state*)st)->arrived) == st->arrived_at_start &&
           now_s() - t0 < TSK_ONI_START_GRACE_S) {
        struct timespec ts = {0, 2000000};
        nanosleep(&ts, NULL);
    }
}

tsk_status tsk_oni_stop(tsk_depth_source* src) {
    tsk_oni_state* st = src->oni;
    if (st->started && st->stream) {
        if (!st->is_file) wait_first_frame(st);
        oniStreamStop(st->stream);
        st->stopped_s = now_s();
    }
    st->started = 0;
    return TSK_OK;
}

/* OpenNI2's Dummy driver (and possibly others) only flags its frame thread to stop and
 * does not join it; the thread touches the stream up to one frame period (33 ms) later.
 * Destroying the stream before that is a use-after-free, so a device stream is destroyed
 * only TSK_ONI_STOP_GRACE_S after it was stopped. */
#define TSK_ONI_STOP_GRACE_S 0.12
static void wait_after_stop(const tsk_oni_state* st) {
    if (st->is_file || st->stopped_s == 0.0) return;
    const double left = TSK_ONI_STOP_GRACE_S - (now_s() - st->stopped_s);
    if (left <= 0.0) return;
    struct timespec ts = {0, (long)(left * 1e9)};
    nanosleep(&ts, NULL);
}

/* Seeking does not use OpenNI2's ONI_DEVICE_COMMAND_SEEK: the OniFile player of OpenNI2
 * 2.2 crashed in its reading thread on seek in our tests, and a crash would take Blender
 * down. Instead a backward seek reopens the recording, and frames up to `index` are read
 * and dropped (manual playback reads a 640x480 frame in about a millisecond). */
tsk_status tsk_oni_seek(tsk_depth_source* src, int index) {
    if (index < src->cursor) {
        char path[sizeof src->description];
        memcpy(path, src->description, sizeof path);
        const int frames = src->frame_count;
        tsk_oni_close(src);
        tsk_status s = tsk_oni_open(src, path, 1);
        if (s != TSK_OK) return s;
        if (src->frame_count != frames)
            return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' changed while it was read", path);
        src->cursor = 0;
    }
    if (src->cursor == index) return TSK_OK;
    const size_t npix = (size_t)src->width * (size_t)src->height;
    float* scratch = tsk_alloc(npix * sizeof(float), "seek buffer");
    if (scratch == NULL) return TSK_ERR_MEMORY;
    tsk_status s = TSK_OK;
    while (src->cursor < index && s == TSK_OK) {
        tsk_depth_frame fr;
        memset(&fr, 0, sizeof fr);
        s = tsk_oni_read(src, scratch, npix, &fr);
        if (s == TSK_OK && !fr.is_new)
            s = tsk_error_arg(TSK_ERR_FORMAT, "index", "recording ended before frame %d", index);
    }
    tsk_free(scratch);
    return s;
}

static void convert(const tsk_depth_source* src, const tsk_oni_state* st, const OniFrame* f,
                    float* depth_m) {
    const float scale = st->pixel_format == ONI_PIXEL_FORMAT_DEPTH_100_UM ? 1e-4f : 1e-3f;
    const int w = src->width, h = src->height;
    const int ox = f->croppingEnabled ? f->cropOriginX : 0;
    const int oy = f->croppingEnabled ? f->cropOriginY : 0;
    memset(depth_m, 0, (size_t)w * (size_t)h * sizeof(float));
    const int stride = f->stride > 0 ? f->stride : f->width * 2;
    for (int y = 0; y < f->height; ++y) {
        const int ty = y + oy;
        if (ty < 0 || ty >= h) continue;
        const size_t row_off = (size_t)y * (size_t)stride;
        if (row_off + (size_t)f->width * 2 > (size_t)f->dataSize) break;
        const uint16_t* row = (const uint16_t*)((const unsigned char*)f->data + row_off);
        for (int x = 0; x < f->width; ++x) {
            const int tx = x + ox;
            if (tx < 0 || tx >= w) continue;
            depth_m[(size_t)ty * (size_t)w + (size_t)tx] = (float)row[x] * scale;
        }
    }
}

tsk_status tsk_oni_read(tsk_depth_source* src, float* depth_m, size_t count,
                        tsk_depth_frame* frame) {
    (void)count;
    tsk_oni_state* st = src->oni;
    if (st->is_file) {
        frame->index = src->cursor;
        if (src->cursor >= src->frame_count) {
            frame->end = 1;
            return TSK_OK;
        }
        int idx = 0;
        OniStatus ws = oniWaitForAnyStream(&st->stream, 1, &idx, TSK_ONI_FILE_WAIT_MS);
        if (ws != ONI_STATUS_OK)
            return tsk_error_arg(TSK_ERR_FORMAT, "source",
                                 "recording '%s' gave no frame %d (of %d) within %d ms (%s)",
                                 src->description, src->cursor, src->frame_count,
                                 TSK_ONI_FILE_WAIT_MS, oni_error());
        OniFrame* f = NULL;
        if (oniStreamReadFrame(st->stream, &f) != ONI_STATUS_OK || f == NULL)
            return tsk_error_arg(TSK_ERR_FORMAT, "source", "cannot read frame %d of '%s' (%s)",
                                 src->cursor, src->description, oni_error());
        convert(src, st, f, depth_m);
        frame->timestamp = (double)f->timestamp * 1e-6;
        oniFrameRelease(f);
        frame->is_new = 1;
        ++src->cursor;
        frame->end = src->cursor >= src->frame_count;
        return TSK_OK;
    }
    if (atomic_load(&st->lost))
        return tsk_error_arg(TSK_ERR_DEVICE, "source",
                             "device '%s' was lost (unplugged?) during capture", st->uri);
    if (!st->started)
        return tsk_error_arg(TSK_ERR_ARGUMENT, "source",
                             "the stream of '%s' is not started (call start first)", st->uri);
    const int arrived = atomic_load(&st->arrived);
    frame->index = st->frames_read;
    if (arrived == st->seen) {
        if (now_s() - st->last_frame_s > TSK_ONI_STALL_S) {
            atomic_store(&st->lost, 1);
            return tsk_error_arg(TSK_ERR_DEVICE, "source",
                                 "device '%s' sent no frame for %.0f s: lost?", st->uri,
                                 TSK_ONI_STALL_S);
        }
        return TSK_OK; /* nothing new: never wait */
    }
    OniFrame* f = NULL;
    /* a frame has arrived, so this read returns without waiting */
    if (oniStreamReadFrame(st->stream, &f) != ONI_STATUS_OK || f == NULL) {
        return tsk_error_arg(TSK_ERR_DEVICE, "source", "cannot read a frame from '%s' (%s)",
                             st->uri, oni_error());
    }
    convert(src, st, f, depth_m);
    frame->timestamp = (double)f->timestamp * 1e-6;
    oniFrameRelease(f);
    st->seen = arrived;
    st->last_frame_s = now_s();
    frame->is_new = 1;
    frame->index = st->frames_read++;
    return TSK_OK;
}

void tsk_oni_close(tsk_depth_source* src) {
    tsk_oni_state* st = src->oni;
    if (st == NULL) return;
    if (!st->is_file) registry_set(st, 0);
    if (st->stream) {
        if (st->started) {
            if (!st->is_file) wait_first_frame(st);
            oniStreamStop(st->stream);
            st->stopped_s = now_s();
        }
        if (st->frame_cb) oniStreamUnregisterNewFrameCallback(st->stream, st->frame_cb);
        wait_after_stop(st);
        oniStreamDestroy(st->stream);
    }
    if (st->dev) oniDeviceClose(st->dev);
    tsk_free(st);
    src->oni = NULL;
}

void tsk_oni_simulate_loss(tsk_depth_source* src) {
    if (src && src->oni) atomic_store(&src->oni->lost, 1);
}
