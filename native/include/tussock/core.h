/* Tussock core: status codes and the thread-local last error, allocation hooks,
 * a counter-based deterministic random generator, a thread-count-independent
 * parallel-for and the library version. Every other module builds on this header. */
#ifndef TUSSOCK_CORE_H
#define TUSSOCK_CORE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/// Status returned by every fallible function. TSK_OK is zero.
typedef enum tsk_status {
    TSK_OK = 0,
    TSK_ERR_ARGUMENT, ///< a parameter or buffer is invalid (message names it)
    TSK_ERR_IO, ///< a file or device could not be read or written
    TSK_ERR_FORMAT, ///< data was read but is not of the expected form
    TSK_ERR_MEMORY, ///< an allocation failed
    TSK_ERR_LIMIT, ///< the request exceeds a documented limit
    TSK_ERR_DEVICE, ///< a capture device failed or was lost
    TSK_ERR_CANCELLED, ///< the caller asked to stop
    TSK_ERR_INTERNAL, ///< a bug in Tussock or a library it uses
} tsk_status;

/// Short name of a status ("argument", "io", ...). Never NULL.
const char* tsk_status_name(tsk_status status);

/// Message of the last error set on the calling thread ("" if none). Valid until the
/// next call that sets an error on this thread.
const char* tsk_last_error(void);

/// Clears the calling thread's last error.
void tsk_clear_error(void);

/// Sets the calling thread's last error (printf-style) and returns `status`,
/// so that a function can `return tsk_error(TSK_ERR_IO, "...");`.
tsk_status tsk_error(tsk_status status, const char* fmt, ...)
#if defined(__MINGW32__) /* the library formats with MinGW's C99 printf, not msvcrt.dll's */
    __attribute__((format(gnu_printf, 2, 3)))
#elif defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/// Like tsk_error, with the failing argument named first: "argname: message".
tsk_status tsk_error_arg(tsk_status status, const char* arg, const char* fmt, ...)
#if defined(__MINGW32__)
    __attribute__((format(gnu_printf, 3, 4)))
#elif defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* ---- allocation ------------------------------------------------------------------- */

typedef void* tsk_alloc_fn(size_t size, void* user);
typedef void tsk_free_fn(void* ptr, void* user);

/// Replaces the allocator (both NULL restores malloc/free). Not thread-safe: call before use.
void tsk_set_allocator(tsk_alloc_fn* alloc, tsk_free_fn* free_fn, void* user);

/// Allocates `size` bytes aligned to 64 bytes. On failure returns NULL and sets the last
/// error (TSK_ERR_MEMORY) naming `what`. size 0 returns a valid unique pointer.
void* tsk_alloc(size_t size, const char* what);
/// Zero-filled tsk_alloc of count*size bytes with overflow check.
void* tsk_calloc(size_t count, size_t size, const char* what);
/// Frees memory from tsk_alloc/tsk_calloc. NULL is ignored.
void tsk_free(void* ptr);
/// Bytes currently allocated through tsk_alloc (for leak and release checks).
size_t tsk_allocated_bytes(void);

/* ---- memory budget ------------------------------------------------------------------- */
/// Fraction of physical memory that one request (a meadow, a tree mesh, a picture with its
/// layers, a capture frame, a wind grid) may plan to use. Requests whose estimate exceeds
/// it are refused with TSK_ERR_LIMIT before anything large is allocated.
#define TSK_MEMORY_FRACTION 0.5
/// Physical memory of the machine in bytes (sysconf), 0 if unknown.
uint64_t tsk_physical_memory(void);
/// The budget in bytes: the value given to tsk_set_memory_budget, else the environment
/// variable TSK_MEMORY_BUDGET_MB (MiB), else TSK_MEMORY_FRACTION of physical memory
/// (4 GiB if that is unknown).
uint64_t tsk_memory_budget(void);
/// Sets the budget in bytes for the whole process; 0 restores the default.
void tsk_set_memory_budget(uint64_t bytes);
/// TSK_OK if `bytes` (an estimate, any size, as double so that it cannot overflow) fits in
/// the budget; else TSK_ERR_LIMIT with "what: needs about N MiB, more than the memory
/// budget of M MiB". NaN is refused.
tsk_status tsk_memory_check(double bytes, const char* what);

/* ---- deterministic random numbers ---------------------------------------------------- */

/// 64-bit hash of a seed and three indices (counter-based: no state, any order, any thread).
uint64_t tsk_hash4(uint64_t seed, uint64_t a, uint64_t b, uint64_t c);
/// Uniform float in [0, 1) from the hash of (seed, a, b, c): 24 random bits.
float tsk_rand01(uint64_t seed, uint64_t a, uint64_t b, uint64_t c);

/// Fills out[i] = tsk_rand01(seed, stream, i, 0) for i in [0, count).
tsk_status tsk_rand_fill(uint64_t seed, uint64_t stream, float* out, size_t count);

/* ---- parallel-for -------------------------------------------------------------------- */

/// Body of a parallel loop: processes indices [begin, end). `chunk` is the chunk index.
typedef void tsk_range_fn(size_t begin, size_t end, size_t chunk, void* ctx);

/// Sets the number of worker threads (1..256); 0 means all cores.
tsk_status tsk_set_threads(int count);
/// Number of worker threads in use.
int tsk_get_threads(void);

/// Splits [0, count) into chunks of `grain` indices (the last may be shorter) and runs
/// `fn` on each chunk, in parallel. Chunk boundaries depend only on count and grain,
/// never on the thread count, so per-chunk partial results combined in chunk order are
/// identical for any number of threads.
void tsk_parallel_for(size_t count, size_t grain, tsk_range_fn* fn, void* ctx);

/// Number of chunks tsk_parallel_for uses for (count, grain).
size_t tsk_chunk_count(size_t count, size_t grain);

/* ---- small array math (used through the binding and by modules) ---------------------- */

/// out[i] = |xyz[3i..3i+2]| for i in [0, count). Non-finite input yields TSK_ERR_ARGUMENT.
tsk_status tsk_vec3_lengths(const float* xyz, size_t count, float* out);

/// Bounding box of `count` >= 1 points xyz (3 floats each): lo and hi per axis, on all
/// threads. Non-finite input or no points yields TSK_ERR_ARGUMENT.
tsk_status tsk_vec3_bounds(const float* xyz, size_t count, float lo[3], float hi[3]);

/// Edges of a mesh of `face_count` faces of `face_size` corners each (corner c of face f is
/// corners[f * face_size + c], a vertex in [0, vertex_count)). Writes each distinct edge once,
/// in the order of the first corner that draws it, as that corner's vertex and the next one
/// (edges: 2 per edge, room for 2 * face_count * face_size), the edge of every corner
/// (corner_edges: face_count * face_size) and *edge_count. An out-of-range vertex or a face
/// that repeats a vertex in a row gives TSK_ERR_ARGUMENT. This is what Blender derives in
/// Mesh.update() when a mesh comes without edges.
tsk_status tsk_mesh_edges(const int32_t* corners, size_t face_count, int face_size,
                          int32_t vertex_count, int32_t* edges, int32_t* corner_edges,
                          size_t* edge_count);

/* ---- version ------------------------------------------------------------------------- */

/// Library version "MAJOR.MINOR.PATCH" (from manifest.toml at build time).
const char* tsk_version(void);

#ifdef __cplusplus
}
#endif
#endif
