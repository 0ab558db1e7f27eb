/*
 * Membership at run time: removing entities and links through the node API
 * (everything naming them cleared or stopped, and counted), manual masks that
 * pin, and MEMBERSHIP requests over the bus (ub_member.h) between a GCS node
 * and a vehicle node on a memlink: add, idempotent retries, masks, removal,
 * link operations with and without a handler, refusals, timeouts.
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
#include "ub/ub_member.h"
#include "ub/ub_node.h"
#include "ub/ub_policy.h"
#include "ub/ub_pubsub.h"
#include "ub/ub_wire.h"

static void test_remove_entity_clears_everything_that_names_it(void **state) {
    (void)state;
    world_t *w = world_new();
    ub_node_t *n = world_node(w, &ub_test_cat, NULL);
    int gcs = ub_node_add_entity_name(n, "gcs1", true);
    int uav = ub_node_add_entity_name(n, "uav7", false);
    int other = ub_node_add_entity_name(n, "uav8", false);
    int l0 = ub_node_add_link(n, gcs, 0, "radio");
    capture_t cap = {0};
    assert_int_equal(ub_node_link_attach(n, l0, &capture_ops, &cap), UB_OK);
    assert_int_equal(ub_node_set_mask(n, gcs, uav, 0x01), UB_OK);
    assert_int_equal(ub_node_set_mask(n, gcs, other, 0x01), UB_OK);
    struct test_gps gps = {0};
    assert_int_equal(ub_node_bind(n, TEST_GPS, &gps), UB_OK);
    uint8_t uav_id[UB_ENTITY_ID_LEN], other_id[UB_ENTITY_ID_LEN];
    test_eid("uav7", uav_id);
    test_eid("uav8", other_id);
    /* Rows naming uav7: a publication to it, a subscription from it; one row for uav8 stays. */
    assert_true(ub_pubsub_publish(n, gcs, TEST_GPS, uav_id, 100, 0) >= 0);
    assert_true(ub_pubsub_subscribe(n, gcs, TEST_IMU, uav_id, 100, 0) >= 0);
    assert_true(ub_pubsub_publish(n, gcs, TEST_GPS, other_id, 100, 0) >= 0);
    /* An administration row with uav7 as source. */
    ub_admin_t *adm = calloc(1, sizeof *adm);
    assert_non_null(adm);
    assert_int_equal(ub_admin_init(adm, n, gcs, NULL), UB_OK);
    ub_admin_row_spec_t spec = {.instance = TEST_GPS, .period_ms = 100, .type = UB_ADMIN_ROW_PUBLICATION};
    memcpy(spec.source, uav_id, UB_ENTITY_ID_LEN);
    memcpy(spec.destination, ub_node_entity_id(n, gcs), UB_ENTITY_ID_LEN);
    int arow = ub_admin_add_row(adm, &spec);
    assert_int_equal(ub_admin_set_active(adm, arow, true, 0), UB_OK);
    /* uav7 sends us a frame: it has a duplicate window here. */
    uint8_t frame[UB_FRAME_MAX];
    size_t len = make_frame(frame, UB_ADMIN_DATA, ub_test_cat.instances[TEST_GPS].id, "uav7", "gcs1", 5, 8,
                            ub_test_cat.instances[TEST_GPS].type->fingerprint, (const uint8_t[24]){0}, 24);
    assert_int_equal(ub_node_rx_frame(n, l0, frame, len, 1), UB_OK);
    assert_int_equal(ub_node_counters(n)->delivered, 1);

    assert_int_equal(ub_node_remove_entity(n, gcs, 2), UB_ERR_INVAL); /* local entities stay */
    assert_int_equal(ub_node_remove_entity(n, uav, 2), UB_OK);
    const ub_node_counters_t *c = ub_node_counters(n);
    assert_int_equal(c->entities_removed, 1);
    assert_int_equal(c->rows_stopped, 2);
    assert_int_equal(c->admin_rows_stopped, 1);
    assert_int_equal(c->dedup_cleared, 1);
    assert_int_equal(ub_node_find_entity(n, uav_id), UB_ERR_NOTFOUND);
    assert_int_equal(ub_pubsub_find(n, gcs, UB_PS_PUBLICATION, TEST_GPS, uav_id), UB_ERR_NOTFOUND);
    assert_int_equal(ub_pubsub_find(n, gcs, UB_PS_SUBSCRIPTION, TEST_IMU, uav_id), UB_ERR_NOTFOUND);
    assert_true(ub_pubsub_find(n, gcs, UB_PS_PUBLICATION, TEST_GPS, other_id) >= 0);
    ub_admin_row_info_t info;
    assert_int_equal(ub_admin_row_status(adm, arow, &info), UB_OK);
    assert_false(info.active_flag);
    /* The freed row comes back clean: no mask, no pin, a fresh duplicate window (seq 5 accepted again). */
    int again = ub_node_add_entity_name(n, "uav7", false);
    assert_int_equal(again, uav);
    uint8_t mask = 0xFF;
    assert_int_equal(ub_node_get_mask(n, gcs, again, &mask), UB_OK);
    assert_int_equal(mask, 0);
    assert_false(ub_node_mask_pinned(n, gcs, again));
    assert_int_equal(ub_node_rx_frame(n, l0, frame, len, 3), UB_OK);
    assert_int_equal(ub_node_counters(n)->delivered, 2);
    assert_int_equal(ub_node_counters(n)->drops[UB_DROP_DUPLICATE], 0);
    free(adm);
    free(w);
}

static void test_remove_link(void **state) {
    (void)state;
    world_t *w = world_new();
    ub_node_t *n = world_node(w, &ub_test_cat, NULL);
    int e = ub_node_add_entity_name(n, "gcs1", true);
    int d = ub_node_add_entity_name(n, "uav7", false);
    int l0 = ub_node_add_link(n, e, 0, "a");
    int l1 = ub_node_add_link(n, e, 1, "b");
    capture_t cap = {0};
    assert_int_equal(ub_node_link_attach(n, l1, &capture_ops, &cap), UB_OK);
    assert_int_equal(ub_node_set_mask(n, e, d, 0x03), UB_OK);
    assert_int_equal(ub_node_remove_link(n, l1), UB_ERR_INVAL); /* a transport is attached */
    assert_int_equal(ub_node_link_detach(n, l1), UB_OK);
    assert_int_equal(ub_node_remove_link(n, l1), UB_OK);
    uint8_t mask = 0;
    assert_int_equal(ub_node_get_mask(n, e, d, &mask), UB_OK);
    assert_int_equal(mask, 0x01);
    assert_true(ub_node_mask_pinned(n, e, d));
    assert_null(ub_node_link(n, l1));
    assert_int_equal(ub_node_find_link(n, "b"), UB_ERR_NOTFOUND);
    assert_int_equal(ub_node_remove_link(n, l0), UB_OK);
    assert_int_equal(ub_node_get_mask(n, e, d, &mask), UB_OK);
    assert_int_equal(mask, 0);
    assert_false(ub_node_mask_pinned(n, e, d)); /* emptied: no longer pinned */
    /* The index and the name are free again. */
    int l2 = ub_node_add_link(n, e, 1, "b");
    assert_true(l2 >= 0);
    assert_int_equal(ub_node_link(n, l2)->counters.frames_out, 0);
    assert_int_equal(ub_node_counters(n)->links_removed, 2);
    assert_int_equal(ub_node_counters(n)->links_added, 3);
    free(w);
}

static void test_memlink_disconnect(void **state) {
    (void)state;
    world_t *w = world_new();
    ub_node_t *a = world_node(w, &ub_test_cat, NULL);
    ub_node_t *b = world_node(w, &ub_test_cat, NULL);
    int ea = ub_node_add_entity_name(a, "a", true), eb = ub_node_add_entity_name(b, "b", true);
    int la = ub_node_add_link(a, ea, 0, "ab"), lb = ub_node_add_link(b, eb, 0, "ba");
    ub_memlink_t *ml = world_connect(w, a, la, b, lb, NULL, 1);
    assert_int_equal(ub_node_add_entity_name(a, "b", false), 1);
    assert_int_equal(ub_node_set_mask(a, ea, 1, 0x01), UB_OK);
    struct test_gps gps = {0};
    assert_int_equal(ub_node_bind(a, TEST_GPS, &gps), UB_OK);
    uint8_t bid[UB_ENTITY_ID_LEN];
    test_eid("b", bid);
    assert_int_equal(ub_node_send_data(a, ea, TEST_GPS, bid, 0), 1);
    assert_int_equal(ub_memlink_pending(ml), 1);
    ub_memlink_disconnect(ml);
    assert_int_equal(ub_memlink_pending(ml), 0);
    assert_int_equal(ub_memlink_stats(ml, 0)->lost, 1);
    assert_null(ub_node_link(a, la)->ops);
    assert_int_equal(ub_memlink_pump(ml, 1), 0);
    assert_int_equal(ub_node_remove_link(a, la), UB_OK);
    assert_int_equal(ub_node_remove_link(b, lb), UB_OK);
    free(w);
}

/* ---- MEMBERSHIP over the bus ------------------------------------------------------------------------ */

typedef struct pair {
    world_t *w;
    ub_node_t *gcs, *uav;
    int g, u;          /* entity indexes of gcs1 (in gcs) and uav1 (in uav) */
    ub_member_t m;     /* the GCS's requester */
    ub_member_t um;    /* the vehicle's (link handler) */
    int handler_calls;
} pair_t;

static pair_t *pair_new(void) {
    pair_t *p = calloc(1, sizeof *p);
    assert_non_null(p);
    p->w = world_new();
    p->gcs = world_node(p->w, &ub_test_cat, NULL);
    p->uav = world_node(p->w, &ub_test_cat, NULL);
    p->g = ub_node_add_entity_name(p->gcs, "gcs1", true);
    p->u = ub_node_add_entity_name(p->uav, "uav1", true);
    int gu = ub_node_add_entity_name(p->gcs, "uav1", false);
    int ug = ub_node_add_entity_name(p->uav, "gcs1", false);
    int lg = ub_node_add_link(p->gcs, p->g, 0, "g2u"), lu = ub_node_add_link(p->uav, p->u, 0, "u2g");
    world_connect(p->w, p->gcs, lg, p->uav, lu, NULL, 1);
    assert_int_equal(ub_node_set_mask(p->gcs, p->g, gu, 0x01), UB_OK);
    assert_int_equal(ub_node_set_mask(p->uav, p->u, ug, 0x01), UB_OK);
    ub_member_options_t mo = {.retry_ms = 50, .max_retries = 4};
    assert_int_equal(ub_member_init(&p->m, p->gcs, p->g, &mo), UB_OK);
    return p;
}

static ub_member_spec_t spec_for(ub_member_op_t op, const char *target, const char *subject) {
    ub_member_spec_t s;
    memset(&s, 0, sizeof s);
    s.op = (uint8_t)op;
    test_eid(target, s.target);
    if (subject != NULL) test_eid(subject, s.subject);
    return s;
}

static ub_member_info_t run_request(pair_t *p, const ub_member_spec_t *s) {
    int row = ub_member_request(&p->m, s, p->w->now_ms);
    assert_true(row >= 0);
    world_run(p->w, p->w->now_ms + 400, 1);
    ub_member_info_t info;
    assert_int_equal(ub_member_status(&p->m, row, &info), UB_OK);
    assert_int_equal(ub_member_forget(&p->m, row), UB_OK);
    return info;
}

static int link_handler(void *user, ub_node_t *node, int entity, ub_member_op_t op, unsigned index, const char *name,
                        const char *spec, uint64_t now_ms) {
    (void)spec;
    (void)now_ms;
    pair_t *p = user;
    p->handler_calls++;
    if (op == UB_MEMBER_ADD_LINK) {
        int rc = ub_node_add_link(node, entity, index, name);
        return rc >= 0 ? UB_OK : rc;
    }
    int id = ub_node_find_link(node, name);
    if (id < 0) return id;
    return ub_node_remove_link(node, id);
}

static void test_membership_requests(void **state) {
    (void)state;
    pair_t *p = pair_new();
    uint8_t v9[UB_ENTITY_ID_LEN];
    test_eid("uav9", v9);

    /* The announcement: uav9 exists. Applied once, then idempotent. */
    ub_member_spec_t add = spec_for(UB_MEMBER_ADD_ENTITY, "uav1", "uav9");
    ub_member_info_t info = run_request(p, &add);
    assert_int_equal(info.status, UB_MEMBER_DONE);
    assert_true(info.changed);
    assert_int_equal(info.attempts, 1);
    int e9 = ub_node_find_entity(p->uav, v9);
    assert_true(e9 >= 0);
    info = run_request(p, &add);
    assert_int_equal(info.status, UB_MEMBER_DONE);
    assert_false(info.changed);

    /* A mask set over the bus pins the vehicle's entry; 0 unpins it. */
    ub_member_spec_t mask = spec_for(UB_MEMBER_SET_MASK, "uav1", "uav9");
    mask.mask = 0x01;
    assert_int_equal(run_request(p, &mask).status, UB_MEMBER_DONE);
    assert_true(ub_node_mask_pinned(p->uav, p->u, e9));
    uint8_t m = 0;
    assert_int_equal(ub_node_get_mask(p->uav, p->u, e9, &m), UB_OK);
    assert_int_equal(m, 0x01);
    mask.mask = 0x02; /* link[1] does not exist: invalid */
    info = run_request(p, &mask);
    assert_int_equal(info.status, UB_MEMBER_FAILED);
    assert_int_equal(info.nack_reason, UB_NACK_INVALID);

    /* Removal. Removing the target's own entity is refused. */
    ub_member_spec_t rm = spec_for(UB_MEMBER_REMOVE_ENTITY, "uav1", "uav9");
    info = run_request(p, &rm);
    assert_int_equal(info.status, UB_MEMBER_DONE);
    assert_true(info.changed);
    assert_int_equal(ub_node_find_entity(p->uav, v9), UB_ERR_NOTFOUND);
    assert_false(run_request(p, &rm).changed);
    ub_member_spec_t rm_self = spec_for(UB_MEMBER_REMOVE_ENTITY, "uav1", "uav1");
    info = run_request(p, &rm_self);
    assert_int_equal(info.status, UB_MEMBER_FAILED);
    assert_int_equal(info.nack_reason, UB_NACK_INVALID);

    /* Links need the application: without a handler, unsupported; with one, applied. */
    ub_member_spec_t link = spec_for(UB_MEMBER_ADD_LINK, "uav1", NULL);
    link.link_index = 3;
    strcpy(link.link_name, "radio2");
    strcpy(link.port_spec, "udp:bind=127.0.0.1:0,peer=127.0.0.1:9");
    info = run_request(p, &link);
    assert_int_equal(info.status, UB_MEMBER_FAILED);
    assert_int_equal(info.nack_reason, UB_NACK_UNSUPPORTED);
    assert_int_equal(ub_member_init(&p->um, p->uav, p->u, NULL), UB_OK);
    ub_member_set_link_handler(&p->um, link_handler, p);
    info = run_request(p, &link);
    assert_int_equal(info.status, UB_MEMBER_DONE);
    assert_true(info.changed);
    int lid = ub_node_find_link(p->uav, "radio2");
    assert_true(lid >= 0);
    assert_int_equal(ub_node_link(p->uav, lid)->index, 3);
    assert_false(run_request(p, &link).changed); /* exists: already so */
    ub_member_spec_t unlink = spec_for(UB_MEMBER_REMOVE_LINK, "uav1", NULL);
    strcpy(unlink.link_name, "radio2");
    assert_true(run_request(p, &unlink).changed);
    assert_int_equal(ub_node_find_link(p->uav, "radio2"), UB_ERR_NOTFOUND);
    assert_int_equal(p->handler_calls, 3);

    const ub_node_counters_t *c = ub_node_counters(p->uav);
    assert_int_equal(c->membership_applied, 8);
    assert_int_equal(c->membership_refused, 3);
    assert_int_equal(ub_member_counters(&p->m)->done, 8);
    assert_int_equal(ub_member_counters(&p->m)->failed, 3);
    free(p->w);
    free(p);
}

static void test_membership_timeout_and_validation(void **state) {
    (void)state;
    pair_t *p = pair_new();
    /* A target nobody routes to: retried max_retries times, then FAILED with no reason. */
    assert_true(ub_node_add_entity_name(p->gcs, "ghost", false) >= 0);
    ub_member_spec_t s = spec_for(UB_MEMBER_ADD_ENTITY, "ghost", "uav9");
    ub_member_info_t info = run_request(p, &s);
    assert_int_equal(info.status, UB_MEMBER_FAILED);
    assert_int_equal(info.nack_reason, UB_NACK_NONE);
    assert_int_equal(info.attempts, 4);
    assert_int_equal(ub_member_counters(&p->m)->sent, 4);
    /* Requests checked before they leave. */
    ub_member_spec_t bad = spec_for(UB_MEMBER_ADD_ENTITY, "uav1", NULL); /* no subject */
    assert_int_equal(ub_member_request(&p->m, &bad, 0), UB_ERR_INVAL);
    bad.op = 99;
    assert_int_equal(ub_member_request(&p->m, &bad, 0), UB_ERR_INVAL);
    ub_member_spec_t nolink = spec_for(UB_MEMBER_ADD_LINK, "uav1", NULL);
    assert_int_equal(ub_member_request(&p->m, &nolink, 0), UB_ERR_INVAL);
    ub_member_spec_t ll = spec_for(UB_MEMBER_ADD_ENTITY, "uav1", "uav9");
    memset(ll.subject, UB_LINK_LOCAL_BYTE, UB_ENTITY_ID_LEN);
    assert_int_equal(ub_member_request(&p->m, &ll, 0), UB_ERR_INVAL);
    /* A request to one of our own entities is applied locally, synchronously. */
    ub_member_spec_t local = spec_for(UB_MEMBER_ADD_ENTITY, "gcs1", "uav5");
    info = run_request(p, &local);
    assert_int_equal(info.status, UB_MEMBER_DONE);
    uint8_t v5[UB_ENTITY_ID_LEN];
    test_eid("uav5", v5);
    assert_true(ub_node_find_entity(p->gcs, v5) >= 0);
    /* Table full: rows stay until forgotten. */
    for (int i = 0; i < UB_MAX_MEMBER_REQUESTS; i++) assert_int_equal(ub_member_request(&p->m, &local, 0), i);
    assert_int_equal(ub_member_request(&p->m, &local, 0), UB_ERR_FULL);
    free(p->w);
    free(p);
}

/* Under a policy only administrators may change a node's membership over the bus; a local request is not judged. */
static void test_membership_needs_an_administrator(void **state) {
    (void)state;
    pair_t *p = pair_new();
    ub_policy_t *pol = calloc(1, sizeof *pol);
    assert_non_null(pol);
    ub_policy_init(pol);
    uint8_t boss[UB_ENTITY_ID_LEN];
    test_eid("boss", boss);
    assert_int_equal(ub_policy_add_admin(pol, boss), UB_OK);
    ub_node_set_policy(p->uav, pol);
    ub_member_spec_t add = spec_for(UB_MEMBER_ADD_ENTITY, "uav1", "uav9");
    ub_member_info_t info = run_request(p, &add);
    assert_int_equal(info.status, UB_MEMBER_FAILED);
    assert_int_equal(info.nack_reason, UB_NACK_NOT_AUTHORIZED);
    uint8_t v9[UB_ENTITY_ID_LEN];
    test_eid("uav9", v9);
    assert_int_equal(ub_node_find_entity(p->uav, v9), UB_ERR_NOTFOUND);
    assert_int_equal(ub_node_counters(p->uav)->drops[UB_DROP_NOT_AUTHORIZED], 1);
    assert_int_equal(ub_node_counters(p->uav)->membership_refused, 1);
    assert_false(ub_node_may_administer(p->uav, p->u, ub_node_entity_id(p->gcs, p->g), true));
    assert_true(ub_node_may_administer(p->uav, p->u, boss, true));
    assert_true(ub_node_may_administer(p->uav, p->u, boss, false)); /* no keyring: nothing is verified */
    /* gcs1 becomes an administrator: the same request is applied. */
    assert_int_equal(ub_policy_add_admin(pol, ub_node_entity_id(p->gcs, p->g)), UB_OK);
    info = run_request(p, &add);
    assert_int_equal(info.status, UB_MEMBER_DONE);
    assert_true(ub_node_find_entity(p->uav, v9) >= 0);
    /* A request between entities of one node is not judged (they share the process). */
    assert_int_equal(ub_member_init(&p->um, p->uav, p->u, NULL), UB_OK);
    ub_member_spec_t self = spec_for(UB_MEMBER_REMOVE_ENTITY, "uav1", "uav9");
    assert_true(ub_member_request(&p->um, &self, p->w->now_ms) >= 0);
    world_run(p->w, p->w->now_ms + 1, 1);
    assert_int_equal(ub_node_find_entity(p->uav, v9), UB_ERR_NOTFOUND);
    free(pol);
    free(p->w);
    free(p);
}

/* Malformed MEMBERSHIP frames are counted bad_payload and not answered; stray replies are counted. */
static void test_membership_bad_frames(void **state) {
    (void)state;
    pair_t *p = pair_new();
    int lu = ub_node_find_link(p->uav, "u2g");
    uint8_t frame[UB_FRAME_MAX], payload[UB_MEMBER_ENTITY_LEN] = {0};
    static const uint8_t zero_dir[UB_DIR_ID_LEN] = {0};
    size_t len = make_frame(frame, UB_ADMIN_MEMBERSHIP, zero_dir, "gcs1", "uav1", 100, 8, 0, payload, 10);
    assert_int_equal(ub_node_rx_frame(p->uav, lu, frame, len, 1), UB_OK);
    assert_int_equal(ub_node_counters(p->uav)->drops[UB_DROP_BAD_PAYLOAD], 1);
    /* Unknown operation: a well-formed frame, NACKed invalid. */
    payload[UB_MEMBER_OFF_OP] = 42;
    len = make_frame(frame, UB_ADMIN_MEMBERSHIP, zero_dir, "gcs1", "uav1", 101, 8, 0, payload, sizeof payload);
    assert_int_equal(ub_node_rx_frame(p->uav, lu, frame, len, 2), UB_OK);
    assert_int_equal(ub_node_counters(p->uav)->membership_refused, 1);
    /* A reply for no request. */
    uint8_t reply[8] = {0};
    ub_put_u32le(reply, 777);
    reply[4] = UB_ADMIN_MEMBERSHIP;
    int lg = ub_node_find_link(p->gcs, "g2u");
    len = make_frame(frame, UB_ADMIN_ACK, zero_dir, "uav1", "gcs1", 102, 8, 0, reply, sizeof reply);
    assert_int_equal(ub_node_rx_frame(p->gcs, lg, frame, len, 3), UB_OK);
    assert_int_equal(ub_member_counters(&p->m)->unmatched_replies, 1);
    free(p->w);
    free(p);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_remove_entity_clears_everything_that_names_it),
        cmocka_unit_test(test_remove_link),
        cmocka_unit_test(test_memlink_disconnect),
        cmocka_unit_test(test_membership_requests),
        cmocka_unit_test(test_membership_timeout_and_validation),
        cmocka_unit_test(test_membership_needs_an_administrator),
        cmocka_unit_test(test_membership_bad_frames),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
