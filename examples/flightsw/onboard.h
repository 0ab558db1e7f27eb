/**
 * @file onboard.h
 * @brief Onboard sets: the top-level configuration and state of each flight
 *        computer. `onboardSet` is the directory the paper uses to explain the
 *        16-byte content ID (its ID is "onboardSboardSet").
 *
 * One set per computer: onboardSet on the primary flight computer (rmax1ob1),
 * onboard2Set on the secondary (rmax1ob2) and fcsSet on the backup computer
 * (fcs20), which runs the same executable with the relay port disabled.
 */
#ifndef ONBOARD_H
#define ONBOARD_H

#include <stdint.h>
#include "fsw_types.h"

struct onboardSet;

/** Software switches; one bit each so the GCS can toggle them in one write. */
typedef struct onboardSwitches {
    unsigned int enableDatalink2 : 1;   /* second wireless link fitted */
    unsigned int enableRelayPort : 1;   /* serial link to the backup computer */
    unsigned int enableVision : 1;
    unsigned int enableSimulation : 1;  /* SITL: sensors come from sim.h */
    unsigned int logLevel : 3;          /* 0 = off .. 7 = every frame */
    unsigned int reserved : 25;
} onboardSwitches_t;

/** The datum all NED positions refer to. */
typedef struct onboardDatum {
    double latitudeDeg;
    double longitudeDeg;
    float altitudeMsl;
    float magneticVariationDeg;
} onboardDatum_t;

typedef struct onboardSet {
    timeTag_t time;
    computerId_t computer;
    vehicleMode_t mode;
    onboardSwitches_t switches;
    onboardDatum_t datum;
    uint16_t softwareVersion;
    uint16_t configCrc;
    float mainLoopRateHz;            /* 100 Hz on rmax1ob1, 50 Hz on fcs20 */
    float controllerGains[4][3];     /* per axis (roll, pitch, yaw, heave): P, I, D */
    _Bool armed;
    _Bool onGround;
    char vehicleName[16];            /* "GTMax", "RMAX-2": operator label, not sent */
    const char *buildDescription;    /* points into the binary's rodata */
    struct onboardSet *peerSet;      /* the other computer's set when co-hosted */
} onboardSet_t;

/** Main-loop timing of one computer. */
typedef struct onboardTiming {
    timeTag_t time;
    uint32_t frameCount;
    uint32_t overrunCount;
    float framePeriodMs;
    float worstFramePeriodMs;
    uint16_t idleMarginPct;
} onboardTiming_t;

extern onboardSet_t onboardSet;      /* rmax1ob1 */
extern onboardSet_t onboard2Set;     /* rmax1ob2 */
extern onboardSet_t fcsSet;          /* fcs20 */
extern onboardTiming_t onboardTiming;
extern onboardTiming_t onboard2Timing;
extern onboardTiming_t fcsTiming;

#endif /* ONBOARD_H */
