/*
 * Deterministic motion model of the example node program: the vehicle flies a
 * horizontal circle of `radius_m` at `speed_mps` around a datum, clockwise seen
 * from above, starting due north of the centre heading east. Every output is a
 * pure function of the time since start, so two runs (or two processes) agree.
 *
 * It fills the directories a flight computer produces: gpsOut (position,
 * velocity), imuOut (body rates, specific force, increments over `dt_s`) and
 * navFilterState (position/velocity NED, attitude). Each gets the timeTag the
 * caller passes (uavbus_node uses CLOCK_MONOTONIC at the update, so a receiver
 * on the same machine can compute latency).
 */
#ifndef NODE_MOTION_H
#define NODE_MOTION_H

#include "gps.h"
#include "imu.h"
#include "navfilter.h"

typedef struct node_motion {
    double lat0_deg, lon0_deg, alt0_m; /* centre of the circle */
    double radius_m;
    double speed_mps;
} node_motion_t;

/* The default: 200 m circle at 10 m/s around the Fort Benning range datum, 120 m MSL. */
void node_motion_init(node_motion_t *m);

/* Fills the fields the model owns; counters (solutionCount, sampleCount, updateCount) are incremented. */
void node_motion_gps(const node_motion_t *m, double t_s, timeTag_t stamp, gpsOut_t *out);
void node_motion_imu(const node_motion_t *m, double t_s, double dt_s, timeTag_t stamp, imuOut_t *out);
void node_motion_nav(const node_motion_t *m, double t_s, timeTag_t stamp, navFilterState_t *out);

#endif /* NODE_MOTION_H */
