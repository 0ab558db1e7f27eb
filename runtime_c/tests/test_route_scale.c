/*
 * The routing service's bookkeeping for cost at scale (docs/routing.md, "Cost at scale"):
 *  - ub_timeheap.h against a brute-force model under random operations (min, get, the due list in item order);
 *  - on a routing fleet that converges, loses a link, starves and learns and forgets entities, after every
 *    step each node's heap holds exactly the earliest of the route table's documented timers (stated here in the
 *    test's own terms, each interval checked when the table records its moment), the per-link owed counts match
 *    the destinations' dirty/request/lazy bits and the per-link route-entry counts match the route table;
 *  - the node's entity index (ID -> row) against a scan of the entity table under random adds and removes.
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
#include "ub/ub_timeheap.h"

/* ---- the heap against a model ------------------------------------------------------------------------ */

static uint64_t g_rng = 0x243F6A8885A308D3ull;
static uint64_t rnd(void) {
    g_rng ^= g_rng << 13;
    g_rng ^= g_rng >> 7;
    g_rng ^= g_rng << 17;
    return g_rng;
}

static void check_heap(const ub_timeheap_t *h, const uint64_t *model) {
    uint64_t min = UB_TIMEHEAP_NONE;
    unsigned n = 0;
    for (unsigned i = 0; i < UB_TIMEHEAP_CAP; i++) {
        assert_true(ub_timeheap_get(h, i) == model[i]);
        if (model[i] != UB_TIMEHEAP_NONE) n++;
        if (model[i] < min) min = model[i];
    }
    assert_int_equal(h->n, n);
    assert_true(ub_timeheap_min(h) == min);
    for (unsigned k = 1; k < h->n; k++) assert_true(h->due[h->at[(k - 1) / 2]] <= h->due[h->at[k]]); /* heap order */
    for (unsigned k = 0; k < h->n; k++) assert_int_equal(h->pos[h->at[k]], k + 1);
    /* the due list: every item <= now, ascending, for a few `now`s including none and all */
    uint64_t nows[] = {0, min, min + 7, 50, 500, UB_TIMEHEAP_NONE - 1};
    for (size_t t = 0; t < sizeof nows / sizeof nows[0]; t++) {
        uint16_t out[UB_TIMEHEAP_CAP];
        size_t got = ub_timeheap_due(h, nows[t], out, UB_TIMEHEAP_CAP), want = 0;
        for (unsigned i = 0; i < UB_TIMEHEAP_CAP; i++) {
            if (model[i] == UB_TIMEHEAP_NONE || model[i] > nows[t]) continue; /* absent items are never due */
            assert_true(want < got);
            assert_int_equal(out[want], i);
            want++;
        }
        assert_int_equal(got, want);
    }
}

static void test_timeheap_matches_a_model(void **state) {
    (void)state;
    static ub_timeheap_t h;
    uint64_t model[UB_TIMEHEAP_CAP];
    ub_timeheap_init(&h);
    for (unsigned i = 0; i < UB_TIMEHEAP_CAP; i++) model[i] = UB_TIMEHEAP_NONE;
    check_heap(&h, model);
    for (int step = 0; step < 20000; step++) {
        unsigned item = (unsigned)(rnd() % UB_TIMEHEAP_CAP);
        uint64_t r = rnd() % 16, due;
        if (r < 3) due = UB_TIMEHEAP_NONE;          /* removal (of a present or an absent item) */
        else if (r < 5) due = model[item];          /* unchanged */
        else if (r < 7) due = rnd() % 4;            /* ties */
        else due = rnd() % 1000;
        ub_timeheap_set(&h, item, due);
        model[item] = due;
        if (step % 7 == 0) check_heap(&h, model);
    }
    check_heap(&h, model);
    /* out of range: ignored */
    ub_timeheap_set(&h, UB_TIMEHEAP_CAP, 1);
    assert_true(ub_timeheap_get(&h, UB_TIMEHEAP_CAP) == UB_TIMEHEAP_NONE);
    check_heap(&h, model);
}

static void test_timeheap_due_respects_cap(void **state) {
    (void)state;
    static ub_timeheap_t h;
    ub_timeheap_init(&h);
    for (unsigned i = 0; i < UB_TIMEHEAP_CAP; i++) ub_timeheap_set(&h, i, 10u + i % 3u);
    uint16_t out[UB_TIMEHEAP_CAP];
    assert_int_equal(ub_timeheap_due(&h, 9, out, UB_TIMEHEAP_CAP), 0);
    assert_int_equal(ub_timeheap_due(&h, 12, out, 3), 3);
    for (int k = 0; k < 3; k++) assert_true(h.due[out[k]] <= 12);
    assert_true(out[0] < out[1] && out[1] < out[2]);
    assert_int_equal(ub_timeheap_due(&h, 12, out, UB_TIMEHEAP_CAP), UB_TIMEHEAP_CAP);
    for (unsigned i = 0; i < UB_TIMEHEAP_CAP; i++) ub_timeheap_set(&h, i, UB_TIMEHEAP_NONE);
    assert_int_equal(h.n, 0);
    assert_true(ub_timeheap_min(&h) == UB_TIMEHEAP_NONE);
    assert_int_equal(ub_timeheap_due(&h, UB_TIMEHEAP_NONE - 1, out, UB_TIMEHEAP_CAP), 0);
}

/* ---- the routing service's bookkeeping against a scan of its tables ----------------------------------- */

#define HELLO_MS 100u

/*
 * The oracle: the route table's timers as docs/routing.md ("Updates and timers", "Learning", "Starvation") states
 * them, each armed by what the table records and due at the moment it records plus the documented interval:
 *
 *   learned entity      removed learn_expiry_ms after the last update that advertised a route to it
 *   route entry         expires 3.5 neighbour update intervals after the update that refreshed it
 *   retraction          advertised for 2 update intervals after the route was lost, then dropped
 *   starvation          a new seqno request one hello interval after the last one, while starving
 *   feasibility dist.   forgotten source_gc_ms after it was last advertised, while unreachable and not retracting
 *
 * The moments are read from the table, but the intervals are the test's own: watch() checks each moment when the
 * table records it (a refresh at t must expire at t + 3.5 x the neighbour's update interval, a loss at t must end its
 * retraction at t + 2 x update_ms, ...), so a wrong interval or a timer the engine forgot to arm fails here instead
 * of being copied into the oracle.
 */
typedef struct shadow {
    uint64_t expires[UB_MAX_ENTITIES][UB_MAX_NODE_LINKS];
    uint8_t retracting[UB_MAX_LOCAL_ENTITIES][UB_MAX_ENTITIES];
    uint64_t starve_at[UB_MAX_LOCAL_ENTITIES][UB_MAX_ENTITIES];
    uint64_t fd_touched[UB_MAX_LOCAL_ENTITIES][UB_MAX_ENTITIES];
    uint64_t advertised[UB_MAX_ENTITIES];
} shadow_t;

static void earliest(uint64_t *best, uint64_t t) {
    if (t < *best) *best = t;
}

static uint64_t documented_deadline(const ub_route_t *rt, int e) {
    const ub_route_options_t *o = &rt->opt;
    uint64_t due = UB_TIMEHEAP_NONE;
    if (rt->learned[e]) earliest(&due, rt->advertised_ms[e] + o->learn_expiry_ms);
    for (int lid = 0; lid < UB_MAX_NODE_LINKS; lid++)
        if (rt->routes[e][lid].in_use) earliest(&due, rt->routes[e][lid].expires_ms);
    for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++) {
        const ub_route_dest_t *ds = &rt->dests[s][e];
        bool reachable = ds->sel_link >= 0, starving = ds->starve_at_ms != 0;
        if (ds->retracting) earliest(&due, ds->retract_until_ms);
        if (starving) earliest(&due, ds->starve_at_ms + o->hello_ms);
        if (ds->fd_valid && !reachable && !ds->retracting) earliest(&due, ds->fd_touched_ms + o->source_gc_ms);
    }
    return due;
}

/* After a step to `now`: every moment the table recorded in this step carries the documented interval. */
static void watch(const ub_route_t *rt, shadow_t *sh, uint64_t now) {
    const ub_route_options_t *o = &rt->opt;
    for (int e = 0; e < UB_MAX_ENTITIES; e++) {
        for (int lid = 0; lid < UB_MAX_NODE_LINKS; lid++) {
            const ub_route_entry_t *r = &rt->routes[e][lid];
            uint64_t was = sh->expires[e][lid];
            sh->expires[e][lid] = r->in_use ? r->expires_ms : 0;
            if (r->in_use && r->expires_ms != was) /* refreshed now: 3.5 of the neighbour's update intervals */
                assert_true(r->expires_ms == now + rt->links[lid].nb_update_ms * 7u / 2u);
        }
        if (rt->learned[e] && rt->advertised_ms[e] != sh->advertised[e]) assert_true(rt->advertised_ms[e] == now);
        sh->advertised[e] = rt->advertised_ms[e];
        for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++) {
            const ub_route_dest_t *ds = &rt->dests[s][e];
            if (ds->retracting && !sh->retracting[s][e]) assert_true(ds->retract_until_ms == now + 2u * o->update_ms);
            sh->retracting[s][e] = ds->retracting;
            if (ds->starve_at_ms != 0 && ds->starve_at_ms != sh->starve_at[s][e]) assert_true(ds->starve_at_ms == now);
            sh->starve_at[s][e] = ds->starve_at_ms;
            if (ds->fd_valid && ds->fd_touched_ms != sh->fd_touched[s][e]) assert_true(ds->fd_touched_ms == now);
            sh->fd_touched[s][e] = ds->fd_touched_ms;
        }
    }
}

static void check_bookkeeping(const ub_route_t *rt) {
    for (int e = 0; e < UB_MAX_ENTITIES; e++) assert_true(ub_timeheap_get(&rt->timers, (unsigned)e) == documented_deadline(rt, e));
    for (int lid = 0; lid < UB_MAX_NODE_LINKS; lid++) {
        unsigned in_use = 0;
        for (int e = 0; e < UB_MAX_ENTITIES; e++) in_use += rt->routes[e][lid].in_use != 0;
        assert_int_equal(rt->link_routes[lid], in_use);
    }
    for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++)
        for (unsigned i = 0; i < UB_MAX_LINKS_PER_ENTITY; i++) {
            unsigned dirty = 0, req = 0, lazy = 0;
            for (int e = 0; e < UB_MAX_ENTITIES; e++) {
                dirty += (rt->dests[s][e].dirty_links >> i) & 1u;
                req += (rt->dests[s][e].req_links >> i) & 1u;
                lazy += (rt->dests[s][e].lazy_links >> i) & 1u;
            }
            assert_int_equal(rt->owed_dirty[s][i], dirty);
            assert_int_equal(rt->owed_req[s][i], req);
            assert_int_equal(rt->owed_lazy[s][i], lazy);
        }
}

typedef struct fleet {
    world_t *w;
    ub_route_t rt[WORLD_MAX_NODES];
    int self[WORLD_MAX_NODES];
    unsigned next_index[WORLD_MAX_NODES];
    int link_a[WORLD_MAX_LINKS];
    shadow_t shadow[WORLD_MAX_NODES];
} fleet_t;

static int connect(fleet_t *f, int a, int b) {
    char na[32], nb[32];
    snprintf(na, sizeof na, "l%zu_%d", f->w->n_links, a);
    snprintf(nb, sizeof nb, "l%zu_%d", f->w->n_links, b);
    int la = ub_node_add_link(&f->w->nodes[a], f->self[a], f->next_index[a]++, na);
    int lb = ub_node_add_link(&f->w->nodes[b], f->self[b], f->next_index[b]++, nb);
    assert_true(la >= 0 && lb >= 0);
    int e = (int)f->w->n_links;
    f->link_a[e] = la;
    world_connect(f->w, &f->w->nodes[a], la, &f->w->nodes[b], lb, NULL, (uint64_t)e + 1);
    return e;
}

static void run_checked(fleet_t *f, size_t n, uint64_t until_ms) {
    while (f->w->now_ms < until_ms) {
        world_run(f->w, f->w->now_ms + 1, 1);
        for (size_t i = 0; i < n; i++) {
            watch(&f->rt[i], &f->shadow[i], f->w->now_ms);
            check_bookkeeping(&f->rt[i]);
        }
    }
}

/* The starvation diamond of test_route.c (v0-v1-v2 with the detour v0-v3-v4-v2), plus a cut and a heal, an
 * entity added and removed by hand on v0 and a learned entity expiring: every write path of the tables. */
static void test_route_bookkeeping_matches_a_scan(void **state) {
    (void)state;
    fleet_t *f = calloc(1, sizeof *f);
    assert_non_null(f);
    f->w = world_new();
    const size_t n = 5;
    for (size_t i = 0; i < n; i++) {
        ub_node_t *node = world_node(f->w, &ub_test_cat, NULL);
        char name[16];
        snprintf(name, sizeof name, "v%zu", i);
        f->self[i] = ub_node_add_entity_name(node, name, true);
        assert_true(f->self[i] >= 0);
    }
    int direct = connect(f, 0, 1);
    connect(f, 1, 2);
    connect(f, 0, 3);
    connect(f, 3, 4);
    connect(f, 4, 2);
    ub_route_options_t ro = {.hello_ms = HELLO_MS, .learn_expiry_ms = 30 * HELLO_MS};
    for (size_t i = 0; i < n; i++) assert_int_equal(ub_route_attach(&f->rt[i], &f->w->nodes[i], &ro, 0), UB_OK);
    run_checked(f, n, 2000);
    for (size_t i = 0; i < n; i++) assert_true(ub_timeheap_min(&f->rt[i].timers) != UB_TIMEHEAP_NONE);
    /* a cut: routes expire, v0 starves and asks for a newer seqno */
    ub_memlink_faults_t lost = {.loss_ppm = 1000000u};
    ub_memlink_set_faults(&f->w->links[direct], &lost);
    run_checked(f, n, 4000);
    assert_true(ub_route_counters(&f->rt[0])->expired > 0);
    assert_true(ub_route_counters(&f->rt[0])->starvation_requests > 0);
    /* an entity added by hand on v4 (known, routed by nobody), the cut healed, then the entity removed */
    int extra = ub_node_add_entity_name(&f->w->nodes[4], "byhand", false);
    assert_true(extra >= 0);
    ub_memlink_set_faults(&f->w->links[direct], NULL);
    run_checked(f, n, 6000);
    assert_int_equal(ub_node_remove_entity(&f->w->nodes[4], extra, f->w->now_ms), UB_OK);
    /* every link but v0-v1 goes dark: the entities v0 and v1 learned beyond it expire after learn_expiry_ms */
    for (size_t l = 0; l < f->w->n_links; l++)
        if (l != (size_t)direct) ub_memlink_set_faults(&f->w->links[l], &lost);
    run_checked(f, n, 6000 + 2 * ro.learn_expiry_ms);
    uint64_t expired = 0;
    for (size_t i = 0; i < n; i++) expired += ub_route_counters(&f->rt[i])->learn_expired;
    assert_true(expired > 0);
    free(f->w);
    free(f);
}

/* ---- the node's entity index --------------------------------------------------------------------------- */

static void test_entity_index_matches_a_scan(void **state) {
    (void)state;
    world_t *w = world_new();
    ub_node_t *node = world_node(w, &ub_test_cat, NULL);
    uint8_t ids[3 * UB_MAX_ENTITIES][UB_ENTITY_ID_LEN];
    for (int k = 0; k < 3 * UB_MAX_ENTITIES; k++) {
        char name[16];
        snprintf(name, sizeof name, "n%d", k); /* similar IDs: one byte or two apart */
        test_eid(name, ids[k]);
    }
    assert_true(ub_node_add_entity(node, ids[0], true) >= 0); /* a local one stays throughout */
    for (int step = 0; step < 5000; step++) {
        int k = 1 + (int)(rnd() % (3 * UB_MAX_ENTITIES - 1));
        int row = ub_node_find_entity(node, ids[k]);
        if (row >= 0 && rnd() % 2) {
            assert_int_equal(ub_node_remove_entity(node, row, 0), UB_OK);
        } else if (row < 0) {
            int added = ub_node_add_entity(node, ids[k], false);
            assert_true(added >= 0 || added == UB_ERR_FULL);
        } else {
            assert_int_equal(ub_node_add_entity(node, ids[k], false), UB_ERR_EXISTS);
        }
        /* every ID: the index answers what a scan of the table answers */
        for (int j = 0; j < 3 * UB_MAX_ENTITIES; j++) {
            int scan = UB_ERR_NOTFOUND;
            for (int e = 0; e < UB_MAX_ENTITIES; e++) {
                const uint8_t *id = ub_node_entity_id(node, e);
                if (id != NULL && memcmp(id, ids[j], UB_ENTITY_ID_LEN) == 0) scan = e;
            }
            assert_int_equal(ub_node_find_entity(node, ids[j]), scan);
        }
    }
    free(w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_timeheap_matches_a_model),
        cmocka_unit_test(test_timeheap_due_respects_cap),
        cmocka_unit_test(test_route_bookkeeping_matches_a_scan),
        cmocka_unit_test(test_entity_index_matches_a_scan),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
