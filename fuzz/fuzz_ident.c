/*
 * Fuzz harness: identity certificates and revocation records (ub_ident.h, issue 23) on arbitrary bytes.
 *
 * Input: byte 0 is a mode, the rest the bytes. The bytes are decoded as a certificate and as a revocation
 * record, then offered to an identity store whose authority is fixed (the seeds are that authority's
 * certificates and records, so mutations of genuine bytes get explored). Properties: no crash, no memory
 * error; a decode that succeeds re-encodes to the same bytes (one encoding per value) and its fields are in
 * their domain (version 1, known roles, serial > 0, not_before <= not_after); whatever the store accepts
 * verifies under its authority, and anything that does not is counted as refused; lookups in the store
 * never answer for an entity the store did not accept.
 */
#include <stdint.h>
#include <string.h>

#include "fuzz_util.h"
#include "ub/ub_ident.h"

#define T_NOW 1790000000u

static ub_ident_store_t g_store;
static uint8_t g_auth_pk[32], g_auth_sk[64];

static void authority(void) {
    uint8_t seed[32];
    for (unsigned i = 0; i < 32; i++) seed[i] = (uint8_t)(0xA0u + i);
    fuzz_ignore(ub_ident_sign_keypair(seed, g_auth_pk, g_auth_sk));
}

int LLVMFuzzerInitialize(int *argc, char ***argv) {
    (void)argc;
    (void)argv;
    authority();
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size < 1) return 0;
    uint8_t mode = data[0];
    const uint8_t *p = data + 1;
    size_t n = size - 1;
    ub_cert_t c;
    if (ub_cert_decode(&c, p, n) == UB_OK) {
        uint8_t again[UB_CERT_LEN];
        FUZZ_CHECK(ub_cert_encode(&c, again) == UB_OK, "encode of a decoded certificate failed");
        FUZZ_CHECK(n == UB_CERT_LEN && memcmp(again, p, n) == 0, "a certificate decodes from a non-canonical form");
        FUZZ_CHECK(c.version == 1 && (c.roles & ~UB_ROLES_KNOWN) == 0 && c.serial > 0 && c.not_before <= c.not_after,
                   "a decoded certificate holds a field out of its domain");
    }
    ub_revocation_t r;
    if (ub_revocation_decode(&r, p, n) == UB_OK) {
        uint8_t again[UB_REVOCATION_LEN];
        FUZZ_CHECK(ub_revocation_encode(&r, again) == UB_OK, "encode of a decoded record failed");
        FUZZ_CHECK(n == UB_REVOCATION_LEN && memcmp(again, p, n) == 0, "a record decodes from a non-canonical form");
        FUZZ_CHECK(r.serial > 0, "a decoded record has serial 0");
    }
    /* The store: a fresh one per input (mode bit 0: keep the previous input's, to explore sequences). */
    if ((mode & 1u) == 0) {
        ub_ident_store_init(&g_store);
        FUZZ_CHECK(ub_ident_set_authority(&g_store, g_auth_pk) == UB_OK, "authority refused");
    }
    uint32_t refused_before = g_store.stats.revocations_refused;
    ub_ident_status_t why;
    int rc = ub_ident_add_revocation(&g_store, p, n, &why);
    if (rc >= 0) {
        FUZZ_CHECK(ub_revocation_decode(&r, p, n) == UB_OK && ub_revocation_verify(&r, g_auth_pk) == UB_IDENT_VALID,
                   "the store took a record that does not verify");
    } else if (rc == UB_ERR_AUTH) {
        FUZZ_CHECK(g_store.stats.revocations_refused == refused_before + 1, "a refused record was not counted");
    }
    uint64_t now = T_NOW + (uint64_t)(mode >> 1) * 86400u;
    rc = ub_ident_add_peer(&g_store, p, n, now, &why);
    uint8_t pk[32];
    if (rc == UB_OK) {
        FUZZ_CHECK(ub_cert_decode(&c, p, n) == UB_OK && ub_cert_verify(&c, g_auth_pk) == UB_IDENT_VALID,
                   "the store took a certificate that does not verify");
        FUZZ_CHECK(ub_ident_peer_kx_key(&g_store, c.entity, now, pk) == UB_OK, "an accepted peer is not found");
        FUZZ_CHECK(memcmp(pk, c.kx_pk, 32) == 0, "the lookup answers another key");
    } else if (n >= 24 && (mode & 1u) == 0) {
        /* nothing accepted in a fresh store: its entity stays unknown or revoked */
        FUZZ_CHECK(ub_ident_peer_kx_key(&g_store, p + 12, now, pk) != UB_OK, "a refused certificate answers");
    }
    return 0;
}

/* Seeds: genuine certificates and records of the fixed authority, and their damaged forms. */
void ub_fuzz_write_seeds(const char *dir) {
    authority();
    uint8_t buf[1 + UB_CERT_LEN];
    for (unsigned k = 0; k < 4; k++) {
        ub_cert_t c;
        memset(&c, 0, sizeof c);
        c.version = 1;
        c.roles = (uint16_t)(1u << k);
        c.serial = k + 1u;
        c.not_before = T_NOW - 10;
        c.not_after = T_NOW + 86400u * (k + 1u);
        static const char *const names[] = {"gcs1", "rmax1ob1", "fcs20", "mavbridge1"};
        fuzz_ignore(ub_entity_id(names[k], c.entity));
        uint8_t seed[32];
        memset(seed, (int)(k + 1u), sizeof seed);
        uint8_t sk[64], kx_sk[32];
        fuzz_ignore(ub_ident_sign_keypair(seed, c.sign_pk, sk));
        fuzz_ignore(ub_ident_kx_keypair(seed, c.kx_pk, kx_sk));
        fuzz_ignore(ub_cert_sign(&c, g_auth_sk));
        buf[0] = (uint8_t)(k << 1);
        fuzz_ignore(ub_cert_encode(&c, buf + 1));
        char name[32];
        (void)snprintf(name, sizeof name, "cert_%u", k);
        fuzz_write_seed(dir, name, buf, sizeof buf);
        ub_revocation_t r;
        memset(&r, 0, sizeof r);
        r.serial = c.serial;
        memcpy(r.entity, c.entity, sizeof r.entity);
        r.time_s = T_NOW;
        fuzz_ignore(ub_revocation_sign(&r, g_auth_sk));
        buf[0] = (uint8_t)(k & 1u);
        fuzz_ignore(ub_revocation_encode(&r, buf + 1));
        (void)snprintf(name, sizeof name, "revocation_%u", k);
        fuzz_write_seed(dir, name, buf, 1 + UB_REVOCATION_LEN);
    }
    static const uint8_t short_input[] = {0, 1, 1, 0};
    fuzz_write_seed(dir, "short", short_input, sizeof short_input);
}
