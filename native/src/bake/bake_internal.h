/* Private helpers of the bake module. */
#ifndef TSK_BAKE_INTERNAL_H
#define TSK_BAKE_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "tussock/core.h"

/* Writes the concatenated parts to `path` atomically (temporary file, fsync, rename). */
tsk_status tsk_bake_write_parts(const char* path, const void* const* parts, const size_t* sizes,
                                int part_count);

/* Little-endian fields of the cache headers, whatever the machine's byte order. */
static inline void put_u32(unsigned char* p, uint32_t v) {
    for (int i = 0; i < 4; ++i) p[i] = (unsigned char)(v >> (8 * i));
}
static inline void put_u64(unsigned char* p, uint64_t v) {
    for (int i = 0; i < 8; ++i) p[i] = (unsigned char)(v >> (8 * i));
}
static inline uint32_t get_u32(const unsigned char* p) {
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= (uint32_t)p[i] << (8 * i);
    return v;
}
static inline uint64_t get_u64(const unsigned char* p) {
    uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v |= (uint64_t)p[i] << (8 * i);
    return v;
}

#endif
