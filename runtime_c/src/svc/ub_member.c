/* Membership over the bus (ub_member.h, docs/routing.md "MEMBERSHIP"): a service of the node (ub_service.h).
 * Every node serves MEMBERSHIP requests (ub_priv_member_server, registered by ub_node_init()); a requester
 * (ub_member_init()) takes the registration over while attached. Public headers only. */
#include "ub/ub_member.h"

#include <string.h>

#include "ub/ub_wire.h"
#include "svc/ub_requester.h"
#include "svc/ub_svc_private.h"

#define DEFAULT_RETRY_MS 200u

static const char *const op_names[] = {
    [UB_MEMBER_ADD_ENTITY] = "add_entity", [UB_MEMBER_REMOVE_ENTITY] = "remove_entity",
    [UB_MEMBER_SET_MASK] = "set_mask",     [UB_MEMBER_ADD_LINK] = "add_link",
    [UB_MEMBER_REMOVE_LINK] = "remove_link",
};

const char *ub_member_op_name(ub_member_op_t op) {
    if ((unsigned)op >= sizeof op_names / sizeof op_names[0] || op_names[op] == NULL) return "?";
    return op_names[op];
}

static const char *const status_names[] = {
    [UB_MEMBER_FREE] = "free", [UB_MEMBER_PENDING] = "pending", [UB_MEMBER_DONE] = "done",
    [UB_MEMBER_FAILED] = "failed"};

const char *ub_member_status_name(ub_member_status_t status) {
    if ((unsigned)status >= sizeof status_names / sizeof status_names[0]) return "?";
    return status_names[status];
}

static bool is_link_op(uint8_t op) { return op == UB_MEMBER_ADD_LINK || op == UB_MEMBER_REMOVE_LINK; }

static bool id_usable(const uint8_t id[UB_ENTITY_ID_LEN]) {
    return !ub_entity_id_is_zero(id) && !ub_entity_id_is_link_local(id);
}

static bool name_ok(const char *name, size_t cap) {
    size_t n = strnlen(name, cap);
    return n > 0 && n < cap;
}

/* Checks a spec's shape (both ends use it: the requester before sending, the target on receipt). */
static bool spec_ok(const ub_member_spec_t *s) {
    switch (s->op) {
    case UB_MEMBER_ADD_ENTITY:
    case UB_MEMBER_REMOVE_ENTITY:
        return id_usable(s->subject);
    case UB_MEMBER_SET_MASK:
        return id_usable(s->subject) && (UB_MAX_LINKS_PER_ENTITY >= 8 || (s->mask >> UB_MAX_LINKS_PER_ENTITY) == 0);
    case UB_MEMBER_ADD_LINK:
        return name_ok(s->link_name, sizeof s->link_name) && s->link_index < UB_MAX_LINKS_PER_ENTITY &&
               strnlen(s->port_spec, sizeof s->port_spec) < sizeof s->port_spec;
    case UB_MEMBER_REMOVE_LINK:
        return name_ok(s->link_name, sizeof s->link_name);
    default:
        return false;
    }
}

/* ---- applying (the target) ------------------------------------------------------------------------- */

static uint8_t apply_link(ub_node_t *node, int entity, const ub_member_spec_t *s, uint64_t now_ms, bool *changed) {
    /* The link handler is the requester's (ub_member_set_link_handler()): found through its registration. */
    const ub_service_t *svc = ub_node_service_for(node, UB_SVC_CODE, UB_ADMIN_MEMBERSHIP);
    ub_member_t *m = svc != NULL ? svc->user : NULL;
    if (m == NULL || m->link_fn == NULL) return UB_NACK_UNSUPPORTED;
    int rc = m->link_fn(m->link_user, node, entity, (ub_member_op_t)s->op, s->link_index, s->link_name,
                        s->port_spec, now_ms);
    if (rc == UB_OK) {
        *changed = true;
        return UB_NACK_NONE;
    }
    if ((rc == UB_ERR_EXISTS && s->op == UB_MEMBER_ADD_LINK) || (rc == UB_ERR_NOTFOUND && s->op == UB_MEMBER_REMOVE_LINK))
        return UB_NACK_NONE; /* already so */
    return rc == UB_ERR_FULL ? UB_NACK_TABLE_FULL : UB_NACK_INVALID;
}

uint8_t ub_member_apply(ub_node_t *node, int entity, const ub_member_spec_t *s, uint64_t now_ms, bool *changed) {
    *changed = false;
    if (node == NULL || s == NULL || ub_node_entity_slot(node, entity) < 0 || !spec_ok(s)) return UB_NACK_INVALID;
    int row = is_link_op(s->op) ? -1 : ub_node_find_entity(node, s->subject);
    switch (s->op) {
    case UB_MEMBER_ADD_ENTITY: {
        if (row >= 0) return UB_NACK_NONE;
        int rc = ub_node_add_entity(node, s->subject, false);
        if (rc == UB_ERR_FULL) return UB_NACK_TABLE_FULL;
        if (rc < 0) return UB_NACK_INVALID;
        *changed = true;
        return UB_NACK_NONE;
    }
    case UB_MEMBER_REMOVE_ENTITY:
        if (row < 0) return UB_NACK_NONE;
        if (ub_node_remove_entity(node, row, now_ms) != UB_OK) return UB_NACK_INVALID; /* a local entity */
        *changed = true;
        return UB_NACK_NONE;
    case UB_MEMBER_SET_MASK: {
        uint8_t before = 0;
        if (row < 0 || ub_node_get_mask(node, entity, row, &before) != UB_OK) return UB_NACK_INVALID;
        bool was_pinned = ub_node_mask_pinned(node, entity, row);
        if (ub_node_set_mask(node, entity, row, s->mask) != UB_OK) return UB_NACK_INVALID;
        *changed = before != s->mask || was_pinned != (s->mask != 0);
        return UB_NACK_NONE;
    }
    default:
        return apply_link(node, entity, s, now_ms, changed);
    }
}

static void decode(const ub_frame_header_t *h, const uint8_t *p, ub_member_spec_t *s) {
    memset(s, 0, sizeof *s);
    s->op = p[UB_MEMBER_OFF_OP];
    memcpy(s->target, h->dest_id, UB_ENTITY_ID_LEN);
    memcpy(s->subject, p + UB_MEMBER_OFF_SUBJECT, UB_ENTITY_ID_LEN);
    s->mask = p[UB_MEMBER_OFF_ARG];
    s->link_index = p[UB_MEMBER_OFF_ARG];
    if (h->payload_size >= UB_MEMBER_LINK_LEN) {
        memcpy(s->link_name, p + UB_MEMBER_OFF_LINK, UB_LINK_NAME_LEN);
        s->link_name[UB_LINK_NAME_LEN - 1] = '\0';
        size_t spec_len = h->payload_size - UB_MEMBER_LINK_LEN;
        if (spec_len >= sizeof s->port_spec) spec_len = sizeof s->port_spec - 1;
        memcpy(s->port_spec, p + UB_MEMBER_OFF_SPEC, spec_len);
    }
}

/* A MEMBERSHIP request reached local slot `rx->slot` over a link (the policy judges it, ub_node_may_administer())
 * or from a local entity. Returns false when the node must count a drop, of reason `*drop`: an unusable payload
 * (bad_payload, nothing answered) or a refused requester (not_authorized, NACK sent). */
static bool member_on_request(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx,
                              const ub_frame_header_t *h, const uint8_t *payload, uint64_t now_ms, ub_drop_reason_t *drop) {
    (void)svc;
    int slot = rx->slot;
    *drop = UB_DROP_BAD_PAYLOAD;
    if (h->payload_size < UB_MEMBER_ENTITY_LEN) return false;
    uint32_t id = ub_get_u32le(payload + UB_MEMBER_OFF_ID);
    uint8_t op = payload[UB_MEMBER_OFF_OP];
    if (is_link_op(op) && h->payload_size < UB_MEMBER_LINK_LEN) return false;
    int entity = ub_node_slot_entity(node, slot);
    uint8_t reason;
    bool changed = false;
    /* Entities of one node share its process: only requests that came over a link are judged. */
    bool authorized = rx->link_id < 0 || ub_node_may_administer(node, entity, h->src_id, rx->secured);
    if (!authorized) {
        reason = UB_NACK_NOT_AUTHORIZED;
    } else {
        ub_member_spec_t spec;
        decode(h, payload, &spec);
        reason = ub_member_apply(node, entity, &spec, now_ms, &changed);
    }
    static const uint8_t zero_dir[UB_DIR_ID_LEN] = {0};
    if (reason != UB_NACK_NONE) ub_node_svc_counters(node)->membership_refused++;
    else ub_node_svc_counters(node)->membership_applied++;
    (void)ub_node_svc_send_reply(node, slot, reason != UB_NACK_NONE, zero_dir, h->src_id, id, UB_ADMIN_MEMBERSHIP,
                             reason != UB_NACK_NONE ? reason : (changed ? UB_MEMBER_CHANGED : 0), 0, now_ms);
    if (!authorized) {
        *drop = UB_DROP_NOT_AUTHORIZED;
        return false;
    }
    return true;
}

/* ---- requesting ------------------------------------------------------------------------------------- */

static bool member_on_reply(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx,
                            const ub_frame_header_t *h, const ub_service_reply_t *r, uint64_t now_ms,
                            ub_drop_reason_t *drop);
static bool nobody_asked(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx,
                         const ub_frame_header_t *h, const ub_service_reply_t *r, uint64_t now_ms, ub_drop_reason_t *drop);
static void member_tick(const ub_service_t *svc, ub_node_t *node, uint64_t now_ms);
static bool member_next_due(const ub_service_t *svc, const ub_node_t *node, uint64_t now_ms, uint64_t *due_ms);

static const uint8_t member_codes[] = {UB_ADMIN_MEMBERSHIP};

/* Every node serves MEMBERSHIP requests; without a requester attached, replies to them are unasked for. */
const ub_service_t ub_priv_member_server = {
    .name = "membership",
    .codes = member_codes,
    .n_codes = sizeof member_codes,
    .reply_codes = member_codes,
    .n_reply_codes = sizeof member_codes,
    .order = UB_SVC_ORDER_MEMBER,
    .on_frame = member_on_request,
    .on_reply = nobody_asked,
};

int ub_member_init(ub_member_t *m, ub_node_t *node, int entity, const ub_member_options_t *opt) {
    if (m == NULL || node == NULL || ub_node_entity_slot(node, entity) < 0) return UB_ERR_INVAL;
    /* The requester takes the membership registration over (from the server, or from a requester attached
     * before: the last one attached answers, as it always did). */
    const ub_service_t *prev = ub_node_service_for(node, UB_SVC_CODE, UB_ADMIN_MEMBERSHIP);
    if (prev != NULL && ub_node_remove_service(node, prev) != UB_OK) return UB_ERR_INVAL;
    memset(m, 0, sizeof *m);
    if (opt != NULL) m->opt = *opt;
    if (m->opt.retry_ms == 0) m->opt.retry_ms = DEFAULT_RETRY_MS;
    m->node = node;
    m->entity = entity;
    m->svc = ub_priv_member_server;
    m->svc.on_reply = member_on_reply;
    m->svc.tick = member_tick;
    m->svc.next_due = member_next_due;
    m->svc.user = m;
    int rc = ub_node_add_service(node, &m->svc);
    if (rc != UB_OK && prev != NULL && ub_node_add_service(node, prev) != UB_OK) {
        /* cannot fail: its codes were just freed */
    }
    if (rc != UB_OK) m->node = NULL; /* not attached: serving goes on as before */
    return rc;
}

void ub_member_detach(ub_member_t *m) {
    if (m == NULL || m->node == NULL) return;
    /* Serving goes on without it. */
    if (ub_node_remove_service(m->node, &m->svc) == UB_OK && ub_node_add_service(m->node, &ub_priv_member_server) != UB_OK) {
        /* cannot fail: the code was just freed */
    }
    m->node = NULL;
}

void ub_member_set_link_handler(ub_member_t *m, ub_member_link_fn fn, void *user) {
    if (m == NULL) return;
    m->link_fn = fn;
    m->link_user = user;
}

int ub_member_request(ub_member_t *m, const ub_member_spec_t *spec, uint64_t now_ms) {
    if (m == NULL || m->node == NULL || spec == NULL || !spec_ok(spec) || !id_usable(spec->target)) return UB_ERR_INVAL;
    for (int r = 0; r < UB_MAX_MEMBER_REQUESTS; r++) {
        ub_member_row_t *row = &m->rows[r];
        if (row->in_use) continue;
        memset(row, 0, sizeof *row);
        row->in_use = 1;
        row->info.spec = *spec;
        row->info.status = UB_MEMBER_PENDING;
        row->info.request_id = ub_node_svc_new_request_id(m->node);
        row->next_send_ms = now_ms;
        return r;
    }
    return UB_ERR_FULL;
}

int ub_member_status(const ub_member_t *m, int row, ub_member_info_t *out) {
    if (m == NULL || out == NULL || row < 0 || row >= UB_MAX_MEMBER_REQUESTS || !m->rows[row].in_use)
        return UB_ERR_NOTFOUND;
    *out = m->rows[row].info;
    return UB_OK;
}

int ub_member_forget(ub_member_t *m, int row) {
    if (m == NULL || row < 0 || row >= UB_MAX_MEMBER_REQUESTS || !m->rows[row].in_use) return UB_ERR_NOTFOUND;
    m->rows[row].in_use = 0;
    return UB_OK;
}

const ub_member_counters_t *ub_member_counters(const ub_member_t *m) { return m == NULL ? NULL : &m->counters; }

static void send_request(ub_member_t *m, const ub_member_row_t *row, uint64_t now_ms) {
    const ub_member_spec_t *s = &row->info.spec;
    uint8_t p[UB_MEMBER_OFF_SPEC + UB_MEMBER_SPEC_LEN];
    memset(p, 0, sizeof p);
    ub_put_u32le(p + UB_MEMBER_OFF_ID, row->info.request_id);
    p[UB_MEMBER_OFF_OP] = s->op;
    p[UB_MEMBER_OFF_ARG] = s->op == UB_MEMBER_ADD_LINK ? s->link_index : s->mask;
    memcpy(p + UB_MEMBER_OFF_SUBJECT, s->subject, UB_ENTITY_ID_LEN);
    uint16_t len = UB_MEMBER_ENTITY_LEN;
    if (is_link_op(s->op)) {
        memcpy(p + UB_MEMBER_OFF_LINK, s->link_name, strnlen(s->link_name, UB_LINK_NAME_LEN - 1));
        len = UB_MEMBER_LINK_LEN;
        if (s->op == UB_MEMBER_ADD_LINK) {
            size_t n = strnlen(s->port_spec, sizeof s->port_spec - 1);
            memcpy(p + UB_MEMBER_OFF_SPEC, s->port_spec, n);
            len = (uint16_t)(len + n);
        }
    }
    static const uint8_t zero_dir[UB_DIR_ID_LEN] = {0};
    int slot = ub_node_entity_slot(m->node, m->entity);
    (void)ub_node_svc_send_admin(m->node, slot, UB_ADMIN_MEMBERSHIP, zero_dir, 0, s->target, p, len, now_ms);
    m->counters.sent++;
}

static void member_tick(const ub_service_t *svc, ub_node_t *node, uint64_t now_ms) {
    (void)node;
    ub_member_t *m = svc->user;
    for (int r = 0; r < UB_MAX_MEMBER_REQUESTS; r++) {
        ub_member_row_t *row = &m->rows[r];
        if (!row->in_use || row->info.status != UB_MEMBER_PENDING) continue;
        ub_req_step_t step = ub_req_step(&row->next_send_ms, &row->info.attempts, m->opt.retry_ms, m->opt.max_retries, now_ms);
        if (step == UB_REQ_GIVE_UP) {
            row->info.status = UB_MEMBER_FAILED;
            row->info.done_ms = now_ms;
            m->counters.failed++;
        } else if (step == UB_REQ_SEND) {
            send_request(m, row, now_ms); /* last: a local target answers synchronously */
        }
    }
}

/* Pending requests' next sends (ub_service.h `next_due`). */
static bool member_next_due(const ub_service_t *svc, const ub_node_t *node, uint64_t now_ms, uint64_t *due_ms) {
    (void)node;
    const ub_member_t *m = svc->user;
    uint64_t best = UINT64_MAX;
    for (int r = 0; r < UB_MAX_MEMBER_REQUESTS; r++) {
        const ub_member_row_t *row = &m->rows[r];
        if (row->in_use && row->info.status == UB_MEMBER_PENDING) ub_req_due(row->next_send_ms, now_ms, &best);
    }
    *due_ms = best;
    return best != UINT64_MAX;
}

/* Nobody here asked (no requester attached): counted on the node, as any unusable admin frame. */
static bool nobody_asked(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx,
                         const ub_frame_header_t *h, const ub_service_reply_t *r, uint64_t now_ms, ub_drop_reason_t *drop) {
    (void)svc, (void)rx, (void)h, (void)r, (void)now_ms, (void)drop;
    ub_node_svc_count_drop(node, -1, UB_DROP_BAD_PAYLOAD);
    return true;
}

/* An ACK/NACK answering a MEMBERSHIP request reached local slot `rx->slot`. */
static bool member_on_reply(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx,
                            const ub_frame_header_t *h, const ub_service_reply_t *rep, uint64_t now_ms,
                            ub_drop_reason_t *drop) {
    (void)drop;
    ub_member_t *m = svc->user;
    int slot = rx->slot;
    const uint8_t *src_id = h->src_id;
    uint32_t request_id = rep->request_id;
    bool nack = rep->nack;
    uint8_t detail = rep->detail;
    for (int r = 0; r < UB_MAX_MEMBER_REQUESTS; r++) {
        ub_member_row_t *row = &m->rows[r];
        if (!row->in_use || row->info.request_id != request_id) continue;
        /* Bound to the row: the answer must come from the target, to the requesting entity. */
        if (row->info.status != UB_MEMBER_PENDING || !ub_req_bound(node, slot, m->entity, src_id, row->info.spec.target))
            break;
        row->info.done_ms = now_ms;
        if (nack) {
            row->info.status = UB_MEMBER_FAILED;
            row->info.nack_reason = detail;
            m->counters.failed++;
        } else {
            row->info.status = UB_MEMBER_DONE;
            row->info.changed = (detail & UB_MEMBER_CHANGED) != 0;
            m->counters.done++;
        }
        return true;
    }
    m->counters.unmatched_replies++;
    return true;
}
