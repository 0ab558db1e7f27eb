/**
 * @file ub_inspect.h
 * @brief Remote inspection and change over the bus: the paper's variable
 *        browser (Figures 4, 5 and 8) for any entity of any node.
 *
 * An INSPECT request (admin code 12, routed like any request, so it works
 * over several hops) asks its destination entity (the *target*) to:
 *
 *   UB_INSPECT_READ        send the current value of a directory it hosts (once)
 *   UB_INSPECT_WRITE       write bytes of a directory's packed image (the whole
 *                          directory, or one field at its packed offset)
 *   UB_INSPECT_LIST        list one of its tables (entities with masks, links
 *                          with counters, publish/subscribe rows, admin rows)
 *   UB_INSPECT_SET_PERIOD  change the period of one of its publish/subscribe rows
 *   UB_INSPECT_SET_MASK    set its link mask toward an entity (pinned, as ub_node_set_mask())
 *   UB_INSPECT_ADMIN_ROW   change one of its administration rows in place
 *                          (period, or activation flag)
 *
 * Every target serves these itself; nothing to attach. READ and LIST are
 * answered with an INSPECT_VALUE frame (admin code 13) carrying the bytes; the
 * others with ACK (detail 1: the value changed, 0: it already was so) and every
 * refusal with a NACK naming its reason. Values longer than one payload come
 * in chunks: a reply says the total and the offset of the next chunk (or row),
 * and the requester asks for it (ub_inspect_read_all() style loops live in the
 * callers: Python's Node.remote()).
 *
 * Permission (with a policy attached, ub_policy.h; requests between entities
 * of one node are not judged): READ needs a read rule naming (target,
 * requester, content) when reads are restricted; WRITE needs a write rule
 * naming (target, requester, content); LIST and the table changes need an
 * administrator (ub_node_may_administer()); an administrator may do all. With
 * a security context attached, an administrator's request counts only in a
 * frame whose tag verified (a forged source ID learns nothing). A refusal is
 * NACK UB_NACK_NOT_AUTHORIZED and counts a `not_authorized` drop.
 *
 * The requester is a caller-owned ub_inspect_t attached to the node
 * (ub_inspect_init()): ub_inspect_request() queues a request, ub_node_tick()
 * sends it every `retry_ms` until answered (or `max_retries` times), and the
 * reply (bound to the row by its random request id and the target's ID) sets
 * its status and, for READ and LIST, copies the bytes into the row.
 * Payload layouts: docs/inspect.md.
 */
#ifndef UB_INSPECT_H
#define UB_INSPECT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "ub_config.h"
#include "ub_error.h"
#include "ub_node.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Request payload (admin code UB_ADMIN_INSPECT) offsets; data from UB_INSPECT_REQ_DATA. */
#define UB_INSPECT_REQ_ID 0u
#define UB_INSPECT_REQ_OP 4u
#define UB_INSPECT_REQ_ARG 5u
#define UB_INSPECT_REQ_OFFSET 6u
#define UB_INSPECT_REQ_VALUE 8u
#define UB_INSPECT_REQ_DATA 12u
/** Value payload (admin code UB_ADMIN_INSPECT_VALUE) offsets; data from UB_INSPECT_VAL_DATA. */
#define UB_INSPECT_VAL_ID 0u
#define UB_INSPECT_VAL_OP 4u
#define UB_INSPECT_VAL_ARG 5u
#define UB_INSPECT_VAL_OFFSET 6u
#define UB_INSPECT_VAL_TOTAL 8u
#define UB_INSPECT_VAL_NEXT 10u
#define UB_INSPECT_VAL_DATA 12u
/** Most data bytes in one value reply, and in one write request. */
#define UB_INSPECT_CHUNK (UB_MAX_PAYLOAD - UB_INSPECT_VAL_DATA)
/** `next` of the last chunk / page. */
#define UB_INSPECT_END 0xFFFFu

/** Table records (LIST), little-endian, fixed size per table (docs/inspect.md). */
#define UB_INSPECT_ENTITY_REC 16u /**< id[12] local mask pinned reserved */
#define UB_INSPECT_LINK_REC 60u   /**< name[32] index attached 2*reserved, u32: frames_in frames_out bytes_in bytes_out drops accepted */
#define UB_INSPECT_PUBSUB_REC 52u /**< row u16 kind state dir[16] peer[12] owner[12] period u32 frames u32 */
#define UB_INSPECT_ADMIN_REC 52u  /**< row u16 type status dir[16] source[12] destination[12] period u32 active nack 2*reserved */

typedef enum ub_inspect_op {
    UB_INSPECT_READ = 1,
    UB_INSPECT_WRITE = 2,
    UB_INSPECT_LIST = 3,
    UB_INSPECT_SET_PERIOD = 4,
    UB_INSPECT_SET_MASK = 5,
    UB_INSPECT_ADMIN_ROW = 6
} ub_inspect_op_t;

/** Tables for UB_INSPECT_LIST (the request's `arg`). */
typedef enum ub_inspect_table {
    UB_INSPECT_ENTITIES = 1,
    UB_INSPECT_LINKS = 2,
    UB_INSPECT_PUBSUB = 3,
    UB_INSPECT_ADMIN = 4
} ub_inspect_table_t;

/** What UB_INSPECT_ADMIN_ROW changes (the request's `arg`); the new value is `value`. */
typedef enum ub_inspect_admin_field {
    UB_INSPECT_ADMIN_PERIOD = 1, /**< period in ms (> 0); an active row sends its request again at once */
    UB_INSPECT_ADMIN_ACTIVE = 2  /**< the activation flag (0 or 1), as ub_admin_set_active() */
} ub_inspect_admin_field_t;

/** @return a static name ("read", "list", ...) for an operation, "?" if unknown. */
const char *ub_inspect_op_name(ub_inspect_op_t op);

/* ---- payload layouts (docs/inspect.md), as pure encoders: the requester and the server use them, and
 * tests/vectors/inspect.json pins them byte for byte ---------------------------------------------------- */

/** An entity table record (LIST entities). */
typedef struct ub_inspect_entity_rec {
    uint8_t id[UB_ENTITY_ID_LEN];
    uint8_t local;  /**< hosted by the answering node */
    uint8_t mask;   /**< the target's link mask toward this entity */
    uint8_t pinned; /**< the mask is pinned (routing leaves it) */
} ub_inspect_entity_rec_t;

/** A link record (LIST links); counters saturate at UINT32_MAX. */
typedef struct ub_inspect_link_rec {
    char name[UB_LINK_NAME_LEN]; /**< NUL-padded, not necessarily NUL-terminated */
    uint8_t index, attached;
    uint32_t frames_in, frames_out, bytes_in, bytes_out, drops, accepted;
} ub_inspect_link_rec_t;

/** A publish/subscribe row record (LIST pubsub). */
typedef struct ub_inspect_pubsub_rec {
    uint16_t row;
    uint8_t kind, state; /**< kind: 1 publication, 2 subscription */
    uint8_t dir_id[UB_DIR_ID_LEN];
    uint8_t peer[UB_ENTITY_ID_LEN];
    uint8_t owner[UB_ENTITY_ID_LEN]; /**< zero: the local API */
    uint32_t period_ms, frames;
} ub_inspect_pubsub_rec_t;

/** An administration row record (LIST admin). */
typedef struct ub_inspect_admin_rec {
    uint16_t row;
    uint8_t type, status; /**< type: 0 publication, 1 subscription; status: ub_admin_status_t */
    uint8_t dir_id[UB_DIR_ID_LEN];
    uint8_t source[UB_ENTITY_ID_LEN];
    uint8_t destination[UB_ENTITY_ID_LEN];
    uint32_t period_ms;
    uint8_t active, nack_reason;
} ub_inspect_admin_rec_t;

void ub_inspect_put_entity_rec(uint8_t p[UB_INSPECT_ENTITY_REC], const ub_inspect_entity_rec_t *r);
void ub_inspect_put_link_rec(uint8_t p[UB_INSPECT_LINK_REC], const ub_inspect_link_rec_t *r);
void ub_inspect_put_pubsub_rec(uint8_t p[UB_INSPECT_PUBSUB_REC], const ub_inspect_pubsub_rec_t *r);
void ub_inspect_put_admin_rec(uint8_t p[UB_INSPECT_ADMIN_REC], const ub_inspect_admin_rec_t *r);

/** Writes the fixed part of an INSPECT_VALUE payload (UB_INSPECT_VAL_DATA bytes); the data follows. */
void ub_inspect_put_value_head(uint8_t p[UB_INSPECT_VAL_DATA], uint32_t request_id, uint8_t op, uint8_t arg,
                               uint16_t offset, uint16_t total, uint16_t next);

/** One request, as the operator enters it. */
typedef struct ub_inspect_spec {
    uint8_t op;                       /**< ub_inspect_op_t */
    uint8_t arg;                      /**< LIST: table; ADMIN_ROW: field */
    uint16_t offset;                  /**< READ/WRITE: byte offset in the packed image; LIST: first row;
                                           SET_PERIOD/ADMIN_ROW: row index */
    uint32_t value;                   /**< SET_PERIOD/ADMIN_ROW: new value; SET_MASK: the mask */
    uint32_t instance;                /**< READ/WRITE: catalogue instance (the requester's catalogue) */
    uint8_t target[UB_ENTITY_ID_LEN]; /**< entity whose node answers */
    uint8_t subject[UB_ENTITY_ID_LEN];/**< SET_MASK: the destination entity */
    uint16_t len;                     /**< WRITE: bytes in `data` (<= UB_INSPECT_CHUNK) */
    uint8_t data[UB_INSPECT_CHUNK];   /**< WRITE: the bytes written at `offset` */
} ub_inspect_spec_t;

typedef enum ub_inspect_status {
    UB_INSPECT_FREE = 0,
    UB_INSPECT_PENDING, /**< sent every retry_ms until answered */
    UB_INSPECT_DONE,    /**< answered: ACK, or the value in `data` */
    UB_INSPECT_FAILED   /**< NACKed (nack_reason), or max_retries without an answer (nack_reason 0) */
} ub_inspect_status_t;

/** @return a static name ("pending", ...) for a status. */
const char *ub_inspect_status_name(ub_inspect_status_t status);

/** A request's outcome. */
typedef struct ub_inspect_result {
    uint8_t status;      /**< ub_inspect_status_t */
    uint8_t nack_reason; /**< ub_nack_reason_t when FAILED by a NACK */
    bool changed;        /**< DONE by ACK: the target's value changed */
    uint32_t request_id;
    uint32_t attempts;
    uint64_t sent_ms;    /**< first attempt */
    uint64_t done_ms;    /**< time of the answer */
    uint16_t total;      /**< value replies: READ: packed size; LIST: rows in the table */
    uint16_t next;       /**< value replies: next offset / row to ask for, UB_INSPECT_END when complete */
    uint16_t len;        /**< bytes in data */
    uint8_t data[UB_INSPECT_CHUNK];
} ub_inspect_result_t;

/** Requester timing; 0 = default. */
typedef struct ub_inspect_options {
    uint32_t retry_ms;    /**< resend period while pending; default 200 */
    uint32_t max_retries; /**< attempts before FAILED; default 0 = until answered */
} ub_inspect_options_t;

typedef struct ub_inspect_counters {
    uint64_t sent;              /**< requests sent (first attempts and retries) */
    uint64_t done;
    uint64_t failed;
    uint64_t unmatched_replies; /**< replies for no pending row, or from another entity */
} ub_inspect_counters_t;

typedef struct ub_inspect_row {
    uint8_t in_use;
    ub_inspect_spec_t spec;
    ub_inspect_result_t result;
    uint64_t next_send_ms;
} ub_inspect_row_t;

/** The requester of one node. Caller-owned; treat the fields as private. */
typedef struct ub_inspect {
    ub_node_t *node;
    int entity; /**< local entity the requests come from */
    ub_inspect_options_t opt;
    ub_inspect_row_t rows[UB_MAX_INSPECT_REQUESTS];
    ub_inspect_counters_t counters;
    ub_service_t svc; /**< its registration with the node (ub_service.h): serves requests, takes the answers */
} ub_inspect_t;

/**
 * Writes the INSPECT payload of `spec` with `request_id` into `p` (`cap` bytes): the fixed part, then
 * WRITE's data or SET_MASK's subject. @return its length, or 0 if it does not fit in `cap` (or `p` or
 * `spec` is NULL).
 */
size_t ub_inspect_put_request(uint8_t *p, size_t cap, uint32_t request_id, const ub_inspect_spec_t *spec);

/**
 * Initialises `in` and attaches it to `node` (one per node; replaces any
 * previous one): requests come from local entity `entity`.
 * @return UB_OK, UB_ERR_INVAL (NULL, `entity` not local), UB_ERR_FULL (the node's service table,
 *         UB_MAX_SERVICES, is full: nothing attached, the node goes on serving requests).
 */
UB_CHECK int ub_inspect_init(ub_inspect_t *in, ub_node_t *node, int entity, const ub_inspect_options_t *opt);

/** Detaches `in` from its node (pending requests stop). Safe on a detached one. */
void ub_inspect_detach(ub_inspect_t *in);

/**
 * Queues a request; it leaves at the next ub_node_tick().
 * @return the row; UB_ERR_INVAL (unknown op or table, zero or link-local
 *         target, instance out of range, WRITE without data or longer than
 *         UB_INSPECT_CHUNK, SET_MASK without subject); UB_ERR_FULL (every row
 *         in use: ub_inspect_forget() some).
 */
UB_CHECK int ub_inspect_request(ub_inspect_t *in, const ub_inspect_spec_t *spec, uint64_t now_ms);

/** Copies a row's outcome out. @return UB_OK or UB_ERR_NOTFOUND. */
UB_CHECK int ub_inspect_result(const ub_inspect_t *in, int row, ub_inspect_result_t *out);

/** Frees a row in any state (a pending request is no longer sent). @return UB_OK or UB_ERR_NOTFOUND. */
UB_CHECK int ub_inspect_forget(ub_inspect_t *in, int row);

/** @return the requester's counters. */
const ub_inspect_counters_t *ub_inspect_counters(const ub_inspect_t *in);

#ifdef __cplusplus
}
#endif
#endif /* UB_INSPECT_H */
