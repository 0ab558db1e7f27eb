/* Origin authentication (contracts in ub/ub_origin.h; design in docs/security.md, "Origin
 * authentication"). A service: it seals the frames local entities originate and opens the frames that
 * reach them, through the node's seal/open hooks (ub_service.h); the core only carries the block.
 * Cryptography is libsodium's alone: X25519 (crypto_scalarmult), BLAKE2b (crypto_generichash), its KDF,
 * SipHash-2-4 (crypto_shorthash_siphash24), constant-time comparison (sodium_memcmp). */
#include "ub/ub_origin.h"
#include "codec/ub_wipe_private.h"

#include <string.h>

#include "ub/ub_node.h"
#include "ub/ub_node_svc.h"
#include "ub/ub_sec.h"

#if defined(UB_SECURITY) && UB_SECURITY
#include <sodium.h>
#define HAVE_SODIUM 1
#define HAVE_AGREEMENT UB_ORIGIN_AGREEMENT
_Static_assert(crypto_scalarmult_BYTES == UB_ORIGIN_PK_LEN, "X25519 public key length");
_Static_assert(crypto_scalarmult_SCALARBYTES == UB_ORIGIN_SK_LEN, "X25519 secret key length");
_Static_assert(crypto_shorthash_siphash24_KEYBYTES == UB_ORIGIN_KEY_LEN, "SipHash-2-4 key = a directional key");
_Static_assert(crypto_shorthash_siphash24_BYTES == UB_FRAME_ORIGIN_TAG_LEN, "SipHash-2-4 output = the origin tag");
_Static_assert(crypto_kdf_CONTEXTBYTES == sizeof UB_ORIGIN_KDF_CONTEXT - 1u, "KDF context length");
_Static_assert(UB_ORIGIN_KEY_LEN >= crypto_kdf_BYTES_MIN, "KDF subkey length");
#else
#define HAVE_SODIUM 0
#define HAVE_AGREEMENT 0
#endif

_Static_assert(sizeof UB_ORIGIN_DOMAIN - 1u == 11u, "the origin domain replaces the 11-byte signing domain");
_Static_assert(sizeof UB_ORIGIN_AGREE_DOMAIN - 1u == 16u, "agreement domain is 16 bytes");

#define AGREE_INPUT_LEN (16u + 32u + 2u * (UB_ENTITY_ID_LEN + UB_ORIGIN_PK_LEN))

/* ---- pure functions ---------------------------------------------------------------------------- */

int ub_origin_public_key(const uint8_t sk[UB_ORIGIN_SK_LEN], uint8_t pk[UB_ORIGIN_PK_LEN]) {
    if (sk == NULL || pk == NULL) return UB_ERR_INVAL;
#if HAVE_AGREEMENT
    return crypto_scalarmult_base(pk, sk) == 0 ? UB_OK : UB_ERR_INVAL;
#else
    return UB_ERR_UNSUPPORTED;
#endif
}

int ub_origin_pair_keys(const uint8_t self_id[UB_ENTITY_ID_LEN], const uint8_t self_sk[UB_ORIGIN_SK_LEN],
                        const uint8_t peer_id[UB_ENTITY_ID_LEN], const uint8_t peer_pk[UB_ORIGIN_PK_LEN],
                        uint8_t k_tx[UB_ORIGIN_KEY_LEN], uint8_t k_rx[UB_ORIGIN_KEY_LEN]) {
    if (self_id == NULL || self_sk == NULL || peer_id == NULL || peer_pk == NULL || k_tx == NULL || k_rx == NULL)
        return UB_ERR_INVAL;
    int order = memcmp(self_id, peer_id, UB_ENTITY_ID_LEN);
    if (order == 0) return UB_ERR_INVAL;
#if HAVE_AGREEMENT
    uint8_t self_pk[UB_ORIGIN_PK_LEN];
    if (crypto_scalarmult_base(self_pk, self_sk) != 0) return UB_ERR_INVAL;
    uint8_t in[AGREE_INPUT_LEN];
    uint8_t *p = in;
    memcpy(p, UB_ORIGIN_AGREE_DOMAIN, 16);
    p += 16;
    /* libsodium refuses (returns -1) an all-zero result: a small-order public key contributes nothing. */
    if (crypto_scalarmult(p, self_sk, peer_pk) != 0) {
        ub_priv_wipe(in, sizeof in);
        return UB_ERR_AUTH;
    }
    p += 32;
    const uint8_t *a_id = order < 0 ? self_id : peer_id, *a_pk = order < 0 ? self_pk : peer_pk;
    const uint8_t *b_id = order < 0 ? peer_id : self_id, *b_pk = order < 0 ? peer_pk : self_pk;
    memcpy(p, a_id, UB_ENTITY_ID_LEN);
    p += UB_ENTITY_ID_LEN;
    memcpy(p, a_pk, UB_ORIGIN_PK_LEN);
    p += UB_ORIGIN_PK_LEN;
    memcpy(p, b_id, UB_ENTITY_ID_LEN);
    p += UB_ENTITY_ID_LEN;
    memcpy(p, b_pk, UB_ORIGIN_PK_LEN);
    uint8_t master[crypto_kdf_KEYBYTES];
    int rc = crypto_generichash(master, sizeof master, in, sizeof in, NULL, 0);
    uint8_t k_ab[UB_ORIGIN_KEY_LEN], k_ba[UB_ORIGIN_KEY_LEN];
    if (rc == 0) rc = crypto_kdf_derive_from_key(k_ab, sizeof k_ab, 1, UB_ORIGIN_KDF_CONTEXT, master);
    if (rc == 0) rc = crypto_kdf_derive_from_key(k_ba, sizeof k_ba, 2, UB_ORIGIN_KDF_CONTEXT, master);
    if (rc == 0) {
        memcpy(k_tx, order < 0 ? k_ab : k_ba, UB_ORIGIN_KEY_LEN);
        memcpy(k_rx, order < 0 ? k_ba : k_ab, UB_ORIGIN_KEY_LEN);
    }
    ub_priv_wipe(in, sizeof in);
    ub_priv_wipe(master, sizeof master);
    ub_priv_wipe(k_ab, sizeof k_ab);
    ub_priv_wipe(k_ba, sizeof k_ba);
    return rc == 0 ? UB_OK : UB_ERR_INVAL;
#else
    return UB_ERR_UNSUPPORTED;
#endif
}

int ub_origin_tag(const uint8_t key[UB_ORIGIN_KEY_LEN], const ub_frame_header_t *h, const uint8_t *payload,
                  uint8_t tag[UB_FRAME_ORIGIN_TAG_LEN]) {
    if (key == NULL || h == NULL || tag == NULL || (payload == NULL && h->payload_size > 0)) return UB_ERR_INVAL;
    if (h->payload_size > UB_MAX_PAYLOAD) return UB_ERR_RANGE;
#if HAVE_SODIUM
    /* The signing header with ORIGIN alone and key id 0: the same whichever hop protection (SIGNED or
     * ENCRYPTED, and which group key) a forwarder gives the frame. */
    ub_frame_header_t o = *h;
    o.flags = UB_FRAME_FLAG_ORIGIN;
    o.key_id = 0;
    uint8_t in[UB_SEC_SIGNING_HEADER_LEN + 1u + UB_MAX_PAYLOAD];
    ub_sec_signing_header(&o, in);
    memcpy(in, UB_ORIGIN_DOMAIN, sizeof UB_ORIGIN_DOMAIN - 1u);
    in[UB_SEC_SIGNING_HEADER_LEN] = h->origin_hop0;
    if (h->payload_size > 0) memcpy(in + UB_SEC_SIGNING_HEADER_LEN + 1u, payload, h->payload_size);
    (void)crypto_shorthash_siphash24(tag, in, UB_SEC_SIGNING_HEADER_LEN + 1u + (size_t)h->payload_size, key);
    return UB_OK;
#else
    return UB_ERR_UNSUPPORTED;
#endif
}

/* ---- the cache ------------------------------------------------------------------------------------ */

static int local_index(const ub_origin_t *o, const uint8_t id[UB_ENTITY_ID_LEN]) {
    for (int i = 0; i < (int)UB_ORIGIN_LOCALS; i++)
        if (o->idents[i].in_use && ub_entity_id_eq(o->idents[i].id, id)) return i;
    return -1;
}

static uint64_t now_s(const ub_origin_t *o, uint64_t now_ms) {
    return o->opt.clock_s != NULL ? o->opt.clock_s(o->opt.clock_user) : now_ms / 1000u;
}

/* The pair (local `li`, `peer`), derived or re-checked with the store as needed; NULL when the store
 * refuses the peer (any cached pair of it is forgotten) or the agreement fails. */
static ub_origin_peer_t *pair_get(ub_origin_t *o, int li, const uint8_t peer[UB_ENTITY_ID_LEN], uint64_t now_ms) {
    ub_origin_peer_t *hit = NULL, *victim = NULL;
    for (size_t i = 0; i < UB_ORIGIN_PEERS && hit == NULL; i++) {
        ub_origin_peer_t *e = &o->peers[i];
        if (e->in_use && e->local == li && ub_entity_id_eq(e->peer_id, peer)) hit = e;
    }
    if (hit != NULL && hit->pinned) { /* provisioned: the authority's keys, no store to ask */
        hit->last_used = ++o->lru_tick;
        return hit;
    }
    /* provisioned pairs only: no store, or a local entity without a secret key (a zero key would derive
     * keys anyone can compute) */
    if (o->opt.lookup == NULL || !o->idents[li].has_sk) return NULL;
    if (hit == NULL) { /* a free row, else the least recently used (never a provisioned one) */
        for (size_t i = 0; i < UB_ORIGIN_PEERS; i++) {
            ub_origin_peer_t *e = &o->peers[i];
            if (!e->in_use) {
                victim = e;
                break;
            }
            if (!e->pinned && (victim == NULL || e->last_used < victim->last_used)) victim = e;
        }
        if (victim == NULL) return NULL; /* every row provisioned */
    }
    /* A clock that went backwards counts as due, so a revocation is never postponed for good. */
    if (hit != NULL && now_ms >= hit->checked_ms && now_ms - hit->checked_ms < o->opt.recheck_ms) {
        hit->last_used = ++o->lru_tick;
        return hit;
    }
    uint8_t pk[UB_ORIGIN_PK_LEN];
    o->stats.lookups++;
    if (o->opt.lookup(o->opt.lookup_user, peer, now_s(o, now_ms), pk) < 0) {
        if (hit != NULL) ub_priv_wipe(hit, sizeof *hit);
        return NULL;
    }
    if (hit != NULL && memcmp(hit->peer_pk, pk, UB_ORIGIN_PK_LEN) == 0) {
        hit->checked_ms = now_ms;
        hit->last_used = ++o->lru_tick;
        return hit;
    }
    ub_origin_peer_t *e = hit != NULL ? hit : victim;
    if (hit != NULL)
        o->stats.rekeys++;
    else if (e->in_use)
        o->stats.evictions++;
    ub_origin_peer_t fresh;
    memset(&fresh, 0, sizeof fresh);
    if (ub_origin_pair_keys(o->idents[li].id, o->idents[li].sk, peer, pk, fresh.k_tx, fresh.k_rx) < 0) {
        ub_priv_wipe(&fresh, sizeof fresh);
        if (hit != NULL) ub_priv_wipe(hit, sizeof *hit);
        return NULL;
    }
    o->stats.derivations++;
    memcpy(fresh.peer_id, peer, UB_ENTITY_ID_LEN);
    memcpy(fresh.peer_pk, pk, UB_ORIGIN_PK_LEN);
    fresh.checked_ms = now_ms;
    fresh.last_used = ++o->lru_tick;
    fresh.local = (uint8_t)li;
    fresh.in_use = 1;
    *e = fresh;
    ub_priv_wipe(&fresh, sizeof fresh);
    return e;
}

/* ---- the service ------------------------------------------------------------------------------------ */

static int origin_seal(const ub_service_t *svc, ub_node_t *node, int slot, ub_frame_header_t *h, const uint8_t *payload,
                       uint64_t now_ms, ub_drop_reason_t *drop) {
    ub_origin_t *o = svc->user;
    if (ub_entity_id_is_link_local(h->dest_id)) return 0; /* no single receiver: the hop tag alone */
    int entity = ub_node_slot_entity(node, slot);
    const uint8_t *self = entity >= 0 ? ub_node_entity_id(node, entity) : NULL;
    int li = self != NULL ? local_index(o, self) : -1;
    ub_origin_peer_t *pair = li >= 0 ? pair_get(o, li, h->dest_id, now_ms) : NULL;
    if (pair == NULL) {
        o->stats.no_identity++;
        if (o->opt.optional) return 0;
        *drop = UB_DROP_NO_IDENTITY;
        return UB_ERR_NOTFOUND;
    }
    h->origin_hop0 = h->hop_limit;
    if (ub_origin_tag(pair->k_tx, h, payload, h->origin_tag) < 0) {
        *drop = UB_DROP_BAD_PAYLOAD;
        return UB_ERR_INVAL;
    }
    o->stats.sealed++;
    return 1;
}

static bool origin_open(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx,
                        const ub_frame_header_t *h, const uint8_t *payload, uint64_t now_ms, bool *origin,
                        ub_drop_reason_t *drop) {
    ub_origin_t *o = svc->user;
    *origin = false;
    if (!(h->flags & UB_FRAME_FLAG_ORIGIN)) {
        if (o->opt.optional) return true;
        o->stats.no_origin++;
        *drop = UB_DROP_NO_ORIGIN;
        return false;
    }
    int entity = ub_node_slot_entity(node, rx->slot);
    const uint8_t *self = entity >= 0 ? ub_node_entity_id(node, entity) : NULL;
    int li = self != NULL ? local_index(o, self) : -1;
    ub_origin_peer_t *pair = li >= 0 ? pair_get(o, li, h->src_id, now_ms) : NULL;
    if (pair == NULL) {
        o->stats.no_identity++;
        *drop = UB_DROP_NO_IDENTITY;
        return false;
    }
    uint8_t tag[UB_FRAME_ORIGIN_TAG_LEN];
    if (ub_origin_tag(pair->k_rx, h, payload, tag) < 0) {
        *drop = UB_DROP_BAD_PAYLOAD;
        return false;
    }
#if HAVE_SODIUM
    bool ok = sodium_memcmp(tag, h->origin_tag, UB_FRAME_ORIGIN_TAG_LEN) == 0;
#else
    bool ok = false;
#endif
    /* hop0 is under the tag: the gate already refused a hop limit above it. */
    if (!ok || h->hop_limit > h->origin_hop0) {
        o->stats.bad_origin++;
        *drop = UB_DROP_BAD_ORIGIN;
        return false;
    }
    o->stats.opened++;
    *origin = true;
    return true;
}

/* ---- set-up -------------------------------------------------------------------------------------------- */

int ub_origin_init(ub_origin_t *o, const ub_origin_options_t *opt) {
    if (o == NULL || opt == NULL) return UB_ERR_INVAL;
    memset(o, 0, sizeof *o);
    o->opt = *opt;
    if (o->opt.recheck_ms == 0) o->opt.recheck_ms = UB_ORIGIN_DEFAULT_RECHECK_MS;
    o->svc.name = "origin";
    o->svc.order = UB_SVC_ORDER_USER;
    o->svc.seal = origin_seal;
    o->svc.open = origin_open;
    o->svc.user = o;
#if HAVE_SODIUM
    if (UB_SODIUM_INIT() < 0) return UB_ERR_IO;
    o->initialised = 1;
    return UB_OK;
#else
    return UB_ERR_UNSUPPORTED;
#endif
}

int ub_origin_add_identity(ub_origin_t *o, const uint8_t entity_id[UB_ENTITY_ID_LEN],
                           const uint8_t x25519_sk[UB_ORIGIN_SK_LEN]) {
    if (o == NULL || entity_id == NULL || x25519_sk == NULL || !o->initialised) return UB_ERR_INVAL;
    if (local_index(o, entity_id) >= 0) return UB_ERR_EXISTS;
    for (size_t i = 0; i < UB_ORIGIN_LOCALS; i++) {
        ub_origin_local_t *l = &o->idents[i];
        if (l->in_use) continue;
        int rc = ub_origin_public_key(x25519_sk, l->pk);
        if (rc < 0) return rc;
        memcpy(l->id, entity_id, UB_ENTITY_ID_LEN);
        memcpy(l->sk, x25519_sk, UB_ORIGIN_SK_LEN);
        l->in_use = 1;
        l->has_sk = 1;
        return UB_OK;
    }
    return UB_ERR_FULL;
}

int ub_origin_add_pair(ub_origin_t *o, const uint8_t entity_id[UB_ENTITY_ID_LEN], const uint8_t peer_id[UB_ENTITY_ID_LEN],
                       const uint8_t k_tx[UB_ORIGIN_KEY_LEN], const uint8_t k_rx[UB_ORIGIN_KEY_LEN]) {
    if (o == NULL || entity_id == NULL || peer_id == NULL || k_tx == NULL || k_rx == NULL || !o->initialised ||
        ub_entity_id_eq(entity_id, peer_id))
        return UB_ERR_INVAL;
    int li = local_index(o, entity_id);
    for (size_t i = 0; i < UB_ORIGIN_LOCALS && li < 0; i++) { /* a local entity without a secret key */
        ub_origin_local_t *l = &o->idents[i];
        if (l->in_use) continue;
        memset(l, 0, sizeof *l);
        memcpy(l->id, entity_id, UB_ENTITY_ID_LEN);
        l->in_use = 1;
        li = (int)i;
    }
    if (li < 0) return UB_ERR_FULL;
    ub_origin_peer_t *row = NULL;
    for (size_t i = 0; i < UB_ORIGIN_PEERS; i++) { /* the pair's row, else a free one, else a derived one */
        ub_origin_peer_t *e = &o->peers[i];
        if (e->in_use && e->local == li && ub_entity_id_eq(e->peer_id, peer_id)) {
            row = e;
            break;
        }
        if (row == NULL && !e->in_use) row = e;
    }
    for (size_t i = 0; i < UB_ORIGIN_PEERS && row == NULL; i++)
        if (!o->peers[i].pinned) row = &o->peers[i];
    if (row == NULL) return UB_ERR_FULL;
    ub_priv_wipe(row, sizeof *row);
    memcpy(row->peer_id, peer_id, UB_ENTITY_ID_LEN);
    memcpy(row->k_tx, k_tx, UB_ORIGIN_KEY_LEN);
    memcpy(row->k_rx, k_rx, UB_ORIGIN_KEY_LEN);
    row->local = (uint8_t)li;
    row->last_used = ++o->lru_tick;
    row->pinned = 1;
    row->in_use = 1;
    return UB_OK;
}

int ub_origin_load_pairs(ub_origin_t *o, const uint8_t *table, size_t len, ub_origin_provision_t *out) {
    if (o == NULL || table == NULL || out == NULL || !o->initialised) return UB_ERR_INVAL;
    if (len < UB_ORIGIN_PAIRS_LEN(0) || memcmp(table, UB_ORIGIN_PAIRS_MAGIC, 4) != 0 || table[4] != 1u)
        return UB_ERR_CONFIG;
    size_t n = table[5];
    if (len != UB_ORIGIN_PAIRS_LEN(n)) return UB_ERR_CONFIG;
    size_t body = len - 4u;
    uint32_t crc = (uint32_t)table[body] | (uint32_t)table[body + 1u] << 8 | (uint32_t)table[body + 2u] << 16 |
                   (uint32_t)table[body + 3u] << 24;
    if (ub_crc32c(table, body) != crc) return UB_ERR_CONFIG;
    const uint8_t *self = table + 8;
    for (size_t i = 0; i < n; i++)
        if (ub_entity_id_eq(table + UB_ORIGIN_PAIRS_HEADER_LEN + i * UB_ORIGIN_PAIRS_ENTRY_LEN, self))
            return UB_ERR_CONFIG;
    if (n > UB_ORIGIN_PEERS) return UB_ERR_FULL; /* nothing installed */
    memset(out, 0, sizeof *out);
    memcpy(out->entity_id, self, UB_ENTITY_ID_LEN);
    out->group_key_id = table[20];
    out->has_group_key = (table[21] & 1u) != 0;
    if (out->has_group_key) memcpy(out->group_key, table + 24, sizeof out->group_key);
    for (size_t i = 0; i < n; i++) {
        const uint8_t *e = table + UB_ORIGIN_PAIRS_HEADER_LEN + i * UB_ORIGIN_PAIRS_ENTRY_LEN;
        int rc = ub_origin_add_pair(o, self, e, e + UB_ENTITY_ID_LEN, e + UB_ENTITY_ID_LEN + UB_ORIGIN_KEY_LEN);
        if (rc < 0) { /* no room left among pinned rows: take back what this table installed */
            for (size_t j = 0; j < i; j++)
                (void)ub_origin_forget(o, table + UB_ORIGIN_PAIRS_HEADER_LEN + j * UB_ORIGIN_PAIRS_ENTRY_LEN);
            ub_priv_wipe(out, sizeof *out);
            return rc;
        }
        out->pairs++;
    }
    return (int)n;
}

int ub_origin_attach(ub_origin_t *o, ub_node_t *node) {
    if (o == NULL || node == NULL || !o->initialised) return UB_ERR_INVAL;
    return ub_node_add_service(node, &o->svc);
}

int ub_origin_detach(ub_origin_t *o, ub_node_t *node) {
    if (o == NULL || node == NULL) return UB_ERR_INVAL;
    return ub_node_remove_service(node, &o->svc);
}

size_t ub_origin_forget(ub_origin_t *o, const uint8_t peer_id[UB_ENTITY_ID_LEN]) {
    size_t n = 0;
    if (o == NULL || peer_id == NULL) return 0;
    for (size_t i = 0; i < UB_ORIGIN_PEERS; i++) {
        ub_origin_peer_t *e = &o->peers[i];
        if (e->in_use && ub_entity_id_eq(e->peer_id, peer_id)) {
            ub_priv_wipe(e, sizeof *e);
            n++;
        }
    }
    return n;
}

void ub_origin_forget_hook(void *origin, const uint8_t peer_id[UB_ENTITY_ID_LEN]) {
    (void)ub_origin_forget(origin, peer_id);
}

size_t ub_origin_cached(const ub_origin_t *o) {
    size_t n = 0;
    if (o == NULL) return 0;
    for (size_t i = 0; i < UB_ORIGIN_PEERS; i++) n += o->peers[i].in_use ? 1u : 0u;
    return n;
}

const ub_origin_stats_t *ub_origin_stats(const ub_origin_t *o) { return o == NULL ? NULL : &o->stats; }
