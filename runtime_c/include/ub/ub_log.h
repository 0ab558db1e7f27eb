/**
 * @file ub_log.h
 * @brief Binary frame log ("ublog"): the writer, installed as a node's frame
 *        tap, and a small reader over a caller buffer (for C tests and tools).
 *
 * docs/log-format.md is the specification. In short (all integers little-endian):
 *
 *     file header  "UBLOG1\r\n" | u32 meta_len | u32 catalogue_len | u32 crc32c(meta | catalogue)
 *                  | meta (JSON) | catalogue (the catalogue's compact JSON)
 *     record       u16 0xB10C | u16 frame_len | u64 t_ms | u8 link_id | u8 dir (0 rx, 1 tx)
 *                  | u16 reserved (0) | u32 crc32c(record[0..15] | frame) | frame
 *
 * meta is `{"format":1,"node":"<name>","links":{"<link_id>":"<link name>",...},
 * "start_unix_ms":N,"start_t_ms":N,"record_tx":true|false}`; `t_ms` of a
 * record is the node's clock (the `now_ms` it was given), so
 * unix time = start_unix_ms + (t_ms - start_t_ms).
 *
 * Writing is append-only: each record is built in the struct and written with
 * one write() (so it reaches the OS at once and a crash cuts at most the
 * record being written). A reader stops at the last whole record whose CRC
 * holds and reports how many bytes it ignored after it.
 *
 * Usage:
 *
 *     int fd = open("primary.ublog", O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
 *     static ub_log_t log;
 *     ub_log_open(&log, fd, &node, "primary", false, unix_ms_now, now_ms);
 *     ub_node_set_tap(&node, ub_log_tap, &log);
 *     ...
 *     ub_node_set_tap(&node, NULL, NULL); ub_log_close(&log); close(fd);
 */
#ifndef UB_LOG_H
#define UB_LOG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ub_error.h"
#include "ub_frame.h"
#include "ub_node.h"

#ifdef __cplusplus
extern "C" {
#endif

#define UB_LOG_MAGIC "UBLOG1\r\n"
#define UB_LOG_MAGIC_LEN 8u
/** Fixed part of the file header: magic, meta_len, catalogue_len, crc. */
#define UB_LOG_FILE_HEADER_LEN 20u
#define UB_LOG_RECORD_MARKER 0xB10Cu
/** Record header: marker, frame_len, t_ms, link_id, dir, reserved, crc. */
#define UB_LOG_RECORD_HEADER_LEN 20u
/** Bytes of the record header covered by its CRC (everything before the CRC). */
#define UB_LOG_RECORD_CRC_SPAN 16u
/** Largest meta JSON the writer produces. */
#define UB_LOG_META_MAX 2048u

typedef struct ub_log_stats {
    uint64_t records;      /**< records written whole */
    uint64_t bytes;        /**< bytes written (header included) */
    uint64_t write_errors; /**< records not written (write failed or was short; errno kept in last_errno) */
    uint64_t skipped_tx;   /**< transmitted frames not recorded (record_tx off) */
    int last_errno;
} ub_log_stats_t;

/** A log writer. Caller-owned; treat the fields as private. */
typedef struct ub_log {
    int fd;          /**< -1 when closed */
    uint8_t record_tx;
    ub_log_stats_t stats;
    uint8_t rec[UB_LOG_RECORD_HEADER_LEN + UB_FRAME_MAX];
} ub_log_t;

/**
 * Writes the file header to `fd` (which the caller opened for writing at the
 * start of a file and keeps owning) and prepares `log`. The meta JSON names
 * every link of `node` by id, the node `node_name`, and the start times; the
 * catalogue JSON is `node`'s catalogue self-description (empty if it has none).
 * `record_tx` false records received frames only.
 * Names are JSON-escaped in the meta.
 * @return UB_OK; UB_ERR_INVAL (NULL, fd < 0, node without catalogue);
 *         UB_ERR_NOSPACE (meta longer than UB_LOG_META_MAX);
 *         UB_ERR_IO (the header could not be written whole; errno set).
 */
UB_CHECK int ub_log_open(ub_log_t *log, int fd, const ub_node_t *node, const char *node_name, bool record_tx,
                         uint64_t start_unix_ms, uint64_t start_t_ms);

/**
 * Appends one record with one write().
 * @return UB_OK; UB_ERR_INVAL (closed, NULL frame, len 0 or > UB_FRAME_MAX,
 *         link_id outside 0..255); UB_ERR_IO (counted in write_errors).
 */
UB_CHECK int ub_log_write(ub_log_t *log, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len,
                          uint64_t t_ms);

/** A ub_tap_fn: `user` is the ub_log_t. Failures are counted (ub_log_stats()), never silent. */
void ub_log_tap(void *user, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len, uint64_t now_ms);

/** @return the counters. */
const ub_log_stats_t *ub_log_stats(const ub_log_t *log);

/** Stops writing (later writes are UB_ERR_INVAL). Does not close the descriptor. Safe to call twice. */
void ub_log_close(ub_log_t *log);

/* ---- Reader over a whole file image in memory ---------------------------------------- */

/** The parsed file header; `meta` and `catalogue` point into the caller's buffer. */
typedef struct ub_log_header {
    const char *meta;
    uint32_t meta_len;
    const char *catalogue;
    uint32_t catalogue_len;
} ub_log_header_t;

typedef struct ub_log_record {
    uint64_t t_ms;
    uint8_t link_id;
    uint8_t dir;          /**< UB_TAP_RX or UB_TAP_TX */
    const uint8_t *frame; /**< points into the caller's buffer */
    uint16_t len;
} ub_log_record_t;

/** Record iterator over `buf[0, len)`. */
typedef struct ub_log_reader {
    const uint8_t *buf;
    size_t len;
    size_t pos;
} ub_log_reader_t;

/**
 * Checks the file header of `buf[0, len)` and positions `rd` at the first record.
 * @return UB_OK; UB_ERR_INVAL (NULL); UB_ERR_TRUNCATED (shorter than the
 *         header says); UB_ERR_CHECKSUM (bad magic or header CRC).
 */
UB_CHECK int ub_log_reader_init(ub_log_reader_t *rd, const uint8_t *buf, size_t len, ub_log_header_t *hdr);

/**
 * Reads the next record.
 * @return 1 with `*rec` filled; 0 at the end of the valid records (a bad
 *         marker, a CRC mismatch or a cut record: see ub_log_reader_ignored()).
 */
int ub_log_reader_next(ub_log_reader_t *rd, ub_log_record_t *rec);

/** @return bytes after the last valid record read so far (0 when the whole file was read). */
size_t ub_log_reader_ignored(const ub_log_reader_t *rd);

#ifdef __cplusplus
}
#endif
#endif /* UB_LOG_H */
