/* Counter-based random numbers: a value is a pure function of (seed, indices), so the
 * same blade gets the same number whatever thread, order or process computes it. */
#include "tussock/core.h"

/* SplitMix64 finaliser (Steele, Lea, Flood 2014): a bijective 64-bit mixer. */
static inline uint64_t mix64(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

uint64_t tsk_hash4(uint64_t seed, uint64_t a, uint64_t b, uint64_t c) {
    uint64_t h = mix64(seed ^ 0x9E3779B97F4A7C15ull);
    h = mix64(h + a);
    h = mix64(h + b + 0x632BE59BD9B4E019ull);
    h = mix64(h + c + 0x8CB92BA72F3D8DD7ull);
    return h;
}

float tsk_rand01(uint64_t seed, uint64_t a, uint64_t b, uint64_t c) {
    /* top 24 bits: exactly representable in a float, result in [0, 1) */
    return (float)(tsk_hash4(seed, a, b, c) >> 40) * (1.0f / 16777216.0f);
}

typedef struct fill_ctx {
    uint64_t seed, stream;
    float* out;
} fill_ctx;

static void fill_range(size_t begin, size_t end, size_t chunk, void* vctx) {
    (void)chunk;
    fill_ctx* ctx = vctx;
    for (size_t i = begin; i < end; ++i) ctx->out[i] = tsk_rand01(ctx->seed, ctx->stream, i, 0);
}

tsk_status tsk_rand_fill(uint64_t seed, uint64_t stream, float* out, size_t count) {
    if (out == NULL && count > 0) return tsk_error_arg(TSK_ERR_ARGUMENT, "out", "is NULL");
    fill_ctx ctx = {seed, stream, out};
    tsk_parallel_for(count, 4096, fill_range, &ctx);
    return TSK_OK;
}
