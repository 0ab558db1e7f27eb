/**
 * @file ub_batchlink.h
 * @brief Frames in batches: a link transport that packs what the router sends on it into batch
 *        format 1 in caller-owned memory, and the unpacking of a received batch into a node.
 *
 * What the Zenoh bridge carries (docs/bridges.md "Batches"): one Zenoh sample holds one batch,
 *
 *     0: 0xA5   1: 0xBA   2: version (1)   3-4: frame count, little-endian (1..65535)
 *     then per frame: length (2 bytes, little-endian, 1..65535), the frame's bytes; nothing after.
 *
 * Byte 1 tells a batch from a bare frame (0x5B there). Consecutive frames join one batch while they
 * have the same key bytes (dir_id, dest_id, src_id, admin: offsets 8..48, what names a flow) and the
 * batch stays within `batch_limit` bytes; so the caller publishes each batch under one flow's key.
 * The per-frame work is all here: the caller's loop sees batches, never frames.
 *
 * Usage (the caller owns every byte; nothing is allocated):
 *
 *     ub_batchlink_t bl;  uint8_t buf[1 << 18];  uint32_t ends[1024];
 *     ub_batchlink_init(&bl, buf, sizeof buf, ends, 1024, 16384);
 *     ub_batchlink_attach(&bl, &node, link);
 *     ... after the node ran: batch i is buf[ends[i-1] (0 for i = 0) .. ends[i]), i < bl.n;
 *     ub_batchlink_clear(&bl);
 *
 * A frame that does not fit (memory or `ends` full) is refused with UB_ERR_AGAIN, which the node counts
 * as backpressure on the link (and `refused` here): bounded, never silent.
 */
#ifndef UB_BATCHLINK_H
#define UB_BATCHLINK_H

#include <stddef.h>
#include <stdint.h>
#include "ub_error.h"
#include "ub_link.h"

#ifdef __cplusplus
extern "C" {
#endif

#define UB_BATCH_SYNC 0xA5u
#define UB_BATCH_MARK 0xBAu
#define UB_BATCH_VERSION 1u
#define UB_BATCH_HEADER 5u
#define UB_BATCH_KEY_OFFSET 8u /**< dir_id, dest_id, src_id, admin of a frame (ub_frame.h) */
#define UB_BATCH_KEY_LEN 41u

typedef struct ub_node ub_node_t;

/** A batching link end. Fields are read by the caller between runs of the node; written only here. */
typedef struct ub_batchlink {
    uint8_t *buf;        /**< caller's memory: the pending batches, back to back */
    size_t cap;
    uint32_t *ends;      /**< caller's memory: end offset in `buf` of each pending batch */
    size_t ends_cap;
    size_t batch_limit;  /**< bytes of one batch; a larger frame goes alone */
    size_t len;          /**< bytes of `buf` in use */
    size_t n;            /**< pending batches; the last one is still open to more frames */
    size_t open_start;   /**< offset of the last batch */
    uint32_t open_count; /**< its frames */
    uint64_t frames;     /**< frames taken in since init */
    uint64_t refused;    /**< frames refused: memory full (UB_ERR_AGAIN) or too long for format 1 */
} ub_batchlink_t;

/** Statuses of ub_batch_check() / ub_batch_rx(): a payload is taken whole or not at all. */
typedef enum ub_batch_status {
    UB_BATCH_OK = 0,
    UB_BATCH_FOREIGN = 1,   /**< not a batch nor a frame: another publisher */
    UB_BATCH_OTHER_VERSION = 2, /**< a bare frame (a bridge before batches) or another format version */
    UB_BATCH_MALFORMED = 3  /**< a batch whose counts and lengths do not add up */
} ub_batch_status_t;

/** The transport vtable of batch links (kind "zenoh": what the bridge carries it over). */
extern const ub_link_ops_t ub_batchlink_ops;

/**
 * Initialises `bl` over the caller's `buf` (`cap` bytes) and `ends` (`ends_cap` entries); `cap` >=
 * UB_BATCH_HEADER + 2 + UB_FRAME_MAX keeps room for any frame; `batch_limit` >= UB_BATCH_HEADER + 2.
 * @return UB_OK, or UB_ERR_INVAL on a NULL pointer or a size outside those bounds (or above UINT32_MAX).
 */
UB_CHECK int ub_batchlink_init(ub_batchlink_t *bl, uint8_t *buf, size_t cap, uint32_t *ends, size_t ends_cap,
                               size_t batch_limit);

/**
 * Puts `bl` behind link slot `link_id` of `node` (ub_node_link_attach() with ub_batchlink_ops).
 * @return UB_OK or the error of ub_node_link_attach().
 */
UB_CHECK int ub_batchlink_attach(ub_batchlink_t *bl, ub_node_t *node, int link_id);

/** Forgets the pending batches (after the caller took them); counters stay. */
void ub_batchlink_clear(ub_batchlink_t *bl);

/**
 * Checks a received payload whole. On UB_BATCH_OK `*count` (may be NULL) is its number of frames.
 */
ub_batch_status_t ub_batch_check(const uint8_t *payload, size_t len, size_t *count);

/**
 * ub_batch_check(), then each frame of the batch in order to ub_node_rx_frame(node, link_id, ..., now_ms).
 * `*frames` (frames handed over) and `*rejected` (those the node refused, counted there by reason) are
 * set, 0 when the payload is refused.
 * @return a ub_batch_status_t.
 */
int ub_batch_rx(ub_node_t *node, int link_id, const uint8_t *payload, size_t len, uint64_t now_ms, size_t *frames,
                size_t *rejected);

#ifdef __cplusplus
}
#endif
#endif /* UB_BATCHLINK_H */
