/*
 * Private: the seeded pseudo-random generator of the fault injectors (ub_memlink.c, ub_impair.c).
 * xorshift64* (Vigna): small, fast, its whole state one uint64_t in the caller's struct (no statics),
 * so a seed replays the same faults. The state must not be 0 (a fixed point); seeding is the caller's.
 */
#ifndef UB_RNG_PRIVATE_H
#define UB_RNG_PRIVATE_H

#include <stdint.h>

static inline uint64_t ub_rng_next(uint64_t *state) {
    uint64_t x = *state;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    *state = x;
    return x * 0x2545F4914F6CDD1DULL;
}

#endif /* UB_RNG_PRIVATE_H */
