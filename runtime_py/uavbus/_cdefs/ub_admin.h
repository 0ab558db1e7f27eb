/* cffi cdef for runtime_c/include/ub/ub_admin.h: the global administration table (GCS API). */

typedef struct ub_node ub_node_t;

typedef enum ub_admin_row_type { UB_ADMIN_ROW_PUBLICATION, UB_ADMIN_ROW_SUBSCRIPTION, ... } ub_admin_row_type_t;

typedef enum ub_admin_status {
    UB_ADMIN_INACTIVE, UB_ADMIN_PENDING, UB_ADMIN_ACKNOWLEDGED, UB_ADMIN_ACTIVE, UB_ADMIN_FAILED,
    UB_ADMIN_STOPPING, UB_ADMIN_STALE, ...
} ub_admin_status_t;

const char *ub_admin_status_name(ub_admin_status_t status);

typedef enum ub_nack_reason {
    UB_NACK_NONE, UB_NACK_UNKNOWN_CONTENT, UB_NACK_LAYOUT, UB_NACK_UNBOUND, UB_NACK_TABLE_FULL, UB_NACK_INVALID,
    UB_NACK_NOT_AUTHORIZED, UB_NACK_LIMIT, UB_NACK_UNSUPPORTED, UB_NACK_OTHER_ADMIN, UB_NACK_NO_SUCH_ROW,
    UB_NACK_BAD_VALUE, ...
} ub_nack_reason_t;

const char *ub_nack_reason_name(ub_nack_reason_t reason);

typedef struct ub_admin_row_spec {
    uint32_t instance;
    uint8_t source[...];
    uint8_t destination[...];
    uint32_t period_ms;
    ub_admin_row_type_t type;
    ...;
} ub_admin_row_spec_t;

typedef struct ub_admin_row_info {
    ub_admin_row_spec_t spec;
    ub_admin_status_t status;
    bool active_flag;
    ub_nack_reason_t nack_reason;
    bool nack_relayed;
    uint32_t request_id;
    uint32_t attempts;
    uint64_t acked_at_ms;
    uint64_t active_at_ms;
    uint64_t last_ack_ms;
    uint64_t last_data_ms;
    ...;
} ub_admin_row_info_t;

typedef struct ub_admin_options {
    uint32_t retry_ms;
    uint32_t renew_ms;
    uint32_t lease_ms;
    uint32_t max_retries;
    uint32_t max_stop_retries;
    ...;
} ub_admin_options_t;

typedef struct ub_admin { ...; } ub_admin_t;

#define UB_MAX_ADMIN_ROWS ...

int ub_admin_init(ub_admin_t *adm, ub_node_t *node, int entity, const ub_admin_options_t *opt);
void ub_admin_detach(ub_admin_t *adm);
int ub_admin_add_row(ub_admin_t *adm, const ub_admin_row_spec_t *spec);
int ub_admin_set_active(ub_admin_t *adm, int row, bool active, uint64_t now_ms);
int ub_admin_remove_row(ub_admin_t *adm, int row);
int ub_admin_row_status(const ub_admin_t *adm, int row, ub_admin_row_info_t *out);
