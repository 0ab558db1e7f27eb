/* The frame layer's fast paths against its reference path, over seeded random rows and hops:
 *  - a row's header template (ub_frame_tpl_finish) writes the bytes ub_frame_finish writes, across payload
 *    sizes (a size change re-primes the template) and sequence numbers;
 *  - patching the hop limit by CRC linearity (ub_frame_patch_hop_limit) writes the bytes recomputing the
 *    checks does (ub_frame_set_hop_limit), plain and flagged frames, every hop limit, chains of hops; and so does
 *    the forwarder's copy with its memo of the last change (ub_frame_copy_hop_limit);
 *  - the CRC helpers under them (ub_crc32c_zeros, ub_crc32c_byte_delta, ub_crc32c_frame_tail, ub_crc32c_header)
 *    against the table path and plain CRCs.
 * The vectors of tests/vectors/frames.json are reproduced by the same fast paths in test_frame_vectors. */
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "../src/codec/ub_crc32c_impl.h"
#include "test_frame_util.h"
#include "ub/ub_frame.h"
#include "ub/ub_wire.h"

#define ROWS 300

static uint16_t random_size(test_rng_t *r) {
    /* Mostly small (every 0..8 remainder of the 8-byte steps), sometimes up to the largest payload. */
    return (uint16_t)(rng_below(r, 4) == 0 ? rng_below(r, UB_MAX_PAYLOAD + 1) : rng_below(r, 130));
}

static void test_template_equals_finish(void **state) {
    (void)state;
    test_rng_t r = {0x28A7u};
    for (int row = 0; row < ROWS; row++) {
        ub_frame_header_t h = random_header(&r, random_size(&r));
        h.admin = (uint8_t)rng_next(&r);
        ub_frame_tpl_t t;
        assert_int_equal(ub_frame_tpl_init(&t, &h), UB_OK);
        for (int k = 0; k < 8; k++) {
            if (rng_below(&r, 4) == 0) h.payload_size = random_size(&r); /* a variable-size type: re-primed */
            h.seq = rng_below(&r, 3) == 0 ? h.seq + 1 : (uint32_t)rng_next(&r);
            uint8_t want[UB_FRAME_MAX], got[UB_FRAME_MAX];
            rng_fill(&r, want, sizeof want);
            memcpy(got, want, sizeof got); /* same payload and same bytes past it */
            int n = ub_frame_finish(want, sizeof want, &h);
            assert_true(n > 0);
            assert_int_equal(ub_frame_tpl_finish(&t, got, sizeof got, h.payload_size, h.seq), n);
            assert_memory_equal(got, want, sizeof got); /* nothing past the frame written either */
            ub_frame_header_t back;
            assert_int_equal(ub_frame_parse(got, (size_t)n, &back), UB_OK);
            assert_int_equal(back.seq, h.seq);
        }
    }
}

/* The template's portable build (a CPU without the hardware CRC) against ub_frame_finish: on this machine the
 * hardware path runs, so the test sets fast_size to what tpl_prime() writes on such a CPU (UINT32_MAX: no
 * payload size matches) -- white-box, the one way to reach that build here. Every size 0..129 (each remainder
 * of the 16-byte steps and of the 8/4/2/1 tail) and the largest. */
static void test_template_portable_equals_finish(void **state) {
    (void)state;
    test_rng_t r = {0x5E42u};
    for (int size = 0; size <= 130; size++) {
        uint16_t ps = (uint16_t)(size == 130 ? UB_MAX_PAYLOAD : size);
        ub_frame_header_t h = random_header(&r, ps);
        ub_frame_tpl_t t;
        assert_int_equal(ub_frame_tpl_init(&t, &h), UB_OK);
        t.fast_size = UINT32_MAX;
        uint8_t want[UB_FRAME_MAX], got[UB_FRAME_MAX];
        rng_fill(&r, want, sizeof want);
        memcpy(got, want, sizeof got);
        int n = ub_frame_finish(want, sizeof want, &h);
        assert_true(n > 0);
        assert_int_equal(ub_frame_tpl_finish(&t, got, sizeof got, ps, h.seq), n);
        assert_memory_equal(got, want, sizeof got);
        assert_int_equal(ub_frame_tpl_finish(&t, got, (size_t)n - 1, ps, h.seq), UB_ERR_NOSPACE);
    }
}

/* ub_frame_tpl_finish_header: one template as a cache over headers that change in every fixed field now and
 * then (a node's send path keeps a few for many rows): same bytes as ub_frame_finish each time, starting from a
 * zeroed template (which must match no header). */
static void test_template_cache_equals_finish(void **state) {
    (void)state;
    test_rng_t r = {0xCAC4Eu};
    ub_frame_tpl_t t;
    memset(&t, 0, sizeof t);
    ub_frame_header_t h = random_header(&r, random_size(&r));
    for (int k = 0; k < 2000; k++) {
        switch (rng_below(&r, 9)) {
        case 0: h = random_header(&r, random_size(&r)); break; /* another row */
        case 1: h.hop_limit = (uint8_t)(1 + rng_below(&r, 255)); break;
        case 2: h.payload_size = random_size(&r); break;
        case 3: h.admin = (uint8_t)rng_next(&r); break;
        case 4: h.fingerprint ^= 1u << rng_below(&r, 32); break;
        case 5: h.dir_id[rng_below(&r, UB_DIR_ID_LEN)] ^= (uint8_t)(1 + rng_below(&r, 255)); break;
        case 6: /* one byte of either entity ID: each of the template's compared words */
            (rng_below(&r, 2) ? h.dest_id : h.src_id)[rng_below(&r, UB_ENTITY_ID_LEN)] ^= (uint8_t)(1 + rng_below(&r, 255));
            break;
        default: break; /* the same row again */
        }
        h.flags = 0;
        h.seq = (uint32_t)rng_next(&r);
        uint8_t want[UB_FRAME_MAX], got[UB_FRAME_MAX];
        rng_fill(&r, want, sizeof want);
        memcpy(got, want, sizeof got);
        int n = ub_frame_finish(want, sizeof want, &h);
        assert_true(n > 0);
        assert_int_equal(ub_frame_tpl_finish_header(&t, got, sizeof got, &h), n);
        assert_memory_equal(got, want, sizeof got);
    }
    uint8_t frame[UB_FRAME_MAX];
    assert_int_equal(ub_frame_tpl_finish_header(NULL, frame, sizeof frame, &h), UB_ERR_INVAL);
    assert_int_equal(ub_frame_tpl_finish_header(&t, frame, sizeof frame, NULL), UB_ERR_INVAL);
    h.flags = UB_FRAME_FLAG_SIGNED;
    assert_int_equal(ub_frame_tpl_finish_header(&t, frame, sizeof frame, &h), UB_ERR_INVAL);
    h.flags = 0;
    h.hop_limit = 0;
    assert_int_equal(ub_frame_tpl_finish_header(&t, frame, sizeof frame, &h), UB_ERR_RANGE);
    h.hop_limit = 1;
    assert_int_equal(ub_frame_tpl_finish_header(&t, frame, UB_FRAME_HEADER_LEN + h.payload_size - 1u, &h), UB_ERR_NOSPACE);
    /* A zeroed template matches no header, not even an all-zero one: its hop limit 0 is refused, not built. */
    memset(&t, 0, sizeof t);
    memset(&h, 0, sizeof h);
    assert_int_equal(ub_frame_tpl_finish_header(&t, frame, sizeof frame, &h), UB_ERR_RANGE);
}

static void test_template_errors(void **state) {
    (void)state;
    test_rng_t r = {7};
    ub_frame_header_t h = random_header(&r, 20);
    ub_frame_tpl_t t;
    uint8_t frame[UB_FRAME_MAX];
    assert_int_equal(ub_frame_tpl_init(NULL, &h), UB_ERR_INVAL);
    assert_int_equal(ub_frame_tpl_init(&t, NULL), UB_ERR_INVAL);
    h.flags = UB_FRAME_FLAG_SIGNED;
    assert_int_equal(ub_frame_tpl_init(&t, &h), UB_ERR_INVAL); /* protected frames: ub_sec_protect() */
    h.flags = 0;
    h.hop_limit = 0;
    assert_int_equal(ub_frame_tpl_init(&t, &h), UB_ERR_RANGE);
    h.hop_limit = 3;
    h.payload_size = UB_MAX_PAYLOAD + 1;
    assert_int_equal(ub_frame_tpl_init(&t, &h), UB_ERR_RANGE);
    h.payload_size = 20;
    assert_int_equal(ub_frame_tpl_init(&t, &h), UB_OK);
    assert_int_equal(ub_frame_tpl_finish(NULL, frame, sizeof frame, 20, 1), UB_ERR_INVAL);
    assert_int_equal(ub_frame_tpl_finish(&t, NULL, sizeof frame, 20, 1), UB_ERR_INVAL);
    assert_int_equal(ub_frame_tpl_finish(&t, frame, UB_FRAME_HEADER_LEN + 19, 20, 1), UB_ERR_NOSPACE);
    assert_int_equal(ub_frame_tpl_finish(&t, frame, sizeof frame, UB_MAX_PAYLOAD + 1, 1), UB_ERR_RANGE);
    assert_int_equal(ub_frame_tpl_finish(&t, frame, sizeof frame, 20, 1), UB_FRAME_HEADER_LEN + 20);
}

/* A random valid frame, plain or with one of the trailers (random trailer bytes: the checks cover them). */
static size_t random_any_frame(test_rng_t *r, uint8_t *out) {
    static const uint8_t flags[] = {0, UB_FRAME_FLAG_SIGNED, UB_FRAME_FLAG_ENCRYPTED,
                                    UB_FRAME_FLAG_SIGNED | UB_FRAME_FLAG_ORIGIN,
                                    UB_FRAME_FLAG_ENCRYPTED | UB_FRAME_FLAG_ORIGIN};
    ub_frame_header_t h = random_header(r, random_size(r));
    h.flags = flags[rng_below(r, sizeof flags)];
    rng_fill(r, out + UB_FRAME_HEADER_LEN, h.payload_size + ub_frame_trailer_len(h.flags));
    int n = ub_frame_finish(out, UB_FRAME_MAX, &h);
    assert_true(n > 0);
    return (size_t)n;
}

static void test_patch_equals_recompute(void **state) {
    (void)state;
    test_rng_t r = {0x5EED28u};
    for (int row = 0; row < ROWS; row++) {
        uint8_t want[UB_FRAME_MAX], got[UB_FRAME_MAX];
        size_t n = random_any_frame(&r, want);
        memcpy(got, want, n);
        /* A chain of forwarders (each patching the last one's output), then arbitrary new limits. */
        for (int hop = 0; hop < 12; hop++) {
            uint8_t next = hop < 6 ? (uint8_t)(got[UB_FRAME_OFF_HOP_LIMIT] > 1 ? got[UB_FRAME_OFF_HOP_LIMIT] - 1 : 255)
                                   : (uint8_t)(1 + rng_below(&r, 255));
            assert_int_equal(ub_frame_set_hop_limit(want, n, next), UB_OK);
            assert_int_equal(ub_frame_patch_hop_limit(got, n, next), UB_OK);
            assert_memory_equal(got, want, n);
            assert_int_equal(ub_frame_parse(got, n, NULL), UB_OK);
        }
        /* The same limit again changes nothing. */
        assert_int_equal(ub_frame_patch_hop_limit(got, n, got[UB_FRAME_OFF_HOP_LIMIT]), UB_OK);
        assert_memory_equal(got, want, n);
    }
}

static void test_patch_keeps_damage_and_errors(void **state) {
    (void)state;
    test_rng_t r = {99};
    uint8_t f[UB_FRAME_MAX];
    size_t n = random_frame(&r, f, 40);
    f[UB_FRAME_HEADER_LEN + 5] ^= 0x10; /* a damaged payload: the patch must not make it valid */
    assert_int_equal(ub_frame_parse(f, n, NULL), UB_ERR_CHECKSUM);
    assert_int_equal(ub_frame_patch_hop_limit(f, n, 2), UB_OK);
    assert_int_equal(ub_frame_parse(f, n, NULL), UB_ERR_CHECKSUM);
    assert_int_equal(ub_frame_patch_hop_limit(f, n, 0), UB_ERR_RANGE);
    assert_int_equal(ub_frame_patch_hop_limit(NULL, n, 2), UB_ERR_INVAL);
    assert_int_equal(ub_frame_patch_hop_limit(f, n - 1, 2), UB_ERR_INVAL);
    assert_int_equal(ub_frame_patch_hop_limit(f, 10, 2), UB_ERR_INVAL);
}

/* The forwarder's copy (ub_frame_copy_hop_limit) against copying and recomputing: one memo across rows of every
 * length, chains of hops and arbitrary limits, so the memo is reused (same change, same length), replaced
 * (another change or length) and found stale; and without a memo. The source is never written. */
static void test_copy_equals_recompute(void **state) {
    (void)state;
    test_rng_t r = {0xC0B7u};
    ub_frame_hop_memo_t memo;
    memset(&memo, 0, sizeof memo);
    unsigned reused = 0;
    for (int row = 0; row < ROWS; row++) {
        uint8_t src[UB_FRAME_MAX], keep[UB_FRAME_MAX], want[UB_FRAME_MAX], got[UB_FRAME_MAX];
        size_t n = random_any_frame(&r, src);
        for (int k = 0; k < 8; k++) {
            uint8_t next = k < 4 ? (uint8_t)(src[UB_FRAME_OFF_HOP_LIMIT] > 1 ? src[UB_FRAME_OFF_HOP_LIMIT] - 1 : 255)
                                 : (uint8_t)(1 + rng_below(&r, 255));
            memcpy(keep, src, n);
            memcpy(want, src, n);
            assert_int_equal(ub_frame_set_hop_limit(want, n, next), UB_OK);
            bool hit = memo.len == n && memo.d == (src[UB_FRAME_OFF_HOP_LIMIT] ^ next);
            reused += hit;
            rng_fill(&r, got, sizeof got);
            assert_int_equal(ub_frame_copy_hop_limit(got, src, n, next, k % 3 == 2 ? NULL : &memo), UB_OK);
            assert_memory_equal(got, want, n);
            assert_memory_equal(src, keep, n);
            assert_int_equal(ub_frame_parse(got, n, NULL), UB_OK);
            if (k % 2 == 1) memcpy(src, got, n); /* the next forwarder's input: a chain */
        }
    }
    assert_true(reused > ROWS); /* the memo's path ran, not only the first-change one */
}

static void test_copy_keeps_damage_and_errors(void **state) {
    (void)state;
    test_rng_t r = {77};
    uint8_t f[UB_FRAME_MAX], out[UB_FRAME_MAX], untouched[UB_FRAME_MAX];
    size_t n = random_frame(&r, f, 40);
    ub_frame_hop_memo_t memo;
    memset(&memo, 0, sizeof memo);
    f[UB_FRAME_HEADER_LEN + 5] ^= 0x10; /* a damaged payload: neither copy may make it valid */
    for (int k = 0; k < 2; k++) {       /* the first change, then the memo's */
        assert_int_equal(ub_frame_copy_hop_limit(out, f, n, 2, &memo), UB_OK);
        assert_int_equal(ub_frame_parse(out, n, NULL), UB_ERR_CHECKSUM);
    }
    memset(out, 0xA5, sizeof out);
    memcpy(untouched, out, sizeof out);
    assert_int_equal(ub_frame_copy_hop_limit(out, f, n, 0, &memo), UB_ERR_RANGE);
    assert_int_equal(ub_frame_copy_hop_limit(NULL, f, n, 2, &memo), UB_ERR_INVAL);
    assert_int_equal(ub_frame_copy_hop_limit(out, NULL, n, 2, &memo), UB_ERR_INVAL);
    assert_int_equal(ub_frame_copy_hop_limit(out, f, n - 1, 2, &memo), UB_ERR_INVAL);
    assert_int_equal(ub_frame_copy_hop_limit(out, f, 10, 2, NULL), UB_ERR_INVAL);
    assert_memory_equal(out, untouched, sizeof out); /* refused: nothing written */
}

/* The register over n zero bytes, by feeding real zero bytes through the table path (which works on
 * finished CRCs: register = ~crc). */
static uint32_t zeros_reference(uint32_t reg, size_t n) {
    static const uint8_t zero[UB_FRAME_MAX]; /* const: no state */
    return ~ub_crc32c_update_portable(~reg, zero, n);
}

static void test_crc_helpers(void **state) {
    (void)state;
    test_rng_t r = {0xC0FFEEu};
    for (int i = 0; i < 2000; i++) {
        uint32_t reg = (uint32_t)rng_next(&r);
        size_t n = rng_below(&r, UB_FRAME_MAX);
        assert_int_equal(ub_crc32c_zeros(reg, n), zeros_reference(reg, n));
        uint8_t hdr[UB_FRAME_HEADER_LEN];
        rng_fill(&r, hdr, sizeof hdr);
        assert_int_equal(ub_crc32c_header(hdr), ub_crc32c_update_portable(0, hdr + 4, 56));
        uint8_t d = (uint8_t)rng_next(&r);
        size_t n1 = rng_below(&r, 64), n2 = rng_below(&r, UB_FRAME_MAX);
        uint32_t d1 = 0, d2 = ub_crc32c_byte_delta(d, n1, n2, &d1);
        assert_int_equal(d1, zeros_reference(~ub_crc32c_update_portable(0xFFFFFFFFu, &d, 1), n1));
        assert_int_equal(d2, zeros_reference(d1, n2));
        if (i % 16 == 0) { /* both constant tables (ub_crc32c_shift.h), any 16-bit length, and beyond */
            size_t big = rng_below(&r, 0x14000u);
            uint32_t want = reg;
            for (size_t left = big; left > 0;) {
                size_t step = left < UB_FRAME_MAX ? left : UB_FRAME_MAX;
                want = zeros_reference(want, step);
                left -= step;
            }
            assert_int_equal(ub_crc32c_zeros(reg, big), want);
        }
        uint8_t bytes[8 + 200];
        size_t len = rng_below(&r, 201);
        rng_fill(&r, bytes, 8 + len);
        assert_int_equal(ub_crc32c_zeros(reg, i % 300), zeros_reference(reg, i % 300)); /* every small length */
        uint32_t head = (uint32_t)rng_next(&r);
        uint64_t both = ub_crc32c_frame_tail(head, ub_get_u64le(bytes), bytes + 8, len);
        assert_int_equal((uint32_t)both, ub_crc32c_update_portable(head, bytes, 8));
        assert_int_equal((uint32_t)(both >> 32), ub_crc32c_update_portable(head, bytes, 8 + len));
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_template_equals_finish),
        cmocka_unit_test(test_template_portable_equals_finish),
        cmocka_unit_test(test_template_cache_equals_finish),
        cmocka_unit_test(test_template_errors),
        cmocka_unit_test(test_patch_equals_recompute),
        cmocka_unit_test(test_patch_keeps_damage_and_errors),
        cmocka_unit_test(test_copy_equals_recompute),
        cmocka_unit_test(test_copy_keeps_damage_and_errors),
        cmocka_unit_test(test_crc_helpers),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
