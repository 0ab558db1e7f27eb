/* tests/vectors/origin_frames.json (written by the independent Python reference
 * tests/vectors/make_origin_vectors.py) reproduced by the C runtime byte for byte: every X25519 public key,
 * every pair's directional keys, every origin tag and whole ORIGIN frame (hop tag or AEAD under the group key);
 * then every vector handed to a node hosting its destination passes the origin check, and every reject is
 * refused for its named reason. The JSON is read at run time with the runtime's own reader (ub_json.h). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "support/ub_test_world.h"
#include "ub/ub_frame.h"
#include "ub/ub_node_svc.h"
#include "ub/ub_origin.h"
#include "ub/ub_sec.h"
#include "codec/ub_json.h"

#define N_IDS 3

static char *text;
static ub_json_doc_t doc;
static ub_json_value_t root;
static char names[N_IDS][16];
static uint8_t ids[N_IDS][UB_ENTITY_ID_LEN], sks[N_IDS][32], pks[N_IDS][32];
static uint8_t group_key[32];

/* ---- JSON helpers ---- */
static bool member(const ub_json_value_t *obj, const char *key, ub_json_value_t *out) {
    ub_json_iter_t it;
    ub_json_value_t k, v;
    char name[64];
    ub_json_iter_begin(&it, &doc, obj);
    while (ub_json_iter_next(&it, &k, &v)) {
        ub_json_string(&doc, &k, name, sizeof name);
        if (strcmp(name, key) == 0) {
            *out = v;
            return true;
        }
    }
    return false;
}
static ub_json_value_t get(const ub_json_value_t *obj, const char *key) {
    ub_json_value_t v;
    if (!member(obj, key, &v)) fail_msg("missing key %s", key);
    return v;
}
static unsigned long long num(const ub_json_value_t *obj, const char *key) {
    ub_json_value_t v = get(obj, key);
    return strtoull(doc.text + v.start, NULL, 10);
}
static size_t str(const ub_json_value_t *obj, const char *key, char *out, size_t cap) {
    ub_json_value_t v = get(obj, key);
    return ub_json_string(&doc, &v, out, cap);
}
static size_t hex(const ub_json_value_t *obj, const char *key, uint8_t *out, size_t cap) {
    static char buf[8192];
    size_t n = str(obj, key, buf, sizeof buf);
    assert_true(n < sizeof buf && n % 2 == 0 && n / 2 <= cap);
    for (size_t i = 0; i < n / 2; i++) {
        unsigned b;
        sscanf(buf + 2 * i, "%2x", &b);
        out[i] = (uint8_t)b;
    }
    return n / 2;
}
static int who(const char *name) {
    for (int i = 0; i < N_IDS; i++)
        if (strcmp(names[i], name) == 0) return i;
    fail_msg("unknown identity %s", name);
    return -1;
}

static int setup(void **state) {
    (void)state;
    FILE *fp = fopen("tests/vectors/origin_frames.json", "rb");
    if (fp == NULL) return -1;
    fseek(fp, 0, SEEK_END);
    long n = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    text = malloc((size_t)n + 1);
    if (text == NULL || fread(text, 1, (size_t)n, fp) != (size_t)n) return -1;
    fclose(fp);
    uint32_t line;
    char msg[128];
    if (ub_json_parse(&doc, text, (size_t)n, &root, &line, msg, sizeof msg) != 0) return -1;
    ub_json_value_t arr = get(&root, "identities"), item, gk = get(&root, "group_key");
    hex(&gk, "key", group_key, sizeof group_key);
    ub_json_iter_t it;
    ub_json_iter_begin(&it, &doc, &arr);
    int k = 0;
    while (ub_json_iter_next(&it, NULL, &item) && k < N_IDS) {
        str(&item, "name", names[k], sizeof names[k]);
        hex(&item, "id", ids[k], UB_ENTITY_ID_LEN);
        hex(&item, "x25519_sk", sks[k], 32);
        hex(&item, "x25519_pk", pks[k], 32);
        k++;
    }
    return k == N_IDS ? 0 : -1;
}

static int teardown(void **state) {
    (void)state;
    free(text);
    return 0;
}

static void test_public_keys_and_pair_keys(void **state) {
    (void)state;
    for (int i = 0; i < N_IDS; i++) {
        uint8_t pk[32];
        assert_int_equal(ub_origin_public_key(sks[i], pk), UB_OK);
        assert_memory_equal(pk, pks[i], 32);
    }
    ub_json_value_t arr = get(&root, "pairs"), item;
    ub_json_iter_t it;
    ub_json_iter_begin(&it, &doc, &arr);
    size_t n = 0;
    while (ub_json_iter_next(&it, NULL, &item)) {
        char x[16], y[16];
        str(&item, "x", x, sizeof x);
        str(&item, "y", y, sizeof y);
        int ix = who(x), iy = who(y);
        uint8_t a[12], ab[16], ba[16], tx[16], rx[16];
        hex(&item, "a", a, sizeof a);
        hex(&item, "key_ab", ab, sizeof ab);
        hex(&item, "key_ba", ba, sizeof ba);
        bool x_is_a = memcmp(a, ids[ix], 12) == 0;
        assert_int_equal(ub_origin_pair_keys(ids[ix], sks[ix], ids[iy], pks[iy], tx, rx), UB_OK);
        assert_memory_equal(tx, x_is_a ? ab : ba, 16);
        assert_memory_equal(rx, x_is_a ? ba : ab, 16);
        assert_int_equal(ub_origin_pair_keys(ids[iy], sks[iy], ids[ix], pks[ix], tx, rx), UB_OK);
        assert_memory_equal(tx, x_is_a ? ba : ab, 16);
        n++;
    }
    assert_int_equal(n, 3);
}

/* ---- a node hosting one identity, the others known to its store ---- */
typedef struct host {
    ub_node_t node;
    ub_sec_t sec;
    ub_origin_t org;
    int link;
} host_t;

static int json_lookup(void *user, const uint8_t id[UB_ENTITY_ID_LEN], uint64_t now_s, uint8_t pk[32]) {
    (void)user;
    (void)now_s;
    for (int i = 0; i < N_IDS; i++)
        if (memcmp(ids[i], id, 12) == 0) {
            memcpy(pk, pks[i], 32);
            return UB_OK;
        }
    return UB_ERR_NOTFOUND;
}

static void host_up(host_t *h, int self) {
    assert_int_equal(ub_node_init(&h->node, &ub_test_cat, NULL), UB_OK);
    int e = ub_node_add_entity(&h->node, ids[self], true);
    for (int i = 0; i < N_IDS; i++)
        if (i != self) assert_true(ub_node_add_entity(&h->node, ids[i], false) >= 0);
    h->link = ub_node_add_link(&h->node, e, 0, "l0");
    test_sec_on(&h->sec, &h->node, group_key, 1000, true);
    ub_origin_options_t o = {.lookup = json_lookup};
    assert_int_equal(ub_origin_init(&h->org, &o), UB_OK);
    assert_int_equal(ub_origin_add_identity(&h->org, ids[self], sks[self]), UB_OK);
    assert_int_equal(ub_origin_attach(&h->org, &h->node), UB_OK);
}

static void test_frames_byte_for_byte_and_accepted_by_their_destination(void **state) {
    (void)state;
    static host_t hosts[N_IDS];
    for (int i = 0; i < N_IDS; i++) host_up(&hosts[i], i);
    ub_json_value_t arr = get(&root, "vectors"), v;
    ub_json_iter_t it;
    ub_json_iter_begin(&it, &doc, &arr);
    size_t n = 0;
    while (ub_json_iter_next(&it, NULL, &v)) {
        char mode[16], src[16], dest[16];
        str(&v, "mode", mode, sizeof mode);
        str(&v, "src", src, sizeof src);
        str(&v, "dest", dest, sizeof dest);
        int is = who(src), id = who(dest);
        ub_frame_header_t h;
        memset(&h, 0, sizeof h);
        static uint8_t payload[UB_MAX_PAYLOAD], want[UB_FRAME_MAX], frame[UB_FRAME_MAX];
        h.payload_size = (uint16_t)hex(&v, "payload", payload, sizeof payload);
        hex(&v, "dir_id", h.dir_id, UB_DIR_ID_LEN);
        memcpy(h.src_id, ids[is], 12);
        memcpy(h.dest_id, ids[id], 12);
        h.admin = (uint8_t)num(&v, "admin");
        h.hop_limit = (uint8_t)num(&v, "hop_limit");
        h.origin_hop0 = (uint8_t)num(&v, "hop0");
        h.fingerprint = (uint32_t)num(&v, "fingerprint");
        uint64_t counter = num(&v, "counter");
        h.seq = (uint32_t)counter;
        h.counter_hi = (uint16_t)(counter >> 32);
        h.key_id = (uint8_t)num(&v, "key_id");
        /* the origin tag, under the source's key towards the destination */
        uint8_t tx[16], rx[16], otag[8], want_tag[8];
        assert_int_equal(ub_origin_pair_keys(ids[is], sks[is], ids[id], pks[id], tx, rx), UB_OK);
        assert_int_equal(ub_origin_tag(tx, &h, payload, otag), UB_OK);
        hex(&v, "origin_tag", want_tag, sizeof want_tag);
        assert_memory_equal(otag, want_tag, 8);
        memcpy(h.origin_tag, otag, 8);
        h.flags = (uint8_t)((strcmp(mode, "signed") == 0 ? UB_FRAME_FLAG_SIGNED : UB_FRAME_FLAG_ENCRYPTED) |
                            UB_FRAME_FLAG_ORIGIN);
        int len = ub_sec_protect(&hosts[is].sec, &h, payload, frame, sizeof frame);
        size_t wn = hex(&v, "frame", want, sizeof want);
        assert_int_equal(len, (int)wn);
        assert_memory_equal(frame, want, wn);
        /* parsed back: the origin block */
        ub_frame_header_t p;
        assert_int_equal(ub_frame_parse(want, wn, &p), UB_OK);
        assert_int_equal(p.origin_hop0, h.origin_hop0);
        assert_memory_equal(p.origin_tag, otag, 8);
        /* the destination's node: past the hop tag and the origin check (then its window: unverified, a
         * challenge, or a reply to no challenge of its own) */
        host_t *d = &hosts[id];
        uint64_t opened = ub_origin_stats(&d->org)->opened;
        assert_int_equal(ub_node_rx_frame(&d->node, d->link, want, wn, 10), UB_OK);
        assert_int_equal(ub_origin_stats(&d->org)->opened, opened + 1);
        /* the source's node is no destination: it would forward; a third identity's node refuses the tag */
        n++;
    }
    assert_int_equal(n, 8);
    for (int i = 0; i < N_IDS; i++) {
        const ub_node_counters_t *c = ub_node_counters(&hosts[i].node);
        assert_int_equal(c->drops[UB_DROP_BAD_ORIGIN] + c->drops[UB_DROP_BAD_TAG] + c->drops[UB_DROP_NO_IDENTITY], 0);
    }
}

static void test_rejects_are_refused_for_their_reason(void **state) {
    (void)state;
    static host_t hosts[N_IDS];
    for (int i = 0; i < N_IDS; i++) host_up(&hosts[i], i);
    ub_json_value_t arr = get(&root, "rejects"), r;
    ub_json_iter_t it;
    ub_json_iter_begin(&it, &doc, &arr);
    size_t n = 0;
    while (ub_json_iter_next(&it, NULL, &r)) {
        char expect[32], dest[16];
        str(&r, "expect", expect, sizeof expect);
        str(&r, "dest", dest, sizeof dest);
        host_t *d = &hosts[who(dest)];
        static uint8_t frame[UB_FRAME_MAX];
        size_t len = hex(&r, "frame", frame, sizeof frame);
        if (strcmp(expect, "bad_version") == 0) {
            ub_rx_reason_t why = UB_RX_BAD_SYNC;
            assert_true(ub_frame_parse_reason(frame, len, NULL, &why) < 0);
            assert_int_equal(why, UB_RX_BAD_VERSION);
            n++;
            continue;
        }
        ub_drop_reason_t reason = UB_DROP_REASON_COUNT;
        for (int k = 0; k < UB_DROP_REASON_COUNT; k++)
            if (strcmp(ub_drop_reason_name((ub_drop_reason_t)k), expect) == 0) reason = (ub_drop_reason_t)k;
        assert_true(reason != UB_DROP_REASON_COUNT);
        uint64_t before = ub_node_counters(&d->node)->drops[reason];
        assert_int_equal(ub_node_rx_frame(&d->node, d->link, frame, len, 10), UB_OK);
        assert_int_equal(ub_node_counters(&d->node)->drops[reason], before + 1);
        n++;
    }
    assert_int_equal(n, 6);
    for (int i = 0; i < N_IDS; i++) assert_int_equal(ub_origin_stats(&hosts[i].org)->opened, 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_public_keys_and_pair_keys),
        cmocka_unit_test(test_frames_byte_for_byte_and_accepted_by_their_destination),
        cmocka_unit_test(test_rejects_are_refused_for_their_reason),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
