/*
 * uavbus_node: one process hosting the entities of one node of a config file
 * (e.g. Table 2's "primary" = rmax1ob1), with its links on real transports.
 *
 *   uavbus_node --config examples/configs/table2.json --node primary
 *               [--port NAME=SPEC]... [--record FILE [--record-tx] [--record-max-bytes N]
 *               [--record-max-ms MS] [--record-max-files N]]
 *               [--impair loss=0.2,reorder=0.2,dup=0,delay=5,jitter=0,seed=1]
 *               [--stats-ms 500] [--duration-ms N]
 *               [--subscribe ENTITY:CONTENT@SOURCE/PERIOD_MS]... [--publish ENTITY:CONTENT>DEST/PERIOD_MS]...
 *
 * It updates the directories its entities produce from a deterministic motion
 * model (node_motion.h), serves publish/subscribe requests, and reports on
 * stdout, one JSON object per line: "ready", "stats", "rebound", "error", ...
 * stdin takes line commands: `rebind NAME SPEC`, `impair SPEC`, `dump NAME`, `stats`, `quit`, and for
 * key rotation `key add FILE`, `key use ID`, `key remove ID`, and `revoke FILE` (a revocations file:
 * its records spread to the fleet; docs/security.md).
 * See programs/node/README.md and docs/program-protocol.md.
 *
 * The program shell (runtime_c/app/ub_app.h) owns the command line's common part, the node and its
 * ports, the JSON-lines output, stdin, the signals and the poll() loop; this file is what the node
 * hosts: the directories and their motion, publish/subscribe from the command line, the log, and its
 * own events and commands. The time is CLOCK_MONOTONIC in ms, the same clock that stamps the
 * directories' timeTag. All large state is static (sized by ub_config.h, no malloc).
 */
#include <errno.h>
#include <inttypes.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "ub/ub_compact.h"
#include "ub/ub_frag.h"
#include "ub/ub_impair.h"
#include "ub/ub_log.h"
#include "ub/ub_node.h"
#include "ub/ub_nodecfg.h"
#include "ub/ub_ports.h"
#include "ub/ub_pubsub.h"
#include "ub/ub_sec.h"
#include "ub/ub_secfile.h"

#include "flightsw.h"
#include "gps.h"
#include "imu.h"
#include "navfilter.h"
#include "node_fleet.h"
#include "node_motion.h"
#include "onboard.h"
#include "ub_app.h"
#include "waypoints.h"

/* programs/node/adapter_nmea.c: the NMEA 0183 GPS adapter, a driver table like the built-ins. */
#include "adapter_serial.h"
extern const adapter_serial_kind_t adapter_nmea;
/* programs/node/adapter_ubx.c: the u-blox UBX GPS adapter. */
extern const adapter_serial_kind_t adapter_ubx;

#define MAX_PS_ARGS 16

/* ---- directories this program keeps storage for ----------------------------------------------------- */

/* What moves, and at which rate: the producer is the hosted entity named `entity`. */
typedef enum motion_kind { MOTION_NONE = 0, MOTION_GPS, MOTION_IMU, MOTION_NAV } motion_kind_t;

typedef struct directory {
    const char *name;     /* catalogue instance */
    void *storage;        /* flightsw_data.c */
    const char *producer; /* entity that updates it here, or NULL (received only) */
    motion_kind_t motion;
    uint32_t period_ms;   /* update period of the motion model */
} directory_t;

static const directory_t k_dirs[] = {
    {"gpsOut", &gpsOut, "rmax1ob1", MOTION_GPS, 100},
    {"navFilterState", &navFilterState, "rmax1ob1", MOTION_NAV, 20},
    {"imuOutPrimary", &imuOutPrimary, "rmax1ob1", MOTION_IMU, 10},
    {"onboardSet", &onboardSet, "rmax1ob1", MOTION_NONE, 0},
    {"imuOut", &imuOut, "fcs20", MOTION_IMU, 10},
    {"gpsOutBackup", &gpsOutBackup, "fcs20", MOTION_GPS, 100},
    {"navFilterStateBackup", &navFilterStateBackup, "fcs20", MOTION_NAV, 20},
    {"fcsSet", &fcsSet, "fcs20", MOTION_NONE, 0},
    {"onboard2Set", &onboard2Set, "rmax1ob2", MOTION_NONE, 0},
    /* Uploaded by the GCS (gcs1 is never local here): storage for what arrives, read back with `dump`. */
    {"gcsMissionRmax1[0]", &gcsMissionRmax1[0], "gcs1", MOTION_NONE, 0},
};
#define N_DIRS (sizeof k_dirs / sizeof k_dirs[0])

/* Per directory: produced here?, which sample its storage holds, and what was received (latency from the timeTag). */
typedef struct dir_state {
    int instance;
    bool produced;
    bool sampled;         /* the storage holds sample `k` of the motion model */
    int64_t k, first_k;   /* sample instants epoch + k * period_ms; first_k: the first this process wrote */
    uint64_t rx_count;
    double lat_last_ms, lat_max_ms, lat_sum_ms;
} dir_state_t;

/* ---- program state (static: large; one node per process) --------------------------------------------- */

/* The node's own options; the shell has --config, --node, --port, --stats-ms, --duration-ms. */
typedef struct options {
    const char *record;
    bool record_tx;
    ub_log_rotation_t rotation;
    const char *impair;
    int n_ps;
    const char *ps[MAX_PS_ARGS];
    bool ps_is_pub[MAX_PS_ARGS];
    int ps_argi[MAX_PS_ARGS];
} options_t;

static ub_app_t g_app; /* the shell: the node (g_app.node), its ports, sec, config; stdout and stdin */
static options_t g_opt;
static ub_frag_t g_frag; /* directories above the payload limit or a link's MTU, in fragments (ub_frag.h) */
static ub_log_t g_log;
static bool g_logging;
static node_motion_t g_motion;
static dir_state_t g_dirs[N_DIRS];

/* The timeTag that starts every flightsw directory: CLOCK_MONOTONIC, as receivers on this machine read it. */
static timeTag_t mono_stamp(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (timeTag_t){(uint32_t)ts.tv_sec, (uint32_t)(ts.tv_nsec / 1000)};
}

/* ---- command line -------------------------------------------------------------------------------------- */

static void usage(FILE *f) {
    fprintf(f,
            "usage: uavbus_node --config FILE --node NAME [--port LINK=SPEC]... [--record FILE [--record-tx]\n"
            "                   [--record-max-bytes N] [--record-max-ms MS] [--record-max-files N]]\n"
            "                   [--impair loss=P,dup=P,reorder=P,delay=MS,jitter=MS,seed=N] [--stats-ms MS]\n"
            "                   [--duration-ms MS] [--subscribe ENTITY:CONTENT@SOURCE/PERIOD_MS]...\n"
            "                   [--publish ENTITY:CONTENT>DEST/PERIOD_MS]...\n"
            "                   [--origin-key KEYFILE --origin-peers FILE]  (origin authentication without identities:\n"
            "                   a config naming security.identity has it already; KEYFILE may contain {entity};\n"
            "                   FILE: \"ENTITY HEX_X25519_PUBLIC_KEY\" lines)\n"
            "SPEC: udp:bind=HOST:PORT[,peer=HOST:PORT][,accept=peer|learn|any] | tcp:listen=HOST:PORT |\n"
            "      tcp:connect=HOST:PORT |"
            "      serial:device=PATH[,baud=N]\n"
            "stdin commands: rebind LINK SPEC | impair SPEC | dump NAME | stats | quit |\n"
            "                key add FILE | key use ID | key remove ID | revoke FILE\n"
            "%s",
            fleet_usage);
}

/* The node's options (the shell takes its own first). */
static bool option(ub_app_t *app, const char *a, const char *v, int i) {
    options_t *o = &g_opt;
    if (strcmp(a, "--record-tx") == 0) o->record_tx = true;
    else if (strcmp(a, "--record") == 0) o->record = v;
    else if (strcmp(a, "--record-max-bytes") == 0)
        o->rotation.max_bytes = ub_app_parse_uint(app, v, i, UINT64_MAX, "a whole number of bytes");
    else if (strcmp(a, "--record-max-ms") == 0)
        o->rotation.max_ms = ub_app_parse_uint(app, v, i, UINT64_MAX, "a whole number of milliseconds");
    else if (strcmp(a, "--record-max-files") == 0) {
        uint64_t n = ub_app_parse_uint(app, v, i, UINT64_MAX, "a whole number of files");
        if (n > UINT32_MAX) ub_app_die(app, "uavbus_node:argv[%d]: '%s' files is too many (at most %u)", i, v, UINT32_MAX);
        o->rotation.max_files = (uint32_t)n;
    } else if (strcmp(a, "--impair") == 0) o->impair = v;
    else if (strcmp(a, "--subscribe") == 0 || strcmp(a, "--publish") == 0) {
        if (o->n_ps == MAX_PS_ARGS) ub_app_die(app, "uavbus_node:argv[%d]: more than %d --subscribe/--publish", i, MAX_PS_ARGS);
        o->ps_argi[o->n_ps] = i;
        o->ps_is_pub[o->n_ps] = a[2] == 'p';
        o->ps[o->n_ps++] = v;
    } else return fleet_option(app, a, v, i);
    return true;
}

/* ---- set-up ------------------------------------------------------------------------------------------- */

static int local_entity(ub_app_t *app, const char *name) {
    uint8_t id[UB_ENTITY_ID_LEN];
    if (ub_entity_id(name, id) != UB_OK) return UB_ERR_RANGE;
    int e = ub_node_find_entity(&app->node, id);
    if (e < 0) return e;
    for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++) {
        if (app->node.locals[s].in_use && app->node.locals[s].entity == e) return e;
    }
    return UB_ERR_INVAL;
}

static void bind_directories(ub_app_t *app) {
    /* Every catalogued instance flightsw_data.c defines is hosted (generated bind table), so an
     * operator can subscribe to, read or write any of them; k_dirs only adds the motion models. */
    if (flightsw_bind_all(&app->node) < 0) ub_app_die(app, "uavbus_node: the flightsw bind table does not match the catalogue");
    for (size_t i = 0; i < N_DIRS; i++) {
        int inst = ub_catalogue_find_name(&flightsw_catalogue, k_dirs[i].name);
        if (inst < 0) ub_app_die(app, "uavbus_node: directory '%s' is not in the flightsw catalogue (rebuild)", k_dirs[i].name);
        if (ub_node_bind(&app->node, (uint32_t)inst, k_dirs[i].storage) != UB_OK) {
            ub_app_die(app, "uavbus_node: cannot bind '%s' (UB_MAX_BINDINGS too small?)", k_dirs[i].name);
        }
        g_dirs[i].instance = inst;
        g_dirs[i].produced = local_entity(app, fleet_producer(k_dirs[i].name, k_dirs[i].producer)) >= 0;
    }
}

/* "ENTITY:CONTENT@SOURCE/PERIOD" (subscribe) or "ENTITY:CONTENT>DEST/PERIOD" (publish). */
static void add_pubsub(ub_app_t *app, const char *text, bool publish, int argi, uint64_t now_ms) {
    char buf[128], entity[32], content[96], peer[32];
    unsigned long period = 0;
    char sep = publish ? '>' : '@';
    if (strlen(text) >= sizeof buf) ub_app_die(app, "uavbus_node:argv[%d]: '%.40s...' is too long", argi, text);
    memcpy(buf, text, strlen(text) + 1);
    char *colon = strchr(buf, ':'), *mid = colon ? strchr(colon, sep) : NULL, *slash = mid ? strrchr(mid, '/') : NULL;
    char *end = NULL;
    if (slash != NULL) period = strtoul(slash + 1, &end, 10);
    if (colon == NULL || mid == NULL || slash == NULL || end == NULL || *end != '\0' || period == 0
        || period > UINT32_MAX || colon == buf || mid == colon + 1 || slash == mid + 1
        || (size_t)(colon - buf) >= sizeof entity || (size_t)(mid - colon - 1) >= sizeof content
        || (size_t)(slash - mid - 1) >= sizeof peer) {
        ub_app_die(app, "uavbus_node:argv[%d]: '%s': expected %s (period > 0 ms)", argi, text,
            publish ? "ENTITY:CONTENT>DEST/PERIOD_MS, e.g. rmax1ob1:gpsOut>gcs1/100"
                    : "ENTITY:CONTENT@SOURCE/PERIOD_MS, e.g. gcs1:imuOut@fcs20/20");
    }
    *colon = *mid = *slash = '\0';
    snprintf(entity, sizeof entity, "%s", buf);
    snprintf(content, sizeof content, "%s", colon + 1);
    snprintf(peer, sizeof peer, "%s", mid + 1);
    int e = local_entity(app, entity);
    if (e < 0) ub_app_die(app, "uavbus_node:argv[%d]: '%s' is not an entity hosted by this node", argi, entity);
    int inst = ub_catalogue_find_name(&flightsw_catalogue, content);
    if (inst < 0) ub_app_die(app, "uavbus_node:argv[%d]: no directory '%s' in the flightsw catalogue", argi, content);
    if (ub_node_binding(&app->node, (uint32_t)inst) == NULL) {
        ub_app_die(app, "uavbus_node:argv[%d]: no storage for '%s' (flightsw_data.c does not define it)", argi, content);
    }
    uint8_t pid[UB_ENTITY_ID_LEN];
    if (ub_entity_id(peer, pid) != UB_OK || ub_node_find_entity(&app->node, pid) < 0) {
        ub_app_die(app, "uavbus_node:argv[%d]: '%s' is not an entity of the config", argi, peer);
    }
    int rc = publish ? ub_pubsub_publish(&app->node, e, (uint32_t)inst, pid, (uint32_t)period, now_ms)
                     : ub_pubsub_subscribe(&app->node, e, (uint32_t)inst, pid, (uint32_t)period, now_ms);
    if (rc < 0) ub_app_die(app, "uavbus_node:argv[%d]: '%s' refused: %s", argi, text, ub_strerror(rc));
}

/* ---- events ------------------------------------------------------------------------------------------- */

static void out_port(ub_app_t *app, const ub_port_t *p, const char *name) {
    char spec[128];
    uint16_t lp = 0;
    ub_port_spec_format(&p->spec, spec, sizeof spec);
    ub_app_out(app, "\"transport\":\"%s\",\"spec\":", ub_port_spec_transport(&p->spec));
    ub_app_str(app, spec, SIZE_MAX);
    if (ub_ports_local_port(&app->ports, name, &lp) == UB_OK) ub_app_out(app, ",\"local_port\":%u", (unsigned)lp);
    else if (p->spec.kind == UB_PORT_TCP_CONNECT) ub_app_out(app, ",\"local_port\":null,\"connect_port\":%u", (unsigned)p->spec.port);
    else ub_app_out(app, ",\"local_port\":null");
}

static void ready_port(ub_app_t *app, int id, const ub_link_t *l, const ub_port_t *p) {
    (void)id;
    out_port(app, p, l->name);
}

static void event_ready(ub_app_t *app) {
    ub_app_out(app, "{\"event\":\"ready\",\"node\":");
    ub_app_str(app, app->node_name, SIZE_MAX);
    ub_app_out(app, ",\"pid\":%ld,\"t_ms\":%" PRIu64 ",\"entities\":[", (long)getpid(), ub_app_mono_ms());
    bool first = true;
    for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++) {
        if (!app->node.locals[s].in_use) continue;
        ub_app_out(app, first ? "" : ",");
        ub_app_entity(app, ub_node_entity_id(&app->node, app->node.locals[s].entity));
        first = false;
    }
    ub_app_out(app, "],\"ports\":");
    ub_app_links(app, true, ready_port);
    ub_app_out(app, ",\"produces\":[");
    first = true;
    for (size_t i = 0; i < N_DIRS; i++) {
        if (!g_dirs[i].produced) continue;
        ub_app_out(app, "%s\"%s\"", first ? "" : ",", k_dirs[i].name);
        first = false;
    }
    ub_app_out(app, "]}");
    ub_app_flush(app);
}

static void out_impair(ub_app_t *app, const ub_port_t *p) {
    const ub_impair_stats_t *s = ub_impair_stats(&p->impair);
    ub_app_out(app, ",\"impair\":{\"offered\":%" PRIu64 ",\"lost\":%" PRIu64 ",\"duplicated\":%" PRIu64 ",\"reordered\":%" PRIu64
        ",\"delayed\":%" PRIu64 ",\"queue_full\":%" PRIu64 ",\"passed\":%" PRIu64 ",\"inner_again\":%" PRIu64
        ",\"inner_errors\":%" PRIu64 ",\"shed\":%" PRIu64 ",\"pending\":%zu}",
        s->offered, s->lost, s->duplicated, s->reordered, s->delayed, s->queue_full, s->passed, s->inner_again,
        s->inner_errors, s->shed, ub_impair_pending(&p->impair));
}

/* The port's driver object ("udp":{...}), written by its driver table (ub_driver.h), built-in or registered. */
static void out_driver(ub_app_t *app, const char *name) {
    char text[2048];
    if (ub_ports_describe(&app->ports, name, text, sizeof text) > 0) ub_app_out(app, ",%s", text);
}

static void out_keys(ub_app_t *app) {
    uint8_t ids[UB_MAX_KEYS];
    size_t n = ub_sec_key_ids(&app->sec, ids, UB_MAX_KEYS);
    ub_app_out(app, "\"tx_key\":%u,\"keys\":[", (unsigned)ub_sec_tx_key(&app->sec));
    for (size_t i = 0; i < n && i < UB_MAX_KEYS; i++) ub_app_out(app, "%s%u", i ? "," : "", (unsigned)ids[i]);
    ub_app_out(app, "]");
}

/* The security context's counters ("security":null without a "security" section). */
static void out_security(ub_app_t *app) {
    if (ub_node_security(&app->node) == NULL) {
        ub_app_out(app, ",\"security\":null");
        return;
    }
    const ub_sec_stats_t *s = ub_sec_stats(&app->sec);
    ub_app_out(app, ",\"security\":{");
    out_keys(app);
    ub_app_out(app, ",\"signed_out\":%" PRIu64 ",\"encrypted_out\":%" PRIu64 ",\"verified_in\":%" PRIu64 ",\"decrypted_in\":%" PRIu64
        ",\"auth_failures\":%" PRIu64 ",\"unknown_keys\":%" PRIu64 ",\"challenges_sent\":%" PRIu64
        ",\"challenges_completed\":%" PRIu64 ",\"replies_sent\":%" PRIu64 ",\"replies_suppressed\":%" PRIu64
        ",\"reservations\":%" PRIu64 ",\"reserve_failures\":%" PRIu64 ",\"tx_refused\":%" PRIu64
        ",\"rechallenges\":%" PRIu64 ",\"window_resets\":%" PRIu64 ",\"counter_mark\":%" PRIu64,
        s->signed_out, s->encrypted_out, s->verified_in, s->decrypted_in, s->auth_failures, s->unknown_keys,
        s->challenges_sent, s->challenges_completed, s->replies_sent, s->replies_suppressed, s->reservations,
        s->reserve_failures, s->tx_refused, s->rechallenges, s->window_resets, app->counter.mark);
    /* Origin authentication (identities, or --origin-key): its counters, or null. */
    if (!app->origin_on) {
        ub_app_out(app, ",\"origin\":null}");
        return;
    }
    const ub_origin_stats_t *o = ub_origin_stats(&app->origin);
    ub_app_out(app, ",\"origin\":{\"sealed\":%" PRIu64 ",\"opened\":%" PRIu64 ",\"bad_origin\":%" PRIu64
        ",\"no_origin\":%" PRIu64 ",\"no_identity\":%" PRIu64 ",\"derivations\":%" PRIu64 ",\"evictions\":%" PRIu64
        ",\"cached\":%zu}}",
        o->sealed, o->opened, o->bad_origin, o->no_origin, o->no_identity, o->derivations, o->evictions,
        ub_origin_cached(&app->origin));
}

/* The identity store's and the revocation service's counters ("identity":null without an authority). */
static void out_identity(ub_app_t *app) {
    if (!app->ident_on) {
        ub_app_out(app, ",\"identity\":null");
        return;
    }
    const ub_ident_stats_t *s = ub_ident_stats(&app->ident);
    const ub_revoke_stats_t *r = ub_revoke_stats(&app->revoke);
    const ub_cert_t *self = ub_ident_self(&app->ident);
    uint32_t refused = 0, lookups_refused = 0;
    for (int i = 0; i < 8; i++) {
        refused += s->peers_refused[i];
        lookups_refused += s->lookups_refused[i];
    }
    ub_app_out(app, ",\"identity\":{\"serial\":%" PRIu64 ",\"roles\":%u,\"revocations\":%u,\"peers_added\":%" PRIu32
        ",\"peers_refused\":%" PRIu32 ",\"peers_removed\":%" PRIu32 ",\"lookups\":%" PRIu32 ",\"lookups_refused\":%" PRIu32
        ",\"revocations_received\":%" PRIu32 ",\"revocations_accepted\":%" PRIu32 ",\"revocations_known\":%" PRIu32
        ",\"revocations_refused\":%" PRIu32 ",\"revocations_sent\":%" PRIu32 ",\"revocations_over_budget\":%" PRIu32
        ",\"persisted\":%" PRIu32 ",\"persist_failures\":%" PRIu32 ",\"certs_accepted\":%" PRIu32
        ",\"certs_known\":%" PRIu32 ",\"certs_refused\":%" PRIu32 ",\"certs_sent\":%" PRIu32 "}",
        self != NULL ? self->serial : 0, self != NULL ? (unsigned)self->roles : 0u,
        (unsigned)ub_ident_revocation_count(&app->ident), s->peers_added, refused, s->peers_removed, s->lookups,
        lookups_refused, r->received, r->accepted, r->known, r->refused + r->full, r->sent, r->over_budget,
        r->persisted, r->persist_failures, r->certs_accepted, r->certs_known, r->certs_refused, r->certs_sent);
}

/* `revoke FILE`: the records of a revocations file (uavbus keys revoke ENTITY) handed to the revocation
 * service, which verifies them, persists them and spreads them to the fleet. */
static void revoke_command(ub_app_t *app, char *save, uint64_t now_ms) {
    char msg[UB_IDENTFILE_ERR_LEN + 64], err[UB_IDENTFILE_ERR_LEN];
    char *path = strtok_r(NULL, " \t\r", &save);
    if (path == NULL) {
        ub_app_error(app, "revoke: expected 'revoke FILE' (a revocations file: uavbus keys revoke ENTITY)");
        return;
    }
    if (!app->ident_on) {
        ub_app_error(app, "revoke: this node has no identities (the config's \"security\" section names no authority)");
        return;
    }
    static uint8_t records[UB_IDENT_MAX_REVOCATIONS * UB_REVOCATION_LEN];
    int n = ub_revfile_read(path, records, UB_IDENT_MAX_REVOCATIONS, err, sizeof err);
    if (n < 0) {
        snprintf(msg, sizeof msg, "revoke: %s", err);
        ub_app_error(app, msg);
        return;
    }
    unsigned accepted = 0, known = 0, refused = 0;
    for (int i = 0; i < n; i++) {
        int rc = ub_revoke_submit(&app->revoke, records + (size_t)i * UB_REVOCATION_LEN, UB_REVOCATION_LEN, now_ms);
        if (rc == UB_OK) accepted++;
        else if (rc == UB_ERR_EXISTS) known++;
        else refused++;
    }
    if (refused > 0) {
        snprintf(msg, sizeof msg, "revoke: %s: %u of %d records refused (another authority's, or damaged)", path,
                 refused, n);
        ub_app_error(app, msg);
    }
    ub_app_out(app, "{\"event\":\"revoke\",\"file\":");
    ub_app_str(app, path, SIZE_MAX);
    ub_app_out(app, ",\"accepted\":%u,\"known\":%u,\"refused\":%u,\"revocations\":%u}", accepted, known, refused,
               (unsigned)ub_ident_revocation_count(&app->ident));
    ub_app_flush(app);
}

static void link_stats(ub_app_t *app, int id, const ub_link_t *l, const ub_port_t *p) {
    const ub_link_counters_t *c = &l->counters;
    ub_app_out(app, "\"id\":%d,\"frames_in\":%" PRIu64 ",\"bytes_in\":%" PRIu64 ",\"frames_out\":%" PRIu64
        ",\"bytes_out\":%" PRIu64 ",\"frames_accepted\":%" PRIu64 ",\"require_signed\":%s,\"encrypt\":%s,",
        id, c->frames_in, c->bytes_in, c->frames_out, c->bytes_out, c->frames_accepted,
        ub_node_link_requires_signed(&app->node, id) ? "true" : "false", l->encrypt ? "true" : "false");
    ub_app_drops(app, c->drops);
    ub_app_out(app, ",\"bad\":{");
    for (int r = 0; r < UB_RX_REASON_COUNT; r++) {
        ub_app_out(app, "%s\"%s\":%" PRIu64, r ? "," : "", ub_rx_reason_name((ub_rx_reason_t)r),
            ub_node_link_bad_frames(&app->node, id, (ub_rx_reason_t)r));
    }
    ub_app_out(app, "}");
    const ub_compact_t *cs = ub_node_link_compact(&app->node, id);
    if (cs != NULL) { /* a compact link: its dictionary exchange and what it refused (issue 29) */
        const ub_compact_stats_t *k = &cs->stats;
        ub_app_out(app, ",\"compact\":{\"agreed\":%s,\"tx_frames\":%" PRIu64 ",\"rx_frames\":%" PRIu64
            ",\"tx_bytes\":%" PRIu64 ",\"tx_full_bytes\":%" PRIu64 ",\"hello_tx\":%" PRIu64 ",\"hello_rx\":%" PRIu64
            ",\"hello_bad\":%" PRIu64 ",\"peer_restarts\":%" PRIu64 ",\"peer_lists\":%" PRIu64
            ",\"dict_changes\":%" PRIu64 ",\"dict_limited\":%" PRIu64 "}",
            ub_compact_agreed(cs) ? "true" : "false", k->tx_frames, k->rx_frames, k->tx_bytes, k->tx_full_bytes,
            k->hello_tx, k->hello_rx, k->hello_bad, k->peer_restarts, k->peer_lists, k->dict_changes,
            k->dict_limited);
    }
    if (p != NULL) {
        ub_app_out(app, ",\"port\":{");
        out_port(app, p, l->name);
        ub_app_out(app, ",\"rebinds\":%" PRIu32 ",\"service_errors\":%" PRIu64 "}", p->rebinds, p->service_errors);
        out_driver(app, l->name);
        if (p->impaired) out_impair(app, p);
    } else {
        ub_app_out(app, ",\"port\":null");
    }
}

static const char *k_sub_states[] = {"requesting", "receiving", "stopping"};

static void event_stats(ub_app_t *app, uint64_t now_ms, bool final) {
    const ub_node_counters_t *n = ub_node_counters(&app->node);
    ub_app_out(app, "{\"event\":\"stats\",\"t_ms\":%" PRIu64 ",\"uptime_ms\":%" PRIu64 "%s,\"node\":{\"originated\":%" PRIu64
        ",\"forwarded\":%" PRIu64 ",\"delivered\":%" PRIu64 ",\"admin_handled\":%" PRIu64 ",\"local_direct\":%" PRIu64
        ",\"dedup_resets\":%" PRIu64 ",\"dedup_evictions\":%" PRIu64 ",\"leases_expired\":%" PRIu64
        ",\"replies_unmatched\":%" PRIu64 ",\"requests_limited\":%" PRIu64 ",\"leases_clamped\":%" PRIu64
        ",\"rows_evicted\":%" PRIu64 ",\"random_failures\":%" PRIu64 ",\"handovers\":%" PRIu64
        ",\"nacks_relayed\":%" PRIu64 ",\"other_admin\":%" PRIu64 ",",
        now_ms, now_ms - app->start_ms, final ? ",\"final\":true" : "", n->originated, n->forwarded, n->delivered,
        n->admin_handled, n->local_direct, n->dedup_resets, n->dedup_evictions, n->leases_expired,
        n->replies_unmatched, n->requests_limited, n->leases_clamped, n->rows_evicted, n->random_failures,
        n->handovers, n->nacks_relayed, n->other_admin);
    ub_app_drops(app, n->drops);
    ub_app_out(app, "},\"links\":");
    ub_app_links(app, false, link_stats);
    const ub_frag_stats_t *fs = ub_node_frag_stats(&app->node);
    if (fs != NULL) { /* fragment reassembly and its bounds (ub_frag.h) */
        ub_app_out(app, ",\"fragments\":{\"tx_transfers\":%" PRIu64 ",\"tx_fragments\":%" PRIu64 ",\"tx_busy\":%" PRIu64
            ",\"tx_abandoned\":%" PRIu64 ",\"rx_started\":%" PRIu64 ",\"rx_complete\":%" PRIu64 ",\"rx_duplicates\":%" PRIu64
            ",\"rx_timeouts\":%" PRIu64 ",\"rx_evicted\":%" PRIu64 ",\"rx_refused\":%" PRIu64 ",\"rx_source_limit\":%" PRIu64
            ",\"rx_restarted\":%" PRIu64 ",\"rx_bad\":%" PRIu64 ",\"pending\":%zu}",
            fs->tx_transfers, fs->tx_fragments, fs->tx_busy, fs->tx_abandoned, fs->rx_started, fs->rx_complete,
            fs->rx_duplicates, fs->rx_timeouts, fs->rx_evicted, fs->rx_refused, fs->rx_source_limit, fs->rx_restarted,
            fs->rx_bad, ub_frag_pending(&g_frag));
    }
    ub_app_out(app, ",\"pubsub\":{");
    bool first = true;
    for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++) {
        const ub_local_entity_t *le = &app->node.locals[s];
        if (!le->in_use) continue;
        ub_app_out(app, "%s", first ? "" : ",");
        first = false;
        ub_app_entity(app, ub_node_entity_id(&app->node, le->entity));
        ub_app_out(app, ":[");
        bool rfirst = true;
        for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) {
            const ub_ps_row_t *row = ub_pubsub_row(&app->node, le->entity, r);
            if (row == NULL || row->kind == UB_PS_FREE) continue;
            bool pub = row->kind == UB_PS_PUBLICATION;
            ub_app_out(app, "%s{\"row\":%d,\"kind\":\"%s\",\"content\":", rfirst ? "" : ",", r, pub ? "publication" : "subscription");
            rfirst = false;
            ub_app_str(app, flightsw_catalogue.instances[row->instance].name, SIZE_MAX);
            ub_app_out(app, ",\"%s\":", pub ? "destination" : "source");
            ub_app_entity(app, row->peer);
            ub_app_out(app, ",\"period_ms\":%" PRIu32 ",\"frames\":%" PRIu64 ",\"lease_until_ms\":%" PRIu64, row->period_ms,
                row->frames, row->lease_until_ms);
            if (!pub) ub_app_out(app, ",\"state\":\"%s\",\"acked\":%s", k_sub_states[row->state % 3], row->acked ? "true" : "false");
            bool remote = false;
            for (int k = 0; k < UB_ENTITY_ID_LEN; k++) remote = remote || row->owner[k] != 0;
            if (remote) {
                ub_app_out(app, ",\"owner\":");
                ub_app_entity(app, row->owner);
            }
            ub_app_out(app, "}");
        }
        ub_app_out(app, "]");
    }
    ub_app_out(app, "},\"received\":{");
    first = true;
    for (size_t i = 0; i < N_DIRS; i++) {
        const dir_state_t *d = &g_dirs[i];
        if (d->rx_count == 0) continue;
        ub_app_out(app, "%s\"%s\":{\"count\":%" PRIu64 ",\"latency_ms\":{\"last\":%.3f,\"max\":%.3f,\"mean\":%.3f}}", first ? "" : ",",
            k_dirs[i].name, d->rx_count, d->lat_last_ms, d->lat_max_ms, d->lat_sum_ms / (double)d->rx_count);
        first = false;
    }
    ub_app_out(app, "}");
    if (g_logging) {
        const ub_log_stats_t *s = ub_log_stats(&g_log);
        ub_app_out(app, ",\"log\":{\"records\":%" PRIu64 ",\"bytes\":%" PRIu64 ",\"write_errors\":%" PRIu64 ",\"skipped_tx\":%" PRIu64
            ",\"torn_writes\":%" PRIu64 ",\"recoveries\":%" PRIu64 ",\"file_index\":%" PRIu32 ",\"files\":%" PRIu64
            ",\"files_deleted\":%" PRIu64 ",\"open_errors\":%" PRIu64 ",\"limit_rotations\":%" PRIu64
            ",\"failing\":%s,\"last_error\":",
            s->records, s->bytes, s->write_errors, s->skipped_tx, s->torn_writes, s->recoveries,
            ub_log_file_index(&g_log), s->files, s->files_deleted, s->open_errors, s->limit_rotations,
            g_log.failing ? "true" : "false");
        if (s->last_errno != 0) ub_app_str(app, strerror(s->last_errno), SIZE_MAX);
        else ub_app_out(app, "null");
        ub_app_out(app, "}");
    }
    out_security(app);
    out_identity(app);
    fleet_stats(app);
    ub_app_out(app, ",\"stdin_dropped\":%" PRIu64 ",\"wakeups\":%" PRIu64 "}", app->stdin_dropped, app->wakeups);
    ub_app_flush(app);
}

/* ---- run time ----------------------------------------------------------------------------------------- */

/* Latency of received directories: every flightsw directory starts with a timeTag stamped on CLOCK_MONOTONIC. */
static void on_deliver(void *user, int entity, uint32_t instance, const ub_frame_header_t *h, uint64_t now_ms) {
    (void)user;
    fleet_on_deliver(entity, instance, h, now_ms);
    for (size_t i = 0; i < N_DIRS; i++) {
        if (g_dirs[i].instance != (int)instance) continue;
        const timeTag_t *t = (const timeTag_t *)k_dirs[i].storage;
        timeTag_t now = mono_stamp();
        double lat = ((double)now.seconds - (double)t->seconds) * 1000.0
                     + ((double)now.microseconds - (double)t->microseconds) / 1000.0;
        dir_state_t *d = &g_dirs[i];
        d->rx_count++;
        d->lat_last_ms = lat;
        if (lat > d->lat_max_ms) d->lat_max_ms = lat;
        d->lat_sum_ms += lat;
    }
}

/* ---- motion models --------------------------------------------------------------------------------------
 *
 * A produced directory holds the model's sample at its latest instant s = epoch + k * period_ms <= now
 * (epoch: --epoch-ms, else the start): the model at t = k * period_ms (t < 0 counts as 0), timeTag s on
 * CLOCK_MONOTONIC, and its counter (solutionCount, sampleCount, updateCount) k - first_k + 1, first_k being
 * the instant of the first sample this process wrote (at start). Every field is a function of k alone
 * (node_motion.h: the model integrates nothing), so a sample is the same whenever it is computed.
 *
 * So the models are sampled lazily: motion_catch_up() brings every produced directory to `now` each time
 * the loop wakes, before stdin, the ports and the tick -- the only places the storage is read (a
 * publication, a read request, `dump`, the log's copy of what is sent). The models have no timers of their
 * own: a sample nobody reads wakes nobody (at 100 Hz imuOut and 50 Hz navFilterState it was ~9 wake-ups in
 * 10, issue 28 item 5). What a reader sees is what sampling every period_ms on time would have left there;
 * the old eager loop stamped the moment it woke instead, up to its wake-up delay late. */

static int64_t sample_index(uint64_t now_ms, uint64_t epoch_ms, uint32_t period_ms) {
    if (now_ms >= epoch_ms) return (int64_t)((now_ms - epoch_ms) / period_ms);
    return -(int64_t)((epoch_ms - now_ms + period_ms - 1) / period_ms); /* floor: the instant at or before now */
}

static void motion_catch_up(uint64_t now_ms) {
    uint64_t epoch = fleet_epoch_ms(g_app.start_ms);
    for (size_t i = 0; i < N_DIRS; i++) {
        dir_state_t *d = &g_dirs[i];
        const directory_t *dk = &k_dirs[i];
        if (!d->produced || dk->motion == MOTION_NONE) continue;
        int64_t k = sample_index(now_ms, epoch, dk->period_ms);
        if (d->sampled && k == d->k) continue; /* now only grows: the storage holds this sample already */
        if (!d->sampled) d->first_k = k;
        d->sampled = true;
        d->k = k;
        int64_t at_ms = (int64_t)epoch + k * (int64_t)dk->period_ms;
        if (at_ms < 0) at_ms = 0;
        timeTag_t stamp = {(uint32_t)(at_ms / 1000), (uint32_t)(at_ms % 1000) * 1000u};
        double t_s = (double)k * (double)dk->period_ms / 1000.0;
        uint32_t count = (uint32_t)(k - d->first_k + 1);
        switch (dk->motion) {
        case MOTION_GPS: node_motion_gps(&g_motion, t_s, stamp, count, dk->storage); break;
        case MOTION_IMU: node_motion_imu(&g_motion, t_s, dk->period_ms / 1000.0, stamp, count, dk->storage); break;
        case MOTION_NAV: node_motion_nav(&g_motion, t_s, stamp, count, dk->storage); break;
        default: break;
        }
    }
}

static void apply_impair(ub_app_t *app, const char *text, bool at_start) {
    ub_impair_params_t params;
    uint64_t seed = 1;
    char err[160], msg[256];
    if (ub_impair_parse(text, &params, &seed, err, sizeof err) != UB_OK) {
        if (at_start) ub_app_die(app, "uavbus_node: --impair: %s", err);
        snprintf(msg, sizeof msg, "impair: %s", err);
        ub_app_error(app, msg);
        return;
    }
    if (ub_ports_set_impairment(&app->ports, &params, seed) != UB_OK) ub_app_error(app, "impair: refused");
}

/* Key rotation (docs/security.md): `key add FILE` (accept a key), `key use ID` (sign with it),
 * `key remove ID` (retire one; never the signing key). Answers with a "key" event or an error. */
static void key_command(ub_app_t *app, char *save) {
    char msg[UB_SECFILE_ERR_LEN + 64];
    char *action = strtok_r(NULL, " \t\r", &save);
    char *arg = strtok_r(NULL, " \t\r", &save);
    if (action == NULL || arg == NULL) {
        ub_app_error(app, "key: expected 'key add FILE', 'key use ID' or 'key remove ID'");
        return;
    }
    if (ub_node_security(&app->node) == NULL) {
        ub_app_error(app, "key: this node runs without security (the config has no \"security\" section)");
        return;
    }
    int rc;
    unsigned id = 0;
    if (strcmp(action, "add") == 0) {
        uint8_t kid = 0, key[UB_SEC_KEY_LEN];
        char err[UB_SECFILE_ERR_LEN];
        if (ub_keyfile_load(arg, &kid, key, err, sizeof err) != UB_OK) {
            snprintf(msg, sizeof msg, "key add: %s", err);
            ub_app_error(app, msg);
            return;
        }
        rc = ub_sec_add_key(&app->sec, kid, key);
        memset(key, 0, sizeof key);
        id = kid;
    } else if (strcmp(action, "use") == 0 || strcmp(action, "remove") == 0) {
        char *end = NULL;
        unsigned long v = strtoul(arg, &end, 10);
        if (end == arg || *end != '\0' || v < 1 || v > 255) {
            snprintf(msg, sizeof msg, "key %s: '%.16s' is not a key id 1..255", action, arg);
            ub_app_error(app, msg);
            return;
        }
        id = (unsigned)v;
        rc = action[0] == 'u' ? ub_sec_set_tx_key(&app->sec, (uint8_t)id) : ub_sec_remove_key(&app->sec, (uint8_t)id);
    } else {
        snprintf(msg, sizeof msg, "key: unknown action '%.16s' (expected add, use or remove)", action);
        ub_app_error(app, msg);
        return;
    }
    if (rc != UB_OK) {
        const char *why = rc == UB_ERR_EXISTS ? "a key with this id is already loaded"
                        : rc == UB_ERR_FULL ? "the keyring is full (remove a retired key first)"
                        : rc == UB_ERR_NOTFOUND ? "no key with this id is loaded"
                        : action[0] == 'r' ? "it signs what this node sends: 'key use' another key first"
                                           : ub_strerror(rc);
        snprintf(msg, sizeof msg, "key %s %u: %s", action, id, why);
        ub_app_error(app, msg);
        return;
    }
    ub_app_out(app, "{\"event\":\"key\",\"action\":\"%s\",\"id\":%u,", action, id);
    out_keys(app);
    ub_app_out(app, "}");
    ub_app_flush(app);
}

/* The node's stdin commands (the shell answers `stats` and `quit`). */
static bool command(ub_app_t *app, const char *verb, char **saved, uint64_t now_ms) {
    char *save = *saved;
    char msg[UB_PORTS_ERR_LEN + 64];
    if (strcmp(verb, "dump") == 0) {
        /* The bound C struct packed again with the generated codec: a sender can check that this
         * process unpacked what it sent into identical bytes (tests/system, mixed languages). */
        char *name = strtok_r(NULL, " \t\r", &save);
        int inst = name != NULL ? ub_catalogue_find_name(&flightsw_catalogue, name) : UB_ERR_NOTFOUND;
        void *storage = inst >= 0 ? ub_node_binding(&app->node, (uint32_t)inst) : NULL;
        if (storage == NULL) {
            snprintf(msg, sizeof msg, "dump: '%.40s' is not a directory this node binds", name != NULL ? name : "");
            ub_app_error(app, msg);
            return true;
        }
        const ub_type_desc_t *type = flightsw_catalogue.instances[inst].type;
        uint8_t packed[UB_MAX_PAYLOAD];
        int n = type->pack(storage, packed, sizeof packed);
        ub_app_out(app, "{\"event\":\"dump\",\"name\":");
        ub_app_str(app, name, SIZE_MAX);
        ub_app_out(app, ",\"packed\":\"");
        for (int i = 0; i < n; i++) ub_app_out(app, "%02x", packed[i]);
        ub_app_out(app, "\"}");
        ub_app_flush(app);
    } else if (strcmp(verb, "impair") == 0) {
        char *spec = strtok_r(NULL, " \t\r", &save);
        apply_impair(app, spec != NULL ? spec : "", false);
    } else if (strcmp(verb, "rebind") == 0) {
        char *name = strtok_r(NULL, " \t\r", &save);
        char *spec = strtok_r(NULL, " \t\r", &save);
        char err[UB_PORTS_ERR_LEN];
        if (name == NULL || spec == NULL) {
            ub_app_error(app, "rebind: expected 'rebind LINK SPEC', e.g. rebind onboardPortIPC udp:bind=127.0.0.1:0,peer=127.0.0.1:5001");
            return true;
        }
        if (ub_ports_open_text(&app->ports, name, spec, now_ms, err, sizeof err) != UB_OK) {
            snprintf(msg, sizeof msg, "rebind: %s", err);
            ub_app_error(app, msg);
            return true;
        }
        const ub_port_t *p = ub_ports_find(&app->ports, name);
        ub_app_out(app, "{\"event\":\"rebound\",\"port\":");
        ub_app_str(app, name, SIZE_MAX);
        ub_app_out(app, ",");
        out_port(app, p, name);
        ub_app_out(app, ",\"rebinds\":%" PRIu32 "}", p->rebinds);
        ub_app_flush(app);
    } else if (strcmp(verb, "key") == 0) {
        key_command(app, save);
    } else if (strcmp(verb, "revoke") == 0) {
        revoke_command(app, save, now_ms);
    } else {
        return fleet_command(verb, saved, now_ms); /* node_fleet.c */
    }
    return true;
}

static void on_wake(ub_app_t *app, uint64_t now_ms) {
    (void)app;
    motion_catch_up(now_ms);
}

static void after_tick(ub_app_t *app, uint64_t now_ms) {
    (void)app;
    fleet_poll(now_ms);
}

/* The program's own timers: the fleet's "flows" events. The motion models have none (sampled lazily, above);
 * membership results arrive with frames, which wake the loop anyway. */
static uint64_t program_next_due(ub_app_t *app, uint64_t now_ms) {
    (void)app;
    return fleet_next_due(now_ms);
}

/* The log's rotation: every file deleted to keep --record-max-files is said, never silent. */
static void on_log_event(void *user, ub_log_event_t event, uint32_t index, const char *name) {
    ub_app_t *app = user;
    char msg[UB_LOG_PATH_MAX + 96];
    if (event == UB_LOG_EVENT_FILE_DELETED) {
        snprintf(msg, sizeof msg, "log: deleted %s (file %lu) to keep --record-max-files", name, (unsigned long)index);
        ub_app_warning(app, msg);
    } else if (event == UB_LOG_EVENT_DELETE_FAILED) {
        snprintf(msg, sizeof msg, "log: could not delete %s (file %lu) to keep --record-max-files: %s", name,
                 (unsigned long)index, strerror(errno));
        ub_app_warning(app, msg);
    }
}

/* After the shell's command line: the node, what it hosts, its ports, its "ready" event. */
static void setup(ub_app_t *app) {
    const options_t *o = &g_opt;
    ub_app_start(app, &flightsw_catalogue, &g_frag);
    node_motion_init(&g_motion);
    bind_directories(app);
    fleet_setup(app, &g_motion, ub_app_mono_ms());

    app->start_ms = ub_app_mono_ms(); /* the motion's t = 0 and --duration-ms count from here */
    motion_catch_up(app->start_ms); /* storage holds a valid sample before anything can be sent */
    ub_node_set_deliver_hook(&app->node, on_deliver, NULL);
    if (o->impair != NULL) apply_impair(app, o->impair, true);
    /* Device adapters (docs/adapters.md): a port spec names them like any transport. */
    if (ub_ports_register(&app->ports, &adapter_nmea.driver) != UB_OK) ub_app_die(app, "uavbus_node: cannot register the nmea adapter");
    if (ub_ports_register(&app->ports, &adapter_ubx.driver) != UB_OK) ub_app_die(app, "uavbus_node: cannot register the ubx adapter");
    ub_app_open_ports(app, app->start_ms);
    for (int i = 0; i < o->n_ps; i++) add_pubsub(app, o->ps[i], o->ps_is_pub[i], o->ps_argi[i], app->start_ms);
    if (o->record != NULL) {
        /* ub_log_open_path() opens (and rotates) the files itself; a file-size limit comes back as EFBIG
         * since SIGXFSZ is ignored, and the log moves on to its next file. */
        int rc = ub_log_open_path(&g_log, o->record, &o->rotation, &app->node, app->node_name, o->record_tx,
                                  ub_app_unix_ms(), app->start_ms);
        uint64_t min_bytes = 0;
        if (rc == UB_ERR_RANGE && ub_log_rotation_floor(&app->node, app->node_name, &min_bytes) == UB_OK)
            ub_app_die(app, "%s: --record-max-bytes %" PRIu64 " is below %" PRIu64 ", the smallest file that holds the "
                       "log header (meta and catalogue, twice) and one largest record: raise it",
                       o->record, o->rotation.max_bytes, min_bytes);
        if (rc != UB_OK) ub_app_die(app, "%s: cannot start the log: %s (%s)", o->record, ub_strerror(rc), strerror(errno));
        ub_log_set_event_fn(&g_log, on_log_event, app);
        ub_node_set_tap(&app->node, ub_log_tap, &g_log);
        g_logging = true;
    }
    event_ready(app);
}

static void close_log(ub_app_t *app) {
    if (!g_logging) return;
    ub_node_set_tap(&app->node, NULL, NULL);
    ub_log_close(&g_log);
}

static const char *const k_flags[] = {"--record-tx", NULL};

static const ub_app_program_t k_program = {
    .name = "uavbus_node",
    .usage = usage,
    .config_hint = "(e.g. --config examples/configs/table2.json)",
    .commands = "rebind LINK SPEC, impair SPEC, dump NAME, stats, quit, key ..., or a fleet command: see --help",
    .flags = k_flags,
    .option = option,
    .command = command,
    .setup = setup,
    .close = close_log,
    .wake = on_wake,
    .after_tick = after_tick,
    .next_due = program_next_due,
    .stats = event_stats,
};

int main(int argc, char **argv) { return ub_app_main(&g_app, &k_program, argc, argv); }
