/**
 * @file fsw_types.h
 * @brief Types shared by every flight-software module of the GTMax / RMAX
 *        research helicopters: vectors, time tags, vehicle modes and fix
 *        qualities. Included by all other flight-software headers.
 *
 * Conventions (unchanged since the original onboard software):
 *  - positions are NED metres relative to the datum in onboardSet, or
 *    WGS-84 degrees where the name says lat/lon;
 *  - angles are radians, rates rad/s, unless the field name says Deg;
 *  - every directory starts with a timeTag so that the GCS can show its age.
 */
#ifndef FSW_TYPES_H
#define FSW_TYPES_H

#include <stdint.h>

/** Simulation and onboard time: whole seconds and microseconds since power-up. */
typedef struct timeTag {
    uint32_t seconds;
    uint32_t microseconds;
} timeTag_t;

/** A 3-vector in double precision (navigation quantities). */
typedef struct vector3d {
    double x;
    double y;
    double z;
} vector3d_t;

/** A 3-vector in single precision (sensor quantities). */
typedef struct vector3f {
    float x;
    float y;
    float z;
} vector3f_t;

/** Attitude quaternion, scalar first. */
typedef struct quaternion {
    double q0;
    double q1;
    double q2;
    double q3;
} quaternion_t;

/** Guidance mode of a vehicle, as commanded from the GCS. */
typedef enum vehicleMode {
    MODE_STANDBY = 0,
    MODE_MANUAL = 1,
    MODE_AUGMENTED = 2,   /* pilot stick through the inner loop */
    MODE_AUTONOMOUS = 3,  /* waypoint following */
    MODE_FORMATION = 4,   /* station keeping on a leader */
    MODE_AUTOLAND = 5,
    MODE_ABORT = 6
} vehicleMode_t;

/** Quality of a GPS position solution. */
typedef enum gpsFixType {
    GPS_FIX_NONE = 0,
    GPS_FIX_2D = 2,
    GPS_FIX_3D = 3,
    GPS_FIX_DGPS = 4,
    GPS_FIX_RTK_FLOAT = 5,
    GPS_FIX_RTK_FIXED = 6
} gpsFixType_t;

/**
 * Health level reported by every module. Stored in one byte (packed enum) so
 * that health arrays stay small on the 9600-baud serial datalink.
 */
typedef enum __attribute__((packed)) healthLevel {
    HEALTH_OK = 0,
    HEALTH_DEGRADED = 1,
    HEALTH_FAILED = 2,
    HEALTH_UNKNOWN = 255
} healthLevel_t;

/** Onboard computers and ground stations of the team (see entities.h). */
typedef enum computerId {
    COMPUTER_RMAX1OB1 = 0, /* primary flight computer */
    COMPUTER_RMAX1OB2 = 1, /* secondary flight computer */
    COMPUTER_FCS20 = 2,    /* backup flight computer */
    COMPUTER_GCS1 = 3      /* primary ground control station */
} computerId_t;

#endif /* FSW_TYPES_H */
