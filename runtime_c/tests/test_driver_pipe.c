/*
 * A transport written only against the public driver interface (ub_driver.h), registered at run time
 * without touching ub_ports.c: "pipe", one end of a SOCK_SEQPACKET socket pair (one packet, one frame).
 * It is opened from a port spec ("pipe:fd=N"), in all three spec forms, carries a subscription between
 * two nodes, switches to and from UDP at run time, takes the impairment in front of it, and reports its
 * counters through the same describe/counters path as the built-in drivers.
 *
 * The driver is the model of docs/architecture.md, "A new transport in six steps".
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <errno.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "support/ub_test_pair.h"
#include "ub/ub_driver.h"
#include "ub/ub_node.h"
#include "ub/ub_nodecfg.h"
#include "ub/ub_ports.h"
#include "ub/ub_pubsub.h"

/* ---- the driver: steps 1 to 5 of the recipe ----------------------------------------------------------- */

/* 1. The instance: everything one open pipe needs, no allocation (the ports set owns the storage). */
typedef struct pipe_link {
    int fd;
    ub_node_t *node;
    int link_id;
    uint64_t frames_in, frames_out, again, send_errors, rx_errors;
    uint8_t rx[UB_FRAME_MAX + 1]; /* one byte more than a frame: an oversize packet must not pass as one */
} pipe_link_t;

/* 2. The link vtable: how the node sends (never blocking). */
static int pipe_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)now_ms;
    pipe_link_t *pl = impl;
    if (send(pl->fd, frame, len, MSG_DONTWAIT | MSG_NOSIGNAL) == (ssize_t)len) {
        pl->frames_out++;
        return UB_OK;
    }
    if (errno == EAGAIN || errno == EWOULDBLOCK) {
        pl->again++;
        return UB_ERR_AGAIN;
    }
    pl->send_errors++;
    return UB_ERR_IO;
}

static int pipe_fileno(void *impl) { return ((pipe_link_t *)impl)->fd; }

static const ub_link_ops_t k_pipe_ops = {.kind = "pipe", .send = pipe_send, .fileno = pipe_fileno};

/* 3. The spec: "pipe:fd=N" (the descriptor is dup()ed at open, so the caller keeps its own). */
static int pipe_spec_param(ub_port_spec_t *spec, uint32_t *seen, const char *key, const char *value, char *err,
                           size_t cap) {
    if (strcmp(key, "fd") != 0) return UB_ERR_NOTFOUND;
    uint32_t fd = 0;
    if (*seen || !ub_driver_parse_u32(value, 65535u, &fd)) {
        snprintf(err, cap, "'fd=%.20s': %s", value, *seen ? "given twice: give it once" : "give a descriptor number");
        return UB_ERR_INVAL;
    }
    spec->port = (uint16_t)fd; /* a number: kept in the spec's port field */
    *seen = 1;
    return UB_OK;
}

static int pipe_spec_finish(ub_port_spec_t *spec, uint32_t seen, char *err, size_t cap) {
    (void)spec;
    if (seen) return UB_OK;
    snprintf(err, cap, "pipe needs fd=N, e.g. pipe:fd=3");
    return UB_ERR_INVAL;
}

static int pipe_spec_format(const ub_port_spec_t *spec, char *out, size_t cap) {
    return snprintf(out, cap, "pipe:fd=%u", (unsigned)spec->port);
}

/* 4. The instance's life: open, close, attach (the shared helper), service, poll, counters. */
static int pipe_open(void *state, const ub_port_spec_t *spec) {
    pipe_link_t *pl = state;
    pl->fd = dup(spec->port);
    return pl->fd >= 0 ? UB_OK : UB_ERR_IO;
}

static void pipe_close(void *state) {
    pipe_link_t *pl = state;
    if (pl->fd >= 0) close(pl->fd);
    pl->fd = -1;
}

static int pipe_attach(void *state, ub_node_t *node, int link_id) {
    pipe_link_t *pl = state;
    return ub_driver_attach(node, link_id, &k_pipe_ops, pl, &pl->node, &pl->link_id);
}

static int pipe_service(void *state, ub_node_t *node, uint64_t now_ms) {
    pipe_link_t *pl = state;
    if (pl->fd < 0 || node != pl->node) return UB_ERR_INVAL;
    int handed = 0;
    for (int i = 0; i < 64; i++) {
        ssize_t n = recv(pl->fd, pl->rx, sizeof pl->rx, MSG_DONTWAIT);
        if (n <= 0) break;
        pl->frames_in++;
        if (ub_node_rx_frame(node, pl->link_id, pl->rx, (size_t)n, now_ms) < 0) pl->rx_errors++;
        handed++;
    }
    return handed;
}

static int pipe_pollfds(const void *state, struct pollfd *fds, int cap) {
    const pipe_link_t *pl = state;
    if (pl->fd < 0) return 0;
    if (cap < 1) return UB_ERR_NOSPACE;
    fds[0] = (struct pollfd){.fd = pl->fd, .events = POLLIN};
    return 1;
}

static size_t pipe_counters(const void *state, ub_driver_counter_t *out, size_t cap) {
    const pipe_link_t *pl = state;
    const ub_driver_counter_t all[] = {{"frames_in", pl->frames_in},     {"frames_out", pl->frames_out},
                                       {"again", pl->again},             {"send_errors", pl->send_errors},
                                       {"rx_errors", pl->rx_errors}};
    for (size_t i = 0; i < 5 && i < cap; i++) out[i] = all[i];
    return 5;
}

/* 5. The table: one constant entry (describe NULL: its counters are its description). */
static const ub_driver_t k_pipe_driver = {
    .name = "pipe",
    .keys = "fd",
    .examples = "pipe:fd=3",
    .wire_params = true,
    .state_size = sizeof(pipe_link_t),
    .spec_param = pipe_spec_param,
    .spec_finish = pipe_spec_finish,
    .spec_format = pipe_spec_format,
    .open = pipe_open,
    .close = pipe_close,
    .attach = pipe_attach,
    .link_ops = &k_pipe_ops,
    .service = pipe_service,
    .pollfds = pipe_pollfds,
    .counters = pipe_counters,
};

/* ---- the tests: step 6, registration ---------------------------------------------------------------- */

typedef struct net {
    pair_t *p;
    ub_ports_t *a, *b; /* the pub node's ports, the sub node's */
    int sv[2];         /* the socket pair the pipes are opened on */
} net_t;

static net_t net_new(void) {
    net_t n = {.p = pair_new(NULL), .a = calloc(1, sizeof *n.a), .b = calloc(1, sizeof *n.b)};
    assert_non_null(n.a);
    assert_non_null(n.b);
    assert_int_equal(ub_ports_init(n.a, n.p->pub_node), UB_OK);
    assert_int_equal(ub_ports_init(n.b, n.p->sub_node), UB_OK);
    assert_int_equal(ub_ports_register(n.a, &k_pipe_driver), UB_OK);
    assert_int_equal(ub_ports_register(n.b, &k_pipe_driver), UB_OK);
    assert_int_equal(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, n.sv), 0);
    return n;
}

static void net_free(net_t *n) {
    ub_ports_close_all(n->a);
    ub_ports_close_all(n->b);
    close(n->sv[0]);
    close(n->sv[1]);
    free(n->a);
    free(n->b);
    pair_free(n->p);
}

static void step(net_t *n, uint64_t now_ms) {
    struct pollfd fds[4 * UB_PORTS_MAX];
    int na = ub_ports_pollfds(n->a, fds, 2 * UB_PORTS_MAX);
    int nb = ub_ports_pollfds(n->b, fds + na, 2 * UB_PORTS_MAX);
    assert_true(na >= 1 && nb >= 1);
    assert_true(poll(fds, (nfds_t)(na + nb), 0) >= 0);
    (void)ub_ports_service(n->a, now_ms);
    (void)ub_ports_service(n->b, now_ms);
    ub_node_tick(n->p->pub_node, now_ms);
    ub_node_tick(n->p->sub_node, now_ms);
}

static void run(net_t *n, uint64_t from_ms, uint64_t to_ms) {
    for (uint64_t t = from_ms; t < to_ms; t++) step(n, t);
}

/* The counter `name` of the port behind `link`, read through the interface every driver shares. */
static uint64_t counter(const ub_ports_t *ports, const char *link, const char *name) {
    ub_driver_counter_t c[32];
    int n = ub_ports_counters(ports, link, c, 32);
    assert_true(n > 0 && n <= 32);
    for (int i = 0; i < n; i++) {
        if (strcmp(c[i].name, name) == 0) return c[i].value;
    }
    fail_msg("no counter '%s' on %s", name, link);
    return 0;
}

static void test_registration_is_checked(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_ports_t *ports = calloc(1, sizeof *ports);
    assert_non_null(ports);
    assert_int_equal(ub_ports_init(ports, p->pub_node), UB_OK);
    assert_int_equal(ub_ports_register(NULL, &k_pipe_driver), UB_ERR_INVAL);
    assert_int_equal(ub_ports_register(ports, NULL), UB_ERR_INVAL);
    ub_driver_t bad = k_pipe_driver;
    bad.name = "Pipe!"; /* not a lower-case word */
    assert_int_equal(ub_ports_register(ports, &bad), UB_ERR_INVAL);
    bad = k_pipe_driver;
    bad.service = NULL; /* openable, but it could never read */
    assert_int_equal(ub_ports_register(ports, &bad), UB_ERR_INVAL);
    bad = k_pipe_driver;
    bad.state_size = UB_DRIVER_STATE_MAX + 1;
    assert_int_equal(ub_ports_register(ports, &bad), UB_ERR_INVAL);
    bad = k_pipe_driver;
    bad.name = "udp"; /* a built-in's word */
    assert_int_equal(ub_ports_register(ports, &bad), UB_ERR_EXISTS);
    assert_int_equal(ub_ports_register(ports, &k_pipe_driver), UB_OK);
    assert_int_equal(ub_ports_register(ports, &k_pipe_driver), UB_ERR_EXISTS);
    /* The registry is the set's own: up to UB_PORTS_MAX_DRIVERS, built-ins included. */
    static const char *const words[] = {"p1", "p2", "p3", "p4", "p5", "p6", "p7", "p8"};
    ub_driver_t more[8];
    int added = 0;
    for (int i = 0; i < 8; i++) {
        more[i] = k_pipe_driver;
        more[i].name = words[i];
        int rc = ub_ports_register(ports, &more[i]);
        if (rc == UB_ERR_FULL) break;
        assert_int_equal(rc, UB_OK);
        added++;
    }
    assert_int_equal(added, UB_PORTS_MAX_DRIVERS - 6); /* udp, tcp, serial, legacy, mem, pipe */
    ub_ports_t *other = calloc(1, sizeof *other);
    assert_non_null(other);
    assert_int_equal(ub_ports_init(other, p->sub_node), UB_OK);
    char err[UB_PORTS_ERR_LEN];
    ub_port_spec_t s;
    assert_int_equal(ub_ports_spec_parse(other, "pipe:fd=3", &s, err, sizeof err), UB_ERR_INVAL); /* not there */
    ub_ports_close_all(ports);
    free(other);
    free(ports);
    pair_free(p);
}

static void test_specs_in_every_form(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    ub_ports_t *ports = calloc(1, sizeof *ports);
    assert_non_null(ports);
    assert_int_equal(ub_ports_init(ports, p->pub_node), UB_OK);
    char err[UB_PORTS_ERR_LEN], text[128], name[64];
    ub_port_spec_t s;
    /* Before registration, and without a set, "pipe" is unknown; the message lists what is known. */
    assert_int_equal(ub_ports_spec_parse(ports, "pipe:fd=3", &s, err, sizeof err), UB_ERR_INVAL);
    assert_non_null(strstr(err, "unknown transport 'pipe' (expected udp, tcp, serial, legacy or mem, e.g. udp:bind="));
    assert_int_equal(ub_ports_register(ports, &k_pipe_driver), UB_OK);
    assert_int_equal(ub_port_spec_parse("pipe:fd=3", &s, err, sizeof err), UB_ERR_INVAL);
    char long_err[512]; /* the whole message: a UB_PORTS_ERR_LEN buffer cuts the last examples */
    assert_int_equal(ub_ports_spec_parse(ports, "xmpp", &s, long_err, sizeof long_err), UB_ERR_INVAL);
    assert_non_null(strstr(long_err, "(expected udp, tcp, serial, legacy, mem or pipe, e.g. "));
    assert_non_null(strstr(long_err, " | mem | pipe:fd=3)"));
    /* Command-line form, with the wire parameters every transport takes; formatted back the same. */
    assert_int_equal(ub_ports_spec_parse(ports, "pipe:fd=7,encoding=compact,mtu=255", &s, err, sizeof err), UB_OK);
    assert_int_equal(s.kind, UB_PORT_DRIVER);
    assert_ptr_equal(s.driver, &k_pipe_driver);
    assert_string_equal(ub_port_spec_transport(&s), "pipe");
    assert_int_equal(s.port, 7);
    assert_int_equal(s.encoding, UB_PORT_ENCODING_COMPACT);
    assert_int_equal(s.mtu, 255);
    ub_port_spec_format(&s, text, sizeof text);
    assert_string_equal(text, "pipe:fd=7,encoding=compact,mtu=255");
    /* The driver's own messages, and ub_ports' for keys it does not know. */
    assert_int_equal(ub_ports_spec_parse(ports, "pipe", &s, err, sizeof err), UB_ERR_INVAL);
    assert_string_equal(err, "pipe needs fd=N, e.g. pipe:fd=3");
    assert_int_equal(ub_ports_spec_parse(ports, "pipe:fd=x", &s, err, sizeof err), UB_ERR_INVAL);
    assert_string_equal(err, "'fd=x': give a descriptor number");
    assert_int_equal(ub_ports_spec_parse(ports, "pipe:fd=1,speed=9", &s, err, sizeof err), UB_ERR_INVAL);
    assert_string_equal(err, "unknown parameter 'speed' for pipe (expected: fd, encoding, mtu, prio)");
    /* --port form: "pipe:fd=3" alone is a spec without a link name. */
    assert_int_equal(ub_ports_arg_parse(ports, "pubPort=pipe:fd=3", name, sizeof name, &s, err, sizeof err), UB_OK);
    assert_string_equal(name, "pubPort");
    assert_ptr_equal(s.driver, &k_pipe_driver);
    assert_int_equal(ub_ports_arg_parse(ports, "pipe:fd=3", name, sizeof name, &s, err, sizeof err), UB_ERR_INVAL);
    assert_non_null(strstr(err, "expected LINK=SPEC"));
    /* Config form: "transport": "pipe" with its parameters. */
    static const char cfg_text[] =
        "{\"entities\": [{\"name\": \"pub\", \"links\": [\"pubPort\"]}],\n"
        " \"ports\": {\"pubPort\": {\"transport\": \"pipe\", \"fd\": 4}}}\n";
    ub_nodecfg_t *cfg = calloc(1, sizeof *cfg);
    assert_non_null(cfg);
    char cerr[UB_NODECFG_ERR_LEN];
    assert_int_equal(ub_nodecfg_parse(cfg, cfg_text, strlen(cfg_text), "pipe.json", cerr, sizeof cerr), UB_OK);
    assert_int_equal(ub_ports_spec_from_config(ports, &cfg->ports[0], cfg->source, &s, err, sizeof err), UB_OK);
    assert_int_equal(s.port, 4);
    assert_int_equal(ub_port_spec_from_config(&cfg->ports[0], cfg->source, &s, err, sizeof err), UB_ERR_CONFIG);
    assert_non_null(strstr(err, "pipe.json:2: port 'pubPort', field 'transport': unknown transport 'pipe'"));
    free(cfg);
    free(ports);
    pair_free(p);
}

static void test_pipe_carries_a_subscription_and_switches(void **state) {
    (void)state;
    net_t n = net_new();
    pair_t *p = n.p;
    char err[UB_PORTS_ERR_LEN], spec[64], text[1024];
    snprintf(spec, sizeof spec, "pipe:fd=%d", n.sv[0]);
    assert_int_equal(ub_ports_open_text(n.a, "pubPort", spec, 0, err, sizeof err), UB_OK);
    snprintf(spec, sizeof spec, "pipe:fd=%d", n.sv[1]);
    assert_int_equal(ub_ports_open_text(n.b, "subPort", spec, 0, err, sizeof err), UB_OK);
    assert_string_equal(ub_node_link(p->pub_node, p->pub_link)->ops->kind, "pipe");
    assert_int_equal(ub_ports_local_port(n.a, "pubPort", &(uint16_t){0}), UB_ERR_INVAL); /* it has none */
    const pipe_link_t *pa = ub_ports_state(n.a, "pubPort", &k_pipe_driver);
    assert_non_null(pa);
    assert_null(ub_ports_state(n.a, "pubPort", &ub_udp_driver));

    int row = ub_pubsub_subscribe(p->sub_node, p->sub, TEST_GPS, p->pub_id, 20, 0);
    assert_true(row >= 0);
    run(&n, 0, 500);
    assert_in_range(delivery_count(&p->log, p->sub, TEST_GPS, 0, 500), 20, 25);
    assert_memory_equal(&p->gps_dst, &p->gps_src, sizeof p->gps_src);
    /* The driver's counters agree with the node's link counters, frame for frame. */
    const ub_link_counters_t *ca = &ub_node_link(p->pub_node, p->pub_link)->counters;
    const ub_link_counters_t *cb = &ub_node_link(p->sub_node, p->sub_link)->counters;
    assert_int_equal(counter(n.a, "pubPort", "frames_out"), ca->frames_out);
    assert_int_equal(counter(n.b, "subPort", "frames_in"), cb->frames_in);
    assert_int_equal(ca->frames_out, cb->frames_in); /* nothing lost in a socket pair */
    assert_int_equal(counter(n.b, "subPort", "rx_errors"), 0);

    /* The same description path as a built-in: "<transport>":{...}, here the default (its counters). */
    int len = ub_ports_describe(n.b, "subPort", text, sizeof text);
    assert_true(len > 0);
    char want[128];
    snprintf(want, sizeof want, "\"pipe\":{\"frames_in\":%llu,\"frames_out\":", (unsigned long long)cb->frames_in);
    assert_memory_equal(text, want, strlen(want));
    assert_string_equal(text + len - 1, "}");
    assert_int_equal(ub_ports_describe(n.b, "subPort", text, 8), UB_ERR_NOSPACE);
    assert_string_equal(text, "\"pip...");

    /* The runtime software switch, pipe -> UDP and back: the subscription carries on. */
    uint16_t ub = 0, ua = 0;
    assert_int_equal(ub_ports_open_text(n.b, "subPort", "udp:bind=127.0.0.1:0,accept=any", 500, err, sizeof err), UB_OK);
    assert_int_equal(ub_ports_local_port(n.b, "subPort", &ub), UB_OK);
    snprintf(spec, sizeof spec, "udp:bind=127.0.0.1:0,peer=127.0.0.1:%u", (unsigned)ub);
    assert_int_equal(ub_ports_open_text(n.a, "pubPort", spec, 500, err, sizeof err), UB_OK);
    assert_int_equal(ub_ports_local_port(n.a, "pubPort", &ua), UB_OK);
    run(&n, 500, 1000);
    assert_in_range(delivery_count(&p->log, p->sub, TEST_GPS, 500, 1000), 20, 26);
    len = ub_ports_describe(n.b, "subPort", text, sizeof text);
    assert_true(len > 0);
    assert_memory_equal(text, "\"udp\":{\"datagrams_in\":", strlen("\"udp\":{\"datagrams_in\":"));
    snprintf(want, sizeof want, "\"peers\":[\"127.0.0.1:%u\"]}", (unsigned)ua);
    assert_string_equal(text + len - strlen(want), want);
    snprintf(spec, sizeof spec, "pipe:fd=%d", n.sv[0]);
    assert_int_equal(ub_ports_open_text(n.a, "pubPort", spec, 1000, err, sizeof err), UB_OK);
    snprintf(spec, sizeof spec, "pipe:fd=%d", n.sv[1]);
    assert_int_equal(ub_ports_open_text(n.b, "subPort", spec, 1000, err, sizeof err), UB_OK);
    assert_int_equal(ub_ports_find(n.a, "pubPort")->rebinds, 2);
    run(&n, 1000, 1500);
    assert_in_range(delivery_count(&p->log, p->sub, TEST_GPS, 1000, 1500), 20, 26);
    assert_int_equal(ub_pubsub_row(p->sub_node, p->sub, row)->state, UB_SUB_RECEIVING);
    assert_true(counter(n.b, "subPort", "frames_in") > 20); /* a new instance: counted from the switch */

    /* The impairment sits in front of a registered driver as of a built-in one (through its link_ops). */
    const ub_impair_params_t imp = {.loss_ppm = 1000000};
    assert_int_equal(ub_ports_set_link_impairment(n.a, "pubPort", &imp, 1), UB_OK);
    assert_string_equal(ub_node_link(p->pub_node, p->pub_link)->ops->kind, "impair");
    uint64_t out_before = counter(n.a, "pubPort", "frames_out");
    run(&n, 1500, 1700);
    assert_int_equal(counter(n.a, "pubPort", "frames_out"), out_before); /* everything lost on the way */
    assert_int_equal(ub_ports_set_link_impairment(n.a, "pubPort", NULL, 1), UB_OK);
    assert_string_equal(ub_node_link(p->pub_node, p->pub_link)->ops->kind, "pipe");

    assert_int_equal(ub_ports_close(n.a, "pubPort"), UB_OK);
    assert_null(ub_node_link(p->pub_node, p->pub_link)->ops); /* closing detaches the slot */
    assert_int_equal(ub_ports_counters(n.a, "pubPort", NULL, 0), UB_ERR_NOTFOUND);
    net_free(&n);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_registration_is_checked),
        cmocka_unit_test(test_specs_in_every_form),
        cmocka_unit_test(test_pipe_carries_a_subscription_and_switches),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
