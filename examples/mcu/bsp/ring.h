/*
 * A single-producer single-consumer byte ring shared by an interrupt and the main loop: the producer
 * only writes `head`, the consumer only `tail`; both are free-running 32-bit counters (the fill is
 * head - tail, correct across wrap-around), and the size is a power of two so the index is a mask.
 * On a Cortex-M an aligned 32-bit load or store is atomic; the compiler barrier orders the data
 * access before the index update that publishes it.
 */
#ifndef BSP_RING_H
#define BSP_RING_H

#include <stddef.h>
#include <stdint.h>

#define BSP_RING_SIZE 1024u /* a power of two; one frame of the largest payload fits */
_Static_assert((BSP_RING_SIZE & (BSP_RING_SIZE - 1u)) == 0, "BSP_RING_SIZE must be a power of two");

typedef struct bsp_ring {
    uint8_t buf[BSP_RING_SIZE];
    volatile uint32_t head; /* written by the producer */
    volatile uint32_t tail; /* written by the consumer */
} bsp_ring_t;

#define BSP_BARRIER() __asm__ volatile("" ::: "memory")

static inline uint32_t bsp_ring_fill(const bsp_ring_t *r) { return r->head - r->tail; }

static inline int bsp_ring_put(bsp_ring_t *r, uint8_t b) {
    if (bsp_ring_fill(r) >= BSP_RING_SIZE) return -1;
    r->buf[r->head & (BSP_RING_SIZE - 1u)] = b;
    BSP_BARRIER();
    r->head = r->head + 1u;
    return 0;
}

static inline int bsp_ring_get(bsp_ring_t *r, uint8_t *b) {
    if (r->head == r->tail) return -1;
    *b = r->buf[r->tail & (BSP_RING_SIZE - 1u)];
    BSP_BARRIER();
    r->tail = r->tail + 1u;
    return 0;
}

#endif /* BSP_RING_H */
