/*
 * The paper's Table 1 / Figure 9, as published: 4 entities in 3 nodes, the
 * table's exact link masks (parsed from the paper's hex strings), in one
 * process over memlinks. Entities 0 and 1 share node A, yet their
 * e0Toe1/e1Toe0 link still exists (a memlink from node A to itself).
 *
 *   node A: Entity 0 (e0Toe1, e0Toe3a, e0Toe3b) + Entity 1 (e1Toe0, e1Toe2), admin table on Entity 1
 *   node B: Entity 2 (e2Toe1)
 *   node C: Entity 3 (e3Toe0a, e3Toe0b)
 *
 * A subscription of Entity 2 to Entity 3's imuOut (path 2->1->0->3) and a
 * publication from 3 to 2 are set up from the administration table; each must
 * deliver at the requested rate within two periods of the acknowledgement,
 * and stopping must end the traffic and remove the entries at both ends.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "support/ub_test_fig9.h"
#include "ub/ub_admin.h"
#include "ub/ub_link.h"
#include "ub/ub_node.h"
#include "ub/ub_pubsub.h"

static void test_paper_masks_parse_as_published(void **state) {
    (void)state;
    uint8_t m;
    assert_int_equal(ub_link_mask_parse("0x00000110", &m), UB_OK);
    assert_int_equal(m, 0x06); /* links 1 and 2 */
    assert_int_equal(ub_link_mask_parse("0x00000011", &m), UB_OK);
    assert_int_equal(m, 0x03);
    assert_int_equal(ub_link_mask_parse("0x000000011", &m), UB_OK); /* Figure 8 prints 9 digits */
    assert_int_equal(m, 0x03);
    assert_int_equal(ub_link_mask_parse("0x00001000", &m), UB_OK);
    assert_int_equal(m, 0x08);
    assert_int_equal(ub_link_mask_parse("0x00000000", &m), UB_OK);
    assert_int_equal(m, 0x00);
    assert_int_equal(ub_link_mask_parse("0x00000002", &m), UB_ERR_INVAL);
    assert_int_equal(ub_link_mask_parse("00000110", &m), UB_ERR_INVAL);
    assert_int_equal(ub_link_mask_parse("0x", &m), UB_ERR_INVAL);
    assert_int_equal(ub_link_mask_parse("0x100000000", &m), UB_ERR_RANGE);
    char text[11];
    ub_link_mask_format(0x06, text);
    assert_string_equal(text, "0x00000110");
}

static void check_rate_and_stop(fig9_t *f, int row, uint64_t acked_ms) {
    /* Within two periods after the acknowledgement, data arrives ... */
    world_run(f->w, acked_ms + 2 * PERIOD_MS, 1);
    assert_true(fig9_first_delivery_after(f, acked_ms) <= acked_ms + 2 * PERIOD_MS);
    /* ... and keeps arriving at the requested rate: 20 periods, 20 frames (+-1 for phase). */
    uint64_t from = f->w->now_ms;
    world_run(f->w, from + 20 * PERIOD_MS, 1);
    size_t n = delivery_count(&f->log, f->ent[2], TEST_IMU, from, from + 20 * PERIOD_MS);
    assert_in_range(n, 19, 21);
    assert_memory_equal(&f->imu_dst, &f->imu_src, sizeof f->imu_src);
    assert_int_equal(fig9_row_info(f, row).status, UB_ADMIN_ACTIVE);
    /* The redundant 0x11 / 0x110 pairs carried two copies; each was delivered once. */
    assert_int_equal(delivery_repeats(&f->log), 0);
    assert_true(ub_node_counters(f->node[0])->drops[UB_DROP_DUPLICATE] > 0);

    /* Stop: the traffic ends and the entries at both ends are gone. */
    assert_int_equal(ub_admin_set_active(&f->admin, row, false, f->w->now_ms), UB_OK);
    uint64_t stop = f->w->now_ms;
    world_run(f->w, stop + 500, 1);
    assert_int_equal(fig9_row_info(f, row).status, UB_ADMIN_INACTIVE);
    assert_int_equal(ub_pubsub_count(f->node[3], f->ent[3], UB_PS_PUBLICATION), 0);
    assert_int_equal(ub_pubsub_count(f->node[2], f->ent[2], UB_PS_SUBSCRIPTION), 0);
    size_t before = f->log.n;
    world_run(f->w, stop + 5000, 5); /* longer than every lease and renewal */
    assert_int_equal(f->log.n, before);
    assert_int_equal(ub_pubsub_count(f->node[3], f->ent[3], UB_PS_FREE), UB_MAX_PUBSUB_ROWS);
    assert_int_equal(ub_pubsub_count(f->node[2], f->ent[2], UB_PS_FREE), UB_MAX_PUBSUB_ROWS);
}

static void test_subscription_from_entity1_admin(void **state) {
    (void)state;
    fig9_t *f = fig9_build(NULL, 1);
    int row = fig9_admin_row(f, UB_ADMIN_ROW_SUBSCRIPTION);
    uint64_t acked = fig9_run_until_acked(f, row, 2000);
    /* The destination holds the subscription, the source the publication it asked for. */
    world_run(f->w, acked + 50, 1);
    int sub = ub_pubsub_find(f->node[2], f->ent[2], UB_PS_SUBSCRIPTION, TEST_IMU, f->id[3]);
    assert_true(sub >= 0);
    assert_true(ub_pubsub_find(f->node[3], f->ent[3], UB_PS_PUBLICATION, TEST_IMU, f->id[2]) >= 0);
    /* The request went 2 -> 1 -> 0 -> 3: node A relayed it. */
    assert_true(ub_node_counters(f->node[0])->forwarded > 0);
    check_rate_and_stop(f, row, acked);
    fig9_free(f);
}

static void test_publication_from_entity1_admin(void **state) {
    (void)state;
    fig9_t *f = fig9_build(NULL, 11);
    int row = fig9_admin_row(f, UB_ADMIN_ROW_PUBLICATION);
    uint64_t acked = fig9_run_until_acked(f, row, 2000);
    assert_true(ub_pubsub_find(f->node[3], f->ent[3], UB_PS_PUBLICATION, TEST_IMU, f->id[2]) >= 0);
    /* A publication creates no subscription at the destination. */
    assert_int_equal(ub_pubsub_count(f->node[2], f->ent[2], UB_PS_SUBSCRIPTION), 0);
    check_rate_and_stop(f, row, acked);
    fig9_free(f);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_paper_masks_parse_as_published),
        cmocka_unit_test(test_subscription_from_entity1_admin),
        cmocka_unit_test(test_publication_from_entity1_admin),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
