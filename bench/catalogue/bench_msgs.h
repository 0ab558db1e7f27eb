/**
 * @file bench_msgs.h
 * @brief The bench catalogue: structs with the same fields as MAVLink's ATTITUDE, GPS_RAW_INT and
 *        HIGHRES_IMU (common.xml, extensions included, in MAVLink's wire order), plus a 64-byte
 *        blob for the transport figures. bench_msgs.lcm carries the same messages for LCM.
 *
 * Generated at bench build time (bench/run.sh): `uavbus gen bench/catalogue/bench_msgs.h --name benchcat`.
 */
#ifndef BENCH_MSGS_H
#define BENCH_MSGS_H

#include <stdint.h>

/** MAVLink ATTITUDE (#30): 28-byte payload. */
typedef struct benchAttitude {
    uint32_t time_boot_ms;
    float roll;
    float pitch;
    float yaw;
    float rollspeed;
    float pitchspeed;
    float yawspeed;
} benchAttitude_t;

/** MAVLink GPS_RAW_INT (#24): 52-byte payload (30 base + 22 extension bytes). */
typedef struct benchGpsRawInt {
    uint64_t time_usec;
    int32_t lat;
    int32_t lon;
    int32_t alt;
    uint16_t eph;
    uint16_t epv;
    uint16_t vel;
    uint16_t cog;
    uint8_t fix_type;
    uint8_t satellites_visible;
    int32_t alt_ellipsoid;
    uint32_t h_acc;
    uint32_t v_acc;
    uint32_t vel_acc;
    uint32_t hdg_acc;
    uint16_t yaw;
} benchGpsRawInt_t;

/** MAVLink HIGHRES_IMU (#105): 63-byte payload (62 base + 1 extension byte). */
typedef struct benchHighresImu {
    uint64_t time_usec;
    float xacc;
    float yacc;
    float zacc;
    float xgyro;
    float ygyro;
    float zgyro;
    float xmag;
    float ymag;
    float zmag;
    float abs_pressure;
    float diff_pressure;
    float pressure_alt;
    float temperature;
    uint16_t fields_updated;
    uint8_t id;
} benchHighresImu_t;

/** The transport figures' 64-byte payload (peers.md sends 64 raw bytes). */
typedef struct benchBlob64 {
    uint64_t seq;
    uint64_t t_ns; /* CLOCK_MONOTONIC at send, for round-trip times */
    uint8_t bytes[48];
} benchBlob64_t;

extern benchAttitude_t benchAttitude;
extern benchGpsRawInt_t benchGpsRawInt;
extern benchHighresImu_t benchHighresImu;
extern benchBlob64_t benchBlob64;
extern benchBlob64_t benchBlob64Echo;

#endif /* BENCH_MSGS_H */
