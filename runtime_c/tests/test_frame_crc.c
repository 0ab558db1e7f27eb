/* CRC-32C: the standard check value on every path, and the hardware path against the
 * table path on random lengths and alignments (seeded). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "../src/codec/ub_crc32c_impl.h"
#include "test_frame_util.h"
#include "ub/ub_frame.h"

static const uint8_t check_input[] = "123456789";
#define CHECK_VALUE 0xE3069283u

/* A textbook bit-at-a-time CRC-32C, independent of both implementations under test. */
static uint32_t crc32c_bitwise(const uint8_t *p, size_t n) {
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0; i < n; i++) {
        c ^= p[i];
        for (int b = 0; b < 8; b++) c = (c >> 1) ^ ((c & 1u) ? 0x82F63B78u : 0u);
    }
    return ~c;
}

static void test_check_value_every_path(void **state) {
    (void)state;
    assert_int_equal(ub_crc32c(check_input, 9), CHECK_VALUE);
    assert_int_equal(ub_crc32c_update_portable(0, check_input, 9), CHECK_VALUE);
    assert_int_equal(ub_crc32c_update_hw(0, check_input, 9), CHECK_VALUE);
    assert_int_equal(crc32c_bitwise(check_input, 9), CHECK_VALUE);
}

static void test_empty_input_is_identity(void **state) {
    (void)state;
    assert_int_equal(ub_crc32c(NULL, 0), 0);
    assert_int_equal(ub_crc32c_update(0x12345678u, NULL, 0), 0x12345678u);
    assert_int_equal(ub_crc32c_update_portable(0x12345678u, NULL, 0), 0x12345678u);
}

/* 32 zero bytes and 32 0xFF bytes: the published CRC-32C test patterns (RFC 3720, B.4). */
static void test_rfc3720_patterns(void **state) {
    (void)state;
    uint8_t buf[32];
    memset(buf, 0, sizeof buf);
    assert_int_equal(ub_crc32c(buf, sizeof buf), 0x8A9136AAu);
    assert_int_equal(ub_crc32c_update_portable(0, buf, sizeof buf), 0x8A9136AAu);
    memset(buf, 0xFF, sizeof buf);
    assert_int_equal(ub_crc32c(buf, sizeof buf), 0x62A8AB43u);
    assert_int_equal(ub_crc32c_update_portable(0, buf, sizeof buf), 0x62A8AB43u);
    for (size_t i = 0; i < sizeof buf; i++) buf[i] = (uint8_t)i;
    assert_int_equal(ub_crc32c(buf, sizeof buf), 0x46DD794Eu);
}

static void test_paths_agree_on_random_lengths_and_alignments(void **state) {
    (void)state;
    test_rng_t rng = {0xC0FFEEu};
    uint8_t buf[2048 + 16];
    rng_fill(&rng, buf, sizeof buf);
    for (int trial = 0; trial < 4000; trial++) {
        size_t align = rng_below(&rng, 16);
        size_t len = trial < 64 ? (size_t)trial : rng_below(&rng, 2048);
        const uint8_t *p = buf + align;
        uint32_t want = crc32c_bitwise(p, len);
        assert_int_equal(ub_crc32c_update_portable(0, p, len), want);
        assert_int_equal(ub_crc32c_update_hw(0, p, len), want);
        assert_int_equal(ub_crc32c(p, len), want);
    }
}

static void test_update_continues_across_any_split(void **state) {
    (void)state;
    test_rng_t rng = {42};
    uint8_t buf[300];
    rng_fill(&rng, buf, sizeof buf);
    uint32_t whole = ub_crc32c(buf, sizeof buf);
    for (size_t split = 0; split <= sizeof buf; split++) {
        uint32_t first = ub_crc32c(buf, split);
        assert_int_equal(ub_crc32c_update(first, buf + split, sizeof buf - split), whole);
        assert_int_equal(ub_crc32c_update_portable(ub_crc32c_update_hw(0, buf, split), buf + split, sizeof buf - split),
                         whole);
    }
}

static void test_header_words_equal_byte_crc(void **state) {
    (void)state;
    test_rng_t rng = {7};
    for (int trial = 0; trial < 1000; trial++) {
        uint64_t words[8];
        uint8_t bytes[64];
        for (int k = 0; k < 8; k++) {
            words[k] = rng_next(&rng);
            for (int b = 0; b < 8; b++) bytes[8 * k + b] = (uint8_t)(words[k] >> (8 * b));
        }
        assert_int_equal(ub_crc32c_header_words(words), ub_crc32c_update_portable(0, bytes + 4, 56));
        uint8_t body[40];
        for (size_t b = 0; b < sizeof body; b++) body[b] = (uint8_t)(rng_next(&rng) >> 56);
        size_t n = (size_t)trial % sizeof body;
        uint32_t header_crc = 0;
        uint32_t msg = ub_crc32c_frame_words(words, body, n, &header_crc);
        assert_int_equal(header_crc, ub_crc32c_header_words(words));
        assert_int_equal(msg, ub_crc32c_update_portable(header_crc, body, n));
    }
}

static void test_hardware_path_is_used_where_expected(void **state) {
    (void)state;
#if defined(__x86_64__)
    assert_int_equal(ub_crc32c_hw_available(), __builtin_cpu_supports("sse4.2") ? 1 : 0);
#else
    assert_true(ub_crc32c_hw_available() == 0 || ub_crc32c_hw_available() == 1);
#endif
    print_message("CRC-32C hardware path: %s\n", ub_crc32c_hw_available() ? "yes" : "no (table only)");
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_check_value_every_path),
        cmocka_unit_test(test_empty_input_is_identity),
        cmocka_unit_test(test_rfc3720_patterns),
        cmocka_unit_test(test_paths_agree_on_random_lengths_and_alignments),
        cmocka_unit_test(test_update_continues_across_any_split),
        cmocka_unit_test(test_header_words_equal_byte_crc),
        cmocka_unit_test(test_hardware_path_is_used_where_expected),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
