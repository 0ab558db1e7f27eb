/**
 * @file nmea_gps.h
 * @brief The directory a COTS NMEA 0183 GPS receiver becomes: what the NMEA adapter
 *        (programs/node/adapter_nmea.c, port spec `nmea:device=...`) writes from the receiver's
 *        GGA, RMC, VTG and GSA sentences, and the node publishes like any other directory.
 *
 * This header is the adapter's half of the catalogue (docs/adapters.md): the generator catalogues it with
 * the rest of this folder, and the adapter includes it for the layout it writes.
 */
#ifndef NMEA_GPS_H
#define NMEA_GPS_H

#include <stdint.h>
#include "fsw_types.h"

/** The receiver's fix as its sentences tell it; empty fields leave a value as it was. */
typedef struct nmeaGps {
    timeTag_t time;            /* node time (monotonic) of the last sentence merged */
    double latitudeDeg;        /* + north */
    double longitudeDeg;       /* + east */
    double altitudeMsl;        /* GGA, m */
    double geoidSeparation;    /* GGA, m */
    double speedMps;           /* RMC or VTG speed over ground, m/s */
    double courseDeg;          /* RMC or VTG true course, deg */
    float hdop;
    float pdop;
    float vdop;
    uint32_t utcMilliseconds;  /* time of day of the fix, ms since 00:00 UTC */
    uint32_t utcDate;          /* RMC date as sent, ddmmyy; 0 until seen */
    uint8_t fixQuality;        /* GGA: 0 invalid, 1 GPS, 2 DGPS, 4 RTK fixed... */
    uint8_t fixType;           /* GSA: 1 none, 2 2D, 3 3D; 0 until seen */
    uint8_t satellitesUsed;    /* GGA */
    uint8_t statusValid;       /* RMC status: 1 'A', 0 'V' */
    uint32_t sentencesOk;      /* good GGA/RMC/VTG/GSA merged so far */
    uint32_t badChecksums;     /* sentences whose checksum did not match: never merged */
    uint32_t badSentences;     /* no checksum, malformed field or overlong line: never merged */
} nmeaGps_t;

/** The receiver on the vehicle's serial port. */
extern nmeaGps_t gpsNmea;

#endif /* NMEA_GPS_H */
