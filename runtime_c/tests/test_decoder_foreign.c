/* Mixed streams (issue #24 item 1): uavbus frames interleaved with foreign traffic (NMEA-like text, random
 * binary, damaged frames), fed in seeded random chunkings. The test knows what it wrote, so it checks exactly:
 *  - the frame callback sees exactly the good frames, in order, byte for byte;
 *  - the foreign handler sees exactly every other byte, once, in order (the concatenation of its runs is the
 *    concatenation of the foreign items), and a run never holds a byte of a delivered frame;
 *  - when a frame is delivered, the handler has already seen every foreign byte written before it;
 *  - after every feed, bytes_in == bytes_ok + foreign_bytes + garbage_bytes + pending, with garbage 0;
 *  - bytes the handler does not take are counted in foreign_refused, exactly.
 * Without a handler the same stream counts the same bytes as garbage (today's behaviour). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_frame_util.h"
#include "ub/ub_frame.h"

#define SEED 0x24F0E1u
#define ROUNDS 200u
#define ITEMS_PER_ROUND 40u
#define STREAM_CAP (ITEMS_PER_ROUND * (UB_FRAME_MAX + 400u))

typedef struct expect {
    uint8_t *stream;
    size_t len;
    uint8_t *foreign; /* the foreign items' bytes, concatenated in stream order */
    size_t foreign_len;
    size_t frame_off[ITEMS_PER_ROUND]; /* good frames: offset in stream, length, foreign bytes before it */
    size_t frame_len[ITEMS_PER_ROUND];
    size_t foreign_before[ITEMS_PER_ROUND];
    size_t n_frames;
} expect_t;

typedef struct seen {
    const expect_t *e;
    size_t frames;
    size_t foreign;        /* bytes handed to the handler so far */
    size_t refused;        /* bytes it did not take, by its own count */
    size_t take_divisor;   /* 0: take every run whole; k: take len / k */
    int order_errors;
} seen_t;

static void on_frame(void *user, const ub_frame_header_t *h, const uint8_t *frame, size_t len) {
    (void)h;
    seen_t *s = user;
    const expect_t *e = s->e;
    assert_true(s->frames < e->n_frames);
    assert_int_equal(len, e->frame_len[s->frames]);
    assert_memory_equal(frame, e->stream + e->frame_off[s->frames], len);
    /* Every foreign byte before this frame was handed on before the frame. */
    if (s->foreign != e->foreign_before[s->frames]) s->order_errors++;
    s->frames++;
}

static size_t on_foreign(void *user, const uint8_t *run, size_t len) {
    seen_t *s = user;
    const expect_t *e = s->e;
    assert_true(len > 0);
    assert_true(s->foreign + len <= e->foreign_len);
    assert_memory_equal(run, e->foreign + s->foreign, len);
    s->foreign += len;
    size_t took = s->take_divisor == 0 ? len : len / s->take_divisor;
    s->refused += len - took;
    return took;
}

static void append(expect_t *e, const uint8_t *p, size_t n, int foreign) {
    assert_true(e->len + n <= STREAM_CAP);
    memcpy(e->stream + e->len, p, n);
    e->len += n;
    if (foreign) {
        memcpy(e->foreign + e->foreign_len, p, n);
        e->foreign_len += n;
    }
}

/* An NMEA-like sentence: printable ASCII, never a sync byte. */
static size_t nmea_like(test_rng_t *r, uint8_t *out) {
    size_t n = (size_t)snprintf((char *)out, 96, "$GPGGA,%06u.00,4807.%03u,N,01131.%03u,E,1,08,0.9,545.4,M,46.9,M,,*%02X\r\n",
                                (unsigned)rng_below(r, 235959), (unsigned)rng_below(r, 1000), (unsigned)rng_below(r, 1000),
                                (unsigned)rng_below(r, 256));
    return n;
}

static void build_round(test_rng_t *r, expect_t *e) {
    e->len = e->foreign_len = e->n_frames = 0;
    uint8_t tmp[UB_FRAME_MAX];
    for (unsigned i = 0; i < ITEMS_PER_ROUND; i++) {
        unsigned kind = i + 1 == ITEMS_PER_ROUND ? 0 : rng_below(r, 5); /* end on a good frame: nothing held */
        if (kind <= 1) {
            size_t n = random_frame(r, tmp, (uint16_t)rng_below(r, 200));
            assert_true(n > 0);
            e->frame_off[e->n_frames] = e->len;
            e->frame_len[e->n_frames] = n;
            e->foreign_before[e->n_frames] = e->foreign_len;
            e->n_frames++;
            append(e, tmp, n, 0);
        } else if (kind == 2) {
            append(e, tmp, nmea_like(r, tmp), 1);
        } else if (kind == 3) { /* random binary, with false sync pairs planted */
            size_t n = 1 + rng_below(r, 120);
            rng_fill(r, tmp, n);
            if (n >= 2 && rng_below(r, 2)) {
                size_t at = rng_below(r, (uint32_t)(n - 1));
                tmp[at] = UB_SYNC0;
                tmp[at + 1] = UB_SYNC1;
            }
            if (rng_below(r, 4) == 0) tmp[n - 1] = UB_SYNC0; /* a lone SYNC0 just before what follows */
            append(e, tmp, n, 1);
        } else { /* a damaged frame: one bit flipped, or cut short */
            size_t n = random_frame(r, tmp, (uint16_t)rng_below(r, 200));
            if (rng_below(r, 2)) {
                size_t at = rng_below(r, (uint32_t)n);
                tmp[at] ^= (uint8_t)(1u << rng_below(r, 8));
            } else {
                n = 1 + rng_below(r, (uint32_t)(n - 1));
            }
            append(e, tmp, n, 1);
        }
    }
}

static void check_accounting(const ub_decoder_t *d) {
    const ub_decoder_stats_t *st = &d->stats;
    assert_int_equal(st->bytes_in, st->bytes_ok + st->foreign_bytes + st->garbage_bytes + ub_decoder_pending(d));
}

static void feed_round(const expect_t *e, test_rng_t *r, size_t max_chunk, size_t take_divisor) {
    ub_decoder_t d;
    ub_decoder_init(&d);
    seen_t s = {.e = e, .take_divisor = take_divisor};
    ub_decoder_set_foreign(&d, on_foreign, &s);
    size_t off = 0;
    while (off < e->len) {
        size_t n = max_chunk == 0 ? e->len - off : 1 + rng_below(r, (uint32_t)max_chunk);
        if (n > e->len - off) n = e->len - off;
        (void)ub_decoder_feed(&d, e->stream + off, n, on_frame, &s);
        off += n;
        check_accounting(&d);
        assert_int_equal(d.stats.garbage_bytes, 0);
    }
    assert_int_equal(s.frames, e->n_frames);
    assert_int_equal(s.foreign, e->foreign_len);
    assert_int_equal(s.order_errors, 0);
    assert_int_equal(ub_decoder_pending(&d), 0);
    assert_int_equal(d.stats.frames_ok, e->n_frames);
    assert_int_equal(d.stats.foreign_bytes, e->foreign_len);
    assert_int_equal(d.stats.foreign_refused, s.refused);
    assert_int_equal(d.stats.bytes_in, e->len);
}

static void test_mixed_streams_random(void **state) {
    (void)state;
    expect_t e = {.stream = malloc(STREAM_CAP), .foreign = malloc(STREAM_CAP)};
    assert_non_null(e.stream);
    assert_non_null(e.foreign);
    test_rng_t r = {SEED};
    size_t refusing_rounds = 0;
    for (unsigned round = 0; round < ROUNDS; round++) {
        build_round(&r, &e);
        size_t divisor = round % 3 == 2 ? 2 : 0;
        refusing_rounds += divisor != 0;
        feed_round(&e, &r, 0, divisor);   /* one piece */
        feed_round(&e, &r, 1, divisor);   /* byte by byte */
        feed_round(&e, &r, 97, divisor);  /* odd chunks, shorter than a header */
        feed_round(&e, &r, 700, divisor); /* serial-sized reads */
    }
    assert_true(refusing_rounds > 0);
    free(e.stream);
    free(e.foreign);
}

/* Without a handler the same bytes are garbage, as before: the handler changes where they go, not what is
 * a frame. */
static void test_without_handler_bytes_are_garbage(void **state) {
    (void)state;
    expect_t e = {.stream = malloc(STREAM_CAP), .foreign = malloc(STREAM_CAP)};
    assert_non_null(e.stream);
    assert_non_null(e.foreign);
    test_rng_t r = {SEED ^ 1u};
    build_round(&r, &e);
    ub_decoder_t d;
    ub_decoder_init(&d);
    seen_t s = {.e = &e};
    (void)ub_decoder_feed(&d, e.stream, e.len, on_frame, &s);
    assert_int_equal(s.frames, e.n_frames);
    assert_int_equal(d.stats.foreign_bytes, 0);
    assert_int_equal(d.stats.garbage_bytes, e.foreign_len);
    check_accounting(&d);
    free(e.stream);
    free(e.foreign);
}

static size_t never_called(void *user, const uint8_t *run, size_t len) {
    (void)run;
    ++*(int *)user;
    return len;
}

/* A pure uavbus stream never reaches the handler; removing the handler restores garbage counting. */
static void test_pure_stream_and_removal(void **state) {
    (void)state;
    static uint8_t stream[16 * UB_FRAME_MAX];
    test_rng_t r = {SEED ^ 2u};
    size_t len = 0;
    for (int i = 0; i < 16; i++) len += random_frame(&r, stream + len, (uint16_t)rng_below(&r, 300));
    int calls = 0;
    ub_decoder_t d;
    ub_decoder_init(&d);
    ub_decoder_set_foreign(&d, never_called, &calls);
    assert_int_equal(ub_decoder_feed(&d, stream, len, NULL, NULL), 16);
    assert_int_equal(calls, 0);
    assert_int_equal(d.stats.foreign_bytes, 0);
    ub_decoder_set_foreign(&d, NULL, &calls);
    const uint8_t junk[] = "$GPVTG,054.7,T,034.4,M,005.5,N,010.2,K*48\r\n";
    assert_int_equal(ub_decoder_feed(&d, junk, sizeof junk - 1, NULL, NULL), 0);
    assert_int_equal(calls, 0);
    assert_int_equal(d.stats.garbage_bytes, sizeof junk - 1);
    ub_decoder_set_foreign(&d, never_called, &calls);
    ub_decoder_init(&d); /* init removes the handler too */
    assert_int_equal(ub_decoder_feed(&d, junk, sizeof junk - 1, NULL, NULL), 0);
    assert_int_equal(calls, 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mixed_streams_random),
        cmocka_unit_test(test_without_handler_bytes_are_garbage),
        cmocka_unit_test(test_pure_stream_and_removal),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
