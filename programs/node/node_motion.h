/*
 * Mapping of the runtime flight model (ub_motion.h) onto the flight-software
 * directories the example node program produces: gpsOut (position,
 * velocity), imuOut (body rates, specific force, increments over `dt_s`) and
 * navFilterState (position/velocity NED, attitude). The kinematics are
 * ub_motion's, the same Python's simulated vehicles use (uavbus.sim.flight),
 * so a vehicle moves the same way in either language; each output is a pure
 * function of the time since start, so two runs (or two processes) agree.
 * Each directory gets the timeTag the caller passes (uavbus_node uses
 * CLOCK_MONOTONIC at the update, so a receiver on the same machine can
 * compute latency).
 */
#ifndef NODE_MOTION_H
#define NODE_MOTION_H

#include "gps.h"
#include "imu.h"
#include "navfilter.h"
#include "ub/ub_motion.h"

typedef struct node_motion {
    ub_motion_t path; /* default: ub_motion_default(), the 200 m circle at 10 m/s */
} node_motion_t;

/* The default path; replace `path` (ub_motion_parse()) for another one. */
void node_motion_init(node_motion_t *m);

/* Fill the fields the model owns; counters (solutionCount, sampleCount, updateCount) are incremented. */
void node_motion_gps(const node_motion_t *m, double t_s, timeTag_t stamp, gpsOut_t *out);
void node_motion_imu(const node_motion_t *m, double t_s, double dt_s, timeTag_t stamp, imuOut_t *out);
void node_motion_nav(const node_motion_t *m, double t_s, timeTag_t stamp, navFilterState_t *out);

#endif /* NODE_MOTION_H */
