#ifndef ATTITUDE_H
#define ATTITUDE_H

#include "../common/fw_types.h"

typedef struct {
    flight_mode_t mode;       /* one byte here: `armed` follows at offset 1, not 4 */
    bool armed;
    uint16_t loop_hz;
    float q[4];
    double home_lat;          /* 8-byte aligned on the EABI */
    int64_t boot_us;
    gps_fix_t fix;
    int8_t trim[3];
    char callsign[8];
    unsigned failsafe_reason : 3;
    unsigned rc_lost : 1;
} attitude_state_t;

extern attitude_state_t attitude_state;
extern attitude_state_t attitude_setpoints[2];

#endif
