/* The firmware's own time header: named like the C library's <time.h>, as real trees do. */
#ifndef FW_COMMON_TIME_H
#define FW_COMMON_TIME_H

#include <stdint.h>

typedef struct {
    uint32_t sec;
    uint32_t usec;
} fw_time_t;

#endif
