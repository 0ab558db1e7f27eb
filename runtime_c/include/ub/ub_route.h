/**
 * @file ub_route.h
 * @brief Automatic routes (paper VI, future work): a Babel-like (RFC 8966)
 *        loop-free distance-vector protocol that fills a node's link masks.
 *
 * The paper's entities are told their links *and* which links lead to every
 * other entity (`linktoentity`, Table 1). Its future work asks for the second
 * half to be computed: "the entities should only know about the local links
 * available but not who is listening at the other end. The fields
 * `linktoentity` could get filled by some optimization algorithm ... dynamic".
 * ub_route does that, opt-in per node: attach one to a node and every
 * local entity runs as a router over its own links.
 *
 * Protocol (docs/routing.md has the frame layouts, timers and rationale):
 *  - Every hello interval each link carries exactly one routing frame, sent
 *    *link-local* (ub_node_send_link_local(): to whoever is at the other end,
 *    hop limit 1, never forwarded): a HELLO, or a ROUTE_UPDATE when it also
 *    carries route entries. Both carry the hello part: a per-link hello
 *    sequence number and an IHU ("I heard you": the sender's receive cost of
 *    the receiver), so the receiver knows the loss in both directions.
 *  - Link cost is ETX-like (RFC 8966 A.2.2): from the last 16 hellos, beta =
 *    fraction received; rxcost = 256 / beta; cost = max(txcost, 256) * rxcost
 *    / 256, txcost being the neighbour's rxcost for us. A loss-free link
 *    costs 256. A link is down (infinite cost) when the last `dead_misses`
 *    expected hellos were missed -- one more for each hello lost before those
 *    among the last 32 expected, at most `dead_misses` more, so a lossy
 *    link's usual runs of loss do not take it down -- or when the neighbour
 *    does not hear us.
 *  - Routes: a destination is an entity; it is its own Babel "source" with a
 *    16-bit sequence number. Route entries are (destination, seqno, metric)
 *    per link; metric of a route = link cost + advertised metric.
 *  - Loop freedom by the feasibility condition: per (local entity,
 *    destination) the feasibility distance FD = (seqno, metric) of the
 *    smallest metric advertised for the newest seqno. An update (s, m) is
 *    feasible when there is no FD, m is infinite (a retraction), s is newer
 *    than FD's seqno, or s equals it and m < FD's metric. Only feasible routes
 *    are selected, so the next-hop graph never has a cycle, even while the
 *    network reconverges. An unfeasible update for the selected route at the
 *    same seqno (its neighbour's metric rose), with no feasible alternative,
 *    is held back (RFC 8966 3.5.4): the entry keeps its last metric, unrefreshed,
 *    until a feasible update refreshes it or it expires.
 *  - Starvation: with no feasible route but unfeasible ones, the entity sends
 *    a seqno request (seqno FD + 1) to its neighbours; routers forward it
 *    toward the destination along their selected routes, and the destination
 *    (or its node) raises its seqno, which makes the new routes feasible.
 *  - Full tables every `update_ms` (in slices riding on the hello frames);
 *    triggered updates when a route appears, disappears or changes seqno or
 *    a lot of metric (at most one triggered frame per link per
 *    `trigger_gap_ms`). Routes expire 3.5 update intervals after their last
 *    refresh; a silent neighbour's routes go with its link.
 *  - Parallel links to one neighbour (the paper's 0x11): policy
 *    UB_ROUTE_PARALLEL_ALL puts every usable link to the chosen next hop in
 *    the mask (redundancy; the receiver's duplicate window keeps one copy),
 *    UB_ROUTE_PARALLEL_BEST only the cheapest.
 *  - Masks are written with ub_node_set_auto_mask(): an entry the operator
 *    set by hand (pinned) is never overwritten.
 *  - Learning: an update for an entity missing from the node's entity table
 *    adds it as a remote entity (unless `no_learn`), so relays can forward to
 *    vehicles nobody announced to them. An entity removed with
 *    ub_node_remove_entity() is not learned again for 4 update intervals.
 *    A learned entity that no update has advertised a route to (a
 *    retraction is no route) for `learn_expiry_ms` is removed again
 *    (`learn_expired`), so entities from forged or stale updates do not
 *    fill the entity table for good (issue 29).
 *  - Insiders (docs/security.md, "Routing from insiders"): one neighbour may
 *    have route entries for at most `max_dests` destinations; entries for
 *    further ones are ignored before they are learned (`neighbour_limit`),
 *    so one key holder cannot fill the route or entity table. An optional
 *    `accept_dest` filter can refuse destinations (`dest_refused`), e.g.
 *    entities no certificate names. False metrics within the bound are NOT
 *    detected: they attract traffic (loss of availability, not forgery).
 *
 * All state is in the caller-owned ub_route_t (fixed size from ub_config.h,
 * no allocation). Time comes only from ub_node_tick() and the receive path.
 * Routing frames are ordinary frames to the node: they get its sequence
 * numbers, tap, counters and (with the trust work) its signatures.
 *
 *     static ub_route_t rt;
 *     ub_route_options_t ro = {.hello_ms = 1000, .parallel = UB_ROUTE_PARALLEL_ALL};
 *     if (ub_route_attach(&rt, &node, &ro, now_ms) != UB_OK) ...
 *     ... ub_node_tick(&node, now_ms) drives it ...
 *     ub_route_info_t ri; ub_route_get(&rt, self, dest, &ri);   // what it chose
 */
#ifndef UB_ROUTE_H
#define UB_ROUTE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "ub_config.h"
#include "ub_error.h"
#include "ub_node.h"
#include "ub_timeheap.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Metric and cost of "unreachable". */
#define UB_ROUTE_INFINITY 0xFFFFu
/** Cost of a loss-free link. */
#define UB_ROUTE_LINK_COST 256u
/** Hop count put in an originated seqno request. */
#define UB_ROUTE_REQUEST_HOPS 16u
/** Version byte of the routing payload (docs/routing.md). */
#define UB_ROUTE_WIRE_VERSION 1u
/** Bytes before the entries of a HELLO / ROUTE_UPDATE payload, and bytes per entry. */
#define UB_ROUTE_HDR_LEN 24u
#define UB_ROUTE_ENTRY_LEN 16u
/** ub_route_options_t.coalesce_ms: an eighth of the fast hello interval, at most UB_ROUTE_COALESCE_MAX_MS (16 ms:
 *  about an eighth of the default fast hello interval at the default 1 s hello). */
#define UB_ROUTE_COALESCE_AUTO UINT32_MAX
#define UB_ROUTE_COALESCE_MAX_MS 16u

/** How parallel links to the chosen next hop are used. */
typedef enum ub_route_parallel {
    UB_ROUTE_PARALLEL_ALL = 0, /**< every usable link to the next hop (the paper's 0x11: redundancy) */
    UB_ROUTE_PARALLEL_BEST = 1 /**< only the cheapest link */
} ub_route_parallel_t;

/** Options; 0 in a field means its default. */
typedef struct ub_route_options {
    uint32_t hello_ms;       /**< hello interval, 10..65535; default 1000 */
    uint32_t update_ms;      /**< full-table interval, >= hello_ms, <= 65535; default 4 * hello_ms */
    uint32_t trigger_gap_ms; /**< least time between two frames on one link for triggered updates; default hello_ms / 20 */
    uint32_t source_gc_ms;   /**< forget a feasibility distance unused this long; default 16 * update_ms */
    uint8_t dead_misses;     /**< consecutive missed hellos that take a loss-free link down (+1 per hello lost before, at most 2x), 1..16; default 2 */
    uint8_t parallel;        /**< ub_route_parallel_t; default UB_ROUTE_PARALLEL_ALL */
    uint8_t no_learn;        /**< 1: never add entities to the table from updates */
    uint16_t initial_seqno;  /**< first seqno of every local entity; default 0 */
    uint32_t learn_expiry_ms; /**< a learned entity no update advertised a route to this long is removed; default source_gc_ms */
    uint16_t max_dests;      /**< destinations one neighbour may have route entries for (new ones beyond: ignored,
                                  `neighbour_limit`); 1..UB_MAX_ENTITIES, default UB_ROUTE_MAX_DESTS_PER_NEIGHBOUR */
    /** Optional filter, asked before an advertised destination gets a route entry (or is learned): false
     *  ignores the entry (`dest_refused`). Generic on purpose: the application decides -- e.g. "only
     *  entities the identity store certifies" or "metric 0 only for the neighbour itself". NULL: all accepted.
     *  `neighbour` is the advertising entity, `metric` the advertised metric (UB_ROUTE_INFINITY: retraction). */
    bool (*accept_dest)(void *user, const uint8_t dest[UB_ENTITY_ID_LEN], const uint8_t neighbour[UB_ENTITY_ID_LEN],
                        uint16_t metric);
    void *accept_user;
    /** Hello interval on a link that carries the neighbour's traffic toward us (non-routing frames arrived on it
     *  within the last hello interval), so that the neighbour notices a cut from the gap in our frames within a
     *  few of these instead of a few hello intervals (docs/routing.md, "Transport evidence"). The advertised
     *  interval stays hello_ms: the neighbour's hello timeout is unchanged. 10..hello_ms; default hello_ms / 8
     *  (at least 10); hello_ms: off. */
    uint32_t fast_hello_ms;
    /** Timer coalescing (docs/routing.md "Timer coalescing"), for a caller that sleeps until ub_node_next_due(): a
     *  regular or fast hello due within this many ms goes in the current tick (awake anyway for a frame or another
     *  timer) instead of a wake-up of its own. Hellos only ever go early by it, never late (the gaps a neighbour
     *  learns can only shrink); a regular hello sent early keeps its schedule; missed-hello and doubt timers
     *  have no slack. A tick up to this early may then send a hello (ub_node_next_due() stays the deadline).
     *  0: off (exact); UB_ROUTE_COALESCE_AUTO; at most fast_hello_ms / 8. */
    uint32_t coalesce_ms;
} ub_route_options_t;

/** Per-link routing counters. */
typedef struct ub_route_link_stats {
    uint64_t frames_out;     /**< routing frames the transport accepted (HELLO + ROUTE_UPDATE) */
    uint64_t hellos_out;     /**< of which HELLO */
    uint64_t triggered_out;  /**< of which sent before their hello was due (triggered updates, answers) */
    uint64_t entries_out;    /**< route entries sent */
    uint64_t requests_out;   /**< seqno requests sent */
    uint64_t bytes_out;      /**< payload bytes of the accepted frames */
    uint64_t refused_out;    /**< routing frames the transport refused (counted by the node too) */
    uint64_t frames_in;      /**< routing frames received and parsed */
    uint64_t entries_in;
    uint64_t requests_in;
    uint64_t bad_in;         /**< unusable routing payloads (also counted bad_payload by the node) */
    uint64_t neighbour_changes; /**< a different entity started answering on this link */
    uint64_t link_downs;     /**< the neighbour went silent for 16 hello intervals and was forgotten */
    uint64_t over_limit_in;  /**< entries ignored: the neighbour already had max_dests destinations */
    uint64_t fast_hellos_out; /**< of hellos_out, the fast ones on a link carrying the neighbour's traffic (a repeated
                                   hello seqno: liveness evidence, docs/routing.md "Transport evidence") */
} ub_route_link_stats_t;

/** Engine-wide counters. */
typedef struct ub_route_counters {
    uint64_t route_changes;       /**< a selected next hop changed */
    uint64_t routes_found;        /**< a destination became reachable */
    uint64_t routes_lost;         /**< a destination became unreachable (retraction sent) */
    uint64_t unfeasible;          /**< updates refused by the feasibility condition */
    uint64_t expired;             /**< route entries that expired */
    uint64_t starvation_requests; /**< seqno requests originated */
    uint64_t requests_forwarded;
    uint64_t requests_answered;
    uint64_t requests_dropped;    /**< requests with nowhere to go (no route, hop count spent) */
    uint64_t seqno_bumps;         /**< own seqno raised for a request */
    uint64_t learned;             /**< entities added to the table from updates */
    uint64_t learn_full;          /**< could not learn: entity table full */
    uint64_t learn_refused;       /**< not learned: no_learn, or removed recently */
    uint64_t learn_expired;       /**< learned entities removed: no update advertised a route to them for learn_expiry_ms */
    uint64_t pinned_skips;        /**< masks not written because the operator pinned them */
    uint64_t neighbour_limit;     /**< entries ignored: their neighbour already advertised max_dests destinations */
    uint64_t dest_refused;        /**< entries ignored: the accept_dest filter refused the destination */
    uint64_t link_evidence_down;  /**< links taken down at once by transport evidence (ub_node_link_event()) */
    uint64_t link_doubts;         /**< links put in doubt by a gap in their neighbour's frames */
    /* Why routes were lost (the four sum to routes_lost): what had become of the selected route. */
    uint64_t lost_link_down;      /**< its link went down (missed hellos, no IHU, a link event) */
    uint64_t lost_entry_gone;     /**< its entry expired or its neighbour was forgotten */
    uint64_t lost_retracted;      /**< its neighbour retracted it */
    uint64_t lost_unfeasible;     /**< its neighbour's metric rose to our feasibility distance or above */
    /* Why entries were owed to links (per destination and link; a triggered frame carries every owed one). */
    uint64_t owed_route_change;   /**< triggered: a route appeared, was lost, or its metric changed a lot */
    uint64_t owed_seqno_asked;    /**< triggered: a new seqno toward a neighbour that asked for it */
    uint64_t owed_request_answer; /**< triggered: answering a neighbour's request with our route or own seqno */
    uint64_t seqno_deferred;      /**< not triggered: a new seqno nobody on that link asked for, carried by the
                                       link's next regular frame (RFC 8966 3.7.2) */
    uint64_t requests_suppressed; /**< requests not forwarded: the same seqno (or an older one) was forwarded less than
                                       a hello interval ago or is still waiting to go (its asker is remembered) */
    uint64_t unfeasible_held;     /**< updates for the selected route held back: its neighbour's metric rose, at the same
                                       seqno, to our feasibility distance or above with no feasible alternative left
                                       (RFC 8966 3.5.4; the entry keeps its metric and expires unless refreshed) */
} ub_route_counters_t;

/** Per-link state. Private: read it with ub_route_link_info(). */
typedef struct ub_route_link {
    uint8_t active;          /* initialised for the slot's current link */
    uint8_t nb_in_use;
    uint8_t nb_id[UB_ENTITY_ID_LEN];
    uint8_t samples;         /* valid bits of history, <= 32 (the ETX window is the last 16) */
    uint8_t dumping;         /* a full table is being sent in slices */
    uint16_t dump_cursor;    /* next entity index of the slice (UB_MAX_ENTITIES may exceed 255) */
    uint8_t sent_any;
    uint32_t history;        /* bit 0 = most recent expected hello: 1 heard, 0 missed */
    uint16_t expected_seq;
    uint16_t txcost;         /* neighbour's rxcost for us (its IHU), UB_ROUTE_INFINITY if none */
    uint16_t hello_seq;      /* ours on this link */
    uint16_t last_cost;
    uint32_t nb_hello_ms;
    uint32_t nb_update_ms;
    uint64_t next_miss_ms;
    uint64_t next_hello_ms;
    uint64_t last_tx_ms;
    uint64_t dump_due_ms;
    /* Transport evidence and frame gaps (docs/routing.md, "Transport evidence"). */
    uint8_t doubt;           /* silent for longer than its recent frames predicted: routes over it use every
                                feasible successor until a frame arrives or the hello timeout decides */
    uint32_t gap_ms;         /* largest gap between the neighbour's frames in the current window */
    uint32_t gap_prev_ms;    /* ... in the window before (the estimate is the larger: bursts never lower it) */
    uint64_t gap_window_ms;  /* start of the current window (one neighbour hello interval long) */
    uint64_t rx_seen;        /* the node's frames_accepted counter of the link at the last look */
    uint64_t routing_seen;   /* stats.frames_in at the last look */
    uint64_t tx_seen;        /* the node's frames_out counter of the link at the last look */
    uint64_t routing_tx_seen; /* stats.frames_out at the last look */
    uint64_t sending_until_ms; /* we send traffic over this link: its neighbour sends fast hellos, a gap means doubt */
    uint64_t last_rx_ms;     /* when a frame was last seen arriving (at tick granularity) */
    uint64_t carry_until_ms; /* the neighbour's traffic crosses this link toward us: fast hellos until then */
    ub_route_link_stats_t stats;
} ub_route_link_t;

/** A route entry: what the neighbour on one link advertised for one destination. Private. */
typedef struct ub_route_entry {
    uint8_t in_use;
    uint16_t seqno;
    uint16_t metric;         /* as advertised (without our link cost) */
    uint64_t expires_ms;
} ub_route_entry_t;

/** Per (local entity, destination) state. Private: read it with ub_route_get(). */
typedef struct ub_route_dest {
    int8_t sel_link;         /* selected link id, -1 none */
    uint8_t retracting;      /* lost: advertising the retraction until retract_until_ms */
    uint8_t fd_valid;
    uint8_t dirty_links;     /* bit i: link[i] still owes a triggered entry */
    uint8_t req_links;       /* bit i: a seqno request is to go on link[i] */
    uint8_t lazy_links;      /* bit i: link[i] owes an entry at its next regular frame, not a triggered one (a new
                                seqno nobody on that link asked for: RFC 8966 3.7.2) */
    uint8_t asked_links;     /* bit i: the neighbour on link[i] asked for seqno >= asked_seqno (a request we forwarded
                                or suppressed as a duplicate): the new seqno goes to it as a triggered entry */
    uint16_t asked_seqno;
    uint8_t req_hops;
    uint8_t mask;            /* last mask computed */
    uint8_t bounce;          /* last bounce mask written (ub_node_set_bounce_mask()) */
    uint16_t metric;         /* advertised metric */
    uint16_t seqno;          /* advertised seqno */
    uint16_t fd_seqno;
    uint16_t fd_metric;
    uint16_t req_seqno;
    uint64_t retract_until_ms;
    uint64_t fd_touched_ms;
    uint64_t req_at_ms;      /* last request forwarded */
    uint64_t starve_at_ms;   /* last request originated while starving (0: not starving) */
} ub_route_dest_t;

/** An entity removed recently, not to be learned again before `until_ms`. Private. */
/* What route choice reads of one link of a local slot: a change in it means every destination is chosen again. */
typedef struct ub_route_link_sig {
    int16_t link_id;         /* -1: no link at this index */
    uint16_t cost;
    uint8_t nb_in_use;
    uint8_t doubt;
    uint8_t nb_id[UB_ENTITY_ID_LEN];
} ub_route_link_sig_t;

typedef struct ub_route_tombstone {
    uint8_t id[UB_ENTITY_ID_LEN];
    uint64_t until_ms;
} ub_route_tombstone_t;

/** The engine. Caller-owned, must outlive its attachment; treat the fields as private. */
typedef struct ub_route {
    ub_node_t *node;
    ub_route_options_t opt;
    uint16_t seqno[UB_MAX_LOCAL_ENTITIES];   /* per local slot */
    uint8_t learned[UB_MAX_ENTITIES];
    uint8_t expiring;                        /* removing an expired learned entity: no tombstone */
    uint64_t advertised_ms[UB_MAX_ENTITIES]; /* learned entities: last update that advertised a route to it */
    uint8_t reselect[UB_MAX_LOCAL_ENTITIES]; /* the slot's routes must be chosen again */
    ub_route_tombstone_t tomb[UB_ROUTE_TOMBSTONES];
    ub_route_link_t links[UB_MAX_NODE_LINKS];
    ub_route_entry_t routes[UB_MAX_ENTITIES][UB_MAX_NODE_LINKS];
    ub_route_dest_t dests[UB_MAX_LOCAL_ENTITIES][UB_MAX_ENTITIES];
    ub_route_counters_t counters;
    /* Bookkeeping for the cost of a tick (no state of its own: all derived from the tables above, docs/routing.md
     * "Cost at scale"). timers: per entity, the earliest of its route expiries, learned-entity expiry, retraction
     * end, starvation retry and feasibility-distance collection; owed_*: per local slot and link index, how many
     * destinations owe that link a triggered entry / a seqno request. */
    ub_timeheap_t timers;
    uint16_t owed_dirty[UB_MAX_LOCAL_ENTITIES][UB_MAX_LINKS_PER_ENTITY];
    uint16_t owed_req[UB_MAX_LOCAL_ENTITIES][UB_MAX_LINKS_PER_ENTITY];
    uint16_t owed_lazy[UB_MAX_LOCAL_ENTITIES][UB_MAX_LINKS_PER_ENTITY]; /* ... an entry at the next regular frame */
    /* Incremental route choice: a selection chooses again only the destinations whose inputs changed (bit set:
     * a route entry, the feasibility distance, a request, a starving destination's retry), or every one when a
     * link's cost, neighbour or doubt changed since the last selection (link_sig) or resel_full is set. */
    uint16_t link_routes[UB_MAX_NODE_LINKS]; /* route entries in use per link (the neighbour's destinations, admit()) */
    uint64_t resel_bits[UB_MAX_LOCAL_ENTITIES][(UB_MAX_ENTITIES + 63) / 64];
    uint8_t resel_full[UB_MAX_LOCAL_ENTITIES];
    ub_route_link_sig_t link_sig[UB_MAX_LOCAL_ENTITIES][UB_MAX_LINKS_PER_ENTITY];
    ub_service_t svc; /* its registration with the node (ub_service.h): HELLO and ROUTE_UPDATE, link-local */
} ub_route_t;

/**
 * Initialises `rt` and attaches it to `node` (one engine per node; replaces
 * any previous one). From the next ub_node_tick() every attached link sends
 * its hello and full table.
 * @return UB_OK; UB_ERR_INVAL (NULL, or an option out of range: hello_ms not
 *         10..65535, update_ms < hello_ms or > 65535, dead_misses > 16,
 *         max_dests > UB_MAX_ENTITIES,
 *         parallel unknown); UB_ERR_FULL (the node's service table,
 *         UB_MAX_SERVICES, is full: nothing attached).
 */
UB_CHECK int ub_route_attach(ub_route_t *rt, ub_node_t *node, const ub_route_options_t *opt, uint64_t now_ms);

/** Detaches `rt`: the masks it wrote (not the pinned ones) are cleared; manual routing resumes. */
void ub_route_detach(ub_route_t *rt);

/** What the engine chose for one (local entity, destination). */
typedef struct ub_route_info {
    bool local;              /**< the destination is an entity of this node (delivered, not routed) */
    bool reachable;          /**< a feasible route is selected */
    bool retracting;         /**< lost recently; the retraction is still being advertised */
    bool starving;           /**< no feasible route, but unfeasible ones: seqno requests are out */
    bool pinned;             /**< the node's mask is pinned by hand (the engine does not write it) */
    bool learned;            /**< the entity was added to the table by the engine */
    int link_id;             /**< selected link, -1 when unreachable */
    uint8_t next_hop[UB_ENTITY_ID_LEN]; /**< entity at the other end of the selected link */
    uint16_t metric;         /**< metric of the selected route (UB_ROUTE_INFINITY when unreachable) */
    uint16_t seqno;          /**< its seqno */
    uint8_t mask;            /**< the mask the engine computed (installed unless pinned) */
    uint8_t routes;          /**< route entries known, over all links */
    uint8_t feasible;        /**< of which usable now (finite, feasible, link up) */
    bool fd_valid;
    uint16_t fd_seqno;
    uint16_t fd_metric;
} ub_route_info_t;

/**
 * Reads the route of local entity `entity` toward `dest` (entity-table indexes).
 * @return UB_OK; UB_ERR_INVAL (NULL, `entity` not local, `dest` not in the table).
 */
UB_CHECK int ub_route_get(const ub_route_t *rt, int entity, int dest, ub_route_info_t *out);

/** What the engine knows about one link. */
typedef struct ub_route_link_info {
    bool neighbour;          /**< an entity answers on this link */
    uint8_t neighbour_id[UB_ENTITY_ID_LEN];
    uint16_t rxcost;         /**< 256 / fraction of its hellos we received (UB_ROUTE_INFINITY: none / down) */
    uint16_t txcost;         /**< its rxcost for us, from its IHU */
    uint16_t cost;           /**< the link's cost in routes (UB_ROUTE_INFINITY: down) */
    uint16_t history;        /**< hello history (the ETX window: the last 16), bit 0 = most recent */
    uint8_t samples;         /**< valid bits of `history`, <= 16 */
    uint32_t neighbour_hello_ms;
    ub_route_link_stats_t stats;
} ub_route_link_info_t;

/** @return UB_OK, or UB_ERR_INVAL (NULL, not a link of the node). */
UB_CHECK int ub_route_link_info(const ub_route_t *rt, int link_id, ub_route_link_info_t *out);

/** @return the engine-wide counters. */
const ub_route_counters_t *ub_route_counters(const ub_route_t *rt);

/** @return the current seqno of local entity `entity`, or 0 if it is not local. */
uint16_t ub_route_seqno(const ub_route_t *rt, int entity);

#ifdef __cplusplus
}
#endif
#endif /* UB_ROUTE_H */
