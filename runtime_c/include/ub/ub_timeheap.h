/**
 * @file ub_timeheap.h
 * @brief An indexed min-heap of deadlines, one per item 0..UB_TIMEHEAP_CAP-1, in caller-owned memory.
 *
 * For services that keep a deadline per table row (the routing service: one per entity, the earliest of
 * its route expiries, retraction end, starvation retry and feasibility-distance collection) and must say
 * when the next one comes (ub_service.h `next_due`) and which have come, without scanning every row on
 * every tick: setting an item's deadline costs O(log n), the earliest is read in O(1), and the k items
 * due by a time are listed in O(k) (a walk of the heap that stops below every later deadline).
 *
 *     ub_timeheap_t h;
 *     ub_timeheap_init(&h);
 *     ub_timeheap_set(&h, 7, 1500);            // item 7 due at 1500
 *     ub_timeheap_set(&h, 7, UB_TIMEHEAP_NONE); // no deadline any more
 *     uint64_t next = ub_timeheap_min(&h);     // UB_TIMEHEAP_NONE when empty
 */
#ifndef UB_TIMEHEAP_H
#define UB_TIMEHEAP_H

#include <stddef.h>
#include <stdint.h>

#include "ub_config.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Items per heap: one per entity-table row. */
#define UB_TIMEHEAP_CAP UB_MAX_ENTITIES
/** "No deadline": an item set to it leaves the heap; the minimum of an empty heap. */
#define UB_TIMEHEAP_NONE UINT64_MAX

#if UB_TIMEHEAP_CAP > 65535
#error "ub_timeheap indexes items in uint16_t: UB_MAX_ENTITIES must stay <= 65535"
#endif

typedef struct ub_timeheap {
    uint16_t n;                        /* items in the heap */
    uint16_t at[UB_TIMEHEAP_CAP];      /* heap order: at[0] is the earliest */
    uint16_t pos[UB_TIMEHEAP_CAP];     /* item -> index in `at` + 1; 0: not in the heap */
    uint64_t due[UB_TIMEHEAP_CAP];     /* item -> its deadline (UB_TIMEHEAP_NONE when absent) */
} ub_timeheap_t;

/** Empties `h`. */
void ub_timeheap_init(ub_timeheap_t *h);

/** Sets item `item`'s deadline to `due_ms` (UB_TIMEHEAP_NONE: removes it). An item >= UB_TIMEHEAP_CAP is ignored. */
void ub_timeheap_set(ub_timeheap_t *h, unsigned item, uint64_t due_ms);

/** Item `item`'s deadline, UB_TIMEHEAP_NONE if it has none. */
uint64_t ub_timeheap_get(const ub_timeheap_t *h, unsigned item);

/** The earliest deadline, UB_TIMEHEAP_NONE when the heap is empty. */
static inline uint64_t ub_timeheap_min(const ub_timeheap_t *h) { return h->n == 0 ? UB_TIMEHEAP_NONE : h->due[h->at[0]]; }

/**
 * Writes the items whose deadline is <= now_ms into out[] in ascending item order and returns how many
 * (at most `cap`: the earliest-found beyond it are left out, so a caller with cap < UB_TIMEHEAP_CAP loops).
 * The heap is not changed: the caller sets each item's next deadline after acting on it.
 */
size_t ub_timeheap_due(const ub_timeheap_t *h, uint64_t now_ms, uint16_t *out, size_t cap);

#ifdef __cplusplus
}
#endif

#endif
