#ifndef SYSTEMALARMS_H
#define SYSTEMALARMS_H

#include "../lib/uavobjectmanager.h"

#define SYSTEMALARMS_OBJID 0x7BD9C77A

typedef struct __attribute__((packed)) {
    uint8_t Alarm[22];
    uint8_t ExtendedAlarmStatus[4];
    uint8_t ExtendedAlarmSubStatus[4];
} SystemAlarmsData;

UAVObjHandle SystemAlarmsHandle(void);

#endif
