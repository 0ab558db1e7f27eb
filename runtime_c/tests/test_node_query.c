/*
 * The node's read-only queries (ub_node.h "Queries", ub_node_query.c): what bindings read instead of the
 * fields of ub_node_t and ub_link_t. Every query takes any index; out of range or unused reads as "none".
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "ub/ub_node.h"

static const ub_catalogue_t empty_cat = {.name = "query", .abi_version = UB_CATALOGUE_ABI_VERSION};

static int refuse_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)impl, (void)frame, (void)len, (void)now_ms;
    return UB_ERR_AGAIN;
}

static const ub_link_ops_t test_ops = {.kind = "test", .send = refuse_send};
static ub_frag_t frag; /* large: static storage, as ub_node_set_frag() asks */

static void test_entities_and_their_links(void **state) {
    (void)state;
    ub_node_t *n = calloc(1, sizeof *n);
    assert_non_null(n);
    assert_int_equal(ub_node_init(n, &empty_cat, NULL), UB_OK);
    int gcs = ub_node_add_entity_name(n, "gcs1", true);
    int uav = ub_node_add_entity_name(n, "rmax1ob1", false);
    assert_true(gcs >= 0 && uav >= 0);
    assert_true(ub_node_entity_in_use(n, gcs) && ub_node_entity_in_use(n, uav));
    assert_true(ub_node_entity_is_local(n, gcs));
    assert_false(ub_node_entity_is_local(n, uav));
    for (int bad = -1; bad <= UB_MAX_ENTITIES; bad += UB_MAX_ENTITIES + 1) {
        assert_false(ub_node_entity_in_use(n, bad));
        assert_false(ub_node_entity_is_local(n, bad));
    }
    assert_false(ub_node_entity_in_use(n, 2)); /* a free row */
    assert_false(ub_node_entity_in_use(NULL, gcs));

    int l2 = ub_node_add_link(n, gcs, 2, "radio");
    assert_true(l2 >= 0);
    assert_int_equal(ub_node_entity_link(n, gcs, 2), l2);
    assert_int_equal(ub_node_entity_link(n, gcs, 0), UB_ERR_NOTFOUND);
    assert_int_equal(ub_node_entity_link(n, gcs, UB_MAX_LINKS_PER_ENTITY), UB_ERR_INVAL);
    assert_int_equal(ub_node_entity_link(n, uav, 0), UB_ERR_INVAL); /* not local */

    /* Removing the entity frees its row: the queries follow. */
    assert_int_equal(ub_node_remove_entity(n, uav, 0), UB_OK);
    assert_false(ub_node_entity_in_use(n, uav));
    free(n);
}

static void test_link_slots(void **state) {
    (void)state;
    ub_node_t *n = calloc(1, sizeof *n);
    assert_non_null(n);
    assert_int_equal(ub_node_init(n, &empty_cat, NULL), UB_OK);
    int gcs = ub_node_add_entity_name(n, "gcs1", true);
    int l = ub_node_add_link(n, gcs, 0, "radio");
    assert_true(l >= 0);
    assert_string_equal(ub_node_link_name(n, l), "radio");
    assert_null(ub_node_link_kind(n, l)); /* detached */
    assert_int_equal(ub_node_link_attach(n, l, &test_ops, NULL), UB_OK);
    assert_string_equal(ub_node_link_kind(n, l), "test");
    const ub_link_counters_t *c = ub_node_link_counters(n, l);
    assert_non_null(c);
    assert_int_equal(c->frames_out, 0);

    assert_int_equal(ub_node_link_mtu(n, l), 0);
    assert_int_equal(ub_node_link_set_mtu(n, l, 300), UB_OK);
    assert_int_equal(ub_node_link_mtu(n, l), 300);
    assert_false(ub_node_link_encrypts(n, l));
    assert_int_equal(ub_node_link_set_security(n, l, -1, true), UB_OK);
    assert_true(ub_node_link_encrypts(n, l));

    static ub_compact_t compact;
    assert_null(ub_node_link_compact_stats(n, l));
    assert_int_equal(ub_node_link_set_compact(n, l, &compact, NULL), UB_OK);
    assert_ptr_equal(ub_node_link_compact_stats(n, l), &compact.stats);
    assert_int_equal(ub_node_link_set_compact(n, l, NULL, NULL), UB_OK);
    assert_null(ub_node_link_compact_stats(n, l));

    assert_null(ub_node_frag_stats(n));
    ub_frag_init(&frag, NULL, 1);
    assert_int_equal(ub_node_set_frag(n, &frag), UB_OK);
    assert_ptr_equal(ub_node_frag_stats(n), &frag.stats);

    /* Unused slots and bad ids read as none. */
    for (int bad = -1; bad <= UB_MAX_NODE_LINKS; bad += UB_MAX_NODE_LINKS + 1) {
        assert_null(ub_node_link_name(n, bad));
        assert_null(ub_node_link_kind(n, bad));
        assert_null(ub_node_link_counters(n, bad));
        assert_int_equal(ub_node_link_mtu(n, bad), 0);
        assert_false(ub_node_link_encrypts(n, bad));
    }
    assert_int_equal(ub_node_link_detach(n, l), UB_OK);
    assert_int_equal(ub_node_remove_link(n, l), UB_OK);
    assert_null(ub_node_link_name(n, l));
    assert_null(ub_node_link_counters(n, l));
    free(n);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_entities_and_their_links),
        cmocka_unit_test(test_link_slots),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
