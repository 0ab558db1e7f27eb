/*
 * ub_app: the shell of a uavbus program -- one node of a configuration file as a process that a
 * supervisor (Python's uavbus.sim, a test, an operator's script) drives over pipes.
 *
 * `uavbus_node` (programs/node) and `uavbus_mavbridge` (bridges/mavlink) are this shell plus what
 * they host. The shell owns what every such program does the same way:
 *   - the command line: --config, --node, --port LINK=SPEC..., --stats-ms, --duration-ms, --help,
 *     and `PROG:argv[i]: message` for anything wrong (exit status 2, UB_APP_EXIT_USAGE);
 *   - the node: the configuration loaded and applied (entities, links, masks, the "security"
 *     section), sequence numbers from the wall clock, request ids from the OS, the ports (the
 *     configuration's, with --port replacing an entry for the same link);
 *   - the JSON-lines protocol on stdout: one object per line, built with ub_app_out() and written
 *     whole by ub_app_flush(); "error" and "warning" events; the "stats" schedule (every
 *     --stats-ms, on the `stats` command, once with "final":true at exit). The events, their
 *     fields and the commands are docs/program-protocol.md and schemas/program-events.schema.json,
 *     which the Python supervisor reads (uavbus.sim.protocol);
 *   - stdin: one command a line; `stats` and `quit` here, the others to the program's `command`;
 *     an over-long line is dropped, counted (ub_app_t.stdin_dropped) and answered with an error;
 *   - SIGINT/SIGTERM stop the loop as `quit` does; SIGPIPE (a supervisor gone) and SIGXFSZ (a
 *     file-size limit: the log sees EFBIG and rotates) are ignored;
 *   - the loop: poll() on the ports, the program's descriptors and stdin, sleeping until the next
 *     due time -- the node's (ub_node_next_due(): publications, routing timers, ...), the program's
 *     (its `next_due` hook), a port's (TCP reconnect, serial reopen, impairment queue), the stats, the
 *     end of --duration-ms. A program with tick hooks but no `next_due` is woken every
 *     UB_APP_MAX_WAIT_MS, as before the node could say when it is due.
 *
 * Compiled into each program (the `ub_app` CMake target carries the source, not an archive): a
 * program may build the runtime with its own capacities (UB_CONFIG_FILE, as the MAVLink bridge
 * does), and ub_app_t embeds the node, so the shell must see the same ub_config.h as the program.
 *
 * One ub_app_t per process, caller-owned (it is large: keep it static). The only static inside the
 * shell is the flag the signal handler sets: a handler cannot be handed a context.
 */
#ifndef UB_APP_H
#define UB_APP_H

#include <poll.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "ub/ub_frag.h"
#include "ub/ub_ident.h"
#include "ub/ub_identfile.h"
#include "ub/ub_node.h"
#include "ub/ub_nodecfg.h"
#include "ub/ub_origin.h"
#include "ub/ub_ports.h"
#include "ub/ub_revoke.h"
#include "ub/ub_sec.h"
#include "ub/ub_secfile.h"

#if defined(__GNUC__)
#define UB_APP_PRINTF(a, b) __attribute__((format(printf, a, b)))
#define UB_APP_NORETURN __attribute__((noreturn))
#else
#define UB_APP_PRINTF(a, b)
#define UB_APP_NORETURN
#endif

#define UB_APP_EXIT_USAGE 2          /* bad command line or set-up: the message names argv[i] or file:line */
#define UB_APP_MAX_PORT_ARGS 16      /* --port options */
#define UB_APP_MAX_CONTENTS 1024     /* catalogue instances the config's "priorities" can class */
#define UB_APP_MAX_WAIT_MS 1         /* a program with tick hooks and no next_due hook: wake every ms */
#define UB_APP_OUT_CAP (1 << 16)     /* one event line; a longer one becomes an error event */
#define UB_APP_LINE_CAP 1024         /* one stdin command line, newline included */
#define UB_APP_CONFIG_CAP (1 << 16)  /* the configuration file's text */
#define UB_APP_MAX_FDS (2 * UB_PORTS_MAX + 8)

typedef struct ub_app ub_app_t;

/* What a program adds to the shell. Every hook may be NULL. */
typedef struct ub_app_program {
    const char *name;        /* e.g. "uavbus_node": prefixes its messages */
    void (*usage)(FILE *f);  /* the --help text */
    const char *config_hint; /* after "--config FILE is required", e.g. "(e.g. --config table2.json)" */
    const char *commands;    /* what the error for an unknown stdin command lists */
    const char *const *flags; /* the program's options without a value, NULL-terminated (or NULL) */
    /* After the command line (ub_app_main()): ub_app_start(), the program's own set-up,
     * ub_app_open_ports(), its "ready" event. Exit through ub_app_die() on a refusal. */
    void (*setup)(ub_app_t *app);
    /* After the loop and the final stats, before the ports close: what setup opened besides them. */
    void (*close)(ub_app_t *app);
    /* A program option (`val` NULL for one of `flags`): true if it is the program's. Called in
     * argv order; exit through ub_app_die() on a bad value. */
    bool (*option)(ub_app_t *app, const char *opt, const char *val, int argi);
    /* A stdin command other than `stats` and `quit`, whose first word is `verb` (`save` continues
     * strtok_r over the line): true if it is the program's (it answers with an event). */
    bool (*command)(ub_app_t *app, const char *verb, char **save, uint64_t now_ms);
    /* Descriptors to poll besides the ports and stdin: how many it wrote to fds[0, max). */
    int (*pollfds)(ub_app_t *app, struct pollfd *fds, int max);
    /* Every loop turn as poll() returns, before stdin, the ports and the tick read anything: state that is a
     * function of time is brought up to `now_ms` here, lazily (uavbus_node's motion models). It asks for no
     * wake-up of its own: a program whose state must change at a time says so through next_due. */
    void (*wake)(ub_app_t *app, uint64_t now_ms);
    /* Every loop turn once the ports are serviced: before and after ub_node_tick(). */
    void (*before_tick)(ub_app_t *app, uint64_t now_ms);
    void (*after_tick)(ub_app_t *app, uint64_t now_ms);
    /* When the program's tick hooks next have work (its own timers); UINT64_MAX: none. NULL with a tick
     * hook: every UB_APP_MAX_WAIT_MS. The loop sleeps until the earliest of this, ub_node_next_due(), the
     * ports', the stats' and the end, or until input. */
    uint64_t (*next_due)(ub_app_t *app, uint64_t now_ms);
    /* The program's "stats" event (periodic, on `stats`, and with final true at exit). */
    void (*stats)(ub_app_t *app, uint64_t now_ms, bool final);
    void *user;
} ub_app_program_t;

struct ub_app {
    const ub_app_program_t *prog;

    /* The command line (ub_app_parse()). */
    const char *config_path;
    const char *node_opt;    /* --node, or NULL: the file's "hosts" */
    uint64_t stats_ms;       /* 0: only the final stats */
    uint64_t duration_ms;
    bool has_duration;
    int n_ports;
    const char *port_args[UB_APP_MAX_PORT_ARGS];
    int port_argi[UB_APP_MAX_PORT_ARGS];

    /* The node (ub_app_start()). */
    ub_nodecfg_t cfg;
    char cfg_text[UB_APP_CONFIG_CAP];
    const char *node_name;   /* --node, or the first of "hosts" */
    ub_node_t node;
    ub_sec_t sec;            /* used when the configuration has a "security" section */
    ub_counter_file_t counter;
    uint8_t content_class[UB_APP_MAX_CONTENTS]; /* the config's "priorities" per instance (ub_prio.h) */
    /* Identity per entity (issue 23): used when the "security" section names an authority. The revocation
     * service spreads and persists revocations (ub_revoke.h); its records are the store's. */
    bool ident_on;
    ub_ident_store_t ident;
    ub_revoke_t revoke;
    char revocations_path[UB_NODECFG_PATH_MAX + 128];
    char certificates_path[UB_NODECFG_PATH_MAX + 128];
    /* Origin authentication (docs/security.md, "Origin authentication"): on whenever the configuration names
     * identities (keys from the identity store, required on every frame to a hosted entity); without them,
     * --origin-key (the hosted entity's X25519 secret key) and --origin-peers ("ENTITY HEX_X25519_PUBLIC_KEY"
     * lines) stand in for the store. */
    bool origin_on;
    const char *origin_key_path;
    const char *origin_peers_path;
    ub_origin_t origin;
    int origin_peer_count;
    uint8_t origin_peer_ids[UB_ORIGIN_PEERS][UB_ENTITY_ID_LEN];
    uint8_t origin_peer_pks[UB_ORIGIN_PEERS][UB_ORIGIN_PK_LEN];
    ub_ports_t ports;
    uint32_t first_seq;
    uint64_t start_ms;       /* CLOCK_MONOTONIC at the start; --duration-ms counts from it */

    /* stdout: the event being built. */
    char out[UB_APP_OUT_CAP];
    size_t out_len;
    bool out_overflow;

    /* stdin: the command line being read. */
    char line[UB_APP_LINE_CAP];
    size_t line_len;
    bool discarding;         /* the rest of an over-long line is dropped up to its newline */
    bool stdin_open;
    uint64_t stdin_dropped;  /* bytes of over-long command lines */
    uint64_t wakeups;        /* loop turns (poll() returns): what sleeping until the next due time saves */
    bool stop;
};

/* ---- clocks ---------------------------------------------------------------------------------------- */

/* CLOCK_MONOTONIC in ms: the time every ub_* call of the shell gets, and the "t_ms" of events. */
uint64_t ub_app_mono_ms(void);
/* CLOCK_REALTIME in ms and in us. */
uint64_t ub_app_unix_ms(void);
uint64_t ub_app_unix_us(void);

/* ---- life cycle ------------------------------------------------------------------------------------ */

/* The whole program: ub_app_parse(), prog->setup, ub_app_run(), prog->close, ub_app_close(). Returns
 * the exit status for main(). */
int ub_app_main(ub_app_t *app, const ub_app_program_t *prog, int argc, char **argv);

/* Reads the command line into `app` (zeroed first) for program `prog` (which must outlive it): the
 * shell's options and, through prog->option, the program's. --help prints the usage and exits 0;
 * anything wrong exits UB_APP_EXIT_USAGE with `NAME:argv[i]: ...` on stderr and an error event.
 * Then makes stdout fully buffered (ub_app_flush() writes each event whole) and installs the signal
 * handling. */
void ub_app_parse(ub_app_t *app, const ub_app_program_t *prog, int argc, char **argv);

/* Loads the configuration, picks the node, initialises it on `catalogue` (with fragments when
 * `frag` is not NULL), applies the configuration and its "security" section, and initialises the
 * ports (none open yet). Exits UB_APP_EXIT_USAGE with `file:line: ...` on a refusal. */
void ub_app_start(ub_app_t *app, const ub_catalogue_t *catalogue, ub_frag_t *frag);

/* Opens the configuration's ports of this node, except those a --port replaces, then the --port ones.
 * Exits UB_APP_EXIT_USAGE on a refusal (address in use, bad spec, no such link). */
void ub_app_open_ports(ub_app_t *app, uint64_t now_ms);

/* The loop, until `quit`, a signal, or --duration-ms after start_ms; then the final stats. Returns the
 * exit status (0). The caller closes what it opened, then calls ub_app_close(). */
int ub_app_run(ub_app_t *app);

/* Closes every port. */
void ub_app_close(ub_app_t *app);

/* The stdin command line `line` (no newline), as if it had been read: for a program that takes commands
 * from elsewhere too, and for tests. */
void ub_app_command(ub_app_t *app, char *line, uint64_t now_ms);

/* ---- the JSON-lines protocol ----------------------------------------------------------------------- */

/* Appends to the event being built (an overlong event becomes an error event at ub_app_flush()). */
void ub_app_out(ub_app_t *app, const char *fmt, ...) UB_APP_PRINTF(2, 3);
/* A JSON string of s[0, max) (up to a NUL). Whatever the bytes (entity IDs and names arrive from the
 * network), the output is valid UTF-8 JSON: quotes, backslashes and control characters are escaped,
 * and every byte that is not part of a well-formed UTF-8 sequence becomes U+FFFD. */
void ub_app_str(ub_app_t *app, const char *s, size_t max);
/* An entity ID as a JSON string (the name without its padding). */
void ub_app_entity(ub_app_t *app, const uint8_t id[UB_ENTITY_ID_LEN]);
/* "drops":{REASON:N,...} for every reason ub_drop_reason_name() knows. */
void ub_app_drops(ub_app_t *app, const uint64_t drops[UB_DROP_REASON_COUNT]);
/* {"LINK":{...},...}: the node's links in id order (only those with an open port when `ports_only`),
 * each its name as the key and an object whose members `each` writes (port NULL: no open port). */
typedef void (*ub_app_link_fn)(ub_app_t *app, int id, const ub_link_t *link, const ub_port_t *port);
void ub_app_links(ub_app_t *app, bool ports_only, ub_app_link_fn each);
/* Writes the event as one line (flushed) and starts the next. */
void ub_app_flush(ub_app_t *app);
/* {"event":"error","message":MSG} */
void ub_app_error(ub_app_t *app, const char *msg);
/* {"event":"warning","message":MSG}, and MSG on stderr: something the operator should know once. */
void ub_app_warning(ub_app_t *app, const char *msg);
/* Start-up failure: the message on stderr and as an error event, exit status UB_APP_EXIT_USAGE. */
void ub_app_die(ub_app_t *app, const char *fmt, ...) UB_APP_PRINTF(2, 3) UB_APP_NORETURN;

/* A whole number in argv[argi] (no sign), at most `max`, or ub_app_die():
 * `NAME:argv[argi]: 'S' is not WHAT` (`... (0..MAX)` when max is not UINT64_MAX). */
uint64_t ub_app_parse_uint(ub_app_t *app, const char *s, int argi, uint64_t max, const char *what);

#endif /* UB_APP_H */
