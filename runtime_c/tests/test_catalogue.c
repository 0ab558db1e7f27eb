/* ID rules shared with the generator (generator/ids.py); the paper's own example first. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "ub/ub_catalogue.h"

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
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
