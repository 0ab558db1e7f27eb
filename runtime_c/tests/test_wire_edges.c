/*
 * The node's fragment and compact-link paths at their edges (ub_node_wire.c, issue #29 item 6), on a
 * transport the test holds (a bounded queue that pushes back like a full socket buffer) and an injected
 * clock:
 *  - a directory that fits every link's MTU goes as one plain frame; what no longer fits once the frame is
 *    signed or encrypted goes in fragments sized for that trailer; a node with a keyring but no transmit
 *    key sends unsigned frames and plans no trailer;
 *  - a packed (codec) directory split over a small MTU is reassembled whole; a reassembly under way is the
 *    node's next due time (its timeout) and is dropped `incomplete` when that comes;
 *  - both transmit slots held by pushed-back transfers: the next send is refused UB_ERR_AGAIN (tx_busy), so
 *    is a hand-over to a local entity; transfers stuck for a whole timeout are given up; a route lost
 *    under a paused transfer gives it up at the next tick;
 *  - a value its codec refuses is never fragmented;
 *  - on compact links with a large MTU, fragments leave room for byte stuffing; a compact link's node is
 *    polled every millisecond while attached, not once detached;
 *  - a LINK_HELLO on a full-frame link, or a malformed one on a compact link, is dropped bad_payload.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "support/ub_test_world.h"
#include "ub/ub_compact.h"
#include "ub/ub_frag.h"
#include "ub/ub_sec.h"
#include "ub/ub_service.h"
#include "ub/ub_wire.h"

/* ---- a catalogue: the test's gpsOut and imuOut plus bigFlag, a 2000-byte directory with a codec that
 * refuses a flag other than 0 or 1 (as generated codecs refuse an out-of-range bool) ---- */
#define BIG_FLAG_LEN 2000u
struct big_flag {
    uint8_t on; /* a bool on the wire: 0 or 1 */
    uint8_t body[BIG_FLAG_LEN - 1];
};
static int pack_big_flag(const void *obj, uint8_t *buf, size_t cap) {
    const struct big_flag *v = obj;
    if (cap < BIG_FLAG_LEN) return UB_ERR_NOSPACE;
    if (v->on > 1) return UB_ERR_RANGE;
    buf[0] = v->on;
    memcpy(buf + 1, v->body, sizeof v->body);
    return (int)BIG_FLAG_LEN;
}
static int unpack_big_flag(void *obj, const uint8_t *buf, size_t len) {
    struct big_flag *v = obj;
    if (len < BIG_FLAG_LEN || buf[0] > 1) return UB_ERR_RANGE;
    v->on = buf[0];
    memcpy(v->body, buf + 1, sizeof v->body);
    return (int)BIG_FLAG_LEN;
}
static const ub_type_desc_t flag_type = {"struct big_flag", 0xF1A6B16Bu, BIG_FLAG_LEN, sizeof(struct big_flag),
                                         pack_big_flag, unpack_big_flag};
static ub_instance_desc_t edge_insts[3];
static ub_catalogue_t edge_cat;
static uint32_t GPS, BIG;

static int by_id(const void *a, const void *b) {
    return memcmp(((const ub_instance_desc_t *)a)->id, ((const ub_instance_desc_t *)b)->id, UB_DIR_ID_LEN);
}

static void edge_cat_init(void) {
    edge_insts[0] = ub_test_cat.instances[TEST_GPS];
    edge_insts[1] = ub_test_cat.instances[TEST_IMU];
    ub_dir_id_paper("bigFlag", edge_insts[2].id);
    edge_insts[2].name = "bigFlag";
    edge_insts[2].type = &flag_type;
    qsort(edge_insts, 3, sizeof edge_insts[0], by_id);
    edge_cat = ub_test_cat;
    edge_cat.instances = edge_insts;
    edge_cat.n_instances = 3;
    edge_cat.max_packed_size = BIG_FLAG_LEN;
    edge_cat.json = NULL;
    edge_cat.json_len = 0;
    int g = ub_catalogue_find_name(&edge_cat, "gpsOut"), b = ub_catalogue_find_name(&edge_cat, "bigFlag");
    assert_true(g >= 0 && b >= 0);
    GPS = (uint32_t)g;
    BIG = (uint32_t)b;
}

/* ---- a transport: a queue of `limit` frames that pushes back (UB_ERR_AGAIN) when full ---- */
#define QMAX 320
typedef struct queue {
    size_t limit, n;
    size_t len[QMAX];
    uint8_t frame[QMAX][UB_FRAME_MAX];
} queue_t;

static int queue_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)now_ms;
    queue_t *q = impl;
    if (q->n >= q->limit) return UB_ERR_AGAIN;
    assert_true(len <= UB_FRAME_MAX);
    memcpy(q->frame[q->n], frame, len);
    q->len[q->n++] = len;
    return UB_OK;
}
static const ub_link_ops_t queue_ops = {.kind = "queue", .send = queue_send, .fileno = NULL};

/* ---- two nodes: a (local a and a2; b over link 0; nobody, unrouted) and b (a over link 0) ---- */
typedef struct pair {
    world_t *w;
    ub_node_t *a, *b;
    int ea, ea2, eb, a_b, a_nobody, b_a, la, lb;
    uint8_t b_id[UB_ENTITY_ID_LEN], a2_id[UB_ENTITY_ID_LEN], nobody_id[UB_ENTITY_ID_LEN];
    queue_t *qa, *qb;
    ub_frag_t *frag; /* [0] a's, [1] b's */
    struct test_gps gps_a, gps_b;
} pair_t;

static pair_t *pair_new(uint16_t mtu, size_t queue_limit) {
    pair_t *p = calloc(1, sizeof *p);
    assert_non_null(p);
    p->w = world_new();
    p->qa = calloc(1, sizeof *p->qa);
    p->qb = calloc(1, sizeof *p->qb);
    p->frag = calloc(2, sizeof *p->frag);
    assert_true(p->qa != NULL && p->qb != NULL && p->frag != NULL);
    p->qa->limit = queue_limit;
    p->qb->limit = QMAX;
    ub_node_options_t oa = {.first_seq = 1000, .random_seed = 1}, ob = {.first_seq = 2000, .random_seed = 2};
    p->a = world_node(p->w, &edge_cat, &oa);
    p->b = world_node(p->w, &edge_cat, &ob);
    p->ea = ub_node_add_entity_name(p->a, "a", true);
    p->ea2 = ub_node_add_entity_name(p->a, "a2", true);
    p->a_b = ub_node_add_entity_name(p->a, "b", false);
    p->a_nobody = ub_node_add_entity_name(p->a, "nobody", false);
    p->eb = ub_node_add_entity_name(p->b, "b", true);
    p->b_a = ub_node_add_entity_name(p->b, "a", false);
    assert_true(p->ea >= 0 && p->ea2 >= 0 && p->a_b >= 0 && p->a_nobody >= 0 && p->eb >= 0 && p->b_a >= 0);
    test_eid("b", p->b_id);
    test_eid("a2", p->a2_id);
    test_eid("nobody", p->nobody_id);
    p->la = ub_node_add_link(p->a, p->ea, 0, "toB");
    p->lb = ub_node_add_link(p->b, p->eb, 0, "toA");
    assert_true(p->la >= 0 && p->lb >= 0);
    assert_int_equal(ub_node_set_mask(p->a, p->ea, p->a_b, 0x01), UB_OK);
    assert_int_equal(ub_node_set_mask(p->b, p->eb, p->b_a, 0x01), UB_OK);
    assert_int_equal(ub_node_link_attach(p->a, p->la, &queue_ops, p->qa), UB_OK);
    assert_int_equal(ub_node_link_attach(p->b, p->lb, &queue_ops, p->qb), UB_OK);
    if (mtu != 0) assert_int_equal(ub_node_link_set_mtu(p->a, p->la, mtu), UB_OK);
    for (int i = 0; i < 2; i++) ub_frag_init(&p->frag[i], NULL, (uint16_t)(10 * i));
    assert_int_equal(ub_node_set_frag(p->a, &p->frag[0]), UB_OK);
    assert_int_equal(ub_node_set_frag(p->b, &p->frag[1]), UB_OK);
    assert_int_equal(ub_node_bind(p->a, GPS, &p->gps_a), UB_OK);
    assert_int_equal(ub_node_bind(p->b, GPS, &p->gps_b), UB_OK);
    return p;
}

static void pair_free(pair_t *p) {
    free(p->w);
    free(p->qa);
    free(p->qb);
    free(p->frag);
    free(p);
}

/* Hands a's queued frames [from, to) to b. */
static void deliver(pair_t *p, size_t from, size_t to, uint64_t now_ms) {
    for (size_t i = from; i < to; i++)
        assert_int_equal(ub_node_rx_frame(p->b, p->lb, p->qa->frame[i], p->qa->len[i], now_ms), UB_OK);
}

static uint64_t drops(const ub_node_t *n, ub_drop_reason_t why) { return ub_node_counters(n)->drops[why]; }

static const uint8_t KEY[UB_SEC_KEY_LEN] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16,
                                            17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31, 32};

/* gpsOut is 24 bytes: an 88-byte frame unsigned, 99 signed (11-byte trailer), 107 encrypted (19). */
static void test_fits_whole_unless_its_trailer_does_not(void **state) {
    (void)state;
    pair_t *p = pair_new(95, QMAX);
    p->gps_a = (struct test_gps){12.5, -3.25, 42.0f, 3};
    const ub_frag_stats_t *fs = ub_node_frag_stats(p->a);
    assert_int_equal(ub_node_send_data(p->a, p->ea, GPS, p->b_id, 0), 1);
    assert_int_equal(p->qa->n, 1); /* one plain frame */
    assert_int_equal(p->qa->len[0], UB_FRAME_HEADER_LEN + 24u);
    assert_int_equal(fs->tx_transfers, 0);
    deliver(p, 0, 1, 1);
    assert_memory_equal(&p->gps_b, &p->gps_a, sizeof p->gps_a);
    /* Nowhere to go: refused once, counted once (not by both the fragment and the plain path). */
    uint64_t no_route = drops(p->a, UB_DROP_NO_ROUTE);
    assert_int_equal(ub_node_send_data(p->a, p->ea, GPS, p->nobody_id, 2), UB_ERR_NOROUTE);
    assert_int_equal(drops(p->a, UB_DROP_NO_ROUTE), no_route + 1);
    assert_int_equal(p->qa->n, 1);

    /* A keyring without a transmit key signs nothing: still one 88-byte frame. */
    if (!ub_sec_available()) {
        pair_free(p);
        skip();
    }
    ub_sec_t *sec = calloc(1, sizeof *sec);
    assert_non_null(sec);
    assert_int_equal(ub_sec_init(sec, NULL), UB_OK);
    assert_int_equal(ub_sec_add_key(sec, 1, KEY), UB_OK);
    assert_int_equal(ub_sec_start(sec, 0, 1000), UB_OK);
    assert_int_equal(ub_node_set_security(p->a, sec), UB_OK);
    assert_int_equal(ub_node_send_data(p->a, p->ea, GPS, p->b_id, 3), 1);
    assert_int_equal(p->qa->n, 2);
    assert_int_equal(p->qa->len[1], UB_FRAME_HEADER_LEN + 24u);
    assert_int_equal(fs->tx_transfers, 0);
    /* Signing: 99 > 95, so fragments of at most 95 - 64 - 11 - 8 = 12 bytes: two of them. */
    assert_int_equal(ub_sec_set_tx_key(sec, 1), UB_OK);
    assert_int_equal(ub_node_send_data(p->a, p->ea, GPS, p->b_id, 4), 1);
    assert_int_equal(fs->tx_transfers, 1);
    assert_int_equal(p->qa->n, 4);
    for (size_t i = 2; i < 4; i++) assert_int_equal(p->qa->len[i], 95u);
    /* Encrypting: 95 - 64 - 19 - 8 = 4 bytes a fragment, six of them, none over the MTU. */
    assert_int_equal(ub_node_link_set_security(p->a, p->la, -1, true), UB_OK);
    assert_int_equal(ub_node_send_data(p->a, p->ea, GPS, p->b_id, 5), 1);
    assert_int_equal(fs->tx_transfers, 2);
    assert_int_equal(p->qa->n, 10);
    for (size_t i = 4; i < 10; i++) assert_true(p->qa->len[i] <= 95u);
    assert_int_equal(fs->tx_fragments, 2 + 6);
    free(sec);
    pair_free(p);
}

/* gpsOut (a codec type) over an 80-byte MTU: 80 - 64 - 8 = 8 bytes a fragment, three fragments. */
static void test_packed_directory_reassembled_and_a_stalled_one_times_out(void **state) {
    (void)state;
    pair_t *p = pair_new(80, QMAX);
    p->gps_a = (struct test_gps){1.5, 2.5, 3.5f, 7};
    assert_int_equal(ub_node_send_data(p->a, p->ea, GPS, p->b_id, 0), 1);
    assert_int_equal(p->qa->n, 3);
    for (size_t i = 0; i < 3; i++) assert_int_equal(p->qa->len[i], 80u);
    deliver(p, 0, 1, 10);
    assert_int_equal(ub_frag_pending(&p->frag[1]), 1);
    /* The reassembly is b's next work: at its timeout (and "now" if the clock is before its last fragment). */
    assert_int_equal(ub_node_next_due(p->b, 11), 10 + UB_FRAG_TIMEOUT_MS);
    assert_int_equal(ub_node_next_due(p->b, 5), 5);
    deliver(p, 1, 3, 12);
    assert_memory_equal(&p->gps_b, &p->gps_a, sizeof p->gps_a);
    assert_int_equal(p->frag[1].stats.rx_complete, 1);
    assert_int_equal(ub_frag_pending(&p->frag[1]), 0);
    assert_int_equal(ub_node_next_due(p->b, 13), UINT64_MAX);

    /* The next version loses its last two fragments: dropped incomplete at the timeout, not before. */
    p->gps_a.fix = 8;
    assert_int_equal(ub_node_send_data(p->a, p->ea, GPS, p->b_id, 100), 1);
    deliver(p, 3, 4, 100);
    uint64_t incomplete = drops(p->b, UB_DROP_INCOMPLETE);
    ub_node_tick(p->b, 100 + UB_FRAG_TIMEOUT_MS - 1);
    assert_int_equal(ub_frag_pending(&p->frag[1]), 1);
    ub_node_tick(p->b, 100 + UB_FRAG_TIMEOUT_MS);
    assert_int_equal(ub_frag_pending(&p->frag[1]), 0);
    assert_int_equal(p->frag[1].stats.rx_timeouts, 1);
    assert_int_equal(drops(p->b, UB_DROP_INCOMPLETE), incomplete + 1);
    assert_int_equal(p->gps_b.fix, 7);
    pair_free(p);
}

/* bigFlag over an 80-byte MTU is 250 fragments; a queue of 10 pushes back. */
static void test_busy_transmit_slots_and_stuck_transfers(void **state) {
    (void)state;
    pair_t *p = pair_new(80, 10);
    static struct big_flag big;
    memset(&big, 0x42, sizeof big);
    big.on = 1;
    assert_int_equal(ub_node_bind(p->a, BIG, &big), UB_OK);
    const ub_frag_stats_t *fs = ub_node_frag_stats(p->a);
    assert_int_equal(ub_node_send_data(p->a, p->ea, BIG, p->b_id, 0), 1); /* the first 10 fragments went */
    assert_int_equal(p->qa->n, 10);
    assert_int_equal(ub_node_send_data(p->a, p->ea, BIG, p->b_id, 0), 0); /* queued behind: pushed back at once */
    assert_int_equal(fs->tx_paused, 2);
    assert_int_equal(fs->tx_transfers, 2);
    /* Both transmit slots held: the next send is refused, and so is a hand-over to a2 (its image needs one). */
    assert_int_equal(ub_node_send_data(p->a, p->ea, BIG, p->b_id, 1), UB_ERR_AGAIN);
    assert_int_equal(fs->tx_busy, 1);
    uint64_t too_big = drops(p->a, UB_DROP_TOO_BIG);
    assert_int_equal(ub_node_send_data(p->a, p->ea, BIG, p->a2_id, 1), UB_ERR_AGAIN);
    assert_int_equal(drops(p->a, UB_DROP_TOO_BIG), too_big + 1);
    /* Transfers under way keep the node polled every millisecond. */
    assert_int_equal(ub_node_next_due(p->a, 5), 6);
    /* Still pushed back just before the timeout; given up at it, and the slots are free again. */
    ub_node_tick(p->a, UB_FRAG_TIMEOUT_MS - 1);
    assert_int_equal(fs->tx_abandoned, 0);
    assert_int_equal(fs->tx_paused, 4);
    ub_node_tick(p->a, UB_FRAG_TIMEOUT_MS);
    assert_int_equal(fs->tx_abandoned, 2);
    assert_int_equal(p->qa->n, 10);
    assert_int_equal(ub_node_next_due(p->a, UB_FRAG_TIMEOUT_MS), UINT64_MAX);
    p->qa->n = 0;
    p->qa->limit = QMAX;
    assert_int_equal(ub_node_send_data(p->a, p->ea, BIG, p->b_id, UB_FRAG_TIMEOUT_MS + 1), 1);
    assert_int_equal(p->qa->n, 250);
    pair_free(p);
}

static void test_route_lost_under_a_paused_transfer_gives_it_up(void **state) {
    (void)state;
    pair_t *p = pair_new(80, 10);
    static struct big_flag big;
    big.on = 0;
    assert_int_equal(ub_node_bind(p->a, BIG, &big), UB_OK);
    const ub_frag_stats_t *fs = ub_node_frag_stats(p->a);
    assert_int_equal(ub_node_send_data(p->a, p->ea, BIG, p->b_id, 0), 1);
    assert_int_equal(fs->tx_paused, 1);
    assert_int_equal(ub_node_set_mask(p->a, p->ea, p->a_b, 0), UB_OK); /* the route goes */
    p->qa->n = 0;                                                       /* the link drains */
    uint64_t no_route = drops(p->a, UB_DROP_NO_ROUTE), handed = fs->tx_fragments;
    ub_node_tick(p->a, 5);
    assert_int_equal(fs->tx_abandoned, 1);
    assert_int_equal(p->qa->n, 0); /* nothing more of it sent */
    assert_int_equal(drops(p->a, UB_DROP_NO_ROUTE), no_route + 1);
    assert_int_equal(fs->tx_fragments, handed);
    assert_int_equal(ub_node_next_due(p->a, 6), UINT64_MAX); /* nothing left to pump */
    pair_free(p);
}

/* A value the codec refuses is never split: the send fails with the codec's error, no fragment leaves, no
 * transmit slot is held (to a link or to a local entity). */
static void test_value_the_codec_refuses_is_not_fragmented(void **state) {
    (void)state;
    pair_t *p = pair_new(0, QMAX);
    static struct big_flag big;
    memset(&big, 0, sizeof big);
    big.on = 2;
    assert_int_equal(ub_node_bind(p->a, BIG, &big), UB_OK);
    const ub_frag_stats_t *fs = ub_node_frag_stats(p->a);
    assert_int_equal(ub_node_send_data(p->a, p->ea, BIG, p->b_id, 0), UB_ERR_RANGE);
    assert_int_equal(ub_node_send_data(p->a, p->ea, BIG, p->a2_id, 0), UB_ERR_RANGE);
    assert_int_equal(p->qa->n, 0);
    assert_int_equal(fs->tx_transfers, 0);
    assert_int_equal(fs->tx_fragments, 0);
    big.on = 1; /* a valid value goes: 2000 bytes in two fragments (no MTU: the payload limit) */
    assert_int_equal(ub_node_send_data(p->a, p->ea, BIG, p->b_id, 1), 1);
    assert_int_equal(p->qa->n, 2);
    assert_int_equal(fs->tx_transfers, 1);
    pair_free(p);
}

/* ---- compact links (memlinks, both ends compact) ---- */

typedef struct cpair {
    world_t *w;
    ub_node_t *a, *b;
    int ea, eb, la, lb;
    ub_compact_t ca, cb;
    ub_frag_t *frag;
} cpair_t;

static cpair_t *cpair_new(uint16_t mtu) {
    cpair_t *c = calloc(1, sizeof *c);
    assert_non_null(c);
    c->frag = calloc(2, sizeof *c->frag);
    assert_non_null(c->frag);
    c->w = world_new();
    ub_node_options_t oa = {.first_seq = 10, .random_seed = 3}, ob = {.first_seq = 20, .random_seed = 4};
    c->a = world_node(c->w, &edge_cat, &oa);
    c->b = world_node(c->w, &edge_cat, &ob);
    c->ea = ub_node_add_entity_name(c->a, "a", true);
    int a_b = ub_node_add_entity_name(c->a, "b", false);
    c->eb = ub_node_add_entity_name(c->b, "b", true);
    int b_a = ub_node_add_entity_name(c->b, "a", false);
    c->la = ub_node_add_link(c->a, c->ea, 0, "toB");
    c->lb = ub_node_add_link(c->b, c->eb, 0, "toA");
    assert_int_equal(ub_node_set_mask(c->a, c->ea, a_b, 0x01), UB_OK);
    assert_int_equal(ub_node_set_mask(c->b, c->eb, b_a, 0x01), UB_OK);
    (void)world_connect(c->w, c->a, c->la, c->b, c->lb, NULL, 5);
    assert_int_equal(ub_node_link_set_compact(c->a, c->la, &c->ca, NULL), UB_OK);
    assert_int_equal(ub_node_link_set_compact(c->b, c->lb, &c->cb, NULL), UB_OK);
    if (mtu != 0) {
        assert_int_equal(ub_node_link_set_mtu(c->a, c->la, mtu), UB_OK);
        assert_int_equal(ub_node_link_set_mtu(c->b, c->lb, mtu), UB_OK);
    }
    for (int i = 0; i < 2; i++) ub_frag_init(&c->frag[i], NULL, (uint16_t)(50 * i));
    assert_int_equal(ub_node_set_frag(c->a, &c->frag[0]), UB_OK);
    assert_int_equal(ub_node_set_frag(c->b, &c->frag[1]), UB_OK);
    world_run(c->w, 50, 10); /* the dictionaries agree */
    assert_true(ub_compact_agreed(&c->ca) && ub_compact_agreed(&c->cb));
    return c;
}

static void cpair_free(cpair_t *c) {
    free(c->w);
    free(c->frag);
    free(c);
}

/* 2000 bytes over a 1000-byte compact MTU: a fragment of ~990 bytes gains stuffing bytes (one per 254) that
 * must still fit, so each is cut to what fits once stuffed. */
static void test_compact_fragments_leave_room_for_stuffing(void **state) {
    (void)state;
    cpair_t *c = cpair_new(1000);
    static struct big_flag src, dst;
    for (size_t i = 0; i < sizeof src.body; i++) src.body[i] = (uint8_t)(i * 7u + 1u); /* no zero: all stuffed */
    src.on = 1;
    assert_int_equal(ub_node_bind(c->a, BIG, &src), UB_OK);
    assert_int_equal(ub_node_bind(c->b, BIG, &dst), UB_OK);
    uint8_t b_id[UB_ENTITY_ID_LEN];
    test_eid("b", b_id);
    const ub_link_t *out = ub_node_link(c->a, c->la);
    uint64_t frames = out->counters.frames_out, bytes = out->counters.bytes_out;
    assert_int_equal(ub_node_send_data(c->a, c->ea, BIG, b_id, c->w->now_ms), 1);
    world_run(c->w, c->w->now_ms + 5, 1);
    assert_memory_equal(&dst, &src, sizeof src);
    uint64_t n = out->counters.frames_out - frames, sent = out->counters.bytes_out - bytes;
    assert_int_equal(n, ub_node_frag_stats(c->a)->tx_fragments);
    assert_true(n >= 3); /* 2000 bytes do not fit two stuffed 1000-byte packets */
    assert_true(sent <= 1000u * n);
    assert_int_equal(drops(c->a, UB_DROP_TOO_BIG) + drops(c->b, UB_DROP_TOO_BIG), 0);
    cpair_free(c);
}

/* A compact link keeps its node polled every millisecond (its pages are paced inside the compact state);
 * detached, its hello rounds stop and so does the polling. */
static void test_compact_polling_follows_the_attached_link(void **state) {
    (void)state;
    cpair_t *c = cpair_new(0);
    uint64_t now = c->w->now_ms;
    assert_int_equal(ub_node_next_due(c->a, now), now + 1);
    assert_int_equal(ub_node_link_detach(c->a, c->la), UB_OK);
    assert_true(ub_node_next_due(c->a, now) > now + 1);
    uint64_t out = ub_node_link(c->a, c->la)->counters.frames_out;
    for (uint64_t t = now; t < now + 5000; t += 100) ub_node_tick(c->a, t); /* rounds would be due: none sent */
    assert_int_equal(ub_node_link(c->a, c->la)->counters.frames_out, out);
    cpair_free(c);
}

/* LINK_HELLO is a compact link's: on a full-frame link it is unusable, and a malformed one on a compact link
 * changes nothing; both are dropped bad_payload on the link they came in on. */
static void test_link_hello_on_a_full_link_or_malformed_is_dropped(void **state) {
    (void)state;
    pair_t *p = pair_new(0, QMAX);
    uint8_t junk[3] = {0xFF, 0x00, 0x01};
    assert_true(ub_node_send_link_local(p->a, p->la, UB_ADMIN_LINK_HELLO, junk, sizeof junk, 0) >= 0);
    assert_int_equal(p->qa->n, 1);
    const ub_link_t *in = ub_node_link(p->b, p->lb);
    uint64_t bad = in->counters.drops[UB_DROP_BAD_PAYLOAD];
    deliver(p, 0, 1, 1);
    assert_int_equal(in->counters.drops[UB_DROP_BAD_PAYLOAD], bad + 1);
    pair_free(p);

    cpair_t *c = cpair_new(0);
    const ub_compact_stats_t *st = ub_node_link_compact_stats(c->b, c->lb);
    assert_non_null(st);
    uint64_t hello_bad = st->hello_bad, changes = st->dict_changes;
    const ub_link_t *cin = ub_node_link(c->b, c->lb);
    bad = cin->counters.drops[UB_DROP_BAD_PAYLOAD];
    assert_true(ub_node_send_link_local(c->a, c->la, UB_ADMIN_LINK_HELLO, junk, sizeof junk, c->w->now_ms) >= 0);
    world_run(c->w, c->w->now_ms + 1, 1);
    assert_int_equal(cin->counters.drops[UB_DROP_BAD_PAYLOAD], bad + 1);
    assert_int_equal(st->hello_bad, hello_bad + 1);
    assert_int_equal(st->dict_changes, changes);
    assert_true(ub_compact_agreed(&c->cb));
    cpair_free(c);
}

int main(void) {
    edge_cat_init();
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fits_whole_unless_its_trailer_does_not),
        cmocka_unit_test(test_packed_directory_reassembled_and_a_stalled_one_times_out),
        cmocka_unit_test(test_busy_transmit_slots_and_stuck_transfers),
        cmocka_unit_test(test_route_lost_under_a_paused_transfer_gives_it_up),
        cmocka_unit_test(test_value_the_codec_refuses_is_not_fragmented),
        cmocka_unit_test(test_compact_fragments_leave_room_for_stuffing),
        cmocka_unit_test(test_compact_polling_follows_the_attached_link),
        cmocka_unit_test(test_link_hello_on_a_full_link_or_malformed_is_dropped),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
