/*
 * ub_node_init(): the node core (ub_node_core_init(), src/core/) with the services every node runs.
 * This file is where the core and the built-in engines meet, so that neither names the other: the core
 * registers nothing of the service layer, the engines register through ub_service.h like any service.
 */
#include "ub/ub_node.h"

#include "ub/ub_node_svc.h"
#include "svc/ub_svc_private.h"

int ub_node_init(ub_node_t *node, const ub_catalogue_t *cat, const ub_node_options_t *opt) {
    ub_node_options_t o = {0};
    if (opt != NULL) o = *opt;
    ub_priv_timing_defaults(&o.timing);
    int rc = ub_node_core_init(node, cat, &o);
    if (rc == UB_OK) rc = ub_node_add_service(node, &ub_priv_pubsub_service);
    if (rc == UB_OK) rc = ub_node_add_service(node, &ub_priv_member_server);
    if (rc == UB_OK) rc = ub_node_add_service(node, &ub_priv_inspect_server);
    return rc;
}
