/* What every driver shares (ub_driver.h): the attach, number parsing, counters as JSON members. Portable:
 * no operating system here, so a microcontroller build has it too. */
#include "ub/ub_driver.h"

#include <stdio.h>

#include "ub/ub_node.h"

int ub_driver_attach(ub_node_t *node, int link_id, const ub_link_ops_t *ops, void *impl, ub_node_t **node_out,
                     int *link_out) {
    if (impl == NULL || node_out == NULL || link_out == NULL) return UB_ERR_INVAL;
    int rc = ub_node_link_attach(node, link_id, ops, impl);
    if (rc < 0) return rc;
    *node_out = node;
    *link_out = link_id;
    return UB_OK;
}

int ub_driver_reattach(ub_node_t *node, int link_id, const ub_link_ops_t *ops, void *impl) {
    if (node == NULL) return UB_ERR_INVAL;
    return ub_node_link_attach(node, link_id, ops, impl);
}

bool ub_driver_parse_u32(const char *text, uint32_t max, uint32_t *out) {
    if (text == NULL || out == NULL || *text == '\0') return false;
    uint64_t v = 0;
    for (const char *s = text; *s != '\0'; s++) {
        if (*s < '0' || *s > '9') return false;
        v = v * 10 + (uint64_t)(*s - '0');
        if (v > max) return false;
    }
    *out = (uint32_t)v;
    return true;
}

int ub_driver_format_counters(const ub_driver_counter_t *counters, size_t n, char *out, size_t cap) {
    if (out == NULL || cap == 0) return 0;
    out[0] = '\0';
    size_t len = 0;
    for (size_t i = 0; i < n && counters != NULL; i++) {
        int k = snprintf(out + (len < cap ? len : cap - 1), len < cap ? cap - len : 1, "%s\"%s\":%llu",
                         i ? "," : "", counters[i].name, (unsigned long long)counters[i].value);
        if (k < 0) return k;
        len += (size_t)k;
    }
    return (int)len;
}
