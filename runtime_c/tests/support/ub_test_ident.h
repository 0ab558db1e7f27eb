/* Test support for identities (test_ident, test_revoke): an authority and entities made from fixed
 * labels (deterministic: Ed25519 and the seeded key pairs are), certificates and records signed by it. */
#ifndef UB_TEST_IDENT_H
#define UB_TEST_IDENT_H

#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "ub/ub_ident.h"

typedef struct test_authority {
    uint8_t seed[UB_IDENT_SEED_LEN];
    uint8_t pk[UB_IDENT_SIGN_PK_LEN];
    uint8_t sk[UB_IDENT_SIGN_SK_LEN];
} test_authority_t;

typedef struct test_entity {
    ub_cert_t cert;
    uint8_t cert_bytes[UB_CERT_LEN];
    uint8_t sign_seed[UB_IDENT_SEED_LEN];
    uint8_t sign_sk[UB_IDENT_SIGN_SK_LEN];
    uint8_t kx_sk[UB_IDENT_KX_SK_LEN];
} test_entity_t;

/* A seed from a label: its bytes repeated (the tests need distinct, fixed seeds, nothing more). */
static inline void test_seed(const char *label, uint8_t out[UB_IDENT_SEED_LEN]) {
    size_t n = strlen(label);
    for (size_t i = 0; i < UB_IDENT_SEED_LEN; i++) out[i] = (uint8_t)(label[i % n] + i);
}

static inline int test_authority(test_authority_t *a, const char *label) {
    test_seed(label, a->seed);
    return ub_ident_sign_keypair(a->seed, a->pk, a->sk);
}

/* Issues `name` a certificate from `a`; returns UB_OK or the first error. */
static inline int test_issue(test_entity_t *e, const test_authority_t *a, const char *name, uint16_t roles,
                             uint64_t serial, uint64_t not_before, uint64_t not_after) {
    memset(e, 0, sizeof *e);
    char label[64];
    uint8_t kx_seed[UB_IDENT_SEED_LEN];
    (void)snprintf(label, sizeof label, "%s/sign", name);
    test_seed(label, e->sign_seed);
    (void)snprintf(label, sizeof label, "%s/kx", name);
    test_seed(label, kx_seed);
    int rc = ub_ident_sign_keypair(e->sign_seed, e->cert.sign_pk, e->sign_sk);
    if (rc == UB_OK) rc = ub_ident_kx_keypair(kx_seed, e->cert.kx_pk, e->kx_sk);
    if (rc == UB_OK) rc = ub_entity_id(name, e->cert.entity);
    e->cert.version = UB_IDENT_VERSION;
    e->cert.roles = roles;
    e->cert.serial = serial;
    e->cert.not_before = not_before;
    e->cert.not_after = not_after;
    if (rc == UB_OK) rc = ub_cert_sign(&e->cert, a->sk);
    if (rc == UB_OK) rc = ub_cert_encode(&e->cert, e->cert_bytes);
    return rc;
}

static inline int test_revoke_record(uint8_t out[UB_REVOCATION_LEN], const test_authority_t *a, const char *name,
                                     uint64_t serial, uint64_t time_s) {
    ub_revocation_t r;
    memset(&r, 0, sizeof r);
    r.serial = serial;
    r.time_s = time_s;
    int rc = ub_entity_id(name, r.entity);
    if (rc == UB_OK) rc = ub_revocation_sign(&r, a->sk);
    if (rc == UB_OK) rc = ub_revocation_encode(&r, out);
    return rc;
}

#endif /* UB_TEST_IDENT_H */
