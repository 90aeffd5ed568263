/* The shm:// transport's rings (hal_host_net_shm_seg.h): writing an entry, reading one back
 * checked against the writer, and the subscription test writers make for each reader.
 *
 * Memory order, as a seqlock's (Boehm, "Can seqlocks get along with programming language
 * memory models?", 2012), the bytes going through the segment's descriptor (a system call
 * orders as a full fence does). The writer stores reserve, fences (release), writes the bytes, then
 * stores head (seq_cst: the wake-up's Dekker pairing in hal_host_net_shm.c needs it). A reader
 * loads head, copies the bytes, fences (acquire) and loads reserve: had any byte it copied
 * been overwritten, that reserve, or a later one, is what it sees. A copy may catch a write
 * half done: the check after it discards that copy. */
#define _DEFAULT_SOURCE /* pwritev */
#include "hal_host_net_shm_seg.h"

#include <errno.h>
#include <string.h>
#include <sys/uio.h>
#include <unistd.h>

uint32_t shm_chan_hash(const char *channel)
{
    uint32_t h = 2166136261u;
    for (const unsigned char *p = (const unsigned char *)channel; *p != '\0'; p++)
        h = (h ^ *p) * 16777619u;
    return h != 0 ? h : 1u;
}

int shm_slot_wants(shm_slot_t *slot, uint32_t hash, int64_t sender)
{
    const uint32_t seq = atomic_load_explicit(&slot->sub_seq, memory_order_acquire);
    if (seq & 1u)
        return 1;
    const uint32_t n = atomic_load_explicit(&slot->n_subs, memory_order_relaxed);
    int want = 0;
    for (uint32_t i = 0; i < n && i < HAL_HOST_NET_MAX_SUBS && !want; i++) {
        shm_sub_t *s = &slot->sub[i];
        if (atomic_load_explicit(&s->hash, memory_order_relaxed) != hash)
            continue;
        want = !atomic_load_explicit(&s->filtered, memory_order_relaxed) || sender < 0 ||
               (sender < (int64_t)BOARD_MAX_FLEET &&
                ((atomic_load_explicit(&s->wanted[sender >> 5], memory_order_relaxed) >> (sender & 31)) & 1u));
    }
    SHM_FENCE(memory_order_acquire);
    return want || atomic_load_explicit(&slot->sub_seq, memory_order_relaxed) != seq;
}

void shm_slot_set_sub(shm_slot_t *slot, uint32_t i, uint32_t hash, const uint8_t *wanted)
{
    atomic_fetch_add(&slot->sub_seq, 1u); /* odd: being changed */
    shm_sub_t *s = &slot->sub[i];
    atomic_store_explicit(&s->hash, hash, memory_order_relaxed);
    atomic_store_explicit(&s->filtered, wanted != NULL, memory_order_relaxed);
    for (uint32_t w = 0; w < SHM_SENDER_WORDS; w++) {
        uint32_t v = 0;
        for (uint32_t b = 0; wanted != NULL && b < 4u && 4u * w + b < HAL_HOST_NET_SENDER_BYTES; b++)
            v |= (uint32_t)wanted[4u * w + b] << (8u * b);
        atomic_store_explicit(&s->wanted[w], v, memory_order_relaxed);
    }
    if (atomic_load_explicit(&slot->n_subs, memory_order_relaxed) < i + 1u)
        atomic_store_explicit(&slot->n_subs, i + 1u, memory_order_relaxed);
    atomic_fetch_add(&slot->sub_seq, 1u); /* even again (release: the stores above first) */
}

void shm_slot_clear_subs(shm_slot_t *slot)
{
    atomic_fetch_add(&slot->sub_seq, 1u);
    atomic_store(&slot->n_subs, 0u);
    atomic_fetch_add(&slot->sub_seq, 1u);
}

int shm_ring_write(shm_ring_ctl_t *ctl, int fd, uint64_t ring, int cls, const shm_entry_t *e, const void *data,
                   uint64_t *at)
{
    const uint64_t cap = shm_ring_cap(cls), size = SHM_ENTRY_BYTES(e->len);
    const uint64_t p = atomic_load_explicit(&ctl->head, memory_order_relaxed);
    const uint64_t off = p % cap, pad = off + size > cap ? cap - off : 0u;
    *at = p + pad;
    const uint64_t end = *at + size;
    atomic_store_explicit(&ctl->reserve, end, memory_order_relaxed);
    SHM_FENCE(memory_order_release);
    const uint32_t skip = SHM_SKIP;
    if (pad != 0 && pwrite(fd, &skip, sizeof skip, (off_t)(ring + off)) != (ssize_t)sizeof skip)
        return -EIO;
    struct iovec v[2] = {{(void *)e, sizeof *e}, {(void *)data, e->len}};
    const ssize_t want = (ssize_t)(sizeof *e + e->len);
    if (pwritev(fd, v, e->len > 0 ? 2 : 1, (off_t)(ring + *at % cap)) != want)
        return -EIO; /* head stays: readers never see it; the next write overwrites it */
    atomic_store_explicit(&ctl->head, end, memory_order_seq_cst);
    return 0;
}

/* Whether what was copied from position pos on is still what the writer wrote there. */
static int still_there(shm_ring_ctl_t *ctl, uint64_t pos, uint64_t cap)
{
    SHM_FENCE(memory_order_acquire);
    return atomic_load_explicit(&ctl->reserve, memory_order_relaxed) <= pos + cap;
}

static int read_at(int fd, void *buf, size_t len, uint64_t at)
{
    return pread(fd, buf, len, (off_t)at) == (ssize_t)len;
}

shm_read_t shm_ring_read(shm_ring_ctl_t *ctl, int fd, uint64_t ring, int cls, uint64_t pos, shm_entry_t *e, void *data)
{
    const uint64_t cap = shm_ring_cap(cls), off = pos % cap;
    if (off % 8u != 0)
        return SHM_READ_INVALID;
    const size_t first = cap - off < sizeof *e ? sizeof(uint32_t) : sizeof *e; /* padding may be 8 bytes */
    memset(e, 0, sizeof *e);
    if (!read_at(fd, e, first, ring + off))
        return SHM_READ_FAILED;
    if (e->len == SHM_SKIP || first < sizeof *e) {
        if (!still_there(ctl, pos, cap))
            return SHM_READ_LAPPED;
        return e->len == SHM_SKIP ? SHM_READ_SKIP : SHM_READ_INVALID;
    }
    const int bounded = e->len <= SHM_DATAGRAM_MAX && off + SHM_ENTRY_BYTES(e->len) <= cap &&
                        memchr(e->channel, '\0', sizeof e->channel) != NULL;
    if (bounded && data != NULL && e->len > 0 && !read_at(fd, data, e->len, ring + off + sizeof *e))
        return SHM_READ_FAILED;
    if (!still_there(ctl, pos, cap))
        return SHM_READ_LAPPED;
    return bounded ? SHM_READ_OK : SHM_READ_INVALID;
}
