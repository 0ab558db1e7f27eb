/*
 * A small flight model for the board's sensors: the vehicle flies a level coordinated turn (a circle
 * of FM_RADIUS_M at FM_SPEED_MS around a fixed point near Atlanta) and the model writes what an IMU and
 * a GPS receiver on it would measure into the imuOut, imuRaw and gpsOut directories, stamped with the
 * board's time since power-up. The gyro bias of imuCalibration (writable over the bus) is added to the
 * rates, so a write from the ground shows in the next imuOut.
 *
 * No libm and no trigonometry at run time: the heading advances by a constant rotation (cos/sin of the
 * step angle are compile-time constants), renormalised each step, so the model costs a few hundred bytes
 * of code and a few multiplications per step. Deterministic: the sensor noise is a seeded xorshift.
 */
#ifndef FLIGHT_MODEL_H
#define FLIGHT_MODEL_H

#include <stdint.h>

#include "gps.h"
#include "imu.h"

#define FM_STEP_MS 10u   /* IMU rate 100 Hz */
#define FM_GPS_EVERY 10u /* GPS at 10 Hz: every 10th step */

typedef struct flight_model {
    float cos_h, sin_h; /* heading on the circle */
    uint32_t steps;
    uint32_t noise;     /* xorshift32 state */
} flight_model_t;

void flight_model_init(flight_model_t *m, imuCalibration_t *cal);

/** Advances the model by one FM_STEP_MS step at board time `now_ms`; updates the directories. */
void flight_model_step(flight_model_t *m, uint64_t now_ms, const imuCalibration_t *cal, imuOut_t *imu,
                       imuRaw_t *raw, gpsOut_t *gps);

#endif /* FLIGHT_MODEL_H */
