/*
 * Flows that outlive their administrator, and no silent status (issue 12, items 3 and 4; docs/pubsub.md,
 * "Who keeps a row alive", "No silent status", "Two administrators").
 *
 *   gcs1 --L0-- veh1 --L1-- veh2 --L2-- gcs2          (four nodes on memlinks, manual masks)
 *
 * veh1 hosts gpsOut and imuOut (the source); veh2 binds storage for both (the destination). gcs1 and gcs2
 * each hold an administration table. The flows are between the two vehicles; the ground stations only set
 * them up, then go dark, come back, compete.
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
#include "ub/ub_nodecfg.h"
#include "ub/ub_policy.h"
#include "ub/ub_pubsub.h"

#define EXPIRY_MS 10000u /* shorter than the 60 s default, so the tests stay quick */

static const ub_memlink_faults_t dark = {.loss_ppm = 1000000};

typedef struct hw {
    world_t *w;
    ub_node_t *g1, *v1, *v2, *g2;
    int e[4];          /* each node's own entity, in its table: g1, v1, v2, g2 */
    int l[4][2];       /* link ids: g1 {L0}, v1 {L0, L1}, v2 {L1, L2}, g2 {L2} */
    uint8_t id[4][UB_ENTITY_ID_LEN];
    ub_memlink_t *ml[3]; /* L0, L1, L2 */
    ub_admin_t adm1, adm2;
    ub_policy_t pol;
    struct test_gps gps_src, gps_v2;
    struct test_imu imu_src, imu_v2;
    delivery_log_t log; /* deliveries at veh2 */
} hw_t;

enum { G1 = 0, V1 = 1, V2 = 2, G2 = 3 };
static const char *const names[4] = {"gcs1", "veh1", "veh2", "gcs2"};
/* Mask per (node, destination): the link index that leads there. */
static const uint8_t masks[4][4] = {
    {0, 0x1, 0x1, 0x1}, /* gcs1: everything over L0 */
    {0x1, 0, 0x2, 0x2}, /* veh1: gcs1 over its link 0, the rest over link 1 */
    {0x1, 0x1, 0, 0x2}, /* veh2: gcs1 and veh1 over its link 0, gcs2 over link 1 */
    {0x1, 0x1, 0x1, 0}, /* gcs2: everything over L2 */
};

static ub_node_t *node_of(hw_t *h, int who) {
    ub_node_t *n[4] = {h->g1, h->v1, h->v2, h->g2};
    return n[who];
}

/* Entity table, links and masks of node `who` (also after a restart of its process). */
static void setup_node(hw_t *h, int who) {
    ub_node_t *n = node_of(h, who);
    int idx[4];
    for (int k = 0; k < 4; k++) idx[k] = ub_node_add_entity(n, h->id[k], k == who);
    h->e[who] = idx[who];
    int n_links = (who == V1 || who == V2) ? 2 : 1;
    for (int i = 0; i < n_links; i++) {
        char name[8] = {'l', (char)('0' + who), (char)('0' + i), 0};
        h->l[who][i] = ub_node_add_link(n, idx[who], (unsigned)i, name);
        assert_true(h->l[who][i] >= 0);
    }
    for (int k = 0; k < 4; k++)
        if (k != who) assert_int_equal(ub_node_set_mask(n, idx[who], idx[k], masks[who][k]), UB_OK);
}

static void bind_source(hw_t *h, bool imu) {
    assert_int_equal(ub_node_bind(h->v1, TEST_GPS, &h->gps_src), UB_OK);
    if (imu) assert_int_equal(ub_node_bind(h->v1, TEST_IMU, &h->imu_src), UB_OK);
}

static hw_t *hw_new(const ub_catalogue_t *v1_cat, bool v1_binds_imu) {
    hw_t *h = calloc(1, sizeof *h);
    assert_non_null(h);
    h->w = world_new();
    ub_node_options_t opt = {.timing = {.expiry_ms = EXPIRY_MS}};
    for (int k = 0; k < 4; k++) {
        test_eid(names[k], h->id[k]);
        opt.random_seed = 1000u + (uint64_t)k;
        ub_node_t *n = world_node(h->w, k == V1 ? v1_cat : &ub_test_cat, &opt);
        if (k == G1) h->g1 = n;
        if (k == V1) h->v1 = n;
        if (k == V2) h->v2 = n;
        if (k == G2) h->g2 = n;
    }
    for (int k = 0; k < 4; k++) setup_node(h, k);
    h->ml[0] = world_connect(h->w, h->g1, h->l[G1][0], h->v1, h->l[V1][0], NULL, 1);
    h->ml[1] = world_connect(h->w, h->v1, h->l[V1][1], h->v2, h->l[V2][0], NULL, 2);
    h->ml[2] = world_connect(h->w, h->v2, h->l[V2][1], h->g2, h->l[G2][0], NULL, 3);
    h->gps_src = (struct test_gps){33.78, -84.40, 300.0f, 3};
    h->imu_src.t_ms = 7;
    bind_source(h, v1_binds_imu);
    assert_int_equal(ub_node_bind(h->v2, TEST_GPS, &h->gps_v2), UB_OK);
    assert_int_equal(ub_node_bind(h->v2, TEST_IMU, &h->imu_v2), UB_OK);
    ub_node_set_deliver_hook(h->v2, delivery_log_hook, &h->log);
    assert_int_equal(ub_admin_init(&h->adm1, h->g1, h->e[G1], NULL), UB_OK);
    assert_int_equal(ub_admin_init(&h->adm2, h->g2, h->e[G2], NULL), UB_OK);
    return h;
}

static void hw_free(hw_t *h) {
    free(h->w);
    free(h);
}

/* A row of `adm`: `instance` from veh1 to veh2, activated now. */
static int flow_row(hw_t *h, ub_admin_t *adm, ub_admin_row_type_t type, uint32_t instance, uint32_t period_ms) {
    ub_admin_row_spec_t spec = {.instance = instance, .period_ms = period_ms, .type = type};
    memcpy(spec.source, h->id[V1], UB_ENTITY_ID_LEN);
    memcpy(spec.destination, h->id[V2], UB_ENTITY_ID_LEN);
    int row = ub_admin_add_row(adm, &spec);
    assert_true(row >= 0);
    assert_int_equal(ub_admin_set_active(adm, row, true, h->w->now_ms), UB_OK);
    return row;
}

static ub_admin_row_info_t info_of(const ub_admin_t *adm, int row) {
    ub_admin_row_info_t info;
    assert_int_equal(ub_admin_row_status(adm, row, &info), UB_OK);
    return info;
}

static size_t received(const hw_t *h, uint32_t instance, uint64_t from_ms, uint64_t to_ms) {
    return delivery_count(&h->log, h->e[V2], instance, from_ms, to_ms);
}

static void run_to(hw_t *h, uint64_t t_ms) { world_run(h->w, t_ms, 1); }

static const ub_ps_row_t *row_at(hw_t *h, int who, ub_ps_kind_t kind, uint32_t instance, int peer) {
    int r = ub_pubsub_find(node_of(h, who), h->e[who], kind, instance, h->id[peer]);
    return r < 0 ? NULL : ub_pubsub_row(node_of(h, who), h->e[who], r);
}

/* ---- item 3: flows that outlive the operator ---------------------------------------------------------- */

/* gcs1 sets up a subscription (imuOut) and a publication (gpsOut) between the vehicles, then loses its radio for
 * five times the expiry: both flows keep their rate the whole time, and gcs1 takes them back when it returns. */
static void test_flows_outlive_the_administrator(void **state) {
    (void)state;
    hw_t *h = hw_new(&ub_test_cat, true);
    int sub = flow_row(h, &h->adm1, UB_ADMIN_ROW_SUBSCRIPTION, TEST_IMU, 100);
    int pub = flow_row(h, &h->adm1, UB_ADMIN_ROW_PUBLICATION, TEST_GPS, 200);
    run_to(h, 2000);
    assert_int_equal(info_of(&h->adm1, sub).status, UB_ADMIN_ACTIVE);
    assert_int_equal(info_of(&h->adm1, pub).status, UB_ADMIN_ACTIVE);

    ub_memlink_set_faults(h->ml[0], &dark); /* gcs1 out of range of everyone */
    run_to(h, 2000 + 5 * EXPIRY_MS);
    /* 10 Hz and 5 Hz all along: nothing waited for the administrator's renewals. */
    assert_in_range(received(h, TEST_IMU, 5000, 52000), 465, 471);
    assert_in_range(received(h, TEST_GPS, 5000, 52000), 232, 236);
    const ub_ps_row_t *s = row_at(h, V2, UB_PS_SUBSCRIPTION, TEST_IMU, V1);
    const ub_ps_row_t *p = row_at(h, V1, UB_PS_PUBLICATION, TEST_GPS, V2);
    assert_non_null(s);
    assert_non_null(p);
    assert_true(s->handed_over && p->handed_over);
    assert_memory_equal(s->owner, h->id[G1], UB_ENTITY_ID_LEN); /* still gcs1's, kept by its keeper */
    assert_int_equal(ub_node_counters(h->v2)->handovers, 1);
    assert_int_equal(ub_node_counters(h->v1)->handovers, 1);
    assert_int_equal(ub_node_counters(h->v2)->leases_expired, 0);
    /* gcs1 cannot know: its rows say so, they do not claim "active". */
    assert_int_equal(info_of(&h->adm1, sub).status, UB_ADMIN_PENDING);
    assert_int_equal(info_of(&h->adm1, pub).status, UB_ADMIN_PENDING);

    ub_memlink_set_faults(h->ml[0], NULL);
    uint64_t back = h->w->now_ms;
    run_to(h, back + 1500);
    assert_int_equal(info_of(&h->adm1, sub).status, UB_ADMIN_ACTIVE);
    assert_int_equal(info_of(&h->adm1, pub).status, UB_ADMIN_ACTIVE);
    assert_false(row_at(h, V2, UB_PS_SUBSCRIPTION, TEST_IMU, V1)->handed_over); /* its owner renews again */
    assert_int_equal(ub_node_counters(h->v1)->other_admin, 0);
    hw_free(h);
}

/* Handed-over rows go when their keeper does: the subscription when its source stops answering, the
 * publication when its node has no route to the destination any more, each EXPIRY_MS after the last sign. */
static void test_handed_over_rows_go_with_their_keeper(void **state) {
    (void)state;
    hw_t *h = hw_new(&ub_test_cat, true);
    (void)flow_row(h, &h->adm1, UB_ADMIN_ROW_SUBSCRIPTION, TEST_IMU, 100);
    (void)flow_row(h, &h->adm1, UB_ADMIN_ROW_PUBLICATION, TEST_GPS, 200);
    run_to(h, 2000);
    ub_memlink_set_faults(h->ml[0], &dark);
    run_to(h, 8000); /* both leases (3 s) lapsed: handed over */
    assert_true(row_at(h, V2, UB_PS_SUBSCRIPTION, TEST_IMU, V1)->handed_over);

    /* veh1 and veh2 lose each other; veh1's route to veh2 is withdrawn (as automatic routes would). */
    ub_memlink_set_faults(h->ml[1], &dark);
    int v1_to_v2 = ub_node_find_entity(h->v1, h->id[V2]);
    int v1_to_g2 = ub_node_find_entity(h->v1, h->id[G2]);
    assert_int_equal(ub_node_set_mask(h->v1, h->e[V1], v1_to_v2, 0), UB_OK);
    assert_int_equal(ub_node_set_mask(h->v1, h->e[V1], v1_to_g2, 0), UB_OK);
    uint64_t cut = h->w->now_ms;
    run_to(h, cut + EXPIRY_MS - 1200); /* the last signs came just before the cut */
    assert_non_null(row_at(h, V2, UB_PS_SUBSCRIPTION, TEST_IMU, V1));
    assert_non_null(row_at(h, V1, UB_PS_PUBLICATION, TEST_GPS, V2));
    run_to(h, cut + EXPIRY_MS + 100);
    assert_null(row_at(h, V2, UB_PS_SUBSCRIPTION, TEST_IMU, V1)); /* stopping: PUB_STOPs then freed */
    assert_null(row_at(h, V1, UB_PS_PUBLICATION, TEST_GPS, V2));
    run_to(h, cut + EXPIRY_MS + 3000);
    assert_int_equal(ub_pubsub_count(h->v2, h->e[V2], UB_PS_SUBSCRIPTION), 0);
    assert_int_equal(ub_pubsub_count(h->v1, h->e[V1], UB_PS_PUBLICATION), 0);
    assert_int_equal(ub_node_counters(h->v2)->leases_expired, 1);
    assert_int_equal(ub_node_counters(h->v1)->leases_expired, 2); /* gpsOut, and veh2's own imuOut lease */
    /* Bounded: nothing more leaves veh2 for this flow once the row is gone. */
    uint64_t sent = ub_node_counters(h->v2)->originated;
    run_to(h, h->w->now_ms + 5000);
    assert_int_equal(ub_node_counters(h->v2)->originated, sent);
    hw_free(h);
}

/* A manual mask never says the destination is gone: the paper's mode keeps an administrator's publication
 * until a STOP reaches it, as the paper's rows had no lease at all. Documented; shown here. */
static void test_manual_mask_keeps_a_publication(void **state) {
    (void)state;
    hw_t *h = hw_new(&ub_test_cat, true);
    (void)flow_row(h, &h->adm1, UB_ADMIN_ROW_PUBLICATION, TEST_GPS, 200);
    run_to(h, 2000);
    ub_memlink_set_faults(h->ml[0], &dark);
    ub_memlink_set_faults(h->ml[1], &dark);
    run_to(h, 2000 + 3 * EXPIRY_MS);
    assert_non_null(row_at(h, V1, UB_PS_PUBLICATION, TEST_GPS, V2));
    hw_free(h);
}

/* The source restarts (empty tables) while the administrator is away: the subscription heals through its
 * destination's re-requests; the publication comes back when the administrator reaches the source again. */
static void test_restarted_source_heals(void **state) {
    (void)state;
    hw_t *h = hw_new(&ub_test_cat, true);
    (void)flow_row(h, &h->adm1, UB_ADMIN_ROW_SUBSCRIPTION, TEST_IMU, 100);
    (void)flow_row(h, &h->adm1, UB_ADMIN_ROW_PUBLICATION, TEST_GPS, 200);
    run_to(h, 2000);
    ub_memlink_set_faults(h->ml[0], &dark);
    run_to(h, 8000);
    /* veh1's process restarts: a new node in the same place, same links. */
    ub_node_options_t opt = {.timing = {.expiry_ms = EXPIRY_MS}, .random_seed = 77};
    assert_int_equal(ub_node_init(h->v1, &ub_test_cat, &opt), UB_OK);
    setup_node(h, V1);
    assert_int_equal(ub_node_link_attach(h->v1, h->l[V1][0], &ub_memlink_ops, &h->ml[0]->end[1]), UB_OK);
    assert_int_equal(ub_node_link_attach(h->v1, h->l[V1][1], &ub_memlink_ops, &h->ml[1]->end[0]), UB_OK);
    bind_source(h, true);
    run_to(h, 10000);
    /* Data timeout (500 ms), re-request, data: imuOut is back without anyone's help. */
    assert_in_range(received(h, TEST_IMU, 9000, 10000), 9, 11);
    assert_int_equal(received(h, TEST_GPS, 8500, 10000), 0); /* a publication is the weaker link */
    ub_memlink_set_faults(h->ml[0], NULL);
    uint64_t back = h->w->now_ms;
    run_to(h, back + 2500);
    assert_true(received(h, TEST_GPS, back + 1000, back + 2500) >= 6);
    hw_free(h);
}

/* ---- item 4: no silent status ------------------------------------------------------------------------- */

/* The source refuses the destination's requests: the administrator's subscription row fails with the source's
 * reason, marked relayed, within one round trip, and the destination's row does not linger. */
static void nack_relayed(const ub_catalogue_t *v1_cat, bool v1_binds_imu, const ub_policy_t *v1_policy,
                         uint32_t instance, ub_nack_reason_t expected) {
    hw_t *h = hw_new(v1_cat, v1_binds_imu);
    if (v1_policy != NULL) {
        h->pol = *v1_policy;
        ub_node_set_policy(h->v1, &h->pol);
    }
    int row = flow_row(h, &h->adm1, UB_ADMIN_ROW_SUBSCRIPTION, instance, 100);
    run_to(h, 100);
    ub_admin_row_info_t info = info_of(&h->adm1, row);
    assert_int_equal(info.status, UB_ADMIN_FAILED);
    assert_int_equal(info.nack_reason, expected);
    assert_true(info.nack_relayed);
    assert_true(ub_node_counters(h->v2)->nacks_relayed >= 1);
    /* gcs1 gave up; the destination's row runs out with gcs1's lease, since its source never agreed. */
    run_to(h, 5000);
    assert_int_equal(ub_pubsub_count(h->v2, h->e[V2], UB_PS_SUBSCRIPTION), 0);
    assert_int_equal(info_of(&h->adm1, row).status, UB_ADMIN_FAILED);
    hw_free(h);
}

static void test_source_nack_reaches_the_administrator(void **state) {
    (void)state;
    nack_relayed(&ub_test_cat, false, NULL, TEST_IMU, UB_NACK_UNBOUND);        /* veh1 does not host imuOut */
    nack_relayed(&ub_test_cat_changed, true, NULL, TEST_GPS, UB_NACK_LAYOUT);  /* veh1 runs another gpsOut... */
    ub_policy_t pol;
    ub_policy_init(&pol);
    assert_int_equal(ub_policy_add_admin(&pol, (const uint8_t *)"gcs1\0\0\0\0\0\0\0\0"), UB_OK);
    ub_policy_restrict_reads(&pol); /* ... veh2 may not read from veh1 ... */
    nack_relayed(&ub_test_cat, true, &pol, TEST_IMU, UB_NACK_NOT_AUTHORIZED);
    ub_policy_init(&pol);
    ub_policy_limits_t lim = {.min_period_ms = 500};
    assert_int_equal(ub_policy_set_limits(&pol, &lim), UB_OK); /* ... or not that fast */
    nack_relayed(&ub_test_cat, true, &pol, TEST_IMU, UB_NACK_LIMIT);
}

/* The same with the relay lost: the destination answers the administrator's next request with the source's
 * reason instead of an ACK. Fixing the cause and activating again makes the row active. */
static void test_relayed_nack_survives_loss_and_heals(void **state) {
    (void)state;
    hw_t *h = hw_new(&ub_test_cat, false);
    /* veh2 has no route back to gcs1 for a while: its ACK and its relay are lost, gcs1's requests are not. */
    int v2_to_g1 = ub_node_find_entity(h->v2, h->id[G1]);
    assert_int_equal(ub_node_set_mask(h->v2, h->e[V2], v2_to_g1, 0), UB_OK);
    int row = flow_row(h, &h->adm1, UB_ADMIN_ROW_SUBSCRIPTION, TEST_IMU, 100);
    run_to(h, 600);
    assert_int_equal(info_of(&h->adm1, row).status, UB_ADMIN_PENDING);
    assert_true(ub_node_counters(h->v2)->nacks_relayed >= 2); /* relayed, then answered, into no route */
    assert_int_equal(ub_node_set_mask(h->v2, h->e[V2], v2_to_g1, 0x1), UB_OK);
    run_to(h, 1000);
    ub_admin_row_info_t info = info_of(&h->adm1, row);
    assert_int_equal(info.status, UB_ADMIN_FAILED);
    assert_int_equal(info.nack_reason, UB_NACK_UNBOUND);
    assert_true(info.nack_relayed);
    /* The operator has veh1 host imuOut and activates the row again: a fresh start, no stale refusal. */
    assert_int_equal(ub_node_bind(h->v1, TEST_IMU, &h->imu_src), UB_OK);
    assert_int_equal(ub_admin_set_active(&h->adm1, row, true, h->w->now_ms), UB_OK);
    run_to(h, h->w->now_ms + 1500);
    info = info_of(&h->adm1, row);
    assert_int_equal(info.status, UB_ADMIN_ACTIVE);
    assert_false(info.nack_relayed);
    hw_free(h);
}

/* Two administrators ask for the same flow at 100 ms and 500 ms. The flow runs at the first one's rate, its row
 * says active; the second is told other_admin and never moves nor stops the first one's flow. */
static void two_administrators(ub_admin_row_type_t type, uint32_t instance) {
    hw_t *h = hw_new(&ub_test_cat, true);
    int r1 = flow_row(h, &h->adm1, type, instance, 100);
    run_to(h, 1000);
    int r2 = flow_row(h, &h->adm2, type, instance, 500);
    run_to(h, 3000);
    assert_int_equal(info_of(&h->adm1, r1).status, UB_ADMIN_ACTIVE);
    ub_admin_row_info_t i2 = info_of(&h->adm2, r2);
    assert_int_equal(i2.status, UB_ADMIN_FAILED);
    assert_int_equal(i2.nack_reason, UB_NACK_OTHER_ADMIN);
    assert_false(i2.nack_relayed);
    assert_string_equal(ub_nack_reason_name(UB_NACK_OTHER_ADMIN), "other_admin");
    assert_in_range(received(h, instance, 2000, 3000), 9, 11); /* 10 Hz: gcs1's rate, as its row says */
    /* The second operator switches its row off: nothing changes for the first. */
    assert_int_equal(ub_admin_set_active(&h->adm2, r2, false, h->w->now_ms), UB_OK);
    run_to(h, 5000);
    assert_in_range(received(h, instance, 4000, 5000), 9, 11);
    assert_int_equal(info_of(&h->adm1, r1).status, UB_ADMIN_ACTIVE);
    /* The first one stops: the flow stops; now the second may have it, at its own rate. */
    assert_int_equal(ub_admin_set_active(&h->adm1, r1, false, h->w->now_ms), UB_OK);
    run_to(h, 6500);
    assert_int_equal(info_of(&h->adm1, r1).status, UB_ADMIN_INACTIVE);
    assert_int_equal(received(h, instance, 6000, 6500), 0);
    assert_int_equal(ub_admin_set_active(&h->adm2, r2, true, h->w->now_ms), UB_OK);
    run_to(h, 9000);
    assert_int_equal(info_of(&h->adm2, r2).status, UB_ADMIN_ACTIVE);
    assert_in_range(received(h, instance, 8000, 9000), 2, 3); /* 2 Hz */
    hw_free(h);
}

static void test_two_administrators_subscription(void **state) {
    (void)state;
    two_administrators(UB_ADMIN_ROW_SUBSCRIPTION, TEST_IMU);
}

static void test_two_administrators_publication(void **state) {
    (void)state;
    two_administrators(UB_ADMIN_ROW_PUBLICATION, TEST_GPS);
}

/* A row handed over when its administrator went quiet may be adopted by another. The first one's STOP, sent
 * while it was away, is acknowledged without ending the flow the second one now keeps; its renewed request is
 * told other_admin. */
static void test_adoption_of_a_handed_over_row(void **state) {
    (void)state;
    hw_t *h = hw_new(&ub_test_cat, true);
    int r1 = flow_row(h, &h->adm1, UB_ADMIN_ROW_PUBLICATION, TEST_GPS, 100);
    run_to(h, 1000);
    ub_memlink_set_faults(h->ml[0], &dark);
    run_to(h, 6000); /* gcs1's lease lapsed: handed over, still flowing at 10 Hz */
    assert_in_range(received(h, TEST_GPS, 5000, 6000), 9, 11);
    int r2 = flow_row(h, &h->adm2, UB_ADMIN_ROW_PUBLICATION, TEST_GPS, 500);
    run_to(h, 7000);
    assert_int_equal(info_of(&h->adm2, r2).status, UB_ADMIN_ACTIVE);
    assert_in_range(received(h, TEST_GPS, 6000, 7000), 2, 3); /* gcs2's rate now */
    /* gcs1's operator switches its row off while out of range; the STOP arrives when it is back. */
    assert_int_equal(ub_admin_set_active(&h->adm1, r1, false, h->w->now_ms), UB_OK);
    run_to(h, 8000);
    assert_int_equal(info_of(&h->adm1, r1).status, UB_ADMIN_STOPPING);
    ub_memlink_set_faults(h->ml[0], NULL);
    run_to(h, 9000);
    assert_int_equal(info_of(&h->adm1, r1).status, UB_ADMIN_INACTIVE);
    assert_int_equal(info_of(&h->adm2, r2).status, UB_ADMIN_ACTIVE);
    assert_in_range(received(h, TEST_GPS, 8000, 9000), 2, 3);
    const ub_ps_row_t *kept = row_at(h, V1, UB_PS_PUBLICATION, TEST_GPS, V2);
    assert_memory_equal(kept->owner, h->id[G2], UB_ENTITY_ID_LEN);
    assert_true(kept->frames >= 6); /* the same row since 6 s, never freed and made again */
    assert_int_equal(ub_admin_set_active(&h->adm1, r1, true, h->w->now_ms), UB_OK);
    run_to(h, 9600);
    ub_admin_row_info_t i1 = info_of(&h->adm1, r1);
    assert_int_equal(i1.status, UB_ADMIN_FAILED);
    assert_int_equal(i1.nack_reason, UB_NACK_OTHER_ADMIN);
    /* gcs2 stops its own flow. */
    assert_int_equal(ub_admin_set_active(&h->adm2, r2, false, h->w->now_ms), UB_OK);
    run_to(h, 10500);
    assert_int_equal(info_of(&h->adm2, r2).status, UB_ADMIN_INACTIVE);
    assert_int_equal(received(h, TEST_GPS, 10000, 10500), 0);
    hw_free(h);
}

/* Exclusive-administrator policy: while gcs1 keeps rows at veh1, gcs2 may not set up anything there, not
 * even another flow; when gcs1's rows are stopped, gcs2 may. The config key sets the same flag. */
static void test_exclusive_administrator(void **state) {
    (void)state;
    hw_t *h = hw_new(&ub_test_cat, true);
    ub_policy_init(&h->pol);
    assert_int_equal(ub_policy_add_admin(&h->pol, h->id[G1]), UB_OK);
    assert_int_equal(ub_policy_add_admin(&h->pol, h->id[G2]), UB_OK);
    assert_int_equal(ub_policy_add_rule(&h->pol, UB_POLICY_WRITE, "veh2", "veh1", "*"), UB_OK);
    ub_policy_set_exclusive(&h->pol, true);
    for (int k = 0; k < 4; k++) ub_node_set_policy(node_of(h, k), &h->pol);
    int r1 = flow_row(h, &h->adm1, UB_ADMIN_ROW_PUBLICATION, TEST_GPS, 100);
    run_to(h, 1000);
    int r2 = flow_row(h, &h->adm2, UB_ADMIN_ROW_PUBLICATION, TEST_IMU, 100); /* another flow, same node */
    run_to(h, 2000);
    assert_int_equal(info_of(&h->adm1, r1).status, UB_ADMIN_ACTIVE);
    assert_int_equal(info_of(&h->adm2, r2).status, UB_ADMIN_FAILED);
    assert_int_equal(info_of(&h->adm2, r2).nack_reason, UB_NACK_OTHER_ADMIN);
    assert_int_equal(ub_node_counters(h->v1)->other_admin, 1);
    assert_int_equal(ub_admin_set_active(&h->adm1, r1, false, h->w->now_ms), UB_OK);
    run_to(h, 3000);
    assert_int_equal(ub_admin_set_active(&h->adm2, r2, true, h->w->now_ms), UB_OK);
    run_to(h, 4000);
    assert_int_equal(info_of(&h->adm2, r2).status, UB_ADMIN_ACTIVE);

    /* Config: "exclusive_admin": true (and a clear error for anything but a boolean). */
    static const char doc[] = "{\"entities\": [{\"name\": \"gcs1\"}, {\"name\": \"veh1\"}],\n"
                              " \"security\": {\"administrators\": [\"gcs1\"], \"exclusive_admin\": true}}";
    static const char bad[] = "{\"entities\": [{\"name\": \"gcs1\"}],\n"
                              " \"security\": {\"exclusive_admin\": \"yes\"}}";
    ub_nodecfg_t *cfg = calloc(1, sizeof *cfg);
    assert_non_null(cfg);
    char err[256];
    assert_int_equal(ub_nodecfg_parse(cfg, doc, sizeof doc - 1, "inline.json", err, sizeof err), UB_OK);
    assert_true(cfg->has_policy && cfg->policy.exclusive_admin);
    assert_int_equal(ub_nodecfg_parse(cfg, bad, sizeof bad - 1, "inline.json", err, sizeof err), UB_ERR_CONFIG);
    assert_string_equal(err, "inline.json:2: field 'security.exclusive_admin': must be true (one administrator at a "
                             "time per node) or false");
    free(cfg);
    hw_free(h);
}

/* Removing an entity leaves no noise: rows toward it go without STOPs nobody can route, administration rows
 * whose target it is become inactive at once; rows it merely administered live on under their keeper. */
static void test_removing_entities_is_quiet(void **state) {
    (void)state;
    hw_t *h = hw_new(&ub_test_cat, true);
    int sub = flow_row(h, &h->adm1, UB_ADMIN_ROW_SUBSCRIPTION, TEST_IMU, 100);
    assert_true(ub_pubsub_subscribe(h->v2, h->e[V2], TEST_GPS, h->id[V1], 200, 0) >= 0);
    run_to(h, 2000);
    /* gcs1 is gone and veh2 forgets it: the imuOut subscription gcs1 set up goes on (its keeper, veh1, is there). */
    ub_memlink_set_faults(h->ml[0], &dark);
    assert_int_equal(ub_node_remove_entity(h->v2, ub_node_find_entity(h->v2, h->id[G1]), h->w->now_ms), UB_OK);
    run_to(h, 12000);
    assert_in_range(received(h, TEST_IMU, 11000, 12000), 9, 11);
    /* veh2 forgets veh1: both subscriptions go at once, and not one frame is sent toward it. */
    uint64_t no_route = ub_node_counters(h->v2)->drops[UB_DROP_NO_ROUTE];
    assert_int_equal(ub_node_remove_entity(h->v2, ub_node_find_entity(h->v2, h->id[V1]), h->w->now_ms), UB_OK);
    assert_int_equal(ub_pubsub_count(h->v2, h->e[V2], UB_PS_SUBSCRIPTION), 0);
    assert_int_equal(ub_node_counters(h->v2)->rows_stopped, 2);
    run_to(h, 15000);
    assert_int_equal(ub_node_counters(h->v2)->drops[UB_DROP_NO_ROUTE], no_route);
    /* gcs1 forgets veh2, the target of its subscription row: inactive now, no STOP toward nowhere. */
    assert_int_equal(ub_node_remove_entity(h->g1, ub_node_find_entity(h->g1, h->id[V2]), h->w->now_ms), UB_OK);
    assert_int_equal(info_of(&h->adm1, sub).status, UB_ADMIN_INACTIVE);
    uint64_t sent = ub_node_counters(h->g1)->originated;
    run_to(h, 17000);
    assert_int_equal(ub_node_counters(h->g1)->originated, sent);
    hw_free(h);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_flows_outlive_the_administrator),
        cmocka_unit_test(test_handed_over_rows_go_with_their_keeper),
        cmocka_unit_test(test_manual_mask_keeps_a_publication),
        cmocka_unit_test(test_restarted_source_heals),
        cmocka_unit_test(test_source_nack_reaches_the_administrator),
        cmocka_unit_test(test_relayed_nack_survives_loss_and_heals),
        cmocka_unit_test(test_two_administrators_subscription),
        cmocka_unit_test(test_two_administrators_publication),
        cmocka_unit_test(test_adoption_of_a_handed_over_row),
        cmocka_unit_test(test_exclusive_administrator),
        cmocka_unit_test(test_removing_entities_is_quiet),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
