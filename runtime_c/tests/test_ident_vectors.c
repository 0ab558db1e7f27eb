/*
 * tests/vectors/identity.json (made by tests/vectors/make_identity_vectors.py with PyNaCl + hashlib,
 * no code shared with C) rebuilt by the C runtime from the same seeds, byte for byte: the
 * authority's key id and files, every certificate and identity file, every revocation record and the
 * revocations file. Then each certificate and record of the file is decoded, verified and re-encoded.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "codec/ub_json.h"
#include "ub/ub_ident.h"
#include "ub/ub_identfile.h"

#define VECTORS "tests/vectors/identity.json"

static char text[1 << 17];
static ub_json_doc_t doc;
static ub_json_value_t root;
static char tmpdir[64];

static int setup(void **state) {
    (void)state;
    FILE *f = fopen(VECTORS, "rb");
    if (f == NULL) return -1;
    size_t n = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    uint32_t line;
    char msg[128];
    if (ub_json_parse(&doc, text, n, &root, &line, msg, sizeof msg) != 0) return -1;
    (void)snprintf(tmpdir, sizeof tmpdir, "/tmp/ub_ident_vectors_XXXXXX");
    return mkdtemp(tmpdir) != NULL ? 0 : -1;
}

static int teardown(void **state) {
    (void)state;
    char cmd[128];
    (void)snprintf(cmd, sizeof cmd, "rm -rf %s", tmpdir);
    return system(cmd) == 0 ? 0 : -1;
}

static bool member(const ub_json_value_t *obj, const char *name, ub_json_value_t *out) {
    ub_json_iter_t it;
    ub_json_value_t k, v;
    char key[64];
    ub_json_iter_begin(&it, &doc, obj);
    while (ub_json_iter_next(&it, &k, &v)) {
        (void)ub_json_string(&doc, &k, key, sizeof key);
        if (strcmp(key, name) == 0) {
            *out = v;
            return true;
        }
    }
    return false;
}

static void str_of(const ub_json_value_t *obj, const char *name, char *out, size_t cap) {
    ub_json_value_t v;
    if (!member(obj, name, &v)) fail_msg("no member '%s'", name);
    if (v.kind == UB_JSON_STRING) (void)ub_json_string(&doc, &v, out, cap);
    else (void)snprintf(out, cap, "%.*s", (int)(v.end - v.start), doc.text + v.start);
}

static uint64_t u64_of(const ub_json_value_t *obj, const char *name) {
    char s[32];
    str_of(obj, name, s, sizeof s);
    return strtoull(s, NULL, 10);
}

/* Hex member `name` into out[cap]; returns its length. */
static size_t hex_of(const ub_json_value_t *obj, const char *name, uint8_t *out, size_t cap) {
    static char hex[4096];
    str_of(obj, name, hex, sizeof hex);
    size_t n = strlen(hex) / 2;
    assert_true(n <= cap);
    for (size_t i = 0; i < n; i++) {
        unsigned b;
        assert_int_equal(sscanf(hex + 2 * i, "%2x", &b), 1);
        out[i] = (uint8_t)b;
    }
    return n;
}

static size_t read_back(const char *path, uint8_t *out, size_t cap) {
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    size_t n = fread(out, 1, cap, f);
    fclose(f);
    return n;
}

static void authority_keys(uint8_t pk[32], uint8_t sk[64]) {
    ub_json_value_t a;
    assert_true(member(&root, "authority", &a));
    uint8_t seed[32];
    assert_int_equal(hex_of(&a, "seed", seed, sizeof seed), 32);
    assert_int_equal(ub_ident_sign_keypair(seed, pk, sk), UB_OK);
}

static void test_authority(void **state) {
    (void)state;
    ub_json_value_t a;
    assert_true(member(&root, "authority", &a));
    uint8_t pk[32], sk[64], want[64], kid[8], file[64];
    authority_keys(pk, sk);
    assert_int_equal(hex_of(&a, "public_key", want, sizeof want), 32);
    assert_memory_equal(pk, want, 32);
    assert_int_equal(ub_ident_authority_kid(pk, kid), UB_OK);
    assert_int_equal(hex_of(&a, "key_id", want, sizeof want), 8);
    assert_memory_equal(kid, want, 8);
    char path[128], err[UB_IDENTFILE_ERR_LEN];
    (void)snprintf(path, sizeof path, "%s/authority.pub", tmpdir);
    assert_int_equal(ub_authfile_write_public(path, pk, false, err, sizeof err), UB_OK);
    size_t n = hex_of(&a, "public_file", want, sizeof want);
    assert_int_equal(read_back(path, file, sizeof file), n);
    assert_memory_equal(file, want, n);
    (void)snprintf(path, sizeof path, "%s/authority.key", tmpdir);
    assert_int_equal(ub_authfile_write_secret(path, sk, err, sizeof err), UB_OK); /* the seed = sk's first half */
    n = hex_of(&a, "secret_file", want, sizeof want);
    assert_int_equal(read_back(path, file, sizeof file), n);
    assert_memory_equal(file, want, n);
    uint8_t sk2[64];
    assert_int_equal(ub_authfile_load_secret(path, sk2, err, sizeof err), UB_OK);
    assert_memory_equal(sk2, sk, 64);
}

static void test_certificates(void **state) {
    (void)state;
    uint8_t apk[32], ask[64];
    authority_keys(apk, ask);
    ub_json_value_t list, c;
    assert_true(member(&root, "certificates", &list));
    ub_json_iter_t it;
    ub_json_iter_begin(&it, &doc, &list);
    int count = 0;
    while (ub_json_iter_next(&it, NULL, &c)) {
        ub_cert_t cert;
        memset(&cert, 0, sizeof cert);
        char entity[16];
        uint8_t sign_seed[32], kx_seed[32], sign_sk[64], kx_sk[32], want[UB_IDENTFILE_LEN];
        str_of(&c, "entity", entity, sizeof entity);
        hex_of(&c, "sign_seed", sign_seed, 32);
        hex_of(&c, "kx_seed", kx_seed, 32);
        assert_int_equal(ub_entity_id(entity, cert.entity), UB_OK);
        cert.version = 1;
        cert.roles = (uint16_t)u64_of(&c, "roles");
        cert.serial = u64_of(&c, "serial");
        cert.not_before = u64_of(&c, "not_before");
        cert.not_after = u64_of(&c, "not_after");
        assert_int_equal(ub_ident_sign_keypair(sign_seed, cert.sign_pk, sign_sk), UB_OK);
        assert_int_equal(ub_ident_kx_keypair(kx_seed, cert.kx_pk, kx_sk), UB_OK);
        assert_int_equal(ub_cert_sign(&cert, ask), UB_OK);
        uint8_t bytes[UB_CERT_LEN];
        assert_int_equal(ub_cert_encode(&cert, bytes), UB_OK);
        assert_int_equal(hex_of(&c, "bytes", want, sizeof want), UB_CERT_LEN);
        if (memcmp(bytes, want, UB_CERT_LEN) != 0) fail_msg("certificate of %s differs", entity);
        /* the file's bytes decode, verify and re-encode */
        ub_cert_t d;
        assert_int_equal(ub_cert_decode(&d, want, UB_CERT_LEN), UB_OK);
        assert_int_equal(ub_cert_verify(&d, apk), UB_IDENT_VALID);
        assert_int_equal(ub_cert_encode(&d, bytes), UB_OK);
        assert_memory_equal(bytes, want, UB_CERT_LEN);
        /* the identity file */
        char path[128], err[UB_IDENTFILE_ERR_LEN];
        (void)snprintf(path, sizeof path, "%s/%s.id", tmpdir, entity);
        assert_int_equal(ub_identfile_write(path, &cert, sign_seed, kx_sk, false, err, sizeof err), UB_OK);
        uint8_t file[UB_IDENTFILE_LEN + 1];
        size_t n = hex_of(&c, "identity_file", want, sizeof want);
        assert_int_equal(read_back(path, file, sizeof file), n);
        assert_memory_equal(file, want, n);
        ub_cert_t loaded;
        uint8_t lsk[64], lkx[32];
        assert_int_equal(ub_identfile_load(path, &loaded, lsk, lkx, err, sizeof err), UB_OK);
        assert_memory_equal(lsk, sign_sk, 64);
        assert_memory_equal(lkx, kx_sk, 32);
        count++;
    }
    assert_int_equal(count, 5);
}

static void test_revocations(void **state) {
    (void)state;
    uint8_t apk[32], ask[64];
    authority_keys(apk, ask);
    ub_ident_store_t *s = calloc(1, sizeof *s);
    ub_ident_store_init(s);
    assert_int_equal(ub_ident_set_authority(s, apk), UB_OK);
    ub_json_value_t list, r;
    assert_true(member(&root, "revocations", &list));
    ub_json_iter_t it;
    ub_json_iter_begin(&it, &doc, &list);
    int count = 0;
    while (ub_json_iter_next(&it, NULL, &r)) {
        ub_revocation_t rev;
        memset(&rev, 0, sizeof rev);
        char entity[16];
        str_of(&r, "entity", entity, sizeof entity);
        assert_int_equal(ub_entity_id(entity, rev.entity), UB_OK);
        rev.serial = u64_of(&r, "serial");
        rev.time_s = u64_of(&r, "time");
        assert_int_equal(ub_revocation_sign(&rev, ask), UB_OK);
        uint8_t bytes[UB_REVOCATION_LEN], want[UB_REVOCATION_LEN];
        assert_int_equal(ub_revocation_encode(&rev, bytes), UB_OK);
        assert_int_equal(hex_of(&r, "bytes", want, sizeof want), UB_REVOCATION_LEN);
        if (memcmp(bytes, want, UB_REVOCATION_LEN) != 0) fail_msg("revocation of %s differs", entity);
        assert_int_equal(ub_ident_add_revocation(s, want, sizeof want, NULL), count);
        count++;
    }
    assert_int_equal(count, 2);
    char path[128], err[UB_IDENTFILE_ERR_LEN];
    (void)snprintf(path, sizeof path, "%s/revocations.ubr", tmpdir);
    assert_int_equal(ub_revfile_save(path, s, err, sizeof err), UB_OK);
    static uint8_t want[UB_REVFILE_MAX], file[UB_REVFILE_MAX];
    size_t n = hex_of(&root, "revocations_file", want, sizeof want);
    assert_int_equal(read_back(path, file, sizeof file), n);
    assert_memory_equal(file, want, n);
    free(s);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_authority),
        cmocka_unit_test(test_certificates),
        cmocka_unit_test(test_revocations),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
