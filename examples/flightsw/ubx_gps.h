/**
 * @file ubx_gps.h
 * @brief The directory a u-blox receiver becomes: what the UBX adapter (programs/node/adapter_ubx.c, port
 *        spec `ubx:device=...`) writes from the receiver's NAV-PVT messages, published like any directory.
 *
 * The adapter's half of the catalogue (docs/adapters.md), as nmea_gps.h is for NMEA. Writing goes the
 * other way: a node that writes `gpsUbxCfg` (a publication to the node hosting the port) makes the adapter
 * send the receiver a UBX-CFG-RATE and wait for its ACK; the outcome is counted in `gpsUbx`.
 */
#ifndef UBX_GPS_H
#define UBX_GPS_H

#include <stdint.h>
#include "fsw_types.h"

/** The receiver's last NAV-PVT solution, in SI units. */
typedef struct ubxGps {
    timeTag_t time;            /* node time (monotonic) of the last NAV-PVT decoded */
    double latitudeDeg;
    double longitudeDeg;
    double altitudeMsl;        /* m */
    double heightEllipsoid;    /* m */
    double groundSpeedMps;
    double headingDeg;         /* heading of motion */
    float velNorth;            /* m/s */
    float velEast;
    float velDown;
    float hAccuracy;           /* m */
    float vAccuracy;           /* m */
    float pdop;
    uint32_t iTowMs;           /* GPS time of week of the epoch */
    uint16_t year;
    uint8_t month;
    uint8_t day;
    uint8_t hour;
    uint8_t minute;
    uint8_t second;
    uint8_t fixType;           /* 0 none, 1 DR, 2 2D, 3 3D, 4 GNSS+DR, 5 time only */
    uint8_t satellitesUsed;
    uint32_t navPvtOk;         /* NAV-PVT decoded so far */
    uint32_t badChecksums;     /* messages whose checksum did not match: never decoded */
    uint32_t badMessages;      /* NAV-PVT of the wrong length, or messages too long to keep */
    uint32_t cfgSent;          /* CFG-RATE messages written to the receiver (gpsUbxCfg changed, or a retry) */
    uint32_t cfgAcked;         /* answered ACK-ACK: applied */
    uint32_t cfgNaked;         /* answered ACK-NAK: refused by the receiver */
    uint32_t cfgTimeouts;      /* no answer within a second: sent again */
    uint16_t cfgMeasRateMs;    /* the measurement period the receiver last acknowledged (0: none yet) */
} ubxGps_t;

/** What is written to the receiver: its navigation rate (UBX-CFG-RATE). measRateMs 0 writes nothing. */
typedef struct ubxCfg {
    uint16_t measRateMs;       /* measurement period, ms (e.g. 200 for 5 Hz) */
    uint16_t navRate;          /* measurements per navigation solution (1..127) */
    uint16_t timeRef;          /* 0 UTC, 1 GPS time */
} ubxCfg_t;

/** The u-blox receiver on the vehicle's serial port. */
extern ubxGps_t gpsUbx;
/** Its configuration, written by anyone in the fleet (the adapter looks for `<dir>Cfg`). */
extern ubxCfg_t gpsUbxCfg;

#endif /* UBX_GPS_H */
