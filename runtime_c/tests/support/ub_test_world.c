#include "ub_test_world.h"

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "ub/ub_sec.h"
#include "ub/ub_wire.h"

/* ---- codecs, as the generator would write them --------------------------- */

static int pack_gps(const void *obj, uint8_t *buf, size_t cap) {
    const struct test_gps *g = obj;
    if (cap < 24) return UB_ERR_NOSPACE;
    ub_put_f64le(buf, g->lat);
    ub_put_f64le(buf + 8, g->lon);
    ub_put_f32le(buf + 16, g->alt);
    ub_put_u32le(buf + 20, g->fix);
    return 24;
}

static int unpack_gps(void *obj, const uint8_t *buf, size_t len) {
    struct test_gps *g = obj;
    if (len < 24) return UB_ERR_TRUNCATED;
    g->lat = ub_get_f64le(buf);
    g->lon = ub_get_f64le(buf + 8);
    g->alt = ub_get_f32le(buf + 16);
    g->fix = ub_get_u32le(buf + 20);
    return 24;
}

static int pack_gps_v2(const void *obj, uint8_t *buf, size_t cap) {
    const struct test_gps_v2 *g = obj;
    if (cap < 28) return UB_ERR_NOSPACE;
    ub_put_f64le(buf, g->lat);
    ub_put_f64le(buf + 8, g->lon);
    ub_put_f64le(buf + 16, g->alt);
    ub_put_u32le(buf + 24, g->fix);
    return 28;
}

static int unpack_gps_v2(void *obj, const uint8_t *buf, size_t len) {
    struct test_gps_v2 *g = obj;
    if (len < 28) return UB_ERR_TRUNCATED;
    g->lat = ub_get_f64le(buf);
    g->lon = ub_get_f64le(buf + 8);
    g->alt = ub_get_f64le(buf + 16);
    g->fix = ub_get_u32le(buf + 24);
    return 28;
}

static int pack_imu(const void *obj, uint8_t *buf, size_t cap) {
    const struct test_imu *m = obj;
    if (cap < 28) return UB_ERR_NOSPACE;
    for (int i = 0; i < 3; i++) {
        ub_put_f32le(buf + 4 * i, m->acc[i]);
        ub_put_f32le(buf + 12 + 4 * i, m->gyro[i]);
    }
    ub_put_u32le(buf + 24, m->t_ms);
    return 28;
}

static int unpack_imu(void *obj, const uint8_t *buf, size_t len) {
    struct test_imu *m = obj;
    if (len < 28) return UB_ERR_TRUNCATED;
    for (int i = 0; i < 3; i++) {
        m->acc[i] = ub_get_f32le(buf + 4 * i);
        m->gyro[i] = ub_get_f32le(buf + 12 + 4 * i);
    }
    m->t_ms = ub_get_u32le(buf + 24);
    return 28;
}

static int pack_new(const void *obj, uint8_t *buf, size_t cap) {
    const struct test_new *n = obj;
    if (cap < 8) return UB_ERR_NOSPACE;
    ub_put_u32le(buf, n->a);
    ub_put_u32le(buf + 4, n->b);
    return 8;
}

static int unpack_new(void *obj, const uint8_t *buf, size_t len) {
    struct test_new *n = obj;
    if (len < 8) return UB_ERR_TRUNCATED;
    n->a = ub_get_u32le(buf);
    n->b = ub_get_u32le(buf + 4);
    return 8;
}

/* Initialisers, not objects: C11 allows a const object's value in no static initialiser (GCC accepts it as an
 * extension; clang refuses, which the clang build of make test-cross found). */
#define GPS_TYPE {"struct test_gps", 0x6A1F0C21u, 24, sizeof(struct test_gps), pack_gps, unpack_gps}
#define GPS_V2_TYPE {"struct test_gps", 0x3B77D0E5u, 28, sizeof(struct test_gps_v2), pack_gps_v2, unpack_gps_v2}
#define IMU_TYPE {"struct test_imu", 0x1D2C3B4Au, 28, sizeof(struct test_imu), pack_imu, unpack_imu}
#define NEW_TYPE {"struct test_new", 0x0BADCAFEu, 8, sizeof(struct test_new), pack_new, unpack_new}

/* IDs under the paper's rule (first 8 + last 8 characters, 0x00-padded halves). */
#define ID_GPS "gpsOut\0\0gpsOut\0\0"
#define ID_IMU "imuOut\0\0imuOut\0\0"
#define ID_NEW "newMsg\0\0newMsg\0\0"

static const ub_type_desc_t base_types[] = {GPS_TYPE, IMU_TYPE};
static const ub_instance_desc_t base_instances[] = {
    {ID_GPS, "gpsOut", &base_types[0]},
    {ID_IMU, "imuOut", &base_types[1]},
};
const ub_catalogue_t ub_test_cat = {"test", UB_ID_SCHEME_PAPER, UB_CATALOGUE_ABI_VERSION, base_types, 2,
                                    base_instances, 2, 28, NULL, 0};

static const ub_type_desc_t newer_types[] = {GPS_TYPE, IMU_TYPE, NEW_TYPE};
static const ub_instance_desc_t newer_instances[] = {
    {ID_GPS, "gpsOut", &newer_types[0]},
    {ID_IMU, "imuOut", &newer_types[1]},
    {ID_NEW, "newMsg", &newer_types[2]},
};
const ub_catalogue_t ub_test_cat_newer = {"test_newer", UB_ID_SCHEME_PAPER, UB_CATALOGUE_ABI_VERSION, newer_types, 3,
                                          newer_instances, 3, 28, NULL, 0};

static const ub_type_desc_t changed_types[] = {GPS_V2_TYPE, IMU_TYPE};
static const ub_instance_desc_t changed_instances[] = {
    {ID_GPS, "gpsOut", &changed_types[0]},
    {ID_IMU, "imuOut", &changed_types[1]},
};
const ub_catalogue_t ub_test_cat_changed = {"test_changed", UB_ID_SCHEME_PAPER, UB_CATALOGUE_ABI_VERSION,
                                            changed_types, 2, changed_instances, 2, 28, NULL, 0};

void test_eid(const char *name, uint8_t out[UB_ENTITY_ID_LEN]) { assert_int_equal(ub_entity_id(name, out), UB_OK); }

/* ---- the world --------------------------------------------------------- */

world_t *world_new(void) {
    world_t *w = calloc(1, sizeof *w);
    assert_non_null(w);
    return w;
}

ub_node_t *world_node(world_t *w, const ub_catalogue_t *cat, const ub_node_options_t *opt) {
    assert_true(w->n_nodes < WORLD_MAX_NODES);
    ub_node_t *n = &w->nodes[w->n_nodes++];
    assert_int_equal(ub_node_init(n, cat, opt), UB_OK);
    return n;
}

ub_memlink_t *world_connect(world_t *w, ub_node_t *a, int la, ub_node_t *b, int lb,
                            const ub_memlink_faults_t *faults, uint64_t seed) {
    assert_true(w->n_links < WORLD_MAX_LINKS);
    ub_memlink_t *ml = &w->links[w->n_links++];
    ub_memlink_init(ml, faults, seed);
    assert_int_equal(ub_memlink_connect(ml, a, la, b, lb), UB_OK);
    return ml;
}

void world_run(world_t *w, uint64_t until_ms, uint64_t step_ms) {
    while (w->now_ms < until_ms) {
        w->now_ms += step_ms;
        for (size_t i = 0; i < w->n_nodes; i++) ub_node_tick(&w->nodes[i], w->now_ms);
        /* Relays queue onto the next memlink while pumping; bounded by the hop limit. */
        for (int round = 0; round < 64; round++) {
            size_t moved = 0;
            for (size_t l = 0; l < w->n_links; l++) moved += ub_memlink_pump(&w->links[l], w->now_ms);
            if (moved == 0) break;
        }
    }
}

void delivery_log_hook(void *user, int entity, uint32_t instance, const ub_frame_header_t *h, uint64_t now_ms) {
    delivery_log_t *log = user;
    assert_true(log->n < REC_MAX);
    log->d[log->n].entity = entity;
    log->d[log->n].instance = instance;
    log->d[log->n].seq = h->seq;
    memcpy(log->d[log->n].src, h->src_id, UB_ENTITY_ID_LEN);
    log->d[log->n].at_ms = now_ms;
    log->n++;
}

size_t delivery_count(const delivery_log_t *log, int entity, uint32_t instance, uint64_t from_ms, uint64_t to_ms) {
    size_t n = 0;
    for (size_t i = 0; i < log->n; i++)
        n += log->d[i].entity == entity && log->d[i].instance == instance && log->d[i].at_ms >= from_ms &&
             log->d[i].at_ms < to_ms;
    return n;
}

size_t delivery_repeats(const delivery_log_t *log) {
    size_t repeats = 0;
    for (size_t i = 0; i < log->n; i++) {
        for (size_t j = i + 1; j < log->n; j++) {
            if (log->d[i].entity == log->d[j].entity && log->d[i].instance == log->d[j].instance &&
                log->d[i].seq == log->d[j].seq && memcmp(log->d[i].src, log->d[j].src, UB_ENTITY_ID_LEN) == 0) {
                repeats++;
                break;
            }
        }
    }
    return repeats;
}

static int capture_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)now_ms;
    capture_t *cap = impl;
    if (cap->rc < 0) return cap->rc;
    assert_true(cap->n < CAPTURE_MAX);
    memcpy(cap->frame[cap->n], frame, len);
    cap->len[cap->n] = len;
    cap->n++;
    return UB_OK;
}

const ub_link_ops_t capture_ops = {.kind = "capture", .send = capture_send, .fileno = NULL};

size_t make_frame(uint8_t *out, ub_admin_code_t admin, const uint8_t dir_id[UB_DIR_ID_LEN], const char *src,
                  const char *dest, uint32_t seq, uint8_t hop_limit, uint32_t fingerprint, const uint8_t *payload,
                  uint16_t payload_len) {
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memcpy(h.dir_id, dir_id, UB_DIR_ID_LEN);
    test_eid(src, h.src_id);
    test_eid(dest, h.dest_id);
    h.admin = (uint8_t)admin;
    h.hop_limit = hop_limit;
    h.seq = seq;
    h.fingerprint = fingerprint;
    h.payload_size = payload_len;
    if (payload_len > 0) memcpy(out + UB_FRAME_HEADER_LEN, payload, payload_len);
    int len = ub_frame_finish(out, UB_FRAME_MAX, &h);
    assert_true(len > 0);
    return (size_t)len;
}

void test_sec_on(struct ub_sec *sec, ub_node_t *node, const uint8_t key[32], uint64_t wall, bool require) {
    assert_int_equal(ub_sec_init(sec, NULL), UB_OK);
    assert_int_equal(ub_sec_add_key(sec, 1, key), UB_OK);
    assert_int_equal(ub_sec_set_tx_key(sec, 1), UB_OK);
    assert_int_equal(ub_sec_start(sec, 0, wall), UB_OK);
    if (node == NULL) return;
    assert_int_equal(ub_node_set_security(node, sec), UB_OK);
    if (require) assert_int_equal(ub_node_set_require_signed(node, true), UB_OK);
}
