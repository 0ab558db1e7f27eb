/* Link impairment decorator (ub_impair.h). */
#include "ub/ub_impair.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/ub_rng_private.h"

static uint64_t rng_next(ub_impair_t *imp) { return ub_rng_next(&imp->rng); }

/* True with probability ppm / 10^6. A zero probability consumes no random number, so enabling one
 * impairment does not shift the decisions of the others. */
static bool chance(ub_impair_t *imp, uint32_t ppm) {
    if (ppm == 0) return false;
    if (ppm >= UB_IMPAIR_PPM_MAX) return true;
    return (rng_next(imp) >> 11) % UB_IMPAIR_PPM_MAX < ppm;
}

static uint32_t uniform(ub_impair_t *imp, uint32_t max_inclusive) {
    if (max_inclusive == 0) return 0;
    return (uint32_t)((rng_next(imp) >> 11) % ((uint64_t)max_inclusive + 1));
}

void ub_impair_reseed(ub_impair_t *imp, uint64_t seed) {
    if (imp == NULL) return;
    /* splitmix64 step: neighbouring seeds (1, 2, ...) give unrelated streams. */
    uint64_t z = seed + 0x9E3779B97F4A7C15ULL;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    z ^= z >> 31;
    imp->rng = z != 0 ? z : 0x9E3779B97F4A7C15ULL;
}

void ub_impair_init(ub_impair_t *imp, const ub_impair_params_t *params, uint64_t seed) {
    if (imp == NULL) return;
    memset(imp, 0, sizeof *imp);
    if (params != NULL) imp->params = *params;
    ub_impair_reseed(imp, seed);
}

void ub_impair_set_params(ub_impair_t *imp, const ub_impair_params_t *params) {
    if (imp == NULL) return;
    if (params != NULL) {
        imp->params = *params;
    } else {
        memset(&imp->params, 0, sizeof imp->params);
    }
}

int ub_impair_wrap(ub_impair_t *imp, const ub_link_ops_t *ops, void *impl) {
    if (imp == NULL) return UB_ERR_INVAL;
    if (ops != NULL && (ops->send == NULL || (ops == &ub_impair_ops && impl == imp))) return UB_ERR_INVAL;
    imp->inner_ops = ops;
    imp->inner = ops != NULL ? impl : NULL;
    return UB_OK;
}

static uint32_t hold_ms(const ub_impair_t *imp) {
    return imp->params.reorder_hold_ms != 0 ? imp->params.reorder_hold_ms : UB_IMPAIR_REORDER_HOLD_MS;
}

/* Hands one copy to the inner transport, counting the outcome. */
static int inner_send(ub_impair_t *imp, const uint8_t *frame, size_t len, uint64_t now_ms) {
    int rc = imp->inner_ops != NULL ? imp->inner_ops->send(imp->inner, frame, len, now_ms) : UB_ERR_CLOSED;
    if (rc == UB_OK) {
        imp->stats.passed++;
        imp->stats.bytes += len;
    } else if (rc == UB_ERR_AGAIN) {
        imp->stats.inner_again++;
    } else {
        imp->stats.inner_errors++;
    }
    return rc;
}

static void remove_at(ub_impair_t *imp, size_t i) {
    if (imp->queue[i].waiting) imp->waiting[imp->queue[i].cls]--;
    imp->count--;
    if (i != imp->count) imp->queue[i] = imp->queue[imp->count];
}

/* When a held (reordered) copy may leave: once a later copy has left, or when its hold runs out. */
static uint64_t held_deadline(const ub_impair_t *imp, const ub_impair_frame_t *f) {
    return f->due_ms + hold_ms(imp);
}

/* Index of the next copy to leave at now_ms, or -1. Unheld copies that are due leave first (lowest due
 * time, then send order); a held copy leaves only when a later copy has already left (`released_after`
 * is the order of the last copy that left) or its hold has run out. */
static long next_ready(const ub_impair_t *imp, uint64_t now_ms, uint64_t released_after, bool any_released) {
    long best = -1;
    for (size_t i = 0; i < imp->count; i++) {
        const ub_impair_frame_t *f = &imp->queue[i];
        bool ready;
        if (f->waiting) continue; /* still waiting for the medium (prio) */
        if (!f->held) {
            ready = f->due_ms <= now_ms;
        } else {
            ready = (any_released && f->order < released_after && f->due_ms <= now_ms)
                    || held_deadline(imp, f) <= now_ms;
        }
        if (!ready) continue;
        if (best < 0) {
            best = (long)i;
            continue;
        }
        const ub_impair_frame_t *b = &imp->queue[best];
        /* A held copy goes after the unheld ones that are ready now: that is the point of holding it. */
        if (f->held != b->held) {
            if (!f->held) best = (long)i;
            continue;
        }
        if (f->due_ms < b->due_ms || (f->due_ms == b->due_ms && f->order < b->order)) best = (long)i;
    }
    return best;
}

/* ---- priorities (prio = 1): the medium takes the highest class waiting whenever it is free ---- */

static uint64_t carry_us(const ub_impair_t *imp, size_t len) {
    if (imp->params.rate_Bps == 0) return 0; /* the rate was taken away while copies waited: they go at once */
    return ((uint64_t)len * 1000000u + imp->params.rate_Bps - 1) / imp->params.rate_Bps;
}

/* When the medium can start its next copy: once it is free and a copy has arrived. False: none waits. */
static bool medium_next_start(const ub_impair_t *imp, uint64_t *start_us) {
    bool any = false;
    uint64_t first = UINT64_MAX;
    for (size_t i = 0; i < imp->count; i++) {
        const ub_impair_frame_t *f = &imp->queue[i];
        if (f->waiting && f->arrival_us < first) first = f->arrival_us;
        any |= f->waiting != 0;
    }
    if (!any) return false;
    *start_us = imp->busy_until_us > first ? imp->busy_until_us : first;
    return true;
}

/* Puts waiting copies on the medium, one after the other, for as long as it is free by `now_ms`: at each
 * start the oldest copy of the highest class that had arrived by then. A copy on the medium has its leave
 * time and goes out through the ordinary release (ub_impair_service()). */
static void medium_pump(ub_impair_t *imp, uint64_t now_ms) {
    /* Saturated: ub_ports drains a decorator it takes away with a time later than any due time. */
    uint64_t now_us = now_ms > UINT64_MAX / 1000u ? UINT64_MAX : now_ms * 1000u;
    uint64_t start_us;
    while (medium_next_start(imp, &start_us) && start_us <= now_us) {
        long best = -1;
        bool older_lower = false;
        for (size_t i = 0; i < imp->count; i++) {
            const ub_impair_frame_t *f = &imp->queue[i];
            if (!f->waiting || f->arrival_us > start_us) continue;
            if (best < 0) {
                best = (long)i;
                continue;
            }
            const ub_impair_frame_t *b = &imp->queue[best];
            if (f->cls < b->cls || (f->cls == b->cls && f->order < b->order)) best = (long)i;
        }
        if (imp->queue[best].cls == UB_PRIO_TELEMETRY) {
            /* Bulk's share: after UB_PRIO_BULK_EVERY telemetry copies taken while bulk waited, the oldest bulk
             * copy goes, so a telemetry flood slows a large directory down but never stops it. Commands and
             * control are never held back by it. */
            long bulk = -1;
            for (size_t i = 0; i < imp->count; i++) {
                const ub_impair_frame_t *o = &imp->queue[i];
                if (o->waiting && o->cls == UB_PRIO_BULK && o->arrival_us <= start_us &&
                    (bulk < 0 || o->order < imp->queue[bulk].order))
                    bulk = (long)i;
            }
            if (bulk >= 0 && imp->tel_run >= UB_PRIO_BULK_EVERY) best = bulk;
            else if (bulk >= 0) imp->tel_run++;
        }
        if (imp->queue[best].cls == UB_PRIO_BULK) imp->tel_run = 0;
        ub_impair_frame_t *f = &imp->queue[best];
        for (size_t i = 0; i < imp->count; i++) {
            const ub_impair_frame_t *o = &imp->queue[i];
            if (o->waiting && o->arrival_us <= start_us && o->cls > f->cls && o->order < f->order) older_lower = true;
        }
        if (older_lower) imp->stats.overtaken++;
        imp->busy_until_us = start_us + carry_us(imp, f->len);
        uint64_t leaves_ms = (imp->busy_until_us + 999u) / 1000u;
        if (leaves_ms * 1000u > f->arrival_us + 999u) imp->stats.rate_waits++;
        f->waiting = 0;
        imp->waiting[f->cls]--;
        f->due_ms = leaves_ms + f->delay_ms;
    }
}

static uint16_t class_depth(uint8_t cls) {
    switch (cls) {
    case UB_PRIO_COMMAND: return UB_PRIO_DEPTH_COMMAND;
    case UB_PRIO_CONTROL: return UB_PRIO_DEPTH_CONTROL;
    case UB_PRIO_BULK: return UB_PRIO_DEPTH_BULK;
    default: return UB_PRIO_DEPTH_TELEMETRY;
    }
}

_Static_assert(UB_PRIO_DEPTH_COMMAND + UB_PRIO_DEPTH_CONTROL + UB_PRIO_DEPTH_TELEMETRY + UB_PRIO_DEPTH_BULK
                   <= UB_IMPAIR_DEPTH,
               "the per-class queues must fit in the link's buffer (UB_IMPAIR_DEPTH)");

/* Drops the oldest waiting telemetry copy (to take a newer one). @return false when none waits. */
static bool shed_oldest_telemetry(ub_impair_t *imp) {
    long oldest = -1;
    for (size_t i = 0; i < imp->count; i++) {
        const ub_impair_frame_t *f = &imp->queue[i];
        if (f->waiting && f->cls == UB_PRIO_TELEMETRY && (oldest < 0 || f->order < imp->queue[oldest].order))
            oldest = (long)i;
    }
    if (oldest < 0) return false;
    imp->stats.shed++;
    remove_at(imp, (size_t)oldest);
    return true;
}

size_t ub_impair_service(ub_impair_t *imp, uint64_t now_ms) {
    if (imp == NULL || imp->inner_ops == NULL) return 0;
    medium_pump(imp, now_ms);
    size_t accepted = 0;
    uint64_t last_order = 0;
    bool any = false;
    /* Bounded: every iteration removes one queued copy. */
    for (;;) {
        long i = next_ready(imp, now_ms, last_order, any);
        if (i < 0) break;
        ub_impair_frame_t *f = &imp->queue[i];
        if (!f->held && (!any || f->order > last_order)) last_order = f->order;
        any = true;
        if (inner_send(imp, f->bytes, f->len, now_ms) == UB_OK) accepted++;
        remove_at(imp, (size_t)i);
    }
    return accepted;
}

static uint64_t now_us_of(uint64_t ms) { return ms * 1000u; }

/* Queues one copy; false (counted queue_full) when the queue is full. */
static bool enqueue(ub_impair_t *imp, const uint8_t *frame, size_t len, uint64_t due_ms, bool held) {
    if (imp->count >= UB_IMPAIR_DEPTH) {
        imp->stats.queue_full++;
        return false;
    }
    ub_impair_frame_t *f = &imp->queue[imp->count++];
    f->due_ms = due_ms;
    f->order = ++imp->next_order;
    f->held = held ? 1 : 0;
    f->waiting = 0;
    f->cls = UB_PRIO_TELEMETRY;
    f->delay_ms = 0;
    f->arrival_us = now_us_of(due_ms);
    f->len = (uint16_t)len;
    memcpy(f->bytes, frame, len);
    return true;
}

/* One copy: decide its delay and whether it is held back, then send now or queue. Returns the result the
 * node should see for this copy. */
static int send_copy(ub_impair_t *imp, const uint8_t *frame, size_t len, uint8_t cls, uint64_t now_ms) {
    uint32_t delay = imp->params.delay_ms + uniform(imp, imp->params.jitter_ms);
    bool held = chance(imp, imp->params.reorder_ppm);
    uint64_t leaves_ms = now_ms;
    if (imp->params.rate_Bps != 0 && imp->params.prio != 0) {
        /* Wait in the class queue; the medium takes copies by class whenever it is free (medium_pump()). */
        int shed = 0;
        if (imp->waiting[cls] >= class_depth(cls) || imp->count >= UB_IMPAIR_DEPTH) {
            if (cls != UB_PRIO_TELEMETRY || !shed_oldest_telemetry(imp)) {
                imp->stats.queue_full++;
                return UB_ERR_AGAIN;
            }
            shed = 1;
        }
        if (delay > 0) imp->stats.delayed++;
        if (held) imp->stats.reordered++;
        (void)enqueue(imp, frame, len, 0, held); /* room made above */
        ub_impair_frame_t *f = &imp->queue[imp->count - 1];
        f->waiting = 1;
        f->cls = cls;
        f->delay_ms = delay;
        f->arrival_us = now_ms * 1000u;
        imp->waiting[cls]++;
        (void)ub_impair_service(imp, now_ms);
        return shed;
    }
    if (imp->params.rate_Bps != 0) {
        /* The medium carries one copy after the other: this one starts when it is free and takes len/rate. */
        if (imp->count >= UB_IMPAIR_DEPTH) { /* the radio's buffer is full: push back before taking the medium */
            imp->stats.queue_full++;
            return UB_ERR_AGAIN;
        }
        uint64_t now_us = now_ms * 1000u;
        uint64_t start_us = imp->busy_until_us > now_us ? imp->busy_until_us : now_us;
        imp->busy_until_us = start_us + ((uint64_t)len * 1000000u + imp->params.rate_Bps - 1) / imp->params.rate_Bps;
        leaves_ms = (imp->busy_until_us + 999u) / 1000u;
        if (leaves_ms > now_ms) imp->stats.rate_waits++;
    }
    if (delay > 0) imp->stats.delayed++;
    if (held) imp->stats.reordered++;
    if (delay == 0 && !held && imp->count == 0 && leaves_ms == now_ms) {
        /* Straight through: the node sees the inner transport's own answer (backpressure, errors). */
        return inner_send(imp, frame, len, now_ms);
    }
    if (!enqueue(imp, frame, len, leaves_ms + delay, held)) return UB_ERR_AGAIN;
    /* An unheld copy due now leaves at once (with anything ready before it, and held copies it overtakes). */
    if (delay == 0 && !held && leaves_ms == now_ms) (void)ub_impair_service(imp, now_ms);
    return UB_OK;
}

static int impair_send_class(void *impl, const uint8_t *frame, size_t len, uint8_t cls, uint64_t now_ms) {
    ub_impair_t *imp = impl;
    if (imp == NULL || frame == NULL || len == 0 || len > UB_FRAME_MAX) return UB_ERR_INVAL;
    if (cls >= UB_PRIO_CLASSES) cls = UB_PRIO_TELEMETRY;
    imp->stats.offered++;
    if (imp->inner_ops == NULL) {
        imp->stats.inner_errors++;
        return UB_ERR_CLOSED;
    }
    if (imp->params.mtu != 0 && len > imp->params.mtu) {
        imp->stats.too_big++;
        return UB_ERR_RANGE;
    }
    if (chance(imp, imp->params.loss_ppm)) {
        imp->stats.lost++;
        return UB_OK;
    }
    bool dup = chance(imp, imp->params.dup_ppm);
    int rc = send_copy(imp, frame, len, cls, now_ms);
    if (dup) {
        imp->stats.duplicated++;
        int rc2 = send_copy(imp, frame, len, cls, now_ms); /* its failure is counted; the node sent one frame */
        if (rc >= 0 && rc2 > 0) rc += rc2;
    }
    return rc;
}

/* Without a class (a caller that is not a node, the benches' raw streams): telemetry. A shed is counted
 * here; send() itself answers only UB_OK or an error. */
static int impair_send(void *impl, const uint8_t *frame, size_t len, uint64_t now_ms) {
    int rc = impair_send_class(impl, frame, len, UB_PRIO_TELEMETRY, now_ms);
    return rc > 0 ? UB_OK : rc;
}

static int impair_fileno(void *impl) {
    const ub_impair_t *imp = impl;
    if (imp == NULL || imp->inner_ops == NULL || imp->inner_ops->fileno == NULL) return -1;
    return imp->inner_ops->fileno(imp->inner);
}

const ub_link_ops_t ub_impair_ops = {
    .kind = "impair", .send = impair_send, .fileno = impair_fileno, .send_class = impair_send_class};

size_t ub_impair_pending(const ub_impair_t *imp) { return imp != NULL ? imp->count : 0; }

bool ub_impair_next_due(const ub_impair_t *imp, uint64_t *due_ms) {
    if (imp == NULL || imp->count == 0) return false;
    uint64_t best = UINT64_MAX;
    uint64_t start_us;
    if (medium_next_start(imp, &start_us)) best = (start_us + 999u) / 1000u; /* the medium takes the next copy */
    for (size_t i = 0; i < imp->count; i++) {
        const ub_impair_frame_t *f = &imp->queue[i];
        if (f->waiting) continue;
        /* A held copy may leave earlier (after a successor), but that happens inside a send or service. */
        uint64_t due = f->held ? held_deadline(imp, f) : f->due_ms;
        if (due < best) best = due;
    }
    if (due_ms != NULL) *due_ms = best;
    return true;
}

const ub_impair_stats_t *ub_impair_stats(const ub_impair_t *imp) { return imp != NULL ? &imp->stats : NULL; }

bool ub_impair_check_balance(const ub_impair_t *imp) {
    if (imp == NULL) return false;
    const ub_impair_stats_t *s = &imp->stats;
    return s->offered + s->duplicated
           == s->too_big + s->lost + s->queue_full + s->shed + s->passed + s->inner_again + s->inner_errors + imp->count;
}

/* ---- "loss=0.2,reorder=0.1,delay=5" ------------------------------------------------------------------ */

static void set_err(char *err, size_t cap, const char *msg, const char *item, size_t item_len) {
    if (err == NULL || cap == 0) return;
    snprintf(err, cap, "impairment item '%.*s': %s", (int)(item_len > 40 ? 40 : item_len), item, msg);
}

/* "0.25" / "1" / "0" / ".5" -> ppm, up to 6 fraction digits, at most 1. */
static bool parse_prob(const char *s, size_t n, uint32_t *ppm) {
    uint64_t whole = 0, frac = 0;
    size_t i = 0, whole_digits = 0, frac_digits = 0;
    while (i < n && s[i] >= '0' && s[i] <= '9') {
        whole = whole * 10 + (uint64_t)(s[i] - '0');
        if (whole > 1) return false;
        i++;
        whole_digits++;
    }
    if (i < n && s[i] == '.') {
        i++;
        while (i < n && s[i] >= '0' && s[i] <= '9') {
            if (frac_digits == 6) return false;
            frac = frac * 10 + (uint64_t)(s[i] - '0');
            frac_digits++;
            i++;
        }
    }
    if (i != n || whole_digits + frac_digits == 0) return false;
    for (size_t k = frac_digits; k < 6; k++) frac *= 10;
    uint64_t v = whole * UB_IMPAIR_PPM_MAX + frac;
    if (v > UB_IMPAIR_PPM_MAX) return false;
    *ppm = (uint32_t)v;
    return true;
}

static bool parse_uint(const char *s, size_t n, uint64_t max, uint64_t *out) {
    if (n == 0 || n > 20) return false;
    uint64_t v = 0;
    for (size_t i = 0; i < n; i++) {
        if (s[i] < '0' || s[i] > '9') return false;
        uint64_t d = (uint64_t)(s[i] - '0');
        if (v > (max - d) / 10) return false;
        v = v * 10 + d;
    }
    *out = v;
    return true;
}

int ub_impair_parse(const char *text, ub_impair_params_t *params, uint64_t *seed, char *err, size_t err_cap) {
    if (text == NULL || params == NULL) return UB_ERR_INVAL;
    ub_impair_params_t p;
    memset(&p, 0, sizeof p);
    uint64_t new_seed = 0;
    bool seed_given = false;
    const char *s = text;
    while (*s != '\0') {
        const char *end = strchr(s, ',');
        size_t n = end != NULL ? (size_t)(end - s) : strlen(s);
        const char *eq = memchr(s, '=', n);
        if (eq == NULL) {
            set_err(err, err_cap, "expected KEY=VALUE (keys: loss, dup, reorder, delay, jitter, hold, rate, mtu, prio, seed)",
                    s, n);
            return UB_ERR_INVAL;
        }
        size_t kn = (size_t)(eq - s);
        const char *v = eq + 1;
        size_t vn = n - kn - 1;
        uint64_t u = 0;
        bool ok;
#define KEY_IS(k) (kn == sizeof(k) - 1 && memcmp(s, k, kn) == 0)
        if (KEY_IS("loss") || KEY_IS("dup") || KEY_IS("reorder")) {
            uint32_t *dst = KEY_IS("loss") ? &p.loss_ppm : KEY_IS("dup") ? &p.dup_ppm : &p.reorder_ppm;
            ok = parse_prob(v, vn, dst);
            if (!ok) {
                set_err(err, err_cap, "probability must be a decimal from 0 to 1 (e.g. 0.2), at most 6 fraction digits",
                        s, n);
                return UB_ERR_INVAL;
            }
        } else if (KEY_IS("delay") || KEY_IS("jitter") || KEY_IS("hold")) {
            ok = parse_uint(v, vn, 600000u, &u);
            if (!ok) {
                set_err(err, err_cap, "time must be whole milliseconds from 0 to 600000", s, n);
                return UB_ERR_INVAL;
            }
            if (KEY_IS("delay")) p.delay_ms = (uint32_t)u;
            else if (KEY_IS("jitter")) p.jitter_ms = (uint32_t)u;
            else p.reorder_hold_ms = (uint32_t)u;
        } else if (KEY_IS("rate") || KEY_IS("mtu")) {
            ok = parse_uint(v, vn, KEY_IS("mtu") ? 65535u : 1000000000u, &u);
            if (!ok) {
                set_err(err, err_cap,
                        KEY_IS("mtu") ? "mtu must be whole bytes from 0 (no limit) to 65535"
                                      : "rate must be whole bytes per second from 0 (no limit) to 1000000000 (a "
                                        "57,600-baud radio: rate=5760)",
                        s, n);
                return UB_ERR_INVAL;
            }
            if (KEY_IS("mtu")) p.mtu = (uint32_t)u;
            else p.rate_Bps = (uint32_t)u;
        } else if (KEY_IS("prio")) {
            if (vn != 1 || (v[0] != '0' && v[0] != '1')) {
                set_err(err, err_cap, "prio must be 0 (send order) or 1 (by priority class, with rate=)", s, n);
                return UB_ERR_INVAL;
            }
            p.prio = (uint32_t)(v[0] - '0');
        } else if (KEY_IS("seed")) {
            ok = parse_uint(v, vn, UINT64_MAX, &u);
            if (!ok) {
                set_err(err, err_cap, "seed must be a whole number (0 to 18446744073709551615)", s, n);
                return UB_ERR_INVAL;
            }
            new_seed = u;
            seed_given = true;
        } else {
            set_err(err, err_cap,
                    "unknown key (expected one of: loss, dup, reorder, delay, jitter, hold, rate, mtu, prio, seed)", s, n);
            return UB_ERR_INVAL;
        }
#undef KEY_IS
        s += n;
        if (*s == ',') s++;
    }
    *params = p;
    if (seed_given && seed != NULL) *seed = new_seed;
    return UB_OK;
}
