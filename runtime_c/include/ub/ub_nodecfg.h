/**
 * @file ub_nodecfg.h
 * @brief Node configuration: the paper's entity table (section III.D, Tables 1
 *        and 2) read from a JSON file, validated, into a caller-owned struct.
 *
 * The format is documented in docs/config-format.md and its structure in
 * schemas/config.schema.json. In short:
 *
 * @code{.json}
 * {
 *   "system": "hitl-table2",
 *   "entities": [
 *     {"name": "rmax1ob1",
 *      "links": ["onboardPortDatalink1", "onboardPortDatalink2", "onboardPortIPC"],
 *      "linktoentity": {"gcs1": "0x00000011", "rmax1ob2": ["onboardPortIPC"]}},
 *     {"name": "rmax1ob2", "links": ["onboard2PortIPC"], "linktoentity": ["0x1", "0x0", "0x1"]},
 *     {"name": "gcs1", "links": ["gcsPortDatalink1", "gcsPortDatalink2"],
 *      "linktoentity": ["0x00000011", "0x00000011", "0x00000000"]}
 *   ],
 *   "hosts": ["rmax1ob1"]
 * }
 * @endcode
 *
 * Link masks: bit i set = "send over this entity's link[i]". In the paper's hex
 * notation each hex digit is one link and must be 0 or 1, least-significant
 * digit = link 0 ("0x00000110" = links 1 and 2). Lists of link indices ([1, 2])
 * or link names (["onboardPortIPC"]) mean the same.
 *
 * Every error is reported as one line,
 *   "<file>:<line>: entity '<name>', field '<path>': <what is wrong and what to do>"
 * (the entity part only where one applies), e.g.
 *   "table2.json:7: entity 'gcs1', field 'linktoentity.fcs20': hex digit '2' is
 *    not 0 or 1 (each hex digit is one link: 0x00000110 means links 1 and 2)".
 * Python loads configurations through this loader too (runtime_py/uavbus/config.py
 * is a thin layer over it via cffi), so both languages report the same messages
 * for the same files (cases in tests/unit/config_cases/).
 *
 * Memory: ub_nodecfg_t is a plain value sized by ub_config.h and the limits
 * below. Nothing here allocates or keeps state outside the caller's structs.
 *
 * Example (set-up time; `cfg`, `node` and `text` are the caller's, e.g. static
 * storage of the application, since ub_nodecfg_t and ub_node_t are large):
 * @code
 *   char err[UB_NODECFG_ERR_LEN];
 *   if (ub_nodecfg_load_file(&cfg, "examples/configs/table2.json", text, sizeof text, err, sizeof err) != UB_OK
 *       || ub_nodecfg_select_node(&cfg, "gcs", err, sizeof err) != UB_OK
 *       || ub_node_init(&node, &my_catalogue, NULL) != UB_OK
 *       || ub_nodecfg_apply(&cfg, &node, err, sizeof err) != UB_OK) {
 *       fprintf(stderr, "%s\n", err);
 *       return 1;
 *   }
 *   int m = ub_nodecfg_mask(&cfg, "rmax1ob1", "gcs1");   // 0x03: links 0 and 1
 *   int l = ub_node_find_link(&node, "gcsPortDatalink1"); // then ub_node_link_attach(&node, l, ...)
 * @endcode
 */
#ifndef UB_NODECFG_H
#define UB_NODECFG_H

#include <stddef.h>
#include <stdint.h>

#include "ub_catalogue.h" /* UB_ENTITY_ID_LEN */
#include "ub_config.h"
#include "ub_error.h"
#include "ub_policy.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Limits of the config format itself. Overridable like ub_config.h; they are
 * documented in docs/config-format.md and mirrored in the JSON Schema. */
/** Longest link, node or port-parameter value name (the paper's link names are ~20). */
#ifndef UB_NODECFG_NAME_MAX
#define UB_NODECFG_NAME_MAX 31
#endif
/** Longest free text: "system", a port's parameter values. */
#ifndef UB_NODECFG_TEXT_MAX
#define UB_NODECFG_TEXT_MAX 63
#endif
/** Longest port key: a link name, optionally qualified "entity:link". */
#define UB_NODECFG_PORT_KEY_MAX (UB_ENTITY_ID_LEN + 1 + UB_NODECFG_NAME_MAX)
/** Longest transport or port-parameter name ("tcp", "connect"). */
#define UB_NODECFG_WORD_MAX 15
/** Entries of the "ports" section (reserved for the links issue). */
#ifndef UB_NODECFG_MAX_PORTS
#define UB_NODECFG_MAX_PORTS 32
#endif
/** Parameters per port besides "transport". */
#ifndef UB_NODECFG_MAX_PORT_PARAMS
#define UB_NODECFG_MAX_PORT_PARAMS 6
#endif
/** Entries of the "priorities" section (content pattern -> priority class, ub_prio.h). */
#ifndef UB_NODECFG_MAX_PRIORITIES
#define UB_NODECFG_MAX_PRIORITIES 16
#endif
/** Recommended size of the error-message buffers passed to this API (a config path of a few hundred characters
 *  and the longest message, the security section's list of fields, fit). */
#define UB_NODECFG_ERR_LEN 512

/* The loader (ub_nodecfg.c) counts entities and ports in uint8_t and refuses to build beyond 255; the types here
 * stay usable by code that only passes a configuration along (ub_policy.c, ub_ports.c), so a runtime built for a
 * larger in-process fleet (bench figure 8: 1000 vehicles, -DUB_MAX_ENTITIES=1024) needs only leave the loader out. */

/** One row of the entity table (the paper's "systemEntity"). */
typedef struct ub_nodecfg_entity {
    char name[UB_ENTITY_ID_LEN + 1]; /**< 1..12 chars of [A-Za-z0-9_.-]; the entity ID */
    uint8_t link_count;              /**< entries used in links[] */
    char links[UB_MAX_LINKS_PER_ENTITY][UB_NODECFG_NAME_MAX + 1]; /**< the paper's link[i] */
    /** mask[j]: links of this entity toward entities[j]; bit i = link[i]. mask[self] == 0. */
    uint8_t mask[UB_MAX_ENTITIES];
    uint32_t line; /**< line of the entity's object in the file */
} ub_nodecfg_entity_t;

/** A named group of entities one process hosts ("nodes" section). */
typedef struct ub_nodecfg_node {
    char name[UB_NODECFG_NAME_MAX + 1];
    uint8_t entity_count;
    uint8_t entity[UB_MAX_LOCAL_ENTITIES]; /**< indices into ub_nodecfg_t.entities */
} ub_nodecfg_node_t;

/** One extra parameter of a port, kept as text ("127.0.0.1:5001", "115200", "true"). */
typedef struct ub_nodecfg_port_param {
    char key[UB_NODECFG_WORD_MAX + 1];
    char value[UB_NODECFG_TEXT_MAX + 1];
} ub_nodecfg_port_param_t;

/** A "ports" entry: binds a link name to a transport. Shape-checked only. */
typedef struct ub_nodecfg_port {
    char name[UB_NODECFG_PORT_KEY_MAX + 1];
    char transport[UB_NODECFG_WORD_MAX + 1];
    uint8_t param_count;
    ub_nodecfg_port_param_t params[UB_NODECFG_MAX_PORT_PARAMS];
    uint32_t line;
} ub_nodecfg_port_t;

/** Longest source name kept for ub_nodecfg_apply()'s messages (longer ones are cut). */
#define UB_NODECFG_SOURCE_MAX 128

/** Longest path in the "security" section (key files, counter file), as written in the file. */
#ifndef UB_NODECFG_PATH_MAX
#define UB_NODECFG_PATH_MAX 160
#endif

/** Per-link security settings ("security.links"): receive policy and encryption. */
typedef struct ub_nodecfg_link_security {
    char name[UB_NODECFG_PORT_KEY_MAX + 1]; /**< link name, or "entity:link" as in "ports" */
    int8_t require_signed;                  /**< 1 / 0, or -1 when not given (the node's policy) */
    uint8_t encrypt;                        /**< send ENCRYPTED only (and accept only that where signing is required) */
    uint32_t line;
} ub_nodecfg_link_security_t;

/**
 * The frame-security part of the "security" section (docs/config-format.md#security,
 * docs/security.md). Key files are read, and the counter file opened, only by
 * ub_nodecfg_apply_security().
 */
typedef struct ub_nodecfg_security {
    uint8_t present;                                 /**< the file has a "security" section */
    uint32_t line;
    uint8_t key_count;
    char keys[UB_MAX_KEYS][UB_NODECFG_PATH_MAX + 1]; /**< key files; relative to the config file's directory */
    uint32_t key_lines[UB_MAX_KEYS];
    uint8_t tx_key;                                  /**< id of the key that signs; 0 = the first key file's */
    uint32_t tx_key_line;
    uint8_t require_signed;                          /**< node-wide receive policy; default true */
    char counter_file[UB_NODECFG_PATH_MAX + 1];      /**< "{entity}" = the first hosted entity's name */
    uint32_t counter_file_line;
    uint8_t link_count;
    ub_nodecfg_link_security_t links[UB_NODECFG_MAX_PORTS];
} ub_nodecfg_security_t;

/**
 * Identity per entity (issue 23; docs/security.md "Identity per entity"): "security.identity" (this node's
 * identity file, "{entity}" = the first hosted entity's name), "security.authority" (the authority's
 * public file), "security.revocations" (the revocations file, read and kept up to date),
 * "security.certificates" (the fleet's certificates file: the peers this node knows). Read only by
 * ub_nodecfg_load_identity().
 */
typedef struct ub_nodecfg_identity {
    uint8_t present;                            /**< "authority" given (it is what turns identities on) */
    char identity[UB_NODECFG_PATH_MAX + 1];     /**< "" when not given: the node verifies others only */
    char authority[UB_NODECFG_PATH_MAX + 1];
    char revocations[UB_NODECFG_PATH_MAX + 1];  /**< "" when not given */
    char certificates[UB_NODECFG_PATH_MAX + 1]; /**< "" when not given */
    uint32_t identity_line, authority_line, revocations_line, certificates_line;
} ub_nodecfg_identity_t;

/** A parsed, validated configuration. Caller-owned; no pointers into the source text. */
typedef struct ub_nodecfg {
    char source[UB_NODECFG_SOURCE_MAX]; /**< the source name given to the parser, for messages */
    char system[UB_NODECFG_TEXT_MAX + 1]; /**< "" if the file gives none */
    uint8_t entity_count;
    ub_nodecfg_entity_t entities[UB_MAX_ENTITIES]; /**< in file order: the paper's index i */
    uint8_t host_count;
    uint8_t hosts[UB_MAX_LOCAL_ENTITIES]; /**< entities this process hosts (indices) */
    uint8_t node_count;
    ub_nodecfg_node_t nodes[UB_MAX_ENTITIES]; /**< each entity is in at most one node */
    uint8_t port_count;
    ub_nodecfg_port_t ports[UB_NODECFG_MAX_PORTS];
    /** 1 when the "security" section gives any of administrators, read, write, limits: then `policy`
     *  holds them (ub_policy.h) and ub_nodecfg_apply() attaches it to the node. */
    uint8_t has_policy;
    ub_policy_t policy;
    ub_nodecfg_security_t security;
    ub_nodecfg_identity_t identity;
    /** "priorities": content-name patterns and their class (ub_prio.h), in file order; applied by
     *  ub_nodecfg_apply_priorities(). */
    uint8_t priority_count;
    struct {
        char content[UB_POLICY_PATTERN_MAX + 1]; /**< catalogue instance name pattern (`*` = any run) */
        uint8_t cls;                             /**< ub_prio_class_t */
        uint32_t line;
    } priorities[UB_NODECFG_MAX_PRIORITIES];
} ub_nodecfg_t;

/**
 * Parses and validates a configuration held in `text[0, len)` (need not be
 * NUL-terminated). `source_name` names it in messages (normally the path).
 * On success `cfg` holds the configuration, with hosts taken from "hosts"
 * (possibly none: see ub_nodecfg_select_node()).
 * @retval UB_OK
 * @retval UB_ERR_CONFIG invalid JSON or configuration; `err` says where and why.
 *                       `cfg` is zeroed.
 * @retval UB_ERR_INVAL  a NULL pointer argument (err_cap may be 0; err then unused).
 */
UB_CHECK int ub_nodecfg_parse(ub_nodecfg_t *cfg, const char *text, size_t len, const char *source_name,
                              char *err, size_t err_cap);

/**
 * Capacities a configuration is checked against, for checking a file meant
 * for a smaller build (a microcontroller's ub_config.h) from a bigger one.
 * Each field is at most the build's own capacity; 0 means the build's value.
 */
typedef struct ub_nodecfg_limits {
    uint8_t max_entities;         /**< UB_MAX_ENTITIES: entities per file, and nodes */
    uint8_t max_links_per_entity; /**< UB_MAX_LINKS_PER_ENTITY */
    uint8_t max_local_entities;   /**< UB_MAX_LOCAL_ENTITIES: hosts, and entities per node */
    uint8_t max_ports;            /**< UB_NODECFG_MAX_PORTS */
    uint8_t max_port_params;      /**< UB_NODECFG_MAX_PORT_PARAMS */
} ub_nodecfg_limits_t;

/** Fills `limits` with this build's capacities. */
void ub_nodecfg_build_limits(ub_nodecfg_limits_t *limits);

/**
 * ub_nodecfg_parse() against `limits` (NULL: the build's capacities). A file
 * beyond a limit gets the same message as beyond the build's capacity, with
 * the smaller number.
 * @retval UB_ERR_RANGE a limit above the build's capacity (`err` names it).
 * @retval others as ub_nodecfg_parse().
 */
UB_CHECK int ub_nodecfg_parse_limits(ub_nodecfg_t *cfg, const char *text, size_t len, const char *source_name,
                                     const ub_nodecfg_limits_t *limits, char *err, size_t err_cap);

/**
 * Reads file `path` into the caller's `buf` (at most `buf_cap` bytes) and
 * parses it with `source_name` = path.
 * @retval UB_OK
 * @retval UB_ERR_IO      the file cannot be opened or read ("<path>: cannot open: <reason>").
 * @retval UB_ERR_NOSPACE the file is larger than `buf_cap`.
 * @retval UB_ERR_CONFIG, UB_ERR_INVAL as ub_nodecfg_parse().
 */
UB_CHECK int ub_nodecfg_load_file(ub_nodecfg_t *cfg, const char *path, char *buf, size_t buf_cap, char *err,
                                  size_t err_cap);

/**
 * Makes the entities of node `node` (from the "nodes" section) this process's
 * hosts, replacing what "hosts" said.
 * @retval UB_OK
 * @retval UB_ERR_NOTFOUND no such node; `err` lists the known ones.
 * @retval UB_ERR_INVAL    a NULL argument.
 */
UB_CHECK int ub_nodecfg_select_node(ub_nodecfg_t *cfg, const char *node, char *err, size_t err_cap);

/** @return the index of entity `name` in cfg->entities, or UB_ERR_NOTFOUND / UB_ERR_INVAL. */
UB_CHECK int ub_nodecfg_find_entity(const ub_nodecfg_t *cfg, const char *name);

/**
 * @return the link mask of entity `from` toward entity `to` (0..255, bit i =
 *         from's link[i]), or UB_ERR_NOTFOUND if either is unknown, UB_ERR_INVAL on NULL.
 */
UB_CHECK int ub_nodecfg_mask(const ub_nodecfg_t *cfg, const char *from, const char *to);

/* Hex masks on their own ("0x00000110"): ub_link_mask_parse() / ub_link_mask_format() in ub_link.h. */

struct ub_node; /* ub_node.h; only a pointer is needed here */

/**
 * Gives the node the "priorities" of the file (docs/config-format.md; ub_prio.h): `classes` (caller-owned,
 * `n` == the node's catalogue's n_instances entries, outliving the node) is filled with each content's class
 * (the first pattern in file order that matches its instance name; telemetry when none does) and set with
 * ub_node_set_content_classes(). Without a "priorities" section it does nothing (`classes` may be NULL).
 * @return UB_OK; UB_ERR_CONFIG with `err` ("file:line: field 'priorities.X': ...") when a pattern matches no
 *         content of the catalogue; UB_ERR_INVAL (NULL, `n` wrong).
 */
UB_CHECK int ub_nodecfg_apply_priorities(const ub_nodecfg_t *cfg, struct ub_node *node, const ub_catalogue_t *cat,
                                         uint8_t *classes, size_t n, char *err, size_t err_cap);

/**
 * Applies the table to a node initialised with ub_node_init():
 *  1. adds every entity in file order, the hosted ones (cfg->hosts) as local
 *     entities, the others as known remote entities;
 *  2. creates each hosted entity's links, link[i] named links[i] (detached:
 *     attach transports with ub_node_find_link() + ub_node_link_attach();
 *     the "ports" section is reserved for doing that from the file);
 *  3. sets each hosted entity's mask toward every entity;
 *  4. when the file has a policy (has_policy), attaches `&cfg->policy` to the
 *     node (ub_node_set_policy()): `cfg` must then outlive the node.
 * Remote entities' own rows (their links and masks) belong to the nodes that
 * host them and are not applied. The node may already hold other entities;
 * entity indices in the node are whatever ub_node_add_entity() returns.
 * @retval UB_OK
 * @retval UB_ERR_CONFIG the node refused the table: no hosted entity, an entity
 *         already in the node, two hosted entities with the same link name,
 *         more links than UB_MAX_NODE_LINKS, a link name too long for
 *         UB_LINK_NAME_LEN... `err` says which, as
 *         "<source>:<line>: entity '<name>', field 'links[i]': ...". The node is
 *         then partly set up: initialise it again before retrying.
 * @retval UB_ERR_INVAL NULL argument.
 */
UB_CHECK int ub_nodecfg_apply(const ub_nodecfg_t *cfg, struct ub_node *node, char *err, size_t err_cap);

struct ub_sec;
struct ub_sec_options;
struct ub_counter_file;
struct ub_ident_store;

/**
 * Loads the identity files the "security" section names (ub_nodecfg_identity_t) into `store`
 * (ub_identfile_load_store()): paths relative to the config file's directory, "{entity}" expanded.
 * `revocations_path` (may be NULL) receives the resolved revocations path, for ub_revfile_persist().
 * A refused file is reported as "<config>:<line>: field 'security.identity': <file>: what to do".
 * @retval UB_OK (also when the section names no authority: `store` is left empty)
 * @retval UB_ERR_CONFIG / UB_ERR_IO / UB_ERR_UNSUPPORTED `err` says which file and what to do.
 * @retval UB_ERR_INVAL NULL argument.
 */
UB_CHECK int ub_nodecfg_load_identity(const ub_nodecfg_t *cfg, struct ub_ident_store *store, uint64_t now_s,
                                      char *revocations_path, size_t path_cap, char *err, size_t err_cap);

/** The certificates file the section names, resolved as ub_nodecfg_load_identity() does ("" when none).
 *  @return UB_OK; UB_ERR_RANGE (longer than `cap`); UB_ERR_INVAL. */
UB_CHECK int ub_nodecfg_certificates_path(const ub_nodecfg_t *cfg, char *out, size_t cap);

/**
 * ub_nodecfg_load_identity(), then authorization by certified role on `node` (ub_policy_use_roles() with
 * ub_ident_roles_now() over `store`): the config's policy, or the default one attached to the node when
 * the section has no policy keys, so a vehicle never administers another unless its certificate says so.
 * Nothing happens when the section names no authority (group-key mode unchanged).
 * `cfg` must outlive the node (its policy is attached), as for ub_nodecfg_apply().
 * @return as ub_nodecfg_load_identity().
 */
UB_CHECK int ub_nodecfg_apply_identity(ub_nodecfg_t *cfg, struct ub_node *node, struct ub_ident_store *store,
                                       uint64_t now_s, char *revocations_path, size_t path_cap, char *err,
                                       size_t err_cap);

/**
 * Applies the "security" section to a node that ub_nodecfg_apply() set up:
 *  1. initialises `sec` (with `opt`, may be NULL) and loads every key file
 *     (ub_secfile.h: refused when group/other-accessible; ids unique);
 *  2. makes `tx_key` (default: the first file's key) sign;
 *  3. opens the counter file into `counter` and starts the counter at
 *     max(its mark, the wall clock `unix_us`), reserving through the file;
 *  4. sets require_signed and the per-link settings of the hosted links,
 *     and attaches `sec` to the node.
 * Without a "security" section nothing happens (the node stays unsigned).
 * `sec` and `counter` must outlive the node.
 * @retval UB_OK
 * @retval UB_ERR_CONFIG / UB_ERR_IO a key file, the counter file or a setting
 *         was refused: "<source>:<line>: field 'security.<...>': <why, what to do>".
 * @retval UB_ERR_UNSUPPORTED the file asks for security and this build has none.
 * @retval UB_ERR_INVAL NULL argument.
 */
UB_CHECK int ub_nodecfg_apply_security(const ub_nodecfg_t *cfg, struct ub_node *node, struct ub_sec *sec,
                                       struct ub_counter_file *counter, const struct ub_sec_options *opt,
                                       uint64_t unix_us, char *err, size_t err_cap);

#ifdef __cplusplus
}
#endif
#endif /* UB_NODECFG_H */
