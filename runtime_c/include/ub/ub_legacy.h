/**
 * @file ub_legacy.h
 * @brief The paper's existing datalink message (AIAA 2005-6309, section III.A) as an envelope: uavbus frames
 *        travel as one more message type of a legacy datalink, beside the legacy messages (section IV: "the
 *        publish/subscribe message has the form of a standard message type of the existing messaging
 *        system"). docs/wire-format.md, "Legacy datalink envelope", is the byte layout; tests/vectors has
 *        vectors that C and Python reproduce.
 *
 * One message (integers little-endian, by shifts):
 *
 *     off size field
 *       0    1  sync0   0xEB
 *       1    1  sync1   0x90   (0xEB90: the classic PCM telemetry frame sync)
 *       2    1  hck     header checksum: 8-bit sum of bytes 4..7
 *       3    1  mck     message checksum: 8-bit sum of bytes 4..7 and every payload byte
 *       4    2  type    message type (the legacy "large case statement" switches on it)
 *       6    2  size    payload bytes (at most UB_LEGACY_PAYLOAD_MAX)
 *       8 size  payload (for the uavbus type: one whole uavbus frame, unchanged)
 *
 * The paper names the fields but not their widths; these are the widths uavbus uses (a deployment whose
 * datalink differs changes this codec and its vectors, nothing else). As in the paper, the checksums
 * are "simple and low-overhead": a uavbus frame inside still carries its own CRC-32C, so a false match of
 * the 8-bit sums cannot deliver a corrupted frame.
 *
 * The parser is a pure state machine (no I/O, no allocation): feed it a stream in any cuts; it calls back
 * once per message whose two checksums hold, with the type, the whole message (header included, as
 * received: a legacy handler gets it byte-exact) and the payload. Bytes before a sync pair, and the sync
 * byte of a candidate whose header checksum, size or message checksum is wrong, are counted `noise_bytes`
 * and the search resumes one byte later.
 */
#ifndef UB_LEGACY_H
#define UB_LEGACY_H

#include <stddef.h>
#include <stdint.h>

#include "ub_error.h"
#include "ub_frame.h"

#ifdef __cplusplus
extern "C" {
#endif

#define UB_LEGACY_SYNC0 0xEBu
#define UB_LEGACY_SYNC1 0x90u
#define UB_LEGACY_HEADER_LEN 8u
/** Largest payload: one whole uavbus frame. */
#define UB_LEGACY_PAYLOAD_MAX UB_FRAME_MAX
#define UB_LEGACY_MESSAGE_MAX (UB_LEGACY_HEADER_LEN + UB_LEGACY_PAYLOAD_MAX)

/** Counters: every byte fed is in exactly one of message_bytes and noise_bytes, or still held. */
typedef struct ub_legacy_stats {
    uint64_t bytes_in;
    uint64_t messages;       /**< good messages called back */
    uint64_t message_bytes;  /**< their bytes, headers included */
    uint64_t noise_bytes;    /**< bytes outside good messages */
    uint64_t bad_header;     /**< candidates whose header checksum did not hold */
    uint64_t bad_checksum;   /**< candidates whose message checksum did not hold */
    uint64_t too_long;       /**< candidates whose size is above UB_LEGACY_PAYLOAD_MAX */
} ub_legacy_stats_t;

/** Parser state; caller-owned. Read `stats`; the rest is private. */
typedef struct ub_legacy {
    uint8_t buf[UB_LEGACY_MESSAGE_MAX];
    size_t have;
    ub_legacy_stats_t stats;
} ub_legacy_t;

/** One good message: `msg` (`msg_len` bytes, header included) and its payload; valid only during the call. */
typedef void (*ub_legacy_cb)(void *user, uint16_t type, const uint8_t *msg, size_t msg_len, const uint8_t *payload,
                             size_t payload_len);

/** Empties the parser and zeroes its counters. */
void ub_legacy_init(ub_legacy_t *p);

/** @return bytes held: an unfinished candidate message (counted in neither message_bytes nor noise_bytes). */
size_t ub_legacy_pending(const ub_legacy_t *p);

/**
 * Feeds bytes in any cuts; `cb` (may be NULL) once per good message, in stream order.
 * @return good messages found by this call, or UB_ERR_INVAL (NULL `p`, NULL `data` with `len` > 0).
 */
UB_CHECK int ub_legacy_feed(ub_legacy_t *p, const uint8_t *data, size_t len, ub_legacy_cb cb, void *user);

/**
 * Writes one message of `type` around `payload` into `out`.
 * @return its length (UB_LEGACY_HEADER_LEN + len); UB_ERR_RANGE (len above UB_LEGACY_PAYLOAD_MAX);
 *         UB_ERR_NOSPACE (`cap` too small); UB_ERR_INVAL (NULL).
 */
UB_CHECK int ub_legacy_build(uint16_t type, const uint8_t *payload, size_t len, uint8_t *out, size_t cap);

#ifdef __cplusplus
}
#endif
#endif /* UB_LEGACY_H */
