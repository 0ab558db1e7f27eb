/*
 * Ports (ub_ports.h), the refusals and the per-link impairment knobs: every bad spec text, config entry,
 * link name and open is refused with its one-line message (what to write instead), every API misuse with
 * its code, and a failed software switch either keeps the old transport or says the slot is detached.
 * Real 127.0.0.1 sockets hold the addresses that make an open fail; real config text feeds the config form.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "support/ub_test_pair.h"
#include "ub/ub_nodecfg.h"
#include "ub/ub_ports.h"
#include "ub/ub_pubsub.h"

/* Parses `text` with the built-in registry and expects a refusal whose message contains `want`. */
static void refused(const char *text, const char *want) {
    ub_port_spec_t s;
    char err[UB_PORTS_ERR_LEN] = "";
    assert_int_equal(ub_port_spec_parse(text, &s, err, sizeof err), UB_ERR_INVAL);
    if (strstr(err, want) == NULL) fail_msg("spec '%s': message '%s' lacks '%s'", text, err, want);
}

static void test_spec_text_refusals(void **state) {
    (void)state;
    ub_port_spec_t s;
    char err[UB_PORTS_ERR_LEN];
    assert_int_equal(ub_port_spec_parse(NULL, &s, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_port_spec_parse("mem", NULL, err, sizeof err), UB_ERR_INVAL);
    refused("", "port spec must be 1 to 255 characters: TRANSPORT[:KEY=VALUE,...], e.g. udp:");
    char longspec[300];
    memset(longspec, 'a', sizeof longspec - 1);
    longspec[sizeof longspec - 1] = '\0';
    refused(longspec, "port spec must be 1 to 255 characters");
    refused("xmpp:host=a", "unknown transport 'xmpp' (expected udp, tcp, serial, legacy or mem, e.g. ");
    refused("udp:bind", "'bind' is not KEY=VALUE (e.g. ");
    refused("udp:=127.0.0.1:5", "'=127.0.0.1:5' is not KEY=VALUE");
    refused("udp:bind=127.0.0.1:0,encoding=compact,encoding=full", "'encoding=full': given twice: give it once");
    refused("udp:bind=127.0.0.1:0,encoding=huge", "'encoding=huge': use full (64-byte headers, the default) or compact");
    refused("udp:bind=127.0.0.1:0,mtu=63", "'mtu=63': give the largest frame the link carries, in bytes, from 64 to");
    refused("udp:bind=127.0.0.1:0,mtu=65536", "'mtu=65536': give the largest frame");
    refused("udp:bind=127.0.0.1:0,mtu=lots", "'mtu=lots': give the largest frame");
    refused("udp:bind=127.0.0.1:0,mtu=64,mtu=128", "'mtu=128': given twice: give it once");
    refused("udp:bind=127.0.0.1:0,colour=red", "unknown parameter 'colour' for udp (expected: ");
    refused("udp:bind=127.0.0.1:0,colour=red", ", encoding, mtu, prio)");
    /* mem takes no parameters and has no wire parameters to offer. */
    assert_int_equal(ub_port_spec_parse("mem:mtu=100", &s, err, sizeof err), UB_ERR_INVAL);
    assert_string_equal(err, "unknown parameter 'mtu' for mem (expected: none)");
    /* Each wire parameter's edge values are taken. */
    assert_int_equal(ub_port_spec_parse("udp:bind=127.0.0.1:0,mtu=64,encoding=full", &s, err, sizeof err), UB_OK);
    assert_int_equal(s.mtu, 64);
    assert_int_equal(s.encoding, UB_PORT_ENCODING_FULL);
    assert_int_equal(ub_port_spec_parse("udp:bind=127.0.0.1:0,mtu=65535", &s, err, sizeof err), UB_OK);
    assert_int_equal(s.mtu, 65535);
    /* No message buffer: still refused, nothing written. */
    assert_int_equal(ub_port_spec_parse("", &s, NULL, 0), UB_ERR_INVAL);
    err[0] = 'x';
    assert_int_equal(ub_port_spec_parse("xmpp", &s, err, 0), UB_ERR_INVAL);
    assert_int_equal(err[0], 'x');
    /* The set forms refuse a missing set. */
    assert_int_equal(ub_ports_spec_parse(NULL, "mem", &s, err, sizeof err), UB_ERR_INVAL);
}

static void test_arg_refusals(void **state) {
    (void)state;
    ub_port_spec_t s;
    char err[UB_PORTS_ERR_LEN], name[64];
    assert_int_equal(ub_port_arg_parse(NULL, name, sizeof name, &s, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_port_arg_parse("a=mem", NULL, sizeof name, &s, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_port_arg_parse("a=mem", name, 0, &s, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_port_arg_parse("a=mem", name, sizeof name, NULL, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_port_arg_parse("linkonly", name, sizeof name, &s, err, sizeof err), UB_ERR_INVAL);
    assert_string_equal(err, "'linkonly': expected LINK=SPEC, e.g. onboardPortIPC=tcp:connect=127.0.0.1:5001");
    assert_int_equal(ub_port_arg_parse("=udp:bind=127.0.0.1:0", name, sizeof name, &s, err, sizeof err), UB_ERR_INVAL);
    assert_non_null(strstr(err, "expected LINK=SPEC"));
    /* A spec without its link name (each transport that opens), not read as link "udp:bind". */
    assert_int_equal(ub_port_arg_parse("udp:bind=127.0.0.1:0", name, sizeof name, &s, err, sizeof err), UB_ERR_INVAL);
    assert_non_null(strstr(err, "expected LINK=SPEC"));
    assert_int_equal(ub_port_arg_parse("serial:device=/dev/x", name, sizeof name, &s, err, sizeof err), UB_ERR_INVAL);
    assert_non_null(strstr(err, "expected LINK=SPEC"));
    /* Too long for the config's key, and too long for the caller's buffer. */
    char arg[128];
    snprintf(arg, sizeof arg, "%0*d=mem", UB_NODECFG_PORT_KEY_MAX + 1, 7);
    assert_int_equal(ub_port_arg_parse(arg, name, sizeof name, &s, err, sizeof err), UB_ERR_INVAL);
    char want[96];
    snprintf(want, sizeof want, "is too long (at most %d characters)", UB_NODECFG_PORT_KEY_MAX);
    assert_non_null(strstr(err, want));
    char small[6];
    assert_int_equal(ub_port_arg_parse("radio1=mem", small, sizeof small, &s, err, sizeof err), UB_ERR_INVAL);
    assert_string_equal(err, "link name 'radio1=mem...' is too long (at most 5 characters)");
    assert_int_equal(ub_port_arg_parse("radio=mem", small, sizeof small, &s, err, sizeof err), UB_OK);
    assert_string_equal(small, "radio");
    /* The spec's own message, prefixed with the link. */
    assert_int_equal(ub_port_arg_parse("radio=udp:bind=127.0.0.1:0,mtu=1", name, sizeof name, &s, err, sizeof err),
                     UB_ERR_INVAL);
    assert_non_null(strstr(err, "port 'radio': 'mtu=1': give the largest frame"));
    assert_int_equal(ub_ports_arg_parse(NULL, "a=mem", name, sizeof name, &s, err, sizeof err), UB_ERR_INVAL);
}

static void test_spec_format_edges(void **state) {
    (void)state;
    char out[16];
    ub_port_spec_format(NULL, NULL, 0); /* nothing to write into: no effect, no crash */
    memcpy(out, "keep", 5);
    ub_port_spec_format(NULL, out, 0);
    assert_string_equal(out, "keep");
    ub_port_spec_format(NULL, out, sizeof out);
    assert_string_equal(out, "");
    ub_port_spec_t none;
    memset(&none, 0, sizeof none);
    ub_port_spec_format(&none, out, sizeof out);
    assert_string_equal(out, "none");
    assert_string_equal(ub_port_spec_transport(&none), "none");
    assert_string_equal(ub_port_spec_transport(NULL), "none");
    ub_port_spec_t s;
    char err[UB_PORTS_ERR_LEN], text[128];
    assert_int_equal(ub_port_spec_parse("udp:bind=127.0.0.1:5001,encoding=compact,mtu=300", &s, err, sizeof err),
                     UB_OK);
    assert_string_equal(ub_port_spec_transport(&s), "udp");
    ub_port_spec_format(&s, text, sizeof text);
    assert_string_equal(text, "udp:bind=127.0.0.1:5001,encoding=compact,mtu=300");
    /* Cut: ends in "..." wherever the cut falls (driver text, encoding, mtu). */
    ub_port_spec_format(&s, out, sizeof out);
    assert_int_equal(strlen(out), sizeof out - 1);
    assert_string_equal(out + sizeof out - 4, "...");
    char mid[48];
    ub_port_spec_format(&s, mid, 30); /* inside ",encoding=compact" */
    assert_string_equal(mid, "udp:bind=127.0.0.1:5001,en...");
    ub_port_spec_format(&s, mid, 44); /* inside ",mtu=300" */
    assert_string_equal(mid, "udp:bind=127.0.0.1:5001,encoding=compact...");
    char tiny[3];
    ub_port_spec_format(&s, tiny, sizeof tiny); /* too small for "...": cut as snprintf cuts */
    assert_string_equal(tiny, "ud");
    /* The legacy kinds' words, and a kind out of range. */
    assert_string_equal(ub_port_kind_transport(UB_PORT_TCP_LISTEN), "tcp");
    assert_string_equal(ub_port_kind_transport(UB_PORT_SERIAL), "serial");
    assert_string_equal(ub_port_kind_transport((ub_port_kind_t)77), "none");
}

static const char k_bad_config[] =
    "{\n"
    "  \"entities\": [{\"name\": \"pub\", \"links\": [\"pubPort\"]}],\n"
    "  \"ports\": {\n"
    "    \"pubPort\": {\"transport\": \"carrierpigeon\"},\n"
    "    \"radio\": {\"transport\": \"udp\", \"bind\": \"127.0.0.1:0\", \"encoding\": \"tiny\"},\n"
    "    \"wire\": {\"transport\": \"tcp\", \"mtu\": 100}\n"
    "  }\n"
    "}\n";

static void test_config_refusals(void **state) {
    (void)state;
    ub_nodecfg_t *cfg = calloc(1, sizeof *cfg);
    assert_non_null(cfg);
    char err[UB_PORTS_ERR_LEN];
    assert_int_equal(ub_nodecfg_parse(cfg, k_bad_config, strlen(k_bad_config), "bad.json", err, sizeof err), UB_OK);
    assert_int_equal(cfg->port_count, 3);
    ub_port_spec_t s;
    assert_int_equal(ub_port_spec_from_config(NULL, "x", &s, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_port_spec_from_config(&cfg->ports[0], "x", NULL, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_port_spec_from_config(&cfg->ports[0], cfg->source, &s, err, sizeof err), UB_ERR_CONFIG);
    assert_non_null(strstr(err, "bad.json:4: port 'pubPort', field 'transport': unknown transport 'carrierpigeon' "
                                "(expected udp, tcp, serial, legacy or mem"));
    assert_int_equal(ub_port_spec_from_config(&cfg->ports[1], cfg->source, &s, err, sizeof err), UB_ERR_CONFIG);
    assert_non_null(strstr(err, "bad.json:5: port 'radio', field 'encoding': 'encoding=tiny': use full"));
    /* No source given: the message still says where, as "<config>". */
    assert_int_equal(ub_port_spec_from_config(&cfg->ports[2], NULL, &s, err, sizeof err), UB_ERR_CONFIG);
    assert_true(strncmp(err, "<config>:6: port 'wire': ", strlen("<config>:6: port 'wire': ")) == 0);
    /* The set's form, and the whole config: refused before anything opens. */
    pair_t *p = pair_new(NULL);
    ub_ports_t *ports = calloc(1, sizeof *ports);
    assert_non_null(ports);
    assert_int_equal(ub_ports_init(NULL, p->pub_node), UB_ERR_INVAL);
    assert_int_equal(ub_ports_init(ports, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_ports_init(ports, p->pub_node), UB_OK);
    assert_int_equal(ub_ports_spec_from_config(NULL, &cfg->ports[0], "x", &s, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_ports_open_config(NULL, cfg, 0, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_ports_open_config(ports, NULL, 0, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_ports_open_config(ports, cfg, 0, err, sizeof err), UB_ERR_CONFIG);
    assert_non_null(strstr(err, "bad.json:4:"));
    assert_null(ub_ports_find(ports, "pubPort"));
    free(ports);
    pair_free(p);
    free(cfg);
}

/* A real UDP socket on 127.0.0.1 holding an ephemeral port: what makes a port's open fail (and a stranger). */
static int hold_port(uint16_t *port) {
    int fd = socket(AF_INET, SOCK_DGRAM, 0);
    assert_true(fd >= 0);
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = 0};
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    assert_int_equal(bind(fd, (struct sockaddr *)&a, sizeof a), 0);
    socklen_t len = sizeof a;
    assert_int_equal(getsockname(fd, (struct sockaddr *)&a, &len), 0);
    *port = ntohs(a.sin_port);
    return fd;
}

typedef struct ports_env {
    pair_t *p;
    ub_ports_t *ports;
} ports_env_t;

static ports_env_t env_new(void) {
    ports_env_t e = {.p = pair_new(NULL), .ports = calloc(1, sizeof *e.ports)};
    assert_non_null(e.ports);
    assert_int_equal(ub_ports_init(e.ports, e.p->pub_node), UB_OK);
    return e;
}

static void env_free(ports_env_t *e) {
    ub_ports_close_all(e->ports);
    free(e->ports);
    pair_free(e->p);
}

static void test_open_refusals(void **state) {
    (void)state;
    ports_env_t e = env_new();
    char err[UB_PORTS_ERR_LEN], spec[96], name[64];
    ub_port_spec_t s;
    assert_int_equal(ub_port_spec_parse("udp:bind=127.0.0.1:0", &s, err, sizeof err), UB_OK);
    assert_int_equal(ub_ports_open(NULL, "pubPort", &s, 0, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_ports_open(e.ports, NULL, &s, 0, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_ports_open(e.ports, "pubPort", NULL, 0, err, sizeof err), UB_ERR_INVAL);
    /* Entity-qualified names: the empty entity, one longer than an entity id, and the right owner. */
    assert_int_equal(ub_ports_open(e.ports, ":pubPort", &s, 0, err, sizeof err), UB_ERR_NOTFOUND);
    assert_non_null(strstr(err, "port ':pubPort': this node has no such link"));
    char longname[64];
    snprintf(longname, sizeof longname, "%0*d:pubPort", UB_ENTITY_ID_LEN + 1, 1);
    assert_int_equal(ub_ports_open(e.ports, longname, &s, 0, err, sizeof err), UB_ERR_NOTFOUND);
    assert_int_equal(ub_ports_open(e.ports, "pub:nosuch", &s, 0, err, sizeof err), UB_ERR_NOTFOUND);
    snprintf(name, sizeof name, "%s:pubPort", (const char *)e.p->pub_id);
    assert_int_equal(ub_ports_open(e.ports, name, &s, 0, err, sizeof err), UB_OK);
    assert_non_null(ub_ports_find(e.ports, "pubPort"));
    assert_int_equal(ub_ports_close(e.ports, name), UB_OK);
    assert_null(ub_ports_find(e.ports, "pubPort"));
    assert_int_equal(ub_ports_close(e.ports, "pubPort"), UB_ERR_NOTFOUND);
    assert_int_equal(ub_ports_close(NULL, "pubPort"), UB_ERR_INVAL);
    /* Bad text for a link: the link named, "?" when there is no name. */
    assert_int_equal(ub_ports_open_text(NULL, "pubPort", "mem", 0, err, sizeof err), UB_ERR_INVAL);
    assert_int_equal(ub_ports_open_text(e.ports, "pubPort", "udp:mtu=9", 0, err, sizeof err), UB_ERR_INVAL);
    assert_non_null(strstr(err, "port 'pubPort': 'mtu=9'"));
    assert_int_equal(ub_ports_open_text(e.ports, NULL, "xmpp", 0, err, sizeof err), UB_ERR_INVAL);
    assert_non_null(strstr(err, "port '?': unknown transport 'xmpp'"));

    /* A first open on an address another socket holds: refused with the system's reason, nothing attached. */
    uint16_t held = 0;
    int holder = hold_port(&held);
    snprintf(spec, sizeof spec, "udp:bind=127.0.0.1:%u", (unsigned)held);
    assert_int_equal(ub_ports_open_text(e.ports, "pubPort", spec, 0, err, sizeof err), UB_ERR_IO);
    char want[160];
    snprintf(want, sizeof want, "port 'pubPort': cannot open udp:bind=127.0.0.1:%u: ", (unsigned)held);
    assert_true(strncmp(err, want, strlen(want)) == 0);
    assert_non_null(strstr(err, "(Address already in use)"));
    assert_null(strstr(err, "previous transport"));
    assert_null(ub_ports_find(e.ports, "pubPort"));
    assert_null(ub_node_link(e.p->pub_node, e.p->pub_link)->ops);

    /* A switch to a held address: the old transport is closed to free an address it may hold, the new one still
     * fails: the message does not promise the old transport, and the slot is detached. */
    assert_int_equal(ub_ports_open_text(e.ports, "pubPort", "udp:bind=127.0.0.1:0,mtu=200", 0, err, sizeof err),
                     UB_OK);
    assert_int_equal(ub_node_link(e.p->pub_node, e.p->pub_link)->mtu, 200);
    uint16_t before = 0;
    assert_int_equal(ub_ports_local_port(e.ports, "pubPort", &before), UB_OK);
    assert_int_equal(ub_ports_open_text(e.ports, "pubPort", spec, 0, err, sizeof err), UB_ERR_IO);
    assert_non_null(strstr(err, "(Address already in use)"));
    assert_null(strstr(err, "the previous transport stays in place"));
    assert_null(ub_ports_find(e.ports, "pubPort"));
    assert_null(ub_node_link(e.p->pub_node, e.p->pub_link)->ops);

    /* A switch that fails for another reason than a held address (a serial device that does not exist) keeps
     * the old transport running, and says so. */
    assert_int_equal(ub_ports_open_text(e.ports, "pubPort", "udp:bind=127.0.0.1:0", 0, err, sizeof err), UB_OK);
    assert_int_equal(ub_ports_local_port(e.ports, "pubPort", &before), UB_OK);
    assert_int_equal(ub_ports_open_text(e.ports, "pubPort", "serial:device=/nonexistent/ttyUB0", 0, err, sizeof err),
                     UB_ERR_IO);
    assert_non_null(strstr(err, "port 'pubPort': cannot open serial:device=/nonexistent/ttyUB0"));
    assert_non_null(strstr(err, "; the previous transport stays in place"));
    uint16_t after = 0;
    assert_int_equal(ub_ports_local_port(e.ports, "pubPort", &after), UB_OK);
    assert_int_equal(after, before);
    assert_string_equal(ub_node_link(e.p->pub_node, e.p->pub_link)->ops->kind, "udp");
    assert_int_equal(ub_ports_find(e.ports, "pubPort")->rebinds, 0);
    close(holder);
    env_free(&e);
}

/* API misuse on a set with one UDP port open: each refused with its code, nothing changed. */
static void test_api_refusals(void **state) {
    (void)state;
    ports_env_t e = env_new();
    char err[UB_PORTS_ERR_LEN], text[256];
    assert_int_equal(ub_ports_open_text(e.ports, "pubPort", "udp:bind=127.0.0.1:0,peer=127.0.0.1:9", 0, err,
                                        sizeof err),
                     UB_OK);
    struct pollfd fds[4];
    assert_int_equal(ub_ports_pollfds(NULL, fds, 4), UB_ERR_INVAL);
    assert_int_equal(ub_ports_pollfds(e.ports, NULL, 4), UB_ERR_INVAL);
    assert_int_equal(ub_ports_pollfds(e.ports, fds, -1), UB_ERR_INVAL);
    assert_true(ub_ports_pollfds(e.ports, fds, 0) < 0); /* the driver's refusal: no room for its socket */
    assert_int_equal(ub_ports_pollfds(e.ports, fds, 4), 1);
    assert_int_equal(ub_ports_service(NULL, 0), 0);
    assert_int_equal(ub_ports_poll_timeout(NULL, 0, -5), 0);
    assert_int_equal(ub_ports_poll_timeout(NULL, 0, 30), 30);
    assert_int_equal(ub_ports_poll_timeout(e.ports, 0, 30), 30);
    assert_null(ub_ports_find(NULL, "pubPort"));
    assert_null(ub_ports_state(e.ports, "nosuch", NULL));
    assert_null(ub_ports_state(e.ports, "pubPort", &ub_tcp_driver)); /* another driver's state: not given */
    assert_non_null(ub_ports_state(e.ports, "pubPort", NULL));
    uint16_t port;
    assert_int_equal(ub_ports_local_port(NULL, "pubPort", &port), UB_ERR_INVAL);
    assert_int_equal(ub_ports_local_port(e.ports, "pubPort", NULL), UB_ERR_INVAL);
    assert_int_equal(ub_ports_local_port(e.ports, "nosuch", &port), UB_ERR_NOTFOUND);
    ub_driver_counter_t c[64];
    assert_int_equal(ub_ports_counters(NULL, "pubPort", c, 64), UB_ERR_INVAL);
    assert_int_equal(ub_ports_counters(e.ports, "pubPort", NULL, 1), UB_ERR_INVAL);
    assert_int_equal(ub_ports_counters(e.ports, "nosuch", c, 64), UB_ERR_NOTFOUND);
    int nc = ub_ports_counters(e.ports, "pubPort", c, 64);
    assert_true(nc > 0);
    assert_int_equal(ub_ports_describe(NULL, "pubPort", text, sizeof text), UB_ERR_INVAL);
    assert_int_equal(ub_ports_describe(e.ports, "pubPort", NULL, sizeof text), UB_ERR_INVAL);
    assert_int_equal(ub_ports_describe(e.ports, "pubPort", text, 0), UB_ERR_INVAL);
    assert_int_equal(ub_ports_describe(e.ports, "nosuch", text, sizeof text), UB_ERR_NOTFOUND);
    assert_string_equal(text, "");
    int n = ub_ports_describe(e.ports, "pubPort", text, sizeof text);
    assert_true(n > 0 && (size_t)n == strlen(text));
    assert_true(strncmp(text, "\"udp\":{", 7) == 0);
    assert_int_equal(text[n - 1], '}');
    char cut[12];
    assert_int_equal(ub_ports_describe(e.ports, "pubPort", cut, sizeof cut), UB_ERR_NOSPACE);
    assert_string_equal(cut, "\"udp\":{\"...");
    char three[3];
    assert_int_equal(ub_ports_describe(e.ports, "pubPort", three, sizeof three), UB_ERR_NOSPACE);
    assert_int_equal(strlen(three), 2);
    /* Foreign traffic: UDP takes a handler but writes none; a missing link or set is refused. */
    static const uint8_t bytes[] = {1, 2, 3};
    assert_int_equal(ub_ports_write_foreign(NULL, "pubPort", bytes, 3, 0), UB_ERR_INVAL);
    assert_int_equal(ub_ports_write_foreign(e.ports, "pubPort", NULL, 3, 0), UB_ERR_INVAL);
    assert_int_equal(ub_ports_write_foreign(e.ports, "nosuch", bytes, 3, 0), UB_ERR_NOTFOUND);
    assert_int_equal(ub_ports_write_foreign(e.ports, "pubPort", bytes, 3, 0), UB_ERR_UNSUPPORTED);
    /* Impairment and notices on no set. */
    const ub_impair_params_t loss = {.loss_ppm = 1};
    assert_int_equal(ub_ports_set_impairment(NULL, &loss, 1), UB_ERR_INVAL);
    assert_int_equal(ub_ports_set_link_impairment(NULL, "pubPort", &loss, 1), UB_ERR_INVAL);
    assert_int_equal(ub_ports_set_link_impairment(e.ports, NULL, &loss, 1), UB_ERR_INVAL);
    assert_int_equal(ub_ports_notice(NULL, text, sizeof text), UB_ERR_INVAL);
    assert_int_equal(ub_ports_notice(e.ports, NULL, sizeof text), UB_ERR_INVAL);
    assert_int_equal(ub_ports_notice(e.ports, text, 0), UB_ERR_INVAL);
    assert_int_equal(ub_ports_notice(e.ports, text, sizeof text), 0); /* nothing to report yet */
    ub_ports_close_all(NULL);
    env_free(&e);
}

/* Each impairment parameter alone turns the impairment on (an all-zero set turns it off). */
static void test_each_impairment_param_counts(void **state) {
    (void)state;
    ports_env_t e = env_new();
    char err[UB_PORTS_ERR_LEN];
    assert_int_equal(ub_ports_open_text(e.ports, "pubPort", "udp:bind=127.0.0.1:0,peer=127.0.0.1:9", 0, err,
                                        sizeof err),
                     UB_OK);
    const ub_impair_params_t each[] = {{.loss_ppm = 1}, {.dup_ppm = 1}, {.reorder_ppm = 1}, {.delay_ms = 1},
                                       {.jitter_ms = 1}, {.rate_Bps = 1000}, {.mtu = 100}};
    const ub_link_t *link = ub_node_link(e.p->pub_node, e.p->pub_link);
    for (size_t i = 0; i < sizeof each / sizeof each[0]; i++) {
        assert_int_equal(ub_ports_set_impairment(e.ports, &each[i], 3), UB_OK);
        if (strcmp(link->ops->kind, "impair") != 0) fail_msg("parameter %zu alone did not impair the port", i);
        const ub_impair_params_t zero = {0};
        assert_int_equal(ub_ports_set_impairment(e.ports, &zero, 3), UB_OK);
        assert_string_equal(link->ops->kind, "udp");
        assert_int_equal(ub_ports_set_link_impairment(e.ports, "pubPort", &each[i], 4), UB_OK);
        assert_string_equal(link->ops->kind, "impair");
        assert_int_equal(ub_ports_set_link_impairment(e.ports, "pubPort", &zero, 4), UB_OK); /* off: node-wide off */
        assert_string_equal(link->ops->kind, "udp");
        assert_false(ub_ports_find(e.ports, "pubPort")->impaired);
    }
    env_free(&e);
}

/* A delayed copy is due: the loop's timeout says when; a reseed changes the PRNG; a close counts what is
 * still queued as refused (inner_errors), so the impairment's books balance. */
static void test_impairment_queue_seed_and_close(void **state) {
    (void)state;
    ports_env_t e = env_new();
    char err[UB_PORTS_ERR_LEN];
    ub_ports_t *ports = e.ports;
    assert_int_equal(ub_ports_open_text(ports, "pubPort", "udp:bind=127.0.0.1:0,peer=127.0.0.1:9", 0, err,
                                        sizeof err),
                     UB_OK);
    const ub_impair_params_t slow = {.delay_ms = 500};
    assert_int_equal(ub_ports_set_link_impairment(ports, "pubPort", &slow, 1), UB_OK);
    const ub_port_t *p = ub_ports_find(ports, "pubPort");
    assert_true(p->own_impair && p->impaired);
    assert_int_equal(p->own_seed, 1);
    /* Same parameters, another seed: the port keeps its queue and takes the new seed. */
    assert_int_equal(ub_ports_set_link_impairment(ports, "pubPort", &slow, 2), UB_OK);
    assert_int_equal(p->own_seed, 2);
    /* The node-wide setting with a new seed leaves a port with its own impairment alone. */
    const ub_impair_params_t loss = {.loss_ppm = 1000000};
    assert_int_equal(ub_ports_set_impairment(ports, &loss, 9), UB_OK);
    assert_int_equal(p->impair.params.delay_ms, 500);
    /* Three frames into the link's transport (the impairment in front of the socket) wait out the delay. */
    const ub_link_t *link = ub_node_link(e.p->pub_node, e.p->pub_link);
    static const uint8_t frame[64] = {0};
    for (int i = 0; i < 3; i++) assert_int_equal(link->ops->send(link->impl, frame, sizeof frame, 0), UB_OK);
    assert_int_equal(ub_impair_pending(&p->impair), 3);
    int t = ub_ports_poll_timeout(ports, 100, 1000);
    assert_int_equal(t, 400); /* due at 500 */
    assert_int_equal(ub_ports_poll_timeout(ports, 600, 1000), 0);
    /* Rebinding keeps the impairment and its queue in front of the new socket. */
    assert_int_equal(ub_ports_open_text(ports, "pubPort", "udp:bind=127.0.0.1:0,peer=127.0.0.1:9", 0, err,
                                        sizeof err),
                     UB_OK);
    assert_int_equal(p->rebinds, 1);
    assert_true(p->impaired);
    assert_string_equal(link->ops->kind, "impair");
    assert_int_equal(ub_impair_pending(&p->impair), 3);
    uint64_t errors_before = ub_impair_stats(&p->impair)->inner_errors;
    assert_int_equal(ub_ports_close(ports, "pubPort"), UB_OK);
    assert_int_equal(ub_impair_stats(&p->impair)->inner_errors, errors_before + 3);
    assert_int_equal(p->impair.count, 0);
    assert_false(p->in_use);
    env_free(&e);
}

/* A stranger's datagram on a port that takes only its peer: refused, counted, and reported once as a notice
 * naming the link; the next call has nothing new. */
static void test_notice_once_per_port(void **state) {
    (void)state;
    ports_env_t e = env_new();
    char err[UB_PORTS_ERR_LEN], text[256];
    assert_int_equal(ub_ports_open_text(e.ports, "pubPort", "udp:bind=127.0.0.1:0,peer=127.0.0.1:9", 0, err,
                                        sizeof err),
                     UB_OK);
    uint16_t port = 0;
    assert_int_equal(ub_ports_local_port(e.ports, "pubPort", &port), UB_OK);
    uint16_t mine = 0;
    int fd = hold_port(&mine);
    struct sockaddr_in to = {.sin_family = AF_INET, .sin_port = htons(port)};
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    static const char junk[] = "stranger";
    assert_int_equal(sendto(fd, junk, sizeof junk, 0, (struct sockaddr *)&to, sizeof to), (ssize_t)sizeof junk);
    for (int i = 0; i < 50 && ub_ports_notice(e.ports, text, sizeof text) == 0; i++) {
        struct pollfd fds[2];
        int n = ub_ports_pollfds(e.ports, fds, 2);
        assert_true(poll(fds, (nfds_t)n, 20) >= 0);
        assert_true(ub_ports_service(e.ports, (uint64_t)i) >= 0);
    }
    assert_non_null(strstr(text, "pubPort"));
    char mine_text[16];
    snprintf(mine_text, sizeof mine_text, "%u", (unsigned)mine);
    assert_non_null(strstr(text, mine_text)); /* names the sender */
    for (const char *c = text; *c; c++) assert_true(*c >= 0x20 && *c < 0x7f);
    assert_true(ub_ports_find(e.ports, "pubPort")->notice_reported);
    assert_int_equal(ub_ports_notice(e.ports, text, sizeof text), 0);
    close(fd);
    env_free(&e);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_spec_text_refusals),
        cmocka_unit_test(test_arg_refusals),
        cmocka_unit_test(test_spec_format_edges),
        cmocka_unit_test(test_config_refusals),
        cmocka_unit_test(test_open_refusals),
        cmocka_unit_test(test_api_refusals),
        cmocka_unit_test(test_each_impairment_param_counts),
        cmocka_unit_test(test_impairment_queue_seed_and_close),
        cmocka_unit_test(test_notice_once_per_port),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
