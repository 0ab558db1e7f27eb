/*
 * The compact encoding at its bounds (issue #29 item 6): COBS refusals, what ub_compact_encode() refuses,
 * two link states agreeing on their dictionaries through LINK_HELLO pages, frames encoded with indices and
 * decoded back byte for byte, every strict prefix of a packet refused (never read past its end), and each
 * malformed LINK_HELLO counted hello_bad. test_compact_vectors.c reproduces the shared vectors.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "ub/ub_compact.h"
#include "ub/ub_frame.h"
#include "ub/ub_wire.h"

/* A hand catalogue: one 8-byte type, two instances (sorted by ID). */
static const ub_type_desc_t k_types[] = {{"struct eight", 0x0BADCAFEu, 8, 8, NULL, NULL}};
static const ub_instance_desc_t k_insts[] = {
    {{'a', 'l', 'p', 'h', 'a'}, "alpha", &k_types[0]},
    {{'b', 'r', 'a', 'v', 'o'}, "bravo", &k_types[0]},
};
static const ub_catalogue_t k_cat = {.name = "bounds", .types = k_types, .n_types = 1, .instances = k_insts,
                                     .n_instances = 2, .max_packed_size = 8};

static void eid(uint8_t id[UB_ENTITY_ID_LEN], const char *name) {
    memset(id, 0, UB_ENTITY_ID_LEN);
    memcpy(id, name, strlen(name));
}

static size_t make_frame(uint8_t *f, uint8_t admin, uint32_t seq, uint16_t payload) {
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memcpy(h.dir_id, k_insts[1].id, UB_DIR_ID_LEN);
    eid(h.dest_id, "bbb");
    eid(h.src_id, "aaa");
    h.admin = admin;
    h.hop_limit = 5;
    h.payload_size = payload;
    h.seq = seq;
    h.fingerprint = k_types[0].fingerprint;
    for (uint16_t i = 0; i < payload; i++) f[UB_FRAME_HEADER_LEN + i] = (uint8_t)(i * 3u + 1u);
    int len = ub_frame_finish(f, UB_FRAME_MAX, &h);
    assert_true(len > 0);
    return (size_t)len;
}

static void test_cobs_refusals(void **state) {
    (void)state;
    uint8_t in[300], out[320], back[320];
    for (size_t i = 0; i < sizeof in; i++) in[i] = (uint8_t)(i % 7); /* zeros every 7 bytes, and a long run */
    memset(in + 20, 0x55, 260);
    size_t n = ub_cobs_encode(in, sizeof in, out, sizeof out);
    assert_true(n > sizeof in);
    assert_int_equal(out[n - 1], 0);
    assert_null(memchr(out, 0, n - 1));
    assert_int_equal(ub_cobs_decode(out, n - 1, back, sizeof back), (int)sizeof in);
    assert_memory_equal(back, in, sizeof in);
    assert_int_equal(ub_cobs_encode(in, sizeof in, out, UB_COBS_MAX(sizeof in) - 1), 0); /* no room */
    assert_int_equal(ub_cobs_encode(NULL, 3, out, sizeof out), 0);
    assert_int_equal(ub_cobs_encode(in, 3, NULL, sizeof out), 0);
    assert_int_equal(ub_cobs_encode(NULL, 0, out, sizeof out), 2); /* the empty packet: code 1, delimiter */
    assert_int_equal(ub_cobs_decode(NULL, 3, back, sizeof back), UB_ERR_INVAL);
    assert_int_equal(ub_cobs_decode(out, n - 1, NULL, sizeof back), UB_ERR_INVAL);
    assert_int_equal(ub_cobs_decode((const uint8_t[]){0x00, 0x01}, 2, back, sizeof back), UB_ERR_INVAL); /* code 0 */
    assert_int_equal(ub_cobs_decode((const uint8_t[]){0x05, 0x01}, 2, back, sizeof back), UB_ERR_INVAL); /* past the end */
    assert_int_equal(ub_cobs_decode((const uint8_t[]){0x03, 0x00, 0x01}, 3, back, sizeof back), UB_ERR_INVAL); /* a zero inside */
    assert_int_equal(ub_cobs_encode(in, sizeof in, out, sizeof out), n); /* again: the calls above wrote to out */
    assert_int_equal(ub_cobs_decode(out, n - 1, back, 10), UB_ERR_NOSPACE);        /* mid-run */
    assert_int_equal(ub_cobs_decode((const uint8_t[]){0x02, 0x07, 0x02, 0x08}, 4, back, 1), UB_ERR_NOSPACE); /* at a group end */
}

static void test_encode_refusals(void **state) {
    (void)state;
    ub_compact_codec_t c = {0};
    uint8_t f[UB_FRAME_MAX], pkt[UB_COMPACT_PACKET_MAX];
    size_t len = make_frame(f, UB_ADMIN_DATA, 7, 8);
    int n = ub_compact_encode(&c, f, len, false, pkt, sizeof pkt);
    assert_true(n > 0);
    assert_int_equal(ub_compact_encode(NULL, f, len, false, pkt, sizeof pkt), UB_ERR_INVAL);
    assert_int_equal(ub_compact_encode(&c, NULL, len, false, pkt, sizeof pkt), UB_ERR_INVAL);
    assert_int_equal(ub_compact_encode(&c, f, len, false, NULL, sizeof pkt), UB_ERR_INVAL);
    assert_int_equal(ub_compact_encode(&c, f, UB_FRAME_HEADER_LEN - 1, false, pkt, sizeof pkt), UB_ERR_INVAL);
    assert_int_equal(ub_compact_encode(&c, f, len - 1, false, pkt, sizeof pkt), UB_ERR_INVAL); /* length disagrees */
    assert_int_equal(ub_compact_encode(&c, f, len, false, pkt, (size_t)n - 1), UB_ERR_NOSPACE);
    uint8_t g[UB_FRAME_MAX];
    memcpy(g, f, len);
    g[UB_FRAME_OFF_VERSION] ^= 0x0F; /* another wire version */
    assert_int_equal(ub_compact_encode(&c, g, len, false, pkt, sizeof pkt), UB_ERR_INVAL);
    memcpy(g, f, len);
    g[UB_FRAME_OFF_HOP_LIMIT] = 0;
    assert_int_equal(ub_compact_encode(&c, g, len, false, pkt, sizeof pkt), UB_ERR_INVAL);
    /* Decoding refuses what it cannot hold or read. */
    uint8_t out[UB_FRAME_MAX];
    ub_frame_header_t h;
    ub_rx_reason_t why = UB_RX_REASON_COUNT;
    assert_true(ub_compact_decode(&c, pkt, (size_t)n, NULL, out, UB_FRAME_MAX - 1, &h, &why) < 0);
    assert_int_equal(why, UB_RX_BAD_LENGTH);
    assert_true(ub_compact_decode(NULL, pkt, (size_t)n, NULL, out, sizeof out, &h, NULL) < 0);
    assert_true(ub_compact_decode(&c, pkt, (size_t)n, NULL, out, sizeof out, NULL, NULL) < 0);
    assert_null(ub_compact_ref_find(NULL, f + UB_FRAME_OFF_SRC_ID));
}

/* Runs LINK_HELLO pages both ways until both ends agree; returns the rounds it took. */
static int agree(ub_compact_t *a, ub_compact_t *b, uint64_t *now) {
    uint8_t p[UB_COMPACT_HELLO_FIXED + UB_COMPACT_PAGE * UB_ENTITY_ID_LEN];
    uint16_t len = 0;
    for (int round = 1; round <= 10; round++) {
        while (ub_compact_hello_due(a, *now, p, sizeof p, &len)) assert_int_equal(ub_compact_on_hello(b, p, len, *now), UB_OK);
        while (ub_compact_hello_due(b, *now, p, sizeof p, &len)) assert_int_equal(ub_compact_on_hello(a, p, len, *now), UB_OK);
        if (ub_compact_agreed(a) && ub_compact_agreed(b)) return round;
        *now += UB_COMPACT_RETRY_MS;
    }
    return -1;
}

static ub_compact_t g_a, g_b;

static void test_agreed_indices_round_trip_and_every_prefix_refused(void **state) {
    (void)state;
    uint64_t now = 1000;
    /* Ten entities: more than one LINK_HELLO page (8). */
    uint8_t ids[10][UB_ENTITY_ID_LEN];
    const char *names[10] = {"aaa", "bbb", "ccc", "ddd", "eee", "fff", "ggg", "hhh", "iii", "jjj"};
    for (int i = 0; i < 10; i++) eid(ids[i], names[i]);
    ub_compact_init(&g_a, &k_cat, 11, NULL);
    ub_compact_init(&g_b, &k_cat, 0, NULL); /* epoch 0 is replaced by 1 */
    assert_int_equal(g_b.epoch, 1);
    ub_compact_set_local(&g_a, (const uint8_t(*)[UB_ENTITY_ID_LEN])ids, 10, 1, now);
    ub_compact_set_local(&g_b, (const uint8_t(*)[UB_ENTITY_ID_LEN])ids, 10, 1, now);
    ub_compact_set_local(&g_b, (const uint8_t(*)[UB_ENTITY_ID_LEN])ids, 10, 1, now); /* same version: nothing */
    assert_false(ub_compact_agreed(&g_a));
    assert_true(agree(&g_a, &g_b, &now) > 0);
    assert_int_equal(g_b.stats.hello_bad, 0);
    assert_true(g_b.stats.peer_lists >= 1);

    ub_compact_codec_t tx, rx;
    ub_compact_tx_codec(&g_a, &tx);
    ub_compact_rx_codec(&g_b, &rx);
    assert_true(tx.entities_ok && tx.content_ok);
    uint8_t f[UB_FRAME_MAX], pkt[UB_COMPACT_PACKET_MAX], out[UB_FRAME_MAX];
    for (uint8_t admin = UB_ADMIN_DATA; admin <= UB_ADMIN_PUB_REQUEST; admin++) {
        size_t len = make_frame(f, admin, 0x12345678u, admin == UB_ADMIN_DATA ? 8 : 5);
        int n = ub_compact_encode(&tx, f, len, true, pkt, sizeof pkt);
        assert_true(n > 0);
        assert_true((size_t)n < len / 2); /* indices, not IDs */
        ub_frame_header_t h;
        ub_rx_reason_t why = UB_RX_REASON_COUNT;
        assert_int_equal(ub_compact_decode(&rx, pkt, (size_t)n, NULL, out, sizeof out, &h, &why), (int)len);
        assert_memory_equal(out, f, len);
        assert_int_equal(h.seq, 0x12345678u);
        for (int k = 0; k < n; k++) { /* every strict prefix: refused, with a reason */
            why = UB_RX_REASON_COUNT;
            assert_true(ub_compact_decode(&rx, pkt, (size_t)k, NULL, out, sizeof out, &h, &why) < 0);
            assert_true(why < UB_RX_REASON_COUNT);
        }
        /* A 16-bit sequence without a reference: refused NO_REFERENCE; with one: restored. */
        n = ub_compact_encode(&tx, f, len, false, pkt, sizeof pkt);
        assert_true(n > 0);
        assert_true(ub_compact_decode(&rx, pkt, (size_t)n, NULL, out, sizeof out, &h, &why) < 0);
        assert_int_equal(why, UB_RX_NO_REFERENCE);
        ub_compact_refs_t refs;
        memset(&refs, 0, sizeof refs);
        memcpy(refs.ref[0].src, f + UB_FRAME_OFF_SRC_ID, UB_ENTITY_ID_LEN);
        refs.ref[0].in_use = 1;
        refs.ref[0].seq = 0x12345600u;
        assert_int_equal(ub_compact_decode(&rx, pkt, (size_t)n, &refs, out, sizeof out, &h, &why), (int)len);
        assert_int_equal(h.seq, 0x12345678u);
    }
    /* A decoder without the dictionary cannot expand the indices. */
    ub_compact_codec_t bare = {0};
    size_t len = make_frame(f, UB_ADMIN_DATA, 1, 8);
    int n = ub_compact_encode(&tx, f, len, true, pkt, sizeof pkt);
    ub_frame_header_t h;
    ub_rx_reason_t why = UB_RX_REASON_COUNT;
    assert_true(ub_compact_decode(&bare, pkt, (size_t)n, NULL, out, sizeof out, &h, &why) < 0);
    assert_int_equal(why, UB_RX_NO_DICTIONARY);
    /* Forgetting a source's reference: its next frame carries all 32 bits again. */
    uint8_t wire[UB_COMPACT_WIRE_MAX];
    for (int i = 0; i < 4; i++) assert_true(ub_compact_link_encode(&g_a, f, len, wire, sizeof wire) > 0);
    uint64_t seq32 = g_a.stats.tx_seq32;
    ub_compact_tx_forget(&g_a, f + UB_FRAME_OFF_SRC_ID);
    assert_true(ub_compact_link_encode(&g_a, f, len, wire, sizeof wire) > 0);
    assert_int_equal(g_a.stats.tx_seq32, seq32 + 1);
    ub_compact_tx_forget(NULL, f + UB_FRAME_OFF_SRC_ID);
    assert_true(ub_compact_link_encode(&g_a, f, len, wire, 4) < 0); /* no room */
    assert_true(ub_compact_link_encode(NULL, f, len, wire, sizeof wire) < 0);
}

static void test_bad_hellos_counted(void **state) {
    (void)state;
    uint64_t now = 1000;
    uint8_t ids[2][UB_ENTITY_ID_LEN];
    eid(ids[0], "aaa");
    eid(ids[1], "bbb");
    ub_compact_init(&g_a, &k_cat, 5, NULL);
    ub_compact_init(&g_b, NULL, 6, NULL);
    ub_compact_set_local(&g_a, (const uint8_t(*)[UB_ENTITY_ID_LEN])ids, 2, 1, now);
    uint8_t p[UB_COMPACT_HELLO_FIXED + UB_COMPACT_PAGE * UB_ENTITY_ID_LEN];
    uint16_t len = 0;
    assert_true(ub_compact_hello_due(&g_a, now, p, sizeof p, &len));
    assert_int_equal(len, UB_COMPACT_HELLO_FIXED + 2 * UB_ENTITY_ID_LEN);
    assert_false(ub_compact_hello_due(&g_a, now, p, UB_COMPACT_HELLO_FIXED, &len)); /* no room for a page */
    assert_false(ub_compact_hello_due(&g_b, now, p, sizeof p, &len));                 /* no list yet */
    uint8_t q[sizeof p];
    int bad = 0;
    memcpy(q, p, len);
    q[UB_CH_OFF_VERSION] = 2;
    assert_true(ub_compact_on_hello(&g_b, q, len, now) < 0), bad++;
    assert_true(ub_compact_on_hello(&g_b, p, UB_COMPACT_HELLO_FIXED - 1, now) < 0), bad++;
    assert_true(ub_compact_on_hello(&g_b, p, (size_t)len - 1, now) < 0), bad++; /* count disagrees with the length */
    memcpy(q, p, len);
    q[UB_CH_OFF_FIRST] = 1; /* not a page boundary */
    assert_true(ub_compact_on_hello(&g_b, q, len, now) < 0), bad++;
    memcpy(q, p, len);
    q[UB_CH_OFF_TOTAL] = 0; /* an empty list with IDs */
    assert_true(ub_compact_on_hello(&g_b, q, len, now) < 0), bad++;
    memcpy(q, p, len);
    q[UB_CH_OFF_FIRST] = 8; /* a page past the list */
    assert_true(ub_compact_on_hello(&g_b, q, len, now) < 0), bad++;
    assert_int_equal(g_b.stats.hello_bad, (uint64_t)bad);
    assert_int_equal(g_b.stats.hello_rx, 0);
    assert_int_equal(ub_compact_on_hello(NULL, p, len, now), UB_ERR_INVAL);
    assert_int_equal(ub_compact_on_hello(&g_b, NULL, len, now), UB_ERR_INVAL);
    assert_int_equal(ub_compact_on_hello(&g_b, p, len, now), UB_OK);
    assert_int_equal(g_b.stats.hello_rx, 1);
    assert_false(ub_compact_agreed(NULL));
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cobs_refusals),
        cmocka_unit_test(test_encode_refusals),
        cmocka_unit_test(test_agreed_indices_round_trip_and_every_prefix_refused),
        cmocka_unit_test(test_bad_hellos_counted),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
