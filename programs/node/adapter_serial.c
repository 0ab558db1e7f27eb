/*
 * The serial-port half every device adapter shares (contracts and shape in adapter_serial.h). Written once
 * so that an adapter file holds only its device: the parser, what a message writes into the directory, its
 * counters (docs/adapters.md, "Adding your own adapter").
 */
#include "adapter_serial.h"

#include <poll.h>
#include <stdio.h>
#include <string.h>

#include "ub/ub_catalogue.h"
#include "ub/ub_node.h"
#include "ub/ub_node_svc.h"

/* The kind whose driver table this is: the kind starts with its driver (adapter_serial.h). */
static const adapter_serial_kind_t *kind_of(const ub_driver_t *driver) {
    return (const adapter_serial_kind_t *)(const void *)driver;
}

/* The link's foreign-traffic handler: every byte that is not a uavbus frame goes to the kind's parser. */
static size_t to_parser(void *user, const uint8_t *run, size_t len) {
    adapter_serial_t *a = user;
    if (a->dir == NULL) return 0; /* not attached: refused, and counted so (foreign_refused) */
    return a->kind->feed(a, run, len);
}

/* ---- the spec ---- */

enum { SEEN_DIR = 1u << 8 }; /* above the serial driver's own bits, which its spec_param sets */

void adapter_serial_spec_init(ub_port_spec_t *spec) {
    const adapter_serial_kind_t *k = kind_of(spec->driver);
    spec->kind = UB_PORT_DRIVER;
    spec->baud = k->default_baud;
    /* the directory name is kept in `host` (ub_ports.h allows a driver its own use of the fields) */
    snprintf(spec->host, sizeof spec->host, "%s", k->default_dir);
}

int adapter_serial_spec_param(ub_port_spec_t *s, uint32_t *seen, const char *key, const char *value, char *err,
                              size_t cap) {
    if (strcmp(key, "dir") == 0) {
        const adapter_serial_kind_t *k = kind_of(s->driver);
        size_t n = strlen(value);
        bool ok = n > 0 && n < sizeof s->host;
        for (size_t i = 0; ok && i < n; i++) {
            char c = value[i];
            ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
        }
        if (!ok || (*seen & SEEN_DIR)) {
            snprintf(err, cap, "'dir=%.40s': give one catalogued directory name of type %s, e.g. dir=%s", value,
                     k->dir_type, k->default_dir);
            return UB_ERR_INVAL;
        }
        memcpy(s->host, value, n + 1);
        *seen |= SEEN_DIR;
        return UB_OK;
    }
    return ub_serial_driver.spec_param(s, seen, key, value, err, cap); /* device, baud */
}

int adapter_serial_spec_finish(ub_port_spec_t *s, uint32_t seen, char *err, size_t cap) {
    (void)seen;
    if (s->device[0] == '\0') {
        const adapter_serial_kind_t *k = kind_of(s->driver);
        snprintf(err, cap, "%s needs device=PATH, e.g. %s:device=/dev/ttyUSB0,baud=%u", k->driver.name,
                 k->driver.name, (unsigned)k->default_baud);
        return UB_ERR_INVAL;
    }
    return UB_OK;
}

int adapter_serial_spec_format(const ub_port_spec_t *spec, char *out, size_t cap) {
    return snprintf(out, cap, "%s:device=%s,baud=%u,dir=%s", spec->driver->name, spec->device, (unsigned)spec->baud,
                    spec->host);
}

/* ---- one instance ---- */

int adapter_serial_open(void *state, const ub_port_spec_t *spec) {
    adapter_serial_t *a = state;
    int rc = ub_serial_open(&a->serial, spec->device, spec->baud);
    if (rc != UB_OK) return rc;
    a->kind = kind_of(spec->driver);
    ub_decoder_init(&a->dec);
    ub_decoder_set_foreign(&a->dec, to_parser, a);
    a->kind->reset(a);
    snprintf(a->dir_name, sizeof a->dir_name, "%s", spec->host);
    return ub_serial_set_decoder(&a->serial, &a->dec);
}

void adapter_serial_close(void *state) { ub_serial_driver.close(&((adapter_serial_t *)state)->serial); }

void *adapter_serial_directory(adapter_serial_t *a, const char *name, size_t size) {
    if (a->node == NULL) return NULL;
    const ub_catalogue_t *cat = ub_node_catalogue(a->node);
    int inst = cat != NULL ? ub_catalogue_find_name(cat, name) : UB_ERR_NOTFOUND;
    if (inst < 0 || cat->instances[inst].type->c_size != size) return NULL;
    return ub_node_binding(a->node, (uint32_t)inst);
}

/* The directory must be catalogued with the adapter's layout and bound (hosted) on this node: the adapter
 * writes into that storage and nowhere else. */
int adapter_serial_attach(void *state, ub_node_t *node, int link_id) {
    adapter_serial_t *a = state;
    const ub_catalogue_t *cat = ub_node_catalogue(node);
    int inst = cat != NULL ? ub_catalogue_find_name(cat, a->dir_name) : UB_ERR_NOTFOUND;
    if (inst < 0) return UB_ERR_NOTFOUND;
    if (cat->instances[inst].type->c_size != a->kind->dir_size) return UB_ERR_INVAL; /* fail closed */
    a->node = node;
    a->dir = adapter_serial_directory(a, a->dir_name, a->kind->dir_size);
    if (a->dir == NULL) return UB_ERR_NOTFOUND;
    return ub_serial_attach(&a->serial, node, link_id);
}

int adapter_serial_service(void *state, ub_node_t *node, uint64_t now_ms) {
    adapter_serial_t *a = state;
    a->now_ms = now_ms;
    if (a->kind->service != NULL && a->dir != NULL) a->kind->service(a, now_ms);
    return ub_serial_service(&a->serial, node, now_ms);
}

int adapter_serial_pollfds(const void *state, struct pollfd *fds, int cap) {
    return ub_serial_driver.pollfds(&((const adapter_serial_t *)state)->serial, fds, cap);
}

bool adapter_serial_next_due(const void *state, uint64_t *due_ms) {
    return ub_serial_next_retry(&((const adapter_serial_t *)state)->serial, due_ms);
}

int adapter_serial_write(adapter_serial_t *a, const uint8_t *data, size_t len) {
    return ub_serial_write_foreign(&a->serial, data, len, a->now_ms);
}

size_t adapter_serial_put_counters(const ub_driver_counter_t *all, size_t n, ub_driver_counter_t *out, size_t cap) {
    for (size_t i = 0; i < n && i < cap && out != NULL; i++) out[i] = all[i];
    return n;
}

/* The kind's counters, then the link's: what the decoder found and rejected, and the serial link's bytes. */
size_t adapter_serial_counters(const void *state, ub_driver_counter_t *out, size_t cap) {
    const adapter_serial_t *a = state;
    size_t own = a->kind != NULL ? a->kind->counters(a, out, out != NULL ? cap : 0) : 0;
    const ub_decoder_stats_t *d = &a->dec.stats;
    uint64_t rejected = 0;
    for (int r = 0; r < UB_RX_REASON_COUNT; r++) rejected += d->rejected[r];
    const ub_driver_counter_t link[] = {
        {"frames_in", d->frames_ok},
        {"frames_rejected", rejected},
        {"foreign_bytes", d->foreign_bytes},
        {"foreign_refused", d->foreign_refused},
        {"bytes_in", a->serial.stats.bytes_in},
        {"bytes_out", a->serial.stats.bytes_out},
        {"foreign_out", a->serial.stats.foreign_out},
        {"hangups", a->serial.stats.hangups},
    };
    size_t rest = out != NULL && cap > own ? cap - own : 0;
    return own + adapter_serial_put_counters(link, sizeof link / sizeof link[0], rest ? out + own : NULL, rest);
}
