/* The flight model of flight_model.h. */
#include "flight_model.h"

#include <string.h>

#define G 9.80665f
#define FM_RADIUS_M 60.0f
#define FM_SPEED_MS 12.0f
#define FM_ALT_M 300.0
#define LAT0_DEG 33.7756 /* the circle's centre */
#define LON0_DEG (-84.3963)
#define M_PER_DEG_LAT 111320.0
#define COS_LAT0 0.831349 /* cos(33.7756 deg) */
/* Turn rate w = V / R = 0.2 rad/s; one step turns w * 10 ms = 0.002 rad. */
#define W_RAD_S (FM_SPEED_MS / FM_RADIUS_M)
#define STEP_COS 0.999998000000667f /* cos(0.002) */
#define STEP_SIN 0.001999998666667f /* sin(0.002) */
/* Bank of a coordinated turn: tan(phi) = V^2 / (R g) = 0.2447; sin and cos of it. */
#define SIN_BANK 0.237683f
#define COS_BANK 0.971343f

static float noise(flight_model_t *m, float amplitude) {
    uint32_t x = m->noise;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    m->noise = x;
    return amplitude * ((float)(x & 0xFFFFu) / 32768.0f - 1.0f);
}

static void stamp(timeTag_t *t, uint64_t now_ms) {
    t->seconds = (uint32_t)(now_ms / 1000u);
    t->microseconds = (uint32_t)(now_ms % 1000u) * 1000u;
}

void flight_model_init(flight_model_t *m, imuCalibration_t *cal) {
    m->cos_h = 1.0f;
    m->sin_h = 0.0f;
    m->steps = 0;
    m->noise = 0x2545F491u;
    memset(cal, 0, sizeof *cal);
    for (int i = 0; i < 3; i++) cal->gyro.scale[i] = cal->accel.scale[i] = 1.0f;
    cal->temperatureRef = 25.0f;
    cal->calibrationDate = 20261126u;
    memcpy(cal->serialNumber, "QEMU-AN386", sizeof "QEMU-AN386");
}

void flight_model_step(flight_model_t *m, uint64_t now_ms, const imuCalibration_t *cal, imuOut_t *imu,
                       imuRaw_t *raw, gpsOut_t *gps) {
    const float dt = (float)FM_STEP_MS / 1000.0f;
    /* Heading: rotate by the step angle, then pull the vector back to unit length (first order). */
    float c = m->cos_h * STEP_COS - m->sin_h * STEP_SIN;
    float s = m->sin_h * STEP_COS + m->cos_h * STEP_SIN;
    float k = 1.5f - 0.5f * (c * c + s * s);
    m->cos_h = c * k;
    m->sin_h = s * k;
    m->steps++;

    /* Body rates of a coordinated turn plus the gyro bias the calibration says the sensor has. */
    float p = noise(m, 0.002f) + cal->gyro.bias[0];
    float q = W_RAD_S * SIN_BANK + noise(m, 0.002f) + cal->gyro.bias[1];
    float r = W_RAD_S * COS_BANK + noise(m, 0.002f) + cal->gyro.bias[2];
    /* Specific force: the lift that holds the turn, along -z body: g / cos(bank). */
    float fz = -G / COS_BANK + noise(m, 0.05f);
    float fx = noise(m, 0.05f), fy = noise(m, 0.05f);

    stamp(&imu->time, now_ms);
    imu->p = p;
    imu->q = q;
    imu->r = r;
    imu->specificForce.x = fx;
    imu->specificForce.y = fy;
    imu->specificForce.z = fz;
    imu->deltaVelocity.x = fx * dt;
    imu->deltaVelocity.y = fy * dt;
    imu->deltaVelocity.z = fz * dt;
    imu->deltaAngle.x = p * dt;
    imu->deltaAngle.y = q * dt;
    imu->deltaAngle.z = r * dt;
    imu->temperatureC = 35.0f + (float)(m->steps % 6000u) / 1000.0f; /* warms up, repeats every minute */
    imu->sampleCount = m->steps;
    imu->saturated = 0;
    imu->health = HEALTH_OK;

    stamp(&raw->time, now_ms);
    raw->gyroCounts[0] = (int16_t)(p * 3000.0f);
    raw->gyroCounts[1] = (int16_t)(q * 3000.0f);
    raw->gyroCounts[2] = (int16_t)(r * 3000.0f);
    raw->accelCounts[0] = (int16_t)(fx * 800.0f);
    raw->accelCounts[1] = (int16_t)(fy * 800.0f);
    raw->accelCounts[2] = (int16_t)(fz * 800.0f);
    raw->temperatureCounts = (int16_t)(imu->temperatureC * 16.0f);
    raw->sampleCounter = (uint16_t)m->steps;

    if (m->steps % FM_GPS_EVERY == 0u) {
        float north = FM_RADIUS_M * m->cos_h, east = FM_RADIUS_M * m->sin_h;
        stamp(&gps->time, now_ms);
        gps->latitudeDeg = LAT0_DEG + (double)north / M_PER_DEG_LAT;
        gps->longitudeDeg = LON0_DEG + (double)east / (M_PER_DEG_LAT * COS_LAT0);
        gps->altitudeMsl = FM_ALT_M + (double)noise(m, 0.3f);
        gps->velocityNed.x = -FM_SPEED_MS * m->sin_h;
        gps->velocityNed.y = FM_SPEED_MS * m->cos_h;
        gps->velocityNed.z = 0.0f;
        gps->horizontalAccuracy = 1.5f;
        gps->verticalAccuracy = 2.5f;
        gps->pdop = 1.4f;
        gps->fix = GPS_FIX_3D;
        gps->satellitesUsed = 11;
        gps->status.antennaOk = 1;
        gps->solutionCount++;
    }
}
