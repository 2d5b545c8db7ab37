/* The recording reader's process and the channel to it, for depth_oni_proxy.c, which holds
 * the conversation (oni_reader_protocol.h): the platform's part. POSIX: posix_spawn (safe in a
 * multi-threaded process such as Blender, unlike fork) and a socket pair on the reader's
 * descriptor TSK_ONI_READER_FD. Windows: CreateProcessW and two pipes whose handles the reader
 * gets on its command line (TSK_ONI_READER_HANDLES). */
#ifndef TSK_ONI_READER_PROCESS_H
#define TSK_ONI_READER_PROCESS_H

#include <stddef.h>

#include "depth_internal.h"

#ifdef _WIN32
typedef void* tsk_oni_process; /* a process HANDLE; NULL: none */
#else
#include <sys/types.h>
typedef pid_t tsk_oni_process; /* -1: none */
#endif

/* Seconds on a monotonic clock. */
double tsk_oni_now_s(void);

/* Finds the reader ($TSK_ONI_READER, else beside the binary that holds this library) and
 * starts it on the recording `path`, with the other end of *ch. On failure nothing is left
 * open and the error is set. */
tsk_status tsk_oni_reader_start(const char* path, tsk_oni_channel* ch, tsk_oni_process* process);

/* The process with id `pid` (a reader started by tsk_oni_reader_start) as a tsk_oni_process;
 * pid <= 0 gives none. */
tsk_oni_process tsk_oni_process_of(int pid);
/* Its process id, -1 for none. */
int tsk_oni_process_id(tsk_oni_process process);
/* Waits up to `grace` seconds for the process to end, stopping it after that; writes how it
 * ended into `how` ("" if it exited with status 0 or there is no process; `how` may be NULL)
 * and sets *process to none. */
void tsk_oni_process_reap(tsk_oni_process* process, double grace, char* how, size_t cap);
/* Ends the process at once and reaps it (a channel that failed before the first word). */
void tsk_oni_process_kill(tsk_oni_process* process);

/* Receives exactly n bytes before `deadline` (tsk_oni_now_s); 0 on success, -1 on end of
 * stream, error or timeout. */
int tsk_oni_channel_recv(tsk_oni_channel ch, void* buf, size_t n, double deadline);
/* Sends n bytes; 0 on success, -1 if the reader is gone (never a signal). */
int tsk_oni_channel_send(tsk_oni_channel ch, const void* buf, size_t n);
void tsk_oni_channel_close(tsk_oni_channel ch);

#endif
