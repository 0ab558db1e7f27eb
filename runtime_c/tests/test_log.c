/*
 * The binary frame log (ub_log.h, docs/log-format.md): recorded through the tap of a node that runs a
 * subscription over a memlink, read back whole, read back with a crash-cut tail and a corrupt record,
 * and write failures counted.
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
    assert_string_equal(meta, "{\"format\":1,\"node\":\"gcs\",\"links\":{\"0\":\"gcs\\\"Radio\"},"
                              "\"start_unix_ms\":1700000000000,\"start_t_ms\":0,\"record_tx\":true}");
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
    /* A flipped bit in record 3's frame ends the valid part there. */
    ub_log_reader_t r2;
    assert_int_equal(ub_log_reader_init(&r2, buf, len, NULL), UB_OK);
    ub_log_record_t rec;
    for (int i = 0; i < 3; i++) assert_int_equal(ub_log_reader_next(&r2, &rec), 1);
    size_t third = (size_t)(rec.frame - buf);
    buf[third + 10] ^= 0x01;
    assert_int_equal(count_records(buf, len, &rx, &tx, &ignored), 2);
    assert_int_equal(ignored, len - (third - UB_LOG_RECORD_HEADER_LEN));
    /* A damaged header is refused. */
    buf[UB_LOG_FILE_HEADER_LEN] ^= 0x01;
    assert_int_equal(ub_log_reader_init(&r2, buf, len, NULL), UB_ERR_CHECKSUM);
    assert_int_equal(ub_log_reader_init(&r2, buf, 10, NULL), UB_ERR_TRUNCATED);
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

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_record_and_read_back),
        cmocka_unit_test(test_rx_only_counts_skipped_tx),
        cmocka_unit_test(test_write_failures_are_counted),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
