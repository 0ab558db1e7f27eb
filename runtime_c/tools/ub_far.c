/* False-accept rate of the frame checks under random corruption, for
 *   (a) the paper's baseline: two 8-bit additive checksums (header, whole message),
 *   (b) uavbus: 8-bit folded CRC-32C header check + 32-bit CRC-32C message check,
 *   (c) uavbus compact (ub_compact.h): COBS-stuffed packet, CRC-32C over the dictionary and the packet,
 *       decoded by the link's own receive path (ub_compact_feed) with the dictionary agreed, and
 *   (d) the same compact packet with MAVLink 2's 16-bit check (CRC-16/MCRF4XX) in place of the CRC-32C,
 *       to show what two bytes of check would give.
 * The full frames carry the same fields; corruption hits every byte after the two sync
 * bytes (a hit sync byte is rejected by both schemes alike, so it would only dilute); for
 * compact packets every byte on the wire but the final 0x00 delimiter (the frames around
 * it would take the damage otherwise).
 * Modes: k random distinct bit flips (k = 1..8); a burst of 2..16 random bytes; and
 * whole-frame garbage that keeps sync, version, message type and both sizes (so only
 * the checks can reject it). Trials that left the frame unchanged are not counted.
 * Not a test; built at -O2 by runtime_c/tests/frame.cmake:
 *
 *     ub_far [trials per mode and scheme, default 1000000] [seed, default 1]
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ub/ub_compact.h"
#include "ub/ub_frame.h"
#include "ub/ub_wire.h"

#define BASE_HEADER_LEN 60u /* sync(2) hdr_sum(1) msg_sum(1) + the same fields as bytes [4,60) of ours */

typedef struct rng {
    uint64_t state;
} rng_t;

static uint64_t rng_next(rng_t *r) {
    uint64_t z = (r->state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static uint32_t rng_below(rng_t *r, uint32_t n) { return (uint32_t)(rng_next(r) % n); }

static uint8_t sum8(const uint8_t *p, size_t n) {
    uint8_t s = 0;
    for (size_t i = 0; i < n; i++) s = (uint8_t)(s + p[i]);
    return s;
}

typedef struct scheme {
    const char *name;
    size_t (*build)(rng_t *r, uint8_t *f, uint16_t payload_size);
    int (*accepts)(const uint8_t *f, size_t len);
    void (*restore_structure)(uint8_t *f, const uint8_t *orig); /* for the garbage mode */
    size_t head, tail; /* bytes corruption leaves alone: sync before, delimiter after */
    size_t (*garbage)(rng_t *r, uint8_t *f, size_t len, const uint8_t *orig); /* NULL: random + restore */
} scheme_t;

static void random_fields(rng_t *r, uint8_t *f, size_t len) {
    for (size_t i = 0; i < len; i++) f[i] = (uint8_t)rng_next(r);
}

static size_t ours_build(rng_t *r, uint8_t *f, uint16_t payload_size) {
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    random_fields(r, h.dir_id, sizeof h.dir_id);
    random_fields(r, h.dest_id, sizeof h.dest_id);
    random_fields(r, h.src_id, sizeof h.src_id);
    h.admin = (uint8_t)rng_below(r, 7);
    h.hop_limit = (uint8_t)(1 + rng_below(r, 255));
    h.payload_size = payload_size;
    h.seq = (uint32_t)rng_next(r);
    h.fingerprint = (uint32_t)rng_next(r);
    random_fields(r, f + UB_FRAME_HEADER_LEN, payload_size);
    int n = ub_frame_finish(f, UB_FRAME_MAX, &h);
    return n < 0 ? 0 : (size_t)n;
}

static int ours_accepts(const uint8_t *f, size_t len) { return ub_frame_parse(f, len, NULL) == UB_OK; }

static void ours_restore(uint8_t *f, const uint8_t *orig) {
    f[UB_FRAME_OFF_VERSION] = orig[UB_FRAME_OFF_VERSION];
    memcpy(f + UB_FRAME_OFF_MSG_TYPE, orig + UB_FRAME_OFF_MSG_TYPE, 4); /* msg_type, msg_size */
    memcpy(f + UB_FRAME_OFF_PAYLOAD_SIZE, orig + UB_FRAME_OFF_PAYLOAD_SIZE, 2);
}

/* The baseline: the same 56 field bytes at [4,60), payload after, two 8-bit sums. */
static size_t base_build(rng_t *r, uint8_t *f, uint16_t payload_size) {
    size_t len = BASE_HEADER_LEN + payload_size;
    random_fields(r, f + 4, len - 4);
    f[0] = UB_SYNC0;
    f[1] = UB_SYNC1;
    ub_put_u16le(f + 4, UB_MSG_TYPE_PUBSUB);
    ub_put_u16le(f + 6, (uint16_t)len);
    ub_put_u16le(f + 50, payload_size);
    f[2] = sum8(f + 4, BASE_HEADER_LEN - 4);
    f[3] = sum8(f + 4, len - 4);
    return len;
}

static int base_accepts(const uint8_t *f, size_t len) {
    return f[0] == UB_SYNC0 && f[1] == UB_SYNC1 && ub_get_u16le(f + 4) == UB_MSG_TYPE_PUBSUB &&
           ub_get_u16le(f + 6) == len && ub_get_u16le(f + 50) + BASE_HEADER_LEN == len &&
           f[2] == sum8(f + 4, BASE_HEADER_LEN - 4) && f[3] == sum8(f + 4, len - 4);
}

static void base_restore(uint8_t *f, const uint8_t *orig) {
    memcpy(f + 4, orig + 4, 4); /* msg_type, msg_size */
    memcpy(f + 50, orig + 50, 2);
}

/* ---- compact: a 3-type catalogue (24/48/59-byte payloads) and an agreed 8-entity list ---- */
static ub_type_desc_t c_types[3] = {{"t24", 0x11111111u, 24, 24, NULL, NULL},
                                    {"t48", 0x22222222u, 48, 48, NULL, NULL},
                                    {"t59", 0x33333333u, 59, 59, NULL, NULL}};
static ub_instance_desc_t c_insts[3];
static ub_catalogue_t c_cat;
static ub_compact_t c_rx;        /* the receiving end: the sender's list and a reference for every source */
static ub_compact_codec_t c_tx;  /* the sending end's dictionary */

static void compact_setup(void) {
    for (int i = 0; i < 3; i++) {
        memset(c_insts[i].id, 'a' + i, UB_DIR_ID_LEN); /* ascending IDs */
        c_insts[i].name = c_types[i].name;
        c_insts[i].type = &c_types[i];
    }
    c_cat = (ub_catalogue_t){"far", UB_ID_SCHEME_PAPER, UB_CATALOGUE_ABI_VERSION, c_types, 3, c_insts, 3, 59, NULL, 0};
    ub_compact_init(&c_rx, &c_cat, 1, NULL);
    c_rx.peer_n = 8;
    for (int i = 0; i < 8; i++) memset(c_rx.peer_ids[i], 'A' + i, UB_ENTITY_ID_LEN);
    c_rx.peer_list_hash = ub_compact_list_hash((const uint8_t(*)[UB_ENTITY_ID_LEN])c_rx.peer_ids, 8);
    c_rx.peer_list_ok = 1;
    for (int i = 0; i < 8; i++) ub_compact_rx_note(&c_rx, c_rx.peer_ids[i], 0x40000000u, true);
    ub_compact_rx_codec(&c_rx, &c_tx);
    c_tx.content_ok = 1;
}

/* A random indexed DATA frame, its packet (16-bit sequence near the receiver's reference), stuffed. */
static int compact_packet(rng_t *r, uint16_t payload_size, uint8_t *pkt) {
    int t = payload_size == 24 ? 0 : payload_size == 48 ? 1 : 2;
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memcpy(h.dir_id, c_insts[t].id, UB_DIR_ID_LEN);
    memcpy(h.dest_id, c_rx.peer_ids[rng_below(r, 8)], UB_ENTITY_ID_LEN);
    memcpy(h.src_id, c_rx.peer_ids[rng_below(r, 8)], UB_ENTITY_ID_LEN);
    h.hop_limit = (uint8_t)(1 + rng_below(r, 15));
    h.payload_size = payload_size;
    h.seq = 0x40000000u + rng_below(r, 30000);
    h.fingerprint = c_types[t].fingerprint;
    uint8_t f[UB_FRAME_MAX];
    random_fields(r, f + UB_FRAME_HEADER_LEN, payload_size);
    f[UB_FRAME_HEADER_LEN + payload_size - 1] |= 1; /* no trailing zero: every frame the same size */
    int n = ub_frame_finish(f, sizeof f, &h);
    return n < 0 ? n : ub_compact_encode(&c_tx, f, (size_t)n, false, pkt, UB_COMPACT_PACKET_MAX);
}

static size_t compact_build(rng_t *r, uint8_t *f, uint16_t payload_size) {
    uint8_t pkt[UB_COMPACT_PACKET_MAX];
    int n = compact_packet(r, payload_size, pkt);
    return n < 0 ? 0 : ub_cobs_encode(pkt, (size_t)n, f, UB_FRAME_MAX);
}

static int compact_accepts(const uint8_t *f, size_t len) {
    c_rx.stats.rx_frames = 0;
    return ub_compact_feed(&c_rx, NULL, f, len, 0, NULL, NULL, NULL) > 0;
}

/* Garbage: the packet's bytes after its control byte random, stuffed again, so that only the check rejects. */
static size_t compact_garbage(rng_t *r, uint8_t *f, size_t len, const uint8_t *orig) {
    (void)len;
    uint8_t pkt[UB_COMPACT_PACKET_MAX];
    int n = ub_cobs_decode(orig, len - 1, pkt, sizeof pkt);
    if (n < 2) return 0;
    random_fields(r, pkt + 1, (size_t)n - 1);
    return ub_cobs_encode(pkt, (size_t)n, f, UB_FRAME_MAX);
}

/* (d): the same packet, its 4-byte check replaced by CRC-16/MCRF4XX (MAVLink's) over the prefix and packet. */
static uint16_t crc16_x25(uint16_t crc, const uint8_t *p, size_t n) {
    for (size_t i = 0; i < n; i++) {
        uint8_t t = (uint8_t)(p[i] ^ (crc & 0xFF));
        t ^= (uint8_t)(t << 4);
        crc = (uint16_t)((crc >> 8) ^ ((uint16_t)t << 8) ^ ((uint16_t)t << 3) ^ (t >> 4));
    }
    return crc;
}
static uint16_t crc16_of(const uint8_t *pkt, size_t n) {
    uint8_t prefix[16];
    ub_put_u64le(prefix, c_tx.cat_hash);
    ub_put_u64le(prefix + 8, c_tx.list_hash);
    return crc16_x25(crc16_x25(0xFFFF, prefix, 16), pkt, n);
}
static size_t crc16_build(rng_t *r, uint8_t *f, uint16_t payload_size) {
    uint8_t pkt[UB_COMPACT_PACKET_MAX];
    int n = compact_packet(r, payload_size, pkt);
    if (n < 6) return 0;
    n -= 2; /* two check bytes instead of four */
    ub_put_u16le(pkt + n - 2, crc16_of(pkt, (size_t)n - 2));
    return ub_cobs_encode(pkt, (size_t)n, f, UB_FRAME_MAX);
}
static int crc16_accepts(const uint8_t *f, size_t len) {
    /* Every packet the stream holds (a flip can create a delimiter): accepted if one passes its check. */
    size_t start = 0;
    for (size_t i = 0; i < len; i++) {
        if (f[i] != 0) continue;
        uint8_t pkt[UB_COMPACT_PACKET_MAX];
        int n = ub_cobs_decode(f + start, i - start, pkt, sizeof pkt);
        start = i + 1;
        if (n >= 7 && ub_get_u16le(pkt + n - 2) == crc16_of(pkt, (size_t)n - 2)) return 1;
    }
    return 0;
}

enum { MODE_FLIPS_FIRST = 1, MODE_FLIPS_LAST = 8, MODE_BURST = 9, MODE_GARBAGE = 10 };

static size_t corrupt(rng_t *r, int mode, uint8_t *f, size_t len, const uint8_t *orig, const scheme_t *s) {
    size_t head = s->head, body = len - s->head - s->tail, body_bits = 8 * body;
    if (mode >= MODE_FLIPS_FIRST && mode <= MODE_FLIPS_LAST) {
        uint32_t chosen[MODE_FLIPS_LAST];
        for (int k = 0; k < mode; k++) {
            uint32_t bit;
            int again;
            do { /* distinct positions, so k flips really change k bits */
                bit = rng_below(r, (uint32_t)body_bits);
                again = 0;
                for (int j = 0; j < k; j++) again |= chosen[j] == bit;
            } while (again);
            chosen[k] = bit;
            f[head + bit / 8] ^= (uint8_t)(1u << (bit % 8));
        }
    } else if (mode == MODE_BURST) {
        size_t burst = 2 + rng_below(r, 15);
        size_t start = head + rng_below(r, (uint32_t)(body - burst + 1));
        random_fields(r, f + start, burst);
    } else if (s->garbage != NULL) {
        return s->garbage(r, f, len, orig);
    } else {
        random_fields(r, f + head, body);
        s->restore_structure(f, orig);
    }
    return len;
}

static const char *mode_name(int mode, char *buf, size_t cap) {
    if (mode == MODE_BURST) return "burst of 2-16 random bytes";
    if (mode == MODE_GARBAGE) return "whole-frame garbage";
    snprintf(buf, cap, "%d random bit flip%s", mode, mode == 1 ? "" : "s");
    return buf;
}

int main(int argc, char **argv) {
    long trials = argc > 1 ? atol(argv[1]) : 1000000;
    uint64_t seed = argc > 2 ? strtoull(argv[2], NULL, 0) : 1;
    if (trials < 1) {
        fprintf(stderr, "usage: %s [trials >= 1] [seed]\n", argv[0]);
        return 2;
    }
    compact_setup();
    static const scheme_t schemes[] = {
        {"two 8-bit sums (paper)", base_build, base_accepts, base_restore, 2, 0, NULL},
        {"uavbus CRC-32C", ours_build, ours_accepts, ours_restore, 2, 0, NULL},
        {"compact, CRC-32C", compact_build, compact_accepts, NULL, 0, 1, compact_garbage},
        {"compact, 16-bit (MAVLink's)", crc16_build, crc16_accepts, NULL, 0, 1, compact_garbage},
    };
    enum { N_SCHEMES = sizeof schemes / sizeof schemes[0] };
    static const uint16_t payloads[] = {24, 48, 59}; /* 88/112/123-byte frames (compact: 35/59/70), as in the benchmarks */
    printf("false accepts per corrupted frame, %ld trials per cell, seed %llu, payloads 24/48/59 B\n", trials,
           (unsigned long long)seed);
    printf("%-28s", "corruption");
    for (size_t s = 0; s < N_SCHEMES; s++) printf(" %30s", schemes[s].name);
    printf("\n");
    uint8_t frame[UB_FRAME_MAX], orig[UB_FRAME_MAX];
    for (int mode = MODE_FLIPS_FIRST; mode <= MODE_GARBAGE; mode++) {
        char name[48];
        printf("%-28s", mode_name(mode, name, sizeof name));
        for (size_t s = 0; s < N_SCHEMES; s++) {
            rng_t r = {seed * 1000003u + (uint64_t)mode * 17u + s};
            long counted = 0, accepted = 0;
            while (counted < trials) {
                size_t len = schemes[s].build(&r, orig, payloads[rng_below(&r, 3)]);
                if (len == 0) abort();
                memcpy(frame, orig, len);
                size_t got = corrupt(&r, mode, frame, len, orig, &schemes[s]);
                if (got == len && memcmp(frame, orig, len) == 0) continue;
                counted++;
                accepted += schemes[s].accepts(frame, got);
            }
            char cell[64];
            if (accepted == 0)
                snprintf(cell, sizeof cell, "0/%ld (< %.1e)", counted, 3.0 / (double)counted); /* 95% bound */
            else
                snprintf(cell, sizeof cell, "%ld/%ld = %.2e", accepted, counted, (double)accepted / (double)counted);
            printf(" %30s", cell);
        }
        printf("\n");
        fflush(stdout);
    }
    return 0;
}
