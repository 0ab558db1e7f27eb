/**
 * @file navfilter.h
 * @brief Navigation filter (extended Kalman filter with 12 error states:
 *        position, velocity, attitude, gyro bias) and its sensor residuals.
 */
#ifndef NAVFILTER_H
#define NAVFILTER_H

#include <stdint.h>
#include "fsw_types.h"

#define NAV_STATES 12

/** Index of each sensor residual record in navSensorResidual[]. */
typedef enum navSensor {
    NAV_SENSOR_GPS_POS = 0,
    NAV_SENSOR_GPS_VEL = 1,
    NAV_SENSOR_MAGNETOMETER = 2,
    NAV_SENSOR_SONAR = 3,
    NAV_SENSOR_BARO = 4,
    NAV_SENSOR_VISION = 5,
    NAV_SENSOR_RADAR_ALT = 6,
    NAV_SENSOR_AIR_DATA = 7,
    NAV_SENSOR_COUNT = 8
} navSensor_t;

typedef struct navFilterState {
    timeTag_t time;
    vector3d_t positionNed;
    vector3d_t velocityNed;
    quaternion_t attitude;
    double dcmBodyToNed[3][3];
    vector3f_t gyroBias;
    vector3f_t accelBias;
    float stateStdDev[NAV_STATES];
    uint32_t updateCount;
    uint16_t resetCount;
    uint8_t aligned;
    healthLevel_t health;
} navFilterState_t;

/** Full error-state covariance, published at 1 Hz for monitoring. */
typedef struct navCovariance {
    timeTag_t time;
    float p[NAV_STATES][NAV_STATES];
} navCovariance_t;

typedef struct navFilterConfig {
    float processNoise[NAV_STATES];
    float gpsPosNoise;
    float gpsVelNoise;
    float magNoise;
    float sonarNoise;
    uint16_t gpsLatencyMs;
    uint8_t useVision : 1;
    uint8_t useSonar : 1;
    uint8_t useMagnetometer : 1;
    uint8_t spare : 5;
} navFilterConfig_t;

/** Innovation statistics of one aiding sensor. */
typedef struct navSensorResidual {
    timeTag_t lastUpdate;
    float innovation[3];
    float innovationVariance[3];
    uint32_t accepted;
    uint32_t rejected;               /* failed the chi-square gate */
} navSensorResidual_t;

extern navFilterState_t navFilterState;
extern navFilterState_t navFilterStateBackup;  /* fcs20's reduced filter */
extern navCovariance_t navCovariance;
extern navFilterConfig_t navFilterConfig;
extern navSensorResidual_t navSensorResidual[NAV_SENSOR_COUNT];

#endif /* NAVFILTER_H */
