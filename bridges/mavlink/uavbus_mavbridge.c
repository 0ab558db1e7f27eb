/*
 * uavbus_mavbridge: a uavbus entity that talks MAVLink 2 to an autopilot (docs/bridges.md).
 *
 *   uavbus_mavbridge --config FILE [--node NAME] [--entity NAME] --mavlink SPEC
 *                    [--sysid N] [--compid N] [--target SYSID/COMPID] [--mavlink-key FILE [--link-id N]]
 *                    [--commands-without-policy] [--port LINK=SPEC]... [--stats-ms MS] [--duration-ms MS]
 *
 * The uavbus side is a node of a configuration file, as uavbus_node's: entity table, ports, and
 * the "security" section (whose write policy says who may command the autopilot). The bridge
 * entity is --entity, or the node's first hosted entity. The MAVLink side is one UDP or serial
 * link (--mavlink udp:bind=HOST:PORT,peer=HOST:PORT | serial:device=PATH[,baud=N]).
 *
 * Output on stdout, one JSON object per line: "ready", "autopilot" (connected / lost), "stats",
 * "error". stdin: `stats`, `quit`. One poll() loop, CLOCK_MONOTONIC ms, no allocation: the node,
 * the ports and the bridge are static.
 */
#include <errno.h>
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

#include "mavcat.h"
#include "ub/ub_node.h"
#include "ub/ub_nodecfg.h"
#include "ub/ub_ports.h"
#include "ub/ub_random.h"
#include "ub/ub_sec.h"
#include "ub/ub_secfile.h"
#include "ub_mavbridge.h"
#include "ub_mavio.h"

#define EXIT_USAGE 2
#define MAX_PORT_ARGS 16
#define LOOP_MAX_WAIT_MS 1 /* on-update rows and heartbeats are due on whole ms */

typedef struct options {
    const char *config, *node, *entity, *mavlink, *key;
    unsigned sysid, compid, target_sysid, target_compid, link_id;
    bool commands_without_policy;
    uint64_t stats_ms, duration_ms;
    bool has_duration;
    int n_ports;
    const char *ports[MAX_PORT_ARGS];
} options_t;

static volatile sig_atomic_t g_stop;
static ub_nodecfg_t g_cfg;
static char g_cfg_text[1 << 16];
static ub_node_t g_node;
static ub_sec_t g_sec;                /* used when the config has a "security" section with keys */
static ub_counter_file_t g_counter;
static ub_ports_t g_ports;
static ub_mavio_t g_io;
static ub_mavbridge_t g_br;
static char g_out[1 << 16];
static size_t g_out_len;
static bool g_out_overflow;

static void on_signal(int sig) {
    (void)sig;
    g_stop = 1;
}

static uint64_t clock_ms(clockid_t id) {
    struct timespec ts;
    clock_gettime(id, &ts);
    return (uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / 1000000u;
}

/* ---- JSON lines ---------------------------------------------------------------------------------- */

#if defined(__GNUC__)
__attribute__((format(printf, 1, 2)))
#endif
static void out(const char *fmt, ...) {
    if (g_out_overflow) return;
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(g_out + g_out_len, sizeof g_out - g_out_len, fmt, ap);
    va_end(ap);
    if (n < 0 || (size_t)n >= sizeof g_out - g_out_len) g_out_overflow = true;
    else g_out_len += (size_t)n;
}

/* A JSON string of printable ASCII; anything else becomes '?' (names here are ASCII). */
static void out_str(const char *s, size_t max) {
    out("\"");
    for (size_t i = 0; i < max && s[i] != '\0'; i++) {
        unsigned char c = (unsigned char)s[i];
        if (c == '"' || c == '\\') out("\\%c", c);
        else out("%c", c >= 0x20 && c < 0x7f ? c : '?');
    }
    out("\"");
}

static void out_flush(void) {
    if (g_out_overflow) {
        g_out_len = 0;
        g_out_overflow = false;
        out("{\"event\":\"error\",\"message\":\"uavbus_mavbridge: an event longer than %zu bytes was not printed\"}",
            sizeof g_out);
    }
    out("\n");
    fwrite(g_out, 1, g_out_len, stdout);
    fflush(stdout);
    g_out_len = 0;
}

static void event_error(const char *msg) {
    out("{\"event\":\"error\",\"message\":");
    out_str(msg, SIZE_MAX);
    out("}");
    out_flush();
}

static void event_warning(const char *msg) {
    out("{\"event\":\"warning\",\"message\":");
    out_str(msg, SIZE_MAX);
    out("}");
    out_flush();
}

#if defined(__GNUC__)
__attribute__((format(printf, 1, 2), noreturn))
#endif
static void die(const char *fmt, ...) {
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    fprintf(stderr, "%s\n", msg);
    event_error(msg);
    exit(EXIT_USAGE);
}

/* ---- arguments ----------------------------------------------------------------------------------- */

static void usage(FILE *f) {
    fprintf(f,
            "usage: uavbus_mavbridge --config FILE [--node NAME] [--entity NAME] --mavlink SPEC\n"
            "                        [--sysid N] [--compid N] [--target SYSID/COMPID]\n"
            "                        [--mavlink-key FILE [--link-id N]] [--commands-without-policy]\n"
            "                        [--port LINK=SPEC]... [--stats-ms MS] [--duration-ms MS]\n"
            "SPEC (--mavlink): udp:bind=HOST:PORT,peer=HOST:PORT | serial:device=PATH[,baud=N]\n"
            "stdin commands: stats | quit\n");
}

static unsigned long parse_num(const char *s, int argi, unsigned long max, const char *what) {
    char *end = NULL;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 10);
    if (s[0] == '\0' || s[0] == '-' || *end != '\0' || errno != 0 || v > max)
        die("uavbus_mavbridge:argv[%d]: '%s' is not %s (0..%lu)", argi, s, what, max);
    return (unsigned long)v;
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
        if (strcmp(a, "--commands-without-policy") == 0) {
            o->commands_without_policy = true;
            continue;
        }
        if (i + 1 >= argc) {
            usage(stderr);
            die("uavbus_mavbridge:argv[%d]: '%s' needs a value (or is unknown: see --help)", i, a);
        }
        const char *v = argv[++i];
        if (strcmp(a, "--config") == 0) o->config = v;
        else if (strcmp(a, "--node") == 0) o->node = v;
        else if (strcmp(a, "--entity") == 0) o->entity = v;
        else if (strcmp(a, "--mavlink") == 0) o->mavlink = v;
        else if (strcmp(a, "--mavlink-key") == 0) o->key = v;
        else if (strcmp(a, "--sysid") == 0) o->sysid = (unsigned)parse_num(v, i, 255, "a MAVLink system id");
        else if (strcmp(a, "--compid") == 0) o->compid = (unsigned)parse_num(v, i, 255, "a MAVLink component id");
        else if (strcmp(a, "--link-id") == 0) o->link_id = (unsigned)parse_num(v, i, 255, "a signing link id");
        else if (strcmp(a, "--stats-ms") == 0) o->stats_ms = parse_num(v, i, UINT32_MAX, "a number of ms");
        else if (strcmp(a, "--duration-ms") == 0) {
            o->duration_ms = parse_num(v, i, UINT32_MAX, "a number of ms");
            o->has_duration = true;
        } else if (strcmp(a, "--target") == 0) {
            unsigned s = 0, c = 0;
            char tail;
            if (sscanf(v, "%u/%u%c", &s, &c, &tail) != 2 || s < 1 || s > 255 || c < 1 || c > 255)
                die("uavbus_mavbridge:argv[%d]: '%s': expected SYSID/COMPID, each 1..255, e.g. 1/1", i, v);
            o->target_sysid = s;
            o->target_compid = c;
        } else if (strcmp(a, "--port") == 0) {
            if (o->n_ports == MAX_PORT_ARGS) die("uavbus_mavbridge:argv[%d]: more than %d --port options", i, MAX_PORT_ARGS);
            o->ports[o->n_ports++] = v;
        } else {
            usage(stderr);
            die("uavbus_mavbridge:argv[%d]: unknown option '%s' (see --help)", i - 1, a);
        }
    }
    if (o->config == NULL) die("uavbus_mavbridge: --config FILE is required (the uavbus side: entities, ports, security)");
    if (o->mavlink == NULL)
        die("uavbus_mavbridge: --mavlink SPEC is required, e.g. --mavlink udp:bind=127.0.0.1:14550,peer=127.0.0.1:14555");
}

/* ---- set-up -------------------------------------------------------------------------------------- */

static int bridge_entity(const options_t *o) {
    if (o->entity == NULL) {
        for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++)
            if (g_node.locals[s].in_use) return g_node.locals[s].entity;
        die("%s: the node hosts no entity", o->config);
    }
    uint8_t id[UB_ENTITY_ID_LEN];
    int e = ub_entity_id(o->entity, id) == UB_OK ? ub_node_find_entity(&g_node, id) : UB_ERR_NOTFOUND;
    if (e < 0 || ub_pubsub_row(&g_node, e, 0) == NULL)
        die("uavbus_mavbridge: --entity '%s' is not an entity this node hosts (see \"hosts\"/\"nodes\" in %s)",
            o->entity, o->config);
    return e;
}

static void open_ports(const options_t *o, uint64_t now_ms) {
    char err[UB_PORTS_ERR_LEN];
    int rc = ub_ports_open_config(&g_ports, &g_cfg, now_ms, err, sizeof err);
    if (rc < 0) die("%s", err);
    for (int i = 0; i < o->n_ports; i++) {
        char name[UB_NODECFG_PORT_KEY_MAX + 1];
        ub_port_spec_t spec;
        if (ub_port_arg_parse(o->ports[i], name, sizeof name, &spec, err, sizeof err) != UB_OK ||
            ub_ports_open(&g_ports, name, &spec, now_ms, err, sizeof err) != UB_OK)
            die("uavbus_mavbridge: --port %s: %s", o->ports[i], err);
    }
}

/* ---- events -------------------------------------------------------------------------------------- */

static void out_entity(int e) { out_str((const char *)ub_node_entity_id(&g_node, e), UB_ENTITY_ID_LEN); }

static void event_ready(const options_t *o) {
    uint16_t port = 0;
    out("{\"event\":\"ready\",\"pid\":%ld,\"entity\":", (long)getpid());
    out_entity(g_br.entity);
    out(",\"mavlink\":");
    out_str(o->mavlink, SIZE_MAX);
    if (ub_mavio_local_port(&g_io, &port) == UB_OK) out(",\"mavlink_port\":%u", (unsigned)port);
    out(",\"sysid\":%u,\"compid\":%u,\"signing\":%s,\"uavbus_signed\":%s,\"commands\":%s,\"directories\":%zu,"
        "\"ports\":{",
        g_br.opt.sysid, g_br.opt.compid, g_br.opt.sign ? "true" : "false",
        ub_node_security(&g_node) != NULL ? "true" : "false", g_br.opt.commands ? "true" : "false", g_br.n_dirs);
    bool first = true;
    for (int id = 0; id < UB_MAX_NODE_LINKS; id++) {
        const ub_link_t *l = ub_node_link(&g_node, id);
        if (l == NULL || ub_ports_find(&g_ports, l->name) == NULL) continue;
        out("%s", first ? "" : ",");
        out_str(l->name, SIZE_MAX);
        out(":{\"local_port\":");
        if (ub_ports_local_port(&g_ports, l->name, &port) == UB_OK) out("%u}", (unsigned)port);
        else out("null}");
        first = false;
    }
    out("}}");
    out_flush();
}

static void out_drops(const uint64_t drops[UB_DROP_REASON_COUNT]) {
    out("\"drops\":{");
    for (int r = 0; r < UB_DROP_REASON_COUNT; r++)
        out("%s\"%s\":%" PRIu64, r ? "," : "", ub_drop_reason_name((ub_drop_reason_t)r), drops[r]);
    out("}");
}

#define C(name) out(",\"" #name "\":%" PRIu64, c->name)

static void event_stats(uint64_t now_ms, bool final) {
    const ub_node_counters_t *n = ub_node_counters(&g_node);
    out("{\"event\":\"stats\",\"t_ms\":%" PRIu64 "%s,\"node\":{\"originated\":%" PRIu64 ",\"forwarded\":%" PRIu64
        ",\"delivered\":%" PRIu64 ",",
        now_ms, final ? ",\"final\":true" : "", n->originated, n->forwarded, n->delivered);
    out_drops(n->drops);
    out("},\"links\":{");
    bool first = true;
    for (int id = 0; id < UB_MAX_NODE_LINKS; id++) {
        const ub_link_t *l = ub_node_link(&g_node, id);
        if (l == NULL) continue;
        out("%s", first ? "" : ",");
        first = false;
        out_str(l->name, SIZE_MAX);
        out(":{\"frames_in\":%" PRIu64 ",\"frames_out\":%" PRIu64 ",", l->counters.frames_in, l->counters.frames_out);
        out_drops(l->counters.drops);
        out("}");
    }
    const ub_mavbridge_counters_t *c = ub_mavbridge_counters(&g_br);
    uint8_t sys = 0, comp = 0;
    bool up = ub_mavbridge_connected(&g_br, &sys, &comp);
    out("}");
    if (ub_node_security(&g_node) != NULL) {
        const ub_sec_stats_t *ss = ub_sec_stats(&g_sec);
        out(",\"security\":{\"signed_out\":%" PRIu64 ",\"verified_in\":%" PRIu64 ",\"auth_failures\":%" PRIu64
            ",\"unknown_keys\":%" PRIu64 ",\"challenges_sent\":%" PRIu64 ",\"challenges_completed\":%" PRIu64
            ",\"reserve_failures\":%" PRIu64 ",\"tx_refused\":%" PRIu64 "}",
            ss->signed_out, ss->verified_in, ss->auth_failures, ss->unknown_keys, ss->challenges_sent,
            ss->challenges_completed, ss->reserve_failures, ss->tx_refused);
    }
    out(",\"mavlink\":{\"connected\":%s,\"sysid\":%u,\"compid\":%u", up ? "true" : "false", sys, comp);
    C(bytes_in); C(messages_in); C(updates_sent); C(lost); C(bad_crc); C(parse_errors); C(unsigned_refused);
    C(bad_signature); C(replayed); C(too_many_streams); C(other_source); C(unidentified); C(no_directory); C(messages_out);
    C(bytes_out); C(send_errors); C(backpressure); C(heartbeats_out); C(autopilot_heartbeats); C(link_up);
    C(link_lost); C(commands_forwarded); C(commands_off); C(writes_ignored); C(commands_failed); C(acks_routed);
    C(replies_routed); C(pending_full); C(intervals_sent); C(intervals_granted); C(intervals_refused);
    C(intervals_timeout);
    const ub_mavio_stats_t *s = &g_io.stats;
    out(",\"transport\":{\"datagrams_in\":%" PRIu64 ",\"foreign\":%" PRIu64 ",\"read_errors\":%" PRIu64
        ",\"again\":%" PRIu64 ",\"send_errors\":%" PRIu64 "}",
        s->datagrams_in, s->foreign, s->read_errors, s->again, s->send_errors);
    out(",\"rates\":{");
    first = true;
    for (size_t d = 0; d < g_br.n_dirs; d++) {
        const ub_mav_dir_state_t *st = ub_mavbridge_dir_state(&g_br, d);
        if (st->wanted_us == 0 && st->granted_us == 0) continue;
        out("%s", first ? "" : ",");
        first = false;
        out_str(g_br.dirs[d].name, SIZE_MAX);
        out(":{\"wanted_us\":%" PRIu32 ",\"granted_us\":%" PRIu32 ",\"received\":%" PRIu64 "}", st->wanted_us,
            st->granted_us, st->rx);
    }
    out("}}}");
    out_flush();
}

static void event_autopilot(bool up) {
    uint8_t sys = 0, comp = 0;
    (void)ub_mavbridge_connected(&g_br, &sys, &comp);
    out("{\"event\":\"autopilot\",\"state\":\"%s\",\"sysid\":%u,\"compid\":%u}", up ? "connected" : "lost", sys, comp);
    out_flush();
}

static bool read_stdin(uint64_t now_ms) {
    static char buf[256];
    static size_t len;
    ssize_t n = read(STDIN_FILENO, buf + len, sizeof buf - 1 - len);
    if (n == 0) return false;
    if (n < 0) return errno == EINTR || errno == EAGAIN;
    len += (size_t)n;
    char *nl;
    while ((nl = memchr(buf, '\n', len)) != NULL) {
        *nl = '\0';
        char *cmd = buf + strspn(buf, " \t\r");
        cmd[strcspn(cmd, " \t\r")] = '\0';
        if (strcmp(cmd, "quit") == 0) g_stop = 1;
        else if (strcmp(cmd, "stats") == 0) event_stats(now_ms, false);
        else if (cmd[0] != '\0') event_error("unknown command (expected: stats, quit)");
        size_t used = (size_t)(nl - buf) + 1;
        memmove(buf, buf + used, len - used);
        len -= used;
    }
    if (len == sizeof buf - 1) len = 0; /* an over-long line: dropped */
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
    signal(SIGPIPE, SIG_IGN);

    char err[UB_NODECFG_ERR_LEN];
    int rc = ub_nodecfg_load_file(&g_cfg, o.config, g_cfg_text, sizeof g_cfg_text, err, sizeof err);
    if (rc == UB_ERR_NOSPACE) die("%s: larger than %zu bytes", o.config, sizeof g_cfg_text);
    if (rc != UB_OK) die("%s", err);
    if (o.node != NULL) {
        if (ub_nodecfg_select_node(&g_cfg, o.node, err, sizeof err) != UB_OK) die("%s: %s", o.config, err);
    } else if (g_cfg.host_count == 0) {
        die("%s: no --node given and the file has no \"hosts\": say which node to run (--node NAME)", o.config);
    }
    /* Sequence numbers from the wall clock (as uavbus_node): a restarted bridge is not taken for a replay. */
    ub_node_options_t node_opt = {0};
    node_opt.first_seq = (uint32_t)(clock_ms(CLOCK_REALTIME) & 0x7FFFFFFFu);
    if (node_opt.first_seq == 0) node_opt.first_seq = 1;
    node_opt.random = ub_random_os;
    if (ub_node_init(&g_node, &mavcat_catalogue, &node_opt) != UB_OK) die("uavbus_mavbridge: catalogue refused by the runtime");
    if (ub_nodecfg_apply(&g_cfg, &g_node, err, sizeof err) != UB_OK) die("%s", err);
    /* The uavbus side signs (and requires signed frames) as the "security" section says, as uavbus_node. */
    char sec_err[UB_NODECFG_ERR_LEN + UB_SECFILE_ERR_LEN];
    if (ub_nodecfg_apply_security(&g_cfg, &g_node, &g_sec, &g_counter, NULL, clock_ms(CLOCK_REALTIME) * 1000u, sec_err,
                                  sizeof sec_err) != UB_OK)
        die("%s", sec_err);
    if (ub_ports_init(&g_ports, &g_node) != UB_OK) die("uavbus_mavbridge: ub_ports_init failed");

    ub_port_spec_t mspec;
    char perr[UB_PORTS_ERR_LEN];
    if (ub_port_spec_parse(o.mavlink, &mspec, perr, sizeof perr) != UB_OK) die("uavbus_mavbridge: --mavlink: %s", perr);
    if (ub_mavio_open(&g_io, &mspec, perr, sizeof perr) != UB_OK) die("uavbus_mavbridge: --mavlink %s: %s", o.mavlink, perr);

    ub_mavbridge_options_t bopt;
    memset(&bopt, 0, sizeof bopt);
    bopt.sysid = (uint8_t)o.sysid;
    bopt.compid = (uint8_t)o.compid;
    bopt.target_sysid = (uint8_t)o.target_sysid;
    bopt.target_compid = (uint8_t)o.target_compid;
    /* Commands need someone to say who may give them: the configuration's write policy. */
    bopt.commands = g_cfg.has_policy || o.commands_without_policy;
    if (o.key != NULL) {
        if (ub_mavbridge_load_key(o.key, bopt.key, perr, sizeof perr) != UB_OK) die("%s", perr);
        bopt.sign = true;
        bopt.link_id = (uint8_t)o.link_id;
        bopt.sign_timestamp = ub_mavbridge_signing_time(clock_ms(CLOCK_REALTIME) * 1000u);
    }
    uint64_t now = clock_ms(CLOCK_MONOTONIC);
    int entity = bridge_entity(&o);
    rc = ub_mavbridge_init(&g_br, &g_node, entity, mav_directories, mav_directories_count, &mavbridgeStatus, &bopt,
                           ub_mavio_write, &g_io, now);
    if (rc != UB_OK) die("uavbus_mavbridge: bridge set-up failed: %s", ub_strerror(rc));
    ub_node_set_deliver_hook(&g_node, ub_mavbridge_on_deliver, &g_br);
    open_ports(&o, now);
    event_ready(&o);
    if (!bopt.commands)
        event_warning("commands are off: the configuration has no \"security\" policy saying who may write to the "
                    "autopilot (add one, or run with --commands-without-policy in a closed lab)");

    bool stdin_open = true, was_up = false;
    uint64_t next_stats = o.stats_ms > 0 ? now + o.stats_ms : UINT64_MAX;
    uint64_t end = o.has_duration ? now + o.duration_ms : UINT64_MAX;
    struct pollfd fds[2 * UB_PORTS_MAX + 2];
    while (!g_stop && now < end) {
        int n = ub_ports_pollfds(&g_ports, fds, 2 * UB_PORTS_MAX);
        if (n < 0) n = 0;
        ub_mavio_pollfd(&g_io, &fds[n++]);
        int stdin_slot = -1;
        if (stdin_open) {
            stdin_slot = n;
            fds[n++] = (struct pollfd){.fd = STDIN_FILENO, .events = POLLIN};
        }
        if (poll(fds, (nfds_t)n, ub_ports_poll_timeout(&g_ports, now, LOOP_MAX_WAIT_MS)) < 0 && errno != EINTR) {
            char msg[96];
            snprintf(msg, sizeof msg, "poll: %s", strerror(errno));
            event_error(msg);
        }
        now = clock_ms(CLOCK_MONOTONIC);
        if (stdin_slot >= 0 && (fds[stdin_slot].revents & (POLLIN | POLLHUP | POLLERR)) != 0) stdin_open = read_stdin(now);
        (void)ub_ports_service(&g_ports, now);
        if (ub_mavio_service(&g_io, &g_br, now) < 0) event_error("mavlink: the autopilot link failed (read error)");
        ub_mavbridge_tick(&g_br, now);
        ub_node_tick(&g_node, now);
        bool up = ub_mavbridge_connected(&g_br, NULL, NULL);
        if (up != was_up) event_autopilot(up);
        was_up = up;
        if (now >= next_stats) {
            event_stats(now, false);
            next_stats += o.stats_ms;
            if (next_stats <= now) next_stats = now + o.stats_ms;
        }
    }
    event_stats(clock_ms(CLOCK_MONOTONIC), true);
    ub_ports_close_all(&g_ports);
    ub_mavio_close(&g_io);
    return 0;
}
