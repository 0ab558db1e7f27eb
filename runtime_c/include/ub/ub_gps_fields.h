/**
 * @file ub_gps_fields.h
 * @brief What the GPS adapters write into their catalogued directories, in one place (issue #24).
 *
 * The NMEA and UBX parsers (ub_nmea.h, ub_ubx.h) decode into the receiver's own terms; the adapters turn
 * that into the members of the catalogue's `nmeaGps_t` / `ubxGps_t` (examples/flightsw/nmea_gps.h,
 * ubx_gps.h). Two front ends do it, one mapping: the C adapters of uavbus_node (programs/node/adapter_*.c)
 * expand the X-macro lists below into typed assignments (`d->latitudeDeg = (double)(expr);`), and Python
 * (uavbus.adapters, through cffi) reads the same lists as (member name, value) pairs from
 * ub_nmea_dir_values() / ub_ubx_dir_values() and writes them by name. A member added here reaches both.
 *
 * Each entry is X(member, C type of the member, expression over `n` (const ub_nmea_t *) or `u` (const
 * ub_ubx_t *), or `c` (const ub_ubx_cfg_t *)). The `_FIX` lists are written when a good sentence/message was merged, the `_COUNTS` lists
 * after every run fed (they change on bad input too). The time tag is the adapter's own (node time).
 */
#ifndef UB_GPS_FIELDS_H
#define UB_GPS_FIELDS_H

#include <stddef.h>
#include <stdint.h>

#include "ub_nmea.h"
#include "ub_ubx.h"

#ifdef __cplusplus
extern "C" {
#endif

#define UB_NMEA_DIR_FIX(X)                                  \
    X(latitudeDeg, double, n->fix.lat_deg)                  \
    X(longitudeDeg, double, n->fix.lon_deg)                 \
    X(altitudeMsl, double, n->fix.alt_msl_m)                \
    X(geoidSeparation, double, n->fix.geoid_sep_m)          \
    X(speedMps, double, n->fix.speed_mps)                   \
    X(courseDeg, double, n->fix.course_deg)                 \
    X(hdop, float, n->fix.hdop)                             \
    X(pdop, float, n->fix.pdop)                             \
    X(vdop, float, n->fix.vdop)                             \
    X(utcMilliseconds, uint32_t, n->fix.utc_ms)             \
    X(utcDate, uint32_t, n->fix.date_ddmmyy)                \
    X(fixQuality, uint8_t, n->fix.quality)                  \
    X(fixType, uint8_t, n->fix.fix_type)                    \
    X(satellitesUsed, uint8_t, n->fix.satellites)           \
    X(statusValid, uint8_t, n->fix.valid)

#define UB_NMEA_DIR_COUNTS(X)                               \
    X(sentencesOk, uint32_t, n->stats.sentences_ok)         \
    X(badChecksums, uint32_t, n->stats.bad_checksum)        \
    X(badSentences, uint32_t, n->stats.no_checksum + n->stats.malformed + n->stats.overlong)

#define UB_UBX_DIR_FIX(X)                                   \
    X(latitudeDeg, double, u->pvt.lat_1e7 / 1e7)            \
    X(longitudeDeg, double, u->pvt.lon_1e7 / 1e7)           \
    X(altitudeMsl, double, u->pvt.hmsl_mm / 1000.0)         \
    X(heightEllipsoid, double, u->pvt.height_mm / 1000.0)   \
    X(groundSpeedMps, double, u->pvt.g_speed_mms / 1000.0)  \
    X(headingDeg, double, u->pvt.head_mot_1e5 / 1e5)        \
    X(velNorth, float, u->pvt.vel_n_mms / 1000.0)           \
    X(velEast, float, u->pvt.vel_e_mms / 1000.0)            \
    X(velDown, float, u->pvt.vel_d_mms / 1000.0)            \
    X(hAccuracy, float, u->pvt.h_acc_mm / 1000.0)           \
    X(vAccuracy, float, u->pvt.v_acc_mm / 1000.0)           \
    X(pdop, float, u->pvt.p_dop_1e2 / 100.0)                \
    X(iTowMs, uint32_t, u->pvt.itow_ms)                     \
    X(year, uint16_t, u->pvt.year)                          \
    X(month, uint8_t, u->pvt.month)                         \
    X(day, uint8_t, u->pvt.day)                             \
    X(hour, uint8_t, u->pvt.hour)                           \
    X(minute, uint8_t, u->pvt.min)                          \
    X(second, uint8_t, u->pvt.sec)                          \
    X(fixType, uint8_t, u->pvt.fix_type)                    \
    X(satellitesUsed, uint8_t, u->pvt.num_sv)

#define UB_UBX_DIR_COUNTS(X)                                \
    X(navPvtOk, uint32_t, u->stats.nav_pvt)                 \
    X(badChecksums, uint32_t, u->stats.bad_checksum)        \
    X(badMessages, uint32_t, u->stats.bad_length + u->stats.too_long)

/* The receiver's answers to the rate written (ub_ubx_cfg_t, `c`), counted in the same directory. */
#define UB_UBX_DIR_CFG(X)                                   \
    X(cfgSent, uint32_t, c->sent_count)                     \
    X(cfgAcked, uint32_t, c->acked)                         \
    X(cfgNaked, uint32_t, c->naked)                         \
    X(cfgTimeouts, uint32_t, c->timeouts)                   \
    X(cfgMeasRateMs, uint16_t, c->acked_meas_rate_ms)

/** One directory member's value, as the member's C type holds it (converted, then widened to double:
 *  exact for every type above). */
typedef struct ub_dir_value {
    const char *member; /**< static storage: the catalogue member's name */
    double value;
    uint8_t counter;    /**< 1: a `_COUNTS` entry (written after every run), 0: a `_FIX` entry */
} ub_dir_value_t;

/** Room for any of the lists below. */
#define UB_DIR_VALUES_MAX 32

/** The gpsNmea members from the parser's state, `_FIX` then `_COUNTS`. @return how many (all when `cap`
 *  is large enough; at most `cap` are written), or 0 for NULL. */
size_t ub_nmea_dir_values(const ub_nmea_t *n, ub_dir_value_t *out, size_t cap);

/** The gpsUbx members from the parser's last NAV-PVT and its counters, as ub_nmea_dir_values(). */
size_t ub_ubx_dir_values(const ub_ubx_t *u, ub_dir_value_t *out, size_t cap);

/** The gpsUbx members of the CFG-RATE exchange (UB_UBX_DIR_CFG, all flagged counters). */
size_t ub_ubx_cfg_dir_values(const ub_ubx_cfg_t *c, ub_dir_value_t *out, size_t cap);

#ifdef __cplusplus
}
#endif
#endif /* UB_GPS_FIELDS_H */
