/* Circle motion model of uavbus_node (node_motion.h). */
#include "node_motion.h"

#include <math.h>
#include <string.h>

#define EARTH_RADIUS_M 6378137.0
#define GRAVITY_MPS2 9.80665
#define DEG_PER_RAD (180.0 / M_PI)

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

void node_motion_init(node_motion_t *m) {
    memset(m, 0, sizeof *m);
    m->lat0_deg = 32.3738;
    m->lon0_deg = -84.9664;
    m->alt0_m = 120.0;
    m->radius_m = 200.0;
    m->speed_mps = 10.0;
}

/* Angle around the circle (0 = north of the centre), turn rate, position and velocity NED. */
typedef struct kin {
    double omega;                 /* rad/s, positive = clockwise from above = right turn */
    double heading;               /* rad from north */
    double n, e, vn, ve;
} kin_t;

static kin_t kinematics(const node_motion_t *m, double t_s) {
    kin_t k;
    k.omega = m->speed_mps / m->radius_m;
    double a = k.omega * t_s;
    k.n = m->radius_m * cos(a);
    k.e = m->radius_m * sin(a);
    k.vn = -m->speed_mps * sin(a);
    k.ve = m->speed_mps * cos(a);
    k.heading = atan2(k.ve, k.vn);
    return k;
}

void node_motion_gps(const node_motion_t *m, double t_s, timeTag_t stamp, gpsOut_t *out) {
    kin_t k = kinematics(m, t_s);
    out->time = stamp;
    out->latitudeDeg = m->lat0_deg + (k.n / EARTH_RADIUS_M) * DEG_PER_RAD;
    out->longitudeDeg = m->lon0_deg + (k.e / (EARTH_RADIUS_M * cos(m->lat0_deg / DEG_PER_RAD))) * DEG_PER_RAD;
    out->altitudeMsl = m->alt0_m;
    out->velocityNed = (vector3f_t){(float)k.vn, (float)k.ve, 0.0f};
    out->horizontalAccuracy = 1.5f;
    out->verticalAccuracy = 3.0f;
    out->pdop = 1.4f;
    out->fix = GPS_FIX_3D;
    out->satellitesUsed = 9;
    out->status.antennaOk = 1;
    out->status.almanacValid = 1;
    out->solutionCount++;
}

void node_motion_imu(const node_motion_t *m, double t_s, double dt_s, timeTag_t stamp, imuOut_t *out) {
    kin_t k = kinematics(m, t_s);
    double centripetal = m->speed_mps * k.omega; /* v^2 / r, toward the centre = body right in a right turn */
    out->time = stamp;
    /* A steady turn has constant body rates; a gentle, deterministic roll and pitch oscillation (as from
     * gusts and the pilot's corrections) gives receivers and plots values that change with time. */
    out->p = 0.20 * sin(2.0 * M_PI * 0.40 * t_s);
    out->q = 0.10 * sin(2.0 * M_PI * 0.25 * t_s + 1.0);
    out->r = k.omega;
    out->specificForce = (vector3d_t){0.0, centripetal, -GRAVITY_MPS2};
    out->deltaVelocity = (vector3d_t){0.0, centripetal * dt_s, -GRAVITY_MPS2 * dt_s};
    out->deltaAngle = (vector3d_t){out->p * dt_s, out->q * dt_s, out->r * dt_s};
    out->temperatureC = 35.0f;
    out->sampleCount++;
    out->saturated = 0;
    out->health = HEALTH_OK;
}

void node_motion_nav(const node_motion_t *m, double t_s, timeTag_t stamp, navFilterState_t *out) {
    kin_t k = kinematics(m, t_s);
    double c = cos(k.heading), s = sin(k.heading);
    out->time = stamp;
    out->positionNed = (vector3d_t){k.n, k.e, 0.0};
    out->velocityNed = (vector3d_t){k.vn, k.ve, 0.0};
    out->attitude = (quaternion_t){cos(k.heading / 2.0), 0.0, 0.0, sin(k.heading / 2.0)};
    const double dcm[3][3] = {{c, -s, 0.0}, {s, c, 0.0}, {0.0, 0.0, 1.0}};
    memcpy(out->dcmBodyToNed, dcm, sizeof dcm);
    for (int i = 0; i < NAV_STATES; i++) out->stateStdDev[i] = 0.1f;
    out->updateCount++;
    out->aligned = 1;
    out->health = HEALTH_OK;
}
