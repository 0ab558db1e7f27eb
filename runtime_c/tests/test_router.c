/*
 * Routing rules of docs/architecture.md: forward on the mask minus the
 * ingress with the hop limit decremented, drop-and-count no_route, relay of
 * content IDs the forwarder does not know, direct hand-over between entities
 * of one node, stream reception in any chunking, the frame tap, and transport
 * failures counted by reason.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "support/ub_test_world.h"
#include "ub/ub_memlink.h"
#include "ub/ub_node.h"

/* A forwarder "fwd" with three links, all captured; it knows "far" through links 1 and 2. */
typedef struct fwd_fixture {
    ub_node_t node;
    int self, far;
    int link[3];
    capture_t cap[3];
} fwd_fixture_t;

static fwd_fixture_t *fwd_fixture(const ub_catalogue_t *cat) {
    fwd_fixture_t *f = calloc(1, sizeof *f);
    assert_non_null(f);
    assert_int_equal(ub_node_init(&f->node, cat, NULL), UB_OK);
    f->self = ub_node_add_entity_name(&f->node, "fwd", true);
    f->far = ub_node_add_entity_name(&f->node, "far", false);
    const char *names[3] = {"l0", "l1", "l2"};
    for (unsigned i = 0; i < 3; i++) {
        f->link[i] = ub_node_add_link(&f->node, f->self, i, names[i]);
        assert_int_equal(ub_node_link_attach(&f->node, f->link[i], &capture_ops, &f->cap[i]), UB_OK);
    }
    uint8_t mask;
    assert_int_equal(ub_link_mask_parse("0x00000110", &mask), UB_OK);
    assert_int_equal(ub_node_set_mask(&f->node, f->self, f->far, mask), UB_OK);
    return f;
}

static void test_forward_on_mask_minus_ingress_with_hop_decrement(void **state) {
    (void)state;
    fwd_fixture_t *f = fwd_fixture(&ub_test_cat);
    uint8_t frame[UB_FRAME_MAX];
    const uint8_t payload[4] = {1, 2, 3, 4};
    const ub_instance_desc_t *inst = &ub_test_cat.instances[TEST_IMU];
    size_t len = make_frame(frame, UB_ADMIN_DATA, inst->id, "near", "far", 1, 5, 77, payload, 4);

    /* In on link 0: out on links 1 and 2. */
    assert_int_equal(ub_node_rx_frame(&f->node, f->link[0], frame, len, 0), UB_OK);
    assert_int_equal(f->cap[0].n, 0);
    assert_int_equal(f->cap[1].n, 1);
    assert_int_equal(f->cap[2].n, 1);
    ub_frame_header_t h;
    assert_int_equal(ub_frame_parse(f->cap[1].frame[0], f->cap[1].len[0], &h), UB_OK);
    assert_int_equal(h.hop_limit, 4);
    assert_int_equal(h.seq, 1);
    /* Everything but the hop limit and the checks is relayed untouched. */
    assert_int_equal(f->cap[1].len[0], len);
    assert_memory_equal(f->cap[1].frame[0] + 4, frame + 4, UB_FRAME_OFF_HOP_LIMIT - 4);
    assert_memory_equal(f->cap[1].frame[0] + 50, frame + 50, 10);
    assert_memory_equal(f->cap[1].frame[0] + 64, payload, 4);

    /* In on link 1 (a new sequence): out on link 2 only, never back on the ingress. */
    len = make_frame(frame, UB_ADMIN_DATA, inst->id, "near", "far", 2, 5, 77, payload, 4);
    assert_int_equal(ub_node_rx_frame(&f->node, f->link[1], frame, len, 0), UB_OK);
    assert_int_equal(f->cap[1].n, 1);
    assert_int_equal(f->cap[2].n, 2);
    assert_int_equal(ub_node_counters(&f->node)->forwarded, 2);

    /* Hop limit 1 arriving: forwarding would send 0, so drop and count. */
    len = make_frame(frame, UB_ADMIN_DATA, inst->id, "near", "far", 3, 1, 77, payload, 4);
    assert_int_equal(ub_node_rx_frame(&f->node, f->link[0], frame, len, 0), UB_OK);
    assert_int_equal(ub_node_link(&f->node, f->link[0])->counters.drops[UB_DROP_HOP_LIMIT], 1);
    assert_int_equal(f->cap[2].n, 2);
    free(f);
}

static void test_no_route_is_dropped_and_counted(void **state) {
    (void)state;
    fwd_fixture_t *f = fwd_fixture(&ub_test_cat);
    uint8_t frame[UB_FRAME_MAX];
    const ub_instance_desc_t *inst = &ub_test_cat.instances[TEST_IMU];
    /* Unknown destination. */
    size_t len = make_frame(frame, UB_ADMIN_DATA, inst->id, "near", "nobody", 1, 5, 0, NULL, 0);
    assert_int_equal(ub_node_rx_frame(&f->node, f->link[0], frame, len, 0), UB_OK);
    /* Known destination, but its only links are the ingress: set far = link 1 only, arrive on link 1. */
    assert_int_equal(ub_node_set_mask(&f->node, f->self, f->far, 0x02), UB_OK);
    len = make_frame(frame, UB_ADMIN_DATA, inst->id, "near", "far", 2, 5, 0, NULL, 0);
    assert_int_equal(ub_node_rx_frame(&f->node, f->link[1], frame, len, 0), UB_OK);
    assert_int_equal(ub_node_counters(&f->node)->drops[UB_DROP_NO_ROUTE], 2);
    assert_int_equal(f->cap[0].n + f->cap[1].n + f->cap[2].n, 0);
    /* Originating towards an unknown entity. */
    uint8_t nobody[UB_ENTITY_ID_LEN];
    test_eid("nobody", nobody);
    struct test_imu imu = {0};
    assert_int_equal(ub_node_bind(&f->node, TEST_IMU, &imu), UB_OK);
    assert_int_equal(ub_node_send_data(&f->node, f->self, TEST_IMU, nobody, 0), UB_ERR_NOROUTE);
    assert_int_equal(ub_node_counters(&f->node)->drops[UB_DROP_NO_ROUTE], 3);
    free(f);
}

/* An older build relays a content ID it does not know (the paper's motivation). */
static void test_intermediate_relays_unknown_content(void **state) {
    (void)state;
    world_t *w = world_new();
    ub_node_t *newer_a = world_node(w, &ub_test_cat_newer, NULL);
    ub_node_t *older = world_node(w, &ub_test_cat, NULL);
    ub_node_t *newer_c = world_node(w, &ub_test_cat_newer, NULL);
    uint8_t id_a[UB_ENTITY_ID_LEN], id_c[UB_ENTITY_ID_LEN];
    test_eid("a", id_a);
    test_eid("c", id_c);
    int a = ub_node_add_entity(newer_a, id_a, true);
    int a_c = ub_node_add_entity(newer_a, id_c, false);
    int b = ub_node_add_entity_name(older, "b", true);
    int b_c = ub_node_add_entity(older, id_c, false);
    int c = ub_node_add_entity(newer_c, id_c, true);
    int la = ub_node_add_link(newer_a, a, 0, "aTob");
    int lb0 = ub_node_add_link(older, b, 0, "bToa");
    int lb1 = ub_node_add_link(older, b, 1, "bToc");
    int lc = ub_node_add_link(newer_c, c, 0, "cTob");
    assert_int_equal(ub_node_set_mask(newer_a, a, a_c, 0x01), UB_OK);
    assert_int_equal(ub_node_set_mask(older, b, b_c, 0x02), UB_OK);
    world_connect(w, newer_a, la, older, lb0, NULL, 0);
    world_connect(w, older, lb1, newer_c, lc, NULL, 0);
    struct test_new sent = {0xDEADBEEF, 42}, got = {0, 0};
    assert_int_equal(ub_node_bind(newer_a, TEST_NEW, &sent), UB_OK);
    assert_int_equal(ub_node_bind(newer_c, TEST_NEW, &got), UB_OK);
    assert_int_equal(ub_node_send_data(newer_a, a, TEST_NEW, id_c, 0), 1);
    world_run(w, 10, 1);
    assert_int_equal(ub_node_counters(older)->forwarded, 1);
    assert_int_equal(ub_node_counters(older)->drops[UB_DROP_UNKNOWN_CONTENT], 0);
    assert_int_equal(got.a, 0xDEADBEEF);
    assert_int_equal(got.b, 42);
    free(w);
}

static void test_local_entities_hand_over_directly(void **state) {
    (void)state;
    ub_node_t *n = calloc(1, sizeof *n);
    assert_non_null(n);
    assert_int_equal(ub_node_init(n, &ub_test_cat, NULL), UB_OK);
    int gcs = ub_node_add_entity_name(n, "gcs", true);
    int sim = ub_node_add_entity_name(n, "sim", true);
    struct test_gps g = {1, 2, 3, 4};
    assert_int_equal(ub_node_bind(n, TEST_GPS, &g), UB_OK);
    delivery_log_t *log = calloc(1, sizeof *log);
    assert_non_null(log);
    ub_node_set_deliver_hook(n, delivery_log_hook, log);
    assert_int_equal(ub_node_send_data(n, gcs, TEST_GPS, ub_node_entity_id(n, sim), 5), 0);
    assert_int_equal(ub_node_counters(n)->local_direct, 1);
    assert_int_equal(log->n, 1);
    assert_int_equal(log->d[0].entity, sim);
    free(log);
    free(n);
}

static void test_delivery_checks_are_counted(void **state) {
    (void)state;
    fwd_fixture_t *f = fwd_fixture(&ub_test_cat);
    uint8_t frame[UB_FRAME_MAX];
    uint8_t payload[28] = {0};
    const ub_instance_desc_t *imu = &ub_test_cat.instances[TEST_IMU];
    const ub_instance_desc_t *newer = &ub_test_cat_newer.instances[TEST_NEW];
    /* Unbound instance. */
    size_t len = make_frame(frame, UB_ADMIN_DATA, imu->id, "near", "fwd", 1, 5, imu->type->fingerprint, payload, 28);
    assert_int_equal(ub_node_rx_frame(&f->node, f->link[0], frame, len, 0), UB_OK);
    /* Content this build does not know, addressed to it. */
    len = make_frame(frame, UB_ADMIN_DATA, newer->id, "near", "fwd", 2, 5, newer->type->fingerprint, payload, 8);
    assert_int_equal(ub_node_rx_frame(&f->node, f->link[0], frame, len, 0), UB_OK);
    /* Right fingerprint, wrong size. */
    struct test_imu storage;
    memset(&storage, 0x5A, sizeof storage);
    assert_int_equal(ub_node_bind(&f->node, TEST_IMU, &storage), UB_OK);
    len = make_frame(frame, UB_ADMIN_DATA, imu->id, "near", "fwd", 3, 5, imu->type->fingerprint, payload, 20);
    assert_int_equal(ub_node_rx_frame(&f->node, f->link[0], frame, len, 0), UB_OK);
    /* An admin frame too short to read. */
    len = make_frame(frame, UB_ADMIN_PUB_REQUEST, imu->id, "near", "fwd", 4, 5, imu->type->fingerprint, payload, 3);
    assert_int_equal(ub_node_rx_frame(&f->node, f->link[0], frame, len, 0), UB_OK);
    const ub_link_counters_t *c = &ub_node_link(&f->node, f->link[0])->counters;
    assert_int_equal(c->drops[UB_DROP_UNBOUND], 1);
    assert_int_equal(c->drops[UB_DROP_UNKNOWN_CONTENT], 1);
    assert_int_equal(c->drops[UB_DROP_LAYOUT_MISMATCH], 1);
    assert_int_equal(c->drops[UB_DROP_BAD_PAYLOAD], 1);
    assert_int_equal(c->frames_in, 4);
    assert_int_equal(((uint8_t *)&storage)[0], 0x5A);
    free(f);
}

/* Frame tap: every verified frame in, every frame out. */
typedef struct tap_log {
    int rx, tx;
    int last_link;
} tap_log_t;

static void tap(void *user, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)frame;
    (void)len;
    (void)now_ms;
    tap_log_t *t = user;
    if (dir == UB_TAP_RX) t->rx++;
    else t->tx++;
    t->last_link = link_id;
}

static void test_stream_rx_any_chunking_and_tap(void **state) {
    (void)state;
    /* Three frames with garbage between them, as one byte stream. */
    uint8_t stream[3 * (UB_FRAME_HEADER_LEN + 24) + 20];
    size_t total = 0;
    const ub_instance_desc_t *gps = &ub_test_cat.instances[TEST_GPS];
    uint8_t payload[24] = {0};
    for (uint32_t i = 0; i < 3; i++) {
        uint8_t frame[UB_FRAME_MAX];
        size_t len = make_frame(frame, UB_ADMIN_DATA, gps->id, "near", "fwd", 10 + i, 5, gps->type->fingerprint,
                                payload, 24);
        memcpy(stream + total, frame, len);
        total += len;
        if (i < 2) {
            memset(stream + total, 0x11 * (i + 1), 10);
            total += 10;
        }
    }
    for (size_t chunk = 1; chunk <= total; chunk += (chunk < 8 ? 1 : 37)) {
        fwd_fixture_t *f = fwd_fixture(&ub_test_cat);
        struct test_gps g;
        assert_int_equal(ub_node_bind(&f->node, TEST_GPS, &g), UB_OK);
        tap_log_t t = {0, 0, -1};
        ub_node_set_tap(&f->node, tap, &t);
        int frames = 0;
        for (size_t off = 0; off < total; off += chunk) {
            size_t n = total - off < chunk ? total - off : chunk;
            int rc = ub_node_rx(&f->node, f->link[2], stream + off, n, 0);
            assert_true(rc >= 0);
            frames += rc;
        }
        assert_int_equal(frames, 3);
        assert_int_equal(ub_node_counters(&f->node)->delivered, 3);
        assert_int_equal(t.rx, 3);
        assert_int_equal(t.last_link, f->link[2]);
        assert_int_equal(ub_node_link(&f->node, f->link[2])->decoder.stats.garbage_bytes, 20);
        assert_int_equal(ub_node_link(&f->node, f->link[2])->counters.bytes_in, total);
        free(f);
    }
}

static void test_bad_datagram_counted(void **state) {
    (void)state;
    fwd_fixture_t *f = fwd_fixture(&ub_test_cat);
    uint8_t frame[UB_FRAME_MAX];
    const ub_instance_desc_t *gps = &ub_test_cat.instances[TEST_GPS];
    uint8_t payload[24] = {0};
    size_t len = make_frame(frame, UB_ADMIN_DATA, gps->id, "near", "far", 1, 5, gps->type->fingerprint, payload, 24);
    frame[UB_FRAME_HEADER_LEN + 3] ^= 0x40; /* payload bit flip */
    assert_int_equal(ub_node_rx_frame(&f->node, f->link[0], frame, len, 0), UB_ERR_CHECKSUM);
    assert_int_equal(ub_node_link_bad_frames(&f->node, f->link[0], UB_RX_BAD_CRC), 1);
    assert_int_equal(ub_node_link(&f->node, f->link[0])->counters.frames_in, 0);
    assert_int_equal(f->cap[1].n + f->cap[2].n, 0);
    free(f);
}

static void test_transport_failures_counted_by_reason(void **state) {
    (void)state;
    fwd_fixture_t *f = fwd_fixture(&ub_test_cat);
    struct test_imu imu = {0};
    assert_int_equal(ub_node_bind(&f->node, TEST_IMU, &imu), UB_OK);
    f->cap[1].rc = UB_ERR_AGAIN;
    f->cap[2].rc = UB_ERR_IO;
    assert_int_equal(ub_node_send_data(&f->node, f->self, TEST_IMU, ub_node_entity_id(&f->node, f->far), 0), 0);
    assert_int_equal(ub_node_link(&f->node, f->link[1])->counters.drops[UB_DROP_BACKPRESSURE], 1);
    assert_int_equal(ub_node_link(&f->node, f->link[2])->counters.drops[UB_DROP_TX_ERROR], 1);
    f->cap[1].rc = UB_OK;
    assert_int_equal(ub_node_send_data(&f->node, f->self, TEST_IMU, ub_node_entity_id(&f->node, f->far), 0), 1);
    assert_int_equal(ub_node_link(&f->node, f->link[1])->counters.frames_out, 1);
    assert_int_equal(ub_node_link(&f->node, f->link[1])->counters.bytes_out, UB_FRAME_HEADER_LEN + 28);
    free(f);
}

/* A capturing transport that also takes forwards with their hop limit (ub_link_ops_t.send_hop), as a memlink
 * does, and counts them: the node's direct forward, one copy into the transport's buffer. */
static unsigned hop_sends;
static int capture_hop_send(void *impl, const uint8_t *frame, size_t len, uint8_t hop_limit, ub_frame_hop_memo_t *memo,
                            uint64_t now_ms) {
    (void)now_ms;
    capture_t *cap = impl;
    hop_sends++;
    if (cap->rc < 0) return cap->rc;
    assert_true(cap->n < CAPTURE_MAX);
    int rc = ub_frame_copy_hop_limit(cap->frame[cap->n], frame, len, hop_limit, memo);
    if (rc < 0) return rc;
    cap->len[cap->n++] = len;
    return UB_OK;
}
static int capture_plain_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    return capture_ops.send(impl, frame, len, now_ms);
}
static const ub_link_ops_t capture_hop_ops = {.kind = "capture", .send = capture_plain_send, .send_hop = capture_hop_send};

/* A forward to one link whose transport takes send_hop leaves with the bytes and counters of the general path
 * (the node's patched copy through send()), frame after frame (the memo reused, then replaced by another hop
 * limit); a refusal is counted the same; a second outgoing link or a tap takes the general path. */
static void test_direct_forward_equals_general_path(void **state) {
    (void)state;
    fwd_fixture_t *g = fwd_fixture(&ub_test_cat), *d = fwd_fixture(&ub_test_cat);
    for (fwd_fixture_t *f = g; f != NULL; f = f == g ? d : NULL)
        assert_int_equal(ub_node_set_mask(&f->node, f->self, f->far, 0x02), UB_OK); /* link 1 only */
    assert_int_equal(ub_node_link_detach(&d->node, d->link[1]), UB_OK);
    assert_int_equal(ub_node_link_attach(&d->node, d->link[1], &capture_hop_ops, &d->cap[1]), UB_OK);
    hop_sends = 0;
    const uint8_t payload[6] = {9, 8, 7, 6, 5, 4};
    const ub_instance_desc_t *inst = &ub_test_cat.instances[TEST_IMU];
    for (uint32_t seq = 1; seq <= 6; seq++) {
        uint8_t frame[UB_FRAME_MAX];
        size_t len = make_frame(frame, UB_ADMIN_DATA, inst->id, "near", "far", seq, seq <= 3 ? 9 : 200, 77, payload,
                                (uint16_t)seq);
        if (seq == 5) d->cap[1].rc = g->cap[1].rc = UB_ERR_AGAIN;
        if (seq == 6) d->cap[1].rc = g->cap[1].rc = UB_OK;
        assert_int_equal(ub_node_rx_frame(&g->node, g->link[0], frame, len, 0), UB_OK);
        assert_int_equal(ub_node_rx_frame(&d->node, d->link[0], frame, len, 0), UB_OK);
    }
    assert_int_equal(hop_sends, 6);
    assert_int_equal(d->cap[1].n, 5);
    assert_int_equal(g->cap[1].n, d->cap[1].n);
    for (size_t k = 0; k < d->cap[1].n; k++) {
        assert_int_equal(d->cap[1].len[k], g->cap[1].len[k]);
        assert_memory_equal(d->cap[1].frame[k], g->cap[1].frame[k], g->cap[1].len[k]);
        assert_int_equal(ub_frame_parse(d->cap[1].frame[k], d->cap[1].len[k], NULL), UB_OK);
    }
    const ub_link_counters_t *cg = &ub_node_link(&g->node, g->link[1])->counters;
    const ub_link_counters_t *cd = &ub_node_link(&d->node, d->link[1])->counters;
    assert_int_equal(cd->frames_out, cg->frames_out);
    assert_int_equal(cd->bytes_out, cg->bytes_out);
    assert_int_equal(cd->drops[UB_DROP_BACKPRESSURE], 1);
    assert_int_equal(cg->drops[UB_DROP_BACKPRESSURE], 1);
    assert_int_equal(ub_node_counters(&d->node)->forwarded, ub_node_counters(&g->node)->forwarded);
    /* Two outgoing links, or a tap that must see the frame sent: the general path, same bytes again. */
    uint8_t frame[UB_FRAME_MAX];
    size_t len = make_frame(frame, UB_ADMIN_DATA, inst->id, "near", "far", 7, 9, 77, payload, 6);
    assert_int_equal(ub_node_set_mask(&d->node, d->self, d->far, 0x06), UB_OK);
    assert_int_equal(ub_node_rx_frame(&d->node, d->link[0], frame, len, 0), UB_OK);
    assert_int_equal(hop_sends, 6);
    assert_int_equal(d->cap[2].n, 1);
    assert_memory_equal(d->cap[1].frame[d->cap[1].n - 1], d->cap[2].frame[0], len);
    free(g);
    free(d);
}

/* A forward over a memlink is patched into the queue slot; with faults (a delay) into a copy taking send()'s
 * path. Both arrive as ub_frame_set_hop_limit() writes them, seen by the next node's tap. */
static uint8_t tapped[UB_FRAME_MAX];
static size_t tapped_len;
static void tap_rx(void *user, int link_id, ub_tap_dir_t dir, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)user, (void)link_id, (void)now_ms;
    if (dir != UB_TAP_RX) return;
    memcpy(tapped, frame, len);
    tapped_len = len;
}

static void test_memlink_forward_patches_in_its_slot(void **state) {
    (void)state;
    ub_node_t *fw = calloc(2, sizeof *fw), *end = fw + 1;
    ub_memlink_t ml;
    assert_non_null(fw);
    assert_int_equal(ub_node_init(fw, &ub_test_cat, NULL), UB_OK);
    assert_int_equal(ub_node_init(end, &ub_test_cat, NULL), UB_OK);
    int self = ub_node_add_entity_name(fw, "fwd", true), far = ub_node_add_entity_name(fw, "far", false);
    int in = ub_node_add_link(fw, self, 0, "in"), out = ub_node_add_link(fw, self, 1, "out");
    assert_true(far >= 0 && in >= 0 && out >= 0);
    capture_t sink = {0};
    assert_int_equal(ub_node_link_attach(fw, in, &capture_ops, &sink), UB_OK);
    assert_int_equal(ub_node_set_mask(fw, self, far, 0x02), UB_OK);
    int end_self = ub_node_add_entity_name(end, "far", true);
    int back = ub_node_add_link(end, end_self, 0, "back");
    assert_true(back >= 0);
    ub_memlink_init(&ml, NULL, 5);
    assert_int_equal(ub_memlink_connect(&ml, fw, out, end, back), UB_OK);
    ub_node_set_tap(end, tap_rx, NULL);
    const ub_instance_desc_t *inst = &ub_test_cat.instances[TEST_IMU];
    const uint8_t payload[3] = {1, 2, 3};
    for (int faulty = 0; faulty < 2; faulty++) {
        ub_memlink_faults_t delay = {.delay_ms = 1};
        ub_memlink_set_faults(&ml, faulty ? &delay : NULL);
        uint8_t frame[UB_FRAME_MAX], want[UB_FRAME_MAX];
        size_t len = make_frame(frame, UB_ADMIN_DATA, inst->id, "near", "far", 10u + (uint32_t)faulty, 7, 77, payload, 3);
        memcpy(want, frame, len);
        assert_int_equal(ub_frame_set_hop_limit(want, len, 6), UB_OK);
        tapped_len = 0;
        assert_int_equal(ub_node_rx_frame(fw, in, frame, len, 10), UB_OK);
        assert_int_equal(ub_memlink_pump(&ml, 10), faulty ? 0u : 1u);
        if (faulty) assert_int_equal(ub_memlink_pump(&ml, 11), 1u);
        assert_int_equal(tapped_len, len);
        assert_memory_equal(tapped, want, len);
        assert_int_equal(ub_memlink_stats(&ml, 0)->sent, (uint64_t)faulty + 1u);
    }
    assert_int_equal(ub_node_link(fw, out)->counters.frames_out, 2);
    ub_memlink_disconnect(&ml);
    free(fw);
}

/* An originated plain frame on one link (finished in place, no forms) has the bytes the reference build writes
 * for its header and payload, as on two links (the forms path); the template cache serves both. */
static void assert_reference_frame(const capture_t *cap, size_t k) {
    ub_frame_header_t h;
    assert_int_equal(ub_frame_parse(cap->frame[k], cap->len[k], &h), UB_OK);
    uint8_t want[UB_FRAME_MAX];
    memcpy(want + UB_FRAME_HEADER_LEN, cap->frame[k] + UB_FRAME_HEADER_LEN, h.payload_size);
    assert_int_equal(ub_frame_finish(want, sizeof want, &h), (int)cap->len[k]);
    assert_memory_equal(cap->frame[k], want, cap->len[k]);
}

static void test_origin_on_one_link_equals_reference(void **state) {
    (void)state;
    fwd_fixture_t *f = fwd_fixture(&ub_test_cat);
    struct test_imu imu = {0};
    assert_int_equal(ub_node_bind(&f->node, TEST_IMU, &imu), UB_OK);
    const uint8_t *far = ub_node_entity_id(&f->node, f->far);
    for (int k = 0; k < 6; k++) {
        imu.t_ms = (uint32_t)k * 7u; /* another payload each time */
        assert_int_equal(ub_node_set_mask(&f->node, f->self, f->far, k % 3 == 2 ? 0x06 : 0x02), UB_OK);
        assert_int_equal(ub_node_send_data(&f->node, f->self, TEST_IMU, far, (uint64_t)k), k % 3 == 2 ? 2 : 1);
    }
    assert_int_equal(f->cap[1].n, 6);
    assert_int_equal(f->cap[2].n, 2);
    for (size_t k = 0; k < f->cap[1].n; k++) assert_reference_frame(&f->cap[1], k);
    for (size_t k = 0; k < f->cap[2].n; k++) assert_reference_frame(&f->cap[2], k);
    assert_memory_equal(f->cap[1].frame[2], f->cap[2].frame[0], f->cap[1].len[2]); /* the same frame on both */
    free(f);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_forward_on_mask_minus_ingress_with_hop_decrement),
        cmocka_unit_test(test_no_route_is_dropped_and_counted),
        cmocka_unit_test(test_intermediate_relays_unknown_content),
        cmocka_unit_test(test_local_entities_hand_over_directly),
        cmocka_unit_test(test_delivery_checks_are_counted),
        cmocka_unit_test(test_stream_rx_any_chunking_and_tap),
        cmocka_unit_test(test_bad_datagram_counted),
        cmocka_unit_test(test_transport_failures_counted_by_reason),
        cmocka_unit_test(test_direct_forward_equals_general_path),
        cmocka_unit_test(test_memlink_forward_patches_in_its_slot),
        cmocka_unit_test(test_origin_on_one_link_equals_reference),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
