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

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pure_function_contracts),
        cmocka_unit_test(test_context_contracts),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
