#include "ub/ub_batchlink.h"

#include <stdbool.h>
#include <string.h>

#include "ub/ub_node.h"

int ub_batchlink_init(ub_batchlink_t *bl, uint8_t *buf, size_t cap, uint32_t *ends, size_t ends_cap,
                      size_t batch_limit) {
    if (bl == NULL || buf == NULL || ends == NULL || ends_cap == 0 || cap > UINT32_MAX ||
        cap < UB_BATCH_HEADER + 2u || batch_limit < UB_BATCH_HEADER + 2u)
        return UB_ERR_INVAL;
    memset(bl, 0, sizeof *bl);
    bl->buf = buf;
    bl->cap = cap;
    bl->ends = ends;
    bl->ends_cap = ends_cap;
    bl->batch_limit = batch_limit;
    return UB_OK;
}

void ub_batchlink_clear(ub_batchlink_t *bl) {
    bl->len = 0;
    bl->n = 0;
    bl->open_start = 0;
    bl->open_count = 0;
}

static void put16(uint8_t *p, size_t v) {
    p[0] = (uint8_t)(v & 0xFFu);
    p[1] = (uint8_t)((v >> 8) & 0xFFu);
}

static size_t get16(const uint8_t *p) { return (size_t)p[0] | (size_t)p[1] << 8; }

/* The open batch takes `frame` when it is of the same flow (key bytes of its first frame) and fits. */
static bool joins_open(const ub_batchlink_t *bl, const uint8_t *frame, size_t len) {
    if (bl->n == 0 || bl->open_count >= 0xFFFFu) return false;
    if (bl->len - bl->open_start + 2u + len > bl->batch_limit) return false;
    const uint8_t *first = bl->buf + bl->open_start + UB_BATCH_HEADER + 2u;
    return memcmp(first + UB_BATCH_KEY_OFFSET, frame + UB_BATCH_KEY_OFFSET, UB_BATCH_KEY_LEN) == 0;
}

static int batchlink_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    ub_batchlink_t *bl = impl;
    (void)now_ms;
    if (len < UB_BATCH_KEY_OFFSET + UB_BATCH_KEY_LEN || len > 0xFFFFu) {
        bl->refused++;
        return UB_ERR_RANGE; /* no frame of ub_frame.h is this short or long */
    }
    bool join = joins_open(bl, frame, len);
    size_t need = (join ? 0u : UB_BATCH_HEADER) + 2u + len;
    if (bl->cap - bl->len < need || (!join && bl->n == bl->ends_cap)) {
        bl->refused++;
        return UB_ERR_AGAIN;
    }
    if (!join) {
        uint8_t *h = bl->buf + bl->len;
        h[0] = UB_BATCH_SYNC;
        h[1] = UB_BATCH_MARK;
        h[2] = UB_BATCH_VERSION;
        bl->open_start = bl->len;
        bl->open_count = 0;
        bl->len += UB_BATCH_HEADER;
        bl->n++;
    }
    put16(bl->buf + bl->len, len);
    memcpy(bl->buf + bl->len + 2u, frame, len);
    bl->len += 2u + len;
    bl->open_count++;
    put16(bl->buf + bl->open_start + 3u, bl->open_count);
    bl->ends[bl->n - 1u] = (uint32_t)bl->len;
    bl->frames++;
    return UB_OK;
}

static int batchlink_fileno(void *impl) {
    (void)impl;
    return -1;
}

const ub_link_ops_t ub_batchlink_ops = {.kind = "zenoh", .send = batchlink_send, .fileno = batchlink_fileno};

int ub_batchlink_attach(ub_batchlink_t *bl, ub_node_t *node, int link_id) {
    return ub_node_link_attach(node, link_id, &ub_batchlink_ops, bl);
}

ub_batch_status_t ub_batch_check(const uint8_t *p, size_t len, size_t *count) {
    if (count != NULL) *count = 0;
    if (p == NULL || len < 2u || p[0] != UB_BATCH_SYNC || (p[1] != UB_BATCH_MARK && p[1] != 0x5Bu))
        return UB_BATCH_FOREIGN;
    if (p[1] != UB_BATCH_MARK) return UB_BATCH_OTHER_VERSION; /* a bare frame: a bridge before batches */
    if (len < UB_BATCH_HEADER) return UB_BATCH_MALFORMED;
    if (p[2] != UB_BATCH_VERSION) return UB_BATCH_OTHER_VERSION;
    size_t n = get16(p + 3), at = UB_BATCH_HEADER;
    if (n == 0) return UB_BATCH_MALFORMED;
    for (size_t i = 0; i < n; i++) {
        if (len - at < 2u) return UB_BATCH_MALFORMED;
        size_t size = get16(p + at);
        at += 2u;
        if (size == 0 || len - at < size) return UB_BATCH_MALFORMED;
        at += size;
    }
    if (at != len) return UB_BATCH_MALFORMED;
    if (count != NULL) *count = n;
    return UB_BATCH_OK;
}

int ub_batch_rx(ub_node_t *node, int link_id, const uint8_t *p, size_t len, uint64_t now_ms, size_t *frames,
                size_t *rejected) {
    size_t n = 0, bad = 0;
    ub_batch_status_t st = ub_batch_check(p, len, &n);
    if (st == UB_BATCH_OK) {
        size_t at = UB_BATCH_HEADER;
        for (size_t i = 0; i < n; i++) {
            size_t size = get16(p + at);
            if (ub_node_rx_frame(node, link_id, p + at + 2u, size, now_ms) < 0) bad++;
            at += 2u + size;
        }
    }
    if (frames != NULL) *frames = st == UB_BATCH_OK ? n : 0;
    if (rejected != NULL) *rejected = bad;
    return (int)st;
}
