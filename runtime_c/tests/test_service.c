/*
 * The service contract (ub_service.h) from the outside: an "echo" service written only against the
 * public headers (ub_node.h, ub_node_svc.h, ub_service.h, ub_admin_wire.h; this target has no private
 * include directory), registered with ub_node_add_service(), run between two nodes on a memlink.
 * It answers a PING with a PONG carrying the same bytes, or with a NACK when asked to refuse, takes the
 * NACKs answering its own PINGs, pings on its tick, hears about forgotten entities and links, and
 * takes one code link-local. Also: codes taken are refused, a removed service's codes are free again
 * and its frames are then dropped `bad_payload` like any unknown admin frame.
 *
 * Admin codes 0xF0-0xF2 are test-only: docs/wire-format.md reserves 0xF0-0xFF for local experiments
 * and tests; the runtime never sends them.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "support/ub_test_world.h"
#include "ub/ub_admin_wire.h"
#include "ub/ub_member.h"
#include "ub/ub_node.h"
#include "ub/ub_node_svc.h"
#include "ub/ub_route.h"
#include "ub/ub_service.h"
#include "ub/ub_wire.h"

#define ECHO_PING 0xF0u      /* payload: id u32, flags u8, data...; answered by PONG or NACK */
#define ECHO_PONG 0xF1u      /* payload: the PING's, echoed */
#define ECHO_LINK_PING 0xF2u /* link-local: counted by the receiver */
#define ECHO_FLAG_REFUSE 0x01u
#define ECHO_NACK_REASON 0x42u

/* The service's state, with its registration record embedded (caller-owned, no allocation by the node). */
typedef struct echo {
    ub_service_t svc;
    int entity; /* the local entity it pings from */
    uint8_t peer[UB_ENTITY_ID_LEN];
    uint32_t tick_period_ms; /* 0: no pings on tick */
    uint64_t next_ping_ms;
    uint32_t next_id;
    /* what happened */
    unsigned pings_served, pings_refused, pongs, nacks, ticks, forgotten_entities, forgotten_links, link_pings;
    int last_link;
    uint32_t last_pong_id;
    uint8_t last_pong[64];
    uint16_t last_pong_len;
    uint8_t last_nack_reason;
} echo_t;

static bool echo_on_frame(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx,
                          const ub_frame_header_t *h, const uint8_t *payload, uint64_t now_ms, ub_drop_reason_t *drop) {
    echo_t *e = svc->user;
    *drop = UB_DROP_BAD_PAYLOAD;
    if (h->admin == ECHO_LINK_PING) {
        e->link_pings++;
        e->last_link = rx->link_id;
        return true;
    }
    if (h->payload_size < 5) return false; /* counted bad_payload by the node */
    uint32_t id = ub_get_u32le(payload);
    if (h->admin == ECHO_PONG) {
        e->pongs++;
        e->last_pong_id = id;
        e->last_pong_len = h->payload_size < sizeof e->last_pong ? h->payload_size : (uint16_t)sizeof e->last_pong;
        memcpy(e->last_pong, payload, e->last_pong_len);
        return true;
    }
    if (payload[4] & ECHO_FLAG_REFUSE) {
        e->pings_refused++;
        (void)ub_node_svc_send_reply(node, rx->slot, true, h->dir_id, h->src_id, id, ECHO_PING, ECHO_NACK_REASON, 0,
                                     now_ms);
        return true;
    }
    e->pings_served++;
    (void)ub_node_svc_send_admin(node, rx->slot, (ub_admin_code_t)ECHO_PONG, h->dir_id, 0, h->src_id, payload,
                                 h->payload_size, now_ms);
    return true;
}

static bool echo_on_reply(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx,
                          const ub_frame_header_t *h, const ub_service_reply_t *r, uint64_t now_ms,
                          ub_drop_reason_t *drop) {
    (void)node, (void)rx, (void)h, (void)now_ms, (void)drop;
    echo_t *e = svc->user;
    if (r->code != ECHO_PING) return false;
    if (r->nack) {
        e->nacks++;
        e->last_nack_reason = r->detail;
    }
    return true;
}

static int echo_ping(echo_t *e, ub_node_t *node, uint8_t flags, const char *text, uint64_t now_ms) {
    uint8_t p[64];
    size_t n = strlen(text);
    ub_put_u32le(p, ++e->next_id);
    p[4] = flags;
    memcpy(p + 5, text, n);
    static const uint8_t no_dir[UB_DIR_ID_LEN] = {0};
    return ub_node_svc_send_admin(node, ub_node_entity_slot(node, e->entity), (ub_admin_code_t)ECHO_PING, no_dir, 0,
                                  e->peer, p, (uint16_t)(5 + n), now_ms);
}

static void echo_tick(const ub_service_t *svc, ub_node_t *node, uint64_t now_ms) {
    echo_t *e = svc->user;
    e->ticks++;
    if (e->tick_period_ms == 0 || now_ms < e->next_ping_ms) return;
    e->next_ping_ms = now_ms + e->tick_period_ms;
    (void)echo_ping(e, node, 0, "tick", now_ms);
}

static void echo_forget_entity(const ub_service_t *svc, ub_node_t *node, int entity, const uint8_t id[UB_ENTITY_ID_LEN],
                               uint64_t now_ms) {
    (void)node, (void)entity, (void)now_ms;
    echo_t *e = svc->user;
    e->forgotten_entities++;
    if (ub_entity_id_eq(id, e->peer)) e->tick_period_ms = 0; /* nobody left to ping */
}

static void echo_forget_link(const ub_service_t *svc, ub_node_t *node, int link_id, uint64_t now_ms) {
    (void)now_ms;
    echo_t *e = svc->user;
    assert_non_null(ub_node_link(node, link_id)); /* still readable during the call */
    e->forgotten_links++;
}

static const uint8_t echo_codes[] = {ECHO_PING, ECHO_PONG};
static const uint8_t echo_reply_codes[] = {ECHO_PING};
static const uint8_t echo_link_codes[] = {ECHO_LINK_PING};

/* Step 3 of the recipe (docs/architecture.md): the registration record, filled by the service's init. */
static void echo_init(echo_t *e, int entity, const char *peer) {
    memset(e, 0, sizeof *e);
    e->entity = entity;
    e->last_link = -1;
    test_eid(peer, e->peer);
    e->svc = (ub_service_t){.name = "echo",
                            .codes = echo_codes,
                            .n_codes = sizeof echo_codes,
                            .reply_codes = echo_reply_codes,
                            .n_reply_codes = sizeof echo_reply_codes,
                            .link_local_codes = echo_link_codes,
                            .n_link_local_codes = sizeof echo_link_codes,
                            .order = UB_SVC_ORDER_USER,
                            .on_frame = echo_on_frame,
                            .on_reply = echo_on_reply,
                            .tick = echo_tick,
                            .forget_entity = echo_forget_entity,
                            .forget_link = echo_forget_link,
                            .user = e};
}

/* Two nodes, one entity each ("gcs1" on a, "uav7" on b), a memlink between them, echo on both. */
typedef struct pair {
    world_t *w;
    ub_node_t *a, *b;
    int ea, eb, la, lb;
    echo_t echo_a, echo_b;
} pair_t;

static pair_t *pair_new(void) {
    pair_t *p = calloc(1, sizeof *p);
    assert_non_null(p);
    p->w = world_new();
    p->a = world_node(p->w, &ub_test_cat, NULL);
    p->b = world_node(p->w, &ub_test_cat, NULL);
    p->ea = ub_node_add_entity_name(p->a, "gcs1", true);
    int a_uav = ub_node_add_entity_name(p->a, "uav7", false);
    p->eb = ub_node_add_entity_name(p->b, "uav7", true);
    int b_gcs = ub_node_add_entity_name(p->b, "gcs1", false);
    p->la = ub_node_add_link(p->a, p->ea, 0, "toB");
    p->lb = ub_node_add_link(p->b, p->eb, 0, "toA");
    assert_true(p->ea >= 0 && a_uav >= 0 && p->eb >= 0 && b_gcs >= 0 && p->la >= 0 && p->lb >= 0);
    assert_int_equal(ub_node_set_mask(p->a, p->ea, a_uav, 0x01), UB_OK);
    assert_int_equal(ub_node_set_mask(p->b, p->eb, b_gcs, 0x01), UB_OK);
    (void)world_connect(p->w, p->a, p->la, p->b, p->lb, NULL, 1);
    echo_init(&p->echo_a, p->ea, "uav7");
    echo_init(&p->echo_b, p->eb, "gcs1");
    assert_int_equal(ub_node_add_service(p->a, &p->echo_a.svc), UB_OK);
    assert_int_equal(ub_node_add_service(p->b, &p->echo_b.svc), UB_OK);
    return p;
}

static void pair_free(pair_t *p) {
    free(p->w);
    free(p);
}

static void test_ping_is_answered_across_two_nodes(void **state) {
    (void)state;
    pair_t *p = pair_new();
    uint64_t handled_b = ub_node_counters(p->b)->admin_handled;
    assert_int_equal(echo_ping(&p->echo_a, p->a, 0, "hello, uav7", p->w->now_ms), 1);
    world_run(p->w, p->w->now_ms + 5, 1);
    assert_int_equal(p->echo_b.pings_served, 1);
    assert_int_equal(p->echo_a.pongs, 1);
    assert_int_equal(p->echo_a.last_pong_id, 1);
    assert_int_equal(p->echo_a.last_pong_len, 5 + strlen("hello, uav7"));
    assert_memory_equal(p->echo_a.last_pong + 5, "hello, uav7", strlen("hello, uav7"));
    /* The core counted the frames it handed over as admin frames, and dropped nothing. */
    assert_true(ub_node_counters(p->b)->admin_handled > handled_b);
    assert_int_equal(ub_node_counters(p->a)->drops[UB_DROP_BAD_PAYLOAD], 0);
    assert_int_equal(ub_node_counters(p->b)->drops[UB_DROP_BAD_PAYLOAD], 0);
    pair_free(p);
}

static void test_refusal_comes_back_as_a_nack_to_the_service_that_asked(void **state) {
    (void)state;
    pair_t *p = pair_new();
    uint64_t unmatched = ub_node_counters(p->a)->replies_unmatched;
    assert_int_equal(echo_ping(&p->echo_a, p->a, ECHO_FLAG_REFUSE, "no", p->w->now_ms), 1);
    world_run(p->w, p->w->now_ms + 5, 1);
    assert_int_equal(p->echo_b.pings_refused, 1);
    assert_int_equal(p->echo_a.nacks, 1);
    assert_int_equal(p->echo_a.last_nack_reason, ECHO_NACK_REASON);
    assert_int_equal(p->echo_a.pongs, 0);
    /* Taken by the echo service, not by the publish/subscribe tables (which would count it unmatched). */
    assert_int_equal(ub_node_counters(p->a)->replies_unmatched, unmatched);
    pair_free(p);
}

static void test_ticks_pings_and_forgetting_reach_the_service(void **state) {
    (void)state;
    pair_t *p = pair_new();
    p->echo_a.tick_period_ms = 100;
    world_run(p->w, p->w->now_ms + 350, 10);
    assert_true(p->echo_a.ticks >= 35);
    assert_int_equal(p->echo_b.pings_served, 4); /* at 0 (first tick), 100, 200, 300 */
    assert_int_equal(p->echo_a.pongs, 4);
    /* Removing the peer reaches the service through the node's forget loop. */
    int uav = ub_node_find_entity(p->a, p->echo_a.peer);
    assert_int_equal(ub_node_remove_entity(p->a, uav, p->w->now_ms), UB_OK);
    assert_int_equal(p->echo_a.forgotten_entities, 1);
    assert_int_equal(p->echo_a.tick_period_ms, 0);
    world_run(p->w, p->w->now_ms + 300, 10);
    assert_int_equal(p->echo_b.pings_served, 4);
    /* And so does removing a link. */
    assert_int_equal(ub_node_link_detach(p->b, p->lb), UB_OK);
    assert_int_equal(ub_node_remove_link(p->b, p->lb), UB_OK);
    assert_int_equal(p->echo_b.forgotten_links, 1);
    pair_free(p);
}

static void test_link_local_code_reaches_the_link_owner(void **state) {
    (void)state;
    pair_t *p = pair_new();
    assert_int_equal(ub_node_send_link_local(p->a, p->la, (ub_admin_code_t)ECHO_LINK_PING, (const uint8_t *)"x", 1,
                                             p->w->now_ms),
                     1);
    world_run(p->w, p->w->now_ms + 2, 1);
    assert_int_equal(p->echo_b.link_pings, 1);
    assert_int_equal(p->echo_b.last_link, p->lb);
    /* Unregistered, the code is not one the node takes link-local: refused as bad_payload. */
    assert_int_equal(ub_node_remove_service(p->b, &p->echo_b.svc), UB_OK);
    uint64_t bad = ub_node_link(p->b, p->lb)->counters.drops[UB_DROP_BAD_PAYLOAD];
    assert_int_equal(ub_node_send_link_local(p->a, p->la, (ub_admin_code_t)ECHO_LINK_PING, (const uint8_t *)"x", 1,
                                             p->w->now_ms),
                     1);
    world_run(p->w, p->w->now_ms + 2, 1);
    assert_int_equal(p->echo_b.link_pings, 1);
    assert_int_equal(ub_node_link(p->b, p->lb)->counters.drops[UB_DROP_BAD_PAYLOAD], bad + 1);
    pair_free(p);
}

static void test_taken_codes_are_refused_and_freed_on_removal(void **state) {
    (void)state;
    pair_t *p = pair_new();
    echo_t *second = calloc(1, sizeof *second);
    assert_non_null(second);
    echo_init(second, p->eb, "gcs1");
    /* The echo codes are taken on b; so is a built-in one (PUB_REQUEST: publish/subscribe). */
    assert_int_equal(ub_node_add_service(p->b, &second->svc), UB_ERR_EXISTS);
    assert_int_equal(ub_node_add_service(p->b, &p->echo_b.svc), UB_ERR_EXISTS); /* already registered */
    static const uint8_t pubsub_code[] = {UB_ADMIN_PUB_REQUEST};
    ub_service_t thief = {.name = "thief", .codes = pubsub_code, .n_codes = 1, .order = UB_SVC_ORDER_USER};
    assert_int_equal(ub_node_add_service(p->b, &thief), UB_ERR_EXISTS);
    static const uint8_t data_code[] = {UB_ADMIN_DATA};
    ub_service_t data = {.name = "data", .codes = data_code, .n_codes = 1, .order = UB_SVC_ORDER_USER};
    assert_int_equal(ub_node_add_service(p->b, &data), UB_ERR_INVAL); /* DATA is the core's */
    assert_int_equal(ub_node_add_service(p->b, NULL), UB_ERR_INVAL);
    assert_ptr_equal(ub_node_service_for(p->b, UB_SVC_CODE, ECHO_PING), &p->echo_b.svc);
    assert_ptr_equal(ub_node_service_for(p->b, UB_SVC_REPLY, ECHO_PING), &p->echo_b.svc);
    assert_ptr_equal(ub_node_service_for(p->b, UB_SVC_LINK_LOCAL, ECHO_LINK_PING), &p->echo_b.svc);
    /* Removed: its codes are free, and a PING is now an admin frame nobody takes. */
    assert_int_equal(ub_node_remove_service(p->b, &p->echo_b.svc), UB_OK);
    assert_int_equal(ub_node_remove_service(p->b, &p->echo_b.svc), UB_ERR_NOTFOUND);
    assert_null(ub_node_service_for(p->b, UB_SVC_CODE, ECHO_PING));
    uint64_t bad = ub_node_counters(p->b)->drops[UB_DROP_BAD_PAYLOAD];
    assert_int_equal(echo_ping(&p->echo_a, p->a, 0, "anyone?", p->w->now_ms), 1);
    world_run(p->w, p->w->now_ms + 5, 1);
    assert_int_equal(p->echo_b.pings_served, 0);
    assert_int_equal(ub_node_counters(p->b)->drops[UB_DROP_BAD_PAYLOAD], bad + 1);
    /* The second echo takes the codes now, and answers. */
    assert_int_equal(ub_node_add_service(p->b, &second->svc), UB_OK);
    assert_int_equal(echo_ping(&p->echo_a, p->a, 0, "again", p->w->now_ms), 1);
    world_run(p->w, p->w->now_ms + 5, 1);
    assert_int_equal(second->pings_served, 1);
    assert_int_equal(p->echo_a.pongs, 1);
    free(second);
    pair_free(p);
}

static void test_table_capacity_is_the_configured_one(void **state) {
    (void)state;
    world_t *w = world_new();
    ub_node_t *n = world_node(w, &ub_test_cat, NULL);
    /* Services without codes still take a row (a tick-only service): fill the table, then one more. */
    ub_service_t s[UB_MAX_SERVICES];
    memset(s, 0, sizeof s);
    int added = 0;
    for (int i = 0; i < UB_MAX_SERVICES; i++) {
        s[i].name = "filler";
        s[i].order = UB_SVC_ORDER_USER;
        int rc = ub_node_add_service(n, &s[i]);
        if (rc == UB_ERR_FULL) break;
        assert_int_equal(rc, UB_OK);
        added++;
    }
    assert_true(added > 0 && added < UB_MAX_SERVICES); /* the built-in services hold the rest */
    ub_service_t extra = {.name = "extra", .order = UB_SVC_ORDER_USER};
    assert_int_equal(ub_node_add_service(n, &extra), UB_ERR_FULL);
    /* The engines' own attach functions say so too, and leave the node as it was... */
    int e = ub_node_add_entity_name(n, "gcs1", true);
    assert_true(e >= 0);
    ub_route_t *rt = calloc(1, sizeof *rt);
    assert_non_null(rt);
    assert_int_equal(ub_route_attach(rt, n, NULL, 0), UB_ERR_FULL);
    assert_null(ub_node_service_for(n, UB_SVC_LINK_LOCAL, UB_ADMIN_HELLO));
    /* ... while a requester takes the row of the serving side it replaces, so it still fits. */
    ub_member_t *m = calloc(1, sizeof *m);
    assert_non_null(m);
    const ub_service_t *server = ub_node_service_for(n, UB_SVC_CODE, UB_ADMIN_MEMBERSHIP);
    assert_non_null(server);
    assert_int_equal(ub_member_init(m, n, e, NULL), UB_OK);
    assert_ptr_equal(ub_node_service_for(n, UB_SVC_CODE, UB_ADMIN_MEMBERSHIP), &m->svc);
    ub_member_detach(m);
    assert_ptr_equal(ub_node_service_for(n, UB_SVC_CODE, UB_ADMIN_MEMBERSHIP), server);
    free(m);
    free(rt);
    free(w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ping_is_answered_across_two_nodes),
        cmocka_unit_test(test_refusal_comes_back_as_a_nack_to_the_service_that_asked),
        cmocka_unit_test(test_ticks_pings_and_forgetting_reach_the_service),
        cmocka_unit_test(test_link_local_code_reaches_the_link_owner),
        cmocka_unit_test(test_taken_codes_are_refused_and_freed_on_removal),
        cmocka_unit_test(test_table_capacity_is_the_configured_one),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
