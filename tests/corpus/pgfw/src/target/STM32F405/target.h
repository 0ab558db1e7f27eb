// The board's target header: only its own build may include it (found through the build's -I).
#pragma once

#if !defined(STM32F405) || !defined(__ARM_ARCH_7EM__) || !defined(__ARM_FP)
#error "build for STM32F405 (Cortex-M4F: -mcpu=cortex-m4 -mfloat-abi=hard -DSTM32F405)"
#endif

#define TARGET_BOARD_IDENTIFIER "S405"
#define MAX_PROFILE_COUNT 3
