/*
 * Fuzz harness: mixed streams (issue #24 item 1), uavbus frames and foreign traffic on one byte stream.
 *
 * Input: byte 0 = largest chunk (0: one piece), byte 1 = the handler takes len / byte1 of each run (0: all),
 * then the stream. The stream is fed to a decoder with a foreign-traffic handler, in chunks cut by the
 * input, and again in one piece to a decoder without a handler. Properties checked (a failure aborts):
 *  - after every feed: bytes_in == bytes_ok + foreign_bytes + garbage_bytes + pending, and garbage is 0;
 *  - the foreign runs and the delivered frames, appended in the order the decoder called back, rebuild
 *    the stream exactly up to the bytes still held: every byte handed on once, in order, and a frame's
 *    bytes never reach the handler;
 *  - foreign_refused is exactly what the handler did not take;
 *  - the handler changes where bytes go, not what is a frame: the decoder without a handler delivers the
 *    same frames and counts the foreign bytes as garbage;
 *  - the same stream, in the same cuts, read as a compact-encoded stream with a handler (its packets are
 *    COBS-delimited, and a packet glued after foreign bytes is searched for): the same accounting invariant,
 *    garbage 0; and read by the legacy datalink envelope's parser: every byte a message's, noise, or held.
 */
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "fuzz_util.h"
#include "ub/ub_compact.h"
#include "ub/ub_frame.h"
#include "ub/ub_legacy.h"

#define MAX_INPUT (1u << 16)

typedef struct rebuild {
    uint8_t out[MAX_INPUT];
    size_t len;
    size_t divisor;
    uint64_t refused;
    uint64_t frames;
    int overflow;
} rebuild_t;

static rebuild_t g_rb; /* a harness is a program: its large state is static (fuzz_util.h) */

static void append(rebuild_t *rb, const uint8_t *p, size_t n) {
    if (rb->len + n > sizeof rb->out) {
        rb->overflow = 1;
        return;
    }
    memcpy(rb->out + rb->len, p, n);
    rb->len += n;
}

static void on_frame(void *user, const ub_frame_header_t *h, const uint8_t *frame, size_t len) {
    (void)h;
    rebuild_t *rb = user;
    rb->frames++;
    append(rb, frame, len);
}

static size_t on_foreign(void *user, const uint8_t *run, size_t len) {
    rebuild_t *rb = user;
    FUZZ_CHECK(len > 0, "an empty run was handed on");
    append(rb, run, len);
    size_t took = rb->divisor == 0 ? len : len / rb->divisor;
    rb->refused += len - took;
    return took;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size < 2 || size - 2 > MAX_INPUT) return 0;
    size_t max_chunk = data[0];
    rebuild_t *rb = &g_rb;
    rb->len = 0;
    rb->divisor = data[1];
    rb->refused = 0;
    rb->frames = 0;
    rb->overflow = 0;
    const uint8_t *s = data + 2;
    size_t n = size - 2;

    static ub_decoder_t d, plain;
    ub_decoder_init(&d);
    ub_decoder_set_foreign(&d, on_foreign, rb);
    size_t off = 0, k = 0;
    while (off < n) {
        /* Chunk sizes vary with the stream itself, so the fuzzer explores cuts without more input. */
        size_t c = max_chunk == 0 ? n - off : 1 + (s[k++ % n] % max_chunk);
        if (c > n - off) c = n - off;
        (void)ub_decoder_feed(&d, s + off, c, on_frame, rb);
        off += c;
        const ub_decoder_stats_t *st = &d.stats;
        FUZZ_CHECK(st->bytes_in == st->bytes_ok + st->foreign_bytes + st->garbage_bytes + ub_decoder_pending(&d),
                   "in %llu ok %llu foreign %llu garbage %llu pending %zu", (unsigned long long)st->bytes_in,
                   (unsigned long long)st->bytes_ok, (unsigned long long)st->foreign_bytes,
                   (unsigned long long)st->garbage_bytes, ub_decoder_pending(&d));
        FUZZ_CHECK(st->garbage_bytes == 0, "garbage %llu with a handler", (unsigned long long)st->garbage_bytes);
    }
    FUZZ_CHECK(!rb->overflow, "handed on more bytes than were fed");
    size_t pending = ub_decoder_pending(&d);
    FUZZ_CHECK(rb->len + pending == n, "rebuilt %zu + held %zu != fed %zu", rb->len, pending, n);
    FUZZ_CHECK(memcmp(rb->out, s, rb->len) == 0, "frames and foreign runs do not rebuild the stream in order");
    FUZZ_CHECK(d.stats.foreign_refused == rb->refused, "refused %llu, handler says %llu",
               (unsigned long long)d.stats.foreign_refused, (unsigned long long)rb->refused);
    FUZZ_CHECK(d.stats.frames_ok == rb->frames, "frames counted %llu, delivered %llu",
               (unsigned long long)d.stats.frames_ok, (unsigned long long)rb->frames);

    ub_decoder_init(&plain);
    (void)ub_decoder_feed(&plain, s, n, NULL, NULL);
    FUZZ_CHECK(plain.stats.frames_ok == d.stats.frames_ok, "frames %llu without a handler, %llu with",
               (unsigned long long)plain.stats.frames_ok, (unsigned long long)d.stats.frames_ok);
    FUZZ_CHECK(plain.stats.garbage_bytes == d.stats.foreign_bytes && ub_decoder_pending(&plain) == pending,
               "garbage %llu without a handler, foreign %llu with", (unsigned long long)plain.stats.garbage_bytes,
               (unsigned long long)d.stats.foreign_bytes);

    /* A compact stream and the legacy envelope, in the same cuts. */
    static ub_compact_t cs;
    static ub_decoder_t cd;
    static ub_legacy_t lp;
    ub_compact_init(&cs, NULL, 1, NULL);
    ub_decoder_init(&cd);
    ub_decoder_set_foreign(&cd, on_foreign, rb);
    ub_legacy_init(&lp);
    rb->len = 0;
    for (off = 0, k = 0; off < n;) {
        size_t c = max_chunk == 0 ? n - off : 1 + (s[k++ % n] % max_chunk);
        if (c > n - off) c = n - off;
        (void)ub_compact_feed(&cs, &cd, s + off, c, 0, NULL, NULL, NULL);
        FUZZ_CHECK(ub_legacy_feed(&lp, s + off, c, NULL, NULL) >= 0, "legacy: feed refused");
        off += c;
        const ub_decoder_stats_t *st = &cd.stats;
        FUZZ_CHECK(st->bytes_in == st->bytes_ok + st->foreign_bytes + st->garbage_bytes + ub_decoder_pending(&cd),
                   "compact: in %llu ok %llu foreign %llu garbage %llu pending %zu", (unsigned long long)st->bytes_in,
                   (unsigned long long)st->bytes_ok, (unsigned long long)st->foreign_bytes,
                   (unsigned long long)st->garbage_bytes, ub_decoder_pending(&cd));
        FUZZ_CHECK(st->garbage_bytes == 0, "compact: garbage %llu with a handler", (unsigned long long)st->garbage_bytes);
        const ub_legacy_stats_t *ls = &lp.stats;
        FUZZ_CHECK(ls->bytes_in == ls->message_bytes + ls->noise_bytes + ub_legacy_pending(&lp),
                   "legacy: in %llu messages %llu noise %llu pending %zu", (unsigned long long)ls->bytes_in,
                   (unsigned long long)ls->message_bytes, (unsigned long long)ls->noise_bytes, ub_legacy_pending(&lp));
    }
    FUZZ_CHECK(cd.stats.foreign_bytes == rb->len || rb->overflow, "compact: handed on %zu, counted %llu", rb->len,
               (unsigned long long)cd.stats.foreign_bytes);
    return 0;
}

int LLVMFuzzerInitialize(int *argc, char ***argv) {
    (void)argc;
    (void)argv;
    return 0;
}

/* Seeds: frames between NMEA sentences, binary noise with false sync pairs, a cut frame, in several cuts. */
void ub_fuzz_write_seeds(const char *dir) {
    static uint8_t buf[4096];
    static const char *const sentences[] = {
        "$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47\r\n",
        "$GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W*6A\r\n",
        "$GPVTG,054.7,T,034.4,M,005.5,N,010.2,K*48\r\n",
        "$GPGSA,A,3,04,05,,09,12,,,24,,,,,2.5,1.3,2.1*39\r\n",
    };
    for (int seed = 0; seed < 6; seed++) {
        size_t n = 0;
        buf[n++] = (uint8_t)(seed * 37); /* largest chunk */
        buf[n++] = (uint8_t)(seed % 3);  /* refusal divisor */
        for (int i = 0; i < 6; i++) {
            const char *text = sentences[(seed + i) % 4];
            memcpy(buf + n, text, strlen(text));
            n += strlen(text);
            uint8_t *f = buf + n;
            ub_frame_header_t h = {.hop_limit = 1, .payload_size = (uint16_t)(8 * i), .seq = (uint32_t)i};
            memset(f + UB_FRAME_HEADER_LEN, 0x11 * i, h.payload_size);
            int len = ub_frame_finish(f, sizeof buf - n, &h);
            if (len < 0) return;
            if (seed == 4 && i == 2) len -= 5; /* a cut frame, the next one still found */
            n += (size_t)len;
            if (seed == 5) { /* noise with a false sync pair */
                static const uint8_t noise[] = {0x00, UB_SYNC0, UB_SYNC1, 0x42, 0xFF, UB_SYNC0};
                memcpy(buf + n, noise, sizeof noise);
                n += sizeof noise;
            }
        }
        char path[512];
        snprintf(path, sizeof path, "%s/mixed_%d", dir, seed);
        FILE *out = fopen(path, "wb");
        if (out == NULL) return;
        fwrite(buf, 1, n, out);
        fclose(out);
    }
}
