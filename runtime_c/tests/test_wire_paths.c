/*
 * The wire issue's paths, on memlinks and an injected clock:
 *  - compact and full links mixed on one 3-hop path deliver exactly the directories sent, and the compact
 *    links carry them in a few bytes once the dictionaries are agreed (LINK_HELLO);
 *  - signed frames cross compact links and are verified after every translation (also when a forwarder
 *    turns them into ENCRYPTED frames for a compact link); a forged compact frame is `bad_tag`;
 *  - nodes with different entity tables fall back to full IDs and still deliver; a restarted peer
 *    (new epoch) is caught up;
 *  - a frame over an outgoing link's MTU is dropped `too_big` by a forwarder;
 *  - a 16 KiB directory crosses 2 hops of 255-byte-MTU compact links, signed, in fragments;
 *  - fragments under 30 % loss, duplication and reordering: every directory arrives whole or is
 *    counted `incomplete`, never torn.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "support/ub_test_store.h"
#include "support/ub_test_world.h"
#include "ub/ub_compact.h"
#include "ub/ub_frag.h"
#include "ub/ub_sec.h"
#include "ub/ub_wire.h"
#include "core/ub_rng_private.h"

/* ---- a catalogue with large directories (wire-image storage: pack/unpack NULL) ---- */
#define BIG_LEN 16384u
#define MID_LEN 700u
static ub_type_desc_t wire_types[] = {
    {"struct big", 0xB16B16B1u, BIG_LEN, BIG_LEN, NULL, NULL},
    {"struct mid", 0x3131D1D1u, MID_LEN, MID_LEN, NULL, NULL},
};
static ub_instance_desc_t wire_insts[2];
static ub_catalogue_t wire_cat;
#define INST_BIG 0u
#define INST_MID 1u

static void wire_cat_init(void) {
    ub_dir_id_paper("bigTable", wire_insts[0].id);
    ub_dir_id_paper("midTable", wire_insts[1].id);
    wire_insts[0].name = "bigTable";
    wire_insts[0].type = &wire_types[0];
    wire_insts[1].name = "midTable";
    wire_insts[1].type = &wire_types[1];
    if (memcmp(wire_insts[0].id, wire_insts[1].id, UB_DIR_ID_LEN) > 0) { /* sorted by ID */
        ub_instance_desc_t t = wire_insts[0];
        wire_insts[0] = wire_insts[1];
        wire_insts[1] = t;
    }
    wire_cat = (ub_catalogue_t){"wire", UB_ID_SCHEME_PAPER, UB_CATALOGUE_ABI_VERSION, wire_types, 2, wire_insts, 2,
                                BIG_LEN, NULL, 0};
}

static uint32_t inst_of(const char *name) {
    int i = ub_catalogue_find_name(&wire_cat, name);
    assert_true(i >= 0);
    return (uint32_t)i;
}

/* ---- a line of nodes n0 - n1 - ... ---- */
#define MAXN 4
typedef struct line {
    world_t *w;
    int n;
    ub_node_t *node[MAXN];
    int ent[MAXN];           /* the node's own entity */
    int peer[MAXN][MAXN];    /* entity index of node j's entity in node i's table, -1 if unknown */
    int left[MAXN], right[MAXN];
    ub_compact_t comp[MAXN][2];
    ub_frag_t *frag;         /* MAXN of them */
    delivery_log_t log;      /* deliveries at the last node */
} line_t;

/* `compact`: bit i = the link between node i and i+1 is compact. `tables_full`: every node knows every entity
 * (else only its neighbours and the two ends). */
static line_t *line_new(int n, const ub_catalogue_t *cat, unsigned compact, uint16_t mtu, bool tables_full,
                        const ub_memlink_faults_t *faults) {
    line_t *l = calloc(1, sizeof *l);
    assert_non_null(l);
    l->frag = calloc(MAXN, sizeof *l->frag);
    assert_non_null(l->frag);
    l->w = world_new();
    l->n = n;
    char name[16];
    for (int i = 0; i < n; i++) {
        ub_node_options_t opt = {.first_seq = 1000u * (uint32_t)(i + 1), .random_seed = (uint64_t)(i + 1)};
        l->node[i] = world_node(l->w, cat, &opt);
        snprintf(name, sizeof name, "n%d", i);
        l->ent[i] = ub_node_add_entity_name(l->node[i], name, true);
        assert_true(l->ent[i] >= 0);
        ub_frag_init(&l->frag[i], NULL, (uint16_t)(100 * i));
        assert_int_equal(ub_node_set_frag(l->node[i], &l->frag[i]), UB_OK);
    }
    for (int i = 0; i < n; i++) {
        for (int j = 0; j < n; j++) {
            l->peer[i][j] = i == j ? l->ent[i] : -1;
            if (i == j || !(tables_full || j == 0 || j == n - 1 || j == i - 1 || j == i + 1)) continue;
            snprintf(name, sizeof name, "n%d", j);
            l->peer[i][j] = ub_node_add_entity_name(l->node[i], name, false);
            assert_true(l->peer[i][j] >= 0);
        }
        l->left[i] = i > 0 ? ub_node_add_link(l->node[i], l->ent[i], 0, "left") : -1;
        l->right[i] = i < n - 1 ? ub_node_add_link(l->node[i], l->ent[i], 1, "right") : -1;
    }
    for (int i = 0; i < n; i++) {
        for (int j = 0; j < n; j++) {
            if (l->peer[i][j] < 0 || i == j) continue;
            assert_int_equal(ub_node_set_mask(l->node[i], l->ent[i], l->peer[i][j], j > i ? 0x02 : 0x01), UB_OK);
        }
    }
    for (int i = 0; i + 1 < n; i++) {
        (void)world_connect(l->w, l->node[i], l->right[i], l->node[i + 1], l->left[i + 1], faults, (uint64_t)(77 + i));
        if (compact & (1u << i)) {
            assert_int_equal(ub_node_link_set_compact(l->node[i], l->right[i], &l->comp[i][1], NULL), UB_OK);
            assert_int_equal(ub_node_link_set_compact(l->node[i + 1], l->left[i + 1], &l->comp[i + 1][0], NULL), UB_OK);
        }
        if (mtu != 0) {
            assert_int_equal(ub_node_link_set_mtu(l->node[i], l->right[i], mtu), UB_OK);
            assert_int_equal(ub_node_link_set_mtu(l->node[i + 1], l->left[i + 1], mtu), UB_OK);
        }
    }
    ub_node_set_deliver_hook(l->node[n - 1], delivery_log_hook, &l->log);
    return l;
}

static void line_free(line_t *l) {
    free(l->w);
    free(l->frag);
    free(l);
}

static uint64_t drops(const ub_node_t *node, ub_drop_reason_t why) { return ub_node_counters(node)->drops[why]; }

static uint64_t all_drops(const line_t *l, ub_drop_reason_t why) {
    uint64_t n = 0;
    for (int i = 0; i < l->n; i++) n += drops(l->node[i], why);
    return n;
}

/* ---- compact and full mixed ---- */

static void test_mixed_path_delivers_identical_directories(void **state) {
    (void)state;
    /* n0 =compact= n1 -full- n2 =compact= n3: three hops, two translations each way. */
    line_t *l = line_new(4, &ub_test_cat, 0x5u, 0, true, NULL);
    struct test_gps src_gps = {0}, dst_gps = {0};
    struct test_imu src_imu = {0}, dst_imu = {0};
    assert_int_equal(ub_node_bind(l->node[0], TEST_GPS, &src_gps), UB_OK);
    assert_int_equal(ub_node_bind(l->node[0], TEST_IMU, &src_imu), UB_OK);
    assert_int_equal(ub_node_bind(l->node[3], TEST_GPS, &dst_gps), UB_OK);
    assert_int_equal(ub_node_bind(l->node[3], TEST_IMU, &dst_imu), UB_OK);
    const uint8_t *dest = ub_node_entity_id(l->node[0], l->peer[0][3]);
    world_run(l->w, 50, 10); /* LINK_HELLO rounds: the dictionaries agree */
    for (int k = 0; k < 2; k++) {
        assert_true(ub_compact_agreed(&l->comp[k == 0 ? 0 : 2][1]));
        assert_true(ub_compact_agreed(&l->comp[k == 0 ? 1 : 3][0]));
    }
    const ub_link_t *first = ub_node_link(l->node[0], l->right[0]);
    const ub_link_t *middle = ub_node_link(l->node[1], l->right[1]);
    uint64_t bytes0 = first->counters.bytes_out, bytes1 = middle->counters.bytes_out;
    for (int i = 0; i < 200; i++) {
        src_gps.lat = 32.5 + i * 1e-5;
        src_gps.lon = -84.9 - i * 2e-5;
        src_gps.alt = (float)(120 + i % 7);
        src_gps.fix = (uint32_t)(i % 4);
        src_imu.t_ms = (uint32_t)(i * 10);
        src_imu.acc[i % 3] = (float)i;
        int rc = ub_node_send_data(l->node[0], l->ent[0], i % 2 ? TEST_IMU : TEST_GPS, dest, l->w->now_ms);
        assert_int_equal(rc, 1);
        world_run(l->w, l->w->now_ms + 1, 1);
        if (i % 2) {
            assert_memory_equal(&dst_imu, &src_imu, sizeof src_imu);
        } else {
            assert_memory_equal(&dst_gps, &src_gps, sizeof src_gps);
        }
    }
    assert_int_equal(delivery_count(&l->log, l->ent[3], TEST_GPS, 0, UINT64_MAX), 100);
    assert_int_equal(delivery_count(&l->log, l->ent[3], TEST_IMU, 0, UINT64_MAX), 100);
    assert_int_equal(delivery_repeats(&l->log), 0);
    /* Full: 64-byte header + 24/28 bytes. Compact: at most 9 bytes of header and check + 2 of stuffing. */
    uint64_t full = first->counters.bytes_out - bytes0, mid = middle->counters.bytes_out - bytes1;
    assert_int_equal(mid, 100 * (64 + 24) + 100 * (64 + 28));
    assert_true(full <= 100 * (24 + 11) + 100 * (28 + 11) + 3 * 2 * 2 /* the first frames carry 32 sequence bits */);
    for (int i = 0; i < 4; i++) {
        assert_int_equal(ub_node_link_bad_frames(l->node[i], l->left[i] >= 0 ? l->left[i] : l->right[i], UB_RX_BAD_CRC), 0);
        assert_int_equal(all_drops(l, UB_DROP_BAD_PAYLOAD), 0);
    }
    assert_int_equal(l->comp[3][0].stats.rejected[UB_RX_NO_REFERENCE] + l->comp[3][0].stats.rejected[UB_RX_NO_DICTIONARY],
                     0);
    line_free(l);
}

static void test_different_tables_fall_back_to_full_ids_and_restart_catches_up(void **state) {
    (void)state;
    /* Each node knows only its neighbours and the ends: lists differ, yet each side indexes its own list. */
    line_t *l = line_new(4, &ub_test_cat, 0x7u, 0, false, NULL);
    struct test_gps src = {.lat = 1.0}, dst = {0};
    assert_int_equal(ub_node_bind(l->node[0], TEST_GPS, &src), UB_OK);
    assert_int_equal(ub_node_bind(l->node[3], TEST_GPS, &dst), UB_OK);
    const uint8_t *dest = ub_node_entity_id(l->node[0], l->peer[0][3]);
    /* Before any LINK_HELLO: full IDs, still delivered. */
    assert_int_equal(ub_node_send_data(l->node[0], l->ent[0], TEST_GPS, dest, 0), 1);
    for (int i = 0; i < 3; i++) ub_memlink_pump(&l->w->links[i], 0), ub_memlink_pump(&l->w->links[0], 0);
    world_run(l->w, 1, 1);
    assert_memory_equal(&dst, &src, sizeof src);
    assert_true(l->comp[0][1].stats.tx_full_ids >= 1);
    world_run(l->w, 100, 10);
    for (int i = 0; i < 3; i++) assert_true(ub_compact_agreed(&l->comp[i][1]));
    uint64_t full_before = l->comp[0][1].stats.tx_full_ids;
    for (int i = 0; i < 20; i++) {
        src.fix = (uint32_t)i;
        assert_int_equal(ub_node_send_data(l->node[0], l->ent[0], TEST_GPS, dest, l->w->now_ms), 1);
        world_run(l->w, l->w->now_ms + 1, 1);
        assert_int_equal(dst.fix, (uint32_t)i);
    }
    assert_int_equal(l->comp[0][1].stats.tx_full_ids, full_before);
    /* n1 restarts its end toward n0 (new epoch, no list, no references): frames in flight meanwhile are
     * refused and counted; the next LINK_HELLO round tells n0, which resends what is needed. */
    assert_int_equal(ub_node_link_set_compact(l->node[1], l->left[1], &l->comp[1][0], NULL), UB_OK);
    int delivered_after = 0;
    for (int i = 0; i < 60; i++) {
        src.fix = (uint32_t)(100 + i);
        assert_int_equal(ub_node_send_data(l->node[0], l->ent[0], TEST_GPS, dest, l->w->now_ms), 1);
        world_run(l->w, l->w->now_ms + 20, 10);
        if (dst.fix == src.fix) delivered_after++;
    }
    assert_true(delivered_after >= 50);
    assert_int_equal(dst.fix, src.fix);
    assert_true(l->comp[0][1].stats.peer_restarts >= 1);
    line_free(l);
}

static void test_forwarder_drops_frames_over_the_mtu(void **state) {
    (void)state;
    line_t *l = line_new(3, &ub_test_cat, 0, 0, true, NULL);
    assert_int_equal(ub_node_link_set_mtu(l->node[1], l->right[1], 80), UB_OK); /* a 24-byte gpsOut frame is 88 */
    assert_int_equal(ub_node_link_set_mtu(l->node[1], l->right[1], 10), UB_ERR_RANGE);
    struct test_gps src = {.lat = 3.0}, dst = {0};
    assert_int_equal(ub_node_bind(l->node[0], TEST_GPS, &src), UB_OK);
    assert_int_equal(ub_node_bind(l->node[2], TEST_GPS, &dst), UB_OK);
    assert_int_equal(ub_node_send_data(l->node[0], l->ent[0], TEST_GPS, ub_node_entity_id(l->node[0], l->peer[0][2]), 0),
                     1);
    world_run(l->w, 5, 1);
    assert_int_equal(drops(l->node[1], UB_DROP_TOO_BIG), 1);
    assert_int_equal(ub_node_link(l->node[1], l->right[1])->counters.drops[UB_DROP_TOO_BIG], 1);
    assert_true(dst.lat == 0.0);
    line_free(l);
}

/* ---- signed ---- */

static const uint8_t KEY[UB_SEC_KEY_LEN] = {9, 8, 7, 6, 5, 4, 3, 2, 1, 0, 1, 2, 3, 4, 5, 6,
                                            7, 8, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0, 1, 2, 3, 4};
static int seeded_random(void *user, uint8_t *out, size_t len) {
    for (size_t i = 0; i < len; i++) out[i] = (uint8_t)(ub_rng_next(user) >> 56);
    return UB_OK;
}
typedef struct sec_end {
    ub_sec_t sec;
    store_t store;
    uint64_t rng;
} sec_end_t;

static void secure(line_t *l, sec_end_t *e) {
    for (int i = 0; i < l->n; i++) {
        e[i].rng = (uint64_t)(i + 5) * 0x9E3779B97F4A7C15ull;
        ub_sec_options_t o = {.random = seeded_random, .random_user = &e[i].rng, .reserve = store_reserve,
                              .reserve_user = &e[i].store, .reserve_block = 1u << 16};
        assert_int_equal(ub_sec_init(&e[i].sec, &o), UB_OK);
        assert_int_equal(ub_sec_add_key(&e[i].sec, 1, KEY), UB_OK);
        assert_int_equal(ub_sec_set_tx_key(&e[i].sec, 1), UB_OK);
        assert_int_equal(ub_sec_start(&e[i].sec, 0, 1000000u * (uint64_t)(i + 1)), UB_OK);
        assert_int_equal(ub_node_set_security(l->node[i], &e[i].sec), UB_OK);
        assert_int_equal(ub_node_set_require_signed(l->node[i], true), UB_OK);
    }
}

static void test_signed_compact_frames_verify_after_translation(void **state) {
    (void)state;
    if (!ub_sec_available()) skip();
    /* n0 =compact= n1 -full- n2 =compact, encrypting= n3 */
    line_t *l = line_new(4, &ub_test_cat, 0x5u, 0, true, NULL);
    sec_end_t *e = calloc(4, sizeof *e);
    assert_non_null(e);
    secure(l, e);
    assert_int_equal(ub_node_link_set_security(l->node[2], l->right[2], -1, true), UB_OK);
    assert_int_equal(ub_node_link_set_security(l->node[3], l->left[3], -1, true), UB_OK);
    struct test_gps src = {0}, dst = {0};
    assert_int_equal(ub_node_bind(l->node[0], TEST_GPS, &src), UB_OK);
    assert_int_equal(ub_node_bind(l->node[3], TEST_GPS, &dst), UB_OK);
    const uint8_t *dest = ub_node_entity_id(l->node[0], l->peer[0][3]);
    int delivered = 0;
    for (int i = 0; i < 100; i++) {
        src.fix = (uint32_t)(i + 1);
        assert_true(ub_node_send_data(l->node[0], l->ent[0], TEST_GPS, dest, l->w->now_ms) >= 0);
        world_run(l->w, l->w->now_ms + 10, 5);
        if (dst.fix == src.fix) delivered++;
    }
    /* The first frames of each hop wait for its freshness challenge; after that every frame arrives. */
    assert_true(delivered >= 90);
    assert_int_equal(dst.fix, 100);
    assert_int_equal(all_drops(l, UB_DROP_BAD_TAG), 0);
    assert_int_equal(all_drops(l, UB_DROP_UNSIGNED), 0);
    assert_true(ub_compact_agreed(&l->comp[0][1]) && ub_compact_agreed(&l->comp[3][0]));
    /* A forgery on the compact link: one bit of the payload flipped and the check made right again. */
    const ub_link_t *in3 = ub_node_link(l->node[3], l->left[3]);
    uint64_t accepted = in3->counters.frames_accepted;
    uint8_t frame[UB_FRAME_MAX], wire[UB_COMPACT_WIRE_MAX], pkt[UB_COMPACT_PACKET_MAX];
    uint8_t payload[24] = {1, 2, 3};
    size_t len = make_frame(frame, UB_ADMIN_DATA, ub_test_cat.instances[TEST_GPS].id, "n0", "n3", 5, 8,
                            ub_test_cat.types[0].fingerprint, payload, sizeof payload);
    (void)len;
    /* Take a genuine ENCRYPTED compact frame as n2 sends it, flip a ciphertext bit, fix the check. */
    src.fix = 4242;
    assert_true(ub_node_send_data(l->node[0], l->ent[0], TEST_GPS, dest, l->w->now_ms) >= 0);
    for (int k = 0; k < 2; k++) (void)ub_memlink_pump(&l->w->links[k], l->w->now_ms);
    ub_memlink_end_t *end = &l->w->links[2].end[0]; /* n2 -> n3 */
    assert_int_equal(end->count, 1);
    const ub_memlink_frame_t *queued = &end->queue[end->ring[end->head]];
    size_t w = queued->len;
    memcpy(wire, queued->bytes, w);
    int n = ub_cobs_decode(wire, w - 1, pkt, sizeof pkt);
    assert_true(n > 30);
    assert_int_equal((pkt[0] & UB_COMPACT_PROT_MASK) >> UB_COMPACT_PROT_SHIFT, 2); /* ENCRYPTED */
    pkt[n - 4 - 19 - 1] ^= 0x01;                                                    /* last ciphertext byte */
    ub_compact_codec_t c;
    ub_compact_tx_codec(&l->comp[2][1], &c);
    uint8_t prefix[16];
    ub_put_u64le(prefix, c.cat_hash);
    ub_put_u64le(prefix + 8, c.list_hash);
    ub_put_u32le(pkt + n - 4, ub_crc32c_update(ub_crc32c(prefix, 16), pkt, (size_t)n - 4));
    w = ub_cobs_encode(pkt, (size_t)n, wire, sizeof wire);
    end->count = 0; /* the genuine one never arrives */
    end->n_free = UB_MEMLINK_DEPTH;
    for (size_t i = 0; i < UB_MEMLINK_DEPTH; i++) end->free_slots[i] = (uint16_t)i;
    assert_int_equal(ub_node_rx_frame(l->node[3], l->left[3], wire, w, l->w->now_ms), UB_OK);
    assert_int_equal(drops(l->node[3], UB_DROP_BAD_TAG), 1);
    assert_int_equal(in3->counters.frames_accepted, accepted);
    assert_int_equal(dst.fix, 100);
    free(e);
    line_free(l);
}

/* ---- fragments ---- */

static void fill(uint8_t *buf, size_t n, uint32_t version) {
    uint64_t s = 0x1234567ull * (version + 1);
    for (size_t i = 0; i < n; i++) buf[i] = (uint8_t)(ub_rng_next(&s) >> 56);
    memcpy(buf, &version, sizeof version); /* every byte depends on the version; the first four say which */
}

static void test_16k_directory_crosses_two_hops_of_255_byte_mtu(void **state) {
    (void)state;
    if (!ub_sec_available()) skip();
    line_t *l = line_new(3, &wire_cat, 0x3u, 255, true, NULL);
    sec_end_t *e = calloc(3, sizeof *e);
    assert_non_null(e);
    secure(l, e);
    static uint8_t src[BIG_LEN], dst[BIG_LEN], mid[MID_LEN], mid_dst[MID_LEN];
    uint32_t big = inst_of("bigTable"), midi = inst_of("midTable");
    assert_int_equal(ub_node_bind(l->node[0], big, src), UB_OK);
    assert_int_equal(ub_node_bind(l->node[2], big, dst), UB_OK);
    assert_int_equal(ub_node_bind(l->node[0], midi, mid), UB_OK);
    assert_int_equal(ub_node_bind(l->node[2], midi, mid_dst), UB_OK);
    const uint8_t *dest = ub_node_entity_id(l->node[0], l->peer[0][2]);
    world_run(l->w, 100, 10);
    /* A small directory first: the freshness challenges of both hops are over after it. */
    fill(mid, MID_LEN, 1);
    assert_true(ub_node_send_data(l->node[0], l->ent[0], midi, dest, l->w->now_ms) >= 1);
    world_run(l->w, l->w->now_ms + 500, 10);
    fill(mid, MID_LEN, 2);
    assert_true(ub_node_send_data(l->node[0], l->ent[0], midi, dest, l->w->now_ms) >= 1);
    world_run(l->w, l->w->now_ms + 50, 10);
    assert_memory_equal(mid_dst, mid, MID_LEN);
    uint64_t complete_before = l->frag[2].stats.rx_complete;
    for (uint32_t v = 10; v < 13; v++) {
        fill(src, BIG_LEN, v);
        assert_true(ub_node_send_data(l->node[0], l->ent[0], big, dest, l->w->now_ms) >= 1);
        /* 74 fragments > the memlink's 64 slots: the rest go on at the next ticks (push back, not loss). */
        world_run(l->w, l->w->now_ms + 100, 10);
        assert_memory_equal(dst, src, BIG_LEN);
    }
    const ub_frag_stats_t *tx = &l->frag[0].stats, *rx = &l->frag[2].stats;
    assert_int_equal(rx->rx_complete - complete_before, 3);
    assert_true(tx->tx_fragments >= 3 * (BIG_LEN / 230));
    assert_true(tx->tx_paused >= 1);
    assert_int_equal(all_drops(l, UB_DROP_TOO_BIG), 0);
    assert_int_equal(all_drops(l, UB_DROP_INCOMPLETE), 0);
    assert_int_equal(all_drops(l, UB_DROP_BAD_TAG), 0);
    /* Every fragment fitted the 255-byte packets, compact and signed. */
    for (int i = 0; i < 2; i++) {
        const ub_link_t *link = ub_node_link(l->node[i], l->right[i]);
        assert_true(link->counters.bytes_out <= 255u * link->counters.frames_out);
        assert_true(link->counters.bytes_out > 220u * (link->counters.frames_out - 40)); /* well filled */
    }
    free(e);
    line_free(l);
}

static void test_fragments_under_loss_duplication_reordering_never_torn(void **state) {
    (void)state;
    ub_memlink_faults_t faults = {.loss_ppm = 300000, .duplicate_ppm = 200000, .reorder_ppm = 200000,
                                  .reorder_delay_ms = 3};
    line_t *l = line_new(2, &wire_cat, 0x1u, 255, true, NULL);
    world_run(l->w, 50, 10); /* perfect link while the dictionaries agree */
    ub_memlink_set_faults(&l->w->links[0], &faults);
    static uint8_t src[MID_LEN], dst[MID_LEN];
    uint32_t midi = inst_of("midTable");
    assert_int_equal(ub_node_bind(l->node[0], midi, src), UB_OK);
    assert_int_equal(ub_node_bind(l->node[1], midi, dst), UB_OK);
    const uint8_t *dest = ub_node_entity_id(l->node[0], l->peer[0][1]);
    size_t seen = 0;
    for (uint32_t v = 1; v <= 300; v++) {
        fill(src, MID_LEN, v);
        assert_true(ub_node_send_data(l->node[0], l->ent[0], midi, dest, l->w->now_ms) >= 0);
        world_run(l->w, l->w->now_ms + 7, 1);
        if (l->log.n > seen) {
            /* Whatever arrived is exactly one version, whole. */
            uint32_t got;
            memcpy(&got, dst, sizeof got);
            uint8_t want[MID_LEN];
            fill(want, MID_LEN, got);
            assert_memory_equal(dst, want, MID_LEN);
            assert_true(got >= 1 && got <= v);
            seen = l->log.n;
        }
    }
    world_run(l->w, l->w->now_ms + 3 * UB_FRAG_TIMEOUT_MS, 100);
    const ub_frag_stats_t *rx = &l->frag[1].stats;
    uint64_t lost = rx->rx_timeouts + rx->rx_evicted + rx->rx_restarted + rx->rx_source_limit;
    /* Every transfer the receiver heard of is delivered whole or counted. */
    assert_int_equal(rx->rx_started, rx->rx_complete + lost + ub_frag_pending(&l->frag[1]));
    assert_int_equal(ub_frag_pending(&l->frag[1]), 0);
    assert_int_equal(drops(l->node[1], UB_DROP_INCOMPLETE), lost + rx->rx_refused); /* + fragments refused */
    assert_int_equal(l->log.n, rx->rx_complete);
    assert_true(rx->rx_complete >= 30 && lost >= 30); /* both happen at 30 % loss (4 fragments each) */
    assert_true(rx->rx_duplicates + drops(l->node[1], UB_DROP_DUPLICATE) > 0);
    line_free(l);
}

int main(void) {
    wire_cat_init();
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mixed_path_delivers_identical_directories),
        cmocka_unit_test(test_different_tables_fall_back_to_full_ids_and_restart_catches_up),
        cmocka_unit_test(test_forwarder_drops_frames_over_the_mtu),
        cmocka_unit_test(test_signed_compact_frames_verify_after_translation),
        cmocka_unit_test(test_16k_directory_crosses_two_hops_of_255_byte_mtu),
        cmocka_unit_test(test_fragments_under_loss_duplication_reordering_never_torn),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
