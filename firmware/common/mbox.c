#include "common/mbox.h"

#include <errno.h>
#include <string.h>

#include "hal/hal_board.h"

#define MBOX_INDEX_MASK 0x3u

void *mbox_write_buffer(mbox_t *mbox)
{
    return mbox->storage + (size_t)mbox->write_idx * mbox->block_size;
}

uint64_t mbox_publish(mbox_t *mbox)
{
    uint64_t seq = ++mbox->write_seq;
    mbox->seq[mbox->write_idx] = seq;
    /* acq_rel: release our block to the reader, acquire the buffer the reader gave back. */
    uint32_t old = atomic_exchange_explicit(&mbox->middle, mbox->write_idx | MBOX_FRESH,
                                            memory_order_acq_rel);
    mbox->write_idx = old & MBOX_INDEX_MASK;
    return seq;
}

int mbox_put(mbox_t *mbox, const void *src)
{
    HAL_ASSERT(mbox != NULL && src != NULL);
    memcpy(mbox_write_buffer(mbox), src, mbox->block_size);
    (void)mbox_publish(mbox);
    return 0;
}

int mbox_fetch(mbox_t *mbox)
{
    HAL_ASSERT(mbox != NULL);
    if ((atomic_load_explicit(&mbox->middle, memory_order_relaxed) & MBOX_FRESH) == 0)
        return 0;
    uint32_t old = atomic_exchange_explicit(&mbox->middle, mbox->read_idx, memory_order_acq_rel);
    mbox->read_idx = old & MBOX_INDEX_MASK;
    return 1;
}

const void *mbox_read_buffer(const mbox_t *mbox, uint64_t *seq)
{
    if (seq != NULL)
        *seq = mbox->seq[mbox->read_idx];
    return mbox->storage + (size_t)mbox->read_idx * mbox->block_size;
}

int mbox_get(mbox_t *mbox, void *dst, uint64_t *seq)
{
    HAL_ASSERT(mbox != NULL && dst != NULL);
    int fresh = mbox_fetch(mbox);
    uint64_t s;
    const void *src = mbox_read_buffer(mbox, &s);
    if (seq != NULL)
        *seq = s;
    if (fresh == 1)
        memcpy(dst, src, mbox->block_size);
    return fresh;
}

void mbox_reset(mbox_t *mbox)
{
    atomic_store(&mbox->middle, 2u);
    mbox->write_idx = 0u;
    mbox->read_idx = 1u;
    mbox->write_seq = 0u;
    mbox->seq[0] = mbox->seq[1] = mbox->seq[2] = 0u;
}
