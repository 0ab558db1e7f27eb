/* cffi cdef for runtime_c/include/ub/ub_frag.h: large directories in numbered fragments. */

#define UB_FRAG_HEADER_LEN ...
#define UB_FRAG_SLOTS ...
#define UB_FRAG_SLOTS_PER_SOURCE ...
#define UB_FRAG_TX_SLOTS ...
#define UB_FRAG_MAX_FRAGMENTS ...
#define UB_FRAG_TIMEOUT_MS ...
#define UB_MAX_DIRECTORY ...

typedef struct ub_frag_params {
    uint32_t timeout_ms;
    uint32_t protect_ms;
    ...;
} ub_frag_params_t;

typedef struct ub_frag_stats {
    uint64_t tx_transfers;
    uint64_t tx_fragments;
    uint64_t tx_busy;
    uint64_t tx_paused;
    uint64_t tx_abandoned;
    uint64_t rx_started;
    uint64_t rx_fragments;
    uint64_t rx_duplicates;
    uint64_t rx_complete;
    uint64_t rx_timeouts;
    uint64_t rx_evicted;
    uint64_t rx_refused;
    uint64_t rx_source_limit;
    uint64_t rx_restarted;
    uint64_t rx_bad;
    ...;
} ub_frag_stats_t;

typedef struct ub_frag {
    ub_frag_stats_t stats;
    ...;
} ub_frag_t;

void ub_frag_init(ub_frag_t *f, const ub_frag_params_t *params, uint16_t first_transfer);
int ub_frag_plan(size_t total, size_t max_bytes, uint16_t *count);
int ub_frag_write(uint8_t *out, size_t cap, uint16_t transfer, uint16_t index, uint16_t count, const uint8_t *data,
                  size_t total);
int ub_frag_take(ub_frag_t *f, int slot, const uint8_t src[12], const uint8_t dir_id[16], uint32_t fingerprint,
                 const uint8_t *payload, size_t len, uint64_t now_ms, const uint8_t **data, size_t *total);
size_t ub_frag_expire(ub_frag_t *f, uint64_t now_ms);
size_t ub_frag_pending(const ub_frag_t *f);
