/**
 * @file ub_config.h
 * @brief Compile-time capacities of the runtime. All memory is sized here and
 *        owned by the caller's context structs: there is no malloc after init.
 *
 * Override any value by defining it on the compiler command line
 * (-DUB_MAX_PAYLOAD=2048) or by pointing UB_CONFIG_FILE at a header of your own
 * (-DUB_CONFIG_FILE='"my_ub_config.h"'), which is included first.
 */
#ifndef UB_CONFIG_H
#define UB_CONFIG_H

#ifdef UB_CONFIG_FILE
#include UB_CONFIG_FILE
#endif

/** Largest payload (packed directory) one frame carries, in bytes. */
#ifndef UB_MAX_PAYLOAD
#define UB_MAX_PAYLOAD 1024
#endif
/**
 * Largest directory (packed type) a node carries, in bytes. Types above UB_MAX_PAYLOAD travel in
 * fragments (ub_frag.h), which needs a ub_frag_t attached to the node; the payload_size field of
 * the frame is 16 bits, hence at most 65535. `uavbus gen`/`check` accept types up to this size.
 */
#ifndef UB_MAX_DIRECTORY
#define UB_MAX_DIRECTORY 16384
#endif
/** Entity-table rows per node: every entity this node knows (local and remote). */
#ifndef UB_MAX_ENTITIES
#define UB_MAX_ENTITIES 16
#endif
/** Links per entity; the paper allows 8 ("a maximum of 8 links originating at one entity"). */
/* Header templates a node keeps for the plain frames it builds (ub_node_t.tpl): a small direct-mapped
 * cache keyed by content ID and destination, so a publisher's rows reuse their template (ub_frame_tpl_t,
 * ~110 bytes each) instead of rebuilding the whole header CRC per frame. */
#ifndef UB_NODE_TPL_CACHE
#define UB_NODE_TPL_CACHE 8
#endif

#ifndef UB_MAX_LINKS_PER_ENTITY
#define UB_MAX_LINKS_PER_ENTITY 8
#endif
/** Link slots per node (all local entities' links together). */
#ifndef UB_MAX_NODE_LINKS
#define UB_MAX_NODE_LINKS 16
#endif
/** Entities hosted by one node (process). */
#ifndef UB_MAX_LOCAL_ENTITIES
#define UB_MAX_LOCAL_ENTITIES 4
#endif
/** Publish/subscribe table rows per local entity. */
#ifndef UB_MAX_PUBSUB_ROWS
#define UB_MAX_PUBSUB_ROWS 32
#endif
/** Rows of the global administration table. */
#ifndef UB_MAX_ADMIN_ROWS
#define UB_MAX_ADMIN_ROWS 32
#endif
/** Directory instances one node binds to local storage. */
/** Services a node can register (ub_service.h): the built-in ones take 7 (publish/subscribe, routing,
 *  membership, inspection, freshness challenges, compact links, fragments). */
#ifndef UB_MAX_SERVICES
#define UB_MAX_SERVICES 12
#endif

#ifndef UB_MAX_BINDINGS
#define UB_MAX_BINDINGS 64
#endif
/** Sources tracked by the duplicate-suppression window. */
#ifndef UB_DEDUP_SOURCES
#define UB_DEDUP_SOURCES 16
#endif
/** Administrators ("exclusive rights", paper III.B) one policy lists (ub_policy.h). */
#ifndef UB_POLICY_MAX_ADMINS
#define UB_POLICY_MAX_ADMINS 8
#endif
/** Read and write rules of one policy together; a config rule with n sources and m contents takes n * m. */
#ifndef UB_POLICY_MAX_RULES
#define UB_POLICY_MAX_RULES 48
#endif
/** Longest content-name pattern of a policy rule ("gcsMissionRmax1*"). */
#ifndef UB_POLICY_PATTERN_MAX
#define UB_POLICY_PATTERN_MAX 63
#endif
/** Keys one security context holds (ub_sec.h): all are accepted, one signs; two suffice for a rollover. */
#ifndef UB_MAX_KEYS
#define UB_MAX_KEYS 4
#endif
/* ---- priorities on slow links (ub_prio.h, issue 28) ---- */
/** Frames that may wait per priority class on a byte-budget link that queues by class (ub_impair.h with
 *  `prio=1`). Commands and control are rare and small; telemetry is the flood (its oldest frame is dropped
 *  for a newer one, counted `shed`, so what waits stays fresh: 12 ATTITUDE frames are 80 ms of a
 *  57,600-baud radio); bulk fragments pause on a full queue and go on later. Together they must not exceed
 *  the link's buffer (UB_IMPAIR_DEPTH, 32 frames). */
#ifndef UB_PRIO_DEPTH_COMMAND
#define UB_PRIO_DEPTH_COMMAND 8
#endif
#ifndef UB_PRIO_DEPTH_CONTROL
#define UB_PRIO_DEPTH_CONTROL 8
#endif
#ifndef UB_PRIO_DEPTH_TELEMETRY
#define UB_PRIO_DEPTH_TELEMETRY 12
#endif
#ifndef UB_PRIO_DEPTH_BULK
#define UB_PRIO_DEPTH_BULK 4
#endif
/** Bulk's share of a link flooded by telemetry: one bulk frame after this many telemetry frames taken while
 *  bulk waited (a large directory slows down under a flood, never stops; commands and control still go first). */
#ifndef UB_PRIO_BULK_EVERY
#define UB_PRIO_BULK_EVERY 8
#endif

/** Hop limit written into frames this node originates. */
#ifndef UB_DEFAULT_HOP_LIMIT
#define UB_DEFAULT_HOP_LIMIT 8
#endif

/** Outstanding membership requests one node can track (ub_member.h). */
#ifndef UB_MAX_MEMBER_REQUESTS
#define UB_MAX_MEMBER_REQUESTS 16
#endif

/** Remote inspection requests one node keeps open at once (ub_inspect.h; each holds one payload). */
#ifndef UB_MAX_INSPECT_REQUESTS
#define UB_MAX_INSPECT_REQUESTS 4
#endif
/** Removed entities the routing engine refuses to re-learn for a while (ub_route.h). */
#ifndef UB_ROUTE_TOMBSTONES
#define UB_ROUTE_TOMBSTONES 8
#endif
/** Default bound on the destinations one neighbour (one link) may have route entries for (ub_route.h
 * `max_dests`). The default is the whole entity table: in a fleet one relay (a ground station's radio, a
 * mothership) legitimately teaches every other entity, and a smaller default cut the newest vehicle of the
 * 14-entity demo fleet off (26 % delivery, 17 s to reconverge). A fleet that can name its relays sets a
 * smaller bound per node (`max_dests`), so that a key-holding insider advertising a thousand destinations
 * takes at most that many rows of the route table and of the learned-entity table. */
#ifndef UB_ROUTE_MAX_DESTS_PER_NEIGHBOUR
#define UB_ROUTE_MAX_DESTS_PER_NEIGHBOUR UB_MAX_ENTITIES
#endif

/* ---- identity per entity (ub_ident.h, issue 23) ---- */
/** Peers' certificates one identity store holds (184 bytes each: with 64 revocations the store is 18,872
 *  bytes on a Cortex-M4 hosting one entity, 19,712 on a 64-bit host with UB_MAX_LOCAL_ENTITIES 4). */
#ifndef UB_IDENT_MAX_PEERS
#define UB_IDENT_MAX_PEERS 64
#endif
/** Revoked entities one store holds (one record each: a newer record replaces an older one in place). */
#ifndef UB_IDENT_MAX_REVOCATIONS
#define UB_IDENT_MAX_REVOCATIONS 64
#endif

/* ---- origin authentication (ub_origin.h; docs/security.md, "Origin authentication") ---- */
/** Pairwise keys (local entity, peer entity) one ub_origin_t caches; the least recently used is evicted. */
#ifndef UB_ORIGIN_PEERS
#define UB_ORIGIN_PEERS 64
#endif
/** Local identities (entities with their own X25519 secret key) one ub_origin_t holds. */
#ifndef UB_ORIGIN_LOCALS
#define UB_ORIGIN_LOCALS UB_MAX_LOCAL_ENTITIES
#endif
/* How the frame security (ub_sec.c, ub_origin.c) initialises libsodium: sodium_init(). A bare-metal board
 * whose libsodium has no OS random source installs its own (randombytes_set_implementation()) and may define
 * this as 0: there sodium_init() would only pick x86 SIMD code (the portable implementations are libsodium's
 * static defaults) and link every primitive it can pick (X25519 and Argon2: 40 KiB of flash). */
#ifndef UB_SODIUM_INIT
#define UB_SODIUM_INIT() sodium_init()
#endif

/* Key agreement in origin authentication (X25519 + BLAKE2b + KDF, ub_origin_pair_keys()). 0: provisioned
 * pairs only (ub_origin_add_pair(), `uavbus keys pairwise`), for a microcontroller: no X25519 is linked. */
#ifndef UB_ORIGIN_AGREEMENT
#define UB_ORIGIN_AGREEMENT 1
#endif

#if UB_MAX_PAYLOAD < 64 || UB_MAX_PAYLOAD > 65000
#error "UB_MAX_PAYLOAD must be between 64 and 65000 (the frame's payload size field is 16 bits)"
#endif
#if UB_MAX_DIRECTORY < UB_MAX_PAYLOAD || UB_MAX_DIRECTORY > 65535
#error "UB_MAX_DIRECTORY must be between UB_MAX_PAYLOAD and 65535 (the reassembled payload size is 16 bits)"
#endif
#if UB_MAX_LINKS_PER_ENTITY < 1 || UB_MAX_LINKS_PER_ENTITY > 8
#error "UB_MAX_LINKS_PER_ENTITY must be 1..8: the paper's link masks have one hex digit per link, 8 digits"
#endif
#if UB_MAX_ENTITIES < 2
#error "UB_MAX_ENTITIES must be at least 2"
#endif
#if UB_MAX_KEYS < 1 || UB_MAX_KEYS > 255
#error "UB_MAX_KEYS must be 1..255 (key ids are one byte)"
#endif
#if UB_DEFAULT_HOP_LIMIT < 1 || UB_DEFAULT_HOP_LIMIT > 255
#error "UB_DEFAULT_HOP_LIMIT must be 1..255"
#endif

#endif /* UB_CONFIG_H */
