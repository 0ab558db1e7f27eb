/*
 * The NMEA 0183 GPS adapter (issue #24): a COTS receiver on a serial port becomes the catalogued directory
 * `gpsNmea` (examples/flightsw/nmea_gps.h), published by the node like any other, and the same port still
 * carries uavbus frames. Port spec:
 *
 *     nmea:device=/dev/ttyUSB0[,baud=9600][,dir=gpsNmea]
 *
 * It is written the way a user adds an adapter (docs/adapters.md): this one C file against public headers
 * (the driver interface ub_driver.h, the serial link, the decoder's foreign-traffic handler, the NMEA
 * parser) plus one catalogue header, and one ub_ports_register() line in the program. Nothing in the node,
 * the ports or the program shell knows about NMEA.
 *
 * How: the instance is a serial link (first member, so the link's impl is the serial link itself and
 * every serial operation applies unchanged) read through a decoder of its own whose foreign-traffic
 * handler is the NMEA parser. uavbus frames go to the node as on any serial link; every other byte goes
 * to the parser, once, in order; each good GGA/RMC/VTG/GSA is written into the directory's bound storage,
 * from where the node's publications pack it. Bad sentences are counted in the directory and in the
 * port's counters, never written.
 */
#include <poll.h>
#include <stdio.h>
#include <string.h>

#include "nmea_gps.h"
#include "ub/ub_catalogue.h"
#include "ub/ub_driver.h"
#include "ub/ub_frame.h"
#include "ub/ub_nmea.h"
#include "ub/ub_node.h"
#include "ub/ub_node_svc.h"
#include "ub/ub_ports.h"
#include "ub/ub_serial.h"

#define NMEA_DEFAULT_DIR "gpsNmea"
#define NMEA_DEFAULT_BAUD 9600u

typedef struct nmea_adapter {
    ub_serial_t serial; /* first: the link's impl (ub_serial_ops) is this serial link */
    ub_decoder_t dec;   /* the link's decoder; its foreign-traffic handler is the parser */
    ub_nmea_t nmea;
    nmeaGps_t *dir;     /* the directory's bound storage; NULL until attached */
    uint64_t now_ms;    /* the service call's time, for the directory's timeTag */
    char dir_name[UB_PORT_HOST_LEN];
} nmea_adapter_t;

/* ---- from sentences to the directory ---- */

static void write_counters(nmea_adapter_t *a) {
    const ub_nmea_stats_t *s = &a->nmea.stats;
    a->dir->sentencesOk = (uint32_t)s->sentences_ok;
    a->dir->badChecksums = (uint32_t)s->bad_checksum;
    a->dir->badSentences = (uint32_t)(s->no_checksum + s->malformed + s->overlong);
}

static void on_sentence(void *user, ub_nmea_kind_t kind, const ub_nmea_t *nmea) {
    (void)kind;
    nmea_adapter_t *a = user;
    const ub_nmea_fix_t *f = &nmea->fix;
    nmeaGps_t *d = a->dir;
    d->time.seconds = (uint32_t)(a->now_ms / 1000u);
    d->time.microseconds = (uint32_t)(a->now_ms % 1000u * 1000u);
    d->latitudeDeg = f->lat_deg;
    d->longitudeDeg = f->lon_deg;
    d->altitudeMsl = f->alt_msl_m;
    d->geoidSeparation = f->geoid_sep_m;
    d->speedMps = f->speed_mps;
    d->courseDeg = f->course_deg;
    d->hdop = (float)f->hdop;
    d->pdop = (float)f->pdop;
    d->vdop = (float)f->vdop;
    d->utcMilliseconds = f->utc_ms;
    d->utcDate = f->date_ddmmyy;
    d->fixQuality = f->quality;
    d->fixType = f->fix_type;
    d->satellitesUsed = f->satellites;
    d->statusValid = f->valid;
}

/* The link's foreign-traffic handler: every byte that is not a uavbus frame. The parser takes all of them
 * (what is not a sentence it counts as noise), so nothing is refused. */
static size_t to_parser(void *user, const uint8_t *run, size_t len) {
    nmea_adapter_t *a = user;
    if (a->dir == NULL) return 0; /* not attached: refused, and counted so */
    int merged = ub_nmea_feed(&a->nmea, run, len, on_sentence, a);
    (void)merged; /* the parser's own counters say it */
    write_counters(a);
    return len;
}

/* ---- the driver table ---- */

enum { SEEN_DIR = 1u << 8 }; /* above the serial driver's own bits, which its spec_param sets */

static void nmea_spec_init(ub_port_spec_t *spec) {
    spec->kind = UB_PORT_DRIVER;
    spec->baud = NMEA_DEFAULT_BAUD;
    memcpy(spec->host, NMEA_DEFAULT_DIR, sizeof NMEA_DEFAULT_DIR); /* the directory name (ub_ports.h allows it) */
}

static int nmea_spec_param(ub_port_spec_t *s, uint32_t *seen, const char *key, const char *value, char *err,
                           size_t cap) {
    if (strcmp(key, "dir") == 0) {
        size_t n = strlen(value);
        bool ok = n > 0 && n < sizeof s->host;
        for (size_t i = 0; ok && i < n; i++) {
            char c = value[i];
            ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
        }
        if (!ok || (*seen & SEEN_DIR)) {
            snprintf(err, cap, "'dir=%.40s': give one catalogued directory name of type nmeaGps_t, e.g. dir=gpsNmea",
                     value);
            return UB_ERR_INVAL;
        }
        memcpy(s->host, value, n + 1);
        *seen |= SEEN_DIR;
        return UB_OK;
    }
    return ub_serial_driver.spec_param(s, seen, key, value, err, cap); /* device, baud */
}

static int nmea_spec_finish(ub_port_spec_t *s, uint32_t seen, char *err, size_t cap) {
    (void)seen;
    if (s->device[0] == '\0') {
        snprintf(err, cap, "nmea needs device=PATH, e.g. nmea:device=/dev/ttyUSB0,baud=9600");
        return UB_ERR_INVAL;
    }
    return UB_OK;
}

static int nmea_spec_format(const ub_port_spec_t *spec, char *out, size_t cap) {
    return snprintf(out, cap, "nmea:device=%s,baud=%u,dir=%s", spec->device, (unsigned)spec->baud, spec->host);
}

static int nmea_open(void *state, const ub_port_spec_t *spec) {
    nmea_adapter_t *a = state;
    int rc = ub_serial_open(&a->serial, spec->device, spec->baud);
    if (rc != UB_OK) return rc;
    ub_decoder_init(&a->dec);
    ub_decoder_set_foreign(&a->dec, to_parser, a);
    ub_nmea_init(&a->nmea);
    snprintf(a->dir_name, sizeof a->dir_name, "%s", spec->host);
    return ub_serial_set_decoder(&a->serial, &a->dec);
}

static void nmea_close(void *state) { ub_serial_driver.close(&((nmea_adapter_t *)state)->serial); }

/* The directory must be catalogued with this adapter's layout and bound (hosted) on this node: the
 * adapter writes into that storage and nowhere else. */
static int nmea_attach(void *state, ub_node_t *node, int link_id) {
    nmea_adapter_t *a = state;
    const ub_catalogue_t *cat = ub_node_catalogue(node);
    int inst = cat != NULL ? ub_catalogue_find_name(cat, a->dir_name) : UB_ERR_NOTFOUND;
    if (inst < 0) return UB_ERR_NOTFOUND;
    if (cat->instances[inst].type->c_size != sizeof(nmeaGps_t)) return UB_ERR_INVAL;
    void *storage = ub_node_binding(node, (uint32_t)inst);
    if (storage == NULL) return UB_ERR_NOTFOUND;
    a->dir = storage;
    return ub_serial_attach(&a->serial, node, link_id);
}

static int nmea_service(void *state, ub_node_t *node, uint64_t now_ms) {
    nmea_adapter_t *a = state;
    a->now_ms = now_ms;
    return ub_serial_service(&a->serial, node, now_ms);
}

static int nmea_pollfds(const void *state, struct pollfd *fds, int cap) {
    return ub_serial_driver.pollfds(&((const nmea_adapter_t *)state)->serial, fds, cap);
}

static bool nmea_next_due(const void *state, uint64_t *due_ms) {
    return ub_serial_next_retry(&((const nmea_adapter_t *)state)->serial, due_ms);
}

static size_t nmea_counters(const void *state, ub_driver_counter_t *out, size_t cap) {
    const nmea_adapter_t *a = state;
    const ub_nmea_stats_t *n = &a->nmea.stats;
    const ub_decoder_stats_t *d = &a->dec.stats;
    uint64_t rejected = 0;
    for (int r = 0; r < UB_RX_REASON_COUNT; r++) rejected += d->rejected[r];
    const ub_driver_counter_t all[] = {
        {"sentences_ok", n->sentences_ok},   {"bad_checksum", n->bad_checksum},
        {"no_checksum", n->no_checksum},     {"malformed", n->malformed},
        {"overlong", n->overlong},           {"unsupported", n->unsupported},
        {"gga", n->by_kind[UB_NMEA_GGA]},    {"rmc", n->by_kind[UB_NMEA_RMC]},
        {"vtg", n->by_kind[UB_NMEA_VTG]},    {"gsa", n->by_kind[UB_NMEA_GSA]},
        {"noise_bytes", n->noise_bytes},     {"frames_in", d->frames_ok},
        {"frames_rejected", rejected},       {"foreign_bytes", d->foreign_bytes},
        {"foreign_refused", d->foreign_refused}, {"bytes_in", a->serial.stats.bytes_in},
        {"bytes_out", a->serial.stats.bytes_out}, {"hangups", a->serial.stats.hangups},
    };
    size_t count = sizeof all / sizeof all[0];
    for (size_t i = 0; i < count && i < cap && out != NULL; i++) out[i] = all[i];
    return count;
}

const ub_driver_t adapter_nmea_driver = {
    .name = "nmea",
    .keys = "device, baud, dir",
    .examples = "nmea:device=/dev/ttyUSB0,baud=9600 | nmea:device=/dev/ttyS1,baud=4800,dir=gpsNmea",
    .wire_params = false, /* the link carries full frames between the sentences */
    .state_size = sizeof(nmea_adapter_t),
    .spec_init = nmea_spec_init,
    .spec_param = nmea_spec_param,
    .spec_finish = nmea_spec_finish,
    .spec_format = nmea_spec_format,
    .open = nmea_open,
    .close = nmea_close,
    .attach = nmea_attach,
    .link_ops = &ub_serial_ops,
    .service = nmea_service,
    .pollfds = nmea_pollfds,
    .next_due = nmea_next_due,
    .counters = nmea_counters,
};
