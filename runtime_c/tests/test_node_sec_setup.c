/*
 * The node's security set-up contracts (ub_node.h "Security", runtime_c/src/core/ub_node_sec.c; issue #29
 * item 6): a keyring is taken only initialised and started, detached with NULL; the node-wide and per-link
 * signing rules and how a link follows the node's; every refusal for a bad node, link or value. And an
 * unsigned CHALLENGE arriving over a link is dropped `unsigned` and never answered: it proves nothing, and
 * answering it would let anyone make the node sign on demand.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "support/ub_test_world.h"
#include "ub/ub_sec.h"

static const uint8_t KEY[UB_SEC_KEY_LEN] = {3, 1, 4, 1, 5, 9, 2, 6, 5, 3, 5, 8, 9, 7, 9, 3,
                                            2, 3, 8, 4, 6, 2, 6, 4, 3, 3, 8, 3, 2, 7, 9, 5};

static void test_keyring_and_signing_rules_set_up(void **state) {
    (void)state;
    if (!ub_sec_available()) skip();
    world_t *w = world_new();
    ub_node_t *n = world_node(w, &ub_test_cat, NULL);
    int me = ub_node_add_entity_name(n, "me", true);
    assert_true(me >= 0);
    int l0 = ub_node_add_link(n, me, 0, "l0");
    assert_true(l0 >= 0);
    ub_sec_t *sec = calloc(1, sizeof *sec);
    assert_non_null(sec);
    /* not initialised, then initialised but not started: refused, nothing attached */
    assert_int_equal(ub_node_set_security(n, sec), UB_ERR_INVAL);
    assert_int_equal(ub_sec_init(sec, NULL), UB_OK);
    assert_int_equal(ub_sec_add_key(sec, 1, KEY), UB_OK);
    assert_int_equal(ub_node_set_security(n, sec), UB_ERR_INVAL);
    assert_null(ub_node_security(n));
    assert_int_equal(ub_sec_start(sec, 0, 5000), UB_OK);
    assert_int_equal(ub_node_set_security(NULL, sec), UB_ERR_INVAL);
    assert_int_equal(ub_node_set_security(n, sec), UB_OK);
    assert_ptr_equal(ub_node_security(n), sec);
    assert_null(ub_node_security(NULL));
    /* a link follows the node's rule (-1) until it has its own */
    assert_false(ub_node_link_requires_signed(n, l0));
    assert_int_equal(ub_node_set_require_signed(n, true), UB_OK);
    assert_true(ub_node_link_requires_signed(n, l0));
    assert_int_equal(ub_node_link_set_security(n, l0, 0, false), UB_OK);
    assert_false(ub_node_link_requires_signed(n, l0));
    assert_int_equal(ub_node_link_set_security(n, l0, -1, true), UB_OK);
    assert_true(ub_node_link_requires_signed(n, l0));
    assert_true(ub_node_link_encrypts(n, l0));
    assert_int_equal(ub_node_set_require_signed(NULL, true), UB_ERR_INVAL);
    /* refusals leave the link as it was */
    assert_int_equal(ub_node_link_set_security(NULL, l0, 1, false), UB_ERR_INVAL);
    assert_int_equal(ub_node_link_set_security(n, -1, 1, false), UB_ERR_INVAL);
    assert_int_equal(ub_node_link_set_security(n, UB_MAX_NODE_LINKS, 1, false), UB_ERR_INVAL);
    assert_int_equal(ub_node_link_set_security(n, l0 + 1, 1, false), UB_ERR_INVAL); /* not in use */
    assert_int_equal(ub_node_link_set_security(n, l0, -2, false), UB_ERR_INVAL);
    assert_int_equal(ub_node_link_set_security(n, l0, 2, false), UB_ERR_INVAL);
    assert_true(ub_node_link_encrypts(n, l0));
    assert_false(ub_node_link_requires_signed(NULL, l0));
    assert_false(ub_node_link_requires_signed(n, -1));
    assert_false(ub_node_link_requires_signed(n, l0 + 1));
    /* NULL detaches the keyring */
    assert_int_equal(ub_node_set_security(n, NULL), UB_OK);
    assert_null(ub_node_security(n));
    free(sec);
    free(w);
}

static void test_unsigned_challenge_is_dropped_never_answered(void **state) {
    (void)state;
    if (!ub_sec_available()) skip();
    world_t *w = world_new();
    ub_node_t *n = world_node(w, &ub_test_cat, NULL);
    int me = ub_node_add_entity_name(n, "me", true), peer = ub_node_add_entity_name(n, "peer", false);
    assert_true(me >= 0 && peer >= 0);
    int l0 = ub_node_add_link(n, me, 0, "l0");
    assert_true(l0 >= 0);
    assert_int_equal(ub_node_set_mask(n, me, peer, 0x01), UB_OK);
    static capture_t cap;
    memset(&cap, 0, sizeof cap);
    assert_int_equal(ub_node_link_attach(n, l0, &capture_ops, &cap), UB_OK);
    ub_sec_t *sec = calloc(1, sizeof *sec);
    assert_non_null(sec);
    test_sec_on(sec, n, KEY, 7000, false); /* signs; does not require signed frames */
    uint8_t nonce[UB_SEC_NONCE_LEN], f[UB_FRAME_MAX], dir[UB_DIR_ID_LEN] = {0};
    memset(nonce, 0x5C, sizeof nonce);
    size_t len = make_frame(f, UB_ADMIN_CHALLENGE, dir, "peer", "me", 41, 8, 0, nonce, sizeof nonce);
    uint64_t unsigned_drops = ub_node_counters(n)->drops[UB_DROP_UNSIGNED];
    assert_int_equal(ub_node_rx_frame(n, l0, f, len, 10), UB_OK);
    ub_node_tick(n, 11);
    assert_int_equal(ub_node_counters(n)->drops[UB_DROP_UNSIGNED], unsigned_drops + 1);
    assert_int_equal(ub_node_link(n, l0)->counters.drops[UB_DROP_UNSIGNED], 1);
    assert_int_equal(cap.n, 0); /* no CHALLENGE_REPLY */
    free(sec);
    free(w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_keyring_and_signing_rules_set_up),
        cmocka_unit_test(test_unsigned_challenge_is_dropped_never_answered),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
