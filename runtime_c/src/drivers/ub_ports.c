/* Ports: transports behind a node's links, opened from text, serviced from one loop (ub_ports.h).
 *
 * A registry: every transport is a driver table (ub_driver.h) and every per-transport step (parse a
 * parameter, format, open, attach, service, poll, retry time, local port, counters, describe, notice)
 * goes through the table of the spec or instance at hand. What stays here is what every transport
 * shares: the spec syntax and its messages, the wire parameters (encoding=, mtu=), the software switch,
 * the impairment in front of a driver, and the link slot's bookkeeping. */
#include "ub/ub_ports.h"

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

/* Replaces control bytes and bytes outside printable ASCII by '?' (see fail()): for the text a driver wrote. */
static void sanitize(char *text) {
    for (char *c = text; c != NULL && *c != '\0'; c++) {
        if ((unsigned char)*c < 0x20 || (unsigned char)*c >= 0x7f) *c = '?';
    }
}

/* ---- the registry -------------------------------------------------------------------------------------- */

/* A spec naming no driver of its own (mem): parsed, and then skipped, because the program attaches a
 * ub_memlink itself. */
static void mem_spec_init(ub_port_spec_t *spec) { spec->kind = UB_PORT_MEM; }
static int mem_spec_param(ub_port_spec_t *spec, uint32_t *seen, const char *key, const char *value, char *err,
                          size_t cap) {
    (void)spec, (void)seen, (void)key, (void)value, (void)err, (void)cap;
    return UB_ERR_NOTFOUND;
}
static int mem_spec_format(const ub_port_spec_t *spec, char *out, size_t cap) {
    (void)spec;
    return snprintf(out, cap, "mem");
}
static const ub_driver_t k_mem_driver = {
    .name = "mem",
    .keys = "none",
    .examples = "mem",
    .spec_init = mem_spec_init,
    .spec_param = mem_spec_param,
    .spec_format = mem_spec_format,
};

/* The built-in drivers, in the order messages list them. Constant: each set registers them (ub_ports_init()). */
static const ub_driver_t *const k_builtin[] = {&ub_udp_driver, &ub_tcp_driver, &ub_serial_driver, &ub_legacy_driver,
                                               &k_mem_driver};
#define BUILTIN_COUNT (sizeof k_builtin / sizeof k_builtin[0])

/* Which drivers a parse knows: a set's registry, or the built-ins alone. */
typedef struct registry {
    const ub_driver_t *const *drivers;
    size_t count;
} registry_t;

static registry_t registry_of(const ub_ports_t *ports) {
    registry_t r = {k_builtin, BUILTIN_COUNT};
    if (ports != NULL && ports->driver_count > 0) {
        r.drivers = ports->drivers;
        r.count = ports->driver_count;
    }
    return r;
}

static const ub_driver_t *registry_find(registry_t r, const char *word) {
    for (size_t i = 0; i < r.count; i++) {
        if (strcmp(r.drivers[i]->name, word) == 0) return r.drivers[i];
    }
    return NULL;
}

/* Appends to `out` (NUL-terminated, `cap` bytes) what snprintf would, cut at the end. */
#if defined(__GNUC__) || defined(__clang__)
__attribute__((format(printf, 3, 4)))
#endif
static void append(char *out, size_t cap, const char *fmt, ...) {
    size_t len = strlen(out);
    if (len + 1 >= cap) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(out + len, cap - len, fmt, ap);
    va_end(ap);
}

/* "udp, tcp, serial, legacy or mem" and "udp:... | tcp:... | mem": the transports a message offers. */
static void registry_words(registry_t r, char *out, size_t cap) {
    out[0] = '\0';
    for (size_t i = 0; i < r.count; i++) {
        append(out, cap, "%s%s", i == 0 ? "" : i + 1 == r.count ? " or " : ", ", r.drivers[i]->name);
    }
}

static void registry_examples(registry_t r, char *out, size_t cap) {
    out[0] = '\0';
    for (size_t i = 0; i < r.count; i++) append(out, cap, "%s%s", i ? " | " : "", r.drivers[i]->examples);
}

static bool name_ok(const char *name) {
    size_t n = name != NULL ? strlen(name) : 0;
    if (n == 0 || n > UB_DRIVER_NAME_MAX) return false;
    for (size_t i = 0; i < n; i++) {
        if (!((name[i] >= 'a' && name[i] <= 'z') || (name[i] >= '0' && name[i] <= '9'))) return false;
    }
    return true;
}

static bool driver_ok(const ub_driver_t *d) {
    if (d == NULL || !name_ok(d->name) || d->keys == NULL || d->examples == NULL || d->spec_param == NULL ||
        d->spec_format == NULL)
        return false;
    if (d->open == NULL) return true; /* parsed only, like mem */
    return d->close != NULL && d->attach != NULL && d->link_ops != NULL && d->link_ops->send != NULL &&
           d->service != NULL && d->pollfds != NULL && d->counters != NULL && d->state_size <= UB_DRIVER_STATE_MAX;
}

int ub_ports_register(ub_ports_t *ports, const ub_driver_t *driver) {
    if (ports == NULL || !driver_ok(driver)) return UB_ERR_INVAL;
    registry_t r = registry_of(ports);
    if (registry_find(r, driver->name) != NULL) return UB_ERR_EXISTS;
    if (ports->driver_count >= UB_PORTS_MAX_DRIVERS) return UB_ERR_FULL;
    ports->drivers[ports->driver_count++] = driver;
    return UB_OK;
}

const char *ub_port_kind_transport(ub_port_kind_t kind) {
    static const char *const words[] = {
        [UB_PORT_NONE] = "none",  [UB_PORT_UDP] = "udp",       [UB_PORT_TCP_LISTEN] = "tcp",
        [UB_PORT_TCP_CONNECT] = "tcp", [UB_PORT_SERIAL] = "serial", [UB_PORT_MEM] = "mem",
        [UB_PORT_DRIVER] = "none",
    };
    return (unsigned)kind < sizeof words / sizeof words[0] ? words[kind] : "none";
}

const char *ub_port_spec_transport(const ub_port_spec_t *spec) {
    return spec != NULL && spec->driver != NULL ? spec->driver->name : "none";
}

/* ---- spec parsing (shared by the command-line and config forms) -------------------------------------- */

/* Spec being built: its driver, the driver's bits of what it has seen, and the wire parameters seen. */
typedef struct spec_builder {
    ub_port_spec_t spec;
    uint32_t seen;
    bool has_encoding, has_mtu, has_prio;
} spec_builder_t;

static int builder_start(spec_builder_t *b, registry_t r, const char *transport, char *err, size_t cap) {
    memset(b, 0, sizeof *b);
    const ub_driver_t *d = registry_find(r, transport);
    if (d == NULL) {
        char words[160], examples[UB_PORTS_ERR_LEN];
        registry_words(r, words, sizeof words);
        registry_examples(r, examples, sizeof examples);
        fail(err, cap, "unknown transport '%.20s' (expected %s, e.g. %s)", transport, words, examples);
        return UB_ERR_INVAL;
    }
    b->spec.driver = d;
    b->spec.kind = UB_PORT_DRIVER;
    if (d->spec_init != NULL) d->spec_init(&b->spec);
    return UB_OK;
}

/* One KEY=VALUE: the driver's own keys first, then the link's wire parameters. Messages name the key so
 * the caller can prefix where it came from. */
static int builder_param(spec_builder_t *b, const char *key, const char *value, char *err, size_t cap) {
    ub_port_spec_t *s = &b->spec;
    const ub_driver_t *d = s->driver;
    char msg[UB_PORTS_ERR_LEN] = "";
    int rc = d->spec_param(s, &b->seen, key, value, msg, sizeof msg);
    if (rc != UB_ERR_NOTFOUND) {
        if (rc != UB_OK) fail(err, cap, "%s", msg);
        return rc == UB_OK ? UB_OK : UB_ERR_INVAL;
    }
    if (d->wire_params && strcmp(key, "encoding") == 0) {
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
    if (d->wire_params && strcmp(key, "mtu") == 0) {
        uint32_t v = 0;
        if (b->has_mtu || !ub_driver_parse_u32(value, 65535u, &v) || v < UB_LINK_MTU_MIN) {
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
    if (d->wire_params && strcmp(key, "prio") == 0) {
        if (b->has_prio || (strcmp(value, "0") != 0 && strcmp(value, "1") != 0)) {
            fail(err, cap, "'prio=%.20s': %s", value,
                 b->has_prio ? "given twice: give it once"
                             : "give 1 (send by priority class at the port's byte rate: a serial port's baud / 10) or 0");
            return UB_ERR_INVAL;
        }
        s->prio = value[0] == '1' ? 1 : 0;
        b->has_prio = true;
        return UB_OK;
    }
    fail(err, cap, "unknown parameter '%.20s' for %s (expected: %s%s)", key, d->name, d->keys,
         d->wire_params ? ", encoding, mtu, prio" : "");
    return UB_ERR_INVAL;
}

static int builder_finish(spec_builder_t *b, ub_port_spec_t *out, char *err, size_t cap) {
    const ub_driver_t *d = b->spec.driver;
    char msg[UB_PORTS_ERR_LEN] = "";
    if (d->spec_finish != NULL && d->spec_finish(&b->spec, b->seen, msg, sizeof msg) != UB_OK) {
        fail(err, cap, "%s", msg);
        return UB_ERR_INVAL;
    }
    if (b->spec.prio && (b->spec.kind != UB_PORT_SERIAL || b->spec.baud < 10)) {
        fail(err, cap, "'prio=1' needs the port's byte rate: a serial port with baud= (on another transport give the "
                       "impairment a rate: --impair rate=BYTES_PER_S,prio=1)");
        return UB_ERR_INVAL;
    }
    *out = b->spec;
    return UB_OK;
}

static int spec_parse(registry_t r, const char *text, ub_port_spec_t *spec, char *err, size_t err_cap) {
    if (text == NULL || spec == NULL) return UB_ERR_INVAL;
    char buf[256];
    size_t n = strlen(text);
    if (n == 0 || n >= sizeof buf) {
        char examples[UB_PORTS_ERR_LEN];
        registry_examples(r, examples, sizeof examples);
        fail(err, err_cap, "port spec must be 1 to %zu characters: TRANSPORT[:KEY=VALUE,...], e.g. %s",
             sizeof buf - 1, examples);
        return UB_ERR_INVAL;
    }
    memcpy(buf, text, n + 1);
    char *params = strchr(buf, ':');
    if (params != NULL) *params++ = '\0';
    spec_builder_t b;
    int rc = builder_start(&b, r, buf, err, err_cap);
    if (rc != UB_OK) return rc;
    while (params != NULL && *params != '\0') {
        char *next = strchr(params, ',');
        if (next != NULL) *next++ = '\0';
        char *eq = strchr(params, '=');
        if (eq == NULL || eq == params) {
            char examples[UB_PORTS_ERR_LEN];
            registry_examples(r, examples, sizeof examples);
            fail(err, err_cap, "'%.40s' is not KEY=VALUE (e.g. %s)", params, examples);
            return UB_ERR_INVAL;
        }
        *eq = '\0';
        rc = builder_param(&b, params, eq + 1, err, err_cap);
        if (rc != UB_OK) return rc;
        params = next;
    }
    return builder_finish(&b, spec, err, err_cap);
}

int ub_port_spec_parse(const char *text, ub_port_spec_t *spec, char *err, size_t err_cap) {
    return spec_parse(registry_of(NULL), text, spec, err, err_cap);
}

int ub_ports_spec_parse(const ub_ports_t *ports, const char *text, ub_port_spec_t *spec, char *err, size_t err_cap) {
    if (ports == NULL) return UB_ERR_INVAL;
    return spec_parse(registry_of(ports), text, spec, err, err_cap);
}

static int arg_parse(registry_t r, const char *arg, char *name, size_t name_cap, ub_port_spec_t *spec, char *err,
                     size_t err_cap) {
    if (arg == NULL || name == NULL || name_cap == 0 || spec == NULL) return UB_ERR_INVAL;
    const char *eq = strchr(arg, '=');
    size_t n = eq != NULL ? (size_t)(eq - arg) : 0;
    /* "tcp:connect=..." without a link name would otherwise read as link "tcp:connect" (entity:link form). */
    bool spec_only = false;
    for (size_t i = 0; i < r.count; i++) {
        size_t w = strlen(r.drivers[i]->name);
        spec_only = spec_only || (r.drivers[i]->open != NULL && strncmp(arg, r.drivers[i]->name, w) == 0 &&
                                  arg[w] == ':');
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
    if (spec_parse(r, eq + 1, spec, msg, sizeof msg) != UB_OK) {
        fail(err, err_cap, "port '%.*s': %s", (int)n, arg, msg);
        return UB_ERR_INVAL;
    }
    memcpy(name, arg, n);
    name[n] = '\0';
    return UB_OK;
}

int ub_port_arg_parse(const char *arg, char *name, size_t name_cap, ub_port_spec_t *spec, char *err,
                      size_t err_cap) {
    return arg_parse(registry_of(NULL), arg, name, name_cap, spec, err, err_cap);
}

int ub_ports_arg_parse(const ub_ports_t *ports, const char *arg, char *name, size_t name_cap, ub_port_spec_t *spec,
                       char *err, size_t err_cap) {
    if (ports == NULL) return UB_ERR_INVAL;
    return arg_parse(registry_of(ports), arg, name, name_cap, spec, err, err_cap);
}

static int spec_from_config(registry_t r, const ub_nodecfg_port_t *entry, const char *source, ub_port_spec_t *spec,
                            char *err, size_t err_cap) {
    if (entry == NULL || spec == NULL) return UB_ERR_INVAL;
    if (source == NULL) source = "<config>";
    char msg[UB_PORTS_ERR_LEN];
    spec_builder_t b;
    if (builder_start(&b, r, entry->transport, msg, sizeof msg) != UB_OK) {
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

int ub_port_spec_from_config(const ub_nodecfg_port_t *entry, const char *source, ub_port_spec_t *spec, char *err,
                             size_t err_cap) {
    return spec_from_config(registry_of(NULL), entry, source, spec, err, err_cap);
}

int ub_ports_spec_from_config(const ub_ports_t *ports, const ub_nodecfg_port_t *entry, const char *source,
                              ub_port_spec_t *spec, char *err, size_t err_cap) {
    if (ports == NULL) return UB_ERR_INVAL;
    return spec_from_config(registry_of(ports), entry, source, spec, err, err_cap);
}

void ub_port_spec_format(const ub_port_spec_t *spec, char *out, size_t cap) {
    if (out == NULL || cap == 0) return;
    if (spec == NULL) {
        out[0] = '\0';
        return;
    }
    int n = spec->driver != NULL ? spec->driver->spec_format(spec, out, cap) : snprintf(out, cap, "none");
    if (n >= 0 && (size_t)n < cap && spec->encoding == UB_PORT_ENCODING_COMPACT)
        n += snprintf(out + n, cap - (size_t)n, ",encoding=compact");
    if (n >= 0 && (size_t)n < cap && spec->mtu != 0) n += snprintf(out + n, cap - (size_t)n, ",mtu=%u", (unsigned)spec->mtu);
    if (n >= 0 && (size_t)n < cap && spec->prio != 0) n += snprintf(out + n, cap - (size_t)n, ",prio=1");
    /* A cut text ends in "..." so it cannot be mistaken for a whole spec (diagnostics only). */
    if ((n < 0 || (size_t)n >= cap) && cap >= 4) memcpy(out + cap - 4, "...", 4);
}

/* Counters the default description (a driver without describe()) writes at most. */
#define UB_PORTS_DESCRIBE_COUNTERS 32

/* ---- driver instances: every call goes through the instance's driver table ------------------------------ */

static const ub_link_ops_t *driver_ops(ub_port_driver_t *d, void **impl) {
    *impl = d->driver != NULL ? &d->state : NULL;
    return d->driver != NULL ? d->driver->link_ops : NULL;
}

static void driver_close(ub_port_driver_t *d) {
    if (d->driver != NULL) d->driver->close(&d->state);
    d->driver = NULL;
}

/* Opens the socket/device of `spec` into `d` (not attached yet). errno is kept for the caller. */
static int driver_open(ub_port_driver_t *d, const ub_port_spec_t *spec) {
    memset(d, 0, sizeof *d);
    const ub_driver_t *drv = spec->driver;
    if (drv == NULL || drv->open == NULL || drv->state_size > sizeof d->state) return UB_ERR_INVAL;
    int rc = drv->open(&d->state, spec);
    if (rc == UB_OK) d->driver = drv;
    return rc;
}

static int driver_attach(ub_port_driver_t *d, ub_node_t *node, int link_id) {
    return d->driver != NULL ? d->driver->attach(&d->state, node, link_id) : UB_ERR_INVAL;
}

static int driver_service(ub_port_driver_t *d, ub_node_t *node, uint64_t now_ms) {
    return d->driver != NULL ? d->driver->service(&d->state, node, now_ms) : 0;
}

/* ---- the set ----------------------------------------------------------------------------------------- */

int ub_ports_init(ub_ports_t *ports, ub_node_t *node) {
    if (ports == NULL || node == NULL) return UB_ERR_INVAL;
    memset(ports, 0, sizeof *ports);
    ports->node = node;
    for (size_t i = 0; i < BUILTIN_COUNT; i++) ports->drivers[ports->driver_count++] = k_builtin[i];
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

/* The impairment in force for a port: its own, else the node-wide one, else none (NULL). A port whose spec
 * asks for priorities (prio=1) always has one: the bandwidth model at the port's own byte rate (serial 8N1:
 * baud / 10) sending by class (ub_prio.h), on top of whatever impairment is set; frames then reach the UART no
 * faster than it drains them, so its buffer stays about one frame long and the class decides the order. */
static const ub_impair_params_t *port_params(const ub_ports_t *ports, ub_port_t *p, uint64_t *seed) {
    const ub_impair_params_t *base;
    if (p->own_impair) {
        *seed = p->own_seed;
        base = &p->own_params;
    } else {
        *seed = ports->impair_seed;
        base = ports->impair_on ? &ports->impair_params : NULL;
    }
    if (!p->spec.prio) return base;
    if (base != NULL) p->eff_params = *base;
    else memset(&p->eff_params, 0, sizeof p->eff_params);
    if (p->eff_params.rate_Bps == 0) p->eff_params.rate_Bps = p->spec.baud / 10u;
    p->eff_params.prio = 1;
    return &p->eff_params;
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
    if (spec->driver == NULL || spec->driver->open == NULL) {
        fail(err, err_cap, "port '%s': transport '%s' cannot be opened from a spec (attach a ub_memlink in the program)",
             link_name, ub_port_spec_transport(spec));
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
             rebind && p->drv[p->active].driver != NULL ? "; the previous transport stays in place" : "");
        if (rebind && p->drv[p->active].driver == NULL) {
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
    /* E.g. a TCP client starts its first connection attempt now rather than at the first service. */
    ub_port_driver_t *d = &p->drv[slot];
    if (p->foreign != NULL && d->driver->set_foreign != NULL) { /* the handler follows a software switch */
        if (d->driver->set_foreign(&d->state, p->foreign, p->foreign_user) != UB_OK) { /* cannot fail: valid state */ }
    }
    if (d->driver->start != NULL) d->driver->start(&d->state, ports->node, now_ms);
    return UB_OK;
}

int ub_ports_open_text(ub_ports_t *ports, const char *link_name, const char *spec_text, uint64_t now_ms, char *err,
                       size_t err_cap) {
    ub_port_spec_t spec;
    char msg[UB_PORTS_ERR_LEN];
    if (ports == NULL) return UB_ERR_INVAL;
    if (ub_ports_spec_parse(ports, spec_text, &spec, msg, sizeof msg) != UB_OK) {
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
        int rc = ub_ports_spec_from_config(ports, &cfg->ports[i], cfg->source, &specs[i], err, err_cap);
        if (rc != UB_OK) return rc;
    }
    for (unsigned i = 0; i < cfg->port_count; i++) {
        const ub_nodecfg_port_t *e = &cfg->ports[i];
        if (specs[i].driver->open == NULL) continue; /* mem: the program attaches it */
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

int ub_ports_set_foreign(ub_ports_t *ports, const char *link_name, ub_foreign_cb cb, void *user) {
    if (ports == NULL || ports->node == NULL) return UB_ERR_INVAL;
    int id = resolve_link(ports->node, link_name);
    ub_port_t *p = id >= 0 ? port_of_link(ports, id) : NULL;
    if (p == NULL || p->drv[p->active].driver == NULL) return UB_ERR_NOTFOUND;
    ub_port_driver_t *d = &p->drv[p->active];
    if (d->driver->set_foreign == NULL) return UB_ERR_UNSUPPORTED;
    int rc = d->driver->set_foreign(&d->state, cb, user);
    if (rc != UB_OK) return rc;
    p->foreign = cb;
    p->foreign_user = cb != NULL ? user : NULL;
    return UB_OK;
}

int ub_ports_write_foreign(ub_ports_t *ports, const char *link_name, const uint8_t *data, size_t len,
                           uint64_t now_ms) {
    if (ports == NULL || ports->node == NULL || (data == NULL && len != 0)) return UB_ERR_INVAL;
    int id = resolve_link(ports->node, link_name);
    ub_port_t *p = id >= 0 ? port_of_link(ports, id) : NULL;
    if (p == NULL || p->drv[p->active].driver == NULL) return UB_ERR_NOTFOUND;
    ub_port_driver_t *d = &p->drv[p->active];
    if (d->driver->write_foreign == NULL) return UB_ERR_UNSUPPORTED;
    return d->driver->write_foreign(&d->state, data, len, now_ms);
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

/* The impairment in front of a port: put back after a TCP re-attach, its queue released when due. */
static void service_impair(ub_ports_t *ports, ub_port_t *p, uint64_t now_ms) {
    if (!p->impaired) return;
    /* A TCP driver re-attaches itself when a connection comes up: put the impairment back in front. */
    const ub_link_t *link = ub_node_link(ports->node, p->link_id);
    if (link != NULL && link->ops != &ub_impair_ops
        && ub_node_link_set_transport(ports->node, p->link_id, &ub_impair_ops, &p->impair) != UB_OK) {
        p->service_errors++; /* cannot happen: the id was resolved */
    }
    (void)ub_impair_service(&p->impair, now_ms);
}

static int service_port(ub_ports_t *ports, ub_port_t *p, bool driver, uint64_t now_ms) {
    int n = driver ? driver_service(&p->drv[p->active], ports->node, now_ms) : 0;
    if (n < 0) p->service_errors++;
    service_impair(ports, p, now_ms);
    return n < 0 ? 0 : n;
}

int ub_ports_service(ub_ports_t *ports, uint64_t now_ms) {
    if (ports == NULL || ports->node == NULL) return 0;
    int total = 0;
    for (size_t i = 0; i < UB_PORTS_MAX; i++) {
        ub_port_t *p = &ports->port[i];
        if (p->in_use) total += service_port(ports, p, true, now_ms);
    }
    return total;
}

/* Has the instance work: not ready_only, due, or one of its descriptors reported by poll()? */
static bool instance_has_work(const ub_port_driver_t *d, const struct pollfd *fds, int nfds, uint64_t now_ms) {
    const ub_driver_t *drv = d->driver;
    if (drv == NULL) return false;
    if (!drv->ready_only) return true;
    struct pollfd own[2]; /* ub_driver.h: at most 2 per instance */
    int k = drv->pollfds(&d->state, own, 2);
    if (k < 0) return true;
    for (int j = 0; j < k; j++) {
        for (int i = 0; i < nfds; i++) {
            if (fds[i].fd == own[j].fd && fds[i].revents != 0) return true;
        }
    }
    uint64_t due; /* last: the readiness above is what most turns find */
    return drv->next_due != NULL && drv->next_due(&d->state, &due) && due <= now_ms;
}

int ub_ports_service_ready(ub_ports_t *ports, const struct pollfd *fds, int nfds, uint64_t now_ms) {
    if (ports == NULL || ports->node == NULL) return 0;
    if (fds == NULL || nfds < 0) nfds = 0;
    int total = 0;
    for (size_t i = 0; i < UB_PORTS_MAX; i++) {
        ub_port_t *p = &ports->port[i];
        if (!p->in_use) continue;
        total += service_port(ports, p, instance_has_work(&p->drv[p->active], fds, nfds, now_ms), now_ms);
    }
    return total;
}

int ub_ports_flush(ub_ports_t *ports) {
    if (ports == NULL) return UB_ERR_INVAL;
    int left = 0;
    for (size_t i = 0; i < UB_PORTS_MAX; i++) {
        ub_port_t *p = &ports->port[i];
        ub_port_driver_t *d = &p->drv[p->active];
        if (!p->in_use || d->driver == NULL || d->driver->flush == NULL) continue;
        int n = d->driver->flush(&d->state);
        if (n < 0) p->service_errors++;
        else left += n;
    }
    return left;
}

int ub_ports_pollfds(const ub_ports_t *ports, struct pollfd *fds, int cap) {
    if (ports == NULL || (fds == NULL && cap > 0) || cap < 0) return UB_ERR_INVAL;
    int n = 0;
    for (size_t i = 0; i < UB_PORTS_MAX; i++) {
        const ub_port_t *p = &ports->port[i];
        const ub_port_driver_t *d = &p->drv[p->active];
        if (!p->in_use || d->driver == NULL) continue;
        int rc = d->driver->pollfds(&d->state, fds + n, cap - n);
        if (rc < 0) return rc;
        n += rc;
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
        /* A driver with nothing to poll while it waits (a TCP client's retry, a serial device's reopen) must
         * still be serviced in time: its due time wakes the loop. */
        const ub_port_driver_t *d = &p->drv[p->active];
        if (d->driver != NULL && d->driver->next_due != NULL && d->driver->next_due(&d->state, &due) && due < best)
            best = due;
    }
    return best <= now_ms ? 0 : (int)(best - now_ms);
}

const ub_port_t *ub_ports_find(const ub_ports_t *ports, const char *link_name) {
    if (ports == NULL || ports->node == NULL) return NULL;
    int id = resolve_link(ports->node, link_name);
    return id >= 0 ? port_of_link((ub_ports_t *)ports, id) : NULL;
}

const void *ub_ports_state(const ub_ports_t *ports, const char *link_name, const ub_driver_t *driver) {
    const ub_port_t *p = ub_ports_find(ports, link_name);
    if (p == NULL) return NULL;
    const ub_port_driver_t *d = &p->drv[p->active];
    if (d->driver == NULL || (driver != NULL && d->driver != driver)) return NULL;
    return &d->state;
}

/* Kept for the programs that read a UDP port's peers and stats (ub_udp.h). */
const ub_udp_t *ub_ports_udp(const ub_ports_t *ports, const char *link_name) {
    return ub_ports_state(ports, link_name, &ub_udp_driver);
}

int ub_ports_local_port(const ub_ports_t *ports, const char *link_name, uint16_t *port) {
    if (ports == NULL || port == NULL) return UB_ERR_INVAL;
    const ub_port_t *p = ub_ports_find(ports, link_name);
    if (p == NULL) return UB_ERR_NOTFOUND;
    const ub_port_driver_t *d = &p->drv[p->active];
    if (d->driver == NULL || d->driver->local_port == NULL) return UB_ERR_INVAL;
    return d->driver->local_port(&d->state, port);
}

int ub_ports_counters(const ub_ports_t *ports, const char *link_name, ub_driver_counter_t *out, size_t cap) {
    if (ports == NULL || (out == NULL && cap > 0)) return UB_ERR_INVAL;
    const ub_port_t *p = ub_ports_find(ports, link_name);
    if (p == NULL || p->drv[p->active].driver == NULL) return UB_ERR_NOTFOUND;
    const ub_port_driver_t *d = &p->drv[p->active];
    size_t n = d->driver->counters(&d->state, out, cap);
    return n > INT32_MAX ? INT32_MAX : (int)n;
}

int ub_ports_describe(const ub_ports_t *ports, const char *link_name, char *out, size_t cap) {
    if (ports == NULL || out == NULL || cap == 0) return UB_ERR_INVAL;
    out[0] = '\0';
    const ub_port_t *p = ub_ports_find(ports, link_name);
    if (p == NULL || p->drv[p->active].driver == NULL) return UB_ERR_NOTFOUND;
    const ub_port_driver_t *d = &p->drv[p->active];
    int n = snprintf(out, cap, "\"%s\":{", d->driver->name);
    size_t at = n >= 0 && (size_t)n < cap ? (size_t)n : cap - 1;
    int k;
    if (d->driver->describe != NULL) {
        k = d->driver->describe(&d->state, out + at, cap - at);
    } else {
        ub_driver_counter_t c[UB_PORTS_DESCRIBE_COUNTERS];
        size_t m = d->driver->counters(&d->state, c, UB_PORTS_DESCRIBE_COUNTERS);
        k = ub_driver_format_counters(c, m < UB_PORTS_DESCRIBE_COUNTERS ? m : UB_PORTS_DESCRIBE_COUNTERS, out + at,
                                      cap - at);
    }
    if (n < 0 || k < 0) return UB_ERR_INVAL;
    n += k;
    at = (size_t)n < cap ? (size_t)n : cap - 1;
    n += snprintf(out + at, cap - at, "}");
    sanitize(out); /* one clean line, whatever a driver wrote */
    if ((size_t)n >= cap) {
        if (cap >= 4) memcpy(out + cap - 4, "...", 4);
        return UB_ERR_NOSPACE;
    }
    return n;
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
        uint64_t unused_seed;
        if (port_params(ports, p, &unused_seed) != NULL) { /* the node-wide one, or a prio=1 port's budget */
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
        uint64_t unused_seed;
        if (port_params(ports, p, &unused_seed) != NULL) impair_install(ports, p);
        else impair_remove(ports, p);
    }
    return UB_OK;
}

int ub_ports_notice(ub_ports_t *ports, char *out, size_t cap) {
    if (ports == NULL || ports->node == NULL || out == NULL || cap == 0) return UB_ERR_INVAL;
    for (size_t i = 0; i < UB_PORTS_MAX; i++) {
        ub_port_t *p = &ports->port[i];
        const ub_port_driver_t *d = &p->drv[p->active];
        if (!p->in_use || p->notice_reported || d->driver == NULL || d->driver->notice == NULL) continue;
        const ub_link_t *link = ub_node_link(ports->node, p->link_id);
        if (d->driver->notice(&d->state, link != NULL ? link->name : "?", out, cap) != 1) continue;
        p->notice_reported = 1;
        sanitize(out);
        return 1;
    }
    return 0;
}
