/* Read-only queries of a node's tables (ub_node.h, "Queries"): what a binding or a tool reads instead of the
 * fields of ub_node_t and ub_link_t, so the struct layout can change without them. Nothing here writes. */
#include "ub/ub_node.h"

#include <stddef.h>

static const ub_link_t *link_in_use(const ub_node_t *node, int link_id) {
    if (node == NULL || link_id < 0 || link_id >= UB_MAX_NODE_LINKS || !node->links[link_id].in_use) return NULL;
    return &node->links[link_id];
}

bool ub_node_entity_in_use(const ub_node_t *node, int entity) {
    return node != NULL && entity >= 0 && entity < UB_MAX_ENTITIES && node->entities[entity].in_use;
}

bool ub_node_entity_is_local(const ub_node_t *node, int entity) {
    return ub_node_entity_in_use(node, entity) && node->entities[entity].local >= 0;
}

int ub_node_entity_link(const ub_node_t *node, int entity, unsigned index) {
    if (!ub_node_entity_is_local(node, entity) || index >= UB_MAX_LINKS_PER_ENTITY) return UB_ERR_INVAL;
    int link_id = node->locals[node->entities[entity].local].link_ids[index];
    return link_id >= 0 ? link_id : UB_ERR_NOTFOUND;
}

const char *ub_node_link_name(const ub_node_t *node, int link_id) {
    const ub_link_t *link = link_in_use(node, link_id);
    return link != NULL ? link->name : NULL;
}

const char *ub_node_link_kind(const ub_node_t *node, int link_id) {
    const ub_link_t *link = link_in_use(node, link_id);
    return link != NULL && link->ops != NULL ? link->ops->kind : NULL;
}

const ub_link_counters_t *ub_node_link_counters(const ub_node_t *node, int link_id) {
    const ub_link_t *link = link_in_use(node, link_id);
    return link != NULL ? &link->counters : NULL;
}

bool ub_node_link_encrypts(const ub_node_t *node, int link_id) {
    const ub_link_t *link = link_in_use(node, link_id);
    return link != NULL && link->encrypt != 0;
}

uint16_t ub_node_link_mtu(const ub_node_t *node, int link_id) {
    const ub_link_t *link = link_in_use(node, link_id);
    return link != NULL ? link->mtu : 0;
}

const ub_compact_stats_t *ub_node_link_compact_stats(const ub_node_t *node, int link_id) {
    const ub_compact_t *c = ub_node_link_compact(node, link_id);
    return c != NULL ? &c->stats : NULL;
}

const ub_frag_stats_t *ub_node_frag_stats(const ub_node_t *node) {
    const ub_frag_t *f = ub_node_frag(node);
    return f != NULL ? &f->stats : NULL;
}
