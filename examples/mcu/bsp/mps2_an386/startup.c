/*
 * Reset and vector table of the Arm MPS2 board with the AN386 FPGA image (Cortex-M4), as QEMU's
 * `-machine mps2-an386` models it: code in ZBT SSRAM1 at 0x00000000, data in SSRAM2/3 at 0x20000000
 * (linker script mps2_an386.ld), UART0 receive/transmit on IRQ 0/1.
 *
 * To port: keep Reset_Handler and the sixteen system vectors; list your part's interrupts after them
 * (its reference manual's vector table), pointing the ones you use at your drivers' handlers.
 */
#include <stdint.h>
#include <string.h>

#include "cortex_m.h"

extern int main(void);
void Reset_Handler(void);
void Default_Handler(void);
void SysTick_Handler(void);
void UART0_RX_Handler(void);

/* From the linker script. */
extern uint32_t __stack_top;
extern uint32_t __data_load, __data_start, __data_end, __bss_start, __bss_end;

/* A fault or an unexpected interrupt stops here; a debugger shows which (IPSR). A flight board would
 * record it in a reset-surviving area and let the watchdog reset. */
void Default_Handler(void) {
    for (;;) {
    }
}

void HardFault_Handler(void) __attribute__((weak, alias("Default_Handler")));
void UART0_TX_Handler(void) __attribute__((weak, alias("Default_Handler")));

#define MPS2_IRQS 32u /* AN386: UART0..2, timers, Ethernet, ... (external interrupts 0..31 used here) */

typedef void (*vector_t)(void);

__attribute__((section(".vectors"), used)) const vector_t vector_table[16u + MPS2_IRQS] = {
    (vector_t)(uintptr_t)&__stack_top, /* initial main stack pointer */
    Reset_Handler,
    Default_Handler,   /* NMI */
    HardFault_Handler, /* HardFault */
    Default_Handler,   /* MemManage */
    Default_Handler,   /* BusFault */
    Default_Handler,   /* UsageFault */
    0, 0, 0, 0,        /* reserved */
    Default_Handler,   /* SVCall */
    Default_Handler,   /* DebugMonitor */
    0,                 /* reserved */
    Default_Handler,   /* PendSV */
    SysTick_Handler,   /* SysTick */
    [16 + 0] = UART0_RX_Handler,
    [16 + 1] = UART0_TX_Handler,
    [16 + 2 ... 16 + MPS2_IRQS - 1] = Default_Handler,
};

void Reset_Handler(void) {
    /* The FPU first: the compiler may use floating-point registers anywhere after this (hard float). */
    cm_enable_fpu();
    memcpy(&__data_start, &__data_load, (size_t)((uintptr_t)&__data_end - (uintptr_t)&__data_start));
    memset(&__bss_start, 0, (size_t)((uintptr_t)&__bss_end - (uintptr_t)&__bss_start));
    SCB_VTOR = (uint32_t)(uintptr_t)vector_table;
    (void)main();
    Default_Handler(); /* main never returns on a board */
}
