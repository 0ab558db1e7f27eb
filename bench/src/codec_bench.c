/*
 * C codecs side by side (bench figure 1): uavbus generated code + frame layer vs MAVLink v2 C
 * (mavgen from pymavlink's common.xml) and LCM C (lcm-gen), for ATTITUDE, GPS_RAW_INT and
 * HIGHRES_IMU, plus the memcpy and checksum floors. Built by bench/run.sh at -O2.
 *
 *   codec_bench            timing: every case calibrated to ~10 ms batches, SAMPLES samples taken
 *                          round-robin across all cases (drift hits every case alike);
 *                          prints "case<TAB>bytes<TAB>ns per op (one per sample)..."
 *   codec_bench callgrind  runs each case BENCH_ITERS times between CALLGRIND_ZERO_STATS and
 *                          CALLGRIND_DUMP_STATS_AT(case) (run under valgrind --tool=callgrind);
 *                          bench/tables.py divides the dumped Ir by BENCH_ITERS.
 *
 * Every iteration changes the input (a timestamp field += 1) and sinks the output through an
 * asm barrier, so no work is hoisted or deleted.
 *
 * Signing (bench figure 1b): uavbus SIGNED (SipHash-2-4, 64-bit tag) and ENCRYPTED (XChaCha20-Poly1305)
 * frames against MAVLink 2 signing (SHA-256 truncated to 48 bits) from the same mavgen headers:
 * the tag alone (ub_sec_protect vs mavlink_sign_packet; ub_sec_verify + replay window vs
 * mavlink_signature_check) and the whole signed frame (pack + sign; parse + verify + unpack); and the
 * floor of the tag: libsodium's SipHash-2-4 alone over the same tag input.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <valgrind/callgrind.h>

#include "benchcat.h"
#include "common/mavlink.h"
#include "benchlcm_attitude_t.h"
#include "benchlcm_gps_raw_int_t.h"
#include "benchlcm_highres_imu_t.h"
#include "ub/ub_frame.h"
#include "ub/ub_sec.h"
/* make bench BENCH_BASE=REF builds this file against an earlier runtime too (figure 1 before and after a
 * change): a case whose API that runtime lacks is left out there. Detected from the headers present, so no
 * flag has to be kept in step with the runtime's history. */
#if __has_include("ub/ub_origin.h")
#include "ub/ub_origin.h"
#define BENCH_HAS_ORIGIN 1
#else
#define BENCH_HAS_ORIGIN 0
#endif
#include <sodium.h> /* only for the tag's floor row (SipHash-2-4 alone); uavbus itself uses ub_sec */

benchAttitude_t benchAttitude;
benchGpsRawInt_t benchGpsRawInt;
benchHighresImu_t benchHighresImu;
benchBlob64_t benchBlob64, benchBlob64Echo;

#define SAMPLES 11
#define BENCH_ITERS 20000

static inline void sink(const void *p) { __asm__ volatile("" : : "r"(p) : "memory"); }
static volatile size_t runtime_size; /* memcpy floor: size known only at run time */

static double now_ns(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

static uint8_t frame_buf[UB_FRAME_MAX];
static ub_frame_header_t hdr;
static ub_decoder_t dec;
/* Per-message header templates (a row's state in the runtime). BENCH_BASE may name a runtime from before
 * templates: there the build case is ub_frame_finish, as in the untemplated case. */
#ifdef UB_FRAME_TPL
static ub_frame_tpl_t tpl[3];
#define BUILD_FROM_TEMPLATE(M, p) ub_frame_tpl_finish(&tpl[M], frame_buf, sizeof frame_buf, (uint16_t)(p), hdr.seq)
#define PRIME_TEMPLATE(M)                                                                                   \
    do {                                                                                                    \
        if (ub_frame_tpl_init(&tpl[M], &hdr) != UB_OK) abort();                                             \
    } while (0)
#else
#define BUILD_FROM_TEMPLATE(M, p) (hdr.payload_size = (uint16_t)(p), ub_frame_finish(frame_buf, sizeof frame_buf, &hdr))
#define PRIME_TEMPLATE(M) ((void)0)
#endif
/* The same decoder with a foreign-traffic handler set (issue #24: mixed streams), fed the same pure uavbus
 * stream: what a link that may carry a GPS or a legacy datalink pays when it carries only uavbus. */
static ub_decoder_t dec_foreign;
static uint64_t foreign_seen;
#ifdef UB_DECODER_FOREIGN
static size_t on_foreign(void *user, const uint8_t *run, size_t len) {
    (void)user;
    (void)run;
    foreign_seen += len; /* a pure stream has none: main() checks */
    return len;
}
#endif
static uint8_t ub_frame_bytes[3][UB_FRAME_MAX];
static size_t ub_frame_len[3];
static uint8_t mav_frame_bytes[3][MAVLINK_MAX_PACKET_LEN];
static size_t mav_frame_len[3];
static uint8_t lcm_bytes[3][128];
static int lcm_len[3];
static uint8_t payload_src[128], payload_dst[128];

/* ---- signing state ---- */
static ub_sec_t sec;                      /* key id 1 */
static ub_frame_header_t shdr;            /* SIGNED header template; the AEAD cases flip the flag */
static ub_sec_window_t win;
static uint8_t plain_buf[UB_MAX_PAYLOAD];
static uint8_t ub_signed_bytes[3][UB_FRAME_MAX], ub_aead_bytes[3][UB_FRAME_MAX];
static size_t ub_signed_len[3], ub_aead_len[3];
static ub_frame_header_t ub_signed_hdr[3]; /* parsed from ub_signed_bytes (verify cases) */
static ub_frame_header_t ub_sign_hdr[3];   /* what the sign cases sign (their seq moves) */
static mavlink_signing_t mav_signing_tx, mav_signing_rx;
static mavlink_signing_streams_t mav_streams;
static uint8_t mav_signed_bytes[3][MAVLINK_MAX_PACKET_LEN];
static size_t mav_signed_len[3];
static mavlink_message_t mav_signed_msg[3];
static uint8_t mav_sig[MAVLINK_SIGNATURE_BLOCK_LEN];
#if BENCH_HAS_ORIGIN
/* Origin authentication (issue 23): SIGNED | ORIGIN frames under one cached pairwise key (both ends' view). */
static uint8_t origin_key[UB_ORIGIN_KEY_LEN];
static uint8_t ub_origin_bytes[3][UB_FRAME_MAX];
static size_t ub_origin_len[3];
#endif

/* One verified SIGNED/ENCRYPTED frame from the decoder: tag, replay window (reset, so every frame is new,
 * as MAVLink's stream table is below), then the payload unpacked by the caller's function. */
static const uint8_t *verified_payload(const ub_frame_header_t *h, const uint8_t *f, size_t len) {
    if (ub_sec_verify(&sec, h, f, len, plain_buf, sizeof plain_buf) != UB_OK) abort();
    win.highest = 0;
    win.seen = 0;
    uint64_t c = ub_frame_counter(h);
    if (ub_sec_window_check(&win, c) != UB_SEC_WINDOW_NEW) abort();
    ub_sec_window_accept(&win, c);
    return h->flags == UB_FRAME_FLAG_ENCRYPTED ? plain_buf : f + UB_FRAME_HEADER_LEN;
}

/* ---- per-message cases, one macro instance per message ----
 * M: index; UT: uavbus struct; PK/UN: generated pack/unpack; INST: instance; MT: mavlink struct;
 * MN: mavlink message name (lower case); LT: lcm type; TF: the timestamp field changed per iteration. */
#define MESSAGE_CASES(M, UT, PK, UN, INST, MT, MN, LT, TF)                                                  \
    static UT ub_obj_##M, ub_out_##M;                                                                       \
    static MT mav_obj_##M, mav_out_##M;                                                                     \
    static LT lcm_obj_##M, lcm_out_##M;                                                                     \
    static void ub_build_finish_##M(long n) {                                                                      \
        for (long i = 0; i < n; i++) {                                                                      \
            ub_obj_##M.TF++;                                                                                \
            int p = PK(&ub_obj_##M, frame_buf + UB_FRAME_HEADER_LEN, UB_MAX_PAYLOAD);                       \
            hdr.payload_size = (uint16_t)p;                                                                 \
            hdr.seq++;                                                                                      \
            int len = ub_frame_finish(frame_buf, sizeof frame_buf, &hdr);                                   \
            sink(frame_buf);                                                                                \
            if (len < 0) abort();                                                                           \
        }                                                                                                   \
    }                                                                                                       \
    static void ub_build_##M(long n) { /* as a row builds: pack + its header template (ub_frame_tpl_t) */   \
        for (long i = 0; i < n; i++) {                                                                      \
            ub_obj_##M.TF++;                                                                                \
            int p = PK(&ub_obj_##M, frame_buf + UB_FRAME_HEADER_LEN, UB_MAX_PAYLOAD);                       \
            hdr.seq++;                                                                                      \
            int len = BUILD_FROM_TEMPLATE(M, p);                                                            \
            sink(frame_buf);                                                                                \
            if (p < 0 || len < 0) abort();                                                                  \
        }                                                                                                   \
    }                                                                                                       \
    static void on_frame_##M(void *user, const ub_frame_header_t *h, const uint8_t *f, size_t len) {        \
        (void)user;                                                                                         \
        if (UN(&ub_out_##M, f + UB_FRAME_HEADER_LEN, h->payload_size) < 0 || len == 0) abort();             \
        sink(&ub_out_##M);                                                                                  \
    }                                                                                                       \
    static void ub_parse_##M(long n) {                                                                      \
        for (long i = 0; i < n; i++) {                                                                      \
            sink(ub_frame_bytes[M]);                                                                        \
            (void)ub_decoder_feed(&dec, ub_frame_bytes[M], ub_frame_len[M], on_frame_##M, NULL);            \
        }                                                                                                   \
    }                                                                                                       \
    static void ub_parse_foreign_##M(long n) {                                                              \
        for (long i = 0; i < n; i++) {                                                                      \
            sink(ub_frame_bytes[M]);                                                                        \
            (void)ub_decoder_feed(&dec_foreign, ub_frame_bytes[M], ub_frame_len[M], on_frame_##M, NULL);    \
        }                                                                                                   \
    }                                                                                                       \
    static void ub_pack_##M(long n) {                                                                       \
        for (long i = 0; i < n; i++) {                                                                      \
            ub_obj_##M.TF++;                                                                                \
            if (PK(&ub_obj_##M, payload_dst, sizeof payload_dst) < 0) abort();                              \
            sink(payload_dst);                                                                              \
        }                                                                                                   \
    }                                                                                                       \
    static void ub_unpack_##M(long n) {                                                                     \
        for (long i = 0; i < n; i++) {                                                                      \
            sink(ub_frame_bytes[M]);                                                                        \
            if (UN(&ub_out_##M, ub_frame_bytes[M] + UB_FRAME_HEADER_LEN, ub_frame_len[M] - UB_FRAME_HEADER_LEN) < 0) \
                abort();                                                                                    \
            sink(&ub_out_##M);                                                                              \
        }                                                                                                   \
    }                                                                                                       \
    static void mav_pack_##M(long n) {                                                                      \
        mavlink_message_t msg;                                                                              \
        for (long i = 0; i < n; i++) {                                                                      \
            mav_obj_##M.TF++;                                                                               \
            mavlink_msg_##MN##_encode(1, 1, &msg, &mav_obj_##M);                                            \
            sink(&msg);                                                                                     \
        }                                                                                                   \
    }                                                                                                       \
    static void mav_pack_tobuf_##M(long n) {                                                                \
        mavlink_message_t msg;                                                                              \
        uint8_t out[MAVLINK_MAX_PACKET_LEN];                                                                \
        for (long i = 0; i < n; i++) {                                                                      \
            mav_obj_##M.TF++;                                                                               \
            mavlink_msg_##MN##_encode(1, 1, &msg, &mav_obj_##M);                                            \
            uint16_t len = mavlink_msg_to_send_buffer(out, &msg);                                           \
            sink(out);                                                                                      \
            if (len == 0) abort();                                                                          \
        }                                                                                                   \
    }                                                                                                       \
    static void mav_parse_##M(long n) {                                                                     \
        mavlink_message_t msg;                                                                              \
        mavlink_status_t st;                                                                                \
        for (long i = 0; i < n; i++) {                                                                      \
            sink(mav_frame_bytes[M]);                                                                       \
            int got = 0;                                                                                    \
            for (size_t b = 0; b < mav_frame_len[M]; b++)                                                   \
                if (mavlink_parse_char(MAVLINK_COMM_0, mav_frame_bytes[M][b], &msg, &st)) got = 1;          \
            if (!got) abort();                                                                              \
            mavlink_msg_##MN##_decode(&msg, &mav_out_##M);                                                  \
            sink(&mav_out_##M);                                                                             \
        }                                                                                                   \
    }                                                                                                       \
    static void lcm_encode_##M(long n) {                                                                    \
        for (long i = 0; i < n; i++) {                                                                      \
            lcm_obj_##M.TF++;                                                                               \
            if (LT##_encode(payload_dst, 0, sizeof payload_dst, &lcm_obj_##M) < 0) abort();                 \
            sink(payload_dst);                                                                              \
        }                                                                                                   \
    }                                                                                                       \
    static void lcm_decode_##M(long n) {                                                                    \
        for (long i = 0; i < n; i++) {                                                                      \
            sink(lcm_bytes[M]);                                                                             \
            if (LT##_decode(lcm_bytes[M], 0, lcm_len[M], &lcm_out_##M) < 0) abort();                        \
            sink(&lcm_out_##M);                                                                             \
        }                                                                                                   \
    }                                                                                                       \
    static void floor_memcpy_##M(long n) {                                                                  \
        size_t sz = sizeof(MT) + runtime_size;                                                              \
        for (long i = 0; i < n; i++) {                                                                      \
            sink(payload_src);                                                                              \
            memcpy(payload_dst, payload_src, sz);                                                           \
            sink(payload_dst);                                                                              \
        }                                                                                                   \
    }                                                                                                       \
    static void floor_crc32c_##M(long n) {                                                                  \
        for (long i = 0; i < n; i++) {                                                                      \
            sink(ub_frame_bytes[M]);                                                                        \
            uint32_t c = ub_crc32c(ub_frame_bytes[M] + 4, ub_frame_len[M] - 4);                             \
            sink(&c);                                                                                       \
        }                                                                                                   \
    }                                                                                                       \
    static void floor_x25_##M(long n) {                                                                     \
        for (long i = 0; i < n; i++) {                                                                      \
            sink(mav_frame_bytes[M]);                                                                       \
            uint16_t c = crc_calculate(mav_frame_bytes[M] + 1, (uint16_t)(mav_frame_len[M] - 3));           \
            sink(&c);                                                                                       \
        }                                                                                                   \
    }                                                                                                       \
    static void setup_##M(void) {                                                                           \
        memset(&ub_obj_##M, 0x11, sizeof ub_obj_##M);                                                      \
        memset(&mav_obj_##M, 0x11, sizeof mav_obj_##M);                                                    \
        memset(&lcm_obj_##M, 0x11, sizeof lcm_obj_##M);                                                    \
        memcpy(hdr.dir_id, benchcat_catalogue.instances[INST].id, UB_DIR_ID_LEN);                           \
        hdr.fingerprint = benchcat_catalogue.instances[INST].type->fingerprint;                             \
        int p = PK(&ub_obj_##M, ub_frame_bytes[M] + UB_FRAME_HEADER_LEN, UB_MAX_PAYLOAD);                   \
        hdr.payload_size = (uint16_t)p;                                                                     \
        int fl = ub_frame_finish(ub_frame_bytes[M], UB_FRAME_MAX, &hdr);                                    \
        if (p < 0 || fl < 0) abort();                                                                       \
        ub_frame_len[M] = (size_t)fl;                                                                       \
        PRIME_TEMPLATE(M);                                                                                  \
        mavlink_message_t msg;                                                                              \
        mavlink_msg_##MN##_encode(1, 1, &msg, &mav_obj_##M);                                                \
        mav_frame_len[M] = mavlink_msg_to_send_buffer(mav_frame_bytes[M], &msg);                            \
        lcm_len[M] = LT##_encode(lcm_bytes[M], 0, sizeof lcm_bytes[M], &lcm_obj_##M);                       \
        if (lcm_len[M] < 0) abort();                                                                        \
    }

MESSAGE_CASES(0, benchAttitude_t, benchcat_pack_benchAttitude, benchcat_unpack_benchAttitude,
              benchcat_INST_benchAttitude, mavlink_attitude_t, attitude, benchlcm_attitude_t, time_boot_ms)
MESSAGE_CASES(1, benchGpsRawInt_t, benchcat_pack_benchGpsRawInt, benchcat_unpack_benchGpsRawInt,
              benchcat_INST_benchGpsRawInt, mavlink_gps_raw_int_t, gps_raw_int, benchlcm_gps_raw_int_t, time_usec)
MESSAGE_CASES(2, benchHighresImu_t, benchcat_pack_benchHighresImu, benchcat_unpack_benchHighresImu,
              benchcat_INST_benchHighresImu, mavlink_highres_imu_t, highres_imu, benchlcm_highres_imu_t, time_usec)


/* ---- signing cases, one instance per message (M, the uavbus/MAVLink types and functions as above) ---- */
#define SIGN_CASES(M, UT, PK, UN, MT, MN, TF)                                                               \
    static void ub_sign_##M(long n) { /* tag + trailer + checks over a packed payload already in place */   \
        for (long i = 0; i < n; i++) {                                                                      \
            ub_sign_hdr[M].seq++;                                                                           \
            int len = ub_sec_protect(&sec, &ub_sign_hdr[M], frame_buf + UB_FRAME_HEADER_LEN, frame_buf,     \
                                     sizeof frame_buf);                                                     \
            sink(frame_buf);                                                                                \
            if (len < 0) abort();                                                                           \
        }                                                                                                   \
    }                                                                                                       \
    static void ub_verify_##M(long n) { /* tag check + replay window of a parsed frame */                   \
        for (long i = 0; i < n; i++) {                                                                      \
            sink(ub_signed_bytes[M]);                                                                       \
            sink(verified_payload(&ub_signed_hdr[M], ub_signed_bytes[M], ub_signed_len[M]));                \
        }                                                                                                   \
    }                                                                                                       \
    static void mav_sign_##M(long n) {                                                                      \
        const uint8_t *b = mav_frame_bytes[M];                                                              \
        size_t pl = mav_frame_len[M] - MAVLINK_NUM_NON_PAYLOAD_BYTES;                                       \
        for (long i = 0; i < n; i++) {                                                                      \
            sink(b);                                                                                        \
            if (mavlink_sign_packet(&mav_signing_tx, mav_sig, b, MAVLINK_CORE_HEADER_LEN + 1,               \
                                    b + MAVLINK_CORE_HEADER_LEN + 1, (uint8_t)pl,                           \
                                    b + MAVLINK_CORE_HEADER_LEN + 1 + pl) == 0)                             \
                abort();                                                                                    \
            sink(mav_sig);                                                                                  \
        }                                                                                                   \
    }                                                                                                       \
    static void mav_check_##M(long n) {                                                                     \
        for (long i = 0; i < n; i++) {                                                                      \
            sink(&mav_signed_msg[M]);                                                                       \
            mav_streams.num_signing_streams = 0; /* every check is a new stream: it passes */             \
            if (!mavlink_signature_check(&mav_signing_rx, &mav_streams, &mav_signed_msg[M])) abort();        \
        }                                                                                                   \
    }                                                                                                       \
    static void protected_build_##M(long n, uint8_t flags) { /* pack + SIGNED or ENCRYPTED frame */        \
        for (long i = 0; i < n; i++) {                                                                      \
            ub_obj_##M.TF++;                                                                                \
            int p = PK(&ub_obj_##M, frame_buf + UB_FRAME_HEADER_LEN, UB_MAX_PAYLOAD);                       \
            shdr.payload_size = (uint16_t)p;                                                                \
            shdr.flags = flags;                                                                             \
            shdr.seq++;                                                                                     \
            int len = ub_sec_protect(&sec, &shdr, frame_buf + UB_FRAME_HEADER_LEN, frame_buf, sizeof frame_buf); \
            sink(frame_buf);                                                                                \
            if (len < 0) abort();                                                                           \
        }                                                                                                   \
    }                                                                                                       \
    static void ub_signed_build_##M(long n) { protected_build_##M(n, UB_FRAME_FLAG_SIGNED); }               \
    static void ub_aead_build_##M(long n) { protected_build_##M(n, UB_FRAME_FLAG_ENCRYPTED); }              \
    static void on_signed_##M(void *user, const ub_frame_header_t *h, const uint8_t *f, size_t len) {       \
        (void)user;                                                                                         \
        if (UN(&ub_out_##M, verified_payload(h, f, len), h->payload_size) < 0) abort();                     \
        sink(&ub_out_##M);                                                                                  \
    }                                                                                                       \
    static void protected_parse_##M(long n, const uint8_t *bytes, size_t len) { /* feed + verify + unpack */ \
        for (long i = 0; i < n; i++) {                                                                      \
            sink(bytes);                                                                                    \
            if (ub_decoder_feed(&dec, bytes, len, on_signed_##M, NULL) != 1) abort();                       \
        }                                                                                                   \
    }                                                                                                       \
    static void ub_signed_parse_##M(long n) { protected_parse_##M(n, ub_signed_bytes[M], ub_signed_len[M]); } \
    static void ub_aead_parse_##M(long n) { protected_parse_##M(n, ub_aead_bytes[M], ub_aead_len[M]); }      \
    static void mav_signed_pack_##M(long n) {                                                               \
        mavlink_message_t msg;                                                                              \
        uint8_t out[MAVLINK_MAX_PACKET_LEN];                                                                \
        for (long i = 0; i < n; i++) {                                                                      \
            mav_obj_##M.TF++;                                                                               \
            mavlink_msg_##MN##_encode_chan(1, 1, MAVLINK_COMM_1, &msg, &mav_obj_##M);                       \
            uint16_t len = mavlink_msg_to_send_buffer(out, &msg);                                           \
            sink(out);                                                                                      \
            if (len == 0 || !(msg.incompat_flags & MAVLINK_IFLAG_SIGNED)) abort();                          \
        }                                                                                                   \
    }                                                                                                       \
    static void mav_signed_parse_##M(long n) {                                                              \
        mavlink_message_t msg;                                                                              \
        mavlink_status_t st;                                                                                \
        for (long i = 0; i < n; i++) {                                                                      \
            sink(mav_signed_bytes[M]);                                                                      \
            mav_streams.num_signing_streams = 0;                                                            \
            int got = 0;                                                                                    \
            for (size_t b = 0; b < mav_signed_len[M]; b++)                                                  \
                if (mavlink_parse_char(MAVLINK_COMM_2, mav_signed_bytes[M][b], &msg, &st)) got = 1;         \
            if (!got) abort();                                                                              \
            mavlink_msg_##MN##_decode(&msg, &mav_out_##M);                                                  \
            sink(&mav_out_##M);                                                                             \
        }                                                                                                   \
    }                                                                                                       \
    static void floor_siphash_##M(long n) { /* the tag's floor: libsodium SipHash-2-4 over the tag input */  \
        uint8_t in[UB_SEC_SIGNING_HEADER_LEN + UB_MAX_PAYLOAD], out[8], k[16] = {1};                        \
        size_t pl = ub_signed_hdr[M].payload_size;                                                          \
        for (long i = 0; i < n; i++) {                                                                      \
            ub_sign_hdr[M].seq++;                                                                           \
            ub_sec_signing_header(&ub_sign_hdr[M], in);                                                     \
            memcpy(in + UB_SEC_SIGNING_HEADER_LEN, frame_buf + UB_FRAME_HEADER_LEN, pl);                    \
            crypto_shorthash_siphash24(out, in, UB_SEC_SIGNING_HEADER_LEN + pl, k);                         \
            sink(out);                                                                                      \
        }                                                                                                   \
    }                                                                                                       \
    static void setup_sign_##M(void) {                                                                      \
        ub_frame_header_t h = hdr;                                                                          \
        int p = PK(&ub_obj_##M, ub_signed_bytes[M] + UB_FRAME_HEADER_LEN, UB_MAX_PAYLOAD);                  \
        h.payload_size = (uint16_t)p;                                                                       \
        h.flags = UB_FRAME_FLAG_SIGNED;                                                                     \
        h.key_id = 1;                                                                                       \
        h.counter_hi = 0x3A5B;                                                                              \
        h.seq = 1;                                                                                          \
        int fl = ub_sec_protect(&sec, &h, ub_signed_bytes[M] + UB_FRAME_HEADER_LEN, ub_signed_bytes[M],     \
                                UB_FRAME_MAX);                                                              \
        if (p < 0 || fl < 0 || ub_frame_parse(ub_signed_bytes[M], (size_t)fl, &ub_signed_hdr[M]) != UB_OK) \
            abort();                                                                                        \
        ub_signed_len[M] = (size_t)fl;                                                                      \
        ub_sign_hdr[M] = ub_signed_hdr[M];                                                                  \
        memcpy(frame_buf + UB_FRAME_HEADER_LEN, ub_signed_bytes[M] + UB_FRAME_HEADER_LEN, (size_t)p);       \
        h.flags = UB_FRAME_FLAG_ENCRYPTED;                                                                  \
        if (PK(&ub_obj_##M, ub_aead_bytes[M] + UB_FRAME_HEADER_LEN, UB_MAX_PAYLOAD) != p) abort();          \
        fl = ub_sec_protect(&sec, &h, ub_aead_bytes[M] + UB_FRAME_HEADER_LEN, ub_aead_bytes[M], UB_FRAME_MAX); \
        if (fl < 0) abort();                                                                                \
        ub_aead_len[M] = (size_t)fl;                                                                        \
        mavlink_message_t msg;                                                                              \
        mavlink_msg_##MN##_encode_chan(1, 1, MAVLINK_COMM_1, &msg, &mav_obj_##M);                           \
        mav_signed_len[M] = mavlink_msg_to_send_buffer(mav_signed_bytes[M], &msg);                          \
        if (!(msg.incompat_flags & MAVLINK_IFLAG_SIGNED)) abort();                                          \
        /* the check reads what the parser fills (ck, signature): parse it on a channel without signing */  \
        mavlink_status_t st;                                                                                \
        int got = 0;                                                                                        \
        for (size_t b = 0; b < mav_signed_len[M]; b++)                                                      \
            if (mavlink_parse_char(MAVLINK_COMM_3, mav_signed_bytes[M][b], &mav_signed_msg[M], &st)) got = 1; \
        mav_streams.num_signing_streams = 0;                                                                \
        if (!got || !mavlink_signature_check(&mav_signing_rx, &mav_streams, &mav_signed_msg[M])) abort();  \
    }

SIGN_CASES(0, benchAttitude_t, benchcat_pack_benchAttitude, benchcat_unpack_benchAttitude, mavlink_attitude_t,
           attitude, time_boot_ms)
SIGN_CASES(1, benchGpsRawInt_t, benchcat_pack_benchGpsRawInt, benchcat_unpack_benchGpsRawInt, mavlink_gps_raw_int_t,
           gps_raw_int, time_usec)
SIGN_CASES(2, benchHighresImu_t, benchcat_pack_benchHighresImu, benchcat_unpack_benchHighresImu,
           mavlink_highres_imu_t, highres_imu, time_usec)

#if BENCH_HAS_ORIGIN
/* ---- origin authentication cases (runtimes with ub_origin.h), one instance per message ---- */
#define ORIGIN_CASES(M, UT, PK, UN, TF)                                                                     \
    static void ub_origin_build_##M(long n) { /* pack + origin tag + SIGNED|ORIGIN frame (hop tag over it) */ \
        for (long i = 0; i < n; i++) {                                                                      \
            ub_obj_##M.TF++;                                                                                \
            int p = PK(&ub_obj_##M, frame_buf + UB_FRAME_HEADER_LEN, UB_MAX_PAYLOAD);                       \
            shdr.payload_size = (uint16_t)p;                                                                \
            shdr.flags = UB_FRAME_FLAG_SIGNED | UB_FRAME_FLAG_ORIGIN;                                       \
            shdr.seq++;                                                                                     \
            shdr.origin_hop0 = shdr.hop_limit;                                                              \
            if (ub_origin_tag(origin_key, &shdr, frame_buf + UB_FRAME_HEADER_LEN, shdr.origin_tag) != UB_OK) \
                abort();                                                                                    \
            int len = ub_sec_protect(&sec, &shdr, frame_buf + UB_FRAME_HEADER_LEN, frame_buf, sizeof frame_buf); \
            sink(frame_buf);                                                                                \
            if (len < 0) abort();                                                                           \
        }                                                                                                   \
    }                                                                                                       \
    static void on_origin_##M(void *user, const ub_frame_header_t *h, const uint8_t *f, size_t len) {       \
        (void)user;                                                                                         \
        const uint8_t *pl = verified_payload(h, f, len);                                                    \
        uint8_t tag[UB_FRAME_ORIGIN_TAG_LEN];                                                               \
        if (ub_origin_tag(origin_key, h, pl, tag) != UB_OK || sodium_memcmp(tag, h->origin_tag, sizeof tag) != 0 || \
            h->hop_limit > h->origin_hop0)                                                                  \
            abort();                                                                                        \
        if (UN(&ub_out_##M, pl, h->payload_size) < 0) abort();                                              \
        sink(&ub_out_##M);                                                                                  \
    }                                                                                                       \
    static void ub_origin_parse_##M(long n) { /* feed + hop tag + origin tag + window + unpack */          \
        for (long i = 0; i < n; i++) {                                                                      \
            sink(ub_origin_bytes[M]);                                                                       \
            if (ub_decoder_feed(&dec, ub_origin_bytes[M], ub_origin_len[M], on_origin_##M, NULL) != 1) abort(); \
        }                                                                                                   \
    }                                                                                                       \
    static void setup_origin_##M(void) { /* the SIGNED|ORIGIN frame the parse case feeds */                \
        ub_frame_header_t h = hdr;                                                                          \
        int p = PK(&ub_obj_##M, ub_origin_bytes[M] + UB_FRAME_HEADER_LEN, UB_MAX_PAYLOAD);                  \
        h.payload_size = (uint16_t)p;                                                                       \
        h.key_id = 1;                                                                                       \
        h.counter_hi = 0x3A5B;                                                                              \
        h.seq = 1;                                                                                          \
        h.flags = UB_FRAME_FLAG_SIGNED | UB_FRAME_FLAG_ORIGIN;                                              \
        h.origin_hop0 = h.hop_limit;                                                                        \
        if (p < 0 || ub_origin_tag(origin_key, &h, ub_origin_bytes[M] + UB_FRAME_HEADER_LEN, h.origin_tag) != UB_OK) \
            abort();                                                                                        \
        int fl = ub_sec_protect(&sec, &h, ub_origin_bytes[M] + UB_FRAME_HEADER_LEN, ub_origin_bytes[M], UB_FRAME_MAX); \
        if (fl < 0) abort();                                                                                \
        ub_origin_len[M] = (size_t)fl;                                                                      \
    }

ORIGIN_CASES(0, benchAttitude_t, benchcat_pack_benchAttitude, benchcat_unpack_benchAttitude, time_boot_ms)
ORIGIN_CASES(1, benchGpsRawInt_t, benchcat_pack_benchGpsRawInt, benchcat_unpack_benchGpsRawInt, time_usec)
ORIGIN_CASES(2, benchHighresImu_t, benchcat_pack_benchHighresImu, benchcat_unpack_benchHighresImu, time_usec)
#endif

typedef struct bench_case {
    const char *name;
    int msg;
    int bytes_kind; /* 0 uavbus frame, 1 mavlink frame, 2 payload, 3 lcm encoding, 4 signed uavbus frame,
                       5 signed mavlink frame, 6 encrypted uavbus frame, 7 SIGNED|ORIGIN uavbus frame */
    void (*fn)(long);
    long iters;
    double ns[SAMPLES];
} bench_case_t;

#define CASES_FOR(M)                                                                                        \
    {"ub_frame_build", M, 0, ub_build_##M, 0, {0}}, {"mav_pack", M, 1, mav_pack_##M, 0, {0}},              \
        {"ub_frame_build_finish", M, 0, ub_build_finish_##M, 0, {0}},                                       \
        {"mav_pack_tobuf", M, 1, mav_pack_tobuf_##M, 0, {0}}, {"ub_frame_parse", M, 0, ub_parse_##M, 0, {0}}, \
        {"ub_frame_parse_foreign", M, 0, ub_parse_foreign_##M, 0, {0}},                                     \
        {"mav_parse_decode", M, 1, mav_parse_##M, 0, {0}}, {"ub_pack", M, 2, ub_pack_##M, 0, {0}},          \
        {"ub_unpack", M, 2, ub_unpack_##M, 0, {0}}, {"lcm_encode", M, 3, lcm_encode_##M, 0, {0}},           \
        {"lcm_decode", M, 3, lcm_decode_##M, 0, {0}}, {"floor_memcpy", M, 2, floor_memcpy_##M, 0, {0}},     \
        {"floor_crc32c", M, 0, floor_crc32c_##M, 0, {0}}, {"floor_x25", M, 1, floor_x25_##M, 0, {0}}

#define SIGN_CASES_FOR(M)                                                                                   \
    {"ub_sign", M, 4, ub_sign_##M, 0, {0}}, {"mav_sign_packet", M, 5, mav_sign_##M, 0, {0}},               \
        {"ub_verify", M, 4, ub_verify_##M, 0, {0}}, {"mav_signature_check", M, 5, mav_check_##M, 0, {0}},   \
        {"ub_signed_build", M, 4, ub_signed_build_##M, 0, {0}},                                              \
        {"mav_signed_pack_tobuf", M, 5, mav_signed_pack_##M, 0, {0}},                                       \
        {"ub_signed_parse", M, 4, ub_signed_parse_##M, 0, {0}},                                              \
        {"mav_signed_parse_decode", M, 5, mav_signed_parse_##M, 0, {0}},                                    \
        {"ub_aead_build", M, 6, ub_aead_build_##M, 0, {0}}, {"ub_aead_parse", M, 6, ub_aead_parse_##M, 0, {0}}, \
        {"floor_siphash24", M, 4, floor_siphash_##M, 0, {0}}

#if BENCH_HAS_ORIGIN /* a leading comma, so that a runtime without origin leaves nothing behind */
#define ORIGIN_CASES_FOR(M)                                                                                 \
    , {"ub_origin_build", M, 7, ub_origin_build_##M, 0, {0}}, {"ub_origin_parse", M, 7, ub_origin_parse_##M, 0, {0}}
#else
#define ORIGIN_CASES_FOR(M)
#endif

static bench_case_t cases[] = {CASES_FOR(0),      CASES_FOR(1),      CASES_FOR(2),
                               SIGN_CASES_FOR(0) ORIGIN_CASES_FOR(0), SIGN_CASES_FOR(1) ORIGIN_CASES_FOR(1),
                               SIGN_CASES_FOR(2) ORIGIN_CASES_FOR(2)};
#define N_CASES (sizeof cases / sizeof cases[0])
static const char *msg_names[3] = {"ATTITUDE", "GPS_RAW_INT", "HIGHRES_IMU"};

static size_t case_bytes(const bench_case_t *c) {
    static const size_t payload[3] = {28, 52, 63};
    switch (c->bytes_kind) {
    case 0: return ub_frame_len[c->msg];
    case 1: return mav_frame_len[c->msg];
    case 3: return (size_t)lcm_len[c->msg];
    case 4: return ub_signed_len[c->msg];
    case 5: return mav_signed_len[c->msg];
    case 6: return ub_aead_len[c->msg];
#if BENCH_HAS_ORIGIN
    case 7: return ub_origin_len[c->msg];
#endif
    default: return payload[c->msg];
    }
}

int main(int argc, char **argv) {
    int callgrind = argc > 1 && strcmp(argv[1], "callgrind") == 0;
    ub_decoder_init(&dec);
    ub_decoder_init(&dec_foreign);
#ifdef UB_DECODER_FOREIGN /* BENCH_BASE may name a runtime from before foreign traffic: there both cases are one */
    ub_decoder_set_foreign(&dec_foreign, on_foreign, NULL);
#endif
    memcpy(hdr.dest_id, "rx\0\0\0\0\0\0\0\0\0\0", UB_ENTITY_ID_LEN);
    memcpy(hdr.src_id, "tx\0\0\0\0\0\0\0\0\0\0", UB_ENTITY_ID_LEN);
    hdr.admin = UB_ADMIN_DATA;
    hdr.hop_limit = UB_DEFAULT_HOP_LIMIT;
    memset(payload_src, 0x5a, sizeof payload_src);
    setup_0();
    setup_1();
    setup_2();
    /* signing: one 32-byte key on both sides (uavbus key id 1; MAVLink link 0), signing on channels 1 (tx) and 2 (rx) */
    uint8_t key[UB_SEC_KEY_LEN];
    memset(key, 0x42, sizeof key);
    if (ub_sec_init(&sec, NULL) != UB_OK || ub_sec_add_key(&sec, 1, key) != UB_OK) abort();
#if BENCH_HAS_ORIGIN
    /* origin: the pairwise key "tx" -> "rx" from two fixed X25519 secret keys (the bench is both ends) */
    uint8_t sk_tx[UB_ORIGIN_SK_LEN], sk_rx[UB_ORIGIN_SK_LEN], pk_rx[UB_ORIGIN_PK_LEN], k_back[UB_ORIGIN_KEY_LEN];
    memset(sk_tx, 0x17, sizeof sk_tx);
    memset(sk_rx, 0x29, sizeof sk_rx);
    if (ub_origin_public_key(sk_rx, pk_rx) != UB_OK ||
        ub_origin_pair_keys(hdr.src_id, sk_tx, hdr.dest_id, pk_rx, origin_key, k_back) != UB_OK)
        abort();
#endif
    shdr = hdr;
    shdr.key_id = 1;
    shdr.counter_hi = 0x3A5B;
    mav_signing_tx.flags = MAVLINK_SIGNING_FLAG_SIGN_OUTGOING;
    mav_signing_tx.timestamp = 1000000;
    memcpy(mav_signing_tx.secret_key, key, sizeof key);
    mav_signing_rx = mav_signing_tx;
    mav_signing_rx.flags = 0;
    mavlink_get_channel_status(MAVLINK_COMM_1)->signing = &mav_signing_tx;
    mavlink_get_channel_status(MAVLINK_COMM_2)->signing = &mav_signing_rx;
    mavlink_get_channel_status(MAVLINK_COMM_2)->signing_streams = &mav_streams;
    setup_sign_0();
    setup_sign_1();
    setup_sign_2();
#if BENCH_HAS_ORIGIN
    setup_origin_0();
    setup_origin_1();
    setup_origin_2();
#endif
    if (callgrind) {
        for (size_t i = 0; i < N_CASES; i++) {
            char name[64];
            snprintf(name, sizeof name, "%s/%s", cases[i].name, msg_names[cases[i].msg]);
            cases[i].fn(100); /* warm: first-call effects out of the count */
            CALLGRIND_ZERO_STATS;
            cases[i].fn(BENCH_ITERS);
            CALLGRIND_DUMP_STATS_AT(name);
        }
        return 0;
    }
    for (size_t i = 0; i < N_CASES; i++) { /* calibrate to ~10 ms per sample */
        long n = 1000;
        for (;;) {
            double t0 = now_ns();
            cases[i].fn(n);
            double dt = now_ns() - t0;
            if (dt > 5e6 || n > (1L << 30)) {
                cases[i].iters = (long)(n * (1e7 / dt)) + 1;
                break;
            }
            n *= 4;
        }
    }
    for (int s = 0; s < SAMPLES; s++)
        for (size_t i = 0; i < N_CASES; i++) {
            double t0 = now_ns();
            cases[i].fn(cases[i].iters);
            cases[i].ns[s] = (now_ns() - t0) / (double)cases[i].iters;
        }
    if (foreign_seen != 0) abort(); /* a pure stream hands nothing on */
    for (size_t i = 0; i < N_CASES; i++) {
        printf("%s\t%s\t%zu", cases[i].name, msg_names[cases[i].msg], case_bytes(&cases[i]));
        for (int s = 0; s < SAMPLES; s++) printf("\t%.3f", cases[i].ns[s]);
        printf("\n");
    }
    return 0;
}
