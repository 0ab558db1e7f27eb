/**
 * @file ub_random.h
 * @brief Where the runtime's unpredictable numbers come from: a caller-supplied
 *        function, so the core never touches an operating system.
 *
 * The node draws request ids of its publish/subscribe and administration rows
 * from `ub_node_options_t.random` (docs/pubsub.md, "Replies bound to their
 * row"): an attacker who cannot read the traffic cannot guess the id of a row
 * and forge its ACK, NACK or STOP.
 *
 *  - Hosted programs pass ub_random_os (below, POSIX: getrandom(2), else
 *    /dev/urandom). uavbus_node and the Python Node do.
 *  - Left NULL, the node uses its own seeded generator (xorshift64*, seed
 *    `ub_node_options_t.random_seed`): deterministic, for tests and
 *    simulations, and **guessable** by anyone who knows the seed.
 *  - A bare-metal port passes its hardware RNG (or, with libsodium,
 *    a wrapper of randombytes_buf()).
 */
#ifndef UB_RANDOM_H
#define UB_RANDOM_H

#include <stddef.h>
#include <stdint.h>

#include "ub_error.h"

#ifdef __cplusplus
extern "C" {
#endif

/**
 * Fills `out[0, len)` with unpredictable bytes.
 * @return UB_OK, or a negative code when no randomness is available (the
 *         node then falls back to its seeded generator and counts it in
 *         ub_node_counters_t.random_failures).
 */
typedef int (*ub_random_fn)(void *user, uint8_t *out, size_t len);

/**
 * POSIX implementation of ub_random_fn: getrandom(2) where the C library has
 * it, else reads /dev/urandom. `user` is unused. Never blocks once the kernel
 * pool is initialised. Not part of the core: builds without an OS leave
 * src/drivers/ub_random_os.c out and supply their own function.
 * @return UB_OK or UB_ERR_IO.
 */
UB_CHECK int ub_random_os(void *user, uint8_t *out, size_t len);

#ifdef __cplusplus
}
#endif
#endif /* UB_RANDOM_H */
