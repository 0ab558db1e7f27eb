/**
 * @file ub_nmea.h
 * @brief NMEA 0183 sentences from a byte stream (a COTS GPS receiver sharing a link with uavbus, #24).
 *
 * A pure state machine like the frame decoder: no I/O, no allocation, no globals. Feed it the foreign
 * runs a link's decoder hands on (ub_decoder_set_foreign(), ub_frame.h), in any cuts; it assembles
 * `$...*HH` sentences, verifies the checksum, and merges GGA, RMC, VTG and GSA into one fix, calling back
 * once per good sentence of those four. Everything else is counted, never delivered: a bad checksum, a
 * sentence without one, a field that does not parse, an overlong line, another sentence type, and the
 * bytes outside sentences.
 *
 *     ub_nmea_t nmea;                       // caller-owned, ~200 B
 *     ub_nmea_init(&nmea);
 *     ... ub_nmea_feed(&nmea, run, len, on_sentence, ctx);   // on_sentence reads nmea.fix
 *
 * Sentence layout (NMEA 0183 v4.11): '$' talker(2) type(3) {',' field} '*' HH CR LF, at most 82
 * characters; HH is the XOR of the bytes between '$' and '*', in hex. Any talker (GP, GN, GL, GA...) is
 * taken. Empty fields leave the fix's value as it was (a receiver without a fix sends them empty).
 */
#ifndef UB_NMEA_H
#define UB_NMEA_H

#include <stddef.h>
#include <stdint.h>

#include "ub_error.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Longest sentence kept, '$' to the checksum's last digit (the standard's 82 include CR LF). */
#define UB_NMEA_LINE_MAX 96

/** The sentences merged into the fix. */
typedef enum ub_nmea_kind {
    UB_NMEA_GGA = 0, /**< time, position, fix quality, satellites, HDOP, altitude, geoid separation */
    UB_NMEA_RMC,     /**< time, status, position, speed, course, date */
    UB_NMEA_VTG,     /**< course and speed over ground */
    UB_NMEA_GSA,     /**< fix type (1 none, 2 2D, 3 3D), PDOP, HDOP, VDOP */
    UB_NMEA_KIND_COUNT
} ub_nmea_kind_t;

/** The receiver's state as the sentences so far tell it. */
typedef struct ub_nmea_fix {
    double lat_deg;        /**< + north */
    double lon_deg;        /**< + east */
    double alt_msl_m;      /**< GGA antenna altitude above mean sea level */
    double geoid_sep_m;    /**< GGA geoid separation */
    double speed_mps;      /**< RMC or VTG speed over ground (knots * 1852 / 3600) */
    double course_deg;     /**< RMC or VTG true course */
    double hdop, pdop, vdop;
    uint32_t utc_ms;       /**< time of day, ms since 00:00 UTC */
    uint32_t date_ddmmyy;  /**< RMC date as sent (230394 = 23 March 1994); 0 until seen */
    uint8_t quality;       /**< GGA fix quality (0 invalid, 1 GPS, 2 DGPS, 4 RTK...) */
    uint8_t satellites;    /**< GGA satellites in use */
    uint8_t fix_type;      /**< GSA 1 none, 2 2D, 3 3D; 0 until seen */
    uint8_t valid;         /**< RMC status 'A' (1) or 'V' (0) */
} ub_nmea_fix_t;

/** Counters: every byte fed is in exactly one of bytes_in_sentences and noise_bytes, or still held. */
typedef struct ub_nmea_stats {
    uint64_t bytes_in;
    uint64_t noise_bytes;          /**< bytes outside any '$' sentence (line ends included) */
    uint64_t bytes_in_sentences;   /**< bytes of finished or dropped sentences */
    uint64_t sentences_ok;         /**< good GGA/RMC/VTG/GSA merged into the fix (and called back) */
    uint64_t by_kind[UB_NMEA_KIND_COUNT];
    uint64_t bad_checksum;         /**< checksum present and wrong: corrupted in transit */
    uint64_t no_checksum;          /**< no '*HH' (cut short by the next '$', or sent without one) */
    uint64_t malformed;            /**< checksum right but a field does not parse: not merged */
    uint64_t overlong;             /**< more than UB_NMEA_LINE_MAX characters before the line end */
    uint64_t unsupported;          /**< good sentences of other types (GSV, GLL, ZDA...): counted, ignored */
} ub_nmea_stats_t;

/** Parser state; caller-owned. Treat the fields as private; read `fix` and `stats`. */
typedef struct ub_nmea {
    char line[UB_NMEA_LINE_MAX];
    size_t len;       /* characters of the sentence being assembled, '$' included */
    uint8_t state;    /* 0 outside a sentence, 1 inside, 2 skipping an overlong one */
    ub_nmea_fix_t fix;
    ub_nmea_stats_t stats;
} ub_nmea_t;

/** Called once per good GGA/RMC/VTG/GSA, after it was merged into `nmea->fix`. */
typedef void (*ub_nmea_cb)(void *user, ub_nmea_kind_t kind, const ub_nmea_t *nmea);

/** Empties the parser, zeroes its fix and counters. */
void ub_nmea_init(ub_nmea_t *nmea);

/**
 * Feeds bytes in any cuts. `cb` may be NULL (count and merge only).
 * @return good sentences merged by this call, or UB_ERR_INVAL (NULL `nmea`, or NULL `data` with `len` > 0).
 */
UB_CHECK int ub_nmea_feed(ub_nmea_t *nmea, const uint8_t *data, size_t len, ub_nmea_cb cb, void *user);

/** @return the name of a kind ("GGA"), or "?" when out of range. */
const char *ub_nmea_kind_name(ub_nmea_kind_t kind);

#ifdef __cplusplus
}
#endif
#endif /* UB_NMEA_H */
