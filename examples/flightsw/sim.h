/**
 * @file sim.h
 * @brief Software-in-the-loop simulation: the simulated vehicles' true states
 *        and the environment. With onboardSet.switches.enableSimulation set,
 *        the sensor drivers read from here instead of the hardware.
 */
#ifndef SIM_H
#define SIM_H

#include <stdint.h>
#include "fsw_types.h"

#define SIM_VEHICLES 4

typedef struct simVehicleState {
    timeTag_t time;
    vector3d_t positionNed;
    vector3d_t velocityNed;
    quaternion_t attitude;
    vector3d_t angularRate;
    float rotorRpm;
    float fuelKg;
    uint8_t entityID[12];
    uint8_t crashed;
} simVehicleState_t;

typedef struct simEnvironment {
    timeTag_t time;
    vector3f_t windNed;
    float gustIntensity;
    float turbulenceScale;
    float temperatureC;
    float pressurePa;
    uint32_t randomSeed;
    double timeScale;                /* 1.0 real time; >1 faster */
} simEnvironment_t;

extern simVehicleState_t simVehicleState[SIM_VEHICLES];
extern simEnvironment_t simEnvironment;

#endif /* SIM_H */
