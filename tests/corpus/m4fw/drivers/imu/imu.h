#ifndef IMU_H
#define IMU_H

#include <time.h> /* the C library's, for struct timespec */
#include "../../common/fw_types.h"
#include "../../common/time.h"

typedef struct {
    sensor_health_t health;
    uint8_t sample_count;
    int16_t gyro_raw[3];
    float accel[3];
    fw_time_t stamp;
    struct timespec taken;
} imu_sample_t;

extern imu_sample_t imu_latest;

#endif
