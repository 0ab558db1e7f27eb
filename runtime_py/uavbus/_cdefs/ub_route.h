/* cffi cdef for runtime_c/include/ub/ub_route.h: automatic routes. The engine is opaque (its size comes
 * from the compiler); Python reads what it chose through ub_route_get() / ub_route_link_info(). */

#define UB_ROUTE_INFINITY ...
#define UB_ROUTE_LINK_COST ...

typedef enum ub_route_parallel { UB_ROUTE_PARALLEL_ALL, UB_ROUTE_PARALLEL_BEST, ... } ub_route_parallel_t;

typedef struct ub_route_options {
    uint32_t hello_ms;
    uint32_t update_ms;
    uint32_t trigger_gap_ms;
    uint32_t source_gc_ms;
    uint8_t dead_misses;
    uint8_t parallel;
    uint8_t no_learn;
    uint16_t initial_seqno;
    uint32_t learn_expiry_ms;
    uint16_t max_dests;
    bool (*accept_dest)(void *user, const uint8_t dest[], const uint8_t neighbour[], uint16_t metric);
    void *accept_user;
    ...;
} ub_route_options_t;

typedef struct ub_route_link_stats {
    uint64_t frames_out;
    uint64_t hellos_out;
    uint64_t triggered_out;
    uint64_t entries_out;
    uint64_t requests_out;
    uint64_t bytes_out;
    uint64_t refused_out;
    uint64_t frames_in;
    uint64_t entries_in;
    uint64_t requests_in;
    uint64_t bad_in;
    uint64_t neighbour_changes;
    uint64_t link_downs;
    uint64_t over_limit_in;
    uint64_t fast_hellos_out;
    ...;
} ub_route_link_stats_t;

typedef struct ub_route_counters {
    uint64_t route_changes;
    uint64_t routes_found;
    uint64_t routes_lost;
    uint64_t unfeasible;
    uint64_t expired;
    uint64_t starvation_requests;
    uint64_t requests_forwarded;
    uint64_t requests_answered;
    uint64_t requests_dropped;
    uint64_t seqno_bumps;
    uint64_t learned;
    uint64_t learn_full;
    uint64_t learn_expired;
    uint64_t learn_refused;
    uint64_t pinned_skips;
    uint64_t neighbour_limit;
    uint64_t dest_refused;
    uint64_t link_evidence_down;
    uint64_t link_doubts;
    uint64_t lost_link_down;
    uint64_t lost_entry_gone;
    uint64_t lost_retracted;
    uint64_t lost_unfeasible;
    uint64_t owed_route_change;
    uint64_t owed_seqno_asked;
    uint64_t owed_request_answer;
    uint64_t seqno_deferred;
    uint64_t requests_suppressed;
    uint64_t unfeasible_held;
    ...;
} ub_route_counters_t;

typedef struct ub_route { ...; } ub_route_t;

typedef struct ub_route_info {
    bool local;
    bool reachable;
    bool retracting;
    bool starving;
    bool pinned;
    bool learned;
    int link_id;
    uint8_t next_hop[...];
    uint16_t metric;
    uint16_t seqno;
    uint8_t mask;
    uint8_t routes;
    uint8_t feasible;
    bool fd_valid;
    uint16_t fd_seqno;
    uint16_t fd_metric;
    ...;
} ub_route_info_t;

typedef struct ub_route_link_info {
    bool neighbour;
    uint8_t neighbour_id[...];
    uint16_t rxcost;
    uint16_t txcost;
    uint16_t cost;
    uint16_t history;
    uint8_t samples;
    uint32_t neighbour_hello_ms;
    ub_route_link_stats_t stats;
    ...;
} ub_route_link_info_t;

int ub_route_attach(ub_route_t *rt, ub_node_t *node, const ub_route_options_t *opt, uint64_t now_ms);
void ub_route_detach(ub_route_t *rt);
int ub_route_get(const ub_route_t *rt, int entity, int dest, ub_route_info_t *out);
int ub_route_link_info(const ub_route_t *rt, int link_id, ub_route_link_info_t *out);
const ub_route_counters_t *ub_route_counters(const ub_route_t *rt);
uint16_t ub_route_seqno(const ub_route_t *rt, int entity);
