/**
 * @file ub_mavroute.h
 * @brief The MAVLink front door (docs/bridges.md): a MAVLink router inside a bridge node, whose links are
 *        the local autopilot (the bridge, ub_mavbridge.h), the ground stations of the node's GCS
 *        endpoint (clients), and the other bridge nodes of the fleet (peers), reached over the bus.
 *
 *  - **Between bridge nodes** a MAVLink frame travels unchanged as a DATA write of the catalogued
 *    directory `mavFrame` (struct ub_mavframe) into the peer's bridge entity: the bus signs, compacts,
 *    fragments and routes it like any directory, over any number of hops, and the peer's node write
 *    policy says which bridges may feed it.
 *  - **Only where someone listens.** The autopilot's broadcasts (telemetry) go to a peer only while that
 *    peer was heard within UB_MAVROUTE_PEER_TIMEOUT_MS: ground stations' broadcasts (their HEARTBEAT) go to
 *    every peer and wake the vehicle bridges up; with no ground station anywhere, nothing crosses the bus.
 *  - **Routing** follows the MAVLink routing guide: every link's source system ids are learned from the
 *    traffic; a message without a target system (or target 0, broadcast) goes to every other link; a
 *    message with a target goes only to the links where that system was seen (nowhere if none: counted
 *    `no_target`). A frame from the bus goes to local links only (autopilot, clients): the bus does the
 *    multi-hop part, so nothing loops.
 *  - **Pinning.** Only the autopilot's own messages (the bridge's target, from its pinned address) are
 *    forwarded from the autopilot link; frames from ground stations and peers reach the autopilot only
 *    when the bridge forwards commands (`commands`, the node's write policy).
 *  - The same system id seen behind two different vehicle links (the local autopilot and a peer, or two
 *    peers) is counted `sysid_conflicts` and reported, never silently merged: the first link keeps it.
 *
 *  - **Rates a ground station asks** (`SET_MESSAGE_INTERVAL` in COMMAND_LONG / COMMAND_INT,
 *    `REQUEST_DATA_STREAM`) are flows of this router, never commands to the autopilot: the node whose
 *    autopilot is the target records the interval for the link it came from (a ground station, or a peer
 *    door), sends that link the message no faster (`-1`: not at all), answers COMMAND_ACK as an autopilot
 *    does, and hands the fastest interval any link wants to the bridge (ub_mavbridge_set_flow()), which
 *    asks its autopilot for the fastest of those and of its uavbus subscriptions. A door whose ground
 *    station asks for a vehicle behind a peer records it for that ground station too, and sends the peer
 *    the fastest interval its ground stations want (the command rewritten), so each ground station gets
 *    its own rate and the bus carries the fastest of them.
 *  - **Signing on the GCS endpoint** (ub_mavroute_set_gcs_key()): only MAVLink 2 frames signed with the
 *    endpoint's key get in (unsigned, bad signature, replayed: counted, dropped; the sender gets nothing
 *    until it sent one good frame), and every frame to the ground stations is signed with it.
 *
 * No I/O: frames to ground stations go out through the caller's `send` (ub_mavio.h's GCS endpoint).
 * Caller-owned state, no allocation.
 */
#ifndef UB_MAVROUTE_H
#define UB_MAVROUTE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ub_mavbridge.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Ground stations on the node's GCS endpoint at once. */
#ifndef UB_MAVROUTE_MAX_CLIENTS
#define UB_MAVROUTE_MAX_CLIENTS 8
#endif
/** Other bridge entities of the fleet. */
#ifndef UB_MAVROUTE_MAX_PEERS
#define UB_MAVROUTE_MAX_PEERS 8
#endif

/** A peer bridge heard from (any mavFrame) within this long gets this node's vehicles' broadcasts: a door's
 *  ground stations wake the vehicle bridges up (their HEARTBEATs are broadcasts), and nothing crosses the
 *  bus toward a node where no ground station is. */
#ifndef UB_MAVROUTE_PEER_TIMEOUT_MS
#define UB_MAVROUTE_PEER_TIMEOUT_MS 10000
#endif

/** Rate entries (link, system, message) at once: ground stations' SET_MESSAGE_INTERVAL / REQUEST_DATA_STREAM.
 *  MAVProxy and QGroundControl ask 7 streams (13 messages) of every vehicle: two of them with three vehicles
 *  fill 78 at a door. */
#ifndef UB_MAVROUTE_MAX_FLOWS
#define UB_MAVROUTE_MAX_FLOWS 128
#endif

/** Link numbers: 0 the autopilot, 1.. clients, then peers (bits of the learned-system masks). */
#define UB_MAVROUTE_LINK_AUTOPILOT 0
#define UB_MAVROUTE_LINK_CLIENT0 1
#define UB_MAVROUTE_LINK_PEER0 (1 + UB_MAVROUTE_MAX_CLIENTS)
#if 1 + UB_MAVROUTE_MAX_CLIENTS + UB_MAVROUTE_MAX_PEERS > 32
#error "the learned-system masks are 32 bits: UB_MAVROUTE_MAX_CLIENTS + UB_MAVROUTE_MAX_PEERS must stay below 32"
#endif

/** Sends one MAVLink frame to ground station `client`. @return UB_OK or a negative code (counted). */
typedef int (*ub_mavroute_send_fn)(void *user, int client, const uint8_t *bytes, size_t len);

typedef struct ub_mavroute_counters {
    uint64_t from_autopilot;   /**< autopilot messages routed */
    uint64_t from_clients;     /**< ground-station messages parsed */
    uint64_t from_peers;       /**< frames received from peer bridges */
    uint64_t to_clients;       /**< frames sent to ground stations */
    uint64_t to_peers;         /**< frames sent over the bus */
    uint64_t to_autopilot;     /**< frames forwarded to the autopilot */
    uint64_t no_target;        /**< targeted messages whose system was seen on no link: dropped */
    uint64_t commands_off;     /**< frames for the autopilot refused: the bridge does not forward commands */
    uint64_t bad_frames;       /**< frames from the bus that are no MAVLink frame (length, checksum) */
    uint64_t client_parse_errors; /**< bytes from ground stations the parser threw away, bad checksums */
    uint64_t send_errors;      /**< a client's or a peer's send failed */
    uint64_t sysid_conflicts;  /**< one system id behind two vehicle links (reported, first kept) */
    uint64_t unknown_peer;     /**< frames from a bridge entity not in the peer list: dropped */
    uint64_t rate_requests;    /**< SET_MESSAGE_INTERVAL / REQUEST_DATA_STREAM answered here for the local autopilot */
    uint64_t rate_forwarded;   /**< ... from a ground station toward a peer's vehicle (recorded for it, rewritten) */
    uint64_t rate_limited;     /**< frames not sent to a link because of the interval it asked */
    uint64_t flows_full;       /**< rate requests not recorded: UB_MAVROUTE_MAX_FLOWS entries in use */
    uint64_t gcs_unsigned;     /**< GCS signing on: unsigned frames from ground stations, dropped */
    uint64_t gcs_bad_signature;/**< ... signed with another key */
    uint64_t gcs_replayed;     /**< ... a timestamp not newer than the stream's, or too old */
    uint64_t gcs_sysid_shared; /**< a GCS HEARTBEAT with a system id another ground station uses (reported: both get its replies) */
} ub_mavroute_counters_t;

/** One rate a link asked (private to the router; visible for tests and stats). */
typedef struct ub_mavroute_flow {
    uint8_t link;        /**< link number + 1; 0 = free */
    uint8_t sysid;       /**< the vehicle */
    uint32_t msgid;
    int32_t interval_us; /**< > 0: at most once per interval; -1: not at all; 0: as it comes (kept only for aggregation) */
    uint64_t next_ms;    /**< the next frame may go at this time */
} ub_mavroute_flow_t;

/** The router. Caller-owned (a few kB); fields private. */
typedef struct ub_mavroute {
    ub_mavbridge_t *br;
    bool autopilot;              /* the bridge has an autopilot link (default); off: a door only */
    ub_node_t *node;
    int entity;
    int32_t frame_instance;
    struct ub_mavframe *frame; /* the bound mavFrame storage */
    ub_mavroute_send_fn send;
    void *send_user;
    uint8_t peers[UB_MAVROUTE_MAX_PEERS][UB_ENTITY_ID_LEN];
    int n_peers;
    uint64_t peer_heard_ms[UB_MAVROUTE_MAX_PEERS]; /* last mavFrame from each peer, 0 = never */
    uint8_t client_up[UB_MAVROUTE_MAX_CLIENTS];
    mavlink_message_t cbuf[UB_MAVROUTE_MAX_CLIENTS]; /* a parser per client (TCP and serial are streams) */
    mavlink_status_t cstatus[UB_MAVROUTE_MAX_CLIENTS];
    mavlink_message_t msg, pbuf;
    mavlink_status_t pstatus;
    uint32_t seen[256];          /* per system id: the links it was heard on */
    uint8_t gcs[256];            /* per system id: its HEARTBEAT says MAV_TYPE_GCS */
    uint8_t vehicle[256];        /* per system id: 1 + the vehicle link that owns it (its HEARTBEAT), 0 = none */
    uint8_t last_conflict;       /* system id of the last conflict (for the program's report) */
    uint8_t last_gcs_shared;     /* system id two ground stations use (for the program's report) */
    uint8_t tx[MAVLINK_MAX_PACKET_LEN];
    uint8_t ctx[MAVLINK_MAX_PACKET_LEN]; /* the frame for ground stations (re-signed when GCS signing is on) */
    mavlink_message_t out;       /* re-encoded messages (signed copies, rewritten rate requests, our ACKs) */
    uint8_t ack_seq;
    ub_mavroute_flow_t flows[UB_MAVROUTE_MAX_FLOWS];
    uint64_t next_expiry_ms;
    bool gcs_sign;
    mavlink_signing_t gsign;
    mavlink_signing_streams_t gstreams;
    uint64_t gsign_t0, gsign_base_ms;
    ub_mavroute_counters_t c;
} ub_mavroute_t;

/**
 * Sets up the router over bridge `br` (its node and entity): binds `frame` as the `mavFrame`
 * directory, taps the bridge's autopilot messages. `peers`: the other bridge entities' names
 * (`n_peers` of them). `send`: frames to ground stations.
 * @return UB_OK; UB_ERR_INVAL (NULLs, an unknown peer name, mavFrame missing from the catalogue);
 *         UB_ERR_FULL (more than UB_MAVROUTE_MAX_PEERS); the node's bind error.
 */
UB_CHECK int ub_mavroute_init(ub_mavroute_t *rt, ub_mavbridge_t *br, struct ub_mavframe *frame,
                              const char *const *peers, int n_peers, ub_mavroute_send_fn send, void *send_user);

/** Says whether the bridge has an autopilot link (default yes). A node that is only a front door (its ground
 *  stations and the fleet's vehicles, none of its own) sends nothing toward one. */
void ub_mavroute_set_autopilot(ub_mavroute_t *rt, bool has_autopilot);

/** Bytes from ground station `client` (0..UB_MAVROUTE_MAX_CLIENTS-1): parsed, learned, routed.
 *  @return messages routed, or UB_ERR_INVAL. */
UB_CHECK int ub_mavroute_from_client(ub_mavroute_t *rt, int client, const uint8_t *bytes, size_t len, uint64_t now_ms);

/**
 * Turns MAVLink signing on for the GCS endpoint: frames from ground stations must be signed with `key`
 * (MAVLink 2 signing; unsigned and badly signed ones are counted and dropped), frames to them are signed
 * with it (link id `link_id`), the signing time starting at `timestamp` (10 µs since 2015-01-01, from a
 * wall clock: ub_mavbridge_signing_time()) at `now_ms`.
 */
void ub_mavroute_set_gcs_key(ub_mavroute_t *rt, const uint8_t key[32], uint8_t link_id, uint64_t timestamp,
                             uint64_t now_ms);

/** @return whether ground station `client` sent a valid (with GCS signing: well signed) frame since it appeared. */
bool ub_mavroute_client_up(const ub_mavroute_t *rt, int client);

/** Expires the rates of peers no longer heard (UB_MAVROUTE_PEER_TIMEOUT_MS). Call every loop turn. */
void ub_mavroute_tick(ub_mavroute_t *rt, uint64_t now_ms);

/** Ground station `client` went away (timeout, closed): forgets what was learned on it. */
void ub_mavroute_client_gone(ub_mavroute_t *rt, int client);

/** The node's delivery hook for the bridge node (`user` = the router): takes `mavFrame` writes, passes
 *  every other delivery to ub_mavbridge_on_deliver(). */
void ub_mavroute_on_deliver(void *user, int entity, uint32_t instance, const ub_frame_header_t *h, uint64_t now_ms);

/** @return the counters. */
const ub_mavroute_counters_t *ub_mavroute_counters(const ub_mavroute_t *rt);

/** @return the links system `sysid` was heard on (bit UB_MAVROUTE_LINK_*). */
uint32_t ub_mavroute_seen(const ub_mavroute_t *rt, uint8_t sysid);

#ifdef __cplusplus
}
#endif
#endif /* UB_MAVROUTE_H */
