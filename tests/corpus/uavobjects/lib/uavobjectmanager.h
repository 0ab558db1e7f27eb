/* The object manager of a UAVObject-style autopilot: objects are created at run time and reached
 * through opaque handles; no object data is a global variable. */
#ifndef UAVOBJECTMANAGER_H
#define UAVOBJECTMANAGER_H

#include <stdbool.h>
#include <stdint.h>

typedef void *UAVObjHandle;

/* Manager bookkeeping: struct types, but not object data (the pattern must not pick them). */
typedef struct {
    uint32_t objId;
    uint16_t instId;
    uint16_t event;
} UAVObjEvent;

typedef struct {
    uint8_t flags;
    uint16_t telemetryUpdatePeriod;
    uint16_t loggingUpdatePeriod;
} UAVObjMetadata;

int32_t UAVObjGetData(UAVObjHandle obj, void *dataOut);
int32_t UAVObjSetData(UAVObjHandle obj, const void *dataIn);

#endif
