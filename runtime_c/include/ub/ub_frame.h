/**
 * @file ub_frame.h
 * @brief The publish/subscribe frame: build, verify, and a streaming decoder.
 *
 * Byte layout (little-endian; diagram in docs/wire-format.md):
 *
 *   off len field
 *    0   2  sync            0xA5 0x5B
 *    2   1  hdr_check       CRC-32C of bytes [4,60), folded to 8 bits
 *    3   1  version         UB_WIRE_VERSION
 *    4   2  msg_type        UB_MSG_TYPE_PUBSUB (the datalink's message type)
 *    6   2  msg_size        whole frame: 64 + payload_size
 *    8  16  dir_id          content ("uniqueDirID")
 *   24  12  dest_id         destination entity ("uniqueDestID")
 *   36  12  src_id          source entity ("uniqueSrcID")
 *   48   1  admin           admin code (ub_admin_code_t)
 *   49   1  hop_limit       decremented by each forwarder; 0 is never sent
 *   50   2  payload_size
 *   52   4  seq             per-source sequence number
 *   56   4  fingerprint     layout fingerprint of the content type (0 if none)
 *   60   4  msg_crc         CRC-32C (Castagnoli) of bytes [4,60) then the payload
 *   64   n  payload
 *
 * The decoder is a pure state machine: no I/O, no allocation, no globals. Feed
 * it any chunking of a byte stream; it calls back once per verified frame and
 * counts every rejection by reason.
 */
#ifndef UB_FRAME_H
#define UB_FRAME_H

#include <stddef.h>
#include <stdint.h>
#include "ub_catalogue.h"
#include "ub_config.h"
#include "ub_error.h"

#ifdef __cplusplus
extern "C" {
#endif

#define UB_SYNC0 0xA5u
#define UB_SYNC1 0x5Bu
#define UB_WIRE_VERSION 1u
#define UB_MSG_TYPE_PUBSUB 0x5053u /* "PS" */
#define UB_FRAME_HEADER_LEN 64u
#define UB_FRAME_MAX (UB_FRAME_HEADER_LEN + UB_MAX_PAYLOAD)

/** Admin codes (docs/wire-format.md, "Admin codes"). */
typedef enum ub_admin_code {
    UB_ADMIN_DATA = 0,        /**< payload is a packed directory instance */
    UB_ADMIN_PUB_REQUEST = 1, /**< add/renew a publication at the source entity */
    UB_ADMIN_SUB_REQUEST = 2, /**< add/renew a subscription at the destination entity */
    UB_ADMIN_PUB_STOP = 3,    /**< remove a publication at the source entity */
    UB_ADMIN_SUB_STOP = 4,    /**< remove a subscription at the destination entity */
    UB_ADMIN_ACK = 5,         /**< a table-change request was applied */
    UB_ADMIN_NACK = 6         /**< a table-change request was refused (reason in payload) */
} ub_admin_code_t;

/** Host form of a frame header; ub_frame_finish() fills in the checks and sizes. */
typedef struct ub_frame_header {
    uint16_t msg_type;
    uint8_t dir_id[UB_DIR_ID_LEN];
    uint8_t dest_id[UB_ENTITY_ID_LEN];
    uint8_t src_id[UB_ENTITY_ID_LEN];
    uint8_t admin;
    uint8_t hop_limit;
    uint16_t payload_size;
    uint32_t seq;
    uint32_t fingerprint;
} ub_frame_header_t;

/**
 * Completes a frame whose payload the caller has already written at
 * `frame + UB_FRAME_HEADER_LEN` (so pack writes straight into the frame, with
 * no copy): writes the header from `h`, then both checks.
 * @return total frame length, UB_ERR_NOSPACE if `cap` is too small, or
 *         UB_ERR_RANGE if h->payload_size > UB_MAX_PAYLOAD.
 */
UB_CHECK int ub_frame_finish(uint8_t *frame, size_t cap, const ub_frame_header_t *h);

/**
 * Verifies one complete frame of exactly `len` bytes and decodes its header.
 * @return UB_OK, UB_ERR_TRUNCATED, UB_ERR_CHECKSUM, or UB_ERR_INVAL (bad sync,
 *         version or inconsistent sizes).
 */
UB_CHECK int ub_frame_parse(const uint8_t *frame, size_t len, ub_frame_header_t *h);

/** Why the decoder rejected bytes; indexes ub_decoder_stats_t.rejected[]. */
typedef enum ub_rx_reason {
    UB_RX_BAD_HDR_CHECK = 0, /**< header check byte mismatch */
    UB_RX_BAD_CRC,           /**< message CRC mismatch (corrupt payload, truncation, lying length) */
    UB_RX_BAD_LENGTH,        /**< msg_size/payload_size inconsistent or above UB_MAX_PAYLOAD */
    UB_RX_BAD_VERSION,       /**< unknown wire version or message type */
    UB_RX_REASON_COUNT
} ub_rx_reason_t;

typedef struct ub_decoder_stats {
    uint64_t frames_ok;                     /**< frames delivered to the callback */
    uint64_t bytes_in;                      /**< bytes fed */
    uint64_t garbage_bytes;                 /**< bytes skipped while hunting for sync */
    uint64_t rejected[UB_RX_REASON_COUNT];  /**< rejected candidate frames, by reason */
} ub_decoder_stats_t;

/**
 * Called once per verified frame. `frame` points to the whole frame
 * (`frame_len` bytes) and is valid only during the call.
 */
typedef void (*ub_frame_cb)(void *user, const ub_frame_header_t *h, const uint8_t *frame, size_t frame_len);

/** Streaming decoder; caller-owned, no allocation. Treat the fields as private. */
typedef struct ub_decoder {
    uint8_t buf[UB_FRAME_MAX]; /* a partial frame carried between feeds */
    size_t have;
    ub_decoder_stats_t stats;
} ub_decoder_t;

void ub_decoder_init(ub_decoder_t *d);

/**
 * Feeds `len` bytes. Calls `cb` for each verified frame, in stream order.
 * After any rejection it resumes the search one byte past the rejected sync,
 * so a valid frame that follows garbage, a truncated frame or a lying length
 * is still found.
 * @return the number of frames delivered by this call (never negative).
 */
size_t ub_decoder_feed(ub_decoder_t *d, const uint8_t *data, size_t len, ub_frame_cb cb, void *user);

/** CRC-32C (Castagnoli, reflected, init/xorout 0xFFFFFFFF) of a buffer. */
uint32_t ub_crc32c(const uint8_t *data, size_t len);
/** Continues a CRC-32C: pass the previous result as `crc` (0 to start). */
uint32_t ub_crc32c_update(uint32_t crc, const uint8_t *data, size_t len);

#ifdef __cplusplus
}
#endif
#endif /* UB_FRAME_H */
