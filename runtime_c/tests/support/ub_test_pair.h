/* Two nodes joined by one memlink: "pub" (hosts gpsOut/imuOut) and "sub". Shared by test_pubsub,
 * test_admin and test_memlink. */
#ifndef UB_TEST_PAIR_H
#define UB_TEST_PAIR_H

#include "ub_test_world.h"

typedef struct pair {
    world_t *w;
    ub_node_t *pub_node, *sub_node;
    int pub, sub;              /* local entity indexes in their nodes */
    int pub_peer, sub_peer;    /* the other entity's index in each node */
    int pub_link, sub_link;
    ub_memlink_t *ml;
    uint8_t pub_id[UB_ENTITY_ID_LEN], sub_id[UB_ENTITY_ID_LEN];
    struct test_gps gps_src, gps_dst;
    delivery_log_t log; /* deliveries at the sub node */
} pair_t;

/* `opt` applies to both nodes (NULL = defaults). */
pair_t *pair_new(const ub_node_options_t *opt);
void pair_free(pair_t *p);

#endif /* UB_TEST_PAIR_H */
