/*
 * Publication on update (ub_pubsub_set_on_update / ub_pubsub_updated), the mode bridges use for
 * directories refreshed from outside the node (docs/bridges.md): every update sent once and at
 * once when the source runs at the row's rate with jitter, a faster source thinned to the row's
 * period without drift, nothing sent while the source is silent (the subscriber times out instead
 * of receiving stale copies), no burst when it comes back, and the timer mode left as it was.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "support/ub_test_pair.h"
#include "ub/ub_pubsub.h"

/* What the subscriber received: the `fix` field carries the update number. */
typedef struct received {
    size_t n;
    uint32_t fix[4096];
    uint64_t at_ms[4096];
    const struct test_gps *dst;
} received_t;

static void on_deliver(void *user, int entity, uint32_t instance, const ub_frame_header_t *h, uint64_t now_ms) {
    (void)entity;
    (void)h;
    received_t *r = user;
    if (instance != TEST_GPS || r->n == 4096) return;
    r->fix[r->n] = r->dst->fix;
    r->at_ms[r->n] = now_ms;
    r->n++;
}

/* A pair whose publisher publishes gpsOut on update, with `sub` subscribed at `period_ms` from t = 0. */
static pair_t *on_update_pair(received_t *rx, uint32_t period_ms) {
    pair_t *p = pair_new(NULL);
    assert_int_equal(ub_pubsub_set_on_update(p->pub_node, TEST_GPS, true), UB_OK);
    memset(rx, 0, sizeof *rx);
    rx->dst = &p->gps_dst;
    ub_node_set_deliver_hook(p->sub_node, on_deliver, rx);
    assert_true(ub_pubsub_subscribe(p->sub_node, p->sub, TEST_GPS, p->pub_id, period_ms, 0) >= 0);
    world_run(p->w, 50, 1); /* request, row at the source, ACK */
    assert_true(ub_pubsub_find(p->pub_node, p->pub, UB_PS_PUBLICATION, TEST_GPS, p->sub_id) >= 0);
    return p;
}

/* Runs the world 1 ms at a time to `until`, updating the source at each time of `times` (sorted). */
static uint32_t run_updates(pair_t *p, const uint64_t *times, size_t n, uint32_t first_fix, uint64_t until) {
    size_t k = 0;
    uint32_t fix = first_fix;
    for (uint64_t t = p->w->now_ms + 1; t <= until; t++) {
        while (k < n && times[k] <= t) {
            p->gps_src.fix = ++fix;
            assert_true(ub_pubsub_updated(p->pub_node, p->pub, TEST_GPS, t) >= 0);
            k++;
        }
        world_run(p->w, t, 1);
    }
    return fix;
}

/* Deterministic jitter in [-8, +8] ms (a Python autopilot on a loaded machine). */
static int64_t jitter(size_t k) { return (int64_t)((k * 7919u) % 17u) - 8; }

static void test_every_update_once_at_the_rows_rate_with_jitter(void **state) {
    (void)state;
    received_t *rx = test_calloc(1, sizeof *rx);
    pair_t *p = on_update_pair(rx, 20);
    uint64_t times[150];
    for (size_t k = 0; k < 150; k++) times[k] = (uint64_t)(100 + 20 * (int64_t)k + jitter(k));
    uint32_t last = run_updates(p, times, 150, 0, 3200);
    assert_int_equal(last, 150);
    /* All 150 updates arrived, each once, in order: none lost to jitter, none repeated. */
    assert_int_equal(rx->n, 150);
    for (size_t k = 0; k < rx->n; k++) assert_int_equal(rx->fix[k], k + 1);
    /* Early updates wait for their turn at most half a period. */
    for (size_t k = 0; k < rx->n; k++) assert_true(rx->at_ms[k] <= times[k] + 10);
    pair_free(p);
    test_free(rx);
}

static void test_faster_source_thinned_to_the_period_without_drift(void **state) {
    (void)state;
    received_t *rx = test_calloc(1, sizeof *rx);
    pair_t *p = on_update_pair(rx, 20);
    uint64_t times[800];
    for (size_t k = 0; k < 800; k++) times[k] = 100 + 5 * k; /* 200 Hz for 4 s */
    (void)run_updates(p, times, 800, 0, 4100);
    /* 50 Hz out of 200 Hz: once the schedule is under way (the first turn may come half a period
     * early), 195 frames in the 3.9 s from 200 ms, within one either way; every value a fresh one. */
    size_t steady = 0;
    for (size_t k = 0; k < rx->n; k++) steady += rx->at_ms[k] >= 200;
    assert_in_range(steady, 194, 196);
    assert_in_range(rx->n, 199, 203);
    for (size_t k = 1; k < rx->n; k++) assert_true(rx->fix[k] > rx->fix[k - 1]);
    pair_free(p);
    test_free(rx);
}

static void test_silent_source_sends_nothing_and_resumes_without_burst(void **state) {
    (void)state;
    received_t *rx = test_calloc(1, sizeof *rx);
    pair_t *p = on_update_pair(rx, 20);
    uint64_t first[25];
    for (size_t k = 0; k < 25; k++) first[k] = 100 + 20 * k;
    uint32_t fix = run_updates(p, first, 25, 0, 600);
    size_t before = rx->n;
    assert_int_equal(before, 25);
    /* 2 s of silence: no stale copies; the subscriber's data times out and it asks again. */
    fix = run_updates(p, NULL, 0, fix, 2600);
    assert_int_equal(rx->n, before);
    int row = ub_pubsub_find(p->sub_node, p->sub, UB_PS_SUBSCRIPTION, TEST_GPS, p->pub_id);
    assert_true(row >= 0);
    assert_int_equal(ub_pubsub_row(p->sub_node, p->sub, row)->state, UB_SUB_REQUESTING);
    /* The source comes back at 200 Hz: the first 100 ms carry at most 6 frames (50 Hz + one), not a burst. */
    uint64_t again[200];
    for (size_t k = 0; k < 200; k++) again[k] = 2601 + 5 * k;
    (void)run_updates(p, again, 200, fix, 3600);
    size_t first_100ms = 0;
    for (size_t k = before; k < rx->n; k++) first_100ms += rx->at_ms[k] < 2701;
    assert_in_range(first_100ms, 4, 6);
    assert_in_range(rx->n - before, 49, 51);
    pair_free(p);
    test_free(rx);
}

static void test_api_errors_and_timer_mode_untouched(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    /* imuOut is not bound at the publisher. */
    assert_int_equal(ub_pubsub_set_on_update(p->pub_node, TEST_IMU, true), UB_ERR_NOTFOUND);
    assert_int_equal(ub_pubsub_set_on_update(NULL, TEST_GPS, true), UB_ERR_INVAL);
    /* gpsOut is published on a timer: updated() refuses, the timer keeps its rate. */
    assert_int_equal(ub_pubsub_updated(p->pub_node, p->pub, TEST_GPS, 0), UB_ERR_INVAL);
    assert_int_equal(ub_pubsub_updated(p->pub_node, p->pub_peer, TEST_GPS, 0), UB_ERR_INVAL);
    assert_true(ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, p->sub_id, 30, 0) >= 0);
    world_run(p->w, 3000, 7);
    assert_in_range(delivery_count(&p->log, p->sub, TEST_GPS, 0, 3001), 99, 101);
    /* Switched to on update, the same row sends nothing until an update; back off, the timer resumes. */
    assert_int_equal(ub_pubsub_set_on_update(p->pub_node, TEST_GPS, true), UB_OK);
    size_t n = p->log.n;
    world_run(p->w, 4000, 1);
    assert_int_equal(p->log.n, n);
    assert_int_equal(ub_pubsub_updated(p->pub_node, p->pub, TEST_GPS, 4001), 1);
    world_run(p->w, 4001, 1);
    assert_int_equal(p->log.n, n + 1);
    assert_int_equal(ub_pubsub_set_on_update(p->pub_node, TEST_GPS, false), UB_OK);
    world_run(p->w, 5000, 1);
    assert_in_range(p->log.n - (n + 1), 32, 34);
    pair_free(p);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_update_once_at_the_rows_rate_with_jitter),
        cmocka_unit_test(test_faster_source_thinned_to_the_period_without_drift),
        cmocka_unit_test(test_silent_source_sends_nothing_and_resumes_without_burst),
        cmocka_unit_test(test_api_errors_and_timer_mode_untouched),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
