/* Opening a file that an artist named, without ever blocking on it: a FIFO opened for
 * reading waits for a writer, a character device (/dev/zero, /dev/urandom) never ends, and a
 * socket cannot be read as a file at all. Every input file that capture, pictures and bakes
 * read is opened through here, so a wrong path is an error message within a call instead of
 * a Blender that hangs with no way to cancel. */
#ifndef TSK_CORE_FILE_H
#define TSK_CORE_FILE_H

#include <stdio.h>

#include "tussock/core.h"

/// Opens `path` for binary reading into *out if it is a regular file (links followed).
/// Otherwise *out is NULL and the status says why, with the error naming argument `arg`:
/// TSK_ERR_ARGUMENT for an empty path, TSK_ERR_IO for a missing or unreadable file, a
/// folder, a FIFO, a socket or a device. The open never waits: a FIFO is opened non-blocking
/// and refused before anything is read.
tsk_status tsk_fopen_regular(const char* path, const char* arg, FILE** out);

#endif
