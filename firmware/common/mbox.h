/* Latest-value mailbox for large blocks (a parameter vector, a neighbour's state).
 *
 * Contract
 * - One writer thread, one reader thread. The reader always sees a whole block exactly as
 *   one mbox_publish() left it: never torn, never mixed from two publishes.
 * - Neither side ever blocks or waits. The writer may publish faster than the reader reads;
 *   the reader then gets the newest block and the ones in between are skipped (this is a
 *   state, not a queue: use a ring when every record matters).
 * - Implementation: three buffers (a triple buffer). The writer owns one, the reader owns
 *   one, and the third holds the latest publish. Publishing and fetching each swap ownership
 *   with one atomic exchange, so no byte is ever written and read at the same time (the
 *   C11 memory model and ThreadSanitizer agree; a seqlock copy would be a formal data race).
 *   Cost: 3 x block bytes of static storage, declared by MBOX_DEFINE().
 * - Every publish carries a sequence number (1, 2, ...) so the reader knows which version
 *   it holds; 0 means nothing was ever published.
 */
#ifndef COMMON_MBOX_H
#define COMMON_MBOX_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

typedef struct mbox {
    _Atomic uint32_t middle;  /* index of the latest-publish buffer | MBOX_FRESH */
    uint32_t write_idx;       /* writer-owned buffer */
    uint32_t read_idx;        /* reader-owned buffer */
    uint64_t write_seq;       /* writer: sequence of the last publish */
    uint64_t seq[3];          /* sequence stored with each buffer */
    size_t block_size;        /* bytes per buffer */
    uint8_t *storage;         /* 3 * block_size bytes */
} mbox_t;

#define MBOX_FRESH 0x4u /* set in `middle` when it holds a publish the reader has not taken */

/* Declares `name` (an mbox_t) and its three buffers with static duration. */
#define MBOX_DEFINE(name, block_size_)                                                      \
    _Static_assert((block_size_) > 0, "MBOX_DEFINE: block size must be positive");         \
    static _Alignas(64) uint8_t name##_storage[3u * (size_t)(block_size_)];                \
    static mbox_t name = {.middle = 2u, .write_idx = 0u, .read_idx = 1u,                   \
                          .block_size = (block_size_), .storage = name##_storage}

#define MBOX_STORAGE_BYTES(block_size_) (3u * (size_t)(block_size_))

/* Back to "nothing ever published", the state MBOX_DEFINE() gives (the buffers' bytes are
 * left as they are). Only while neither writer nor reader uses the mailbox. */
void mbox_reset(mbox_t *mbox);

/* Writer only. The buffer the writer may fill; valid until the next mbox_publish(). */
void *mbox_write_buffer(mbox_t *mbox);

/* Writer only. Makes the write buffer the latest block. Returns its sequence number. */
uint64_t mbox_publish(mbox_t *mbox);

/* Writer only. Copies block_size bytes from `src` and publishes. Always 0;
 * NULL arguments: HAL_ASSERT. */
FS_MUST_CHECK int mbox_put(mbox_t *mbox, const void *src);

/* Reader only. Takes the latest block if a newer one was published since the last fetch.
 * Returns 1 when a new block was taken, 0 when nothing new (the reader keeps the block it
 * had); NULL: HAL_ASSERT. */
FS_MUST_CHECK int mbox_fetch(mbox_t *mbox);

/* Reader only. The block taken by the last mbox_fetch(); valid until the next fetch.
 * `seq` (may be NULL) receives its sequence number, 0 if nothing was ever taken. */
const void *mbox_read_buffer(const mbox_t *mbox, uint64_t *seq);

/* Reader only. mbox_fetch() then a copy of the latest block into `dst` (block_size bytes).
 * Returns 1 when the copy is newer than the previous mbox_get(), 0 when there is still no
 * publish at all or nothing new (`dst` then holds the same block as before, or is untouched
 * when nothing was ever published); NULL arguments: HAL_ASSERT. */
FS_MUST_CHECK int mbox_get(mbox_t *mbox, void *dst, uint64_t *seq);

#endif /* COMMON_MBOX_H */
