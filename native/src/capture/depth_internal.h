/* Private state of a depth source, shared by the files and OpenNI2 back ends. */
#ifndef TSK_DEPTH_INTERNAL_H
#define TSK_DEPTH_INTERNAL_H

#include "tussock/capture.h"

typedef struct tsk_oni_state tsk_oni_state;
typedef struct tsk_oni_proxy tsk_oni_proxy;

struct tsk_depth_source {
    tsk_depth_kind kind;
    int width, height;
    int frame_count; /* -1 for devices */
    int first_frame;
    int cursor; /* next frame to read (files, recordings) */
    int has_K;
    tsk_intrinsics K;
    char description[256];
    /* files: read through this pointer, which tsk_depth_open_files (depth_files.c) sets, so
     * that a program that never opens files (the recording reader) links no image codec */
    tsk_status (*read_file)(tsk_depth_source* src, int index, float* depth_m, size_t count,
                            int* invalid);
    char* pattern; /* path with the '#' run (or a plain path) */
    int hash_pos, hash_len; /* position and length of the '#' run; len 0 = single file */
    /* OpenNI2, in this process (devices; recordings inside the recording reader) */
    tsk_oni_state* oni;
    /* OpenNI2 recordings, through the recording reader process (depth_oni_proxy.c) */
    tsk_oni_proxy* proxy;
};

/* a zeroed source of `kind` (NULL when out of memory) */
tsk_depth_source* tsk_depth_new_source(tsk_depth_kind kind);

/* files back end */
tsk_status tsk_files_read(tsk_depth_source* src, int index, float* depth_m, size_t count,
                          int* invalid);
/* Reads and checks the header of a PNG or OpenEXR file: size limit, PNG bit depth and
 * colour type. Sets *w, *h. */
tsk_status tsk_depth_check_header(const char* path, int* w, int* h);

/* OpenNI2 back end (recordings and devices) */
tsk_status tsk_oni_open(tsk_depth_source* src, const char* uri, int is_file);
tsk_status tsk_oni_start(tsk_depth_source* src);
tsk_status tsk_oni_stop(tsk_depth_source* src);
tsk_status tsk_oni_seek(tsk_depth_source* src, int index);
tsk_status tsk_oni_read(tsk_depth_source* src, float* depth_m, size_t count,
                        tsk_depth_frame* frame);
void tsk_oni_close(tsk_depth_source* src);
/* Opens a recording in this process, with OpenNI2's own player. Only the recording reader
 * (native/helpers/oni_reader.c) calls it: a damaged file can crash that player. */
tsk_status tsk_depth_open_oni_local(const char* path, tsk_depth_source** out);

/* .oni recordings through the recording reader process */
tsk_status tsk_oni_proxy_open(tsk_depth_source* src, const char* path);
/* Our end of the channel to a recording reader (oni_reader_protocol.h). POSIX: one end of a
 * socket pair, both ways. Windows: two pipes, one each way, since a pipe cannot be closed
 * for writing alone as a socket can: the reader's answers arrive on `answers` (a named pipe
 * opened for overlapped reads, which time out), requests go to `requests`. */
#ifdef _WIN32
typedef struct tsk_oni_channel {
    void* answers; /* HANDLE */
    void* requests; /* HANDLE */
} tsk_oni_channel;
/* A new channel: `ours` as above; `theirs` is the reader's side (answers: the write end,
 * requests: the read end), inheritable by a child process if `inheritable`. 0 on success,
 * -1 with GetLastError set. Tests write the reader's side of a conversation with it. */
int tsk_oni_channel_pair(tsk_oni_channel* ours, tsk_oni_channel* theirs, int inheritable);
#else
typedef int tsk_oni_channel;
#endif
/* Takes over `ch`, the channel to a reader (process id `pid`, or -1 for none: tests and
 * fuzzing feed the bytes themselves), and receives and checks its hello. */
tsk_status tsk_oni_proxy_attach(tsk_depth_source* src, tsk_oni_channel ch, int pid,
                                const char* path);
/* A recording source over `ch` with no reader process behind it: tests and fuzz_oni write
 * the reader's side of the conversation themselves. */
tsk_status tsk_depth_attach_oni_reader(tsk_oni_channel ch, const char* name,
                                       tsk_depth_source** out);
/* Test hook: the process id of a recording's reader (-1 if none). */
int tsk_oni_proxy_pid(const tsk_depth_source* src);
tsk_status tsk_oni_proxy_read(tsk_depth_source* src, float* depth_m, size_t count,
                              tsk_depth_frame* frame);
tsk_status tsk_oni_proxy_seek(tsk_depth_source* src, int index);
void tsk_oni_proxy_close(tsk_depth_source* src);

/* Test hook: makes a device source behave as if the device had been unplugged. */
void tsk_oni_simulate_loss(tsk_depth_source* src);

#endif
