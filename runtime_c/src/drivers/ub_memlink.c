#include "ub/ub_memlink.h"

#include <stdbool.h>
#include <string.h>

#include "ub/ub_node.h"
#include "ub/ub_wire.h"
#include "core/ub_rng_private.h"

#define PPM 1000000u
#define DEFAULT_REORDER_DELAY_MS 5u

static uint64_t next_random(ub_memlink_t *ml) { return ub_rng_next(&ml->rng); }

static uint32_t random_below(ub_memlink_t *ml, uint32_t bound) {
    return bound == 0 ? 0 : (uint32_t)((next_random(ml) >> 32) % bound);
}

static bool happens(ub_memlink_t *ml, uint32_t ppm) { return ppm != 0 && random_below(ml, PPM) < ppm; }

/* Empties an end's queue: every slot free. */
static void reset_queue(ub_memlink_end_t *end) {
    end->resets++;
    end->head = 0;
    end->count = 0;
    end->unordered = 0;
    end->n_free = UB_MEMLINK_DEPTH;
    for (size_t i = 0; i < UB_MEMLINK_DEPTH; i++) end->free_slots[i] = (uint16_t)(UB_MEMLINK_DEPTH - 1 - i);
}

void ub_memlink_init(ub_memlink_t *ml, const ub_memlink_faults_t *faults, uint64_t seed) {
    memset(ml, 0, sizeof *ml);
    if (faults != NULL) ml->faults = *faults;
    /* xorshift must not start at 0; mixing the seed also decorrelates neighbouring seeds. */
    ml->rng = (seed ^ 0x9E3779B97F4A7C15ULL) * 0xBF58476D1CE4E5B9ULL;
    if (ml->rng == 0) ml->rng = 0x9E3779B97F4A7C15ULL;
    for (int side = 0; side < 2; side++) {
        ml->end[side].ml = ml;
        ml->end[side].side = side;
        ml->end[side].link_id = -1;
        reset_queue(&ml->end[side]);
    }
}

void ub_memlink_set_faults(ub_memlink_t *ml, const ub_memlink_faults_t *faults) {
    memset(&ml->faults, 0, sizeof ml->faults);
    if (faults != NULL) ml->faults = *faults;
}

/* Appends slot `index` (its due time set) to the end's send order; notes when it is due before the frame queued
 * ahead of it, which makes the pump search the queue instead of taking its head. */
static inline void ring_push(ub_memlink_end_t *end, uint16_t index) {
    const ub_memlink_frame_t *slot = &end->queue[index];
    if (end->count > 0 && slot->due_ms < end->queue[end->ring[(end->head + end->count - 1) % UB_MEMLINK_DEPTH]].due_ms)
        end->unordered = 1;
    end->ring[(end->head + end->count) % UB_MEMLINK_DEPTH] = index;
    end->count++;
}

/* Takes a free slot of the end's queue and copies the frame into it, in send order (`order`); NULL when the queue
 * is full (counted `overflow`). With `memo` the copy is a forward's: ub_frame_copy_hop_limit() to `hop_limit`
 * (the caller checked the length). The caller sets the due time and then ring_push()es it: a link without
 * faults takes it as is (no random draw), enqueue() adds its delay, jitter, reordering and corruption first. */
static inline ub_memlink_frame_t *slot_take(ub_memlink_end_t *end, const uint8_t *frame, size_t len,
                                            uint8_t hop_limit, ub_frame_hop_memo_t *memo, uint16_t *index) {
    if (end->n_free == 0) {
        end->stats.overflow++;
        return NULL;
    }
    *index = end->free_slots[--end->n_free];
    ub_memlink_frame_t *slot = &end->queue[*index];
    if (memo == NULL) {
        memcpy(slot->bytes, frame, len);
    } else {
        int copied = ub_frame_copy_hop_limit(slot->bytes, frame, len, hop_limit, memo);
        (void)copied; /* UB_OK: memlink_send_hop() checked the hop limit and the length */
    }
    slot->len = len;
    slot->order = end->ml->next_order++;
    return slot;
}

/* Queues one copy on a link without faults (a forward's with `memo`, as slot_take()): due now, nothing drawn
 * (enqueue() with every setting zero draws nothing either, so the random sequence is the same). */
static inline bool enqueue_plain(ub_memlink_end_t *end, const uint8_t *frame, size_t len, uint8_t hop_limit,
                                 ub_frame_hop_memo_t *memo, uint64_t now_ms) {
    uint16_t index;
    ub_memlink_frame_t *slot = slot_take(end, frame, len, hop_limit, memo, &index);
    if (slot == NULL) return false;
    slot->due_ms = now_ms;
    ring_push(end, index);
    return true;
}

/* Queues one copy; false when the queue is full. */
static bool enqueue(ub_memlink_end_t *end, const uint8_t *frame, size_t len, uint64_t now_ms, bool corrupt) {
    ub_memlink_t *ml = end->ml;
    uint16_t index;
    ub_memlink_frame_t *slot = slot_take(end, frame, len, 0, NULL, &index);
    if (slot == NULL) return false;
    slot->due_ms = now_ms + ml->faults.delay_ms + (ml->faults.jitter_ms != 0 ? random_below(ml, ml->faults.jitter_ms + 1u) : 0u);
    if (happens(ml, ml->faults.reorder_ppm)) {
        end->stats.reordered++;
        slot->due_ms += ml->faults.reorder_delay_ms != 0 ? ml->faults.reorder_delay_ms : DEFAULT_REORDER_DELAY_MS;
    }
    if (corrupt && len > 0) {
        end->stats.corrupted++;
        uint32_t bit = random_below(ml, (uint32_t)(len * 8u));
        slot->bytes[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
    }
    ring_push(end, index);
    return true;
}

static int memlink_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    ub_memlink_end_t *end = impl;
    ub_memlink_t *ml = end->ml;
    if (len > UB_FRAME_MAX) return UB_ERR_RANGE;
    end->stats.sent++;
    const ub_memlink_faults_t *fl = &ml->faults;
    /* Read at every send, not cached: tests change the settings in place between frames. */
    if ((fl->loss_ppm | fl->duplicate_ppm | fl->reorder_ppm | fl->corrupt_ppm | fl->delay_ms | fl->jitter_ms) == 0)
        return enqueue_plain(end, frame, len, 0, NULL, now_ms) ? UB_OK : UB_ERR_AGAIN;
    if (happens(ml, ml->faults.loss_ppm)) {
        end->stats.lost++;
        return UB_OK; /* the wire ate it; the sender cannot know */
    }
    if (!enqueue(end, frame, len, now_ms, happens(ml, ml->faults.corrupt_ppm))) return UB_ERR_AGAIN;
    if (happens(ml, ml->faults.duplicate_ppm) && enqueue(end, frame, len, now_ms, false)) end->stats.duplicated++;
    return UB_OK;
}

/* A forward (ub_link_ops_t.send_hop): without faults the hop limit is patched into the queue slot itself; with
 * faults into a copy that then takes send()'s path, so loss, duplicates and corruption draw as for any frame. */
static int memlink_send_hop(void *impl, const uint8_t *frame, size_t len, uint8_t hop_limit, ub_frame_hop_memo_t *memo,
                            uint64_t now_ms) {
    ub_memlink_end_t *end = impl;
    const ub_memlink_faults_t *fl = &end->ml->faults;
    if (len > UB_FRAME_MAX) return UB_ERR_RANGE;
    if ((fl->loss_ppm | fl->duplicate_ppm | fl->reorder_ppm | fl->corrupt_ppm | fl->delay_ms | fl->jitter_ms) == 0) {
        if (hop_limit == 0) return UB_ERR_RANGE;
        if (len < UB_FRAME_HEADER_LEN || len != ub_get_u16le(frame + UB_FRAME_OFF_MSG_SIZE)) return UB_ERR_INVAL;
        end->stats.sent++;
        return enqueue_plain(end, frame, len, hop_limit, memo, now_ms) ? UB_OK : UB_ERR_AGAIN;
    }
    uint8_t out[UB_FRAME_MAX];
    int rc = ub_frame_copy_hop_limit(out, frame, len, hop_limit, memo);
    return rc < 0 ? rc : memlink_send(impl, out, len, now_ms);
}

static int memlink_fileno(void *impl) {
    (void)impl;
    return -1;
}

const ub_link_ops_t ub_memlink_ops = {
    .kind = "mem", .send = memlink_send, .fileno = memlink_fileno, .send_hop = memlink_send_hop};

int ub_memlink_connect(ub_memlink_t *ml, ub_node_t *a, int link_a, ub_node_t *b, int link_b) {
    int rc = ub_node_link_attach(a, link_a, &ub_memlink_ops, &ml->end[0]);
    if (rc < 0) return rc;
    rc = ub_node_link_attach(b, link_b, &ub_memlink_ops, &ml->end[1]);
    if (rc < 0) {
        /* Half a link would queue a's frames toward nobody: a goes back to detached (dropped, counted). */
        int undone = ub_node_link_detach(a, link_a);
        (void)undone; /* it was attached just above */
        return rc;
    }
    ml->end[0].node = a;
    ml->end[0].link_id = link_a;
    ml->end[1].node = b;
    ml->end[1].link_id = link_b;
    return UB_OK;
}

void ub_memlink_disconnect(ub_memlink_t *ml) {
    if (ml == NULL) return;
    for (int s = 0; s < 2; s++) {
        ub_memlink_end_t *end = &ml->end[s];
        const ub_link_t *slot = end->node != NULL ? ub_node_link(end->node, end->link_id) : NULL;
        if (slot != NULL && slot->impl == end && ub_node_link_detach(end->node, end->link_id) != UB_OK) {
            /* cannot happen: the slot was just found */
        }
        end->stats.lost += end->count;
        reset_queue(end);
        end->node = NULL;
        end->link_id = -1;
    }
}

/* earliest_at() of an end whose frames are not due in send order: the whole queue searched. */
static __attribute__((noinline)) long earliest_unordered(const ub_memlink_end_t *end, uint64_t now_ms,
                                                         uint64_t order_limit) {
    long best = -1;
    const ub_memlink_frame_t *b = NULL;
    for (size_t p = 0; p < end->count; p++) {
        const ub_memlink_frame_t *f = &end->queue[end->ring[(end->head + p) % UB_MEMLINK_DEPTH]];
        if (f->due_ms > now_ms || f->order >= order_limit) continue;
        if (b == NULL || f->due_ms < b->due_ms || (f->due_ms == b->due_ms && f->order < b->order)) {
            b = f;
            best = (long)p;
        }
    }
    return best;
}

/* Position (in send order) of the end's earliest due frame (ties: send order) queued before `order_limit`, or
 * -1. In send order and due in that order (no delay, jitter or reordering): the head or nothing, decided
 * inline -- the pump asks both ends before every frame it delivers and once more to stop. */
static inline __attribute__((always_inline)) long earliest_at(const ub_memlink_end_t *end, uint64_t now_ms,
                                                              uint64_t order_limit) {
    if (end->unordered) return earliest_unordered(end, now_ms, order_limit);
    if (end->count == 0) return -1;
    const ub_memlink_frame_t *f = &end->queue[end->ring[end->head]];
    return f->due_ms <= now_ms && f->order < order_limit ? 0 : -1;
}

/* Takes the frame at send position `p` out of the ring; returns its slot (still owned until released). */
static uint16_t take_at(ub_memlink_end_t *end, size_t p) {
    uint16_t index = end->ring[(end->head + p) % UB_MEMLINK_DEPTH];
    if (p == 0) {
        end->head = (end->head + 1) % UB_MEMLINK_DEPTH;
    } else {
        for (size_t i = p; i + 1 < end->count; i++)
            end->ring[(end->head + i) % UB_MEMLINK_DEPTH] = end->ring[(end->head + i + 1) % UB_MEMLINK_DEPTH];
    }
    if (--end->count == 0) end->unordered = 0;
    return index;
}

/* The frame queued at send position `p` of `end`. */
static inline const ub_memlink_frame_t *queued_at(const ub_memlink_end_t *end, size_t p) {
    return &end->queue[end->ring[(end->head + p) % UB_MEMLINK_DEPTH]];
}

/* Hands the frame at send position `p` of `from` to the node at the other end, `to`. Out of the queue first, but
 * the slot stays taken while the node handles the frame in place: the delivery may queue replies (into other
 * slots) on this very link. */
static inline void deliver_at(ub_memlink_end_t *from, ub_memlink_end_t *to, long p, uint64_t now_ms) {
    uint16_t index = take_at(from, (size_t)p);
    from->stats.delivered++;
    const ub_memlink_frame_t *f = &from->queue[index];
    uint32_t resets = from->resets;
    if (to->node != NULL && ub_node_rx_frame(to->node, to->link_id, f->bytes, f->len, now_ms) < 0)
        from->stats.rejected++;
    if (from->resets == resets) from->free_slots[from->n_free++] = index; /* else: freed by the disconnect */
}

size_t ub_memlink_pump(ub_memlink_t *ml, uint64_t now_ms) {
    uint64_t order_limit = ml->next_order;
    size_t delivered = 0;
    ub_memlink_end_t *e0 = &ml->end[0], *e1 = &ml->end[1];
    /* An end with nothing queued as the pump starts has nothing to deliver in it: what deliveries queue there is
     * past order_limit. Then the other end's frames go in order without asking it before each one (a flow in
     * one direction, the common case). */
    if (e0->count == 0 || e1->count == 0) {
        ub_memlink_end_t *from = e0->count != 0 ? e0 : e1, *to = from == e0 ? e1 : e0;
        for (long p; (p = earliest_at(from, now_ms, order_limit)) >= 0; delivered++) deliver_at(from, to, p, now_ms);
        return delivered;
    }
    for (;; delivered++) {
        /* The earliest due frame of the two ends (ties: send order), by pointer rather than by side index:
         * an index into ml->end[] multiplied by the end's size at every use. */
        long p0 = earliest_at(e0, now_ms, order_limit);
        long p1 = earliest_at(e1, now_ms, order_limit);
        if (p1 < 0) {
            if (p0 < 0) break;
            deliver_at(e0, e1, p0, now_ms);
        } else if (p0 < 0) {
            deliver_at(e1, e0, p1, now_ms);
        } else {
            const ub_memlink_frame_t *a = queued_at(e0, (size_t)p0), *b = queued_at(e1, (size_t)p1);
            bool second = b->due_ms < a->due_ms || (b->due_ms == a->due_ms && b->order < a->order);
            if (second)
                deliver_at(e1, e0, p1, now_ms);
            else
                deliver_at(e0, e1, p0, now_ms);
        }
    }
    return delivered;
}

size_t ub_memlink_pending(const ub_memlink_t *ml) { return ml->end[0].count + ml->end[1].count; }

const ub_memlink_stats_t *ub_memlink_stats(const ub_memlink_t *ml, int side) {
    if (ml == NULL || side < 0 || side > 1) return NULL;
    return &ml->end[side].stats;
}
