/*
 * Identity files (ub_identfile.h) that are wrong on disk (issue #29 item 6): missing, a directory, too
 * short, another magic, another format version, a length that is not the format's, a certificate that
 * does not decode, secret keys that are not the certificate's, a secret file others may read, a
 * revocations or certificates body that is not whole records, files that exist already; and NULL
 * arguments. Each refusal is one line naming the file. test_ident.c covers the files that are right.
 */
#define _XOPEN_SOURCE 700 /* mkdtemp */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "ub/ub_identfile.h"

#define NOW 1800000000ull

static char g_dir[64];
static char g_err[UB_IDENTFILE_ERR_LEN];
static uint8_t g_auth_pk[UB_IDENT_SIGN_PK_LEN], g_auth_sk[UB_IDENT_SIGN_SK_LEN];
static ub_ident_store_t g_store;

static const char *path_of(const char *name) {
    static char p[4][128];
    static int k;
    k = (k + 1) % 4;
    snprintf(p[k], sizeof p[k], "%s/%s", g_dir, name);
    return p[k];
}

static void write_raw(const char *path, const uint8_t *data, size_t len, mode_t mode) {
    (void)unlink(path);
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, mode);
    assert_true(fd >= 0);
    assert_int_equal(write(fd, data, len), (ssize_t)len);
    assert_int_equal(fchmod(fd, mode), 0);
    close(fd);
}

static void header(uint8_t *b, const char *magic, uint8_t version) {
    memcpy(b, magic, 4);
    b[4] = version;
    b[5] = b[6] = b[7] = 0;
}

/* The error names the file and is one line. */
static void one_line_about(const char *path) {
    assert_non_null(strstr(g_err, path));
    assert_null(strchr(g_err, '\n'));
}

static void make_cert(ub_cert_t *c, uint8_t seed[UB_IDENT_SEED_LEN], uint8_t kx_sk[UB_IDENT_KX_SK_LEN]) {
    uint8_t sk[UB_IDENT_SIGN_SK_LEN], kx_pk[UB_IDENT_KX_PK_LEN], kx_seed[UB_IDENT_SEED_LEN];
    memset(c, 0, sizeof *c);
    c->version = UB_IDENT_VERSION;
    c->roles = UB_ROLE_VEHICLE;
    c->serial = 3;
    memcpy(c->entity, "veh7", 4);
    memset(seed, 0x41, UB_IDENT_SEED_LEN);
    assert_int_equal(ub_ident_sign_keypair(seed, c->sign_pk, sk), UB_OK);
    memset(kx_seed, 0x42, sizeof kx_seed);
    assert_int_equal(ub_ident_kx_keypair(kx_seed, kx_pk, kx_sk), UB_OK);
    memcpy(c->kx_pk, kx_pk, sizeof kx_pk);
    c->not_before = NOW - 10;
    c->not_after = NOW + 10;
    assert_int_equal(ub_cert_sign(c, g_auth_sk), UB_OK);
}

static int setup(void **state) {
    (void)state;
    snprintf(g_dir, sizeof g_dir, "/tmp/ub_identfile_XXXXXX");
    assert_non_null(mkdtemp(g_dir));
    uint8_t seed[UB_IDENT_SEED_LEN];
    memset(seed, 0x31, sizeof seed);
    assert_int_equal(ub_ident_sign_keypair(seed, g_auth_pk, g_auth_sk), UB_OK);
    return 0;
}

static int teardown(void **state) {
    (void)state;
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", g_dir);
    return system(cmd) == 0 ? 0 : -1;
}

static void test_identity_file_refusals(void **state) {
    (void)state;
    ub_cert_t c, got;
    uint8_t seed[UB_IDENT_SEED_LEN], kx_sk[UB_IDENT_KX_SK_LEN], sk[UB_IDENT_SIGN_SK_LEN], kx[UB_IDENT_KX_SK_LEN];
    make_cert(&c, seed, kx_sk);
    const char *id = path_of("veh7.id");
    assert_int_equal(ub_identfile_write(id, &c, seed, kx_sk, false, g_err, sizeof g_err), UB_OK);
    assert_int_equal(ub_identfile_load(id, &got, sk, kx, g_err, sizeof g_err), UB_OK);
    assert_memory_equal(got.sign_pk, c.sign_pk, sizeof c.sign_pk);
    assert_int_equal(ub_identfile_write(id, &c, seed, kx_sk, false, g_err, sizeof g_err), UB_ERR_EXISTS);
    assert_int_equal(ub_identfile_write(id, &c, seed, kx_sk, true, g_err, sizeof g_err), UB_OK); /* replaced */
    assert_int_equal(ub_identfile_write(NULL, &c, seed, kx_sk, false, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_identfile_write(id, NULL, seed, kx_sk, false, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_identfile_write(id, &c, NULL, kx_sk, false, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_identfile_write(id, &c, seed, NULL, false, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_identfile_load(NULL, &got, sk, kx, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_identfile_load(id, NULL, sk, kx, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_identfile_load(id, &got, NULL, kx, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_identfile_load(id, &got, sk, NULL, g_err, sizeof g_err), UB_ERR_INVAL);
    /* A path too long for its temporary twin (replace: written beside it, then renamed over it). */
    char longp[5000];
    memset(longp, 'a', sizeof longp - 1);
    longp[0] = '/';
    longp[sizeof longp - 1] = '\0';
    assert_int_equal(ub_identfile_write(longp, &c, seed, kx_sk, true, g_err, sizeof g_err), UB_ERR_IO);
    assert_true(strlen(g_err) > 0);
    /* A path in a directory that does not exist: cannot be written. */
    assert_true(ub_identfile_write(path_of("no/such/dir.id"), &c, seed, kx_sk, false, g_err, sizeof g_err) < 0);

    uint8_t good[UB_IDENTFILE_LEN];
    int fd = open(id, O_RDONLY);
    assert_true(fd >= 0);
    assert_int_equal(read(fd, good, sizeof good), (ssize_t)sizeof good);
    close(fd);
    uint8_t b[UB_IDENTFILE_LEN + 1];
    const char *bad = path_of("bad.id");
    assert_int_equal(ub_identfile_load(path_of("missing.id"), &got, sk, kx, g_err, sizeof g_err), UB_ERR_IO);
    one_line_about("missing.id");
    assert_int_equal(ub_identfile_load(g_dir, &got, sk, kx, g_err, sizeof g_err), UB_ERR_CONFIG); /* a directory */
    write_raw(bad, good, 4, 0600); /* shorter than the header */
    assert_int_equal(ub_identfile_load(bad, &got, sk, kx, g_err, sizeof g_err), UB_ERR_CONFIG);
    one_line_about("bad.id");
    memcpy(b, good, sizeof good);
    header(b, "UBXX", 1);
    write_raw(bad, b, sizeof good, 0600);
    assert_int_equal(ub_identfile_load(bad, &got, sk, kx, g_err, sizeof g_err), UB_ERR_CONFIG);
    assert_non_null(strstr(g_err, "not a uavbus"));
    header(b, "UBID", 2);
    write_raw(bad, b, sizeof good, 0600);
    assert_int_equal(ub_identfile_load(bad, &got, sk, kx, g_err, sizeof g_err), UB_ERR_CONFIG);
    assert_non_null(strstr(g_err, "format 2"));
    memcpy(b, good, sizeof good);
    b[7] = 1; /* a reserved header byte */
    write_raw(bad, b, sizeof good, 0600);
    assert_int_equal(ub_identfile_load(bad, &got, sk, kx, g_err, sizeof g_err), UB_ERR_CONFIG);
    memcpy(b, good, sizeof good);
    write_raw(bad, b, sizeof good + 1, 0600); /* one byte too many */
    assert_int_equal(ub_identfile_load(bad, &got, sk, kx, g_err, sizeof g_err), UB_ERR_CONFIG);
    memcpy(b, good, sizeof good);
    b[UB_IDENTFILE_HEADER_LEN] = 9; /* certificate version 9: does not decode */
    write_raw(bad, b, sizeof good, 0600);
    assert_int_equal(ub_identfile_load(bad, &got, sk, kx, g_err, sizeof g_err), UB_ERR_CONFIG);
    memcpy(b, good, sizeof good);
    b[UB_IDENTFILE_LEN - 1] ^= 0x55; /* the X25519 secret is not the certificate's */
    write_raw(bad, b, sizeof good, 0600);
    assert_int_equal(ub_identfile_load(bad, &got, sk, kx, g_err, sizeof g_err), UB_ERR_CONFIG);
    one_line_about("bad.id");
    write_raw(bad, good, sizeof good, 0644); /* others may read the secrets */
    assert_int_equal(ub_identfile_load(bad, &got, sk, kx, g_err, sizeof g_err), UB_ERR_CONFIG);
    one_line_about("bad.id");
}

static void test_authority_files(void **state) {
    (void)state;
    uint8_t seed[UB_IDENT_SEED_LEN], sk[UB_IDENT_SIGN_SK_LEN], pk[UB_IDENT_SIGN_PK_LEN];
    memset(seed, 0x31, sizeof seed);
    const char *sec = path_of("auth.key"), *pub = path_of("auth.pub");
    assert_int_equal(ub_authfile_write_secret(sec, seed, g_err, sizeof g_err), UB_OK);
    assert_int_equal(ub_authfile_write_secret(sec, seed, g_err, sizeof g_err), UB_ERR_EXISTS); /* never over one */
    assert_int_equal(ub_authfile_load_secret(sec, sk, g_err, sizeof g_err), UB_OK);
    assert_memory_equal(sk, g_auth_sk, sizeof sk);
    assert_int_equal(ub_authfile_write_public(pub, g_auth_pk, false, g_err, sizeof g_err), UB_OK);
    assert_int_equal(ub_authfile_write_public(pub, g_auth_pk, false, g_err, sizeof g_err), UB_ERR_EXISTS);
    assert_int_equal(ub_authfile_write_public(pub, g_auth_pk, true, g_err, sizeof g_err), UB_OK);
    assert_int_equal(ub_authfile_load_public(pub, pk, g_err, sizeof g_err), UB_OK);
    assert_memory_equal(pk, g_auth_pk, sizeof pk);
    assert_int_equal(ub_authfile_write_secret(NULL, seed, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_authfile_write_secret(sec, NULL, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_authfile_write_public(NULL, pk, false, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_authfile_write_public(pub, NULL, false, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_authfile_load_secret(NULL, sk, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_authfile_load_secret(sec, NULL, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_authfile_load_public(NULL, pk, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_authfile_load_public(pub, NULL, g_err, sizeof g_err), UB_ERR_INVAL);
    uint8_t b[UB_AUTHFILE_LEN + 4] = {0};
    const char *bad = path_of("bad.key");
    header(b, "UBAK", 1);
    write_raw(bad, b, UB_AUTHFILE_LEN + 4, 0600); /* too long */
    assert_int_equal(ub_authfile_load_secret(bad, sk, g_err, sizeof g_err), UB_ERR_CONFIG);
    one_line_about("bad.key");
    header(b, "UBAP", 1);
    write_raw(bad, b, UB_AUTHFILE_LEN - 1, 0644); /* too short */
    assert_int_equal(ub_authfile_load_public(bad, pk, g_err, sizeof g_err), UB_ERR_CONFIG);
    header(b, "UBAK", 1);
    write_raw(bad, b, UB_AUTHFILE_LEN, 0600); /* the wrong magic for a public file */
    assert_int_equal(ub_authfile_load_public(bad, pk, g_err, sizeof g_err), UB_ERR_CONFIG);
    write_raw(bad, b, UB_AUTHFILE_LEN, 0640); /* a secret group may read */
    assert_int_equal(ub_authfile_load_secret(bad, sk, g_err, sizeof g_err), UB_ERR_CONFIG);
}

static void test_revocation_and_certificate_files(void **state) {
    (void)state;
    ub_ident_store_init(&g_store);
    assert_int_equal(ub_ident_set_authority(&g_store, g_auth_pk), UB_OK);
    const char *rv = path_of("revoked.bin"), *cs = path_of("certs.bin");
    /* Missing: an empty list, not an error. */
    assert_int_equal(ub_revfile_load(rv, &g_store, g_err, sizeof g_err), 0);
    assert_int_equal(ub_revfile_load(NULL, &g_store, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_revfile_load(rv, NULL, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_revfile_save(NULL, &g_store, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_revfile_save(rv, NULL, g_err, sizeof g_err), UB_ERR_INVAL);
    uint8_t rec[UB_REVOCATION_LEN];
    assert_int_equal(ub_revfile_read(NULL, rec, 1, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_revfile_read(rv, NULL, 1, g_err, sizeof g_err), UB_ERR_INVAL);
    ub_revocation_t r = {.serial = 4, .time_s = NOW};
    memcpy(r.entity, "veh9", 4);
    assert_int_equal(ub_revocation_sign(&r, g_auth_sk), UB_OK);
    assert_int_equal(ub_revocation_encode(&r, rec), UB_OK);
    assert_true(ub_ident_add_revocation(&g_store, rec, sizeof rec, NULL) >= 0);
    assert_int_equal(ub_revfile_save(rv, &g_store, g_err, sizeof g_err), UB_OK);
    uint8_t out[2 * UB_REVOCATION_LEN];
    assert_int_equal(ub_revfile_read(rv, out, 2, g_err, sizeof g_err), 1);
    assert_memory_equal(out, rec, sizeof rec);
    assert_int_equal(ub_revfile_read(rv, out, 0, g_err, sizeof g_err), 0); /* room for none */
    assert_int_equal(ub_revfile_read(rv, NULL, 0, g_err, sizeof g_err), 0);  /* nowhere to put them, none asked */
    uint8_t b[UB_IDENTFILE_HEADER_LEN + UB_REVOCATION_LEN + 3];
    header(b, "UBRV", 1);
    memcpy(b + UB_IDENTFILE_HEADER_LEN, rec, sizeof rec);
    const char *bad = path_of("bad.rv");
    write_raw(bad, b, sizeof b, 0644); /* not whole records */
    assert_int_equal(ub_revfile_read(bad, out, 2, g_err, sizeof g_err), UB_ERR_CONFIG);
    one_line_about("bad.rv");
    assert_int_equal(ub_revfile_load(bad, &g_store, g_err, sizeof g_err), UB_ERR_CONFIG);
    b[UB_IDENTFILE_HEADER_LEN + 20] ^= 1; /* a record whose signature fails */
    write_raw(bad, b, UB_IDENTFILE_HEADER_LEN + UB_REVOCATION_LEN, 0644);
    assert_true(ub_revfile_load(bad, &g_store, g_err, sizeof g_err) < 0);
    one_line_about("bad.rv");

    ub_cert_t c;
    uint8_t seed[UB_IDENT_SEED_LEN], kx_sk[UB_IDENT_KX_SK_LEN], cert[UB_CERT_LEN];
    make_cert(&c, seed, kx_sk);
    assert_int_equal(ub_cert_encode(&c, cert), UB_OK);
    assert_int_equal(ub_certfile_put(cs, cert, sizeof cert, g_err, sizeof g_err), UB_OK);
    assert_int_equal(ub_certfile_put(cs, cert, sizeof cert, g_err, sizeof g_err), UB_OK); /* the same entity: in place */
    assert_int_equal(ub_certfile_put(NULL, cert, sizeof cert, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_certfile_put(cs, NULL, sizeof cert, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_true(ub_certfile_put(cs, cert, sizeof cert - 1, g_err, sizeof g_err) < 0); /* does not decode */
    assert_int_equal(ub_certfile_load(cs, &g_store, NOW, g_err, sizeof g_err), 1);
    assert_int_equal(ub_certfile_load(NULL, &g_store, NOW, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_certfile_load(cs, NULL, NOW, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_certfile_load(cs, &g_store, NOW + 100, g_err, sizeof g_err), 0); /* expired: skipped */
    uint8_t cb[UB_IDENTFILE_HEADER_LEN + UB_CERT_LEN + 1];
    header(cb, "UBCS", 1);
    memcpy(cb + UB_IDENTFILE_HEADER_LEN, cert, sizeof cert);
    const char *badc = path_of("bad.cs");
    write_raw(badc, cb, sizeof cb, 0644);
    assert_int_equal(ub_certfile_load(badc, &g_store, NOW, g_err, sizeof g_err), UB_ERR_CONFIG);
    one_line_about("bad.cs");
    assert_true(ub_certfile_put(badc, cert, sizeof cert, g_err, sizeof g_err) < 0); /* cannot add to a broken file */
}

/* The one-call set-ups: NULLs, an identity expired or not yet valid at start (refused with the reason), a
 * revocations file with only its header (no records), then the set-up that works. */
static void test_store_setup(void **state) {
    (void)state;
    ub_cert_t c;
    uint8_t seed[UB_IDENT_SEED_LEN], kx_sk[UB_IDENT_KX_SK_LEN];
    make_cert(&c, seed, kx_sk);
    const char *id = path_of("setup.id"), *pub = path_of("setup.pub"), *rv = path_of("setup.rv");
    assert_int_equal(ub_identfile_write(id, &c, seed, kx_sk, true, g_err, sizeof g_err), UB_OK);
    assert_int_equal(ub_authfile_write_public(pub, g_auth_pk, true, g_err, sizeof g_err), UB_OK);
    uint8_t h[UB_IDENTFILE_HEADER_LEN];
    header(h, "UBRV", 1);
    write_raw(rv, h, sizeof h, 0644);
    ub_ident_store_init(&g_store);
    assert_int_equal(ub_identfile_load_store(NULL, id, pub, rv, NOW, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_identfile_load_store(&g_store, id, NULL, rv, NOW, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_identfile_load_self(NULL, id, rv, NOW, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_identfile_load_self(&g_store, NULL, rv, NOW, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_identfile_load_store(&g_store, id, pub, rv, NOW + 100, g_err, sizeof g_err), UB_ERR_CONFIG);
    one_line_about("setup.id");
    assert_non_null(strstr(g_err, "expired"));
    assert_int_equal(ub_identfile_load_store(&g_store, id, pub, rv, NOW - 100, g_err, sizeof g_err), UB_ERR_CONFIG);
    assert_int_equal(ub_identfile_load_store(&g_store, id, path_of("none.pub"), rv, NOW, g_err, sizeof g_err),
                     UB_ERR_IO); /* no authority file */
    assert_int_equal(ub_identfile_load_store(&g_store, id, pub, rv, NOW, g_err, sizeof g_err), UB_OK);
    assert_int_equal(ub_ident_self_count(&g_store), 1);
    assert_int_equal(ub_ident_revocation_count(&g_store), 0);
}

/* A certificates file at its bounds: UB_CERTFILE_MAX_CERTS entities, then another refused FULL (one line
 * naming the file) while an entity already held is still replaced in place; loaded into a store with room
 * for UB_IDENT_MAX_PEERS, refused FULL; a certificate not valid yet is skipped, not an error. And a header
 * whose reserved bytes are set is another format. */
static void test_certificate_file_bounds_and_reserved_header_bytes(void **state) {
    (void)state;
    const char *cs = path_of("many.cs");
    (void)unlink(cs);
    ub_cert_t c;
    uint8_t seed[UB_IDENT_SEED_LEN], kx_sk[UB_IDENT_KX_SK_LEN], cert[UB_CERT_LEN];
    make_cert(&c, seed, kx_sk);
    for (unsigned i = 0; i <= UB_CERTFILE_MAX_CERTS; i++) {
        memset(c.entity, 0, UB_ENTITY_ID_LEN);
        snprintf((char *)c.entity, UB_ENTITY_ID_LEN, "v%u", i);
        c.serial = 100u + i;
        assert_int_equal(ub_cert_sign(&c, g_auth_sk), UB_OK);
        assert_int_equal(ub_cert_encode(&c, cert), UB_OK);
        int rc = ub_certfile_put(cs, cert, sizeof cert, g_err, sizeof g_err);
        if (i < UB_CERTFILE_MAX_CERTS) {
            assert_int_equal(rc, UB_OK);
        } else {
            assert_int_equal(rc, UB_ERR_FULL);
            one_line_about("many.cs");
        }
    }
    memset(c.entity, 0, UB_ENTITY_ID_LEN);
    memcpy(c.entity, "v7", 2);
    c.serial = 999;
    assert_int_equal(ub_cert_sign(&c, g_auth_sk), UB_OK);
    assert_int_equal(ub_cert_encode(&c, cert), UB_OK);
    assert_int_equal(ub_certfile_put(cs, cert, sizeof cert, g_err, sizeof g_err), UB_OK); /* held: replaced */
    ub_ident_store_init(&g_store);
    assert_int_equal(ub_ident_set_authority(&g_store, g_auth_pk), UB_OK);
    assert_int_equal(ub_certfile_load(cs, &g_store, NOW, g_err, sizeof g_err), UB_ERR_FULL);
    one_line_about("many.cs");
    /* one certificate, not valid before NOW - 10: skipped at NOW - 100 */
    const char *one = path_of("one.cs");
    (void)unlink(one);
    assert_int_equal(ub_certfile_put(one, cert, sizeof cert, g_err, sizeof g_err), UB_OK);
    ub_ident_store_init(&g_store);
    assert_int_equal(ub_ident_set_authority(&g_store, g_auth_pk), UB_OK);
    assert_int_equal(ub_certfile_load(one, &g_store, NOW - 100, g_err, sizeof g_err), 0);
    assert_int_equal(ub_certfile_load(one, &g_store, NOW, g_err, sizeof g_err), 1);
    /* reserved header bytes 5 and 6: refused as another format, naming the file */
    uint8_t b[UB_IDENTFILE_HEADER_LEN + UB_CERT_LEN];
    for (int k = 5; k <= 6; k++) {
        header(b, "UBCS", 1);
        b[k] = 1;
        memcpy(b + UB_IDENTFILE_HEADER_LEN, cert, sizeof cert);
        write_raw(one, b, sizeof b, 0644);
        assert_int_equal(ub_certfile_load(one, &g_store, NOW, g_err, sizeof g_err), UB_ERR_CONFIG);
        one_line_about("one.cs");
        assert_non_null(strstr(g_err, "format"));
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_identity_file_refusals),
        cmocka_unit_test(test_authority_files),
        cmocka_unit_test(test_revocation_and_certificate_files),
        cmocka_unit_test(test_store_setup),
        cmocka_unit_test(test_certificate_file_bounds_and_reserved_header_bytes),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
