/*
 * The u-blox UBX GPS adapter (issue #24): a receiver speaking UBX on a serial port becomes the catalogued
 * directory `gpsUbx` (examples/flightsw/ubx_gps.h), published by the node like any other, and the same port
 * still carries uavbus frames. Port spec:
 *
 *     ubx:device=/dev/ttyACM0[,baud=115200][,dir=gpsUbx]
 *
 * The second adapter written the way docs/adapters.md describes (adapter_nmea.c is the first): a serial link
 * read through a decoder of its own whose foreign-traffic handler is the UBX parser (ub_ubx.h); each good
 * NAV-PVT is written into the directory's bound storage. Reading only: writing CFG messages (and checking
 * their ACK) is not done yet.
 */
#include <poll.h>
#include <stdio.h>
#include <string.h>

#include "ubx_gps.h"
#include "ub/ub_catalogue.h"
#include "ub/ub_driver.h"
#include "ub/ub_frame.h"
#include "ub/ub_node.h"
#include "ub/ub_node_svc.h"
#include "ub/ub_ports.h"
#include "ub/ub_serial.h"
#include "ub/ub_ubx.h"

#define UBX_DEFAULT_DIR "gpsUbx"
#define UBX_DEFAULT_BAUD 115200u

typedef struct ubx_adapter {
    ub_serial_t serial; /* first: the link's impl (ub_serial_ops) is this serial link */
    ub_decoder_t dec;   /* the link's decoder; its foreign-traffic handler is the parser */
    ub_ubx_t ubx;
    ubxGps_t *dir;      /* the directory's bound storage; NULL until attached */
    uint64_t now_ms;
    char dir_name[UB_PORT_HOST_LEN];
} ubx_adapter_t;

static void write_counters(ubx_adapter_t *a) {
    const ub_ubx_stats_t *s = &a->ubx.stats;
    a->dir->navPvtOk = (uint32_t)s->nav_pvt;
    a->dir->badChecksums = (uint32_t)s->bad_checksum;
    a->dir->badMessages = (uint32_t)(s->bad_length + s->too_long);
}

static void on_pvt(void *user, const ub_ubx_t *ubx) {
    ubx_adapter_t *a = user;
    const ub_ubx_pvt_t *p = &ubx->pvt;
    ubxGps_t *d = a->dir;
    d->time.seconds = (uint32_t)(a->now_ms / 1000u);
    d->time.microseconds = (uint32_t)(a->now_ms % 1000u * 1000u);
    d->latitudeDeg = p->lat_1e7 / 1e7;
    d->longitudeDeg = p->lon_1e7 / 1e7;
    d->altitudeMsl = p->hmsl_mm / 1000.0;
    d->heightEllipsoid = p->height_mm / 1000.0;
    d->groundSpeedMps = p->g_speed_mms / 1000.0;
    d->headingDeg = p->head_mot_1e5 / 1e5;
    d->velNorth = (float)(p->vel_n_mms / 1000.0);
    d->velEast = (float)(p->vel_e_mms / 1000.0);
    d->velDown = (float)(p->vel_d_mms / 1000.0);
    d->hAccuracy = (float)(p->h_acc_mm / 1000.0);
    d->vAccuracy = (float)(p->v_acc_mm / 1000.0);
    d->pdop = (float)(p->p_dop_1e2 / 100.0);
    d->iTowMs = p->itow_ms;
    d->year = p->year;
    d->month = p->month;
    d->day = p->day;
    d->hour = p->hour;
    d->minute = p->min;
    d->second = p->sec;
    d->fixType = p->fix_type;
    d->satellitesUsed = p->num_sv;
}

static size_t to_parser(void *user, const uint8_t *run, size_t len) {
    ubx_adapter_t *a = user;
    if (a->dir == NULL) return 0;
    int decoded = ub_ubx_feed(&a->ubx, run, len, on_pvt, a);
    (void)decoded; /* the parser's own counters say it */
    write_counters(a);
    return len;
}

/* ---- the driver table ---- */

enum { SEEN_DIR = 1u << 8 }; /* above the serial driver's own bits, which its spec_param sets */

static void ubx_spec_init(ub_port_spec_t *spec) {
    spec->kind = UB_PORT_DRIVER;
    spec->baud = UBX_DEFAULT_BAUD;
    memcpy(spec->host, UBX_DEFAULT_DIR, sizeof UBX_DEFAULT_DIR); /* the directory name (ub_ports.h allows it) */
}

static int ubx_spec_param(ub_port_spec_t *s, uint32_t *seen, const char *key, const char *value, char *err,
                           size_t cap) {
    if (strcmp(key, "dir") == 0) {
        size_t n = strlen(value);
        bool ok = n > 0 && n < sizeof s->host;
        for (size_t i = 0; ok && i < n; i++) {
            char c = value[i];
            ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
        }
        if (!ok || (*seen & SEEN_DIR)) {
            snprintf(err, cap, "'dir=%.40s': give one catalogued directory name of type ubxGps_t, e.g. dir=gpsUbx",
                     value);
            return UB_ERR_INVAL;
        }
        memcpy(s->host, value, n + 1);
        *seen |= SEEN_DIR;
        return UB_OK;
    }
    return ub_serial_driver.spec_param(s, seen, key, value, err, cap); /* device, baud */
}

static int ubx_spec_finish(ub_port_spec_t *s, uint32_t seen, char *err, size_t cap) {
    (void)seen;
    if (s->device[0] == '\0') {
        snprintf(err, cap, "ubx needs device=PATH, e.g. ubx:device=/dev/ttyACM0,baud=115200");
        return UB_ERR_INVAL;
    }
    return UB_OK;
}

static int ubx_spec_format(const ub_port_spec_t *spec, char *out, size_t cap) {
    return snprintf(out, cap, "ubx:device=%s,baud=%u,dir=%s", spec->device, (unsigned)spec->baud, spec->host);
}

static int ubx_open(void *state, const ub_port_spec_t *spec) {
    ubx_adapter_t *a = state;
    int rc = ub_serial_open(&a->serial, spec->device, spec->baud);
    if (rc != UB_OK) return rc;
    ub_decoder_init(&a->dec);
    ub_decoder_set_foreign(&a->dec, to_parser, a);
    ub_ubx_init(&a->ubx);
    snprintf(a->dir_name, sizeof a->dir_name, "%s", spec->host);
    return ub_serial_set_decoder(&a->serial, &a->dec);
}

static void ubx_close(void *state) { ub_serial_driver.close(&((ubx_adapter_t *)state)->serial); }

/* The directory must be catalogued with this adapter's layout and bound (hosted) on this node: the
 * adapter writes into that storage and nowhere else. */
static int ubx_attach(void *state, ub_node_t *node, int link_id) {
    ubx_adapter_t *a = state;
    const ub_catalogue_t *cat = ub_node_catalogue(node);
    int inst = cat != NULL ? ub_catalogue_find_name(cat, a->dir_name) : UB_ERR_NOTFOUND;
    if (inst < 0) return UB_ERR_NOTFOUND;
    if (cat->instances[inst].type->c_size != sizeof(ubxGps_t)) return UB_ERR_INVAL;
    void *storage = ub_node_binding(node, (uint32_t)inst);
    if (storage == NULL) return UB_ERR_NOTFOUND;
    a->dir = storage;
    return ub_serial_attach(&a->serial, node, link_id);
}

static int ubx_service(void *state, ub_node_t *node, uint64_t now_ms) {
    ubx_adapter_t *a = state;
    a->now_ms = now_ms;
    return ub_serial_service(&a->serial, node, now_ms);
}

static int ubx_pollfds(const void *state, struct pollfd *fds, int cap) {
    return ub_serial_driver.pollfds(&((const ubx_adapter_t *)state)->serial, fds, cap);
}

static bool ubx_next_due(const void *state, uint64_t *due_ms) {
    return ub_serial_next_retry(&((const ubx_adapter_t *)state)->serial, due_ms);
}

static size_t ubx_counters(const void *state, ub_driver_counter_t *out, size_t cap) {
    const ubx_adapter_t *a = state;
    const ub_ubx_stats_t *n = &a->ubx.stats;
    const ub_decoder_stats_t *d = &a->dec.stats;
    uint64_t rejected = 0;
    for (int r = 0; r < UB_RX_REASON_COUNT; r++) rejected += d->rejected[r];
    const ub_driver_counter_t all[] = {
        {"nav_pvt", n->nav_pvt},             {"bad_checksum", n->bad_checksum},
        {"bad_length", n->bad_length},       {"too_long", n->too_long},
        {"unsupported", n->unsupported},     {"noise_bytes", n->noise_bytes},
        {"frames_in", d->frames_ok},         {"frames_rejected", rejected},
        {"foreign_bytes", d->foreign_bytes}, {"foreign_refused", d->foreign_refused},
        {"bytes_in", a->serial.stats.bytes_in}, {"bytes_out", a->serial.stats.bytes_out},
        {"hangups", a->serial.stats.hangups},
    };
    size_t count = sizeof all / sizeof all[0];
    for (size_t i = 0; i < count && i < cap && out != NULL; i++) out[i] = all[i];
    return count;
}

const ub_driver_t adapter_ubx_driver = {
    .name = "ubx",
    .keys = "device, baud, dir",
    .examples = "ubx:device=/dev/ttyACM0,baud=115200 | ubx:device=/dev/ttyS1,baud=9600,dir=gpsUbx",
    .wire_params = false, /* the link carries full frames between the sentences */
    .state_size = sizeof(ubx_adapter_t),
    .spec_init = ubx_spec_init,
    .spec_param = ubx_spec_param,
    .spec_finish = ubx_spec_finish,
    .spec_format = ubx_spec_format,
    .open = ubx_open,
    .close = ubx_close,
    .attach = ubx_attach,
    .link_ops = &ub_serial_ops,
    .service = ubx_service,
    .pollfds = ubx_pollfds,
    .next_due = ubx_next_due,
    .counters = ubx_counters,
};
