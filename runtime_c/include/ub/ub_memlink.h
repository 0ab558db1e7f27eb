/**
 * @file ub_memlink.h
 * @brief In-memory link pair: one executable hosting several nodes (the
 *        paper's default simulation), with optional seeded fault injection.
 *
 * A ub_memlink_t joins two link slots (of the same node or of two nodes).
 * Each end queues what its node sends (up to UB_MEMLINK_DEPTH frames, each
 * held with a deliver-at time); ub_memlink_pump(ml, now_ms) hands every frame
 * that is due to the node at the other end with ub_node_rx_frame(), oldest
 * due time first (ties in send order). Nothing happens between pumps, so a
 * simulation controls time completely. A full queue refuses the frame with
 * UB_ERR_AGAIN, which the node counts as `backpressure`; the memlink counts it
 * as `overflow` too. Nothing is dropped silently.
 *
 * Faults, decided per frame by the memlink's own PRNG (xorshift64*, seeded at
 * init, state in the struct, so runs are reproducible and independent):
 *  - loss (`loss_ppm`): not queued, counted `lost`;
 *  - duplication (`duplicate_ppm`): queued twice, each copy with its own delay;
 *  - reordering (`reorder_ppm`): held `reorder_delay_ms` longer, so later frames overtake it;
 *  - delay: every frame waits `delay_ms` plus a uniform 0..`jitter_ms`;
 *  - corruption (`corrupt_ppm`): one random bit of the queued copy is flipped.
 * Probabilities are in parts per million (300000 = 30 %).
 *
 * Usage:
 *
 *     static ub_memlink_t ml;   // large (2 * UB_MEMLINK_DEPTH frames): not on a small stack
 *     ub_memlink_init(&ml, &faults, 42);
 *     ub_memlink_connect(&ml, &gcs, gcs_link, &uav, uav_link);
 *     for (t = 0; ; t += 1) { ub_node_tick(&gcs, t); ub_node_tick(&uav, t); ub_memlink_pump(&ml, t); }
 */
#ifndef UB_MEMLINK_H
#define UB_MEMLINK_H

#include <stddef.h>
#include <stdint.h>
#include "ub_config.h"
#include "ub_error.h"
#include "ub_frame.h"
#include "ub_link.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Frames each direction of a memlink can hold. */
#ifndef UB_MEMLINK_DEPTH
#define UB_MEMLINK_DEPTH 64
#endif

typedef struct ub_node ub_node_t;

/** Fault injection settings; all zero = a perfect, instantaneous link. */
typedef struct ub_memlink_faults {
    uint32_t loss_ppm;
    uint32_t duplicate_ppm;
    uint32_t reorder_ppm;
    uint32_t corrupt_ppm;
    uint32_t delay_ms;
    uint32_t jitter_ms;
    uint32_t reorder_delay_ms; /**< extra hold of a reordered frame; default (0) = 5 ms */
} ub_memlink_faults_t;

/** Counters of one direction (frames sent by one end). */
typedef struct ub_memlink_stats {
    uint64_t sent;        /**< frames the node handed to this end */
    uint64_t delivered;   /**< frames handed to the other node */
    uint64_t lost;
    uint64_t duplicated;
    uint64_t reordered;
    uint64_t corrupted;
    uint64_t overflow;    /**< frames (or duplicate copies) refused: queue full */
    uint64_t rejected;    /**< delivered frames the other node refused as invalid (corruption) */
} ub_memlink_stats_t;

typedef struct ub_memlink_frame {
    uint64_t due_ms;
    uint64_t order;
    size_t len;
    uint8_t bytes[UB_FRAME_MAX];
} ub_memlink_frame_t;

struct ub_memlink;

#if UB_MEMLINK_DEPTH < 1 || UB_MEMLINK_DEPTH > 65535
#error "UB_MEMLINK_DEPTH must be 1..65535"
#endif

/**
 * One end: the slot it serves and the queue of frames sent from it. Private. Frames sit in `queue[]`
 * slots; `ring` lists the queued slots in send order, so a link without delay, jitter or reordering
 * delivers from the head without searching, and a frame is handed to the node from its slot without
 * being copied out (the slot is freed after the delivery, which may queue replies on the same link).
 */
typedef struct ub_memlink_end {
    struct ub_memlink *ml;
    int side;
    ub_node_t *node;
    int link_id;
    ub_memlink_frame_t queue[UB_MEMLINK_DEPTH];
    uint16_t ring[UB_MEMLINK_DEPTH];       /**< queued slots in send order, from `head` */
    uint16_t free_slots[UB_MEMLINK_DEPTH]; /**< a stack of the free slots */
    size_t head;
    size_t count;                          /**< frames queued */
    size_t n_free;
    uint8_t unordered;                     /**< a queued frame is due before one queued ahead of it */
    uint32_t resets;                       /**< queue emptied by a disconnect (a slot out for delivery is not given back) */
    ub_memlink_stats_t stats;
} ub_memlink_end_t;

typedef struct ub_memlink {
    ub_memlink_end_t end[2];
    ub_memlink_faults_t faults;
    uint64_t rng;
    uint64_t next_order;
} ub_memlink_t;

/** The transport vtable of memlink ends (kind "mem"). */
extern const ub_link_ops_t ub_memlink_ops;

/**
 * Initialises an unconnected memlink. `faults` may be NULL (none); `seed`
 * selects the fault sequence (any value, 0 included).
 */
void ub_memlink_init(ub_memlink_t *ml, const ub_memlink_faults_t *faults, uint64_t seed);

/** Replaces the fault settings (the PRNG continues). */
void ub_memlink_set_faults(ub_memlink_t *ml, const ub_memlink_faults_t *faults);

/**
 * Attaches end 0 to (`a`, `link_a`) and end 1 to (`b`, `link_b`) with
 * ub_node_link_attach(). `a` and `b` may be the same node (two of its
 * entities joined by a real link).
 * @return UB_OK or the error of ub_node_link_attach(); then neither end is attached.
 */
UB_CHECK int ub_memlink_connect(ub_memlink_t *ml, ub_node_t *a, int link_a, ub_node_t *b, int link_b);

/**
 * Takes both ends off their nodes (ub_node_link_detach(), when the slot still
 * holds this memlink) and drops the frames queued in both directions (counted
 * as lost). Afterwards the slots can be removed (ub_node_remove_link()) or
 * connected elsewhere; pumping a disconnected memlink does nothing.
 */
void ub_memlink_disconnect(ub_memlink_t *ml);

/**
 * Delivers every frame due at `now_ms` that was queued before this call
 * (frames queued while pumping wait for the next pump, which bounds the work).
 * @return the number of frames delivered.
 */
size_t ub_memlink_pump(ub_memlink_t *ml, uint64_t now_ms);

/** @return frames queued in both directions. */
size_t ub_memlink_pending(const ub_memlink_t *ml);

/** @return the counters of frames sent from end `side` (0 or 1), or NULL. */
const ub_memlink_stats_t *ub_memlink_stats(const ub_memlink_t *ml, int side);

#ifdef __cplusplus
}
#endif
#endif /* UB_MEMLINK_H */
