#ifndef PARAMS_H
#define PARAMS_H

#include "../common/fw_types.h"

typedef struct {
    const char *name;
    const flight_mode_t applies_in;
    const uint8_t type;
    float value;
    const float min;
    const float max;
} param_t;

extern param_t param_rate_p;

#endif
