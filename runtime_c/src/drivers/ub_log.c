/* Binary frame log writer and reader (ub_log.h, docs/log-format.md). */
#include "ub/ub_log.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "ub/ub_wire.h"

/* ---- writing ----------------------------------------------------------------------------------------- */

static ssize_t write_once(ub_log_t *log, const uint8_t *buf, size_t len) {
    ssize_t n;
    do {
        n = log->write_fn != NULL ? log->write_fn(log->write_user, log->fd, buf, len) : write(log->fd, buf, len);
    } while (n < 0 && errno == EINTR);
    return n;
}

/* Writes buf whole, continuing after short writes (a signal can cut a regular-file write) until the OS
 * refuses. @return bytes written; when fewer than `len`, errno says why. */
static size_t write_all(ub_log_t *log, const uint8_t *buf, size_t len) {
    size_t done = 0;
    while (done < len) {
        ssize_t n = write_once(log, buf + done, len - done);
        if (n < 0) return done;
        if (n == 0) {
            errno = EIO;
            return done;
        }
        done += (size_t)n;
    }
    return done;
}

/* A write stopped after `written` of its bytes: cut the file back to where the write started, so the
 * next record follows the last whole one. Where that is impossible (a pipe, a descriptor positioned by
 * someone else) the torn bytes stay: readers skip them. errno is preserved for the caller. */
static void cut_back(ub_log_t *log, size_t written) {
    if (written == 0) return;
    int saved = errno;
    log->stats.torn_writes++;
    if (ftruncate(log->fd, (off_t)log->file_bytes) != 0 || lseek(log->fd, (off_t)log->file_bytes, SEEK_SET) < 0) {
        log->file_bytes += written;
        log->stats.bytes += written;
        log->stats.torn_bytes += written;
    }
    errno = saved;
}

/* Appends a JSON string (quoted, escaped) to out[*pos..cap). False when it does not fit. */
static bool put_json_string(char *out, size_t cap, size_t *pos, const char *s) {
    size_t p = *pos;
    if (p + 1 >= cap) return false;
    out[p++] = '"';
    for (const unsigned char *c = (const unsigned char *)s; *c != '\0'; c++) {
        char esc[8];
        size_t n;
        if (*c == '"' || *c == '\\') {
            esc[0] = '\\';
            esc[1] = (char)*c;
            n = 2;
        } else if (*c < 0x20) {
            n = (size_t)snprintf(esc, sizeof esc, "\\u%04x", (unsigned)*c);
        } else {
            esc[0] = (char)*c;
            n = 1;
        }
        if (p + n + 1 >= cap) return false;
        memcpy(out + p, esc, n);
        p += n;
    }
    if (p + 1 >= cap) return false;
    out[p++] = '"';
    out[p] = '\0';
    *pos = p;
    return true;
}

static bool put_text(char *out, size_t cap, size_t *pos, const char *text) {
    size_t n = strlen(text);
    if (*pos + n + 1 > cap) return false;
    memcpy(out + *pos, text, n + 1);
    *pos += n;
    return true;
}

/* meta: {"format":3,"node":"..","links":{"0":"name",...},"start_unix_ms":N,"start_t_ms":N,"record_tx":b,
 *        "file_index":K,"first_seq":S,"max_files":M[,"deleted_file":D]} */
static int build_meta(const ub_log_t *log, uint64_t start_unix_ms, uint64_t start_t_ms, char *out, size_t cap,
                      size_t *len) {
    size_t pos = 0;
    char tmp[224];
    bool ok = put_text(out, cap, &pos, "{\"format\":3,\"node\":") && put_json_string(out, cap, &pos, log->node_name)
              && put_text(out, cap, &pos, ",\"links\":{");
    bool first = true;
    for (int id = 0; ok && id < UB_MAX_NODE_LINKS; id++) {
        const ub_link_t *link = ub_node_link(log->node, id);
        if (link == NULL) continue;
        snprintf(tmp, sizeof tmp, "%s\"%d\":", first ? "" : ",", id);
        ok = put_text(out, cap, &pos, tmp) && put_json_string(out, cap, &pos, link->name);
        first = false;
    }
    snprintf(tmp, sizeof tmp,
             "},\"start_unix_ms\":%llu,\"start_t_ms\":%llu,\"record_tx\":%s,\"file_index\":%lu,\"first_seq\":%lu,"
             "\"max_files\":%lu",
             (unsigned long long)start_unix_ms, (unsigned long long)start_t_ms, log->record_tx ? "true" : "false",
             (unsigned long)log->file_index, (unsigned long)log->file_first_seq, (unsigned long)log->rot.max_files);
    ok = ok && put_text(out, cap, &pos, tmp);
    if (log->file_deleted >= 0) {
        snprintf(tmp, sizeof tmp, ",\"deleted_file\":%lld", (long long)log->file_deleted);
        ok = ok && put_text(out, cap, &pos, tmp);
    }
    ok = ok && put_text(out, cap, &pos, "}");
    if (!ok) return UB_ERR_NOSPACE;
    *len = pos;
    return UB_OK;
}

/* Writes the current file's header, the file starting at `t_ms`: the copy (magic, lengths, CRC, head_crc,
 * meta, catalogue) twice, so that one damaged region leaves a whole copy. On failure the file is cut back
 * to empty and need_header stays set. */
static int write_header(ub_log_t *log, uint64_t t_ms) {
    uint8_t head[UB_LOG_FILE_HEADER_LEN + UB_LOG_META_MAX];
    size_t meta_len = 0;
    uint64_t unix_ms = log->start_unix_ms + (t_ms >= log->start_t_ms ? t_ms - log->start_t_ms : 0);
    int rc = build_meta(log, unix_ms, t_ms, (char *)head + UB_LOG_FILE_HEADER_LEN, UB_LOG_META_MAX, &meta_len);
    if (rc != UB_OK) return rc;
    const uint8_t *cat = (const uint8_t *)log->node->cat->json;
    size_t cat_len = cat != NULL ? log->node->cat->json_len : 0;
    memcpy(head, UB_LOG_MAGIC, UB_LOG_MAGIC_LEN);
    ub_put_u32le(head + 8, (uint32_t)meta_len);
    ub_put_u32le(head + 12, (uint32_t)cat_len);
    uint32_t crc = ub_crc32c(head + UB_LOG_FILE_HEADER_LEN, meta_len);
    crc = ub_crc32c_update(crc, cat, cat_len);
    ub_put_u32le(head + 16, crc);
    ub_put_u32le(head + UB_LOG_FILE_HEAD_SPAN, ub_crc32c(head, UB_LOG_FILE_HEAD_SPAN));
    /* Per copy: fixed part and meta with one write(); the catalogue (tens of kB) follows. */
    size_t first = UB_LOG_FILE_HEADER_LEN + meta_len;
    size_t done = 0, want = 0;
    for (unsigned copy = 0; copy < UB_LOG_HEADER_COPIES && done == want; copy++) {
        want += first;
        done += write_all(log, head, first);
        if (done == want && cat_len > 0) {
            want += cat_len;
            done += write_all(log, cat, cat_len);
        }
    }
    if (done != UB_LOG_HEADER_COPIES * (first + cat_len)) {
        cut_back(log, done);
        return UB_ERR_IO;
    }
    log->file_bytes += done;
    log->stats.bytes += done;
    log->file_start_t_ms = t_ms;
    log->need_header = 0;
    return UB_OK;
}

int ub_log_file_name(const char *path, uint32_t index, char *out, size_t cap) {
    if (path == NULL || out == NULL || cap == 0) return UB_ERR_INVAL;
    int n;
    if (index == 0) {
        n = snprintf(out, cap, "%s", path);
    } else {
        /* The extension is the last '.' of the last path component, unless that component starts with it. */
        const char *base = strrchr(path, '/');
        base = base != NULL ? base + 1 : path;
        const char *dot = strrchr(base, '.');
        if (dot == NULL || dot == base) dot = base + strlen(base);
        n = snprintf(out, cap, "%.*s.%04lu%s", (int)(dot - path), path, (unsigned long)index, dot);
    }
    return n < 0 || (size_t)n >= cap ? UB_ERR_NOSPACE : UB_OK;
}

/* The shared part of both opens: everything but the descriptor. */
static int prepare(ub_log_t *log, const ub_node_t *node, const char *node_name, bool record_tx,
                   uint64_t start_unix_ms, uint64_t start_t_ms) {
    if (log == NULL || node == NULL || node_name == NULL || node->cat == NULL) return UB_ERR_INVAL;
    memset(log, 0, sizeof *log);
    log->fd = -1;
    size_t name_len = strlen(node_name);
    if (name_len >= sizeof log->node_name) return UB_ERR_NOSPACE;
    if (node->cat->json != NULL && node->cat->json_len > UINT32_MAX) return UB_ERR_RANGE;
    memcpy(log->node_name, node_name, name_len + 1);
    log->node = node;
    log->record_tx = record_tx ? 1 : 0;
    log->start_unix_ms = start_unix_ms;
    log->start_t_ms = start_t_ms;
    log->need_header = 1;
    log->file_deleted = -1;
    return UB_OK;
}

int ub_log_rotation_floor(const ub_node_t *node, const char *node_name, uint64_t *out) {
    if (out == NULL) return UB_ERR_INVAL;
    /* The widest meta any file of the set can have: every number at its longest, a deletion named. */
    ub_log_t probe; /* only its meta fields are used */
    int rc = prepare(&probe, node, node_name, true, UINT64_MAX, UINT64_MAX);
    if (rc != UB_OK) return rc;
    probe.file_index = UINT32_MAX;
    probe.file_first_seq = UINT32_MAX;
    probe.rot.max_files = UINT32_MAX;
    probe.file_deleted = UINT32_MAX;
    char meta[UB_LOG_META_MAX];
    size_t meta_len = 0;
    rc = build_meta(&probe, UINT64_MAX, UINT64_MAX, meta, sizeof meta, &meta_len);
    size_t cat_len = node->cat->json != NULL ? node->cat->json_len : 0;
    if (rc != UB_OK) return rc;
    *out = (uint64_t)UB_LOG_HEADER_COPIES * (UB_LOG_FILE_HEADER_LEN + meta_len + cat_len) + UB_LOG_RECORD_HEADER_LEN
           + UB_FRAME_MAX;
    return UB_OK;
}

int ub_log_open(ub_log_t *log, int fd, const ub_node_t *node, const char *node_name, bool record_tx,
                uint64_t start_unix_ms, uint64_t start_t_ms) {
    if (fd < 0) return UB_ERR_INVAL;
    int rc = prepare(log, node, node_name, record_tx, start_unix_ms, start_t_ms);
    if (rc != UB_OK) return rc;
    log->fd = fd;
    rc = write_header(log, start_t_ms);
    if (rc != UB_OK) {
        log->fd = -1;
        return rc;
    }
    log->stats.files = 1;
    log->open = 1;
    return UB_OK;
}

static void event(ub_log_t *log, ub_log_event_t ev, uint32_t index, const char *name) {
    if (log->event_fn != NULL) log->event_fn(log->event_user, ev, index, name);
}

/* Deletes the file that falls out of the max_files window when file `log->file_index` starts; the new
 * file's meta names it ("deleted_file") and the event hook hears of it: a deletion is never silent. */
static void delete_oldest(ub_log_t *log) {
    if (log->rot.max_files == 0 || log->file_index < log->rot.max_files) return;
    uint32_t index = log->file_index - log->rot.max_files;
    char name[UB_LOG_PATH_MAX];
    if (ub_log_file_name(log->path, index, name, sizeof name) != UB_OK) return;
    int saved = errno;
    if (unlink(name) == 0) {
        log->stats.files_deleted++;
        log->file_deleted = index;
        event(log, UB_LOG_EVENT_FILE_DELETED, index, name);
    } else if (errno != ENOENT) {
        log->stats.delete_errors++;
        log->stats.last_errno = errno;
        event(log, UB_LOG_EVENT_DELETE_FAILED, index, name);
    }
    errno = saved;
}

/* Opens file `log->file_index` and writes its header. On failure the log waits UB_LOG_REOPEN_MS (node
 * clock) before the next attempt, losing (and counting) the records meanwhile. */
static int start_file(ub_log_t *log, uint64_t t_ms) {
    char name[UB_LOG_PATH_MAX];
    if (ub_log_file_name(log->path, log->file_index, name, sizeof name) != UB_OK) return UB_ERR_NOSPACE;
    delete_oldest(log);
    if (log->fd < 0) {
        log->fd = open(name, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
        if (log->fd < 0) {
            log->stats.open_errors++;
            log->reopen_at_ms = t_ms + UB_LOG_REOPEN_MS;
            return UB_ERR_IO;
        }
        log->stats.files++;
        log->file_bytes = 0;
        log->file_first_seq = log->next_seq;
        log->need_header = 1;
        if (log->file_index > 0) event(log, UB_LOG_EVENT_FILE_STARTED, log->file_index, name);
    }
    if (write_header(log, t_ms) != UB_OK) {
        log->stats.open_errors++;
        log->reopen_at_ms = t_ms + UB_LOG_REOPEN_MS;
        return UB_ERR_IO;
    }
    return UB_OK;
}

int ub_log_open_path(ub_log_t *log, const char *path, const ub_log_rotation_t *rot, const ub_node_t *node,
                     const char *node_name, bool record_tx, uint64_t start_unix_ms, uint64_t start_t_ms) {
    if (path == NULL) return UB_ERR_INVAL;
    int rc = prepare(log, node, node_name, record_tx, start_unix_ms, start_t_ms);
    if (rc != UB_OK) return rc;
    /* Every later file name must fit too: check the longest index now, not at a rotation. */
    char longest[UB_LOG_PATH_MAX];
    if (strlen(path) >= sizeof log->path || ub_log_file_name(path, UINT32_MAX, longest, sizeof longest) != UB_OK)
        return UB_ERR_NOSPACE;
    memcpy(log->path, path, strlen(path) + 1);
    if (rot != NULL) log->rot = *rot;
    if (log->rot.max_bytes != 0) {
        uint64_t min_bytes = 0;
        rc = ub_log_rotation_floor(node, node_name, &min_bytes);
        if (rc != UB_OK) return rc;
        if (log->rot.max_bytes < min_bytes) return UB_ERR_RANGE; /* a file per record otherwise */
    }
    log->owns_fd = 1;
    rc = start_file(log, start_t_ms);
    if (rc != UB_OK) {
        int saved = errno;
        if (log->fd >= 0) close(log->fd);
        log->fd = -1;
        errno = saved;
        return rc;
    }
    log->open = 1;
    return UB_OK;
}

void ub_log_set_event_fn(ub_log_t *log, ub_log_event_fn fn, void *user) {
    if (log == NULL) return;
    log->event_fn = fn;
    log->event_user = user;
}

void ub_log_set_write_fn(ub_log_t *log, ub_log_write_fn fn, void *user) {
    if (log == NULL) return;
    log->write_fn = fn;
    log->write_user = user;
}

/* Closes the current file and starts the next one of the set. */
static int rotate(ub_log_t *log, uint64_t t_ms) {
    if (log->fd >= 0) close(log->fd);
    log->fd = -1;
    log->file_index++;
    log->file_deleted = -1;
    return start_file(log, t_ms);
}

static bool rotation_due(const ub_log_t *log, size_t total, uint64_t t_ms) {
    if (!log->owns_fd || log->fd < 0 || log->need_header || log->next_seq == log->file_first_seq) return false;
    if (log->rot.max_bytes != 0 && log->file_bytes + total > log->rot.max_bytes) return true;
    return log->rot.max_ms != 0 && t_ms >= log->file_start_t_ms && t_ms - log->file_start_t_ms >= log->rot.max_ms;
}

/* Gets the current file ready for a record: rotation when due, a file that failed to open, a header that
 * failed to write. @return UB_OK, or UB_ERR_IO (errno set) when the record cannot be written now. */
static int ready_for_record(ub_log_t *log, size_t total, uint64_t t_ms) {
    if (rotation_due(log, total, t_ms)) return rotate(log, t_ms);
    if (log->fd < 0 || log->need_header) {
        if (!log->owns_fd || t_ms < log->reopen_at_ms) {
            errno = log->stats.last_errno != 0 ? log->stats.last_errno : EIO;
            return UB_ERR_IO;
        }
        return start_file(log, t_ms);
    }
    return UB_OK;
}

static int record_lost(ub_log_t *log, int err) {
    log->next_seq++;
    log->stats.write_errors++;
    log->stats.last_errno = err != 0 ? err : EIO;
    log->failing = 1;
    return UB_ERR_IO;
}

int ub_log_write(ub_log_t *log, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len, uint64_t t_ms) {
    if (log == NULL || !log->open || frame == NULL || len == 0 || len > UB_FRAME_MAX || link_id < 0
        || link_id > 255 || (dir != UB_TAP_RX && dir != UB_TAP_TX))
        return UB_ERR_INVAL;
    size_t total = UB_LOG_RECORD_HEADER_LEN + len;
    uint32_t seq = log->next_seq; /* taken whether or not the record is written: a gap tells readers */
    if (ready_for_record(log, total, t_ms) != UB_OK) return record_lost(log, errno);
    uint8_t *r = log->rec;
    ub_put_u16le(r, UB_LOG_RECORD_MARKER);
    ub_put_u16le(r + 2, (uint16_t)len);
    ub_put_u32le(r + 4, seq);
    ub_put_u64le(r + 8, t_ms);
    ub_put_u8(r + 16, (uint8_t)link_id);
    ub_put_u8(r + 17, (uint8_t)dir);
    ub_put_u16le(r + 18, 0);
    uint32_t head_crc = ub_crc32c(r, UB_LOG_RECORD_HEAD_SPAN);
    ub_put_u32le(r + 20, head_crc);
    ub_put_u32le(r + 24, ub_crc32c_update(head_crc, frame, len));
    memcpy(r + UB_LOG_RECORD_HEADER_LEN, frame, len);
    /* One write() per record: it reaches the OS at once and is never interleaved with another. */
    size_t written = write_all(log, r, total);
    if (written != total) {
        int err = errno;
        cut_back(log, written);
        /* A file-size limit (RLIMIT_FSIZE, with SIGXFSZ ignored) is per file: the next file takes the record
         * (unless this file holds no record yet: then the limit is below one header and a record). */
        bool first_in_file = log->file_first_seq == seq;
        if (err != EFBIG || !log->owns_fd || first_in_file) return record_lost(log, err);
        log->stats.limit_rotations++;
        if (rotate(log, t_ms) != UB_OK) return record_lost(log, errno);
        written = write_all(log, r, total);
        if (written != total) {
            err = errno;
            cut_back(log, written);
            return record_lost(log, err);
        }
    }
    log->next_seq++;
    if (log->failing) {
        log->stats.recoveries++;
        log->failing = 0;
    }
    log->stats.records++;
    log->stats.bytes += total;
    log->file_bytes += total;
    return UB_OK;
}

void ub_log_tap(void *user, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len, uint64_t now_ms) {
    ub_log_t *log = user;
    if (log == NULL) return;
    if (dir == UB_TAP_TX && !log->record_tx) {
        log->stats.skipped_tx++;
        return;
    }
    if (ub_log_write(log, link_id, dir, frame, len, now_ms) == UB_ERR_INVAL) log->stats.write_errors++;
}

const ub_log_stats_t *ub_log_stats(const ub_log_t *log) { return log != NULL ? &log->stats : NULL; }

uint32_t ub_log_file_index(const ub_log_t *log) { return log != NULL ? log->file_index : 0; }

void ub_log_close(ub_log_t *log) {
    if (log == NULL) return;
    if (log->owns_fd && log->fd >= 0) close(log->fd);
    log->fd = -1;
    log->open = 0;
}

/* ---- reading ----------------------------------------------------------------------------------------- */

/* Version 1 and 2: one copy, no check of its own on the fixed part. */
static int parse_v2(const uint8_t *buf, size_t len, uint8_t version, ub_log_header_t *hdr) {
    if (len < UB_LOG_V2_FILE_HEADER_LEN) return UB_ERR_TRUNCATED;
    uint64_t meta_len = ub_get_u32le(buf + 8);
    uint64_t cat_len = ub_get_u32le(buf + 12);
    if (UB_LOG_V2_FILE_HEADER_LEN + meta_len + cat_len > len) return UB_ERR_TRUNCATED;
    const uint8_t *meta = buf + UB_LOG_V2_FILE_HEADER_LEN;
    uint32_t crc = ub_crc32c_update(ub_crc32c(meta, (size_t)meta_len), meta + meta_len, (size_t)cat_len);
    hdr->version = version;
    if (crc != ub_get_u32le(buf + 16)) {
        hdr->damaged = UB_LOG_COPY_PRIMARY;
        return UB_ERR_CHECKSUM; /* the lengths are not to be trusted: where records start is unknown */
    }
    hdr->meta = (const char *)meta;
    hdr->meta_len = (uint32_t)meta_len;
    hdr->catalogue = (const char *)(meta + meta_len);
    hdr->catalogue_len = (uint32_t)cat_len;
    hdr->size = UB_LOG_V2_FILE_HEADER_LEN + (size_t)meta_len + (size_t)cat_len;
    return UB_OK;
}

/* Whether the fixed part of a version 3 copy at `p` (UB_LOG_FILE_HEADER_LEN bytes there) holds. */
static bool v3_fixed_ok(const uint8_t *p) {
    return memcmp(p, UB_LOG_MAGIC, UB_LOG_MAGIC_LEN) == 0
           && ub_crc32c(p, UB_LOG_FILE_HEAD_SPAN) == ub_get_u32le(p + UB_LOG_FILE_HEAD_SPAN);
}

/* The spare copy of a file whose primary's fixed part is damaged: the first position after the primary's
 * fixed part where a sound fixed part says the copy before it is exactly as long (the copies are equal).
 * @return its offset, or 0 when none is in buf. */
static size_t find_spare(const uint8_t *buf, size_t len) {
    size_t from = UB_LOG_FILE_HEADER_LEN;
    while (from + UB_LOG_FILE_HEADER_LEN <= len) {
        const uint8_t *hit = memchr(buf + from, UB_LOG_MAGIC[0], len - from - UB_LOG_FILE_HEADER_LEN + 1);
        if (hit == NULL) return 0;
        size_t at = (size_t)(hit - buf);
        if (v3_fixed_ok(hit)) {
            uint64_t copy = UB_LOG_FILE_HEADER_LEN + (uint64_t)ub_get_u32le(hit + 8) + ub_get_u32le(hit + 12);
            if (copy == at) return at;
        }
        from = at + 1;
    }
    return 0;
}

/* Where the two copies of a version 3 header are: `*fixed` is a sound fixed part (the primary's, else the
 * spare's), `*spare` the spare's offset. @return UB_OK, UB_ERR_TRUNCATED or UB_ERR_CHECKSUM (no sound fixed
 * part: *spare 0). Sets UB_LOG_COPY_* in *damaged for a fixed part that does not hold. */
static int locate_v3(const uint8_t *buf, size_t len, const uint8_t **fixed, size_t *spare, uint8_t *damaged) {
    *spare = 0;
    if (len < UB_LOG_FILE_HEADER_LEN) return UB_ERR_TRUNCATED;
    if (v3_fixed_ok(buf)) {
        *fixed = buf;
        *spare = UB_LOG_FILE_HEADER_LEN + (size_t)ub_get_u32le(buf + 8) + (size_t)ub_get_u32le(buf + 12);
        if ((uint64_t)*spare * UB_LOG_HEADER_COPIES > len) return UB_ERR_TRUNCATED;
        if (memcmp(buf + *spare, buf, UB_LOG_FILE_HEADER_LEN) != 0) *damaged |= UB_LOG_COPY_SPARE;
        return UB_OK;
    }
    *damaged |= UB_LOG_COPY_PRIMARY;
    *spare = find_spare(buf, len);
    if (*spare == 0) return UB_ERR_CHECKSUM;
    *fixed = buf + *spare;
    return *spare * UB_LOG_HEADER_COPIES > len ? UB_ERR_TRUNCATED : UB_OK;
}

/* Version 3: two equal copies; each copy's meta and catalogue are checked against the CRC of the sound fixed
 * part, the primary's first. */
static int parse_v3(const uint8_t *buf, size_t len, ub_log_header_t *hdr) {
    hdr->version = 3;
    const uint8_t *fixed = NULL;
    size_t spare = 0;
    int rc = locate_v3(buf, len, &fixed, &spare, &hdr->damaged);
    if (rc != UB_OK) return rc; /* CHECKSUM: size 0, records are searched for from the start */
    hdr->size = spare * UB_LOG_HEADER_COPIES;
    size_t meta_len = ub_get_u32le(fixed + 8), cat_len = ub_get_u32le(fixed + 12);
    uint32_t want = ub_get_u32le(fixed + 16);
    const uint8_t *found = NULL;
    for (unsigned copy = 0; copy < UB_LOG_HEADER_COPIES; copy++) {
        const uint8_t *meta = buf + copy * spare + UB_LOG_FILE_HEADER_LEN;
        if (ub_crc32c_update(ub_crc32c(meta, meta_len), meta + meta_len, cat_len) == want) {
            if (found == NULL) found = meta;
        } else {
            hdr->damaged |= copy == 0 ? UB_LOG_COPY_PRIMARY : UB_LOG_COPY_SPARE;
        }
    }
    if (found == NULL) return UB_ERR_CHECKSUM;
    hdr->meta = (const char *)found;
    hdr->meta_len = (uint32_t)meta_len;
    hdr->catalogue = (const char *)(found + meta_len);
    hdr->catalogue_len = (uint32_t)cat_len;
    return UB_OK;
}

int ub_log_header_repair(uint8_t *buf, size_t len) {
    if (buf == NULL) return UB_ERR_INVAL;
    if (len < UB_LOG_MAGIC_LEN || (memcmp(buf, UB_LOG_MAGIC, UB_LOG_MAGIC_LEN) != 0 && find_spare(buf, len) == 0))
        return UB_ERR_INVAL; /* versions 1 and 2 have one copy: nothing to repair from */
    const uint8_t *fixed = NULL;
    size_t spare = 0;
    uint8_t damaged = 0;
    int rc = locate_v3(buf, len, &fixed, &spare, &damaged);
    if (rc != UB_OK) return rc;
    size_t n = (size_t)ub_get_u32le(fixed + 8) + ub_get_u32le(fixed + 12);
    uint32_t want = ub_get_u32le(fixed + 16);
    uint8_t *a = buf + UB_LOG_FILE_HEADER_LEN;
    const uint8_t *b = buf + spare + UB_LOG_FILE_HEADER_LEN;
    /* One region over the end of the primary and the start of the spare damages the primary's bytes from
     * some x on and the spare's up to some y < x: between the two the copies agree. The longest stretch where
     * they agree is taken as that middle; the primary up to its start and the spare from there on must then
     * match the CRC. (A region inside one copy leaves the other whole: parse needs no repair then.) */
    size_t best = 0, best_len = 0, run = 0;
    for (size_t i = 0; i <= n; i++) {
        if (i < n && a[i] == b[i]) {
            run++;
            continue;
        }
        if (run > best_len) {
            best_len = run;
            best = i - run;
        }
        run = 0;
    }
    if (ub_crc32c_update(ub_crc32c(a, best), b + best, n - best) != want) return UB_ERR_CHECKSUM;
    memcpy(a + best, b + best, n - best);
    if (fixed != buf) memcpy(buf, fixed, UB_LOG_FILE_HEADER_LEN);
    return UB_OK;
}

int ub_log_header_parse(const uint8_t *buf, size_t len, ub_log_header_t *hdr) {
    if (buf == NULL && len > 0) return UB_ERR_INVAL;
    ub_log_header_t h;
    memset(&h, 0, sizeof h);
    size_t prefix = len < UB_LOG_MAGIC_LEN ? len : UB_LOG_MAGIC_LEN;
    int rc;
    if (memcmp(buf, UB_LOG_MAGIC, prefix) == 0) {
        rc = parse_v3(buf, len, &h);
    } else if (memcmp(buf, UB_LOG_MAGIC_V2, prefix) == 0) {
        rc = parse_v2(buf, len, 2, &h);
    } else if (memcmp(buf, UB_LOG_MAGIC_V1, prefix) == 0) {
        rc = parse_v2(buf, len, 1, &h);
    } else if (len >= UB_LOG_FILE_HEADER_LEN && find_spare(buf, len) != 0) {
        rc = parse_v3(buf, len, &h); /* the primary's magic is damaged; its spare says this is a log */
    } else {
        return UB_ERR_INVAL;
    }
    if (hdr != NULL && (rc == UB_OK || rc == UB_ERR_CHECKSUM)) *hdr = h;
    return rc;
}

void ub_log_reader_begin(ub_log_reader_t *rd, uint8_t version) {
    if (rd == NULL) return;
    memset(rd, 0, sizeof *rd);
    rd->version = version;
}

void ub_log_reader_data(ub_log_reader_t *rd, const uint8_t *buf, size_t len, bool final) {
    if (rd == NULL) return;
    rd->buf = buf;
    rd->len = buf != NULL ? len : 0;
    rd->pos = 0;
    rd->final = final ? 1 : 0;
}

int ub_log_reader_init(ub_log_reader_t *rd, const uint8_t *buf, size_t len, ub_log_header_t *hdr) {
    if (rd == NULL) return UB_ERR_INVAL;
    ub_log_header_t h;
    memset(&h, 0, sizeof h);
    memset(rd, 0, sizeof *rd);
    int rc = ub_log_header_parse(buf, len, &h);
    if (hdr != NULL && (rc == UB_OK || rc == UB_ERR_CHECKSUM)) *hdr = h; /* where records start, if known */
    if (rc != UB_OK) return rc;
    ub_log_reader_begin(rd, h.version);
    ub_log_reader_data(rd, buf, len, true);
    rd->pos = h.size;
    return UB_OK;
}

/* What the bytes at `at` are. */
typedef enum verdict { REC_OK, REC_NEED_MORE, REC_BAD_HEAD, REC_BAD_BODY } verdict_t;

static size_t header_len(const ub_log_reader_t *rd) {
    return rd->version == 1 ? UB_LOG_V1_RECORD_HEADER_LEN : UB_LOG_RECORD_HEADER_LEN;
}

/* Judges a record candidate at `at`; on REC_OK and REC_BAD_BODY sets *frame_len. Version 2 trusts a
 * header once its own CRC holds (so a damaged frame costs that record only); version 1 has one CRC over
 * everything, so a failing candidate there can only be treated as a lost boundary. */
static verdict_t judge(const ub_log_reader_t *rd, size_t at, size_t *frame_len) {
    const uint8_t *r = rd->buf + at;
    size_t left = rd->len - at;
    size_t hl = header_len(rd);
    if (left < 2) return left == 1 && r[0] != (UB_LOG_RECORD_MARKER & 0xFF) ? REC_BAD_HEAD : REC_NEED_MORE;
    if (ub_get_u16le(r) != UB_LOG_RECORD_MARKER) return REC_BAD_HEAD;
    if (left < hl) return REC_NEED_MORE;
    size_t flen = ub_get_u16le(r + 2);
    if (rd->version == 1) {
        if (flen == 0 || flen > UB_FRAME_MAX) return REC_BAD_HEAD;
        if (left < hl + flen) return REC_NEED_MORE;
        uint32_t crc = ub_crc32c_update(ub_crc32c(r, 16), r + hl, flen);
        if (crc != ub_get_u32le(r + 16)) return REC_BAD_HEAD;
        *frame_len = flen;
        return REC_OK;
    }
    uint32_t head_crc = ub_crc32c(r, UB_LOG_RECORD_HEAD_SPAN);
    if (head_crc != ub_get_u32le(r + 20) || flen == 0 || flen > UB_FRAME_MAX) return REC_BAD_HEAD;
    *frame_len = flen;
    if (left < hl + flen) return REC_NEED_MORE;
    if (ub_crc32c_update(head_crc, r + hl, flen) != ub_get_u32le(r + 24)) return REC_BAD_BODY;
    return REC_OK;
}

static void skip(ub_log_reader_t *rd, size_t n) {
    rd->pos += n;
    rd->stats.skipped_bytes += n;
}

/* Lost the boundary at rd->pos: skips to the next place a record marker could start (a lone first marker
 * byte at the very end of a window that is not final may be one). */
static void search(ub_log_reader_t *rd) {
    size_t from = rd->pos + 1;
    size_t at = rd->len;
    while (from < rd->len) {
        const uint8_t *hit = memchr(rd->buf + from, UB_LOG_RECORD_MARKER & 0xFF, rd->len - from);
        if (hit == NULL) break;
        size_t k = (size_t)(hit - rd->buf);
        if (k + 1 == rd->len || rd->buf[k + 1] == (UB_LOG_RECORD_MARKER >> 8)) {
            at = k;
            break;
        }
        from = k + 1;
    }
    skip(rd, at - rd->pos);
}

static void deliver(ub_log_reader_t *rd, size_t frame_len, ub_log_record_t *rec) {
    const uint8_t *r = rd->buf + rd->pos;
    size_t hl = header_len(rd);
    uint32_t seq;
    if (rd->version == 1) {
        rec->t_ms = ub_get_u64le(r + 4);
        rec->link_id = ub_get_u8(r + 12);
        rec->dir = ub_get_u8(r + 13);
        seq = rd->next_seq;
    } else {
        seq = ub_get_u32le(r + 4);
        rec->t_ms = ub_get_u64le(r + 8);
        rec->link_id = ub_get_u8(r + 16);
        rec->dir = ub_get_u8(r + 17);
    }
    if (rd->have_seq && seq != rd->next_seq) {
        uint32_t ahead = seq - rd->next_seq; /* serial arithmetic: the writer's counter may wrap */
        if (ahead < 0x80000000u) rd->stats.missing_records += ahead;
        else rd->stats.seq_restarts++;
    }
    rd->have_seq = 1;
    rd->next_seq = seq + 1;
    rec->seq = seq;
    rec->frame = r + hl;
    rec->len = (uint16_t)frame_len;
    rec->offset = rd->pos;
    rd->pos += hl + frame_len;
    rd->stats.records++;
    rd->stats.record_bytes += hl + frame_len;
    if (rd->lost == 2) rd->stats.resyncs++; /* a cut-looking record turned out to be damage: records follow */
    rd->lost = 0;
}

int ub_log_reader_next(ub_log_reader_t *rd, ub_log_record_t *rec) {
    if (rd == NULL || rec == NULL || rd->buf == NULL) return 0;
    while (rd->pos < rd->len) {
        size_t flen = 0;
        verdict_t v = judge(rd, rd->pos, &flen);
        if (v == REC_OK) {
            deliver(rd, flen, rec);
            return 1;
        }
        if (v == REC_NEED_MORE) {
            if (!rd->final) return 0;
            /* The file ends inside this candidate. If no record follows, it is a cut tail; if one does,
             * the candidate was damage (lost == 2 counts the resync when that record appears). */
            if (rd->lost == 0) {
                rd->lost = 2;
                rd->tail_at = rd->pos;
            }
            search(rd);
            continue;
        }
        if (v == REC_BAD_BODY) {
            size_t end = rd->pos + header_len(rd) + flen;
            size_t next_len = 0;
            /* Only the frame was damaged when a record header follows it (or the file ends there). That is
             * decided only once the bytes after it are here, so chunking never changes what is read. */
            verdict_t after = end < rd->len || !rd->final ? judge(rd, end, &next_len) : REC_OK;
            if (after == REC_NEED_MORE && !rd->final) return 0;
            rd->stats.damaged_records++;
            if (after == REC_OK || after == REC_BAD_BODY) {
                if (rd->lost == 2) rd->stats.resyncs++;
                rd->lost = 0;
                skip(rd, end - rd->pos);
                continue;
            }
            /* Bytes were deleted or inserted inside it: the boundary is lost after its sound header and
             * head_crc (a record can start right after those when a deletion ran up to it). */
            skip(rd, UB_LOG_RECORD_HEAD_SPAN + 4 - 1);
            if (rd->lost != 1) rd->stats.resyncs++;
            rd->lost = 1;
            search(rd);
            continue;
        }
        /* No record here. Inside what looks like a cut tail (lost == 2) false markers change nothing. */
        if (rd->lost == 0) {
            rd->stats.resyncs++;
            rd->lost = 1;
        }
        search(rd);
    }
    if (rd->lost == 2 && rd->final) {
        rd->stats.truncated_bytes += rd->len - rd->tail_at;
        rd->lost = 1;
    }
    return 0;
}

size_t ub_log_reader_consumed(const ub_log_reader_t *rd) { return rd != NULL ? rd->pos : 0; }

void ub_log_reader_expect_seq(ub_log_reader_t *rd, uint32_t seq) {
    if (rd == NULL) return;
    rd->have_seq = 1;
    rd->next_seq = seq;
}

const ub_log_reader_stats_t *ub_log_reader_stats(const ub_log_reader_t *rd) { return rd != NULL ? &rd->stats : NULL; }

size_t ub_log_reader_ignored(const ub_log_reader_t *rd) { return rd != NULL ? (size_t)rd->stats.skipped_bytes : 0; }
