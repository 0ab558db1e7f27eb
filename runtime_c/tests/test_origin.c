/*
 * Origin authentication (ub_origin.h; docs/security.md, "Origin authentication") in the router, on
 * memlinks and an injected clock, three nodes in a line a -- f -- b, every one holding the group key and
 * its own X25519 identity (fixed test seeds; a tiny test lookup stands in for the identity store):
 * pairwise keys are established on first use and frames flow; a forwarder holding the group key cannot
 * forge a frame for an entity it relays (its tag fails at the destination, counted, and the destination's
 * window does not move); hop-limit tampering is detected by outsiders' and insiders' means alike; a
 * restart of either end re-establishes (counters, challenge); the pair cache evicts the least recently
 * used pair; a revoked peer is refused within the recheck period.
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
#include "ub/ub_compact.h"
#include "ub/ub_memlink.h"
#include "ub/ub_node_svc.h"
#include "ub/ub_origin.h"
#include "ub/ub_pubsub.h"
#include "ub/ub_sec.h"

static const uint8_t GROUP_KEY[UB_SEC_KEY_LEN] = {5, 5, 5, 5, 5, 5, 5, 5, 5, 5, 5, 5, 5, 5, 5, 5,
                                                  5, 5, 5, 5, 5, 5, 5, 5, 5, 5, 5, 5, 5, 5, 5, 1};

/* ---- a tiny identity store: fixed seeds, a revoked flag ---------------------------------------------- */

#define FLEET_MAX 80
typedef struct fleet {
    size_t n;
    uint8_t id[FLEET_MAX][UB_ENTITY_ID_LEN];
    uint8_t sk[FLEET_MAX][UB_ORIGIN_SK_LEN];
    uint8_t pk[FLEET_MAX][UB_ORIGIN_PK_LEN];
    bool revoked[FLEET_MAX];
    uint64_t lookups;
} fleet_t;

static int fleet_add(fleet_t *fl, const char *name) {
    int i = (int)fl->n++;
    assert_true(fl->n <= FLEET_MAX);
    test_eid(name, fl->id[i]);
    for (size_t k = 0; k < UB_ORIGIN_SK_LEN; k++) fl->sk[i][k] = (uint8_t)(0x40 + 7 * k + 13 * (size_t)i);
    assert_int_equal(ub_origin_public_key(fl->sk[i], fl->pk[i]), UB_OK);
    return i;
}

static int fleet_find(const fleet_t *fl, const uint8_t id[UB_ENTITY_ID_LEN]) {
    for (size_t i = 0; i < fl->n; i++)
        if (memcmp(fl->id[i], id, UB_ENTITY_ID_LEN) == 0) return (int)i;
    return -1;
}

static int fleet_lookup(void *user, const uint8_t id[UB_ENTITY_ID_LEN], uint64_t now_s, uint8_t pk[UB_ORIGIN_PK_LEN]) {
    (void)now_s;
    fleet_t *fl = user;
    fl->lookups++;
    int i = fleet_find(fl, id);
    if (i < 0 || fl->revoked[i]) return UB_ERR_NOTFOUND;
    memcpy(pk, fl->pk[i], UB_ORIGIN_PK_LEN);
    return UB_OK;
}

/* ---- the line a -- f -- b ------------------------------------------------------------------------------- */

typedef struct member {
    ub_node_t *n;
    ub_sec_t sec;
    ub_origin_t org;
    int self;
    int link[2];
} member_t;

typedef struct line {
    world_t *w;
    fleet_t fleet;
    member_t m[3]; /* a, f, b */
    ub_memlink_t *ml[2];
    struct test_gps src, dst;
    delivery_log_t log;
    uint8_t a_id[UB_ENTITY_ID_LEN], f_id[UB_ENTITY_ID_LEN], b_id[UB_ENTITY_ID_LEN];
} line_t;

static const char *const NAMES[3] = {"a", "f", "b"};

/* (Re)builds member `k` on its node: entities, links, masks, bindings, group key from `wall`, identity. */
static void member_setup(line_t *L, int k, uint64_t wall, bool with_origin) {
    member_t *m = &L->m[k];
    assert_int_equal(ub_node_init(m->n, &ub_test_cat, NULL), UB_OK);
    m->self = ub_node_add_entity_name(m->n, NAMES[k], true);
    int other[3];
    for (int j = 0; j < 3; j++) other[j] = j == k ? m->self : ub_node_add_entity_name(m->n, NAMES[j], false);
    m->link[0] = ub_node_add_link(m->n, m->self, 0, "l0");
    m->link[1] = k == 1 ? ub_node_add_link(m->n, m->self, 1, "l1") : -1;
    for (int j = 0; j < 3; j++) {
        if (j == k) continue;
        uint8_t mask = k == 1 && j == 2 ? 0x02 : 0x01; /* f reaches b on its second link */
        assert_int_equal(ub_node_set_mask(m->n, m->self, other[j], mask), UB_OK);
    }
    if (k == 0) assert_int_equal(ub_node_bind(m->n, TEST_GPS, &L->src), UB_OK);
    if (k == 2) {
        assert_int_equal(ub_node_bind(m->n, TEST_GPS, &L->dst), UB_OK);
        ub_node_set_deliver_hook(m->n, delivery_log_hook, &L->log);
    }
    test_sec_on(&m->sec, m->n, GROUP_KEY, wall, true);
    if (!with_origin) return;
    ub_origin_options_t o = {.lookup = fleet_lookup, .lookup_user = &L->fleet};
    assert_int_equal(ub_origin_init(&m->org, &o), UB_OK);
    int fi = fleet_find(&L->fleet, ub_node_entity_id(m->n, m->self));
    assert_true(fi >= 0);
    assert_int_equal(ub_origin_add_identity(&m->org, L->fleet.id[fi], L->fleet.sk[fi]), UB_OK);
    assert_int_equal(ub_origin_attach(&m->org, m->n), UB_OK);
}

static void line_connect(line_t *L) {
    assert_int_equal(ub_memlink_connect(L->ml[0], L->m[0].n, L->m[0].link[0], L->m[1].n, L->m[1].link[0]), UB_OK);
    assert_int_equal(ub_memlink_connect(L->ml[1], L->m[1].n, L->m[1].link[1], L->m[2].n, L->m[2].link[0]), UB_OK);
}

static line_t *line_new(void) {
    line_t *L = calloc(1, sizeof *L);
    assert_non_null(L);
    L->w = world_new();
    for (int k = 0; k < 3; k++) fleet_add(&L->fleet, NAMES[k]);
    for (int k = 0; k < 3; k++) L->m[k].n = world_node(L->w, &ub_test_cat, NULL);
    for (int k = 0; k < 3; k++) member_setup(L, k, 1000, true);
    L->ml[0] = world_connect(L->w, L->m[0].n, L->m[0].link[0], L->m[1].n, L->m[1].link[0], NULL, 1);
    L->ml[1] = world_connect(L->w, L->m[1].n, L->m[1].link[1], L->m[2].n, L->m[2].link[0], NULL, 1);
    L->src = (struct test_gps){10.0, 20.0, 30.0f, 4};
    test_eid("a", L->a_id);
    test_eid("f", L->f_id);
    test_eid("b", L->b_id);
    return L;
}

static void line_free(line_t *L) {
    free(L->w);
    free(L);
}

static uint64_t drops(const member_t *m, ub_drop_reason_t why) { return ub_node_counters(m->n)->drops[why]; }

static size_t delivered(const line_t *L, uint64_t from, uint64_t to) {
    return delivery_count(&L->log, L->m[2].self, TEST_GPS, from, to);
}

/* What a node puts on its links (DATA frames only). */
typedef struct capture_log {
    size_t n;
    size_t len[64];
    uint8_t f[64][UB_FRAME_MAX];
} capture_log_t;

static void capture_tx(void *user, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)now_ms;
    (void)link_id;
    capture_log_t *c = user;
    if (dir != UB_TAP_TX || c->n == 64 || frame[UB_FRAME_OFF_ADMIN] != UB_ADMIN_DATA) return;
    memcpy(c->f[c->n], frame, len);
    c->len[c->n++] = len;
}

/* ---- tests ------------------------------------------------------------------------------------------------ */

static void test_pairwise_keys_agree_and_frames_flow_through_a_forwarder(void **state) {
    (void)state;
    line_t *L = line_new();
    /* both ends derive the same directional keys, and the two directions differ */
    uint8_t ab_tx[16], ab_rx[16], ba_tx[16], ba_rx[16];
    assert_int_equal(ub_origin_pair_keys(L->fleet.id[0], L->fleet.sk[0], L->fleet.id[2], L->fleet.pk[2], ab_tx, ab_rx), UB_OK);
    assert_int_equal(ub_origin_pair_keys(L->fleet.id[2], L->fleet.sk[2], L->fleet.id[0], L->fleet.pk[0], ba_tx, ba_rx), UB_OK);
    assert_memory_equal(ab_tx, ba_rx, 16);
    assert_memory_equal(ab_rx, ba_tx, 16);
    assert_memory_not_equal(ab_tx, ab_rx, 16);
    assert_int_equal(ub_origin_pair_keys(L->fleet.id[0], L->fleet.sk[0], L->fleet.id[0], L->fleet.pk[0], ab_tx, ab_rx),
                     UB_ERR_INVAL);
    static const uint8_t small_order[32] = {0}; /* the identity point: an all-zero agreement is refused */
    assert_int_equal(ub_origin_pair_keys(L->fleet.id[0], L->fleet.sk[0], L->fleet.id[2], small_order, ab_tx, ab_rx),
                     UB_ERR_AUTH);

    static capture_log_t on_wire;
    memset(&on_wire, 0, sizeof on_wire);
    ub_node_set_tap(L->m[1].n, capture_tx, &on_wire);
    assert_true(ub_pubsub_publish(L->m[0].n, L->m[0].self, TEST_GPS, L->b_id, 10, 0) >= 0);
    world_run(L->w, 1000, 1);
    /* f and b each challenge a once (origin-tagged challenge and reply); the rest arrives */
    assert_in_range(delivered(L, 0, 1001), 96, 99);
    assert_memory_equal(&L->dst, &L->src, sizeof L->src);
    /* what f relays is SIGNED | ORIGIN, hop limit lowered, hop0 the origin's, re-tagged by f */
    assert_true(on_wire.n > 0);
    for (size_t i = 0; i < on_wire.n; i++) {
        ub_frame_header_t h;
        assert_int_equal(ub_frame_parse(on_wire.f[i], on_wire.len[i], &h), UB_OK);
        assert_int_equal(on_wire.f[i][UB_FRAME_OFF_VERSION], 0x91);
        assert_int_equal(h.hop_limit, UB_DEFAULT_HOP_LIMIT - 1);
        assert_int_equal(h.origin_hop0, UB_DEFAULT_HOP_LIMIT);
        assert_int_equal(ub_sec_verify(&L->m[2].sec, &h, on_wire.f[i], on_wire.len[i], NULL, 0), UB_OK);
    }
    const ub_origin_stats_t *sa = ub_origin_stats(&L->m[0].org), *sb = ub_origin_stats(&L->m[2].org);
    assert_true(sb->opened >= 96);
    assert_true(sa->sealed >= 99);
    /* a derived one pair per peer it talks to (b; f for f's challenge), b one (a), cached afterwards */
    assert_int_equal(sa->derivations, 2);
    assert_int_equal(sb->derivations, 1);
    assert_int_equal(ub_origin_cached(&L->m[0].org), 2);
    for (int k = 0; k < 3; k++) {
        assert_int_equal(drops(&L->m[k], UB_DROP_BAD_ORIGIN) + drops(&L->m[k], UB_DROP_NO_ORIGIN) +
                             drops(&L->m[k], UB_DROP_NO_IDENTITY) + drops(&L->m[k], UB_DROP_BAD_TAG),
                         0);
    }
    line_free(L);
}

/* A frame f forges in a's name for b: the group key makes its hop tag right; its origin tag is made with
 * f's own pairwise key with b (the best an insider has), or is a guess. */
static size_t forge_as_a(line_t *L, uint8_t *out, uint64_t counter, bool with_origin, bool own_key) {
    member_t *f = &L->m[1];
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memcpy(h.dir_id, ub_test_cat.instances[TEST_GPS].id, UB_DIR_ID_LEN);
    memcpy(h.dest_id, L->b_id, UB_ENTITY_ID_LEN);
    memcpy(h.src_id, L->a_id, UB_ENTITY_ID_LEN);
    h.admin = UB_ADMIN_DATA;
    h.hop_limit = 7;
    h.payload_size = (uint16_t)ub_test_cat.instances[TEST_GPS].type->packed_size;
    h.fingerprint = ub_test_cat.instances[TEST_GPS].type->fingerprint;
    h.seq = (uint32_t)counter;
    h.counter_hi = (uint16_t)(counter >> 32);
    h.key_id = 1;
    h.flags = UB_FRAME_FLAG_SIGNED;
    uint8_t payload[UB_MAX_PAYLOAD];
    memset(payload, 0x66, h.payload_size); /* "armed = 1", "a waypoint": anything */
    if (with_origin) {
        h.flags |= UB_FRAME_FLAG_ORIGIN;
        h.origin_hop0 = 8;
        if (own_key) {
            uint8_t k_tx[16], k_rx[16];
            assert_int_equal(ub_origin_pair_keys(L->fleet.id[1], L->fleet.sk[1], L->b_id, L->fleet.pk[2], k_tx, k_rx),
                             UB_OK);
            assert_int_equal(ub_origin_tag(k_tx, &h, payload, h.origin_tag), UB_OK);
        } else {
            memset(h.origin_tag, 0xA5, sizeof h.origin_tag);
        }
    }
    int n = ub_sec_protect(&f->sec, &h, payload, out, UB_FRAME_MAX);
    assert_true(n > 0);
    return (size_t)n;
}

static void test_forwarder_with_the_group_key_cannot_forge_for_an_entity_it_relays(void **state) {
    (void)state;
    line_t *L = line_new();
    assert_true(ub_pubsub_publish(L->m[0].n, L->m[0].self, TEST_GPS, L->b_id, 10, 0) >= 0);
    world_run(L->w, 500, 1);
    size_t before = delivered(L, 0, 501);
    assert_true(before >= 45);
    member_t *b = &L->m[2];
    uint64_t opened = ub_origin_stats(&b->org)->opened;
    /* 20 forgeries of each kind, the last ones with the lockout counter 2^48 - 2 */
    uint8_t frame[UB_FRAME_MAX];
    for (int i = 0; i < 20; i++) {
        uint64_t counter = i < 19 ? UINT64_C(0x10000000) + (uint64_t)i : UB_SEC_COUNTER_MAX - 1u;
        size_t n = forge_as_a(L, frame, counter, true, true);
        assert_int_equal(ub_node_rx_frame(b->n, b->link[0], frame, n, 500), UB_OK);
        n = forge_as_a(L, frame, counter, true, false);
        assert_int_equal(ub_node_rx_frame(b->n, b->link[0], frame, n, 500), UB_OK);
        n = forge_as_a(L, frame, counter, false, false);
        assert_int_equal(ub_node_rx_frame(b->n, b->link[0], frame, n, 500), UB_OK);
    }
    assert_int_equal(drops(b, UB_DROP_BAD_ORIGIN), 40);
    assert_int_equal(drops(b, UB_DROP_NO_ORIGIN), 20);
    assert_int_equal(ub_node_link(b->n, b->link[0])->counters.drops[UB_DROP_BAD_ORIGIN], 40);
    assert_int_equal(ub_origin_stats(&b->org)->bad_origin, 40);
    assert_int_equal(ub_origin_stats(&b->org)->opened, opened);
    assert_int_equal(drops(b, UB_DROP_BAD_TAG), 0); /* the hop tag was right: an insider */
    assert_int_not_equal(L->dst.fix, 0x66666666); /* nothing of the forgery reached the storage */
    assert_memory_equal(&L->dst, &L->src, sizeof L->src);
    /* the lockout counter did not move b's window for a: a's genuine frames go on arriving */
    world_run(L->w, 1000, 1);
    assert_in_range(delivered(L, 501, 1001), 49, 50);
    assert_int_equal(drops(b, UB_DROP_REPLAY), 0);
    line_free(L);
}

static void test_hop_limit_is_under_a_tag(void **state) {
    (void)state;
    line_t *L = line_new();
    static capture_log_t cap; /* what a sends to f */
    memset(&cap, 0, sizeof cap);
    ub_node_set_tap(L->m[0].n, capture_tx, &cap);
    assert_true(ub_pubsub_publish(L->m[0].n, L->m[0].self, TEST_GPS, L->b_id, 10, 0) >= 0);
    world_run(L->w, 300, 1);
    ub_node_set_tap(L->m[0].n, NULL, NULL);
    assert_true(cap.n >= 20);
    member_t *f = &L->m[1], *b = &L->m[2];
    uint8_t frame[UB_FRAME_MAX];
    /* 1. an outsider raises or lowers the hop limit and fixes the checks: the hop tag fails at f */
    size_t n = cap.len[0];
    memcpy(frame, cap.f[0], n);
    assert_int_equal(ub_frame_set_hop_limit(frame, n, 200), UB_OK);
    assert_int_equal(ub_node_rx_frame(f->n, f->link[0], frame, n, 300), UB_OK);
    memcpy(frame, cap.f[1], n);
    assert_int_equal(ub_frame_set_hop_limit(frame, n, 3), UB_OK);
    assert_int_equal(ub_node_rx_frame(f->n, f->link[0], frame, n, 300), UB_OK);
    assert_int_equal(drops(f, UB_DROP_BAD_TAG), 2);
    /* 2. an insider (group key) re-tags a hop limit above the origin's: refused by the gate, anywhere */
    ub_frame_header_t h;
    assert_int_equal(ub_frame_parse(cap.f[2], cap.len[2], &h), UB_OK);
    h.hop_limit = 60;
    int m = ub_sec_protect(&f->sec, &h, cap.f[2] + UB_FRAME_HEADER_LEN, frame, sizeof frame);
    assert_true(m > 0);
    assert_int_equal(ub_node_rx_frame(b->n, b->link[0], frame, (size_t)m, 300), UB_OK);
    assert_int_equal(drops(b, UB_DROP_BAD_ORIGIN), 1);
    /* 3. ... and raises hop0 with it: the origin tag, which covers hop0, fails at the destination */
    assert_int_equal(ub_frame_parse(cap.f[3], cap.len[3], &h), UB_OK);
    h.hop_limit = 60;
    h.origin_hop0 = 60;
    m = ub_sec_protect(&f->sec, &h, cap.f[3] + UB_FRAME_HEADER_LEN, frame, sizeof frame);
    assert_true(m > 0);
    assert_int_equal(ub_node_rx_frame(b->n, b->link[0], frame, (size_t)m, 300), UB_OK);
    assert_int_equal(drops(b, UB_DROP_BAD_ORIGIN), 2);
    assert_int_equal(ub_origin_stats(&b->org)->bad_origin, 1);
    /* the untouched frame, lowered and re-tagged by an honest hop, is a duplicate at b, not a forgery */
    assert_int_equal(ub_frame_parse(cap.f[4], cap.len[4], &h), UB_OK);
    h.hop_limit = 6;
    m = ub_sec_protect(&f->sec, &h, cap.f[4] + UB_FRAME_HEADER_LEN, frame, sizeof frame);
    assert_int_equal(ub_node_rx_frame(b->n, b->link[0], frame, (size_t)m, 300), UB_OK);
    assert_int_equal(drops(b, UB_DROP_BAD_ORIGIN), 2);
    assert_int_equal(drops(b, UB_DROP_DUPLICATE) + drops(b, UB_DROP_REPLAY), 1);
    line_free(L);
}

static void test_restart_of_either_end_reestablishes(void **state) {
    (void)state;
    line_t *L = line_new();
    assert_true(ub_pubsub_publish(L->m[0].n, L->m[0].self, TEST_GPS, L->b_id, 10, 0) >= 0);
    world_run(L->w, 500, 1);
    assert_true(delivered(L, 0, 501) >= 45);
    /* the receiver restarts: window and pair cache lost; it challenges a (origin-tagged both ways) */
    member_setup(L, 2, 2000, true);
    line_connect(L);
    world_run(L->w, 1000, 1);
    assert_int_equal(ub_sec_stats(&L->m[2].sec)->challenges_completed, 1);
    assert_int_equal(ub_origin_stats(&L->m[2].org)->derivations, 1);
    assert_in_range(delivered(L, 501, 1001), 48, 50);
    /* the sender restarts (counters from a later wall clock, a new cache): no challenge needed, nothing lost
     * once its publication is set up again */
    member_setup(L, 0, 5000000, true);
    line_connect(L);
    assert_true(ub_pubsub_publish(L->m[0].n, L->m[0].self, TEST_GPS, L->b_id, 10, 1000) >= 0);
    world_run(L->w, 1500, 1);
    assert_in_range(delivered(L, 1001, 1501), 49, 51); /* every 10 ms from t = 1000 */
    /* Its counter jumped further than it could have counted since it last proved one (ub_sec_jump_limit()):
     * the forwarder and the destination each drop one frame counter_jump and challenge it, so besides its
     * pair with the destination it derives one with the forwarder (whose challenge is origin-tagged). */
    assert_int_equal(drops(&L->m[1], UB_DROP_COUNTER_JUMP), 1);
    assert_int_equal(drops(&L->m[2], UB_DROP_COUNTER_JUMP), 1);
    assert_int_equal(ub_origin_stats(&L->m[0].org)->derivations, 2);
    for (int k = 0; k < 3; k++)
        assert_int_equal(drops(&L->m[k], UB_DROP_BAD_ORIGIN) + drops(&L->m[k], UB_DROP_NO_IDENTITY), 0);
    line_free(L);
}

static void test_revoked_peer_is_refused_within_the_recheck(void **state) {
    (void)state;
    line_t *L = line_new();
    assert_true(ub_pubsub_publish(L->m[0].n, L->m[0].self, TEST_GPS, L->b_id, 10, 0) >= 0);
    world_run(L->w, 500, 1);
    L->fleet.revoked[0] = true; /* the store now refuses a */
    world_run(L->w, 3000, 1);
    /* b accepted a's frames at most until its cached pair was checked again (1 s) */
    assert_true(delivered(L, 1501, 3001) == 0);
    assert_true(drops(&L->m[2], UB_DROP_NO_IDENTITY) + drops(&L->m[0], UB_DROP_NO_IDENTITY) > 0);
    /* a still seals to b (b is not revoked); b refuses every frame of a, counted */
    assert_true(drops(&L->m[2], UB_DROP_NO_IDENTITY) >= 150);
    line_free(L);
}

/* The pair-cache tests' fleet: "me" (index 0), then UB_ORIGIN_PEERS + 8 peers p0.. (indexes 1..), more than
 * the cache holds. */
static void fleet_me_and_peers(fleet_t *fl) {
    memset(fl, 0, sizeof *fl);
    fleet_add(fl, "me");
    char name[16];
    for (int i = 0; i < UB_ORIGIN_PEERS + 8; i++) {
        snprintf(name, sizeof name, "p%d", i);
        fleet_add(fl, name);
    }
}

/* A header from "me" (fleet index 0) to fleet member `peer`, hop limit 8, for a payload of `payload_size`. */
static ub_frame_header_t me_to(const fleet_t *fl, int peer, uint16_t payload_size) {
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memcpy(h.dest_id, fl->id[peer], UB_ENTITY_ID_LEN);
    memcpy(h.src_id, fl->id[0], UB_ENTITY_ID_LEN);
    h.hop_limit = 8;
    h.payload_size = payload_size;
    return h;
}

/* Seals through the service's hook for `n` distinct peers, touching peer 0 before each new one. */
static void test_pair_cache_evicts_the_least_recently_used(void **state) {
    (void)state;
    static fleet_t fl;
    fleet_me_and_peers(&fl);
    world_t *w = world_new();
    ub_node_t *n = world_node(w, &ub_test_cat, NULL);
    int me = ub_node_add_entity_name(n, "me", true);
    int slot = ub_node_entity_slot(n, me);
    static ub_origin_t org;
    ub_origin_options_t o = {.lookup = fleet_lookup, .lookup_user = &fl};
    assert_int_equal(ub_origin_init(&org, &o), UB_OK);
    assert_int_equal(ub_origin_add_identity(&org, fl.id[0], fl.sk[0]), UB_OK);
    assert_int_equal(ub_origin_add_identity(&org, fl.id[0], fl.sk[0]), UB_ERR_EXISTS);
    uint8_t payload[4] = {1, 2, 3, 4};
    for (int i = 1; i <= UB_ORIGIN_PEERS + 8; i++) {
        for (int pass = 0; pass < 2; pass++) {
            int peer = pass == 0 ? 1 : i;
            ub_frame_header_t h = me_to(&fl, peer, sizeof payload);
            ub_drop_reason_t drop = UB_DROP_NO_ROUTE;
            assert_int_equal(org.svc.seal(&org.svc, n, slot, &h, payload, 10, &drop), 1);
            assert_int_equal(h.origin_hop0, 8);
        }
    }
    const ub_origin_stats_t *s = ub_origin_stats(&org);
    assert_int_equal(ub_origin_cached(&org), UB_ORIGIN_PEERS);
    assert_int_equal(s->evictions, 8);                        /* p1 was always the most recent: never evicted */
    assert_int_equal(s->derivations, UB_ORIGIN_PEERS + 8);   /* one per peer: p1 stayed cached */
    assert_int_equal(ub_origin_forget(&org, fl.id[1]), 1);
    assert_int_equal(ub_origin_cached(&org), UB_ORIGIN_PEERS - 1);
    /* a peer the store does not know: the frame is refused (fail closed), counted no_identity */
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    test_eid("stranger", h.dest_id);
    h.hop_limit = 8;
    ub_drop_reason_t drop = UB_DROP_NO_ROUTE;
    assert_true(org.svc.seal(&org.svc, n, slot, &h, payload, 10, &drop) < 0);
    assert_int_equal(drop, UB_DROP_NO_IDENTITY);
    assert_int_equal(s->no_identity, 1);
    /* link-local frames get no block */
    memset(h.dest_id, 0xFF, UB_ENTITY_ID_LEN);
    assert_int_equal(org.svc.seal(&org.svc, n, slot, &h, payload, 10, &drop), 0);
    free(w);
}

/* Issue 23 item 8: b is a microcontroller entity with no key agreement. The authority computed its
 * directional keys with a and f from b's secret key (what `uavbus keys pairwise` writes); b holds only those
 * (ub_origin_add_pair(), no store, no secret key), a and f derive theirs from b's public key as always.
 * Traffic and challenges flow both ways; f (the group key and its own pair with b) cannot forge for a. */
static void test_provisioned_pairs_interoperate_with_derived_ones(void **state) {
    (void)state;
    line_t *L = line_new();
    member_t *b = &L->m[2];
    assert_int_equal(ub_origin_detach(&b->org, b->n), UB_OK);
    ub_origin_options_t none = {0};                                  /* no lookup: provisioned pairs only */
    assert_int_equal(ub_origin_init(&b->org, &none), UB_OK);
    for (int peer = 0; peer < 2; peer++) {                           /* the authority's table for b */
        uint8_t k_tx[16], k_rx[16];
        assert_int_equal(ub_origin_pair_keys(L->b_id, L->fleet.sk[2], L->fleet.id[peer], L->fleet.pk[peer], k_tx, k_rx),
                         UB_OK);
        assert_int_equal(ub_origin_add_pair(&b->org, L->b_id, L->fleet.id[peer], k_tx, k_rx), UB_OK);
        assert_int_equal(ub_origin_add_pair(&b->org, L->b_id, L->fleet.id[peer], k_tx, k_rx), UB_OK); /* replaced */
    }
    uint8_t k[16] = {0};
    assert_int_equal(ub_origin_add_pair(&b->org, L->b_id, L->b_id, k, k), UB_ERR_INVAL);
    assert_int_equal(ub_origin_cached(&b->org), 2);
    assert_int_equal(ub_origin_attach(&b->org, b->n), UB_OK);

    assert_true(ub_pubsub_publish(L->m[0].n, L->m[0].self, TEST_GPS, L->b_id, 10, 0) >= 0);
    world_run(L->w, 1000, 1);
    assert_in_range(delivered(L, 0, 1001), 96, 99);   /* b challenged a once: its challenge went out tagged */
    assert_memory_equal(&L->dst, &L->src, sizeof L->src);
    const ub_origin_stats_t *sb = ub_origin_stats(&b->org);
    assert_true(sb->opened >= 96);
    assert_true(sb->sealed >= 1);                     /* b's challenge to a, verified by a's derived key */
    assert_int_equal(sb->derivations, 0);
    assert_int_equal(sb->lookups, 0);
    assert_int_equal(drops(&L->m[0], UB_DROP_BAD_ORIGIN) + drops(&L->m[0], UB_DROP_NO_IDENTITY), 0);
    /* f's forgeries in a's name: its own pairwise key with b, a guess, no block */
    uint8_t frame[UB_FRAME_MAX];
    for (int i = 0; i < 5; i++) {
        uint64_t counter = UINT64_C(0x10000000) + (uint64_t)i;
        size_t n = forge_as_a(L, frame, counter, true, true);
        assert_int_equal(ub_node_rx_frame(b->n, b->link[0], frame, n, 1001), UB_OK);
        n = forge_as_a(L, frame, counter, false, false);
        assert_int_equal(ub_node_rx_frame(b->n, b->link[0], frame, n, 1001), UB_OK);
    }
    assert_int_equal(drops(b, UB_DROP_BAD_ORIGIN), 5);
    assert_int_equal(drops(b, UB_DROP_NO_ORIGIN), 5);
    assert_memory_equal(&L->dst, &L->src, sizeof L->src);
    /* a peer outside the table: refused (no store to ask, and no secret key to derive with) */
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    test_eid("stranger", h.dest_id);
    h.hop_limit = 8;
    ub_drop_reason_t drop = UB_DROP_NO_ROUTE;
    uint8_t payload[4] = {0};
    h.payload_size = sizeof payload;
    assert_true(b->org.svc.seal(&b->org.svc, b->n, ub_node_entity_slot(b->n, b->self), &h, payload, 1001, &drop) < 0);
    assert_int_equal(drop, UB_DROP_NO_IDENTITY);
    /* revocation on b's side: the operator's forget (or a new table) ends the pair */
    assert_int_equal(ub_origin_forget(&b->org, L->a_id), 1);
    uint64_t refused = drops(b, UB_DROP_NO_IDENTITY);
    world_run(L->w, 1300, 1);
    assert_true(drops(b, UB_DROP_NO_IDENTITY) > refused);
    line_free(L);
}

/* Provisioned pairs are pinned: a full cache of derived pairs never evicts them, and they take no store. */
static void test_provisioned_pairs_are_never_evicted(void **state) {
    (void)state;
    static fleet_t fl;
    fleet_me_and_peers(&fl);
    world_t *w = world_new();
    ub_node_t *n = world_node(w, &ub_test_cat, NULL);
    int slot = ub_node_entity_slot(n, ub_node_add_entity_name(n, "me", true));
    static ub_origin_t org;
    ub_origin_options_t o = {.lookup = fleet_lookup, .lookup_user = &fl};
    assert_int_equal(ub_origin_init(&org, &o), UB_OK);
    assert_int_equal(ub_origin_add_identity(&org, fl.id[0], fl.sk[0]), UB_OK);
    uint8_t k_tx[16], k_rx[16];
    assert_int_equal(ub_origin_pair_keys(fl.id[0], fl.sk[0], fl.id[1], fl.pk[1], k_tx, k_rx), UB_OK);
    assert_int_equal(ub_origin_add_pair(&org, fl.id[0], fl.id[1], k_tx, k_rx), UB_OK);
    uint8_t payload[4] = {1, 2, 3, 4};
    for (int i = 2; i <= UB_ORIGIN_PEERS + 8; i++) {
        ub_frame_header_t h = me_to(&fl, i, sizeof payload);
        ub_drop_reason_t drop = UB_DROP_NO_ROUTE;
        assert_int_equal(org.svc.seal(&org.svc, n, slot, &h, payload, 10, &drop), 1);
    }
    uint64_t lookups = ub_origin_stats(&org)->lookups;
    ub_frame_header_t h = me_to(&fl, 1, sizeof payload);
    ub_drop_reason_t drop = UB_DROP_NO_ROUTE;
    assert_int_equal(org.svc.seal(&org.svc, n, slot, &h, payload, 10000, &drop), 1);   /* long after any recheck */
    uint8_t want[8];
    assert_int_equal(ub_origin_tag(k_tx, &h, payload, want), UB_OK);
    assert_memory_equal(h.origin_tag, want, 8);
    assert_int_equal(ub_origin_stats(&org)->lookups, lookups);      /* the pinned pair asked nobody */
    assert_int_equal(ub_origin_cached(&org), UB_ORIGIN_PEERS);
    free(w);
}

/* A compact link carries the origin block unchanged (ctl1 bit 5): the frame decoded is the frame encoded,
 * SIGNED and ENCRYPTED; ORIGIN without a protection is refused. */
static void test_compact_encoding_carries_the_origin_block(void **state) {
    (void)state;
    static ub_sec_t sec;
    test_sec_on(&sec, NULL, GROUP_KEY, 1000, false);
    ub_compact_codec_t codec;
    memset(&codec, 0, sizeof codec);
    for (int enc = 0; enc < 2; enc++) {
        ub_frame_header_t h;
        memset(&h, 0, sizeof h);
        test_eid("a", h.src_id);
        test_eid("b", h.dest_id);
        memcpy(h.dir_id, ub_test_cat.instances[TEST_GPS].id, UB_DIR_ID_LEN);
        h.fingerprint = ub_test_cat.instances[TEST_GPS].type->fingerprint;
        h.hop_limit = 5;
        h.origin_hop0 = 8;
        memset(h.origin_tag, 0x5C, sizeof h.origin_tag);
        h.payload_size = 20;
        h.seq = 77;
        h.counter_hi = 3;
        h.key_id = 1;
        h.flags = (uint8_t)((enc ? UB_FRAME_FLAG_ENCRYPTED : UB_FRAME_FLAG_SIGNED) | UB_FRAME_FLAG_ORIGIN);
        uint8_t payload[20], frame[UB_FRAME_MAX], pkt[UB_COMPACT_PACKET_MAX], back[UB_FRAME_MAX];
        for (int i = 0; i < 20; i++) payload[i] = (uint8_t)(i + 1);
        int n = ub_sec_protect(&sec, &h, payload, frame, sizeof frame);
        assert_true(n > 0);
        int p = ub_compact_encode(&codec, frame, (size_t)n, true, pkt, sizeof pkt);
        assert_true(p > 0);
        ub_frame_header_t d;
        ub_rx_reason_t why = UB_RX_REASON_COUNT;
        int m = ub_compact_decode(&codec, pkt, (size_t)p, NULL, back, sizeof back, &d, &why);
        assert_int_equal(m, n);
        assert_memory_equal(back, frame, (size_t)n);
        assert_int_equal(d.origin_hop0, 8);
        assert_memory_equal(d.origin_tag, h.origin_tag, 8);
        uint8_t plain[UB_MAX_PAYLOAD];
        assert_int_equal(ub_sec_verify(&sec, &d, back, (size_t)m, plain, sizeof plain), UB_OK);
        if (enc) assert_memory_equal(plain, payload, sizeof payload);
        /* the ORIGIN bit with protection 0: bad_version (the check made again over the change) */
        if (!enc) {
            assert_true((pkt[0] & UB_COMPACT_EXT) != 0);
            pkt[0] = (uint8_t)(pkt[0] & ~UB_COMPACT_PROT_MASK);
            assert_true(ub_compact_decode(&codec, pkt, (size_t)p, NULL, back, sizeof back, &d, &why) < 0);
            assert_int_equal(why, UB_RX_BAD_VERSION);
        }
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pairwise_keys_agree_and_frames_flow_through_a_forwarder),
        cmocka_unit_test(test_forwarder_with_the_group_key_cannot_forge_for_an_entity_it_relays),
        cmocka_unit_test(test_hop_limit_is_under_a_tag),
        cmocka_unit_test(test_restart_of_either_end_reestablishes),
        cmocka_unit_test(test_revoked_peer_is_refused_within_the_recheck),
        cmocka_unit_test(test_pair_cache_evicts_the_least_recently_used),
        cmocka_unit_test(test_compact_encoding_carries_the_origin_block),
        cmocka_unit_test(test_provisioned_pairs_interoperate_with_derived_ones),
        cmocka_unit_test(test_provisioned_pairs_are_never_evicted),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
