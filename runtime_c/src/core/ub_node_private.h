/*
 * Core-private: the contract between the node core's own files (src/core/ub_node.c, ub_node_sec.c,
 * ub_node_wire.c, ub_node_svc.c). Not installed, not part of the API; symbols are prefixed ub_priv_.
 * Services never include this header (ub_node_svc.h is theirs; layer_check enforces it).
 *
 *   ub_node.c       set-up, the service table, routing of received and originated frames
 *   ub_node_sec.c   the security gate, duplicate / replay windows, freshness challenges (a core service)
 *   ub_node_wire.c  compact links and fragments: shaping for the links' encodings and MTUs
 *   ub_node_svc.c   the accessors and sending helpers of ub_node_svc.h
 */
#ifndef UB_NODE_PRIVATE_H
#define UB_NODE_PRIVATE_H

#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "ub/ub_admin_wire.h"
#include "ub/ub_frame.h"
#include "ub/ub_node.h"
#include "ub/ub_node_svc.h"

#define ub_priv_id_eq ub_entity_id_eq
#define ub_priv_id_is_zero ub_entity_id_is_zero
#define ub_priv_count_drop ub_node_svc_count_drop

/*
 * Originates the frame whose payload is at `frame + UB_FRAME_HEADER_LEN` (`cap` >= UB_FRAME_MAX)
 * from local slot `slot`: counter, source, hop limit, then local delivery or the links of the
 * slot's mask for h->dest_id in the form each link asks for. When no mask leads to the
 * destination, `fallback_link` (if >= 0 and owned by `slot`) is used: a challenge goes back where
 * the unverified frame came from. Returns links used (>= 0) or a negative error.
 */
int ub_priv_originate(ub_node_t *node, int slot, uint8_t *frame, size_t cap, ub_frame_header_t *h, int fallback_link,
                      uint64_t now_ms);

/* Originates DATA of any size (up to UB_MAX_DIRECTORY) from `slot` to local slot `dest_slot`, never as a frame:
 * stamped like any originated frame, then handed over. Returns 0 or a negative error. */
int ub_priv_originate_local(ub_node_t *node, int slot, int dest_slot, ub_frame_header_t *h, const uint8_t *payload,
                            uint64_t now_ms);

/* DATA reached local slot `slot` (link -1: from an entity of this node): content, policy, layout, binding,
 * unpack, the DATA observer (publish/subscribe), the delivery hook. */
void ub_priv_deliver_data(ub_node_t *node, int slot, int link_id, const ub_frame_header_t *h, const uint8_t *payload,
                          uint64_t now_ms);

/* The write policy for DATA received over a link: asks the DATA observer; refused without one when a
 * policy is attached (fail closed). */
bool ub_priv_may_write(const ub_node_t *node, int slot, uint32_t instance, const uint8_t src_id[UB_ENTITY_ID_LEN]);

/* ---- wire shaping (ub_node_wire.c) ---- */

/* Sends DATA of `instance` (bound at `storage`) when it is larger than a frame carries or than the MTU of a link
 * it leaves on: in fragments (or, to a local entity, whole). `*sent` false: not needed, the caller sends a plain
 * frame. Returns as ub_node_send_data(). */
int ub_priv_frag_send(ub_node_t *node, int slot, uint32_t instance, const void *storage,
                      const uint8_t dest_id[UB_ENTITY_ID_LEN], uint64_t now_ms, bool *sent);

/* The core's services for compact links (LINK_HELLO, link-local) and fragments (FRAGMENT), registered by
 * ub_node_core_init(). */
extern const ub_service_t ub_priv_compact_service;
extern const ub_service_t ub_priv_frag_service;

/* ---- security (ub_node_sec.c) ---- */

/* What the security gate established about a received frame. */
typedef struct ub_priv_rx {
    const uint8_t *payload; /* plaintext payload: in the frame, or the caller's buffer for ENCRYPTED */
    uint64_t counter;       /* 48-bit counter (secured) or the 32-bit sequence (unsigned) */
    bool secured;           /* the tag verified */
    bool origin;            /* the origin block verified (the seal service's open) */
} ub_priv_rx_t;

/*
 * Policy, key and tag of a CRC-valid frame received on `link_id`. ENCRYPTED payloads are decrypted
 * into `plain` (UB_MAX_PAYLOAD bytes). Returns false when the frame is dropped (counted).
 */
bool ub_priv_sec_gate(ub_node_t *node, int link_id, const ub_frame_header_t *h, const uint8_t *frame, size_t len,
                      uint8_t *plain, ub_priv_rx_t *rx);

typedef enum ub_priv_window {
    UB_PRIV_WINDOW_PASS = 0,   /* new: route it */
    UB_PRIV_WINDOW_DROPPED,    /* replay or unsigned-after-signed: counted */
    UB_PRIV_WINDOW_DUPLICATE,  /* a genuine frame already handled: counted */
    UB_PRIV_WINDOW_UNVERIFIED  /* authentic, source without freshness state: counted, challenge sent */
} ub_priv_window_t;

/* The duplicate / replay window of handling slot `slot` for the frame's source. */
ub_priv_window_t ub_priv_window_pass(ub_node_t *node, int slot, int link_id, const ub_frame_header_t *h,
                                     const ub_priv_rx_t *rx, uint64_t now_ms);

/* Enters an originated frame (seq / counter in `h`) in the originator's own window. */
void ub_priv_window_note_own(ub_node_t *node, int slot, const ub_frame_header_t *h, bool secured, uint64_t now_ms);

/* The freshness-challenge service (CHALLENGE / CHALLENGE_REPLY), registered by ub_node_core_init(). */
extern const ub_service_t ub_priv_sec_service;

#endif /* UB_NODE_PRIVATE_H */
