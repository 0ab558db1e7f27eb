/* cdefs for ub_rxring.h (batched delivery, send_many). Declared after ub_node.h (sorted), whose
 * ub_node_t, ub_deliver_fn and ub_frame_header_t it uses. The ring's fields are the C compiler's. */
#define UB_RXREC_HEADER ...

typedef struct ub_rxring_counters {
    uint64_t recorded;
    uint64_t drained;
    uint64_t spilled;
    uint64_t dropped;
    uint64_t high_water;
} ub_rxring_counters_t;

typedef struct ub_rxring {
    size_t capacity;
    size_t stride;
    ...;
} ub_rxring_t;

int ub_rxring_init(ub_rxring_t *ring, uint8_t *mem, size_t mem_len, size_t stride);
int ub_rxring_attach(ub_rxring_t *ring, ub_node_t *node, ub_deliver_fn spill, void *spill_user);
void ub_rxring_detach(ub_rxring_t *ring);
size_t ub_rxring_drain(ub_rxring_t *ring, uint8_t *out, size_t max);
size_t ub_rxring_pending(const ub_rxring_t *ring);
ub_rxring_counters_t ub_rxring_get_counters(const ub_rxring_t *ring);
long ub_send_many(ub_node_t *node, int entity, uint32_t instance, const uint8_t *dest_id, uint64_t now_ms,
                  size_t offset, size_t size, const uint8_t *values, size_t n);
