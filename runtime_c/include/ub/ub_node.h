/**
 * @file ub_node.h
 * @brief A node: one process's router (paper III.B, III.D, III.E). Entity
 *        table, local entities with their links and link masks, duplicate
 *        suppression, multi-hop forwarding, bindings of directory instances to
 *        storage, and the publish/subscribe tables of its local entities.
 *
 * All state lives in the caller-owned ub_node_t (size fixed by ub_config.h):
 * no allocation, no globals, so any number of nodes run in one process.
 *
 * Set-up (what a node configuration applies, in this order):
 *
 *     ub_node_t node;                                         // every call below returns
 *     ub_node_init(&node, &fsw_catalogue, NULL);              // an error code: check it
 *     int e0 = ub_node_add_entity(&node, id_e0, true);        // local entity
 *     int e1 = ub_node_add_entity(&node, id_e1, false);       // known remote entity
 *     int l  = ub_node_add_link(&node, e0, 0, "e0Toe1");      // e0's link[0]
 *     ub_node_set_mask(&node, e0, e1, 0x01);                  // "0x00000001"
 *     ub_node_link_attach(&node, l, &my_udp_ops, &my_udp);    // any transport
 *     ub_node_bind(&node, instance_index, &gpsOut);           // local storage
 *
 * Run: feed received bytes with ub_node_rx()/ub_node_rx_frame(), and call
 * ub_node_tick(&node, now_ms) periodically. Time is only ever passed in.
 *
 * Routing (docs/architecture.md, "Nodes, entities and links"):
 *  - **Originate** (local entity S sends to D): D local -> delivered directly;
 *    otherwise sent on every link of S's mask for D; none -> drop `no_route`.
 *    The frame's (S, seq) is entered in S's duplicate window, so a copy that
 *    loops back to S is cut.
 *  - **Receive** on link L owned by local entity R: the frame is verified,
 *    then checked against a duplicate window. The window belongs to the
 *    *handling* entity: D when D is local (so two copies over a 0x11 pair
 *    deliver once), R otherwise (so entities of one node that forward to each
 *    other over a real link each forward once). D local -> deliver. Otherwise
 *    forward on R's mask for D minus L with hop limit - 1; D unknown or no
 *    link left -> `no_route`; hop limit would reach 0 -> `hop_limit`.
 *    Forwarders never look at the content ID.
 *  - **Deliver** DATA: catalogue lookup (`unknown_content`), the write policy
 *    when one is attached and the frame came over a link (`not_allowed`,
 *    ub_policy.h), fingerprint and payload size check (`layout_mismatch`,
 *    storage never written), binding (`unbound`), unpack, then the
 *    subscription bookkeeping and the delivery hook. Admin frames go to the
 *    service registered for their code (ub_service.h): an ACK/NACK to the one
 *    taking replies to the code it answers (the publish/subscribe tables and
 *    their administration tables apply the policy to requests and STOPs and
 *    bind replies to their rows); a code nobody takes is dropped `bad_payload`.
 *
 * Link-local frames (docs/routing.md): a frame whose destination ID is
 * UB_LINK_LOCAL_ID (twelve 0xFF bytes, never an entity) is addressed to
 * "whichever entity is at the other end of this link". It is originated on
 * exactly one link with ub_node_send_link_local() (hop limit 1), handled by
 * the owner of the link it arrived on, and never forwarded, whatever its hop
 * limit. The routing codes (HELLO, ROUTE_UPDATE), LINK_HELLO and codes a
 * service registered link-local use it; anything else sent link-local is
 * dropped `bad_payload`, and routing frames reaching a node without a routing
 * engine are dropped `routing_off`.
 *
 * Membership at run time: entities, links and masks can be added and removed
 * while the node runs. ub_node_remove_entity() clears everything that named
 * the entity (masks, duplicate windows, routing state) and stops the
 * publish/subscribe and administration rows naming it through their own API.
 * Over the bus, MEMBERSHIP requests (ub_member.h) do the same.
 *
 * Masks are *manual* (ub_node_set_mask(): a non-zero mask pins the entry) or
 * *automatic* (ub_node_set_auto_mask(), written by the routing engine of
 * ub_route.h, never over a pinned entry).
 *
 * Duplicate window: per (handling entity, source entity) the highest sequence
 * seen and a 64-bit bitmap below it (UB_DEDUP_WINDOW). A sequence more than the
 * window behind is taken as a restarted source: the window resets to it and
 * the frame is accepted (`dedup_resets`). A source restarting within 64 frames
 * *below* its old sequence loses up to 64 frames; ub_node_options_t.first_seq
 * lets a node start elsewhere: from ub_node_seq_seed() (the microsecond wall
 * clock, as uavbus_node and Python nodes do: a restarted process starts ahead
 * of its predecessor's numbers) or from a boot counter. Full source tables
 * evict the least recently seen source (`dedup_evictions`). That reset is for
 * unsigned traffic only: see "Security" below.
 *
 * Wire (docs/wire-format.md): a link may use the compact encoding (ub_compact.h,
 * ub_node_link_set_compact()): frames are encoded on send and decoded back to the full frame on
 * receive, so routing, security, the tap and logs only ever see full frames; LINK_HELLO frames
 * (link-local, admin code 20) agree the dictionaries. A link may have an MTU
 * (ub_node_link_set_mtu()): a frame larger on the wire is dropped `too_big`. A directory larger
 * than UB_MAX_PAYLOAD or than the smallest MTU of the links it leaves on goes in fragments
 * (ub_frag.h; needs ub_node_set_frag()), reassembled at its destination and delivered whole or not
 * at all; forwarders relay fragments like any frame and never fragment again.
 *
 * Security (optional; docs/security.md): with a context attached
 * (ub_node_set_security(), ub_sec.h) the node
 *  - **originates** with counters from the context (48-bit: the header's seq
 *    is the low half) and, when it has a signing key, sends SIGNED frames,
 *    or ENCRYPTED ones on links set to encrypt (ub_node_link_set_security());
 *  - **receives** in this order, before any state is touched (duplicate or
 *    replay windows, routing, tables): the policy (require_signed per node
 *    and per link: `unsigned`), the key (`unknown_key`) and the tag
 *    (`bad_tag`); then the source's replay window, per handling entity:
 *    a counter above the highest or unseen inside the 64-bit window passes,
 *    a seen one is a `duplicate`, an older one a `replay` (never a restart);
 *    a counter further ahead than the source could have counted since its
 *    last CHALLENGE_REPLY (ub_sec_jump_limit()) is a `counter_jump` and moves
 *    nothing. A jump, or ub_sec_options_t.replay_streak replays in a row,
 *    challenge the source again (a locked-out or restarted sender recovers);
 *    removing the key that raised a window forgets it (docs/security.md,
 *    "Lockout").
 *    A source without freshness state is not trusted: its frames are dropped
 *    `unverified` and the handling entity sends it a CHALLENGE (random
 *    16-byte nonce); the CHALLENGE_REPLY, signed with the source's current
 *    counter, starts the window there with everything older barred.
 *    CHALLENGE / CHALLENGE_REPLY are verified but exempt from the window when
 *    there is no state (idempotent; the reply is bound to the nonce; replies
 *    to one requester are rate-limited). Once a source was accepted signed,
 *    unsigned frames claiming it are dropped (`unsigned`);
 *  - **forwards** a verified frame as it came, with the hop limit lowered
 *    (not under the tag), converting SIGNED to ENCRYPTED for an encrypting
 *    link and back for the others (same key, same counter): authenticity is
 *    end to end, confidentiality per link. Forwarders hold the group key:
 *    an unverifiable frame must not touch their windows.
 */
#ifndef UB_NODE_H
#define UB_NODE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "ub_admin.h"
#include "ub_catalogue.h"
#include "ub_compact.h"
#include "ub_config.h"
#include "ub_error.h"
#include "ub_frag.h"
#include "ub_frame.h"
#include "ub_link.h"
#include "ub_policy.h"
#include "ub_pubsub.h"
#include "ub_random.h"
#include "ub_sec.h"
#include "ub_service.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Sequences remembered below the highest one per source (bits of the window). */
#define UB_DEDUP_WINDOW 64

/** The link-local destination: every byte 0xFF (docs/routing.md). Never a valid entity ID. */
#define UB_LINK_LOCAL_BYTE 0xFFu

/** @return true if `id` is the link-local destination (UB_ENTITY_ID_LEN bytes of UB_LINK_LOCAL_BYTE). */
bool ub_entity_id_is_link_local(const uint8_t id[UB_ENTITY_ID_LEN]);

/** Direction of a tapped frame. */
typedef enum ub_tap_dir { UB_TAP_RX = 0, UB_TAP_TX = 1 } ub_tap_dir_t;

/**
 * Frame tap (for the log recorder): called with every verified frame received
 * on a link (before routing) and every frame the transport accepted. `frame`
 * is valid only during the call. The tap must not call back into the node.
 */
typedef void (*ub_tap_fn)(void *user, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len,
                          uint64_t now_ms);

/**
 * Delivery hook: called after DATA was unpacked into the bound storage of
 * `instance` for local entity `entity` (entity-table index). `h` is the frame
 * header (source, sequence...). May send (e.g. ub_node_send_data()).
 */
typedef void (*ub_deliver_fn)(void *user, int entity, uint32_t instance, const ub_frame_header_t *h, uint64_t now_ms);

/** Node options; NULL or 0 fields mean the defaults. */
typedef struct ub_node_options {
    uint8_t hop_limit;         /**< hop limit of originated frames; default UB_DEFAULT_HOP_LIMIT */
    uint32_t first_seq;        /**< first sequence number this node uses; default 1 */
    ub_pubsub_timing_t timing; /**< publish/subscribe timing (ub_pubsub.h) */
    /** Source of request ids (ub_random.h): ub_random_os on a POSIX host. NULL = the node's seeded
     *  generator, deterministic and guessable: for tests and simulations. */
    ub_random_fn random;
    void *random_user;         /**< passed to `random` */
    uint64_t random_seed;      /**< seed of the fallback generator; 0 = a fixed constant */
} ub_node_options_t;

/** Node-wide counters. Drops are also counted on the link concerned. */
typedef struct ub_node_counters {
    uint64_t originated;      /**< frames originated by local entities (once per frame) */
    uint64_t forwarded;       /**< received frames forwarded (once per frame) */
    uint64_t delivered;       /**< DATA unpacked into bound storage */
    uint64_t admin_handled;   /**< admin frames handled by a local entity */
    uint64_t local_direct;    /**< frames from one local entity to another, delivered without a link */
    uint64_t dedup_resets;    /**< restarted sources detected */
    uint64_t dedup_evictions; /**< sources evicted from a full window table */
    uint64_t leases_expired;  /**< publish/subscribe rows removed because their lease ran out (and, for a row
                                   handed over, its keeper was gone: docs/pubsub.md) */
    uint64_t replies_unmatched; /**< ACK/NACKs bound to no row (request id, counterpart or content differ): ignored */
    uint64_t requests_limited;  /**< requests refused with NACK LIMIT (ub_policy.h limits) */
    uint64_t leases_clamped;    /**< non-administrator leases shortened to the policy's max_lease_ms */
    uint64_t rows_evicted;      /**< non-administrator rows given up to an administrator's request (full table) */
    uint64_t random_failures;   /**< ub_node_options_t.random failed; the seeded generator stood in */
    uint64_t entities_added;  /**< entity-table rows added (configuration and run time) */
    uint64_t entities_removed; /**< entity-table rows removed (ub_node_remove_entity()) */
    uint64_t links_added;     /**< link slots created */
    uint64_t links_removed;   /**< link slots removed (ub_node_remove_link()) */
    uint64_t rows_stopped;    /**< publish/subscribe rows stopped because an entity they named was removed */
    uint64_t admin_rows_stopped; /**< administration rows deactivated because an entity they named was removed */
    uint64_t dedup_cleared;   /**< duplicate windows cleared because their source was removed */
    uint64_t membership_applied; /**< MEMBERSHIP requests served (ACKed) */
    uint64_t inspect_served;     /**< INSPECT requests answered with a value or ACK */
    uint64_t inspect_refused;    /**< INSPECT requests answered with a NACK */
    uint64_t membership_refused; /**< MEMBERSHIP requests NACKed (invalid, full, unsupported, not authorized) */
    uint64_t handovers;       /**< rows whose owner's lease lapsed while their keeper lived: kept (docs/pubsub.md) */
    uint64_t nacks_relayed;   /**< source NACKs a subscribing destination relayed to the administrator of its row */
    uint64_t other_admin;     /**< requests answered NACK OTHER_ADMIN: another administrator keeps the row or node */
    uint64_t drops[UB_DROP_REASON_COUNT];
} ub_node_counters_t;

/** Entity-table row. */
typedef struct ub_entity_row {
    uint8_t id[UB_ENTITY_ID_LEN];
    uint8_t in_use;
    int8_t local;            /**< local-entity slot, or -1 for a remote entity */
} ub_entity_row_t;

/**
 * Duplicate / replay window of one source, as seen by one handling entity,
 * and its freshness handshake. Unsigned sources use the low 32 bits of
 * `win.highest` with serial-number arithmetic (and may reset); secured ones
 * the 48-bit counter, moved by a frame at most to ub_sec_jump_limit() and
 * re-established only by a CHALLENGE_REPLY to our nonce (or forgotten when
 * the key that set it leaves the keyring): docs/security.md, "Lockout".
 */
typedef struct ub_dedup_entry {
    uint8_t src[UB_ENTITY_ID_LEN];
    uint8_t in_use;
    uint8_t secured;         /**< freshness established by a verified frame: the window is the 48-bit one */
    uint8_t challenging;     /**< a CHALLENGE with `nonce` is outstanding */
    uint8_t challenge_tries; /**< sends of it since the last frame from the source */
    int16_t challenge_link;  /**< ingress link of the frame that started it (route when no mask leads back) */
    ub_sec_window_t win;     /**< highest and bitmap: bit k = highest - k seen */
    uint64_t last_used;      /**< node-wide use stamp, for LRU eviction */
    uint64_t challenge_ms;   /**< last send of the outstanding challenge */
    uint64_t reply_ms;       /**< last CHALLENGE_REPLY sent to this source (as requester) */
    uint8_t nonce[UB_SEC_NONCE_LEN];       /**< outstanding challenge */
    uint8_t reply_nonce[UB_SEC_NONCE_LEN]; /**< nonce of the last reply sent to this source */
    /* Lockout protection (docs/security.md, "Lockout"): how far a frame may move the window. */
    uint64_t proven;         /**< counter the source proved (CHALLENGE_REPLY; own frames: the first) */
    uint64_t proven_ms;      /**< when, on this node's clock: ub_sec_jump_limit() grows from it */
    uint64_t jump_bound;     /**< a ub_sec_jump_limit() already computed: counters up to it pass without recomputing
                                  (the limit only grows with time), so most frames cost no division */
    uint64_t rechallenge_ms; /**< last challenge started for this source while it held freshness */
    uint16_t replay_streak;  /**< frames judged `replay` in a row (a re-challenge at ub_sec_options_t.replay_streak) */
    uint8_t win_key;         /**< key id of the frame that last set `win.highest`: removing the key resets the window */
    uint8_t reproving;       /**< the window's key left the keyring: frames wait (`unverified`) for a new proof */
    uint8_t rechallenged;    /**< `rechallenge_ms` is set */
} ub_dedup_entry_t;

/** A local entity: its links, masks, duplicate windows and tables. */
typedef struct ub_local_entity {
    uint8_t in_use;
    uint8_t entity;                              /**< its entity-table index */
    int16_t link_ids[UB_MAX_LINKS_PER_ENTITY];   /**< link[i] -> link slot, -1 if none */
    uint8_t masks[UB_MAX_ENTITIES];              /**< per destination entity-table index */
    uint8_t pinned[UB_MAX_ENTITIES];             /**< 1: the mask was set by hand (routing leaves it alone) */
    uint8_t bounce[UB_MAX_ENTITIES];             /**< links for a frame sent back by its next hop (ub_node_set_bounce_mask()) */
    ub_dedup_entry_t dedup[UB_DEDUP_SOURCES];
    ub_pubsub_table_t ps;                        /**< kept for the publish/subscribe service (ub_pubsub.h) */
} ub_local_entity_t;

typedef struct ub_binding {
    uint32_t instance;
    void *storage;
    uint8_t on_update; /**< published on update, not on a timer (ub_pubsub_set_on_update()) */
} ub_binding_t;

/* Slots of the node's entity index (open addressing on the entity ID): a power of two at least twice
 * UB_MAX_ENTITIES, so a lookup probes ~1-2 slots instead of scanning the entity table. */
#if UB_MAX_ENTITIES <= 16
#define UB_ENTITY_INDEX_BITS 5
#elif UB_MAX_ENTITIES <= 64
#define UB_ENTITY_INDEX_BITS 7
#elif UB_MAX_ENTITIES <= 256
#define UB_ENTITY_INDEX_BITS 9
#elif UB_MAX_ENTITIES <= 1024
#define UB_ENTITY_INDEX_BITS 11
#elif UB_MAX_ENTITIES <= 4096
#define UB_ENTITY_INDEX_BITS 13
#elif UB_MAX_ENTITIES <= 16384
#define UB_ENTITY_INDEX_BITS 15
#else
#error "the entity index holds rows in int16_t: UB_MAX_ENTITIES must stay <= 16384"
#endif
#define UB_ENTITY_INDEX_SLOTS (1u << UB_ENTITY_INDEX_BITS)

/**
 * The node. Caller-owned; treat the fields as private (use the functions; services use ub_node_svc.h).
 * UB_NODE_OPAQUE hides them: the build defines it for the service layer (src/svc/), so a service that
 * reaches into the struct does not compile (docs/architecture.md, "Layers").
 */
#ifndef UB_NODE_OPAQUE
struct ub_node {
    const ub_catalogue_t *cat;
    ub_node_options_t opt;
    ub_entity_row_t entities[UB_MAX_ENTITIES];
    int16_t entity_index[UB_ENTITY_INDEX_SLOTS]; /* ID hash -> row, -1 empty (linear probing, kept by add/remove) */
    ub_local_entity_t locals[UB_MAX_LOCAL_ENTITIES];
    ub_link_t links[UB_MAX_NODE_LINKS];
    ub_binding_t bindings[UB_MAX_BINDINGS];
    size_t n_bindings;
    void *const *bind_table;    /**< per-instance storage (ub_node_bind_table()), or NULL */
    const uint8_t *content_class; /**< per-instance priority class (ub_node_set_content_classes()), or NULL */
    uint32_t next_seq;          /**< without a security context; with one, counters come from it */
    uint64_t rng_state;         /**< seeded fallback generator of request ids (ub_random.h) */
    const ub_policy_t *policy;  /**< NULL: no authorization (the paper's closed lab) */
    ub_sec_t *sec;              /**< attached security context, or NULL */
    uint8_t require_signed;     /**< node-wide receive policy (links may override) */
    uint64_t use_stamp;
    ub_tap_fn tap;
    void *tap_user;
    ub_deliver_fn deliver;
    void *deliver_user;
    ub_frag_t *frag;          /**< fragment state (ub_node_set_frag()), or NULL: no directory above the payload limit */
    uint16_t mtu_links;       /**< links with an MTU set: only then does a send compare frame sizes with MTUs */
    uint32_t last_content;    /**< catalogue index of the last DATA delivered: checked before a search */
    uint32_t last_dest;       /**< entity row of the last destination routed (local_destination()): checked
                                   before a search (a stale one fails the check: in use and the same ID) */
    /** Header templates of the plain frames this node built last (ub_frame_tpl_finish_header()), by a hash of
     *  content ID and destination: a row sending again reuses its own. Zeroed at init: no entry matches. */
    ub_frame_tpl_t tpl[UB_NODE_TPL_CACHE];
    /** The last hop-limit change this node forwarded with (ub_frame_copy_hop_limit()): a flow's frames share it,
     *  so its check deltas are computed once per flow. Zeroed at init: empty. */
    ub_frame_hop_memo_t hop_memo;
    ub_node_counters_t counters;
    /* Registered services (ub_service.h), in tick order, and per admin code the index + 1 of the one
     * taking it as a code, as a reply, link-local (0: none): a lookup on the admin path, never on DATA's. */
    const ub_service_t *services[UB_MAX_SERVICES];
    uint8_t n_services;
    uint8_t svc_by_code[3][256];
    const ub_service_t *data_svc; /**< the service observing DATA (ub_service_t.on_data), or NULL */
    const ub_service_t *seal_svc; /**< the service sealing / opening origin blocks (ub_service_t.seal), or NULL */
};
#endif /* UB_NODE_OPAQUE */

/**
 * Initialises an empty node over `cat` (which must outlive the node), with the
 * services every node runs: publish/subscribe (and administration tables) and
 * the serving side of membership and inspection (ub_node_core_init(),
 * ub_node_svc.h, is the core without them).
 * @return UB_OK, or UB_ERR_INVAL (NULL node/catalogue, catalogue ABI version
 *         mismatch, or a catalogue type larger than UB_MAX_DIRECTORY: which one,
 *         ub_catalogue_oversize(cat, ub_catalogue_payload_limit()) says; types above
 *         UB_MAX_PAYLOAD travel in fragments, ub_node_set_frag()).
 */
UB_CHECK int ub_node_init(ub_node_t *node, const ub_catalogue_t *cat, const ub_node_options_t *opt);

/**
 * The first sequence number (ub_node_options_t.first_seq) of a process started at wall-clock time
 * `unix_us` (microseconds): the clock itself, mod 2^32 (1 if that is 0). A node restarted after a
 * predecessor that sent N frames in the E microseconds between their starts begins E - N ahead of the
 * predecessor's last number, so no receiver's duplicate window takes its first frames for the
 * predecessor's, whatever the predecessor's rate below one frame per microsecond. The clock in
 * milliseconds was not enough: a `uavbus list` sends ~750 probes in well under 750 ms, and the next
 * tool process, seeded 700 ms later, landed up to 63 numbers behind them and lost its first requests
 * as duplicates. Predecessors older than 2^31 us (35.8 min) may compare behind by serial arithmetic:
 * 64 or more behind is a restart (the window resets), so only a 64-us coincidence loses frames.
 */
uint32_t ub_node_seq_seed(uint64_t unix_us);

/**
 * Adds an entity to the entity table; `local` makes it one of this node's
 * entities (with links, masks and a publish/subscribe table).
 * @return its entity-table index; UB_ERR_EXISTS (ID already present),
 *         UB_ERR_FULL (UB_MAX_ENTITIES or UB_MAX_LOCAL_ENTITIES), UB_ERR_INVAL.
 */
UB_CHECK int ub_node_add_entity(ub_node_t *node, const uint8_t id[UB_ENTITY_ID_LEN], bool local);

/**
 * Removes remote entity `entity` from the table at run time, and with it
 * everything that names it: every local entity's mask toward it (pinned or
 * not), the duplicate windows of it as a source, the routing engine's state
 * for it, and the rows naming it: publish/subscribe rows whose peer it is are
 * freed at once, without a STOP nobody could route (`rows_stopped`); rows it
 * owns as a third party (an administrator) have their lease end now and live
 * on under their keeper (docs/pubsub.md, "Who keeps a row alive"); active
 * administration rows whose target it is (the source of a publication row,
 * the destination of a subscription row) become INACTIVE at once, those
 * naming it only as the other end are deactivated with ub_admin_set_active()
 * (their STOP goes to the target) (`admin_rows_stopped`). Each is counted
 * (ub_node_counters_t). The row may be reused by a later ub_node_add_entity().
 * @return UB_OK; UB_ERR_INVAL (bad index, or a local entity: local entities
 *         live as long as the node).
 */
UB_CHECK int ub_node_remove_entity(ub_node_t *node, int entity, uint64_t now_ms);

/** Same as ub_node_add_entity() with the ID made from a name (ub_entity_id()); UB_ERR_RANGE if too long. */
UB_CHECK int ub_node_add_entity_name(ub_node_t *node, const char *name, bool local);

/** @return the entity-table index of `id`, or UB_ERR_NOTFOUND. */
UB_CHECK int ub_node_find_entity(const ub_node_t *node, const uint8_t id[UB_ENTITY_ID_LEN]);

/** @return the ID of entity `entity`, or NULL if out of range. */
const uint8_t *ub_node_entity_id(const ub_node_t *node, int entity);

/**
 * Creates link slot `name` as `link[index]` of local entity `entity`. The slot
 * starts detached (frames sent on it are dropped as `detached`).
 * @return the link id (stable until the link is removed); UB_ERR_INVAL (not local,
 *         index >= UB_MAX_LINKS_PER_ENTITY, empty name or longer than
 *         UB_LINK_NAME_LEN - 1), UB_ERR_EXISTS (index taken, or name used in
 *         this node), UB_ERR_FULL (UB_MAX_NODE_LINKS).
 */
UB_CHECK int ub_node_add_link(ub_node_t *node, int entity, unsigned index, const char *name);

/**
 * Removes link slot `link_id` at run time: its bit is cleared from every mask
 * of its owner (a pinned mask left empty is unpinned), the routing engine
 * forgets its neighbour and the routes through it, the slot is freed (its
 * counters go with it; the node-wide counters keep their totals) and its id
 * may be reused by a later ub_node_add_link().
 * The transport must be gone first, so that no driver can feed a reused id:
 * close the port (ub_ports_close()) or ub_memlink_disconnect(), or
 * ub_node_link_detach().
 * @return UB_OK; UB_ERR_INVAL (bad id, or a transport is still attached).
 */
UB_CHECK int ub_node_remove_link(ub_node_t *node, int link_id);

/** @return the link id named `name`, or UB_ERR_NOTFOUND. */
UB_CHECK int ub_node_find_link(const ub_node_t *node, const char *name);

/** @return the link slot, or NULL if `link_id` is not a link of this node. */
const ub_link_t *ub_node_link(const ub_node_t *node, int link_id);

/**
 * Sets local entity `entity`'s link mask for destination `dest` (bit i = its
 * link[i]) by hand, the paper's way. The mask for the entity itself must be 0.
 * A non-zero mask *pins* the entry: a routing engine (ub_route.h) leaves it
 * alone. Mask 0 clears the entry and unpins it, so an automatic route may
 * fill it again.
 * @return UB_OK; UB_ERR_INVAL (bad indexes, not local, non-zero mask to
 *         itself); UB_ERR_NOTFOUND (a bit names a link[i] not created yet).
 */
UB_CHECK int ub_node_set_mask(ub_node_t *node, int entity, int dest, uint8_t mask);

/**
 * Sets a mask on behalf of a routing engine: like ub_node_set_mask() but the
 * entry is not pinned, and a pinned entry is left unchanged.
 * @return UB_OK; UB_ERR_EXISTS (the entry is pinned, nothing written); the
 *         errors of ub_node_set_mask().
 */
UB_CHECK int ub_node_set_auto_mask(ub_node_t *node, int entity, int dest, uint8_t mask);

/**
 * Sets, on behalf of a routing engine, where a frame toward `dest` goes when it comes back over a link of the
 * mask -- the next hop sent it back, having no other way (it routes through us, or its link onward is in
 * doubt): the other loop-free successors the engine knows (docs/routing.md, "Transport evidence"). Used only
 * then, and never for a pinned entry; 0 (the default) drops such a frame `no_route` as before. Cleared with
 * the mask when `dest` or a link goes.
 * @return UB_OK; the errors of ub_node_set_mask().
 */
UB_CHECK int ub_node_set_bounce_mask(ub_node_t *node, int entity, int dest, uint8_t mask);

/** @return true if local entity `entity`'s mask toward `dest` was set by hand (pinned). */
bool ub_node_mask_pinned(const ub_node_t *node, int entity, int dest);

/** Reads a mask. @return UB_OK or UB_ERR_INVAL. */
UB_CHECK int ub_node_get_mask(const ub_node_t *node, int entity, int dest, uint8_t *mask);

/**
 * Puts transport (`ops`, `impl`) behind link slot `link_id`, replacing any
 * previous one. Entity tables, masks, publish/subscribe state and counters
 * are kept; the slot's stream decoder is reset (its partial bytes belonged to
 * the old transport, and are counted in its garbage_bytes, so the decoder's
 * bytes_in == bytes_ok + garbage_bytes + pending holds across re-attaches).
 * @return UB_OK, or UB_ERR_INVAL (bad id, NULL ops or ops->send).
 */
UB_CHECK int ub_node_link_attach(ub_node_t *node, int link_id, const ub_link_ops_t *ops, void *impl);

/**
 * Replaces the transport behind a slot *without* resetting its stream decoder:
 * for a decorator (ub_impair.h) put in front of, or taken away from, the
 * transport already there, whose byte stream simply continues. A new
 * connection or device must use ub_node_link_attach() instead.
 * @return UB_OK, or UB_ERR_INVAL (bad id, NULL ops or ops->send).
 */
UB_CHECK int ub_node_link_set_transport(ub_node_t *node, int link_id, const ub_link_ops_t *ops, void *impl);

/** Detaches the transport of a slot. @return UB_OK or UB_ERR_INVAL. */
UB_CHECK int ub_node_link_detach(ub_node_t *node, int link_id);

/** @return decoder (stream) plus datagram rejections of `reason` on a link; 0 for a bad id. */
uint64_t ub_node_link_bad_frames(const ub_node_t *node, int link_id, ub_rx_reason_t reason);

/**
 * Binds catalogue instance `instance` to `storage` (a variable of the
 * instance's C type, which must outlive the node). DATA for that instance is
 * unpacked into it; publications pack from it. Rebinding replaces.
 * @return UB_OK; UB_ERR_INVAL (NULL, instance out of range); UB_ERR_FULL.
 */
UB_CHECK int ub_node_bind(ub_node_t *node, uint32_t instance, void *storage);

/**
 * Binds every instance at once from `table`, indexed by catalogue instance
 * index, with exactly `n` == the catalogue's n_instances entries (NULL: that
 * instance is not hosted here). The generated `<NAME>_bind_all()` passes the
 * program's own link-time table (`<NAME>_storage`), so a program hosts every
 * catalogued instance it defines with one call, no copy and no malloc; its
 * capacity is the catalogue's, not UB_MAX_BINDINGS. The table must outlive
 * the node. Bindings made with ub_node_bind() take precedence over it.
 * @return the number of instances the table binds; UB_ERR_INVAL (NULL node,
 *         `n` != n_instances). A NULL table removes a previous one (returns 0).
 */
UB_CHECK int ub_node_bind_table(ub_node_t *node, void *const *table, size_t n);

/**
 * Gives every catalogued content its priority class on slow links (ub_prio.h), from `classes`, indexed by
 * catalogue instance index, with exactly `n` == n_instances entries, each a ub_prio_class_t (0..3). The
 * node reads it when a frame leaves on a link whose transport queues by class (ub_link_ops_t.send_class):
 * DATA takes its content's class, a content not in the catalogue telemetry. Give every node of a fleet the
 * same table (the config's "priorities", docs/config-format.md), so that a frame has one class at every
 * hop: the class is derived at each hop, never carried on the wire. The table must outlive the node.
 * NULL removes it (every DATA is telemetry).
 * @return UB_OK; UB_ERR_INVAL (NULL node, `n` != n_instances, a class out of range).
 */
UB_CHECK int ub_node_set_content_classes(ub_node_t *node, const uint8_t *classes, size_t n);

/** @return the storage bound to `instance` (ub_node_bind(), else the bind table), or NULL. */
void *ub_node_binding(const ub_node_t *node, uint32_t instance);

/**
 * Feeds bytes received on a stream link. The slot's decoder finds and verifies
 * frames (rejections counted by reason in its stats) and routes each one.
 * @return the number of frames found, or UB_ERR_INVAL (bad link id / NULL data with len > 0).
 */
UB_CHECK int ub_node_rx(ub_node_t *node, int link_id, const uint8_t *data, size_t len, uint64_t now_ms);

/** What ub_node_rx_stream() made of the frames it found. */
typedef struct ub_rx_verdicts {
    unsigned authentic; /**< passed the policy and the tag, and were neither duplicates nor replays (those
                             dropped `unverified` while their source's challenge runs included) */
    unsigned fresh;     /**< of those, the ones whose freshness is proven (routed, delivered or forwarded) */
} ub_rx_verdicts_t;

/**
 * ub_node_rx() with an explicit decoder: for a transport that reads a second
 * byte stream for the same slot (a TCP server's candidate connection) and
 * must know whether it carried authentic frames. `dec` NULL = the slot's own
 * decoder. `verdicts` (may be NULL) receives the counts of this call.
 * @return frames found, or UB_ERR_INVAL.
 */
UB_CHECK int ub_node_rx_stream(ub_node_t *node, int link_id, ub_decoder_t *dec, const uint8_t *data, size_t len,
                               uint64_t now_ms, ub_rx_verdicts_t *verdicts);

/**
 * Hands one datagram (exactly one frame) received on a link to the router.
 * @return UB_OK (routed, delivered or dropped-and-counted); the error of
 *         ub_frame_parse() when the datagram is not a valid frame (counted in
 *         `bad_datagrams`); UB_ERR_INVAL (bad link id).
 */
UB_CHECK int ub_node_rx_frame(ub_node_t *node, int link_id, const uint8_t *frame, size_t len, uint64_t now_ms);

/**
 * What the router made of one received frame: the node's verdict, for transports that act on who
 * sent it (a UDP link learning its peer from the first frame the node accepted, ub_udp.h). It says
 * whether the frame passed the checks that establish that it is genuine and new; what happens after
 * (delivered, forwarded, or dropped for routing or content: no_route, unbound, ...) does not change it.
 */
typedef enum ub_rx_verdict {
    /** Not a frame (bad sync, CRC, length...), or refused by a check on its origin: with security on,
     *  unsigned where signing is required, bad tag, unknown key, replay. */
    UB_VERDICT_REFUSED = 0,
    /** A genuine frame the node had handled already: the copy over a redundant link (a 0x11 mask),
     *  or a replay of an earlier frame (with security on: anyone may send such a copy). */
    UB_VERDICT_DUPLICATE = 1,
    /** Genuine and new: passed verification, every security check and the duplicate window. */
    UB_VERDICT_ACCEPTED = 2,
    /** Authentic (its tag verified) but not accepted: its source has no freshness state here yet, so it
     *  was dropped `unverified` and a CHALLENGE went to the source (docs/security.md). It may be the
     *  first frame of a genuine new peer -- or a captured one replayed: a transport may reach its sender
     *  provisionally, so the challenge can get there, and must not trust it more until a frame from it is
     *  ACCEPTED (ub_udp.h). */
    UB_VERDICT_UNVERIFIED = 3
} ub_rx_verdict_t;

/**
 * ub_node_rx_frame() that also reports the verdict on the frame (always set, also on error).
 * The node-level hook for peer learning: a transport that can tell senders apart (UDP) learns a
 * sender only from frames the node accepted, so security decides who becomes a peer, not the transport.
 * @return as ub_node_rx_frame().
 */
UB_CHECK int ub_node_rx_frame_verdict(ub_node_t *node, int link_id, const uint8_t *frame, size_t len,
                                      uint64_t now_ms, ub_rx_verdict_t *verdict);

/**
 * Originates DATA: packs the storage bound to `instance` and sends it from
 * local entity `entity` to `dest_id`.
 * @return the number of links whose transport accepted the frame (0 when
 *         delivered to a local entity, or when every transport refused it:
 *         refusals are counted as tx_error / backpressure / detached);
 *         UB_ERR_INVAL; UB_ERR_NOTFOUND (instance not bound);
 *         UB_ERR_NOROUTE (no link for the destination; counted `no_route`).
 */
UB_CHECK int ub_node_send_data(ub_node_t *node, int entity, uint32_t instance, const uint8_t dest_id[UB_ENTITY_ID_LEN],
                               uint64_t now_ms);

/**
 * Originates one link-local frame (see "Link-local frames" above) with admin
 * code `code` and `len` payload bytes on link `link_id` only, from the link's
 * owner, hop limit 1, through the same path as every originated frame
 * (sequence number, duplicate window, tap, counters).
 * @return 1 if the transport accepted it, 0 if it refused it (counted as
 *         tx_error / backpressure / detached); UB_ERR_INVAL (bad link id,
 *         NULL payload with len > 0); UB_ERR_RANGE (len > UB_MAX_PAYLOAD).
 */
UB_CHECK int ub_node_send_link_local(ub_node_t *node, int link_id, ub_admin_code_t code, const uint8_t *payload,
                                     uint16_t len, uint64_t now_ms);

/**
 * The one authorization question of the administrative plane: may entity
 * `src_id` administer local entity `entity` (use the exclusive rights:
 * change its tables, membership)? Every admin request received over a link
 * asks it (membership here, publish/subscribe requests in ub_pubsub.c).
 * `verified`: the request arrived SIGNED or ENCRYPTED and its tag verified
 * (the receive gate; docs/security.md). When the node has a keyring
 * (ub_node_set_security()), an unverified request never administers, since
 * only the tag proves who sent it (a link with "require_signed": false still
 * carries unsigned data, never administration). Otherwise: true without a
 * policy (the paper's closed lab), else only for the policy's administrators
 * (ub_policy.h; docs/routing.md, "Membership"; docs/pubsub.md).
 */
bool ub_node_may_administer(const ub_node_t *node, int entity, const uint8_t src_id[UB_ENTITY_ID_LEN], bool verified);

/**
 * Advances every registered service to `now_ms`, in their order (ub_service.h):
 * the publish/subscribe tables (and attached administration tables: due DATA,
 * requests, renewals, timeouts, lease expiry), the routing engine, the
 * membership and inspection requesters when attached, then the frame path's
 * own (challenges, compact links, fragments), then the application's.
 * Time must not go backwards.
 */
void ub_node_tick(ub_node_t *node, uint64_t now_ms);

/** Installs (or with NULL removes) the frame tap. */
void ub_node_set_tap(ub_node_t *node, ub_tap_fn fn, void *user);

/** Installs (or with NULL removes) the delivery hook. */
void ub_node_set_deliver_hook(ub_node_t *node, ub_deliver_fn fn, void *user);

/**
 * Attaches a policy (ub_policy.h), or with NULL removes it. The node keeps the
 * pointer: the policy must outlive the attachment and not change while frames
 * are handled. Rows that exist keep their owners and leases; the policy judges
 * requests, STOPs and DATA from now on. ub_nodecfg_apply() attaches the
 * policy of a configuration's "security" section.
 */
void ub_node_set_policy(ub_node_t *node, const ub_policy_t *policy);

/** @return the node-wide counters. */
const ub_node_counters_t *ub_node_counters(const ub_node_t *node);

/**
 * Attaches a security context (NULL detaches). The context must outlive the
 * node and have been started (ub_sec_start()): from now on counters come
 * from it. Replay state already held is kept.
 * @return UB_OK; UB_ERR_INVAL (NULL node, context not started);
 *         UB_ERR_UNSUPPORTED (built without security).
 */
UB_CHECK int ub_node_set_security(ub_node_t *node, ub_sec_t *sec);

/** @return the attached security context, or NULL. */
ub_sec_t *ub_node_security(const ub_node_t *node);

/** Node-wide receive policy: `on` drops every frame without a valid trailer (`unsigned`). @return UB_OK or UB_ERR_INVAL. */
UB_CHECK int ub_node_set_require_signed(ub_node_t *node, bool on);

/**
 * Per-link security: `require_signed` 1 / 0 overrides the node's policy for
 * frames received on the link, -1 follows it; `encrypt` sends only ENCRYPTED
 * frames on it and, where signing is required, accepts only ENCRYPTED ones.
 * @return UB_OK or UB_ERR_INVAL (bad link id or value).
 */
UB_CHECK int ub_node_link_set_security(ub_node_t *node, int link_id, int require_signed, bool encrypt);

/** @return whether frames received on the link must be signed (its own setting, else the node's). */
bool ub_node_link_requires_signed(const ub_node_t *node, int link_id);

/**
 * Sets link `link_id` to the compact encoding with `state` (caller-owned, must outlive the
 * setting; initialised here with the node's catalogue, `params` (may be NULL) and a random
 * epoch), or back to full frames with NULL. Both ends of a link must be set alike. The slot's
 * stream decoder restarts (its bytes belonged to the other encoding); the first LINK_HELLO round
 * goes out at the next ub_node_tick().
 * @return UB_OK or UB_ERR_INVAL (bad link id).
 */
UB_CHECK int ub_node_link_set_compact(ub_node_t *node, int link_id, ub_compact_t *state,
                                      const ub_compact_params_t *params);

/** @return the compact state of a link, or NULL (full frames, or a bad id). */
ub_compact_t *ub_node_link_compact(const ub_node_t *node, int link_id);

/**
 * Sets the MTU of a link: the largest frame it carries on the wire, in bytes after encoding (0:
 * no limit). A larger frame is dropped `too_big`; directories that do not fit the links they
 * leave on are sent in fragments (ub_node_set_frag()).
 * @return UB_OK; UB_ERR_INVAL (bad id); UB_ERR_RANGE (1..UB_LINK_MTU_MIN - 1).
 */
UB_CHECK int ub_node_link_set_mtu(ub_node_t *node, int link_id, uint16_t mtu);

/** Smallest MTU a link accepts (a fragment must still carry some bytes). */
#define UB_LINK_MTU_MIN 64u

/**
 * Attaches fragment state (ub_frag.h, caller-owned, large: static storage), or with NULL detaches
 * it. Without it a node neither sends nor reassembles directories above the payload limit or
 * the path MTU (`too_big`).
 * @return UB_OK or UB_ERR_INVAL.
 */
UB_CHECK int ub_node_set_frag(ub_node_t *node, ub_frag_t *frag);

/** @return the attached fragment state, or NULL. */
ub_frag_t *ub_node_frag(const ub_node_t *node);

/** @return a number that changes whenever the entity table changes (compact links rebuild their dictionary). */
#ifndef UB_NODE_OPAQUE
static inline uint64_t ub_node_table_version(const ub_node_t *node) {
    return node->counters.entities_added + node->counters.entities_removed;
}
#endif

/* ==== Queries (runtime_c/src/core/ub_node_query.c) ==================================================
 * Read-only views of the entity table and the link slots for bindings and tools (the Python tier 2 reads
 * no field of ub_node_t or ub_link_t). Each takes any index: out of range or unused reads as "none". */

/** @return true if entity-table row `entity` is in use. */
bool ub_node_entity_in_use(const ub_node_t *node, int entity);

/** @return true if `entity` is in use and one of this node's local entities. */
bool ub_node_entity_is_local(const ub_node_t *node, int entity);

/** @return the link id of link[`index`] of local entity `entity`; UB_ERR_NOTFOUND (no link there);
 *  UB_ERR_INVAL (not a local entity, or index >= UB_MAX_LINKS_PER_ENTITY). */
UB_CHECK int ub_node_entity_link(const ub_node_t *node, int entity, unsigned index);

/** @return the name of link slot `link_id`, or NULL if the slot is not in use. */
const char *ub_node_link_name(const ub_node_t *node, int link_id);

/** @return the kind of the transport attached to `link_id` ("udp", "tcp", ...), or NULL (detached, unused). */
const char *ub_node_link_kind(const ub_node_t *node, int link_id);

/** @return the counters of link slot `link_id`, or NULL if the slot is not in use. */
const ub_link_counters_t *ub_node_link_counters(const ub_node_t *node, int link_id);

/** @return true if `link_id` sends only ENCRYPTED frames (ub_node_link_set_security()). */
bool ub_node_link_encrypts(const ub_node_t *node, int link_id);

/** @return the MTU of `link_id` (ub_node_link_set_mtu()); 0: no limit, or not a link in use. */
uint16_t ub_node_link_mtu(const ub_node_t *node, int link_id);

/** @return the counters of `link_id`'s compact encoding, or NULL (full frames, or not a link in use). */
const ub_compact_stats_t *ub_node_link_compact_stats(const ub_node_t *node, int link_id);

/** @return the counters of the attached fragment state (ub_node_set_frag()), or NULL. */
const ub_frag_stats_t *ub_node_frag_stats(const ub_node_t *node);
/* ==== end of Queries ================================================================================ */

#ifdef __cplusplus
}
#endif
#endif /* UB_NODE_H */
