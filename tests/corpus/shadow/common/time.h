/* Named like the C library's header, as in many firmware trees. */
#ifndef SHADOW_COMMON_TIME_H
#define SHADOW_COMMON_TIME_H

#include <stdint.h>

typedef struct {
    uint32_t ticks;
    uint16_t rollovers;
} os_time_t;

#endif
