/* Batched delivery and sending for bindings (ub_rxring.h). Uses the node's public API only: the ring is
 * an ordinary delivery hook, send_many an ordinary loop over ub_node_send_data(). */
#include "ub/ub_rxring.h"

#include <string.h>

#include "ub/ub_catalogue.h"
#include "ub/ub_node_svc.h" /* ub_node_catalogue() */

int ub_rxring_init(ub_rxring_t *ring, uint8_t *mem, size_t mem_len, size_t stride) {
    if (ring == NULL || mem == NULL || stride <= UB_RXREC_HEADER || stride % 8u != 0 || mem_len / stride == 0)
        return UB_ERR_INVAL;
    memset(ring, 0, sizeof *ring);
    ring->mem = mem;
    ring->stride = stride;
    ring->capacity = mem_len / stride;
    return 0;
}

int ub_rxring_attach(ub_rxring_t *ring, ub_node_t *node, ub_deliver_fn spill, void *spill_user) {
    if (ring == NULL || node == NULL) return UB_ERR_INVAL;
    ring->node = node;
    ring->spill = spill;
    ring->spill_user = spill_user;
    ub_node_set_deliver_hook(node, ub_rxring_deliver, ring);
    return 0;
}

void ub_rxring_detach(ub_rxring_t *ring) {
    if (ring == NULL || ring->node == NULL) return;
    ub_node_set_deliver_hook(ring->node, NULL, NULL);
    ring->node = NULL;
}

static void put_u64(uint8_t *p, uint64_t v) { memcpy(p, &v, sizeof v); } /* host order: an in-memory record */
static void put_u32(uint8_t *p, uint32_t v) { memcpy(p, &v, sizeof v); }
static void put_u16(uint8_t *p, uint16_t v) { memcpy(p, &v, sizeof v); }

/* The wire image of `instance` as bound on the node, into `out` (cap bytes). @return its length or < 0. */
static int image_of(const ub_node_t *node, uint32_t instance, uint8_t *out, size_t cap) {
    const ub_catalogue_t *cat = ub_node_catalogue(node);
    if (cat == NULL || instance >= cat->n_instances) return UB_ERR_NOTFOUND;
    const ub_type_desc_t *t = cat->instances[instance].type;
    const void *storage = ub_node_binding(node, instance);
    if (storage == NULL) return UB_ERR_NOTFOUND;
    if (t->pack != NULL) return t->pack(storage, out, cap);
    if (t->packed_size > cap) return UB_ERR_NOSPACE;
    memcpy(out, storage, t->packed_size);
    return (int)t->packed_size;
}

void ub_rxring_deliver(void *user, int entity, uint32_t instance, const ub_frame_header_t *h, uint64_t now_ms) {
    ub_rxring_t *ring = user;
    if (ring->spilling || ring->count == ring->capacity) {
        /* Full: the caller's per-delivery path keeps it (and, for order, every later one until a drain). */
        if (ring->spill != NULL) {
            ring->spilling = 1;
            ring->counters.spilled++;
            ring->spill(ring->spill_user, entity, instance, h, now_ms);
        } else {
            ring->counters.dropped++;
        }
        return;
    }
    size_t slot = ring->head + ring->count;
    if (slot >= ring->capacity) slot -= ring->capacity;
    uint8_t *r = ring->mem + slot * ring->stride;
    int len = image_of(ring->node, instance, r + UB_RXREC_HEADER, ring->stride - UB_RXREC_HEADER);
    if (len < 0) { /* an image larger than a record (stride chosen too small) or nothing bound: counted */
        ring->counters.dropped++;
        return;
    }
    put_u64(r, now_ms);
    put_u32(r + 8, instance);
    put_u32(r + 12, h->seq);
    put_u32(r + 16, (uint32_t)entity);
    put_u16(r + 20, (uint16_t)len);
    r[22] = h->hop_limit;
    r[23] = 0;
    memcpy(r + 24, h->src_id, UB_ENTITY_ID_LEN);
    memcpy(r + 36, h->dest_id, UB_ENTITY_ID_LEN);
    ring->count++;
    ring->counters.recorded++;
    if (ring->count > ring->counters.high_water) ring->counters.high_water = ring->count;
}

size_t ub_rxring_drain(ub_rxring_t *ring, uint8_t *out, size_t max) {
    if (ring == NULL || out == NULL) return 0;
    size_t n = ring->count < max ? ring->count : max;
    /* At most two runs: head to the end of the memory, then from its start. */
    size_t first = ring->capacity - ring->head;
    if (first > n) first = n;
    memcpy(out, ring->mem + ring->head * ring->stride, first * ring->stride);
    if (n > first) memcpy(out + first * ring->stride, ring->mem, (n - first) * ring->stride);
    ring->head += n;
    if (ring->head >= ring->capacity) ring->head -= ring->capacity;
    ring->count -= n;
    ring->counters.drained += n;
    if (ring->count == 0) ring->spilling = 0; /* the caller has the spilled ones after these, in order */
    return n;
}

size_t ub_rxring_pending(const ub_rxring_t *ring) { return ring == NULL ? 0 : ring->count; }

ub_rxring_counters_t ub_rxring_get_counters(const ub_rxring_t *ring) {
    ub_rxring_counters_t zero = {0};
    return ring == NULL ? zero : ring->counters;
}

long ub_send_many(ub_node_t *node, int entity, uint32_t instance, const uint8_t dest_id[UB_ENTITY_ID_LEN],
                  uint64_t now_ms, size_t offset, size_t size, const uint8_t *values, size_t n) {
    if (node == NULL || dest_id == NULL || (values == NULL && n > 0 && size > 0)) return UB_ERR_INVAL;
    const ub_catalogue_t *cat = ub_node_catalogue(node);
    if (cat == NULL || instance >= cat->n_instances) return UB_ERR_NOTFOUND;
    const ub_type_desc_t *t = cat->instances[instance].type;
    size_t storage_size = t->unpack == NULL ? t->packed_size : t->c_size;
    uint8_t *storage = ub_node_binding(node, instance);
    if (storage == NULL || offset > storage_size || size > storage_size - offset) return UB_ERR_INVAL;
    long total = 0;
    for (size_t i = 0; i < n; i++) {
        if (size > 0) memcpy(storage + offset, values + i * size, size);
        int rc = ub_node_send_data(node, entity, instance, dest_id, now_ms);
        if (rc < 0) return rc;
        total += rc;
    }
    return total;
}
