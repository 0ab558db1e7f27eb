#include "ub/ub_pubsub.h"

#include <string.h>

#include "ub/ub_node.h"
#include "ub/ub_wire.h"
#include "ub_router_private.h"

void ub_priv_timing_defaults(ub_pubsub_timing_t *t) {
    if (t->retry_ms == 0) t->retry_ms = UB_PS_DEFAULT_RETRY_MS;
    if (t->renew_ms == 0) t->renew_ms = UB_PS_DEFAULT_RENEW_MS;
    if (t->lease_ms == 0) t->lease_ms = 3u * t->renew_ms;
    if (t->timeout_min_ms == 0) t->timeout_min_ms = UB_PS_DEFAULT_TIMEOUT_MIN_MS;
    if (t->stop_retries == 0) t->stop_retries = UB_PS_DEFAULT_STOP_RETRIES;
}

uint64_t ub_pubsub_data_timeout_ms(const ub_pubsub_timing_t *timing, uint32_t period_ms) {
    uint64_t three_periods = 3u * (uint64_t)period_ms;
    return three_periods > timing->timeout_min_ms ? three_periods : timing->timeout_min_ms;
}

static ub_pubsub_table_t *table_of(ub_node_t *node, int slot) { return &node->locals[slot].ps; }

static const uint8_t *self_id(const ub_node_t *node, int slot) {
    return node->entities[node->locals[slot].entity].id;
}

/* Live = not free and not on its way out; stopping rows are found only when `with_stopping`. */
static int find_row(const ub_pubsub_table_t *t, ub_ps_kind_t kind, uint32_t instance,
                    const uint8_t peer[UB_ENTITY_ID_LEN], bool with_stopping) {
    for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) {
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
        memset(row, 0, sizeof *row);
        row->kind = (uint8_t)kind;
        row->instance = instance;
        memcpy(row->peer, peer, UB_ENTITY_ID_LEN);
        return row;
    }
    return NULL;
}

static int row_index(const ub_pubsub_table_t *t, const ub_ps_row_t *row) { return (int)(row - t->rows); }

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
    if (node == NULL || peer == NULL || period_ms == 0 || instance >= node->cat->n_instances) return UB_ERR_INVAL;
    int slot = ub_priv_local_slot(node, entity);
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
    if (r < 0) row->request_id = node->next_request_id++;
    memset(row->owner, 0, UB_ENTITY_ID_LEN);
    row->lease_until_ms = 0;
    row->period_ms = period_ms;
    start_requesting(row, now_ms);
    return row_index(t, row);
}

int ub_pubsub_stop(ub_node_t *node, int entity, int row, uint64_t now_ms) {
    if (node == NULL || row < 0 || row >= UB_MAX_PUBSUB_ROWS) return UB_ERR_INVAL;
    int slot = ub_priv_local_slot(node, entity);
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
    int slot = ub_priv_local_slot(node, entity);
    if (slot < 0) return UB_ERR_INVAL;
    return find_row(&node->locals[slot].ps, kind, instance, peer, false);
}

const ub_ps_row_t *ub_pubsub_row(const ub_node_t *node, int entity, int row) {
    if (node == NULL || row < 0 || row >= UB_MAX_PUBSUB_ROWS) return NULL;
    int slot = ub_priv_local_slot(node, entity);
    return slot < 0 ? NULL : &node->locals[slot].ps.rows[row];
}

int ub_pubsub_count(const ub_node_t *node, int entity, ub_ps_kind_t kind) {
    if (node == NULL) return UB_ERR_INVAL;
    int slot = ub_priv_local_slot(node, entity);
    if (slot < 0) return UB_ERR_INVAL;
    int n = 0;
    for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) n += node->locals[slot].ps.rows[r].kind == kind;
    return n;
}

/* ---- requests from other entities --------------------------------------- */

typedef struct request {
    uint32_t id;
    uint32_t period_ms;
    uint32_t lease_ms;
    const uint8_t *peer;
} request_t;

static void reply(ub_node_t *node, int slot, const ub_frame_header_t *h, uint32_t request_id, bool nack,
                  uint8_t detail, uint64_t now_ms) {
    (void)ub_priv_send_reply(node, slot, nack, h->dir_id, h->src_id, request_id, h->admin, detail, now_ms);
}

/* Resolves and checks the content of a request; returns the instance or -(nack reason). */
static int requested_instance(const ub_node_t *node, const ub_frame_header_t *h, bool needs_binding) {
    int idx = ub_catalogue_find(node->cat, h->dir_id);
    if (idx < 0) return -UB_NACK_UNKNOWN_CONTENT;
    if (node->cat->instances[idx].type->fingerprint != h->fingerprint) return -UB_NACK_LAYOUT;
    if (needs_binding && ub_node_binding(node, (uint32_t)idx) == NULL) return -UB_NACK_UNBOUND;
    return idx;
}

static void take_ownership(ub_ps_row_t *row, const ub_frame_header_t *h, const request_t *req, uint64_t now_ms) {
    memcpy(row->owner, h->src_id, UB_ENTITY_ID_LEN);
    row->owner_request_id = req->id;
    row->lease_until_ms = req->lease_ms != 0 ? now_ms + req->lease_ms : 0;
}

static void on_pub_request(ub_node_t *node, int slot, const ub_frame_header_t *h, const request_t *req,
                           uint64_t now_ms) {
    int idx = requested_instance(node, h, true);
    if (idx >= 0 && req->period_ms == 0) idx = -UB_NACK_INVALID;
    if (idx < 0) {
        reply(node, slot, h, req->id, true, (uint8_t)-idx, now_ms);
        return;
    }
    ub_pubsub_table_t *t = table_of(node, slot);
    int r = find_row(t, UB_PS_PUBLICATION, (uint32_t)idx, req->peer, false);
    ub_ps_row_t *row = r >= 0 ? &t->rows[r] : new_row(t, UB_PS_PUBLICATION, (uint32_t)idx, req->peer);
    if (row == NULL) {
        reply(node, slot, h, req->id, true, UB_NACK_TABLE_FULL, now_ms);
        return;
    }
    bool locally_owned = r >= 0 && ub_priv_id_is_zero(row->owner);
    if (!locally_owned) {
        /* A new row, a changed rate or a new owner starts a fresh schedule now. */
        if (r < 0 || row->period_ms != req->period_ms) {
            row->period_ms = req->period_ms;
            row->next_due_ms = now_ms;
        }
        if (memcmp(row->owner, h->src_id, UB_ENTITY_ID_LEN) != 0 || row->owner_request_id != req->id)
            row->reported_flowing = 0;
        take_ownership(row, h, req, now_ms);
    }
    if (row->frames > 0 && !locally_owned) row->reported_flowing = 1;
    reply(node, slot, h, req->id, false, row->frames > 0 ? UB_ACK_FLOWING : 0, now_ms);
}

static void on_sub_request(ub_node_t *node, int slot, const ub_frame_header_t *h, const request_t *req,
                           uint64_t now_ms) {
    int idx = requested_instance(node, h, true);
    if (idx >= 0 && (req->period_ms == 0 || memcmp(req->peer, self_id(node, slot), UB_ENTITY_ID_LEN) == 0))
        idx = -UB_NACK_INVALID;
    if (idx < 0) {
        reply(node, slot, h, req->id, true, (uint8_t)-idx, now_ms);
        return;
    }
    ub_pubsub_table_t *t = table_of(node, slot);
    int r = find_row(t, UB_PS_SUBSCRIPTION, (uint32_t)idx, req->peer, true);
    ub_ps_row_t *row = r >= 0 ? &t->rows[r] : new_row(t, UB_PS_SUBSCRIPTION, (uint32_t)idx, req->peer);
    if (row == NULL) {
        reply(node, slot, h, req->id, true, UB_NACK_TABLE_FULL, now_ms);
        return;
    }
    if (r < 0) row->request_id = node->next_request_id++;
    if (r < 0 || row->state == UB_SUB_STOPPING || row->period_ms != req->period_ms) {
        row->period_ms = req->period_ms;
        start_requesting(row, now_ms);
    }
    if (memcmp(row->owner, h->src_id, UB_ENTITY_ID_LEN) != 0 || row->owner_request_id != req->id)
        row->reported_flowing = 0;
    take_ownership(row, h, req, now_ms);
    bool flowing = row->state == UB_SUB_RECEIVING;
    if (flowing) row->reported_flowing = 1;
    reply(node, slot, h, req->id, false, flowing ? UB_ACK_FLOWING : 0, now_ms);
}

static void on_stop(ub_node_t *node, int slot, const ub_frame_header_t *h, uint32_t request_id,
                    const uint8_t *peer, uint64_t now_ms) {
    int idx = ub_catalogue_find(node->cat, h->dir_id);
    if (idx >= 0) {
        ub_pubsub_table_t *t = table_of(node, slot);
        bool pub = h->admin == UB_ADMIN_PUB_STOP;
        int r = find_row(t, pub ? UB_PS_PUBLICATION : UB_PS_SUBSCRIPTION, (uint32_t)idx, peer, false);
        if (r >= 0 && pub) t->rows[r].kind = UB_PS_FREE;
        else if (r >= 0) start_stopping(&t->rows[r], now_ms);
    }
    /* Stops are idempotent: an absent row is already stopped. */
    reply(node, slot, h, request_id, false, 0, now_ms);
}

/* A reply to one of this entity's own subscription requests. */
static void on_reply_to_subscription(ub_node_t *node, int slot, uint32_t request_id, uint8_t code, bool nack,
                                     uint64_t now_ms) {
    ub_pubsub_table_t *t = table_of(node, slot);
    for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) {
        ub_ps_row_t *row = &t->rows[r];
        if (row->kind != UB_PS_SUBSCRIPTION || row->request_id != request_id) continue;
        if (code == UB_ADMIN_PUB_STOP && row->state == UB_SUB_STOPPING) {
            row->kind = UB_PS_FREE;
        } else if (code == UB_ADMIN_PUB_REQUEST && row->state != UB_SUB_STOPPING) {
            row->acked = nack ? 0 : 1;
            if (nack || row->state == UB_SUB_RECEIVING) {
                /* Renewal done (or refused, which will not change soon): next one at the renewal pace. */
                row->next_due_ms = now_ms + node->opt.timing.renew_ms;
            } else {
                /* The source publishes now: give its data one timeout to arrive before asking again. */
                row->next_due_ms = now_ms + ub_pubsub_data_timeout_ms(&node->opt.timing, row->period_ms);
            }
        }
        return;
    }
}

int ub_priv_pubsub_on_admin(ub_node_t *node, int slot, const ub_frame_header_t *h, const uint8_t *payload,
                            uint64_t now_ms) {
    uint16_t len = h->payload_size;
    switch (h->admin) {
    case UB_ADMIN_PUB_REQUEST:
    case UB_ADMIN_SUB_REQUEST: {
        if (len < UB_PL_REQUEST_LEN) return UB_ERR_TRUNCATED;
        request_t req = {ub_get_u32le(payload + UB_PL_REQUEST_ID), ub_get_u32le(payload + UB_PL_REQUEST_PERIOD),
                         ub_get_u32le(payload + UB_PL_REQUEST_LEASE), payload + UB_PL_REQUEST_PEER};
        if (h->admin == UB_ADMIN_PUB_REQUEST) on_pub_request(node, slot, h, &req, now_ms);
        else on_sub_request(node, slot, h, &req, now_ms);
        return UB_OK;
    }
    case UB_ADMIN_PUB_STOP:
    case UB_ADMIN_SUB_STOP:
        if (len < UB_PL_STOP_LEN) return UB_ERR_TRUNCATED;
        on_stop(node, slot, h, ub_get_u32le(payload + UB_PL_STOP_ID), payload + UB_PL_STOP_PEER, now_ms);
        return UB_OK;
    case UB_ADMIN_ACK:
    case UB_ADMIN_NACK: {
        if (len < UB_PL_REPLY_LEN) return UB_ERR_TRUNCATED;
        uint32_t id = ub_get_u32le(payload + UB_PL_REPLY_ID);
        uint8_t code = ub_get_u8(payload + UB_PL_REPLY_CODE);
        uint8_t detail = ub_get_u8(payload + UB_PL_REPLY_DETAIL);
        bool nack = h->admin == UB_ADMIN_NACK;
        ub_admin_t *adm = node->locals[slot].admin;
        if (adm != NULL && ub_priv_admin_on_reply(adm, id, code, nack, detail, now_ms)) return UB_OK;
        on_reply_to_subscription(node, slot, id, code, nack, now_ms);
        return UB_OK;
    }
    default:
        return UB_ERR_INVAL;
    }
}

/* ---- data and time ----------------------------------------------------- */

static void report_flowing(ub_node_t *node, int slot, ub_ps_row_t *row, uint8_t code, uint64_t now_ms) {
    if (ub_priv_id_is_zero(row->owner) || row->reported_flowing) return;
    row->reported_flowing = 1;
    (void)ub_priv_send_reply(node, slot, false, node->cat->instances[row->instance].id, row->owner,
                             row->owner_request_id, code, UB_ACK_FLOWING, now_ms);
}

void ub_priv_pubsub_on_data(ub_node_t *node, int slot, uint32_t instance, const uint8_t src_id[UB_ENTITY_ID_LEN],
                            uint64_t now_ms) {
    ub_pubsub_table_t *t = table_of(node, slot);
    int r = find_row(t, UB_PS_SUBSCRIPTION, instance, src_id, false);
    if (r < 0) return;
    ub_ps_row_t *row = &t->rows[r];
    row->last_data_ms = now_ms;
    row->frames++;
    if (row->state == UB_SUB_REQUESTING) {
        row->state = UB_SUB_RECEIVING;
        row->next_due_ms = now_ms + node->opt.timing.renew_ms;
        report_flowing(node, slot, row, UB_ADMIN_SUB_REQUEST, now_ms);
    }
}

static void send_pub_request(ub_node_t *node, int slot, const ub_ps_row_t *row, uint64_t now_ms) {
    const ub_instance_desc_t *inst = &node->cat->instances[row->instance];
    uint8_t payload[UB_PL_REQUEST_LEN];
    ub_put_u32le(payload + UB_PL_REQUEST_ID, row->request_id);
    ub_put_u32le(payload + UB_PL_REQUEST_PERIOD, row->period_ms);
    ub_put_u32le(payload + UB_PL_REQUEST_LEASE, node->opt.timing.lease_ms);
    memcpy(payload + UB_PL_REQUEST_PEER, self_id(node, slot), UB_ENTITY_ID_LEN);
    (void)ub_priv_send_admin(node, slot, UB_ADMIN_PUB_REQUEST, inst->id, inst->type->fingerprint, row->peer, payload,
                             UB_PL_REQUEST_LEN, now_ms);
}

static void send_pub_stop(ub_node_t *node, int slot, const ub_ps_row_t *row, uint64_t now_ms) {
    const ub_instance_desc_t *inst = &node->cat->instances[row->instance];
    uint8_t payload[UB_PL_STOP_LEN];
    ub_put_u32le(payload + UB_PL_STOP_ID, row->request_id);
    memcpy(payload + UB_PL_STOP_PEER, self_id(node, slot), UB_ENTITY_ID_LEN);
    (void)ub_priv_send_admin(node, slot, UB_ADMIN_PUB_STOP, inst->id, inst->type->fingerprint, row->peer, payload,
                             UB_PL_STOP_LEN, now_ms);
}

static void tick_publication(ub_node_t *node, int slot, ub_ps_row_t *row, uint64_t now_ms) {
    if (row->lease_until_ms != 0 && now_ms >= row->lease_until_ms) {
        row->kind = UB_PS_FREE;
        node->counters.leases_expired++;
        return;
    }
    if (now_ms < row->next_due_ms) return;
    if (ub_priv_send_data_from_slot(node, slot, row->instance, row->peer, now_ms) >= 0) {
        row->frames++;
        report_flowing(node, slot, row, UB_ADMIN_PUB_REQUEST, now_ms);
    }
    /* Schedule from the previous due time (no drift); after a stall, resume from now (no burst). */
    row->next_due_ms += row->period_ms;
    if (row->next_due_ms <= now_ms) row->next_due_ms = now_ms + row->period_ms;
}

static void tick_subscription(ub_node_t *node, int slot, ub_ps_row_t *row, uint64_t now_ms) {
    const ub_pubsub_timing_t *timing = &node->opt.timing;
    if (row->state != UB_SUB_STOPPING && row->lease_until_ms != 0 && now_ms >= row->lease_until_ms) {
        node->counters.leases_expired++;
        start_stopping(row, now_ms);
    }
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

void ub_priv_pubsub_tick(ub_node_t *node, int slot, uint64_t now_ms) {
    ub_pubsub_table_t *t = table_of(node, slot);
    for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) {
        ub_ps_row_t *row = &t->rows[r];
        if (row->kind == UB_PS_PUBLICATION) tick_publication(node, slot, row, now_ms);
        else if (row->kind == UB_PS_SUBSCRIPTION) tick_subscription(node, slot, row, now_ms);
    }
}
