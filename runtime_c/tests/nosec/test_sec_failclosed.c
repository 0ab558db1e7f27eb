/* The runtime built WITHOUT libsodium (UAVBUS_SECURITY=OFF: sec.cmake compiles every source into
 * ub_nosec without UB_SECURITY) still builds and fails closed: no context can be initialised or
 * attached, nothing can be signed, and every flagged frame (the signed vectors, valid ones included)
 * is dropped `unknown_key` while unsigned traffic still flows. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "support/ub_test_world.h"
#include "ub/ub_ident.h"
#include "ub/ub_node.h"
#include "ub/ub_sec.h"
#include "ub_signed_vectors.h"

static void test_every_crypto_entry_point_refuses(void **state) {
    (void)state;
    static ub_sec_t sec;
    uint8_t key[UB_SEC_KEY_LEN] = {1};
    assert_false(ub_sec_available());
    assert_int_equal(ub_sec_init(&sec, NULL), UB_ERR_UNSUPPORTED);
    assert_int_equal(ub_sec_add_key(&sec, 1, key), UB_ERR_UNSUPPORTED);
    assert_int_equal(ub_sec_keygen(key), UB_ERR_UNSUPPORTED);
    ub_frame_header_t h = {.flags = UB_FRAME_FLAG_SIGNED, .key_id = 1, .hop_limit = 1};
    uint8_t frame[UB_FRAME_MAX];
    assert_int_equal(ub_sec_protect(&sec, &h, frame + UB_FRAME_HEADER_LEN, frame, sizeof frame), UB_ERR_UNSUPPORTED);
    assert_int_equal(ub_sec_start(&sec, 0, 100), UB_OK); /* even "started", it cannot be attached */
    static ub_node_t node;
    assert_int_equal(ub_node_init(&node, &ub_test_cat, NULL), UB_OK);
    assert_int_equal(ub_node_set_security(&node, &sec), UB_ERR_UNSUPPORTED);
    assert_null(ub_node_security(&node));
    /* the replay windows are plain arithmetic and work in every build */
    ub_sec_window_t w = {0, 0};
    ub_sec_window_establish(&w, 10);
    assert_int_equal(ub_sec_window_check(&w, 10), UB_SEC_WINDOW_DUPLICATE);
    assert_int_equal(ub_sec_window_check(&w, 11), UB_SEC_WINDOW_NEW);
}

static void test_flagged_frames_are_dropped_unknown_key(void **state) {
    (void)state;
    static ub_node_t node;
    assert_int_equal(ub_node_init(&node, &ub_test_cat, NULL), UB_OK);
    uint8_t me[UB_ENTITY_ID_LEN];
    int local = -1;
    /* host every destination of the vectors, so nothing is dropped for want of a route */
    for (size_t i = 0; i < SIGNED_VECTOR_COUNT; i++) {
        int e = ub_node_find_entity(&node, signed_vectors[i].dest_id);
        if (e < 0) e = ub_node_add_entity(&node, signed_vectors[i].dest_id, true);
        if (local < 0 && e >= 0) local = e;
    }
    assert_true(local >= 0);
    int link = ub_node_add_link(&node, local, 0, "in");
    assert_true(link >= 0);
    for (size_t i = 0; i < SIGNED_VECTOR_COUNT; i++)
        assert_int_equal(ub_node_rx_frame(&node, link, signed_vectors[i].frame, signed_vectors[i].frame_len, 1), UB_OK);
    const ub_node_counters_t *c = ub_node_counters(&node);
    assert_int_equal(c->drops[UB_DROP_UNKNOWN_KEY], SIGNED_VECTOR_COUNT);
    assert_int_equal(c->delivered + c->admin_handled + c->forwarded, 0);
    assert_int_equal(ub_node_link(&node, link)->counters.frames_accepted, 0);
    /* unsigned frames still flow (the paper's scenario needs no keys) */
    uint8_t frame[UB_FRAME_MAX];
    uint8_t payload[8] = {0};
    test_eid("somebody", me);
    size_t n = make_frame(frame, UB_ADMIN_ACK, (const uint8_t *)"gpsOut\0\0gpsOut\0\0", "somebody", "rmax1ob1", 5, 8, 0,
                          payload, sizeof payload);
    assert_int_equal(ub_node_rx_frame(&node, link, frame, n, 2), UB_OK);
    assert_int_equal(ub_node_link(&node, link)->counters.frames_accepted, 1);
}

/* Without libsodium there is no sodium_memzero(): codec/ub_wipe_private.h erases through a volatile pointer
 * instead (issue #29 item 6: that loop ran in no test). An identity store full of stand-in secret bytes is all
 * zeros after it is cleared. */
static void test_secrets_still_erased(void **state) {
    (void)state;
    static ub_ident_store_t store;
    memset(&store, 0xA5, sizeof store);
    ub_ident_store_clear(&store);
    static const ub_ident_store_t zero;
    assert_memory_equal(&store, &zero, sizeof store);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_crypto_entry_point_refuses),
        cmocka_unit_test(test_flagged_frames_are_dropped_unknown_key),
        cmocka_unit_test(test_secrets_still_erased),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
