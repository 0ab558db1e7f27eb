/* The compact encoding of a frame (contracts in ub/ub_compact.h; bytes in docs/wire-format.md). */
#include "ub/ub_compact.h"

#include <string.h>

#include "ub/ub_wire.h"

#define FNV_OFFSET 0xCBF29CE484222325ull
#define FNV_PRIME 0x100000001B3ull

static uint64_t fnv(uint64_t h, const uint8_t *p, size_t n) {
    for (size_t i = 0; i < n; i++) {
        h ^= p[i];
        h *= FNV_PRIME;
    }
    return h;
}

uint64_t ub_compact_catalogue_hash(const ub_catalogue_t *cat) {
    if (cat == NULL) return 0;
    uint64_t h = FNV_OFFSET;
    for (size_t i = 0; i < cat->n_instances; i++) {
        const ub_instance_desc_t *inst = &cat->instances[i];
        uint8_t b[8];
        ub_put_u32le(b, inst->type->fingerprint);
        ub_put_u32le(b + 4, inst->type->packed_size);
        h = fnv(h, inst->id, UB_DIR_ID_LEN);
        h = fnv(h, b, sizeof b);
    }
    return h;
}

uint64_t ub_compact_list_hash(const uint8_t (*ids)[UB_ENTITY_ID_LEN], size_t n) {
    uint8_t count = (uint8_t)n;
    uint64_t h = fnv(FNV_OFFSET, &count, 1);
    for (size_t i = 0; i < n; i++) h = fnv(h, ids[i], UB_ENTITY_ID_LEN);
    return h;
}

/* ---- COBS (Cheshire & Baker, 1999): no 0x00 inside a packet, so 0x00 delimits ------------------- */

size_t ub_cobs_encode(const uint8_t *in, size_t n, uint8_t *out, size_t cap) {
    if (out == NULL || (in == NULL && n > 0) || cap < UB_COBS_MAX(n)) return 0;
    size_t code_at = 0, o = 1;
    uint8_t code = 1;
    for (size_t i = 0; i < n; i++) {
        if (in[i] == 0) {
            out[code_at] = code;
            code_at = o++;
            code = 1;
            continue;
        }
        out[o++] = in[i];
        if (++code == 0xFF) { /* a full block of 254 non-zero bytes: no implied zero after it */
            out[code_at] = code;
            code_at = o++;
            code = 1;
        }
    }
    out[code_at] = code;
    out[o++] = 0;
    return o;
}

int ub_cobs_decode(const uint8_t *in, size_t n, uint8_t *out, size_t cap) {
    if (in == NULL || out == NULL) return UB_ERR_INVAL;
    size_t i = 0, o = 0;
    while (i < n) {
        uint8_t code = in[i++];
        if (code == 0 || i + (size_t)(code - 1) > n) return UB_ERR_INVAL;
        for (uint8_t k = 1; k < code; k++) {
            if (in[i] == 0) return UB_ERR_INVAL;
            if (o >= cap) return UB_ERR_NOSPACE;
            out[o++] = in[i++];
        }
        if (code != 0xFF && i < n) { /* the implied zero, except after the last block */
            if (o >= cap) return UB_ERR_NOSPACE;
            out[o++] = 0;
        }
    }
    return (int)o;
}

/* ---- codec --------------------------------------------------------------------------------------- */

static bool all_zero(const uint8_t *p, size_t n) {
    for (size_t i = 0; i < n; i++)
        if (p[i] != 0) return false;
    return true;
}

/* Index of `id` in the ascending list, or -1. */
static int list_index(const ub_compact_codec_t *c, const uint8_t id[UB_ENTITY_ID_LEN]) {
    if (!c->entities_ok || c->ids == NULL) return -1;
    int lo = 0, hi = c->n_ids;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        int cmp = memcmp(c->ids[mid], id, UB_ENTITY_ID_LEN);
        if (cmp == 0) return mid;
        if (cmp < 0) lo = mid + 1;
        else hi = mid;
    }
    return -1;
}

/* The check: CRC-32C of the dictionary prefix, then the packet bytes. */
static uint32_t packet_check(uint64_t cat_hash, uint64_t list_hash, const uint8_t *pkt, size_t n) {
    uint8_t prefix[16];
    ub_put_u64le(prefix, cat_hash);
    ub_put_u64le(prefix + 8, list_hash);
    return ub_crc32c_update(ub_crc32c(prefix, sizeof prefix), pkt, n);
}

/* Content varint v: 0 = no content, v = instance v - 1. At most 14 bits (two bytes). */
#define CONTENT_MAX 0x3FFFu

int ub_compact_encode(const ub_compact_codec_t *c, const uint8_t *frame, size_t len, bool seq32, uint8_t *pkt,
                      size_t cap) {
    if (c == NULL || frame == NULL || pkt == NULL || len < UB_FRAME_HEADER_LEN) return UB_ERR_INVAL;
    uint8_t flags = frame[UB_FRAME_OFF_VERSION] & UB_FRAME_FLAGS_MASK;
    if (!ub_frame_flags_valid(flags) || (frame[UB_FRAME_OFF_VERSION] & UB_FRAME_VERSION_MASK) != UB_WIRE_VERSION)
        return UB_ERR_INVAL;
    size_t ps = ub_get_u16le(frame + UB_FRAME_OFF_PAYLOAD_SIZE);
    size_t tl = ub_frame_trailer_len(flags);
    if (len != UB_FRAME_HEADER_LEN + ps + tl) return UB_ERR_INVAL;
    const uint8_t *dir = frame + UB_FRAME_OFF_DIR_ID;
    const uint8_t *dest = frame + UB_FRAME_OFF_DEST_ID;
    const uint8_t *src = frame + UB_FRAME_OFF_SRC_ID;
    const uint8_t *payload = frame + UB_FRAME_HEADER_LEN;
    uint8_t admin = frame[UB_FRAME_OFF_ADMIN];
    uint8_t hop = frame[UB_FRAME_OFF_HOP_LIMIT];
    uint32_t seq = ub_get_u32le(frame + UB_FRAME_OFF_SEQ);
    uint32_t fp = ub_get_u32le(frame + UB_FRAME_OFF_FINGERPRINT);
    if (hop == 0) return UB_ERR_INVAL;

    long v = -1; /* content varint, -1: full */
    const ub_type_desc_t *type = NULL;
    if (fp == 0 && all_zero(dir, UB_DIR_ID_LEN)) {
        v = 0;
    } else if (c->content_ok && c->cat != NULL) {
        int i = ub_catalogue_find(c->cat, dir);
        if (i >= 0 && (size_t)i < CONTENT_MAX) {
            const ub_type_desc_t *t = c->cat->instances[i].type;
            if (t->fingerprint == fp && (admin != UB_ADMIN_DATA || t->packed_size == ps)) {
                v = i + 1;
                type = t;
            }
        }
    }
    int di = list_index(c, dest), si = list_index(c, src);
    uint8_t ctl1 = 0;
    if (v < 0) ctl1 |= UB_COMPACT_DIR_FULL;
    if (di < 0) ctl1 |= UB_COMPACT_DEST_FULL;
    if (si < 0) ctl1 |= UB_COMPACT_SRC_FULL;
    if (seq32) ctl1 |= UB_COMPACT_SEQ32;
    if (di >= 0 && si >= 0 && (di > 15 || si > 15)) ctl1 |= UB_COMPACT_ENT_WIDE;
    if (flags & UB_FRAME_FLAG_ORIGIN) ctl1 |= UB_COMPACT_ORIGIN;
    size_t wire_ps = ps;
    if (admin == UB_ADMIN_DATA && type != NULL)
        while (wire_ps > 0 && payload[wire_ps - 1] == 0) wire_ps--;

    size_t need = 1u + (ctl1 != 0 ? 1u : 0u) + (hop > 15 ? 1u : 0u) + (admin != 0 ? 1u : 0u) + (seq32 ? 4u : 2u) +
                  (v < 0 ? UB_DIR_ID_LEN + 4u : v > 0x7F ? 2u : 1u) +
                  (!(ctl1 & (UB_COMPACT_DEST_FULL | UB_COMPACT_SRC_FULL | UB_COMPACT_ENT_WIDE))
                       ? 1u
                       : (di < 0 ? UB_ENTITY_ID_LEN : 1u) + (si < 0 ? UB_ENTITY_ID_LEN : 1u)) +
                  wire_ps + tl + UB_COMPACT_CHECK_LEN;
    if (cap < need) return UB_ERR_NOSPACE;
    size_t p = 0;
    uint8_t pf = flags & UB_FRAME_FLAG_PROTECT_MASK;
    uint8_t prot = pf == UB_FRAME_FLAG_SIGNED ? 1u : pf == UB_FRAME_FLAG_ENCRYPTED ? 2u : 0u;
    pkt[p++] = (uint8_t)((hop <= 15 ? hop : 0u) | (unsigned)prot << UB_COMPACT_PROT_SHIFT | (admin != 0 ? UB_COMPACT_ADMIN : 0u) |
                         (ctl1 != 0 ? UB_COMPACT_EXT : 0u));
    if (ctl1 != 0) pkt[p++] = ctl1;
    if (hop > 15) pkt[p++] = hop;
    if (admin != 0) pkt[p++] = admin;
    if (seq32) {
        ub_put_u32le(pkt + p, seq);
        p += 4;
    } else {
        ub_put_u16le(pkt + p, (uint16_t)seq);
        p += 2;
    }
    if (v < 0) {
        memcpy(pkt + p, dir, UB_DIR_ID_LEN);
        ub_put_u32le(pkt + p + UB_DIR_ID_LEN, fp);
        p += UB_DIR_ID_LEN + 4;
    } else if (v > 0x7F) {
        pkt[p++] = (uint8_t)(0x80u | (v & 0x7F));
        pkt[p++] = (uint8_t)(v >> 7);
    } else {
        pkt[p++] = (uint8_t)v;
    }
    if (!(ctl1 & (UB_COMPACT_DEST_FULL | UB_COMPACT_SRC_FULL | UB_COMPACT_ENT_WIDE))) {
        pkt[p++] = (uint8_t)(di | si << 4);
    } else {
        if (di < 0) {
            memcpy(pkt + p, dest, UB_ENTITY_ID_LEN);
            p += UB_ENTITY_ID_LEN;
        } else {
            pkt[p++] = (uint8_t)di;
        }
        if (si < 0) {
            memcpy(pkt + p, src, UB_ENTITY_ID_LEN);
            p += UB_ENTITY_ID_LEN;
        } else {
            pkt[p++] = (uint8_t)si;
        }
    }
    memcpy(pkt + p, payload, wire_ps);
    p += wire_ps;
    memcpy(pkt + p, payload + ps, tl);
    p += tl;
    uint32_t crc = packet_check(v > 0 ? c->cat_hash : 0, (di >= 0 || si >= 0) ? c->list_hash : 0, pkt, p);
    ub_put_u32le(pkt + p, crc);
    return (int)(p + UB_COMPACT_CHECK_LEN);
}

const ub_compact_ref_t *ub_compact_ref_find(const ub_compact_refs_t *refs, const uint8_t src[UB_ENTITY_ID_LEN]) {
    if (refs == NULL || src == NULL) return NULL;
    for (size_t i = 0; i < UB_COMPACT_REFS; i++)
        if (refs->ref[i].in_use && memcmp(refs->ref[i].src, src, UB_ENTITY_ID_LEN) == 0) return &refs->ref[i];
    return NULL;
}

static int reject(ub_rx_reason_t *why, ub_rx_reason_t reason) {
    if (why != NULL) *why = reason;
    return reason == UB_RX_BAD_CRC ? UB_ERR_CHECKSUM : UB_ERR_INVAL;
}

int ub_compact_decode(const ub_compact_codec_t *c, const uint8_t *pkt, size_t n, const ub_compact_refs_t *refs,
                      uint8_t *frame, size_t cap, ub_frame_header_t *h, ub_rx_reason_t *why) {
    if (c == NULL || pkt == NULL || frame == NULL || h == NULL || cap < UB_FRAME_MAX) return reject(why, UB_RX_BAD_LENGTH);
    if (n < 1 + 2 + 1 + 1 + UB_COMPACT_CHECK_LEN) return reject(why, UB_RX_BAD_LENGTH);
    size_t end = n - UB_COMPACT_CHECK_LEN; /* fields must end before the check */
    size_t p = 0;
    uint8_t ctl0 = pkt[p++];
    uint8_t ctl1 = 0;
    if (ctl0 & UB_COMPACT_EXT) ctl1 = pkt[p++];
    unsigned prot = (ctl0 & UB_COMPACT_PROT_MASK) >> UB_COMPACT_PROT_SHIFT;
    if ((ctl1 & UB_COMPACT_CTL1_RESERVED) || prot == 3 || ((ctl1 & UB_COMPACT_ORIGIN) && prot == 0))
        return reject(why, UB_RX_BAD_VERSION);
    uint8_t flags = prot == 1 ? UB_FRAME_FLAG_SIGNED : prot == 2 ? UB_FRAME_FLAG_ENCRYPTED : 0u;
    if (ctl1 & UB_COMPACT_ORIGIN) flags |= UB_FRAME_FLAG_ORIGIN;
    size_t tl = ub_frame_trailer_len(flags);
    uint8_t hop = ctl0 & UB_COMPACT_HOP_MASK;
    if (hop == 0) {
        if (p >= end) return reject(why, UB_RX_BAD_LENGTH);
        hop = pkt[p++];
        if (hop == 0) return reject(why, UB_RX_BAD_VERSION);
    }
    uint8_t admin = 0;
    if (ctl0 & UB_COMPACT_ADMIN) {
        if (p >= end) return reject(why, UB_RX_BAD_LENGTH);
        admin = pkt[p++];
    }
    uint32_t seq;
    bool seq32 = (ctl1 & UB_COMPACT_SEQ32) != 0;
    if (p + (seq32 ? 4u : 2u) > end) return reject(why, UB_RX_BAD_LENGTH);
    seq = seq32 ? ub_get_u32le(pkt + p) : ub_get_u16le(pkt + p);
    p += seq32 ? 4u : 2u;
    long v = -1;
    const uint8_t *dir_full = NULL;
    uint32_t fp = 0;
    if (ctl1 & UB_COMPACT_DIR_FULL) {
        if (p + UB_DIR_ID_LEN + 4 > end) return reject(why, UB_RX_BAD_LENGTH);
        dir_full = pkt + p;
        fp = ub_get_u32le(pkt + p + UB_DIR_ID_LEN);
        p += UB_DIR_ID_LEN + 4;
    } else {
        if (p >= end) return reject(why, UB_RX_BAD_LENGTH);
        uint8_t b0 = pkt[p++];
        v = b0 & 0x7F;
        if (b0 & 0x80) {
            if (p >= end) return reject(why, UB_RX_BAD_LENGTH);
            uint8_t b1 = pkt[p++];
            if (b1 & 0x80) return reject(why, UB_RX_BAD_VERSION);
            v |= (long)b1 << 7;
        }
    }
    bool dest_full = (ctl1 & UB_COMPACT_DEST_FULL) != 0, src_full = (ctl1 & UB_COMPACT_SRC_FULL) != 0;
    int di = -1, si = -1;
    const uint8_t *dest = NULL, *src = NULL;
    if (!dest_full && !src_full && !(ctl1 & UB_COMPACT_ENT_WIDE)) {
        if (p >= end) return reject(why, UB_RX_BAD_LENGTH);
        di = pkt[p] & 0x0F;
        si = pkt[p] >> 4;
        p++;
    } else {
        if (p + (dest_full ? UB_ENTITY_ID_LEN : 1u) > end) return reject(why, UB_RX_BAD_LENGTH);
        if (dest_full) dest = pkt + p;
        else di = pkt[p];
        p += dest_full ? UB_ENTITY_ID_LEN : 1u;
        if (p + (src_full ? UB_ENTITY_ID_LEN : 1u) > end) return reject(why, UB_RX_BAD_LENGTH);
        if (src_full) src = pkt + p;
        else si = pkt[p];
        p += src_full ? UB_ENTITY_ID_LEN : 1u;
    }
    if (p + tl > end) return reject(why, UB_RX_BAD_LENGTH);
    size_t wire_ps = end - p - tl;
    bool entity_index = di >= 0 || si >= 0;
    if (entity_index && (!c->entities_ok || c->ids == NULL)) return reject(why, UB_RX_NO_DICTIONARY);
    if (v > 0 && c->cat == NULL) return reject(why, UB_RX_NO_DICTIONARY);
    uint32_t crc = packet_check(v > 0 ? c->cat_hash : 0, entity_index ? c->list_hash : 0, pkt, end);
    if (crc != ub_get_u32le(pkt + end)) return reject(why, UB_RX_BAD_CRC);

    /* Expand. */
    memset(h, 0, sizeof *h);
    size_t ps = wire_ps;
    if (dir_full != NULL) {
        memcpy(h->dir_id, dir_full, UB_DIR_ID_LEN);
        h->fingerprint = fp;
    } else if (v > 0) {
        if ((size_t)(v - 1) >= c->cat->n_instances) return reject(why, UB_RX_BAD_LENGTH);
        const ub_instance_desc_t *inst = &c->cat->instances[v - 1];
        memcpy(h->dir_id, inst->id, UB_DIR_ID_LEN);
        h->fingerprint = inst->type->fingerprint;
        if (admin == UB_ADMIN_DATA) {
            if (wire_ps > inst->type->packed_size) return reject(why, UB_RX_BAD_LENGTH);
            ps = inst->type->packed_size;
        }
    }
    if (ps > UB_MAX_PAYLOAD) return reject(why, UB_RX_BAD_LENGTH);
    if ((di >= 0 && di >= c->n_ids) || (si >= 0 && si >= c->n_ids)) return reject(why, UB_RX_BAD_LENGTH);
    memcpy(h->dest_id, dest != NULL ? dest : c->ids[di], UB_ENTITY_ID_LEN);
    memcpy(h->src_id, src != NULL ? src : c->ids[si], UB_ENTITY_ID_LEN);
    if (!seq32) {
        const ub_compact_ref_t *ref = ub_compact_ref_find(refs, h->src_id);
        if (ref == NULL) return reject(why, UB_RX_NO_REFERENCE);
        seq = ub_compact_seq_restore(ref->seq, (uint16_t)seq);
    }
    h->msg_type = UB_MSG_TYPE_PUBSUB;
    h->flags = flags;
    h->admin = admin;
    h->hop_limit = hop;
    h->payload_size = (uint16_t)ps;
    h->seq = seq;
    uint8_t *body = frame + UB_FRAME_HEADER_LEN;
    memcpy(body, pkt + p, wire_ps);
    memset(body + wire_ps, 0, ps - wire_ps);
    memcpy(body + ps, pkt + p + wire_ps, tl);
    if (tl > 0) {
        h->key_id = body[ps + UB_FRAME_TRL_OFF_KEY_ID];
        h->counter_hi = ub_get_u16le(body + ps + UB_FRAME_TRL_OFF_COUNTER_HI);
        if (flags & UB_FRAME_FLAG_ORIGIN) {
            h->origin_hop0 = body[ps + tl - UB_FRAME_ORIGIN_LEN];
            memcpy(h->origin_tag, body + ps + tl - UB_FRAME_ORIGIN_TAG_LEN, UB_FRAME_ORIGIN_TAG_LEN);
        }
    }
    int len = ub_frame_finish(frame, cap, h);
    if (len < 0) return reject(why, UB_RX_BAD_LENGTH);
    return len;
}

/* ---- references -------------------------------------------------------------------------------- */

static ub_compact_ref_t *ref_get(ub_compact_refs_t *refs, const uint8_t src[UB_ENTITY_ID_LEN], bool *fresh) {
    ub_compact_ref_t *hit = (ub_compact_ref_t *)ub_compact_ref_find(refs, src);
    *fresh = hit == NULL;
    if (hit == NULL) {
        hit = &refs->ref[0];
        for (size_t i = 0; i < UB_COMPACT_REFS; i++) {
            ub_compact_ref_t *r = &refs->ref[i];
            if (!r->in_use) {
                hit = r;
                break;
            }
            if (r->used < hit->used) hit = r;
        }
        memset(hit, 0, sizeof *hit);
        memcpy(hit->src, src, UB_ENTITY_ID_LEN);
        hit->in_use = 1;
    }
    hit->used = ++refs->stamp;
    return hit;
}

void ub_compact_rx_note(ub_compact_t *s, const uint8_t src[UB_ENTITY_ID_LEN], uint32_t seq, bool seq32) {
    if (s == NULL || src == NULL) return;
    bool fresh;
    ub_compact_ref_t *r = ref_get(&s->rx, src, &fresh);
    if (fresh || seq32 || (int32_t)(seq - r->seq) > 0) r->seq = seq;
}

/* ---- a link ------------------------------------------------------------------------------------ */

void ub_compact_init(ub_compact_t *s, const ub_catalogue_t *cat, uint32_t epoch, const ub_compact_params_t *params) {
    if (s == NULL) return;
    memset(s, 0, sizeof *s);
    if (params != NULL) s->params = *params;
    if (s->params.hello_ms == 0) s->params.hello_ms = UB_COMPACT_HELLO_MS;
    if (s->params.retry_ms == 0) s->params.retry_ms = UB_COMPACT_RETRY_MS;
    if (s->params.change_min_ms == 0) s->params.change_min_ms = UB_COMPACT_CHANGE_MIN_MS;
    s->epoch = epoch != 0 ? epoch : 1u;
    s->cat = cat;
    s->cat_hash = ub_compact_catalogue_hash(cat);
}

/* A round at once: for events that happen once per peer epoch (first contact, a restart, the peer's list
 * complete), so they cannot make a storm. */
static void schedule_now(ub_compact_t *s, uint64_t now_ms) {
    s->started = 1;
    if (now_ms < s->next_round_ms) s->next_round_ms = now_ms;
}

/* A round soon, at most one per retry_ms: for what a peer or a line fault may repeat (echo mismatch, packets
 * this end could not expand). */
static void schedule_soon(ub_compact_t *s, uint64_t now_ms) {
    uint64_t at = s->last_round_ms + s->params.retry_ms;
    if (!s->started || at < now_ms) at = now_ms;
    if (at < s->next_round_ms) s->next_round_ms = at;
}

void ub_compact_set_local(ub_compact_t *s, const uint8_t (*ids)[UB_ENTITY_ID_LEN], size_t n, uint64_t version,
                          uint64_t now_ms) {
    if (s == NULL || (ids == NULL && n > 0)) return;
    if (s->have_list && s->version == version) return;
    uint8_t sorted[UB_COMPACT_DICT_MAX][UB_ENTITY_ID_LEN];
    size_t m = 0;
    for (size_t i = 0; i < n; i++) { /* insertion sort, ascending; the first UB_COMPACT_DICT_MAX by ID */
        size_t at = m;
        while (at > 0 && memcmp(sorted[at - 1], ids[i], UB_ENTITY_ID_LEN) > 0) at--;
        if (at >= UB_COMPACT_DICT_MAX) continue;
        size_t move = (m < UB_COMPACT_DICT_MAX ? m : UB_COMPACT_DICT_MAX - 1) - at;
        memmove(sorted[at + 1], sorted[at], move * UB_ENTITY_ID_LEN);
        memcpy(sorted[at], ids[i], UB_ENTITY_ID_LEN);
        if (m < UB_COMPACT_DICT_MAX) m++;
    }
    uint64_t hash = ub_compact_list_hash((const uint8_t(*)[UB_ENTITY_ID_LEN])sorted, m);
    bool changed = !s->have_list || hash != s->list_hash;
    memcpy(s->ids, sorted, m * UB_ENTITY_ID_LEN);
    s->n_ids = (uint8_t)m;
    s->list_hash = hash;
    s->version = version;
    s->have_list = 1;
    if (changed) {
        s->started = 1;
        s->next_round_ms = now_ms; /* announce the new list now (a round under way finishes first) */
    }
}

void ub_compact_tx_codec(const ub_compact_t *s, ub_compact_codec_t *c) {
    memset(c, 0, sizeof *c);
    c->cat = s->cat;
    c->cat_hash = s->cat_hash;
    c->content_ok = s->cat != NULL && s->peer_heard && s->peer_cat_hash == s->cat_hash;
    c->entities_ok = s->have_list && s->list_hash != 0 && s->peer_echo == s->list_hash;
    c->n_ids = s->n_ids;
    c->ids = (const uint8_t(*)[UB_ENTITY_ID_LEN])s->ids;
    c->list_hash = s->list_hash;
}

void ub_compact_rx_codec(const ub_compact_t *s, ub_compact_codec_t *c) {
    memset(c, 0, sizeof *c);
    c->cat = s->cat;
    c->cat_hash = s->cat_hash; /* a content index decodes only if the sender's catalogue hash was ours (the check) */
    c->content_ok = s->cat != NULL;
    c->entities_ok = s->peer_list_ok;
    c->n_ids = s->peer_n;
    c->ids = (const uint8_t(*)[UB_ENTITY_ID_LEN])s->peer_ids;
    c->list_hash = s->peer_list_hash;
}

bool ub_compact_agreed(const ub_compact_t *s) {
    if (s == NULL) return false;
    ub_compact_codec_t c;
    ub_compact_tx_codec(s, &c);
    return c.entities_ok && (c.content_ok || s->cat == NULL) && s->peer_list_ok;
}

int ub_compact_link_encode(ub_compact_t *s, const uint8_t *frame, size_t len, uint8_t *wire, size_t cap) {
    if (s == NULL || frame == NULL || wire == NULL || len < UB_FRAME_HEADER_LEN) return UB_ERR_INVAL;
    ub_compact_codec_t c;
    ub_compact_tx_codec(s, &c);
    uint32_t seq = ub_get_u32le(frame + UB_FRAME_OFF_SEQ);
    bool fresh;
    ub_compact_ref_t *r = ref_get(&s->tx, frame + UB_FRAME_OFF_SRC_ID, &fresh);
    int32_t jump = (int32_t)(seq - r->seq);
    /* The first three frames of a source all carry 32 bits, so one lost frame does not leave the peer without a
     * reference until the next periodic one. */
    bool seq32 = fresh || r->seq32_count < 3 || r->since_seq32 >= UB_COMPACT_SEQ32_EVERY - 1 ||
                 jump >= (int32_t)UB_COMPACT_SEQ_JUMP || jump <= -(int32_t)UB_COMPACT_SEQ_JUMP;
    uint8_t pkt[UB_COMPACT_PACKET_MAX];
    int n = ub_compact_encode(&c, frame, len, seq32, pkt, sizeof pkt);
    if (n < 0) return n;
    size_t w = ub_cobs_encode(pkt, (size_t)n, wire, cap);
    if (w == 0) return UB_ERR_NOSPACE;
    r->seq = seq;
    if (seq32) {
        r->since_seq32 = 0;
        if (r->seq32_count < 255) r->seq32_count++;
        s->stats.tx_seq32++;
    } else {
        r->since_seq32++;
    }
    s->stats.tx_frames++;
    s->stats.tx_bytes += w;
    s->stats.tx_full_bytes += len;
    if (pkt[0] & UB_COMPACT_EXT && pkt[1] & (UB_COMPACT_DIR_FULL | UB_COMPACT_DEST_FULL | UB_COMPACT_SRC_FULL))
        s->stats.tx_full_ids++;
    return (int)w;
}

void ub_compact_tx_forget(ub_compact_t *s, const uint8_t src[UB_ENTITY_ID_LEN]) {
    ub_compact_ref_t *r = s != NULL ? (ub_compact_ref_t *)ub_compact_ref_find(&s->tx, src) : NULL;
    if (r != NULL) memset(r, 0, sizeof *r);
}

_Static_assert(UB_COMPACT_WIRE_MAX <= UB_FRAME_MAX, "a stream's unfinished packet is carried in ub_decoder_t.buf");

/* A stream decoder discarding an overlong packet until the next delimiter. */
#define OVERFLOW ((size_t)-1)

/* One stuffed packet without its delimiter: unstuffed, decoded, handed on or counted. */
static bool take_packet(ub_compact_t *s, const uint8_t *seg, size_t n, uint64_t now_ms, uint64_t *rejected,
                        ub_compact_frame_cb cb, void *user) {
    uint8_t pkt[UB_COMPACT_PACKET_MAX];
    uint8_t frame[UB_FRAME_MAX];
    ub_rx_reason_t why = UB_RX_BAD_CRC;
    int m = ub_cobs_decode(seg, n, pkt, sizeof pkt);
    int len = -1;
    ub_frame_header_t h;
    if (m < 0) {
        why = m == UB_ERR_NOSPACE ? UB_RX_BAD_LENGTH : UB_RX_BAD_CRC; /* stuffing broken: line noise */
    } else {
        ub_compact_codec_t c;
        ub_compact_rx_codec(s, &c);
        len = ub_compact_decode(&c, pkt, (size_t)m, &s->rx, frame, sizeof frame, &h, &why);
    }
    if (len < 0) {
        s->stats.rejected[why]++;
        if (rejected != NULL) rejected[why]++;
        if (why == UB_RX_NO_REFERENCE) s->refs_lost++;
        if (why == UB_RX_NO_DICTIONARY || why == UB_RX_NO_REFERENCE) schedule_soon(s, now_ms);
        return false;
    }
    s->stats.rx_frames++;
    /* Traffic from a peer whose LINK_HELLO we never took in (lost, or dropped while its freshness was being
     * established): announce ourselves again soon, which makes it answer. */
    if (!s->peer_heard) schedule_soon(s, now_ms);
    if (cb != NULL) cb(user, &h, frame, (size_t)len, (pkt[0] & UB_COMPACT_EXT) && (pkt[1] & UB_COMPACT_SEQ32));
    return true;
}

/* A stream segment that is not a packet, on a link with a foreign-traffic handler: foreign bytes with, maybe,
 * a packet glued after them. Returns where the first suffix that decodes as a packet starts (its CRC-32C check
 * makes a false find improbable), or `n`. Quiet: nothing is counted for the suffixes tried. Only after a
 * rejection with a handler set, so a pure compact stream never pays for it. */
static size_t packet_suffix(const ub_compact_t *s, const uint8_t *seg, size_t n) {
    uint8_t pkt[UB_COMPACT_PACKET_MAX];
    uint8_t frame[UB_FRAME_MAX];
    ub_compact_codec_t c;
    ub_compact_rx_codec(s, &c);
    for (size_t k = 1; k + 1 < n; k++) {
        int m = ub_cobs_decode(seg + k, n - k, pkt, sizeof pkt);
        ub_frame_header_t h;
        if (m > 0 && ub_compact_decode(&c, pkt, (size_t)m, &s->rx, frame, sizeof frame, &h, NULL) >= 0) return k;
    }
    return n;
}

size_t ub_compact_feed(ub_compact_t *s, ub_decoder_t *stream, const uint8_t *data, size_t len, uint64_t now_ms,
                       uint64_t rejected[UB_RX_REASON_COUNT], ub_compact_frame_cb cb, void *user) {
    if (s == NULL || (data == NULL && len > 0)) return 0;
    s->stats.rx_bytes += len;
    ub_decoder_stats_t *ds = stream != NULL ? &stream->stats : NULL;
    if (ds != NULL) {
        ds->bytes_in += len;
        rejected = ds->rejected;
    }
    size_t frames = 0, pos = 0;
    while (pos < len) {
        const uint8_t *z = memchr(data + pos, 0, len - pos);
        size_t seg = z != NULL ? (size_t)(z - (data + pos)) : len - pos;
        if (stream == NULL) {
            if (z == NULL) { /* a tail without its delimiter: not a packet */
                s->stats.rejected[UB_RX_BAD_LENGTH]++;
                if (rejected != NULL) rejected[UB_RX_BAD_LENGTH]++;
                s->stats.garbage_bytes += seg;
                break;
            }
            if (seg > 0 && take_packet(s, data + pos, seg, now_ms, rejected, cb, user)) frames++;
            else s->stats.garbage_bytes += seg + 1;
            pos += seg + 1;
            continue;
        }
        /* Stream: append to the carried packet; one longer than the largest packet is not a packet (noise, or
         * foreign traffic: handed on as it comes, the decoder's handler decides). */
        if (stream->have != OVERFLOW && stream->have + seg <= UB_COMPACT_WIRE_MAX) {
            memcpy(stream->buf + stream->have, data + pos, seg);
            stream->have += seg;
        } else {
            size_t held = stream->have != OVERFLOW ? stream->have : 0;
            s->stats.garbage_bytes += held + seg;
            stream->have = OVERFLOW;
            ub_decoder_not_frame(stream, stream->buf, held);
            ub_decoder_not_frame(stream, data + pos, seg);
        }
        pos += seg;
        if (z == NULL) break;
        pos++; /* the delimiter */
        size_t have = stream->have;
        stream->have = 0;
        if (have == OVERFLOW) {
            s->stats.rejected[UB_RX_BAD_LENGTH]++;
            ds->rejected[UB_RX_BAD_LENGTH]++;
            s->stats.garbage_bytes++;
            ub_decoder_not_frame(stream, data + pos - 1, 1);
        } else if (have > 0 && take_packet(s, stream->buf, have, now_ms, rejected, cb, user)) {
            frames++;
            ds->frames_ok++;
            ds->bytes_ok += have + 1;
        } else {
            /* Foreign traffic carries no delimiter of ours: its bytes are glued to the packet after them. */
            size_t k = stream->foreign != NULL ? packet_suffix(s, stream->buf, have) : have;
            s->stats.garbage_bytes += k;
            ub_decoder_not_frame(stream, stream->buf, k);
            if (k < have && take_packet(s, stream->buf + k, have - k, now_ms, rejected, cb, user)) {
                frames++;
                ds->frames_ok++;
                ds->bytes_ok += have - k + 1;
            } else {
                s->stats.garbage_bytes += have - k + 1;
                ub_decoder_not_frame(stream, data + pos - 1, 1);
            }
        }
    }
    return frames;
}

/* ---- LINK_HELLO ---------------------------------------------------------------------------------- */

static size_t page_count(size_t n) { return n == 0 ? 1 : (n + UB_COMPACT_PAGE - 1) / UB_COMPACT_PAGE; }

bool ub_compact_hello_due(ub_compact_t *s, uint64_t now_ms, uint8_t *payload, size_t cap, uint16_t *len) {
    if (s == NULL || payload == NULL || len == NULL || !s->have_list) return false;
    if (cap < UB_COMPACT_HELLO_FIXED + UB_COMPACT_PAGE * UB_ENTITY_ID_LEN) return false;
    if (!s->started) {
        s->started = 1;
        s->next_round_ms = now_ms;
    }
    if (s->round_page >= s->round_pages) {
        if (now_ms < s->next_round_ms) return false;
        s->round_pages = (uint8_t)page_count(s->n_ids);
        s->round_page = 0;
        s->last_round_ms = now_ms;
        /* Agreed: refresh now and then; heard but not agreed: soon; peer silent: back off. */
        uint32_t gap = ub_compact_agreed(s) ? s->params.hello_ms
                     : s->peer_heard       ? s->params.retry_ms
                                           : 4u * s->params.retry_ms;
        s->next_round_ms = now_ms + gap;
    }
    size_t first = (size_t)s->round_page * UB_COMPACT_PAGE;
    size_t count = s->n_ids > first ? s->n_ids - first : 0;
    if (count > UB_COMPACT_PAGE) count = UB_COMPACT_PAGE;
    s->round_page++;
    memset(payload, 0, UB_COMPACT_HELLO_FIXED);
    payload[UB_CH_OFF_VERSION] = UB_COMPACT_HELLO_VERSION;
    payload[UB_CH_OFF_FIRST] = (uint8_t)first;
    payload[UB_CH_OFF_COUNT] = (uint8_t)count;
    payload[UB_CH_OFF_TOTAL] = s->n_ids;
    ub_put_u32le(payload + UB_CH_OFF_EPOCH, s->epoch);
    ub_put_u64le(payload + UB_CH_OFF_CAT, s->cat_hash);
    ub_put_u64le(payload + UB_CH_OFF_LIST, s->list_hash);
    ub_put_u64le(payload + UB_CH_OFF_ECHO, s->peer_list_ok ? s->peer_list_hash : 0);
    ub_put_u32le(payload + UB_CH_OFF_REFS_LOST, s->refs_lost);
    memcpy(payload + UB_CH_OFF_IDS, s->ids[first], count * UB_ENTITY_ID_LEN);
    *len = (uint16_t)(UB_COMPACT_HELLO_FIXED + count * UB_ENTITY_ID_LEN);
    s->stats.hello_tx++;
    return true;
}

static void reset_tx_refs(ub_compact_t *s) { memset(&s->tx, 0, sizeof s->tx); }

int ub_compact_on_hello(ub_compact_t *s, const uint8_t *payload, size_t len, uint64_t now_ms) {
    return ub_compact_on_hello_from(s, payload, len, now_ms, true);
}

int ub_compact_on_hello_from(ub_compact_t *s, const uint8_t *payload, size_t len, uint64_t now_ms, bool authenticated) {
    if (s == NULL || payload == NULL) return UB_ERR_INVAL;
    if (len < UB_COMPACT_HELLO_FIXED || payload[UB_CH_OFF_VERSION] != UB_COMPACT_HELLO_VERSION) {
        s->stats.hello_bad++;
        return UB_ERR_INVAL;
    }
    size_t first = payload[UB_CH_OFF_FIRST], count = payload[UB_CH_OFF_COUNT], total = payload[UB_CH_OFF_TOTAL];
    size_t want = total > first ? total - first : 0;
    if (want > UB_COMPACT_PAGE) want = UB_COMPACT_PAGE;
    if (first % UB_COMPACT_PAGE != 0 || (total > 0 && first >= total) || (total == 0 && first != 0) || count != want ||
        len != UB_COMPACT_HELLO_FIXED + count * UB_ENTITY_ID_LEN) {
        s->stats.hello_bad++;
        return UB_ERR_INVAL;
    }
    uint32_t epoch = ub_get_u32le(payload + UB_CH_OFF_EPOCH);
    uint32_t refs_lost = ub_get_u32le(payload + UB_CH_OFF_REFS_LOST);
    if (s->peer_heard && (epoch != s->peer_epoch || ub_get_u64le(payload + UB_CH_OFF_CAT) != s->peer_cat_hash ||
                          ub_get_u64le(payload + UB_CH_OFF_LIST) != s->peer_list_hash)) {
        /* A change of the peer's dictionary. Unauthenticated, at most one per change_min_ms (a clock that went
         * backwards lets one through, so the link is never stuck on a stale dictionary). */
        if (!authenticated && s->stats.dict_changes > 0 && now_ms >= s->change_ms &&
            now_ms - s->change_ms < s->params.change_min_ms) {
            s->stats.dict_limited++;
            return UB_ERR_AGAIN;
        }
        s->stats.dict_changes++;
        s->change_ms = now_ms;
    }
    if (!s->peer_heard || epoch != s->peer_epoch) {
        /* First contact, or the peer restarted: it holds no references and none of our list. */
        if (s->peer_heard) s->stats.peer_restarts++;
        reset_tx_refs(s);
        s->peer_list_ok = 0;
        s->peer_list_hash = 0;
        s->peer_n = 0;
        memset(s->peer_pages, 0, sizeof s->peer_pages);
        s->peer_epoch = epoch;
        s->peer_refs_lost = refs_lost;
        s->peer_heard = 1;
        schedule_now(s, now_ms);
    }
    if (refs_lost != s->peer_refs_lost) { /* the peer lacked references: send all 32 bits again */
        reset_tx_refs(s);
        s->peer_refs_lost = refs_lost;
    }
    s->stats.hello_rx++;
    s->peer_cat_hash = ub_get_u64le(payload + UB_CH_OFF_CAT);
    s->peer_echo = ub_get_u64le(payload + UB_CH_OFF_ECHO);
    if (s->have_list && s->peer_echo != s->list_hash) schedule_soon(s, now_ms);
    uint64_t list = ub_get_u64le(payload + UB_CH_OFF_LIST);
    if (list != s->peer_list_hash || total != s->peer_n) {
        s->peer_list_ok = 0;
        s->peer_list_hash = list;
        s->peer_n = (uint8_t)(total <= UB_COMPACT_DICT_MAX ? total : 0);
        memset(s->peer_pages, 0, sizeof s->peer_pages);
    }
    if (s->peer_list_ok || total > UB_COMPACT_DICT_MAX) return UB_OK; /* held already, or too long to hold */
    memcpy(s->peer_ids[first], payload + UB_CH_OFF_IDS, count * UB_ENTITY_ID_LEN);
    size_t page = first / UB_COMPACT_PAGE, pages = page_count(total);
    s->peer_pages[page / 8] |= (uint8_t)(1u << (page % 8));
    for (size_t k = 0; k < pages; k++)
        if (!(s->peer_pages[k / 8] & (1u << (k % 8)))) return UB_OK;
    if (ub_compact_list_hash((const uint8_t(*)[UB_ENTITY_ID_LEN])s->peer_ids, total) == list) {
        s->peer_list_ok = 1;
        s->stats.peer_lists++;
        schedule_now(s, now_ms); /* echo it at once, so the peer starts using indices */
    } else {
        s->stats.hello_bad++;
        memset(s->peer_pages, 0, sizeof s->peer_pages);
    }
    return UB_OK;
}

size_t ub_compact_wire_size(const ub_compact_t *s, const uint8_t dir_id[UB_DIR_ID_LEN], uint32_t fingerprint,
                            const uint8_t dest_id[UB_ENTITY_ID_LEN], const uint8_t src_id[UB_ENTITY_ID_LEN],
                            size_t payload_len, size_t trailer_len) {
    ub_compact_codec_t c;
    ub_compact_tx_codec(s, &c);
    size_t content = UB_DIR_ID_LEN + 4u;
    if (fingerprint == 0 && all_zero(dir_id, UB_DIR_ID_LEN)) {
        content = 1;
    } else if (c.content_ok && c.cat != NULL) {
        int i = ub_catalogue_find(c.cat, dir_id);
        if (i >= 0 && c.cat->instances[i].type->fingerprint == fingerprint) content = i + 1 > 0x7F ? 2u : 1u;
    }
    int di = list_index(&c, dest_id), si = list_index(&c, src_id);
    size_t ents = (di < 0 ? UB_ENTITY_ID_LEN : 1u) + (si < 0 ? UB_ENTITY_ID_LEN : 1u);
    /* ctl0, ctl1, hop byte, admin byte, 32-bit sequence: the worst case of each. */
    size_t pkt = 1 + 1 + 1 + 1 + 4 + content + ents + payload_len + trailer_len + UB_COMPACT_CHECK_LEN;
    return UB_COBS_MAX(pkt);
}
