/*
 * Internal contract between ub_node.c, ub_pubsub.c and ub_admin.c. Not
 * installed, not part of the API; symbols are prefixed ub_priv_.
 *
 * Admin payload layouts (little-endian, documented byte by byte in
 * docs/pubsub.md). The frame header's dir_id names the content and its
 * fingerprint field carries the content type's fingerprint on requests.
 */
#ifndef UB_ROUTER_PRIVATE_H
#define UB_ROUTER_PRIVATE_H

#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "ub/ub_admin.h"
#include "ub/ub_frame.h"
#include "ub/ub_node.h"
#include "ub/ub_pubsub.h"

/* Largest admin payload. */
#define UB_PL_MAX_LEN 32u
/* PUB_REQUEST / SUB_REQUEST: request_id u32, period_ms u32, lease_ms u32, peer ID[12]. */
#define UB_PL_REQUEST_LEN 24u
#define UB_PL_REQUEST_ID 0u
#define UB_PL_REQUEST_PERIOD 4u
#define UB_PL_REQUEST_LEASE 8u
#define UB_PL_REQUEST_PEER 12u
/* PUB_STOP / SUB_STOP: request_id u32, peer ID[12]. */
#define UB_PL_STOP_LEN 16u
#define UB_PL_STOP_ID 0u
#define UB_PL_STOP_PEER 4u
/* ACK / NACK: request_id u32, code u8 (the admin code answered), flags (ACK) or reason (NACK) u8, NACK origin
 * flags u8 (UB_NACK_RELAYED; 0 in ACKs), reserved u8. */
#define UB_PL_REPLY_LEN 8u
#define UB_PL_REPLY_ID 0u
#define UB_PL_REPLY_CODE 4u
#define UB_PL_REPLY_DETAIL 5u
#define UB_PL_REPLY_FLAGS 6u

/* Local-entity slot of entity-table index `entity`, or -1 if it is not local. */
int ub_priv_local_slot(const ub_node_t *node, int entity);

/* A fresh request id for a row: from ub_node_options_t.random, never 0 (docs/pubsub.md, "Replies bound
 * to their row"). */
uint32_t ub_priv_new_request_id(ub_node_t *node);

/* Fills 0 fields of `t` with the defaults of ub_pubsub.h. */
void ub_priv_timing_defaults(ub_pubsub_timing_t *t);

/*
 * Sends an admin frame from local slot `slot` to `dest_id`. `payload` is
 * copied. Routing as for any originated frame.
 * Returns links used (>= 0) or a negative error.
 */
int ub_priv_send_admin(ub_node_t *node, int slot, ub_admin_code_t code, const uint8_t dir_id[UB_DIR_ID_LEN],
                       uint32_t fingerprint, const uint8_t dest_id[UB_ENTITY_ID_LEN], const uint8_t *payload,
                       uint16_t len, uint64_t now_ms);

/* Sends ACK (nack == false, detail = flags) or NACK (detail = reason, `origin` = UB_NACK_RELAYED or 0). */
int ub_priv_send_reply(ub_node_t *node, int slot, bool nack, const uint8_t dir_id[UB_DIR_ID_LEN],
                       const uint8_t dest_id[UB_ENTITY_ID_LEN], uint32_t request_id, uint8_t code, uint8_t detail,
                       uint8_t origin, uint64_t now_ms);

/* Originates DATA of `instance` from `slot`; same returns as ub_node_send_data(). */
int ub_priv_send_data_from_slot(ub_node_t *node, int slot, uint32_t instance, const uint8_t dest_id[UB_ENTITY_ID_LEN],
                                uint64_t now_ms);

struct ub_priv_rx; /* what the security gate established about a received frame (below) */

/*
 * An admin frame reached local slot `slot`, over a link (`rx`: what the
 * security gate established) or from another local entity (`rx` NULL).
 * Returns true when handled; false when the node must count it as dropped for
 * `*drop` (bad_payload: unusable; not_authorized: refused by the policy, a
 * NACK already sent).
 */
bool ub_priv_pubsub_on_admin(ub_node_t *node, int slot, const ub_frame_header_t *h, const uint8_t *payload,
                             const struct ub_priv_rx *rx, uint64_t now_ms, ub_drop_reason_t *drop);

/*
 * Write policy (ub_policy.h): may DATA of `instance` from `src_id`, received
 * over a link, be stored for local slot `slot`? True without a policy.
 */
bool ub_priv_pubsub_may_write(const ub_node_t *node, int slot, uint32_t instance,
                              const uint8_t src_id[UB_ENTITY_ID_LEN]);

/* DATA of `instance` from `src_id` was unpacked for local slot `slot`. */
void ub_priv_pubsub_on_data(ub_node_t *node, int slot, uint32_t instance, const uint8_t src_id[UB_ENTITY_ID_LEN],
                            uint64_t now_ms);

void ub_priv_pubsub_tick(ub_node_t *node, int slot, uint64_t now_ms);

/* Entity `id` is being removed from the node: rows of local slot `slot` whose peer it is are freed (returns how
 * many); rows it owns have their lease end now (their keeper decides). */
int ub_priv_pubsub_forget(ub_node_t *node, int slot, const uint8_t id[UB_ENTITY_ID_LEN], uint64_t now_ms);

/*
 * An ACK/NACK reached the administration table's entity. Returns true if it
 * answered one of its rows: same request id, sent by the row's target (the
 * source of a publication row, the destination of a subscription row), about
 * the row's content.
 */
bool ub_priv_admin_on_reply(ub_admin_t *adm, const ub_frame_header_t *h, uint32_t request_id, uint8_t code, bool nack,
                            uint8_t detail, uint8_t flags, uint64_t now_ms);

/* Entity `id` is being removed: rows whose target it is become INACTIVE at once (nobody to send a STOP to),
 * active rows naming it as the other end are deactivated (their STOP goes to the target). Returns how many. */
int ub_priv_admin_forget(ub_admin_t *adm, const uint8_t id[UB_ENTITY_ID_LEN], uint64_t now_ms);

/* Whether an activated row of `adm` brings `instance` from `src_id` to entity `dest_id`. */
bool ub_priv_admin_routes_to(const ub_admin_t *adm, uint32_t instance, const uint8_t src_id[UB_ENTITY_ID_LEN],
                             const uint8_t dest_id[UB_ENTITY_ID_LEN]);

void ub_priv_admin_tick(ub_admin_t *adm, uint64_t now_ms);

/* Whether two 12-byte entity IDs are equal: two loads each (memcpy into integers), not a byte loop. The router
 * compares IDs on every frame (destination, window, link-local address). */
static inline bool ub_priv_id_eq(const uint8_t a[UB_ENTITY_ID_LEN], const uint8_t b[UB_ENTITY_ID_LEN]) {
    uint64_t a0, b0;
    uint32_t a1, b1;
    memcpy(&a0, a, 8);
    memcpy(&b0, b, 8);
    memcpy(&a1, a + 8, 4);
    memcpy(&b1, b + 8, 4);
    return ((a0 ^ b0) | (uint64_t)(a1 ^ b1)) == 0;
}

/* Whether an entity ID is all zero (the "no owner" marker). */
bool ub_priv_id_is_zero(const uint8_t id[UB_ENTITY_ID_LEN]);

/* Counts a drop on the node and, for a valid `link_id`, on that link. */
void ub_priv_count_drop(ub_node_t *node, int link_id, ub_drop_reason_t reason);

/*
 * Originates the frame whose payload is at `frame + UB_FRAME_HEADER_LEN` (`cap` >= UB_FRAME_MAX)
 * from local slot `slot`: counter, source, hop limit, then local delivery or the links of the
 * slot's mask for h->dest_id in the form each link asks for. When no mask leads to the
 * destination, `fallback_link` (if >= 0 and owned by `slot`) is used: a challenge goes back where
 * the unverified frame came from. Returns links used (>= 0) or a negative error.
 */
int ub_priv_originate(ub_node_t *node, int slot, uint8_t *frame, size_t cap, ub_frame_header_t *h, int fallback_link,
                      uint64_t now_ms);

/* ---- wire glue (ub_node.c, ub_node_frag.c) ---- */

/* DATA reached local slot `slot` (link -1: from an entity of this node): content, policy, layout, binding,
 * unpack, subscription bookkeeping, the delivery hook. */
void ub_priv_deliver_data(ub_node_t *node, int slot, int link_id, const ub_frame_header_t *h, const uint8_t *payload,
                          uint64_t now_ms);

/* Sends DATA of `instance` (bound at `storage`) when it is larger than a frame carries or than the MTU of a link
 * it leaves on: in fragments (or, to a local entity, whole). `*sent` false: not needed, the caller sends a plain
 * frame. Returns as ub_node_send_data(). */
int ub_priv_frag_send(ub_node_t *node, int slot, uint32_t instance, const void *storage,
                      const uint8_t dest_id[UB_ENTITY_ID_LEN], uint64_t now_ms, bool *sent);

/* Originates DATA of any size (up to UB_MAX_DIRECTORY) from `slot` to local slot `dest_slot`, never as a frame:
 * stamped like any originated frame, then handed over. Returns 0 or a negative error. */
int ub_priv_originate_local(ub_node_t *node, int slot, int dest_slot, ub_frame_header_t *h, const uint8_t *payload,
                            uint64_t now_ms);

/* A FRAGMENT reached local slot `slot`. */
void ub_priv_frag_on_fragment(ub_node_t *node, int slot, int link_id, const ub_frame_header_t *h,
                              const uint8_t *payload, uint64_t now_ms);

/* Timeouts of reassemblies; transfers that were pushed back go on. */
void ub_priv_frag_tick(ub_node_t *node, uint64_t now_ms);

/* Compact links: their dictionaries follow the entity table; LINK_HELLO rounds go out when due. */
void ub_priv_compact_tick(ub_node_t *node, uint64_t now_ms);

/* ---- security glue (ub_node_sec.c) ---- */

/* What the security gate established about a received frame. */
typedef struct ub_priv_rx {
    const uint8_t *payload; /* plaintext payload: in the frame, or the caller's buffer for ENCRYPTED */
    uint64_t counter;       /* 48-bit counter (secured) or the 32-bit sequence (unsigned) */
    bool secured;           /* the tag verified */
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
void ub_priv_window_note_own(ub_node_t *node, int slot, const ub_frame_header_t *h, bool secured);

/* CHALLENGE / CHALLENGE_REPLY reached local slot `slot` (`rx` NULL: from an entity of this node). */
void ub_priv_sec_on_admin(ub_node_t *node, int slot, int link_id, const ub_frame_header_t *h, const uint8_t *payload,
                          const ub_priv_rx_t *rx, uint64_t now_ms);

/* Resends unanswered challenges (at most UB_SEC_CHALLENGE_TRIES per frame of their source). */
void ub_priv_sec_tick(ub_node_t *node, uint64_t now_ms);

#endif /* UB_ROUTER_PRIVATE_H */
