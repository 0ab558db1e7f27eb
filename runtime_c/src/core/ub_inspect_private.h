/*
 * Internal contract between ub_node.c and remote inspection (ub_inspect.c). Not installed; symbols are
 * prefixed ub_priv_. The node calls these hooks; ub_inspect.c acts on the node through its public API and
 * the send helpers of ub_router_private.h, so every frame it originates takes the node's path.
 */
#ifndef UB_INSPECT_PRIVATE_H
#define UB_INSPECT_PRIVATE_H

#include <stdbool.h>
#include <stdint.h>

#include "ub/ub_frame.h"
#include "ub/ub_node.h"

/* An INSPECT request reached local slot `slot` (`from_link`: over a link, so the policy judges it;
 * `secured`: its tag verified). Answers it (value, ACK or NACK). Returns false when the node must count a
 * drop of reason `*drop`: an unusable payload (bad_payload, nothing answered) or a refused requester
 * (not_authorized, NACK sent). */
bool ub_priv_inspect_on_request(ub_node_t *node, int slot, const ub_frame_header_t *h, const uint8_t *payload,
                                bool from_link, bool secured, uint64_t now_ms, ub_drop_reason_t *drop);

/* An ACK/NACK answering an INSPECT request reached local slot `slot`. */
void ub_priv_inspect_on_reply(ub_node_t *node, int slot, const uint8_t src_id[UB_ENTITY_ID_LEN], uint32_t request_id,
                              bool nack, uint8_t detail, uint64_t now_ms);

/* An INSPECT_VALUE reached local slot `slot`. Returns false for an unusable payload (bad_payload). */
bool ub_priv_inspect_on_value(ub_node_t *node, int slot, const ub_frame_header_t *h, const uint8_t *payload,
                              uint64_t now_ms);

void ub_priv_inspect_tick(struct ub_inspect *in, uint64_t now_ms);

#endif /* UB_INSPECT_PRIVATE_H */
