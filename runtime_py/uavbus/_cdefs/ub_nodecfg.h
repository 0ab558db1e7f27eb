/* cffi cdef for runtime_c/include/ub/ub_nodecfg.h: the config loader C and Python share, so both
 * apply the same table. ub_nodecfg_t is read only through functions and a few summary fields. */

#define UB_NODECFG_ERR_LEN ...

typedef struct ub_nodecfg_port { ...; } ub_nodecfg_port_t;

typedef struct ub_nodecfg_entity {
    char name[...];
    uint8_t link_count;
    ...;
} ub_nodecfg_entity_t;

typedef struct ub_nodecfg_node {
    char name[...];
    uint8_t entity_count;
    uint8_t entity[...];
    ...;
} ub_nodecfg_node_t;

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
    ...;
} ub_nodecfg_t;

int ub_nodecfg_parse(ub_nodecfg_t *cfg, const char *text, size_t len, const char *source_name, char *err,
                     size_t err_cap);
int ub_nodecfg_load_file(ub_nodecfg_t *cfg, const char *path, char *buf, size_t buf_cap, char *err, size_t err_cap);
int ub_nodecfg_select_node(ub_nodecfg_t *cfg, const char *node, char *err, size_t err_cap);
int ub_nodecfg_find_entity(const ub_nodecfg_t *cfg, const char *name);
int ub_nodecfg_mask(const ub_nodecfg_t *cfg, const char *from, const char *to);
int ub_nodecfg_apply(const ub_nodecfg_t *cfg, ub_node_t *node, char *err, size_t err_cap);
