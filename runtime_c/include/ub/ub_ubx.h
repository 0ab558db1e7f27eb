/**
 * @file ub_ubx.h
 * @brief u-blox UBX messages from a byte stream (a COTS receiver sharing a link with uavbus, #24).
 *
 * A pure state machine like ub_nmea.h: no I/O, no allocation, no globals; feed it a link's foreign runs in
 * any cuts. It finds `B5 62 class id len(u16 LE) payload CK_A CK_B`, verifies the 8-bit Fletcher checksum
 * over class..payload, and decodes NAV-PVT (class 0x01, id 0x07, 92 bytes) into a solution, calling back
 * once per good NAV-PVT. Other messages with a good checksum are counted `unsupported`; a bad checksum, a
 * NAV-PVT of the wrong length or a message longer than UB_UBX_PAYLOAD_MAX is counted, never decoded.
 *
 *     ub_ubx_t ubx;   ub_ubx_init(&ubx);   ub_ubx_feed(&ubx, run, len, on_pvt, ctx);
 */
#ifndef UB_UBX_H
#define UB_UBX_H

#include <stddef.h>
#include <stdint.h>

#include "ub_error.h"

#ifdef __cplusplus
extern "C" {
#endif

#define UB_UBX_SYNC1 0xB5u
#define UB_UBX_SYNC2 0x62u
#define UB_UBX_CLASS_NAV 0x01u
#define UB_UBX_ID_NAV_PVT 0x07u
#define UB_UBX_NAV_PVT_LEN 92u
/** Longest payload kept; longer messages are skipped (counted `too_long`). */
#define UB_UBX_PAYLOAD_MAX 128u

/** NAV-PVT, in the receiver's units (docs: u-blox M8/M9 interface description, UBX-NAV-PVT). */
typedef struct ub_ubx_pvt {
    uint32_t itow_ms;       /**< GPS time of week of the epoch */
    uint16_t year;
    uint8_t month, day, hour, min, sec, valid;
    uint8_t fix_type;       /**< 0 none, 1 DR, 2 2D, 3 3D, 4 GNSS+DR, 5 time only */
    uint8_t flags;
    uint8_t num_sv;
    int32_t lon_1e7, lat_1e7; /**< degrees * 1e7 */
    int32_t height_mm;      /**< above the ellipsoid */
    int32_t hmsl_mm;        /**< above mean sea level */
    uint32_t h_acc_mm, v_acc_mm;
    int32_t vel_n_mms, vel_e_mms, vel_d_mms;
    int32_t g_speed_mms;
    int32_t head_mot_1e5;   /**< heading of motion, degrees * 1e5 */
    uint16_t p_dop_1e2;     /**< position DOP * 100 */
} ub_ubx_pvt_t;

/** Counters: every byte fed is in exactly one of bytes_in_messages and noise_bytes, or still held. */
typedef struct ub_ubx_stats {
    uint64_t bytes_in;
    uint64_t noise_bytes;        /**< bytes outside any message */
    uint64_t bytes_in_messages;  /**< bytes of finished or dropped messages, sync included */
    uint64_t nav_pvt;            /**< good NAV-PVT decoded (and called back) */
    uint64_t bad_checksum;       /**< checksum wrong: corrupted in transit */
    uint64_t bad_length;         /**< NAV-PVT whose length is not 92 */
    uint64_t too_long;           /**< payload above UB_UBX_PAYLOAD_MAX: skipped */
    uint64_t unsupported;        /**< good messages of other classes/ids */
} ub_ubx_stats_t;

/** Parser state; caller-owned. Read `pvt` and `stats`; the rest is private. */
typedef struct ub_ubx {
    uint8_t state;
    uint8_t cls, id;
    uint8_t ck_a, ck_b;
    uint8_t ck_bad;
    uint16_t len, have;
    uint8_t payload[UB_UBX_PAYLOAD_MAX];
    ub_ubx_pvt_t pvt;
    ub_ubx_stats_t stats;
} ub_ubx_t;

/** Called once per good NAV-PVT, after it was decoded into `ubx->pvt`. */
typedef void (*ub_ubx_cb)(void *user, const ub_ubx_t *ubx);

/** Empties the parser, zeroes its solution and counters. */
void ub_ubx_init(ub_ubx_t *ubx);

/**
 * Feeds bytes in any cuts. `cb` may be NULL.
 * @return good NAV-PVT decoded by this call, or UB_ERR_INVAL (NULL `ubx`, or NULL `data` with `len` > 0).
 */
UB_CHECK int ub_ubx_feed(ub_ubx_t *ubx, const uint8_t *data, size_t len, ub_ubx_cb cb, void *user);

#ifdef __cplusplus
}
#endif
#endif /* UB_UBX_H */
