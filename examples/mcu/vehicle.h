/* The directories of a small autopilot board: what the firmware in firmware.c publishes and receives. */
#ifndef VEHICLE_H
#define VEHICLE_H

#include <stdint.h>

typedef struct attitudeState {
    uint32_t tMs;
    float roll, pitch, yaw;         /* rad */
    float p, q, r;                  /* rad/s */
} attitudeState_t;

typedef struct rcCommand {
    uint32_t tMs;
    int16_t channel[8];             /* us offset from 1500 */
    uint8_t armed;
} rcCommand_t;

extern attitudeState_t attitudeOut;  /* published to the ground station */
extern rcCommand_t rcIn;             /* received from the ground station */

#endif
