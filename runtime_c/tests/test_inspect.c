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
    void *table[3];          /* one entry per catalogue instance; NULL: not defined by this program */
    ub_policy_t policy;
} chain_t;

static int add(ub_node_t *n, const uint8_t id[UB_ENTITY_ID_LEN], bool local) {
    int e = ub_node_add_entity(n, id, local);
    assert_true(e >= 0);
    return e;
}

static chain_t *chain_on(const ub_catalogue_t *cat, uint32_t retry_ms, uint32_t max_retries) {
    chain_t *c = test_calloc(1, sizeof *c);
    c->w = world_new();
    test_eid("gcs", c->gcs_id);
    test_eid("relay", c->relay_id);
    test_eid("fcs", c->fcs_id);
    c->gcs_node = world_node(c->w, cat, NULL);
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
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
