/*
 * Authorization of the administration plane (ub_policy.h, docs/pubsub.md "Authorization and limits"): each
 * attack of issue #11 on the admin plane, forged by a rogue on veh1's radio link, must fail and be counted,
 * while the legitimate flows (the administrator gcs1, the subscriber obs1) keep working. World: support/
 * ub_test_authz.h. The rogue is "mallory", an entity no policy lists; some tests also let it claim other
 * non-administrator names, which signing (trust-wire) will stop but authorization alone must survive.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "support/ub_test_authz.h"
#include "ub/ub_admin.h"
#include "ub/ub_policy.h"
#include "ub/ub_pubsub.h"
#include "ub/ub_member.h"
#include "ub/ub_random.h"
#include "ub/ub_sec.h"
#include "ub/ub_wire.h"

static uint8_t g_id[4][UB_ENTITY_ID_LEN];

static const uint8_t *eid(int k, const char *name) {
    test_eid(name, g_id[k]);
    return g_id[k];
}

static const ub_node_counters_t *counters(const ub_node_t *n) { return ub_node_counters(n); }

static int admin_row(authz_t *a, const char *content, const char *source, const char *destination, uint32_t period,
                     ub_admin_row_type_t type) {
    ub_admin_row_spec_t spec = {.instance = authz_instance(a, content), .period_ms = period, .type = type};
    test_eid(source, spec.source);
    test_eid(destination, spec.destination);
    int row = ub_admin_add_row(&a->admin, &spec);
    assert_true(row >= 0);
    assert_int_equal(ub_admin_set_active(&a->admin, row, true, a->w.now_ms), UB_OK);
    return row;
}

static ub_admin_row_info_t info(const authz_t *a, int row) {
    ub_admin_row_info_t i;
    assert_int_equal(ub_admin_row_status(&a->admin, row, &i), UB_OK);
    return i;
}

static const ub_ps_row_t *veh_row(const authz_t *a, ub_ps_kind_t kind, const char *content, const char *peer) {
    int r = ub_pubsub_find(a->veh, a->e_veh, kind, authz_instance(a, content), eid(3, peer));
    return r >= 0 ? ub_pubsub_row(a->veh, a->e_veh, r) : NULL;
}

static void run(authz_t *a, uint64_t ms) { world_run(&a->w, a->w.now_ms + ms, 1); }

/* ---- replies bound to their row ------------------------------------------------------------- */

static void test_forged_replies_ignored_and_counted(void **state) {
    (void)state;
    authz_t *a = authz_new(11);
    uint32_t gps = authz_instance(a, "gpsOut"), imu = authz_instance(a, "imuOut");
    int row = admin_row(a, "gpsOut", "veh1", "gcs1", 100, UB_ADMIN_ROW_PUBLICATION);
    run(a, 500);
    assert_int_equal(info(a, row).status, UB_ADMIN_ACTIVE);
    uint32_t id = info(a, row).request_id;
    uint64_t base = counters(a->gcs)->replies_unmatched;

    /* Guessed ids (what worked against ids 1, 2, 3...), the real id overheard by another entity, and the
     * real id from the real target about another content: none is the row's reply. */
    for (uint32_t k = 1; k <= 16; k++)
        authz_reply(a, true, gps, "mallory", "gcs1", k, UB_ADMIN_PUB_REQUEST, UB_NACK_TABLE_FULL);
    authz_reply(a, true, gps, "mallory", "gcs1", id, UB_ADMIN_PUB_REQUEST, UB_NACK_TABLE_FULL);
    authz_reply(a, true, gps, "obs1", "gcs1", id, UB_ADMIN_PUB_REQUEST, UB_NACK_TABLE_FULL);
    authz_reply(a, true, imu, "veh1", "gcs1", id, UB_ADMIN_PUB_REQUEST, UB_NACK_TABLE_FULL);
    assert_int_equal(info(a, row).status, UB_ADMIN_ACTIVE);
    assert_int_equal(info(a, row).nack_reason, UB_NACK_NONE);
    assert_int_equal(counters(a->gcs)->replies_unmatched - base, 19);
    run(a, 500);
    assert_int_equal(info(a, row).status, UB_ADMIN_ACTIVE);

    /* A forged ACK does not make a pending row look acknowledged. */
    ub_memlink_faults_t dark = {.loss_ppm = 1000000};
    ub_memlink_set_faults(&a->w.links[0], &dark);
    int pending = admin_row(a, "imuOut", "veh1", "gcs1", 100, UB_ADMIN_ROW_PUBLICATION);
    run(a, 300);
    uint32_t pid = info(a, pending).request_id;
    authz_reply(a, false, imu, "mallory", "gcs1", pid, UB_ADMIN_PUB_REQUEST, UB_ACK_FLOWING);
    assert_int_equal(info(a, pending).status, UB_ADMIN_PENDING);
    ub_memlink_set_faults(&a->w.links[0], NULL);

    /* The same binding protects a subscriber's row. */
    int sub = ub_pubsub_subscribe(a->obs, a->e_obs, gps, eid(0, "veh1"), 100, a->w.now_ms);
    assert_true(sub >= 0);
    run(a, 500);
    const ub_ps_row_t *srow = ub_pubsub_row(a->obs, a->e_obs, sub);
    assert_int_equal(srow->state, UB_SUB_RECEIVING);
    uint64_t due = srow->next_due_ms, obs_base = counters(a->obs)->replies_unmatched;
    authz_reply(a, true, gps, "mallory", "obs1", srow->request_id, UB_ADMIN_PUB_REQUEST, UB_NACK_UNBOUND);
    authz_reply(a, false, gps, "mallory", "obs1", srow->request_id, UB_ADMIN_PUB_STOP, 0);
    assert_int_equal(counters(a->obs)->replies_unmatched - obs_base, 2);
    assert_int_equal(srow->acked, 1);
    assert_int_equal(srow->next_due_ms, due);
    assert_int_equal(srow->kind, UB_PS_SUBSCRIPTION);

    /* Binding refuses nothing genuine: the target's own NACK still fails the row, reported by name. */
    authz_reply(a, true, gps, "veh1", "gcs1", id, UB_ADMIN_PUB_REQUEST, UB_NACK_LIMIT);
    assert_int_equal(info(a, row).status, UB_ADMIN_FAILED);
    assert_int_equal(info(a, row).nack_reason, UB_NACK_LIMIT);
    assert_string_equal(ub_nack_reason_name(info(a, row).nack_reason), "limit");
    assert_string_equal(ub_nack_reason_name(UB_NACK_NOT_AUTHORIZED), "not_authorized");
    assert_string_equal(ub_nack_reason_name((ub_nack_reason_t)99), "?");
    free(a);
}

/* ---- STOPs ---------------------------------------------------------------------------------- */

static void test_forged_stops_refused(void **state) {
    (void)state;
    authz_t *a = authz_new(21);
    uint32_t gps = authz_instance(a, "gpsOut"), imu = authz_instance(a, "imuOut"), c0 = authz_instance(a, "cell00");
    /* veh1's own configured row, an administrator's row, and obs1's subscription. */
    assert_true(ub_pubsub_publish(a->veh, a->e_veh, gps, eid(0, "obs1"), 100, 0) >= 0);
    int row = admin_row(a, "imuOut", "veh1", "gcs1", 100, UB_ADMIN_ROW_PUBLICATION);
    int sub = ub_pubsub_subscribe(a->obs, a->e_obs, c0, eid(0, "veh1"), 100, 0);
    run(a, 500);
    assert_int_equal(info(a, row).status, UB_ADMIN_ACTIVE);
    uint32_t admin_id = info(a, row).request_id;
    uint32_t obs_id = ub_pubsub_row(a->obs, a->e_obs, sub)->request_id;
    assert_non_null(veh_row(a, UB_PS_PUBLICATION, "cell00", "obs1"));

    authz_stop(a, UB_ADMIN_PUB_STOP, gps, "mallory", "obs1", 0);           /* someone else's data */
    authz_stop(a, UB_ADMIN_PUB_STOP, imu, "mallory", "gcs1", admin_id);    /* with the overheard id */
    authz_stop(a, UB_ADMIN_SUB_STOP, gps, "mallory", "obs1", 0);           /* exclusive rights */
    authz_stop(a, UB_ADMIN_PUB_STOP, gps, "obs1", "obs1", 0);              /* a local row, even to its receiver */
    authz_stop(a, UB_ADMIN_PUB_STOP, c0, "obs1", "obs1", obs_id + 1);      /* obs1's row, not its request id */
    assert_int_equal(counters(a->veh)->drops[UB_DROP_NOT_AUTHORIZED], 5);
    assert_int_equal(a->veh->links[a->veh_link_rogue].counters.drops[UB_DROP_NOT_AUTHORIZED], 5);
    assert_int_equal(a->rogue.nacks[UB_NACK_NOT_AUTHORIZED], 3); /* the other two went to obs1 */
    assert_non_null(veh_row(a, UB_PS_PUBLICATION, "gpsOut", "obs1"));
    assert_non_null(veh_row(a, UB_PS_PUBLICATION, "imuOut", "gcs1"));
    assert_non_null(veh_row(a, UB_PS_PUBLICATION, "cell00", "obs1"));
    size_t before = delivery_count(&a->gcs_log, a->e_gcs, imu, 0, UINT64_MAX);
    run(a, 500);
    assert_int_equal(info(a, row).status, UB_ADMIN_ACTIVE);
    assert_in_range(delivery_count(&a->gcs_log, a->e_gcs, imu, 0, UINT64_MAX) - before, 4, 6);

    /* The owner's own STOP (bound to its request id) is honoured ... */
    assert_int_equal(ub_pubsub_stop(a->obs, a->e_obs, sub, a->w.now_ms), UB_OK);
    run(a, 300);
    assert_null(veh_row(a, UB_PS_PUBLICATION, "cell00", "obs1"));
    /* ... and an administrator may stop any row, a local one included (its exclusive rights). */
    assert_int_equal(ub_admin_set_active(&a->admin, row, false, a->w.now_ms), UB_OK);
    run(a, 300);
    assert_int_equal(info(a, row).status, UB_ADMIN_INACTIVE);
    assert_null(veh_row(a, UB_PS_PUBLICATION, "imuOut", "gcs1"));
    authz_stop(a, UB_ADMIN_PUB_STOP, gps, "gcs1", "obs1", 0);
    assert_null(veh_row(a, UB_PS_PUBLICATION, "gpsOut", "obs1"));
    assert_int_equal(counters(a->veh)->drops[UB_DROP_NOT_AUTHORIZED], 5);
    free(a);
}

/* ---- exclusive rights ----------------------------------------------------------------------- */

static void test_non_admin_sub_and_foreign_pub_requests_refused(void **state) {
    (void)state;
    authz_t *a = authz_new(31);
    uint32_t gps = authz_instance(a, "gpsOut");
    authz_request(a, UB_ADMIN_SUB_REQUEST, gps, "mallory", "obs1", 100, 3000, 77); /* make veh1 subscribe */
    authz_request(a, UB_ADMIN_PUB_REQUEST, gps, "mallory", "gcs1", 100, 3000, 78); /* data to someone else */
    assert_int_equal(a->rogue.nacks[UB_NACK_NOT_AUTHORIZED], 2);
    assert_int_equal(a->rogue.acks, 0);
    assert_int_equal(counters(a->veh)->drops[UB_DROP_NOT_AUTHORIZED], 2);
    assert_int_equal(ub_pubsub_count(a->veh, a->e_veh, UB_PS_SUBSCRIPTION), 0);
    assert_int_equal(ub_pubsub_count(a->veh, a->e_veh, UB_PS_PUBLICATION), 0);
    run(a, 500);
    assert_int_equal(a->rogue.data, 0);
    assert_int_equal(a->gcs_log.n, 0);
    /* The administrator's identical requests are served. */
    authz_request(a, UB_ADMIN_SUB_REQUEST, gps, "gcs1", "obs1", 100, 3000, 79);
    authz_request(a, UB_ADMIN_PUB_REQUEST, gps, "gcs1", "obs1", 100, 3000, 80);
    assert_int_equal(ub_pubsub_count(a->veh, a->e_veh, UB_PS_SUBSCRIPTION), 1);
    assert_int_equal(ub_pubsub_count(a->veh, a->e_veh, UB_PS_PUBLICATION), 1);
    assert_int_equal(counters(a->veh)->drops[UB_DROP_NOT_AUTHORIZED], 2);
    free(a);
}

/* ---- amplification -------------------------------------------------------------------------- */

static void test_amplification_bounded(void **state) {
    (void)state;
    authz_t *a = authz_new(41);
    ub_policy_limits_t lim = {.max_lease_ms = 2000};
    assert_int_equal(ub_policy_set_limits(&a->policy, &lim), UB_OK);
    uint32_t gps = authz_instance(a, "gpsOut");
    /* The 88-byte request: 1 ms period, lease 0. Refused, nothing created, nothing sent. */
    authz_request(a, UB_ADMIN_PUB_REQUEST, gps, "mallory", "mallory", 1, 0, 5);
    assert_int_equal(a->rogue.nacks[UB_NACK_LIMIT], 1);
    assert_int_equal(counters(a->veh)->requests_limited, 1);
    assert_int_equal(ub_pubsub_count(a->veh, a->e_veh, UB_PS_PUBLICATION), 0);
    run(a, 500);
    assert_int_equal(a->rogue.data, 0);
    /* Within the limits but "forever": the lease is clamped, the traffic ends with it. */
    uint64_t t0 = a->w.now_ms;
    authz_request(a, UB_ADMIN_PUB_REQUEST, gps, "mallory", "mallory", 100, 0, 6);
    assert_int_equal(a->rogue.acks, 1);
    assert_int_equal(counters(a->veh)->leases_clamped, 1);
    const ub_ps_row_t *row = veh_row(a, UB_PS_PUBLICATION, "gpsOut", "mallory");
    assert_non_null(row);
    assert_int_equal(row->lease_until_ms, t0 + 2000);
    world_run(&a->w, t0 + 1999, 1);
    assert_in_range(a->rogue.data, 19, 21); /* 10 Hz for 2 s */
    uint64_t expired = counters(a->veh)->leases_expired;
    world_run(&a->w, t0 + 5000, 1);
    assert_null(veh_row(a, UB_PS_PUBLICATION, "gpsOut", "mallory"));
    assert_int_equal(counters(a->veh)->leases_expired, expired + 1);
    assert_in_range(a->rogue.data, 19, 21);
    assert_true(a->rogue.last_data_ms < t0 + 2000);
    /* A long lease is clamped the same way; an administrator's lease 0 too, to its own, longer bound (#23). */
    authz_request(a, UB_ADMIN_PUB_REQUEST, gps, "mallory", "mallory", 100, 600000, 7);
    assert_int_equal(veh_row(a, UB_PS_PUBLICATION, "gpsOut", "mallory")->lease_until_ms, a->w.now_ms + 2000);
    authz_request(a, UB_ADMIN_PUB_REQUEST, gps, "gcs1", "obs1", 100, 0, 8);
    assert_int_equal(veh_row(a, UB_PS_PUBLICATION, "gpsOut", "obs1")->lease_until_ms,
                     a->w.now_ms + UB_POLICY_DEFAULT_ADMIN_MAX_LEASE_MS);
    free(a);
}

static size_t veh_publications(const authz_t *a) { return ub_pubsub_count(a->veh, a->e_veh, UB_PS_PUBLICATION); }

/* Issue #23 item 5: 30 requests "from gcs1" (an administrator: any group-key holder can sign as it) made 30 rows
 * at 1 ms with no lease, and veh1 sent 16k frames/s forever. An administrator has limits too: its own. */
static void test_administrator_limits_bounded(void **state) {
    (void)state;
    authz_t *a = authz_new(43);
    char name[16];
    uint64_t limited0 = counters(a->veh)->requests_limited;
    for (uint32_t i = 0; i < 30; i++) {
        (void)snprintf(name, sizeof name, "cell%02u", i);
        authz_request(a, UB_ADMIN_PUB_REQUEST, authz_instance(a, name), "gcs1", "gcs1", 1, 0, 100 + i);
    }
    assert_int_equal(counters(a->veh)->requests_limited - limited0, 30);
    assert_int_equal(veh_publications(a), 0);
    run(a, 200);
    /* its rows: at most max_rows, each lease bounded (lease 0 is not "forever") */
    ub_policy_limits_t lim = {.max_rows = 6, .max_lease_ms = 5000};
    assert_int_equal(ub_policy_set_admin_limits(&a->policy, &lim), UB_OK);
    assert_int_equal(a->policy.admin_limits.min_period_ms, UB_POLICY_DEFAULT_ADMIN_MIN_PERIOD_MS); /* 0 = default */
    uint64_t t0 = a->w.now_ms;
    for (uint32_t i = 0; i < 10; i++) {
        (void)snprintf(name, sizeof name, "cell%02u", i);
        authz_request(a, UB_ADMIN_PUB_REQUEST, authz_instance(a, name), "gcs1", "gcs1", 100, 0, 200 + i);
    }
    assert_int_equal(veh_publications(a), 6);
    assert_int_equal(counters(a->veh)->requests_limited - limited0, 34);
    for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) {
        const ub_ps_row_t *row = ub_pubsub_row(a->veh, a->e_veh, r);
        if (row != NULL && row->kind == UB_PS_PUBLICATION) assert_int_equal(row->lease_until_ms, t0 + 5000);
    }
    /* unrenewed, they end with their lease */
    run(a, 6000);
    assert_int_equal(veh_publications(a), 0);
    /* the byte budget: 68-byte frames at 10 ms cost 6800 B/s each */
    ub_policy_limits_t bytes = {.max_bytes_per_s = 10000};
    assert_int_equal(ub_policy_set_admin_limits(&a->policy, &bytes), UB_OK);
    authz_request(a, UB_ADMIN_PUB_REQUEST, authz_instance(a, "cell00"), "gcs1", "gcs1", 10, 3000, 300);
    authz_request(a, UB_ADMIN_PUB_REQUEST, authz_instance(a, "cell01"), "gcs1", "gcs1", 10, 3000, 301);
    assert_int_equal(veh_publications(a), 1);
    /* a bad bound is refused, not taken as "none" */
    ub_policy_limits_t bad = {.max_lease_ms = 10};
    assert_int_equal(ub_policy_set_admin_limits(&a->policy, &bad), UB_ERR_RANGE);
    free(a);
}

/* ---- table exhaustion and the full-table rule ----------------------------------------------- */

static void request_cells(authz_t *a, const char *who, int first, int count, uint32_t id0) {
    char name[16]; /* "cell" and any int: gcc 12 checks the whole range (-Wformat-truncation) */
    for (int i = first; i < first + count; i++) {
        (void)snprintf(name, sizeof name, "cell%02d", i);
        authz_request(a, UB_ADMIN_PUB_REQUEST, authz_instance(a, name), who, who, 1000, 3000, id0 + (uint32_t)i);
    }
}

static void test_table_exhaustion_bounded_and_administrator_served(void **state) {
    (void)state;
    authz_t *a = authz_new(51); /* default limits: 8 rows per requester */
    uint32_t gps = authz_instance(a, "gpsOut"), imu = authz_instance(a, "imuOut");
    assert_true(ub_pubsub_publish(a->veh, a->e_veh, gps, eid(0, "obs1"), 1000, 0) >= 0);
    assert_true(ub_pubsub_publish(a->veh, a->e_veh, imu, eid(0, "obs1"), 1000, 0) >= 0);

    /* One requester asks for 40 rows: it gets its 8. */
    request_cells(a, "mallory", 0, AUTHZ_CELLS, 100);
    assert_int_equal(authz_rows_owned(a, "mallory"), UB_POLICY_DEFAULT_MAX_ROWS);
    assert_int_equal(a->rogue.acks, UB_POLICY_DEFAULT_MAX_ROWS);
    assert_int_equal(a->rogue.nacks[UB_NACK_LIMIT], AUTHZ_CELLS - UB_POLICY_DEFAULT_MAX_ROWS);

    /* Claimed names (no signatures yet) fill the table, each within its own limit. */
    run(a, 10);
    request_cells(a, "m1", 8, 8, 200);
    request_cells(a, "m2", 16, 8, 300);
    request_cells(a, "m3", 24, 6, 400);
    assert_int_equal(ub_pubsub_count(a->veh, a->e_veh, UB_PS_FREE), 0);
    request_cells(a, "obs1", 39, 1, 500); /* another non-administrator: table full, nothing taken */
    assert_int_equal(authz_rows_owned(a, "obs1"), 0);
    assert_int_equal(counters(a->veh)->rows_evicted, 0);

    /* The administrator is served: its request takes the non-administrator row whose lease ends first
     * (mallory's, the oldest), through its table as well as by a direct request. */
    int row = admin_row(a, "gpsOut", "veh1", "gcs1", 100, UB_ADMIN_ROW_PUBLICATION);
    run(a, 300);
    assert_int_equal(info(a, row).status, UB_ADMIN_ACTIVE);
    assert_int_equal(counters(a->veh)->rows_evicted, 1);
    assert_int_equal(authz_rows_owned(a, "mallory"), UB_POLICY_DEFAULT_MAX_ROWS - 1);
    /* Every non-administrator row can go, never a local or an administrator's row. */
    for (int i = 0; i < 29; i++) {
        char name[8];
        (void)snprintf(name, sizeof name, "cell%02d", i);
        authz_request(a, UB_ADMIN_PUB_REQUEST, authz_instance(a, name), "gcs1", "obs1", 1000, 0, 900 + (uint32_t)i);
    }
    assert_int_equal(counters(a->veh)->rows_evicted, 30);
    assert_int_equal(authz_rows_owned(a, "gcs1"), 30);
    assert_int_equal(authz_rows_owned(a, "mallory") + authz_rows_owned(a, "m1") + authz_rows_owned(a, "m2") +
                         authz_rows_owned(a, "m3"),
                     0);
    authz_request(a, UB_ADMIN_PUB_REQUEST, authz_instance(a, "cell39"), "gcs1", "obs1", 1000, 0, 999);
    assert_int_equal(counters(a->veh)->rows_evicted, 30); /* nothing left to take: TABLE_FULL */
    assert_non_null(veh_row(a, UB_PS_PUBLICATION, "gpsOut", "obs1"));
    assert_non_null(veh_row(a, UB_PS_PUBLICATION, "imuOut", "obs1"));
    assert_int_equal(info(a, row).status, UB_ADMIN_ACTIVE);
    free(a);
}

/* ---- write policy --------------------------------------------------------------------------- */

static void test_write_policy_drops_before_storage(void **state) {
    (void)state;
    authz_t *a = authz_new(61);
    uint32_t gps = authz_instance(a, "gpsOut"), imu = authz_instance(a, "imuOut"), c5 = authz_instance(a, "cell05");
    uint8_t fake[28];
    memset(fake, 0xAA, sizeof fake);
    struct test_gps before = a->veh_gps;
    authz_data(a, gps, "mallory", fake);
    authz_data(a, gps, "gcs1", fake); /* being an administrator grants no write by itself */
    assert_int_equal(counters(a->veh)->drops[UB_DROP_NOT_ALLOWED], 2);
    assert_int_equal(a->veh->links[a->veh_link_rogue].counters.drops[UB_DROP_NOT_ALLOWED], 2);
    assert_memory_equal(&a->veh_gps, &before, sizeof before);
    assert_int_equal(counters(a->veh)->delivered, 0);

    /* A write rule names (source, content) pairs. */
    assert_int_equal(ub_policy_add_rule(&a->policy, UB_POLICY_WRITE, "veh1", "gcs1", "cell*"), UB_OK);
    uint8_t seven[4] = {7, 0, 0, 0}, nine[4] = {9, 0, 0, 0};
    authz_data(a, c5, "gcs1", seven);
    assert_int_equal(a->veh_cells[5], 7);
    authz_data(a, c5, "mallory", nine);
    authz_data(a, gps, "gcs1", fake);
    assert_int_equal(a->veh_cells[5], 7);
    assert_int_equal(counters(a->veh)->drops[UB_DROP_NOT_ALLOWED], 4);

    /* What an entity subscribed to is stored; other data to it is not. */
    assert_true(ub_pubsub_subscribe(a->obs, a->e_obs, gps, eid(0, "veh1"), 100, a->w.now_ms) >= 0);
    run(a, 600);
    assert_in_range(delivery_count(&a->obs_log, a->e_obs, gps, 0, UINT64_MAX), 4, 7);
    authz_data_to(a, a->obs, a->obs_link, "obs1", imu, "mallory", fake);
    authz_data_to(a, a->obs, a->obs_link, "obs1", imu, "veh1", fake); /* the right source, not subscribed */
    assert_int_equal(counters(a->obs)->drops[UB_DROP_NOT_ALLOWED], 2);
    assert_int_equal(delivery_count(&a->obs_log, a->e_obs, imu, 0, UINT64_MAX), 0);

    /* What the entity's own administration table set up is stored, while the row is active. */
    int row = admin_row(a, "cell07", "veh1", "gcs1", 100, UB_ADMIN_ROW_PUBLICATION);
    run(a, 500);
    uint32_t c7 = authz_instance(a, "cell07");
    assert_in_range(delivery_count(&a->gcs_log, a->e_gcs, c7, 0, UINT64_MAX), 3, 6);
    assert_int_equal(counters(a->gcs)->drops[UB_DROP_NOT_ALLOWED], 0);
    assert_int_equal(ub_admin_set_active(&a->admin, row, false, a->w.now_ms), UB_OK);
    run(a, 500);
    assert_int_equal(info(a, row).status, UB_ADMIN_INACTIVE);
    authz_data_to(a, a->gcs, a->gcs_link, "gcs1", c7, "veh1", seven);
    assert_int_equal(counters(a->gcs)->drops[UB_DROP_NOT_ALLOWED], 1);

    /* No policy: the paper's closed lab, everything is written. */
    ub_node_set_policy(a->veh, NULL);
    authz_data(a, c5, "mallory", nine);
    assert_int_equal(a->veh_cells[5], 9);
    free(a);
}

/* ---- read policy ---------------------------------------------------------------------------- */

static void test_read_policy_nacks(void **state) {
    (void)state;
    authz_t *a = authz_new(71);
    assert_int_equal(ub_policy_add_rule(&a->policy, UB_POLICY_READ, "veh1", "obs*", "gps*"), UB_OK);
    uint32_t gps = authz_instance(a, "gpsOut"), imu = authz_instance(a, "imuOut");
    authz_request(a, UB_ADMIN_PUB_REQUEST, gps, "mallory", "mallory", 100, 3000, 1);
    assert_int_equal(a->rogue.nacks[UB_NACK_NOT_AUTHORIZED], 1);
    assert_int_equal(counters(a->veh)->drops[UB_DROP_NOT_AUTHORIZED], 1);
    /* obs1 may read gpsOut, not imuOut: its refused row keeps asking at the renewal pace only. */
    int ok = ub_pubsub_subscribe(a->obs, a->e_obs, gps, eid(0, "veh1"), 100, a->w.now_ms);
    int refused = ub_pubsub_subscribe(a->obs, a->e_obs, imu, eid(0, "veh1"), 100, a->w.now_ms);
    assert_true(ok >= 0 && refused >= 0);
    run(a, 2500);
    assert_true(delivery_count(&a->obs_log, a->e_obs, gps, 0, UINT64_MAX) >= 20);
    assert_int_equal(delivery_count(&a->obs_log, a->e_obs, imu, 0, UINT64_MAX), 0);
    assert_null(veh_row(a, UB_PS_PUBLICATION, "imuOut", "obs1"));
    uint64_t refusals = counters(a->veh)->drops[UB_DROP_NOT_AUTHORIZED] - 1;
    assert_in_range(refusals, 2, 4); /* t = 1, then every renew_ms (1 s) */
    /* An administrator reads anything. */
    int row = admin_row(a, "imuOut", "veh1", "gcs1", 100, UB_ADMIN_ROW_PUBLICATION);
    run(a, 300);
    assert_int_equal(info(a, row).status, UB_ADMIN_ACTIVE);
    /* An empty read section: nobody but the administrators. */
    ub_policy_t closed;
    ub_policy_init(&closed);
    ub_policy_restrict_reads(&closed);
    assert_int_equal(ub_policy_add_admin(&closed, eid(0, "gcs1")), UB_OK);
    ub_node_set_policy(a->veh, &closed);
    uint64_t nacked = a->rogue.nacks[UB_NACK_NOT_AUTHORIZED];
    authz_request(a, UB_ADMIN_PUB_REQUEST, gps, "mallory", "mallory", 100, 3000, 2);
    assert_int_equal(a->rogue.nacks[UB_NACK_NOT_AUTHORIZED], nacked + 1);
    free(a);
}

/* ---- limits per requester ------------------------------------------------------------------- */

static void test_limits_per_requester(void **state) {
    (void)state;
    authz_t *a = authz_new(81);
    /* A cell costs (64 + 4) bytes per period: 68 B/s every second, 680 B/s every 100 ms. */
    assert_int_equal(ub_policy_row_bytes_per_s(4, 1000), 68);
    assert_int_equal(ub_policy_row_bytes_per_s(4, 100), 680);
    assert_int_equal(ub_policy_row_bytes_per_s(4, 22), 3091); /* rounded up */
    ub_policy_limits_t lim = {.min_period_ms = 20, .max_rows = 3, .max_bytes_per_s = 3000};
    assert_int_equal(ub_policy_set_limits(&a->policy, &lim), UB_OK);
    request_cells(a, "mallory", 0, 4, 10); /* 3 rows of 68 B/s; the 4th row is one too many */
    assert_int_equal(authz_rows_owned(a, "mallory"), 3);
    assert_int_equal(a->rogue.nacks[UB_NACK_LIMIT], 1);
    /* Another requester has its own allowance: obs1's three subscriptions all flow. */
    for (int i = 10; i < 13; i++) {
        char name[8];
        (void)snprintf(name, sizeof name, "cell%02d", i);
        assert_true(ub_pubsub_subscribe(a->obs, a->e_obs, authz_instance(a, name), eid(0, "veh1"), 100, a->w.now_ms) >= 0);
    }
    run(a, 600);
    assert_int_equal(authz_rows_owned(a, "obs1"), 3);
    assert_in_range(delivery_count(&a->obs_log, a->e_obs, authz_instance(a, "cell12"), 0, UINT64_MAX), 4, 7);
    /* A renewal that would change the period is checked too, and leaves the row as it was when refused. */
    uint32_t c0 = authz_instance(a, "cell00");
    authz_request(a, UB_ADMIN_PUB_REQUEST, c0, "mallory", "mallory", 22, 3000, 10); /* 3091 + 136 > 3000 */
    assert_int_equal(veh_row(a, UB_PS_PUBLICATION, "cell00", "mallory")->period_ms, 1000);
    authz_request(a, UB_ADMIN_PUB_REQUEST, c0, "mallory", "mallory", 10, 3000, 10); /* below min_period_ms */
    assert_int_equal(a->rogue.nacks[UB_NACK_LIMIT], 3);
    authz_request(a, UB_ADMIN_PUB_REQUEST, c0, "mallory", "mallory", 100, 3000, 10); /* 680 + 136: fine */
    assert_int_equal(veh_row(a, UB_PS_PUBLICATION, "cell00", "mallory")->period_ms, 100);
    assert_int_equal(counters(a->veh)->requests_limited, 3);
    /* Refusals of one requester never touched the other's rows. */
    assert_int_equal(authz_rows_owned(a, "obs1"), 3);
    /* The byte budget on its own: one fast row leaves no room for a slow one. */
    authz_t *b = authz_new(82);
    lim = (ub_policy_limits_t){.max_bytes_per_s = 3000};
    assert_int_equal(ub_policy_set_limits(&b->policy, &lim), UB_OK);
    authz_request(b, UB_ADMIN_PUB_REQUEST, authz_instance(b, "cell20"), "mallory", "mallory", 25, 3000, 1); /* 2720 */
    authz_request(b, UB_ADMIN_PUB_REQUEST, authz_instance(b, "cell21"), "mallory", "mallory", 100, 3000, 2);
    assert_int_equal(authz_rows_owned(b, "mallory"), 1);
    assert_int_equal(b->rogue.nacks[UB_NACK_LIMIT], 1);
    free(b);
    free(a);
}

/* ---- no policy: the paper's closed lab ------------------------------------------------------ */

static void test_without_policy_behaviour_unchanged(void **state) {
    (void)state;
    authz_t *a = authz_new(91);
    ub_node_set_policy(a->gcs, NULL);
    ub_node_set_policy(a->veh, NULL);
    ub_node_set_policy(a->obs, NULL);
    uint32_t gps = authz_instance(a, "gpsOut"), imu = authz_instance(a, "imuOut");
    assert_true(ub_pubsub_publish(a->veh, a->e_veh, imu, eid(0, "obs1"), 100, 0) >= 0);
    /* Everyone has the exclusive rights, no limit applies: what the policy exists to stop. */
    authz_request(a, UB_ADMIN_SUB_REQUEST, gps, "mallory", "obs1", 100, 3000, 1);
    authz_request(a, UB_ADMIN_PUB_REQUEST, gps, "mallory", "gcs1", 1, 0, 2);
    authz_stop(a, UB_ADMIN_PUB_STOP, imu, "mallory", "obs1", 0);
    assert_int_equal(a->rogue.acks, 3);
    assert_int_equal(ub_pubsub_count(a->veh, a->e_veh, UB_PS_SUBSCRIPTION), 1);
    assert_int_equal(veh_row(a, UB_PS_PUBLICATION, "gpsOut", "gcs1")->lease_until_ms, 0);
    assert_null(veh_row(a, UB_PS_PUBLICATION, "imuOut", "obs1"));
    for (int r = 0; r < UB_DROP_REASON_COUNT; r++)
        if (r == UB_DROP_NOT_ALLOWED || r == UB_DROP_NOT_AUTHORIZED) assert_int_equal(counters(a->veh)->drops[r], 0);
    /* Replies stay bound to their rows even so. */
    int row = admin_row(a, "imuOut", "veh1", "gcs1", 100, UB_ADMIN_ROW_PUBLICATION);
    run(a, 300);
    authz_reply(a, true, imu, "mallory", "gcs1", info(a, row).request_id, UB_ADMIN_PUB_REQUEST, UB_NACK_UNBOUND);
    assert_int_equal(info(a, row).status, UB_ADMIN_ACTIVE);
    free(a);
}

/* ---- with a keyring, only a verified requester administers ----------------------------------- */

static const uint8_t FLEET_KEY[UB_SEC_KEY_LEN] = {0x5a, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15,
                                                  16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31};

static void membership_request(authz_t *a, const char *src, uint32_t id) {
    uint8_t p[UB_MEMBER_ENTITY_LEN] = {0};
    ub_put_u32le(p + UB_MEMBER_OFF_ID, id);
    p[UB_MEMBER_OFF_OP] = UB_MEMBER_REMOVE_ENTITY;
    test_eid("obs1", p + UB_MEMBER_OFF_SUBJECT);
    uint8_t frame[UB_FRAME_MAX];
    static const uint8_t no_dir[UB_DIR_ID_LEN] = {0};
    size_t n = make_frame(frame, UB_ADMIN_MEMBERSHIP, no_dir, src, "veh1", a->seq++, 8, 0, p, sizeof p);
    assert_int_equal(ub_node_rx_frame(a->veh, a->veh_link_rogue, frame, n, a->w.now_ms), UB_OK);
}

/*
 * A node with a keyring whose radio link still takes unsigned frames ("require_signed": false, e.g. for
 * a legacy sensor): an unsigned frame claiming the administrator gcs1 gets none of its rights (the tag is
 * what proves the sender), while gcs1's genuine, signed requests still administer. Without the keyring
 * the same forged frames administer (the control: this test can fail).
 */
static void test_with_a_keyring_only_verified_requests_administer(void **state) {
    (void)state;
    authz_t *a = authz_new(61);
    uint32_t gps = authz_instance(a, "gpsOut"), imu = authz_instance(a, "imuOut");
    uint8_t gcs1[UB_ENTITY_ID_LEN];
    test_eid("gcs1", gcs1);
    /* control, no keyring: the forged "gcs1" requests are obeyed */
    authz_request(a, UB_ADMIN_PUB_REQUEST, gps, "gcs1", "mallory", 100, 0, 1);
    assert_non_null(veh_row(a, UB_PS_PUBLICATION, "gpsOut", "mallory"));
    authz_stop(a, UB_ADMIN_PUB_STOP, gps, "gcs1", "mallory", 1);
    assert_null(veh_row(a, UB_PS_PUBLICATION, "gpsOut", "mallory"));
    assert_true(ub_node_may_administer(a->veh, a->e_veh, gcs1, false));

    static ub_sec_t sec[3];
    test_sec_on(&sec[0], a->gcs, FLEET_KEY, 1000, false); /* keys, but unsigned frames still allowed */
    test_sec_on(&sec[1], a->veh, FLEET_KEY, 2000, false);
    test_sec_on(&sec[2], a->obs, FLEET_KEY, 3000, false);
    assert_false(ub_node_link_requires_signed(a->veh, a->veh_link_rogue));
    uint64_t refused = counters(a->veh)->drops[UB_DROP_NOT_AUTHORIZED];
    uint64_t member_refused = counters(a->veh)->membership_refused;
    assert_true(ub_pubsub_publish(a->veh, a->e_veh, imu, eid(0, "obs1"), 100, a->w.now_ms) >= 0);
    /* forged, unsigned, claiming the administrator: data to mallory, a subscription, a stop of a local row,
     * a membership change */
    authz_request(a, UB_ADMIN_PUB_REQUEST, gps, "gcs1", "mallory", 1, 0, 2);
    authz_request(a, UB_ADMIN_SUB_REQUEST, gps, "gcs1", "mallory", 100, 0, 3);
    authz_stop(a, UB_ADMIN_PUB_STOP, imu, "gcs1", "obs1", 0);
    membership_request(a, "gcs1", 4);
    assert_int_equal(counters(a->veh)->drops[UB_DROP_NOT_AUTHORIZED] - refused, 4);
    assert_int_equal(counters(a->veh)->membership_refused - member_refused, 1);
    assert_null(veh_row(a, UB_PS_PUBLICATION, "gpsOut", "mallory"));
    assert_int_equal(ub_pubsub_count(a->veh, a->e_veh, UB_PS_SUBSCRIPTION), 0);
    assert_non_null(veh_row(a, UB_PS_PUBLICATION, "imuOut", "obs1"));
    assert_true(ub_node_find_entity(a->veh, eid(0, "obs1")) >= 0);
    assert_false(ub_node_may_administer(a->veh, a->e_veh, gcs1, false));
    assert_true(ub_node_may_administer(a->veh, a->e_veh, gcs1, true));
    run(a, 500);
    assert_int_equal(a->rogue.data, 0);

    /* gcs1's own administration table, signed over its link: data to obs1 (exclusive rights) flows */
    int row = admin_row(a, "gpsOut", "veh1", "obs1", 100, UB_ADMIN_ROW_PUBLICATION);
    run(a, 1500);
    assert_int_equal(info(a, row).status, UB_ADMIN_ACTIVE);
    const ub_ps_row_t *granted = veh_row(a, UB_PS_PUBLICATION, "gpsOut", "obs1");
    assert_non_null(granted);
    assert_memory_equal(granted->owner, gcs1, UB_ENTITY_ID_LEN);
    assert_true(granted->frames >= 10);
    assert_int_equal(counters(a->veh)->drops[UB_DROP_NOT_AUTHORIZED] - refused, 4);
    free(a);
}

/* ---- request ids ---------------------------------------------------------------------------- */

typedef struct scripted {
    int calls;
    int fail_first;  /* calls that fail */
    int zero_first;  /* calls (after failures) that give 0 */
} scripted_t;

static int scripted_random(void *user, uint8_t *out, size_t len) {
    scripted_t *s = user;
    s->calls++;
    if (s->calls <= s->fail_first) return UB_ERR_IO;
    bool zero = s->calls <= s->fail_first + s->zero_first;
    for (size_t i = 0; i < len; i++) out[i] = zero ? 0 : (uint8_t)(0x44 - 0x11 * (int)i);
    return UB_OK;
}

static uint32_t subscribe_id(ub_node_t *n, int e, uint32_t instance, const uint8_t *src) {
    int r = ub_pubsub_subscribe(n, e, instance, src, 100, 0);
    assert_true(r >= 0);
    return ub_pubsub_row(n, e, r)->request_id;
}

static void test_request_ids_unguessable_and_injectable(void **state) {
    (void)state;
    authz_t *a = authz_new(101);
    uint8_t veh[UB_ENTITY_ID_LEN];
    test_eid("veh1", veh);
    /* Seeded default: deterministic per seed, not a counter. */
    uint32_t ids[4];
    for (int i = 0; i < 4; i++) ids[i] = subscribe_id(a->obs, a->e_obs, (uint32_t)i, veh);
    for (int i = 0; i < 4; i++) {
        assert_true(ids[i] != 0);
        for (int j = 0; j < i; j++) assert_true(ids[i] != ids[j] && ids[i] - ids[j] != 1u && ids[j] - ids[i] != 1u);
    }
    authz_t *b = authz_new(101);
    assert_int_equal(subscribe_id(b->obs, b->e_obs, 0, veh), ids[0]);
    free(b);
    /* An injected source is used, 0 is never an id, and a failing source is counted and stood in for. */
    ub_node_t *n = calloc(1, sizeof *n);
    assert_non_null(n);
    scripted_t script = {.fail_first = 1, .zero_first = 1};
    ub_node_options_t opt = {.random = scripted_random, .random_user = &script};
    assert_int_equal(ub_node_init(n, &a->cat, &opt), UB_OK);
    int e = ub_node_add_entity_name(n, "obs1", true);
    assert_true(e >= 0 && ub_node_add_entity_name(n, "veh1", false) >= 0);
    uint32_t first = subscribe_id(n, e, 0, veh);  /* failed: the seeded generator stands in */
    assert_true(first != 0);
    assert_int_equal(ub_node_counters(n)->random_failures, 1);
    uint32_t second = subscribe_id(n, e, 1, veh); /* 0 from the source: drawn again */
    assert_int_equal(second, 0x11223344u);
    assert_int_equal(script.calls, 3);
    /* The POSIX source answers, and differently each time. */
    uint8_t r1[16], r2[16];
    assert_int_equal(ub_random_os(NULL, r1, sizeof r1), UB_OK);
    assert_int_equal(ub_random_os(NULL, r2, sizeof r2), UB_OK);
    assert_memory_not_equal(r1, r2, sizeof r1);
    free(n);
    free(a);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_forged_replies_ignored_and_counted),
        cmocka_unit_test(test_forged_stops_refused),
        cmocka_unit_test(test_non_admin_sub_and_foreign_pub_requests_refused),
        cmocka_unit_test(test_amplification_bounded),
        cmocka_unit_test(test_administrator_limits_bounded),
        cmocka_unit_test(test_table_exhaustion_bounded_and_administrator_served),
        cmocka_unit_test(test_write_policy_drops_before_storage),
        cmocka_unit_test(test_read_policy_nacks),
        cmocka_unit_test(test_limits_per_requester),
        cmocka_unit_test(test_without_policy_behaviour_unchanged),
        cmocka_unit_test(test_with_a_keyring_only_verified_requests_administer),
        cmocka_unit_test(test_request_ids_unguessable_and_injectable),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
