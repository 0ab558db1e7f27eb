/*
 * Automatic routes (ub_route.h) on memlink worlds stepped by a simulated clock:
 * convergence, the steady-state frame budget, loop freedom while
 * reconverging (no DATA frame crosses one link twice), parallel links under
 * both policies, expiry of a silent neighbour, a partition and its repair,
 * starvation and seqno requests, a restarted node, learning, pinned masks and
 * the link-local addressing rules.
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
#include "ub/ub_wire.h"

#define HELLO_MS 100u
#define LOST 1000000u /* loss_ppm of a cut link */

typedef struct edge {
    int a, b, la, lb;
} edge_t;

/* A fleet: node i hosts one entity "v<i>" and runs ub_route; links are memlinks ("edges"). */
typedef struct fleet {
    world_t *w;
    size_t n;
    ub_route_t rt[WORLD_MAX_NODES];
    ub_route_options_t ro;
    int self[WORLD_MAX_NODES];
    unsigned next_index[WORLD_MAX_NODES];
    edge_t edge[WORLD_MAX_LINKS];
    struct test_gps gps[WORLD_MAX_NODES];
    uint64_t last_rx[WORLD_MAX_NODES][WORLD_MAX_NODES]; /* [receiver][source node] */
    uint64_t rx_count[WORLD_MAX_NODES][WORLD_MAX_NODES];
} fleet_t;

static void vname(int i, char out[16]) { snprintf(out, 16, "v%d", i); }

static void vid(int i, uint8_t id[UB_ENTITY_ID_LEN]) {
    char name[16];
    vname(i, name);
    test_eid(name, id);
}


typedef struct hook_ctx {
    fleet_t *f;
    int node;
} hook_ctx_t;
static hook_ctx_t g_hooks[WORLD_MAX_NODES]; /* test-only: user pointers for the delivery hooks */

static void on_deliver(void *user, int entity, uint32_t instance, const ub_frame_header_t *h, uint64_t now_ms) {
    (void)entity;
    (void)instance;
    hook_ctx_t *c = user;
    int src = atoi((const char *)h->src_id + 1);
    c->f->last_rx[c->node][src] = now_ms;
    c->f->rx_count[c->node][src]++;
}

static fleet_t *fleet_new(size_t n, const ub_route_options_t *ro) {
    fleet_t *f = calloc(1, sizeof *f);
    assert_non_null(f);
    f->w = world_new();
    f->n = n;
    if (ro != NULL) f->ro = *ro;
    if (f->ro.hello_ms == 0) f->ro.hello_ms = HELLO_MS;
    for (size_t i = 0; i < n; i++) {
        ub_node_t *node = world_node(f->w, &ub_test_cat, NULL);
        char name[16];
        vname((int)i, name);
        f->self[i] = ub_node_add_entity_name(node, name, true);
        assert_true(f->self[i] >= 0);
        assert_int_equal(ub_node_bind(node, TEST_GPS, &f->gps[i]), UB_OK);
        g_hooks[i] = (hook_ctx_t){f, (int)i};
        ub_node_set_deliver_hook(node, on_deliver, &g_hooks[i]);
    }
    return f;
}

static void fleet_start(fleet_t *f) {
    for (size_t i = 0; i < f->n; i++) assert_int_equal(ub_route_attach(&f->rt[i], &f->w->nodes[i], &f->ro, f->w->now_ms), UB_OK);
}

static void fleet_free(fleet_t *f) {
    free(f->w);
    free(f);
}

static int fleet_link(fleet_t *f, int a, int b) {
    char na[32], nb[32];
    snprintf(na, sizeof na, "l%zu_%dto%d", f->w->n_links, a, b);
    snprintf(nb, sizeof nb, "l%zu_%dto%d", f->w->n_links, b, a);
    int la = ub_node_add_link(&f->w->nodes[a], f->self[a], f->next_index[a]++, na);
    int lb = ub_node_add_link(&f->w->nodes[b], f->self[b], f->next_index[b]++, nb);
    assert_true(la >= 0 && lb >= 0);
    int e = (int)f->w->n_links;
    world_connect(f->w, &f->w->nodes[a], la, &f->w->nodes[b], lb, NULL, (uint64_t)e + 1);
    f->edge[e] = (edge_t){a, b, la, lb};
    return e;
}

static void fleet_cut(fleet_t *f, int e) {
    ub_memlink_faults_t lost = {.loss_ppm = LOST};
    ub_memlink_set_faults(&f->w->links[e], &lost);
}

static void fleet_heal(fleet_t *f, int e) { ub_memlink_set_faults(&f->w->links[e], NULL); }

/* Node a's route toward entity v<b>; asserts that a knows v<b>. */
static ub_route_info_t route(fleet_t *f, int a, int b) {
    uint8_t id[UB_ENTITY_ID_LEN];
    vid(b, id);
    int dest = ub_node_find_entity(&f->w->nodes[a], id);
    assert_true(dest >= 0);
    ub_route_info_t ri;
    assert_int_equal(ub_route_get(&f->rt[a], f->self[a], dest, &ri), UB_OK);
    return ri;
}

static bool knows(fleet_t *f, int a, int b) {
    uint8_t id[UB_ENTITY_ID_LEN];
    vid(b, id);
    return ub_node_find_entity(&f->w->nodes[a], id) >= 0;
}

static bool all_reach(fleet_t *f) {
    for (size_t a = 0; a < f->n; a++)
        for (size_t b = 0; b < f->n; b++)
            if (a != b && (!knows(f, (int)a, (int)b) || !route(f, (int)a, (int)b).reachable)) return false;
    return true;
}

/* On a failure: what every node chose, and its links (cmocka shows stderr). */
static void dump_routes(fleet_t *f) {
    for (size_t a = 0; a < f->n; a++) {
        for (size_t b = 0; b < f->n; b++) {
            if (a == b) continue;
            if (!knows(f, (int)a, (int)b)) {
                fprintf(stderr, "v%zu does not know v%zu\n", a, b);
                continue;
            }
            ub_route_info_t ri = route(f, (int)a, (int)b);
            fprintf(stderr, "v%zu->v%zu reachable=%d link=%d metric=%u seqno=%u fd=%d/%u/%u routes=%u feasible=%u starving=%d\n",
                    a, b, ri.reachable, ri.link_id, ri.metric, ri.seqno, ri.fd_valid, ri.fd_seqno, ri.fd_metric, ri.routes,
                    ri.feasible, ri.starving);
        }
        for (int l = 0; l < UB_MAX_NODE_LINKS; l++) {
            ub_route_link_info_t li;
            if (ub_route_link_info(&f->rt[a], l, &li) != UB_OK) continue;
            fprintf(stderr, "v%zu link %d neighbour=%d cost=%u rxcost=%u txcost=%u history=%04x/%u\n", a, l, li.neighbour,
                    li.cost, li.rxcost, li.txcost, li.history, li.samples);
        }
    }
}

/* Runs until every node reaches every other one; returns the time it took. Fails after `limit_ms`. */
static uint64_t converge(fleet_t *f, uint64_t limit_ms) {
    uint64_t t0 = f->w->now_ms;
    while (!all_reach(f)) {
        if (f->w->now_ms - t0 >= limit_ms) dump_routes(f);
        assert_true(f->w->now_ms - t0 < limit_ms);
        world_run(f->w, f->w->now_ms + 1, 1);
    }
    return f->w->now_ms - t0;
}

static uint64_t link_frames(const fleet_t *f, int node, int link_id) {
    ub_route_link_info_t li;
    assert_int_equal(ub_route_link_info(&f->rt[node], link_id, &li), UB_OK);
    return li.stats.frames_out;
}

/* ---- DATA traffic and the loop check ------------------------------------------------------------------ */

#define TX_MAX 200000
typedef struct tx_record {
    uint8_t src;
    uint32_t seq;
    uint8_t edge;
} tx_record_t;

typedef struct tx_log {
    fleet_t *f;
    size_t n;
    tx_record_t r[TX_MAX];
} tx_log_t;

typedef struct tap_ctx {
    tx_log_t *log;
    int node;
} tap_ctx_t;
static tap_ctx_t g_taps[WORLD_MAX_NODES];

static int edge_of(const fleet_t *f, int node, int link_id) {
    for (size_t e = 0; e < f->w->n_links; e++) {
        if ((f->edge[e].a == node && f->edge[e].la == link_id) || (f->edge[e].b == node && f->edge[e].lb == link_id))
            return (int)e;
    }
    return -1;
}

static void on_tap(void *user, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)len;
    (void)now_ms;
    tap_ctx_t *c = user;
    if (dir != UB_TAP_TX || frame[UB_FRAME_OFF_ADMIN] != UB_ADMIN_DATA) return;
    tx_log_t *log = c->log;
    assert_true(log->n < TX_MAX);
    tx_record_t *r = &log->r[log->n++];
    r->src = (uint8_t)atoi((const char *)frame + UB_FRAME_OFF_SRC_ID + 1);
    r->seq = ub_get_u32le(frame + UB_FRAME_OFF_SEQ);
    r->edge = (uint8_t)edge_of(log->f, c->node, link_id);
}

static void taps_on(fleet_t *f, tx_log_t *log) {
    log->f = f;
    for (size_t i = 0; i < f->n; i++) {
        g_taps[i] = (tap_ctx_t){log, (int)i};
        ub_node_set_tap(&f->w->nodes[i], on_tap, &g_taps[i]);
    }
}

static int cmp_tx(const void *x, const void *y) {
    const tx_record_t *a = x, *b = y;
    if (a->src != b->src) return a->src < b->src ? -1 : 1;
    if (a->seq != b->seq) return a->seq < b->seq ? -1 : 1;
    return a->edge < b->edge ? -1 : a->edge > b->edge;
}

/* Number of (frame, link) pairs seen more than once: a frame crossing one link twice went round a loop. */
static size_t link_repeats(tx_log_t *log) {
    qsort(log->r, log->n, sizeof log->r[0], cmp_tx);
    size_t rep = 0;
    for (size_t i = 1; i < log->n; i++)
        if (cmp_tx(&log->r[i - 1], &log->r[i]) == 0) rep++;
    return rep;
}

/* Every node sends DATA to every other node it knows, every `period_ms`, while the world runs. */
static void run_traffic(fleet_t *f, uint64_t until_ms, uint64_t period_ms) {
    while (f->w->now_ms < until_ms) {
        if (f->w->now_ms % period_ms == 0) {
            for (size_t a = 0; a < f->n; a++) {
                for (size_t b = 0; b < f->n; b++) {
                    uint8_t id[UB_ENTITY_ID_LEN];
                    vid((int)b, id);
                    if (a == b || ub_node_find_entity(&f->w->nodes[a], id) < 0) continue;
                    int rc = ub_node_send_data(&f->w->nodes[a], f->self[a], TEST_GPS, id, f->w->now_ms);
                    assert_true(rc >= 0 || rc == UB_ERR_NOROUTE);
                }
            }
        }
        world_run(f->w, f->w->now_ms + 1, 1);
    }
}

/* v0 sends DATA to v<b> every `period_ms` while the world runs until `until_ms`; returns frames sent. */
static uint64_t stream_to(fleet_t *f, int b, uint64_t until_ms, uint64_t period_ms) {
    uint64_t sent = 0;
    uint8_t id[UB_ENTITY_ID_LEN];
    vid(b, id);
    while (f->w->now_ms < until_ms) {
        if (f->w->now_ms % period_ms == 0) {
            int rc = ub_node_send_data(&f->w->nodes[0], f->self[0], TEST_GPS, id, f->w->now_ms);
            assert_true(rc >= 0 || rc == UB_ERR_NOROUTE);
            sent++;
        }
        world_run(f->w, f->w->now_ms + 1, 1);
    }
    return sent;
}

/* A diamond: v0 reaches v3 through v1 or v2 at the same metric (both feasible). Returns the edge v0 uses. */
static int diamond(fleet_t *f, int edges[4]) {
    edges[0] = fleet_link(f, 0, 1);
    edges[1] = fleet_link(f, 1, 3);
    edges[2] = fleet_link(f, 0, 2);
    edges[3] = fleet_link(f, 2, 3);
    fleet_start(f);
    converge(f, 10 * HELLO_MS);
    stream_to(f, 3, f->w->now_ms + 4 * HELLO_MS, 10); /* traffic: v1/v2 send v0 fast hellos */
    ub_route_info_t ri = route(f, 0, 3);
    assert_true(ri.reachable);
    return ri.link_id == f->edge[edges[0]].la ? edges[0] : edges[2];
}

/* ---- tests -------------------------------------------------------------------------------------------- */

/* v0 - v1 - v2 - v3: nobody is told about anybody; routes, masks and the entity tables fill themselves. */
static void test_line_converges_and_learns(void **state) {
    (void)state;
    fleet_t *f = fleet_new(4, NULL);
    int e01 = fleet_link(f, 0, 1);
    fleet_link(f, 1, 2);
    fleet_link(f, 2, 3);
    fleet_start(f);
    uint64_t t = converge(f, 10 * HELLO_MS);
    /* One hello to hear, one to be heard (IHU), then triggered updates hop by hop: well under 3 intervals. */
    assert_true(t <= 3 * HELLO_MS);
    ub_route_info_t ri = route(f, 0, 3);
    assert_true(ri.reachable && ri.learned && !ri.local);
    assert_int_equal(ri.metric, 3 * UB_ROUTE_LINK_COST);
    assert_int_equal(ri.link_id, f->edge[e01].la);
    uint8_t v1[UB_ENTITY_ID_LEN];
    vid(1, v1);
    assert_memory_equal(ri.next_hop, v1, UB_ENTITY_ID_LEN);
    /* The node's mask for v3 is the one bit of the link to v1, written by the engine, not pinned. */
    uint8_t mask = 0, v3[UB_ENTITY_ID_LEN];
    vid(3, v3);
    assert_int_equal(ub_node_get_mask(&f->w->nodes[0], f->self[0], ub_node_find_entity(&f->w->nodes[0], v3), &mask), UB_OK);
    assert_int_equal(mask, 0x01);
    assert_false(ri.pinned);
    /* DATA over three hops. */
    run_traffic(f, f->w->now_ms + 200, 10);
    assert_true(f->rx_count[3][0] >= 15);
    assert_true(f->rx_count[0][3] >= 15);
    assert_int_equal(ub_route_counters(&f->rt[1])->learned, 3); /* v1 learned v0, v2 and v3 */
    fleet_free(f);
}

/* In steady state every link carries exactly one routing frame per hello interval (HELLO or an update slice). */
static void test_steady_state_one_frame_per_link_per_hello(void **state) {
    (void)state;
    fleet_t *f = fleet_new(5, NULL);
    fleet_link(f, 0, 1);
    fleet_link(f, 1, 2);
    fleet_link(f, 2, 3);
    fleet_link(f, 3, 4);
    fleet_link(f, 4, 0);
    fleet_link(f, 1, 3);
    fleet_start(f);
    converge(f, 10 * HELLO_MS);
    world_run(f->w, f->w->now_ms + 20 * HELLO_MS, 1); /* let the start-up triggered updates die out */
    uint64_t before[WORLD_MAX_LINKS][2], trig[WORLD_MAX_LINKS][2];
    for (size_t e = 0; e < f->w->n_links; e++) {
        before[e][0] = link_frames(f, f->edge[e].a, f->edge[e].la);
        before[e][1] = link_frames(f, f->edge[e].b, f->edge[e].lb);
        ub_route_link_info_t li;
        assert_int_equal(ub_route_link_info(&f->rt[f->edge[e].a], f->edge[e].la, &li), UB_OK);
        trig[e][0] = li.stats.triggered_out;
        assert_int_equal(ub_route_link_info(&f->rt[f->edge[e].b], f->edge[e].lb, &li), UB_OK);
        trig[e][1] = li.stats.triggered_out;
    }
    const uint64_t window = 100 * HELLO_MS;
    world_run(f->w, f->w->now_ms + window, 1);
    for (size_t e = 0; e < f->w->n_links; e++) {
        uint64_t sent_a = link_frames(f, f->edge[e].a, f->edge[e].la) - before[e][0];
        uint64_t sent_b = link_frames(f, f->edge[e].b, f->edge[e].lb) - before[e][1];
        assert_true(sent_a >= window / HELLO_MS - 1 && sent_a <= window / HELLO_MS + 1);
        assert_true(sent_b >= window / HELLO_MS - 1 && sent_b <= window / HELLO_MS + 1);
        ub_route_link_info_t li;
        assert_int_equal(ub_route_link_info(&f->rt[f->edge[e].a], f->edge[e].la, &li), UB_OK);
        assert_int_equal(li.stats.triggered_out, trig[e][0]); /* nothing changed: nothing triggered */
        assert_int_equal(li.cost, UB_ROUTE_LINK_COST);
    }
    fleet_free(f);
}

/*
 * Loop freedom while reconverging: a mesh carries DATA between all pairs every 2 ms while links fail and
 * come back; the tap records every DATA transmission, and no frame may cross the same link twice.
 */
static void test_no_frame_crosses_a_link_twice_while_reconverging(void **state) {
    (void)state;
    fleet_t *f = fleet_new(6, NULL);
    int ab = fleet_link(f, 0, 1);
    fleet_link(f, 1, 2);
    int cd = fleet_link(f, 2, 3);
    fleet_link(f, 3, 4);
    fleet_link(f, 4, 5);
    int fa = fleet_link(f, 5, 0);
    fleet_link(f, 1, 4);
    int be = fleet_link(f, 0, 3);
    fleet_start(f);
    converge(f, 10 * HELLO_MS);
    tx_log_t *log = calloc(1, sizeof *log);
    assert_non_null(log);
    taps_on(f, log);
    run_traffic(f, f->w->now_ms + 5 * HELLO_MS, 2);
    fleet_cut(f, ab);
    fleet_cut(f, cd);
    run_traffic(f, f->w->now_ms + 10 * HELLO_MS, 2);
    fleet_heal(f, ab);
    fleet_cut(f, be);
    run_traffic(f, f->w->now_ms + 10 * HELLO_MS, 2);
    fleet_cut(f, fa);
    fleet_heal(f, cd);
    run_traffic(f, f->w->now_ms + 10 * HELLO_MS, 2);
    assert_true(log->n > 10000);
    assert_int_equal(link_repeats(log), 0);
    /* Duplicates come only from links in doubt (a cut is first a gap in the neighbour's frames: every feasible
     * successor carries the traffic until the hello timeout decides); without a doubt there are none. Loop
     * freedom is the assertion above: no copy crossed a link twice. */
    uint64_t dups = 0, doubts = 0;
    for (size_t i = 0; i < f->n; i++) {
        dups += ub_node_counters(&f->w->nodes[i])->drops[UB_DROP_DUPLICATE];
        doubts += ub_route_counters(&f->rt[i])->link_doubts;
    }
    assert_true(dups == 0 || doubts > 0);
    /* The mesh is still connected (ab, cd healed; fa, be cut): everyone reaches everyone. */
    assert_true(all_reach(f));
    free(log);
    fleet_free(f);
}

/* Two links between v0 and v1 (the paper's 0x11): policy ALL uses both, BEST the cheaper one. */
static void test_parallel_links(void **state) {
    (void)state;
    for (int policy = UB_ROUTE_PARALLEL_ALL; policy <= UB_ROUTE_PARALLEL_BEST; policy++) {
        ub_route_options_t ro = {.hello_ms = HELLO_MS, .parallel = (uint8_t)policy};
        fleet_t *f = fleet_new(3, &ro);
        int a = fleet_link(f, 0, 1);
        int b = fleet_link(f, 0, 1);
        fleet_link(f, 1, 2);
        fleet_start(f);
        converge(f, 10 * HELLO_MS);
        ub_route_info_t ri = route(f, 0, 2);
        assert_int_equal(ri.mask, policy == UB_ROUTE_PARALLEL_ALL ? 0x03 : (ri.link_id == f->edge[a].la ? 0x01 : 0x02));
        /* Frames from v0 to v2: with ALL, two copies reach v1 and one is cut by its duplicate window. */
        run_traffic(f, f->w->now_ms + 100, 10);
        uint64_t dups = ub_node_counters(&f->w->nodes[1])->drops[UB_DROP_DUPLICATE];
        if (policy == UB_ROUTE_PARALLEL_ALL) assert_true(dups >= 10);
        else assert_int_equal(dups, 0);
        /* A lossy link (30 %) costs more: BEST moves to the clean one; ALL keeps both while both are up. */
        ub_memlink_faults_t lossy = {.loss_ppm = 300000};
        ub_memlink_set_faults(&f->w->links[a], &lossy);
        world_run(f->w, f->w->now_ms + 40 * HELLO_MS, 1);
        ri = route(f, 0, 2);
        assert_true(ri.reachable);
        ub_route_link_info_t la, lb;
        assert_int_equal(ub_route_link_info(&f->rt[0], f->edge[a].la, &la), UB_OK);
        assert_int_equal(ub_route_link_info(&f->rt[0], f->edge[b].la, &lb), UB_OK);
        assert_true(la.cost > lb.cost);
        assert_int_equal(ri.link_id, f->edge[b].la);
        if (policy == UB_ROUTE_PARALLEL_BEST) assert_int_equal(ri.mask, 0x02);
        /* One link dead: it leaves the mask under either policy. */
        fleet_cut(f, a);
        world_run(f->w, f->w->now_ms + 4 * HELLO_MS, 1);
        ri = route(f, 0, 2);
        assert_true(ri.reachable);
        assert_int_equal(ri.mask, 0x02);
        fleet_free(f);
    }
}

/* A neighbour that goes silent: its link is down within 3 hello intervals, its routes go with it, and
 * after 16 intervals it is forgotten. */
static void test_silent_neighbour_expires(void **state) {
    (void)state;
    fleet_t *f = fleet_new(3, NULL);
    int e = fleet_link(f, 0, 1);
    fleet_link(f, 1, 2);
    fleet_start(f);
    converge(f, 10 * HELLO_MS);
    fleet_cut(f, e);
    uint64_t t0 = f->w->now_ms;
    while (route(f, 0, 2).reachable || route(f, 0, 1).reachable) {
        assert_true(f->w->now_ms - t0 <= 3 * HELLO_MS);
        world_run(f->w, f->w->now_ms + 1, 1);
    }
    /* Node masks follow: no link toward v1 or v2 any more. */
    uint8_t id[UB_ENTITY_ID_LEN], mask = 0xFF;
    vid(2, id);
    assert_int_equal(ub_node_get_mask(&f->w->nodes[0], f->self[0], ub_node_find_entity(&f->w->nodes[0], id), &mask), UB_OK);
    assert_int_equal(mask, 0);
    assert_true(route(f, 0, 2).retracting);
    assert_int_equal(ub_node_send_data(&f->w->nodes[0], f->self[0], TEST_GPS, id, f->w->now_ms), UB_ERR_NOROUTE);
    world_run(f->w, f->w->now_ms + 17 * HELLO_MS, 1);
    ub_route_link_info_t li;
    assert_int_equal(ub_route_link_info(&f->rt[0], f->edge[e].la, &li), UB_OK);
    assert_false(li.neighbour);
    assert_int_equal(li.stats.link_downs, 1);
    assert_false(route(f, 0, 2).retracting); /* the retraction was advertised, then dropped */
    assert_true(route(f, 0, 2).routes == 0);
    fleet_free(f);
}

/* Drops `n` of node `who`'s routing frames on edge e (who is one of its ends), one frame at a time (the edge is cut
 * until exactly one more of its frames has gone into it), two hello intervals apart. */
static void lose_frames_of(fleet_t *f, int e, int who, unsigned n) {
    int link = who == f->edge[e].a ? f->edge[e].la : f->edge[e].lb;
    for (unsigned k = 0; k < n; k++) {
        ub_route_link_info_t l1;
        assert_int_equal(ub_route_link_info(&f->rt[who], link, &l1), UB_OK);
        uint64_t sent = l1.stats.frames_out;
        fleet_cut(f, e);
        while (l1.stats.frames_out == sent) {
            world_run(f->w, f->w->now_ms + 1, 1);
            assert_int_equal(ub_route_link_info(&f->rt[who], link, &l1), UB_OK);
        }
        fleet_heal(f, e);
        world_run(f->w, f->w->now_ms + 2 * HELLO_MS, 1);
    }
}

/* Two nodes and one link, dead_misses 3. v1's routing frames are dropped `lost` times, one frame at a time and two
 * hello intervals apart, then `quiet` more hello intervals pass, then the link is cut for good. Returns the run of
 * missed hellos at which v0 took the link down (its rxcost went infinite), having checked that it was up one miss
 * before. `etx_lost`: the misses v0's ETX window (the last 16 hellos, ub_route_link_info()) shows before the cut. */
static unsigned misses_to_down(unsigned lost, unsigned quiet, unsigned *etx_lost) {
    ub_route_options_t ro = {.hello_ms = HELLO_MS, .dead_misses = 3};
    fleet_t *f = fleet_new(2, &ro);
    int e = fleet_link(f, 0, 1);
    fleet_start(f);
    converge(f, 10 * HELLO_MS);
    world_run(f->w, f->w->now_ms + 40 * HELLO_MS, 1); /* a full memory of hellos heard */
    ub_route_link_info_t li;
    lose_frames_of(f, e, 1, lost);
    world_run(f->w, f->w->now_ms + quiet * HELLO_MS, 1);
    assert_int_equal(ub_route_link_info(&f->rt[0], f->edge[e].la, &li), UB_OK);
    assert_int_equal(li.samples, 16);
    assert_true(li.history & 1u);
    *etx_lost = 16u - (unsigned)__builtin_popcount(li.history);
    fleet_cut(f, e);
    unsigned run = 0;
    for (;;) {
        world_run(f->w, f->w->now_ms + 1, 1);
        assert_int_equal(ub_route_link_info(&f->rt[0], f->edge[e].la, &li), UB_OK);
        unsigned now = li.history == 0 ? 16u : (unsigned)__builtin_ctz(li.history);
        if (li.rxcost == UB_ROUTE_INFINITY) {
            assert_int_equal(now, run + 1); /* down on the miss that made the run long enough, not later */
            run = now;
            break;
        }
        assert_true(now <= run + 1);
        run = now;
        assert_true(run < 16);
    }
    fleet_free(f);
    return run;
}

/* A run of missed hellos takes a link down only when the link's own loss does not explain it: `dead_misses` in a
 * row on a link that lost nothing before, one more per hello lost among the 32 expected before the run, at most
 * `dead_misses` more. fleet6's detour loses 20 % of its hellos: a run of 3 came every ~125 hellos and took it down
 * each time, and each time the seqno requests and answers crossed the fleet (the frame budget of its steady
 * windows). */
static void test_a_lossy_link_needs_a_longer_run_of_misses(void **state) {
    (void)state;
    unsigned etx = 0;
    assert_int_equal(misses_to_down(0, 0, &etx), 3);
    assert_int_equal(etx, 0);
    assert_int_equal(misses_to_down(1, 0, &etx), 4);
    assert_int_equal(etx, 1);
    assert_int_equal(misses_to_down(2, 0, &etx), 5);
    assert_int_equal(etx, 2);
    assert_int_equal(misses_to_down(4, 0, &etx), 6); /* at most twice dead_misses */
    assert_int_equal(etx, 4);
    /* Losses that have left the ETX window (the cost is 256 again) are still remembered for this. */
    assert_int_equal(misses_to_down(2, 18, &etx), 5);
    assert_int_equal(etx, 0);
}

/* A lossy link that went down and comes back resumes at the cost it had before the outage: the outage's misses are
 * dropped, its earlier losses kept. Starting it as a perfect link (256) lowered the feasibility distances of routes
 * through it, and its true cost a few seconds later made them unfeasible (seqno requests; fleet6's detour). */
static void test_a_lossy_link_comes_back_at_its_old_cost(void **state) {
    (void)state;
    ub_route_options_t ro = {.hello_ms = HELLO_MS, .dead_misses = 3};
    fleet_t *f = fleet_new(2, &ro);
    int e = fleet_link(f, 0, 1);
    fleet_start(f);
    converge(f, 10 * HELLO_MS);
    world_run(f->w, f->w->now_ms + 40 * HELLO_MS, 1);
    ub_route_link_info_t li;
    lose_frames_of(f, e, 1, 3);
    assert_int_equal(ub_route_link_info(&f->rt[0], f->edge[e].la, &li), UB_OK);
    uint16_t before = li.rxcost;
    assert_true(before > UB_ROUTE_LINK_COST); /* 16 * 256 / 13 */
    fleet_cut(f, e);
    while (li.rxcost != UB_ROUTE_INFINITY) {
        world_run(f->w, f->w->now_ms + 1, 1);
        assert_int_equal(ub_route_link_info(&f->rt[0], f->edge[e].la, &li), UB_OK);
    }
    fleet_heal(f, e);
    while (li.rxcost == UB_ROUTE_INFINITY) {
        world_run(f->w, f->w->now_ms + 1, 1);
        assert_int_equal(ub_route_link_info(&f->rt[0], f->edge[e].la, &li), UB_OK);
    }
    /* Back with its earlier record and the hello that brought it back; the outage is not counted. */
    assert_true(li.rxcost > UB_ROUTE_LINK_COST);
    assert_true(li.rxcost <= before);
    assert_int_equal(li.history & 1u, 1u);
    fleet_free(f);
}

/* ETX noise on a path must not make a destination starve. v0 -- v1 -- v2: v0 reaches v2 through v1 (metric 512,
 * its feasibility distance). Every other frame across v1-v2 is lost, so v1's cost to v2, and the metric it advertises
 * for v2 at the same seqno, rises to 512 and more: unfeasible at v0, which has no other route. Accepting it (before)
 * lost the route and sent a seqno request to v2, whose new seqno then crossed every link: on fleet6's 20 %-lossy
 * detour that happened in steady windows. Held back (RFC 8966 3.5.4), the route stays selected at its last feasible
 * metric while the rise lasts less than its expiry, and is refreshed when the cost comes back; a rise that outlasts
 * the expiry still starves and asks, so a held metric is never kept for good. */
static void test_a_metric_rise_on_the_only_route_is_held_not_starved(void **state) {
    (void)state;
    ub_route_options_t ro = {.hello_ms = HELLO_MS, .dead_misses = 3};
    fleet_t *f = fleet_new(3, &ro);
    fleet_link(f, 0, 1);
    int far = fleet_link(f, 1, 2);
    fleet_start(f);
    converge(f, 10 * HELLO_MS);
    world_run(f->w, f->w->now_ms + 40 * HELLO_MS, 1);
    assert_int_equal(route(f, 0, 2).metric, 2 * UB_ROUTE_LINK_COST);
    uint16_t seq = ub_route_seqno(&f->rt[2], f->self[2]);
    const ub_route_counters_t *c0 = ub_route_counters(&f->rt[0]);
    /* A rise that lasts about one expiry (3.5 update intervals = 14 hellos): 6 frames of v2's lost, every other one. */
    lose_frames_of(f, far, 2, 6);
    ub_route_link_info_t li;
    assert_int_equal(ub_route_link_info(&f->rt[1], f->edge[far].la, &li), UB_OK);
    assert_true(li.cost >= 2 * UB_ROUTE_LINK_COST); /* v1 advertises v2 at 512 or more: unfeasible at v0 */
    assert_true(route(f, 0, 2).reachable);
    assert_int_equal(c0->routes_lost, 0);
    assert_int_equal(c0->starvation_requests, 0);
    assert_int_equal(ub_route_counters(&f->rt[2])->seqno_bumps, 0);
    assert_int_equal(ub_route_seqno(&f->rt[2], f->self[2]), seq);
    assert_true(c0->unfeasible_held >= 1);
    /* The cost comes back below v0's feasibility distance: the entry is refreshed, the route never lost. */
    world_run(f->w, f->w->now_ms + 20 * HELLO_MS, 1);
    assert_true(route(f, 0, 2).reachable);
    assert_int_equal(c0->routes_lost, 0);
    assert_int_equal(c0->starvation_requests, 0);
    assert_int_equal(c0->expired, 0);
    /* A rise that outlasts the expiry: the held entry expires, v0 starves and asks, v2's new seqno makes the worse
     * route feasible, and v0 reaches v2 at its true metric. */
    lose_frames_of(f, far, 2, 30);
    assert_true(c0->starvation_requests >= 1);
    assert_true(ub_route_counters(&f->rt[2])->seqno_bumps >= 1);
    assert_true(route(f, 0, 2).reachable);
    assert_true(route(f, 0, 2).metric > 2 * UB_ROUTE_LINK_COST);
    fleet_free(f);
}

/* A partition and its repair: v0-v1 | v2-v3; each side loses the other, and regains it once healed. */
static void test_partition_and_repair(void **state) {
    (void)state;
    fleet_t *f = fleet_new(4, NULL);
    fleet_link(f, 0, 1);
    int mid = fleet_link(f, 1, 2);
    fleet_link(f, 2, 3);
    fleet_start(f);
    converge(f, 10 * HELLO_MS);
    fleet_cut(f, mid);
    uint64_t t0 = f->w->now_ms;
    while (route(f, 0, 3).reachable || route(f, 3, 0).reachable || route(f, 0, 2).reachable) {
        assert_true(f->w->now_ms - t0 <= 3 * HELLO_MS);
        world_run(f->w, f->w->now_ms + 1, 1);
    }
    assert_true(route(f, 0, 1).reachable && route(f, 2, 3).reachable); /* each side keeps itself */
    run_traffic(f, f->w->now_ms + 10 * HELLO_MS, 10);
    fleet_heal(f, mid);
    t0 = f->w->now_ms;
    memset(f->last_rx, 0, sizeof f->last_rx);
    /* Back within two hello intervals: the first hello across answers at once (IHU), then whole tables. */
    converge(f, 2 * HELLO_MS);
    run_traffic(f, f->w->now_ms + 100, 10);
    assert_true(f->last_rx[3][0] > t0 && f->last_rx[0][3] > t0);
    fleet_free(f);
}

/*
 * Starvation: v0 reaches v2 through v1 (metric 512). When v0-v1 fails, the detour v0-v3-v4-v2 advertises
 * v2 at 512 as well, which is not below v0's feasibility distance (512): unfeasible. v0 must ask for a
 * newer seqno; the request travels v3 -> v4 -> v2, v2 raises its seqno and the detour becomes feasible.
 */
static void test_starvation_is_resolved_by_a_seqno_request(void **state) {
    (void)state;
    fleet_t *f = fleet_new(5, NULL);
    int direct = fleet_link(f, 0, 1);
    fleet_link(f, 1, 2);
    fleet_link(f, 0, 3);
    fleet_link(f, 3, 4);
    fleet_link(f, 4, 2);
    fleet_start(f);
    converge(f, 10 * HELLO_MS);
    world_run(f->w, f->w->now_ms + 10 * HELLO_MS, 1);
    ub_route_info_t ri = route(f, 0, 2);
    assert_int_equal(ri.metric, 2 * UB_ROUTE_LINK_COST);
    uint16_t seq_before = ub_route_seqno(&f->rt[2], f->self[2]);
    fleet_cut(f, direct);
    uint64_t t0 = f->w->now_ms;
    while (!(route(f, 0, 2).reachable && route(f, 0, 2).metric == 3 * UB_ROUTE_LINK_COST)) {
        assert_true(f->w->now_ms - t0 <= 3 * HELLO_MS);
        world_run(f->w, f->w->now_ms + 1, 1);
    }
    assert_true(ub_route_counters(&f->rt[0])->starvation_requests >= 1);
    assert_true(ub_route_counters(&f->rt[2])->seqno_bumps >= 1);
    assert_true(ub_route_seqno(&f->rt[2], f->self[2]) != seq_before);
    assert_true(ub_route_counters(&f->rt[3])->requests_forwarded + ub_route_counters(&f->rt[4])->requests_forwarded >= 1);
    fleet_free(f);
}

/* The starving node's neighbour was routing through it: the retraction and the seqno request arrive in one
 * frame. The neighbour chooses its other route first and forwards the request along it at once; dropping it
 * (as a request from its next hop) left the starving node to ask again a hello interval later.
 *
 *   v0 (A) --cut-- v2 (D)        A's only alternative, through B, is unfeasible (512 + 256 > its FD 256).
 *    |              |            B routes through A (its first link); its other route, through C, is
 *   v1 (B) ------ v3 (C)         feasible at the same metric. */
static void test_starving_neighbours_request_goes_on_at_once(void **state) {
    (void)state;
    fleet_t *f = fleet_new(4, NULL);
    int direct = fleet_link(f, 0, 2);
    fleet_link(f, 1, 0);
    fleet_link(f, 1, 3);
    fleet_link(f, 3, 2);
    fleet_start(f);
    converge(f, 10 * HELLO_MS);
    world_run(f->w, f->w->now_ms + 10 * HELLO_MS, 1);
    assert_string_equal((const char *)route(f, 1, 2).next_hop, "v0");
    fleet_cut(f, direct);
    while (route(f, 0, 2).reachable) world_run(f->w, f->w->now_ms + 1, 1); /* A notices: dead_misses */
    uint64_t lost = f->w->now_ms;
    while (!route(f, 0, 2).reachable) {
        assert_true(f->w->now_ms - lost < HELLO_MS / 2); /* a few triggered frames, not another hello interval */
        world_run(f->w, f->w->now_ms + 1, 1);
    }
    assert_string_equal((const char *)route(f, 0, 2).next_hop, "v1");
    assert_true(ub_route_counters(&f->rt[1])->requests_forwarded >= 1);
    assert_int_equal(ub_route_counters(&f->rt[0])->starvation_requests, 1);
    fleet_free(f);
}

/* A node restarts (all state lost, seqno back to 0): its neighbours hold a newer FD for it, starve, ask,
 * and the restarted node jumps its seqno past the old one. */
static void test_restarted_node_is_reachable_again(void **state) {
    (void)state;
    ub_route_options_t ro = {.hello_ms = HELLO_MS, .initial_seqno = 0};
    fleet_t *f = fleet_new(3, &ro);
    fleet_link(f, 0, 1);
    fleet_link(f, 1, 2);
    fleet_start(f);
    converge(f, 10 * HELLO_MS);
    /* Make v2's seqno move on, so that the restarted one (0) is older than what the others hold. */
    for (int i = 0; i < 3; i++) {
        f->rt[2].seqno[0] = (uint16_t)(f->rt[2].seqno[0] + 5);
        world_run(f->w, f->w->now_ms + 5 * HELLO_MS, 1);
    }
    assert_true(route(f, 0, 2).seqno >= 15);
    /* Restart v2 in place: same entity, same link id, fresh node and engine. */
    ub_node_t *n2 = &f->w->nodes[2];
    ub_memlink_t *ml = &f->w->links[1];
    ub_memlink_disconnect(ml);
    /* A restarted process starts its sequence numbers elsewhere (uavbus_node: from the wall clock), or the
     * duplicate windows of its neighbours would take its first frames for old ones (ub_node.h). */
    ub_node_options_t boot = {.first_seq = 1000000};
    assert_int_equal(ub_node_init(n2, &ub_test_cat, &boot), UB_OK);
    assert_int_equal(ub_node_add_entity_name(n2, "v2", true), f->self[2]);
    assert_int_equal(ub_node_add_link(n2, f->self[2], 0, "l1_2to1"), f->edge[1].lb);
    assert_int_equal(ub_node_bind(n2, TEST_GPS, &f->gps[2]), UB_OK);
    ub_node_set_deliver_hook(n2, on_deliver, &g_hooks[2]);
    assert_int_equal(ub_memlink_connect(ml, &f->w->nodes[1], f->edge[1].la, n2, f->edge[1].lb), UB_OK);
    assert_int_equal(ub_route_attach(&f->rt[2], n2, &ro, f->w->now_ms), UB_OK);
    uint64_t t0 = f->w->now_ms;
    memset(f->last_rx, 0, sizeof f->last_rx);
    converge(f, 6 * HELLO_MS);
    run_traffic(f, f->w->now_ms + 100, 10);
    assert_true(f->last_rx[2][0] > t0 && f->last_rx[0][2] > t0);
    assert_true(ub_route_seqno(&f->rt[2], f->self[2]) >= 15);
    fleet_free(f);
}

/* A hand-set mask pins its entry; mask 0 unpins it and the engine fills it again. */
static void test_manual_mask_pins_a_route(void **state) {
    (void)state;
    fleet_t *f = fleet_new(3, NULL);
    int ab = fleet_link(f, 0, 1);
    int ab2 = fleet_link(f, 0, 1);
    fleet_link(f, 1, 2);
    fleet_start(f);
    converge(f, 10 * HELLO_MS);
    uint8_t v2[UB_ENTITY_ID_LEN];
    vid(2, v2);
    ub_node_t *n0 = &f->w->nodes[0];
    int d = ub_node_find_entity(n0, v2);
    assert_int_equal(ub_node_set_mask(n0, f->self[0], d, 0x02), UB_OK); /* only the second link */
    assert_true(ub_node_mask_pinned(n0, f->self[0], d));
    assert_int_equal(ub_node_set_auto_mask(n0, f->self[0], d, 0x01), UB_ERR_EXISTS);
    fleet_cut(f, ab2); /* the pinned link fails: the engine's route changes, the pin does not */
    world_run(f->w, f->w->now_ms + 5 * HELLO_MS, 1);
    uint8_t mask = 0;
    assert_int_equal(ub_node_get_mask(n0, f->self[0], d, &mask), UB_OK);
    assert_int_equal(mask, 0x02);
    ub_route_info_t ri = route(f, 0, 2);
    assert_true(ri.pinned && ri.reachable);
    assert_int_equal(ri.mask, 0x01);
    assert_true(ub_route_counters(&f->rt[0])->pinned_skips >= 1);
    /* Unpin: the automatic route comes back at the next tick. */
    assert_int_equal(ub_node_set_mask(n0, f->self[0], d, 0), UB_OK);
    assert_false(ub_node_mask_pinned(n0, f->self[0], d));
    world_run(f->w, f->w->now_ms + 1, 1);
    assert_int_equal(ub_node_get_mask(n0, f->self[0], d, &mask), UB_OK);
    assert_int_equal(mask, 0x01);
    (void)ab;
    /* Detaching the engine clears the automatic masks: manual routing resumes. */
    ub_route_detach(&f->rt[0]);
    assert_int_equal(ub_node_get_mask(n0, f->self[0], d, &mask), UB_OK);
    assert_int_equal(mask, 0);
    fleet_free(f);
}

/* Removing an entity forgets its routes, and it is not learned back while neighbours still advertise it. */
static void test_removed_entity_is_not_relearned_at_once(void **state) {
    (void)state;
    fleet_t *f = fleet_new(3, NULL);
    fleet_link(f, 0, 1);
    fleet_link(f, 1, 2);
    fleet_start(f);
    converge(f, 10 * HELLO_MS);
    uint8_t v2[UB_ENTITY_ID_LEN];
    vid(2, v2);
    ub_node_t *n0 = &f->w->nodes[0];
    assert_int_equal(ub_node_remove_entity(n0, ub_node_find_entity(n0, v2), f->w->now_ms), UB_OK);
    world_run(f->w, f->w->now_ms + 10 * HELLO_MS, 1);
    assert_int_equal(ub_node_find_entity(n0, v2), UB_ERR_NOTFOUND);
    assert_true(ub_route_counters(&f->rt[0])->learn_refused >= 1);
    /* After the tombstone (4 update intervals) a still-advertised entity is learned again. */
    world_run(f->w, f->w->now_ms + 4 * 4 * HELLO_MS, 1);
    assert_true(ub_node_find_entity(n0, v2) >= 0);
    fleet_free(f);
}

/* A forged ROUTE_UPDATE from `src` advertising `n` entities "f<first>".. (unsigned: anyone may send it on an
 * unsigned network), into node `node`'s link `link_id`. */
static void forge_update(fleet_t *f, int node, int link_id, const char *src, uint32_t seq, unsigned first, unsigned n) {
    uint8_t frame[UB_FRAME_MAX];
    uint8_t *p = frame + UB_FRAME_HEADER_LEN;
    size_t len = UB_ROUTE_HDR_LEN + n * UB_ROUTE_ENTRY_LEN;
    memset(p, 0, len);
    p[0] = UB_ROUTE_WIRE_VERSION;
    ub_put_u16le(p + 2, (uint16_t)seq);
    ub_put_u16le(p + 4, HELLO_MS);
    ub_put_u16le(p + 6, 4 * HELLO_MS);
    ub_put_u16le(p + 8, UB_ROUTE_INFINITY);
    p[10] = (uint8_t)n;
    for (unsigned i = 0; i < n; i++) {
        uint8_t *e = p + UB_ROUTE_HDR_LEN + i * UB_ROUTE_ENTRY_LEN;
        char name[16];
        snprintf(name, sizeof name, "f%u", first + i);
        test_eid(name, e);
        ub_put_u16le(e + 12, 1);                 /* seqno */
        ub_put_u16le(e + 14, UB_ROUTE_LINK_COST); /* metric */
    }
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memset(h.dest_id, UB_LINK_LOCAL_BYTE, UB_ENTITY_ID_LEN);
    test_eid(src, h.src_id);
    h.admin = UB_ADMIN_ROUTE_UPDATE;
    h.hop_limit = 1;
    h.payload_size = (uint16_t)len;
    h.seq = seq;
    int fl = ub_frame_finish(frame, sizeof frame, &h);
    assert_true(fl > 0);
    assert_int_equal(ub_node_rx_frame(&f->w->nodes[node], link_id, frame, (size_t)fl, f->w->now_ms), UB_OK);
}

static int fakes_known(fleet_t *f, int node, unsigned n) {
    int known = 0;
    for (unsigned i = 0; i < n; i++) {
        char name[16];
        uint8_t id[UB_ENTITY_ID_LEN];
        snprintf(name, sizeof name, "f%u", i);
        test_eid(name, id);
        known += ub_node_find_entity(&f->w->nodes[node], id) >= 0;
    }
    return known;
}

/* Issue 29: forged route updates on an unsigned network fill the entity table (learn_full) -- but what no
 * update advertises any more leaves it after learn_expiry_ms, and the table takes genuine entities again. */
static void test_learned_entities_expire_when_nobody_advertises_them(void **state) {
    (void)state;
    ub_route_options_t ro = {.learn_expiry_ms = 10 * HELLO_MS, .max_dests = UB_MAX_ENTITIES}; /* no per-neighbour bound:
                                                                  this test is about the table filling up and emptying */
    fleet_t *f = fleet_new(3, &ro);
    int e01 = fleet_link(f, 0, 1);
    fleet_link(f, 1, 2);
    fleet_start(f);
    converge(f, 10 * HELLO_MS);
    const ub_route_counters_t *c = ub_route_counters(&f->rt[0]);
    /* the forger fills node 0's table: 24 fake entities, more than it holds */
    uint64_t t_forged = f->w->now_ms;
    for (uint32_t k = 0; k < 3; k++) {
        forge_update(f, 0, f->edge[e01].la, "evil", 1 + k, 8 * k, 8);
        world_run(f->w, f->w->now_ms + 5, 1);
    }
    int filled = fakes_known(f, 0, 24);
    assert_true(filled > 0);
    assert_true(c->learn_full > 0); /* the table was full: the bound, counted */
    assert_int_equal(c->learn_expired, 0);
    /* nobody advertises them any more: no entity learned from the forger outlives the expiry (checked every ms,
     * give or take the tick that removes it) */
    while (f->w->now_ms < t_forged + ro.learn_expiry_ms + 2 * HELLO_MS) {
        world_run(f->w, f->w->now_ms + 1, 1);
        if (f->w->now_ms > t_forged + 15 + ro.learn_expiry_ms) assert_int_equal(fakes_known(f, 0, 24), 0);
    }
    assert_int_equal(c->learn_expired, (uint64_t)filled);
    /* the genuine ones, advertised all along, stayed; a new genuine entity finds room again */
    assert_true(knows(f, 0, 1) && knows(f, 0, 2));
    assert_true(route(f, 0, 2).reachable);
    assert_true(fakes_known(f, 0, 24) == 0);
    forge_update(f, 0, f->edge[e01].la, "evil2", 100, 0, 1); /* learnable again at once: no tombstone */
    assert_int_equal(fakes_known(f, 0, 1), 1);
    fleet_free(f);
}

/* An insider: a neighbour "evil" whose frames are genuine (it holds a valid key, so signatures would not stop
 * them) on its own link of node `node`. Its hello part is well-formed -- consecutive hello seqnos, an IHU of a
 * loss-free link about v<node> -- so the link is up and its routes are usable. Entries: "f<first>".."f<first+n-1>"
 * at metric 256, then, if `extra` is set, `extra` with `extra_seqno` at metric 0 (a false low metric). */
typedef struct insider {
    int node, link;
    uint16_t hello_seq;
    uint32_t seq;
} insider_t;

static void insider_send(fleet_t *f, insider_t *in, unsigned first, unsigned n, const char *extra, uint16_t extra_seqno) {
    uint8_t frame[UB_FRAME_MAX];
    uint8_t *p = frame + UB_FRAME_HEADER_LEN;
    unsigned total = n + (extra != NULL);
    size_t len = UB_ROUTE_HDR_LEN + total * UB_ROUTE_ENTRY_LEN;
    assert_true(len <= UB_MAX_PAYLOAD && total <= 255);
    memset(p, 0, len);
    p[0] = UB_ROUTE_WIRE_VERSION;
    ub_put_u16le(p + 2, in->hello_seq++);
    ub_put_u16le(p + 4, HELLO_MS);
    ub_put_u16le(p + 6, 4 * HELLO_MS);
    ub_put_u16le(p + 8, UB_ROUTE_LINK_COST); /* it hears us perfectly */
    p[10] = (uint8_t)total;
    vid(in->node, p + 12);
    for (unsigned i = 0; i < total; i++) {
        uint8_t *e = p + UB_ROUTE_HDR_LEN + i * UB_ROUTE_ENTRY_LEN;
        char name[16];
        snprintf(name, sizeof name, "f%u", first + i);
        test_eid(i < n ? name : extra, e);
        ub_put_u16le(e + 12, i < n ? 1 : extra_seqno);
        ub_put_u16le(e + 14, i < n ? UB_ROUTE_LINK_COST : 0);
    }
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memset(h.dest_id, UB_LINK_LOCAL_BYTE, UB_ENTITY_ID_LEN);
    test_eid("evil", h.src_id);
    h.admin = UB_ADMIN_ROUTE_UPDATE;
    h.hop_limit = 1;
    h.payload_size = (uint16_t)len;
    h.seq = ++in->seq;
    int fl = ub_frame_finish(frame, sizeof frame, &h);
    assert_true(fl > 0);
    assert_int_equal(ub_node_rx_frame(&f->w->nodes[in->node], in->link, frame, (size_t)fl, f->w->now_ms), UB_OK);
}

/* Node 0 -- node 1 -- node 2, and an insider on a second link of node 0 (no transport: node 0's frames to it go
 * nowhere, which an insider does not need). */
static fleet_t *insider_fleet(const ub_route_options_t *ro, int *e01, insider_t *in) {
    fleet_t *f = fleet_new(3, ro);
    *e01 = fleet_link(f, 0, 1);
    fleet_link(f, 1, 2);
    *in = (insider_t){.node = 0, .link = ub_node_add_link(&f->w->nodes[0], f->self[0], f->next_index[0]++, "insider")};
    assert_true(in->link >= 0);
    fleet_start(f);
    converge(f, 10 * HELLO_MS);
    assert_true(route(f, 0, 2).reachable);
    return f;
}

/* Issue 23 item 6: a key-holding insider advertises 1,000 destinations, then a false metric 0 (with a newer
 * seqno) for the genuine v2. The per-neighbour bound keeps max_dests of them: the route table and the entity
 * table keep room for everyone else, every entry beyond is counted, and its claim for v2 -- beyond the bound --
 * does not take v2's traffic from the genuine route. */
static void test_insider_destinations_are_bounded_per_neighbour(void **state) {
    (void)state;
    int e01;
    insider_t in;
    const unsigned bound = UB_MAX_ENTITIES * 3 / 4; /* a node that knows its neighbours teach at most that many */
    ub_route_options_t ro = {.max_dests = (uint16_t)bound};
    fleet_t *f = insider_fleet(&ro, &e01, &in);
    assert_int_equal(f->rt[0].opt.max_dests, bound);
    const ub_route_counters_t *c = ub_route_counters(&f->rt[0]);
    uint16_t v2_seqno = route(f, 0, 2).seqno;
    for (unsigned k = 0; k < 20; k++) insider_send(f, &in, 50 * k, 50, NULL, 0); /* f0..f999 */
    insider_send(f, &in, 1000, 0, "v2", (uint16_t)(v2_seqno + 1));
    for (unsigned t = 0; t < 5; t++) { /* it keeps the link up and refreshes the claim */
        world_run(f->w, f->w->now_ms + HELLO_MS, 1);
        insider_send(f, &in, 1000, 0, "v2", (uint16_t)(v2_seqno + 1));
    }
    /* bounded: exactly `bound` of its destinations got a row (and were learned), the rest counted */
    assert_int_equal(fakes_known(f, 0, 1000), (int)bound);
    assert_int_equal(c->learn_full, 0);
    assert_int_equal(c->neighbour_limit, 1000 - bound + 6);
    ub_route_link_info_t li;
    assert_int_equal(ub_route_link_info(&f->rt[0], in.link, &li), UB_OK);
    assert_true(li.neighbour && li.cost == UB_ROUTE_LINK_COST); /* its link is up and cheap: the bound did that */
    assert_int_equal(li.stats.over_limit_in, c->neighbour_limit);
    /* the admitted ones are routed through it (within the bound, it attracts traffic: not protected) */
    uint8_t id[UB_ENTITY_ID_LEN];
    test_eid("f0", id);
    ub_route_info_t ri;
    assert_int_equal(ub_route_get(&f->rt[0], f->self[0], ub_node_find_entity(&f->w->nodes[0], id), &ri), UB_OK);
    assert_true(ri.reachable && ri.link_id == in.link);
    /* genuine routes: v2 still through node 1, whatever metric it claimed; v1 too */
    ri = route(f, 0, 2);
    assert_true(ri.reachable);
    assert_int_equal(ri.link_id, f->edge[e01].la);
    assert_int_equal(route(f, 0, 1).link_id, f->edge[e01].la);
    /* the entity table keeps room: a genuine newcomer is still accepted */
    assert_true(ub_node_add_entity_name(&f->w->nodes[0], "newcomer", false) >= 0);
    /* node 1, the insider's victim's neighbour, learned nothing of it: the fakes stop at node 0's bound, and node 0
     * re-advertises at most `bound` of them */
    assert_true(fakes_known(f, 1, 1000) <= (int)bound);
    fleet_free(f);
}

/* The accept_dest hook (e.g. "certified entities only", from the application's identity store): destinations
 * it refuses get no row and are not learned (dest_refused); a certified destination with a false low metric is
 * accepted -- what the threat model says stays open. */
static const char *const g_certified[] = {"v0", "v1", "v2", "evil"};
static bool certified_only(void *user, const uint8_t dest[UB_ENTITY_ID_LEN], const uint8_t neighbour[UB_ENTITY_ID_LEN],
                           uint16_t metric) {
    (void)neighbour;
    (void)metric;
    (*(unsigned *)user)++;
    for (size_t i = 0; i < sizeof g_certified / sizeof g_certified[0]; i++) {
        uint8_t id[UB_ENTITY_ID_LEN];
        test_eid(g_certified[i], id);
        if (memcmp(id, dest, UB_ENTITY_ID_LEN) == 0) return true;
    }
    return false;
}

static void test_insider_uncertified_destinations_are_refused(void **state) {
    (void)state;
    unsigned asked = 0;
    ub_route_options_t ro = {.accept_dest = certified_only, .accept_user = &asked, .max_dests = 4};
    int e01;
    insider_t in;
    fleet_t *f = insider_fleet(&ro, &e01, &in);
    const ub_route_counters_t *c = ub_route_counters(&f->rt[0]);
    uint64_t refused0 = c->dest_refused;
    uint16_t v2_seqno = route(f, 0, 2).seqno;
    for (unsigned k = 0; k < 20; k++) insider_send(f, &in, 50 * k, 50, NULL, 0);
    assert_int_equal(fakes_known(f, 0, 1000), 0);
    assert_int_equal(c->dest_refused - refused0, 1000);
    assert_int_equal(c->neighbour_limit, 0);
    assert_true(asked >= 1000);
    /* a certified destination at a false metric 0 and a newer seqno: accepted, and it takes v2's traffic */
    for (unsigned t = 0; t < 3; t++) {
        insider_send(f, &in, 0, 0, "v2", (uint16_t)(v2_seqno + 1));
        world_run(f->w, f->w->now_ms + HELLO_MS, 1);
    }
    ub_route_info_t ri = route(f, 0, 2);
    assert_true(ri.reachable);
    assert_int_equal(ri.link_id, in.link);
    fleet_free(f);
}

/* Link-local frames: never forwarded; routing frames at a node without the engine count routing_off; any
 * other code sent link-local counts bad_payload. */
static void test_link_local_addressing(void **state) {
    (void)state;
    world_t *w = world_new();
    ub_node_t *a = world_node(w, &ub_test_cat, NULL);
    ub_node_t *b = world_node(w, &ub_test_cat, NULL);
    ub_node_t *c = world_node(w, &ub_test_cat, NULL);
    int ea = ub_node_add_entity_name(a, "a", true), eb = ub_node_add_entity_name(b, "b", true);
    int ec = ub_node_add_entity_name(c, "c", true);
    uint8_t ll[UB_ENTITY_ID_LEN];
    memset(ll, UB_LINK_LOCAL_BYTE, sizeof ll);
    assert_int_equal(ub_node_add_entity(a, ll, false), UB_ERR_INVAL); /* never an entity */
    int la = ub_node_add_link(a, ea, 0, "ab"), lb = ub_node_add_link(b, eb, 0, "ba");
    int lb2 = ub_node_add_link(b, eb, 1, "bc"), lc = ub_node_add_link(c, ec, 0, "cb");
    world_connect(w, a, la, b, lb, NULL, 1);
    world_connect(w, b, lb2, c, lc, NULL, 2);
    /* Even with a mask toward "everything", b does not forward a link-local frame. */
    uint8_t payload[UB_ROUTE_HDR_LEN] = {UB_ROUTE_WIRE_VERSION};
    ub_put_u16le(payload + 4, 100);
    ub_put_u16le(payload + 6, 400);
    assert_int_equal(ub_node_send_link_local(a, la, UB_ADMIN_HELLO, payload, sizeof payload, 0), 1);
    assert_int_equal(ub_node_send_link_local(a, la, UB_ADMIN_DATA, NULL, 0, 0), 1);
    world_run(w, 5, 1);
    assert_int_equal(ub_node_counters(b)->drops[UB_DROP_ROUTING_OFF], 1);
    assert_int_equal(ub_node_counters(b)->drops[UB_DROP_BAD_PAYLOAD], 1);
    assert_int_equal(ub_node_counters(b)->forwarded, 0);
    assert_int_equal(ub_node_link(c, lc)->counters.frames_in, 0);
    /* With an engine at b the hello is consumed there, and still not forwarded. */
    ub_route_t *rt = calloc(1, sizeof *rt);
    assert_non_null(rt);
    ub_route_options_t ro = {.hello_ms = 100};
    assert_int_equal(ub_route_attach(rt, b, &ro, 5), UB_OK);
    assert_int_equal(ub_node_send_link_local(a, la, UB_ADMIN_HELLO, payload, sizeof payload, 6), 1);
    ub_memlink_pump(&w->links[0], 6);
    ub_route_link_info_t li;
    assert_int_equal(ub_route_link_info(rt, lb, &li), UB_OK);
    assert_true(li.neighbour);
    assert_int_equal(li.stats.frames_in, 1);
    assert_int_equal(ub_node_counters(b)->forwarded, 0);
    /* A truncated routing payload is counted bad. */
    assert_int_equal(ub_node_send_link_local(a, la, UB_ADMIN_ROUTE_UPDATE, payload, 10, 7), 1);
    ub_memlink_pump(&w->links[0], 7);
    assert_int_equal(ub_node_counters(b)->drops[UB_DROP_BAD_PAYLOAD], 2);
    (void)ea;
    free(rt);
    free(w);
}

static void test_options_checked(void **state) {
    (void)state;
    world_t *w = world_new();
    ub_node_t *n = world_node(w, &ub_test_cat, NULL);
    ub_route_t *rt = calloc(1, sizeof *rt);
    assert_non_null(rt);
    ub_route_options_t bad[] = {{.hello_ms = 5}, {.hello_ms = 100, .update_ms = 50}, {.dead_misses = 17}, {.parallel = 2},
                                {.hello_ms = 70000}, {.max_dests = UB_MAX_ENTITIES + 1}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) assert_int_equal(ub_route_attach(rt, n, &bad[i], 0), UB_ERR_INVAL);
    assert_null(ub_node_service_for(n, UB_SVC_LINK_LOCAL, UB_ADMIN_HELLO));
    assert_int_equal(ub_route_attach(rt, n, NULL, 0), UB_OK);
    assert_int_equal(rt->opt.hello_ms, 1000);
    assert_int_equal(rt->opt.update_ms, 4000);
    assert_int_equal(rt->opt.max_dests, UB_ROUTE_MAX_DESTS_PER_NEIGHBOUR);
    free(rt);
    free(w);
}

/* A cut is first a gap in the neighbour's frames (its fast hellos on a link carrying our traffic): the link falls
 * in doubt and every feasible successor carries the data, long before the hello timeout (2 missed hellos,
 * ~2.5 hello intervals). */
static void test_gap_in_neighbour_frames_sends_on_every_successor(void **state) {
    (void)state;
    fleet_t *f = fleet_new(4, NULL);
    int e[4];
    int used = diamond(f, e);
    int used_link = f->edge[used].la;
    uint64_t rx0 = f->rx_count[3][0];
    fleet_cut(f, used);
    uint64_t t_cut = f->w->now_ms;
    uint64_t sent = 0;
    while (f->w->now_ms - t_cut < HELLO_MS && f->rx_count[3][0] == rx0) sent += stream_to(f, 3, f->w->now_ms + 1, 10);
    uint64_t cut_to_data = f->w->now_ms - t_cut;
    /* Back within a fraction of one hello interval (fast hello HELLO_MS / 8, doubt after 1.5 gaps). */
    assert_true(f->rx_count[3][0] > rx0);
    assert_true(cut_to_data < HELLO_MS / 2);
    assert_true(ub_route_counters(&f->rt[0])->link_doubts >= 1);
    /* In doubt, not torn down: the selected route is still the one over the cut link, with the other
     * successor in its mask. */
    ub_route_info_t ri = route(f, 0, 3);
    assert_int_equal(ri.link_id, used_link);
    assert_true(__builtin_popcount(ri.mask) == 2);
    assert_true(sent >= 1);
    /* The hello timeout confirms it later; the doubt had moved the data long before. */
    stream_to(f, 3, f->w->now_ms + 4 * HELLO_MS, 10);
    assert_true(route(f, 0, 3).link_id != used_link);
    fleet_free(f);
}

/* The grid's tie: v0 reaches v2 directly; its neighbour v1 reaches v2 directly too, at the metric v0 advertises, so
 * the feasibility condition (strictly below) refuses v1 as a successor, though its route cannot pass through v0
 * (that would cost one more link). v3 hangs off v0 and routes through it. In doubt, v1 carries the data at once;
 * v3 never does. */
static void test_doubt_uses_a_neighbour_whose_route_avoids_us(void **state) {
    (void)state;
    fleet_t *f = fleet_new(4, NULL);
    int direct = fleet_link(f, 0, 2);
    fleet_link(f, 1, 2);
    int side = fleet_link(f, 0, 1);
    int tail = fleet_link(f, 0, 3);
    fleet_start(f);
    converge(f, 10 * HELLO_MS);
    stream_to(f, 2, f->w->now_ms + 4 * HELLO_MS, 10); /* traffic: v2 sends v0 fast hellos */
    ub_route_info_t ri = route(f, 0, 2);
    assert_int_equal(ri.link_id, f->edge[direct].la);
    assert_int_equal(ri.feasible, 1); /* v1's route is not feasible: equal metric */
    uint64_t rx0 = f->rx_count[2][0];
    fleet_cut(f, direct);
    uint64_t t_cut = f->w->now_ms;
    while (f->w->now_ms - t_cut < HELLO_MS && f->rx_count[2][0] == rx0) stream_to(f, 2, f->w->now_ms + 1, 10);
    assert_true(f->rx_count[2][0] > rx0);
    assert_true(f->w->now_ms - t_cut < HELLO_MS / 2);
    ri = route(f, 0, 2);
    assert_int_equal(ri.link_id, f->edge[direct].la); /* in doubt, not torn down */
    uint8_t via_v1 = (uint8_t)(1u << ub_node_link(&f->w->nodes[0], f->edge[side].la)->index);
    uint8_t via_v3 = (uint8_t)(1u << ub_node_link(&f->w->nodes[0], f->edge[tail].la)->index);
    assert_true((ri.mask & via_v1) != 0);
    assert_true((ri.mask & via_v3) == 0);
    /* Healed before the hello timeout: one successor again, and nothing was selected but the direct link. */
    fleet_heal(f, direct);
    stream_to(f, 2, f->w->now_ms + 2 * HELLO_MS, 10);
    ri = route(f, 0, 2);
    assert_int_equal(ri.link_id, f->edge[direct].la);
    assert_int_equal(__builtin_popcount(ri.mask), 1);
    fleet_free(f);
}

/* The tie that feasibility cannot see through: v1 reaches v2 through v0 or through v3 at one metric and kept v0 (its
 * link to v3 came later: hysteresis), so to v0 its route looks like one through v0. Cut v0-v2: v0, in doubt with
 * no successor known to avoid it, hands the data to every neighbour with a route; v1 gets it from its own next hop
 * and sends it on over its other feasible successor (its bounce mask), not back. */
static void test_doubt_reaches_a_tied_neighbour_that_routes_through_us(void **state) {
    (void)state;
    fleet_t *f = fleet_new(4, NULL);
    int direct = fleet_link(f, 0, 2);
    int side = fleet_link(f, 0, 1);
    fleet_link(f, 3, 2);
    fleet_start(f);
    converge(f, 10 * HELLO_MS);
    int late = fleet_link(f, 1, 3);
    world_run(f->w, f->w->now_ms + 6 * HELLO_MS, 1);
    stream_to(f, 2, f->w->now_ms + 4 * HELLO_MS, 10);
    ub_route_info_t r1 = route(f, 1, 2);
    assert_int_equal(r1.link_id, f->edge[side].lb);     /* v1 kept v0 ... */
    assert_int_equal(r1.feasible, 2);                     /* ... though v3 is feasible for it too */
    assert_int_equal(route(f, 0, 2).feasible, 1);         /* to v0, v1's route is no successor */
    uint8_t v2[UB_ENTITY_ID_LEN];
    vid(2, v2);
    int d = ub_node_find_entity(&f->w->nodes[1], v2);
    assert_true(d >= 0);
    uint8_t bounce = f->w->nodes[1].locals[0].bounce[d]; /* v1 is the node's one local entity */
    assert_int_equal(bounce, (uint8_t)(1u << ub_node_link(&f->w->nodes[1], f->edge[late].la)->index));
    uint64_t rx0 = f->rx_count[2][0], nr0 = ub_node_counters(&f->w->nodes[1])->drops[UB_DROP_NO_ROUTE];
    fleet_cut(f, direct);
    uint64_t t_cut = f->w->now_ms;
    while (f->w->now_ms - t_cut < HELLO_MS && f->rx_count[2][0] == rx0) stream_to(f, 2, f->w->now_ms + 1, 10);
    assert_true(f->rx_count[2][0] > rx0);
    assert_true(f->w->now_ms - t_cut < HELLO_MS / 2);
    assert_int_equal(route(f, 1, 2).link_id, f->edge[side].lb); /* nothing reselected: the frames went around */
    assert_int_equal(ub_node_counters(&f->w->nodes[1])->drops[UB_DROP_NO_ROUTE], nr0);
    fleet_free(f);
}

/* The node's side of the bounce mask, without an engine: v1's mask toward v3 is its link to v0; a frame for v3
 * that v0 sends it comes back over that link and goes out over the bounce mask (to v2), unless the entry is pinned;
 * removing the link clears the bit. */
static void test_bounce_mask_takes_frames_sent_back(void **state) {
    (void)state;
    fleet_t *f = fleet_new(4, NULL);
    int ab = fleet_link(f, 0, 1), bc = fleet_link(f, 1, 2);
    uint8_t v3[UB_ENTITY_ID_LEN];
    vid(3, v3);
    ub_node_t *a = &f->w->nodes[0], *b = &f->w->nodes[1];
    int da = ub_node_add_entity(a, v3, false), db = ub_node_add_entity(b, v3, false);
    assert_true(da >= 0 && db >= 0);
    uint8_t to_a = (uint8_t)(1u << ub_node_link(b, f->edge[ab].lb)->index);
    uint8_t to_c = (uint8_t)(1u << ub_node_link(b, f->edge[bc].la)->index);
    assert_int_equal(ub_node_set_mask(a, f->self[0], da, (uint8_t)(1u << ub_node_link(a, f->edge[ab].la)->index)), UB_OK);
    assert_int_equal(ub_node_set_auto_mask(b, f->self[1], db, to_a), UB_OK);
    assert_int_equal(ub_node_set_bounce_mask(b, f->self[1], db, 0x80), UB_ERR_NOTFOUND); /* no link[7] */
    assert_int_equal(ub_node_set_bounce_mask(b, f->self[1], db, to_c), UB_OK);
    const ub_link_t *c_in = ub_node_link(&f->w->nodes[2], f->edge[bc].lb);
    uint64_t c0 = c_in->counters.frames_accepted;
    assert_true(ub_node_send_data(a, f->self[0], TEST_GPS, v3, f->w->now_ms) >= 0);
    world_run(f->w, f->w->now_ms + 5, 1);
    assert_int_equal(c_in->counters.frames_accepted, c0 + 1); /* sent back by its next hop: over the bounce mask */
    /* A pinned entry is the operator's route: nothing goes around it. */
    assert_int_equal(ub_node_set_mask(b, f->self[1], db, to_a), UB_OK);
    uint64_t nr = ub_node_counters(b)->drops[UB_DROP_NO_ROUTE];
    assert_true(ub_node_send_data(a, f->self[0], TEST_GPS, v3, f->w->now_ms) >= 0);
    world_run(f->w, f->w->now_ms + 5, 1);
    assert_int_equal(c_in->counters.frames_accepted, c0 + 1);
    assert_int_equal(ub_node_counters(b)->drops[UB_DROP_NO_ROUTE], nr + 1);
    fleet_free(f);
}

/* A brief gap (shorter than the hello timeout) costs duplicates, never the link, a route or a frame. (The
 * hellos it swallowed still count in the link's ETX as before: a route may move to an equal successor.) */
static void test_brief_gap_is_harmless(void **state) {
    (void)state;
    fleet_t *f = fleet_new(4, NULL);
    int e[4];
    int used = diamond(f, e);
    int used_link = f->edge[used].la;
    uint64_t lost0 = ub_route_counters(&f->rt[0])->routes_lost;
    uint64_t rx0 = f->rx_count[3][0];
    uint64_t doubts0 = ub_route_counters(&f->rt[0])->link_doubts;
    fleet_cut(f, used);
    uint64_t sent = 0, until = f->w->now_ms + HELLO_MS / 2; /* past the doubt, before 2 missed hellos */
    while (f->w->now_ms < until) {
        sent += stream_to(f, 3, f->w->now_ms + 1, 10);
        ub_route_link_info_t li;
        assert_int_equal(ub_route_link_info(&f->rt[0], used_link, &li), UB_OK);
        assert_true(li.cost < UB_ROUTE_INFINITY); /* in doubt, never down */
    }
    fleet_heal(f, used);
    sent += stream_to(f, 3, f->w->now_ms + 2 * HELLO_MS, 10);
    assert_true(ub_route_counters(&f->rt[0])->link_doubts > doubts0);
    assert_int_equal(ub_route_counters(&f->rt[0])->routes_lost, lost0);
    /* Every frame but those already in flight into the cut link when the doubt began arrived exactly once. */
    uint64_t got = f->rx_count[3][0] - rx0;
    assert_true(got <= sent);
    assert_true(got + 3 >= sent);
    /* And the mask is back to one successor once the neighbour is heard again. */
    assert_int_equal(__builtin_popcount(route(f, 0, 3).mask), 1);
    fleet_free(f);
}

/* Transport evidence (ub_node_link_event(), as a driver raises it on a TCP reset or a serial hang-up) takes the
 * link down at the next tick: the route moves to the other successor in a millisecond. */
static void test_link_event_down_switches_at_once(void **state) {
    (void)state;
    fleet_t *f = fleet_new(4, NULL);
    int e[4];
    int used = diamond(f, e);
    int used_link = f->edge[used].la;
    fleet_cut(f, used);
    ub_node_link_event(&f->w->nodes[0], used_link, UB_LINK_EVENT_DOWN, f->w->now_ms);
    world_run(f->w, f->w->now_ms + 1, 1);
    ub_route_info_t ri = route(f, 0, 3);
    assert_true(ri.reachable);
    assert_true(ri.link_id != used_link);
    assert_int_equal(ub_route_counters(&f->rt[0])->link_evidence_down, 1);
    /* The neighbour's next hello brings the link back (fresh history): UP is not needed for that. */
    fleet_heal(f, used);
    stream_to(f, 3, f->w->now_ms + 3 * HELLO_MS, 10);
    ub_route_link_info_t li;
    assert_int_equal(ub_route_link_info(&f->rt[0], used_link, &li), UB_OK);
    assert_true(li.cost < UB_ROUTE_INFINITY);
    fleet_free(f);
}

/* DEAD_EXPLORE=loss_ppm,hellos,dead_misses: two nodes on one link losing loss_ppm of its frames each way for that
 * many hello intervals; prints how often v0 took the link down (docs/routing.md, "Neighbours and link cost"). */
static int explore_dead(const char *env) {
    unsigned ppm = 200000, hellos = 100000, dead = 3;
    if (sscanf(env, "%u,%u,%u", &ppm, &hellos, &dead) < 1 || dead == 0 || dead > 16) return 2;
    ub_route_options_t ro = {.hello_ms = HELLO_MS, .dead_misses = (uint8_t)dead};
    fleet_t *f = fleet_new(2, &ro);
    int e = fleet_link(f, 0, 1);
    fleet_start(f);
    converge(f, 10 * HELLO_MS);
    ub_memlink_faults_t lossy = {.loss_ppm = ppm};
    ub_memlink_set_faults(&f->w->links[e], &lossy);
    uint64_t downs = 0, end = f->w->now_ms + (uint64_t)hellos * HELLO_MS;
    bool was_down = false;
    while (f->w->now_ms < end) {
        world_run(f->w, f->w->now_ms + 10, 1);
        ub_route_link_info_t li;
        if (ub_route_link_info(&f->rt[0], f->edge[e].la, &li) != UB_OK) return 1;
        bool down = li.rxcost == UB_ROUTE_INFINITY;
        if (down && !was_down) downs++;
        was_down = down;
    }
    fprintf(stderr, "loss_ppm=%u hellos=%u dead_misses=%u: %llu link downs (one per %.0f hellos)\n", ppm, hellos, dead,
            (unsigned long long)downs, downs ? (double)hellos / (double)downs : 0.0);
    fleet_free(f);
    return 0;
}

int main(void) {
    const char *env = getenv("DEAD_EXPLORE");
    if (env != NULL) return explore_dead(env);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_line_converges_and_learns),
        cmocka_unit_test(test_steady_state_one_frame_per_link_per_hello),
        cmocka_unit_test(test_no_frame_crosses_a_link_twice_while_reconverging),
        cmocka_unit_test(test_parallel_links),
        cmocka_unit_test(test_silent_neighbour_expires),
        cmocka_unit_test(test_a_lossy_link_needs_a_longer_run_of_misses),
        cmocka_unit_test(test_a_lossy_link_comes_back_at_its_old_cost),
        cmocka_unit_test(test_a_metric_rise_on_the_only_route_is_held_not_starved),
        cmocka_unit_test(test_partition_and_repair),
        cmocka_unit_test(test_starvation_is_resolved_by_a_seqno_request),
        cmocka_unit_test(test_starving_neighbours_request_goes_on_at_once),
        cmocka_unit_test(test_restarted_node_is_reachable_again),
        cmocka_unit_test(test_manual_mask_pins_a_route),
        cmocka_unit_test(test_removed_entity_is_not_relearned_at_once),
        cmocka_unit_test(test_learned_entities_expire_when_nobody_advertises_them),
        cmocka_unit_test(test_insider_destinations_are_bounded_per_neighbour),
        cmocka_unit_test(test_insider_uncertified_destinations_are_refused),
        cmocka_unit_test(test_link_local_addressing),
        cmocka_unit_test(test_options_checked),
        cmocka_unit_test(test_gap_in_neighbour_frames_sends_on_every_successor),
        cmocka_unit_test(test_doubt_uses_a_neighbour_whose_route_avoids_us),
        cmocka_unit_test(test_doubt_reaches_a_tied_neighbour_that_routes_through_us),
        cmocka_unit_test(test_bounce_mask_takes_frames_sent_back),
        cmocka_unit_test(test_brief_gap_is_harmless),
        cmocka_unit_test(test_link_event_down_switches_at_once),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
