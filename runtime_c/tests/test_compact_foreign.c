/* Foreign traffic on a compact-encoded stream (issue #24): compact packets are COBS-stuffed and end with a
 * 0x00 delimiter, so a foreign message (NMEA text, a legacy binary message without a 0x00) is glued to the
 * packet after it. With a foreign-traffic handler the stream decoder hands the foreign bytes on, once and in
 * order, and still delivers the packet glued after them; a packet's bytes never reach the handler. Without a
 * handler the same bytes are garbage, as before. After every feed the decoder's accounting invariant holds. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <string.h>

#include "test_frame_util.h"
#include "ub/ub_compact.h"
#include "ub/ub_frame.h"

#define N_PACKETS 6

typedef struct seen {
    uint8_t foreign[2048];
    size_t foreign_len;
    uint8_t frames[N_PACKETS][UB_FRAME_MAX];
    size_t frame_len[N_PACKETS];
    size_t n_frames;
    ub_compact_t *rx;
} seen_t;

static size_t on_foreign(void *user, const uint8_t *run, size_t len) {
    seen_t *s = user;
    assert_true(s->foreign_len + len <= sizeof s->foreign);
    memcpy(s->foreign + s->foreign_len, run, len);
    s->foreign_len += len;
    return len;
}

static void on_frame(void *user, const ub_frame_header_t *h, const uint8_t *frame, size_t len, bool seq32) {
    seen_t *s = user;
    assert_true(s->n_frames < N_PACKETS);
    memcpy(s->frames[s->n_frames], frame, len);
    s->frame_len[s->n_frames++] = len;
    ub_compact_rx_note(s->rx, h->src_id, h->seq, seq32); /* as the node does after its security gate */
}

static void check_invariant(const ub_decoder_t *d) {
    const ub_decoder_stats_t *st = &d->stats;
    assert_int_equal(st->bytes_in, st->bytes_ok + st->foreign_bytes + st->garbage_bytes + ub_decoder_pending(d));
}

/* Text, packet, text, packet, ... text: NMEA-like sentences (no 0x00) before every packet. */
static void run(bool with_handler) {
    test_rng_t rng = {0x24C0u};
    ub_compact_t tx, rx;
    ub_compact_init(&tx, NULL, 7, NULL);
    ub_compact_init(&rx, NULL, 9, NULL);
    uint8_t stream[8192], frames[N_PACKETS][UB_FRAME_MAX], text[2048];
    size_t len = 0, text_len = 0, frame_len[N_PACKETS];
    for (int i = 0; i < N_PACKETS; i++) {
        char line[96];
        int n = snprintf(line, sizeof line, "$GPVTG,%d.5,T,,M,5.5,N,10.2,K*4%d\r\n", 50 + i, i);
        memcpy(stream + len, line, (size_t)n);
        memcpy(text + text_len, line, (size_t)n);
        len += (size_t)n;
        text_len += (size_t)n;
        frame_len[i] = random_frame(&rng, frames[i], (uint16_t)(8 + 4 * i));
        int w = ub_compact_link_encode(&tx, frames[i], frame_len[i], stream + len, sizeof stream - len);
        assert_true(w > 0);
        len += (size_t)w;
    }
    const char tail[] = "legacy tail, then its own 0x00:";
    memcpy(stream + len, tail, sizeof tail); /* sizeof: with the NUL, which ends the segment */
    memcpy(text + text_len, tail, sizeof tail);
    len += sizeof tail;
    text_len += sizeof tail;

    seen_t seen;
    memset(&seen, 0, sizeof seen);
    seen.rx = &rx;
    ub_decoder_t dec;
    ub_decoder_init(&dec);
    if (with_handler) ub_decoder_set_foreign(&dec, on_foreign, &seen);
    uint64_t rejected[UB_RX_REASON_COUNT] = {0};
    size_t found = 0;
    for (size_t off = 0, cut = 1; off < len; off += cut, cut = cut % 37 + 1) { /* cuts of 1..37 bytes */
        size_t c = cut < len - off ? cut : len - off;
        found += ub_compact_feed(&rx, &dec, stream + off, c, 0, rejected, on_frame, &seen);
        check_invariant(&dec);
    }
    assert_int_equal(ub_decoder_pending(&dec), 0);
    if (with_handler) {
        assert_int_equal(found, N_PACKETS); /* every packet, though glued to the text before it */
        assert_int_equal(seen.n_frames, N_PACKETS);
        for (int i = 0; i < N_PACKETS; i++) {
            assert_int_equal(seen.frame_len[i], frame_len[i]);
            assert_memory_equal(seen.frames[i], frames[i], frame_len[i]);
        }
        assert_int_equal(seen.foreign_len, text_len); /* every foreign byte once, in order, no packet byte */
        assert_memory_equal(seen.foreign, text, text_len);
        assert_int_equal(dec.stats.foreign_bytes, text_len);
        assert_int_equal(dec.stats.garbage_bytes, 0);
    } else {
        assert_int_equal(dec.stats.foreign_bytes, 0); /* as before: the glued segments are garbage */
        assert_int_equal(dec.stats.bytes_ok + dec.stats.garbage_bytes, len);
    }
}

static void test_foreign_bytes_on_a_compact_stream(void **state) {
    (void)state;
    run(true);
}

static void test_without_handler_they_are_garbage(void **state) {
    (void)state;
    run(false);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_foreign_bytes_on_a_compact_stream),
        cmocka_unit_test(test_without_handler_they_are_garbage),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
