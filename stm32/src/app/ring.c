#include "ring.h"

void ring_init(ring_t *ring)
{
    ring->head = 0;
    ring->tail = 0;
    ring->dropped = 0;
}

bool ring_put(ring_t *ring, uint8_t byte)
{
    uint32_t head = ring->head;
    uint32_t next = (head + 1u) & RING_MASK;
    if (next == ring->tail) {
        ring->dropped = ring->dropped + 1u;
        return false;
    }
    ring->data[head] = byte;
    ring->head = next;
    return true;
}

bool ring_get(ring_t *ring, uint8_t *byte)
{
    uint32_t tail = ring->tail;
    if (tail == ring->head) {
        return false;
    }
    *byte = ring->data[tail];
    ring->tail = (tail + 1u) & RING_MASK;
    return true;
}

uint32_t ring_count(const ring_t *ring)
{
    return (ring->head - ring->tail) & RING_MASK;
}
