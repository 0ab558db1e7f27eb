/* cffi cdef for runtime_c/include/ub/ub_pubsub.h: per-entity publish/subscribe tables. */

typedef struct ub_node ub_node_t;

typedef enum ub_ps_kind { UB_PS_FREE, UB_PS_PUBLICATION, UB_PS_SUBSCRIPTION, ... } ub_ps_kind_t;
typedef enum ub_sub_state { UB_SUB_REQUESTING, UB_SUB_RECEIVING, UB_SUB_STOPPING, ... } ub_sub_state_t;

/* ub_pubsub_timing_t is declared in ub_node.h: cdefs load in name order and ub_node_options_t needs it. */

typedef struct ub_ps_row {
    uint8_t kind;
    uint8_t state;
    uint8_t acked;
    uint8_t reported_flowing;
    uint32_t instance;
    uint8_t peer[...];
    uint8_t owner[...];
    uint32_t owner_request_id;
    uint32_t request_id;
    uint32_t period_ms;
    uint32_t stop_tries;
    uint64_t lease_until_ms;
    uint64_t next_due_ms;
    uint64_t last_data_ms;
    uint64_t frames;
    ...;
} ub_ps_row_t;

#define UB_MAX_PUBSUB_ROWS ...

int ub_pubsub_publish(ub_node_t *node, int entity, uint32_t instance, const uint8_t dest_id[], uint32_t period_ms,
                      uint64_t now_ms);
int ub_pubsub_subscribe(ub_node_t *node, int entity, uint32_t instance, const uint8_t source_id[],
                        uint32_t period_ms, uint64_t now_ms);
int ub_pubsub_stop(ub_node_t *node, int entity, int row, uint64_t now_ms);
int ub_pubsub_find(const ub_node_t *node, int entity, ub_ps_kind_t kind, uint32_t instance, const uint8_t peer[]);
const ub_ps_row_t *ub_pubsub_row(const ub_node_t *node, int entity, int row);
int ub_pubsub_count(const ub_node_t *node, int entity, ub_ps_kind_t kind);
uint64_t ub_pubsub_data_timeout_ms(const ub_pubsub_timing_t *timing, uint32_t period_ms);
