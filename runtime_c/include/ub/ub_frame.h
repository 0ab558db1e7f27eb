/**
 * @file ub_frame.h
 * @brief The publish/subscribe frame: build, verify, and a streaming decoder.
 *
 * Byte layout (little-endian; diagram and rationale in docs/wire-format.md):
 *
 *   off len field
 *    0   2  sync            0xA5 0x5B
 *    2   1  hdr_check       CRC-32C of bytes [4,60), folded to 8 bits (XOR of its 4 bytes)
 *    3   1  version         low nibble UB_WIRE_VERSION, high nibble flags (UB_FRAME_FLAG_*)
 *    4   2  msg_type        UB_MSG_TYPE_PUBSUB (the datalink's message type)
 *    6   2  msg_size        whole frame: 64 + payload_size + trailer length (from the flags)
 *    8  16  dir_id          content ("uniqueDirID")
 *   24  12  dest_id         destination entity ("uniqueDestID")
 *   36  12  src_id          source entity ("uniqueSrcID")
 *   48   1  admin           admin code (ub_admin_code_t)
 *   49   1  hop_limit       decremented by each forwarder; 0 is never sent
 *   50   2  payload_size
 *   52   4  seq             per-source sequence number
 *   56   4  fingerprint     layout fingerprint of the content type (0 if none)
 *   60   4  msg_crc         CRC-32C (Castagnoli) of bytes [4,60), then the payload and the trailer
 *   64   n  payload         (ciphertext when ENCRYPTED)
 * 64+n   t  trailer         only when flagged: key_id u8 | counter_hi u16 | tag (8 B SIGNED, 16 B ENCRYPTED),
 *                           then, with ORIGIN, hop0 u8 | origin tag[8]
 *
 * Frames without flags are exactly the frames of wire version 1 (no trailer).
 * This codec checks the flags and sizes only; the trailer's tag is made and
 * verified by ub_sec.h, which calls ub_frame_finish() after writing the trailer.
 *
 * Both checks come from one CRC pass: the CRC-32C of bytes [4,60) (a finished
 * CRC, i.e. after the final XOR) folds to `hdr_check`; continuing that CRC
 * over the payload (and trailer) with ub_crc32c_update() gives `msg_crc`. The version byte
 * and the sync bytes are not under a check: they are compared with constants.
 *
 * Building a frame (the payload is packed in place, so nothing is copied):
 *
 *     uint8_t frame[UB_FRAME_MAX];
 *     int n = type->pack(obj, frame + UB_FRAME_HEADER_LEN, UB_MAX_PAYLOAD);
 *     if (n < 0) return n;
 *     ub_frame_header_t h = {.admin = UB_ADMIN_DATA, .hop_limit = UB_DEFAULT_HOP_LIMIT,
 *                            .payload_size = (uint16_t)n, .seq = next_seq++,
 *                            .fingerprint = type->fingerprint};
 *     memcpy(h.dir_id, inst->id, UB_DIR_ID_LEN);  // and dest_id, src_id
 *     int len = ub_frame_finish(frame, sizeof frame, &h);  // total length or < 0
 *
 * Receiving from a byte stream:
 *
 *     ub_decoder_t dec;                  // caller-owned, ~1.1 KiB
 *     ub_decoder_init(&dec);
 *     ... on every read(): ub_decoder_feed(&dec, bytes, n, on_frame, ctx);
 *
 * The decoder is a pure state machine: no I/O, no allocation, no globals. Feed
 * it any chunking of a byte stream; it calls back once per verified frame and
 * counts every rejection by reason. Every function here is reentrant on
 * distinct objects; none keeps state outside its arguments.
 */
#ifndef UB_FRAME_H
#define UB_FRAME_H

#include <stddef.h>
#include <stdint.h>
#include "ub_catalogue.h"
#include "ub_config.h"
#include "ub_error.h"

#ifdef __cplusplus
extern "C" {
#endif

#define UB_SYNC0 0xA5u
#define UB_SYNC1 0x5Bu
#define UB_WIRE_VERSION 1u
#define UB_MSG_TYPE_PUBSUB 0x5053u /* "PS" */
#define UB_FRAME_HEADER_LEN 64u

/* Flags: the high nibble of the version byte (docs/wire-format.md, "Flags and trailer"). */
#define UB_FRAME_FLAG_SIGNED 0x10u    /**< a SIGNED trailer follows the payload */
#define UB_FRAME_FLAG_ENCRYPTED 0x20u /**< payload is AEAD ciphertext; an ENCRYPTED trailer follows */
#define UB_FRAME_FLAG_ORIGIN 0x80u    /**< an origin block follows the trailer; only with SIGNED or ENCRYPTED (docs/security.md,
                                           "Origin authentication"); the hop tag then covers hop_limit and the block */
#define UB_FRAME_FLAG_PROTECT_MASK 0x30u /**< SIGNED | ENCRYPTED: the hop protection of a flags value */
#define UB_FRAME_FLAGS_MASK 0xF0u     /**< 0x40 is reserved: a frame with it is BAD_VERSION */
#define UB_FRAME_VERSION_MASK 0x0Fu
/* Trailer: key_id u8 | counter_hi u16 LE | tag. */
#define UB_FRAME_SIG_TAG_LEN 8u
#define UB_FRAME_AEAD_TAG_LEN 16u
#define UB_FRAME_SIG_TRAILER_LEN (3u + UB_FRAME_SIG_TAG_LEN)   /* 11 */
#define UB_FRAME_AEAD_TRAILER_LEN (3u + UB_FRAME_AEAD_TAG_LEN) /* 19 */
/* Origin block, after the trailer of an ORIGIN frame: hop0 u8 (the hop limit its origin sent) | origin tag[8]. */
#define UB_FRAME_ORIGIN_TAG_LEN 8u
#define UB_FRAME_ORIGIN_LEN (1u + UB_FRAME_ORIGIN_TAG_LEN) /* 9 */
#define UB_FRAME_TRAILER_MAX (UB_FRAME_AEAD_TRAILER_LEN + UB_FRAME_ORIGIN_LEN)
#define UB_FRAME_TRL_OFF_KEY_ID 0u
#define UB_FRAME_TRL_OFF_COUNTER_HI 1u
#define UB_FRAME_TRL_OFF_TAG 3u

/** Largest frame: header, largest payload, largest trailer. */
#define UB_FRAME_MAX (UB_FRAME_HEADER_LEN + UB_MAX_PAYLOAD + UB_FRAME_TRAILER_MAX)

/* Field offsets, for code that reads one field of a verified frame in place. */
#define UB_FRAME_OFF_HDR_CHECK 2u
#define UB_FRAME_OFF_VERSION 3u
#define UB_FRAME_OFF_MSG_TYPE 4u
#define UB_FRAME_OFF_MSG_SIZE 6u
#define UB_FRAME_OFF_DIR_ID 8u
#define UB_FRAME_OFF_DEST_ID 24u
#define UB_FRAME_OFF_SRC_ID 36u
#define UB_FRAME_OFF_ADMIN 48u
#define UB_FRAME_OFF_HOP_LIMIT 49u
#define UB_FRAME_OFF_PAYLOAD_SIZE 50u
#define UB_FRAME_OFF_SEQ 52u
#define UB_FRAME_OFF_FINGERPRINT 56u
#define UB_FRAME_OFF_MSG_CRC 60u
/** The header bytes both checks cover: [UB_FRAME_CHECKED_OFF, UB_FRAME_CHECKED_OFF + UB_FRAME_CHECKED_LEN). */
#define UB_FRAME_CHECKED_OFF 4u
#define UB_FRAME_CHECKED_LEN 56u

/** Admin codes (docs/wire-format.md, "Admin codes and payloads"). */
typedef enum ub_admin_code {
    UB_ADMIN_DATA = 0,        /**< payload is a packed directory instance */
    UB_ADMIN_PUB_REQUEST = 1, /**< add/renew a publication at the source entity */
    UB_ADMIN_SUB_REQUEST = 2, /**< add/renew a subscription at the destination entity */
    UB_ADMIN_PUB_STOP = 3,    /**< remove a publication at the source entity */
    UB_ADMIN_SUB_STOP = 4,    /**< remove a subscription at the destination entity */
    UB_ADMIN_ACK = 5,         /**< a table-change request was applied */
    UB_ADMIN_NACK = 6,        /**< a table-change request was refused (reason in payload) */
    UB_ADMIN_CHALLENGE = 7,   /**< freshness challenge: payload = 16-byte nonce (docs/security.md) */
    UB_ADMIN_CHALLENGE_REPLY = 8, /**< answer to a challenge: payload = the nonce echoed; its counter is fresh */
    UB_ADMIN_HELLO = 9,        /**< routing: link-local hello + IHU (docs/routing.md); never forwarded */
    UB_ADMIN_ROUTE_UPDATE = 10, /**< routing: link-local hello + route entries + seqno requests; never forwarded */
    UB_ADMIN_MEMBERSHIP = 11,   /**< an administrator's membership change (ub_member.h); answered by ACK/NACK */
    UB_ADMIN_INSPECT = 12,      /**< remote inspection request (ub_inspect.h); answered by INSPECT_VALUE, ACK or NACK */
    UB_ADMIN_INSPECT_VALUE = 13, /**< the value or table page answering an INSPECT read or list (docs/inspect.md) */
    UB_ADMIN_LINK_HELLO = 20,   /**< compact links: link-local dictionary announcement (ub_compact.h); never forwarded */
    UB_ADMIN_FRAGMENT = 21,     /**< one numbered fragment of a large DATA directory (ub_frag.h), end to end */
    UB_ADMIN_REVOCATION = 24,   /**< an authority-signed revocation record (ub_revoke.h); link-local, spread hop by hop */
    UB_ADMIN_CERTIFICATE = 25   /**< an authority-signed certificate (ub_revoke.h); link-local, spread hop by hop */
} ub_admin_code_t;

/**
 * Host form of a frame header. ub_frame_finish() reads it (and fills in the
 * checks, sizes, sync, version and message type itself); ub_frame_parse()
 * and the decoder fill every field.
 */
typedef struct ub_frame_header {
    uint16_t msg_type; /**< filled by parse; ignored by finish, which always writes UB_MSG_TYPE_PUBSUB */
    uint8_t flags;     /**< 0, UB_FRAME_FLAG_SIGNED or UB_FRAME_FLAG_ENCRYPTED, either maybe | UB_FRAME_FLAG_ORIGIN */
    uint8_t dir_id[UB_DIR_ID_LEN];
    uint8_t dest_id[UB_ENTITY_ID_LEN];
    uint8_t src_id[UB_ENTITY_ID_LEN];
    uint8_t admin;
    uint8_t hop_limit; /**< 1..255 on the wire; finish refuses 0 */
    uint16_t payload_size;
    uint32_t seq;        /**< low 32 bits of the sender's counter */
    uint32_t fingerprint;
    /* From the trailer (parse fills them; 0 without flags). finish ignores them: ub_sec writes the trailer. */
    uint8_t key_id;
    uint16_t counter_hi; /**< high 16 bits of the 48-bit counter */
    /* From the origin block (parse fills them with ORIGIN; else 0). ub_sec_protect() writes them when h->flags has ORIGIN. */
    uint8_t origin_hop0;                           /**< the hop limit the origin sent */
    uint8_t origin_tag[UB_FRAME_ORIGIN_TAG_LEN];   /**< the origin tag (ub_origin.h) */
} ub_frame_header_t;

/** @return the trailer length that `flags` imply: 0, UB_FRAME_SIG_TRAILER_LEN or UB_FRAME_AEAD_TRAILER_LEN; 0 also for an invalid combination. */
static inline size_t ub_frame_trailer_len(uint8_t flags) {
    size_t origin = (flags & UB_FRAME_FLAG_ORIGIN) ? UB_FRAME_ORIGIN_LEN : 0u;
    flags &= (uint8_t)~UB_FRAME_FLAG_ORIGIN;
    return flags == UB_FRAME_FLAG_SIGNED ? UB_FRAME_SIG_TRAILER_LEN + origin
         : flags == UB_FRAME_FLAG_ENCRYPTED ? UB_FRAME_AEAD_TRAILER_LEN + origin : 0u;
}

/** @return whether `flags` (high nibble of the version byte) is one this codec accepts: none, SIGNED or ENCRYPTED,
 *  the latter two maybe with ORIGIN. */
static inline int ub_frame_flags_valid(uint8_t flags) {
    uint8_t prot = flags & (uint8_t)~UB_FRAME_FLAG_ORIGIN;
    return flags == 0u || prot == UB_FRAME_FLAG_SIGNED || prot == UB_FRAME_FLAG_ENCRYPTED;
}

/** @return the 48-bit freshness counter of a parsed header: counter_hi << 32 | seq. */
static inline uint64_t ub_frame_counter(const ub_frame_header_t *h) {
    return (uint64_t)h->counter_hi << 32 | h->seq;
}

/**
 * Completes a frame whose payload the caller has already written at
 * `frame + UB_FRAME_HEADER_LEN` (so pack writes straight into the frame, with
 * no copy): writes the header from `h`, then both checks. With h->flags set,
 * the trailer must already follow the payload (ub_sec_protect() writes it and
 * calls this). Reads exactly `h->payload_size` + trailer bytes after the header
 * and writes only bytes [0, 64) of `frame`.
 * @return total frame length (64 + payload_size + trailer), UB_ERR_INVAL if
 *         `frame` or `h` is NULL or h->flags is not 0, SIGNED or ENCRYPTED,
 *         UB_ERR_NOSPACE if `cap` is too small, or UB_ERR_RANGE if
 *         h->payload_size > UB_MAX_PAYLOAD or h->hop_limit == 0.
 */
UB_CHECK int ub_frame_finish(uint8_t *frame, size_t cap, const ub_frame_header_t *h);

/**
 * Verifies one complete frame of exactly `len` bytes and decodes its header
 * into `h` (which may be NULL to verify only; `h` is written only on UB_OK).
 * Never reads outside [frame, frame + len).
 * A flagged frame's trailer fields (key_id, counter_hi) are read into `h`;
 * its tag is NOT checked here (ub_sec_verify() does that).
 * @return UB_OK; UB_ERR_TRUNCATED (`len` shorter than the header or than
 *         msg_size); UB_ERR_CHECKSUM (header check or message CRC mismatch);
 *         UB_ERR_INVAL (NULL `frame`, bad sync, version, flags or message type,
 *         msg_size inconsistent with payload_size and the flags' trailer, or
 *         above UB_FRAME_MAX, or `len` longer than msg_size).
 */
UB_CHECK int ub_frame_parse(const uint8_t *frame, size_t len, ub_frame_header_t *h);

/** Why the decoder rejected bytes; indexes ub_decoder_stats_t.rejected[]. */
typedef enum ub_rx_reason {
    UB_RX_BAD_HDR_CHECK = 0, /**< header check byte mismatch */
    UB_RX_BAD_CRC,           /**< message CRC mismatch (corrupt payload, truncation, lying length) */
    UB_RX_BAD_LENGTH,        /**< msg_size != 64 + payload_size + trailer, or payload above UB_MAX_PAYLOAD; datagram size != msg_size */
    UB_RX_BAD_VERSION,       /**< unknown wire version, reserved or unknown flags, or unknown message type */
    UB_RX_BAD_SYNC,          /**< datagram not starting with the sync bytes (the stream decoder counts these as garbage_bytes) */
    UB_RX_NO_DICTIONARY,     /**< compact packet with an index this end cannot expand (ub_compact.h): the peer's catalogue or list not held */
    UB_RX_NO_REFERENCE,      /**< compact packet with a 16-bit sequence from a source this link holds no reference for */
    UB_RX_REASON_COUNT
} ub_rx_reason_t;

/** @return a static name for a reason ("bad_hdr_check", ...), or "?" when out of range. */
const char *ub_rx_reason_name(ub_rx_reason_t reason);

/**
 * ub_frame_parse() for datagram transports, which must count rejections by
 * reason as the stream decoder does. Same checks, same order, same returns;
 * on failure `*reason` (if not NULL) says why: bad sync -> UB_RX_BAD_SYNC; a
 * datagram shorter than the header, or whose size differs from msg_size ->
 * UB_RX_BAD_LENGTH; otherwise the decoder's reason for the same bytes.
 */
UB_CHECK int ub_frame_parse_reason(const uint8_t *frame, size_t len, ub_frame_header_t *h, ub_rx_reason_t *reason);

/**
 * Rewrites the hop limit of a verified frame in place and recomputes both
 * checks (they cover the hop limit), for forwarders. A flagged frame's tag
 * does not cover the hop limit, so no key is needed. The caller must have
 * verified the frame (decoder or ub_frame_parse()): this function recomputes
 * the checks and does not re-verify the old ones.
 * @return UB_OK; UB_ERR_RANGE if `hop_limit` is 0; UB_ERR_INVAL if `frame` is
 *         NULL or `len` is not the frame's msg_size.
 */
UB_CHECK int ub_frame_set_hop_limit(uint8_t *frame, size_t len, uint8_t hop_limit);

/**
 * Forwarder's fast path: lowers (or sets) the hop limit of a frame whose checks are known good and updates
 * both checks by CRC linearity in a few register steps (no pass over the frame). Same bytes as
 * ub_frame_set_hop_limit() on a verified frame; on a frame whose checks were wrong they stay wrong (it
 * never turns a damaged frame into a valid one). For frames received and verified by the decoder or
 * ub_frame_parse(); ub_frame_set_hop_limit() remains for re-sealing bytes of unknown state.
 * @return UB_OK; UB_ERR_RANGE if `hop_limit` is 0; UB_ERR_INVAL if `frame` is NULL or `len` is not the
 *         frame's msg_size.
 */
UB_CHECK int ub_frame_patch_hop_limit(uint8_t *frame, size_t len, uint8_t hop_limit);

/**
 * The checks' change for one hop-limit change, kept for the next frame (ub_frame_copy_hop_limit()): it depends
 * only on the old and new hop limit and the frame's length, which all frames of a flow through a forwarder
 * share, so it is computed once per flow instead of once per frame. Caller-owned (a node keeps one); zeroed =
 * empty (no frame has length 0). Treat the fields as private.
 */
typedef struct ub_frame_hop_memo {
    uint32_t msg_delta; /* XORed into msg_crc */
    uint16_t len;       /* the frame length it is for; 0: empty */
    uint8_t d;          /* old hop limit ^ new hop limit */
    uint8_t hdr_delta;  /* XORed into hdr_check */
} ub_frame_hop_memo_t;

/**
 * ub_frame_patch_hop_limit() into a copy: writes the `len` bytes of `src` to `dst` with the hop limit set to
 * `hop_limit` and both checks patched, the same bytes as copying and then ub_frame_patch_hop_limit() (a frame
 * whose checks were wrong stays wrong). The forwarder's one step from a received frame to the one it sends.
 * `memo` (may be NULL) holds the last change's deltas: the same change on a frame of the same length reuses
 * them, another one replaces them. `dst` and `src` must not overlap.
 * @return UB_OK; UB_ERR_RANGE if `hop_limit` is 0; UB_ERR_INVAL if `dst` or `src` is NULL or `len` is not
 *         the frame's msg_size (then nothing is written).
 */
UB_CHECK int ub_frame_copy_hop_limit(uint8_t *dst, const uint8_t *src, size_t len, uint8_t hop_limit,
                                     ub_frame_hop_memo_t *memo);

/**
 * A per-row header template: the header bytes a row's frames share (everything but seq and the two checks)
 * and the CRC-32C state over header bytes [4,52), which hold only such constant fields. Building a frame
 * from it runs the CRC over 8 header bytes (seq, fingerprint) and the payload instead of the whole header.
 * Caller-owned (keep one in the row's state, next to its sequence counter); no pointers inside, so it may be
 * copied. Plain frames only (flags 0): protected frames are built by ub_sec_protect().
 * Treat the fields as private.
 */
typedef struct ub_frame_tpl {
    uint8_t header[UB_FRAME_HEADER_LEN]; /* the header bytes with seq and both checks zero */
    uint64_t fingerprint_hi;             /* the fingerprint << 32: header bytes [52,60) are seq | this */
    uint32_t head_reg;                   /* ~ub_crc32c() of header bytes [4,52): the CRC register there (no
                                            final inversion), from which the next step continues as is */
    size_t fast_len;                     /* the frame length (64 + payload_size), compared with the caller's
                                            room as is: no length arithmetic per frame */
    size_t fast_len16;                   /* payload_size & ~15: where the CRC's 16-byte steps end */
    uint32_t fast_size;                  /* payload_size where the CPU has the hardware CRC, else a value no
                                            uint16_t equals: one compare picks the fast build */
    uint16_t payload_size;               /* the payload size header[] and head_reg are primed for */
} ub_frame_tpl_t;

/** Defined where the frame layer has header templates (bench code built against older runtimes tests it). */
#define UB_FRAME_TPL 1

/**
 * Primes `t` from `h` (its seq, key_id, counter_hi and origin fields are ignored).
 * @return UB_OK; UB_ERR_INVAL if `t` or `h` is NULL or h->flags is not 0; UB_ERR_RANGE if
 *         h->payload_size > UB_MAX_PAYLOAD or h->hop_limit == 0.
 */
UB_CHECK int ub_frame_tpl_init(ub_frame_tpl_t *t, const ub_frame_header_t *h);

/**
 * ub_frame_finish() from a template: the payload (`payload_size` bytes) is already at
 * `frame + UB_FRAME_HEADER_LEN`; writes the 64 header bytes with `seq` and both checks. The bytes are
 * those ub_frame_finish() writes for the template's header with that payload size and seq. A payload size
 * other than the one `t` was primed for re-primes `t` first (one ub_frame_finish()'s worth of work), so a
 * variable-size type is still right, only not faster.
 * @return total frame length (64 + payload_size); UB_ERR_INVAL if `t` or `frame` is NULL; UB_ERR_RANGE if
 *         payload_size > UB_MAX_PAYLOAD; UB_ERR_NOSPACE if `cap` is too small.
 */
static inline UB_CHECK int ub_frame_tpl_finish(ub_frame_tpl_t *t, uint8_t *frame, size_t cap, uint16_t payload_size,
                                               uint32_t seq);

/* The two halves of ub_frame_tpl_finish(), not API (call ub_frame_tpl_finish()): _primed builds a frame of the
 * size `t` is primed for with room checked (x86-64: the SSE4.2 build, taken only where tpl_prime() found the
 * instruction at run time, as t->fast_size says); _other everything else (re-priming, the portable CRC, the
 * errors). */
UB_CHECK int ub_frame_tpl_finish_primed(const ub_frame_tpl_t *t, uint8_t *frame, size_t cap, uint16_t payload_size,
                                        uint32_t seq);
UB_CHECK int ub_frame_tpl_finish_other(ub_frame_tpl_t *t, uint8_t *frame, size_t cap, uint16_t payload_size,
                                       uint32_t seq);

/* Inline, so a row's build has no call and no dispatch of its own before the finish: a primed size on a CPU
 * with the hardware CRC is one compare against fast_size (tpl_prime() folds the run-time CPU test into it:
 * a value no uint16_t equals where there is none), then the room check. */
static inline UB_CHECK int ub_frame_tpl_finish(ub_frame_tpl_t *t, uint8_t *frame, size_t cap, uint16_t payload_size,
                                               uint32_t seq) {
    if (t == NULL || frame == NULL) return UB_ERR_INVAL;
    if (payload_size == t->fast_size && cap >= t->fast_len)
        return ub_frame_tpl_finish_primed(t, frame, cap, payload_size, seq);
    return ub_frame_tpl_finish_other(t, frame, cap, payload_size, seq);
}

/**
 * ub_frame_finish(frame, cap, h) for a plain header (h->flags 0), through the template `t` used as a cache:
 * when `t` is primed for h's fixed fields (everything but seq; a zeroed `t` matches no header) the build is
 * ub_frame_tpl_finish(); otherwise `t` is primed from `h` first. Same bytes as ub_frame_finish() either way.
 * For senders that hold a few templates and do not know which row a header belongs to (the node's send path).
 * @return total frame length; UB_ERR_INVAL if an argument is NULL or h->flags is not 0; UB_ERR_RANGE if
 *         h->payload_size > UB_MAX_PAYLOAD or h->hop_limit == 0; UB_ERR_NOSPACE if `cap` is too small.
 */
UB_CHECK int ub_frame_tpl_finish_header(ub_frame_tpl_t *t, uint8_t *frame, size_t cap, const ub_frame_header_t *h);

/**
 * Decoder counters. Every byte fed ends up in exactly one place, so
 * `bytes_in == bytes_ok + foreign_bytes + garbage_bytes + ub_decoder_pending(d)` always holds
 * (with no foreign-traffic handler, foreign_bytes stays 0 and these bytes are garbage).
 */
typedef struct ub_decoder_stats {
    uint64_t frames_ok;                     /**< frames delivered to the callback */
    uint64_t bytes_in;                      /**< bytes fed */
    uint64_t bytes_ok;                      /**< bytes of delivered frames */
    uint64_t garbage_bytes;                 /**< bytes dropped (no foreign handler): skipped while hunting for sync, and the sync byte of every rejected candidate */
    uint64_t foreign_bytes;                 /**< the same bytes when a foreign handler is set: handed to it, each exactly once */
    uint64_t foreign_refused;               /**< of foreign_bytes, those the handler did not take (its return below the run's length) */
    uint64_t rejected[UB_RX_REASON_COUNT];  /**< rejected candidate frames, by reason (never UB_RX_BAD_SYNC) */
} ub_decoder_stats_t;

/**
 * The link's foreign-traffic handler (paper section IV: uavbus is one message type among the datalink's
 * others; a GPS or a legacy datalink may share the wire). Called with every run of bytes the decoder does
 * not recognise as part of a uavbus frame, in stream order and interleaved in order with the frame
 * callbacks: the bytes before a frame are handed on before that frame is delivered. Each byte is handed on
 * exactly once; a run may be split (at chunk ends, or where a held candidate turned out not to be a frame),
 * so a handler that parses lines or messages keeps its own partial state. Bytes of a candidate frame still
 * held (ub_decoder_pending()) are handed on only once the candidate is rejected. A delivered frame's bytes
 * are never handed on. `run` is valid only during the call; the handler must not feed the same decoder.
 * @return how many of the `len` bytes it took (a value above `len` counts as `len`); the rest are counted
 *         in foreign_refused (a full buffer, an unknown protocol) and are not offered again.
 */
typedef size_t (*ub_foreign_cb)(void *user, const uint8_t *run, size_t len);
/** Defined where the decoder takes a foreign-traffic handler (code built against older runtimes tests it). */
#define UB_DECODER_FOREIGN 1

/**
 * Called once per verified frame. `frame` points to the whole frame
 * (`frame_len` bytes) and is valid only during the call: either into the
 * caller's input (whole frames are verified in place) or into the decoder's
 * buffer. The callback must not feed the same decoder.
 */
typedef void (*ub_frame_cb)(void *user, const ub_frame_header_t *h, const uint8_t *frame, size_t frame_len);

/** Streaming decoder; caller-owned, no allocation. Treat the fields as private; read `stats`. */
typedef struct ub_decoder {
    uint8_t buf[UB_FRAME_MAX]; /* bytes of an unfinished candidate frame, starting at its sync */
    size_t have;
    ub_foreign_cb foreign; /* NULL: bytes outside frames are garbage */
    void *foreign_user;
    ub_decoder_stats_t stats;
} ub_decoder_t;

/** Empties the decoder, zeroes its counters and removes its foreign-traffic handler. */
void ub_decoder_init(ub_decoder_t *d);

/**
 * Sets (or with `cb` NULL removes) the foreign-traffic handler: from the next byte fed on, bytes outside
 * frames go to `cb(user, ...)` and are counted in foreign_bytes instead of garbage_bytes. Costs nothing per
 * byte: runs are handed over whole, so a pure uavbus stream decodes as fast as without a handler.
 */
void ub_decoder_set_foreign(ub_decoder_t *d, ub_foreign_cb cb, void *user);

/**
 * A new stream starts on the same link (a reconnection, a reopened device): the bytes of a candidate still
 * held cannot be completed and are counted as garbage (the accounting invariant holds); the counters and
 * the foreign-traffic handler are kept.
 */
void ub_decoder_restart(ub_decoder_t *d);

/**
 * For a codec that frames the stream itself but shares this decoder's buffer and counters (the compact
 * encoding, ub_compact.h): `n` bytes that are no frame, in stream order, to the foreign-traffic handler
 * (counted foreign_bytes, foreign_refused) or, without one, counted as garbage. Not for use beside
 * ub_decoder_feed() on the same stream.
 */
void ub_decoder_not_frame(ub_decoder_t *d, const uint8_t *run, size_t n);

/**
 * Feeds `len` bytes (`data` may be NULL only when `len` is 0). Calls `cb`
 * (may be NULL: count only) for each verified frame, in stream order.
 *
 * Every position holding the sync pair that is not inside a delivered frame
 * is tried as a frame start; a candidate is accepted or rejected only once
 * all its bytes are present, so the outcome does not depend on how the
 * stream is chunked. After a rejection the search resumes one byte past the
 * rejected sync, including bytes already buffered, so a valid frame after
 * garbage, a truncated frame or a lying length is still found. A candidate
 * is checked in this order: header check (UB_RX_BAD_HDR_CHECK), version, flags
 * and message type (UB_RX_BAD_VERSION), msg_size/payload_size/trailer
 * (UB_RX_BAD_LENGTH), message CRC (UB_RX_BAD_CRC). Never reads or writes outside `data[0..len)`
 * and `*d`.
 * @return the number of frames delivered by this call (never negative).
 */
size_t ub_decoder_feed(ub_decoder_t *d, const uint8_t *data, size_t len, ub_frame_cb cb, void *user);

/** @return bytes held for an unfinished candidate frame (at most UB_FRAME_MAX - 1). */
size_t ub_decoder_pending(const ub_decoder_t *d);

/**
 * CRC-32C (Castagnoli, reflected polynomial 0x82F63B78, init and final XOR
 * 0xFFFFFFFF) of a buffer: ub_crc32c("123456789", 9) == 0xE3069283. Uses the
 * CPU's CRC instructions when present (x86-64 SSE4.2, ARMv8 CRC), else a
 * table. `data` may be NULL only when `len` is 0.
 */
uint32_t ub_crc32c(const uint8_t *data, size_t len);
/**
 * Continues a CRC-32C: pass the previous result as `crc` (0 to start), so
 * ub_crc32c_update(ub_crc32c(a, n), b, m) is the CRC of a then b.
 */
uint32_t ub_crc32c_update(uint32_t crc, const uint8_t *data, size_t len);

#ifdef __cplusplus
}
#endif
#endif /* UB_FRAME_H */
