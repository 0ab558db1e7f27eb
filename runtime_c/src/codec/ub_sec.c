/* Frame security (contracts in ub/ub_sec.h; construction in docs/security.md).
 *
 * Only libsodium does cryptography here: its KDF (crypto_kdf_derive_from_key) splits each key file's
 * key into a SipHash-2-4 subkey and an XChaCha20-Poly1305 subkey once, when the key is added;
 * crypto_shorthash_siphash24 makes SIGNED tags, XChaCha20-Poly1305 (IETF, detached) ENCRYPTED frames,
 * sodium_memcmp compares tags, randombytes_buf makes nonces and keys. UB_SECURITY (set by CMake's UAVBUS_SECURITY option and by the
 * cffi build) switches it in; without it every cryptographic entry point returns UB_ERR_UNSUPPORTED,
 * so nothing can be signed and nothing flagged can be accepted. */
#include "ub/ub_sec.h"
#include "codec/ub_wipe_private.h"

#include <string.h>

#include "ub/ub_wire.h"

#if defined(UB_SECURITY) && UB_SECURITY
#include <sodium.h>
#define HAVE_SODIUM 1
_Static_assert(crypto_shorthash_siphash24_KEYBYTES == UB_SEC_SIG_KEY_LEN, "SipHash-2-4 key length");
_Static_assert(crypto_shorthash_siphash24_BYTES == UB_FRAME_SIG_TAG_LEN, "SipHash-2-4 output = the SIGNED tag");
_Static_assert(crypto_kdf_KEYBYTES == UB_SEC_KEY_LEN, "KDF master key length");
_Static_assert(crypto_kdf_CONTEXTBYTES == sizeof UB_SEC_SIG_CONTEXT - 1u, "KDF context length (signing)");
_Static_assert(crypto_kdf_CONTEXTBYTES == sizeof UB_SEC_AEAD_CONTEXT - 1u, "KDF context length (AEAD)");
_Static_assert(UB_SEC_SIG_KEY_LEN >= crypto_kdf_BYTES_MIN, "KDF subkey length");
_Static_assert(crypto_aead_xchacha20poly1305_ietf_ABYTES == UB_FRAME_AEAD_TAG_LEN, "Poly1305 tag length");
_Static_assert(crypto_aead_xchacha20poly1305_ietf_NPUBBYTES == 24, "XChaCha20 nonce length");
_Static_assert(crypto_aead_xchacha20poly1305_ietf_KEYBYTES == UB_SEC_KEY_LEN, "AEAD key length");
#else
#define HAVE_SODIUM 0
#endif

#define DOMAIN_LEN (sizeof UB_SEC_DOMAIN - 1u)

_Static_assert(DOMAIN_LEN == 11, "domain string is 11 bytes");

bool ub_sec_available(void) { return HAVE_SODIUM; }

static ub_sec_key_t *find_key(ub_sec_t *sec, uint8_t id) {
    if (id == 0) return NULL;
    for (size_t i = 0; i < UB_MAX_KEYS; i++)
        if (sec->keys[i].id == id) return &sec->keys[i];
    return NULL;
}

bool ub_sec_has_key(const ub_sec_t *sec, uint8_t id) {
    return sec != NULL && find_key((ub_sec_t *)sec, id) != NULL;
}

size_t ub_sec_key_ids(const ub_sec_t *sec, uint8_t *ids, size_t cap) {
    size_t n = 0;
    if (sec == NULL) return 0;
    for (size_t i = 0; i < UB_MAX_KEYS; i++) {
        if (sec->keys[i].id == 0) continue;
        if (ids != NULL && n < cap) ids[n] = sec->keys[i].id;
        n++;
    }
    return n;
}

int ub_sec_init(ub_sec_t *sec, const ub_sec_options_t *opt) {
    if (sec == NULL) return UB_ERR_INVAL;
    memset(sec, 0, sizeof *sec);
    if (opt != NULL) sec->opt = *opt;
    if (sec->opt.reserve_block == 0) sec->opt.reserve_block = UB_SEC_DEFAULT_RESERVE_BLOCK;
    if (sec->opt.challenge_retry_ms == 0) sec->opt.challenge_retry_ms = UB_SEC_DEFAULT_CHALLENGE_RETRY_MS;
    if (sec->opt.reply_min_ms == 0) sec->opt.reply_min_ms = UB_SEC_DEFAULT_REPLY_MIN_MS;
    if (sec->opt.max_counter_rate == 0) sec->opt.max_counter_rate = UB_SEC_DEFAULT_MAX_COUNTER_RATE;
    if (sec->opt.replay_streak == 0) sec->opt.replay_streak = UB_SEC_DEFAULT_REPLAY_STREAK;
    if (sec->opt.rechallenge_min_ms == 0) sec->opt.rechallenge_min_ms = UB_SEC_DEFAULT_RECHALLENGE_MIN_MS;
#if HAVE_SODIUM
    if (UB_SODIUM_INIT() < 0) return UB_ERR_IO;
    sec->initialised = 1;
    return UB_OK;
#else
    return UB_ERR_UNSUPPORTED;
#endif
}

int ub_sec_add_key(ub_sec_t *sec, uint8_t id, const uint8_t key[UB_SEC_KEY_LEN]) {
    if (sec == NULL || key == NULL || id == 0) return UB_ERR_INVAL;
#if HAVE_SODIUM
    if (!sec->initialised) return UB_ERR_INVAL;
    if (find_key(sec, id) != NULL) return UB_ERR_EXISTS;
    ub_sec_key_t *slot = NULL;
    for (size_t i = 0; i < UB_MAX_KEYS && slot == NULL; i++)
        if (sec->keys[i].id == 0) slot = &sec->keys[i];
    if (slot == NULL) return UB_ERR_FULL;
    /* Key separation, once per key: the tag and the AEAD never use the same key, nor the file's key. */
    if (crypto_kdf_derive_from_key(slot->sig_key, UB_SEC_SIG_KEY_LEN, UB_SEC_SUBKEY_ID, UB_SEC_SIG_CONTEXT, key) != 0 ||
        crypto_kdf_derive_from_key(slot->aead_key, UB_SEC_KEY_LEN, UB_SEC_SUBKEY_ID, UB_SEC_AEAD_CONTEXT, key) != 0) {
        ub_priv_wipe(slot, sizeof *slot);
        return UB_ERR_INVAL;
    }
    slot->id = id;
    return UB_OK;
#else
    return UB_ERR_UNSUPPORTED;
#endif
}

int ub_sec_remove_key(ub_sec_t *sec, uint8_t id) {
    if (sec == NULL || id == 0) return UB_ERR_INVAL;
    ub_sec_key_t *k = find_key(sec, id);
    if (k == NULL) return UB_ERR_NOTFOUND;
    if (sec->tx_key == id) return UB_ERR_INVAL;
    ub_priv_wipe(k, sizeof *k);
    return UB_OK;
}

int ub_sec_set_tx_key(ub_sec_t *sec, uint8_t id) {
    if (sec == NULL) return UB_ERR_INVAL;
    if (id != 0 && find_key(sec, id) == NULL) return UB_ERR_NOTFOUND;
    sec->tx_key = id;
    return UB_OK;
}

uint8_t ub_sec_tx_key(const ub_sec_t *sec) { return sec == NULL ? 0 : sec->tx_key; }

uint64_t ub_sec_wall_counter(uint64_t unix_us) {
    const uint64_t epoch_us = UB_SEC_EPOCH_UNIX_S * UINT64_C(1000000);
    return unix_us <= epoch_us ? 0 : (unix_us - epoch_us) / 10u;
}

int ub_sec_start(ub_sec_t *sec, uint64_t persisted_mark, uint64_t wall_counter) {
    if (sec == NULL) return UB_ERR_INVAL;
    uint64_t first = persisted_mark > wall_counter ? persisted_mark : wall_counter;
    if (first == 0) first = 1; /* 0 is never sent: a receiver's empty window starts there */
    if (first > UB_SEC_COUNTER_MAX) return UB_ERR_RANGE;
    sec->counter = first;
    sec->reserved = first; /* nothing at or above `first` is covered yet */
    sec->started = 1;
    return UB_OK;
}

int ub_sec_next_counter(ub_sec_t *sec, uint64_t *counter) {
    if (sec == NULL || counter == NULL || !sec->started) return UB_ERR_INVAL;
    if (sec->counter > UB_SEC_COUNTER_MAX) {
        sec->stats.tx_refused++;
        return UB_ERR_RANGE;
    }
    if (sec->opt.reserve != NULL && sec->counter >= sec->reserved) {
        uint64_t mark = sec->counter + sec->opt.reserve_block;
        if (mark > UB_SEC_COUNTER_MAX + 1u) mark = UB_SEC_COUNTER_MAX + 1u;
        if (sec->opt.reserve(sec->opt.reserve_user, mark) < 0) {
            /* Fail closed: a counter not covered by a durable mark could be reused after a restart. */
            sec->stats.reserve_failures++;
            sec->stats.tx_refused++;
            return UB_ERR_IO;
        }
        sec->stats.reservations++;
        sec->reserved = mark;
    }
    *counter = sec->counter++;
    return UB_OK;
}

void ub_sec_signing_header(const ub_frame_header_t *h, uint8_t out[UB_SEC_SIGNING_HEADER_LEN]) {
    uint8_t *p = out;
    memcpy(p, UB_SEC_DOMAIN, DOMAIN_LEN);
    p += DOMAIN_LEN;
    *p++ = (uint8_t)(UB_WIRE_VERSION | h->flags);
    ub_put_u16le(p, UB_MSG_TYPE_PUBSUB);
    p += 2;
    memcpy(p, h->dir_id, UB_DIR_ID_LEN);
    p += UB_DIR_ID_LEN;
    memcpy(p, h->dest_id, UB_ENTITY_ID_LEN);
    p += UB_ENTITY_ID_LEN;
    memcpy(p, h->src_id, UB_ENTITY_ID_LEN);
    p += UB_ENTITY_ID_LEN;
    *p++ = h->admin;
    ub_put_u16le(p, h->payload_size);
    p += 2;
    ub_put_u32le(p, h->seq);
    p += 4;
    ub_put_u32le(p, h->fingerprint);
    p += 4;
    *p++ = h->key_id;
    ub_put_u16le(p, h->counter_hi);
}

size_t ub_sec_hop_header(const ub_frame_header_t *h, uint8_t out[UB_SEC_SIGNING_HEADER_MAX]) {
    ub_sec_signing_header(h, out);
    if (!(h->flags & UB_FRAME_FLAG_ORIGIN)) return UB_SEC_SIGNING_HEADER_LEN;
    /* ORIGIN frames: the hop tag also covers the hop limit as sent on this hop and the origin block, so
     * nobody without the group key changes either (each forwarder re-tags after lowering the hop limit). */
    uint8_t *p = out + UB_SEC_SIGNING_HEADER_LEN;
    p[0] = h->hop_limit;
    p[1] = h->origin_hop0;
    memcpy(p + 2, h->origin_tag, UB_FRAME_ORIGIN_TAG_LEN);
    return UB_SEC_SIGNING_HEADER_MAX;
}

#if HAVE_SODIUM
/* SipHash-2-4 over (signing header, payload). libsodium's SipHash takes one contiguous input, so both go
 * into a stack buffer first (a copy of at most 78 + UB_MAX_PAYLOAD bytes: a few ns beside the hash). */
static void sig_tag(const ub_sec_key_t *k, const uint8_t *sh, size_t sh_len, const uint8_t *payload,
                    size_t payload_len, uint8_t out[UB_FRAME_SIG_TAG_LEN]) {
    uint8_t in[UB_SEC_SIGNING_HEADER_MAX + UB_MAX_PAYLOAD];
    memcpy(in, sh, sh_len);
    if (payload_len > 0) memcpy(in + sh_len, payload, payload_len);
    (void)crypto_shorthash_siphash24(out, in, sh_len + payload_len, k->sig_key);
}
static void aead_nonce(const ub_frame_header_t *h, uint8_t nonce[24]) {
    memset(nonce, 0, 24);
    memcpy(nonce, h->src_id, UB_ENTITY_ID_LEN);
    ub_put_u32le(nonce + 12, h->seq);
    ub_put_u16le(nonce + 16, h->counter_hi);
    nonce[18] = h->key_id;
    /* ORIGIN frames are re-encrypted at every hop with the hop limit in the additional data: the hop limit in
     * the nonce keeps one (key, nonce) from ever authenticating two different additional data. */
    if (h->flags & UB_FRAME_FLAG_ORIGIN) nonce[19] = h->hop_limit;
}
#endif

int ub_sec_protect(ub_sec_t *sec, const ub_frame_header_t *h, const uint8_t *payload, uint8_t *frame, size_t cap) {
    if (sec == NULL || h == NULL || frame == NULL || (payload == NULL && h->payload_size > 0)) return UB_ERR_INVAL;
    uint8_t prot = h->flags & (uint8_t)~UB_FRAME_FLAG_ORIGIN;
    if (prot != UB_FRAME_FLAG_SIGNED && prot != UB_FRAME_FLAG_ENCRYPTED) return UB_ERR_INVAL;
#if HAVE_SODIUM
    const ub_sec_key_t *k = find_key(sec, h->key_id);
    if (k == NULL) return UB_ERR_NOTFOUND;
    if (h->payload_size > UB_MAX_PAYLOAD) return UB_ERR_RANGE;
    size_t trailer_len = ub_frame_trailer_len(h->flags);
    if (cap < UB_FRAME_HEADER_LEN + (size_t)h->payload_size + trailer_len) return UB_ERR_NOSPACE;
    uint8_t *body = frame + UB_FRAME_HEADER_LEN;
    uint8_t *trailer = body + h->payload_size;
    uint8_t sh[UB_SEC_SIGNING_HEADER_MAX];
    size_t sh_len = ub_sec_hop_header(h, sh);
    trailer[UB_FRAME_TRL_OFF_KEY_ID] = h->key_id;
    ub_put_u16le(trailer + UB_FRAME_TRL_OFF_COUNTER_HI, h->counter_hi);
    if (h->flags & UB_FRAME_FLAG_ORIGIN) {
        uint8_t *o = trailer + trailer_len - UB_FRAME_ORIGIN_LEN;
        o[0] = h->origin_hop0;
        memcpy(o + 1, h->origin_tag, UB_FRAME_ORIGIN_TAG_LEN);
    }
    if (prot == UB_FRAME_FLAG_SIGNED) {
        if (payload != body) memmove(body, payload, h->payload_size);
        sig_tag(k, sh, sh_len, body, h->payload_size, trailer + UB_FRAME_TRL_OFF_TAG);
        sec->stats.signed_out++;
    } else {
        uint8_t nonce[24];
        aead_nonce(h, nonce);
        unsigned long long mac_len = 0;
        /* In place is allowed (c == m); a separate source is read before its bytes are overwritten. */
        if (payload != body) memmove(body, payload, h->payload_size);
        if (crypto_aead_xchacha20poly1305_ietf_encrypt_detached(body, trailer + UB_FRAME_TRL_OFF_TAG, &mac_len, body,
                                                                h->payload_size, sh, sh_len, NULL, nonce,
                                                                k->aead_key) != 0)
            return UB_ERR_INVAL;
        sec->stats.encrypted_out++;
    }
    return ub_frame_finish(frame, cap, h);
#else
    (void)cap;
    return UB_ERR_UNSUPPORTED;
#endif
}

int ub_sec_verify(ub_sec_t *sec, const ub_frame_header_t *h, const uint8_t *frame, size_t len, uint8_t *plain,
                  size_t plain_cap) {
    if (sec == NULL || h == NULL || frame == NULL) return UB_ERR_INVAL;
    uint8_t prot = h->flags & (uint8_t)~UB_FRAME_FLAG_ORIGIN;
    if (prot != UB_FRAME_FLAG_SIGNED && prot != UB_FRAME_FLAG_ENCRYPTED) return UB_ERR_INVAL;
    size_t trailer_len = ub_frame_trailer_len(h->flags);
    if (len != UB_FRAME_HEADER_LEN + (size_t)h->payload_size + trailer_len) return UB_ERR_INVAL;
#if HAVE_SODIUM
    const ub_sec_key_t *k = find_key(sec, h->key_id);
    if (k == NULL) {
        sec->stats.unknown_keys++;
        return UB_ERR_NOTFOUND;
    }
    const uint8_t *body = frame + UB_FRAME_HEADER_LEN;
    const uint8_t *tag = body + h->payload_size + UB_FRAME_TRL_OFF_TAG;
    uint8_t sh[UB_SEC_SIGNING_HEADER_MAX];
    size_t sh_len = ub_sec_hop_header(h, sh);
    if (prot == UB_FRAME_FLAG_SIGNED) {
        uint8_t mac[UB_FRAME_SIG_TAG_LEN];
        sig_tag(k, sh, sh_len, body, h->payload_size, mac);
        if (sodium_memcmp(mac, tag, UB_FRAME_SIG_TAG_LEN) != 0) {
            sec->stats.auth_failures++;
            return UB_ERR_AUTH;
        }
        sec->stats.verified_in++;
        return UB_OK;
    }
    if (plain == NULL || plain_cap < h->payload_size) return UB_ERR_INVAL;
    uint8_t nonce[24];
    aead_nonce(h, nonce);
    if (crypto_aead_xchacha20poly1305_ietf_decrypt_detached(plain, NULL, body, h->payload_size, tag, sh, sh_len,
                                                            nonce, k->aead_key) != 0) {
        sec->stats.auth_failures++;
        return UB_ERR_AUTH;
    }
    sec->stats.decrypted_in++;
    return UB_OK;
#else
    (void)plain;
    (void)plain_cap;
    return UB_ERR_UNSUPPORTED;
#endif
}

void ub_sec_random(ub_sec_t *sec, uint8_t *out, size_t len) {
    if (out == NULL || len == 0) return;
    if (sec != NULL && sec->opt.random != NULL && sec->opt.random(sec->opt.random_user, out, len) == UB_OK) return;
#if HAVE_SODIUM
    randombytes_buf(out, len);
#else
    memset(out, 0, len); /* unreachable in practice: a context cannot be initialised without libsodium */
#endif
}

int ub_sec_keygen(uint8_t key[UB_SEC_KEY_LEN]) {
    if (key == NULL) return UB_ERR_INVAL;
#if HAVE_SODIUM
    if (UB_SODIUM_INIT() < 0) return UB_ERR_IO;
    randombytes_buf(key, UB_SEC_KEY_LEN);
    return UB_OK;
#else
    return UB_ERR_UNSUPPORTED;
#endif
}

const ub_sec_stats_t *ub_sec_stats(const ub_sec_t *sec) { return sec == NULL ? NULL : &sec->stats; }

/* ---- replay windows ---- */

uint64_t ub_sec_jump_limit(uint64_t proven, uint64_t elapsed_ms, uint32_t max_rate) {
    if (max_rate == 0) max_rate = UB_SEC_DEFAULT_MAX_COUNTER_RATE;
    if (proven >= UB_SEC_COUNTER_MAX) return UB_SEC_COUNTER_MAX;
    uint64_t room = UB_SEC_COUNTER_MAX - proven; /* saturate: no overflow for any clock or rate */
    if (room <= UB_SEC_JUMP_SLACK) return UB_SEC_COUNTER_MAX;
    room -= UB_SEC_JUMP_SLACK;
    uint64_t secs = elapsed_ms / 1000u, ms = elapsed_ms % 1000u; /* rate x time without a 64-bit overflow */
    if (secs > room / max_rate) return UB_SEC_COUNTER_MAX;
    uint64_t ahead = secs * max_rate + ms * max_rate / 1000u;
    return ahead >= room ? UB_SEC_COUNTER_MAX : proven + UB_SEC_JUMP_SLACK + ahead;
}

ub_sec_window_verdict_t ub_sec_window_check(const ub_sec_window_t *w, uint64_t counter) {
    if (counter > w->highest) return UB_SEC_WINDOW_NEW;
    uint64_t behind = w->highest - counter;
    if (behind >= UB_SEC_WINDOW_BITS) return UB_SEC_WINDOW_OLD;
    return (w->seen >> behind) & 1u ? UB_SEC_WINDOW_DUPLICATE : UB_SEC_WINDOW_NEW;
}

void ub_sec_window_accept(ub_sec_window_t *w, uint64_t counter) {
    if (counter > w->highest) {
        uint64_t ahead = counter - w->highest;
        w->seen = ahead >= UB_SEC_WINDOW_BITS ? 1u : (w->seen << ahead) | 1u;
        w->highest = counter;
        return;
    }
    uint64_t behind = w->highest - counter;
    if (behind < UB_SEC_WINDOW_BITS) w->seen |= UINT64_C(1) << behind;
}

void ub_sec_window_establish(ub_sec_window_t *w, uint64_t counter) {
    w->highest = counter;
    w->seen = ~UINT64_C(0);
}
