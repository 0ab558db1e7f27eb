/**
 * @file traffic.h
 * @brief Traffic picture: the states of other aircraft as each vehicle of the
 *        team sees them (own datalink reports plus transponder returns).
 *
 * One traffic array per vehicle, indexed by track number; the GCS fuses them
 * into trafficSummary.
 */
#ifndef TRAFFIC_H
#define TRAFFIC_H

#include <stdint.h>
#include "fsw_types.h"

#define TRAFFIC_TRACKS 24

typedef enum trafficSource {
    TRAFFIC_TEAM_DATALINK = 0,
    TRAFFIC_TRANSPONDER = 1,
    TRAFFIC_VISION = 2,
    TRAFFIC_SIMULATED = 3
} trafficSource_t;

typedef struct trafficTrack {
    timeTag_t lastUpdate;
    uint32_t icaoAddress;            /* 0 for team members */
    uint8_t teamEntityID[12];        /* entity ID when the track is a team member */
    double latitudeDeg;
    double longitudeDeg;
    float altitudeMsl;
    vector3f_t velocityNed;
    float headingDeg;
    trafficSource_t source;
    struct {
        unsigned int valid : 1;
        unsigned int coasting : 1;   /* no update for more than 2 s */
        unsigned int threat : 2;     /* 0 none .. 3 resolution advisory */
        unsigned int : 4;
    } flags;
    char callsign[9];
} trafficTrack_t;

typedef struct trafficSummary {
    timeTag_t time;
    uint16_t tracksValid;
    uint16_t threats;
    float closestRange;
    float closestTimeToCpa;
    uint8_t closestTrack;
    uint8_t closestVehicle;
} trafficSummary_t;

extern trafficTrack_t trafficRmax1[TRAFFIC_TRACKS];
extern trafficTrack_t trafficRmax2[TRAFFIC_TRACKS];
extern trafficTrack_t trafficGTMax[TRAFFIC_TRACKS];
extern trafficSummary_t trafficSummary;

#endif /* TRAFFIC_H */
