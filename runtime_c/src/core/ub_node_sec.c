/* The node's side of frame security (contracts in ub/ub_node.h, "Security"; design in
 * docs/security.md): the receive gate (policy, key, tag), the per-(handling entity, source)
 * duplicate / replay windows, and the freshness challenge. Cryptography is ub_sec.c's; this file
 * decides what a verified or refused frame means for the router, and counts every drop. */
#include <string.h>

#include "ub/ub_node.h"
#include "ub/ub_sec.h"
#include "ub/ub_wire.h"
#include "core/ub_node_private.h"

static bool link_ok(const ub_node_t *node, int link_id) {
    return link_id >= 0 && link_id < UB_MAX_NODE_LINKS && node->links[link_id].in_use;
}

/* ---- set-up ------------------------------------------------------------ */

int ub_node_set_security(ub_node_t *node, ub_sec_t *sec) {
    if (node == NULL) return UB_ERR_INVAL;
    if (sec == NULL) {
        node->sec = NULL;
        return UB_OK;
    }
    if (!ub_sec_available()) return UB_ERR_UNSUPPORTED;
    if (!sec->initialised || !sec->started) return UB_ERR_INVAL;
    node->sec = sec;
    return UB_OK;
}

ub_sec_t *ub_node_security(const ub_node_t *node) { return node == NULL ? NULL : node->sec; }

int ub_node_set_require_signed(ub_node_t *node, bool on) {
    if (node == NULL) return UB_ERR_INVAL;
    node->require_signed = on ? 1 : 0;
    return UB_OK;
}

int ub_node_link_set_security(ub_node_t *node, int link_id, int require_signed, bool encrypt) {
    if (node == NULL || !link_ok(node, link_id) || require_signed < -1 || require_signed > 1) return UB_ERR_INVAL;
    node->links[link_id].require_signed = (int8_t)require_signed;
    node->links[link_id].encrypt = encrypt ? 1 : 0;
    return UB_OK;
}

bool ub_node_link_requires_signed(const ub_node_t *node, int link_id) {
    if (node == NULL || !link_ok(node, link_id)) return false;
    const ub_link_t *link = &node->links[link_id];
    return link->require_signed >= 0 ? link->require_signed != 0 : node->require_signed != 0;
}

/* ---- the gate: before any state ------------------------------------------ */

bool ub_priv_sec_gate(ub_node_t *node, int link_id, const ub_frame_header_t *h, const uint8_t *frame, size_t len,
                      uint8_t *plain, ub_priv_rx_t *rx) {
    const ub_link_t *link = &node->links[link_id];
    bool require = ub_node_link_requires_signed(node, link_id);
    if (h->flags == 0) {
        if (require) {
            ub_priv_count_drop(node, link_id, UB_DROP_UNSIGNED);
            return false;
        }
        rx->payload = frame + UB_FRAME_HEADER_LEN;
        rx->counter = h->seq;
        rx->secured = false;
        return true;
    }
    if (node->sec == NULL) { /* no keys here (or no security in this build): fail closed */
        ub_priv_count_drop(node, link_id, UB_DROP_UNKNOWN_KEY);
        return false;
    }
    int rc = ub_sec_verify(node->sec, h, frame, len, plain, UB_MAX_PAYLOAD);
    if (rc == UB_ERR_NOTFOUND || rc == UB_ERR_UNSUPPORTED) {
        ub_priv_count_drop(node, link_id, UB_DROP_UNKNOWN_KEY);
        return false;
    }
    if (rc < 0) {
        ub_priv_count_drop(node, link_id, UB_DROP_BAD_TAG);
        return false;
    }
    uint8_t prot = h->flags & UB_FRAME_FLAG_PROTECT_MASK;
    if (link->encrypt && require && prot != UB_FRAME_FLAG_ENCRYPTED) {
        ub_priv_count_drop(node, link_id, UB_DROP_UNSIGNED); /* authentic, but sent in clear where it must not be */
        return false;
    }
    /* Origin block (docs/security.md, "Origin authentication"): hop0 is under the hop tag, so only a
     * key-holding forwarder could have raised the hop limit above what the origin sent. */
    if ((h->flags & UB_FRAME_FLAG_ORIGIN) && h->hop_limit > h->origin_hop0) {
        ub_priv_count_drop(node, link_id, UB_DROP_BAD_ORIGIN);
        return false;
    }
    rx->payload = prot == UB_FRAME_FLAG_ENCRYPTED ? plain : frame + UB_FRAME_HEADER_LEN;
    rx->counter = ub_frame_counter(h);
    rx->secured = true;
    return true;
}

/* ---- windows ------------------------------------------------------------ */

static ub_dedup_entry_t *entry_find(ub_local_entity_t *loc, const uint8_t src[UB_ENTITY_ID_LEN]) {
    for (size_t i = 0; i < UB_DEDUP_SOURCES; i++) {
        ub_dedup_entry_t *e = &loc->dedup[i];
        if (e->in_use && ub_priv_id_eq(e->src, src)) return e;
    }
    return NULL;
}

/* The entry of `src`, created (evicting the least recently used one) if absent; *fresh tells which. */
static ub_dedup_entry_t *entry_get(ub_node_t *node, ub_local_entity_t *loc, const uint8_t src[UB_ENTITY_ID_LEN],
                                   bool *fresh) {
    ub_dedup_entry_t *found = entry_find(loc, src);
    if (found != NULL) {
        *fresh = false;
        return found;
    }
    ub_dedup_entry_t *victim = NULL;
    for (size_t i = 0; i < UB_DEDUP_SOURCES; i++) {
        ub_dedup_entry_t *e = &loc->dedup[i];
        if (!e->in_use) {
            victim = e;
            break;
        }
        if (victim == NULL || e->last_used < victim->last_used) victim = e;
    }
    if (victim->in_use) node->counters.dedup_evictions++; /* an evicted signed source is challenged again */
    memset(victim, 0, sizeof *victim);
    memcpy(victim->src, src, UB_ENTITY_ID_LEN);
    victim->in_use = 1;
    victim->challenge_link = -1;
    *fresh = true;
    return victim;
}

/* Unsigned sources: the 32-bit sequence with serial-number arithmetic (it may wrap), and the
 * restart rule (a sequence far behind resets the window). Returns true for a duplicate. */
static inline bool unsigned_seen(ub_node_t *node, ub_dedup_entry_t *e, bool fresh, uint32_t seq) {
    uint32_t highest = (uint32_t)e->win.highest;
    if (fresh) {
        e->win.highest = seq;
        e->win.seen = 1;
        return false;
    }
    int64_t ahead = (int32_t)(seq - highest);
    if (ahead > 0) {
        e->win.seen = ahead >= UB_DEDUP_WINDOW ? 1u : (e->win.seen << ahead) | 1u;
        e->win.highest = seq;
        return false;
    }
    if (-ahead < UB_DEDUP_WINDOW) {
        uint64_t bit = (uint64_t)1 << (-ahead);
        if (e->win.seen & bit) return true;
        e->win.seen |= bit;
        return false;
    }
    /* Far behind the window: the source restarted its sequence; do not silence it. Unsigned only:
     * a secured source never gets here (its replays stay replays). */
    node->counters.dedup_resets++;
    e->win.highest = seq;
    e->win.seen = 1;
    return false;
}

/* The source proved `counter` (a CHALLENGE_REPLY bound to our nonce, or our own frame): the window starts
 * there with everything at or below barred, and the jump bound grows from here. */
static void prove(ub_dedup_entry_t *e, uint64_t counter, uint8_t key_id, uint64_t now_ms) {
    ub_sec_window_establish(&e->win, counter);
    e->secured = 1;
    e->proven = counter;
    e->proven_ms = now_ms;
    e->jump_bound = ub_sec_jump_limit(counter, 0, 0); /* proven + slack: the bound at any rate and time */
    e->win_key = key_id;
    e->replay_streak = 0;
    e->reproving = 0;
}

void ub_priv_window_note_own(ub_node_t *node, int slot, const ub_frame_header_t *h, bool secured, uint64_t now_ms) {
    ub_local_entity_t *loc = &node->locals[slot];
    bool fresh;
    ub_dedup_entry_t *e = entry_get(node, loc, h->src_id, &fresh);
    e->last_used = ++node->use_stamp;
    if (!secured) {
        (void)unsigned_seen(node, e, fresh, h->seq);
        return;
    }
    uint64_t counter = ub_frame_counter(h);
    if (!e->secured || e->reproving || counter > e->win.highest) {
        /* Our own counter is its own proof: a frame claiming to be ours can never get ahead of it by more
         * than the bound. */
        prove(e, counter, h->key_id, now_ms);
    } else if (ub_sec_window_check(&e->win, counter) == UB_SEC_WINDOW_NEW) {
        ub_sec_window_accept(&e->win, counter);
    }
}

/* A link-local frame of a service whose link-local frames prove themselves (ub_service_t.link_local_self_proving). */
static bool self_proving(const ub_node_t *node, const ub_frame_header_t *h) {
    if (!ub_entity_id_is_link_local(h->dest_id)) return false;
    uint8_t i = node->svc_by_code[UB_SVC_LINK_LOCAL][h->admin];
    return i != 0 && node->services[i - 1]->link_local_self_proving;
}

static bool is_challenge_code(uint8_t admin) {
    return admin == UB_ADMIN_CHALLENGE || admin == UB_ADMIN_CHALLENGE_REPLY;
}

/* Sends (or resends) the challenge held in `e` from local slot `slot` to the entry's source. */
static void send_challenge(ub_node_t *node, int slot, ub_dedup_entry_t *e, uint64_t now_ms) {
    uint8_t frame[UB_FRAME_MAX];
    memcpy(frame + UB_FRAME_HEADER_LEN, e->nonce, UB_SEC_NONCE_LEN);
    ub_frame_header_t h;
    memset(&h, 0, sizeof h);
    memcpy(h.dest_id, e->src, UB_ENTITY_ID_LEN);
    h.admin = UB_ADMIN_CHALLENGE;
    h.payload_size = UB_SEC_NONCE_LEN;
    e->challenge_ms = now_ms;
    e->challenge_tries++;
    node->sec->stats.challenges_sent++;
    (void)ub_priv_originate(node, slot, frame, sizeof frame, &h, e->challenge_link, now_ms);
}

/* A frame from a source without freshness state arrived at `slot`: start (or retry) its challenge. */
static void challenge(ub_node_t *node, int slot, int link_id, ub_dedup_entry_t *e, const uint8_t src[UB_ENTITY_ID_LEN],
                      uint64_t now_ms) {
    ub_sec_t *sec = node->sec;
    if (sec == NULL || ub_sec_tx_key(sec) == 0) return; /* cannot sign a challenge: the source stays unverified */
    if (e == NULL) {
        bool fresh;
        e = entry_get(node, &node->locals[slot], src, &fresh);
    }
    e->last_used = ++node->use_stamp;
    if (e->challenging) {
        e->challenge_tries = 0; /* traffic from the source: the tick may retry again */
        bool recent = now_ms >= e->challenge_ms && now_ms - e->challenge_ms < sec->opt.challenge_retry_ms;
        if (recent) return;
    } else {
        ub_sec_random(sec, e->nonce, UB_SEC_NONCE_LEN);
        e->challenging = 1;
        e->challenge_tries = 0;
    }
    e->challenge_link = (int16_t)link_id;
    send_challenge(node, slot, e, now_ms);
}

/* A source that holds freshness here looks out of step (a counter jump, or a run of `replay`): challenge it
 * again, at most once per rechallenge_min_ms, keeping its window until the reply re-proves its counter. A
 * genuine sender that restarted, or whose window a forged frame pushed ahead, recovers this way. */
static void rechallenge(ub_node_t *node, int slot, int link_id, ub_dedup_entry_t *e, uint64_t now_ms) {
    ub_sec_t *sec = node->sec;
    if (!e->challenging) {
        bool recent = e->rechallenged && now_ms >= e->rechallenge_ms && now_ms - e->rechallenge_ms < sec->opt.rechallenge_min_ms;
        if (recent) return;
        e->rechallenged = 1;
        e->rechallenge_ms = now_ms;
        sec->stats.rechallenges++;
    }
    challenge(node, slot, link_id, e, e->src, now_ms);
}

/* The key whose frames set this window left the keyring (a rotation removed it): what they set is forgotten,
 * and the source proves its counter again under a key still held. */
static void check_window_key(ub_node_t *node, ub_dedup_entry_t *e) {
    if (e->win_key == 0 || ub_sec_has_key(node->sec, e->win_key)) return;
    e->win_key = 0;
    e->reproving = 1;
    e->challenging = 0; /* a challenge under the removed key may be outstanding: start afresh */
    node->sec->stats.window_resets++;
}

static ub_priv_window_t secured_pass(ub_node_t *node, int slot, int link_id, const ub_frame_header_t *h,
                                     const ub_priv_rx_t *rx, ub_dedup_entry_t *e, uint64_t now_ms) {
    ub_sec_t *sec = node->sec;
    e->last_used = ++node->use_stamp;
    /* A CHALLENGE_REPLY while we challenge is judged by its nonce (on_reply), not by the window it may repair. */
    bool awaited_reply = h->admin == UB_ADMIN_CHALLENGE_REPLY && e->challenging;
    if (rx->counter > e->jump_bound) { /* beyond the bound last computed: compute it for now */
        uint64_t elapsed = now_ms >= e->proven_ms ? now_ms - e->proven_ms : 0; /* a clock gone back: no credit */
        uint64_t limit = ub_sec_jump_limit(e->proven, elapsed, sec->opt.max_counter_rate);
        if (limit > e->jump_bound) e->jump_bound = limit;
    }
    if (rx->counter > e->jump_bound) {
        if (awaited_reply) return UB_PRIV_WINDOW_PASS;
        ub_priv_count_drop(node, link_id, UB_DROP_COUNTER_JUMP);
        rechallenge(node, slot, link_id, e, now_ms);
        return UB_PRIV_WINDOW_DROPPED;
    }
    switch (ub_sec_window_check(&e->win, rx->counter)) {
    case UB_SEC_WINDOW_NEW:
        if (rx->counter > e->win.highest) e->win_key = h->key_id;
        ub_sec_window_accept(&e->win, rx->counter);
        e->replay_streak = 0;
        return UB_PRIV_WINDOW_PASS;
    case UB_SEC_WINDOW_DUPLICATE:
        ub_priv_count_drop(node, link_id, UB_DROP_DUPLICATE);
        return UB_PRIV_WINDOW_DUPLICATE;
    case UB_SEC_WINDOW_OLD:
    default:
        if (awaited_reply) return UB_PRIV_WINDOW_PASS;
        ub_priv_count_drop(node, link_id, UB_DROP_REPLAY);
        if (e->replay_streak < UINT16_MAX) e->replay_streak++;
        if (e->replay_streak >= sec->opt.replay_streak) rechallenge(node, slot, link_id, e, now_ms);
        return UB_PRIV_WINDOW_DROPPED;
    }
}

/* ub_priv_window_pass() for a frame that passed the security gate, out of line: the unsigned path (every
 * frame of a lab without keys, three times per frame over three hops) saves no registers for it. */
static __attribute__((noinline)) ub_priv_window_t window_pass_secured(ub_node_t *node, int slot, int link_id,
                                                                      const ub_frame_header_t *h,
                                                                      const ub_priv_rx_t *rx, ub_dedup_entry_t *e,
                                                                      uint64_t now_ms) {
    if (e != NULL && e->secured) {
        check_window_key(node, e);
        if (!e->reproving) return secured_pass(node, slot, link_id, h, rx, e, now_ms);
    }
    /* No freshness state (or none under a key still held): the counter proves nothing (it may be a captured
     * frame). A challenge and its reply are the exception that builds the state: they are idempotent and
     * bound to a nonce. */
    if (is_challenge_code(h->admin) || self_proving(node, h)) return UB_PRIV_WINDOW_PASS;
    ub_priv_count_drop(node, link_id, UB_DROP_UNVERIFIED);
    challenge(node, slot, link_id, e, h->src_id, now_ms);
    return UB_PRIV_WINDOW_UNVERIFIED;
}

ub_priv_window_t ub_priv_window_pass(ub_node_t *node, int slot, int link_id, const ub_frame_header_t *h,
                                     const ub_priv_rx_t *rx, uint64_t now_ms) {
    ub_local_entity_t *loc = &node->locals[slot];
    ub_dedup_entry_t *e = entry_find(loc, h->src_id);
    if (rx->secured) return window_pass_secured(node, slot, link_id, h, rx, e, now_ms);
    if (e != NULL && e->secured) { /* this source speaks signed: a plain frame claiming it is forged */
        ub_priv_count_drop(node, link_id, UB_DROP_UNSIGNED);
        return UB_PRIV_WINDOW_DROPPED;
    }
    bool fresh = false;
    if (e == NULL) e = entry_get(node, loc, h->src_id, &fresh);
    e->last_used = ++node->use_stamp;
    if (unsigned_seen(node, e, fresh, h->seq)) {
        ub_priv_count_drop(node, link_id, UB_DROP_DUPLICATE);
        return UB_PRIV_WINDOW_DUPLICATE;
    }
    return UB_PRIV_WINDOW_PASS;
}

/* ---- the challenge protocol at its ends ---------------------------------- */

static void on_challenge(ub_node_t *node, int slot, int link_id, const ub_frame_header_t *h, const uint8_t *nonce,
                         uint64_t now_ms) {
    ub_sec_t *sec = node->sec;
    if (sec == NULL || ub_sec_tx_key(sec) == 0) return; /* cannot answer signed; the requester keeps dropping */
    bool fresh;
    ub_dedup_entry_t *e = entry_get(node, &node->locals[slot], h->src_id, &fresh);
    e->last_used = ++node->use_stamp;
    /* One reply per nonce per reply_min_ms: copies over redundant links, or a replayed challenge, do
     * not multiply replies; the requester's retry (every challenge_retry_ms) is answered again. */
    bool recent = !fresh && now_ms >= e->reply_ms && now_ms - e->reply_ms < sec->opt.reply_min_ms &&
                  memcmp(e->reply_nonce, nonce, UB_SEC_NONCE_LEN) == 0;
    if (recent) {
        sec->stats.replies_suppressed++;
        ub_priv_count_drop(node, link_id, UB_DROP_DUPLICATE);
        return;
    }
    memcpy(e->reply_nonce, nonce, UB_SEC_NONCE_LEN);
    e->reply_ms = now_ms;
    uint8_t frame[UB_FRAME_MAX];
    memcpy(frame + UB_FRAME_HEADER_LEN, nonce, UB_SEC_NONCE_LEN);
    ub_frame_header_t r;
    memset(&r, 0, sizeof r);
    memcpy(r.dest_id, h->src_id, UB_ENTITY_ID_LEN);
    r.admin = UB_ADMIN_CHALLENGE_REPLY;
    r.payload_size = UB_SEC_NONCE_LEN;
    sec->stats.replies_sent++;
    (void)ub_priv_originate(node, slot, frame, sizeof frame, &r, link_id, now_ms);
}

static void on_reply(ub_node_t *node, int slot, int link_id, const ub_frame_header_t *h, const uint8_t *nonce,
                     uint64_t now_ms) {
    ub_dedup_entry_t *e = entry_find(&node->locals[slot], h->src_id);
    if (e == NULL || !e->challenging || memcmp(e->nonce, nonce, UB_SEC_NONCE_LEN) != 0) {
        ub_priv_count_drop(node, link_id, UB_DROP_REPLAY); /* bound to no outstanding challenge of ours */
        return;
    }
    /* The reply carries the source's current counter: nothing at or below it (any captured frame)
     * will ever pass; everything it sends next does. */
    prove(e, ub_frame_counter(h), h->key_id, now_ms);
    e->challenging = 0;
    e->challenge_tries = 0;
    memset(e->nonce, 0, sizeof e->nonce);
    if (node->sec != NULL) node->sec->stats.challenges_completed++;
}

/* CHALLENGE / CHALLENGE_REPLY reached local slot `rx->slot` (link -1: from an entity of this node). Drops are
 * counted here (unsigned, bad_payload, replay), so the frame is always "handled". */
static bool sec_on_frame(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx, const ub_frame_header_t *h,
                         const uint8_t *payload, uint64_t now_ms, ub_drop_reason_t *drop) {
    (void)svc;
    (void)drop;
    int slot = rx->slot, link_id = rx->link_id;
    if (link_id >= 0 && !rx->secured) { /* an unsigned challenge proves nothing and is never answered */
        ub_priv_count_drop(node, link_id, UB_DROP_UNSIGNED);
        return true;
    }
    if (h->payload_size != UB_SEC_NONCE_LEN) {
        ub_priv_count_drop(node, link_id, UB_DROP_BAD_PAYLOAD);
        return true;
    }
    if (ub_entity_id_is_link_local(h->dest_id)) {
        /* A link hello (ub_tcp.h): a signed CHALLENGE to whoever is at the other end, sent by a connecting
         * client so that a listener can adopt the connection. Passing the window already proved what it
         * can (the key, a counter); there is nobody's freshness to establish, so nothing to answer. */
        if (h->admin != UB_ADMIN_CHALLENGE) ub_priv_count_drop(node, link_id, UB_DROP_BAD_PAYLOAD);
        return true;
    }
    if (h->admin == UB_ADMIN_CHALLENGE)
        on_challenge(node, slot, link_id, h, payload, now_ms);
    else
        on_reply(node, slot, link_id, h, payload, now_ms);
    return true;
}

/* Resends unanswered challenges (at most UB_SEC_CHALLENGE_TRIES per frame of their source). */
static void sec_tick(const ub_service_t *svc, ub_node_t *node, uint64_t now_ms) {
    (void)svc;
    ub_sec_t *sec = node->sec;
    if (sec == NULL || ub_sec_tx_key(sec) == 0) return;
    for (int slot = 0; slot < UB_MAX_LOCAL_ENTITIES; slot++) {
        ub_local_entity_t *loc = &node->locals[slot];
        if (!loc->in_use) continue;
        for (size_t i = 0; i < UB_DEDUP_SOURCES; i++) {
            ub_dedup_entry_t *e = &loc->dedup[i];
            if (!e->in_use || !e->challenging || e->challenge_tries >= UB_SEC_CHALLENGE_TRIES) continue;
            /* A clock that went backwards counts as due, so a retry is never postponed for good. */
            if (now_ms >= e->challenge_ms && now_ms - e->challenge_ms < sec->opt.challenge_retry_ms) continue;
            send_challenge(node, slot, e, now_ms);
        }
    }
}

/* Next challenge retry (ub_service.h `next_due`); none without a keyring that signs. */
static bool sec_next_due(const ub_service_t *svc, const ub_node_t *node, uint64_t now_ms, uint64_t *due_ms) {
    (void)svc;
    const ub_sec_t *sec = node->sec;
    if (sec == NULL || ub_sec_tx_key(sec) == 0) return false;
    uint64_t best = UINT64_MAX;
    for (int slot = 0; slot < UB_MAX_LOCAL_ENTITIES; slot++) {
        const ub_local_entity_t *loc = &node->locals[slot];
        if (!loc->in_use) continue;
        for (size_t i = 0; i < UB_DEDUP_SOURCES; i++) {
            const ub_dedup_entry_t *e = &loc->dedup[i];
            if (!e->in_use || !e->challenging || e->challenge_tries >= UB_SEC_CHALLENGE_TRIES) continue;
            uint64_t due = now_ms < e->challenge_ms ? now_ms : e->challenge_ms + sec->opt.challenge_retry_ms;
            if (due < best) best = due;
        }
    }
    *due_ms = best;
    return best != UINT64_MAX;
}

static const uint8_t sec_codes[] = {UB_ADMIN_CHALLENGE, UB_ADMIN_CHALLENGE_REPLY};
static const uint8_t sec_link_local_codes[] = {UB_ADMIN_CHALLENGE}; /* the link hello */

/* Freshness challenges (docs/security.md) as a service of the core: the window (ub_priv_window_pass())
 * starts them, this answers and completes them. Ticks after the protocol engines, as before services. */
const ub_service_t ub_priv_sec_service = {
    .name = "challenge",
    .codes = sec_codes,
    .n_codes = sizeof sec_codes,
    .link_local_codes = sec_link_local_codes,
    .n_link_local_codes = sizeof sec_link_local_codes,
    .order = 50,
    .on_frame = sec_on_frame,
    .tick = sec_tick,
    .next_due = sec_next_due,
};
