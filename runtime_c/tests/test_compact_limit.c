/*
 * Compact dictionaries on an unsigned link (issue 29, item 3): every change of the peer's dictionary is
 * counted (dict_changes); unauthenticated changes are taken at most once per change_min_ms (dict_limited),
 * so a flood of forged LINK_HELLOs cannot keep resetting the link; authenticated ones are never limited.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "ub/ub_compact.h"

/* The first LINK_HELLO page of a peer with epoch `epoch` and `n` entities. */
static size_t hello_of(uint32_t epoch, size_t n, uint8_t *payload, size_t cap) {
    static ub_compact_t peer;
    ub_compact_init(&peer, NULL, epoch, NULL);
    uint8_t ids[4][UB_ENTITY_ID_LEN];
    memset(ids, 0, sizeof ids);
    for (size_t i = 0; i < n && i < 4; i++) ids[i][0] = (uint8_t)(1 + i);
    ub_compact_set_local(&peer, (const uint8_t(*)[UB_ENTITY_ID_LEN])ids, n, 1, 0);
    uint16_t len = 0;
    assert_true(ub_compact_hello_due(&peer, 0, payload, cap, &len));
    return len;
}

static void test_changes_are_counted_and_unsigned_ones_limited(void **state) {
    (void)state;
    static ub_compact_t s;
    ub_compact_params_t p = {.change_min_ms = 1000};
    ub_compact_init(&s, NULL, 77, &p);
    uint8_t pl[UB_COMPACT_HELLO_FIXED + UB_COMPACT_PAGE * UB_ENTITY_ID_LEN];
    size_t n = hello_of(1, 2, pl, sizeof pl);
    assert_int_equal(ub_compact_on_hello_from(&s, pl, n, 10, false), UB_OK); /* first contact: no change */
    assert_int_equal(ub_compact_on_hello_from(&s, pl, n, 20, false), UB_OK); /* the same again: no change */
    assert_int_equal(s.stats.dict_changes, 0);
    n = hello_of(2, 2, pl, sizeof pl); /* the peer restarted */
    assert_int_equal(ub_compact_on_hello_from(&s, pl, n, 30, false), UB_OK);
    assert_int_equal(s.stats.dict_changes, 1);
    assert_int_equal(s.stats.peer_restarts, 1);
    n = hello_of(2, 3, pl, sizeof pl); /* its list changed too soon after: refused, counted, nothing taken */
    assert_int_equal(ub_compact_on_hello_from(&s, pl, n, 500, false), UB_ERR_AGAIN);
    assert_int_equal(s.stats.dict_limited, 1);
    assert_int_equal(s.stats.dict_changes, 1);
    assert_int_equal(ub_compact_on_hello_from(&s, pl, n, 1030, false), UB_OK); /* change_min_ms later: taken */
    assert_int_equal(s.stats.dict_changes, 2);
    n = hello_of(3, 3, pl, sizeof pl); /* authenticated (a signed link): never limited */
    assert_int_equal(ub_compact_on_hello_from(&s, pl, n, 1031, true), UB_OK);
    n = hello_of(4, 3, pl, sizeof pl);
    assert_int_equal(ub_compact_on_hello(&s, pl, n, 1032), UB_OK);
    assert_int_equal(s.stats.dict_changes, 4);
    assert_int_equal(s.stats.dict_limited, 1);
    /* a clock that went backwards lets a change through: the link is never stuck on a stale dictionary */
    n = hello_of(5, 3, pl, sizeof pl);
    assert_int_equal(ub_compact_on_hello_from(&s, pl, n, 100, false), UB_OK);
    assert_int_equal(s.stats.dict_changes, 5);
}

/* A flood of forged hellos, a new epoch every 10 ms for 10 s: at most one change per change_min_ms. */
static void test_a_flood_of_forged_hellos_changes_the_dictionary_at_a_bounded_rate(void **state) {
    (void)state;
    static ub_compact_t s;
    ub_compact_init(&s, NULL, 5, NULL);
    uint8_t pl[UB_COMPACT_HELLO_FIXED + UB_COMPACT_PAGE * UB_ENTITY_ID_LEN];
    size_t n = hello_of(1000, 2, pl, sizeof pl);
    assert_int_equal(ub_compact_on_hello_from(&s, pl, n, 0, false), UB_OK);
    for (uint32_t k = 1; k <= 1000; k++) {
        n = hello_of(1000 + k, 2, pl, sizeof pl);
        int rc = ub_compact_on_hello_from(&s, pl, n, 10u * k, false);
        assert_true(rc == UB_OK || rc == UB_ERR_AGAIN);
    }
    assert_int_equal(s.params.change_min_ms, UB_COMPACT_CHANGE_MIN_MS);
    uint64_t most = 10000 / UB_COMPACT_CHANGE_MIN_MS + 1;
    assert_true(s.stats.dict_changes <= most);
    assert_true(s.stats.peer_restarts <= most);
    assert_int_equal(s.stats.dict_changes + s.stats.dict_limited, 1000);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_changes_are_counted_and_unsigned_ones_limited),
        cmocka_unit_test(test_a_flood_of_forged_hellos_changes_the_dictionary_at_a_bounded_rate),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
