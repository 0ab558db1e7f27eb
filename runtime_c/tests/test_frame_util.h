/* Helpers shared by the test_frame*.c programs: a seeded generator and random frames.
 * Everything is static inline and stateless; the generator state is the caller's. */
#ifndef TEST_FRAME_UTIL_H
#define TEST_FRAME_UTIL_H

#include <stdint.h>
#include <string.h>

#include "ub/ub_frame.h"

/* splitmix64: tiny, seedable, good enough to spread corruptions. */
typedef struct test_rng {
    uint64_t state;
} test_rng_t;

static inline uint64_t rng_next(test_rng_t *r) {
    uint64_t z = (r->state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* Uniform in [0, n); n > 0. The modulo bias is irrelevant at these ranges. */
static inline uint32_t rng_below(test_rng_t *r, uint32_t n) { return (uint32_t)(rng_next(r) % n); }

static inline void rng_fill(test_rng_t *r, uint8_t *p, size_t n) {
    for (size_t i = 0; i < n; i++) p[i] = (uint8_t)rng_next(r);
}

/* A random valid header with the given payload size. */
static inline ub_frame_header_t random_header(test_rng_t *r, uint16_t payload_size) {
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    rng_fill(r, h.dir_id, sizeof h.dir_id);
    rng_fill(r, h.dest_id, sizeof h.dest_id);
    rng_fill(r, h.src_id, sizeof h.src_id);
    h.admin = (uint8_t)rng_below(r, 7);
    h.hop_limit = (uint8_t)(1 + rng_below(r, 255));
    h.payload_size = payload_size;
    h.seq = (uint32_t)rng_next(r);
    h.fingerprint = (uint32_t)rng_next(r);
    return h;
}

/* Writes a random valid frame with `payload_size` random payload bytes into `out`
 * (at least 64 + payload_size bytes); returns its length. */
static inline size_t random_frame(test_rng_t *r, uint8_t *out, uint16_t payload_size) {
    ub_frame_header_t h = random_header(r, payload_size);
    rng_fill(r, out + UB_FRAME_HEADER_LEN, payload_size);
    int n = ub_frame_finish(out, UB_FRAME_MAX, &h);
    return n < 0 ? 0 : (size_t)n;
}

#endif /* TEST_FRAME_UTIL_H */
