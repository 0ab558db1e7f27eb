/**
 * @file ub_sec.h
 * @brief Frame security: a keyring, signing / AEAD encryption and verification
 *        of whole frames, the sender's 48-bit freshness counter with a
 *        persisted reservation, replay windows and challenge nonces.
 *
 * Construction (docs/security.md, docs/wire-format.md "Flags and trailer"):
 *
 *  - **Tag input** is a canonical 68-byte *signing header* followed by the
 *    (plaintext) payload. The signing header is the domain string
 *    "uavbus-sig1" | version/flags byte | msg_type u16 | dir_id[16] |
 *    dest_id[12] | src_id[12] | admin u8 | payload_size u16 | seq u32 |
 *    fingerprint u32 | key_id u8 | counter_hi u16 (integers little-endian).
 *    Not covered: sync, hdr_check, msg_size, hop_limit, msg_crc, so a
 *    forwarder lowers the hop limit without re-signing.
 *  - **Keys**: each 32-byte key (a key file's) is split once, when it is
 *    added, by libsodium's KDF (crypto_kdf_derive_from_key, subkey id 1) into
 *    a 128-bit signing subkey (context "ubsig001") and a 256-bit AEAD subkey
 *    (context "ubaead01"); the file's key itself is not kept.
 *  - **SIGNED** (flag 0x10): tag = SipHash-2-4 (libsodium
 *    crypto_shorthash_siphash24, 64-bit output) of the tag input under the
 *    signing subkey; trailer key_id | counter_hi | tag[8] (11 bytes).
 *  - **ENCRYPTED** (flag 0x20): XChaCha20-Poly1305 (IETF, detached) of the
 *    payload in place; additional data = the signing header (with the
 *    ENCRYPTED flag); nonce = src_id[12] | counter (48-bit LE, 6 bytes) |
 *    key_id | 5 zero bytes; key = the AEAD subkey; trailer key_id |
 *    counter_hi | Poly1305 tag[16] (19 bytes).
 *  - **Freshness** is the sender's 48-bit counter, counter_hi << 32 | seq.
 *    It starts at max(persisted reservation, wall clock in 10 µs units since
 *    2015-01-01) and rises by one per originated frame; before using values
 *    at or above the stored mark the context asks the caller's reserve
 *    callback to store mark + block durably. If that fails, no counter is
 *    handed out (fail closed): counters are never reused, which the AEAD
 *    nonce's uniqueness rests on.
 *
 * The subkeys are derived once per key (ub_sec_add_key()): no per-frame key
 * setup. Everything here works on caller-owned structs: no
 * allocation, no statics (libsodium's sodium_init() runs in ub_sec_init()).
 *
 * Built with UAVBUS_SECURITY=OFF (no libsodium, e.g. bare-metal), every
 * function that needs cryptography returns UB_ERR_UNSUPPORTED and a node
 * cannot attach a context: flagged frames are then dropped `unknown_key` and
 * nothing is signed (fail closed). The replay-window functions work in both.
 *
 *     ub_sec_t sec;                                      // caller-owned (400 bytes with 4 keys, x86-64)
 *     ub_sec_options_t o = {.reserve = my_store, .reserve_user = &file};
 *     ub_sec_init(&sec, &o);
 *     ub_sec_add_key(&sec, 7, key32);  ub_sec_set_tx_key(&sec, 7);
 *     ub_sec_start(&sec, persisted_mark, ub_sec_wall_counter(unix_us));
 *     ub_node_set_security(&node, &sec);                 // ub_node.h
 */
#ifndef UB_SEC_H
#define UB_SEC_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ub_config.h"
#include "ub_error.h"
#include "ub_frame.h"
#include "ub_random.h"

#ifdef __cplusplus
extern "C" {
#endif

#define UB_SEC_KEY_LEN 32u
#define UB_SEC_NONCE_LEN 16u /**< challenge nonce (payload of CHALLENGE and CHALLENGE_REPLY) */
#define UB_SEC_SIGNING_HEADER_LEN 68u
/** The hop tag's header of an ORIGIN frame: the signing header, hop_limit, the origin block (hop0, origin tag). */
#define UB_SEC_SIGNING_HEADER_MAX (UB_SEC_SIGNING_HEADER_LEN + 1u + UB_FRAME_ORIGIN_LEN)
#define UB_SEC_DOMAIN "uavbus-sig1"
#define UB_SEC_COUNTER_MAX ((UINT64_C(1) << 48) - 1u)
/** 2015-01-01T00:00:00Z in Unix seconds: the epoch of the wall-clock counter (as MAVLink's timestamp). */
#define UB_SEC_EPOCH_UNIX_S UINT64_C(1420070400)
/** Counter values reserved per durable store, by default. */
#define UB_SEC_DEFAULT_RESERVE_BLOCK (UINT64_C(1) << 16)
#define UB_SEC_DEFAULT_CHALLENGE_RETRY_MS 200u
#define UB_SEC_DEFAULT_REPLY_MIN_MS 50u
/** Challenge sends per outstanding challenge without traffic from the source (then it waits for the next frame). */
#define UB_SEC_CHALLENGE_TRIES 5u
/**
 * Freshness bound (docs/security.md, "Lockout"). No genuine sender's counter rises faster than this
 * many values per second: it is the wall-clock counter's own rate (10 µs units), which the restart
 * rule above already assumes of every sender (a node sending more frames per second than that would
 * outrun its wall clock). A received frame may move its source's window up to
 * proven + UB_SEC_JUMP_SLACK + rate x (ms since the proof) / 1000, where `proven` is the counter the
 * source proved by its last CHALLENGE_REPLY; a frame above is dropped `counter_jump`, moves nothing
 * and has its source challenged again.
 */
#define UB_SEC_DEFAULT_MAX_COUNTER_RATE 100000u
/** Counters a source may be ahead of its bound at once (a burst, its reserve block): one reservation. */
#define UB_SEC_JUMP_SLACK UB_SEC_DEFAULT_RESERVE_BLOCK
/** Frames of one source judged `replay` in a row after which it is challenged again (a restarted or locked-out sender recovers). */
#define UB_SEC_DEFAULT_REPLAY_STREAK 8u
/** Least time between two challenges a node starts for a source it already holds freshness for (jump or replay streak). */
#define UB_SEC_DEFAULT_RECHALLENGE_MIN_MS 1000u
/** SipHash-2-4 key: the 128-bit signing subkey. */
#define UB_SEC_SIG_KEY_LEN 16u
/** libsodium KDF contexts (8 characters each) and the subkey id of both subkeys. */
#define UB_SEC_SIG_CONTEXT "ubsig001"
#define UB_SEC_AEAD_CONTEXT "ubaead01"
#define UB_SEC_SUBKEY_ID 1u

/**
 * Durably stores `mark`: after a restart the context must start at or above
 * it. Called with the context's counter lock-step: return only once stored
 * (e.g. written and fsync'ed). @return UB_OK, or a negative error (the
 * context then refuses to hand out counters above the previous mark).
 */
typedef int (*ub_sec_reserve_fn)(void *user, uint64_t mark);

/** Options; zero fields mean the defaults. */
typedef struct ub_sec_options {
    ub_random_fn random;         /**< challenge nonces (ub_random.h); NULL or failing: libsodium randombytes_buf().
                                      Tests inject a seeded one. */
    void *random_user;
    ub_sec_reserve_fn reserve;   /**< NULL: counters are not persisted (the wall clock alone must be right) */
    void *reserve_user;
    uint64_t reserve_block;      /**< counters reserved per store; default UB_SEC_DEFAULT_RESERVE_BLOCK */
    uint32_t challenge_retry_ms; /**< resend of an unanswered challenge; default 200 */
    uint32_t reply_min_ms;       /**< least time between two replies to one requester for one nonce; default 50 */
    uint32_t max_counter_rate;   /**< counters per second a source may advance (the jump bound); default 100000 */
    uint32_t replay_streak;      /**< `replay` frames in a row that re-challenge their source; default 8 */
    uint32_t rechallenge_min_ms; /**< least time between two re-challenges of one source; default 1000 */
} ub_sec_options_t;

/** One key of the keyring. Treat as private. */
typedef struct ub_sec_key {
    uint8_t id;                          /**< 1..255; 0 = free slot */
    uint8_t sig_key[UB_SEC_SIG_KEY_LEN]; /**< SipHash-2-4 subkey (KDF context "ubsig001") */
    uint8_t aead_key[UB_SEC_KEY_LEN];    /**< XChaCha20-Poly1305 subkey (KDF context "ubaead01") */
} ub_sec_key_t;

/** Counters of a security context (node-wide). Drops of received frames are in the node's drop counters. */
typedef struct ub_sec_stats {
    uint64_t signed_out;           /**< SIGNED frames made (originated, or converted by a forwarder) */
    uint64_t encrypted_out;        /**< ENCRYPTED frames made */
    uint64_t verified_in;          /**< SIGNED frames whose tag verified */
    uint64_t decrypted_in;         /**< ENCRYPTED frames that decrypted */
    uint64_t auth_failures;        /**< tags that did not verify */
    uint64_t unknown_keys;         /**< frames naming a key id not in the keyring */
    uint64_t challenges_sent;      /**< CHALLENGE frames sent (first sends and retries) */
    uint64_t challenges_completed; /**< sources whose freshness a CHALLENGE_REPLY established */
    uint64_t replies_sent;         /**< CHALLENGE_REPLY frames sent */
    uint64_t replies_suppressed;   /**< challenges not answered again within reply_min_ms (same nonce) */
    uint64_t reservations;         /**< successful counter reservations (calls of the reserve callback) */
    uint64_t reserve_failures;     /**< failed reservations: frames were refused rather than counters reused */
    uint64_t tx_refused;           /**< frames not originated because no counter could be handed out */
    uint64_t rechallenges;         /**< challenges started for a source already holding freshness (jump, replay streak) */
    uint64_t window_resets;        /**< windows forgotten because the key that set them left the keyring (rotation) */
} ub_sec_stats_t;

/** A security context. Caller-owned; treat the fields as private (use the functions). */
typedef struct ub_sec {
    ub_sec_options_t opt;
    ub_sec_key_t keys[UB_MAX_KEYS];
    uint8_t tx_key;      /**< key id that signs; 0 = none (frames go out unsigned) */
    uint8_t initialised;
    uint8_t started;
    uint64_t counter;    /**< next counter to hand out */
    uint64_t reserved;   /**< counters below this are covered by a stored reservation */
    ub_sec_stats_t stats;
} ub_sec_t;

/** @return true when this build has cryptography (UAVBUS_SECURITY=ON). */
bool ub_sec_available(void);

/**
 * Initialises an empty context (no keys, no counter yet) and libsodium.
 * @return UB_OK; UB_ERR_INVAL (NULL); UB_ERR_IO (libsodium failed to
 *         initialise); UB_ERR_UNSUPPORTED (built without security).
 */
UB_CHECK int ub_sec_init(ub_sec_t *sec, const ub_sec_options_t *opt);

/**
 * Adds key `id` (1..255): derives its signing and AEAD subkeys (the key
 * itself is not kept). Accepting a key does
 * not make it sign (ub_sec_set_tx_key()): during a rollover both old and new
 * keys verify.
 * @return UB_OK; UB_ERR_INVAL (NULL, id 0); UB_ERR_EXISTS (id present);
 *         UB_ERR_FULL (UB_MAX_KEYS); UB_ERR_UNSUPPORTED.
 */
UB_CHECK int ub_sec_add_key(ub_sec_t *sec, uint8_t id, const uint8_t key[UB_SEC_KEY_LEN]);

/**
 * Removes key `id` and wipes it. The key that signs cannot be removed:
 * switch to another first.
 * @return UB_OK; UB_ERR_NOTFOUND; UB_ERR_INVAL (NULL, or `id` is the tx key).
 */
UB_CHECK int ub_sec_remove_key(ub_sec_t *sec, uint8_t id);

/** Makes key `id` sign what this node sends (0: send unsigned). @return UB_OK, UB_ERR_NOTFOUND, UB_ERR_INVAL. */
UB_CHECK int ub_sec_set_tx_key(ub_sec_t *sec, uint8_t id);

/** @return the signing key id, 0 for none. */
uint8_t ub_sec_tx_key(const ub_sec_t *sec);

/** @return whether key `id` is in the keyring. */
bool ub_sec_has_key(const ub_sec_t *sec, uint8_t id);

/** Writes up to `cap` key ids into `ids` (keyring order). @return the number of keys. */
size_t ub_sec_key_ids(const ub_sec_t *sec, uint8_t *ids, size_t cap);

/** Wall-clock counter: 10 µs units since 2015-01-01 for a Unix time in µs (0 before the epoch). */
uint64_t ub_sec_wall_counter(uint64_t unix_us);

/**
 * Sets the first counter to max(`persisted_mark`, `wall_counter`). A clock
 * that jumps backwards (or an unset RTC) is covered by the mark, a reset of
 * the mark (lost file) by a sane clock.
 * @return UB_OK; UB_ERR_INVAL (NULL); UB_ERR_RANGE (beyond 48 bits).
 */
UB_CHECK int ub_sec_start(ub_sec_t *sec, uint64_t persisted_mark, uint64_t wall_counter);

/**
 * Hands out the next counter. When it reaches the stored reservation, asks
 * the reserve callback to store counter + block first.
 * @return UB_OK; UB_ERR_IO (the reservation could not be stored: counted,
 *         nothing handed out; the next call tries again); UB_ERR_RANGE
 *         (48-bit counter exhausted); UB_ERR_INVAL (NULL, not started).
 */
UB_CHECK int ub_sec_next_counter(ub_sec_t *sec, uint64_t *counter);

/**
 * Protects a frame: `h` is the complete header (h->flags SIGNED or ENCRYPTED,
 * h->key_id, h->seq and h->counter_hi = the 48-bit counter's two halves);
 * `payload` is the plaintext (h->payload_size bytes; it may be
 * `frame + UB_FRAME_HEADER_LEN` itself). Writes the payload (ciphertext for
 * ENCRYPTED), the trailer and the header with both checks into `frame`.
 * @return the frame length; UB_ERR_NOTFOUND (key not in the keyring);
 *         UB_ERR_INVAL (NULL, flags neither SIGNED nor ENCRYPTED); the
 *         errors of ub_frame_finish(); UB_ERR_UNSUPPORTED.
 */
UB_CHECK int ub_sec_protect(ub_sec_t *sec, const ub_frame_header_t *h, const uint8_t *payload, uint8_t *frame,
                            size_t cap);

/**
 * Verifies a CRC-valid flagged frame (`h` from ub_frame_parse() of these
 * `len` bytes). SIGNED: checks the tag in constant time (`plain` unused,
 * may be NULL). ENCRYPTED: authenticates and decrypts the payload into
 * `plain` (`plain_cap` >= h->payload_size); nothing is written unless the tag
 * verifies. Touches no state besides the counters.
 * @return UB_OK; UB_ERR_AUTH (tag mismatch); UB_ERR_NOTFOUND (unknown key
 *         id); UB_ERR_INVAL (NULL, unflagged frame, `len` not the frame's
 *         size, `plain` too small); UB_ERR_UNSUPPORTED.
 */
UB_CHECK int ub_sec_verify(ub_sec_t *sec, const ub_frame_header_t *h, const uint8_t *frame, size_t len,
                           uint8_t *plain, size_t plain_cap);

/** Fills `out` with random bytes from the options' generator (libsodium's by default, and when it fails). */
void ub_sec_random(ub_sec_t *sec, uint8_t *out, size_t len);

/** Makes a new random key (libsodium's generator, never the injected one). @return UB_OK or UB_ERR_UNSUPPORTED. */
UB_CHECK int ub_sec_keygen(uint8_t key[UB_SEC_KEY_LEN]);

/** Writes the 68-byte signing header of `h` (with its flags, key id and counter_hi) into `out`. */
void ub_sec_signing_header(const ub_frame_header_t *h, uint8_t out[UB_SEC_SIGNING_HEADER_LEN]);

/**
 * Writes the header the hop tag (SIGNED) or AEAD (ENCRYPTED, as additional data) covers before the
 * payload: the signing header, then for ORIGIN frames hop_limit | origin_hop0 | origin_tag.
 * @return its length: UB_SEC_SIGNING_HEADER_LEN, or UB_SEC_SIGNING_HEADER_MAX with ORIGIN.
 */
size_t ub_sec_hop_header(const ub_frame_header_t *h, uint8_t out[UB_SEC_SIGNING_HEADER_MAX]);

/** @return the context's counters. */
const ub_sec_stats_t *ub_sec_stats(const ub_sec_t *sec);

/* ---- replay windows (pure functions; no cryptography, available in every build) ---- */

/** Bits of history below the highest counter. */
#define UB_SEC_WINDOW_BITS 64

/** Per-source replay window over 48-bit counters: the highest accepted and a bitmap below it. */
typedef struct ub_sec_window {
    uint64_t highest;
    uint64_t seen; /**< bit k: highest - k was accepted (or is barred) */
} ub_sec_window_t;

typedef enum ub_sec_window_verdict {
    UB_SEC_WINDOW_NEW = 0,  /**< above highest, or inside the window and not yet seen: accept */
    UB_SEC_WINDOW_DUPLICATE, /**< inside the window and already seen */
    UB_SEC_WINDOW_OLD        /**< UB_SEC_WINDOW_BITS or more behind highest: a replay */
} ub_sec_window_verdict_t;

/**
 * The highest counter a frame of a source may carry `elapsed_ms` after the source proved counter
 * `proven` (its CHALLENGE_REPLY): proven + UB_SEC_JUMP_SLACK + max_rate x elapsed_ms / 1000,
 * saturating at UB_SEC_COUNTER_MAX. Pure; `max_rate` 0 means UB_SEC_DEFAULT_MAX_COUNTER_RATE.
 */
uint64_t ub_sec_jump_limit(uint64_t proven, uint64_t elapsed_ms, uint32_t max_rate);

/** Judges `counter` against `w` without changing it. */
ub_sec_window_verdict_t ub_sec_window_check(const ub_sec_window_t *w, uint64_t counter);

/** Records `counter`, which ub_sec_window_check() judged NEW. */
void ub_sec_window_accept(ub_sec_window_t *w, uint64_t counter);

/**
 * Starts a window at `counter` with everything at or below it barred: used
 * when a challenge reply proves the source's current counter, so no captured
 * frame (all older) is ever accepted afterwards.
 */
void ub_sec_window_establish(ub_sec_window_t *w, uint64_t counter);

#ifdef __cplusplus
}
#endif
#endif /* UB_SEC_H */
