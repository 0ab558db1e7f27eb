/*
 * ub_policy: patterns, the policy's own API, and the "security" section of the node configuration
 * (administrators, read, write, limits) with its one-line errors. Enforcement by the router is in
 * test_authz. Runs with the repository root as working directory.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ub/ub_node.h"
#include "ub/ub_nodecfg.h"
#include "ub/ub_policy.h"

typedef struct fixture {
    ub_nodecfg_t cfg;
    ub_policy_t pol;
    char text[4096];
    char err[UB_NODECFG_ERR_LEN];
} fixture_t;

/* One fixture for the whole program (large, so not on the stack), zeroed before each test. */
static fixture_t g_fixture;

static int fresh(void **state) {
    memset(&g_fixture, 0, sizeof g_fixture);
    *state = &g_fixture;
    return 0;
}

static uint8_t g_ids[3][UB_ENTITY_ID_LEN];

static const uint8_t *id(int k, const char *name) {
    assert_int_equal(ub_entity_id(name, g_ids[k]), UB_OK);
    return g_ids[k];
}

/* ---- patterns ------------------------------------------------------------------------------- */

static bool m(const char *pattern, const char *text) { return ub_policy_match(pattern, text, strlen(text)); }

static void test_patterns(void **state) {
    (void)state;
    assert_true(m("*", ""));
    assert_true(m("*", "gpsOut"));
    assert_true(m("gpsOut", "gpsOut"));
    assert_true(m("gps*", "gpsOut"));
    assert_true(m("*Out", "gpsOut"));
    assert_true(m("g*O*t", "gpsOut"));
    assert_true(m("a*b*c", "aXbYbZc")); /* the first `*` must give back characters */
    assert_true(m("gcsMission*", "gcsMissionRmax1[0]"));
    assert_true(m("cell[0]*", "cell[0][3]"));
    assert_true(m("**", "x"));
    assert_true(m("", ""));
    assert_false(m("a*b*c", "aXbYbZ"));
    assert_false(m("gpsOut", "gpsOut2"));
    assert_false(m("gpsOut*", "gps"));
    assert_false(m("", "a"));
    assert_false(m("GPSOUT", "gpsOut")); /* names are case-sensitive, like the IDs */
    assert_false(ub_policy_match(NULL, "x", 1));
    /* Entity IDs are names padded with NUL bytes: the padding is not part of the name. */
    ub_policy_t pol;
    ub_policy_init(&pol);
    assert_int_equal(ub_policy_add_rule(&pol, UB_POLICY_WRITE, "veh*", "gcs1", "*"), UB_OK);
    assert_true(ub_policy_rule_matches(&pol, UB_POLICY_WRITE, id(0, "veh1"), id(1, "gcs1"), "x"));
    assert_false(ub_policy_rule_matches(&pol, UB_POLICY_WRITE, id(0, "veh1"), id(1, "gcs12"), "x"));
    assert_false(ub_policy_rule_matches(&pol, UB_POLICY_READ, id(0, "veh1"), id(1, "gcs1"), "x"));
    uint8_t full[UB_ENTITY_ID_LEN];
    memcpy(full, "vehicle12345", UB_ENTITY_ID_LEN); /* 12 characters, no padding at all */
    assert_true(ub_policy_rule_matches(&pol, UB_POLICY_WRITE, full, id(1, "gcs1"), "x"));

    assert_true(ub_policy_pattern_ok("gcsMissionRmax1[0]*", UB_POLICY_PATTERN_MAX));
    assert_false(ub_policy_pattern_ok("gps Out", UB_POLICY_PATTERN_MAX));
    assert_false(ub_policy_pattern_ok("", UB_POLICY_PATTERN_MAX));
    assert_false(ub_policy_pattern_ok("gps\"", UB_POLICY_PATTERN_MAX));
    assert_false(ub_policy_pattern_ok("abcdefghijklmnop", UB_POLICY_ENTITY_PATTERN_MAX));
    assert_false(ub_policy_pattern_ok(NULL, 10));
}

/* ---- the API -------------------------------------------------------------------------------- */

static void test_policy_api(void **state) {
    fixture_t *f = *state;
    ub_policy_t *pol = &f->pol;
    ub_policy_init(pol);
    assert_int_equal(pol->limits.min_period_ms, UB_POLICY_DEFAULT_MIN_PERIOD_MS);
    assert_int_equal(pol->limits.max_rows, UB_POLICY_DEFAULT_MAX_ROWS);
    assert_int_equal(pol->limits.max_bytes_per_s, UB_POLICY_DEFAULT_MAX_BYTES_PER_S);
    assert_int_equal(pol->limits.max_lease_ms, UB_POLICY_DEFAULT_MAX_LEASE_MS);
    assert_false(pol->read_restricted);
    assert_false(ub_policy_is_admin(pol, id(0, "gcs1")));
    assert_false(ub_policy_is_admin(NULL, id(0, "gcs1")));

    assert_int_equal(ub_policy_add_admin(pol, id(0, "gcs1")), UB_OK);
    assert_int_equal(ub_policy_add_admin(pol, id(0, "gcs1")), UB_ERR_EXISTS);
    assert_true(ub_policy_is_admin(pol, id(0, "gcs1")));
    char name[8];
    for (int k = 1; k < UB_POLICY_MAX_ADMINS; k++) {
        (void)snprintf(name, sizeof name, "gcs%d", k + 1);
        assert_int_equal(ub_policy_add_admin(pol, id(0, name)), UB_OK);
    }
    assert_int_equal(ub_policy_add_admin(pol, id(0, "one_more")), UB_ERR_FULL);

    assert_int_equal(ub_policy_add_rule(pol, UB_POLICY_READ, "veh1", "obs1", NULL), UB_ERR_INVAL);
    assert_int_equal(ub_policy_add_rule(pol, UB_POLICY_READ, "veh1", "obs1", "gps Out"), UB_ERR_INVAL);
    assert_int_equal(ub_policy_add_rule(pol, UB_POLICY_READ, "a_very_long_name", "obs1", "x"), UB_ERR_INVAL);
    assert_int_equal(ub_policy_add_rule(pol, (ub_policy_dir_t)7, "veh1", "obs1", "x"), UB_ERR_INVAL);
    assert_false(pol->read_restricted); /* refused rules change nothing */
    for (int k = 0; k < UB_POLICY_MAX_RULES; k++)
        assert_int_equal(ub_policy_add_rule(pol, UB_POLICY_READ, "veh1", "obs1", "x"), UB_OK);
    assert_int_equal(ub_policy_add_rule(pol, UB_POLICY_WRITE, "veh1", "obs1", "x"), UB_ERR_FULL);
    assert_true(pol->read_restricted);

    ub_policy_limits_t lim = {.max_rows = 2, .max_lease_ms = 999};
    assert_int_equal(ub_policy_set_limits(pol, &lim), UB_ERR_RANGE);
    assert_int_equal(pol->limits.max_rows, UB_POLICY_DEFAULT_MAX_ROWS); /* unchanged */
    lim.max_lease_ms = 0;
    assert_int_equal(ub_policy_set_limits(pol, &lim), UB_OK);
    assert_int_equal(pol->limits.max_rows, 2);
    assert_int_equal(pol->limits.max_lease_ms, UB_POLICY_DEFAULT_MAX_LEASE_MS);
    assert_int_equal(ub_policy_set_limits(pol, NULL), UB_ERR_INVAL);

    /* A frame every period: the paper's gpsOut (70 bytes) at 10 Hz is 1340 B/s on the wire. */
    assert_int_equal(ub_policy_row_bytes_per_s(70, 100), 1340);
    assert_int_equal(ub_policy_row_bytes_per_s(70, 1), 134000);
    assert_int_equal(ub_policy_row_bytes_per_s(70, 0), UINT64_MAX);
}

/* ---- the configuration's "security" section ------------------------------------------------- */

/* Line 1: four entities, veh1 hosted; the security section starts on line 2. */
#define BASE "{\"entities\": [{\"name\": \"gcs1\"}, {\"name\": \"veh1\"}, {\"name\": \"obs1\"}, {\"name\": \"mallory\"}]," \
             " \"hosts\": [\"veh1\"],\n"

static int parse(fixture_t *f, const char *security) {
    (void)snprintf(f->text, sizeof f->text, BASE "%s}", security);
    return ub_nodecfg_parse(&f->cfg, f->text, strlen(f->text), "inline.json", f->err, sizeof f->err);
}

static void expect_error(fixture_t *f, const char *security, const char *expected) {
    if (parse(f, security) != UB_ERR_CONFIG) fail_msg("accepted: %s", security);
    assert_string_equal(f->err, expected);
    assert_false(f->cfg.has_policy); /* a refused file leaves nothing behind */
}

static void test_config_security_section(void **state) {
    fixture_t *f = *state;
    int rc = parse(f, "\"security\": {\"administrators\": [\"gcs1\"],\n"
                      " \"read\": {\"veh1\": [{\"from\": [\"obs1\", \"gcs*\"], \"content\": [\"gpsOut\", \"imu*\"]}]},\n"
                      " \"write\": {\"*\": [{\"from\": \"gcs1\", \"content\": \"cell*\"}]},\n"
                      " \"limits\": {\"min_period_ms\": 20, \"max_rows\": 4, \"max_lease_ms\": 5000}}");
    if (rc != UB_OK) fail_msg("%s", f->err);
    const ub_policy_t *pol = &f->cfg.policy;
    assert_true(f->cfg.has_policy);
    assert_int_equal(pol->n_admins, 1);
    assert_true(ub_policy_is_admin(pol, id(0, "gcs1")));
    assert_int_equal(pol->n_rules, 5); /* 2 x 2 read rules, 1 write rule */
    assert_true(pol->read_restricted);
    assert_int_equal(pol->rules[0].line, 3);
    assert_int_equal(pol->rules[4].line, 4);
    assert_true(ub_policy_rule_matches(pol, UB_POLICY_READ, id(0, "veh1"), id(1, "gcs7"), "imuOut"));
    assert_false(ub_policy_rule_matches(pol, UB_POLICY_READ, id(0, "veh1"), id(1, "mallory"), "gpsOut"));
    assert_true(ub_policy_rule_matches(pol, UB_POLICY_WRITE, id(0, "obs1"), id(1, "gcs1"), "cell07"));
    assert_int_equal(pol->limits.min_period_ms, 20);
    assert_int_equal(pol->limits.max_rows, 4);
    assert_int_equal(pol->limits.max_bytes_per_s, UB_POLICY_DEFAULT_MAX_BYTES_PER_S);
    assert_int_equal(pol->limits.max_lease_ms, 5000);
    /* administrators: their own defaults, never none */
    assert_int_equal(pol->admin_limits.min_period_ms, UB_POLICY_DEFAULT_ADMIN_MIN_PERIOD_MS);
    assert_int_equal(pol->admin_limits.max_rows, UB_POLICY_DEFAULT_ADMIN_MAX_ROWS);
    assert_int_equal(pol->admin_limits.max_bytes_per_s, UB_POLICY_DEFAULT_ADMIN_MAX_BYTES_PER_S);
    assert_int_equal(pol->admin_limits.max_lease_ms, UB_POLICY_DEFAULT_ADMIN_MAX_LEASE_MS);
    assert_ptr_equal(ub_policy_limits_for(pol, true), &pol->admin_limits);
    assert_ptr_equal(ub_policy_limits_for(pol, false), &pol->limits);
    rc = parse(f, "\"security\": {\"administrators\": [\"gcs1\"],\n"
                  " \"admin_limits\": {\"min_period_ms\": 2, \"max_rows\": 16, \"max_bytes_per_s\": 65536}}");
    if (rc != UB_OK) fail_msg("%s", f->err);
    assert_int_equal(f->cfg.policy.admin_limits.min_period_ms, 2);
    assert_int_equal(f->cfg.policy.admin_limits.max_rows, 16);
    assert_int_equal(f->cfg.policy.admin_limits.max_bytes_per_s, 65536);
    assert_int_equal(f->cfg.policy.admin_limits.max_lease_ms, UB_POLICY_DEFAULT_ADMIN_MAX_LEASE_MS);
    assert_int_equal(f->cfg.policy.limits.max_rows, UB_POLICY_DEFAULT_MAX_ROWS);
    rc = parse(f, "\"security\": {\"administrators\": [\"gcs1\"],\n"
                  " \"limits\": {\"min_period_ms\": 20, \"max_rows\": 4, \"max_lease_ms\": 5000}}");

    /* ub_nodecfg_apply() attaches the configuration's policy; without one the node keeps none. */
    ub_node_t *node = calloc(1, sizeof *node);
    assert_non_null(node);
    static const ub_catalogue_t empty = {"empty", UB_ID_SCHEME_PAPER, UB_CATALOGUE_ABI_VERSION, NULL, 0, NULL, 0, 0,
                                         NULL, 0};
    assert_int_equal(ub_node_init(node, &empty, NULL), UB_OK);
    assert_int_equal(ub_nodecfg_apply(&f->cfg, node, f->err, sizeof f->err), UB_OK);
    assert_ptr_equal(node->policy, &f->cfg.policy);
    assert_int_equal(parse(f, "\"security\": {}"), UB_OK); /* no policy key: no policy (frame keys may come alone) */
    assert_false(f->cfg.has_policy);
    assert_int_equal(ub_node_init(node, &empty, NULL), UB_OK);
    assert_int_equal(ub_nodecfg_apply(&f->cfg, node, f->err, sizeof f->err), UB_OK);
    assert_null(node->policy);
    free(node);

    assert_int_equal(parse(f, "\"security\": {\"read\": {}}"), UB_OK); /* reads for administrators only */
    assert_true(f->cfg.has_policy);
    assert_true(f->cfg.policy.read_restricted);
    assert_int_equal(f->cfg.policy.n_admins, 0);
}

static void test_config_security_errors(void **state) {
    fixture_t *f = *state;
    expect_error(f, "\"security\": []",
                 "inline.json:2: field 'security': must be an object with keys, tx_key, require_signed, counter_file, "
                 "links, administrators, read, write and/or limits (see docs/config-format.md)");
    expect_error(f, "\"security\": {\"admins\": [\"gcs1\"]}",
                 "inline.json:2: field 'security.admins': unknown field (expected one of: keys, tx_key, "
                 "require_signed, counter_file, links, administrators, read, write, limits, exclusive_admin, admin_limits, identity, "
                 "authority, revocations, certificates)");
    expect_error(f, "\"security\": {\"admin_limits\": {\"max_rows\": 0}}",
                 "inline.json:2: field 'security.admin_limits.max_rows': must be a whole number from 1 to 4294967295");
    expect_error(f, "\"security\": {\"admin_limits\":\n {\"max_lease_ms\": 500}}",
                 "inline.json:3: field 'security.admin_limits.max_lease_ms': must be at least 1000 ms: a shorter lease "
                 "lapses between two renewals (renew_ms 1000)");
    expect_error(f, "\"security\": {\"admin_limits\": {\"rows\": 3}}",
                 "inline.json:2: field 'security.admin_limits': unknown field (expected one of: min_period_ms, "
                 "max_rows, max_bytes_per_s, max_lease_ms)");
    expect_error(f, "\"security\": {\"admin_limits\": \"none\"}",
                 "inline.json:2: field 'security.admin_limits': must be an object with min_period_ms, max_rows, "
                 "max_bytes_per_s and/or max_lease_ms");
    expect_error(f, "\"security\": {\"administrators\": [\"gcs1\"], \"administrators\": []}",
                 "inline.json:2: field 'security.administrators': duplicate field (first given on line 2)");
    expect_error(f, "\"security\": {\"administrators\": \"gcs1\"}",
                 "inline.json:2: field 'security.administrators': must be a list of entity names (the entities with "
                 "the exclusive rights)");
    expect_error(f, "\"security\": {\"administrators\": [\"gcs1\",\n \"gcs9\"]}",
                 "inline.json:3: field 'security.administrators[1]': no entity named 'gcs9' in 'entities'");
    expect_error(f, "\"security\": {\"administrators\": [\"gcs1\", \"gcs1\"]}",
                 "inline.json:2: field 'security.administrators[1]': entity 'gcs1' is listed twice");
    expect_error(f, "\"security\": {\"administrators\": [\"gcs*\"]}",
                 "inline.json:2: field 'security.administrators[0]': must be an entity name (administrators are "
                 "named, not patterns)");
    expect_error(f, "\"security\": {\"read\": [\"veh1\"]}",
                 "inline.json:2: field 'security.read': must be an object mapping entity names (or patterns) to "
                 "lists of rules [{\"from\": ..., \"content\": ...}]");
    expect_error(f, "\"security\": {\"read\": {\"vehX\": []}}",
                 "inline.json:2: field 'security.read': no entity named 'vehX' in 'entities' (use '*' in a pattern)");
    expect_error(f, "\"security\": {\"read\": {\"veh1\": {\"from\": \"obs1\"}}}",
                 "inline.json:2: entity 'veh1', field 'security.read.veh1': must be a list of rules [{\"from\": ..., "
                 "\"content\": ...}]");
    expect_error(f, "\"security\": {\"read\": {\"veh1\": [\n{\"from\": \"obs1\"}]}}",
                 "inline.json:3: entity 'veh1', field 'security.read.veh1[0].content': missing (directory names or "
                 "patterns such as \"gpsOut*\")");
    expect_error(f, "\"security\": {\"write\": {\"veh1\": [{\"content\": \"x\"}]}}",
                 "inline.json:2: entity 'veh1', field 'security.write.veh1[0].from': missing (whose data may be "
                 "written: an entity name, a pattern or a list)");
    expect_error(f, "\"security\": {\"write\": {\"veh1\": [{\"from\": \"mallroy\", \"content\": \"x\"}]}}",
                 "inline.json:2: entity 'veh1', field 'security.write.veh1[0].from': no entity named 'mallroy' in "
                 "'entities' (use '*' in a pattern)");
    expect_error(f, "\"security\": {\"write\": {\"*\": [{\"from\": [\"gcs1\", 7], \"content\": \"x\"}]}}",
                 "inline.json:2: field 'security.write.*[0].from[1]': must be an entity name or a pattern such as "
                 "\"gcs*\" or \"*\" (1 to 15 characters from A-Z a-z 0-9 _ . - [ ] *)");
    expect_error(f, "\"security\": {\"write\": {\"veh1\": [{\"from\": \"gcs1\", \"content\": \"gps Out\"}]}}",
                 "inline.json:2: entity 'veh1', field 'security.write.veh1[0].content': must be a directory name or "
                 "a pattern such as \"gcsMission*\" (1 to 63 characters from A-Z a-z 0-9 _ . - [ ] *)");
    expect_error(f, "\"security\": {\"write\": {\"veh1\": [{\"from\": [], \"content\": \"x\"}]}}",
                 "inline.json:2: entity 'veh1', field 'security.write.veh1[0].from': must not be empty (a rule that "
                 "names nothing grants nothing)");
    expect_error(f, "\"security\": {\"write\": {\"veh1\": [{\"from\": \"gcs1\", \"content\": \"x\", \"to\": 1}]}}",
                 "inline.json:2: entity 'veh1', field 'security.write.veh1[0]': unknown field (expected one of: from, "
                 "content)");
    expect_error(f, "\"security\": {\"write\": {\"veh1\": [{\"from\": \"gcs1\", \"from\": \"obs1\", \"content\": \"x\"}]}}",
                 "inline.json:2: entity 'veh1', field 'security.write.veh1[0].from': duplicate field");
    expect_error(f, "\"security\": {\"limits\": {\"max_rows\": 0}}",
                 "inline.json:2: field 'security.limits.max_rows': must be a whole number from 1 to 4294967295");
    expect_error(f, "\"security\": {\"limits\": {\"max_rows\": 1.5}}",
                 "inline.json:2: field 'security.limits.max_rows': must be a whole number from 1 to 4294967295");
    expect_error(f, "\"security\": {\"limits\": {\"max_rows\": -3}}",
                 "inline.json:2: field 'security.limits.max_rows': must be a whole number from 1 to 4294967295");
    expect_error(f, "\"security\": {\"limits\": {\"min_period_ms\": 4294967296}}",
                 "inline.json:2: field 'security.limits.min_period_ms': must be a whole number from 1 to 4294967295");
    expect_error(f, "\"security\": {\"limits\": {\"max_lease_ms\": 500}}",
                 "inline.json:2: field 'security.limits.max_lease_ms': must be at least 1000 ms: a shorter lease "
                 "lapses between two renewals (renew_ms 1000)");
    expect_error(f, "\"security\": {\"limits\": {\"max_row\": 3}}",
                 "inline.json:2: field 'security.limits': unknown field (expected one of: min_period_ms, max_rows, "
                 "max_bytes_per_s, max_lease_ms)");
    expect_error(f, "\"security\": {\"limits\": {\"max_rows\": 3, \"max_rows\": 4}}",
                 "inline.json:2: field 'security.limits.max_rows': duplicate field");
    /* 7 sources x 7 contents = 49 rules: one more than a build holds. */
    expect_error(f, "\"security\": {\"read\": {\"veh1\": [{\"from\": [\"a*\", \"b*\", \"c*\", \"d*\", \"e*\", \"f*\", "
                    "\"g*\"], \"content\": [\"a\", \"b\", \"c\", \"d\", \"e\", \"f\", \"g\"]}]}}",
                 "inline.json:2: entity 'veh1', field 'security.read.veh1[0]': too many rules: this build holds 48 "
                 "read and write rules together, one per (from, content) pair (raise UB_POLICY_MAX_RULES in "
                 "ub_config.h)");
}

/* The shipped example parses, and its policy says what docs/config-format.md says it does. */
static void test_example_policy_file(void **state) {
    fixture_t *f = *state;
    int rc = ub_nodecfg_load_file(&f->cfg, "examples/configs/table2_policy.json", f->text, sizeof f->text, f->err,
                                  sizeof f->err);
    if (rc != UB_OK) fail_msg("%s", f->err);
    const ub_policy_t *pol = &f->cfg.policy;
    assert_true(f->cfg.has_policy);
    assert_true(ub_policy_is_admin(pol, id(0, "gcs1")));
    assert_false(ub_policy_is_admin(pol, id(0, "rmax1ob2")));
    assert_true(ub_policy_rule_matches(pol, UB_POLICY_WRITE, id(0, "rmax1ob1"), id(1, "gcs1"), "gcsMissionRmax1[0]"));
    assert_false(ub_policy_rule_matches(pol, UB_POLICY_WRITE, id(0, "rmax1ob1"), id(1, "rmax1ob2"), "onboardSet"));
    assert_true(ub_policy_rule_matches(pol, UB_POLICY_READ, id(0, "rmax1ob1"), id(1, "rmax1ob2"), "gpsOut"));
    assert_false(ub_policy_rule_matches(pol, UB_POLICY_READ, id(0, "rmax1ob1"), id(1, "rmax1ob2"), "onboardSet"));
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_patterns),
        cmocka_unit_test_setup_teardown(test_policy_api, fresh, NULL),
        cmocka_unit_test_setup_teardown(test_config_security_section, fresh, NULL),
        cmocka_unit_test_setup_teardown(test_config_security_errors, fresh, NULL),
        cmocka_unit_test_setup_teardown(test_example_policy_file, fresh, NULL),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
