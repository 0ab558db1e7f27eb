/*
 * Priorities on slow links (ub_prio.h, issue 28): the class of a frame from its admin code and its
 * content's configured class; the impairment's byte-budget medium (ub_impair.h, prio=1) sending in class
 * order with bounded per-class queues (oldest telemetry shed and counted); a command never waiting more than
 * one MTU time behind a stream of fragments; the node counting sheds on the link. Time is the injected
 * clock, never the machine's.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ub/ub_impair.h"
#include "ub/ub_node.h"
#include "ub/ub_nodecfg.h"
#include "ub/ub_prio.h"
#include "support/ub_test_pair.h"

/* ---- the class of a frame ---- */

static void test_class_of_admin_codes(void **state) {
    (void)state;
    assert_int_equal(ub_prio_class_of(UB_ADMIN_DATA, UB_PRIO_TELEMETRY), UB_PRIO_TELEMETRY);
    assert_int_equal(ub_prio_class_of(UB_ADMIN_DATA, UB_PRIO_CONTROL), UB_PRIO_CONTROL);
    assert_int_equal(ub_prio_class_of(UB_ADMIN_DATA, UB_PRIO_COMMAND), UB_PRIO_COMMAND);
    assert_int_equal(ub_prio_class_of(UB_ADMIN_DATA, (ub_prio_class_t)9), UB_PRIO_TELEMETRY);
    /* A fragment is bulk whatever its content's class. */
    assert_int_equal(ub_prio_class_of(UB_ADMIN_FRAGMENT, UB_PRIO_COMMAND), UB_PRIO_BULK);
    for (unsigned code = 1; code < 256; code++) {
        if (code == UB_ADMIN_FRAGMENT) continue;
        assert_int_equal(ub_prio_class_of((uint8_t)code, UB_PRIO_BULK), UB_PRIO_COMMAND);
    }
    ub_prio_class_t c;
    for (unsigned k = 0; k < UB_PRIO_CLASSES; k++) {
        assert_int_equal(ub_prio_class_parse(ub_prio_class_name((ub_prio_class_t)k), &c), UB_OK);
        assert_int_equal(c, k);
    }
    assert_int_equal(ub_prio_class_parse("urgent", &c), UB_ERR_INVAL);
    assert_string_equal(ub_prio_class_name(UB_PRIO_CLASSES), "?");
}

/* ---- the medium: a capture behind the impairment ---- */

#define CAP_MAX 4096
typedef struct capture_at {
    size_t n;
    uint32_t id[CAP_MAX];
    uint64_t at[CAP_MAX];
} capture_at_t;

static int cap_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    capture_at_t *c = impl;
    assert_true(len >= 4 && c->n < CAP_MAX);
    uint32_t id;
    memcpy(&id, frame, 4);
    c->id[c->n] = id;
    c->at[c->n++] = now_ms;
    return UB_OK;
}
static const ub_link_ops_t cap_ops = {.kind = "capture", .send = cap_send, .fileno = NULL};

typedef struct medium {
    ub_impair_t imp;
    capture_at_t cap;
} medium_t;

static medium_t *medium_new(uint32_t prio) {
    medium_t *m = calloc(1, sizeof *m);
    assert_non_null(m);
    ub_impair_params_t p = {.rate_Bps = 5760, .prio = prio};
    ub_impair_init(&m->imp, &p, 1);
    assert_int_equal(ub_impair_wrap(&m->imp, &cap_ops, &m->cap), UB_OK);
    return m;
}

/* Sends frame `id` of `len` bytes in class `cls`: the node's call. */
static int offer(medium_t *m, uint32_t id, size_t len, ub_prio_class_t cls, uint64_t now_ms) {
    uint8_t frame[UB_FRAME_MAX] = {0};
    memcpy(frame, &id, 4);
    return ub_impair_ops.send_class(&m->imp, frame, len, (uint8_t)cls, now_ms);
}

static void run_until(medium_t *m, uint64_t from_ms, uint64_t to_ms) {
    for (uint64_t t = from_ms; t <= to_ms; t++) (void)ub_impair_service(&m->imp, t);
}

static long position(const medium_t *m, uint32_t id) {
    for (size_t i = 0; i < m->cap.n; i++)
        if (m->cap.id[i] == id) return (long)i;
    return -1;
}

/* Everything offered at t=0 while the medium is busy with the first frame leaves by class, oldest first
 * within a class; in send order without priorities. */
static void test_priority_order(void **state) {
    (void)state;
    for (uint32_t prio = 0; prio <= 1; prio++) {
        medium_t *m = medium_new(prio);
        /* ids: 1..6 telemetry, 11..12 bulk, 21 control, 31..32 command; 100 bytes each (17.4 ms at 5760 B/s) */
        for (uint32_t i = 1; i <= 6; i++) assert_true(offer(m, i, 100, UB_PRIO_TELEMETRY, 0) >= 0);
        assert_int_equal(offer(m, 11, 100, UB_PRIO_BULK, 0), UB_OK);
        assert_int_equal(offer(m, 12, 100, UB_PRIO_BULK, 0), UB_OK);
        assert_int_equal(offer(m, 21, 100, UB_PRIO_CONTROL, 0), UB_OK);
        assert_int_equal(offer(m, 31, 100, UB_PRIO_COMMAND, 0), UB_OK);
        assert_int_equal(offer(m, 32, 100, UB_PRIO_COMMAND, 0), UB_OK);
        run_until(m, 0, 1000);
        assert_int_equal(m->cap.n, 11);
        const uint32_t want_prio[] = {1, 31, 32, 21, 2, 3, 4, 5, 6, 11, 12};
        const uint32_t want_fifo[] = {1, 2, 3, 4, 5, 6, 11, 12, 21, 31, 32};
        const uint32_t *want = prio ? want_prio : want_fifo;
        for (size_t i = 0; i < 11; i++) assert_int_equal(m->cap.id[i], want[i]);
        /* One frame after the other at the byte rate, whatever the order: 11 x 100 B take 191 ms. */
        assert_int_equal(m->cap.at[10], (11 * 100 * 1000 + 5759) / 5760);
        if (prio) assert_true(m->imp.stats.overtaken >= 3);
        assert_true(ub_impair_check_balance(&m->imp));
        free(m);
    }
}

/* Per-class bounds: telemetry beyond its depth sheds its oldest (counted, reported to the caller); bulk and
 * commands beyond theirs push back; nothing is lost uncounted. */
static void test_per_class_bounds(void **state) {
    (void)state;
    medium_t *m = medium_new(1);
    int shed_reported = 0;
    /* Frame 1 takes the medium at once; 2..13 fill the telemetry queue; 14..20 each shed the oldest. */
    for (uint32_t i = 1; i <= 20; i++) {
        int rc = offer(m, i, 100, UB_PRIO_TELEMETRY, 0);
        assert_true(rc >= 0);
        shed_reported += rc;
    }
    assert_int_equal(shed_reported, 20 - 1 - UB_PRIO_DEPTH_TELEMETRY);
    assert_int_equal(m->imp.stats.shed, 20 - 1 - UB_PRIO_DEPTH_TELEMETRY);
    for (uint32_t i = 0; i < UB_PRIO_DEPTH_BULK; i++) assert_int_equal(offer(m, 100 + i, 100, UB_PRIO_BULK, 0), UB_OK);
    assert_int_equal(offer(m, 199, 100, UB_PRIO_BULK, 0), UB_ERR_AGAIN);
    for (uint32_t i = 0; i < UB_PRIO_DEPTH_COMMAND; i++)
        assert_int_equal(offer(m, 200 + i, 20, UB_PRIO_COMMAND, 0), UB_OK);
    assert_int_equal(offer(m, 299, 20, UB_PRIO_COMMAND, 0), UB_ERR_AGAIN);
    assert_int_equal(m->imp.stats.queue_full, 2);
    assert_true(ub_impair_check_balance(&m->imp));
    run_until(m, 0, 2000);
    /* The oldest telemetry went: 1 (already on the medium), then 9..20 are what is left, in order. */
    assert_int_equal(position(m, 1), 0);
    for (uint32_t i = 2; i <= 8; i++) assert_int_equal(position(m, i), -1);
    for (uint32_t i = 9; i < 20; i++) assert_true(position(m, i) < position(m, i + 1));
    /* Commands first, then telemetry, then bulk. */
    assert_true(position(m, 200 + UB_PRIO_DEPTH_COMMAND - 1) < position(m, 9));
    /* Bulk's share: after UB_PRIO_BULK_EVERY telemetry frames taken while bulk waited, one bulk frame. */
    assert_int_equal(position(m, 100), 1 + UB_PRIO_DEPTH_COMMAND + UB_PRIO_BULK_EVERY);
    assert_int_equal(position(m, 9 + UB_PRIO_BULK_EVERY), position(m, 100) + 1);
    assert_true(position(m, 20) < position(m, 101));
    assert_int_equal(position(m, 199), -1);
    assert_int_equal(m->cap.n, 1 + 12 + UB_PRIO_DEPTH_BULK + UB_PRIO_DEPTH_COMMAND);
    assert_int_equal(ub_impair_pending(&m->imp), 0);
    assert_true(ub_impair_check_balance(&m->imp));
    free(m);
}

/* A sender that keeps the bulk queue full of MTU-sized fragments (a 16 KiB directory after another) and
 * telemetry flowing; a command at an arbitrary millisecond waits at most for the frame on the medium: its
 * latency is at most one MTU time plus its own time on the medium (plus 1 ms of clock rounding each). */
static void test_fragments_never_delay_a_command_beyond_one_mtu(void **state) {
    (void)state;
    const size_t mtu = 255, cmd_len = 40;
    const uint64_t mtu_ms = (mtu * 1000 + 5759) / 5760, cmd_ms = (cmd_len * 1000 + 5759) / 5760;
    {
        medium_t *m = medium_new(1);
        uint32_t next_frag = 1000000, next_tel = 2000000, next_cmd = 1;
        uint64_t cmd_sent[64] = {0};
        uint64_t rng = 12345;
        uint64_t next_cmd_at = 37;
        for (uint64_t t = 0; t < 20000; t++) {
            (void)ub_impair_service(&m->imp, t);
            while (offer(m, next_frag, mtu, UB_PRIO_BULK, t) == UB_OK) next_frag++; /* fragments: as fast as taken */
            if (t % 20 == 0) (void)offer(m, next_tel++, 74, UB_PRIO_TELEMETRY, t);
            if (t == next_cmd_at && next_cmd < 64) {
                assert_int_equal(offer(m, next_cmd, cmd_len, UB_PRIO_COMMAND, t), UB_OK);
                cmd_sent[next_cmd++] = t;
                rng = rng * 6364136223846793005ULL + 1442695040888963407ULL;
                next_cmd_at = t + 150 + (rng >> 33) % 157; /* commands at odd phases of the fragment stream */
            }
        }
        run_until(m, 20000, 22000);
        assert_true(next_cmd > 60);
        assert_true(next_frag - 1000000 > 100); /* the fragments did flow */
        assert_true(m->imp.stats.bytes >= 5760u * 20u * 95u / 100u); /* and the medium was saturated */
        uint64_t worst = 0;
        for (uint32_t c = 1; c < next_cmd; c++) {
            long i = position(m, c);
            assert_true(i >= 0);
            uint64_t lat = m->cap.at[i] - cmd_sent[c];
            if (lat > worst) worst = lat;
            assert_true(lat <= mtu_ms + 1 + cmd_ms + 1);
        }
        assert_true(worst > cmd_ms); /* some command did wait behind a fragment: the bound was exercised */
        assert_true(ub_impair_check_balance(&m->imp));
        free(m);
    }
}

/* A telemetry flood (174 % of the link) slows bulk to its share but never stops it; without the share it
 * would get nothing (telemetry always waits). */
static void test_bulk_keeps_its_share_under_a_flood(void **state) {
    (void)state;
    medium_t *m = medium_new(1);
    uint32_t tel = 1, bulk = 1000000;
    for (uint64_t t = 0; t < 10000; t++) {
        (void)ub_impair_service(&m->imp, t);
        if (t % 10 == 0) assert_true(offer(m, tel++, 100, UB_PRIO_TELEMETRY, t) >= 0);
        while (offer(m, bulk, 200, UB_PRIO_BULK, t) == UB_OK) bulk++;
    }
    size_t n_tel = 0, n_bulk = 0;
    for (size_t i = 0; i < m->cap.n; i++) *(m->cap.id[i] >= 1000000 ? &n_bulk : &n_tel) += 1;
    assert_true(m->imp.stats.shed > 0);                    /* the flood was real */
    assert_true(n_bulk * UB_PRIO_BULK_EVERY >= n_tel - 16); /* one bulk frame per UB_PRIO_BULK_EVERY telemetry */
    assert_true(n_bulk * UB_PRIO_BULK_EVERY <= n_tel + 16);
    assert_true(ub_impair_check_balance(&m->imp));
    free(m);
}

/* Taken away (ub_ports drains a decorator with a time later than any due time): every waiting frame leaves,
 * in class order, none stays behind uncounted. */
static void test_drain_leaves_nothing_waiting(void **state) {
    (void)state;
    medium_t *m = medium_new(1);
    for (uint32_t i = 1; i <= 10; i++) assert_true(offer(m, i, 200, UB_PRIO_TELEMETRY, 5) >= 0);
    assert_int_equal(offer(m, 99, 40, UB_PRIO_COMMAND, 5), UB_OK);
    assert_int_equal(ub_impair_service(&m->imp, UINT64_MAX / 2), 11); /* frame 1 was on the medium, due later */
    assert_int_equal(ub_impair_pending(&m->imp), 0);
    assert_int_equal(m->cap.n, 11);
    assert_int_equal(position(m, 99), 1);
    assert_true(ub_impair_check_balance(&m->imp));
    free(m);
}

/* Without priorities the same stream holds a command behind the whole queue: the bound above is the
 * priorities' doing (this is the test that fails if the classes are ignored). */
static void test_without_priorities_a_command_waits_behind_the_queue(void **state) {
    (void)state;
    medium_t *m = medium_new(0);
    for (uint32_t i = 1; i <= 20; i++) assert_int_equal(offer(m, i, 255, UB_PRIO_BULK, 0), UB_OK);
    assert_int_equal(offer(m, 99, 40, UB_PRIO_COMMAND, 0), UB_OK);
    run_until(m, 0, 3000);
    assert_int_equal(position(m, 99), 20);
    assert_true(m->cap.at[20] > 20 * 255 * 1000 / 5760);
    free(m);
}

/* ---- the node: derives the class where the frame leaves, counts sheds ---- */

typedef struct class_capture {
    size_t n;
    uint8_t cls[16];
    int rc; /* what send_class answers */
} class_capture_t;

static int cc_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)impl, (void)frame, (void)len, (void)now_ms;
    fail_msg("the node must call send_class when the transport has it");
    return UB_ERR_IO;
}
static int cc_send_class(void *impl, const uint8_t *frame, size_t len, uint8_t cls, uint64_t now_ms) {
    (void)frame, (void)len, (void)now_ms;
    class_capture_t *c = impl;
    if (c->n < 16) c->cls[c->n++] = cls;
    return c->rc;
}
static const ub_link_ops_t cc_ops = {.kind = "classes", .send = cc_send, .fileno = NULL, .send_class = cc_send_class};

static void test_node_derives_class_and_counts_sheds(void **state) {
    (void)state;
    pair_t *p = pair_new(NULL);
    class_capture_t cc = {0};
    assert_int_equal(ub_node_link_attach(p->pub_node, p->pub_link, &cc_ops, &cc), UB_OK);
    /* No table: DATA is telemetry; an admin frame is a command. */
    assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 10), 1);
    uint8_t hello[4] = {0};
    assert_int_equal(ub_node_send_link_local(p->pub_node, p->pub_link, UB_ADMIN_HELLO, hello, sizeof hello, 11), 1);
    /* The configured class of the content. */
    uint8_t classes[8];
    size_t n = ub_test_cat.n_instances;
    assert_true(n <= 8);
    for (size_t i = 0; i < n; i++) classes[i] = UB_PRIO_TELEMETRY;
    classes[TEST_GPS] = UB_PRIO_CONTROL;
    assert_int_equal(ub_node_set_content_classes(p->pub_node, classes, n + 1), UB_ERR_INVAL);
    classes[TEST_IMU] = 7;
    assert_int_equal(ub_node_set_content_classes(p->pub_node, classes, n), UB_ERR_INVAL);
    classes[TEST_IMU] = UB_PRIO_TELEMETRY;
    assert_int_equal(ub_node_set_content_classes(p->pub_node, classes, n), UB_OK);
    assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 12), 1);
    assert_int_equal(cc.n, 3);
    assert_int_equal(cc.cls[0], UB_PRIO_TELEMETRY);
    assert_int_equal(cc.cls[1], UB_PRIO_COMMAND);
    assert_int_equal(cc.cls[2], UB_PRIO_CONTROL);
    /* A transport that shed two older frames to take this one: the frame counts as sent, the two as shed. */
    cc.rc = 2;
    uint64_t out_before = ub_node_link_counters(p->pub_node, p->pub_link)->frames_out;
    assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 13), 1);
    const ub_link_counters_t *lc = ub_node_link_counters(p->pub_node, p->pub_link);
    assert_int_equal(lc->frames_out, out_before + 1);
    assert_int_equal(lc->drops[UB_DROP_SHED], 2);
    assert_int_equal(ub_node_counters(p->pub_node)->drops[UB_DROP_SHED], 2);
    assert_string_equal(ub_drop_reason_name(UB_DROP_SHED), "shed");
    /* Push-back stays backpressure. */
    cc.rc = UB_ERR_AGAIN;
    assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 14), 0);
    assert_int_equal(ub_node_link_counters(p->pub_node, p->pub_link)->drops[UB_DROP_BACKPRESSURE], 1);
    assert_int_equal(ub_node_set_content_classes(p->pub_node, NULL, 0), UB_OK);
    pair_free(p);
}

/* ---- the configuration's "priorities" ---- */

static int parse_cfg(ub_nodecfg_t *cfg, const char *priorities, char *err, size_t cap) {
    char text[1024];
    (void)snprintf(text, sizeof text,
                   "{\"entities\": [{\"name\": \"a\", \"links\": [\"l0\"], \"linktoentity\": [\"0x00000000\"]}],\n"
                   " \"hosts\": [\"a\"],\n \"priorities\": %s}",
                   priorities);
    return ub_nodecfg_parse(cfg, text, strlen(text), "prio.json", err, cap);
}

static void test_config_priorities(void **state) {
    (void)state;
    ub_nodecfg_t *cfg = calloc(1, sizeof *cfg);
    assert_non_null(cfg);
    char err[UB_NODECFG_ERR_LEN];
    /* The first pattern in file order decides; unnamed contents are telemetry. */
    assert_int_equal(parse_cfg(cfg, "{\"gps*\": \"control\", \"*Out\": \"bulk\"}", err, sizeof err), UB_OK);
    pair_t *p = pair_new(NULL);
    uint8_t classes[8];
    size_t n = ub_test_cat.n_instances;
    assert_int_equal(ub_nodecfg_apply_priorities(cfg, p->pub_node, &ub_test_cat, classes, n, err, sizeof err), UB_OK);
    assert_int_equal(classes[TEST_GPS], UB_PRIO_CONTROL);
    assert_int_equal(classes[TEST_IMU], UB_PRIO_BULK);
    class_capture_t cc = {0};
    assert_int_equal(ub_node_link_attach(p->pub_node, p->pub_link, &cc_ops, &cc), UB_OK);
    assert_int_equal(ub_node_send_data(p->pub_node, p->pub, TEST_GPS, p->sub_id, 10), 1);
    assert_int_equal(cc.cls[0], UB_PRIO_CONTROL);
    /* A pattern that matches nothing is a mistake the operator hears of, with its line. */
    assert_int_equal(parse_cfg(cfg, "{\"gpsOut\": \"command\",\n \"gpsOutt\": \"bulk\"}", err, sizeof err), UB_OK);
    assert_int_equal(ub_nodecfg_apply_priorities(cfg, p->pub_node, &ub_test_cat, classes, n, err, sizeof err),
                     UB_ERR_CONFIG);
    assert_non_null(strstr(err, "prio.json:4: field 'priorities.gpsOutt': matches no content"));
    /* Refused at parse: an unknown class, a non-object, a bad pattern; each names file:line. */
    assert_int_equal(parse_cfg(cfg, "{\"gpsOut\": \"urgent\"}", err, sizeof err), UB_ERR_CONFIG);
    assert_non_null(strstr(err, "prio.json:3:"));
    assert_non_null(strstr(err, "\"command\", \"control\", \"telemetry\", \"bulk\""));
    assert_int_equal(parse_cfg(cfg, "[\"gpsOut\"]", err, sizeof err), UB_ERR_CONFIG);
    assert_int_equal(parse_cfg(cfg, "{\"gps Out\": \"bulk\"}", err, sizeof err), UB_ERR_CONFIG);
    /* No section: nothing applied, the node keeps its table. */
    assert_int_equal(parse_cfg(cfg, "{}", err, sizeof err), UB_OK);
    assert_int_equal(ub_nodecfg_apply_priorities(cfg, p->pub_node, &ub_test_cat, NULL, 0, err, sizeof err), UB_OK);
    pair_free(p);
    free(cfg);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_class_of_admin_codes),
        cmocka_unit_test(test_priority_order),
        cmocka_unit_test(test_per_class_bounds),
        cmocka_unit_test(test_fragments_never_delay_a_command_beyond_one_mtu),
        cmocka_unit_test(test_bulk_keeps_its_share_under_a_flood),
        cmocka_unit_test(test_drain_leaves_nothing_waiting),
        cmocka_unit_test(test_without_priorities_a_command_waits_behind_the_queue),
        cmocka_unit_test(test_node_derives_class_and_counts_sheds),
        cmocka_unit_test(test_config_priorities),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
