/*
 * The few Armv7-M system registers every Cortex-M3/M4 board uses (SysTick, NVIC, SCB), at the
 * addresses the architecture fixes (Armv7-M ARM, B3.2-B3.4). No vendor header needed.
 */
#ifndef BSP_CORTEX_M_H
#define BSP_CORTEX_M_H

#include <stdint.h>

#define REG32(addr) (*(volatile uint32_t *)(uintptr_t)(addr))

#define SYST_CSR REG32(0xE000E010u) /* SysTick control and status */
#define SYST_RVR REG32(0xE000E014u) /* reload value */
#define SYST_CVR REG32(0xE000E018u) /* current value */
#define SYST_CSR_ENABLE (1u << 0)
#define SYST_CSR_TICKINT (1u << 1)
#define SYST_CSR_CLKSOURCE_CPU (1u << 2)

#define NVIC_ISER(n) REG32(0xE000E100u + 4u * (n)) /* interrupt set-enable */
#define NVIC_IPR_BYTE(irq) (*(volatile uint8_t *)(uintptr_t)(0xE000E400u + (irq)))

#define SCB_VTOR REG32(0xE000ED08u)  /* vector table offset */
#define SCB_CPACR REG32(0xE000ED88u) /* coprocessor access: CP10/CP11 = the FPU */

static inline void cm_enable_fpu(void) {
    SCB_CPACR |= (0xFu << 20); /* CP10 and CP11 full access: before the first floating-point instruction */
    __asm__ volatile("dsb\n\tisb" ::: "memory");
}

static inline void cm_nvic_enable(unsigned irq) { NVIC_ISER(irq / 32u) = 1u << (irq % 32u); }

static inline void cm_wfi(void) { __asm__ volatile("wfi" ::: "memory"); }
static inline void cm_irq_disable(void) { __asm__ volatile("cpsid i" ::: "memory"); }
static inline void cm_irq_enable(void) { __asm__ volatile("cpsie i" ::: "memory"); }

#endif /* BSP_CORTEX_M_H */
