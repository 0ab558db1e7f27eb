/*
 * Loops: three nodes, each routing an entity it has never seen ("ghost") to the
 * next node, so A -> B -> C -> A forms a loop. A message may cross at most
 * hop-limit links; the duplicate window cuts the loop where it closes (the
 * originator remembers its own sequence numbers), the hop limit cuts it
 * earlier when it is smaller than the loop. Both cuts are counted.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>

#include "support/ub_test_world.h"
#include "ub/ub_node.h"

typedef struct ring {
    world_t *w;
    ub_node_t *n[3];
    int self[3];
    uint8_t ghost[UB_ENTITY_ID_LEN];
    struct test_gps gps;
} ring_t;

static ring_t *ring_build(uint8_t hop_limit) {
    ring_t *r = calloc(1, sizeof *r);
    assert_non_null(r);
    r->w = world_new();
    const char *names[3] = {"ringA", "ringB", "ringC"};
    ub_node_options_t opt = {.hop_limit = hop_limit};
    test_eid("ghost", r->ghost);
    int to_next[3], from_prev[3];
    for (int i = 0; i < 3; i++) {
        r->n[i] = world_node(r->w, &ub_test_cat, &opt);
        r->self[i] = ub_node_add_entity_name(r->n[i], names[i], true);
        assert_true(r->self[i] >= 0);
        int ghost = ub_node_add_entity(r->n[i], r->ghost, false);
        assert_true(ghost >= 0);
        to_next[i] = ub_node_add_link(r->n[i], r->self[i], 0, "toNext");
        from_prev[i] = ub_node_add_link(r->n[i], r->self[i], 1, "fromPrev");
        assert_true(to_next[i] >= 0 && from_prev[i] >= 0);
        /* The misconfiguration: every node believes the ghost is reached through the next one. */
        assert_int_equal(ub_node_set_mask(r->n[i], r->self[i], ghost, 0x01), UB_OK);
    }
    for (int i = 0; i < 3; i++) world_connect(r->w, r->n[i], to_next[i], r->n[(i + 1) % 3], from_prev[(i + 1) % 3], NULL, 0);
    assert_int_equal(ub_node_bind(r->n[0], TEST_GPS, &r->gps), UB_OK);
    return r;
}

static void ring_free(ring_t *r) {
    free(r->w);
    free(r);
}

static uint64_t drops_total(const ring_t *r, ub_drop_reason_t reason) {
    uint64_t total = 0;
    for (int i = 0; i < 3; i++) total += ub_node_counters(r->n[i])->drops[reason];
    return total;
}

static uint64_t forwarded_total(const ring_t *r) {
    uint64_t total = 0;
    for (int i = 0; i < 3; i++) total += ub_node_counters(r->n[i])->forwarded;
    return total;
}

static uint64_t transmissions(const ring_t *r) {
    uint64_t total = 0;
    for (int i = 0; i < 3; i++)
        for (int l = 0; l < 2; l++) total += ub_node_link(r->n[i], l)->counters.frames_out;
    return total;
}

static void test_loop_is_cut_by_hop_limit_or_duplicate_window(void **state) {
    (void)state;
    for (uint8_t hop = 1; hop <= 8; hop++) {
        ring_t *r = ring_build(hop);
        assert_int_equal(ub_node_send_data(r->n[0], r->self[0], TEST_GPS, r->ghost, 0), 1);
        world_run(r->w, 100, 1);
        uint64_t sent = transmissions(r);
        uint64_t hop_drops = drops_total(r, UB_DROP_HOP_LIMIT);
        uint64_t dup_drops = drops_total(r, UB_DROP_DUPLICATE);
        /* At most hop-limit links crossed; the loop is 3 links long. */
        assert_true(sent <= hop);
        if (hop < 3) {
            assert_int_equal(sent, hop);
            assert_int_equal(hop_drops, 1); /* the hop-limit cut */
            assert_int_equal(dup_drops, 0);
            assert_int_equal(forwarded_total(r), hop - 1);
        } else {
            assert_int_equal(sent, 3);
            assert_int_equal(dup_drops, 1); /* the duplicate-window cut, back at the originator */
            assert_int_equal(hop_drops, 0);
            assert_int_equal(ub_node_counters(r->n[0])->drops[UB_DROP_DUPLICATE], 1);
            assert_int_equal(forwarded_total(r), 2);
        }
        assert_int_equal(ub_memlink_pending(&r->w->links[0]) + ub_memlink_pending(&r->w->links[1]) +
                             ub_memlink_pending(&r->w->links[2]),
                         0);
        ring_free(r);
    }
}

/* Many messages: each one is cut; the loop never amplifies or keeps traffic alive. */
static void test_loop_traffic_stays_bounded(void **state) {
    (void)state;
    ring_t *r = ring_build(8);
    for (int i = 0; i < 200; i++) {
        assert_int_equal(ub_node_send_data(r->n[0], r->self[0], TEST_GPS, r->ghost, r->w->now_ms), 1);
        world_run(r->w, r->w->now_ms + 1, 1);
    }
    world_run(r->w, r->w->now_ms + 50, 1);
    assert_int_equal(transmissions(r), 3 * 200);
    assert_int_equal(drops_total(r, UB_DROP_DUPLICATE), 200);
    ring_free(r);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_loop_is_cut_by_hop_limit_or_duplicate_window),
        cmocka_unit_test(test_loop_traffic_stays_bounded),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
