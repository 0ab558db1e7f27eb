/* A settings table in the style of flight-controller CLIs: each row describes one setting, and
 * everything but the value is fixed when the firmware is built, so it is declared const. */
#ifndef SETTINGS_H
#define SETTINGS_H

#include <stdbool.h>
#include <stdint.h>

typedef enum { VAR_UINT8, VAR_INT16, VAR_FLOAT } setting_type_e;

typedef struct {
    const int16_t min;
    const int16_t max;
} setting_range_t;

typedef struct {
    const char *name;             /* a pointer: not on the wire */
    const setting_type_e type;    /* const enum: the `assignment of read-only member 'type'` case */
    const setting_range_t range;  /* const nested struct: its members are read-only too */
    const uint8_t flags[2];       /* const byte array */
    const float scale;
    const bool persistent;
    int16_t value;                /* the one member the firmware writes */
} setting_t;

#define SETTINGS_COUNT 3
extern setting_t settings[SETTINGS_COUNT];

#endif
