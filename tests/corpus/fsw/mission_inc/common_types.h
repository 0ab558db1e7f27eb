/* Mission-wide scalar types, in the style of cFE's common_types.h. */
#ifndef COMMON_TYPES_H
#define COMMON_TYPES_H

#include <stdbool.h>
#include <stdint.h>

typedef uint8_t uint8;
typedef int8_t int8;
typedef uint16_t uint16;
typedef int16_t int16;
typedef uint32_t uint32;
typedef int32_t int32;
typedef uint64_t uint64;

typedef struct {
    uint32 Seconds;
    uint32 Subseconds;
} CFE_TIME_SysTime_t;

#define MISSION_MAX_NAME_LEN 20

#endif
