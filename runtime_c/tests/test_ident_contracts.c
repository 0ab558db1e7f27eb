/*
 * ub_ident.h called the wrong way on purpose (issue #29 item 6): NULL arguments, a zero X25519 key, every
 * status and role name, certificates and records a field out of its domain (refused before signing), the
 * own-identity checks of ub_ident_set_self() each with its reason, lookups of unknown, revoked and expired
 * entities (each counted), and the revocation table's index bounds. test_ident.c covers the working paths.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "ub/ub_ident.h"

#define NOW 1800000000ull

static uint8_t auth_pk[UB_IDENT_SIGN_PK_LEN], auth_sk[UB_IDENT_SIGN_SK_LEN];
static uint8_t other_pk[UB_IDENT_SIGN_PK_LEN], other_sk[UB_IDENT_SIGN_SK_LEN];
static ub_ident_store_t g_store;

static void seed_of(uint8_t seed[UB_IDENT_SEED_LEN], uint8_t v) { memset(seed, v, UB_IDENT_SEED_LEN); }

static void eid(uint8_t id[UB_ENTITY_ID_LEN], const char *name) {
    memset(id, 0, UB_ENTITY_ID_LEN);
    memcpy(id, name, strlen(name));
}

/* A certificate for `name` with keys from seed `v`, signed by `sk`. */
static void make_cert(ub_cert_t *c, const char *name, uint8_t v, uint64_t serial, uint64_t nb, uint64_t na,
                      const uint8_t *sk, uint8_t sign_sk[UB_IDENT_SIGN_SK_LEN], uint8_t kx_sk[UB_IDENT_KX_SK_LEN]) {
    uint8_t seed[UB_IDENT_SEED_LEN], kx_pk[UB_IDENT_KX_PK_LEN];
    memset(c, 0, sizeof *c);
    c->version = UB_IDENT_VERSION;
    c->roles = UB_ROLE_VEHICLE;
    c->serial = serial;
    eid(c->entity, name);
    seed_of(seed, v);
    assert_int_equal(ub_ident_sign_keypair(seed, c->sign_pk, sign_sk), UB_OK);
    seed_of(seed, (uint8_t)(v + 100));
    assert_int_equal(ub_ident_kx_keypair(seed, kx_pk, kx_sk), UB_OK);
    memcpy(c->kx_pk, kx_pk, sizeof kx_pk);
    c->not_before = nb;
    c->not_after = na;
    assert_int_equal(ub_cert_sign(c, sk), UB_OK);
}

static int setup(void **state) {
    (void)state;
    uint8_t seed[UB_IDENT_SEED_LEN];
    seed_of(seed, 1);
    assert_int_equal(ub_ident_sign_keypair(seed, auth_pk, auth_sk), UB_OK);
    seed_of(seed, 2);
    assert_int_equal(ub_ident_sign_keypair(seed, other_pk, other_sk), UB_OK);
    return 0;
}

static void test_names_and_key_contracts(void **state) {
    (void)state;
    static const char *const want[] = {"valid", "unknown", "revoked", "expired", "not_yet_valid",
                                       "wrong_authority", "bad_signature", "malformed"};
    for (int s = 0; s <= UB_IDENT_MALFORMED; s++) assert_string_equal(ub_ident_status_name((ub_ident_status_t)s), want[s]);
    assert_string_equal(ub_ident_status_name((ub_ident_status_t)42), "?");
    assert_string_equal(ub_ident_role_name(UB_ROLE_ADMIN), "admin");
    assert_string_equal(ub_ident_role_name(UB_ROLE_VEHICLE), "vehicle");
    assert_string_equal(ub_ident_role_name(UB_ROLE_RELAY), "relay");
    assert_string_equal(ub_ident_role_name(UB_ROLE_BRIDGE), "bridge");
    assert_string_equal(ub_ident_role_name(UB_ROLE_OBSERVER), "observer");
    assert_null(ub_ident_role_name(UB_ROLE_ADMIN | UB_ROLE_VEHICLE)); /* not one bit */
    assert_null(ub_ident_role_name(0x8000u));

    uint8_t seed[UB_IDENT_SEED_LEN] = {0}, pk[32], sk[64], kid[UB_IDENT_KID_LEN];
    assert_int_equal(ub_ident_authority_kid(NULL, kid), UB_ERR_INVAL);
    assert_int_equal(ub_ident_authority_kid(auth_pk, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_ident_sign_keypair(NULL, pk, sk), UB_ERR_INVAL);
    assert_int_equal(ub_ident_sign_keypair(seed, NULL, sk), UB_ERR_INVAL);
    assert_int_equal(ub_ident_sign_keypair(seed, pk, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_ident_kx_keypair(NULL, pk, sk), UB_ERR_INVAL);
    assert_int_equal(ub_ident_kx_keypair(seed, NULL, sk), UB_ERR_INVAL);
    assert_int_equal(ub_ident_kx_keypair(seed, pk, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_ident_kx_public(NULL, pk), UB_ERR_INVAL);
    assert_int_equal(ub_ident_kx_public(seed, NULL), UB_ERR_INVAL);
    /* The zero key: libsodium clamps the scalar, so it has a public half (ub_ident.h's "UB_ERR_AUTH (a zero
     * key)" is not what happens; the branch answers crypto_scalarmult_base() failing, which a clamped
     * scalar does not). */
    assert_int_equal(ub_ident_kx_public(seed, pk), UB_OK);
    uint8_t r[16] = {0};
    assert_int_equal(ub_ident_random(NULL, 4), UB_ERR_INVAL);
    assert_int_equal(ub_ident_random(NULL, 0), UB_OK);
    assert_int_equal(ub_ident_random(r, sizeof r), UB_OK);
}

static void test_cert_and_record_contracts(void **state) {
    (void)state;
    ub_cert_t c;
    uint8_t ssk[UB_IDENT_SIGN_SK_LEN], xsk[UB_IDENT_KX_SK_LEN], buf[UB_CERT_LEN];
    make_cert(&c, "veh1", 10, 1, NOW - 10, NOW + 10, auth_sk, ssk, xsk);
    assert_int_equal(ub_cert_encode(NULL, buf), UB_ERR_INVAL);
    assert_int_equal(ub_cert_encode(&c, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_cert_decode(NULL, buf, sizeof buf), UB_ERR_INVAL);
    assert_int_equal(ub_cert_decode(&c, NULL, sizeof buf), UB_ERR_INVAL);
    assert_int_equal(ub_cert_sign(NULL, auth_sk), UB_ERR_INVAL);
    assert_int_equal(ub_cert_sign(&c, NULL), UB_ERR_INVAL);
    ub_cert_t bad = c;
    bad.serial = 0; /* a field ub_cert_decode() would refuse: not signed */
    assert_int_equal(ub_cert_sign(&bad, auth_sk), UB_ERR_CONFIG);
    assert_int_equal(ub_cert_verify(NULL, auth_pk), UB_IDENT_MALFORMED);
    assert_int_equal(ub_cert_verify(&c, NULL), UB_IDENT_MALFORMED);
    assert_int_equal(ub_cert_verify(&bad, auth_pk), UB_IDENT_MALFORMED);
    assert_int_equal(ub_cert_verify(&c, other_pk), UB_IDENT_WRONG_AUTHORITY);
    assert_int_equal(ub_cert_check_time(NULL, NOW), UB_IDENT_MALFORMED);

    ub_revocation_t rv = {.serial = 1, .time_s = NOW};
    eid(rv.entity, "veh1");
    uint8_t rb[UB_REVOCATION_LEN];
    assert_int_equal(ub_revocation_sign(NULL, auth_sk), UB_ERR_INVAL);
    assert_int_equal(ub_revocation_sign(&rv, NULL), UB_ERR_INVAL);
    ub_revocation_t rbad = rv;
    rbad.serial = 0;
    assert_int_equal(ub_revocation_sign(&rbad, auth_sk), UB_ERR_CONFIG);
    memset(rbad.entity, 0xFF, UB_ENTITY_ID_LEN); /* all 0xFF: no entity */
    rbad.serial = 3;
    assert_int_equal(ub_revocation_sign(&rbad, auth_sk), UB_ERR_CONFIG);
    assert_int_equal(ub_revocation_sign(&rv, auth_sk), UB_OK);
    assert_int_equal(ub_revocation_encode(NULL, rb), UB_ERR_INVAL);
    assert_int_equal(ub_revocation_encode(&rv, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_revocation_encode(&rv, rb), UB_OK);
    assert_int_equal(ub_revocation_decode(NULL, rb, sizeof rb), UB_ERR_INVAL);
    assert_int_equal(ub_revocation_decode(&rbad, NULL, sizeof rb), UB_ERR_INVAL);
    assert_int_equal(ub_revocation_decode(&rbad, rb, sizeof rb - 1), UB_ERR_TRUNCATED);
    assert_int_equal(ub_revocation_verify(NULL, auth_pk), UB_IDENT_MALFORMED);
    assert_int_equal(ub_revocation_verify(&rv, NULL), UB_IDENT_MALFORMED);
    assert_int_equal(ub_revocation_verify(&rv, other_pk), UB_IDENT_WRONG_AUTHORITY);
    rv.sig[0] ^= 1;
    assert_int_equal(ub_revocation_verify(&rv, auth_pk), UB_IDENT_BAD_SIGNATURE);
}

static void test_store_contracts_and_refusals(void **state) {
    (void)state;
    ub_ident_store_t *s = &g_store;
    ub_ident_store_init(s);
    ub_ident_store_init(NULL);
    ub_ident_store_clear(NULL);
    ub_cert_t self;
    uint8_t ssk[UB_IDENT_SIGN_SK_LEN], xsk[UB_IDENT_KX_SK_LEN], buf[UB_CERT_LEN];
    make_cert(&self, "gcs1", 20, 5, NOW - 100, NOW + 100, auth_sk, ssk, xsk);
    ub_ident_status_t why = UB_IDENT_VALID;
    /* No authority yet: nothing to verify against. */
    assert_int_equal(ub_ident_set_self(s, &self, ssk, xsk, NOW, &why), UB_ERR_NOTFOUND);
    assert_int_equal(ub_cert_encode(&self, buf), UB_OK);
    assert_int_equal(ub_ident_add_peer(s, buf, sizeof buf, NOW, &why), UB_ERR_AUTH);
    assert_int_equal(why, UB_IDENT_WRONG_AUTHORITY);
    assert_int_equal(ub_ident_set_authority(NULL, auth_pk), UB_ERR_INVAL);
    assert_int_equal(ub_ident_set_authority(s, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_ident_set_authority(s, auth_pk), UB_OK);
    assert_int_equal(ub_ident_set_authority(s, auth_pk), UB_OK); /* the same again: nothing forgotten */

    assert_int_equal(ub_ident_set_self(NULL, &self, ssk, xsk, NOW, &why), UB_ERR_INVAL);
    assert_int_equal(ub_ident_set_self(s, NULL, ssk, xsk, NOW, &why), UB_ERR_INVAL);
    assert_int_equal(ub_ident_set_self(s, &self, NULL, xsk, NOW, &why), UB_ERR_INVAL);
    assert_int_equal(ub_ident_set_self(s, &self, ssk, NULL, NOW, &why), UB_ERR_INVAL);
    uint8_t wrong[UB_IDENT_KX_SK_LEN];
    memset(wrong, 7, sizeof wrong);
    assert_int_equal(ub_ident_set_self(s, &self, ssk, wrong, NOW, &why), UB_ERR_AUTH); /* not the certificate's key */
    assert_int_equal(why, UB_IDENT_MALFORMED);
    assert_int_equal(ub_ident_set_self(s, &self, ssk, xsk, NOW + 1000, &why), UB_ERR_AUTH);
    assert_int_equal(why, UB_IDENT_EXPIRED);
    assert_int_equal(ub_ident_self_count(s), 0);
    assert_null(ub_ident_self(s));
    assert_null(ub_ident_self_kx_sk(s));
    assert_int_equal(ub_ident_set_self(s, &self, ssk, xsk, NOW, &why), UB_OK);
    assert_int_equal(ub_ident_set_self(s, &self, ssk, xsk, NOW, &why), UB_OK); /* the same entity: replaced */
    assert_int_equal(ub_ident_self_count(s), 1);
    assert_non_null(ub_ident_self_kx_sk(s));
    assert_null(ub_ident_self_at(s, 1));
    assert_null(ub_ident_self_at(NULL, 0));
    assert_int_equal(ub_ident_self_count(NULL), 0);
    assert_null(ub_ident_self(NULL));
    assert_null(ub_ident_self_kx_sk(NULL));
    uint8_t id[UB_ENTITY_ID_LEN];
    eid(id, "gcs1");
    assert_memory_equal(ub_ident_self_kx_sk_for(s, id), xsk, UB_IDENT_KX_SK_LEN);
    eid(id, "nobody");
    assert_null(ub_ident_self_kx_sk_for(s, id));
    assert_null(ub_ident_self_kx_sk_for(s, NULL));
    assert_null(ub_ident_self_kx_sk_for(NULL, id));

    /* Peers: NULL, wrong length, not yet valid; then lookups of unknown, valid, expired, revoked. */
    ub_cert_t peer;
    uint8_t pssk[UB_IDENT_SIGN_SK_LEN], pxsk[UB_IDENT_KX_SK_LEN];
    make_cert(&peer, "veh2", 30, 2, NOW + 50, NOW + 500, auth_sk, pssk, pxsk);
    assert_int_equal(ub_cert_encode(&peer, buf), UB_OK);
    assert_int_equal(ub_ident_add_peer(NULL, buf, sizeof buf, NOW, &why), UB_ERR_INVAL);
    assert_int_equal(ub_ident_add_peer(s, NULL, sizeof buf, NOW, &why), UB_ERR_INVAL);
    assert_int_equal(ub_ident_add_peer(s, buf, sizeof buf - 1, NOW, NULL), UB_ERR_AUTH);
    assert_int_equal(ub_ident_add_peer(s, buf, sizeof buf, NOW, &why), UB_ERR_AUTH);
    assert_int_equal(why, UB_IDENT_NOT_YET_VALID);
    assert_int_equal(ub_ident_add_peer(s, buf, sizeof buf, NOW + 60, &why), UB_OK);
    const ub_ident_stats_t *st = ub_ident_stats(s);
    assert_int_equal(st->peers_refused[UB_IDENT_MALFORMED], 1);
    assert_int_equal(st->peers_refused[UB_IDENT_NOT_YET_VALID], 1);
    assert_null(ub_ident_stats(NULL));

    uint8_t pk[UB_IDENT_SIGN_PK_LEN];
    uint16_t roles = 0xFFFF;
    eid(id, "veh2");
    assert_int_equal(ub_ident_peer_sign_key(s, id, NOW + 60, pk), UB_OK);
    assert_memory_equal(pk, peer.sign_pk, sizeof pk);
    assert_int_equal(ub_ident_peer_sign_key(NULL, id, NOW, pk), UB_ERR_INVAL);
    assert_int_equal(ub_ident_peer_sign_key(s, NULL, NOW, pk), UB_ERR_INVAL);
    assert_int_equal(ub_ident_peer_sign_key(s, id, NOW, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_ident_peer_kx_key(NULL, id, NOW, pk), UB_ERR_INVAL);
    assert_int_equal(ub_ident_peer_roles(NULL, id, NOW, &roles), UB_ERR_INVAL);
    assert_int_equal(ub_ident_peer_roles(s, id, NOW, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_ident_peer_roles(s, id, NOW + 1000, &roles), UB_ERR_AUTH); /* expired by then */
    assert_int_equal(roles, 0);
    assert_int_equal(ub_ident_peer_kx_key(s, id, NOW + 1000, pk), UB_ERR_AUTH); /* a key lookup: counted */
    assert_int_equal(ub_ident_peer_status(NULL, id, NOW), UB_IDENT_MALFORMED);
    assert_int_equal(ub_ident_peer_status(s, NULL, NOW), UB_IDENT_MALFORMED);
    assert_null(ub_ident_peer_cert(NULL, id, NOW));
    assert_null(ub_ident_peer_cert(s, NULL, NOW));
    eid(id, "nobody");
    assert_int_equal(ub_ident_peer_sign_key(s, id, NOW, pk), UB_ERR_NOTFOUND);
    assert_int_equal(ub_ident_peer_status(s, id, NOW), UB_IDENT_UNKNOWN);
    assert_true(st->lookups_refused[UB_IDENT_UNKNOWN] >= 1);
    assert_true(st->lookups_refused[UB_IDENT_EXPIRED] >= 1);

    /* Revocation records: NULL, the index bounds, and a record of another authority. */
    ub_revocation_t rv = {.serial = 2, .time_s = NOW};
    eid(rv.entity, "veh2");
    uint8_t rb[UB_REVOCATION_LEN];
    assert_int_equal(ub_revocation_sign(&rv, other_sk), UB_OK);
    assert_int_equal(ub_revocation_encode(&rv, rb), UB_OK);
    assert_int_equal(ub_ident_add_revocation(s, rb, sizeof rb, &why), UB_ERR_AUTH);
    assert_int_equal(why, UB_IDENT_WRONG_AUTHORITY);
    assert_int_equal(ub_ident_add_revocation(NULL, rb, sizeof rb, &why), UB_ERR_INVAL);
    assert_int_equal(ub_ident_add_revocation(s, NULL, sizeof rb, &why), UB_ERR_INVAL);
    assert_int_equal(st->revocations_refused, 1);
    assert_int_equal(ub_revocation_sign(&rv, auth_sk), UB_OK);
    assert_int_equal(ub_revocation_encode(&rv, rb), UB_OK);
    assert_true(ub_ident_add_revocation(s, rb, sizeof rb, &why) >= 0);
    assert_int_equal(ub_ident_add_revocation(s, rb, sizeof rb, &why), UB_ERR_EXISTS);
    assert_int_equal(st->revocations_known, 1);
    eid(id, "veh2");
    assert_int_equal(ub_ident_peer_status(s, id, NOW + 60), UB_IDENT_REVOKED);
    assert_int_equal(ub_ident_revocation_count(s), 1);
    assert_int_equal(ub_ident_revocation_count(NULL), 0);
    uint8_t out[UB_REVOCATION_LEN];
    assert_int_equal(ub_ident_revocation_at(s, 0, out), UB_OK);
    assert_memory_equal(out, rb, sizeof rb);
    assert_int_equal(ub_ident_revocation_at(s, 1, out), UB_ERR_NOTFOUND);
    assert_int_equal(ub_ident_revocation_at(NULL, 0, out), UB_ERR_INVAL);
    assert_int_equal(ub_ident_revocation_at(s, 0, NULL), UB_ERR_INVAL);
    assert_false(ub_ident_is_revoked(NULL, id, 1));
    assert_false(ub_ident_is_revoked(s, NULL, 1));
    assert_true(ub_ident_is_revoked(s, id, 2));
    assert_false(ub_ident_is_revoked(s, id, 3));
    /* Another authority: nothing the first one signed stays. */
    assert_int_equal(ub_ident_set_authority(s, other_pk), UB_OK);
    assert_int_equal(ub_ident_revocation_count(s), 0);
    assert_int_equal(ub_ident_self_count(s), 0);
    assert_false(ub_ident_is_revoked(s, id, 2));
    ub_ident_store_clear(s);
    assert_int_equal(ub_ident_revocation_count(s), 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_names_and_key_contracts),
        cmocka_unit_test(test_cert_and_record_contracts),
        cmocka_unit_test(test_store_contracts_and_refusals),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
