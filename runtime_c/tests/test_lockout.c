/*
 * Lockout (issue #23 item 5, docs/security.md "Lockout"): a key holder's forged frame cannot push a source's
 * freshness out of its reach. On a chain a -- f -- b with the group key, a forged frame in a's name:
 *  - with counter 2^48-2 is dropped `counter_jump` at the forwarder (never forwarded), re-challenges the
 *    source, and a's stream to b loses nothing;
 *  - within the bound but ahead of a's counter moves the windows of f and b; a's frames then come back
 *    `replay` until UB_SEC_DEFAULT_REPLAY_STREAK of them in a row re-challenge a at each, and the stream
 *    flows again;
 *  - with the streak rule out of the way, removing the forged frame's key (a rotation) resets the window.
 * And the bound itself, ub_sec_jump_limit(), as a pure function.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "support/ub_test_world.h"
#include "ub/ub_pubsub.h"
#include "ub/ub_sec.h"

static const uint8_t KEY1[UB_SEC_KEY_LEN] = {1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1,
                                             1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 7};
static const uint8_t KEY2[UB_SEC_KEY_LEN] = {2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2,
                                             2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 9};
#define LOCKOUT_COUNTER ((UINT64_C(1) << 48) - 2u)

static void test_jump_limit_grows_with_time_and_saturates(void **state) {
    (void)state;
    assert_int_equal(ub_sec_jump_limit(1000, 0, 0), 1000 + UB_SEC_JUMP_SLACK);
    assert_int_equal(ub_sec_jump_limit(1000, 1000, 0), 1000 + UB_SEC_JUMP_SLACK + UB_SEC_DEFAULT_MAX_COUNTER_RATE);
    assert_int_equal(ub_sec_jump_limit(1000, 1500, 2000), 1000 + UB_SEC_JUMP_SLACK + 3000);
    assert_int_equal(ub_sec_jump_limit(1000, 1, 999), 1000 + UB_SEC_JUMP_SLACK); /* below one per ms: rounds down */
    /* the lockout counter is out of reach for ~77 years after a proof at today's wall clock */
    uint64_t today = ub_sec_wall_counter(UINT64_C(1795000000) * 1000000u);
    uint64_t year_ms = UINT64_C(365) * 24 * 3600 * 1000;
    assert_true(ub_sec_jump_limit(today, 70 * year_ms, 0) < LOCKOUT_COUNTER);
    assert_int_equal(ub_sec_jump_limit(today, 90 * year_ms, 0), UB_SEC_COUNTER_MAX);
    /* no overflow, whatever the clock or rate */
    assert_int_equal(ub_sec_jump_limit(0, UINT64_MAX, UINT32_MAX), UB_SEC_COUNTER_MAX);
    assert_int_equal(ub_sec_jump_limit(UB_SEC_COUNTER_MAX - 5, 0, 0), UB_SEC_COUNTER_MAX);
    assert_int_equal(ub_sec_jump_limit(UB_SEC_COUNTER_MAX, 0, 0), UB_SEC_COUNTER_MAX);
}

typedef struct chain {
    world_t *w;
    ub_node_t *na, *nf, *nb;
    int a, f, b, la, lfa, lfb, lb;
    ub_sec_t sa, sf, sb;
    struct test_gps src, dst;
    delivery_log_t log;
} chain_t;

static void sec_up(ub_sec_t *sec, ub_node_t *node, uint64_t wall, uint32_t replay_streak) {
    ub_sec_options_t o = {.replay_streak = replay_streak};
    assert_int_equal(ub_sec_init(sec, &o), UB_OK);
    assert_int_equal(ub_sec_add_key(sec, 1, KEY1), UB_OK);
    assert_int_equal(ub_sec_set_tx_key(sec, 1), UB_OK);
    assert_int_equal(ub_sec_start(sec, 0, wall), UB_OK);
    assert_int_equal(ub_node_set_security(node, sec), UB_OK);
    assert_int_equal(ub_node_set_require_signed(node, true), UB_OK);
}

/* a --(link 0)-- f --(link 1)-- b, group key 1 everywhere, a publishing gpsOut to b every 10 ms. */
static chain_t *chain_new(uint32_t replay_streak) {
    chain_t *c = calloc(1, sizeof *c);
    assert_non_null(c);
    c->w = world_new();
    c->na = world_node(c->w, &ub_test_cat, NULL);
    c->nf = world_node(c->w, &ub_test_cat, NULL);
    c->nb = world_node(c->w, &ub_test_cat, NULL);
    c->a = ub_node_add_entity_name(c->na, "a", true);
    int a_f = ub_node_add_entity_name(c->na, "f", false), a_b = ub_node_add_entity_name(c->na, "b", false);
    c->f = ub_node_add_entity_name(c->nf, "f", true);
    int f_a = ub_node_add_entity_name(c->nf, "a", false), f_b = ub_node_add_entity_name(c->nf, "b", false);
    c->b = ub_node_add_entity_name(c->nb, "b", true);
    int b_f = ub_node_add_entity_name(c->nb, "f", false), b_a = ub_node_add_entity_name(c->nb, "a", false);
    c->la = ub_node_add_link(c->na, c->a, 0, "a0");
    c->lfa = ub_node_add_link(c->nf, c->f, 0, "f0");
    c->lfb = ub_node_add_link(c->nf, c->f, 1, "f1");
    c->lb = ub_node_add_link(c->nb, c->b, 0, "b0");
    assert_int_equal(ub_node_set_mask(c->na, c->a, a_b, 0x01), UB_OK);
    assert_int_equal(ub_node_set_mask(c->na, c->a, a_f, 0x01), UB_OK);
    assert_int_equal(ub_node_set_mask(c->nf, c->f, f_b, 0x02), UB_OK);
    assert_int_equal(ub_node_set_mask(c->nf, c->f, f_a, 0x01), UB_OK);
    assert_int_equal(ub_node_set_mask(c->nb, c->b, b_a, 0x01), UB_OK);
    assert_int_equal(ub_node_set_mask(c->nb, c->b, b_f, 0x01), UB_OK);
    world_connect(c->w, c->na, c->la, c->nf, c->lfa, NULL, 1);
    world_connect(c->w, c->nf, c->lfb, c->nb, c->lb, NULL, 2);
    sec_up(&c->sa, c->na, 100000, 0);
    sec_up(&c->sf, c->nf, 200000, replay_streak);
    sec_up(&c->sb, c->nb, 300000, replay_streak);
    c->src = (struct test_gps){10.0, 20.0, 30.0f, 4};
    assert_int_equal(ub_node_bind(c->na, TEST_GPS, &c->src), UB_OK);
    assert_int_equal(ub_node_bind(c->nb, TEST_GPS, &c->dst), UB_OK);
    ub_node_set_deliver_hook(c->nb, delivery_log_hook, &c->log);
    uint8_t bid[UB_ENTITY_ID_LEN];
    test_eid("b", bid);
    assert_true(ub_pubsub_publish(c->na, c->a, TEST_GPS, bid, 10, 0) >= 0);
    return c;
}

static void chain_free(chain_t *c) {
    free(c->w);
    free(c);
}

/* DATA frames a's publication sent so far. */
static uint64_t originated(const chain_t *c) {
    uint64_t n = 0;
    for (int row = 0; row < UB_MAX_PUBSUB_ROWS; row++) {
        const ub_ps_row_t *pr = ub_pubsub_row(c->na, c->a, row);
        if (pr != NULL && pr->kind == UB_PS_PUBLICATION) n += pr->frames;
    }
    return n;
}

static uint64_t drops(const ub_node_t *n, ub_drop_reason_t why) { return ub_node_counters(n)->drops[why]; }

/* A gpsOut frame in a's name for b, signed with the group key `key_id`/`key` (what any key holder can make),
 * injected into f's link from a. */
static void inject_forged(chain_t *c, uint8_t key_id, const uint8_t *key, uint64_t counter, uint64_t now_ms) {
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memcpy(h.dir_id, ub_test_cat.instances[TEST_GPS].id, UB_DIR_ID_LEN);
    test_eid("a", h.src_id);
    test_eid("b", h.dest_id);
    h.admin = UB_ADMIN_DATA;
    h.hop_limit = 8;
    h.payload_size = (uint16_t)ub_test_cat.instances[TEST_GPS].type->packed_size;
    h.fingerprint = ub_test_cat.instances[TEST_GPS].type->fingerprint;
    h.seq = (uint32_t)counter;
    h.counter_hi = (uint16_t)(counter >> 32);
    h.flags = UB_FRAME_FLAG_SIGNED;
    h.key_id = key_id;
    uint8_t frame[UB_FRAME_MAX];
    struct test_gps evil = {1.0, 2.0, 3.0f, 66};
    assert_true(ub_test_cat.instances[TEST_GPS].type->pack(&evil, frame + UB_FRAME_HEADER_LEN, UB_MAX_PAYLOAD) > 0);
    static ub_sec_t insider; /* holds the group key, as a captured vehicle does */
    assert_int_equal(ub_sec_init(&insider, NULL), UB_OK);
    assert_int_equal(ub_sec_add_key(&insider, key_id, key), UB_OK);
    int n = ub_sec_protect(&insider, &h, frame + UB_FRAME_HEADER_LEN, frame, sizeof frame);
    assert_true(n > 0);
    assert_int_equal(ub_node_rx_frame(c->nf, c->lfa, frame, (size_t)n, now_ms), UB_OK);
}

static void test_one_far_future_frame_silences_nobody(void **state) {
    (void)state;
    chain_t *c = chain_new(0);
    world_run(c->w, 500, 1);
    assert_true(delivery_count(&c->log, c->b, TEST_GPS, 0, 501) >= 45);
    uint64_t o0 = originated(c);
    size_t d0 = delivery_count(&c->log, c->b, TEST_GPS, 0, 501);
    uint64_t fwd0 = ub_node_counters(c->nf)->forwarded;
    inject_forged(c, 1, KEY1, LOCKOUT_COUNTER, 500);
    /* dropped at the first node that judges it, counted under its own reason, never forwarded */
    assert_int_equal(drops(c->nf, UB_DROP_COUNTER_JUMP), 1);
    assert_int_equal(ub_node_link(c->nf, c->lfa)->counters.drops[UB_DROP_COUNTER_JUMP], 1);
    assert_int_equal(ub_node_counters(c->nf)->forwarded, fwd0);
    assert_int_equal(ub_sec_stats(&c->sf)->rechallenges, 1);
    world_run(c->w, 1500, 1);
    /* every frame a sent since reaches b: nobody was silenced */
    assert_int_equal(delivery_count(&c->log, c->b, TEST_GPS, 0, 1501) - d0, originated(c) - o0);
    assert_true(originated(c) - o0 >= 99);
    assert_int_equal(c->dst.fix, 4);
    assert_int_equal(drops(c->nf, UB_DROP_REPLAY) + drops(c->nb, UB_DROP_REPLAY), 0);
    assert_int_equal(drops(c->nb, UB_DROP_COUNTER_JUMP), 0);
    /* a storm of them changes nothing either, and re-challenges at most once per rechallenge_min_ms */
    for (uint64_t t = 1500; t < 2500; t += 10) {
        inject_forged(c, 1, KEY1, LOCKOUT_COUNTER - t, t);
        world_run(c->w, t + 10, 1);
    }
    assert_int_equal(drops(c->nf, UB_DROP_COUNTER_JUMP), 101);
    assert_in_range(ub_sec_stats(&c->sf)->rechallenges, 2, 3);
    assert_int_equal(delivery_count(&c->log, c->b, TEST_GPS, 0, 2501) - d0, originated(c) - o0);
    chain_free(c);
}

static void test_replay_streak_rechallenges_a_pushed_window(void **state) {
    (void)state;
    chain_t *c = chain_new(0);
    world_run(c->w, 500, 1);
    /* ahead of a's counter, but within the bound: accepted (a key holder can forge in this mode) and forwarded */
    inject_forged(c, 1, KEY1, c->sa.counter + 30000, 500);
    assert_int_equal(drops(c->nf, UB_DROP_COUNTER_JUMP), 0);
    world_run(c->w, 501, 1);
    assert_int_equal(c->dst.fix, 66);
    world_run(c->w, 1500, 1);
    /* a's frames came back `replay`: a streak at f re-challenged a there, then the same at b */
    assert_int_equal(ub_sec_stats(&c->sf)->rechallenges, 1);
    assert_int_equal(ub_sec_stats(&c->sb)->rechallenges, 1);
    assert_int_equal(drops(c->nf, UB_DROP_REPLAY), UB_SEC_DEFAULT_REPLAY_STREAK);
    assert_int_equal(drops(c->nb, UB_DROP_REPLAY), UB_SEC_DEFAULT_REPLAY_STREAK);
    assert_int_equal(c->dst.fix, 4);
    /* flowing again, every frame */
    uint64_t o0 = originated(c);
    size_t d0 = delivery_count(&c->log, c->b, TEST_GPS, 0, 1501);
    world_run(c->w, 2000, 1);
    assert_int_equal(delivery_count(&c->log, c->b, TEST_GPS, 0, 2001) - d0, originated(c) - o0);
    assert_true(originated(c) - o0 >= 49);
    chain_free(c);
}

static void test_key_removal_resets_what_its_frames_set(void **state) {
    (void)state;
    chain_t *c = chain_new(1000000); /* no replay-streak recovery here: only the rotation may repair */
    world_run(c->w, 500, 1);
    inject_forged(c, 1, KEY1, c->sa.counter + 30000, 500);
    world_run(c->w, 1000, 1);
    size_t d0 = delivery_count(&c->log, c->b, TEST_GPS, 0, 1001);
    world_run(c->w, 1500, 1);
    assert_int_equal(delivery_count(&c->log, c->b, TEST_GPS, 0, 1501), d0); /* locked out */
    assert_true(drops(c->nf, UB_DROP_REPLAY) >= 90);
    assert_int_equal(ub_sec_stats(&c->sf)->rechallenges, 0);
    /* the documented rotation: every node learns key 2, signs with it, then key 1 is removed */
    ub_sec_t *all[] = {&c->sa, &c->sf, &c->sb};
    for (int i = 0; i < 3; i++) assert_int_equal(ub_sec_add_key(all[i], 2, KEY2), UB_OK);
    for (int i = 0; i < 3; i++) assert_int_equal(ub_sec_set_tx_key(all[i], 2), UB_OK);
    for (int i = 0; i < 3; i++) assert_int_equal(ub_sec_remove_key(all[i], 1), UB_OK);
    world_run(c->w, 2000, 1);
    assert_int_equal(ub_sec_stats(&c->sf)->window_resets, 1);
    assert_int_equal(ub_sec_stats(&c->sb)->window_resets, 1);
    uint64_t o0 = originated(c);
    size_t d1 = delivery_count(&c->log, c->b, TEST_GPS, 0, 2001);
    assert_true(d1 > d0);
    world_run(c->w, 2500, 1);
    assert_int_equal(delivery_count(&c->log, c->b, TEST_GPS, 0, 2501) - d1, originated(c) - o0);
    chain_free(c);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_jump_limit_grows_with_time_and_saturates),
        cmocka_unit_test(test_one_far_future_frame_silences_nobody),
        cmocka_unit_test(test_replay_streak_rechallenges_a_pushed_window),
        cmocka_unit_test(test_key_removal_resets_what_its_frames_set),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
