/*
 * The retry-until-answered request rows that membership (ub_member.c) and inspection (ub_inspect.c)
 * keep, as one helper: when a pending row is sent again or given up, and which answer is bound to it.
 * Private to the service layer; public headers only (layer_check). The administration table keeps its
 * own state machine (renewals, STOPs, leases: ub_admin.c), which this does not try to cover.
 */
#ifndef UB_REQUESTER_H
#define UB_REQUESTER_H

#include <stdbool.h>
#include <stdint.h>

#include "ub/ub_node.h"
#include "ub/ub_node_svc.h"

typedef enum ub_req_step {
    UB_REQ_WAIT = 0, /* not due yet */
    UB_REQ_SEND,     /* due: the attempt is counted and the next one scheduled; send it now (last) */
    UB_REQ_GIVE_UP   /* `max_retries` attempts went unanswered: the row fails */
} ub_req_step_t;

/* A pending row at tick time: sent every `retry_ms` until answered, at most `max_retries` times (0: no limit). */
static inline ub_req_step_t ub_req_step(uint64_t *next_send_ms, uint32_t *attempts, uint32_t retry_ms,
                                        uint32_t max_retries, uint64_t now_ms) {
    if (now_ms < *next_send_ms) return UB_REQ_WAIT;
    if (max_retries != 0 && *attempts >= max_retries) return UB_REQ_GIVE_UP;
    (*attempts)++;
    *next_send_ms = now_ms + retry_ms;
    return UB_REQ_SEND;
}

/* A pending row's next due time for the service's `next_due` (ub_service.h): its next send, or now. */
static inline void ub_req_due(uint64_t next_send_ms, uint64_t now_ms, uint64_t *best) {
    uint64_t due = next_send_ms < now_ms ? now_ms : next_send_ms;
    if (due < *best) *best = due;
}

/* Whether an answer from `src_id` that reached local slot `slot` is bound to a pending row asking `target`
 * from entity `requester`: it must come from the target and reach the requesting entity (the request id
 * the caller has matched already). */
static inline bool ub_req_bound(const ub_node_t *node, int slot, int requester, const uint8_t src_id[UB_ENTITY_ID_LEN],
                                const uint8_t target[UB_ENTITY_ID_LEN]) {
    return ub_entity_id_eq(src_id, target) && ub_node_entity_slot(node, requester) == slot;
}

#endif /* UB_REQUESTER_H */
