/*
 * Layout mismatch: a sender built from a changed struct definition (gpsOut
 * with a double altitude: other fingerprint, other size) sends DATA; the
 * receiver rejects and counts it and its bound instance stays byte-for-byte
 * untouched. A request from such a build is refused with NACK(layout), so the
 * operator sees "failed" instead of silent loss.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "support/ub_test_world.h"
#include "ub/ub_admin.h"
#include "ub/ub_node.h"

typedef struct pair {
    world_t *w;
    ub_node_t *old_build, *new_build;
    int old_e, new_e, old_link;
    uint8_t old_id[UB_ENTITY_ID_LEN], new_id[UB_ENTITY_ID_LEN];
} builds_t;

static builds_t build_builds(void) {
    builds_t p;
    p.w = world_new();
    test_eid("receiver", p.old_id);
    test_eid("changed", p.new_id);
    p.old_build = world_node(p.w, &ub_test_cat, NULL);
    p.new_build = world_node(p.w, &ub_test_cat_changed, NULL);
    p.old_e = ub_node_add_entity(p.old_build, p.old_id, true);
    int peer = ub_node_add_entity(p.old_build, p.new_id, false);
    p.new_e = ub_node_add_entity(p.new_build, p.new_id, true);
    int back = ub_node_add_entity(p.new_build, p.old_id, false);
    p.old_link = ub_node_add_link(p.old_build, p.old_e, 0, "toChanged");
    int nl = ub_node_add_link(p.new_build, p.new_e, 0, "toReceiver");
    assert_int_equal(ub_node_set_mask(p.old_build, p.old_e, peer, 0x01), UB_OK);
    assert_int_equal(ub_node_set_mask(p.new_build, p.new_e, back, 0x01), UB_OK);
    world_connect(p.w, p.old_build, p.old_link, p.new_build, nl, NULL, 0);
    return p;
}

static void test_changed_definition_is_rejected_and_storage_untouched(void **state) {
    (void)state;
    builds_t p = build_builds();
    struct test_gps_v2 sent = {33.7756, -84.3963, 287.5, 3};
    assert_int_equal(ub_node_bind(p.new_build, TEST_GPS, &sent), UB_OK);
    struct test_gps received;
    memset(&received, 0xA5, sizeof received);
    struct test_gps snapshot;
    memcpy(&snapshot, &received, sizeof snapshot);
    assert_int_equal(ub_node_bind(p.old_build, TEST_GPS, &received), UB_OK);

    for (int i = 0; i < 5; i++) assert_int_equal(ub_node_send_data(p.new_build, p.new_e, TEST_GPS, p.old_id, i), 1);
    world_run(p.w, 20, 1);

    assert_memory_equal(&received, &snapshot, sizeof received);
    assert_int_equal(ub_node_counters(p.old_build)->drops[UB_DROP_LAYOUT_MISMATCH], 5);
    assert_int_equal(ub_node_link(p.old_build, p.old_link)->counters.drops[UB_DROP_LAYOUT_MISMATCH], 5);
    assert_int_equal(ub_node_counters(p.old_build)->delivered, 0);

    /* Control: the same receiver accepts the matching definition (so the rejection was the layout). */
    struct test_imu imu_src = {{1, 2, 3}, {4, 5, 6}, 7}, imu_dst;
    memset(&imu_dst, 0, sizeof imu_dst);
    assert_int_equal(ub_node_bind(p.new_build, TEST_IMU, &imu_src), UB_OK);
    assert_int_equal(ub_node_bind(p.old_build, TEST_IMU, &imu_dst), UB_OK);
    assert_int_equal(ub_node_send_data(p.new_build, p.new_e, TEST_IMU, p.old_id, 30), 1);
    world_run(p.w, 40, 1);
    assert_memory_equal(&imu_dst, &imu_src, sizeof imu_src);
    assert_int_equal(ub_node_counters(p.old_build)->delivered, 1);
    free(p.w);
}

static void test_request_across_layouts_is_nacked(void **state) {
    (void)state;
    builds_t p = build_builds();
    struct test_gps gps = {0};
    struct test_gps_v2 gps_v2 = {0};
    assert_int_equal(ub_node_bind(p.old_build, TEST_GPS, &gps), UB_OK);
    assert_int_equal(ub_node_bind(p.new_build, TEST_GPS, &gps_v2), UB_OK);
    ub_admin_t adm;
    assert_int_equal(ub_admin_init(&adm, p.old_build, p.old_e, NULL), UB_OK);
    ub_admin_row_spec_t spec = {.instance = TEST_GPS, .period_ms = 100, .type = UB_ADMIN_ROW_PUBLICATION};
    memcpy(spec.source, p.new_id, UB_ENTITY_ID_LEN);
    memcpy(spec.destination, p.old_id, UB_ENTITY_ID_LEN);
    int row = ub_admin_add_row(&adm, &spec);
    assert_true(row >= 0);
    assert_int_equal(ub_admin_set_active(&adm, row, true, 0), UB_OK);
    world_run(p.w, 100, 1);
    ub_admin_row_info_t info;
    assert_int_equal(ub_admin_row_status(&adm, row, &info), UB_OK);
    assert_int_equal(info.status, UB_ADMIN_FAILED);
    assert_int_equal(info.nack_reason, UB_NACK_LAYOUT);
    assert_int_equal(ub_pubsub_count(p.new_build, p.new_e, UB_PS_PUBLICATION), 0);
    free(p.w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_changed_definition_is_rejected_and_storage_untouched),
        cmocka_unit_test(test_request_across_layouts_is_nacked),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
