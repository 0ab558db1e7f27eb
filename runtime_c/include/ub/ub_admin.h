/**
 * @file ub_admin.h
 * @brief The global administration table (paper III.B, Figure 5): operator rows
 *        that set up publications and subscriptions anywhere in the system.
 *
 * One caller-owned ub_admin_t is attached to one local entity of a node
 * (usually the GCS) with ub_admin_init(); ub_node_tick() drives it and the node
 * hands it the ACK/NACK frames addressed to that entity.
 *
 * Row life cycle (status, readable with ub_admin_row_status()):
 *
 *     INACTIVE --activate--> PENDING --ACK--> ACKNOWLEDGED --ACK+FLOWING--> ACTIVE
 *                               |  NACK / retries exhausted
 *                               +--> FAILED
 *     any active status --deactivate--> STOPPING --ACK of the STOP--> INACTIVE
 *
 *  - A **publication** row sends PUB_REQUEST (content, destination, period,
 *    lease) to the **source**; a **subscription** row sends SUB_REQUEST
 *    (content, source, period, lease) to the **destination**, which from then
 *    on drives the source itself with its own PUB_REQUESTs.
 *  - Each activation draws a random request id (ub_node_options_t.random).
 *    An ACK or NACK changes a row only if it carries that id, comes from the
 *    row's target (the source of a publication row, the destination of a
 *    subscription row) and names the row's content; anything else is counted
 *    in ub_node_counters_t.replies_unmatched and ignored.
 *  - PENDING: the request is resent every `retry_ms` until acknowledged
 *    (`max_retries` = 0 means forever; otherwise FAILED after that many).
 *  - ACKNOWLEDGED / ACTIVE: the request (same request id) is renewed every
 *    `renew_ms`, which renews the target's lease; without any ACK for one
 *    lease the row falls back to PENDING.
 *  - STALE: a status that depends on data turns stale visibly. When the
 *    row's destination is an entity of this node (the administrator's own
 *    ground station, typically), the table sees the data arrive; an
 *    ACKNOWLEDGED or ACTIVE row that receives nothing for
 *    UB_ADMIN_STALE_PERIODS periods + UB_ADMIN_STALE_MARGIN_MS becomes STALE
 *    (renewals go on) and returns to its ACK's status with the next DATA.
 *    A subscription row with its destination elsewhere turns STALE when the
 *    destination, having reported FLOWING, acknowledges without it (its data
 *    timed out there), and ACTIVE again with its next FLOWING ACK.
 *  - **Active** is observed through the target: every ACK carries a FLOWING
 *    flag. A source sets it once it has sent DATA for the publication; a
 *    subscribing destination sets it while DATA from the source arrives
 *    within its data timeout. Targets also send an unsolicited ACK with
 *    FLOWING as soon as data starts, so ACTIVE does not wait for a renewal.
 *    For a publication row, ACTIVE therefore means "the source is sending",
 *    not "the destination receives" (a publication is the weaker link).
 *  - Deactivation sends PUB_STOP (publication rows, to the source) or
 *    SUB_STOP (subscription rows, to the destination, which then stops the
 *    source) every `retry_ms` until acknowledged, `max_stop_retries` times,
 *    then every `renew_ms` until acknowledged: the row stays STOPPING, since a
 *    flow handed over to its keeper (ub_pubsub.h) does not end by itself when
 *    the administrator goes quiet. A STOPPING row may be removed (the operator
 *    gives up on the STOP).
 *  - **No silent status**: a NACK fails the row with its reason, also when the
 *    destination of a subscription row relays its source's refusal
 *    (`nack_relayed`); a target whose row another administrator keeps alive
 *    answers UB_NACK_OTHER_ADMIN, so two administrators never both see
 *    ACTIVE for one flow at two rates. One table refuses a second row for the
 *    same (content, source, destination) (UB_ERR_EXISTS).
 */
#ifndef UB_ADMIN_H
#define UB_ADMIN_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "ub_catalogue.h"
#include "ub_config.h"
#include "ub_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ub_node ub_node_t;

/** Row type, as in the paper's table: who receives the table-change request. */
typedef enum ub_admin_row_type {
    UB_ADMIN_ROW_PUBLICATION = 0,  /**< request goes to the source */
    UB_ADMIN_ROW_SUBSCRIPTION = 1  /**< request goes to the destination */
} ub_admin_row_type_t;

typedef enum ub_admin_status {
    UB_ADMIN_INACTIVE = 0,
    UB_ADMIN_PENDING,      /**< request sent, not acknowledged yet */
    UB_ADMIN_ACKNOWLEDGED, /**< target applied the change, data not (yet) reported flowing */
    UB_ADMIN_ACTIVE,       /**< target reports data flowing */
    UB_ADMIN_FAILED,       /**< NACKed (see nack_reason) or retries exhausted */
    UB_ADMIN_STOPPING,     /**< STOP sent, waiting for its ACK */
    UB_ADMIN_STALE         /**< acknowledged, but the data it stands for stopped: the row's destination is an entity
                                of this node and no DATA of the row's content from its source reached it for
                                UB_ADMIN_STALE_PERIODS periods + UB_ADMIN_STALE_MARGIN_MS (the first DATA returns
                                the row to what its last ACK said); or, destination elsewhere, a subscription row
                                whose destination reported FLOWING and now acknowledges without it (its next
                                FLOWING ACK makes it active). Renewals go on. A local status: nothing on the wire
                                changes. */
} ub_admin_status_t;

/** A row whose destination is local turns STALE after this many periods without its data, plus the margin. */
#define UB_ADMIN_STALE_PERIODS 3u
#define UB_ADMIN_STALE_MARGIN_MS 500u

/** @return a static name ("pending", ...) for a status, "?" if out of range. */
const char *ub_admin_status_name(ub_admin_status_t status);

/** NACK reasons (byte 5 of a NACK payload; docs/pubsub.md). */
typedef enum ub_nack_reason {
    UB_NACK_NONE = 0,
    UB_NACK_UNKNOWN_CONTENT = 1, /**< target's catalogue lacks the content ID */
    UB_NACK_LAYOUT = 2,          /**< target's fingerprint for the content differs */
    UB_NACK_UNBOUND = 3,         /**< source does not host (bind) the instance */
    UB_NACK_TABLE_FULL = 4,      /**< target's publish/subscribe table is full */
    UB_NACK_INVALID = 5,         /**< period 0, or a payload the target cannot read */
    UB_NACK_NOT_AUTHORIZED = 6,  /**< the target's policy refuses the request to its source (ub_policy.h) */
    UB_NACK_LIMIT = 7,           /**< the request exceeds the requester's limits (period, rows, bytes/s) */
    UB_NACK_UNSUPPORTED = 8,     /**< the target cannot do this: a membership operation (e.g. links: no handler),
                                      or inspecting a directory above UB_MAX_PAYLOAD bytes */
    UB_NACK_OTHER_ADMIN = 9,     /**< another administrator keeps this row alive (or, under an exclusive-administrator
                                      policy, holds rows at this node): the request changed nothing */
    UB_NACK_NO_SUCH_ROW = 10,    /**< inspection: no such table row, entity, or offset past the value's end */
    UB_NACK_BAD_VALUE = 11       /**< inspection: the target's codec refuses the value (e.g. a bool or enum out of range) */
} ub_nack_reason_t;

/** @return a static name ("table_full", "not_authorized", ...) for a NACK reason; "none" for 0, "?" if unknown. */
const char *ub_nack_reason_name(ub_nack_reason_t reason);

/** ACK status flags (byte 5 of an ACK payload). */
#define UB_ACK_FLOWING 0x01u /**< data is flowing for the acknowledged row */

/** NACK origin flags (byte 6 of a NACK payload). */
#define UB_NACK_RELAYED 0x01u /**< the reason is the source's, relayed by the destination of a subscription */

/** An operator row, as entered in the paper's Figure 5. */
typedef struct ub_admin_row_spec {
    uint32_t instance;                     /**< content: catalogue instance index */
    uint8_t source[UB_ENTITY_ID_LEN];      /**< publishing entity */
    uint8_t destination[UB_ENTITY_ID_LEN]; /**< receiving entity */
    uint32_t period_ms;                    /**< 1 / rate */
    ub_admin_row_type_t type;
} ub_admin_row_spec_t;

/** Status of a row, as read back by the operator. */
typedef struct ub_admin_row_info {
    ub_admin_row_spec_t spec;
    ub_admin_status_t status;
    bool active_flag;            /**< the operator's activation flag */
    ub_nack_reason_t nack_reason;
    bool nack_relayed;           /**< the NACK came from the source, relayed by the destination (subscription rows) */
    uint32_t request_id;
    uint32_t attempts;           /**< requests (or STOPs) sent since the last status change */
    uint64_t acked_at_ms;        /**< time of the first ACK after activation (0 = none yet) */
    uint64_t active_at_ms;       /**< time the row first became ACTIVE (0 = not yet) */
    uint64_t last_ack_ms;
    uint64_t last_data_ms;       /**< last DATA of the row's content from its source at its destination, when the
                                      destination is an entity of this node (0 = none, or not observable here) */
} ub_admin_row_info_t;

/** Admin timing. 0 in a field = default. */
typedef struct ub_admin_options {
    uint32_t retry_ms;         /**< resend period while PENDING or STOPPING; default 200 */
    uint32_t renew_ms;         /**< renewal period while ACKNOWLEDGED/ACTIVE; default 1000 */
    uint32_t lease_ms;         /**< lease requested at the target; default 3 * renew_ms */
    uint32_t max_retries;      /**< PENDING attempts before FAILED; 0 = retry forever (default) */
    uint32_t max_stop_retries; /**< STOPs at the retry pace before slowing to the renewal pace; default 10 */
} ub_admin_options_t;

/** Internal row state; read it through ub_admin_row_status(). */
typedef struct ub_admin_row {
    uint8_t in_use;
    uint8_t acked_status; /**< what the last ACK said (ACKNOWLEDGED or ACTIVE): the status once data flows again */
    ub_admin_row_info_t info;
    uint64_t next_send_ms;
} ub_admin_row_t;

/** The administration table. Caller-owned; must outlive its attachment to the node. */
typedef struct ub_admin {
    ub_node_t *node;
    int entity;                 /**< entity-table index of the hosting local entity */
    ub_admin_options_t opt;     /**< with defaults filled in */
    ub_admin_row_t rows[UB_MAX_ADMIN_ROWS];
} ub_admin_t;

/**
 * Initialises `adm` and attaches it to local entity `entity` of `node`
 * (one administration table per entity; replaces any previous one).
 * `opt` may be NULL for the defaults.
 * @return UB_OK, or UB_ERR_INVAL (NULL, or `entity` not local).
 */
UB_CHECK int ub_admin_init(ub_admin_t *adm, ub_node_t *node, int entity, const ub_admin_options_t *opt);

/** Detaches `adm` from its node; it stops being ticked. Safe on an unattached table. */
void ub_admin_detach(ub_admin_t *adm);

/**
 * Adds an inactive row.
 * @return the row index; UB_ERR_INVAL (bad instance index, period 0, source ==
 *         destination); UB_ERR_EXISTS (a row for the same content, source and
 *         destination, of either type: the two would fight over one flow);
 *         UB_ERR_FULL.
 */
UB_CHECK int ub_admin_add_row(ub_admin_t *adm, const ub_admin_row_spec_t *spec);

/**
 * Sets the operator's activation flag. Activating sends the request at the
 * next ub_node_tick() (status PENDING); deactivating sends the STOP (status
 * STOPPING). Setting the flag it already has changes nothing, except that
 * activating a FAILED row retries it.
 * @return UB_OK, UB_ERR_NOTFOUND (no such row).
 */
UB_CHECK int ub_admin_set_active(ub_admin_t *adm, int row, bool active, uint64_t now_ms);

/**
 * Removes a row; it must be INACTIVE, FAILED or STOPPING (removing a STOPPING
 * row abandons its STOP: a flow already handed over lives on at the target
 * until its keeper is gone, docs/pubsub.md).
 * @return UB_OK, UB_ERR_NOTFOUND, UB_ERR_INVAL (still active).
 */
UB_CHECK int ub_admin_remove_row(ub_admin_t *adm, int row);

/** Copies a row's status out. @return UB_OK or UB_ERR_NOTFOUND. */
UB_CHECK int ub_admin_row_status(const ub_admin_t *adm, int row, ub_admin_row_info_t *out);

#ifdef __cplusplus
}
#endif
#endif /* UB_ADMIN_H */
