/* Bad input: 10^5 seeded corruptions (bit flips, byte changes, truncations, lying
 * lengths, garbage bursts with false sync bytes and sealed fake headers), each followed
 * by a good frame, fed in random chunk sizes and then in one piece.
 *
 * The test knows what it wrote, so it checks exactly, with no tolerance. Which frames
 * must arrive follows from the decoder's rule (every sync position outside a delivered
 * frame is tried once, accepted iff the bytes from there form a valid frame), applied
 * by a plain whole-buffer scan with ub_frame_parse(). That expectation is then held
 * against what the test wrote: every delivery starts where the test put a good or a
 * corrupted frame (never inside garbage or inside a frame), every good frame arrives
 * unless a corrupted frame that is still valid covers it (a frame cut by one byte that
 * the next frame's first byte happens to complete), and a corrupted frame arrives only
 * if its bytes are valid. The decoder must then match it exactly: the same frames in
 * order, byte for byte; one rejection per other sync position (so every bad frame whose
 * sync survived is counted, the others as garbage); garbage == every byte not
 * delivered; nothing pending. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "test_frame_util.h"
#include "ub/ub_frame.h"
#include "ub/ub_wire.h"

#define CORRUPTIONS 100000u
#define SEED 0x5EEDF00Du

typedef struct span {
    size_t off;
    size_t len;
} span_t;

enum item_kind { ITEM_GOOD, ITEM_BROKEN, ITEM_GARBAGE };

typedef struct item {
    size_t off;
    enum item_kind kind;
} item_t;

typedef struct stream {
    uint8_t *bytes;
    size_t len, cap;
    item_t *items; /* what the test wrote, in order */
    size_t n_items, cap_items;
    span_t *expected; /* frames the decoder must deliver, in order (from expect_deliveries) */
    size_t n_expected;
    size_t broken;
} stream_t;

static uint8_t *stream_reserve(stream_t *s, size_t n) {
    if (s->len + n > s->cap) {
        s->cap = (s->len + n) * 2;
        s->bytes = realloc(s->bytes, s->cap);
        assert_non_null(s->bytes);
    }
    return s->bytes + s->len;
}

static void add_item(stream_t *s, enum item_kind kind) {
    if (s->n_items == s->cap_items) {
        s->cap_items = s->cap_items ? 2 * s->cap_items : 1024;
        s->items = realloc(s->items, s->cap_items * sizeof *s->items);
        assert_non_null(s->items);
    }
    s->items[s->n_items++] = (item_t){s->len, kind};
}

static uint16_t random_payload_size(test_rng_t *r) {
    return (uint16_t)(rng_below(r, 50) == 0 ? rng_below(r, UB_MAX_PAYLOAD + 1) : rng_below(r, 65));
}

static void append_good(stream_t *s, test_rng_t *r) {
    size_t n = random_frame(r, stream_reserve(s, UB_FRAME_MAX), random_payload_size(r));
    add_item(s, ITEM_GOOD);
    s->len += n;
}

/* Recomputes the header check only (as a sender with a bug or an attacker might). */
static void reseal_header(uint8_t *f) {
    uint32_t c = ub_crc32c(f + 4, 56);
    f[2] = (uint8_t)(c ^ (c >> 8) ^ (c >> 16) ^ (c >> 24));
}

enum kind { BIT_FLIPS, BYTE_CHANGES, TRUNCATION, LYING_LENGTH, GARBAGE, FAKE_HEADERS };

/* Appends one corrupted frame or garbage burst. */
static void append_corruption(stream_t *s, test_rng_t *r) {
    enum kind kind = (enum kind)rng_below(r, 6);
    uint8_t *f = stream_reserve(s, UB_FRAME_MAX + 300);
    size_t n = 0;
    if (kind == GARBAGE || kind == FAKE_HEADERS) {
        n = 1 + rng_below(r, 200);
        rng_fill(r, f, n);
        for (uint32_t k = rng_below(r, 4); k > 0; k--) { /* false sync pairs */
            size_t at = rng_below(r, (uint32_t)n);
            f[at] = UB_SYNC0;
            if (at + 1 < n) f[at + 1] = UB_SYNC1;
        }
        if (kind == FAKE_HEADERS && n >= 64) { /* a sealed header promising more than follows */
            size_t at = rng_below(r, (uint32_t)(n - 63));
            uint8_t *h = f + at;
            h[0] = UB_SYNC0;
            h[1] = UB_SYNC1;
            h[3] = rng_below(r, 8) == 0 ? 2 : UB_WIRE_VERSION;
            ub_put_u16le(h + UB_FRAME_OFF_MSG_TYPE, UB_MSG_TYPE_PUBSUB);
            uint16_t ps = (uint16_t)rng_below(r, UB_MAX_PAYLOAD + 40);
            ub_put_u16le(h + UB_FRAME_OFF_PAYLOAD_SIZE, ps);
            ub_put_u16le(h + UB_FRAME_OFF_MSG_SIZE, (uint16_t)(64 + ps + (rng_below(r, 4) == 0)));
            reseal_header(h);
        }
        add_item(s, ITEM_GARBAGE);
        s->len += n;
        return;
    }
    n = random_frame(r, f, random_payload_size(r));
    size_t keep = n;
    switch (kind) {
    case BIT_FLIPS:
        for (uint32_t k = 1 + rng_below(r, 8); k > 0; k--) {
            uint32_t bit = rng_below(r, (uint32_t)(8 * n));
            f[bit / 8] ^= (uint8_t)(1u << (bit % 8));
        }
        break;
    case BYTE_CHANGES:
        for (uint32_t k = 1 + rng_below(r, 4); k > 0; k--) f[rng_below(r, (uint32_t)n)] = (uint8_t)rng_next(r);
        break;
    case TRUNCATION: keep = 1 + rng_below(r, (uint32_t)(n - 1)); break;
    case LYING_LENGTH: {
        uint16_t ps = (uint16_t)rng_below(r, UB_MAX_PAYLOAD + 40);
        ub_put_u16le(f + UB_FRAME_OFF_PAYLOAD_SIZE, ps);
        ub_put_u16le(f + UB_FRAME_OFF_MSG_SIZE, (uint16_t)(64 + ps));
        reseal_header(f);
        break;
    }
    default: break;
    }
    s->broken++;
    add_item(s, ITEM_BROKEN);
    s->len += keep;
}

static void build_stream(stream_t *s) {
    test_rng_t rng = {SEED};
    append_good(s, &rng);
    for (uint32_t i = 0; i < CORRUPTIONS; i++) {
        append_corruption(s, &rng);
        append_good(s, &rng);
    }
    /* Zeros after the last frame let every open candidate reach its verdict. */
    memset(stream_reserve(s, UB_FRAME_MAX), 0, UB_FRAME_MAX);
    s->len += UB_FRAME_MAX;
}

/* Length of the valid frame starting at `i`, or 0: the decoder's acceptance rule. */
static size_t valid_frame_at(const stream_t *s, size_t i) {
    if (s->len - i < UB_FRAME_HEADER_LEN) return 0;
    size_t claimed = ub_get_u16le(s->bytes + i + UB_FRAME_OFF_MSG_SIZE);
    if (claimed > s->len - i) return 0;
    return ub_frame_parse(s->bytes + i, claimed, NULL) == UB_OK ? claimed : 0;
}

/* The plain scan: fills s->expected and returns the number of sync positions rejected. */
static uint64_t expect_deliveries(stream_t *s) {
    uint64_t rejections = 0;
    s->expected = malloc((s->n_items + 1) * sizeof *s->expected);
    assert_non_null(s->expected);
    for (size_t i = 0; i + 1 < s->len;) {
        if (s->bytes[i] != UB_SYNC0 || s->bytes[i + 1] != UB_SYNC1) {
            i++;
            continue;
        }
        size_t n = valid_frame_at(s, i);
        if (n == 0) {
            rejections++;
            i++;
            continue;
        }
        assert_true(s->n_expected <= s->n_items);
        s->expected[s->n_expected++] = (span_t){i, n};
        i += n;
    }
    return rejections;
}

/* Holds the expectation against what the test wrote (see the comment at the top). */
static void check_expectation_against_ground_truth(const stream_t *s, size_t *broken_valid, size_t *swallowed) {
    size_t e = 0;
    *broken_valid = *swallowed = 0;
    for (size_t k = 0; k < s->n_items; k++) {
        const item_t *it = &s->items[k];
        int delivered_here = e < s->n_expected && s->expected[e].off == it->off;
        int covered = e > 0 && it->off < s->expected[e - 1].off + s->expected[e - 1].len;
        assert_true(e >= s->n_expected || s->expected[e].off >= it->off); /* no delivery inside an item */
        if (delivered_here) {
            assert_int_not_equal(it->kind, ITEM_GARBAGE);
            if (it->kind == ITEM_BROKEN) (*broken_valid)++;
            e++;
        } else if (it->kind == ITEM_GOOD) {
            /* Only a still-valid corrupted frame just before may cover a good one. */
            assert_true(covered && s->items[k - 1].kind == ITEM_BROKEN && s->expected[e - 1].off == s->items[k - 1].off);
            (*swallowed)++;
        }
        if (it->kind == ITEM_BROKEN && delivered_here) { /* it can only have been completed, never shortened */
            size_t own_len = (k + 1 < s->n_items ? s->items[k + 1].off : s->len) - it->off;
            assert_true(s->expected[e - 1].len >= own_len);
        }
    }
    assert_int_equal(e, s->n_expected);
}

typedef struct checker {
    const stream_t *s;
    size_t next;
    size_t mismatches;
} checker_t;

static void check_delivery(void *user, const ub_frame_header_t *h, const uint8_t *frame, size_t frame_len) {
    checker_t *c = user;
    const span_t *want = c->next < c->s->n_expected ? &c->s->expected[c->next] : NULL;
    if (want == NULL || want->len != frame_len || memcmp(frame, c->s->bytes + want->off, frame_len) != 0 ||
        h->payload_size + UB_FRAME_HEADER_LEN != frame_len) {
        if (c->mismatches++ < 5)
            print_error("delivery %zu differs from the expected frame: got %zu bytes at %td, want %zu at %zu\n",
                        c->next, frame_len, frame - c->s->bytes, want ? want->len : 0, want ? want->off : 0);
    }
    c->next++;
}

static void assert_exact_outcome(const stream_t *s, const ub_decoder_t *d, const checker_t *c, uint64_t rejections) {
    uint64_t rejected = 0, delivered_bytes = 0;
    for (int r = 0; r < UB_RX_REASON_COUNT; r++) rejected += d->stats.rejected[r];
    for (size_t i = 0; i < s->n_expected; i++) delivered_bytes += s->expected[i].len;
    assert_int_equal(c->mismatches, 0);
    assert_int_equal(c->next, s->n_expected);
    assert_int_equal(d->stats.frames_ok, s->n_expected);
    assert_int_equal(d->stats.bytes_in, s->len);
    assert_int_equal(d->stats.bytes_ok, delivered_bytes);
    assert_int_equal(ub_decoder_pending(d), 0);
    assert_int_equal(d->stats.garbage_bytes, s->len - delivered_bytes);
    assert_int_equal(rejected, rejections);
    assert_int_equal(d->stats.rejected[UB_RX_BAD_SYNC], 0);
}

static void test_corruptions_fed_in_random_chunks(void **state) {
    (void)state;
    stream_t s = {0};
    build_stream(&s);
    uint64_t rejections = expect_deliveries(&s);
    size_t broken_valid = 0, swallowed = 0;
    check_expectation_against_ground_truth(&s, &broken_valid, &swallowed);
    assert_true(s.broken >= CORRUPTIONS / 2);

    ub_decoder_t dec;
    ub_decoder_init(&dec);
    checker_t c = {&s, 0, 0};
    test_rng_t rng = {SEED ^ 0xC4u};
    static const uint32_t chunk_limits[] = {1, 8, 100, 2000, 70000};
    for (size_t off = 0; off < s.len;) {
        size_t chunk = 1 + rng_below(&rng, chunk_limits[rng_below(&rng, 5)]);
        if (chunk > s.len - off) chunk = s.len - off;
        (void)ub_decoder_feed(&dec, s.bytes + off, chunk, check_delivery, &c);
        off += chunk;
    }
    print_message("%zu bytes: %zu corruptions (%zu broke a frame, %zu of those still valid and delivered, "
                  "covering %zu good frames), %zu frames delivered, "
                  "rejected hdr/crc/len/ver %llu/%llu/%llu/%llu, garbage %llu bytes\n",
                  s.len, (size_t)CORRUPTIONS, s.broken, broken_valid, swallowed, s.n_expected,
                  (unsigned long long)dec.stats.rejected[0], (unsigned long long)dec.stats.rejected[1],
                  (unsigned long long)dec.stats.rejected[2], (unsigned long long)dec.stats.rejected[3],
                  (unsigned long long)dec.stats.garbage_bytes);
    assert_exact_outcome(&s, &dec, &c, rejections);
    /* Each reason must actually have been exercised. */
    for (int r = 0; r < UB_RX_BAD_SYNC; r++) assert_true(dec.stats.rejected[r] > 0);

    /* The same stream in one piece: identical counters (chunking changes nothing). */
    ub_decoder_stats_t chunked = dec.stats;
    ub_decoder_init(&dec);
    checker_t whole = {&s, 0, 0};
    (void)ub_decoder_feed(&dec, s.bytes, s.len, check_delivery, &whole);
    assert_exact_outcome(&s, &dec, &whole, rejections);
    assert_memory_equal(&dec.stats, &chunked, sizeof chunked);

    free(s.bytes);
    free(s.items);
    free(s.expected);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_corruptions_fed_in_random_chunks),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
