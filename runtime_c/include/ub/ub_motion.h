/**
 * @file ub_motion.h
 * @brief The simulated vehicles' flight model: orbits, waypoint paths or a
 *        fixed position, as a pure function of time.
 *
 * One implementation for every simulated vehicle: the C node program
 * (programs/node, through node_motion.c) and Python's in-process vehicles
 * and scenario launcher (uavbus.sim.flight, through cffi) sample the same
 * model, so a vehicle moves the same way whichever process hosts it and the
 * launcher knows where every vehicle is (range-based connectivity) without
 * reading its GPS.
 *
 * Positions are north/east/up metres from a datum (lat0, lon0, alt0 MSL),
 * converted to latitude/longitude on a spherical earth (good to centimetres
 * over the few kilometres of a simulated range).
 *
 *  - UB_MOTION_ORBIT: a horizontal circle of `radius_m` around (center_n,
 *    center_e) at `speed_mps`, clockwise (seen from above) or not, starting
 *    at angle `phase_rad` (0 = due north of the centre). The default is
 *    uavbus_node's historic model: 200 m at 10 m/s around the Fort Benning
 *    datum, clockwise, starting north heading east.
 *  - UB_MOTION_WAYPOINTS: straight legs between up to UB_MOTION_MAX_WAYPOINTS
 *    points at `speed_mps`; with `loop` the last leg returns to the first
 *    point and the path repeats, else the vehicle holds at the last point.
 *    Turns at the points are instantaneous (body rates zero on the legs).
 *  - UB_MOTION_STATIC: stands at (center_n, center_e, up_m): ground stations.
 *
 * Every sample adds the same gentle deterministic roll/pitch oscillation to
 * the body rates (0.20 rad/s at 0.40 Hz, 0.10 rad/s at 0.25 Hz), so IMU
 * values change with time even on a straight leg.
 *
 * Text form (command lines, scenario files), keys optional, angles in degrees:
 *
 *     orbit:r=200,v=10,n=0,e=0,alt=0,phase=0,dir=cw
 *     waypoints:v=12,alt=30,loop=1,pts=0/0;800/0;800/600
 *     static:n=-50,e=20,alt=2
 *
 * plus lat0=, lon0=, alt0= (datum) on any kind. `pts` is N/E[/U] triples
 * separated by ';' (U defaults to `alt`).
 */
#ifndef UB_MOTION_H
#define UB_MOTION_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "ub_error.h"

#ifdef __cplusplus
extern "C" {
#endif

#ifndef UB_MOTION_MAX_WAYPOINTS
#define UB_MOTION_MAX_WAYPOINTS 16
#endif

typedef enum ub_motion_kind { UB_MOTION_ORBIT = 0, UB_MOTION_WAYPOINTS = 1, UB_MOTION_STATIC = 2 } ub_motion_kind_t;

typedef struct ub_motion_point {
    double north_m, east_m, up_m;
} ub_motion_point_t;

/** A vehicle's path. Fill with ub_motion_default() / ub_motion_parse(), then adjust fields if needed. */
typedef struct ub_motion {
    uint8_t kind;               /**< ub_motion_kind_t */
    bool clockwise;             /**< orbit direction, seen from above */
    bool loop;                  /**< waypoints: repeat the path */
    double lat0_deg, lon0_deg, alt0_m; /**< datum */
    double center_n_m, center_e_m, up_m; /**< orbit centre / static position, height above the datum */
    double radius_m, speed_mps, phase_rad;
    ub_motion_point_t wp[UB_MOTION_MAX_WAYPOINTS];
    uint8_t n_wp;
} ub_motion_t;

/** The vehicle at one instant. Body axes: x forward, y right, z down. */
typedef struct ub_motion_state {
    double north_m, east_m, up_m;       /**< from the datum */
    double lat_deg, lon_deg, alt_msl_m;
    double vel_ned[3];                  /**< m/s */
    double heading_rad;                 /**< from north, clockwise */
    double rates[3];                    /**< body rates p, q, r (rad/s) */
    double specific_force[3];           /**< body, m/s^2 (what an accelerometer reads) */
    double attitude[4];                 /**< body-to-NED quaternion w, x, y, z (heading only) */
} ub_motion_state_t;

/** The default orbit (see the file comment). */
void ub_motion_default(ub_motion_t *m);

/**
 * Parses the text form into `m` (starting from ub_motion_default()).
 * @return UB_OK, or UB_ERR_INVAL with `err` saying which key and what is
 *         expected (unknown kind or key, a bad number, radius or speed <= 0,
 *         fewer than 2 or more than UB_MOTION_MAX_WAYPOINTS points).
 */
UB_CHECK int ub_motion_parse(const char *text, ub_motion_t *m, char *err, size_t err_cap);

/** Samples the model at `t_s` seconds after its start (t < 0 counts as 0). */
void ub_motion_sample(const ub_motion_t *m, double t_s, ub_motion_state_t *out);

/** @return the horizontal distance in metres between two samples (same datum). */
double ub_motion_distance(const ub_motion_state_t *a, const ub_motion_state_t *b);

#ifdef __cplusplus
}
#endif
#endif /* UB_MOTION_H */
