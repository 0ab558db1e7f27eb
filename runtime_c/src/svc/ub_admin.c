/* The administration table (ub_admin.h, docs/pubsub.md): part of the publish/subscribe service, which
 * hands it replies and ticks it (svc/ub_svc_private.h). Public headers only. */
#include "ub/ub_admin.h"

#include <string.h>

#include "ub/ub_node.h"
#include "ub/ub_wire.h"
#include "svc/ub_svc_private.h"

static const char *const status_names[] = {
    [UB_ADMIN_INACTIVE] = "inactive",         [UB_ADMIN_PENDING] = "pending", [UB_ADMIN_ACKNOWLEDGED] = "acknowledged",
    [UB_ADMIN_ACTIVE] = "active",             [UB_ADMIN_FAILED] = "failed",   [UB_ADMIN_STOPPING] = "stopping",
    [UB_ADMIN_STALE] = "stale",
};

const char *ub_admin_status_name(ub_admin_status_t status) {
    if ((unsigned)status >= sizeof status_names / sizeof status_names[0]) return "?";
    return status_names[status];
}

static const char *const nack_names[] = {
    [UB_NACK_NONE] = "none",
    [UB_NACK_UNKNOWN_CONTENT] = "unknown_content",
    [UB_NACK_LAYOUT] = "layout",
    [UB_NACK_UNBOUND] = "unbound",
    [UB_NACK_TABLE_FULL] = "table_full",
    [UB_NACK_INVALID] = "invalid",
    [UB_NACK_NOT_AUTHORIZED] = "not_authorized",
    [UB_NACK_LIMIT] = "limit",
    [UB_NACK_UNSUPPORTED] = "unsupported",
    [UB_NACK_OTHER_ADMIN] = "other_admin",
    [UB_NACK_NO_SUCH_ROW] = "no_such_row",
    [UB_NACK_BAD_VALUE] = "bad_value",
};

const char *ub_nack_reason_name(ub_nack_reason_t reason) {
    if ((unsigned)reason >= sizeof nack_names / sizeof nack_names[0]) return "?";
    return nack_names[reason] != NULL ? nack_names[reason] : "?";
}

int ub_admin_init(ub_admin_t *adm, ub_node_t *node, int entity, const ub_admin_options_t *opt) {
    if (adm == NULL || node == NULL) return UB_ERR_INVAL;
    int slot = ub_node_entity_slot(node, entity);
    if (slot < 0) return UB_ERR_INVAL;
    memset(adm, 0, sizeof *adm);
    if (opt != NULL) adm->opt = *opt;
    if (adm->opt.retry_ms == 0) adm->opt.retry_ms = UB_PS_DEFAULT_RETRY_MS;
    if (adm->opt.renew_ms == 0) adm->opt.renew_ms = UB_PS_DEFAULT_RENEW_MS;
    if (adm->opt.lease_ms == 0) adm->opt.lease_ms = 3u * adm->opt.renew_ms;
    if (adm->opt.max_stop_retries == 0) adm->opt.max_stop_retries = UB_PS_DEFAULT_STOP_RETRIES;
    adm->node = node;
    adm->entity = entity;
    ub_priv_pubsub_set_admin(node, slot, adm);
    return UB_OK;
}

void ub_admin_detach(ub_admin_t *adm) {
    if (adm == NULL || adm->node == NULL) return;
    int slot = ub_node_entity_slot(adm->node, adm->entity);
    if (slot >= 0 && ub_node_svc_pubsub_table(adm->node, slot)->admin == adm) ub_priv_pubsub_set_admin(adm->node, slot, NULL);
    adm->node = NULL;
}

static ub_admin_row_t *row_at(const ub_admin_t *adm, int row) {
    if (adm == NULL || row < 0 || row >= UB_MAX_ADMIN_ROWS || !adm->rows[row].in_use) return NULL;
    return (ub_admin_row_t *)&adm->rows[row];
}

int ub_admin_add_row(ub_admin_t *adm, const ub_admin_row_spec_t *spec) {
    if (adm == NULL || adm->node == NULL || spec == NULL) return UB_ERR_INVAL;
    if (spec->instance >= ub_node_catalogue(adm->node)->n_instances || spec->period_ms == 0) return UB_ERR_INVAL;
    if (memcmp(spec->source, spec->destination, UB_ENTITY_ID_LEN) == 0) return UB_ERR_INVAL;
    if (spec->type != UB_ADMIN_ROW_PUBLICATION && spec->type != UB_ADMIN_ROW_SUBSCRIPTION) return UB_ERR_INVAL;
    /* One flow, one row: two rows of one table for the same flow would renew one target row in turns, each
     * with its own rate and request id, and each would read the other's status. */
    for (int r = 0; r < UB_MAX_ADMIN_ROWS; r++) {
        const ub_admin_row_spec_t *o = &adm->rows[r].info.spec;
        if (adm->rows[r].in_use && o->instance == spec->instance &&
            memcmp(o->source, spec->source, UB_ENTITY_ID_LEN) == 0 &&
            memcmp(o->destination, spec->destination, UB_ENTITY_ID_LEN) == 0)
            return UB_ERR_EXISTS;
    }
    for (int r = 0; r < UB_MAX_ADMIN_ROWS; r++) {
        if (adm->rows[r].in_use) continue;
        memset(&adm->rows[r], 0, sizeof adm->rows[r]);
        adm->rows[r].in_use = 1;
        adm->rows[r].info.spec = *spec;
        return r;
    }
    return UB_ERR_FULL;
}

static void enter(ub_admin_row_t *row, ub_admin_status_t status, uint64_t now_ms) {
    row->info.status = status;
    row->info.attempts = 0;
    row->next_send_ms = now_ms;
}

int ub_admin_set_active(ub_admin_t *adm, int row, bool active, uint64_t now_ms) {
    ub_admin_row_t *r = row_at(adm, row);
    if (r == NULL) return UB_ERR_NOTFOUND;
    ub_admin_status_t st = r->info.status;
    if (active && (!r->info.active_flag || st == UB_ADMIN_FAILED)) {
        /* A fresh request id, so late replies to an earlier activation are not mistaken for this one. */
        r->info.request_id = ub_node_svc_new_request_id(adm->node);
        r->info.nack_reason = UB_NACK_NONE;
        r->info.nack_relayed = false;
        r->info.acked_at_ms = 0;
        r->info.active_at_ms = 0;
        r->info.last_ack_ms = 0;
        r->info.last_data_ms = 0;
        enter(r, UB_ADMIN_PENDING, now_ms);
    } else if (!active && r->info.active_flag) {
        enter(r, st == UB_ADMIN_FAILED ? UB_ADMIN_INACTIVE : UB_ADMIN_STOPPING, now_ms);
    }
    r->info.active_flag = active;
    return UB_OK;
}

int ub_admin_remove_row(ub_admin_t *adm, int row) {
    ub_admin_row_t *r = row_at(adm, row);
    if (r == NULL) return UB_ERR_NOTFOUND;
    if (r->info.status != UB_ADMIN_INACTIVE && r->info.status != UB_ADMIN_FAILED && r->info.status != UB_ADMIN_STOPPING)
        return UB_ERR_INVAL;
    r->in_use = 0;
    return UB_OK;
}

int ub_admin_row_status(const ub_admin_t *adm, int row, ub_admin_row_info_t *out) {
    const ub_admin_row_t *r = row_at(adm, row);
    if (r == NULL || out == NULL) return UB_ERR_NOTFOUND;
    *out = r->info;
    return UB_OK;
}

/* Publication rows talk to the source, subscription rows to the destination. */
static const uint8_t *target_of(const ub_admin_row_spec_t *spec) {
    return spec->type == UB_ADMIN_ROW_PUBLICATION ? spec->source : spec->destination;
}

static const uint8_t *peer_of(const ub_admin_row_spec_t *spec) {
    return spec->type == UB_ADMIN_ROW_PUBLICATION ? spec->destination : spec->source;
}

static ub_admin_code_t request_code(const ub_admin_row_spec_t *spec) {
    return spec->type == UB_ADMIN_ROW_PUBLICATION ? UB_ADMIN_PUB_REQUEST : UB_ADMIN_SUB_REQUEST;
}

static ub_admin_code_t stop_code(const ub_admin_row_spec_t *spec) {
    return spec->type == UB_ADMIN_ROW_PUBLICATION ? UB_ADMIN_PUB_STOP : UB_ADMIN_SUB_STOP;
}

static void send_row(ub_admin_t *adm, const ub_admin_row_t *row, bool stop, uint64_t now_ms) {
    ub_node_t *node = adm->node;
    const ub_admin_row_spec_t *spec = &row->info.spec;
    const ub_instance_desc_t *inst = &ub_node_catalogue(node)->instances[spec->instance];
    uint8_t payload[UB_PL_REQUEST_LEN];
    uint16_t len;
    if (stop) {
        ub_put_u32le(payload + UB_PL_STOP_ID, row->info.request_id);
        memcpy(payload + UB_PL_STOP_PEER, peer_of(spec), UB_ENTITY_ID_LEN);
        len = UB_PL_STOP_LEN;
    } else {
        ub_put_u32le(payload + UB_PL_REQUEST_ID, row->info.request_id);
        ub_put_u32le(payload + UB_PL_REQUEST_PERIOD, spec->period_ms);
        ub_put_u32le(payload + UB_PL_REQUEST_LEASE, adm->opt.lease_ms);
        memcpy(payload + UB_PL_REQUEST_PEER, peer_of(spec), UB_ENTITY_ID_LEN);
        len = UB_PL_REQUEST_LEN;
    }
    int slot = ub_node_entity_slot(node, adm->entity);
    (void)ub_node_svc_send_admin(node, slot, stop ? stop_code(spec) : request_code(spec), inst->id,
                             inst->type->fingerprint, target_of(spec), payload, len, now_ms);
}

/* A reply belongs to a row only if its target sent it, about the row's content, with the row's request id:
 * a guessed or overheard id from anyone else does not move the row (docs/pubsub.md). */
static bool reply_is_for(const ub_admin_t *adm, const ub_admin_row_t *row, const ub_frame_header_t *h,
                         uint32_t request_id) {
    const ub_admin_row_spec_t *spec = &row->info.spec;
    return row->in_use && row->info.request_id == request_id &&
           memcmp(h->src_id, target_of(spec), UB_ENTITY_ID_LEN) == 0 &&
           memcmp(h->dir_id, ub_node_catalogue(adm->node)->instances[spec->instance].id, UB_DIR_ID_LEN) == 0;
}

/* The row's destination is an entity of this node: the table sees its data arrive (pubsub_on_data). */
static bool data_observable(const ub_admin_t *adm, const ub_admin_row_spec_t *spec) {
    int e = ub_node_find_entity(adm->node, spec->destination);
    return e >= 0 && ub_node_entity_slot(adm->node, e) >= 0;
}

/* An acknowledged row with an observable destination that got no data for UB_ADMIN_STALE_PERIODS periods + margin,
 * counted from its first ACK or its last data, whichever is later. */
static bool data_quiet(const ub_admin_t *adm, const ub_admin_row_t *row, uint64_t now_ms) {
    const ub_admin_row_info_t *info = &row->info;
    if (info->acked_at_ms == 0 || !data_observable(adm, &info->spec)) return false;
    uint64_t since = info->last_data_ms > info->acked_at_ms ? info->last_data_ms : info->acked_at_ms;
    uint64_t allowed = (uint64_t)UB_ADMIN_STALE_PERIODS * info->spec.period_ms + UB_ADMIN_STALE_MARGIN_MS;
    return now_ms > since && now_ms - since > allowed;
}

void ub_priv_admin_on_data(ub_admin_t *adm, uint32_t instance, const uint8_t src_id[UB_ENTITY_ID_LEN],
                           const uint8_t dest_id[UB_ENTITY_ID_LEN], uint64_t now_ms) {
    for (int r = 0; r < UB_MAX_ADMIN_ROWS; r++) {
        ub_admin_row_t *row = &adm->rows[r];
        const ub_admin_row_spec_t *spec = &row->info.spec;
        if (!row->in_use || spec->instance != instance || memcmp(spec->source, src_id, UB_ENTITY_ID_LEN) != 0 ||
            memcmp(spec->destination, dest_id, UB_ENTITY_ID_LEN) != 0)
            continue;
        row->info.last_data_ms = now_ms;
        if (row->info.status == UB_ADMIN_STALE) row->info.status = (ub_admin_status_t)row->acked_status;
    }
}

bool ub_priv_admin_on_reply(ub_admin_t *adm, const ub_frame_header_t *h, uint32_t request_id, uint8_t code, bool nack,
                            uint8_t detail, uint8_t flags, uint64_t now_ms) {
    for (int r = 0; r < UB_MAX_ADMIN_ROWS; r++) {
        ub_admin_row_t *row = &adm->rows[r];
        if (!reply_is_for(adm, row, h, request_id)) continue;
        ub_admin_row_info_t *info = &row->info;
        if (info->status == UB_ADMIN_STOPPING) {
            if (code == stop_code(&info->spec)) enter(row, UB_ADMIN_INACTIVE, now_ms);
            return true;
        }
        bool live = info->status == UB_ADMIN_PENDING || info->status == UB_ADMIN_ACKNOWLEDGED ||
                    info->status == UB_ADMIN_ACTIVE || info->status == UB_ADMIN_STALE;
        if (!live || code != request_code(&info->spec)) return true;
        if (nack) {
            info->nack_reason = (ub_nack_reason_t)detail;
            info->nack_relayed = (flags & UB_NACK_RELAYED) != 0;
            enter(row, UB_ADMIN_FAILED, now_ms);
            return true;
        }
        info->last_ack_ms = now_ms;
        if (info->acked_at_ms == 0) info->acked_at_ms = now_ms;
        row->acked_status = (detail & UB_ACK_FLOWING) ? UB_ADMIN_ACTIVE : UB_ADMIN_ACKNOWLEDGED;
        if (row->acked_status == UB_ADMIN_ACTIVE && info->active_at_ms == 0) info->active_at_ms = now_ms;
        /* The target's word does not make data arrive: a stale row stays stale until the data does. Where the
         * data cannot be seen here, a subscription row's destination says it: no FLOWING after it had reported
         * FLOWING means its data stopped (its row fell back to requesting), not that it has yet to start. */
        bool stale = data_observable(adm, &info->spec)
                         ? info->status == UB_ADMIN_STALE && data_quiet(adm, row, now_ms)
                         : info->spec.type == UB_ADMIN_ROW_SUBSCRIPTION && row->acked_status == UB_ADMIN_ACKNOWLEDGED &&
                               info->active_at_ms != 0;
        info->status = stale ? UB_ADMIN_STALE : (ub_admin_status_t)row->acked_status;
        info->attempts = 0;
        row->next_send_ms = now_ms + adm->opt.renew_ms;
        return true;
    }
    return false;
}

bool ub_priv_admin_routes_to(const ub_admin_t *adm, uint32_t instance, const uint8_t src_id[UB_ENTITY_ID_LEN],
                             const uint8_t dest_id[UB_ENTITY_ID_LEN]) {
    for (int r = 0; r < UB_MAX_ADMIN_ROWS; r++) {
        const ub_admin_row_t *row = &adm->rows[r];
        const ub_admin_row_spec_t *spec = &row->info.spec;
        /* A row on its way out still admits the data already under way. */
        bool live = row->info.active_flag || row->info.status == UB_ADMIN_STOPPING;
        if (row->in_use && live && spec->instance == instance &&
            memcmp(spec->source, src_id, UB_ENTITY_ID_LEN) == 0 &&
            memcmp(spec->destination, dest_id, UB_ENTITY_ID_LEN) == 0)
            return true;
    }
    return false;
}

void ub_priv_admin_tick(ub_admin_t *adm, uint64_t now_ms) {
    for (int r = 0; r < UB_MAX_ADMIN_ROWS; r++) {
        ub_admin_row_t *row = &adm->rows[r];
        ub_admin_row_info_t *info = &row->info;
        if (!row->in_use) continue;
        switch (info->status) {
        case UB_ADMIN_ACKNOWLEDGED:
        case UB_ADMIN_ACTIVE:
        case UB_ADMIN_STALE:
            /* Renewals keep the target's lease; silence for a whole lease means the target is gone. */
            if (now_ms - info->last_ack_ms > adm->opt.lease_ms) enter(row, UB_ADMIN_PENDING, now_ms);
            else if (info->status != UB_ADMIN_STALE && data_quiet(adm, row, now_ms)) info->status = UB_ADMIN_STALE;
            /* fall through */
        case UB_ADMIN_PENDING:
            if (now_ms < row->next_send_ms) break;
            if (info->status == UB_ADMIN_PENDING && adm->opt.max_retries != 0 &&
                info->attempts >= adm->opt.max_retries) {
                enter(row, UB_ADMIN_FAILED, now_ms);
                break;
            }
            /* Requests and renewals are repeated at the retry pace until an ACK moves the next one out
             * to the renewal pace, so one lost renewal does not cost a lease. */
            send_row(adm, row, false, now_ms);
            info->attempts++;
            if (row->next_send_ms <= now_ms) row->next_send_ms = now_ms + adm->opt.retry_ms;
            break;
        case UB_ADMIN_STOPPING:
            /* Until acknowledged: a flow handed over to its keeper does not end when we go quiet, so giving
             * up would leave "inactive" on a flow that still runs. After the first burst, at the renewal pace. */
            if (now_ms < row->next_send_ms) break;
            send_row(adm, row, true, now_ms);
            info->attempts++;
            row->next_send_ms = now_ms + (info->attempts >= adm->opt.max_stop_retries ? adm->opt.renew_ms
                                                                                      : adm->opt.retry_ms);
            break;
        default:
            break;
        }
    }
}

int ub_priv_admin_forget(ub_admin_t *adm, const uint8_t id[UB_ENTITY_ID_LEN], uint64_t now_ms) {
    int n = 0;
    for (int r = 0; r < UB_MAX_ADMIN_ROWS; r++) {
        ub_admin_row_t *row = &adm->rows[r];
        ub_admin_row_info_t *info = &row->info;
        if (!row->in_use || (!info->active_flag && info->status != UB_ADMIN_STOPPING)) continue;
        if (memcmp(target_of(&info->spec), id, UB_ENTITY_ID_LEN) == 0) {
            /* Nobody left to ask or to stop: the row is inactive now, not STOPPING toward no route. */
            info->active_flag = false;
            enter(row, UB_ADMIN_INACTIVE, now_ms);
            n++;
        } else if (info->active_flag && memcmp(peer_of(&info->spec), id, UB_ENTITY_ID_LEN) == 0) {
            if (ub_admin_set_active(adm, r, false, now_ms) == UB_OK) n++;
        }
    }
    return n;
}
