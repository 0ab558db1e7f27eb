/* The legacy datalink envelope (contracts and layout in ub/ub_legacy.h). */
#include "ub/ub_legacy.h"

#include <string.h>

#include "ub/ub_wire.h"

void ub_legacy_init(ub_legacy_t *p) {
    if (p == NULL) return;
    p->have = 0;
    memset(&p->stats, 0, sizeof p->stats);
}

size_t ub_legacy_pending(const ub_legacy_t *p) { return p == NULL ? 0 : p->have; }

static uint8_t sum8(const uint8_t *b, size_t n, uint8_t acc) {
    for (size_t i = 0; i < n; i++) acc = (uint8_t)(acc + b[i]);
    return acc;
}

int ub_legacy_build(uint16_t type, const uint8_t *payload, size_t len, uint8_t *out, size_t cap) {
    if (out == NULL || (payload == NULL && len != 0)) return UB_ERR_INVAL;
    if (len > UB_LEGACY_PAYLOAD_MAX) return UB_ERR_RANGE;
    if (cap < UB_LEGACY_HEADER_LEN + len) return UB_ERR_NOSPACE;
    out[0] = UB_LEGACY_SYNC0;
    out[1] = UB_LEGACY_SYNC1;
    ub_put_u16le(out + 4, type);
    ub_put_u16le(out + 6, (uint16_t)len);
    if (len != 0) memmove(out + UB_LEGACY_HEADER_LEN, payload, len); /* memmove: the payload may be in `out` */
    out[2] = sum8(out + 4, 4, 0);
    out[3] = sum8(out + UB_LEGACY_HEADER_LEN, len, out[2]);
    return (int)(UB_LEGACY_HEADER_LEN + len);
}

/* Drops `n` bytes from the front of the buffer as noise. */
static void drop(ub_legacy_t *p, size_t n) {
    p->stats.noise_bytes += n;
    memmove(p->buf, p->buf + n, p->have - n);
    p->have -= n;
}

/* Judges what the buffer holds; returns 1 per good message called back, stops when it needs more bytes. */
static int scan(ub_legacy_t *p, ub_legacy_cb cb, void *user) {
    int found = 0;
    while (p->have > 0) {
        const uint8_t *sync = memchr(p->buf, UB_LEGACY_SYNC0, p->have);
        size_t at = sync != NULL ? (size_t)(sync - p->buf) : p->have;
        if (at > 0) {
            drop(p, at);
            continue;
        }
        if (p->have < 2) return found;
        if (p->buf[1] != UB_LEGACY_SYNC1) {
            drop(p, 1);
            continue;
        }
        if (p->have < UB_LEGACY_HEADER_LEN) return found;
        if (sum8(p->buf + 4, 4, 0) != p->buf[2]) {
            p->stats.bad_header++;
            drop(p, 1);
            continue;
        }
        size_t size = ub_get_u16le(p->buf + 6);
        if (size > UB_LEGACY_PAYLOAD_MAX) {
            p->stats.too_long++;
            drop(p, 1);
            continue;
        }
        size_t total = UB_LEGACY_HEADER_LEN + size;
        if (p->have < total) return found;
        if (sum8(p->buf + UB_LEGACY_HEADER_LEN, size, p->buf[2]) != p->buf[3]) {
            p->stats.bad_checksum++;
            drop(p, 1);
            continue;
        }
        p->stats.messages++;
        p->stats.message_bytes += total;
        if (cb != NULL) cb(user, ub_get_u16le(p->buf + 4), p->buf, total, p->buf + UB_LEGACY_HEADER_LEN, size);
        memmove(p->buf, p->buf + total, p->have - total);
        p->have -= total;
        found++;
    }
    return found;
}

int ub_legacy_feed(ub_legacy_t *p, const uint8_t *data, size_t len, ub_legacy_cb cb, void *user) {
    if (p == NULL || (data == NULL && len != 0)) return UB_ERR_INVAL;
    p->stats.bytes_in += len;
    int found = 0;
    while (len > 0) {
        size_t take = sizeof p->buf - p->have;
        if (take > len) take = len;
        memcpy(p->buf + p->have, data, take);
        p->have += take;
        data += take;
        len -= take;
        found += scan(p, cb, user);
    }
    return found;
}
