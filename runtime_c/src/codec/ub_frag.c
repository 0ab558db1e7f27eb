/* Large directories in numbered fragments (contracts in ub/ub_frag.h). */
#include "ub/ub_frag.h"

#include <string.h>

#include "ub/ub_wire.h"

static size_t ceil_div(size_t a, size_t b) { return (a + b - 1) / b; }

int ub_frag_parse(const uint8_t *payload, size_t len, ub_frag_info_t *out) {
    if (payload == NULL || out == NULL || len < UB_FRAG_HEADER_LEN) return UB_ERR_INVAL;
    ub_frag_info_t fi;
    fi.transfer = ub_get_u16le(payload + UB_FRAG_OFF_TRANSFER);
    fi.index = ub_get_u16le(payload + UB_FRAG_OFF_INDEX);
    fi.count = ub_get_u16le(payload + UB_FRAG_OFF_COUNT);
    fi.total = ub_get_u16le(payload + UB_FRAG_OFF_TOTAL);
    if (fi.count == 0 || fi.count > UB_FRAG_MAX_FRAGMENTS || fi.total == 0 || fi.total > UB_MAX_DIRECTORY ||
        fi.count > fi.total || fi.index >= fi.count)
        return UB_ERR_INVAL;
    size_t chunk = ceil_div(fi.total, fi.count);
    if (chunk * (size_t)(fi.count - 1) >= fi.total) return UB_ERR_INVAL; /* a count whose last fragment is empty */
    size_t offset = chunk * fi.index;
    size_t want = fi.index + 1u == fi.count ? fi.total - offset : chunk;
    if (len != UB_FRAG_HEADER_LEN + want) return UB_ERR_INVAL;
    fi.offset = (uint16_t)offset;
    fi.len = (uint16_t)want;
    fi.bytes = payload + UB_FRAG_HEADER_LEN;
    *out = fi;
    return UB_OK;
}

int ub_frag_plan(size_t total, size_t max_bytes, uint16_t *count) {
    if (count == NULL || total == 0 || total > UB_MAX_DIRECTORY || max_bytes == 0) return UB_ERR_RANGE;
    /* Balanced: the fragment size is ceil(total / n) for the fewest n that fit, and the count what that size needs,
     * so the receiver derives the same size from (total, count) and no fragment is empty. */
    size_t n = ceil_div(total, max_bytes);
    size_t chunk = ceil_div(total, n);
    n = ceil_div(total, chunk);
    if (n > UB_FRAG_MAX_FRAGMENTS) return UB_ERR_RANGE;
    *count = (uint16_t)n;
    return UB_OK;
}

int ub_frag_write(uint8_t *out, size_t cap, uint16_t transfer, uint16_t index, uint16_t count, const uint8_t *data,
                  size_t total) {
    if (out == NULL || data == NULL || count == 0 || index >= count || total == 0 || total > UB_MAX_DIRECTORY)
        return UB_ERR_INVAL;
    size_t chunk = ceil_div(total, count);
    size_t offset = chunk * index;
    if (offset >= total) return UB_ERR_INVAL;
    size_t n = index + 1u == count ? total - offset : chunk;
    if (cap < UB_FRAG_HEADER_LEN + n) return UB_ERR_NOSPACE;
    ub_put_u16le(out + UB_FRAG_OFF_TRANSFER, transfer);
    ub_put_u16le(out + UB_FRAG_OFF_INDEX, index);
    ub_put_u16le(out + UB_FRAG_OFF_COUNT, count);
    ub_put_u16le(out + UB_FRAG_OFF_TOTAL, (uint16_t)total);
    memcpy(out + UB_FRAG_HEADER_LEN, data + offset, n);
    return (int)(UB_FRAG_HEADER_LEN + n);
}

void ub_frag_init(ub_frag_t *f, const ub_frag_params_t *params, uint16_t first_transfer) {
    if (f == NULL) return;
    /* Only the bookkeeping: the data buffers are written before they are read. */
    f->params.timeout_ms = params != NULL && params->timeout_ms != 0 ? params->timeout_ms : UB_FRAG_TIMEOUT_MS;
    f->params.protect_ms = params != NULL && params->protect_ms != 0 ? params->protect_ms : f->params.timeout_ms / 4u;
    f->next_transfer = first_transfer;
    memset(&f->stats, 0, sizeof f->stats);
    for (size_t i = 0; i < UB_FRAG_SLOTS; i++) f->rx[i].in_use = 0;
    for (size_t i = 0; i < UB_FRAG_TX_SLOTS; i++) f->tx[i].in_use = 0;
}

static void start(ub_frag_t *f, ub_frag_rx_t *r, int slot, const uint8_t src[UB_ENTITY_ID_LEN], const uint8_t dir_id[UB_DIR_ID_LEN],
                  uint32_t fingerprint, const ub_frag_info_t *fi) {
    r->in_use = 1;
    r->slot = (int8_t)slot;
    memcpy(r->src, src, UB_ENTITY_ID_LEN);
    memcpy(r->dir_id, dir_id, UB_DIR_ID_LEN);
    r->fingerprint = fingerprint;
    r->transfer = fi->transfer;
    r->count = fi->count;
    r->total = fi->total;
    r->received = 0;
    memset(r->have, 0, sizeof r->have);
    f->stats.rx_started++;
}

/* The slot a new transfer of `src` goes to, or NULL (refused): its own idlest one once it holds its share, else a
 * free one, else the idlest of all if that one has been idle for protect_ms (ub_frag.h). Counts what it drops. */
static ub_frag_rx_t *room_for(ub_frag_t *f, const uint8_t src[UB_ENTITY_ID_LEN], uint64_t now_ms) {
    ub_frag_rx_t *free_slot = NULL, *own = NULL, *idlest = NULL;
    size_t own_n = 0;
    for (size_t i = 0; i < UB_FRAG_SLOTS; i++) {
        ub_frag_rx_t *c = &f->rx[i];
        if (!c->in_use) {
            if (free_slot == NULL) free_slot = c;
            continue;
        }
        if (idlest == NULL || c->last_ms < idlest->last_ms) idlest = c;
        if (memcmp(c->src, src, UB_ENTITY_ID_LEN) != 0) continue;
        own_n++;
        if (own == NULL || c->last_ms < own->last_ms) own = c;
    }
    if (own_n >= UB_FRAG_SLOTS_PER_SOURCE) {
        f->stats.rx_source_limit++;
        return own;
    }
    if (free_slot != NULL) return free_slot;
    /* A clock that went backwards counts as idle, so a slot is never held for good. */
    if (now_ms < idlest->last_ms || now_ms - idlest->last_ms >= f->params.protect_ms) {
        f->stats.rx_evicted++;
        return idlest;
    }
    return NULL;
}

int ub_frag_take(ub_frag_t *f, int slot, const uint8_t src[UB_ENTITY_ID_LEN], const uint8_t dir_id[UB_DIR_ID_LEN],
                 uint32_t fingerprint, const uint8_t *payload, size_t len, uint64_t now_ms, const uint8_t **data,
                 size_t *total) {
    if (f == NULL || src == NULL || dir_id == NULL || data == NULL || total == NULL) return UB_ERR_INVAL;
    ub_frag_info_t fi;
    if (ub_frag_parse(payload, len, &fi) != UB_OK) {
        f->stats.rx_bad++;
        return UB_ERR_INVAL;
    }
    ub_frag_rx_t *r = NULL;
    for (size_t i = 0; i < UB_FRAG_SLOTS && r == NULL; i++) {
        ub_frag_rx_t *c = &f->rx[i];
        if (c->in_use && c->slot == slot && c->transfer == fi.transfer && memcmp(c->src, src, UB_ENTITY_ID_LEN) == 0)
            r = c;
    }
    if (r != NULL && (r->count != fi.count || r->total != fi.total || r->fingerprint != fingerprint ||
                      memcmp(r->dir_id, dir_id, UB_DIR_ID_LEN) != 0)) {
        f->stats.rx_restarted++; /* a reused transfer number, or a forgery: never mix the two */
        start(f, r, slot, src, dir_id, fingerprint, &fi);
    }
    if (r == NULL) {
        r = room_for(f, src, now_ms);
        if (r == NULL) {
            f->stats.rx_refused++;
            return UB_FRAG_REFUSED;
        }
        start(f, r, slot, src, dir_id, fingerprint, &fi);
        r->last_ms = now_ms;
    }
    uint8_t bit = (uint8_t)(1u << (fi.index % 8));
    if (r->have[fi.index / 8] & bit) {
        f->stats.rx_duplicates++;
        return UB_FRAG_DUPLICATE;
    }
    memcpy(r->data + fi.offset, fi.bytes, fi.len);
    r->have[fi.index / 8] |= bit;
    r->received++;
    r->last_ms = now_ms;
    f->stats.rx_fragments++;
    if (r->received < r->count) return UB_FRAG_PENDING;
    r->in_use = 0; /* the data stays until the slot is reused, which cannot happen before the caller returns */
    f->stats.rx_complete++;
    *data = r->data;
    *total = r->total;
    return UB_FRAG_COMPLETE;
}

size_t ub_frag_expire(ub_frag_t *f, uint64_t now_ms) {
    if (f == NULL) return 0;
    size_t n = 0;
    for (size_t i = 0; i < UB_FRAG_SLOTS; i++) {
        ub_frag_rx_t *r = &f->rx[i];
        if (!r->in_use || now_ms < r->last_ms || now_ms - r->last_ms < f->params.timeout_ms) continue;
        r->in_use = 0;
        f->stats.rx_timeouts++;
        n++;
    }
    return n;
}

void ub_frag_forget(ub_frag_t *f, int slot, const uint8_t id[UB_ENTITY_ID_LEN]) {
    if (f == NULL) return;
    for (size_t i = 0; i < UB_FRAG_SLOTS; i++) {
        ub_frag_rx_t *r = &f->rx[i];
        if (r->in_use && ((slot >= 0 && r->slot == slot) || (id != NULL && memcmp(r->src, id, UB_ENTITY_ID_LEN) == 0)))
            r->in_use = 0;
    }
    for (size_t i = 0; i < UB_FRAG_TX_SLOTS; i++) {
        ub_frag_tx_t *t = &f->tx[i];
        if (t->in_use && ((slot >= 0 && t->slot == slot) || (id != NULL && memcmp(t->dest, id, UB_ENTITY_ID_LEN) == 0)))
            t->in_use = 0;
    }
}

size_t ub_frag_pending(const ub_frag_t *f) {
    size_t n = 0;
    for (size_t i = 0; f != NULL && i < UB_FRAG_SLOTS; i++) n += f->rx[i].in_use;
    return n;
}
