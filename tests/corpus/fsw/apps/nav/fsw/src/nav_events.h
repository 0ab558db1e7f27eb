/* Private to the app's sources, and not self-contained: nav_app.c includes common_types.h first. */
#ifndef NAV_EVENTS_H
#define NAV_EVENTS_H

typedef struct {
    uint16 EventId;
    uint16 Count;
    CFE_TIME_SysTime_t Last;
} NAV_EventCount_t;

typedef struct {
    uint32 Total;
    NAV_EventCount_t Counts[8];
} NAV_EventLog_t;

#endif
