/* Conformance: frames built from tests/vectors/frames.json inputs match the independent
 * Python reference byte for byte, parse back to the same inputs, and the decoder yields
 * exactly those frames whatever the chunking. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "ub/ub_frame.h"
#include "ub_frame_vectors.h" /* generated from tests/vectors/frames.json (frame.cmake) */

static ub_frame_header_t vector_header(const frame_vector_t *v) {
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memcpy(h.dir_id, v->dir_id, sizeof h.dir_id);
    memcpy(h.dest_id, v->dest_id, sizeof h.dest_id);
    memcpy(h.src_id, v->src_id, sizeof h.src_id);
    h.admin = v->admin;
    h.hop_limit = v->hop_limit;
    h.payload_size = (uint16_t)v->payload_len;
    h.seq = v->seq;
    h.fingerprint = v->fingerprint;
    return h;
}

/* Lays vector `v`'s payload into `frame` (UB_FRAME_MAX bytes, the rest 0xEE so that a byte the builder
 * forgets shows) and returns its header, ready for a builder to finish. */
static ub_frame_header_t vector_frame(const frame_vector_t *v, uint8_t *frame) {
    memset(frame, 0xEE, UB_FRAME_MAX);
    memcpy(frame + UB_FRAME_HEADER_LEN, v->payload, v->payload_len);
    return vector_header(v);
}

static void assert_header_matches(const ub_frame_header_t *got, const frame_vector_t *v) {
    assert_int_equal(got->msg_type, UB_MSG_TYPE_PUBSUB);
    assert_memory_equal(got->dir_id, v->dir_id, UB_DIR_ID_LEN);
    assert_memory_equal(got->dest_id, v->dest_id, UB_ENTITY_ID_LEN);
    assert_memory_equal(got->src_id, v->src_id, UB_ENTITY_ID_LEN);
    assert_int_equal(got->admin, v->admin);
    assert_int_equal(got->hop_limit, v->hop_limit);
    assert_int_equal(got->payload_size, v->payload_len);
    assert_int_equal(got->seq, v->seq);
    assert_int_equal(got->fingerprint, v->fingerprint);
}

static void test_crc_check_value_from_vectors(void **state) {
    (void)state;
    assert_int_equal(ub_crc32c(crc32c_check_input, CRC32C_CHECK_LEN), CRC32C_CHECK_VALUE);
}

static void test_build_matches_reference_byte_for_byte(void **state) {
    (void)state;
    assert_true(FRAME_VECTOR_COUNT >= 10);
    for (size_t i = 0; i < FRAME_VECTOR_COUNT; i++) {
        const frame_vector_t *v = &frame_vectors[i];
        uint8_t frame[UB_FRAME_MAX];
        ub_frame_header_t h = vector_frame(v, frame);
        h.msg_type = 0x1234; /* ignored by finish: it always writes UB_MSG_TYPE_PUBSUB */
        print_message("vector %s (%zu bytes)\n", v->name, v->frame_len);
        assert_int_equal(ub_frame_finish(frame, sizeof frame, &h), (int)v->frame_len);
        assert_memory_equal(frame, v->frame, v->frame_len);
        assert_int_equal(frame[UB_FRAME_OFF_HDR_CHECK], v->hdr_check);
        assert_int_equal(frame[UB_FRAME_OFF_MSG_CRC] | frame[UB_FRAME_OFF_MSG_CRC + 1] << 8 |
                             frame[UB_FRAME_OFF_MSG_CRC + 2] << 16 | (uint32_t)frame[UB_FRAME_OFF_MSG_CRC + 3] << 24,
                         v->msg_crc);
        if (v->frame_len < sizeof frame) assert_int_equal(frame[v->frame_len], 0xEE); /* nothing past the frame */
    }
}

static void test_parse_recovers_inputs(void **state) {
    (void)state;
    for (size_t i = 0; i < FRAME_VECTOR_COUNT; i++) {
        const frame_vector_t *v = &frame_vectors[i];
        ub_frame_header_t h;
        assert_int_equal(ub_frame_parse(v->frame, v->frame_len, &h), UB_OK);
        assert_header_matches(&h, v);
    }
}

typedef struct stream_check {
    const size_t *order; /* vector index of each frame in the stream */
    size_t n_frames;
    size_t next;
    int mismatches;
} stream_check_t;

static void check_next_frame(void *user, const ub_frame_header_t *h, const uint8_t *frame, size_t frame_len) {
    stream_check_t *sc = user;
    if (sc->next >= sc->n_frames) {
        sc->mismatches++;
        return;
    }
    const frame_vector_t *v = &frame_vectors[sc->order[sc->next++]];
    if (frame_len != v->frame_len || memcmp(frame, v->frame, frame_len) != 0 || h->seq != v->seq ||
        h->payload_size != v->payload_len || memcmp(h->src_id, v->src_id, UB_ENTITY_ID_LEN) != 0)
        sc->mismatches++;
}

/* Feeds `stream` in chunks of `chunk` bytes and checks the decoder delivered `order` exactly. */
static void feed_in_chunks(const uint8_t *stream, size_t len, size_t chunk, const size_t *order, size_t n_frames) {
    ub_decoder_t dec;
    ub_decoder_init(&dec);
    stream_check_t sc = {order, n_frames, 0, 0};
    size_t delivered = 0;
    for (size_t off = 0; off < len; off += chunk) {
        size_t n = len - off < chunk ? len - off : chunk;
        delivered += ub_decoder_feed(&dec, stream + off, n, check_next_frame, &sc);
    }
    if (sc.mismatches != 0 || sc.next != n_frames || delivered != n_frames) {
        print_error("chunk %zu: delivered %zu of %zu, %d mismatches\n", chunk, sc.next, n_frames, sc.mismatches);
        fail();
    }
    assert_int_equal(dec.stats.frames_ok, n_frames);
    assert_int_equal(dec.stats.bytes_ok, len);
    assert_int_equal(dec.stats.garbage_bytes, 0);
    for (int r = 0; r < UB_RX_REASON_COUNT; r++) assert_int_equal(dec.stats.rejected[r], 0);
    assert_int_equal(ub_decoder_pending(&dec), 0);
}

static void test_decoder_each_vector_every_chunk_size(void **state) {
    (void)state;
    for (size_t i = 0; i < FRAME_VECTOR_COUNT; i++) {
        const frame_vector_t *v = &frame_vectors[i];
        for (size_t chunk = 1; chunk <= v->frame_len; chunk++) feed_in_chunks(v->frame, v->frame_len, chunk, &i, 1);
    }
}

/* All vectors back to back, twice (so frames start at every kind of chunk offset),
 * in chunks of every size from 1 to the longest frame. */
static void test_decoder_all_vectors_back_to_back(void **state) {
    (void)state;
    uint8_t *stream = malloc(2 * FRAME_VECTOR_COUNT * UB_FRAME_MAX);
    assert_non_null(stream);
    size_t order[2 * FRAME_VECTOR_COUNT];
    size_t len = 0, longest = 0, n = 0;
    for (size_t round = 0; round < 2; round++) {
        for (size_t i = 0; i < FRAME_VECTOR_COUNT; i++) {
            const frame_vector_t *v = &frame_vectors[i];
            memcpy(stream + len, v->frame, v->frame_len);
            len += v->frame_len;
            order[n++] = i;
            if (v->frame_len > longest) longest = v->frame_len;
        }
    }
    for (size_t chunk = 1; chunk <= longest; chunk++) feed_in_chunks(stream, len, chunk, order, n);
    feed_in_chunks(stream, len, len, order, n);
    free(stream);
}

/* The fast paths reproduce every vector: a row's header template (ub_frame_tpl_finish) writes the vector's
 * bytes, and patching the hop limit by CRC linearity (ub_frame_patch_hop_limit) gives the frame built with
 * that hop limit, for every hop limit 1..255. */
static void test_fast_paths_reproduce_vectors(void **state) {
    (void)state;
    for (size_t i = 0; i < FRAME_VECTOR_COUNT; i++) {
        const frame_vector_t *v = &frame_vectors[i];
        uint8_t frame[UB_FRAME_MAX];
        ub_frame_header_t h = vector_frame(v, frame);
        ub_frame_tpl_t t;
        assert_int_equal(ub_frame_tpl_init(&t, &h), UB_OK);
        assert_int_equal(ub_frame_tpl_finish(&t, frame, sizeof frame, (uint16_t)v->payload_len, v->seq), (int)v->frame_len);
        assert_memory_equal(frame, v->frame, v->frame_len);
        for (unsigned hop = 1; hop <= 255; hop++) {
            uint8_t want[UB_FRAME_MAX], got[UB_FRAME_MAX];
            memcpy(want, v->frame, v->frame_len);
            memcpy(got, v->frame, v->frame_len);
            h.hop_limit = (uint8_t)hop;
            assert_int_equal(ub_frame_finish(want, sizeof want, &h), (int)v->frame_len);
            assert_int_equal(ub_frame_patch_hop_limit(got, v->frame_len, (uint8_t)hop), UB_OK);
            assert_memory_equal(got, want, v->frame_len);
        }
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_crc_check_value_from_vectors),
        cmocka_unit_test(test_build_matches_reference_byte_for_byte),
        cmocka_unit_test(test_fast_paths_reproduce_vectors),
        cmocka_unit_test(test_parse_recovers_inputs),
        cmocka_unit_test(test_decoder_each_vector_every_chunk_size),
        cmocka_unit_test(test_decoder_all_vectors_back_to_back),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
