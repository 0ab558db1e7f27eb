/*
 * Fuzz harness: the configuration loader (ub_nodecfg.h) and the port specs of its "ports" section
 * (ub_ports.h), on arbitrary text (issue #17 item 6).
 *
 * Every file is parsed; a valid one is then selected node by node, applied to a node over the flight-software
 * catalogue, its masks read back, and every port entry converted to a spec and formatted back. Properties:
 * no crash, no memory error (ASan/UBSan); every error message is one clean line that says where
 * ("fuzz.json:<line>: ...") and holds printable ASCII only (docs/config-format.md promises that text from
 * the file is quoted back only when printable, else as '?'); a port spec that converts formats back into
 * text that parses to the same spec.
 */
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "flightsw.h"
#include "fuzz_util.h"
#include "ub/ub_node.h"
#include "ub/ub_nodecfg.h"
#include "ub/ub_ports.h"

static ub_nodecfg_t g_cfg, g_sel;
static ub_node_t g_node;

static void check_message(const char *err, const char *what) {
    size_t n = strlen(err);
    FUZZ_CHECK(n > 0, "%s: empty error message", what);
    for (size_t i = 0; i < n; i++) {
        unsigned char c = (unsigned char)err[i];
        FUZZ_CHECK(c >= 0x20 && c < 0x7f, "%s: byte 0x%02x at %zu of the message: %s", what, c, i, err);
    }
}

int LLVMFuzzerInitialize(int *argc, char ***argv) {
    (void)argc;
    (void)argv;
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    char err[UB_NODECFG_ERR_LEN];
    err[0] = '\0';
    if (ub_nodecfg_parse(&g_cfg, (const char *)data, size, "fuzz.json", err, sizeof err) != UB_OK) {
        check_message(err, "parse");
        FUZZ_CHECK(strncmp(err, "fuzz.json:", 10) == 0, "message does not say where: %s", err);
        return 0;
    }
    /* Each node of the file, then a name it does not have. */
    for (unsigned k = 0; k <= g_cfg.node_count; k++) {
        g_sel = g_cfg;
        const char *name = k < g_cfg.node_count ? g_cfg.nodes[k].name : "no-such-node";
        if (ub_nodecfg_select_node(&g_sel, name, err, sizeof err) != UB_OK) {
            check_message(err, "select");
            continue;
        }
        FUZZ_CHECK(ub_node_init(&g_node, &flightsw_catalogue, NULL) == UB_OK, "node init");
        if (ub_nodecfg_apply(&g_sel, &g_node, err, sizeof err) != UB_OK) check_message(err, "apply");
    }
    for (unsigned i = 0; i < g_cfg.entity_count; i++) {
        for (unsigned j = 0; j < g_cfg.entity_count; j++) {
            int m = ub_nodecfg_mask(&g_cfg, g_cfg.entities[i].name, g_cfg.entities[j].name);
            FUZZ_CHECK(m < 0 || (i != j || m == 0), "mask to itself is %d", m);
        }
    }
    for (unsigned p = 0; p < g_cfg.port_count; p++) {
        ub_port_spec_t spec, again;
        if (ub_port_spec_from_config(&g_cfg.ports[p], g_cfg.source, &spec, err, sizeof err) != UB_OK) {
            check_message(err, "port");
            continue;
        }
        char text[256];
        ub_port_spec_format(&spec, text, sizeof text);
        if (spec.kind == UB_PORT_MEM) continue;
        FUZZ_CHECK(ub_port_spec_parse(text, &again, err, sizeof err) == UB_OK, "'%s' does not parse back: %s", text, err);
        FUZZ_CHECK(spec.kind == again.kind && strcmp(spec.host, again.host) == 0 && spec.port == again.port
                       && strcmp(spec.peer_host, again.peer_host) == 0 && spec.peer_port == again.peer_port
                       && strcmp(spec.device, again.device) == 0 && spec.baud == again.baud,
                   "'%s' parses back to another spec", text);
    }
    return 0;
}

/* Seeds: the shipped configurations and one of each shape; fuzz/run.sh adds tests/unit/config_cases. */
void ub_fuzz_write_seeds(const char *dir) {
    static const char small[] =
        "{\"system\":\"s\",\"entities\":[{\"name\":\"a\",\"links\":[\"la\",\"lb\"],\"linktoentity\":{\"b\":\"0x11\"}},"
        "{\"name\":\"b\",\"links\":[\"lc\"],\"linktoentity\":[[0],[]]}],\"hosts\":[\"a\"],"
        "\"nodes\":{\"n1\":[\"a\"],\"n2\":[\"b\"]},"
        "\"ports\":{\"la\":{\"transport\":\"udp\",\"bind\":\"127.0.0.1:0\",\"peer\":\"127.0.0.1:9\"},"
        "\"b:lc\":{\"transport\":\"tcp\",\"connect\":\"localhost:5001\"},"
        "\"lb\":{\"transport\":\"serial\",\"device\":\"/dev/ttyUSB0\",\"baud\":57600}}}";
    fuzz_write_seed(dir, "small_all_shapes.json", small, sizeof small - 1);
}
