/* Node configuration loader: the paper's Tables 1 and 2, the shared bad-config
 * corpus (tests/unit/config_cases/, also checked by tests/unit/test_config.py),
 * mask helpers, capacities and robustness against malformed input.
 * Runs with the repository root as working directory (see runtime_c/CMakeLists.txt). */
#include <dirent.h>
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

#define CASES_DIR "tests/unit/config_cases"
#define TEXT_CAP 16384

/* Large fixtures live in one struct on the heap per test, so the tests do not
 * depend on the stack size; the library itself never allocates. */
typedef struct fixture {
    ub_node_t node;
    ub_nodecfg_t cfg;
    char text[TEXT_CAP];
    char err[UB_NODECFG_ERR_LEN];
} fixture_t;

static int setup(void **state) {
    *state = calloc(1, sizeof(fixture_t));
    return *state == NULL ? -1 : 0;
}

static int teardown(void **state) {
    free(*state);
    return 0;
}

static void load_ok(fixture_t *f, const char *path) {
    int rc = ub_nodecfg_load_file(&f->cfg, path, f->text, sizeof f->text, f->err, sizeof f->err);
    if (rc != UB_OK) fail_msg("%s: %s", ub_strerror(rc), f->err);
}

static void parse_ok(fixture_t *f, const char *text) {
    int rc = ub_nodecfg_parse(&f->cfg, text, strlen(text), "inline.json", f->err, sizeof f->err);
    if (rc != UB_OK) fail_msg("%s: %s", ub_strerror(rc), f->err);
}

static void assert_parse_error(fixture_t *f, const char *text, const char *expected) {
    assert_int_equal(ub_nodecfg_parse(&f->cfg, text, strlen(text), "inline.json", f->err, sizeof f->err),
                     UB_ERR_CONFIG);
    assert_string_equal(f->err, expected);
}

static void assert_masks(const ub_nodecfg_t *cfg, const char *entity, const uint8_t *expected) {
    int e = ub_nodecfg_find_entity(cfg, entity);
    assert_true(e >= 0);
    for (int j = 0; j < cfg->entity_count; j++) {
        if (cfg->entities[e].mask[j] != expected[j])
            fail_msg("%s -> %s: mask 0x%02x, expected 0x%02x", entity, cfg->entities[j].name,
                     cfg->entities[e].mask[j], expected[j]);
    }
}

/* Paper Table 1 (Figure 9): masks as bits, e.g. 0x00000110 -> 0x06. */
static void test_table1_as_published(void **state) {
    fixture_t *f = *state;
    load_ok(f, "examples/configs/table1.json");
    const ub_nodecfg_t *c = &f->cfg;
    assert_string_equal(c->system, "paper-table1");
    assert_int_equal(c->entity_count, 4);
    assert_masks(c, "entity0", (const uint8_t[]){0x00, 0x01, 0x01, 0x06});
    assert_masks(c, "entity1", (const uint8_t[]){0x01, 0x00, 0x02, 0x01});
    assert_masks(c, "entity2", (const uint8_t[]){0x01, 0x01, 0x00, 0x01});
    assert_masks(c, "entity3", (const uint8_t[]){0x03, 0x03, 0x03, 0x00});
    assert_int_equal(c->entities[0].link_count, 3);
    assert_string_equal(c->entities[0].links[2], "e0Toe3b");
    assert_int_equal(c->entities[2].link_count, 1);
    assert_string_equal(c->entities[3].links[1], "e3Toe0b");
    assert_int_equal(c->host_count, 0);
    assert_int_equal(c->node_count, 3);
    assert_string_equal(c->nodes[0].name, "A");
    assert_int_equal(c->nodes[0].entity_count, 2);
}

/* Paper Table 2 (HITL): rmax1ob1's row is keyed by name, the others follow 'entities' order. */
static void test_table2_as_published(void **state) {
    fixture_t *f = *state;
    load_ok(f, "examples/configs/table2.json");
    ub_nodecfg_t *c = &f->cfg;
    assert_int_equal(c->entity_count, 4);
    assert_int_equal(ub_nodecfg_mask(c, "rmax1ob1", "gcs1"), 0x03);
    assert_int_equal(ub_nodecfg_mask(c, "rmax1ob1", "rmax1ob2"), 0x04);
    assert_int_equal(ub_nodecfg_mask(c, "rmax1ob1", "fcs20"), 0x08);
    assert_int_equal(ub_nodecfg_mask(c, "rmax1ob1", "rmax1ob1"), 0x00);
    assert_masks(c, "rmax1ob2", (const uint8_t[]){0x01, 0x00, 0x01, 0x01});
    assert_masks(c, "fcs20", (const uint8_t[]){0x01, 0x01, 0x00, 0x01});
    assert_masks(c, "gcs1", (const uint8_t[]){0x03, 0x03, 0x03, 0x00});
    assert_string_equal(c->entities[0].links[3], "onboardPortRelay");
    assert_string_equal(c->entities[2].links[0], "onboardPortDatalink1"); /* same name as rmax1ob1's link 0 */
    assert_int_equal(ub_nodecfg_mask(c, "gcs1", "nobody"), UB_ERR_NOTFOUND);

    assert_int_equal(c->node_count, 4);
    assert_int_equal(ub_nodecfg_select_node(c, "gcs", f->err, sizeof f->err), UB_OK);
    assert_int_equal(c->host_count, 1);
    assert_string_equal(c->entities[c->hosts[0]].name, "gcs1");
    assert_int_equal(ub_nodecfg_select_node(c, "tower", f->err, sizeof f->err), UB_ERR_NOTFOUND);
    assert_string_equal(f->err, "no node named 'tower' in 'nodes' (known: primary, secondary, backup, gcs)");
}

/* The same Table 2 in the list forms (indices, names, mixed) gives the same masks. */
static void test_hex_and_list_forms_agree(void **state) {
    fixture_t *f = *state;
    load_ok(f, "examples/configs/table2.json");
    ub_nodecfg_t hex = f->cfg;
    parse_ok(f, "{\"entities\": [\n"
                " {\"name\": \"rmax1ob1\", \"links\": [\"onboardPortDatalink1\", \"onboardPortDatalink2\","
                "  \"onboardPortIPC\", \"onboardPortRelay\"],\n"
                "  \"linktoentity\": {\"gcs1\": [\"onboardPortDatalink1\", 1], \"rmax1ob2\": [\"onboardPortIPC\"],"
                "  \"fcs20\": [3], \"rmax1ob1\": []}},\n"
                " {\"name\": \"rmax1ob2\", \"links\": [\"onboard2PortIPC\"], \"linktoentity\": [[0], [], [0], "
                "  [\"onboard2PortIPC\"]]},\n"
                " {\"name\": \"fcs20\", \"links\": [\"onboardPortDatalink1\"], \"linktoentity\": [[0], [0], [], [0]]},\n"
                " {\"name\": \"gcs1\", \"links\": [\"gcsPortDatalink1\", \"gcsPortDatalink2\"],"
                "  \"linktoentity\": {\"rmax1ob1\": [1, 0], \"rmax1ob2\": \"0x11\", \"fcs20\": [\"gcsPortDatalink2\","
                "  \"gcsPortDatalink1\"]}}\n"
                "]}");
    assert_int_equal(f->cfg.entity_count, hex.entity_count);
    for (int i = 0; i < hex.entity_count; i++)
        assert_memory_equal(f->cfg.entities[i].mask, hex.entities[i].mask, sizeof hex.entities[i].mask);
}

static char *read_text(const char *path, char *buf, size_t cap) {
    FILE *fp = fopen(path, "rb");
    if (fp == NULL) return NULL;
    size_t n = fread(buf, 1, cap - 1, fp);
    fclose(fp);
    buf[n] = '\0';
    while (n > 0 && (buf[n - 1] == '\n' || buf[n - 1] == '\r')) buf[--n] = '\0';
    return buf;
}

static char *read_text_for_limits(fixture_t *f) {
    char *text = read_text("examples/configs/table2.json", f->text, sizeof f->text);
    assert_non_null(text);
    return text;
}

/* A smaller build's capacities: the same file is checked as that build would check it. */
static void test_smaller_limits(void **state) {
    fixture_t *f = *state;
    char *text = read_text_for_limits(f);
    size_t len = strlen(text);
    ub_nodecfg_limits_t lim = {0};
    assert_int_equal(ub_nodecfg_parse_limits(&f->cfg, text, len, "t2.json", &lim, f->err, sizeof f->err), UB_OK);
    lim.max_entities = 2;
    assert_int_equal(ub_nodecfg_parse_limits(&f->cfg, text, len, "t2.json", &lim, f->err, sizeof f->err),
                     UB_ERR_CONFIG);
    assert_non_null(strstr(f->err, "field 'entities[2]': too many entities: this build holds 2 (raise "));
    lim.max_entities = 0;
    lim.max_links_per_entity = 3;
    assert_int_equal(ub_nodecfg_parse_limits(&f->cfg, text, len, "t2.json", &lim, f->err, sizeof f->err),
                     UB_ERR_CONFIG);
    assert_non_null(strstr(f->err, "entity 'rmax1ob1', field 'links[3]': too many links: at most 3 per entity"));
    lim.max_links_per_entity = UB_MAX_LINKS_PER_ENTITY + 1;
    assert_int_equal(ub_nodecfg_parse_limits(&f->cfg, text, len, "t2.json", &lim, f->err, sizeof f->err),
                     UB_ERR_RANGE);
    assert_non_null(strstr(f->err, "limits: max_links_per_entity "));
    ub_nodecfg_build_limits(&lim);
    assert_int_equal(lim.max_entities, UB_MAX_ENTITIES);
    assert_int_equal(lim.max_port_params, UB_NODECFG_MAX_PORT_PARAMS);
}


/* Every file in the shared corpus is rejected with exactly the message in its .expect file. */
static void test_shared_bad_configs(void **state) {
    fixture_t *f = *state;
    DIR *dir = opendir(CASES_DIR);
    assert_non_null(dir);
    int checked = 0, mismatches = 0;
    struct dirent *ent;
    while ((ent = readdir(dir)) != NULL) {
        size_t n = strlen(ent->d_name);
        if (n < 6 || strcmp(ent->d_name + n - 5, ".json") != 0) continue;
        char path[512], expect_path[512], expected[UB_NODECFG_ERR_LEN + 8];
        snprintf(path, sizeof path, CASES_DIR "/%s", ent->d_name);
        snprintf(expect_path, sizeof expect_path, CASES_DIR "/%.*s.expect", (int)(n - 5), ent->d_name);
        if (read_text(expect_path, expected, sizeof expected) == NULL) fail_msg("missing %s", expect_path);
        int rc = ub_nodecfg_load_file(&f->cfg, path, f->text, sizeof f->text, f->err, sizeof f->err);
        if (rc != UB_ERR_CONFIG || strcmp(f->err, expected) != 0) {
            print_error("%s\n  rc:       %s\n  got:      %s\n  expected: %s\n", path, ub_strerror(rc), f->err,
                        expected);
            mismatches++;
        }
        for (size_t i = 0; i < sizeof f->cfg; i++) /* a failed parse leaves nothing behind */
            if (((const unsigned char *)&f->cfg)[i] != 0) fail_msg("%s: cfg not zeroed after error", path);
        checked++;
    }
    closedir(dir);
    assert_int_equal(mismatches, 0);
    assert_true(checked >= 60); /* the corpus is there and was read */
}

static void test_mask_hex_helpers(void **state) {
    (void)state;
    uint8_t m = 0xFF;
    char buf[11];
    assert_int_equal(ub_link_mask_parse("0x00000110", &m), UB_OK);
    assert_int_equal(m, 0x06);
    assert_int_equal(ub_link_mask_parse("0x000000011", &m), UB_OK); /* Figure 8's nine-digit spelling */
    assert_int_equal(m, 0x03);
    assert_int_equal(ub_link_mask_parse("0X1", &m), UB_OK);
    assert_int_equal(m, 0x01);
    assert_int_equal(ub_link_mask_parse("0x10000000", &m), UB_OK);
    assert_int_equal(m, 0x80);
    ub_link_mask_format(0x06, buf);
    assert_string_equal(buf, "0x00000110");
    ub_link_mask_format(0x03, buf);
    assert_string_equal(buf, "0x00000011");
    for (int v = 0; v < 256; v++) {
        ub_link_mask_format((uint8_t)v, buf);
        assert_int_equal(ub_link_mask_parse(buf, &m), UB_OK);
        assert_int_equal(m, v);
    }
    const char *bad[] = {"", "0x", "110", "0x2", "0x0000000g", "0x100000000", "x0001", "0x00000000000000001"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        m = 0x5A;
        assert_true(ub_link_mask_parse(bad[i], &m) < 0);
        assert_int_equal(m, 0x5A); /* untouched on error */
    }
    assert_int_equal(ub_link_mask_parse(NULL, &m), UB_ERR_INVAL);
}

static void test_ports_reserved_section(void **state) {
    fixture_t *f = *state;
    parse_ok(f, "{\"entities\": [{\"name\": \"rmax1ob1\", \"links\": [\"onboardPortIPC\"]}],\n"
                " \"hosts\": [\"rmax1ob1\"],\n"
                " \"ports\": {\"onboardPortIPC\": {\"transport\": \"tcp\", \"connect\": \"127.0.0.1:5001\",\n"
                "   \"retry_ms\": 500, \"nodelay\": true},\n"
                "   \"rmax1ob1:onboardPortIPC\": {\"transport\": \"mem\"}}}");
    const ub_nodecfg_t *c = &f->cfg;
    assert_int_equal(c->host_count, 1);
    assert_int_equal(c->port_count, 2);
    assert_string_equal(c->ports[0].name, "onboardPortIPC");
    assert_string_equal(c->ports[0].transport, "tcp");
    assert_int_equal(c->ports[0].param_count, 3);
    assert_string_equal(c->ports[0].params[0].key, "connect");
    assert_string_equal(c->ports[0].params[0].value, "127.0.0.1:5001");
    assert_string_equal(c->ports[0].params[1].value, "500");
    assert_string_equal(c->ports[0].params[2].value, "true");
    assert_int_equal(c->ports[0].line, 3);
    assert_string_equal(c->ports[1].name, "rmax1ob1:onboardPortIPC");
    assert_int_equal(c->ports[1].line, 5);
}

static void test_string_escapes_decode(void **state) {
    fixture_t *f = *state;
    parse_ok(f, "{\"system\": \"caf\\u00e9 \\ud83d\\ude81\", \"entities\": [{\"name\": \"\\u0067cs1\"}],"
                " \"hosts\": [\"gcs\\u0031\"]}");
    assert_string_equal(f->cfg.system, "caf\xc3\xa9 \xf0\x9f\x9a\x81");
    assert_string_equal(f->cfg.entities[0].name, "gcs1");
    assert_int_equal(f->cfg.host_count, 1);
    /* An escaped NUL must not shorten a name into a valid one. */
    assert_parse_error(f, "{\"entities\": [{\"name\": \"gcs1\\u0000x\"}]}",
                       "inline.json:1: field 'entities[0].name': entity names are 1 to 12 characters from "
                       "A-Z a-z 0-9 _ . - (the name is the 12-byte entity ID)");
}

/* Capacities: a config larger than the build holds is refused with a clear
 * message; error text is cut to the caller's buffer; file buffer too small. */
static void test_capacity_and_buffers(void **state) {
    fixture_t *f = *state;
    char small[24];
    memset(small, 'Z', sizeof small);
    int rc = ub_nodecfg_load_file(&f->cfg, CASES_DIR "/entities_too_many.json", f->text, sizeof f->text, small, 16);
    assert_int_equal(rc, UB_ERR_CONFIG);
    assert_int_equal(strlen(small), 15);       /* truncated and terminated */
    assert_int_equal(small[16], 'Z');          /* nothing written past err_cap */
    rc = ub_nodecfg_load_file(&f->cfg, "examples/configs/table2.json", f->text, 100, f->err, sizeof f->err);
    assert_int_equal(rc, UB_ERR_NOSPACE);
    assert_string_equal(f->err,
                        "examples/configs/table2.json: file is larger than the 100-byte buffer given to "
                        "ub_nodecfg_load_file");
    rc = ub_nodecfg_load_file(&f->cfg, "examples/configs/none.json", f->text, sizeof f->text, f->err, sizeof f->err);
    assert_int_equal(rc, UB_ERR_IO);
    assert_string_equal(f->err, "examples/configs/none.json: cannot open: No such file or directory");
    assert_int_equal(ub_nodecfg_parse(NULL, "{}", 2, "x", f->err, sizeof f->err), UB_ERR_INVAL);
    assert_int_equal(ub_nodecfg_parse(&f->cfg, "{}", 2, "x", NULL, 0), UB_ERR_CONFIG); /* no message wanted */
}

/* Every proper prefix of a valid file is malformed; none may read past its end
 * (the text is copied into an exact-size heap block so ASan sees overreads). */
static void test_every_truncation_rejected(void **state) {
    fixture_t *f = *state;
    size_t len = strlen(read_text("examples/configs/table2.json", f->text, sizeof f->text));
    assert_true(len > 500);
    for (size_t cut = 0; cut < len; cut++) {
        char *copy = malloc(cut + 1);
        assert_non_null(copy);
        memcpy(copy, f->text, cut);
        int rc = ub_nodecfg_parse(&f->cfg, copy, cut, "cut.json", f->err, sizeof f->err);
        free(copy);
        if (rc != UB_ERR_CONFIG) fail_msg("prefix of %zu bytes: %s", cut, ub_strerror(rc));
        assert_memory_equal(f->err, "cut.json:", 9);
    }
}

/* Seeded random byte mutations: never a crash or overread; every result is a
 * clean accept or a located error. Deterministic (xorshift, fixed seed). */
static void test_random_mutations(void **state) {
    fixture_t *f = *state;
    char original[TEXT_CAP];
    size_t len = strlen(read_text("examples/configs/table2.json", original, sizeof original));
    uint32_t x = 0x2005u;
    int accepted = 0;
    const char alphabet[] = "{}[]\",:0x1\\u 9-eE.tnfa\n";
    for (int round = 0; round < 3000; round++) {
        char *copy = malloc(len);
        assert_non_null(copy);
        memcpy(copy, original, len);
        int edits = 1 + round % 4;
        for (int k = 0; k < edits; k++) {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            size_t at = x % len;
            copy[at] = (x >> 24) & 1 ? (char)(x >> 16) : alphabet[(x >> 16) % (sizeof alphabet - 1)];
        }
        int rc = ub_nodecfg_parse(&f->cfg, copy, len, "m.json", f->err, sizeof f->err);
        free(copy);
        if (rc == UB_OK)
            accepted++;
        else if (rc != UB_ERR_CONFIG || strncmp(f->err, "m.json:", 7) != 0)
            fail_msg("round %d: rc %s, '%s'", round, ub_strerror(rc), f->err);
    }
    assert_true(accepted < 3000); /* mutations did reach the checks */
}


/* ---- ub_nodecfg_apply ---- */

static const ub_catalogue_t empty_catalogue = {
    .name = "empty", .id_scheme = UB_ID_SCHEME_PAPER, .abi_version = UB_CATALOGUE_ABI_VERSION,
};

static int node_entity(const ub_node_t *node, const char *name) {
    uint8_t id[UB_ENTITY_ID_LEN];
    assert_int_equal(ub_entity_id(name, id), UB_OK);
    return ub_node_find_entity(node, id);
}

static void apply_ok(fixture_t *f) {
    assert_int_equal(ub_node_init(&f->node, &empty_catalogue, NULL), UB_OK);
    int rc = ub_nodecfg_apply(&f->cfg, &f->node, f->err, sizeof f->err);
    if (rc != UB_OK) fail_msg("%s: %s", ub_strerror(rc), f->err);
}

static void assert_apply_error(fixture_t *f, const char *expected) {
    assert_int_equal(ub_node_init(&f->node, &empty_catalogue, NULL), UB_OK);
    assert_int_equal(ub_nodecfg_apply(&f->cfg, &f->node, f->err, sizeof f->err), UB_ERR_CONFIG);
    assert_string_equal(f->err, expected);
}

/* Each of the four HITL processes gets its entity with the published masks and
 * its links; the other three are known remote entities without links here. */
static void test_apply_table2_each_node(void **state) {
    fixture_t *f = *state;
    const char *nodes[] = {"primary", "secondary", "backup", "gcs"};
    for (int n = 0; n < 4; n++) {
        load_ok(f, "examples/configs/table2.json");
        assert_int_equal(ub_nodecfg_select_node(&f->cfg, nodes[n], f->err, sizeof f->err), UB_OK);
        apply_ok(f);
        const ub_nodecfg_entity_t *hosted = &f->cfg.entities[f->cfg.hosts[0]];
        int self = node_entity(&f->node, hosted->name);
        assert_true(self >= 0);
        for (int j = 0; j < f->cfg.entity_count; j++) {
            int dest = node_entity(&f->node, f->cfg.entities[j].name);
            uint8_t mask = 0xFF;
            assert_true(dest >= 0);
            assert_int_equal(ub_node_get_mask(&f->node, self, dest, &mask), UB_OK);
            assert_int_equal(mask, hosted->mask[j]);
        }
        for (int i = 0; i < hosted->link_count; i++) {
            int link = ub_node_find_link(&f->node, hosted->links[i]);
            assert_true(link >= 0);
            assert_int_equal(ub_node_link(&f->node, link)->index, i);
        }
    }
    /* The GCS node: rmax1ob1's links are not created there. */
    assert_int_equal(ub_node_find_link(&f->node, "onboardPortIPC"), UB_ERR_NOTFOUND);
    uint8_t mask = 0;
    assert_int_equal(ub_node_get_mask(&f->node, node_entity(&f->node, "gcs1"), node_entity(&f->node, "fcs20"), &mask),
                     UB_OK);
    assert_int_equal(mask, 0x03); /* 0x00000011: via rmax1ob1 over both datalinks */
}

/* Table 1's node A hosts Entities 0 and 1 (Figure 9): both local, e0Toe1/e1Toe0 distinct links. */
static void test_apply_table1_node_a(void **state) {
    fixture_t *f = *state;
    load_ok(f, "examples/configs/table1.json");
    assert_int_equal(ub_nodecfg_select_node(&f->cfg, "A", f->err, sizeof f->err), UB_OK);
    apply_ok(f);
    int e0 = node_entity(&f->node, "entity0"), e1 = node_entity(&f->node, "entity1");
    int e3 = node_entity(&f->node, "entity3");
    uint8_t mask = 0;
    assert_int_equal(ub_node_get_mask(&f->node, e0, e3, &mask), UB_OK);
    assert_int_equal(mask, 0x06); /* 0x00000110: e0Toe3a and e0Toe3b */
    assert_int_equal(ub_node_get_mask(&f->node, e1, e0, &mask), UB_OK);
    assert_int_equal(mask, 0x01);
    assert_int_equal(ub_node_link(&f->node, ub_node_find_link(&f->node, "e1Toe2"))->index, 1);
    assert_int_equal(ub_node_find_link(&f->node, "e2Toe1"), UB_ERR_NOTFOUND);
}

static void test_apply_errors(void **state) {
    fixture_t *f = *state;
    load_ok(f, "examples/configs/table1.json");
    assert_apply_error(f, "examples/configs/table1.json: field 'hosts': this process hosts no entity: list them in "
                          "'hosts' or select one of 'nodes'");
    /* Table 2's fcs20 and rmax1ob1 both call their link 0 onboardPortDatalink1: fine in
     * separate processes, a clash when one process hosts both. */
    parse_ok(f, "{\"entities\": [\n"
                " {\"name\": \"rmax1ob1\", \"links\": [\"onboardPortDatalink1\"]},\n"
                " {\"name\": \"fcs20\", \"links\": [\"onboardPortDatalink1\"]}\n"
                "], \"hosts\": [\"rmax1ob1\", \"fcs20\"]}");
    assert_apply_error(f, "inline.json:3: entity 'fcs20', field 'links[0]': link 'onboardPortDatalink1' already "
                          "exists in this node (another hosted entity has a link of that name; rename one)");
    parse_ok(f, "{\"entities\": [\n"
                " {\"name\": \"a\", \"links\": [\"a0\", \"a1\", \"a2\", \"a3\", \"a4\", \"a5\", \"a6\", \"a7\"]},\n"
                " {\"name\": \"b\", \"links\": [\"b0\", \"b1\", \"b2\", \"b3\", \"b4\", \"b5\", \"b6\", \"b7\"]},\n"
                " {\"name\": \"c\", \"links\": [\"c0\"]}\n"
                "], \"hosts\": [\"a\", \"b\", \"c\"]}");
    char expected[UB_NODECFG_ERR_LEN];
    snprintf(expected, sizeof expected,
             "inline.json:4: entity 'c', field 'links[0]': the node holds at most %d links in all (raise "
             "UB_MAX_NODE_LINKS in ub_config.h)", UB_MAX_NODE_LINKS);
    if (UB_MAX_NODE_LINKS == 16) assert_apply_error(f, expected);
    /* Applying twice: every entity is already there. */
    load_ok(f, "examples/configs/table2.json");
    assert_int_equal(ub_nodecfg_select_node(&f->cfg, "gcs", f->err, sizeof f->err), UB_OK);
    apply_ok(f);
    assert_int_equal(ub_nodecfg_apply(&f->cfg, &f->node, f->err, sizeof f->err), UB_ERR_CONFIG);
    assert_string_equal(f->err, "examples/configs/table2.json:4: entity 'rmax1ob1', field 'name': the node already "
                                "has an entity of this name");
    assert_int_equal(ub_nodecfg_apply(NULL, &f->node, f->err, sizeof f->err), UB_ERR_INVAL);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_table1_as_published, setup, teardown),
        cmocka_unit_test_setup_teardown(test_table2_as_published, setup, teardown),
        cmocka_unit_test_setup_teardown(test_hex_and_list_forms_agree, setup, teardown),
        cmocka_unit_test_setup_teardown(test_shared_bad_configs, setup, teardown),
        cmocka_unit_test_setup_teardown(test_mask_hex_helpers, setup, teardown),
        cmocka_unit_test_setup_teardown(test_ports_reserved_section, setup, teardown),
        cmocka_unit_test_setup_teardown(test_string_escapes_decode, setup, teardown),
        cmocka_unit_test_setup_teardown(test_capacity_and_buffers, setup, teardown),
        cmocka_unit_test_setup_teardown(test_every_truncation_rejected, setup, teardown),
        cmocka_unit_test_setup_teardown(test_random_mutations, setup, teardown),
        cmocka_unit_test_setup_teardown(test_apply_table2_each_node, setup, teardown),
        cmocka_unit_test_setup_teardown(test_apply_table1_node_a, setup, teardown),
        cmocka_unit_test_setup_teardown(test_apply_errors, setup, teardown),
        cmocka_unit_test_setup_teardown(test_smaller_limits, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
