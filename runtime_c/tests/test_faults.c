/*
 * Faults: the Table 1 / Figure 9 scenario with 30 % loss, 10 % duplication
 * and 10 % reordering (plus delay and jitter) on every memlink, for several
 * seeds. It must converge: the admin's request is acknowledged, data flows,
 * the redundant 0x11 / 0x110 pairs deliver each message once (deliveries
 * counted by sequence number), and a stop still empties both ends.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "support/ub_test_fig9.h"
#include "ub/ub_memlink.h"
#include "ub/ub_node.h"
#include "ub/ub_pubsub.h"

static const ub_memlink_faults_t harsh = {
    .loss_ppm = 300000,
    .duplicate_ppm = 100000,
    .reorder_ppm = 100000,
    .delay_ms = 2,
    .jitter_ms = 3,
    .reorder_delay_ms = 15,
};

static uint64_t total_lost(const fig9_t *f) {
    uint64_t n = 0;
    for (size_t l = 0; l < f->w->n_links; l++)
        for (int side = 0; side < 2; side++) n += ub_memlink_stats(&f->w->links[l], side)->lost;
    return n;
}

static uint64_t total_duplicated(const fig9_t *f) {
    uint64_t n = 0;
    for (size_t l = 0; l < f->w->n_links; l++)
        for (int side = 0; side < 2; side++) n += ub_memlink_stats(&f->w->links[l], side)->duplicated;
    return n;
}

static void converge(ub_admin_row_type_t type, uint64_t seed) {
    fig9_t *f = fig9_build(&harsh, seed);
    int row = fig9_admin_row(f, type);
    (void)fig9_run_until_acked(f, row, 10000);
    /* Data flows: every frame crosses three lossy hops (one of them doubled), so
     * about 45 % of the 100 frames of 10 s arrive; demand a clear majority of that. */
    uint64_t from = f->w->now_ms + 1000;
    world_run(f->w, from + 10000, 1);
    size_t n = delivery_count(&f->log, f->ent[2], TEST_IMU, from, from + 10000);
    assert_true(n >= 25);
    assert_true(n <= 100);
    ub_admin_row_info_t info = fig9_row_info(f, row);
    assert_true(info.status == UB_ADMIN_ACTIVE || info.status == UB_ADMIN_ACKNOWLEDGED);
    assert_true(info.active_at_ms != 0);
    /* Each message once, although links duplicated and the redundant pairs doubled them. */
    assert_int_equal(delivery_repeats(&f->log), 0);
    assert_true(total_duplicated(f) > 0);
    assert_true(total_lost(f) > 0);
    uint64_t dup_drops = 0;
    for (int e = 0; e < 4; e++) dup_drops += ub_node_counters(f->node[e])->drops[UB_DROP_DUPLICATE];
    assert_true(dup_drops > 0);

    /* Stopping converges too (STOPs are retried; leases clean up whatever they miss). */
    assert_int_equal(ub_admin_set_active(&f->admin, row, false, f->w->now_ms), UB_OK);
    uint64_t stop = f->w->now_ms;
    world_run(f->w, stop + 6000, 1);
    assert_int_equal(ub_pubsub_count(f->node[3], f->ent[3], UB_PS_PUBLICATION), 0);
    assert_int_equal(ub_pubsub_count(f->node[2], f->ent[2], UB_PS_SUBSCRIPTION), 0);
    size_t before = f->log.n;
    world_run(f->w, f->w->now_ms + 3000, 5);
    assert_int_equal(f->log.n, before);
    fig9_free(f);
}

static void test_subscription_converges_under_faults(void **state) {
    (void)state;
    for (uint64_t seed = 100; seed < 104; seed++) converge(UB_ADMIN_ROW_SUBSCRIPTION, seed);
}

static void test_publication_converges_under_faults(void **state) {
    (void)state;
    for (uint64_t seed = 200; seed < 204; seed++) converge(UB_ADMIN_ROW_PUBLICATION, seed);
}

/* Same seed, same run: the fault injection is reproducible. */
static void test_faults_are_deterministic(void **state) {
    (void)state;
    uint64_t lost[2];
    size_t delivered[2];
    for (int run = 0; run < 2; run++) {
        fig9_t *f = fig9_build(&harsh, 7);
        (void)fig9_admin_row(f, UB_ADMIN_ROW_SUBSCRIPTION);
        world_run(f->w, 3000, 1);
        lost[run] = total_lost(f);
        delivered[run] = f->log.n;
        fig9_free(f);
    }
    assert_int_equal(lost[0], lost[1]);
    assert_int_equal(delivered[0], delivered[1]);
    assert_true(lost[0] > 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_subscription_converges_under_faults),
        cmocka_unit_test(test_publication_converges_under_faults),
        cmocka_unit_test(test_faults_are_deterministic),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
