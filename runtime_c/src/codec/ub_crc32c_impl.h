/**
 * @file ub_crc32c_impl.h
 * @brief Private: the two CRC-32C implementations behind ub_crc32c_update(),
 *        exposed so tests and the benchmark can check them against each other.
 *        Not part of the public API; include only from runtime_c/src, tests and tools.
 *
 * Both functions have ub_crc32c_update()'s contract: `crc` is a previous result
 * (0 to start), `data` may be NULL only when `len` is 0.
 */
#ifndef UB_CRC32C_IMPL_H
#define UB_CRC32C_IMPL_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/** Slicing-by-8 over a `static const` table; correct on every host. */
uint32_t ub_crc32c_update_portable(uint32_t crc, const uint8_t *data, size_t len);

/** 1 when this CPU has CRC-32C instructions this build can use (SSE4.2, ARMv8 CRC), else 0. */
int ub_crc32c_hw_available(void);

/**
 * The hardware path, 8 bytes per instruction. Call only when
 * ub_crc32c_hw_available() returns 1; otherwise it falls back to the portable path.
 */
uint32_t ub_crc32c_update_hw(uint32_t crc, const uint8_t *data, size_t len);

/**
 * CRC-32C (finished, started from 0) of bytes [4,60) of a 64-byte frame header
 * given as eight little-endian words: word k holds bytes [8k, 8k+8), byte 8k in
 * its low 8 bits. Equal to ub_crc32c(bytes + 4, 56) on the encoded bytes; it
 * exists so ub_frame_finish() can check the header from registers instead of
 * re-reading bytes it has just stored (see ub_frame.c).
 */
uint32_t ub_crc32c_header_words(const uint64_t words[8]);

/**
 * Both checks of a frame in one call: the header CRC as ub_crc32c_header_words() gives it, in *header_crc,
 * and, returned, that CRC continued over the frame's `body_len` body bytes (payload, trailer), the message
 * CRC. ub_frame_finish() builds every frame with it: one dispatch and one unbroken instruction chain.
 */
uint32_t ub_crc32c_frame_words(const uint64_t words[8], const uint8_t *body, size_t body_len, uint32_t *header_crc);

/**
 * The checks of a frame built from a header template (ub_frame_tpl_t): `crc_head` is the CRC-32C
 * (finished, started from 0) of header bytes [4,52), which a row's template holds; `tail` is header bytes
 * [52,60) (seq, fingerprint) as a little-endian word. Returns the CRC of [4,60) (the header CRC) in the low
 * 32 bits and that CRC continued over the `body_len` body bytes (the message CRC) in the high 32 bits: the
 * same two values ub_crc32c_frame_words() gives for the whole header, with 6 of its 7 header steps done once
 * per row. (One return value rather than an out-parameter: both stay in registers.)
 */
uint64_t ub_crc32c_frame_tail(uint32_t crc_head, uint64_t tail, const uint8_t *body, size_t body_len);

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <nmmintrin.h>
#include <string.h>
/**
 * The SSE4.2 steps over `len` bytes from the register `c` (no inversion either side): 16 bytes a loop trip up
 * to `end16` (== data + (len & ~15), which a template keeps precomputed), then at most one 8-, 4-, 2- and
 * 1-byte step. One body for ub_crc32c_update_hw() and the template build: 16 bytes a trip pays one compare
 * and branch per two steps, and a 28-byte ATTITUDE payload is one trip and three single steps.
 */
__attribute__((target("sse4.2"), always_inline)) static inline uint32_t ub_crc32c_steps_sse42(
    uint64_t c, const uint8_t *data, size_t len, const uint8_t *end16) {
    while (data != end16) {
        uint64_t w0, w1;
        memcpy(&w0, data, sizeof w0); /* x86 is little-endian, as the CRC wants */
        memcpy(&w1, data + 8, sizeof w1);
        c = _mm_crc32_u64(_mm_crc32_u64(c, w0), w1);
        data += 16;
    }
    data = end16; /* the same pointer; said so the compiler does not recompute it from the trip count */
    if (len & 8) {
        uint64_t word;
        memcpy(&word, data, sizeof word);
        c = _mm_crc32_u64(c, word);
        data += 8;
    }
    uint32_t c32 = (uint32_t)c;
    if (len & 4) {
        uint32_t word;
        memcpy(&word, data, sizeof word);
        c32 = _mm_crc32_u32(c32, word);
        data += 4;
    }
    if (len & 2) {
        uint16_t word;
        memcpy(&word, data, sizeof word);
        c32 = _mm_crc32_u16(c32, word);
        data += 2;
    }
    if (len & 1) c32 = _mm_crc32_u8(c32, *data);
    return c32;
}

/**
 * ub_crc32c_header()'s SSE4.2 body, inline for callers compiled with target("sse4.2") themselves (the
 * decoder's frame check): bytes [4,60) of the header at `f` as seven 8-byte steps, no loop (the instruction
 * takes unaligned words, and a CRC does not care where its steps split the bytes). Returns the register before
 * the final inversion (the header CRC is its complement), as the instruction leaves it: zero-extended to 64
 * bits, so ub_crc32c_steps_sse42() continues from it with no conversion.
 */
__attribute__((target("sse4.2"), always_inline)) static inline uint64_t ub_crc32c_header_reg_sse42(const uint8_t *f) {
    uint64_t w64, c = 0xFFFFFFFFu;
#define UB_HDR_STEP(off) (memcpy(&w64, f + (off), sizeof w64), c = _mm_crc32_u64(c, w64))
    UB_HDR_STEP(4); /* written out: -O2 keeps a 7-trip loop as a loop */
    UB_HDR_STEP(12);
    UB_HDR_STEP(20);
    UB_HDR_STEP(28);
    UB_HDR_STEP(36);
    UB_HDR_STEP(44);
    UB_HDR_STEP(52);
#undef UB_HDR_STEP
    return c;
}

/**
 * ub_crc32c_frame_tail()'s SSE4.2 body, inline for callers compiled with target("sse4.2") themselves
 * (ub_frame_tpl_finish's hardware path), so the template's whole build is one function with no call
 * (returns the message CRC, *header_reg the header CRC's register before the final inversion -- the header
 * CRC is its complement -- inlined, both stay in registers): the tail word from the template's register, then
 * the body's steps. Call only when ub_crc32c_hw_available().
 */
__attribute__((target("sse4.2"), always_inline)) static inline uint32_t ub_crc32c_frame_tail_sse42(
    uint32_t head_reg, uint64_t tail, const uint8_t *body, size_t len, size_t len16, uint32_t *header_reg) {
    uint64_t c = _mm_crc32_u64(head_reg, tail);
    *header_reg = (uint32_t)c; /* not inverted: the header CRC is ~*header_reg (its fold is the same, see callers) */
    return ~ub_crc32c_steps_sse42(c, body, len, body + len16);
}
#endif

/**
 * The bare CRC-32C register `reg` (no initial or final inversion: the state between two bytes) advanced over
 * `n` zero bytes, without reading memory. Used to move a checksum difference to where the message ends
 * (ub_frame_patch_hop_limit(): CRC linearity).
 */
uint32_t ub_crc32c_zeros(uint32_t reg, size_t n);

/**
 * The register difference a one-byte change makes, for patching checks by linearity: with d the XOR of the
 * old and new byte, returns R(d, 0) advanced over `to_end1 + to_end2` zero bytes and sets *delta1 to it
 * advanced over `to_end1` only (R(m, s): the register after bytes m from state s). A CRC whose range ends
 * `to_end1` bytes after the changed byte changes by *delta1; one whose range ends `to_end2` bytes later by
 * the return value. One dispatch, a table lookup and two or three carry-less multiplications.
 */
uint32_t ub_crc32c_byte_delta(uint8_t d, size_t to_end1, size_t to_end2, uint32_t *delta1);

/**
 * ub_crc32c(frame + 4, 56): the CRC of the header bytes both checks cover, read from a frame in memory, as
 * the decoder judges every candidate. The hardware path is 8 unrolled steps (4 + 6 x 8 + 4 bytes) with no
 * loop; the result is the same as ub_crc32c_update(0, frame + 4, 56) on every path.
 */
uint32_t ub_crc32c_header(const uint8_t *frame);

#ifdef __cplusplus
}
#endif
#endif /* UB_CRC32C_IMPL_H */
