/*
 * Node set-up API (entity table, links, masks, bindings) and the duplicate
 * window: (source, sequence) suppression, out-of-order acceptance inside the
 * window, restarted sources, sequence wrap, and eviction of old sources.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "support/ub_test_world.h"
#include "ub/ub_node.h"

static void test_setup_api_contracts(void **state) {
    (void)state;
    ub_node_t *n = calloc(1, sizeof *n);
    assert_non_null(n);
    assert_int_equal(ub_node_init(n, NULL, NULL), UB_ERR_INVAL);
    ub_catalogue_t wrong_abi = ub_test_cat;
    wrong_abi.abi_version = UB_CATALOGUE_ABI_VERSION + 1;
    assert_int_equal(ub_node_init(n, &wrong_abi, NULL), UB_ERR_INVAL);
    assert_int_equal(ub_node_init(n, &ub_test_cat, NULL), UB_OK);

    int gcs = ub_node_add_entity_name(n, "gcs1", true);
    int uav = ub_node_add_entity_name(n, "rmax1ob1", false);
    assert_int_equal(gcs, 0);
    assert_int_equal(uav, 1);
    assert_int_equal(ub_node_add_entity_name(n, "gcs1", false), UB_ERR_EXISTS);
    assert_int_equal(ub_node_add_entity_name(n, "averyveryverylongname", false), UB_ERR_RANGE);
    uint8_t id[UB_ENTITY_ID_LEN];
    test_eid("rmax1ob1", id);
    assert_int_equal(ub_node_find_entity(n, id), uav);
    assert_memory_equal(ub_node_entity_id(n, uav), id, UB_ENTITY_ID_LEN);

    /* Links belong to local entities, at a free index < 8, with a node-unique name. */
    assert_int_equal(ub_node_add_link(n, uav, 0, "x"), UB_ERR_INVAL);
    assert_int_equal(ub_node_add_link(n, gcs, UB_MAX_LINKS_PER_ENTITY, "x"), UB_ERR_INVAL);
    assert_int_equal(ub_node_add_link(n, gcs, 0, ""), UB_ERR_INVAL);
    int l1 = ub_node_add_link(n, gcs, 1, "gcsPortDatalink2");
    assert_true(l1 >= 0);
    assert_int_equal(ub_node_add_link(n, gcs, 1, "other"), UB_ERR_EXISTS);
    assert_int_equal(ub_node_add_link(n, gcs, 0, "gcsPortDatalink2"), UB_ERR_EXISTS);
    int l0 = ub_node_add_link(n, gcs, 0, "gcsPortDatalink1");
    assert_true(l0 >= 0 && l0 != l1);
    assert_int_equal(ub_node_find_link(n, "gcsPortDatalink1"), l0);
    assert_int_equal(ub_node_find_link(n, "nope"), UB_ERR_NOTFOUND);
    assert_int_equal(ub_node_link(n, l1)->index, 1);
    assert_string_equal(ub_node_link(n, l1)->name, "gcsPortDatalink2");
    assert_int_equal(ub_link_fileno(ub_node_link(n, l0)), -1); /* detached */

    /* Masks: Table 2's gcs1 row, "0x00000011" to rmax1ob1. */
    uint8_t mask;
    assert_int_equal(ub_link_mask_parse("0x00000011", &mask), UB_OK);
    assert_int_equal(ub_node_set_mask(n, gcs, uav, mask), UB_OK);
    uint8_t back = 0;
    assert_int_equal(ub_node_get_mask(n, gcs, uav, &back), UB_OK);
    assert_int_equal(back, 0x03);
    assert_int_equal(ub_node_set_mask(n, gcs, uav, 0x04), UB_ERR_NOTFOUND); /* link[2] does not exist */
    assert_int_equal(ub_node_set_mask(n, gcs, gcs, 0x01), UB_ERR_INVAL);    /* "this is entity 0" */
    assert_int_equal(ub_node_set_mask(n, uav, gcs, 0x01), UB_ERR_INVAL);    /* not local */

    struct test_gps g;
    assert_int_equal(ub_node_bind(n, 99, &g), UB_ERR_INVAL);
    assert_int_equal(ub_node_bind(n, TEST_GPS, &g), UB_OK);
    assert_ptr_equal(ub_node_binding(n, TEST_GPS), &g);
    assert_null(ub_node_binding(n, TEST_IMU));

    /* Sending over a detached port is counted, never silent. */
    assert_int_equal(ub_node_send_data(n, gcs, TEST_GPS, id, 0), 0);
    assert_int_equal(ub_node_counters(n)->drops[UB_DROP_DETACHED], 2);
    assert_int_equal(ub_node_link(n, l0)->counters.drops[UB_DROP_DETACHED], 1);
    free(n);
}

static void test_tables_fill_up(void **state) {
    (void)state;
    ub_node_t *n = calloc(1, sizeof *n);
    assert_non_null(n);
    assert_int_equal(ub_node_init(n, &ub_test_cat, NULL), UB_OK);
    char name[8];
    for (int i = 0; i < UB_MAX_ENTITIES; i++) {
        snprintf(name, sizeof name, "e%d", i);
        assert_int_equal(ub_node_add_entity_name(n, name, i < UB_MAX_LOCAL_ENTITIES), i);
    }
    assert_int_equal(ub_node_add_entity_name(n, "one_more", false), UB_ERR_FULL);
    ub_node_t *m = calloc(1, sizeof *m);
    assert_non_null(m);
    assert_int_equal(ub_node_init(m, &ub_test_cat, NULL), UB_OK);
    for (int i = 0; i < UB_MAX_LOCAL_ENTITIES; i++) {
        snprintf(name, sizeof name, "l%d", i);
        assert_true(ub_node_add_entity_name(m, name, true) >= 0);
    }
    assert_int_equal(ub_node_add_entity_name(m, "l_more", true), UB_ERR_FULL);
    free(n);
    free(m);
}

/* A node hosting "dst" that hears DATA from "src" on one link. */
typedef struct rx_fixture {
    ub_node_t node;
    int link;
    struct test_gps gps;
    uint8_t payload[24];
} rx_fixture_t;

static rx_fixture_t *rx_fixture(void) {
    rx_fixture_t *f = calloc(1, sizeof *f);
    assert_non_null(f);
    assert_int_equal(ub_node_init(&f->node, &ub_test_cat, NULL), UB_OK);
    int dst = ub_node_add_entity_name(&f->node, "dst", true);
    assert_true(dst >= 0);
    f->link = ub_node_add_link(&f->node, dst, 0, "in");
    assert_int_equal(ub_node_bind(&f->node, TEST_GPS, &f->gps), UB_OK);
    struct test_gps v = {1.5, 2.5, 3.5f, 4};
    assert_int_equal(ub_test_cat.instances[TEST_GPS].type->pack(&v, f->payload, sizeof f->payload), 24);
    return f;
}

/* Feeds one DATA frame from `src` with `seq`; returns 1 if it was delivered. */
static int feed(rx_fixture_t *f, const char *src, uint32_t seq) {
    uint8_t frame[UB_FRAME_MAX];
    const ub_instance_desc_t *inst = &ub_test_cat.instances[TEST_GPS];
    size_t len = make_frame(frame, UB_ADMIN_DATA, inst->id, src, "dst", seq, 4, inst->type->fingerprint, f->payload, 24);
    uint64_t before = ub_node_counters(&f->node)->delivered;
    assert_int_equal(ub_node_rx_frame(&f->node, f->link, frame, len, 0), UB_OK);
    return (int)(ub_node_counters(&f->node)->delivered - before);
}

static void test_duplicate_window(void **state) {
    (void)state;
    rx_fixture_t *f = rx_fixture();
    assert_int_equal(feed(f, "src", 100), 1);
    assert_int_equal(feed(f, "src", 100), 0); /* duplicate */
    assert_int_equal(feed(f, "src", 99), 1);  /* late, but inside the window and unseen */
    assert_int_equal(feed(f, "src", 101), 1);
    assert_int_equal(feed(f, "src", 99), 0);
    assert_int_equal(feed(f, "other", 100), 1); /* windows are per source */
    assert_int_equal(feed(f, "src", 200), 1);   /* a jump */
    assert_int_equal(feed(f, "src", 137), 1);   /* 63 behind: still inside */
    assert_int_equal(feed(f, "src", 137), 0);
    assert_int_equal(feed(f, "src", 101), 1); /* 99 behind: a restarted source, not silenced */
    assert_int_equal(ub_node_counters(&f->node)->dedup_resets, 1);
    assert_int_equal(feed(f, "src", 102), 1);
    assert_int_equal(feed(f, "src", 101), 0);
    assert_int_equal(ub_node_counters(&f->node)->drops[UB_DROP_DUPLICATE], 4);
    assert_int_equal(ub_node_link(&f->node, f->link)->counters.drops[UB_DROP_DUPLICATE], 4);
    free(f);
}

static void test_sequence_wraps(void **state) {
    (void)state;
    rx_fixture_t *f = rx_fixture();
    assert_int_equal(feed(f, "src", 0xFFFFFFFEu), 1);
    assert_int_equal(feed(f, "src", 0xFFFFFFFFu), 1);
    assert_int_equal(feed(f, "src", 0), 1);
    assert_int_equal(feed(f, "src", 1), 1);
    assert_int_equal(feed(f, "src", 0xFFFFFFFFu), 0);
    assert_int_equal(ub_node_counters(&f->node)->dedup_resets, 0);
    free(f);
}

/* A process of source "src" seeded with ub_node_seq_seed() at `pred_us` sent `sent` frames; its successor,
 * seeded at `succ_us`, sends `count` frames to the same receiver. Returns how many of those were delivered.
 * Only the predecessor's last 64 frames are fed: they alone make the window the successor meets. */
static int successor_delivered(uint64_t pred_us, uint32_t sent, uint64_t succ_us, int count) {
    rx_fixture_t *f = rx_fixture();
    uint32_t last = ub_node_seq_seed(pred_us) + sent - 1u;
    for (uint32_t k = 0; k < UB_DEDUP_WINDOW && k < sent; k++) assert_int_equal(feed(f, "src", last - k), 1);
    int delivered = 0;
    uint32_t first = ub_node_seq_seed(succ_us);
    for (int k = 0; k < count; k++) delivered += feed(f, "src", first + (uint32_t)k);
    free(f);
    return delivered;
}

/* CI failure of `uavbus list`: the tool before it sent ~755 requests within its first ~100 ms and the next
 * tool process, hosting the same entity, started ~700 ms later. Seeded from the millisecond clock, the new
 * process began up to 63 numbers below the old one's last: every retry of its first request (30 in 6 s)
 * was a duplicate at the forwarder. Seeded by ub_node_seq_seed(), no restart delay loses a frame. */
static void test_restarted_process_is_not_taken_for_its_predecessor(void **state) {
    (void)state;
    const uint64_t t0 = 1795766400123456ull; /* 2026-11-27 08:00:00.123456 UTC, in us */
    for (uint64_t delay_ms = 1; delay_ms <= 1500; delay_ms++) {
        int got = successor_delivered(t0, 755, t0 + delay_ms * 1000u, 64);
        if (got != 64) fail_msg("restart %llu ms after a 755-frame run: %d of 64 frames delivered",
                                (unsigned long long)delay_ms, got);
    }
    /* a predecessor at 50 kHz for 10 ms, then a restart 1 ms later; and one whose numbers wrapped past 2^32 */
    assert_int_equal(successor_delivered(t0, 500, t0 + 11000u, 64), 64);
    const uint64_t wrap = (t0 | 0xFFFFFFFFull) - 20000u; /* seeded 20 ms before the seed wraps */
    assert_int_equal(successor_delivered(wrap, 755, wrap + 700000u, 64), 64);
    /* a predecessor alive 40 min (> 2^31 us) at 50 Hz: its successor compares behind, and is a restart */
    assert_int_equal(successor_delivered(t0, 120000, t0 + 2400000000ull, 64), 64);
    assert_int_equal(ub_node_seq_seed(0), 1u);
    assert_int_equal(ub_node_seq_seed(1ull << 32), 1u);
}

static void test_full_window_table_evicts_least_recent(void **state) {
    (void)state;
    rx_fixture_t *f = rx_fixture();
    char name[8];
    for (int s = 0; s <= UB_DEDUP_SOURCES; s++) {
        snprintf(name, sizeof name, "s%d", s);
        assert_int_equal(feed(f, name, 7), 1);
    }
    assert_int_equal(ub_node_counters(&f->node)->dedup_evictions, 1);
    assert_int_equal(feed(f, "s16", 7), 0); /* recent sources are still remembered */
    assert_int_equal(feed(f, "s0", 7), 1);  /* s0 was evicted: its window starts again */
    free(f);
}


/* A catalogue whose types have no codec (what the Python binding builds from catalogue.json): the
 * bound storage is the wire image, copied as is, and still checked by fingerprint and size. */
static void test_wire_image_storage(void **state) {
    (void)state;
    ub_type_desc_t wire_types[2] = {*ub_test_cat.instances[TEST_GPS].type, *ub_test_cat.instances[TEST_IMU].type};
    for (int i = 0; i < 2; i++) wire_types[i].pack = NULL, wire_types[i].unpack = NULL;
    ub_instance_desc_t wire_instances[2] = {ub_test_cat.instances[TEST_GPS], ub_test_cat.instances[TEST_IMU]};
    wire_instances[0].type = &wire_types[0];
    wire_instances[1].type = &wire_types[1];
    ub_catalogue_t wire_cat = ub_test_cat;
    wire_cat.types = wire_types;
    wire_cat.instances = wire_instances;

    world_t *w = world_new();
    ub_node_t *c = world_node(w, &ub_test_cat, NULL);
    ub_node_t *py = world_node(w, &wire_cat, NULL);
    int c_uav = ub_node_add_entity_name(c, "uav", true), c_gcs = ub_node_add_entity_name(c, "gcs", false);
    int p_uav = ub_node_add_entity_name(py, "uav", false), p_gcs = ub_node_add_entity_name(py, "gcs", true);
    int lc = ub_node_add_link(c, c_uav, 0, "toGcs"), lp = ub_node_add_link(py, p_gcs, 0, "toUav");
    assert_int_equal(ub_node_set_mask(c, c_uav, c_gcs, 1), UB_OK);
    assert_int_equal(ub_node_set_mask(py, p_gcs, p_uav, 1), UB_OK);
    world_connect(w, c, lc, py, lp, NULL, 1);
    struct test_gps gps = {47.5, 8.25, 512.5f, 3}, back;
    uint8_t image[24] = {0};
    assert_int_equal(ub_node_bind(c, TEST_GPS, &gps), UB_OK);
    assert_int_equal(ub_node_bind(py, TEST_GPS, image), UB_OK);
    uint8_t gcs_id[UB_ENTITY_ID_LEN], uav_id[UB_ENTITY_ID_LEN], expect[24];
    test_eid("gcs", gcs_id);
    test_eid("uav", uav_id);
    assert_int_equal(ub_node_send_data(c, c_uav, TEST_GPS, gcs_id, 0), 1);
    world_run(w, 1, 1);
    assert_int_equal(ub_test_cat.instances[TEST_GPS].type->pack(&gps, expect, sizeof expect), 24);
    assert_memory_equal(image, expect, 24);

    image[0] ^= 0x01; /* the wire-image side changes a value and sends it back */
    assert_int_equal(ub_node_bind(c, TEST_GPS, &back), UB_OK);
    assert_int_equal(ub_node_send_data(py, p_gcs, TEST_GPS, uav_id, 1), 1);
    world_run(w, 2, 1);
    assert_int_equal(ub_node_counters(c)->delivered, 1);
    assert_true(back.lat != gps.lat);
    assert_true(back.lon == gps.lon && back.alt == gps.alt && back.fix == gps.fix);
    free(w);
}

/* The node checks the last destination it routed before searching the entity table: a row freed and taken by
 * another entity must not keep routing the old ID. (No transport attached: a routed frame is dropped `detached`
 * and the send returns 0; an unknown destination is UB_ERR_NOROUTE.) */
static void test_last_destination_follows_removal(void **state) {
    (void)state;
    ub_node_t *n = calloc(1, sizeof *n);
    assert_non_null(n);
    assert_int_equal(ub_node_init(n, &ub_test_cat, NULL), UB_OK);
    struct test_gps gps = {1.0, 2.0, 3.0f, 4};
    assert_int_equal(ub_node_bind(n, TEST_GPS, &gps), UB_OK);
    int me = ub_node_add_entity_name(n, "me", true);
    int a = ub_node_add_entity_name(n, "a", false);
    assert_true(me >= 0 && a >= 0);
    assert_true(ub_node_add_link(n, me, 0, "out") >= 0);
    assert_int_equal(ub_node_set_mask(n, me, a, 1), UB_OK);
    uint8_t a_id[UB_ENTITY_ID_LEN], b_id[UB_ENTITY_ID_LEN];
    test_eid("a", a_id);
    test_eid("b", b_id);
    assert_int_equal(ub_node_send_data(n, me, TEST_GPS, a_id, 0), 0); /* routed (to a detached link) */
    assert_int_equal(ub_node_send_data(n, me, TEST_GPS, b_id, 0), UB_ERR_NOROUTE);
    assert_int_equal(ub_node_remove_entity(n, a, 0), UB_OK);
    assert_int_equal(ub_node_send_data(n, me, TEST_GPS, a_id, 0), UB_ERR_NOROUTE);
    int b = ub_node_add_entity_name(n, "b", false);
    assert_int_equal(b, a); /* the freed row */
    assert_int_equal(ub_node_set_mask(n, me, b, 1), UB_OK);
    assert_int_equal(ub_node_send_data(n, me, TEST_GPS, b_id, 0), 0);
    assert_int_equal(ub_node_send_data(n, me, TEST_GPS, a_id, 0), UB_ERR_NOROUTE);
    free(n);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_setup_api_contracts),
        cmocka_unit_test(test_tables_fill_up),
        cmocka_unit_test(test_duplicate_window),
        cmocka_unit_test(test_sequence_wraps),
        cmocka_unit_test(test_restarted_process_is_not_taken_for_its_predecessor),
        cmocka_unit_test(test_full_window_table_evicts_least_recent),
        cmocka_unit_test(test_wire_image_storage),
        cmocka_unit_test(test_last_destination_follows_removal),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
