/*
 * Fuzz harness: the binary log reader (ub_log.h) on damaged and hostile files (issue #17 item 6).
 *
 * Input: byte 0 is a mode, the rest a file. Mode bit 0 clear: the harness writes a valid file header
 * itself (format 3, format 1 with bit 1, format 2 with bit 3) and the rest is the records, so the fuzzer
 * works on records rather than on the header CRC; with bit 2 it also reseals every record it finds (marker,
 * head_crc and crc recomputed at each boundary) so sequences, lengths and links of valid records get
 * explored. Bit 0 set: the rest is the whole file, header included; a header with no whole copy is given to
 * ub_log_header_repair(), whose success must make it parse.
 *
 * Properties: no crash or memory error; every record returned lies inside the file, after the previous
 * one, with a length in range; every byte is accounted for (header + record bytes + skipped bytes = file
 * size); and reading the same file in pieces (chunk sizes from the mode's upper bits), as `follow` does,
 * gives the same records and the same counters.
 */
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_util.h"
#include "ub/ub_log.h"
#include "ub/ub_wire.h"

#define MAX_RECORDS 4096

static uint8_t g_file[1 << 20];
static ub_log_record_t g_recs[MAX_RECORDS];

int LLVMFuzzerInitialize(int *argc, char ***argv) {
    (void)argc;
    (void)argv;
    return 0;
}

static size_t write_header(uint8_t *out, int version) {
    static const char meta[] = "{\"format\":3,\"node\":\"fuzz\",\"links\":{\"0\":\"a\",\"1\":\"b\"},\"start_unix_ms\":0,"
                               "\"start_t_ms\":0,\"record_tx\":true,\"file_index\":0,\"first_seq\":0}";
    static const char cat[] = "{\"name\":\"fuzz\",\"types\":[],\"instances\":[]}";
    size_t ml = sizeof meta - 1, cl = sizeof cat - 1;
    size_t fixed = version == 3 ? UB_LOG_FILE_HEADER_LEN : UB_LOG_V2_FILE_HEADER_LEN;
    memcpy(out, version == 1 ? UB_LOG_MAGIC_V1 : version == 2 ? UB_LOG_MAGIC_V2 : UB_LOG_MAGIC, UB_LOG_MAGIC_LEN);
    ub_put_u32le(out + 8, (uint32_t)ml);
    ub_put_u32le(out + 12, (uint32_t)cl);
    memcpy(out + fixed, meta, ml);
    memcpy(out + fixed + ml, cat, cl);
    ub_put_u32le(out + 16, ub_crc32c(out + fixed, ml + cl));
    if (version != 3) return fixed + ml + cl;
    ub_put_u32le(out + UB_LOG_FILE_HEAD_SPAN, ub_crc32c(out, UB_LOG_FILE_HEAD_SPAN));
    size_t copy = fixed + ml + cl;
    memcpy(out + copy, out, copy); /* the spare */
    return UB_LOG_HEADER_COPIES * copy;
}

/* Recomputes the checks of every record found by walking `body` from its start. */
static void reseal(uint8_t *body, size_t n, int version) {
    size_t hl = version == 1 ? UB_LOG_V1_RECORD_HEADER_LEN : UB_LOG_RECORD_HEADER_LEN;
    size_t pos = 0;
    while (pos + hl <= n) {
        size_t flen = ub_get_u16le(body + pos + 2);
        if (ub_get_u16le(body + pos) != UB_LOG_RECORD_MARKER || flen == 0 || flen > UB_FRAME_MAX
            || pos + hl + flen > n) {
            pos++;
            continue;
        }
        uint8_t *r = body + pos;
        if (version == 1) {
            ub_put_u32le(r + 16, ub_crc32c_update(ub_crc32c(r, 16), r + hl, flen));
        } else {
            uint32_t head = ub_crc32c(r, UB_LOG_RECORD_HEAD_SPAN);
            ub_put_u32le(r + 20, head);
            ub_put_u32le(r + 24, ub_crc32c_update(head, r + hl, flen));
        }
        pos += hl + flen;
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size == 0) return 0;
    uint8_t mode = data[0];
    data++;
    size--;
    size_t len = 0;
    if (mode & 1) {
        if (size > sizeof g_file) return 0;
        memcpy(g_file, data, size);
        len = size;
    } else {
        int version = mode & 2 ? 1 : mode & 8 ? 2 : 3;
        len = write_header(g_file, version);
        if (len + size > sizeof g_file) return 0;
        memcpy(g_file + len, data, size);
        if (mode & 4) reseal(g_file + len, size, version);
        len += size;
    }
    /* The exact bytes, so ASan catches a read one past the end. */
    uint8_t *file = malloc(len > 0 ? len : 1);
    FUZZ_CHECK(file != NULL, "malloc");
    memcpy(file, g_file, len);

    ub_log_reader_t rd;
    ub_log_header_t hdr;
    int rc = ub_log_reader_init(&rd, file, len, &hdr);
    if (rc == UB_ERR_CHECKSUM) {
        FUZZ_CHECK(hdr.size <= len, "lost header's size %zu of %zu", hdr.size, len);
        if (ub_log_header_repair(file, len) == UB_OK) {
            rc = ub_log_reader_init(&rd, file, len, &hdr);
            FUZZ_CHECK(rc == UB_OK, "a repaired header does not parse (%d)", rc);
        }
    }
    if (rc != UB_OK) {
        free(file);
        return 0;
    }
    FUZZ_CHECK(hdr.size <= len && hdr.version >= 1 && hdr.version <= 3, "header size %zu of %zu", hdr.size, len);
    FUZZ_CHECK(hdr.meta >= (const char *)file && hdr.catalogue + hdr.catalogue_len <= (const char *)file + hdr.size,
               "meta and catalogue outside the header");
    size_t hl = hdr.version == 1 ? UB_LOG_V1_RECORD_HEADER_LEN : UB_LOG_RECORD_HEADER_LEN;
    size_t n = 0, end = hdr.size;
    uint64_t bytes = 0;
    ub_log_record_t rec;
    while (ub_log_reader_next(&rd, &rec) == 1) {
        FUZZ_CHECK(rec.len >= 1 && rec.len <= UB_FRAME_MAX, "record length %u", rec.len);
        FUZZ_CHECK(rec.offset >= end && rec.offset + hl + rec.len <= len, "record at %zu (+%u) outside %zu..%zu",
                   rec.offset, rec.len, end, len);
        FUZZ_CHECK(rec.frame == file + rec.offset + hl, "frame pointer");
        end = rec.offset + hl + rec.len;
        bytes += hl + rec.len;
        if (n < MAX_RECORDS) g_recs[n] = rec;
        n++;
    }
    const ub_log_reader_stats_t *st = ub_log_reader_stats(&rd);
    FUZZ_CHECK(st->records == n && st->record_bytes == bytes, "counters: %llu records", (unsigned long long)st->records);
    FUZZ_CHECK(hdr.size + st->record_bytes + st->skipped_bytes == len, "bytes: %zu + %llu + %llu != %zu", hdr.size,
               (unsigned long long)st->record_bytes, (unsigned long long)st->skipped_bytes, len);
    FUZZ_CHECK(st->truncated_bytes <= st->skipped_bytes, "truncated > skipped");
    ub_log_reader_stats_t whole = *st;

    /* The same body in pieces, as a follower reads a growing file. */
    ub_log_reader_t inc;
    ub_log_reader_begin(&inc, hdr.version);
    uint32_t rng = 0x9E3779B9u ^ mode;
    size_t base = hdr.size, fed = hdr.size, got = 0;
    for (;;) {
        rng = rng * 1664525u + 1013904223u;
        size_t step = 1 + (rng >> 8) % (mode & 0x80 ? 7u : 600u);
        fed = fed + step > len ? len : fed + step;
        ub_log_reader_data(&inc, file + base, fed - base, fed == len);
        while (ub_log_reader_next(&inc, &rec) == 1) {
            FUZZ_CHECK(got < n, "piecewise reading found more records");
            if (got < MAX_RECORDS) {
                FUZZ_CHECK(base + rec.offset == g_recs[got].offset && rec.len == g_recs[got].len
                               && rec.seq == g_recs[got].seq && rec.t_ms == g_recs[got].t_ms,
                           "record %zu differs when read in pieces", got);
            }
            got++;
        }
        base += ub_log_reader_consumed(&inc);
        if (fed == len) break;
    }
    FUZZ_CHECK(got == n && base == len, "piecewise: %zu records, %zu bytes decided (whole: %zu, %zu)", got, base, n, len);
    FUZZ_CHECK(memcmp(ub_log_reader_stats(&inc), &whole, sizeof whole) == 0, "piecewise counters differ");
    free(file);
    return 0;
}

/* Seeds: bodies of records as the writer lays them out, sound, damaged and cut, both formats. */
void ub_fuzz_write_seeds(const char *dir) {
    static uint8_t buf[1 + 8 * (UB_LOG_RECORD_HEADER_LEN + 200)];
    uint8_t frame[200];
    for (int version = 1; version <= 2; version++) {
        size_t hl = version == 1 ? UB_LOG_V1_RECORD_HEADER_LEN : UB_LOG_RECORD_HEADER_LEN;
        size_t n = 1;
        buf[0] = (uint8_t)(version == 1 ? 2 : 0);
        for (uint32_t i = 0; i < 8; i++) {
            size_t flen = 64 + 16 * i;
            ub_frame_header_t h = {.hop_limit = 1, .payload_size = (uint16_t)(flen - 64), .seq = i};
            memset(frame + 64, (int)i, flen - 64);
            fuzz_ignore(ub_frame_finish(frame, sizeof frame, &h));
            uint8_t *r = buf + n;
            ub_put_u16le(r, UB_LOG_RECORD_MARKER);
            ub_put_u16le(r + 2, (uint16_t)flen);
            if (version == 1) {
                ub_put_u64le(r + 4, 100u * i);
                r[12] = (uint8_t)(i & 1);
                r[13] = (uint8_t)(i >> 2 & 1);
                ub_put_u16le(r + 14, 0);
                memcpy(r + hl, frame, flen);
                ub_put_u32le(r + 16, ub_crc32c_update(ub_crc32c(r, 16), r + hl, flen));
            } else {
                ub_put_u32le(r + 4, i + (i > 4)); /* one record missing by its number */
                ub_put_u64le(r + 8, 100u * i);
                r[16] = (uint8_t)(i & 1);
                r[17] = (uint8_t)(i >> 2 & 1);
                ub_put_u16le(r + 18, 0);
                uint32_t head = ub_crc32c(r, UB_LOG_RECORD_HEAD_SPAN);
                ub_put_u32le(r + 20, head);
                memcpy(r + hl, frame, flen);
                ub_put_u32le(r + 24, ub_crc32c_update(head, r + hl, flen));
            }
            n += hl + flen;
        }
        char name[32];
        snprintf(name, sizeof name, "v%d_sound", version);
        fuzz_write_seed(dir, name, buf, n);
        buf[n / 2] ^= 0x40; /* a flipped byte */
        snprintf(name, sizeof name, "v%d_flipped_and_cut", version);
        fuzz_write_seed(dir, name, buf, n - 7);
    }
}
