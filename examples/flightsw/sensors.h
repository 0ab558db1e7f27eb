/**
 * @file sensors.h
 * @brief Aiding and housekeeping sensors: magnetometer, sonar and radar
 *        altimeters, air data, engine, batteries, thermocouples and the
 *        vision system's target tracks.
 */
#ifndef SENSORS_H
#define SENSORS_H

#include <stdint.h>
#include "fsw_types.h"

#define BATTERY_PACKS 2
#define CELLS_PER_PACK 12
#define THERMO_BOARDS 4
#define THERMO_CHANNELS 8
#define CAMERAS 2
#define TRACKS_PER_CAMERA 16

typedef struct magnetometer {
    timeTag_t time;
    vector3f_t fieldBody;            /* Gauss */
    vector3f_t hardIron;
    float softIron[3][3];
    float headingDeg;
    uint8_t valid;
} magnetometer_t;

/** Sonar or radar altimeter. */
typedef struct altimeter {
    timeTag_t time;
    float range;
    float rangeRate;
    float signalStrength;
    uint16_t echoCount;
    uint8_t valid;
    uint8_t outOfRange;
} altimeter_t;

typedef struct airData {
    timeTag_t time;
    float staticPressurePa;
    float dynamicPressurePa;
    float outsideAirTempC;
    float densityAltitude;
    float indicatedAirspeed;
    int32_t rawCounts[2];
} airData_t;

typedef struct engineSensors {
    timeTag_t time;
    float engineRpm;
    float rotorRpm;
    float cylinderHeadTempC[2];
    float fuelLevelPct;
    uint16_t ignitionErrors;
    uint8_t starterEngaged;
} engineSensors_t;

/** One cell of a lithium avionics battery pack. */
typedef struct batteryCell {
    uint16_t millivolts;
    int16_t temperatureDeciC;
    uint8_t balancing;
    uint8_t fault;
} batteryCell_t;

typedef struct thermocouple {
    float temperatureC;
    int16_t rawCounts;
    uint8_t openCircuit;
} thermocouple_t;

/** A target tracked by one camera of the vision system. */
typedef struct cameraTrack {
    timeTag_t time;
    uint16_t trackId;
    uint16_t ageFrames;
    float pixel[2];                  /* image coordinates of the centroid */
    float bearing[2];                /* azimuth, elevation in body axes */
    float range;                     /* < 0 when unknown */
    float size;
    uint8_t confidence;
    uint8_t classification;
} cameraTrack_t;

extern magnetometer_t magnetometer;
extern altimeter_t sonarAltimeter;
extern altimeter_t radarAltimeter;
extern airData_t airData;
extern engineSensors_t engineSensors;
extern batteryCell_t batteryCell[BATTERY_PACKS][CELLS_PER_PACK];
extern thermocouple_t thermocouple[THERMO_BOARDS][THERMO_CHANNELS];
extern cameraTrack_t cameraTrack[CAMERAS][TRACKS_PER_CAMERA];

#endif /* SENSORS_H */
