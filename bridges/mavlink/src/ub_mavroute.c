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
        if (owner == 0 && vehicle_heartbeat(m)) {
            rt->vehicle[m->sysid] = (uint8_t)(from + 1);
            /* The owner is known: another vehicle link this id was heard on before any HEARTBEAT (a second
             * vehicle with the same id) no longer gets what is addressed to it. */
            uint32_t vehicle_links = bit(UB_MAVROUTE_LINK_AUTOPILOT);
            for (int p = 0; p < UB_MAVROUTE_MAX_PEERS; p++) vehicle_links |= bit(UB_MAVROUTE_LINK_PEER0 + p);
            rt->seen[m->sysid] &= ~(vehicle_links & ~bit(from));
        }
    }
    if (gcs_heartbeat(m)) {
        rt->gcs[m->sysid] = 1;
        /* Two ground stations with one system id: both get the replies addressed to it (reported, not hidden). */
        uint32_t clients = 0;
        for (int c = 0; c < UB_MAVROUTE_MAX_CLIENTS; c++) clients |= bit(UB_MAVROUTE_LINK_CLIENT0 + c);
        if (is_client_link(from) && !(rt->seen[m->sysid] & bit(from)) && (rt->seen[m->sysid] & clients) != 0) {
            rt->c.gcs_sysid_shared++;
            rt->last_gcs_shared = m->sysid;
        }
    }
    rt->seen[m->sysid] |= bit(from);
    return true;
}

/* ---- re-encoding ------------------------------------------------------------------------------------ */

/* Encodes `m` (payload zero-filled to its full length, as the parser leaves it) again into rt->out and `buf`
 * under its own ids and sequence, signed with the GCS key when `sign`. @return the frame length, 0 if the
 * message is unknown to the dialect. */
static uint16_t reencode(ub_mavroute_t *rt, const mavlink_message_t *m, bool sign, uint8_t *buf, uint64_t now_ms) {
    const mavlink_msg_entry_t *e = mavlink_get_msg_entry(m->msgid);
    if (e == NULL) return 0;
    if (&rt->out != m) rt->out = *m;
    mavlink_status_t st;
    memset(&st, 0, sizeof st);
    st.current_tx_seq = m->seq;
    if (m->magic == MAVLINK_STX_MAVLINK1) st.flags |= MAVLINK_STATUS_FLAG_OUT_MAVLINK1;
    if (sign) {
        /* The signing time follows the clock as well as the frames (never reused, close to real time). */
        uint64_t t = rt->gsign_t0 + (now_ms - rt->gsign_base_ms) * 100u;
        if (t > rt->gsign.timestamp) rt->gsign.timestamp = t;
        st.signing = &rt->gsign;
    }
    (void)mavlink_finalize_message_buffer(&rt->out, m->sysid, m->compid, &st, e->min_msg_len, e->max_msg_len,
                                          e->crc_extra);
    return mavlink_msg_to_send_buffer(buf, &rt->out);
}

/* ---- rates: SET_MESSAGE_INTERVAL / REQUEST_DATA_STREAM ------------------------------------------------ */

/* The messages a REQUEST_DATA_STREAM stream stands for (ArduPilot's groups; MAVLink deprecated the
 * message, MAVProxy and QGroundControl still send it to ArduPilot). */
static const struct {
    uint8_t stream;
    uint32_t msgs[3];
} k_streams[] = {
    {MAV_DATA_STREAM_RAW_SENSORS, {MAVLINK_MSG_ID_RAW_IMU, MAVLINK_MSG_ID_SCALED_PRESSURE, 0}},
    {MAV_DATA_STREAM_EXTENDED_STATUS, {MAVLINK_MSG_ID_SYS_STATUS, MAVLINK_MSG_ID_GPS_RAW_INT, MAVLINK_MSG_ID_MISSION_CURRENT}},
    {MAV_DATA_STREAM_RC_CHANNELS, {MAVLINK_MSG_ID_RC_CHANNELS, MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, 0}},
    {MAV_DATA_STREAM_POSITION, {MAVLINK_MSG_ID_GLOBAL_POSITION_INT, MAVLINK_MSG_ID_LOCAL_POSITION_NED, 0}},
    {MAV_DATA_STREAM_EXTRA1, {MAVLINK_MSG_ID_ATTITUDE, 0, 0}},
    {MAV_DATA_STREAM_EXTRA2, {MAVLINK_MSG_ID_VFR_HUD, 0, 0}},
    {MAV_DATA_STREAM_EXTRA3, {MAVLINK_MSG_ID_SYSTEM_TIME, MAVLINK_MSG_ID_BATTERY_STATUS, 0}},
};
#define N_STREAMS (sizeof k_streams / sizeof k_streams[0])
#define MAX_ASKED (N_STREAMS * 3)

static int32_t interval_of(float us) {
    if (us < 0) return -1;
    return us >= 2147483647.0f ? 2147483647 : (int32_t)us;
}

/* The (message, interval) pairs `m` asks for; 0 when it is no rate request. `command`: its COMMAND_ACK's
 * command id (0 for REQUEST_DATA_STREAM, which autopilots do not acknowledge). */
static int rate_request(const mavlink_message_t *m, uint32_t *msgids, int32_t *us, uint16_t *command) {
    *command = 0;
    if (m->msgid == MAVLINK_MSG_ID_COMMAND_LONG || m->msgid == MAVLINK_MSG_ID_COMMAND_INT) {
        float p1, p2;
        uint16_t cmd;
        if (m->msgid == MAVLINK_MSG_ID_COMMAND_LONG) {
            mavlink_command_long_t c;
            memcpy(&c, _MAV_PAYLOAD(m), sizeof c);
            cmd = c.command, p1 = c.param1, p2 = c.param2;
        } else {
            mavlink_command_int_t c;
            memcpy(&c, _MAV_PAYLOAD(m), sizeof c);
            cmd = c.command, p1 = c.param1, p2 = c.param2;
        }
        if (cmd != MAV_CMD_SET_MESSAGE_INTERVAL || !(p1 >= 0 && p1 <= 16777215.0f)) return 0;
        *command = cmd;
        msgids[0] = (uint32_t)p1;
        us[0] = interval_of(p2);
        return 1;
    }
    if (m->msgid != MAVLINK_MSG_ID_REQUEST_DATA_STREAM) return 0;
    mavlink_request_data_stream_t r;
    memcpy(&r, _MAV_PAYLOAD(m), sizeof r);
    int32_t iv = r.start_stop == 0 || r.req_message_rate == 0 ? -1 : (int32_t)(1000000u / r.req_message_rate);
    int n = 0;
    for (size_t k = 0; k < N_STREAMS; k++) {
        if (r.req_stream_id != MAV_DATA_STREAM_ALL && r.req_stream_id != k_streams[k].stream) continue;
        for (int j = 0; j < 3 && k_streams[k].msgs[j] != 0; j++) {
            msgids[n] = k_streams[k].msgs[j];
            us[n++] = iv;
        }
    }
    return n;
}

static ub_mavroute_flow_t *find_flow(ub_mavroute_t *rt, int link, uint8_t sysid, uint32_t msgid) {
    for (int i = 0; i < UB_MAVROUTE_MAX_FLOWS; i++) {
        ub_mavroute_flow_t *f = &rt->flows[i];
        if (f->link == (uint8_t)(link + 1) && f->sysid == sysid && f->msgid == msgid) return f;
    }
    return NULL;
}

static void set_flow(ub_mavroute_t *rt, int link, uint8_t sysid, uint32_t msgid, int32_t us, uint64_t now_ms) {
    ub_mavroute_flow_t *f = find_flow(rt, link, sysid, msgid);
    for (int i = 0; f == NULL && i < UB_MAVROUTE_MAX_FLOWS; i++)
        if (rt->flows[i].link == 0) f = &rt->flows[i];
    if (f == NULL) {
        rt->c.flows_full++;
        return;
    }
    f->link = (uint8_t)(link + 1);
    f->sysid = sysid;
    f->msgid = msgid;
    f->interval_us = us;
    f->next_ms = now_ms;
}

/* The fastest interval the links of mask `links` ask of (sysid, msgid): > 0; 0 when one of them asked the
 * default (or none asked); -1 when every one that asked wants none. */
static int32_t fastest(const ub_mavroute_t *rt, uint8_t sysid, uint32_t msgid, uint32_t links) {
    int32_t best = -2;
    for (int i = 0; i < UB_MAVROUTE_MAX_FLOWS; i++) {
        const ub_mavroute_flow_t *f = &rt->flows[i];
        if (f->link == 0 || f->sysid != sysid || f->msgid != msgid || !(links & bit(f->link - 1))) continue;
        int32_t v = f->interval_us;
        if (best == -2 || (v > 0 && (best <= 0 || v < best)) || (v == 0 && best < 0)) best = v;
    }
    return best == -2 ? 0 : best;
}

/* Is `sysid` this node's autopilot (configured, or its first HEARTBEAT heard by the bridge)? */
static bool local_vehicle(const ub_mavroute_t *rt, uint8_t sysid) {
    uint8_t own = 0;
    (void)ub_mavbridge_connected(rt->br, &own, NULL);
    return rt->autopilot && own != 0 && own == sysid;
}

/* The local autopilot's message `msgid`: the fastest any link wants goes to the bridge. */
static void update_bridge(ub_mavroute_t *rt, uint8_t sysid, uint32_t msgid) {
    int32_t v = fastest(rt, sysid, msgid, ALL_LINKS);
    if (ub_mavbridge_set_flow(rt->br, msgid, v > 0 ? (uint32_t)v : 0u) < 0) return; /* not streamed: nothing to ask */
}

static void send_to_client(ub_mavroute_t *rt, int c, const uint8_t *bytes, uint16_t len) {
    if (rt->send(rt->send_user, c, bytes, len) == UB_OK) rt->c.to_clients++;
    else rt->c.send_errors++;
}

static void to_peer(ub_mavroute_t *rt, int p, const uint8_t *bytes, uint16_t len, uint64_t now_ms);

/* Answers a SET_MESSAGE_INTERVAL for the local autopilot on link `to`, as the autopilot does. */
static void answer(ub_mavroute_t *rt, const mavlink_message_t *req, uint16_t command, uint8_t result, int to,
                   uint64_t now_ms) {
    uint8_t sysid = 0, compid = 0;
    (void)ub_mavbridge_connected(rt->br, &sysid, &compid);
    mavlink_command_ack_t ack;
    memset(&ack, 0, sizeof ack);
    ack.command = command;
    ack.result = result;
    ack.target_system = req->sysid;
    ack.target_component = req->compid;
    mavlink_message_t *o = &rt->out;
    memset(o, 0, sizeof *o);
    memcpy(_MAV_PAYLOAD_NON_CONST(o), &ack, sizeof ack);
    o->msgid = MAVLINK_MSG_ID_COMMAND_ACK;
    o->magic = MAVLINK_STX;
    o->sysid = sysid;
    o->compid = compid;
    o->seq = rt->ack_seq++;
    bool sign = rt->gcs_sign && is_client_link(to);
    uint16_t len = reencode(rt, o, sign, rt->ctx, now_ms);
    if (is_client_link(to)) send_to_client(rt, to - UB_MAVROUTE_LINK_CLIENT0, rt->ctx, len);
    else if (is_peer_link(to)) to_peer(rt, to - UB_MAVROUTE_LINK_PEER0, rt->ctx, len, now_ms);
}

/* A rate request from link `from` (a ground station or a peer) for system `target`. The local autopilot's:
 * recorded, answered, never forwarded (returns true). A peer's vehicle, from a ground station: recorded
 * for that ground station, and `m` rewritten to the fastest any of them wants (returns false: routed on). */
static bool rates(ub_mavroute_t *rt, mavlink_message_t *m, int from, uint8_t target, uint64_t now_ms) {
    uint32_t msgids[MAX_ASKED];
    int32_t us[MAX_ASKED];
    uint16_t command;
    if (from == UB_MAVROUTE_LINK_AUTOPILOT || target == 0) return false;
    int n = rate_request(m, msgids, us, &command);
    if (n == 0) return false;
    if (local_vehicle(rt, target)) {
        bool ok = true;
        for (int i = 0; i < n; i++) {
            set_flow(rt, from, target, msgids[i], us[i], now_ms);
            update_bridge(rt, target, msgids[i]);
            ok = ok && ub_mavbridge_find(rt->br, msgids[i]) >= 0;
        }
        rt->c.rate_requests++;
        if (command != 0) answer(rt, m, command, ok ? MAV_RESULT_ACCEPTED : MAV_RESULT_UNSUPPORTED, from, now_ms);
        return true;
    }
    if (!is_client_link(from)) return false;
    uint32_t clients = 0;
    for (int c = 0; c < UB_MAVROUTE_MAX_CLIENTS; c++) clients |= bit(UB_MAVROUTE_LINK_CLIENT0 + c);
    for (int i = 0; i < n; i++) set_flow(rt, from, target, msgids[i], us[i], now_ms);
    rt->c.rate_forwarded++;
    if (command != 0) {
        /* The peer records one rate for this door: the fastest its ground stations want. param2 is bytes
         * 4..7 of both COMMAND_LONG and COMMAND_INT (MAVLink orders the floats first). */
        float v = (float)fastest(rt, target, msgids[0], clients);
        memcpy((uint8_t *)_MAV_PAYLOAD_NON_CONST(m) + 4, &v, sizeof v);
        (void)reencode(rt, m, false, rt->tx, now_ms);
        *m = rt->out;
    } else {
        /* REQUEST_DATA_STREAM: the fastest its ground stations want of the stream's (first) message, in whole
         * Hz rounded up; left as asked when one of them wants the default (the message cannot say it). */
        int32_t v = fastest(rt, target, msgids[0], clients);
        mavlink_request_data_stream_t r;
        memcpy(&r, _MAV_PAYLOAD(m), sizeof r);
        if (v < 0) {
            r.start_stop = 0;
        } else if (v > 0) {
            uint32_t hz = (1000000u + (uint32_t)v - 1u) / (uint32_t)v;
            r.req_message_rate = (uint16_t)(hz > 65535u ? 65535u : hz);
            r.start_stop = 1;
        }
        memcpy((uint8_t *)_MAV_PAYLOAD_NON_CONST(m), &r, sizeof r);
        (void)reencode(rt, m, false, rt->tx, now_ms);
        *m = rt->out;
    }
    return false;
}

/* May message `m` (a vehicle's broadcast) go to link `to` now, given the interval that link asked? A
 * generic cell rate algorithm: `next_ms` is the theoretical time of the next frame; one may come early by a
 * tolerance of one interval, at least 10 ms (the clock's millisecond and the links' jitter: at 1 kHz
 * asked, two frames within one millisecond are no excess), so the long-run rate never exceeds the asked one. */
static bool rate_allows(ub_mavroute_t *rt, const mavlink_message_t *m, int to, uint64_t now_ms) {
    ub_mavroute_flow_t *f = find_flow(rt, to, m->sysid, m->msgid);
    if (f == NULL || f->interval_us == 0) return true;
    uint64_t iv = (uint64_t)f->interval_us / 1000u;
    if (iv == 0) iv = 1;
    uint64_t tolerance = iv > 10 ? iv : 10;
    if (f->interval_us < 0 || now_ms + tolerance < f->next_ms) {
        rt->c.rate_limited++;
        return false;
    }
    f->next_ms = (f->next_ms > now_ms ? f->next_ms : now_ms) + iv;
    return true;
}

static void forget_link_flows(ub_mavroute_t *rt, int link) {
    for (int i = 0; i < UB_MAVROUTE_MAX_FLOWS; i++) {
        ub_mavroute_flow_t *f = &rt->flows[i];
        if (f->link != (uint8_t)(link + 1)) continue;
        f->link = 0;
        if (local_vehicle(rt, f->sysid)) update_bridge(rt, f->sysid, f->msgid);
    }
}

static void to_peer(ub_mavroute_t *rt, int p, const uint8_t *bytes, uint16_t len, uint64_t now_ms) {
    rt->frame->len = len;
    memcpy(rt->frame->bytes, bytes, len);
    if (ub_node_send_data(rt->node, rt->entity, (uint32_t)rt->frame_instance, rt->peers[p], now_ms) >= 0)
        rt->c.to_peers++;
    else
        rt->c.send_errors++;
}

static void route(ub_mavroute_t *rt, mavlink_message_t *m, int from, uint64_t now_ms) {
    if (!learn(rt, m, from)) return;
    uint8_t target = target_of(m);
    if (rates(rt, m, from, target, now_ms)) return;
    uint32_t mask = target == 0 ? ALL_LINKS : rt->seen[target];
    mask &= ~bit(from);
    if (target != 0 && rt->seen[target] == 0) {
        rt->c.no_target++;
        return;
    }
    uint16_t len = mavlink_msg_to_send_buffer(rt->tx, m);
    /* Only a vehicle's broadcasts (its telemetry) are held to the rates links asked. */
    bool telemetry = target == 0 && !is_client_link(from) && !rt->gcs[m->sysid];
    /* The autopilot: what is addressed to it, and ground stations' broadcasts (HEARTBEAT...: from a local ground
     * station, or from a system whose HEARTBEAT says GCS), never other vehicles' broadcast telemetry.
     * Only when the bridge forwards commands (the node's write policy). */
    if (rt->autopilot && (mask & bit(UB_MAVROUTE_LINK_AUTOPILOT)) && from != UB_MAVROUTE_LINK_AUTOPILOT &&
        (target != 0 || is_client_link(from) || rt->gcs[m->sysid])) {
        if (!rt->br->opt.commands) rt->c.commands_off++;
        else if (ub_mavbridge_forward(rt->br, m, now_ms) == UB_OK) rt->c.to_autopilot++;
        else rt->c.send_errors++;
    }
    uint16_t clen = 0;
    for (int c = 0; c < UB_MAVROUTE_MAX_CLIENTS; c++) {
        if (!rt->client_up[c] || !(mask & bit(UB_MAVROUTE_LINK_CLIENT0 + c))) continue;
        if (telemetry && !rate_allows(rt, m, UB_MAVROUTE_LINK_CLIENT0 + c, now_ms)) continue;
        if (!rt->gcs_sign) {
            send_to_client(rt, c, rt->tx, len);
            continue;
        }
        /* Signed with the endpoint's key once for every ground station (a MAVLink 1 frame cannot be). */
        if (clen == 0) clen = reencode(rt, m, m->magic != MAVLINK_STX_MAVLINK1, rt->ctx, now_ms);
        if (clen != 0) send_to_client(rt, c, rt->ctx, clen);
    }
    /* The bus does the multi-hop part: what came from a peer goes to local links only (no loops). */
    if (is_peer_link(from)) return;
    for (int p = 0; p < rt->n_peers; p++) {
        if (!(mask & bit(UB_MAVROUTE_LINK_PEER0 + p))) continue;
        /* A vehicle's broadcast goes only to a peer heard lately (someone listens there). */
        bool listening = rt->peer_heard_ms[p] != 0 && now_ms - rt->peer_heard_ms[p] <= UB_MAVROUTE_PEER_TIMEOUT_MS;
        if (from == UB_MAVROUTE_LINK_AUTOPILOT && target == 0 && !listening) continue;
        if (telemetry && !rate_allows(rt, m, UB_MAVROUTE_LINK_PEER0 + p, now_ms)) continue;
        to_peer(rt, p, rt->tx, len, now_ms);
    }
}

static void on_autopilot(void *user, const mavlink_message_t *m, uint64_t now_ms) {
    ub_mavroute_t *rt = user;
    rt->c.from_autopilot++;
    rt->msg = *m; /* route() may rewrite what it routes: never the bridge's own copy */
    route(rt, &rt->msg, UB_MAVROUTE_LINK_AUTOPILOT, now_ms);
}

static void count_gcs_refusal(ub_mavroute_t *rt, const mavlink_message_t *m) {
    if (!(m->incompat_flags & MAVLINK_IFLAG_SIGNED)) rt->c.gcs_unsigned++;
    else if (rt->gsign.last_status == MAVLINK_SIGNING_STATUS_REPLAY ||
             rt->gsign.last_status == MAVLINK_SIGNING_STATUS_OLD_TIMESTAMP)
        rt->c.gcs_replayed++;
    else rt->c.gcs_bad_signature++;
}

int ub_mavroute_from_client(ub_mavroute_t *rt, int client, const uint8_t *bytes, size_t len, uint64_t now_ms) {
    if (rt == NULL || client < 0 || client >= UB_MAVROUTE_MAX_CLIENTS || (bytes == NULL && len > 0))
        return UB_ERR_INVAL;
    int routed = 0;
    mavlink_status_t *st = &rt->cstatus[client];
    if (rt->gcs_sign) {
        st->signing = &rt->gsign;
        st->signing_streams = &rt->gstreams;
    }
    for (size_t i = 0; i < len; i++) {
        uint8_t r = mavlink_frame_char_buffer(&rt->cbuf[client], st, bytes[i], &rt->msg, NULL);
        rt->c.client_parse_errors += st->parse_error;
        st->parse_error = 0;
        if (r == MAVLINK_FRAMING_INCOMPLETE) continue;
        if (r == MAVLINK_FRAMING_BAD_SIGNATURE) {
            count_gcs_refusal(rt, &rt->msg);
            continue;
        }
        if (r != MAVLINK_FRAMING_OK) {
            rt->c.client_parse_errors++;
            continue;
        }
        /* A ground station gets frames once it sent a valid one (with signing: a well signed one): a spoofed
         * address without the key learns nothing and keeps no place. */
        rt->client_up[client] = 1;
        rt->c.from_clients++;
        route(rt, &rt->msg, UB_MAVROUTE_LINK_CLIENT0 + client, now_ms);
        routed++;
    }
    return routed;
}

bool ub_mavroute_client_up(const ub_mavroute_t *rt, int client) {
    return rt != NULL && client >= 0 && client < UB_MAVROUTE_MAX_CLIENTS && rt->client_up[client];
}

void ub_mavroute_set_gcs_key(ub_mavroute_t *rt, const uint8_t key[32], uint8_t link_id, uint64_t timestamp,
                             uint64_t now_ms) {
    if (rt == NULL || key == NULL) return;
    memset(&rt->gsign, 0, sizeof rt->gsign);
    memset(&rt->gstreams, 0, sizeof rt->gstreams);
    memcpy(rt->gsign.secret_key, key, sizeof rt->gsign.secret_key);
    rt->gsign.link_id = link_id;
    rt->gsign.timestamp = timestamp;
    rt->gsign.flags = MAVLINK_SIGNING_FLAG_SIGN_OUTGOING;
    rt->gsign.accept_unsigned_callback = NULL; /* strict: nothing unsigned gets in */
    rt->gsign_t0 = timestamp;
    rt->gsign_base_ms = now_ms;
    rt->gcs_sign = true;
}

void ub_mavroute_tick(ub_mavroute_t *rt, uint64_t now_ms) {
    if (rt == NULL || now_ms < rt->next_expiry_ms) return;
    rt->next_expiry_ms = now_ms + 1000u;
    for (int p = 0; p < rt->n_peers; p++) {
        bool heard = rt->peer_heard_ms[p] != 0 && now_ms - rt->peer_heard_ms[p] <= UB_MAVROUTE_PEER_TIMEOUT_MS;
        if (!heard) forget_link_flows(rt, UB_MAVROUTE_LINK_PEER0 + p);
    }
}

void ub_mavroute_client_gone(ub_mavroute_t *rt, int client) {
    if (rt == NULL || client < 0 || client >= UB_MAVROUTE_MAX_CLIENTS) return;
    rt->client_up[client] = 0;
    memset(&rt->cstatus[client], 0, sizeof rt->cstatus[client]);
    for (int s = 0; s < 256; s++) rt->seen[s] &= ~bit(UB_MAVROUTE_LINK_CLIENT0 + client);
    forget_link_flows(rt, UB_MAVROUTE_LINK_CLIENT0 + client);
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
