/*
 * Remote inspection (ub_inspect.h) on the in-memory test world: gcs -- relay -- fcs, so every request
 * and answer crosses two hops. The requester is gcs's ub_inspect_t; fcs's C router answers. Covered:
 * READ of a directory hosted only through the bind table (ub_node_bind_table), a hand binding taking
 * precedence, WRITE of one field, LIST of the tables, SET_PERIOD, a policy's refusal with its reason,
 * a request lost on the way and answered on a retry, and silence ending in FAILED with no reason.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "support/ub_test_world.h"
#include "ub/ub_frag.h"
#include "ub/ub_inspect.h"
#include "ub/ub_policy.h"
#include "ub/ub_pubsub.h"
#include "ub/ub_sec.h"
#include "ub/ub_service.h"
#include "ub/ub_wire.h"

typedef struct chain {
    world_t *w;
    ub_node_t *gcs_node, *relay_node, *fcs_node;
    int gcs, fcs;                 /* local entities in their nodes */
    uint8_t gcs_id[UB_ENTITY_ID_LEN], relay_id[UB_ENTITY_ID_LEN], fcs_id[UB_ENTITY_ID_LEN];
    ub_memlink_t *near;           /* gcs -- relay */
    ub_inspect_t in;              /* gcs's requester */
    struct test_imu imu;          /* fcs's imuOut: only in the bind table */
    struct test_gps gps_table, gps_hand;
    void *table[5];          /* one entry per catalogue instance; NULL: not defined by this program */
    ub_policy_t policy;
} chain_t;

static int add(ub_node_t *n, const uint8_t id[UB_ENTITY_ID_LEN], bool local) {
    int e = ub_node_add_entity(n, id, local);
    assert_true(e >= 0);
    return e;
}

/* gcs's node may be built from another catalogue than the relay's and fcs's (`gcs_cat`). */
static chain_t *chain_on_cats(const ub_catalogue_t *gcs_cat, const ub_catalogue_t *cat, uint32_t retry_ms,
                              uint32_t max_retries) {
    chain_t *c = test_calloc(1, sizeof *c);
    c->w = world_new();
    test_eid("gcs", c->gcs_id);
    test_eid("relay", c->relay_id);
    test_eid("fcs", c->fcs_id);
    c->gcs_node = world_node(c->w, gcs_cat, NULL);
    c->relay_node = world_node(c->w, cat, NULL);
    c->fcs_node = world_node(c->w, cat, NULL);
    /* gcs: link[0] to the relay, which carries everything */
    c->gcs = add(c->gcs_node, c->gcs_id, true);
    int g_relay = add(c->gcs_node, c->relay_id, false), g_fcs = add(c->gcs_node, c->fcs_id, false);
    int gl = ub_node_add_link(c->gcs_node, c->gcs, 0, "gcsPort");
    assert_int_equal(ub_node_set_mask(c->gcs_node, c->gcs, g_relay, 0x01), UB_OK);
    assert_int_equal(ub_node_set_mask(c->gcs_node, c->gcs, g_fcs, 0x01), UB_OK);
    /* relay: link[0] toward gcs, link[1] toward fcs */
    int relay = add(c->relay_node, c->relay_id, true);
    int r_gcs = add(c->relay_node, c->gcs_id, false), r_fcs = add(c->relay_node, c->fcs_id, false);
    int rl0 = ub_node_add_link(c->relay_node, relay, 0, "relayToGcs");
    int rl1 = ub_node_add_link(c->relay_node, relay, 1, "relayToFcs");
    assert_int_equal(ub_node_set_mask(c->relay_node, relay, r_gcs, 0x01), UB_OK);
    assert_int_equal(ub_node_set_mask(c->relay_node, relay, r_fcs, 0x02), UB_OK); /* link[1] */
    /* fcs: link[0] to the relay */
    c->fcs = add(c->fcs_node, c->fcs_id, true);
    int f_relay = add(c->fcs_node, c->relay_id, false), f_gcs = add(c->fcs_node, c->gcs_id, false);
    int fl = ub_node_add_link(c->fcs_node, c->fcs, 0, "fcsPort");
    assert_int_equal(ub_node_set_mask(c->fcs_node, c->fcs, f_relay, 0x01), UB_OK);
    assert_int_equal(ub_node_set_mask(c->fcs_node, c->fcs, f_gcs, 0x01), UB_OK);
    c->near = world_connect(c->w, c->gcs_node, gl, c->relay_node, rl0, NULL, 1);
    (void)world_connect(c->w, c->relay_node, rl1, c->fcs_node, fl, NULL, 2);
    /* fcs hosts both directories through its bind table, as NAME_bind_all() does; no hand binding */
    c->imu = (struct test_imu){{0.1f, 0.2f, 9.81f}, {0.0f, 0.0f, 0.5f}, 123456u};
    c->gps_table = (struct test_gps){33.78, -84.40, 300.0f, 3};
    c->table[TEST_GPS] = &c->gps_table;
    c->table[TEST_IMU] = &c->imu;
    assert_int_equal(ub_node_bind_table(c->fcs_node, c->table, cat->n_instances), 2); /* both hosted */
    ub_inspect_options_t opt = {.retry_ms = retry_ms, .max_retries = max_retries};
    assert_int_equal(ub_inspect_init(&c->in, c->gcs_node, c->gcs, &opt), UB_OK);
    return c;
}

static chain_t *chain_on(const ub_catalogue_t *cat, uint32_t retry_ms, uint32_t max_retries) {
    return chain_on_cats(cat, cat, retry_ms, max_retries);
}

static chain_t *chain_new(uint32_t retry_ms, uint32_t max_retries) {
    return chain_on(&ub_test_cat, retry_ms, max_retries);
}

static void chain_free(chain_t *c) {
    free(c->w);
    test_free(c);
}

/* Queues a request to fcs and runs the world until it is no longer pending (or `ms` pass). */
static ub_inspect_result_t ask(chain_t *c, ub_inspect_spec_t s, uint64_t ms) {
    memcpy(s.target, c->fcs_id, UB_ENTITY_ID_LEN);
    int row = ub_inspect_request(&c->in, &s, c->w->now_ms);
    assert_true(row >= 0);
    ub_inspect_result_t r;
    uint64_t until = c->w->now_ms + ms;
    do {
        world_run(c->w, c->w->now_ms + 1, 1);
        assert_int_equal(ub_inspect_result(&c->in, row, &r), UB_OK);
    } while (r.status == UB_INSPECT_PENDING && c->w->now_ms < until);
    assert_int_equal(ub_inspect_forget(&c->in, row), UB_OK);
    return r;
}

static void packed(const ub_node_t *n, uint32_t instance, const void *obj, uint8_t *out, size_t *len) {
    const ub_type_desc_t *t = n->cat->instances[instance].type;
    *len = t->packed_size;
    if (t->pack != NULL) {
        assert_int_equal(t->pack(obj, out, UB_MAX_PAYLOAD), (int)t->packed_size);
    } else {
        memcpy(out, obj, t->packed_size);
    }
}

static void test_read_through_bind_table_and_hand_binding_first(void **state) {
    (void)state;
    chain_t *c = chain_new(0, 0);
    uint8_t want[UB_MAX_PAYLOAD];
    size_t len;
    ub_inspect_result_t r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_READ, .instance = TEST_IMU}, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    packed(c->fcs_node, TEST_IMU, &c->imu, want, &len);
    assert_int_equal(r.total, len);
    assert_int_equal(r.next, UB_INSPECT_END);
    assert_int_equal(r.len, len);
    assert_memory_equal(r.data, want, len);
    assert_int_equal(r.attempts, 1);
    /* A hand binding of gpsOut takes precedence over the table's storage. */
    c->gps_hand = (struct test_gps){-1.0, 2.0, 3.0f, 9};
    assert_int_equal(ub_node_bind(c->fcs_node, TEST_GPS, &c->gps_hand), UB_OK);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_READ, .instance = TEST_GPS}, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    packed(c->fcs_node, TEST_GPS, &c->gps_hand, want, &len);
    assert_memory_equal(r.data, want, len);
    assert_int_equal(ub_node_counters(c->fcs_node)->inspect_served, 2);
    chain_free(c);
}

/* The test catalogue plus a directory above UB_MAX_PAYLOAD (what fragments carry, up to UB_MAX_DIRECTORY):
 * its ID sorts last, so gpsOut and imuOut keep their indices. Wire-image storage (pack == NULL). */
#define BIG_SIZE (UB_MAX_PAYLOAD + 976u)
#define TEST_BIG 2
static const ub_type_desc_t big_types[] = {
    {"struct big", 0x0B16B16Bu, BIG_SIZE, BIG_SIZE, NULL, NULL},
};
static ub_instance_desc_t big_instances[3];
static ub_catalogue_t big_cat;

static const ub_catalogue_t *catalogue_with_big(void) {
    big_instances[0] = ub_test_cat.instances[0];
    big_instances[1] = ub_test_cat.instances[1];
    big_instances[2] = (ub_instance_desc_t){"zBigBlobzBigBlob", "zBigBlob", &big_types[0]}; /* paper rule */
    big_cat = ub_test_cat;
    big_cat.instances = big_instances;
    big_cat.n_instances = 3;
    big_cat.max_packed_size = BIG_SIZE;
    return &big_cat;
}

static void test_a_directory_above_the_payload_limit_is_refused_not_overrun(void **state) {
    (void)state;
    chain_t *c = chain_on(catalogue_with_big(), 0, 0);
    static uint8_t big[BIG_SIZE];
    memset(big, 0xA5, sizeof big);
    assert_int_equal(ub_node_bind(c->fcs_node, TEST_BIG, big), UB_OK);
    ub_inspect_result_t r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_READ, .instance = TEST_BIG}, 1000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_UNSUPPORTED);
    /* a write at an offset past UB_MAX_PAYLOAD (inside the type) is refused the same way, storage untouched */
    ub_inspect_spec_t s = {.op = UB_INSPECT_WRITE, .instance = TEST_BIG, .offset = BIG_SIZE - 4, .len = 4};
    memset(s.data, 0x11, 4);
    r = ask(c, s, 1000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_UNSUPPORTED);
    assert_int_equal(big[BIG_SIZE - 1], 0xA5);
    /* the small directories of the same node stay readable */
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_READ, .instance = TEST_IMU}, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    chain_free(c);
}

static void test_write_one_field_leaves_the_others(void **state) {
    (void)state;
    chain_t *c = chain_new(0, 0);
    struct test_imu before = c->imu;
    uint8_t t_ms[4];
    ub_put_u32le(t_ms, 777u); /* t_ms: the last field, at byte 24 of the packed image */
    ub_inspect_spec_t s = {.op = UB_INSPECT_WRITE, .instance = TEST_IMU, .offset = 24, .len = 4};
    memcpy(s.data, t_ms, 4);
    ub_inspect_result_t r = ask(c, s, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_true(r.changed);
    assert_int_equal(c->imu.t_ms, 777u);
    assert_memory_equal(c->imu.acc, before.acc, sizeof before.acc);
    assert_memory_equal(c->imu.gyro, before.gyro, sizeof before.gyro);
    r = ask(c, s, 1000); /* idempotent: the same write again changes nothing */
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_false(r.changed);
    /* a write reaching past the image's end is refused whole, the storage untouched */
    s.offset = 26;
    r = ask(c, s, 1000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_INVALID);
    assert_int_equal(c->imu.t_ms, 777u);
    chain_free(c);
}

static void test_list_tables_and_set_period(void **state) {
    (void)state;
    chain_t *c = chain_new(0, 0);
    /* gcs subscribes to fcs's gpsOut: fcs gets a publication row toward gcs */
    assert_true(ub_pubsub_subscribe(c->gcs_node, c->gcs, TEST_GPS, c->fcs_id, 100, 0) >= 0);
    static struct test_gps gps_at_gcs;
    assert_int_equal(ub_node_bind(c->gcs_node, TEST_GPS, &gps_at_gcs), UB_OK);
    world_run(c->w, c->w->now_ms + 300, 1);

    ub_inspect_result_t r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_LIST, .arg = UB_INSPECT_ENTITIES}, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_int_equal(r.total, 3);
    assert_int_equal(r.len, 3 * UB_INSPECT_ENTITY_REC);
    assert_memory_equal(r.data, c->fcs_id, UB_ENTITY_ID_LEN); /* fcs itself, local */
    assert_int_equal(r.data[12], 1);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_LIST, .arg = UB_INSPECT_LINKS}, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_int_equal(r.total, 1);
    assert_string_equal((const char *)r.data, "fcsPort");
    assert_true(ub_get_u32le(r.data + 36) > 0); /* frames_in */
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_LIST, .arg = UB_INSPECT_PUBSUB}, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_int_equal(r.total, 1);
    uint16_t row = ub_get_u16le(r.data);
    assert_int_equal(r.data[2], UB_PS_PUBLICATION);
    assert_memory_equal(r.data + 20, c->gcs_id, UB_ENTITY_ID_LEN);
    assert_int_equal(ub_get_u32le(r.data + 44), 100);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_LIST, .arg = UB_INSPECT_ADMIN}, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_int_equal(r.total, 0);

    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_SET_PERIOD, .offset = row, .value = 20}, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_true(r.changed);
    assert_int_equal(ub_pubsub_row(c->fcs_node, c->fcs, row)->period_ms, 20);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_SET_PERIOD, .offset = 40, .value = 20}, 1000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_NO_SUCH_ROW);
    chain_free(c);
}

static void test_policy_refusal_has_its_reason(void **state) {
    (void)state;
    chain_t *c = chain_new(0, 0);
    ub_policy_init(&c->policy);
    assert_int_equal(ub_policy_add_admin(&c->policy, c->relay_id), UB_OK); /* not gcs */
    ub_node_set_policy(c->fcs_node, &c->policy);
    uint32_t t_ms = c->imu.t_ms;
    ub_inspect_spec_t w = {.op = UB_INSPECT_WRITE, .instance = TEST_IMU, .offset = 24, .len = 4};
    ub_inspect_result_t r = ask(c, w, 1000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_NOT_AUTHORIZED);
    assert_int_equal(c->imu.t_ms, t_ms);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_LIST, .arg = UB_INSPECT_LINKS}, 1000);
    assert_int_equal(r.nack_reason, UB_NACK_NOT_AUTHORIZED);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_READ, .instance = TEST_IMU}, 1000); /* reads stay open */
    assert_int_equal(r.status, UB_INSPECT_DONE);
    /* a write rule grants gcs that one content */
    assert_int_equal(ub_policy_add_rule(&c->policy, UB_POLICY_WRITE, "fcs", "gcs", "imuOut"), UB_OK);
    r = ask(c, w, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    const ub_node_counters_t *k = ub_node_counters(c->fcs_node);
    assert_int_equal(k->inspect_refused, 2);
    assert_int_equal(k->drops[UB_DROP_NOT_AUTHORIZED], 2);
    chain_free(c);
}

static void test_retry_after_loss_and_silence(void **state) {
    (void)state;
    chain_t *c = chain_new(50, 0);
    c->near->faults.loss_ppm = 1000000u; /* everything lost between gcs and the relay */
    ub_inspect_spec_t s = {.op = UB_INSPECT_READ, .instance = TEST_IMU};
    memcpy(s.target, c->fcs_id, UB_ENTITY_ID_LEN);
    int row = ub_inspect_request(&c->in, &s, c->w->now_ms);
    assert_true(row >= 0);
    world_run(c->w, c->w->now_ms + 120, 1);
    ub_inspect_result_t r;
    assert_int_equal(ub_inspect_result(&c->in, row, &r), UB_OK);
    assert_int_equal(r.status, UB_INSPECT_PENDING);
    assert_true(r.attempts >= 2);
    c->near->faults.loss_ppm = 0; /* the link comes back: the next retry is answered */
    world_run(c->w, c->w->now_ms + 60, 1);
    assert_int_equal(ub_inspect_result(&c->in, row, &r), UB_OK);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_true(r.attempts >= 3);
    assert_int_equal(r.total, c->fcs_node->cat->instances[TEST_IMU].type->packed_size);
    assert_int_equal(ub_inspect_forget(&c->in, row), UB_OK);
    chain_free(c);

    /* with max_retries, silence ends in FAILED with no NACK reason (Python: NoAnswerError) */
    c = chain_new(50, 3);
    c->near->faults.loss_ppm = 1000000u;
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_READ, .instance = TEST_IMU}, 2000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_NONE);
    assert_int_equal(r.attempts, 3);
    chain_free(c);
}

/* SET_MASK answered with whether it changed anything, and refused for an entity the node does not know; an
 * ADMIN_ROW change refused on a node with no administration table (issue #29 item 6: every refusal counted). */
static void test_set_mask_and_admin_row_refusals(void **state) {
    (void)state;
    chain_t *c = chain_new(0, 0);
    int f_relay = ub_node_find_entity(c->fcs_node, c->relay_id);
    assert_true(f_relay >= 0);
    ub_inspect_spec_t m = {.op = UB_INSPECT_SET_MASK, .value = 0x00};
    memcpy(m.subject, c->relay_id, UB_ENTITY_ID_LEN);
    ub_inspect_result_t r = ask(c, m, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_true(r.changed);
    uint8_t mask = 0xFF;
    assert_int_equal(ub_node_get_mask(c->fcs_node, c->fcs, f_relay, &mask), UB_OK);
    assert_int_equal(mask, 0x00);
    r = ask(c, m, 1000); /* the same mask again: done, nothing changed */
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_false(r.changed);
    test_eid("nobody", m.subject);
    r = ask(c, m, 1000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_NO_SUCH_ROW);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_ADMIN_ROW, .arg = UB_INSPECT_ADMIN_PERIOD, .value = 50}, 1000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_NO_SUCH_ROW);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_SET_PERIOD, .offset = UB_MAX_PUBSUB_ROWS, .value = 5}, 1000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_NO_SUCH_ROW);
    const ub_node_counters_t *k = ub_node_counters(c->fcs_node);
    assert_int_equal(k->inspect_served, 2);
    assert_int_equal(k->inspect_refused, 3);
    const ub_inspect_counters_t *ic = ub_inspect_counters(&c->in);
    assert_non_null(ic);
    assert_int_equal(ic->done, 2);
    assert_int_equal(ic->failed, 3);
    assert_null(ub_inspect_counters(NULL));
    chain_free(c);
}

/* A directory the answering node hosts nowhere: refused UNBOUND, not read from nowhere. */
static void test_read_of_an_unbound_directory_is_refused(void **state) {
    (void)state;
    chain_t *c = chain_on(catalogue_with_big(), 0, 0); /* zBigBlob: in the catalogue, bound by no one */
    ub_inspect_result_t r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_READ, .instance = TEST_BIG}, 1000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_UNBOUND);
    assert_int_equal(ub_node_counters(c->fcs_node)->inspect_refused, 1);
    chain_free(c);
}

/* Requests the requester refuses before sending anything (ub_inspect_request's contract), the row table's
 * bound, the names, and detaching. */
static void test_request_refusals_and_bounds(void **state) {
    (void)state;
    chain_t *c = chain_new(0, 0);
    uint64_t now = c->w->now_ms;
    ub_inspect_spec_t ok = {.op = UB_INSPECT_READ, .instance = TEST_IMU};
    memcpy(ok.target, c->fcs_id, UB_ENTITY_ID_LEN);
    ub_inspect_spec_t s = ok;
    memset(s.target, 0, UB_ENTITY_ID_LEN); /* no target */
    assert_int_equal(ub_inspect_request(&c->in, &s, now), UB_ERR_INVAL);
    s = ok;
    s.instance = c->gcs_node->cat->n_instances;
    assert_int_equal(ub_inspect_request(&c->in, &s, now), UB_ERR_INVAL);
    s = ok;
    s.op = UB_INSPECT_WRITE;
    s.len = 0;
    assert_int_equal(ub_inspect_request(&c->in, &s, now), UB_ERR_INVAL);
    s.len = UB_INSPECT_CHUNK + 1;
    assert_int_equal(ub_inspect_request(&c->in, &s, now), UB_ERR_INVAL);
    s.len = 1;
    s.instance = c->gcs_node->cat->n_instances;
    assert_int_equal(ub_inspect_request(&c->in, &s, now), UB_ERR_INVAL);
    s = ok;
    s.op = UB_INSPECT_LIST;
    s.arg = 0;
    assert_int_equal(ub_inspect_request(&c->in, &s, now), UB_ERR_INVAL);
    s.arg = UB_INSPECT_ADMIN + 1;
    assert_int_equal(ub_inspect_request(&c->in, &s, now), UB_ERR_INVAL);
    s = ok;
    s.op = UB_INSPECT_SET_PERIOD;
    s.value = 0;
    assert_int_equal(ub_inspect_request(&c->in, &s, now), UB_ERR_INVAL);
    s = ok;
    s.op = UB_INSPECT_SET_MASK; /* subject left zero */
    assert_int_equal(ub_inspect_request(&c->in, &s, now), UB_ERR_INVAL);
    memcpy(s.subject, c->relay_id, UB_ENTITY_ID_LEN);
    s.value = 0x100;
    assert_int_equal(ub_inspect_request(&c->in, &s, now), UB_ERR_INVAL);
    s = ok;
    s.op = UB_INSPECT_ADMIN_ROW;
    s.arg = 0;
    assert_int_equal(ub_inspect_request(&c->in, &s, now), UB_ERR_INVAL);
    s.op = 0x7F;
    assert_int_equal(ub_inspect_request(&c->in, &s, now), UB_ERR_INVAL);
    assert_int_equal(ub_inspect_request(&c->in, NULL, now), UB_ERR_INVAL);
    assert_int_equal(ub_inspect_request(NULL, &ok, now), UB_ERR_INVAL);
    assert_int_equal(ub_inspect_counters(&c->in)->sent, 0);

    /* The row table's bound, then rows that do not exist. */
    for (int i = 0; i < UB_MAX_INSPECT_REQUESTS; i++) assert_int_equal(ub_inspect_request(&c->in, &ok, now), i);
    assert_int_equal(ub_inspect_request(&c->in, &ok, now), UB_ERR_FULL);
    ub_inspect_result_t r;
    assert_int_equal(ub_inspect_result(&c->in, -1, &r), UB_ERR_NOTFOUND);
    assert_int_equal(ub_inspect_result(&c->in, UB_MAX_INSPECT_REQUESTS, &r), UB_ERR_NOTFOUND);
    assert_int_equal(ub_inspect_result(&c->in, 0, NULL), UB_ERR_NOTFOUND);
    assert_int_equal(ub_inspect_result(NULL, 0, &r), UB_ERR_NOTFOUND);
    assert_int_equal(ub_inspect_forget(&c->in, 0), UB_OK);
    assert_int_equal(ub_inspect_forget(&c->in, 0), UB_ERR_NOTFOUND);
    assert_int_equal(ub_inspect_result(&c->in, 0, &r), UB_ERR_NOTFOUND);
    assert_int_equal(ub_inspect_forget(&c->in, UB_MAX_INSPECT_REQUESTS), UB_ERR_NOTFOUND);
    assert_int_equal(ub_inspect_forget(NULL, 1), UB_ERR_NOTFOUND);

    assert_string_equal(ub_inspect_op_name(UB_INSPECT_READ), "read");
    assert_string_equal(ub_inspect_op_name(UB_INSPECT_ADMIN_ROW), "admin_row");
    assert_string_equal(ub_inspect_op_name((ub_inspect_op_t)0), "?");
    assert_string_equal(ub_inspect_op_name((ub_inspect_op_t)99), "?");
    assert_string_equal(ub_inspect_status_name(UB_INSPECT_DONE), "done");
    assert_string_equal(ub_inspect_status_name((ub_inspect_status_t)99), "?");

    /* Detached, the requester takes no more requests; the node goes on serving (a request from fcs's
     * side is answered by gcs's node). */
    ub_inspect_detach(&c->in);
    assert_int_equal(ub_inspect_request(&c->in, &ok, now), UB_ERR_INVAL);
    ub_inspect_detach(&c->in); /* twice: nothing */
    ub_inspect_detach(NULL);
    ub_inspect_t back;
    assert_int_equal(ub_inspect_init(&back, c->fcs_node, c->fcs, NULL), UB_OK);
    assert_int_equal(back.opt.retry_ms, 200u); /* the default */
    ub_inspect_spec_t list = {.op = UB_INSPECT_LIST, .arg = UB_INSPECT_ENTITIES};
    memcpy(list.target, c->gcs_id, UB_ENTITY_ID_LEN);
    int row = ub_inspect_request(&back, &list, c->w->now_ms);
    assert_true(row >= 0);
    world_run(c->w, c->w->now_ms + 100, 1);
    assert_int_equal(ub_inspect_result(&back, row, &r), UB_OK);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_int_equal(r.total, 3);
    assert_int_equal(ub_node_counters(c->gcs_node)->inspect_served, 1);
    assert_int_equal(ub_inspect_init(NULL, c->fcs_node, c->fcs, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_inspect_init(&back, NULL, c->fcs, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_inspect_init(&back, c->fcs_node, 99, NULL), UB_ERR_INVAL);
    chain_free(c);
}

/* A reply to a request forgotten before it came (the operator gave up on it) is counted unmatched, never
 * taken as an answer to another row. A read from an offset inside the image returns the rest; one at its
 * end is refused NO_SUCH_ROW. */
static void test_duplicate_replies_and_read_offsets(void **state) {
    (void)state;
    chain_t *c = chain_new(0, 0);
    size_t size = c->fcs_node->cat->instances[TEST_IMU].type->packed_size;
    ub_inspect_result_t r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_READ, .instance = TEST_IMU, .offset = 24}, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_int_equal(r.len, size - 24);
    assert_int_equal(ub_get_u32le(r.data), c->imu.t_ms);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_READ, .instance = TEST_IMU, .offset = (uint16_t)size}, 1000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_NO_SUCH_ROW);
    ub_inspect_spec_t s = {.op = UB_INSPECT_READ, .instance = TEST_IMU};
    memcpy(s.target, c->fcs_id, UB_ENTITY_ID_LEN);
    c->near->faults.delay_ms = 50; /* the request is in flight for a while */
    int row = ub_inspect_request(&c->in, &s, c->w->now_ms);
    assert_true(row >= 0);
    world_run(c->w, c->w->now_ms + 5, 1); /* sent, not yet answered */
    assert_int_equal(ub_inspect_result(&c->in, row, &r), UB_OK);
    assert_int_equal(r.status, UB_INSPECT_PENDING);
    assert_int_equal(ub_inspect_forget(&c->in, row), UB_OK);
    world_run(c->w, c->w->now_ms + 200, 1);
    assert_int_equal(ub_inspect_counters(&c->in)->unmatched_replies, 1);
    assert_int_equal(ub_inspect_counters(&c->in)->done, 1);
    chain_free(c);
}

/* A directory above UB_MAX_PAYLOAD sent from fcs (issue #29 item 6, ub_node_wire.c): to another entity of the
 * same node it is handed over whole, which needs fragment state (a transmit slot holds the image): without
 * it refused UB_ERR_RANGE and counted too_big; to an entity with no route, refused UB_ERR_NOROUTE and counted
 * no_route; over a link without fragment state, refused too_big. */
static void test_big_directory_local_unrouted_and_without_fragments(void **state) {
    (void)state;
    chain_t *c = chain_on(catalogue_with_big(), 0, 0);
    static uint8_t big[BIG_SIZE];
    memset(big, 0x3C, sizeof big);
    assert_int_equal(ub_node_bind(c->fcs_node, TEST_BIG, big), UB_OK);
    uint8_t peer_id[UB_ENTITY_ID_LEN], nobody[UB_ENTITY_ID_LEN];
    test_eid("fcs2", peer_id);
    test_eid("nobody", nobody);
    assert_true(ub_node_add_entity(c->fcs_node, peer_id, true) >= 0);
    const ub_node_counters_t *k = ub_node_counters(c->fcs_node);
    uint64_t now = c->w->now_ms;
    uint64_t too_big = k->drops[UB_DROP_TOO_BIG], no_route = k->drops[UB_DROP_NO_ROUTE];
    assert_int_equal(ub_node_send_data(c->fcs_node, c->fcs, TEST_BIG, peer_id, now), UB_ERR_RANGE);
    assert_int_equal(k->drops[UB_DROP_TOO_BIG], too_big + 1);
    assert_int_equal(ub_node_send_data(c->fcs_node, c->fcs, TEST_BIG, c->gcs_id, now), UB_ERR_RANGE); /* a link */
    assert_int_equal(k->drops[UB_DROP_TOO_BIG], too_big + 2);
    assert_int_equal(ub_node_send_data(c->fcs_node, c->fcs, TEST_BIG, nobody, now), UB_ERR_NOROUTE);
    assert_int_equal(k->drops[UB_DROP_NO_ROUTE], no_route + 1);
    static ub_frag_t frag;
    ub_frag_init(&frag, NULL, 1);
    assert_int_equal(ub_node_set_frag(c->fcs_node, &frag), UB_OK);
    assert_true(ub_node_send_data(c->fcs_node, c->fcs, TEST_BIG, peer_id, now) >= 0); /* handed over whole */
    assert_int_equal(k->drops[UB_DROP_TOO_BIG], too_big + 2);
    chain_free(c);
}

/* ---- edges (issue #29 item 6) ------------------------------------------------------------------------ */

/* The big catalogue plus zzImage, a wire-image directory of exactly UB_MAX_PAYLOAD bytes (read in two
 * chunks), and zzzFlag, a codec type whose `on` byte is a bool its codec refuses outside 0..1. */
#define TEST_IMAGE 3
#define TEST_FLAG 4
struct test_flag {
    uint32_t n;
    uint8_t on;
};
static int pack_flag(const void *obj, uint8_t *buf, size_t cap) {
    const struct test_flag *v = obj;
    if (cap < 5u) return UB_ERR_NOSPACE;
    if (v->on > 1) return UB_ERR_RANGE;
    ub_put_u32le(buf, v->n);
    buf[4] = v->on;
    return 5;
}
static int unpack_flag(void *obj, const uint8_t *buf, size_t len) {
    struct test_flag *v = obj;
    if (len < 5u || buf[4] > 1) return UB_ERR_RANGE;
    v->n = ub_get_u32le(buf);
    v->on = buf[4];
    return 5;
}
static const ub_type_desc_t edge_types[] = {
    {"struct image", 0x1A6E1A6Eu, UB_MAX_PAYLOAD, UB_MAX_PAYLOAD, NULL, NULL},
    {"struct test_flag", 0xF1A6F1A6u, 5, sizeof(struct test_flag), pack_flag, unpack_flag},
};
static ub_instance_desc_t edge_instances[5];
static ub_catalogue_t edge_cat;

static const ub_catalogue_t *catalogue_with_edges(void) {
    (void)catalogue_with_big();
    memcpy(edge_instances, big_instances, sizeof big_instances);
    edge_instances[TEST_IMAGE] = (ub_instance_desc_t){.name = "zzImage", .type = &edge_types[0]};
    edge_instances[TEST_FLAG] = (ub_instance_desc_t){.name = "zzzFlag", .type = &edge_types[1]};
    ub_dir_id_paper("zzImage", edge_instances[TEST_IMAGE].id);
    ub_dir_id_paper("zzzFlag", edge_instances[TEST_FLAG].id);
    for (int i = 1; i < 5; i++) assert_true(memcmp(edge_instances[i - 1].id, edge_instances[i].id, UB_DIR_ID_LEN) < 0);
    edge_cat = big_cat;
    edge_cat.instances = edge_instances;
    edge_cat.n_instances = 5;
    return &edge_cat;
}

/* A frame as `src` would send it, handed to `node` on link `link`. */
static void inject(ub_node_t *node, const char *link, ub_admin_code_t code, const char *src, const char *dest,
                   uint32_t seq, const uint8_t *payload, uint16_t len, uint64_t now_ms) {
    uint8_t f[UB_FRAME_MAX], dir[UB_DIR_ID_LEN] = {0};
    size_t n = make_frame(f, code, dir, src, dest, seq, 8, 0, payload, len);
    int l = ub_node_find_link(node, link);
    assert_true(l >= 0);
    assert_int_equal(ub_node_rx_frame(node, l, f, n, now_ms), UB_OK);
}

static int request_to_fcs(chain_t *c, ub_inspect_spec_t s) {
    memcpy(s.target, c->fcs_id, UB_ENTITY_ID_LEN);
    int row = ub_inspect_request(&c->in, &s, c->w->now_ms);
    assert_true(row >= 0);
    return row;
}

static ub_inspect_status_t status_of(const chain_t *c, int row) {
    ub_inspect_result_t r;
    assert_int_equal(ub_inspect_result(&c->in, row, &r), UB_OK);
    return r.status;
}

/* A pending request is the requester's next due time (its retry), the earliest of several; an answer counts
 * only from the row's target, to the requesting entity, with the row's operation and offset, while pending:
 * anything else is an unmatched reply and leaves the row as it was. A value nobody asked for at a node
 * without a requester is dropped bad_payload, as is a value too short to carry its head. */
static void test_pending_rows_due_and_answers_bound_to_their_request(void **state) {
    (void)state;
    chain_t *c = chain_new(100, 0);
    c->near->faults.loss_ppm = 1000000u; /* nothing real reaches fcs: the answers below are the test's */
    uint8_t gcs2_id[UB_ENTITY_ID_LEN];
    test_eid("gcs2", gcs2_id);
    assert_true(ub_node_add_entity(c->gcs_node, gcs2_id, true) >= 0);
    world_run(c->w, 1000, 1);
    int row = request_to_fcs(c, (ub_inspect_spec_t){.op = UB_INSPECT_READ, .instance = TEST_IMU, .offset = 4});
    assert_int_equal(ub_node_next_due(c->gcs_node, 1000), 1000); /* due at once */
    world_run(c->w, 1001, 1);                                     /* sent at the tick of 1001 */
    assert_int_equal(ub_node_next_due(c->gcs_node, 1001), 1101);
    world_run(c->w, 1030, 1);
    int later = request_to_fcs(c, (ub_inspect_spec_t){.op = UB_INSPECT_LIST, .arg = UB_INSPECT_LINKS});
    world_run(c->w, 1031, 1); /* sent at 1031: due 1131, after the first row's 1101 */
    assert_int_equal(ub_node_next_due(c->gcs_node, 1031), 1101);
    assert_int_equal(ub_node_next_due(c->gcs_node, 1150), 1150); /* overdue: now */
    ub_inspect_result_t res;
    assert_int_equal(ub_inspect_result(&c->in, row, &res), UB_OK);
    uint8_t v[UB_INSPECT_VAL_DATA + 4] = {0};
    uint64_t now = c->w->now_ms;
    const ub_inspect_counters_t *k = ub_inspect_counters(&c->in);
    /* from another entity than the target */
    ub_inspect_put_value_head(v, res.request_id, UB_INSPECT_READ, 0, 4, 28, UB_INSPECT_END);
    inject(c->gcs_node, "gcsPort", UB_ADMIN_INSPECT_VALUE, "relay", "gcs", 50001, v, sizeof v, now);
    assert_int_equal(k->unmatched_replies, 1);
    /* to another local entity than the requester */
    inject(c->gcs_node, "gcsPort", UB_ADMIN_INSPECT_VALUE, "fcs", "gcs2", 50002, v, sizeof v, now);
    assert_int_equal(k->unmatched_replies, 2);
    /* another operation, another offset */
    ub_inspect_put_value_head(v, res.request_id, UB_INSPECT_LIST, 0, 4, 28, UB_INSPECT_END);
    inject(c->gcs_node, "gcsPort", UB_ADMIN_INSPECT_VALUE, "fcs", "gcs", 50003, v, sizeof v, now);
    ub_inspect_put_value_head(v, res.request_id, UB_INSPECT_READ, 0, 0, 28, UB_INSPECT_END);
    inject(c->gcs_node, "gcsPort", UB_ADMIN_INSPECT_VALUE, "fcs", "gcs", 50004, v, sizeof v, now);
    assert_int_equal(k->unmatched_replies, 4);
    assert_int_equal(status_of(c, row), UB_INSPECT_PENDING);
    /* too short for a value's head: unusable, not an answer */
    uint64_t bad = ub_node_counters(c->gcs_node)->drops[UB_DROP_BAD_PAYLOAD];
    inject(c->gcs_node, "gcsPort", UB_ADMIN_INSPECT_VALUE, "fcs", "gcs", 50005, v, UB_INSPECT_VAL_DATA - 1, now);
    assert_int_equal(ub_node_counters(c->gcs_node)->drops[UB_DROP_BAD_PAYLOAD], bad + 1);
    assert_int_equal(status_of(c, row), UB_INSPECT_PENDING);
    /* the answer: from fcs, to gcs, READ at 4 */
    ub_inspect_put_value_head(v, res.request_id, UB_INSPECT_READ, 0, 4, 28, UB_INSPECT_END);
    v[UB_INSPECT_VAL_DATA] = 0x5A;
    inject(c->gcs_node, "gcsPort", UB_ADMIN_INSPECT_VALUE, "fcs", "gcs", 50006, v, sizeof v, now);
    assert_int_equal(ub_inspect_result(&c->in, row, &res), UB_OK);
    assert_int_equal(res.status, UB_INSPECT_DONE);
    assert_int_equal(res.len, 4);
    assert_int_equal(res.data[0], 0x5A);
    assert_int_equal(res.total, 28);
    /* the same answer again: the row is no longer pending */
    inject(c->gcs_node, "gcsPort", UB_ADMIN_INSPECT_VALUE, "fcs", "gcs", 50007, v, sizeof v, now);
    assert_int_equal(k->unmatched_replies, 5);
    assert_int_equal(k->done, 1);
    assert_int_equal(status_of(c, later), UB_INSPECT_PENDING);
    /* fcs has no requester: a value is nobody's answer */
    bad = ub_node_counters(c->fcs_node)->drops[UB_DROP_BAD_PAYLOAD];
    inject(c->fcs_node, "fcsPort", UB_ADMIN_INSPECT_VALUE, "gcs", "fcs", 50008, v, sizeof v, now);
    assert_int_equal(ub_node_counters(c->fcs_node)->drops[UB_DROP_BAD_PAYLOAD], bad + 1);
    chain_free(c);
}

/* An ACK for a WRITE the operator forgot before it came back is unmatched, not taken by another row. */
static void test_ack_for_a_forgotten_write_is_unmatched(void **state) {
    (void)state;
    chain_t *c = chain_new(0, 0);
    c->near->faults.delay_ms = 50;
    ub_inspect_spec_t w = {.op = UB_INSPECT_WRITE, .instance = TEST_IMU, .offset = 24, .len = 4};
    ub_put_u32le(w.data, 4242u);
    int row = request_to_fcs(c, w);
    world_run(c->w, c->w->now_ms + 5, 1);
    assert_int_equal(ub_inspect_forget(&c->in, row), UB_OK);
    int other = request_to_fcs(c, (ub_inspect_spec_t){.op = UB_INSPECT_LIST, .arg = UB_INSPECT_ENTITIES});
    world_run(c->w, c->w->now_ms + 300, 1);
    assert_int_equal(c->imu.t_ms, 4242u); /* the write itself was done */
    assert_int_equal(ub_inspect_counters(&c->in)->unmatched_replies, 1);
    ub_inspect_result_t r;
    assert_int_equal(ub_inspect_result(&c->in, other, &r), UB_OK);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_false(r.changed);
    assert_int_equal(r.total, 3);
    chain_free(c);
}

/* A content the target's catalogue lacks, or knows with another layout, is refused by reason. */
static void test_unknown_and_changed_content_refused(void **state) {
    (void)state;
    chain_t *c = chain_on_cats(&ub_test_cat_newer, &ub_test_cat, 0, 0);
    ub_inspect_result_t r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_READ, .instance = TEST_NEW}, 1000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_UNKNOWN_CONTENT);
    chain_free(c);
    c = chain_on_cats(&ub_test_cat_changed, &ub_test_cat, 0, 0);
    struct test_gps before = c->gps_table;
    ub_inspect_spec_t w = {.op = UB_INSPECT_WRITE, .instance = TEST_GPS, .offset = 0, .len = 8};
    memset(w.data, 0x77, 8);
    r = ask(c, w, 1000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_LAYOUT);
    assert_memory_equal(&c->gps_table, &before, sizeof before);
    assert_int_equal(ub_node_counters(c->fcs_node)->inspect_refused, 1);
    chain_free(c);
}

/* A wire-image value of UB_MAX_PAYLOAD bytes is read in two chunks (`next` says where the second starts) and
 * written in place; a codec's refusal of the stored value or of the written one is BAD_VALUE, the storage kept. */
static void test_chunked_reads_wire_images_and_codec_refusals(void **state) {
    (void)state;
    chain_t *c = chain_on(catalogue_with_edges(), 0, 0);
    static uint8_t image[UB_MAX_PAYLOAD];
    for (size_t i = 0; i < sizeof image; i++) image[i] = (uint8_t)(i * 13u + 5u);
    struct test_flag flag = {.n = 7, .on = 2}; /* not a bool: its codec refuses it */
    assert_int_equal(ub_node_bind(c->fcs_node, TEST_IMAGE, image), UB_OK);
    assert_int_equal(ub_node_bind(c->fcs_node, TEST_FLAG, &flag), UB_OK);
    ub_inspect_result_t r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_READ, .instance = TEST_IMAGE}, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_int_equal(r.total, UB_MAX_PAYLOAD);
    assert_int_equal(r.len, UB_INSPECT_CHUNK);
    assert_int_equal(r.next, UB_INSPECT_CHUNK);
    assert_memory_equal(r.data, image, UB_INSPECT_CHUNK);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_READ, .instance = TEST_IMAGE, .offset = r.next}, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_int_equal(r.len, UB_MAX_PAYLOAD - UB_INSPECT_CHUNK);
    assert_int_equal(r.next, UB_INSPECT_END);
    assert_memory_equal(r.data, image + UB_INSPECT_CHUNK, UB_MAX_PAYLOAD - UB_INSPECT_CHUNK);
    ub_inspect_spec_t w = {.op = UB_INSPECT_WRITE, .instance = TEST_IMAGE, .offset = 1000, .len = 3};
    memset(w.data, 0xEE, 3);
    r = ask(c, w, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_true(r.changed);
    assert_int_equal(image[1000], 0xEE);
    assert_int_equal(image[1002], 0xEE);
    assert_int_equal(image[1003], (uint8_t)(1003u * 13u + 5u));
    /* the stored flag cannot be packed: a read is refused BAD_VALUE */
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_READ, .instance = TEST_FLAG}, 1000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_BAD_VALUE);
    /* a write of a bool 3 is refused by the codec: the storage keeps its value */
    w = (ub_inspect_spec_t){.op = UB_INSPECT_WRITE, .instance = TEST_FLAG, .offset = 0, .len = 5};
    ub_put_u32le(w.data, 9);
    w.data[4] = 3;
    r = ask(c, w, 1000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_BAD_VALUE);
    assert_int_equal(flag.n, 7);
    assert_int_equal(flag.on, 2);
    /* a whole valid value replaces the unpackable one */
    w.data[4] = 1;
    r = ask(c, w, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_true(r.changed);
    assert_int_equal(flag.n, 9);
    assert_int_equal(flag.on, 1);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_READ, .instance = TEST_FLAG}, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_int_equal(r.len, 5);
    assert_int_equal(r.data[4], 1);
    chain_free(c);
}

/* A request between two entities of one node never crossed a link: the policy (which judges requesters
 * arriving over links) does not stop it. */
static void test_request_inside_one_node_is_not_judged_by_the_policy(void **state) {
    (void)state;
    chain_t *c = chain_new(0, 0);
    uint8_t gcs2_id[UB_ENTITY_ID_LEN];
    test_eid("gcs2", gcs2_id);
    assert_true(ub_node_add_entity(c->gcs_node, gcs2_id, true) >= 0);
    static struct test_imu imu2;
    assert_int_equal(ub_node_bind(c->gcs_node, TEST_IMU, &imu2), UB_OK);
    ub_policy_init(&c->policy);
    assert_int_equal(ub_policy_add_admin(&c->policy, c->relay_id), UB_OK);
    ub_node_set_policy(c->gcs_node, &c->policy);
    ub_inspect_spec_t w = {.op = UB_INSPECT_WRITE, .instance = TEST_IMU, .offset = 24, .len = 4};
    ub_put_u32le(w.data, 99u);
    memcpy(w.target, gcs2_id, UB_ENTITY_ID_LEN);
    int row = ub_inspect_request(&c->in, &w, c->w->now_ms);
    assert_true(row >= 0);
    world_run(c->w, c->w->now_ms + 5, 1);
    ub_inspect_result_t r;
    assert_int_equal(ub_inspect_result(&c->in, row, &r), UB_OK);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_int_equal(imu2.t_ms, 99u);
    assert_int_equal(ub_node_counters(c->gcs_node)->drops[UB_DROP_NOT_AUTHORIZED], 0);
    chain_free(c);
}

/* A policy that restricts reads: a non-administrator reads only with a read rule. */
static void test_read_restricted_policy(void **state) {
    (void)state;
    chain_t *c = chain_new(0, 0);
    ub_policy_init(&c->policy);
    assert_int_equal(ub_policy_add_admin(&c->policy, c->relay_id), UB_OK);
    assert_int_equal(ub_policy_add_rule(&c->policy, UB_POLICY_READ, "fcs", "gcs", "gpsOut"), UB_OK);
    assert_true(c->policy.read_restricted);
    ub_node_set_policy(c->fcs_node, &c->policy);
    ub_inspect_result_t r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_READ, .instance = TEST_IMU}, 1000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_NOT_AUTHORIZED);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_READ, .instance = TEST_GPS}, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    chain_free(c);
}

/* At a node with a keyring and no policy, who sent an unsigned request is unknown: it may read (reads are as
 * open as subscriptions), never write. */
static void test_unsigned_requester_at_a_keyed_node_reads_but_cannot_write(void **state) {
    (void)state;
    if (!ub_sec_available()) skip();
    chain_t *c = chain_new(0, 0);
    static const uint8_t key[32] = {7, 7, 7, 7, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12,
                                    13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28};
    /* fcs verifies signed frames (a keyring) but signs nothing itself (no transmit key), nor requires it */
    ub_sec_t *sec = test_calloc(1, sizeof *sec);
    assert_int_equal(ub_sec_init(sec, NULL), UB_OK);
    assert_int_equal(ub_sec_add_key(sec, 1, key), UB_OK);
    assert_int_equal(ub_sec_start(sec, 0, 1000), UB_OK);
    assert_int_equal(ub_node_set_security(c->fcs_node, sec), UB_OK);
    ub_inspect_result_t r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_READ, .instance = TEST_IMU}, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    uint32_t t_ms = c->imu.t_ms;
    ub_inspect_spec_t w = {.op = UB_INSPECT_WRITE, .instance = TEST_IMU, .offset = 24, .len = 4};
    ub_put_u32le(w.data, t_ms + 1);
    r = ask(c, w, 1000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_NOT_AUTHORIZED);
    assert_int_equal(c->imu.t_ms, t_ms);
    assert_int_equal(ub_node_counters(c->fcs_node)->drops[UB_DROP_NOT_AUTHORIZED], 1);
    chain_free(c);
    test_free(sec);
}

/* LIST at its edges: records from an offset on, a link of another local entity not listed, a subscription
 * row's state, counters above 32 bits saturated; an administration table too long for one chunk says where
 * the rest starts. SET_PERIOD on a free row or a subscription (asked again at once); ADMIN_ROW's values. */
static void test_list_offsets_chunks_and_row_changes(void **state) {
    (void)state;
    chain_t *c = chain_new(0, 0);
    uint8_t fcs2_id[UB_ENTITY_ID_LEN];
    test_eid("fcs2", fcs2_id);
    int fcs2 = ub_node_add_entity(c->fcs_node, fcs2_id, true);
    assert_true(fcs2 >= 0);
    assert_true(ub_node_add_link(c->fcs_node, fcs2, 0, "fcs2Port") >= 0);
    /* entities from row 2 on: 4 in all, one record */
    ub_inspect_result_t r =
        ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_LIST, .arg = UB_INSPECT_ENTITIES, .offset = 3}, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_int_equal(r.total, 4);
    assert_int_equal(r.len, UB_INSPECT_ENTITY_REC);
    assert_memory_equal(r.data, fcs2_id, UB_ENTITY_ID_LEN);
    /* links: only fcs's own, its bytes_in saturated at 2^32 - 1 */
    int fl = ub_node_find_link(c->fcs_node, "fcsPort");
    assert_true(fl >= 0);
    c->fcs_node->links[fl].counters.bytes_in = 5000000000ull;
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_LIST, .arg = UB_INSPECT_LINKS}, 1000);
    assert_int_equal(r.total, 1);
    assert_string_equal((const char *)r.data, "fcsPort");
    assert_int_equal(ub_get_u32le(r.data + 44), UINT32_MAX);
    /* fcs subscribes to gcs's imuOut: a subscription row, listed with its state, re-asked on SET_PERIOD */
    static struct test_imu imu_at_gcs;
    assert_int_equal(ub_node_bind(c->gcs_node, TEST_IMU, &imu_at_gcs), UB_OK);
    int sub = ub_pubsub_subscribe(c->fcs_node, c->fcs, TEST_IMU, c->gcs_id, 100, 0);
    assert_true(sub >= 0);
    world_run(c->w, c->w->now_ms + 300, 1);
    const ub_ps_row_t *row = ub_pubsub_row(c->fcs_node, c->fcs, sub);
    assert_non_null(row);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_LIST, .arg = UB_INSPECT_PUBSUB}, 1000);
    assert_int_equal(r.total, 1);
    assert_int_equal(ub_get_u16le(r.data), sub);
    assert_int_equal(r.data[2], UB_PS_SUBSCRIPTION);
    assert_int_equal(r.data[3], row->state);
    assert_true(row->next_due_ms > c->w->now_ms + 1);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_SET_PERIOD, .offset = (uint16_t)sub, .value = 40}, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_int_equal(row->period_ms, 40);
    assert_true(row->next_due_ms <= c->w->now_ms); /* asked again at once */
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_SET_PERIOD, .offset = (uint16_t)(sub + 1), .value = 40}, 1000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_NO_SUCH_ROW);
    /* an administration table of 24 rows: 19 records of 52 bytes fit a chunk */
    static ub_admin_t adm;
    assert_int_equal(ub_admin_init(&adm, c->fcs_node, c->fcs, NULL), UB_OK);
    for (int i = 0; i < 24; i++) {
        ub_admin_row_spec_t spec = {.instance = TEST_GPS, .period_ms = 100u + (uint32_t)i, .type = UB_ADMIN_ROW_SUBSCRIPTION};
        memcpy(spec.source, c->relay_id, UB_ENTITY_ID_LEN);
        char name[8] = {'d', (char)('a' + i), 0};
        test_eid(name, spec.destination);
        assert_int_equal(ub_admin_add_row(&adm, &spec), i);
    }
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_LIST, .arg = UB_INSPECT_ADMIN}, 1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_int_equal(r.total, 24);
    size_t fit = UB_INSPECT_CHUNK / UB_INSPECT_ADMIN_REC;
    assert_int_equal(r.len, fit * UB_INSPECT_ADMIN_REC);
    assert_int_equal(r.next, fit);
    assert_int_equal(ub_get_u32le(r.data + 44), 100);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_LIST, .arg = UB_INSPECT_ADMIN, .offset = r.next}, 1000);
    assert_int_equal(r.len, (24 - fit) * UB_INSPECT_ADMIN_REC);
    assert_int_equal(r.next, UB_INSPECT_END);
    assert_int_equal(ub_get_u16le(r.data), fit);
    /* ADMIN_ROW: period 0 and an activation flag of 2 are refused; a row that does not exist too */
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_ADMIN_ROW, .arg = UB_INSPECT_ADMIN_PERIOD, .offset = 1}, 1000);
    assert_int_equal(r.nack_reason, UB_NACK_INVALID);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_ADMIN_ROW, .arg = UB_INSPECT_ADMIN_ACTIVE, .offset = 1, .value = 2},
            1000);
    assert_int_equal(r.nack_reason, UB_NACK_INVALID);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_ADMIN_ROW, .arg = UB_INSPECT_ADMIN_PERIOD, .offset = 30, .value = 5},
            1000);
    assert_int_equal(r.nack_reason, UB_NACK_NO_SUCH_ROW);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_ADMIN_ROW, .arg = UB_INSPECT_ADMIN_PERIOD, .offset = 1, .value = 55},
            1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_true(r.changed);
    ub_admin_row_info_t info;
    assert_int_equal(ub_admin_row_status(&adm, 1, &info), UB_OK);
    assert_int_equal(info.spec.period_ms, 55);
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_ADMIN_ROW, .arg = UB_INSPECT_ADMIN_ACTIVE, .offset = 1, .value = 1},
            1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_true(r.changed);
    assert_int_equal(ub_admin_row_status(&adm, 1, &info), UB_OK);
    assert_true(info.active_flag);
    /* an active row takes a new period at once (its request goes again now) */
    uint64_t now = c->w->now_ms;
    r = ask(c, (ub_inspect_spec_t){.op = UB_INSPECT_ADMIN_ROW, .arg = UB_INSPECT_ADMIN_PERIOD, .offset = 1, .value = 60},
            1000);
    assert_int_equal(r.status, UB_INSPECT_DONE);
    assert_true(adm.rows[1].next_send_ms <= c->w->now_ms && adm.rows[1].next_send_ms >= now);
    ub_admin_detach(&adm);
    chain_free(c);
}

/* Requests no requester sends, built by hand: a SET_MASK whose subject is cut short or whose mask is above a
 * byte, and a mask toward the target itself (always 0), are INVALID; an unknown operation too. */
static void test_malformed_requests_refused_invalid(void **state) {
    (void)state;
    chain_t *c = chain_new(0, 0);
    ub_inspect_result_t r;
    ub_inspect_spec_t m = {.op = UB_INSPECT_SET_MASK, .value = 1};
    memcpy(m.subject, c->fcs_id, UB_ENTITY_ID_LEN); /* fcs's mask toward itself */
    r = ask(c, m, 1000);
    assert_int_equal(r.status, UB_INSPECT_FAILED);
    assert_int_equal(r.nack_reason, UB_NACK_INVALID);
    const ub_node_counters_t *k = ub_node_counters(c->fcs_node);
    uint64_t refused = k->inspect_refused;
    uint8_t p[UB_INSPECT_REQ_DATA + UB_ENTITY_ID_LEN];
    memcpy(m.subject, c->relay_id, UB_ENTITY_ID_LEN);
    assert_int_equal(ub_inspect_put_request(p, sizeof p, 77, &m), sizeof p);
    uint64_t now = c->w->now_ms;
    inject(c->fcs_node, "fcsPort", UB_ADMIN_INSPECT, "gcs", "fcs", 60001, p, UB_INSPECT_REQ_DATA + 4, now);
    m.value = 0x100;
    assert_int_equal(ub_inspect_put_request(p, sizeof p, 78, &m), sizeof p);
    inject(c->fcs_node, "fcsPort", UB_ADMIN_INSPECT, "gcs", "fcs", 60002, p, sizeof p, now);
    p[UB_INSPECT_REQ_OP] = 0x7F;
    inject(c->fcs_node, "fcsPort", UB_ADMIN_INSPECT, "gcs", "fcs", 60003, p, sizeof p, now);
    assert_int_equal(k->inspect_refused, refused + 3);
    uint8_t mask = 0;
    int f_relay = ub_node_find_entity(c->fcs_node, c->relay_id);
    assert_int_equal(ub_node_get_mask(c->fcs_node, c->fcs, f_relay, &mask), UB_OK);
    assert_int_equal(mask, 0x01); /* untouched */
    chain_free(c);
}

/* ub_inspect_put_request() refuses what it cannot write whole; a link-local target is no target. */
static void test_put_request_bounds_and_link_local_target(void **state) {
    (void)state;
    uint8_t p[UB_MAX_PAYLOAD];
    ub_inspect_spec_t s = {.op = UB_INSPECT_WRITE, .len = 4};
    assert_int_equal(ub_inspect_put_request(NULL, sizeof p, 1, &s), 0);
    assert_int_equal(ub_inspect_put_request(p, sizeof p, 1, NULL), 0);
    assert_int_equal(ub_inspect_put_request(p, UB_INSPECT_REQ_DATA + 3, 1, &s), 0);
    assert_int_equal(ub_inspect_put_request(p, UB_INSPECT_REQ_DATA + 4, 1, &s), UB_INSPECT_REQ_DATA + 4);
    s.len = UB_INSPECT_CHUNK + 1;
    assert_int_equal(ub_inspect_put_request(p, sizeof p, 1, &s), 0);
    chain_t *c = chain_new(0, 0);
    ub_inspect_spec_t ll = {.op = UB_INSPECT_LIST, .arg = UB_INSPECT_LINKS};
    memset(ll.target, UB_LINK_LOCAL_BYTE, UB_ENTITY_ID_LEN);
    assert_int_equal(ub_inspect_request(&c->in, &ll, 0), UB_ERR_INVAL);
    ub_inspect_spec_t act = {.op = UB_INSPECT_ADMIN_ROW, .arg = UB_INSPECT_ADMIN_ACTIVE, .value = 1};
    memcpy(act.target, c->fcs_id, UB_ENTITY_ID_LEN);
    assert_true(ub_inspect_request(&c->in, &act, 0) >= 0);
    chain_free(c);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_read_through_bind_table_and_hand_binding_first),
        cmocka_unit_test(test_write_one_field_leaves_the_others),
        cmocka_unit_test(test_a_directory_above_the_payload_limit_is_refused_not_overrun),
        cmocka_unit_test(test_list_tables_and_set_period),
        cmocka_unit_test(test_policy_refusal_has_its_reason),
        cmocka_unit_test(test_retry_after_loss_and_silence),
        cmocka_unit_test(test_set_mask_and_admin_row_refusals),
        cmocka_unit_test(test_read_of_an_unbound_directory_is_refused),
        cmocka_unit_test(test_request_refusals_and_bounds),
        cmocka_unit_test(test_duplicate_replies_and_read_offsets),
        cmocka_unit_test(test_big_directory_local_unrouted_and_without_fragments),
        cmocka_unit_test(test_pending_rows_due_and_answers_bound_to_their_request),
        cmocka_unit_test(test_ack_for_a_forgotten_write_is_unmatched),
        cmocka_unit_test(test_unknown_and_changed_content_refused),
        cmocka_unit_test(test_chunked_reads_wire_images_and_codec_refusals),
        cmocka_unit_test(test_request_inside_one_node_is_not_judged_by_the_policy),
        cmocka_unit_test(test_read_restricted_policy),
        cmocka_unit_test(test_unsigned_requester_at_a_keyed_node_reads_but_cannot_write),
        cmocka_unit_test(test_list_offsets_chunks_and_row_changes),
        cmocka_unit_test(test_malformed_requests_refused_invalid),
        cmocka_unit_test(test_put_request_bounds_and_link_local_target),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
