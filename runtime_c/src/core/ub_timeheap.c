/* Indexed binary min-heap of deadlines (ub_timeheap.h). */
#include "ub/ub_timeheap.h"

#include <string.h>

void ub_timeheap_init(ub_timeheap_t *h) {
    h->n = 0;
    memset(h->pos, 0, sizeof h->pos);
    for (size_t i = 0; i < UB_TIMEHEAP_CAP; i++) h->due[i] = UB_TIMEHEAP_NONE;
}

static void place(ub_timeheap_t *h, unsigned k, uint16_t item) {
    h->at[k] = item;
    h->pos[item] = (uint16_t)(k + 1u);
}

static void sift_up(ub_timeheap_t *h, unsigned k) {
    uint16_t item = h->at[k];
    uint64_t d = h->due[item];
    while (k > 0) {
        unsigned parent = (k - 1u) / 2u;
        if (h->due[h->at[parent]] <= d) break;
        place(h, k, h->at[parent]);
        k = parent;
    }
    place(h, k, item);
}

static void sift_down(ub_timeheap_t *h, unsigned k) {
    uint16_t item = h->at[k];
    uint64_t d = h->due[item];
    for (;;) {
        unsigned c = 2u * k + 1u;
        if (c >= h->n) break;
        if (c + 1u < h->n && h->due[h->at[c + 1u]] < h->due[h->at[c]]) c++;
        if (h->due[h->at[c]] >= d) break;
        place(h, k, h->at[c]);
        k = c;
    }
    place(h, k, item);
}

void ub_timeheap_set(ub_timeheap_t *h, unsigned item, uint64_t due_ms) {
    if (item >= UB_TIMEHEAP_CAP) return;
    uint64_t old = h->due[item];
    if (old == due_ms) return;
    h->due[item] = due_ms;
    unsigned p = h->pos[item];
    if (p == 0) { /* absent (old is NONE, due_ms is not) */
        place(h, h->n++, (uint16_t)item);
        sift_up(h, h->n - 1u);
        return;
    }
    unsigned k = p - 1u;
    if (due_ms == UB_TIMEHEAP_NONE) { /* remove: the last item takes its place */
        h->pos[item] = 0;
        h->n--;
        if (k == h->n) return;
        place(h, k, h->at[h->n]);
        sift_up(h, k);
        sift_down(h, h->pos[h->at[k]] - 1u);
        return;
    }
    if (due_ms < old) sift_up(h, k);
    else sift_down(h, k);
}

uint64_t ub_timeheap_get(const ub_timeheap_t *h, unsigned item) {
    return item < UB_TIMEHEAP_CAP ? h->due[item] : UB_TIMEHEAP_NONE;
}

size_t ub_timeheap_due(const ub_timeheap_t *h, uint64_t now_ms, uint16_t *out, size_t cap) {
    /* Depth-first over the heap: a node later than now_ms has no due descendant. The explicit stack holds at
     * most one pending sibling per level plus the current node. */
    uint32_t stack[40];
    size_t sp = 0, n = 0;
    if (h->n == 0 || cap == 0) return 0;
    stack[sp++] = 0;
    while (sp > 0 && n < cap) {
        unsigned k = stack[--sp];
        if (k >= h->n || h->due[h->at[k]] > now_ms) continue;
        out[n++] = h->at[k];
        if (sp + 2u <= sizeof stack / sizeof stack[0]) {
            stack[sp++] = 2u * k + 2u;
            stack[sp++] = 2u * k + 1u;
        }
    }
    /* Ascending item order (the caller acts on rows in table order, as a full scan would): insertion sort for
     * the usual few, a bitmap pass for many. */
    if (n <= 8) {
        for (size_t i = 1; i < n; i++) {
            uint16_t v = out[i];
            size_t j = i;
            for (; j > 0 && out[j - 1] > v; j--) out[j] = out[j - 1];
            out[j] = v;
        }
        return n;
    }
    uint64_t bits[(UB_TIMEHEAP_CAP + 63) / 64] = {0};
    for (size_t i = 0; i < n; i++) bits[out[i] / 64u] |= 1ull << (out[i] % 64u);
    size_t m = 0;
    for (size_t w = 0; w < sizeof bits / sizeof bits[0]; w++)
        for (uint64_t b = bits[w]; b != 0; b &= b - 1u) out[m++] = (uint16_t)(w * 64u + (unsigned)__builtin_ctzll(b));
    return m;
}
