/*
 * Mapping of the runtime flight model (ub_motion.h) onto the flight-software
 * directories the example node program produces: gpsOut (position,
 * velocity), imuOut (body rates, specific force, increments over `dt_s`) and
 * navFilterState (position/velocity NED, attitude). The kinematics are
 * ub_motion's, the same Python's simulated vehicles use (uavbus.sim.flight),
 * so a vehicle moves the same way in either language; each output is a pure
 * function of the time since start, so two runs (or two processes) agree.
 * Each directory gets the timeTag the caller passes (uavbus_node passes the
 * sample's instant on CLOCK_MONOTONIC, so a receiver on the same machine can
 * compute latency) and the sample's number `count` (1 for the first sample
 * the process wrote): a sample is the same whenever it is computed, which is
 * what lets uavbus_node sample lazily (uavbus_node.c, "Motion models").
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

/* Fill the fields the model owns, from t_s, stamp and count alone; the counters (solutionCount,
 * sampleCount, updateCount) are set to `count`. */
void node_motion_gps(const node_motion_t *m, double t_s, timeTag_t stamp, uint32_t count, gpsOut_t *out);
void node_motion_imu(const node_motion_t *m, double t_s, double dt_s, timeTag_t stamp, uint32_t count, imuOut_t *out);
void node_motion_nav(const node_motion_t *m, double t_s, timeTag_t stamp, uint32_t count, navFilterState_t *out);

#endif /* NODE_MOTION_H */
