/* The revocation service (contract in ub/ub_revoke.h; design in docs/security.md "Revocation").
 * It reaches the node only through ub_node_svc.h: records go out with ub_node_send_link_local(). */
#include "ub/ub_revoke.h"

#include <string.h>

#include "ub/ub_node_svc.h"

#define DEFAULT_MIN_INTERVAL_MS 50u
#define DEFAULT_REPEAT_MS 200u
#define DEFAULT_REPEATS 4u
#define DEFAULT_VERIFY_PER_S 32u

#if UB_MAX_PAYLOAD < UB_REVOCATION_LEN
#error "a revocation record (104 bytes) must fit one frame: UB_MAX_PAYLOAD >= 104"
#endif

#if UB_MAX_PAYLOAD < UB_CERT_LEN
#error "a certificate (176 bytes) must fit one frame: UB_MAX_PAYLOAD >= 176"
#endif

static const uint8_t REVOKE_CODES[] = {UB_ADMIN_REVOCATION, UB_ADMIN_CERTIFICATE};

/* A record changed the store at `index`: persist it, then spread it (not back on `from_link` at first). */
static void schedule(ub_revoke_t *rv, int index, int from_link, uint64_t now_ms) {
    rv->dirty = true;
    rv->spread[index].remaining = rv->opt.repeats;
    rv->spread[index].from_link = (int8_t)(from_link >= 0 && from_link < 127 ? from_link : -1);
    rv->spread[index].due_ms = now_ms;
}

/* Adds one record to the store; counts what happened. */
static int take(ub_revoke_t *rv, const uint8_t *record, size_t len, int from_link, uint64_t now_ms) {
    rv->stats.received++;
    ub_ident_status_t why;
    int rc = ub_ident_add_revocation(rv->store, record, len, &why);
    if (rc >= 0) {
        rv->stats.accepted++;
        ub_revocation_t rec;
        if (rv->on_peer != NULL && ub_revocation_decode(&rec, record, len) == UB_OK) rv->on_peer(rv->on_peer_user, rec.entity);
        schedule(rv, rc, from_link, now_ms);
        return UB_OK;
    }
    if (rc == UB_ERR_EXISTS) rv->stats.known++;
    else if (rc == UB_ERR_FULL) rv->stats.full++;
    else rv->stats.refused++;
    return rc;
}

/* ---- certificates ---- */

static uint64_t unix_s(const ub_revoke_t *rv, uint64_t now_ms) {
    return rv->opt.clock_s != NULL ? rv->opt.clock_s(rv->opt.clock_user) : now_ms / 1000u;
}

static bool is_self(const ub_revoke_t *rv, const uint8_t *entity) {
    for (size_t i = 0; i < ub_ident_self_count(rv->store); i++)
        if (memcmp(ub_ident_self_at(rv->store, i)->cert.entity, entity, UB_ENTITY_ID_LEN) == 0) return true;
    return false;
}

/* Queues `cert` for spreading (a queued one of the same entity is replaced). */
static void queue_cert(ub_revoke_t *rv, const uint8_t *cert, int from_link, uint64_t now_ms) {
    int at = -1;
    for (int i = 0; i < UB_REVOKE_CERT_QUEUE; i++) {
        if (rv->certs[i].remaining != 0 && memcmp(rv->certs[i].cert + 12, cert + 12, UB_ENTITY_ID_LEN) == 0) at = i;
    }
    for (int i = 0; i < UB_REVOKE_CERT_QUEUE && at < 0; i++)
        if (rv->certs[i].remaining == 0) at = i;
    if (at < 0) {
        rv->stats.certs_dropped++;
        return;
    }
    memcpy(rv->certs[at].cert, cert, UB_CERT_LEN);
    rv->certs[at].remaining = rv->opt.repeats;
    rv->certs[at].from_link = (int8_t)(from_link >= 0 && from_link < 127 ? from_link : -1);
    rv->certs[at].due_ms = now_ms;
}

static int take_cert(ub_revoke_t *rv, const uint8_t *cert, size_t len, int from_link, uint64_t now_ms) {
    rv->stats.certs_received++;
    ub_cert_t c;
    if (ub_cert_decode(&c, cert, len) == UB_OK && is_self(rv, c.entity)) {
        rv->stats.certs_known++; /* our own, back from a neighbour */
        return UB_ERR_EXISTS;
    }
    uint32_t added = rv->store->stats.peers_added;
    ub_ident_status_t why;
    int rc = ub_ident_add_peer(rv->store, cert, len, unix_s(rv, now_ms), &why);
    if (rc == UB_OK && rv->store->stats.peers_added == added) {
        rv->stats.certs_known++;
        return UB_ERR_EXISTS;
    }
    if (rc != UB_OK) {
        rv->stats.certs_refused++;
        return rc;
    }
    rv->stats.certs_accepted++;
    if (rv->on_peer != NULL && ub_cert_decode(&c, cert, len) == UB_OK) rv->on_peer(rv->on_peer_user, c.entity);
    if (rv->persist_cert != NULL) {
        if (rv->persist_cert(rv->persist_cert_user, cert, len) == UB_OK) rv->stats.persisted++;
        else rv->stats.persist_failures++;
    }
    queue_cert(rv, cert, from_link, now_ms);
    return UB_OK;
}

/* The verification budget: a second's worth of Ed25519 verifications at most. */
static bool within_budget(ub_revoke_t *rv, uint64_t now_ms) {
    if (now_ms < rv->budget_window_ms || now_ms - rv->budget_window_ms >= 1000u) {
        rv->budget_window_ms = now_ms;
        rv->budget_used = 0;
    }
    if (rv->budget_used >= rv->opt.verify_per_s) {
        rv->stats.over_budget++;
        return false;
    }
    rv->budget_used++;
    return true;
}

static bool on_frame(const ub_service_t *svc, ub_node_t *node, const ub_service_rx_t *rx, const ub_frame_header_t *h,
                     const uint8_t *payload, uint64_t now_ms, ub_drop_reason_t *drop) {
    (void)node;
    ub_revoke_t *rv = svc->user;
    *drop = UB_DROP_BAD_PAYLOAD;
    if (h->admin == UB_ADMIN_CERTIFICATE) {
        if (h->payload_size != UB_CERT_LEN) {
            rv->stats.certs_received++;
            rv->stats.certs_refused++;
            return false;
        }
        if (!within_budget(rv, now_ms)) {
            rv->stats.certs_received++;
            *drop = UB_DROP_BACKPRESSURE;
            return false;
        }
        int rc = take_cert(rv, payload, h->payload_size, rx->link_id, now_ms);
        return rc == UB_OK || rc == UB_ERR_EXISTS || rc == UB_ERR_FULL;
    }
    if (h->payload_size != UB_REVOCATION_LEN) {
        rv->stats.received++;
        rv->stats.refused++;
        return false;
    }
    if (!within_budget(rv, now_ms)) {
        rv->stats.received++;
        *drop = UB_DROP_BACKPRESSURE;
        return false;
    }
    int rc = take(rv, payload, h->payload_size, rx->link_id, now_ms);
    return rc == UB_OK || rc == UB_ERR_EXISTS || rc == UB_ERR_FULL;
}

static bool link_attached(const ub_node_t *node, int link_id) {
    const ub_link_t *l = ub_node_link(node, link_id);
    return l != NULL && l->in_use && l->ops != NULL;
}

static void tick(const ub_service_t *svc, ub_node_t *node, uint64_t now_ms) {
    ub_revoke_t *rv = svc->user;
    if (rv->dirty && rv->persist != NULL) {
        if (rv->persist(rv->persist_user, rv->store) == UB_OK) {
            rv->dirty = false;
            rv->stats.persisted++;
        } else {
            rv->stats.persist_failures++;
        }
    } else if (rv->persist == NULL) {
        rv->dirty = false;
    }
    if (now_ms < rv->next_send_ms) return;
    /* One record per tick at most: the oldest due. */
    size_t n = ub_ident_revocation_count(rv->store);
    for (size_t i = 0; i < n; i++) {
        if (rv->spread[i].remaining == 0 || now_ms < rv->spread[i].due_ms) continue;
        uint8_t rec[UB_REVOCATION_LEN];
        if (ub_ident_revocation_at(rv->store, i, rec) != UB_OK) continue;
        bool any = false;
        for (int lid = 0; lid < UB_MAX_NODE_LINKS; lid++) {
            if (!link_attached(node, lid)) continue;
            /* Back to the neighbour that sent it only on the repeats (it may have lost our copy; it ignores it). */
            if (lid == rv->spread[i].from_link && rv->spread[i].remaining == rv->opt.repeats) {
                any = true;
                continue;
            }
            if (ub_node_send_link_local(node, lid, UB_ADMIN_REVOCATION, rec, UB_REVOCATION_LEN, now_ms) == 1) {
                rv->stats.sent++;
                any = true;
            }
        }
        /* A round no transport took (links down, a TCP peer not yet adopted) does not count as a repeat: it is
         * tried again after repeat_ms, so a record is never lost to a link that was down when it arrived. */
        if (any) rv->spread[i].remaining--;
        else rv->stats.unsent++;
        /* Doubling gaps (200, 400, 800 ms by default): the repeats outlast a second whose verification budget a
         * flood of junk used up, and a long outage costs few sends. */
        unsigned done = (unsigned)(rv->opt.repeats - rv->spread[i].remaining);
        rv->spread[i].due_ms = now_ms + ((uint64_t)rv->opt.repeat_ms << (done > 0 && done < 8 ? done - 1u : 0u));
        rv->next_send_ms = now_ms + rv->opt.min_interval_ms;
        return;
    }
    /* Then one certificate, the same way (revocations first: they close, certificates open). */
    for (int i = 0; i < UB_REVOKE_CERT_QUEUE; i++) {
        if (rv->certs[i].remaining == 0 || now_ms < rv->certs[i].due_ms) continue;
        bool any = false;
        for (int lid = 0; lid < UB_MAX_NODE_LINKS; lid++) {
            if (!link_attached(node, lid)) continue;
            if (lid == rv->certs[i].from_link && rv->certs[i].remaining == rv->opt.repeats) {
                any = true;
                continue;
            }
            if (ub_node_send_link_local(node, lid, UB_ADMIN_CERTIFICATE, rv->certs[i].cert, UB_CERT_LEN, now_ms) == 1) {
                rv->stats.certs_sent++;
                any = true;
            }
        }
        if (any) rv->certs[i].remaining--;
        else rv->stats.unsent++;
        unsigned done = (unsigned)(rv->opt.repeats - rv->certs[i].remaining);
        rv->certs[i].due_ms = now_ms + ((uint64_t)rv->opt.repeat_ms << (done > 0 && done < 8 ? done - 1u : 0u));
        rv->next_send_ms = now_ms + rv->opt.min_interval_ms;
        return;
    }
}

int ub_revoke_init(ub_revoke_t *rv, ub_node_t *node, ub_ident_store_t *store, const ub_revoke_options_t *opt,
                   ub_revoke_persist_fn persist, void *persist_user) {
    if (rv == NULL || node == NULL || store == NULL) return UB_ERR_INVAL;
    memset(rv, 0, sizeof *rv);
    rv->node = node;
    rv->store = store;
    rv->persist = persist;
    rv->persist_user = persist_user;
    if (opt != NULL) rv->opt = *opt;
    if (rv->opt.min_interval_ms == 0) rv->opt.min_interval_ms = DEFAULT_MIN_INTERVAL_MS;
    if (rv->opt.repeat_ms == 0) rv->opt.repeat_ms = DEFAULT_REPEAT_MS;
    if (rv->opt.repeats == 0) rv->opt.repeats = DEFAULT_REPEATS;
    if (rv->opt.verify_per_s == 0) rv->opt.verify_per_s = DEFAULT_VERIFY_PER_S;
    for (size_t i = 0; i < UB_IDENT_MAX_REVOCATIONS; i++) rv->spread[i].from_link = -1;
    for (size_t i = 0; i < UB_REVOKE_CERT_QUEUE; i++) rv->certs[i].from_link = -1;
    rv->svc.name = "revoke";
    rv->svc.codes = REVOKE_CODES;
    rv->svc.n_codes = 2;
    rv->svc.link_local_codes = REVOKE_CODES;
    rv->svc.n_link_local_codes = 2;
    rv->svc.link_local_self_proving = true; /* certificates and records carry the authority's signature */
    rv->svc.order = UB_SVC_ORDER_USER;
    rv->svc.on_frame = on_frame;
    rv->svc.tick = tick;
    rv->svc.user = rv;
    return ub_node_add_service(node, &rv->svc);
}

int ub_revoke_set_peer_hook(ub_revoke_t *rv, ub_revoke_peer_fn fn, void *user) {
    if (rv == NULL) return UB_ERR_INVAL;
    rv->on_peer = fn;
    rv->on_peer_user = user;
    return UB_OK;
}

int ub_revoke_remove(ub_revoke_t *rv) {
    if (rv == NULL || rv->node == NULL) return UB_ERR_INVAL;
    return ub_node_remove_service(rv->node, &rv->svc);
}

int ub_revoke_submit(ub_revoke_t *rv, const uint8_t *record, size_t len, uint64_t now_ms) {
    if (rv == NULL || record == NULL) return UB_ERR_INVAL;
    return take(rv, record, len, -1, now_ms);
}

const ub_revoke_stats_t *ub_revoke_stats(const ub_revoke_t *rv) { return rv != NULL ? &rv->stats : NULL; }

int ub_revoke_spread_certificates(ub_revoke_t *rv, ub_revoke_persist_cert_fn persist_cert, void *user,
                                  uint64_t now_ms) {
    if (rv == NULL) return UB_ERR_INVAL;
    rv->persist_cert = persist_cert;
    rv->persist_cert_user = user;
    for (size_t i = 0; i < ub_ident_self_count(rv->store); i++) {
        uint8_t cert[UB_CERT_LEN];
        if (ub_cert_encode(&ub_ident_self_at(rv->store, i)->cert, cert) == UB_OK) queue_cert(rv, cert, -1, now_ms);
    }
    return UB_OK;
}

int ub_revoke_submit_certificate(ub_revoke_t *rv, const uint8_t *cert, size_t len, uint64_t now_ms) {
    if (rv == NULL || cert == NULL) return UB_ERR_INVAL;
    return take_cert(rv, cert, len, -1, now_ms);
}
