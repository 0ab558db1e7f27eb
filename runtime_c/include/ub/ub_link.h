/**
 * @file ub_link.h
 * @brief The one interface every transport implements, the per-link counters,
 *        and the paper's link-mask notation.
 *
 * A **link** is a slot in a node (`ub_link_t`, owned by the node, addressed by
 * a stable `link_id`). It belongs to exactly one local entity, at an index
 * `0..7` of that entity's `link[]` array, and has a name ("onboardPortIPC").
 * Behind the slot sits a **transport**: a vtable plus an opaque `impl`
 * pointer. Drivers only move bytes:
 *
 *  - outbound, the node calls `ops->send(impl, frame, len, now_ms)` with one
 *    whole, verified frame;
 *  - inbound, the driver hands bytes to the node with ub_node_rx() (stream
 *    transports: TCP, serial; the slot's decoder finds the frames) or
 *    ub_node_rx_frame() (datagram transports: UDP, the in-memory link).
 *
 * Because the node refers to links only through slots, the transport behind a
 * slot can be replaced at run time with ub_node_link_attach() (e.g. the
 * paper's "software switch" from a memory link to Ethernet) without touching
 * entity tables, masks or publish/subscribe state.
 *
 * Link masks (paper III.D): bit i set means "send over this entity's link[i]".
 * The paper writes them in hexadecimal with one digit per link, each digit 0 or
 * 1 (`0x00000110` = links 1 and 2); ub_link_mask_parse() reads that notation.
 */
#ifndef UB_LINK_H
#define UB_LINK_H

#include <stddef.h>
#include <stdint.h>
#include "ub_config.h"
#include "ub_error.h"
#include "ub_frame.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Longest link name, including the terminating NUL. */
#define UB_LINK_NAME_LEN 32

/** Why the router dropped a verified frame; indexes the `drops[]` counters. */
typedef enum ub_drop_reason {
    UB_DROP_NO_ROUTE = 0,    /**< destination unknown, or no link left after removing the ingress */
    UB_DROP_HOP_LIMIT,       /**< forwarding would send hop limit 0 */
    UB_DROP_DUPLICATE,       /**< (source, sequence) already seen by the handling entity */
    UB_DROP_LAYOUT_MISMATCH, /**< DATA fingerprint or size differs from the local catalogue */
    UB_DROP_UNKNOWN_CONTENT, /**< DATA or request for a content ID not in the local catalogue */
    UB_DROP_UNBOUND,         /**< DATA for an instance this node did not bind */
    UB_DROP_BAD_PAYLOAD,     /**< admin payload too short / invalid, or unknown admin code */
    UB_DROP_TX_ERROR,        /**< the transport's send failed (UB_ERR_IO, UB_ERR_CLOSED, ...) */
    UB_DROP_BACKPRESSURE,    /**< the transport's send returned UB_ERR_AGAIN or its queue is full */
    UB_DROP_DETACHED,        /**< the slot has no transport attached */
    UB_DROP_NOT_ALLOWED,     /**< DATA the destination's write policy refuses (ub_policy.h), storage untouched */
    UB_DROP_NOT_AUTHORIZED,  /**< admin request or STOP the policy refuses to its source (NACK NOT_AUTHORIZED sent) */
    UB_DROP_ROUTING_OFF,     /**< a routing frame (HELLO, ROUTE_UPDATE) reached a node not running ub_route (no service
                                  registered for the code link-local) */
    /* Security (docs/security.md). Received frames are checked in this order, before any state is touched. */
    UB_DROP_UNSIGNED,        /**< not protected as the node/link requires (no trailer where signing is required,
                                  SIGNED where ENCRYPTED is required, unsigned from a source already seen signed),
                                  or an unsigned frame for an encrypting link */
    UB_DROP_BAD_TAG,         /**< CRC-valid flagged frame whose tag does not verify: a forgery or a wrong key */
    UB_DROP_UNKNOWN_KEY,     /**< key id not in the keyring (or no security here); or no key to sign for an encrypting link */
    UB_DROP_REPLAY,          /**< counter behind the replay window, or a challenge reply bound to no outstanding challenge */
    UB_DROP_UNVERIFIED,      /**< authentic, but no freshness state for its source yet: dropped while a challenge runs */
    /* Wire (docs/wire-format.md, "Compact encoding" and "Fragments"). */
    UB_DROP_TOO_BIG,         /**< larger than the outgoing link's MTU (forwarders never fragment), or a directory above the
                                  payload limit at a node without fragment state (ub_node_set_frag()) */
    UB_DROP_INCOMPLETE,      /**< a fragmented directory given up: fragments missing at its timeout, or its slot taken */
    UB_DROP_COUNTER_JUMP,    /**< secured frame whose counter is further ahead than its source could have counted since it
                                  last proved its counter (ub_sec_jump_limit()): moves no window; the source is challenged */
    /* Origin authentication (ub_origin.h; docs/security.md, "Origin authentication"). */
    UB_DROP_BAD_ORIGIN,      /**< origin tag wrong for its source and destination, or hop limit above the origin's */
    UB_DROP_NO_ORIGIN,       /**< no origin block where the destination requires one */
    UB_DROP_NO_IDENTITY,     /**< the peer's identity is unknown, revoked or expired (the identity store refused it) */
    /* Priorities on slow links (ub_prio.h). */
    UB_DROP_SHED,            /**< an older telemetry frame a byte-budget link dropped from its full telemetry queue to take a
                                  newer one (ub_link_ops_t.send_class returned how many) */
    UB_DROP_REASON_COUNT
} ub_drop_reason_t;

/** @return a static name for a drop reason ("no_route", ...), or "?" when out of range. */
const char *ub_drop_reason_name(ub_drop_reason_t reason);

/** Counters of one link slot. They survive ub_node_link_attach(). */
typedef struct ub_link_counters {
    uint64_t frames_in;  /**< CRC-verified frames received (before the security checks) */
    uint64_t frames_accepted; /**< received frames that passed the security checks and were not duplicates or replays */
    uint64_t bytes_in;   /**< bytes handed to ub_node_rx()/ub_node_rx_frame() */
    uint64_t frames_out; /**< frames the transport accepted */
    uint64_t bytes_out;  /**< bytes the transport accepted */
    /** Datagrams rejected by ub_node_rx_frame(), by decoder reason. Stream
     *  rejections are in the slot decoder's stats (see ub_node_link_bad_frames()). */
    uint64_t bad_datagrams[UB_RX_REASON_COUNT];
    /** Frames dropped, counted on the link they arrived on (receive side) or
     *  were to leave on (TX_ERROR, BACKPRESSURE, DETACHED). */
    uint64_t drops[UB_DROP_REASON_COUNT];
} ub_link_counters_t;

/**
 * What a transport provides. All functions receive the `impl` pointer given
 * to ub_node_link_attach().
 */
typedef struct ub_link_ops {
    /** Short transport kind for diagnostics: "mem", "udp", "tcp", "serial". */
    const char *kind;
    /**
     * Sends one whole frame (`len` bytes, already verified and finished).
     * Must not call back into the node synchronously (queue instead).
     * @return UB_OK; UB_ERR_AGAIN when the transport cannot take it now
     *         (counted as backpressure); UB_ERR_NOROUTE when it has nowhere to
     *         send yet, e.g. a UDP link still waiting to learn its peer
     *         (counted as no_route); any other negative code on failure
     *         (counted as tx_error).
     */
    int (*send)(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms);
    /** @return a pollable file descriptor, or -1 if the transport has none. May be NULL (= -1). */
    int (*fileno)(void *impl);
    /**
     * Optional: send() with the frame's priority class (ub_prio.h), for a transport that queues by class
     * (a byte-budget link). When set, the node calls it instead of send(), with the class it derived from
     * the full frame (before any compact encoding). Same contract as send(), except that a positive return
     * means "taken, and that many older telemetry frames were dropped from the queue to make room": the
     * node counts them `shed` on the link. NULL: the node calls send().
     */
    int (*send_class)(void *impl, const uint8_t *frame, size_t len, uint8_t cls, uint64_t now_ms);
    /**
     * Optional: send() of a frame being forwarded, with its hop limit set to `hop_limit` on the way: the
     * transport writes ub_frame_copy_hop_limit(dst, frame, len, hop_limit, memo) straight into its own buffer,
     * so a forward costs one copy instead of two (into the node's buffer, then the transport's). `frame` is a
     * verified frame (its checks patched, never recomputed); `memo` is the node's. Same returns as send(). The
     * node uses it only for a link without compact encoding, MTU or classes, taking the form the frame came in,
     * with no tap attached (which is handed the frame sent). NULL: the node patches a copy and calls send().
     */
    int (*send_hop)(void *impl, const uint8_t *frame, size_t len, uint8_t hop_limit, ub_frame_hop_memo_t *memo,
                    uint64_t now_ms);
} ub_link_ops_t;

/** One link slot of a node. Owned by ub_node_t; treat the fields as read-only. */
typedef struct ub_link {
    char name[UB_LINK_NAME_LEN];
    uint8_t in_use;
    uint8_t owner;      /**< local entity slot that owns this link */
    uint8_t index;      /**< position in the owner's link[] (bit `index` of its masks) */
    const ub_link_ops_t *ops; /**< NULL while detached */
    void *impl;
    ub_decoder_t decoder; /**< stream reassembly for ub_node_rx(); reset on attach */
    int8_t require_signed; /**< receive policy: 1 require protected frames, 0 accept unsigned, -1 the node's policy */
    uint8_t encrypt;       /**< send only ENCRYPTED frames; when signing is required, accept only those */
    uint16_t mtu;          /**< largest frame on the wire (bytes, after encoding); 0: no limit (ub_node_link_set_mtu()) */
    struct ub_compact *compact; /**< compact encoding state (ub_compact.h), or NULL: full frames */
    ub_link_counters_t counters;
} ub_link_t;

/**
 * Parses a link mask in the paper's notation: "0x" then hex digits, each 0 or
 * 1, the rightmost digit being link[0]; 1 to 16 digits. Leading zeros beyond 8 digits are
 * accepted (the paper's Figure 8 prints "0x000000011"); a 1 in a digit
 * position >= UB_MAX_LINKS_PER_ENTITY is refused.
 * Examples: "0x00000110" -> 0x06 (links 1, 2); "0x00000011" -> 0x03.
 * @return UB_OK, or UB_ERR_INVAL (NULL, no "0x", empty, a digit other than 0/1,
 *         trailing characters) or UB_ERR_RANGE (a link index too high).
 */
UB_CHECK int ub_link_mask_parse(const char *text, uint8_t *mask);

/**
 * Formats a mask in the paper's notation, always "0x" + 8 digits
 * (0x06 -> "0x00000110"). `out` must hold at least 11 bytes.
 */
void ub_link_mask_format(uint8_t mask, char out[11]);

/** @return the transport's descriptor, or -1 if detached or the transport has none. */
int ub_link_fileno(const ub_link_t *link);

#ifdef __cplusplus
}
#endif
#endif /* UB_LINK_H */
