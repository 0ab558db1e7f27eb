#include "ub/ub_nodecfg.h"

#if UB_MAX_ENTITIES > 255 || UB_NODECFG_MAX_PORTS > 255
#error "ub_nodecfg counts entities and ports in uint8_t: keep UB_MAX_ENTITIES and UB_NODECFG_MAX_PORTS <= 255"
#endif

#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "ub/ub_node.h"
#include "ub/ub_prio.h"
#include "ub/ub_sec.h"
#include "ub/ub_identfile.h"
#include "ub/ub_secfile.h"
#include "codec/ub_json.h"
#include "config/ub_nodecfg_private.h"

/* The one configuration loader of uavbus: Python reaches it through cffi (runtime_py/uavbus/config.py),
 * so every message below is what both languages print (tests/unit/config_cases/ holds one per error). */
#define HEX_HINT "(each hex digit is one link: 0x00000110 means links 1 and 2)"
#define NAME_CHARS "A-Z a-z 0-9 _ . -"
#define MASK_SHAPE "a mask is a hex string such as \"0x00000110\" or a list of links such as [1, 2] or [\"linkName\"]"
#define PATH_LEN 128
#define KEY_BUF 64 /* > every name limit, so "fits" is checked on the decoded length */
#define ECHO_MAX 40

typedef struct parser {
    ub_json_doc_t doc;
    const char *file;
    char *err;
    size_t err_cap;
    ub_nodecfg_t *cfg;
    ub_nodecfg_limits_t lim; /* every field 1..the build's capacity */
} parser_t;

static void append(char *buf, size_t cap, size_t *used, const char *fmt, va_list ap) {
    if (*used >= cap) return;
    int n = vsnprintf(buf + *used, cap - *used, fmt, ap);
    if (n > 0) *used += (size_t)n;
}

static void appendf(char *buf, size_t cap, size_t *used, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    append(buf, cap, used, fmt, ap);
    va_end(ap);
}

/* "<file>:<line>: [entity '<e>', ][field '<f>': ]<message>" */
static int fail(const parser_t *p, uint32_t line, const char *entity, const char *field, const char *fmt, ...) {
    if (p->err == NULL || p->err_cap == 0) return UB_ERR_CONFIG;
    size_t used = 0;
    appendf(p->err, p->err_cap, &used, "%s:%lu: ", p->file, (unsigned long)line);
    if (entity != NULL) appendf(p->err, p->err_cap, &used, "entity '%s', ", entity);
    if (field != NULL) appendf(p->err, p->err_cap, &used, "field '%s': ", field);
    va_list ap;
    va_start(ap, fmt);
    append(p->err, p->err_cap, &used, fmt, ap);
    va_end(ap);
    return UB_ERR_CONFIG;
}

static bool is_name_char(char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '.' ||
           c == '-';
}

static bool is_name(const char *s, size_t n, size_t max) {
    if (n == 0 || n > max) return false;
    for (size_t i = 0; i < n; i++)
        if (!is_name_char(s[i])) return false;
    return true;
}

/* Transport and parameter names: [a-z][a-z0-9_]{0,14}. */
static bool is_word(const char *s, size_t n) {
    if (n == 0 || n > UB_NODECFG_WORD_MAX || !(s[0] >= 'a' && s[0] <= 'z')) return false;
    for (size_t i = 1; i < n; i++)
        if (!((s[i] >= 'a' && s[i] <= 'z') || (s[i] >= '0' && s[i] <= '9') || s[i] == '_')) return false;
    return true;
}

/* Unknown keys are quoted back only when that is safe and short, so messages stay one clean line. */
static const char *echo(const char *s, size_t n) {
    if (n == 0 || n > ECHO_MAX) return "?";
    for (size_t i = 0; i < n; i++)
        if (s[i] < 0x20 || s[i] > 0x7e || s[i] == '\'') return "?";
    return s;
}

/* Shows a number literal, shortened so a huge one cannot flood the message. */
static void number_text(const parser_t *p, const ub_json_value_t *v, char *out, size_t cap) {
    size_t n = v->end - v->start;
    if (n > 24)
        (void)snprintf(out, cap, "%.20s...", p->doc.text + v->start);
    else
        (void)snprintf(out, cap, "%.*s", (int)n, p->doc.text + v->start);
}

static bool is_integer_literal(const parser_t *p, const ub_json_value_t *v) {
    for (size_t i = v->start; i < v->end; i++) {
        char c = p->doc.text[i];
        if (c == '.' || c == 'e' || c == 'E') return false;
    }
    return true;
}

static size_t key_text(const parser_t *p, const ub_json_value_t *v, char *buf) {
    return ub_json_string(&p->doc, v, buf, KEY_BUF);
}

static void describe_links(int count, char *out, size_t cap) {
    if (count == 0)
        (void)snprintf(out, cap, "no links");
    else if (count == 1)
        (void)snprintf(out, cap, "1 link (link 0)");
    else
        (void)snprintf(out, cap, "%d links (link 0 to link %d)", count, count - 1);
}

/* Looks fields up by name, rejecting unknown and repeated ones; values[k] gets
 * the member for fields[k] (kind 0 when absent). At most CHECK_FIELDS_MAX fields
 * (the "security" section gathers the keys of several concerns). */
#define CHECK_FIELDS_MAX 16
static int check_fields(const parser_t *p, const ub_json_value_t *obj, const char *const *fields, size_t nfields,
                        const char *entity, const char *prefix, ub_json_value_t *values) {
    uint32_t first_line[CHECK_FIELDS_MAX] = {0};
    ub_json_iter_t it;
    ub_json_value_t key, val;
    char name[KEY_BUF], path[PATH_LEN], expected[192];
    size_t used = 0;
    if (nfields > CHECK_FIELDS_MAX) return fail(p, obj->line, entity, prefix, "internal: too many fields to check");
    for (size_t k = 0; k < nfields; k++) {
        values[k].kind = (ub_json_kind_t)0;
        appendf(expected, sizeof expected, &used, "%s%s", k ? ", " : "", fields[k]);
    }
    ub_json_iter_begin(&it, &p->doc, obj);
    while (ub_json_iter_next(&it, &key, &val)) {
        size_t n = key_text(p, &key, name);
        size_t k = 0;
        while (k < nfields && !(n < KEY_BUF && strlen(fields[k]) == n && memcmp(fields[k], name, n) == 0)) k++;
        /* The path only names the field in a message: a longer one is shown cut, marked with '~'. */
        if (snprintf(path, sizeof path, "%s%s", prefix, k < nfields ? fields[k] : echo(name, n)) >= (int)sizeof path)
            path[sizeof path - 2] = '~';
        if (k == nfields)
            return fail(p, key.line, entity, path, "unknown field (expected one of: %s)", expected);
        if (first_line[k] != 0)
            return fail(p, key.line, entity, path, "duplicate field (first given on line %lu)",
                        (unsigned long)first_line[k]);
        first_line[k] = key.line;
        values[k] = val;
    }
    return UB_OK;
}

static int find_entity(const ub_nodecfg_t *cfg, const char *name, size_t n) {
    for (int i = 0; i < cfg->entity_count; i++)
        if (strlen(cfg->entities[i].name) == n && memcmp(cfg->entities[i].name, name, n) == 0) return i;
    return UB_ERR_NOTFOUND;
}

/* ---- masks ---- */

static int hex_parse(const char *s, size_t n, uint8_t *mask, char *why, size_t why_cap) {
    if (n < 2 || s[0] != '0' || (s[1] != 'x' && s[1] != 'X')) {
        (void)snprintf(why, why_cap, "a hex mask starts with \"0x\" " HEX_HINT);
        return UB_ERR_CONFIG;
    }
    size_t digits = n - 2;
    if (digits == 0 || digits > 16) {
        (void)snprintf(why, why_cap, "a hex mask has 1 to 16 digits after \"0x\" " HEX_HINT);
        return UB_ERR_CONFIG;
    }
    for (size_t i = 2; i < n; i++) {
        unsigned char c = (unsigned char)s[i];
        if (c == '0' || c == '1') continue;
        if ((c >= '2' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F'))
            (void)snprintf(why, why_cap, "hex digit '%c' is not 0 or 1 " HEX_HINT, c);
        else if (c >= 0x20 && c <= 0x7e && c != '\'')
            (void)snprintf(why, why_cap, "'%c' is not a hex digit " HEX_HINT, c);
        else
            (void)snprintf(why, why_cap, "byte 0x%02x is not a hex digit " HEX_HINT, c);
        return UB_ERR_CONFIG;
    }
    uint8_t bits = 0;
    for (size_t i = 2; i < n; i++) {
        size_t link = n - 1 - i;
        if (s[i] != '1') continue;
        if (link >= 8) {
            (void)snprintf(why, why_cap, "hex digit for link %u is set, but links are numbered 0 to 7 " HEX_HINT,
                           (unsigned)link);
            return UB_ERR_CONFIG;
        }
        bits = (uint8_t)(bits | (1u << link));
    }
    *mask = bits;
    return UB_OK;
}

static int mask_list(const parser_t *p, const ub_nodecfg_entity_t *e, const ub_json_value_t *list,
                     const char *field, uint8_t *out) {
    ub_json_iter_t it;
    ub_json_value_t v;
    char path[PATH_LEN], text[KEY_BUF], links[48];
    uint8_t bits = 0;
    int k = 0;
    describe_links(e->link_count, links, sizeof links);
    ub_json_iter_begin(&it, &p->doc, list);
    for (; ub_json_iter_next(&it, NULL, &v); k++) {
        int link = -1;
        (void)snprintf(path, sizeof path, "%s[%d]", field, k);
        if (v.kind == UB_JSON_NUMBER) {
            number_text(p, &v, text, sizeof text);
            if (!is_integer_literal(p, &v) || p->doc.text[v.start] == '-')
                return fail(p, v.line, e->name, path, "link index %s must be a whole number 0 to 7", text);
            size_t digits = v.end - v.start;
            link = 0;
            for (size_t i = v.start; i < v.end && digits <= 3; i++) link = link * 10 + (p->doc.text[i] - '0');
            if (digits > 3 || link >= e->link_count)
                return fail(p, v.line, e->name, path, "link index %s is out of range: this entity has %s", text,
                            links);
        } else if (v.kind == UB_JSON_STRING) {
            size_t n = key_text(p, &v, text);
            if (!is_name(text, n, UB_NODECFG_NAME_MAX))
                return fail(p, v.line, e->name, path, "list elements are link indices (0 to 7) or link names");
            for (int i = 0; i < e->link_count && link < 0; i++)
                if (strcmp(e->links[i], text) == 0) link = i;
            if (link < 0) return fail(p, v.line, e->name, path, "no link named '%s' in this entity's 'links'", text);
        } else {
            return fail(p, v.line, e->name, path, "list elements are link indices (0 to 7) or link names");
        }
        if (bits & (1u << link)) return fail(p, v.line, e->name, path, "link %d is listed twice", link);
        bits = (uint8_t)(bits | (1u << link));
    }
    *out = bits;
    return UB_OK;
}

/* One linktoentity value of entity `self` toward entity `target`. */
static int parse_mask(const parser_t *p, int self, int target, const ub_json_value_t *v, const char *field) {
    ub_nodecfg_entity_t *e = &p->cfg->entities[self];
    uint8_t bits = 0;
    int rc;
    if (v->kind == UB_JSON_STRING) {
        char text[KEY_BUF], why[160], links[48];
        /* An over-long string is cut in `text`, but hex_parse rejects it by its
         * length after reading only the "0x" prefix. */
        size_t n = key_text(p, v, text);
        if (hex_parse(text, n, &bits, why, sizeof why) != UB_OK) return fail(p, v->line, e->name, field, "%s", why);
        for (int link = e->link_count; link < 8; link++) {
            if (!(bits & (1u << link))) continue;
            describe_links(e->link_count, links, sizeof links);
            return fail(p, v->line, e->name, field, "link %d is set, but this entity has %s", link, links);
        }
    } else if (v->kind == UB_JSON_ARRAY) {
        if ((rc = mask_list(p, e, v, field, &bits)) != UB_OK) return rc;
    } else {
        return fail(p, v->line, e->name, field, MASK_SHAPE);
    }
    if (self == target && bits != 0)
        return fail(p, v->line, e->name, field,
                    "an entity's mask to itself must be 0x00000000 (frames for a local entity are delivered, "
                    "not sent)");
    e->mask[target] = bits;
    return UB_OK;
}

static int parse_linktoentity(const parser_t *p, int self, const ub_json_value_t *lte) {
    const ub_nodecfg_t *cfg = p->cfg;
    const char *ename = cfg->entities[self].name;
    ub_json_iter_t it;
    ub_json_value_t key, v;
    char path[PATH_LEN], name[KEY_BUF];
    int rc;
    if (lte->kind == UB_JSON_OBJECT) {
        uint32_t first_line[UB_MAX_ENTITIES] = {0};
        ub_json_iter_begin(&it, &p->doc, lte);
        while (ub_json_iter_next(&it, &key, &v)) {
            size_t n = key_text(p, &key, name);
            if (!is_name(name, n, UB_ENTITY_ID_LEN))
                return fail(p, key.line, ename, "linktoentity",
                            "'linktoentity' keys are entity names (1 to 12 characters from " NAME_CHARS ")");
            (void)snprintf(path, sizeof path, "linktoentity.%s", name);
            int target = find_entity(cfg, name, n);
            if (target < 0) return fail(p, key.line, ename, path, "no entity named '%s' in 'entities'", name);
            if (first_line[target] != 0)
                return fail(p, key.line, ename, path, "duplicate field (first given on line %lu)",
                            (unsigned long)first_line[target]);
            first_line[target] = key.line;
            if ((rc = parse_mask(p, self, target, &v, path)) != UB_OK) return rc;
        }
        return UB_OK;
    }
    if (lte->kind != UB_JSON_ARRAY)
        return fail(p, lte->line, ename, "linktoentity",
                    "must be an object keyed by entity name or a list with one mask per entity");
    int count = 0;
    ub_json_iter_begin(&it, &p->doc, lte);
    while (ub_json_iter_next(&it, NULL, &v)) count++;
    if (count != cfg->entity_count)
        return fail(p, lte->line, ename, "linktoentity",
                    "has %d masks but 'entities' lists %d; give one mask per entity in 'entities' order, "
                    "or key the masks by entity name",
                    count, cfg->entity_count);
    ub_json_iter_begin(&it, &p->doc, lte);
    for (int target = 0; ub_json_iter_next(&it, NULL, &v); target++) {
        (void)snprintf(path, sizeof path, "linktoentity[%d]", target);
        if ((rc = parse_mask(p, self, target, &v, path)) != UB_OK) return rc;
    }
    return UB_OK;
}

/* ---- entities ---- */

static const char *const ENTITY_FIELDS[] = {"name", "links", "linktoentity"};
enum { F_NAME, F_LINKS, F_LTE, N_ENTITY_FIELDS };

static int parse_links(const parser_t *p, ub_nodecfg_entity_t *e, const ub_json_value_t *links) {
    ub_json_iter_t it;
    ub_json_value_t v;
    char path[PATH_LEN], name[KEY_BUF];
    if (links->kind != UB_JSON_ARRAY) return fail(p, links->line, e->name, "links", "must be a list of link names");
    ub_json_iter_begin(&it, &p->doc, links);
    for (int k = 0; ub_json_iter_next(&it, NULL, &v); k++) {
        (void)snprintf(path, sizeof path, "links[%d]", k);
        if (k == p->lim.max_links_per_entity)
            return fail(p, v.line, e->name, path,
                        "too many links: at most %d per entity (the paper's limit is 8; UB_MAX_LINKS_PER_ENTITY)",
                        p->lim.max_links_per_entity);
        size_t n = v.kind == UB_JSON_STRING ? key_text(p, &v, name) : 0;
        if (!is_name(name, n, UB_NODECFG_NAME_MAX))
            return fail(p, v.line, e->name, path, "link names are 1 to %d characters from " NAME_CHARS,
                        UB_NODECFG_NAME_MAX);
        for (int i = 0; i < k; i++)
            if (strcmp(e->links[i], name) == 0)
                return fail(p, v.line, e->name, path, "duplicate link name '%s' (first at links[%d])", name, i);
        memcpy(e->links[k], name, n + 1);
        e->link_count = (uint8_t)(k + 1);
    }
    return UB_OK;
}

/* First pass over one entity: everything but linktoentity, which needs all names. */
static int parse_entity(const parser_t *p, int index, const ub_json_value_t *obj, ub_json_value_t *lte) {
    ub_nodecfg_t *cfg = p->cfg;
    ub_nodecfg_entity_t *e = &cfg->entities[index];
    ub_json_value_t values[N_ENTITY_FIELDS], key, v;
    ub_json_iter_t it;
    char path[PATH_LEN], name[KEY_BUF];
    int rc;
    (void)snprintf(path, sizeof path, "entities[%d]", index);
    if (obj->kind != UB_JSON_OBJECT)
        return fail(p, obj->line, NULL, path,
                    "must be an object {\"name\": ..., \"links\": [...], \"linktoentity\": ...}");
    bool have_name = false;
    ub_json_iter_begin(&it, &p->doc, obj);
    while (!have_name && ub_json_iter_next(&it, &key, &v))
        have_name = key_text(p, &key, name) == 4 && memcmp(name, "name", 4) == 0;
    (void)snprintf(path, sizeof path, "entities[%d].name", index);
    if (!have_name) return fail(p, obj->line, NULL, path, "missing (every entity needs a name: its 12-byte ID)");
    size_t n = v.kind == UB_JSON_STRING ? key_text(p, &v, name) : 0;
    if (!is_name(name, n, UB_ENTITY_ID_LEN))
        return fail(p, v.line, NULL, path,
                    "entity names are 1 to 12 characters from " NAME_CHARS " (the name is the 12-byte entity ID)");
    int first = find_entity(cfg, name, n);
    if (first >= 0)
        return fail(p, v.line, name, "name", "duplicate entity name (first defined on line %lu)",
                    (unsigned long)cfg->entities[first].line);
    memcpy(e->name, name, n + 1);
    e->line = obj->line;
    cfg->entity_count = (uint8_t)(index + 1);
    if ((rc = check_fields(p, obj, ENTITY_FIELDS, N_ENTITY_FIELDS, e->name, "", values)) != UB_OK) return rc;
    if (values[F_LINKS].kind != 0 && (rc = parse_links(p, e, &values[F_LINKS])) != UB_OK) return rc;
    *lte = values[F_LTE];
    return UB_OK;
}

static int parse_entities(const parser_t *p, const ub_json_value_t *arr) {
    ub_json_value_t lte[UB_MAX_ENTITIES], v;
    ub_json_iter_t it;
    char path[PATH_LEN];
    int count = 0, rc;
    if (arr->kind != UB_JSON_ARRAY) return fail(p, arr->line, NULL, "entities", "must be a list of entity objects");
    ub_json_iter_begin(&it, &p->doc, arr);
    for (; ub_json_iter_next(&it, NULL, &v); count++) {
        if (count == p->lim.max_entities) {
            (void)snprintf(path, sizeof path, "entities[%d]", count);
            return fail(p, v.line, NULL, path, "too many entities: this build holds %d (raise UB_MAX_ENTITIES in "
                                               "ub_config.h)", p->lim.max_entities);
        }
        if ((rc = parse_entity(p, count, &v, &lte[count])) != UB_OK) return rc;
    }
    if (count == 0) return fail(p, arr->line, NULL, "entities", "must list at least one entity");
    for (int i = 0; i < count; i++)
        if (lte[i].kind != 0 && (rc = parse_linktoentity(p, i, &lte[i])) != UB_OK) return rc;
    return UB_OK;
}

/* ---- hosts and nodes ---- */

/* Reads a list of entity names into out[]; `node` >= 0 also rejects entities
 * that an earlier node already hosts. */
static int parse_entity_list(const parser_t *p, const ub_json_value_t *list, const char *field, int node,
                             uint8_t *out, uint8_t *count) {
    const ub_nodecfg_t *cfg = p->cfg;
    ub_json_iter_t it;
    ub_json_value_t v;
    char path[PATH_LEN + 16], name[KEY_BUF]; /* room for "<field>[<index>]" */
    if (list->kind != UB_JSON_ARRAY) return fail(p, list->line, NULL, field, "must be a list of entity names");
    ub_json_iter_begin(&it, &p->doc, list);
    for (int k = 0; ub_json_iter_next(&it, NULL, &v); k++) {
        (void)snprintf(path, sizeof path, "%s[%d]", field, k);
        if (k == p->lim.max_local_entities)
            return fail(p, v.line, NULL, path,
                        "too many hosted entities: this build holds %d (raise UB_MAX_LOCAL_ENTITIES in ub_config.h)",
                        p->lim.max_local_entities);
        size_t n = v.kind == UB_JSON_STRING ? key_text(p, &v, name) : 0;
        if (!is_name(name, n, UB_ENTITY_ID_LEN)) return fail(p, v.line, NULL, path, "must be an entity name");
        int e = find_entity(cfg, name, n);
        if (e < 0) return fail(p, v.line, NULL, path, "no entity named '%s' in 'entities'", name);
        for (int i = 0; i < k; i++)
            if (out[i] == e) return fail(p, v.line, NULL, path, "entity '%s' is listed twice", name);
        for (int other = 0; other < node; other++)
            for (int i = 0; i < cfg->nodes[other].entity_count; i++)
                if (cfg->nodes[other].entity[i] == e)
                    return fail(p, v.line, NULL, path, "entity '%s' is already hosted by node '%s'", name,
                                cfg->nodes[other].name);
        out[k] = (uint8_t)e;
        *count = (uint8_t)(k + 1);
    }
    return UB_OK;
}

static int parse_nodes(const parser_t *p, const ub_json_value_t *obj) {
    ub_nodecfg_t *cfg = p->cfg;
    uint32_t first_line[UB_MAX_ENTITIES] = {0};
    ub_json_iter_t it;
    ub_json_value_t key, v;
    char path[PATH_LEN], name[KEY_BUF];
    int rc;
    if (obj->kind != UB_JSON_OBJECT)
        return fail(p, obj->line, NULL, "nodes", "must be an object mapping node names to lists of entity names");
    ub_json_iter_begin(&it, &p->doc, obj);
    while (ub_json_iter_next(&it, &key, &v)) {
        size_t n = key_text(p, &key, name);
        if (!is_name(name, n, UB_NODECFG_NAME_MAX))
            return fail(p, key.line, NULL, "nodes", "node names are 1 to %d characters from " NAME_CHARS,
                        UB_NODECFG_NAME_MAX);
        (void)snprintf(path, sizeof path, "nodes.%s", name);
        for (int i = 0; i < cfg->node_count; i++)
            if (strcmp(cfg->nodes[i].name, name) == 0)
                return fail(p, key.line, NULL, path, "duplicate field (first given on line %lu)",
                            (unsigned long)first_line[i]);
        if (cfg->node_count == p->lim.max_entities)
            return fail(p, key.line, NULL, path, "too many nodes: this build holds %d (UB_MAX_ENTITIES)",
                        p->lim.max_entities);
        int node = cfg->node_count;
        ub_nodecfg_node_t *nd = &cfg->nodes[node];
        memcpy(nd->name, name, n + 1);
        first_line[node] = key.line;
        if ((rc = parse_entity_list(p, &v, path, node, nd->entity, &nd->entity_count)) != UB_OK) return rc;
        if (nd->entity_count == 0) return fail(p, v.line, NULL, path, "must list at least one entity");
        cfg->node_count = (uint8_t)(node + 1);
    }
    return UB_OK;
}

/* ---- ports (reserved for the links issue: shape only) ---- */

static bool is_port_key(const char *s, size_t n) {
    const char *colon = memchr(s, ':', n);
    if (colon == NULL) return is_name(s, n, UB_NODECFG_NAME_MAX);
    size_t left = (size_t)(colon - s);
    return is_name(s, left, UB_ENTITY_ID_LEN) && is_name(colon + 1, n - left - 1, UB_NODECFG_NAME_MAX);
}

static int parse_port_value(const parser_t *p, ub_nodecfg_port_t *port, const ub_json_value_t *obj,
                            const char *port_path) {
    uint32_t transport_line = 0, param_line[UB_NODECFG_MAX_PORT_PARAMS] = {0};
    ub_json_iter_t it;
    ub_json_value_t key, v;
    /* Room for "<port_path>.<key>" at their longest, so a field path is never cut short. */
    char path[PATH_LEN + 1 + KEY_BUF], name[KEY_BUF], text[UB_NODECFG_TEXT_MAX + 1];
    if (obj->kind != UB_JSON_OBJECT)
        return fail(p, obj->line, NULL, port_path, "must be an object with a \"transport\" string");
    ub_json_iter_begin(&it, &p->doc, obj);
    while (ub_json_iter_next(&it, &key, &v)) {
        size_t n = key_text(p, &key, name);
        if (!is_word(name, n))
            return fail(p, key.line, NULL, port_path,
                        "parameter names are lower-case words of 1 to 15 characters such as \"connect\"");
        (void)snprintf(path, sizeof path, "%s.%s", port_path, name);
        if (strcmp(name, "transport") == 0) {
            if (transport_line != 0)
                return fail(p, key.line, NULL, path, "duplicate field (first given on line %lu)",
                            (unsigned long)transport_line);
            transport_line = key.line;
            size_t tn = v.kind == UB_JSON_STRING ? ub_json_string(&p->doc, &v, text, sizeof text) : 0;
            if (!is_word(text, tn))
                return fail(p, v.line, NULL, path, "must be a lower-case word of 1 to 15 characters such as \"tcp\"");
            memcpy(port->transport, text, tn + 1);
            continue;
        }
        for (int i = 0; i < port->param_count; i++)
            if (strcmp(port->params[i].key, name) == 0)
                return fail(p, key.line, NULL, path, "duplicate field (first given on line %lu)",
                            (unsigned long)param_line[i]);
        if (port->param_count == p->lim.max_port_params)
            return fail(p, key.line, NULL, path,
                        "too many parameters: this build holds %d per port (UB_NODECFG_MAX_PORT_PARAMS)",
                        p->lim.max_port_params);
        ub_nodecfg_port_param_t *param = &port->params[port->param_count];
        size_t len = v.end - v.start;
        if (v.kind == UB_JSON_STRING) {
            len = ub_json_string(&p->doc, &v, text, sizeof text);
            if (len >= sizeof text || strlen(text) != len) len = sizeof text; /* too long, or an escaped NUL */
        } else if ((v.kind == UB_JSON_NUMBER && is_integer_literal(p, &v)) || v.kind == UB_JSON_TRUE ||
                   v.kind == UB_JSON_FALSE) {
            if (len < sizeof text) memcpy(text, p->doc.text + v.start, len);
        } else {
            len = sizeof text;
        }
        if (len >= sizeof text)
            return fail(p, v.line, NULL, path, "must be a string of up to %d characters, a whole number or true/false",
                        UB_NODECFG_TEXT_MAX);
        text[len] = '\0';
        memcpy(param->key, name, n + 1);
        memcpy(param->value, text, len + 1);
        param_line[port->param_count] = key.line;
        port->param_count++;
    }
    if (transport_line == 0) {
        (void)snprintf(path, sizeof path, "%s.transport", port_path);
        return fail(p, obj->line, NULL, path, "missing (for example \"tcp\", \"udp\", \"serial\" or \"mem\")");
    }
    return UB_OK;
}

static int parse_ports(const parser_t *p, const ub_json_value_t *obj) {
    ub_nodecfg_t *cfg = p->cfg;
    ub_json_iter_t it;
    ub_json_value_t key, v;
    char path[PATH_LEN], name[KEY_BUF];
    int rc;
    if (obj->kind != UB_JSON_OBJECT)
        return fail(p, obj->line, NULL, "ports",
                    "must be an object mapping link names to {\"transport\": ...} (reserved for the links issue)");
    ub_json_iter_begin(&it, &p->doc, obj);
    while (ub_json_iter_next(&it, &key, &v)) {
        size_t n = key_text(p, &key, name);
        if (n >= KEY_BUF || !is_port_key(name, n))
            return fail(p, key.line, NULL, "ports", "port keys are link names, optionally qualified as \"entity:link\"");
        (void)snprintf(path, sizeof path, "ports.%s", name);
        for (int i = 0; i < cfg->port_count; i++)
            if (strcmp(cfg->ports[i].name, name) == 0)
                return fail(p, key.line, NULL, path, "duplicate field (first given on line %lu)",
                            (unsigned long)cfg->ports[i].line);
        if (cfg->port_count == p->lim.max_ports)
            return fail(p, key.line, NULL, path, "too many ports: this build holds %d (UB_NODECFG_MAX_PORTS)",
                        p->lim.max_ports);
        ub_nodecfg_port_t *port = &cfg->ports[cfg->port_count];
        memcpy(port->name, name, n + 1);
        port->line = key.line;
        if ((rc = parse_port_value(p, port, &v, path)) != UB_OK) return rc;
        cfg->port_count++;
    }
    return UB_OK;
}

/* ---- security ----
 * The "security" section gathers the keys of several concerns, each parsed by its own code:
 *  - frame protection (docs/security.md): keys, tx_key, require_signed, counter_file, links — here, into
 *    cfg->security; on as soon as one of them is given, and then keys and counter_file are required.
 *    Key files and the counter file are read only by ub_nodecfg_apply_security();
 *  - authorization of the admin plane: administrators, read, write, limits, exclusive_admin — ub_policy.c
 *    (ub_priv_policy_parse_key), into cfg->policy; on as soon as one of those is given. */

#define FRAME_SECURITY_KEYS "keys", "tx_key", "require_signed", "counter_file", "links"
enum { S_KEYS, S_TX_KEY, S_REQUIRE_SIGNED, S_COUNTER_FILE, S_LINKS, N_FRAME_SECURITY_FIELDS };
/* Identity per entity (issue 23): the last keys of the section. */
#define IDENTITY_KEYS "identity", "authority", "revocations", "certificates"
enum { N_IDENTITY_FIELDS = 4 };
static const char *const SECURITY_FIELDS[] = {FRAME_SECURITY_KEYS, UB_PRIV_POLICY_KEYS, IDENTITY_KEYS};
#define N_SECURITY_FIELDS (sizeof SECURITY_FIELDS / sizeof SECURITY_FIELDS[0])
#define FIRST_IDENTITY_FIELD (N_SECURITY_FIELDS - N_IDENTITY_FIELDS)

static int parse_path(const parser_t *p, const ub_json_value_t *v, const char *field, char *out) {
    size_t n = v->kind == UB_JSON_STRING ? ub_json_string(&p->doc, v, out, UB_NODECFG_PATH_MAX + 1) : 0;
    if (n == 0 || n > UB_NODECFG_PATH_MAX || strlen(out) != n)
        return fail(p, v->line, NULL, field, "must be a file path of 1 to %d characters", UB_NODECFG_PATH_MAX);
    return UB_OK;
}

static int parse_bool(const parser_t *p, const ub_json_value_t *v, const char *field, uint8_t *out) {
    if (v->kind != UB_JSON_TRUE && v->kind != UB_JSON_FALSE) return fail(p, v->line, NULL, field, "must be true or false");
    *out = v->kind == UB_JSON_TRUE;
    return UB_OK;
}

/* A "security.links" key must name a link of some entity ("entity:link" that entity's): a misspelt
 * link must not leave a link unencrypted without a word. */
static bool link_exists(const ub_nodecfg_t *cfg, const char *key) {
    const char *colon = strchr(key, ':');
    for (int i = 0; i < cfg->entity_count; i++) {
        const ub_nodecfg_entity_t *e = &cfg->entities[i];
        const char *link = key;
        if (colon != NULL) {
            if (strlen(e->name) != (size_t)(colon - key) || memcmp(e->name, key, (size_t)(colon - key)) != 0) continue;
            link = colon + 1;
        }
        for (int l = 0; l < e->link_count; l++)
            if (strcmp(e->links[l], link) == 0) return true;
    }
    return false;
}

static int parse_security_links(const parser_t *p, const ub_json_value_t *obj) {
    static const char *const LINK_FIELDS[] = {"require_signed", "encrypt"};
    ub_nodecfg_security_t *sec = &p->cfg->security;
    ub_json_iter_t it;
    ub_json_value_t key, v, values[2];
    char path[PATH_LEN + 16], name[KEY_BUF];
    int rc;
    if (obj->kind != UB_JSON_OBJECT)
        return fail(p, obj->line, NULL, "security.links",
                    "must be an object mapping link names to {\"require_signed\": ..., \"encrypt\": ...}");
    ub_json_iter_begin(&it, &p->doc, obj);
    while (ub_json_iter_next(&it, &key, &v)) {
        size_t n = key_text(p, &key, name);
        if (n >= KEY_BUF || !is_port_key(name, n))
            return fail(p, key.line, NULL, "security.links", "keys are link names, optionally qualified as \"entity:link\"");
        (void)snprintf(path, sizeof path, "security.links.%s", name);
        if (!link_exists(p->cfg, name))
            return fail(p, key.line, NULL, path, "no link of that name in any entity's 'links'");
        for (int i = 0; i < sec->link_count; i++)
            if (strcmp(sec->links[i].name, name) == 0)
                return fail(p, key.line, NULL, path, "duplicate field (first given on line %lu)",
                            (unsigned long)sec->links[i].line);
        if (sec->link_count == UB_NODECFG_MAX_PORTS)
            return fail(p, key.line, NULL, path, "too many links: this build holds %d (UB_NODECFG_MAX_PORTS)",
                        UB_NODECFG_MAX_PORTS);
        if (v.kind != UB_JSON_OBJECT)
            return fail(p, v.line, NULL, path, "must be an object such as {\"encrypt\": true}");
        (void)snprintf(path, sizeof path, "security.links.%s.", name);
        if ((rc = check_fields(p, &v, LINK_FIELDS, 2, NULL, path, values)) != UB_OK) return rc;
        ub_nodecfg_link_security_t *ls = &sec->links[sec->link_count];
        memcpy(ls->name, name, n + 1);
        ls->line = key.line;
        ls->require_signed = -1;
        if (values[0].kind != 0) {
            uint8_t b = 0;
            (void)snprintf(path, sizeof path, "security.links.%s.require_signed", name);
            if ((rc = parse_bool(p, &values[0], path, &b)) != UB_OK) return rc;
            ls->require_signed = (int8_t)b;
        }
        if (values[1].kind != 0) {
            (void)snprintf(path, sizeof path, "security.links.%s.encrypt", name);
            if ((rc = parse_bool(p, &values[1], path, &ls->encrypt)) != UB_OK) return rc;
        }
        sec->link_count++;
    }
    return UB_OK;
}

/* The frame-protection keys (values[0, N_FRAME_SECURITY_FIELDS) of the section), when any is given. */
static int parse_frame_security(const parser_t *p, const ub_json_value_t *obj, const ub_json_value_t *values) {
    ub_nodecfg_security_t *sec = &p->cfg->security;
    ub_json_iter_t it;
    ub_json_value_t v;
    char path[PATH_LEN];
    int rc;
    bool any = false;
    for (int k = 0; k < N_FRAME_SECURITY_FIELDS; k++) any = any || values[k].kind != 0;
    if (!any) return UB_OK;
    sec->present = 1;
    sec->line = obj->line;
    sec->require_signed = 1; /* a node given keys refuses unsigned frames unless told otherwise */
    const ub_json_value_t *keys = &values[S_KEYS];
    if (keys->kind == 0)
        return fail(p, obj->line, NULL, "security.keys",
                    "missing (list the key files, e.g. [\"keys/fleet.key\"]; make one with: uavbus keys new FILE)");
    if (keys->kind != UB_JSON_ARRAY) return fail(p, keys->line, NULL, "security.keys", "must be a list of key file paths");
    ub_json_iter_begin(&it, &p->doc, keys);
    for (int k = 0; ub_json_iter_next(&it, NULL, &v); k++) {
        (void)snprintf(path, sizeof path, "security.keys[%d]", k);
        if (k == UB_MAX_KEYS)
            return fail(p, v.line, NULL, path, "too many keys: this build holds %d (UB_MAX_KEYS in ub_config.h)",
                        UB_MAX_KEYS);
        if ((rc = parse_path(p, &v, path, sec->keys[k])) != UB_OK) return rc;
        sec->key_lines[k] = v.line;
        sec->key_count = (uint8_t)(k + 1);
    }
    if (sec->key_count == 0)
        return fail(p, keys->line, NULL, "security.keys", "must list at least one key file (make one with: uavbus keys new FILE)");
    const ub_json_value_t *tx = &values[S_TX_KEY];
    if (tx->kind != 0) {
        char num[32];
        number_text(p, tx, num, sizeof num);
        unsigned long id = 0;
        bool ok = tx->kind == UB_JSON_NUMBER && is_integer_literal(p, tx) && num[0] != '-' && strlen(num) <= 3;
        for (size_t i = 0; ok && num[i] != '\0'; i++) id = id * 10u + (unsigned long)(num[i] - '0');
        if (!ok || id < 1 || id > 255)
            return fail(p, tx->line, NULL, "security.tx_key", "must be a key id 1..255 (the id=N of one of the key files)");
        sec->tx_key = (uint8_t)id;
        sec->tx_key_line = tx->line;
    }
    if (values[S_REQUIRE_SIGNED].kind != 0 &&
        (rc = parse_bool(p, &values[S_REQUIRE_SIGNED], "security.require_signed", &sec->require_signed)) != UB_OK)
        return rc;
    if (values[S_COUNTER_FILE].kind == 0)
        return fail(p, obj->line, NULL, "security.counter_file",
                    "missing: a node that signs needs a durable counter, e.g. \"state/{entity}.counter\" (docs/security.md)");
    if ((rc = parse_path(p, &values[S_COUNTER_FILE], "security.counter_file", sec->counter_file)) != UB_OK) return rc;
    sec->counter_file_line = values[S_COUNTER_FILE].line;
    if (values[S_LINKS].kind != 0 && (rc = parse_security_links(p, &values[S_LINKS])) != UB_OK) return rc;
    return UB_OK;
}

/* Identity files ("identity", "authority", "revocations"): paths only; ub_nodecfg_load_identity() reads them. */
static int parse_identity(const parser_t *p, const ub_json_value_t *obj, const ub_json_value_t *values) {
    ub_nodecfg_identity_t *id = &p->cfg->identity;
    int rc;
    if (values[0].kind == 0 && values[1].kind == 0 && values[2].kind == 0 && values[3].kind == 0) return UB_OK;
    if (values[1].kind == 0)
        return fail(p, obj->line, NULL, "security.authority",
                    "missing: identities are verified under the fleet authority's public key, e.g. "
                    "\"keys/authority.pub\" (make it with: uavbus keys authority create)");
    id->present = 1;
    if ((rc = parse_path(p, &values[1], "security.authority", id->authority)) != UB_OK) return rc;
    id->authority_line = values[1].line;
    if (values[0].kind != 0) {
        if ((rc = parse_path(p, &values[0], "security.identity", id->identity)) != UB_OK) return rc;
        id->identity_line = values[0].line;
    }
    if (values[2].kind != 0) {
        if ((rc = parse_path(p, &values[2], "security.revocations", id->revocations)) != UB_OK) return rc;
        id->revocations_line = values[2].line;
    }
    if (values[3].kind != 0) {
        if ((rc = parse_path(p, &values[3], "security.certificates", id->certificates)) != UB_OK) return rc;
        id->certificates_line = values[3].line;
    }
    return UB_OK;
}

static int parse_security(const parser_t *p, const ub_json_value_t *obj) {
    ub_nodecfg_t *cfg = p->cfg;
    ub_json_value_t values[N_SECURITY_FIELDS];
    int rc;
    if (obj->kind != UB_JSON_OBJECT)
        return fail(p, obj->line, NULL, "security",
                    "must be an object with keys, tx_key, require_signed, counter_file, links, administrators, read, "
                    "write and/or limits (see docs/config-format.md)");
    if ((rc = check_fields(p, obj, SECURITY_FIELDS, N_SECURITY_FIELDS, NULL, "security.", values)) != UB_OK) return rc;
    if ((rc = parse_frame_security(p, obj, values)) != UB_OK) return rc;
    if ((rc = parse_identity(p, obj, values + FIRST_IDENTITY_FIELD)) != UB_OK) return rc;
    ub_policy_init(&cfg->policy);
    for (size_t k = N_FRAME_SECURITY_FIELDS; k < FIRST_IDENTITY_FIELD; k++) {
        if (values[k].kind == 0) continue;
        ub_cfg_error_t e;
        memset(&e, 0, sizeof e);
        rc = ub_priv_policy_parse_key(&cfg->policy, cfg, &p->doc, SECURITY_FIELDS[k], &values[k], &e);
        if (rc != UB_OK) return fail(p, e.line, e.entity[0] != '\0' ? e.entity : NULL, e.field, "%s", e.message);
        cfg->has_policy = 1;
    }
    return UB_OK;
}

/* ---- priorities: {"content pattern": "class", ...} (ub_prio.h) ---- */

static int parse_priorities(const parser_t *p, const ub_json_value_t *obj) {
    ub_nodecfg_t *cfg = p->cfg;
    ub_json_iter_t it;
    ub_json_value_t key, v;
    char path[PATH_LEN], name[KEY_BUF], cls_text[16];
    if (obj->kind != UB_JSON_OBJECT)
        return fail(p, obj->line, NULL, "priorities",
                    "must be an object mapping content names to a class: {\"gcsCommand\": \"command\", "
                    "\"setpoint\": \"control\", \"mapTile*\": \"bulk\"}");
    ub_json_iter_begin(&it, &p->doc, obj);
    while (ub_json_iter_next(&it, &key, &v)) {
        size_t n = key_text(p, &key, name);
        if (n == 0 || n >= KEY_BUF || n > UB_POLICY_PATTERN_MAX || !ub_policy_pattern_ok(name, UB_POLICY_PATTERN_MAX))
            return fail(p, key.line, NULL, "priorities",
                        "keys are content names or patterns (letters, digits, _ [ ] . and * for any run), at most %d "
                        "characters", UB_POLICY_PATTERN_MAX);
        (void)snprintf(path, sizeof path, "priorities.%s", name);
        for (int i = 0; i < cfg->priority_count; i++)
            if (strcmp(cfg->priorities[i].content, name) == 0)
                return fail(p, key.line, NULL, path, "duplicate field (first given on line %lu)",
                            (unsigned long)cfg->priorities[i].line);
        if (cfg->priority_count == UB_NODECFG_MAX_PRIORITIES)
            return fail(p, key.line, NULL, path, "too many entries: this build holds %d (UB_NODECFG_MAX_PRIORITIES)",
                        UB_NODECFG_MAX_PRIORITIES);
        ub_prio_class_t cls;
        size_t cn = v.kind == UB_JSON_STRING ? ub_json_string(&p->doc, &v, cls_text, sizeof cls_text) : 0;
        if (cn == 0 || cn >= sizeof cls_text || ub_prio_class_parse(cls_text, &cls) != UB_OK)
            return fail(p, v.line, NULL, path, "must be one of \"command\", \"control\", \"telemetry\", \"bulk\"");
        memcpy(cfg->priorities[cfg->priority_count].content, name, n + 1);
        cfg->priorities[cfg->priority_count].cls = (uint8_t)cls;
        cfg->priorities[cfg->priority_count].line = key.line;
        cfg->priority_count++;
    }
    return UB_OK;
}

int ub_nodecfg_apply_priorities(const ub_nodecfg_t *cfg, struct ub_node *node, const ub_catalogue_t *cat,
                                uint8_t *classes, size_t n, char *err, size_t err_cap) {
    if (cfg == NULL || node == NULL || cat == NULL || (err == NULL && err_cap > 0)) return UB_ERR_INVAL;
    if (cfg->priority_count == 0) return UB_OK;
    if (classes == NULL || n != cat->n_instances) return UB_ERR_INVAL;
    for (size_t i = 0; i < n; i++) classes[i] = UB_PRIO_TELEMETRY;
    for (int k = 0; k < cfg->priority_count; k++) {
        bool matched = false;
        for (size_t i = 0; i < n; i++) {
            const char *name = cat->instances[i].name;
            if (name == NULL || !ub_policy_match(cfg->priorities[k].content, name, strlen(name))) continue;
            matched = true;
            /* The first pattern in file order decides: a later, broader one does not undo it. */
            bool earlier = false;
            for (int j = 0; j < k && !earlier; j++)
                earlier = ub_policy_match(cfg->priorities[j].content, name, strlen(name));
            if (!earlier) classes[i] = cfg->priorities[k].cls;
        }
        if (!matched) {
            if (err_cap > 0)
                (void)snprintf(err, err_cap, "%s:%lu: field 'priorities.%s': matches no content of the catalogue "
                                             "(write an instance name of it, or a pattern with *)",
                               cfg->source, (unsigned long)cfg->priorities[k].line, cfg->priorities[k].content);
            return UB_ERR_CONFIG;
        }
    }
    return ub_node_set_content_classes(node, classes, n);
}

/* ---- top level ---- */

static const char *const TOP_FIELDS[] = {"system", "entities", "hosts", "nodes", "ports", "security", "priorities"};
enum { T_SYSTEM, T_ENTITIES, T_HOSTS, T_NODES, T_PORTS, T_SECURITY, T_PRIORITIES, N_TOP_FIELDS };

static int parse_document(const parser_t *p, const ub_json_value_t *root) {
    ub_nodecfg_t *cfg = p->cfg;
    ub_json_value_t values[N_TOP_FIELDS];
    int rc;
    if (root->kind != UB_JSON_OBJECT)
        return fail(p, root->line, NULL, NULL,
                    "the top level must be an object {\"entities\": [...], ...} (see docs/config-format.md)");
    if ((rc = check_fields(p, root, TOP_FIELDS, N_TOP_FIELDS, NULL, "", values)) != UB_OK) return rc;
    const ub_json_value_t *system = &values[T_SYSTEM];
    if (system->kind != 0) {
        size_t n = system->kind == UB_JSON_STRING ? ub_json_string(&p->doc, system, cfg->system, sizeof cfg->system) : 0;
        if (n == 0 || n > UB_NODECFG_TEXT_MAX || strlen(cfg->system) != n)
            return fail(p, system->line, NULL, "system", "must be a string of 1 to %d characters", UB_NODECFG_TEXT_MAX);
    }
    if (values[T_ENTITIES].kind == 0)
        return fail(p, root->line, NULL, "entities", "missing (list every entity this node knows)");
    if ((rc = parse_entities(p, &values[T_ENTITIES])) != UB_OK) return rc;
    if (values[T_HOSTS].kind != 0 &&
        (rc = parse_entity_list(p, &values[T_HOSTS], "hosts", -1, cfg->hosts, &cfg->host_count)) != UB_OK)
        return rc;
    if (values[T_NODES].kind != 0 && (rc = parse_nodes(p, &values[T_NODES])) != UB_OK) return rc;
    if (values[T_PORTS].kind != 0 && (rc = parse_ports(p, &values[T_PORTS])) != UB_OK) return rc;
    if (values[T_SECURITY].kind != 0 && (rc = parse_security(p, &values[T_SECURITY])) != UB_OK) return rc;
    if (values[T_PRIORITIES].kind != 0 && (rc = parse_priorities(p, &values[T_PRIORITIES])) != UB_OK) return rc;
    return UB_OK;
}

/* A limit of 0 means the build's capacity; a larger one than the build's cannot be held. */
static int resolve_limit(uint8_t asked, int build, const char *name, uint8_t *out, char *err, size_t err_cap) {
    if (asked > build) {
        if (err_cap > 0)
            (void)snprintf(err, err_cap, "limits: %s %u is more than this build holds (%d): give 0 for the "
                                         "build's value or a smaller one", name, (unsigned)asked, build);
        return UB_ERR_RANGE;
    }
    *out = asked == 0 ? (uint8_t)build : asked;
    return UB_OK;
}

void ub_nodecfg_build_limits(ub_nodecfg_limits_t *limits) {
    if (limits == NULL) return;
    limits->max_entities = UB_MAX_ENTITIES;
    limits->max_links_per_entity = UB_MAX_LINKS_PER_ENTITY;
    limits->max_local_entities = UB_MAX_LOCAL_ENTITIES;
    limits->max_ports = UB_NODECFG_MAX_PORTS;
    limits->max_port_params = UB_NODECFG_MAX_PORT_PARAMS;
}

int ub_nodecfg_parse_limits(ub_nodecfg_t *cfg, const char *text, size_t len, const char *source_name,
                            const ub_nodecfg_limits_t *limits, char *err, size_t err_cap) {
    if (cfg == NULL || text == NULL || source_name == NULL || (err == NULL && err_cap > 0)) return UB_ERR_INVAL;
    memset(cfg, 0, sizeof *cfg);
    parser_t p = {.file = source_name, .err = err, .err_cap = err_cap, .cfg = cfg};
    ub_nodecfg_limits_t asked = {0};
    if (limits != NULL) asked = *limits;
    int rc = resolve_limit(asked.max_entities, UB_MAX_ENTITIES, "max_entities", &p.lim.max_entities, err, err_cap);
    if (rc == UB_OK)
        rc = resolve_limit(asked.max_links_per_entity, UB_MAX_LINKS_PER_ENTITY, "max_links_per_entity",
                           &p.lim.max_links_per_entity, err, err_cap);
    if (rc == UB_OK)
        rc = resolve_limit(asked.max_local_entities, UB_MAX_LOCAL_ENTITIES, "max_local_entities",
                           &p.lim.max_local_entities, err, err_cap);
    if (rc == UB_OK)
        rc = resolve_limit(asked.max_ports, UB_NODECFG_MAX_PORTS, "max_ports", &p.lim.max_ports, err, err_cap);
    if (rc == UB_OK)
        rc = resolve_limit(asked.max_port_params, UB_NODECFG_MAX_PORT_PARAMS, "max_port_params",
                           &p.lim.max_port_params, err, err_cap);
    if (rc != UB_OK) return rc;
    (void)snprintf(cfg->source, sizeof cfg->source, "%s", source_name);
    ub_json_value_t root;
    uint32_t line = 0;
    char why[160];
    rc = ub_json_parse(&p.doc, text, len, &root, &line, why, sizeof why);
    if (rc != UB_OK)
        rc = fail(&p, line, NULL, NULL, "%s", why);
    else
        rc = parse_document(&p, &root);
    if (rc != UB_OK) memset(cfg, 0, sizeof *cfg);
    return rc;
}

int ub_nodecfg_parse(ub_nodecfg_t *cfg, const char *text, size_t len, const char *source_name, char *err,
                     size_t err_cap) {
    return ub_nodecfg_parse_limits(cfg, text, len, source_name, NULL, err, err_cap);
}

/* POSIX read() rather than stdio: fopen() may allocate its FILE, and nothing
 * in the runtime library touches the heap (checked by ub_noalloc_nm). */
static int read_all(int fd, char *buf, size_t cap, size_t *len, bool *too_large) {
    *len = 0;
    for (;;) {
        char probe;
        char *to = *len < cap ? buf + *len : &probe;
        ssize_t n = read(fd, to, *len < cap ? cap - *len : 1);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) return UB_ERR_IO;
        if (n == 0) return UB_OK;
        if (*len >= cap) {
            *too_large = true;
            return UB_OK;
        }
        *len += (size_t)n;
    }
}

int ub_nodecfg_load_file(ub_nodecfg_t *cfg, const char *path, char *buf, size_t buf_cap, char *err,
                         size_t err_cap) {
    if (cfg == NULL || path == NULL || buf == NULL || (err == NULL && err_cap > 0)) return UB_ERR_INVAL;
    memset(cfg, 0, sizeof *cfg);
    int fd = open(path, O_RDONLY);
    if (fd < 0) {
        if (err_cap > 0) (void)snprintf(err, err_cap, "%s: cannot open: %s", path, strerror(errno));
        return UB_ERR_IO;
    }
    size_t len = 0;
    bool too_large = false;
    int rc = read_all(fd, buf, buf_cap, &len, &too_large);
    int read_errno = errno;
    (void)close(fd);
    if (rc != UB_OK) {
        if (err_cap > 0) (void)snprintf(err, err_cap, "%s: cannot read: %s", path, strerror(read_errno));
        return UB_ERR_IO;
    }
    if (too_large) {
        if (err_cap > 0)
            (void)snprintf(err, err_cap, "%s: file is larger than the %lu-byte buffer given to ub_nodecfg_load_file",
                           path, (unsigned long)buf_cap);
        return UB_ERR_NOSPACE;
    }
    return ub_nodecfg_parse(cfg, buf, len, path, err, err_cap);
}

int ub_nodecfg_select_node(ub_nodecfg_t *cfg, const char *node, char *err, size_t err_cap) {
    if (cfg == NULL || node == NULL || (err == NULL && err_cap > 0)) return UB_ERR_INVAL;
    for (int i = 0; i < cfg->node_count; i++) {
        if (strcmp(cfg->nodes[i].name, node) != 0) continue;
        cfg->host_count = cfg->nodes[i].entity_count;
        memcpy(cfg->hosts, cfg->nodes[i].entity, cfg->host_count);
        return UB_OK;
    }
    if (err_cap > 0) {
        size_t used = 0;
        appendf(err, err_cap, &used, "no node named '%s' in 'nodes' (known: ", echo(node, strlen(node)));
        for (int i = 0; i < cfg->node_count; i++)
            appendf(err, err_cap, &used, "%s%s", i ? ", " : "", cfg->nodes[i].name);
        appendf(err, err_cap, &used, "%s)", cfg->node_count == 0 ? "none" : "");
    }
    return UB_ERR_NOTFOUND;
}

int ub_nodecfg_find_entity(const ub_nodecfg_t *cfg, const char *name) {
    if (cfg == NULL || name == NULL) return UB_ERR_INVAL;
    return find_entity(cfg, name, strlen(name));
}

int ub_nodecfg_mask(const ub_nodecfg_t *cfg, const char *from, const char *to) {
    if (cfg == NULL || from == NULL || to == NULL) return UB_ERR_INVAL;
    int f = find_entity(cfg, from, strlen(from));
    int t = find_entity(cfg, to, strlen(to));
    if (f < 0 || t < 0) return UB_ERR_NOTFOUND;
    return cfg->entities[f].mask[t];
}

/* ---- applying to a node ---- */

static int apply_failed(const ub_nodecfg_t *cfg, char *err, size_t err_cap, const ub_nodecfg_entity_t *e,
                        const char *field, const char *fmt, ...) {
    if (err_cap == 0) return UB_ERR_CONFIG;
    size_t used = 0;
    if (e != NULL)
        appendf(err, err_cap, &used, "%s:%lu: entity '%s', ", cfg->source, (unsigned long)e->line, e->name);
    else
        appendf(err, err_cap, &used, "%s: ", cfg->source);
    appendf(err, err_cap, &used, "field '%s': ", field);
    va_list ap;
    va_start(ap, fmt);
    append(err, err_cap, &used, fmt, ap);
    va_end(ap);
    return UB_ERR_CONFIG;
}

static bool is_hosted(const ub_nodecfg_t *cfg, int entity) {
    for (int h = 0; h < cfg->host_count; h++)
        if (cfg->hosts[h] == entity) return true;
    return false;
}

static int apply_links(const ub_nodecfg_t *cfg, ub_node_t *node, int index, int node_entity, char *err,
                       size_t err_cap) {
    const ub_nodecfg_entity_t *e = &cfg->entities[index];
    char field[32];
    for (int i = 0; i < e->link_count; i++) {
        (void)snprintf(field, sizeof field, "links[%d]", i);
        int rc = ub_node_add_link(node, node_entity, (unsigned)i, e->links[i]);
        if (rc == UB_ERR_EXISTS)
            return apply_failed(cfg, err, err_cap, e, field,
                                "link '%s' already exists in this node (another hosted entity has a link of that "
                                "name; rename one)", e->links[i]);
        if (rc == UB_ERR_FULL)
            return apply_failed(cfg, err, err_cap, e, field,
                                "the node holds at most %d links in all (raise UB_MAX_NODE_LINKS in ub_config.h)",
                                UB_MAX_NODE_LINKS);
        if (rc < 0)
            return apply_failed(cfg, err, err_cap, e, field, "the node refused link '%s': %s (names are at most %d "
                                "characters here: UB_LINK_NAME_LEN)", e->links[i], ub_strerror(rc),
                                UB_LINK_NAME_LEN - 1);
    }
    return UB_OK;
}

int ub_nodecfg_apply(const ub_nodecfg_t *cfg, struct ub_node *node, char *err, size_t err_cap) {
    if (cfg == NULL || node == NULL || (err == NULL && err_cap > 0)) return UB_ERR_INVAL;
    int node_index[UB_MAX_ENTITIES];
    if (cfg->host_count == 0)
        return apply_failed(cfg, err, err_cap, NULL, "hosts",
                            "this process hosts no entity: list them in 'hosts' or select one of 'nodes'");
    for (int i = 0; i < cfg->entity_count; i++) {
        const ub_nodecfg_entity_t *e = &cfg->entities[i];
        node_index[i] = ub_node_add_entity_name(node, e->name, is_hosted(cfg, i));
        if (node_index[i] == UB_ERR_EXISTS)
            return apply_failed(cfg, err, err_cap, e, "name", "the node already has an entity of this name");
        if (node_index[i] < 0)
            return apply_failed(cfg, err, err_cap, e, "name",
                                "the node refused the entity: %s (its tables hold %d entities, %d of them local)",
                                ub_strerror(node_index[i]), UB_MAX_ENTITIES, UB_MAX_LOCAL_ENTITIES);
    }
    for (int h = 0; h < cfg->host_count; h++) {
        int i = cfg->hosts[h];
        int rc = apply_links(cfg, node, i, node_index[i], err, err_cap);
        if (rc != UB_OK) return rc;
        for (int j = 0; j < cfg->entity_count; j++) {
            rc = ub_node_set_mask(node, node_index[i], node_index[j], cfg->entities[i].mask[j]);
            if (rc != UB_OK) /* validated masks: only a node not built from this table gets here */
                return apply_failed(cfg, err, err_cap, &cfg->entities[i], "linktoentity",
                                    "the node refused the mask toward '%s': %s", cfg->entities[j].name,
                                    ub_strerror(rc));
        }
    }
    if (cfg->has_policy) ub_node_set_policy(node, &cfg->policy);
    return UB_OK;
}

/* ---- applying the security section ---- */

/* `path` as written in the file, relative to the config file's directory; "{entity}" expanded. */
static int resolve_path(const ub_nodecfg_t *cfg, const char *path, const char *entity, char *out, size_t cap) {
    size_t used = 0;
    const char *slash = strrchr(cfg->source, '/');
    if (path[0] != '/' && slash != NULL) appendf(out, cap, &used, "%.*s/", (int)(slash - cfg->source), cfg->source);
    else out[0] = '\0';
    for (const char *c = path; *c != '\0'; c++) {
        if (entity != NULL && strncmp(c, "{entity}", 8) == 0) {
            appendf(out, cap, &used, "%s", entity);
            c += 7;
        } else {
            appendf(out, cap, &used, "%c", *c);
        }
    }
    return used < cap ? UB_OK : UB_ERR_RANGE;
}

#if defined(__GNUC__)
__attribute__((format(printf, 6, 7)))
#endif
static int sec_failed(const ub_nodecfg_t *cfg, char *err, size_t err_cap, uint32_t line, const char *field,
                      const char *fmt, ...) {
    if (err_cap == 0) return UB_ERR_CONFIG;
    size_t used = 0;
    appendf(err, err_cap, &used, "%s:%lu: field '%s': ", cfg->source, (unsigned long)line, field);
    va_list ap;
    va_start(ap, fmt);
    append(err, err_cap, &used, fmt, ap);
    va_end(ap);
    return UB_ERR_CONFIG;
}

int ub_nodecfg_apply_security(const ub_nodecfg_t *cfg, struct ub_node *node, struct ub_sec *sec,
                              struct ub_counter_file *counter, const struct ub_sec_options *opt, uint64_t unix_us,
                              char *err, size_t err_cap) {
    if (cfg == NULL || node == NULL || sec == NULL || counter == NULL || (err == NULL && err_cap > 0))
        return UB_ERR_INVAL;
    const ub_nodecfg_security_t *s = &cfg->security;
    if (!s->present) return UB_OK;
    char path[UB_SECFILE_PATH_MAX], why[UB_SECFILE_ERR_LEN], field[48];
    if (cfg->host_count == 0)
        return sec_failed(cfg, err, err_cap, s->line, "security", "this process hosts no entity (apply the table first)");
    ub_sec_options_t o = {0};
    if (opt != NULL) o = *opt;
    o.reserve = ub_counter_file_reserve;
    o.reserve_user = counter;
    int rc = ub_sec_init(sec, &o);
    if (rc == UB_ERR_UNSUPPORTED)
        return sec_failed(cfg, err, err_cap, s->line, "security",
                          "this build has no security (UAVBUS_SECURITY=OFF): rebuild with libsodium or remove the section");
    if (rc != UB_OK) return sec_failed(cfg, err, err_cap, s->line, "security", "libsodium failed to initialise");
    uint8_t first_id = 0;
    for (int k = 0; k < s->key_count; k++) {
        (void)snprintf(field, sizeof field, "security.keys[%d]", k);
        if (resolve_path(cfg, s->keys[k], NULL, path, sizeof path) != UB_OK)
            return sec_failed(cfg, err, err_cap, s->key_lines[k], field, "path too long");
        uint8_t id = 0, key[UB_SEC_KEY_LEN];
        rc = ub_keyfile_load(path, &id, key, why, sizeof why);
        if (rc != UB_OK) return sec_failed(cfg, err, err_cap, s->key_lines[k], field, "%s", why);
        rc = ub_sec_add_key(sec, id, key);
        memset(key, 0, sizeof key);
        if (rc == UB_ERR_EXISTS)
            return sec_failed(cfg, err, err_cap, s->key_lines[k], field,
                              "%s: key id %u is already used by another key file here (give each key its own id)", path,
                              (unsigned)id);
        if (rc != UB_OK)
            return sec_failed(cfg, err, err_cap, s->key_lines[k], field, "%s: refused: %s", path, ub_strerror(rc));
        if (k == 0) first_id = id;
    }
    uint8_t tx = s->tx_key != 0 ? s->tx_key : first_id;
    if (ub_sec_set_tx_key(sec, tx) != UB_OK)
        return sec_failed(cfg, err, err_cap, s->tx_key_line, "security.tx_key",
                          "no key file given has id %u (tx_key names the id=N of one of 'keys')", (unsigned)tx);
    const char *entity = cfg->entities[cfg->hosts[0]].name;
    if (resolve_path(cfg, s->counter_file, entity, path, sizeof path) != UB_OK)
        return sec_failed(cfg, err, err_cap, s->counter_file_line, "security.counter_file", "path too long");
    uint64_t mark = 0;
    rc = ub_counter_file_open(counter, path, &mark, why, sizeof why);
    if (rc != UB_OK) return sec_failed(cfg, err, err_cap, s->counter_file_line, "security.counter_file", "%s", why);
    if (ub_sec_start(sec, mark, ub_sec_wall_counter(unix_us)) != UB_OK)
        return sec_failed(cfg, err, err_cap, s->counter_file_line, "security.counter_file",
                          "%s: the counter is exhausted (48 bits): use a new key", path);
    /* Reserve now, so a counter file that cannot be written stops the start rather than the first frame. */
    uint64_t probe;
    if (ub_sec_next_counter(sec, &probe) != UB_OK)
        return sec_failed(cfg, err, err_cap, s->counter_file_line, "security.counter_file",
                          "%s: cannot store the counter reservation (%s): the directory must exist and be writable",
                          path, strerror(counter->last_errno));
    if (ub_node_set_require_signed(node, s->require_signed != 0) != UB_OK) return UB_ERR_INVAL;
    for (int i = 0; i < s->link_count; i++) {
        const ub_nodecfg_link_security_t *ls = &s->links[i];
        const char *colon = strchr(ls->name, ':');
        int link = ub_node_find_link(node, colon != NULL ? colon + 1 : ls->name);
        if (link < 0) continue; /* a link of another process */
        if (colon != NULL) {
            uint8_t id[UB_ENTITY_ID_LEN];
            char ename[UB_ENTITY_ID_LEN + 1];
            size_t n = (size_t)(colon - ls->name);
            memcpy(ename, ls->name, n);
            ename[n] = '\0';
            const ub_link_t *l = ub_node_link(node, link);
            if (ub_entity_id(ename, id) != UB_OK || l == NULL ||
                memcmp(ub_node_entity_id(node, node->locals[l->owner].entity), id, UB_ENTITY_ID_LEN) != 0)
                continue; /* same link name, but another entity's */
        }
        (void)snprintf(field, sizeof field, "security.links.%.24s", ls->name);
        if (ub_node_link_set_security(node, link, ls->require_signed, ls->encrypt != 0) != UB_OK)
            return sec_failed(cfg, err, err_cap, ls->line, field, "the node refused the setting");
    }
    rc = ub_node_set_security(node, sec);
    if (rc != UB_OK)
        return sec_failed(cfg, err, err_cap, s->line, "security", "the node refused the context: %s", ub_strerror(rc));
    return UB_OK;
}

/* ---- identity files (issue 23) ---- */

int ub_nodecfg_load_identity(const ub_nodecfg_t *cfg, struct ub_ident_store *store, uint64_t now_s,
                             char *revocations_path, size_t path_cap, char *err, size_t err_cap) {
    if (cfg == NULL || store == NULL || (err == NULL && err_cap > 0)) return UB_ERR_INVAL;
    const ub_nodecfg_identity_t *id = &cfg->identity;
    if (!id->present) return UB_OK;
    const char *entity = cfg->host_count > 0 ? cfg->entities[cfg->hosts[0]].name : NULL;
    char ident[UB_SECFILE_PATH_MAX], auth[UB_SECFILE_PATH_MAX], revs[UB_SECFILE_PATH_MAX], why[UB_IDENTFILE_ERR_LEN];
    if (resolve_path(cfg, id->authority, entity, auth, sizeof auth) != UB_OK)
        return sec_failed(cfg, err, err_cap, id->authority_line, "security.authority", "path too long");
    if (id->identity[0] != '\0' && resolve_path(cfg, id->identity, entity, ident, sizeof ident) != UB_OK)
        return sec_failed(cfg, err, err_cap, id->identity_line, "security.identity", "path too long");
    if (id->revocations[0] != '\0' && resolve_path(cfg, id->revocations, entity, revs, sizeof revs) != UB_OK)
        return sec_failed(cfg, err, err_cap, id->revocations_line, "security.revocations", "path too long");
    why[0] = '\0';
    int rc = ub_identfile_load_store(store, id->identity[0] != '\0' ? ident : NULL, auth,
                                     id->revocations[0] != '\0' ? revs : NULL, now_s, why, sizeof why);
#if UB_MAX_LOCAL_ENTITIES > 1
    /* "{entity}" in the identity path: every hosted entity has its own identity (the first is loaded above). */
    for (int h = 1; rc == UB_OK && id->identity[0] != '\0' && strstr(id->identity, "{entity}") != NULL &&
                    h < cfg->host_count && h < UB_MAX_LOCAL_ENTITIES; h++) {
        if (resolve_path(cfg, id->identity, cfg->entities[cfg->hosts[h]].name, ident, sizeof ident) != UB_OK)
            return sec_failed(cfg, err, err_cap, id->identity_line, "security.identity", "path too long");
        rc = ub_identfile_load_self(store, ident, id->revocations[0] != '\0' ? revs : NULL, now_s, why, sizeof why);
    }
#endif
    if (rc != UB_OK) {
        /* The line of the field naming the file that was refused. */
        size_t n = strlen(auth);
        uint32_t line = id->authority_line;
        const char *field = "security.authority";
        if (id->revocations[0] != '\0' && strncmp(why, revs, strlen(revs)) == 0 && why[strlen(revs)] == ':') {
            line = id->revocations_line;
            field = "security.revocations";
        } else if (id->identity[0] != '\0' && !(strncmp(why, auth, n) == 0 && why[n] == ':')) {
            line = id->identity_line;
            field = "security.identity";
        }
        (void)sec_failed(cfg, err, err_cap, line, field, "%s", why);
        return rc;
    }
    if (id->certificates[0] != '\0') {
        char certs[UB_SECFILE_PATH_MAX];
        if (resolve_path(cfg, id->certificates, entity, certs, sizeof certs) != UB_OK)
            return sec_failed(cfg, err, err_cap, id->certificates_line, "security.certificates", "path too long");
        rc = ub_certfile_load(certs, store, now_s, why, sizeof why);
        if (rc < 0) {
            (void)sec_failed(cfg, err, err_cap, id->certificates_line, "security.certificates", "%s", why);
            return rc;
        }
    }
    if (revocations_path != NULL && path_cap > 0) {
        const char *r = id->revocations[0] != '\0' ? revs : "";
        if (strlen(r) >= path_cap)
            return sec_failed(cfg, err, err_cap, id->revocations_line, "security.revocations", "path too long");
        memcpy(revocations_path, r, strlen(r) + 1);
    }
    return UB_OK;
}

int ub_nodecfg_apply_identity(ub_nodecfg_t *cfg, struct ub_node *node, struct ub_ident_store *store, uint64_t now_s,
                              char *revocations_path, size_t path_cap, char *err, size_t err_cap) {
    if (cfg == NULL || node == NULL) return UB_ERR_INVAL;
    int rc = ub_nodecfg_load_identity(cfg, store, now_s, revocations_path, path_cap, err, err_cap);
    if (rc != UB_OK || !cfg->identity.present) return rc;
    if (!cfg->has_policy) {
        ub_policy_init(&cfg->policy);
        cfg->has_policy = 1;
    }
    ub_policy_use_roles(&cfg->policy, ub_ident_roles_now, store);
    ub_node_set_policy(node, &cfg->policy);
    return UB_OK;
}

int ub_nodecfg_certificates_path(const ub_nodecfg_t *cfg, char *out, size_t cap) {
    if (cfg == NULL || out == NULL || cap == 0) return UB_ERR_INVAL;
    out[0] = '\0';
    if (!cfg->identity.present || cfg->identity.certificates[0] == '\0') return UB_OK;
    const char *entity = cfg->host_count > 0 ? cfg->entities[cfg->hosts[0]].name : NULL;
    return resolve_path(cfg, cfg->identity.certificates, entity, out, cap);
}
