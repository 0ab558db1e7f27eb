/*
 * Key files, counter files and the config's "security" section, on real files in a temporary
 * directory: keys written 0600 and read back; group/other-readable key files refused with what to
 * do; every malformed key file named with file:line; the counter file's mark stored atomically and
 * read back; a security section applied to a node (keys, tx key, policy, per-link settings,
 * counter), and each of its errors reported with the config's file:line.
 */
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

#include "support/ub_test_world.h"
#include "ub/ub_node.h"
#include "ub/ub_nodecfg.h"
#include "ub/ub_sec.h"
#include "ub/ub_secfile.h"

static char g_dir[128];

static int make_dir(void **state) {
    (void)state;
    snprintf(g_dir, sizeof g_dir, "/tmp/ub_secfile_XXXXXX");
    return mkdtemp(g_dir) == NULL ? -1 : 0;
}

static int remove_dir(void **state) {
    (void)state;
    char cmd[160];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", g_dir);
    return system(cmd) == 0 ? 0 : -1;
}

static void path_in(char *out, size_t cap, const char *name) { snprintf(out, cap, "%s/%s", g_dir, name); }

static void write_text(const char *path, const char *text, mode_t mode) {
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, mode);
    assert_true(fd >= 0);
    assert_int_equal(write(fd, text, strlen(text)), (ssize_t)strlen(text));
    assert_int_equal(fchmod(fd, mode), 0);
    close(fd);
}

static void test_new_key_is_0600_and_reads_back(void **state) {
    (void)state;
    char path[192], err[UB_SECFILE_ERR_LEN];
    path_in(path, sizeof path, "a.key");
    uint8_t id = 0;
    assert_int_equal(ub_keyfile_new(path, 42, &id, err, sizeof err), UB_OK);
    assert_int_equal(id, 42);
    struct stat st;
    assert_int_equal(stat(path, &st), 0);
    assert_int_equal(st.st_mode & 0777, 0600);
    uint8_t got_id = 0, key[UB_SEC_KEY_LEN], zero[UB_SEC_KEY_LEN] = {0};
    assert_int_equal(ub_keyfile_load(path, &got_id, key, err, sizeof err), UB_OK);
    assert_int_equal(got_id, 42);
    assert_memory_not_equal(key, zero, sizeof key);
    /* never overwritten */
    assert_int_equal(ub_keyfile_new(path, 43, &id, err, sizeof err), UB_ERR_EXISTS);
    assert_non_null(strstr(err, "already exists"));
    assert_int_equal(ub_keyfile_load(path, &got_id, key, err, sizeof err), UB_OK);
    assert_int_equal(got_id, 42);
    /* a random id is 1..255, and two new keys differ */
    char p2[192];
    path_in(p2, sizeof p2, "b.key");
    assert_int_equal(ub_keyfile_new(p2, 0, &id, err, sizeof err), UB_OK);
    assert_true(id >= 1);
    uint8_t key2[UB_SEC_KEY_LEN];
    assert_int_equal(ub_keyfile_load(p2, &got_id, key2, err, sizeof err), UB_OK);
    assert_int_equal(got_id, id);
    assert_memory_not_equal(key, key2, sizeof key);
}

static void test_readable_key_file_is_refused_with_the_fix(void **state) {
    (void)state;
    char path[192], err[UB_SECFILE_ERR_LEN], expect[512];
    path_in(path, sizeof path, "open.key");
    write_text(path, "uavbus-key 1 id=3 000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f\n", 0644);
    uint8_t id, key[UB_SEC_KEY_LEN];
    assert_int_equal(ub_keyfile_load(path, &id, key, err, sizeof err), UB_ERR_CONFIG);
    snprintf(expect, sizeof expect,
             "%s: mode 644 lets group or others access the key; refusing it (chmod 600 %s)", path, path);
    assert_string_equal(err, expect);
    assert_int_equal(chmod(path, 0600), 0);
    assert_int_equal(ub_keyfile_load(path, &id, key, err, sizeof err), UB_OK);
    assert_int_equal(id, 3);
    assert_int_equal(key[31], 0x1f);
    assert_int_equal(chmod(path, 0640), 0); /* group-readable is as bad */
    assert_int_equal(ub_keyfile_load(path, &id, key, err, sizeof err), UB_ERR_CONFIG);
}

static void test_malformed_key_files_name_file_and_line(void **state) {
    (void)state;
    static const struct {
        const char *text;
        const char *expect; /* after "<source>:" */
    } cases[] = {
        {"", "1: no key in the file: expected 'uavbus-key 1 id=<1..255> <64 hex digits>' (make one with: uavbus keys "
             "new FILE)"},
        {"# only a comment\n\n", "2: no key in the file: expected 'uavbus-key 1 id=<1..255> <64 hex digits>' (make "
                                 "one with: uavbus keys new FILE)"},
        {"# k\nuavbus-key 2 id=1 00\n", "2: key file format '2' is not supported (this build reads format 1)"},
        {"uavbus-key 1 id=0 000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f\n",
         "1: the key id must be written id=<1..255>, e.g. id=7"},
        {"uavbus-key 1 id=256 000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f\n",
         "1: the key id must be written id=<1..255>, e.g. id=7"},
        {"uavbus-key 1 7 000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f\n",
         "1: the key id must be written id=<1..255>, e.g. id=7"},
        {"uavbus-key 1 id=7 0001020304\n", "1: the key must be 64 hex digits (32 bytes), not 10 characters"},
        {"uavbus-key 1 id=7 g00102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f\n",
         "1: the key has a character that is not a hex digit (0-9, a-f)"},
        {"uavbus-key 1 id=7\n", "1: too few fields: expected 'uavbus-key 1 id=<1..255> <64 hex digits>'"},
        {"ssh-rsa AAAA\n", "1: not a uavbus key line: expected 'uavbus-key 1 id=<1..255> <64 hex digits>' (make one "
                           "with: uavbus keys new FILE)"},
        {"uavbus-key 1 id=7 000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f\n"
         "uavbus-key 1 id=8 000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f\n",
         "2: a second key (the key is on line 1; a key file holds one key: use one file per key)"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char err[UB_SECFILE_ERR_LEN], expect[UB_SECFILE_ERR_LEN];
        uint8_t id, key[UB_SEC_KEY_LEN];
        assert_int_equal(ub_keyfile_parse(cases[i].text, strlen(cases[i].text), "k.key", &id, key, err, sizeof err),
                         UB_ERR_CONFIG);
        snprintf(expect, sizeof expect, "k.key:%s", cases[i].expect);
        assert_string_equal(err, expect);
    }
    /* comments, blank lines, CRLF and upper-case hex are fine */
    const char *ok = "# fleet key\r\n\r\n  uavbus-key 1 id=9 000102030405060708090A0B0C0D0E0F101112131415161718191a1b1c1d1e1f\r\n";
    uint8_t id, key[UB_SEC_KEY_LEN];
    char err[UB_SECFILE_ERR_LEN];
    assert_int_equal(ub_keyfile_parse(ok, strlen(ok), "k.key", &id, key, err, sizeof err), UB_OK);
    assert_int_equal(id, 9);
    assert_int_equal(key[10], 0x0a);
}

static void test_counter_file_round_trip(void **state) {
    (void)state;
    char path[192], err[UB_SECFILE_ERR_LEN];
    path_in(path, sizeof path, "node.counter");
    ub_counter_file_t cf;
    uint64_t mark = 99;
    assert_int_equal(ub_counter_file_open(&cf, path, &mark, err, sizeof err), UB_OK);
    assert_true(mark == 0); /* first start */
    assert_int_equal(ub_counter_file_reserve(&cf, UINT64_C(123456789012345)), UB_OK);
    assert_int_equal(ub_counter_file_open(&cf, path, &mark, err, sizeof err), UB_OK);
    assert_true(mark == UINT64_C(123456789012345));
    char tmp[200];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    assert_int_not_equal(access(tmp, F_OK), 0); /* renamed over the file, not left beside it */
    write_text(path, "uavbus-counter 1 12x\n", 0600);
    assert_int_equal(ub_counter_file_open(&cf, path, &mark, err, sizeof err), UB_ERR_CONFIG);
    assert_non_null(strstr(err, ":1: not a uavbus counter file"));
    /* a directory that cannot be written: the reservation fails (and the node fails closed) */
    char bad[192];
    path_in(bad, sizeof bad, "missing-dir/node.counter");
    assert_int_equal(ub_counter_file_open(&cf, bad, &mark, err, sizeof err), UB_OK);
    assert_int_equal(ub_counter_file_reserve(&cf, 5), UB_ERR_IO);
    assert_int_equal(cf.failures, 1);
}

/* ---- the config's security section ---- */

static const char *BASE =
    "{\"entities\": [{\"name\": \"a\", \"links\": [\"l0\", \"l1\"], \"linktoentity\": {\"b\": \"0x11\"}},\n"
    "              {\"name\": \"b\", \"links\": [\"m0\"]}],\n"
    " \"hosts\": [\"a\"],\n"
    " \"security\": %s}\n";

static int load(ub_nodecfg_t *cfg, const char *security, char *err, size_t cap) {
    char text[2048], path[192];
    snprintf(text, sizeof text, BASE, security);
    path_in(path, sizeof path, "node.json");
    write_text(path, text, 0644);
    static char buf[1 << 14];
    return ub_nodecfg_load_file(cfg, path, buf, sizeof buf, err, cap);
}

static void test_security_section_parse_errors(void **state) {
    (void)state;
    static const struct {
        const char *security;
        const char *expect; /* after "<dir>/node.json:" */
    } cases[] = {
        {"[]", "4: field 'security': must be an object with keys, tx_key, require_signed, counter_file, links, administrators, read, write and/or limits (see docs/config-format.md)"},
        {"{\"counter_file\": \"c\"}",
         "4: field 'security.keys': missing (list the key files, e.g. [\"keys/fleet.key\"]; make one with: uavbus keys "
         "new FILE)"},
        {"{\"keys\": [], \"counter_file\": \"c\"}",
         "4: field 'security.keys': must list at least one key file (make one with: uavbus keys new FILE)"},
        {"{\"keys\": [\"a\", \"b\", \"c\", \"d\", \"e\"], \"counter_file\": \"c\"}",
         "4: field 'security.keys[4]': too many keys: this build holds 4 (UB_MAX_KEYS in ub_config.h)"},
        {"{\"keys\": [\"k\"], \"tx_key\": 0, \"counter_file\": \"c\"}",
         "4: field 'security.tx_key': must be a key id 1..255 (the id=N of one of the key files)"},
        {"{\"keys\": [\"k\"], \"require_signed\": 1, \"counter_file\": \"c\"}",
         "4: field 'security.require_signed': must be true or false"},
        {"{\"keys\": [\"k\"]}",
         "4: field 'security.counter_file': missing: a node that signs needs a durable counter, e.g. "
         "\"state/{entity}.counter\" (docs/security.md)"},
        {"{\"keys\": [\"k\"], \"counter_file\": \"c\", \"links\": {\"l7\": {\"encrypt\": true}}}",
         "4: field 'security.links.l7': no link of that name in any entity's 'links'"},
        {"{\"keys\": [\"k\"], \"counter_file\": \"c\", \"links\": {\"b:l0\": {\"encrypt\": true}}}",
         "4: field 'security.links.b:l0': no link of that name in any entity's 'links'"},
        {"{\"keys\": [\"k\"], \"counter_file\": \"c\", \"links\": {\"l0\": {\"encrypted\": true}}}",
         "4: field 'security.links.l0.encrypted': unknown field (expected one of: require_signed, encrypt)"},
        {"{\"keys\": [\"k\"], \"counter_file\": \"c\", \"admins\": []}",
         "4: field 'security.admins': unknown field (expected one of: keys, tx_key, require_signed, counter_file, "
         "links, administrators, read, write, limits, exclusive_admin, admin_limits, identity, authority, revocations, "
         "certificates)"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        static ub_nodecfg_t cfg;
        char err[UB_NODECFG_ERR_LEN], expect[UB_NODECFG_ERR_LEN + 400];
        assert_int_equal(load(&cfg, cases[i].security, err, sizeof err), UB_ERR_CONFIG);
        snprintf(expect, sizeof expect, "%s/node.json:%s", g_dir, cases[i].expect);
        assert_string_equal(err, expect);
    }
}

static ub_node_t g_node;
static ub_sec_t g_sec;
static ub_counter_file_t g_counter;

static int apply(const char *security, char *err, size_t cap) {
    static ub_nodecfg_t cfg;
    int rc = load(&cfg, security, err, cap);
    if (rc != UB_OK) return rc;
    if (ub_node_init(&g_node, &ub_test_cat, NULL) != UB_OK || ub_nodecfg_apply(&cfg, &g_node, err, cap) != UB_OK)
        return -100;
    return ub_nodecfg_apply_security(&cfg, &g_node, &g_sec, &g_counter, NULL, UINT64_C(1735689600000000), err, cap);
}

static void test_security_section_applied_to_a_node(void **state) {
    (void)state;
    char path[192], err[UB_NODECFG_ERR_LEN + 200];
    char sub[192];
    path_in(sub, sizeof sub, "keys");
    assert_int_equal(mkdir(sub, 0700), 0);
    path_in(sub, sizeof sub, "state");
    assert_int_equal(mkdir(sub, 0700), 0);
    uint8_t id;
    path_in(path, sizeof path, "keys/one.key");
    assert_int_equal(ub_keyfile_new(path, 5, &id, err, sizeof err), UB_OK);
    path_in(path, sizeof path, "keys/two.key");
    assert_int_equal(ub_keyfile_new(path, 6, &id, err, sizeof err), UB_OK);
    /* relative paths are relative to the config file; {entity} is the hosted entity */
    assert_int_equal(apply("{\"keys\": [\"keys/one.key\", \"keys/two.key\"], \"tx_key\": 6,"
                           " \"counter_file\": \"state/{entity}.counter\","
                           " \"links\": {\"l1\": {\"encrypt\": true}, \"a:l0\": {\"require_signed\": false},"
                           "           \"m0\": {\"encrypt\": true}}}",
                           err, sizeof err),
                     UB_OK);
    assert_ptr_equal(ub_node_security(&g_node), &g_sec);
    assert_int_equal(ub_sec_tx_key(&g_sec), 6);
    assert_true(ub_sec_has_key(&g_sec, 5) && ub_sec_has_key(&g_sec, 6));
    int l0 = ub_node_find_link(&g_node, "l0"), l1 = ub_node_find_link(&g_node, "l1");
    assert_false(ub_node_link_requires_signed(&g_node, l0));
    assert_true(ub_node_link_requires_signed(&g_node, l1));
    assert_int_equal(ub_node_link(&g_node, l1)->encrypt, 1);
    assert_int_equal(ub_node_link(&g_node, l0)->encrypt, 0);
    /* the counter started from the wall clock and its first block is already stored */
    path_in(path, sizeof path, "state/a.counter");
    assert_int_equal(access(path, F_OK), 0);
    assert_true(g_counter.mark > ub_sec_wall_counter(UINT64_C(1735689600000000)));
    uint64_t first_mark = g_counter.mark;
    /* a restart continues above the stored mark even with the clock set back */
    static ub_nodecfg_t cfg;
    assert_int_equal(load(&cfg, "{\"keys\": [\"keys/one.key\"], \"counter_file\": \"state/{entity}.counter\"}", err,
                          sizeof err),
                     UB_OK);
    assert_int_equal(ub_node_init(&g_node, &ub_test_cat, NULL), UB_OK);
    assert_int_equal(ub_nodecfg_apply(&cfg, &g_node, err, sizeof err), UB_OK);
    assert_int_equal(ub_nodecfg_apply_security(&cfg, &g_node, &g_sec, &g_counter, NULL, 0, err, sizeof err), UB_OK);
    assert_true(g_sec.counter > first_mark - 1);
    assert_int_equal(ub_sec_tx_key(&g_sec), 5); /* default: the first key file */
    assert_true(ub_node_link_requires_signed(&g_node, l0)); /* default true */
}

static void test_security_section_apply_errors(void **state) {
    (void)state;
    char path[192], err[UB_NODECFG_ERR_LEN + 200], expect[900];
    uint8_t id;
    path_in(path, sizeof path, "k7.key");
    assert_int_equal(ub_keyfile_new(path, 7, &id, err, sizeof err), UB_OK);
    path_in(path, sizeof path, "k7b.key");
    assert_int_equal(ub_keyfile_new(path, 7, &id, err, sizeof err), UB_OK);
    path_in(path, sizeof path, "open.key");
    write_text(path, "uavbus-key 1 id=8 000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f\n", 0644);

    assert_int_equal(apply("{\"keys\": [\"nope.key\"], \"counter_file\": \"c\"}", err, sizeof err), UB_ERR_CONFIG);
    snprintf(expect, sizeof expect,
             "%s/node.json:4: field 'security.keys[0]': %s/nope.key: cannot open the key file: No such file or directory",
             g_dir, g_dir);
    assert_string_equal(err, expect);

    assert_int_equal(apply("{\"keys\": [\"open.key\"], \"counter_file\": \"c\"}", err, sizeof err), UB_ERR_CONFIG);
    snprintf(expect, sizeof expect,
             "%s/node.json:4: field 'security.keys[0]': %s/open.key: mode 644 lets group or others access the key; "
             "refusing it (chmod 600 %s/open.key)",
             g_dir, g_dir, g_dir);
    assert_string_equal(err, expect);

    assert_int_equal(apply("{\"keys\": [\"k7.key\", \"k7b.key\"], \"counter_file\": \"c\"}", err, sizeof err),
                     UB_ERR_CONFIG);
    assert_non_null(strstr(err, "field 'security.keys[1]': "));
    assert_non_null(strstr(err, "key id 7 is already used by another key file here (give each key its own id)"));

    assert_int_equal(apply("{\"keys\": [\"k7.key\"], \"tx_key\": 9, \"counter_file\": \"c\"}", err, sizeof err),
                     UB_ERR_CONFIG);
    snprintf(expect, sizeof expect,
             "%s/node.json:4: field 'security.tx_key': no key file given has id 9 (tx_key names the id=N of one of "
             "'keys')",
             g_dir);
    assert_string_equal(err, expect);

    assert_int_equal(apply("{\"keys\": [\"k7.key\"], \"counter_file\": \"no/such/dir/c\"}", err, sizeof err),
                     UB_ERR_CONFIG);
    assert_non_null(strstr(err, "field 'security.counter_file': "));
    assert_non_null(strstr(err, "cannot store the counter reservation (No such file or directory)"));
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_new_key_is_0600_and_reads_back),
        cmocka_unit_test(test_readable_key_file_is_refused_with_the_fix),
        cmocka_unit_test(test_malformed_key_files_name_file_and_line),
        cmocka_unit_test(test_counter_file_round_trip),
        cmocka_unit_test(test_security_section_parse_errors),
        cmocka_unit_test(test_security_section_applied_to_a_node),
        cmocka_unit_test(test_security_section_apply_errors),
    };
    return cmocka_run_group_tests(tests, make_dir, remove_dir);
}
