/**
 * @file ub_rxring.h
 * @brief Batched delivery: a ring of delivered DATA records in caller-owned memory, filled from the
 *        node's delivery hook and drained by one call; and ub_send_many(), one call for N publications.
 *
 * For bindings whose per-call overhead dwarfs the router's work (Python through cffi: ~1 us per
 * callback against ~0.1 us of C per frame). Instead of a callback per delivery, the node's delivery
 * hook (ub_node_set_deliver_hook(), installed by ub_rxring_attach()) appends one fixed-size record per
 * delivery: its header fields and a copy of the bound storage's wire image, taken at delivery time
 * (a later delivery of the same instance overwrites the storage). The binding drains every record
 * with ub_rxring_drain() once per loop turn.
 *
 * Nothing is lost silently. When the ring is full, a delivery goes to the `spill` hook given at
 * attach (the binding's per-delivery path), counted in `spilled`; without one it is dropped, counted
 * in `dropped`. Once a delivery spilled, every later one spills too until the ring is drained
 * (ub_rxring_drain() clears the state), so ring records then spilled ones are one ordered stream.
 *
 * Record layout (host byte order, `stride` bytes apart, stride = UB_RXREC_HEADER + image capacity
 * rounded up to 8):
 *
 *     offset  0  uint64_t t_ms        the node's now at delivery
 *             8  uint32_t instance    catalogue instance index
 *            12  uint32_t seq         the frame's sequence number
 *            16  int32_t  entity      local entity index that received it
 *            20  uint16_t len         image bytes that follow the header (the type's packed_size)
 *            22  uint8_t  hop_limit   on arrival
 *            23  uint8_t  reserved    0
 *            24  uint8_t  src_id[12]
 *            36  uint8_t  dest_id[12]
 *            48  image: the wire image (storage copied as is when the type has no unpack, i.e. the
 *                storage is the wire image; else the type's pack() of the C storage)
 *
 * Usage (no allocation: the caller owns the record memory):
 *
 *     static uint8_t mem[256 * (UB_RXREC_HEADER + 128)];
 *     ub_rxring_t ring;
 *     ub_rxring_init(&ring, mem, sizeof mem, UB_RXREC_HEADER + 128);
 *     ub_rxring_attach(&ring, &node, NULL, NULL);
 *     ... ub_memlink_pump() / ub_udp_service() ...
 *     size_t n = ub_rxring_drain(&ring, out, out_cap);   // n records, oldest first, `ring.stride` apart
 */
#ifndef UB_RXRING_H
#define UB_RXRING_H

#include <stddef.h>
#include <stdint.h>
#include "ub_error.h"
#include "ub_node.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Bytes of a record before its image. */
#define UB_RXREC_HEADER 48u

typedef struct ub_rxring_counters {
    uint64_t recorded; /**< deliveries written to the ring */
    uint64_t drained;  /**< records handed out by ub_rxring_drain() */
    uint64_t spilled;  /**< deliveries handed to the spill hook: the ring was full */
    uint64_t dropped;  /**< deliveries lost: ring full and no spill hook, or an image larger than a record */
    uint64_t high_water; /**< most records held at once */
} ub_rxring_counters_t;

typedef struct ub_rxring {
    uint8_t *mem;          /**< caller-owned: capacity * stride bytes */
    size_t capacity;       /**< records */
    size_t stride;         /**< bytes per record (UB_RXREC_HEADER + image capacity) */
    size_t head, count;    /**< oldest record's slot; records held */
    int spilling;          /**< a delivery spilled since the last drain: later ones spill too (order) */
    ub_node_t *node;       /**< attached node, or NULL */
    ub_deliver_fn spill;   /**< per-delivery hook while the ring is full, or NULL */
    void *spill_user;
    ub_rxring_counters_t counters;
} ub_rxring_t;

/**
 * Sets a ring over `mem` (`mem_len` bytes, caller-owned, outliving the ring) with records of `stride`
 * bytes: capacity = mem_len / stride.
 * @return 0; UB_ERR_INVAL (NULL, stride not a multiple of 8 or <= UB_RXREC_HEADER, or room for no record).
 */
UB_CHECK int ub_rxring_init(ub_rxring_t *ring, uint8_t *mem, size_t mem_len, size_t stride);

/**
 * Installs the ring as `node`'s delivery hook (replacing any other). `spill` (may be NULL) receives the
 * deliveries that find the ring full, with `spill_user`. ub_rxring_detach() (or another
 * ub_node_set_deliver_hook()) removes it.
 * @return 0; UB_ERR_INVAL (NULL ring or node).
 */
UB_CHECK int ub_rxring_attach(ub_rxring_t *ring, ub_node_t *node, ub_deliver_fn spill, void *spill_user);

/** Removes the ring's hook from its node (records stay until drained). */
void ub_rxring_detach(ub_rxring_t *ring);

/** The delivery hook itself (`user` = the ring), for callers that chain hooks. */
void ub_rxring_deliver(void *user, int entity, uint32_t instance, const ub_frame_header_t *h, uint64_t now_ms);

/**
 * Moves up to `max` records, oldest first, into `out` (at least max * stride bytes), contiguous,
 * `stride` apart, and ends a spill (see above) once the ring is empty.
 * @return records moved (0..max).
 */
size_t ub_rxring_drain(ub_rxring_t *ring, uint8_t *out, size_t max);

/** @return records waiting in the ring. */
size_t ub_rxring_pending(const ub_rxring_t *ring);

/** @return the ring's counters. */
ub_rxring_counters_t ub_rxring_get_counters(const ub_rxring_t *ring);

/**
 * One publication sent `n` times from one call (a binding's send_many()): before send i, the `size`
 * bytes at `values + i * size` are written at byte `offset` of the storage bound to `instance`, then
 * ub_node_send_data() originates it. With offset 0 and size = the storage size each value is a whole
 * image; with a field's offset and size it is one field's column (e.g. timestamps).
 * @return the sum of ub_node_send_data()'s results (links that accepted each frame), or its first
 *         negative error (frames before it were sent); UB_ERR_INVAL (NULL, nothing bound,
 *         `offset + size` beyond the type's storage), UB_ERR_NOTFOUND (instance).
 */
UB_CHECK long ub_send_many(ub_node_t *node, int entity, uint32_t instance, const uint8_t dest_id[UB_ENTITY_ID_LEN],
                           uint64_t now_ms, size_t offset, size_t size, const uint8_t *values, size_t n);

#ifdef __cplusplus
}
#endif

#endif /* UB_RXRING_H */
