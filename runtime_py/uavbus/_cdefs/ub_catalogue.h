/* cffi cdef for runtime_c/include/ub/ub_catalogue.h: the ID functions and the catalogue descriptors.
 * Python builds ub_catalogue_t arrays at run time from <name>.catalogue.json with pack/unpack NULL
 * (bound storage = the wire image), so no C codec build is needed to host a directory. */

#define UB_DIR_ID_LEN ...
#define UB_ENTITY_ID_LEN ...
#define UB_CATALOGUE_ABI_VERSION ...

typedef int (*ub_pack_fn)(const void *obj, uint8_t *buf, size_t cap);
typedef int (*ub_unpack_fn)(void *obj, const uint8_t *buf, size_t len);

typedef struct ub_type_desc {
    const char *name;
    uint32_t fingerprint;
    uint32_t packed_size;
    uint32_t c_size;
    ub_pack_fn pack;
    ub_unpack_fn unpack;
    ...;
} ub_type_desc_t;

typedef struct ub_instance_desc {
    uint8_t id[...];
    const char *name;
    const ub_type_desc_t *type;
    ...;
} ub_instance_desc_t;

typedef enum ub_id_scheme { UB_ID_SCHEME_PAPER, UB_ID_SCHEME_HASHED, ... } ub_id_scheme_t;

typedef struct ub_catalogue {
    const char *name;
    ub_id_scheme_t id_scheme;
    uint32_t abi_version;
    const ub_type_desc_t *types;
    size_t n_types;
    const ub_instance_desc_t *instances;
    size_t n_instances;
    uint32_t max_packed_size;
    const char *json;
    size_t json_len;
    ...;
} ub_catalogue_t;

int ub_catalogue_find(const ub_catalogue_t *cat, const uint8_t id[]);
int ub_catalogue_find_name(const ub_catalogue_t *cat, const char *name);
void ub_dir_id_paper(const char *name, uint8_t out[]);
uint32_t ub_catalogue_payload_limit(void);
const ub_type_desc_t *ub_catalogue_oversize(const ub_catalogue_t *cat, uint32_t limit);
int ub_entity_id(const char *name, uint8_t out[]);
