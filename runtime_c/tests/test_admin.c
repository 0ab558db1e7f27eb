/*
 * The global administration table: retry until acknowledged, status read back
 * (pending, acknowledged, active, failed, stopping, inactive), NACKs, retry
 * limits, losing the target after the ACK, deactivation, and the admin being
 * the destination itself.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "support/ub_test_pair.h"
#include "ub/ub_admin.h"
#include "ub/ub_node_svc.h"
#include "ub/ub_pubsub.h"

/* The admin table sits on the "sub" entity; rows publish gpsOut from "pub" to "sub". */
static int add_row(pair_t *p, ub_admin_t *adm, ub_admin_row_type_t type, uint32_t instance) {
    ub_admin_row_spec_t spec = {.instance = instance, .period_ms = 100, .type = type};
    memcpy(spec.source, p->pub_id, UB_ENTITY_ID_LEN);
    memcpy(spec.destination, p->sub_id, UB_ENTITY_ID_LEN);
    int row = ub_admin_add_row(adm, &spec);
    assert_true(row >= 0);
    return row;
}

static ub_admin_row_info_t info_of(const ub_admin_t *adm, int row) {
    ub_admin_row_info_t info;
    assert_int_equal(ub_admin_row_status(adm, row, &info), UB_OK);
    return info;
}

static void test_retried_until_acknowledged(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_admin_t adm;
    assert_int_equal(ub_admin_init(&adm, p->sub_node, p->sub, NULL), UB_OK);
    int row = add_row(p, &adm, UB_ADMIN_ROW_PUBLICATION, TEST_GPS);
    ub_memlink_faults_t dark = {.loss_ppm = 1000000};
    ub_memlink_set_faults(p->ml, &dark);
    assert_int_equal(ub_admin_set_active(&adm, row, true, 0), UB_OK);
    world_run(p->w, 999, 1);
    ub_admin_row_info_t info = info_of(&adm, row);
    assert_int_equal(info.status, UB_ADMIN_PENDING);
    assert_int_equal(info.attempts, 5); /* t = 1, 201, 401, 601, 801 (retry_ms 200) */
    ub_memlink_set_faults(p->ml, NULL);
    world_run(p->w, 1300, 1);
    info = info_of(&adm, row);
    assert_int_equal(info.status, UB_ADMIN_ACTIVE);
    assert_true(info.acked_at_ms >= 1000 && info.acked_at_ms <= 1010);
    assert_true(info.active_at_ms >= info.acked_at_ms);
    assert_string_equal(ub_admin_status_name(info.status), "active");
    assert_true(p->log.n > 0);
    pair_free(p);
}

/* Issue #23 item 5: a status that depends on data turns stale visibly. The administrator is the destination
 * (its own node sees the data); the source keeps acknowledging the renewals while its DATA stops arriving. */
static void test_acknowledged_row_without_data_turns_stale_and_back(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_admin_t adm;
    assert_int_equal(ub_admin_init(&adm, p->sub_node, p->sub, NULL), UB_OK);
    int row = add_row(p, &adm, UB_ADMIN_ROW_PUBLICATION, TEST_GPS);
    assert_int_equal(ub_admin_set_active(&adm, row, true, 0), UB_OK);
    world_run(p->w, 1000, 1);
    assert_int_equal(info_of(&adm, row).status, UB_ADMIN_ACTIVE);
    assert_true(info_of(&adm, row).last_data_ms >= 900);
    /* DATA (88-byte frames) no longer reaches the destination, dropped `too_big` at the source; the 72-byte
     * replies still come back */
    assert_int_equal(ub_node_link_set_mtu(p->pub_node, p->pub_link, 80), UB_OK);
    uint64_t last = info_of(&adm, row).last_data_ms;
    uint64_t bound = last + UB_ADMIN_STALE_PERIODS * 100u + UB_ADMIN_STALE_MARGIN_MS;
    world_run(p->w, bound, 1);
    assert_int_equal(info_of(&adm, row).status, UB_ADMIN_ACTIVE); /* not yet */
    world_run(p->w, bound + 2, 1);
    assert_int_equal(info_of(&adm, row).status, UB_ADMIN_STALE);
    assert_string_equal(ub_admin_status_name(UB_ADMIN_STALE), "stale");
    /* renewals go on and are acknowledged, yet the row stays stale: the target's word is not the data */
    uint64_t acks = info_of(&adm, row).last_ack_ms;
    world_run(p->w, bound + 2500, 1);
    assert_true(info_of(&adm, row).last_ack_ms > acks);
    assert_int_equal(info_of(&adm, row).status, UB_ADMIN_STALE);
    /* data again: back to what the ACK said */
    assert_true(ub_node_counters(p->pub_node)->drops[UB_DROP_TOO_BIG] >= 20);
    assert_int_equal(ub_node_link_set_mtu(p->pub_node, p->pub_link, 0), UB_OK);
    world_run(p->w, bound + 2700, 1);
    assert_int_equal(info_of(&adm, row).status, UB_ADMIN_ACTIVE);
    pair_free(p);
}

/* The same for a subscription row whose destination is elsewhere: the administrator (here on the source's node)
 * cannot see the data, the destination says it: FLOWING, then (its data timed out) acknowledged without it. */
static void test_remote_subscription_row_turns_stale_when_its_destination_stops_receiving(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_admin_t adm;
    assert_int_equal(ub_admin_init(&adm, p->pub_node, p->pub, NULL), UB_OK);
    static struct test_imu imu_src, imu_dst; /* imuOut: 92-byte frames */
    assert_int_equal(ub_node_bind(p->pub_node, TEST_IMU, &imu_src), UB_OK);
    assert_int_equal(ub_node_bind(p->sub_node, TEST_IMU, &imu_dst), UB_OK);
    ub_admin_row_spec_t spec = {.instance = TEST_IMU, .period_ms = 100, .type = UB_ADMIN_ROW_SUBSCRIPTION};
    memcpy(spec.source, p->pub_id, UB_ENTITY_ID_LEN);
    memcpy(spec.destination, p->sub_id, UB_ENTITY_ID_LEN);
    int row = ub_admin_add_row(&adm, &spec);
    assert_true(row >= 0);
    assert_int_equal(ub_admin_set_active(&adm, row, true, 0), UB_OK);
    world_run(p->w, 2000, 1);
    assert_int_equal(info_of(&adm, row).status, UB_ADMIN_ACTIVE);
    /* DATA (92 bytes) stops; requests (88) and replies (72) pass */
    assert_int_equal(ub_node_link_set_mtu(p->pub_node, p->pub_link, 90), UB_OK);
    world_run(p->w, 6000, 1);
    assert_true(ub_node_counters(p->pub_node)->drops[UB_DROP_TOO_BIG] >= 30);
    assert_int_equal(info_of(&adm, row).status, UB_ADMIN_STALE);
    assert_true(info_of(&adm, row).last_ack_ms >= 5000); /* still renewed and acknowledged */
    assert_int_equal(ub_node_link_set_mtu(p->pub_node, p->pub_link, 0), UB_OK);
    world_run(p->w, 8000, 1);
    assert_int_equal(info_of(&adm, row).status, UB_ADMIN_ACTIVE);
    pair_free(p);
}

static void test_nack_fails_row_and_reactivation_retries(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_admin_t adm;
    assert_int_equal(ub_admin_init(&adm, p->sub_node, p->sub, NULL), UB_OK);
    int row = add_row(p, &adm, UB_ADMIN_ROW_PUBLICATION, TEST_IMU); /* not bound at the source */
    assert_int_equal(ub_admin_set_active(&adm, row, true, 0), UB_OK);
    world_run(p->w, 100, 1);
    ub_admin_row_info_t info = info_of(&adm, row);
    assert_int_equal(info.status, UB_ADMIN_FAILED);
    assert_int_equal(info.nack_reason, UB_NACK_UNBOUND);
    /* The source binds it; the operator activates the row again. */
    struct test_imu imu = {0};
    assert_int_equal(ub_node_bind(p->pub_node, TEST_IMU, &imu), UB_OK);
    assert_int_equal(ub_admin_set_active(&adm, row, true, p->w->now_ms), UB_OK);
    world_run(p->w, 300, 1);
    info = info_of(&adm, row);
    assert_int_equal(info.status, UB_ADMIN_ACTIVE);
    assert_int_equal(info.nack_reason, UB_NACK_NONE);
    pair_free(p);
}

static void test_retry_limit_fails_row(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_admin_t adm;
    ub_admin_options_t opt = {.retry_ms = 50, .max_retries = 4};
    assert_int_equal(ub_admin_init(&adm, p->sub_node, p->sub, &opt), UB_OK);
    int row = add_row(p, &adm, UB_ADMIN_ROW_PUBLICATION, TEST_GPS);
    ub_memlink_faults_t dark = {.loss_ppm = 1000000};
    ub_memlink_set_faults(p->ml, &dark);
    assert_int_equal(ub_admin_set_active(&adm, row, true, 0), UB_OK);
    world_run(p->w, 1000, 1);
    ub_admin_row_info_t info = info_of(&adm, row);
    assert_int_equal(info.status, UB_ADMIN_FAILED);
    assert_int_equal(info.nack_reason, UB_NACK_NONE);
    assert_int_equal(ub_memlink_stats(p->ml, 1)->sent, 4);
    pair_free(p);
}

static void test_target_lost_after_ack_falls_back_to_pending(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_admin_t adm;
    assert_int_equal(ub_admin_init(&adm, p->sub_node, p->sub, NULL), UB_OK);
    int row = add_row(p, &adm, UB_ADMIN_ROW_PUBLICATION, TEST_GPS);
    assert_int_equal(ub_admin_set_active(&adm, row, true, 0), UB_OK);
    world_run(p->w, 500, 1);
    assert_int_equal(info_of(&adm, row).status, UB_ADMIN_ACTIVE);
    ub_memlink_faults_t dark = {.loss_ppm = 1000000};
    ub_memlink_set_faults(p->ml, &dark);
    world_run(p->w, 500 + 3000 + 300, 1); /* no ACK for longer than the lease (3 s) */
    assert_int_equal(info_of(&adm, row).status, UB_ADMIN_PENDING);
    ub_memlink_set_faults(p->ml, NULL);
    world_run(p->w, p->w->now_ms + 500, 1);
    assert_int_equal(info_of(&adm, row).status, UB_ADMIN_ACTIVE);
    pair_free(p);
}

static void test_deactivate_stops_and_row_reads_back(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_admin_t adm;
    assert_int_equal(ub_admin_init(&adm, p->sub_node, p->sub, NULL), UB_OK);
    int row = add_row(p, &adm, UB_ADMIN_ROW_PUBLICATION, TEST_GPS);
    assert_int_equal(ub_admin_remove_row(&adm, 5), UB_ERR_NOTFOUND);
    assert_int_equal(ub_admin_set_active(&adm, row, true, 0), UB_OK);
    world_run(p->w, 500, 1);
    assert_int_equal(ub_admin_remove_row(&adm, row), UB_ERR_INVAL); /* still active */
    ub_admin_row_info_t info = info_of(&adm, row);
    assert_true(info.active_flag);
    assert_int_equal(info.spec.period_ms, 100);
    assert_memory_equal(info.spec.source, p->pub_id, UB_ENTITY_ID_LEN);
    assert_int_equal(ub_admin_set_active(&adm, row, false, p->w->now_ms), UB_OK);
    assert_int_equal(info_of(&adm, row).status, UB_ADMIN_STOPPING);
    world_run(p->w, 600, 1);
    assert_int_equal(info_of(&adm, row).status, UB_ADMIN_INACTIVE);
    assert_int_equal(ub_pubsub_count(p->pub_node, p->pub, UB_PS_PUBLICATION), 0);
    assert_int_equal(ub_admin_remove_row(&adm, row), UB_OK);
    assert_int_equal(ub_admin_row_status(&adm, row, &info), UB_ERR_NOTFOUND);
    pair_free(p);
}

/* A subscription row whose destination is the admin's own entity: the SUB_REQUEST is handed over locally. */
static void test_admin_as_destination_subscribes(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_admin_t adm;
    assert_int_equal(ub_admin_init(&adm, p->sub_node, p->sub, NULL), UB_OK);
    int row = add_row(p, &adm, UB_ADMIN_ROW_SUBSCRIPTION, TEST_GPS);
    assert_int_equal(ub_admin_set_active(&adm, row, true, 0), UB_OK);
    world_run(p->w, 1000, 1);
    assert_int_equal(info_of(&adm, row).status, UB_ADMIN_ACTIVE);
    assert_true(ub_pubsub_find(p->sub_node, p->sub, UB_PS_SUBSCRIPTION, TEST_GPS, p->pub_id) >= 0);
    assert_in_range(delivery_count(&p->log, p->sub, TEST_GPS, 500, 1000), 4, 6);
    assert_int_equal(ub_admin_set_active(&adm, row, false, p->w->now_ms), UB_OK);
    world_run(p->w, 1500, 1);
    assert_int_equal(info_of(&adm, row).status, UB_ADMIN_INACTIVE);
    assert_int_equal(ub_pubsub_count(p->sub_node, p->sub, UB_PS_SUBSCRIPTION), 0);
    assert_int_equal(ub_pubsub_count(p->pub_node, p->pub, UB_PS_PUBLICATION), 0);
    ub_admin_detach(&adm);
    pair_free(p);
}

static void test_row_validation(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_admin_t adm;
    assert_int_equal(ub_admin_init(&adm, p->sub_node, p->sub_peer, NULL), UB_ERR_INVAL); /* not local */
    assert_int_equal(ub_admin_init(&adm, p->sub_node, p->sub, NULL), UB_OK);
    ub_admin_row_spec_t spec = {.instance = TEST_GPS, .period_ms = 100, .type = UB_ADMIN_ROW_PUBLICATION};
    memcpy(spec.source, p->pub_id, UB_ENTITY_ID_LEN);
    memcpy(spec.destination, p->pub_id, UB_ENTITY_ID_LEN);
    assert_int_equal(ub_admin_add_row(&adm, &spec), UB_ERR_INVAL); /* source == destination */
    memcpy(spec.destination, p->sub_id, UB_ENTITY_ID_LEN);
    spec.period_ms = 0;
    assert_int_equal(ub_admin_add_row(&adm, &spec), UB_ERR_INVAL);
    spec.period_ms = 100;
    spec.instance = 9;
    assert_int_equal(ub_admin_add_row(&adm, &spec), UB_ERR_INVAL);
    spec.instance = TEST_GPS;
    assert_int_equal(ub_admin_add_row(&adm, &spec), 0);
    /* One flow, one row, whatever the type or rate: two would fight over the target's row. */
    spec.type = UB_ADMIN_ROW_SUBSCRIPTION;
    spec.period_ms = 500;
    assert_int_equal(ub_admin_add_row(&adm, &spec), UB_ERR_EXISTS);
    for (int i = 1; i < UB_MAX_ADMIN_ROWS; i++) {
        spec.destination[UB_ENTITY_ID_LEN - 1] = (uint8_t)i; /* other destinations: other flows */
        assert_int_equal(ub_admin_add_row(&adm, &spec), i);
    }
    spec.destination[UB_ENTITY_ID_LEN - 1] = 0xFF;
    assert_int_equal(ub_admin_add_row(&adm, &spec), UB_ERR_FULL);
    assert_string_equal(ub_admin_status_name((ub_admin_status_t)42), "?");
    pair_free(p);
}

/* Every table of a node carries the mask of its slots with an administration table (admin_slots): DATA
 * delivered to any slot asks exactly those tables, and a node without one asks none. Attach on two slots, a
 * second attach on the same slot, detaches in either order. */
static uint32_t slots_seen(const ub_node_t *node) {
    uint32_t mask = ub_node_svc_pubsub_table(node, 0)->admin_slots;
    for (int s = 1; s < UB_MAX_LOCAL_ENTITIES; s++) assert_int_equal(ub_node_svc_pubsub_table(node, s)->admin_slots, mask);
    return mask;
}

static void test_admin_slots_follow_attach_and_detach(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    uint8_t ops_id[UB_ENTITY_ID_LEN] = {0x0F, 0x05, 0x02, 0x08};
    int ops = ub_node_add_entity(p->sub_node, ops_id, true);
    assert_true(ops >= 0);
    int sub_slot = ub_node_entity_slot(p->sub_node, p->sub), ops_slot = ub_node_entity_slot(p->sub_node, ops);
    assert_true(sub_slot >= 0 && ops_slot >= 0 && sub_slot != ops_slot);
    assert_int_equal(slots_seen(p->sub_node), 0);
    ub_admin_t a, b, c;
    assert_int_equal(ub_admin_init(&a, p->sub_node, ops, NULL), UB_OK);
    assert_int_equal(slots_seen(p->sub_node), 1u << ops_slot);
    assert_int_equal(ub_admin_init(&b, p->sub_node, p->sub, NULL), UB_OK);
    assert_int_equal(slots_seen(p->sub_node), (1u << ops_slot) | (1u << sub_slot));
    assert_int_equal(ub_admin_init(&c, p->sub_node, p->sub, NULL), UB_OK); /* replaces b on that slot */
    ub_admin_detach(&b);                                                  /* no longer attached: changes nothing */
    assert_int_equal(slots_seen(p->sub_node), (1u << ops_slot) | (1u << sub_slot));
    ub_admin_detach(&a);
    assert_int_equal(slots_seen(p->sub_node), 1u << sub_slot);
    ub_admin_detach(&c);
    assert_int_equal(slots_seen(p->sub_node), 0);
    assert_int_equal(slots_seen(p->pub_node), 0); /* the other node never had one */
    pair_free(p);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_retried_until_acknowledged),
        cmocka_unit_test(test_acknowledged_row_without_data_turns_stale_and_back),
        cmocka_unit_test(test_remote_subscription_row_turns_stale_when_its_destination_stops_receiving),
        cmocka_unit_test(test_nack_fails_row_and_reactivation_retries),
        cmocka_unit_test(test_retry_limit_fails_row),
        cmocka_unit_test(test_target_lost_after_ack_falls_back_to_pending),
        cmocka_unit_test(test_deactivate_stops_and_row_reads_back),
        cmocka_unit_test(test_admin_as_destination_subscribes),
        cmocka_unit_test(test_row_validation),
        cmocka_unit_test(test_admin_slots_follow_attach_and_detach),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
