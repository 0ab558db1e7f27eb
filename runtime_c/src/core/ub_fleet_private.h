/*
 * Internal contract between ub_node.c and the fleet concerns: the routing
 * engine (ub_route.c) and the membership protocol (ub_member.c). Not
 * installed; symbols are prefixed ub_priv_. The node calls these hooks; the
 * engines act on the node only through its public API (ub_node.h) and the
 * send helper below, so every frame they originate takes the node's path.
 */
#ifndef UB_FLEET_PRIVATE_H
#define UB_FLEET_PRIVATE_H

#include <stdbool.h>
#include <stdint.h>

#include "ub/ub_frame.h"
#include "ub/ub_node.h"

/* Entity-table index of local slot `slot`, or -1 if the slot is free. */
int ub_priv_slot_entity(const ub_node_t *node, int slot);

/* ---- routing engine (ub_route.c) ------------------------------------------------------------------ */

/* A link-local routing frame (HELLO or ROUTE_UPDATE) arrived on `link_id`, past the duplicate window.
 * Returns UB_OK, or a negative error when the payload is unusable (the node counts bad_payload). */
int ub_priv_route_on_frame(struct ub_route *rt, int link_id, const ub_frame_header_t *h, const uint8_t *payload,
                           uint64_t now_ms);

/* Timers and sending; called from ub_node_tick(). */
void ub_priv_route_tick(struct ub_route *rt, uint64_t now_ms);

/* Entity-table row `entity` is being removed, with this ID: forget every route, feasibility distance
 * and request about it, and do not learn it again for a while. */
void ub_priv_route_forget_entity(struct ub_route *rt, int entity, const uint8_t id[UB_ENTITY_ID_LEN], uint64_t now_ms);

/* Local slot `slot` set a mask by hand (pinned or unpinned): choose its routes again at the next tick, so
 * an unpinned entry is filled at once. */
void ub_priv_route_mask_set(struct ub_route *rt, int slot);

/* Link slot `link_id` is being removed: forget its neighbour and the routes through it. */
void ub_priv_route_forget_link(struct ub_route *rt, int link_id, uint64_t now_ms);

/* ---- membership (ub_member.c) --------------------------------------------------------------------- */

/* A MEMBERSHIP request reached local slot `slot` over a link (`rx`, from the security gate: the policy
 * judges it, ub_node_may_administer()) or from a local entity (`rx` NULL). Returns false when the node
 * must count a drop, of reason `*drop`: an unusable payload (bad_payload, nothing answered) or a refused
 * requester (not_authorized, NACK sent). */
struct ub_priv_rx;
bool ub_priv_member_on_request(ub_node_t *node, int slot, const ub_frame_header_t *h, const uint8_t *payload,
                               const struct ub_priv_rx *rx, uint64_t now_ms, ub_drop_reason_t *drop);

/* An ACK/NACK answering a MEMBERSHIP request reached local slot `slot`. */
void ub_priv_member_on_reply(ub_node_t *node, int slot, const uint8_t src_id[UB_ENTITY_ID_LEN], uint32_t request_id,
                             bool nack, uint8_t detail, uint64_t now_ms);

void ub_priv_member_tick(struct ub_member *m, uint64_t now_ms);

#endif /* UB_FLEET_PRIVATE_H */
