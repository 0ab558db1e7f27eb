/**
 * @file ub_revoke.h
 * @brief Revocation that reaches the fleet (issue 23 item 4; docs/security.md "Revocation"): a
 *        service (ub_service.h) that carries authority-signed revocation records (ub_ident.h) from
 *        node to node, adds them to the node's identity store and persists them.
 *
 * Admin code UB_ADMIN_REVOCATION (24), payload = one UB_REVOCATION_LEN-byte record, sent
 * **link-local** (docs/wire-format.md): each node that learns a record it did not hold sends it on
 * every attached link, so it spreads hop by hop to the whole connected fleet, whatever the routes
 * (a revoked relay cannot hide it by refusing to route, as long as another path exists). The record
 * proves itself (the authority's Ed25519 signature), so it is accepted from any neighbour, signed
 * link or not, and a forwarder cannot forge or alter one.
 *
 *  - **Idempotent**: a record the store already covers (same or newer serial for the entity) changes
 *    nothing and is not sent on (counted `known`): copies die out after one hop.
 *  - **Bounded**: a node sends at most one record per `min_interval_ms` (all links at once), each new
 *    record `repeats` times, `repeat_ms` apart then doubling (a lossy radio, or a neighbour still challenging our
 *    freshness, gets another chance; a round no link took, all down, is retried and not counted), and verifies at most `verify_per_s` received records per
 *    second (Ed25519 costs ~50 us; more are dropped `backpressure`, counted `over_budget`): a flood of
 *    junk records cannot eat the CPU, and the genuine record's repeats get through after it.
 *  - **Persisted**: every record that changed the store is handed to `persist` (ub_revfile_persist()
 *    rewrites the revocations file atomically) before it is spread; a failure is counted and retried
 *    on the next tick.
 *  - From then on the store refuses the revoked entity (ub_ident_peer_kx_key(), _roles()), so the
 *    origin service and the policy refuse its frames and requests, and a certificate with the revoked
 *    serial (or an older one) is never accepted again.
 *
 * The operator injects a record with ub_revoke_submit() (uavbus_node stdin `revoke FILE`, Python
 * `Node.identity.submit()`), exactly as if a neighbour had sent it.
 *
 * **Certificates travel the same way** (admin code UB_ADMIN_CERTIFICATE, 25, payload = one UB_CERT_LEN
 * certificate): a node announces its own certificates when the service starts, and every node that
 * learns a certificate it did not hold (a new entity, or a higher serial: the replacement of a revoked
 * vehicle) adds it to its store, hands it to `persist_cert` (ub_certfile_put(): the certificates file)
 * and spreads it, with the same repeats, rate and verification budget. A certificate the store refuses
 * (revoked serial, expired, another authority) is not spread. So a re-keyed replacement is known to the
 * fleet as soon as it starts, without touching the other nodes' files.
 *
 * State is caller-owned (ub_revoke_t embeds its ub_service_t); no allocation, no statics.
 */
#ifndef UB_REVOKE_H
#define UB_REVOKE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ub_ident.h"
#include "ub_node.h"
#include "ub_service.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Stores the store's revocation list durably; UB_OK or a negative error (retried on the next tick). */
typedef int (*ub_revoke_persist_fn)(void *user, const ub_ident_store_t *store);

/** Stores one newly learned certificate durably (UB_CERT_LEN bytes); UB_OK or a negative error (counted). */
typedef int (*ub_revoke_persist_cert_fn)(void *user, const uint8_t *cert, size_t len);

/** Told at once that what the store holds for peer `entity` changed: a revocation of it was accepted, or a
 *  new certificate (a replacement's keys). The origin service's ub_origin_forget_hook() fits: the revoked
 *  peer's cached pairwise keys go at once, not at the next recheck. */
typedef void (*ub_revoke_peer_fn)(void *user, const uint8_t entity[UB_ENTITY_ID_LEN]);

/** Certificates waiting to be spread at once (a newer one for the same entity takes its place). */
#ifndef UB_REVOKE_CERT_QUEUE
#define UB_REVOKE_CERT_QUEUE 8
#endif

/** Options (0 = default). */
typedef struct ub_revoke_options {
    uint32_t min_interval_ms; /**< least time between two records sent (default 50) */
    uint32_t repeat_ms;       /**< gap before the first repeat of a record, doubling after (default 200) */
    uint8_t repeats;          /**< times each new record is sent on every link (default 4) */
    uint16_t verify_per_s;    /**< received records and certificates verified per second at most (default 32) */
    /** Unix time in seconds, for certificates' validity (ub_identfile_unix_s() reads the wall clock); NULL:
     *  the node's now_ms / 1000 (a simulated clock that counts unix time, as the tests' worlds do). */
    uint64_t (*clock_s)(void *user);
    void *clock_user;
} ub_revoke_options_t;

/** What the service did. */
typedef struct ub_revoke_stats {
    uint32_t received;      /**< REVOCATION frames handed to it (and records submitted) */
    uint32_t accepted;      /**< records that changed the store (new entity revoked, or a higher serial) */
    uint32_t known;         /**< records the store already covered: nothing changed, not spread */
    uint32_t refused;       /**< malformed, wrong authority, bad signature (dropped bad_payload) */
    uint32_t full;          /**< refused: the store holds UB_IDENT_MAX_REVOCATIONS entities */
    uint32_t over_budget;   /**< not verified: more than verify_per_s this second (dropped backpressure) */
    uint32_t sent;          /**< REVOCATION frames sent (one per link per send) */
    uint32_t unsent;        /**< rounds no link took (all down or refusing): retried after repeat_ms, not counted as a repeat */
    uint32_t persisted;     /**< successful calls of `persist` */
    uint32_t persist_failures;
    uint32_t certs_received;  /**< CERTIFICATE frames handed to it */
    uint32_t certs_accepted;  /**< certificates that changed the store (new entity or higher serial): spread */
    uint32_t certs_known;     /**< already held: not spread */
    uint32_t certs_refused;   /**< malformed, another authority, bad signature, revoked, expired (bad_payload) */
    uint32_t certs_sent;      /**< CERTIFICATE frames sent */
    uint32_t certs_dropped;   /**< certificates not spread: the queue (UB_REVOKE_CERT_QUEUE) was full */
} ub_revoke_stats_t;

/** The service's state. Caller-owned; treat the fields as private. */
typedef struct ub_revoke {
    ub_service_t svc;
    ub_node_t *node;
    ub_ident_store_t *store;
    ub_revoke_persist_fn persist;
    void *persist_user;
    ub_revoke_options_t opt;
    bool dirty;                /**< the store changed and is not persisted yet */
    uint64_t next_send_ms;     /**< earliest time of the next send */
    uint64_t budget_window_ms; /**< start of the current verification second */
    uint16_t budget_used;
    struct {
        uint8_t remaining;  /**< sends left for store record i */
        int8_t from_link;   /**< link it arrived on (not sent back there the first time), -1 none */
        uint64_t due_ms;
    } spread[UB_IDENT_MAX_REVOCATIONS];
    ub_revoke_persist_cert_fn persist_cert;
    void *persist_cert_user;
    struct {
        uint8_t cert[UB_CERT_LEN];
        uint8_t remaining;  /**< 0: free */
        int8_t from_link;
        uint64_t due_ms;
    } certs[UB_REVOKE_CERT_QUEUE];
    ub_revoke_peer_fn on_peer;
    void *on_peer_user;
    ub_revoke_stats_t stats;
} ub_revoke_t;

/**
 * Initialises `rv` over `store` (its authority set) and registers it with `node`. `persist` may be
 * NULL (nothing stored: a test, or a node without a disk). Records already in the store (loaded from
 * the revocations file) are not sent again: the fleet had them.
 * @return UB_OK; UB_ERR_INVAL; UB_ERR_EXISTS / UB_ERR_FULL (as ub_node_add_service()).
 */
UB_CHECK int ub_revoke_init(ub_revoke_t *rv, ub_node_t *node, ub_ident_store_t *store,
                            const ub_revoke_options_t *opt, ub_revoke_persist_fn persist, void *persist_user);

/**
 * Distributes certificates too (see the file comment): `persist_cert` (may be NULL) stores each one
 * learned; this node's own certificates are announced from the next tick.
 * @return UB_OK; UB_ERR_INVAL.
 */
UB_CHECK int ub_revoke_spread_certificates(ub_revoke_t *rv, ub_revoke_persist_cert_fn persist_cert, void *user,
                                           uint64_t now_ms);

/** A certificate from the operator, handled as if received. @return UB_OK (new: spread); UB_ERR_EXISTS;
 *  UB_ERR_AUTH (refused); UB_ERR_FULL; UB_ERR_INVAL. */
UB_CHECK int ub_revoke_submit_certificate(ub_revoke_t *rv, const uint8_t *cert, size_t len, uint64_t now_ms);

/** Sets (or clears, NULL) the hook called when a revocation or a certificate of a peer is accepted
 *  (ub_revoke_peer_fn). @return UB_OK; UB_ERR_INVAL. */
UB_CHECK int ub_revoke_set_peer_hook(ub_revoke_t *rv, ub_revoke_peer_fn fn, void *user);

/** Unregisters the service. @return as ub_node_remove_service(). */
UB_CHECK int ub_revoke_remove(ub_revoke_t *rv);

/**
 * A record from the operator (a revocation file's record): handled as if received, with no budget.
 * @return UB_OK (accepted: it will be persisted and spread); UB_ERR_EXISTS (already held: nothing
 *         to do); UB_ERR_AUTH (refused); UB_ERR_FULL; UB_ERR_INVAL.
 */
UB_CHECK int ub_revoke_submit(ub_revoke_t *rv, const uint8_t *record, size_t len, uint64_t now_ms);

/** @return the service's counters. */
const ub_revoke_stats_t *ub_revoke_stats(const ub_revoke_t *rv);

#ifdef __cplusplus
}
#endif
#endif /* UB_REVOKE_H */
