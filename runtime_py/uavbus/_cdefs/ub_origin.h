/* cffi cdef for runtime_c/include/ub/ub_origin.h: origin authentication (pairwise X25519 keys per entity
 * pair, origin tags checked by the destination). The identity store's lookup is the `extern "Python"`
 * ub_py_origin_lookup, defined in uavbus._bindings.ub_origin. */

#define UB_ORIGIN_SK_LEN ...
#define UB_ORIGIN_PK_LEN ...
#define UB_ORIGIN_KEY_LEN ...
#define UB_ORIGIN_PEERS ...
#define UB_ORIGIN_LOCALS ...

typedef int (*ub_origin_lookup_fn)(void *user, const uint8_t entity_id[], uint64_t now_s, uint8_t x25519_pk[]);
typedef uint64_t (*ub_origin_clock_fn)(void *user);

typedef struct ub_origin_options {
    ub_origin_lookup_fn lookup;
    void *lookup_user;
    ub_origin_clock_fn clock_s;
    void *clock_user;
    uint32_t recheck_ms;
    bool optional;
    ...;
} ub_origin_options_t;

typedef struct ub_origin_stats {
    uint64_t sealed;
    uint64_t opened;
    uint64_t bad_origin;
    uint64_t no_origin;
    uint64_t no_identity;
    uint64_t derivations;
    uint64_t lookups;
    uint64_t evictions;
    uint64_t rekeys;
    ...;
} ub_origin_stats_t;

/* Private fields stay hidden: Python uses the functions. */
typedef struct ub_origin {
    ...;
} ub_origin_t;

int ub_origin_init(ub_origin_t *o, const ub_origin_options_t *opt);
int ub_origin_add_identity(ub_origin_t *o, const uint8_t entity_id[], const uint8_t x25519_sk[]);
int ub_origin_add_pair(ub_origin_t *o, const uint8_t entity_id[], const uint8_t peer_id[], const uint8_t k_tx[],
                       const uint8_t k_rx[]);
#define UB_ORIGIN_PAIRS_HEADER_LEN ...
#define UB_ORIGIN_PAIRS_ENTRY_LEN ...
typedef struct ub_origin_provision {
    uint8_t entity_id[12];
    uint8_t group_key[32];
    uint8_t group_key_id;
    bool has_group_key;
    uint8_t pairs;
} ub_origin_provision_t;
int ub_origin_load_pairs(ub_origin_t *o, const uint8_t *table, size_t len, ub_origin_provision_t *out);
int ub_origin_attach(ub_origin_t *o, ub_node_t *node);
int ub_origin_detach(ub_origin_t *o, ub_node_t *node);
size_t ub_origin_forget(ub_origin_t *o, const uint8_t peer_id[]);
void ub_origin_forget_hook(void *origin, const uint8_t peer_id[]);
size_t ub_origin_cached(const ub_origin_t *o);
const ub_origin_stats_t *ub_origin_stats(const ub_origin_t *o);
int ub_origin_public_key(const uint8_t sk[], uint8_t pk[]);
int ub_origin_pair_keys(const uint8_t self_id[], const uint8_t self_sk[], const uint8_t peer_id[],
                        const uint8_t peer_pk[], uint8_t k_tx[], uint8_t k_rx[]);
int ub_origin_tag(const uint8_t key[], const ub_frame_header_t *h, const uint8_t *payload, uint8_t tag[]);

extern "Python" int ub_py_origin_lookup(void *user, const uint8_t entity_id[], uint64_t now_s, uint8_t x25519_pk[]);
