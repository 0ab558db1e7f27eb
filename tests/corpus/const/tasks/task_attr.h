/* Task attributes of an RTOS scheduler: the build fixes name, priority, stack and period; the
 * scheduler counts runs. */
#ifndef TASK_ATTR_H
#define TASK_ATTR_H

#include <stdint.h>

typedef struct {
    const char name[12];          /* const text (skipped by default: strings) */
    const uint16_t stack_words;
    const uint8_t priority;
    const unsigned core : 2;      /* a const bitfield has no address: skipped, with the reason */
    unsigned spare : 6;
    const uint32_t period_us;
    const uint16_t deadlines_us[4];
    uint32_t runs;
    volatile uint32_t overruns;
} task_attr_t;

extern task_attr_t task_attr_gyro;
extern task_attr_t task_attr_rx;

#endif
