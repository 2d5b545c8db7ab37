/* Allocation hooks with 64-byte alignment (for vector loads) and a live-bytes counter,
 * so tests can check that released state really returns its memory. */
#include "tussock/core.h"

#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

enum { TSK_ALIGN = 64 };

/* Header stored just before the aligned block. */
typedef struct block_header {
    void* base;
    size_t size;
} block_header;

static void* default_alloc(size_t size, void* user) {
    (void)user;
    return malloc(size);
}
static void default_free(void* ptr, void* user) {
    (void)user;
    free(ptr);
}

static tsk_alloc_fn* g_alloc = default_alloc;
static tsk_free_fn* g_free = default_free;
static void* g_user = NULL;
static atomic_size_t g_live_bytes;

void tsk_set_allocator(tsk_alloc_fn* alloc, tsk_free_fn* free_fn, void* user) {
    if (alloc == NULL || free_fn == NULL) {
        g_alloc = default_alloc;
        g_free = default_free;
        g_user = NULL;
        return;
    }
    g_alloc = alloc;
    g_free = free_fn;
    g_user = user;
}

void* tsk_alloc(size_t size, const char* what) {
    const size_t extra = TSK_ALIGN + sizeof(block_header);
    if (size > SIZE_MAX - extra) {
        tsk_error(TSK_ERR_MEMORY, "cannot allocate %zu bytes for %s", size, what ? what : "data");
        return NULL;
    }
    void* base = g_alloc(size + extra, g_user);
    if (base == NULL) {
        tsk_error(TSK_ERR_MEMORY, "out of memory allocating %zu bytes for %s", size,
                  what ? what : "data");
        return NULL;
    }
    uintptr_t start = (uintptr_t)base + sizeof(block_header);
    uintptr_t aligned = (start + (TSK_ALIGN - 1)) & ~(uintptr_t)(TSK_ALIGN - 1);
    block_header* h = (block_header*)(aligned - sizeof(block_header));
    h->base = base;
    h->size = size;
    atomic_fetch_add(&g_live_bytes, size);
    return (void*)aligned;
}

void* tsk_calloc(size_t count, size_t size, const char* what) {
    if (size != 0 && count > SIZE_MAX / size) {
        tsk_error(TSK_ERR_MEMORY, "cannot allocate %zu x %zu bytes for %s", count, size,
                  what ? what : "data");
        return NULL;
    }
    void* p = tsk_alloc(count * size, what);
    if (p != NULL) memset(p, 0, count * size);
    return p;
}

void tsk_free(void* ptr) {
    if (ptr == NULL) return;
    block_header* h = (block_header*)((uintptr_t)ptr - sizeof(block_header));
    atomic_fetch_sub(&g_live_bytes, h->size);
    g_free(h->base, g_user);
}

size_t tsk_allocated_bytes(void) { return atomic_load(&g_live_bytes); }
