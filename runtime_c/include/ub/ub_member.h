/**
 * @file ub_member.h
 * @brief Membership over the bus: an administrator adds and removes entities,
 *        links and masks of a running node (paper II: "the presence of a new
 *        node must be announced to the existing nodes ... the operator
 *        manually notifies nodes about the existence of other nodes").
 *
 * A MEMBERSHIP frame (admin code 11, routed like any request) asks its
 * destination entity (the *target*) to apply one operation to its node:
 *
 *   UB_MEMBER_ADD_ENTITY     add `subject` as a remote entity (the announcement)
 *   UB_MEMBER_REMOVE_ENTITY  remove `subject` and everything naming it (ub_node_remove_entity())
 *   UB_MEMBER_SET_MASK       set the target's mask toward `subject` by hand (pins it; 0 unpins)
 *   UB_MEMBER_ADD_LINK       create link[`link_index`] `link_name` of the target, with port spec text
 *   UB_MEMBER_REMOVE_LINK    close and remove link `link_name` of the target
 *
 * Every target serves the entity and mask operations itself. Link operations
 * need a transport, which only the application can open: they are served
 * when the target's node has a ub_member_t with a link handler
 * (ub_member_set_link_handler(); uavbus_node installs one over ub_ports),
 * else refused with NACK UB_NACK_UNSUPPORTED.
 *
 * The target answers ACK (detail bit UB_MEMBER_CHANGED: the table changed; 0:
 * it already was so; every operation is idempotent, so retries are safe) or
 * NACK with a reason: UB_NACK_INVALID (bad payload, unknown operation, a
 * local entity to remove, an unknown destination or link), UB_NACK_TABLE_FULL,
 * UB_NACK_UNSUPPORTED, or UB_NACK_NOT_AUTHORIZED when
 * ub_node_may_administer() refuses the requester (which also counts a
 * `not_authorized` drop; requests between entities of one node are not judged).
 *
 * The requesting side is a caller-owned ub_member_t attached to the node
 * (ub_member_init()): ub_member_request() queues a request, ub_node_tick()
 * sends it every `retry_ms` until answered (or `max_retries` times), and the
 * reply sets its status, as the administration table does for its rows.
 * Payload layout: docs/routing.md, "MEMBERSHIP".
 */
#ifndef UB_MEMBER_H
#define UB_MEMBER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "ub_admin.h"
#include "ub_config.h"
#include "ub_error.h"
#include "ub_link.h"
#include "ub_node.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Longest port spec text carried by ADD_LINK, including the NUL. */
#define UB_MEMBER_SPEC_LEN 96
/** Payload offsets and sizes (docs/routing.md). */
#define UB_MEMBER_OFF_ID 0u
#define UB_MEMBER_OFF_OP 4u
#define UB_MEMBER_OFF_ARG 5u
#define UB_MEMBER_OFF_SUBJECT 8u
#define UB_MEMBER_OFF_LINK 20u
#define UB_MEMBER_OFF_SPEC 52u
#define UB_MEMBER_ENTITY_LEN 20u /**< ADD/REMOVE_ENTITY, SET_MASK */
#define UB_MEMBER_LINK_LEN 52u   /**< REMOVE_LINK; ADD_LINK without a spec */

/** ACK detail bit: the operation changed the target's tables. */
#define UB_MEMBER_CHANGED 0x01u

typedef enum ub_member_op {
    UB_MEMBER_ADD_ENTITY = 1,
    UB_MEMBER_REMOVE_ENTITY = 2,
    UB_MEMBER_SET_MASK = 3,
    UB_MEMBER_ADD_LINK = 4,
    UB_MEMBER_REMOVE_LINK = 5
} ub_member_op_t;

/** @return a static name ("add_entity", ...) for an operation, "?" if unknown. */
const char *ub_member_op_name(ub_member_op_t op);

/** One request, as the operator enters it. */
typedef struct ub_member_spec {
    uint8_t op;                               /**< ub_member_op_t */
    uint8_t target[UB_ENTITY_ID_LEN];         /**< entity whose node applies it */
    uint8_t subject[UB_ENTITY_ID_LEN];        /**< entity added/removed, or the mask's destination */
    uint8_t mask;                             /**< SET_MASK */
    uint8_t link_index;                       /**< ADD_LINK: the target's link[index] */
    char link_name[UB_LINK_NAME_LEN];         /**< ADD_LINK, REMOVE_LINK */
    char port_spec[UB_MEMBER_SPEC_LEN];       /**< ADD_LINK: "udp:bind=...,peer=..." (may be empty) */
} ub_member_spec_t;

typedef enum ub_member_status {
    UB_MEMBER_FREE = 0,
    UB_MEMBER_PENDING,  /**< sent every retry_ms until answered */
    UB_MEMBER_DONE,     /**< ACKed */
    UB_MEMBER_FAILED    /**< NACKed (nack_reason), or max_retries without an answer (nack_reason 0) */
} ub_member_status_t;

/** @return a static name ("pending", ...) for a status. */
const char *ub_member_status_name(ub_member_status_t status);

typedef struct ub_member_info {
    ub_member_spec_t spec;
    uint8_t status;          /**< ub_member_status_t */
    uint8_t nack_reason;     /**< ub_nack_reason_t when FAILED by a NACK */
    bool changed;            /**< DONE: the target's table changed (false: it already was so) */
    uint32_t request_id;
    uint32_t attempts;
    uint64_t done_ms;        /**< time of the answer */
} ub_member_info_t;

/** Requester timing; 0 = default. */
typedef struct ub_member_options {
    uint32_t retry_ms;    /**< resend period while pending; default 200 */
    uint32_t max_retries; /**< attempts before FAILED; default 0 = until answered */
} ub_member_options_t;

/**
 * Serves ADD_LINK / REMOVE_LINK at the target: open (`spec`, may be "") or
 * close the transport of link `name` of local entity `entity` and create or
 * remove the slot (ub_node_add_link() / ub_node_remove_link()).
 * @return UB_OK, UB_ERR_EXISTS / UB_ERR_NOTFOUND (already so: ACKed as
 *         unchanged), UB_ERR_FULL (NACK table_full), other < 0 (NACK invalid).
 */
typedef int (*ub_member_link_fn)(void *user, ub_node_t *node, int entity, ub_member_op_t op, unsigned index,
                                 const char *name, const char *spec, uint64_t now_ms);

typedef struct ub_member_counters {
    uint64_t sent;              /**< requests sent (first attempts and retries) */
    uint64_t done;              /**< ACKed */
    uint64_t failed;            /**< NACKed or retries exhausted */
    uint64_t unmatched_replies; /**< membership replies for no pending row (late duplicates), or from another entity */
} ub_member_counters_t;

typedef struct ub_member_row {
    uint8_t in_use;
    ub_member_info_t info;
    uint64_t next_send_ms;
} ub_member_row_t;

/** The requester (and link-operation server) of one node. Caller-owned; treat the fields as private. */
typedef struct ub_member {
    ub_node_t *node;
    int entity;               /**< local entity the requests come from */
    ub_member_options_t opt;
    ub_member_link_fn link_fn;
    void *link_user;
    ub_member_row_t rows[UB_MAX_MEMBER_REQUESTS];
    ub_member_counters_t counters;
    ub_service_t svc; /**< its registration with the node (ub_service.h): serves requests, takes their replies */
} ub_member_t;

/**
 * Initialises `m` and attaches it to `node` (one per node; replaces any
 * previous one): requests come from local entity `entity`.
 * @return UB_OK, UB_ERR_INVAL (NULL, `entity` not local), UB_ERR_FULL (the node's service table,
 *         UB_MAX_SERVICES, is full: nothing attached, the node goes on serving requests).
 */
UB_CHECK int ub_member_init(ub_member_t *m, ub_node_t *node, int entity, const ub_member_options_t *opt);

/** Detaches `m` from its node (pending requests stop). Safe on a detached one. */
void ub_member_detach(ub_member_t *m);

/** Installs (or with NULL removes) the handler serving link operations at this node. */
void ub_member_set_link_handler(ub_member_t *m, ub_member_link_fn fn, void *user);

/**
 * Queues a request; it leaves at the next ub_node_tick().
 * @return the row; UB_ERR_INVAL (unknown op, zero or link-local IDs, subject
 *         missing for an entity/mask op, link name missing or too long for a
 *         link op, index >= UB_MAX_LINKS_PER_ENTITY, spec without its NUL);
 *         UB_ERR_FULL (every row pending or unread: ub_member_forget() some).
 */
UB_CHECK int ub_member_request(ub_member_t *m, const ub_member_spec_t *spec, uint64_t now_ms);

/** Copies a row's status out. @return UB_OK or UB_ERR_NOTFOUND. */
UB_CHECK int ub_member_status(const ub_member_t *m, int row, ub_member_info_t *out);

/** Frees a row in any state (a pending request is no longer sent). @return UB_OK or UB_ERR_NOTFOUND. */
UB_CHECK int ub_member_forget(ub_member_t *m, int row);

/** @return the requester's counters. */
const ub_member_counters_t *ub_member_counters(const ub_member_t *m);

/**
 * Applies `spec` to local entity `entity` of `node` here, exactly as a
 * received request would be (the stdin commands of uavbus_node use it). The
 * link operations go to the node's ub_member_t link handler.
 * @return 0 and `*changed` on success, else the NACK reason (ub_nack_reason_t).
 */
uint8_t ub_member_apply(ub_node_t *node, int entity, const ub_member_spec_t *spec, uint64_t now_ms, bool *changed);

#ifdef __cplusplus
}
#endif
#endif /* UB_MEMBER_H */
