/**
 * @file ring.h
 * Single-producer single-consumer byte ring buffer (producer: the USART RX interrupt,
 * consumer: the main loop). Capacity RING_SIZE - 1 bytes; RING_SIZE is a power of two.
 */
#ifndef MSR_RING_H
#define MSR_RING_H

#include <stdbool.h>
#include <stdint.h>

#define RING_SIZE 1024u
#define RING_MASK (RING_SIZE - 1u)

typedef struct {
    volatile uint32_t head;     /**< next write position (producer only) */
    volatile uint32_t tail;     /**< next read position (consumer only) */
    volatile uint32_t dropped;  /**< bytes lost because the buffer was full */
    uint8_t data[RING_SIZE];
} ring_t;

void ring_init(ring_t *ring);
/** Producer side; false (and counted in dropped) when full. */
bool ring_put(ring_t *ring, uint8_t byte);
/** Consumer side; false when empty. */
bool ring_get(ring_t *ring, uint8_t *byte);
uint32_t ring_count(const ring_t *ring);

#endif
