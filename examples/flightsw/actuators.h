/**
 * @file actuators.h
 * @brief Servo commands and feedback, swashplate mixing, tail rotor and the
 *        engine throttle governor of the RMAX helicopter.
 *
 * Servo channel order: 0 lateral cyclic, 1 longitudinal cyclic, 2 collective,
 * 3 tail rotor, 4 throttle, 5 spare, 6 camera pan, 7 camera tilt.
 */
#ifndef ACTUATORS_H
#define ACTUATORS_H

#include <stdint.h>
#include "fsw_types.h"

#define SERVO_CHANNELS 8

/** Command to one servo, written by the controller every frame. */
typedef struct servoCommand {
    uint16_t pulseWidthUs;           /* 1000..2000 */
    int16_t rateLimitUsPerFrame;
    float normalized;                /* -1..+1 before calibration */
    uint8_t source;                  /* 0 autopilot, 1 pilot, 2 failsafe */
    _Bool saturated;
} servoCommand_t;

/** Position feedback of one servo (potentiometer on the output arm). */
typedef struct servoFeedback {
    timeTag_t time;
    int16_t positionCounts;
    int16_t currentMa;
    float positionNormalized;
    uint8_t faultFlags;
} servoFeedback_t;

typedef struct servoCalibration {
    uint16_t minUs;
    uint16_t centerUs;
    uint16_t maxUs;
    int8_t direction;                /* +1 or -1 */
    uint8_t trimLocked;
    char label[16];                  /* "collective": for the GCS page only */
} servoCalibration_t;

typedef struct swashplateMix {
    float mix[3][3];                 /* (lat, lon, coll) -> (servo A, B, C) */
    float collectivePitchRangeDeg[2];
    float cyclicLimitDeg;
    uint8_t type;                    /* 120 or 140 degree CCPM */
} swashplateMix_t;

typedef struct tailRotor {
    float pitchCommandDeg;
    float pitchFeedbackDeg;
    float yawRateGyroGain;
    uint8_t headingHold;
} tailRotor_t;

/** Engine speed governor (the RMAX is driven by a two-stroke engine). */
typedef struct throttleGovernor {
    timeTag_t time;
    float rotorRpmCommand;
    float rotorRpmMeasured;
    float throttleOut;
    float integrator;
    struct {
        float kp;
        float ki;
        float feedForward;
    } gains;
    uint8_t engaged;
    int (*limiterHook)(float *throttle);   /* installed by the test stand only */
} throttleGovernor_t;

typedef struct actuatorOut {
    timeTag_t time;
    float latCyclic;
    float lonCyclic;
    float collective;
    float pedal;
    float throttle;
    uint32_t frame;
} actuatorOut_t;

extern servoCommand_t servoCommand[SERVO_CHANNELS];
extern servoFeedback_t servoFeedback[SERVO_CHANNELS];
extern servoCalibration_t servoCalibration[SERVO_CHANNELS];
extern swashplateMix_t swashplateMix;
extern tailRotor_t tailRotor;
extern throttleGovernor_t throttleGovernor;
extern actuatorOut_t actuatorOut;
extern actuatorOut_t actuatorOutBackup;   /* what fcs20 would command on takeover */

#endif /* ACTUATORS_H */
