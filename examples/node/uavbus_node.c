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
 * stdout, one JSON object per line: "ready", "stats", "rebound", "error".
 * stdin takes line commands: `rebind NAME SPEC`, `impair SPEC`, `dump NAME`, `stats`, `quit`, and for
 * key rotation `key add FILE`, `key use ID`, `key remove ID` (docs/security.md).
 * See examples/node/README.md.
 *
 * One poll() loop drives everything; the time is CLOCK_MONOTONIC in ms, the
 * same clock that stamps the directories' timeTag. All large state is static
 * (ub_node_t, ub_ports_t, ub_nodecfg_t are sized by ub_config.h, no malloc).
 */
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <poll.h>
#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "ub/ub_impair.h"
#include "ub/ub_log.h"
#include "ub/ub_node.h"
#include "ub/ub_nodecfg.h"
#include "ub/ub_ports.h"
#include "ub/ub_pubsub.h"
#include "ub/ub_random.h"
#include "ub/ub_sec.h"
#include "ub/ub_secfile.h"

#include "flightsw.h"
#include "gps.h"
#include "imu.h"
#include "navfilter.h"
#include "node_fleet.h"
#include "node_motion.h"
#include "node_out.h"
#include "onboard.h"
#include "waypoints.h"

#define EXIT_USAGE 2
#define MAX_PORT_ARGS 16
#define MAX_PS_ARGS 16
#define LOOP_MAX_WAIT_MS 1 /* publications are due on whole ms: wake at least every ms */

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

/* Per directory: produced here?, next update, and what was received (latency from the timeTag). */
typedef struct dir_state {
    int instance;
    bool produced;
    uint64_t next_ms;
    uint64_t rx_count;
    double lat_last_ms, lat_max_ms, lat_sum_ms;
} dir_state_t;

/* ---- program state (static: large, and the signal handler needs a flag) ---------------------------- */

typedef struct options {
    const char *config;
    const char *node;
    const char *record;
    bool record_tx;
    ub_log_rotation_t rotation;
    const char *impair;
    uint64_t stats_ms;
    uint64_t duration_ms;
    bool has_duration;
    int n_ports;
    const char *ports[MAX_PORT_ARGS];
    int port_argi[MAX_PORT_ARGS];
    int n_ps;
    const char *ps[MAX_PS_ARGS];
    bool ps_is_pub[MAX_PS_ARGS];
    int ps_argi[MAX_PS_ARGS];
} options_t;

static volatile sig_atomic_t g_stop;
static ub_nodecfg_t g_cfg;
static char g_cfg_text[1 << 16];
static ub_node_t g_node;
static ub_frag_t g_frag; /* directories above the payload limit or a link's MTU, in fragments (ub_frag.h) */
static ub_sec_t g_sec;                /* used when the config has a "security" section */
static ub_counter_file_t g_counter;
static ub_ports_t g_ports;
static ub_log_t g_log;
static bool g_logging;
static node_motion_t g_motion;
static dir_state_t g_dirs[N_DIRS];
static uint64_t g_start_ms;
static char g_out[1 << 16]; /* one JSON line */
static size_t g_out_len;
static bool g_out_overflow;
static uint64_t g_stdin_dropped; /* bytes of over-long command lines */

static void on_signal(int sig) {
    (void)sig;
    g_stop = 1;
}

static uint64_t mono_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / 1000000u;
}

static timeTag_t mono_stamp(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (timeTag_t){(uint32_t)ts.tv_sec, (uint32_t)(ts.tv_nsec / 1000)};
}

static uint64_t unix_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / 1000000u;
}

static uint64_t unix_us(void) {
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

/* ---- JSON output -------------------------------------------------------------------------------------- */

void out(const char *fmt, ...) {
    if (g_out_overflow) return;
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(g_out + g_out_len, sizeof g_out - g_out_len, fmt, ap);
    va_end(ap);
    if (n < 0 || (size_t)n >= sizeof g_out - g_out_len) {
        g_out_overflow = true;
        return;
    }
    g_out_len += (size_t)n;
}

/* Length of the well-formed UTF-8 sequence at s[0, n) (RFC 3629: shortest form, no surrogates, at most
 * U+10FFFF), or 0 when the bytes there are not one. */
static size_t utf8_sequence(const unsigned char *s, size_t n) {
    unsigned c = s[0];
    size_t len;
    uint32_t cp, min;
    if (c < 0x80) return 1;
    if ((c & 0xE0) == 0xC0) {
        len = 2, cp = c & 0x1F, min = 0x80;
    } else if ((c & 0xF0) == 0xE0) {
        len = 3, cp = c & 0x0F, min = 0x800;
    } else if ((c & 0xF8) == 0xF0) {
        len = 4, cp = c & 0x07, min = 0x10000;
    } else {
        return 0;
    }
    if (n < len) return 0;
    for (size_t i = 1; i < len; i++) {
        if ((s[i] & 0xC0) != 0x80) return 0;
        cp = cp << 6 | (s[i] & 0x3F);
    }
    return cp < min || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF) ? 0 : len;
}

/* A JSON string of s[0, max) (up to a NUL). Whatever the bytes (entity IDs and names arrive from the
 * network), the output is valid UTF-8 JSON: quotes, backslashes and control characters are escaped, and
 * every byte that is not part of a well-formed UTF-8 sequence becomes U+FFFD. */
void out_str(const char *s, size_t max) {
    const unsigned char *u = (const unsigned char *)s;
    size_t n = strnlen(s, max);
    out("\"");
    for (size_t i = 0; i < n;) {
        unsigned char c = u[i];
        size_t len = utf8_sequence(u + i, n - i);
        if (len == 0) {
            out("\\ufffd");
            i++;
        } else if (c == '"' || c == '\\') {
            out("\\%c", c);
            i++;
        } else if (c < 0x20) {
            out("\\u%04x", c);
            i++;
        } else {
            out("%.*s", (int)len, s + i);
            i += len;
        }
    }
    out("\"");
}

void out_entity(const uint8_t id[UB_ENTITY_ID_LEN]) { out_str((const char *)id, UB_ENTITY_ID_LEN); }

/* Writes the line and starts the next; an overlong line becomes an error event instead of a cut one. */
void out_flush(void) {
    if (g_out_overflow) {
        g_out_len = 0;
        g_out_overflow = false;
        out("{\"event\":\"error\",\"message\":\"uavbus_node: an event was longer than %zu bytes and was not printed\"}",
            sizeof g_out);
    }
    out("\n");
    fwrite(g_out, 1, g_out_len, stdout);
    fflush(stdout);
    g_out_len = 0;
}

void event_error(const char *msg) {
    out("{\"event\":\"error\",\"message\":");
    out_str(msg, SIZE_MAX);
    out("}");
    out_flush();
}

/* Something the operator should know once (e.g. a UDP port refusing datagrams from a stranger). */
static void event_warning(const char *msg) {
    out("{\"event\":\"warning\",\"message\":");
    out_str(msg, SIZE_MAX);
    out("}");
    out_flush();
    fprintf(stderr, "uavbus_node: %s\n", msg);
}

/* The log's rotation: every file deleted to keep --record-max-files is said, never silent. */
static void on_log_event(void *user, ub_log_event_t event, uint32_t index, const char *name) {
    (void)user;
    char msg[UB_LOG_PATH_MAX + 96];
    if (event == UB_LOG_EVENT_FILE_DELETED) {
        snprintf(msg, sizeof msg, "log: deleted %s (file %lu) to keep --record-max-files", name, (unsigned long)index);
        event_warning(msg);
    } else if (event == UB_LOG_EVENT_DELETE_FAILED) {
        snprintf(msg, sizeof msg, "log: could not delete %s (file %lu) to keep --record-max-files: %s", name,
                 (unsigned long)index, strerror(errno));
        event_warning(msg);
    }
}

/* ---- usage and start-up errors ------------------------------------------------------------------------ */

static void usage(FILE *f) {
    fprintf(f,
            "usage: uavbus_node --config FILE --node NAME [--port LINK=SPEC]... [--record FILE [--record-tx]\n"
            "                   [--record-max-bytes N] [--record-max-ms MS] [--record-max-files N]]\n"
            "                   [--impair loss=P,dup=P,reorder=P,delay=MS,jitter=MS,seed=N] [--stats-ms MS]\n"
            "                   [--duration-ms MS] [--subscribe ENTITY:CONTENT@SOURCE/PERIOD_MS]...\n"
            "                   [--publish ENTITY:CONTENT>DEST/PERIOD_MS]...\n"
            "SPEC: udp:bind=HOST:PORT[,peer=HOST:PORT][,accept=peer|learn|any] | tcp:listen=HOST:PORT |\n"
            "      tcp:connect=HOST:PORT |"
            "      serial:device=PATH[,baud=N]\n"
            "stdin commands: rebind LINK SPEC | impair SPEC | dump NAME | stats | quit |\n"
            "                key add FILE | key use ID | key remove ID\n"
            "%s",
            fleet_usage);
}

/* Start-up failure: the message on stderr (file:line: ... or argv[i]: ...) and as an error event; exit 2. */
void die(const char *fmt, ...) {
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    fprintf(stderr, "%s\n", msg);
    event_error(msg);
    exit(EXIT_USAGE);
}

static uint64_t parse_ms(const char *s, int argi) {
    char *end = NULL;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 10);
    if (s[0] == '\0' || s[0] == '-' || *end != '\0' || errno != 0) {
        die("uavbus_node:argv[%d]: '%s' is not a whole number of milliseconds", argi, s);
    }
    return (uint64_t)v;
}

static uint64_t parse_count(const char *s, int argi, const char *unit) {
    char *end = NULL;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 10);
    if (s[0] == '\0' || s[0] == '-' || *end != '\0' || errno != 0) {
        die("uavbus_node:argv[%d]: '%s' is not a whole number of %s", argi, s, unit);
    }
    return (uint64_t)v;
}

static void parse_args(int argc, char **argv, options_t *o) {
    memset(o, 0, sizeof *o);
    o->stats_ms = 1000;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            exit(0);
        }
        if (strcmp(a, "--record-tx") == 0) {
            o->record_tx = true;
            continue;
        }
        if (i + 1 >= argc) {
            usage(stderr);
            die("uavbus_node:argv[%d]: '%s' needs a value (or is unknown: see --help)", i, a);
        }
        const char *v = argv[++i];
        if (strcmp(a, "--config") == 0) o->config = v;
        else if (strcmp(a, "--node") == 0) o->node = v;
        else if (strcmp(a, "--record") == 0) o->record = v;
        else if (strcmp(a, "--record-max-bytes") == 0) o->rotation.max_bytes = parse_count(v, i, "bytes");
        else if (strcmp(a, "--record-max-ms") == 0) o->rotation.max_ms = parse_ms(v, i);
        else if (strcmp(a, "--record-max-files") == 0) {
            uint64_t n = parse_count(v, i, "files");
            if (n > UINT32_MAX) die("uavbus_node:argv[%d]: '%s' files is too many (at most %u)", i, v, UINT32_MAX);
            o->rotation.max_files = (uint32_t)n;
        }
        else if (strcmp(a, "--impair") == 0) o->impair = v;
        else if (fleet_option(a, v, i)) continue;
        else if (strcmp(a, "--stats-ms") == 0) o->stats_ms = parse_ms(v, i);
        else if (strcmp(a, "--duration-ms") == 0) {
            o->duration_ms = parse_ms(v, i);
            o->has_duration = true;
        } else if (strcmp(a, "--port") == 0) {
            if (o->n_ports == MAX_PORT_ARGS) die("uavbus_node:argv[%d]: more than %d --port options", i, MAX_PORT_ARGS);
            o->port_argi[o->n_ports] = i;
            o->ports[o->n_ports++] = v;
        } else if (strcmp(a, "--subscribe") == 0 || strcmp(a, "--publish") == 0) {
            if (o->n_ps == MAX_PS_ARGS) die("uavbus_node:argv[%d]: more than %d --subscribe/--publish", i, MAX_PS_ARGS);
            o->ps_argi[o->n_ps] = i;
            o->ps_is_pub[o->n_ps] = a[2] == 'p';
            o->ps[o->n_ps++] = v;
        } else {
            usage(stderr);
            die("uavbus_node:argv[%d]: unknown option '%s' (see --help)", i - 1, a);
        }
    }
    if (o->config == NULL) die("uavbus_node: --config FILE is required (e.g. --config examples/configs/table2.json)");
}

/* ---- set-up ------------------------------------------------------------------------------------------- */

static int local_entity(const char *name) {
    uint8_t id[UB_ENTITY_ID_LEN];
    if (ub_entity_id(name, id) != UB_OK) return UB_ERR_RANGE;
    int e = ub_node_find_entity(&g_node, id);
    if (e < 0) return e;
    for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++) {
        if (g_node.locals[s].in_use && g_node.locals[s].entity == e) return e;
    }
    return UB_ERR_INVAL;
}

static void bind_directories(void) {
    /* Every catalogued instance flightsw_data.c defines is hosted (generated bind table), so an
     * operator can subscribe to, read or write any of them; k_dirs only adds the motion models. */
    if (flightsw_bind_all(&g_node) < 0) die("uavbus_node: the flightsw bind table does not match the catalogue");
    for (size_t i = 0; i < N_DIRS; i++) {
        int inst = ub_catalogue_find_name(&flightsw_catalogue, k_dirs[i].name);
        if (inst < 0) die("uavbus_node: directory '%s' is not in the flightsw catalogue (rebuild)", k_dirs[i].name);
        if (ub_node_bind(&g_node, (uint32_t)inst, k_dirs[i].storage) != UB_OK) {
            die("uavbus_node: cannot bind '%s' (UB_MAX_BINDINGS too small?)", k_dirs[i].name);
        }
        g_dirs[i].instance = inst;
        g_dirs[i].produced = local_entity(fleet_producer(k_dirs[i].name, k_dirs[i].producer)) >= 0;
    }
}

/* "ENTITY:CONTENT@SOURCE/PERIOD" (subscribe) or "ENTITY:CONTENT>DEST/PERIOD" (publish). */
static void add_pubsub(const char *text, bool publish, int argi, uint64_t now_ms) {
    char buf[128], entity[32], content[96], peer[32];
    unsigned long period = 0;
    char sep = publish ? '>' : '@';
    if (strlen(text) >= sizeof buf) die("uavbus_node:argv[%d]: '%.40s...' is too long", argi, text);
    memcpy(buf, text, strlen(text) + 1);
    char *colon = strchr(buf, ':'), *mid = colon ? strchr(colon, sep) : NULL, *slash = mid ? strrchr(mid, '/') : NULL;
    char *end = NULL;
    if (slash != NULL) period = strtoul(slash + 1, &end, 10);
    if (colon == NULL || mid == NULL || slash == NULL || end == NULL || *end != '\0' || period == 0
        || period > UINT32_MAX || colon == buf || mid == colon + 1 || slash == mid + 1
        || (size_t)(colon - buf) >= sizeof entity || (size_t)(mid - colon - 1) >= sizeof content
        || (size_t)(slash - mid - 1) >= sizeof peer) {
        die("uavbus_node:argv[%d]: '%s': expected %s (period > 0 ms)", argi, text,
            publish ? "ENTITY:CONTENT>DEST/PERIOD_MS, e.g. rmax1ob1:gpsOut>gcs1/100"
                    : "ENTITY:CONTENT@SOURCE/PERIOD_MS, e.g. gcs1:imuOut@fcs20/20");
    }
    *colon = *mid = *slash = '\0';
    snprintf(entity, sizeof entity, "%s", buf);
    snprintf(content, sizeof content, "%s", colon + 1);
    snprintf(peer, sizeof peer, "%s", mid + 1);
    int e = local_entity(entity);
    if (e < 0) die("uavbus_node:argv[%d]: '%s' is not an entity hosted by this node", argi, entity);
    int inst = ub_catalogue_find_name(&flightsw_catalogue, content);
    if (inst < 0) die("uavbus_node:argv[%d]: no directory '%s' in the flightsw catalogue", argi, content);
    if (ub_node_binding(&g_node, (uint32_t)inst) == NULL) {
        die("uavbus_node:argv[%d]: no storage for '%s' (flightsw_data.c does not define it)", argi, content);
    }
    uint8_t pid[UB_ENTITY_ID_LEN];
    if (ub_entity_id(peer, pid) != UB_OK || ub_node_find_entity(&g_node, pid) < 0) {
        die("uavbus_node:argv[%d]: '%s' is not an entity of the config", argi, peer);
    }
    int rc = publish ? ub_pubsub_publish(&g_node, e, (uint32_t)inst, pid, (uint32_t)period, now_ms)
                     : ub_pubsub_subscribe(&g_node, e, (uint32_t)inst, pid, (uint32_t)period, now_ms);
    if (rc < 0) die("uavbus_node:argv[%d]: '%s' refused: %s", argi, text, ub_strerror(rc));
}

/* Config ports, except links a --port names (those override), then the --port ones. */
static void open_ports(const options_t *o, uint64_t now_ms) {
    char err[UB_PORTS_ERR_LEN];
    char names[MAX_PORT_ARGS][UB_NODECFG_PORT_KEY_MAX + 1];
    ub_port_spec_t specs[MAX_PORT_ARGS];
    int ids[MAX_PORT_ARGS];
    for (int i = 0; i < o->n_ports; i++) {
        if (ub_port_arg_parse(o->ports[i], names[i], sizeof names[i], &specs[i], err, sizeof err) != UB_OK) {
            die("uavbus_node:argv[%d]: %s", o->port_argi[i], err);
        }
        const char *link = strchr(names[i], ':') != NULL ? strchr(names[i], ':') + 1 : names[i];
        ids[i] = ub_node_find_link(&g_node, link);
        if (ids[i] < 0) {
            die("uavbus_node:argv[%d]: port '%s': node '%s' has no such link (its links are in the config's "
                "'links' of its entities)",
                o->port_argi[i], names[i], o->node);
        }
    }
    for (unsigned c = 0; c < g_cfg.port_count; c++) {
        const ub_nodecfg_port_t *e = &g_cfg.ports[c];
        ub_port_spec_t spec;
        if (ub_port_spec_from_config(e, g_cfg.source, &spec, err, sizeof err) != UB_OK) die("%s", err);
        if (spec.kind == UB_PORT_MEM) continue;
        const char *link = strchr(e->name, ':') != NULL ? strchr(e->name, ':') + 1 : e->name;
        int id = ub_node_find_link(&g_node, link);
        if (id < 0) continue; /* a link of an entity hosted by another node */
        bool overridden = false;
        for (int i = 0; i < o->n_ports; i++) overridden = overridden || ids[i] == id;
        if (overridden) continue;
        int rc = ub_ports_open(&g_ports, e->name, &spec, now_ms, err, sizeof err);
        if (rc == UB_ERR_NOTFOUND) continue; /* "entity:link" of an entity hosted elsewhere */
        if (rc != UB_OK) die("%s:%u: %s", g_cfg.source, (unsigned)e->line, err);
    }
    for (int i = 0; i < o->n_ports; i++) {
        if (ub_ports_open(&g_ports, names[i], &specs[i], now_ms, err, sizeof err) != UB_OK) {
            die("uavbus_node:argv[%d]: %s", o->port_argi[i], err);
        }
    }
}

/* ---- events ------------------------------------------------------------------------------------------- */

static void out_port(const ub_port_t *p, const char *name) {
    char spec[128];
    uint16_t lp = 0;
    ub_port_spec_format(&p->spec, spec, sizeof spec);
    out("\"transport\":\"%s\",\"spec\":", ub_port_kind_transport(p->spec.kind));
    out_str(spec, SIZE_MAX);
    if (ub_ports_local_port(&g_ports, name, &lp) == UB_OK) out(",\"local_port\":%u", (unsigned)lp);
    else if (p->spec.kind == UB_PORT_TCP_CONNECT) out(",\"local_port\":null,\"connect_port\":%u", (unsigned)p->spec.port);
    else out(",\"local_port\":null");
}

static void event_ready(const char *node_name) {
    out("{\"event\":\"ready\",\"node\":");
    out_str(node_name, SIZE_MAX);
    out(",\"pid\":%ld,\"t_ms\":%" PRIu64 ",\"entities\":[", (long)getpid(), mono_ms());
    bool first = true;
    for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++) {
        if (!g_node.locals[s].in_use) continue;
        out(first ? "" : ",");
        out_entity(ub_node_entity_id(&g_node, g_node.locals[s].entity));
        first = false;
    }
    out("],\"ports\":{");
    first = true;
    for (int id = 0; id < UB_MAX_NODE_LINKS; id++) {
        const ub_link_t *l = ub_node_link(&g_node, id);
        const ub_port_t *p = l != NULL ? ub_ports_find(&g_ports, l->name) : NULL;
        if (p == NULL) continue;
        out("%s", first ? "" : ",");
        out_str(l->name, SIZE_MAX);
        out(":{");
        out_port(p, l->name);
        out("}");
        first = false;
    }
    out("},\"produces\":[");
    first = true;
    for (size_t i = 0; i < N_DIRS; i++) {
        if (!g_dirs[i].produced) continue;
        out("%s\"%s\"", first ? "" : ",", k_dirs[i].name);
        first = false;
    }
    out("]}");
    out_flush();
}

static void out_drops(const uint64_t drops[UB_DROP_REASON_COUNT]) {
    out("\"drops\":{");
    for (int r = 0; r < UB_DROP_REASON_COUNT; r++) {
        out("%s\"%s\":%" PRIu64, r ? "," : "", ub_drop_reason_name((ub_drop_reason_t)r), drops[r]);
    }
    out("}");
}

static void out_impair(const ub_port_t *p) {
    const ub_impair_stats_t *s = ub_impair_stats(&p->impair);
    out(",\"impair\":{\"offered\":%" PRIu64 ",\"lost\":%" PRIu64 ",\"duplicated\":%" PRIu64 ",\"reordered\":%" PRIu64
        ",\"delayed\":%" PRIu64 ",\"queue_full\":%" PRIu64 ",\"passed\":%" PRIu64 ",\"inner_again\":%" PRIu64
        ",\"inner_errors\":%" PRIu64 ",\"pending\":%zu}",
        s->offered, s->lost, s->duplicated, s->reordered, s->delayed, s->queue_full, s->passed, s->inner_again,
        s->inner_errors, ub_impair_pending(&p->impair));
}

static void out_driver(const ub_port_t *p) {
    const ub_port_driver_t *d = &p->drv[p->active];
    switch (d->kind) {
    case UB_PORT_UDP: {
        const ub_udp_stats_t *s = &d->u.udp.stats;
        out(",\"udp\":{\"datagrams_in\":%" PRIu64 ",\"rejected\":%" PRIu64 ",\"foreign\":%" PRIu64
            ",\"datagrams_out\":%" PRIu64 ",\"again\":%" PRIu64 ",\"send_errors\":%" PRIu64
            ",\"no_peer\":%" PRIu64 ",\"peers_learned\":%" PRIu64 ",\"peers\":[",
            s->datagrams_in, s->rejected, s->foreign, s->datagrams_out, s->again, s->send_errors, s->no_peer,
            s->peers_learned);
        char host[16];
        uint16_t port;
        for (int i = 0; ub_udp_peer_at(&d->u.udp, i, host, &port) == UB_OK; i++) out("%s\"%s:%u\"", i ? "," : "", host, port);
        out("]}");
        break;
    }
    case UB_PORT_TCP_LISTEN:
    case UB_PORT_TCP_CONNECT: {
        const ub_tcp_stats_t *s = ub_tcp_stats(&d->u.tcp);
        static const char *const states[] = {"down", "connecting", "up"};
        out(",\"tcp\":{\"state\":\"%s\",\"connects\":%" PRIu64 ",\"reconnects\":%" PRIu64 ",\"disconnects\":%" PRIu64
            ",\"failed_attempts\":%" PRIu64 ",\"backpressure\":%" PRIu64 ",\"send_closed\":%" PRIu64
            ",\"tx_discarded\":%" PRIu64 ",\"candidates\":%" PRIu64 ",\"adopted\":%" PRIu64 ",\"replaced\":%" PRIu64
            ",\"candidates_refused\":%" PRIu64 ",\"candidates_expired\":%" PRIu64 ",\"candidates_lost\":%" PRIu64
            ",\"candidate_rejected\":%" PRIu64 ",\"candidates_open\":%d}",
            states[ub_tcp_state(&d->u.tcp) % 3], s->connects, s->reconnects, s->disconnects, s->failed_attempts,
            s->backpressure, s->send_closed, s->tx_discarded, s->candidates, s->adopted, s->replaced,
            s->candidates_refused, s->candidates_expired, s->candidates_lost, s->candidate_rejected,
            ub_tcp_candidates(&d->u.tcp));
        break;
    }
    case UB_PORT_SERIAL: {
        const ub_serial_stats_t *s = ub_serial_stats(&d->u.serial);
        out(",\"serial\":{\"state\":\"%s\",\"bytes_in\":%" PRIu64 ",\"bytes_out\":%" PRIu64 ",\"backpressure\":%" PRIu64
            ",\"io_errors\":%" PRIu64 ",\"hangups\":%" PRIu64 ",\"reopens\":%" PRIu64 ",\"reopen_failures\":%" PRIu64
            ",\"send_closed\":%" PRIu64 ",\"tx_discarded\":%" PRIu64 "}",
            ub_serial_state(&d->u.serial) == UB_SERIAL_UP ? "up" : "down", s->bytes_in, s->bytes_out,
            s->backpressure, s->io_errors, s->hangups, s->reopens, s->reopen_failures, s->send_closed,
            s->tx_discarded);
        break;
    }
    default: break;
    }
}

static void out_keys(void) {
    uint8_t ids[UB_MAX_KEYS];
    size_t n = ub_sec_key_ids(&g_sec, ids, UB_MAX_KEYS);
    out("\"tx_key\":%u,\"keys\":[", (unsigned)ub_sec_tx_key(&g_sec));
    for (size_t i = 0; i < n && i < UB_MAX_KEYS; i++) out("%s%u", i ? "," : "", (unsigned)ids[i]);
    out("]");
}

/* The security context's counters ("security":null without a "security" section). */
static void out_security(void) {
    if (ub_node_security(&g_node) == NULL) {
        out(",\"security\":null");
        return;
    }
    const ub_sec_stats_t *s = ub_sec_stats(&g_sec);
    out(",\"security\":{");
    out_keys();
    out(",\"signed_out\":%" PRIu64 ",\"encrypted_out\":%" PRIu64 ",\"verified_in\":%" PRIu64 ",\"decrypted_in\":%" PRIu64
        ",\"auth_failures\":%" PRIu64 ",\"unknown_keys\":%" PRIu64 ",\"challenges_sent\":%" PRIu64
        ",\"challenges_completed\":%" PRIu64 ",\"replies_sent\":%" PRIu64 ",\"replies_suppressed\":%" PRIu64
        ",\"reservations\":%" PRIu64 ",\"reserve_failures\":%" PRIu64 ",\"tx_refused\":%" PRIu64
        ",\"counter_mark\":%" PRIu64 "}",
        s->signed_out, s->encrypted_out, s->verified_in, s->decrypted_in, s->auth_failures, s->unknown_keys,
        s->challenges_sent, s->challenges_completed, s->replies_sent, s->replies_suppressed, s->reservations,
        s->reserve_failures, s->tx_refused, g_counter.mark);
}

static const char *k_sub_states[] = {"requesting", "receiving", "stopping"};

static void event_stats(uint64_t now_ms, bool final) {
    const ub_node_counters_t *n = ub_node_counters(&g_node);
    out("{\"event\":\"stats\",\"t_ms\":%" PRIu64 ",\"uptime_ms\":%" PRIu64 "%s,\"node\":{\"originated\":%" PRIu64
        ",\"forwarded\":%" PRIu64 ",\"delivered\":%" PRIu64 ",\"admin_handled\":%" PRIu64 ",\"local_direct\":%" PRIu64
        ",\"dedup_resets\":%" PRIu64 ",\"dedup_evictions\":%" PRIu64 ",\"leases_expired\":%" PRIu64
        ",\"replies_unmatched\":%" PRIu64 ",\"requests_limited\":%" PRIu64 ",\"leases_clamped\":%" PRIu64
        ",\"rows_evicted\":%" PRIu64 ",\"random_failures\":%" PRIu64 ",\"handovers\":%" PRIu64
        ",\"nacks_relayed\":%" PRIu64 ",\"other_admin\":%" PRIu64 ",",
        now_ms, now_ms - g_start_ms, final ? ",\"final\":true" : "", n->originated, n->forwarded, n->delivered,
        n->admin_handled, n->local_direct, n->dedup_resets, n->dedup_evictions, n->leases_expired,
        n->replies_unmatched, n->requests_limited, n->leases_clamped, n->rows_evicted, n->random_failures,
        n->handovers, n->nacks_relayed, n->other_admin);
    out_drops(n->drops);
    out("},\"links\":{");
    bool first = true;
    for (int id = 0; id < UB_MAX_NODE_LINKS; id++) {
        const ub_link_t *l = ub_node_link(&g_node, id);
        if (l == NULL) continue;
        const ub_link_counters_t *c = &l->counters;
        out("%s", first ? "" : ",");
        first = false;
        out_str(l->name, SIZE_MAX);
        out(":{\"id\":%d,\"frames_in\":%" PRIu64 ",\"bytes_in\":%" PRIu64 ",\"frames_out\":%" PRIu64
            ",\"bytes_out\":%" PRIu64 ",\"frames_accepted\":%" PRIu64 ",\"require_signed\":%s,\"encrypt\":%s,",
            id, c->frames_in, c->bytes_in, c->frames_out, c->bytes_out, c->frames_accepted,
            ub_node_link_requires_signed(&g_node, id) ? "true" : "false", l->encrypt ? "true" : "false");
        out_drops(c->drops);
        out(",\"bad\":{");
        for (int r = 0; r < UB_RX_REASON_COUNT; r++) {
            out("%s\"%s\":%" PRIu64, r ? "," : "", ub_rx_reason_name((ub_rx_reason_t)r),
                ub_node_link_bad_frames(&g_node, id, (ub_rx_reason_t)r));
        }
        out("}");
        const ub_port_t *p = ub_ports_find(&g_ports, l->name);
        if (p != NULL) {
            out(",\"port\":{");
            out_port(p, l->name);
            out(",\"rebinds\":%" PRIu32 ",\"service_errors\":%" PRIu64 "}", p->rebinds, p->service_errors);
            out_driver(p);
            if (p->impaired) out_impair(p);
        } else {
            out(",\"port\":null");
        }
        out("}");
    }
    out("},\"pubsub\":{");
    first = true;
    for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++) {
        const ub_local_entity_t *le = &g_node.locals[s];
        if (!le->in_use) continue;
        out("%s", first ? "" : ",");
        first = false;
        out_entity(ub_node_entity_id(&g_node, le->entity));
        out(":[");
        bool rfirst = true;
        for (int r = 0; r < UB_MAX_PUBSUB_ROWS; r++) {
            const ub_ps_row_t *row = ub_pubsub_row(&g_node, le->entity, r);
            if (row == NULL || row->kind == UB_PS_FREE) continue;
            bool pub = row->kind == UB_PS_PUBLICATION;
            out("%s{\"row\":%d,\"kind\":\"%s\",\"content\":", rfirst ? "" : ",", r, pub ? "publication" : "subscription");
            rfirst = false;
            out_str(flightsw_catalogue.instances[row->instance].name, SIZE_MAX);
            out(",\"%s\":", pub ? "destination" : "source");
            out_entity(row->peer);
            out(",\"period_ms\":%" PRIu32 ",\"frames\":%" PRIu64 ",\"lease_until_ms\":%" PRIu64, row->period_ms,
                row->frames, row->lease_until_ms);
            if (!pub) out(",\"state\":\"%s\",\"acked\":%s", k_sub_states[row->state % 3], row->acked ? "true" : "false");
            bool remote = false;
            for (int k = 0; k < UB_ENTITY_ID_LEN; k++) remote = remote || row->owner[k] != 0;
            if (remote) {
                out(",\"owner\":");
                out_entity(row->owner);
            }
            out("}");
        }
        out("]");
    }
    out("},\"received\":{");
    first = true;
    for (size_t i = 0; i < N_DIRS; i++) {
        const dir_state_t *d = &g_dirs[i];
        if (d->rx_count == 0) continue;
        out("%s\"%s\":{\"count\":%" PRIu64 ",\"latency_ms\":{\"last\":%.3f,\"max\":%.3f,\"mean\":%.3f}}", first ? "" : ",",
            k_dirs[i].name, d->rx_count, d->lat_last_ms, d->lat_max_ms, d->lat_sum_ms / (double)d->rx_count);
        first = false;
    }
    out("}");
    if (g_logging) {
        const ub_log_stats_t *s = ub_log_stats(&g_log);
        out(",\"log\":{\"records\":%" PRIu64 ",\"bytes\":%" PRIu64 ",\"write_errors\":%" PRIu64 ",\"skipped_tx\":%" PRIu64
            ",\"torn_writes\":%" PRIu64 ",\"recoveries\":%" PRIu64 ",\"file_index\":%" PRIu32 ",\"files\":%" PRIu64
            ",\"files_deleted\":%" PRIu64 ",\"open_errors\":%" PRIu64 ",\"limit_rotations\":%" PRIu64
            ",\"failing\":%s,\"last_error\":",
            s->records, s->bytes, s->write_errors, s->skipped_tx, s->torn_writes, s->recoveries,
            ub_log_file_index(&g_log), s->files, s->files_deleted, s->open_errors, s->limit_rotations,
            g_log.failing ? "true" : "false");
        if (s->last_errno != 0) out_str(strerror(s->last_errno), SIZE_MAX);
        else out("null");
        out("}");
    }
    out_security();
    out(",\"stdin_dropped\":%" PRIu64 "}", g_stdin_dropped);
    out_flush();
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

static void update_motion(uint64_t now_ms) {
    uint64_t epoch = fleet_epoch_ms(g_start_ms);
    double t_s = now_ms > epoch ? (double)(now_ms - epoch) / 1000.0 : 0.0;
    for (size_t i = 0; i < N_DIRS; i++) {
        dir_state_t *d = &g_dirs[i];
        const directory_t *k = &k_dirs[i];
        if (!d->produced || k->motion == MOTION_NONE || now_ms < d->next_ms) continue;
        /* One update per call even after a stall: the model is a function of time, nothing to catch up. */
        d->next_ms += k->period_ms;
        if (d->next_ms <= now_ms) d->next_ms = now_ms + k->period_ms;
        timeTag_t stamp = mono_stamp();
        switch (k->motion) {
        case MOTION_GPS: node_motion_gps(&g_motion, t_s, stamp, k->storage); break;
        case MOTION_IMU: node_motion_imu(&g_motion, t_s, k->period_ms / 1000.0, stamp, k->storage); break;
        case MOTION_NAV: node_motion_nav(&g_motion, t_s, stamp, k->storage); break;
        default: break;
        }
    }
}

static void apply_impair(const char *text, bool at_start) {
    ub_impair_params_t params;
    uint64_t seed = 1;
    char err[160], msg[256];
    if (ub_impair_parse(text, &params, &seed, err, sizeof err) != UB_OK) {
        if (at_start) die("uavbus_node: --impair: %s", err);
        snprintf(msg, sizeof msg, "impair: %s", err);
        event_error(msg);
        return;
    }
    if (ub_ports_set_impairment(&g_ports, &params, seed) != UB_OK) event_error("impair: refused");
}

/* Key rotation (docs/security.md): `key add FILE` (accept a key), `key use ID` (sign with it),
 * `key remove ID` (retire one; never the signing key). Answers with a "key" event or an error. */
static void key_command(char *save) {
    char msg[UB_SECFILE_ERR_LEN + 64];
    char *action = strtok_r(NULL, " \t\r", &save);
    char *arg = strtok_r(NULL, " \t\r", &save);
    if (action == NULL || arg == NULL) {
        event_error("key: expected 'key add FILE', 'key use ID' or 'key remove ID'");
        return;
    }
    if (ub_node_security(&g_node) == NULL) {
        event_error("key: this node runs without security (the config has no \"security\" section)");
        return;
    }
    int rc;
    unsigned id = 0;
    if (strcmp(action, "add") == 0) {
        uint8_t kid = 0, key[UB_SEC_KEY_LEN];
        char err[UB_SECFILE_ERR_LEN];
        if (ub_keyfile_load(arg, &kid, key, err, sizeof err) != UB_OK) {
            snprintf(msg, sizeof msg, "key add: %s", err);
            event_error(msg);
            return;
        }
        rc = ub_sec_add_key(&g_sec, kid, key);
        memset(key, 0, sizeof key);
        id = kid;
    } else if (strcmp(action, "use") == 0 || strcmp(action, "remove") == 0) {
        char *end = NULL;
        unsigned long v = strtoul(arg, &end, 10);
        if (end == arg || *end != '\0' || v < 1 || v > 255) {
            snprintf(msg, sizeof msg, "key %s: '%.16s' is not a key id 1..255", action, arg);
            event_error(msg);
            return;
        }
        id = (unsigned)v;
        rc = action[0] == 'u' ? ub_sec_set_tx_key(&g_sec, (uint8_t)id) : ub_sec_remove_key(&g_sec, (uint8_t)id);
    } else {
        snprintf(msg, sizeof msg, "key: unknown action '%.16s' (expected add, use or remove)", action);
        event_error(msg);
        return;
    }
    if (rc != UB_OK) {
        const char *why = rc == UB_ERR_EXISTS ? "a key with this id is already loaded"
                        : rc == UB_ERR_FULL ? "the keyring is full (remove a retired key first)"
                        : rc == UB_ERR_NOTFOUND ? "no key with this id is loaded"
                        : action[0] == 'r' ? "it signs what this node sends: 'key use' another key first"
                                           : ub_strerror(rc);
        snprintf(msg, sizeof msg, "key %s %u: %s", action, id, why);
        event_error(msg);
        return;
    }
    out("{\"event\":\"key\",\"action\":\"%s\",\"id\":%u,", action, id);
    out_keys();
    out("}");
    out_flush();
}

static void command(char *line, uint64_t now_ms) {
    char *save = NULL;
    char *verb = strtok_r(line, " \t\r", &save);
    if (verb == NULL) return;
    char msg[UB_PORTS_ERR_LEN + 64];
    if (strcmp(verb, "quit") == 0) {
        g_stop = 1;
    } else if (strcmp(verb, "stats") == 0) {
        event_stats(now_ms, false);
    } else if (strcmp(verb, "dump") == 0) {
        /* The bound C struct packed again with the generated codec: a sender can check that this
         * process unpacked what it sent into identical bytes (tests/system, mixed languages). */
        char *name = strtok_r(NULL, " \t\r", &save);
        int inst = name != NULL ? ub_catalogue_find_name(&flightsw_catalogue, name) : UB_ERR_NOTFOUND;
        void *storage = inst >= 0 ? ub_node_binding(&g_node, (uint32_t)inst) : NULL;
        if (storage == NULL) {
            snprintf(msg, sizeof msg, "dump: '%.40s' is not a directory this node binds", name != NULL ? name : "");
            event_error(msg);
            return;
        }
        const ub_type_desc_t *type = flightsw_catalogue.instances[inst].type;
        uint8_t packed[UB_MAX_PAYLOAD];
        int n = type->pack(storage, packed, sizeof packed);
        out("{\"event\":\"dump\",\"name\":");
        out_str(name, SIZE_MAX);
        out(",\"packed\":\"");
        for (int i = 0; i < n; i++) out("%02x", packed[i]);
        out("\"}");
        out_flush();
    } else if (strcmp(verb, "impair") == 0) {
        char *spec = strtok_r(NULL, " \t\r", &save);
        apply_impair(spec != NULL ? spec : "", false);
    } else if (strcmp(verb, "rebind") == 0) {
        char *name = strtok_r(NULL, " \t\r", &save);
        char *spec = strtok_r(NULL, " \t\r", &save);
        char err[UB_PORTS_ERR_LEN];
        if (name == NULL || spec == NULL) {
            event_error("rebind: expected 'rebind LINK SPEC', e.g. rebind onboardPortIPC udp:bind=127.0.0.1:0,peer=127.0.0.1:5001");
            return;
        }
        if (ub_ports_open_text(&g_ports, name, spec, now_ms, err, sizeof err) != UB_OK) {
            snprintf(msg, sizeof msg, "rebind: %s", err);
            event_error(msg);
            return;
        }
        const ub_port_t *p = ub_ports_find(&g_ports, name);
        out("{\"event\":\"rebound\",\"port\":");
        out_str(name, SIZE_MAX);
        out(",");
        out_port(p, name);
        out(",\"rebinds\":%" PRIu32 "}", p->rebinds);
        out_flush();
    } else if (strcmp(verb, "key") == 0) {
        key_command(save);
    } else if (fleet_command(verb, &save, now_ms)) {
        /* answered by node_fleet.c */
    } else {
        snprintf(msg, sizeof msg, "unknown command '%.40s' (expected: rebind LINK SPEC, impair SPEC, dump NAME, stats, quit, "
                 "key ..., or a fleet command: see --help)", verb);
        event_error(msg);
    }
}

/* Reads what stdin has and runs each whole line. Returns false at EOF (stop polling it). */
static bool read_stdin(uint64_t now_ms) {
    static char buf[1024];
    static size_t len;
    static bool discarding;
    ssize_t n = read(STDIN_FILENO, buf + len, sizeof buf - 1 - len);
    if (n == 0) return false;
    if (n < 0) return errno == EINTR || errno == EAGAIN;
    len += (size_t)n;
    for (;;) {
        char *nl = memchr(buf, '\n', len);
        if (nl == NULL) break;
        *nl = '\0';
        if (!discarding) command(buf, now_ms);
        discarding = false;
        size_t used = (size_t)(nl - buf) + 1;
        memmove(buf, buf + used, len - used);
        len -= used;
    }
    if (len == sizeof buf - 1) {
        /* A line longer than any command: drop it (counted) up to its newline. */
        g_stdin_dropped += len;
        len = 0;
        if (!discarding) event_error("stdin: a command line longer than 1023 bytes was ignored");
        discarding = true;
    }
    return true;
}

int main(int argc, char **argv) {
    options_t o;
    parse_args(argc, argv, &o);
    setvbuf(stdout, NULL, _IOFBF, 1 << 16);

    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    signal(SIGPIPE, SIG_IGN); /* a closed stdout reader must not kill the node; writes just fail */
    signal(SIGXFSZ, SIG_IGN); /* a file-size limit must not kill it either: the log sees EFBIG and rotates */

    char err[UB_NODECFG_ERR_LEN];
    int rc = ub_nodecfg_load_file(&g_cfg, o.config, g_cfg_text, sizeof g_cfg_text, err, sizeof err);
    if (rc == UB_ERR_NOSPACE) die("%s: larger than %zu bytes", o.config, sizeof g_cfg_text);
    if (rc != UB_OK) die("%s", err);
    if (o.node != NULL) {
        if (ub_nodecfg_select_node(&g_cfg, o.node, err, sizeof err) != UB_OK) die("%s: %s", o.config, err);
    } else if (g_cfg.host_count == 0) {
        die("%s: no --node given and the file has no \"hosts\": say which node to run (--node NAME)", o.config);
    }
    const char *node_name = o.node != NULL ? o.node : g_cfg.entities[g_cfg.hosts[0]].name;
    /* Start the sequence numbers from the wall clock, not from 1: receivers keep a 64-frame duplicate
     * window per source, and a restarted process whose new numbers land inside the old window would
     * have its first frames dropped as duplicates (ub_node.h, "Duplicate window"). */
    struct timespec boot;
    clock_gettime(CLOCK_REALTIME, &boot);
    ub_node_options_t node_opt = {0};
    node_opt.first_seq = (uint32_t)(((uint64_t)boot.tv_sec * 1000u + (uint64_t)boot.tv_nsec / 1000000u) & 0x7FFFFFFFu);
    if (node_opt.first_seq == 0) node_opt.first_seq = 1;
    node_opt.random = ub_random_os; /* unguessable request ids (docs/pubsub.md, "Replies bound to their row") */
    if (ub_node_init(&g_node, &flightsw_catalogue, &node_opt) != UB_OK) die("uavbus_node: catalogue refused by the runtime");
    ub_frag_init(&g_frag, NULL, (uint16_t)node_opt.first_seq);
    if (ub_node_set_frag(&g_node, &g_frag) != UB_OK) die("uavbus_node: fragment state refused");
    if (ub_nodecfg_apply(&g_cfg, &g_node, err, sizeof err) != UB_OK) die("%s", err);
    /* Keys, counter file and policy of the "security" section (none: the node stays unsigned). */
    char sec_err[UB_NODECFG_ERR_LEN + UB_SECFILE_ERR_LEN];
    if (ub_nodecfg_apply_security(&g_cfg, &g_node, &g_sec, &g_counter, NULL, unix_us(), sec_err, sizeof sec_err) != UB_OK)
        die("%s", sec_err);
    if (ub_ports_init(&g_ports, &g_node) != UB_OK) die("uavbus_node: ub_ports_init failed");
    node_motion_init(&g_motion);
    bind_directories();
    fleet_setup(&g_node, &g_ports, &g_motion, mono_ms());

    g_start_ms = mono_ms();
    for (size_t i = 0; i < N_DIRS; i++) g_dirs[i].next_ms = g_start_ms;
    update_motion(g_start_ms); /* storage holds a valid sample before anything can be sent */
    ub_node_set_deliver_hook(&g_node, on_deliver, NULL);
    if (o.impair != NULL) apply_impair(o.impair, true);
    open_ports(&o, g_start_ms);
    for (int i = 0; i < o.n_ps; i++) add_pubsub(o.ps[i], o.ps_is_pub[i], o.ps_argi[i], g_start_ms);
    if (o.record != NULL) {
        /* ub_log_open_path() opens (and rotates) the files itself; a file-size limit comes back as EFBIG
         * since SIGXFSZ is ignored, and the log moves on to its next file. */
        rc = ub_log_open_path(&g_log, o.record, &o.rotation, &g_node, node_name, o.record_tx, unix_ms(), g_start_ms);
        uint64_t min_bytes = 0;
        if (rc == UB_ERR_RANGE && ub_log_rotation_floor(&g_node, node_name, &min_bytes) == UB_OK)
            die("%s: --record-max-bytes %" PRIu64 " is below %" PRIu64 ", the smallest file that holds the log header "
                "(meta and catalogue, twice) and one largest record: raise it",
                o.record, o.rotation.max_bytes, min_bytes);
        if (rc != UB_OK) die("%s: cannot start the log: %s (%s)", o.record, ub_strerror(rc), strerror(errno));
        ub_log_set_event_fn(&g_log, on_log_event, NULL);
        ub_node_set_tap(&g_node, ub_log_tap, &g_log);
        g_logging = true;
    }
    event_ready(node_name);

    bool stdin_open = true;
    uint64_t now = mono_ms();
    uint64_t next_stats = o.stats_ms > 0 ? now + o.stats_ms : UINT64_MAX;
    uint64_t end = o.has_duration ? g_start_ms + o.duration_ms : UINT64_MAX;
    struct pollfd fds[2 * UB_PORTS_MAX + 1];
    while (!g_stop && now < end) {
        int n = ub_ports_pollfds(&g_ports, fds, 2 * UB_PORTS_MAX);
        if (n < 0) n = 0; /* cannot happen: 2 * UB_PORTS_MAX always suffices */
        int stdin_slot = -1;
        if (stdin_open) {
            stdin_slot = n;
            fds[n++] = (struct pollfd){.fd = STDIN_FILENO, .events = POLLIN};
        }
        int wait = ub_ports_poll_timeout(&g_ports, now, LOOP_MAX_WAIT_MS);
        if (poll(fds, (nfds_t)n, wait) < 0 && errno != EINTR) {
            char msg[128];
            snprintf(msg, sizeof msg, "poll: %s", strerror(errno));
            event_error(msg);
        }
        now = mono_ms();
        if (stdin_slot >= 0 && (fds[stdin_slot].revents & (POLLIN | POLLHUP | POLLERR)) != 0) {
            stdin_open = read_stdin(now);
        }
        (void)ub_ports_service(&g_ports, now);
        char notice[512];
        while (ub_ports_notice(&g_ports, notice, sizeof notice) > 0) event_warning(notice);
        update_motion(now);
        ub_node_tick(&g_node, now);
        fleet_poll(now);
        if (now >= next_stats) {
            event_stats(now, false);
            next_stats += o.stats_ms;
            if (next_stats <= now) next_stats = now + o.stats_ms;
        }
    }
    now = mono_ms();
    event_stats(now, true);
    if (g_logging) {
        ub_node_set_tap(&g_node, NULL, NULL);
        ub_log_close(&g_log);
    }
    ub_ports_close_all(&g_ports);
    return 0;
}
