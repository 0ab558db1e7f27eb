/* cffi cdef for runtime_c/include/ub/ub_batchlink.h: frames in batches (the Zenoh bridge's samples). */

typedef struct ub_batchlink {
    uint8_t *buf;
    size_t cap;
    uint32_t *ends;
    size_t ends_cap;
    size_t batch_limit;
    size_t len;
    size_t n;
    size_t open_start;
    uint32_t open_count;
    uint64_t frames;
    uint64_t refused;
    ...;
} ub_batchlink_t;

typedef enum ub_batch_status {
    UB_BATCH_OK = 0,
    UB_BATCH_FOREIGN = 1,
    UB_BATCH_OTHER_VERSION = 2,
    UB_BATCH_MALFORMED = 3
} ub_batch_status_t;

int ub_batchlink_init(ub_batchlink_t *bl, uint8_t *buf, size_t cap, uint32_t *ends, size_t ends_cap,
                      size_t batch_limit);
int ub_batchlink_attach(ub_batchlink_t *bl, ub_node_t *node, int link_id);
void ub_batchlink_clear(ub_batchlink_t *bl);
ub_batch_status_t ub_batch_check(const uint8_t *payload, size_t len, size_t *count);
int ub_batch_rx(ub_node_t *node, int link_id, const uint8_t *payload, size_t len, uint64_t now_ms, size_t *frames,
                size_t *rejected);
