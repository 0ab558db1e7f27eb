/* Generated from attitudestate.xml (UAVObject style). */
#ifndef ATTITUDESTATE_H
#define ATTITUDESTATE_H

#include "../lib/uavobjectmanager.h"

#define ATTITUDESTATE_OBJID 0xD7E0D964
#define ATTITUDESTATE_NUMBYTES sizeof(AttitudeStateData)

typedef struct __attribute__((packed)) {
    float q1;
    float q2;
    float q3;
    float q4;
    float Roll;
    float Pitch;
    float Yaw;
} AttitudeStateData;

UAVObjHandle AttitudeStateHandle(void);
static inline int32_t AttitudeStateGet(AttitudeStateData *d) { return UAVObjGetData(AttitudeStateHandle(), d); }

#endif
