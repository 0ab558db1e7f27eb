/*
 * Batch links (ub_batchlink.h): frames packed in batch format 1 by flow, cut at the size limit, refused
 * (counted) when the caller's memory is full; every packed batch passes ub_batch_check() whole, and
 * damaged or foreign payloads are refused by reason, never partly read.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "ub/ub_batchlink.h"

enum { FRAME = 80 };

/* A stand-in frame: only the key bytes (8..48) and the length matter to the batch link. */
static void make_frame(uint8_t *f, size_t len, uint8_t flow, uint8_t fill) {
    memset(f, fill, len);
    f[0] = 0xA5;
    f[1] = 0x5B;
    memset(f + UB_BATCH_KEY_OFFSET, flow, UB_BATCH_KEY_LEN);
}

static int send_frame(ub_batchlink_t *bl, size_t len, uint8_t flow, uint8_t fill) {
    uint8_t f[2048];
    make_frame(f, len, flow, fill);
    return ub_batchlink_ops.send(bl, f, len, 0);
}

static void test_runs_of_one_flow_share_a_batch(void **state) {
    (void)state;
    uint8_t buf[4096];
    uint32_t ends[16];
    ub_batchlink_t bl;
    assert_int_equal(ub_batchlink_init(&bl, buf, sizeof buf, ends, 16, 1024), UB_OK);
    uint8_t flows[] = {1, 1, 1, 2, 1, 1};
    for (size_t i = 0; i < sizeof flows; i++) assert_int_equal(send_frame(&bl, FRAME, flows[i], (uint8_t)i), UB_OK);
    assert_int_equal(bl.n, 3); /* 1 1 1 | 2 | 1 1 */
    size_t start = 0, counts[] = {3, 1, 2}, seen = 0;
    for (size_t b = 0; b < bl.n; b++) {
        size_t n = 0;
        assert_int_equal(ub_batch_check(buf + start, ends[b] - start, &n), UB_BATCH_OK);
        assert_int_equal(n, counts[b]);
        assert_int_equal(buf[start + 2], UB_BATCH_VERSION);
        /* frames in send order: the fill byte after the key is the frame's index */
        for (size_t k = 0, at = start + UB_BATCH_HEADER; k < n; k++, seen++) {
            assert_int_equal(buf[at] | buf[at + 1] << 8, FRAME);
            assert_int_equal(buf[at + 2 + 60], seen);
            at += 2u + FRAME;
        }
        start = ends[b];
    }
    assert_int_equal(start, bl.len);
    assert_int_equal(bl.frames, 6);
    ub_batchlink_clear(&bl);
    assert_int_equal(bl.n, 0);
    assert_int_equal(bl.len, 0);
}

static void test_limit_cuts_and_a_large_frame_goes_alone(void **state) {
    (void)state;
    uint8_t buf[8192];
    uint32_t ends[64];
    ub_batchlink_t bl;
    size_t limit = UB_BATCH_HEADER + 3u * (2u + FRAME);
    assert_int_equal(ub_batchlink_init(&bl, buf, sizeof buf, ends, 64, limit), UB_OK);
    for (int i = 0; i < 7; i++) assert_int_equal(send_frame(&bl, FRAME, 1, 0), UB_OK);
    assert_int_equal(bl.n, 3); /* 3 + 3 + 1 */
    assert_int_equal(ends[0], limit);
    assert_int_equal(send_frame(&bl, 1000, 1, 0), UB_OK); /* larger than the limit: its own batch */
    assert_int_equal(bl.n, 4);
    size_t n = 0;
    assert_int_equal(ub_batch_check(buf + ends[2], ends[3] - ends[2], &n), UB_BATCH_OK);
    assert_int_equal(n, 1);
}

static void test_full_memory_refuses_and_counts(void **state) {
    (void)state;
    uint8_t buf[UB_BATCH_HEADER + 2u * (2u + FRAME)];
    uint32_t ends[1];
    ub_batchlink_t bl;
    assert_int_equal(ub_batchlink_init(&bl, buf, sizeof buf, ends, 1, 4096), UB_OK);
    assert_int_equal(send_frame(&bl, FRAME, 1, 0), UB_OK);
    assert_int_equal(send_frame(&bl, FRAME, 2, 0), UB_ERR_AGAIN); /* another flow: no batch slot left */
    assert_int_equal(send_frame(&bl, FRAME, 1, 0), UB_OK);
    assert_int_equal(send_frame(&bl, FRAME, 1, 0), UB_ERR_AGAIN); /* no bytes left */
    assert_int_equal(send_frame(&bl, 20, 1, 0), UB_ERR_RANGE);    /* shorter than any frame */
    assert_int_equal(bl.refused, 3);
    assert_int_equal(bl.frames, 2);
    assert_int_equal(ub_batch_check(buf, bl.len, NULL), UB_BATCH_OK);
    assert_int_equal(ub_batchlink_init(&bl, buf, sizeof buf, ends, 0, 4096), UB_ERR_INVAL);
    assert_int_equal(ub_batchlink_init(&bl, buf, sizeof buf, ends, 1, 3), UB_ERR_INVAL);
}

static void test_damaged_payloads_are_refused_whole(void **state) {
    (void)state;
    uint8_t buf[1024];
    uint32_t ends[4];
    ub_batchlink_t bl;
    assert_int_equal(ub_batchlink_init(&bl, buf, sizeof buf, ends, 4, 1024), UB_OK);
    assert_int_equal(send_frame(&bl, FRAME, 1, 0), UB_OK);
    assert_int_equal(send_frame(&bl, FRAME, 1, 0), UB_OK);
    size_t len = bl.len, n = 99;
    uint8_t copy[1024];
    assert_int_equal(ub_batch_check(buf, len, &n), UB_BATCH_OK);
    assert_int_equal(n, 2);
    assert_int_equal(ub_batch_check((const uint8_t *)"hello", 5, &n), UB_BATCH_FOREIGN);
    assert_int_equal(n, 0);
    assert_int_equal(ub_batch_check(buf, 1, NULL), UB_BATCH_FOREIGN);
    assert_int_equal(ub_batch_check(buf + UB_BATCH_HEADER + 2u, FRAME, NULL), UB_BATCH_OTHER_VERSION); /* bare frame */
    memcpy(copy, buf, len);
    copy[2] = 2;
    assert_int_equal(ub_batch_check(copy, len, NULL), UB_BATCH_OTHER_VERSION);
    assert_int_equal(ub_batch_check(buf, 4, NULL), UB_BATCH_MALFORMED);
    assert_int_equal(ub_batch_check(buf, len - 1, NULL), UB_BATCH_MALFORMED);
    assert_int_equal(ub_batch_check(buf, len + 1, NULL), UB_BATCH_MALFORMED); /* a byte after the last frame */
    memcpy(copy, buf, len);
    copy[3] = 3;
    assert_int_equal(ub_batch_check(copy, len, NULL), UB_BATCH_MALFORMED);
    memcpy(copy, buf, len);
    copy[3] = 0;
    assert_int_equal(ub_batch_check(copy, len, NULL), UB_BATCH_MALFORMED);
    memcpy(copy, buf, len);
    copy[UB_BATCH_HEADER] = 0;
    copy[UB_BATCH_HEADER + 1] = 0;
    assert_int_equal(ub_batch_check(copy, len, NULL), UB_BATCH_MALFORMED);
    size_t frames = 7, rejected = 7;
    assert_int_equal(ub_batch_rx(NULL, 0, copy, len, 0, &frames, &rejected), UB_BATCH_MALFORMED);
    assert_int_equal(frames, 0); /* refused before any frame reached a node (there is none here) */
    assert_int_equal(rejected, 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_runs_of_one_flow_share_a_batch),
        cmocka_unit_test(test_limit_cuts_and_a_large_frame_goes_alone),
        cmocka_unit_test(test_full_memory_refuses_and_counts),
        cmocka_unit_test(test_damaged_payloads_are_refused_whole),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
