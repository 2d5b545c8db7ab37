/* A minimal test-only writer of OpenNI2 recordings (.oni, file format "NI10" 1.0.1.0), so
 * that the tests can make a recording that OpenNI2's own player (OniFile driver) plays
 * back. It writes the records that OpenNI2's FileRecorder writes for a depth stream
 * (node added, the properties of the stream, state ready, data begin, one uncompressed
 * NEW_DATA record per frame, node removed, seek table, end), plus the properties the
 * player needs before it delivers any frame: "xnCropping" (the player drops every frame
 * of a stream without it — which is why recording OpenNI2's Dummy device, which has no
 * cropping property, gives files that play no frame) and "xnFOV" (so that reading
 * intrinsics from a recording is tested). All fields little-endian, records packed. */
#ifndef TSK_ONI_WRITER_H
#define TSK_ONI_WRITER_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct oni_writer {
    FILE* f;
    int width, height, frames;
    long node_added_pos, last_data_pos;
    uint64_t last_ts;
    long* frame_pos;
    uint64_t* frame_ts;
    int cap;
} oni_writer;

enum {
    ONIW_NODE_ADDED = 0x0D,
    ONIW_INT_PROPERTY = 0x03,
    ONIW_GENERAL_PROPERTY = 0x06,
    ONIW_NODE_REMOVED = 0x07,
    ONIW_NODE_DATA_BEGIN = 0x08,
    ONIW_NODE_STATE_READY = 0x09,
    ONIW_NEW_DATA = 0x0A,
    ONIW_END = 0x0B,
    ONIW_SEEK_TABLE = 0x0E,
};
#define ONIW_HEADER 28 /* magic, type, node, fieldsSize, payloadSize (u32), undo pos (u64) */

static void oniw_u32(unsigned char** p, uint32_t v) {
    for (int i = 0; i < 4; ++i) *(*p)++ = (unsigned char)(v >> (8 * i));
}
static void oniw_u64(unsigned char** p, uint64_t v) {
    for (int i = 0; i < 8; ++i) *(*p)++ = (unsigned char)(v >> (8 * i));
}
static void oniw_str(unsigned char** p, const char* s) {
    const uint32_t n = (uint32_t)strlen(s) + 1;
    oniw_u32(p, n);
    memcpy(*p, s, n);
    *p += n;
}

/* Writes one record: header, then `fields` (fields_len bytes), then payload. */
static void oniw_record(oni_writer* w, uint32_t type, uint32_t node, uint64_t undo,
                        const unsigned char* fields, size_t fields_len, const void* payload,
                        size_t payload_len) {
    unsigned char h[ONIW_HEADER], *p = h;
    oniw_u32(&p, 0x0052494E); /* "NIR\0" */
    oniw_u32(&p, type);
    oniw_u32(&p, node);
    oniw_u32(&p, (uint32_t)(ONIW_HEADER + fields_len));
    oniw_u32(&p, (uint32_t)payload_len);
    oniw_u64(&p, undo);
    fwrite(h, 1, sizeof h, w->f);
    if (fields_len) fwrite(fields, 1, fields_len, w->f);
    if (payload_len) fwrite(payload, 1, payload_len, w->f);
}

static void oniw_general(oni_writer* w, const char* name, const void* data, uint32_t size) {
    unsigned char buf[512], *p = buf;
    oniw_str(&p, name);
    oniw_u32(&p, size);
    memcpy(p, data, size);
    p += size;
    oniw_record(w, ONIW_GENERAL_PROPERTY, 1, 0, buf, (size_t)(p - buf), NULL, 0);
}

static void oniw_int(oni_writer* w, const char* name, uint64_t v) {
    unsigned char buf[256], *p = buf;
    oniw_str(&p, name);
    oniw_u32(&p, 8);
    oniw_u64(&p, v);
    oniw_record(w, ONIW_INT_PROPERTY, 1, 0, buf, (size_t)(p - buf), NULL, 0);
}

static void oniw_node_added(oni_writer* w, uint32_t frames, uint64_t max_ts, uint64_t seek_pos) {
    unsigned char buf[128], *p = buf;
    oniw_str(&p, "Depth");
    oniw_u32(&p, 2); /* node type: depth */
    oniw_u32(&p, 0x454E4F4E); /* codec "NONE": uncompressed */
    oniw_u32(&p, frames);
    oniw_u64(&p, 0); /* min timestamp */
    oniw_u64(&p, max_ts);
    oniw_u64(&p, seek_pos);
    oniw_record(w, ONIW_NODE_ADDED, 1, 0, buf, (size_t)(p - buf), NULL, 0);
}

static void oniw_file_header(oni_writer* w, uint64_t max_ts) {
    unsigned char h[24], *p = h;
    memcpy(p, "NI10", 4);
    p += 4;
    *p++ = 1; /* version 1.0.1.0 */
    *p++ = 0;
    *p++ = 1;
    *p++ = 0;
    oniw_u32(&p, 0); /* build */
    oniw_u64(&p, max_ts);
    oniw_u32(&p, 1); /* max node id */
    fwrite(h, 1, sizeof h, w->f);
}

/* Opens a recording of width x height depth frames in millimetres with the given field of
 * view (radians). Returns 0 on success. */
static int oniw_open(oni_writer* w, const char* path, int width, int height, double hfov,
                     double vfov) {
    memset(w, 0, sizeof *w);
    w->f = fopen(path, "wb");
    if (!w->f) return -1;
    w->width = width;
    w->height = height;
    oniw_file_header(w, UINT64_MAX);
    w->node_added_pos = ftell(w->f);
    oniw_node_added(w, UINT32_MAX, UINT64_MAX, 0);
    const char device[256] = "Tussock test writer";
    oniw_general(w, "oniOriginalDevice", device, sizeof device);
    oniw_int(w, "oniRequiredFrameSize", (uint64_t)width * (uint64_t)height * 2u);
    oniw_int(w, "xnIsGenerating", 1);
    oniw_int(w, "xnDeviceMaxDepth", 10000);
    oniw_int(w, "xnSupportedMapOutputModesCount", 1);
    unsigned char mode[12], *p = mode;
    oniw_u32(&p, (uint32_t)width);
    oniw_u32(&p, (uint32_t)height);
    oniw_u32(&p, 30);
    oniw_general(w, "xnSupportedMapOutputModes", mode, sizeof mode);
    oniw_general(w, "xnMapOutputMode", mode, sizeof mode);
    const uint32_t supported = 1u << 3; /* grayscale 16-bit */
    oniw_general(w, "xnSupportedPixelFormats", &supported, 4);
    oniw_int(w, "xnPixelFormat", 4); /* XN_PIXEL_FORMAT_GRAYSCALE_16_BIT */
    oniw_int(w, "oniPixelFormat", 100); /* ONI_PIXEL_FORMAT_DEPTH_1_MM */
    double fov[2] = {hfov, vfov};
    oniw_general(w, "xnFOV", fov, sizeof fov);
    oniw_int(w, "Cropping", 1);
    unsigned char crop[12] = {0}; /* XnCropping: XnBool (int) enabled = 0, 4 x u16 */
    oniw_general(w, "xnCropping", crop, sizeof crop);
    oniw_record(w, ONIW_NODE_STATE_READY, 1, 0, NULL, 0, NULL, 0);
    unsigned char begin[12], *q = begin;
    oniw_u32(&q, UINT32_MAX);
    oniw_u64(&q, UINT64_MAX);
    oniw_record(w, ONIW_NODE_DATA_BEGIN, 1, 0, begin, sizeof begin, NULL, 0);
    return 0;
}

/* Appends one frame of width*height millimetre values. */
static int oniw_frame(oni_writer* w, const uint16_t* mm) {
    if (w->frames == w->cap) {
        w->cap = w->cap ? 2 * w->cap : 16;
        w->frame_pos = realloc(w->frame_pos, sizeof(long) * (size_t)w->cap);
        w->frame_ts = realloc(w->frame_ts, sizeof(uint64_t) * (size_t)w->cap);
        if (!w->frame_pos || !w->frame_ts) return -1;
    }
    const uint64_t ts = 33333u * (uint64_t)(w->frames + 1); /* microseconds */
    const long pos = ftell(w->f);
    unsigned char fields[12], *p = fields;
    oniw_u64(&p, ts);
    oniw_u32(&p, (uint32_t)(w->frames + 1)); /* frame ids start at 1 */
    oniw_record(w, ONIW_NEW_DATA, 1, (uint64_t)w->last_data_pos, fields, sizeof fields, mm,
                (size_t)w->width * (size_t)w->height * 2u);
    w->frame_pos[w->frames] = pos;
    w->frame_ts[w->frames] = ts;
    w->last_data_pos = pos;
    w->last_ts = ts;
    ++w->frames;
    return 0;
}

/* Writes the closing records, patches the header and node record; closes the file. */
static int oniw_close(oni_writer* w) {
    oniw_record(w, ONIW_NODE_REMOVED, 1, (uint64_t)w->node_added_pos, NULL, 0, NULL, 0);
    const long seek_pos = ftell(w->f);
    const size_t entry = 20; /* u64 timestamp, u32 configuration id, u64 position */
    const size_t n = (size_t)w->frames + 1;
    unsigned char* table = calloc(n, entry);
    unsigned char* p = table + entry; /* entry 0 is empty: frames start at 1 */
    for (int i = 0; i < w->frames; ++i) {
        oniw_u64(&p, w->frame_ts[i]);
        oniw_u32(&p, 0);
        oniw_u64(&p, (uint64_t)w->frame_pos[i]);
    }
    oniw_record(w, ONIW_SEEK_TABLE, 1, 0, NULL, 0, table, n * entry);
    free(table);
    oniw_record(w, ONIW_END, 0, 0, NULL, 0, NULL, 0);
    fseek(w->f, 0, SEEK_SET);
    oniw_file_header(w, w->last_ts);
    fseek(w->f, w->node_added_pos, SEEK_SET);
    oniw_node_added(w, (uint32_t)w->frames, w->last_ts, (uint64_t)seek_pos);
    const int rc = fclose(w->f);
    free(w->frame_pos);
    free(w->frame_ts);
    memset(w, 0, sizeof *w);
    return rc;
}

#endif
