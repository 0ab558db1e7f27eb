/**
 * @file ub_compact.h
 * @brief The compact encoding of a frame, for links that need it (57.6 kbit/s radios, 255-byte
 *        packets): the same frame as ub_frame.h, its 64-byte header replaced by a few bytes that
 *        both ends of the link can expand back (docs/wire-format.md, "Compact encoding").
 *
 * A link is set to compact at both ends (config `"encoding": "compact"`, port spec
 * `encoding=compact`, ub_node_link_set_compact()). Inside the node every frame stays the full
 * reference frame: a compact link encodes on send and decodes back to the full frame on receive,
 * so routers translate between compact and full links for free, the frame tap and logs see full
 * frames, and the signature trailer (whose tag covers the canonical header, not the encoding) is
 * carried unchanged.
 *
 * Packet (before byte stuffing), all integers little-endian:
 *
 *     ctl0    u8   bits 0-3 hop limit (1..15; 0: a hop byte follows), bits 4-5 protection
 *                  (0 none, 1 SIGNED, 2 ENCRYPTED), bit 6 ADMIN (an admin byte follows; clear: DATA),
 *                  bit 7 EXT (ctl1 follows)
 *    [ctl1]  u8   bit 0 DIR_FULL, bit 1 DEST_FULL, bit 2 SRC_FULL, bit 3 SEQ32, bit 4 ENT_WIDE,
 *                  bit 5 ORIGIN (the frame's ORIGIN flag: an origin block ends its trailer; only with
 *                  protection 1 or 2); bits 6-7 reserved (0). Absent = all clear.
 *    [hop]   u8   when ctl0's hop nibble is 0
 *    [admin] u8   when ADMIN
 *     seq    u16  low 16 bits of the frame's seq; u32 (the whole seq) with SEQ32
 *     content     DIR_FULL: dir_id[16] + fingerprint u32; else a varint v (1 or 2 bytes, 7 bits
 *                  each, low first): 0 = zero dir_id and fingerprint 0, v = instance v-1 of the
 *                  catalogue with its type's fingerprint
 *     entities    neither full and not ENT_WIDE: one byte, dest index | src index << 4;
 *                  else dest (12-byte ID with DEST_FULL, else a 1-byte index), then src likewise
 *     payload     DATA with a content index: trailing zero bytes cut (the type's packed size
 *                  restores them); otherwise all payload_size bytes
 *    [trailer]    the SIGNED (11 B) or ENCRYPTED (19 B) trailer, unchanged
 *     check  u32  CRC-32C of a 16-byte dictionary prefix (catalogue hash when the content is an
 *                  index, else zeros; the sender's entity-list hash when an entity is an index,
 *                  else zeros), then every packet byte before it
 *
 * On the wire every packet is COBS-stuffed and ends with a 0x00 delimiter, on streams (serial,
 * TCP: self-synchronising at the next 0x00) and datagrams alike (one or more whole packets per
 * datagram). Lengths are implicit: the delimiter ends the packet, the flags give the header and
 * trailer sizes. A DATA frame with both entities and its content indexed costs 9 bytes + 2 of
 * stuffing = 11 (MAVLink 2: 12).
 *
 * Dictionaries: each end announces, in LINK_HELLO frames (admin code 20, link-local, signed like
 * any frame), its catalogue hash, a random epoch and its entity table sorted by ID (in pages of
 * UB_COMPACT_PAGE IDs) with the list's hash, and echoes the hash of the peer's list it holds. A
 * sender uses content indices once the peer announced the same catalogue hash, entity indices
 * once the peer echoed its current list hash; anything not in the dictionary goes as a full ID.
 * The check covers the dictionary hashes, so a frame decoded under another dictionary fails its
 * check (counted) instead of being delivered to the wrong entity. Mismatch costs bytes, never
 * correctness.
 *
 * Sequence numbers: a packet carries the low 16 bits; the receiver restores the rest from the
 * last authentic frame of that source on this link (serial arithmetic: right within +-32,767).
 * The sender sends all 32 bits (SEQ32) for the first frame of a source on the link, after a jump
 * of 16,384 or more since the last one it sent, every UB_COMPACT_SEQ32_EVERY frames of a source
 * and after the peer restarted (new epoch). Signed frames take bits 32-47 from their trailer, so
 * a wrong restoration makes the tag fail (`bad_tag`), never a silent mis-delivery.
 *
 * Everything here is a pure function or state in caller-owned structs (no allocation, no
 * globals); the node (ub_node.h) calls it through a narrow interface.
 */
#ifndef UB_COMPACT_H
#define UB_COMPACT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ub_catalogue.h"
#include "ub_config.h"
#include "ub_error.h"
#include "ub_frame.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ctl0 / ctl1 bits (docs/wire-format.md, "Compact encoding"). */
#define UB_COMPACT_HOP_MASK 0x0Fu
#define UB_COMPACT_PROT_SHIFT 4u
#define UB_COMPACT_PROT_MASK 0x30u
#define UB_COMPACT_ADMIN 0x40u
#define UB_COMPACT_EXT 0x80u
#define UB_COMPACT_DIR_FULL 0x01u
#define UB_COMPACT_DEST_FULL 0x02u
#define UB_COMPACT_SRC_FULL 0x04u
#define UB_COMPACT_SEQ32 0x08u
#define UB_COMPACT_ENT_WIDE 0x10u
#define UB_COMPACT_ORIGIN 0x20u
#define UB_COMPACT_CTL1_RESERVED 0xC0u

/** Bytes of the check. */
#define UB_COMPACT_CHECK_LEN 4u
/** Longest packet header: ctl0, ctl1, hop, admin, seq32, dir_id + fingerprint, two full IDs. */
#define UB_COMPACT_HEADER_MAX (1u + 1u + 1u + 1u + 4u + UB_DIR_ID_LEN + 4u + 2u * UB_ENTITY_ID_LEN)
/** Longest packet before stuffing. */
#define UB_COMPACT_PACKET_MAX (UB_COMPACT_HEADER_MAX + UB_MAX_PAYLOAD + UB_FRAME_TRAILER_MAX + UB_COMPACT_CHECK_LEN)
/** COBS-stuffed size of an n-byte packet with its delimiter. */
#define UB_COBS_MAX(n) ((n) + (n) / 254u + 2u)
/** Longest packet on the wire (stuffed, with its delimiter). */
#define UB_COMPACT_WIRE_MAX UB_COBS_MAX(UB_COMPACT_PACKET_MAX)

/** Entities one dictionary lists at most (indices are one byte). */
#ifndef UB_COMPACT_DICT_MAX
#define UB_COMPACT_DICT_MAX (UB_MAX_ENTITIES < 255 ? UB_MAX_ENTITIES : 255)
#endif
/** Entity IDs per LINK_HELLO page (a page must fit a 255-byte radio packet). */
#define UB_COMPACT_PAGE 8u
/** Sources whose sequence a link remembers per direction (least recently used evicted). */
#ifndef UB_COMPACT_REFS
#define UB_COMPACT_REFS UB_DEDUP_SOURCES
#endif
/** A source's frames on a link carry all 32 sequence bits at least this often. */
#define UB_COMPACT_SEQ32_EVERY 128u
/** A sequence jump this large since the last frame sent for a source goes as SEQ32. */
#define UB_COMPACT_SEQ_JUMP 16384u

/* LINK_HELLO payload (admin code UB_ADMIN_LINK_HELLO), little-endian. */
#define UB_COMPACT_HELLO_VERSION 1u
#define UB_COMPACT_HELLO_FIXED 40u /**< bytes before the IDs */
#define UB_CH_OFF_VERSION 0u       /**< u8: UB_COMPACT_HELLO_VERSION */
#define UB_CH_OFF_FIRST 1u         /**< u8: index of the first ID in this page */
#define UB_CH_OFF_COUNT 2u         /**< u8: IDs in this page (0..UB_COMPACT_PAGE) */
#define UB_CH_OFF_TOTAL 3u         /**< u8: IDs in the whole list */
#define UB_CH_OFF_EPOCH 4u         /**< u32: the sender's epoch (random, per start) */
#define UB_CH_OFF_CAT 8u           /**< u64: the sender's catalogue hash */
#define UB_CH_OFF_LIST 16u         /**< u64: the hash of the sender's list */
#define UB_CH_OFF_ECHO 24u         /**< u64: hash of the receiver's list the sender holds (0: none) */
#define UB_CH_OFF_REFS_LOST 32u    /**< u32: packets the sender refused for want of a sequence reference (a change: resend 32 bits) */
#define UB_CH_OFF_RESERVED 36u     /**< 4 bytes, 0 */
#define UB_CH_OFF_IDS 40u          /**< count x 12-byte IDs, ascending */

/**
 * A dictionary view for one direction of a link: what the encoder may use, or what the decoder
 * expands with. Plain values and one pointer: the codec below never changes it.
 */
typedef struct ub_compact_codec {
    const ub_catalogue_t *cat; /**< the catalogue content indices refer to (NULL: none) */
    uint64_t cat_hash;         /**< its hash (ub_compact_catalogue_hash()) */
    uint8_t content_ok;        /**< both ends hold that catalogue: content indices allowed */
    uint8_t entities_ok;       /**< the receiver holds `ids`: entity indices allowed */
    uint8_t n_ids;
    const uint8_t (*ids)[UB_ENTITY_ID_LEN]; /**< the sender's entity list, ascending */
    uint64_t list_hash;        /**< its hash (ub_compact_list_hash()) */
} ub_compact_codec_t;

/** One source's last sequence on a link. */
typedef struct ub_compact_ref {
    uint8_t src[UB_ENTITY_ID_LEN];
    uint8_t in_use;
    uint8_t since_seq32;  /**< frames sent since the last SEQ32 (sender side) */
    uint8_t seq32_count;  /**< SEQ32 frames sent for this source (sender side; saturates) */
    uint32_t seq;         /**< last sequence sent (sender) / last authentic sequence received (receiver) */
    uint64_t used;        /**< use stamp, for LRU eviction */
} ub_compact_ref_t;

/** A table of references; caller-owned, zero = empty. */
typedef struct ub_compact_refs {
    ub_compact_ref_t ref[UB_COMPACT_REFS];
    uint64_t stamp;
} ub_compact_refs_t;

/** Counters of one compact link. */
typedef struct ub_compact_stats {
    uint64_t tx_frames;        /**< frames encoded */
    uint64_t tx_bytes;         /**< bytes encoded (stuffed, with delimiters) */
    uint64_t tx_full_bytes;    /**< what the same frames measure in the full encoding */
    uint64_t tx_full_ids;      /**< frames that carried at least one full ID or dir_id */
    uint64_t tx_seq32;         /**< frames that carried all 32 sequence bits */
    uint64_t rx_frames;        /**< packets decoded to a frame */
    uint64_t rx_bytes;         /**< bytes fed */
    uint64_t garbage_bytes;    /**< bytes of rejected or empty packets, and of an unfinished datagram tail */
    uint64_t rejected[UB_RX_REASON_COUNT]; /**< packets rejected, by reason */
    uint64_t hello_tx;         /**< LINK_HELLO pages built */
    uint64_t hello_rx;         /**< LINK_HELLO pages taken in */
    uint64_t hello_bad;        /**< LINK_HELLO payloads refused (size, version, page) */
    uint64_t peer_restarts;    /**< the peer's epoch changed */
    uint64_t peer_lists;       /**< complete peer lists taken in (new hash) */
    uint64_t dict_changes;     /**< LINK_HELLOs that replaced the peer's dictionary held here (epoch, catalogue or list hash), first contact not counted */
    uint64_t dict_limited;     /**< changes refused: an unauthenticated LINK_HELLO within change_min_ms of the last change */
} ub_compact_stats_t;

/** Timing of the dictionary exchange; 0 = default. */
typedef struct ub_compact_params {
    uint32_t hello_ms; /**< a full round of LINK_HELLO pages every hello_ms once agreed (default 5000) */
    uint32_t retry_ms; /**< least gap between rounds while not agreed or on demand (default 500) */
    uint32_t change_min_ms; /**< least gap between two dictionary changes taken from unauthenticated LINK_HELLOs (default 2000) */
} ub_compact_params_t;

#define UB_COMPACT_HELLO_MS 5000u
#define UB_COMPACT_RETRY_MS 500u
#define UB_COMPACT_CHANGE_MIN_MS 2000u

/** One compact link's state. Caller-owned (about 1.5 KiB with 16 entities); fields private. A stream's unfinished
 *  packet is carried in the link's ub_decoder_t, which is large enough (UB_COMPACT_WIRE_MAX <= UB_FRAME_MAX). */
typedef struct ub_compact {
    ub_compact_params_t params;
    uint32_t epoch;             /**< ours (non-zero) */
    uint64_t cat_hash;          /**< ours */
    const ub_catalogue_t *cat;
    uint64_t version;           /**< the table version our list was made from */
    uint8_t have_list;
    uint8_t n_ids;
    uint8_t ids[UB_COMPACT_DICT_MAX][UB_ENTITY_ID_LEN];
    uint64_t list_hash;
    /* the peer */
    uint8_t peer_heard;
    uint8_t peer_list_ok;       /**< peer_ids is the complete list whose hash is peer_list_hash */
    uint8_t peer_n;
    uint32_t peer_epoch;
    uint64_t peer_cat_hash;
    uint64_t peer_list_hash;    /**< announced */
    uint64_t peer_echo;         /**< hash of our list the peer says it holds */
    uint32_t peer_refs_lost;    /**< the peer's refs_lost as last announced */
    uint32_t refs_lost;         /**< our packets refused for want of a reference (announced in LINK_HELLO) */
    uint8_t peer_ids[UB_COMPACT_DICT_MAX][UB_ENTITY_ID_LEN];
    uint8_t peer_pages[(UB_COMPACT_DICT_MAX + UB_COMPACT_PAGE - 1) / UB_COMPACT_PAGE / 8 + 1];
    /* hello schedule */
    uint8_t round_page;         /**< next page of the round under way; round_pages when none */
    uint8_t round_pages;
    uint8_t started;
    uint64_t next_round_ms;
    uint64_t last_round_ms;
    uint64_t change_ms;         /**< last dictionary change taken from the peer */
    /* sequences */
    ub_compact_refs_t tx;
    ub_compact_refs_t rx;
    ub_compact_stats_t stats;
} ub_compact_t;

/* ---- pure functions ------------------------------------------------------------------------- */

/** FNV-1a 64 over each instance of `cat` in index order: id[16], fingerprint u32, packed size u32. 0 for NULL. */
uint64_t ub_compact_catalogue_hash(const ub_catalogue_t *cat);

/** FNV-1a 64 over the count (u8) then the IDs, in the given (ascending) order. */
uint64_t ub_compact_list_hash(const uint8_t (*ids)[UB_ENTITY_ID_LEN], size_t n);

/**
 * COBS-stuffs `n` bytes and appends the 0x00 delimiter.
 * @return bytes written (at most UB_COBS_MAX(n)), or 0 if `cap` is too small.
 */
size_t ub_cobs_encode(const uint8_t *in, size_t n, uint8_t *out, size_t cap);

/**
 * Unstuffs one packet (`n` bytes, without its delimiter). `out` may equal `in` (in place).
 * @return the packet length, or UB_ERR_INVAL (a 0x00 inside, or a code running past the end),
 *         UB_ERR_NOSPACE.
 */
int ub_cobs_decode(const uint8_t *in, size_t n, uint8_t *out, size_t cap);

/**
 * Encodes one verified full frame (`len` bytes, as ub_frame_parse() accepts) as a packet (not
 * stuffed) with the dictionary `c`. `seq32` sends all 32 sequence bits.
 * @return the packet length; UB_ERR_INVAL (NULL, or not a well-formed frame); UB_ERR_NOSPACE.
 */
UB_CHECK int ub_compact_encode(const ub_compact_codec_t *c, const uint8_t *frame, size_t len, bool seq32,
                               uint8_t *pkt, size_t cap);

/**
 * Decodes one packet (`n` bytes, unstuffed) into the full frame it stands for, written to
 * `frame` (`cap` >= UB_FRAME_MAX) with both checks, and its header into `h`. `refs` gives the
 * last sequence of each source (may be NULL: only SEQ32 packets decode).
 * @return the frame length, or a negative error with `*why` (may be NULL) set: UB_RX_BAD_LENGTH
 *         (too short, fields past the end, an index out of the dictionary, payload longer than the
 *         type), UB_RX_BAD_VERSION (reserved bits, protection 3), UB_RX_NO_DICTIONARY (an index
 *         this end cannot expand: the peer's catalogue or list is not held), UB_RX_BAD_CRC,
 *         UB_RX_NO_REFERENCE (16-bit sequence from a source without a reference).
 */
UB_CHECK int ub_compact_decode(const ub_compact_codec_t *c, const uint8_t *pkt, size_t n,
                               const ub_compact_refs_t *refs, uint8_t *frame, size_t cap, ub_frame_header_t *h,
                               ub_rx_reason_t *why);

/** Restores a 32-bit sequence from its low 16 bits and the last one seen (closest value, serial arithmetic). */
static inline uint32_t ub_compact_seq_restore(uint32_t last, uint16_t low) {
    /* The 16-bit step from `last`, taken as signed (-32768..32767) in unsigned arithmetic mod 2^32. */
    uint32_t step = (uint16_t)(low - (uint16_t)last);
    return last + step - ((step & 0x8000u) ? 0x10000u : 0u);
}

/** @return the reference of `src` in `refs`, or NULL. */
const ub_compact_ref_t *ub_compact_ref_find(const ub_compact_refs_t *refs, const uint8_t src[UB_ENTITY_ID_LEN]);

/* ---- a compact link ------------------------------------------------------------------------- */

/**
 * Initialises a link's state for catalogue `cat` (may be NULL: no content indices) with epoch
 * `epoch` (0 is replaced by 1; a random one lets the peer notice a restart). `params` may be NULL.
 */
void ub_compact_init(ub_compact_t *s, const ub_catalogue_t *cat, uint32_t epoch, const ub_compact_params_t *params);

/**
 * Gives the link this end's entity table (`n` IDs in any order; at most UB_COMPACT_DICT_MAX are
 * indexed) as of table version `version`. Unchanged versions cost nothing; a changed list starts
 * a LINK_HELLO round at once.
 */
void ub_compact_set_local(ub_compact_t *s, const uint8_t (*ids)[UB_ENTITY_ID_LEN], size_t n, uint64_t version,
                          uint64_t now_ms);

/** @return whether the table version differs from the one the list was made from (the node then calls ub_compact_set_local()). */
static inline bool ub_compact_local_stale(const ub_compact_t *s, uint64_t version) {
    return !s->have_list || s->version != version;
}

/** The dictionary this end encodes with (what the peer can expand). */
void ub_compact_tx_codec(const ub_compact_t *s, ub_compact_codec_t *c);
/** The dictionary this end decodes the peer's packets with. */
void ub_compact_rx_codec(const ub_compact_t *s, ub_compact_codec_t *c);

/**
 * Encodes a full frame for the wire: packet, stuffing, delimiter; decides SEQ32 and counts.
 * @return bytes written to `wire` (`cap` >= UB_COMPACT_WIRE_MAX suffices); negative on error.
 */
UB_CHECK int ub_compact_link_encode(ub_compact_t *s, const uint8_t *frame, size_t len, uint8_t *wire, size_t cap);

/** Forgets the sender-side reference of `src` (its next frame carries all 32 bits): the transport refused a frame. */
void ub_compact_tx_forget(ub_compact_t *s, const uint8_t src[UB_ENTITY_ID_LEN]);

/** Called with each decoded full frame; `frame` is valid only during the call. */
typedef void (*ub_compact_frame_cb)(void *user, const ub_frame_header_t *h, const uint8_t *frame, size_t len,
                                    bool seq32);

/**
 * Feeds received bytes. With `stream` (a byte stream: serial, TCP) an unfinished packet is carried
 * over in `stream`'s buffer to the next call, and `stream`'s counters count what it found (as
 * ub_decoder_feed() does); with `stream` NULL, `data` is one datagram of whole packets (a tail
 * without its delimiter is garbage) and rejections are also added to `rejected` (may be NULL).
 * Each packet is unstuffed, decoded and handed to `cb`; rejections are counted by reason in the
 * link's stats. A packet this end cannot expand (no dictionary, no sequence reference) asks for a
 * LINK_HELLO round, which tells the peer.
 * @return packets decoded to frames.
 */
size_t ub_compact_feed(ub_compact_t *s, ub_decoder_t *stream, const uint8_t *data, size_t len, uint64_t now_ms,
                       uint64_t rejected[UB_RX_REASON_COUNT], ub_compact_frame_cb cb, void *user);

/**
 * Notes the sequence of an authentic frame received from `src` (the node calls it after the
 * security gate): an explicit (SEQ32) sequence sets the reference, a restored one only moves it
 * forward, so a replayed old frame cannot drag it back.
 */
void ub_compact_rx_note(ub_compact_t *s, const uint8_t src[UB_ENTITY_ID_LEN], uint32_t seq, bool seq32);

/**
 * Whether a LINK_HELLO page is due at `now_ms`; if so writes its payload to `payload` (`cap` >=
 * UB_COMPACT_HELLO_FIXED + UB_COMPACT_PAGE * 12) and sets `*len`. Call until false: a round sends
 * every page of the list.
 */
bool ub_compact_hello_due(ub_compact_t *s, uint64_t now_ms, uint8_t *payload, size_t cap, uint16_t *len);

/**
 * Takes in a LINK_HELLO payload from the peer (authenticated: ub_compact_on_hello_from() with true).
 * @return UB_OK, or UB_ERR_INVAL (bad size, version or page: counted hello_bad).
 */
UB_CHECK int ub_compact_on_hello(ub_compact_t *s, const uint8_t *payload, size_t len, uint64_t now_ms);

/**
 * Takes in a LINK_HELLO payload from the peer. A page that replaces the peer's dictionary held here
 * (another epoch, catalogue hash or list hash; not first contact) is a **change**, counted
 * `dict_changes`. On an unsigned link (`authenticated` false: anyone may send a LINK_HELLO there) a
 * change within `change_min_ms` of the previous one is refused whole and counted `dict_limited`: a
 * flood of forged hellos cannot keep resetting the link's dictionary and sequence references, only
 * change it once per `change_min_ms` -- which is still a change nobody can tell from the peer's; sign the
 * link to stop forged ones (docs/wire-format.md).
 * @return UB_OK; UB_ERR_INVAL (bad size, version or page: counted hello_bad); UB_ERR_AGAIN (refused by
 *         the limit).
 */
UB_CHECK int ub_compact_on_hello_from(ub_compact_t *s, const uint8_t *payload, size_t len, uint64_t now_ms,
                                      bool authenticated);

/**
 * The most bytes a frame of `payload_len` payload bytes and `trailer_len` trailer bytes takes on
 * this link as things stand (dictionary in force; worst case for the sequence and the stuffing),
 * for sizing fragments. `dir_id`, `dest_id`, `src_id` as in the frame.
 */
size_t ub_compact_wire_size(const ub_compact_t *s, const uint8_t dir_id[UB_DIR_ID_LEN], uint32_t fingerprint,
                            const uint8_t dest_id[UB_ENTITY_ID_LEN], const uint8_t src_id[UB_ENTITY_ID_LEN],
                            size_t payload_len, size_t trailer_len);

/** @return true when both directions use indices (catalogue and both lists agreed). */
bool ub_compact_agreed(const ub_compact_t *s);

#ifdef __cplusplus
}
#endif
#endif /* UB_COMPACT_H */
