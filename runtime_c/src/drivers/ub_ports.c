/* Ports: transports behind a node's links, opened from text, serviced from one loop (ub_ports.h). */
#include "ub/ub_ports.h"

#include <arpa/inet.h>
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

/* ---- messages ---------------------------------------------------------------------------------------- */

#if defined(__GNUC__) || defined(__clang__)
__attribute__((format(printf, 3, 4)))
#endif
static void fail(char *err, size_t cap, const char *fmt, ...) {
    if (err == NULL || cap == 0) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, cap, fmt, ap);
    va_end(ap);
    /* Messages quote text from config files and command lines: a control byte (a terminal escape) or a
     * byte outside printable ASCII is shown as '?', so every message is one clean line (config-format.md). */
    for (char *c = err; *c != '\0'; c++) {
        if ((unsigned char)*c < 0x20 || (unsigned char)*c >= 0x7f) *c = '?';
    }
}

const char *ub_port_kind_transport(ub_port_kind_t kind) {
    switch (kind) {
    case UB_PORT_UDP: return "udp";
    case UB_PORT_TCP_LISTEN:
    case UB_PORT_TCP_CONNECT: return "tcp";
    case UB_PORT_SERIAL: return "serial";
    case UB_PORT_MEM: return "mem";
    default: return "none";
    }
}

/* ---- spec parsing (shared by the command-line and config forms) -------------------------------------- */

#define EXAMPLES                                                                                            \
    "udp:bind=127.0.0.1:0,peer=127.0.0.1:5001 | udp:bind=0.0.0.0:5001 (peers learned) | "                 \
    "tcp:listen=127.0.0.1:5001 | tcp:connect=127.0.0.1:5001 | serial:device=/dev/ttyUSB0,baud=115200 | mem"

static const uint32_t k_bauds[] = {1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400, 460800, 921600};

static bool parse_u32(const char *s, uint32_t max, uint32_t *out) {
    if (*s == '\0') return false;
    uint64_t v = 0;
    for (; *s != '\0'; s++) {
        if (*s < '0' || *s > '9') return false;
        v = v * 10 + (uint64_t)(*s - '0');
        if (v > max) return false;
    }
    *out = (uint32_t)v;
    return true;
}

/* "HOST:PORT" -> dotted host + port. "localhost" means 127.0.0.1 (the drivers take dotted IPv4 only). */
static bool parse_hostport(const char *value, char host[UB_PORT_HOST_LEN], uint16_t *port) {
    const char *colon = strrchr(value, ':');
    if (colon == NULL || colon == value || (size_t)(colon - value) >= UB_PORT_HOST_LEN) return false;
    char h[UB_PORT_HOST_LEN];
    memcpy(h, value, (size_t)(colon - value));
    h[colon - value] = '\0';
    if (strcmp(h, "localhost") == 0) snprintf(h, sizeof h, "127.0.0.1");
    struct in_addr a;
    if (inet_pton(AF_INET, h, &a) != 1) return false;
    uint32_t p;
    if (!parse_u32(colon + 1, 65535u, &p)) return false;
    memcpy(host, h, sizeof h);
    *port = (uint16_t)p;
    return true;
}

/* Spec being built: which transport word, and which parameters were seen. */
typedef struct spec_builder {
    ub_port_spec_t spec;
    bool is_tcp;
    bool has_bind, has_peer, has_listen, has_connect, has_device, has_accept, has_encoding, has_mtu;
} spec_builder_t;

static int builder_start(spec_builder_t *b, const char *transport, char *err, size_t cap) {
    memset(b, 0, sizeof *b);
    if (strcmp(transport, "udp") == 0) {
        b->spec.kind = UB_PORT_UDP;
    } else if (strcmp(transport, "tcp") == 0) {
        b->is_tcp = true;
    } else if (strcmp(transport, "serial") == 0) {
        b->spec.kind = UB_PORT_SERIAL;
        b->spec.baud = UB_PORT_DEFAULT_BAUD;
    } else if (strcmp(transport, "mem") == 0) {
        b->spec.kind = UB_PORT_MEM;
    } else {
        fail(err, cap, "unknown transport '%.20s' (expected udp, tcp, serial or mem, e.g. " EXAMPLES ")", transport);
        return UB_ERR_INVAL;
    }
    return UB_OK;
}

/* One KEY=VALUE; messages name the key so the caller can prefix where it came from. */
static int builder_param(spec_builder_t *b, const char *key, const char *value, char *err, size_t cap) {
    ub_port_spec_t *s = &b->spec;
    const char *hp_help = "expected HOST:PORT with a dotted IPv4 host and a port 0..65535, e.g. 127.0.0.1:5001";
    if (s->kind == UB_PORT_UDP && (strcmp(key, "bind") == 0 || strcmp(key, "peer") == 0)) {
        bool bind = key[0] == 'b';
        if (bind ? b->has_bind : b->has_peer) {
            fail(err, cap, "'%s' given twice: give it once", key);
            return UB_ERR_INVAL;
        }
        if (!parse_hostport(value, bind ? s->host : s->peer_host, bind ? &s->port : &s->peer_port)) {
            fail(err, cap, "'%s=%.40s': %s", key, value, hp_help);
            return UB_ERR_INVAL;
        }
        if (!bind && s->peer_port == 0) {
            fail(err, cap, "'peer=%.40s': the peer port must not be 0 (it is where frames are sent)", value);
            return UB_ERR_INVAL;
        }
        if (bind) b->has_bind = true;
        else b->has_peer = true;
        return UB_OK;
    }
    if (s->kind == UB_PORT_UDP && strcmp(key, "accept") == 0) {
        static const char *const modes[] = {"peer", "learn", "any"};
        size_t m = 0;
        while (m < 3 && strcmp(value, modes[m]) != 0) m++;
        if (m == 3 || b->has_accept) {
            fail(err, cap, "'accept=%.20s': %s", value,
                 b->has_accept ? "given twice: give it once"
                               : "use peer (the peer only), learn (one peer: the last sender the node accepted) or "
                                 "any (every sender of a genuine frame, up to UB_UDP_MAX_PEERS)");
            return UB_ERR_INVAL;
        }
        s->accept = (uint8_t)m;
        b->has_accept = true;
        return UB_OK;
    }
    if (b->is_tcp && (strcmp(key, "listen") == 0 || strcmp(key, "connect") == 0)) {
        if (b->has_listen || b->has_connect) {
            fail(err, cap, "'%s': a tcp port either listens or connects: give exactly one of listen=, connect=", key);
            return UB_ERR_INVAL;
        }
        if (!parse_hostport(value, s->host, &s->port)) {
            fail(err, cap, "'%s=%.40s': %s", key, value, hp_help);
            return UB_ERR_INVAL;
        }
        if (key[0] == 'c') {
            if (s->port == 0) {
                fail(err, cap, "'connect=%.40s': the port to connect to must not be 0", value);
                return UB_ERR_INVAL;
            }
            s->kind = UB_PORT_TCP_CONNECT;
            b->has_connect = true;
        } else {
            s->kind = UB_PORT_TCP_LISTEN;
            b->has_listen = true;
        }
        return UB_OK;
    }
    if (s->kind == UB_PORT_SERIAL && strcmp(key, "device") == 0) {
        size_t n = strlen(value);
        if (n == 0 || n >= UB_PORT_DEVICE_LEN) {
            fail(err, cap, "'device': give a device path of 1 to %d characters, e.g. /dev/ttyUSB0",
                 UB_PORT_DEVICE_LEN - 1);
            return UB_ERR_INVAL;
        }
        /* A config file could name one, but the spec text (--port, rebind, the "ready" event) could not say it. */
        if (strchr(value, ',') != NULL) {
            fail(err, cap, "'device=%.40s': a device path cannot contain ',' (it separates a spec's parameters); "
                 "use a symlink without one", value);
            return UB_ERR_INVAL;
        }
        memcpy(s->device, value, n + 1);
        b->has_device = true;
        return UB_OK;
    }
    if (s->kind == UB_PORT_SERIAL && strcmp(key, "baud") == 0) {
        uint32_t v = 0;
        bool ok = parse_u32(value, 10000000u, &v);
        bool known = false;
        for (size_t i = 0; ok && i < sizeof k_bauds / sizeof k_bauds[0]; i++) known = known || k_bauds[i] == v;
        if (!known) {
            fail(err, cap,
                 "'baud=%.20s': use one of 1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400, 460800, "
                 "921600",
                 value);
            return UB_ERR_INVAL;
        }
        s->baud = v;
        return UB_OK;
    }
    if (s->kind != UB_PORT_MEM && strcmp(key, "encoding") == 0) {
        bool compact = strcmp(value, "compact") == 0;
        if (b->has_encoding || (!compact && strcmp(value, "full") != 0)) {
            fail(err, cap, "'encoding=%.20s': %s", value,
                 b->has_encoding ? "given twice: give it once"
                                 : "use full (64-byte headers, the default) or compact (both ends of the link alike)");
            return UB_ERR_INVAL;
        }
        s->encoding = compact ? UB_PORT_ENCODING_COMPACT : UB_PORT_ENCODING_FULL;
        b->has_encoding = true;
        return UB_OK;
    }
    if (s->kind != UB_PORT_MEM && strcmp(key, "mtu") == 0) {
        uint32_t v = 0;
        if (b->has_mtu || !parse_u32(value, 65535u, &v) || v < UB_LINK_MTU_MIN) {
            fail(err, cap, "'mtu=%.20s': %s", value,
                 b->has_mtu ? "given twice: give it once"
                            : "give the largest frame the link carries, in bytes, from 64 to 65535 (e.g. mtu=255 for "
                              "a radio's packets)");
            return UB_ERR_INVAL;
        }
        s->mtu = (uint16_t)v;
        b->has_mtu = true;
        return UB_OK;
    }
    const char *expected = s->kind == UB_PORT_UDP      ? "bind, peer, accept, encoding, mtu"
                           : b->is_tcp                 ? "listen or connect, encoding, mtu"
                           : s->kind == UB_PORT_SERIAL ? "device, baud, encoding, mtu"
                                                       : "none";
    fail(err, cap, "unknown parameter '%.20s' for %s (expected: %s)", key,
         b->is_tcp ? "tcp" : ub_port_kind_transport(s->kind), expected);
    return UB_ERR_INVAL;
}

static int builder_finish(spec_builder_t *b, ub_port_spec_t *out, char *err, size_t cap) {
    if (b->spec.kind == UB_PORT_UDP && !b->has_bind) {
        fail(err, cap, "udp needs bind=HOST:PORT, e.g. udp:bind=127.0.0.1:0,peer=127.0.0.1:5001 (or, to learn its "
                       "peers, udp:bind=0.0.0.0:5001)");
        return UB_ERR_INVAL;
    }
    if (b->spec.kind == UB_PORT_UDP && !b->has_accept) b->spec.accept = b->has_peer ? UB_UDP_ACCEPT_PEER : UB_UDP_ACCEPT_ANY;
    if (b->spec.kind == UB_PORT_UDP && b->spec.accept == UB_UDP_ACCEPT_PEER && !b->has_peer) {
        fail(err, cap, "udp with accept=peer needs peer=HOST:PORT, e.g. udp:bind=127.0.0.1:0,peer=127.0.0.1:5001");
        return UB_ERR_INVAL;
    }
    if (b->is_tcp && b->spec.kind == UB_PORT_NONE) {
        fail(err, cap, "tcp needs listen=HOST:PORT (server) or connect=HOST:PORT (client), e.g. tcp:connect=127.0.0.1:5001");
        return UB_ERR_INVAL;
    }
    if (b->spec.kind == UB_PORT_SERIAL && !b->has_device) {
        fail(err, cap, "serial needs device=PATH, e.g. serial:device=/dev/ttyUSB0,baud=115200");
        return UB_ERR_INVAL;
    }
    *out = b->spec;
    return UB_OK;
}

int ub_port_spec_parse(const char *text, ub_port_spec_t *spec, char *err, size_t err_cap) {
    if (text == NULL || spec == NULL) return UB_ERR_INVAL;
    char buf[256];
    size_t n = strlen(text);
    if (n == 0 || n >= sizeof buf) {
        fail(err, err_cap, "port spec must be 1 to %zu characters: TRANSPORT[:KEY=VALUE,...], e.g. " EXAMPLES,
             sizeof buf - 1);
        return UB_ERR_INVAL;
    }
    memcpy(buf, text, n + 1);
    char *params = strchr(buf, ':');
    if (params != NULL) *params++ = '\0';
    spec_builder_t b;
    int rc = builder_start(&b, buf, err, err_cap);
    if (rc != UB_OK) return rc;
    while (params != NULL && *params != '\0') {
        char *next = strchr(params, ',');
        if (next != NULL) *next++ = '\0';
        char *eq = strchr(params, '=');
        if (eq == NULL || eq == params) {
            fail(err, err_cap, "'%.40s' is not KEY=VALUE (e.g. " EXAMPLES ")", params);
            return UB_ERR_INVAL;
        }
        *eq = '\0';
        rc = builder_param(&b, params, eq + 1, err, err_cap);
        if (rc != UB_OK) return rc;
        params = next;
    }
    return builder_finish(&b, spec, err, err_cap);
}

int ub_port_arg_parse(const char *arg, char *name, size_t name_cap, ub_port_spec_t *spec, char *err,
                      size_t err_cap) {
    if (arg == NULL || name == NULL || name_cap == 0 || spec == NULL) return UB_ERR_INVAL;
    const char *eq = strchr(arg, '=');
    size_t n = eq != NULL ? (size_t)(eq - arg) : 0;
    /* "tcp:connect=..." without a link name would otherwise read as link "tcp:connect" (entity:link form). */
    bool spec_only = false;
    static const char *const words[] = {"udp:", "tcp:", "serial:"};
    for (size_t i = 0; i < sizeof words / sizeof words[0]; i++) {
        spec_only = spec_only || strncmp(arg, words[i], strlen(words[i])) == 0;
    }
    if (eq == NULL || n == 0 || spec_only) {
        fail(err, err_cap, "'%.60s': expected LINK=SPEC, e.g. onboardPortIPC=tcp:connect=127.0.0.1:5001", arg);
        return UB_ERR_INVAL;
    }
    if (n > UB_NODECFG_PORT_KEY_MAX || n >= name_cap) {
        fail(err, err_cap, "link name '%.*s...' is too long (at most %d characters)", 20, arg,
             (int)(UB_NODECFG_PORT_KEY_MAX < name_cap - 1 ? UB_NODECFG_PORT_KEY_MAX : name_cap - 1));
        return UB_ERR_INVAL;
    }
    char msg[UB_PORTS_ERR_LEN];
    if (ub_port_spec_parse(eq + 1, spec, msg, sizeof msg) != UB_OK) {
        fail(err, err_cap, "port '%.*s': %s", (int)n, arg, msg);
        return UB_ERR_INVAL;
    }
    memcpy(name, arg, n);
    name[n] = '\0';
    return UB_OK;
}

int ub_port_spec_from_config(const ub_nodecfg_port_t *entry, const char *source, ub_port_spec_t *spec, char *err,
                             size_t err_cap) {
    if (entry == NULL || spec == NULL) return UB_ERR_INVAL;
    if (source == NULL) source = "<config>";
    char msg[UB_PORTS_ERR_LEN];
    spec_builder_t b;
    if (builder_start(&b, entry->transport, msg, sizeof msg) != UB_OK) {
        fail(err, err_cap, "%s:%u: port '%s', field 'transport': %s", source, (unsigned)entry->line, entry->name, msg);
        return UB_ERR_CONFIG;
    }
    for (unsigned i = 0; i < entry->param_count; i++) {
        const ub_nodecfg_port_param_t *p = &entry->params[i];
        if (builder_param(&b, p->key, p->value, msg, sizeof msg) != UB_OK) {
            fail(err, err_cap, "%s:%u: port '%s', field '%s': %s", source, (unsigned)entry->line, entry->name, p->key,
                 msg);
            return UB_ERR_CONFIG;
        }
    }
    if (builder_finish(&b, spec, msg, sizeof msg) != UB_OK) {
        fail(err, err_cap, "%s:%u: port '%s': %s", source, (unsigned)entry->line, entry->name, msg);
        return UB_ERR_CONFIG;
    }
    return UB_OK;
}

void ub_port_spec_format(const ub_port_spec_t *spec, char *out, size_t cap) {
    if (out == NULL || cap == 0) return;
    if (spec == NULL) {
        out[0] = '\0';
        return;
    }
    int n;
    switch (spec->kind) {
    case UB_PORT_UDP: {
        /* accept= only when it is not what the other parameters imply (peer given: peer; none: any). */
        bool peer = spec->peer_port != 0;
        unsigned implied = peer ? UB_UDP_ACCEPT_PEER : UB_UDP_ACCEPT_ANY;
        static const char *const modes[] = {"peer", "learn", "any"};
        char peer_text[UB_PORT_HOST_LEN + 16] = "";
        if (peer) snprintf(peer_text, sizeof peer_text, ",peer=%s:%u", spec->peer_host, (unsigned)spec->peer_port);
        n = snprintf(out, cap, "udp:bind=%s:%u%s%s%s", spec->host, (unsigned)spec->port, peer_text,
                     spec->accept != implied ? ",accept=" : "", spec->accept != implied ? modes[spec->accept % 3] : "");
        break;
    }
    case UB_PORT_TCP_LISTEN: n = snprintf(out, cap, "tcp:listen=%s:%u", spec->host, (unsigned)spec->port); break;
    case UB_PORT_TCP_CONNECT: n = snprintf(out, cap, "tcp:connect=%s:%u", spec->host, (unsigned)spec->port); break;
    case UB_PORT_SERIAL: n = snprintf(out, cap, "serial:device=%s,baud=%u", spec->device, (unsigned)spec->baud); break;
    case UB_PORT_MEM: n = snprintf(out, cap, "mem"); break;
    default: n = snprintf(out, cap, "none"); break;
    }
    if (n >= 0 && (size_t)n < cap && spec->encoding == UB_PORT_ENCODING_COMPACT)
        n += snprintf(out + n, cap - (size_t)n, ",encoding=compact");
    if (n >= 0 && (size_t)n < cap && spec->mtu != 0) n += snprintf(out + n, cap - (size_t)n, ",mtu=%u", (unsigned)spec->mtu);
    /* A cut text ends in "..." so it cannot be mistaken for a whole spec (diagnostics only). */
    if ((n < 0 || (size_t)n >= cap) && cap >= 4) memcpy(out + cap - 4, "...", 4);
}

/* ---- drivers ----------------------------------------------------------------------------------------- */

static const ub_link_ops_t *driver_ops(ub_port_driver_t *d, void **impl) {
    switch (d->kind) {
    case UB_PORT_UDP: *impl = &d->u.udp; return &ub_udp_ops;
    case UB_PORT_TCP_LISTEN:
    case UB_PORT_TCP_CONNECT: *impl = &d->u.tcp; return &ub_tcp_ops;
    case UB_PORT_SERIAL: *impl = &d->u.serial; return &ub_serial_ops;
    default: *impl = NULL; return NULL;
    }
}

static void driver_close(ub_port_driver_t *d) {
    switch (d->kind) {
    case UB_PORT_UDP: ub_udp_close(&d->u.udp); break;
    case UB_PORT_TCP_LISTEN:
    case UB_PORT_TCP_CONNECT: ub_tcp_close(&d->u.tcp); break;
    case UB_PORT_SERIAL: ub_serial_close(&d->u.serial); break;
    default: break;
    }
    d->kind = UB_PORT_NONE;
}

/* Opens the socket/device of `spec` into `d` (not attached yet). errno is kept for the caller. */
static int driver_open(ub_port_driver_t *d, const ub_port_spec_t *spec) {
    int rc;
    memset(d, 0, sizeof *d);
    switch (spec->kind) {
    case UB_PORT_UDP:
        rc = ub_udp_open(&d->u.udp, spec->host, spec->port, spec->peer_port != 0 ? spec->peer_host : NULL,
                         spec->peer_port);
        if (rc == UB_OK) rc = ub_udp_set_accept(&d->u.udp, (ub_udp_accept_t)spec->accept);
        if (rc != UB_OK) ub_udp_close(&d->u.udp);
        break;
    case UB_PORT_TCP_LISTEN: rc = ub_tcp_server_open(&d->u.tcp, spec->host, spec->port, NULL); break;
    case UB_PORT_TCP_CONNECT: rc = ub_tcp_client_init(&d->u.tcp, spec->host, spec->port, NULL); break;
    case UB_PORT_SERIAL: rc = ub_serial_open(&d->u.serial, spec->device, spec->baud); break;
    default: return UB_ERR_INVAL;
    }
    if (rc == UB_OK) d->kind = spec->kind;
    return rc;
}

static int driver_attach(ub_port_driver_t *d, ub_node_t *node, int link_id) {
    switch (d->kind) {
    case UB_PORT_UDP: return ub_udp_attach(&d->u.udp, node, link_id);
    case UB_PORT_TCP_LISTEN:
    case UB_PORT_TCP_CONNECT: return ub_tcp_attach(&d->u.tcp, node, link_id);
    case UB_PORT_SERIAL: return ub_serial_attach(&d->u.serial, node, link_id);
    default: return UB_ERR_INVAL;
    }
}

static int driver_service(ub_port_driver_t *d, ub_node_t *node, uint64_t now_ms) {
    switch (d->kind) {
    case UB_PORT_UDP: return ub_udp_service(&d->u.udp, node, now_ms);
    case UB_PORT_TCP_LISTEN:
    case UB_PORT_TCP_CONNECT: return ub_tcp_service(&d->u.tcp, node, now_ms);
    case UB_PORT_SERIAL: return ub_serial_service(&d->u.serial, node, now_ms);
    default: return 0;
    }
}

/* ---- the set ----------------------------------------------------------------------------------------- */

int ub_ports_init(ub_ports_t *ports, ub_node_t *node) {
    if (ports == NULL || node == NULL) return UB_ERR_INVAL;
    memset(ports, 0, sizeof *ports);
    ports->node = node;
    return UB_OK;
}

/* "link" or "entity:link" -> link id of this node (the entity, when given, must own the link). */
static int resolve_link(const ub_node_t *node, const char *name) {
    if (name == NULL) return UB_ERR_INVAL;
    const char *colon = strchr(name, ':');
    if (colon == NULL) return ub_node_find_link(node, name);
    size_t en = (size_t)(colon - name);
    if (en == 0 || en > UB_ENTITY_ID_LEN) return UB_ERR_NOTFOUND;
    int id = ub_node_find_link(node, colon + 1);
    if (id < 0) return id;
    const ub_link_t *link = ub_node_link(node, id);
    const uint8_t *owner = ub_node_entity_id(node, node->locals[link->owner].entity);
    uint8_t want[UB_ENTITY_ID_LEN] = {0};
    memcpy(want, name, en);
    if (owner == NULL || memcmp(owner, want, UB_ENTITY_ID_LEN) != 0) return UB_ERR_NOTFOUND;
    return id;
}

static ub_port_t *port_of_link(ub_ports_t *ports, int link_id) {
    for (size_t i = 0; i < UB_PORTS_MAX; i++) {
        if (ports->port[i].in_use && ports->port[i].link_id == link_id) return &ports->port[i];
    }
    return NULL;
}

static bool params_active(const ub_impair_params_t *p) {
    return p->loss_ppm != 0 || p->dup_ppm != 0 || p->reorder_ppm != 0 || p->delay_ms != 0 || p->jitter_ms != 0 ||
           p->rate_Bps != 0 || p->mtu != 0;
}

/* The link's wire settings from the spec: the compact encoding (state in the port) and the MTU. */
static void apply_wire(ub_ports_t *ports, ub_port_t *p, const ub_port_spec_t *spec) {
    ub_compact_t *now = ub_node_link_compact(ports->node, p->link_id);
    if (spec->encoding == UB_PORT_ENCODING_COMPACT && now != &p->compact) {
        if (ub_node_link_set_compact(ports->node, p->link_id, &p->compact, NULL) != UB_OK) { /* id resolved */ }
    } else if (spec->encoding != UB_PORT_ENCODING_COMPACT && now == &p->compact) {
        if (ub_node_link_set_compact(ports->node, p->link_id, NULL, NULL) != UB_OK) { /* id resolved */ }
    }
    if (spec->mtu != 0 || p->set_mtu) {
        if (ub_node_link_set_mtu(ports->node, p->link_id, spec->mtu) != UB_OK) { /* 0 or >= 64: checked */ }
        p->set_mtu = spec->mtu != 0;
    }
}

/* A different PRNG stream per link, all derived from one seed. */
static uint64_t port_seed(uint64_t seed, int link_id) {
    return seed ^ ((uint64_t)(link_id + 1) * 0xD1B54A32D192ED03ULL);
}

/* The impairment in force for a port: its own, else the node-wide one, else none (NULL). */
static const ub_impair_params_t *port_params(const ub_ports_t *ports, const ub_port_t *p, uint64_t *seed) {
    if (p->own_impair) {
        *seed = p->own_seed;
        return &p->own_params;
    }
    *seed = ports->impair_seed;
    return ports->impair_on ? &ports->impair_params : NULL;
}

/* Puts the impairment in front of the port's current driver (slot transport swapped, stream kept). */
static void impair_install(ub_ports_t *ports, ub_port_t *p) {
    void *impl = NULL;
    const ub_link_ops_t *ops = driver_ops(&p->drv[p->active], &impl);
    uint64_t seed = 0;
    const ub_impair_params_t *params = port_params(ports, p, &seed);
    if (ops == NULL || params == NULL) return;
    if (!p->impaired) ub_impair_init(&p->impair, params, port_seed(seed, p->link_id));
    else ub_impair_set_params(&p->impair, params);
    if (ub_impair_wrap(&p->impair, ops, impl) != UB_OK) return;
    if (ub_node_link_set_transport(ports->node, p->link_id, &ub_impair_ops, &p->impair) != UB_OK) return;
    p->impaired = 1;
}

/* Takes the impairment away: what it still holds leaves now, then the driver is behind the slot again. */
static void impair_remove(ub_ports_t *ports, ub_port_t *p) {
    if (!p->impaired) return;
    (void)ub_impair_service(&p->impair, UINT64_MAX / 2); /* later than any due time: everything leaves */
    void *impl = NULL;
    const ub_link_ops_t *ops = driver_ops(&p->drv[p->active], &impl);
    if (ops != NULL && ub_node_link_set_transport(ports->node, p->link_id, ops, impl) != UB_OK) {
        /* cannot fail: the id was resolved and the driver ops have send */
    }
    p->impaired = 0;
}

int ub_ports_open(ub_ports_t *ports, const char *link_name, const ub_port_spec_t *spec, uint64_t now_ms, char *err,
                  size_t err_cap) {
    if (ports == NULL || ports->node == NULL || link_name == NULL || spec == NULL) return UB_ERR_INVAL;
    int link_id = resolve_link(ports->node, link_name);
    if (link_id < 0) {
        fail(err, err_cap, "port '%s': this node has no such link (hosted links are named in the config's 'links')",
             link_name);
        return UB_ERR_NOTFOUND;
    }
    if (spec->kind == UB_PORT_MEM || spec->kind == UB_PORT_NONE) {
        fail(err, err_cap, "port '%s': transport '%s' cannot be opened from a spec (attach a ub_memlink in the program)",
             link_name, ub_port_kind_transport(spec->kind));
        return UB_ERR_INVAL;
    }
    ub_port_t *p = port_of_link(ports, link_id);
    bool rebind = p != NULL;
    if (p == NULL) {
        for (size_t i = 0; i < UB_PORTS_MAX && p == NULL; i++) {
            if (!ports->port[i].in_use) p = &ports->port[i];
        }
        if (p == NULL) {
            fail(err, err_cap, "port '%s': all %d ports are in use (UB_PORTS_MAX)", link_name, UB_PORTS_MAX);
            return UB_ERR_FULL;
        }
        memset(p, 0, sizeof *p);
        p->link_id = link_id;
    }
    uint8_t slot = rebind ? (uint8_t)(1 - p->active) : 0;
    /* The software switch: open the new transport while the old one still runs... */
    int rc = driver_open(&p->drv[slot], spec);
    if (rc == UB_ERR_IO && rebind && errno == EADDRINUSE) {
        /* ...unless it needs the address the old one holds: then the old one goes first. */
        driver_close(&p->drv[p->active]);
        rc = driver_open(&p->drv[slot], spec);
    }
    if (rc != UB_OK) {
        int e = errno;
        char text[96];
        ub_port_spec_format(spec, text, sizeof text);
        fail(err, err_cap, "port '%s': cannot open %s: %s (%s)%s", link_name, text, ub_strerror(rc),
             rc == UB_ERR_IO ? strerror(e) : "check the parameters",
             rebind && p->drv[p->active].kind != UB_PORT_NONE ? "; the previous transport stays in place" : "");
        if (rebind && p->drv[p->active].kind == UB_PORT_NONE) {
            /* The old transport was closed to free its address and the new one failed: the slot is detached. */
            if (ub_node_link_detach(ports->node, link_id) != UB_OK) { /* cannot fail: link_id was resolved */ }
            p->in_use = 0;
            p->impaired = 0;
        }
        return rc;
    }
    /* ...attach it (the node's tables and counters stay as they are)... */
    rc = driver_attach(&p->drv[slot], ports->node, link_id);
    if (rc != UB_OK) {
        driver_close(&p->drv[slot]);
        fail(err, err_cap, "port '%s': cannot attach the transport: %s", link_name, ub_strerror(rc));
        return rc;
    }
    uint8_t old = p->active;
    p->active = slot;
    p->in_use = 1;
    p->spec = *spec;
    apply_wire(ports, p, spec);
    bool was_impaired = p->impaired;
    p->impaired = 0;
    uint64_t unused_seed;
    if (port_params(ports, p, &unused_seed) != NULL) {
        p->impaired = was_impaired ? 1 : 0; /* keep its PRNG and queue: queued copies leave via the new transport */
        impair_install(ports, p);
    }
    /* ...then close the old one. */
    if (rebind) {
        driver_close(&p->drv[old]);
        p->rebinds++;
    }
    /* A TCP client starts its first connection attempt now rather than at the first service. */
    if (spec->kind == UB_PORT_TCP_CONNECT) (void)driver_service(&p->drv[slot], ports->node, now_ms);
    return UB_OK;
}

int ub_ports_open_text(ub_ports_t *ports, const char *link_name, const char *spec_text, uint64_t now_ms, char *err,
                       size_t err_cap) {
    ub_port_spec_t spec;
    char msg[UB_PORTS_ERR_LEN];
    if (ub_port_spec_parse(spec_text, &spec, msg, sizeof msg) != UB_OK) {
        fail(err, err_cap, "port '%s': %s", link_name != NULL ? link_name : "?", msg);
        return UB_ERR_INVAL;
    }
    return ub_ports_open(ports, link_name, &spec, now_ms, err, err_cap);
}

int ub_ports_open_config(ub_ports_t *ports, const ub_nodecfg_t *cfg, uint64_t now_ms, char *err, size_t err_cap) {
    if (ports == NULL || ports->node == NULL || cfg == NULL) return UB_ERR_INVAL;
    int opened = 0;
    /* Check every entry first, so a bad entry fails before anything is opened. */
    ub_port_spec_t specs[UB_NODECFG_MAX_PORTS];
    for (unsigned i = 0; i < cfg->port_count; i++) {
        int rc = ub_port_spec_from_config(&cfg->ports[i], cfg->source, &specs[i], err, err_cap);
        if (rc != UB_OK) return rc;
    }
    for (unsigned i = 0; i < cfg->port_count; i++) {
        const ub_nodecfg_port_t *e = &cfg->ports[i];
        if (specs[i].kind == UB_PORT_MEM) continue;
        if (resolve_link(ports->node, e->name) < 0) continue; /* a link of an entity hosted elsewhere */
        char msg[UB_PORTS_ERR_LEN];
        int rc = ub_ports_open(ports, e->name, &specs[i], now_ms, msg, sizeof msg);
        if (rc != UB_OK) {
            fail(err, err_cap, "%s:%u: %s", cfg->source, (unsigned)e->line, msg);
            return rc;
        }
        opened++;
    }
    return opened;
}

static void port_close(ub_ports_t *ports, ub_port_t *p) {
    if (p->impaired) {
        /* Whatever is still queued cannot leave any more: count it as refused by a closed transport. */
        p->impair.stats.inner_errors += p->impair.count;
        p->impair.count = 0;
    }
    driver_close(&p->drv[0]);
    driver_close(&p->drv[1]);
    if (ub_node_link_detach(ports->node, p->link_id) != UB_OK) { /* cannot fail: the id was resolved */ }
    ub_port_spec_t full;
    memset(&full, 0, sizeof full);
    apply_wire(ports, p, &full); /* the link forgets the port's compact state and MTU */
    p->in_use = 0;
    p->impaired = 0;
    p->own_impair = 0;
}

int ub_ports_close(ub_ports_t *ports, const char *link_name) {
    if (ports == NULL || ports->node == NULL) return UB_ERR_INVAL;
    int id = resolve_link(ports->node, link_name);
    ub_port_t *p = id >= 0 ? port_of_link(ports, id) : NULL;
    if (p == NULL) return UB_ERR_NOTFOUND;
    port_close(ports, p);
    return UB_OK;
}

void ub_ports_close_all(ub_ports_t *ports) {
    if (ports == NULL || ports->node == NULL) return;
    for (size_t i = 0; i < UB_PORTS_MAX; i++) {
        if (ports->port[i].in_use) port_close(ports, &ports->port[i]);
    }
}

int ub_ports_service(ub_ports_t *ports, uint64_t now_ms) {
    if (ports == NULL || ports->node == NULL) return 0;
    int total = 0;
    for (size_t i = 0; i < UB_PORTS_MAX; i++) {
        ub_port_t *p = &ports->port[i];
        if (!p->in_use) continue;
        int n = driver_service(&p->drv[p->active], ports->node, now_ms);
        if (n < 0) p->service_errors++;
        else total += n;
        if (p->impaired) {
            /* A TCP driver re-attaches itself when a connection comes up: put the impairment back in front. */
            const ub_link_t *link = ub_node_link(ports->node, p->link_id);
            if (link != NULL && link->ops != &ub_impair_ops
                && ub_node_link_set_transport(ports->node, p->link_id, &ub_impair_ops, &p->impair) != UB_OK) {
                p->service_errors++; /* cannot happen: the id was resolved */
            }
            (void)ub_impair_service(&p->impair, now_ms);
        }
    }
    return total;
}

static int add_fd(struct pollfd *fds, int cap, int *n, int fd, short events) {
    if (fd < 0) return UB_OK;
    if (*n >= cap) return UB_ERR_NOSPACE;
    fds[*n].fd = fd;
    fds[*n].events = events;
    fds[*n].revents = 0;
    (*n)++;
    return UB_OK;
}

int ub_ports_pollfds(const ub_ports_t *ports, struct pollfd *fds, int cap) {
    if (ports == NULL || (fds == NULL && cap > 0) || cap < 0) return UB_ERR_INVAL;
    int n = 0;
    for (size_t i = 0; i < UB_PORTS_MAX; i++) {
        const ub_port_t *p = &ports->port[i];
        if (!p->in_use) continue;
        const ub_port_driver_t *d = &p->drv[p->active];
        int rc = UB_OK;
        switch (d->kind) {
        case UB_PORT_UDP:
            rc = add_fd(fds, cap, &n, ub_udp_fileno(&d->u.udp),
                        (short)(POLLIN | (ub_udp_tx_pending(&d->u.udp) > 0 ? POLLOUT : 0)));
            break;
        case UB_PORT_TCP_LISTEN:
        case UB_PORT_TCP_CONNECT: {
            const ub_tcp_t *t = &d->u.tcp;
            rc = add_fd(fds, cap, &n, ub_tcp_listen_fileno(t), POLLIN);
            bool out = ub_tcp_tx_pending(t) > 0 || ub_tcp_state(t) == UB_TCP_CONNECTING;
            if (rc == UB_OK) rc = add_fd(fds, cap, &n, ub_tcp_fileno(t), (short)(POLLIN | (out ? POLLOUT : 0)));
            break;
        }
        case UB_PORT_SERIAL:
            rc = add_fd(fds, cap, &n, ub_serial_fileno(&d->u.serial),
                        (short)(POLLIN | (ub_serial_tx_pending(&d->u.serial) > 0 ? POLLOUT : 0)));
            break;
        default: break;
        }
        if (rc != UB_OK) return rc;
    }
    return n;
}

int ub_ports_poll_timeout(const ub_ports_t *ports, uint64_t now_ms, int max_ms) {
    if (max_ms < 0) max_ms = 0;
    if (ports == NULL) return max_ms;
    uint64_t best = now_ms + (uint64_t)max_ms;
    for (size_t i = 0; i < UB_PORTS_MAX; i++) {
        const ub_port_t *p = &ports->port[i];
        if (!p->in_use) continue;
        uint64_t due;
        if (p->impaired && ub_impair_next_due(&p->impair, &due) && due < best) best = due;
        const ub_port_driver_t *d = &p->drv[p->active];
        /* A client waiting to retry has no descriptor to wake the loop: its retry time must. */
        if (d->kind == UB_PORT_TCP_CONNECT && ub_tcp_state(&d->u.tcp) == UB_TCP_DOWN
            && d->u.tcp.next_attempt_ms < best)
            best = d->u.tcp.next_attempt_ms;
        /* So must a serial device that hung up and waits to be reopened. */
        if (d->kind == UB_PORT_SERIAL && ub_serial_next_retry(&d->u.serial, &due) && due < best) best = due;
    }
    return best <= now_ms ? 0 : (int)(best - now_ms);
}

const ub_port_t *ub_ports_find(const ub_ports_t *ports, const char *link_name) {
    if (ports == NULL || ports->node == NULL) return NULL;
    int id = resolve_link(ports->node, link_name);
    return id >= 0 ? port_of_link((ub_ports_t *)ports, id) : NULL;
}

const ub_udp_t *ub_ports_udp(const ub_ports_t *ports, const char *link_name) {
    const ub_port_t *p = ub_ports_find(ports, link_name);
    if (p == NULL || p->drv[p->active].kind != UB_PORT_UDP) return NULL;
    return &p->drv[p->active].u.udp;
}

int ub_ports_local_port(const ub_ports_t *ports, const char *link_name, uint16_t *port) {
    if (ports == NULL || port == NULL) return UB_ERR_INVAL;
    const ub_port_t *p = ub_ports_find(ports, link_name);
    if (p == NULL) return UB_ERR_NOTFOUND;
    const ub_port_driver_t *d = &p->drv[p->active];
    switch (d->kind) {
    case UB_PORT_UDP: return ub_udp_local_port(&d->u.udp, port);
    case UB_PORT_TCP_LISTEN: return ub_tcp_local_port(&d->u.tcp, port);
    default: return UB_ERR_INVAL;
    }
}

int ub_ports_set_impairment(ub_ports_t *ports, const ub_impair_params_t *params, uint64_t seed) {
    if (ports == NULL || ports->node == NULL) return UB_ERR_INVAL;
    bool on = params != NULL && params_active(params);
    if (on) {
        ports->impair_params = *params;
    } else {
        memset(&ports->impair_params, 0, sizeof ports->impair_params);
    }
    bool reseed = ports->impair_seed != seed;
    ports->impair_seed = seed;
    ports->impair_on = on ? 1 : 0;
    for (size_t i = 0; i < UB_PORTS_MAX; i++) {
        ub_port_t *p = &ports->port[i];
        if (!p->in_use || p->own_impair) continue; /* a port with its own impairment keeps it */
        if (on) {
            if (p->impaired && reseed) ub_impair_reseed(&p->impair, port_seed(seed, p->link_id));
            impair_install(ports, p);
        } else {
            impair_remove(ports, p);
        }
    }
    return UB_OK;
}

int ub_ports_set_link_impairment(ub_ports_t *ports, const char *link_name, const ub_impair_params_t *params,
                                 uint64_t seed) {
    if (ports == NULL || ports->node == NULL || link_name == NULL) return UB_ERR_INVAL;
    const ub_port_t *found = ub_ports_find(ports, link_name);
    if (found == NULL) return UB_ERR_NOTFOUND;
    ub_port_t *p = &ports->port[found - ports->port];
    if (params != NULL && params_active(params)) {
        if (p->impaired && p->own_impair && p->own_seed != seed) ub_impair_reseed(&p->impair, port_seed(seed, p->link_id));
        p->own_impair = 1;
        p->own_params = *params;
        p->own_seed = seed;
        impair_install(ports, p);
    } else {
        p->own_impair = 0;
        if (ports->impair_on) impair_install(ports, p);
        else impair_remove(ports, p);
    }
    return UB_OK;
}

int ub_ports_notice(ub_ports_t *ports, char *out, size_t cap) {
    if (ports == NULL || ports->node == NULL || out == NULL || cap == 0) return UB_ERR_INVAL;
    for (size_t i = 0; i < UB_PORTS_MAX; i++) {
        ub_port_t *p = &ports->port[i];
        if (!p->in_use || p->refusal_reported) continue;
        const ub_port_driver_t *d = &p->drv[p->active];
        if (d->kind != UB_PORT_UDP || d->u.udp.stats.foreign == 0) continue;
        p->refusal_reported = 1;
        const ub_link_t *link = ub_node_link(ports->node, p->link_id);
        char from[INET_ADDRSTRLEN] = "?", peer[INET_ADDRSTRLEN + 8] = "?";
        const struct sockaddr_in *r = &d->u.udp.refused_from;
        if (r->sin_port != 0) (void)inet_ntop(AF_INET, &r->sin_addr, from, sizeof from);
        char host[16];
        uint16_t port = 0;
        if (ub_udp_peer_at(&d->u.udp, 0, host, &port) == UB_OK) snprintf(peer, sizeof peer, "%s:%u", host, port);
        fail(out, cap,
             "port '%s': refused a datagram from %s:%u: not this link's peer (%s); it is counted as 'foreign' and "
             "not reported again. To accept other senders too, open the port with accept=any (several peers, e.g. "
             "a GCS on an ephemeral port and a monitor) or accept=learn (docs/config-format.md#ports)",
             link != NULL ? link->name : "?", from, (unsigned)ntohs(r->sin_port), peer);
        return 1;
    }
    return 0;
}
