/* cffi cdef for runtime_c/include/ub/ub_link.h: link slots, their counters and the mask notation.
 * Python reads a slot's counters through ub_node.h's queries, and can put a transport of its own behind a
 * slot (uavbus.pylink): its `send` is the `extern "Python"` ub_py_link_send below. */

#define UB_LINK_NAME_LEN ...

typedef enum ub_drop_reason {
    UB_DROP_NO_ROUTE, UB_DROP_HOP_LIMIT, UB_DROP_DUPLICATE, UB_DROP_LAYOUT_MISMATCH, UB_DROP_UNKNOWN_CONTENT,
    UB_DROP_UNBOUND, UB_DROP_BAD_PAYLOAD, UB_DROP_TX_ERROR, UB_DROP_BACKPRESSURE, UB_DROP_DETACHED,
    UB_DROP_NOT_ALLOWED, UB_DROP_NOT_AUTHORIZED, UB_DROP_ROUTING_OFF,
    UB_DROP_UNSIGNED, UB_DROP_BAD_TAG, UB_DROP_UNKNOWN_KEY, UB_DROP_REPLAY, UB_DROP_UNVERIFIED,
    UB_DROP_TOO_BIG, UB_DROP_INCOMPLETE, UB_DROP_COUNTER_JUMP, UB_DROP_BAD_ORIGIN, UB_DROP_NO_ORIGIN,
    UB_DROP_NO_IDENTITY, UB_DROP_SHED,
    UB_DROP_REASON_COUNT, ...
} ub_drop_reason_t;

const char *ub_drop_reason_name(ub_drop_reason_t reason);

typedef struct ub_link_counters {
    uint64_t frames_in;
    uint64_t frames_accepted;
    uint64_t bytes_in;
    uint64_t frames_out;
    uint64_t bytes_out;
    uint64_t bad_datagrams[...];
    uint64_t drops[...];
    ...;
} ub_link_counters_t;

typedef struct ub_link_ops {
    const char *kind;
    int (*send)(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms);
    int (*fileno)(void *impl);
    ...;
} ub_link_ops_t;

extern "Python" int ub_py_link_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms);

/* Opaque: a slot is read through ub_node.h's queries (ub_node_link_name(), ub_node_link_counters(), ...). */
typedef struct ub_link {
    ...;
} ub_link_t;

int ub_link_mask_parse(const char *text, uint8_t *mask);
void ub_link_mask_format(uint8_t mask, char out[11]);
int ub_link_fileno(const ub_link_t *link);

/* From ub_node.h, declared here because the cdefs load in name order and ub_log.h needs them. */
typedef enum ub_tap_dir { UB_TAP_RX, UB_TAP_TX, ... } ub_tap_dir_t;

typedef void (*ub_tap_fn)(void *user, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len,
                          uint64_t now_ms);
