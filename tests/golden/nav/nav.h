/* A small flight-software header in the paper's style (golden test input). */
#ifndef NAV_H
#define NAV_H

#include <stdint.h>

typedef struct {
    double lat, lon;
    float alt;
} position_t;

struct nav_state {
    position_t pos;
    float vel[3];
    uint8_t mode : 4;
    uint8_t valid : 1;
    const char *label;
};

extern struct nav_state onboardSet;
extern position_t waypoint[2][2];

#endif
