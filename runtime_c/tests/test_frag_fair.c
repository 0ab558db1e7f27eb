/*
 * Reassembly slots shared fairly (issue 29, item 3): transfers that never complete, from many sources or
 * from one, cannot push out a genuine transfer whose fragments keep arriving; one source holds at most
 * UB_FRAG_SLOTS_PER_SOURCE slots; each bound is counted when it is hit; a slot idle for protect_ms is
 * still taken for a newcomer, so nothing holds a slot for good.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "ub/ub_frag.h"

static const uint8_t DIR[UB_DIR_ID_LEN] = {7};
#define TOTAL 600u

static void entity(uint8_t id[UB_ENTITY_ID_LEN], unsigned n) {
    memset(id, 0, UB_ENTITY_ID_LEN);
    id[0] = 's';
    id[1] = (uint8_t)n;
}

/* Feeds fragment `index` of a `count`-fragment transfer `transfer` from source `src_n`. */
static int feed(ub_frag_t *f, unsigned src_n, uint16_t transfer, uint16_t index, uint16_t count, uint64_t now,
                size_t *got) {
    static uint8_t data[TOTAL];
    for (size_t i = 0; i < TOTAL; i++) data[i] = (uint8_t)(i * 7u + src_n);
    uint8_t payload[UB_FRAG_HEADER_LEN + TOTAL];
    int n = ub_frag_write(payload, sizeof payload, transfer, index, count, data, TOTAL);
    assert_true(n > 0);
    uint8_t src[UB_ENTITY_ID_LEN];
    entity(src, src_n);
    const uint8_t *out = NULL;
    size_t total = 0;
    int r = ub_frag_take(f, 0, src, DIR, 0x1234u, payload, (size_t)n, now, &out, &total);
    if (r == UB_FRAG_COMPLETE) {
        assert_int_equal(total, TOTAL);
        assert_memory_equal(out, data, TOTAL);
        if (got != NULL) (*got)++;
    }
    return r;
}

/* The acceptance scenario: 10 never-completing transfers of other sources around a genuine 2-fragment one. */
static void test_ten_never_completing_transfers_do_not_evict_a_genuine_one(void **state) {
    (void)state;
    static ub_frag_t f;
    ub_frag_init(&f, NULL, 0);
    size_t got = 0;
    assert_int_equal(feed(&f, 1, 50, 0, 2, 1000, &got), UB_FRAG_PENDING);
    for (unsigned k = 0; k < 10; k++) (void)feed(&f, 100 + k, (uint16_t)k, 0, 4, 1001 + k, NULL);
    assert_int_equal(feed(&f, 1, 50, 1, 2, 1020, &got), UB_FRAG_COMPLETE);
    assert_int_equal(got, 1);
    assert_int_equal(f.stats.rx_refused, 10 - (UB_FRAG_SLOTS - 1)); /* the ones that found no free slot */
    assert_int_equal(f.stats.rx_evicted, 0);
}

/* One source floods: it only ever replaces its own transfers, never another source's. */
static void test_one_source_is_held_to_its_share(void **state) {
    (void)state;
    static ub_frag_t f;
    ub_frag_init(&f, NULL, 0);
    size_t got = 0;
    assert_int_equal(feed(&f, 1, 9, 0, 3, 0, &got), UB_FRAG_PENDING);
    for (unsigned k = 0; k < 50; k++) (void)feed(&f, 2, (uint16_t)k, 0, 4, 1 + k, NULL);
    assert_int_equal(f.stats.rx_source_limit, 50 - UB_FRAG_SLOTS_PER_SOURCE);
    assert_int_equal(f.stats.rx_refused + f.stats.rx_evicted, 0);
    assert_int_equal(ub_frag_pending(&f), 1 + UB_FRAG_SLOTS_PER_SOURCE);
    assert_int_equal(feed(&f, 1, 9, 1, 3, 60, &got), UB_FRAG_PENDING);
    assert_int_equal(feed(&f, 1, 9, 2, 3, 61, &got), UB_FRAG_COMPLETE);
    assert_int_equal(got, 1);
}

/* Busy slots idle for protect_ms are taken for a newcomer: a flood that stops sending frees its slots
 * without waiting for the timeout; a transfer still progressing is not taken. */
static void test_idle_slots_are_taken_after_protect_ms(void **state) {
    (void)state;
    static ub_frag_t f;
    ub_frag_params_t p = {.timeout_ms = 2000, .protect_ms = 300};
    ub_frag_init(&f, &p, 0);
    for (unsigned k = 0; k < UB_FRAG_SLOTS; k++) (void)feed(&f, 10 + k, 1, 0, 4, 0, NULL);
    (void)feed(&f, 10, 1, 1, 4, 250, NULL); /* source 10 is still progressing */
    assert_int_equal(feed(&f, 99, 1, 0, 2, 299, NULL), UB_FRAG_REFUSED);
    assert_int_equal(feed(&f, 99, 1, 0, 2, 300, NULL), UB_FRAG_PENDING);
    assert_int_equal(f.stats.rx_evicted, 1);
    assert_int_equal(f.stats.rx_refused, 1);
    size_t got = 0;
    (void)feed(&f, 10, 1, 2, 4, 310, &got);
    assert_int_equal(feed(&f, 10, 1, 3, 4, 320, &got), UB_FRAG_COMPLETE); /* never taken: it progressed */
    assert_int_equal(feed(&f, 99, 1, 1, 2, 330, &got), UB_FRAG_COMPLETE);
    assert_int_equal(got, 2);
    /* a clock that went backwards counts as idle: a newcomer is never refused for good */
    for (unsigned k = 0; k < UB_FRAG_SLOTS; k++) (void)feed(&f, 20 + k, 2, 0, 4, 5000, NULL);
    uint64_t evicted = f.stats.rx_evicted;
    assert_int_equal(feed(&f, 98, 2, 0, 2, 4000, NULL), UB_FRAG_PENDING);
    assert_int_equal(f.stats.rx_evicted, evicted + 1);
    /* default protect_ms: a quarter of the timeout */
    ub_frag_init(&f, NULL, 0);
    assert_int_equal(f.params.protect_ms, UB_FRAG_TIMEOUT_MS / 4);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ten_never_completing_transfers_do_not_evict_a_genuine_one),
        cmocka_unit_test(test_one_source_is_held_to_its_share),
        cmocka_unit_test(test_idle_slots_are_taken_after_protect_ms),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
