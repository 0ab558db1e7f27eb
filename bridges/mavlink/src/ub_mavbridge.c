/*
 * The MAVLink bridge core (ub_mavbridge.h). MAVLink framing, checksums and signing are the
 * generated headers' own (mavlink_frame_char_buffer, mavlink_finalize_message_buffer) over state in
 * ub_mavbridge_t: the channel-array helpers (mavlink_parse_char, *_chan) and their statics are
 * never used. Payloads are copied between MAVLink messages and the directory structs as MAVLink's
 * own decode/encode do: the C structs are the MAVLink payload in wire order (little-endian host).
 */
#include "ub_mavbridge.h"

#include <string.h>

#include "ub/ub_catalogue.h"
#include "ub/ub_pubsub.h"

#if MAVLINK_NEED_BYTE_SWAP
#error "ub_mavbridge copies MAVLink payloads into the message structs as they are: little-endian hosts only"
#endif

#define DEFAULT_SYSID 255
#define DEFAULT_COMPID MAV_COMP_ID_MISSIONPLANNER
#define NO_REFUSAL UINT32_MAX
#define SCAN_MS 100u /* how often the subscriptions' periods are compared with what the autopilot was asked */

/* Messages that are answers or events, never streams: asking the autopilot for an interval makes no
 * sense (it would answer DENIED), so subscribing to them asks for nothing. */
static const uint32_t k_not_streamed[] = {
    MAVLINK_MSG_ID_HEARTBEAT,        MAVLINK_MSG_ID_PARAM_VALUE,         MAVLINK_MSG_ID_MISSION_ITEM,
    MAVLINK_MSG_ID_MISSION_REQUEST,  MAVLINK_MSG_ID_MISSION_COUNT,       MAVLINK_MSG_ID_MISSION_ACK,
    MAVLINK_MSG_ID_MISSION_REQUEST_INT, MAVLINK_MSG_ID_MISSION_ITEM_INT, MAVLINK_MSG_ID_COMMAND_INT,
    MAVLINK_MSG_ID_COMMAND_LONG,     MAVLINK_MSG_ID_COMMAND_ACK,         MAVLINK_MSG_ID_STATUSTEXT,
};

/* Writes whose answers go straight back to the writer (besides COMMAND_ACK, matched by command id). */
typedef struct reply_rule {
    uint32_t write;
    uint32_t replies[3];
} reply_rule_t;

static const reply_rule_t k_replies[] = {
    {MAVLINK_MSG_ID_MISSION_COUNT, {MAVLINK_MSG_ID_MISSION_REQUEST_INT, MAVLINK_MSG_ID_MISSION_REQUEST, MAVLINK_MSG_ID_MISSION_ACK}},
    {MAVLINK_MSG_ID_MISSION_ITEM_INT, {MAVLINK_MSG_ID_MISSION_REQUEST_INT, MAVLINK_MSG_ID_MISSION_REQUEST, MAVLINK_MSG_ID_MISSION_ACK}},
    {MAVLINK_MSG_ID_MISSION_ITEM, {MAVLINK_MSG_ID_MISSION_REQUEST_INT, MAVLINK_MSG_ID_MISSION_REQUEST, MAVLINK_MSG_ID_MISSION_ACK}},
    {MAVLINK_MSG_ID_MISSION_REQUEST_LIST, {MAVLINK_MSG_ID_MISSION_COUNT, 0, 0}},
    {MAVLINK_MSG_ID_MISSION_REQUEST_INT, {MAVLINK_MSG_ID_MISSION_ITEM_INT, MAVLINK_MSG_ID_MISSION_ACK, 0}},
    {MAVLINK_MSG_ID_MISSION_REQUEST, {MAVLINK_MSG_ID_MISSION_ITEM, MAVLINK_MSG_ID_MISSION_ACK, 0}},
    {MAVLINK_MSG_ID_MISSION_CLEAR_ALL, {MAVLINK_MSG_ID_MISSION_ACK, 0, 0}},
    {MAVLINK_MSG_ID_MISSION_SET_CURRENT, {MAVLINK_MSG_ID_MISSION_CURRENT, 0, 0}},
    {MAVLINK_MSG_ID_PARAM_REQUEST_READ, {MAVLINK_MSG_ID_PARAM_VALUE, 0, 0}},
    {MAVLINK_MSG_ID_PARAM_REQUEST_LIST, {MAVLINK_MSG_ID_PARAM_VALUE, 0, 0}},
    {MAVLINK_MSG_ID_PARAM_SET, {MAVLINK_MSG_ID_PARAM_VALUE, 0, 0}},
};

#define COUNT_OF(a) (sizeof(a) / sizeof((a)[0]))

uint64_t ub_mavbridge_signing_time(uint64_t unix_us) {
    const uint64_t epoch_2015_us = 1420070400ull * 1000000ull;
    return unix_us > epoch_2015_us ? (unix_us - epoch_2015_us) / 10u : 0u;
}

int ub_mavbridge_find(const ub_mavbridge_t *br, uint32_t msgid) {
    if (br == NULL || br->n_dirs == 0) return UB_ERR_NOTFOUND;
    size_t lo = 0, hi = br->n_dirs;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (br->dirs[mid].msgid < msgid) lo = mid + 1;
        else hi = mid;
    }
    return lo < br->n_dirs && br->dirs[lo].msgid == msgid ? (int)lo : UB_ERR_NOTFOUND;
}

/* The directory index of catalogue instance `instance`, or -1. */
static int dir_of_instance(const ub_mavbridge_t *br, uint32_t instance) {
    size_t lo = 0, hi = br->n_dirs;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if ((uint32_t)br->st[br->by_instance[mid]].instance < instance) lo = mid + 1;
        else hi = mid;
    }
    if (lo < br->n_dirs && (uint32_t)br->st[br->by_instance[lo]].instance == instance) return br->by_instance[lo];
    return -1;
}

static bool streamed(uint32_t msgid) {
    for (size_t i = 0; i < COUNT_OF(k_not_streamed); i++)
        if (k_not_streamed[i] == msgid) return false;
    return true;
}

static void defaults(ub_mavbridge_options_t *o) {
    if (o->sysid == 0) o->sysid = DEFAULT_SYSID;
    if (o->compid == 0) o->compid = DEFAULT_COMPID;
    if (o->heartbeat_ms == 0) o->heartbeat_ms = 1000;
    if (o->link_timeout_ms == 0) o->link_timeout_ms = 3500;
    if (o->command_retry_ms == 0) o->command_retry_ms = 500;
    if (o->command_retries == 0) o->command_retries = 5;
    if (o->retry_backoff_ms == 0) o->retry_backoff_ms = 5000;
    if (o->reply_window_ms == 0) o->reply_window_ms = 5000;
    if (o->status_ms == 0) o->status_ms = 1000;
}

int ub_mavbridge_init(ub_mavbridge_t *br, ub_node_t *node, int entity, const ub_mav_dir_t *dirs, size_t n_dirs,
                      struct ub_mavbridge_status *status, const ub_mavbridge_options_t *opt, ub_mav_write_fn write,
                      void *write_user, uint64_t now_ms) {
    if (br == NULL || node == NULL || dirs == NULL || write == NULL) return UB_ERR_INVAL;
    if (n_dirs > UB_MAVBRIDGE_MAX_DIRS) return UB_ERR_FULL;
    memset(br, 0, sizeof *br);
    if (ub_pubsub_row(node, entity, 0) == NULL) return UB_ERR_INVAL; /* not a local entity */
    br->node = node;
    br->entity = entity;
    br->dirs = dirs;
    br->n_dirs = n_dirs;
    br->write = write;
    br->write_user = write_user;
    if (opt != NULL) br->opt = *opt;
    defaults(&br->opt);
    const ub_catalogue_t *cat = node->cat;
    for (size_t d = 0; d < n_dirs; d++) {
        if (d > 0 && dirs[d].msgid <= dirs[d - 1].msgid) return UB_ERR_INVAL;
        int inst = ub_catalogue_find_name(cat, dirs[d].name);
        if (inst < 0 || dirs[d].storage == NULL) return UB_ERR_INVAL;
        int rc = ub_node_bind(node, (uint32_t)inst, dirs[d].storage);
        if (rc < 0) return rc;
        if (ub_pubsub_set_on_update(node, (uint32_t)inst, true) < 0) return UB_ERR_INVAL;
        br->st[d].instance = inst;
        br->st[d].refused_us = NO_REFUSAL;
        /* Insertion into the instance-sorted index (init only: n_dirs is a few hundred). */
        size_t k = d;
        while (k > 0 && br->st[br->by_instance[k - 1]].instance > inst) {
            br->by_instance[k] = br->by_instance[k - 1];
            k--;
        }
        br->by_instance[k] = (uint16_t)d;
    }
    br->status_instance = -1;
    if (status != NULL) {
        int inst = ub_catalogue_find_name(cat, UB_MAVBRIDGE_STATUS_NAME);
        if (inst < 0) return UB_ERR_INVAL;
        int rc = ub_node_bind(node, (uint32_t)inst, status);
        if (rc < 0) return rc;
        if (ub_pubsub_set_on_update(node, (uint32_t)inst, true) < 0) return UB_ERR_INVAL;
        memset(status, 0, sizeof *status);
        br->status = status;
        br->status_instance = inst;
    }
    if (br->opt.sign) {
        memcpy(br->signing.secret_key, br->opt.key, sizeof br->signing.secret_key);
        br->signing.link_id = br->opt.link_id;
        br->signing.timestamp = br->opt.sign_timestamp;
        br->signing.flags = MAVLINK_SIGNING_FLAG_SIGN_OUTGOING;
        br->signing.accept_unsigned_callback = NULL; /* strict: nothing unsigned gets in */
        br->rx_status.signing = &br->signing;
        br->rx_status.signing_streams = &br->streams;
        br->tx_status.signing = &br->signing;
        br->tx_status.signing_streams = &br->streams;
    }
    br->target_sysid = br->opt.target_sysid;
    br->target_compid = br->opt.target_compid;
    br->target_known = br->target_sysid != 0 && br->target_compid != 0;
    br->asking = -1;
    br->start_ms = now_ms;
    br->sign_t0_ms = now_ms;
    br->next_heartbeat_ms = now_ms;
    br->next_scan_ms = now_ms;
    br->next_status_ms = now_ms;
    return UB_OK;
}

/* ---- sending MAVLink ------------------------------------------------------------------------------ */

/* Sends `payload` (a message struct) as message `msgid` from our ids, signed when signing is on. */
static int send_message(ub_mavbridge_t *br, uint32_t msgid, const void *payload, size_t size, uint64_t now_ms) {
    const mavlink_msg_entry_t *e = mavlink_get_msg_entry(msgid);
    if (e == NULL) return UB_ERR_NOTFOUND;
    mavlink_message_t *m = &br->tx_msg;
    uint8_t *pl = (uint8_t *)_MAV_PAYLOAD_NON_CONST(m);
    size_t n = size < e->max_msg_len ? size : e->max_msg_len;
    memcpy(pl, payload, n);
    memset(pl + n, 0, (size_t)e->max_msg_len - n);
    m->msgid = msgid;
    if (br->opt.sign) {
        /* Signing time advances with the clock as well as per message (MAVLink's rule: never reused,
         * close to real time so that a restarted peer's replay window accepts us). */
        uint64_t t = br->opt.sign_timestamp + (now_ms - br->sign_t0_ms) * 100u;
        if (t > br->signing.timestamp) br->signing.timestamp = t;
    }
    (void)mavlink_finalize_message_buffer(m, br->opt.sysid, br->opt.compid, &br->tx_status, e->min_msg_len,
                                          e->max_msg_len, e->crc_extra);
    uint16_t len = mavlink_msg_to_send_buffer(br->tx, m);
    int rc = br->write(br->write_user, br->tx, len);
    if (rc == UB_OK) {
        br->c.messages_out++;
        br->c.bytes_out += len;
    } else if (rc == UB_ERR_AGAIN) {
        br->c.backpressure++;
    } else {
        br->c.send_errors++;
    }
    return rc;
}

static void send_heartbeat(ub_mavbridge_t *br, uint64_t now_ms) {
    mavlink_heartbeat_t hb;
    memset(&hb, 0, sizeof hb);
    hb.type = MAV_TYPE_GCS;
    hb.autopilot = MAV_AUTOPILOT_INVALID;
    hb.system_status = MAV_STATE_ACTIVE;
    hb.mavlink_version = 3;
    if (send_message(br, MAVLINK_MSG_ID_HEARTBEAT, &hb, sizeof hb, now_ms) == UB_OK) br->c.heartbeats_out++;
}

static void send_interval(ub_mavbridge_t *br, uint64_t now_ms) {
    mavlink_command_long_t cmd;
    memset(&cmd, 0, sizeof cmd);
    cmd.target_system = br->target_sysid;
    cmd.target_component = br->target_compid;
    cmd.command = MAV_CMD_SET_MESSAGE_INTERVAL;
    cmd.confirmation = (uint8_t)(br->tries > 255 ? 255 : br->tries);
    cmd.param1 = (float)br->dirs[br->asking].msgid;
    cmd.param2 = (float)br->asking_us; /* 0 = the autopilot's default rate */
    br->tries++;
    br->next_try_ms = now_ms + br->opt.command_retry_ms;
    br->c.intervals_sent++;
    (void)send_message(br, MAVLINK_MSG_ID_COMMAND_LONG, &cmd, sizeof cmd, now_ms);
}

/* ---- rates: the subscriptions' periods -> SET_MESSAGE_INTERVAL ----------------------------------- */

static void scan_rows(ub_mavbridge_t *br) {
    for (size_t d = 0; d < br->n_dirs; d++) br->st[d].wanted_us = 0;
    for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) {
        const ub_ps_row_t *row = ub_pubsub_row(br->node, br->entity, r);
        if (row == NULL || row->kind != UB_PS_PUBLICATION) continue;
        int d = dir_of_instance(br, row->instance);
        if (d < 0 || !streamed(br->dirs[d].msgid)) continue;
        uint64_t us = (uint64_t)row->period_ms * 1000u;
        uint32_t want = us > UINT32_MAX ? UINT32_MAX : (uint32_t)us;
        if (br->st[d].wanted_us == 0 || want < br->st[d].wanted_us) br->st[d].wanted_us = want;
    }
    /* Ground stations' rates (the front door's flows): the autopilot must send at least as fast. */
    for (size_t d = 0; d < br->n_dirs; d++) {
        uint32_t f = br->st[d].flow_us;
        if (f != 0 && (br->st[d].wanted_us == 0 || f < br->st[d].wanted_us)) br->st[d].wanted_us = f;
    }
}

int ub_mavbridge_set_flow(ub_mavbridge_t *br, uint32_t msgid, uint32_t us) {
    int d = ub_mavbridge_find(br, msgid);
    if (d < 0 || !streamed(msgid)) return UB_ERR_NOTFOUND;
    br->st[d].flow_us = us;
    br->next_scan_ms = 0; /* looked at on the next tick, not within SCAN_MS */
    return UB_OK;
}

/* What directory `d` needs the autopilot to be told, if anything: its wanted interval, or 0 (default
 * rate) once nobody wants it any more. */
static bool needs_request(const ub_mav_dir_state_t *s, uint64_t now_ms, uint32_t *value) {
    if ((s->wanted_us == s->granted_us && !s->resend) || now_ms < s->retry_after_ms) return false;
    if (s->wanted_us == s->refused_us) return false;
    *value = s->wanted_us;
    return true;
}

static void manage_intervals(ub_mavbridge_t *br, uint64_t now_ms) {
    if (!br->target_known || !br->connected) return;
    if (br->asking >= 0) {
        if (now_ms < br->next_try_ms) return;
        if (br->tries < br->opt.command_retries) {
            send_interval(br, now_ms);
            return;
        }
        /* Unanswered: leave it for the backoff, then ask again. */
        br->c.intervals_timeout++;
        br->st[br->asking].retry_after_ms = now_ms + br->opt.retry_backoff_ms;
        br->asking = -1;
    }
    for (size_t k = 0; k < br->n_dirs; k++) {
        size_t d = (br->scan_from + k) % br->n_dirs;
        uint32_t value;
        if (!needs_request(&br->st[d], now_ms, &value)) continue;
        br->scan_from = d + 1;
        br->asking = (int32_t)d;
        br->asking_us = value;
        br->tries = 0;
        send_interval(br, now_ms);
        return;
    }
}

static void on_interval_ack(ub_mavbridge_t *br, uint8_t result, uint64_t now_ms) {
    if (br->asking < 0 || result == MAV_RESULT_IN_PROGRESS) return;
    ub_mav_dir_state_t *s = &br->st[br->asking];
    if (result == MAV_RESULT_ACCEPTED) {
        s->granted_us = br->asking_us;
        s->resend = 0;
        s->refused_us = NO_REFUSAL;
        br->c.intervals_granted++;
    } else if (result == MAV_RESULT_TEMPORARILY_REJECTED) {
        s->retry_after_ms = now_ms + br->opt.command_retry_ms;
    } else {
        s->refused_us = br->asking_us;
        s->resend = 0;
        br->c.intervals_refused++;
    }
    br->asking = -1;
}

/* ---- replies to writers ---------------------------------------------------------------------------- */

/* Sends directory `d` (just updated) to `writer` unless a subscription of its already carries it. */
static bool reply_to(ub_mavbridge_t *br, int d, const uint8_t writer[UB_ENTITY_ID_LEN], uint64_t now_ms) {
    uint32_t inst = (uint32_t)br->st[d].instance;
    if (ub_pubsub_find(br->node, br->entity, UB_PS_PUBLICATION, inst, writer) >= 0) return false;
    return ub_node_send_data(br->node, br->entity, inst, writer, now_ms) >= 0;
}

static void remember_command(ub_mavbridge_t *br, uint16_t command, const uint8_t writer[UB_ENTITY_ID_LEN],
                             uint64_t now_ms) {
    int slot = -1;
    for (int i = 0; i < UB_MAVBRIDGE_MAX_PENDING; i++) {
        bool expired = br->pending[i].in_use && now_ms >= br->pending[i].until_ms;
        if (br->pending[i].in_use && !expired && br->pending[i].command == command) {
            slot = i; /* the latest writer of a command gets its ACK */
            break;
        }
        if (slot < 0 && (!br->pending[i].in_use || expired)) slot = i;
    }
    if (slot < 0) {
        br->c.pending_full++;
        return;
    }
    br->pending[slot].in_use = 1;
    br->pending[slot].command = command;
    memcpy(br->pending[slot].writer, writer, UB_ENTITY_ID_LEN);
    br->pending[slot].until_ms = now_ms + br->opt.reply_window_ms;
}

static void remember_replies(ub_mavbridge_t *br, uint32_t msgid, const uint8_t writer[UB_ENTITY_ID_LEN],
                             uint64_t now_ms) {
    for (size_t k = 0; k < COUNT_OF(k_replies); k++) {
        if (k_replies[k].write != msgid) continue;
        for (size_t j = 0; j < COUNT_OF(k_replies[k].replies) && k_replies[k].replies[j] != 0; j++) {
            uint32_t reply = k_replies[k].replies[j];
            int slot = -1;
            for (int i = 0; i < UB_MAVBRIDGE_MAX_ROUTES; i++) {
                if (br->routes[i].msgid == reply || (slot < 0 && (br->routes[i].msgid == 0 ||
                                                                  now_ms >= br->routes[i].until_ms))) {
                    slot = i;
                    if (br->routes[i].msgid == reply) break;
                }
            }
            if (slot < 0) continue; /* cannot happen: more routes than reply types */
            br->routes[slot].msgid = reply;
            memcpy(br->routes[slot].writer, writer, UB_ENTITY_ID_LEN);
            br->routes[slot].until_ms = now_ms + br->opt.reply_window_ms;
        }
    }
}

static void route_command_ack(ub_mavbridge_t *br, int d, const mavlink_command_ack_t *ack, uint64_t now_ms) {
    if (ack->command == MAV_CMD_SET_MESSAGE_INTERVAL && br->asking >= 0) {
        on_interval_ack(br, ack->result, now_ms);
        return;
    }
    for (int i = 0; i < UB_MAVBRIDGE_MAX_PENDING; i++) {
        if (!br->pending[i].in_use || br->pending[i].command != ack->command) continue;
        if (now_ms >= br->pending[i].until_ms) {
            br->pending[i].in_use = 0;
            continue;
        }
        if (reply_to(br, d, br->pending[i].writer, now_ms)) br->c.acks_routed++;
        /* IN_PROGRESS is followed by more ACKs: keep the writer until the final result. */
        if (ack->result != MAV_RESULT_IN_PROGRESS) br->pending[i].in_use = 0;
        return;
    }
}

static void route_reply(ub_mavbridge_t *br, int d, uint64_t now_ms) {
    uint32_t msgid = br->dirs[d].msgid;
    for (int i = 0; i < UB_MAVBRIDGE_MAX_ROUTES; i++) {
        if (br->routes[i].msgid != msgid || now_ms >= br->routes[i].until_ms) continue;
        if (reply_to(br, d, br->routes[i].writer, now_ms)) br->c.replies_routed++;
        return;
    }
}

/* ---- receiving MAVLink ------------------------------------------------------------------------------ */

static void heard_autopilot(ub_mavbridge_t *br, uint64_t now_ms) {
    br->last_heartbeat_ms = now_ms;
    br->c.autopilot_heartbeats++;
    if (!br->connected) {
        br->connected = 1;
        br->c.link_up++;
        /* A returning autopilot may have rebooted with its default rates, or kept ours: tell it again
         * every rate asked for or changed before. */
        for (size_t d = 0; d < br->n_dirs; d++) {
            ub_mav_dir_state_t *s = &br->st[d];
            s->resend = s->wanted_us != 0 || s->granted_us != 0;
            s->refused_us = NO_REFUSAL;
            s->retry_after_ms = 0;
        }
        br->asking = -1;
    }
}

/* Is `m` from the autopilot? Adopts the first autopilot heard when no target was configured. */
static bool from_target(ub_mavbridge_t *br, const mavlink_message_t *m) {
    if (br->target_known) return m->sysid == br->target_sysid && m->compid == br->target_compid;
    if (m->msgid != MAVLINK_MSG_ID_HEARTBEAT) return false;
    mavlink_heartbeat_t hb;
    memcpy(&hb, _MAV_PAYLOAD(m), sizeof hb); /* zero-filled to full length by the parser */
    if (hb.autopilot == MAV_AUTOPILOT_INVALID || hb.type == MAV_TYPE_GCS) return false;
    if (br->opt.target_sysid != 0 && m->sysid != br->opt.target_sysid) return false;
    if (br->opt.target_compid != 0 && m->compid != br->opt.target_compid) return false;
    br->target_sysid = m->sysid;
    br->target_compid = m->compid;
    br->target_known = 1;
    return true;
}

/* Losses by MAVLink sequence. A jump is counted only when the next message continues from it: a single
 * forged (or corrupted) sequence number would otherwise add up to 255 losses, and a forger sending one
 * message a second inflated `lost` by tens of thousands. A jump the next message does not continue is
 * an outlier (counted as such); the stream's own sequence goes on. */
static void count_sequence(ub_mavbridge_t *br, uint8_t seq) {
    if (!br->seq_known) {
        br->seq_known = 1;
        br->last_seq = seq;
        return;
    }
    if (br->jump_pending) {
        br->jump_pending = 0;
        if (seq == (uint8_t)(br->jump_seq + 1u)) {
            br->c.lost += br->jump_gap; /* confirmed: the stream really jumped */
            br->last_seq = seq;
            return;
        }
        br->c.seq_outliers++;
    }
    if (seq == (uint8_t)(br->last_seq + 1u)) {
        br->last_seq = seq;
        return;
    }
    br->jump_pending = 1;
    br->jump_seq = seq;
    br->jump_gap = (uint8_t)(seq - (uint8_t)(br->last_seq + 1u));
}

static void accept_message(ub_mavbridge_t *br, const mavlink_message_t *m, uint64_t now_ms) {
    bool known = br->target_known;
    if (!from_target(br, m)) {
        if (known) br->c.other_source++;
        else br->c.unidentified++;
        return;
    }
    br->c.messages_in++;
    count_sequence(br, m->seq);
    if (br->tap != NULL) br->tap(br->tap_user, m, now_ms);
    if (m->msgid == MAVLINK_MSG_ID_HEARTBEAT) heard_autopilot(br, now_ms);
    int d = ub_mavbridge_find(br, m->msgid);
    if (d < 0) {
        br->c.no_directory++;
        return;
    }
    const mavlink_msg_entry_t *e = mavlink_get_msg_entry(m->msgid);
    size_t wire = e != NULL ? e->max_msg_len : m->len;
    size_t size = br->dirs[d].size;
    size_t n = size < wire ? size : wire;
    /* The parser zero-filled the payload up to the message's full length (MAVLink 2 trims zeros). */
    memcpy(br->dirs[d].storage, _MAV_PAYLOAD(m), n);
    memset((uint8_t *)br->dirs[d].storage + n, 0, size - n);
    ub_mav_dir_state_t *s = &br->st[d];
    s->rx++;
    s->last_rx_ms = now_ms;
    int sent = ub_pubsub_updated(br->node, br->entity, (uint32_t)s->instance, now_ms);
    if (sent > 0) br->c.updates_sent += (uint64_t)sent;
    if (m->msgid == MAVLINK_MSG_ID_COMMAND_ACK) {
        route_command_ack(br, d, (const mavlink_command_ack_t *)br->dirs[d].storage, now_ms);
    } else {
        route_reply(br, d, now_ms);
    }
}

static void count_refusal(ub_mavbridge_t *br, const mavlink_message_t *m) {
    if (!(m->incompat_flags & MAVLINK_IFLAG_SIGNED)) {
        br->c.unsigned_refused++;
        return;
    }
    switch (br->signing.last_status) {
    case MAVLINK_SIGNING_STATUS_REPLAY:
    case MAVLINK_SIGNING_STATUS_OLD_TIMESTAMP: br->c.replayed++; break;
    case MAVLINK_SIGNING_STATUS_TOO_MANY_STREAMS: br->c.too_many_streams++; break;
    default: br->c.bad_signature++; break;
    }
}

int ub_mavbridge_rx(ub_mavbridge_t *br, const uint8_t *bytes, size_t len, uint64_t now_ms) {
    if (br == NULL || (bytes == NULL && len > 0)) return UB_ERR_INVAL;
    br->c.bytes_in += len;
    int accepted = 0;
    for (size_t i = 0; i < len; i++) {
        uint8_t r = mavlink_frame_char_buffer(&br->rx_buf, &br->rx_status, bytes[i], &br->rx_msg, NULL);
        br->c.parse_errors += br->rx_status.parse_error;
        br->rx_status.parse_error = 0;
        if (r == MAVLINK_FRAMING_INCOMPLETE) continue;
        if (r == MAVLINK_FRAMING_BAD_CRC) {
            br->c.bad_crc++;
        } else if (r == MAVLINK_FRAMING_BAD_SIGNATURE) {
            count_refusal(br, &br->rx_msg);
        } else {
            uint64_t before = br->c.messages_in;
            accept_message(br, &br->rx_msg, now_ms);
            accepted += br->c.messages_in != before;
        }
    }
    return accepted;
}

void ub_mavbridge_set_tap(ub_mavbridge_t *br, ub_mav_tap_fn fn, void *user) {
    if (br == NULL) return;
    br->tap = fn;
    br->tap_user = user;
}

int ub_mavbridge_forward(ub_mavbridge_t *br, const mavlink_message_t *m, uint64_t now_ms) {
    if (br == NULL || m == NULL) return UB_ERR_INVAL;
    uint16_t len;
    if (br->opt.sign) {
        /* The autopilot takes only messages signed with the key: sign the ground station's message
         * as the bridge's own (the GCS need not hold the vehicle's key; the bus authenticated it). */
        const mavlink_msg_entry_t *e = mavlink_get_msg_entry(m->msgid);
        if (e == NULL) return UB_ERR_NOTFOUND;
        return send_message(br, m->msgid, _MAV_PAYLOAD(m), e->max_msg_len, now_ms);
    }
    len = mavlink_msg_to_send_buffer(br->tx, m);
    int rc = br->write(br->write_user, br->tx, len);
    if (rc == UB_OK) {
        br->c.messages_out++;
        br->c.bytes_out += len;
    } else if (rc == UB_ERR_AGAIN) {
        br->c.backpressure++;
    } else {
        br->c.send_errors++;
    }
    return rc;
}

/* ---- writes from entities --------------------------------------------------------------------------- */

void ub_mavbridge_on_deliver(void *user, int entity, uint32_t instance, const ub_frame_header_t *h, uint64_t now_ms) {
    ub_mavbridge_t *br = user;
    if (br == NULL || entity != br->entity) return;
    int d = dir_of_instance(br, instance);
    if (d < 0) {
        br->c.writes_ignored++;
        return;
    }
    if (!br->opt.commands) {
        br->c.commands_off++;
        return;
    }
    const ub_mav_dir_t *dir = &br->dirs[d];
    if (send_message(br, dir->msgid, dir->storage, dir->size, now_ms) != UB_OK) {
        br->c.commands_failed++;
        return;
    }
    br->c.commands_forwarded++;
    if (dir->msgid == MAVLINK_MSG_ID_COMMAND_LONG) {
        remember_command(br, ((const mavlink_command_long_t *)dir->storage)->command, h->src_id, now_ms);
    } else if (dir->msgid == MAVLINK_MSG_ID_COMMAND_INT) {
        remember_command(br, ((const mavlink_command_int_t *)dir->storage)->command, h->src_id, now_ms);
    } else if (dir->msgid == MAVLINK_MSG_ID_SET_MODE) {
        remember_command(br, MAVLINK_MSG_ID_SET_MODE, h->src_id, now_ms); /* ArduPilot ACKs SET_MODE so */
    } else {
        remember_replies(br, dir->msgid, h->src_id, now_ms);
    }
}

/* ---- time ----------------------------------------------------------------------------------------- */

static uint32_t u32(uint64_t v) { return (uint32_t)v; }

static void update_status(ub_mavbridge_t *br, uint64_t now_ms) {
    struct ub_mavbridge_status *s = br->status;
    const ub_mavbridge_counters_t *c = &br->c;
    s->uptime_ms = u32(now_ms - br->start_ms);
    s->autopilot_sysid = br->target_sysid;
    s->autopilot_compid = br->target_compid;
    s->connected = br->connected;
    s->signing = br->opt.sign ? 1 : 0;
    s->messages_in = u32(c->messages_in);
    s->messages_out = u32(c->messages_out);
    s->lost = u32(c->lost);
    s->bad_crc = u32(c->bad_crc);
    s->bad_signature = u32(c->unsigned_refused + c->bad_signature + c->replayed + c->too_many_streams);
    s->other_source = u32(c->other_source);
    s->commands_forwarded = u32(c->commands_forwarded);
    s->commands_refused = u32(c->commands_off + c->writes_ignored + c->commands_failed);
    s->intervals_granted = u32(c->intervals_granted);
    s->intervals_refused = u32(c->intervals_refused + c->intervals_timeout);
    s->link_lost = u32(c->link_lost);
    int sent = ub_pubsub_updated(br->node, br->entity, (uint32_t)br->status_instance, now_ms);
    if (sent > 0) br->c.updates_sent += (uint64_t)sent;
}

void ub_mavbridge_tick(ub_mavbridge_t *br, uint64_t now_ms) {
    if (br == NULL) return;
    if (now_ms >= br->next_heartbeat_ms) {
        send_heartbeat(br, now_ms);
        br->next_heartbeat_ms += br->opt.heartbeat_ms;
        if (br->next_heartbeat_ms <= now_ms) br->next_heartbeat_ms = now_ms + br->opt.heartbeat_ms;
    }
    if (br->connected && now_ms - br->last_heartbeat_ms > br->opt.link_timeout_ms) {
        br->connected = 0;
        br->c.link_lost++;
        br->asking = -1;
    }
    if (now_ms >= br->next_scan_ms) {
        scan_rows(br);
        br->next_scan_ms = now_ms + SCAN_MS;
    }
    manage_intervals(br, now_ms);
    if (br->status != NULL && now_ms >= br->next_status_ms) {
        update_status(br, now_ms);
        br->next_status_ms = now_ms + br->opt.status_ms;
    }
}

const ub_mav_dir_state_t *ub_mavbridge_dir_state(const ub_mavbridge_t *br, size_t dir) {
    return br != NULL && dir < br->n_dirs ? &br->st[dir] : NULL;
}

const ub_mavbridge_counters_t *ub_mavbridge_counters(const ub_mavbridge_t *br) { return br != NULL ? &br->c : NULL; }

bool ub_mavbridge_connected(const ub_mavbridge_t *br, uint8_t *sysid, uint8_t *compid) {
    if (br == NULL) return false;
    if (sysid != NULL) *sysid = br->target_sysid;
    if (compid != NULL) *compid = br->target_compid;
    return br->connected != 0;
}
