/*
 * The NMEA 0183 GPS adapter (issue #24): a COTS receiver on a serial port becomes the catalogued directory
 * `gpsNmea` (examples/flightsw/nmea_gps.h), published by the node like any other, and the same port still
 * carries uavbus frames. Port spec:
 *
 *     nmea:device=/dev/ttyUSB0[,baud=9600][,dir=gpsNmea]
 *
 * It is written the way a user adds an adapter (docs/adapters.md): this one C file against the serial
 * adapter helper (adapter_serial.h: the port spec, the serial link read through a decoder whose
 * foreign-traffic handler is this file's feed, the directory found in the catalogue) and the NMEA parser,
 * plus one catalogue header, and one ub_ports_register() line in the program. Nothing in the node, the
 * ports or the program shell knows about NMEA.
 *
 * How: uavbus frames go to the node as on any serial link; every other byte goes
 * to the parser, once, in order; each good GGA/RMC/VTG/GSA is written into the directory's bound storage,
 * from where the node's publications pack it. Bad sentences are counted in the directory and in the
 * port's counters, never written.
 */
#include "adapter_serial.h"
#include "nmea_gps.h"
#include "ub/ub_gps_fields.h"
#include "ub/ub_nmea.h"

typedef struct nmea_adapter {
    adapter_serial_t base; /* first (adapter_serial.h) */
    ub_nmea_t nmea;
} nmea_adapter_t;

static void nmea_reset(adapter_serial_t *a) { ub_nmea_init(&((nmea_adapter_t *)a)->nmea); }

/* The members and their sources are ub_gps_fields.h's lists, shared with Python's adapter. */
#define PUT(member, ctype, expr) d->member = (ctype)(expr);

static void on_sentence(void *user, ub_nmea_kind_t kind, const ub_nmea_t *n) {
    (void)kind;
    nmea_adapter_t *a = user;
    nmeaGps_t *d = a->base.dir;
    d->time.seconds = (uint32_t)(a->base.now_ms / 1000u);
    d->time.microseconds = (uint32_t)(a->base.now_ms % 1000u * 1000u);
    UB_NMEA_DIR_FIX(PUT)
}

/* Every byte that is not a uavbus frame. The parser takes all of them (what is not a sentence it counts as
 * noise), so nothing is refused. */
static size_t nmea_feed(adapter_serial_t *base, const uint8_t *run, size_t len) {
    nmea_adapter_t *a = (nmea_adapter_t *)base;
    int merged = ub_nmea_feed(&a->nmea, run, len, on_sentence, a);
    (void)merged; /* the parser's own counters say it */
    const ub_nmea_t *n = &a->nmea;
    nmeaGps_t *d = base->dir;
    UB_NMEA_DIR_COUNTS(PUT)
    return len;
}

static size_t nmea_counters(const adapter_serial_t *base, ub_driver_counter_t *out, size_t cap) {
    const ub_nmea_stats_t *n = &((const nmea_adapter_t *)base)->nmea.stats;
    const ub_driver_counter_t all[] = {
        {"sentences_ok", n->sentences_ok}, {"bad_checksum", n->bad_checksum}, {"no_checksum", n->no_checksum},
        {"malformed", n->malformed},       {"overlong", n->overlong},         {"unsupported", n->unsupported},
        {"gga", n->by_kind[UB_NMEA_GGA]},  {"rmc", n->by_kind[UB_NMEA_RMC]},  {"vtg", n->by_kind[UB_NMEA_VTG]},
        {"gsa", n->by_kind[UB_NMEA_GSA]},  {"noise_bytes", n->noise_bytes},
    };
    return adapter_serial_put_counters(all, sizeof all / sizeof all[0], out, cap);
}

const adapter_serial_kind_t adapter_nmea = {
    .driver = ADAPTER_SERIAL_DRIVER("nmea", "nmea:device=/dev/ttyUSB0,baud=9600 | nmea:device=/dev/ttyS1,baud=4800,dir=gpsNmea",
                                    nmea_adapter_t),
    .dir_type = "nmeaGps_t",
    .default_dir = "gpsNmea",
    .default_baud = 9600,
    .dir_size = sizeof(nmeaGps_t),
    .reset = nmea_reset,
    .feed = nmea_feed,
    .counters = nmea_counters,
};
