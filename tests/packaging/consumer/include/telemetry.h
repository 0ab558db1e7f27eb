/* A consumer's own flight-software header: uavbus_generate() makes the catalogue from it. */
#ifndef TELEMETRY_H
#define TELEMETRY_H

#include <stdint.h>

typedef struct attitude {
    uint32_t t_ms;
    float roll, pitch, yaw; /* rad */
    uint8_t mode;
} attitude_t;

extern attitude_t attitudeOut; /* the directory this vehicle publishes */

#endif
