/**
 * @file imu.h
 * @brief Inertial measurement unit: raw counts, calibration and the
 *        compensated inertial measurements.
 *
 * The compensated measurements (imuOut) are computed on the backup flight
 * computer fcs20, which owns the IMU's serial port; the GCS subscribes to them
 * through rmax1ob1 (the paper's most complex HITL test).
 */
#ifndef IMU_H
#define IMU_H

#include <stdint.h>
#include "fsw_types.h"

/** Raw sample as read from the IMU, in sensor counts. */
typedef struct imuRaw {
    timeTag_t time;
    int16_t gyroCounts[3];
    int16_t accelCounts[3];
    int16_t temperatureCounts;
    uint16_t sampleCounter;
    uint8_t statusByte;
    uint8_t parityErrors;
} imuRaw_t;

/** Scale factor, misalignment and bias of one sensor triad. */
typedef struct imuTriadCal {
    float scale[3];
    float misalignment[3][3];
    float bias[3];
} imuTriadCal_t;

typedef struct imuCalibration {
    timeTag_t time;
    imuTriadCal_t gyro;
    imuTriadCal_t accel;
    float temperatureRef;
    uint32_t calibrationDate;        /* yyyymmdd */
    char serialNumber[12];
} imuCalibration_t;

/** Temperature compensation polynomial of one axis. */
typedef struct imuTemperatureComp {
    float gyroCoeff[4];
    float accelCoeff[4];
    float validFromC;
    float validToC;
} imuTemperatureComp_t;

/** Compensated inertial measurements: the imuOut directory. */
typedef struct imuOut {
    timeTag_t time;
    struct {                         /* C11 anonymous struct: imuOut.p, imuOut.q, imuOut.r */
        double p;                    /**< [rad/s] roll rate, body x */
        double q;                    /**< [rad/s] pitch rate, body y */
        double r;                    /**< [rad/s] yaw rate, body z */
    };
    vector3d_t specificForce;        /* m/s^2, body axes */
    vector3d_t deltaVelocity;        /* integrated over the last frame */
    vector3d_t deltaAngle;
    float temperatureC;              /**< [degC] sensor temperature */
    uint32_t sampleCount;
    _Bool saturated;
    healthLevel_t health;
} imuOut_t;

extern imuRaw_t imuRaw;
extern imuCalibration_t imuCalibration;
extern imuTemperatureComp_t imuTemperatureComp[3];
extern imuOut_t imuOut;              /* computed on fcs20 */
extern imuOut_t imuOutPrimary;       /* rmax1ob1's copy after time alignment */

#endif /* IMU_H */
