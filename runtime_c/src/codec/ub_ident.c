/* Certificates, revocation records and the identity store (contracts and byte layouts in ub/ub_ident.h;
 * design in docs/security.md "Identity per entity").
 *
 * libsodium does all the cryptography: Ed25519 (crypto_sign_detached / crypto_sign_verify_detached)
 * for the authority's signatures, BLAKE2b (crypto_generichash) for the authority key id, X25519
 * (crypto_kx_seed_keypair, crypto_scalarmult_base) for the key-agreement keys. Decoding is plain
 * bounds-checked byte work and runs without it; everything that signs or verifies returns
 * UB_ERR_UNSUPPORTED / refuses without it (UB_SECURITY off), so nothing unverified ever enters a store. */
#include "ub/ub_ident.h"
#include "codec/ub_wipe_private.h"

#include <string.h>

#include "ub/ub_wire.h"

#if defined(UB_SECURITY) && UB_SECURITY
#include <sodium.h>
#define HAVE_SODIUM 1
_Static_assert(crypto_sign_PUBLICKEYBYTES == UB_IDENT_SIGN_PK_LEN, "Ed25519 public key length");
_Static_assert(crypto_sign_SECRETKEYBYTES == UB_IDENT_SIGN_SK_LEN, "Ed25519 secret key length");
_Static_assert(crypto_sign_SEEDBYTES == UB_IDENT_SEED_LEN, "Ed25519 seed length");
_Static_assert(crypto_sign_BYTES == UB_IDENT_SIG_LEN, "Ed25519 signature length");
_Static_assert(crypto_kx_PUBLICKEYBYTES == UB_IDENT_KX_PK_LEN, "X25519 public key length");
_Static_assert(crypto_kx_SECRETKEYBYTES == UB_IDENT_KX_SK_LEN, "X25519 secret key length");
_Static_assert(crypto_kx_SEEDBYTES == UB_IDENT_SEED_LEN, "X25519 seed length");
_Static_assert(crypto_scalarmult_BYTES == UB_IDENT_KX_PK_LEN, "X25519 point length");
#else
#define HAVE_SODIUM 0
#endif

_Static_assert(UB_CERT_SIGNED_LEN + UB_IDENT_SIG_LEN == UB_CERT_LEN, "certificate = signed part + signature");
_Static_assert(UB_REVOCATION_SIGNED_LEN + UB_IDENT_SIG_LEN == UB_REVOCATION_LEN, "record = signed part + signature");
_Static_assert(UB_IDENT_MAX_PEERS >= 1 && UB_IDENT_MAX_PEERS <= 65535, "UB_IDENT_MAX_PEERS must be 1..65535");
_Static_assert(UB_IDENT_MAX_REVOCATIONS >= 1 && UB_IDENT_MAX_REVOCATIONS <= 65535,
               "UB_IDENT_MAX_REVOCATIONS must be 1..65535");

/* Field offsets (docs/wire-format.md#identity-certificates). */
enum {
    C_VERSION = 0,
    C_KIND = 1,
    C_ROLES = 2,
    C_SERIAL = 4,
    C_ENTITY = 12,
    C_SIGN_PK = 24,
    C_KX_PK = 56,
    C_NOT_BEFORE = 88,
    C_NOT_AFTER = 96,
    C_AUTHORITY = 104,
    C_SIG = 112,
    R_VERSION = 0,
    R_KIND = 1,
    R_RESERVED = 2,
    R_SERIAL = 4,
    R_ENTITY = 12,
    R_TIME = 24,
    R_AUTHORITY = 32,
    R_SIG = 40
};

static bool id_eq(const uint8_t *a, const uint8_t *b) { return memcmp(a, b, UB_ENTITY_ID_LEN) == 0; }

/* An entity ID of a certificate or record: neither "no owner" (all 0x00) nor link-local (all 0xFF). */
static bool id_ok(const uint8_t *id) {
    bool zero = true, ff = true;
    for (size_t i = 0; i < UB_ENTITY_ID_LEN; i++) {
        zero = zero && id[i] == 0x00u;
        ff = ff && id[i] == 0xFFu;
    }
    return !zero && !ff;
}

const char *ub_ident_status_name(ub_ident_status_t status) {
    switch (status) {
    case UB_IDENT_VALID: return "valid";
    case UB_IDENT_UNKNOWN: return "unknown";
    case UB_IDENT_REVOKED: return "revoked";
    case UB_IDENT_EXPIRED: return "expired";
    case UB_IDENT_NOT_YET_VALID: return "not_yet_valid";
    case UB_IDENT_WRONG_AUTHORITY: return "wrong_authority";
    case UB_IDENT_BAD_SIGNATURE: return "bad_signature";
    case UB_IDENT_MALFORMED: return "malformed";
    }
    return "?";
}

const char *ub_ident_role_name(uint16_t role) {
    switch (role) {
    case UB_ROLE_ADMIN: return "admin";
    case UB_ROLE_VEHICLE: return "vehicle";
    case UB_ROLE_RELAY: return "relay";
    case UB_ROLE_BRIDGE: return "bridge";
    case UB_ROLE_OBSERVER: return "observer";
    default: return NULL;
    }
}

/* ---- keys ---- */

int ub_ident_authority_kid(const uint8_t pk[UB_IDENT_SIGN_PK_LEN], uint8_t kid[UB_IDENT_KID_LEN]) {
    if (pk == NULL || kid == NULL) return UB_ERR_INVAL;
#if HAVE_SODIUM
    uint8_t h[32];
    if (sodium_init() < 0 || crypto_generichash(h, sizeof h, pk, UB_IDENT_SIGN_PK_LEN, NULL, 0) != 0) return UB_ERR_IO;
    memcpy(kid, h, UB_IDENT_KID_LEN);
    return UB_OK;
#else
    return UB_ERR_UNSUPPORTED;
#endif
}

int ub_ident_sign_keypair(const uint8_t seed[UB_IDENT_SEED_LEN], uint8_t pk[UB_IDENT_SIGN_PK_LEN],
                          uint8_t sk[UB_IDENT_SIGN_SK_LEN]) {
    if (seed == NULL || pk == NULL || sk == NULL) return UB_ERR_INVAL;
#if HAVE_SODIUM
    if (sodium_init() < 0 || crypto_sign_seed_keypair(pk, sk, seed) != 0) return UB_ERR_IO;
    return UB_OK;
#else
    memset(pk, 0, UB_IDENT_SIGN_PK_LEN); /* no key leaves a build that cannot make one */
    memset(sk, 0, UB_IDENT_SIGN_SK_LEN);
    return UB_ERR_UNSUPPORTED;
#endif
}

int ub_ident_kx_keypair(const uint8_t seed[UB_IDENT_SEED_LEN], uint8_t pk[UB_IDENT_KX_PK_LEN],
                        uint8_t sk[UB_IDENT_KX_SK_LEN]) {
    if (seed == NULL || pk == NULL || sk == NULL) return UB_ERR_INVAL;
#if HAVE_SODIUM
    if (sodium_init() < 0 || crypto_kx_seed_keypair(pk, sk, seed) != 0) return UB_ERR_IO;
    return UB_OK;
#else
    memset(pk, 0, UB_IDENT_KX_PK_LEN);
    memset(sk, 0, UB_IDENT_KX_SK_LEN);
    return UB_ERR_UNSUPPORTED;
#endif
}

int ub_ident_kx_public(const uint8_t sk[UB_IDENT_KX_SK_LEN], uint8_t pk[UB_IDENT_KX_PK_LEN]) {
    if (sk == NULL || pk == NULL) return UB_ERR_INVAL;
#if HAVE_SODIUM
    if (sodium_init() < 0 || crypto_scalarmult_base(pk, sk) != 0) return UB_ERR_AUTH;
    return UB_OK;
#else
    memset(pk, 0, UB_IDENT_KX_PK_LEN);
    return UB_ERR_UNSUPPORTED;
#endif
}

int ub_ident_random(uint8_t *out, size_t len) {
    if (out == NULL && len > 0) return UB_ERR_INVAL;
#if HAVE_SODIUM
    if (sodium_init() < 0) return UB_ERR_IO;
    if (len > 0) randombytes_buf(out, len); /* out may be NULL when len is 0: randombytes_buf() takes no NULL */
    return UB_OK;
#else
    return UB_ERR_UNSUPPORTED;
#endif
}

/* ---- certificates ---- */

static bool cert_fields_ok(const ub_cert_t *c) {
    return c->version == UB_IDENT_VERSION && (c->roles & ~(unsigned)UB_ROLES_KNOWN) == 0 && c->serial > 0 &&
           id_ok(c->entity) && c->not_before <= c->not_after;
}

static void cert_put_signed(const ub_cert_t *c, uint8_t *out) {
    out[C_VERSION] = c->version;
    out[C_KIND] = UB_IDENT_KIND_CERT;
    ub_put_u16le(out + C_ROLES, c->roles);
    ub_put_u64le(out + C_SERIAL, c->serial);
    memcpy(out + C_ENTITY, c->entity, UB_ENTITY_ID_LEN);
    memcpy(out + C_SIGN_PK, c->sign_pk, UB_IDENT_SIGN_PK_LEN);
    memcpy(out + C_KX_PK, c->kx_pk, UB_IDENT_KX_PK_LEN);
    ub_put_u64le(out + C_NOT_BEFORE, c->not_before);
    ub_put_u64le(out + C_NOT_AFTER, c->not_after);
    memcpy(out + C_AUTHORITY, c->authority, UB_IDENT_KID_LEN);
}

int ub_cert_encode(const ub_cert_t *cert, uint8_t out[UB_CERT_LEN]) {
    if (cert == NULL || out == NULL) return UB_ERR_INVAL;
    cert_put_signed(cert, out);
    memcpy(out + C_SIG, cert->sig, UB_IDENT_SIG_LEN);
    return UB_OK;
}

int ub_cert_decode(ub_cert_t *cert, const uint8_t *buf, size_t len) {
    if (cert == NULL || buf == NULL) return UB_ERR_INVAL;
    memset(cert, 0, sizeof *cert);
    if (len != UB_CERT_LEN) return UB_ERR_TRUNCATED;
    if (buf[C_KIND] != UB_IDENT_KIND_CERT) return UB_ERR_CONFIG;
    ub_cert_t c;
    c.version = buf[C_VERSION];
    c.roles = ub_get_u16le(buf + C_ROLES);
    c.serial = ub_get_u64le(buf + C_SERIAL);
    memcpy(c.entity, buf + C_ENTITY, UB_ENTITY_ID_LEN);
    memcpy(c.sign_pk, buf + C_SIGN_PK, UB_IDENT_SIGN_PK_LEN);
    memcpy(c.kx_pk, buf + C_KX_PK, UB_IDENT_KX_PK_LEN);
    c.not_before = ub_get_u64le(buf + C_NOT_BEFORE);
    c.not_after = ub_get_u64le(buf + C_NOT_AFTER);
    memcpy(c.authority, buf + C_AUTHORITY, UB_IDENT_KID_LEN);
    memcpy(c.sig, buf + C_SIG, UB_IDENT_SIG_LEN);
    if (!cert_fields_ok(&c)) return UB_ERR_CONFIG;
    *cert = c;
    return UB_OK;
}

int ub_cert_sign(ub_cert_t *cert, const uint8_t authority_sk[UB_IDENT_SIGN_SK_LEN]) {
    if (cert == NULL || authority_sk == NULL) return UB_ERR_INVAL;
    if (!cert_fields_ok(cert)) return UB_ERR_CONFIG;
#if HAVE_SODIUM
    /* libsodium's secret key ends with the public key: the key id is the authority's. */
    int rc = ub_ident_authority_kid(authority_sk + UB_IDENT_SEED_LEN, cert->authority);
    if (rc != UB_OK) return rc;
    uint8_t msg[UB_CERT_SIGNED_LEN];
    cert_put_signed(cert, msg);
    if (crypto_sign_detached(cert->sig, NULL, msg, sizeof msg, authority_sk) != 0) return UB_ERR_IO;
    return UB_OK;
#else
    return UB_ERR_UNSUPPORTED;
#endif
}

/* The common verification: key id, then Ed25519 over the signed bytes. */
static ub_ident_status_t verify_signed(const uint8_t *msg, size_t len, const uint8_t *kid, const uint8_t *sig,
                                       const uint8_t *authority_pk) {
#if HAVE_SODIUM
    uint8_t want[UB_IDENT_KID_LEN];
    if (ub_ident_authority_kid(authority_pk, want) != UB_OK) return UB_IDENT_MALFORMED;
    if (memcmp(want, kid, UB_IDENT_KID_LEN) != 0) return UB_IDENT_WRONG_AUTHORITY;
    if (crypto_sign_verify_detached(sig, msg, len, authority_pk) != 0) return UB_IDENT_BAD_SIGNATURE;
    return UB_IDENT_VALID;
#else
    (void)msg, (void)len, (void)kid, (void)sig, (void)authority_pk;
    return UB_IDENT_MALFORMED; /* nothing verifies without libsodium: fail closed */
#endif
}

ub_ident_status_t ub_cert_verify(const ub_cert_t *cert, const uint8_t authority_pk[UB_IDENT_SIGN_PK_LEN]) {
    if (cert == NULL || authority_pk == NULL || !cert_fields_ok(cert)) return UB_IDENT_MALFORMED;
    uint8_t msg[UB_CERT_SIGNED_LEN];
    cert_put_signed(cert, msg);
    return verify_signed(msg, sizeof msg, cert->authority, cert->sig, authority_pk);
}

ub_ident_status_t ub_cert_check_time(const ub_cert_t *cert, uint64_t now_s) {
    if (cert == NULL) return UB_IDENT_MALFORMED;
    if (now_s < cert->not_before) return UB_IDENT_NOT_YET_VALID;
    if (now_s > cert->not_after) return UB_IDENT_EXPIRED;
    return UB_IDENT_VALID;
}

/* ---- revocation records ---- */

static bool rev_fields_ok(const ub_revocation_t *r) { return r->serial > 0 && id_ok(r->entity); }

static void rev_put_signed(const ub_revocation_t *r, uint8_t *out) {
    out[R_VERSION] = UB_IDENT_VERSION;
    out[R_KIND] = UB_IDENT_KIND_REVOCATION;
    ub_put_u16le(out + R_RESERVED, 0);
    ub_put_u64le(out + R_SERIAL, r->serial);
    memcpy(out + R_ENTITY, r->entity, UB_ENTITY_ID_LEN);
    ub_put_u64le(out + R_TIME, r->time_s);
    memcpy(out + R_AUTHORITY, r->authority, UB_IDENT_KID_LEN);
}

int ub_revocation_encode(const ub_revocation_t *rev, uint8_t out[UB_REVOCATION_LEN]) {
    if (rev == NULL || out == NULL) return UB_ERR_INVAL;
    rev_put_signed(rev, out);
    memcpy(out + R_SIG, rev->sig, UB_IDENT_SIG_LEN);
    return UB_OK;
}

int ub_revocation_decode(ub_revocation_t *rev, const uint8_t *buf, size_t len) {
    if (rev == NULL || buf == NULL) return UB_ERR_INVAL;
    memset(rev, 0, sizeof *rev);
    if (len != UB_REVOCATION_LEN) return UB_ERR_TRUNCATED;
    if (buf[R_VERSION] != UB_IDENT_VERSION || buf[R_KIND] != UB_IDENT_KIND_REVOCATION ||
        ub_get_u16le(buf + R_RESERVED) != 0)
        return UB_ERR_CONFIG;
    ub_revocation_t r;
    r.serial = ub_get_u64le(buf + R_SERIAL);
    memcpy(r.entity, buf + R_ENTITY, UB_ENTITY_ID_LEN);
    r.time_s = ub_get_u64le(buf + R_TIME);
    memcpy(r.authority, buf + R_AUTHORITY, UB_IDENT_KID_LEN);
    memcpy(r.sig, buf + R_SIG, UB_IDENT_SIG_LEN);
    if (!rev_fields_ok(&r)) return UB_ERR_CONFIG;
    *rev = r;
    return UB_OK;
}

int ub_revocation_sign(ub_revocation_t *rev, const uint8_t authority_sk[UB_IDENT_SIGN_SK_LEN]) {
    if (rev == NULL || authority_sk == NULL) return UB_ERR_INVAL;
    if (!rev_fields_ok(rev)) return UB_ERR_CONFIG;
#if HAVE_SODIUM
    int rc = ub_ident_authority_kid(authority_sk + UB_IDENT_SEED_LEN, rev->authority);
    if (rc != UB_OK) return rc;
    uint8_t msg[UB_REVOCATION_SIGNED_LEN];
    rev_put_signed(rev, msg);
    if (crypto_sign_detached(rev->sig, NULL, msg, sizeof msg, authority_sk) != 0) return UB_ERR_IO;
    return UB_OK;
#else
    return UB_ERR_UNSUPPORTED;
#endif
}

ub_ident_status_t ub_revocation_verify(const ub_revocation_t *rev, const uint8_t authority_pk[UB_IDENT_SIGN_PK_LEN]) {
    if (rev == NULL || authority_pk == NULL || !rev_fields_ok(rev)) return UB_IDENT_MALFORMED;
    uint8_t msg[UB_REVOCATION_SIGNED_LEN];
    rev_put_signed(rev, msg);
    return verify_signed(msg, sizeof msg, rev->authority, rev->sig, authority_pk);
}

/* ---- the store ---- */

void ub_ident_store_init(ub_ident_store_t *store) {
    if (store == NULL) return;
    ub_priv_wipe(store, sizeof *store);
}

void ub_ident_store_clear(ub_ident_store_t *store) { ub_ident_store_init(store); }

static const ub_revocation_t *revocation_for(const ub_ident_store_t *s, const uint8_t *entity) {
    for (uint16_t i = 0; i < s->n_revoked; i++)
        if (id_eq(s->revoked[i].entity, entity)) return &s->revoked[i];
    return NULL;
}

bool ub_ident_is_revoked(const ub_ident_store_t *store, const uint8_t entity[UB_ENTITY_ID_LEN], uint64_t serial) {
    if (store == NULL || entity == NULL) return false;
    const ub_revocation_t *r = revocation_for(store, entity);
    return r != NULL && serial <= r->serial;
}

int ub_ident_set_authority(ub_ident_store_t *store, const uint8_t pk[UB_IDENT_SIGN_PK_LEN]) {
    if (store == NULL || pk == NULL) return UB_ERR_INVAL;
    uint8_t kid[UB_IDENT_KID_LEN];
    int rc = ub_ident_authority_kid(pk, kid);
    if (rc != UB_OK) return rc;
    if (store->has_authority && memcmp(kid, store->authority_kid, UB_IDENT_KID_LEN) != 0) {
        /* Another authority: nothing it did not sign may stay. */
        ub_priv_wipe(store->selves, sizeof store->selves);
        store->n_selves = 0;
        memset(store->peers, 0, sizeof store->peers);
        store->n_peers = 0;
        memset(store->revoked, 0, sizeof store->revoked);
        store->n_revoked = 0;
    }
    memcpy(store->authority_pk, pk, UB_IDENT_SIGN_PK_LEN);
    memcpy(store->authority_kid, kid, UB_IDENT_KID_LEN);
    store->has_authority = 1;
    return UB_OK;
}

/* Signature, time and revocation of a certificate, in that order. */
static ub_ident_status_t judge(const ub_ident_store_t *s, const ub_cert_t *c, uint64_t now_s) {
    ub_ident_status_t st = ub_cert_verify(c, s->authority_pk);
    if (st != UB_IDENT_VALID) return st;
    if (ub_ident_is_revoked(s, c->entity, c->serial)) return UB_IDENT_REVOKED;
    return ub_cert_check_time(c, now_s);
}

int ub_ident_set_self(ub_ident_store_t *store, const ub_cert_t *cert, const uint8_t sign_sk[UB_IDENT_SIGN_SK_LEN],
                      const uint8_t kx_sk[UB_IDENT_KX_SK_LEN], uint64_t now_s, ub_ident_status_t *why) {
    ub_ident_status_t dummy;
    if (why == NULL) why = &dummy;
    *why = UB_IDENT_MALFORMED;
    if (store == NULL || cert == NULL || sign_sk == NULL || kx_sk == NULL) return UB_ERR_INVAL;
    if (!store->has_authority) return UB_ERR_NOTFOUND;
    if (!HAVE_SODIUM) return UB_ERR_UNSUPPORTED;
    *why = judge(store, cert, now_s);
    if (*why != UB_IDENT_VALID) return UB_ERR_AUTH;
    /* The secret keys must be the certificate's: recompute both public halves. */
    uint8_t seed[UB_IDENT_SEED_LEN], pk[UB_IDENT_SIGN_PK_LEN], sk[UB_IDENT_SIGN_SK_LEN], kx_pk[UB_IDENT_KX_PK_LEN];
    memcpy(seed, sign_sk, UB_IDENT_SEED_LEN);
    int rc = ub_ident_sign_keypair(seed, pk, sk);
    bool match = rc == UB_OK && memcmp(pk, cert->sign_pk, sizeof pk) == 0 && memcmp(sk, sign_sk, sizeof sk) == 0 &&
                 ub_ident_kx_public(kx_sk, kx_pk) == UB_OK && memcmp(kx_pk, cert->kx_pk, sizeof kx_pk) == 0;
    ub_priv_wipe(seed, sizeof seed);
    ub_priv_wipe(sk, sizeof sk);
    if (!match) {
        *why = UB_IDENT_MALFORMED;
        return UB_ERR_AUTH;
    }
    size_t at = store->n_selves;
    for (size_t i = 0; i < store->n_selves; i++)
        if (id_eq(store->selves[i].cert.entity, cert->entity)) at = i;
    if (at == UB_MAX_LOCAL_ENTITIES) return UB_ERR_FULL;
    if (at == store->n_selves) store->n_selves++;
    ub_ident_self_t *me = &store->selves[at];
    me->cert = *cert;
    memcpy(me->sign_sk, sign_sk, UB_IDENT_SIGN_SK_LEN);
    memcpy(me->kx_sk, kx_sk, UB_IDENT_KX_SK_LEN);
    return UB_OK;
}

const ub_cert_t *ub_ident_self(const ub_ident_store_t *store) {
    return store != NULL && store->n_selves > 0 ? &store->selves[0].cert : NULL;
}

size_t ub_ident_self_count(const ub_ident_store_t *store) { return store != NULL ? store->n_selves : 0; }

const ub_ident_self_t *ub_ident_self_at(const ub_ident_store_t *store, size_t index) {
    return store != NULL && index < store->n_selves ? &store->selves[index] : NULL;
}

const uint8_t *ub_ident_self_kx_sk(const ub_ident_store_t *store) {
    return store != NULL && store->n_selves > 0 ? store->selves[0].kx_sk : NULL;
}

const uint8_t *ub_ident_self_kx_sk_for(const ub_ident_store_t *store, const uint8_t entity_id[UB_ENTITY_ID_LEN]) {
    if (store == NULL || entity_id == NULL) return NULL;
    for (size_t i = 0; i < store->n_selves; i++)
        if (id_eq(store->selves[i].cert.entity, entity_id)) return store->selves[i].kx_sk;
    return NULL;
}

static int peer_index(const ub_ident_store_t *s, const uint8_t *entity) {
    for (uint16_t i = 0; i < s->n_peers; i++)
        if (id_eq(s->peers[i].entity, entity)) return i;
    return -1;
}

static void count_refused(uint32_t *by_status, ub_ident_status_t st) {
    unsigned i = (unsigned)st;
    if (i < 8u) by_status[i]++;
}

static void remove_peer(ub_ident_store_t *s, int i) {
    s->peers[i] = s->peers[s->n_peers - 1u];
    memset(&s->peers[s->n_peers - 1u], 0, sizeof s->peers[0]);
    s->n_peers--;
}

int ub_ident_add_peer(ub_ident_store_t *store, const uint8_t *cert, size_t len, uint64_t now_s,
                      ub_ident_status_t *why) {
    ub_ident_status_t dummy;
    if (why == NULL) why = &dummy;
    *why = UB_IDENT_MALFORMED;
    if (store == NULL || cert == NULL) return UB_ERR_INVAL;
    ub_cert_t c;
    ub_ident_status_t st = UB_IDENT_MALFORMED;
    if (!store->has_authority) st = UB_IDENT_WRONG_AUTHORITY;
    else if (ub_cert_decode(&c, cert, len) == UB_OK) st = judge(store, &c, now_s);
    int at = st == UB_IDENT_VALID ? peer_index(store, c.entity) : -1;
    if (at >= 0 && c.serial < store->peers[at].serial) st = UB_IDENT_REVOKED; /* never back to an older identity */
    *why = st;
    if (st != UB_IDENT_VALID) {
        count_refused(store->stats.peers_refused, st);
        return UB_ERR_AUTH;
    }
    if (at >= 0) {
        if (c.serial == store->peers[at].serial) {
            if (memcmp(c.sig, store->peers[at].sig, sizeof c.sig) == 0) return UB_OK; /* the same: idempotent */
            /* Two different certificates with one serial: the authority never issues that. Keep the first. */
            *why = UB_IDENT_MALFORMED;
            count_refused(store->stats.peers_refused, UB_IDENT_MALFORMED);
            return UB_ERR_AUTH;
        }
        store->peers[at] = c;
        store->stats.peers_added++;
        return UB_OK;
    }
    if (store->n_peers == UB_IDENT_MAX_PEERS) {
        /* Reuse the place of a certificate that is no longer valid (expired); never evict a valid one. */
        for (int i = 0; i < (int)store->n_peers; i++) {
            if (ub_cert_check_time(&store->peers[i], now_s) != UB_IDENT_VALID) {
                remove_peer(store, i);
                break;
            }
        }
        if (store->n_peers == UB_IDENT_MAX_PEERS) {
            store->stats.peers_full++;
            return UB_ERR_FULL;
        }
    }
    store->peers[store->n_peers++] = c;
    store->stats.peers_added++;
    return UB_OK;
}

int ub_ident_add_revocation(ub_ident_store_t *store, const uint8_t *rec, size_t len, ub_ident_status_t *why) {
    ub_ident_status_t dummy;
    if (why == NULL) why = &dummy;
    *why = UB_IDENT_MALFORMED;
    if (store == NULL || rec == NULL) return UB_ERR_INVAL;
    ub_revocation_t r;
    ub_ident_status_t st = UB_IDENT_MALFORMED;
    if (!store->has_authority) st = UB_IDENT_WRONG_AUTHORITY;
    else if (ub_revocation_decode(&r, rec, len) == UB_OK) st = ub_revocation_verify(&r, store->authority_pk);
    *why = st;
    if (st != UB_IDENT_VALID) {
        store->stats.revocations_refused++;
        return UB_ERR_AUTH;
    }
    int index = -1;
    for (uint16_t i = 0; i < store->n_revoked; i++)
        if (id_eq(store->revoked[i].entity, r.entity)) index = i;
    if (index >= 0 && store->revoked[index].serial >= r.serial) {
        store->stats.revocations_known++;
        return UB_ERR_EXISTS;
    }
    if (index < 0) {
        if (store->n_revoked == UB_IDENT_MAX_REVOCATIONS) {
            store->stats.revocations_full++;
            return UB_ERR_FULL;
        }
        index = store->n_revoked++;
    }
    store->revoked[index] = r;
    store->stats.revocations_added++;
    int p = peer_index(store, r.entity);
    if (p >= 0 && store->peers[p].serial <= r.serial) {
        remove_peer(store, p);
        store->stats.peers_removed++;
    }
    return index;
}

size_t ub_ident_revocation_count(const ub_ident_store_t *store) { return store != NULL ? store->n_revoked : 0; }

int ub_ident_revocation_at(const ub_ident_store_t *store, size_t index, uint8_t out[UB_REVOCATION_LEN]) {
    if (store == NULL || out == NULL) return UB_ERR_INVAL;
    if (index >= store->n_revoked) return UB_ERR_NOTFOUND;
    return ub_revocation_encode(&store->revoked[index], out);
}

/* The certificate held for `entity` (own or peer), and its status at now_s. */
static ub_ident_status_t find(const ub_ident_store_t *s, const uint8_t *entity, uint64_t now_s, const ub_cert_t **out) {
    *out = NULL;
    const ub_cert_t *c = NULL;
    for (size_t i = 0; i < s->n_selves && c == NULL; i++)
        if (id_eq(s->selves[i].cert.entity, entity)) c = &s->selves[i].cert;
    if (c == NULL) {
        int i = peer_index(s, entity);
        if (i >= 0) c = &s->peers[i];
    }
    if (c == NULL) return ub_ident_is_revoked(s, entity, 1) ? UB_IDENT_REVOKED : UB_IDENT_UNKNOWN;
    if (ub_ident_is_revoked(s, entity, c->serial)) return UB_IDENT_REVOKED;
    ub_ident_status_t st = ub_cert_check_time(c, now_s);
    if (st == UB_IDENT_VALID) *out = c;
    return st;
}

ub_ident_status_t ub_ident_peer_status(const ub_ident_store_t *store, const uint8_t entity_id[UB_ENTITY_ID_LEN],
                                       uint64_t now_s) {
    if (store == NULL || entity_id == NULL) return UB_IDENT_MALFORMED;
    const ub_cert_t *c;
    return find(store, entity_id, now_s, &c);
}

const ub_cert_t *ub_ident_peer_cert(const ub_ident_store_t *store, const uint8_t entity_id[UB_ENTITY_ID_LEN],
                                    uint64_t now_s) {
    if (store == NULL || entity_id == NULL) return NULL;
    const ub_cert_t *c;
    (void)find(store, entity_id, now_s, &c);
    return c;
}

/* A counted query: the certificate or the refusal code. */
static int query(ub_ident_store_t *s, const uint8_t *entity, uint64_t now_s, const ub_cert_t **c) {
    ub_ident_status_t st = find(s, entity, now_s, c);
    if (st == UB_IDENT_VALID) {
        s->stats.lookups++;
        return UB_OK;
    }
    count_refused(s->stats.lookups_refused, st);
    return st == UB_IDENT_UNKNOWN ? UB_ERR_NOTFOUND : UB_ERR_AUTH;
}

int ub_ident_peer_kx_key(void *store, const uint8_t entity_id[UB_ENTITY_ID_LEN], uint64_t now_s,
                         uint8_t pk[UB_IDENT_KX_PK_LEN]) {
    if (store == NULL || entity_id == NULL || pk == NULL) return UB_ERR_INVAL;
    const ub_cert_t *c;
    int rc = query(store, entity_id, now_s, &c);
    if (rc == UB_OK) memcpy(pk, c->kx_pk, UB_IDENT_KX_PK_LEN);
    return rc;
}

int ub_ident_peer_sign_key(void *store, const uint8_t entity_id[UB_ENTITY_ID_LEN], uint64_t now_s,
                           uint8_t pk[UB_IDENT_SIGN_PK_LEN]) {
    if (store == NULL || entity_id == NULL || pk == NULL) return UB_ERR_INVAL;
    const ub_cert_t *c;
    int rc = query(store, entity_id, now_s, &c);
    if (rc == UB_OK) memcpy(pk, c->sign_pk, UB_IDENT_SIGN_PK_LEN);
    return rc;
}

int ub_ident_peer_roles(const ub_ident_store_t *store, const uint8_t entity_id[UB_ENTITY_ID_LEN], uint64_t now_s,
                        uint16_t *roles) {
    if (store == NULL || entity_id == NULL || roles == NULL) return UB_ERR_INVAL;
    *roles = 0;
    const ub_cert_t *c;
    ub_ident_status_t st = find(store, entity_id, now_s, &c);
    if (st != UB_IDENT_VALID) return st == UB_IDENT_UNKNOWN ? UB_ERR_NOTFOUND : UB_ERR_AUTH;
    *roles = c->roles;
    return UB_OK;
}

const ub_ident_stats_t *ub_ident_stats(const ub_ident_store_t *store) { return store != NULL ? &store->stats : NULL; }
