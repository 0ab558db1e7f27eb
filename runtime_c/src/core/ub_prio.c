/* Priority classes of frames (ub_prio.h). */
#include "ub/ub_prio.h"

#include <string.h>

#include "ub/ub_frame.h"

static const char *const class_names[UB_PRIO_CLASSES] = {
    [UB_PRIO_COMMAND] = "command",
    [UB_PRIO_CONTROL] = "control",
    [UB_PRIO_TELEMETRY] = "telemetry",
    [UB_PRIO_BULK] = "bulk",
};

const char *ub_prio_class_name(ub_prio_class_t cls) {
    if ((unsigned)cls >= UB_PRIO_CLASSES) return "?";
    return class_names[cls];
}

int ub_prio_class_parse(const char *name, ub_prio_class_t *cls) {
    if (name == NULL || cls == NULL) return UB_ERR_INVAL;
    for (unsigned c = 0; c < UB_PRIO_CLASSES; c++) {
        if (strcmp(name, class_names[c]) == 0) {
            *cls = (ub_prio_class_t)c;
            return UB_OK;
        }
    }
    return UB_ERR_INVAL;
}

ub_prio_class_t ub_prio_class_of(uint8_t admin, ub_prio_class_t data_class) {
    if (admin == UB_ADMIN_DATA) return (unsigned)data_class < UB_PRIO_CLASSES ? data_class : UB_PRIO_TELEMETRY;
    /* A large directory in pieces is the bulk of a slow link: it must never hold up a command. */
    if (admin == UB_ADMIN_FRAGMENT) return UB_PRIO_BULK;
    /* Requests, STOPs, their answers, routing and link hellos: small, rare, and what keeps the system
     * controllable and its routes alive. */
    return UB_PRIO_COMMAND;
}
