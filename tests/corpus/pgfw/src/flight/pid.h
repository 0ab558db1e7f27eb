#pragma once

#include "pg/pg.h"

typedef enum { PID_ROLL, PID_PITCH, PID_YAW, PID_LEVEL, PID_ITEM_COUNT } pidIndex_e;

typedef struct pidf_s {
    uint8_t P;
    uint8_t I;
    uint8_t D;
    uint16_t F;
} pidf_t;

typedef struct pidProfile_s {
    uint16_t yaw_lowpass_hz;
    pidf_t pid[PID_ITEM_COUNT];
    pidIndex_e feedforward_axis;
    char profileName[9];
    double anti_gravity_gain;
} pidProfile_t;

PG_DECLARE_ARRAY(pidProfile_t, MAX_PROFILE_COUNT, pidProfiles);
