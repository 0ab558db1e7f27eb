/* ub_frame_finish / ub_frame_parse contracts, and the decoder's handling of each kind of
 * bad input on hand-made streams (every chunking), with its counters checked exactly. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "test_frame_util.h"
#include "ub/ub_frame.h"
#include "ub/ub_wire.h"

/* Recomputes both checks after a test edited header fields, straight from the definition
 * in ub_frame.h: hdr_check = XOR of the bytes of CRC-32C([4,60)); msg_crc continues it
 * over `payload_len` payload bytes. Lets a test build "valid-looking" bad frames. */
static void reseal(uint8_t *f, size_t payload_len) {
    uint32_t c = ub_crc32c(f + 4, 56);
    f[2] = (uint8_t)(c ^ (c >> 8) ^ (c >> 16) ^ (c >> 24));
    ub_put_u32le(f + 60, ub_crc32c_update(c, f + 64, payload_len));
}

static size_t make_frame(uint64_t seed, uint8_t *out, uint16_t payload_size) {
    test_rng_t rng = {seed};
    return random_frame(&rng, out, payload_size);
}

static void test_finish_argument_errors(void **state) {
    (void)state;
    test_rng_t rng = {1};
    uint8_t f[UB_FRAME_MAX];
    ub_frame_header_t h = random_header(&rng, 10);
    assert_int_equal(ub_frame_finish(NULL, sizeof f, &h), UB_ERR_INVAL);
    assert_int_equal(ub_frame_finish(f, sizeof f, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_frame_finish(f, 73, &h), UB_ERR_NOSPACE);
    assert_int_equal(ub_frame_finish(f, 74, &h), 74);
    h.hop_limit = 0;
    assert_int_equal(ub_frame_finish(f, sizeof f, &h), UB_ERR_RANGE);
    h.hop_limit = 1;
    h.payload_size = UB_MAX_PAYLOAD + 1;
    assert_int_equal(ub_frame_finish(f, sizeof f + 1, &h), UB_ERR_RANGE);
    h.payload_size = UB_MAX_PAYLOAD;
    /* The largest unsigned frame; UB_FRAME_MAX also leaves room for the largest trailer. */
    assert_int_equal(ub_frame_finish(f, sizeof f, &h), (int)(UB_FRAME_HEADER_LEN + UB_MAX_PAYLOAD));
    assert_int_equal(UB_FRAME_MAX, UB_FRAME_HEADER_LEN + UB_MAX_PAYLOAD + UB_FRAME_TRAILER_MAX);
    h.flags = 0x30; /* SIGNED and ENCRYPTED together are not a valid combination */
    assert_int_equal(ub_frame_finish(f, sizeof f, &h), UB_ERR_INVAL);
}

static void test_finish_writes_only_the_header(void **state) {
    (void)state;
    test_rng_t rng = {2};
    uint8_t f[200];
    memset(f, 0x77, sizeof f);
    ub_frame_header_t h = random_header(&rng, 30);
    assert_int_equal(ub_frame_finish(f, sizeof f, &h), 94);
    for (size_t i = 64; i < sizeof f; i++) assert_int_equal(f[i], 0x77);
    assert_int_equal(ub_frame_parse(f, 94, NULL), UB_OK);
}

static void test_parse_errors(void **state) {
    (void)state;
    uint8_t f[UB_FRAME_MAX + 1];
    size_t n = make_frame(3, f, 40);
    ub_frame_header_t h;
    assert_int_equal(ub_frame_parse(f, n, &h), UB_OK);
    assert_int_equal(ub_frame_parse(f, n, NULL), UB_OK);
    assert_int_equal(ub_frame_parse(NULL, n, &h), UB_ERR_INVAL);
    assert_int_equal(ub_frame_parse(f, 63, &h), UB_ERR_TRUNCATED);
    assert_int_equal(ub_frame_parse(f, n - 1, &h), UB_ERR_TRUNCATED);
    assert_int_equal(ub_frame_parse(f, n + 1, &h), UB_ERR_INVAL);
    /* Every single-bit flip anywhere in the frame is caught, with the documented code. */
    for (size_t byte = 0; byte < n; byte++) {
        for (int bit = 0; bit < 8; bit++) {
            f[byte] ^= (uint8_t)(1u << bit);
            int err = ub_frame_parse(f, n, &h);
            int want = (byte < 2 || byte == 3) ? UB_ERR_INVAL : UB_ERR_CHECKSUM;
            if (err != want) {
                print_error("flip of byte %zu bit %d: %s, want %s\n", byte, bit, ub_strerror(err), ub_strerror(want));
                fail();
            }
            f[byte] ^= (uint8_t)(1u << bit);
        }
    }
    assert_int_equal(ub_frame_parse(f, n, &h), UB_OK);
}

/* A frame with a valid header check whose contents are wrong in one way. */
typedef enum sealed_defect { WRONG_VERSION, WRONG_TYPE, PAYLOAD_TOO_BIG, SIZES_DISAGREE, LONGER_CLAIM } sealed_defect_t;

static size_t make_sealed_bad(uint8_t *f, sealed_defect_t defect) {
    size_t n = make_frame(4, f, 20);
    switch (defect) {
    case WRONG_VERSION: f[UB_FRAME_OFF_VERSION] = 2; break;
    case WRONG_TYPE: ub_put_u16le(f + UB_FRAME_OFF_MSG_TYPE, 0x1234); break;
    case PAYLOAD_TOO_BIG:
        ub_put_u16le(f + UB_FRAME_OFF_PAYLOAD_SIZE, UB_MAX_PAYLOAD + 1);
        ub_put_u16le(f + UB_FRAME_OFF_MSG_SIZE, UB_FRAME_MAX + 1);
        break;
    case SIZES_DISAGREE: ub_put_u16le(f + UB_FRAME_OFF_MSG_SIZE, (uint16_t)(n + 1)); break;
    case LONGER_CLAIM: /* a "lying length": consistent sizes, but more than was sent */
        ub_put_u16le(f + UB_FRAME_OFF_PAYLOAD_SIZE, 500);
        ub_put_u16le(f + UB_FRAME_OFF_MSG_SIZE, 564);
        break;
    }
    reseal(f, 20);
    return n;
}

static void test_parse_reason_names_each_defect(void **state) {
    (void)state;
    uint8_t f[UB_FRAME_MAX];
    ub_rx_reason_t why = UB_RX_REASON_COUNT;
    size_t n = make_sealed_bad(f, WRONG_VERSION);
    assert_int_equal(ub_frame_parse_reason(f, n, NULL, &why), UB_ERR_INVAL);
    assert_int_equal(why, UB_RX_BAD_VERSION);
    n = make_sealed_bad(f, WRONG_TYPE);
    assert_int_equal(ub_frame_parse_reason(f, n, NULL, &why), UB_ERR_INVAL);
    assert_int_equal(why, UB_RX_BAD_VERSION);
    n = make_sealed_bad(f, PAYLOAD_TOO_BIG);
    assert_int_equal(ub_frame_parse_reason(f, n, NULL, &why), UB_ERR_INVAL);
    assert_int_equal(why, UB_RX_BAD_LENGTH);
    n = make_sealed_bad(f, SIZES_DISAGREE);
    assert_int_equal(ub_frame_parse_reason(f, n, NULL, &why), UB_ERR_INVAL);
    assert_int_equal(why, UB_RX_BAD_LENGTH);
    n = make_sealed_bad(f, LONGER_CLAIM);
    assert_int_equal(ub_frame_parse_reason(f, n, NULL, &why), UB_ERR_TRUNCATED);
    assert_int_equal(why, UB_RX_BAD_LENGTH);

    n = make_frame(5, f, 20);
    f[70] ^= 1;
    assert_int_equal(ub_frame_parse_reason(f, n, NULL, &why), UB_ERR_CHECKSUM);
    assert_int_equal(why, UB_RX_BAD_CRC);
    f[70] ^= 1;
    f[10] ^= 1;
    assert_int_equal(ub_frame_parse_reason(f, n, NULL, &why), UB_ERR_CHECKSUM);
    assert_int_equal(why, UB_RX_BAD_HDR_CHECK);
    f[10] ^= 1;
    f[1] = 0;
    assert_int_equal(ub_frame_parse_reason(f, n, NULL, &why), UB_ERR_INVAL);
    assert_int_equal(why, UB_RX_BAD_SYNC);
    f[1] = UB_SYNC1;
    assert_int_equal(ub_frame_parse_reason(f, 1, NULL, &why), UB_ERR_TRUNCATED);
    assert_int_equal(why, UB_RX_BAD_SYNC);
    assert_int_equal(ub_frame_parse_reason(f, 40, NULL, &why), UB_ERR_TRUNCATED);
    assert_int_equal(why, UB_RX_BAD_LENGTH);
    why = UB_RX_REASON_COUNT;
    assert_int_equal(ub_frame_parse_reason(f, n, NULL, &why), UB_OK);
    assert_int_equal(why, UB_RX_REASON_COUNT); /* untouched on success */

    assert_string_equal(ub_rx_reason_name(UB_RX_BAD_CRC), "bad_crc");
    assert_string_equal(ub_rx_reason_name(UB_RX_REASON_COUNT), "?");
}

static void test_set_hop_limit_reseals(void **state) {
    (void)state;
    uint8_t f[UB_FRAME_MAX], orig[UB_FRAME_MAX];
    size_t n = make_frame(6, f, 33);
    memcpy(orig, f, n);
    ub_frame_header_t before, after;
    memset(&before, 0, sizeof before); /* padding too, for the memcmp below */
    memset(&after, 0, sizeof after);
    assert_int_equal(ub_frame_parse(f, n, &before), UB_OK);
    uint8_t lower = (uint8_t)(before.hop_limit > 1 ? before.hop_limit - 1 : 200);
    assert_int_equal(ub_frame_set_hop_limit(f, n, lower), UB_OK);
    assert_int_equal(ub_frame_parse(f, n, &after), UB_OK);
    assert_int_equal(after.hop_limit, lower);
    after.hop_limit = before.hop_limit;
    assert_memory_equal(&after, &before, sizeof before);
    assert_memory_equal(f + 64, orig + 64, n - 64);
    assert_int_equal(ub_frame_set_hop_limit(f, n, 0), UB_ERR_RANGE);
    assert_int_equal(ub_frame_set_hop_limit(f, n - 1, 3), UB_ERR_INVAL);
    assert_int_equal(ub_frame_set_hop_limit(f, 10, 3), UB_ERR_INVAL);
    assert_int_equal(ub_frame_set_hop_limit(NULL, n, 3), UB_ERR_INVAL);
    assert_int_equal(ub_frame_parse(f, n, NULL), UB_OK); /* refused calls changed nothing */
}

/* ---- decoder on hand-made streams ---- */

typedef struct seen {
    size_t count;
    uint32_t seq[16];
    size_t len[16];
} seen_t;

static void record(void *user, const ub_frame_header_t *h, const uint8_t *frame, size_t frame_len) {
    seen_t *s = user;
    assert_int_equal(ub_frame_parse(frame, frame_len, NULL), UB_OK);
    assert_true(s->count < 16);
    s->seq[s->count] = h->seq;
    s->len[s->count] = frame_len;
    s->count++;
}

typedef struct expectation {
    size_t frames;
    uint32_t seq[16];
    uint64_t rejected[UB_RX_REASON_COUNT];
    uint64_t garbage;
    size_t pending;
} expectation_t;

/* Feeds `stream` in every chunk size 1..len and checks deliveries and counters each time. */
static void check_every_chunking(const uint8_t *stream, size_t len, const expectation_t *want) {
    for (size_t chunk = 1; chunk <= len; chunk++) {
        ub_decoder_t dec;
        ub_decoder_init(&dec);
        seen_t seen = {0};
        size_t delivered = 0;
        for (size_t off = 0; off < len; off += chunk)
            delivered += ub_decoder_feed(&dec, stream + off, len - off < chunk ? len - off : chunk, record, &seen);
        int ok = delivered == want->frames && seen.count == want->frames &&
                 dec.stats.garbage_bytes == want->garbage && ub_decoder_pending(&dec) == want->pending &&
                 dec.stats.bytes_in == len &&
                 dec.stats.bytes_in == dec.stats.bytes_ok + dec.stats.garbage_bytes + ub_decoder_pending(&dec);
        for (size_t i = 0; ok && i < want->frames; i++) ok = seen.seq[i] == want->seq[i];
        for (int r = 0; ok && r < UB_RX_REASON_COUNT; r++) ok = dec.stats.rejected[r] == want->rejected[r];
        if (!ok) {
            print_error("chunk %zu: %zu frames (want %zu), garbage %llu (want %llu), pending %zu (want %zu), "
                        "rejected hdr/crc/len/ver %llu/%llu/%llu/%llu (want %llu/%llu/%llu/%llu)\n",
                        chunk, seen.count, want->frames, (unsigned long long)dec.stats.garbage_bytes,
                        (unsigned long long)want->garbage, ub_decoder_pending(&dec), want->pending,
                        (unsigned long long)dec.stats.rejected[0], (unsigned long long)dec.stats.rejected[1],
                        (unsigned long long)dec.stats.rejected[2], (unsigned long long)dec.stats.rejected[3],
                        (unsigned long long)want->rejected[0], (unsigned long long)want->rejected[1],
                        (unsigned long long)want->rejected[2], (unsigned long long)want->rejected[3]);
            fail();
        }
    }
}

static uint32_t seq_of(const uint8_t *f) { return ub_get_u32le(f + UB_FRAME_OFF_SEQ); }

static void test_decoder_garbage_and_false_syncs(void **state) {
    (void)state;
    uint8_t s[200];
    size_t n = 0;
    const uint8_t junk[] = {0x00, 0xA5, 0x00, 0xA5, 0xA5, 0x5B, 0x01, 0x02}; /* A5 A5 5B: one candidate at the second A5 */
    memcpy(s + n, junk, sizeof junk);
    n += sizeof junk;
    size_t good = make_frame(10, s + n, 12);
    uint32_t seq = seq_of(s + n);
    n += good;
    s[n++] = 0xA5; /* a lone sync byte at the very end stays pending */
    /* The false candidate at offset 4 spans into the good frame: its header check fails. */
    expectation_t want = {.frames = 1, .seq = {seq}, .garbage = sizeof junk, .pending = 1};
    want.rejected[UB_RX_BAD_HDR_CHECK] = 1;
    check_every_chunking(s, n, &want);
}

static void test_decoder_names_each_rejection(void **state) {
    (void)state;
    uint8_t s[1200];
    size_t n = 0;
    expectation_t want = {0};
    sealed_defect_t defects[] = {WRONG_VERSION, WRONG_TYPE, PAYLOAD_TOO_BIG, SIZES_DISAGREE};
    ub_rx_reason_t reasons[] = {UB_RX_BAD_VERSION, UB_RX_BAD_VERSION, UB_RX_BAD_LENGTH, UB_RX_BAD_LENGTH};
    for (size_t i = 0; i < 4; i++) {
        size_t bad = make_sealed_bad(s + n, defects[i]);
        n += bad;
        want.garbage += bad;
        want.rejected[reasons[i]]++;
        size_t good = make_frame(20 + i, s + n, (uint16_t)(5 * i));
        want.seq[want.frames++] = seq_of(s + n);
        n += good;
    }
    size_t bad = make_frame(30, s + n, 25); /* payload flip: BAD_CRC */
    s[n + 80] ^= 0x10;
    n += bad;
    want.garbage += bad;
    want.rejected[UB_RX_BAD_CRC]++;
    bad = make_frame(31, s + n, 25); /* header flip: BAD_HDR_CHECK */
    s[n + 30] ^= 0x01;
    n += bad;
    want.garbage += bad;
    want.rejected[UB_RX_BAD_HDR_CHECK]++;
    size_t good = make_frame(32, s + n, 0);
    want.seq[want.frames++] = seq_of(s + n);
    n += good;
    check_every_chunking(s, n, &want);
}

/* A frame cut short inside its payload, then good frames: the cut frame's CRC runs into
 * the next frame and fails, and the decoder must find the next frame in bytes it has
 * already buffered. Same for a cut inside the header. */
static void test_decoder_truncated_then_good(void **state) {
    (void)state;
    for (size_t cut = 2; cut < 90; cut += 7) {
        uint8_t s[600];
        size_t n = 0;
        expectation_t want = {0};
        assert_int_equal(make_frame(40, s, 26), 90);
        n = cut; /* keep only the first `cut` bytes of the 90-byte frame */
        want.garbage = cut;
        want.rejected[cut <= 64 ? UB_RX_BAD_HDR_CHECK : UB_RX_BAD_CRC] = 1;
        for (int i = 0; i < 3; i++) {
            size_t good = make_frame(41 + (uint64_t)i, s + n, (uint16_t)(10 + 30 * i));
            want.seq[want.frames++] = seq_of(s + n);
            n += good;
        }
        check_every_chunking(s, n, &want);
    }
}

/* A sealed header claiming 500 payload bytes that never come: the good frames inside
 * the claimed length are found once the claim fails its CRC. The trailing filler
 * completes the claimed length so the verdict is reached. */
static void test_decoder_lying_length_hides_good_frames(void **state) {
    (void)state;
    uint8_t s[1000];
    memset(s, 0, sizeof s);
    size_t n = make_sealed_bad(s, LONGER_CLAIM) - 20; /* keep the 64-byte header only */
    expectation_t want = {0};
    want.rejected[UB_RX_BAD_CRC] = 1;
    want.garbage = n;
    for (int i = 0; i < 4; i++) {
        size_t good = make_frame(50 + (uint64_t)i, s + n, (uint16_t)(7 * i));
        want.seq[want.frames++] = seq_of(s + n);
        n += good;
    }
    size_t filler = 564 - n + 10;
    n += filler; /* zeros: no sync */
    want.garbage += filler;
    check_every_chunking(s, n, &want);

    /* Without the filler the claim is still open: everything after its header stays pending. */
    expectation_t open = {.pending = n - filler};
    check_every_chunking(s, n - filler, &open);
}

static void test_decoder_null_callback_and_empty_feeds(void **state) {
    (void)state;
    uint8_t f[UB_FRAME_MAX];
    size_t n = make_frame(60, f, 17);
    ub_decoder_t dec;
    ub_decoder_init(&dec);
    assert_int_equal(ub_decoder_feed(&dec, NULL, 0, NULL, NULL), 0);
    assert_int_equal(ub_decoder_feed(&dec, f, 0, NULL, NULL), 0);
    assert_int_equal(ub_decoder_feed(&dec, NULL, 5, NULL, NULL), 0);
    assert_int_equal(ub_decoder_feed(NULL, f, n, NULL, NULL), 0);
    assert_int_equal(ub_decoder_feed(&dec, f, n, NULL, NULL), 1);
    assert_int_equal(dec.stats.frames_ok, 1);
    assert_int_equal(dec.stats.bytes_ok, n);
    assert_int_equal(dec.stats.bytes_in, n);
    ub_decoder_init(&dec);
    assert_int_equal(dec.stats.frames_ok, 0);
    assert_int_equal(ub_decoder_pending(&dec), 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_finish_argument_errors),
        cmocka_unit_test(test_finish_writes_only_the_header),
        cmocka_unit_test(test_parse_errors),
        cmocka_unit_test(test_parse_reason_names_each_defect),
        cmocka_unit_test(test_set_hop_limit_reseals),
        cmocka_unit_test(test_decoder_garbage_and_false_syncs),
        cmocka_unit_test(test_decoder_names_each_rejection),
        cmocka_unit_test(test_decoder_truncated_then_good),
        cmocka_unit_test(test_decoder_lying_length_hides_good_frames),
        cmocka_unit_test(test_decoder_null_callback_and_empty_feeds),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
