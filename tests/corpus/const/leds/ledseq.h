/* LED sequences: the const comes through a typedef, on array elements and on a whole array of
 * structs. */
#ifndef LEDSEQ_H
#define LEDSEQ_H

#include <stdint.h>

typedef const uint8_t led_level_t;

typedef struct {
    uint16_t on_ms;
    uint16_t off_ms;
} led_step_t;

typedef struct {
    led_level_t levels[8];
    const led_step_t steps[3];
    const double gamma;
    uint8_t playing;
} led_sequence_t;

extern led_sequence_t ledseq_boot;

#endif
