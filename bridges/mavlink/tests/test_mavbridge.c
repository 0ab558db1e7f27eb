/*
 * The MAVLink bridge core on an injected clock, with MAVLink's own generated code on the autopilot
 * side of the test: who is the autopilot, heartbeats, telemetry on update to a subscriber, the
 * SET_MESSAGE_INTERVAL protocol (ask, retry, accept, refuse, time out, reset, ask again after a lost
 * link), commands and their ACK routed back, signing (signed out, unsigned / wrong key / replay
 * refused), and every refusal counted.
 *
 * One node hosts the bridge entity and the subscriber `gcs1`: requests and DATA between them take
 * the router's local path, so the test sees the bridge, not the links (the multi-process tests in
 * tests/bridges do the links and the write policy).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "mavcat.h"
#include "ub/ub_node.h"
#include "ub/ub_pubsub.h"
#include "ub_mavbridge.h"

#define AP_SYS 1
#define AP_COMP 1
#define OUT_MAX 64

/* Everything the bridge wrote toward the autopilot, parsed back with MAVLink's parser. */
typedef struct sent {
    size_t n;
    mavlink_message_t msg[OUT_MAX];
    uint8_t framing[OUT_MAX];
    int refuse; /* the transport's answer (0 = take it) */
    mavlink_status_t status;
    mavlink_message_t buf;
    mavlink_signing_t signing;
    mavlink_signing_streams_t streams;
} sent_t;

typedef struct fixture {
    ub_node_t node;
    ub_mavbridge_t br;
    struct ub_mavbridge_status status;
    sent_t out;
    int bridge, gcs;
    uint64_t now;
    /* the autopilot's MAVLink state */
    mavlink_status_t ap_status;
    mavlink_signing_t ap_signing;
    /* deliveries to gcs1 */
    size_t delivered[512];
    mavlink_attitude_t last_attitude;
    mavlink_command_ack_t last_ack;
} fixture_t;

static fixture_t g_f; /* large: static, like the program's */

static int capture_write(void *user, const uint8_t *bytes, size_t len) {
    sent_t *s = user;
    if (s->refuse != 0) return s->refuse;
    for (size_t i = 0; i < len; i++) {
        mavlink_message_t m;
        uint8_t r = mavlink_frame_char_buffer(&s->buf, &s->status, bytes[i], &m, NULL);
        if (r != MAVLINK_FRAMING_INCOMPLETE && s->n < OUT_MAX) {
            s->msg[s->n] = m;
            s->framing[s->n] = r;
            s->n++;
        }
    }
    return UB_OK;
}

static void on_deliver(void *user, int entity, uint32_t instance, const ub_frame_header_t *h, uint64_t now_ms) {
    fixture_t *f = user;
    if (entity == f->bridge) {
        ub_mavbridge_on_deliver(&f->br, entity, instance, h, now_ms);
        return;
    }
    if (instance < 512) f->delivered[instance]++;
    if (instance == (uint32_t)ub_catalogue_find_name(&mavcat_catalogue, "ATTITUDE_30")) f->last_attitude = ATTITUDE_30;
    if (instance == (uint32_t)ub_catalogue_find_name(&mavcat_catalogue, "COMMAND_ACK_77")) f->last_ack = COMMAND_ACK_77;
}

static uint32_t inst(const char *name) {
    int i = ub_catalogue_find_name(&mavcat_catalogue, name);
    assert_true(i >= 0);
    return (uint32_t)i;
}

/* The GCS and the bridge share ATTITUDE_30's storage here (one node); gcs1 reads what was delivered. */
static void setup_bridge(const ub_mavbridge_options_t *opt) {
    fixture_t *f = &g_f;
    memset(f, 0, sizeof *f);
    assert_int_equal(ub_node_init(&f->node, &mavcat_catalogue, NULL), UB_OK);
    f->bridge = ub_node_add_entity_name(&f->node, "mavbridge", true);
    f->gcs = ub_node_add_entity_name(&f->node, "gcs1", true);
    assert_true(f->bridge >= 0 && f->gcs >= 0);
    f->now = 1000;
    assert_int_equal(ub_mavbridge_init(&f->br, &f->node, f->bridge, mav_directories, mav_directories_count, &f->status,
                                       opt, capture_write, &f->out, f->now),
                     UB_OK);
    ub_node_set_deliver_hook(&f->node, on_deliver, f);
}

static void run(uint64_t until, uint64_t step) {
    while (g_f.now < until) {
        g_f.now += step;
        ub_mavbridge_tick(&g_f.br, g_f.now);
        ub_node_tick(&g_f.node, g_f.now);
    }
}

/* The autopilot sends one message (signed when the autopilot's signing is set). */
static void ap_send(mavlink_message_t *m) {
    uint8_t buf[MAVLINK_MAX_PACKET_LEN];
    uint16_t n = mavlink_msg_to_send_buffer(buf, m);
    assert_true(ub_mavbridge_rx(&g_f.br, buf, n, g_f.now) >= 0);
}

static void ap_heartbeat(uint8_t sys, uint8_t comp, uint8_t type) {
    mavlink_heartbeat_t hb = {.type = type, .autopilot = MAV_AUTOPILOT_PX4, .system_status = MAV_STATE_ACTIVE,
                              .mavlink_version = 3};
    mavlink_message_t m;
    mavlink_msg_heartbeat_encode_status(sys, comp, &g_f.ap_status, &m, &hb);
    ap_send(&m);
}

static void ap_attitude(uint8_t sys, uint8_t comp, uint32_t boot_ms, float roll) {
    mavlink_attitude_t a = {.time_boot_ms = boot_ms, .roll = roll, .pitch = 0.25f, .yaw = -1.5f};
    mavlink_message_t m;
    mavlink_msg_attitude_encode_status(sys, comp, &g_f.ap_status, &m, &a);
    ap_send(&m);
}

static void ap_ack(uint16_t command, uint8_t result) {
    mavlink_command_ack_t ack = {.command = command, .result = result, .target_system = 255, .target_component = 190};
    mavlink_message_t m;
    mavlink_msg_command_ack_encode_status(AP_SYS, AP_COMP, &g_f.ap_status, &m, &ack);
    ap_send(&m);
}

/* The n-th COMMAND_LONG the bridge sent since `from`, decoded; NULL-safe index check by the caller. */
static size_t commands_sent(size_t from, mavlink_command_long_t *last) {
    size_t n = 0;
    for (size_t i = from; i < g_f.out.n; i++) {
        if (g_f.out.msg[i].msgid != MAVLINK_MSG_ID_COMMAND_LONG) continue;
        if (last != NULL) mavlink_msg_command_long_decode(&g_f.out.msg[i], last);
        n++;
    }
    return n;
}

static const ub_mav_dir_state_t *state_of(uint32_t msgid) {
    int d = ub_mavbridge_find(&g_f.br, msgid);
    assert_true(d >= 0);
    return ub_mavbridge_dir_state(&g_f.br, (size_t)d);
}

static void connect_autopilot(void) {
    ap_heartbeat(AP_SYS, AP_COMP, MAV_TYPE_QUADROTOR);
    assert_true(ub_mavbridge_connected(&g_f.br, NULL, NULL));
}

/* ---- tests --------------------------------------------------------------------------------------- */

static void test_heartbeats_and_who_the_autopilot_is(void **state) {
    (void)state;
    setup_bridge(NULL);
    run(5000, 10);
    /* 1 Hz from t = 1000: 1000, 2000, ..., 5000. */
    assert_int_equal(g_f.out.n, 5);
    for (size_t i = 0; i < g_f.out.n; i++) {
        mavlink_heartbeat_t hb;
        assert_int_equal(g_f.out.msg[i].msgid, MAVLINK_MSG_ID_HEARTBEAT);
        assert_int_equal(g_f.out.msg[i].sysid, 255);
        assert_int_equal(g_f.out.msg[i].compid, MAV_COMP_ID_MISSIONPLANNER);
        mavlink_msg_heartbeat_decode(&g_f.out.msg[i], &hb);
        assert_int_equal(hb.type, MAV_TYPE_GCS);
        assert_int_equal(hb.autopilot, MAV_AUTOPILOT_INVALID);
    }
    /* Before any autopilot HEARTBEAT nobody is the target; a GCS's heartbeat does not make one. */
    ap_attitude(AP_SYS, AP_COMP, 1, 0.1f);
    ap_heartbeat(7, 190, MAV_TYPE_GCS);
    assert_false(ub_mavbridge_connected(&g_f.br, NULL, NULL));
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->unidentified, 2);
    connect_autopilot();
    uint8_t sys = 0, comp = 0;
    assert_true(ub_mavbridge_connected(&g_f.br, &sys, &comp));
    assert_int_equal(sys, AP_SYS);
    assert_int_equal(comp, AP_COMP);
    /* Another component of the same vehicle, and another system: counted, ignored. */
    ap_attitude(AP_SYS, 154, 2, 0.2f);
    ap_attitude(2, AP_COMP, 3, 0.3f);
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->other_source, 2);
    assert_int_equal(state_of(MAVLINK_MSG_ID_ATTITUDE)->rx, 0);
    /* Silence for longer than the link timeout: lost, once. */
    run(10000, 10);
    assert_false(ub_mavbridge_connected(&g_f.br, NULL, NULL));
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->link_lost, 1);
    run(10500, 10);
    assert_int_equal(g_f.status.connected, 0);
    assert_int_equal(g_f.status.link_lost, 1);
}

static void test_telemetry_reaches_a_subscriber_once_per_update(void **state) {
    (void)state;
    setup_bridge(NULL);
    connect_autopilot();
    assert_true(ub_pubsub_subscribe(&g_f.node, g_f.gcs, inst("ATTITUDE_30"), ub_node_entity_id(&g_f.node, g_f.bridge), 20,
                                    g_f.now) >= 0);
    run(g_f.now + 50, 1);
    for (uint32_t k = 1; k <= 50; k++) {
        ap_attitude(AP_SYS, AP_COMP, k * 20, 0.01f * (float)k);
        run(g_f.now + 20, 1);
    }
    assert_int_equal(g_f.delivered[inst("ATTITUDE_30")], 50);
    assert_int_equal(g_f.last_attitude.time_boot_ms, 1000);
    assert_true(g_f.last_attitude.roll == 0.5f && g_f.last_attitude.yaw == -1.5f);
    /* A silent autopilot sends nothing more: no stale copies. */
    run(g_f.now + 400, 1);
    assert_int_equal(g_f.delivered[inst("ATTITUDE_30")], 50);
    assert_int_equal(state_of(MAVLINK_MSG_ID_ATTITUDE)->rx, 50);
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->lost, 0);
    /* A gap in the autopilot's sequence numbers is counted once the next message continues from it. */
    g_f.ap_status.current_tx_seq += 3;
    ap_attitude(AP_SYS, AP_COMP, 9999, 0.f);
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->lost, 0);
    ap_attitude(AP_SYS, AP_COMP, 10000, 0.f);
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->lost, 3);
    /* A forged sequence number (one message far ahead, the stream going on) is no loss: an outlier. */
    uint8_t seq = g_f.ap_status.current_tx_seq;
    g_f.ap_status.current_tx_seq = (uint8_t)(seq + 200u);
    ap_attitude(AP_SYS, AP_COMP, 10001, 0.f);
    g_f.ap_status.current_tx_seq = seq;
    ap_attitude(AP_SYS, AP_COMP, 10002, 0.f);
    ap_attitude(AP_SYS, AP_COMP, 10003, 0.f);
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->lost, 3);
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->seq_outliers, 1);
}

static void test_subscription_periods_become_message_intervals(void **state) {
    (void)state;
    setup_bridge(NULL);
    connect_autopilot();
    const uint8_t *bridge_id = ub_node_entity_id(&g_f.node, g_f.bridge);
    int row = ub_pubsub_subscribe(&g_f.node, g_f.gcs, inst("ATTITUDE_30"), bridge_id, 20, g_f.now);
    assert_true(row >= 0);
    size_t from = g_f.out.n;
    run(g_f.now + 1200, 10);
    mavlink_command_long_t cmd;
    /* Asked, then re-asked every 500 ms while unanswered (MAVLink's command protocol), confirmation counting. */
    size_t asked = commands_sent(from, &cmd);
    assert_in_range(asked, 3, 3);
    assert_int_equal(cmd.command, MAV_CMD_SET_MESSAGE_INTERVAL);
    assert_int_equal((int)cmd.param1, MAVLINK_MSG_ID_ATTITUDE);
    assert_int_equal((int)cmd.param2, 20000);
    assert_int_equal(cmd.target_system, AP_SYS);
    assert_int_equal(cmd.confirmation, 2);
    ap_heartbeat(AP_SYS, AP_COMP, MAV_TYPE_QUADROTOR);
    ap_ack(MAV_CMD_SET_MESSAGE_INTERVAL, MAV_RESULT_ACCEPTED);
    assert_int_equal(state_of(MAVLINK_MSG_ID_ATTITUDE)->granted_us, 20000);
    from = g_f.out.n;
    run(g_f.now + 900, 10);
    assert_int_equal(commands_sent(from, NULL), 0); /* granted: nothing more to say */
    /* The last subscriber goes: back to the autopilot's default rate (interval 0). */
    assert_int_equal(ub_pubsub_stop(&g_f.node, g_f.gcs, row, g_f.now), UB_OK);
    ap_heartbeat(AP_SYS, AP_COMP, MAV_TYPE_QUADROTOR);
    run(g_f.now + 300, 10);
    assert_int_equal(commands_sent(from, &cmd), 1);
    assert_int_equal((int)cmd.param1, MAVLINK_MSG_ID_ATTITUDE);
    assert_int_equal((int)cmd.param2, 0);
    ap_ack(MAV_CMD_SET_MESSAGE_INTERVAL, MAV_RESULT_ACCEPTED);
    assert_int_equal(state_of(MAVLINK_MSG_ID_ATTITUDE)->granted_us, 0);
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->intervals_granted, 2);
    /* Answers and events are not streams: subscribing to COMMAND_ACK asks for nothing. */
    assert_true(ub_pubsub_subscribe(&g_f.node, g_f.gcs, inst("COMMAND_ACK_77"), bridge_id, 100, g_f.now) >= 0);
    from = g_f.out.n;
    ap_heartbeat(AP_SYS, AP_COMP, MAV_TYPE_QUADROTOR);
    run(g_f.now + 500, 10);
    assert_int_equal(commands_sent(from, NULL), 0);
}

static void test_refusals_timeouts_and_a_returning_autopilot(void **state) {
    (void)state;
    ub_mavbridge_options_t opt = {.link_timeout_ms = 60000};
    setup_bridge(&opt);
    connect_autopilot();
    const uint8_t *bridge_id = ub_node_entity_id(&g_f.node, g_f.bridge);
    assert_true(ub_pubsub_subscribe(&g_f.node, g_f.gcs, inst("ATTITUDE_30"), bridge_id, 20, g_f.now) >= 0);
    run(g_f.now + 150, 10);
    ap_ack(MAV_CMD_SET_MESSAGE_INTERVAL, MAV_RESULT_DENIED);
    size_t from = g_f.out.n;
    run(g_f.now + 3000, 10);
    assert_int_equal(commands_sent(from, NULL), 0); /* refused: not asked again while the rate stays */
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->intervals_refused, 1);
    assert_int_equal(state_of(MAVLINK_MSG_ID_ATTITUDE)->refused_us, 20000);
    /* Another message left unanswered: 5 attempts, then a 5 s pause, then asked again. */
    assert_true(ub_pubsub_subscribe(&g_f.node, g_f.gcs, inst("GLOBAL_POSITION_INT_33"), bridge_id, 40, g_f.now) >= 0);
    from = g_f.out.n;
    run(g_f.now + 3000, 10);
    assert_int_equal(commands_sent(from, NULL), 5);
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->intervals_timeout, 1);
    from = g_f.out.n;
    run(g_f.now + 4000, 10);
    assert_int_equal(commands_sent(from, NULL), 0);
    run(g_f.now + 1500, 10);
    assert_true(commands_sent(from, NULL) >= 1);
    ap_ack(MAV_CMD_SET_MESSAGE_INTERVAL, MAV_RESULT_ACCEPTED);
    assert_int_equal(state_of(MAVLINK_MSG_ID_GLOBAL_POSITION_INT)->granted_us, 40000);
}

static void test_link_lost_then_rates_told_again(void **state) {
    (void)state;
    setup_bridge(NULL);
    connect_autopilot();
    const uint8_t *bridge_id = ub_node_entity_id(&g_f.node, g_f.bridge);
    assert_true(ub_pubsub_subscribe(&g_f.node, g_f.gcs, inst("GLOBAL_POSITION_INT_33"), bridge_id, 40, g_f.now) >= 0);
    run(g_f.now + 150, 10);
    ap_ack(MAV_CMD_SET_MESSAGE_INTERVAL, MAV_RESULT_ACCEPTED);
    /* The autopilot reboots: silent for 4 s, then back with its defaults. The subscriber keeps its row
     * (its lease is renewed locally), so the bridge asks for 40 ms again. */
    run(g_f.now + 4000, 10);
    assert_false(ub_mavbridge_connected(&g_f.br, NULL, NULL));
    size_t from = g_f.out.n;
    connect_autopilot();
    run(g_f.now + 200, 10);
    mavlink_command_long_t cmd;
    assert_int_equal(commands_sent(from, &cmd), 1);
    assert_int_equal((int)cmd.param1, MAVLINK_MSG_ID_GLOBAL_POSITION_INT);
    assert_int_equal((int)cmd.param2, 40000);
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->link_up, 2);
}

static void test_commands_forwarded_and_acks_routed_back(void **state) {
    (void)state;
    ub_mavbridge_options_t opt = {.commands = true};
    setup_bridge(&opt);
    connect_autopilot();
    const uint8_t *bridge_id = ub_node_entity_id(&g_f.node, g_f.bridge);
    /* gcs1 writes COMMAND_LONG into the bridge entity (here through the shared storage and a local send). */
    COMMAND_LONG_76 = (mavlink_command_long_t){.param1 = 1.0f, .param7 = 7.5f, .command = MAV_CMD_COMPONENT_ARM_DISARM,
                                               .target_system = AP_SYS, .target_component = AP_COMP};
    size_t from = g_f.out.n;
    assert_true(ub_node_send_data(&g_f.node, g_f.gcs, inst("COMMAND_LONG_76"), bridge_id, g_f.now) >= 0);
    mavlink_command_long_t cmd;
    assert_int_equal(commands_sent(from, &cmd), 1);
    assert_int_equal(cmd.command, MAV_CMD_COMPONENT_ARM_DISARM);
    assert_true(cmd.param1 == 1.0f && cmd.param7 == 7.5f);
    assert_int_equal(cmd.target_system, AP_SYS);
    /* The ACK comes back to the writer, even though it never subscribed to COMMAND_ACK. */
    ap_ack(MAV_CMD_COMPONENT_ARM_DISARM, MAV_RESULT_ACCEPTED);
    assert_int_equal(g_f.delivered[inst("COMMAND_ACK_77")], 1);
    assert_int_equal(g_f.last_ack.command, MAV_CMD_COMPONENT_ARM_DISARM);
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->acks_routed, 1);
    /* An ACK nobody waits for goes nowhere; a write into the status directory is ignored, counted. */
    ap_ack(MAV_CMD_COMPONENT_ARM_DISARM, MAV_RESULT_ACCEPTED);
    assert_int_equal(g_f.delivered[inst("COMMAND_ACK_77")], 1);
    assert_true(ub_node_send_data(&g_f.node, g_f.gcs, inst(UB_MAVBRIDGE_STATUS_NAME), bridge_id, g_f.now) >= 0);
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->writes_ignored, 1);
    /* A transport that refuses: counted as a failed command and backpressure. */
    g_f.out.refuse = UB_ERR_AGAIN;
    assert_true(ub_node_send_data(&g_f.node, g_f.gcs, inst("COMMAND_LONG_76"), bridge_id, g_f.now) >= 0);
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->commands_failed, 1);
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->backpressure, 1);
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->commands_forwarded, 1);
}

static void test_commands_off_sends_nothing(void **state) {
    (void)state;
    setup_bridge(NULL);
    connect_autopilot();
    size_t from = g_f.out.n;
    assert_true(ub_node_send_data(&g_f.node, g_f.gcs, inst("COMMAND_LONG_76"), ub_node_entity_id(&g_f.node, g_f.bridge),
                                  g_f.now) >= 0);
    assert_int_equal(commands_sent(from, NULL), 0);
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->commands_off, 1);
}

static void set_signing(mavlink_signing_t *s, uint8_t key_byte, uint64_t timestamp) {
    memset(s, 0, sizeof *s);
    memset(s->secret_key, key_byte, sizeof s->secret_key);
    s->flags = MAVLINK_SIGNING_FLAG_SIGN_OUTGOING;
    s->timestamp = timestamp;
}

static void test_signing(void **state) {
    (void)state;
    ub_mavbridge_options_t opt = {.sign = true, .sign_timestamp = 1000000};
    memset(opt.key, 0x5a, sizeof opt.key);
    setup_bridge(&opt);
    /* The autopilot signs with the same key. */
    set_signing(&g_f.ap_signing, 0x5a, 2000000);
    g_f.ap_status.signing = &g_f.ap_signing;
    connect_autopilot();
    ap_attitude(AP_SYS, AP_COMP, 1, 0.1f);
    assert_int_equal(state_of(MAVLINK_MSG_ID_ATTITUDE)->rx, 1);
    /* Unsigned, and signed with another key: refused, counted by cause. */
    g_f.ap_status.signing = NULL;
    ap_attitude(AP_SYS, AP_COMP, 2, 2.5f);
    mavlink_signing_t wrong;
    set_signing(&wrong, 0x11, 3000000);
    g_f.ap_status.signing = &wrong;
    ap_attitude(AP_SYS, AP_COMP, 3, 2.75f);
    /* A replay: the same signed bytes twice. */
    g_f.ap_status.signing = &g_f.ap_signing;
    mavlink_attitude_t a = {.time_boot_ms = 4, .roll = 0.4f};
    mavlink_message_t m;
    mavlink_msg_attitude_encode_status(AP_SYS, AP_COMP, &g_f.ap_status, &m, &a);
    ap_send(&m);
    ap_send(&m);
    const ub_mavbridge_counters_t *c = ub_mavbridge_counters(&g_f.br);
    assert_int_equal(c->unsigned_refused, 1);
    assert_int_equal(c->bad_signature, 1);
    assert_int_equal(c->replayed, 1);
    assert_int_equal(state_of(MAVLINK_MSG_ID_ATTITUDE)->rx, 2);
    assert_true(ATTITUDE_30.roll == 0.4f);
    /* What the bridge sends is signed with the key: MAVLink's parser with the key accepts it, ... */
    set_signing(&g_f.out.signing, 0x5a, 0);
    g_f.out.status.signing = &g_f.out.signing;
    g_f.out.status.signing_streams = &g_f.out.streams;
    size_t from = g_f.out.n;
    run(g_f.now + 2000, 10);
    assert_true(g_f.out.n > from);
    for (size_t i = from; i < g_f.out.n; i++) {
        assert_int_equal(g_f.out.framing[i], MAVLINK_FRAMING_OK);
        assert_true(g_f.out.msg[i].incompat_flags & MAVLINK_IFLAG_SIGNED);
    }
    /* ... with another key refuses it. */
    set_signing(&g_f.out.signing, 0x11, 0);
    memset(&g_f.out.streams, 0, sizeof g_f.out.streams);
    from = g_f.out.n;
    run(g_f.now + 1000, 10);
    assert_true(g_f.out.n > from);
    for (size_t i = from; i < g_f.out.n; i++) assert_int_equal(g_f.out.framing[i], MAVLINK_FRAMING_BAD_SIGNATURE);
}

static void test_damaged_bytes_are_counted(void **state) {
    (void)state;
    setup_bridge(NULL);
    connect_autopilot();
    mavlink_attitude_t a = {.time_boot_ms = 9};
    mavlink_message_t m;
    uint8_t buf[MAVLINK_MAX_PACKET_LEN];
    mavlink_msg_attitude_encode_status(AP_SYS, AP_COMP, &g_f.ap_status, &m, &a);
    uint16_t n = mavlink_msg_to_send_buffer(buf, &m);
    buf[n / 2] ^= 0x40;
    assert_int_equal(ub_mavbridge_rx(&g_f.br, buf, n, g_f.now), 0);
    assert_int_equal(ub_mavbridge_counters(&g_f.br)->bad_crc, 1);
    assert_int_equal(state_of(MAVLINK_MSG_ID_ATTITUDE)->rx, 0);
    assert_int_equal(ub_mavbridge_rx(&g_f.br, NULL, 3, g_f.now), UB_ERR_INVAL);
}

static void test_init_refuses_what_it_cannot_serve(void **state) {
    (void)state;
    static ub_node_t node;
    static ub_mavbridge_t br;
    assert_int_equal(ub_node_init(&node, &mavcat_catalogue, NULL), UB_OK);
    int local = ub_node_add_entity_name(&node, "mavbridge", true);
    int remote = ub_node_add_entity_name(&node, "far", false);
    assert_int_equal(ub_mavbridge_init(&br, &node, remote, mav_directories, mav_directories_count, NULL, NULL,
                                       capture_write, &g_f.out, 0),
                     UB_ERR_INVAL);
    /* A table out of msgid order. */
    ub_mav_dir_t swapped[2] = {mav_directories[1], mav_directories[0]};
    assert_int_equal(ub_mavbridge_init(&br, &node, local, swapped, 2, NULL, NULL, capture_write, &g_f.out, 0), UB_ERR_INVAL);
    assert_int_equal(ub_mavbridge_init(&br, &node, local, mav_directories, mav_directories_count, NULL, NULL, NULL, NULL, 0),
                     UB_ERR_INVAL);
    assert_int_equal(ub_mavbridge_signing_time(1420070400ull * 1000000ull + 10), 1);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_heartbeats_and_who_the_autopilot_is),
        cmocka_unit_test(test_telemetry_reaches_a_subscriber_once_per_update),
        cmocka_unit_test(test_subscription_periods_become_message_intervals),
        cmocka_unit_test(test_refusals_timeouts_and_a_returning_autopilot),
        cmocka_unit_test(test_link_lost_then_rates_told_again),
        cmocka_unit_test(test_commands_forwarded_and_acks_routed_back),
        cmocka_unit_test(test_commands_off_sends_nothing),
        cmocka_unit_test(test_signing),
        cmocka_unit_test(test_damaged_bytes_are_counted),
        cmocka_unit_test(test_init_refuses_what_it_cannot_serve),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
