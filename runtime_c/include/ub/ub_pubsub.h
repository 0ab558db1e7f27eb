/**
 * @file ub_pubsub.h
 * @brief Per-entity publish/subscribe tables (paper III.B), driven by the
 *        injected clock of ub_node_tick().
 *
 * Every local entity of a node owns one table of UB_MAX_PUBSUB_ROWS rows,
 * stored inside ub_node_t. A row is either
 *
 *  - a **publication** (content, destination, period): the entity sends the
 *    bound instance as DATA to the destination every period. Rows created by a
 *    remote PUB_REQUEST carry a **lease**: they disappear unless renewed
 *    before `lease_until_ms`;
 *  - a **subscription** (content, source, period): the entity sends
 *    PUB_REQUEST to the source every `retry_ms` until DATA arrives, renews it
 *    every `renew_ms` while data flows, and requests again at once when no
 *    DATA came for the **data timeout** = max(3 * period, timeout_min_ms).
 *    Rows created by a remote SUB_REQUEST (the administration table) carry a
 *    lease as well.
 *
 * Stopping a subscription puts it in the STOPPING state: it sends PUB_STOP to
 * the source every `retry_ms` until acknowledged (at most `stop_retries`
 * times; the source's lease cleans up after that) and then frees the row. So
 * PUB_STOP / SUB_STOP remove the entries at both ends. Leases, the choice and
 * the payload layouts are documented in docs/pubsub.md.
 *
 * Flows outlive their administrator (docs/pubsub.md, "Who keeps a row
 * alive"): a row an administrator created for a flow between two other
 * entities (a subscription at the destination, a publication at the source
 * toward someone else) is a lease only while the administrator renews it.
 * When that lease lapses the row is handed over to its **keeper**, the
 * flow's other end: it lives on while the keeper shows signs of life (a
 * subscription: the source acknowledges its requests; a publication: the
 * node has a route to the destination) and is reclaimed `expiry_ms` after the
 * last one. A publication requested by its own destination stays a plain
 * lease (the destination is its keeper and renews it).
 *
 * No silent status: a source's NACK to a subscription set up by an
 * administrator is relayed to that administrator (NACK flag "relayed"); a
 * second administrator asking for a row another one keeps alive is answered
 * NACK OTHER_ADMIN, and never moves or stops the first one's row.
 *
 * Scheduling: a publication's next send is `previous due + period`, so rates do
 * not drift; after a stall longer than a period it sends once and restarts the
 * schedule from `now` (no burst of missed frames).
 *
 * Remote requests and STOPs are judged by the node's policy when one is
 * attached (ub_policy.h: administrators, read rules, limits; refusals are
 * NACK NOT_AUTHORIZED or LIMIT). Replies count only for the row they are
 * bound to: its random request id, its counterpart, its content
 * (docs/pubsub.md, "Authorization and limits").
 *
 * Entities are addressed by their index in the node's entity table (see
 * ub_node_add_entity()); the functions below require a local entity.
 */
#ifndef UB_PUBSUB_H
#define UB_PUBSUB_H

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

/** Kind of a publish/subscribe row. */
typedef enum ub_ps_kind {
    UB_PS_FREE = 0,
    UB_PS_PUBLICATION = 1,
    UB_PS_SUBSCRIPTION = 2
} ub_ps_kind_t;

/** State of a subscription row. */
typedef enum ub_sub_state {
    UB_SUB_REQUESTING = 0, /**< no data yet (or timed out): PUB_REQUEST every retry_ms */
    UB_SUB_RECEIVING = 1,  /**< data flowing: PUB_REQUEST renewal every renew_ms */
    UB_SUB_STOPPING = 2    /**< PUB_STOP sent, waiting for the ACK before freeing the row */
} ub_sub_state_t;

/** Timing of all tables of a node (ub_node_options_t.timing). 0 in a field = its default. */
typedef struct ub_pubsub_timing {
    uint32_t retry_ms;       /**< request / stop retry period; default 200 */
    uint32_t renew_ms;       /**< renewal period of remote entries; default 1000 */
    uint32_t lease_ms;       /**< lease written into requests; default 3 * renew_ms */
    uint32_t timeout_min_ms; /**< lower bound of the data timeout; default 500 */
    uint32_t stop_retries;   /**< PUB_STOP attempts before leaving it to the lease; default 10 */
    uint32_t expiry_ms;      /**< a handed-over row is reclaimed this long after its keeper's last sign of life;
                                  default 60000 (docs/pubsub.md, "Who keeps a row alive") */
} ub_pubsub_timing_t;

#define UB_PS_DEFAULT_RETRY_MS 200u
#define UB_PS_DEFAULT_RENEW_MS 1000u
#define UB_PS_DEFAULT_TIMEOUT_MIN_MS 500u
#define UB_PS_DEFAULT_STOP_RETRIES 10u
#define UB_PS_DEFAULT_EXPIRY_MS 60000u

/** One row. Read it with ub_pubsub_row(); change it only through this API. */
typedef struct ub_ps_row {
    uint8_t kind;                        /**< ub_ps_kind_t */
    uint8_t state;                       /**< ub_sub_state_t (subscriptions) */
    uint8_t acked;                       /**< subscription: the source acknowledged a request */
    uint8_t reported_flowing;            /**< a FLOWING status was sent to the owner */
    uint8_t source_acked;                /**< subscription: the source acknowledged a request since the row's
                                              last (re)activation, and has not refused one since */
    uint8_t source_nack;                 /**< subscription: the source's last answer was this NACK reason (0: not a NACK) */
    uint8_t handed_over;                 /**< the owner's lease lapsed; the row lives on its keeper (counted once) */
    uint8_t keeper_seen;                 /**< keeper_ms is valid */
    uint32_t instance;                   /**< catalogue instance index (the content) */
    uint8_t peer[UB_ENTITY_ID_LEN];      /**< publication: destination; subscription: source */
    uint8_t owner[UB_ENTITY_ID_LEN];     /**< who created the row remotely; all zero = local API */
    uint32_t owner_request_id;           /**< owner's request id, echoed in status ACKs */
    uint32_t request_id;                 /**< id of this row's own requests (subscriptions): random, never 0 */
    uint32_t period_ms;
    uint32_t stop_tries;                 /**< PUB_STOPs sent while STOPPING */
    uint64_t lease_until_ms;             /**< owner's lease; 0 = no lease (created through this API, or asked so) */
    uint64_t keeper_ms;                  /**< last sign of life of the row's keeper (subscription: the source's
                                              ACK or DATA; publication: a route to the destination) */
    uint64_t next_due_ms;                /**< publication: next DATA; subscription: next request */
    uint64_t last_data_ms;               /**< subscription: last DATA received */
    uint64_t frames;                     /**< publication: DATA sent; subscription: DATA received */
    uint8_t update_pending;              /**< publication on update: a new value waits for its turn */
} ub_ps_row_t;

/** The table of one local entity (part of ub_node_t). */
typedef struct ub_pubsub_table {
    ub_ps_row_t rows[UB_MAX_PUBSUB_ROWS];
    struct ub_admin *admin; /**< the administration table attached to the entity (ub_admin.h), or NULL */
    uint32_t rows_used;     /**< rows [rows_used, UB_MAX_PUBSUB_ROWS) were never taken, so are free: searches stop there */
    uint32_t admin_slots;   /**< bit s: local slot s has an administration table attached; the same in every table
                                 of the node, so DATA (delivered to any slot) asks the tables only when there is one */
} ub_pubsub_table_t;

/**
 * Adds (or updates) a publication of `instance` from local entity `entity` to
 * `dest_id`, every `period_ms`, without lease. The first DATA leaves at the
 * next ub_node_tick() at or after `now_ms`.
 * @return the row index; UB_ERR_INVAL (not a local entity, period 0, instance
 *         out of range), UB_ERR_FULL.
 */
UB_CHECK int ub_pubsub_publish(ub_node_t *node, int entity, uint32_t instance, const uint8_t dest_id[UB_ENTITY_ID_LEN],
                               uint32_t period_ms, uint64_t now_ms);

/**
 * Adds (or updates) a subscription of local entity `entity` to `instance` from
 * `source_id`, every `period_ms`, without lease. The first PUB_REQUEST leaves
 * at the next ub_node_tick().
 * @return the row index; UB_ERR_INVAL, UB_ERR_FULL.
 */
UB_CHECK int ub_pubsub_subscribe(ub_node_t *node, int entity, uint32_t instance,
                                 const uint8_t source_id[UB_ENTITY_ID_LEN], uint32_t period_ms, uint64_t now_ms);

/**
 * Stops a row: a publication is freed at once; a subscription goes to
 * UB_SUB_STOPPING (PUB_STOP to the source until ACKed) and is freed then.
 * A publication created by a remote request comes back with its owner's next
 * renewal: stop such flows at their owner (subscriber or admin table).
 * @return UB_OK; UB_ERR_INVAL; UB_ERR_NOTFOUND (free row).
 */
UB_CHECK int ub_pubsub_stop(ub_node_t *node, int entity, int row, uint64_t now_ms);

/**
 * Finds a live row (not free, not stopping) of `kind` for (instance, peer).
 * @return the row index, UB_ERR_NOTFOUND, or UB_ERR_INVAL.
 */
UB_CHECK int ub_pubsub_find(const ub_node_t *node, int entity, ub_ps_kind_t kind, uint32_t instance,
                            const uint8_t peer[UB_ENTITY_ID_LEN]);

/** @return the row, or NULL if `entity`/`row` is out of range. Free rows have kind UB_PS_FREE. */
const ub_ps_row_t *ub_pubsub_row(const ub_node_t *node, int entity, int row);

/** @return the number of rows of `kind` (UB_PS_FREE counts free rows), or UB_ERR_INVAL. */
UB_CHECK int ub_pubsub_count(const ub_node_t *node, int entity, ub_ps_kind_t kind);

/**
 * Publishes bound instance `instance` **on update** instead of on a timer: for
 * directories refreshed from outside the node at their own pace (a bridge's
 * telemetry, e.g. the MAVLink bridge, docs/bridges.md). A publication row of
 * such an instance sends the bound value once after each ub_pubsub_updated(),
 * as soon as its period allows, and never sends a value twice:
 *
 *  - the period is the row's spacing: the row may send when `now + period/2`
 *    reaches its next due time, which then advances by one period (and never
 *    lags `now` by more than half a period). A source at the row's rate with
 *    up to half a period of jitter has every update sent at once; a faster
 *    source is thinned to the period, without drift; an update that comes
 *    too early waits (only the latest value) for its turn at the next tick;
 *  - a source that stops updating stops the data: subscribers see their data
 *    time out (ub_pubsub.h) instead of copies of a stale value.
 *
 * Applies to the rows of every local entity, existing and future.
 * @return UB_OK; UB_ERR_INVAL (NULL node); UB_ERR_NOTFOUND (`instance` not bound).
 */
UB_CHECK int ub_pubsub_set_on_update(ub_node_t *node, uint32_t instance, bool on_update);

/**
 * The bound value of on-update instance `instance` (ub_pubsub_set_on_update())
 * was just refreshed: every publication row of it at local entity `entity`
 * whose turn has come sends it now; the others send it at their turn.
 * @return the number of rows that sent now (>= 0); UB_ERR_INVAL (not a local
 *         entity, or the instance is not published on update).
 */
UB_CHECK int ub_pubsub_updated(ub_node_t *node, int entity, uint32_t instance, uint64_t now_ms);

/** @return the data timeout of a subscription with `period_ms` under `timing`: max(3 * period, timeout_min_ms). */
uint64_t ub_pubsub_data_timeout_ms(const ub_pubsub_timing_t *timing, uint32_t period_ms);

#ifdef __cplusplus
}
#endif
#endif /* UB_PUBSUB_H */
