/*
 * Slow nodes (docs/routing.md, "Slow nodes"): a fleet shaped like examples/scenarios/fleet6.yaml on memlinks and a
 * simulated clock, where nodes are serviced late -- a node that stalls neither ticks nor reads its links until
 * the stall ends, then reads what queued up and ticks, as a loaded process (or a slow board) does. Stalls are
 * drawn from a seeded generator, so every run is the same. In steady state such lateness must not set off
 * seqno requests, seqno bumps or triggered updates; a real cut must still be detected as fast as on a fleet of
 * punctual nodes.
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

#define N 8          /* gcs (v0) and seven vehicles, as fleet6 */
#define HELLO_MS 200u
#define FLOW_MS 100u

/* One direction of a link: frames wait here until their receiver is awake (a socket buffer). Loss and a 2 ms
 * delay as fleet6's radio; the draws come from the fleet's seeded generator. */
#define INBOX_DEPTH 128
#define LINK_DELAY_MS 2u
struct slow_fleet;
typedef struct inbox {
    struct slow_fleet *f;
    int to, to_link;
    uint32_t loss_ppm;
    size_t head, n;
    uint64_t due[INBOX_DEPTH];
    size_t len[INBOX_DEPTH];
    uint8_t bytes[INBOX_DEPTH][UB_FRAME_MAX];
} inbox_t;

typedef struct slow_fleet {
    world_t *w;
    ub_route_t rt[N];
    int self[N];
    unsigned next_index[N];
    struct test_gps gps[N];
    size_t n_edges;
    int ea[WORLD_MAX_LINKS], eb[WORLD_MAX_LINKS], la[WORLD_MAX_LINKS], lb[WORLD_MAX_LINKS];
    inbox_t box[WORLD_MAX_LINKS][2]; /* [edge][0]: toward eb, [1]: toward ea */
    uint64_t awake_at[N]; /* a stalled node is serviced again at this time */
    uint64_t rng;
    uint32_t stall_ppm;   /* chance per service that a stall follows */
    uint32_t stall_max_ms; /* a stall lasts 1..stall_max_ms */
    uint64_t stalls;
} slow_fleet_t;

static void vid(int i, uint8_t id[UB_ENTITY_ID_LEN]) {
    char name[16];
    snprintf(name, sizeof name, "v%d", i);
    test_eid(name, id);
}

static uint64_t rnd(slow_fleet_t *f) { /* xorshift64*: a seeded, reproducible draw */
    f->rng ^= f->rng >> 12;
    f->rng ^= f->rng << 25;
    f->rng ^= f->rng >> 27;
    return f->rng * 0x2545F4914F6CDD1Dull;
}

static int inbox_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    inbox_t *box = impl;
    if (rnd(box->f) % 1000000u < box->loss_ppm) return UB_OK; /* the radio ate it */
    if (box->n == INBOX_DEPTH) return UB_ERR_AGAIN;
    size_t i = (box->head + box->n++) % INBOX_DEPTH;
    memcpy(box->bytes[i], frame, len);
    box->len[i] = len;
    box->due[i] = now_ms + LINK_DELAY_MS;
    return UB_OK;
}

static const ub_link_ops_t inbox_ops = {.kind = "inbox", .send = inbox_send, .fileno = NULL};

static int slow_link(slow_fleet_t *f, int a, int b, uint32_t loss_ppm) {
    char na[32], nb[32];
    snprintf(na, sizeof na, "l%zu", f->n_edges);
    snprintf(nb, sizeof nb, "l%zu", f->n_edges);
    int la = ub_node_add_link(&f->w->nodes[a], f->self[a], f->next_index[a]++, na);
    int lb = ub_node_add_link(&f->w->nodes[b], f->self[b], f->next_index[b]++, nb);
    assert_true(la >= 0 && lb >= 0);
    int e = (int)f->n_edges++;
    f->box[e][0] = (inbox_t){.f = f, .to = b, .to_link = lb, .loss_ppm = loss_ppm};
    f->box[e][1] = (inbox_t){.f = f, .to = a, .to_link = la, .loss_ppm = loss_ppm};
    assert_int_equal(ub_node_link_attach(&f->w->nodes[a], la, &inbox_ops, &f->box[e][0]), UB_OK);
    assert_int_equal(ub_node_link_attach(&f->w->nodes[b], lb, &inbox_ops, &f->box[e][1]), UB_OK);
    f->ea[e] = a;
    f->eb[e] = b;
    f->la[e] = la;
    f->lb[e] = lb;
    return e;
}

/* fleet6's graph (uav<i> is v<i>, gcs1 is v0), 2 % loss on every link, 20 % on the lossy detour v7-v2. */
static slow_fleet_t *slow_fleet_new(uint8_t dead_misses, uint64_t seed, uint32_t loss_ppm, uint32_t lossy_ppm) {
    slow_fleet_t *f = calloc(1, sizeof *f);
    assert_non_null(f);
    f->w = world_new();
    f->rng = 0x9E3779B97F4A7C15ull ^ (seed * 0x2545F4914F6CDD1Dull);
    for (int i = 0; i < N; i++) {
        ub_node_options_t opt = {.random_seed = 500u + (uint64_t)i};
        ub_node_t *node = world_node(f->w, &ub_test_cat, &opt);
        char name[16];
        snprintf(name, sizeof name, "v%d", i);
        f->self[i] = ub_node_add_entity_name(node, name, true);
        assert_true(f->self[i] >= 0);
        assert_int_equal(ub_node_bind(node, TEST_GPS, &f->gps[i]), UB_OK);
    }
    static const int g[][2] = {{0, 1}, {0, 6}, {0, 7}, {1, 2}, {1, 4}, {2, 3}, {4, 3}, {3, 5}, {1, 6}};
    for (size_t k = 0; k < sizeof g / sizeof g[0]; k++) slow_link(f, g[k][0], g[k][1], loss_ppm);
    slow_link(f, 7, 2, lossy_ppm);
    ub_route_options_t ro = {.hello_ms = HELLO_MS, .dead_misses = dead_misses, .parallel = UB_ROUTE_PARALLEL_ALL};
    for (int i = 0; i < N; i++) assert_int_equal(ub_route_attach(&f->rt[i], &f->w->nodes[i], &ro, 0), UB_OK);
    return f;
}

static void slow_fleet_free(slow_fleet_t *f) {
    free(f->w);
    free(f);
}

static bool awake(const slow_fleet_t *f, int k) { return f->w->now_ms >= f->awake_at[k]; }

/* Hands every awake node the frames due for it (a node relaying one queues it for the next step at the earliest:
 * the delay is 2 ms). */
static void deliver(slow_fleet_t *f) {
    for (size_t e = 0; e < f->n_edges; e++) {
        for (int d = 0; d < 2; d++) {
            inbox_t *box = &f->box[e][d];
            while (box->n > 0 && awake(f, box->to) && box->due[box->head] <= f->w->now_ms) {
                int rc = ub_node_rx_frame(&f->w->nodes[box->to], box->to_link, box->bytes[box->head], box->len[box->head],
                                          f->w->now_ms);
                (void)rc; /* duplicates and the like are the node's to count */
                box->head = (box->head + 1) % INBOX_DEPTH;
                box->n--;
            }
        }
    }
}

/* One millisecond: the flows of fleet6 (to v0 from v3, v5, v6, v7; v5 to v2), every awake node ticks (a node
 * woken from a stall first reads what queued up for it, as ub_app_run() services its ports before the tick), and
 * a node may stall for the next 1..stall_max_ms. A memlink moves frames only while both of its ends are awake. */
static void slow_step(slow_fleet_t *f) {
    world_t *w = f->w;
    w->now_ms++;
    static const int flows[][2] = {{3, 0}, {5, 0}, {6, 0}, {5, 2}, {7, 0}};
    for (int k = 0; k < N; k++) {
        if (!awake(f, k)) continue;
        for (size_t i = 0; i < sizeof flows / sizeof flows[0]; i++) {
            if (flows[i][0] != k || w->now_ms % FLOW_MS != (uint64_t)(7 * i) % FLOW_MS) continue;
            uint8_t id[UB_ENTITY_ID_LEN];
            vid(flows[i][1], id);
            if (ub_node_find_entity(&w->nodes[k], id) < 0) continue;
            int rc = ub_node_send_data(&w->nodes[k], f->self[k], TEST_GPS, id, w->now_ms);
            assert_true(rc >= 0 || rc == UB_ERR_NOROUTE);
        }
    }
    deliver(f);
    for (int k = 0; k < N; k++) {
        if (!awake(f, k)) continue;
        ub_node_tick(&w->nodes[k], w->now_ms);
        if (f->stall_ppm != 0 && rnd(f) % 1000000u < f->stall_ppm) {
            f->awake_at[k] = w->now_ms + 1u + rnd(f) % f->stall_max_ms;
            f->stalls++;
        }
    }
}

static void slow_run(slow_fleet_t *f, uint64_t ms) {
    uint64_t until = f->w->now_ms + ms;
    while (f->w->now_ms < until) slow_step(f);
}

/* Totals over the fleet. */
typedef struct totals {
    uint64_t requests, bumps, triggered, frames, lost, doubts, expired, changes;
    uint64_t lost_down, lost_gone, lost_retr, lost_unf, o_change, o_asked, o_answer, deferred;
} totals_t;

static totals_t totals(const slow_fleet_t *f) {
    totals_t t = {0};
    for (int k = 0; k < N; k++) {
        const ub_route_counters_t *c = ub_route_counters(&f->rt[k]);
        t.requests += c->starvation_requests;
        t.bumps += c->seqno_bumps;
        t.lost += c->routes_lost;
        t.doubts += c->link_doubts;
        t.expired += c->expired;
        t.changes += c->route_changes;
        t.lost_down += c->lost_link_down;
        t.lost_gone += c->lost_entry_gone;
        t.lost_retr += c->lost_retracted;
        t.lost_unf += c->lost_unfeasible;
        t.o_change += c->owed_route_change;
        t.o_asked += c->owed_seqno_asked;
        t.o_answer += c->owed_request_answer;
        t.deferred += c->seqno_deferred;
    }
    for (size_t e = 0; e < f->n_edges; e++) {
        ub_route_link_info_t li;
        assert_int_equal(ub_route_link_info(&f->rt[f->ea[e]], f->la[e], &li), UB_OK);
        t.triggered += li.stats.triggered_out;
        t.frames += li.stats.frames_out - li.stats.fast_hellos_out;
        assert_int_equal(ub_route_link_info(&f->rt[f->eb[e]], f->lb[e], &li), UB_OK);
        t.triggered += li.stats.triggered_out;
        t.frames += li.stats.frames_out - li.stats.fast_hellos_out;
    }
    return t;
}

static void print_totals(const char *what, const totals_t *a, const totals_t *b, uint64_t stalls) {
    fprintf(stderr,
            "%s: stalls=%llu requests=%llu bumps=%llu triggered=%llu frames=%llu lost=%llu doubts=%llu expired=%llu "
            "changes=%llu\n",
            what, (unsigned long long)stalls, (unsigned long long)(b->requests - a->requests),
            (unsigned long long)(b->bumps - a->bumps), (unsigned long long)(b->triggered - a->triggered),
            (unsigned long long)(b->frames - a->frames), (unsigned long long)(b->lost - a->lost),
            (unsigned long long)(b->doubts - a->doubts), (unsigned long long)(b->expired - a->expired),
            (unsigned long long)(b->changes - a->changes));
    fprintf(stderr, "  lost: down=%llu gone=%llu retracted=%llu unfeasible=%llu; owed: change=%llu asked=%llu answer=%llu deferred=%llu\n",
            (unsigned long long)(b->lost_down - a->lost_down), (unsigned long long)(b->lost_gone - a->lost_gone),
            (unsigned long long)(b->lost_retr - a->lost_retr), (unsigned long long)(b->lost_unf - a->lost_unf),
            (unsigned long long)(b->o_change - a->o_change), (unsigned long long)(b->o_asked - a->o_asked),
            (unsigned long long)(b->o_answer - a->o_answer), (unsigned long long)(b->deferred - a->deferred));
}

/* Node a's route toward v<b>. */
static ub_route_info_t route_to(slow_fleet_t *f, int a, int b) {
    uint8_t id[UB_ENTITY_ID_LEN];
    vid(b, id);
    int dest = ub_node_find_entity(&f->w->nodes[a], id);
    assert_true(dest >= 0);
    ub_route_info_t ri;
    assert_int_equal(ub_route_get(&f->rt[a], f->self[a], dest, &ri), UB_OK);
    return ri;
}

static bool all_reach(slow_fleet_t *f) {
    for (int a = 0; a < N; a++)
        for (int b = 0; b < N; b++) {
            uint8_t id[UB_ENTITY_ID_LEN];
            vid(b, id);
            if (a != b && (ub_node_find_entity(&f->w->nodes[a], id) < 0 || !route_to(f, a, b).reachable)) return false;
        }
    return true;
}

/* Runs until every node reaches every other one, then lets the start-up's triggered updates die out. */
static void settle(slow_fleet_t *f) {
    while (!all_reach(f)) {
        assert_true(f->w->now_ms < 20u * HELLO_MS);
        slow_step(f);
    }
    slow_run(f, 40u * HELLO_MS);
}

/* Link-level figures of one run: expected hellos that some node counted missed (later taken back or not). */
static uint64_t misses_now(const slow_fleet_t *f) {
    uint64_t n = 0;
    for (size_t e = 0; e < f->n_edges; e++) {
        ub_route_link_info_t li;
        assert_int_equal(ub_route_link_info(&f->rt[f->ea[e]], f->la[e], &li), UB_OK);
        n += li.samples - (uint64_t)__builtin_popcount(li.history);
        assert_int_equal(ub_route_link_info(&f->rt[f->eb[e]], f->lb[e], &li), UB_OK);
        n += li.samples - (uint64_t)__builtin_popcount(li.history);
    }
    return n;
}

/* Runs `ms` with stalls of 1..max_ms (stall_ppm per service) on every node; returns the counter deltas and, in
 * *late, how often a link's history showed a hello counted missed (sampled every 10 ms). */
static totals_t stalled_run(slow_fleet_t *f, uint32_t ppm, uint32_t max_ms, uint64_t ms, uint64_t *late) {
    totals_t a = totals(f);
    f->stall_ppm = ppm;
    f->stall_max_ms = max_ms;
    uint64_t until = f->w->now_ms + ms;
    *late = 0;
    while (f->w->now_ms < until) {
        slow_step(f);
        if (f->w->now_ms % 10u == 0) *late += misses_now(f) != 0;
    }
    f->stall_ppm = 0;
    totals_t b = totals(f);
    totals_t d = {b.requests - a.requests, b.bumps - a.bumps, b.triggered - a.triggered, b.frames - a.frames,
                  b.lost - a.lost, b.doubts - a.doubts, b.expired - a.expired, b.changes - a.changes,
                  b.lost_down - a.lost_down, b.lost_gone - a.lost_gone, b.lost_retr - a.lost_retr,
                  b.lost_unf - a.lost_unf, b.o_change - a.o_change, b.o_asked - a.o_asked, b.o_answer - a.o_answer,
                  b.deferred - a.deferred};
    return d;
}

/*
 * A node serviced late is not a failed node. On a loss-free fleet a neighbour's k-th missed hello is counted
 * 1.5 + (k - 1) hello intervals after the last one heard, and a node stalled for d ms sends its next hello at
 * most one interval + d after its last (plus the link's 2 ms), so stalls shorter than (dead_misses - 0.5) hello
 * intervals - 2 ms (498 ms here, dead_misses 3; 298 ms with 2) can have hellos counted missed but never take a
 * link down: the late hello takes the misses back. Every node stalls five times a second for up to 450 ms
 * (250 ms) for a minute: no link goes down, no route is lost, nobody starves or asks for a seqno, and no
 * triggered frame goes out -- while the stalls did make neighbours count hellos missed.
 */
static void slow_nodes_alone(uint8_t dead_misses, uint32_t max_ms) {
    slow_fleet_t *f = slow_fleet_new(dead_misses, 7, 0, 0);
    settle(f);
    uint64_t late = 0;
    totals_t d = stalled_run(f, 5000u, max_ms, 60000u, &late);
    print_totals("stalled, no loss", &(totals_t){0}, &d, f->stalls);
    assert_true(f->stalls > 1000u);
    assert_true(late > 0); /* the stalls were long enough to be seen */
    assert_int_equal(d.lost, 0);
    assert_int_equal(d.requests, 0);
    assert_int_equal(d.bumps, 0);
    assert_int_equal(d.triggered, 0);
    assert_true(all_reach(f));
    slow_fleet_free(f);
}

static void test_slow_nodes_never_take_a_link_down(void **state) {
    (void)state;
    slow_nodes_alone(3, 450u);
    slow_nodes_alone(2, 250u);
}

/* The other side of the bound: a node silent for longer than the hello timeout allows is taken down, stalled or
 * not (failure detection does not wait for slow nodes). Stalls up to 700 ms on the same fleet lose links. */
static void test_a_stall_past_the_hello_timeout_is_a_failure(void **state) {
    (void)state;
    slow_fleet_t *f = slow_fleet_new(3, 7, 0, 0);
    settle(f);
    uint64_t late = 0;
    totals_t d = stalled_run(f, 5000u, 700u, 60000u, &late);
    print_totals("stalled up to 700 ms", &(totals_t){0}, &d, f->stalls);
    assert_true(d.lost_down > 0);
    /* Every loss is counted with its cause, and every request received with what became of it. */
    assert_int_equal(d.lost, d.lost_down + d.lost_gone + d.lost_retr + d.lost_unf);
    uint64_t in = 0, outcomes = 0;
    for (int k = 0; k < N; k++) {
        const ub_route_counters_t *c = ub_route_counters(&f->rt[k]);
        outcomes += c->requests_forwarded + c->requests_answered + c->requests_dropped + c->requests_suppressed;
        for (size_t e = 0; e < f->n_edges; e++) {
            ub_route_link_info_t li;
            int lid = f->ea[e] == k ? f->la[e] : f->eb[e] == k ? f->lb[e] : -1;
            if (lid < 0) continue;
            assert_int_equal(ub_route_link_info(&f->rt[k], lid, &li), UB_OK);
            in += li.stats.requests_in;
        }
    }
    assert_true(in > 0);
    assert_int_equal(in, outcomes);
    slow_run(f, 20u * HELLO_MS);
    assert_true(all_reach(f)); /* and the fleet is whole again once nobody stalls */
    slow_fleet_free(f);
}

/*
 * A new seqno is not echoed (RFC 8966 3.7.2): fleet6's lossy detour v7-v2 is cut. v2 starves for v7 (its other
 * way, through v1, advertises a metric above v2's feasibility distance), asks, and v7 raises its seqno; v7
 * starves for v2, v3 and v5 in turn and their sources raise theirs. The answers travel back to the requesters as
 * triggered entries, and v2 reaches v7 again within a few hello intervals. v6, which asked for nothing and whose
 * routes did not change, gets no triggered frame from either neighbour: it hears the new seqnos on their next
 * regular frames, within a hello interval of each bump. Triggering every seqno change echoed each request over
 * every link of the fleet.
 */
static void test_a_new_seqno_is_not_echoed(void **state) {
    (void)state;
    slow_fleet_t *f = slow_fleet_new(3, 7, 0, 0);
    settle(f);
    int to_v6[2] = {1, 8}; /* edges v0-v6 and v1-v6: v6 is their b end */
    uint64_t trig0[2], bumps0 = ub_route_counters(&f->rt[7])->seqno_bumps;
    for (int k = 0; k < 2; k++) {
        ub_route_link_info_t li;
        assert_int_equal(f->eb[to_v6[k]], 6);
        assert_int_equal(ub_route_link_info(&f->rt[f->ea[to_v6[k]]], f->la[to_v6[k]], &li), UB_OK);
        trig0[k] = li.stats.triggered_out;
    }
    assert_int_equal(f->ea[9], 7);
    assert_int_equal(f->eb[9], 2);
    uint16_t fd_before = route_to(f, 2, 7).fd_seqno;
    f->box[9][0].loss_ppm = f->box[9][1].loss_ppm = 1000000u; /* the cut */
    uint64_t cut = f->w->now_ms, bumped = 0;
    while (f->w->now_ms < cut + 10u * HELLO_MS) {
        slow_step(f);
        if (bumped == 0 && ub_route_counters(&f->rt[7])->seqno_bumps > bumps0) bumped = f->w->now_ms;
        if (bumped != 0 && route_to(f, 2, 7).reachable) break;
    }
    assert_true(bumped != 0); /* v2 starved, asked, and v7 raised its seqno */
    ub_route_info_t back = route_to(f, 2, 7);
    assert_true(back.reachable);
    assert_true(back.seqno != fd_before);
    assert_true(f->w->now_ms < cut + 4u * HELLO_MS); /* hello timeout (2.5 intervals) and the request's round trip */
    /* v6 hears v7's new seqno on a regular frame, within one hello interval of the bump (+ the link's delay). */
    while (route_to(f, 6, 7).seqno != ub_route_seqno(&f->rt[7], f->self[7])) {
        assert_true(f->w->now_ms <= bumped + HELLO_MS + 2u * LINK_DELAY_MS);
        slow_step(f);
    }
    slow_run(f, 10u * HELLO_MS); /* the other sources' bumps (v2, v3, v5) */
    for (int k = 0; k < 2; k++) {
        ub_route_link_info_t li;
        assert_int_equal(ub_route_link_info(&f->rt[f->ea[to_v6[k]]], f->la[to_v6[k]], &li), UB_OK);
        assert_int_equal(li.stats.triggered_out, trig0[k]);
    }
    assert_true(ub_route_counters(&f->rt[0])->seqno_deferred > 0);
    for (int b = 1; b < N; b++) /* v6 is up to date with every source */
        if (b != 6) assert_int_equal(route_to(f, 6, b).seqno, ub_route_seqno(&f->rt[b], f->self[b]));
    slow_fleet_free(f);
}

/* SLOW_EXPLORE=dead,stall_ppm,stall_max_ms,seed,loss_ppm,lossy_ppm: one minute of that fleet's counters on stderr
 * (the figures of docs/routing.md, "Slow nodes"), instead of the tests. */
static int explore(const char *env) {
    unsigned dead = 3, ppm = 2000, max_ms = 300, seed = 1, loss = 20000, lossy = 200000;
    if (sscanf(env, "%u,%u,%u,%u,%u,%u", &dead, &ppm, &max_ms, &seed, &loss, &lossy) < 1 || max_ms == 0) return 2;
    slow_fleet_t *f = slow_fleet_new((uint8_t)dead, seed, loss, lossy);
    slow_run(f, 10000);
    uint64_t late = 0;
    totals_t d = stalled_run(f, ppm, max_ms, 60000u, &late);
    char what[128];
    snprintf(what, sizeof what, "dead=%u ppm=%u max=%u seed=%u loss=%u lossy=%u", dead, ppm, max_ms, seed, loss, lossy);
    print_totals(what, &(totals_t){0}, &d, f->stalls);
    slow_fleet_free(f);
    return 0;
}

int main(void) {
    const char *env = getenv("SLOW_EXPLORE");
    if (env != NULL) return explore(env);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_slow_nodes_never_take_a_link_down),
        cmocka_unit_test(test_a_stall_past_the_hello_timeout_is_a_failure),
        cmocka_unit_test(test_a_new_seqno_is_not_echoed),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
