/* ID rules shared with the generator (generator/ids.py); the paper's own example first. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "ub/ub_catalogue.h"
#include "ub/ub_config.h"
#include "ub/ub_node.h"

static void test_paper_example_onboardSet(void **state) {
    (void)state;
    uint8_t id[16];
    ub_dir_id_paper("onboardSet", id);
    assert_memory_equal(id, "onboardSboardSet", 16);
}

static void test_short_name_padded_with_nul(void **state) {
    (void)state;
    uint8_t id[16];
    ub_dir_id_paper("gps", id);
    assert_memory_equal(id, "gps\0\0\0\0\0gps\0\0\0\0\0", 16);
}

static void test_long_name_first8_last8(void **state) {
    (void)state;
    uint8_t id[16];
    ub_dir_id_paper("navigationFilterState[12]", id);
    assert_memory_equal(id, "navigatitate[12]", 16);
}

/* A catalogue holding a type over the payload limit: the node refuses it, and the catalogue
 * functions name the type and the limit (what `uavbus gen --max-payload` checks beforehand). */
static void test_oversize_type_is_named(void **state) {
    (void)state;
    ub_type_desc_t types[2] = {
        {"struct fits", 1u, UB_MAX_DIRECTORY, 8u, NULL, NULL},
        {"struct tooBig", 2u, UB_MAX_DIRECTORY + 1u, 8u, NULL, NULL},
    };
    ub_catalogue_t cat = {"limits", UB_ID_SCHEME_PAPER, UB_CATALOGUE_ABI_VERSION, types, 2, NULL, 0,
                          UB_MAX_DIRECTORY + 1u, NULL, 0};
    assert_int_equal(ub_catalogue_payload_limit(), UB_MAX_DIRECTORY);
    const ub_type_desc_t *big = ub_catalogue_oversize(&cat, ub_catalogue_payload_limit());
    assert_ptr_equal(big, &types[1]);
    assert_string_equal(big->name, "struct tooBig");
    assert_null(ub_catalogue_oversize(&cat, UB_MAX_DIRECTORY + 1u));
    assert_null(ub_catalogue_oversize(NULL, 0));
    static ub_node_t node;
    assert_int_equal(ub_node_init(&node, &cat, NULL), UB_ERR_INVAL);
    /* max_packed_size understated: the per-type check still refuses it. */
    cat.max_packed_size = 1u;
    assert_int_equal(ub_node_init(&node, &cat, NULL), UB_ERR_INVAL);
    cat.n_types = 1;
    assert_int_equal(ub_node_init(&node, &cat, NULL), UB_OK);
}

static void test_entity_id(void **state) {
    (void)state;
    uint8_t id[12];
    assert_int_equal(ub_entity_id("rmax1ob1", id), UB_OK);
    assert_memory_equal(id, "rmax1ob1\0\0\0\0", 12);
    assert_int_equal(ub_entity_id("averyveryverylongname", id), UB_ERR_RANGE);
    assert_int_equal(ub_entity_id("", id), UB_ERR_RANGE);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_paper_example_onboardSet),
        cmocka_unit_test(test_short_name_padded_with_nul),
        cmocka_unit_test(test_long_name_first8_last8),
        cmocka_unit_test(test_entity_id),
        cmocka_unit_test(test_oversize_type_is_named),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
