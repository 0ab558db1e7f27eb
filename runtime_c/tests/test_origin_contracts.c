/*
 * ub_origin.h called the wrong way on purpose (issue #29 item 6): NULL arguments of the pure functions and
 * of the context, equal IDs and a small-order peer key refused by the pair derivation, a payload above the
 * limit refused by the tag, identities added twice and past UB_ORIGIN_LOCALS, and a context used before
 * ub_origin_init(). test_origin.c covers sealing and opening on nodes.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "ub/ub_frame.h"
#include "ub/ub_node.h"
#include "ub/ub_origin.h"

static const ub_type_desc_t k_types[] = {{"struct eight", 0x0BADCAFEu, 8, 8, NULL, NULL}};
static const ub_instance_desc_t k_insts[] = {{{'a', 'l', 'p', 'h', 'a'}, "alpha", &k_types[0]}};
static const ub_catalogue_t k_cat = {.name = "origin", .abi_version = UB_CATALOGUE_ABI_VERSION, .types = k_types,
                                     .n_types = 1, .instances = k_insts, .n_instances = 1, .max_packed_size = 8};
static ub_origin_t g_o;
static ub_node_t g_node;

static int no_lookup(void *user, const uint8_t id[UB_ENTITY_ID_LEN], uint64_t now_s, uint8_t pk[UB_ORIGIN_PK_LEN]) {
    (void)user, (void)id, (void)now_s, (void)pk;
    return UB_ERR_NOTFOUND;
}

static void test_pure_function_contracts(void **state) {
    (void)state;
    uint8_t a_id[UB_ENTITY_ID_LEN] = "alice", b_id[UB_ENTITY_ID_LEN] = "bob";
    uint8_t a_sk[UB_ORIGIN_SK_LEN], b_sk[UB_ORIGIN_SK_LEN], a_pk[UB_ORIGIN_PK_LEN], b_pk[UB_ORIGIN_PK_LEN];
    memset(a_sk, 0x11, sizeof a_sk);
    memset(b_sk, 0x22, sizeof b_sk);
    assert_int_equal(ub_origin_public_key(a_sk, a_pk), UB_OK);
    assert_int_equal(ub_origin_public_key(b_sk, b_pk), UB_OK);
    assert_int_equal(ub_origin_public_key(NULL, a_pk), UB_ERR_INVAL);
    assert_int_equal(ub_origin_public_key(a_sk, NULL), UB_ERR_INVAL);

    uint8_t tx[UB_ORIGIN_KEY_LEN], rx[UB_ORIGIN_KEY_LEN], tx2[UB_ORIGIN_KEY_LEN], rx2[UB_ORIGIN_KEY_LEN];
    assert_int_equal(ub_origin_pair_keys(a_id, a_sk, b_id, b_pk, tx, rx), UB_OK);
    assert_int_equal(ub_origin_pair_keys(b_id, b_sk, a_id, a_pk, tx2, rx2), UB_OK);
    assert_memory_equal(tx, rx2, sizeof tx); /* alice -> bob is what bob receives with */
    assert_memory_equal(rx, tx2, sizeof rx);
    assert_memory_not_equal(tx, rx, sizeof tx); /* directional */
    assert_int_equal(ub_origin_pair_keys(NULL, a_sk, b_id, b_pk, tx, rx), UB_ERR_INVAL);
    assert_int_equal(ub_origin_pair_keys(a_id, NULL, b_id, b_pk, tx, rx), UB_ERR_INVAL);
    assert_int_equal(ub_origin_pair_keys(a_id, a_sk, NULL, b_pk, tx, rx), UB_ERR_INVAL);
    assert_int_equal(ub_origin_pair_keys(a_id, a_sk, b_id, NULL, tx, rx), UB_ERR_INVAL);
    assert_int_equal(ub_origin_pair_keys(a_id, a_sk, b_id, b_pk, NULL, rx), UB_ERR_INVAL);
    assert_int_equal(ub_origin_pair_keys(a_id, a_sk, b_id, b_pk, tx, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_origin_pair_keys(a_id, a_sk, a_id, b_pk, tx, rx), UB_ERR_INVAL); /* equal IDs */
    uint8_t zero_pk[UB_ORIGIN_PK_LEN] = {0};                                            /* small order */
    assert_true(ub_origin_pair_keys(a_id, a_sk, b_id, zero_pk, tx, rx) < 0);

    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    h.payload_size = 4;
    h.origin_hop0 = 5;
    uint8_t payload[4] = {1, 2, 3, 4}, tag[UB_FRAME_ORIGIN_TAG_LEN], tag2[UB_FRAME_ORIGIN_TAG_LEN];
    assert_int_equal(ub_origin_tag(tx, &h, payload, tag), UB_OK);
    payload[0] ^= 1;
    assert_int_equal(ub_origin_tag(tx, &h, payload, tag2), UB_OK);
    assert_memory_not_equal(tag, tag2, sizeof tag);
    assert_int_equal(ub_origin_tag(NULL, &h, payload, tag), UB_ERR_INVAL);
    assert_int_equal(ub_origin_tag(tx, NULL, payload, tag), UB_ERR_INVAL);
    assert_int_equal(ub_origin_tag(tx, &h, payload, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_origin_tag(tx, &h, NULL, tag), UB_ERR_INVAL);
    h.payload_size = 0;
    assert_int_equal(ub_origin_tag(tx, &h, NULL, tag), UB_OK); /* nothing to read */
    h.payload_size = UB_MAX_PAYLOAD + 1;
    assert_int_equal(ub_origin_tag(tx, &h, payload, tag), UB_ERR_RANGE);
}

static void test_context_contracts(void **state) {
    (void)state;
    uint8_t id[UB_ENTITY_ID_LEN] = "alice", sk[UB_ORIGIN_SK_LEN];
    memset(sk, 0x33, sizeof sk);
    memset(&g_o, 0, sizeof g_o);
    /* before ub_origin_init(): nothing is taken */
    assert_int_equal(ub_origin_add_identity(&g_o, id, sk), UB_ERR_INVAL);
    assert_int_equal(ub_node_init(&g_node, &k_cat, NULL), UB_OK);
    assert_int_equal(ub_origin_attach(&g_o, &g_node), UB_ERR_INVAL);
    ub_origin_options_t opt = {.lookup = no_lookup};
    assert_int_equal(ub_origin_init(NULL, &opt), UB_ERR_INVAL);
    assert_int_equal(ub_origin_init(&g_o, NULL), UB_ERR_INVAL);
    ub_origin_options_t none = {0};
    uint8_t peer[UB_ENTITY_ID_LEN] = {'p'}, k16[UB_ORIGIN_KEY_LEN] = {1};
    assert_int_equal(ub_origin_add_pair(&g_o, id, peer, k16, k16), UB_ERR_INVAL); /* not initialised */
    assert_int_equal(ub_origin_init(&g_o, &none), UB_OK); /* no lookup: provisioned pairs only */
    assert_int_equal(ub_origin_add_pair(NULL, id, peer, k16, k16), UB_ERR_INVAL);
    assert_int_equal(ub_origin_add_pair(&g_o, NULL, peer, k16, k16), UB_ERR_INVAL);
    assert_int_equal(ub_origin_add_pair(&g_o, id, NULL, k16, k16), UB_ERR_INVAL);
    assert_int_equal(ub_origin_add_pair(&g_o, id, peer, NULL, k16), UB_ERR_INVAL);
    assert_int_equal(ub_origin_add_pair(&g_o, id, peer, k16, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_origin_add_pair(&g_o, id, id, k16, k16), UB_ERR_INVAL);
    assert_int_equal(ub_origin_add_pair(&g_o, id, peer, k16, k16), UB_OK);
    assert_int_equal(ub_origin_cached(&g_o), 1);
    assert_int_equal(ub_origin_init(&g_o, &opt), UB_OK);
    assert_int_equal(ub_origin_add_identity(NULL, id, sk), UB_ERR_INVAL);
    assert_int_equal(ub_origin_add_identity(&g_o, NULL, sk), UB_ERR_INVAL);
    assert_int_equal(ub_origin_add_identity(&g_o, id, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_origin_add_identity(&g_o, id, sk), UB_OK);
    assert_int_equal(ub_origin_add_identity(&g_o, id, sk), UB_ERR_EXISTS);
    int full = UB_OK;
    for (int i = 1; i <= UB_ORIGIN_LOCALS && full == UB_OK; i++) {
        uint8_t other[UB_ENTITY_ID_LEN] = "local";
        other[6] = (uint8_t)('0' + i);
        full = ub_origin_add_identity(&g_o, other, sk);
    }
    assert_int_equal(full, UB_ERR_FULL);
    assert_int_equal(ub_origin_attach(NULL, &g_node), UB_ERR_INVAL);
    assert_int_equal(ub_origin_attach(&g_o, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_origin_attach(&g_o, &g_node), UB_OK);
    assert_int_equal(ub_origin_detach(NULL, &g_node), UB_ERR_INVAL);
    assert_int_equal(ub_origin_detach(&g_o, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_origin_detach(&g_o, &g_node), UB_OK);
    assert_int_equal(ub_origin_forget(NULL, id), 0);
    assert_int_equal(ub_origin_forget(&g_o, NULL), 0);
    assert_int_equal(ub_origin_forget(&g_o, id), 0);
    assert_int_equal(ub_origin_cached(NULL), 0);
    assert_int_equal(ub_origin_cached(&g_o), 0);
    assert_null(ub_origin_stats(NULL));
    assert_non_null(ub_origin_stats(&g_o));
}

/* A provisioning table (docs/security.md, "Origin authentication"): header, n entries, CRC-32C. */
static size_t pairs_table(uint8_t *t, size_t n, const char *self, bool group) {
    size_t len = UB_ORIGIN_PAIRS_LEN(n);
    memset(t, 0, len);
    memcpy(t, UB_ORIGIN_PAIRS_MAGIC, 4);
    t[4] = 1;
    t[5] = (uint8_t)n;
    memcpy(t + 8, self, strlen(self));
    t[20] = 7;
    t[21] = group ? 1 : 0;
    if (group) memset(t + 24, 0x6B, 32);
    for (size_t i = 0; i < n; i++) {
        uint8_t *e = t + UB_ORIGIN_PAIRS_HEADER_LEN + i * UB_ORIGIN_PAIRS_ENTRY_LEN;
        e[0] = 'p';
        e[1] = (uint8_t)('a' + i);
        memset(e + UB_ENTITY_ID_LEN, (int)(0x10 + i), 2 * UB_ORIGIN_KEY_LEN);
    }
    uint32_t crc = ub_crc32c(t, len - 4);
    for (int k = 0; k < 4; k++) t[len - 4 + (size_t)k] = (uint8_t)(crc >> (8 * k));
    return len;
}

/* Every way a table is not one is refused CONFIG, before anything is installed; a good one installs its pairs
 * and hands back the group key. */
static void test_pairs_table_refusals(void **state) {
    (void)state;
    static ub_origin_t o;
    ub_origin_options_t none = {0};
    ub_origin_provision_t out;
    static uint8_t t[UB_ORIGIN_PAIRS_LEN(UB_ORIGIN_PEERS + 1)], bad[UB_ORIGIN_PAIRS_LEN(UB_ORIGIN_PEERS + 1)];
    memset(&o, 0, sizeof o);
    size_t len = pairs_table(t, 2, "gcs", true);
    assert_int_equal(ub_origin_load_pairs(&o, t, len, &out), UB_ERR_INVAL); /* not initialised */
    assert_int_equal(ub_origin_init(&o, &none), UB_OK);
    assert_int_equal(ub_origin_load_pairs(NULL, t, len, &out), UB_ERR_INVAL);
    assert_int_equal(ub_origin_load_pairs(&o, NULL, len, &out), UB_ERR_INVAL);
    assert_int_equal(ub_origin_load_pairs(&o, t, len, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_origin_load_pairs(&o, t, UB_ORIGIN_PAIRS_LEN(0) - 1, &out), UB_ERR_CONFIG); /* too short */
    memcpy(bad, t, len);
    bad[0] = 'X'; /* magic */
    assert_int_equal(ub_origin_load_pairs(&o, bad, len, &out), UB_ERR_CONFIG);
    memcpy(bad, t, len);
    bad[4] = 2; /* version */
    assert_int_equal(ub_origin_load_pairs(&o, bad, len, &out), UB_ERR_CONFIG);
    assert_int_equal(ub_origin_load_pairs(&o, t, len - 1, &out), UB_ERR_CONFIG); /* length is not n's */
    memcpy(bad, t, len);
    bad[60] ^= 1; /* a key bit: the CRC fails */
    assert_int_equal(ub_origin_load_pairs(&o, bad, len, &out), UB_ERR_CONFIG);
    size_t self_len = pairs_table(bad, 1, "pa", false); /* its one pair is with itself */
    assert_int_equal(ub_origin_load_pairs(&o, bad, self_len, &out), UB_ERR_CONFIG);
    size_t many = pairs_table(bad, UB_ORIGIN_PEERS + 1, "gcs", false);
    assert_int_equal(ub_origin_load_pairs(&o, bad, many, &out), UB_ERR_FULL);
    assert_int_equal(ub_origin_cached(&o), 0); /* nothing installed by any of them */
    assert_int_equal(ub_origin_load_pairs(&o, t, len, &out), 2);
    assert_int_equal(ub_origin_cached(&o), 2);
    assert_true(out.has_group_key);
    assert_int_equal(out.group_key_id, 7);
    assert_int_equal(out.group_key[0], 0x6B);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pure_function_contracts),
        cmocka_unit_test(test_context_contracts),
        cmocka_unit_test(test_pairs_table_refusals),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
