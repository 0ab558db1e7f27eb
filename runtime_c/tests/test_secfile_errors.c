/*
 * Key and counter files (ub_secfile.h) wrong in every way the parser and the loaders tell apart (issue #29
 * item 6): each key-line defect with its own message and line, key files that are a directory or too large,
 * writes over an existing file or with NULLs, a random key id, and counter files with another magic, too many
 * digits, trailing text, a path too long, a directory in their place. test_secfile.c covers the good files.
 */
#define _XOPEN_SOURCE 700 /* mkdtemp */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "ub/ub_secfile.h"

static char g_dir[64];
static char g_err[256];

static const char *path_of(const char *name) {
    static char p[4][160];
    static int k;
    k = (k + 1) % 4;
    snprintf(p[k], sizeof p[k], "%s/%s", g_dir, name);
    return p[k];
}

static void write_text(const char *path, const char *text, size_t len, mode_t mode) {
    (void)unlink(path);
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, mode);
    assert_true(fd >= 0);
    assert_int_equal(write(fd, text, len), (ssize_t)len);
    assert_int_equal(fchmod(fd, mode), 0);
    close(fd);
}

static int setup(void **state) {
    (void)state;
    snprintf(g_dir, sizeof g_dir, "/tmp/ub_secfile_XXXXXX");
    return mkdtemp(g_dir) != NULL ? 0 : -1;
}

static int teardown(void **state) {
    (void)state;
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", g_dir);
    return system(cmd) == 0 ? 0 : -1;
}

#define HEX64 "00112233445566778899AABBCCDDEEFF00112233445566778899aabbccddeeff"

static void test_each_key_line_defect(void **state) {
    (void)state;
    static const struct {
        const char *text;
        const char *says;
    } cases[] = {
        {"", "no key in the file"},
        {"# only a comment\n\n   \t\n", "no key in the file"},
        {"uavbus-key\n", "too few fields"},
        {"uavbus-key 1 id=7 " HEX64 " extra more\n", "too many fields"},
        {"uavbus-key 1 id=7 " HEX64 " x\n", "too many fields"},
        {"uavbus-key 2x345678901 id=7 " HEX64 "\n", "format '2x345678'"},
        {"uavbus-key 1 id= " HEX64 "\n", "id=<1..255>"},
        {"uavbus-key 1 id=1234 " HEX64 "\n", "id=<1..255>"},
        {"uavbus-key 1 id=0 " HEX64 "\n", "id=<1..255>"},
        {"uavbus-key 1 id=256 " HEX64 "\n", "id=<1..255>"},
        {"uavbus-key 1 id=7a " HEX64 "\n", "id=<1..255>"},
        {"uavbus-key 1 ID=7 " HEX64 "\n", "id=<1..255>"},
        {"uavbus-key 1 id=7 00112233\n", "64 hex digits"},
        {"uavbus-key 1 id=7 " "g0112233445566778899aabbccddeeff00112233445566778899aabbccddeeff" "\n", "not a hex digit"},
        {"uavbus-key 1 id=7 " "0g112233445566778899aabbccddeeff00112233445566778899aabbccddeeff" "\n", "not a hex digit"},
        {"uavbus-key 1 id=7 " HEX64 "\nuavbus-key 1 id=8 " HEX64 "\n", "a second key"},
    };
    uint8_t id = 0, key[32];
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        g_err[0] = '\0';
        assert_int_equal(ub_keyfile_parse(cases[i].text, strlen(cases[i].text), "k.key", &id, key, g_err, sizeof g_err),
                         UB_ERR_CONFIG);
        if (strstr(g_err, cases[i].says) == NULL) fail_msg("case %zu: '%s' does not say '%s'", i, g_err, cases[i].says);
        assert_true(strncmp(g_err, "k.key:", 6) == 0);
    }
    /* Good: CRLF line ends, no final newline, upper- and lower-case hex, leading blanks. */
    const char *good = "# key\r\n  uavbus-key\t1 id=255 " HEX64;
    assert_int_equal(ub_keyfile_parse(good, strlen(good), "k.key", &id, key, g_err, sizeof g_err), UB_OK);
    assert_int_equal(id, 255);
    assert_int_equal(key[10], 0xAA);
    assert_int_equal(key[26], 0xaa);
    assert_int_equal(ub_keyfile_parse(NULL, 0, "k", &id, key, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_keyfile_parse(good, 1, NULL, &id, key, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_keyfile_parse(good, 1, "k", NULL, key, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_keyfile_parse(good, 1, "k", &id, NULL, g_err, sizeof g_err), UB_ERR_INVAL);
}

static void test_key_file_loading_and_writing(void **state) {
    (void)state;
    uint8_t id = 0, key[32];
    memset(key, 0x42, sizeof key);
    assert_int_equal(ub_keyfile_load(NULL, &id, key, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_keyfile_load(g_dir, &id, key, g_err, sizeof g_err), UB_ERR_CONFIG); /* a directory */
    assert_non_null(strstr(g_err, g_dir));
    static char big[UB_KEYFILE_MAX + 10];
    memset(big, '#', sizeof big);
    const char *large = path_of("large.key");
    write_text(large, big, sizeof big, 0600);
    assert_int_equal(ub_keyfile_load(large, &id, key, g_err, sizeof g_err), UB_ERR_CONFIG);
    assert_non_null(strstr(g_err, "large.key"));
    const char *k = path_of("k.key");
    assert_int_equal(ub_keyfile_write(NULL, 7, key, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_keyfile_write(k, 0, key, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_keyfile_write(k, 7, NULL, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_keyfile_write(k, 7, key, g_err, sizeof g_err), UB_OK);
    assert_int_equal(ub_keyfile_write(k, 7, key, g_err, sizeof g_err), UB_ERR_EXISTS);
    assert_int_equal(ub_keyfile_write(path_of("none/k.key"), 7, key, g_err, sizeof g_err), UB_ERR_IO);
    uint8_t id_out = 0;
    assert_int_equal(ub_keyfile_new(NULL, 0, &id_out, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_keyfile_new(path_of("r.key"), 0, &id_out, g_err, sizeof g_err), UB_OK); /* a random id */
    assert_true(id_out >= 1);
    uint8_t got = 0, gkey[32];
    assert_int_equal(ub_keyfile_load(path_of("r.key"), &got, gkey, g_err, sizeof g_err), UB_OK);
    assert_int_equal(got, id_out);
    assert_int_equal(ub_keyfile_new(path_of("s.key"), 9, NULL, g_err, sizeof g_err), UB_OK);
}

static void test_counter_file_defects(void **state) {
    (void)state;
    ub_counter_file_t cf;
    uint64_t mark = 99;
    const char *c = path_of("c.counter");
    assert_int_equal(ub_counter_file_open(NULL, c, &mark, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_counter_file_open(&cf, NULL, &mark, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_counter_file_open(&cf, c, NULL, g_err, sizeof g_err), UB_ERR_INVAL);
    assert_int_equal(ub_counter_file_open(&cf, "", &mark, g_err, sizeof g_err), UB_ERR_RANGE);
    char longp[UB_SECFILE_PATH_MAX + 8];
    memset(longp, 'p', sizeof longp - 1);
    longp[sizeof longp - 1] = '\0';
    assert_int_equal(ub_counter_file_open(&cf, longp, &mark, g_err, sizeof g_err), UB_ERR_RANGE);
    static const char *const bad[] = {
        "uavbus-counter 2 5\n", "uavbus-counter 1 \n", "uavbus-counter 1 12x\n", "uavbus-counter 1 12\n\n",
        "uavbus-counter 1 99999999999999999999\n", "uavbus-counter 1 281474976710657\n",
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        write_text(c, bad[i], strlen(bad[i]), 0600);
        if (ub_counter_file_open(&cf, c, &mark, g_err, sizeof g_err) != UB_ERR_CONFIG) fail_msg("accepted: %s", bad[i]);
        assert_non_null(strstr(g_err, "c.counter:1:"));
    }
    /* the largest mark, 2^48 (every 48-bit counter reserved), without a newline */
    write_text(c, "uavbus-counter 1 281474976710656", 32, 0600);
    assert_int_equal(ub_counter_file_open(&cf, c, &mark, g_err, sizeof g_err), UB_OK);
    assert_int_equal(mark, UINT64_C(281474976710656));
    assert_int_equal(ub_counter_file_open(&cf, g_dir, &mark, g_err, sizeof g_err), UB_ERR_IO); /* a directory */
    assert_int_equal(ub_counter_file_reserve(NULL, 1), UB_ERR_INVAL);
    ub_counter_file_t empty;
    memset(&empty, 0, sizeof empty);
    assert_int_equal(ub_counter_file_reserve(&empty, 1), UB_ERR_INVAL);
    assert_int_equal(ub_counter_file_mark(NULL), 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_each_key_line_defect),
        cmocka_unit_test(test_key_file_loading_and_writing),
        cmocka_unit_test(test_counter_file_defects),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
