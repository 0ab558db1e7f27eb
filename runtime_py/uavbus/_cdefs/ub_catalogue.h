/* cffi cdef for runtime_c/include/ub/ub_catalogue.h: the ID functions. The catalogue descriptors
 * themselves are bound later, with the generated Python bindings. */

#define UB_DIR_ID_LEN ...
#define UB_ENTITY_ID_LEN ...

void ub_dir_id_paper(const char *name, uint8_t out[]);
int ub_entity_id(const char *name, uint8_t out[]);
