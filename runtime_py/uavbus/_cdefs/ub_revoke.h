/* cffi cdef for runtime_c/include/ub/ub_revoke.h: the revocation service (identity per entity). */

typedef int (*ub_revoke_persist_fn)(void *user, const ub_ident_store_t *store);

typedef struct ub_revoke_options {
    uint32_t min_interval_ms;
    uint32_t repeat_ms;
    uint8_t repeats;
    uint16_t verify_per_s;
    uint64_t (*clock_s)(void *user);
    void *clock_user;
} ub_revoke_options_t;

typedef int (*ub_revoke_persist_cert_fn)(void *user, const uint8_t *cert, size_t len);

typedef struct ub_revoke_stats {
    uint32_t received;
    uint32_t accepted;
    uint32_t known;
    uint32_t refused;
    uint32_t full;
    uint32_t over_budget;
    uint32_t sent;
    uint32_t unsent;
    uint32_t persisted;
    uint32_t persist_failures;
    uint32_t certs_received;
    uint32_t certs_accepted;
    uint32_t certs_known;
    uint32_t certs_refused;
    uint32_t certs_sent;
    uint32_t certs_dropped;
} ub_revoke_stats_t;

/* Opaque here: its size comes from the compiler. */
typedef struct ub_revoke {
    ...;
} ub_revoke_t;

int ub_revoke_init(ub_revoke_t *rv, ub_node_t *node, ub_ident_store_t *store, const ub_revoke_options_t *opt,
                   ub_revoke_persist_fn persist, void *persist_user);
int ub_revoke_remove(ub_revoke_t *rv);
int ub_revoke_submit(ub_revoke_t *rv, const uint8_t *record, size_t len, uint64_t now_ms);
const ub_revoke_stats_t *ub_revoke_stats(const ub_revoke_t *rv);
int ub_revoke_spread_certificates(ub_revoke_t *rv, ub_revoke_persist_cert_fn persist_cert, void *user, uint64_t now_ms);
int ub_revoke_submit_certificate(ub_revoke_t *rv, const uint8_t *cert, size_t len, uint64_t now_ms);
typedef void (*ub_revoke_peer_fn)(void *user, const uint8_t entity[]);
int ub_revoke_set_peer_hook(ub_revoke_t *rv, ub_revoke_peer_fn fn, void *user);
