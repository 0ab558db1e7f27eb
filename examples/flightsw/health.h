/**
 * @file health.h
 * @brief Health and status: per-process task health, CPU load per computer,
 *        the fault log and the watchdog.
 */
#ifndef HEALTH_H
#define HEALTH_H

#include <stdint.h>
#include "fsw_types.h"

#define HEALTH_TASKS 32
#define FAULT_LOG_SIZE 64
#define COMPUTERS 3

/** Health of one periodic task of the flight software. */
typedef struct taskHealth {
    uint32_t runs;
    uint32_t deadlineMisses;
    float worstRunTimeMs;
    float averageRunTimeMs;
    healthLevel_t level;
    uint8_t priority;
    char taskName[16];
} taskHealth_t;

typedef struct cpuLoad {
    timeTag_t time;
    float loadPct[4];                /* 1 s, 10 s, 1 min, since boot */
    uint32_t freeMemoryKb;
    int16_t boardTemperatureC;
    computerId_t computer;
} cpuLoad_t;

/** One fault log entry; the log is a ring written by every module. */
typedef struct faultLogEntry {
    timeTag_t time;
    uint16_t code;
    uint8_t module;
    healthLevel_t severity;
    int32_t detail[2];
    char text[40];                   /* human-readable summary for the GCS */
} faultLogEntry_t;

typedef struct healthMonitor {
    timeTag_t time;
    healthLevel_t overall;
    healthLevel_t subsystem[12];     /* indexed by the module numbers of faultLogEntry */
    uint16_t activeFaults;
    uint16_t faultLogHead;
    uint64_t uptimeMs;
    signed char gpsHealthTrend;      /* -1 worse, 0 steady, +1 better */
    unsigned short resetCause;
    long long lastResetMs;
} healthMonitor_t;

typedef struct watchdogStatus {
    uint32_t kicks;
    uint32_t nearMisses;
    uint16_t timeoutMs;
    uint8_t armed;
    uint8_t trippedSinceBoot;
    void (*onTrip)(void);            /* safe-state handler */
} watchdogStatus_t;

extern healthMonitor_t healthMonitor;
extern taskHealth_t taskHealth[HEALTH_TASKS];
extern cpuLoad_t cpuLoad[COMPUTERS];
extern faultLogEntry_t faultLog[FAULT_LOG_SIZE];
extern watchdogStatus_t watchdogStatus;

#endif /* HEALTH_H */
