/*
 * The routing engine's next due time (ub_service.h `next_due`, ub_route.c route_next_due) on memlink worlds:
 * a caller that sleeps until ub_node_next_due() -- as uavbus_node does -- instead of ticking every millisecond
 * must see the same network. Checked on a line and on a ring with a cut and a repair:
 *  - no node sends anything when ticked one millisecond before the earliest due time of the world (the due
 *    time is never late: "calling ub_node_tick() earlier does nothing a later call would not");
 *  - driven only at due times (and at frame arrivals, which the pump delivers), every node learns a route to
 *    every other, a cut is routed around and a lost entity is retracted, as when polled;
 *  - the world wakes far less often than once a millisecond (the due time is not "now + 1" throughout).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "support/ub_test_world.h"
#include "ub/ub_node.h"
#include "ub/ub_route.h"
#include "ub/ub_service.h"

#define HELLO_MS 100u

typedef struct net {
    world_t *w;
    size_t n;
    ub_route_t rt[WORLD_MAX_NODES];
    int self[WORLD_MAX_NODES];
    unsigned next_index[WORLD_MAX_NODES];
    uint64_t wakeups;
} net_t;

static void vid(int i, uint8_t id[UB_ENTITY_ID_LEN]) {
    char name[16];
    snprintf(name, sizeof name, "v%d", i);
    test_eid(name, id);
}

static net_t *net_new(size_t n) {
    net_t *t = calloc(1, sizeof *t);
    assert_non_null(t);
    t->w = world_new();
    t->n = n;
    for (size_t i = 0; i < n; i++) {
        ub_node_options_t opt = {.first_seq = 100u * (uint32_t)(i + 1), .random_seed = (uint64_t)(i + 11)};
        ub_node_t *node = world_node(t->w, &ub_test_cat, &opt);
        char name[16];
        snprintf(name, sizeof name, "v%zu", i);
        t->self[i] = ub_node_add_entity_name(node, name, true);
        assert_true(t->self[i] >= 0);
    }
    return t;
}

static int net_link(net_t *t, int a, int b) {
    char na[32], nb[32];
    snprintf(na, sizeof na, "l%zu_%dto%d", t->w->n_links, a, b);
    snprintf(nb, sizeof nb, "l%zu_%dto%d", t->w->n_links, b, a);
    int la = ub_node_add_link(&t->w->nodes[a], t->self[a], t->next_index[a]++, na);
    int lb = ub_node_add_link(&t->w->nodes[b], t->self[b], t->next_index[b]++, nb);
    assert_true(la >= 0 && lb >= 0);
    int e = (int)t->w->n_links;
    (void)world_connect(t->w, &t->w->nodes[a], la, &t->w->nodes[b], lb, NULL, (uint64_t)e + 1);
    return e;
}

static void net_start(net_t *t) {
    ub_route_options_t ro = {.hello_ms = HELLO_MS};
    for (size_t i = 0; i < t->n; i++)
        assert_int_equal(ub_route_attach(&t->rt[i], &t->w->nodes[i], &ro, t->w->now_ms), UB_OK);
}

static void net_start_opt(net_t *t, const ub_route_options_t *ro) {
    for (size_t i = 0; i < t->n; i++) assert_int_equal(ub_route_attach(&t->rt[i], &t->w->nodes[i], ro, t->w->now_ms), UB_OK);
}

static void net_free(net_t *t) {
    free(t->w);
    free(t);
}

static uint64_t frames_out(const net_t *t) {
    uint64_t n = 0;
    for (size_t i = 0; i < t->n; i++)
        for (int l = 0; l < UB_MAX_NODE_LINKS; l++) {
            const ub_link_t *link = ub_node_link(&t->w->nodes[i], l);
            if (link != NULL) n += link->counters.frames_out;
        }
    return n;
}

static void pump(net_t *t) {
    for (int round = 0; round < 64; round++) {
        size_t moved = 0;
        for (size_t l = 0; l < t->w->n_links; l++) moved += ub_memlink_pump(&t->w->links[l], t->w->now_ms);
        if (moved == 0) break;
    }
}

/* Runs until `until_ms`, waking only at the world's earliest due time. Before each wake-up every node is
 * ticked at the millisecond before it: nothing may be sent then. */
static void run_by_due_times(net_t *t, uint64_t until_ms) {
    while (t->w->now_ms < until_ms) {
        uint64_t due = UINT64_MAX;
        for (size_t i = 0; i < t->n; i++) {
            uint64_t d = ub_node_next_due(&t->w->nodes[i], t->w->now_ms);
            if (d < due) due = d;
        }
        assert_true(due != UINT64_MAX); /* a routing node always has a hello ahead */
        if (due <= t->w->now_ms) due = t->w->now_ms + 1;
        if (due > until_ms) due = until_ms;
        if (due - 1 > t->w->now_ms) {
            uint64_t before = frames_out(t);
            for (size_t i = 0; i < t->n; i++) ub_node_tick(&t->w->nodes[i], due - 1);
            assert_int_equal(frames_out(t), before);
        }
        t->w->now_ms = due;
        for (size_t i = 0; i < t->n; i++) ub_node_tick(&t->w->nodes[i], due);
        pump(t);
        t->wakeups++;
    }
}

static bool reaches(net_t *t, int a, int b, ub_route_info_t *out) {
    uint8_t id[UB_ENTITY_ID_LEN];
    vid(b, id);
    int dest = ub_node_find_entity(&t->w->nodes[a], id);
    if (dest < 0) return false;
    ub_route_info_t ri;
    if (ub_route_get(&t->rt[a], t->self[a], dest, &ri) != UB_OK) return false;
    if (out != NULL) *out = ri;
    return ri.link_id >= 0 && ri.metric != UB_ROUTE_INFINITY;
}

static void test_line_converges_when_driven_by_due_times(void **state) {
    (void)state;
    net_t *t = net_new(4);
    for (int i = 0; i + 1 < 4; i++) (void)net_link(t, i, i + 1);
    net_start(t);
    run_by_due_times(t, 3000);
    for (int a = 0; a < 4; a++)
        for (int b = 0; b < 4; b++) {
            if (a == b) continue;
            ub_route_info_t ri = {0}; /* reaches() writes it only on success */
            assert_true(reaches(t, a, b, &ri));
            assert_true(ri.learned);
        }
    /* 4 nodes, hellos every 100 ms: a few wake-ups per hello round (125 here), not one per millisecond. */
    assert_true(t->wakeups < 3000 / 10);
    net_free(t);
}

static void test_ring_cut_and_repair_when_driven_by_due_times(void **state) {
    (void)state;
    net_t *t = net_new(5);
    int e[5];
    for (int i = 0; i < 5; i++) e[i] = net_link(t, i, (i + 1) % 5);
    net_start(t);
    run_by_due_times(t, 3000);
    ub_route_info_t ri;
    assert_true(reaches(t, 0, 1, &ri));
    uint8_t v1[UB_ENTITY_ID_LEN];
    vid(1, v1);
    assert_memory_equal(ri.next_hop, v1, UB_ENTITY_ID_LEN); /* the direct link */
    /* v0 -- v1 cut: v0 reaches v1 the long way round (v4, v3, v2) */
    ub_memlink_faults_t lost = {.loss_ppm = 1000000u};
    ub_memlink_set_faults(&t->w->links[e[0]], &lost);
    uint64_t wake = t->wakeups;
    run_by_due_times(t, 8000);
    assert_true(reaches(t, 0, 1, &ri));
    uint8_t v4[UB_ENTITY_ID_LEN];
    vid(4, v4);
    assert_memory_equal(ri.next_hop, v4, UB_ENTITY_ID_LEN);
    assert_true(t->wakeups - wake < 5000 / 10);
    /* v1 cut off entirely: the others retract it (unreachable), then the repair brings it back */
    ub_memlink_set_faults(&t->w->links[e[1]], &lost);
    run_by_due_times(t, 14000);
    for (int a = 2; a <= 4; a++) assert_false(reaches(t, a, 1, NULL));
    ub_memlink_set_faults(&t->w->links[e[0]], NULL);
    ub_memlink_set_faults(&t->w->links[e[1]], NULL);
    run_by_due_times(t, 18000);
    for (int a = 0; a < 5; a++)
        if (a != 1) assert_true(reaches(t, a, 1, NULL));
    net_free(t);
}

/* A tick that sent only routing frames leaves nothing due at that millisecond: the engine notes its own frames
 * as it sends them. Before, route_next_due() saw frames_out move and called the next tick due at once, so a loop
 * sleeping until the due time (uavbus_node) woke a second time for every hello and fast hello. */
static void test_own_routing_frames_make_nothing_due_at_once(void **state) {
    (void)state;
    net_t *t = net_new(3);
    for (int i = 0; i + 1 < 3; i++) (void)net_link(t, i, i + 1);
    net_start(t);
    run_by_due_times(t, 2000);
    int sends = 0;
    while (sends < 20 && t->w->now_ms < 8000) {
        uint64_t due = UINT64_MAX;
        size_t who = 0;
        for (size_t i = 0; i < t->n; i++) {
            uint64_t d = ub_node_next_due(&t->w->nodes[i], t->w->now_ms);
            if (d < due) due = d, who = i;
        }
        if (due > t->w->now_ms) t->w->now_ms = due;
        uint64_t before = frames_out(t);
        ub_node_tick(&t->w->nodes[who], t->w->now_ms);
        if (frames_out(t) > before) {
            sends++;
            assert_true(ub_node_next_due(&t->w->nodes[who], t->w->now_ms) > t->w->now_ms);
        }
        pump(t); /* the neighbours' copies make them due now: their turn comes next */
    }
    assert_int_equal(sends, 20);
    net_free(t);
}

/* Timer coalescing (coalesce_ms, uavbus_node's setting): a regular hello due within the slack goes in a tick that
 * is awake anyway, not in a wake-up of its own -- and keeps its schedule (the hello rate does not change). Off, a
 * tick one millisecond early sends nothing (the test above); the slack is bounded by the fast hello interval. */
static void test_coalescing_sends_a_hello_due_within_the_slack(void **state) {
    (void)state;
    for (int on = 0; on <= 1; on++) {
        net_t *t = net_new(2);
        (void)net_link(t, 0, 1);
        ub_route_options_t ro = {.hello_ms = 1000, .coalesce_ms = on ? UB_ROUTE_COALESCE_AUTO : 0};
        net_start_opt(t, &ro);
        assert_int_equal(t->rt[0].opt.coalesce_ms, on ? 125u / 8u : 0u); /* fast hellos every 1000 / 8 ms */
        for (uint64_t ms = 1; ms <= 3500; ms++) { /* routes up, hellos on their schedule */
            t->w->now_ms = ms;
            for (size_t i = 0; i < t->n; i++) ub_node_tick(&t->w->nodes[i], ms);
            pump(t);
        }
        ub_route_link_t *l = &t->rt[0].links[0];
        uint64_t hello = l->next_hello_ms;
        uint64_t slack = on ? 15u : 0u;
        assert_true(hello > t->w->now_ms + slack + 1);
        assert_true(ub_node_next_due(&t->w->nodes[0], t->w->now_ms) <= hello); /* still woken by the deadline */
        uint64_t sent = l->stats.frames_out; /* the regular frame: a HELLO, or a ROUTE_UPDATE when a dump is due */
        ub_node_tick(&t->w->nodes[0], hello - slack - 1); /* before the window: nothing */
        assert_int_equal(l->stats.frames_out, sent);
        ub_node_tick(&t->w->nodes[0], hello - slack); /* in it (off: the deadline itself) */
        assert_int_equal(l->stats.frames_out, sent + 1);
        assert_int_equal(l->next_hello_ms, hello + 1000u); /* early, but the schedule is kept */
        net_free(t);
    }
    /* More slack than an eighth of the fast hello interval is refused: the gaps the neighbour learns stay close. */
    net_t *t = net_new(1);
    ub_route_options_t bad = {.hello_ms = 1000, .coalesce_ms = 16};
    assert_int_equal(ub_route_attach(&t->rt[0], &t->w->nodes[0], &bad, 0), UB_ERR_INVAL);
    net_free(t);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_line_converges_when_driven_by_due_times),
        cmocka_unit_test(test_ring_cut_and_repair_when_driven_by_due_times),
        cmocka_unit_test(test_own_routing_frames_make_nothing_due_at_once),
        cmocka_unit_test(test_coalescing_sends_a_hello_due_within_the_slack),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
