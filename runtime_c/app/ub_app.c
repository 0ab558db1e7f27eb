/*
 * ub_app: the program shell (ub_app.h). The protocol it speaks is docs/program-protocol.md.
 */
#include "ub_app.h"

#include <errno.h>
#include <inttypes.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "ub/ub_random.h"

/* The one static: a signal handler cannot be handed a context. Read by ub_app_run() only. */
static volatile sig_atomic_t g_signalled;

static void on_signal(int sig) {
    (void)sig;
    g_signalled = 1;
}

/* ---- clocks ---------------------------------------------------------------------------------------- */

static uint64_t clock_us(clockid_t id) {
    struct timespec ts;
    clock_gettime(id, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

uint64_t ub_app_mono_ms(void) { return clock_us(CLOCK_MONOTONIC) / 1000u; }
uint64_t ub_app_unix_ms(void) { return clock_us(CLOCK_REALTIME) / 1000u; }
uint64_t ub_app_unix_us(void) { return clock_us(CLOCK_REALTIME); }

/* ---- JSON lines -------------------------------------------------------------------------------------- */

void ub_app_out(ub_app_t *app, const char *fmt, ...) {
    if (app->out_overflow) return;
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(app->out + app->out_len, sizeof app->out - app->out_len, fmt, ap);
    va_end(ap);
    if (n < 0 || (size_t)n >= sizeof app->out - app->out_len) {
        app->out_overflow = true;
        return;
    }
    app->out_len += (size_t)n;
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

void ub_app_str(ub_app_t *app, const char *s, size_t max) {
    const unsigned char *u = (const unsigned char *)s;
    size_t n = strnlen(s, max);
    ub_app_out(app, "\"");
    for (size_t i = 0; i < n;) {
        unsigned char c = u[i];
        size_t len = utf8_sequence(u + i, n - i);
        if (len == 0) {
            ub_app_out(app, "\\ufffd");
            i++;
        } else if (c == '"' || c == '\\') {
            ub_app_out(app, "\\%c", c);
            i++;
        } else if (c < 0x20) {
            ub_app_out(app, "\\u%04x", c);
            i++;
        } else {
            ub_app_out(app, "%.*s", (int)len, s + i);
            i += len;
        }
    }
    ub_app_out(app, "\"");
}

void ub_app_entity(ub_app_t *app, const uint8_t id[UB_ENTITY_ID_LEN]) {
    ub_app_str(app, (const char *)id, UB_ENTITY_ID_LEN);
}

void ub_app_drops(ub_app_t *app, const uint64_t drops[UB_DROP_REASON_COUNT]) {
    ub_app_out(app, "\"drops\":{");
    for (int r = 0; r < UB_DROP_REASON_COUNT; r++) {
        ub_app_out(app, "%s\"%s\":%" PRIu64, r ? "," : "", ub_drop_reason_name((ub_drop_reason_t)r), drops[r]);
    }
    ub_app_out(app, "}");
}

void ub_app_links(ub_app_t *app, bool ports_only, ub_app_link_fn each) {
    ub_app_out(app, "{");
    bool first = true;
    for (int id = 0; id < UB_MAX_NODE_LINKS; id++) {
        const ub_link_t *l = ub_node_link(&app->node, id);
        const ub_port_t *p = l != NULL ? ub_ports_find(&app->ports, l->name) : NULL;
        if (l == NULL || (ports_only && p == NULL)) continue;
        ub_app_out(app, "%s", first ? "" : ",");
        first = false;
        ub_app_str(app, l->name, SIZE_MAX);
        ub_app_out(app, ":{");
        each(app, id, l, p);
        ub_app_out(app, "}");
    }
    ub_app_out(app, "}");
}

/* An overlong event becomes an error event rather than a cut line: a supervisor parses every line. */
void ub_app_flush(ub_app_t *app) {
    if (app->out_overflow) {
        app->out_len = 0;
        app->out_overflow = false;
        ub_app_out(app, "{\"event\":\"error\",\"message\":\"%s: an event was longer than %zu bytes and was not printed\"}",
                   app->prog->name, sizeof app->out);
    }
    ub_app_out(app, "\n");
    fwrite(app->out, 1, app->out_len, stdout);
    fflush(stdout);
    app->out_len = 0;
}

/* `head` is the event up to its message: {"event":"error","message": */
static void event_message(ub_app_t *app, const char *head, const char *msg) {
    ub_app_out(app, "%s", head);
    ub_app_str(app, msg, SIZE_MAX);
    ub_app_out(app, "}");
    ub_app_flush(app);
}

void ub_app_error(ub_app_t *app, const char *msg) { event_message(app, "{\"event\":\"error\",\"message\":", msg); }

void ub_app_warning(ub_app_t *app, const char *msg) {
    event_message(app, "{\"event\":\"warning\",\"message\":", msg);
    fprintf(stderr, "%s: %s\n", app->prog->name, msg);
}

void ub_app_die(ub_app_t *app, const char *fmt, ...) {
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    fprintf(stderr, "%s\n", msg);
    ub_app_error(app, msg);
    exit(UB_APP_EXIT_USAGE);
}

/* ---- the command line -------------------------------------------------------------------------------- */

uint64_t ub_app_parse_uint(ub_app_t *app, const char *s, int argi, uint64_t max, const char *what) {
    char *end = NULL;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 10);
    if (s[0] == '\0' || s[0] == '-' || *end != '\0' || errno != 0 || v > max) {
        if (max == UINT64_MAX) ub_app_die(app, "%s:argv[%d]: '%s' is not %s", app->prog->name, argi, s, what);
        ub_app_die(app, "%s:argv[%d]: '%s' is not %s (0..%" PRIu64 ")", app->prog->name, argi, s, what, max);
    }
    return (uint64_t)v;
}

static bool is_flag(const ub_app_program_t *prog, const char *opt) {
    for (const char *const *f = prog->flags; f != NULL && *f != NULL; f++) {
        if (strcmp(*f, opt) == 0) return true;
    }
    return false;
}

static void usage(const ub_app_program_t *prog, FILE *f) {
    if (prog->usage != NULL) prog->usage(f);
}

static void signals(void) {
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    signal(SIGPIPE, SIG_IGN); /* a closed stdout reader must not kill the program; writes just fail */
    signal(SIGXFSZ, SIG_IGN); /* a file-size limit must not kill it either: the log sees EFBIG and rotates */
}

void ub_app_parse(ub_app_t *app, const ub_app_program_t *prog, int argc, char **argv) {
    memset(app, 0, sizeof *app);
    app->prog = prog;
    app->stats_ms = 1000;
    app->stdin_open = true;
    const char *name = prog->name;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(prog, stdout);
            exit(0);
        }
        if (is_flag(prog, a)) {
            if (prog->option == NULL || !prog->option(app, a, NULL, i)) ub_app_die(app, "%s: '%s' refused", name, a);
            continue;
        }
        if (i + 1 >= argc) {
            usage(prog, stderr);
            ub_app_die(app, "%s:argv[%d]: '%s' needs a value (or is unknown: see --help)", name, i, a);
        }
        const char *v = argv[++i];
        if (strcmp(a, "--config") == 0) app->config_path = v;
        else if (strcmp(a, "--node") == 0) app->node_opt = v;
        else if (strcmp(a, "--stats-ms") == 0) app->stats_ms = ub_app_parse_uint(app, v, i, UINT64_MAX, "a whole number of milliseconds");
        else if (strcmp(a, "--duration-ms") == 0) {
            app->duration_ms = ub_app_parse_uint(app, v, i, UINT64_MAX, "a whole number of milliseconds");
            app->has_duration = true;
        } else if (strcmp(a, "--port") == 0) {
            if (app->n_ports == UB_APP_MAX_PORT_ARGS) {
                ub_app_die(app, "%s:argv[%d]: more than %d --port options", name, i, UB_APP_MAX_PORT_ARGS);
            }
            app->port_argi[app->n_ports] = i;
            app->port_args[app->n_ports++] = v;
        } else if (strcmp(a, "--origin-key") == 0) {
            app->origin_key_path = v;
        } else if (strcmp(a, "--origin-peers") == 0) {
            app->origin_peers_path = v;
        } else if (prog->option == NULL || !prog->option(app, a, v, i)) {
            usage(prog, stderr);
            ub_app_die(app, "%s:argv[%d]: unknown option '%s' (see --help)", name, i - 1, a);
        }
    }
    if (app->config_path == NULL) {
        ub_app_die(app, "%s: --config FILE is required%s%s", name, prog->config_hint ? " " : "",
                   prog->config_hint ? prog->config_hint : "");
    }
    /* Fully buffered: every event is written whole by ub_app_flush(), never a part of one. */
    setvbuf(stdout, NULL, _IOFBF, 1 << 16);
    signals();
}

/* ---- origin authentication (--origin-key, --origin-peers) ---------------------------------------------------
 * Without an authority in the configuration (a bench, or a fleet without identities), these stand in for the
 * identity store (start_origin_identities() below is what a fleet with identities uses): each
 * hosted entity's X25519 secret key in a key file (`uavbus keys new`: any 32 random bytes are an X25519 secret
 * key; "{entity}" in the path is the entity's name), and the peers' public keys in a text file, one
 * "ENTITY HEX_X25519_PUBLIC_KEY" a line, '#' comments. No validity periods or revocation: that is the store's. */

static int app_origin_lookup(void *user, const uint8_t id[UB_ENTITY_ID_LEN], uint64_t now_s, uint8_t pk[UB_ORIGIN_PK_LEN]) {
    const ub_app_t *app = user;
    (void)now_s;
    for (int i = 0; i < app->origin_peer_count; i++)
        if (memcmp(app->origin_peer_ids[i], id, UB_ENTITY_ID_LEN) == 0) {
            memcpy(pk, app->origin_peer_pks[i], UB_ORIGIN_PK_LEN);
            return UB_OK;
        }
    return UB_ERR_NOTFOUND;
}

static int hex_nibble(char c) {
    return c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : c >= 'A' && c <= 'F' ? c - 'A' + 10 : -1;
}

static void load_origin_peers(ub_app_t *app, const char *path) {
    FILE *f = fopen(path, "r");
    if (f == NULL) ub_app_die(app, "%s: cannot open the origin peers file: %s", path, strerror(errno));
    char line[256];
    unsigned long lineno = 0;
    while (fgets(line, sizeof line, f) != NULL) {
        lineno++;
        char name[64], hex[128];
        char *hash = strchr(line, '#');
        if (hash != NULL) *hash = '\0';
        int n = sscanf(line, "%63s %127s", name, hex);
        if (n <= 0) continue;
        uint8_t id[UB_ENTITY_ID_LEN];
        if (n != 2 || strlen(hex) != 2 * UB_ORIGIN_PK_LEN || ub_entity_id(name, id) != UB_OK) {
            fclose(f);
            ub_app_die(app, "%s:%lu: expected \"ENTITY HEX_X25519_PUBLIC_KEY\" (an entity name of at most 12 bytes and "
                       "64 hex digits)", path, lineno);
        }
        if (app->origin_peer_count == UB_ORIGIN_PEERS) {
            fclose(f);
            ub_app_die(app, "%s:%lu: more than %d peers (UB_ORIGIN_PEERS in ub_config.h)", path, lineno, UB_ORIGIN_PEERS);
        }
        uint8_t *pk = app->origin_peer_pks[app->origin_peer_count];
        for (size_t k = 0; k < UB_ORIGIN_PK_LEN; k++) {
            int hi = hex_nibble(hex[2 * k]), lo = hex_nibble(hex[2 * k + 1]);
            if (hi < 0 || lo < 0) {
                fclose(f);
                ub_app_die(app, "%s:%lu: '%s' is not 64 hex digits", path, lineno, hex);
            }
            pk[k] = (uint8_t)(hi << 4 | lo);
        }
        memcpy(app->origin_peer_ids[app->origin_peer_count++], id, UB_ENTITY_ID_LEN);
    }
    fclose(f);
}

/* Origin authentication from the identity store (issue 23: one feature): each hosted entity's X25519 secret key
 * is its identity file's, a peer's public key is its certificate's, valid and unrevoked at the wall clock
 * (ub_ident_peer_kx_key()), and a revocation the revocation service accepts ends the peer's cached pairs at
 * once. Origin blocks are required on every frame to a hosted entity (fail closed: `no_origin`). */
static void start_origin_identities(ub_app_t *app) {
    const char *name = app->prog->name;
    if (app->origin_key_path != NULL || app->origin_peers_path != NULL)
        ub_app_die(app, "%s: --origin-key/--origin-peers and a configuration naming identities (security.identity) "
                   "exclude each other: the identities give origin authentication its keys (drop the options)", name);
    if (ub_node_security(&app->node) == NULL)
        ub_app_die(app, "%s: security.identity needs the fleet's group key too (security.keys): origin tags ride on "
                   "signed frames (docs/security.md, \"Origin authentication\")", app->config_path);
    ub_origin_options_t o = {.lookup = ub_ident_peer_kx_key, .lookup_user = &app->ident, .clock_s = ub_identfile_unix_s};
    if (ub_origin_init(&app->origin, &o) != UB_OK) ub_app_die(app, "%s: origin authentication failed to start", name);
    for (int h = 0; h < app->cfg.host_count; h++) {
        const char *entity = app->cfg.entities[app->cfg.hosts[h]].name;
        uint8_t id[UB_ENTITY_ID_LEN];
        const uint8_t *sk = ub_entity_id(entity, id) == UB_OK ? ub_ident_self_kx_sk_for(&app->ident, id) : NULL;
        if (sk == NULL) {
            char msg[256];
            snprintf(msg, sizeof msg, "%s: hosted entity %s has no identity (put {entity} in security.identity): it "
                     "cannot send to other entities (counted no_identity)", app->config_path, entity);
            ub_app_warning(app, msg);
            continue;
        }
        int rc = ub_origin_add_identity(&app->origin, id, sk);
        if (rc != UB_OK) ub_app_die(app, "%s: identity of %s refused by origin authentication: %s", name, entity, ub_strerror(rc));
    }
    if (ub_origin_attach(&app->origin, &app->node) != UB_OK) ub_app_die(app, "%s: the node refused origin authentication", name);
    if (ub_revoke_set_peer_hook(&app->revoke, ub_origin_forget_hook, &app->origin) != UB_OK)
        ub_app_die(app, "%s: the revocation service refused its hook", name);
    app->origin_on = true;
}

static void start_origin(ub_app_t *app) {
    if (app->ident_on) {
        start_origin_identities(app);
        return;
    }
    if (app->origin_key_path == NULL && app->origin_peers_path == NULL) return;
    const char *name = app->prog->name;
    if (app->origin_key_path == NULL || app->origin_peers_path == NULL)
        ub_app_die(app, "%s: --origin-key and --origin-peers go together (the entity's key and its peers' public keys)", name);
    if (ub_node_security(&app->node) == NULL)
        ub_app_die(app, "%s: --origin-key needs a signed configuration (a \"security\" section with the group key)", name);
    load_origin_peers(app, app->origin_peers_path);
    ub_origin_options_t o = {.lookup = app_origin_lookup, .lookup_user = app};
    if (ub_origin_init(&app->origin, &o) != UB_OK) ub_app_die(app, "%s: origin authentication failed to start", name);
    for (int h = 0; h < app->cfg.host_count; h++) {
        const char *entity = app->cfg.entities[app->cfg.hosts[h]].name;
        char path[512], why[UB_SECFILE_ERR_LEN];
        const char *at = strstr(app->origin_key_path, "{entity}");
        if (at != NULL)
            (void)snprintf(path, sizeof path, "%.*s%s%s", (int)(at - app->origin_key_path), app->origin_key_path, entity,
                           at + strlen("{entity}"));
        else
            (void)snprintf(path, sizeof path, "%s", app->origin_key_path);
        uint8_t key_id = 0, sk[UB_ORIGIN_SK_LEN], id[UB_ENTITY_ID_LEN];
        if (ub_keyfile_load(path, &key_id, sk, why, sizeof why) != UB_OK) ub_app_die(app, "%s", why);
        int rc = ub_entity_id(entity, id) == UB_OK ? ub_origin_add_identity(&app->origin, id, sk) : UB_ERR_RANGE;
        memset(sk, 0, sizeof sk);
        if (rc != UB_OK)
            ub_app_die(app, "%s: identity of %s refused: %s (one key file per hosted entity: put {entity} in the path)",
                       path, entity, ub_strerror(rc));
    }
    if (ub_origin_attach(&app->origin, &app->node) != UB_OK) ub_app_die(app, "%s: the node refused origin authentication", name);
    app->origin_on = true;
}

/* ---- the node ---------------------------------------------------------------------------------------- */

void ub_app_start(ub_app_t *app, const ub_catalogue_t *catalogue, ub_frag_t *frag) {
    const char *name = app->prog->name, *path = app->config_path;
    char err[UB_NODECFG_ERR_LEN];
    int rc = ub_nodecfg_load_file(&app->cfg, path, app->cfg_text, sizeof app->cfg_text, err, sizeof err);
    if (rc == UB_ERR_NOSPACE) ub_app_die(app, "%s: larger than %zu bytes", path, sizeof app->cfg_text);
    if (rc != UB_OK) ub_app_die(app, "%s", err);
    if (app->node_opt != NULL) {
        if (ub_nodecfg_select_node(&app->cfg, app->node_opt, err, sizeof err) != UB_OK) ub_app_die(app, "%s: %s", path, err);
    } else if (app->cfg.host_count == 0) {
        ub_app_die(app, "%s: no --node given and the file has no \"hosts\": say which node to run (--node NAME)", path);
    }
    app->node_name = app->node_opt != NULL ? app->node_opt : app->cfg.entities[app->cfg.hosts[0]].name;
    /* Start the sequence numbers from the wall clock in microseconds, not from 1 (nor from milliseconds,
     * which a process sending faster than a frame per ms outruns): receivers keep a 64-frame duplicate
     * window per source, and a restarted process whose new numbers land inside the old window would
     * have its first frames dropped as duplicates (ub_node.h, "Duplicate window"; ub_node_seq_seed()). */
    ub_node_options_t opt = {0};
    opt.first_seq = ub_node_seq_seed(ub_app_unix_us());
    opt.random = ub_random_os; /* unguessable request ids (docs/pubsub.md, "Replies bound to their row") */
    app->first_seq = opt.first_seq;
    if (ub_node_init(&app->node, catalogue, &opt) != UB_OK) ub_app_die(app, "%s: catalogue refused by the runtime", name);
    if (frag != NULL) {
        /* directories above the payload limit or a link's MTU, in fragments (ub_frag.h) */
        /* transfer numbers from the millisecond clock, as before: +1 per fragmented directory, so a
         * restart a second later starts past the ones its predecessor may have left in reassembly */
        ub_frag_init(frag, NULL, (uint16_t)ub_app_unix_ms());
        if (ub_node_set_frag(&app->node, frag) != UB_OK) ub_app_die(app, "%s: fragment state refused", name);
    }
    if (ub_nodecfg_apply(&app->cfg, &app->node, err, sizeof err) != UB_OK) ub_app_die(app, "%s", err);
    /* Priority classes of contents on slow links (docs/pubsub.md, "Priorities on slow links"). */
    if (app->cfg.priority_count > 0 && catalogue->n_instances > UB_APP_MAX_CONTENTS)
        ub_app_die(app, "%s: priorities: the catalogue has %zu contents, this program classes at most %d "
                   "(UB_APP_MAX_CONTENTS)", app->cfg.source, (size_t)catalogue->n_instances, UB_APP_MAX_CONTENTS);
    if (ub_nodecfg_apply_priorities(&app->cfg, &app->node, catalogue, app->content_class, catalogue->n_instances, err,
                                    sizeof err) != UB_OK)
        ub_app_die(app, "%s", err);
    /* Keys, counter file and policy of the "security" section (none: the node stays unsigned). */
    char sec_err[UB_NODECFG_ERR_LEN + UB_SECFILE_ERR_LEN];
    if (ub_nodecfg_apply_security(&app->cfg, &app->node, &app->sec, &app->counter, NULL, ub_app_unix_us(), sec_err,
                                  sizeof sec_err) != UB_OK) {
        ub_app_die(app, "%s", sec_err);
    }
    /* Identity per entity: the store from the files the section names, authorization by certified role
     * (issue 23 item 3: a vehicle never administers another unless its certificate says so), and
     * revocation over the bus. */
    char id_err[UB_NODECFG_ERR_LEN + UB_IDENTFILE_ERR_LEN];
    if (ub_nodecfg_apply_identity(&app->cfg, &app->node, &app->ident, ub_app_unix_ms() / 1000u, app->revocations_path,
                                  sizeof app->revocations_path, id_err, sizeof id_err) != UB_OK) {
        ub_app_die(app, "%s", id_err);
    }
    if (app->cfg.identity.present) {
        app->ident_on = true;
        ub_revoke_options_t ropt = {.clock_s = ub_identfile_unix_s};
        if (ub_revoke_init(&app->revoke, &app->node, &app->ident, &ropt,
                           app->revocations_path[0] != '\0' ? ub_revfile_persist : NULL, app->revocations_path) != UB_OK)
            ub_app_die(app, "%s: the revocation service was refused", name);
        /* certificates spread too: this node's own are announced, new ones learned go to the certificates file */
        if (ub_nodecfg_certificates_path(&app->cfg, app->certificates_path, sizeof app->certificates_path) != UB_OK ||
            ub_revoke_spread_certificates(&app->revoke, app->certificates_path[0] != '\0' ? ub_certfile_persist : NULL,
                                          app->certificates_path, ub_app_mono_ms()) != UB_OK)
            ub_app_die(app, "%s: security.certificates: path too long", name);
    }
    start_origin(app);
    if (ub_ports_init(&app->ports, &app->node) != UB_OK) ub_app_die(app, "%s: ub_ports_init failed", name);
    app->start_ms = ub_app_mono_ms();
}

static const char *link_of(const char *port_name) {
    const char *colon = strchr(port_name, ':');
    return colon != NULL ? colon + 1 : port_name; /* "entity:link" or "link" */
}

/* Specs are parsed here, not with the command line, and through the ports set: a driver the program
 * registered in its setup (ub_ports_register(), e.g. a device adapter) is known by its word. */
void ub_app_open_ports(ub_app_t *app, uint64_t now_ms) {
    const char *name = app->prog->name;
    char err[UB_PORTS_ERR_LEN];
    char names[UB_APP_MAX_PORT_ARGS][UB_NODECFG_PORT_KEY_MAX + 1];
    ub_port_spec_t specs[UB_APP_MAX_PORT_ARGS];
    int ids[UB_APP_MAX_PORT_ARGS];
    for (int i = 0; i < app->n_ports; i++) {
        if (ub_ports_arg_parse(&app->ports, app->port_args[i], names[i], sizeof names[i], &specs[i], err, sizeof err) != UB_OK) {
            ub_app_die(app, "%s:argv[%d]: %s", name, app->port_argi[i], err);
        }
        ids[i] = ub_node_find_link(&app->node, link_of(names[i]));
        if (ids[i] < 0) {
            ub_app_die(app, "%s:argv[%d]: port '%s': node '%s' has no such link (its links are in the config's "
                       "'links' of its entities)", name, app->port_argi[i], names[i], app->node_opt);
        }
    }
    /* The configuration's, except the links a --port names: the command line replaces the file. */
    const ub_nodecfg_t *cfg = &app->cfg;
    for (unsigned c = 0; c < cfg->port_count; c++) {
        const ub_nodecfg_port_t *e = &cfg->ports[c];
        ub_port_spec_t spec;
        if (ub_ports_spec_from_config(&app->ports, e, cfg->source, &spec, err, sizeof err) != UB_OK) ub_app_die(app, "%s", err);
        if (spec.kind == UB_PORT_MEM) continue;
        int id = ub_node_find_link(&app->node, link_of(e->name));
        if (id < 0) continue; /* a link of an entity hosted by another node */
        bool overridden = false;
        for (int i = 0; i < app->n_ports; i++) overridden = overridden || ids[i] == id;
        if (overridden) continue;
        int rc = ub_ports_open(&app->ports, e->name, &spec, now_ms, err, sizeof err);
        if (rc == UB_ERR_NOTFOUND) continue; /* "entity:link" of an entity hosted elsewhere */
        if (rc != UB_OK) ub_app_die(app, "%s:%u: %s", cfg->source, (unsigned)e->line, err);
    }
    for (int i = 0; i < app->n_ports; i++) {
        if (ub_ports_open(&app->ports, names[i], &specs[i], now_ms, err, sizeof err) != UB_OK) {
            ub_app_die(app, "%s:argv[%d]: %s", name, app->port_argi[i], err);
        }
    }
}

void ub_app_close(ub_app_t *app) { ub_ports_close_all(&app->ports); }

int ub_app_main(ub_app_t *app, const ub_app_program_t *prog, int argc, char **argv) {
    ub_app_parse(app, prog, argc, argv);
    if (prog->setup != NULL) prog->setup(app);
    int status = ub_app_run(app);
    if (prog->close != NULL) prog->close(app);
    ub_app_close(app);
    return status;
}

/* ---- stdin ------------------------------------------------------------------------------------------- */

void ub_app_command(ub_app_t *app, char *line, uint64_t now_ms) {
    char *save = NULL;
    char *verb = strtok_r(line, " \t\r", &save);
    if (verb == NULL) return;
    if (strcmp(verb, "quit") == 0) {
        app->stop = true;
    } else if (strcmp(verb, "stats") == 0) {
        if (app->prog->stats != NULL) app->prog->stats(app, now_ms, false);
    } else if (app->prog->command == NULL || !app->prog->command(app, verb, &save, now_ms)) {
        char msg[256];
        snprintf(msg, sizeof msg, "unknown command '%.40s' (expected: %s)", verb,
                 app->prog->commands != NULL ? app->prog->commands : "stats, quit");
        ub_app_error(app, msg);
    }
}

/* Reads what stdin has and runs each whole line. Returns false at EOF (stop polling it). */
static bool read_stdin(ub_app_t *app, uint64_t now_ms) {
    char *buf = app->line;
    ssize_t n = read(STDIN_FILENO, buf + app->line_len, sizeof app->line - 1 - app->line_len);
    if (n == 0) return false;
    if (n < 0) return errno == EINTR || errno == EAGAIN;
    app->line_len += (size_t)n;
    for (;;) {
        char *nl = memchr(buf, '\n', app->line_len);
        if (nl == NULL) break;
        *nl = '\0';
        if (!app->discarding) ub_app_command(app, buf, now_ms);
        app->discarding = false;
        size_t used = (size_t)(nl - buf) + 1;
        memmove(buf, buf + used, app->line_len - used);
        app->line_len -= used;
    }
    if (app->line_len == sizeof app->line - 1) {
        /* A line longer than any command: drop it (counted) up to its newline. */
        app->stdin_dropped += app->line_len;
        app->line_len = 0;
        if (!app->discarding) {
            char msg[96];
            snprintf(msg, sizeof msg, "stdin: a command line longer than %zu bytes was ignored", sizeof app->line - 1);
            ub_app_error(app, msg);
        }
        app->discarding = true;
    }
    return true;
}

/* ---- the loop ---------------------------------------------------------------------------------------- */

static uint64_t min_u64(uint64_t a, uint64_t b) { return a < b ? a : b; }

int ub_app_run(ub_app_t *app) {
    const ub_app_program_t *prog = app->prog;
    uint64_t now = ub_app_mono_ms();
    uint64_t next_stats = app->stats_ms > 0 ? now + app->stats_ms : UINT64_MAX;
    uint64_t end = app->has_duration ? app->start_ms + app->duration_ms : UINT64_MAX;
    struct pollfd fds[UB_APP_MAX_FDS];
    while (!app->stop && !g_signalled && now < end) {
        int n = ub_ports_pollfds(&app->ports, fds, 2 * UB_PORTS_MAX);
        if (n < 0) n = 0; /* cannot happen: 2 * UB_PORTS_MAX always suffices */
        int n_port_fds = n;
        if (prog->pollfds != NULL) n += prog->pollfds(app, fds + n, UB_APP_MAX_FDS - 1 - n);
        int stdin_slot = -1;
        if (app->stdin_open) {
            stdin_slot = n;
            fds[n++] = (struct pollfd){.fd = STDIN_FILENO, .events = POLLIN};
        }
        /* Sleep until the next due time: the node's (its services' timers), the program's, a port's, the
         * stats', the end's. Input wakes the loop earlier; the tick then runs whatever it brought. */
        uint64_t due = min_u64(min_u64(next_stats, end), ub_node_next_due(&app->node, now));
        if (prog->next_due != NULL) due = min_u64(due, prog->next_due(app, now));
        else if (prog->before_tick != NULL || prog->after_tick != NULL) due = min_u64(due, now + UB_APP_MAX_WAIT_MS);
        int cap = due <= now ? 0 : (int)min_u64(due - now, INT32_MAX);
        if (poll(fds, (nfds_t)n, ub_ports_poll_timeout(&app->ports, now, cap)) < 0 && errno != EINTR) {
            char msg[128];
            snprintf(msg, sizeof msg, "poll: %s", strerror(errno));
            ub_app_error(app, msg);
        }
        now = ub_app_mono_ms();
        app->wakeups++;
        if (prog->wake != NULL) prog->wake(app, now);
        if (stdin_slot >= 0 && (fds[stdin_slot].revents & (POLLIN | POLLHUP | POLLERR)) != 0) {
            app->stdin_open = read_stdin(app, now);
        }
        /* Only the ports poll() reported (or that are due): a timer's wake-up reads no socket. */
        (void)ub_ports_service_ready(&app->ports, fds, n_port_fds, now);
        char notice[512];
        while (ub_ports_notice(&app->ports, notice, sizeof notice) > 0) ub_app_warning(app, notice);
        if (prog->before_tick != NULL) prog->before_tick(app, now);
        ub_node_tick(&app->node, now);
        if (prog->after_tick != NULL) prog->after_tick(app, now);
        /* What the tick queued on batching ports (udp batch=1) leaves in this turn, not after one more
         * poll() woken by POLLOUT. */
        (void)ub_ports_flush(&app->ports);
        if (now >= next_stats) {
            if (prog->stats != NULL) prog->stats(app, now, false);
            next_stats += app->stats_ms;
            if (next_stats <= now) next_stats = now + app->stats_ms;
        }
    }
    if (prog->stats != NULL) prog->stats(app, ub_app_mono_ms(), true);
    return 0;
}
