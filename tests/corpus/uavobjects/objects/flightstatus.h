#ifndef FLIGHTSTATUS_H
#define FLIGHTSTATUS_H

#include "../lib/uavobjectmanager.h"

#define FLIGHTSTATUS_OBJID 0x24D25E28

typedef enum __attribute__((packed)) {
    FLIGHTSTATUS_ARMED_DISARMED = 0,
    FLIGHTSTATUS_ARMED_ARMING = 1,
    FLIGHTSTATUS_ARMED_ARMED = 2
} FlightStatusArmedOptions;

typedef enum __attribute__((packed)) {
    FLIGHTSTATUS_FLIGHTMODE_MANUAL = 0,
    FLIGHTSTATUS_FLIGHTMODE_STABILIZED1 = 1,
    FLIGHTSTATUS_FLIGHTMODE_POSITIONHOLD = 7
} FlightStatusFlightModeOptions;

typedef struct __attribute__((packed)) {
    FlightStatusArmedOptions Armed;
    FlightStatusFlightModeOptions FlightMode;
    bool AlwaysStabilizeWhenArmed;
    uint8_t ControlChain[3];
} FlightStatusData;

UAVObjHandle FlightStatusHandle(void);

#endif
