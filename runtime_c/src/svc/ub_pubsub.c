/* Publish/subscribe tables (ub_pubsub.h, docs/pubsub.md): the service every node runs (ub_node_init(),
 * ub_priv_pubsub_service below). It takes the request/STOP codes and the replies no other service claims,
 * carries the administration tables of its entities (ub_admin.c: their replies and ticks come through
 * here), and observes DATA (subscription bookkeeping, the write policy). Public headers only. */
#include "ub/ub_pubsub.h"

#include <string.h>

#include "ub/ub_node.h"
#include "ub/ub_wire.h"
#include "svc/ub_svc_private.h"

void ub_priv_timing_defaults(ub_pubsub_timing_t *t) {
    if (t->retry_ms == 0) t->retry_ms = UB_PS_DEFAULT_RETRY_MS;
    if (t->renew_ms == 0) t->renew_ms = UB_PS_DEFAULT_RENEW_MS;
    if (t->lease_ms == 0) t->lease_ms = 3u * t->renew_ms;
    if (t->timeout_min_ms == 0) t->timeout_min_ms = UB_PS_DEFAULT_TIMEOUT_MIN_MS;
    if (t->stop_retries == 0) t->stop_retries = UB_PS_DEFAULT_STOP_RETRIES;
    if (t->expiry_ms == 0) t->expiry_ms = UB_PS_DEFAULT_EXPIRY_MS;
}

uint64_t ub_pubsub_data_timeout_ms(const ub_pubsub_timing_t *timing, uint32_t period_ms) {
    uint64_t three_periods = 3u * (uint64_t)period_ms;
    return three_periods > timing->timeout_min_ms ? three_periods : timing->timeout_min_ms;
}

static ub_pubsub_table_t *table_of(ub_node_t *node, int slot) { return ub_node_svc_pubsub_table(node, slot); }

static const uint8_t *self_id(const ub_node_t *node, int slot) {
    return ub_node_entity_id(node, ub_node_slot_entity(node, slot));
}

/* Live = not free and not on its way out; stopping rows are found only when `with_stopping`. Rows are taken
 * lowest first (new_row), so the search ends at the highest row ever taken: every delivered DATA frame asks
 * here, and a table with a few rows used to pay 32 compares for a source it has no row for. */
static int find_row(const ub_pubsub_table_t *t, ub_ps_kind_t kind, uint32_t instance,
                    const uint8_t peer[UB_ENTITY_ID_LEN], bool with_stopping) {
    for (int r = 0; r < (int)t->rows_used; r++) {
        const ub_ps_row_t *row = &t->rows[r];
        if (row->kind != kind || row->instance != instance) continue;
        if (memcmp(row->peer, peer, UB_ENTITY_ID_LEN) != 0) continue;
        if (!with_stopping && kind == UB_PS_SUBSCRIPTION && row->state == UB_SUB_STOPPING) continue;
        return r;
    }
    return UB_ERR_NOTFOUND;
}

static ub_ps_row_t *new_row(ub_pubsub_table_t *t, ub_ps_kind_t kind, uint32_t instance,
                            const uint8_t peer[UB_ENTITY_ID_LEN]) {
    for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) {
        ub_ps_row_t *row = &t->rows[r];
        if (row->kind != UB_PS_FREE) continue;
        if ((uint32_t)r >= t->rows_used) t->rows_used = (uint32_t)r + 1u;
        memset(row, 0, sizeof *row);
        row->kind = (uint8_t)kind;
        row->instance = instance;
        memcpy(row->peer, peer, UB_ENTITY_ID_LEN);
        return row;
    }
    return NULL;
}

static int row_index(const ub_pubsub_table_t *t, const ub_ps_row_t *row) { return (int)(row - t->rows); }

/* ---- who keeps a row alive (docs/pubsub.md) ------------------------------
 *
 * A remote row has an owner (who asked for it) and a lease the owner renews. When the owner is the flow's
 * other end -- a publication its own destination asked for -- the lease is the whole story. When it is a
 * third party -- an administrator's subscription at a destination, or its publication from a source to
 * someone else -- the row belongs to the flow once the target acknowledged it (the paper: "the
 * responsibility for regenerating table change requests ... lies at the data destination"): if the owner's
 * lease lapses, the row lives on as long as its keeper, the flow's other end, shows signs of life, and is
 * reclaimed `expiry_ms` after the last one. */

static bool third_party(const ub_ps_row_t *row) {
    if (ub_entity_id_is_zero(row->owner)) return false; /* local */
    return row->kind == UB_PS_SUBSCRIPTION || memcmp(row->owner, row->peer, UB_ENTITY_ID_LEN) != 0;
}

/* The owner renews its lease: it is still around (as far as this node can tell). Local rows have no owner. */
static bool owner_live(const ub_ps_row_t *row, uint64_t now_ms) {
    return !ub_entity_id_is_zero(row->owner) && (row->lease_until_ms == 0 || now_ms < row->lease_until_ms);
}

static void keeper_alive(ub_ps_row_t *row, uint64_t now_ms) {
    row->keeper_ms = now_ms;
    row->keeper_seen = 1;
}

static bool keeper_lives(const ub_node_t *node, const ub_ps_row_t *row, uint64_t now_ms) {
    return row->keeper_seen && now_ms - row->keeper_ms < ub_node_options(node)->timing.expiry_ms;
}

/* The owner's lease ran out at `now_ms`: true when the row must go, false when it is (or stays) handed over. */
static bool lease_lapsed_reclaims(ub_node_t *node, ub_ps_row_t *row, uint64_t now_ms) {
    if (!third_party(row) || !keeper_lives(node, row, now_ms)) {
        ub_node_svc_counters(node)->leases_expired++;
        return true;
    }
    if (!row->handed_over) {
        row->handed_over = 1;
        ub_node_svc_counters(node)->handovers++;
    }
    return false;
}

static void start_requesting(ub_ps_row_t *row, uint64_t now_ms) {
    row->state = UB_SUB_REQUESTING;
    row->reported_flowing = 0;
    row->next_due_ms = now_ms;
}

static void start_stopping(ub_ps_row_t *row, uint64_t now_ms) {
    row->state = UB_SUB_STOPPING;
    row->stop_tries = 0;
    row->next_due_ms = now_ms;
}

/* ---- local API --------------------------------------------------------- */

static int checked_slot(const ub_node_t *node, int entity, uint32_t instance, const uint8_t *peer,
                        uint32_t period_ms) {
    if (node == NULL || peer == NULL || period_ms == 0 || instance >= ub_node_catalogue(node)->n_instances) return UB_ERR_INVAL;
    int slot = ub_node_entity_slot(node, entity);
    return slot < 0 ? UB_ERR_INVAL : slot;
}

int ub_pubsub_publish(ub_node_t *node, int entity, uint32_t instance, const uint8_t dest_id[UB_ENTITY_ID_LEN],
                      uint32_t period_ms, uint64_t now_ms) {
    int slot = checked_slot(node, entity, instance, dest_id, period_ms);
    if (slot < 0) return slot;
    ub_pubsub_table_t *t = table_of(node, slot);
    int r = find_row(t, UB_PS_PUBLICATION, instance, dest_id, false);
    ub_ps_row_t *row = r >= 0 ? &t->rows[r] : new_row(t, UB_PS_PUBLICATION, instance, dest_id);
    if (row == NULL) return UB_ERR_FULL;
    memset(row->owner, 0, UB_ENTITY_ID_LEN);
    row->lease_until_ms = 0;
    row->handed_over = 0;
    row->period_ms = period_ms;
    row->next_due_ms = now_ms;
    return row_index(t, row);
}

int ub_pubsub_subscribe(ub_node_t *node, int entity, uint32_t instance, const uint8_t source_id[UB_ENTITY_ID_LEN],
                        uint32_t period_ms, uint64_t now_ms) {
    int slot = checked_slot(node, entity, instance, source_id, period_ms);
    if (slot < 0) return slot;
    ub_pubsub_table_t *t = table_of(node, slot);
    int r = find_row(t, UB_PS_SUBSCRIPTION, instance, source_id, true);
    ub_ps_row_t *row = r >= 0 ? &t->rows[r] : new_row(t, UB_PS_SUBSCRIPTION, instance, source_id);
    if (row == NULL) return UB_ERR_FULL;
    if (r < 0) row->request_id = ub_node_svc_new_request_id(node);
    memset(row->owner, 0, UB_ENTITY_ID_LEN);
    row->lease_until_ms = 0;
    row->handed_over = 0;
    row->period_ms = period_ms;
    start_requesting(row, now_ms);
    return row_index(t, row);
}

int ub_pubsub_stop(ub_node_t *node, int entity, int row, uint64_t now_ms) {
    if (node == NULL || row < 0 || row >= UB_MAX_PUBSUB_ROWS) return UB_ERR_INVAL;
    int slot = ub_node_entity_slot(node, entity);
    if (slot < 0) return UB_ERR_INVAL;
    ub_ps_row_t *r = &table_of(node, slot)->rows[row];
    if (r->kind == UB_PS_FREE) return UB_ERR_NOTFOUND;
    if (r->kind == UB_PS_PUBLICATION) r->kind = UB_PS_FREE;
    else if (r->state != UB_SUB_STOPPING) start_stopping(r, now_ms);
    return UB_OK;
}

int ub_pubsub_find(const ub_node_t *node, int entity, ub_ps_kind_t kind, uint32_t instance,
                   const uint8_t peer[UB_ENTITY_ID_LEN]) {
    if (node == NULL || peer == NULL) return UB_ERR_INVAL;
    int slot = ub_node_entity_slot(node, entity);
    if (slot < 0) return UB_ERR_INVAL;
    return find_row(&(*ub_node_svc_pubsub_table(node, slot)), kind, instance, peer, false);
}

const ub_ps_row_t *ub_pubsub_row(const ub_node_t *node, int entity, int row) {
    if (node == NULL || row < 0 || row >= UB_MAX_PUBSUB_ROWS) return NULL;
    int slot = ub_node_entity_slot(node, entity);
    return slot < 0 ? NULL : &(*ub_node_svc_pubsub_table(node, slot)).rows[row];
}

int ub_pubsub_count(const ub_node_t *node, int entity, ub_ps_kind_t kind) {
    if (node == NULL) return UB_ERR_INVAL;
    int slot = ub_node_entity_slot(node, entity);
    if (slot < 0) return UB_ERR_INVAL;
    int n = 0;
    for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) n += (*ub_node_svc_pubsub_table(node, slot)).rows[r].kind == kind;
    return n;
}

/* ---- requests from other entities --------------------------------------- */

typedef struct request {
    uint32_t id;
    uint32_t period_ms;
    uint32_t lease_ms;
    const uint8_t *peer;
} request_t;

/*
 * The sender of an admin frame as the policy sees it (ub_policy.h). `policed`: a policy is attached and
 * the frame came over a link. `admin`: may use the exclusive rights -- local entities, and over a link
 * whoever ub_node_may_administer() accepts: on a node with a keyring only a verified (signed) requester,
 * then everyone without a policy (the paper's closed lab), otherwise only a listed administrator.
 */
typedef struct sender {
    const ub_frame_header_t *h;
    bool policed;
    bool admin;
} sender_t;

static bool is_self(const uint8_t *peer, const ub_frame_header_t *h) {
    return memcmp(peer, h->src_id, UB_ENTITY_ID_LEN) == 0;
}

static void reply(ub_node_t *node, int slot, const ub_frame_header_t *h, uint32_t request_id, bool nack,
                  uint8_t detail, uint64_t now_ms) {
    (void)ub_node_svc_send_reply(node, slot, nack, h->dir_id, h->src_id, request_id, h->admin, detail, 0, now_ms);
}

/* Another administrator keeps this row (or, under an exclusive policy, this node): the request changes nothing,
 * and the requester is told so instead of being acknowledged into a status that is not its own. */
static bool other_admin(ub_node_t *node, int slot, const ub_frame_header_t *h, uint32_t request_id, uint64_t now_ms) {
    ub_node_svc_counters(node)->other_admin++;
    reply(node, slot, h, request_id, true, UB_NACK_OTHER_ADMIN, now_ms);
    return true;
}

/* Exclusive-administrator policy (ub_policy.h): some administrator other than `requester` owns a live row in a
 * table of this node. */
static bool node_held_by_other(const ub_node_t *node, const uint8_t requester[UB_ENTITY_ID_LEN], uint64_t now_ms) {
    for (int slot = 0; slot < UB_MAX_LOCAL_ENTITIES; slot++) {
        if (!(ub_node_slot_entity(node, slot) >= 0)) continue;
        for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) {
            const ub_ps_row_t *row = &(*ub_node_svc_pubsub_table(node, slot)).rows[r];
            if (row->kind == UB_PS_FREE || !owner_live(row, now_ms)) continue;
            if (row->kind == UB_PS_SUBSCRIPTION && row->state == UB_SUB_STOPPING) continue;
            if (memcmp(row->owner, requester, UB_ENTITY_ID_LEN) != 0 && ub_policy_is_admin(ub_node_policy(node), row->owner))
                return true;
        }
    }
    return false;
}

static bool exclusive_refuses(const ub_node_t *node, const sender_t *s, uint64_t now_ms) {
    return s->policed && s->admin && ub_node_policy(node)->exclusive_admin && node_held_by_other(node, s->h->src_id, now_ms);
}

/* The policy refuses this sender: tell it why; the caller's `false` makes the node count the drop. */
static bool refuse(ub_node_t *node, int slot, const ub_frame_header_t *h, uint32_t request_id, uint64_t now_ms) {
    reply(node, slot, h, request_id, true, UB_NACK_NOT_AUTHORIZED, now_ms);
    return false;
}

/* Resolves and checks the content of a request; returns the instance or -(nack reason). */
static int requested_instance(const ub_node_t *node, const ub_frame_header_t *h, bool needs_binding) {
    int idx = ub_catalogue_find(ub_node_catalogue(node), h->dir_id);
    if (idx < 0) return -UB_NACK_UNKNOWN_CONTENT;
    if (ub_node_catalogue(node)->instances[idx].type->fingerprint != h->fingerprint) return -UB_NACK_LAYOUT;
    if (needs_binding && ub_node_binding(node, (uint32_t)idx) == NULL) return -UB_NACK_UNBOUND;
    return idx;
}

static const char *instance_name(const ub_node_t *node, uint32_t instance) {
    const char *name = ub_node_catalogue(node)->instances[instance].name;
    return name != NULL ? name : "";
}

static bool may_read(const ub_node_t *node, int slot, const sender_t *s, uint32_t instance) {
    if (!s->policed || s->admin || !ub_node_policy(node)->read_restricted) return true;
    return ub_policy_rule_matches(ub_node_policy(node), UB_POLICY_READ, self_id(node, slot), s->h->src_id,
                                  instance_name(node, instance));
}

static uint64_t row_cost(const ub_node_t *node, uint32_t instance, uint32_t period_ms) {
    return ub_policy_row_bytes_per_s(ub_node_catalogue(node)->instances[instance].type->packed_size, period_ms);
}

/*
 * Limits of a requester (ub_policy_limits_t; an administrator's own, higher ones: never none, issue #23 item 5):
 * the period, and its rows and their bytes per second over every table of this node once `replacing` (its
 * existing row, or NULL) takes the new period.
 */
static bool within_limits(const ub_node_t *node, const uint8_t requester[UB_ENTITY_ID_LEN], bool admin,
                          uint32_t instance, uint32_t period_ms, const ub_ps_row_t *replacing) {
    const ub_policy_limits_t *lim = ub_policy_limits_for(ub_node_policy(node), admin);
    if (period_ms < lim->min_period_ms) return false;
    uint64_t rows = 1, bytes = row_cost(node, instance, period_ms);
    for (int slot = 0; slot < UB_MAX_LOCAL_ENTITIES; slot++) {
        if (!(ub_node_slot_entity(node, slot) >= 0)) continue;
        for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) {
            const ub_ps_row_t *row = &(*ub_node_svc_pubsub_table(node, slot)).rows[r];
            if (row == replacing || row->kind == UB_PS_FREE || memcmp(row->owner, requester, UB_ENTITY_ID_LEN) != 0)
                continue;
            rows++;
            bytes += row_cost(node, row->instance, row->period_ms);
        }
    }
    return rows <= lim->max_rows && bytes <= lim->max_bytes_per_s;
}

/* A policed requester's lease (an administrator's too): never "no lease", never longer than its max_lease_ms. */
static uint32_t granted_lease(ub_node_t *node, const sender_t *s, uint32_t lease_ms) {
    if (!s->policed) return lease_ms;
    uint32_t max = ub_policy_limits_for(ub_node_policy(node), s->admin)->max_lease_ms;
    if (lease_ms != 0 && lease_ms <= max) return lease_ms;
    ub_node_svc_counters(node)->leases_clamped++;
    return max;
}

/*
 * The full-table rule (docs/pubsub.md): a full table never locks out an administrator. Its request takes
 * the row of a non-administrator (remote owner, not an administrator) whose lease ends first; rows created
 * locally and rows of administrators are never taken. Only under a policy: without one, nobody is told apart.
 */
static ub_ps_row_t *evict_for_admin(ub_node_t *node, ub_pubsub_table_t *t, const sender_t *s) {
    if (!s->policed || !s->admin) return NULL;
    ub_ps_row_t *victim = NULL;
    for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) {
        ub_ps_row_t *row = &t->rows[r];
        if (row->kind == UB_PS_FREE || ub_entity_id_is_zero(row->owner) || ub_policy_is_admin(ub_node_policy(node), row->owner))
            continue;
        uint64_t end = row->lease_until_ms != 0 ? row->lease_until_ms : UINT64_MAX;
        uint64_t best = victim == NULL ? 0 : victim->lease_until_ms != 0 ? victim->lease_until_ms : UINT64_MAX;
        if (victim == NULL || end < best) victim = row;
    }
    if (victim == NULL) return NULL;
    victim->kind = UB_PS_FREE; /* its owner's next renewal finds no row and asks again */
    ub_node_svc_counters(node)->rows_evicted++;
    return victim;
}

static ub_ps_row_t *new_row_for(ub_node_t *node, ub_pubsub_table_t *t, const sender_t *s, ub_ps_kind_t kind,
                                uint32_t instance, const uint8_t peer[UB_ENTITY_ID_LEN]) {
    ub_ps_row_t *row = new_row(t, kind, instance, peer);
    if (row == NULL && evict_for_admin(node, t, s) != NULL) row = new_row(t, kind, instance, peer);
    return row;
}

static void take_ownership(ub_ps_row_t *row, const ub_frame_header_t *h, uint32_t request_id, uint32_t lease_ms,
                           uint64_t now_ms) {
    memcpy(row->owner, h->src_id, UB_ENTITY_ID_LEN);
    row->owner_request_id = request_id;
    row->lease_until_ms = lease_ms != 0 ? now_ms + lease_ms : 0;
    row->handed_over = 0;
}

/* What an existing row means to a new request from `h->src_id`. */
typedef enum claim {
    CLAIM_NEW,   /* no row yet */
    CLAIM_LOCAL, /* created through the local API: never changed by a remote request */
    CLAIM_MINE,  /* owned by the requester: a renewal, or a new activation of the same owner */
    CLAIM_FREE,  /* owned by someone whose lease lapsed (a handed-over row): the requester may adopt it */
    CLAIM_TAKEN  /* owned by someone else who still renews it */
} claim_t;

static claim_t claim_of(const ub_ps_row_t *row, const ub_frame_header_t *h, uint64_t now_ms) {
    if (row == NULL) return CLAIM_NEW;
    if (ub_entity_id_is_zero(row->owner)) return CLAIM_LOCAL;
    if (memcmp(row->owner, h->src_id, UB_ENTITY_ID_LEN) == 0) return CLAIM_MINE;
    return owner_live(row, now_ms) ? CLAIM_TAKEN : CLAIM_FREE;
}

static bool on_pub_request(ub_node_t *node, int slot, const sender_t *s, const request_t *req, uint64_t now_ms) {
    const ub_frame_header_t *h = s->h;
    /* Data for anyone but the requester itself is the administrator's business (exclusive rights). */
    if (!s->admin && !is_self(req->peer, h)) return refuse(node, slot, h, req->id, now_ms);
    int idx = requested_instance(node, h, true);
    if (idx >= 0 && !may_read(node, slot, s, (uint32_t)idx)) return refuse(node, slot, h, req->id, now_ms);
    if (idx >= 0 && req->period_ms == 0) idx = -UB_NACK_INVALID;
    if (idx < 0) {
        reply(node, slot, h, req->id, true, (uint8_t)-idx, now_ms);
        return true;
    }
    if (exclusive_refuses(node, s, now_ms)) return other_admin(node, slot, h, req->id, now_ms);
    ub_pubsub_table_t *t = table_of(node, slot);
    int r = find_row(t, UB_PS_PUBLICATION, (uint32_t)idx, req->peer, false);
    ub_ps_row_t *existing = r >= 0 ? &t->rows[r] : NULL;
    claim_t claim = claim_of(existing, h, now_ms);
    /* Two administrators for one flow: the one who keeps the row keeps it, at its rate; the other is told. A
     * non-administrator asking for data to itself is not administering: the data already flows to it. */
    if (claim == CLAIM_TAKEN && s->admin) return other_admin(node, slot, h, req->id, now_ms);
    /* A remote request never changes a row created locally; a non-administrator changes only its own rows.
     * Either way the data already flows to the requester, so it gets its ACK. */
    bool keep = claim == CLAIM_LOCAL || (!s->admin && claim != CLAIM_MINE && claim != CLAIM_NEW);
    if (!keep && s->policed && !within_limits(node, h->src_id, s->admin, (uint32_t)idx, req->period_ms, existing)) {
        ub_node_svc_counters(node)->requests_limited++;
        reply(node, slot, h, req->id, true, UB_NACK_LIMIT, now_ms);
        return true;
    }
    ub_ps_row_t *row = existing != NULL ? existing : new_row_for(node, t, s, UB_PS_PUBLICATION, (uint32_t)idx, req->peer);
    if (row == NULL) {
        reply(node, slot, h, req->id, true, UB_NACK_TABLE_FULL, now_ms);
        return true;
    }
    if (!keep) {
        /* A new row, a changed rate or a new owner starts a fresh schedule now. */
        if (existing == NULL || row->period_ms != req->period_ms) {
            row->period_ms = req->period_ms;
            row->next_due_ms = now_ms;
        }
        if (memcmp(row->owner, h->src_id, UB_ENTITY_ID_LEN) != 0 || row->owner_request_id != req->id)
            row->reported_flowing = 0;
        take_ownership(row, h, req->id, granted_lease(node, s, req->lease_ms), now_ms);
        if (row->frames > 0) row->reported_flowing = 1;
    }
    reply(node, slot, h, req->id, false, row->frames > 0 ? UB_ACK_FLOWING : 0, now_ms);
    return true;
}

/* A subscription reports FLOWING only for data its source agreed to send: data arriving while the source
 * refuses this row's requests belongs to someone else's flow. */
static bool subscription_flowing(const ub_ps_row_t *row) {
    return row->state == UB_SUB_RECEIVING && row->source_acked && row->source_nack == 0;
}

static bool on_sub_request(ub_node_t *node, int slot, const sender_t *s, const request_t *req, uint64_t now_ms) {
    const ub_frame_header_t *h = s->h;
    /* Making another entity subscribe is the administration table's job alone. */
    if (!s->admin) return refuse(node, slot, h, req->id, now_ms);
    int idx = requested_instance(node, h, true);
    if (idx >= 0 && (req->period_ms == 0 || memcmp(req->peer, self_id(node, slot), UB_ENTITY_ID_LEN) == 0))
        idx = -UB_NACK_INVALID;
    if (idx < 0) {
        reply(node, slot, h, req->id, true, (uint8_t)-idx, now_ms);
        return true;
    }
    if (exclusive_refuses(node, s, now_ms)) return other_admin(node, slot, h, req->id, now_ms);
    ub_pubsub_table_t *t = table_of(node, slot);
    int r = find_row(t, UB_PS_SUBSCRIPTION, (uint32_t)idx, req->peer, true);
    ub_ps_row_t *existing = r >= 0 ? &t->rows[r] : NULL;
    bool stopping = existing != NULL && existing->state == UB_SUB_STOPPING;
    claim_t claim = stopping ? CLAIM_FREE : claim_of(existing, h, now_ms);
    if (claim == CLAIM_TAKEN) return other_admin(node, slot, h, req->id, now_ms);
    if (claim == CLAIM_LOCAL) {
        /* The destination subscribes by itself already: acknowledged, never converted into a lease. */
        reply(node, slot, h, req->id, false, subscription_flowing(existing) ? UB_ACK_FLOWING : 0, now_ms);
        return true;
    }
    if (s->policed && !within_limits(node, h->src_id, s->admin, (uint32_t)idx, req->period_ms, existing)) {
        ub_node_svc_counters(node)->requests_limited++;
        reply(node, slot, h, req->id, true, UB_NACK_LIMIT, now_ms);
        return true;
    }
    ub_ps_row_t *row = existing != NULL ? existing : new_row_for(node, t, s, UB_PS_SUBSCRIPTION, (uint32_t)idx, req->peer);
    if (row == NULL) {
        reply(node, slot, h, req->id, true, UB_NACK_TABLE_FULL, now_ms);
        return true;
    }
    bool activation = claim != CLAIM_MINE || row->owner_request_id != req->id;
    if (existing == NULL) row->request_id = ub_node_svc_new_request_id(node);
    if (existing == NULL || stopping || row->period_ms != req->period_ms) {
        row->period_ms = req->period_ms;
        start_requesting(row, now_ms);
    } else if (activation && row->source_nack != 0) {
        row->next_due_ms = now_ms; /* a new activation after a refusal: ask the source again now */
    }
    if (activation) {
        /* The source's answers so far belonged to an earlier activation. */
        row->reported_flowing = 0;
        row->source_nack = 0;
        if (existing == NULL || stopping) row->source_acked = 0;
    }
    take_ownership(row, h, req->id, granted_lease(node, s, req->lease_ms), now_ms);
    if (row->source_nack != 0) {
        /* A renewal while the source refuses: the refusal is the row's status, not an ACK. */
        ub_node_svc_counters(node)->nacks_relayed++;
        (void)ub_node_svc_send_reply(node, slot, true, h->dir_id, h->src_id, req->id, h->admin, row->source_nack,
                                 UB_NACK_RELAYED, now_ms);
        return true;
    }
    bool flowing = subscription_flowing(row);
    if (flowing) row->reported_flowing = 1;
    reply(node, slot, h, req->id, false, flowing ? UB_ACK_FLOWING : 0, now_ms);
    return true;
}

static bool on_stop(ub_node_t *node, int slot, const sender_t *s, uint32_t request_id, const uint8_t *peer,
                    uint64_t now_ms) {
    const ub_frame_header_t *h = s->h;
    bool pub = h->admin == UB_ADMIN_PUB_STOP;
    /* Without exclusive rights one may only stop data sent to oneself. */
    if (!s->admin && (!pub || !is_self(peer, h))) return refuse(node, slot, h, request_id, now_ms);
    int idx = ub_catalogue_find(ub_node_catalogue(node), h->dir_id);
    if (idx >= 0) {
        ub_pubsub_table_t *t = table_of(node, slot);
        int r = find_row(t, pub ? UB_PS_PUBLICATION : UB_PS_SUBSCRIPTION, (uint32_t)idx, peer, false);
        if (r >= 0) {
            ub_ps_row_t *row = &t->rows[r];
            claim_t claim = claim_of(row, h, now_ms);
            /* ... and only a row it owns, bound by the request id that created it: never a local row. */
            if (!s->admin && !(claim == CLAIM_MINE && row->owner_request_id == request_id))
                return refuse(node, slot, h, request_id, now_ms);
            /* An administrator stops its own rows, local ones, and rows nobody keeps any more; a row another
             * owner still renews is that owner's flow (two administrators): the STOP is acknowledged, since
             * the stopper's own row is gone, and the flow goes on. */
            if (claim != CLAIM_TAKEN) {
                if (pub) row->kind = UB_PS_FREE;
                else start_stopping(row, now_ms);
            }
        }
    }
    /* Stops are idempotent: an absent row is already stopped. */
    reply(node, slot, h, request_id, false, 0, now_ms);
    return true;
}

static void report_flowing(ub_node_t *node, int slot, ub_ps_row_t *row, uint8_t code, uint64_t now_ms) {
    if (ub_entity_id_is_zero(row->owner) || row->reported_flowing || !owner_live(row, now_ms)) return;
    row->reported_flowing = 1;
    (void)ub_node_svc_send_reply(node, slot, false, ub_node_catalogue(node)->instances[row->instance].id, row->owner,
                             row->owner_request_id, code, UB_ACK_FLOWING, 0, now_ms);
}

/* A reply to one of this entity's own subscription requests: bound to the row by the request id, the
 * source that was asked and the content. Returns false when it answers no row. */
static bool on_reply_to_subscription(ub_node_t *node, int slot, const ub_frame_header_t *h, uint32_t request_id,
                                     uint8_t code, bool nack, uint8_t detail, uint64_t now_ms) {
    ub_pubsub_table_t *t = table_of(node, slot);
    for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) {
        ub_ps_row_t *row = &t->rows[r];
        if (row->kind != UB_PS_SUBSCRIPTION || row->request_id != request_id ||
            memcmp(row->peer, h->src_id, UB_ENTITY_ID_LEN) != 0 ||
            memcmp(ub_node_catalogue(node)->instances[row->instance].id, h->dir_id, UB_DIR_ID_LEN) != 0)
            continue;
        if (code == UB_ADMIN_PUB_STOP && row->state == UB_SUB_STOPPING) {
            row->kind = UB_PS_FREE;
        } else if (code == UB_ADMIN_PUB_REQUEST && row->state != UB_SUB_STOPPING) {
            row->acked = nack ? 0 : 1;
            if (nack) {
                /* No silent status: the administrator who set this row up learns the source's refusal, with
                 * its reason, through the destination (its own row would otherwise say acknowledged). Only
                 * while it renews: an administrator gone quiet is not sent frames it cannot receive. */
                row->source_nack = detail;
                row->source_acked = 0;
                if (third_party(row) && owner_live(row, now_ms)) {
                    ub_node_svc_counters(node)->nacks_relayed++;
                    (void)ub_node_svc_send_reply(node, slot, true, h->dir_id, row->owner, row->owner_request_id,
                                             UB_ADMIN_SUB_REQUEST, detail, UB_NACK_RELAYED, now_ms);
                }
            } else {
                row->source_nack = 0;
                row->source_acked = 1;
                keeper_alive(row, now_ms);
                if (row->state == UB_SUB_RECEIVING) report_flowing(node, slot, row, UB_ADMIN_SUB_REQUEST, now_ms);
            }
            if (nack || row->state == UB_SUB_RECEIVING) {
                /* Renewal done (or refused, which will not change soon): next one at the renewal pace. */
                row->next_due_ms = now_ms + ub_node_options(node)->timing.renew_ms;
            } else {
                /* The source publishes now: give its data one timeout to arrive before asking again. */
                row->next_due_ms = now_ms + ub_pubsub_data_timeout_ms(&ub_node_options(node)->timing, row->period_ms);
            }
        }
        return true;
    }
    return false;
}

/* A publish/subscribe request, STOP or reply reached local slot `rx->slot` (over a link: the policy judges it). */
static bool pubsub_on_frame(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx,
                            const ub_frame_header_t *h, const uint8_t *payload, uint64_t now_ms, ub_drop_reason_t *drop) {
    (void)svc;
    int slot = rx->slot;
    bool from_link = rx->link_id >= 0;
    uint16_t len = h->payload_size;
    sender_t s = {h, ub_node_policy(node) != NULL && from_link, true};
    if (from_link) s.admin = ub_node_may_administer(node, ub_node_slot_entity(node, slot), h->src_id, rx->secured);
    *drop = UB_DROP_BAD_PAYLOAD;
    switch (h->admin) {
    case UB_ADMIN_PUB_REQUEST:
    case UB_ADMIN_SUB_REQUEST: {
        if (len < UB_PL_REQUEST_LEN) return false;
        request_t req = {ub_get_u32le(payload + UB_PL_REQUEST_ID), ub_get_u32le(payload + UB_PL_REQUEST_PERIOD),
                         ub_get_u32le(payload + UB_PL_REQUEST_LEASE), payload + UB_PL_REQUEST_PEER};
        *drop = UB_DROP_NOT_AUTHORIZED;
        return h->admin == UB_ADMIN_PUB_REQUEST ? on_pub_request(node, slot, &s, &req, now_ms)
                                                : on_sub_request(node, slot, &s, &req, now_ms);
    }
    case UB_ADMIN_PUB_STOP:
    case UB_ADMIN_SUB_STOP:
        if (len < UB_PL_STOP_LEN) return false;
        *drop = UB_DROP_NOT_AUTHORIZED;
        return on_stop(node, slot, &s, ub_get_u32le(payload + UB_PL_STOP_ID), payload + UB_PL_STOP_PEER, now_ms);
    case UB_ADMIN_ACK:
    case UB_ADMIN_NACK: {
        if (len < UB_PL_REPLY_LEN) return false;
        uint32_t id = ub_get_u32le(payload + UB_PL_REPLY_ID);
        uint8_t code = ub_get_u8(payload + UB_PL_REPLY_CODE);
        uint8_t detail = ub_get_u8(payload + UB_PL_REPLY_DETAIL);
        uint8_t flags = ub_get_u8(payload + UB_PL_REPLY_FLAGS);
        bool nack = h->admin == UB_ADMIN_NACK;
        ub_admin_t *adm = ub_node_svc_pubsub_table(node, slot)->admin;
        if (adm != NULL && ub_priv_admin_on_reply(adm, h, id, code, nack, detail, flags, now_ms)) return true;
        /* Never applied to a row it is not bound to; counted, since it is either late or forged. */
        if (!on_reply_to_subscription(node, slot, h, id, code, nack, detail, now_ms)) ub_node_svc_counters(node)->replies_unmatched++;
        return true;
    }
    default:
        return false;
    }
}

/* Write policy (ub_policy.h): may DATA of `instance` from `src_id`, received over a link, be stored for
 * local slot `slot`? True without a policy. */
static bool pubsub_may_write(const ub_service_t *svc, const ub_node_t *node, int slot, uint32_t instance,
                             const uint8_t src_id[UB_ENTITY_ID_LEN]) {
    (void)svc;
    const ub_policy_t *pol = ub_node_policy(node);
    if (pol == NULL) return true;
    /* What the entity subscribed to (a row on its way out still admits the data under way) ... */
    if (find_row(&(*ub_node_svc_pubsub_table(node, slot)), UB_PS_SUBSCRIPTION, instance, src_id, true) >= 0) return true;
    /* ... what an administration table of this node set up to arrive at it ... */
    const uint8_t *self = self_id(node, slot);
    for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++) {
        const ub_admin_t *adm = ub_node_svc_pubsub_table(node, s)->admin;
        if ((ub_node_slot_entity(node, s) >= 0) && adm != NULL && ub_priv_admin_routes_to(adm, instance, src_id, self)) return true;
    }
    /* ... or what the policy's write rules name. */
    return ub_policy_rule_matches(pol, UB_POLICY_WRITE, self, src_id, instance_name(node, instance));
}

/* ---- data and time ----------------------------------------------------- */

void ub_priv_pubsub_set_admin(ub_node_t *node, int slot, ub_admin_t *adm) {
    table_of(node, slot)->admin = adm;
    _Static_assert(UB_MAX_LOCAL_ENTITIES <= 32, "admin_slots holds one bit per local slot");
    uint32_t mask = 0;
    for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++)
        if (table_of(node, s)->admin != NULL) mask |= 1u << s;
    for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++) table_of(node, s)->admin_slots = mask;
}

/* DATA of `instance` from `src_id` was unpacked for local slot `slot`: the subscription bookkeeping. */
static void pubsub_on_data(const ub_service_t *svc, ub_node_t *node, int slot, uint32_t instance,
                           const uint8_t src_id[UB_ENTITY_ID_LEN], uint64_t now_ms) {
    (void)svc;
    ub_pubsub_table_t *t = table_of(node, slot);
    /* Administration rows whose data this is (not stale). This runs for every delivered frame, and most
     * nodes host no administration table: the slots that have one are a mask in every table. */
    for (uint32_t bits = t->admin_slots; bits != 0; bits &= bits - 1) {
        int s = __builtin_ctz(bits);
        ub_admin_t *adm = table_of(node, s)->admin;
        if (adm != NULL && ub_node_slot_entity(node, s) >= 0)
            ub_priv_admin_on_data(adm, instance, src_id, self_id(node, slot), now_ms);
    }
    int r = find_row(t, UB_PS_SUBSCRIPTION, instance, src_id, false);
    if (r < 0) return;
    ub_ps_row_t *row = &t->rows[r];
    row->last_data_ms = now_ms;
    row->frames++;
    /* Data from a source that refuses this row's requests is someone else's flow: no sign of life for us. */
    if (row->source_nack == 0) keeper_alive(row, now_ms);
    if (row->state == UB_SUB_REQUESTING) {
        row->state = UB_SUB_RECEIVING;
        row->next_due_ms = now_ms + ub_node_options(node)->timing.renew_ms;
    }
    if (subscription_flowing(row)) report_flowing(node, slot, row, UB_ADMIN_SUB_REQUEST, now_ms);
}

static void send_pub_request(ub_node_t *node, int slot, const ub_ps_row_t *row, uint64_t now_ms) {
    const ub_instance_desc_t *inst = &ub_node_catalogue(node)->instances[row->instance];
    uint8_t payload[UB_PL_REQUEST_LEN];
    ub_put_u32le(payload + UB_PL_REQUEST_ID, row->request_id);
    ub_put_u32le(payload + UB_PL_REQUEST_PERIOD, row->period_ms);
    ub_put_u32le(payload + UB_PL_REQUEST_LEASE, ub_node_options(node)->timing.lease_ms);
    memcpy(payload + UB_PL_REQUEST_PEER, self_id(node, slot), UB_ENTITY_ID_LEN);
    (void)ub_node_svc_send_admin(node, slot, UB_ADMIN_PUB_REQUEST, inst->id, inst->type->fingerprint, row->peer, payload,
                             UB_PL_REQUEST_LEN, now_ms);
}

static void send_pub_stop(ub_node_t *node, int slot, const ub_ps_row_t *row, uint64_t now_ms) {
    const ub_instance_desc_t *inst = &ub_node_catalogue(node)->instances[row->instance];
    uint8_t payload[UB_PL_STOP_LEN];
    ub_put_u32le(payload + UB_PL_STOP_ID, row->request_id);
    memcpy(payload + UB_PL_STOP_PEER, self_id(node, slot), UB_ENTITY_ID_LEN);
    (void)ub_node_svc_send_admin(node, slot, UB_ADMIN_PUB_STOP, inst->id, inst->type->fingerprint, row->peer, payload,
                             UB_PL_STOP_LEN, now_ms);
}

/* ---- publication on update (ub_pubsub_set_on_update) --------------------- */

static const ub_binding_t *binding_of(const ub_node_t *node, uint32_t instance) {
    return ub_node_svc_binding_row(node, instance);
}

static bool on_update(const ub_node_t *node, uint32_t instance) {
    const ub_binding_t *b = binding_of(node, instance);
    return b != NULL && b->on_update;
}

int ub_pubsub_set_on_update(ub_node_t *node, uint32_t instance, bool on) {
    if (node == NULL) return UB_ERR_INVAL;
    ub_binding_t *b = (ub_binding_t *)binding_of(node, instance);
    void *table_storage = b == NULL ? ub_node_binding(node, instance) : NULL;
    if (table_storage != NULL) { /* bound by the bind table: an explicit binding carries the flag */
        int rc = ub_node_bind(node, instance, table_storage);
        if (rc < 0) return rc;
        b = (ub_binding_t *)binding_of(node, instance);
    }
    if (b == NULL) return UB_ERR_NOTFOUND;
    b->on_update = on ? 1u : 0u;
    return UB_OK;
}

/* Sends a waiting update if the row's turn has come: half a period early at most (jitter), and the
 * turn advances by one period from the previous one (no drift) but never lags now by more than half a
 * period (no catch-up burst after a pause of the source). */
static bool send_update(ub_node_t *node, int slot, ub_ps_row_t *row, uint64_t now_ms) {
    uint64_t half = row->period_ms / 2u;
    if (!row->update_pending || now_ms + half < row->next_due_ms) return false;
    row->update_pending = 0;
    bool sent = ub_node_svc_send_data(node, slot, row->instance, row->peer, now_ms) >= 0;
    if (sent) {
        row->frames++;
        keeper_alive(row, now_ms);
        report_flowing(node, slot, row, UB_ADMIN_PUB_REQUEST, now_ms);
    }
    row->next_due_ms += row->period_ms;
    if (row->next_due_ms + half < now_ms + row->period_ms) row->next_due_ms = now_ms + row->period_ms - half;
    return sent;
}

int ub_pubsub_updated(ub_node_t *node, int entity, uint32_t instance, uint64_t now_ms) {
    if (node == NULL) return UB_ERR_INVAL;
    int slot = ub_node_entity_slot(node, entity);
    if (slot < 0 || !on_update(node, instance)) return UB_ERR_INVAL;
    ub_pubsub_table_t *t = table_of(node, slot);
    int sent = 0;
    for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) {
        ub_ps_row_t *row = &t->rows[r];
        if (row->kind != UB_PS_PUBLICATION || row->instance != instance) continue;
        row->update_pending = 1;
        sent += send_update(node, slot, row, now_ms);
    }
    return sent;
}

/* The keeper of a publication is its destination: reachable while the node has a route to it (with automatic
 * routes the route goes when the destination does; a manual mask never tells). */
static bool route_to(const ub_node_t *node, int slot, const uint8_t id[UB_ENTITY_ID_LEN]) {
    int e = ub_node_find_entity(node, id);
    return e >= 0 && (ub_node_entity_slot(node, e) >= 0 || ub_node_slot_mask(node, slot, e) != 0);
}

static void tick_publication(ub_node_t *node, int slot, ub_ps_row_t *row, uint64_t now_ms) {
    if (row->lease_until_ms != 0 && now_ms >= row->lease_until_ms) {
        /* Asked every tick once handed over, so that a row published on update, which may send rarely,
         * lives on its route and not on its traffic. */
        if (third_party(row) && route_to(node, slot, row->peer)) keeper_alive(row, now_ms);
        if (lease_lapsed_reclaims(node, row, now_ms)) {
            row->kind = UB_PS_FREE;
            return;
        }
    }
    if (on_update(node, row->instance)) {
        (void)send_update(node, slot, row, now_ms);
        return;
    }
    if (now_ms < row->next_due_ms) return;
    if (ub_node_svc_send_data(node, slot, row->instance, row->peer, now_ms) >= 0) {
        row->frames++;
        keeper_alive(row, now_ms);
        report_flowing(node, slot, row, UB_ADMIN_PUB_REQUEST, now_ms);
    }
    /* Schedule from the previous due time (no drift); after a stall, resume from now (no burst). */
    row->next_due_ms += row->period_ms;
    if (row->next_due_ms <= now_ms) row->next_due_ms = now_ms + row->period_ms;
}

static void tick_subscription(ub_node_t *node, int slot, ub_ps_row_t *row, uint64_t now_ms) {
    const ub_pubsub_timing_t *timing = &ub_node_options(node)->timing;
    if (row->state != UB_SUB_STOPPING && row->lease_until_ms != 0 && now_ms >= row->lease_until_ms &&
        lease_lapsed_reclaims(node, row, now_ms))
        start_stopping(row, now_ms);
    if (row->state == UB_SUB_RECEIVING && now_ms - row->last_data_ms > ub_pubsub_data_timeout_ms(timing, row->period_ms))
        start_requesting(row, now_ms);
    if (now_ms < row->next_due_ms) return;
    switch (row->state) {
    case UB_SUB_REQUESTING:
    case UB_SUB_RECEIVING:
        /* Requests and renewals alike are repeated at the retry pace until acknowledged; the ACK
         * moves the next one out to the renewal pace (see on_reply_to_subscription). */
        send_pub_request(node, slot, row, now_ms);
        row->acked = 0;
        row->next_due_ms = now_ms + timing->retry_ms;
        break;
    default:
        if (row->stop_tries >= timing->stop_retries) {
            row->kind = UB_PS_FREE;
            break;
        }
        send_pub_stop(node, slot, row, now_ms);
        row->stop_tries++;
        row->next_due_ms = now_ms + timing->retry_ms;
        break;
    }
}

static void pubsub_tick_slot(ub_node_t *node, int slot, uint64_t now_ms) {
    ub_pubsub_table_t *t = table_of(node, slot);
    for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) {
        ub_ps_row_t *row = &t->rows[r];
        if (row->kind == UB_PS_PUBLICATION) tick_publication(node, slot, row, now_ms);
        else if (row->kind == UB_PS_SUBSCRIPTION) tick_subscription(node, slot, row, now_ms);
    }
}

static int pubsub_forget_slot(ub_node_t *node, int slot, const uint8_t id[UB_ENTITY_ID_LEN], uint64_t now_ms) {
    ub_pubsub_table_t *t = table_of(node, slot);
    int freed = 0;
    for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) {
        ub_ps_row_t *row = &t->rows[r];
        if (row->kind == UB_PS_FREE) continue;
        if (memcmp(row->peer, id, UB_ENTITY_ID_LEN) == 0) {
            /* Nothing left to send to, nor to ask: a STOP to an entity nobody can route to would only count
             * no_route until its retries ran out. */
            row->kind = UB_PS_FREE;
            freed++;
        } else if (memcmp(row->owner, id, UB_ENTITY_ID_LEN) == 0 && owner_live(row, now_ms)) {
            /* Its owner (an administrator) is gone: its lease ends now and the keeper decides (a flow outlives
             * its administrator). */
            row->lease_until_ms = now_ms != 0 ? now_ms : 1;
        }
    }
    return freed;
}

/* ---- the service ------------------------------------------------------------------------------------- */

/* Every local entity's table, then its administration table, slot by slot (the order before services). */
static void pubsub_tick(const ub_service_t *svc, ub_node_t *node, uint64_t now_ms) {
    (void)svc;
    for (int slot = 0; slot < UB_MAX_LOCAL_ENTITIES; slot++) {
        if (ub_node_slot_entity(node, slot) < 0) continue;
        pubsub_tick_slot(node, slot, now_ms);
        ub_admin_t *adm = table_of(node, slot)->admin;
        if (adm != NULL) ub_priv_admin_tick(adm, now_ms);
    }
}

static void earliest(uint64_t *best, uint64_t t) {
    if (t < *best) *best = t;
}

/* When a row's tick has work (ub_service.h `next_due`), mirroring tick_publication() / tick_subscription(). */
static void row_due(const ub_node_t *node, const ub_ps_row_t *row, uint64_t now_ms, uint64_t *best) {
    if (row->kind == UB_PS_PUBLICATION) {
        /* Past its lease a handed-over row is asked every tick (its keeper's route): poll it as before. */
        if (row->lease_until_ms != 0) earliest(best, now_ms >= row->lease_until_ms ? now_ms + 1u : row->lease_until_ms);
        if (on_update(node, row->instance)) {
            if (row->update_pending) earliest(best, row->next_due_ms > row->period_ms / 2u ? row->next_due_ms - row->period_ms / 2u : 0);
            return;
        }
        earliest(best, row->next_due_ms);
    } else if (row->kind == UB_PS_SUBSCRIPTION) {
        const ub_pubsub_timing_t *timing = &ub_node_options(node)->timing;
        if (row->state != UB_SUB_STOPPING && row->lease_until_ms != 0) earliest(best, row->lease_until_ms);
        if (row->state == UB_SUB_RECEIVING)
            earliest(best, row->last_data_ms + ub_pubsub_data_timeout_ms(timing, row->period_ms) + 1u);
        earliest(best, row->next_due_ms);
    }
}

static bool pubsub_next_due(const ub_service_t *svc, const ub_node_t *node, uint64_t now_ms, uint64_t *due_ms) {
    (void)svc;
    uint64_t best = UINT64_MAX;
    for (int slot = 0; slot < UB_MAX_LOCAL_ENTITIES; slot++) {
        if (ub_node_slot_entity(node, slot) < 0) continue;
        const ub_pubsub_table_t *t = ub_node_svc_pubsub_table(node, slot);
        for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) row_due(node, &t->rows[r], now_ms, &best);
        /* Administration tables keep their timers inside ub_priv_admin_tick(): polled every millisecond. */
        if (t->admin != NULL) earliest(&best, now_ms + 1u);
    }
    *due_ms = best < now_ms ? now_ms : best;
    return best != UINT64_MAX;
}

/* The tables apply their own rules (docs/pubsub.md): rows with nobody left to talk to go at once, rows the
 * entity merely administered live on under their keeper; the node counts. */
static void pubsub_forget_entity(const ub_service_t *svc, ub_node_t *node, int entity, const uint8_t id[UB_ENTITY_ID_LEN],
                                 uint64_t now_ms) {
    (void)svc;
    (void)entity;
    ub_node_counters_t *c = ub_node_svc_counters(node);
    for (int slot = 0; slot < UB_MAX_LOCAL_ENTITIES; slot++) {
        if (ub_node_slot_entity(node, slot) < 0) continue;
        c->rows_stopped += (uint64_t)pubsub_forget_slot(node, slot, id, now_ms);
        ub_admin_t *adm = table_of(node, slot)->admin;
        if (adm != NULL) c->admin_rows_stopped += (uint64_t)ub_priv_admin_forget(adm, id, now_ms);
    }
}

/* ACK and NACK as codes: the replies no other service claims (docs/pubsub.md: bound to a row, else counted
 * `replies_unmatched`). */
static const uint8_t pubsub_codes[] = {UB_ADMIN_PUB_REQUEST, UB_ADMIN_SUB_REQUEST, UB_ADMIN_PUB_STOP,
                                       UB_ADMIN_SUB_STOP,    UB_ADMIN_ACK,         UB_ADMIN_NACK};

const ub_service_t ub_priv_pubsub_service = {
    .name = "pubsub",
    .codes = pubsub_codes,
    .n_codes = sizeof pubsub_codes,
    .order = UB_SVC_ORDER_PUBSUB,
    .on_frame = pubsub_on_frame,
    .tick = pubsub_tick,
    .next_due = pubsub_next_due,
    .forget_entity = pubsub_forget_entity,
    .may_write = pubsub_may_write,
    .on_data = pubsub_on_data,
};
