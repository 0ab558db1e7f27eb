/* cffi cdef for runtime_c/include/ub/ub_node.h: the router. ub_node_t is opaque (its size comes
 * from the compiler); Python reads it only through the functions (the queries at the end). Tap and
 * delivery hook are `extern "Python"` callbacks defined in uavbus._bindings.ub_node. */

#define UB_MAX_ENTITIES ...
#define UB_MAX_LOCAL_ENTITIES ...
#define UB_MAX_NODE_LINKS ...
#define UB_MAX_BINDINGS ...

/* ub_tap_dir_t and ub_tap_fn are declared in ub_link.h (cdefs load in name order; ub_log.h needs them). */
typedef void (*ub_deliver_fn)(void *user, int entity, uint32_t instance, const ub_frame_header_t *h,
                              uint64_t now_ms);

/* From ub_pubsub.h (declared here because the cdefs load in name order). */
typedef struct ub_pubsub_timing {
    uint32_t retry_ms;
    uint32_t renew_ms;
    uint32_t lease_ms;
    uint32_t timeout_min_ms;
    uint32_t stop_retries;
    uint32_t expiry_ms;
    ...;
} ub_pubsub_timing_t;

/* From ub_random.h (declared here because the cdefs load in name order). */
typedef int (*ub_random_fn)(void *user, uint8_t *out, size_t len);

typedef struct ub_node_options {
    uint8_t hop_limit;
    uint32_t first_seq;
    ub_pubsub_timing_t timing;
    ub_random_fn random;
    void *random_user;
    uint64_t random_seed;
    ...;
} ub_node_options_t;

typedef struct ub_node_counters {
    uint64_t originated;
    uint64_t forwarded;
    uint64_t delivered;
    uint64_t admin_handled;
    uint64_t local_direct;
    uint64_t dedup_resets;
    uint64_t dedup_evictions;
    uint64_t leases_expired;
    uint64_t replies_unmatched;
    uint64_t requests_limited;
    uint64_t leases_clamped;
    uint64_t rows_evicted;
    uint64_t random_failures;
    uint64_t entities_added;
    uint64_t entities_removed;
    uint64_t links_added;
    uint64_t links_removed;
    uint64_t rows_stopped;
    uint64_t admin_rows_stopped;
    uint64_t dedup_cleared;
    uint64_t membership_applied;
    uint64_t membership_refused;
    uint64_t handovers;
    uint64_t nacks_relayed;
    uint64_t other_admin;
    uint64_t inspect_served;
    uint64_t inspect_refused;
    uint64_t drops[...];
    ...;
} ub_node_counters_t;

/* Opaque: the size comes from the compiler; the tables are read through the query functions below. */
struct ub_node {
    ...;
};

/* ub_sec.h's context (its fields are declared in _cdefs/ub_sec.h, which loads later). */
typedef struct ub_sec ub_sec_t;

int ub_node_init(ub_node_t *node, const ub_catalogue_t *cat, const ub_node_options_t *opt);
uint32_t ub_node_seq_seed(uint64_t unix_us);
int ub_node_add_entity(ub_node_t *node, const uint8_t id[], bool local);
int ub_node_add_entity_name(ub_node_t *node, const char *name, bool local);
int ub_node_remove_entity(ub_node_t *node, int entity, uint64_t now_ms);
int ub_node_remove_link(ub_node_t *node, int link_id);
int ub_node_set_auto_mask(ub_node_t *node, int entity, int dest, uint8_t mask);
int ub_node_set_bounce_mask(ub_node_t *node, int entity, int dest, uint8_t mask);
bool ub_node_mask_pinned(const ub_node_t *node, int entity, int dest);
int ub_node_find_entity(const ub_node_t *node, const uint8_t id[]);
const uint8_t *ub_node_entity_id(const ub_node_t *node, int entity);
int ub_node_add_link(ub_node_t *node, int entity, unsigned index, const char *name);
int ub_node_find_link(const ub_node_t *node, const char *name);
const ub_link_t *ub_node_link(const ub_node_t *node, int link_id);
int ub_node_set_mask(ub_node_t *node, int entity, int dest, uint8_t mask);
int ub_node_get_mask(const ub_node_t *node, int entity, int dest, uint8_t *mask);
int ub_node_link_attach(ub_node_t *node, int link_id, const ub_link_ops_t *ops, void *impl);
int ub_node_link_detach(ub_node_t *node, int link_id);
uint64_t ub_node_link_bad_frames(const ub_node_t *node, int link_id, ub_rx_reason_t reason);
int ub_node_bind(ub_node_t *node, uint32_t instance, void *storage);
int ub_node_set_content_classes(ub_node_t *node, const uint8_t *classes, size_t n);
void *ub_node_binding(const ub_node_t *node, uint32_t instance);
int ub_node_rx(ub_node_t *node, int link_id, const uint8_t *data, size_t len, uint64_t now_ms);
int ub_node_rx_frame(ub_node_t *node, int link_id, const uint8_t *frame, size_t len, uint64_t now_ms);
int ub_node_send_data(ub_node_t *node, int entity, uint32_t instance, const uint8_t dest_id[], uint64_t now_ms);
void ub_node_tick(ub_node_t *node, uint64_t now_ms);
void ub_node_set_tap(ub_node_t *node, ub_tap_fn fn, void *user);
void ub_node_set_deliver_hook(ub_node_t *node, ub_deliver_fn fn, void *user);
const ub_node_counters_t *ub_node_counters(const ub_node_t *node);
int ub_node_set_security(ub_node_t *node, ub_sec_t *sec);
ub_sec_t *ub_node_security(const ub_node_t *node);
int ub_node_set_require_signed(ub_node_t *node, bool on);
int ub_node_link_set_security(ub_node_t *node, int link_id, int require_signed, bool encrypt);
bool ub_node_link_requires_signed(const ub_node_t *node, int link_id);

/* Wire: compact links, MTUs, fragments (ub_node.h "Wire"; ub_compact.h, ub_frag.h). */
int ub_node_link_set_compact(ub_node_t *node, int link_id, ub_compact_t *state, const ub_compact_params_t *params);
ub_compact_t *ub_node_link_compact(const ub_node_t *node, int link_id);
int ub_node_link_set_mtu(ub_node_t *node, int link_id, uint16_t mtu);
int ub_node_set_frag(ub_node_t *node, ub_frag_t *frag);
ub_frag_t *ub_node_frag(const ub_node_t *node);

/* Queries (ub_node.h "Queries", ub_node_query.c): read-only views instead of struct fields. */
bool ub_node_entity_in_use(const ub_node_t *node, int entity);
bool ub_node_entity_is_local(const ub_node_t *node, int entity);
int ub_node_entity_link(const ub_node_t *node, int entity, unsigned index);
const char *ub_node_link_name(const ub_node_t *node, int link_id);
const char *ub_node_link_kind(const ub_node_t *node, int link_id);
const ub_link_counters_t *ub_node_link_counters(const ub_node_t *node, int link_id);
bool ub_node_link_encrypts(const ub_node_t *node, int link_id);
uint16_t ub_node_link_mtu(const ub_node_t *node, int link_id);
const ub_compact_stats_t *ub_node_link_compact_stats(const ub_node_t *node, int link_id);
const ub_frag_stats_t *ub_node_frag_stats(const ub_node_t *node);

/* From ub_compact.h: the functions over frame headers, decoders and rx reasons (declared after ub_frame.h). */
int ub_compact_decode(const ub_compact_codec_t *c, const uint8_t *pkt, size_t n, const ub_compact_refs_t *refs,
                      uint8_t *frame, size_t cap, ub_frame_header_t *h, ub_rx_reason_t *why);

extern "Python" void ub_py_deliver(void *user, int entity, uint32_t instance, const ub_frame_header_t *h,
                                   uint64_t now_ms);
extern "Python" void ub_py_tap(void *user, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len,
                               uint64_t now_ms);
