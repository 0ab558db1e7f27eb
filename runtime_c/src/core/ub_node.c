#include "ub/ub_node.h"

#include <string.h>

#include "ub/ub_prio.h"
#include "ub/ub_wire.h"
#include "core/ub_rng_private.h"
#include "core/ub_node_private.h"

/*
 * The node core: set-up, and the frame path of every received and originated frame. It names no
 * protocol engine: admin frames go to the service registered for their code (ub_service.h, table in
 * ub_node_svc.c), ticks and forgetting are loops over the registered services.
 */

bool ub_entity_id_is_zero(const uint8_t id[UB_ENTITY_ID_LEN]) {
    for (size_t i = 0; i < UB_ENTITY_ID_LEN; i++)
        if (id[i] != 0) return false;
    return true;
}

bool ub_entity_id_is_link_local(const uint8_t id[UB_ENTITY_ID_LEN]) {
    static const uint8_t link_local[UB_ENTITY_ID_LEN] = {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF,
                                                         0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF};
    return ub_priv_id_eq(id, link_local);
}

static bool entity_index_ok(const ub_node_t *node, int entity) {
    return entity >= 0 && entity < UB_MAX_ENTITIES && node->entities[entity].in_use;
}

int ub_node_entity_slot(const ub_node_t *node, int entity) {
    if (!entity_index_ok(node, entity)) return -1;
    return node->entities[entity].local;
}

int ub_node_slot_entity(const ub_node_t *node, int slot) {
    if (slot < 0 || slot >= UB_MAX_LOCAL_ENTITIES || !node->locals[slot].in_use) return -1;
    return node->locals[slot].entity;
}

static bool link_id_ok(const ub_node_t *node, int link_id) {
    return link_id >= 0 && link_id < UB_MAX_NODE_LINKS && node->links[link_id].in_use;
}

void ub_node_svc_count_drop(ub_node_t *node, int link_id, ub_drop_reason_t reason) {
    node->counters.drops[reason]++;
    if (link_id_ok(node, link_id)) node->links[link_id].counters.drops[reason]++;
}

static void count_drop(ub_node_t *node, int link_id, ub_drop_reason_t reason) { ub_priv_count_drop(node, link_id, reason); }

/* ---- set-up ------------------------------------------------------------ */

int ub_node_core_init(ub_node_t *node, const ub_catalogue_t *cat, const ub_node_options_t *opt) {
    if (node == NULL || cat == NULL) return UB_ERR_INVAL;
    /* ub_catalogue_oversize() names the type a caller reports when this refuses. Types above
     * UB_MAX_PAYLOAD travel as fragments (ub_node_set_frag()), so the limit is UB_MAX_DIRECTORY. */
    if (cat->abi_version != UB_CATALOGUE_ABI_VERSION || cat->max_packed_size > UB_MAX_DIRECTORY ||
        ub_catalogue_oversize(cat, UB_MAX_DIRECTORY) != NULL)
        return UB_ERR_INVAL;
    memset(node, 0, sizeof *node);
    memset(node->entity_index, 0xFF, sizeof node->entity_index); /* every slot -1: empty */
    node->cat = cat;
    if (opt != NULL) node->opt = *opt;
    if (node->opt.hop_limit == 0) node->opt.hop_limit = UB_DEFAULT_HOP_LIMIT;
    node->next_seq = node->opt.first_seq != 0 ? node->opt.first_seq : 1u;
    node->rng_state = node->opt.random_seed != 0 ? node->opt.random_seed : 0x9E3779B97F4A7C15ull;
    for (size_t e = 0; e < UB_MAX_ENTITIES; e++) node->entities[e].local = -1;
    for (size_t s = 0; s < UB_MAX_LOCAL_ENTITIES; s++)
        for (size_t i = 0; i < UB_MAX_LINKS_PER_ENTITY; i++) node->locals[s].link_ids[i] = -1;
    /* The frame path's own services: freshness challenges, compact links' dictionaries, fragments. */
    int rc = ub_node_add_service(node, &ub_priv_sec_service);
    if (rc == UB_OK) rc = ub_node_add_service(node, &ub_priv_compact_service);
    if (rc == UB_OK) rc = ub_node_add_service(node, &ub_priv_frag_service);
    return rc;
}

uint32_t ub_node_seq_seed(uint64_t unix_us) {
    uint32_t seq = (uint32_t)unix_us; /* mod 2^32: the window compares by serial arithmetic */
    return seq != 0 ? seq : 1u;
}

/* ---- the entity index: ID -> row, open addressing with linear probing --------------------------------- */

static unsigned index_home(const uint8_t id[UB_ENTITY_ID_LEN]) {
    uint64_t a = 0;
    uint32_t b = 0;
    memcpy(&a, id, 8);
    memcpy(&b, id + 8, 4);
    uint64_t h = a * 0x9E3779B97F4A7C15ull ^ ((uint64_t)b + 0x632BE59BD9B4E019ull) * 0xC2B2AE3D27D4EB4Full;
    h ^= h >> 31;
    return (unsigned)(h >> (64 - UB_ENTITY_INDEX_BITS));
}

#define INDEX_MASK (UB_ENTITY_INDEX_SLOTS - 1u)

static void index_insert(ub_node_t *node, int row) {
    unsigned i = index_home(node->entities[row].id);
    while (node->entity_index[i] >= 0) i = (i + 1u) & INDEX_MASK;
    node->entity_index[i] = (int16_t)row;
}

/* Removes `row` (still holding its ID) from the index; the entries after it move back so no probe chain breaks. */
static void index_remove(ub_node_t *node, int row) {
    unsigned i = index_home(node->entities[row].id);
    while (node->entity_index[i] != row) {
        if (node->entity_index[i] < 0) return; /* not indexed (cannot happen: add indexes every row) */
        i = (i + 1u) & INDEX_MASK;
    }
    for (unsigned j = (i + 1u) & INDEX_MASK; node->entity_index[j] >= 0; j = (j + 1u) & INDEX_MASK) {
        unsigned home = index_home(node->entities[node->entity_index[j]].id);
        /* j's entry may fill the hole at i unless its home lies cyclically in (i, j]. */
        bool stays = i <= j ? (home > i && home <= j) : (home > i || home <= j);
        if (stays) continue;
        node->entity_index[i] = node->entity_index[j];
        i = j;
    }
    node->entity_index[i] = -1;
}

int ub_node_find_entity(const ub_node_t *node, const uint8_t id[UB_ENTITY_ID_LEN]) {
    if (node == NULL || id == NULL) return UB_ERR_INVAL;
    for (unsigned i = index_home(id);; i = (i + 1u) & INDEX_MASK) {
        int row = node->entity_index[i];
        if (row < 0) return UB_ERR_NOTFOUND;
        if (ub_priv_id_eq(node->entities[row].id, id)) return row;
    }
}

const uint8_t *ub_node_entity_id(const ub_node_t *node, int entity) {
    if (node == NULL || !entity_index_ok(node, entity)) return NULL;
    return node->entities[entity].id;
}

int ub_node_add_entity(ub_node_t *node, const uint8_t id[UB_ENTITY_ID_LEN], bool local) {
    if (node == NULL || id == NULL || ub_priv_id_is_zero(id) || ub_entity_id_is_link_local(id)) return UB_ERR_INVAL;
    if (ub_node_find_entity(node, id) >= 0) return UB_ERR_EXISTS;
    int row = -1;
    for (int e = 0; e < UB_MAX_ENTITIES && row < 0; e++)
        if (!node->entities[e].in_use) row = e;
    if (row < 0) return UB_ERR_FULL;
    int slot = -1;
    if (local) {
        for (int s = 0; s < UB_MAX_LOCAL_ENTITIES && slot < 0; s++)
            if (!node->locals[s].in_use) slot = s;
        if (slot < 0) return UB_ERR_FULL;
        node->locals[slot].in_use = 1;
        node->locals[slot].entity = (uint8_t)row;
    }
    memcpy(node->entities[row].id, id, UB_ENTITY_ID_LEN);
    node->entities[row].in_use = 1;
    node->entities[row].local = (int8_t)slot;
    index_insert(node, row);
    node->counters.entities_added++;
    return row;
}

int ub_node_remove_entity(ub_node_t *node, int entity, uint64_t now_ms) {
    if (node == NULL || !entity_index_ok(node, entity) || node->entities[entity].local >= 0) return UB_ERR_INVAL;
    uint8_t id[UB_ENTITY_ID_LEN];
    memcpy(id, node->entities[entity].id, UB_ENTITY_ID_LEN);
    /* The services apply their own rules (publish/subscribe, docs/pubsub.md: rows with nobody left to talk
     * to go at once, rows the entity merely administered live on under their keeper; routing; fragments). */
    for (int i = 0; i < node->n_services; i++) {
        const ub_service_t *svc = node->services[i];
        if (svc->forget_entity != NULL) svc->forget_entity(svc, node, entity, id, now_ms);
    }
    for (int slot = 0; slot < UB_MAX_LOCAL_ENTITIES; slot++) {
        ub_local_entity_t *loc = &node->locals[slot];
        if (!loc->in_use) continue;
        for (size_t i = 0; i < UB_DEDUP_SOURCES; i++) {
            ub_dedup_entry_t *d = &loc->dedup[i];
            if (!d->in_use || memcmp(d->src, id, UB_ENTITY_ID_LEN) != 0) continue;
            memset(d, 0, sizeof *d);
            node->counters.dedup_cleared++;
        }
        loc->masks[entity] = 0;
        loc->pinned[entity] = 0;
        loc->bounce[entity] = 0;
    }
    index_remove(node, entity);
    memset(&node->entities[entity], 0, sizeof node->entities[entity]);
    node->entities[entity].local = -1;
    node->counters.entities_removed++;
    return UB_OK;
}

int ub_node_add_entity_name(ub_node_t *node, const char *name, bool local) {
    uint8_t id[UB_ENTITY_ID_LEN];
    if (name == NULL) return UB_ERR_INVAL;
    int rc = ub_entity_id(name, id);
    if (rc < 0) return rc;
    return ub_node_add_entity(node, id, local);
}

int ub_node_find_link(const ub_node_t *node, const char *name) {
    if (node == NULL || name == NULL) return UB_ERR_INVAL;
    for (int l = 0; l < UB_MAX_NODE_LINKS; l++)
        if (node->links[l].in_use && strcmp(node->links[l].name, name) == 0) return l;
    return UB_ERR_NOTFOUND;
}

int ub_node_add_link(ub_node_t *node, int entity, unsigned index, const char *name) {
    if (node == NULL || name == NULL) return UB_ERR_INVAL;
    int slot = ub_node_entity_slot(node, entity);
    size_t name_len = strlen(name);
    if (slot < 0 || index >= UB_MAX_LINKS_PER_ENTITY || name_len == 0 || name_len >= UB_LINK_NAME_LEN)
        return UB_ERR_INVAL;
    if (node->locals[slot].link_ids[index] >= 0 || ub_node_find_link(node, name) >= 0) return UB_ERR_EXISTS;
    int id = -1;
    for (int l = 0; l < UB_MAX_NODE_LINKS && id < 0; l++)
        if (!node->links[l].in_use) id = l;
    if (id < 0) return UB_ERR_FULL;
    ub_link_t *link = &node->links[id];
    memset(link, 0, sizeof *link);
    memcpy(link->name, name, name_len + 1);
    link->in_use = 1;
    link->owner = (uint8_t)slot;
    link->index = (uint8_t)index;
    link->require_signed = -1; /* the node's policy */
    ub_decoder_init(&link->decoder);
    node->locals[slot].link_ids[index] = (int16_t)id;
    node->counters.links_added++;
    return id;
}

int ub_node_remove_link(ub_node_t *node, int link_id) {
    if (node == NULL || !link_id_ok(node, link_id) || node->links[link_id].ops != NULL) return UB_ERR_INVAL;
    ub_link_t *link = &node->links[link_id];
    ub_local_entity_t *loc = &node->locals[link->owner];
    uint8_t bit = (uint8_t)(1u << link->index);
    for (int d = 0; d < UB_MAX_ENTITIES; d++) {
        loc->masks[d] &= (uint8_t)~bit;
        loc->bounce[d] &= (uint8_t)~bit;
        if (loc->masks[d] == 0) loc->pinned[d] = 0;
    }
    loc->link_ids[link->index] = -1;
    for (int i = 0; i < node->n_services; i++) {
        const ub_service_t *svc = node->services[i];
        if (svc->forget_link != NULL) svc->forget_link(svc, node, link_id, 0);
    }
    if (link->mtu != 0) node->mtu_links--;
    memset(link, 0, sizeof *link);
    node->counters.links_removed++;
    return UB_OK;
}

const ub_link_t *ub_node_link(const ub_node_t *node, int link_id) {
    if (node == NULL || !link_id_ok(node, link_id)) return NULL;
    return &node->links[link_id];
}

static int write_mask(ub_node_t *node, int entity, int dest, uint8_t mask, bool manual) {
    if (node == NULL) return UB_ERR_INVAL;
    int slot = ub_node_entity_slot(node, entity);
    if (slot < 0 || !entity_index_ok(node, dest) || (dest == entity && mask != 0)) return UB_ERR_INVAL;
    for (unsigned i = 0; i < 8; i++) {
        if (!(mask & (1u << i))) continue;
        if (i >= UB_MAX_LINKS_PER_ENTITY || node->locals[slot].link_ids[i] < 0) return UB_ERR_NOTFOUND;
    }
    ub_local_entity_t *loc = &node->locals[slot];
    if (!manual && loc->pinned[dest]) return UB_ERR_EXISTS;
    loc->masks[dest] = mask;
    if (manual) {
        loc->pinned[dest] = mask != 0;
        for (int i = 0; i < node->n_services; i++) {
            const ub_service_t *svc = node->services[i];
            if (svc->mask_set != NULL) svc->mask_set(svc, node, slot);
        }
    }
    return UB_OK;
}

int ub_node_set_mask(ub_node_t *node, int entity, int dest, uint8_t mask) {
    return write_mask(node, entity, dest, mask, true);
}

int ub_node_set_auto_mask(ub_node_t *node, int entity, int dest, uint8_t mask) {
    return write_mask(node, entity, dest, mask, false);
}

int ub_node_set_bounce_mask(ub_node_t *node, int entity, int dest, uint8_t mask) {
    if (node == NULL) return UB_ERR_INVAL;
    int slot = ub_node_entity_slot(node, entity);
    if (slot < 0 || !entity_index_ok(node, dest) || (dest == entity && mask != 0)) return UB_ERR_INVAL;
    for (unsigned i = 0; i < 8; i++)
        if ((mask & (1u << i)) && (i >= UB_MAX_LINKS_PER_ENTITY || node->locals[slot].link_ids[i] < 0)) return UB_ERR_NOTFOUND;
    node->locals[slot].bounce[dest] = mask;
    return UB_OK;
}

bool ub_node_mask_pinned(const ub_node_t *node, int entity, int dest) {
    if (node == NULL) return false;
    int slot = ub_node_entity_slot(node, entity);
    if (slot < 0 || !entity_index_ok(node, dest)) return false;
    return node->locals[slot].pinned[dest] != 0;
}

int ub_node_get_mask(const ub_node_t *node, int entity, int dest, uint8_t *mask) {
    if (node == NULL || mask == NULL) return UB_ERR_INVAL;
    int slot = ub_node_entity_slot(node, entity);
    if (slot < 0 || !entity_index_ok(node, dest)) return UB_ERR_INVAL;
    *mask = node->locals[slot].masks[dest];
    return UB_OK;
}

int ub_node_link_attach(ub_node_t *node, int link_id, const ub_link_ops_t *ops, void *impl) {
    if (node == NULL || !link_id_ok(node, link_id) || ops == NULL || ops->send == NULL) return UB_ERR_INVAL;
    ub_link_t *link = &node->links[link_id];
    /* Keep the counters across the switch: they describe the port, not the transport. The bytes the
     * decoder still holds (a frame the old stream cut) are dropped here, so they are counted as garbage:
     * bytes_in == bytes_ok + garbage_bytes + pending holds across every re-attach. */
    ub_decoder_stats_t kept = link->decoder.stats;
    kept.garbage_bytes += ub_decoder_pending(&link->decoder);
    ub_decoder_init(&link->decoder);
    link->decoder.stats = kept;
    link->ops = ops;
    link->impl = impl;
    return UB_OK;
}

int ub_node_link_set_transport(ub_node_t *node, int link_id, const ub_link_ops_t *ops, void *impl) {
    if (node == NULL || !link_id_ok(node, link_id) || ops == NULL || ops->send == NULL) return UB_ERR_INVAL;
    node->links[link_id].ops = ops;
    node->links[link_id].impl = impl;
    return UB_OK;
}

int ub_node_link_detach(ub_node_t *node, int link_id) {
    if (node == NULL || !link_id_ok(node, link_id)) return UB_ERR_INVAL;
    node->links[link_id].ops = NULL;
    node->links[link_id].impl = NULL;
    return UB_OK;
}

uint64_t ub_node_link_bad_frames(const ub_node_t *node, int link_id, ub_rx_reason_t reason) {
    if (node == NULL || !link_id_ok(node, link_id) || (unsigned)reason >= UB_RX_REASON_COUNT) return 0;
    const ub_link_t *link = &node->links[link_id];
    return link->decoder.stats.rejected[reason] + link->counters.bad_datagrams[reason];
}

int ub_node_bind(ub_node_t *node, uint32_t instance, void *storage) {
    if (node == NULL || storage == NULL || instance >= node->cat->n_instances) return UB_ERR_INVAL;
    for (size_t b = 0; b < node->n_bindings; b++) {
        if (node->bindings[b].instance == instance) {
            node->bindings[b].storage = storage;
            return UB_OK;
        }
    }
    if (node->n_bindings >= UB_MAX_BINDINGS) return UB_ERR_FULL;
    node->bindings[node->n_bindings].instance = instance;
    node->bindings[node->n_bindings].storage = storage;
    node->bindings[node->n_bindings].on_update = 0;
    node->n_bindings++;
    return UB_OK;
}

int ub_node_bind_table(ub_node_t *node, void *const *table, size_t n) {
    if (node == NULL || (table != NULL && n != node->cat->n_instances)) return UB_ERR_INVAL;
    node->bind_table = table;
    int bound = 0;
    for (size_t i = 0; table != NULL && i < n; i++) bound += table[i] != NULL;
    return bound;
}

int ub_node_set_content_classes(ub_node_t *node, const uint8_t *classes, size_t n) {
    if (node == NULL) return UB_ERR_INVAL;
    if (classes == NULL) {
        node->content_class = NULL;
        return UB_OK;
    }
    if (n != node->cat->n_instances) return UB_ERR_INVAL;
    for (size_t i = 0; i < n; i++)
        if (classes[i] >= UB_PRIO_CLASSES) return UB_ERR_INVAL;
    node->content_class = classes;
    return UB_OK;
}

void *ub_node_binding(const ub_node_t *node, uint32_t instance) {
    if (node == NULL) return NULL;
    for (size_t b = 0; b < node->n_bindings; b++)
        if (node->bindings[b].instance == instance) return node->bindings[b].storage;
    if (node->bind_table != NULL && instance < node->cat->n_instances) return node->bind_table[instance];
    return NULL;
}

void ub_node_set_tap(ub_node_t *node, ub_tap_fn fn, void *user) {
    node->tap = fn;
    node->tap_user = user;
}

void ub_node_set_deliver_hook(ub_node_t *node, ub_deliver_fn fn, void *user) {
    node->deliver = fn;
    node->deliver_user = user;
}

void ub_node_set_policy(ub_node_t *node, const ub_policy_t *policy) {
    if (node != NULL) node->policy = policy;
}

const ub_node_counters_t *ub_node_counters(const ub_node_t *node) { return &node->counters; }

uint32_t ub_node_svc_new_request_id(ub_node_t *node) {
    for (;;) {
        uint8_t b[4];
        uint32_t id;
        if (node->opt.random != NULL && node->opt.random(node->opt.random_user, b, sizeof b) == UB_OK) {
            id = ub_get_u32le(b);
        } else {
            if (node->opt.random != NULL) node->counters.random_failures++;
            id = (uint32_t)(ub_rng_next(&node->rng_state) >> 32);
        }
        if (id != 0) return id; /* 0 is never a request id, so zeroed rows match nothing */
    }
}

/* ---- transmit and routing ---------------------------------------------- */

static void count_refusal(ub_node_t *node, int link_id, int rc, uint64_t now_ms) {
    /* UB_ERR_NOROUTE: the transport has nowhere to send yet (a UDP link that has not learned a peer). */
    ub_drop_reason_t why = rc == UB_ERR_AGAIN     ? UB_DROP_BACKPRESSURE
                           : rc == UB_ERR_NOROUTE ? UB_DROP_NO_ROUTE
                                                  : UB_DROP_TX_ERROR;
    count_drop(node, link_id, why);
    /* A send that failed outright (not "later") is transport evidence that the link is gone: the services hear
     * it now rather than after their own timeouts (docs/routing.md, "Transport evidence"). */
    if (why == UB_DROP_TX_ERROR) ub_node_link_event(node, link_id, UB_LINK_EVENT_DOWN, now_ms);
}

static int content_index(ub_node_t *node, const uint8_t dir_id[UB_DIR_ID_LEN]);

/* The priority class of a full frame where it leaves (ub_prio.h): from its admin code, and for DATA from its
 * content's configured class. Derived at every hop from the same configuration, never read from the wire. */
static ub_prio_class_t frame_class(ub_node_t *node, const uint8_t *frame) {
    uint8_t admin = frame[UB_FRAME_OFF_ADMIN];
    ub_prio_class_t data_class = UB_PRIO_TELEMETRY;
    if (admin == UB_ADMIN_DATA && node->content_class != NULL) {
        int idx = content_index(node, frame + UB_FRAME_OFF_DIR_ID);
        if (idx >= 0) data_class = (ub_prio_class_t)node->content_class[idx];
    }
    return ub_prio_class_of(admin, data_class);
}

/* Hands `out` (the wire form of the full `frame`) to a transport that queues by class; the older telemetry
 * frames it dropped to take this one are counted `shed` on the link. */
static __attribute__((noinline)) int send_classed(ub_node_t *node, int link_id, const uint8_t *frame,
                                                  const uint8_t *out, size_t n, uint64_t now_ms) {
    ub_link_t *link = &node->links[link_id];
    int rc = link->ops->send_class(link->impl, out, n, (uint8_t)frame_class(node, frame), now_ms);
    for (int i = 0; i < rc; i++) count_drop(node, link_id, UB_DROP_SHED);
    return rc > 0 ? UB_OK : rc;
}

/* transmit() for a link with an MTU or the compact encoding: the frame is encoded for the wire, measured
 * against the MTU, and the counters count wire bytes; the tap still sees the full frame. Out of line, so the
 * plain path keeps its small stack. */
static __attribute__((noinline)) bool transmit_shaped(ub_node_t *node, int link_id, const uint8_t *frame, size_t len,
                                                      uint64_t now_ms) {
    ub_link_t *link = &node->links[link_id];
    uint8_t wire[UB_COMPACT_WIRE_MAX];
    const uint8_t *out = frame;
    size_t n = len;
    if (link->compact != NULL) {
        int w = ub_compact_link_encode(link->compact, frame, len, wire, sizeof wire);
        if (w < 0) {
            count_drop(node, link_id, UB_DROP_BAD_PAYLOAD);
            return false;
        }
        out = wire;
        n = (size_t)w;
    }
    if (link->mtu != 0 && n > link->mtu) {
        count_drop(node, link_id, UB_DROP_TOO_BIG);
        if (link->compact != NULL) ub_compact_tx_forget(link->compact, frame + UB_FRAME_OFF_SRC_ID);
        return false;
    }
    int rc = link->ops->send_class != NULL ? send_classed(node, link_id, frame, out, n, now_ms)
                                           : link->ops->send(link->impl, out, n, now_ms);
    if (rc < 0) {
        count_refusal(node, link_id, rc, now_ms);
        /* Its next frame carries all 32 sequence bits: the peer may not have the reference this one set. */
        if (link->compact != NULL) ub_compact_tx_forget(link->compact, frame + UB_FRAME_OFF_SRC_ID);
        return false;
    }
    link->counters.frames_out++;
    link->counters.bytes_out += n;
    if (node->tap != NULL) node->tap(node->tap_user, link_id, UB_TAP_TX, frame, len, now_ms);
    return true;
}

/* Hands a finished frame to link `link_id`'s transport and counts it. Inlined into its two callers (the forms
 * loop, a plain frame on one link): a handful of tests around one indirect call, where a call of its own cost
 * a dozen instructions per frame. */
static inline __attribute__((always_inline)) bool transmit(ub_node_t *node, int link_id, const uint8_t *frame, size_t len,
                                                         uint64_t now_ms) {
    ub_link_t *link = &node->links[link_id];
    if (link->ops == NULL) {
        count_drop(node, link_id, UB_DROP_DETACHED);
        return false;
    }
    if (__builtin_expect(link->compact != NULL || link->mtu != 0, 0)) return transmit_shaped(node, link_id, frame, len, now_ms);
    int rc = __builtin_expect(link->ops->send_class != NULL, 0) ? send_classed(node, link_id, frame, frame, len, now_ms)
                                                                : link->ops->send(link->impl, frame, len, now_ms);
    if (rc < 0) {
        count_refusal(node, link_id, rc, now_ms);
        return false;
    }
    link->counters.frames_out++;
    link->counters.bytes_out += len;
    if (node->tap != NULL) node->tap(node->tap_user, link_id, UB_TAP_TX, frame, len, now_ms);
    return true;
}

/*
 * The wire forms one frame may leave in: PLAIN, SIGNED or ENCRYPTED. Each outgoing link takes the
 * form its setting asks for; a form is built the first time a link needs it (so a frame for one
 * plain link costs one finish, and an encrypting link alone costs one AEAD, never both).
 */
enum { FORM_PLAIN = 0, FORM_SIGNED = 1, FORM_ENCRYPTED = 2, N_FORMS };

typedef struct tx_forms {
    const ub_frame_header_t *h;   /* the frame's header: flags ignored; key id and counter used */
    uint8_t hop_limit;            /* the hop limit to send */
    const uint8_t *payload;       /* plaintext payload */
    bool protect;                 /* the frame is authenticated: its clear form is SIGNED, not PLAIN */
    bool origin;                  /* its protected forms carry h's origin block (UB_FRAME_FLAG_ORIGIN) */
    ub_drop_reason_t unprotected; /* why an encrypting link cannot take it when it is not */
    uint8_t *buf[N_FORMS];        /* UB_FRAME_MAX bytes each (may be shared by forms never both needed) */
    int len[N_FORMS];             /* 0: not built yet; < 0: building failed */
} tx_forms_t;

static int form_get(ub_node_t *node, tx_forms_t *f, int form) {
    if (f->len[form] != 0) return f->len[form];
    ub_frame_header_t h = *f->h;
    h.hop_limit = f->hop_limit;
    int n;
    if (form == FORM_PLAIN) {
        if (f->buf[form] + UB_FRAME_HEADER_LEN != f->payload)
            memmove(f->buf[form] + UB_FRAME_HEADER_LEN, f->payload, h.payload_size);
        h.flags = 0;
        h.key_id = 0;
        h.counter_hi = 0;
        /* Through the node's header templates (by content ID and destination): a row sending again continues
         * the CRC of its fixed header bytes instead of recomputing it; same bytes as ub_frame_finish(). */
        unsigned slot = (unsigned)(h.dir_id[UB_DIR_ID_LEN - 1] ^ h.dest_id[UB_ENTITY_ID_LEN - 1]) % UB_NODE_TPL_CACHE;
        n = ub_frame_tpl_finish_header(&node->tpl[slot], f->buf[form], UB_FRAME_MAX, &h);
    } else {
        h.flags = form == FORM_SIGNED ? UB_FRAME_FLAG_SIGNED : UB_FRAME_FLAG_ENCRYPTED;
        if (f->origin) h.flags |= UB_FRAME_FLAG_ORIGIN;
        n = node->sec == NULL ? UB_ERR_NOTFOUND : ub_sec_protect(node->sec, &h, f->payload, f->buf[form], UB_FRAME_MAX);
    }
    f->len[form] = n == 0 ? UB_ERR_INVAL : n;
    return f->len[form];
}

static int send_forms(ub_node_t *node, const ub_local_entity_t *loc, uint8_t mask, tx_forms_t *f, uint64_t now_ms) {
    int sent = 0;
    for (unsigned bits = mask; bits != 0; bits &= bits - 1) { /* the links of the mask, lowest first */
        unsigned i = (unsigned)__builtin_ctz(bits);
        if (i >= UB_MAX_LINKS_PER_ENTITY || loc->link_ids[i] < 0) continue;
        int link_id = loc->link_ids[i];
        int form = node->links[link_id].encrypt ? FORM_ENCRYPTED : f->protect ? FORM_SIGNED : FORM_PLAIN;
        if (form == FORM_ENCRYPTED && !f->protect) {
            count_drop(node, link_id, f->unprotected);
            continue;
        }
        int n = form_get(node, f, form);
        if (n < 0) {
            count_drop(node, link_id, n == UB_ERR_NOTFOUND ? UB_DROP_UNKNOWN_KEY : UB_DROP_BAD_PAYLOAD);
            continue;
        }
        if (transmit(node, link_id, f->buf[form], (size_t)n, now_ms)) sent++;
    }
    return sent;
}

/* The catalogue index of a content ID: the last one found, else a binary search. */
static int content_index(ub_node_t *node, const uint8_t dir_id[UB_DIR_ID_LEN]) {
    uint32_t c = node->last_content;
    if (c < node->cat->n_instances) {
        uint64_t a0, a1, b0, b1;
        memcpy(&a0, node->cat->instances[c].id, 8);
        memcpy(&a1, node->cat->instances[c].id + 8, 8);
        memcpy(&b0, dir_id, 8);
        memcpy(&b1, dir_id + 8, 8);
        if (((a0 ^ b0) | (a1 ^ b1)) == 0) return (int)c;
    }
    int idx = ub_catalogue_find(node->cat, dir_id);
    if (idx >= 0) node->last_content = (uint32_t)idx;
    return idx;
}

void ub_priv_deliver_data(ub_node_t *node, int slot, int link_id, const ub_frame_header_t *h, const uint8_t *payload,
                          uint64_t now_ms) {
    int idx = content_index(node, h->dir_id);
    if (idx < 0) {
        count_drop(node, link_id, UB_DROP_UNKNOWN_CONTENT);
        return;
    }
    /* Authorization before anything else about the content: a refused writer learns nothing more. */
    if (link_id >= 0 && node->policy != NULL && !ub_priv_may_write(node, slot, (uint32_t)idx, h->src_id)) {
        count_drop(node, link_id, UB_DROP_NOT_ALLOWED);
        return;
    }
    const ub_type_desc_t *type = node->cat->instances[idx].type;
    if (h->fingerprint != type->fingerprint || h->payload_size != type->packed_size) {
        count_drop(node, link_id, UB_DROP_LAYOUT_MISMATCH);
        return;
    }
    void *storage = ub_node_binding(node, (uint32_t)idx);
    if (storage == NULL) {
        count_drop(node, link_id, UB_DROP_UNBOUND);
        return;
    }
    if (type->unpack == NULL) {
        memcpy(storage, payload, h->payload_size); /* wire-image storage (ub_type_desc_t) */
    } else if (type->unpack(storage, payload, h->payload_size) < 0) {
        count_drop(node, link_id, UB_DROP_BAD_PAYLOAD);
        return;
    }
    node->counters.delivered++;
    const ub_service_t *observer = node->data_svc;
    if (observer != NULL && observer->on_data != NULL) observer->on_data(observer, node, slot, (uint32_t)idx, h->src_id, now_ms);
    if (node->deliver != NULL) node->deliver(node->deliver_user, node->locals[slot].entity, (uint32_t)idx, h, now_ms);
}

bool ub_priv_may_write(const ub_node_t *node, int slot, uint32_t instance, const uint8_t src_id[UB_ENTITY_ID_LEN]) {
    const ub_service_t *svc = node->data_svc;
    return svc != NULL && svc->may_write != NULL && svc->may_write(svc, node, slot, instance, src_id);
}

/* Hands an admin frame to the service registered for it (ub_service.h): an ACK/NACK to the service taking
 * replies to the code it answers, anything else to the service of its code. Unclaimed: `bad_payload`. */
static __attribute__((noinline)) void dispatch_admin(ub_node_t *node, int slot, int link_id,
                                                     const ub_frame_header_t *h, const uint8_t *payload,
                                                     const ub_priv_rx_t *rx, uint64_t now_ms) {
    /* Fragments are DATA in pieces: counted as delivered once whole, not as admin frames. */
    if (h->admin != UB_ADMIN_FRAGMENT) node->counters.admin_handled++;
    ub_service_rx_t srx = {slot, link_id, false, 0, false};
    if (rx != NULL && link_id >= 0) {
        srx.secured = rx->secured;
        srx.counter = rx->counter;
        srx.origin = rx->origin;
    }
    ub_drop_reason_t drop = UB_DROP_BAD_PAYLOAD;
    bool ok = false;
    unsigned idx = 0;
    if ((h->admin == UB_ADMIN_ACK || h->admin == UB_ADMIN_NACK) && h->payload_size >= UB_PL_REPLY_LEN)
        idx = node->svc_by_code[UB_SVC_REPLY][payload[UB_PL_REPLY_CODE]];
    if (idx != 0) {
        const ub_service_t *svc = node->services[idx - 1];
        ub_service_reply_t r = {ub_get_u32le(payload + UB_PL_REPLY_ID), payload[UB_PL_REPLY_CODE],
                                h->admin == UB_ADMIN_NACK, payload[UB_PL_REPLY_DETAIL], payload[UB_PL_REPLY_FLAGS]};
        ok = svc->on_reply != NULL && svc->on_reply(svc, node, &srx, h, &r, now_ms, &drop);
    } else if ((idx = node->svc_by_code[UB_SVC_CODE][h->admin]) != 0) {
        const ub_service_t *svc = node->services[idx - 1];
        ok = svc->on_frame != NULL && svc->on_frame(svc, node, &srx, h, payload, now_ms, &drop);
    }
    if (!ok) count_drop(node, link_id, drop);
}

/* A frame reached its destination, local slot `slot`, with its plaintext payload; `link_id` is -1 for
 * a node-local hand-over (then `rx` is NULL: it never left the process). DATA first: the hot path
 * pays one comparison for the services. */
static void dispatch(ub_node_t *node, int slot, int link_id, const ub_frame_header_t *h, const uint8_t *payload,
                     const ub_priv_rx_t *rx, uint64_t now_ms) {
    if (h->admin == UB_ADMIN_DATA) {
        ub_priv_deliver_data(node, slot, link_id, h, payload, now_ms);
        return;
    }
    dispatch_admin(node, slot, link_id, h, payload, rx, now_ms);
}

/* The destination's entity row (-1: unknown) in *dest_row, and its local slot (-1: not local). Every originated
 * and received frame asks, mostly for the destination of the frame before: that row is checked first, inline
 * in both callers (the search is the out-of-line part). */
static inline __attribute__((always_inline)) int local_destination(ub_node_t *node, const uint8_t dest_id[UB_ENTITY_ID_LEN],
                                                                 int *dest_row) {
    const ub_entity_row_t *last = &node->entities[node->last_dest];
    if (last->in_use && ub_priv_id_eq(last->id, dest_id)) {
        *dest_row = (int)node->last_dest;
        return last->local;
    }
    *dest_row = ub_node_find_entity(node, dest_id);
    if (*dest_row < 0) return -1;
    node->last_dest = (uint32_t)*dest_row;
    return node->entities[*dest_row].local;
}

/* The next freshness counter: from the security context when one is attached (it may refuse: fail
 * closed), else the node's own 32-bit sequence. */
static int next_counter(ub_node_t *node, uint64_t *counter) {
    if (node->sec != NULL) return ub_sec_next_counter(node->sec, counter);
    *counter = node->next_seq++;
    return UB_OK;
}

/* Stamps a frame originated by local slot `slot`: source, hop limit, freshness counter (the security
 * context's when one is attached: it may refuse, and then nothing is sent) and key id; enters it in the
 * slot's window, so a copy that loops back is cut there. Every originated frame, routed or link-local,
 * goes through here. */
static int stamp(ub_node_t *node, int slot, ub_frame_header_t *h, uint8_t hop_limit, uint64_t now_ms) {
    ub_local_entity_t *loc = &node->locals[slot];
    if (h->payload_size > UB_MAX_PAYLOAD) return UB_ERR_RANGE;
    uint64_t counter;
    int rc = next_counter(node, &counter);
    if (rc < 0) return rc;
    h->msg_type = UB_MSG_TYPE_PUBSUB;
    memcpy(h->src_id, node->entities[loc->entity].id, UB_ENTITY_ID_LEN);
    h->hop_limit = hop_limit;
    h->flags = 0;
    h->seq = (uint32_t)counter;
    h->counter_hi = (uint16_t)(counter >> 32);
    h->key_id = node->sec != NULL ? ub_sec_tx_key(node->sec) : 0;
    node->counters.originated++;
    ub_priv_window_note_own(node, slot, h, h->key_id != 0, now_ms);
    return UB_OK;
}

/* The plain form of a stamped frame finished in place (as form_get() does) and sent on `link_id`: the frame is
 * plain (no key, flags or counter bits above 32) and the link does not encrypt. Returns the links used, 0 or 1,
 * as send_forms() would. */
static inline int send_plain_one(ub_node_t *node, int link_id, uint8_t *frame, const ub_frame_header_t *h,
                                 uint64_t now_ms) {
    unsigned t = (unsigned)(h->dir_id[UB_DIR_ID_LEN - 1] ^ h->dest_id[UB_ENTITY_ID_LEN - 1]) % UB_NODE_TPL_CACHE;
    int n = ub_frame_tpl_finish_header(&node->tpl[t], frame, UB_FRAME_MAX, h);
    if (n <= 0) {
        count_drop(node, link_id, UB_DROP_BAD_PAYLOAD);
        return 0;
    }
    return transmit(node, link_id, frame, (size_t)n, now_ms) ? 1 : 0;
}

/* Sends a stamped frame, whose plaintext payload is in place in `frame`, on the links of `mask`: each
 * link gets the form (plain, signed, encrypted) it asks for. */
static int send_stamped(ub_node_t *node, int slot, uint8_t mask, uint8_t *frame, const ub_frame_header_t *h,
                        uint64_t now_ms) {
    /* One link and a plain frame it takes plain (most data): no forms to keep apart. */
    if (mask != 0 && (mask & (mask - 1u)) == 0 && h->key_id == 0 && h->flags == 0 && h->counter_hi == 0) {
        unsigned i = (unsigned)__builtin_ctz(mask);
        int link_id = i < UB_MAX_LINKS_PER_ENTITY ? node->locals[slot].link_ids[i] : -1;
        if (link_id < 0) return 0; /* send_forms() skips a bit without a link */
        if (!node->links[link_id].encrypt) return send_plain_one(node, link_id, frame, h, now_ms);
    }
    uint8_t alt[UB_FRAME_MAX];
    tx_forms_t f;
    f.h = h;
    f.hop_limit = h->hop_limit;
    f.payload = frame + UB_FRAME_HEADER_LEN;
    f.protect = h->key_id != 0;
    f.origin = f.protect && (h->flags & UB_FRAME_FLAG_ORIGIN) != 0;
    f.unprotected = UB_DROP_UNKNOWN_KEY;
    f.buf[FORM_PLAIN] = f.buf[FORM_SIGNED] = frame;
    f.buf[FORM_ENCRYPTED] = alt;
    f.len[FORM_PLAIN] = f.len[FORM_SIGNED] = f.len[FORM_ENCRYPTED] = 0;
    return send_forms(node, &node->locals[slot], mask, &f, now_ms);
}

int ub_priv_originate(ub_node_t *node, int slot, uint8_t *frame, size_t cap, ub_frame_header_t *h, int fallback_link,
                      uint64_t now_ms) {
    ub_local_entity_t *loc = &node->locals[slot];
    if (cap < UB_FRAME_MAX) return UB_ERR_NOSPACE;
    int rc = stamp(node, slot, h, node->opt.hop_limit, now_ms);
    if (rc < 0) return rc;
    int dest_row;
    int dest_slot = local_destination(node, h->dest_id, &dest_row);
    if (dest_slot >= 0) {
        node->counters.local_direct++;
        dispatch(node, dest_slot, -1, h, frame + UB_FRAME_HEADER_LEN, NULL, now_ms);
        return 0;
    }
    uint8_t mask = dest_row >= 0 ? loc->masks[dest_row] : 0;
    if (mask == 0 && fallback_link >= 0 && link_id_ok(node, fallback_link) && node->links[fallback_link].owner == slot)
        mask = (uint8_t)(1u << node->links[fallback_link].index);
    if (mask == 0) {
        count_drop(node, -1, UB_DROP_NO_ROUTE);
        return UB_ERR_NOROUTE;
    }
    const ub_service_t *sealer = node->seal_svc;
    if (sealer != NULL && sealer->seal != NULL && h->key_id != 0) {
        /* An end-to-end origin block (docs/security.md, "Origin authentication"): the service decides. */
        ub_drop_reason_t drop = UB_DROP_NO_IDENTITY;
        int sealed = sealer->seal(sealer, node, slot, h, frame + UB_FRAME_HEADER_LEN, now_ms, &drop);
        if (sealed < 0) {
            count_drop(node, -1, drop);
            return sealed;
        }
        if (sealed > 0) h->flags = UB_FRAME_FLAG_ORIGIN; /* send_stamped() adds the hop protection */
    }
    return send_stamped(node, slot, mask, frame, h, now_ms);
}

int ub_priv_originate_local(ub_node_t *node, int slot, int dest_slot, ub_frame_header_t *h, const uint8_t *payload,
                            uint64_t now_ms) {
    uint16_t size = h->payload_size;
    h->payload_size = 0; /* stamp() guards the frame's payload limit; this one never becomes a frame */
    int rc = stamp(node, slot, h, node->opt.hop_limit, now_ms);
    h->payload_size = size;
    if (rc < 0) return rc;
    node->counters.local_direct++;
    dispatch(node, dest_slot, -1, h, payload, NULL, now_ms);
    return 0;
}

/* Per-call context of the stream decoder callback. */
typedef struct rx_ctx {
    ub_node_t *node;
    int link_id;
    uint64_t now_ms;
    ub_rx_verdicts_t verdicts;
} rx_ctx_t;

/* Link-local codes the wire format reserves (docs/routing.md): accepted link-local even when no service
 * takes them here, then dropped `routing_off` past the window (the peer runs routing, this node does not). */
static bool link_local_reserved(uint8_t code) { return code == UB_ADMIN_HELLO || code == UB_ADMIN_ROUTE_UPDATE; }

/* A link-local frame that passed the security gate and the window of the ingress link's owner. */
static __attribute__((noinline)) void on_link_local(ub_node_t *node, int link_id, const ub_frame_header_t *h,
                                                    const ub_priv_rx_t *rx, uint64_t now_ms) {
    unsigned idx = node->svc_by_code[UB_SVC_LINK_LOCAL][h->admin];
    if (idx == 0) {
        count_drop(node, link_id, UB_DROP_ROUTING_OFF);
        return;
    }
    const ub_service_t *svc = node->services[idx - 1];
    node->counters.admin_handled++;
    ub_service_rx_t srx = {node->links[link_id].owner, link_id, rx->secured, rx->counter, false};
    ub_drop_reason_t drop = UB_DROP_BAD_PAYLOAD;
    if (svc->on_frame == NULL || !svc->on_frame(svc, node, &srx, h, rx->payload, now_ms, &drop))
        count_drop(node, link_id, drop);
}

/* A forward to one link whose transport patches the hop limit into its own buffer (ub_link_ops_t.send_hop): the
 * frame leaves in the form it came in, which that link takes as is (it would pick the same form in send_forms()),
 * with no compact encoding, MTU, classes or tap, each of which needs the node's own copy. Then the one copy is
 * the transport's. Returns false, having done nothing, when the frame needs the general path. */
static inline bool forward_direct(ub_node_t *node, const ub_local_entity_t *owner, uint8_t mask,
                                  const ub_frame_header_t *h, const uint8_t *frame, size_t len, bool secured,
                                  uint64_t now_ms) {
    unsigned i = (unsigned)__builtin_ctz(mask);
    if (i >= UB_MAX_LINKS_PER_ENTITY || owner->link_ids[i] < 0) return false;
    int out_id = owner->link_ids[i];
    ub_link_t *out = &node->links[out_id];
    if (out->ops == NULL || out->ops->send_hop == NULL || out->ops->send_class != NULL || out->compact != NULL ||
        out->mtu != 0 || node->tap != NULL)
        return false;
    uint8_t prot = h->flags & UB_FRAME_FLAG_PROTECT_MASK;
    uint8_t wanted = out->encrypt ? UB_FRAME_FLAG_ENCRYPTED : secured ? UB_FRAME_FLAG_SIGNED : 0;
    if (prot != wanted || (out->encrypt && !secured)) return false; /* another form, or a drop send_forms() counts */
    node->counters.forwarded++;
    int rc = out->ops->send_hop(out->impl, frame, len, (uint8_t)(h->hop_limit - 1), &node->hop_memo, now_ms);
    if (rc < 0) {
        count_refusal(node, out_id, rc, now_ms);
        return true;
    }
    out->counters.frames_out++;
    out->counters.bytes_out += len;
    return true;
}

/* Routes one verified frame received on `link_id`. Returns the verdict (ub_rx_verdict_t, ub_node.h): a
 * check that refuses a frame for its origin (security, window) returns UB_VERDICT_REFUSED; a genuine copy
 * already handled UB_VERDICT_DUPLICATE; an authentic frame from a source whose freshness is not established
 * yet (a challenge runs) UB_VERDICT_UNVERIFIED; once past the window the frame is accepted, whatever happens
 * next. `verdicts` (may be NULL) counts authentic and fresh frames for TCP adoption (ub_tcp.c). */
static ub_rx_verdict_t route_received(ub_node_t *node, int link_id, const ub_frame_header_t *h, const uint8_t *frame,
                                      size_t len, uint64_t now_ms, ub_rx_verdicts_t *verdicts) {
    ub_link_t *link = &node->links[link_id];
    link->counters.frames_in++;
    /* Security first: nothing below (window, routing, tables, the tap) sees a frame that fails it. */
    uint8_t plain[UB_MAX_PAYLOAD];
    ub_priv_rx_t rx;
    if (h->flags == 0 && node->sec == NULL && link->require_signed <= 0 && (link->require_signed == 0 || !node->require_signed)) {
        rx.payload = frame + UB_FRAME_HEADER_LEN; /* unsigned, and nothing here asks otherwise (the paper's lab) */
        rx.counter = h->seq;
        rx.secured = false;
    } else if (!ub_priv_sec_gate(node, link_id, h, frame, len, plain, &rx)) {
        return UB_VERDICT_REFUSED;
    }
    if (node->tap != NULL) node->tap(node->tap_user, link_id, UB_TAP_RX, frame, len, now_ms);
    /* A link-local frame (docs/routing.md) is for the ingress link's owner and is never forwarded. */
    bool link_local = ub_entity_id_is_link_local(h->dest_id);
    if (link_local && node->svc_by_code[UB_SVC_LINK_LOCAL][h->admin] == 0 && !link_local_reserved(h->admin)) {
        count_drop(node, link_id, UB_DROP_BAD_PAYLOAD);
        return UB_VERDICT_REFUSED;
    }
    int dest_row = -1;
    int dest_slot = link_local ? -1 : local_destination(node, h->dest_id, &dest_row);
    int handler = dest_slot >= 0 ? dest_slot : link->owner;
    rx.origin = false;
    const ub_service_t *opener = node->seal_svc;
    if (dest_slot >= 0 && opener != NULL && opener->open != NULL) {
        /* The destination's origin check comes before its window: a frame a key-holding insider forged in
         * another entity's name never moves that entity's freshness state. */
        ub_service_rx_t srx = {dest_slot, link_id, rx.secured, rx.counter, false};
        ub_drop_reason_t drop = UB_DROP_BAD_ORIGIN;
        if (!opener->open(opener, node, &srx, h, rx.payload, now_ms, &rx.origin, &drop)) {
            count_drop(node, link_id, drop);
            return UB_VERDICT_REFUSED;
        }
    }
    ub_priv_window_t verdict = ub_priv_window_pass(node, handler, link_id, h, &rx, now_ms);
    if (verdict != UB_PRIV_WINDOW_PASS) {
        if (verdict == UB_PRIV_WINDOW_UNVERIFIED && verdicts != NULL) verdicts->authentic++;
        return verdict == UB_PRIV_WINDOW_DUPLICATE    ? UB_VERDICT_DUPLICATE
               : verdict == UB_PRIV_WINDOW_UNVERIFIED ? UB_VERDICT_UNVERIFIED
                                                      : UB_VERDICT_REFUSED;
    }
    link->counters.frames_accepted++;
    if (verdicts != NULL) {
        verdicts->authentic++;
        verdicts->fresh++;
    }
    if (link_local) {
        on_link_local(node, link_id, h, &rx, now_ms);
        return UB_VERDICT_ACCEPTED;
    }
    if (dest_slot >= 0) {
        dispatch(node, dest_slot, link_id, h, rx.payload, &rx, now_ms);
        return UB_VERDICT_ACCEPTED;
    }
    const ub_local_entity_t *owner = &node->locals[link->owner];
    uint8_t in_bit = (uint8_t)(1u << link->index);
    uint8_t mask = (uint8_t)(dest_row >= 0 ? owner->masks[dest_row] & ~in_bit : 0u);
    if (mask == 0 && dest_row >= 0 && (owner->masks[dest_row] & in_bit) && !owner->pinned[dest_row])
        mask = (uint8_t)(owner->bounce[dest_row] & ~in_bit); /* sent back by its next hop: the other successors */
    if (mask == 0) {
        count_drop(node, link_id, UB_DROP_NO_ROUTE);
        return UB_VERDICT_ACCEPTED;
    }
    if (h->hop_limit <= 1) {
        count_drop(node, link_id, UB_DROP_HOP_LIMIT);
        return UB_VERDICT_ACCEPTED;
    }
    /* Forward: the form it came in, with the hop limit lowered (not under the tag); the other
     * protected form only if an outgoing link asks for it. */
    uint8_t out[UB_FRAME_MAX], alt[UB_FRAME_MAX];
    if (len > sizeof out) {
        count_drop(node, link_id, UB_DROP_BAD_PAYLOAD);
        return UB_VERDICT_ACCEPTED;
    }
    bool retag = (h->flags & UB_FRAME_FLAG_ORIGIN) != 0; /* its hop tag covers the hop limit: made again below */
    if (!retag && (mask & (mask - 1u)) == 0 && forward_direct(node, owner, mask, h, frame, len, rx.secured, now_ms))
        return UB_VERDICT_ACCEPTED;
    /* The frame was verified on the way in (decoder, ub_frame_parse() or a compact link's rebuild), so its
     * checks are patched for the new hop limit by CRC linearity instead of recomputed, in the copy, with the
     * deltas of the flow's last frame when they are the same (ub_frame.h). */
    if (retag) {
        memcpy(out, frame, len);
    } else if (ub_frame_copy_hop_limit(out, frame, len, (uint8_t)(h->hop_limit - 1), &node->hop_memo) < 0) {
        count_drop(node, link_id, UB_DROP_BAD_PAYLOAD);
        return UB_VERDICT_ACCEPTED;
    }
    tx_forms_t f;
    f.h = h;
    f.hop_limit = (uint8_t)(h->hop_limit - 1);
    f.payload = rx.payload;
    f.protect = rx.secured;
    f.origin = retag;
    f.unprotected = UB_DROP_UNSIGNED;
    uint8_t prot = h->flags & UB_FRAME_FLAG_PROTECT_MASK;
    int in_form = prot == UB_FRAME_FLAG_ENCRYPTED ? FORM_ENCRYPTED
                : prot == UB_FRAME_FLAG_SIGNED  ? FORM_SIGNED : FORM_PLAIN;
    for (int k = 0; k < N_FORMS; k++) {
        f.buf[k] = alt;
        f.len[k] = 0;
    }
    f.buf[in_form] = out;
    f.len[in_form] = retag ? 0 : (int)len;
    node->counters.forwarded++;
    (void)send_forms(node, owner, mask, &f, now_ms);
    return UB_VERDICT_ACCEPTED;
}

static void on_stream_frame(void *user, const ub_frame_header_t *h, const uint8_t *frame, size_t frame_len) {
    rx_ctx_t *ctx = user;
    (void)route_received(ctx->node, ctx->link_id, h, frame, frame_len, ctx->now_ms, &ctx->verdicts);
}

/* A frame decoded from a compact link: routed as any, then, if it proved authentic, its sequence becomes the
 * link's reference for its source (after the security gate, so a forgery cannot move it). */
typedef struct compact_ctx {
    rx_ctx_t rx;
    ub_rx_verdict_t best;
    size_t frames;
} compact_ctx_t;

static void on_compact_frame(void *user, const ub_frame_header_t *h, const uint8_t *frame, size_t len, bool seq32) {
    compact_ctx_t *ctx = user;
    unsigned authentic = ctx->rx.verdicts.authentic;
    ub_rx_verdict_t v = route_received(ctx->rx.node, ctx->rx.link_id, h, frame, len, ctx->rx.now_ms, &ctx->rx.verdicts);
    if (v > ctx->best) ctx->best = v;
    ctx->frames++;
    ub_link_t *link = &ctx->rx.node->links[ctx->rx.link_id];
    if (link->compact != NULL && (ctx->rx.verdicts.authentic != authentic || v == UB_VERDICT_DUPLICATE))
        ub_compact_rx_note(link->compact, h->src_id, h->seq, seq32);
}

/* Bytes of a compact link: a stream chunk (`dec` carries an unfinished packet) or, with `dec` NULL, one
 * datagram of whole packets. */
static __attribute__((noinline)) size_t rx_compact(ub_node_t *node, int link_id, ub_decoder_t *dec, const uint8_t *data,
                                                   size_t len, uint64_t now_ms, compact_ctx_t *ctx) {
    ub_link_t *link = &node->links[link_id];
    ctx->rx.node = node;
    ctx->rx.link_id = link_id;
    ctx->rx.now_ms = now_ms;
    ctx->rx.verdicts.authentic = ctx->rx.verdicts.fresh = 0;
    ctx->best = UB_VERDICT_REFUSED;
    ctx->frames = 0;
    return ub_compact_feed(link->compact, dec, data, len, now_ms, dec == NULL ? link->counters.bad_datagrams : NULL,
                           on_compact_frame, ctx);
}

int ub_node_rx_stream(ub_node_t *node, int link_id, ub_decoder_t *dec, const uint8_t *data, size_t len,
                      uint64_t now_ms, ub_rx_verdicts_t *verdicts) {
    if (node == NULL || !link_id_ok(node, link_id) || (data == NULL && len > 0)) return UB_ERR_INVAL;
    node->links[link_id].counters.bytes_in += len;
    if (node->links[link_id].compact != NULL) {
        compact_ctx_t cctx;
        size_t found = rx_compact(node, link_id, dec != NULL ? dec : &node->links[link_id].decoder, data, len, now_ms,
                                  &cctx);
        if (verdicts != NULL) *verdicts = cctx.rx.verdicts;
        return found > (size_t)INT32_MAX ? INT32_MAX : (int)found;
    }
    rx_ctx_t ctx = {node, link_id, now_ms, {0, 0}};
    size_t frames = ub_decoder_feed(dec != NULL ? dec : &node->links[link_id].decoder, data, len, on_stream_frame,
                                    &ctx);
    if (verdicts != NULL) *verdicts = ctx.verdicts;
    return frames > (size_t)INT32_MAX ? INT32_MAX : (int)frames;
}

int ub_node_rx(ub_node_t *node, int link_id, const uint8_t *data, size_t len, uint64_t now_ms) {
    return ub_node_rx_stream(node, link_id, NULL, data, len, now_ms, NULL);
}

/* ub_node_rx_frame_verdict() with a verdict to write (`verdict` non-NULL); inlined into both entry points, so
 * ub_node_rx_frame() (every frame a memlink or a datagram link delivers) is not a call to the other. */
static inline __attribute__((always_inline)) int rx_frame(ub_node_t *node, int link_id, const uint8_t *frame,
                                                          size_t len, uint64_t now_ms, ub_rx_verdict_t *verdict) {
    *verdict = UB_VERDICT_REFUSED;
    if (node == NULL || !link_id_ok(node, link_id) || frame == NULL) return UB_ERR_INVAL;
    ub_link_t *link = &node->links[link_id];
    link->counters.bytes_in += len;
    if (link->compact != NULL) {
        compact_ctx_t cctx;
        size_t found = rx_compact(node, link_id, NULL, frame, len, now_ms, &cctx);
        *verdict = cctx.best;
        return found > 0 ? UB_OK : UB_ERR_CHECKSUM;
    }
    ub_frame_header_t h;
    ub_rx_reason_t reason = UB_RX_BAD_LENGTH;
    int rc = ub_frame_parse_reason(frame, len, &h, &reason);
    if (rc < 0) {
        if ((unsigned)reason < UB_RX_REASON_COUNT) link->counters.bad_datagrams[reason]++;
        return rc;
    }
    *verdict = route_received(node, link_id, &h, frame, len, now_ms, NULL);
    return UB_OK;
}

int ub_node_rx_frame_verdict(ub_node_t *node, int link_id, const uint8_t *frame, size_t len, uint64_t now_ms,
                             ub_rx_verdict_t *verdict) {
    ub_rx_verdict_t ignored;
    return rx_frame(node, link_id, frame, len, now_ms, verdict != NULL ? verdict : &ignored);
}

int ub_node_rx_frame(ub_node_t *node, int link_id, const uint8_t *frame, size_t len, uint64_t now_ms) {
    ub_rx_verdict_t ignored;
    return rx_frame(node, link_id, frame, len, now_ms, &ignored);
}

/* ---- originating ------------------------------------------------------- */

int ub_node_svc_send_data(ub_node_t *node, int slot, uint32_t instance, const uint8_t dest_id[UB_ENTITY_ID_LEN],
                                uint64_t now_ms) {
    if (instance >= node->cat->n_instances) return UB_ERR_INVAL;
    void *storage = ub_node_binding(node, instance);
    if (storage == NULL) return UB_ERR_NOTFOUND;
    const ub_instance_desc_t *inst = &node->cat->instances[instance];
    if (inst->type->packed_size > UB_MAX_PAYLOAD || node->mtu_links != 0) {
        /* Maybe too large for a frame or for the links it leaves on: then in fragments. */
        bool sent = false;
        int rc = ub_priv_frag_send(node, slot, instance, storage, dest_id, now_ms, &sent);
        if (sent) return rc;
    }
    uint8_t frame[UB_FRAME_MAX];
    int packed;
    if (inst->type->pack == NULL) { /* wire-image storage (ub_type_desc_t) */
        memcpy(frame + UB_FRAME_HEADER_LEN, storage, inst->type->packed_size);
        packed = (int)inst->type->packed_size;
    } else {
        packed = inst->type->pack(storage, frame + UB_FRAME_HEADER_LEN, UB_MAX_PAYLOAD);
        if (packed < 0) return packed;
    }
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memcpy(h.dir_id, inst->id, UB_DIR_ID_LEN);
    memcpy(h.dest_id, dest_id, UB_ENTITY_ID_LEN);
    h.admin = UB_ADMIN_DATA;
    h.payload_size = (uint16_t)packed;
    h.fingerprint = inst->type->fingerprint;
    return ub_priv_originate(node, slot, frame, sizeof frame, &h, -1, now_ms);
}

int ub_node_send_data(ub_node_t *node, int entity, uint32_t instance, const uint8_t dest_id[UB_ENTITY_ID_LEN],
                      uint64_t now_ms) {
    if (node == NULL || dest_id == NULL) return UB_ERR_INVAL;
    int slot = ub_node_entity_slot(node, entity);
    if (slot < 0) return UB_ERR_INVAL;
    return ub_node_svc_send_data(node, slot, instance, dest_id, now_ms);
}

int ub_node_svc_send_admin(ub_node_t *node, int slot, ub_admin_code_t code, const uint8_t dir_id[UB_DIR_ID_LEN],
                       uint32_t fingerprint, const uint8_t dest_id[UB_ENTITY_ID_LEN], const uint8_t *payload,
                       uint16_t len, uint64_t now_ms) {
    if (len > UB_MAX_PAYLOAD) return UB_ERR_RANGE;
    uint8_t frame[UB_FRAME_MAX];
    memcpy(frame + UB_FRAME_HEADER_LEN, payload, len);
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memcpy(h.dir_id, dir_id, UB_DIR_ID_LEN);
    memcpy(h.dest_id, dest_id, UB_ENTITY_ID_LEN);
    h.admin = (uint8_t)code;
    h.payload_size = len;
    h.fingerprint = fingerprint;
    return ub_priv_originate(node, slot, frame, sizeof frame, &h, -1, now_ms);
}

int ub_node_svc_send_reply(ub_node_t *node, int slot, bool nack, const uint8_t dir_id[UB_DIR_ID_LEN],
                       const uint8_t dest_id[UB_ENTITY_ID_LEN], uint32_t request_id, uint8_t code, uint8_t detail,
                       uint8_t origin, uint64_t now_ms) {
    uint8_t payload[UB_PL_REPLY_LEN] = {0};
    ub_put_u32le(payload + UB_PL_REPLY_ID, request_id);
    ub_put_u8(payload + UB_PL_REPLY_CODE, code);
    ub_put_u8(payload + UB_PL_REPLY_DETAIL, detail);
    ub_put_u8(payload + UB_PL_REPLY_FLAGS, nack ? origin : 0);
    return ub_node_svc_send_admin(node, slot, nack ? UB_ADMIN_NACK : UB_ADMIN_ACK, dir_id, 0, dest_id, payload,
                              UB_PL_REPLY_LEN, now_ms);
}

int ub_node_send_link_local(ub_node_t *node, int link_id, ub_admin_code_t code, const uint8_t *payload,
                            uint16_t len, uint64_t now_ms) {
    if (node == NULL || !link_id_ok(node, link_id) || (payload == NULL && len > 0)) return UB_ERR_INVAL;
    if (len > UB_MAX_PAYLOAD) return UB_ERR_RANGE;
    uint8_t frame[UB_FRAME_MAX];
    if (len > 0) memcpy(frame + UB_FRAME_HEADER_LEN, payload, len);
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memset(h.dest_id, UB_LINK_LOCAL_BYTE, UB_ENTITY_ID_LEN);
    h.admin = (uint8_t)code;
    h.payload_size = len;
    const ub_link_t *link = &node->links[link_id];
    int rc = stamp(node, link->owner, &h, 1, now_ms);
    if (rc < 0) return rc;
    /* Signed or encrypted like any frame on that link (docs/routing.md, docs/security.md). */
    return send_stamped(node, link->owner, (uint8_t)(1u << link->index), frame, &h, now_ms);
}

bool ub_node_may_administer(const ub_node_t *node, int entity, const uint8_t src_id[UB_ENTITY_ID_LEN], bool verified) {
    (void)entity;
    /* With a keyring, who the requester is rests on its tag: an unsigned frame can claim any source. */
    if (node->sec != NULL && !verified) return false;
    /* The paper's exclusive rights (ub_policy.h): without a policy every entity has them. */
    return node->policy == NULL || ub_policy_is_admin(node->policy, src_id);
}

void ub_node_link_event(ub_node_t *node, int link_id, ub_link_event_t ev, uint64_t now_ms) {
    if (node == NULL || !link_id_ok(node, link_id)) return;
    for (int i = 0; i < node->n_services; i++) {
        const ub_service_t *svc = node->services[i];
        if (svc->link_event != NULL) svc->link_event(svc, node, link_id, ev, now_ms);
    }
}

uint64_t ub_node_next_due(const ub_node_t *node, uint64_t now_ms) {
    uint64_t best = UINT64_MAX;
    if (node == NULL) return best;
    for (int i = 0; i < node->n_services && best > now_ms; i++) {
        const ub_service_t *svc = node->services[i];
        uint64_t due;
        if (svc->next_due != NULL) {
            if (svc->next_due(svc, node, now_ms, &due) && due < best) best = due;
        } else if (svc->tick != NULL && now_ms + 1u < best) {
            best = now_ms + 1u; /* a tick with no due time: poll it every millisecond, as before next_due existed */
        }
    }
    return best < now_ms ? now_ms : best;
}

void ub_node_tick(ub_node_t *node, uint64_t now_ms) {
    /* In ascending order (ub_service.h): publish/subscribe, routing, membership, inspection, then the
     * frame path's own (challenges, compact links, fragments), then the application's. */
    for (int i = 0; i < node->n_services; i++) {
        const ub_service_t *svc = node->services[i];
        if (svc->tick != NULL) svc->tick(svc, node, now_ms);
    }
}

/* ---- wire: compact links, MTUs, fragments -------------------------------------------------------- */

int ub_node_link_set_compact(ub_node_t *node, int link_id, ub_compact_t *state, const ub_compact_params_t *params) {
    if (node == NULL || !link_id_ok(node, link_id)) return UB_ERR_INVAL;
    ub_link_t *link = &node->links[link_id];
    if (state != NULL) {
        /* A random epoch: the peer notices our restart and sends all sequence bits again. */
        ub_compact_init(state, node->cat, ub_node_svc_new_request_id(node), params);
    }
    link->compact = state;
    ub_decoder_stats_t kept = link->decoder.stats; /* the carried bytes were the other encoding's */
    ub_decoder_init(&link->decoder);
    link->decoder.stats = kept;
    return UB_OK;
}

ub_compact_t *ub_node_link_compact(const ub_node_t *node, int link_id) {
    if (node == NULL || !link_id_ok(node, link_id)) return NULL;
    return node->links[link_id].compact;
}

int ub_node_link_set_mtu(ub_node_t *node, int link_id, uint16_t mtu) {
    if (node == NULL || !link_id_ok(node, link_id)) return UB_ERR_INVAL;
    if (mtu != 0 && mtu < UB_LINK_MTU_MIN) return UB_ERR_RANGE;
    ub_link_t *link = &node->links[link_id];
    if (link->mtu == 0 && mtu != 0) node->mtu_links++;
    if (link->mtu != 0 && mtu == 0) node->mtu_links--;
    link->mtu = mtu;
    return UB_OK;
}

int ub_node_set_frag(ub_node_t *node, ub_frag_t *frag) {
    if (node == NULL) return UB_ERR_INVAL;
    node->frag = frag; /* its service (ub_node_wire.c) is always registered: without state it refuses fragments */
    return UB_OK;
}

ub_frag_t *ub_node_frag(const ub_node_t *node) { return node != NULL ? node->frag : NULL; }
