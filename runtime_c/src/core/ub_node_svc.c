/*
 * The node's side of the service contract (ub_service.h): the registration table, and the accessors
 * ub_node_svc.h gives services instead of ub_node_t's fields. The sending helpers live with the frame
 * path in ub_node.c.
 */
#include "ub/ub_node_svc.h"

#include <string.h>

#include "core/ub_node_private.h"

/* Codes only the core handles: DATA is the frame path's own (checked before any lookup). */
static bool code_ok(uint8_t code, ub_service_kind_t kind) { return !(kind == UB_SVC_CODE && code == UB_ADMIN_DATA); }

static const uint8_t *codes_of(const ub_service_t *svc, ub_service_kind_t kind, unsigned *n) {
    switch (kind) {
    case UB_SVC_CODE: *n = svc->n_codes; return svc->codes;
    case UB_SVC_REPLY: *n = svc->n_reply_codes; return svc->reply_codes;
    default: *n = svc->n_link_local_codes; return svc->link_local_codes;
    }
}

/* The per-code index (service index + 1) follows the table: rebuilt whenever it changes, so the lookups
 * on the admin path are one load. */
static void reindex(ub_node_t *node) {
    memset(node->svc_by_code, 0, sizeof node->svc_by_code);
    node->data_svc = NULL;
    node->seal_svc = NULL;
    for (int i = 0; i < node->n_services; i++) {
        const ub_service_t *svc = node->services[i];
        for (int k = UB_SVC_CODE; k <= UB_SVC_LINK_LOCAL; k++) {
            unsigned n;
            const uint8_t *c = codes_of(svc, (ub_service_kind_t)k, &n);
            for (unsigned j = 0; j < n; j++) node->svc_by_code[k][c[j]] = (uint8_t)(i + 1);
        }
        if (svc->on_data != NULL || svc->may_write != NULL) node->data_svc = svc;
        if (svc->seal != NULL || svc->open != NULL) node->seal_svc = svc;
    }
}

int ub_node_add_service(ub_node_t *node, const ub_service_t *svc) {
    if (node == NULL || svc == NULL) return UB_ERR_INVAL;
    if ((svc->n_codes > 0 && svc->codes == NULL) || (svc->n_reply_codes > 0 && svc->reply_codes == NULL) ||
        (svc->n_link_local_codes > 0 && svc->link_local_codes == NULL) || (svc->n_reply_codes > 0 && svc->on_reply == NULL) ||
        (svc->on_data != NULL && svc->may_write == NULL))
        return UB_ERR_INVAL;
    for (int i = 0; i < node->n_services; i++)
        if (node->services[i] == svc) return UB_ERR_EXISTS;
    for (int k = UB_SVC_CODE; k <= UB_SVC_LINK_LOCAL; k++) {
        unsigned n;
        const uint8_t *c = codes_of(svc, (ub_service_kind_t)k, &n);
        for (unsigned j = 0; j < n; j++) {
            if (!code_ok(c[j], (ub_service_kind_t)k)) return UB_ERR_INVAL;
            if (node->svc_by_code[k][c[j]] != 0) return UB_ERR_EXISTS;
            for (unsigned m = 0; m < j; m++)
                if (c[m] == c[j]) return UB_ERR_INVAL;
        }
    }
    if ((svc->on_data != NULL || svc->may_write != NULL) && node->data_svc != NULL) return UB_ERR_EXISTS;
    if ((svc->seal != NULL || svc->open != NULL) && node->seal_svc != NULL) return UB_ERR_EXISTS;
    if (node->n_services >= UB_MAX_SERVICES) return UB_ERR_FULL;
    /* Keep the table in tick order: after every service of the same or a lower order. */
    int at = node->n_services;
    while (at > 0 && node->services[at - 1]->order > svc->order) {
        node->services[at] = node->services[at - 1];
        at--;
    }
    node->services[at] = svc;
    node->n_services++;
    reindex(node);
    return UB_OK;
}

int ub_node_remove_service(ub_node_t *node, const ub_service_t *svc) {
    if (node == NULL || svc == NULL) return UB_ERR_INVAL;
    for (int i = 0; i < node->n_services; i++) {
        if (node->services[i] != svc) continue;
        for (int j = i + 1; j < node->n_services; j++) node->services[j - 1] = node->services[j];
        node->n_services--;
        node->services[node->n_services] = NULL;
        reindex(node);
        return UB_OK;
    }
    return UB_ERR_NOTFOUND;
}

const ub_service_t *ub_node_service_for(const ub_node_t *node, ub_service_kind_t kind, uint8_t code) {
    if (node == NULL || (unsigned)kind > UB_SVC_LINK_LOCAL) return NULL;
    unsigned idx = node->svc_by_code[kind][code];
    return idx != 0 ? node->services[idx - 1] : NULL;
}

/* ---- accessors ------------------------------------------------------------------------------------- */

const ub_catalogue_t *ub_node_catalogue(const ub_node_t *node) { return node->cat; }

const ub_node_options_t *ub_node_options(const ub_node_t *node) { return &node->opt; }

const ub_policy_t *ub_node_policy(const ub_node_t *node) { return node->policy; }

int ub_node_slot_link(const ub_node_t *node, int slot, unsigned index) {
    if (ub_node_slot_entity(node, slot) < 0 || index >= UB_MAX_LINKS_PER_ENTITY) return -1;
    return node->locals[slot].link_ids[index];
}

uint8_t ub_node_slot_mask(const ub_node_t *node, int slot, int dest) {
    if (ub_node_slot_entity(node, slot) < 0 || dest < 0 || dest >= UB_MAX_ENTITIES) return 0;
    return node->locals[slot].masks[dest];
}

bool ub_node_slot_pinned(const ub_node_t *node, int slot, int dest) {
    if (ub_node_slot_entity(node, slot) < 0 || dest < 0 || dest >= UB_MAX_ENTITIES) return false;
    return node->locals[slot].pinned[dest] != 0;
}

ub_node_counters_t *ub_node_svc_counters(ub_node_t *node) { return &node->counters; }

ub_pubsub_table_t *ub_node_svc_pubsub_table(const ub_node_t *node, int slot) {
    if (slot < 0 || slot >= UB_MAX_LOCAL_ENTITIES) return NULL;
    return (ub_pubsub_table_t *)&node->locals[slot].ps; /* the table is the service's, whatever the caller may touch */
}

ub_binding_t *ub_node_svc_binding_row(const ub_node_t *node, uint32_t instance) {
    for (size_t b = 0; b < node->n_bindings; b++)
        if (node->bindings[b].instance == instance) return (ub_binding_t *)&node->bindings[b]; /* its flags are the services' */
    return NULL;
}
