/*
 * Babel-like routing (ub_route.h, docs/routing.md). Every local entity of the
 * node is a router over its own links; its state is the row [slot] of
 * `dests`, the route entries of its links, and the per-link neighbour state.
 * A service of the node (ub_service.h, registered by ub_route_attach()): the node
 * hands it HELLO and ROUTE_UPDATE frames and calls its tick and forget hooks; this
 * file acts on the node only through its public API (ub_node.h, ub_node_svc.h)
 * and ub_node_send_link_local().
 */
#include "ub/ub_route.h"

#include <string.h>

#include "ub/ub_wire.h"
#include "ub/ub_node_svc.h"

#define INF UB_ROUTE_INFINITY
#define DEFAULT_HELLO_MS 1000u
#define HISTORY_BITS 16u /* the ETX window; a neighbour silent for this many intervals is forgotten */
#define LOSS_MEMORY 32u  /* expected hellos remembered for link_dead()'s loss estimate */
#define UPDATES_PER_EXPIRY_X2 7u /* routes expire after 3.5 update intervals */

/* Payload offsets (docs/routing.md, "Frame layouts"). */
#define OFF_VERSION 0u
#define OFF_FLAGS 1u
#define OFF_HELLO_SEQ 2u
#define OFF_HELLO_MS 4u
#define OFF_UPDATE_MS 6u
#define OFF_IHU_COST 8u
#define OFF_N_UPDATES 10u
#define OFF_N_REQUESTS 11u
#define OFF_IHU_ID 12u
#define ENT_ID 0u
#define ENT_SEQNO 12u
#define ENT_METRIC 14u /* update entries */
#define ENT_HOPS 14u   /* request entries */

#define MAX_ENTRIES ((UB_MAX_PAYLOAD - UB_ROUTE_HDR_LEN) / UB_ROUTE_ENTRY_LEN > 255u \
                         ? 255u                                                    \
                         : (UB_MAX_PAYLOAD - UB_ROUTE_HDR_LEN) / UB_ROUTE_ENTRY_LEN)

/* ---- small helpers ----------------------------------------------------------------------------------- */

/* Serial-number comparison (RFC 8966 3.2.1): a newer than b. */
static bool seq_newer(uint16_t a, uint16_t b) { return (int16_t)(uint16_t)(a - b) > 0; }

static uint16_t metric_add(uint16_t a, uint16_t b) {
    uint32_t s = (uint32_t)a + b;
    return s >= INF ? (uint16_t)INF : (uint16_t)s;
}

static const ub_link_t *node_link(const ub_route_t *rt, int link_id) { return ub_node_link(rt->node, link_id); }

static const uint8_t *slot_id(const ub_route_t *rt, int slot) {
    return ub_node_entity_id(rt->node, ub_node_slot_entity(rt->node, slot));
}

/* Link id of link[i] of local slot `slot`, or -1. */
static int slot_link(const ub_route_t *rt, int slot, unsigned i) { return ub_node_slot_link(rt->node, slot, i); }

static bool entity_local(const ub_route_t *rt, int e) {
    return (ub_node_entity_id(rt->node, e) != NULL) && ub_node_entity_slot(rt->node, e) >= 0;
}

static uint8_t all_link_bits(const ub_route_t *rt, int slot) {
    uint8_t bits = 0;
    for (unsigned i = 0; i < UB_MAX_LINKS_PER_ENTITY; i++)
        if (slot_link(rt, slot, i) >= 0) bits |= (uint8_t)(1u << i);
    return bits;
}

/* ---- cost at scale: per-entity deadlines and owed counts (docs/routing.md, "Cost at scale") ------------ */

/* Entity e's earliest deadline: what route_timers() acts on for it. Kept in rt->timers (a heap) so that a tick
 * and next_due look at the due entities only instead of every entity and link; retime() after every write to
 * a field it reads (learned, advertised_ms, routes[e][*], dests[*][e]). */
static uint64_t entity_deadline(const ub_route_t *rt, int e) {
    uint64_t best = UB_TIMEHEAP_NONE;
    if (rt->learned[e] && rt->advertised_ms[e] + rt->opt.learn_expiry_ms < best)
        best = rt->advertised_ms[e] + rt->opt.learn_expiry_ms;
    for (int lid = 0; lid < UB_MAX_NODE_LINKS; lid++)
        if (rt->routes[e][lid].in_use && rt->routes[e][lid].expires_ms < best) best = rt->routes[e][lid].expires_ms;
    for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++) {
        const ub_route_dest_t *ds = &rt->dests[s][e];
        if (ds->retracting && ds->retract_until_ms < best) best = ds->retract_until_ms;
        if (ds->starve_at_ms != 0 && ds->starve_at_ms + rt->opt.hello_ms < best) best = ds->starve_at_ms + rt->opt.hello_ms;
        if (ds->fd_valid && ds->sel_link < 0 && !ds->retracting && ds->fd_touched_ms + rt->opt.source_gc_ms < best)
            best = ds->fd_touched_ms + rt->opt.source_gc_ms;
    }
    return best;
}

static void retime(ub_route_t *rt, int e) { ub_timeheap_set(&rt->timers, (unsigned)e, entity_deadline(rt, e)); }

static void retime_all(ub_route_t *rt) {
    for (int e = 0; e < UB_MAX_ENTITIES; e++) retime(rt, e);
}

/* Destination e of `slot` is to be chosen again at the slot's next selection (its inputs changed). */
static void mark_dest(ub_route_t *rt, int slot, int e) { rt->resel_bits[slot][e / 64] |= 1ull << (e % 64); }

/* Writes dests[slot][e].dirty_links / req_links, keeping the per-link counts that owes() reads. */
static void set_owed(ub_route_t *rt, int slot, int e, uint8_t dirty, uint8_t req) {
    ub_route_dest_t *ds = &rt->dests[slot][e];
    for (uint8_t ch = (uint8_t)(ds->dirty_links ^ dirty); ch != 0; ch &= (uint8_t)(ch - 1u)) {
        unsigned i = (unsigned)__builtin_ctz(ch);
        if (dirty & (1u << i)) rt->owed_dirty[slot][i]++;
        else rt->owed_dirty[slot][i]--;
    }
    for (uint8_t ch = (uint8_t)(ds->req_links ^ req); ch != 0; ch &= (uint8_t)(ch - 1u)) {
        unsigned i = (unsigned)__builtin_ctz(ch);
        if (req & (1u << i)) rt->owed_req[slot][i]++;
        else rt->owed_req[slot][i]--;
    }
    if (ds->req_links != req) mark_dest(rt, slot, e); /* a starvation request reads req_links */
    ds->dirty_links = dirty;
    ds->req_links = req;
}

/* Writes dests[slot][e].lazy_links, keeping the per-link counts send_frame() reads. */
static void set_lazy(ub_route_t *rt, int slot, int e, uint8_t lazy) {
    ub_route_dest_t *ds = &rt->dests[slot][e];
    for (uint8_t ch = (uint8_t)(ds->lazy_links ^ lazy); ch != 0; ch &= (uint8_t)(ch - 1u)) {
        unsigned i = (unsigned)__builtin_ctz(ch);
        if (lazy & (1u << i)) rt->owed_lazy[slot][i]++;
        else rt->owed_lazy[slot][i]--;
    }
    ds->lazy_links = lazy;
}

/* ---- link quality (RFC 8966 3.4, A.2.2) ------------------------------------------------------------ */

/* The ETX window (RFC 8966 A.2.2): the last 16 expected hellos, or fewer while the history fills. */
static unsigned etx_samples(const ub_route_link_t *l) { return l->samples < HISTORY_BITS ? l->samples : HISTORY_BITS; }

static uint32_t history_bits(const ub_route_link_t *l, unsigned n) {
    return l->history & (n >= LOSS_MEMORY ? 0xFFFFFFFFu : (1u << n) - 1u);
}

/* Hellos the link lost among the last 32 expected (its loss memory). */
static unsigned hellos_lost(const ub_route_link_t *l) {
    return l->samples - (unsigned)__builtin_popcount(history_bits(l, l->samples));
}

/* Whether the link's latest hellos were all missed in a run too long to be the link's own loss: `dead_misses`
 * in a row, plus one for every hello lost before the run in the history (the last 32 expected; at most
 * `dead_misses` more). On a link that loses 20 % of its hellos a run of 3 comes about every 125 hellos (0.2^3): no
 * failure, yet each took the link down and sent seqno requests and their answers across the fleet (fleet6's lossy
 * detour). Now such a link goes down falsely about once in 14,000 hellos (32 hellos of memory: a 16-hello one,
 * which often saw too few of its losses, read once in 1,100), while a loss-free link still goes down after
 * `dead_misses`. A history with no hello at all (never heard, or taken down by a link event) is dead at once. */
static bool link_dead(const ub_route_t *rt, const ub_route_link_t *l) {
    unsigned dead = rt->opt.dead_misses;
    if (l->samples < dead) return false;
    uint32_t h = history_bits(l, l->samples);
    if (h == 0) return true;
    unsigned run = (unsigned)__builtin_ctz(h); /* the latest misses in a row; bit `run` is the last hello heard */
    if (run < dead) return false;
    unsigned before = l->samples - run - 1u;   /* expected before that hello, still in the history */
    unsigned lost = before - (unsigned)__builtin_popcount(h >> run >> 1);
    return run >= dead + (lost < dead ? lost : dead);
}

static uint16_t rxcost_of(const ub_route_t *rt, const ub_route_link_t *l) {
    if (!l->nb_in_use || l->samples == 0 || link_dead(rt, l)) return INF;
    unsigned n = etx_samples(l);
    unsigned got = (unsigned)__builtin_popcount(history_bits(l, n));
    if (got == 0) return INF;
    uint32_t c = UB_ROUTE_LINK_COST * n / got; /* 256 / beta */
    return c >= INF ? (uint16_t)(INF - 1) : (uint16_t)c;
}

static uint16_t cost_of(const ub_route_t *rt, const ub_route_link_t *l) {
    uint16_t rx = rxcost_of(rt, l);
    if (rx == INF || l->txcost == INF) return INF;
    /* 256 / (alpha * beta), alpha = min(1, 256 / txcost): the loss in both directions. */
    uint32_t tx = l->txcost < UB_ROUTE_LINK_COST ? UB_ROUTE_LINK_COST : l->txcost;
    uint32_t c = tx * rx / UB_ROUTE_LINK_COST;
    return c >= INF ? (uint16_t)(INF - 1) : (uint16_t)c;
}

static void mark_slot(ub_route_t *rt, int link_id) {
    const ub_link_t *link = node_link(rt, link_id);
    if (link != NULL) rt->reselect[link->owner] = rt->resel_full[link->owner] = 1;
}

/* Forgets the neighbour of a link and every route through it. */
static void drop_neighbour(ub_route_t *rt, int link_id) {
    ub_route_link_t *l = &rt->links[link_id];
    for (int e = 0; e < UB_MAX_ENTITIES; e++) memset(&rt->routes[e][link_id], 0, sizeof rt->routes[e][link_id]);
    rt->link_routes[link_id] = 0;
    retime_all(rt);
    l->nb_in_use = 0;
    memset(l->nb_id, 0, sizeof l->nb_id);
    l->history = 0;
    l->samples = 0;
    l->txcost = INF;
    l->last_cost = INF;
    mark_slot(rt, link_id);
}

static ub_route_link_t *activate(ub_route_t *rt, int link_id, uint64_t now_ms) {
    ub_route_link_t *l = &rt->links[link_id];
    if (!l->active) {
        memset(l, 0, sizeof *l);
        l->active = 1;
        l->txcost = INF;
        l->last_cost = INF;
        l->next_hello_ms = now_ms;
        l->dump_due_ms = now_ms;
    }
    return l;
}

/* A hello (any routing frame) with sequence `seq` arrived: RFC 8966 3.4.1. */
static void hello_heard(const ub_route_t *rt, ub_route_link_t *l, uint16_t seq, uint32_t hello_ms, uint64_t now_ms) {
    int16_t diff = (int16_t)(uint16_t)(seq - l->expected_seq);
    if (l->samples == 0 || diff > (int16_t)HISTORY_BITS || diff < -(int16_t)HISTORY_BITS) {
        l->history = 0; /* new neighbour, or it restarted its hello counter */
        l->samples = 0;
    } else if (link_dead(rt, l)) {
        /* A link that was down hears again. The misses that took it down described the outage (out of range, cable
         * pulled), not the link that is back, and counting them would keep it unusable for up to 16 intervals: they
         * are dropped. What came before them is kept, so a lossy link comes back at its old cost and loss memory.
         * Starting it as a perfect link lowered the feasibility distances of the routes through it, and when its
         * true cost showed again a few seconds later those routes were unfeasible: seqno requests across the
         * fleet. A history with nothing before the outage (a link event, or never heard) starts afresh. */
        uint32_t h = history_bits(l, l->samples);
        unsigned run = h == 0 ? l->samples : (unsigned)__builtin_ctz(h);
        l->history = h == 0 ? 0u : h >> run;
        l->samples = (uint8_t)(l->samples - run);
    } else if (diff > 0) { /* hellos we missed without the timer noticing */
        l->history <<= diff;
        int n = l->samples + diff;
        l->samples = (uint8_t)(n > (int)LOSS_MEMORY ? (int)LOSS_MEMORY : n);
    } else if (diff < 0) { /* the timer counted misses that were only late: take them back */
        l->history >>= -diff;
        l->samples = (uint8_t)(l->samples > -diff ? l->samples + diff : 0);
    }
    l->history = (l->history << 1) | 1u;
    if (l->samples < LOSS_MEMORY) l->samples++;
    l->expected_seq = (uint16_t)(seq + 1u);
    l->nb_hello_ms = hello_ms;
    /* Half an interval of slack for scheduling jitter before a hello counts as missed. */
    l->next_miss_ms = now_ms + hello_ms + hello_ms / 2u;
}

/* ---- feasibility and selection (RFC 8966 3.5, 3.6) ------------------------------------------------- */

static bool feasible(const ub_route_dest_t *ds, uint16_t seqno, uint16_t metric) {
    if (metric == INF || !ds->fd_valid) return true;
    return seq_newer(seqno, ds->fd_seqno) || (seqno == ds->fd_seqno && metric < ds->fd_metric);
}

/* A route change every neighbour must hear now: a triggered entry on every link. */
static void make_dirty(ub_route_t *rt, int slot, int e) {
    set_owed(rt, slot, e, all_link_bits(rt, slot), rt->dests[slot][e].req_links);
    rt->dests[slot][e].asked_links = 0; /* answered too */
    rt->counters.owed_route_change++;
}

/* Only the seqno changed (a source raised it for someone's request): RFC 8966 3.7.2 -- a node does not send
 * triggered updates to propagate a new seqno, except to satisfy a request. The links whose neighbour asked for it
 * get a triggered entry; every other link gets it on its next regular frame (no extra frame: the hello that is due
 * anyway carries it). Triggering it everywhere made each request echo over every link of the fleet. */
static void seqno_changed(ub_route_t *rt, int slot, int e, uint16_t seqno) {
    ub_route_dest_t *ds = &rt->dests[slot][e];
    uint8_t asked = ds->asked_links != 0 && !seq_newer(ds->asked_seqno, seqno) ? ds->asked_links : 0;
    uint8_t rest = (uint8_t)(all_link_bits(rt, slot) & ~asked & ~ds->dirty_links);
    if (asked != 0) {
        set_owed(rt, slot, e, (uint8_t)(ds->dirty_links | asked), ds->req_links);
        ds->asked_links = 0;
        rt->counters.owed_seqno_asked++;
    }
    if (rest != 0) {
        set_lazy(rt, slot, e, (uint8_t)(ds->lazy_links | rest));
        rt->counters.seqno_deferred++;
    }
}

/* Asks the neighbours of `slot` for a newer seqno of `e` (starvation, RFC 8966 3.8.2.1); once per hello. */
static void request_seqno(ub_route_t *rt, int slot, int e, uint64_t now_ms) {
    ub_route_dest_t *ds = &rt->dests[slot][e];
    if (!ds->fd_valid) return; /* without a feasibility distance every update is feasible */
    if (ds->req_links != 0 || (ds->starve_at_ms != 0 && now_ms < ds->starve_at_ms + rt->opt.hello_ms)) return;
    ds->req_seqno = (uint16_t)(ds->fd_seqno + 1u);
    ds->req_hops = UB_ROUTE_REQUEST_HOPS;
    set_owed(rt, slot, e, ds->dirty_links, all_link_bits(rt, slot));
    ds->starve_at_ms = now_ms;
    retime(rt, e);
    rt->counters.starvation_requests++;
}

/* Whether a neighbour's route cannot pass through us (a successor for data while in doubt, never for selection):
 * every route through us adds at least one link cost (>= UB_ROUTE_LINK_COST) to a metric we advertised for that
 * seqno, and all of those are >= our feasibility distance. So a route at the FD's seqno with a metric below
 * FD + one link cost does not go through us -- the equal-metric neighbour of a grid, which the feasibility
 * condition (strictly below FD) refuses. Two such neighbours may both be in doubt and hand a frame to each other:
 * the duplicate window of the one that sent it first drops it, so a frame never circles. */
static bool around_us(const ub_route_dest_t *ds, const ub_route_entry_t *r) {
    return ds->fd_valid && r->seqno == ds->fd_seqno && (uint32_t)r->metric < (uint32_t)ds->fd_metric + UB_ROUTE_LINK_COST;
}

static uint8_t compute_mask(const ub_route_t *rt, int slot, int e) {
    const ub_route_dest_t *ds = &rt->dests[slot][e];
    if (ds->sel_link < 0) return 0;
    const ub_link_t *sel = node_link(rt, ds->sel_link);
    if (sel == NULL) return 0;
    uint8_t mask = (uint8_t)(1u << sel->index);
    /* In doubt (its neighbour's frames stopped sooner than they should have, docs/routing.md, "Transport
     * evidence"): every feasible successor, and every neighbour whose route cannot pass through us (around_us()),
     * carries the traffic until a frame arrives or the hello timeout decides. The receivers' duplicate windows
     * keep one copy. Nothing is advertised differently: the routing frames do not change. */
    bool doubt = rt->links[ds->sel_link].doubt != 0;
    if (rt->opt.parallel == UB_ROUTE_PARALLEL_BEST && !doubt) return mask;
    const uint8_t *nb = rt->links[ds->sel_link].nb_id;
    for (unsigned i = 0; i < UB_MAX_LINKS_PER_ENTITY; i++) {
        int lid = slot_link(rt, slot, i);
        if (lid < 0) continue;
        const ub_route_link_t *l = &rt->links[lid];
        const ub_route_entry_t *r = &rt->routes[e][lid];
        if (!l->nb_in_use || (!doubt && memcmp(l->nb_id, nb, UB_ENTITY_ID_LEN) != 0) || cost_of(rt, l) == INF) continue;
        if (!r->in_use || r->metric == INF) continue;
        if (!feasible(ds, r->seqno, r->metric) && !(doubt && around_us(ds, r))) continue;
        mask |= (uint8_t)(1u << i);
    }
    if (doubt && mask == (uint8_t)(1u << sel->index)) {
        /* No successor known to avoid us: every neighbour with a route gets the data. One that routes through us
         * has only us in its mask, so it hands the frame to its own feasible successors (its bounce mask,
         * compute_bounce()) or drops it (`no_route`); none sends it back, and a frame seen twice is dropped as
         * a duplicate anyway. */
        for (unsigned i = 0; i < UB_MAX_LINKS_PER_ENTITY; i++) {
            int lid = slot_link(rt, slot, i);
            if (lid < 0) continue;
            const ub_route_entry_t *r = &rt->routes[e][lid];
            if (rt->links[lid].nb_in_use && cost_of(rt, &rt->links[lid]) != INF && r->in_use && r->metric != INF)
                mask |= (uint8_t)(1u << i);
        }
    }
    return mask;
}

/* Where the node sends a frame toward `e` that its next hop sent back (ub_node_set_bounce_mask()): every feasible
 * successor behind another neighbour. A neighbour tied between us and another way keeps the route through us
 * (hysteresis); when our link onward falls in doubt and we hand it the data, this is its way around. Loop-free as
 * any selection (feasible successors only). */
static uint8_t compute_bounce(const ub_route_t *rt, int slot, int e) {
    const ub_route_dest_t *ds = &rt->dests[slot][e];
    if (ds->sel_link < 0) return 0;
    const uint8_t *nb = rt->links[ds->sel_link].nb_id;
    uint8_t mask = 0;
    for (unsigned i = 0; i < UB_MAX_LINKS_PER_ENTITY; i++) {
        int lid = slot_link(rt, slot, i);
        if (lid < 0) continue;
        const ub_route_link_t *l = &rt->links[lid];
        const ub_route_entry_t *r = &rt->routes[e][lid];
        if (!l->nb_in_use || memcmp(l->nb_id, nb, UB_ENTITY_ID_LEN) == 0 || cost_of(rt, l) == INF) continue;
        if (r->in_use && r->metric != INF && feasible(ds, r->seqno, r->metric)) mask |= (uint8_t)(1u << i);
    }
    return mask;
}

static void install_mask(ub_route_t *rt, int slot, int e) {
    int self = ub_node_slot_entity(rt->node, slot);
    uint8_t bounce = compute_bounce(rt, slot, e);
    if (bounce != rt->dests[slot][e].bounce && ub_node_set_bounce_mask(rt->node, self, e, bounce) == UB_OK)
        rt->dests[slot][e].bounce = bounce;
    uint8_t want = compute_mask(rt, slot, e);
    uint8_t before = rt->dests[slot][e].mask;
    rt->dests[slot][e].mask = want;
    uint8_t have = 0;
    if (ub_node_get_mask(rt->node, self, e, &have) != UB_OK || have == want) return;
    if (ub_node_mask_pinned(rt->node, self, e)) {
        if (before != want) rt->counters.pinned_skips++;
        return;
    }
    if (ub_node_set_auto_mask(rt->node, self, e, want) != UB_OK) rt->counters.pinned_skips++;
}

static void select_route(ub_route_t *rt, int slot, int e, uint64_t now_ms) {
    ub_route_dest_t *ds = &rt->dests[slot][e];
    int best = -1;
    uint16_t best_metric = INF, cur_metric = INF;
    bool unfeasible_left = false;
    for (unsigned i = 0; i < UB_MAX_LINKS_PER_ENTITY; i++) {
        int lid = slot_link(rt, slot, i);
        if (lid < 0) continue;
        const ub_route_entry_t *r = &rt->routes[e][lid];
        if (!r->in_use || r->metric == INF) continue;
        uint16_t c = cost_of(rt, &rt->links[lid]);
        if (c == INF) continue;
        uint16_t m = metric_add(c, r->metric);
        if (m == INF) continue;
        if (!feasible(ds, r->seqno, r->metric)) {
            unfeasible_left = true;
            continue;
        }
        if (lid == ds->sel_link) cur_metric = m;
        if (m < best_metric || (m == best_metric && lid == ds->sel_link)) {
            best = lid;
            best_metric = m;
        }
    }
    /* Hysteresis: leave a working route only for one clearly better (1/16), so ETX noise does not flap. */
    if (cur_metric != INF && best != ds->sel_link && (uint32_t)best_metric + cur_metric / 16u >= cur_metric) {
        best = ds->sel_link;
        best_metric = cur_metric;
    }
    bool had = ds->sel_link >= 0;
    if (best >= 0) {
        uint16_t seqno = rt->routes[e][best].seqno;
        uint16_t old = ds->metric;
        uint16_t delta = best_metric > old ? (uint16_t)(best_metric - old) : (uint16_t)(old - best_metric);
        bool significant = !had || ds->retracting || delta > UB_ROUTE_LINK_COST / 4u + old / 4u;
        bool new_seqno = seqno != ds->seqno;
        if (had && best != ds->sel_link &&
            memcmp(rt->links[best].nb_id, rt->links[ds->sel_link].nb_id, UB_ENTITY_ID_LEN) != 0)
            rt->counters.route_changes++;
        if (!had) rt->counters.routes_found++;
        ds->sel_link = (int8_t)best;
        ds->metric = best_metric;
        ds->seqno = seqno;
        ds->retracting = 0;
        if (significant) make_dirty(rt, slot, e);
        else if (new_seqno) seqno_changed(rt, slot, e, seqno);
    } else if (had) {
        /* Why the selected route is gone (counted per cause: a loss is what sets off starvation and requests). */
        const ub_route_entry_t *r0 = &rt->routes[e][ds->sel_link];
        if (!r0->in_use) rt->counters.lost_entry_gone++;
        else if (r0->metric == INF) rt->counters.lost_retracted++;
        else if (cost_of(rt, &rt->links[ds->sel_link]) == INF) rt->counters.lost_link_down++;
        else rt->counters.lost_unfeasible++;
        ds->sel_link = -1;
        ds->metric = INF;
        ds->retracting = 1;
        ds->retract_until_ms = now_ms + 2u * rt->opt.update_ms;
        make_dirty(rt, slot, e);
        rt->counters.routes_lost++;
    }
    if (best < 0 && unfeasible_left) request_seqno(rt, slot, e, now_ms);
    else ds->starve_at_ms = 0;
    /* No seqno request is sent merely because the selected link is in doubt: tried (one per hello, then one
     * per update interval per destination), each request bumps the destination's seqno and its triggered
     * updates echoed fleet-wide (before seqno_changed()), which broke the routing-frame budget of the 14-entity
     * demo fleet (1.15-1.2 frames per hello against 1.1, tests/system/test_fleet_demo.py). A starving destination (no feasible
     * successor at all) still asks, above; while in doubt the data goes on every feasible successor. */
    retime(rt, e);
    if (ds->starve_at_ms != 0) mark_dest(rt, slot, e); /* starving: every selection may ask again (time-dependent) */
    install_mask(rt, slot, e);
}

/* Whether the links of `slot` changed, for route choice, since the last look (and remembers them). */
static bool links_changed(ub_route_t *rt, int slot) {
    bool changed = false;
    for (unsigned i = 0; i < UB_MAX_LINKS_PER_ENTITY; i++) {
        ub_route_link_sig_t now = {.link_id = -1};
        int lid = slot_link(rt, slot, i);
        if (lid >= 0) {
            const ub_route_link_t *l = &rt->links[lid];
            now.link_id = (int16_t)lid;
            now.cost = cost_of(rt, l);
            now.nb_in_use = l->nb_in_use;
            now.doubt = l->doubt;
            memcpy(now.nb_id, l->nb_id, UB_ENTITY_ID_LEN);
        }
        if (memcmp(&now, &rt->link_sig[slot][i], sizeof now) != 0) {
            rt->link_sig[slot][i] = now;
            changed = true;
        }
    }
    return changed;
}

/* Chooses the routes of `slot` again: every destination when a link changed (or resel_full), else only the marked
 * ones -- the others' inputs are as at their last choice, which would choose the same (docs/routing.md, "Cost at
 * scale"). In table order either way. */
static void reselect_slot(ub_route_t *rt, int slot, uint64_t now_ms) {
    rt->reselect[slot] = 0;
    bool full = links_changed(rt, slot) || rt->resel_full[slot];
    rt->resel_full[slot] = 0;
    uint64_t bits[(UB_MAX_ENTITIES + 63) / 64];
    memcpy(bits, rt->resel_bits[slot], sizeof bits);
    memset(rt->resel_bits[slot], 0, sizeof bits); /* select_route() marks a starving destination again */
    for (size_t w = 0; w < sizeof bits / sizeof bits[0]; w++) {
        uint64_t todo = full ? UINT64_MAX : bits[w];
        for (; todo != 0; todo &= todo - 1u) {
            int e = (int)(w * 64u + (unsigned)__builtin_ctzll(todo));
            if (e >= UB_MAX_ENTITIES) break;
            if (!(ub_node_entity_id(rt->node, e) != NULL) || entity_local(rt, e)) continue;
            select_route(rt, slot, e, now_ms);
        }
    }
}

/* ---- receiving --------------------------------------------------------------------------------------- */

static bool tombstoned(ub_route_t *rt, const uint8_t id[UB_ENTITY_ID_LEN], uint64_t now_ms) {
    for (size_t i = 0; i < UB_ROUTE_TOMBSTONES; i++)
        if (rt->tomb[i].until_ms > now_ms && memcmp(rt->tomb[i].id, id, UB_ENTITY_ID_LEN) == 0) return true;
    return false;
}

/* Entity-table index for an advertised destination, learning it if allowed; -1 to ignore the entry. */
static int destination(ub_route_t *rt, const uint8_t id[UB_ENTITY_ID_LEN], uint16_t metric, uint64_t now_ms) {
    if (ub_entity_id_is_zero(id) || ub_entity_id_is_link_local(id)) return -1;
    int e = ub_node_find_entity(rt->node, id);
    if (e >= 0) {
        if (metric != INF) rt->advertised_ms[e] = now_ms; /* a retraction advertises no route: it expires */
        if (metric != INF && rt->learned[e]) retime(rt, e);
        return e;
    }
    if (metric == INF) return -1; /* a retraction of something we never knew */
    if (rt->opt.no_learn || tombstoned(rt, id, now_ms)) {
        rt->counters.learn_refused++;
        return -1;
    }
    e = ub_node_add_entity(rt->node, id, false);
    if (e < 0) {
        rt->counters.learn_full++;
        return -1;
    }
    rt->learned[e] = 1;
    rt->advertised_ms[e] = now_ms;
    rt->counters.learned++;
    retime(rt, e);
    return e;
}

/* Destinations the neighbour on `link_id` has route entries for (counted where entries are taken and freed). */
static unsigned link_dests(const ub_route_t *rt, int link_id) { return rt->link_routes[link_id]; }

/* Insider bounds, asked before an entry may take a route-table row (and before its destination is learned):
 * the accept_dest filter, then at most max_dests destinations per neighbour. Entries the neighbour already
 * has a row for are always refreshed, so the bound never evicts a route it let in. */
static bool admit(ub_route_t *rt, int link_id, const uint8_t *ent, uint16_t metric) {
    ub_route_link_t *l = &rt->links[link_id];
    if (rt->opt.accept_dest != NULL && !rt->opt.accept_dest(rt->opt.accept_user, ent + ENT_ID, l->nb_id, metric)) {
        rt->counters.dest_refused++;
        return false;
    }
    int known = ub_node_find_entity(rt->node, ent + ENT_ID);
    if (known >= 0 && (rt->routes[known][link_id].in_use || entity_local(rt, known))) return true;
    if (link_dests(rt, link_id) < rt->opt.max_dests) return true;
    rt->counters.neighbour_limit++;
    l->stats.over_limit_in++;
    return false;
}

/* Whether an update for the selected route is held back (RFC 8966 3.5.4: an unfeasible update for the selected
 * route from the same source "MAY be ignored"): its neighbour's metric rose, at the same seqno, to our feasibility
 * distance or above, and no other feasible route is left to switch to. Accepted, it would leave the destination
 * starving and send a seqno request across the fleet; on a lossy link the ETX of one link on the path moves by
 * more than a link's cost every few seconds and back (fleet6's 20 %-lossy detour: uav3's route to uav7 through
 * uav2 went unfeasible in a steady window, a request, a new seqno everywhere; the frame budget read 1.14 under
 * load). Held, the entry keeps its last feasible metric and is NOT refreshed: the next feasible update (the cost
 * coming back) refreshes it, and a rise that lasts lets it expire (3.5+ update intervals), which starves and asks
 * as before. Loop freedom is untouched: acting as if the update had not come is what the RFC allows. A
 * retraction, a change of seqno (a restarted source), or an update that leaves a feasible alternative is
 * accepted as always. */
static bool hold_unfeasible(const ub_route_t *rt, int slot, int e, int link_id, uint16_t seqno, uint16_t metric) {
    const ub_route_dest_t *ds = &rt->dests[slot][e];
    const ub_route_entry_t *r = &rt->routes[e][link_id];
    if (ds->sel_link != link_id || !r->in_use || metric == INF || seqno != r->seqno || metric <= r->metric ||
        feasible(ds, seqno, metric))
        return false;
    for (unsigned i = 0; i < UB_MAX_LINKS_PER_ENTITY; i++) {
        int lid = slot_link(rt, slot, i);
        if (lid < 0 || lid == link_id) continue;
        const ub_route_entry_t *o = &rt->routes[e][lid];
        if (o->in_use && o->metric != INF && cost_of(rt, &rt->links[lid]) != INF && feasible(ds, o->seqno, o->metric))
            return false; /* selection moves to it: no starvation, no request */
    }
    return true;
}

static void on_update(ub_route_t *rt, int slot, int link_id, const uint8_t *ent, uint32_t update_ms, uint64_t now_ms) {
    uint16_t seqno = ub_get_u16le(ent + ENT_SEQNO);
    uint16_t metric = ub_get_u16le(ent + ENT_METRIC);
    if (!admit(rt, link_id, ent, metric)) return;
    int e = destination(rt, ent + ENT_ID, metric, now_ms);
    if (e < 0 || entity_local(rt, e)) return; /* ours: we are the source */
    ub_route_entry_t *r = &rt->routes[e][link_id];
    ub_route_dest_t *ds = &rt->dests[slot][e];
    if (hold_unfeasible(rt, slot, e, link_id, seqno, metric)) {
        rt->counters.unfeasible_held++;
        return;
    }
    if (!feasible(ds, seqno, metric)) {
        /* Kept, never selected while unfeasible (selection checks every time): so that losing the
         * selected route finds the alternatives at once and can ask for a newer seqno (starvation)
         * instead of waiting for the next full table. With no route at all, ask now. */
        rt->counters.unfeasible++;
        if (ds->sel_link < 0) request_seqno(rt, slot, e, now_ms);
    }
    if (!r->in_use) rt->link_routes[link_id]++;
    r->in_use = 1;
    r->seqno = seqno;
    r->metric = metric;
    /* 3.5 update intervals (RFC 8966 appendix B), plus one for each hello the link lost among the last 32, at most
     * 3 more: on fleet6's 20 %-lossy detour three full tables lost in a row (0.2^3 an interval) expired every route
     * it carried while its hellos kept coming, and the starving nodes' requests crossed the fleet. The same
     * allowance as link_dead()'s: a lossy link's silence means less. */
    unsigned lost = hellos_lost(&rt->links[link_id]);
    r->expires_ms = now_ms + (uint64_t)update_ms * (UPDATES_PER_EXPIRY_X2 + 2u * (lost < 3u ? lost : 3u)) / 2u;
    retime(rt, e);
    mark_dest(rt, slot, e);
    rt->reselect[slot] = 1;
}

static void on_request(ub_route_t *rt, int slot, int link_id, const uint8_t *from, const uint8_t *ent,
                       uint64_t now_ms) {
    uint16_t seqno = ub_get_u16le(ent + ENT_SEQNO);
    uint8_t hops = ent[ENT_HOPS];
    int e = ub_node_find_entity(rt->node, ent + ENT_ID);
    if (e < 0) {
        rt->counters.requests_dropped++;
        return;
    }
    int here = ub_node_entity_slot(rt->node, e);
    if (here >= 0) {
        /* We are the source: raise the seqno (RFC 8966 3.8.1.2) and tell everyone. */
        if (seq_newer(seqno, rt->seqno[here])) {
            rt->seqno[here] = seqno;
            rt->counters.seqno_bumps++;
        }
        /* The answer goes at once to the link the request came in on (it leads back to the requester); the other
         * links hear the new seqno at their next regular frame (seqno_changed()'s reason). */
        const ub_link_t *from_link = node_link(rt, link_id);
        for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++) {
            if (ub_node_slot_entity(rt->node, s) < 0) continue;
            ub_route_dest_t *d = &rt->dests[s][e];
            uint8_t now_bits = s == slot ? (uint8_t)(1u << from_link->index) : 0;
            set_owed(rt, s, e, (uint8_t)(d->dirty_links | now_bits), d->req_links);
            set_lazy(rt, s, e, (uint8_t)(d->lazy_links | (all_link_bits(rt, s) & ~now_bits & ~d->dirty_links)));
        }
        rt->counters.owed_request_answer++;
        rt->counters.requests_answered++;
        return;
    }
    ub_route_dest_t *ds = &rt->dests[slot][e];
    const ub_link_t *in = node_link(rt, link_id);
    if (ds->sel_link < 0 || ds->metric == INF) {
        rt->counters.requests_dropped++;
    } else if (!seq_newer(seqno, ds->seqno)) {
        set_owed(rt, slot, e, (uint8_t)(ds->dirty_links | (1u << in->index)), ds->req_links); /* we have it: answer with our route */
        rt->counters.owed_request_answer++;
        rt->counters.requests_answered++;
    } else if (hops > 1 && memcmp(rt->links[ds->sel_link].nb_id, from, UB_ENTITY_ID_LEN) != 0) {
        const ub_link_t *out = node_link(rt, ds->sel_link);
        /* Remember who asked: the new seqno goes back to it as a triggered entry (seqno_changed()). */
        if (ds->asked_links == 0 || seq_newer(seqno, ds->asked_seqno)) ds->asked_seqno = seqno;
        ds->asked_links |= (uint8_t)(1u << in->index);
        bool again = ds->req_links != 0 && !seq_newer(seqno, ds->req_seqno);
        bool recent = ds->req_at_ms != 0 && now_ms < ds->req_at_ms + rt->opt.hello_ms && !seq_newer(seqno, ds->req_seqno);
        if (!again && !recent) {
            ds->req_seqno = seqno;
            ds->req_hops = (uint8_t)(hops - 1u);
            set_owed(rt, slot, e, ds->dirty_links, (uint8_t)(ds->req_links | (1u << out->index)));
            ds->req_at_ms = now_ms;
            rt->counters.requests_forwarded++;
        } else {
            rt->counters.requests_suppressed++;
        }
    } else {
        rt->counters.requests_dropped++;
    }
}

/* A link-local routing frame (HELLO or ROUTE_UPDATE) arrived on `link_id`, past the duplicate window.
 * Returns UB_OK, or a negative error when the payload is unusable (the node counts bad_payload). */
static int route_on_frame(ub_route_t *rt, int link_id, const ub_frame_header_t *h, const uint8_t *payload,
                          uint64_t now_ms) {
    const ub_link_t *link = node_link(rt, link_id);
    if (link == NULL) return UB_ERR_INVAL;
    ub_route_link_t *l = activate(rt, link_id, now_ms);
    uint16_t len = h->payload_size;
    if (len < UB_ROUTE_HDR_LEN || payload[OFF_VERSION] != UB_ROUTE_WIRE_VERSION) {
        l->stats.bad_in++;
        return len < UB_ROUTE_HDR_LEN ? UB_ERR_TRUNCATED : UB_ERR_INVAL;
    }
    unsigned n_upd = payload[OFF_N_UPDATES], n_req = payload[OFF_N_REQUESTS];
    uint32_t hello_ms = ub_get_u16le(payload + OFF_HELLO_MS);
    uint32_t update_ms = ub_get_u16le(payload + OFF_UPDATE_MS);
    if ((size_t)UB_ROUTE_HDR_LEN + (n_upd + n_req) * UB_ROUTE_ENTRY_LEN != len || hello_ms == 0 ||
        update_ms < hello_ms || (h->admin == UB_ADMIN_HELLO && n_upd + n_req != 0)) {
        l->stats.bad_in++;
        return UB_ERR_INVAL;
    }
    int slot = link->owner;
    if (memcmp(h->src_id, slot_id(rt, slot), UB_ENTITY_ID_LEN) == 0) {
        l->stats.bad_in++; /* our own frame looped back over a link: nothing to learn from it */
        return UB_OK;
    }
    if (l->nb_in_use && memcmp(l->nb_id, h->src_id, UB_ENTITY_ID_LEN) != 0) {
        drop_neighbour(rt, link_id); /* someone else answers on this link now */
        l->stats.neighbour_changes++;
    }
    if (!l->nb_in_use) {
        l->nb_in_use = 1;
        memcpy(l->nb_id, h->src_id, UB_ENTITY_ID_LEN);
        l->next_hello_ms = now_ms; /* answer at once: it needs our IHU to use the link */
    }
    l->stats.frames_in++;
    if (link_dead(rt, l)) l->next_hello_ms = now_ms; /* back from an outage: let it hear us (IHU) at once */
    hello_heard(rt, l, ub_get_u16le(payload + OFF_HELLO_SEQ), hello_ms, now_ms);
    l->nb_update_ms = update_ms;
    bool about_us = memcmp(payload + OFF_IHU_ID, slot_id(rt, slot), UB_ENTITY_ID_LEN) == 0;
    l->txcost = about_us ? ub_get_u16le(payload + OFF_IHU_COST) : (uint16_t)INF;
    uint16_t cost = cost_of(rt, l);
    if (cost != l->last_cost) {
        if (l->last_cost == INF) {
            /* The link came up (first contact, or back from an outage): give the neighbour our whole table
             * now instead of at the next periodic update, as Babel does for a new neighbour. */
            l->next_hello_ms = now_ms;
            l->dump_due_ms = now_ms;
            l->dumping = 0;
            l->dump_cursor = 0;
        }
        l->last_cost = cost;
        rt->reselect[slot] = rt->resel_full[slot] = 1;
    }
    const uint8_t *ent = payload + UB_ROUTE_HDR_LEN;
    for (unsigned i = 0; i < n_upd; i++, ent += UB_ROUTE_ENTRY_LEN) {
        l->stats.entries_in++;
        on_update(rt, slot, link_id, ent, update_ms, now_ms);
    }
    /* Choose again before looking at the requests: a starving neighbour sends its retraction and its seqno
     * request in one frame, and a request from the next hop we were still using would be dropped (Babel does
     * not forward toward the requester) -- leaving it to ask again a hello interval later. */
    if (rt->reselect[slot]) reselect_slot(rt, slot, now_ms);
    for (unsigned i = 0; i < n_req; i++, ent += UB_ROUTE_ENTRY_LEN) {
        l->stats.requests_in++;
        on_request(rt, slot, link_id, h->src_id, ent, now_ms);
    }
    if (rt->reselect[slot]) reselect_slot(rt, slot, now_ms);
    return UB_OK;
}

/* ---- sending ----------------------------------------------------------------------------------------- */

/* Whether local slot `slot` advertises destination `e` now, and with what. */
static bool advertised(const ub_route_t *rt, int slot, int e, uint16_t *seqno, uint16_t *metric) {
    if (ub_node_entity_id(rt->node, e) == NULL) return false;
    int local = ub_node_entity_slot(rt->node, e);
    if (local >= 0) { /* an entity of this node: the source itself */
        *seqno = rt->seqno[local];
        *metric = 0;
        return true;
    }
    const ub_route_dest_t *ds = &rt->dests[slot][e];
    if (ds->sel_link >= 0 || ds->retracting) {
        *seqno = ds->seqno;
        *metric = ds->sel_link >= 0 ? ds->metric : (uint16_t)INF;
        return true;
    }
    return false;
}

/* Writes one update entry; advertising a finite metric sets the feasibility distance (RFC 8966 3.7.3). */
static void put_update(ub_route_t *rt, int slot, int e, uint8_t *ent, uint16_t seqno, uint16_t metric,
                       uint64_t now_ms) {
    memcpy(ent + ENT_ID, ub_node_entity_id(rt->node, e), UB_ENTITY_ID_LEN);
    ub_put_u16le(ent + ENT_SEQNO, seqno);
    ub_put_u16le(ent + ENT_METRIC, metric);
    if (entity_local(rt, e) || metric == INF) return;
    ub_route_dest_t *ds = &rt->dests[slot][e];
    if (!ds->fd_valid || seq_newer(seqno, ds->fd_seqno) || (seqno == ds->fd_seqno && metric < ds->fd_metric)) {
        ds->fd_valid = 1;
        ds->fd_seqno = seqno;
        ds->fd_metric = metric;
    }
    ds->fd_touched_ms = now_ms;
    retime(rt, e);
    mark_dest(rt, slot, e); /* the feasibility distance may have moved */
}

/* The 24-byte hello part (docs/routing.md, "Frame layouts"). */
static void put_hello_part(const ub_route_t *rt, const ub_route_link_t *l, uint8_t *buf, uint16_t seq, unsigned n_upd,
                           unsigned n_req) {
    buf[OFF_VERSION] = UB_ROUTE_WIRE_VERSION;
    buf[OFF_FLAGS] = 0;
    ub_put_u16le(buf + OFF_HELLO_SEQ, seq);
    ub_put_u16le(buf + OFF_HELLO_MS, (uint16_t)rt->opt.hello_ms);
    ub_put_u16le(buf + OFF_UPDATE_MS, (uint16_t)rt->opt.update_ms);
    ub_put_u16le(buf + OFF_IHU_COST, rxcost_of(rt, l));
    buf[OFF_N_UPDATES] = (uint8_t)n_upd;
    buf[OFF_N_REQUESTS] = (uint8_t)n_req;
    if (l->nb_in_use) memcpy(buf + OFF_IHU_ID, l->nb_id, UB_ENTITY_ID_LEN);
    else memset(buf + OFF_IHU_ID, 0, UB_ENTITY_ID_LEN);
}

/* A fast hello (a link carrying the neighbour's traffic, docs/routing.md "Transport evidence"): a HELLO that
 * repeats the hello seqno of the last routing frame instead of taking a new one. The receiver's history counts
 * hellos per hello interval, so the repeats prove liveness (a gap in them is the neighbour's evidence) without
 * making the link cost more sensitive to a brief gap: a repeated seqno shifts nothing in (hello_heard(): one
 * step back, then the same bit again). The hello timer is left alone. */
static void send_fast_hello(ub_route_t *rt, int link_id, uint64_t now_ms) {
    ub_route_link_t *l = &rt->links[link_id];
    uint8_t buf[UB_ROUTE_HDR_LEN];
    put_hello_part(rt, l, buf, (uint16_t)(l->hello_seq - 1u), 0, 0);
    l->last_tx_ms = now_ms;
    if (ub_node_send_link_local(rt->node, link_id, UB_ADMIN_HELLO, buf, UB_ROUTE_HDR_LEN, now_ms) != 1) {
        l->stats.refused_out++;
        return;
    }
    l->stats.frames_out++;
    l->stats.bytes_out += UB_ROUTE_HDR_LEN;
    l->stats.hellos_out++;
    l->stats.fast_hellos_out++;
}

static void send_frame(ub_route_t *rt, int link_id, bool triggered, uint64_t now_ms) {
    const ub_link_t *link = node_link(rt, link_id);
    ub_route_link_t *l = &rt->links[link_id];
    int slot = link->owner;
    uint8_t bit = (uint8_t)(1u << link->index);
    uint8_t buf[UB_ROUTE_HDR_LEN + MAX_ENTRIES * UB_ROUTE_ENTRY_LEN];
    uint8_t reqs[UB_MAX_ENTITIES][UB_ROUTE_ENTRY_LEN];
    uint8_t in_frame[UB_MAX_ENTITIES] = {0};
    unsigned n_upd = 0, n_req = 0;
    uint16_t seqno, metric;

    /* Seqno requests first (they are what a starving neighbour waits for), then triggered entries, then a
     * slice of the full table when one is due. */
    for (int e = 0; rt->owed_req[slot][link->index] != 0 && e < UB_MAX_ENTITIES && n_req < MAX_ENTRIES; e++) {
        ub_route_dest_t *ds = &rt->dests[slot][e];
        if (!(ds->req_links & bit)) continue;
        set_owed(rt, slot, e, ds->dirty_links, (uint8_t)(ds->req_links & ~bit));
        if (!(ub_node_entity_id(rt->node, e) != NULL)) continue;
        memcpy(reqs[n_req] + ENT_ID, ub_node_entity_id(rt->node, e), UB_ENTITY_ID_LEN);
        ub_put_u16le(reqs[n_req] + ENT_SEQNO, ds->req_seqno);
        reqs[n_req][ENT_HOPS] = ds->req_hops;
        reqs[n_req][ENT_HOPS + 1] = 0;
        n_req++;
    }
    uint8_t *ent = buf + UB_ROUTE_HDR_LEN;
    /* Owed entries: the triggered ones, and those waiting for a regular frame (any frame that goes takes them). */
    for (int e = 0; rt->owed_dirty[slot][link->index] + rt->owed_lazy[slot][link->index] != 0 && e < UB_MAX_ENTITIES &&
                    n_upd + n_req < MAX_ENTRIES;
         e++) {
        ub_route_dest_t *ds = &rt->dests[slot][e];
        if (!((ds->dirty_links | ds->lazy_links) & bit)) continue;
        set_owed(rt, slot, e, (uint8_t)(ds->dirty_links & ~bit), ds->req_links);
        set_lazy(rt, slot, e, (uint8_t)(ds->lazy_links & ~bit));
        if (!advertised(rt, slot, e, &seqno, &metric)) continue;
        put_update(rt, slot, e, ent + n_upd * UB_ROUTE_ENTRY_LEN, seqno, metric, now_ms);
        in_frame[e] = 1;
        n_upd++;
    }
    if (l->dumping || now_ms >= l->dump_due_ms) {
        l->dumping = 1;
        while (l->dump_cursor < UB_MAX_ENTITIES && n_upd + n_req < MAX_ENTRIES) {
            int e = l->dump_cursor++;
            if (in_frame[e] || !advertised(rt, slot, e, &seqno, &metric)) continue;
            put_update(rt, slot, e, ent + n_upd * UB_ROUTE_ENTRY_LEN, seqno, metric, now_ms);
            n_upd++;
        }
        if (l->dump_cursor >= UB_MAX_ENTITIES) {
            l->dumping = 0;
            l->dump_cursor = 0;
            l->dump_due_ms = now_ms + rt->opt.update_ms;
        }
    }
    memcpy(ent + n_upd * UB_ROUTE_ENTRY_LEN, reqs, n_req * UB_ROUTE_ENTRY_LEN);

    put_hello_part(rt, l, buf, l->hello_seq++, n_upd, n_req);
    uint16_t len = (uint16_t)(UB_ROUTE_HDR_LEN + (n_upd + n_req) * UB_ROUTE_ENTRY_LEN);
    ub_admin_code_t code = n_upd + n_req > 0 ? UB_ADMIN_ROUTE_UPDATE : UB_ADMIN_HELLO;

    /* A regular hello sent early in a coalesced turn keeps its schedule (the rate stays 1000 / hello_ms); a late,
     * answering or triggered frame restarts it from now, as before. */
    l->next_hello_ms = (!triggered && l->next_hello_ms > now_ms ? l->next_hello_ms : now_ms) + rt->opt.hello_ms;
    l->last_tx_ms = now_ms;
    l->sent_any = 1;
    if (ub_node_send_link_local(rt->node, link_id, code, buf, len, now_ms) != 1) {
        l->stats.refused_out++;
        return;
    }
    l->stats.frames_out++;
    l->stats.bytes_out += len;
    l->stats.entries_out += n_upd;
    l->stats.requests_out += n_req;
    if (code == UB_ADMIN_HELLO) l->stats.hellos_out++;
    if (triggered) l->stats.triggered_out++;
}

/* Whether link[bit] of `slot` owes a triggered entry or a request (counted by set_owed()). */
static bool owes(const ub_route_t *rt, int slot, uint8_t bit) {
    unsigned i = (unsigned)__builtin_ctz(bit);
    return rt->owed_dirty[slot][i] != 0 || rt->owed_req[slot][i] != 0;
}

/* ---- timers ------------------------------------------------------------------------------------------ */

static void link_timers(ub_route_t *rt, int link_id, uint64_t now_ms) {
    ub_route_link_t *l = &rt->links[link_id];
    bool changed = false;
    while (l->nb_in_use && now_ms >= l->next_miss_ms) {
        /* An expected hello did not come (RFC 8966 3.4.1: the expected seqno moves on). */
        l->history <<= 1;
        if (l->samples < LOSS_MEMORY) l->samples++;
        l->expected_seq++;
        l->next_miss_ms += l->nb_hello_ms;
        changed = true;
        if (l->samples >= HISTORY_BITS && history_bits(l, HISTORY_BITS) == 0) {
            drop_neighbour(rt, link_id); /* silent for 16 intervals: forget it */
            l->stats.link_downs++;
            break;
        }
    }
    uint16_t cost = cost_of(rt, l);
    if (changed || cost != l->last_cost) {
        l->last_cost = cost;
        mark_slot(rt, link_id);
    }
}

static void route_timers(ub_route_t *rt, uint64_t now_ms) {
    /* Only the entities whose deadline has come (rt->timers); each loop below acts on them in table order, as
     * the scan of every entity did (the others have nothing due: every action here is one of their deadlines). */
    if (ub_timeheap_min(&rt->timers) > now_ms) return;
    uint16_t due[UB_MAX_ENTITIES];
    size_t n_due = ub_timeheap_due(&rt->timers, now_ms, due, UB_MAX_ENTITIES);
    /* Learned entities nobody advertises any more leave the table (a clock gone backwards waits). */
    for (size_t k = 0; k < n_due; k++) {
        int e = due[k];
        if (!rt->learned[e] || now_ms < rt->advertised_ms[e] || now_ms - rt->advertised_ms[e] < rt->opt.learn_expiry_ms)
            continue;
        rt->expiring = 1;
        int removed = ub_node_remove_entity(rt->node, e, now_ms); /* forgets its routes through route_forget_entity() */
        rt->expiring = 0;
        rt->learned[e] = 0;
        if (removed == UB_OK) rt->counters.learn_expired++;
    }
    for (size_t k = 0; k < n_due; k++) {
        int e = due[k];
        for (int lid = 0; lid < UB_MAX_NODE_LINKS; lid++) {
            ub_route_entry_t *r = &rt->routes[e][lid];
            if (!r->in_use || now_ms < r->expires_ms) continue;
            memset(r, 0, sizeof *r);
            rt->link_routes[lid]--;
            rt->counters.expired++;
            mark_slot(rt, lid);
        }
    }
    for (int slot = 0; slot < UB_MAX_LOCAL_ENTITIES; slot++) {
        if (!(ub_node_slot_entity(rt->node, slot) >= 0)) continue;
        for (size_t k = 0; k < n_due; k++) {
            int e = due[k];
            ub_route_dest_t *ds = &rt->dests[slot][e];
            if (ds->retracting && now_ms >= ds->retract_until_ms) ds->retracting = 0;
            if (ds->starve_at_ms != 0 && now_ms >= ds->starve_at_ms + rt->opt.hello_ms)
                rt->reselect[slot] = 1; /* still starving? selection asks again */
            mark_dest(rt, slot, e); /* its deadline came: what selection reads may have changed */
            if (ds->fd_valid && ds->sel_link < 0 && !ds->retracting && now_ms >= ds->fd_touched_ms + rt->opt.source_gc_ms) {
                bool any = false;
                for (int lid = 0; lid < UB_MAX_NODE_LINKS && !any; lid++) any = rt->routes[e][lid].in_use != 0;
                if (!any) ds->fd_valid = 0;
            }
        }
    }
    for (size_t k = 0; k < n_due; k++) retime(rt, due[k]);
}

/* ---- transport evidence (docs/routing.md, "Transport evidence") --------------------------------------- */

/* Silence after which a link whose recent largest gap between frames was `gap` is in doubt: half as long again,
 * plus scheduling slack. A brief gap only costs duplicates (every feasible successor is used), never a route. */
static uint64_t doubt_after(uint32_t gap) { return (uint64_t)gap + gap / 2u + 5u; }

/* Looks at the node's counters of link `lid`: a frame since the last look clears its doubt and measures the gap;
 * none for longer than its recent gaps predict puts it in doubt. Non-routing frames from the neighbour mean our
 * silence would be its evidence: hellos go at the fast interval. */
static uint32_t gap_estimate(const ub_route_link_t *l) { return l->gap_ms > l->gap_prev_ms ? l->gap_ms : l->gap_prev_ms; }

/* Whether link `l` may fall in doubt now: we send traffic over it (so its neighbour sends fast hellos, and a cut
 * costs us data), it is up, and a gap has been measured. */
static bool doubt_armed(const ub_route_link_t *l, uint64_t now_ms) {
    return !l->doubt && l->nb_in_use && l->last_cost != INF && now_ms < l->sending_until_ms && gap_estimate(l) > 0;
}

static void watch_link(ub_route_t *rt, int lid, const ub_link_t *link, uint64_t now_ms) {
    ub_route_link_t *l = &rt->links[lid];
    if (link->counters.frames_out - l->tx_seen > l->stats.frames_out - l->routing_tx_seen) {
        /* Traffic of ours crossed it: the neighbour keeps fast hellos for a hello interval after each frame; we
         * expect them for half of that (so the end of a flow is no gap). */
        l->sending_until_ms = now_ms + rt->opt.hello_ms / 2u;
    }
    l->tx_seen = link->counters.frames_out;
    l->routing_tx_seen = l->stats.frames_out;
    uint64_t acc = link->counters.frames_accepted;
    if (acc != l->rx_seen) {
        uint64_t routing = l->stats.frames_in - l->routing_seen;
        if (acc - l->rx_seen > routing) {
            l->carry_until_ms = now_ms + rt->opt.hello_ms;
        }
        if (l->last_rx_ms != 0 && now_ms > l->last_rx_ms) {
            /* Largest gap over the last one or two windows of a neighbour hello interval: a burst of triggered
             * frames never makes the next regular hello look late. */
            uint32_t gap = (uint32_t)(now_ms - l->last_rx_ms > 0xFFFFu ? 0xFFFFu : now_ms - l->last_rx_ms);
            uint32_t window = l->nb_hello_ms != 0 ? l->nb_hello_ms : rt->opt.hello_ms;
            if (now_ms >= l->gap_window_ms + window) {
                l->gap_prev_ms = l->gap_ms;
                l->gap_ms = 0;
                l->gap_window_ms = now_ms;
            }
            /* A gap longer than the neighbour's hello timer allows was an outage, not its rhythm. */
            if (gap <= window + window / 2u && gap > l->gap_ms) l->gap_ms = gap;
        }
        l->rx_seen = acc;
        l->routing_seen = l->stats.frames_in;
        l->last_rx_ms = now_ms;
        if (l->doubt) {
            l->doubt = 0;
            mark_slot(rt, lid);
        }
    } else if (doubt_armed(l, now_ms) && now_ms >= l->last_rx_ms + doubt_after(gap_estimate(l))) {
        l->doubt = 1;
        rt->counters.link_doubts++;
        mark_slot(rt, lid);
    }
}

/* Transport evidence from a driver or the frame path (ub_node_link_event()). DOWN takes the link down now, as
 * `dead_misses` missed hellos would: routes switch to their feasible alternatives at the next tick (the call may
 * come from inside a send, so nothing is sent or chosen here). The neighbour and its routes are kept: its next
 * hello brings the link back with a fresh history. UP: say hello at once. */
static void route_link_event(const ub_service_t *svc, ub_node_t *node, int link_id, ub_link_event_t ev,
                             uint64_t now_ms) {
    (void)node;
    ub_route_t *rt = svc->user;
    if (link_id < 0 || link_id >= UB_MAX_NODE_LINKS || !rt->links[link_id].active) return;
    ub_route_link_t *l = &rt->links[link_id];
    if (ev == UB_LINK_EVENT_UP) {
        l->next_hello_ms = now_ms;
        return;
    }
    if (!l->nb_in_use || link_dead(rt, l)) return;
    l->history = 0;
    if (l->samples < rt->opt.dead_misses) l->samples = rt->opt.dead_misses;
    l->doubt = 0;
    rt->counters.link_evidence_down++;
    mark_slot(rt, link_id);
}

/* Timers and sending; called from ub_node_tick(). */
static void route_tick(const ub_service_t *svc, ub_node_t *node, uint64_t now_ms) {
    (void)node;
    ub_route_t *rt = svc->user;
    for (int lid = 0; lid < UB_MAX_NODE_LINKS; lid++) {
        const ub_link_t *link = node_link(rt, lid);
        if (link == NULL) continue;
        activate(rt, lid, now_ms);
        watch_link(rt, lid, link, now_ms);
        link_timers(rt, lid, now_ms);
    }
    route_timers(rt, now_ms);
    for (int slot = 0; slot < UB_MAX_LOCAL_ENTITIES; slot++)
        if ((ub_node_slot_entity(rt->node, slot) >= 0) && rt->reselect[slot]) reselect_slot(rt, slot, now_ms);
    for (int lid = 0; lid < UB_MAX_NODE_LINKS; lid++) {
        const ub_link_t *link = node_link(rt, lid);
        if (link == NULL || link->ops == NULL) continue; /* detached: the neighbour will time us out */
        ub_route_link_t *l = &rt->links[lid];
        /* Timer coalescing (issue 28 item 5, docs/routing.md "Timer coalescing"): a hello due within the slack
         * goes in this turn, which is awake anyway (a frame arrived, the publication is due), instead of a turn of
         * its own a few ms later. Early only, never late: the gaps the neighbour learns can only shrink, so its
         * doubt comes no later; the missed-hello and doubt timers have no slack. */
        uint64_t slack = rt->opt.coalesce_ms;
        bool due = now_ms + slack >= l->next_hello_ms;
        bool trigger = !due && now_ms >= l->last_tx_ms + rt->opt.trigger_gap_ms &&
                       owes(rt, link->owner, (uint8_t)(1u << link->index));
        if (due || trigger) send_frame(rt, lid, trigger, now_ms);
        else if (l->sent_any && now_ms < l->carry_until_ms && now_ms + slack >= l->last_tx_ms + rt->opt.fast_hello_ms)
            send_fast_hello(rt, lid, now_ms);
        /* Frames of ours that are all routing frames are noted here, as watch_link() would note them at the next
         * tick (only data extends sending_until_ms); left for it, route_next_due() would call that tick due at
         * once, a second wake-up for every hello (issue 28 item 5: a process sleeping until its due time). */
        if (link->counters.frames_out - l->tx_seen == l->stats.frames_out - l->routing_tx_seen) {
            l->tx_seen = link->counters.frames_out;
            l->routing_tx_seen = l->stats.frames_out;
        }
    }
}

static void earliest(uint64_t *best, uint64_t t) {
    if (t < *best) *best = t;
}

/* The next time route_tick() has work (ub_service.h `next_due`): hellos (fast ones on carrying links), triggered
 * frames, missed-hello timers, doubt deadlines, route and learned-entity expiry, retractions, starvation retries,
 * feasibility-distance collection. A frame the node accepted since the last tick makes it due at once (the tick
 * measures gaps from it). */
static bool route_next_due(const ub_service_t *svc, const ub_node_t *node, uint64_t now_ms, uint64_t *due_ms) {
    (void)node;
    const ub_route_t *rt = svc->user;
    uint64_t best = UINT64_MAX;
    for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++)
        if (rt->reselect[s] && ub_node_slot_entity(rt->node, s) >= 0) earliest(&best, now_ms);
    for (int lid = 0; lid < UB_MAX_NODE_LINKS && best > now_ms; lid++) {
        const ub_link_t *link = node_link(rt, lid);
        if (link == NULL) continue;
        const ub_route_link_t *l = &rt->links[lid];
        if (!l->active || link->counters.frames_accepted != l->rx_seen) {
            earliest(&best, now_ms);
            break;
        }
        if (l->nb_in_use) earliest(&best, l->next_miss_ms);
        if (doubt_armed(l, now_ms)) earliest(&best, l->last_rx_ms + doubt_after(gap_estimate(l)));
        if (link->counters.frames_out != l->tx_seen) earliest(&best, now_ms); /* the tick notes what we sent */
        if (link->ops == NULL) continue;
        earliest(&best, l->next_hello_ms);
        if (l->sent_any && now_ms < l->carry_until_ms) earliest(&best, l->last_tx_ms + rt->opt.fast_hello_ms);
        if (owes(rt, link->owner, (uint8_t)(1u << link->index))) earliest(&best, l->last_tx_ms + rt->opt.trigger_gap_ms);
    }
    earliest(&best, ub_timeheap_min(&rt->timers)); /* every entity's deadlines (entity_deadline()) */
    *due_ms = best;
    return best != UINT64_MAX;
}

/* ---- membership hooks -------------------------------------------------------------------------------- */

/* Entity-table row `entity` is being removed, with this ID: forget every route, feasibility distance and
 * request about it, and do not learn it again for a while. */
static void route_forget_entity(const ub_service_t *svc, ub_node_t *node, int entity,
                                const uint8_t id[UB_ENTITY_ID_LEN], uint64_t now_ms) {
    (void)node;
    ub_route_t *rt = svc->user;
    if (entity < 0 || entity >= UB_MAX_ENTITIES) return;
    for (int lid = 0; lid < UB_MAX_NODE_LINKS; lid++) {
        if (rt->routes[entity][lid].in_use) rt->link_routes[lid]--;
        memset(&rt->routes[entity][lid], 0, sizeof(ub_route_entry_t));
    }
    for (int slot = 0; slot < UB_MAX_LOCAL_ENTITIES; slot++) {
        set_owed(rt, slot, entity, 0, 0);
        set_lazy(rt, slot, entity, 0);
        memset(&rt->dests[slot][entity], 0, sizeof(ub_route_dest_t));
        rt->dests[slot][entity].sel_link = -1;
        mark_dest(rt, slot, entity);
    }
    rt->learned[entity] = 0;
    retime(rt, entity);
    if (rt->expiring) return; /* nobody advertised it for learn_expiry_ms: it may be learned again at once */
    /* Neighbours keep advertising it until their routes expire: do not learn it back meanwhile. */
    size_t victim = 0;
    for (size_t i = 0; i < UB_ROUTE_TOMBSTONES; i++)
        if (rt->tomb[i].until_ms < rt->tomb[victim].until_ms) victim = i;
    memcpy(rt->tomb[victim].id, id, UB_ENTITY_ID_LEN);
    rt->tomb[victim].until_ms = now_ms + 4u * (uint64_t)rt->opt.update_ms;
}

/* Local slot `slot` set a mask by hand (pinned or unpinned): choose its routes again at the next tick, so an
 * unpinned entry is filled at once. */
static void route_mask_set(const ub_service_t *svc, ub_node_t *node, int slot) {
    (void)node;
    ub_route_t *rt = svc->user;
    if (slot >= 0 && slot < UB_MAX_LOCAL_ENTITIES) rt->reselect[slot] = rt->resel_full[slot] = 1;
}

/* Link slot `link_id` is being removed: forget its neighbour and the routes through it. */
static void route_forget_link(const ub_service_t *svc, ub_node_t *node, int link_id, uint64_t now_ms) {
    (void)node;
    ub_route_t *rt = svc->user;
    (void)now_ms;
    if (link_id < 0 || link_id >= UB_MAX_NODE_LINKS) return;
    const ub_link_t *link = node_link(rt, link_id);
    drop_neighbour(rt, link_id);
    if (link != NULL) {
        uint8_t bit = (uint8_t)(1u << link->index);
        for (int e = 0; e < UB_MAX_ENTITIES; e++) {
            ub_route_dest_t *ds = &rt->dests[link->owner][e];
            set_owed(rt, link->owner, e, (uint8_t)(ds->dirty_links & ~bit), (uint8_t)(ds->req_links & ~bit));
            set_lazy(rt, link->owner, e, (uint8_t)(ds->lazy_links & ~bit));
            ds->asked_links &= (uint8_t)~bit;
        }
    }
    memset(&rt->links[link_id], 0, sizeof rt->links[link_id]);
}

static bool route_on_service_frame(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx,
                                   const ub_frame_header_t *h, const uint8_t *payload, uint64_t now_ms,
                                   ub_drop_reason_t *drop) {
    (void)node;
    (void)drop; /* bad_payload */
    return route_on_frame(svc->user, rx->link_id, h, payload, now_ms) >= 0;
}

static const uint8_t route_codes[] = {UB_ADMIN_HELLO, UB_ADMIN_ROUTE_UPDATE};

/* ---- API --------------------------------------------------------------------------------------------- */

int ub_route_attach(ub_route_t *rt, ub_node_t *node, const ub_route_options_t *opt, uint64_t now_ms) {
    (void)now_ms;
    if (rt == NULL || node == NULL) return UB_ERR_INVAL;
    ub_route_options_t o = {0};
    if (opt != NULL) o = *opt;
    if (o.hello_ms == 0) o.hello_ms = DEFAULT_HELLO_MS;
    if (o.update_ms == 0) o.update_ms = 4u * o.hello_ms > 0xFFFFu ? 0xFFFFu : 4u * o.hello_ms;
    if (o.trigger_gap_ms == 0) o.trigger_gap_ms = o.hello_ms / 20u > 0 ? o.hello_ms / 20u : 1u;
    if (o.source_gc_ms == 0) o.source_gc_ms = 16u * o.update_ms;
    if (o.learn_expiry_ms == 0) o.learn_expiry_ms = o.source_gc_ms;
    if (o.dead_misses == 0) o.dead_misses = 2;
    if (o.max_dests == 0) o.max_dests = UB_ROUTE_MAX_DESTS_PER_NEIGHBOUR;
    if (o.fast_hello_ms == 0) o.fast_hello_ms = o.hello_ms / 8u < 10u ? 10u : o.hello_ms / 8u;
    if (o.fast_hello_ms > o.hello_ms) o.fast_hello_ms = o.hello_ms;
    if (o.coalesce_ms == UB_ROUTE_COALESCE_AUTO)
        o.coalesce_ms = o.fast_hello_ms / 8u < UB_ROUTE_COALESCE_MAX_MS ? o.fast_hello_ms / 8u : UB_ROUTE_COALESCE_MAX_MS;
    if (o.hello_ms < 10u || o.hello_ms > 0xFFFFu || o.update_ms < o.hello_ms || o.update_ms > 0xFFFFu ||
        o.fast_hello_ms < 10u || o.coalesce_ms > o.fast_hello_ms / 8u || o.dead_misses > HISTORY_BITS || o.parallel > UB_ROUTE_PARALLEL_BEST || o.max_dests > UB_MAX_ENTITIES)
        return UB_ERR_INVAL;
    /* One routing engine per node: a second attach takes the routing codes over, as it always did. */
    const ub_service_t *prev = ub_node_service_for(node, UB_SVC_LINK_LOCAL, UB_ADMIN_HELLO);
    if (prev != NULL && ub_node_remove_service(node, prev) != UB_OK) return UB_ERR_INVAL;
    memset(rt, 0, sizeof *rt);
    ub_timeheap_init(&rt->timers);
    rt->node = node;
    rt->opt = o;
    for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++) {
        rt->seqno[s] = o.initial_seqno;
        rt->resel_full[s] = 1;
        for (int e = 0; e < UB_MAX_ENTITIES; e++) rt->dests[s][e].sel_link = -1;
    }
    rt->svc = (ub_service_t){.name = "route",
                             .link_local_codes = route_codes,
                             .n_link_local_codes = sizeof route_codes,
                             .order = UB_SVC_ORDER_ROUTE,
                             .on_frame = route_on_service_frame,
                             .tick = route_tick,
                             .forget_entity = route_forget_entity,
                             .forget_link = route_forget_link,
                             .mask_set = route_mask_set,
                             .link_event = route_link_event,
                             .next_due = route_next_due,
                             .user = rt};
    int rc = ub_node_add_service(node, &rt->svc);
    if (rc != UB_OK) {
        rt->node = NULL; /* not attached (a full service table): the engine attached before keeps routing */
        if (prev != NULL && ub_node_add_service(node, prev) != UB_OK) {
            /* cannot fail: its codes were just freed */
        }
    }
    return rc;
}

void ub_route_detach(ub_route_t *rt) {
    if (rt == NULL || rt->node == NULL) return;
    ub_node_t *node = rt->node;
    for (int slot = 0; slot < UB_MAX_LOCAL_ENTITIES; slot++) {
        int self = ub_node_slot_entity(node, slot);
        if (self < 0) continue;
        for (int e = 0; e < UB_MAX_ENTITIES; e++) {
            if ((ub_node_entity_id(node, e) != NULL) && !ub_node_mask_pinned(node, self, e) && e != self &&
                ub_node_set_auto_mask(node, self, e, 0) != UB_OK) {
                /* cannot fail: an unpinned entry toward a known entity */
            }
            if (e != self && ub_node_set_bounce_mask(node, self, e, 0) != UB_OK) {
                /* cannot fail: mask 0 toward another entity-table row */
            }
        }
    }
    if (ub_node_remove_service(node, &rt->svc) != UB_OK) {
        /* another engine took over (ub_route_attach() again): nothing of ours to remove */
    }
    rt->node = NULL;
}

int ub_route_get(const ub_route_t *rt, int entity, int dest, ub_route_info_t *out) {
    if (rt == NULL || rt->node == NULL || out == NULL) return UB_ERR_INVAL;
    int slot = ub_node_entity_slot(rt->node, entity);
    if (slot < 0 || ub_node_entity_id(rt->node, dest) == NULL) return UB_ERR_INVAL;
    memset(out, 0, sizeof *out);
    const ub_route_dest_t *ds = &rt->dests[slot][dest];
    out->local = entity_local(rt, dest);
    out->learned = rt->learned[dest] != 0;
    out->pinned = ub_node_mask_pinned(rt->node, entity, dest);
    out->link_id = out->local ? -1 : ds->sel_link;
    out->reachable = !out->local && ds->sel_link >= 0;
    out->retracting = ds->retracting != 0;
    out->metric = out->local ? 0 : (out->reachable ? ds->metric : (uint16_t)INF);
    out->seqno = out->local ? rt->seqno[ub_node_entity_slot(rt->node, dest)] : ds->seqno;
    out->mask = out->local ? 0 : ds->mask;
    out->fd_valid = ds->fd_valid != 0;
    out->fd_seqno = ds->fd_seqno;
    out->fd_metric = ds->fd_metric;
    if (out->reachable) memcpy(out->next_hop, rt->links[ds->sel_link].nb_id, UB_ENTITY_ID_LEN);
    bool unfeasible = false;
    for (unsigned i = 0; i < UB_MAX_LINKS_PER_ENTITY; i++) {
        int lid = slot_link(rt, slot, i);
        if (lid < 0 || !rt->routes[dest][lid].in_use) continue;
        const ub_route_entry_t *r = &rt->routes[dest][lid];
        out->routes++;
        bool up = r->metric != INF && cost_of(rt, &rt->links[lid]) != INF;
        if (up && feasible(ds, r->seqno, r->metric)) out->feasible++;
        else if (up) unfeasible = true;
    }
    out->starving = !out->local && !out->reachable && unfeasible;
    return UB_OK;
}

int ub_route_link_info(const ub_route_t *rt, int link_id, ub_route_link_info_t *out) {
    if (rt == NULL || rt->node == NULL || out == NULL || node_link(rt, link_id) == NULL) return UB_ERR_INVAL;
    const ub_route_link_t *l = &rt->links[link_id];
    memset(out, 0, sizeof *out);
    out->neighbour = l->nb_in_use != 0;
    memcpy(out->neighbour_id, l->nb_id, UB_ENTITY_ID_LEN);
    out->rxcost = rxcost_of(rt, l);
    out->txcost = l->active ? l->txcost : (uint16_t)INF;
    out->cost = cost_of(rt, l);
    out->history = (uint16_t)history_bits(l, HISTORY_BITS);
    out->samples = (uint8_t)etx_samples(l);
    out->neighbour_hello_ms = l->nb_hello_ms;
    out->stats = l->stats;
    return UB_OK;
}

const ub_route_counters_t *ub_route_counters(const ub_route_t *rt) { return rt == NULL ? NULL : &rt->counters; }

uint16_t ub_route_seqno(const ub_route_t *rt, int entity) {
    if (rt == NULL || rt->node == NULL) return 0;
    int slot = ub_node_entity_slot(rt->node, entity);
    return slot < 0 ? 0 : rt->seqno[slot];
}
