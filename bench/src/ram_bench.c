/*
 * Static RAM of the runtime (bench figure 6) for the reference configuration, compiled with the
 * same -D capacities as the libub objects bench/run.sh measures with `size`:
 *   16 entity-table rows, 8 links per entity, 8 link slots per node, 4 local entities x 64
 *   publish/subscribe rows = 256 table entries.
 * The runtime owns no memory: a node is the caller's ub_node_t (plus an optional ub_admin_t and one
 * driver struct per link), so its RAM is these sizeof figures plus libub's own .data/.bss.
 */
#include <stdio.h>

#include "ub/ub_admin.h"
#include "ub/ub_memlink.h"
#include "ub/ub_node.h"
#include "ub/ub_serial.h"
#include "ub/ub_tcp.h"
#include "ub/ub_udp.h"

int main(void) {
    printf("config UB_MAX_ENTITIES=%d UB_MAX_LINKS_PER_ENTITY=%d UB_MAX_NODE_LINKS=%d UB_MAX_LOCAL_ENTITIES=%d "
           "UB_MAX_PUBSUB_ROWS=%d UB_MAX_ADMIN_ROWS=%d UB_MAX_BINDINGS=%d UB_MAX_PAYLOAD=%d\n",
           UB_MAX_ENTITIES, UB_MAX_LINKS_PER_ENTITY, UB_MAX_NODE_LINKS, UB_MAX_LOCAL_ENTITIES, UB_MAX_PUBSUB_ROWS,
           UB_MAX_ADMIN_ROWS, UB_MAX_BINDINGS, UB_MAX_PAYLOAD);
    printf("sizeof ub_node_t %zu\n", sizeof(ub_node_t));
    printf("sizeof ub_link_t %zu (x%d inside ub_node_t; its stream decoder ub_decoder_t is %zu)\n", sizeof(ub_link_t),
           UB_MAX_NODE_LINKS, sizeof(ub_decoder_t));
    printf("sizeof ub_admin_t %zu\n", sizeof(ub_admin_t));
    printf("sizeof ub_udp_t %zu\n", sizeof(ub_udp_t));
    printf("sizeof ub_tcp_t %zu\n", sizeof(ub_tcp_t));
    printf("sizeof ub_serial_t %zu\n", sizeof(ub_serial_t));
    printf("sizeof ub_memlink_t %zu\n", sizeof(ub_memlink_t));
    return 0;
}
