/**
 * @file ub_ident.h
 * @brief Identity per entity (issue 23, docs/security.md "Identity per entity"): certificates issued
 *        by a fleet authority, signed revocation records, and the caller-owned identity store that
 *        answers "what is entity X's key, and what may it do?".
 *
 * **Certificate** (UB_CERT_LEN = 176 bytes, little-endian, docs/wire-format.md#identity-certificates):
 *
 *     off len field
 *       0   1 version       UB_IDENT_VERSION (1)
 *       1   1 kind          UB_IDENT_KIND_CERT (1)
 *       2   2 roles         UB_ROLE_* bits; bits outside UB_ROLES_KNOWN are refused
 *       4   8 serial        issued by the authority, > 0, grows with every certificate it issues
 *      12  12 entity        entity ID (the catalogue's: name padded with 0x00)
 *      24  32 sign_pk       entity's Ed25519 public key
 *      56  32 kx_pk         entity's X25519 public key (a separate key pair, not converted from sign_pk)
 *      88   8 not_before    unix seconds
 *      96   8 not_after     unix seconds (>= not_before)
 *     104   8 authority     authority key id: the first 8 bytes of BLAKE2b-256(authority Ed25519 pk)
 *     112  64 signature     Ed25519 (libsodium crypto_sign_detached) by the authority over bytes 0..111
 *
 * **Revocation record** (UB_REVOCATION_LEN = 104 bytes):
 *
 *       0   1 version 1;  1 1 kind UB_IDENT_KIND_REVOCATION (2);  2 2 reserved (0)
 *       4   8 serial      every certificate of `entity` with a serial <= this one is revoked
 *      12  12 entity
 *      24   8 time        unix seconds when the authority revoked it (informative)
 *      32   8 authority   as in the certificate
 *      40  64 signature   Ed25519 by the authority over bytes 0..39
 *
 * The kind byte is inside what is signed, so a certificate can never pass for a revocation or the
 * reverse. A revocation covers every serial up to its own: the old certificate of a lost vehicle,
 * and any older one, are refused for good; the replacement gets a new (higher) serial.
 *
 * Why a separate X25519 key pair rather than crypto_sign_ed25519_pk_to_curve25519(): libsodium's
 * documentation recommends distinct keys for signing and key agreement; it costs 32 bytes in the
 * certificate and 32 secret bytes, and it lets an MCU entity hold only the X25519 half it needs.
 *
 * **Store**: ub_ident_store_t holds the authority's public key, this node's own identities (certificate
 * and secret keys of each hosted entity), up to UB_IDENT_MAX_PEERS peers' verified certificates and up to
 * UB_IDENT_MAX_REVOCATIONS revocation records. Caller-owned, fixed size, no allocation, no statics.
 * A certificate enters only verified under the authority, inside its validity period and not
 * revoked; a revocation enters only verified, and removes the peers it covers at once.
 *
 * Every function verifying a signature needs libsodium (UB_SECURITY); without it they return
 * UB_ERR_UNSUPPORTED and the store stays empty (fail closed). Decoding needs nothing.
 */
#ifndef UB_IDENT_H
#define UB_IDENT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ub_catalogue.h" /* UB_ENTITY_ID_LEN */
#include "ub_config.h"
#include "ub_error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Capacities: UB_IDENT_MAX_PEERS and UB_IDENT_MAX_REVOCATIONS in ub_config.h. */

#define UB_IDENT_VERSION 1u
#define UB_IDENT_KIND_CERT 1u
#define UB_IDENT_KIND_REVOCATION 2u

#define UB_IDENT_SIGN_PK_LEN 32u /**< Ed25519 public key */
#define UB_IDENT_SIGN_SK_LEN 64u /**< libsodium's Ed25519 secret key (seed || public key) */
#define UB_IDENT_SEED_LEN 32u    /**< Ed25519 seed / X25519 secret key */
#define UB_IDENT_KX_PK_LEN 32u   /**< X25519 public key */
#define UB_IDENT_KX_SK_LEN 32u   /**< X25519 secret key */
#define UB_IDENT_SIG_LEN 64u     /**< Ed25519 signature */
#define UB_IDENT_KID_LEN 8u      /**< authority key id */

#define UB_CERT_SIGNED_LEN 112u
#define UB_CERT_LEN 176u
#define UB_REVOCATION_SIGNED_LEN 40u
#define UB_REVOCATION_LEN 104u

/** Certified roles (a bitmask; docs/security.md "Roles"). */
enum {
    UB_ROLE_ADMIN = 0x0001u,    /**< may administer other entities (publish/subscribe tables, membership, inspection) */
    UB_ROLE_VEHICLE = 0x0002u,  /**< a vehicle (flight computer, onboard computer) */
    UB_ROLE_RELAY = 0x0004u,    /**< forwards for others */
    UB_ROLE_BRIDGE = 0x0008u,   /**< a bridge to another protocol (MAVLink) */
    UB_ROLE_OBSERVER = 0x0010u, /**< reads only */
    UB_ROLES_KNOWN = 0x001Fu
};

/** Why a certificate or a peer is refused (ub_ident_peer_status(), counters). */
typedef enum ub_ident_status {
    UB_IDENT_VALID = 0,
    UB_IDENT_UNKNOWN = 1,         /**< no certificate for this entity */
    UB_IDENT_REVOKED = 2,         /**< a revocation covers its serial */
    UB_IDENT_EXPIRED = 3,         /**< now > not_after */
    UB_IDENT_NOT_YET_VALID = 4,   /**< now < not_before */
    UB_IDENT_WRONG_AUTHORITY = 5, /**< issued by another authority (key id differs) */
    UB_IDENT_BAD_SIGNATURE = 6,   /**< the authority's signature does not verify */
    UB_IDENT_MALFORMED = 7        /**< not a version-1 certificate / record (length, kind, roles, reserved bits) */
} ub_ident_status_t;

/** A decoded certificate. */
typedef struct ub_cert {
    uint8_t version;
    uint16_t roles;
    uint64_t serial;
    uint8_t entity[UB_ENTITY_ID_LEN];
    uint8_t sign_pk[UB_IDENT_SIGN_PK_LEN];
    uint8_t kx_pk[UB_IDENT_KX_PK_LEN];
    uint64_t not_before;
    uint64_t not_after;
    uint8_t authority[UB_IDENT_KID_LEN];
    uint8_t sig[UB_IDENT_SIG_LEN];
} ub_cert_t;

/** A decoded revocation record. */
typedef struct ub_revocation {
    uint64_t serial;
    uint8_t entity[UB_ENTITY_ID_LEN];
    uint64_t time_s;
    uint8_t authority[UB_IDENT_KID_LEN];
    uint8_t sig[UB_IDENT_SIG_LEN];
} ub_revocation_t;

/** @return a static name for a status ("revoked", "expired"...). */
const char *ub_ident_status_name(ub_ident_status_t status);

/** Role names, in bit order: "admin", "vehicle", "relay", "bridge", "observer". @return the name of one
 *  role bit, or NULL. */
const char *ub_ident_role_name(uint16_t role);

/* ---- keys ---------------------------------------------------------------------------------------- */

/** Key id of an authority public key: the first 8 bytes of BLAKE2b-256(pk). @return UB_OK, UB_ERR_UNSUPPORTED. */
UB_CHECK int ub_ident_authority_kid(const uint8_t pk[UB_IDENT_SIGN_PK_LEN], uint8_t kid[UB_IDENT_KID_LEN]);

/** Ed25519 key pair from a 32-byte seed (crypto_sign_seed_keypair). @return UB_OK, UB_ERR_UNSUPPORTED. */
UB_CHECK int ub_ident_sign_keypair(const uint8_t seed[UB_IDENT_SEED_LEN], uint8_t pk[UB_IDENT_SIGN_PK_LEN],
                                   uint8_t sk[UB_IDENT_SIGN_SK_LEN]);

/** X25519 key pair from a 32-byte seed (crypto_kx_seed_keypair). @return UB_OK, UB_ERR_UNSUPPORTED. */
UB_CHECK int ub_ident_kx_keypair(const uint8_t seed[UB_IDENT_SEED_LEN], uint8_t pk[UB_IDENT_KX_PK_LEN],
                                 uint8_t sk[UB_IDENT_KX_SK_LEN]);

/** X25519 public key of a secret key (crypto_scalarmult_base; the scalar is clamped, so every 32 bytes, zeros
 *  included, give a key). @return UB_OK, UB_ERR_AUTH (libsodium refused the result: an all-zero point, which a
 *  clamped scalar never gives), UB_ERR_UNSUPPORTED (a build without libsodium). */
UB_CHECK int ub_ident_kx_public(const uint8_t sk[UB_IDENT_KX_SK_LEN], uint8_t pk[UB_IDENT_KX_PK_LEN]);

/** Fills `out` with `len` random bytes from libsodium. @return UB_OK, UB_ERR_UNSUPPORTED. */
UB_CHECK int ub_ident_random(uint8_t *out, size_t len);

/* ---- certificates -------------------------------------------------------------------------------- */

/** Encodes all UB_CERT_LEN bytes (signature as held in `cert`). @return UB_OK; UB_ERR_INVAL (NULL). */
UB_CHECK int ub_cert_encode(const ub_cert_t *cert, uint8_t out[UB_CERT_LEN]);

/**
 * Decodes `buf[0, len)` with strict checks: len == UB_CERT_LEN, version 1, kind certificate, no unknown
 * role bit, serial > 0, entity neither all 0x00 nor all 0xFF, not_before <= not_after. Does not verify
 * the signature (ub_cert_verify()).
 * @return UB_OK; UB_ERR_TRUNCATED (len wrong); UB_ERR_CONFIG (a field out of its domain); UB_ERR_INVAL (NULL).
 */
UB_CHECK int ub_cert_decode(ub_cert_t *cert, const uint8_t *buf, size_t len);

/** Sets `cert->authority` from `authority_sk`'s public half and signs. @return UB_OK; UB_ERR_INVAL;
 *  UB_ERR_CONFIG (a field ub_cert_decode() would refuse); UB_ERR_UNSUPPORTED. */
UB_CHECK int ub_cert_sign(ub_cert_t *cert, const uint8_t authority_sk[UB_IDENT_SIGN_SK_LEN]);

/** Verifies the authority's signature: UB_IDENT_VALID, UB_IDENT_WRONG_AUTHORITY, UB_IDENT_BAD_SIGNATURE,
 *  UB_IDENT_MALFORMED (NULL, or a build without libsodium: nothing verifies). Time is not checked. */
ub_ident_status_t ub_cert_verify(const ub_cert_t *cert, const uint8_t authority_pk[UB_IDENT_SIGN_PK_LEN]);

/** UB_IDENT_VALID, UB_IDENT_NOT_YET_VALID or UB_IDENT_EXPIRED at unix time `now_s` (inclusive bounds). */
ub_ident_status_t ub_cert_check_time(const ub_cert_t *cert, uint64_t now_s);

/* ---- revocation records -------------------------------------------------------------------------- */

/** Encodes all UB_REVOCATION_LEN bytes. @return UB_OK; UB_ERR_INVAL. */
UB_CHECK int ub_revocation_encode(const ub_revocation_t *rev, uint8_t out[UB_REVOCATION_LEN]);

/** Strict decode as ub_cert_decode() (len, version, kind, reserved 0, serial > 0, entity). */
UB_CHECK int ub_revocation_decode(ub_revocation_t *rev, const uint8_t *buf, size_t len);

/** Sets the authority key id and signs. @return as ub_cert_sign(). */
UB_CHECK int ub_revocation_sign(ub_revocation_t *rev, const uint8_t authority_sk[UB_IDENT_SIGN_SK_LEN]);

/** As ub_cert_verify(). */
ub_ident_status_t ub_revocation_verify(const ub_revocation_t *rev, const uint8_t authority_pk[UB_IDENT_SIGN_PK_LEN]);

/* ---- the identity store -------------------------------------------------------------------------- */

/** What a store did (every refusal is counted by reason). */
typedef struct ub_ident_stats {
    uint32_t peers_added;       /**< certificates accepted (new or a newer serial) */
    uint32_t peers_refused[8];  /**< certificates refused, by ub_ident_status_t */
    uint32_t peers_full;        /**< refused: UB_IDENT_MAX_PEERS valid peers held */
    uint32_t peers_removed;     /**< removed by a revocation */
    uint32_t lookups;           /**< key or role queries answered */
    uint32_t lookups_refused[8]; /**< queries refused, by ub_ident_status_t */
    uint32_t revocations_added;
    uint32_t revocations_known;   /**< records already covered (idempotent: nothing changed) */
    uint32_t revocations_refused; /**< malformed, wrong authority, bad signature */
    uint32_t revocations_full;    /**< refused: UB_IDENT_MAX_REVOCATIONS entities revoked */
} ub_ident_stats_t;

/** Caller-owned identity store; treat the fields as private (ub_ident_* below). */
/** One of this node's own identities (one per hosted entity). */
typedef struct ub_ident_self {
    ub_cert_t cert;
    uint8_t sign_sk[UB_IDENT_SIGN_SK_LEN];
    uint8_t kx_sk[UB_IDENT_KX_SK_LEN];
} ub_ident_self_t;

typedef struct ub_ident_store {
    uint8_t has_authority;
    uint8_t n_selves;
    uint8_t authority_pk[UB_IDENT_SIGN_PK_LEN];
    uint8_t authority_kid[UB_IDENT_KID_LEN];
    ub_ident_self_t selves[UB_MAX_LOCAL_ENTITIES]; /**< this node's identities, one per hosted entity */
    uint16_t n_peers;
    ub_cert_t peers[UB_IDENT_MAX_PEERS];
    uint16_t n_revoked;
    ub_revocation_t revoked[UB_IDENT_MAX_REVOCATIONS]; /**< append-only order: index i is stable */
    ub_ident_stats_t stats;
} ub_ident_store_t;

/** Empties `store` (secret keys wiped). */
void ub_ident_store_init(ub_ident_store_t *store);

/** Wipes the secret keys and empties the store. */
void ub_ident_store_clear(ub_ident_store_t *store);

/** Sets the authority whose certificates and revocations the store accepts; forgets every peer and
 *  revocation of another authority. @return UB_OK; UB_ERR_INVAL; UB_ERR_UNSUPPORTED. */
UB_CHECK int ub_ident_set_authority(ub_ident_store_t *store, const uint8_t pk[UB_IDENT_SIGN_PK_LEN]);

/**
 * Adds one of this node's own identities (one per hosted entity, up to UB_MAX_LOCAL_ENTITIES; the same
 * entity again replaces its identity): `cert` must verify under the authority, be valid at `now_s` and
 * not revoked, and the secret keys must be the certificate's (their public halves are recomputed).
 * @return UB_OK; UB_ERR_NOTFOUND (no authority yet); UB_ERR_AUTH (`*why` says which check failed:
 *         signature, authority, time, revocation, or UB_IDENT_MALFORMED for keys that do not match);
 *         UB_ERR_FULL; UB_ERR_INVAL; UB_ERR_UNSUPPORTED.
 */
UB_CHECK int ub_ident_set_self(ub_ident_store_t *store, const ub_cert_t *cert,
                               const uint8_t sign_sk[UB_IDENT_SIGN_SK_LEN], const uint8_t kx_sk[UB_IDENT_KX_SK_LEN],
                               uint64_t now_s, ub_ident_status_t *why);

/** @return this node's first identity's certificate, or NULL (none set). */
const ub_cert_t *ub_ident_self(const ub_ident_store_t *store);

/** @return the number of this node's identities. */
size_t ub_ident_self_count(const ub_ident_store_t *store);

/** @return identity `index` (0 .. count-1) of this node, or NULL. */
const ub_ident_self_t *ub_ident_self_at(const ub_ident_store_t *store, size_t index);

/** @return the X25519 secret key of this node's first identity, or NULL (none set). */
const uint8_t *ub_ident_self_kx_sk(const ub_ident_store_t *store);

/** @return the X25519 secret key of this node's identity for hosted entity `entity_id`, or NULL. For the
 *  origin service's key agreement (ub_origin_add_identity() per hosted entity). */
const uint8_t *ub_ident_self_kx_sk_for(const ub_ident_store_t *store, const uint8_t entity_id[UB_ENTITY_ID_LEN]);

/**
 * Adds (or renews) a peer's certificate from its UB_CERT_LEN bytes: decoded strictly, verified under
 * the authority, valid at `now_s`, not revoked. A certificate with a lower serial than the one held
 * for the entity is refused (UB_IDENT_REVOKED: an older identity never replaces a newer one); the same
 * serial is idempotent. When the table is full, an entry that is no longer valid (expired) is reused.
 * @return UB_OK; UB_ERR_AUTH (`*why`, may be NULL, says why); UB_ERR_FULL; UB_ERR_INVAL.
 */
UB_CHECK int ub_ident_add_peer(ub_ident_store_t *store, const uint8_t *cert, size_t len, uint64_t now_s,
                               ub_ident_status_t *why);

/**
 * Adds a revocation record from its UB_REVOCATION_LEN bytes, verified under the authority. It removes
 * the covered peers at once (and marks this node's own identity revoked when it is covered).
 * Idempotent: a record whose entity is already revoked up to this serial or beyond changes nothing.
 * @return index of the record in the store (>= 0) when it changed the store (new, or a higher serial
 *         replacing the entity's record in place); UB_ERR_EXISTS (already covered); UB_ERR_AUTH
 *         (malformed, wrong authority, bad signature: `*why`); UB_ERR_FULL; UB_ERR_INVAL.
 */
UB_CHECK int ub_ident_add_revocation(ub_ident_store_t *store, const uint8_t *rec, size_t len,
                                     ub_ident_status_t *why);

/** @return whether a held revocation covers (entity, serial). */
bool ub_ident_is_revoked(const ub_ident_store_t *store, const uint8_t entity[UB_ENTITY_ID_LEN], uint64_t serial);

/** @return the number of revocation records held. */
size_t ub_ident_revocation_count(const ub_ident_store_t *store);

/** Encodes record `index` (0 .. count-1). @return UB_OK; UB_ERR_NOTFOUND; UB_ERR_INVAL. */
UB_CHECK int ub_ident_revocation_at(const ub_ident_store_t *store, size_t index, uint8_t out[UB_REVOCATION_LEN]);

/**
 * Status of entity `entity_id` at `now_s`: UB_IDENT_VALID when the store holds a certificate for it
 * (this node's own counts) that is inside its validity period and not revoked; otherwise why not.
 */
ub_ident_status_t ub_ident_peer_status(const ub_ident_store_t *store, const uint8_t entity_id[UB_ENTITY_ID_LEN],
                                       uint64_t now_s);

/** @return the valid certificate held for `entity_id` at `now_s`, or NULL (unknown, revoked, expired). */
const ub_cert_t *ub_ident_peer_cert(const ub_ident_store_t *store, const uint8_t entity_id[UB_ENTITY_ID_LEN],
                                    uint64_t now_s);

/**
 * **The key lookup of the origin service** (ub_origin.h's callback; `store` is a ub_ident_store_t *):
 * copies the X25519 public key certified for `entity_id` into `pk` if the store holds a certificate
 * for it that is valid at unix time `now_s` and not revoked (this node's own entity included).
 * Counted in stats.lookups / lookups_refused.
 * @return UB_OK; UB_ERR_NOTFOUND (unknown entity); UB_ERR_AUTH (revoked, expired, not yet valid);
 *         UB_ERR_INVAL (NULL).
 */
int ub_ident_peer_kx_key(void *store, const uint8_t entity_id[UB_ENTITY_ID_LEN], uint64_t now_s,
                         uint8_t pk[UB_IDENT_KX_PK_LEN]);

/** The same for the entity's Ed25519 public key. */
int ub_ident_peer_sign_key(void *store, const uint8_t entity_id[UB_ENTITY_ID_LEN], uint64_t now_s,
                           uint8_t pk[UB_IDENT_SIGN_PK_LEN]);

/**
 * **Authorization data**: the roles certified for `entity_id` (a verified originator) at `now_s`.
 * @return UB_OK (`*roles` set); UB_ERR_NOTFOUND / UB_ERR_AUTH as ub_ident_peer_kx_key() (`*roles` = 0:
 *         an entity without a valid certificate has no role).
 */
int ub_ident_peer_roles(const ub_ident_store_t *store, const uint8_t entity_id[UB_ENTITY_ID_LEN], uint64_t now_s,
                        uint16_t *roles);

/** @return the store's counters (NULL for NULL). */
const ub_ident_stats_t *ub_ident_stats(const ub_ident_store_t *store);

#ifdef __cplusplus
}
#endif
#endif /* UB_IDENT_H */
