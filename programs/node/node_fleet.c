/* The fleet features of uavbus_node (node_fleet.h). State is static, as in uavbus_node.c: one node per process. */
#include "node_fleet.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "flightsw.h"
#include "ub/ub_ident.h"
#include "ub/ub_identfile.h"
#include "ub/ub_impair.h"
#include "ub/ub_link.h"
#include "ub/ub_member.h"
#include "ub/ub_motion.h"
#include "ub/ub_route.h"

#define MAX_FLOWS 64
#define FLOW_GAPS 8
#define SEP " \t\r"

const char fleet_usage[] =
    "fleet options: [--route on|hello=MS,update=MS,dead=N,parallel=all|best,learn=0|1,learn_expiry=MS,max_dests=N,certified=0|1,gap=MS]\n"
    "               [--produce ENTITY] [--motion orbit:...|waypoints:...|static:...] [--epoch-ms MONO_MS]\n"
    "               [--flows-ms MS] [--flow-gap-ms MS]\n"
    "fleet commands: entity add|remove NAME | link add ENTITY INDEX NAME [SPEC] | link remove NAME |\n"
    "                link impair NAME SPEC|off |\n"
    "                mask ENTITY DEST MASK | member TARGET add_entity|remove_entity SUBJECT |\n"
    "                member TARGET set_mask SUBJECT MASK | member TARGET add_link INDEX NAME [SPEC] |\n"
    "                member TARGET remove_link NAME | announce SUBJECT TARGET... | routes | flows\n";

typedef struct flow {
    bool in_use;
    int entity;
    uint32_t instance;
    uint8_t source[UB_ENTITY_ID_LEN];
    uint64_t count, first_ms, last_ms, gaps;
    unsigned hops;
    uint64_t gap_from[FLOW_GAPS], gap_to[FLOW_GAPS]; /* the last FLOW_GAPS outages, oldest first */
} flow_t;

static struct {
    const char *route; /* --route text, NULL = manual masks only */
    const char *produce;
    const char *motion;
    uint64_t epoch_ms;
    bool has_epoch;
    uint64_t flows_ms;
    uint64_t flow_gap_ms;
} g_opt = {.flow_gap_ms = 300};

static ub_app_t *g_app; /* the program shell: its JSON-lines output, its node and ports */
static ub_node_t *g_node_p;
static ub_ports_t *g_ports_p;
static ub_route_t g_route;
static bool g_route_on;
static bool g_route_certified; /* --route certified=1: only destinations the identity store certifies */
static ub_member_t g_member;
static bool g_member_on;
static uint8_t g_reported[UB_MAX_MEMBER_REQUESTS];
static flow_t g_flows[MAX_FLOWS];
static uint64_t g_flows_dropped; /* deliveries of flows beyond MAX_FLOWS */
static uint64_t g_next_flows_ms;
static bool g_flows_changed;      /* a delivery since the last periodic "flows" event: the next one has news */

/* ---- options ------------------------------------------------------------------------------------------ */

static uint64_t number(const char *s, int argi, const char *what) {
    char text[64];
    snprintf(text, sizeof text, "a whole number (%s)", what);
    return ub_app_parse_uint(g_app, s, argi, UINT64_MAX, text);
}

bool fleet_option(ub_app_t *app, const char *opt, const char *val, int argi) {
    g_app = app;
    if (strcmp(opt, "--route") == 0) g_opt.route = val;
    else if (strcmp(opt, "--produce") == 0) g_opt.produce = val;
    else if (strcmp(opt, "--motion") == 0) g_opt.motion = val;
    else if (strcmp(opt, "--epoch-ms") == 0) {
        g_opt.epoch_ms = number(val, argi, "CLOCK_MONOTONIC milliseconds");
        g_opt.has_epoch = true;
    } else if (strcmp(opt, "--flows-ms") == 0) g_opt.flows_ms = number(val, argi, "milliseconds");
    else if (strcmp(opt, "--flow-gap-ms") == 0) g_opt.flow_gap_ms = number(val, argi, "milliseconds");
    else return false;
    return true;
}

const char *fleet_producer(const char *name, const char *dflt) {
    if (g_opt.produce != NULL &&
        (strcmp(name, "gpsOut") == 0 || strcmp(name, "imuOut") == 0 || strcmp(name, "navFilterState") == 0))
        return g_opt.produce;
    return dflt;
}

uint64_t fleet_epoch_ms(uint64_t start_ms) { return g_opt.has_epoch ? g_opt.epoch_ms : start_ms; }

/* "on" or KEY=VALUE,...: the routing options. */
static void parse_route(const char *text, ub_route_options_t *ro) {
    memset(ro, 0, sizeof *ro);
    if (strcmp(text, "on") == 0) return;
    char buf[256];
    if (strlen(text) >= sizeof buf) ub_app_die(g_app, "uavbus_node: --route '%.40s...': too long", text);
    strcpy(buf, text);
    char *save = NULL;
    for (char *kv = strtok_r(buf, ",", &save); kv != NULL; kv = strtok_r(NULL, ",", &save)) {
        char *eq = strchr(kv, '=');
        if (eq == NULL) ub_app_die(g_app, "uavbus_node: --route '%s': expected KEY=VALUE (hello, update, dead, parallel, learn, learn_expiry, max_dests, certified, gap)", kv);
        *eq = '\0';
        const char *v = eq + 1;
        char *end = NULL;
        unsigned long n = strtoul(v, &end, 10);
        bool num = v[0] != '\0' && v[0] != '-' && *end == '\0';
        if (strcmp(kv, "parallel") == 0) {
            if (strcmp(v, "all") == 0) ro->parallel = UB_ROUTE_PARALLEL_ALL;
            else if (strcmp(v, "best") == 0) ro->parallel = UB_ROUTE_PARALLEL_BEST;
            else ub_app_die(g_app, "uavbus_node: --route parallel=%s: expected all or best", v);
        } else if (!num) {
            ub_app_die(g_app, "uavbus_node: --route %s=%s: expected a whole number", kv, v);
        } else if (strcmp(kv, "hello") == 0) {
            ro->hello_ms = (uint32_t)n;
        } else if (strcmp(kv, "update") == 0) {
            ro->update_ms = (uint32_t)n;
        } else if (strcmp(kv, "gap") == 0) {
            ro->trigger_gap_ms = (uint32_t)n;
        } else if (strcmp(kv, "dead") == 0 && n <= 16) {
            ro->dead_misses = (uint8_t)n;
        } else if (strcmp(kv, "learn") == 0 && n <= 1) {
            ro->no_learn = n == 0;
        } else if (strcmp(kv, "learn_expiry") == 0 && (uint64_t)n <= UINT32_MAX) {
            ro->learn_expiry_ms = (uint32_t)n;
        } else if (strcmp(kv, "max_dests") == 0 && n >= 1 && n <= UB_MAX_ENTITIES) {
            ro->max_dests = (uint16_t)n;
        } else if (strcmp(kv, "certified") == 0 && n <= 1) {
            g_route_certified = n == 1;
        } else {
            ub_app_die(g_app, "uavbus_node: --route %s=%s: unknown key or value out of range (hello, update, gap: ms; dead: 1..16; "
                "learn: 0|1; learn_expiry: ms; max_dests: 1..%d; certified: 0|1; parallel: all|best)",
                kv, v, UB_MAX_ENTITIES);
        }
    }
}

void fleet_stats(ub_app_t *app) {
    if (!g_route_on) return;
    const ub_route_counters_t *c = ub_route_counters(&g_route);
    ub_app_out(app, ",\"routing\":{\"learned\":%" PRIu64 ",\"learn_full\":%" PRIu64 ",\"learn_refused\":%" PRIu64
        ",\"learn_expired\":%" PRIu64 ",\"neighbour_limit\":%" PRIu64 "}", c->learned, c->learn_full, c->learn_refused,
        c->learn_expired, c->neighbour_limit);
}

/* ---- membership ------------------------------------------------------------------------------------- */

static const char *reason_name(uint8_t r) {
    static const char *const names[] = {"none", "unknown_content", "layout", "unbound", "table_full",
                                        "invalid", "not_authorized", "limit", "unsupported"};
    return r < sizeof names / sizeof names[0] ? names[r] : "?";
}

static int first_local(void) {
    for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++)
        if (g_node_p->locals[s].in_use) return g_node_p->locals[s].entity;
    return -1;
}

static int local_named(const char *name) {
    uint8_t id[UB_ENTITY_ID_LEN];
    if (name == NULL || ub_entity_id(name, id) != UB_OK) return -1;
    int e = ub_node_find_entity(g_node_p, id);
    return e >= 0 && g_node_p->entities[e].local >= 0 ? e : -1;
}

/* Serves ADD_LINK / REMOVE_LINK (ours from stdin, or an administrator's over the bus) with the ports. */
static int link_handler(void *user, ub_node_t *node, int entity, ub_member_op_t op, unsigned index, const char *name,
                        const char *spec, uint64_t now_ms) {
    (void)user;
    int id = ub_node_find_link(node, name);
    if (op == UB_MEMBER_ADD_LINK) {
        if (id >= 0) return UB_ERR_EXISTS;
        id = ub_node_add_link(node, entity, index, name);
        if (id < 0) return id;
        char err[UB_PORTS_ERR_LEN];
        if (spec[0] != '\0' && ub_ports_open_text(g_ports_p, name, spec, now_ms, err, sizeof err) != UB_OK) {
            ub_app_error(g_app, err);
            if (ub_node_remove_link(node, id) != UB_OK) ub_app_error(g_app, "link add: could not take the new link back");
            return UB_ERR_INVAL;
        }
        return UB_OK;
    }
    if (id < 0) return UB_ERR_NOTFOUND;
    if (ub_node_link(node, id)->owner != node->entities[entity].local) return UB_ERR_INVAL; /* another entity's */
    if (ub_ports_find(g_ports_p, name) != NULL && ub_ports_close(g_ports_p, name) != UB_OK) return UB_ERR_INVAL;
    if (ub_node_link(node, id)->ops != NULL && ub_node_link_detach(node, id) != UB_OK) return UB_ERR_INVAL;
    return ub_node_remove_link(node, id);
}

static void answer(const char *command, uint8_t reason, bool changed) {
    ub_app_out(g_app, "{\"event\":\"membership\",\"command\":");
    ub_app_str(g_app, command, SIZE_MAX);
    ub_app_out(g_app, ",\"ok\":%s,\"changed\":%s", reason == 0 ? "true" : "false", changed ? "true" : "false");
    if (reason != 0) ub_app_out(g_app, ",\"reason\":\"%s\"", reason_name(reason));
    ub_app_out(g_app, ",\"entities\":%" PRIu64 ",\"links\":%" PRIu64 "}", ub_node_counters(g_node_p)->entities_added -
                                                                 ub_node_counters(g_node_p)->entities_removed,
        ub_node_counters(g_node_p)->links_added - ub_node_counters(g_node_p)->links_removed);
    ub_app_flush(g_app);
}

static bool set_id(const char *name, uint8_t id[UB_ENTITY_ID_LEN], const char *what) {
    char msg[320];
    if (name == NULL || ub_entity_id(name, id) != UB_OK) {
        snprintf(msg, sizeof msg, "%s: expected an entity name of 1 to 12 characters", what);
        ub_app_error(g_app, msg);
        return false;
    }
    return true;
}

static bool parse_mask_arg(const char *text, uint8_t *mask, const char *what) {
    if (text != NULL && ub_link_mask_parse(text, mask) == UB_OK) return true;
    char msg[320];
    snprintf(msg, sizeof msg, "%s: expected a mask in the paper's notation, e.g. 0x00000011 (0x0 unpins)", what);
    ub_app_error(g_app, msg);
    return false;
}

/* link impair NAME SPEC: one port's own impairment (ub_ports_set_link_impairment()); "off" removes it. */
static void link_impair(char **save) {
    const char *name = strtok_r(NULL, SEP, save), *spec = strtok_r(NULL, SEP, save);
    char err[200], msg[320];
    ub_impair_params_t params;
    uint64_t seed = 1;
    memset(&params, 0, sizeof params);
    if (name == NULL || spec == NULL) {
        ub_app_error(g_app, "link impair: expected 'link impair NAME SPEC' (SPEC as --impair, or off)");
        return;
    }
    if (strcmp(spec, "off") != 0 && ub_impair_parse(spec, &params, &seed, err, sizeof err) != UB_OK) {
        snprintf(msg, sizeof msg, "link impair: %s", err);
        ub_app_error(g_app, msg);
        return;
    }
    int rc = ub_ports_set_link_impairment(g_ports_p, name, &params, seed);
    if (rc != UB_OK) {
        snprintf(msg, sizeof msg, "link impair: '%s' has no open port", name);
        ub_app_error(g_app, msg);
        return;
    }
    ub_app_out(g_app, "{\"event\":\"impaired\",\"link\":");
    ub_app_str(g_app, name, SIZE_MAX);
    ub_app_out(g_app, ",\"spec\":");
    ub_app_str(g_app, spec, SIZE_MAX);
    ub_app_out(g_app, "}");
    ub_app_flush(g_app);
}

/* entity add|remove NAME; link add ENTITY INDEX NAME [SPEC] | link remove NAME; mask ENTITY DEST MASK */
static void local_change(const char *verb, char **save, uint64_t now_ms) {
    ub_member_spec_t s;
    memset(&s, 0, sizeof s);
    char command[128];
    const char *sub = strcmp(verb, "mask") == 0 ? "" : strtok_r(NULL, SEP, save);
    if (sub == NULL) sub = "";
    snprintf(command, sizeof command, "%s%s%s", verb, sub[0] ? " " : "", sub);
    int entity = first_local();
    if (strcmp(verb, "link") == 0 && strcmp(sub, "impair") == 0) {
        link_impair(save);
        return;
    }
    if (strcmp(verb, "entity") == 0 && (strcmp(sub, "add") == 0 || strcmp(sub, "remove") == 0)) {
        s.op = sub[0] == 'a' ? UB_MEMBER_ADD_ENTITY : UB_MEMBER_REMOVE_ENTITY;
        if (!set_id(strtok_r(NULL, SEP, save), s.subject, command)) return;
    } else if (strcmp(verb, "link") == 0 && strcmp(sub, "add") == 0) {
        const char *ent = strtok_r(NULL, SEP, save), *idx = strtok_r(NULL, SEP, save);
        const char *name = strtok_r(NULL, SEP, save), *spec = strtok_r(NULL, SEP, save);
        entity = local_named(ent);
        char *end = NULL;
        unsigned long index = idx != NULL ? strtoul(idx, &end, 10) : 99;
        if (entity < 0 || name == NULL || end == NULL || *end != '\0' || index >= UB_MAX_LINKS_PER_ENTITY ||
            strlen(name) >= UB_LINK_NAME_LEN || (spec != NULL && strlen(spec) >= UB_MEMBER_SPEC_LEN)) {
            ub_app_error(g_app, "link add: expected 'link add ENTITY INDEX NAME [SPEC]' with a hosted ENTITY and INDEX 0..7, "
                        "e.g. link add uav1 2 radio2 udp:bind=127.0.0.1:0,peer=127.0.0.1:5001");
            return;
        }
        s.op = UB_MEMBER_ADD_LINK;
        s.link_index = (uint8_t)index;
        strcpy(s.link_name, name);
        if (spec != NULL) strcpy(s.port_spec, spec);
    } else if (strcmp(verb, "link") == 0 && strcmp(sub, "remove") == 0) {
        const char *name = strtok_r(NULL, SEP, save);
        int id = name != NULL ? ub_node_find_link(g_node_p, name) : -1;
        if (name == NULL || strlen(name) >= UB_LINK_NAME_LEN) {
            ub_app_error(g_app, "link remove: expected 'link remove NAME'");
            return;
        }
        if (id >= 0) entity = g_node_p->locals[ub_node_link(g_node_p, id)->owner].entity;
        s.op = UB_MEMBER_REMOVE_LINK;
        strcpy(s.link_name, name);
    } else if (strcmp(verb, "mask") == 0) {
        const char *ent = strtok_r(NULL, SEP, save), *dest = strtok_r(NULL, SEP, save);
        const char *mask = strtok_r(NULL, SEP, save);
        entity = local_named(ent);
        if (entity < 0) {
            ub_app_error(g_app, "mask: expected 'mask ENTITY DEST MASK' with a hosted ENTITY, e.g. mask uav1 gcs1 0x00000011");
            return;
        }
        if (!set_id(dest, s.subject, "mask") || !parse_mask_arg(mask, &s.mask, "mask")) return;
        s.op = UB_MEMBER_SET_MASK;
    } else {
        char msg[320];
        snprintf(msg, sizeof msg, "%s: expected '%s'", command,
                 strcmp(verb, "entity") == 0 ? "entity add|remove NAME" : "link add ENTITY INDEX NAME [SPEC] | link remove NAME");
        ub_app_error(g_app, msg);
        return;
    }
    bool changed = false;
    uint8_t reason = ub_member_apply(g_node_p, entity, &s, now_ms, &changed);
    answer(command, reason, changed);
}

static void report_member(int row, const ub_member_info_t *info) {
    ub_app_out(g_app, "{\"event\":\"member\",\"row\":%d,\"op\":\"%s\",\"target\":", row, ub_member_op_name((ub_member_op_t)info->spec.op));
    ub_app_entity(g_app, info->spec.target);
    if (info->spec.op <= UB_MEMBER_SET_MASK) {
        ub_app_out(g_app, ",\"subject\":");
        ub_app_entity(g_app, info->spec.subject);
    } else {
        ub_app_out(g_app, ",\"link\":");
        ub_app_str(g_app, info->spec.link_name, sizeof info->spec.link_name);
    }
    ub_app_out(g_app, ",\"status\":\"%s\",\"attempts\":%" PRIu32, ub_member_status_name((ub_member_status_t)info->status),
        info->attempts);
    if (info->status == UB_MEMBER_DONE) ub_app_out(g_app, ",\"changed\":%s", info->changed ? "true" : "false");
    if (info->status == UB_MEMBER_FAILED) ub_app_out(g_app, ",\"reason\":\"%s\"", info->nack_reason ? reason_name(info->nack_reason) : "no_answer");
    ub_app_out(g_app, "}");
    ub_app_flush(g_app);
}

static void submit(const ub_member_spec_t *s, uint64_t now_ms) {
    int row = ub_member_request(&g_member, s, now_ms);
    if (row < 0) {
        ub_app_error(g_app, row == UB_ERR_FULL ? "member: too many requests pending (wait for their answers)"
                                       : "member: invalid request");
        return;
    }
    ub_member_info_t info;
    if (ub_member_status(&g_member, row, &info) == UB_OK) report_member(row, &info);
    g_reported[row] = UB_MEMBER_PENDING;
}

/* member TARGET OP ARGS...; announce SUBJECT TARGET... */
static void remote_change(const char *verb, char **save, uint64_t now_ms) {
    ub_member_spec_t s;
    memset(&s, 0, sizeof s);
    if (strcmp(verb, "announce") == 0) {
        const char *subject = strtok_r(NULL, SEP, save);
        if (!set_id(subject, s.subject, "announce")) return;
        s.op = UB_MEMBER_ADD_ENTITY;
        int n = 0;
        for (const char *t = strtok_r(NULL, SEP, save); t != NULL; t = strtok_r(NULL, SEP, save), n++) {
            if (!set_id(t, s.target, "announce")) return;
            submit(&s, now_ms);
        }
        if (n == 0) ub_app_error(g_app, "announce: expected 'announce SUBJECT TARGET...'");
        return;
    }
    const char *target = strtok_r(NULL, SEP, save), *op = strtok_r(NULL, SEP, save);
    if (!set_id(target, s.target, "member") || op == NULL) {
        if (target != NULL) ub_app_error(g_app, "member: expected 'member TARGET OP ...' (see --help)");
        return;
    }
    if (strcmp(op, "add_entity") == 0 || strcmp(op, "remove_entity") == 0 || strcmp(op, "set_mask") == 0) {
        s.op = op[0] == 'a' ? UB_MEMBER_ADD_ENTITY : op[0] == 'r' ? UB_MEMBER_REMOVE_ENTITY : UB_MEMBER_SET_MASK;
        if (!set_id(strtok_r(NULL, SEP, save), s.subject, "member")) return;
        if (s.op == UB_MEMBER_SET_MASK && !parse_mask_arg(strtok_r(NULL, SEP, save), &s.mask, "member set_mask")) return;
    } else if (strcmp(op, "add_link") == 0 || strcmp(op, "remove_link") == 0) {
        s.op = op[0] == 'a' ? UB_MEMBER_ADD_LINK : UB_MEMBER_REMOVE_LINK;
        if (s.op == UB_MEMBER_ADD_LINK) {
            const char *idx = strtok_r(NULL, SEP, save);
            s.link_index = (uint8_t)(idx != NULL ? atoi(idx) : 99);
        }
        const char *name = strtok_r(NULL, SEP, save), *spec = strtok_r(NULL, SEP, save);
        if (name == NULL || strlen(name) >= UB_LINK_NAME_LEN || (spec != NULL && strlen(spec) >= UB_MEMBER_SPEC_LEN)) {
            ub_app_error(g_app, "member: expected 'member TARGET add_link INDEX NAME [SPEC]' or 'member TARGET remove_link NAME'");
            return;
        }
        strcpy(s.link_name, name);
        if (spec != NULL) strcpy(s.port_spec, spec);
    } else {
        ub_app_error(g_app, "member: OP is add_entity, remove_entity, set_mask, add_link or remove_link");
        return;
    }
    submit(&s, now_ms);
}

/* ---- routes and flows events --------------------------------------------------------------------------- */

static void out_mask(uint8_t mask) {
    char text[11];
    ub_link_mask_format(mask, text);
    ub_app_out(g_app, "\"%s\"", text);
}

static void event_routes(uint64_t now_ms) {
    ub_app_out(g_app, "{\"event\":\"routes\",\"t_ms\":%" PRIu64 ",\"routing\":%s,\"entities\":{", now_ms, g_route_on ? "true" : "false");
    bool first = true;
    for (int s = 0; s < UB_MAX_LOCAL_ENTITIES; s++) {
        const ub_local_entity_t *le = &g_node_p->locals[s];
        if (!le->in_use) continue;
        ub_app_out(g_app, "%s", first ? "" : ",");
        first = false;
        ub_app_entity(g_app, ub_node_entity_id(g_node_p, le->entity));
        ub_app_out(g_app, ":{");
        bool dfirst = true;
        for (int d = 0; d < UB_MAX_ENTITIES; d++) {
            const uint8_t *id = ub_node_entity_id(g_node_p, d);
            if (id == NULL || d == le->entity) continue;
            uint8_t mask = 0;
            if (ub_node_get_mask(g_node_p, le->entity, d, &mask) != UB_OK) continue;
            ub_app_out(g_app, "%s", dfirst ? "" : ",");
            dfirst = false;
            ub_app_entity(g_app, id);
            ub_app_out(g_app, ":{\"mask\":");
            out_mask(mask);
            ub_app_out(g_app, ",\"pinned\":%s", ub_node_mask_pinned(g_node_p, le->entity, d) ? "true" : "false");
            ub_route_info_t ri;
            if (g_route_on && ub_route_get(&g_route, le->entity, d, &ri) == UB_OK) {
                ub_app_out(g_app, ",\"local\":%s,\"reachable\":%s,\"metric\":%u,\"seqno\":%u,\"learned\":%s,\"starving\":%s",
                    ri.local ? "true" : "false", ri.reachable ? "true" : "false", ri.metric, ri.seqno,
                    ri.learned ? "true" : "false", ri.starving ? "true" : "false");
                if (ri.reachable) {
                    ub_app_out(g_app, ",\"via\":");
                    ub_app_entity(g_app, ri.next_hop);
                    ub_app_out(g_app, ",\"link\":");
                    ub_app_str(g_app, ub_node_link(g_node_p, ri.link_id)->name, UB_LINK_NAME_LEN);
                }
            }
            ub_app_out(g_app, "}");
        }
        ub_app_out(g_app, "}");
    }
    ub_app_out(g_app, "},\"links\":{");
    first = true;
    for (int id = 0; id < UB_MAX_NODE_LINKS; id++) {
        const ub_link_t *l = ub_node_link(g_node_p, id);
        ub_route_link_info_t li;
        if (l == NULL || !g_route_on || ub_route_link_info(&g_route, id, &li) != UB_OK) continue;
        ub_app_out(g_app, "%s", first ? "" : ",");
        first = false;
        ub_app_str(g_app, l->name, UB_LINK_NAME_LEN);
        ub_app_out(g_app, ":{\"neighbour\":");
        if (li.neighbour) ub_app_entity(g_app, li.neighbour_id);
        else ub_app_out(g_app, "null");
        ub_app_out(g_app, ",\"cost\":%u,\"rxcost\":%u,\"txcost\":%u,\"frames_out\":%" PRIu64 ",\"hellos_out\":%" PRIu64
            ",\"triggered_out\":%" PRIu64 ",\"bytes_out\":%" PRIu64 ",\"frames_in\":%" PRIu64 ",\"bad_in\":%" PRIu64
            ",\"fast_hellos_out\":%" PRIu64 "}",
            li.cost, li.rxcost, li.txcost, li.stats.frames_out, li.stats.hellos_out, li.stats.triggered_out,
            li.stats.bytes_out, li.stats.frames_in, li.stats.bad_in, li.stats.fast_hellos_out);
    }
    ub_app_out(g_app, "}");
    if (g_route_on) {
        const ub_route_counters_t *c = ub_route_counters(&g_route);
        ub_app_out(g_app, ",\"counters\":{\"route_changes\":%" PRIu64 ",\"routes_found\":%" PRIu64 ",\"routes_lost\":%" PRIu64
            ",\"unfeasible\":%" PRIu64 ",\"expired\":%" PRIu64 ",\"starvation_requests\":%" PRIu64
            ",\"seqno_bumps\":%" PRIu64 ",\"learned\":%" PRIu64 ",\"learn_full\":%" PRIu64 ",\"learn_expired\":%" PRIu64
            ",\"pinned_skips\":%" PRIu64 ",\"neighbour_limit\":%" PRIu64 ",\"dest_refused\":%" PRIu64
            ",\"link_evidence_down\":%" PRIu64 ",\"link_doubts\":%" PRIu64
            ",\"lost_link_down\":%" PRIu64 ",\"lost_entry_gone\":%" PRIu64 ",\"lost_retracted\":%" PRIu64
            ",\"lost_unfeasible\":%" PRIu64 ",\"owed_route_change\":%" PRIu64 ",\"owed_seqno_asked\":%" PRIu64
            ",\"owed_request_answer\":%" PRIu64 ",\"seqno_deferred\":%" PRIu64 ",\"requests_suppressed\":%" PRIu64
            ",\"unfeasible_held\":%" PRIu64 "}",
            c->route_changes, c->routes_found, c->routes_lost, c->unfeasible, c->expired, c->starvation_requests,
            c->seqno_bumps, c->learned, c->learn_full, c->learn_expired, c->pinned_skips, c->neighbour_limit,
            c->dest_refused, c->link_evidence_down, c->link_doubts, c->lost_link_down, c->lost_entry_gone,
            c->lost_retracted, c->lost_unfeasible, c->owed_route_change, c->owed_seqno_asked, c->owed_request_answer,
            c->seqno_deferred, c->requests_suppressed, c->unfeasible_held);
    }
    const ub_node_counters_t *n = ub_node_counters(g_node_p);
    ub_app_out(g_app, ",\"membership\":{\"entities_added\":%" PRIu64 ",\"entities_removed\":%" PRIu64 ",\"links_added\":%" PRIu64
        ",\"links_removed\":%" PRIu64 ",\"rows_stopped\":%" PRIu64 ",\"admin_rows_stopped\":%" PRIu64
        ",\"dedup_cleared\":%" PRIu64 ",\"applied\":%" PRIu64 ",\"refused\":%" PRIu64 "}}",
        n->entities_added, n->entities_removed, n->links_added, n->links_removed, n->rows_stopped, n->admin_rows_stopped,
        n->dedup_cleared, n->membership_applied, n->membership_refused);
    ub_app_flush(g_app);
}

static void event_flows(uint64_t now_ms) {
    ub_app_out(g_app, "{\"event\":\"flows\",\"t_ms\":%" PRIu64 ",\"gap_ms\":%" PRIu64 ",\"dropped\":%" PRIu64 ",\"flows\":[", now_ms,
        g_opt.flow_gap_ms, g_flows_dropped);
    bool first = true;
    for (int i = 0; i < MAX_FLOWS; i++) {
        const flow_t *f = &g_flows[i];
        if (!f->in_use) continue;
        ub_app_out(g_app, "%s{\"entity\":", first ? "" : ",");
        first = false;
        ub_app_entity(g_app, ub_node_entity_id(g_node_p, f->entity));
        ub_app_out(g_app, ",\"content\":");
        ub_app_str(g_app, flightsw_catalogue.instances[f->instance].name, SIZE_MAX);
        ub_app_out(g_app, ",\"source\":");
        ub_app_entity(g_app, f->source);
        ub_app_out(g_app, ",\"count\":%" PRIu64 ",\"hops\":%u,\"first_ms\":%" PRIu64 ",\"last_ms\":%" PRIu64 ",\"gaps\":%" PRIu64
            ",\"recent_gaps\":[",
            f->count, f->hops, f->first_ms, f->last_ms, f->gaps);
        uint64_t n = f->gaps < FLOW_GAPS ? f->gaps : FLOW_GAPS;
        for (uint64_t k = 0; k < n; k++) {
            uint64_t slot = (f->gaps - n + k) % FLOW_GAPS;
            ub_app_out(g_app, "%s[%" PRIu64 ",%" PRIu64 "]", k ? "," : "", f->gap_from[slot], f->gap_to[slot]);
        }
        ub_app_out(g_app, "]}");
    }
    ub_app_out(g_app, "]}");
    ub_app_flush(g_app);
}

void fleet_on_deliver(int entity, uint32_t instance, const ub_frame_header_t *h, uint64_t now_ms) {
    flow_t *f = NULL, *free_slot = NULL;
    g_flows_changed = true;
    for (int i = 0; i < MAX_FLOWS && f == NULL; i++) {
        flow_t *c = &g_flows[i];
        if (!c->in_use) {
            if (free_slot == NULL) free_slot = c;
        } else if (c->entity == entity && c->instance == instance && memcmp(c->source, h->src_id, UB_ENTITY_ID_LEN) == 0) {
            f = c;
        }
    }
    if (f == NULL) {
        if (free_slot == NULL) {
            g_flows_dropped++;
            return;
        }
        f = free_slot;
        memset(f, 0, sizeof *f);
        f->in_use = true;
        f->entity = entity;
        f->instance = instance;
        memcpy(f->source, h->src_id, UB_ENTITY_ID_LEN);
        f->first_ms = now_ms;
    } else if (now_ms - f->last_ms > g_opt.flow_gap_ms) {
        uint64_t slot = f->gaps % FLOW_GAPS;
        f->gap_from[slot] = f->last_ms;
        f->gap_to[slot] = now_ms;
        f->gaps++;
    }
    f->count++;
    f->last_ms = now_ms;
    /* Links crossed: originators write UB_DEFAULT_HOP_LIMIT (uavbus_node and Python use the default). */
    f->hops = h->hop_limit <= UB_DEFAULT_HOP_LIMIT ? (unsigned)(UB_DEFAULT_HOP_LIMIT - h->hop_limit + 1) : 0;
}

/* ---- hooks --------------------------------------------------------------------------------------------- */

void fleet_setup(ub_app_t *app, node_motion_t *motion, uint64_t now_ms) {
    ub_node_t *node = &app->node;
    g_app = app;
    g_node_p = node;
    g_ports_p = &app->ports;
    char err[200];
    if (g_opt.motion != NULL && ub_motion_parse(g_opt.motion, &motion->path, err, sizeof err) != UB_OK)
        ub_app_die(g_app, "uavbus_node: --motion: %s", err);
    if (g_opt.produce != NULL && local_named(g_opt.produce) < 0)
        ub_app_die(g_app, "uavbus_node: --produce %s: not an entity hosted by this node", g_opt.produce);
    if (g_opt.route != NULL) {
        ub_route_options_t ro;
        parse_route(g_opt.route, &ro);
        /* The program sleeps until its next due time: hellos due within a few ms share the wake-up (issue 28
         * item 5; docs/routing.md "Timer coalescing"). */
        ro.coalesce_ms = UB_ROUTE_COALESCE_AUTO;
        if (g_route_certified) {
            if (!app->ident_on)
                ub_app_die(g_app, "uavbus_node: --route certified=1 needs identities: name an authority in the configuration's "
                    "\"security\" section (uavbus keys fleet), or drop certified=1");
            ro.accept_dest = ub_identfile_route_certified; /* only entities the store certifies */
            ro.accept_user = &app->ident;
        }
        if (ub_route_attach(&g_route, node, &ro, now_ms) != UB_OK)
            ub_app_die(g_app, "uavbus_node: --route %s: out of range (hello 10..65535 ms, update >= hello)", g_opt.route);
        g_route_on = true;
    }
    int e = first_local();
    if (e >= 0 && ub_member_init(&g_member, node, e, NULL) == UB_OK) {
        ub_member_set_link_handler(&g_member, link_handler, NULL);
        g_member_on = true;
    }
    g_next_flows_ms = g_opt.flows_ms > 0 ? now_ms + g_opt.flows_ms : UINT64_MAX;
}

bool fleet_command(const char *verb, char **save, uint64_t now_ms) {
    if (strcmp(verb, "entity") == 0 || strcmp(verb, "link") == 0 || strcmp(verb, "mask") == 0) {
        local_change(verb, save, now_ms);
    } else if (strcmp(verb, "member") == 0 || strcmp(verb, "announce") == 0) {
        if (g_member_on) remote_change(verb, save, now_ms);
        else ub_app_error(g_app, "member: this node hosts no entity to send requests from");
    } else if (strcmp(verb, "routes") == 0) {
        event_routes(now_ms);
    } else if (strcmp(verb, "flows") == 0) {
        event_flows(now_ms);
    } else {
        return false;
    }
    return true;
}

/* The periodic "flows" event is due only when a delivery changed something since the last one: a node nothing
 * is delivered to (a fleet's relays and most vehicles) neither wakes for it nor writes the same line 10 times a
 * second (issue 28 item 5). Its supervisor loses nothing: an unchanged event adds nothing to its counts. */
uint64_t fleet_next_due(uint64_t now_ms) {
    (void)now_ms;
    return g_flows_changed ? g_next_flows_ms : UINT64_MAX;
}

void fleet_poll(uint64_t now_ms) {
    for (int r = 0; g_member_on && r < UB_MAX_MEMBER_REQUESTS; r++) {
        ub_member_info_t info;
        if (ub_member_status(&g_member, r, &info) != UB_OK || info.status == g_reported[r]) continue;
        if (info.status == UB_MEMBER_PENDING) continue;
        report_member(r, &info);
        g_reported[r] = UB_MEMBER_FREE;
        if (ub_member_forget(&g_member, r) != UB_OK) ub_app_error(g_app, "member: row vanished");
    }
    if (now_ms >= g_next_flows_ms) {
        if (g_flows_changed) event_flows(now_ms);
        g_flows_changed = false;
        g_next_flows_ms += g_opt.flows_ms;
        if (g_next_flows_ms <= now_ms) g_next_flows_ms = now_ms + g_opt.flows_ms;
    }
}
