/* cffi cdef for runtime_c/include/ub/ub_ident.h: certificates, revocation records, the identity store
 * (all cryptography in C, libsodium). */

#define UB_IDENT_MAX_PEERS ...
#define UB_IDENT_MAX_REVOCATIONS ...
#define UB_IDENT_VERSION ...
#define UB_IDENT_SIGN_PK_LEN ...
#define UB_IDENT_SIGN_SK_LEN ...
#define UB_IDENT_SEED_LEN ...
#define UB_IDENT_KX_PK_LEN ...
#define UB_IDENT_KX_SK_LEN ...
#define UB_IDENT_SIG_LEN ...
#define UB_IDENT_KID_LEN ...
#define UB_CERT_LEN ...
#define UB_REVOCATION_LEN ...

enum {
    UB_ROLE_ADMIN, UB_ROLE_VEHICLE, UB_ROLE_RELAY, UB_ROLE_BRIDGE, UB_ROLE_OBSERVER, UB_ROLES_KNOWN
};

typedef enum ub_ident_status {
    UB_IDENT_VALID, UB_IDENT_UNKNOWN, UB_IDENT_REVOKED, UB_IDENT_EXPIRED, UB_IDENT_NOT_YET_VALID,
    UB_IDENT_WRONG_AUTHORITY, UB_IDENT_BAD_SIGNATURE, UB_IDENT_MALFORMED
} ub_ident_status_t;

typedef struct ub_cert {
    uint8_t version;
    uint16_t roles;
    uint64_t serial;
    uint8_t entity[12];
    uint8_t sign_pk[32];
    uint8_t kx_pk[32];
    uint64_t not_before;
    uint64_t not_after;
    uint8_t authority[8];
    uint8_t sig[64];
} ub_cert_t;

typedef struct ub_revocation {
    uint64_t serial;
    uint8_t entity[12];
    uint64_t time_s;
    uint8_t authority[8];
    uint8_t sig[64];
} ub_revocation_t;

typedef struct ub_ident_stats {
    uint32_t peers_added;
    uint32_t peers_refused[8];
    uint32_t peers_full;
    uint32_t peers_removed;
    uint32_t lookups;
    uint32_t lookups_refused[8];
    uint32_t revocations_added;
    uint32_t revocations_known;
    uint32_t revocations_refused;
    uint32_t revocations_full;
} ub_ident_stats_t;

/* Opaque here: its size comes from the compiler. */
typedef struct ub_ident_store {
    ...;
} ub_ident_store_t;

const char *ub_ident_status_name(ub_ident_status_t status);
const char *ub_ident_role_name(uint16_t role);
int ub_ident_authority_kid(const uint8_t pk[], uint8_t kid[]);
int ub_ident_sign_keypair(const uint8_t seed[], uint8_t pk[], uint8_t sk[]);
int ub_ident_kx_keypair(const uint8_t seed[], uint8_t pk[], uint8_t sk[]);
int ub_ident_kx_public(const uint8_t sk[], uint8_t pk[]);
int ub_ident_random(uint8_t *out, size_t len);
int ub_cert_encode(const ub_cert_t *cert, uint8_t out[]);
int ub_cert_decode(ub_cert_t *cert, const uint8_t *buf, size_t len);
int ub_cert_sign(ub_cert_t *cert, const uint8_t authority_sk[]);
ub_ident_status_t ub_cert_verify(const ub_cert_t *cert, const uint8_t authority_pk[]);
ub_ident_status_t ub_cert_check_time(const ub_cert_t *cert, uint64_t now_s);
int ub_revocation_encode(const ub_revocation_t *rev, uint8_t out[]);
int ub_revocation_decode(ub_revocation_t *rev, const uint8_t *buf, size_t len);
int ub_revocation_sign(ub_revocation_t *rev, const uint8_t authority_sk[]);
ub_ident_status_t ub_revocation_verify(const ub_revocation_t *rev, const uint8_t authority_pk[]);
void ub_ident_store_init(ub_ident_store_t *store);
int ub_ident_set_authority(ub_ident_store_t *store, const uint8_t pk[]);
int ub_ident_add_peer(ub_ident_store_t *store, const uint8_t *cert, size_t len, uint64_t now_s, ub_ident_status_t *why);
int ub_ident_add_revocation(ub_ident_store_t *store, const uint8_t *rec, size_t len, ub_ident_status_t *why);
bool ub_ident_is_revoked(const ub_ident_store_t *store, const uint8_t entity[], uint64_t serial);
size_t ub_ident_revocation_count(const ub_ident_store_t *store);
int ub_ident_revocation_at(const ub_ident_store_t *store, size_t index, uint8_t out[]);
const ub_cert_t *ub_ident_self(const ub_ident_store_t *store);
ub_ident_status_t ub_ident_peer_status(const ub_ident_store_t *store, const uint8_t entity_id[], uint64_t now_s);
const uint8_t *ub_ident_self_kx_sk_for(const ub_ident_store_t *store, const uint8_t entity_id[]);
int ub_ident_peer_kx_key(void *store, const uint8_t entity_id[], uint64_t now_s, uint8_t pk[]);
int ub_ident_peer_roles(const ub_ident_store_t *store, const uint8_t entity_id[], uint64_t now_s, uint16_t *roles);
const ub_ident_stats_t *ub_ident_stats(const ub_ident_store_t *store);
