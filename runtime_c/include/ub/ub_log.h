/**
 * @file ub_log.h
 * @brief Binary frame log ("ublog"): the writer, installed as a node's frame
 *        tap, and a resynchronising reader over a caller buffer.
 *
 * docs/log-format.md is the specification. In short (all integers little-endian):
 *
 *     header copy  "UBLOG3\r\n" | u32 meta_len | u32 catalogue_len | u32 crc32c(meta | catalogue)
 *                  | u32 head_crc = crc32c(copy[0..20)) | meta (JSON) | catalogue (the catalogue's compact JSON)
 *     file header  header copy | the same copy again (the spare)
 *     record       u16 0xB10C | u16 frame_len | u32 seq | u64 t_ms | u8 link_id | u8 dir (0 rx, 1 tx)
 *                  | u16 reserved (0) | u32 head_crc = crc32c(record[0..20))
 *                  | u32 crc = crc32c continued from head_crc over the frame | frame
 *
 * Every record can be found again after any damage: a reader that loses the
 * record boundary (a flipped byte, deleted or inserted bytes, a torn write)
 * searches for the next position where the marker and `head_crc` hold, and
 * goes on from there. A record whose header holds but whose frame does not is
 * skipped whole and counted; `seq` (one number per record the writer was
 * given, written or not) lets a reader count records that are missing. So a
 * damaged log loses only the records the damage touched. The file header (meta and the
 * embedded catalogue, often the larger part of a short log) is written twice, each copy
 * with its own checks, so one damaged region, wherever it is, leaves one copy whole; and
 * when both are lost (a region over both small copies) the records are still found by
 * searching, to be decoded with a catalogue given separately.
 *
 * meta is `{"format":3,"node":"<name>","links":{"<link_id>":"<link name>",...},
 * "start_unix_ms":N,"start_t_ms":N,"record_tx":true|false,"file_index":K,"first_seq":S,
 * "max_files":M[,"deleted_file":D]}` (D: the file the start of this one deleted to keep max_files);
 * `t_ms` of a record is the node's clock (the `now_ms` it was given), so
 * unix time = start_unix_ms + (t_ms - start_t_ms).
 *
 * Writing is append-only: each record is built in the struct and written with
 * one write(). Failures never stop the node: a record that cannot be written
 * (ENOSPC, EIO, EFBIG...) is counted and its sequence number is skipped; a
 * short write is cut back with ftruncate() where the descriptor allows it;
 * writing resumes by itself when the cause goes away. A program that can meet
 * a file-size limit must ignore SIGXFSZ (uavbus_node does), so the limit
 * comes back as EFBIG: a log opened with ub_log_open_path() then continues in
 * the next file.
 *
 * Rotation refuses a `max_bytes` below ub_log_rotation_floor() (the header and one
 * largest record: a smaller limit would start a file per record); every file deleted
 * to keep `max_files` is counted, named in the next file's meta ("deleted_file") and
 * reported to the event hook (ub_log_set_event_fn()), so no deletion is silent.
 *
 * Usage (a log the writer opens and rotates itself):
 *
 *     static ub_log_t log;
 *     ub_log_rotation_t rot = {.max_bytes = 64u << 20, .max_files = 10};
 *     ub_log_open_path(&log, "primary.ublog", &rot, &node, "primary", false, unix_ms_now, now_ms);
 *     ub_node_set_tap(&node, ub_log_tap, &log);
 *     ...
 *     ub_node_set_tap(&node, NULL, NULL); ub_log_close(&log);
 *
 * or, over a descriptor the caller owns (no rotation): ub_log_open(&log, fd, ...).
 */
#ifndef UB_LOG_H
#define UB_LOG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

#include "ub_error.h"
#include "ub_frame.h"
#include "ub_node.h"

#ifdef __cplusplus
extern "C" {
#endif

#define UB_LOG_MAGIC "UBLOG3\r\n"
/** Version 2 files (one header copy, no head_crc); still read. */
#define UB_LOG_MAGIC_V2 "UBLOG2\r\n"
/** Files written by the first writer (no per-record header check, no sequence numbers); still read. */
#define UB_LOG_MAGIC_V1 "UBLOG1\r\n"
#define UB_LOG_MAGIC_LEN 8u
/** The format version this writer produces (the digit of the magic, and meta's "format"). */
#define UB_LOG_FORMAT 3u
/** Fixed part of one header copy: magic, meta_len, catalogue_len, crc, head_crc. */
#define UB_LOG_FILE_HEADER_LEN 24u
/** Bytes of the fixed part covered by its head_crc (everything before it). */
#define UB_LOG_FILE_HEAD_SPAN 20u
/** Copies of the header at the start of a file (the primary and the spare). */
#define UB_LOG_HEADER_COPIES 2u
/** Fixed part of a version 1 or 2 file header: magic, meta_len, catalogue_len, crc. */
#define UB_LOG_V2_FILE_HEADER_LEN 20u
/** ub_log_header_t.damaged: which copies of the header failed their checks. */
#define UB_LOG_COPY_PRIMARY 0x01u
#define UB_LOG_COPY_SPARE 0x02u
#define UB_LOG_RECORD_MARKER 0xB10Cu
/** Record header: marker, frame_len, seq, t_ms, link_id, dir, reserved, head_crc, crc. */
#define UB_LOG_RECORD_HEADER_LEN 28u
/** Bytes of the record header covered by `head_crc` (everything before it). */
#define UB_LOG_RECORD_HEAD_SPAN 20u
/** Version 1 record header: marker, frame_len, t_ms, link_id, dir, reserved, crc (over 16 bytes + frame). */
#define UB_LOG_V1_RECORD_HEADER_LEN 20u
/** Largest meta JSON the writer produces. */
#define UB_LOG_META_MAX 2048u
/** Longest path ub_log_open_path() accepts, NUL included (rotated names add ".NNNN"). */
#define UB_LOG_PATH_MAX 256u
/** Longest node name, NUL included. */
#define UB_LOG_NAME_MAX 64u
/** After a rotation could not open its next file, the next attempt waits this long (node clock). */
#define UB_LOG_REOPEN_MS 1000u

/** When a log opened with ub_log_open_path() moves on to a new file; zero fields mean "no limit". */
typedef struct ub_log_rotation {
    uint64_t max_bytes; /**< a record that would take the file past this starts the next file */
    uint64_t max_ms;    /**< a record this long (node clock) after the file's start starts the next file */
    uint32_t max_files; /**< files kept: opening one more deletes the oldest (mavlink-router's MaxLogFiles) */
} ub_log_rotation_t;

typedef struct ub_log_stats {
    uint64_t records;      /**< records written whole */
    uint64_t bytes;        /**< bytes now in the log's files (headers included; deleted files too) */
    uint64_t write_errors; /**< records not written (write failed or was short); errno kept in last_errno */
    uint64_t skipped_tx;   /**< transmitted frames not recorded (record_tx off) */
    int last_errno;        /**< errno of the last failure (0: none yet) */
    uint64_t torn_writes;  /**< short writes; cut back with ftruncate(), else left for readers to skip */
    uint64_t torn_bytes;   /**< bytes of short writes that could not be cut back (readers skip them) */
    uint64_t recoveries;   /**< times a record was written again after failures */
    uint64_t files;        /**< files started (1 + rotations that opened a file) */
    uint64_t files_deleted; /**< old files deleted to keep max_files */
    uint64_t open_errors;  /**< rotations that could not open their file or write its header (retried) */
    uint64_t limit_rotations; /**< writes refused with EFBIG (a file-size limit) that moved on to the next file */
    uint64_t delete_errors; /**< old files that max_files should have deleted but could not be (errno in last_errno) */
} ub_log_stats_t;

/** What ub_log_event_fn reports. */
typedef enum ub_log_event {
    UB_LOG_EVENT_FILE_STARTED = 1, /**< a rotation started file `index` (`name`) */
    UB_LOG_EVENT_FILE_DELETED = 2, /**< file `index` (`name`) was deleted to keep max_files */
    UB_LOG_EVENT_DELETE_FAILED = 3 /**< file `index` should have been deleted and could not be (errno set) */
} ub_log_event_t;

/** Event hook of a rotating log (e.g. a program prints one line per event). Called from ub_log_write(). */
typedef void (*ub_log_event_fn)(void *user, ub_log_event_t event, uint32_t index, const char *name);

/** Injectable write(2), for tests: return like write(2), with errno set on failure. */
typedef ssize_t (*ub_log_write_fn)(void *user, int fd, const void *buf, size_t len);

/** A log writer. Caller-owned; treat the fields as private. */
typedef struct ub_log {
    int fd;                /**< -1 when closed, or while a rotation waits to open its file */
    uint8_t open;          /**< between open and close */
    uint8_t record_tx;
    uint8_t owns_fd;       /**< opened from a path: rotation possible, closed by ub_log_close() */
    uint8_t need_header;   /**< the current file has no header yet (retried before the next record) */
    uint8_t failing;       /**< the last record could not be written */
    uint32_t next_seq;     /**< sequence number of the next record */
    uint32_t file_index;
    uint32_t file_first_seq;
    int64_t file_deleted;  /**< index of the file the start of the current one deleted; -1: none */
    uint64_t file_bytes;   /**< bytes in the current file */
    uint64_t file_start_t_ms;
    uint64_t reopen_at_ms;
    uint64_t start_unix_ms, start_t_ms;
    const ub_node_t *node;
    ub_log_rotation_t rot;
    ub_log_write_fn write_fn;
    void *write_user;
    ub_log_event_fn event_fn;
    void *event_user;
    ub_log_stats_t stats;
    char node_name[UB_LOG_NAME_MAX];
    char path[UB_LOG_PATH_MAX];
    uint8_t rec[UB_LOG_RECORD_HEADER_LEN + UB_FRAME_MAX];
} ub_log_t;

/**
 * Writes the file header to `fd` (which the caller opened for writing at the
 * start of a file and keeps owning) and prepares `log`. The meta JSON names
 * every link of `node` by id, the node `node_name`, and the start times; the
 * catalogue JSON is `node`'s catalogue self-description (empty if it has none).
 * `record_tx` false records received frames only. Names are JSON-escaped in the meta.
 * `node` must outlive the log.
 * @return UB_OK; UB_ERR_INVAL (NULL, fd < 0, node without catalogue);
 *         UB_ERR_NOSPACE (meta longer than UB_LOG_META_MAX, name longer than UB_LOG_NAME_MAX - 1);
 *         UB_ERR_IO (the header could not be written whole; errno set).
 */
UB_CHECK int ub_log_open(ub_log_t *log, int fd, const ub_node_t *node, const char *node_name, bool record_tx,
                         uint64_t start_unix_ms, uint64_t start_t_ms);

/**
 * ub_log_open() on a file the writer creates (truncating it) and owns, with
 * rotation: `rot` NULL or all zero = one file. File k > 0 of the set is
 * `path` with ".k" (4 digits at least) before its extension: primary.ublog,
 * primary.0001.ublog, primary.0002.ublog... (ub_log_file_name()). Every file
 * starts with its own header, so each one reads alone; `seq` runs on across files.
 * @return as ub_log_open(); UB_ERR_NOSPACE (path too long); UB_ERR_RANGE
 *         (rot->max_bytes non-zero and below ub_log_rotation_floor(): no file
 *         is created); UB_ERR_IO (open or header write failed, errno set:
 *         nothing is left open).
 */
UB_CHECK int ub_log_open_path(ub_log_t *log, const char *path, const ub_log_rotation_t *rot, const ub_node_t *node,
                              const char *node_name, bool record_tx, uint64_t start_unix_ms, uint64_t start_t_ms);

/**
 * Name of file `index` of a set opened at `path` (index 0 is `path` itself).
 * @return UB_OK, UB_ERR_INVAL or UB_ERR_NOSPACE (`cap` too small).
 */
UB_CHECK int ub_log_file_name(const char *path, uint32_t index, char *out, size_t cap);

/**
 * The smallest `max_bytes` a rotating log of `node` accepts: both copies of the
 * longest header its files can have (meta with the widest numbers, the
 * catalogue) plus one record of UB_FRAME_MAX bytes. Below it every record would
 * start a new file.
 * @return UB_OK with *out set; UB_ERR_INVAL (NULL, node without catalogue);
 *         UB_ERR_NOSPACE (meta or name too long, as ub_log_open()).
 */
UB_CHECK int ub_log_rotation_floor(const ub_node_t *node, const char *node_name, uint64_t *out);

/** Installs the event hook of a log opened with ub_log_open_path() (NULL removes it). */
void ub_log_set_event_fn(ub_log_t *log, ub_log_event_fn fn, void *user);

/** Replaces write(2) for this log (tests inject failures); NULL restores write(2). */
void ub_log_set_write_fn(ub_log_t *log, ub_log_write_fn fn, void *user);

/**
 * Appends one record with one write() (rotating first when a limit is reached).
 * @return UB_OK; UB_ERR_INVAL (closed, NULL frame, len 0 or > UB_FRAME_MAX,
 *         link_id outside 0..255, bad dir); UB_ERR_IO (not written: counted in
 *         write_errors, and the record's sequence number is skipped).
 */
UB_CHECK int ub_log_write(ub_log_t *log, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len,
                          uint64_t t_ms);

/** A ub_tap_fn: `user` is the ub_log_t. Failures are counted (ub_log_stats()), never silent. */
void ub_log_tap(void *user, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len, uint64_t now_ms);

/** @return the counters. */
const ub_log_stats_t *ub_log_stats(const ub_log_t *log);

/** @return the index of the file being written (0 for the first). */
uint32_t ub_log_file_index(const ub_log_t *log);

/** Stops writing (later writes are UB_ERR_INVAL); closes the file if the log opened it. Safe to call twice. */
void ub_log_close(ub_log_t *log);

/* ---- Reader over a file image in memory ----------------------------------------------------------- */

/** The parsed file header; `meta` and `catalogue` point into the caller's buffer. */
typedef struct ub_log_header {
    const char *meta;
    uint32_t meta_len;
    const char *catalogue;
    uint32_t catalogue_len;
    uint8_t version; /**< 1, 2 or 3 */
    size_t size;     /**< bytes of the whole file header (both copies): the offset of the first record;
                          0 when the header is lost and where the records start is unknown */
    uint8_t damaged; /**< UB_LOG_COPY_PRIMARY / UB_LOG_COPY_SPARE: copies that failed their checks (version 3) */
} ub_log_header_t;

typedef struct ub_log_record {
    uint64_t t_ms;
    uint8_t link_id;
    uint8_t dir;          /**< UB_TAP_RX or UB_TAP_TX */
    const uint8_t *frame; /**< points into the caller's buffer */
    uint16_t len;
    uint32_t seq;         /**< the writer's record number (version 1: numbered by the reader from 0) */
    size_t offset;        /**< where the record starts in the buffer given to the reader */
} ub_log_record_t;

/** What the reader saw. header + record_bytes + skipped_bytes == the bytes it decided on. */
typedef struct ub_log_reader_stats {
    uint64_t records;         /**< good records returned */
    uint64_t record_bytes;    /**< their bytes, record headers included */
    uint64_t skipped_bytes;   /**< bytes in no good record: damaged records, garbage, a cut tail */
    uint64_t damaged_records; /**< records whose header held and whose frame check failed (skipped whole) */
    uint64_t resyncs;         /**< times the record boundary was lost and the next record searched for */
    uint64_t truncated_bytes; /**< bytes of an incomplete record at the end of the file (in skipped_bytes too) */
    uint64_t missing_records; /**< records absent by their sequence numbers: not written, or lost to damage */
    uint64_t seq_restarts;    /**< a sequence number went backwards (files of two runs joined) */
} ub_log_reader_stats_t;

/** Record iterator over a window of bytes. Treat the fields as private. */
typedef struct ub_log_reader {
    const uint8_t *buf;
    size_t len;
    size_t pos;     /**< bytes of the window decided (returned or skipped) */
    uint8_t version;
    uint8_t final;  /**< no bytes follow the window: an incomplete record there is a cut tail */
    uint8_t lost;   /**< 0 at a boundary; 1 searching (one resync counted per search); 2 in what may be a cut tail */
    uint8_t have_seq;
    uint32_t next_seq;
    size_t tail_at; /**< where a possible cut tail began (lost == 2) */
    ub_log_reader_stats_t stats;
} ub_log_reader_t;

/**
 * Parses the file header at the start of `buf[0, len)`. Version 3: the first
 * copy whose checks hold is used (the primary, else the spare; a copy whose own
 * fixed part is damaged is read with the other's lengths and CRC), and
 * `hdr->damaged` says which failed. A primary whose magic or fixed part is
 * damaged is found again through its spare.
 * @return UB_OK; UB_ERR_INVAL (NULL, or not a ublog: unknown magic and no spare copy);
 *         UB_ERR_TRUNCATED (`len` shorter than the header says: read more);
 *         UB_ERR_CHECKSUM (no copy of meta and catalogue is whole: `hdr` is still
 *         filled with the version, `damaged` and `size`, the offset of the first
 *         record or 0 when unknown, and no meta or catalogue; the records can be
 *         read from there with ub_log_reader_begin() / ub_log_reader_data(), which
 *         search past whatever is left of the header).
 */
UB_CHECK int ub_log_header_parse(const uint8_t *buf, size_t len, ub_log_header_t *hdr);

/**
 * Rebuilds, in place, the header of a version 3 file for which
 * ub_log_header_parse() found no whole copy (UB_ERR_CHECKSUM with a non-zero
 * size): one damaged region over the end of the primary copy and the start of
 * the spare leaves the primary's start and the spare's end, which together are
 * a whole copy. The spare's bytes are written over the primary's from where
 * the two agree, if the result matches the header CRC; ub_log_header_parse()
 * then succeeds (reporting both copies whole: remember what it said before).
 * @return UB_OK (repaired); UB_ERR_CHECKSUM (no such combination, or no sound
 *         fixed part); UB_ERR_TRUNCATED; UB_ERR_INVAL (NULL, not version 3).
 */
UB_CHECK int ub_log_header_repair(uint8_t *buf, size_t len);

/**
 * Whole-file reader: parses the header of `buf[0, len)` (ub_log_header_parse())
 * and positions `rd` at the first record, with the end of `buf` as the end of the file.
 * @return as ub_log_header_parse().
 */
UB_CHECK int ub_log_reader_init(ub_log_reader_t *rd, const uint8_t *buf, size_t len, ub_log_header_t *hdr);

/**
 * Incremental reader (following a growing file): starts an empty reader for
 * records of format `version` (from the header). Give it bytes with
 * ub_log_reader_data().
 */
void ub_log_reader_begin(ub_log_reader_t *rd, uint8_t version);

/**
 * Makes `buf[0, len)` the window the reader works on, from its start; counters
 * and sequence tracking carry on. `final` says no bytes will follow. A
 * follower passes the bytes from ub_log_reader_consumed() on, plus new ones.
 */
void ub_log_reader_data(ub_log_reader_t *rd, const uint8_t *buf, size_t len, bool final);

/**
 * Reads the next good record, skipping (and counting) whatever is damaged.
 * @return 1 with `*rec` filled; 0 when the window has no further record that
 *         can be decided (at its end, or, if not final, more bytes are needed).
 */
int ub_log_reader_next(ub_log_reader_t *rd, ub_log_record_t *rec);

/** @return bytes at the start of the window decided so far (records returned or bytes skipped). */
size_t ub_log_reader_consumed(const ub_log_reader_t *rd);

/** Counts records missing before the first record read (e.g. meta's "first_seq" of the file). */
void ub_log_reader_expect_seq(ub_log_reader_t *rd, uint32_t seq);

/** @return the counters. */
const ub_log_reader_stats_t *ub_log_reader_stats(const ub_log_reader_t *rd);

/** @return bytes skipped so far (damaged records, garbage, a cut tail): stats.skipped_bytes. */
size_t ub_log_reader_ignored(const ub_log_reader_t *rd);

#ifdef __cplusplus
}
#endif
#endif /* UB_LOG_H */
