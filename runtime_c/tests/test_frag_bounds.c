/*
 * Fragment codec and reassembly at their bounds (issue #29 item 6): every malformed header ub_frag_parse()
 * refuses, the plan and write limits, ub_frag_take()'s refusals each counted in its own statistic (rx_bad,
 * rx_restarted, rx_duplicates), expiry with a clock that went backwards, and ub_frag_forget() by local slot
 * and by peer, for reassemblies and transmit slots alike. test_frag_fair.c covers slot sharing.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "ub/ub_frag.h"
#include "ub/ub_wire.h"

static const uint8_t DIR_A[UB_DIR_ID_LEN] = {1};
static const uint8_t DIR_B[UB_DIR_ID_LEN] = {2};
static ub_frag_t g_f; /* large: static storage */

static void header(uint8_t *p, uint16_t transfer, uint16_t index, uint16_t count, uint16_t total) {
    ub_put_u16le(p + UB_FRAG_OFF_TRANSFER, transfer);
    ub_put_u16le(p + UB_FRAG_OFF_INDEX, index);
    ub_put_u16le(p + UB_FRAG_OFF_COUNT, count);
    ub_put_u16le(p + UB_FRAG_OFF_TOTAL, total);
}

static void src_id(uint8_t id[UB_ENTITY_ID_LEN], uint8_t n) {
    memset(id, 0, UB_ENTITY_ID_LEN);
    id[0] = 'p';
    id[1] = n;
}

static void test_parse_refuses_every_bad_header(void **state) {
    (void)state;
    uint8_t p[UB_FRAG_HEADER_LEN + 64] = {0};
    ub_frag_info_t fi;
    /* A good one first, so each refusal below is that field's doing. */
    header(p, 9, 1, 2, 10);
    assert_int_equal(ub_frag_parse(p, UB_FRAG_HEADER_LEN + 5, &fi), UB_OK);
    assert_int_equal(fi.offset, 5);
    assert_int_equal(fi.len, 5);
    assert_int_equal(fi.transfer, 9);
    assert_int_equal(ub_frag_parse(NULL, UB_FRAG_HEADER_LEN + 5, &fi), UB_ERR_INVAL);
    assert_int_equal(ub_frag_parse(p, UB_FRAG_HEADER_LEN + 5, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_frag_parse(p, UB_FRAG_HEADER_LEN - 1, &fi), UB_ERR_INVAL);
    header(p, 9, 0, 0, 10); /* no fragments */
    assert_int_equal(ub_frag_parse(p, UB_FRAG_HEADER_LEN + 10, &fi), UB_ERR_INVAL);
    header(p, 9, 0, UB_FRAG_MAX_FRAGMENTS + 1, 10); /* too many */
    assert_int_equal(ub_frag_parse(p, UB_FRAG_HEADER_LEN + 1, &fi), UB_ERR_INVAL);
    header(p, 9, 0, 1, 0); /* nothing to carry */
    assert_int_equal(ub_frag_parse(p, UB_FRAG_HEADER_LEN, &fi), UB_ERR_INVAL);
    header(p, 9, 0, 1, (uint16_t)(UB_MAX_DIRECTORY + 1)); /* more than a directory */
    assert_int_equal(ub_frag_parse(p, UB_FRAG_HEADER_LEN + 1, &fi), UB_ERR_INVAL);
    header(p, 9, 0, 4, 3); /* more fragments than bytes */
    assert_int_equal(ub_frag_parse(p, UB_FRAG_HEADER_LEN + 1, &fi), UB_ERR_INVAL);
    header(p, 9, 2, 2, 10); /* index past the count */
    assert_int_equal(ub_frag_parse(p, UB_FRAG_HEADER_LEN + 5, &fi), UB_ERR_INVAL);
    header(p, 9, 0, 4, 6); /* chunk 2: the fourth fragment would be empty */
    assert_int_equal(ub_frag_parse(p, UB_FRAG_HEADER_LEN + 2, &fi), UB_ERR_INVAL);
    header(p, 9, 0, 2, 10); /* a length that disagrees with the header */
    assert_int_equal(ub_frag_parse(p, UB_FRAG_HEADER_LEN + 4, &fi), UB_ERR_INVAL);
    assert_int_equal(ub_frag_parse(p, UB_FRAG_HEADER_LEN + 6, &fi), UB_ERR_INVAL);
}

static void test_plan_and_write_limits(void **state) {
    (void)state;
    uint16_t count = 0;
    assert_int_equal(ub_frag_plan(10, 4, &count), UB_OK);
    assert_int_equal(count, 3); /* 4 + 4 + 2: balanced to chunk 4 */
    assert_int_equal(ub_frag_plan(10, 4, NULL), UB_ERR_RANGE);
    assert_int_equal(ub_frag_plan(0, 4, &count), UB_ERR_RANGE);
    assert_int_equal(ub_frag_plan(UB_MAX_DIRECTORY + 1u, 4000, &count), UB_ERR_RANGE);
    assert_int_equal(ub_frag_plan(10, 0, &count), UB_ERR_RANGE);
    /* One byte a fragment: more fragments than the header can number. */
    assert_int_equal(ub_frag_plan(UB_FRAG_MAX_FRAGMENTS + 1u, 1, &count), UB_ERR_RANGE);

    uint8_t data[10] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9};
    uint8_t out[UB_FRAG_HEADER_LEN + 10];
    assert_int_equal(ub_frag_write(out, sizeof out, 1, 2, 3, data, 10), (int)UB_FRAG_HEADER_LEN + 2);
    assert_memory_equal(out + UB_FRAG_HEADER_LEN, data + 8, 2);
    assert_int_equal(ub_frag_write(NULL, sizeof out, 1, 0, 3, data, 10), UB_ERR_INVAL);
    assert_int_equal(ub_frag_write(out, sizeof out, 1, 0, 3, NULL, 10), UB_ERR_INVAL);
    assert_int_equal(ub_frag_write(out, sizeof out, 1, 0, 0, data, 10), UB_ERR_INVAL);
    assert_int_equal(ub_frag_write(out, sizeof out, 1, 3, 3, data, 10), UB_ERR_INVAL);
    assert_int_equal(ub_frag_write(out, sizeof out, 1, 0, 3, data, 0), UB_ERR_INVAL);
    assert_int_equal(ub_frag_write(out, sizeof out, 1, 0, 3, data, UB_MAX_DIRECTORY + 1u), UB_ERR_INVAL);
    /* 4 fragments of 6 bytes: chunk 2, the fourth would start past the end. */
    assert_int_equal(ub_frag_write(out, sizeof out, 1, 3, 4, data, 6), UB_ERR_INVAL);
    assert_int_equal(ub_frag_write(out, UB_FRAG_HEADER_LEN + 3, 1, 0, 3, data, 10), UB_ERR_NOSPACE);
}

static int take(uint8_t slot, uint8_t src_n, const uint8_t *dir, uint32_t fp, const uint8_t *p, size_t n,
                uint64_t now, size_t *total) {
    uint8_t src[UB_ENTITY_ID_LEN];
    src_id(src, src_n);
    const uint8_t *data = NULL;
    return ub_frag_take(&g_f, slot, src, dir, fp, p, n, now, &data, total);
}

static void test_take_counts_each_refusal(void **state) {
    (void)state;
    ub_frag_params_t params = {.timeout_ms = 100, .protect_ms = 0};
    ub_frag_init(&g_f, &params, 1);
    assert_int_equal(g_f.params.timeout_ms, 100);
    assert_int_equal(g_f.params.protect_ms, 25); /* 0 = timeout / 4 */
    uint8_t data[12];
    for (size_t i = 0; i < sizeof data; i++) data[i] = (uint8_t)(0xa0 + i);
    uint8_t p0[UB_FRAG_HEADER_LEN + 12], p1[UB_FRAG_HEADER_LEN + 12];
    int n0 = ub_frag_write(p0, sizeof p0, 5, 0, 2, data, sizeof data);
    int n1 = ub_frag_write(p1, sizeof p1, 5, 1, 2, data, sizeof data);
    assert_true(n0 > 0 && n1 > 0);
    size_t total = 0;
    uint8_t src[UB_ENTITY_ID_LEN];
    src_id(src, 1);
    const uint8_t *out = NULL;

    /* Missing arguments: refused, nothing counted (no fragment was looked at). */
    assert_int_equal(ub_frag_take(NULL, 0, src, DIR_A, 1, p0, (size_t)n0, 0, &out, &total), UB_ERR_INVAL);
    assert_int_equal(ub_frag_take(&g_f, 0, NULL, DIR_A, 1, p0, (size_t)n0, 0, &out, &total), UB_ERR_INVAL);
    assert_int_equal(ub_frag_take(&g_f, 0, src, NULL, 1, p0, (size_t)n0, 0, &out, &total), UB_ERR_INVAL);
    assert_int_equal(ub_frag_take(&g_f, 0, src, DIR_A, 1, p0, (size_t)n0, 0, NULL, &total), UB_ERR_INVAL);
    assert_int_equal(ub_frag_take(&g_f, 0, src, DIR_A, 1, p0, (size_t)n0, 0, &out, NULL), UB_ERR_INVAL);
    assert_int_equal(g_f.stats.rx_bad, 0);
    /* A malformed fragment: counted rx_bad. */
    assert_int_equal(take(0, 1, DIR_A, 1, p0, (size_t)n0 - 1, 0, &total), UB_ERR_INVAL);
    assert_int_equal(g_f.stats.rx_bad, 1);

    assert_int_equal(take(0, 1, DIR_A, 1, p0, (size_t)n0, 10, &total), UB_FRAG_PENDING);
    assert_int_equal(ub_frag_pending(&g_f), 1);
    assert_int_equal(take(0, 1, DIR_A, 1, p0, (size_t)n0, 11, &total), UB_FRAG_DUPLICATE);
    assert_int_equal(g_f.stats.rx_duplicates, 1);
    /* The same transfer number with another content, fingerprint or size: restarted, never mixed. */
    assert_int_equal(take(0, 1, DIR_B, 1, p1, (size_t)n1, 12, &total), UB_FRAG_PENDING);
    assert_int_equal(g_f.stats.rx_restarted, 1);
    assert_int_equal(take(0, 1, DIR_B, 2, p0, (size_t)n0, 13, &total), UB_FRAG_PENDING);
    assert_int_equal(g_f.stats.rx_restarted, 2);
    uint8_t q[UB_FRAG_HEADER_LEN + 12];
    int nq = ub_frag_write(q, sizeof q, 5, 0, 3, data, sizeof data); /* same transfer, three fragments */
    assert_true(nq > 0);
    assert_int_equal(take(0, 1, DIR_B, 2, q, (size_t)nq, 14, &total), UB_FRAG_PENDING);
    assert_int_equal(g_f.stats.rx_restarted, 3);
    nq = ub_frag_write(q, sizeof q, 5, 0, 2, data, 10); /* same transfer and count, another size */
    assert_int_equal(take(0, 1, DIR_B, 2, q, (size_t)nq, 15, &total), UB_FRAG_PENDING);
    assert_int_equal(g_f.stats.rx_restarted, 4);
    assert_int_equal(ub_frag_pending(&g_f), 1);
    /* Another local slot's transfer of the same number is its own reassembly, completed whole. */
    assert_int_equal(take(1, 1, DIR_A, 1, p1, (size_t)n1, 16, &total), UB_FRAG_PENDING);
    assert_int_equal(ub_frag_pending(&g_f), 2);
    assert_int_equal(ub_frag_take(&g_f, 1, src, DIR_A, 1, p0, (size_t)n0, 17, &out, &total), UB_FRAG_COMPLETE);
    assert_int_equal(total, sizeof data);
    assert_memory_equal(out, data, sizeof data);
    assert_int_equal(g_f.stats.rx_complete, 1);
    assert_int_equal(ub_frag_pending(&g_f), 1);
}

static void test_expire_and_clock_backwards(void **state) {
    (void)state;
    ub_frag_init(&g_f, NULL, 0);
    assert_int_equal(g_f.params.timeout_ms, UB_FRAG_TIMEOUT_MS);
    assert_int_equal(g_f.params.protect_ms, UB_FRAG_TIMEOUT_MS / 4u);
    uint8_t data[12] = {0};
    uint8_t p[UB_FRAG_HEADER_LEN + 12];
    int n = ub_frag_write(p, sizeof p, 7, 0, 2, data, sizeof data);
    size_t total = 0;
    assert_int_equal(take(0, 1, DIR_A, 1, p, (size_t)n, 1000, &total), UB_FRAG_PENDING);
    assert_int_equal(ub_frag_expire(&g_f, 1000 + UB_FRAG_TIMEOUT_MS - 1), 0);
    /* A clock that went backwards keeps the transfer (its idle time is unknown, not infinite). */
    assert_int_equal(ub_frag_expire(&g_f, 10), 0);
    assert_int_equal(ub_frag_pending(&g_f), 1);
    assert_int_equal(ub_frag_expire(&g_f, 1000 + UB_FRAG_TIMEOUT_MS), 1);
    assert_int_equal(g_f.stats.rx_timeouts, 1);
    assert_int_equal(ub_frag_pending(&g_f), 0);
    assert_int_equal(ub_frag_expire(NULL, 0), 0);
    assert_int_equal(ub_frag_pending(NULL), 0);
    ub_frag_init(NULL, NULL, 0); /* no-op, no crash */
}

static void test_forget_by_slot_and_peer(void **state) {
    (void)state;
    ub_frag_init(&g_f, NULL, 0);
    uint8_t data[12] = {0};
    uint8_t p[UB_FRAG_HEADER_LEN + 12];
    int n = ub_frag_write(p, sizeof p, 7, 0, 2, data, sizeof data);
    size_t total = 0;
    assert_int_equal(take(0, 1, DIR_A, 1, p, (size_t)n, 1, &total), UB_FRAG_PENDING);
    assert_int_equal(take(1, 2, DIR_A, 1, p, (size_t)n, 1, &total), UB_FRAG_PENDING);
    assert_int_equal(take(2, 3, DIR_A, 1, p, (size_t)n, 1, &total), UB_FRAG_PENDING);
    /* Transmit slots, as the send path fills them. */
    uint8_t peer[UB_ENTITY_ID_LEN];
    src_id(peer, 2);
    g_f.tx[0].in_use = 1;
    g_f.tx[0].slot = 0;
    src_id(g_f.tx[0].dest, 9);
    g_f.tx[1].in_use = 1;
    g_f.tx[1].slot = 3;
    memcpy(g_f.tx[1].dest, peer, UB_ENTITY_ID_LEN);

    ub_frag_forget(&g_f, 0, NULL); /* local slot 0: its reassembly and its transmission */
    assert_int_equal(ub_frag_pending(&g_f), 2);
    assert_int_equal(g_f.tx[0].in_use, 0);
    assert_int_equal(g_f.tx[1].in_use, 1);
    ub_frag_forget(&g_f, -1, peer); /* peer 2: what it sends and what goes to it */
    assert_int_equal(ub_frag_pending(&g_f), 1);
    assert_int_equal(g_f.tx[1].in_use, 0);
    ub_frag_forget(&g_f, -1, NULL); /* neither: nothing forgotten */
    assert_int_equal(ub_frag_pending(&g_f), 1);
    ub_frag_forget(NULL, 0, peer);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_parse_refuses_every_bad_header),
        cmocka_unit_test(test_plan_and_write_limits),
        cmocka_unit_test(test_take_counts_each_refusal),
        cmocka_unit_test(test_expire_and_clock_backwards),
        cmocka_unit_test(test_forget_by_slot_and_peer),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
