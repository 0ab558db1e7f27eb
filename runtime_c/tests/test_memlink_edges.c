/*
 * The in-memory link at its edges (ub_memlink.h; issue #29 item 6): a connect that fails for either end
 * leaves neither end attached (no half link queueing frames toward nobody); disconnect leaves a transport
 * that replaced the memlink on a slot alone; an oversized frame is refused before it is counted sent; the
 * one seed whose mixing would zero the xorshift state still draws faults at their rate; stats of a side
 * that does not exist are NULL.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "support/ub_test_pair.h"
#include "ub/ub_memlink.h"

static void test_failed_connect_attaches_neither_end(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_memlink_disconnect(p->ml);
    static ub_memlink_t ml;
    ub_memlink_init(&ml, NULL, 1);
    assert_int_equal(ub_memlink_connect(&ml, p->pub_node, p->pub_link, p->sub_node, 99), UB_ERR_INVAL);
    assert_null(ub_node_link_kind(p->pub_node, p->pub_link));
    assert_int_equal(ub_memlink_connect(&ml, p->pub_node, 99, p->sub_node, p->sub_link), UB_ERR_INVAL);
    assert_null(ub_node_link_kind(p->sub_node, p->sub_link));
    /* a frame sent now is dropped `detached` by the node, not queued in the memlink */
    uint64_t detached = ub_node_counters(p->pub_node)->drops[UB_DROP_DETACHED];
    assert_true(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 0) <= 0);
    assert_int_equal(ub_node_counters(p->pub_node)->drops[UB_DROP_DETACHED], detached + 1);
    assert_int_equal(ub_memlink_pending(&ml), 0);
    assert_int_equal(ub_memlink_stats(&ml, 0)->sent, 0);
    /* connected properly, it carries the frame */
    assert_int_equal(ub_memlink_connect(&ml, p->pub_node, p->pub_link, p->sub_node, p->sub_link), UB_OK);
    assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 1), 1);
    assert_int_equal(ub_memlink_pump(&ml, 1), 1);
    assert_int_equal(p->log.n, 1);
    ub_memlink_disconnect(&ml);
    pair_free(p);
}

/* A slot re-attached to another transport keeps it when the old memlink is disconnected. */
static void test_disconnect_leaves_a_replacing_transport(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    static capture_t cap;
    memset(&cap, 0, sizeof cap);
    assert_int_equal(ub_node_link_attach(p->pub_node, p->pub_link, &capture_ops, &cap), UB_OK);
    ub_memlink_disconnect(p->ml);
    assert_string_equal(ub_node_link_kind(p->pub_node, p->pub_link), "capture");
    assert_null(ub_node_link_kind(p->sub_node, p->sub_link)); /* its own end is taken off */
    assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 0), 1);
    assert_int_equal(cap.n, 1);
    ub_memlink_disconnect(p->ml); /* twice: nothing */
    ub_memlink_disconnect(NULL);
    assert_null(ub_memlink_stats(NULL, 0));
    assert_null(ub_memlink_stats(p->ml, -1));
    assert_null(ub_memlink_stats(p->ml, 2));
    pair_free(p);
}

static void test_oversized_frame_refused_before_counting(void **state) {
    (void)state;
    static ub_memlink_t ml;
    ub_memlink_init(&ml, NULL, 3);
    static uint8_t big[UB_FRAME_MAX + 1];
    assert_int_equal(ub_memlink_ops.send(&ml.end[0], big, sizeof big, 0), UB_ERR_RANGE);
    assert_int_equal(ub_memlink_stats(&ml, 0)->sent, 0);
    assert_int_equal(ub_memlink_pending(&ml), 0);
    assert_int_equal(ub_memlink_ops.send(&ml.end[0], big, UB_FRAME_MAX, 0), UB_OK);
    assert_int_equal(ub_memlink_stats(&ml, 0)->sent, 1);
    assert_int_equal(ub_memlink_pending(&ml), 1);
    assert_int_equal(ub_memlink_ops.fileno(&ml.end[0]), -1);
}

/* (seed ^ 0x9E3779B97F4A7C15) * odd is 0 for exactly one seed; xorshift would stay at 0 for ever (every draw
 * alike). That seed must still lose about half the frames at 50 % loss. */
static void test_zeroing_seed_still_draws(void **state) {
    (void)state;
    static ub_memlink_t ml;
    ub_memlink_faults_t half = {.loss_ppm = 500000};
    ub_memlink_init(&ml, &half, 0x9E3779B97F4A7C15ULL);
    uint8_t f[80];
    memset(f, 0x11, sizeof f);
    for (int i = 0; i < 1000; i++) {
        assert_int_equal(ub_memlink_ops.send(&ml.end[0], f, sizeof f, (uint64_t)i), UB_OK);
        (void)ub_memlink_pump(&ml, (uint64_t)i); /* nobody attached: taken off the queue */
    }
    uint64_t lost = ub_memlink_stats(&ml, 0)->lost;
    assert_true(lost > 400 && lost < 600);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_failed_connect_attaches_neither_end),
        cmocka_unit_test(test_disconnect_leaves_a_replacing_transport),
        cmocka_unit_test(test_oversized_frame_refused_before_counting),
        cmocka_unit_test(test_zeroing_seed_still_draws),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
