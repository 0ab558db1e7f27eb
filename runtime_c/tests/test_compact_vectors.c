/* tests/vectors/compact_frames.json (written by the independent Python reference
 * tests/vectors/make_compact_vectors.py) reproduced by the C runtime byte for byte: every full frame from its
 * fields, its packet and its bytes on the wire from the frame and the dictionary, the wire bytes decoded back to
 * the frame (whole, and fed one byte at a time as a stream), every reject refused for its reason, the
 * dictionary hashes, COBS, and the fragmented directory split and reassembled in any order. The JSON is read
 * at run time with the runtime's own reader (ub_json.h). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "ub/ub_compact.h"
#include "ub/ub_frag.h"
#include "ub/ub_frame.h"
#include "ub/ub_wire.h"
#include "codec/ub_json.h"
#include "test_json_vectors.h"

#define MAX_INST 200
#define MAX_IDS 32

#define doc vec_doc /* the document and its root: test_json_vectors.h */
#define root vec_root
static ub_type_desc_t types[MAX_INST];
static ub_instance_desc_t insts[MAX_INST];
static ub_catalogue_t cat;
static uint8_t lists[2][MAX_IDS][UB_ENTITY_ID_LEN];
static size_t list_n[2];
static uint64_t list_hashes[2];
static const char *list_names[2] = {"fleet", "wide"};

/* ---- JSON helpers (and test_json_vectors.h) ---- */
static bool boolean(const ub_json_value_t *obj, const char *key) { return get(obj, key).kind == UB_JSON_TRUE; }
static uint64_t hex64(const ub_json_value_t *obj, const char *key) {
    char buf[32];
    str(obj, key, buf, sizeof buf);
    return strtoull(buf, NULL, 16);
}

static int setup(void **state) {
    (void)state;
    if (vec_load("tests/vectors/compact_frames.json") != 0) return -1;
    /* the catalogue */
    ub_json_value_t arr = get(&root, "catalogue"), item;
    ub_json_iter_t it;
    ub_json_iter_begin(&it, &doc, &arr);
    size_t k = 0;
    while (ub_json_iter_next(&it, NULL, &item)) {
        if (k >= MAX_INST) return -1;
        types[k].name = "t";
        types[k].fingerprint = (uint32_t)num(&item, "fingerprint");
        types[k].packed_size = (uint32_t)num(&item, "packed_size");
        types[k].c_size = types[k].packed_size;
        hex(&item, "id", insts[k].id, UB_DIR_ID_LEN);
        insts[k].name = "i";
        insts[k].type = &types[k];
        k++;
    }
    cat = (ub_catalogue_t){"vectors", UB_ID_SCHEME_PAPER, UB_CATALOGUE_ABI_VERSION, types, k, insts, k, 0, NULL, 0};
    ub_json_value_t ls = get(&root, "lists");
    for (int l = 0; l < 2; l++) {
        ub_json_value_t one = get(&ls, list_names[l]), ids = get(&one, "ids"), id;
        list_hashes[l] = hex64(&one, "hash");
        ub_json_iter_begin(&it, &doc, &ids);
        list_n[l] = 0;
        while (ub_json_iter_next(&it, NULL, &id)) {
            char buf[32];
            ub_json_string(&doc, &id, buf, sizeof buf);
            for (size_t i = 0; i < UB_ENTITY_ID_LEN; i++) {
                unsigned b;
                sscanf(buf + 2 * i, "%2x", &b);
                lists[l][list_n[l]][i] = (uint8_t)b;
            }
            list_n[l]++;
        }
    }
    return 0;
}

static int teardown(void **state) {
    (void)state;
    vec_free();
    return 0;
}

static void codec_for(const char *entities, bool content_ok, ub_compact_codec_t *c) {
    memset(c, 0, sizeof *c);
    c->cat = &cat;
    c->cat_hash = ub_compact_catalogue_hash(&cat);
    c->content_ok = content_ok;
    for (int l = 0; l < 2; l++) {
        if (strcmp(entities, list_names[l]) != 0) continue;
        c->entities_ok = 1;
        c->ids = (const uint8_t(*)[UB_ENTITY_ID_LEN])lists[l];
        c->n_ids = (uint8_t)list_n[l];
        c->list_hash = list_hashes[l];
    }
}

static void test_hashes_and_cobs(void **state) {
    (void)state;
    assert_int_equal(ub_compact_catalogue_hash(&cat), hex64(&root, "catalogue_hash"));
    for (int l = 0; l < 2; l++)
        assert_int_equal(ub_compact_list_hash((const uint8_t(*)[UB_ENTITY_ID_LEN])lists[l], list_n[l]), list_hashes[l]);
    ub_json_value_t arr = get(&root, "cobs"), item;
    ub_json_iter_t it;
    ub_json_iter_begin(&it, &doc, &arr);
    int n = 0;
    while (ub_json_iter_next(&it, NULL, &item)) {
        uint8_t in[600], want[600], out[600], back[600];
        size_t ni = hex(&item, "in", in, sizeof in), nw = hex(&item, "out", want, sizeof want);
        size_t w = ub_cobs_encode(in, ni, out, sizeof out);
        assert_int_equal(w, nw);
        assert_memory_equal(out, want, nw);
        assert_int_equal(ub_cobs_decode(out, w - 1, back, sizeof back), (int)ni);
        if (ni > 0) assert_memory_equal(back, in, ni);
        n++;
    }
    assert_true(n >= 5);
}

typedef struct got {
    uint8_t frame[UB_FRAME_MAX];
    size_t len;
    int calls;
} got_t;

static void on_frame(void *user, const ub_frame_header_t *h, const uint8_t *frame, size_t len, bool seq32) {
    (void)h, (void)seq32;
    got_t *g = user;
    memcpy(g->frame, frame, len);
    g->len = len;
    g->calls++;
}

/* A link state that decodes with the vector's dictionary: the peer's list and a reference for the source. */
static void receiver_for(ub_compact_t *s, const char *entities, const uint8_t *src, long long ref_seq) {
    ub_compact_init(s, &cat, 1, NULL);
    for (int l = 0; l < 2; l++) {
        if (strcmp(entities, list_names[l]) != 0) continue;
        assert_true(list_n[l] <= UB_COMPACT_DICT_MAX);
        memcpy(s->peer_ids, lists[l], list_n[l] * UB_ENTITY_ID_LEN);
        s->peer_n = (uint8_t)list_n[l];
        s->peer_list_hash = list_hashes[l];
        s->peer_list_ok = 1;
    }
    if (ref_seq >= 0) ub_compact_rx_note(s, src, (uint32_t)ref_seq, true);
}

static void test_vectors(void **state) {
    (void)state;
    ub_json_value_t arr = get(&root, "vectors"), v;
    ub_json_iter_t it;
    ub_json_iter_begin(&it, &doc, &arr);
    int count = 0;
    while (ub_json_iter_next(&it, NULL, &v)) {
        char name[64], entities[16];
        str(&v, "name", name, sizeof name);
        str(&v, "entities", entities, sizeof entities);
        static uint8_t payload[UB_MAX_PAYLOAD], trailer[32], want_frame[UB_FRAME_MAX], want_pkt[UB_COMPACT_PACKET_MAX],
            want_wire[UB_COMPACT_WIRE_MAX], frame[UB_FRAME_MAX], pkt[UB_COMPACT_PACKET_MAX], wire[UB_COMPACT_WIRE_MAX];
        ub_frame_header_t h;
        memset(&h, 0, sizeof h);
        h.flags = (uint8_t)num(&v, "flags");
        hex(&v, "dir_id", h.dir_id, UB_DIR_ID_LEN);
        hex(&v, "dest_id", h.dest_id, UB_ENTITY_ID_LEN);
        hex(&v, "src_id", h.src_id, UB_ENTITY_ID_LEN);
        h.admin = (uint8_t)num(&v, "admin");
        h.hop_limit = (uint8_t)num(&v, "hop_limit");
        h.seq = (uint32_t)num(&v, "seq");
        h.fingerprint = (uint32_t)num(&v, "fingerprint");
        size_t np = hex(&v, "payload", payload, sizeof payload), nt = hex(&v, "trailer", trailer, sizeof trailer);
        size_t nf = hex(&v, "frame", want_frame, sizeof want_frame);
        size_t npk = hex(&v, "packet", want_pkt, sizeof want_pkt), nw = hex(&v, "wire", want_wire, sizeof want_wire);
        h.payload_size = (uint16_t)np;
        memcpy(frame + UB_FRAME_HEADER_LEN, payload, np);
        memcpy(frame + UB_FRAME_HEADER_LEN + np, trailer, nt);
        int len = ub_frame_finish(frame, sizeof frame, &h);
        if (len != (int)nf || memcmp(frame, want_frame, nf) != 0) fail_msg("%s: full frame differs", name);
        ub_compact_codec_t c;
        codec_for(entities, boolean(&v, "content_ok"), &c);
        int n = ub_compact_encode(&c, frame, (size_t)len, boolean(&v, "seq32"), pkt, sizeof pkt);
        if (n != (int)npk || memcmp(pkt, want_pkt, npk) != 0) fail_msg("%s: packet differs (%d vs %zu bytes)", name, n, npk);
        size_t w = ub_cobs_encode(pkt, (size_t)n, wire, sizeof wire);
        if (w != nw || memcmp(wire, want_wire, nw) != 0) fail_msg("%s: wire bytes differ", name);
        /* Back, with the codec alone (the vector's dictionary and a reference for the source)... */
        ub_compact_refs_t refs;
        memset(&refs, 0, sizeof refs);
        long long ref_seq = num(&v, "ref_seq");
        if (ref_seq >= 0) {
            refs.ref[0].in_use = 1;
            memcpy(refs.ref[0].src, h.src_id, UB_ENTITY_ID_LEN);
            refs.ref[0].seq = (uint32_t)ref_seq;
        }
        static uint8_t back[UB_FRAME_MAX];
        ub_frame_header_t bh;
        ub_rx_reason_t why = UB_RX_REASON_COUNT;
        int bl = ub_compact_decode(&c, pkt, (size_t)n, &refs, back, sizeof back, &bh, &why);
        if (bl != (int)nf || memcmp(back, want_frame, nf) != 0) fail_msg("%s: decoded frame differs (%d)", name, bl);
        /* ... and through a link's state as a datagram, then one byte at a time as a stream, where the link can
         * hold the list (UB_COMPACT_DICT_MAX entities in this build). */
        if (c.n_ids <= UB_COMPACT_DICT_MAX) {
            static ub_compact_t rx;
            receiver_for(&rx, entities, h.src_id, ref_seq);
            got_t g = {.calls = 0};
            assert_int_equal(ub_compact_feed(&rx, NULL, wire, w, 0, NULL, on_frame, &g), 1);
            if (g.len != nf || memcmp(g.frame, want_frame, nf) != 0) fail_msg("%s: datagram-decoded frame differs", name);
            static ub_decoder_t dec;
            ub_decoder_init(&dec);
            g.calls = 0;
            for (size_t i = 0; i < w; i++) (void)ub_compact_feed(&rx, &dec, wire + i, 1, 0, NULL, on_frame, &g);
            if (g.calls != 1 || memcmp(g.frame, want_frame, nf) != 0) fail_msg("%s: stream-decoded frame differs", name);
            assert_int_equal(dec.stats.frames_ok, 1);
            assert_int_equal(ub_decoder_pending(&dec), 0);
        }
        count++;
    }
    assert_true(count >= 15);
}

static void test_rejects(void **state) {
    (void)state;
    ub_json_value_t arr = get(&root, "rejects"), v;
    ub_json_iter_t it;
    ub_json_iter_begin(&it, &doc, &arr);
    uint32_t ref = (uint32_t)num(&root, "reject_ref_seq");
    int count = 0;
    while (ub_json_iter_next(&it, NULL, &v)) {
        char name[64], expect[32];
        uint8_t wire[UB_COMPACT_WIRE_MAX];
        str(&v, "name", name, sizeof name);
        str(&v, "expect", expect, sizeof expect);
        size_t w = hex(&v, "wire", wire, sizeof wire);
        static ub_compact_t rx;
        uint8_t ob1[UB_ENTITY_ID_LEN], gcs[UB_ENTITY_ID_LEN];
        assert_int_equal(ub_entity_id("rmax1ob1", ob1), UB_OK);
        assert_int_equal(ub_entity_id("gcs1", gcs), UB_OK);
        receiver_for(&rx, "fleet", ob1, ref);
        ub_compact_rx_note(&rx, gcs, ref, true);
        got_t g = {.calls = 0};
        uint64_t rejected[UB_RX_REASON_COUNT] = {0};
        assert_int_equal(ub_compact_feed(&rx, NULL, wire, w, 0, rejected, on_frame, &g), 0);
        assert_int_equal(g.calls, 0);
        int hit = -1;
        for (int r = 0; r < UB_RX_REASON_COUNT; r++)
            if (rejected[r] != 0) hit = r;
        if (hit < 0 || strcmp(ub_rx_reason_name((ub_rx_reason_t)hit), expect) != 0)
            fail_msg("%s: refused as %s, expected %s", name, hit < 0 ? "nothing" : ub_rx_reason_name((ub_rx_reason_t)hit),
                     expect);
        count++;
    }
    assert_true(count >= 5);
}

static void test_fragments(void **state) {
    (void)state;
    ub_json_value_t fr = get(&root, "fragments");
    static uint8_t data[UB_MAX_DIRECTORY];
    size_t total = hex(&fr, "data", data, sizeof data);
    char inst_name[32];
    str(&fr, "instance", inst_name, sizeof inst_name);
    uint16_t count;
    assert_int_equal(ub_frag_plan(total, (size_t)num(&fr, "max_bytes"), &count), UB_OK);
    assert_int_equal(count, num(&fr, "count"));
    uint16_t transfer = (uint16_t)num(&fr, "transfer");
    uint32_t seq0 = (uint32_t)num(&fr, "first_seq");
    /* find the instance by its 16-byte ID (first 8 + last 8 characters) */
    uint8_t did[UB_DIR_ID_LEN];
    ub_dir_id_paper(inst_name, did);
    int idx = ub_catalogue_find(&cat, did);
    assert_true(idx >= 0);
    uint8_t gcs[UB_ENTITY_ID_LEN], ob1[UB_ENTITY_ID_LEN];
    assert_int_equal(ub_entity_id("gcs1", gcs), UB_OK);
    assert_int_equal(ub_entity_id("rmax1ob1", ob1), UB_OK);
    ub_json_value_t arr = get(&fr, "fragments"), v;
    ub_json_iter_t it;
    ub_json_iter_begin(&it, &doc, &arr);
    static uint8_t frames[64][UB_FRAME_MAX];
    static size_t lens[64];
    uint16_t k = 0;
    ub_compact_codec_t c;
    codec_for("fleet", true, &c);
    while (ub_json_iter_next(&it, NULL, &v)) {
        uint8_t want[UB_FRAME_MAX], want_wire[UB_COMPACT_WIRE_MAX], pkt[UB_COMPACT_PACKET_MAX], wire[UB_COMPACT_WIRE_MAX];
        size_t nf = hex(&v, "frame", want, sizeof want), nw = hex(&v, "wire", want_wire, sizeof want_wire);
        ub_frame_header_t h = {.admin = UB_ADMIN_FRAGMENT, .hop_limit = 8, .seq = seq0 + k,
                               .fingerprint = insts[idx].type->fingerprint};
        memcpy(h.dir_id, did, UB_DIR_ID_LEN);
        memcpy(h.dest_id, gcs, UB_ENTITY_ID_LEN);
        memcpy(h.src_id, ob1, UB_ENTITY_ID_LEN);
        int n = ub_frag_write(frames[k] + UB_FRAME_HEADER_LEN, UB_MAX_PAYLOAD, transfer, k, count, data, total);
        assert_true(n > 0);
        h.payload_size = (uint16_t)n;
        int len = ub_frame_finish(frames[k], UB_FRAME_MAX, &h);
        assert_int_equal(len, (int)nf);
        assert_memory_equal(frames[k], want, nf);
        int np = ub_compact_encode(&c, frames[k], (size_t)len, true, pkt, sizeof pkt);
        size_t w = ub_cobs_encode(pkt, (size_t)np, wire, sizeof wire);
        assert_int_equal(w, nw);
        assert_memory_equal(wire, want_wire, nw);
        lens[k] = (size_t)len;
        k++;
    }
    assert_int_equal(k, count);
    /* Reassembly in a scrambled order, every fragment twice: whole once, only with the last missing piece. */
    static ub_frag_t f;
    ub_frag_init(&f, NULL, 0);
    int completes = 0, taken = 0;
    for (uint16_t j = 0; j < count; j++) {
        uint16_t i = (uint16_t)(j % 2 == 0 ? count - 1 - j / 2 : j / 2); /* last, first, last-1, ... */
        for (int copy = 0; copy < 2; copy++) {
            ub_frame_header_t h;
            assert_int_equal(ub_frame_parse(frames[i], lens[i], &h), UB_OK);
            const uint8_t *out = NULL;
            size_t out_len = 0;
            int r = ub_frag_take(&f, 0, h.src_id, h.dir_id, h.fingerprint, frames[i] + UB_FRAME_HEADER_LEN,
                                 h.payload_size, 10, &out, &out_len);
            if (copy == 1 && j + 1 < count) {
                assert_int_equal(r, UB_FRAG_DUPLICATE);
                continue;
            }
            if (copy == 1) continue; /* after completion the copy starts a new transfer: left to time out */
            taken++;
            if (r == UB_FRAG_COMPLETE) {
                completes++;
                assert_int_equal(taken, count);
                assert_int_equal(out_len, total);
                assert_memory_equal(out, data, total);
            } else {
                assert_int_equal(r, UB_FRAG_PENDING);
            }
        }
    }
    assert_int_equal(completes, 1);
    assert_int_equal(f.stats.rx_complete, 1);
    assert_int_equal(f.stats.rx_duplicates, count - 1);
    assert_int_equal(ub_frag_pending(&f), 1); /* the late copy of the last piece */
    assert_int_equal(ub_frag_expire(&f, 10 + UB_FRAG_TIMEOUT_MS - 1), 0);
    assert_int_equal(ub_frag_expire(&f, 10 + UB_FRAG_TIMEOUT_MS), 1);
    assert_int_equal(f.stats.rx_timeouts, 1);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hashes_and_cobs),
        cmocka_unit_test(test_vectors),
        cmocka_unit_test(test_rejects),
        cmocka_unit_test(test_fragments),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
