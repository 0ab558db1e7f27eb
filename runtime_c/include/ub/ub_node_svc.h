/**
 * @file ub_node_svc.h
 * @brief What the node offers its services (ub_service.h): sending through the node's path, and
 *        read access to its tables without reaching into ub_node_t.
 *
 * Services (src/svc/ and any of your own) include this header and ub_node.h, never the core's
 * private headers, and never read or write ub_node_t fields: a check in ctest (ub_layer_check,
 * runtime_c/tools/check_layers.cmake) keeps it so. Everything a service originates goes through
 * the node's path (stamp, duplicate window, routing, security forms, tap, counters).
 *
 * Entities of this node are addressed by *local slot* here (0 .. UB_MAX_LOCAL_ENTITIES - 1, the
 * index a service's per-entity state uses); ub_node_slot_entity() and ub_node_entity_slot() convert
 * to and from entity-table indexes, which the rest of the public API uses.
 */
#ifndef UB_NODE_SVC_H
#define UB_NODE_SVC_H

#include <stdbool.h>
#include <stdint.h>
#include <string.h>
#include "ub_node.h"
#include "ub_service.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- set-up ----------------------------------------------------------------------------------- */

/**
 * Initialises the node core alone: the frame path (security gate, duplicate windows, forwarding,
 * DATA delivery, compact links, fragments, freshness challenges) with no protocol service.
 * ub_node_init() is this plus the built-in services every node runs (publish/subscribe and the
 * serving side of membership and inspection). `opt` is taken as given (publish/subscribe timing
 * defaults are ub_node_init()'s).
 * @return as ub_node_init().
 */
UB_CHECK int ub_node_core_init(ub_node_t *node, const ub_catalogue_t *cat, const ub_node_options_t *opt);

/* ---- entity IDs ------------------------------------------------------------------------------- */

/** Whether two 12-byte entity IDs are equal: two loads each (memcpy into integers), not a byte loop. The router
 *  compares IDs on every frame (destination, window, link-local address). */
static inline bool ub_entity_id_eq(const uint8_t a[UB_ENTITY_ID_LEN], const uint8_t b[UB_ENTITY_ID_LEN]) {
    uint64_t a0, b0;
    uint32_t a1, b1;
    memcpy(&a0, a, 8);
    memcpy(&b0, b, 8);
    memcpy(&a1, a + 8, 4);
    memcpy(&b1, b + 8, 4);
    return ((a0 ^ b0) | (uint64_t)(a1 ^ b1)) == 0;
}

/** @return whether an entity ID is all zero (the "no owner" marker). */
bool ub_entity_id_is_zero(const uint8_t id[UB_ENTITY_ID_LEN]);

/* ---- reading the node --------------------------------------------------------------------------- */

/** @return the catalogue the node was initialised with. */
const ub_catalogue_t *ub_node_catalogue(const ub_node_t *node);

/** @return the node's options, with the defaults filled in. */
const ub_node_options_t *ub_node_options(const ub_node_t *node);

/** @return the attached policy (ub_node_set_policy()), or NULL. */
const ub_policy_t *ub_node_policy(const ub_node_t *node);

/** @return the entity-table index of local slot `slot`, or -1 if the slot is free or out of range. */
int ub_node_slot_entity(const ub_node_t *node, int slot);

/** @return the local slot of entity-table index `entity`, or -1 (remote, free, out of range). */
int ub_node_entity_slot(const ub_node_t *node, int entity);

/** @return the link id of local slot `slot`'s link[`index`], or -1 (none, bad slot or index). */
int ub_node_slot_link(const ub_node_t *node, int slot, unsigned index);

/** @return local slot `slot`'s mask toward entity-table index `dest` (0 for bad indexes). */
uint8_t ub_node_slot_mask(const ub_node_t *node, int slot, int dest);

/** @return whether local slot `slot`'s mask toward `dest` was set by hand (pinned). */
bool ub_node_slot_pinned(const ub_node_t *node, int slot, int dest);

/* ---- state the node keeps for its services ------------------------------------------------------- */

/** @return the node-wide counters, writable: services count what they do there (ub_node_counters_t). */
ub_node_counters_t *ub_node_svc_counters(ub_node_t *node);

/** @return the publish/subscribe table of local slot `slot` (storage sized with the node), or NULL. */
ub_pubsub_table_t *ub_node_svc_pubsub_table(const ub_node_t *node, int slot);

/** @return the binding row of `instance` made with ub_node_bind() (its flags are the services'), or NULL. */
ub_binding_t *ub_node_svc_binding_row(const ub_node_t *node, uint32_t instance);

/** Counts a drop of `reason` on the node and, for a valid `link_id` (>= 0), on that link. */
void ub_node_svc_count_drop(ub_node_t *node, int link_id, ub_drop_reason_t reason);

/** A fresh request id: from ub_node_options_t.random, never 0 (docs/pubsub.md, "Replies bound to their row"). */
uint32_t ub_node_svc_new_request_id(ub_node_t *node);

/* ---- sending ------------------------------------------------------------------------------------ */

/**
 * Sends an admin frame from local slot `slot` to `dest_id`. `payload` is copied. Routing as for any
 * originated frame (to a local entity: handed over at once, before this returns).
 * @return links used (>= 0) or a negative error (UB_ERR_RANGE: len > UB_MAX_PAYLOAD; UB_ERR_NOROUTE).
 */
int ub_node_svc_send_admin(ub_node_t *node, int slot, ub_admin_code_t code, const uint8_t dir_id[UB_DIR_ID_LEN],
                           uint32_t fingerprint, const uint8_t dest_id[UB_ENTITY_ID_LEN], const uint8_t *payload,
                           uint16_t len, uint64_t now_ms);

/**
 * Sends ACK (`nack` false, `detail` = flags) or NACK (`detail` = reason, `origin` = UB_NACK_RELAYED or 0)
 * answering request `request_id` of admin code `code` (layout: ub_admin_wire.h).
 * @return as ub_node_svc_send_admin().
 */
int ub_node_svc_send_reply(ub_node_t *node, int slot, bool nack, const uint8_t dir_id[UB_DIR_ID_LEN],
                           const uint8_t dest_id[UB_ENTITY_ID_LEN], uint32_t request_id, uint8_t code, uint8_t detail,
                           uint8_t origin, uint64_t now_ms);

/** Originates DATA of `instance` from local slot `slot`; same returns as ub_node_send_data(). */
int ub_node_svc_send_data(ub_node_t *node, int slot, uint32_t instance, const uint8_t dest_id[UB_ENTITY_ID_LEN],
                          uint64_t now_ms);

#ifdef __cplusplus
}
#endif
#endif /* UB_NODE_SVC_H */
