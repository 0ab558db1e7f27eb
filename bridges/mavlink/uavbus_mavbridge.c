/*
 * uavbus_mavbridge: a uavbus entity that talks MAVLink 2 to an autopilot (docs/bridges.md).
 *
 *   uavbus_mavbridge --config FILE [--node NAME] [--entity NAME] --mavlink SPEC
 *                    [--sysid N] [--compid N] [--target SYSID/COMPID] [--mavlink-key FILE [--link-id N]]
 *                    [--commands-without-policy] [--gcs udp:bind=HOST:PORT|tcp:listen=HOST:PORT|serial:device=PATH[,baud=N]]
 *                    [--gcs-key FILE] [--fleet ENTITY]...
 *                    [--port LINK=SPEC]... [--stats-ms MS] [--duration-ms MS]
 *
 * The uavbus side is a node of a configuration file, run by the same program shell as uavbus_node
 * (runtime_c/app/ub_app.h): entity table, ports, the "security" section (whose write policy says who
 * may command the autopilot), the JSON-lines protocol, stdin, signals and the poll loop. The bridge
 * entity is --entity, or the node's first hosted entity. The MAVLink side is one UDP, TCP client or serial
 * link (--mavlink udp:bind=HOST:PORT,peer=HOST:PORT | tcp:connect=HOST:PORT | serial:device=PATH[,baud=N]),
 * polled beside the ports. The front door (ub_mavroute.h): --gcs opens a UDP, TCP or serial endpoint for ground
 * stations (--gcs-key: MAVLink 2 signing on it), --fleet names the other bridge entities whose vehicles it shows.
 *
 * Output on stdout, one JSON object per line (docs/program-protocol.md): "ready", "autopilot"
 * (connected / lost), "stats", "warning", "error". stdin: `stats`, `quit`. CLOCK_MONOTONIC ms, no
 * allocation: the shell (with the node and the ports) and the bridge are static.
 */
#include <inttypes.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "mavcat.h"
#include "ub/ub_node.h"
#include "ub/ub_ports.h"
#include "ub/ub_sec.h"
#include "ub_app.h"
#include "ub_mavbridge.h"
#include "ub_mavio.h"
#include "ub_mavroute.h"

/* The bridge's own options; the shell has --config, --node, --port, --stats-ms, --duration-ms. */
#define MAX_FLEET UB_MAVROUTE_MAX_PEERS

typedef struct options {
    const char *entity, *mavlink, *key, *gcs, *gcs_key;
    const char *fleet[MAX_FLEET]; /* --fleet: the other bridge entities (the front door's peers) */
    int n_fleet;
    unsigned sysid, compid, target_sysid, target_compid, link_id;
    bool commands_without_policy;
} options_t;

static ub_app_t g_app; /* the shell: the node (g_app.node), its ports, sec, config; stdout and stdin */
static options_t g_opt;
/* The bridge: autopilot link, bridge, and the front door (router, GCS endpoint). */
static struct {
    ub_mavio_t io;
    ub_mavbridge_t br;
    ub_mavroute_t rt;
    ub_mavgcs_t gcs;
    bool door;                 /* the router runs (--gcs or --fleet) */
    bool autopilot;            /* --mavlink given (a door may have no autopilot of its own) */
    bool was_up;               /* the autopilot's state last reported */
    uint64_t conflicts_reported;
    uint64_t shared_reported;
} g_b;

/* ---- arguments ----------------------------------------------------------------------------------- */

static void usage(FILE *f) {
    fprintf(f,
            "usage: uavbus_mavbridge --config FILE [--node NAME] [--entity NAME] --mavlink SPEC\n"
            "                        [--sysid N] [--compid N] [--target SYSID/COMPID]\n"
            "                        [--mavlink-key FILE [--link-id N]] [--commands-without-policy]\n"
            "                        [--gcs udp:bind=HOST:PORT | tcp:listen=HOST:PORT | serial:device=PATH[,baud=N]]\n"
            "                        [--gcs-key FILE] [--fleet ENTITY]...\n"
            "                        (--gcs without --mavlink: a front door only)\n"
            "                        [--port LINK=SPEC]... [--stats-ms MS] [--duration-ms MS]\n"
            "SPEC (--mavlink): udp:bind=HOST:PORT,peer=HOST:PORT | tcp:connect=HOST:PORT | serial:device=PATH[,baud=N]\n"
            "stdin commands: stats | quit\n");
}

static bool option(ub_app_t *app, const char *a, const char *v, int i) {
    options_t *o = &g_opt;
    if (strcmp(a, "--commands-without-policy") == 0) o->commands_without_policy = true;
    else if (strcmp(a, "--entity") == 0) o->entity = v;
    else if (strcmp(a, "--mavlink") == 0) o->mavlink = v;
    else if (strcmp(a, "--mavlink-key") == 0) o->key = v;
    else if (strcmp(a, "--gcs") == 0) o->gcs = v;
    else if (strcmp(a, "--gcs-key") == 0) o->gcs_key = v;
    else if (strcmp(a, "--fleet") == 0) {
        if (o->n_fleet == MAX_FLEET) ub_app_die(app, "uavbus_mavbridge:argv[%d]: more than %d --fleet entities", i, MAX_FLEET);
        o->fleet[o->n_fleet++] = v;
    }
    else if (strcmp(a, "--sysid") == 0) o->sysid = (unsigned)ub_app_parse_uint(app, v, i, 255, "a MAVLink system id");
    else if (strcmp(a, "--compid") == 0) o->compid = (unsigned)ub_app_parse_uint(app, v, i, 255, "a MAVLink component id");
    else if (strcmp(a, "--link-id") == 0) o->link_id = (unsigned)ub_app_parse_uint(app, v, i, 255, "a signing link id");
    else if (strcmp(a, "--target") == 0) {
        unsigned s = 0, c = 0;
        char tail;
        if (sscanf(v, "%u/%u%c", &s, &c, &tail) != 2 || s < 1 || s > 255 || c < 1 || c > 255)
            ub_app_die(app, "uavbus_mavbridge:argv[%d]: '%s': expected SYSID/COMPID, each 1..255, e.g. 1/1", i, v);
        o->target_sysid = s;
        o->target_compid = c;
    } else return false;
    return true;
}

/* ---- set-up -------------------------------------------------------------------------------------- */

static int bridge_entity(ub_app_t *app, const options_t *o) {
    if (o->entity == NULL) {
        for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++)
            if (app->node.locals[s].in_use) return app->node.locals[s].entity;
        ub_app_die(app, "%s: the node hosts no entity", app->config_path);
    }
    uint8_t id[UB_ENTITY_ID_LEN];
    int e = ub_entity_id(o->entity, id) == UB_OK ? ub_node_find_entity(&app->node, id) : UB_ERR_NOTFOUND;
    if (e < 0 || ub_pubsub_row(&app->node, e, 0) == NULL)
        ub_app_die(app, "uavbus_mavbridge: --entity '%s' is not an entity this node hosts (see \"hosts\"/\"nodes\" in %s)",
                   o->entity, app->config_path);
    return e;
}

/* ---- events -------------------------------------------------------------------------------------- */

static void ready_port(ub_app_t *app, int id, const ub_link_t *l, const ub_port_t *p) {
    uint16_t port = 0;
    (void)id, (void)p;
    ub_app_out(app, "\"local_port\":");
    if (ub_ports_local_port(&app->ports, l->name, &port) == UB_OK) ub_app_out(app, "%u", (unsigned)port);
    else ub_app_out(app, "null");
}

static void event_ready(ub_app_t *app, const options_t *o) {
    uint16_t port = 0;
    ub_app_out(app, "{\"event\":\"ready\",\"pid\":%ld,\"entity\":", (long)getpid());
    ub_app_entity(app, ub_node_entity_id(&app->node, g_b.br.entity));
    ub_app_out(app, ",\"mavlink\":");
    if (o->mavlink != NULL) ub_app_str(app, o->mavlink, SIZE_MAX);
    else ub_app_out(app, "null");
    if (ub_mavio_local_port(&g_b.io, &port) == UB_OK) ub_app_out(app, ",\"mavlink_port\":%u", (unsigned)port);
    if (g_b.gcs.fd >= 0 && ub_mavgcs_local_port(&g_b.gcs, &port) == UB_OK) ub_app_out(app, ",\"gcs_port\":%u", (unsigned)port);
    ub_app_out(app, ",\"fleet\":%d", o->n_fleet);
    ub_app_out(app, ",\"sysid\":%u,\"compid\":%u,\"signing\":%s,\"uavbus_signed\":%s,\"commands\":%s,\"directories\":%zu,"
        "\"ports\":",
        g_b.br.opt.sysid, g_b.br.opt.compid, g_b.br.opt.sign ? "true" : "false",
        ub_node_security(&app->node) != NULL ? "true" : "false", g_b.br.opt.commands ? "true" : "false", g_b.br.n_dirs);
    ub_app_links(app, true, ready_port);
    ub_app_out(app, "}");
    ub_app_flush(app);
}

static void link_stats(ub_app_t *app, int id, const ub_link_t *l, const ub_port_t *p) {
    (void)id, (void)p;
    ub_app_out(app, "\"frames_in\":%" PRIu64 ",\"frames_out\":%" PRIu64 ",", l->counters.frames_in, l->counters.frames_out);
    ub_app_drops(app, l->counters.drops);
}

#define C(name) ub_app_out(app, ",\"" #name "\":%" PRIu64, c->name)

static void event_stats(ub_app_t *app, uint64_t now_ms, bool final) {
    const ub_node_counters_t *n = ub_node_counters(&app->node);
    ub_app_out(app, "{\"event\":\"stats\",\"t_ms\":%" PRIu64 "%s,\"node\":{\"originated\":%" PRIu64 ",\"forwarded\":%" PRIu64
        ",\"delivered\":%" PRIu64 ",",
        now_ms, final ? ",\"final\":true" : "", n->originated, n->forwarded, n->delivered);
    ub_app_drops(app, n->drops);
    ub_app_out(app, "},\"links\":");
    ub_app_links(app, false, link_stats);
    const ub_mavbridge_counters_t *c = ub_mavbridge_counters(&g_b.br);
    uint8_t sys = 0, comp = 0;
    bool up = ub_mavbridge_connected(&g_b.br, &sys, &comp);
    if (ub_node_security(&app->node) != NULL) {
        const ub_sec_stats_t *ss = ub_sec_stats(&app->sec);
        ub_app_out(app, ",\"security\":{\"signed_out\":%" PRIu64 ",\"verified_in\":%" PRIu64 ",\"auth_failures\":%" PRIu64
            ",\"unknown_keys\":%" PRIu64 ",\"challenges_sent\":%" PRIu64 ",\"challenges_completed\":%" PRIu64
            ",\"reserve_failures\":%" PRIu64 ",\"tx_refused\":%" PRIu64 "}",
            ss->signed_out, ss->verified_in, ss->auth_failures, ss->unknown_keys, ss->challenges_sent,
            ss->challenges_completed, ss->reserve_failures, ss->tx_refused);
    }
    ub_app_out(app, ",\"mavlink\":{\"connected\":%s,\"sysid\":%u,\"compid\":%u", up ? "true" : "false", sys, comp);
    C(bytes_in); C(messages_in); C(updates_sent); C(lost); C(bad_crc); C(parse_errors); C(unsigned_refused);
    C(bad_signature); C(replayed); C(too_many_streams); C(other_source); C(unidentified); C(no_directory); C(messages_out);
    C(bytes_out); C(send_errors); C(backpressure); C(heartbeats_out); C(autopilot_heartbeats); C(link_up);
    C(link_lost); C(commands_forwarded); C(commands_off); C(writes_ignored); C(commands_failed); C(acks_routed);
    C(replies_routed); C(pending_full); C(intervals_sent); C(intervals_granted); C(intervals_refused);
    C(intervals_timeout); C(seq_outliers);
    const ub_mavio_stats_t *s = &g_b.io.stats;
    ub_app_out(app, ",\"transport\":{\"datagrams_in\":%" PRIu64 ",\"foreign\":%" PRIu64 ",\"read_errors\":%" PRIu64
        ",\"again\":%" PRIu64 ",\"send_errors\":%" PRIu64 ",\"connects\":%" PRIu64 ",\"disconnects\":%" PRIu64
        ",\"connect_failures\":%" PRIu64 "}",
        s->datagrams_in, s->foreign, s->read_errors, s->again, s->send_errors, s->connects, s->disconnects,
        s->connect_failures);
    if (g_b.door) {
        const ub_mavroute_counters_t *r = ub_mavroute_counters(&g_b.rt);
        const ub_mavgcs_stats_t *gs = &g_b.gcs.stats;
        ub_app_out(app, ",\"door\":{\"from_autopilot\":%" PRIu64 ",\"from_clients\":%" PRIu64 ",\"from_peers\":%" PRIu64
            ",\"to_clients\":%" PRIu64 ",\"to_peers\":%" PRIu64 ",\"to_autopilot\":%" PRIu64 ",\"no_target\":%" PRIu64
            ",\"commands_off\":%" PRIu64 ",\"bad_frames\":%" PRIu64 ",\"client_parse_errors\":%" PRIu64
            ",\"send_errors\":%" PRIu64 ",\"sysid_conflicts\":%" PRIu64 ",\"unknown_peer\":%" PRIu64
            ",\"clients\":%d,\"clients_new\":%" PRIu64 ",\"clients_expired\":%" PRIu64 ",\"clients_full\":%" PRIu64
            ",\"clients_closed\":%" PRIu64 ",\"gcs_again\":%" PRIu64 ",\"gcs_send_errors\":%" PRIu64
            ",\"unauthenticated\":%" PRIu64 ",\"rate_requests\":%" PRIu64 ",\"rate_forwarded\":%" PRIu64
            ",\"rate_limited\":%" PRIu64 ",\"flows_full\":%" PRIu64 ",\"gcs_unsigned\":%" PRIu64
            ",\"gcs_bad_signature\":%" PRIu64 ",\"gcs_replayed\":%" PRIu64 ",\"gcs_sysid_shared\":%" PRIu64
            ",\"gcs_signing\":%s,\"systems\":[",
            r->from_autopilot, r->from_clients, r->from_peers, r->to_clients, r->to_peers, r->to_autopilot, r->no_target,
            r->commands_off, r->bad_frames, r->client_parse_errors, r->send_errors, r->sysid_conflicts, r->unknown_peer,
            ub_mavgcs_clients(&g_b.gcs), gs->clients_new, gs->clients_expired, gs->clients_full, gs->clients_closed,
            gs->again, gs->send_errors, gs->unauthenticated, r->rate_requests, r->rate_forwarded, r->rate_limited,
            r->flows_full, r->gcs_unsigned, r->gcs_bad_signature, r->gcs_replayed, r->gcs_sysid_shared,
            g_b.rt.gcs_sign ? "true" : "false");
        bool first_sys = true;
        for (int sys = 1; sys < 256; sys++) {
            if (g_b.rt.vehicle[sys] == 0) continue;
            ub_app_out(app, "%s%d", first_sys ? "" : ",", sys);
            first_sys = false;
        }
        /* The rates links asked (SET_MESSAGE_INTERVAL / REQUEST_DATA_STREAM): "gcs:N" a ground station of this
         * endpoint, "peer:ENTITY" a door elsewhere; the autopilot is asked for the fastest of them. */
        ub_app_out(app, "],\"flows\":[");
        bool first_flow = true;
        for (int i = 0; i < UB_MAVROUTE_MAX_FLOWS; i++) {
            const ub_mavroute_flow_t *fl = &g_b.rt.flows[i];
            if (fl->link == 0) continue;
            int link = fl->link - 1;
            ub_app_out(app, "%s{\"link\":", first_flow ? "" : ",");
            first_flow = false;
            if (link >= UB_MAVROUTE_LINK_PEER0) {
                char name[64];
                snprintf(name, sizeof name, "peer:%s", g_opt.fleet[link - UB_MAVROUTE_LINK_PEER0]);
                ub_app_str(app, name, SIZE_MAX);
            } else {
                ub_app_out(app, "\"gcs:%d\"", link - UB_MAVROUTE_LINK_CLIENT0);
            }
            ub_app_out(app, ",\"sysid\":%u,\"msgid\":%" PRIu32 ",\"interval_us\":%" PRId32 "}", fl->sysid, fl->msgid,
                       fl->interval_us);
        }
        ub_app_out(app, "]}");
    }
    ub_app_out(app, ",\"rates\":{");
    bool first = true;
    for (size_t d = 0; d < g_b.br.n_dirs; d++) {
        const ub_mav_dir_state_t *st = ub_mavbridge_dir_state(&g_b.br, d);
        if (st->wanted_us == 0 && st->granted_us == 0) continue;
        ub_app_out(app, "%s", first ? "" : ",");
        first = false;
        ub_app_str(app, g_b.br.dirs[d].name, SIZE_MAX);
        ub_app_out(app, ":{\"wanted_us\":%" PRIu32 ",\"granted_us\":%" PRIu32 ",\"received\":%" PRIu64 "}", st->wanted_us,
            st->granted_us, st->rx);
    }
    ub_app_out(app, "}}}");
    ub_app_flush(app);
}

static void event_autopilot(ub_app_t *app, bool up) {
    uint8_t sys = 0, comp = 0;
    (void)ub_mavbridge_connected(&g_b.br, &sys, &comp);
    ub_app_out(app, "{\"event\":\"autopilot\",\"state\":\"%s\",\"sysid\":%u,\"compid\":%u}", up ? "connected" : "lost", sys, comp);
    ub_app_flush(app);
}

/* ---- the loop's hooks (ub_app_run()) --------------------------------------------------------------- */

static int pollfds(ub_app_t *app, struct pollfd *fds, int max) {
    (void)app;
    if (max < 1) return 0;
    ub_mavio_pollfd(&g_b.io, &fds[0]); /* fd -1 (no autopilot, TCP waiting to reconnect): poll ignores it */
    return 1 + ub_mavgcs_pollfds(&g_b.gcs, &fds[1], max - 1);
}

static void before_tick(ub_app_t *app, uint64_t now_ms) {
    if (g_b.autopilot && ub_mavio_service(&g_b.io, &g_b.br, now_ms) < 0)
        ub_app_error(app, "mavlink: the autopilot link failed (read error)");
    if (g_b.gcs.fd >= 0 && ub_mavgcs_service(&g_b.gcs, &g_b.rt, now_ms) < 0)
        ub_app_error(app, "mavlink: the GCS endpoint failed (read error)");
    if (g_b.door) ub_mavroute_tick(&g_b.rt, now_ms);
    if (g_b.autopilot) ub_mavbridge_tick(&g_b.br, now_ms);
}

static void after_tick(ub_app_t *app, uint64_t now_ms) {
    (void)now_ms;
    bool up = ub_mavbridge_connected(&g_b.br, NULL, NULL);
    if (up != g_b.was_up) event_autopilot(app, up);
    g_b.was_up = up;
    const ub_mavroute_counters_t *rc = ub_mavroute_counters(&g_b.rt);
    if (g_b.door && rc->sysid_conflicts > g_b.conflicts_reported) {
        /* Two vehicles with one system id: said once per new conflict, never merged. */
        if (g_b.conflicts_reported == 0) {
            char msg[200];
            snprintf(msg, sizeof msg, "MAVLink system id %u is used by two vehicles: the second one's messages are "
                     "dropped (door.sysid_conflicts); give each vehicle its own SYSID_THISMAV / MAV_SYS_ID",
                     (unsigned)g_b.rt.last_conflict);
            ub_app_warning(app, msg);
        }
        g_b.conflicts_reported = rc->sysid_conflicts;
    }
    if (g_b.door && rc->gcs_sysid_shared > g_b.shared_reported) {
        char msg[200];
        snprintf(msg, sizeof msg, "MAVLink system id %u is used by two ground stations: both get the replies addressed "
                 "to it (door.gcs_sysid_shared); give each its own (MAVProxy --source-system, QGroundControl's MAVLink "
                 "settings)", (unsigned)g_b.rt.last_gcs_shared);
        ub_app_warning(app, msg);
        g_b.shared_reported = rc->gcs_sysid_shared;
    }
}

/* After the shell's command line: the node, the MAVLink link, the bridge, the ports, "ready". */
static void setup(ub_app_t *app) {
    const options_t *o = &g_opt;
    g_b.io.fd = -1; /* nothing open yet: the close hook must not close descriptor 0 */
    g_b.gcs.fd = -1;
    if (o->mavlink == NULL && o->gcs == NULL)
        ub_app_die(app, "uavbus_mavbridge: --mavlink SPEC is required (or --gcs for a front door without an autopilot of "
                        "its own), e.g. --mavlink udp:bind=127.0.0.1:14550,peer=127.0.0.1:14555");
    /* The uavbus side signs (and requires signed frames) as the "security" section says, as uavbus_node. */
    ub_app_start(app, &mavcat_catalogue, NULL);

    ub_port_spec_t mspec;
    char perr[UB_PORTS_ERR_LEN];
    g_b.autopilot = o->mavlink != NULL;
    if (g_b.autopilot && ub_port_spec_parse(o->mavlink, &mspec, perr, sizeof perr) != UB_OK)
        ub_app_die(app, "uavbus_mavbridge: --mavlink: %s", perr);
    if (g_b.autopilot && ub_mavio_open(&g_b.io, &mspec, perr, sizeof perr) != UB_OK)
        ub_app_die(app, "uavbus_mavbridge: --mavlink %s: %s", o->mavlink, perr);

    ub_mavbridge_options_t bopt;
    memset(&bopt, 0, sizeof bopt);
    bopt.sysid = (uint8_t)o->sysid;
    bopt.compid = (uint8_t)o->compid;
    bopt.target_sysid = (uint8_t)o->target_sysid;
    bopt.target_compid = (uint8_t)o->target_compid;
    /* Commands need someone to say who may give them: the configuration's write policy. */
    bopt.commands = app->cfg.has_policy || o->commands_without_policy;
    if (o->key != NULL) {
        if (ub_mavbridge_load_key(o->key, bopt.key, perr, sizeof perr) != UB_OK) ub_app_die(app, "%s", perr);
        bopt.sign = true;
        bopt.link_id = (uint8_t)o->link_id;
        bopt.sign_timestamp = ub_mavbridge_signing_time(ub_app_unix_ms() * 1000u);
    }
    uint64_t now = ub_app_mono_ms();
    int entity = bridge_entity(app, o);
    int rc = ub_mavbridge_init(&g_b.br, &app->node, entity, mav_directories, mav_directories_count, &mavbridgeStatus, &bopt,
                               ub_mavio_write, &g_b.io, now);
    if (rc != UB_OK) ub_app_die(app, "uavbus_mavbridge: bridge set-up failed: %s", ub_strerror(rc));
    if (o->gcs_key != NULL && o->gcs == NULL)
        ub_app_die(app, "uavbus_mavbridge: --gcs-key needs --gcs (the ground stations' endpoint it signs)");
    g_b.door = o->gcs != NULL || o->n_fleet > 0;
    if (g_b.door) {
        rc = ub_mavroute_init(&g_b.rt, &g_b.br, &mavFrame, o->fleet, o->n_fleet, ub_mavgcs_send, &g_b.gcs);
        if (rc == UB_ERR_INVAL)
            ub_app_die(app, "uavbus_mavbridge: --fleet: every entity must be in the entity table of %s", app->config_path);
        if (rc != UB_OK) ub_app_die(app, "uavbus_mavbridge: front door set-up failed: %s", ub_strerror(rc));
        ub_mavroute_set_autopilot(&g_b.rt, g_b.autopilot);
        if (o->gcs_key != NULL) {
            uint8_t gkey[32];
            if (ub_mavbridge_load_key(o->gcs_key, gkey, perr, sizeof perr) != UB_OK) ub_app_die(app, "%s", perr);
            ub_mavroute_set_gcs_key(&g_b.rt, gkey, 0, ub_mavbridge_signing_time(ub_app_unix_ms() * 1000u), now);
            memset(gkey, 0, sizeof gkey);
        }
        ub_node_set_deliver_hook(&app->node, ub_mavroute_on_deliver, &g_b.rt);
    } else {
        ub_node_set_deliver_hook(&app->node, ub_mavbridge_on_deliver, &g_b.br);
    }
    if (o->gcs != NULL) {
        ub_port_spec_t gspec;
        if (ub_port_spec_parse(o->gcs, &gspec, perr, sizeof perr) != UB_OK) ub_app_die(app, "uavbus_mavbridge: --gcs: %s", perr);
        if (ub_mavgcs_open(&g_b.gcs, &gspec, perr, sizeof perr) != UB_OK) ub_app_die(app, "uavbus_mavbridge: --gcs %s: %s", o->gcs, perr);
    }
    ub_app_open_ports(app, now);
    app->start_ms = now; /* --duration-ms counts from here */
    event_ready(app, o);
    if (!bopt.commands)
        ub_app_warning(app, "commands are off: the configuration has no \"security\" policy saying who may write to the "
                            "autopilot (add one, or run with --commands-without-policy in a closed lab)");
}

static void close_mavlink(ub_app_t *app) {
    (void)app;
    ub_mavio_close(&g_b.io);
    ub_mavgcs_close(&g_b.gcs);
}

static const char *const k_flags[] = {"--commands-without-policy", NULL};

static const ub_app_program_t k_program = {
    .name = "uavbus_mavbridge",
    .usage = usage,
    .config_hint = "(the uavbus side: entities, ports, security)",
    .commands = "stats, quit",
    .flags = k_flags,
    .option = option,
    .setup = setup,
    .close = close_mavlink,
    .pollfds = pollfds,
    .before_tick = before_tick,
    .after_tick = after_tick,
    .stats = event_stats,
};

int main(int argc, char **argv) { return ub_app_main(&g_app, &k_program, argc, argv); }
