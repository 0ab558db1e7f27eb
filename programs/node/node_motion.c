/* The flight model's samples written into the flight-software directories (node_motion.h). */
#include "node_motion.h"

#include <math.h>
#include <string.h>

void node_motion_init(node_motion_t *m) { ub_motion_default(&m->path); }

void node_motion_gps(const node_motion_t *m, double t_s, timeTag_t stamp, uint32_t count, gpsOut_t *out) {
    ub_motion_state_t s;
    ub_motion_sample(&m->path, t_s, &s);
    out->time = stamp;
    out->latitudeDeg = s.lat_deg;
    out->longitudeDeg = s.lon_deg;
    out->altitudeMsl = s.alt_msl_m;
    out->velocityNed = (vector3f_t){(float)s.vel_ned[0], (float)s.vel_ned[1], (float)s.vel_ned[2]};
    out->horizontalAccuracy = 1.5f;
    out->verticalAccuracy = 3.0f;
    out->pdop = 1.4f;
    out->fix = GPS_FIX_3D;
    out->satellitesUsed = 9;
    out->status.antennaOk = 1;
    out->status.almanacValid = 1;
    out->solutionCount = count;
}

void node_motion_imu(const node_motion_t *m, double t_s, double dt_s, timeTag_t stamp, uint32_t count, imuOut_t *out) {
    ub_motion_state_t s;
    ub_motion_sample(&m->path, t_s, &s);
    out->time = stamp;
    out->p = s.rates[0];
    out->q = s.rates[1];
    out->r = s.rates[2];
    out->specificForce = (vector3d_t){s.specific_force[0], s.specific_force[1], s.specific_force[2]};
    out->deltaVelocity = (vector3d_t){s.specific_force[0] * dt_s, s.specific_force[1] * dt_s, s.specific_force[2] * dt_s};
    out->deltaAngle = (vector3d_t){out->p * dt_s, out->q * dt_s, out->r * dt_s};
    out->temperatureC = 35.0f;
    out->sampleCount = count;
    out->saturated = 0;
    out->health = HEALTH_OK;
}

void node_motion_nav(const node_motion_t *m, double t_s, timeTag_t stamp, uint32_t count, navFilterState_t *out) {
    ub_motion_state_t s;
    ub_motion_sample(&m->path, t_s, &s);
    double c = cos(s.heading_rad), sn = sin(s.heading_rad);
    out->time = stamp;
    out->positionNed = (vector3d_t){s.north_m, s.east_m, -s.up_m};
    out->velocityNed = (vector3d_t){s.vel_ned[0], s.vel_ned[1], s.vel_ned[2]};
    out->attitude = (quaternion_t){s.attitude[0], s.attitude[1], s.attitude[2], s.attitude[3]};
    const double dcm[3][3] = {{c, -sn, 0.0}, {sn, c, 0.0}, {0.0, 0.0, 1.0}};
    memcpy(out->dcmBodyToNed, dcm, sizeof dcm);
    for (int i = 0; i < NAV_STATES; i++) out->stateStdDev[i] = 0.1f;
    out->updateCount = count;
    out->aligned = 1;
    out->health = HEALTH_OK;
}
