/*
 * The MAVLink front door (ub_mavroute.h): routing between the local autopilot, the ground stations of
 * the node's endpoint and the other bridge nodes, by learned system ids (the MAVLink routing guide).
 * Parsers are the generated headers' mavlink_frame_char_buffer over state in ub_mavroute_t.
 */
#include "ub_mavroute.h"

#include <string.h>

#include "ub/ub_catalogue.h"

#define ALL_LINKS 0xFFFFFFFFu

static uint32_t bit(int link) { return 1u << (unsigned)link; }

static bool is_peer_link(int link) { return link >= UB_MAVROUTE_LINK_PEER0; }
static bool is_client_link(int link) { return link >= UB_MAVROUTE_LINK_CLIENT0 && link < UB_MAVROUTE_LINK_PEER0; }

static void on_autopilot(void *user, const mavlink_message_t *m, uint64_t now_ms);

int ub_mavroute_init(ub_mavroute_t *rt, ub_mavbridge_t *br, struct ub_mavframe *frame, const char *const *peers,
                     int n_peers, ub_mavroute_send_fn send, void *send_user) {
    if (rt == NULL || br == NULL || br->node == NULL || frame == NULL || send == NULL || n_peers < 0 ||
        (n_peers > 0 && peers == NULL))
        return UB_ERR_INVAL;
    if (n_peers > UB_MAVROUTE_MAX_PEERS) return UB_ERR_FULL;
    memset(rt, 0, sizeof *rt);
    rt->br = br;
    rt->autopilot = true;
    rt->node = br->node;
    rt->entity = br->entity;
    rt->frame = frame;
    rt->send = send;
    rt->send_user = send_user;
    for (int p = 0; p < n_peers; p++) {
        if (ub_entity_id(peers[p], rt->peers[p]) != UB_OK || ub_node_find_entity(rt->node, rt->peers[p]) < 0)
            return UB_ERR_INVAL;
    }
    rt->n_peers = n_peers;
    int inst = ub_catalogue_find_name(rt->node->cat, UB_MAVFRAME_NAME);
    if (inst < 0) return UB_ERR_INVAL;
    int rc = ub_node_bind(rt->node, (uint32_t)inst, frame);
    if (rc < 0) return rc;
    memset(frame, 0, sizeof *frame);
    rt->frame_instance = inst;
    ub_mavbridge_set_tap(br, on_autopilot, rt);
    return UB_OK;
}

/* The message's target system (0: broadcast, or a message without one). */
static uint8_t target_of(const mavlink_message_t *m) {
    const mavlink_msg_entry_t *e = mavlink_get_msg_entry(m->msgid);
    if (e == NULL || !(e->flags & MAV_MSG_ENTRY_FLAG_HAVE_TARGET_SYSTEM)) return 0;
    return (uint8_t)_MAV_PAYLOAD(m)[e->target_system_ofs]; /* zero-filled to full length by the parser */
}

static bool vehicle_heartbeat(const mavlink_message_t *m) {
    if (m->msgid != MAVLINK_MSG_ID_HEARTBEAT) return false;
    mavlink_heartbeat_t hb;
    memcpy(&hb, _MAV_PAYLOAD(m), sizeof hb);
    return hb.autopilot != MAV_AUTOPILOT_INVALID && hb.type != MAV_TYPE_GCS;
}

static bool gcs_heartbeat(const mavlink_message_t *m) {
    if (m->msgid != MAVLINK_MSG_ID_HEARTBEAT) return false;
    mavlink_heartbeat_t hb;
    memcpy(&hb, _MAV_PAYLOAD(m), sizeof hb);
    return hb.type == MAV_TYPE_GCS;
}

/* Learns the source system on link `from`. A vehicle system id already owned by another vehicle link
 * (the local autopilot, a peer bridge) is a conflict: counted, reported, dropped (the first keeps it). */
static bool learn(ub_mavroute_t *rt, const mavlink_message_t *m, int from) {
    if (!is_client_link(from)) {
        uint8_t owner = rt->vehicle[m->sysid];
        if (owner != 0 && owner != (uint8_t)(from + 1)) {
            rt->c.sysid_conflicts++;
            rt->last_conflict = m->sysid;
            return false;
        }
        if (owner == 0 && vehicle_heartbeat(m)) rt->vehicle[m->sysid] = (uint8_t)(from + 1);
    }
    if (gcs_heartbeat(m)) rt->gcs[m->sysid] = 1;
    rt->seen[m->sysid] |= bit(from);
    return true;
}

static void to_peer(ub_mavroute_t *rt, int p, const uint8_t *bytes, uint16_t len, uint64_t now_ms) {
    rt->frame->len = len;
    memcpy(rt->frame->bytes, bytes, len);
    if (ub_node_send_data(rt->node, rt->entity, (uint32_t)rt->frame_instance, rt->peers[p], now_ms) >= 0)
        rt->c.to_peers++;
    else
        rt->c.send_errors++;
}

static void route(ub_mavroute_t *rt, const mavlink_message_t *m, int from, uint64_t now_ms) {
    if (!learn(rt, m, from)) return;
    uint8_t target = target_of(m);
    uint32_t mask = target == 0 ? ALL_LINKS : rt->seen[target];
    mask &= ~bit(from);
    if (target != 0 && rt->seen[target] == 0) {
        rt->c.no_target++;
        return;
    }
    uint16_t len = mavlink_msg_to_send_buffer(rt->tx, m);
    /* The autopilot: what is addressed to it, and ground stations' broadcasts (HEARTBEAT...: from a local
     * ground station, or from a system whose HEARTBEAT says GCS), never other vehicles' broadcast telemetry.
     * Only when the bridge forwards commands (the node's write policy). */
    if (rt->autopilot && (mask & bit(UB_MAVROUTE_LINK_AUTOPILOT)) && from != UB_MAVROUTE_LINK_AUTOPILOT &&
        (target != 0 || is_client_link(from) || rt->gcs[m->sysid])) {
        if (!rt->br->opt.commands) rt->c.commands_off++;
        else if (ub_mavbridge_forward(rt->br, m, now_ms) == UB_OK) rt->c.to_autopilot++;
        else rt->c.send_errors++;
    }
    for (int c = 0; c < UB_MAVROUTE_MAX_CLIENTS; c++) {
        if (!rt->client_up[c] || !(mask & bit(UB_MAVROUTE_LINK_CLIENT0 + c))) continue;
        if (rt->send(rt->send_user, c, rt->tx, len) == UB_OK) rt->c.to_clients++;
        else rt->c.send_errors++;
    }
    /* The bus does the multi-hop part: what came from a peer goes to local links only (no loops). */
    if (is_peer_link(from)) return;
    for (int p = 0; p < rt->n_peers; p++) {
        if (!(mask & bit(UB_MAVROUTE_LINK_PEER0 + p))) continue;
        /* A vehicle's broadcast goes only to a peer heard lately (someone listens there). */
        bool listening = rt->peer_heard_ms[p] != 0 && now_ms - rt->peer_heard_ms[p] <= UB_MAVROUTE_PEER_TIMEOUT_MS;
        if (from == UB_MAVROUTE_LINK_AUTOPILOT && target == 0 && !listening) continue;
        to_peer(rt, p, rt->tx, len, now_ms);
    }
}

static void on_autopilot(void *user, const mavlink_message_t *m, uint64_t now_ms) {
    ub_mavroute_t *rt = user;
    rt->c.from_autopilot++;
    route(rt, m, UB_MAVROUTE_LINK_AUTOPILOT, now_ms);
}

int ub_mavroute_from_client(ub_mavroute_t *rt, int client, const uint8_t *bytes, size_t len, uint64_t now_ms) {
    if (rt == NULL || client < 0 || client >= UB_MAVROUTE_MAX_CLIENTS || (bytes == NULL && len > 0))
        return UB_ERR_INVAL;
    rt->client_up[client] = 1;
    int routed = 0;
    mavlink_status_t *st = &rt->cstatus[client];
    for (size_t i = 0; i < len; i++) {
        uint8_t r = mavlink_frame_char_buffer(&rt->cbuf[client], st, bytes[i], &rt->msg, NULL);
        rt->c.client_parse_errors += st->parse_error;
        st->parse_error = 0;
        if (r == MAVLINK_FRAMING_INCOMPLETE) continue;
        if (r != MAVLINK_FRAMING_OK) {
            rt->c.client_parse_errors++;
            continue;
        }
        rt->c.from_clients++;
        route(rt, &rt->msg, UB_MAVROUTE_LINK_CLIENT0 + client, now_ms);
        routed++;
    }
    return routed;
}

void ub_mavroute_client_gone(ub_mavroute_t *rt, int client) {
    if (rt == NULL || client < 0 || client >= UB_MAVROUTE_MAX_CLIENTS) return;
    rt->client_up[client] = 0;
    memset(&rt->cstatus[client], 0, sizeof rt->cstatus[client]);
    for (int s = 0; s < 256; s++) rt->seen[s] &= ~bit(UB_MAVROUTE_LINK_CLIENT0 + client);
}

void ub_mavroute_on_deliver(void *user, int entity, uint32_t instance, const ub_frame_header_t *h, uint64_t now_ms) {
    ub_mavroute_t *rt = user;
    if (rt == NULL) return;
    if (entity != rt->entity || (int32_t)instance != rt->frame_instance) {
        ub_mavbridge_on_deliver(rt->br, entity, instance, h, now_ms);
        return;
    }
    int p = 0;
    while (p < rt->n_peers && memcmp(rt->peers[p], h->src_id, UB_ENTITY_ID_LEN) != 0) p++;
    if (p == rt->n_peers) {
        rt->c.unknown_peer++;
        return;
    }
    rt->c.from_peers++;
    rt->peer_heard_ms[p] = now_ms != 0 ? now_ms : 1;
    /* One whole frame per write: a fresh parser, so a damaged frame cannot disturb the next one. */
    size_t len = rt->frame->len <= UB_MAVFRAME_MAX ? rt->frame->len : 0;
    memset(&rt->pstatus, 0, sizeof rt->pstatus);
    for (size_t i = 0; i < len; i++) {
        uint8_t r = mavlink_frame_char_buffer(&rt->pbuf, &rt->pstatus, rt->frame->bytes[i], &rt->msg, NULL);
        if (r == MAVLINK_FRAMING_INCOMPLETE) continue;
        if (r == MAVLINK_FRAMING_OK && i + 1 == len) {
            route(rt, &rt->msg, UB_MAVROUTE_LINK_PEER0 + p, now_ms);
            return;
        }
        break;
    }
    rt->c.bad_frames++;
}

void ub_mavroute_set_autopilot(ub_mavroute_t *rt, bool has_autopilot) {
    if (rt != NULL) rt->autopilot = has_autopilot;
}

const ub_mavroute_counters_t *ub_mavroute_counters(const ub_mavroute_t *rt) { return rt != NULL ? &rt->c : NULL; }

uint32_t ub_mavroute_seen(const ub_mavroute_t *rt, uint8_t sysid) { return rt != NULL ? rt->seen[sysid] : 0; }
