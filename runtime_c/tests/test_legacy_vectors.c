/* tests/vectors/legacy_envelope.json (written by the independent Python reference
 * tests/vectors/make_legacy_vectors.py) reproduced by the C runtime: every message rebuilt byte for byte from its
 * type and payload, and the mixed stream (noise, messages, a bad header checksum, a bad message checksum, a
 * false sync) parsed to exactly its good messages and counters, whole and one byte at a time. The legacy link
 * driver (ub_legacy_link.h) is tested end to end in tests/python/test_legacy_link.py and, on a pty in C, in
 * test_legacy_link.c. test_limits_and_refusals covers what the vectors do not (too long, in place, NULLs). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "codec/ub_json.h"
#include "test_json_vectors.h"
#include "ub/ub_legacy.h"

#define doc vec_doc /* the document and its root: test_json_vectors.h */
#define root vec_root

static int setup(void **state) {
    (void)state;
    return vec_load("tests/vectors/legacy_envelope.json");
}

static int teardown(void **state) {
    (void)state;
    vec_free();
    return 0;
}

static void test_messages_rebuilt(void **state) {
    (void)state;
    ub_json_value_t arr = get(&root, "vectors"), item;
    ub_json_iter_t it;
    ub_json_iter_begin(&it, &doc, &arr);
    int count = 0;
    while (ub_json_iter_next(&it, NULL, &item)) {
        static uint8_t payload[UB_LEGACY_PAYLOAD_MAX], want[UB_LEGACY_MESSAGE_MAX], got[UB_LEGACY_MESSAGE_MAX];
        size_t plen = hex(&item, "payload", payload, sizeof payload);
        size_t wlen = hex(&item, "message", want, sizeof want);
        int n = ub_legacy_build((uint16_t)num(&item, "type"), payload, plen, got, sizeof got);
        assert_int_equal(n, (int)wlen);
        assert_memory_equal(got, want, wlen);
        count++;
    }
    assert_true(count >= 5);
    uint8_t small[8];
    assert_int_equal(ub_legacy_build(1, small, 1, small, 8), UB_ERR_NOSPACE);
    assert_int_equal(ub_legacy_build(1, NULL, UB_LEGACY_PAYLOAD_MAX + 1, small, 8), UB_ERR_INVAL);
}

typedef struct seen {
    uint8_t msgs[8][UB_LEGACY_MESSAGE_MAX];
    size_t lens[8];
    size_t n;
} seen_t;

static void on_message(void *user, uint16_t type, const uint8_t *msg, size_t msg_len, const uint8_t *payload,
                       size_t payload_len) {
    seen_t *s = user;
    assert_true(s->n < 8);
    assert_int_equal(msg_len, UB_LEGACY_HEADER_LEN + payload_len);
    assert_ptr_equal(payload, msg + UB_LEGACY_HEADER_LEN);
    assert_int_equal(type, msg[4] | msg[5] << 8);
    memcpy(s->msgs[s->n], msg, msg_len);
    s->lens[s->n++] = msg_len;
}

static void test_stream_parsed(void **state) {
    (void)state;
    static uint8_t stream[8192];
    ub_json_value_t st = get(&root, "stream");
    size_t len = hex(&st, "bytes", stream, sizeof stream);
    for (int bytewise = 0; bytewise < 2; bytewise++) {
        static seen_t seen;
        memset(&seen, 0, sizeof seen);
        ub_legacy_t p;
        ub_legacy_init(&p);
        int found = 0;
        if (bytewise) {
            for (size_t i = 0; i < len; i++) found += ub_legacy_feed(&p, stream + i, 1, on_message, &seen);
        } else {
            found = ub_legacy_feed(&p, stream, len, on_message, &seen);
        }
        ub_json_value_t msgs = get(&st, "messages"), m;
        ub_json_iter_t it;
        ub_json_iter_begin(&it, &doc, &msgs);
        size_t k = 0;
        while (ub_json_iter_next(&it, NULL, &m)) {
            static uint8_t want[UB_LEGACY_MESSAGE_MAX];
            char buf[4096];
            size_t n = unhex(buf, ub_json_string(&doc, &m, buf, sizeof buf), want, sizeof want);
            assert_true(k < seen.n);
            assert_int_equal(seen.lens[k], n);
            assert_memory_equal(seen.msgs[k], want, n);
            k++;
        }
        assert_int_equal(found, (int)k);
        assert_int_equal(seen.n, k);
        assert_int_equal(p.stats.bad_header, num(&st, "bad_header"));
        assert_int_equal(p.stats.bad_checksum, num(&st, "bad_checksum"));
        assert_int_equal(p.stats.too_long, num(&st, "too_long"));
        assert_int_equal(p.stats.noise_bytes, num(&st, "noise_bytes"));
        assert_int_equal(p.stats.bytes_in, p.stats.message_bytes + p.stats.noise_bytes + ub_legacy_pending(&p));
    }
}

/* Beyond the vectors (issue #29 item 6): a header whose checksum holds but whose size is above the limit is
 * counted `too_long`, its bytes noise, and the good message after it is found; a parser without a callback
 * still counts; a payload already in the output buffer is built in place; a zero-size message round-trips;
 * the NULL and range refusals. */
static void test_limits_and_refusals(void **state) {
    (void)state;
    static uint8_t good[UB_LEGACY_MESSAGE_MAX], stream[2 * UB_LEGACY_MESSAGE_MAX], copy[UB_LEGACY_MESSAGE_MAX];
    const uint8_t payload[5] = {'h', 'e', 'l', 'l', 'o'};
    int glen = ub_legacy_build(3, payload, sizeof payload, good, sizeof good);
    assert_int_equal(glen, (int)(UB_LEGACY_HEADER_LEN + sizeof payload));
    /* the oversize candidate: sync, a header checksum that holds, size UB_LEGACY_PAYLOAD_MAX + 1 */
    uint8_t big[UB_LEGACY_HEADER_LEN] = {UB_LEGACY_SYNC0, UB_LEGACY_SYNC1, 0, 0, 0x21, 0x00,
                                          (uint8_t)((UB_LEGACY_PAYLOAD_MAX + 1) & 0xFF),
                                          (uint8_t)((UB_LEGACY_PAYLOAD_MAX + 1) >> 8)};
    big[2] = (uint8_t)(big[4] + big[5] + big[6] + big[7]);
    for (size_t i = 1; i < sizeof big; i++) assert_int_not_equal(big[i], UB_LEGACY_SYNC0); /* no false sync inside */
    memcpy(stream, big, sizeof big);
    memcpy(stream + sizeof big, good, (size_t)glen);
    size_t len = sizeof big + (size_t)glen;
    static seen_t seen;
    memset(&seen, 0, sizeof seen);
    ub_legacy_t p;
    ub_legacy_init(&p);
    assert_int_equal(ub_legacy_feed(&p, stream, len, on_message, &seen), 1);
    assert_int_equal(p.stats.too_long, 1);
    assert_int_equal(p.stats.noise_bytes, sizeof big);
    assert_int_equal(seen.n, 1);
    assert_memory_equal(seen.msgs[0], good, (size_t)glen);
    /* no callback: found and counted all the same */
    assert_int_equal(ub_legacy_feed(&p, good, (size_t)glen, NULL, NULL), 1);
    assert_int_equal(p.stats.messages, 2);
    assert_int_equal(p.stats.bytes_in, p.stats.message_bytes + p.stats.noise_bytes);
    /* in place: the payload already where the message's payload goes */
    memcpy(copy + UB_LEGACY_HEADER_LEN, payload, sizeof payload);
    assert_int_equal(ub_legacy_build(3, copy + UB_LEGACY_HEADER_LEN, sizeof payload, copy, sizeof copy), glen);
    assert_memory_equal(copy, good, (size_t)glen);
    /* a message without payload */
    assert_int_equal(ub_legacy_build(9, NULL, 0, copy, UB_LEGACY_HEADER_LEN), (int)UB_LEGACY_HEADER_LEN);
    memset(&seen, 0, sizeof seen);
    assert_int_equal(ub_legacy_feed(&p, copy, UB_LEGACY_HEADER_LEN, on_message, &seen), 1);
    assert_int_equal(seen.lens[0], UB_LEGACY_HEADER_LEN);
    /* refusals */
    assert_int_equal(ub_legacy_build(1, payload, 1, NULL, 64), UB_ERR_INVAL);
    assert_int_equal(ub_legacy_build(1, NULL, 1, copy, sizeof copy), UB_ERR_INVAL);
    assert_int_equal(ub_legacy_build(1, copy, UB_LEGACY_PAYLOAD_MAX + 1, stream, sizeof stream), UB_ERR_RANGE);
    uint64_t in = p.stats.bytes_in;
    assert_int_equal(ub_legacy_feed(NULL, good, 1, NULL, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_legacy_feed(&p, NULL, 1, NULL, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_legacy_feed(&p, NULL, 0, NULL, NULL), 0);
    assert_int_equal(p.stats.bytes_in, in); /* refused input is not counted */
    ub_legacy_init(NULL);
    assert_int_equal(ub_legacy_pending(NULL), 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_messages_rebuilt),
        cmocka_unit_test(test_stream_parsed),
        cmocka_unit_test(test_limits_and_refusals),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
