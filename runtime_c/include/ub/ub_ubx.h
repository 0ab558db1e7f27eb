/**
 * @file ub_ubx.h
 * @brief u-blox UBX messages from a byte stream (a COTS receiver sharing a link with uavbus, #24).
 *
 * A pure state machine like ub_nmea.h: no I/O, no allocation, no globals; feed it a link's foreign runs in
 * any cuts. It finds `B5 62 class id len(u16 LE) payload CK_A CK_B`, verifies the 8-bit Fletcher checksum
 * over class..payload, and decodes NAV-PVT (class 0x01, id 0x07, 92 bytes) into a solution and ACK-ACK /
 * ACK-NAK (class 0x05, 2 bytes: the acknowledged message's class and id) into `ack`, calling back once per
 * good message of either kind (`ubx->cls` says which). Other messages with a good checksum are counted
 * `unsupported`; a bad checksum, a NAV-PVT or ACK of the wrong length or a message longer than
 * UB_UBX_PAYLOAD_MAX is counted, never decoded. ub_ubx_build() writes a message (a CFG to the receiver).
 *
 *     ub_ubx_t ubx;   ub_ubx_init(&ubx);   ub_ubx_feed(&ubx, run, len, on_message, ctx);
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
#define UB_UBX_CLASS_ACK 0x05u
#define UB_UBX_ID_ACK_NAK 0x00u
#define UB_UBX_ID_ACK_ACK 0x01u
#define UB_UBX_CLASS_CFG 0x06u
#define UB_UBX_ID_CFG_RATE 0x08u  /**< measRate u16 ms, navRate u16 cycles, timeRef u16 (0 UTC, 1 GPS) */
#define UB_UBX_CFG_RATE_LEN 6u
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

/** The last ACK-ACK or ACK-NAK: which message the receiver answered, and how. */
typedef struct ub_ubx_ack {
    uint8_t cls, id; /**< the acknowledged message's class and id */
    uint8_t ok;      /**< 1 ACK-ACK (applied), 0 ACK-NAK (refused) */
} ub_ubx_ack_t;

/** Counters: every byte fed is in exactly one of bytes_in_messages and noise_bytes, or still held. */
typedef struct ub_ubx_stats {
    uint64_t bytes_in;
    uint64_t noise_bytes;        /**< bytes outside any message */
    uint64_t bytes_in_messages;  /**< bytes of finished or dropped messages, sync included */
    uint64_t nav_pvt;            /**< good NAV-PVT decoded (and called back) */
    uint64_t bad_checksum;       /**< checksum wrong: corrupted in transit */
    uint64_t bad_length;         /**< NAV-PVT whose length is not 92, ACK whose length is not 2 */
    uint64_t ack;                /**< good ACK-ACK */
    uint64_t nak;                /**< good ACK-NAK */
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
    ub_ubx_ack_t ack;
    ub_ubx_stats_t stats;
} ub_ubx_t;

/** Called once per good NAV-PVT (`ubx->cls` UB_UBX_CLASS_NAV, decoded into `ubx->pvt`) and once per good
 *  ACK-ACK/ACK-NAK (`ubx->cls` UB_UBX_CLASS_ACK, decoded into `ubx->ack`). */
typedef void (*ub_ubx_cb)(void *user, const ub_ubx_t *ubx);

/** Empties the parser, zeroes its solution and counters. */
void ub_ubx_init(ub_ubx_t *ubx);

/**
 * Feeds bytes in any cuts. `cb` may be NULL.
 * @return good NAV-PVT decoded by this call, or UB_ERR_INVAL (NULL `ubx`, or NULL `data` with `len` > 0).
 */
UB_CHECK int ub_ubx_feed(ub_ubx_t *ubx, const uint8_t *data, size_t len, ub_ubx_cb cb, void *user);

/**
 * Writes one UBX message (sync, class, id, length, payload, Fletcher checksum) into `out`.
 * @return its length (8 + len), UB_ERR_NOSPACE when `cap` is smaller, UB_ERR_INVAL (NULL).
 */
UB_CHECK int ub_ubx_build(uint8_t cls, uint8_t id, const uint8_t *payload, uint16_t len, uint8_t *out, size_t cap);

/** A receiver answers a CFG within one navigation epoch; a second covers 1 Hz and a busy link. */
#define UB_UBX_ACK_TIMEOUT_MS 1000u

/** The navigation rate a UBX-CFG-RATE carries. */
typedef struct ub_ubx_rate {
    uint16_t meas_rate_ms; /**< measurement period; 0 means "write nothing" */
    uint16_t nav_rate;     /**< measurements per navigation solution */
    uint16_t time_ref;     /**< 0 UTC, 1 GPS time */
} ub_ubx_rate_t;

/**
 * Writing the rate to the receiver and checking its answer, one exchange at a time (the adapters of
 * uavbus_node and Python share it): ub_ubx_cfg_poll() says what to write when the wanted rate differs from
 * what the receiver last answered, or when an answer is overdue (counted, sent again); the caller writes it
 * and calls ub_ubx_cfg_sent(); each ACK-ACK/ACK-NAK the parser decodes goes to ub_ubx_cfg_answer(). A NAK is
 * not retried (the receiver refused that rate); only a changed wanted rate is sent again. Caller-owned.
 */
typedef struct ub_ubx_cfg {
    ub_ubx_rate_t sent;    /**< what the last CFG-RATE carried */
    ub_ubx_rate_t applied; /**< what the receiver last answered (ACK or NAK) */
    uint64_t sent_ms;
    uint8_t pending;       /**< a CFG-RATE waits for its answer */
    uint32_t sent_count, acked, naked, timeouts;
    uint16_t acked_meas_rate_ms; /**< the period last acknowledged; 0 none yet */
} ub_ubx_cfg_t;

void ub_ubx_cfg_init(ub_ubx_cfg_t *cfg);

/**
 * What to write now for `want` at `now_ms`: a CFG-RATE built into `out`.
 * @return its length, 0 when nothing is to be written, UB_ERR_NOSPACE / UB_ERR_INVAL.
 */
UB_CHECK int ub_ubx_cfg_poll(ub_ubx_cfg_t *cfg, const ub_ubx_rate_t *want, uint64_t now_ms, uint8_t *out,
                             size_t cap);

/** The message ub_ubx_cfg_poll() built for `want` was written whole at `now_ms`: its answer is awaited. */
void ub_ubx_cfg_sent(ub_ubx_cfg_t *cfg, const ub_ubx_rate_t *want, uint64_t now_ms);

/** An ACK-ACK/ACK-NAK (ub_ubx_t.ack): settles the pending CFG-RATE when it names CFG-RATE, else nothing.
 *  @return 1 when it settled it. */
int ub_ubx_cfg_answer(ub_ubx_cfg_t *cfg, const ub_ubx_ack_t *ack);

#ifdef __cplusplus
}
#endif
#endif /* UB_UBX_H */
