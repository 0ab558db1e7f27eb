/*
 * Reset and vector table of an STM32F405/407 (Cortex-M4F; RM0090 table 61): flash at 0x08000000,
 * SRAM1/2 at 0x20000000 (linker script stm32f4.ld), USART2 on IRQ 38. Built, not run here (QEMU has no
 * STM32F4 board with this USART); the same firmware.c runs on it unchanged.
 */
#include <stdint.h>
#include <string.h>

#include "cortex_m.h"

extern int main(void);
void Reset_Handler(void);
void Default_Handler(void);
void SysTick_Handler(void);
void USART2_IRQHandler(void);

extern uint32_t __stack_top;
extern uint32_t __data_load, __data_start, __data_end, __bss_start, __bss_end;

void Default_Handler(void) {
    for (;;) {
    }
}

void HardFault_Handler(void) __attribute__((weak, alias("Default_Handler")));

#define STM32F4_IRQS 82u
#define USART2_IRQ 38u

typedef void (*vector_t)(void);

__attribute__((section(".vectors"), used)) const vector_t vector_table[16u + STM32F4_IRQS] = {
    (vector_t)(uintptr_t)&__stack_top,
    Reset_Handler,
    Default_Handler,   /* NMI */
    HardFault_Handler, /* HardFault */
    Default_Handler,   /* MemManage */
    Default_Handler,   /* BusFault */
    Default_Handler,   /* UsageFault */
    0, 0, 0, 0,
    Default_Handler,   /* SVCall */
    Default_Handler,   /* DebugMonitor */
    0,
    Default_Handler,   /* PendSV */
    SysTick_Handler,
    [16 ... 16 + USART2_IRQ - 1] = Default_Handler,
    [16 + USART2_IRQ] = USART2_IRQHandler,
    [16 + USART2_IRQ + 1 ... 16 + STM32F4_IRQS - 1] = Default_Handler,
};

void Reset_Handler(void) {
    cm_enable_fpu();
    memcpy(&__data_start, &__data_load, (size_t)((uintptr_t)&__data_end - (uintptr_t)&__data_start));
    memset(&__bss_start, 0, (size_t)((uintptr_t)&__bss_end - (uintptr_t)&__bss_start));
    SCB_VTOR = (uint32_t)(uintptr_t)vector_table;
    (void)main();
    Default_Handler();
}
