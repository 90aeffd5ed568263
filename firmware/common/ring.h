/* Lock-free single-producer / single-consumer ring of fixed-size records.
 *
 * Contract
 * - Exactly one producer thread calls ring_put(); exactly one consumer thread calls
 *   ring_get()/ring_peek_count(). Any thread may read ring_drops()/ring_count() as a hint.
 * - Records are copied in and out ("queued by copy, not by reference"): the caller's buffer
 *   may be reused as soon as the call returns.
 * - ring_put() never blocks and never waits: when the ring is full the record is dropped,
 *   the drop counter increments and -ENOSPC is returned. This is what the real-time core
 *   needs: a late consumer costs data, never a deadline.
 * - Storage is static, declared by RING_DEFINE() with capacity and record size fixed at
 *   compile time (capacity a power of two). No allocation ever.
 * - Memory order: the producer publishes a record with a release store of `head`; the
 *   consumer acquires `head` before reading the slot and releases `tail` after copying,
 *   so a slot is never overwritten while it is read.
 */
#ifndef COMMON_RING_H
#define COMMON_RING_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#define RING_CACHE_LINE 64

typedef struct ring {
    _Alignas(RING_CACHE_LINE) _Atomic uint32_t head; /* producer: records ever written */
    _Atomic uint32_t drops;                          /* producer: records dropped (full) */
    _Alignas(RING_CACHE_LINE) _Atomic uint32_t tail; /* consumer: records ever read */
    _Alignas(RING_CACHE_LINE) uint32_t capacity;     /* records, power of two */
    uint32_t record_size;                            /* bytes per record */
    uint8_t *storage;                                /* capacity * record_size bytes */
} ring_t;

/* Declares `name` (a ring_t) and its storage with static duration.
 * Use at file scope (or with `static` semantics inside a function). */
#define RING_DEFINE(name, record_size_, capacity_)                                          \
    _Static_assert((capacity_) > 0 && (((capacity_) & ((capacity_)-1u)) == 0),             \
                   "RING_DEFINE: capacity must be a power of two");                        \
    _Static_assert((capacity_) <= (1u << 30), "RING_DEFINE: capacity too large");          \
    _Static_assert((record_size_) > 0, "RING_DEFINE: record size must be positive");       \
    static _Alignas(RING_CACHE_LINE) uint8_t name##_storage[(size_t)(capacity_) *          \
                                                           (size_t)(record_size_)];        \
    static ring_t name = {.capacity = (capacity_),                                         \
                          .record_size = (record_size_),                                   \
                          .storage = name##_storage}

/* Bytes of storage RING_DEFINE() reserves, for budget checks with _Static_assert. */
#define RING_STORAGE_BYTES(record_size_, capacity_) ((size_t)(capacity_) * (size_t)(record_size_))

/* Producer only. Copies ring->record_size bytes from `record`.
 * Returns 0, or -ENOSPC when full (the record is dropped and counted). NULL arguments break
 * the contract: HAL_ASSERT (the board's fault handler). */
FS_MUST_CHECK int ring_put(ring_t *ring, const void *record);

/* Consumer only. Copies the oldest record into `record`.
 * Returns 0, or -EAGAIN when empty; NULL arguments: HAL_ASSERT. */
FS_MUST_CHECK int ring_get(ring_t *ring, void *record);

/* Empties the ring and zeroes the drop count: the state RING_DEFINE() gives. Only while
 * neither producer nor consumer uses the ring (before the cores start). */
void ring_reset(ring_t *ring);

/* Records waiting. Exact for the consumer; a snapshot for anyone else. */
uint32_t ring_count(const ring_t *ring);

/* Records dropped because the ring was full, since start. */
uint32_t ring_drops(const ring_t *ring);

#endif /* COMMON_RING_H */
