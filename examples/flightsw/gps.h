/**
 * @file gps.h
 * @brief GPS receivers: the raw receiver log, the position/velocity solution,
 *        the per-channel tracking state and the broadcast ephemeris.
 *
 * The primary receiver feeds rmax1ob1 (gpsOut, published to gcs1 every 2 s in
 * the paper's Figure 5); the backup receiver feeds fcs20 (gpsOutBackup).
 */
#ifndef GPS_H
#define GPS_H

#include <stdint.h>
#include "fsw_types.h"

#define GPS_CHANNELS 12     /* tracking channels per receiver */
#define GPS_MAX_PRN 32      /* satellites with a stored ephemeris */

/**
 * Header of the receiver's binary log, exactly as it arrives on the serial
 * port. Packed: the receiver puts the 32-bit week seconds at offset 3.
 */
typedef struct __attribute__((packed)) gpsLogHeader {
    uint8_t sync;
    uint16_t messageId;
    uint32_t weekMilliseconds;
    uint16_t week;
    uint8_t receiverStatus;
    int8_t leapSeconds;
} gpsLogHeader_t;

/** Raw measurements of the last epoch. */
typedef struct gpsRaw {
    timeTag_t time;
    gpsLogHeader_t header;
    uint8_t rawMessage[72];          /* last log as received (binary data) */
    uint16_t bytesReceived;
    uint16_t checksumErrors;
    char receiverModel[24];          /* from the receiver's version log */
} gpsRaw_t;

/** Position/velocity solution; the gpsOut directory. */
typedef struct gpsOut {
    timeTag_t time;
    double latitudeDeg;
    double longitudeDeg;
    double altitudeMsl;
    vector3f_t velocityNed;
    float horizontalAccuracy;
    float verticalAccuracy;
    float pdop;
    gpsFixType_t fix;
    uint8_t satellitesUsed;
    struct {                         /* receiver status word */
        unsigned int antennaOk : 1;
        unsigned int differential : 1;
        unsigned int almanacValid : 1;
        unsigned int clockSteering : 1;
        unsigned int jammingLevel : 4;
    } status;
    uint32_t solutionCount;
} gpsOut_t;

/** Tracking state of one receiver channel. */
typedef struct gpsChannel {
    uint8_t prn;
    uint8_t elevationDeg;
    uint16_t azimuthDeg;
    float cn0;                       /* carrier-to-noise density, dB-Hz */
    int32_t pseudorangeResidualCm;
    _Bool usedInSolution;
    _Bool ephemerisValid;
} gpsChannel_t;

/** Broadcast ephemeris of one satellite (IS-GPS-200 subframes 2 and 3). */
typedef struct gpsEphemeris {
    uint8_t prn;
    uint8_t health;
    uint16_t iode;
    uint32_t toe;
    double sqrtA;
    double eccentricity;
    double i0;
    double omega0;
    double omega;
    double m0;
    double deltaN;
    double omegaDot;
    double iDot;
    float harmonic[6];               /* Cuc, Cus, Crc, Crs, Cic, Cis */
    double clockBias[3];             /* af0, af1, af2 */
} gpsEphemeris_t;

extern gpsRaw_t gpsRaw;
extern gpsOut_t gpsOut;
extern gpsOut_t gpsSolution;         /* after lever-arm and latency correction */
extern gpsOut_t gpsOutBackup;        /* fcs20's own receiver */
extern gpsChannel_t gpsChannelPrimary[GPS_CHANNELS];
extern gpsChannel_t gpsChannelBackup[GPS_CHANNELS];
extern gpsEphemeris_t gpsEphemeris[GPS_MAX_PRN];

#endif /* GPS_H */
