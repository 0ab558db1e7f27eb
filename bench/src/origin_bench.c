/*
 * Origin authentication cost (issue 23 item 2; docs/security.md, "Origin authentication"): the signed frame
 * with and without the origin block, built and verified as the runtime does it, and the pairwise key
 * derivation per pair. Built by bench/run.sh at -O2 against the same libub and libsodium as codec_bench
 * (whose MAVLink 2 signed pack + parse rows, in the same run, are the yardstick).
 *
 *   origin_bench     every case calibrated to ~10 ms batches, SAMPLES samples round-robin across cases;
 *                    prints "case<TAB>bytes<TAB>ns per op (one per sample)...", then "ram<TAB>what<TAB>bytes"
 *
 * Cases (payload: GPS_RAW_INT-sized, 52 bytes; the counter changes every iteration):
 *   signed_build          ub_sec_protect(SIGNED): the existing signed path
 *   signed_verify         ub_frame_parse + ub_sec_verify
 *   signed_build_verify   both
 *   origin_build          ub_origin_tag under a cached pair key + ub_sec_protect(SIGNED | ORIGIN)
 *   origin_verify         ub_frame_parse + ub_sec_verify (hop tag over the hop limit) + ub_origin_tag +
 *                         constant-time compare: what the destination does
 *   origin_build_verify   both
 *   origin_forward        what a forwarder adds for an ORIGIN frame: the hop tag made again (ub_sec_protect)
 *   pair_derive           ub_origin_pair_keys: X25519 + BLAKE2b + 2 KDF subkeys, once per (entity, peer)
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <sodium.h>

#include "ub/ub_frame.h"
#include "ub/ub_origin.h"
#include "ub/ub_sec.h"

#define SAMPLES 11
#define PAYLOAD 52

static inline void sink(const void *p) { __asm__ volatile("" : : "r"(p) : "memory"); }

static double now_ns(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

static ub_sec_t sec;
static ub_frame_header_t hdr;
static uint8_t payload[PAYLOAD];
static uint8_t frame[UB_FRAME_MAX], fwd[UB_FRAME_MAX];
static size_t signed_len, origin_len;
static uint8_t k_tx[16], k_rx[16];
static uint8_t sk_a[32], sk_b[32], pk_b[32], id_a[12] = "gcs1", id_b[12] = "rmax1ob1";
static uint64_t counter = UINT64_C(0x00003A5BC0DE0001);

static void stamp(uint8_t flags) {
    counter++;
    hdr.seq = (uint32_t)counter;
    hdr.counter_hi = (uint16_t)(counter >> 32);
    hdr.flags = flags;
}

static void signed_build(void) {
    stamp(UB_FRAME_FLAG_SIGNED);
    int n = ub_sec_protect(&sec, &hdr, payload, frame, sizeof frame);
    signed_len = (size_t)n;
    sink(frame);
}

static void signed_verify(void) {
    ub_frame_header_t h;
    if (ub_frame_parse(frame, signed_len, &h) != UB_OK || ub_sec_verify(&sec, &h, frame, signed_len, NULL, 0) != UB_OK)
        abort();
    sink(&h);
}

static void signed_build_verify(void) {
    signed_build();
    signed_verify();
}

static void origin_build(void) {
    stamp(UB_FRAME_FLAG_SIGNED | UB_FRAME_FLAG_ORIGIN);
    hdr.origin_hop0 = hdr.hop_limit;
    if (ub_origin_tag(k_tx, &hdr, payload, hdr.origin_tag) != UB_OK) abort();
    int n = ub_sec_protect(&sec, &hdr, payload, frame, sizeof frame);
    origin_len = (size_t)n;
    sink(frame);
}

static void origin_verify(void) {
    ub_frame_header_t h;
    uint8_t tag[8];
    if (ub_frame_parse(frame, origin_len, &h) != UB_OK || ub_sec_verify(&sec, &h, frame, origin_len, NULL, 0) != UB_OK)
        abort();
    if (ub_origin_tag(k_rx, &h, frame + UB_FRAME_HEADER_LEN, tag) != UB_OK || sodium_memcmp(tag, h.origin_tag, 8) != 0 ||
        h.hop_limit > h.origin_hop0)
        abort();
    sink(tag);
}

static void origin_build_verify(void) {
    origin_build();
    origin_verify();
}

static void origin_forward(void) {
    ub_frame_header_t h = hdr;
    h.hop_limit = (uint8_t)(hdr.hop_limit - 1);
    if (ub_sec_protect(&sec, &h, payload, fwd, sizeof fwd) < 0) abort();
    sink(fwd);
}

static void pair_derive(void) {
    uint8_t tx[16], rx[16];
    sk_a[0]++;
    if (ub_origin_pair_keys(id_a, sk_a, id_b, pk_b, tx, rx) != UB_OK) abort();
    sink(tx);
}

typedef struct bench_case {
    const char *name;
    void (*fn)(void);
    size_t bytes;
    long iters;
    double ns[SAMPLES];
} bench_case_t;

int main(void) {
    if (sodium_init() < 0) return 1;
    uint8_t group[32];
    for (int i = 0; i < 32; i++) group[i] = (uint8_t)i;
    ub_sec_options_t o = {0};
    if (ub_sec_init(&sec, &o) != UB_OK || ub_sec_add_key(&sec, 1, group) != UB_OK) return 1;
    for (int i = 0; i < 32; i++) {
        sk_a[i] = (uint8_t)(7 * i + 1);
        sk_b[i] = (uint8_t)(11 * i + 3);
    }
    if (ub_origin_public_key(sk_b, pk_b) != UB_OK) return 1;
    uint8_t pk_a[32];
    if (ub_origin_public_key(sk_a, pk_a) != UB_OK) return 1;
    uint8_t chk_tx[16], chk_rx[16];
    if (ub_origin_pair_keys(id_a, sk_a, id_b, pk_b, k_tx, chk_rx) != UB_OK) return 1;
    if (ub_origin_pair_keys(id_b, sk_b, id_a, pk_a, chk_tx, k_rx) != UB_OK) return 1;
    if (memcmp(k_rx, k_tx, 16) != 0 || memcmp(chk_rx, chk_tx, 16) != 0) return 1; /* both ends agree */
    for (int i = 0; i < PAYLOAD; i++) payload[i] = (uint8_t)(i * 13 + 5);
    memcpy(hdr.dest_id, id_b, 12);
    memcpy(hdr.src_id, id_a, 12);
    memcpy(hdr.dir_id, "gpsOut\0\0\0\0\0\0\0\0\0", 16);
    hdr.hop_limit = 8;
    hdr.payload_size = PAYLOAD;
    hdr.fingerprint = 0x00C0FFEE;
    hdr.key_id = 1;
    origin_build(); /* a frame for the verify-only and forward cases */
    signed_build();

    bench_case_t cases[] = {
        {"signed_build", signed_build, 0, 0, {0}},
        {"signed_verify", signed_verify, 0, 0, {0}},
        {"signed_build_verify", signed_build_verify, 0, 0, {0}},
        {"origin_build", origin_build, 0, 0, {0}},
        {"origin_verify", origin_verify, 0, 0, {0}},
        {"origin_build_verify", origin_build_verify, 0, 0, {0}},
        {"origin_forward", origin_forward, 0, 0, {0}},
        {"pair_derive", pair_derive, 0, 0, {0}},
    };
    size_t n_cases = sizeof cases / sizeof cases[0];
    /* verify-only cases need their own frame in the buffer: run them right after their build */
    for (size_t c = 0; c < n_cases; c++) {
        long iters = 1;
        for (;;) { /* calibrate to >= 10 ms per batch */
            if (strcmp(cases[c].name, "signed_verify") == 0) signed_build();
            if (strcmp(cases[c].name, "origin_verify") == 0 || strcmp(cases[c].name, "origin_forward") == 0) origin_build();
            double t0 = now_ns();
            for (long i = 0; i < iters; i++) cases[c].fn();
            if (now_ns() - t0 >= 1e7) break;
            iters *= 2;
        }
        cases[c].iters = iters;
        cases[c].bytes = strncmp(cases[c].name, "signed", 6) == 0 ? signed_len
                         : strncmp(cases[c].name, "origin", 6) == 0 ? origin_len : 0;
    }
    for (int s = 0; s < SAMPLES; s++) {
        for (size_t c = 0; c < n_cases; c++) {
            if (strcmp(cases[c].name, "signed_verify") == 0) signed_build();
            if (strcmp(cases[c].name, "origin_verify") == 0 || strcmp(cases[c].name, "origin_forward") == 0) origin_build();
            double t0 = now_ns();
            for (long i = 0; i < cases[c].iters; i++) cases[c].fn();
            cases[c].ns[s] = (now_ns() - t0) / (double)cases[c].iters;
        }
    }
    for (size_t c = 0; c < n_cases; c++) {
        printf("%s\t%zu", cases[c].name, cases[c].bytes);
        for (int s = 0; s < SAMPLES; s++) printf("\t%.1f", cases[c].ns[s]);
        printf("\n");
    }
    /* RAM: what origin authentication adds per node (the Cortex-M4 build has the same struct layout rules for
     * these fixed-size members; bench/results.md states the M4 figure from arm-none-eabi-size where run). */
    printf("ram\tub_origin_t (UB_ORIGIN_PEERS=%u, UB_ORIGIN_LOCALS=%u)\t%zu\n", (unsigned)UB_ORIGIN_PEERS,
           (unsigned)UB_ORIGIN_LOCALS, sizeof(ub_origin_t));
    printf("ram\tper cached pair\t%zu\n", sizeof(ub_origin_peer_t));
    printf("ram\tper local identity\t%zu\n", sizeof(ub_origin_local_t));
    return 0;
}
