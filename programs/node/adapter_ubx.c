/*
 * The u-blox UBX GPS adapter (issue #24): a receiver speaking UBX on a serial port becomes the catalogued
 * directory `gpsUbx` (examples/flightsw/ubx_gps.h), published by the node like any other, and the same port
 * still carries uavbus frames. Port spec:
 *
 *     ubx:device=/dev/ttyACM0[,baud=115200][,dir=gpsUbx]
 *
 * The second adapter written the way docs/adapters.md describes (adapter_nmea.c is the first), on the
 * serial adapter helper (adapter_serial.h): the link's foreign bytes go to the UBX parser (ub_ubx.h); each
 * good NAV-PVT is written into the directory's bound storage.
 *
 * Writing (R1's "reading and writing"): the directory `<dir>Cfg` (gpsUbxCfg, type ubxCfg_t) is the
 * receiver's navigation rate. When its value differs from what the receiver last acknowledged, the next
 * service call writes a UBX-CFG-RATE onto the link (between uavbus frames, never inside one) and waits for
 * the receiver's ACK-ACK or ACK-NAK naming CFG-RATE; no answer within UB_UBX_ACK_TIMEOUT_MS is counted
 * and the message sent again (the exchange is ub_ubx.h's ub_ubx_cfg_t, which Python's adapter uses too).
 * Every outcome is counted in the directory (cfgSent, cfgAcked, cfgNaked,
 * cfgTimeouts, cfgMeasRateMs), so the node that wrote the configuration reads the answer two hops away.
 */
#include <string.h>

#include "adapter_serial.h"
#include "ub/ub_gps_fields.h"
#include "ub/ub_ubx.h"
#include "ubx_gps.h"

typedef struct ubx_adapter {
    adapter_serial_t base; /* first (adapter_serial.h) */
    ub_ubx_t ubx;
    ubxCfg_t *cfg;         /* the configuration directory's storage; NULL: none, nothing is written */
    ub_ubx_cfg_t rate;     /* the CFG-RATE exchange (ub_ubx.h, shared with Python's adapter) */
    uint8_t cfg_looked;    /* the configuration directory was looked up (once attached) */
} ubx_adapter_t;

static void ubx_reset(adapter_serial_t *a) {
    ub_ubx_init(&((ubx_adapter_t *)a)->ubx);
    ub_ubx_cfg_init(&((ubx_adapter_t *)a)->rate);
}

/* The members and their sources are ub_gps_fields.h's lists, shared with Python's adapter. */
#define PUT(member, ctype, expr) d->member = (ctype)(expr);

static void on_pvt(ubx_adapter_t *a, const ub_ubx_t *u) {
    ubxGps_t *d = a->base.dir;
    d->time.seconds = (uint32_t)(a->base.now_ms / 1000u);
    d->time.microseconds = (uint32_t)(a->base.now_ms % 1000u * 1000u);
    UB_UBX_DIR_FIX(PUT)
}

/* An ACK-ACK or ACK-NAK: it settles the pending CFG-RATE when it names CFG-RATE (an answer to something
 * else, or with nothing pending, changes nothing: the parser counted it). */
static void on_ack(ubx_adapter_t *a, const ub_ubx_ack_t *ack) {
    if (!ub_ubx_cfg_answer(&a->rate, ack)) return;
    ubxGps_t *d = a->base.dir;
    const ub_ubx_cfg_t *c = &a->rate;
    UB_UBX_DIR_CFG(PUT)
}

static void on_message(void *user, const ub_ubx_t *ubx) {
    if (ubx->cls == UB_UBX_CLASS_ACK) on_ack(user, &ubx->ack);
    else on_pvt(user, ubx);
}

/* Every byte that is not a uavbus frame; the parser takes all (what is not a message is noise). */
static size_t ubx_feed(adapter_serial_t *base, const uint8_t *run, size_t len) {
    ubx_adapter_t *a = (ubx_adapter_t *)base;
    int decoded = ub_ubx_feed(&a->ubx, run, len, on_message, a);
    (void)decoded; /* the parser's own counters say it */
    const ub_ubx_t *u = &a->ubx;
    ubxGps_t *d = base->dir;
    UB_UBX_DIR_COUNTS(PUT)
    return len;
}

/* Before the link is read: a configuration to write, or an answer overdue. */
static void ubx_service(adapter_serial_t *base, uint64_t now_ms) {
    ubx_adapter_t *a = (ubx_adapter_t *)base;
    if (!a->cfg_looked) {
        char name[UB_PORT_HOST_LEN + 4];
        size_t n = strlen(base->dir_name);
        if (n + 4 < sizeof name) {
            memcpy(name, base->dir_name, n);
            memcpy(name + n, "Cfg", 4);
            a->cfg = adapter_serial_directory(base, name, sizeof(ubxCfg_t));
        }
        a->cfg_looked = 1;
    }
    if (a->cfg == NULL) return;
    ubxGps_t *d = base->dir;
    const ub_ubx_cfg_t *c = &a->rate;
    const ub_ubx_rate_t want = {a->cfg->measRateMs, a->cfg->navRate, a->cfg->timeRef};
    uint8_t msg[8 + UB_UBX_CFG_RATE_LEN];
    int n = ub_ubx_cfg_poll(&a->rate, &want, now_ms, msg, sizeof msg);
    /* full or down: counted by the link; the next call tries again */
    if (n > 0 && adapter_serial_write(base, msg, (size_t)n) == UB_OK) ub_ubx_cfg_sent(&a->rate, &want, now_ms);
    UB_UBX_DIR_CFG(PUT) /* a time-out counts even when the resend could not be written */
}

static size_t ubx_counters(const adapter_serial_t *base, ub_driver_counter_t *out, size_t cap) {
    const ub_ubx_stats_t *n = &((const ubx_adapter_t *)base)->ubx.stats;
    const ub_driver_counter_t all[] = {
        {"nav_pvt", n->nav_pvt},         {"bad_checksum", n->bad_checksum}, {"bad_length", n->bad_length},
        {"too_long", n->too_long},       {"unsupported", n->unsupported},   {"ack", n->ack},
        {"nak", n->nak},                 {"noise_bytes", n->noise_bytes},
    };
    return adapter_serial_put_counters(all, sizeof all / sizeof all[0], out, cap);
}

const adapter_serial_kind_t adapter_ubx = {
    .driver = ADAPTER_SERIAL_DRIVER("ubx", "ubx:device=/dev/ttyACM0,baud=115200 | ubx:device=/dev/ttyS1,baud=9600,dir=gpsUbx",
                                    ubx_adapter_t),
    .dir_type = "ubxGps_t",
    .default_dir = "gpsUbx",
    .default_baud = 115200,
    .dir_size = sizeof(ubxGps_t),
    .reset = ubx_reset,
    .feed = ubx_feed,
    .service = ubx_service,
    .counters = ubx_counters,
};
