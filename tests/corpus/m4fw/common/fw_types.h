#ifndef FW_TYPES_H
#define FW_TYPES_H

#include <stdbool.h>
#include <stdint.h>

/* This tree is built for one MCU only: parsing it as another target is refused, as its build is. */
#if !defined(__ARM_ARCH_7EM__) || !defined(__ARM_FP)
#error "fw_types.h: build for a Cortex-M4F (-mcpu=cortex-m4 -mfloat-abi=hard)"
#endif
#ifndef STM32F405xx
#error "fw_types.h: define the MCU (-DSTM32F405xx)"
#endif

/* arm-none-eabi-gcc packs these into one byte (the ARM EABI's variable-size enums). */
typedef enum { MODE_IDLE, MODE_ARMED, MODE_FLYING, MODE_FAILSAFE } flight_mode_t;
typedef enum { FIX_NONE, FIX_2D, FIX_3D } gps_fix_t;
typedef enum { SENSOR_OK = 0, SENSOR_STALE = 1, SENSOR_FAILED = 0x7f } sensor_health_t;

#endif
