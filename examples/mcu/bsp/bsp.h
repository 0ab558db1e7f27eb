/*
 * The board support interface the firmware is written against: one millisecond clock, one UART, idle.
 * Everything the uavbus node needs from a board is here, so porting the firmware to another board is
 * writing these functions (bsp/<board>/: startup, vector table, linker script, UART driver); nothing in
 * firmware.c or the uavbus core touches a register.
 *
 * Contract:
 *  - bsp_init() runs once, first thing in main(): clocks, the 1 kHz wake-up tick, the UART at `baud`
 *    (8N1, no flow control) with its receive interrupt on.
 *  - The UART is interrupt-driven on receive (bytes go into a ring the main loop empties with
 *    bsp_uart_read(); a byte arriving with the ring full is counted in bsp_uart_rx_overruns(), never
 *    silently lost) and ring-buffered on transmit (bsp_uart_write() queues a whole frame or nothing,
 *    so a frame is never cut; bsp_uart_service() moves queued bytes to the hardware).
 *  - bsp_idle() sleeps until the next interrupt (tick or UART) unless bytes are still waiting to go.
 * No function allocates; all state is the driver's static storage (one UART per board).
 */
#ifndef BSP_H
#define BSP_H

#include <stddef.h>
#include <stdint.h>

/** A short name of the board ("mps2-an386", "stm32f4"). */
extern const char bsp_board_name[];

void bsp_init(uint32_t baud);

/** Milliseconds since bsp_init() (64 bits: never wraps in practice). From a hardware counter where the board
 *  has one, so that a late tick interrupt loses no time. Main loop only (not reentrant). */
uint64_t bsp_millis(void);

/** Moves up to `cap` received bytes into `buf`. @return how many. */
size_t bsp_uart_read(uint8_t *buf, size_t cap);

/** Queues `len` bytes for transmission: all of them, or none when the ring lacks room. @return 0 or -1. */
int bsp_uart_write(const uint8_t *buf, size_t len);

/** Moves queued bytes to the UART while it takes them (call from the main loop). */
void bsp_uart_service(void);

/** Bytes dropped because the receive ring was full. */
uint32_t bsp_uart_rx_overruns(void);

/** Waits for the next interrupt when nothing is queued for transmission. */
void bsp_idle(void);

/** Fills `out` with what the board has of unpredictability: a TRNG's output where the part has one; on the
 *  MPS2/QEMU board (none) the free-running timer's low bits sampled around UART bytes — NOT an entropy
 *  source, a stand-in for the emulator (docs/security.md, "Microcontrollers"). @return 0, or -1: none. */
int bsp_entropy(uint8_t *out, size_t len);

#endif /* BSP_H */
