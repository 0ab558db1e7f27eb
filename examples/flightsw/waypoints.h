/**
 * @file waypoints.h
 * @brief Flight plans: the active waypoint plan onboard, rally points, loiter
 *        patterns, the range geofence, and the GCS's copy of each
 *        vehicle's mission.
 *
 * Waypoints are uploaded one array element at a time, so every element is its
 * own directory ("waypointPlan[17]") and a lost upload only resends one.
 */
#ifndef WAYPOINTS_H
#define WAYPOINTS_H

#include <stdint.h>
#include "fsw_types.h"

#define WAYPOINT_PLAN_SIZE 128
#define RALLY_POINTS 16
#define LOITER_PATTERNS 8
#define GCS_MISSION_SIZE 64
#define GEOFENCE_VERTICES 32

typedef enum waypointAction {
    WPT_FLY_THROUGH = 0,
    WPT_STOP_AND_HOVER = 1,
    WPT_LOITER = 2,
    WPT_TAKE_PICTURE = 3,
    WPT_LAND = 4
} waypointAction_t;

typedef struct waypoint {
    double latitudeDeg;
    double longitudeDeg;
    float altitudeMsl;
    float speed;                     /* m/s towards this waypoint */
    float acceptanceRadius;
    float headingDeg;                /* NAN: keep course */
    waypointAction_t action;
    uint16_t holdSeconds;
    uint16_t next;                   /* index of the next waypoint; 0xFFFF ends the plan */
    uint8_t flags;
    uint8_t valid;
} waypoint_t;

typedef struct waypointPlanStatus {
    timeTag_t time;
    uint16_t activeIndex;
    uint16_t planLength;
    uint32_t planCrc;
    float distanceToGo;
    float timeToGo;
    uint8_t uploadInProgress;
} waypointPlanStatus_t;

/** Racetrack or circular loiter around a point. */
typedef struct loiterPattern {
    double centerLatDeg;
    double centerLonDeg;
    float radius;
    float legLength;                 /* 0 for a circle */
    float altitudeMsl;
    int8_t direction;                /* +1 clockwise */
    uint8_t valid;
} loiterPattern_t;

/** One corner of the flight-test range polygon; the vehicle aborts outside it. */
typedef struct geofenceVertex {
    double latitudeDeg;
    double longitudeDeg;
    float floorMsl;
    float ceilingMsl;
    uint8_t used;
} geofenceVertex_t;

extern waypoint_t waypointPlan[WAYPOINT_PLAN_SIZE];
extern waypoint_t rallyPoint[RALLY_POINTS];
extern waypointPlanStatus_t waypointPlanStatus;
extern loiterPattern_t loiterPattern[LOITER_PATTERNS];
extern waypoint_t gcsMissionRmax1[GCS_MISSION_SIZE];
extern waypoint_t gcsMissionRmax2[GCS_MISSION_SIZE];
extern geofenceVertex_t geofenceVertex[GEOFENCE_VERTICES];

#endif /* WAYPOINTS_H */
