/* A service that records the transport evidence a node hands its services (ub_node_link_event(), ub_service.h):
 * the driver tests attach it to see that a TCP reset/close, a serial hang-up or an ICMP "unreachable" reaches
 * the services as a link event, on the right link, at once. Header-only: each test file has its own copy. */
#ifndef UB_TEST_LINK_EVENTS_H
#define UB_TEST_LINK_EVENTS_H

#include <string.h>

#include "ub/ub_node.h"
#include "ub/ub_service.h"

typedef struct link_events {
    ub_service_t svc;
    int downs, ups;
    int last_link;
    uint64_t last_ms;
} link_events_t;

static void link_events_cb(const ub_service_t *svc, ub_node_t *node, int link_id, ub_link_event_t ev, uint64_t now_ms) {
    (void)node;
    link_events_t *le = svc->user;
    if (ev == UB_LINK_EVENT_DOWN) le->downs++;
    else le->ups++;
    le->last_link = link_id;
    le->last_ms = now_ms;
}

/* Registers `le` with `node`; returns ub_node_add_service()'s code. */
static inline int link_events_attach(link_events_t *le, ub_node_t *node) {
    memset(le, 0, sizeof *le);
    le->last_link = -1;
    le->svc.name = "link_events";
    le->svc.order = UB_SVC_ORDER_USER;
    le->svc.link_event = link_events_cb;
    le->svc.user = le;
    return ub_node_add_service(node, &le->svc);
}

#endif /* UB_TEST_LINK_EVENTS_H */
