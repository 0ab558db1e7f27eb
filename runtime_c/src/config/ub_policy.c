#include "ub/ub_policy.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "ub/ub_frame.h"
#include "ub/ub_ident.h"
#include "config/ub_nodecfg_private.h"

/* ---- the policy ---------------------------------------------------------- */

static uint32_t or_default(uint32_t value, uint32_t fallback) { return value != 0 ? value : fallback; }

static const ub_policy_limits_t DEFAULT_LIMITS = {UB_POLICY_DEFAULT_MIN_PERIOD_MS, UB_POLICY_DEFAULT_MAX_ROWS,
                                                  UB_POLICY_DEFAULT_MAX_BYTES_PER_S, UB_POLICY_DEFAULT_MAX_LEASE_MS};
static const ub_policy_limits_t DEFAULT_ADMIN_LIMITS = {
    UB_POLICY_DEFAULT_ADMIN_MIN_PERIOD_MS, UB_POLICY_DEFAULT_ADMIN_MAX_ROWS, UB_POLICY_DEFAULT_ADMIN_MAX_BYTES_PER_S,
    UB_POLICY_DEFAULT_ADMIN_MAX_LEASE_MS};

static void fill_limits(ub_policy_limits_t *out, const ub_policy_limits_t *l, const ub_policy_limits_t *defaults) {
    out->min_period_ms = or_default(l->min_period_ms, defaults->min_period_ms);
    out->max_rows = or_default(l->max_rows, defaults->max_rows);
    out->max_bytes_per_s = or_default(l->max_bytes_per_s, defaults->max_bytes_per_s);
    out->max_lease_ms = or_default(l->max_lease_ms, defaults->max_lease_ms);
}

void ub_policy_init(ub_policy_t *pol) {
    if (pol == NULL) return;
    memset(pol, 0, sizeof *pol);
    pol->limits = DEFAULT_LIMITS;
    pol->admin_limits = DEFAULT_ADMIN_LIMITS;
}

static bool listed(const ub_policy_t *pol, const uint8_t *id) {
    for (unsigned a = 0; a < pol->n_admins; a++)
        if (memcmp(pol->admins[a], id, UB_ENTITY_ID_LEN) == 0) return true;
    return false;
}

int ub_policy_set_limits(ub_policy_t *pol, const ub_policy_limits_t *limits) {
    if (pol == NULL || limits == NULL) return UB_ERR_INVAL;
    if (limits->max_lease_ms != 0 && limits->max_lease_ms < UB_POLICY_MIN_LEASE_MS) return UB_ERR_RANGE;
    fill_limits(&pol->limits, limits, &DEFAULT_LIMITS);
    return UB_OK;
}

int ub_policy_set_admin_limits(ub_policy_t *pol, const ub_policy_limits_t *limits) {
    if (pol == NULL || limits == NULL) return UB_ERR_INVAL;
    if (limits->max_lease_ms != 0 && limits->max_lease_ms < UB_POLICY_MIN_LEASE_MS) return UB_ERR_RANGE;
    fill_limits(&pol->admin_limits, limits, &DEFAULT_ADMIN_LIMITS);
    return UB_OK;
}

const ub_policy_limits_t *ub_policy_limits_for(const ub_policy_t *pol, bool admin) {
    if (pol == NULL) return admin ? &DEFAULT_ADMIN_LIMITS : &DEFAULT_LIMITS;
    return admin ? &pol->admin_limits : &pol->limits;
}

int ub_policy_add_admin(ub_policy_t *pol, const uint8_t id[UB_ENTITY_ID_LEN]) {
    if (pol == NULL || id == NULL) return UB_ERR_INVAL;
    if (listed(pol, id)) return UB_ERR_EXISTS;
    if (pol->n_admins >= UB_POLICY_MAX_ADMINS) return UB_ERR_FULL;
    memcpy(pol->admins[pol->n_admins++], id, UB_ENTITY_ID_LEN);
    return UB_OK;
}

static bool is_pattern_char(char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '.' ||
           c == '-' || c == '[' || c == ']' || c == '*';
}

bool ub_policy_pattern_ok(const char *pattern, size_t max) {
    if (pattern == NULL) return false;
    size_t n = strlen(pattern);
    if (n == 0 || n > max) return false;
    for (size_t i = 0; i < n; i++)
        if (!is_pattern_char(pattern[i])) return false;
    return true;
}

int ub_policy_add_rule(ub_policy_t *pol, ub_policy_dir_t dir, const char *target, const char *from,
                       const char *content) {
    if (pol == NULL || (dir != UB_POLICY_READ && dir != UB_POLICY_WRITE)) return UB_ERR_INVAL;
    if (!ub_policy_pattern_ok(target, UB_POLICY_ENTITY_PATTERN_MAX) ||
        !ub_policy_pattern_ok(from, UB_POLICY_ENTITY_PATTERN_MAX) ||
        !ub_policy_pattern_ok(content, UB_POLICY_PATTERN_MAX))
        return UB_ERR_INVAL;
    if (pol->n_rules >= UB_POLICY_MAX_RULES) return UB_ERR_FULL;
    ub_policy_rule_t *r = &pol->rules[pol->n_rules++];
    memset(r, 0, sizeof *r);
    r->dir = (uint8_t)dir;
    memcpy(r->target, target, strlen(target) + 1);
    memcpy(r->from, from, strlen(from) + 1);
    memcpy(r->content, content, strlen(content) + 1);
    if (dir == UB_POLICY_READ) pol->read_restricted = 1;
    return UB_OK;
}

void ub_policy_set_exclusive(ub_policy_t *pol, bool on) {
    if (pol != NULL) pol->exclusive_admin = on ? 1 : 0;
}

void ub_policy_restrict_reads(ub_policy_t *pol) {
    if (pol != NULL) pol->read_restricted = 1;
}

void ub_policy_use_roles(ub_policy_t *pol, ub_policy_roles_fn roles, void *user) {
    if (pol == NULL) return;
    pol->roles = roles;
    pol->roles_user = user;
}

bool ub_policy_is_admin(const ub_policy_t *pol, const uint8_t id[UB_ENTITY_ID_LEN]) {
    if (pol == NULL || id == NULL) return false;
    if (pol->roles != NULL) {
        /* Identity per entity: the certificate decides; a list of names, if any, only narrows it. */
        uint16_t roles = 0;
        if (pol->roles(pol->roles_user, id, &roles) != UB_OK || (roles & UB_ROLE_ADMIN) == 0) return false;
        return pol->n_admins == 0 || listed(pol, id);
    }
    return listed(pol, id);
}

/* Iterative glob with one backtrack point: on a mismatch after a `*`, the star takes one more character. */
bool ub_policy_match(const char *pattern, const char *text, size_t len) {
    if (pattern == NULL || (text == NULL && len > 0)) return false;
    size_t p = 0, t = 0, star = SIZE_MAX, mark = 0;
    while (t < len) {
        if (pattern[p] == '*') {
            star = p++;
            mark = t;
        } else if (pattern[p] != '\0' && pattern[p] == text[t]) {
            p++;
            t++;
        } else if (star != SIZE_MAX) {
            p = star + 1;
            t = ++mark;
        } else {
            return false;
        }
    }
    while (pattern[p] == '*') p++;
    return pattern[p] == '\0';
}

/* An entity ID is its name padded with NUL bytes. */
static size_t id_name_len(const uint8_t id[UB_ENTITY_ID_LEN]) {
    const void *nul = memchr(id, 0, UB_ENTITY_ID_LEN);
    return nul != NULL ? (size_t)((const uint8_t *)nul - id) : UB_ENTITY_ID_LEN;
}

static bool match_id(const char *pattern, const uint8_t id[UB_ENTITY_ID_LEN]) {
    return ub_policy_match(pattern, (const char *)id, id_name_len(id));
}

bool ub_policy_rule_matches(const ub_policy_t *pol, ub_policy_dir_t dir, const uint8_t target[UB_ENTITY_ID_LEN],
                            const uint8_t from[UB_ENTITY_ID_LEN], const char *content) {
    if (pol == NULL || target == NULL || from == NULL || content == NULL) return false;
    size_t content_len = strlen(content);
    for (unsigned i = 0; i < pol->n_rules; i++) {
        const ub_policy_rule_t *r = &pol->rules[i];
        if (r->dir == (uint8_t)dir && match_id(r->target, target) && match_id(r->from, from) &&
            ub_policy_match(r->content, content, content_len))
            return true;
    }
    return false;
}

uint64_t ub_policy_row_bytes_per_s(uint32_t packed_size, uint32_t period_ms) {
    if (period_ms == 0) return UINT64_MAX;
    uint64_t per_frame = (uint64_t)UB_FRAME_HEADER_LEN + packed_size;
    return (per_frame * 1000u + period_ms - 1u) / period_ms;
}

/* ---- configuration: the "security" keys administrators, read, write, limits, admin_limits ----
 * Called by the config loader (ub_nodecfg.c, parse_security()) for each of these keys it finds; the
 * frame-security keys of the same section are parsed elsewhere. Format: docs/config-format.md. */

#define KEY_BUF 64 /* > every pattern limit, so "fits" is checked on the decoded length */

typedef struct cfg_parse {
    ub_policy_t *pol;
    const ub_nodecfg_t *cfg;
    const ub_json_doc_t *doc;
    ub_cfg_error_t *err;
} cfg_parse_t;

#if defined(__GNUC__)
__attribute__((format(printf, 5, 6)))
#endif
static int cfg_fail(const cfg_parse_t *c, uint32_t line, const char *entity, const char *field, const char *fmt, ...) {
    ub_cfg_error_t *e = c->err;
    e->line = line;
    (void)snprintf(e->entity, sizeof e->entity, "%s", entity != NULL ? entity : "");
    (void)snprintf(e->field, sizeof e->field, "%s", field);
    va_list ap;
    va_start(ap, fmt);
    (void)vsnprintf(e->message, sizeof e->message, fmt, ap);
    va_end(ap);
    return UB_ERR_CONFIG;
}

/* Decodes a string value; returns its length, or KEY_BUF when it is not a string, too long or holds a NUL. */
static size_t cfg_string(const cfg_parse_t *c, const ub_json_value_t *v, char buf[KEY_BUF]) {
    if (v->kind != UB_JSON_STRING) return KEY_BUF;
    size_t n = ub_json_string(c->doc, v, buf, KEY_BUF);
    return n < KEY_BUF && strlen(buf) == n ? n : KEY_BUF;
}

static bool cfg_has_entity(const ub_nodecfg_t *cfg, const char *name) {
    for (int i = 0; i < cfg->entity_count; i++)
        if (strcmp(cfg->entities[i].name, name) == 0) return true;
    return false;
}

/* A pattern of at most `max` characters; `shape` says what is expected when it is not one. */
static int cfg_pattern(const cfg_parse_t *c, const ub_json_value_t *v, const char *entity, const char *field,
                       size_t max, const char *shape, char *out) {
    char buf[KEY_BUF];
    size_t n = cfg_string(c, v, buf);
    if (n > max || !ub_policy_pattern_ok(buf, max))
        return cfg_fail(c, v->line, entity, field, "must be %s (1 to %u characters from A-Z a-z 0-9 _ . - [ ] *)",
                        shape, (unsigned)max);
    memcpy(out, buf, n + 1);
    return UB_OK;
}

/* An entity reference: a name of 'entities', or a pattern with '*'. */
static int cfg_entity_pattern(const cfg_parse_t *c, const ub_json_value_t *v, const char *entity, const char *field,
                              char out[UB_POLICY_ENTITY_PATTERN_MAX + 1]) {
    int rc = cfg_pattern(c, v, entity, field, UB_POLICY_ENTITY_PATTERN_MAX,
                         "an entity name or a pattern such as \"gcs*\" or \"*\"", out);
    if (rc == UB_OK && strchr(out, '*') == NULL && !cfg_has_entity(c->cfg, out))
        return cfg_fail(c, v->line, entity, field, "no entity named '%s' in 'entities' (use '*' in a pattern)", out);
    return rc;
}

static int cfg_administrators(const cfg_parse_t *c, const ub_json_value_t *list) {
    ub_json_iter_t it;
    ub_json_value_t v;
    char field[96], name[KEY_BUF];
    uint8_t id[UB_ENTITY_ID_LEN];
    if (list->kind != UB_JSON_ARRAY)
        return cfg_fail(c, list->line, NULL, "security.administrators",
                        "must be a list of entity names (the entities with the exclusive rights)");
    ub_json_iter_begin(&it, c->doc, list);
    for (int k = 0; ub_json_iter_next(&it, NULL, &v); k++) {
        (void)snprintf(field, sizeof field, "security.administrators[%d]", k);
        size_t n = cfg_string(c, &v, name);
        /* The character check comes first: the name is quoted back below, and must be printable to be
         * (config-format.md: text from the file is quoted back only when it is safe). Found by fuzz_nodecfg. */
        if (n == 0 || n > UB_ENTITY_ID_LEN || !ub_policy_pattern_ok(name, UB_ENTITY_ID_LEN) || strchr(name, '*') != NULL
            || ub_entity_id(name, id) != UB_OK)
            return cfg_fail(c, v.line, NULL, field, "must be an entity name (administrators are named, not patterns)");
        if (!cfg_has_entity(c->cfg, name)) return cfg_fail(c, v.line, NULL, field, "no entity named '%s' in 'entities'", name);
        int rc = ub_policy_add_admin(c->pol, id);
        if (rc == UB_ERR_EXISTS) return cfg_fail(c, v.line, NULL, field, "entity '%s' is listed twice", name);
        if (rc == UB_ERR_FULL)
            return cfg_fail(c, v.line, NULL, field,
                            "too many administrators: this build holds %d (raise UB_POLICY_MAX_ADMINS in ub_config.h)",
                            UB_POLICY_MAX_ADMINS);
    }
    return UB_OK;
}

/* One element of "from" (an entity reference) or "content" (a directory name pattern). */
static int cfg_rule_item(const cfg_parse_t *c, const ub_json_value_t *v, const char *entity, const char *field,
                         bool is_entity, char out[UB_POLICY_PATTERN_MAX + 1]) {
    if (is_entity) return cfg_entity_pattern(c, v, entity, field, out);
    return cfg_pattern(c, v, entity, field, UB_POLICY_PATTERN_MAX, "a directory name or a pattern such as \"gcsMission*\"",
                       out);
}

/* "from" or "content" of a rule: one string or a non-empty list of strings. Returns the element count. */
static int cfg_rule_list(const cfg_parse_t *c, const ub_json_value_t *v, const char *entity, const char *field,
                         bool is_entity, char (*out)[UB_POLICY_PATTERN_MAX + 1], int cap) {
    if (v->kind != UB_JSON_ARRAY) {
        int rc = cfg_rule_item(c, v, entity, field, is_entity, out[0]);
        return rc == UB_OK ? 1 : rc;
    }
    char path[128];
    ub_json_iter_t it;
    ub_json_value_t e;
    int k = 0;
    ub_json_iter_begin(&it, c->doc, v);
    for (; ub_json_iter_next(&it, NULL, &e); k++) {
        (void)snprintf(path, sizeof path, "%s[%d]", field, k);
        if (k == cap)
            return cfg_fail(c, e.line, entity, path, "too many elements: at most %d (UB_POLICY_MAX_RULES)", cap);
        int rc = cfg_rule_item(c, &e, entity, path, is_entity, out[k]);
        if (rc != UB_OK) return rc;
    }
    if (k == 0) return cfg_fail(c, v->line, entity, field, "must not be empty (a rule that names nothing grants nothing)");
    return k;
}

static int cfg_rule(const cfg_parse_t *c, ub_policy_dir_t dir, const char *target, const char *entity,
                    const ub_json_value_t *obj, const char *path) {
    /* Room for every combination this rule could add; the policy's capacity is checked as they go in. */
    char from[UB_POLICY_MAX_RULES][UB_POLICY_PATTERN_MAX + 1];
    char content[UB_POLICY_MAX_RULES][UB_POLICY_PATTERN_MAX + 1];
    ub_json_value_t from_v = {0}, content_v = {0}, key, v;
    ub_json_iter_t it;
    char field[128], name[KEY_BUF];
    if (obj->kind != UB_JSON_OBJECT)
        return cfg_fail(c, obj->line, entity, path, "must be an object {\"from\": ..., \"content\": ...}");
    ub_json_iter_begin(&it, c->doc, obj);
    while (ub_json_iter_next(&it, &key, &v)) {
        size_t n = cfg_string(c, &key, name);
        ub_json_value_t *slot = n == 4 && strcmp(name, "from") == 0      ? &from_v
                                : n == 7 && strcmp(name, "content") == 0 ? &content_v
                                                                          : NULL;
        (void)snprintf(field, sizeof field, "%s.%s", path, slot != NULL ? name : "?");
        if (slot == NULL) return cfg_fail(c, key.line, entity, path, "unknown field (expected one of: from, content)");
        if (slot->kind != 0) return cfg_fail(c, key.line, entity, field, "duplicate field");
        *slot = v;
    }
    (void)snprintf(field, sizeof field, "%s.from", path);
    if (from_v.kind == 0)
        return cfg_fail(c, obj->line, entity, field,
                        dir == UB_POLICY_READ ? "missing (who may ask: an entity name, a pattern or a list)"
                                              : "missing (whose data may be written: an entity name, a pattern or a list)");
    int n_from = cfg_rule_list(c, &from_v, entity, field, true, from, UB_POLICY_MAX_RULES);
    if (n_from < 0) return n_from;
    (void)snprintf(field, sizeof field, "%s.content", path);
    if (content_v.kind == 0)
        return cfg_fail(c, obj->line, entity, field, "missing (directory names or patterns such as \"gpsOut*\")");
    int n_content = cfg_rule_list(c, &content_v, entity, field, false, content, UB_POLICY_MAX_RULES);
    if (n_content < 0) return n_content;
    for (int f = 0; f < n_from; f++) {
        for (int k = 0; k < n_content; k++) {
            if (ub_policy_add_rule(c->pol, dir, target, from[f], content[k]) != UB_OK)
                return cfg_fail(c, obj->line, entity, path,
                                "too many rules: this build holds %d read and write rules together, one per "
                                "(from, content) pair (raise UB_POLICY_MAX_RULES in ub_config.h)",
                                UB_POLICY_MAX_RULES);
            c->pol->rules[c->pol->n_rules - 1].line = obj->line;
        }
    }
    return UB_OK;
}

static int cfg_rules(const cfg_parse_t *c, ub_policy_dir_t dir, const ub_json_value_t *obj) {
    const char *section = dir == UB_POLICY_READ ? "security.read" : "security.write";
    ub_json_iter_t it, rit;
    ub_json_value_t key, v, rule;
    char path[128], field[96], target[UB_POLICY_ENTITY_PATTERN_MAX + 1];
    if (obj->kind != UB_JSON_OBJECT)
        return cfg_fail(c, obj->line, NULL, section,
                        "must be an object mapping entity names (or patterns) to lists of rules "
                        "[{\"from\": ..., \"content\": ...}]");
    if (dir == UB_POLICY_READ) ub_policy_restrict_reads(c->pol);
    ub_json_iter_begin(&it, c->doc, obj);
    while (ub_json_iter_next(&it, &key, &v)) {
        int rc = cfg_entity_pattern(c, &key, NULL, section, target);
        if (rc != UB_OK) return rc;
        const char *entity = strchr(target, '*') == NULL ? target : NULL;
        (void)snprintf(field, sizeof field, "%s.%s", section, target);
        if (v.kind != UB_JSON_ARRAY)
            return cfg_fail(c, v.line, entity, field, "must be a list of rules [{\"from\": ..., \"content\": ...}]");
        ub_json_iter_begin(&rit, c->doc, &v);
        for (int k = 0; ub_json_iter_next(&rit, NULL, &rule); k++) {
            (void)snprintf(path, sizeof path, "%s[%d]", field, k);
            if ((rc = cfg_rule(c, dir, target, entity, &rule, path)) != UB_OK) return rc;
        }
    }
    return UB_OK;
}

static const char *const LIMIT_FIELDS[] = {"min_period_ms", "max_rows", "max_bytes_per_s", "max_lease_ms"};

/* "limits" (every non-administrator) or "admin_limits" (every administrator): the same four fields. */
static int cfg_limits(const cfg_parse_t *c, const ub_json_value_t *obj, bool admin) {
    const char *section = admin ? "security.admin_limits" : "security.limits";
    ub_policy_limits_t l = {0};
    uint32_t *slots[] = {&l.min_period_ms, &l.max_rows, &l.max_bytes_per_s, &l.max_lease_ms};
    ub_json_iter_t it;
    ub_json_value_t key, v;
    char field[96], name[KEY_BUF];
    if (obj->kind != UB_JSON_OBJECT)
        return cfg_fail(c, obj->line, NULL, section,
                        "must be an object with min_period_ms, max_rows, max_bytes_per_s and/or max_lease_ms");
    ub_json_iter_begin(&it, c->doc, obj);
    while (ub_json_iter_next(&it, &key, &v)) {
        size_t n = cfg_string(c, &key, name);
        size_t k = 0;
        while (k < 4 && !(n < KEY_BUF && strcmp(LIMIT_FIELDS[k], name) == 0)) k++;
        if (k == 4)
            return cfg_fail(c, key.line, NULL, section,
                            "unknown field (expected one of: min_period_ms, max_rows, max_bytes_per_s, max_lease_ms)");
        (void)snprintf(field, sizeof field, "%s.%s", section, LIMIT_FIELDS[k]);
        if (*slots[k] != 0) return cfg_fail(c, key.line, NULL, field, "duplicate field");
        uint64_t value = 0;
        bool ok = v.kind == UB_JSON_NUMBER && v.end - v.start <= 10;
        for (size_t i = v.start; ok && i < v.end; i++) {
            char d = c->doc->text[i];
            ok = d >= '0' && d <= '9';
            value = value * 10u + (uint64_t)(d - '0');
        }
        if (!ok || value == 0 || value > UINT32_MAX)
            return cfg_fail(c, v.line, NULL, field, "must be a whole number from 1 to 4294967295");
        if (k == 3 && value < UB_POLICY_MIN_LEASE_MS)
            return cfg_fail(c, v.line, NULL, field,
                            "must be at least %u ms: a shorter lease lapses between two renewals (renew_ms 1000)",
                            UB_POLICY_MIN_LEASE_MS);
        *slots[k] = (uint32_t)value;
    }
    int rc = admin ? ub_policy_set_admin_limits(c->pol, &l) : ub_policy_set_limits(c->pol, &l);
    return rc == UB_OK ? UB_OK : cfg_fail(c, obj->line, NULL, section, "refused");
}

static int cfg_exclusive(const cfg_parse_t *c, const ub_json_value_t *v) {
    if (v->kind != UB_JSON_TRUE && v->kind != UB_JSON_FALSE)
        return cfg_fail(c, v->line, NULL, "security.exclusive_admin",
                        "must be true (one administrator at a time per node) or false");
    ub_policy_set_exclusive(c->pol, v->kind == UB_JSON_TRUE);
    return UB_OK;
}

int ub_priv_policy_parse_key(ub_policy_t *pol, const ub_nodecfg_t *cfg, const ub_json_doc_t *doc, const char *key,
                             const ub_json_value_t *value, ub_cfg_error_t *err) {
    cfg_parse_t c = {pol, cfg, doc, err};
    if (strcmp(key, "exclusive_admin") == 0) return cfg_exclusive(&c, value);
    if (strcmp(key, "administrators") == 0) return cfg_administrators(&c, value);
    if (strcmp(key, "read") == 0) return cfg_rules(&c, UB_POLICY_READ, value);
    if (strcmp(key, "write") == 0) return cfg_rules(&c, UB_POLICY_WRITE, value);
    if (strcmp(key, "limits") == 0) return cfg_limits(&c, value, false);
    if (strcmp(key, "admin_limits") == 0) return cfg_limits(&c, value, true);
    return UB_ERR_NOTFOUND;
}
