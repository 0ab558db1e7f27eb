/**
 * @file ub_origin.h
 * @brief Origin authentication: a receiver-specific tag under a pairwise key agreed between the source
 *        entity and the destination entity, checked by the destination (docs/security.md, "Origin
 *        authentication"; wire: docs/wire-format.md, "Origin block").
 *
 * The group key (ub_sec.h) proves "a fleet member"; this proves "this entity". Each entity holds a
 * long-term X25519 key pair; the identity store (certificates, revocation: another module) answers
 * `lookup(entity_id, now_s) -> X25519 public key` and refuses unknown, revoked and expired peers.
 *
 *  - Pairwise keys (static-static, no round trip): q = X25519(sk_self, pk_peer);
 *    m = BLAKE2b-256("uavbus-origin-v1" | q | id_A | pk_A | id_B | pk_B), A the smaller entity ID;
 *    key A->B = KDF(m, subkey 1, "uborigin"), key B->A = KDF(m, subkey 2, "uborigin"), 16 bytes each
 *    (libsodium crypto_scalarmult, crypto_generichash, crypto_kdf_derive_from_key).
 *  - Origin tag: SipHash-2-4 (crypto_shorthash_siphash24) under the key source->destination over the
 *    68-byte signing header with domain "uavbus-org1", flags = ORIGIN alone and key id 0, then hop0, then
 *    the plaintext payload (ub_origin_tag()).
 *
 * The context is a service (ub_service.h: seal/open hooks): register it with ub_origin_attach(). Every
 * protected unicast frame a local entity originates gets an origin block; every frame reaching a local
 * entity over a link is checked before its window: no block `no_origin` (unless `optional`), a refused
 * identity `no_identity`, a wrong tag or a hop limit above hop0 `bad_origin`.
 *
 * Pairwise keys are cached in the caller-owned context: UB_ORIGIN_PEERS (local entity, peer) pairs, the
 * least recently used evicted (counted), each asked of the store again after `recheck_ms`. No allocation,
 * no statics.
 *
 * **Provisioned pairs** (microcontrollers, issue 23 item 8): an entity that cannot run X25519 takes the
 * directional keys the fleet authority computed for it (`uavbus keys pairwise`, the same keys its peers
 * derive from its certificate) with ub_origin_add_pair(): pinned, never evicted, never asked of a store,
 * removed only by ub_origin_forget() or a new provisioning. Built with UB_ORIGIN_AGREEMENT 0 (ub_config.h)
 * the context has no key agreement at all (no X25519 linked): provisioned pairs only.
 *
 *     static ub_origin_t org;                           // caller-owned (7.1 KiB with 64 peers, 64-bit host)
 *     ub_origin_options_t o = {.lookup = store_lookup, .lookup_user = &store};
 *     ub_origin_init(&org, &o);
 *     ub_origin_add_identity(&org, my_entity_id, my_x25519_sk);
 *     ub_origin_attach(&org, &node);                   // after ub_node_set_security()
 */
#ifndef UB_ORIGIN_H
#define UB_ORIGIN_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ub_config.h"
#include "ub_error.h"
#include "ub_frame.h"
#include "ub_service.h"

#ifdef __cplusplus
extern "C" {
#endif

#define UB_ORIGIN_SK_LEN 32u  /**< X25519 secret key */
#define UB_ORIGIN_PK_LEN 32u  /**< X25519 public key */
#define UB_ORIGIN_KEY_LEN 16u /**< a directional pairwise key (SipHash-2-4) */
#define UB_ORIGIN_DOMAIN "uavbus-org1"        /**< domain of the origin tag's header (11 bytes) */
#define UB_ORIGIN_AGREE_DOMAIN "uavbus-origin-v1" /**< domain of the pairwise master's hash input (16 bytes) */
#define UB_ORIGIN_KDF_CONTEXT "uborigin"       /**< KDF context (8 bytes): subkey 1 = A->B, 2 = B->A */
#define UB_ORIGIN_DEFAULT_RECHECK_MS 1000u

/**
 * The identity store: the X25519 public key of `entity_id`, valid at Unix time `now_s`.
 * @return 0 with `x25519_pk` written; negative when the peer is unknown, revoked or expired.
 */
typedef int (*ub_origin_lookup_fn)(void *user, const uint8_t entity_id[UB_ENTITY_ID_LEN], uint64_t now_s,
                                   uint8_t x25519_pk[UB_ORIGIN_PK_LEN]);

/** Unix time in seconds, for the store's validity periods. */
typedef uint64_t (*ub_origin_clock_fn)(void *user);

/** Options; zero fields mean the defaults. */
typedef struct ub_origin_options {
    ub_origin_lookup_fn lookup; /**< required, unless every pair is provisioned (ub_origin_add_pair()): NULL
                                     then refuses every peer without one (`no_identity`) */
    void *lookup_user;
    ub_origin_clock_fn clock_s; /**< NULL: the node's now_ms / 1000 */
    void *clock_user;
    uint32_t recheck_ms;        /**< a cached pair is asked of the store again after this; default 1000 */
    bool optional;              /**< accept frames without an origin block, and send without one to peers
                                     the store does not know (migration from group-key mode); default off:
                                     fail closed */
} ub_origin_options_t;

/** Counters. Drops are also in the node's drop counters (bad_origin, no_origin, no_identity). */
typedef struct ub_origin_stats {
    uint64_t sealed;      /**< origin blocks made */
    uint64_t opened;      /**< origin blocks verified */
    uint64_t bad_origin;  /**< tags that did not verify */
    uint64_t no_origin;   /**< frames without a block where one is required */
    uint64_t no_identity; /**< frames (in or out) for a peer or local entity without an identity */
    uint64_t derivations; /**< pairwise keys derived (X25519 + BLAKE2b + KDF) */
    uint64_t lookups;     /**< calls of the store */
    uint64_t evictions;   /**< cached pairs evicted for a new one (least recently used) */
    uint64_t rekeys;      /**< cached pairs whose peer public key changed at a recheck */
} ub_origin_stats_t;

/** One local identity. Treat as private. */
typedef struct ub_origin_local {
    uint8_t id[UB_ENTITY_ID_LEN];
    uint8_t sk[UB_ORIGIN_SK_LEN];
    uint8_t pk[UB_ORIGIN_PK_LEN];
    uint8_t in_use;
    uint8_t has_sk; /**< 0: provisioned pairs only (ub_origin_add_pair()), nothing to derive with */
} ub_origin_local_t;

/** One cached pair. Treat as private. */
typedef struct ub_origin_peer {
    uint8_t peer_id[UB_ENTITY_ID_LEN];
    uint8_t peer_pk[UB_ORIGIN_PK_LEN];
    uint8_t k_tx[UB_ORIGIN_KEY_LEN]; /**< local -> peer */
    uint8_t k_rx[UB_ORIGIN_KEY_LEN]; /**< peer -> local */
    uint64_t checked_ms;             /**< when the store last vouched for it */
    uint64_t last_used;              /**< LRU stamp */
    uint8_t local;                   /**< index into idents[] */
    uint8_t in_use;
    uint8_t pinned;                  /**< provisioned (ub_origin_add_pair()): no store, no eviction */
} ub_origin_peer_t;

/** The context: caller-owned, embeds its service record. Treat the fields as private. */
typedef struct ub_origin {
    ub_service_t svc;
    ub_origin_options_t opt;
    ub_origin_local_t idents[UB_ORIGIN_LOCALS];
    ub_origin_peer_t peers[UB_ORIGIN_PEERS];
    uint64_t lru_tick;
    ub_origin_stats_t stats;
    uint8_t initialised;
} ub_origin_t;

/**
 * Initialises an empty context.
 * @return UB_OK; UB_ERR_INVAL (NULL); UB_ERR_UNSUPPORTED (built without security); UB_ERR_IO
 *         (libsodium failed to initialise).
 */
UB_CHECK int ub_origin_init(ub_origin_t *o, const ub_origin_options_t *opt);

/**
 * Gives local entity `entity_id` its X25519 secret key (copied; its public key is derived).
 * @return UB_OK; UB_ERR_INVAL; UB_ERR_EXISTS (that entity has one); UB_ERR_FULL (UB_ORIGIN_LOCALS).
 */
UB_CHECK int ub_origin_add_identity(ub_origin_t *o, const uint8_t entity_id[UB_ENTITY_ID_LEN],
                                    const uint8_t x25519_sk[UB_ORIGIN_SK_LEN]);

/**
 * A provisioned pair (no key agreement): local entity `entity_id` uses `k_tx` for its frames to `peer_id` and
 * checks `peer_id`'s frames with `k_rx` (16 bytes each, from the authority's table: `uavbus keys pairwise`).
 * The local entity needs no secret key (one is added without one if absent); the pair is pinned: never
 * evicted, never re-checked with the store; a second call for the same pair replaces its keys.
 * @return UB_OK; UB_ERR_INVAL (NULL, equal IDs, not initialised); UB_ERR_FULL (UB_ORIGIN_LOCALS, or
 *         UB_ORIGIN_PEERS all pinned).
 */
UB_CHECK int ub_origin_add_pair(ub_origin_t *o, const uint8_t entity_id[UB_ENTITY_ID_LEN],
                                const uint8_t peer_id[UB_ENTITY_ID_LEN], const uint8_t k_tx[UB_ORIGIN_KEY_LEN],
                                const uint8_t k_rx[UB_ORIGIN_KEY_LEN]);

/* A microcontroller's provisioning table (`uavbus keys pairwise`, docs/security.md "Microcontrollers"), all
 * integers little-endian: "UBPR", version 1, n, 2 reserved; the entity ID (12); the group key id, flags
 * (bit 0: a group key follows), 2 reserved; the group master key (32, zero without one); n x (peer ID 12,
 * key entity->peer 16, key peer->entity 16); CRC-32C of everything before it (4). The CRC finds a damaged
 * or half-written flash area; who may write that area is the board's protection, not the table's. */
#define UB_ORIGIN_PAIRS_MAGIC "UBPR"
#define UB_ORIGIN_PAIRS_HEADER_LEN 56u
#define UB_ORIGIN_PAIRS_ENTRY_LEN 44u
#define UB_ORIGIN_PAIRS_LEN(n) (UB_ORIGIN_PAIRS_HEADER_LEN + (n) * UB_ORIGIN_PAIRS_ENTRY_LEN + 4u)

/** What a provisioning table holds besides its pairs. */
typedef struct ub_origin_provision {
    uint8_t entity_id[UB_ENTITY_ID_LEN];
    uint8_t group_key[32]; /**< the fleet's group master key (ub_sec_add_key()), if has_group_key */
    uint8_t group_key_id;
    bool has_group_key;
    uint8_t pairs;         /**< pairs installed */
} ub_origin_provision_t;

/**
 * Installs the pairs of provisioning table `table` (`len` bytes; e.g. a flash area) with
 * ub_origin_add_pair() and reports the rest in `out` (the caller adds the group key to its ub_sec_t, then
 * wipes `out`). Checks everything before installing anything; a refused table leaves no pair of its own.
 * A peer listed twice keeps the later keys.
 * @return the number of entries (>= 0); UB_ERR_INVAL (NULL, not initialised); UB_ERR_CONFIG (no table: wrong
 *         magic or version, a length that does not match n, a bad CRC, a pair with itself); UB_ERR_FULL (more
 *         pairs than UB_ORIGIN_PEERS, or than rows not already provisioned).
 */
UB_CHECK int ub_origin_load_pairs(ub_origin_t *o, const uint8_t *table, size_t len, ub_origin_provision_t *out);

/** Registers the context's service with `node` (ub_node_add_service()). @return as that. */
UB_CHECK int ub_origin_attach(ub_origin_t *o, ub_node_t *node);

/** Unregisters it. @return as ub_node_remove_service(). */
UB_CHECK int ub_origin_detach(ub_origin_t *o, ub_node_t *node);

/** Forgets every cached pair with peer `peer_id` (e.g. at once on a revocation). @return pairs forgotten. */
size_t ub_origin_forget(ub_origin_t *o, const uint8_t peer_id[UB_ENTITY_ID_LEN]);

/** ub_origin_forget() with the signature of a revocation hook (ub_revoke_set_peer_hook(): `origin` is the
 *  ub_origin_t), so a revocation accepted by the revocation service ends the revoked peer's pairs at once. */
void ub_origin_forget_hook(void *origin, const uint8_t peer_id[UB_ENTITY_ID_LEN]);

/** @return cached pairs in use. */
size_t ub_origin_cached(const ub_origin_t *o);

/** @return the counters. */
const ub_origin_stats_t *ub_origin_stats(const ub_origin_t *o);

/* ---- pure functions (vectors, bench, other bindings) ---- */

/** X25519 public key of a secret key. @return UB_OK or UB_ERR_UNSUPPORTED (no security, or
 *  UB_ORIGIN_AGREEMENT 0). */
UB_CHECK int ub_origin_public_key(const uint8_t sk[UB_ORIGIN_SK_LEN], uint8_t pk[UB_ORIGIN_PK_LEN]);

/**
 * The directional pairwise keys of entity `self_id` (secret key `self_sk`) with `peer_id` (public key
 * `peer_pk`): `k_tx` for frames self -> peer, `k_rx` for peer -> self.
 * @return UB_OK; UB_ERR_INVAL (NULL, equal IDs); UB_ERR_AUTH (a small-order peer key: all-zero agreement);
 *         UB_ERR_UNSUPPORTED (no security, or UB_ORIGIN_AGREEMENT 0).
 */
UB_CHECK int ub_origin_pair_keys(const uint8_t self_id[UB_ENTITY_ID_LEN], const uint8_t self_sk[UB_ORIGIN_SK_LEN],
                                 const uint8_t peer_id[UB_ENTITY_ID_LEN], const uint8_t peer_pk[UB_ORIGIN_PK_LEN],
                                 uint8_t k_tx[UB_ORIGIN_KEY_LEN], uint8_t k_rx[UB_ORIGIN_KEY_LEN]);

/**
 * The origin tag of a frame (`h`: header fields and h->origin_hop0; flags and key id ignored) with
 * plaintext `payload` (h->payload_size bytes) under directional key `key`.
 * @return UB_OK; UB_ERR_INVAL; UB_ERR_RANGE (payload too large); UB_ERR_UNSUPPORTED.
 */
UB_CHECK int ub_origin_tag(const uint8_t key[UB_ORIGIN_KEY_LEN], const ub_frame_header_t *h, const uint8_t *payload,
                           uint8_t tag[UB_FRAME_ORIGIN_TAG_LEN]);

#ifdef __cplusplus
}
#endif
#endif /* UB_ORIGIN_H */
