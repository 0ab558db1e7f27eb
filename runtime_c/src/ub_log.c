/* Binary frame log writer and reader (ub_log.h, docs/log-format.md). */
#include "ub/ub_log.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "ub/ub_wire.h"

/* Writes all of buf, retrying short writes and EINTR (a regular file can return short on a signal). */
static int write_all(int fd, const uint8_t *buf, size_t len) {
    while (len > 0) {
        ssize_t n = write(fd, buf, len);
        if (n < 0) {
            if (errno == EINTR) continue;
            return UB_ERR_IO;
        }
        if (n == 0) {
            errno = EIO;
            return UB_ERR_IO;
        }
        buf += n;
        len -= (size_t)n;
    }
    return UB_OK;
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

static bool put_text(char *out, size_t cap, size_t *pos, const char *fmt_result) {
    size_t n = strlen(fmt_result);
    if (*pos + n + 1 > cap) return false;
    memcpy(out + *pos, fmt_result, n + 1);
    *pos += n;
    return true;
}

/* meta: {"format":1,"node":"..","links":{"0":"name",...},"start_unix_ms":N,"start_t_ms":N,"record_tx":b} */
static int build_meta(char *out, size_t cap, const ub_node_t *node, const char *node_name, bool record_tx,
                      uint64_t start_unix_ms, uint64_t start_t_ms, size_t *len) {
    size_t pos = 0;
    char tmp[96];
    bool ok = put_text(out, cap, &pos, "{\"format\":1,\"node\":") && put_json_string(out, cap, &pos, node_name)
              && put_text(out, cap, &pos, ",\"links\":{");
    bool first = true;
    for (int id = 0; ok && id < UB_MAX_NODE_LINKS; id++) {
        const ub_link_t *link = ub_node_link(node, id);
        if (link == NULL) continue;
        snprintf(tmp, sizeof tmp, "%s\"%d\":", first ? "" : ",", id);
        ok = put_text(out, cap, &pos, tmp) && put_json_string(out, cap, &pos, link->name);
        first = false;
    }
    snprintf(tmp, sizeof tmp, "},\"start_unix_ms\":%llu,\"start_t_ms\":%llu,\"record_tx\":%s}",
             (unsigned long long)start_unix_ms, (unsigned long long)start_t_ms, record_tx ? "true" : "false");
    ok = ok && put_text(out, cap, &pos, tmp);
    if (!ok) return UB_ERR_NOSPACE;
    *len = pos;
    return UB_OK;
}

int ub_log_open(ub_log_t *log, int fd, const ub_node_t *node, const char *node_name, bool record_tx,
                uint64_t start_unix_ms, uint64_t start_t_ms) {
    if (log == NULL || fd < 0 || node == NULL || node_name == NULL || node->cat == NULL) return UB_ERR_INVAL;
    memset(log, 0, sizeof *log);
    log->fd = -1;
    /* Header and meta are written with one write(); the catalogue (tens of kB) follows. */
    uint8_t head[UB_LOG_FILE_HEADER_LEN + UB_LOG_META_MAX];
    size_t meta_len = 0;
    int rc = build_meta((char *)head + UB_LOG_FILE_HEADER_LEN, UB_LOG_META_MAX, node, node_name, record_tx,
                        start_unix_ms, start_t_ms, &meta_len);
    if (rc != UB_OK) return rc;
    const uint8_t *cat = (const uint8_t *)node->cat->json;
    size_t cat_len = cat != NULL ? node->cat->json_len : 0;
    if (cat_len > UINT32_MAX) return UB_ERR_RANGE;
    memcpy(head, UB_LOG_MAGIC, UB_LOG_MAGIC_LEN);
    ub_put_u32le(head + 8, (uint32_t)meta_len);
    ub_put_u32le(head + 12, (uint32_t)cat_len);
    uint32_t crc = ub_crc32c(head + UB_LOG_FILE_HEADER_LEN, meta_len);
    crc = ub_crc32c_update(crc, cat, cat_len);
    ub_put_u32le(head + 16, crc);
    if (write_all(fd, head, UB_LOG_FILE_HEADER_LEN + meta_len) != UB_OK) return UB_ERR_IO;
    if (cat_len > 0 && write_all(fd, cat, cat_len) != UB_OK) return UB_ERR_IO;
    log->fd = fd;
    log->record_tx = record_tx ? 1 : 0;
    log->stats.bytes = UB_LOG_FILE_HEADER_LEN + meta_len + cat_len;
    return UB_OK;
}

int ub_log_write(ub_log_t *log, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len, uint64_t t_ms) {
    if (log == NULL || log->fd < 0 || frame == NULL || len == 0 || len > UB_FRAME_MAX || link_id < 0
        || link_id > 255 || (dir != UB_TAP_RX && dir != UB_TAP_TX))
        return UB_ERR_INVAL;
    uint8_t *r = log->rec;
    ub_put_u16le(r, UB_LOG_RECORD_MARKER);
    ub_put_u16le(r + 2, (uint16_t)len);
    ub_put_u64le(r + 4, t_ms);
    ub_put_u8(r + 12, (uint8_t)link_id);
    ub_put_u8(r + 13, (uint8_t)dir);
    ub_put_u16le(r + 14, 0);
    uint32_t crc = ub_crc32c_update(ub_crc32c(r, UB_LOG_RECORD_CRC_SPAN), frame, len);
    ub_put_u32le(r + 16, crc);
    memcpy(r + UB_LOG_RECORD_HEADER_LEN, frame, len);
    size_t total = UB_LOG_RECORD_HEADER_LEN + len;
    /* One write() per record: a record is either in the file whole or cut at the tail, never interleaved. */
    ssize_t n;
    do {
        n = write(log->fd, r, total);
    } while (n < 0 && errno == EINTR);
    if (n != (ssize_t)total) {
        log->stats.write_errors++;
        log->stats.last_errno = n < 0 ? errno : EIO;
        if (n > 0) log->stats.bytes += (uint64_t)n; /* a short record: readers stop before it */
        return UB_ERR_IO;
    }
    log->stats.records++;
    log->stats.bytes += total;
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

void ub_log_close(ub_log_t *log) {
    if (log != NULL) log->fd = -1;
}

/* ---- reader ----------------------------------------------------------------------------------------- */

int ub_log_reader_init(ub_log_reader_t *rd, const uint8_t *buf, size_t len, ub_log_header_t *hdr) {
    if (rd == NULL || (buf == NULL && len > 0)) return UB_ERR_INVAL;
    memset(rd, 0, sizeof *rd);
    if (len < UB_LOG_FILE_HEADER_LEN) return UB_ERR_TRUNCATED;
    if (memcmp(buf, UB_LOG_MAGIC, UB_LOG_MAGIC_LEN) != 0) return UB_ERR_CHECKSUM;
    uint64_t meta_len = ub_get_u32le(buf + 8);
    uint64_t cat_len = ub_get_u32le(buf + 12);
    if (UB_LOG_FILE_HEADER_LEN + meta_len + cat_len > len) return UB_ERR_TRUNCATED;
    const uint8_t *meta = buf + UB_LOG_FILE_HEADER_LEN;
    uint32_t crc = ub_crc32c_update(ub_crc32c(meta, (size_t)meta_len), meta + meta_len, (size_t)cat_len);
    if (crc != ub_get_u32le(buf + 16)) return UB_ERR_CHECKSUM;
    if (hdr != NULL) {
        hdr->meta = (const char *)meta;
        hdr->meta_len = (uint32_t)meta_len;
        hdr->catalogue = (const char *)(meta + meta_len);
        hdr->catalogue_len = (uint32_t)cat_len;
    }
    rd->buf = buf;
    rd->len = len;
    rd->pos = UB_LOG_FILE_HEADER_LEN + (size_t)meta_len + (size_t)cat_len;
    return UB_OK;
}

int ub_log_reader_next(ub_log_reader_t *rd, ub_log_record_t *rec) {
    if (rd == NULL || rec == NULL || rd->buf == NULL) return 0;
    size_t left = rd->len - rd->pos;
    if (left < UB_LOG_RECORD_HEADER_LEN) return 0;
    const uint8_t *r = rd->buf + rd->pos;
    if (ub_get_u16le(r) != UB_LOG_RECORD_MARKER) return 0;
    size_t flen = ub_get_u16le(r + 2);
    if (flen == 0 || flen > UB_FRAME_MAX || left < UB_LOG_RECORD_HEADER_LEN + flen) return 0;
    uint32_t crc = ub_crc32c_update(ub_crc32c(r, UB_LOG_RECORD_CRC_SPAN), r + UB_LOG_RECORD_HEADER_LEN, flen);
    if (crc != ub_get_u32le(r + 16)) return 0;
    rec->t_ms = ub_get_u64le(r + 4);
    rec->link_id = ub_get_u8(r + 12);
    rec->dir = ub_get_u8(r + 13);
    rec->frame = r + UB_LOG_RECORD_HEADER_LEN;
    rec->len = (uint16_t)flen;
    rd->pos += UB_LOG_RECORD_HEADER_LEN + flen;
    return 1;
}

size_t ub_log_reader_ignored(const ub_log_reader_t *rd) { return rd != NULL ? rd->len - rd->pos : 0; }
