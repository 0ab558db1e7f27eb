/* cffi cdef for runtime_c/include/ub/ub_inspect.h: remote inspection and change over the bus. */

#define UB_INSPECT_CHUNK ...
#define UB_INSPECT_END ...
#define UB_INSPECT_ENTITY_REC ...
#define UB_INSPECT_LINK_REC ...
#define UB_INSPECT_PUBSUB_REC ...
#define UB_INSPECT_ADMIN_REC ...

typedef enum ub_inspect_op {
    UB_INSPECT_READ, UB_INSPECT_WRITE, UB_INSPECT_LIST, UB_INSPECT_SET_PERIOD, UB_INSPECT_SET_MASK,
    UB_INSPECT_ADMIN_ROW, ...
} ub_inspect_op_t;

typedef enum ub_inspect_table {
    UB_INSPECT_ENTITIES, UB_INSPECT_LINKS, UB_INSPECT_PUBSUB, UB_INSPECT_ADMIN, ...
} ub_inspect_table_t;

typedef enum ub_inspect_admin_field { UB_INSPECT_ADMIN_PERIOD, UB_INSPECT_ADMIN_ACTIVE, ... } ub_inspect_admin_field_t;

typedef enum ub_inspect_status {
    UB_INSPECT_FREE, UB_INSPECT_PENDING, UB_INSPECT_DONE, UB_INSPECT_FAILED, ...
} ub_inspect_status_t;

typedef struct ub_inspect_spec {
    uint8_t op;
    uint8_t arg;
    uint16_t offset;
    uint32_t value;
    uint32_t instance;
    uint8_t target[...];
    uint8_t subject[...];
    uint16_t len;
    uint8_t data[...];
    ...;
} ub_inspect_spec_t;

typedef struct ub_inspect_result {
    uint8_t status;
    uint8_t nack_reason;
    bool changed;
    uint32_t request_id;
    uint32_t attempts;
    uint64_t sent_ms;
    uint64_t done_ms;
    uint16_t total;
    uint16_t next;
    uint16_t len;
    uint8_t data[...];
    ...;
} ub_inspect_result_t;

typedef struct ub_inspect_options {
    uint32_t retry_ms;
    uint32_t max_retries;
    ...;
} ub_inspect_options_t;

typedef struct ub_inspect_counters {
    uint64_t sent;
    uint64_t done;
    uint64_t failed;
    uint64_t unmatched_replies;
    ...;
} ub_inspect_counters_t;

typedef struct ub_inspect { ...; } ub_inspect_t;

const char *ub_inspect_op_name(ub_inspect_op_t op);
int ub_inspect_init(ub_inspect_t *in, ub_node_t *node, int entity, const ub_inspect_options_t *opt);
void ub_inspect_detach(ub_inspect_t *in);
int ub_inspect_request(ub_inspect_t *in, const ub_inspect_spec_t *spec, uint64_t now_ms);
int ub_inspect_result(const ub_inspect_t *in, int row, ub_inspect_result_t *out);
int ub_inspect_forget(ub_inspect_t *in, int row);
const ub_inspect_counters_t *ub_inspect_counters(const ub_inspect_t *in);
