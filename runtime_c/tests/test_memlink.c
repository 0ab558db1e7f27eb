/*
 * The in-memory link: ordering and delay, fault rates and their
 * reproducibility, corruption caught by the receiver, overflow counted (never
 * silent), and rebinding a named port to another transport at run time
 * without losing publish/subscribe state.
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
#include "ub/ub_pubsub.h"

static void send_n(pair_t *p, int n) {
    for (int i = 0; i < n; i++)
        assert_true(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, p->w->now_ms) >= 0);
}

static void test_delay_and_order(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_memlink_faults_t slow = {.delay_ms = 10};
    ub_memlink_set_faults(p->ml, &slow);
    send_n(p, 5);
    assert_int_equal(ub_memlink_pump(p->ml, 9), 0);
    assert_int_equal(ub_memlink_pending(p->ml), 5);
    assert_int_equal(ub_memlink_pump(p->ml, 10), 5);
    for (size_t i = 0; i < 5; i++) assert_int_equal(p->log.d[i].seq, i + 1); /* in send order */
    assert_int_equal(ub_memlink_stats(p->ml, 0)->delivered, 5);
    pair_free(p);
}

static uint64_t run_faulty(uint64_t seed, const ub_memlink_faults_t *faults, pair_t **out) {
    pair_t *p = pair_new(NULL);
    ub_memlink_init(p->ml, faults, seed);
    assert_int_equal(ub_memlink_connect(p->ml, p->pub_node, p->pub_link, p->sub_node, p->sub_link), UB_OK);
    for (int i = 0; i < 2000; i++) {
        send_n(p, 1);
        world_run(p->w, p->w->now_ms + 1, 1);
    }
    world_run(p->w, p->w->now_ms + 100, 1);
    uint64_t lost = ub_memlink_stats(p->ml, 0)->lost;
    *out = p;
    return lost;
}

static void test_fault_rates_and_reproducibility(void **state) {
    (void)state;
    ub_memlink_faults_t f = {.loss_ppm = 300000, .duplicate_ppm = 100000, .reorder_ppm = 100000, .jitter_ms = 2,
                             .reorder_delay_ms = 10};
    pair_t *a, *b, *c;
    uint64_t lost_a = run_faulty(1, &f, &a);
    uint64_t lost_b = run_faulty(1, &f, &b);
    uint64_t lost_c = run_faulty(2, &f, &c);
    const ub_memlink_stats_t *s = ub_memlink_stats(a->ml, 0);
    assert_int_equal(s->sent, 2000);
    assert_in_range(lost_a, 600 - 90, 600 + 90);           /* 30 % +- ~4.5 sigma */
    assert_in_range(s->duplicated, 140 - 50, 140 + 50);    /* 10 % of the 70 % queued */
    assert_in_range(s->reordered, 154 - 55, 154 + 55);
    assert_int_equal(lost_a, lost_b);                       /* same seed, same faults */
    assert_memory_equal(&a->log.d[0], &b->log.d[0], sizeof a->log.d[0] * a->log.n);
    assert_true(lost_a != lost_c);                          /* another seed, another run */
    /* Duplicates never reach the application twice; reordering shows up as late sequences. */
    assert_int_equal(delivery_repeats(&a->log), 0);
    assert_int_equal(a->log.n, 2000 - lost_a);
    size_t late = 0;
    for (size_t i = 1; i < a->log.n; i++) late += a->log.d[i].seq < a->log.d[i - 1].seq;
    assert_true(late > 0);
    pair_free(a);
    pair_free(b);
    pair_free(c);
}

static void test_corruption_is_caught_by_the_receiver(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_memlink_faults_t f = {.corrupt_ppm = 1000000};
    ub_memlink_set_faults(p->ml, &f);
    memset(&p->gps_dst, 0x33, sizeof p->gps_dst);
    send_n(p, 50);
    world_run(p->w, 10, 1);
    uint64_t bad = 0;
    for (int r = 0; r < UB_RX_REASON_COUNT; r++)
        bad += ub_node_link_bad_frames(p->sub_node, p->sub_link, (ub_rx_reason_t)r);
    /* A flipped bit in the header IDs or payload is a CRC error; in sync/size/version it is refused too. */
    assert_int_equal(ub_memlink_stats(p->ml, 0)->corrupted, 50);
    assert_int_equal(bad, 50);
    assert_int_equal(ub_memlink_stats(p->ml, 0)->rejected, 50);
    assert_int_equal(p->log.n, 0);
    assert_int_equal(((uint8_t *)&p->gps_dst)[0], 0x33);
    pair_free(p);
}

static void test_overflow_is_counted(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    send_n(p, UB_MEMLINK_DEPTH + 6);
    assert_int_equal(ub_memlink_pending(p->ml), UB_MEMLINK_DEPTH);
    assert_int_equal(ub_memlink_stats(p->ml, 0)->overflow, 6);
    assert_int_equal(ub_node_link(p->pub_node, p->pub_link)->counters.drops[UB_DROP_BACKPRESSURE], 6);
    assert_int_equal(ub_node_link(p->pub_node, p->pub_link)->counters.frames_out, UB_MEMLINK_DEPTH);
    world_run(p->w, 1, 1);
    assert_int_equal(p->log.n, UB_MEMLINK_DEPTH);
    pair_free(p);
}

/* The paper's "software switch": the same named port moves to another transport mid-run. */
static void test_rebinding_a_port_keeps_state(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    int row = ub_pubsub_subscribe(p->sub_node, p->sub, TEST_GPS, p->pub_id, 50, 0);
    assert_true(row >= 0);
    world_run(p->w, 1000, 1);
    size_t before = p->log.n;
    uint64_t frames_in = ub_node_link(p->sub_node, p->sub_link)->counters.frames_in;
    uint64_t old_sent = ub_memlink_stats(p->ml, 0)->sent + ub_memlink_stats(p->ml, 1)->sent;
    assert_true(before >= 18);
    /* A second memlink (say, the Ethernet path) replaces the first behind both ports. */
    ub_memlink_t *other = world_connect(p->w, p->pub_node, ub_node_find_link(p->pub_node, "pubPort"), p->sub_node,
                                        ub_node_find_link(p->sub_node, "subPort"), NULL, 9);
    world_run(p->w, 2000, 1);
    assert_in_range(p->log.n - before, 19, 21);
    assert_true(ub_memlink_stats(other, 0)->delivered >= 19);
    assert_int_equal(ub_memlink_stats(p->ml, 0)->sent + ub_memlink_stats(p->ml, 1)->sent, old_sent); /* old path idle */
    /* Subscription and counters carried over. */
    assert_int_equal(ub_pubsub_row(p->sub_node, p->sub, row)->state, UB_SUB_RECEIVING);
    assert_true(ub_node_link(p->sub_node, p->sub_link)->counters.frames_in > frames_in);
    assert_string_equal(ub_node_link(p->sub_node, p->sub_link)->ops->kind, "mem");
    pair_free(p);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_delay_and_order),
        cmocka_unit_test(test_fault_rates_and_reproducibility),
        cmocka_unit_test(test_corruption_is_caught_by_the_receiver),
        cmocka_unit_test(test_overflow_is_counted),
        cmocka_unit_test(test_rebinding_a_port_keeps_state),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
