#ifndef GPSPOSITIONSENSOR_H
#define GPSPOSITIONSENSOR_H

#include "../lib/uavobjectmanager.h"

#define GPSPOSITIONSENSOR_OBJID 0x9DF1F67A

typedef struct __attribute__((packed)) {
    int32_t Latitude;
    int32_t Longitude;
    float Altitude;
    float GeoidSeparation;
    float Heading;
    float Groundspeed;
    float PDOP;
    float HDOP;
    float VDOP;
    uint8_t Status;
    int8_t Satellites;
    uint8_t SensorType;
    uint8_t AutoConfig;
    uint16_t BaudRate;
} GPSPositionSensorData;

UAVObjHandle GPSPositionSensorHandle(void);

#endif
