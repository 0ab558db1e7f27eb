/* cffi cdef for runtime_c/include/ub/ub_member.h: membership requests over the bus. */

#define UB_MEMBER_SPEC_LEN ...
#define UB_MEMBER_CHANGED ...

typedef enum ub_member_op {
    UB_MEMBER_ADD_ENTITY, UB_MEMBER_REMOVE_ENTITY, UB_MEMBER_SET_MASK, UB_MEMBER_ADD_LINK, UB_MEMBER_REMOVE_LINK, ...
} ub_member_op_t;

typedef enum ub_member_status { UB_MEMBER_FREE, UB_MEMBER_PENDING, UB_MEMBER_DONE, UB_MEMBER_FAILED, ... } ub_member_status_t;

typedef struct ub_member_spec {
    uint8_t op;
    uint8_t target[...];
    uint8_t subject[...];
    uint8_t mask;
    uint8_t link_index;
    char link_name[...];
    char port_spec[...];
    ...;
} ub_member_spec_t;

typedef struct ub_member_info {
    ub_member_spec_t spec;
    uint8_t status;
    uint8_t nack_reason;
    bool changed;
    uint32_t request_id;
    uint32_t attempts;
    uint64_t done_ms;
    ...;
} ub_member_info_t;

typedef struct ub_member_options {
    uint32_t retry_ms;
    uint32_t max_retries;
    ...;
} ub_member_options_t;

typedef struct ub_member_counters {
    uint64_t sent;
    uint64_t done;
    uint64_t failed;
    uint64_t unmatched_replies;
    ...;
} ub_member_counters_t;

typedef struct ub_member { ...; } ub_member_t;

const char *ub_member_op_name(ub_member_op_t op);
const char *ub_member_status_name(ub_member_status_t status);
int ub_member_init(ub_member_t *m, ub_node_t *node, int entity, const ub_member_options_t *opt);
void ub_member_detach(ub_member_t *m);
int ub_member_request(ub_member_t *m, const ub_member_spec_t *spec, uint64_t now_ms);
int ub_member_status(const ub_member_t *m, int row, ub_member_info_t *out);
int ub_member_forget(ub_member_t *m, int row);
const ub_member_counters_t *ub_member_counters(const ub_member_t *m);
uint8_t ub_member_apply(ub_node_t *node, int entity, const ub_member_spec_t *spec, uint64_t now_ms, bool *changed);
