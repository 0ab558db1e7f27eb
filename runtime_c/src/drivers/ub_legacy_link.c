/* A serial link in the legacy datalink format (contracts in ub/ub_legacy_link.h; the envelope in ub/ub_legacy.h). */
#include "ub/ub_legacy_link.h"

#include <poll.h>
#include <stdio.h>
#include <string.h>

#include "ub/ub_node.h"
#include "ub/ub_ports.h"

/* ---- received: the parser's messages ---- */

static void on_message(void *user, uint16_t type, const uint8_t *msg, size_t msg_len, const uint8_t *payload,
                       size_t payload_len) {
    ub_legacy_link_t *l = user;
    if (type == l->type) { /* the publish/subscribe message: one frame, checked as a datagram's */
        if (ub_node_rx_frame(l->serial.node, l->serial.link_id, payload, payload_len, l->now_ms) < 0)
            l->stats.frames_rejected++;
        else
            l->stats.frames_in++;
        return;
    }
    if (l->foreign == NULL) { /* "discarded as an unrecognized message type", but counted */
        l->stats.unhandled++;
        return;
    }
    l->stats.foreign_messages++;
    size_t took = l->foreign(l->foreign_user, msg, msg_len);
    if (took < msg_len) l->stats.foreign_refused += msg_len - took;
}

static int rx_hook(void *user, const uint8_t *data, size_t len, uint64_t now_ms) {
    ub_legacy_link_t *l = user;
    uint64_t before = l->stats.frames_in;
    l->now_ms = now_ms;
    /* Cannot fail: the serial driver hands its own receive buffer, never NULL. */
    int messages = ub_legacy_feed(&l->parser, data, len, on_message, l);
    (void)messages; /* counted by the parser; the node wants the frames it took in */
    return (int)(l->stats.frames_in - before);
}

/* ---- sent: each frame in one message ---- */

static int legacy_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    ub_legacy_link_t *l = impl;
    uint8_t msg[UB_LEGACY_MESSAGE_MAX];
    int n = ub_legacy_build(l->type, frame, len, msg, sizeof msg);
    if (n < 0) return n;
    int rc = ub_serial_write_foreign(&l->serial, msg, (size_t)n, now_ms);
    if (rc == UB_OK) l->stats.frames_out++;
    return rc;
}

static int legacy_fileno(void *impl) { return ub_serial_fileno(&((ub_legacy_link_t *)impl)->serial); }

const ub_link_ops_t ub_legacy_link_ops = {.kind = "legacy", .send = legacy_send, .fileno = legacy_fileno};

/* ---- the driver entry: "legacy:device=PATH[,baud=RATE][,type=N]" ---- */

enum { SEEN_TYPE = 1u << 8 }; /* above the serial driver's bits */

/* The uavbus message type is kept in the spec's `port` field (a serial spec has no port). */
static void legacy_spec_init(ub_port_spec_t *spec) {
    spec->kind = UB_PORT_DRIVER;
    spec->baud = UB_PORT_DEFAULT_BAUD;
    spec->port = UB_LEGACY_DEFAULT_TYPE;
}

static int legacy_spec_param(ub_port_spec_t *s, uint32_t *seen, const char *key, const char *value, char *err,
                             size_t cap) {
    if (strcmp(key, "type") == 0) {
        uint32_t v = 0;
        if (!ub_driver_parse_u32(value, 65535u, &v) || v == 0 || (*seen & SEEN_TYPE)) {
            snprintf(err, cap, "'type=%.20s': give once the legacy message type uavbus frames travel as, 1..65535, "
                     "e.g. type=200", value);
            return UB_ERR_INVAL;
        }
        s->port = (uint16_t)v;
        *seen |= SEEN_TYPE;
        return UB_OK;
    }
    return ub_serial_driver.spec_param(s, seen, key, value, err, cap); /* device, baud */
}

static int legacy_spec_finish(ub_port_spec_t *s, uint32_t seen, char *err, size_t cap) {
    (void)seen;
    if (s->device[0] == '\0') {
        snprintf(err, cap, "legacy needs device=PATH, e.g. legacy:device=/dev/ttyS1,baud=57600,type=200");
        return UB_ERR_INVAL;
    }
    return UB_OK;
}

static int legacy_spec_format(const ub_port_spec_t *spec, char *out, size_t cap) {
    return snprintf(out, cap, "legacy:device=%s,baud=%u,type=%u", spec->device, (unsigned)spec->baud,
                    (unsigned)spec->port);
}

static int legacy_open(void *state, const ub_port_spec_t *spec) {
    ub_legacy_link_t *l = state;
    int rc = ub_serial_open(&l->serial, spec->device, spec->baud);
    if (rc != UB_OK) return rc;
    ub_legacy_init(&l->parser);
    l->type = spec->port;
    return ub_serial_set_rx_hook(&l->serial, rx_hook, l);
}

static void legacy_close(void *state) { ub_serial_close(&((ub_legacy_link_t *)state)->serial); }

static int legacy_attach(void *state, ub_node_t *node, int link_id) {
    ub_legacy_link_t *l = state;
    return ub_serial_attach_as(&l->serial, node, link_id, &ub_legacy_link_ops, l);
}

static int legacy_service(void *state, ub_node_t *node, uint64_t now_ms) {
    ub_legacy_link_t *l = state;
    uint64_t reopens = l->serial.stats.reopens;
    int rc = ub_serial_service(&l->serial, node, now_ms);
    if (l->serial.stats.reopens != reopens) { /* a new stream: no half message of the old one survives */
        l->parser.stats.noise_bytes += ub_legacy_pending(&l->parser);
        l->parser.have = 0;
    }
    return rc;
}

static int legacy_pollfds(const void *state, struct pollfd *fds, int cap) {
    return ub_serial_driver.pollfds(&((const ub_legacy_link_t *)state)->serial, fds, cap);
}

static bool legacy_next_due(const void *state, uint64_t *due_ms) {
    return ub_serial_next_retry(&((const ub_legacy_link_t *)state)->serial, due_ms);
}

static int legacy_set_foreign(void *state, ub_foreign_cb cb, void *user) {
    ub_legacy_link_t *l = state;
    l->foreign = cb;
    l->foreign_user = cb != NULL ? user : NULL;
    return UB_OK;
}

static int legacy_write_foreign(void *state, const uint8_t *data, size_t len, uint64_t now_ms) {
    return ub_serial_write_foreign(&((ub_legacy_link_t *)state)->serial, data, len, now_ms);
}

static size_t legacy_counters(const void *state, ub_driver_counter_t *out, size_t cap) {
    const ub_legacy_link_t *l = state;
    const ub_legacy_stats_t *p = &l->parser.stats;
    const ub_serial_stats_t *s = &l->serial.stats;
    const ub_driver_counter_t all[] = {
        {"type", l->type},
        {"frames_in", l->stats.frames_in},
        {"frames_rejected", l->stats.frames_rejected},
        {"frames_out", l->stats.frames_out},
        {"foreign_messages", l->stats.foreign_messages},
        {"foreign_refused", l->stats.foreign_refused},
        {"unhandled", l->stats.unhandled},
        {"messages", p->messages},
        {"bad_header", p->bad_header},
        {"bad_checksum", p->bad_checksum},
        {"too_long", p->too_long},
        {"noise_bytes", p->noise_bytes},
        {"bytes_in", s->bytes_in},
        {"bytes_out", s->bytes_out},
        {"backpressure", s->backpressure},
        {"hangups", s->hangups},
    };
    size_t n = sizeof all / sizeof all[0];
    for (size_t i = 0; i < n && i < cap && out != NULL; i++) out[i] = all[i];
    return n;
}

const ub_driver_t ub_legacy_driver = {
    .name = "legacy",
    .keys = "device, baud, type",
    .examples = "legacy:device=/dev/ttyS1,baud=57600,type=200",
    .wire_params = false, /* full frames, one per message */
    .state_size = sizeof(ub_legacy_link_t),
    .spec_init = legacy_spec_init,
    .spec_param = legacy_spec_param,
    .spec_finish = legacy_spec_finish,
    .spec_format = legacy_spec_format,
    .open = legacy_open,
    .close = legacy_close,
    .attach = legacy_attach,
    .link_ops = &ub_legacy_link_ops,
    .service = legacy_service,
    .pollfds = legacy_pollfds,
    .next_due = legacy_next_due,
    .counters = legacy_counters,
    .set_foreign = legacy_set_foreign,
    .write_foreign = legacy_write_foreign,
};
