/* Navigation telemetry: enums, bitfields, an unnamed nested struct, a union and a pointer. */
#ifndef NAV_MSG_H
#define NAV_MSG_H

#include "common_types.h"
#include "msg_hdr.h"
#include "platform_cfg.h"

typedef enum { NAV_MODE_IDLE = 0, NAV_MODE_ALIGN = 1, NAV_MODE_NAV = 2, NAV_MODE_FAULT = 0xFF } NAV_Mode_t;
enum nav_fix { NAV_FIX_NONE, NAV_FIX_2D, NAV_FIX_3D, NAV_FIX_RTK = 5 };

typedef struct {
    TLM_Hdr_t Hdr;
    NAV_Mode_t Mode;
    enum nav_fix Fix;
    double LatDeg;
    double LonDeg;
    float AltM;
    float VelNed[3];
    struct {
        uint8 GpsOk : 1;
        uint8 ImuOk : 1;
        uint8 BaroOk : 1;
        uint8 Spare : 5;
    } Health;
    uint16 SatsUsed : 6;
    int16 ClockDrift : 10;
    bool Valid;
    union {
        uint32 Raw;
        float Scaled;
    } AuxData;
    const char *Note;
} NAV_HkTlm_t;

typedef struct NAV_Waypoint {
    double Lat;
    double Lon;
    float Alt;
    uint8 Action;
    char Tag[8];
} NAV_Waypoint_t;

typedef struct {
    TLM_Hdr_t Hdr;
    uint16 Count;
    NAV_Waypoint_t Wpt[NAV_MAX_WAYPOINTS];
} NAV_Route_t;

extern NAV_HkTlm_t NAV_HkTlm;
extern NAV_Route_t NAV_Route;
extern NAV_Route_t NAV_AltRoutes[2];

#endif
