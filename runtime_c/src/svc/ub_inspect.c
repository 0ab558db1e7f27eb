/* Remote inspection and change over the bus (ub_inspect.h, docs/inspect.md): a service of the node
 * (ub_service.h). Every node serves INSPECT requests (ub_priv_inspect_server, registered by ub_node_init());
 * a requester (ub_inspect_init()) takes the registration over while attached. Public headers only. */
#include "ub/ub_inspect.h"

#include <string.h>

#include "ub/ub_admin.h"
#include "ub/ub_policy.h"
#include "ub/ub_pubsub.h"
#include "ub/ub_wire.h"
#include "svc/ub_requester.h"
#include "svc/ub_svc_private.h"

#define DEFAULT_RETRY_MS 200u

static const char *const op_names[] = {
    [UB_INSPECT_READ] = "read",           [UB_INSPECT_WRITE] = "write",       [UB_INSPECT_LIST] = "list",
    [UB_INSPECT_SET_PERIOD] = "set_period", [UB_INSPECT_SET_MASK] = "set_mask", [UB_INSPECT_ADMIN_ROW] = "admin_row",
};

const char *ub_inspect_op_name(ub_inspect_op_t op) {
    if ((unsigned)op >= sizeof op_names / sizeof op_names[0] || op_names[op] == NULL) return "?";
    return op_names[op];
}

static const char *const status_names[] = {[UB_INSPECT_FREE] = "free", [UB_INSPECT_PENDING] = "pending",
                                           [UB_INSPECT_DONE] = "done", [UB_INSPECT_FAILED] = "failed"};

const char *ub_inspect_status_name(ub_inspect_status_t status) {
    if ((unsigned)status >= sizeof status_names / sizeof status_names[0]) return "?";
    return status_names[status];
}

static uint32_t sat32(uint64_t v) { return v > UINT32_MAX ? UINT32_MAX : (uint32_t)v; }

/* ---- serving (the target) --------------------------------------------------------------------------- */

typedef struct request {
    const ub_frame_header_t *h;
    const uint8_t *data; /* bytes after the fixed part */
    uint16_t len;
    uint32_t id;
    uint8_t op, arg;
    uint16_t offset;
    uint32_t value;
} request_t;

/* The policy's word on this requester. `admin_only`: LIST and the table changes; otherwise the read or
 * write rule of the content decides for a non-administrator. An administrator's request counts only in
 * a frame whose tag verified when the node has a security context (a forged source ID gets nothing). */
static bool permitted(const ub_node_t *node, int slot, const request_t *r, bool from_link, bool secured,
                      ub_policy_dir_t dir, bool admin_only, int instance) {
    if (!from_link) return true;
    int entity = ub_node_slot_entity(node, slot);
    if (ub_node_may_administer(node, entity, r->h->src_id, secured)) return true;
    if (admin_only) return false;
    /* Not an administrator: the content's read or write rule. Without a policy, reads are as open as
     * subscriptions and a write needs the administrator (there is no rule to grant it). */
    if (ub_node_policy(node) == NULL) return dir == UB_POLICY_READ;
    if (dir == UB_POLICY_READ && !ub_node_policy(node)->read_restricted) return true;
    const char *name = ub_node_catalogue(node)->instances[instance].name;
    return ub_policy_rule_matches(ub_node_policy(node), dir, ub_node_entity_id(node, entity), r->h->src_id, name ? name : "");
}

static void send_value(ub_node_t *node, int slot, const request_t *r, uint16_t total, uint16_t next,
                       const uint8_t *data, size_t len, uint64_t now_ms) {
    uint8_t p[UB_MAX_PAYLOAD];
    ub_inspect_put_value_head(p, r->id, r->op, r->arg, r->offset, total, next);
    memcpy(p + UB_INSPECT_VAL_DATA, data, len);
    (void)ub_node_svc_send_admin(node, slot, UB_ADMIN_INSPECT_VALUE, r->h->dir_id, r->h->fingerprint, r->h->src_id, p,
                             (uint16_t)(UB_INSPECT_VAL_DATA + len), now_ms);
}

/* The content of a READ/WRITE: its instance, or -(NACK reason). */
static int content_of(const ub_node_t *node, const ub_frame_header_t *h) {
    int idx = ub_catalogue_find(ub_node_catalogue(node), h->dir_id);
    if (idx < 0) return -UB_NACK_UNKNOWN_CONTENT;
    const ub_type_desc_t *type = ub_node_catalogue(node)->instances[idx].type;
    if (type->fingerprint != h->fingerprint) return -UB_NACK_LAYOUT;
    if (ub_node_binding(node, (uint32_t)idx) == NULL) return -UB_NACK_UNBOUND;
    return idx;
}

static int pack_current(const ub_node_t *node, uint32_t instance, uint8_t *buf) {
    const ub_type_desc_t *type = ub_node_catalogue(node)->instances[instance].type;
    const void *storage = ub_node_binding(node, instance);
    if (type->pack == NULL) {
        memcpy(buf, storage, type->packed_size); /* wire-image storage (ub_type_desc_t) */
        return (int)type->packed_size;
    }
    return type->pack(storage, buf, UB_MAX_PAYLOAD);
}

/* Inspection packs a whole value into one UB_MAX_PAYLOAD image (on the stack, so a microcontroller's stack
 * stays bounded); a type above that (up to UB_MAX_DIRECTORY, carried in fragments by subscriptions) is
 * refused UNSUPPORTED rather than overrun the image. */
static bool inspectable(const ub_node_t *node, int instance) {
    return ub_node_catalogue(node)->instances[instance].type->packed_size <= UB_MAX_PAYLOAD;
}

static uint8_t serve_read(ub_node_t *node, int slot, const request_t *r, int instance, uint64_t now_ms) {
    if (!inspectable(node, instance)) return UB_NACK_UNSUPPORTED;
    uint8_t image[UB_MAX_PAYLOAD];
    int n = pack_current(node, (uint32_t)instance, image);
    if (n < 0) return UB_NACK_BAD_VALUE; /* the stored value cannot be packed (e.g. a bool out of range) */
    if (r->offset > n || (r->offset == n && n != 0)) return UB_NACK_NO_SUCH_ROW;
    size_t len = (size_t)n - r->offset;
    if (len > UB_INSPECT_CHUNK) len = UB_INSPECT_CHUNK;
    uint16_t next = r->offset + len < (size_t)n ? (uint16_t)(r->offset + len) : UB_INSPECT_END;
    send_value(node, slot, r, (uint16_t)n, next, image + r->offset, len, now_ms);
    return UB_NACK_NONE;
}

static uint8_t serve_write(ub_node_t *node, int slot, const request_t *r, int instance, uint64_t now_ms, bool *changed) {
    const ub_type_desc_t *type = ub_node_catalogue(node)->instances[instance].type;
    if (!inspectable(node, instance)) return UB_NACK_UNSUPPORTED;
    if (r->len == 0 || (size_t)r->offset + r->len > type->packed_size) return UB_NACK_INVALID;
    uint8_t image[UB_MAX_PAYLOAD], before[UB_MAX_PAYLOAD];
    int n = pack_current(node, (uint32_t)instance, image);
    if (n < 0) n = (int)type->packed_size, memset(image, 0, type->packed_size); /* unpackable now: whole write only */
    memcpy(before, image, (size_t)n);
    memcpy(image + r->offset, r->data, r->len);
    *changed = memcmp(before, image, (size_t)n) != 0;
    void *storage = ub_node_binding(node, (uint32_t)instance);
    if (type->unpack == NULL) {
        memcpy(storage, image, type->packed_size);
    } else if (type->unpack(storage, image, type->packed_size) < 0) {
        /* The codec refused the value: unpack checks before writing, so the storage kept its value. */
        *changed = false;
        return UB_NACK_BAD_VALUE;
    }
    /* A publication on update sends the new value (ub_pubsub_set_on_update()); a timed one at its turn. */
    if (ub_pubsub_updated(node, ub_node_slot_entity(node, slot), (uint32_t)instance, now_ms) < 0) {
        /* not published on update here: timed publications carry the new value at their turn */
    }
    return UB_NACK_NONE;
}

/* ---- payload layouts (pure; docs/inspect.md, tests/vectors/inspect.json) ---------------------------- */

void ub_inspect_put_value_head(uint8_t p[UB_INSPECT_VAL_DATA], uint32_t request_id, uint8_t op, uint8_t arg,
                               uint16_t offset, uint16_t total, uint16_t next) {
    ub_put_u32le(p + UB_INSPECT_VAL_ID, request_id);
    p[UB_INSPECT_VAL_OP] = op;
    p[UB_INSPECT_VAL_ARG] = arg;
    ub_put_u16le(p + UB_INSPECT_VAL_OFFSET, offset);
    ub_put_u16le(p + UB_INSPECT_VAL_TOTAL, total);
    ub_put_u16le(p + UB_INSPECT_VAL_NEXT, next);
}

void ub_inspect_put_entity_rec(uint8_t p[UB_INSPECT_ENTITY_REC], const ub_inspect_entity_rec_t *r) {
    memset(p, 0, UB_INSPECT_ENTITY_REC);
    memcpy(p, r->id, UB_ENTITY_ID_LEN);
    p[12] = r->local;
    p[13] = r->mask;
    p[14] = r->pinned;
}

void ub_inspect_put_link_rec(uint8_t p[UB_INSPECT_LINK_REC], const ub_inspect_link_rec_t *r) {
    memset(p, 0, UB_INSPECT_LINK_REC);
    memcpy(p, r->name, strnlen(r->name, UB_LINK_NAME_LEN));
    p[32] = r->index;
    p[33] = r->attached;
    const uint32_t counters[6] = {r->frames_in, r->frames_out, r->bytes_in, r->bytes_out, r->drops, r->accepted};
    for (int k = 0; k < 6; k++) ub_put_u32le(p + 36 + 4 * k, counters[k]);
}

void ub_inspect_put_pubsub_rec(uint8_t p[UB_INSPECT_PUBSUB_REC], const ub_inspect_pubsub_rec_t *r) {
    ub_put_u16le(p, r->row);
    p[2] = r->kind;
    p[3] = r->state;
    memcpy(p + 4, r->dir_id, UB_DIR_ID_LEN);
    memcpy(p + 20, r->peer, UB_ENTITY_ID_LEN);
    memcpy(p + 32, r->owner, UB_ENTITY_ID_LEN);
    ub_put_u32le(p + 44, r->period_ms);
    ub_put_u32le(p + 48, r->frames);
}

void ub_inspect_put_admin_rec(uint8_t p[UB_INSPECT_ADMIN_REC], const ub_inspect_admin_rec_t *r) {
    ub_put_u16le(p, r->row);
    p[2] = r->type;
    p[3] = r->status;
    memcpy(p + 4, r->dir_id, UB_DIR_ID_LEN);
    memcpy(p + 20, r->source, UB_ENTITY_ID_LEN);
    memcpy(p + 32, r->destination, UB_ENTITY_ID_LEN);
    ub_put_u32le(p + 44, r->period_ms);
    p[48] = r->active;
    p[49] = r->nack_reason;
    p[50] = p[51] = 0;
}

size_t ub_inspect_put_request(uint8_t *p, size_t cap, uint32_t request_id, const ub_inspect_spec_t *s) {
    if (p == NULL || s == NULL) return 0; /* before `s` is read */
    size_t extra = s->op == UB_INSPECT_WRITE ? s->len : s->op == UB_INSPECT_SET_MASK ? UB_ENTITY_ID_LEN : 0;
    if (extra > UB_INSPECT_CHUNK || cap < UB_INSPECT_REQ_DATA + extra) return 0;
    ub_put_u32le(p + UB_INSPECT_REQ_ID, request_id);
    p[UB_INSPECT_REQ_OP] = s->op;
    p[UB_INSPECT_REQ_ARG] = s->arg;
    ub_put_u16le(p + UB_INSPECT_REQ_OFFSET, s->offset);
    ub_put_u32le(p + UB_INSPECT_REQ_VALUE, s->value);
    if (s->op == UB_INSPECT_WRITE) memcpy(p + UB_INSPECT_REQ_DATA, s->data, s->len);
    if (s->op == UB_INSPECT_SET_MASK) memcpy(p + UB_INSPECT_REQ_DATA, s->subject, UB_ENTITY_ID_LEN);
    return UB_INSPECT_REQ_DATA + extra;
}

/* ---- records of the node's tables ------------------------------------------------------------------ */

static size_t put_entity(const ub_node_t *node, int slot, int e, uint8_t *p) {
    ub_inspect_entity_rec_t r = {.local = ub_node_entity_slot(node, e) >= 0, .mask = ub_node_slot_mask(node, slot, e),
                                 .pinned = ub_node_slot_pinned(node, slot, e)};
    memcpy(r.id, ub_node_entity_id(node, e), UB_ENTITY_ID_LEN);
    ub_inspect_put_entity_rec(p, &r);
    return UB_INSPECT_ENTITY_REC;
}

static size_t put_link(const ub_node_t *node, int link_id, uint8_t *p) {
    const ub_link_t *l = ub_node_link(node, link_id);
    uint64_t drops = 0;
    for (int d = 0; d < UB_DROP_REASON_COUNT; d++) drops += l->counters.drops[d];
    ub_inspect_link_rec_t r = {.index = l->index, .attached = l->ops != NULL,
                               .frames_in = sat32(l->counters.frames_in), .frames_out = sat32(l->counters.frames_out),
                               .bytes_in = sat32(l->counters.bytes_in), .bytes_out = sat32(l->counters.bytes_out),
                               .drops = sat32(drops), .accepted = sat32(l->counters.frames_accepted)};
    memcpy(r.name, l->name, UB_LINK_NAME_LEN);
    ub_inspect_put_link_rec(p, &r);
    return UB_INSPECT_LINK_REC;
}

static size_t put_pubsub(const ub_node_t *node, int r, const ub_ps_row_t *row, uint8_t *p) {
    ub_inspect_pubsub_rec_t rec = {.row = (uint16_t)r, .kind = row->kind,
                                   .state = row->kind == UB_PS_SUBSCRIPTION ? row->state : row->reported_flowing,
                                   .period_ms = row->period_ms, .frames = sat32(row->frames)};
    memcpy(rec.dir_id, ub_node_catalogue(node)->instances[row->instance].id, UB_DIR_ID_LEN);
    memcpy(rec.peer, row->peer, UB_ENTITY_ID_LEN);
    memcpy(rec.owner, row->owner, UB_ENTITY_ID_LEN);
    ub_inspect_put_pubsub_rec(p, &rec);
    return UB_INSPECT_PUBSUB_REC;
}

static size_t put_admin(const ub_node_t *node, int r, const ub_admin_row_info_t *info, uint8_t *p) {
    ub_inspect_admin_rec_t rec = {.row = (uint16_t)r, .type = (uint8_t)info->spec.type, .status = (uint8_t)info->status,
                                  .period_ms = info->spec.period_ms, .active = info->active_flag,
                                  .nack_reason = (uint8_t)info->nack_reason};
    memcpy(rec.dir_id, ub_node_catalogue(node)->instances[info->spec.instance].id, UB_DIR_ID_LEN);
    memcpy(rec.source, info->spec.source, UB_ENTITY_ID_LEN);
    memcpy(rec.destination, info->spec.destination, UB_ENTITY_ID_LEN);
    ub_inspect_put_admin_rec(p, &rec);
    return UB_INSPECT_ADMIN_REC;
}

/* One table, rows from `offset` on, as many records as fit; `total` = rows in the table. Row numbers
 * are positions among the table's used rows for entities and links, the table's own row index for the
 * publish/subscribe and admin tables (the index SET_PERIOD / ADMIN_ROW take). */
static uint8_t serve_list(ub_node_t *node, int slot, const request_t *r, uint64_t now_ms) {
    uint8_t data[UB_INSPECT_CHUNK];
    size_t len = 0, rec = 0;
    unsigned total = 0, next = UB_INSPECT_END;
    const ub_admin_t *adm = ub_node_svc_pubsub_table(node, slot)->admin;
    unsigned cap;
    switch (r->arg) {
    case UB_INSPECT_ENTITIES: rec = UB_INSPECT_ENTITY_REC; cap = UB_MAX_ENTITIES; break;
    case UB_INSPECT_LINKS: rec = UB_INSPECT_LINK_REC; cap = UB_MAX_NODE_LINKS; break;
    case UB_INSPECT_PUBSUB: rec = UB_INSPECT_PUBSUB_REC; cap = UB_MAX_PUBSUB_ROWS; break;
    case UB_INSPECT_ADMIN: rec = UB_INSPECT_ADMIN_REC; cap = UB_MAX_ADMIN_ROWS; break;
    default: return UB_NACK_INVALID;
    }
    for (unsigned i = 0; i < cap; i++) {
        bool used;
        switch (r->arg) {
        case UB_INSPECT_ENTITIES: used = (ub_node_entity_id(node, i) != NULL); break;
        case UB_INSPECT_LINKS: used = ub_node_link(node, (int)i) != NULL && ub_node_link(node, (int)i)->owner == slot; break;
        case UB_INSPECT_PUBSUB: used = (*ub_node_svc_pubsub_table(node, slot)).rows[i].kind != UB_PS_FREE; break;
        default: used = adm != NULL && adm->rows[i].in_use; break;
        }
        if (!used) continue;
        unsigned row_no = (r->arg == UB_INSPECT_PUBSUB || r->arg == UB_INSPECT_ADMIN) ? i : total;
        total++;
        if (row_no < r->offset) continue;
        if (len + rec > sizeof data) {
            if (next == UB_INSPECT_END) next = row_no;
            continue;
        }
        uint8_t *p = data + len;
        switch (r->arg) {
        case UB_INSPECT_ENTITIES: len += put_entity(node, slot, (int)i, p); break;
        case UB_INSPECT_LINKS: len += put_link(node, (int)i, p); break;
        case UB_INSPECT_PUBSUB: len += put_pubsub(node, (int)i, &(*ub_node_svc_pubsub_table(node, slot)).rows[i], p); break;
        default: len += put_admin(node, (int)i, &adm->rows[i].info, p); break;
        }
    }
    send_value(node, slot, r, (uint16_t)total, (uint16_t)next, data, len, now_ms);
    return UB_NACK_NONE;
}

static uint8_t serve_set_period(ub_node_t *node, int slot, const request_t *r, uint64_t now_ms, bool *changed) {
    if (r->value == 0) return UB_NACK_INVALID;
    if (r->offset >= UB_MAX_PUBSUB_ROWS) return UB_NACK_NO_SUCH_ROW;
    ub_ps_row_t *row = &(*ub_node_svc_pubsub_table(node, slot)).rows[r->offset];
    if (row->kind == UB_PS_FREE) return UB_NACK_NO_SUCH_ROW;
    *changed = row->period_ms != r->value;
    row->period_ms = r->value;
    /* The new rate from now: a publication's next DATA within one new period, a subscription asks its
     * source again at once (its request carries the period). */
    if (row->kind == UB_PS_SUBSCRIPTION || row->next_due_ms > now_ms + r->value) row->next_due_ms = now_ms;
    return UB_NACK_NONE;
}

static uint8_t serve_set_mask(ub_node_t *node, int slot, const request_t *r, bool *changed) {
    if (r->len < UB_ENTITY_ID_LEN || r->value > 0xFFu) return UB_NACK_INVALID;
    int entity = ub_node_slot_entity(node, slot);
    int dest = ub_node_find_entity(node, r->data);
    if (dest < 0) return UB_NACK_NO_SUCH_ROW;
    uint8_t before = 0;
    if (ub_node_get_mask(node, entity, dest, &before) != UB_OK) return UB_NACK_INVALID;
    if (ub_node_set_mask(node, entity, dest, (uint8_t)r->value) != UB_OK) return UB_NACK_INVALID;
    *changed = before != r->value;
    return UB_NACK_NONE;
}

static uint8_t serve_admin_row(ub_node_t *node, int slot, const request_t *r, uint64_t now_ms, bool *changed) {
    ub_admin_t *adm = ub_node_svc_pubsub_table(node, slot)->admin;
    if (adm == NULL || r->offset >= UB_MAX_ADMIN_ROWS || !adm->rows[r->offset].in_use) return UB_NACK_NO_SUCH_ROW;
    ub_admin_row_t *row = &adm->rows[r->offset];
    if (r->arg == UB_INSPECT_ADMIN_PERIOD) {
        if (r->value == 0) return UB_NACK_INVALID;
        *changed = row->info.spec.period_ms != r->value;
        row->info.spec.period_ms = r->value;
        /* In place: an active row renews at once with the new period (same request id: the target
         * updates its row), so the change is lasting and no flow is interrupted. */
        if (row->info.active_flag && row->info.status != UB_ADMIN_FAILED) row->next_send_ms = now_ms;
        return UB_NACK_NONE;
    }
    if (r->arg == UB_INSPECT_ADMIN_ACTIVE && r->value <= 1) {
        *changed = row->info.active_flag != (r->value != 0);
        return ub_admin_set_active(adm, r->offset, r->value != 0, now_ms) == UB_OK ? UB_NACK_NONE : UB_NACK_NO_SUCH_ROW;
    }
    return UB_NACK_INVALID;
}

/* An INSPECT request reached local slot `rx->slot` (over a link: the policy judges it). Answers it (value, ACK
 * or NACK). Returns false when the node must count a drop of reason `*drop`: an unusable payload (bad_payload,
 * nothing answered) or a refused requester (not_authorized, NACK sent). */
static bool inspect_on_request(ub_node_t *node, const ub_service_rx_t *rx, const ub_frame_header_t *h,
                               const uint8_t *payload, uint64_t now_ms, ub_drop_reason_t *drop) {
    int slot = rx->slot;
    bool from_link = rx->link_id >= 0, secured = rx->secured;
    *drop = UB_DROP_BAD_PAYLOAD;
    if (h->payload_size < UB_INSPECT_REQ_DATA) return false;
    request_t r = {h,
                   payload + UB_INSPECT_REQ_DATA,
                   (uint16_t)(h->payload_size - UB_INSPECT_REQ_DATA),
                   ub_get_u32le(payload + UB_INSPECT_REQ_ID),
                   payload[UB_INSPECT_REQ_OP],
                   payload[UB_INSPECT_REQ_ARG],
                   ub_get_u16le(payload + UB_INSPECT_REQ_OFFSET),
                   ub_get_u32le(payload + UB_INSPECT_REQ_VALUE)};
    uint8_t reason = UB_NACK_NONE;
    bool changed = false, authorized = true, value_sent = false;
    int instance = 0;
    if (r.op == UB_INSPECT_READ || r.op == UB_INSPECT_WRITE) {
        instance = content_of(node, h);
        if (instance < 0) reason = (uint8_t)-instance;
    }
    if (reason == UB_NACK_NONE) {
        bool content_op = r.op == UB_INSPECT_READ || r.op == UB_INSPECT_WRITE;
        authorized = permitted(node, slot, &r, from_link, secured, r.op == UB_INSPECT_WRITE ? UB_POLICY_WRITE : UB_POLICY_READ,
                               !content_op, instance);
        if (!authorized) reason = UB_NACK_NOT_AUTHORIZED;
    }
    if (reason == UB_NACK_NONE) {
        switch (r.op) {
        case UB_INSPECT_READ: reason = serve_read(node, slot, &r, instance, now_ms), value_sent = reason == UB_NACK_NONE; break;
        case UB_INSPECT_WRITE: reason = serve_write(node, slot, &r, instance, now_ms, &changed); break;
        case UB_INSPECT_LIST: reason = serve_list(node, slot, &r, now_ms), value_sent = reason == UB_NACK_NONE; break;
        case UB_INSPECT_SET_PERIOD: reason = serve_set_period(node, slot, &r, now_ms, &changed); break;
        case UB_INSPECT_SET_MASK: reason = serve_set_mask(node, slot, &r, &changed); break;
        case UB_INSPECT_ADMIN_ROW: reason = serve_admin_row(node, slot, &r, now_ms, &changed); break;
        default: reason = UB_NACK_INVALID; break;
        }
    }
    if (reason != UB_NACK_NONE) ub_node_svc_counters(node)->inspect_refused++;
    else ub_node_svc_counters(node)->inspect_served++;
    if (!value_sent) {
        (void)ub_node_svc_send_reply(node, slot, reason != UB_NACK_NONE, h->dir_id, h->src_id, r.id, UB_ADMIN_INSPECT,
                                 reason != UB_NACK_NONE ? reason : (changed ? 1u : 0u), 0, now_ms);
    }
    if (!authorized) {
        *drop = UB_DROP_NOT_AUTHORIZED;
        return false;
    }
    return true;
}

/* ---- requesting ------------------------------------------------------------------------------------- */

static bool id_usable(const uint8_t id[UB_ENTITY_ID_LEN]) {
    return !ub_entity_id_is_zero(id) && !ub_entity_id_is_link_local(id);
}

static bool spec_ok(const ub_node_t *node, const ub_inspect_spec_t *s) {
    if (!id_usable(s->target)) return false;
    switch (s->op) {
    case UB_INSPECT_READ: return s->instance < ub_node_catalogue(node)->n_instances;
    case UB_INSPECT_WRITE: return s->instance < ub_node_catalogue(node)->n_instances && s->len > 0 && s->len <= UB_INSPECT_CHUNK;
    case UB_INSPECT_LIST: return s->arg >= UB_INSPECT_ENTITIES && s->arg <= UB_INSPECT_ADMIN;
    case UB_INSPECT_SET_PERIOD: return s->value > 0;
    case UB_INSPECT_SET_MASK: return id_usable(s->subject) && s->value <= 0xFFu;
    case UB_INSPECT_ADMIN_ROW: return s->arg == UB_INSPECT_ADMIN_PERIOD || s->arg == UB_INSPECT_ADMIN_ACTIVE;
    default: return false;
    }
}

static void inspect_tick(const ub_service_t *svc, ub_node_t *node, uint64_t now_ms);
static bool inspect_next_due(const ub_service_t *svc, const ub_node_t *node, uint64_t now_ms, uint64_t *due_ms);

int ub_inspect_init(ub_inspect_t *in, ub_node_t *node, int entity, const ub_inspect_options_t *opt) {
    if (in == NULL || node == NULL || ub_node_entity_slot(node, entity) < 0) return UB_ERR_INVAL;
    /* The requester takes the inspection registration over (from the server, or from a requester attached
     * before: the last one attached gets the answers, as it always did). */
    const ub_service_t *prev = ub_node_service_for(node, UB_SVC_CODE, UB_ADMIN_INSPECT);
    if (prev != NULL && ub_node_remove_service(node, prev) != UB_OK) return UB_ERR_INVAL;
    memset(in, 0, sizeof *in);
    if (opt != NULL) in->opt = *opt;
    if (in->opt.retry_ms == 0) in->opt.retry_ms = DEFAULT_RETRY_MS;
    in->node = node;
    in->entity = entity;
    in->svc = ub_priv_inspect_server;
    in->svc.tick = inspect_tick;
    in->svc.next_due = inspect_next_due;
    in->svc.user = in;
    int rc = ub_node_add_service(node, &in->svc);
    if (rc != UB_OK && prev != NULL && ub_node_add_service(node, prev) != UB_OK) {
        /* cannot fail: its codes were just freed */
    }
    if (rc != UB_OK) in->node = NULL; /* not attached: serving goes on as before */
    return rc;
}

void ub_inspect_detach(ub_inspect_t *in) {
    if (in == NULL || in->node == NULL) return;
    /* Serving goes on without it. */
    if (ub_node_remove_service(in->node, &in->svc) == UB_OK &&
        ub_node_add_service(in->node, &ub_priv_inspect_server) != UB_OK) {
        /* cannot fail: the codes were just freed */
    }
    in->node = NULL;
}

int ub_inspect_request(ub_inspect_t *in, const ub_inspect_spec_t *spec, uint64_t now_ms) {
    if (in == NULL || in->node == NULL || spec == NULL || !spec_ok(in->node, spec)) return UB_ERR_INVAL;
    for (int r = 0; r < UB_MAX_INSPECT_REQUESTS; r++) {
        ub_inspect_row_t *row = &in->rows[r];
        if (row->in_use) continue;
        memset(&row->result, 0, sizeof row->result);
        row->in_use = 1;
        row->spec = *spec;
        row->result.status = UB_INSPECT_PENDING;
        row->result.request_id = ub_node_svc_new_request_id(in->node);
        row->result.sent_ms = now_ms;
        row->next_send_ms = now_ms;
        return r;
    }
    return UB_ERR_FULL;
}

int ub_inspect_result(const ub_inspect_t *in, int row, ub_inspect_result_t *out) {
    if (in == NULL || out == NULL || row < 0 || row >= UB_MAX_INSPECT_REQUESTS || !in->rows[row].in_use)
        return UB_ERR_NOTFOUND;
    *out = in->rows[row].result;
    return UB_OK;
}

int ub_inspect_forget(ub_inspect_t *in, int row) {
    if (in == NULL || row < 0 || row >= UB_MAX_INSPECT_REQUESTS || !in->rows[row].in_use) return UB_ERR_NOTFOUND;
    in->rows[row].in_use = 0;
    return UB_OK;
}

const ub_inspect_counters_t *ub_inspect_counters(const ub_inspect_t *in) { return in == NULL ? NULL : &in->counters; }

static void send_request(ub_inspect_t *in, const ub_inspect_row_t *row, uint64_t now_ms) {
    const ub_inspect_spec_t *s = &row->spec;
    uint8_t p[UB_MAX_PAYLOAD];
    uint16_t len = (uint16_t)ub_inspect_put_request(p, sizeof p, row->result.request_id, s);
    uint8_t dir[UB_DIR_ID_LEN] = {0};
    uint32_t fingerprint = 0;
    if (s->op == UB_INSPECT_READ || s->op == UB_INSPECT_WRITE) {
        const ub_instance_desc_t *inst = &ub_node_catalogue(in->node)->instances[s->instance];
        memcpy(dir, inst->id, UB_DIR_ID_LEN);
        fingerprint = inst->type->fingerprint;
    }
    int slot = ub_node_entity_slot(in->node, in->entity);
    (void)ub_node_svc_send_admin(in->node, slot, UB_ADMIN_INSPECT, dir, fingerprint, s->target, p, len, now_ms);
    in->counters.sent++;
}

/* Pending requests' next sends (ub_service.h `next_due`). */
static bool inspect_next_due(const ub_service_t *svc, const ub_node_t *node, uint64_t now_ms, uint64_t *due_ms) {
    (void)node;
    const ub_inspect_t *in = svc->user;
    uint64_t best = UINT64_MAX;
    for (int r = 0; r < UB_MAX_INSPECT_REQUESTS; r++) {
        const ub_inspect_row_t *row = &in->rows[r];
        if (row->in_use && row->result.status == UB_INSPECT_PENDING) ub_req_due(row->next_send_ms, now_ms, &best);
    }
    *due_ms = best;
    return best != UINT64_MAX;
}

static void inspect_tick(const ub_service_t *svc, ub_node_t *node, uint64_t now_ms) {
    (void)node;
    ub_inspect_t *in = svc->user;
    for (int r = 0; r < UB_MAX_INSPECT_REQUESTS; r++) {
        ub_inspect_row_t *row = &in->rows[r];
        if (!row->in_use || row->result.status != UB_INSPECT_PENDING) continue;
        ub_req_step_t step =
            ub_req_step(&row->next_send_ms, &row->result.attempts, in->opt.retry_ms, in->opt.max_retries, now_ms);
        if (step == UB_REQ_GIVE_UP) {
            row->result.status = UB_INSPECT_FAILED;
            row->result.done_ms = now_ms;
            in->counters.failed++;
        } else if (step == UB_REQ_SEND) {
            send_request(in, row, now_ms); /* last: a local target answers synchronously */
        }
    }
}

/* The pending row of requester `in` (NULL: none attached) a reply answers: same request id, from the row's
 * target, to the requesting entity. */
static ub_inspect_row_t *row_for(ub_inspect_t *in, ub_node_t *node, int slot, const uint8_t src_id[UB_ENTITY_ID_LEN],
                                 uint32_t id) {
    if (in == NULL) return NULL;
    for (int r = 0; r < UB_MAX_INSPECT_REQUESTS; r++) {
        ub_inspect_row_t *row = &in->rows[r];
        if (!row->in_use || row->result.request_id != id) continue;
        if (row->result.status != UB_INSPECT_PENDING || !ub_req_bound(node, slot, in->entity, src_id, row->spec.target))
            return NULL;
        return row;
    }
    return NULL;
}

static void unmatched(ub_inspect_t *in, ub_node_t *node) {
    if (in != NULL) in->counters.unmatched_replies++;
    else ub_node_svc_count_drop(node, -1, UB_DROP_BAD_PAYLOAD); /* nobody asked: counted, as any unusable admin frame */
}

/* An ACK/NACK answering an INSPECT request reached local slot `rx->slot`. */
static bool inspect_on_reply(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx,
                             const ub_frame_header_t *h, const ub_service_reply_t *rep, uint64_t now_ms,
                             ub_drop_reason_t *drop) {
    (void)drop;
    ub_inspect_t *in = svc->user;
    ub_inspect_row_t *row = row_for(in, node, rx->slot, h->src_id, rep->request_id);
    if (row == NULL) {
        unmatched(in, node);
        return true;
    }
    row->result.done_ms = now_ms;
    if (rep->nack) {
        row->result.status = UB_INSPECT_FAILED;
        row->result.nack_reason = rep->detail;
        in->counters.failed++;
    } else {
        row->result.status = UB_INSPECT_DONE;
        row->result.changed = (rep->detail & 1u) != 0;
        in->counters.done++;
    }
    return true;
}

/* An INSPECT_VALUE reached local slot `slot`. Returns false for an unusable payload (bad_payload). */
static bool inspect_on_value(ub_inspect_t *in, ub_node_t *node, int slot, const ub_frame_header_t *h,
                             const uint8_t *payload, uint64_t now_ms) {
    if (h->payload_size < UB_INSPECT_VAL_DATA) return false;
    ub_inspect_row_t *row = row_for(in, node, slot, h->src_id, ub_get_u32le(payload + UB_INSPECT_VAL_ID));
    if (row == NULL || payload[UB_INSPECT_VAL_OP] != row->spec.op ||
        ub_get_u16le(payload + UB_INSPECT_VAL_OFFSET) != row->spec.offset) {
        unmatched(in, node);
        return true;
    }
    ub_inspect_result_t *res = &row->result;
    res->status = UB_INSPECT_DONE;
    res->done_ms = now_ms;
    res->total = ub_get_u16le(payload + UB_INSPECT_VAL_TOTAL);
    res->next = ub_get_u16le(payload + UB_INSPECT_VAL_NEXT);
    res->len = (uint16_t)(h->payload_size - UB_INSPECT_VAL_DATA);
    memcpy(res->data, payload + UB_INSPECT_VAL_DATA, res->len);
    in->counters.done++;
    return true;
}

static bool inspect_on_frame(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx,
                             const ub_frame_header_t *h, const uint8_t *payload, uint64_t now_ms, ub_drop_reason_t *drop) {
    if (h->admin == UB_ADMIN_INSPECT) return inspect_on_request(node, rx, h, payload, now_ms, drop);
    return inspect_on_value(svc->user, node, rx->slot, h, payload, now_ms);
}

static const uint8_t inspect_codes[] = {UB_ADMIN_INSPECT, UB_ADMIN_INSPECT_VALUE};
static const uint8_t inspect_reply_codes[] = {UB_ADMIN_INSPECT};

/* Every node serves INSPECT requests; without a requester attached (user NULL), values and replies are unasked
 * for. ub_inspect_init() takes the registration over with a copy whose user is the requester. */
const ub_service_t ub_priv_inspect_server = {
    .name = "inspect",
    .codes = inspect_codes,
    .n_codes = sizeof inspect_codes,
    .reply_codes = inspect_reply_codes,
    .n_reply_codes = sizeof inspect_reply_codes,
    .order = UB_SVC_ORDER_INSPECT,
    .on_frame = inspect_on_frame,
    .on_reply = inspect_on_reply,
};
