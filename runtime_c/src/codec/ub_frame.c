/* Frame build/verify and the streaming decoder (contracts in ub/ub_frame.h).
 *
 * The decoder's rule is "every sync position not inside a delivered frame is a
 * candidate, judged only once all its bytes are present". The two paths below
 * (in place over the caller's chunk; from the carried buffer) both follow it,
 * so chunking never changes what is delivered or counted. */
#include "ub/ub_frame.h"

#include <stddef.h>
#include <string.h>

#include "ub/ub_wire.h"
#include "codec/ub_crc32c_impl.h"

/* Result of judging a candidate's 64 header bytes: accepted, or a rejection reason. */
#define HEADER_OK UB_RX_REASON_COUNT

/* 1 + the trailer length for each value of the version byte (wire version | flags); 0 for every value the
 * codec refuses (unknown version, reserved or combined flags): one load in the decoder's hot path. */
static const uint8_t k_trailer_plus_one[256] = {
    [UB_WIRE_VERSION] = 1,
    [UB_WIRE_VERSION | UB_FRAME_FLAG_SIGNED] = 1 + UB_FRAME_SIG_TRAILER_LEN,
    [UB_WIRE_VERSION | UB_FRAME_FLAG_ENCRYPTED] = 1 + UB_FRAME_AEAD_TRAILER_LEN,
    [UB_WIRE_VERSION | UB_FRAME_FLAG_SIGNED | UB_FRAME_FLAG_ORIGIN] = 1 + UB_FRAME_SIG_TRAILER_LEN + UB_FRAME_ORIGIN_LEN,
    [UB_WIRE_VERSION | UB_FRAME_FLAG_ENCRYPTED | UB_FRAME_FLAG_ORIGIN] = 1 + UB_FRAME_AEAD_TRAILER_LEN + UB_FRAME_ORIGIN_LEN,
};

/* XOR of the CRC's 4 bytes: halves, then quarters (b0^b2 ^ b1^b3 in the low byte), 4 operations. */
static inline uint8_t fold_crc(uint32_t crc) {
    crc ^= crc >> 16;
    return (uint8_t)(crc ^ (crc >> 8));
}

/* The header as eight little-endian words (word k = bytes [8k, 8k+8)), built in
 * registers. finish checksums these words and then stores them whole: checksumming
 * bytes it had just stored one field at a time made every 8-byte load of the CRC wait
 * for those small stores to retire (a store-forwarding stall), which measured at half
 * the cost of the whole build. Checks and msg_crc are left zero here. */
static inline void header_words(const ub_frame_header_t *h, size_t trailer_len, uint64_t w[8]) {
    w[0] = UB_SYNC0 | UB_SYNC1 << 8 | (uint64_t)(UB_WIRE_VERSION | h->flags) << 24 |
           (uint64_t)UB_MSG_TYPE_PUBSUB << 32 | (uint64_t)(UB_FRAME_HEADER_LEN + h->payload_size + trailer_len) << 48;
    w[1] = ub_get_u64le(h->dir_id);
    w[2] = ub_get_u64le(h->dir_id + 8);
    w[3] = ub_get_u64le(h->dest_id);
    w[4] = ub_get_u32le(h->dest_id + 8) | (uint64_t)ub_get_u32le(h->src_id) << 32;
    w[5] = ub_get_u64le(h->src_id + 4);
    w[6] = h->admin | (uint64_t)h->hop_limit << 8 | (uint64_t)h->payload_size << 16 | (uint64_t)h->seq << 32;
    w[7] = h->fingerprint;
}

/* Inlined (the decoder's delivery and ub_frame_parse): a call here cost the argument and spill moves around it
 * on every delivered frame. */
static inline __attribute__((always_inline)) void read_header(const uint8_t *f, ub_frame_header_t *h) {
    h->msg_type = ub_get_u16le(f + UB_FRAME_OFF_MSG_TYPE);
    h->flags = f[UB_FRAME_OFF_VERSION] & UB_FRAME_FLAGS_MASK;
    /* dir_id, dest_id, src_id, admin and hop_limit lie in the same order, unpadded, on the wire and in the
     * struct (asserted below): one 42-byte copy, a few wide moves where there were five field copies */
    memcpy((uint8_t *)h + offsetof(ub_frame_header_t, dir_id), f + UB_FRAME_OFF_DIR_ID,
           UB_FRAME_OFF_HOP_LIMIT + 1u - UB_FRAME_OFF_DIR_ID);
    h->payload_size = ub_get_u16le(f + UB_FRAME_OFF_PAYLOAD_SIZE);
    h->seq = ub_get_u32le(f + UB_FRAME_OFF_SEQ);
    h->fingerprint = ub_get_u32le(f + UB_FRAME_OFF_FINGERPRINT);
    if (h->flags != 0) { /* a verified frame: its flags are valid, so its trailer is there */
        const uint8_t *t = f + UB_FRAME_HEADER_LEN + h->payload_size;
        h->key_id = t[UB_FRAME_TRL_OFF_KEY_ID];
        h->counter_hi = ub_get_u16le(t + UB_FRAME_TRL_OFF_COUNTER_HI);
        if (h->flags & UB_FRAME_FLAG_ORIGIN) {
            const uint8_t *o = t + ub_frame_trailer_len(h->flags) - UB_FRAME_ORIGIN_LEN;
            h->origin_hop0 = o[0];
            memcpy(h->origin_tag, o + 1, UB_FRAME_ORIGIN_TAG_LEN);
        } else {
            h->origin_hop0 = 0;
            memset(h->origin_tag, 0, UB_FRAME_ORIGIN_TAG_LEN);
        }
    } else {
        /* key_id, counter_hi, origin_hop0 and origin_tag end the struct (asserted below): zeroed as one range,
         * padding included, in one or two wide stores where there were four field stores */
        memset(&h->key_id, 0, sizeof *h - offsetof(ub_frame_header_t, key_id));
    }
}
_Static_assert(offsetof(ub_frame_header_t, dest_id) - offsetof(ub_frame_header_t, dir_id) ==
                       UB_FRAME_OFF_DEST_ID - UB_FRAME_OFF_DIR_ID &&
                   offsetof(ub_frame_header_t, src_id) - offsetof(ub_frame_header_t, dir_id) ==
                       UB_FRAME_OFF_SRC_ID - UB_FRAME_OFF_DIR_ID &&
                   offsetof(ub_frame_header_t, admin) - offsetof(ub_frame_header_t, dir_id) ==
                       UB_FRAME_OFF_ADMIN - UB_FRAME_OFF_DIR_ID &&
                   offsetof(ub_frame_header_t, hop_limit) - offsetof(ub_frame_header_t, dir_id) ==
                       UB_FRAME_OFF_HOP_LIMIT - UB_FRAME_OFF_DIR_ID,
               "read_header() copies dir_id .. hop_limit as one range: the struct must lay them out as the wire does");
_Static_assert(offsetof(ub_frame_header_t, key_id) < offsetof(ub_frame_header_t, counter_hi) &&
                   offsetof(ub_frame_header_t, counter_hi) < offsetof(ub_frame_header_t, origin_hop0) &&
                   offsetof(ub_frame_header_t, origin_hop0) < offsetof(ub_frame_header_t, origin_tag) &&
                   offsetof(ub_frame_header_t, fingerprint) < offsetof(ub_frame_header_t, key_id) &&
                   sizeof(ub_frame_header_t) - offsetof(ub_frame_header_t, origin_tag) - UB_FRAME_ORIGIN_TAG_LEN <
                       _Alignof(ub_frame_header_t),
               "read_header() zeroes the trailer fields from key_id to the end of ub_frame_header_t");

/* The one CRC pass: header state first (for hdr_check), then on over the payload and trailer (`body_len`). */
static void write_checks(uint8_t *f, size_t body_len) {
    uint32_t header_crc = ub_crc32c_update(0, f + UB_FRAME_CHECKED_OFF, UB_FRAME_CHECKED_LEN);
    f[UB_FRAME_OFF_HDR_CHECK] = fold_crc(header_crc);
    ub_put_u32le(f + UB_FRAME_OFF_MSG_CRC, ub_crc32c_update(header_crc, f + UB_FRAME_HEADER_LEN, body_len));
}

/* The header's own fields judged, given its CRC: the header check first, so a corrupted version or length
 * on a real frame is named as such rather than random bytes after a false sync being blamed on "version". */
static inline __attribute__((always_inline)) ub_rx_reason_t judge_fields(const uint8_t *f, uint32_t header_crc,
                                                                         size_t *frame_len) {
    if (fold_crc(header_crc) != f[UB_FRAME_OFF_HDR_CHECK]) return UB_RX_BAD_HDR_CHECK;
    size_t trailer_plus_one = k_trailer_plus_one[f[UB_FRAME_OFF_VERSION]];
    if (trailer_plus_one == 0 || ub_get_u16le(f + UB_FRAME_OFF_MSG_TYPE) != UB_MSG_TYPE_PUBSUB) return UB_RX_BAD_VERSION;
    size_t trailer = trailer_plus_one - 1u;
    size_t payload_size = ub_get_u16le(f + UB_FRAME_OFF_PAYLOAD_SIZE);
    size_t msg_size = ub_get_u16le(f + UB_FRAME_OFF_MSG_SIZE);
    if (payload_size > UB_MAX_PAYLOAD || msg_size != UB_FRAME_HEADER_LEN + payload_size + trailer)
        return UB_RX_BAD_LENGTH;
    *frame_len = msg_size;
    return HEADER_OK;
}

/* Judges the 64 header bytes at `f` (sync already matched). */
/* Inlined into each caller (the decoder's two scans, ub_frame_parse): as a call it saved and restored three
 * registers and passed both results through memory, some 12 instructions of a ~300-instruction parse. */
static inline __attribute__((always_inline)) ub_rx_reason_t judge_header(const uint8_t *f, uint32_t *header_crc,
                                                                         size_t *frame_len) {
    *header_crc = ub_crc32c_header(f); /* = ub_crc32c(f + UB_FRAME_CHECKED_OFF, UB_FRAME_CHECKED_LEN), unrolled */
    return judge_fields(f, *header_crc, frame_len);
}

static int body_crc_ok(const uint8_t *f, size_t frame_len, uint32_t header_crc) {
    uint32_t crc = ub_crc32c_update(header_crc, f + UB_FRAME_HEADER_LEN, frame_len - UB_FRAME_HEADER_LEN);
    return crc == ub_get_u32le(f + UB_FRAME_OFF_MSG_CRC);
}

/* check_frame()'s verdict for a good header whose frame runs past the `avail` bytes at hand. */
#define FRAME_SHORT (HEADER_OK + 1)
/* check_frame() returns a frame's length (at least UB_FRAME_HEADER_LEN) or a verdict (far below it). */
_Static_assert(FRAME_SHORT < UB_FRAME_HEADER_LEN, "check_frame()'s verdicts must stay below UB_FRAME_HEADER_LEN");

/* A whole candidate judged where it lies (`avail` >= UB_FRAME_HEADER_LEN bytes from its sync): its length when
 * the header and the body are both right, FRAME_SHORT when the header is right but the frame is longer than
 * `avail`, else the rejection reason (every verdict is below UB_FRAME_HEADER_LEN, so one register says which).
 * The same verdicts as judge_header() then body_crc_ok(); it exists for the hardware path below, where both
 * CRCs are one instruction chain in one function instead of two calls through the CPU dispatch. */
static size_t check_frame_portable(const uint8_t *f, size_t avail) {
    uint32_t header_crc;
    size_t frame_len = 0;
    ub_rx_reason_t why = judge_header(f, &header_crc, &frame_len);
    if (why != HEADER_OK) return why;
    if (avail < frame_len) return FRAME_SHORT;
    return body_crc_ok(f, frame_len, header_crc) ? frame_len : UB_RX_BAD_CRC;
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
/* Compiled for SSE4.2 on its own (the library still runs on any x86-64); called only when the CPU has it. */
__attribute__((target("sse4.2"))) static size_t check_frame_sse42(const uint8_t *f, size_t avail) {
    uint64_t header_reg = ub_crc32c_header_reg_sse42(f);
    /* judge_fields()'s checks as one condition: a right header takes no branch that must first load the
     * reason it would return; a wrong one is judged again below to name it (the same checks, so that never
     * comes back HEADER_OK). fold_crc(~x) == fold_crc(x) (see tpl_finish_sse42), so the register is judged as
     * it is. */
    size_t trailer_plus_one = k_trailer_plus_one[f[UB_FRAME_OFF_VERSION]];
    size_t payload_size = ub_get_u16le(f + UB_FRAME_OFF_PAYLOAD_SIZE);
    size_t frame_len = ub_get_u16le(f + UB_FRAME_OFF_MSG_SIZE);
    if (__builtin_expect(fold_crc((uint32_t)header_reg) != f[UB_FRAME_OFF_HDR_CHECK] || trailer_plus_one == 0 ||
                             ub_get_u16le(f + UB_FRAME_OFF_MSG_TYPE) != UB_MSG_TYPE_PUBSUB ||
                             payload_size > UB_MAX_PAYLOAD ||
                             frame_len != UB_FRAME_HEADER_LEN - 1u + payload_size + trailer_plus_one,
                         0))
        return judge_fields(f, (uint32_t)header_reg, &frame_len);
    if (avail < frame_len) return FRAME_SHORT;
    size_t body_len = frame_len - UB_FRAME_HEADER_LEN;
    const uint8_t *body = f + UB_FRAME_HEADER_LEN;
    uint32_t crc = ~ub_crc32c_steps_sse42(header_reg, body, body_len, body + (body_len & ~(size_t)15));
    return crc == ub_get_u32le(f + UB_FRAME_OFF_MSG_CRC) ? frame_len : UB_RX_BAD_CRC;
}
#define UB_CHECK_FRAME_HW 1
#endif

static inline __attribute__((always_inline)) size_t check_frame(const uint8_t *f, size_t avail) {
#ifdef UB_CHECK_FRAME_HW
#if !defined(__SSE4_2__)
    if (__builtin_cpu_supports("sse4.2")) /* GCOVR_EXCL_BR_LINE: CPU dispatch */
#endif
        return check_frame_sse42(f, avail);
#endif
    return check_frame_portable(f, avail); /* GCOVR_EXCL_LINE: hosts without SSE4.2 */
}

int ub_frame_finish(uint8_t *frame, size_t cap, const ub_frame_header_t *h) {
    if (frame == NULL || h == NULL) return UB_ERR_INVAL;
    if (!ub_frame_flags_valid(h->flags)) return UB_ERR_INVAL;
    if (h->payload_size > UB_MAX_PAYLOAD || h->hop_limit == 0) return UB_ERR_RANGE;
    size_t body_len = (size_t)h->payload_size + ub_frame_trailer_len(h->flags);
    size_t frame_len = UB_FRAME_HEADER_LEN + body_len;
    if (cap < frame_len) return UB_ERR_NOSPACE;
    uint64_t w[8];
    header_words(h, body_len - h->payload_size, w);
    uint32_t header_crc;
    uint32_t msg_crc = ub_crc32c_frame_words(w, frame + UB_FRAME_HEADER_LEN, body_len, &header_crc);
    w[0] |= (uint64_t)fold_crc(header_crc) << 16;
    w[7] |= (uint64_t)msg_crc << 32;
    for (int k = 0; k < 8; k++) ub_put_u64le(frame + 8 * k, w[k]);
    return (int)frame_len;
}

/* ---- per-row header templates ----
 * Why it is exact: CRC-32C is computed left to right through a 32-bit state, and ub_crc32c_update(crc(a), b)
 * == crc(a || b) (ub_frame.h). Header bytes [4,52) are msg_type, msg_size, the three IDs, admin, hop_limit
 * and payload_size: all fixed for a row once its payload size is. So crc([4,52)) is computed once per row
 * (head_reg, kept as the register: ~crc); each frame continues it over bytes [52,60) (seq, fingerprint) to get the header CRC, and on
 * over the payload to get msg_crc -- the same two values a pass from byte 4 gives. The header is the
 * template's bytes copied whole, then seq and the two checks written over their zero bytes. */
static void tpl_prime(ub_frame_tpl_t *t, uint16_t payload_size) {
    ub_put_u16le(t->header + UB_FRAME_OFF_MSG_SIZE, (uint16_t)(UB_FRAME_HEADER_LEN + payload_size));
    ub_put_u16le(t->header + UB_FRAME_OFF_PAYLOAD_SIZE, payload_size);
    t->payload_size = payload_size;
    /* Decided once per row, not per frame: the hardware path is taken when the size matches fast_size, so
     * ub_frame_tpl_finish() needs no separate CPU test (UINT32_MAX: no payload size matches, the portable
     * build runs). */
    t->fast_size = ub_crc32c_hw_available() ? payload_size : UINT32_MAX;
    t->fast_len = UB_FRAME_HEADER_LEN + (size_t)payload_size;
    t->fast_len16 = payload_size & ~(size_t)15;
    t->head_reg = ~ub_crc32c(t->header + UB_FRAME_CHECKED_OFF, UB_FRAME_OFF_SEQ - UB_FRAME_CHECKED_OFF);
}

int ub_frame_tpl_init(ub_frame_tpl_t *t, const ub_frame_header_t *h) {
    if (t == NULL || h == NULL || h->flags != 0) return UB_ERR_INVAL;
    if (h->payload_size > UB_MAX_PAYLOAD || h->hop_limit == 0) return UB_ERR_RANGE;
    uint64_t w[8];
    header_words(h, 0, w);
    w[6] &= 0xFFFFFFFFull; /* seq zero; the checks are zero in header_words() already */
    for (int k = 0; k < 8; k++) ub_put_u64le(t->header + 8 * k, w[k]);
    t->fingerprint_hi = (uint64_t)h->fingerprint << 32;
    tpl_prime(t, h->payload_size);
    return UB_OK;
}

/* The last step of a template build, given both CRCs. */
static inline int tpl_write(const ub_frame_tpl_t *t, uint8_t *frame, uint32_t seq, uint32_t header_crc,
                            uint32_t msg_crc, size_t frame_len) {
    memcpy(frame, t->header, UB_FRAME_HEADER_LEN);
    frame[UB_FRAME_OFF_HDR_CHECK] = fold_crc(header_crc);
    ub_put_u32le(frame + UB_FRAME_OFF_SEQ, seq);
    ub_put_u32le(frame + UB_FRAME_OFF_MSG_CRC, msg_crc);
    return (int)frame_len;
}

/* Hosts without the x86 path: the CRC steps through ub_crc32c_frame_tail(). Kept out of line so the
 * hardware path's function saves no registers for it. */
static __attribute__((noinline)) int tpl_finish_other(const ub_frame_tpl_t *t, uint8_t *frame, uint32_t seq,
                                                      size_t payload_size) {
    uint64_t crcs = ub_crc32c_frame_tail(~t->head_reg, seq | t->fingerprint_hi, frame + UB_FRAME_HEADER_LEN, payload_size);
    return tpl_write(t, frame, seq, (uint32_t)crcs, (uint32_t)(crcs >> 32), UB_FRAME_HEADER_LEN + payload_size);
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
/* The hardware build, compiled for SSE4.2 on its own (the library still runs on any x86-64) so the CRC steps
 * inline into it: one function, no call, nothing spilled. It takes ub_frame_tpl_finish()'s own arguments in
 * their order (cap unused), so the inline finish (ub_frame.h) calls it with no register moves. Only with
 * payload_size == t->fast_size, which tpl_prime() sets only where the CPU has the instruction (so the length is
 * t->fast_len). The header check folds the CRC register before its final inversion: fold_crc() XORs the 4
 * bytes, and inverting all 4 flips each bit position an even number of times, so fold_crc(~x) == fold_crc(x)
 * -- one inversion fewer, the same byte. */
__attribute__((target("sse4.2"))) int ub_frame_tpl_finish_primed(const ub_frame_tpl_t *t, uint8_t *frame, size_t cap,
                                                                 uint16_t payload_size, uint32_t seq) {
    (void)cap;
    uint32_t header_reg;
    uint32_t msg_crc = ub_crc32c_frame_tail_sse42(t->head_reg, seq | t->fingerprint_hi, frame + UB_FRAME_HEADER_LEN,
                                                  payload_size, t->fast_len16, &header_reg);
    memcpy(frame, t->header, UB_FRAME_HEADER_LEN);
    frame[UB_FRAME_OFF_HDR_CHECK] = fold_crc(header_reg);
    ub_put_u32le(frame + UB_FRAME_OFF_SEQ, seq);
    ub_put_u32le(frame + UB_FRAME_OFF_MSG_CRC, msg_crc);
    return (int)t->fast_len;
}
#else
/* Other hosts (s390x, Arm with or without the CRC instructions, Cortex-M): tpl_prime() sets fast_size where
 * ub_crc32c_hw_available() says so (Armv8's CRC); the steps dispatch inside ub_crc32c_frame_tail(). */
int ub_frame_tpl_finish_primed(const ub_frame_tpl_t *t, uint8_t *frame, size_t cap, uint16_t payload_size,
                               uint32_t seq) {
    (void)cap;
    return tpl_finish_other(t, frame, seq, payload_size);
}
#endif

/* Everything but the common case, out of line so that case saves no registers: a payload size other than the
 * primed one (a variable-size type: re-prime, then build as usual), a CPU without the hardware CRC, and the
 * size errors in the order the contract gives them (UB_ERR_RANGE before UB_ERR_NOSPACE). */
int ub_frame_tpl_finish_other(ub_frame_tpl_t *t, uint8_t *frame, size_t cap, uint16_t payload_size, uint32_t seq) {
    if (payload_size != t->payload_size) {
        if (payload_size > UB_MAX_PAYLOAD) return UB_ERR_RANGE;
        tpl_prime(t, payload_size);
    }
    if (cap < UB_FRAME_HEADER_LEN + (size_t)payload_size) return UB_ERR_NOSPACE;
    if (t->fast_size == payload_size) return ub_frame_tpl_finish_primed(t, frame, cap, payload_size, seq);
    return tpl_finish_other(t, frame, seq, payload_size);
}

/* Whether `t` is primed for h, compared where the bytes already lie: h's IDs, admin and hop limit are the same 42
 * bytes in the struct as on the wire (asserted above), so five 64-bit and one 16-bit compare against the
 * template's header cover them, and payload size and fingerprint are compared as numbers. The other header
 * bytes are constants of every plain frame (sync, version, msg_type) or follow from the payload size
 * (msg_size), and seq and the checks are the build's. A zeroed template has no sync byte, so it never matches.
 * A few dozen instructions where a new template or an untemplated build runs the CRC over the whole header. */
int ub_frame_tpl_finish_header(ub_frame_tpl_t *t, uint8_t *frame, size_t cap, const ub_frame_header_t *h) {
    if (t == NULL || frame == NULL || h == NULL || h->flags != 0) return UB_ERR_INVAL;
    const uint8_t *img = (const uint8_t *)h + offsetof(ub_frame_header_t, dir_id);
    const uint8_t *tpl = t->header + UB_FRAME_OFF_DIR_ID;
    uint64_t diff = (uint64_t)(t->header[0] ^ UB_SYNC0) | (uint64_t)(h->payload_size ^ t->payload_size) |
                    ((uint64_t)h->fingerprint << 32 ^ t->fingerprint_hi) |
                    (uint64_t)(ub_get_u16le(img + 40) ^ ub_get_u16le(tpl + 40));
    for (int k = 0; k < 5; k++) diff |= ub_get_u64le(img + 8 * k) ^ ub_get_u64le(tpl + 8 * k);
    if (diff != 0) {
        int rc = ub_frame_tpl_init(t, h);
        if (rc < 0) return rc;
    }
    return ub_frame_tpl_finish(t, frame, cap, h->payload_size, h->seq);
}

/* The rejections of ub_frame_parse_reason() once the frame's checks ran (`got` from check_frame()), out of line so
 * the accepted frame's path saves no registers for them. A length mismatch is named before a bad body CRC. */
static __attribute__((noinline)) int parse_refusal(const uint8_t *frame, size_t got, size_t len,
                                                   ub_rx_reason_t *reason) {
    ub_rx_reason_t why;
    int err;
    if (got == FRAME_SHORT) {
        why = UB_RX_BAD_LENGTH;
        err = UB_ERR_TRUNCATED;
    } else if (got >= UB_FRAME_HEADER_LEN ||
               (got == UB_RX_BAD_CRC && ub_get_u16le(frame + UB_FRAME_OFF_MSG_SIZE) != len)) {
        why = UB_RX_BAD_LENGTH; /* `len` past the end of a frame (valid, or with a bad CRC: its header was right) */
        err = UB_ERR_INVAL;
    } else {
        why = (ub_rx_reason_t)got;
        err = why == UB_RX_BAD_HDR_CHECK || why == UB_RX_BAD_CRC ? UB_ERR_CHECKSUM : UB_ERR_INVAL;
    }
    if (reason != NULL) *reason = why;
    return err;
}

int ub_frame_parse_reason(const uint8_t *frame, size_t len, ub_frame_header_t *h, ub_rx_reason_t *reason) {
    if (frame == NULL || len < 2 || frame[0] != UB_SYNC0 || frame[1] != UB_SYNC1) {
        if (reason != NULL) *reason = UB_RX_BAD_SYNC;
        return frame == NULL || len >= 2 ? UB_ERR_INVAL : UB_ERR_TRUNCATED;
    }
    if (len < UB_FRAME_HEADER_LEN) {
        if (reason != NULL) *reason = UB_RX_BAD_LENGTH;
        return UB_ERR_TRUNCATED;
    }
    size_t got = check_frame(frame, len);
    if (got != len) return parse_refusal(frame, got, len, reason);
    if (h != NULL) read_header(frame, h);
    return UB_OK;
}

int ub_frame_parse(const uint8_t *frame, size_t len, ub_frame_header_t *h) {
    return ub_frame_parse_reason(frame, len, h, NULL);
}

int ub_frame_set_hop_limit(uint8_t *frame, size_t len, uint8_t hop_limit) {
    if (hop_limit == 0) return UB_ERR_RANGE;
    if (frame == NULL || len < UB_FRAME_HEADER_LEN || len != ub_get_u16le(frame + UB_FRAME_OFF_MSG_SIZE))
        return UB_ERR_INVAL;
    frame[UB_FRAME_OFF_HOP_LIMIT] = hop_limit;
    write_checks(frame, len - UB_FRAME_HEADER_LEN);
    return UB_OK;
}

/* Why a few register steps suffice. Write R(m, s) for the CRC-32C register after feeding bytes m from state
 * s; R is linear over GF(2) in m and s together, and a finished CRC is crc(m) = ~R(m, ~0). For two messages
 * of equal length, m' = m ^ e, so crc(m') = crc(m) ^ R(e, 0) -- the brief form of the same fact is
 * crc(a ^ b) = crc(a) ^ crc(b) ^ crc(0), with crc(b) ^ crc(0) = R(b, 0). Changing the hop limit from h to h'
 * makes e zero everywhere but one byte, d = h ^ h', at offset 49. Leading zero bytes leave R(., 0) at 0, so
 * R(e, 0) is the register of d alone advanced over the bytes after it: 10 header bytes ([50,60)) for the
 * header CRC, and 10 + the body for msg_crc (which continues the header CRC over the body). hdr_check is
 * the XOR of the header CRC's 4 bytes, also linear: it changes by the fold of the header delta. */
/* The deltas of both checks for hop limit change `d` on a frame of `len` bytes: R(d, 0) advanced to the end of
 * the header range, then on to the end of the body. */
static inline void hop_deltas(uint8_t d, size_t len, ub_frame_hop_memo_t *m) {
    uint32_t header_delta;
    m->msg_delta = ub_crc32c_byte_delta(d, UB_FRAME_CHECKED_OFF + UB_FRAME_CHECKED_LEN - (UB_FRAME_OFF_HOP_LIMIT + 1u),
                                        len - UB_FRAME_HEADER_LEN, &header_delta);
    m->hdr_delta = fold_crc(header_delta);
    m->len = (uint16_t)len;
    m->d = d;
}

static inline void hop_apply(uint8_t *frame, uint8_t hop_limit, const ub_frame_hop_memo_t *m) {
    frame[UB_FRAME_OFF_HOP_LIMIT] = hop_limit;
    frame[UB_FRAME_OFF_HDR_CHECK] ^= m->hdr_delta;
    ub_put_u32le(frame + UB_FRAME_OFF_MSG_CRC, ub_get_u32le(frame + UB_FRAME_OFF_MSG_CRC) ^ m->msg_delta);
}

int ub_frame_patch_hop_limit(uint8_t *frame, size_t len, uint8_t hop_limit) {
    if (hop_limit == 0) return UB_ERR_RANGE;
    if (frame == NULL || len < UB_FRAME_HEADER_LEN || len != ub_get_u16le(frame + UB_FRAME_OFF_MSG_SIZE))
        return UB_ERR_INVAL;
    ub_frame_hop_memo_t m;
    hop_deltas(frame[UB_FRAME_OFF_HOP_LIMIT] ^ hop_limit, len, &m);
    hop_apply(frame, hop_limit, &m);
    return UB_OK;
}

/* ub_frame_copy_hop_limit() for a change the memo does not hold (once per flow): out of line, so the memo's
 * path keeps few registers to save. */
static __attribute__((noinline)) int copy_hop_limit_new(uint8_t *dst, const uint8_t *src, size_t len, uint8_t hop_limit,
                                                        ub_frame_hop_memo_t *memo) {
    ub_frame_hop_memo_t local;
    ub_frame_hop_memo_t *m = memo != NULL ? memo : &local;
    hop_deltas(src[UB_FRAME_OFF_HOP_LIMIT] ^ hop_limit, len, m);
    memcpy(dst, src, len);
    hop_apply(dst, hop_limit, m);
    return UB_OK;
}

int ub_frame_copy_hop_limit(uint8_t *dst, const uint8_t *src, size_t len, uint8_t hop_limit, ub_frame_hop_memo_t *memo) {
    if (hop_limit == 0) return UB_ERR_RANGE;
    if (dst == NULL || src == NULL || len < UB_FRAME_HEADER_LEN || len != ub_get_u16le(src + UB_FRAME_OFF_MSG_SIZE))
        return UB_ERR_INVAL;
    uint8_t d = src[UB_FRAME_OFF_HOP_LIMIT] ^ hop_limit;
    if (memo == NULL || memo->len != len || memo->d != d) return copy_hop_limit_new(dst, src, len, hop_limit, memo);
    memcpy(dst, src, len);
    hop_apply(dst, hop_limit, memo);
    return UB_OK;
}

const char *ub_rx_reason_name(ub_rx_reason_t reason) {
    switch (reason) {
    case UB_RX_BAD_HDR_CHECK: return "bad_hdr_check";
    case UB_RX_BAD_CRC: return "bad_crc";
    case UB_RX_BAD_LENGTH: return "bad_length";
    case UB_RX_BAD_VERSION: return "bad_version";
    case UB_RX_BAD_SYNC: return "bad_sync";
    case UB_RX_NO_DICTIONARY: return "no_dictionary";
    case UB_RX_NO_REFERENCE: return "no_reference";
    case UB_RX_REASON_COUNT: break;
    }
    return "?";
}

void ub_decoder_init(ub_decoder_t *d) {
    if (d == NULL) return;
    d->have = 0;
    d->foreign = NULL;
    d->foreign_user = NULL;
    memset(&d->stats, 0, sizeof d->stats);
}

void ub_decoder_set_foreign(ub_decoder_t *d, ub_foreign_cb cb, void *user) {
    if (d == NULL) return;
    d->foreign = cb;
    d->foreign_user = cb != NULL ? user : NULL;
}

/* (A compact link's decoder marks an overlong packet being skipped with a `have` beyond the buffer: nothing pending.) */
size_t ub_decoder_pending(const ub_decoder_t *d) { return d == NULL || d->have > sizeof d->buf ? 0 : d->have; }

/* A run of bytes that are not part of any delivered frame, in stream order: to the foreign-traffic handler
 * when there is one, else garbage. Called once per run (not per byte), so a pure uavbus stream pays one
 * comparison per frame for it. */
static void not_frame(ub_decoder_t *d, const uint8_t *run, size_t n) {
    if (n == 0) return;
    if (d->foreign == NULL) {
        d->stats.garbage_bytes += n;
        return;
    }
    d->stats.foreign_bytes += n;
    size_t took = d->foreign(d->foreign_user, run, n);
    if (took < n) d->stats.foreign_refused += n - took;
}

void ub_decoder_not_frame(ub_decoder_t *d, const uint8_t *run, size_t n) {
    if (d != NULL && (run != NULL || n == 0)) not_frame(d, run, n);
}

void ub_decoder_restart(ub_decoder_t *d) {
    if (d == NULL) return;
    d->stats.garbage_bytes += ub_decoder_pending(d);
    d->have = 0;
}

/* Inlined: the in-place scan delivers nearly every frame, and the call cost its argument moves. */
static inline __attribute__((always_inline)) void deliver(ub_decoder_t *d, const uint8_t *f, size_t frame_len, ub_frame_cb cb, void *user) {
    d->stats.frames_ok++;
    d->stats.bytes_ok += frame_len;
    if (cb != NULL) {
        ub_frame_header_t h;
        read_header(f, &h);
        cb(user, &h, f, frame_len);
    }
}

/* Keeps buf[k, have) from the first sync candidate at or after `from` on: a full sync pair, or a lone
 * SYNC0 as the last byte (its partner may come in the next chunk). buf[0, k) is not a frame (with `from`
 * 1, buf[0] is the sync byte of a rejected candidate, where the search resumes after). */
static void rescan_buffer(ub_decoder_t *d, size_t from) {
    size_t k = from;
    while (k < d->have) {
        const uint8_t *hit = memchr(d->buf + k, UB_SYNC0, d->have - k);
        if (hit == NULL) {
            k = d->have;
            break;
        }
        k = (size_t)(hit - d->buf);
        if (k + 1 == d->have || d->buf[k + 1] == UB_SYNC1) break;
        k++;
    }
    not_frame(d, d->buf, k);
    memmove(d->buf, d->buf + k, d->have - k);
    d->have -= k;
}

/* Advances the carried candidate (buf[0] is SYNC0) with bytes from data[*pos, len).
 * Returns 1 when it reached a verdict (delivered or rejected) and the caller should
 * loop, 0 when it needs more input (all of data was taken). Bytes taken from `data`
 * for a candidate that is then rejected are given back, so they are searched again
 * exactly as if they had arrived in the same chunk. */
static int advance_carried(ub_decoder_t *d, const uint8_t *data, size_t len, size_t *pos, ub_frame_cb cb,
                           void *user, size_t *delivered) {
    size_t taken = 0;
    if (d->have == 1) {
        if (*pos == len) return 0;
        if (data[*pos] != UB_SYNC1) {
            d->have = 0;
            not_frame(d, d->buf, 1); /* a lone SYNC0, not a candidate: nothing is counted as rejected */
            return 1;
        }
    }
    size_t need = UB_FRAME_HEADER_LEN;
    uint32_t header_crc = 0;
    size_t frame_len = 0;
    ub_rx_reason_t why = HEADER_OK;
    for (;;) {
        if (d->have < need) {
            size_t take = need - d->have;
            if (take > len - *pos) take = len - *pos;
            memcpy(d->buf + d->have, data + *pos, take);
            d->have += take;
            *pos += take;
            taken += take;
            if (d->have < need) return 0;
        }
        if (need == UB_FRAME_HEADER_LEN) {
            why = judge_header(d->buf, &header_crc, &frame_len);
            if (why != HEADER_OK) break;
            need = frame_len;
            if (d->have < need) continue;
        }
        if (!body_crc_ok(d->buf, frame_len, header_crc)) {
            why = UB_RX_BAD_CRC;
            break;
        }
        deliver(d, d->buf, frame_len, cb, user);
        (*delivered)++;
        /* Old bytes past this frame (left from an earlier rejection) are searched now. */
        d->have -= frame_len;
        memmove(d->buf, d->buf + frame_len, d->have);
        rescan_buffer(d, 0);
        return 1;
    }
    d->stats.rejected[why]++;
    d->have -= taken;
    *pos -= taken;
    rescan_buffer(d, 1); /* the rejected sync byte is not a frame; the search resumes after it */
    return 1;
}

/* Searches data[pos, len) in place; whole frames are verified where they lie. Leaves
 * an unfinished candidate (shorter than its frame, so it fits) in the buffer. The bytes
 * between frames, rejected candidates' sync bytes included, form one run [run, pos)
 * handed on when a frame is found, a candidate is held, or the chunk ends. */
static __attribute__((noinline)) size_t scan_in_place(ub_decoder_t *d, const uint8_t *data, size_t len, size_t pos, ub_frame_cb cb,
                            void *user) {
    size_t delivered = 0;
    size_t run = pos;
    while (pos < len) {
        /* Frames arrive back to back, so the next one usually starts right here: one byte compare instead of
         * a memchr() call (about 18 instructions a frame); the search runs only between frames. */
        if (data[pos] != UB_SYNC0) {
            const uint8_t *hit = memchr(data + pos, UB_SYNC0, len - pos);
            if (hit == NULL) {
                pos = len;
                break;
            }
            pos = (size_t)(hit - data);
        }
        size_t rest = len - pos;
        if (rest >= 2 && data[pos + 1] != UB_SYNC1) {
            pos++;
            continue;
        }
        if (rest < UB_FRAME_HEADER_LEN) break; /* held below */
        size_t frame_len = check_frame(data + pos, rest);
        if (frame_len == FRAME_SHORT) break; /* held below */
        if (frame_len < UB_FRAME_HEADER_LEN) { /* a rejection reason */
            d->stats.rejected[frame_len]++;
            pos++;
            continue;
        }
        not_frame(d, data + run, pos - run);
        deliver(d, data + pos, frame_len, cb, user);
        delivered++;
        pos += frame_len;
        run = pos;
    }
    not_frame(d, data + run, pos - run);
    if (pos < len) { /* an unfinished candidate: shorter than its frame, so it fits */
        memcpy(d->buf, data + pos, len - pos);
        d->have = len - pos;
    }
    return delivered;
}

/* ub_decoder_feed() past its first frame, or from a carried candidate: out of line, so the common case below
 * (a chunk that starts with a whole frame) saves no registers for the loops. */
static __attribute__((noinline)) size_t feed_carried(ub_decoder_t *d, const uint8_t *data, size_t len, ub_frame_cb cb,
                                                     void *user) {
    size_t delivered = 0;
    size_t pos = 0;
    while (d->have > 0) {
        if (!advance_carried(d, data, len, &pos, cb, user, &delivered)) return delivered;
    }
    return delivered + scan_in_place(d, data, len, pos, cb, user);
}

size_t ub_decoder_feed(ub_decoder_t *d, const uint8_t *data, size_t len, ub_frame_cb cb, void *user) {
    /* An empty chunk decides nothing (a carried candidate is always short of its next verdict), and NULL + 0 or
     * memcpy(p, NULL, 0) further in would be undefined behaviour: (NULL, 0) is allowed and returns here. */
    if (d == NULL || data == NULL || len == 0) return 0;
    d->stats.bytes_in += len;
    /* Nothing carried and a valid frame at the chunk's start (a datagram, a read that ended on a frame
     * boundary): delivered here, the rest of the chunk scanned after it -- what scan_in_place() does with its
     * first frame, without its loop's setup. Anything else (a rejected or unfinished candidate, bytes before a
     * sync) goes the general way, which judges the candidate again and counts it there, once. */
    if (d->have == 0 && len >= UB_FRAME_HEADER_LEN && ub_get_u16le(data) == (UB_SYNC0 | UB_SYNC1 << 8)) {
        size_t frame_len = check_frame(data, len);
        if (frame_len >= UB_FRAME_HEADER_LEN) {
            deliver(d, data, frame_len, cb, user);
            return frame_len == len ? 1u : 1u + scan_in_place(d, data, len, frame_len, cb, user);
        }
    }
    return feed_carried(d, data, len, cb, user);
}
