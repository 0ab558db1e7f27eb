/*
 * A damaged log loses only what was damaged (issue #17, item 1): a recorded log gets flips, deletions,
 * inserted garbage and a cut tail at seeded random places; the reader must give back every record the
 * damage did not touch, in order and byte for byte, nothing that was not written, and account for every
 * byte of the file (header + records read + bytes skipped).
 *
 * The same damage is applied to the same log converted to format version 1, which the reader still reads
 * (it resynchronises there too, with less to go on), and every damaged file is read a second time in
 * random chunks, as `uavbus log` follows a growing file: same records, same counters.
 *
 * Before the resynchronising reader (format 1, reading stopped at the first bad record) this test read
 * back 28,818 of 95,901 undamaged records (30 %).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "support/ub_test_world.h"
#include "test_frame_util.h"
#include "ub/ub_log.h"
#include "ub/ub_wire.h"

#define N_RECORDS 400u
#define TRIALS 2000u
#define SEED 0x106DA3A6Eu

static const char k_cat_json[] = "{\"name\":\"test\",\"types\":[],\"instances\":[]}";

typedef struct span {
    size_t off, len;
} span_t;

typedef struct recorded {
    int version;
    uint8_t *file;
    size_t len;
    size_t header_len;
    span_t rec[N_RECORDS]; /* where each record lies in the file */
    span_t frame[N_RECORDS];
} recorded_t;

static uint8_t *slurp(const char *path, size_t *len) {
    int fd = open(path, O_RDONLY);
    assert_true(fd >= 0);
    struct stat st;
    assert_int_equal(fstat(fd, &st), 0);
    uint8_t *buf = malloc((size_t)st.st_size + 1);
    assert_non_null(buf);
    assert_int_equal(read(fd, buf, (size_t)st.st_size), st.st_size);
    close(fd);
    *len = (size_t)st.st_size;
    return buf;
}

/* Records N_RECORDS random frames (random payload sizes, both directions, several links) with the writer,
 * the node's catalogue self-description being `cat_json`. */
static void record_log_with(recorded_t *r, const char *cat_json) {
    static ub_node_t node;
    static ub_catalogue_t cat;
    cat = ub_test_cat;
    cat.json = cat_json;
    cat.json_len = strlen(cat_json);
    assert_int_equal(ub_node_init(&node, &cat, NULL), UB_OK);
    uint8_t id[UB_ENTITY_ID_LEN];
    test_eid("uav", id);
    int e = ub_node_add_entity(&node, id, true);
    assert_true(e >= 0);
    assert_true(ub_node_add_link(&node, e, 0, "radio") >= 0);
    assert_true(ub_node_add_link(&node, e, 1, "ipc") >= 0);
    char path[64];
    snprintf(path, sizeof path, "/tmp/ub_test_log_damage_%ld.ublog", (long)getpid());
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0600);
    assert_true(fd >= 0);
    static ub_log_t log;
    assert_int_equal(ub_log_open(&log, fd, &node, "uav", true, 1700000000000ull, 0), UB_OK);
    test_rng_t rng = {SEED};
    uint8_t frame[UB_FRAME_MAX];
    for (uint32_t i = 0; i < N_RECORDS; i++) {
        uint16_t ps = (uint16_t)(rng_below(&rng, 8) == 0 ? rng_below(&rng, UB_MAX_PAYLOAD + 1) : rng_below(&rng, 90));
        size_t n = random_frame(&rng, frame, ps);
        assert_int_equal(ub_log_write(&log, (int)rng_below(&rng, 2), rng_below(&rng, 2) ? UB_TAP_TX : UB_TAP_RX,
                                      frame, n, 10u * i),
                         UB_OK);
    }
    ub_log_close(&log);
    close(fd);
    r->file = slurp(path, &r->len);
    unlink(path);
    /* Where the records are, from an undamaged read. */
    ub_log_reader_t rd;
    ub_log_header_t hdr;
    assert_int_equal(ub_log_reader_init(&rd, r->file, r->len, &hdr), UB_OK);
    assert_int_equal(hdr.damaged, 0);
    r->header_len = hdr.size; /* both copies of the header */
    ub_log_record_t rec;
    size_t end = r->header_len;
    for (uint32_t i = 0; i < N_RECORDS; i++) {
        assert_int_equal(ub_log_reader_next(&rd, &rec), 1);
        r->frame[i] = (span_t){(size_t)(rec.frame - r->file), rec.len};
        r->rec[i] = (span_t){end, (size_t)(rec.frame - r->file) + rec.len - end};
        end += r->rec[i].len;
    }
    assert_int_equal(ub_log_reader_next(&rd, &rec), 0);
    assert_int_equal(end, r->len);
    r->version = 3;
}

static void record_log(recorded_t *r) { record_log_with(r, k_cat_json); }

/* The same records in format version 1 (the first writer's layout), built here byte by byte. */
static void convert_to_v1(const recorded_t *r2, recorded_t *r1) {
    static const char meta[] = "{\"format\":1,\"node\":\"uav\",\"links\":{\"0\":\"radio\",\"1\":\"ipc\"},"
                               "\"start_unix_ms\":1700000000000,\"start_t_ms\":0,\"record_tx\":true}";
    size_t meta_len = strlen(meta), cat_len = strlen(k_cat_json);
    r1->version = 1;
    r1->file = malloc(r2->len + meta_len);
    assert_non_null(r1->file);
    uint8_t *p = r1->file;
    memcpy(p, UB_LOG_MAGIC_V1, UB_LOG_MAGIC_LEN);
    ub_put_u32le(p + 8, (uint32_t)meta_len);
    ub_put_u32le(p + 12, (uint32_t)cat_len);
    memcpy(p + 20, meta, meta_len);
    memcpy(p + 20 + meta_len, k_cat_json, cat_len);
    ub_put_u32le(p + 16, ub_crc32c(p + 20, meta_len + cat_len));
    size_t o = r1->header_len = 20 + meta_len + cat_len;
    for (uint32_t i = 0; i < N_RECORDS; i++) {
        const uint8_t *src = r2->file + r2->rec[i].off; /* v2: marker, len, seq, t_ms, link, dir, reserved, ... */
        uint8_t *dst = r1->file + o;
        size_t flen = r2->frame[i].len;
        ub_put_u16le(dst, UB_LOG_RECORD_MARKER);
        ub_put_u16le(dst + 2, (uint16_t)flen);
        memcpy(dst + 4, src + 8, 8);  /* t_ms */
        memcpy(dst + 12, src + 16, 4); /* link_id, dir, reserved */
        memcpy(dst + 20, r2->file + r2->frame[i].off, flen);
        ub_put_u32le(dst + 16, ub_crc32c_update(ub_crc32c(dst, 16), dst + 20, flen));
        r1->rec[i] = (span_t){o, 20 + flen};
        r1->frame[i] = (span_t){o + 20, flen};
        o += 20 + flen;
    }
    r1->len = o;
}

/* Reads buf[0, len) as `uav log` follows a growing file: windows of random growth, the undecided rest
 * carried over. Records must equal `want` (offsets included) and the counters `want_stats`. */
static void read_in_chunks(const uint8_t *buf, size_t len, size_t header_len, int version, test_rng_t *rng,
                           const ub_log_record_t *want, size_t n_want, const ub_log_reader_stats_t *want_stats) {
    ub_log_reader_t rd;
    ub_log_reader_begin(&rd, (uint8_t)version);
    size_t base = header_len, fed = header_len, got = 0;
    while (fed < len || rd.final == 0) {
        size_t more = 1 + rng_below(rng, rng_below(rng, 2) ? 40 : 3000);
        fed = fed + more > len ? len : fed + more;
        ub_log_reader_data(&rd, buf + base, fed - base, fed == len);
        ub_log_record_t rec;
        while (ub_log_reader_next(&rd, &rec) == 1) {
            assert_true(got < n_want);
            assert_int_equal(base + rec.offset, want[got].offset);
            assert_int_equal(rec.len, want[got].len);
            assert_int_equal(rec.seq, want[got].seq);
            got++;
        }
        base += ub_log_reader_consumed(&rd);
        if (fed == len) break;
    }
    assert_int_equal(base, len);
    assert_int_equal(got, n_want);
    assert_memory_equal(ub_log_reader_stats(&rd), want_stats, sizeof *want_stats);
}

enum damage_kind { FLIP, DELETE, INSERT, DAMAGE_KINDS };

typedef struct damage {
    size_t off; /* in the undamaged file */
    size_t len; /* bytes flipped / deleted; inserted bytes for INSERT (placed before `off`) */
    enum damage_kind kind;
} damage_t;

static int by_offset(const void *a, const void *b) {
    const damage_t *x = a, *y = b;
    return x->off < y->off ? -1 : x->off > y->off;
}

typedef struct trial_result {
    size_t undamaged, read_back;
} trial_result_t;

/* One trial: 1..6 damages (and sometimes a cut tail) at seeded places; returns what was expected and read. */
static trial_result_t run_trial(const recorded_t *r, test_rng_t *rng) {
    for (uint32_t i = 0; i < N_RECORDS; i++) assert_true(r->rec[i].off + r->rec[i].len <= r->len);
    damage_t d[8];
    size_t nd = 1 + rng_below(rng, 6);
    size_t body = r->len - r->header_len;
    for (size_t k = 0; k < nd; k++) {
        d[k].kind = (enum damage_kind)rng_below(rng, DAMAGE_KINDS);
        d[k].off = r->header_len + rng_below(rng, (uint32_t)body);
        d[k].len = 1 + rng_below(rng, rng_below(rng, 4) == 0 ? 300 : 6);
        if (d[k].kind != INSERT && d[k].off + d[k].len > r->len) d[k].len = r->len - d[k].off;
    }
    qsort(d, nd, sizeof d[0], by_offset);
    size_t cut = r->len;
    if (rng_below(rng, 3) == 0) cut = r->header_len + rng_below(rng, (uint32_t)body);

    /* Which records does the damage touch? An insertion touches the record it lands in (or, at a
     * boundary, none of them: the garbage lies between two whole records). */
    bool touched[N_RECORDS] = {false};
    for (uint32_t i = 0; i < N_RECORDS; i++) {
        size_t a = r->rec[i].off, b = a + r->rec[i].len;
        if (b > cut) touched[i] = true;
        for (size_t k = 0; k < nd; k++) {
            if (d[k].kind == INSERT ? (d[k].off > a && d[k].off < b) : (d[k].off < b && d[k].off + d[k].len > a))
                touched[i] = true;
        }
    }
    /* Build the damaged file (overlapping damages simply apply in order). */
    uint8_t *out = malloc(cut + 8 * 300 + 16);
    assert_non_null(out);
    size_t o = 0, pos = 0, k = 0;
    while (pos < cut) {
        while (k < nd && d[k].off < pos) k++;
        if (k < nd && d[k].off == pos) {
            const damage_t *dk = &d[k++];
            if (dk->kind == INSERT) {
                for (size_t j = 0; j < dk->len; j++) out[o++] = (uint8_t)rng_next(rng);
            } else if (dk->kind == DELETE) {
                pos += dk->len;
            } else {
                for (size_t j = 0; j < dk->len && pos < cut; j++, pos++)
                    out[o++] = (uint8_t)(r->file[pos] ^ (uint8_t)(1u + rng_below(rng, 255)));
            }
            continue;
        }
        out[o++] = r->file[pos++];
    }

    ub_log_reader_t rd;
    assert_int_equal(ub_log_reader_init(&rd, out, o, NULL), UB_OK);
    ub_log_record_t rec;
    static ub_log_record_t records[N_RECORDS];
    uint32_t next = 0; /* records are read back in order: each must be a written one at or after `next` */
    trial_result_t res = {0, 0};
    size_t read_bytes = 0;
    bool got[N_RECORDS] = {false};
    uint32_t first_i = 0, last_i = 0;
    while (ub_log_reader_next(&rd, &rec) == 1) {
        uint32_t i = next;
        while (i < N_RECORDS && !(r->frame[i].len == rec.len &&
                                  memcmp(r->file + r->frame[i].off, rec.frame, rec.len) == 0))
            i++;
        assert_true(i < N_RECORDS); /* nothing is read that was not written */
        if (r->version >= 2) assert_int_equal(rec.seq, i); /* and its sequence number is the writer's */
        if (res.read_back == 0) first_i = i;
        last_i = i;
        got[i] = true;
        next = i + 1;
        records[res.read_back++] = rec;
        read_bytes += r->rec[i].len;
    }
    for (uint32_t i = 0; i < N_RECORDS; i++) {
        if (touched[i]) continue;
        res.undamaged++;
        if (!got[i]) print_error("v%d: record %u (offset %zu) undamaged but not read back\n", r->version, i,
                                 r->rec[i].off);
        assert_true(got[i]);
    }
    /* Every byte accounted for: the header, the records read, and the bytes the reader skipped. */
    const ub_log_reader_stats_t *st = ub_log_reader_stats(&rd);
    assert_int_equal(r->header_len + read_bytes + ub_log_reader_ignored(&rd), o);
    assert_int_equal(st->records, res.read_back);
    assert_int_equal(st->record_bytes, read_bytes);
    if (r->version >= 2 && res.read_back > 0) {
        /* The sequence numbers name exactly the records lost between the first and last read. */
        assert_int_equal(st->missing_records, (last_i - first_i + 1) - res.read_back);
        assert_true(st->damaged_records <= st->missing_records + first_i + (N_RECORDS - 1 - last_i));
    }
    read_in_chunks(out, o, r->header_len, r->version, rng, records, res.read_back, st);
    free(out);
    return res;
}

static void damage_trials(const recorded_t *r, uint64_t seed) {
    test_rng_t rng = {seed};
    size_t undamaged = 0, read_back = 0;
    for (uint32_t t = 0; t < TRIALS; t++) {
        trial_result_t res = run_trial(r, &rng);
        undamaged += res.undamaged;
        read_back += res.read_back;
    }
    print_message("format %d: %u trials over a %zu-byte log of %u records: %zu undamaged records, %zu read back\n",
                  r->version, TRIALS, r->len, N_RECORDS, undamaged, read_back);
}

static void test_every_undamaged_record_is_read_back(void **state) {
    (void)state;
    recorded_t *r = calloc(1, sizeof *r);
    assert_non_null(r);
    record_log(r);
    damage_trials(r, SEED ^ 0xD4u);
    free(r->file);
    free(r);
}

static void test_format_1_logs_are_read_the_same_way(void **state) {
    (void)state;
    recorded_t *r2 = calloc(1, sizeof *r2), *r1 = calloc(1, sizeof *r1);
    assert_non_null(r2);
    assert_non_null(r1);
    record_log(r2);
    convert_to_v1(r2, r1);
    ub_log_reader_t rd;
    ub_log_header_t hdr;
    assert_int_equal(ub_log_reader_init(&rd, r1->file, r1->len, &hdr), UB_OK);
    assert_int_equal(hdr.version, 1);
    damage_trials(r1, SEED ^ 0x71u);
    free(r2->file);
    free(r1->file);
    free(r2);
    free(r1);
}


/* ---- damage to the file header (issue 29, item 2) -------------------------------------------------- */

/* Reads `buf` as a tool does: the header (either copy; both halves of a damaged pair rebuilt into one by
 * ub_log_header_repair(), counted in *repaired), else the records alone from where the header says they
 * start (or from the start, searching). Every record outside [lost_from, lost_to) of the undamaged file `r`
 * must be read back, byte for byte; @return the header verdict. */
static int read_despite(const recorded_t *r, uint8_t *buf, size_t len, size_t lost_from, size_t lost_to,
                        ub_log_header_t *hdr, size_t *repaired) {
    ub_log_reader_t rd;
    memset(hdr, 0, sizeof *hdr);
    int rc = ub_log_reader_init(&rd, buf, len, hdr);
    if (rc == UB_ERR_CHECKSUM && hdr->size != 0 && ub_log_header_repair(buf, len) == UB_OK) {
        (*repaired)++;
        rc = ub_log_reader_init(&rd, buf, len, hdr);
        assert_int_equal(rc, UB_OK);
    }
    if (rc == UB_ERR_INVAL) {
        /* No magic left at all (a block over both small copies): the records of this writer's format are
         * still searched for, as `uavbus log --catalogue` does. */
        assert_true(lost_from < r->header_len);
        hdr->version = UB_LOG_FORMAT;
        hdr->size = 0;
        rc = UB_ERR_CHECKSUM;
    }
    if (rc == UB_ERR_CHECKSUM) {
        ub_log_reader_begin(&rd, hdr->version);
        ub_log_reader_data(&rd, buf + hdr->size, len - hdr->size, true);
    } else {
        assert_int_equal(rc, UB_OK);
    }
    ub_log_record_t rec;
    bool got[N_RECORDS] = {false};
    int64_t last = -1;
    size_t read_bytes = 0;
    while (ub_log_reader_next(&rd, &rec) == 1) {
        /* In order, each one a written record, byte for byte (the writer numbered them 0..N-1). */
        assert_true((int64_t)rec.seq > last && rec.seq < N_RECORDS);
        last = rec.seq;
        assert_int_equal(rec.len, r->frame[rec.seq].len);
        assert_memory_equal(rec.frame, r->file + r->frame[rec.seq].off, rec.len);
        got[rec.seq] = true;
        read_bytes += r->rec[rec.seq].len;
    }
    /* Every record the damage did not cover was read. */
    for (uint32_t i = 0; i < N_RECORDS; i++) {
        bool covered = r->rec[i].off < lost_to && r->rec[i].off + r->rec[i].len > lost_from;
        if (!covered && !got[i]) print_error("record %u (offset %zu) not covered by the damage, not read\n", i,
                                             r->rec[i].off);
        assert_true(covered || got[i]);
    }
    assert_int_equal(hdr->size + read_bytes + ub_log_reader_ignored(&rd), len);
    return rc;
}

/* A catalogue of `n` bytes (the demo's flightsw catalogue is 93 kB; any text does for the log). */
static char *big_catalogue(size_t n) {
    char *c = malloc(n + 1);
    assert_non_null(c);
    static const char head[] = "{\"name\":\"big\",\"types\":[],\"instances\":[],\"pad\":\"";
    memcpy(c, head, sizeof head - 1);
    for (size_t i = sizeof head - 1; i < n - 2; i++) c[i] = (char)('a' + i % 26);
    memcpy(c + n - 2, "\"}", 3);
    return c;
}

static void test_one_flipped_header_byte_loses_nothing(void **state) {
    (void)state;
    recorded_t *r = calloc(1, sizeof *r);
    assert_non_null(r);
    char *cat = big_catalogue(6000);
    record_log_with(r, cat);
    ub_log_header_t want;
    ub_log_reader_t rd;
    assert_int_equal(ub_log_reader_init(&rd, r->file, r->len, &want), UB_OK);
    assert_int_equal(want.version, 3);
    size_t copy = want.size / UB_LOG_HEADER_COPIES;
    uint8_t *buf = malloc(r->len);
    assert_non_null(buf);
    test_rng_t rng = {SEED ^ 0x4EADu};
    /* 32 positions spread over the header region, its first and last bytes included: each flip alone. */
    for (size_t k = 0; k < 32; k++) {
        size_t at = (want.size - 1) * k / 31;
        memcpy(buf, r->file, r->len);
        buf[at] ^= (uint8_t)(1u + rng_below(&rng, 255));
        ub_log_header_t hdr;
        size_t repaired = 0;
        assert_int_equal(read_despite(r, buf, r->len, 0, 0, &hdr, &repaired), UB_OK);
        assert_int_equal(repaired, 0); /* one flip: one copy whole, no repair needed */
        assert_int_equal(hdr.damaged, at < copy ? UB_LOG_COPY_PRIMARY : UB_LOG_COPY_SPARE);
        assert_int_equal(hdr.size, want.size);
        assert_int_equal(hdr.meta_len, want.meta_len);
        assert_memory_equal(hdr.meta, want.meta, want.meta_len);
        assert_int_equal(hdr.catalogue_len, strlen(cat));
        assert_memory_equal(hdr.catalogue, cat, hdr.catalogue_len);
    }
    free(buf);
    free(cat);
    free(r->file);
    free(r);
}

/* A 1 KiB zeroed block at every 61st offset of the file: it costs at most the records it covers. With a
 * catalogue larger than the block the header always survives (one copy is whole, or the two halves of a
 * block over the boundary leave the primary's fixed part and the spare's body); with a small one the block
 * can cover both copies, and the records are still all read (searched for from the start). */
static void zeroed_blocks(const char *cat, bool header_always) {
    recorded_t *r = calloc(1, sizeof *r);
    assert_non_null(r);
    record_log_with(r, cat);
    uint8_t *buf = malloc(r->len);
    assert_non_null(buf);
    size_t header_lost = 0, trials = 0, repaired = 0;
    for (size_t at = 0; at + 1024 <= r->len; at += 61, trials++) {
        memcpy(buf, r->file, r->len);
        memset(buf + at, 0, 1024);
        ub_log_header_t hdr;
        int rc = read_despite(r, buf, r->len, at, at + 1024, &hdr, &repaired);
        if (rc != UB_OK) {
            assert_int_equal(rc, UB_ERR_CHECKSUM);
            assert_false(header_always);
            assert_true(at < r->header_len);
            header_lost++;
        }
    }
    print_message("zeroed 1 KiB blocks, catalogue of %zu bytes: %zu positions over a %zu-byte log, header "
                  "rebuilt from both copies %zu times, lost %zu times; every record the block did not cover read "
                  "back each time\n",
                  strlen(cat), trials, r->len, repaired, header_lost);
    if (header_always) assert_true(repaired > 0); /* blocks over the boundary of the two copies were met */
    else assert_true(header_lost > 0);           /* the small header's case was exercised */
    free(buf);
    free(r->file);
    free(r);
}

static void test_a_zeroed_kib_costs_only_the_records_it_covers(void **state) {
    (void)state;
    char *cat = big_catalogue(3000);
    zeroed_blocks(cat, true);
    free(cat);
    zeroed_blocks(k_cat_json, false);
}

/* A version 2 file (one header copy, no check on its fixed part), as the previous writer made it: read. */
static void test_format_2_logs_are_still_read(void **state) {
    (void)state;
    recorded_t *r = calloc(1, sizeof *r);
    assert_non_null(r);
    record_log(r);
    ub_log_header_t h3;
    ub_log_reader_t rd;
    assert_int_equal(ub_log_reader_init(&rd, r->file, r->len, &h3), UB_OK);
    size_t body = r->len - h3.size;
    size_t head = UB_LOG_V2_FILE_HEADER_LEN + h3.meta_len + h3.catalogue_len;
    uint8_t *v2 = malloc(head + body);
    assert_non_null(v2);
    memcpy(v2, UB_LOG_MAGIC_V2, UB_LOG_MAGIC_LEN);
    ub_put_u32le(v2 + 8, h3.meta_len);
    ub_put_u32le(v2 + 12, h3.catalogue_len);
    memcpy(v2 + 20, h3.meta, h3.meta_len);
    memcpy(v2 + 20 + h3.meta_len, h3.catalogue, h3.catalogue_len);
    ub_put_u32le(v2 + 16, ub_crc32c(v2 + 20, h3.meta_len + h3.catalogue_len));
    memcpy(v2 + head, r->file + h3.size, body);
    ub_log_header_t h2;
    assert_int_equal(ub_log_reader_init(&rd, v2, head + body, &h2), UB_OK);
    assert_int_equal(h2.version, 2);
    assert_int_equal(h2.size, head);
    ub_log_record_t rec;
    uint32_t n = 0;
    while (ub_log_reader_next(&rd, &rec) == 1) assert_int_equal(rec.seq, n++);
    assert_int_equal(n, N_RECORDS);
    assert_int_equal(ub_log_reader_ignored(&rd), 0);
    /* Its one copy damaged: refused as before, and its records still found by searching from the start. */
    v2[30] ^= 0x20;
    assert_int_equal(ub_log_reader_init(&rd, v2, head + body, &h2), UB_ERR_CHECKSUM);
    assert_int_equal(h2.size, 0);
    ub_log_reader_begin(&rd, h2.version);
    ub_log_reader_data(&rd, v2, head + body, true);
    n = 0;
    while (ub_log_reader_next(&rd, &rec) == 1) n++;
    assert_int_equal(n, N_RECORDS);
    free(v2);
    free(r->file);
    free(r);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_undamaged_record_is_read_back),
        cmocka_unit_test(test_format_1_logs_are_read_the_same_way),
        cmocka_unit_test(test_format_2_logs_are_still_read),
        cmocka_unit_test(test_one_flipped_header_byte_loses_nothing),
        cmocka_unit_test(test_a_zeroed_kib_costs_only_the_records_it_covers),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
