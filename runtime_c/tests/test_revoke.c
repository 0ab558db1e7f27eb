/*
 * Revocation that reaches the fleet (ub_revoke.h), over memlinks in one process: a line of four nodes
 * gcs1 - relay1 - rmax1ob1 - fcs20. The operator submits a record at gcs1; it reaches fcs20, three
 * hops away (two hops beyond its first neighbour), whose store then refuses the revoked entity; every
 * node persisted it once; copies die out (each node sends it `repeats` times, never more); a record of
 * another authority and junk are refused and not spread; a flood is cut by the verification budget.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "support/ub_test_ident.h"
#include "support/ub_test_world.h"
#include "ub/ub_node.h"
#include "ub/ub_revoke.h"
#include "ub/ub_sec.h"

#define N 4
#define T0 1790000000u

typedef struct persisted {
    unsigned calls;
    size_t count; /* revocations in the store at the last call */
} persisted_t;

static int persist_count(void *user, const ub_ident_store_t *store) {
    persisted_t *p = user;
    p->calls++;
    p->count = ub_ident_revocation_count(store);
    return UB_OK;
}

typedef struct line {
    world_t *w;
    ub_node_t *node[N];
    ub_ident_store_t store[N];
    ub_revoke_t rv[N];
    persisted_t persisted[N];
    test_authority_t auth;
    test_entity_t victim;
} line_t;

static const char *const NAMES[N] = {"gcs1", "relay1", "rmax1ob1", "fcs20"};

static line_t *line_new(void) {
    line_t *l = calloc(1, sizeof *l);
    assert_non_null(l);
    l->w = world_new();
    assert_int_equal(test_authority(&l->auth, "fleet authority"), UB_OK);
    assert_int_equal(test_issue(&l->victim, &l->auth, "rmax2ob1", UB_ROLE_VEHICLE, 8, T0, T0 + 86400), UB_OK);
    int links[N][2];
    for (int i = 0; i < N; i++) {
        l->node[i] = world_node(l->w, &ub_test_cat, NULL);
        int e = ub_node_add_entity_name(l->node[i], NAMES[i], true);
        assert_true(e >= 0);
        links[i][0] = ub_node_add_link(l->node[i], e, 0, "left");
        links[i][1] = ub_node_add_link(l->node[i], e, 1, "right");
        assert_true(links[i][0] >= 0 && links[i][1] >= 0);
        ub_ident_store_init(&l->store[i]);
        assert_int_equal(ub_ident_set_authority(&l->store[i], l->auth.pk), UB_OK);
        assert_int_equal(ub_ident_add_peer(&l->store[i], l->victim.cert_bytes, UB_CERT_LEN, T0, NULL), UB_OK);
        assert_int_equal(ub_revoke_init(&l->rv[i], l->node[i], &l->store[i], NULL, persist_count, &l->persisted[i]),
                         UB_OK);
    }
    for (int i = 0; i + 1 < N; i++)
        (void)world_connect(l->w, l->node[i], links[i][1], l->node[i + 1], links[i + 1][0], NULL, (uint64_t)i + 1);
    return l;
}

static void line_free(line_t *l) {
    free(l->w);
    free(l);
}

static void test_spreads_to_the_far_end(void **state) {
    (void)state;
    line_t *l = line_new();
    uint8_t pk[32];
    for (int i = 0; i < N; i++) assert_int_equal(ub_ident_peer_kx_key(&l->store[i], l->victim.cert.entity, T0, pk), UB_OK);
    uint8_t rec[UB_REVOCATION_LEN];
    assert_int_equal(test_revoke_record(rec, &l->auth, "rmax2ob1", 8, T0 + 1), UB_OK);
    world_run(l->w, 10, 10);
    assert_int_equal(ub_revoke_submit(&l->rv[0], rec, sizeof rec, l->w->now_ms), UB_OK);
    assert_int_equal(ub_revoke_submit(&l->rv[0], rec, sizeof rec, l->w->now_ms), UB_ERR_EXISTS); /* idempotent */
    /* one tick per node and hop: within 3 ticks of 10 ms the far end holds it */
    world_run(l->w, l->w->now_ms + 40, 10);
    for (int i = 0; i < N; i++) {
        assert_int_equal(ub_ident_peer_kx_key(&l->store[i], l->victim.cert.entity, T0 + 2, pk), UB_ERR_AUTH);
        assert_int_equal(ub_ident_peer_status(&l->store[i], l->victim.cert.entity, T0 + 2), UB_IDENT_REVOKED);
        assert_int_equal(l->rv[i].stats.accepted, 1);
        assert_int_equal(l->persisted[i].calls, 1);
        assert_int_equal(l->persisted[i].count, 1);
    }
    /* the revoked identity cannot come back anywhere */
    ub_ident_status_t why;
    assert_int_equal(ub_ident_add_peer(&l->store[3], l->victim.cert_bytes, UB_CERT_LEN, T0 + 2, &why), UB_ERR_AUTH);
    assert_int_equal(why, UB_IDENT_REVOKED);
    /* copies die out: after the repeats, nothing more is sent, and each node sent at most repeats x its links */
    world_run(l->w, l->w->now_ms + 5000, 10);
    uint32_t sent_before[N];
    for (int i = 0; i < N; i++) {
        sent_before[i] = l->rv[i].stats.sent;
        uint32_t n_links = (i == 0 || i == N - 1) ? 1u : 2u;
        assert_true(l->rv[i].stats.sent <= 4u * n_links);
        assert_true(l->rv[i].stats.sent >= 1u);
        assert_int_equal(l->rv[i].stats.refused, 0);
        assert_true(l->rv[i].stats.known >= 1u || i == 0); /* neighbours' copies counted, not re-spread */
    }
    world_run(l->w, l->w->now_ms + 5000, 10);
    for (int i = 0; i < N; i++) assert_int_equal(l->rv[i].stats.sent, sent_before[i]);
    line_free(l);
}

static void test_foreign_and_junk_records_stay_put(void **state) {
    (void)state;
    line_t *l = line_new();
    test_authority_t other;
    assert_int_equal(test_authority(&other, "another fleet"), UB_OK);
    uint8_t rec[UB_REVOCATION_LEN];
    assert_int_equal(test_revoke_record(rec, &other, "rmax2ob1", 8, T0 + 1), UB_OK);
    assert_int_equal(ub_revoke_submit(&l->rv[0], rec, sizeof rec, 0), UB_ERR_AUTH);
    /* sent by a neighbour anyway (an insider relaying junk): refused at the first hop, never spread */
    int link = ub_node_find_link(l->node[0], "right");
    assert_true(link >= 0);
    assert_int_equal(ub_node_send_link_local(l->node[0], link, UB_ADMIN_REVOCATION, rec, sizeof rec, 0), 1);
    rec[50] ^= 1;
    assert_int_equal(ub_node_send_link_local(l->node[0], link, UB_ADMIN_REVOCATION, rec, sizeof rec, 0), 1);
    assert_int_equal(ub_node_send_link_local(l->node[0], link, UB_ADMIN_REVOCATION, rec, 20, 0), 1);
    world_run(l->w, 2000, 10);
    assert_int_equal(l->rv[1].stats.refused, 3);
    assert_int_equal(l->rv[1].stats.sent, 0);
    assert_int_equal(l->rv[2].stats.received, 0);
    uint8_t pk[32];
    for (int i = 0; i < N; i++) assert_int_equal(ub_ident_peer_kx_key(&l->store[i], l->victim.cert.entity, T0, pk), UB_OK);
    const ub_link_counters_t *c = ub_node_link_counters(l->node[1], ub_node_find_link(l->node[1], "left"));
    assert_int_equal(c->drops[UB_DROP_BAD_PAYLOAD], 3);
    line_free(l);
}

static void test_flood_is_bounded(void **state) {
    (void)state;
    line_t *l = line_new();
    uint8_t junk[UB_REVOCATION_LEN];
    assert_int_equal(test_revoke_record(junk, &l->auth, "rmax2ob1", 8, T0 + 1), UB_OK);
    uint8_t genuine[UB_REVOCATION_LEN];
    memcpy(genuine, junk, sizeof genuine);
    junk[100] ^= 0x80; /* a bad signature: costs a verification each */
    int link = ub_node_find_link(l->node[0], "right");
    for (int k = 0; k < 60; k++) /* within the memlink's depth (64) */
        assert_int_equal(ub_node_send_link_local(l->node[0], link, UB_ADMIN_REVOCATION, junk, sizeof junk, 0) >= 0, 1);
    world_run(l->w, 10, 10);
    assert_int_equal(l->rv[1].stats.refused, 32); /* the default budget: 32 verifications per second */
    assert_int_equal(l->rv[1].stats.over_budget, 60 - 32);
    /* the genuine record, repeated by its sender, gets in once the second is over */
    assert_int_equal(ub_revoke_submit(&l->rv[0], genuine, sizeof genuine, l->w->now_ms), UB_OK);
    world_run(l->w, 3000, 10);
    uint8_t pk[32];
    assert_int_equal(ub_ident_peer_kx_key(&l->store[3], l->victim.cert.entity, T0 + 2, pk), UB_ERR_AUTH);
    line_free(l);
}

static uint64_t fixed_clock(void *user) {
    (void)user;
    return T0 + 10;
}

/* Certificates spread like revocations: a node announces its own when the service starts, and a
 * replacement identity submitted at one end is known at the other, but a revoked serial is never spread. */
static void test_certificates_spread(void **state) {
    (void)state;
    line_t *l = line_new();
    test_entity_t fcs, repl;
    assert_int_equal(test_issue(&fcs, &l->auth, "fcs20", UB_ROLE_VEHICLE, 11, T0, T0 + 86400), UB_OK);
    assert_int_equal(test_issue(&repl, &l->auth, "rmax2ob1", UB_ROLE_VEHICLE, 12, T0, T0 + 86400), UB_OK);
    ub_revoke_options_t opt = {.clock_s = fixed_clock};
    for (int i = 0; i < N; i++) {
        assert_int_equal(ub_revoke_remove(&l->rv[i]), UB_OK);
        if (i == N - 1)
            assert_int_equal(ub_ident_set_self(&l->store[i], &fcs.cert, fcs.sign_sk, fcs.kx_sk, T0 + 10, NULL), UB_OK);
        assert_int_equal(ub_revoke_init(&l->rv[i], l->node[i], &l->store[i], &opt, persist_count, &l->persisted[i]),
                         UB_OK);
        assert_int_equal(ub_revoke_spread_certificates(&l->rv[i], NULL, NULL, 0), UB_OK);
    }
    world_run(l->w, 100, 10);
    uint8_t pk[32];
    for (int i = 0; i < N; i++) {
        assert_int_equal(ub_ident_peer_kx_key(&l->store[i], fcs.cert.entity, T0 + 10, pk), UB_OK);
        assert_memory_equal(pk, fcs.cert.kx_pk, 32);
    }
    assert_int_equal(l->rv[0].stats.certs_accepted, 1);
    /* the revoked vehicle's replacement: revoke serial 8, then its new certificate reaches the far end */
    uint8_t rec[UB_REVOCATION_LEN];
    assert_int_equal(test_revoke_record(rec, &l->auth, "rmax2ob1", 8, T0 + 5), UB_OK);
    assert_int_equal(ub_revoke_submit(&l->rv[0], rec, sizeof rec, l->w->now_ms), UB_OK);
    assert_int_equal(ub_revoke_submit_certificate(&l->rv[0], repl.cert_bytes, UB_CERT_LEN, l->w->now_ms), UB_OK);
    world_run(l->w, l->w->now_ms + 200, 10);
    assert_int_equal(ub_ident_peer_kx_key(&l->store[3], repl.cert.entity, T0 + 10, pk), UB_OK);
    assert_memory_equal(pk, repl.cert.kx_pk, 32);
    /* the old, revoked certificate submitted again is refused and goes nowhere; copies die out */
    assert_int_equal(ub_revoke_submit_certificate(&l->rv[0], l->victim.cert_bytes, UB_CERT_LEN, l->w->now_ms),
                     UB_ERR_AUTH);
    world_run(l->w, l->w->now_ms + 3000, 10);
    assert_memory_equal(ub_ident_peer_cert(&l->store[3], repl.cert.entity, T0 + 10)->kx_pk, repl.cert.kx_pk, 32);
    uint32_t sent[N];
    for (int i = 0; i < N; i++) {
        sent[i] = l->rv[i].stats.certs_sent;
        uint32_t n_links = (i == 0 || i == N - 1) ? 1u : 2u;
        assert_true(sent[i] <= 2u * 4u * n_links); /* two certificates, 4 repeats each, per link */
        assert_int_equal(l->rv[i].stats.certs_refused, i == 0 ? 1 : 0);
    }
    world_run(l->w, l->w->now_ms + 3000, 10);
    for (int i = 0; i < N; i++) assert_int_equal(l->rv[i].stats.certs_sent, sent[i]);
    line_free(l);
}

typedef struct told {
    unsigned calls;
    uint8_t last[UB_ENTITY_ID_LEN];
} told_t;

static void on_peer(void *user, const uint8_t entity[UB_ENTITY_ID_LEN]) {
    told_t *t = user;
    t->calls++;
    memcpy(t->last, entity, UB_ENTITY_ID_LEN);
}

/* The peer hook (what the program shell gives ub_origin_forget_hook()): every node is told of the revoked
 * entity once, when its revocation changes the store (not for the copies it already holds), and of a
 * replacement's certificate once. */
static void test_peer_hook_tells_each_node_once(void **state) {
    (void)state;
    line_t *l = line_new();
    told_t told[N];
    memset(told, 0, sizeof told);
    ub_revoke_options_t opt = {.clock_s = fixed_clock}; /* certificates' validity: unix time */
    for (int i = 0; i < N; i++) {
        assert_int_equal(ub_revoke_remove(&l->rv[i]), UB_OK);
        assert_int_equal(ub_revoke_init(&l->rv[i], l->node[i], &l->store[i], &opt, NULL, NULL), UB_OK);
        assert_int_equal(ub_revoke_set_peer_hook(&l->rv[i], on_peer, &told[i]), UB_OK);
    }
    assert_int_equal(ub_revoke_set_peer_hook(NULL, on_peer, NULL), UB_ERR_INVAL);
    uint8_t rec[UB_REVOCATION_LEN];
    assert_int_equal(test_revoke_record(rec, &l->auth, "rmax2ob1", 8, T0 + 1), UB_OK);
    world_run(l->w, 10, 10);
    assert_int_equal(ub_revoke_submit(&l->rv[0], rec, sizeof rec, l->w->now_ms), UB_OK);
    world_run(l->w, l->w->now_ms + 5000, 10);
    for (int i = 0; i < N; i++) {
        assert_int_equal(told[i].calls, 1);
        assert_memory_equal(told[i].last, l->victim.cert.entity, UB_ENTITY_ID_LEN);
    }
    test_entity_t repl;
    assert_int_equal(test_issue(&repl, &l->auth, "rmax2ob1", UB_ROLE_VEHICLE, 12, T0, T0 + 86400), UB_OK);
    assert_int_equal(ub_revoke_submit_certificate(&l->rv[0], repl.cert_bytes, UB_CERT_LEN, l->w->now_ms), UB_OK);
    world_run(l->w, l->w->now_ms + 5000, 10);
    for (int i = 0; i < N; i++) assert_int_equal(told[i].calls, 2);
    line_free(l);
}

/* On signed nodes, a certificate from a neighbour this node holds no freshness state for is taken from its first
 * copy, without a challenge first (ub_service_t.link_local_self_proving): it proves itself. With origin
 * authentication this matters -- a re-keyed replacement cannot complete a challenge before its neighbours know
 * its new certificate. */
static void test_certificates_need_no_challenge_on_signed_links(void **state) {
    (void)state;
    static const uint8_t key[32] = {7, 7, 7};
    world_t *w = world_new();
    ub_node_t *node[2];
    ub_ident_store_t *store = calloc(2, sizeof *store);
    ub_revoke_t *rv = calloc(2, sizeof *rv);
    ub_sec_t *sec = calloc(2, sizeof *sec);
    test_authority_t auth;
    test_entity_t repl;
    assert_non_null(store);
    assert_non_null(rv);
    assert_non_null(sec);
    assert_int_equal(test_authority(&auth, "fleet authority"), UB_OK);
    assert_int_equal(test_issue(&repl, &auth, "rmax2ob1", UB_ROLE_VEHICLE, 12, T0, T0 + 86400), UB_OK);
    ub_revoke_options_t opt = {.clock_s = fixed_clock};
    int link[2];
    for (int i = 0; i < 2; i++) {
        node[i] = world_node(w, &ub_test_cat, NULL);
        int e = ub_node_add_entity_name(node[i], i == 0 ? "gcs1" : "fcs20", true);
        assert_true(e >= 0);
        link[i] = ub_node_add_link(node[i], e, 0, "radio");
        assert_true(link[i] >= 0);
        test_sec_on(&sec[i], node[i], key, 1000u * (uint64_t)(i + 1), true);
        ub_ident_store_init(&store[i]);
        assert_int_equal(ub_ident_set_authority(&store[i], auth.pk), UB_OK);
        assert_int_equal(ub_revoke_init(&rv[i], node[i], &store[i], &opt, NULL, NULL), UB_OK);
    }
    (void)world_connect(w, node[0], link[0], node[1], link[1], NULL, 1);
    assert_int_equal(ub_revoke_submit_certificate(&rv[1], repl.cert_bytes, UB_CERT_LEN, w->now_ms), UB_OK);
    world_run(w, w->now_ms + 30, 10); /* well before the first repeat (200 ms): the first copy got in */
    uint8_t pk[32];
    assert_int_equal(ub_ident_peer_kx_key(&store[0], repl.cert.entity, T0 + 10, pk), UB_OK);
    assert_int_equal(rv[0].stats.certs_accepted, 1);
    assert_int_equal(ub_node_counters(node[0])->drops[UB_DROP_UNVERIFIED], 0);
    assert_int_equal(sec[0].stats.challenges_sent, 0);
    free(sec);
    free(rv);
    free(store);
    free(w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_spreads_to_the_far_end),
        cmocka_unit_test(test_foreign_and_junk_records_stay_put),
        cmocka_unit_test(test_flood_is_bounded),
        cmocka_unit_test(test_certificates_spread),
        cmocka_unit_test(test_peer_hook_tells_each_node_once),
        cmocka_unit_test(test_certificates_need_no_challenge_on_signed_links),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
