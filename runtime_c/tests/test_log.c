/*
 * The binary frame log (ub_log.h, docs/log-format.md): recorded through the tap of a node that runs a
 * subscription over a memlink, read back whole, read back with a crash-cut tail and a corrupt record;
 * write failures (ENOSPC, EIO, short writes, EFBIG, a real RLIMIT_FSIZE in a child process) counted and
 * survived; rotation by size and time with a maximum number of files. (Damage at random places:
 * test_log_damage.c.)
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "support/ub_test_world.h"
#include "ub/ub_log.h"
#include "ub/ub_pubsub.h"

static const char k_cat_json[] = "{\"name\":\"test\",\"types\":[],\"instances\":[]}";

typedef struct fixture {
    world_t *w;
    ub_catalogue_t cat; /* ub_test_cat with a self-description, as generated catalogues have */
    ub_node_t *a, *b;
    int a_ent, b_ent, a_link, b_link;
    uint8_t a_id[UB_ENTITY_ID_LEN], b_id[UB_ENTITY_ID_LEN];
    struct test_gps gps_src, gps_dst;
    ub_log_t log;
    char path[64];
    int fd;
} fixture_t;

static fixture_t *fixture_new(void) {
    fixture_t *f = calloc(1, sizeof *f);
    assert_non_null(f);
    f->cat = ub_test_cat;
    f->cat.json = k_cat_json;
    f->cat.json_len = strlen(k_cat_json);
    f->w = world_new();
    f->a = world_node(f->w, &f->cat, NULL);
    f->b = world_node(f->w, &f->cat, NULL);
    test_eid("uav", f->a_id);
    test_eid("gcs", f->b_id);
    f->a_ent = ub_node_add_entity(f->a, f->a_id, true);
    int a_peer = ub_node_add_entity(f->a, f->b_id, false);
    f->b_ent = ub_node_add_entity(f->b, f->b_id, true);
    int b_peer = ub_node_add_entity(f->b, f->a_id, false);
    f->a_link = ub_node_add_link(f->a, f->a_ent, 0, "uavRadio");
    f->b_link = ub_node_add_link(f->b, f->b_ent, 0, "gcs\"Radio"); /* a name that needs JSON escaping */
    assert_true(f->a_link >= 0 && f->b_link >= 0 && a_peer >= 0 && b_peer >= 0);
    assert_int_equal(ub_node_set_mask(f->a, f->a_ent, a_peer, 0x01), UB_OK);
    assert_int_equal(ub_node_set_mask(f->b, f->b_ent, b_peer, 0x01), UB_OK);
    (void)world_connect(f->w, f->a, f->a_link, f->b, f->b_link, NULL, 1);
    f->gps_src = (struct test_gps){33.78, -84.40, 300.0f, 3};
    assert_int_equal(ub_node_bind(f->a, TEST_GPS, &f->gps_src), UB_OK);
    assert_int_equal(ub_node_bind(f->b, TEST_GPS, &f->gps_dst), UB_OK);
    snprintf(f->path, sizeof f->path, "/tmp/ub_test_log_%ld.ublog", (long)getpid());
    f->fd = open(f->path, O_WRONLY | O_CREAT | O_TRUNC, 0600);
    assert_true(f->fd >= 0);
    return f;
}

static void fixture_free(fixture_t *f) {
    if (f->fd >= 0) close(f->fd);
    unlink(f->path);
    free(f->w);
    free(f);
}

/* The whole file, in a calloc'ed buffer. */
static uint8_t *slurp(const char *path, size_t *len) {
    int fd = open(path, O_RDONLY);
    assert_true(fd >= 0);
    struct stat st;
    assert_int_equal(fstat(fd, &st), 0);
    uint8_t *buf = calloc(1, (size_t)st.st_size + 1);
    assert_non_null(buf);
    assert_int_equal(read(fd, buf, (size_t)st.st_size), st.st_size);
    close(fd);
    *len = (size_t)st.st_size;
    return buf;
}

static size_t count_records(const uint8_t *buf, size_t len, size_t *rx, size_t *tx, size_t *ignored) {
    ub_log_reader_t rd;
    ub_log_header_t hdr;
    assert_int_equal(ub_log_reader_init(&rd, buf, len, &hdr), UB_OK);
    ub_log_record_t rec;
    size_t n = 0;
    *rx = *tx = 0;
    uint64_t last_t = 0;
    while (ub_log_reader_next(&rd, &rec) == 1) {
        n++;
        assert_true(rec.t_ms >= last_t);
        last_t = rec.t_ms;
        ub_frame_header_t h;
        assert_int_equal(ub_frame_parse(rec.frame, rec.len, &h), UB_OK); /* the frame bytes are intact */
        if (rec.dir == UB_TAP_RX) (*rx)++;
        else (*tx)++;
    }
    *ignored = ub_log_reader_ignored(&rd);
    return n;
}

static void test_record_and_read_back(void **state) {
    (void)state;
    fixture_t *f = fixture_new();
    assert_int_equal(ub_log_open(&f->log, f->fd, f->b, "gcs", true, 1700000000000ull, 0), UB_OK);
    ub_node_set_tap(f->b, ub_log_tap, &f->log);
    assert_true(ub_pubsub_subscribe(f->b, f->b_ent, TEST_GPS, f->a_id, 20, 0) >= 0);
    world_run(f->w, 1000, 1);
    ub_node_set_tap(f->b, NULL, NULL);
    ub_log_close(&f->log);
    const ub_link_counters_t *c = &ub_node_link(f->b, f->b_link)->counters;
    assert_true(c->frames_in > 40);
    const ub_log_stats_t *s = ub_log_stats(&f->log);
    assert_int_equal(s->records, c->frames_in + c->frames_out);
    assert_int_equal(s->write_errors, 0);

    size_t len;
    uint8_t *buf = slurp(f->path, &len);
    assert_int_equal(len, s->bytes);
    ub_log_reader_t rd;
    ub_log_header_t hdr;
    assert_int_equal(ub_log_reader_init(&rd, buf, len, &hdr), UB_OK);
    char meta[512];
    assert_true(hdr.meta_len < sizeof meta);
    memcpy(meta, hdr.meta, hdr.meta_len);
    meta[hdr.meta_len] = '\0';
    assert_string_equal(meta, "{\"format\":3,\"node\":\"gcs\",\"links\":{\"0\":\"gcs\\\"Radio\"},"
                              "\"start_unix_ms\":1700000000000,\"start_t_ms\":0,\"record_tx\":true,"
                              "\"file_index\":0,\"first_seq\":0,\"max_files\":0}");
    assert_int_equal(hdr.version, 3);
    assert_int_equal(hdr.damaged, 0);
    /* The header twice: the spare copy is byte for byte the primary. */
    size_t copy = UB_LOG_FILE_HEADER_LEN + hdr.meta_len + hdr.catalogue_len;
    assert_int_equal(hdr.size, UB_LOG_HEADER_COPIES * copy);
    assert_memory_equal(buf, buf + copy, copy);
    assert_int_equal(hdr.catalogue_len, strlen(k_cat_json));
    assert_memory_equal(hdr.catalogue, k_cat_json, hdr.catalogue_len);
    size_t rx, tx, ignored;
    assert_int_equal(count_records(buf, len, &rx, &tx, &ignored), s->records);
    assert_int_equal(rx, c->frames_in);
    assert_int_equal(tx, c->frames_out);
    assert_int_equal(ignored, 0);

    /* A crash cuts the last record: the reader stops before it and says how much it ignored. */
    ub_log_record_t last;
    assert_int_equal(ub_log_reader_init(&rd, buf, len, NULL), UB_OK);
    while (ub_log_reader_next(&rd, &last) == 1) {
    }
    size_t last_len = UB_LOG_RECORD_HEADER_LEN + last.len;
    assert_int_equal(count_records(buf, len - 5, &rx, &tx, &ignored), s->records - 1);
    assert_int_equal(ignored, last_len - 5);
    /* A flipped bit in record 3's frame costs record 3 only: the reader skips it whole and goes on. */
    ub_log_reader_t r2;
    assert_int_equal(ub_log_reader_init(&r2, buf, len, NULL), UB_OK);
    ub_log_record_t rec;
    for (int i = 0; i < 3; i++) assert_int_equal(ub_log_reader_next(&r2, &rec), 1);
    size_t third = (size_t)(rec.frame - buf);
    buf[third + 10] ^= 0x01;
    assert_int_equal(count_records(buf, len, &rx, &tx, &ignored), s->records - 1);
    assert_int_equal(ignored, UB_LOG_RECORD_HEADER_LEN + rec.len);
    assert_int_equal(ub_log_reader_init(&r2, buf, len, NULL), UB_OK);
    while (ub_log_reader_next(&r2, &rec) == 1) {
    }
    const ub_log_reader_stats_t *rs = ub_log_reader_stats(&r2);
    assert_int_equal(rs->damaged_records, 1);
    assert_int_equal(rs->missing_records, 1); /* by the sequence numbers: record 2 is absent */
    assert_int_equal(rs->resyncs, 0);         /* its header held: the next record was where it said */
    buf[third + 10] ^= 0x01;
    /* A damaged primary copy: the spare serves, and says so. */
    buf[UB_LOG_FILE_HEADER_LEN] ^= 0x01;
    assert_int_equal(ub_log_reader_init(&r2, buf, len, &hdr), UB_OK);
    assert_int_equal(hdr.damaged, UB_LOG_COPY_PRIMARY);
    assert_ptr_equal(hdr.meta, (const char *)buf + copy + UB_LOG_FILE_HEADER_LEN);
    assert_int_equal(count_records(buf, len, &rx, &tx, &ignored), s->records);
    /* Both copies' meta damaged at different places: no repair can help, refused; the records are still where
     * the (sound) fixed parts say. */
    buf[copy + UB_LOG_FILE_HEADER_LEN + 3] ^= 0x01;
    assert_int_equal(ub_log_reader_init(&r2, buf, len, &hdr), UB_ERR_CHECKSUM);
    assert_int_equal(hdr.damaged, UB_LOG_COPY_PRIMARY | UB_LOG_COPY_SPARE);
    assert_int_equal(hdr.size, UB_LOG_HEADER_COPIES * copy);
    assert_int_equal(ub_log_header_repair(buf, len), UB_ERR_CHECKSUM);
    buf[copy + UB_LOG_FILE_HEADER_LEN + 3] ^= 0x01;
    /* The primary's magic damaged: still a log, found through its spare. */
    buf[0] = 'X';
    assert_int_equal(ub_log_reader_init(&r2, buf, len, &hdr), UB_OK);
    assert_int_equal(hdr.damaged, UB_LOG_COPY_PRIMARY);
    buf[0] = 'U';
    buf[UB_LOG_FILE_HEADER_LEN] ^= 0x01;
    assert_int_equal(ub_log_reader_init(&r2, buf, 10, NULL), UB_ERR_TRUNCATED);
    assert_int_equal(ub_log_reader_init(&r2, buf, copy + 10, NULL), UB_ERR_TRUNCATED); /* the spare still to come */
    buf[0] = 'X';
    buf[copy] = 'X'; /* neither copy has its magic: not a log at all */
    assert_int_equal(ub_log_reader_init(&r2, buf, len, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_log_header_repair(buf, len), UB_ERR_INVAL);
    free(buf);
    fixture_free(f);
}

static void test_rx_only_counts_skipped_tx(void **state) {
    (void)state;
    fixture_t *f = fixture_new();
    assert_int_equal(ub_log_open(&f->log, f->fd, f->a, "uav", false, 0, 5), UB_OK);
    ub_node_set_tap(f->a, ub_log_tap, &f->log);
    assert_true(ub_pubsub_subscribe(f->b, f->b_ent, TEST_GPS, f->a_id, 50, 0) >= 0);
    world_run(f->w, 500, 1);
    const ub_link_counters_t *c = &ub_node_link(f->a, f->a_link)->counters;
    const ub_log_stats_t *s = ub_log_stats(&f->log);
    assert_int_equal(s->records, c->frames_in);
    assert_int_equal(s->skipped_tx, c->frames_out);
    assert_true(c->frames_out > 5);
    fixture_free(f);
}

static void test_write_failures_are_counted(void **state) {
    (void)state;
    fixture_t *f = fixture_new();
    int full = open("/dev/full", O_WRONLY);
    if (full < 0) skip();
    /* The header itself cannot be written: refused. */
    assert_int_equal(ub_log_open(&f->log, full, f->b, "gcs", true, 0, 0), UB_ERR_IO);
    /* Header written to the file, then the descriptor swapped for /dev/full: records fail and are counted. */
    assert_int_equal(ub_log_open(&f->log, f->fd, f->b, "gcs", true, 0, 0), UB_OK);
    f->log.fd = full;
    ub_node_set_tap(f->b, ub_log_tap, &f->log);
    assert_true(ub_pubsub_subscribe(f->b, f->b_ent, TEST_GPS, f->a_id, 50, 0) >= 0);
    world_run(f->w, 300, 1);
    const ub_log_stats_t *s = ub_log_stats(&f->log);
    assert_int_equal(s->records, 0);
    assert_true(s->write_errors > 3);
    ub_log_close(&f->log);
    close(full);
    uint8_t frame[8] = {0};
    assert_int_equal(ub_log_write(&f->log, 0, UB_TAP_RX, frame, sizeof frame, 0), UB_ERR_INVAL);
    assert_int_equal(ub_log_open(NULL, f->fd, f->b, "x", true, 0, 0), UB_ERR_INVAL);
    fixture_free(f);
}

/* ---- injected write failures -------------------------------------------------------------------------- */

/* A write(2) stand-in that fails a scripted range of calls: calls [fail_from, fail_to) return -1 with
 * `err`, except that the first of them, when `short_first` is set, writes half its bytes first. */
typedef struct script {
    unsigned calls;
    unsigned fail_from, fail_to;
    int err;
    int short_first;
} script_t;

static ssize_t scripted_write(void *user, int fd, const void *buf, size_t len) {
    script_t *s = user;
    unsigned call = s->calls++;
    if (call >= s->fail_from && call < s->fail_to) {
        if (s->short_first && call == s->fail_from && len > 1) return write(fd, buf, len / 2);
        errno = s->err;
        return -1;
    }
    return write(fd, buf, len);
}

/* A valid frame to log: a DATA frame for gpsOut with `seq`. */
static size_t log_frame(uint8_t *frame, uint32_t seq) {
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    h.hop_limit = 1;
    h.payload_size = 24;
    h.seq = seq;
    memset(frame + UB_FRAME_HEADER_LEN, (int)(seq & 0xFF), 24);
    int n = ub_frame_finish(frame, UB_FRAME_MAX, &h);
    assert_true(n > 0);
    return (size_t)n;
}

/* Reads `path` whole; every record must be one of the written frames, in order. */
static void read_whole(const char *path, ub_log_reader_stats_t *stats, uint32_t *first_seq, uint32_t *last_seq) {
    size_t len;
    uint8_t *buf = slurp(path, &len);
    ub_log_reader_t rd;
    assert_int_equal(ub_log_reader_init(&rd, buf, len, NULL), UB_OK);
    ub_log_record_t rec;
    bool first = true;
    while (ub_log_reader_next(&rd, &rec) == 1) {
        uint8_t want[UB_FRAME_MAX];
        size_t n = log_frame(want, rec.seq);
        assert_int_equal(rec.len, n);
        assert_memory_equal(rec.frame, want, n); /* record `seq` carries frame `seq` */
        if (first) *first_seq = rec.seq;
        *last_seq = rec.seq;
        first = false;
    }
    *stats = *ub_log_reader_stats(&rd);
    free(buf);
}

static void test_enospc_eio_and_short_writes_are_survived(void **state) {
    (void)state;
    static const struct {
        int err;
        int short_first;
    } cases[] = {{ENOSPC, 0}, {ENOSPC, 1}, {EIO, 0}, {EIO, 1}, {EFBIG, 1}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        fixture_t *f = fixture_new();
        assert_int_equal(ub_log_open(&f->log, f->fd, f->b, "gcs", true, 0, 0), UB_OK);
        /* Records 0..29 written, the calls for records 30..49 fail, then writing works again. A short write
         * is followed by a failing write for its rest, as on a full disk. */
        script_t sc = {0, 30, 50, cases[c].err, cases[c].short_first};
        ub_log_set_write_fn(&f->log, scripted_write, &sc);
        uint8_t frame[UB_FRAME_MAX];
        int failed = 0;
        for (uint32_t i = 0; i < 100; i++) {
            size_t n = log_frame(frame, i);
            int rc = ub_log_write(&f->log, 0, UB_TAP_RX, frame, n, i);
            if (rc == UB_ERR_IO) failed++;
            else assert_int_equal(rc, UB_OK);
        }
        const ub_log_stats_t *s = ub_log_stats(&f->log);
        /* A short write is retried for the rest, which fails: that record needs two calls. */
        int lost = cases[c].short_first ? 19 : 20;
        assert_int_equal(failed, lost);
        assert_int_equal(s->write_errors, lost);
        assert_int_equal(s->records, 100 - lost);
        assert_int_equal(s->last_errno, cases[c].err);
        assert_int_equal(s->torn_writes, cases[c].short_first ? 1 : 0);
        assert_int_equal(s->torn_bytes, 0); /* cut back: the file holds whole records only */
        assert_int_equal(s->recoveries, 1);
        ub_log_close(&f->log);
        struct stat st;
        assert_int_equal(stat(f->path, &st), 0);
        assert_int_equal((uint64_t)st.st_size, s->bytes);
        ub_log_reader_stats_t rs;
        uint32_t first = 0, last = 0;
        read_whole(f->path, &rs, &first, &last);
        assert_int_equal(rs.records, 100 - lost);
        assert_int_equal(rs.skipped_bytes, 0);
        assert_int_equal(rs.missing_records, lost); /* the gap in the sequence numbers says what is missing */
        assert_int_equal(first, 0);
        assert_int_equal(last, 99);
        fixture_free(f);
    }
}

/* Short writes on a descriptor that cannot be cut back (a pipe): the torn bytes stay and readers skip them. */
static void test_torn_record_on_a_pipe_is_skipped_by_readers(void **state) {
    (void)state;
    fixture_t *f = fixture_new();
    int p[2];
    assert_int_equal(pipe(p), 0);
    assert_int_equal(fcntl(p[0], F_SETFL, O_NONBLOCK), 0);
    assert_int_equal(ub_log_open(&f->log, p[1], f->b, "gcs", true, 0, 0), UB_OK);
    script_t sc = {0, 4, 6, EIO, 1}; /* record 4: half written, then EIO for the rest */
    ub_log_set_write_fn(&f->log, scripted_write, &sc);
    uint8_t frame[UB_FRAME_MAX];
    for (uint32_t i = 0; i < 10; i++) {
        int rc = ub_log_write(&f->log, 0, UB_TAP_RX, frame, log_frame(frame, i), i);
        assert_true(rc == UB_OK || (i == 4 && rc == UB_ERR_IO));
    }
    const ub_log_stats_t *s = ub_log_stats(&f->log);
    assert_int_equal(s->torn_writes, 1);
    assert_true(s->torn_bytes > 0);
    static uint8_t buf[1 << 16];
    ssize_t n = read(p[0], buf, sizeof buf);
    assert_int_equal((uint64_t)n, s->bytes);
    ub_log_reader_t rd;
    assert_int_equal(ub_log_reader_init(&rd, buf, (size_t)n, NULL), UB_OK);
    ub_log_record_t rec;
    uint32_t got = 0;
    while (ub_log_reader_next(&rd, &rec) == 1) got++;
    assert_int_equal(got, 9);
    assert_int_equal(ub_log_reader_stats(&rd)->skipped_bytes, s->torn_bytes);
    assert_int_equal(ub_log_reader_stats(&rd)->missing_records, 1);
    ub_log_close(&f->log);
    close(p[0]);
    close(p[1]);
    fixture_free(f);
}

/* ---- rotation ------------------------------------------------------------------------------------------ */

static void remove_set(const char *path, uint32_t files) {
    char name[UB_LOG_PATH_MAX];
    for (uint32_t i = 0; i <= files; i++) {
        if (ub_log_file_name(path, i, name, sizeof name) == UB_OK) unlink(name);
    }
}

static void test_file_names_of_a_set(void **state) {
    (void)state;
    char name[64];
    assert_int_equal(ub_log_file_name("logs/primary.ublog", 0, name, sizeof name), UB_OK);
    assert_string_equal(name, "logs/primary.ublog");
    assert_int_equal(ub_log_file_name("logs/primary.ublog", 7, name, sizeof name), UB_OK);
    assert_string_equal(name, "logs/primary.0007.ublog");
    assert_int_equal(ub_log_file_name("a.b/log", 12345, name, sizeof name), UB_OK);
    assert_string_equal(name, "a.b/log.12345");
    assert_int_equal(ub_log_file_name(".hidden", 1, name, sizeof name), UB_OK);
    assert_string_equal(name, ".hidden.0001");
    assert_int_equal(ub_log_file_name("x.ublog", 1, name, 8), UB_ERR_NOSPACE);
    assert_int_equal(ub_log_file_name(NULL, 1, name, sizeof name), UB_ERR_INVAL);
}

static void test_rotation_by_size_keeps_max_files(void **state) {
    (void)state;
    fixture_t *f = fixture_new();
    char path[96];
    snprintf(path, sizeof path, "/tmp/ub_test_rot_%ld.ublog", (long)getpid());
    ub_log_rotation_t rot = {.max_bytes = 2000, .max_files = 3};
    assert_int_equal(ub_log_open_path(&f->log, path, &rot, f->b, "gcs", true, 1700000000000ull, 0), UB_OK);
    uint8_t frame[UB_FRAME_MAX];
    for (uint32_t i = 0; i < 200; i++) {
        assert_int_equal(ub_log_write(&f->log, 0, UB_TAP_RX, frame, log_frame(frame, i), 1000 + i), UB_OK);
    }
    const ub_log_stats_t *s = ub_log_stats(&f->log);
    uint32_t last_index = ub_log_file_index(&f->log);
    assert_true(last_index >= 5);
    assert_int_equal(s->files, last_index + 1);
    assert_int_equal(s->files_deleted, last_index + 1 - 3);
    ub_log_close(&f->log);
    /* Only the newest three files exist; each reads alone; the records run on across them. */
    char name[UB_LOG_PATH_MAX];
    uint32_t expect_first = 0;
    uint64_t total = 0;
    for (uint32_t i = 0; i <= last_index; i++) {
        assert_int_equal(ub_log_file_name(path, i, name, sizeof name), UB_OK);
        struct stat st;
        if (i + 3 <= last_index) {
            assert_int_equal(stat(name, &st), -1);
            continue;
        }
        assert_int_equal(stat(name, &st), 0);
        assert_true((uint64_t)st.st_size <= rot.max_bytes);
        ub_log_reader_stats_t rs;
        uint32_t first = 0, last = 0;
        read_whole(name, &rs, &first, &last);
        if (i + 3 > last_index + 0 && expect_first != 0) assert_int_equal(first, expect_first);
        expect_first = last + 1;
        assert_int_equal(rs.skipped_bytes, 0);
        assert_int_equal(rs.missing_records, 0);
        total += rs.records;
        /* The header says which file of the set this is and the sequence number it starts at. */
        size_t len;
        uint8_t *buf = slurp(name, &len);
        ub_log_header_t hdr;
        assert_int_equal(ub_log_header_parse(buf, len, &hdr), UB_OK);
        char want[96];
        snprintf(want, sizeof want, "\"file_index\":%u,\"first_seq\":%u,\"max_files\":3", i, first);
        assert_non_null(strstr(hdr.meta, want));
        /* A file whose start deleted the oldest one names it. */
        if (i >= 3) snprintf(want, sizeof want, ",\"deleted_file\":%u}", i - 3);
        else snprintf(want, sizeof want, ",\"max_files\":3}");
        assert_non_null(strstr(hdr.meta, want));
        free(buf);
    }
    assert_int_equal(expect_first, 200);
    assert_true(total < 200); /* the oldest files were deleted */
    remove_set(path, last_index);
    fixture_free(f);
}

static void test_rotation_by_time(void **state) {
    (void)state;
    fixture_t *f = fixture_new();
    char path[96];
    snprintf(path, sizeof path, "/tmp/ub_test_rott_%ld", (long)getpid());
    ub_log_rotation_t rot = {.max_ms = 100};
    assert_int_equal(ub_log_open_path(&f->log, path, &rot, f->b, "gcs", true, 1700000000000ull, 5000), UB_OK);
    uint8_t frame[UB_FRAME_MAX];
    for (uint32_t i = 0; i < 50; i++) { /* one record every 10 ms from t = 5000: a new file every 10 records */
        assert_int_equal(ub_log_write(&f->log, 0, UB_TAP_RX, frame, log_frame(frame, i), 5000 + 10 * i), UB_OK);
    }
    assert_int_equal(ub_log_file_index(&f->log), 4);
    assert_int_equal(ub_log_stats(&f->log)->files_deleted, 0);
    ub_log_close(&f->log);
    char name[UB_LOG_PATH_MAX];
    assert_int_equal(ub_log_file_name(path, 2, name, sizeof name), UB_OK);
    size_t len;
    uint8_t *buf = slurp(name, &len);
    ub_log_header_t hdr;
    assert_int_equal(ub_log_header_parse(buf, len, &hdr), UB_OK);
    /* File 2 started at t = 5200: its wall-clock start follows from the first file's. */
    assert_non_null(strstr(hdr.meta, "\"start_unix_ms\":1700000000200,\"start_t_ms\":5200,"));
    free(buf);
    remove_set(path, 4);
    fixture_free(f);
}

/* EFBIG (a file-size limit) on a rotating log: the record goes to the next file, nothing is lost. */
static void test_efbig_continues_in_the_next_file(void **state) {
    (void)state;
    fixture_t *f = fixture_new();
    char path[96];
    snprintf(path, sizeof path, "/tmp/ub_test_efbig_%ld.ublog", (long)getpid());
    assert_int_equal(ub_log_open_path(&f->log, path, NULL, f->b, "gcs", true, 0, 0), UB_OK);
    script_t sc = {0, 10, 11, EFBIG, 0};
    ub_log_set_write_fn(&f->log, scripted_write, &sc);
    uint8_t frame[UB_FRAME_MAX];
    for (uint32_t i = 0; i < 20; i++) {
        assert_int_equal(ub_log_write(&f->log, 0, UB_TAP_RX, frame, log_frame(frame, i), i), UB_OK);
    }
    const ub_log_stats_t *s = ub_log_stats(&f->log);
    assert_int_equal(s->records, 20);
    assert_int_equal(s->write_errors, 0);
    assert_int_equal(s->limit_rotations, 1);
    assert_int_equal(ub_log_file_index(&f->log), 1);
    ub_log_close(&f->log);
    char name[UB_LOG_PATH_MAX];
    ub_log_reader_stats_t rs;
    uint32_t first = 0, last = 0;
    read_whole(path, &rs, &first, &last);
    assert_int_equal(last, 9);
    assert_int_equal(ub_log_file_name(path, 1, name, sizeof name), UB_OK);
    read_whole(name, &rs, &first, &last);
    assert_int_equal(first, 10);
    assert_int_equal(last, 19);
    remove_set(path, 1);
    fixture_free(f);
}

/* The real thing in a child process: RLIMIT_FSIZE with SIGXFSZ ignored (as uavbus_node does). The
 * writer rotates at every limit and keeps 3 files; the child survives and exits normally. */
static void test_rlimit_fsize_in_a_child_process(void **state) {
    (void)state;
    char path[96];
    snprintf(path, sizeof path, "/tmp/ub_test_fsize_%ld.ublog", (long)getpid());
    fixture_t *f = fixture_new();
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        signal(SIGXFSZ, SIG_IGN);
        struct rlimit lim = {8192, 8192};
        if (setrlimit(RLIMIT_FSIZE, &lim) != 0) _exit(3);
        ub_log_rotation_t rot = {.max_files = 3};
        if (ub_log_open_path(&f->log, path, &rot, f->b, "gcs", true, 0, 0) != UB_OK) _exit(4);
        uint8_t frame[UB_FRAME_MAX];
        int errors = 0;
        for (uint32_t i = 0; i < 1000; i++) {
            if (ub_log_write(&f->log, 0, UB_TAP_RX, frame, log_frame(frame, i), i) != UB_OK) errors++;
        }
        const ub_log_stats_t *s = ub_log_stats(&f->log);
        uint32_t files = ub_log_file_index(&f->log) + 1;
        ub_log_close(&f->log);
        /* Every record written, in files of at most 8 KiB: the exit code says so. */
        _exit(errors == 0 && s->records == 1000 && s->limit_rotations == files - 1 && files > 5 ? 0 : 5);
    }
    int status = 0;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    assert_true(WIFEXITED(status));
    assert_int_equal(WEXITSTATUS(status), 0);
    remove_set(path, 1000);
    fixture_free(f);
}


/* Every deletion under max_files is reported to the event hook, with the file's name. */
typedef struct events {
    unsigned started, deleted, failed;
    uint32_t last_deleted;
    char last_name[UB_LOG_PATH_MAX];
} events_t;

static void on_event(void *user, ub_log_event_t ev, uint32_t index, const char *name) {
    events_t *e = user;
    if (ev == UB_LOG_EVENT_FILE_STARTED) e->started++;
    if (ev == UB_LOG_EVENT_FILE_DELETED) {
        e->deleted++;
        e->last_deleted = index;
        snprintf(e->last_name, sizeof e->last_name, "%s", name);
    }
    if (ev == UB_LOG_EVENT_DELETE_FAILED) e->failed++;
}

static void test_deletions_are_reported(void **state) {
    (void)state;
    fixture_t *f = fixture_new();
    char path[96];
    snprintf(path, sizeof path, "/tmp/ub_test_evt_%ld.ublog", (long)getpid());
    ub_log_rotation_t rot = {.max_ms = 100, .max_files = 2};
    assert_int_equal(ub_log_open_path(&f->log, path, &rot, f->b, "gcs", true, 0, 0), UB_OK);
    events_t ev;
    memset(&ev, 0, sizeof ev);
    ub_log_set_event_fn(&f->log, on_event, &ev);
    uint8_t frame[UB_FRAME_MAX];
    for (uint32_t i = 0; i < 50; i++) { /* a file per 100 ms: files 0..4 */
        assert_int_equal(ub_log_write(&f->log, 0, UB_TAP_RX, frame, log_frame(frame, i), 10 * i), UB_OK);
    }
    ub_log_close(&f->log);
    assert_int_equal(ev.started, 4);
    assert_int_equal(ev.deleted, 3);
    assert_int_equal(ev.failed, 0);
    assert_int_equal(ev.deleted, ub_log_stats(&f->log)->files_deleted);
    assert_int_equal(ev.last_deleted, 2);
    char name[UB_LOG_PATH_MAX];
    assert_int_equal(ub_log_file_name(path, 2, name, sizeof name), UB_OK);
    assert_string_equal(ev.last_name, name);
    remove_set(path, 4);
    fixture_free(f);
}

/* A size limit below one header and one largest record would start a file per record: refused, no file made. */
static void test_rotation_below_the_header_is_refused(void **state) {
    (void)state;
    fixture_t *f = fixture_new();
    uint64_t min_bytes = 0;
    assert_int_equal(ub_log_rotation_floor(f->b, "gcs", &min_bytes), UB_OK);
    /* Both copies of the longest header (meta with every number at its widest) and one largest record. */
    size_t cat = strlen(k_cat_json);
    assert_true(min_bytes > UB_LOG_HEADER_COPIES * (UB_LOG_FILE_HEADER_LEN + cat + 200) + UB_LOG_RECORD_HEADER_LEN
                            + UB_FRAME_MAX);
    assert_true(min_bytes < UB_LOG_HEADER_COPIES * (UB_LOG_FILE_HEADER_LEN + cat + 400) + UB_LOG_RECORD_HEADER_LEN
                            + UB_FRAME_MAX);
    char path[96];
    snprintf(path, sizeof path, "/tmp/ub_test_floor_%ld.ublog", (long)getpid());
    unlink(path);
    ub_log_rotation_t rot = {.max_bytes = min_bytes - 1, .max_files = 3};
    assert_int_equal(ub_log_open_path(&f->log, path, &rot, f->b, "gcs", true, 0, 0), UB_ERR_RANGE);
    struct stat st;
    assert_int_equal(stat(path, &st), -1);
    rot.max_bytes = min_bytes;
    assert_int_equal(ub_log_open_path(&f->log, path, &rot, f->b, "gcs", true, 0, 0), UB_OK);
    /* At the floor every file holds at least one record of the largest size. */
    uint8_t frame[UB_FRAME_MAX];
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    h.hop_limit = 1;
    h.payload_size = UB_MAX_PAYLOAD;
    int n = ub_frame_finish(frame, sizeof frame, &h);
    assert_true(n > 0);
    for (uint32_t i = 0; i < 6; i++) assert_int_equal(ub_log_write(&f->log, 0, UB_TAP_RX, frame, (size_t)n, i), UB_OK);
    assert_int_equal(ub_log_file_index(&f->log), 5); /* one record per file: the largest just fits */
    ub_log_close(&f->log);
    remove_set(path, 5);
    assert_int_equal(ub_log_rotation_floor(NULL, "gcs", &min_bytes), UB_ERR_INVAL);
    fixture_free(f);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_record_and_read_back),
        cmocka_unit_test(test_rx_only_counts_skipped_tx),
        cmocka_unit_test(test_write_failures_are_counted),
        cmocka_unit_test(test_enospc_eio_and_short_writes_are_survived),
        cmocka_unit_test(test_torn_record_on_a_pipe_is_skipped_by_readers),
        cmocka_unit_test(test_file_names_of_a_set),
        cmocka_unit_test(test_rotation_by_size_keeps_max_files),
        cmocka_unit_test(test_rotation_by_time),
        cmocka_unit_test(test_efbig_continues_in_the_next_file),
        cmocka_unit_test(test_rlimit_fsize_in_a_child_process),
        cmocka_unit_test(test_deletions_are_reported),
        cmocka_unit_test(test_rotation_below_the_header_is_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
