/**
 * @file ub_catalogue.h
 * @brief The contract between generated code and the runtime: a catalogue of
 *        directory types (codec + layout fingerprint) and named instances
 *        (16-byte content ID), as emitted by `uavbus gen`.
 *
 * A generated `<name>.c` defines one `const ub_catalogue_t <name>_catalogue`.
 * Its `instances` array is sorted by ID (memcmp order) so ub_catalogue_find()
 * can binary-search. The catalogue holds no storage pointers: an application
 * binds only the instances it hosts to its own variables (see ub_node_bind()).
 */
#ifndef UB_CATALOGUE_H
#define UB_CATALOGUE_H

#include <stddef.h>
#include <stdint.h>
#include "ub_error.h"

#ifdef __cplusplus
extern "C" {
#endif

#define UB_DIR_ID_LEN 16    /**< content ("directory") ID length, paper III.C */
#define UB_ENTITY_ID_LEN 12 /**< entity ID length, paper III.C */

/** Bumped whenever the layout of these descriptors changes; generated code checks it. */
#define UB_CATALOGUE_ABI_VERSION 2

/**
 * Packs `obj` into `buf`. Never writes past `cap`.
 * @return bytes written (the type's packed_size), or UB_ERR_NOSPACE.
 */
typedef int (*ub_pack_fn)(const void *obj, uint8_t *buf, size_t cap);
/**
 * Unpacks `len` bytes into `obj`, leaving skipped fields (pointers, strings,
 * flexible arrays) untouched. Never reads past `len`.
 * @return bytes consumed (the type's packed_size), or UB_ERR_TRUNCATED.
 */
typedef int (*ub_unpack_fn)(void *obj, const uint8_t *buf, size_t len);

/**
 * One directory type. Generated C fills `pack`/`unpack`. A catalogue built at
 * run time from `<name>.catalogue.json` (the Python binding) leaves both NULL:
 * its bound storage then holds the **wire image** (packed_size bytes) and the
 * router copies it as is. Either way the fingerprint and size checks apply.
 */
typedef struct ub_type_desc {
    const char *name;       /**< C type name, e.g. "struct gps_out" or a typedef name */
    uint32_t fingerprint;   /**< layout fingerprint (docs/wire-format.md) */
    uint32_t packed_size;   /**< bytes on the wire; fixed per type */
    uint32_t c_size;        /**< sizeof the C type, as measured by clang */
    ub_pack_fn pack;        /**< NULL: storage is the wire image */
    ub_unpack_fn unpack;    /**< NULL: storage is the wire image */
} ub_type_desc_t;

typedef struct ub_instance_desc {
    uint8_t id[UB_DIR_ID_LEN]; /**< content ID (id scheme in ub_catalogue_t) */
    const char *name;          /**< instance name; array elements as "name[i][j]" */
    const ub_type_desc_t *type;
} ub_instance_desc_t;

typedef enum ub_id_scheme { UB_ID_SCHEME_PAPER = 0, UB_ID_SCHEME_HASHED = 1 } ub_id_scheme_t;

typedef struct ub_catalogue {
    const char *name;
    ub_id_scheme_t id_scheme;
    uint32_t abi_version;                 /**< UB_CATALOGUE_ABI_VERSION at generation */
    const ub_type_desc_t *types;
    size_t n_types;
    const ub_instance_desc_t *instances;  /**< sorted by id */
    size_t n_instances;
    uint32_t max_packed_size;             /**< largest packed_size of any type */
    /** Self-description: the compact `<name>.catalogue.json` text (types with
     *  field layout, instances with IDs), NUL-terminated; NULL if absent.
     *  Binary logs embed it so they decode without the build that wrote them. */
    const char *json;
    size_t json_len;                      /**< strlen(json), 0 if absent */
} ub_catalogue_t;

/**
 * Finds an instance by content ID (binary search).
 * @return the instance index, or UB_ERR_NOTFOUND.
 */
UB_CHECK int ub_catalogue_find(const ub_catalogue_t *cat, const uint8_t id[UB_DIR_ID_LEN]);

/**
 * Finds an instance by name (linear search; for set-up, not for hot paths).
 * @return the instance index, or UB_ERR_NOTFOUND.
 */
UB_CHECK int ub_catalogue_find_name(const ub_catalogue_t *cat, const char *name);

/**
 * The payload limit of this runtime build: UB_MAX_DIRECTORY (ub_config.h) as the
 * library was compiled, the largest packed type a node carries (types above
 * UB_MAX_PAYLOAD, one frame's payload, travel in fragments). `uavbus gen
 * --max-payload` checks a catalogue against the same number.
 */
uint32_t ub_catalogue_payload_limit(void);

/**
 * Finds the first type of `cat` that packs to more than `limit` bytes.
 * ub_node_init() refuses a catalogue holding such a type (UB_ERR_INVAL) for
 * limit = ub_catalogue_payload_limit(); call this to say which type and why:
 *
 *     const ub_type_desc_t *big = ub_catalogue_oversize(&cat, ub_catalogue_payload_limit());
 *     if (big != NULL)
 *         fprintf(stderr, "%s packs to %u bytes; this runtime carries %u (UB_MAX_DIRECTORY)\n",
 *                 big->name, (unsigned)big->packed_size, (unsigned)ub_catalogue_payload_limit());
 *
 * @return the type, or NULL when every type fits (or `cat` is NULL).
 */
const ub_type_desc_t *ub_catalogue_oversize(const ub_catalogue_t *cat, uint32_t limit);

/**
 * Computes a content ID under the paper's rule: the first 8 and the last 8
 * characters of the name; shorter names overlap; each half of a name shorter
 * than 8 is padded on the right with 0x00. (Same rule as the generator.)
 */
void ub_dir_id_paper(const char *name, uint8_t out[UB_DIR_ID_LEN]);

/**
 * Computes an entity ID: the name itself, padded with 0x00 to 12 bytes.
 * @return UB_OK, or UB_ERR_RANGE when the name is longer than 12 characters.
 */
UB_CHECK int ub_entity_id(const char *name, uint8_t out[UB_ENTITY_ID_LEN]);

#ifdef __cplusplus
}
#endif
#endif /* UB_CATALOGUE_H */
