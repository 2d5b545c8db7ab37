/* Files by path, the same on every platform.
 *
 * Opening a file that an artist named, without ever blocking on it: a FIFO opened for
 * reading waits for a writer, a character device (/dev/zero, /dev/urandom) never ends, and a
 * socket cannot be read as a file at all. Every input file that capture, pictures and bakes
 * read is opened through here, so a wrong path is an error message within a call instead of
 * a Blender that hangs with no way to cancel.
 *
 * Paths are UTF-8. The other functions are the POSIX calls that the library uses on files;
 * on Windows they turn the path into a wide (UTF-16) one, so that any name works whatever the
 * ANSI code page, open files in binary mode, and replace files as rename does on POSIX. They
 * set errno as the POSIX calls do. */
#ifndef TSK_CORE_FILE_H
#define TSK_CORE_FILE_H

#include <stdint.h>
#include <stdio.h>

#include "tussock/core.h"

/// Opens `path` for binary reading into *out if it is a regular file (links followed).
/// Otherwise *out is NULL and the status says why, with the error naming argument `arg`:
/// TSK_ERR_ARGUMENT for an empty path, TSK_ERR_IO for a missing or unreadable file, a
/// folder, a FIFO, a socket or a device. The open never waits: a FIFO is opened non-blocking
/// and refused before anything is read.
tsk_status tsk_fopen_regular(const char* path, const char* arg, FILE** out);

/// fopen(path, mode).
FILE* tsk_fopen(const char* path, const char* mode);
/// open(path, flags, 0644) for O_RDONLY, O_WRONLY (an existing file, to sync it) or
/// O_WRONLY | O_CREAT | O_TRUNC (a new file).
int tsk_open(const char* path, int flags);
/// fsync(fd): the file's data is on the disk when it returns 0.
int tsk_fsync(int fd);
/// rename(from, to), replacing a file at `to` atomically: a reader sees the old file or the
/// new one, never none.
int tsk_rename_over(const char* from, const char* to);
/// unlink(path).
int tsk_unlink(const char* path);
/// 1 if anything is at `path` (stat succeeds; it never waits on a FIFO).
int tsk_path_exists(const char* path);
/// The size in bytes of an open file (fstat); 0 on success, -1 otherwise.
int tsk_file_size(FILE* f, uint64_t* size);
/// fseek(f, offset, SEEK_SET), for offsets past 2 GiB too.
int tsk_fseek_set(FILE* f, uint64_t offset);
/// Bytes free to this process in the folder `dir` (statvfs); 0 on success, -1 otherwise.
int tsk_free_bytes(const char* dir, uint64_t* bytes);
/// The process id (getpid), for names of temporary files.
long tsk_process_id(void);
/// The last folder separator of `path` ('/'; on Windows '/' or '\\'), or NULL.
const char* tsk_last_separator(const char* path);

#ifdef _WIN32
#include <wchar.h>
/// `path` as a wide string in a new malloc'd buffer (caller frees), or NULL with errno set
/// (EILSEQ: not UTF-8).
wchar_t* tsk_utf8_to_wide(const char* path);
/// Sets errno from a Windows error code (GetLastError) and returns it.
int tsk_errno_from_windows(unsigned long error);
#endif

#endif
