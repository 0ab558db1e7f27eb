/* Quick timing of the frame codec: ns per frame for build (ub_frame_finish), parse
 * (ub_frame_parse, header decoded) and the streaming decoder, for the 88/112/123-byte
 * frames of the MAVLink comparison (payloads of ATTITUDE, GPS_RAW_INT, HIGHRES_IMU),
 * plus the CRC alone on both paths. Not a test; the benchmark issue does the careful
 * comparison. Built at -O2 by runtime_c/tests/frame.cmake:
 *
 *     ub_frame_bench [iterations per run, default 2000000] [runs, default 7]
 *
 * Prints median [min - max] over the runs. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ub/ub_frame.h"
#include "codec/ub_crc32c_impl.h"

#define MAX_RUNS 31
#define STREAM_FRAMES 256

typedef struct bench_ctx {
    uint8_t frame[UB_FRAME_MAX];
    size_t frame_len;
    ub_frame_header_t header;
    uint8_t stream[STREAM_FRAMES * 128];
    size_t stream_len;
    uint64_t sink; /* results fold in here so no call can be optimised away */
} bench_ctx_t;

typedef double (*bench_fn)(bench_ctx_t *ctx, long iterations);

static double now_ns(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

static double bench_build(bench_ctx_t *c, long n) {
    double t0 = now_ns();
    for (long i = 0; i < n; i++) {
        c->header.seq = (uint32_t)i;
        int len = ub_frame_finish(c->frame, sizeof c->frame, &c->header);
        c->sink += (uint64_t)len + c->frame[UB_FRAME_OFF_MSG_CRC];
    }
    return (now_ns() - t0) / (double)n;
}

static double bench_parse(bench_ctx_t *c, long n) {
    ub_frame_header_t h;
    double t0 = now_ns();
    for (long i = 0; i < n; i++) {
        int err = ub_frame_parse(c->frame, c->frame_len, &h);
        c->sink += (uint64_t)(err + 1) + h.seq;
    }
    return (now_ns() - t0) / (double)n;
}

static void count_frame(void *user, const ub_frame_header_t *h, const uint8_t *frame, size_t len) {
    (void)frame;
    *(uint64_t *)user += h->seq + len;
}

static double bench_decoder_whole(bench_ctx_t *c, long n) {
    ub_decoder_t dec;
    ub_decoder_init(&dec);
    long feeds = n / STREAM_FRAMES + 1;
    double t0 = now_ns();
    for (long i = 0; i < feeds; i++) c->sink += ub_decoder_feed(&dec, c->stream, c->stream_len, count_frame, &c->sink);
    return (now_ns() - t0) / (double)(feeds * STREAM_FRAMES);
}

/* 64-byte reads: most frames straddle a read, so this exercises the carried path. */
static double bench_decoder_chunked(bench_ctx_t *c, long n) {
    ub_decoder_t dec;
    ub_decoder_init(&dec);
    long feeds = n / STREAM_FRAMES + 1;
    double t0 = now_ns();
    for (long i = 0; i < feeds; i++)
        for (size_t off = 0; off < c->stream_len; off += 64) {
            size_t k = c->stream_len - off < 64 ? c->stream_len - off : 64;
            c->sink += ub_decoder_feed(&dec, c->stream + off, k, count_frame, &c->sink);
        }
    return (now_ns() - t0) / (double)(feeds * STREAM_FRAMES);
}

static double bench_crc_hw(bench_ctx_t *c, long n) {
    double t0 = now_ns();
    for (long i = 0; i < n; i++) c->sink += ub_crc32c_update_hw((uint32_t)i, c->frame + 4, c->frame_len - 4);
    return (now_ns() - t0) / (double)n;
}

static double bench_crc_table(bench_ctx_t *c, long n) {
    double t0 = now_ns();
    for (long i = 0; i < n; i++) c->sink += ub_crc32c_update_portable((uint32_t)i, c->frame + 4, c->frame_len - 4);
    return (now_ns() - t0) / (double)n;
}

static int compare_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void prepare(bench_ctx_t *c, uint16_t payload_size) {
    memset(c, 0, sizeof *c);
    memcpy(c->header.dir_id, "onboardSboardSet", UB_DIR_ID_LEN);
    memcpy(c->header.dest_id, "gcs1\0\0\0\0\0\0\0\0", UB_ENTITY_ID_LEN);
    memcpy(c->header.src_id, "rmax1ob1\0\0\0\0", UB_ENTITY_ID_LEN);
    c->header.admin = UB_ADMIN_DATA;
    c->header.hop_limit = UB_DEFAULT_HOP_LIMIT;
    c->header.payload_size = payload_size;
    c->header.fingerprint = 0x1A2B3C4Du;
    for (uint16_t i = 0; i < payload_size; i++) c->frame[UB_FRAME_HEADER_LEN + i] = (uint8_t)(i * 37 + 11);
    int len = ub_frame_finish(c->frame, sizeof c->frame, &c->header);
    if (len < 0) {
        fprintf(stderr, "ub_frame_bench: ub_frame_finish: %s\n", ub_strerror(len));
        exit(1);
    }
    c->frame_len = (size_t)len;
    for (int i = 0; i < STREAM_FRAMES; i++) {
        memcpy(c->stream + c->stream_len, c->frame, c->frame_len);
        c->stream_len += c->frame_len;
    }
}

int main(int argc, char **argv) {
    long iterations = argc > 1 ? atol(argv[1]) : 2000000;
    int runs = argc > 2 ? atoi(argv[2]) : 7;
    if (iterations < 1 || runs < 1 || runs > MAX_RUNS) {
        fprintf(stderr, "usage: %s [iterations >= 1] [runs 1..%d]\n", argv[0], MAX_RUNS);
        return 2;
    }
    static const struct {
        const char *name;
        bench_fn fn;
    } cases[] = {
        {"build   ub_frame_finish", bench_build},
        {"parse   ub_frame_parse", bench_parse},
        {"decode  feed, 256 frames/call", bench_decoder_whole},
        {"decode  feed, 64-byte reads", bench_decoder_chunked},
        {"crc32c  hardware, frame-4 B", bench_crc_hw},
        {"crc32c  table,    frame-4 B", bench_crc_table},
    };
    static const uint16_t payloads[] = {24, 48, 59};
    bench_ctx_t *ctx = malloc(sizeof *ctx);
    if (ctx == NULL) return 1;
    printf("uavbus frame codec, ns/frame, median [min - max] of %d runs x %ld; CRC hardware path: %s\n", runs,
           iterations, ub_crc32c_hw_available() ? "yes" : "no");
    printf("%-32s %22s %22s %22s\n", "case", "88 B", "112 B", "123 B");
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        printf("%-32s", cases[k].name);
        for (size_t p = 0; p < sizeof payloads / sizeof payloads[0]; p++) {
            prepare(ctx, payloads[p]);
            double t[MAX_RUNS];
            (void)cases[k].fn(ctx, iterations / 10 + 1); /* warm-up */
            for (int r = 0; r < runs; r++) t[r] = cases[k].fn(ctx, iterations);
            qsort(t, (size_t)runs, sizeof t[0], compare_double);
            char cell[64];
            snprintf(cell, sizeof cell, "%.1f [%.1f - %.1f]", t[runs / 2], t[0], t[runs - 1]);
            printf(" %22s", cell);
        }
        printf("\n");
    }
    printf("(sink %llu)\n", (unsigned long long)(ctx->sink & 0xFF));
    free(ctx);
    return 0;
}
