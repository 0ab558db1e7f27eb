/*
 * Fuzz harness: hostile ORIGIN frames (the origin block and the origin-tagged challenge handshake; issue 23
 * item 2) into a node hosting "b" that holds the group key and runs ub_origin, with identities "a", "f", "b"
 * (fixed test seeds) in a static store, and a capturing transport behind its link. The input is a program:
 *
 *   repeated: op u8 | arg u8 | len u16le | len bytes
 *     op % 6 = 0  the bytes, raw, as a datagram into ub_node_rx_frame()
 *              1  the bytes made into an ORIGIN frame with a right hop tag (the group key: an insider's or a
 *                 forwarder's frame): header fields, hop limit, hop0 and origin tag from the bytes, source
 *                 and destination among the known IDs and a stranger as `arg` asks, admin code DATA,
 *                 CHALLENGE, CHALLENGE_REPLY or any
 *              2  as 1 with the origin tag the real source would make (a's or f's key towards b), then
 *                 `arg` may flip one bit of the block or raise the hop limit: the accept path, the window and
 *                 the challenge handshake
 *              3  time passes (1 + 8 * arg ms) and the node ticks (challenge retries, origin-tagged)
 *              4  ub_origin_pair_keys() with a public key from the bytes (small-order and non-canonical points)
 *              5  the identity store refuses (arg odd) or knows again (arg even) identity arg / 2 % 3
 *
 * Properties checked after every operation (a failure aborts): every frame the node sends parses, and a frame
 * it sends with an origin block carries the tag b's key towards its destination makes; a frame from "a" or
 * "f" whose origin tag is not the real one is never delivered nor passes the origin check, and one whose tag is
 * the real one always passes it while the store knows its source; the origin counters never exceed the node's
 * drop counters of the same reasons.
 */
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "flightsw.h"
#include "fuzz_util.h"
#include "ub/ub_frame.h"
#include "ub/ub_node.h"
#include "ub/ub_node_svc.h"
#include "ub/ub_origin.h"
#include "ub/ub_sec.h"

#define N_IDS 4 /* a, f, b, and a stranger the store never knows */

static const char *const k_names[N_IDS] = {"a", "f", "b", "stranger"};
static const uint8_t k_group_key[UB_SEC_KEY_LEN] = {9, 8, 7, 6, 5, 4, 3, 2, 1, 0, 9, 8, 7, 6, 5, 4,
                                                    3, 2, 1, 0, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0, 9, 8};
static uint8_t g_ids[N_IDS][UB_ENTITY_ID_LEN], g_sk[N_IDS][32], g_pk[N_IDS][32];
static bool g_refused[N_IDS];
static ub_node_t g_node;
static ub_sec_t g_sec, g_forger; /* the node's context, and the insider's (same group key) */
static ub_origin_t g_org;
static int g_link;

static int store_lookup(void *user, const uint8_t id[UB_ENTITY_ID_LEN], uint64_t now_s, uint8_t pk[32]) {
    (void)user;
    (void)now_s;
    for (int i = 0; i < N_IDS - 1; i++)
        if (memcmp(g_ids[i], id, UB_ENTITY_ID_LEN) == 0 && !g_refused[i]) {
            memcpy(pk, g_pk[i], 32);
            return UB_OK;
        }
    return UB_ERR_NOTFOUND;
}

static int capture_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    (void)impl;
    (void)now_ms;
    ub_frame_header_t h;
    FUZZ_CHECK(ub_frame_parse(frame, len, &h) == UB_OK, "the node sent an invalid frame (%zu bytes)", len);
    if (h.flags & UB_FRAME_FLAG_ORIGIN) {
        int d = -1;
        for (int i = 0; i < N_IDS; i++)
            if (memcmp(g_ids[i], h.dest_id, UB_ENTITY_ID_LEN) == 0) d = i;
        FUZZ_CHECK(d >= 0 && d < N_IDS - 1, "an origin block towards an entity without identity");
        uint8_t tx[16], rx[16], tag[8];
        FUZZ_CHECK(ub_origin_pair_keys(g_ids[2], g_sk[2], g_ids[d], g_pk[d], tx, rx) == UB_OK, "pair keys");
        const uint8_t *payload = frame + UB_FRAME_HEADER_LEN;
        uint8_t plain[UB_MAX_PAYLOAD];
        if (h.flags & UB_FRAME_FLAG_ENCRYPTED) {
            FUZZ_CHECK(ub_sec_verify(&g_forger, &h, frame, len, plain, sizeof plain) == UB_OK, "hop AEAD");
            payload = plain;
        }
        FUZZ_CHECK(ub_origin_tag(tx, &h, payload, tag) == UB_OK && memcmp(tag, h.origin_tag, 8) == 0,
                   "the node sent a wrong origin tag");
        FUZZ_CHECK(h.hop_limit <= h.origin_hop0, "hop limit above hop0 on the way out");
    }
    return UB_OK;
}

static const ub_link_ops_t capture_ops = {.send = capture_send};

static void setup_node(void) {
    FUZZ_CHECK(ub_node_init(&g_node, &flightsw_catalogue, NULL) == UB_OK, "node init");
    int b = ub_node_add_entity(&g_node, g_ids[2], true);
    for (int i = 0; i < N_IDS; i++)
        if (i != 2) FUZZ_CHECK(ub_node_add_entity(&g_node, g_ids[i], false) >= 0, "entity");
    g_link = ub_node_add_link(&g_node, b, 0, "l0");
    FUZZ_CHECK(ub_node_link_attach(&g_node, g_link, &capture_ops, NULL) == UB_OK, "attach");
    for (int i = 0; i < N_IDS; i++)
        if (i != 2) FUZZ_CHECK(ub_node_set_mask(&g_node, b, ub_node_find_entity(&g_node, g_ids[i]), 0x01) == UB_OK, "mask");
    FUZZ_CHECK(ub_sec_init(&g_sec, NULL) == UB_OK && ub_sec_add_key(&g_sec, 1, k_group_key) == UB_OK &&
                   ub_sec_set_tx_key(&g_sec, 1) == UB_OK && ub_sec_start(&g_sec, 0, 1000) == UB_OK,
               "sec");
    FUZZ_CHECK(ub_node_set_security(&g_node, &g_sec) == UB_OK && ub_node_set_require_signed(&g_node, true) == UB_OK,
               "attach sec");
    ub_origin_options_t o = {.lookup = store_lookup};
    FUZZ_CHECK(ub_origin_init(&g_org, &o) == UB_OK && ub_origin_add_identity(&g_org, g_ids[2], g_sk[2]) == UB_OK &&
                   ub_origin_attach(&g_org, &g_node) == UB_OK,
               "origin");
}

int LLVMFuzzerInitialize(int *argc, char ***argv) {
    (void)argc;
    (void)argv;
    for (int i = 0; i < N_IDS; i++) {
        memset(g_ids[i], 0, UB_ENTITY_ID_LEN);
        memcpy(g_ids[i], k_names[i], strlen(k_names[i]));
        for (int k = 0; k < 32; k++) g_sk[i][k] = (uint8_t)(0x30 + 11 * k + 29 * i);
        FUZZ_CHECK(ub_origin_public_key(g_sk[i], g_pk[i]) == UB_OK, "public key");
    }
    FUZZ_CHECK(ub_sec_init(&g_forger, NULL) == UB_OK && ub_sec_add_key(&g_forger, 1, k_group_key) == UB_OK, "forger");
    return 0;
}

/* An ORIGIN frame from the bytes with a right hop tag; `real` puts the true source's origin tag in. */
static size_t make_origin_frame(uint8_t *out, uint8_t arg, const uint8_t *b, size_t n, bool real, bool *genuine) {
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    uint8_t raw[32] = {0};
    memcpy(raw, b, n < sizeof raw ? n : sizeof raw);
    const uint8_t *payload = n > sizeof raw ? b + sizeof raw : raw;
    size_t plen = n > sizeof raw ? n - sizeof raw : 0;
    if (plen > UB_MAX_PAYLOAD) plen = UB_MAX_PAYLOAD;
    int src = (arg & 3) == 2 ? 3 : arg & 3; /* a, f, stranger (or f again) */
    int dest = (arg >> 2) & 3;              /* b mostly: 2; else another */
    if (dest == 3 || dest == 0 || dest == src) dest = 2;
    memcpy(h.src_id, g_ids[src], UB_ENTITY_ID_LEN);
    memcpy(h.dest_id, g_ids[dest], UB_ENTITY_ID_LEN);
    static const uint8_t admins[3] = {UB_ADMIN_DATA, UB_ADMIN_CHALLENGE, UB_ADMIN_CHALLENGE_REPLY};
    unsigned kind = (arg >> 4) & 3u;
    h.admin = kind < 3 ? admins[kind] : raw[0];
    h.hop_limit = raw[1] == 0 ? 1 : raw[1];
    h.origin_hop0 = raw[2];
    memcpy(h.origin_tag, raw + 3, 8);
    h.seq = (uint32_t)raw[11] | (uint32_t)raw[12] << 8 | (uint32_t)raw[13] << 16 | (uint32_t)raw[14] << 24;
    h.counter_hi = (uint16_t)(raw[15] | raw[16] << 8);
    h.fingerprint = raw[17];
    h.payload_size = (uint16_t)plen;
    h.key_id = 1;
    h.flags = (uint8_t)((raw[18] & 1 ? UB_FRAME_FLAG_ENCRYPTED : UB_FRAME_FLAG_SIGNED) | UB_FRAME_FLAG_ORIGIN);
    *genuine = false;
    if (real && src < 2) {
        if (h.origin_hop0 < h.hop_limit) h.origin_hop0 = h.hop_limit;
        uint8_t tx[16], rx[16];
        FUZZ_CHECK(ub_origin_pair_keys(g_ids[src], g_sk[src], g_ids[dest], g_pk[dest], tx, rx) == UB_OK, "keys");
        FUZZ_CHECK(ub_origin_tag(tx, &h, payload, h.origin_tag) == UB_OK, "tag");
        *genuine = true;
        if (arg & 0x40) { /* one bit of the block flipped, or the hop limit raised past hop0 */
            if (raw[19] & 1)
                h.origin_tag[raw[19] >> 1 & 7] ^= (uint8_t)(1u << (raw[20] & 7));
            else if (h.origin_hop0 < 255)
                h.hop_limit = (uint8_t)(h.origin_hop0 + 1);
            else
                h.origin_hop0 ^= 1;
            *genuine = false;
        }
    }
    int len = ub_sec_protect(&g_forger, &h, payload, out, UB_FRAME_MAX);
    FUZZ_CHECK(len > 0, "protect failed");
    return (size_t)len;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    memset(g_refused, 0, sizeof g_refused);
    setup_node();
    fuzz_in_t in = {data, size};
    uint64_t now = 0;
    static uint8_t frame[UB_FRAME_MAX];
    while (in.left > 0) {
        uint8_t op = fuzz_u8(&in), arg = fuzz_u8(&in);
        size_t n;
        const uint8_t *b = fuzz_bytes(&in, fuzz_u16(&in), &n);
        ub_origin_stats_t before = *ub_origin_stats(&g_org);
        uint64_t delivered = ub_node_counters(&g_node)->delivered;
        switch (op % 6) {
        case 0:
            fuzz_ignore(ub_node_rx_frame(&g_node, g_link, b, n, now));
            break;
        case 1:
        case 2: {
            bool genuine = false;
            size_t len = make_origin_frame(frame, arg, b, n, op % 6 == 2, &genuine);
            fuzz_ignore(ub_node_rx_frame(&g_node, g_link, frame, len, now));
            ub_frame_header_t h;
            FUZZ_CHECK(ub_frame_parse(frame, len, &h) == UB_OK, "made frame parses");
            bool to_b = memcmp(h.dest_id, g_ids[2], UB_ENTITY_ID_LEN) == 0;
            int src = -1;
            for (int i = 0; i < 2; i++)
                if (memcmp(h.src_id, g_ids[i], UB_ENTITY_ID_LEN) == 0) src = i;
            if (to_b && genuine && src >= 0 && !g_refused[src])
                FUZZ_CHECK(ub_origin_stats(&g_org)->opened == before.opened + 1, "a genuine origin block was refused");
            if (to_b && !genuine) { /* (2^-64 per input for a random tag to be right) */
                FUZZ_CHECK(ub_origin_stats(&g_org)->opened == before.opened, "a forged origin block was accepted");
                FUZZ_CHECK(ub_node_counters(&g_node)->delivered == delivered, "a forged frame was delivered");
            }
            break;
        }
        case 3:
            now += 1u + 8u * arg;
            ub_node_tick(&g_node, now);
            break;
        case 4: {
            uint8_t pk[32] = {0}, tx[16], rx[16];
            memcpy(pk, b, n < 32 ? n : 32);
            int rc = ub_origin_pair_keys(g_ids[2], g_sk[2], g_ids[arg % 2], pk, tx, rx);
            FUZZ_CHECK(rc == UB_OK || rc == UB_ERR_AUTH, "pair keys: %d", rc);
            break;
        }
        case 5:
            g_refused[(arg / 2) % 3] = (arg & 1) != 0;
            break;
        }
        const ub_origin_stats_t *s = ub_origin_stats(&g_org);
        const ub_node_counters_t *c = ub_node_counters(&g_node);
        FUZZ_CHECK(s->bad_origin <= c->drops[UB_DROP_BAD_ORIGIN] && s->no_origin <= c->drops[UB_DROP_NO_ORIGIN],
                   "origin counters above the node's drops");
        FUZZ_CHECK(ub_origin_cached(&g_org) <= UB_ORIGIN_PEERS, "cache overflow");
    }
    return 0;
}

/* Seeds: a genuine DATA frame from a (and after a tick, again: past the challenge), a challenge from f, a
 * reply, a flipped origin tag, a raised hop limit, a forged frame, a raw truncated datagram, a small-order key. */
void ub_fuzz_write_seeds(const char *dir) {
    static uint8_t buf[2048];
    static const struct {
        uint8_t op, arg;
        uint16_t len;
    } progs[][4] = {
        {{2, 0x00, 60}, {3, 10, 0}, {2, 0x00, 60}, {2, 0x00, 60}},
        {{2, 0x11, 48}, {3, 30, 0}, {2, 0x21, 48}, {3, 30, 0}},
        {{2, 0x40, 60}, {2, 0x40, 40}, {1, 0x00, 60}, {1, 0x01, 20}},
        {{2, 0x00, 60}, {5, 1, 0}, {3, 200, 0}, {2, 0x00, 60}},
        {{0, 0, 40}, {4, 0, 32}, {4, 1, 0}, {2, 0x02, 33}},
    };
    for (size_t s = 0; s < sizeof progs / sizeof progs[0]; s++) {
        size_t n = 0;
        for (int k = 0; k < 4; k++) {
            buf[n++] = progs[s][k].op;
            buf[n++] = progs[s][k].arg;
            buf[n++] = (uint8_t)progs[s][k].len;
            buf[n++] = (uint8_t)(progs[s][k].len >> 8);
            for (uint16_t i = 0; i < progs[s][k].len; i++) buf[n++] = (uint8_t)(i == 1 ? 8 : i == 2 ? 8 : 0x21 * i + s);
        }
        char name[32];
        snprintf(name, sizeof name, "seed%zu", s);
        fuzz_write_seed(dir, name, buf, n);
    }
}
