/*
 * ub_sec.h called the wrong way on purpose (issue #29 item 6): NULL arguments, keys added before init or
 * with id 0, removing or selecting a key not held, counters before ub_sec_start(), protect with a payload
 * above the limit, verify of an unflagged frame, a length that is not the frame's and a plaintext buffer too
 * small (nothing written), the random fill's edge cases. test_sec.c covers the working paths.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "ub/ub_frame.h"
#include "ub/ub_sec.h"

static ub_sec_t g_sec;

static void test_keyring_contracts(void **state) {
    (void)state;
    uint8_t key[UB_SEC_KEY_LEN];
    memset(key, 0x5A, sizeof key);
    memset(&g_sec, 0, sizeof g_sec);
    assert_int_equal(ub_sec_add_key(&g_sec, 1, key), UB_ERR_INVAL); /* before init */
    assert_int_equal(ub_sec_init(NULL, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_sec_init(&g_sec, NULL), UB_OK);
    assert_int_equal(ub_sec_add_key(NULL, 1, key), UB_ERR_INVAL);
    assert_int_equal(ub_sec_add_key(&g_sec, 1, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_sec_add_key(&g_sec, 0, key), UB_ERR_INVAL); /* id 0: "no key" */
    assert_int_equal(ub_sec_add_key(&g_sec, 1, key), UB_OK);
    assert_int_equal(ub_sec_remove_key(NULL, 1), UB_ERR_INVAL);
    assert_int_equal(ub_sec_remove_key(&g_sec, 0), UB_ERR_INVAL);
    assert_int_equal(ub_sec_set_tx_key(NULL, 1), UB_ERR_INVAL);
    assert_int_equal(ub_sec_set_tx_key(&g_sec, 9), UB_ERR_NOTFOUND);
    assert_int_equal(ub_sec_set_tx_key(&g_sec, 0), UB_OK); /* sending unprotected */
    assert_int_equal(ub_sec_tx_key(&g_sec), 0);
    assert_int_equal(ub_sec_set_tx_key(&g_sec, 1), UB_OK);
    assert_int_equal(ub_sec_tx_key(&g_sec), 1);
    assert_int_equal(ub_sec_tx_key(NULL), 0);
    assert_false(ub_sec_has_key(NULL, 1));
    assert_true(ub_sec_has_key(&g_sec, 1));
    assert_int_equal(ub_sec_key_ids(NULL, NULL, 0), 0);
    uint8_t ids[1];
    assert_int_equal(ub_sec_key_ids(&g_sec, NULL, 0), 1); /* counted without a place to put them */
    assert_int_equal(ub_sec_key_ids(&g_sec, ids, 1), 1);
    assert_int_equal(ids[0], 1);
    uint64_t c = 0;
    assert_int_equal(ub_sec_next_counter(&g_sec, &c), UB_ERR_INVAL); /* not started */
    assert_int_equal(ub_sec_start(NULL, 0, 0), UB_ERR_INVAL);
    assert_int_equal(ub_sec_start(&g_sec, 0, 0), UB_OK);
    assert_int_equal(ub_sec_next_counter(&g_sec, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_sec_next_counter(NULL, &c), UB_ERR_INVAL);
    assert_int_equal(ub_sec_next_counter(&g_sec, &c), UB_OK);
    assert_true(c >= 1); /* 0 is never sent */
    assert_null(ub_sec_stats(NULL));
    assert_int_equal(ub_sec_keygen(NULL), UB_ERR_INVAL);
    uint8_t r[8] = {0};
    ub_sec_random(&g_sec, NULL, 8);
    ub_sec_random(&g_sec, r, 0);
    ub_sec_random(NULL, r, sizeof r); /* libsodium's generator */
}

static void test_protect_and_verify_refusals(void **state) {
    (void)state;
    uint8_t key[UB_SEC_KEY_LEN];
    memset(key, 0x5A, sizeof key);
    assert_int_equal(ub_sec_init(&g_sec, NULL), UB_OK);
    assert_int_equal(ub_sec_add_key(&g_sec, 1, key), UB_OK);
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    h.flags = UB_FRAME_FLAG_ENCRYPTED;
    h.key_id = 1;
    h.hop_limit = 3;
    h.seq = 77;
    h.payload_size = 6;
    uint8_t payload[6] = {1, 2, 3, 4, 5, 6}, frame[UB_FRAME_MAX], plain[16];
    int n = ub_sec_protect(&g_sec, &h, payload, frame, sizeof frame);
    assert_true(n > 0);
    assert_int_equal(ub_sec_protect(NULL, &h, payload, frame, sizeof frame), UB_ERR_INVAL);
    assert_int_equal(ub_sec_protect(&g_sec, NULL, payload, frame, sizeof frame), UB_ERR_INVAL);
    assert_int_equal(ub_sec_protect(&g_sec, &h, payload, NULL, sizeof frame), UB_ERR_INVAL);
    assert_int_equal(ub_sec_protect(&g_sec, &h, NULL, frame, sizeof frame), UB_ERR_INVAL);
    ub_frame_header_t big = h;
    big.payload_size = UB_MAX_PAYLOAD + 1;
    assert_int_equal(ub_sec_protect(&g_sec, &big, payload, frame, sizeof frame), UB_ERR_RANGE);

    ub_frame_header_t got;
    assert_int_equal(ub_frame_parse(frame, (size_t)n, &got), UB_OK);
    assert_int_equal(ub_sec_verify(&g_sec, &got, frame, (size_t)n, plain, sizeof plain), UB_OK);
    assert_memory_equal(plain, payload, sizeof payload);
    memset(plain, 0xEE, sizeof plain);
    assert_int_equal(ub_sec_verify(&g_sec, &got, frame, (size_t)n, plain, 5), UB_ERR_INVAL); /* too small */
    assert_int_equal(ub_sec_verify(&g_sec, &got, frame, (size_t)n, NULL, 0), UB_ERR_INVAL);
    assert_int_equal(plain[0], 0xEE); /* nothing written */
    assert_int_equal(ub_sec_verify(&g_sec, &got, frame, (size_t)n - 1, plain, sizeof plain), UB_ERR_INVAL);
    assert_int_equal(ub_sec_verify(NULL, &got, frame, (size_t)n, plain, sizeof plain), UB_ERR_INVAL);
    assert_int_equal(ub_sec_verify(&g_sec, NULL, frame, (size_t)n, plain, sizeof plain), UB_ERR_INVAL);
    assert_int_equal(ub_sec_verify(&g_sec, &got, NULL, (size_t)n, plain, sizeof plain), UB_ERR_INVAL);
    ub_frame_header_t unflagged = got;
    unflagged.flags = 0;
    assert_int_equal(ub_sec_verify(&g_sec, &unflagged, frame, (size_t)n, plain, sizeof plain), UB_ERR_INVAL);
    uint64_t before = ub_sec_stats(&g_sec)->auth_failures;
    frame[UB_FRAME_HEADER_LEN] ^= 1; /* the ciphertext changed: refused, counted */
    assert_int_equal(ub_sec_verify(&g_sec, &got, frame, (size_t)n, plain, sizeof plain), UB_ERR_AUTH);
    assert_int_equal(ub_sec_stats(&g_sec)->auth_failures, before + 1);
    assert_int_equal(ub_sec_remove_key(&g_sec, 1), UB_OK);
    assert_int_equal(ub_sec_verify(&g_sec, &got, frame, (size_t)n, plain, sizeof plain), UB_ERR_NOTFOUND);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_keyring_contracts),
        cmocka_unit_test(test_protect_and_verify_refusals),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
