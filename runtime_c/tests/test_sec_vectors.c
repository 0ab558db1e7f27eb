/* Conformance: SIGNED and ENCRYPTED frames built by ub_sec from the inputs of
 * tests/vectors/signed_frames.json match the independent Python reference (the KDF rebuilt with
 * hashlib BLAKE2b, PyNaCl SipHash-2-4 and XChaCha20-Poly1305) byte for byte; each key's subkeys are
 * those of the reference; they parse and verify back to the inputs; the decoder
 * delivers them whatever the chunking; and every "reject" frame is refused for the named reason. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "ub/ub_frame.h"
#include "ub/ub_sec.h"
#include "ub_signed_vectors.h" /* generated from tests/vectors/signed_frames.json (sec.cmake) */

static ub_sec_t g_sec;

static int setup(void **state) {
    (void)state;
    if (ub_sec_init(&g_sec, NULL) != UB_OK) return -1;
    for (size_t i = 0; i < SIGNED_KEY_COUNT; i++)
        if (ub_sec_add_key(&g_sec, signed_keys[i].id, signed_keys[i].key) != UB_OK) return -1;
    return 0;
}

static ub_frame_header_t vector_header(const signed_vector_t *v) {
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memcpy(h.dir_id, v->dir_id, sizeof h.dir_id);
    memcpy(h.dest_id, v->dest_id, sizeof h.dest_id);
    memcpy(h.src_id, v->src_id, sizeof h.src_id);
    h.flags = v->flags;
    h.admin = v->admin;
    h.hop_limit = v->hop_limit;
    h.payload_size = (uint16_t)v->payload_len;
    h.seq = (uint32_t)v->counter;
    h.counter_hi = (uint16_t)(v->counter >> 32);
    h.key_id = v->key_id;
    h.fingerprint = v->fingerprint;
    return h;
}

static void test_subkeys_match_the_reference_kdf(void **state) {
    (void)state;
    for (size_t i = 0; i < SIGNED_KEY_COUNT; i++) {
        const ub_sec_key_t *k = NULL;
        for (size_t j = 0; j < UB_MAX_KEYS; j++)
            if (g_sec.keys[j].id == signed_keys[i].id) k = &g_sec.keys[j];
        assert_non_null(k);
        assert_memory_equal(k->sig_key, signed_keys[i].sig, sizeof signed_keys[i].sig);
        assert_memory_equal(k->aead_key, signed_keys[i].aead, sizeof signed_keys[i].aead);
        /* key separation: neither subkey is (a prefix of) the key file's key, nor of each other */
        assert_memory_not_equal(k->sig_key, signed_keys[i].key, UB_SEC_SIG_KEY_LEN);
        assert_memory_not_equal(k->aead_key, signed_keys[i].key, UB_SEC_KEY_LEN);
        assert_memory_not_equal(k->sig_key, k->aead_key, UB_SEC_SIG_KEY_LEN);
    }
}

static void test_protect_matches_reference_byte_for_byte(void **state) {
    (void)state;
    assert_true(SIGNED_VECTOR_COUNT >= 12);
    for (size_t i = 0; i < SIGNED_VECTOR_COUNT; i++) {
        const signed_vector_t *v = &signed_vectors[i];
        uint8_t frame[UB_FRAME_MAX + 8];
        memset(frame, 0xEE, sizeof frame);
        ub_frame_header_t h = vector_header(v);
        print_message("vector %s (%zu bytes)\n", v->name, v->frame_len);
        /* from a separate plaintext buffer ... */
        assert_int_equal(ub_sec_protect(&g_sec, &h, v->payload, frame, UB_FRAME_MAX), (int)v->frame_len);
        assert_memory_equal(frame, v->frame, v->frame_len);
        assert_int_equal(frame[v->frame_len], 0xEE); /* nothing past the frame */
        /* ... and in place, the payload already where pack writes it */
        memset(frame, 0xEE, sizeof frame);
        memcpy(frame + UB_FRAME_HEADER_LEN, v->payload, v->payload_len);
        assert_int_equal(ub_sec_protect(&g_sec, &h, frame + UB_FRAME_HEADER_LEN, frame, UB_FRAME_MAX),
                         (int)v->frame_len);
        assert_memory_equal(frame, v->frame, v->frame_len);
    }
}

static void test_parse_and_verify_recover_the_inputs(void **state) {
    (void)state;
    for (size_t i = 0; i < SIGNED_VECTOR_COUNT; i++) {
        const signed_vector_t *v = &signed_vectors[i];
        ub_frame_header_t h;
        assert_int_equal(ub_frame_parse(v->frame, v->frame_len, &h), UB_OK);
        assert_int_equal(h.flags, v->flags);
        assert_int_equal(h.key_id, v->key_id);
        assert_true(ub_frame_counter(&h) == v->counter);
        assert_int_equal(h.payload_size, v->payload_len);
        assert_int_equal(h.hop_limit, v->hop_limit);
        uint8_t plain[UB_MAX_PAYLOAD];
        memset(plain, 0, sizeof plain);
        assert_int_equal(ub_sec_verify(&g_sec, &h, v->frame, v->frame_len, plain, sizeof plain), UB_OK);
        const uint8_t *got = v->flags == UB_FRAME_FLAG_ENCRYPTED ? plain : v->frame + UB_FRAME_HEADER_LEN;
        assert_memory_equal(got, v->payload, v->payload_len);
        if (v->flags == UB_FRAME_FLAG_ENCRYPTED && v->payload_len > 0) /* the wire does not show the plaintext */
            assert_memory_not_equal(v->frame + UB_FRAME_HEADER_LEN, v->payload, v->payload_len);
    }
}

/* signed_hop_1 is signed_data_88 after forwarders: only hop limit and checks differ, the tag is the same. */
static void test_tag_does_not_cover_the_hop_limit(void **state) {
    (void)state;
    const signed_vector_t *a = NULL, *b = NULL;
    for (size_t i = 0; i < SIGNED_VECTOR_COUNT; i++) {
        if (strcmp(signed_vectors[i].name, "signed_data_88") == 0) a = &signed_vectors[i];
        if (strcmp(signed_vectors[i].name, "signed_hop_1") == 0) b = &signed_vectors[i];
    }
    assert_non_null(a);
    assert_non_null(b);
    assert_int_equal(a->frame_len, b->frame_len);
    size_t tag_off = a->frame_len - UB_FRAME_SIG_TAG_LEN;
    assert_memory_equal(a->frame + tag_off, b->frame + tag_off, UB_FRAME_SIG_TAG_LEN);
    uint8_t f[UB_FRAME_MAX];
    memcpy(f, a->frame, a->frame_len);
    assert_int_equal(ub_frame_set_hop_limit(f, a->frame_len, 1), UB_OK); /* what a forwarder does, keyless */
    assert_memory_equal(f, b->frame, b->frame_len);
}

static void test_decoder_delivers_flagged_frames_in_any_chunking(void **state) {
    (void)state;
    static uint8_t stream[SIGNED_VECTOR_COUNT * UB_FRAME_MAX];
    size_t len = 0;
    for (size_t i = 0; i < SIGNED_VECTOR_COUNT; i++) {
        memcpy(stream + len, signed_vectors[i].frame, signed_vectors[i].frame_len);
        len += signed_vectors[i].frame_len;
    }
    for (size_t chunk = 1; chunk <= 130; chunk += 7) {
        ub_decoder_t dec;
        ub_decoder_init(&dec);
        for (size_t off = 0; off < len; off += chunk)
            (void)ub_decoder_feed(&dec, stream + off, len - off < chunk ? len - off : chunk, NULL, NULL);
        assert_int_equal(dec.stats.frames_ok, SIGNED_VECTOR_COUNT);
        assert_int_equal(dec.stats.bytes_ok, len);
        assert_int_equal(dec.stats.garbage_bytes, 0);
    }
}

static void test_rejects_are_refused_for_the_named_reason(void **state) {
    (void)state;
    assert_true(SIGNED_REJECT_COUNT >= 5);
    for (size_t i = 0; i < SIGNED_REJECT_COUNT; i++) {
        const signed_reject_t *r = &signed_rejects[i];
        ub_frame_header_t h;
        ub_rx_reason_t why = UB_RX_REASON_COUNT;
        int rc = ub_frame_parse_reason(r->frame, r->frame_len, &h, &why);
        const char *got;
        if (rc < 0) {
            got = ub_rx_reason_name(why);
        } else {
            uint8_t plain[UB_MAX_PAYLOAD];
            int v = ub_sec_verify(&g_sec, &h, r->frame, r->frame_len, plain, sizeof plain);
            got = v == UB_ERR_AUTH ? "bad_tag" : v == UB_ERR_NOTFOUND ? "unknown_key" : v == UB_OK ? "accepted" : "?";
        }
        print_message("reject %s: %s\n", r->name, got);
        assert_string_equal(got, r->expect);
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_subkeys_match_the_reference_kdf),
        cmocka_unit_test(test_protect_matches_reference_byte_for_byte),
        cmocka_unit_test(test_parse_and_verify_recover_the_inputs),
        cmocka_unit_test(test_tag_does_not_cover_the_hop_limit),
        cmocka_unit_test(test_decoder_delivers_flagged_frames_in_any_chunking),
        cmocka_unit_test(test_rejects_are_refused_for_the_named_reason),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
