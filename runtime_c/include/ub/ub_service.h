/**
 * @file ub_service.h
 * @brief The service contract: how a protocol engine plugs into a node (docs/architecture.md,
 *        "A new protocol service in five steps").
 *
 * The node core (src/core/) carries frames: it verifies them (the security gate), suppresses
 * duplicates, forwards, delivers DATA into bound storage, shapes frames for compact links and MTUs
 * and reassembles fragments. Everything else a frame can ask for is a *service*: publish/subscribe,
 * administration, routing, membership, inspection, freshness challenges, or one of your own. A
 * service declares
 *  - the admin codes it handles when they reach one of the node's local entities (`codes`),
 *  - the replies it takes: ACK/NACK frames whose payload names an admin code it sent
 *    (`reply_codes`: the answered code, UB_PL_REPLY_CODE of ub_admin_wire.h),
 *  - the codes it accepts link-local (`link_local_codes`: addressed to "whoever is at the other
 *    end of this link", never forwarded; docs/routing.md),
 * and callbacks for a frame, a reply, a tick, an entity or a link being forgotten, and a mask set
 * by hand. A callback left NULL is not called.
 *
 * The record is caller-owned (embed it in the engine's own state, or make it `static const` when
 * the service keeps no state of its own) and must outlive its registration; the node keeps a
 * pointer in a fixed table (UB_MAX_SERVICES). ub_node_add_service() refuses a code another
 * registered service already takes, so two engines can never both answer one request.
 *
 * Callbacks may send, change masks and tables, but must not add or remove services (the node is
 * walking its table). A service acts on the node only through the public headers (ub_node.h, ub_node_svc.h): every
 * frame it originates takes the node's path (stamp, window, routing, security, tap).
 *
 * Ordering: services tick, and hear about forgotten entities and links, in ascending `order`
 * (ties: registration order). The built-in engines use the UB_SVC_ORDER_* values below, which
 * reproduce the order the node called them in before it had services; a new service takes
 * UB_SVC_ORDER_USER unless it must run earlier.
 */
#ifndef UB_SERVICE_H
#define UB_SERVICE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "ub_config.h"
#include "ub_error.h"
#include "ub_frame.h"
#include "ub_link.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ub_node ub_node_t;
typedef struct ub_service ub_service_t;

/** Tick / forget order of the built-in services (lower first). */
enum {
    UB_SVC_ORDER_PUBSUB = 10,  /**< publish/subscribe tables (and their administration tables) */
    UB_SVC_ORDER_ROUTE = 20,   /**< routing engine (ub_route.h) */
    UB_SVC_ORDER_MEMBER = 30,  /**< membership (ub_member.h) */
    UB_SVC_ORDER_INSPECT = 40, /**< inspection (ub_inspect.h) */
    UB_SVC_ORDER_USER = 100    /**< services of the application */
};

/** Where a frame handed to a service came from. */
typedef struct ub_service_rx {
    int slot;         /**< local slot of the entity it reached (ub_node_slot_entity(), ub_node_svc.h) */
    int link_id;      /**< the link it arrived on, or -1: from an entity of this node (never left the process) */
    bool secured;     /**< its tag verified (SIGNED or ENCRYPTED); false for local frames */
    uint64_t counter; /**< its freshness counter (48-bit secured, else the 32-bit sequence); 0 when local */
    bool origin;      /**< its origin block verified for this destination (the seal service's `open`, below): the
                           source entity itself sent it, not merely a group-key holder; false for local frames */
} ub_service_rx_t;

/** An ACK or NACK, decoded (its layout: ub_admin_wire.h). */
typedef struct ub_service_reply {
    uint32_t request_id; /**< the request it answers */
    uint8_t code;        /**< the admin code of that request */
    bool nack;           /**< NACK (refused) rather than ACK */
    uint8_t detail;      /**< ACK flags or NACK reason */
    uint8_t flags;       /**< NACK origin flags (UB_NACK_RELAYED); 0 in ACKs */
} ub_service_reply_t;

/**
 * A frame with one of the service's codes reached a local entity (`rx->slot`), or arrived
 * link-local on `rx->link_id` with one of its link-local codes (then `rx->slot` is the link's
 * owner). `payload` holds `h->payload_size` plaintext bytes. Return true when handled; false makes
 * the node count a drop of reason `*drop` (preset to UB_DROP_BAD_PAYLOAD) on the node and the link.
 */
typedef bool (*ub_service_frame_fn)(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx,
                                    const ub_frame_header_t *h, const uint8_t *payload, uint64_t now_ms,
                                    ub_drop_reason_t *drop);

/** An ACK/NACK answering one of the service's `reply_codes` reached local slot `rx->slot`. Returns as
 *  ub_service_frame_fn. */
typedef bool (*ub_service_reply_fn)(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx,
                                    const ub_frame_header_t *h, const ub_service_reply_t *reply, uint64_t now_ms,
                                    ub_drop_reason_t *drop);

/** Timers and sending; called from ub_node_tick(). */
typedef void (*ub_service_tick_fn)(const ub_service_t *svc, ub_node_t *node, uint64_t now_ms);

/** Entity-table row `entity` (ID `id`) is being removed (ub_node_remove_entity()): forget it. The row is
 *  still in the table during the call. */
typedef void (*ub_service_forget_entity_fn)(const ub_service_t *svc, ub_node_t *node, int entity,
                                            const uint8_t id[UB_ENTITY_ID_LEN], uint64_t now_ms);

/** Link `link_id` is being removed (ub_node_remove_link()); still readable with ub_node_link() during the call. */
typedef void (*ub_service_forget_link_fn)(const ub_service_t *svc, ub_node_t *node, int link_id, uint64_t now_ms);

/** Local slot `slot` set a mask by hand (ub_node_set_mask()). */
typedef void (*ub_service_mask_fn)(const ub_service_t *svc, ub_node_t *node, int slot);

/** Transport evidence about a link (ub_node_link_event()): what a driver or the frame path saw. */
typedef enum ub_link_event {
    /** The transport says the link is gone: a TCP connection reset or closed, a serial line hung up, ICMP
     *  "unreachable" (ECONNREFUSED) on a connected UDP socket, a send that failed outright. Nothing will cross
     *  the link until it comes back; a service may stop using it now instead of waiting for its own timers. */
    UB_LINK_EVENT_DOWN = 0,
    /** The transport is back (a TCP connection up again, a serial device reopened): frames may cross it. */
    UB_LINK_EVENT_UP = 1
} ub_link_event_t;

/** Link `link_id` had transport evidence `ev` (ub_node_link_event()). */
typedef void (*ub_service_link_event_fn)(const ub_service_t *svc, ub_node_t *node, int link_id, ub_link_event_t ev,
                                         uint64_t now_ms);

/** When the service's tick next has work: true with `*due_ms` set (a time <= now_ms: at once), false when it
 *  has no timer (only a frame can give it work). ub_node_next_due() takes the earliest over the services. */
typedef bool (*ub_service_next_due_fn)(const ub_service_t *svc, const ub_node_t *node, uint64_t now_ms,
                                       uint64_t *due_ms);

/** DATA write policy (ub_policy.h): may DATA of `instance` from `src_id`, received over a link, be stored
 *  for local slot `slot`? Asked only when a policy is attached (without a service answering it, such DATA
 *  is refused: fail closed). */
typedef bool (*ub_service_may_write_fn)(const ub_service_t *svc, const ub_node_t *node, int slot, uint32_t instance,
                                        const uint8_t src_id[UB_ENTITY_ID_LEN]);

/** DATA of `instance` from `src_id` was unpacked into its storage for local slot `slot` (before the
 *  delivery hook, ub_node_set_deliver_hook()). */
typedef void (*ub_service_data_fn)(const ub_service_t *svc, ub_node_t *node, int slot, uint32_t instance,
                                   const uint8_t src_id[UB_ENTITY_ID_LEN], uint64_t now_ms);

/**
 * Sealing (an end-to-end origin block, UB_FRAME_FLAG_ORIGIN; docs/security.md, "Origin authentication").
 * Called for every protected frame local slot `slot` originates towards a remote destination (`h` stamped:
 * source, counter, key id, hop limit; flags not yet set), with its plaintext payload. Fill
 * h->origin_hop0 and h->origin_tag and return 1 to send the frame with an origin block; return 0 to send it
 * without (e.g. link-local); return a negative error to refuse the frame, with `*drop` the reason counted.
 */
typedef int (*ub_service_seal_fn)(const ub_service_t *svc, ub_node_t *node, int slot, ub_frame_header_t *h,
                                  const uint8_t *payload, uint64_t now_ms, ub_drop_reason_t *drop);

/**
 * Opening: a frame that passed the hop tag reached local slot `rx->slot` over link `rx->link_id`, before
 * its window. `h` carries the origin block when h->flags has UB_FRAME_FLAG_ORIGIN. Return true to let it on
 * (set `*origin` when the block verified); false drops it, counted as `*drop`.
 */
typedef bool (*ub_service_open_fn)(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx,
                                   const ub_frame_header_t *h, const uint8_t *payload, uint64_t now_ms, bool *origin,
                                   ub_drop_reason_t *drop);

/** A service's registration record (caller-owned; see the file comment). */
struct ub_service {
    const char *name;                /**< for diagnostics ("route", "echo"...) */
    const uint8_t *codes;            /**< admin codes handled when addressed to a local entity */
    uint8_t n_codes;
    const uint8_t *reply_codes;      /**< answered codes of the ACK/NACKs it takes */
    uint8_t n_reply_codes;
    const uint8_t *link_local_codes; /**< codes accepted link-local */
    uint8_t n_link_local_codes;
    /** Its link-local frames prove themselves (an authority's signature over the payload, checked by the
     *  service) and are idempotent (a replay changes nothing): taken from a signed source this node holds no
     *  freshness state for, without challenging it first. The revocation service's certificates and
     *  revocations: a re-keyed entity must be learned before its frames -- its challenge replies included --
     *  can pass origin authentication (docs/security.md, "Revocation"). */
    bool link_local_self_proving;
    uint8_t order;                   /**< UB_SVC_ORDER_* */
    ub_service_frame_fn on_frame;
    ub_service_reply_fn on_reply;
    ub_service_tick_fn tick;
    ub_service_forget_entity_fn forget_entity;
    ub_service_forget_link_fn forget_link;
    ub_service_mask_fn mask_set;
    /** DATA observers (publish/subscribe: subscriptions, write policy); at most one registered service has
     *  them (ub_node_add_service() refuses a second: UB_ERR_EXISTS). */
    ub_service_may_write_fn may_write;
    ub_service_data_fn on_data;
    /** Origin sealing and opening (above); at most one registered service has them (UB_ERR_EXISTS). */
    ub_service_seal_fn seal;
    ub_service_open_fn open;
    /** Transport evidence about a link (above); NULL: not interested. */
    ub_service_link_event_fn link_event;
    /** Next due time of `tick` (above). NULL with a `tick`: the node assumes it is due every millisecond (it is
     *  polled, as before this hook existed). */
    ub_service_next_due_fn next_due;
    void *user;                      /**< the engine's state, for the callbacks */
};

/**
 * Registers `svc` with `node`. Admin codes DATA and FRAGMENT belong to the core and the ACK/NACK
 * codes themselves are routed by `reply_codes`, so none of them may appear in `codes` except as the
 * one default taker of replies no service claims (publish/subscribe).
 * @return UB_OK; UB_ERR_INVAL (NULL, a core code); UB_ERR_EXISTS (`svc` is registered already, or one
 *         of its codes, reply codes or link-local codes is taken by another service); UB_ERR_FULL
 *         (UB_MAX_SERVICES).
 */
UB_CHECK int ub_node_add_service(ub_node_t *node, const ub_service_t *svc);

/**
 * Unregisters `svc`: its codes are free again, its callbacks no longer called.
 * @return UB_OK; UB_ERR_INVAL (NULL); UB_ERR_NOTFOUND (not registered).
 */
UB_CHECK int ub_node_remove_service(ub_node_t *node, const ub_service_t *svc);

/**
 * Hands transport evidence about link `link_id` to every registered service that takes it (`link_event`), in
 * their order. Drivers call it (ub_driver.h: TCP reset/close, serial hang-up, UDP ECONNREFUSED); the node calls
 * it itself when a transport's send fails outright (UB_DROP_TX_ERROR, not backpressure). The core names no
 * service: what the evidence means (a route switched, a queue flushed) is each service's business.
 * Ignored for a bad link id.
 */
void ub_node_link_event(ub_node_t *node, int link_id, ub_link_event_t ev, uint64_t now_ms);

/**
 * The earliest time ub_node_tick() has work: the minimum over the services' `next_due` answers (a service with a
 * tick but no `next_due` counts as due at `now_ms` + 1: polled every millisecond). Frames arriving earlier are handled by the receive path
 * whatever this says; a caller sleeps until min(this, its own timers, input). Returns UINT64_MAX when nothing
 * is due ever (no ticking service). Exact: calling ub_node_tick() earlier does nothing a later call would not
 * (except what a service lets go early by choice: a routing engine with `coalesce_ms` sends a hello due within
 * that slack in the current tick, ub_route.h).
 */
uint64_t ub_node_next_due(const ub_node_t *node, uint64_t now_ms);

/** Which of a service's lists ub_node_service_for() looks in. */
typedef enum ub_service_kind {
    UB_SVC_CODE = 0,       /**< `codes` */
    UB_SVC_REPLY = 1,      /**< `reply_codes` */
    UB_SVC_LINK_LOCAL = 2  /**< `link_local_codes` */
} ub_service_kind_t;

/** @return the registered service taking admin code `code` as `kind`, or NULL. */
const ub_service_t *ub_node_service_for(const ub_node_t *node, ub_service_kind_t kind, uint8_t code);

#ifdef __cplusplus
}
#endif
#endif /* UB_SERVICE_H */
