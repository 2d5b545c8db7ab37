/* The conversation between Tussock and its OpenNI2 recording reader, a separate process
 * (native/helpers/oni_reader.c, installed beside the library as `tussock_oni_reader`).
 *
 * Why a process: OpenNI2's recording player (libOniFile) parses .oni files with little
 * checking, and a damaged file can crash it (native/fuzz/crashes/oni-segv-libOniFile.oni is
 * one). In Blender's process that crash would take the artist's work with it; in the reader
 * it is a status. The reader runs the ordinary in-process recording code of depth_openni.c
 * and answers over a socket on file descriptor TSK_ONI_READER_FD; on Windows over two pipes
 * whose handles follow the recording on its command line (TSK_ONI_READER_HANDLES).
 *
 * Messages are fixed-size structs in the machine's own byte order (both ends are this build).
 *   reader -> Tussock, once, at start: tsk_oni_hello.
 *   Tussock -> reader: tsk_oni_request; the reader answers each with tsk_oni_reply, followed
 *   by width*height float32 depths in metres when status is TSK_OK and is_new is 1.
 * Every field that Tussock receives is checked before it is used (fuzz_oni feeds it bytes). */
#ifndef TSK_ONI_READER_PROTOCOL_H
#define TSK_ONI_READER_PROTOCOL_H

#include <stdint.h>

#define TSK_ONI_READER_NAME "tussock_oni_reader"
#define TSK_ONI_READER_FD 3
/* Windows: `tussock_oni_reader RECORDING.oni REQUESTS ANSWERS`, two inherited pipe handles in
 * decimal: it reads requests from the first and writes its answers to the second. */
#define TSK_ONI_READER_HANDLES 2
#define TSK_ONI_MAGIC "TSKONI02"
#define TSK_ONI_MESSAGE 512

enum { TSK_ONI_OP_READ = 1, TSK_ONI_OP_SEEK = 2, TSK_ONI_OP_QUIT = 3 };

typedef struct tsk_oni_hello {
    char magic[8];
    int32_t status; /* tsk_status of opening the recording */
    int32_t width, height, frame_count, has_K;
    int32_t pad_;
    double fx, fy, cx, cy;
    char message[TSK_ONI_MESSAGE]; /* the error message when status != TSK_OK */
} tsk_oni_hello;

typedef struct tsk_oni_request {
    int32_t op;
    int32_t index; /* seek target */
} tsk_oni_request;

typedef struct tsk_oni_reply {
    int32_t status;
    int32_t is_new, index, end;
    double timestamp;
    char message[TSK_ONI_MESSAGE];
} tsk_oni_reply;

#endif
