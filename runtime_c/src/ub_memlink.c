#include "ub/ub_memlink.h"

#include <stdbool.h>
#include <string.h>

#include "ub/ub_node.h"
#include "ub_rng_private.h"

#define PPM 1000000u
#define DEFAULT_REORDER_DELAY_MS 5u

static uint64_t next_random(ub_memlink_t *ml) { return ub_rng_next(&ml->rng); }

static uint32_t random_below(ub_memlink_t *ml, uint32_t bound) {
    return bound == 0 ? 0 : (uint32_t)((next_random(ml) >> 32) % bound);
}

static bool happens(ub_memlink_t *ml, uint32_t ppm) { return ppm != 0 && random_below(ml, PPM) < ppm; }

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
    }
}

void ub_memlink_set_faults(ub_memlink_t *ml, const ub_memlink_faults_t *faults) {
    memset(&ml->faults, 0, sizeof ml->faults);
    if (faults != NULL) ml->faults = *faults;
}

/* Queues one copy; false when the queue is full. */
static bool enqueue(ub_memlink_end_t *end, const uint8_t *frame, size_t len, uint64_t now_ms, bool corrupt) {
    ub_memlink_t *ml = end->ml;
    if (end->count >= UB_MEMLINK_DEPTH) {
        end->stats.overflow++;
        return false;
    }
    ub_memlink_frame_t *slot = &end->queue[end->count++];
    memcpy(slot->bytes, frame, len);
    slot->len = len;
    slot->order = ml->next_order++;
    slot->due_ms = now_ms + ml->faults.delay_ms + random_below(ml, ml->faults.jitter_ms + 1u);
    if (happens(ml, ml->faults.reorder_ppm)) {
        end->stats.reordered++;
        slot->due_ms += ml->faults.reorder_delay_ms != 0 ? ml->faults.reorder_delay_ms : DEFAULT_REORDER_DELAY_MS;
    }
    if (corrupt && len > 0) {
        end->stats.corrupted++;
        uint32_t bit = random_below(ml, (uint32_t)(len * 8u));
        slot->bytes[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
    }
    return true;
}

static int memlink_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    ub_memlink_end_t *end = impl;
    ub_memlink_t *ml = end->ml;
    if (len > UB_FRAME_MAX) return UB_ERR_RANGE;
    end->stats.sent++;
    if (happens(ml, ml->faults.loss_ppm)) {
        end->stats.lost++;
        return UB_OK; /* the wire ate it; the sender cannot know */
    }
    if (!enqueue(end, frame, len, now_ms, happens(ml, ml->faults.corrupt_ppm))) return UB_ERR_AGAIN;
    if (happens(ml, ml->faults.duplicate_ppm) && enqueue(end, frame, len, now_ms, false)) end->stats.duplicated++;
    return UB_OK;
}

static int memlink_fileno(void *impl) {
    (void)impl;
    return -1;
}

const ub_link_ops_t ub_memlink_ops = {.kind = "mem", .send = memlink_send, .fileno = memlink_fileno};

int ub_memlink_connect(ub_memlink_t *ml, ub_node_t *a, int link_a, ub_node_t *b, int link_b) {
    int rc = ub_node_link_attach(a, link_a, &ub_memlink_ops, &ml->end[0]);
    if (rc < 0) return rc;
    rc = ub_node_link_attach(b, link_b, &ub_memlink_ops, &ml->end[1]);
    if (rc < 0) return rc;
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
        end->count = 0;
        end->node = NULL;
        end->link_id = -1;
    }
}

/* Earliest due frame (ties: send order) queued before `order_limit`; false if none is due. */
static bool earliest_due(const ub_memlink_t *ml, uint64_t now_ms, uint64_t order_limit, int *side, size_t *index) {
    bool found = false;
    const ub_memlink_frame_t *best = NULL;
    for (int s = 0; s < 2; s++) {
        for (size_t i = 0; i < ml->end[s].count; i++) {
            const ub_memlink_frame_t *f = &ml->end[s].queue[i];
            if (f->due_ms > now_ms || f->order >= order_limit) continue;
            if (best == NULL || f->due_ms < best->due_ms || (f->due_ms == best->due_ms && f->order < best->order)) {
                best = f;
                *side = s;
                *index = i;
                found = true;
            }
        }
    }
    return found;
}

size_t ub_memlink_pump(ub_memlink_t *ml, uint64_t now_ms) {
    uint64_t order_limit = ml->next_order;
    size_t delivered = 0;
    int side;
    size_t index;
    uint8_t frame[UB_FRAME_MAX];
    while (earliest_due(ml, now_ms, order_limit, &side, &index)) {
        ub_memlink_end_t *from = &ml->end[side];
        ub_memlink_end_t *to = &ml->end[1 - side];
        size_t len = from->queue[index].len;
        /* Copy out and free the slot first: delivery may queue replies into this very queue. */
        memcpy(frame, from->queue[index].bytes, len);
        /* Fill the hole with the last slot, copying only its used bytes (a slot is UB_FRAME_MAX long;
         * copying whole slots was a fifth of all instructions in the 3-hop bench). */
        ub_memlink_frame_t *hole = &from->queue[index];
        const ub_memlink_frame_t *last = &from->queue[from->count - 1];
        if (hole != last) {
            hole->due_ms = last->due_ms;
            hole->order = last->order;
            hole->len = last->len;
            memcpy(hole->bytes, last->bytes, last->len);
        }
        from->count--;
        from->stats.delivered++;
        delivered++;
        if (to->node == NULL) continue;
        if (ub_node_rx_frame(to->node, to->link_id, frame, len, now_ms) < 0) from->stats.rejected++;
    }
    return delivered;
}

size_t ub_memlink_pending(const ub_memlink_t *ml) { return ml->end[0].count + ml->end[1].count; }

const ub_memlink_stats_t *ub_memlink_stats(const ub_memlink_t *ml, int side) {
    if (ml == NULL || side < 0 || side > 1) return NULL;
    return &ml->end[side].stats;
}
