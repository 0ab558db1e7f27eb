/*
 * Board support of the MPS2 AN386 (QEMU mps2-an386): the clock (CMSDK APB timer 0), the 1 kHz SysTick
 * that wakes the main loop, and UART0, an Arm CMSDK APB UART (Cortex-M System Design Kit TRM, "APB
 * UART"), as the uavbus link of the firmware.
 *
 * Time is read from a free-running hardware counter, not counted in the tick interrupt: a tick
 * interrupt that is late loses milliseconds for good (interrupts masked too long on silicon; the
 * emulator's vCPU not scheduled on a loaded host, where QEMU folds overdue SysTick periods into one:
 * the board's clock then ran at 65 % of real time and a 50 Hz row published at 33 Hz). The counter
 * keeps counting whatever the CPU does.
 *
 * The CMSDK UART holds one received byte: the receive interrupt moves it into a ring at once (QEMU
 * does not offer the next byte until DATA was read, so nothing is lost on the emulator; on silicon a
 * byte that arrives before the previous one was read sets RXOVERRUN, counted here). Transmission is
 * polled from the main loop (bsp_uart_service()): the UART takes a byte whenever TXFULL is clear.
 */
#include <stdint.h>

#include "bsp.h"
#include "cortex_m.h"
#include "ring.h"

const char bsp_board_name[] = "mps2-an386";

#define SYSCLK_HZ 25000000u /* MPS2 FPGA system clock (the CPU and the APB peripherals) */

#define TIMER0_BASE 0x40000000u /* CMSDK APB timer: 32-bit down-counter at SYSCLK */
#define TIMER_CTRL REG32(TIMER0_BASE + 0x00u)
#define TIMER_VALUE REG32(TIMER0_BASE + 0x04u)
#define TIMER_RELOAD REG32(TIMER0_BASE + 0x08u)
#define TIMER_CTRL_EN (1u << 0)

#define UART0_BASE 0x40004000u
#define UART0_RX_IRQ 0u
#define UART_DATA REG32(UART0_BASE + 0x00u)
#define UART_STATE REG32(UART0_BASE + 0x04u)
#define UART_CTRL REG32(UART0_BASE + 0x08u)
#define UART_INTSTATUS REG32(UART0_BASE + 0x0Cu) /* read: status; write 1s: clear */
#define UART_BAUDDIV REG32(UART0_BASE + 0x10u)

#define STATE_TXFULL (1u << 0)
#define STATE_RXFULL (1u << 1)
#define STATE_RXOVERRUN (1u << 3)
#define CTRL_TXEN (1u << 0)
#define CTRL_RXEN (1u << 1)
#define CTRL_RXINTEN (1u << 3)
#define INT_RX (1u << 1)

static bsp_ring_t rx_ring, tx_ring;
static volatile uint32_t rx_overruns;
static uint32_t clock_last = 0xFFFFFFFFu; /* last counter value read (main loop only) */
static uint64_t clock_ticks;                /* SYSCLK periods since bsp_init() */

/* Only wakes the CPU from WFI once a millisecond: the clock is TIMER0 (above). */
void SysTick_Handler(void) {}

void UART0_RX_Handler(void) {
    /* Clear first, then drain: a byte that lands after the last RXFULL test raises the interrupt again.
     * (Clearing after the loop lost that byte's interrupt and, the UART holding one byte, every byte after
     * it: the board went deaf after a few seconds of traffic under QEMU, which hands over the next byte
     * from within the DATA read.) */
    UART_INTSTATUS = INT_RX;
    while (UART_STATE & STATE_RXFULL) {
        uint8_t b = (uint8_t)UART_DATA;
        if (bsp_ring_put(&rx_ring, b) != 0) rx_overruns = rx_overruns + 1u;
    }
    if (UART_STATE & STATE_RXOVERRUN) { /* silicon: a byte was lost in the UART itself */
        UART_STATE = STATE_RXOVERRUN;   /* write 1 to clear */
        rx_overruns = rx_overruns + 1u;
    }
}

void bsp_init(uint32_t baud) {
    UART_BAUDDIV = SYSCLK_HZ / baud; /* >= 16 for every rate up to 1.5 Mbit/s */
    UART_CTRL = CTRL_TXEN | CTRL_RXEN | CTRL_RXINTEN;
    cm_nvic_enable(UART0_RX_IRQ);
    TIMER_RELOAD = 0xFFFFFFFFu; /* wraps every 171 s at 25 MHz; bsp_millis() is called far more often */
    TIMER_VALUE = 0xFFFFFFFFu;
    TIMER_CTRL = TIMER_CTRL_EN;
    SYST_RVR = SYSCLK_HZ / 1000u - 1u;
    SYST_CVR = 0;
    SYST_CSR = SYST_CSR_ENABLE | SYST_CSR_TICKINT | SYST_CSR_CLKSOURCE_CPU;
}

uint64_t bsp_millis(void) {
    /* Extends the 32-bit down-counter to 64 bits: the periods since the last read, modulo 2^32, are
     * right as long as reads come less than one wrap (171 s) apart; the main loop reads every tick. */
    uint32_t now = TIMER_VALUE;
    clock_ticks += (uint32_t)(clock_last - now);
    clock_last = now;
    return clock_ticks / (SYSCLK_HZ / 1000u);
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
    while (!(UART_STATE & STATE_TXFULL) && bsp_ring_get(&tx_ring, &b) == 0) UART_DATA = b;
}

uint32_t bsp_uart_rx_overruns(void) { return rx_overruns; }

void bsp_idle(void) {
    /* Interrupts off around the test, so a tick or byte between the test and WFI still wakes it
     * (a pending interrupt ends WFI even while PRIMASK masks it; it runs after cpsie). */
    cm_irq_disable();
    if (bsp_ring_fill(&tx_ring) == 0 && bsp_ring_fill(&rx_ring) == 0) cm_wfi();
    cm_irq_enable();
}

int bsp_entropy(uint8_t *out, size_t len) {
    /* No TRNG on this board: the 25 MHz timer's low bits, read between busy waits of varying length. Under
     * QEMU they follow the host's scheduling; that is unpredictability for a demonstration, not entropy. */
    for (size_t i = 0; i < len; i++) {
        uint32_t t = TIMER_VALUE;
        for (volatile uint32_t spin = (t & 0x3Fu) + 16u; spin > 0; spin--) {
        }
        out[i] = (uint8_t)(t ^ (TIMER_VALUE >> 3) ^ (uint32_t)clock_ticks);
    }
    return 0;
}
