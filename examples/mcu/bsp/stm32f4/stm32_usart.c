/*
 * Board support of an STM32F405/407 running from its 16 MHz internal oscillator (HSI, the reset clock:
 * no PLL set-up to get wrong on an unknown board): SysTick at 1 kHz and USART2 on PA2 (TX) / PA3 (RX),
 * alternate function 7 (RM0090 sections 6, 8, 30). Same contract as bsp/mps2_an386 (bsp.h). Built in CI
 * to keep the template honest; run on a board, untested here.
 */
#include <stdint.h>

#include "bsp.h"
#include "cortex_m.h"
#include "ring.h"

const char bsp_board_name[] = "stm32f4";

#define HCLK_HZ 16000000u /* HSI; APB1 undivided at reset */

#define RCC_AHB1ENR REG32(0x40023830u)
#define RCC_APB1ENR REG32(0x40023840u)
#define GPIOA_MODER REG32(0x40020000u)
#define GPIOA_AFRL REG32(0x40020020u)
#define USART2_BASE 0x40004400u
#define USART_SR REG32(USART2_BASE + 0x00u)
#define USART_DR REG32(USART2_BASE + 0x04u)
#define USART_BRR REG32(USART2_BASE + 0x08u)
#define USART_CR1 REG32(USART2_BASE + 0x0Cu)
#define USART2_IRQ 38u

#define SR_ORE (1u << 3)
#define SR_RXNE (1u << 5)
#define SR_TXE (1u << 7)
#define CR1_RE (1u << 2)
#define CR1_TE (1u << 3)
#define CR1_RXNEIE (1u << 5)
#define CR1_UE (1u << 13)

static bsp_ring_t rx_ring, tx_ring;
static volatile uint32_t rx_overruns;
static volatile uint64_t millis;

void SysTick_Handler(void) { millis = millis + 1u; }

void USART2_IRQHandler(void) {
    uint32_t sr = USART_SR;
    if (sr & (SR_RXNE | SR_ORE)) {
        uint8_t b = (uint8_t)USART_DR; /* reading SR then DR also clears ORE */
        if (sr & SR_ORE) rx_overruns = rx_overruns + 1u;
        if (bsp_ring_put(&rx_ring, b) != 0) rx_overruns = rx_overruns + 1u;
    }
}

void bsp_init(uint32_t baud) {
    RCC_AHB1ENR |= 1u << 0;  /* GPIOA */
    RCC_APB1ENR |= 1u << 17; /* USART2 */
    GPIOA_MODER = (GPIOA_MODER & ~(0xFu << 4)) | (0xAu << 4); /* PA2, PA3: alternate function */
    GPIOA_AFRL = (GPIOA_AFRL & ~(0xFFu << 8)) | (0x77u << 8); /* AF7: USART2 */
    USART_BRR = (HCLK_HZ + baud / 2u) / baud;                 /* oversampling by 16: mantissa.fraction */
    USART_CR1 = CR1_UE | CR1_TE | CR1_RE | CR1_RXNEIE;
    cm_nvic_enable(USART2_IRQ);
    SYST_RVR = HCLK_HZ / 1000u - 1u;
    SYST_CVR = 0;
    SYST_CSR = SYST_CSR_ENABLE | SYST_CSR_TICKINT | SYST_CSR_CLKSOURCE_CPU;
}

uint64_t bsp_millis(void) {
    uint64_t a, b;
    do {
        a = millis;
        b = millis;
    } while (a != b);
    return a;
}

size_t bsp_uart_read(uint8_t *buf, size_t cap) {
    size_t n = 0;
    while (n < cap && bsp_ring_get(&rx_ring, &buf[n]) == 0) n++;
    return n;
}

int bsp_uart_write(const uint8_t *buf, size_t len) {
    if (BSP_RING_SIZE - bsp_ring_fill(&tx_ring) < len) return -1;
    for (size_t i = 0; i < len; i++) (void)bsp_ring_put(&tx_ring, buf[i]);
    bsp_uart_service();
    return 0;
}

void bsp_uart_service(void) {
    uint8_t b;
    while ((USART_SR & SR_TXE) && bsp_ring_get(&tx_ring, &b) == 0) USART_DR = b;
}

uint32_t bsp_uart_rx_overruns(void) { return rx_overruns; }

void bsp_idle(void) {
    cm_irq_disable();
    if (bsp_ring_fill(&tx_ring) == 0 && bsp_ring_fill(&rx_ring) == 0) cm_wfi();
    cm_irq_enable();
}

int bsp_entropy(uint8_t *out, size_t len) {
    /* The STM32F4's RNG peripheral is the source to use here; not written yet: no randomness (the firmware
     * then refuses to turn security on rather than run with a guessable generator). */
    (void)out;
    (void)len;
    return -1;
}
