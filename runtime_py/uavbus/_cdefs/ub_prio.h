/* cffi cdef for runtime_c/include/ub/ub_prio.h: priority classes of frames on slow links. */

typedef enum ub_prio_class {
    UB_PRIO_COMMAND, UB_PRIO_CONTROL, UB_PRIO_TELEMETRY, UB_PRIO_BULK, UB_PRIO_CLASSES, ...
} ub_prio_class_t;

const char *ub_prio_class_name(ub_prio_class_t cls);
int ub_prio_class_parse(const char *name, ub_prio_class_t *cls);
ub_prio_class_t ub_prio_class_of(uint8_t admin, ub_prio_class_t data_class);
