/*
 * Private to the service layer (src/svc/): the publish/subscribe service and the administration
 * tables it carries, and the built-in services ub_node_init() registers. Not installed. Includes only
 * public headers: a service reaches the node through ub_node_svc.h (layer_check enforces it).
 */
#ifndef UB_SVC_PRIVATE_H
#define UB_SVC_PRIVATE_H

#include <stdbool.h>
#include <stdint.h>

#include "ub/ub_admin.h"
#include "ub/ub_admin_wire.h"
#include "ub/ub_frame.h"
#include "ub/ub_node.h"
#include "ub/ub_node_svc.h"
#include "ub/ub_pubsub.h"
#include "ub/ub_service.h"

/* The services every node runs (ub_node_init(), ub_node_std.c): publish/subscribe with its
 * administration tables, and the serving side of membership and inspection (their requesters,
 * ub_member_init() and ub_inspect_init(), take these registrations over while attached). */
extern const ub_service_t ub_priv_pubsub_service;
extern const ub_service_t ub_priv_member_server;
extern const ub_service_t ub_priv_inspect_server;

/* Fills 0 fields of `t` with the defaults of ub_pubsub.h. */
void ub_priv_timing_defaults(ub_pubsub_timing_t *t);

/* ---- administration tables (ub_admin.c), carried by the publish/subscribe service ---- */

/*
 * An ACK/NACK reached the administration table's entity. Returns true if it
 * answered one of its rows: same request id, sent by the row's target (the
 * source of a publication row, the destination of a subscription row), about
 * the row's content.
 */
bool ub_priv_admin_on_reply(ub_admin_t *adm, const ub_frame_header_t *h, uint32_t request_id, uint8_t code, bool nack,
                            uint8_t detail, uint8_t flags, uint64_t now_ms);

/* Entity `id` is being removed: rows whose target it is become INACTIVE at once (nobody to send a STOP to),
 * active rows naming it as the other end are deactivated (their STOP goes to the target). Returns how many. */
int ub_priv_admin_forget(ub_admin_t *adm, const uint8_t id[UB_ENTITY_ID_LEN], uint64_t now_ms);

/* Whether an activated row of `adm` brings `instance` from `src_id` to entity `dest_id`. */
bool ub_priv_admin_routes_to(const ub_admin_t *adm, uint32_t instance, const uint8_t src_id[UB_ENTITY_ID_LEN],
                             const uint8_t dest_id[UB_ENTITY_ID_LEN]);

void ub_priv_admin_tick(ub_admin_t *adm, uint64_t now_ms);

/* Attaches `adm` (NULL: detaches) as local slot `slot`'s administration table and brings every table's
 * admin_slots up to date (ub_pubsub_table_t): the only writer of both. */
void ub_priv_pubsub_set_admin(ub_node_t *node, int slot, ub_admin_t *adm);

/* DATA of `instance` from `src_id` reached local entity `dest_id`: the rows it stands for are not stale. */
void ub_priv_admin_on_data(ub_admin_t *adm, uint32_t instance, const uint8_t src_id[UB_ENTITY_ID_LEN],
                           const uint8_t dest_id[UB_ENTITY_ID_LEN], uint64_t now_ms);

#endif /* UB_SVC_PRIVATE_H */
