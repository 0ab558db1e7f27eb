#include "ub_test_pair.h"

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <stdlib.h>

pair_t *pair_new(const ub_node_options_t *opt) {
    pair_t *p = calloc(1, sizeof *p);
    assert_non_null(p);
    p->w = world_new();
    test_eid("pub", p->pub_id);
    test_eid("sub", p->sub_id);
    p->pub_node = world_node(p->w, &ub_test_cat, opt);
    p->sub_node = world_node(p->w, &ub_test_cat, opt);
    p->pub = ub_node_add_entity(p->pub_node, p->pub_id, true);
    p->pub_peer = ub_node_add_entity(p->pub_node, p->sub_id, false);
    p->sub = ub_node_add_entity(p->sub_node, p->sub_id, true);
    p->sub_peer = ub_node_add_entity(p->sub_node, p->pub_id, false);
    p->pub_link = ub_node_add_link(p->pub_node, p->pub, 0, "pubPort");
    p->sub_link = ub_node_add_link(p->sub_node, p->sub, 0, "subPort");
    assert_int_equal(ub_node_set_mask(p->pub_node, p->pub, p->pub_peer, 0x01), UB_OK);
    assert_int_equal(ub_node_set_mask(p->sub_node, p->sub, p->sub_peer, 0x01), UB_OK);
    p->ml = world_connect(p->w, p->pub_node, p->pub_link, p->sub_node, p->sub_link, NULL, 1);
    p->gps_src = (struct test_gps){33.78, -84.40, 300.0f, 3};
    assert_int_equal(ub_node_bind(p->pub_node, TEST_GPS, &p->gps_src), UB_OK);
    assert_int_equal(ub_node_bind(p->sub_node, TEST_GPS, &p->gps_dst), UB_OK);
    ub_node_set_deliver_hook(p->sub_node, delivery_log_hook, &p->log);
    return p;
}

void pair_free(pair_t *p) {
    free(p->w);
    free(p);
}
