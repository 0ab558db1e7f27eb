/*
 * ub_sec on its own: sign / verify / encrypt round trips, tampering of every byte of a protected
 * frame, unknown keys, the keyring's rules, the counter with its persisted reservation (fail
 * closed, never reused, 48-bit limit), the wall-clock epoch, and the replay windows.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "ub/ub_frame.h"
#include "ub/ub_sec.h"
#include "ub/ub_wire.h"
#include "support/ub_test_store.h"

static const uint8_t KEY_A[UB_SEC_KEY_LEN] = {0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88, 0x99, 0xaa, 0xbb,
                                              0xcc, 0xdd, 0xee, 0xff, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07,
                                              0x08, 0x09, 0x0a, 0x0b, 0x0c, 0x0d, 0x0e, 0x0f, 0x10, 0x12};

static ub_frame_header_t sample_header(uint8_t flags, uint8_t key_id, uint64_t counter, uint16_t payload_size) {
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memcpy(h.dir_id, "gpsOut\0\0gpsOut\0\0", UB_DIR_ID_LEN);
    memcpy(h.dest_id, "gcs1\0\0\0\0\0\0\0\0", UB_ENTITY_ID_LEN);
    memcpy(h.src_id, "rmax1ob1\0\0\0\0", UB_ENTITY_ID_LEN);
    h.flags = flags;
    h.key_id = key_id;
    h.admin = UB_ADMIN_DATA;
    h.hop_limit = 8;
    h.payload_size = payload_size;
    h.seq = (uint32_t)counter;
    h.counter_hi = (uint16_t)(counter >> 32);
    h.fingerprint = 0xC0FFEE;
    return h;
}

static void fill(uint8_t *p, size_t n, uint8_t seed) {
    for (size_t i = 0; i < n; i++) p[i] = (uint8_t)(seed + 31u * i);
}

static int new_sec(ub_sec_t *sec) {
    if (ub_sec_init(sec, NULL) != UB_OK || ub_sec_add_key(sec, 1, KEY_A) != UB_OK) return -1;
    return 0;
}

static void test_sign_verify_and_encrypt_round_trip(void **state) {
    (void)state;
    static ub_sec_t sec;
    assert_int_equal(new_sec(&sec), 0);
    uint8_t payload[48], frame[UB_FRAME_MAX], plain[UB_MAX_PAYLOAD];
    fill(payload, sizeof payload, 3);
    for (int mode = 0; mode < 2; mode++) {
        uint8_t flags = mode == 0 ? UB_FRAME_FLAG_SIGNED : UB_FRAME_FLAG_ENCRYPTED;
        ub_frame_header_t h = sample_header(flags, 1, UINT64_C(0x123456789A), sizeof payload);
        int n = ub_sec_protect(&sec, &h, payload, frame, sizeof frame);
        assert_int_equal(n, 64 + 48 + (int)ub_frame_trailer_len(flags));
        ub_frame_header_t got;
        assert_int_equal(ub_frame_parse(frame, (size_t)n, &got), UB_OK);
        assert_int_equal(got.flags, flags);
        assert_int_equal(got.key_id, 1);
        assert_true(ub_frame_counter(&got) == UINT64_C(0x123456789A));
        memset(plain, 0, sizeof plain);
        assert_int_equal(ub_sec_verify(&sec, &got, frame, (size_t)n, plain, sizeof plain), UB_OK);
        if (flags == UB_FRAME_FLAG_ENCRYPTED) {
            assert_memory_equal(plain, payload, sizeof payload);
            assert_memory_not_equal(frame + 64, payload, sizeof payload); /* the wire carries ciphertext */
        } else {
            assert_memory_equal(frame + 64, payload, sizeof payload);
        }
    }
    const ub_sec_stats_t *s = ub_sec_stats(&sec);
    assert_int_equal(s->signed_out, 1);
    assert_int_equal(s->encrypted_out, 1);
    assert_int_equal(s->verified_in, 1);
    assert_int_equal(s->decrypted_in, 1);
    /* protect refuses what it cannot do */
    ub_frame_header_t h = sample_header(0, 1, 5, 4);
    assert_int_equal(ub_sec_protect(&sec, &h, payload, frame, sizeof frame), UB_ERR_INVAL); /* no flag */
    h = sample_header(UB_FRAME_FLAG_SIGNED, 9, 5, 4);
    assert_int_equal(ub_sec_protect(&sec, &h, payload, frame, sizeof frame), UB_ERR_NOTFOUND); /* no key 9 */
    h = sample_header(UB_FRAME_FLAG_SIGNED, 1, 5, 4);
    assert_int_equal(ub_sec_protect(&sec, &h, payload, frame, 64 + 4 + 10), UB_ERR_NOSPACE);
}

/* What a receiver makes of `f`: parse (CRC) first, then the tag. Returns "ok", a decoder reason, or a tag verdict. */
static const char *judge(ub_sec_t *sec, const uint8_t *f, size_t len) {
    ub_frame_header_t h;
    ub_rx_reason_t why;
    if (ub_frame_parse_reason(f, len, &h, &why) != UB_OK) return ub_rx_reason_name(why);
    uint8_t plain[UB_MAX_PAYLOAD];
    int rc = ub_sec_verify(sec, &h, f, len, plain, sizeof plain);
    return rc == UB_OK ? "ok" : rc == UB_ERR_AUTH ? "bad_tag" : rc == UB_ERR_NOTFOUND ? "unknown_key" : "?";
}

/* Flip each bit pattern of every byte. Without fixing the CRC (line noise) nothing reaches the tag
 * check; with the CRC recomputed (a forger) only the hop limit, which the tag does not cover by
 * design, and the checks themselves (recomputed back) leave a frame that verifies. */
static void tamper_every_byte(uint8_t flags) {
    static ub_sec_t sec;
    assert_int_equal(new_sec(&sec), 0);
    uint8_t payload[24], good[UB_FRAME_MAX], f[UB_FRAME_MAX];
    fill(payload, sizeof payload, 9);
    ub_frame_header_t h = sample_header(flags, 1, UINT64_C(0x00003A5BC0DE0001), sizeof payload);
    int n = ub_sec_protect(&sec, &h, payload, good, sizeof good);
    assert_true(n > 0);
    size_t len = (size_t)n;
    static const uint8_t patterns[] = {0x01, 0x80, 0xFF};
    size_t forged = 0, noise_caught = 0;
    for (size_t i = 0; i < len; i++) {
        for (size_t p = 0; p < sizeof patterns; p++) {
            memcpy(f, good, len);
            f[i] ^= patterns[p];
            /* line noise: the CRC still belongs to the original bytes */
            const char *noise = judge(&sec, f, len);
            assert_string_not_equal(noise, "ok");
            assert_string_not_equal(noise, "bad_tag"); /* noise is never counted as a forgery */
            noise_caught++;
            /* a forger recomputes both checks (only possible while msg_size still matches) */
            if (ub_frame_set_hop_limit(f, len, f[UB_FRAME_OFF_HOP_LIMIT]) != UB_OK) continue;
            const char *v = judge(&sec, f, len);
            bool checks = i == UB_FRAME_OFF_HDR_CHECK || (i >= UB_FRAME_OFF_MSG_CRC && i < UB_FRAME_OFF_MSG_CRC + 4);
            if (checks) {
                assert_memory_equal(f, good, len); /* recomputing restored the very same frame */
            } else if (i == UB_FRAME_OFF_HOP_LIMIT) {
                assert_string_equal(v, "ok"); /* not under the tag: forwarders rewrite it without the key */
            } else {
                if (strcmp(v, "ok") == 0) print_error("byte %zu ^ 0x%02x accepted\n", i, patterns[p]);
                assert_string_not_equal(v, "ok");
                forged++;
            }
        }
    }
    assert_true(forged > 3 * (len - 8) - 30); /* nearly every byte of nearly every pattern was a forgery attempt */
    assert_int_equal(noise_caught, 3 * len);
}

static void test_tamper_every_byte_signed(void **state) {
    (void)state;
    tamper_every_byte(UB_FRAME_FLAG_SIGNED);
}

static void test_tamper_every_byte_encrypted(void **state) {
    (void)state;
    tamper_every_byte(UB_FRAME_FLAG_ENCRYPTED);
}

static void test_unknown_key_and_wrong_key(void **state) {
    (void)state;
    static ub_sec_t a, b, c;
    assert_int_equal(new_sec(&a), 0);
    assert_int_equal(ub_sec_init(&b, NULL), UB_OK);
    uint8_t other[UB_SEC_KEY_LEN];
    memcpy(other, KEY_A, sizeof other);
    other[31] ^= 1; /* one bit of key difference */
    assert_int_equal(ub_sec_add_key(&b, 1, other), UB_OK);
    assert_int_equal(ub_sec_init(&c, NULL), UB_OK);
    assert_int_equal(ub_sec_add_key(&c, 2, KEY_A), UB_OK); /* the right key under another id */
    uint8_t payload[16] = {1, 2, 3}, frame[UB_FRAME_MAX];
    for (int mode = 0; mode < 2; mode++) {
        uint8_t flags = mode ? UB_FRAME_FLAG_ENCRYPTED : UB_FRAME_FLAG_SIGNED;
        ub_frame_header_t h = sample_header(flags, 1, 77, sizeof payload);
        int n = ub_sec_protect(&a, &h, payload, frame, sizeof frame);
        assert_true(n > 0);
        assert_string_equal(judge(&b, frame, (size_t)n), "bad_tag");
        assert_string_equal(judge(&c, frame, (size_t)n), "unknown_key");
        assert_string_equal(judge(&a, frame, (size_t)n), "ok");
    }
    assert_int_equal(ub_sec_stats(&b)->auth_failures, 2);
    assert_int_equal(ub_sec_stats(&c)->unknown_keys, 2);
}

static void test_keyring_rules(void **state) {
    (void)state;
    static ub_sec_t sec;
    assert_int_equal(ub_sec_init(&sec, NULL), UB_OK);
    assert_int_equal(ub_sec_add_key(&sec, 0, KEY_A), UB_ERR_INVAL);
    for (int i = 1; i <= UB_MAX_KEYS; i++) assert_int_equal(ub_sec_add_key(&sec, (uint8_t)(i * 10), KEY_A), UB_OK);
    assert_int_equal(ub_sec_add_key(&sec, 200, KEY_A), UB_ERR_FULL);
    assert_int_equal(ub_sec_add_key(&sec, 10, KEY_A), UB_ERR_EXISTS);
    assert_int_equal(ub_sec_set_tx_key(&sec, 99), UB_ERR_NOTFOUND);
    assert_int_equal(ub_sec_set_tx_key(&sec, 20), UB_OK);
    assert_int_equal(ub_sec_tx_key(&sec), 20);
    assert_int_equal(ub_sec_remove_key(&sec, 20), UB_ERR_INVAL); /* the signing key stays until another signs */
    assert_int_equal(ub_sec_set_tx_key(&sec, 10), UB_OK);
    assert_int_equal(ub_sec_remove_key(&sec, 20), UB_OK);
    assert_false(ub_sec_has_key(&sec, 20));
    assert_int_equal(ub_sec_remove_key(&sec, 20), UB_ERR_NOTFOUND);
    uint8_t ids[8];
    assert_int_equal(ub_sec_key_ids(&sec, ids, sizeof ids), UB_MAX_KEYS - 1);
    assert_int_equal(ub_sec_add_key(&sec, 200, KEY_A), UB_OK); /* the freed slot is reused */
    /* a removed key's material is gone from the context */
    for (size_t i = 0; i < UB_MAX_KEYS; i++)
        if (sec.keys[i].id == 0) {
            uint8_t zero[UB_SEC_KEY_LEN] = {0};
            assert_memory_equal(sec.keys[i].sig_key, zero, UB_SEC_SIG_KEY_LEN);
            assert_memory_equal(sec.keys[i].aead_key, zero, UB_SEC_KEY_LEN);
        }
}


static void test_counter_reservation_fails_closed_and_never_reuses(void **state) {
    (void)state;
    static ub_sec_t sec;
    store_t store = {0, 0, 0};
    ub_sec_options_t o = {.reserve = store_reserve, .reserve_user = &store, .reserve_block = 8};
    assert_int_equal(ub_sec_init(&sec, &o), UB_OK);
    uint64_t c = 0;
    assert_int_equal(ub_sec_next_counter(&sec, &c), UB_ERR_INVAL); /* not started */
    assert_int_equal(ub_sec_start(&sec, 1000, 500), UB_OK);       /* the mark beats a clock that went back */
    uint64_t last = 0;
    for (int i = 0; i < 20; i++) {
        assert_int_equal(ub_sec_next_counter(&sec, &c), UB_OK);
        assert_true(c > last || i == 0);
        assert_true(c < store.mark); /* every counter handed out was covered by a stored mark first */
        last = c;
    }
    assert_true(last == 1019);
    assert_int_equal(store.calls, 3); /* 1000, 1008, 1016 */
    store.fail = 1;
    for (int i = 0; i < 4; i++) assert_int_equal(ub_sec_next_counter(&sec, &c), UB_OK); /* 1020..1023: covered */
    assert_int_equal(ub_sec_next_counter(&sec, &c), UB_ERR_IO); /* 1024 needs a new mark: refused */
    assert_int_equal(ub_sec_next_counter(&sec, &c), UB_ERR_IO);
    assert_int_equal(ub_sec_stats(&sec)->reserve_failures, 2);
    assert_int_equal(ub_sec_stats(&sec)->tx_refused, 2);
    store.fail = 0;
    assert_int_equal(ub_sec_next_counter(&sec, &c), UB_OK);
    assert_true(c == 1024); /* nothing was skipped or reused */
    /* a "restart" from the stored mark continues above everything used */
    uint64_t mark = store.mark;
    assert_int_equal(ub_sec_start(&sec, mark, 0), UB_OK);
    assert_int_equal(ub_sec_next_counter(&sec, &c), UB_OK);
    assert_true(c == mark && c > 1024);
    /* the 48-bit limit */
    assert_int_equal(ub_sec_start(&sec, UB_SEC_COUNTER_MAX, 0), UB_OK);
    assert_int_equal(ub_sec_next_counter(&sec, &c), UB_OK);
    assert_true(c == UB_SEC_COUNTER_MAX);
    assert_int_equal(ub_sec_next_counter(&sec, &c), UB_ERR_RANGE);
    assert_int_equal(ub_sec_start(&sec, UB_SEC_COUNTER_MAX + 1, 0), UB_ERR_RANGE);
}

static void test_wall_counter_epoch(void **state) {
    (void)state;
    uint64_t epoch_us = UB_SEC_EPOCH_UNIX_S * 1000000u;
    assert_true(ub_sec_wall_counter(0) == 0);
    assert_true(ub_sec_wall_counter(epoch_us) == 0);
    assert_true(ub_sec_wall_counter(epoch_us + 1000000u) == 100000u); /* 10 µs units */
    /* 2025 fits 48 bits with decades to spare (2^48 * 10 µs = 89 years) */
    uint64_t y2025 = UINT64_C(1735689600) * 1000000u;
    assert_true(ub_sec_wall_counter(y2025) < UB_SEC_COUNTER_MAX / 8);
}

static void test_replay_window(void **state) {
    (void)state;
    ub_sec_window_t w = {0, 0};
    ub_sec_window_establish(&w, 1000);
    for (uint64_t c = 900; c <= 1000; c++) assert_int_not_equal(ub_sec_window_check(&w, c), UB_SEC_WINDOW_NEW);
    assert_int_equal(ub_sec_window_check(&w, 1000), UB_SEC_WINDOW_DUPLICATE);
    assert_int_equal(ub_sec_window_check(&w, 1000 - 64), UB_SEC_WINDOW_OLD);
    assert_int_equal(ub_sec_window_check(&w, 1001), UB_SEC_WINDOW_NEW);
    ub_sec_window_accept(&w, 1010);
    /* 1001..1009 were skipped: each is accepted once, out of order */
    for (uint64_t c = 1009; c > 1000; c--) {
        assert_int_equal(ub_sec_window_check(&w, c), UB_SEC_WINDOW_NEW);
        ub_sec_window_accept(&w, c);
        assert_int_equal(ub_sec_window_check(&w, c), UB_SEC_WINDOW_DUPLICATE);
    }
    /* a jump far ahead: the old window is history, nothing behind it ever comes back */
    ub_sec_window_accept(&w, UINT64_C(1) << 40);
    assert_int_equal(ub_sec_window_check(&w, 1011), UB_SEC_WINDOW_OLD);
    assert_int_equal(ub_sec_window_check(&w, (UINT64_C(1) << 40) - 63), UB_SEC_WINDOW_NEW);
    assert_int_equal(ub_sec_window_check(&w, (UINT64_C(1) << 40) - 64), UB_SEC_WINDOW_OLD);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sign_verify_and_encrypt_round_trip),
        cmocka_unit_test(test_tamper_every_byte_signed),
        cmocka_unit_test(test_tamper_every_byte_encrypted),
        cmocka_unit_test(test_unknown_key_and_wrong_key),
        cmocka_unit_test(test_keyring_rules),
        cmocka_unit_test(test_counter_reservation_fails_closed_and_never_reuses),
        cmocka_unit_test(test_wall_counter_epoch),
        cmocka_unit_test(test_replay_window),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
