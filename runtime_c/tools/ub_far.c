/* False-accept rate of the frame checks under random corruption, for
 *   (a) the paper's baseline: two 8-bit additive checksums (header, whole message), and
 *   (b) uavbus: 8-bit folded CRC-32C header check + 32-bit CRC-32C message check.
 * Both frames carry the same fields; corruption hits every byte after the two sync
 * bytes (a hit sync byte is rejected by both schemes alike, so it would only dilute).
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

enum { MODE_FLIPS_FIRST = 1, MODE_FLIPS_LAST = 8, MODE_BURST = 9, MODE_GARBAGE = 10 };

static void corrupt(rng_t *r, int mode, uint8_t *f, size_t len, const uint8_t *orig, const scheme_t *s) {
    size_t body_bits = 8 * (len - 2);
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
            f[2 + bit / 8] ^= (uint8_t)(1u << (bit % 8));
        }
    } else if (mode == MODE_BURST) {
        size_t burst = 2 + rng_below(r, 15);
        size_t start = 2 + rng_below(r, (uint32_t)(len - 2 - burst + 1));
        random_fields(r, f + start, burst);
    } else {
        random_fields(r, f + 2, len - 2);
        s->restore_structure(f, orig);
    }
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
    static const scheme_t schemes[] = {
        {"two 8-bit sums (paper)", base_build, base_accepts, base_restore},
        {"uavbus CRC-32C", ours_build, ours_accepts, ours_restore},
    };
    static const uint16_t payloads[] = {24, 48, 59}; /* 88/112/123-byte frames, as in the benchmarks */
    printf("false accepts per corrupted frame, %ld trials per cell, seed %llu, payloads 24/48/59 B\n", trials,
           (unsigned long long)seed);
    printf("%-28s %30s %30s\n", "corruption", schemes[0].name, schemes[1].name);
    uint8_t frame[UB_FRAME_MAX], orig[UB_FRAME_MAX];
    for (int mode = MODE_FLIPS_FIRST; mode <= MODE_GARBAGE; mode++) {
        char name[48];
        printf("%-28s", mode_name(mode, name, sizeof name));
        for (size_t s = 0; s < 2; s++) {
            rng_t r = {seed * 1000003u + (uint64_t)mode * 17u + s};
            long counted = 0, accepted = 0;
            while (counted < trials) {
                size_t len = schemes[s].build(&r, orig, payloads[rng_below(&r, 3)]);
                memcpy(frame, orig, len);
                corrupt(&r, mode, frame, len, orig, &schemes[s]);
                if (memcmp(frame, orig, len) == 0) continue;
                counted++;
                accepted += schemes[s].accepts(frame, len);
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
