#ifndef MANUALCONTROLCOMMAND_H
#define MANUALCONTROLCOMMAND_H

#include "../lib/uavobjectmanager.h"

#define MANUALCONTROLCOMMAND_OBJID 0x161A2C98

typedef struct __attribute__((packed)) {
    float Throttle;
    float Roll;
    float Pitch;
    float Yaw;
    float Collective;
    uint16_t Channel[9];
    uint8_t Connected;
    uint8_t FlightModeSwitchPosition;
} ManualControlCommandData;

UAVObjHandle ManualControlCommandHandle(void);

#endif
