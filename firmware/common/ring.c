#include "common/ring.h"

#include <errno.h>
#include <string.h>

#include "hal/hal_board.h"

int ring_put(ring_t *ring, const void *record)
{
    HAL_ASSERT(ring != NULL && record != NULL);
    /* Only this thread writes head, so a relaxed load of our own value is exact. */
    uint32_t head = atomic_load_explicit(&ring->head, memory_order_relaxed);
    uint32_t tail = atomic_load_explicit(&ring->tail, memory_order_acquire);
    if (head - tail >= ring->capacity) {
        atomic_fetch_add_explicit(&ring->drops, 1u, memory_order_relaxed);
        return -ENOSPC;
    }
    size_t slot = (size_t)(head & (ring->capacity - 1u)) * ring->record_size;
    memcpy(ring->storage + slot, record, ring->record_size);
    atomic_store_explicit(&ring->head, head + 1u, memory_order_release);
    return 0;
}

int ring_get(ring_t *ring, void *record)
{
    HAL_ASSERT(ring != NULL && record != NULL);
    uint32_t tail = atomic_load_explicit(&ring->tail, memory_order_relaxed);
    uint32_t head = atomic_load_explicit(&ring->head, memory_order_acquire);
    if (head == tail)
        return -EAGAIN;
    size_t slot = (size_t)(tail & (ring->capacity - 1u)) * ring->record_size;
    memcpy(record, ring->storage + slot, ring->record_size);
    atomic_store_explicit(&ring->tail, tail + 1u, memory_order_release);
    return 0;
}

void ring_reset(ring_t *ring)
{
    atomic_store(&ring->head, 0u);
    atomic_store(&ring->tail, 0u);
    atomic_store(&ring->drops, 0u);
}

uint32_t ring_count(const ring_t *ring)
{
    /* Casts drop const only for the atomic load API of older libcs; nothing is written. */
    uint32_t head = atomic_load_explicit((_Atomic uint32_t *)&ring->head, memory_order_acquire);
    uint32_t tail = atomic_load_explicit((_Atomic uint32_t *)&ring->tail, memory_order_acquire);
    return head - tail;
}

uint32_t ring_drops(const ring_t *ring)
{
    return atomic_load_explicit((_Atomic uint32_t *)&ring->drops, memory_order_relaxed);
}
