/*
 * Publish/subscribe tables on the injected clock: publication rate without
 * drift, sane catch-up after a stall, subscription requests/renewals, data
 * timeout and immediate re-request, leases (vanished subscriber, restarted
 * publisher heal without an operator), stops removing both ends, refusals.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "support/ub_test_pair.h"
#include "ub/ub_pubsub.h"

static void test_publication_rate_does_not_drift(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    assert_true(ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, p->sub_id, 30, 0) >= 0);
    /* Ticks every 7 ms never line up with the 30 ms period; "next = now + period" would lose ~10 %. */
    world_run(p->w, 3000, 7);
    size_t n = delivery_count(&p->log, p->sub, TEST_GPS, 0, 3001);
    assert_in_range(n, 99, 101);
    assert_memory_equal(&p->gps_dst, &p->gps_src, sizeof p->gps_src);
    pair_free(p);
}

static void test_stall_resumes_without_burst(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    assert_true(ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, p->sub_id, 10, 0) >= 0);
    world_run(p->w, 100, 1);
    size_t before = p->log.n;
    assert_in_range(before, 10, 11);
    /* One tick after a 1 s stall: one frame, not the 100 that were missed. */
    world_run(p->w, 1100, 1000);
    assert_int_equal(p->log.n - before, 1);
    /* Then the rate resumes. */
    world_run(p->w, 1200, 1);
    assert_in_range(p->log.n - before, 10, 12);
    pair_free(p);
}

static void test_subscription_requests_then_renews(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    int row = ub_pubsub_subscribe(p->sub_node, p->sub, TEST_GPS, p->pub_id, 50, 0);
    assert_true(row >= 0);
    world_run(p->w, 10000, 1);
    const ub_ps_row_t *r = ub_pubsub_row(p->sub_node, p->sub, row);
    assert_int_equal(r->kind, UB_PS_SUBSCRIPTION);
    assert_int_equal(r->state, UB_SUB_RECEIVING);
    assert_int_equal(r->acked, 1);
    assert_in_range(r->frames, 195, 201);
    /* The source's row is a lease owned by the subscriber. */
    int pub_row = ub_pubsub_find(p->pub_node, p->pub, UB_PS_PUBLICATION, TEST_GPS, p->sub_id);
    assert_true(pub_row >= 0);
    const ub_ps_row_t *pr = ub_pubsub_row(p->pub_node, p->pub, pub_row);
    assert_memory_equal(pr->owner, p->sub_id, UB_ENTITY_ID_LEN);
    assert_true(pr->lease_until_ms > p->w->now_ms);
    /* One request, then one renewal per renew_ms (1 s): about 10 in 10 s, not one per period. */
    assert_in_range(ub_node_counters(p->sub_node)->originated, 10, 12);
    pair_free(p);
}

static uint64_t first_delivery_after(const pair_t *p, uint64_t t) {
    for (size_t i = 0; i < p->log.n; i++)
        if (p->log.d[i].at_ms >= t) return p->log.d[i].at_ms;
    return UINT64_MAX;
}

static void test_timeout_rerequests_and_lease_heals(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    int row = ub_pubsub_subscribe(p->sub_node, p->sub, TEST_GPS, p->pub_id, 100, 0);
    world_run(p->w, 2000, 1);
    /* The link goes dark for 5 s: longer than the publication's lease (3 s). */
    ub_memlink_faults_t dark = {.loss_ppm = 1000000};
    ub_memlink_set_faults(p->ml, &dark);
    world_run(p->w, 7000, 1);
    const ub_ps_row_t *r = ub_pubsub_row(p->sub_node, p->sub, row);
    assert_int_equal(r->state, UB_SUB_REQUESTING); /* timed out: max(3 * 100, 500) ms */
    assert_int_equal(ub_pubsub_count(p->pub_node, p->pub, UB_PS_PUBLICATION), 0);
    assert_int_equal(ub_node_counters(p->pub_node)->leases_expired, 1);
    /* Light again: the subscriber's requests (every retry_ms) recreate the publication. */
    ub_memlink_set_faults(p->ml, NULL);
    world_run(p->w, 8000, 1);
    assert_true(first_delivery_after(p, 7000) <= 7000 + 200 + 10);
    assert_int_equal(ub_pubsub_row(p->sub_node, p->sub, row)->state, UB_SUB_RECEIVING);
    pair_free(p);
}

static void test_data_timeout_definition(void **state) {
    (void)state;
    ub_pubsub_timing_t t = {0};
    t.timeout_min_ms = 500;
    assert_int_equal(ub_pubsub_data_timeout_ms(&t, 100), 500);
    assert_int_equal(ub_pubsub_data_timeout_ms(&t, 1000), 3000);
}

static void test_restarted_publisher_heals(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    assert_true(ub_pubsub_subscribe(p->sub_node, p->sub, TEST_GPS, p->pub_id, 50, 0) >= 0);
    world_run(p->w, 5000, 1);
    /* The publisher's process restarts: empty tables, sequence numbers from 1 again. */
    assert_int_equal(ub_node_init(p->pub_node, &ub_test_cat, NULL), UB_OK);
    p->pub = ub_node_add_entity(p->pub_node, p->pub_id, true);
    p->pub_peer = ub_node_add_entity(p->pub_node, p->sub_id, false);
    p->pub_link = ub_node_add_link(p->pub_node, p->pub, 0, "pubPort");
    assert_int_equal(ub_node_set_mask(p->pub_node, p->pub, p->pub_peer, 0x01), UB_OK);
    assert_int_equal(ub_node_link_attach(p->pub_node, p->pub_link, &ub_memlink_ops, &p->ml->end[0]), UB_OK);
    assert_int_equal(ub_node_bind(p->pub_node, TEST_GPS, &p->gps_src), UB_OK);
    size_t before = p->log.n;
    world_run(p->w, 7000, 1);
    /* Timeout (500 ms) -> request -> data again, accepted although its sequence restarted. */
    assert_true(p->log.n - before >= 25);
    assert_true(ub_node_counters(p->sub_node)->dedup_resets >= 1);
    pair_free(p);
}

static void test_vanished_subscriber_lease_expires(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    assert_true(ub_pubsub_subscribe(p->sub_node, p->sub, TEST_GPS, p->pub_id, 50, 0) >= 0);
    world_run(p->w, 2000, 1);
    assert_int_equal(ub_pubsub_count(p->pub_node, p->pub, UB_PS_PUBLICATION), 1);
    /* The subscriber's process dies: it no longer ticks (nor renews). */
    p->w->n_nodes = 1;
    world_run(p->w, 2000 + 3000 + 1100, 1);
    assert_int_equal(ub_pubsub_count(p->pub_node, p->pub, UB_PS_PUBLICATION), 0);
    uint64_t sent = ub_node_counters(p->pub_node)->originated;
    world_run(p->w, 8000, 1);
    assert_int_equal(ub_node_counters(p->pub_node)->originated, sent);
    pair_free(p);
}

static void test_stop_removes_both_ends(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    int row = ub_pubsub_subscribe(p->sub_node, p->sub, TEST_GPS, p->pub_id, 50, 0);
    world_run(p->w, 500, 1);
    assert_int_equal(ub_pubsub_count(p->pub_node, p->pub, UB_PS_PUBLICATION), 1);
    assert_int_equal(ub_pubsub_stop(p->sub_node, p->sub, row, p->w->now_ms), UB_OK);
    assert_int_equal(ub_pubsub_row(p->sub_node, p->sub, row)->state, UB_SUB_STOPPING);
    assert_int_equal(ub_pubsub_find(p->sub_node, p->sub, UB_PS_SUBSCRIPTION, TEST_GPS, p->pub_id), UB_ERR_NOTFOUND);
    world_run(p->w, 520, 1);
    assert_int_equal(ub_pubsub_count(p->pub_node, p->pub, UB_PS_PUBLICATION), 0);
    assert_int_equal(ub_pubsub_count(p->sub_node, p->sub, UB_PS_SUBSCRIPTION), 0);
    size_t before = p->log.n;
    world_run(p->w, 5000, 1);
    assert_int_equal(p->log.n, before);
    assert_int_equal(ub_pubsub_stop(p->sub_node, p->sub, row, p->w->now_ms), UB_ERR_NOTFOUND);
    pair_free(p);
}

static void test_refused_request_backs_off(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    /* imuOut is not bound at the source: NACK(unbound); the subscriber slows to the renewal pace. */
    int row = ub_pubsub_subscribe(p->sub_node, p->sub, TEST_IMU, p->pub_id, 50, 0);
    world_run(p->w, 5000, 1);
    assert_int_equal(ub_pubsub_row(p->sub_node, p->sub, row)->acked, 0);
    assert_int_equal(ub_pubsub_count(p->pub_node, p->pub, UB_PS_PUBLICATION), 0);
    uint64_t requests = ub_node_counters(p->sub_node)->originated;
    assert_in_range(requests, 4, 6); /* ~1 per second, not 25 at the 200 ms retry pace */
    pair_free(p);
}

static void test_api_contracts(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    assert_int_equal(ub_pubsub_publish(p->pub_node, p->pub_peer, TEST_GPS, p->sub_id, 10, 0), UB_ERR_INVAL);
    assert_int_equal(ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, p->sub_id, 0, 0), UB_ERR_INVAL);
    assert_int_equal(ub_pubsub_publish(p->pub_node, p->pub, 7, p->sub_id, 10, 0), UB_ERR_INVAL);
    int a = ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, p->sub_id, 10, 0);
    int b = ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, p->sub_id, 20, 0);
    assert_int_equal(a, b); /* same (content, destination): updated, not duplicated */
    assert_int_equal(ub_pubsub_row(p->pub_node, p->pub, a)->period_ms, 20);
    uint8_t other[UB_ENTITY_ID_LEN];
    for (int i = 1; i < UB_MAX_PUBSUB_ROWS; i++) {
        memset(other, 0, sizeof other);
        other[0] = 'x';
        other[1] = (uint8_t)i;
        assert_true(ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, other, 10, 0) >= 0);
    }
    other[1] = 0xFF;
    assert_int_equal(ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, other, 10, 0), UB_ERR_FULL);
    assert_int_equal(ub_pubsub_count(p->pub_node, p->pub, UB_PS_FREE), 0);
    assert_null(ub_pubsub_row(p->pub_node, p->pub, UB_MAX_PUBSUB_ROWS));
    pair_free(p);
}

/* Searches end at the highest row ever taken (rows are taken lowest first): rows above freed ones stay
 * findable, freed rows are not, a freed row is taken again before a never-used one, and the last row of a full
 * table is found. */
static void test_find_after_rows_freed(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    uint8_t dest[UB_MAX_PUBSUB_ROWS + 3][UB_ENTITY_ID_LEN];
    memset(dest, 0, sizeof dest);
    for (int i = 0; i < UB_MAX_PUBSUB_ROWS + 3; i++) {
        dest[i][0] = 'd';
        dest[i][1] = (uint8_t)(i + 1);
    }
    for (int i = 0; i < 5; i++) assert_int_equal(ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, dest[i], 10, 0), i);
    assert_int_equal(ub_pubsub_stop(p->pub_node, p->pub, 0, 0), UB_OK);
    assert_int_equal(ub_pubsub_stop(p->pub_node, p->pub, 2, 0), UB_OK);
    assert_int_equal(ub_pubsub_find(p->pub_node, p->pub, UB_PS_PUBLICATION, TEST_GPS, dest[4]), 4);
    assert_int_equal(ub_pubsub_find(p->pub_node, p->pub, UB_PS_PUBLICATION, TEST_GPS, dest[3]), 3);
    assert_int_equal(ub_pubsub_find(p->pub_node, p->pub, UB_PS_PUBLICATION, TEST_GPS, dest[0]), UB_ERR_NOTFOUND);
    assert_int_equal(ub_pubsub_find(p->pub_node, p->pub, UB_PS_PUBLICATION, TEST_GPS, dest[2]), UB_ERR_NOTFOUND);
    assert_int_equal(ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, dest[5], 10, 0), 0);
    assert_int_equal(ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, dest[6], 10, 0), 2);
    assert_int_equal(ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, dest[7], 10, 0), 5);
    for (int i = 8; i < UB_MAX_PUBSUB_ROWS + 2; i++) /* rows 6 .. the last */
        assert_int_equal(ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, dest[i], 10, 0), i - 2);
    assert_int_equal(ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, dest[UB_MAX_PUBSUB_ROWS + 2], 10, 0), UB_ERR_FULL);
    for (int i = 3; i < UB_MAX_PUBSUB_ROWS + 2; i++)
        assert_true(ub_pubsub_find(p->pub_node, p->pub, UB_PS_PUBLICATION, TEST_GPS, dest[i]) >= 0);
    assert_int_equal(ub_pubsub_find(p->pub_node, p->pub, UB_PS_PUBLICATION, TEST_GPS, dest[UB_MAX_PUBSUB_ROWS + 1]),
                     UB_MAX_PUBSUB_ROWS - 1);
    pair_free(p);
}

/* ub_node_next_due() is exact: a loop that sleeps until the earliest due time of both nodes (as uavbus_node does)
 * wakes about once per 100 ms publication -- not every millisecond -- and the data still leaves on time. The
 * subscription's renewals are due too (its retry and renewal pace), so the bound leaves room for them; a 1 ms
 * loop would wake 2000 times. */
static void test_next_due_is_exact(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    assert_true(ub_pubsub_publish(p->pub_node, p->pub, TEST_GPS, p->sub_id, 100, 0) >= 0);
    uint64_t now = 0, wakeups = 0;
    while (now < 2000) {
        ub_node_tick(p->pub_node, now);
        ub_node_tick(p->sub_node, now);
        while (ub_memlink_pump(p->ml, now) > 0) {
        }
        uint64_t due_pub = ub_node_next_due(p->pub_node, now);
        uint64_t due_sub = ub_node_next_due(p->sub_node, now);
        /* After a tick at a publication's due time, the next one is exactly one period on. */
        if (now % 100 == 0) assert_int_equal(due_pub, now + 100);
        uint64_t due = due_pub < due_sub ? due_pub : due_sub;
        assert_true(due > now); /* nothing left undone at `now`: no busy loop */
        now = due;
        wakeups++;
    }
    assert_in_range(wakeups, 20, 40);
    assert_in_range(delivery_count(&p->log, p->sub, TEST_GPS, 0, 2000), 19, 21);
    /* Nothing published, nothing asked: nothing due (a program may sleep until its own timers or input). */
    pair_t *idle = pair_new(NULL);
    assert_int_equal(ub_node_next_due(idle->pub_node, 0), UINT64_MAX);
    pair_free(idle);
    pair_free(p);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_publication_rate_does_not_drift),
        cmocka_unit_test(test_stall_resumes_without_burst),
        cmocka_unit_test(test_subscription_requests_then_renews),
        cmocka_unit_test(test_timeout_rerequests_and_lease_heals),
        cmocka_unit_test(test_data_timeout_definition),
        cmocka_unit_test(test_restarted_publisher_heals),
        cmocka_unit_test(test_vanished_subscriber_lease_expires),
        cmocka_unit_test(test_stop_removes_both_ends),
        cmocka_unit_test(test_refused_request_backs_off),
        cmocka_unit_test(test_api_contracts),
        cmocka_unit_test(test_next_due_is_exact),
        cmocka_unit_test(test_find_after_rows_freed),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
