#pragma once

#include "pg/pg.h"

typedef enum {
    GYRO_HARDWARE_LPF_NORMAL,
    GYRO_HARDWARE_LPF_OPTION_1,
    GYRO_HARDWARE_LPF_OPTION_2,
} gyroHardwareLpf_e;

typedef struct gyroConfig_s {
    uint8_t gyro_hardware_lpf;  // gyroHardwareLpf_e
    gyroHardwareLpf_e lpf_mode; // one byte under the EABI (short enums)
    uint16_t gyro_lpf1_static_hz;
    int16_t gyro_offset_yaw;
    bool gyro_high_fsr;
    uint32_t gyro_calib_duration;
    float gyro_lpf1_dyn_expo;
} gyroConfig_t;

PG_DECLARE(gyroConfig_t, gyroConfig);
