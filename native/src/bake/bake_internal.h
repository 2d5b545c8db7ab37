/* Private helpers of the bake module. */
#ifndef TSK_BAKE_INTERNAL_H
#define TSK_BAKE_INTERNAL_H

#include <stddef.h>

#include "tussock/core.h"

/* Writes the concatenated parts to `path` atomically (temporary file, fsync, rename). */
tsk_status tsk_bake_write_parts(const char* path, const void* const* parts, const size_t* sizes,
                                int part_count);

#endif
