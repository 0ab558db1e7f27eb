/*
 * Batch links (ub_batchlink.h): frames packed in batch format 1 by flow, cut at the size limit, refused
 * (counted) when the caller's memory is full; every packed batch passes ub_batch_check() whole, and
 * damaged or foreign payloads are refused by reason, never partly read. A node's DATA sent over a batch
 * link reaches another node through ub_batch_rx(), a damaged frame inside refused by that node alone;
 * a flow of more frames than the 16-bit count holds continues in a new batch.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "support/ub_test_world.h"
#include "ub/ub_batchlink.h"

enum { FRAME = 80 };

/* A stand-in frame: only the key bytes (8..48) and the length matter to the batch link. */
static void stand_in_frame(uint8_t *f, size_t len, uint8_t flow, uint8_t fill) {
    memset(f, fill, len);
    f[0] = 0xA5;
    f[1] = 0x5B;
    memset(f + UB_BATCH_KEY_OFFSET, flow, UB_BATCH_KEY_LEN);
}

static int send_frame(ub_batchlink_t *bl, size_t len, uint8_t flow, uint8_t fill) {
    uint8_t f[2048];
    stand_in_frame(f, len, flow, fill);
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

/* The caller's memory is checked once, at init; a batch-slot table that is full refuses a new flow even
 * with bytes to spare. */
static void test_init_refusals_and_full_batch_table(void **state) {
    (void)state;
    uint8_t buf[4096];
    uint32_t ends[1];
    ub_batchlink_t bl;
    assert_int_equal(ub_batchlink_init(NULL, buf, sizeof buf, ends, 1, 1024), UB_ERR_INVAL);
    assert_int_equal(ub_batchlink_init(&bl, NULL, sizeof buf, ends, 1, 1024), UB_ERR_INVAL);
    assert_int_equal(ub_batchlink_init(&bl, buf, sizeof buf, NULL, 1, 1024), UB_ERR_INVAL);
    assert_int_equal(ub_batchlink_init(&bl, buf, UB_BATCH_HEADER + 1u, ends, 1, 1024), UB_ERR_INVAL);
#if SIZE_MAX > UINT32_MAX
    /* ends[] holds 32-bit offsets: a larger buffer cannot be described (never touched here) */
    assert_int_equal(ub_batchlink_init(&bl, buf, (size_t)UINT32_MAX + 1u, ends, 1, 1024), UB_ERR_INVAL);
#endif
    assert_int_equal(ub_batchlink_init(&bl, buf, sizeof buf, ends, 1, 1024), UB_OK);
    assert_int_equal(send_frame(&bl, FRAME, 1, 0), UB_OK);
    assert_int_equal(send_frame(&bl, FRAME, 2, 0), UB_ERR_AGAIN); /* 4 KiB free, but no batch slot */
    assert_int_equal(send_frame(&bl, FRAME, 1, 0), UB_OK);        /* the open batch still takes its flow */
    uint8_t f[16];
    memset(f, 0, sizeof f);
    assert_int_equal(ub_batchlink_ops.send(&bl, f, 0x10000u, 0), UB_ERR_RANGE); /* no frame is this long */
    assert_int_equal(bl.refused, 2);
    assert_int_equal(bl.frames, 2);
    assert_int_equal(ub_batchlink_ops.fileno(&bl), -1);
    assert_string_equal(ub_batchlink_ops.kind, "zenoh");
    assert_int_equal(ub_batch_check(NULL, 10, NULL), UB_BATCH_FOREIGN);
    const uint8_t other[] = {UB_BATCH_SYNC, 0x00, 1, 1, 0};
    assert_int_equal(ub_batch_check(other, sizeof other, NULL), UB_BATCH_FOREIGN); /* sync byte, no mark */
}

/* 65,535 frames of one flow fill a batch's 16-bit count; the next frame starts a new batch. */
static void test_a_batch_holds_at_most_65535_frames(void **state) {
    (void)state;
    enum { LEN = UB_BATCH_KEY_OFFSET + UB_BATCH_KEY_LEN, N = 0xFFFF + 2 };
    size_t cap = 2u * UB_BATCH_HEADER + (size_t)N * (2u + LEN);
    uint8_t *buf = malloc(cap);
    assert_non_null(buf);
    uint32_t ends[4];
    ub_batchlink_t bl;
    assert_int_equal(ub_batchlink_init(&bl, buf, cap, ends, 4, cap), UB_OK);
    uint8_t f[LEN];
    stand_in_frame(f, LEN, 7, 0);
    for (size_t i = 0; i < N; i++) assert_int_equal(ub_batchlink_ops.send(&bl, f, LEN, 0), UB_OK);
    assert_int_equal(bl.n, 2);
    assert_int_equal(bl.len, cap);
    size_t n = 0;
    assert_int_equal(ub_batch_check(buf, ends[0], &n), UB_BATCH_OK);
    assert_int_equal(n, 0xFFFF);
    assert_int_equal(ub_batch_check(buf + ends[0], ends[1] - ends[0], &n), UB_BATCH_OK);
    assert_int_equal(n, 2);
    free(buf);
}

/* Two nodes: a sends over a batch link, b takes the batch with ub_batch_rx(). */
static void test_node_data_over_a_batch_reaches_the_other_node(void **state) {
    (void)state;
    world_t *w = world_new();
    ub_node_t *a = world_node(w, &ub_test_cat, NULL), *b = world_node(w, &ub_test_cat, NULL);
    int ea = ub_node_add_entity_name(a, "a", true), a_b = ub_node_add_entity_name(a, "b", false);
    int eb = ub_node_add_entity_name(b, "b", true), b_a = ub_node_add_entity_name(b, "a", false);
    int la = ub_node_add_link(a, ea, 0, "zenoh"), lb = ub_node_add_link(b, eb, 0, "zenoh");
    assert_true(ea >= 0 && a_b >= 0 && eb >= 0 && b_a >= 0 && la >= 0 && lb >= 0);
    assert_int_equal(ub_node_set_mask(a, ea, a_b, 0x01), UB_OK);
    assert_int_equal(ub_node_set_mask(b, eb, b_a, 0x01), UB_OK);
    static uint8_t buf[8192];
    uint32_t ends[8];
    ub_batchlink_t bl;
    assert_int_equal(ub_batchlink_init(&bl, buf, sizeof buf, ends, 8, 4096), UB_OK);
    assert_int_equal(ub_batchlink_attach(&bl, a, la), UB_OK);
    struct test_gps src = {1.0, 2.0, 3.0f, 0}, dst = {0};
    assert_int_equal(ub_node_bind(a, TEST_GPS, &src), UB_OK);
    assert_int_equal(ub_node_bind(b, TEST_GPS, &dst), UB_OK);
    uint8_t b_id[UB_ENTITY_ID_LEN];
    test_eid("b", b_id);
    for (uint32_t i = 1; i <= 3; i++) {
        src.fix = i;
        assert_int_equal(ub_node_send_data(a, ea, TEST_GPS, b_id, i), 1);
    }
    assert_int_equal(bl.n, 1); /* one flow: one batch of three */
    size_t frames = 0, rejected = 9;
    assert_int_equal(ub_batch_rx(b, lb, buf, bl.len, 10, &frames, &rejected), UB_BATCH_OK);
    assert_int_equal(frames, 3);
    assert_int_equal(rejected, 0);
    assert_int_equal(dst.fix, 3);
    assert_true(dst.lat == 1.0);
    /* The next batch's middle frame damaged (a payload byte): that frame alone is refused, by b, as bad CRC. */
    ub_batchlink_clear(&bl);
    for (uint32_t i = 4; i <= 6; i++) {
        src.fix = i;
        assert_int_equal(ub_node_send_data(a, ea, TEST_GPS, b_id, 10 + i), 1);
    }
    size_t second = UB_BATCH_HEADER + (2u + (buf[UB_BATCH_HEADER] | (size_t)buf[UB_BATCH_HEADER + 1] << 8));
    buf[second + 2u + UB_FRAME_HEADER_LEN + 1u] ^= 0x40;
    uint64_t bad_crc = ub_node_link_bad_frames(b, lb, UB_RX_BAD_CRC);
    assert_int_equal(ub_batch_rx(b, lb, buf, bl.len, 20, NULL, &rejected), UB_BATCH_OK);
    assert_int_equal(rejected, 1);
    assert_int_equal(ub_node_link_bad_frames(b, lb, UB_RX_BAD_CRC), bad_crc + 1);
    assert_int_equal(dst.fix, 6);
    assert_int_equal(ub_batch_rx(b, lb, buf, bl.len - 1, 21, &frames, NULL), UB_BATCH_MALFORMED);
    assert_int_equal(frames, 0);
    free(w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_runs_of_one_flow_share_a_batch),
        cmocka_unit_test(test_limit_cuts_and_a_large_frame_goes_alone),
        cmocka_unit_test(test_full_memory_refuses_and_counts),
        cmocka_unit_test(test_damaged_payloads_are_refused_whole),
        cmocka_unit_test(test_init_refusals_and_full_batch_table),
        cmocka_unit_test(test_a_batch_holds_at_most_65535_frames),
        cmocka_unit_test(test_node_data_over_a_batch_reaches_the_other_node),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
