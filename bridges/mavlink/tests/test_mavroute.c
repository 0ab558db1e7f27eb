/*
 * The front door's router (ub_mavroute.h) on an injected clock: two bridge nodes joined by a memlink,
 * each with a simulated autopilot (MAVLink's generated code), ground stations as captured clients of
 * the door. Checked: every vehicle reaches every ground station; a targeted message reaches only its
 * target, its answer only its asker; a vehicle's broadcast telemetry never reaches another autopilot;
 * commands off refuses and counts; a damaged mavFrame is counted; one system id behind two
 * vehicle links is a conflict, not a merge.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "mavcat.h"
#include "ub/ub_memlink.h"
#include "ub/ub_node.h"
#include "ub_mavroute.h"

#define MAX_SEEN 256

/* Messages one sink (an autopilot's transport or a ground station) received. */
typedef struct sink {
    size_t n;
    struct {
        uint32_t msgid;
        uint8_t sysid, target;
        uint16_t command;
    } m[MAX_SEEN];
    mavlink_status_t status;
    mavlink_message_t buf;
} sink_t;

typedef struct side {
    ub_node_t node;
    ub_mavbridge_t br;
    ub_mavroute_t rt;
    struct ub_mavframe frame;
    sink_t autopilot; /* what the bridge wrote toward its autopilot */
    mavlink_status_t ap_status;
    int entity;
} side_t;

static struct {
    side_t door, mb;
    ub_memlink_t ml;
    sink_t clients[2];
    mavlink_status_t gcs_status[2];
    uint64_t now;
} g_w; /* large: static, like the program's */

static void sink_bytes(sink_t *s, const uint8_t *bytes, size_t len) {
    for (size_t i = 0; i < len; i++) {
        mavlink_message_t m;
        if (mavlink_frame_char_buffer(&s->buf, &s->status, bytes[i], &m, NULL) != MAVLINK_FRAMING_OK) continue;
        if (s->n == MAX_SEEN) continue;
        const mavlink_msg_entry_t *e = mavlink_get_msg_entry(m.msgid);
        s->m[s->n].msgid = m.msgid;
        s->m[s->n].sysid = m.sysid;
        s->m[s->n].target = e != NULL && (e->flags & MAV_MSG_ENTRY_FLAG_HAVE_TARGET_SYSTEM)
                                ? (uint8_t)_MAV_PAYLOAD(&m)[e->target_system_ofs] : 0;
        s->m[s->n].command = m.msgid == MAVLINK_MSG_ID_COMMAND_LONG ? mavlink_msg_command_long_get_command(&m)
                             : m.msgid == MAVLINK_MSG_ID_COMMAND_ACK ? mavlink_msg_command_ack_get_command(&m) : 0;
        s->n++;
    }
}

static int to_autopilot(void *user, const uint8_t *bytes, size_t len) {
    sink_bytes(user, bytes, len);
    return UB_OK;
}

static int to_client(void *user, int client, const uint8_t *bytes, size_t len) {
    (void)user;
    assert_true(client >= 0 && client < 2);
    sink_bytes(&g_w.clients[client], bytes, len);
    return UB_OK;
}

static size_t count(const sink_t *s, uint32_t msgid, int sysid, uint16_t command) {
    size_t n = 0;
    for (size_t i = 0; i < s->n; i++)
        n += s->m[i].msgid == msgid && (sysid < 0 || s->m[i].sysid == sysid) && (command == 0 || s->m[i].command == command);
    return n;
}

static void setup_side(side_t *s, const char *name, const char *peer, bool commands) {
    assert_int_equal(ub_node_init(&s->node, &mavcat_catalogue, NULL), UB_OK);
    s->entity = ub_node_add_entity_name(&s->node, name, true);
    int other = ub_node_add_entity_name(&s->node, peer, false);
    assert_true(s->entity >= 0 && other >= 0);
    assert_true(ub_node_add_link(&s->node, s->entity, 0, "toPeer") >= 0);
    assert_int_equal(ub_node_set_mask(&s->node, s->entity, other, 0x01), UB_OK);
    ub_mavbridge_options_t opt = {.commands = commands};
    assert_int_equal(ub_mavbridge_init(&s->br, &s->node, s->entity, mav_directories, mav_directories_count, NULL, &opt,
                                       to_autopilot, &s->autopilot, g_w.now),
                     UB_OK);
    const char *peers[] = {peer};
    assert_int_equal(ub_mavroute_init(&s->rt, &s->br, &s->frame, peers, 1, to_client, NULL), UB_OK);
    ub_node_set_deliver_hook(&s->node, ub_mavroute_on_deliver, &s->rt);
}

static void setup_world(bool commands) {
    memset(&g_w, 0, sizeof g_w);
    g_w.now = 1000;
    setup_side(&g_w.door, "door", "mb2", commands);
    setup_side(&g_w.mb, "mb2", "door", commands);
    ub_memlink_init(&g_w.ml, NULL, 1);
    assert_int_equal(ub_memlink_connect(&g_w.ml, &g_w.door.node, 0, &g_w.mb.node, 0), UB_OK);
}

static void pump(void) {
    while (ub_memlink_pump(&g_w.ml, g_w.now) > 0) {
    }
}

static void run(uint64_t ms) {
    for (uint64_t end = g_w.now + ms; g_w.now < end; g_w.now += 10) {
        ub_mavbridge_tick(&g_w.door.br, g_w.now);
        ub_mavbridge_tick(&g_w.mb.br, g_w.now);
        ub_node_tick(&g_w.door.node, g_w.now);
        ub_node_tick(&g_w.mb.node, g_w.now);
        pump();
    }
}

static void ap_send(side_t *s, mavlink_message_t *m) {
    uint8_t buf[MAVLINK_MAX_PACKET_LEN];
    uint16_t n = mavlink_msg_to_send_buffer(buf, m);
    assert_true(ub_mavbridge_rx(&s->br, buf, n, g_w.now) >= 0);
    pump();
}

static void ap_heartbeat(side_t *s, uint8_t sysid) {
    mavlink_heartbeat_t hb = {.type = MAV_TYPE_QUADROTOR, .autopilot = MAV_AUTOPILOT_PX4, .mavlink_version = 3};
    mavlink_message_t m;
    mavlink_msg_heartbeat_encode_status(sysid, 1, &s->ap_status, &m, &hb);
    ap_send(s, &m);
}

static void ap_attitude(side_t *s, uint8_t sysid, uint32_t boot_ms) {
    mavlink_attitude_t a = {.time_boot_ms = boot_ms, .roll = 0.1f};
    mavlink_message_t m;
    mavlink_msg_attitude_encode_status(sysid, 1, &s->ap_status, &m, &a);
    ap_send(s, &m);
}

static void ap_ack(side_t *s, uint8_t sysid, uint16_t command, uint8_t to_sys) {
    mavlink_command_ack_t ack = {.command = command, .result = MAV_RESULT_ACCEPTED, .target_system = to_sys,
                                 .target_component = 190};
    mavlink_message_t m;
    mavlink_msg_command_ack_encode_status(sysid, 1, &s->ap_status, &m, &ack);
    ap_send(s, &m);
}

static void gcs_send(int client, mavlink_message_t *m) {
    uint8_t buf[MAVLINK_MAX_PACKET_LEN];
    uint16_t n = mavlink_msg_to_send_buffer(buf, m);
    assert_true(ub_mavroute_from_client(&g_w.door.rt, client, buf, n, g_w.now) >= 0);
    pump();
}

static void gcs_heartbeat(int client, uint8_t sysid) {
    mavlink_heartbeat_t hb = {.type = MAV_TYPE_GCS, .autopilot = MAV_AUTOPILOT_INVALID, .mavlink_version = 3};
    mavlink_message_t m;
    mavlink_msg_heartbeat_encode_status(sysid, 190, &g_w.gcs_status[client], &m, &hb);
    gcs_send(client, &m);
}

static void gcs_command(int client, uint8_t sysid, uint8_t target, uint16_t command) {
    mavlink_command_long_t c = {.target_system = target, .target_component = 1, .command = command, .param1 = 1.0f};
    mavlink_message_t m;
    mavlink_msg_command_long_encode_status(sysid, 190, &g_w.gcs_status[client], &m, &c);
    gcs_send(client, &m);
}

/* Two ground stations (250, 251; 255 is the bridges' own id), vehicles 1 (door) and 2 (behind mb2), each heard once. */
static void meet(void) {
    gcs_heartbeat(0, 250);
    gcs_heartbeat(1, 251);
    ap_heartbeat(&g_w.door, 1);
    ap_heartbeat(&g_w.mb, 2);
    ap_attitude(&g_w.door, 1, 100);
    ap_attitude(&g_w.mb, 2, 100);
    run(50);
}

static void test_every_vehicle_reaches_every_ground_station(void **state) {
    (void)state;
    setup_world(true);
    meet();
    for (int c = 0; c < 2; c++) {
        assert_int_equal(count(&g_w.clients[c], MAVLINK_MSG_ID_HEARTBEAT, 1, 0), 1);
        assert_int_equal(count(&g_w.clients[c], MAVLINK_MSG_ID_HEARTBEAT, 2, 0), 1);
        assert_int_equal(count(&g_w.clients[c], MAVLINK_MSG_ID_ATTITUDE, 2, 0), 1);
    }
    /* Broadcasts go to every other link: ground station 0 (up first) hears 1's heartbeat. */
    assert_int_equal(count(&g_w.clients[0], MAVLINK_MSG_ID_HEARTBEAT, 251, 0), 1);
    assert_int_equal(count(&g_w.clients[1], MAVLINK_MSG_ID_HEARTBEAT, 251, 0), 0); /* never back to its sender */
    /* Vehicles' broadcast telemetry never reaches another autopilot; ground stations' heartbeats do. */
    assert_int_equal(count(&g_w.mb.autopilot, MAVLINK_MSG_ID_ATTITUDE, 1, 0), 0);
    assert_int_equal(count(&g_w.door.autopilot, MAVLINK_MSG_ID_ATTITUDE, 2, 0), 0);
    assert_int_equal(count(&g_w.mb.autopilot, MAVLINK_MSG_ID_HEARTBEAT, 250, 0), 1);
    assert_true(ub_mavroute_seen(&g_w.door.rt, 2) == (1u << UB_MAVROUTE_LINK_PEER0));
    assert_int_equal(ub_mavroute_counters(&g_w.door.rt)->sysid_conflicts, 0);
}

static void test_a_command_reaches_only_its_target_and_its_ack_only_the_asker(void **state) {
    (void)state;
    setup_world(true);
    meet();
    gcs_command(0, 250, 2, MAV_CMD_COMPONENT_ARM_DISARM);
    run(20);
    assert_int_equal(count(&g_w.mb.autopilot, MAVLINK_MSG_ID_COMMAND_LONG, 250, MAV_CMD_COMPONENT_ARM_DISARM), 1);
    assert_int_equal(count(&g_w.door.autopilot, MAVLINK_MSG_ID_COMMAND_LONG, -1, MAV_CMD_COMPONENT_ARM_DISARM), 0);
    assert_int_equal(count(&g_w.clients[1], MAVLINK_MSG_ID_COMMAND_LONG, -1, 0), 0);
    ap_ack(&g_w.mb, 2, MAV_CMD_COMPONENT_ARM_DISARM, 250);
    run(20);
    assert_int_equal(count(&g_w.clients[0], MAVLINK_MSG_ID_COMMAND_ACK, 2, MAV_CMD_COMPONENT_ARM_DISARM), 1);
    assert_int_equal(count(&g_w.clients[1], MAVLINK_MSG_ID_COMMAND_ACK, -1, 0), 0);
    /* A system nobody has seen: dropped, counted. */
    gcs_command(0, 250, 77, MAV_CMD_COMPONENT_ARM_DISARM);
    assert_int_equal(ub_mavroute_counters(&g_w.door.rt)->no_target, 1);
    /* A ground station gone: what was learned on it is forgotten, its ACKs go nowhere. */
    ub_mavroute_client_gone(&g_w.door.rt, 0);
    ap_ack(&g_w.mb, 2, MAV_CMD_COMPONENT_ARM_DISARM, 250);
    run(20);
    assert_int_equal(count(&g_w.clients[0], MAVLINK_MSG_ID_COMMAND_ACK, -1, 0), 1);
}

static void test_commands_off_refuse_and_count(void **state) {
    (void)state;
    setup_world(false);
    meet();
    gcs_command(0, 250, 2, MAV_CMD_COMPONENT_ARM_DISARM);
    gcs_command(0, 250, 1, MAV_CMD_COMPONENT_ARM_DISARM);
    run(20);
    assert_int_equal(count(&g_w.mb.autopilot, MAVLINK_MSG_ID_COMMAND_LONG, -1, 0), 0);
    assert_int_equal(count(&g_w.door.autopilot, MAVLINK_MSG_ID_COMMAND_LONG, -1, 0), 0);
    assert_true(ub_mavroute_counters(&g_w.mb.rt)->commands_off >= 1);
    assert_true(ub_mavroute_counters(&g_w.door.rt)->commands_off >= 1);
}

static void test_damaged_frames_are_counted(void **state) {
    (void)state;
    setup_world(true);
    meet();
    /* A damaged frame written by the peer: counted, not routed. */
    size_t before = g_w.clients[0].n;
    g_w.mb.frame.len = 12;
    memset(g_w.mb.frame.bytes, 0xFD, 12);
    uint8_t door_id[UB_ENTITY_ID_LEN];
    assert_int_equal(ub_entity_id("door", door_id), UB_OK);
    assert_true(ub_node_send_data(&g_w.mb.node, g_w.mb.entity, (uint32_t)g_w.mb.rt.frame_instance, door_id, g_w.now) >= 0);
    g_w.mb.frame.len = 9999; /* a length beyond the frame */
    assert_true(ub_node_send_data(&g_w.mb.node, g_w.mb.entity, (uint32_t)g_w.mb.rt.frame_instance, door_id, g_w.now) >= 0);
    run(20);
    assert_int_equal(ub_mavroute_counters(&g_w.door.rt)->bad_frames, 2);
    assert_int_equal(g_w.clients[0].n, before);
}

static void test_one_system_id_behind_two_vehicle_links_is_a_conflict(void **state) {
    (void)state;
    setup_world(true);
    gcs_heartbeat(0, 250);
    ap_heartbeat(&g_w.door, 1);
    /* mb2's autopilot claims system 1 too (two vehicles left with the default SYSID_THISMAV). */
    ap_heartbeat(&g_w.mb, 1);
    ap_attitude(&g_w.mb, 1, 555);
    run(20);
    /* The door's own vehicle 1 came first: mb2's (woken by the ground station's heartbeat) is the second. */
    assert_int_equal(ub_mavroute_counters(&g_w.door.rt)->sysid_conflicts, 2);
    assert_int_equal(g_w.door.rt.last_conflict, 1);
    assert_int_equal(count(&g_w.clients[0], MAVLINK_MSG_ID_HEARTBEAT, 1, 0), 1); /* the door's vehicle only */
    assert_int_equal(count(&g_w.clients[0], MAVLINK_MSG_ID_ATTITUDE, 1, 0), 0);
}

/* Frames of the second vehicle heard before any HEARTBEAT: once the first vehicle's HEARTBEAT says who owns the
 * id, commands to it go to that vehicle only. */
static void test_a_conflicting_vehicle_heard_first_without_heartbeat_gets_no_commands(void **state) {
    (void)state;
    setup_world(true);
    gcs_heartbeat(0, 250);
    run(20);
    g_w.mb.br.target_sysid = 1; /* mb2's bridge configured with --target 1/1: it forwards before any HEARTBEAT */
    g_w.mb.br.target_compid = 1;
    g_w.mb.br.target_known = 1;
    ap_attitude(&g_w.mb, 1, 100); /* mb2's vehicle 1, no HEARTBEAT yet: learned on the peer link */
    run(20);
    assert_true(ub_mavroute_seen(&g_w.door.rt, 1) & (1u << UB_MAVROUTE_LINK_PEER0));
    ap_heartbeat(&g_w.door, 1); /* the door's own vehicle 1 says it is one */
    run(20);
    gcs_command(0, 250, 1, MAV_CMD_COMPONENT_ARM_DISARM);
    run(20);
    assert_int_equal(count(&g_w.door.autopilot, MAVLINK_MSG_ID_COMMAND_LONG, 250, MAV_CMD_COMPONENT_ARM_DISARM), 1);
    assert_int_equal(count(&g_w.mb.autopilot, MAVLINK_MSG_ID_COMMAND_LONG, 250, MAV_CMD_COMPONENT_ARM_DISARM), 0);
}

static void test_vehicles_broadcast_only_toward_peers_that_listen(void **state) {
    (void)state;
    setup_world(true);
    /* No ground station anywhere: mb2's vehicle sends nothing over the bus. */
    ap_heartbeat(&g_w.mb, 2);
    ap_attitude(&g_w.mb, 2, 100);
    run(20);
    assert_int_equal(ub_mavroute_counters(&g_w.mb.rt)->to_peers, 0);
    /* A ground station on the door: its heartbeat wakes mb2 up, whose vehicle then reaches it. */
    gcs_heartbeat(0, 250);
    ap_attitude(&g_w.mb, 2, 120);
    run(20);
    assert_int_equal(count(&g_w.clients[0], MAVLINK_MSG_ID_ATTITUDE, 2, 0), 1);
    /* Silence from the door for longer than UB_MAVROUTE_PEER_TIMEOUT_MS: mb2 stops sending. */
    run(UB_MAVROUTE_PEER_TIMEOUT_MS + 100);
    uint64_t sent = ub_mavroute_counters(&g_w.mb.rt)->to_peers;
    ap_attitude(&g_w.mb, 2, 140);
    assert_int_equal(ub_mavroute_counters(&g_w.mb.rt)->to_peers, sent);
}

static void test_a_forged_sequence_is_no_loss(void **state) {
    (void)state;
    setup_world(true);
    meet();
    for (uint32_t k = 0; k < 5; k++) ap_attitude(&g_w.door, 1, 200 + k);
    g_w.door.ap_status.current_tx_seq = (uint8_t)(g_w.door.ap_status.current_tx_seq + 100u);
    ap_attitude(&g_w.door, 1, 300);
    g_w.door.ap_status.current_tx_seq = (uint8_t)(g_w.door.ap_status.current_tx_seq - 101u);
    for (uint32_t k = 0; k < 5; k++) ap_attitude(&g_w.door, 1, 400 + k);
    assert_int_equal(ub_mavbridge_counters(&g_w.door.br)->lost, 0);
    assert_int_equal(ub_mavbridge_counters(&g_w.door.br)->seq_outliers, 1);
}

static void gcs_interval(int client, uint8_t sysid, uint8_t target, uint32_t msgid, float us) {
    mavlink_command_long_t c = {.target_system = target, .target_component = 1,
                                .command = MAV_CMD_SET_MESSAGE_INTERVAL, .param1 = (float)msgid, .param2 = us};
    mavlink_message_t m;
    mavlink_msg_command_long_encode_status(sysid, 190, &g_w.gcs_status[client], &m, &c);
    gcs_send(client, &m);
}

/* SET_MESSAGE_INTERVAL from ground stations: answered by the vehicle's bridge as its autopilot (never forwarded),
 * each ground station held to its own rate, the autopilot asked for the fastest. */
static void test_rates_asked_by_ground_stations(void **state) {
    (void)state;
    setup_world(true);
    meet();
    gcs_interval(0, 250, 2, MAVLINK_MSG_ID_ATTITUDE, 100000.0f); /* 10 Hz */
    gcs_interval(1, 251, 2, MAVLINK_MSG_ID_ATTITUDE, 20000.0f);  /* 50 Hz */
    run(20);
    assert_int_equal(ub_mavroute_counters(&g_w.door.rt)->rate_forwarded, 2);
    assert_int_equal(ub_mavroute_counters(&g_w.mb.rt)->rate_requests, 2);
    assert_int_equal(count(&g_w.mb.autopilot, MAVLINK_MSG_ID_COMMAND_LONG, 250, 0), 0);
    assert_int_equal(count(&g_w.mb.autopilot, MAVLINK_MSG_ID_COMMAND_LONG, 251, 0), 0);
    assert_int_equal(count(&g_w.clients[0], MAVLINK_MSG_ID_COMMAND_ACK, 2, MAV_CMD_SET_MESSAGE_INTERVAL), 1);
    assert_int_equal(count(&g_w.clients[1], MAVLINK_MSG_ID_COMMAND_ACK, 2, MAV_CMD_SET_MESSAGE_INTERVAL), 1);
    /* The bridge asks its autopilot for the fastest (the rewritten second request: 20 ms). */
    int d = ub_mavbridge_find(&g_w.mb.br, MAVLINK_MSG_ID_ATTITUDE);
    assert_true(d >= 0);
    assert_int_equal(ub_mavbridge_dir_state(&g_w.mb.br, (size_t)d)->flow_us, 20000);
    assert_int_equal(ub_mavbridge_dir_state(&g_w.mb.br, (size_t)d)->wanted_us, 20000);
    size_t before0 = count(&g_w.clients[0], MAVLINK_MSG_ID_ATTITUDE, 2, 0);
    size_t before1 = count(&g_w.clients[1], MAVLINK_MSG_ID_ATTITUDE, 2, 0);
    for (int k = 0; k < 50; k++) { /* one second at 50 Hz */
        ap_attitude(&g_w.mb, 2, 200 + 20u * (uint32_t)k);
        run(20);
    }
    size_t got0 = count(&g_w.clients[0], MAVLINK_MSG_ID_ATTITUDE, 2, 0) - before0;
    size_t got1 = count(&g_w.clients[1], MAVLINK_MSG_ID_ATTITUDE, 2, 0) - before1;
    assert_true(got0 >= 9 && got0 <= 11);
    assert_int_equal(got1, 50);
    /* Off for ground station 0; ground station 1 goes on. */
    gcs_interval(0, 250, 2, MAVLINK_MSG_ID_ATTITUDE, -1.0f);
    before0 = count(&g_w.clients[0], MAVLINK_MSG_ID_ATTITUDE, 2, 0);
    ap_attitude(&g_w.mb, 2, 5000);
    run(20);
    assert_int_equal(count(&g_w.clients[0], MAVLINK_MSG_ID_ATTITUDE, 2, 0), before0);
    /* A ground station that leaves takes its rate with it. */
    ub_mavroute_client_gone(&g_w.door.rt, 1);
    gcs_interval(0, 250, 2, MAVLINK_MSG_ID_ATTITUDE, 0.0f);
    run(20);
    assert_int_equal(ub_mavbridge_dir_state(&g_w.mb.br, (size_t)d)->flow_us, 0);
}

static void gcs_stream(int client, uint8_t sysid, uint8_t target, uint8_t stream, uint16_t hz, uint8_t start) {
    mavlink_request_data_stream_t r = {.req_message_rate = hz, .target_system = target, .target_component = 1,
                                       .req_stream_id = stream, .start_stop = start};
    mavlink_message_t m;
    mavlink_msg_request_data_stream_encode_status(sysid, 190, &g_w.gcs_status[client], &m, &r);
    gcs_send(client, &m);
}

static int32_t flow_of(const ub_mavroute_t *rt, int link, uint8_t sysid, uint32_t msgid) {
    for (int i = 0; i < UB_MAVROUTE_MAX_FLOWS; i++) {
        const ub_mavroute_flow_t *f = &rt->flows[i];
        if (f->link == link + 1 && f->sysid == sysid && f->msgid == msgid) return f->interval_us;
    }
    return -100; /* none */
}

/* REQUEST_DATA_STREAM from two ground stations of the door: each held to its own rate at the door, the peer told
 * the fastest (rewritten), never the autopilot; stop from one leaves the other's rate. */
static void test_data_streams_asked_by_ground_stations(void **state) {
    (void)state;
    setup_world(true);
    meet();
    gcs_stream(0, 250, 2, MAV_DATA_STREAM_EXTRA1, 2, 1);
    gcs_stream(1, 251, 2, MAV_DATA_STREAM_EXTRA1, 10, 1);
    run(20);
    assert_int_equal(flow_of(&g_w.door.rt, UB_MAVROUTE_LINK_CLIENT0, 2, MAVLINK_MSG_ID_ATTITUDE), 500000);
    assert_int_equal(flow_of(&g_w.door.rt, UB_MAVROUTE_LINK_CLIENT0 + 1, 2, MAVLINK_MSG_ID_ATTITUDE), 100000);
    assert_int_equal(flow_of(&g_w.mb.rt, UB_MAVROUTE_LINK_PEER0, 2, MAVLINK_MSG_ID_ATTITUDE), 100000);
    assert_int_equal(count(&g_w.mb.autopilot, MAVLINK_MSG_ID_REQUEST_DATA_STREAM, -1, 0), 0);
    /* The faster one stops: the peer is told the slower one's rate (a new request from the door). */
    gcs_stream(1, 251, 2, MAV_DATA_STREAM_EXTRA1, 0, 0);
    run(20);
    assert_int_equal(flow_of(&g_w.mb.rt, UB_MAVROUTE_LINK_PEER0, 2, MAVLINK_MSG_ID_ATTITUDE), 500000);
    /* Both stop: the peer stops sending ATTITUDE to the door. */
    gcs_stream(0, 250, 2, MAV_DATA_STREAM_EXTRA1, 0, 0);
    run(20);
    assert_int_equal(flow_of(&g_w.mb.rt, UB_MAVROUTE_LINK_PEER0, 2, MAVLINK_MSG_ID_ATTITUDE), -1);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_vehicle_reaches_every_ground_station),
        cmocka_unit_test(test_a_command_reaches_only_its_target_and_its_ack_only_the_asker),
        cmocka_unit_test(test_commands_off_refuse_and_count),
        cmocka_unit_test(test_damaged_frames_are_counted),
        cmocka_unit_test(test_one_system_id_behind_two_vehicle_links_is_a_conflict),
        cmocka_unit_test(test_vehicles_broadcast_only_toward_peers_that_listen),
        cmocka_unit_test(test_a_forged_sequence_is_no_loss),
        cmocka_unit_test(test_rates_asked_by_ground_stations),
        cmocka_unit_test(test_data_streams_asked_by_ground_stations),
        cmocka_unit_test(test_a_conflicting_vehicle_heard_first_without_heartbeat_gets_no_commands),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
