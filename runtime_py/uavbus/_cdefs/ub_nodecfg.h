/* cffi cdef for runtime_c/include/ub/ub_nodecfg.h: the one configuration loader. Python loads, checks and
 * applies configurations only through it (uavbus.config reads the parsed struct back into dataclasses). */

#define UB_NODECFG_ERR_LEN ...

typedef struct ub_nodecfg_port_param {
    char key[...];
    char value[...];
} ub_nodecfg_port_param_t;

typedef struct ub_nodecfg_port {
    char name[...];
    char transport[...];
    uint8_t param_count;
    ub_nodecfg_port_param_t params[...];
    uint32_t line;
    ...;
} ub_nodecfg_port_t;

typedef struct ub_nodecfg_entity {
    char name[...];
    uint8_t link_count;
    char links[...][...];
    uint8_t mask[...];
    uint32_t line;
    ...;
} ub_nodecfg_entity_t;

typedef struct ub_nodecfg_node {
    char name[...];
    uint8_t entity_count;
    uint8_t entity[...];
    ...;
} ub_nodecfg_node_t;

typedef struct ub_nodecfg_security {
    uint8_t present;
    uint8_t key_count;
    uint8_t tx_key;
    uint8_t require_signed;
    uint8_t link_count;
    ...;
} ub_nodecfg_security_t;

typedef struct ub_nodecfg_identity {
    uint8_t present;
    ...;
} ub_nodecfg_identity_t;

typedef struct ub_nodecfg {
    char source[...];
    char system[...];
    uint8_t entity_count;
    ub_nodecfg_entity_t entities[...];
    uint8_t host_count;
    uint8_t hosts[...];
    uint8_t node_count;
    ub_nodecfg_node_t nodes[...];
    uint8_t port_count;
    ub_nodecfg_port_t ports[...];
    uint8_t has_policy;
    ub_nodecfg_security_t security;
    ub_nodecfg_identity_t identity;
    uint8_t priority_count;
    ...;
} ub_nodecfg_t;

typedef struct ub_nodecfg_limits {
    uint8_t max_entities;
    uint8_t max_links_per_entity;
    uint8_t max_local_entities;
    uint8_t max_ports;
    uint8_t max_port_params;
} ub_nodecfg_limits_t;

void ub_nodecfg_build_limits(ub_nodecfg_limits_t *limits);
int ub_nodecfg_parse(ub_nodecfg_t *cfg, const char *text, size_t len, const char *source_name, char *err,
                     size_t err_cap);
int ub_nodecfg_parse_limits(ub_nodecfg_t *cfg, const char *text, size_t len, const char *source_name,
                            const ub_nodecfg_limits_t *limits, char *err, size_t err_cap);
int ub_nodecfg_load_file(ub_nodecfg_t *cfg, const char *path, char *buf, size_t buf_cap, char *err, size_t err_cap);
int ub_nodecfg_select_node(ub_nodecfg_t *cfg, const char *node, char *err, size_t err_cap);
int ub_nodecfg_find_entity(const ub_nodecfg_t *cfg, const char *name);
int ub_nodecfg_mask(const ub_nodecfg_t *cfg, const char *from, const char *to);
int ub_nodecfg_apply(const ub_nodecfg_t *cfg, ub_node_t *node, char *err, size_t err_cap);
int ub_nodecfg_apply_priorities(const ub_nodecfg_t *cfg, ub_node_t *node, const ub_catalogue_t *cat, uint8_t *classes,
                                size_t n, char *err, size_t err_cap);

/* ub_sec.h / ub_secfile.h types (declared in full in _cdefs/ub_sec.h and ub_secfile.h, which load later). */
typedef struct ub_sec_options ub_sec_options_t;
typedef struct ub_counter_file ub_counter_file_t;
int ub_nodecfg_apply_security(const ub_nodecfg_t *cfg, ub_node_t *node, ub_sec_t *sec, ub_counter_file_t *counter,
                              const ub_sec_options_t *opt, uint64_t unix_us, char *err, size_t err_cap);
int ub_nodecfg_load_identity(const ub_nodecfg_t *cfg, ub_ident_store_t *store, uint64_t now_s, char *revocations_path,
                             size_t path_cap, char *err, size_t err_cap);
int ub_nodecfg_apply_identity(ub_nodecfg_t *cfg, ub_node_t *node, ub_ident_store_t *store, uint64_t now_s,
                              char *revocations_path, size_t path_cap, char *err, size_t err_cap);
int ub_nodecfg_certificates_path(const ub_nodecfg_t *cfg, char *out, size_t cap);
