#ifndef BARO_H
#define BARO_H

#define _POSIX_C_SOURCE 200809L
#include <pthread.h> /* includes the C library's <time.h> */
#include <time.h>
#include "../common/time.h"

typedef struct {
    float pressure_pa;
    float temperature_c;
    os_time_t at;
    struct timespec wall;
    struct tm calendar; /* only the C library's <time.h> defines it */
} baro_sample_t;

extern baro_sample_t baro_latest;

#endif
