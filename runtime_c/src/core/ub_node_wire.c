/* The node's side of the wire concerns (ub_node.h, "Wire"): compact links' dictionaries and LINK_HELLO rounds,
 * and large directories in fragments (ub_frag.h). ub_compact.c and ub_frag.c hold the state machines; this
 * file only connects them to the node's send path and tables. */
#include <string.h>

#include "ub/ub_node.h"
#include "ub/ub_wire.h"
#include "core/ub_node_private.h"

/* ---- compact links ------------------------------------------------------------------------------- */

/* LINK_HELLO rounds go out when due; dictionaries follow the entity table. */
static void compact_tick(const ub_service_t *svc, ub_node_t *node, uint64_t now_ms) {
    (void)svc;
    uint64_t version = ub_node_table_version(node);
    for (int l = 0; l < UB_MAX_NODE_LINKS; l++) {
        ub_link_t *link = &node->links[l];
        if (!link->in_use || link->compact == NULL || link->ops == NULL) continue;
        ub_compact_t *c = link->compact;
        if (ub_compact_local_stale(c, version)) {
            uint8_t ids[UB_MAX_ENTITIES][UB_ENTITY_ID_LEN];
            size_t n = 0;
            for (int e = 0; e < UB_MAX_ENTITIES; e++)
                if (node->entities[e].in_use) memcpy(ids[n++], node->entities[e].id, UB_ENTITY_ID_LEN);
            ub_compact_set_local(c, (const uint8_t(*)[UB_ENTITY_ID_LEN])ids, n, version, now_ms);
        }
        uint8_t payload[UB_COMPACT_HELLO_FIXED + UB_COMPACT_PAGE * UB_ENTITY_ID_LEN];
        uint16_t len = 0;
        while (ub_compact_hello_due(c, now_ms, payload, sizeof payload, &len)) {
            int rc = ub_node_send_link_local(node, l, UB_ADMIN_LINK_HELLO, payload, len, now_ms);
            (void)rc; /* a refusal is counted on the link; the next round repeats the page */
        }
    }
}

/* Compact links pace their dictionary pages inside ub_compact_hello_due(), which keeps no readable due time:
 * a node with a compact link is polled every millisecond as before; without one, never. */
static bool compact_next_due(const ub_service_t *svc, const ub_node_t *node, uint64_t now_ms, uint64_t *due_ms) {
    (void)svc;
    for (int l = 0; l < UB_MAX_NODE_LINKS; l++) {
        const ub_link_t *link = &node->links[l];
        if (link->in_use && link->compact != NULL && link->ops != NULL) {
            *due_ms = now_ms + 1u;
            return true;
        }
    }
    return false;
}

/* A LINK_HELLO (link-local) arrived on `rx->link_id`: the peer's dictionary page. */
static bool compact_on_frame(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx,
                             const ub_frame_header_t *h, const uint8_t *payload, uint64_t now_ms, ub_drop_reason_t *drop) {
    (void)svc;
    (void)drop; /* bad_payload: a LINK_HELLO on a full-frame link, or an unusable one */
    ub_compact_t *c = node->links[rx->link_id].compact;
    /* Unsigned, anyone may send one: dictionary changes are rate-limited (ub_compact.h); a refused one is a drop. */
    return c != NULL && ub_compact_on_hello_from(c, payload, h->payload_size, now_ms, rx->secured) >= 0;
}

static const uint8_t compact_codes[] = {UB_ADMIN_LINK_HELLO};

/* Compact links' dictionaries as a service of the core (the encoding itself is frame shaping, ub_node.c). */
const ub_service_t ub_priv_compact_service = {
    .name = "compact",
    .link_local_codes = compact_codes,
    .n_link_local_codes = sizeof compact_codes,
    .order = 55,
    .on_frame = compact_on_frame,
    .tick = compact_tick,
    .next_due = compact_next_due,
};

/* ---- fragments ----------------------------------------------------------------------------------- */

static size_t min_size(size_t a, size_t b) { return a < b ? a : b; }

/* The most payload bytes one frame like `h` may carry on `link` (its MTU, its encoding, the trailer it gets). */
static size_t link_capacity(const ub_link_t *link, const ub_frame_header_t *h, bool protect) {
    size_t tl = link->encrypt ? UB_FRAME_AEAD_TRAILER_LEN : protect ? UB_FRAME_SIG_TRAILER_LEN : 0;
    if (link->mtu == 0) return UB_MAX_PAYLOAD;
    if (link->compact == NULL)
        return link->mtu > UB_FRAME_HEADER_LEN + tl ? min_size(UB_MAX_PAYLOAD, link->mtu - UB_FRAME_HEADER_LEN - tl) : 0;
    size_t base = ub_compact_wire_size(link->compact, h->dir_id, h->fingerprint, h->dest_id, h->src_id, 0, tl);
    if (base > link->mtu) return 0;
    size_t p = link->mtu - base; /* then less what stuffing adds (one byte per 254) */
    while (p > 0 && ub_compact_wire_size(link->compact, h->dir_id, h->fingerprint, h->dest_id, h->src_id, p, tl) >
                        link->mtu)
        p--;
    return min_size(p, UB_MAX_PAYLOAD);
}

static int pack_into(const ub_type_desc_t *type, const void *storage, uint8_t *out) {
    if (type->pack == NULL) { /* wire-image storage */
        memcpy(out, storage, type->packed_size);
        return (int)type->packed_size;
    }
    return type->pack(storage, out, UB_MAX_DIRECTORY);
}

static ub_frag_tx_t *free_tx(ub_frag_t *f) {
    for (size_t i = 0; i < UB_FRAG_TX_SLOTS; i++)
        if (!f->tx[i].in_use) return &f->tx[i];
    return NULL;
}

/* Sends the fragments of `t` from `t->next` on, until done or a transport pushes back (then the same fragment
 * again at the next tick). Returns the links that took the first fragment sent now, or a negative error (the
 * transfer is then given up). */
static int pump(ub_node_t *node, ub_frag_tx_t *t, uint64_t now_ms) {
    ub_frag_t *f = node->frag;
    const ub_instance_desc_t *inst = &node->cat->instances[t->instance];
    int first = -1;
    while (t->next < t->count) {
        uint8_t frame[UB_FRAME_MAX];
        int n = ub_frag_write(frame + UB_FRAME_HEADER_LEN, UB_MAX_PAYLOAD, t->transfer, t->next, t->count, t->data,
                              t->total);
        if (n < 0) break;
        ub_frame_header_t h;
        memset(&h, 0, sizeof h);
        memcpy(h.dir_id, inst->id, UB_DIR_ID_LEN);
        memcpy(h.dest_id, t->dest, UB_ENTITY_ID_LEN);
        h.admin = UB_ADMIN_FRAGMENT;
        h.payload_size = (uint16_t)n;
        h.fingerprint = inst->type->fingerprint;
        uint64_t pushed_back = node->counters.drops[UB_DROP_BACKPRESSURE];
        int rc = ub_priv_originate(node, t->slot, frame, sizeof frame, &h, -1, now_ms);
        if (rc < 0) {
            t->in_use = 0;
            f->stats.tx_abandoned++;
            return first >= 0 ? first : rc;
        }
        f->stats.tx_fragments++;
        if (first < 0) first = rc;
        if (node->counters.drops[UB_DROP_BACKPRESSURE] != pushed_back) {
            f->stats.tx_paused++; /* a queue is full: this fragment again later, where it was refused */
            return first;
        }
        t->next++;
        t->progress_ms = now_ms;
    }
    t->in_use = 0;
    return first >= 0 ? first : 0;
}

int ub_priv_frag_send(ub_node_t *node, int slot, uint32_t instance, const void *storage,
                      const uint8_t dest_id[UB_ENTITY_ID_LEN], uint64_t now_ms, bool *sent) {
    *sent = false;
    const ub_instance_desc_t *inst = &node->cat->instances[instance];
    const ub_type_desc_t *type = inst->type;
    size_t total = type->packed_size;
    ub_local_entity_t *loc = &node->locals[slot];
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memcpy(h.dir_id, inst->id, UB_DIR_ID_LEN);
    memcpy(h.dest_id, dest_id, UB_ENTITY_ID_LEN);
    memcpy(h.src_id, node->entities[loc->entity].id, UB_ENTITY_ID_LEN);
    h.admin = UB_ADMIN_DATA;
    h.fingerprint = type->fingerprint;
    int dest_row = ub_node_find_entity(node, dest_id);
    int dest_slot = dest_row >= 0 ? node->entities[dest_row].local : -1;
    ub_frag_t *f = node->frag;
    if (dest_slot >= 0) { /* another entity of this node: handed over whole, never as a frame */
        if (total <= UB_MAX_PAYLOAD) return 0;
        *sent = true;
        ub_frag_tx_t *t = f != NULL ? free_tx(f) : NULL;
        if (t == NULL) {
            ub_priv_count_drop(node, -1, UB_DROP_TOO_BIG);
            return f == NULL ? UB_ERR_RANGE : UB_ERR_AGAIN;
        }
        int packed = pack_into(type, storage, t->data);
        if (packed < 0) return packed;
        h.payload_size = (uint16_t)packed;
        return ub_priv_originate_local(node, slot, dest_slot, &h, t->data, now_ms);
    }
    uint8_t mask = dest_row >= 0 ? loc->masks[dest_row] : 0;
    if (mask == 0) {
        if (total <= UB_MAX_PAYLOAD) return 0; /* the plain path counts no_route */
        *sent = true;
        ub_priv_count_drop(node, -1, UB_DROP_NO_ROUTE);
        return UB_ERR_NOROUTE;
    }
    bool protect = node->sec != NULL && ub_sec_tx_key(node->sec) != 0;
    size_t cap = UB_MAX_PAYLOAD;
    for (unsigned i = 0; i < UB_MAX_LINKS_PER_ENTITY; i++) {
        if (!(mask & (1u << i)) || loc->link_ids[i] < 0) continue;
        cap = min_size(cap, link_capacity(&node->links[loc->link_ids[i]], &h, protect));
    }
    if (total <= cap) return 0; /* one plain frame fits every link */
    *sent = true;
    uint16_t count = 0;
    if (f == NULL || cap <= UB_FRAG_HEADER_LEN || ub_frag_plan(total, cap - UB_FRAG_HEADER_LEN, &count) != UB_OK) {
        ub_priv_count_drop(node, -1, UB_DROP_TOO_BIG);
        return UB_ERR_RANGE;
    }
    ub_frag_tx_t *t = free_tx(f);
    if (t == NULL) {
        f->stats.tx_busy++;
        return UB_ERR_AGAIN;
    }
    int packed = pack_into(type, storage, t->data);
    if (packed < 0) return packed;
    t->in_use = 1;
    t->slot = (int8_t)slot;
    memcpy(t->dest, dest_id, UB_ENTITY_ID_LEN);
    t->instance = instance;
    t->transfer = f->next_transfer++;
    t->count = count;
    t->next = 0;
    t->total = (uint16_t)packed;
    t->progress_ms = now_ms;
    f->stats.tx_transfers++;
    return pump(node, t, now_ms);
}

static void frag_on_fragment(ub_node_t *node, int slot, int link_id, const ub_frame_header_t *h,
                             const uint8_t *payload, uint64_t now_ms);

/* A FRAGMENT reached local slot `rx->slot`. Drops are counted here, by reason. */
static bool frag_on_frame(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx,
                          const ub_frame_header_t *h, const uint8_t *payload, uint64_t now_ms, ub_drop_reason_t *drop) {
    (void)svc;
    (void)drop;
    frag_on_fragment(node, rx->slot, rx->link_id, h, payload, now_ms);
    return true;
}

static void frag_on_fragment(ub_node_t *node, int slot, int link_id, const ub_frame_header_t *h,
                             const uint8_t *payload, uint64_t now_ms) {
    ub_frag_t *f = node->frag;
    if (f == NULL) {
        ub_priv_count_drop(node, link_id, UB_DROP_TOO_BIG);
        return;
    }
    /* What DATA would be refused for is refused per fragment, before anything is buffered. */
    int idx = ub_catalogue_find(node->cat, h->dir_id);
    if (idx < 0) {
        ub_priv_count_drop(node, link_id, UB_DROP_UNKNOWN_CONTENT);
        return;
    }
    if (link_id >= 0 && node->policy != NULL && !ub_priv_may_write(node, slot, (uint32_t)idx, h->src_id)) {
        ub_priv_count_drop(node, link_id, UB_DROP_NOT_ALLOWED);
        return;
    }
    const ub_type_desc_t *type = node->cat->instances[idx].type;
    ub_frag_info_t fi;
    if (ub_frag_parse(payload, h->payload_size, &fi) != UB_OK) {
        f->stats.rx_bad++;
        ub_priv_count_drop(node, link_id, UB_DROP_BAD_PAYLOAD);
        return;
    }
    if (h->fingerprint != type->fingerprint || fi.total != type->packed_size) {
        ub_priv_count_drop(node, link_id, UB_DROP_LAYOUT_MISMATCH);
        return;
    }
    if (ub_node_binding(node, (uint32_t)idx) == NULL) {
        ub_priv_count_drop(node, link_id, UB_DROP_UNBOUND);
        return;
    }
    uint64_t lost_before = f->stats.rx_evicted + f->stats.rx_restarted + f->stats.rx_source_limit;
    const uint8_t *data = NULL;
    size_t total = 0;
    int r = ub_frag_take(f, slot, h->src_id, h->dir_id, h->fingerprint, payload, h->payload_size, now_ms, &data,
                         &total);
    for (uint64_t k = lost_before; k < f->stats.rx_evicted + f->stats.rx_restarted + f->stats.rx_source_limit; k++)
        ub_priv_count_drop(node, link_id, UB_DROP_INCOMPLETE);
    if (r == UB_FRAG_DUPLICATE) {
        ub_priv_count_drop(node, link_id, UB_DROP_DUPLICATE);
    } else if (r == UB_FRAG_REFUSED) { /* this directory cannot be reassembled: it is lost incomplete */
        ub_priv_count_drop(node, link_id, UB_DROP_INCOMPLETE);
    } else if (r == UB_FRAG_COMPLETE) {
        ub_frame_header_t whole = *h;
        whole.admin = UB_ADMIN_DATA;
        whole.payload_size = (uint16_t)total;
        ub_priv_deliver_data(node, slot, link_id, &whole, data, now_ms);
    }
    /* No error to count here: ub_frag_take() fails only on a payload ub_frag_parse() refuses, refused above. */
}

/* Timeouts of reassemblies; transfers that were pushed back go on. */
static void frag_tick(const ub_service_t *svc, ub_node_t *node, uint64_t now_ms) {
    (void)svc;
    ub_frag_t *f = node->frag;
    if (f == NULL) return;
    for (size_t n = ub_frag_expire(f, now_ms); n > 0; n--) ub_priv_count_drop(node, -1, UB_DROP_INCOMPLETE);
    for (size_t i = 0; i < UB_FRAG_TX_SLOTS; i++) {
        ub_frag_tx_t *t = &f->tx[i];
        if (!t->in_use) continue;
        if (now_ms >= t->progress_ms && now_ms - t->progress_ms >= f->params.timeout_ms) {
            t->in_use = 0; /* pushed back for a whole timeout: the receiver has dropped it by now anyway */
            f->stats.tx_abandoned++;
            continue;
        }
        (void)pump(node, t, now_ms);
    }
}

/* Reassembly timeouts and senders still pumping fragments (a sender pushed back by its link retries at the next
 * millisecond, as before). */
static bool frag_next_due(const ub_service_t *svc, const ub_node_t *node, uint64_t now_ms, uint64_t *due_ms) {
    (void)svc;
    const ub_frag_t *f = node->frag;
    if (f == NULL) return false;
    uint64_t best = UINT64_MAX;
    for (size_t i = 0; i < UB_FRAG_SLOTS; i++) {
        const ub_frag_rx_t *r = &f->rx[i];
        if (!r->in_use) continue;
        uint64_t due = now_ms < r->last_ms ? now_ms : r->last_ms + f->params.timeout_ms;
        if (due < best) best = due;
    }
    for (size_t i = 0; i < UB_FRAG_TX_SLOTS; i++)
        if (f->tx[i].in_use && now_ms + 1u < best) best = now_ms + 1u;
    *due_ms = best;
    return best != UINT64_MAX;
}

static void frag_forget_entity(const ub_service_t *svc, ub_node_t *node, int entity, const uint8_t id[UB_ENTITY_ID_LEN],
                               uint64_t now_ms) {
    (void)svc;
    (void)entity;
    (void)now_ms;
    ub_frag_forget(node->frag, -1, id);
}

static const uint8_t frag_codes[] = {UB_ADMIN_FRAGMENT};

/* Reassembly as a service of the core: always registered, so a node without fragment state
 * (ub_node_set_frag()) refuses fragments `too_big` rather than as unknown admin frames. */
const ub_service_t ub_priv_frag_service = {
    .name = "fragments",
    .codes = frag_codes,
    .n_codes = sizeof frag_codes,
    .order = 60,
    .on_frame = frag_on_frame,
    .tick = frag_tick,
    .next_due = frag_next_due,
    .forget_entity = frag_forget_entity,
};
