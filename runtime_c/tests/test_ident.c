/*
 * Identity per entity (ub_ident.h, ub_identfile.h): certificates round trip; every byte of a
 * certificate and of a revocation record, altered, is refused; validity period; wrong authority;
 * the store's lookups (unknown, revoked, expired, rollback to an older serial); revocation
 * persistence across a restart (write, reload, still refused); identity files (mode, size, keys
 * that are not the certificate's, expired, revoked) refused with one line that says what to do.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "support/ub_test_ident.h"
#include "ub/ub_identfile.h"
#include "ub/ub_nodecfg.h"
#include "ub/ub_policy.h"

#define T0 1790000000u /* "now" in these tests */
#define DAY 86400u

static test_authority_t auth, other;

static int setup(void **state) {
    (void)state;
    return test_authority(&auth, "fleet authority") == UB_OK && test_authority(&other, "another fleet") == UB_OK ? 0 : -1;
}

static void store_with_authority(ub_ident_store_t *s) {
    ub_ident_store_init(s);
    assert_int_equal(ub_ident_set_authority(s, auth.pk), UB_OK);
}

static void test_round_trip(void **state) {
    (void)state;
    test_entity_t e;
    assert_int_equal(test_issue(&e, &auth, "rmax1ob1", UB_ROLE_VEHICLE | UB_ROLE_RELAY, 7, T0, T0 + DAY), UB_OK);
    ub_cert_t d;
    assert_int_equal(ub_cert_decode(&d, e.cert_bytes, sizeof e.cert_bytes), UB_OK);
    assert_int_equal(d.roles, UB_ROLE_VEHICLE | UB_ROLE_RELAY);
    assert_true(d.serial == 7 && d.not_before == T0 && d.not_after == T0 + DAY);
    assert_memory_equal(d.entity, "rmax1ob1\0\0\0\0", 12);
    assert_memory_equal(d.sign_pk, e.cert.sign_pk, 32);
    assert_memory_equal(d.kx_pk, e.cert.kx_pk, 32);
    assert_int_equal(ub_cert_verify(&d, auth.pk), UB_IDENT_VALID);
    uint8_t again[UB_CERT_LEN];
    assert_int_equal(ub_cert_encode(&d, again), UB_OK);
    assert_memory_equal(again, e.cert_bytes, UB_CERT_LEN);
    /* wire: version, kind, roles little-endian, serial little-endian */
    assert_int_equal(e.cert_bytes[0], 1);
    assert_int_equal(e.cert_bytes[1], UB_IDENT_KIND_CERT);
    assert_int_equal(e.cert_bytes[2], 0x06);
    assert_int_equal(e.cert_bytes[4], 7);
    /* lengths other than 176 are refused */
    assert_int_equal(ub_cert_decode(&d, e.cert_bytes, UB_CERT_LEN - 1), UB_ERR_TRUNCATED);
    uint8_t longer[UB_CERT_LEN + 1];
    memcpy(longer, e.cert_bytes, UB_CERT_LEN);
    longer[UB_CERT_LEN] = 0;
    assert_int_equal(ub_cert_decode(&d, longer, sizeof longer), UB_ERR_TRUNCATED);
}

/* Every byte of the certificate, altered (each bit in turn would take long: one flip of the low bit and
 * one of the high bit per byte), is refused by decode, by the signature, or by the authority key id. */
static void test_every_cert_byte_matters(void **state) {
    (void)state;
    test_entity_t e;
    assert_int_equal(test_issue(&e, &auth, "gcs1", UB_ROLE_ADMIN, 1, T0, T0 + DAY), UB_OK);
    ub_ident_store_t *s = calloc(1, sizeof *s);
    store_with_authority(s);
    for (size_t i = 0; i < UB_CERT_LEN; i++) {
        for (unsigned bit = 0; bit < 8; bit += 7) {
            uint8_t bad[UB_CERT_LEN];
            memcpy(bad, e.cert_bytes, sizeof bad);
            bad[i] ^= (uint8_t)(1u << bit);
            ub_ident_status_t why = UB_IDENT_VALID;
            int rc = ub_ident_add_peer(s, bad, sizeof bad, T0, &why);
            if (rc != UB_ERR_AUTH || why == UB_IDENT_VALID) fail_msg("byte %zu bit %u accepted (rc %d)", i, bit, rc);
        }
    }
    assert_int_equal(s->n_peers, 0);
    assert_int_equal(ub_ident_add_peer(s, e.cert_bytes, UB_CERT_LEN, T0, NULL), UB_OK);
    assert_int_equal(s->n_peers, 1);
    free(s);
}

static void test_every_revocation_byte_matters(void **state) {
    (void)state;
    uint8_t rec[UB_REVOCATION_LEN];
    assert_int_equal(test_revoke_record(rec, &auth, "fcs20", 3, T0), UB_OK);
    ub_ident_store_t *s = calloc(1, sizeof *s);
    store_with_authority(s);
    for (size_t i = 0; i < UB_REVOCATION_LEN; i++) {
        uint8_t bad[UB_REVOCATION_LEN];
        memcpy(bad, rec, sizeof bad);
        bad[i] ^= 0x01;
        if (ub_ident_add_revocation(s, bad, sizeof bad, NULL) != UB_ERR_AUTH) fail_msg("byte %zu accepted", i);
    }
    assert_int_equal(ub_ident_revocation_count(s), 0);
    assert_int_equal(s->stats.revocations_refused, UB_REVOCATION_LEN);
    assert_int_equal(ub_ident_add_revocation(s, rec, sizeof rec, NULL), 0);
    assert_int_equal(ub_ident_add_revocation(s, rec, sizeof rec, NULL), UB_ERR_EXISTS); /* idempotent */
    free(s);
}

static void test_decode_domain(void **state) {
    (void)state;
    test_entity_t e;
    assert_int_equal(test_issue(&e, &auth, "gcs1", UB_ROLE_ADMIN, 1, T0, T0 + DAY), UB_OK);
    ub_cert_t d;
    uint8_t bad[UB_CERT_LEN];
    /* version 2, a revocation's kind, an unknown role bit, serial 0, entity all zero / all 0xFF, nb > na */
    const struct { size_t off; uint8_t v; } cases[] = {{0, 2}, {1, UB_IDENT_KIND_REVOCATION}, {2, 0x20}, {3, 0x80}};
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        memcpy(bad, e.cert_bytes, sizeof bad);
        bad[cases[k].off] = cases[k].v;
        assert_int_equal(ub_cert_decode(&d, bad, sizeof bad), UB_ERR_CONFIG);
    }
    memcpy(bad, e.cert_bytes, sizeof bad);
    memset(bad + 4, 0, 8);
    assert_int_equal(ub_cert_decode(&d, bad, sizeof bad), UB_ERR_CONFIG);
    memcpy(bad, e.cert_bytes, sizeof bad);
    memset(bad + 12, 0, 12);
    assert_int_equal(ub_cert_decode(&d, bad, sizeof bad), UB_ERR_CONFIG);
    memset(bad + 12, 0xFF, 12);
    assert_int_equal(ub_cert_decode(&d, bad, sizeof bad), UB_ERR_CONFIG);
    memcpy(bad, e.cert_bytes, sizeof bad);
    bad[88 + 7] = 0xFF; /* not_before far after not_after */
    assert_int_equal(ub_cert_decode(&d, bad, sizeof bad), UB_ERR_CONFIG);
    /* signing refuses what decoding would refuse */
    ub_cert_t c = e.cert;
    c.roles = 0x100;
    assert_int_equal(ub_cert_sign(&c, auth.sk), UB_ERR_CONFIG);
}

static void test_validity_period(void **state) {
    (void)state;
    test_entity_t e;
    assert_int_equal(test_issue(&e, &auth, "fcs20", UB_ROLE_VEHICLE, 1, T0, T0 + DAY), UB_OK);
    assert_int_equal(ub_cert_check_time(&e.cert, T0 - 1), UB_IDENT_NOT_YET_VALID);
    assert_int_equal(ub_cert_check_time(&e.cert, T0), UB_IDENT_VALID);
    assert_int_equal(ub_cert_check_time(&e.cert, T0 + DAY), UB_IDENT_VALID);
    assert_int_equal(ub_cert_check_time(&e.cert, T0 + DAY + 1), UB_IDENT_EXPIRED);
    ub_ident_store_t *s = calloc(1, sizeof *s);
    store_with_authority(s);
    ub_ident_status_t why;
    assert_int_equal(ub_ident_add_peer(s, e.cert_bytes, UB_CERT_LEN, T0 + DAY + 1, &why), UB_ERR_AUTH);
    assert_int_equal(why, UB_IDENT_EXPIRED);
    assert_int_equal(ub_ident_add_peer(s, e.cert_bytes, UB_CERT_LEN, T0 - 1, &why), UB_ERR_AUTH);
    assert_int_equal(why, UB_IDENT_NOT_YET_VALID);
    assert_int_equal(ub_ident_add_peer(s, e.cert_bytes, UB_CERT_LEN, T0, &why), UB_OK);
    /* held, then expired: the lookup refuses it */
    uint8_t pk[32];
    assert_int_equal(ub_ident_peer_kx_key(s, e.cert.entity, T0 + 10, pk), UB_OK);
    assert_memory_equal(pk, e.cert.kx_pk, 32);
    assert_int_equal(ub_ident_peer_kx_key(s, e.cert.entity, T0 + DAY + 1, pk), UB_ERR_AUTH);
    assert_int_equal(ub_ident_peer_status(s, e.cert.entity, T0 + DAY + 1), UB_IDENT_EXPIRED);
    assert_int_equal(s->stats.lookups_refused[UB_IDENT_EXPIRED], 1);
    uint16_t roles = 0xFFFF;
    assert_int_equal(ub_ident_peer_roles(s, e.cert.entity, T0 + DAY + 1, &roles), UB_ERR_AUTH);
    assert_int_equal(roles, 0);
    free(s);
}

static void test_wrong_authority(void **state) {
    (void)state;
    test_entity_t e;
    assert_int_equal(test_issue(&e, &other, "gcs1", UB_ROLE_ADMIN, 1, T0, T0 + DAY), UB_OK);
    ub_ident_store_t *s = calloc(1, sizeof *s);
    store_with_authority(s);
    ub_ident_status_t why;
    assert_int_equal(ub_ident_add_peer(s, e.cert_bytes, UB_CERT_LEN, T0, &why), UB_ERR_AUTH);
    assert_int_equal(why, UB_IDENT_WRONG_AUTHORITY);
    /* the other authority's signature under our key id: a forged key id does not help */
    ub_cert_t forged = e.cert;
    assert_int_equal(ub_ident_authority_kid(auth.pk, forged.authority), UB_OK);
    uint8_t bytes[UB_CERT_LEN];
    assert_int_equal(ub_cert_encode(&forged, bytes), UB_OK);
    assert_int_equal(ub_ident_add_peer(s, bytes, UB_CERT_LEN, T0, &why), UB_ERR_AUTH);
    assert_int_equal(why, UB_IDENT_BAD_SIGNATURE);
    uint8_t rec[UB_REVOCATION_LEN];
    assert_int_equal(test_revoke_record(rec, &other, "gcs1", 1, T0), UB_OK);
    assert_int_equal(ub_ident_add_revocation(s, rec, sizeof rec, &why), UB_ERR_AUTH);
    assert_int_equal(why, UB_IDENT_WRONG_AUTHORITY);
    uint8_t pk[32];
    assert_int_equal(ub_ident_peer_kx_key(s, e.cert.entity, T0, pk), UB_ERR_NOTFOUND);
    free(s);
}

static void test_revocation_in_the_store(void **state) {
    (void)state;
    test_entity_t old, repl, other_entity;
    assert_int_equal(test_issue(&old, &auth, "rmax1ob1", UB_ROLE_VEHICLE, 5, T0, T0 + DAY), UB_OK);
    assert_int_equal(test_issue(&repl, &auth, "rmax1ob1", UB_ROLE_VEHICLE, 9, T0, T0 + DAY), UB_OK);
    assert_int_equal(test_issue(&other_entity, &auth, "fcs20", UB_ROLE_VEHICLE, 6, T0, T0 + DAY), UB_OK);
    ub_ident_store_t *s = calloc(1, sizeof *s);
    store_with_authority(s);
    assert_int_equal(ub_ident_add_peer(s, old.cert_bytes, UB_CERT_LEN, T0, NULL), UB_OK);
    assert_int_equal(ub_ident_add_peer(s, other_entity.cert_bytes, UB_CERT_LEN, T0, NULL), UB_OK);
    uint8_t rec[UB_REVOCATION_LEN];
    assert_int_equal(test_revoke_record(rec, &auth, "rmax1ob1", 5, T0 + 5), UB_OK);
    assert_int_equal(ub_ident_add_revocation(s, rec, sizeof rec, NULL), 0);
    uint8_t pk[32];
    assert_int_equal(ub_ident_peer_kx_key(s, old.cert.entity, T0 + 6, pk), UB_ERR_AUTH);
    assert_int_equal(ub_ident_peer_status(s, old.cert.entity, T0 + 6), UB_IDENT_REVOKED);
    assert_int_equal(ub_ident_peer_kx_key(s, other_entity.cert.entity, T0 + 6, pk), UB_OK); /* others unaffected */
    assert_int_equal(s->stats.peers_removed, 1);
    /* the revoked certificate cannot come back */
    ub_ident_status_t why;
    assert_int_equal(ub_ident_add_peer(s, old.cert_bytes, UB_CERT_LEN, T0 + 7, &why), UB_ERR_AUTH);
    assert_int_equal(why, UB_IDENT_REVOKED);
    /* the replacement (a higher serial) is accepted; the old one still not */
    assert_int_equal(ub_ident_add_peer(s, repl.cert_bytes, UB_CERT_LEN, T0 + 8, NULL), UB_OK);
    assert_int_equal(ub_ident_peer_kx_key(s, repl.cert.entity, T0 + 8, pk), UB_OK);
    assert_memory_equal(pk, repl.cert.kx_pk, 32);
    assert_int_equal(ub_ident_add_peer(s, old.cert_bytes, UB_CERT_LEN, T0 + 9, &why), UB_ERR_AUTH);
    /* an older serial never replaces a newer one, even unrevoked */
    test_entity_t older;
    assert_int_equal(test_issue(&older, &auth, "fcs20", UB_ROLE_VEHICLE | UB_ROLE_ADMIN, 4, T0, T0 + DAY), UB_OK);
    assert_int_equal(ub_ident_add_peer(s, older.cert_bytes, UB_CERT_LEN, T0, &why), UB_ERR_AUTH);
    uint16_t roles;
    assert_int_equal(ub_ident_peer_roles(s, other_entity.cert.entity, T0, &roles), UB_OK);
    assert_int_equal(roles, UB_ROLE_VEHICLE);
    /* a newer record for the same entity replaces the record in place; an older one is known */
    uint8_t rec2[UB_REVOCATION_LEN], rec_old[UB_REVOCATION_LEN];
    assert_int_equal(test_revoke_record(rec2, &auth, "rmax1ob1", 9, T0 + 20), UB_OK);
    assert_int_equal(test_revoke_record(rec_old, &auth, "rmax1ob1", 3, T0 + 20), UB_OK);
    assert_int_equal(ub_ident_add_revocation(s, rec_old, sizeof rec_old, NULL), UB_ERR_EXISTS);
    assert_int_equal(ub_ident_add_revocation(s, rec2, sizeof rec2, NULL), 0);
    assert_int_equal(ub_ident_revocation_count(s), 1);
    assert_int_equal(ub_ident_peer_kx_key(s, repl.cert.entity, T0 + 21, pk), UB_ERR_AUTH);
    free(s);
}

static void test_self_identity(void **state) {
    (void)state;
    test_entity_t me, you;
    assert_int_equal(test_issue(&me, &auth, "gcs1", UB_ROLE_ADMIN, 1, T0, T0 + DAY), UB_OK);
    assert_int_equal(test_issue(&you, &auth, "fcs20", UB_ROLE_VEHICLE, 2, T0, T0 + DAY), UB_OK);
    ub_ident_store_t *s = calloc(1, sizeof *s);
    ub_ident_store_init(s);
    ub_ident_status_t why;
    assert_int_equal(ub_ident_set_self(s, &me.cert, me.sign_sk, me.kx_sk, T0, &why), UB_ERR_NOTFOUND);
    assert_int_equal(ub_ident_set_authority(s, auth.pk), UB_OK);
    /* someone else's secret keys */
    assert_int_equal(ub_ident_set_self(s, &me.cert, you.sign_sk, me.kx_sk, T0, &why), UB_ERR_AUTH);
    assert_int_equal(why, UB_IDENT_MALFORMED);
    assert_int_equal(ub_ident_set_self(s, &me.cert, me.sign_sk, you.kx_sk, T0, &why), UB_ERR_AUTH);
    assert_int_equal(ub_ident_set_self(s, &me.cert, me.sign_sk, me.kx_sk, T0 + 2 * DAY, &why), UB_ERR_AUTH);
    assert_int_equal(why, UB_IDENT_EXPIRED);
    assert_null(ub_ident_self(s));
    assert_int_equal(ub_ident_set_self(s, &me.cert, me.sign_sk, me.kx_sk, T0, &why), UB_OK);
    assert_non_null(ub_ident_self(s));
    assert_memory_equal(ub_ident_self_kx_sk(s), me.kx_sk, 32);
    uint8_t pk[32];
    assert_int_equal(ub_ident_peer_kx_key(s, me.cert.entity, T0, pk), UB_OK); /* own entity answers too */
    /* a new authority forgets everything the old one signed, secret keys included */
    assert_int_equal(ub_ident_set_authority(s, other.pk), UB_OK);
    assert_null(ub_ident_self(s));
    free(s);
}

static void test_full_table(void **state) {
    (void)state;
    ub_ident_store_t *s = calloc(1, sizeof *s);
    store_with_authority(s);
    test_entity_t e;
    char name[16];
    for (int i = 0; i < UB_IDENT_MAX_PEERS; i++) {
        (void)snprintf(name, sizeof name, "v%d", i);
        /* the first one expires early: its place can be reused */
        assert_int_equal(test_issue(&e, &auth, name, UB_ROLE_VEHICLE, 1, T0, i == 0 ? T0 + 10 : T0 + DAY), UB_OK);
        assert_int_equal(ub_ident_add_peer(s, e.cert_bytes, UB_CERT_LEN, T0, NULL), UB_OK);
    }
    assert_int_equal(test_issue(&e, &auth, "late", UB_ROLE_VEHICLE, 1, T0, T0 + DAY), UB_OK);
    assert_int_equal(ub_ident_add_peer(s, e.cert_bytes, UB_CERT_LEN, T0 + 5, NULL), UB_ERR_FULL);
    assert_int_equal(s->stats.peers_full, 1);
    assert_int_equal(ub_ident_add_peer(s, e.cert_bytes, UB_CERT_LEN, T0 + 11, NULL), UB_OK);
    uint8_t id[12], pk[32];
    assert_int_equal(ub_entity_id("v0", id), UB_OK);
    assert_int_equal(ub_ident_peer_kx_key(s, id, T0 + 11, pk), UB_ERR_NOTFOUND);
    free(s);
}

/* ---- files ---- */

static char dir[64];

static int files_setup(void **state) {
    (void)state;
    (void)snprintf(dir, sizeof dir, "/tmp/ub_test_ident_XXXXXX");
    return mkdtemp(dir) != NULL ? 0 : -1;
}

static int files_teardown(void **state) {
    (void)state;
    char cmd[128];
    (void)snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    return system(cmd) == 0 ? 0 : -1;
}

static void path_of(char *out, size_t cap, const char *name) { (void)snprintf(out, cap, "%s/%s", dir, name); }

/* One line, naming the file, saying what to do. */
static void assert_one_line(const char *err, const char *file, const char *hint) {
    if (strchr(err, '\n') != NULL || strncmp(err, file, strlen(file)) != 0 || strstr(err, hint) == NULL)
        fail_msg("message '%s' (want '%s: ...%s...')", err, file, hint);
}

static void test_identity_files(void **state) {
    (void)state;
    char idp[128], pubp[128], revp[128], err[UB_IDENTFILE_ERR_LEN];
    path_of(idp, sizeof idp, "rmax1ob1.id");
    path_of(pubp, sizeof pubp, "authority.pub");
    path_of(revp, sizeof revp, "revocations.ubr");
    test_entity_t e;
    assert_int_equal(test_issue(&e, &auth, "rmax1ob1", UB_ROLE_VEHICLE, 4, T0, T0 + DAY), UB_OK);
    assert_int_equal(ub_identfile_write(idp, &e.cert, e.sign_seed, e.kx_sk, false, err, sizeof err), UB_OK);
    struct stat st;
    assert_int_equal(stat(idp, &st), 0);
    assert_int_equal(st.st_mode & 0777, 0600);
    assert_int_equal(ub_identfile_write(idp, &e.cert, e.sign_seed, e.kx_sk, false, err, sizeof err), UB_ERR_EXISTS);
    assert_one_line(err, idp, "--force");
    assert_int_equal(ub_identfile_write(idp, &e.cert, e.sign_seed, e.kx_sk, true, err, sizeof err), UB_OK);
    assert_int_equal(ub_authfile_write_public(pubp, auth.pk, false, err, sizeof err), UB_OK);

    ub_ident_store_t *s = calloc(1, sizeof *s);
    assert_int_equal(ub_identfile_load_store(s, idp, pubp, revp, T0, err, sizeof err), UB_OK);
    assert_non_null(ub_ident_self(s));
    assert_memory_equal(ub_ident_self(s)->kx_pk, e.cert.kx_pk, 32);

    /* expired, not yet valid: refused with what to do */
    assert_int_equal(ub_identfile_load_store(s, idp, pubp, revp, T0 + 2 * DAY, err, sizeof err), UB_ERR_CONFIG);
    assert_one_line(err, idp, "uavbus keys issue rmax1ob1");
    assert_non_null(strstr(err, "expired"));
    assert_int_equal(ub_identfile_load_store(s, idp, pubp, revp, T0 - 5, err, sizeof err), UB_ERR_CONFIG);
    assert_one_line(err, idp, "clock");
    /* group-readable secret */
    assert_int_equal(chmod(idp, 0640), 0);
    assert_int_equal(ub_identfile_load_store(s, idp, pubp, revp, T0, err, sizeof err), UB_ERR_CONFIG);
    assert_one_line(err, idp, "chmod 600");
    assert_int_equal(chmod(idp, 0600), 0);
    /* another authority's public key */
    char otherp[128];
    path_of(otherp, sizeof otherp, "other.pub");
    assert_int_equal(ub_authfile_write_public(otherp, other.pk, false, err, sizeof err), UB_OK);
    assert_int_equal(ub_identfile_load_store(s, idp, otherp, NULL, T0, err, sizeof err), UB_ERR_CONFIG);
    assert_one_line(err, idp, "another authority");
    /* a file that is not an identity, a truncated one */
    char keyp[128];
    path_of(keyp, sizeof keyp, "authority.key");
    assert_int_equal(ub_authfile_write_secret(keyp, auth.seed, err, sizeof err), UB_OK);
    assert_int_equal(ub_identfile_load_store(s, keyp, pubp, NULL, T0, err, sizeof err), UB_ERR_CONFIG);
    assert_one_line(err, keyp, "uavbus keys issue");
    assert_int_equal(truncate(idp, UB_IDENTFILE_LEN - 1), 0);
    assert_int_equal(ub_identfile_load_store(s, idp, pubp, NULL, T0, err, sizeof err), UB_ERR_CONFIG);
    assert_one_line(err, idp, "--force");
    /* keys that are not the certificate's */
    test_entity_t f;
    assert_int_equal(test_issue(&f, &auth, "fcs21", UB_ROLE_VEHICLE, 5, T0, T0 + DAY), UB_OK);
    assert_int_equal(ub_identfile_write(idp, &e.cert, f.sign_seed, e.kx_sk, true, err, sizeof err), UB_OK);
    assert_int_equal(ub_identfile_load_store(s, idp, pubp, NULL, T0, err, sizeof err), UB_ERR_CONFIG);
    assert_one_line(err, idp, "not the certificate's");
    free(s);
}

/* Revoked, persisted, restarted: still refused; the revoked identity file cannot start a node. */
static void test_revocation_persists_across_restart(void **state) {
    (void)state;
    char idp[128], pubp[128], revp[128], err[UB_IDENTFILE_ERR_LEN];
    path_of(idp, sizeof idp, "fcs20.id");
    path_of(pubp, sizeof pubp, "authority2.pub");
    path_of(revp, sizeof revp, "state.ubr");
    test_entity_t victim, me;
    assert_int_equal(test_issue(&victim, &auth, "fcs20", UB_ROLE_VEHICLE, 11, T0, T0 + DAY), UB_OK);
    assert_int_equal(test_issue(&me, &auth, "gcs1", UB_ROLE_ADMIN, 12, T0, T0 + DAY), UB_OK);
    assert_int_equal(ub_identfile_write(idp, &victim.cert, victim.sign_seed, victim.kx_sk, false, err, sizeof err),
                     UB_OK);
    assert_int_equal(ub_authfile_write_public(pubp, auth.pk, false, err, sizeof err), UB_OK);

    ub_ident_store_t *s = calloc(1, sizeof *s);
    assert_int_equal(ub_identfile_load_store(s, NULL, pubp, revp, T0, err, sizeof err), UB_OK); /* no file: nothing */
    assert_int_equal(ub_ident_add_peer(s, victim.cert_bytes, UB_CERT_LEN, T0, NULL), UB_OK);
    uint8_t rec[UB_REVOCATION_LEN];
    assert_int_equal(test_revoke_record(rec, &auth, "fcs20", 11, T0 + 1), UB_OK);
    assert_int_equal(ub_ident_add_revocation(s, rec, sizeof rec, NULL), 0);
    assert_int_equal(ub_revfile_persist(revp, s), UB_OK);

    /* restart: a fresh store from the files */
    assert_int_equal(ub_identfile_load_store(s, NULL, pubp, revp, T0 + 2, err, sizeof err), UB_OK);
    assert_int_equal(ub_ident_revocation_count(s), 1);
    ub_ident_status_t why;
    assert_int_equal(ub_ident_add_peer(s, victim.cert_bytes, UB_CERT_LEN, T0 + 2, &why), UB_ERR_AUTH);
    assert_int_equal(why, UB_IDENT_REVOKED);
    uint8_t pk[32];
    assert_int_equal(ub_ident_peer_kx_key(s, victim.cert.entity, T0 + 2, pk), UB_ERR_AUTH);
    /* the revoked vehicle's own restart with the same identity: refused */
    assert_int_equal(ub_identfile_load_store(s, idp, pubp, revp, T0 + 2, err, sizeof err), UB_ERR_CONFIG);
    assert_one_line(err, idp, "revoked");
    /* a damaged revocations file is refused, not silently emptied */
    assert_int_equal(truncate(revp, UB_IDENTFILE_HEADER_LEN + UB_REVOCATION_LEN - 1), 0);
    assert_int_equal(ub_identfile_load_store(s, NULL, pubp, revp, T0 + 2, err, sizeof err), UB_ERR_CONFIG);
    assert_one_line(err, revp, "whole number");
    /* records of another authority make the file refused */
    ub_ident_store_t *o = calloc(1, sizeof *o);
    ub_ident_store_init(o);
    assert_int_equal(ub_ident_set_authority(o, other.pk), UB_OK);
    uint8_t orec[UB_REVOCATION_LEN];
    assert_int_equal(test_revoke_record(orec, &other, "fcs20", 1, T0), UB_OK);
    assert_int_equal(ub_ident_add_revocation(o, orec, sizeof orec, NULL), 0);
    assert_int_equal(ub_revfile_save(revp, o, err, sizeof err), UB_OK);
    assert_int_equal(ub_identfile_load_store(s, NULL, pubp, revp, T0 + 2, err, sizeof err), UB_ERR_CONFIG);
    assert_one_line(err, revp, "record 1");
    free(o);
    free(s);
}

/* The node configuration names the identity files; a refused file is reported at the config line naming it. */
static void test_nodecfg_identity(void **state) {
    (void)state;
    char cfgp[128], idp[128], pubp[128], err[UB_NODECFG_ERR_LEN + UB_IDENTFILE_ERR_LEN];
    path_of(cfgp, sizeof cfgp, "node.json");
    path_of(idp, sizeof idp, "gcs1.id");
    path_of(pubp, sizeof pubp, "authority.pub");
    test_entity_t e;
    assert_int_equal(test_issue(&e, &auth, "gcs1", UB_ROLE_ADMIN, 3, T0, T0 + DAY), UB_OK);
    assert_int_equal(ub_identfile_write(idp, &e.cert, e.sign_seed, e.kx_sk, false, err, sizeof err), UB_OK);
    assert_int_equal(ub_authfile_write_public(pubp, auth.pk, false, err, sizeof err), UB_OK);
    test_entity_t m; /* a second hosted entity (a bridge): "{entity}" gives it an identity of its own */
    char mavp[128];
    path_of(mavp, sizeof mavp, "mav1.id");
    assert_int_equal(test_issue(&m, &auth, "mav1", UB_ROLE_BRIDGE, 4, T0, T0 + DAY), UB_OK);
    assert_int_equal(ub_identfile_write(mavp, &m.cert, m.sign_seed, m.kx_sk, false, err, sizeof err), UB_OK);
    static const char text[] =
        "{\n"
        "  \"entities\": [{\"name\": \"gcs1\", \"links\": [\"l0\"], \"linktoentity\": {}}, {\"name\": \"mav1\"}],\n"
        "  \"hosts\": [\"gcs1\", \"mav1\"],\n"
        "  \"security\": {\n"
        "    \"authority\": \"authority.pub\",\n"
        "    \"identity\": \"{entity}.id\",\n"
        "    \"revocations\": \"state.ubr\"\n"
        "  }\n"
        "}\n";
    FILE *f = fopen(cfgp, "w");
    assert_non_null(f);
    assert_int_equal(fwrite(text, 1, sizeof text - 1, f), sizeof text - 1);
    assert_int_equal(fclose(f), 0);
    ub_nodecfg_t *cfg = calloc(1, sizeof *cfg);
    static char buf[4096];
    assert_int_equal(ub_nodecfg_load_file(cfg, cfgp, buf, sizeof buf, err, sizeof err), UB_OK);
    ub_ident_store_t *s = calloc(1, sizeof *s);
    char revs[256];
    assert_int_equal(ub_nodecfg_load_identity(cfg, s, T0, revs, sizeof revs, err, sizeof err), UB_OK);
    assert_non_null(ub_ident_self(s));
    assert_int_equal(ub_ident_self_count(s), 2);
    assert_memory_equal(ub_ident_self_kx_sk_for(s, e.cert.entity), e.kx_sk, 32);
    assert_memory_equal(ub_ident_self_kx_sk_for(s, m.cert.entity), m.kx_sk, 32);
    uint16_t roles;
    assert_int_equal(ub_ident_peer_roles(s, m.cert.entity, T0, &roles), UB_OK);
    assert_int_equal(roles, UB_ROLE_BRIDGE);
    char want[160];
    path_of(want, sizeof want, "state.ubr");
    assert_string_equal(revs, want);
    /* group-readable identity: the config's line 6 names it, and the file's own message says what to do */
    assert_int_equal(chmod(idp, 0644), 0);
    assert_int_equal(ub_nodecfg_load_identity(cfg, s, T0, NULL, 0, err, sizeof err), UB_ERR_CONFIG);
    char where[400];
    (void)snprintf(where, sizeof where, "%s:6: field 'security.identity': %s: mode 644", cfgp, idp);
    if (strncmp(err, where, strlen(where)) != 0 || strstr(err, "chmod 600") == NULL || strchr(err, '\n') != NULL)
        fail_msg("message '%s'", err);
    assert_int_equal(chmod(idp, 0600), 0);
    /* expired: same line, what to do */
    assert_int_equal(ub_nodecfg_load_identity(cfg, s, T0 + 2 * DAY, NULL, 0, err, sizeof err), UB_ERR_CONFIG);
    (void)snprintf(where, sizeof where, "%s:6: field 'security.identity': %s: the certificate of 'gcs1' expired", cfgp,
                   idp);
    if (strncmp(err, where, strlen(where)) != 0) fail_msg("message '%s'", err);
    /* a damaged authority file: line 5 */
    assert_int_equal(truncate(pubp, 10), 0);
    assert_int_equal(ub_nodecfg_load_identity(cfg, s, T0, NULL, 0, err, sizeof err), UB_ERR_CONFIG);
    (void)snprintf(where, sizeof where, "%s:5: field 'security.authority': %s:", cfgp, pubp);
    if (strncmp(err, where, strlen(where)) != 0) fail_msg("message '%s'", err);
    free(s);
    free(cfg);
}

static void test_certificates_file(void **state) {
    (void)state;
    char certs[128], err[UB_IDENTFILE_ERR_LEN];
    path_of(certs, sizeof certs, "fleet.certs");
    test_entity_t gcs, uav, uav2, old, foreign;
    assert_int_equal(test_issue(&gcs, &auth, "gcs1", UB_ROLE_ADMIN, 1, T0, T0 + DAY), UB_OK);
    assert_int_equal(test_issue(&old, &auth, "rmax1ob1", UB_ROLE_VEHICLE, 2, T0 - 2 * DAY, T0 - DAY), UB_OK);
    assert_int_equal(test_issue(&uav, &auth, "rmax1ob1", UB_ROLE_VEHICLE, 3, T0, T0 + DAY), UB_OK);
    assert_int_equal(test_issue(&uav2, &auth, "fcs20", UB_ROLE_VEHICLE, 4, T0 - 2 * DAY, T0 - DAY), UB_OK);
    assert_int_equal(ub_certfile_put(certs, gcs.cert_bytes, UB_CERT_LEN, err, sizeof err), UB_OK);
    assert_int_equal(ub_certfile_put(certs, old.cert_bytes, UB_CERT_LEN, err, sizeof err), UB_OK);
    assert_int_equal(ub_certfile_put(certs, uav.cert_bytes, UB_CERT_LEN, err, sizeof err), UB_OK); /* replaces */
    assert_int_equal(ub_certfile_put(certs, uav2.cert_bytes, UB_CERT_LEN, err, sizeof err), UB_OK);
    struct stat st;
    assert_int_equal(stat(certs, &st), 0);
    assert_int_equal(st.st_size, UB_IDENTFILE_HEADER_LEN + 3 * UB_CERT_LEN);
    ub_ident_store_t *s = calloc(1, sizeof *s);
    store_with_authority(s);
    assert_int_equal(ub_certfile_load(certs, s, T0, err, sizeof err), 2); /* fcs20's expired one skipped */
    uint16_t roles;
    assert_int_equal(ub_ident_peer_roles(s, gcs.cert.entity, T0, &roles), UB_OK);
    assert_int_equal(roles, UB_ROLE_ADMIN);
    assert_int_equal(s->stats.peers_refused[UB_IDENT_EXPIRED], 1);
    /* another authority's certificate makes the file refused */
    assert_int_equal(test_issue(&foreign, &other, "intruder", UB_ROLE_ADMIN, 9, T0, T0 + DAY), UB_OK);
    assert_int_equal(ub_certfile_put(certs, foreign.cert_bytes, UB_CERT_LEN, err, sizeof err), UB_OK);
    store_with_authority(s);
    assert_int_equal(ub_certfile_load(certs, s, T0, err, sizeof err), UB_ERR_CONFIG);
    assert_one_line(err, certs, "certificate 4 is wrong_authority");
    free(s);
}

static int roles_of(void *user, const uint8_t id[UB_ENTITY_ID_LEN], uint16_t *roles) {
    return ub_ident_peer_roles(user, id, T0 + 1, roles);
}

/* "Administrators administer" on the certified role: not on a name, not for a revoked administrator. */
static void test_policy_by_role(void **state) {
    (void)state;
    test_entity_t gcs, uav, admin2;
    assert_int_equal(test_issue(&gcs, &auth, "gcs1", UB_ROLE_ADMIN, 1, T0, T0 + DAY), UB_OK);
    assert_int_equal(test_issue(&uav, &auth, "rmax1ob1", UB_ROLE_VEHICLE | UB_ROLE_RELAY, 2, T0, T0 + DAY), UB_OK);
    assert_int_equal(test_issue(&admin2, &auth, "gcs2", UB_ROLE_ADMIN, 3, T0, T0 + DAY), UB_OK);
    ub_ident_store_t *s = calloc(1, sizeof *s);
    store_with_authority(s);
    assert_int_equal(ub_ident_add_peer(s, gcs.cert_bytes, UB_CERT_LEN, T0, NULL), UB_OK);
    assert_int_equal(ub_ident_add_peer(s, uav.cert_bytes, UB_CERT_LEN, T0, NULL), UB_OK);
    assert_int_equal(ub_ident_add_peer(s, admin2.cert_bytes, UB_CERT_LEN, T0, NULL), UB_OK);
    ub_policy_t pol;
    ub_policy_init(&pol);
    /* group-key mode: by name */
    assert_int_equal(ub_policy_add_admin(&pol, uav.cert.entity), UB_OK);
    assert_true(ub_policy_is_admin(&pol, uav.cert.entity));
    assert_false(ub_policy_is_admin(&pol, gcs.cert.entity));
    /* by role: the vehicle listed by name is no administrator; a listed name narrows the certified ones */
    ub_policy_use_roles(&pol, roles_of, s);
    assert_false(ub_policy_is_admin(&pol, uav.cert.entity));
    assert_false(ub_policy_is_admin(&pol, gcs.cert.entity)); /* certified admin, but the list names others */
    ub_policy_init(&pol);
    ub_policy_use_roles(&pol, roles_of, s);
    assert_true(ub_policy_is_admin(&pol, gcs.cert.entity));
    assert_true(ub_policy_is_admin(&pol, admin2.cert.entity));
    assert_false(ub_policy_is_admin(&pol, uav.cert.entity));
    uint8_t unknown[12];
    assert_int_equal(ub_entity_id("gcs9", unknown), UB_OK);
    assert_false(ub_policy_is_admin(&pol, unknown));
    assert_int_equal(ub_policy_add_admin(&pol, gcs.cert.entity), UB_OK);
    assert_true(ub_policy_is_admin(&pol, gcs.cert.entity));
    assert_false(ub_policy_is_admin(&pol, admin2.cert.entity));
    /* revoked: no longer an administrator */
    uint8_t rec[UB_REVOCATION_LEN];
    assert_int_equal(test_revoke_record(rec, &auth, "gcs1", 1, T0 + 1), UB_OK);
    assert_int_equal(ub_ident_add_revocation(s, rec, sizeof rec, NULL), 0);
    assert_false(ub_policy_is_admin(&pol, gcs.cert.entity));
    free(s);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip),
        cmocka_unit_test(test_every_cert_byte_matters),
        cmocka_unit_test(test_every_revocation_byte_matters),
        cmocka_unit_test(test_decode_domain),
        cmocka_unit_test(test_validity_period),
        cmocka_unit_test(test_wrong_authority),
        cmocka_unit_test(test_revocation_in_the_store),
        cmocka_unit_test(test_self_identity),
        cmocka_unit_test(test_full_table),
        cmocka_unit_test_setup_teardown(test_identity_files, files_setup, files_teardown),
        cmocka_unit_test_setup_teardown(test_revocation_persists_across_restart, files_setup, files_teardown),
        cmocka_unit_test_setup_teardown(test_nodecfg_identity, files_setup, files_teardown),
        cmocka_unit_test_setup_teardown(test_certificates_file, files_setup, files_teardown),
        cmocka_unit_test(test_policy_by_role),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
