/* The shared-memory segment of the host network's shm:// transport (hal_host_net_shm.c): its
 * layout and the two operations on a ring that need care, the write and the checked read.
 *
 * One POSIX shared-memory object per fleet (mode 0600, /dev/shm on Linux): a header, then
 * SHM_SLOTS slots, then each slot's two rings. Every robot of the host maps the header and the
 * slots; the rings it reads and writes through the descriptor (pread, pwritev), so the
 * rings' pages count in no process's RSS and a full /dev/shm is an error from a write, not a
 * SIGBUS. The rings are the transport's receive buffer: generous, as a socket's 32 MB
 * SO_RCVBUF is, and tmpfs gives pages only to what was written. A process
 * claims one slot (its pid in `owner`) and is the one writer of that slot's rings and the one
 * reader of its mailbox (`armed`, its subscriptions, `first`). A datagram is written once, into
 * the writer's own ring (the small ring up to SHM_SMALL_MAX bytes, else the bulk ring: a burst
 * of state chunks never pushes a beacon out), and read by every robot that wants it straight
 * from there: no copy per receiver on the way, no kernel in the data path.
 *
 * A ring is a byte ring written in stream positions that only grow (uint64: never wrap). An
 * entry (header and datagram, 8-byte aligned) never straddles the ring's end: where it does not
 * fit, a skip marker pads to the end and the entry starts at offset 0, so every multiple of
 * the ring's size is an entry's start, which is where a reader that fell a lap behind picks up.
 * The writer never waits for its readers: a reader a whole ring behind loses what was
 * overwritten (counted as a queue drop, as a socket's full buffer would be). It learns that
 * from `reserve`, the end of what the writer may be overwriting, published before the bytes
 * (a seqlock's sequence: a read is good if, after it, reserve is within one ring of where it
 * read). Not part of any API. */
#ifndef HAL_HOST_NET_SHM_SEG_H
#define HAL_HOST_NET_SHM_SEG_H

#include "hal_host.h"
#include "hal_host_auth.h"
#include "hal_host_net_transport.h"

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

/* The fences of the seqlock and of the doorbell's arming. ThreadSanitizer does not model
   fences (GCC refuses them under -fsanitize=thread); the bytes they order go through system
   calls it does not see, so under it a compiler barrier is all there is to check. */
#if defined(__SANITIZE_THREAD__)
#define SHM_FENCE(order) atomic_signal_fence(order)
#else
#define SHM_FENCE(order) atomic_thread_fence(order)
#endif

#define SHM_SLOTS BOARD_MAX_FLEET
/* The rings: a robot's small messages (beacons, requests, RoundCompletes) and its bulk (state
   chunks, chunks sent again, posteriors: a round sends 134 KB to 1.3 MB, round 0 and posterior
   rounds the most, so about ten rounds). A reader further behind than that has lost the
   oldest. With 64 robots on 2 cores, 512 KB lapped a robot still starting in round 0. */
#define SHM_SMALL_MAX 2048u
#define SHM_RING_SMALL ((uint64_t)256u << 10)
#define SHM_RING_BULK ((uint64_t)8u << 20)
#define SHM_DATAGRAM_MAX (HAL_NET_MTU_BYTES + HAL_HOST_AUTH_TRAILER_BYTES)
#define SHM_SKIP UINT32_MAX

/* An entry's header in a ring, the datagram's bytes right after it. */
typedef struct shm_entry {
    uint32_t len;        /* datagram bytes, or SHM_SKIP: padding to the ring's end */
    uint32_t chan_hash;  /* shm_chan_hash(channel) */
    int64_t sender;      /* the robot the datagram names, -1: none */
    uint64_t stamp;      /* the segment's clock when written: readers take the oldest first */
    char channel[HAL_NET_CHANNEL_MAX];
} shm_entry_t;
#define SHM_ENTRY_BYTES(len) (sizeof(shm_entry_t) + (((uint64_t)(len) + 7u) & ~(uint64_t)7u))
/* A ring holds two of its largest entries: a reader that sees an entry's start always has a
   whole ring's time to read it. */
_Static_assert(2u * SHM_ENTRY_BYTES(SHM_SMALL_MAX) <= SHM_RING_SMALL, "small ring too small");
_Static_assert(2u * SHM_ENTRY_BYTES(SHM_DATAGRAM_MAX) <= SHM_RING_BULK, "bulk ring too small");
_Static_assert(sizeof(shm_entry_t) % 8u == 0, "entries stay 8-byte aligned");

typedef struct shm_ring_ctl {
    _Atomic uint64_t reserve; /* the writer may be writing up to here */
    _Atomic uint64_t head;    /* written and complete up to here */
    uint8_t pad[48];          /* a cache line of its own */
} shm_ring_ctl_t;

/* A subscription as writers see it: the channel's hash and, when narrowed, the wanted senders
   (bit i of sender i in word i / 32). Atomics, read relaxed: the seqlock tells a torn read. */
#define SHM_SENDER_WORDS ((BOARD_MAX_FLEET + 31u) / 32u)
typedef struct shm_sub {
    _Atomic uint32_t hash;
    _Atomic uint32_t filtered;
    _Atomic uint32_t wanted[SHM_SENDER_WORDS];
} shm_sub_t;

typedef struct shm_slot {
    _Atomic uint32_t owner;   /* the process's pid; 0: free */
    _Atomic uint32_t armed;   /* 1: the reader may sleep on its doorbell; the first writer of a
                                 datagram it wants clears it and rings */
    uint8_t pad0[56];
    shm_ring_ctl_t ring[2];   /* small, bulk */
    /* The reader's subscriptions, a seqlock (odd: being changed; a writer that sees it change
       under it counts the datagram as wanted). */
    _Atomic uint32_t sub_seq;
    _Atomic uint32_t n_subs;
    shm_sub_t sub[HAL_HOST_NET_MAX_SUBS];
    /* Per writer and ring: 1 + the stream position of the first entry this reader wants since
       it last looked, 0: none. Set by that writer only when 0, taken (exchanged) by the reader. */
    _Atomic uint64_t first[2][SHM_SLOTS];
} shm_slot_t;

typedef struct shm_header {
    _Atomic uint64_t magic;   /* SHM_MAGIC mixed with the layout: one build's fleet per segment */
    _Atomic uint32_t hi;      /* 1 + the highest slot ever claimed */
    uint32_t pad0;
    _Atomic uint64_t clock;   /* datagrams written so far, fleet-wide: their order */
    uint8_t pad[40];
} shm_header_t;

#define SHM_RINGS_BYTES (SHM_RING_SMALL + SHM_RING_BULK)
/* The mapped part (header and slots), rounded to 64 KB pages; the rings follow. */
#define SHM_MAPPED_BYTES \
    (((uint64_t)sizeof(shm_header_t) + (uint64_t)SHM_SLOTS * sizeof(shm_slot_t) + 0xffffu) & ~(uint64_t)0xffffu)
#define SHM_SEGMENT_BYTES (SHM_MAPPED_BYTES + (uint64_t)SHM_SLOTS * SHM_RINGS_BYTES)

/* Where slot i's ring cls starts in the segment. */
static inline uint64_t shm_ring_offset(uint32_t i, int cls)
{
    return SHM_MAPPED_BYTES + (uint64_t)i * SHM_RINGS_BYTES + (cls ? SHM_RING_SMALL : 0u);
}

static inline uint64_t shm_ring_cap(int cls) { return cls ? SHM_RING_BULK : SHM_RING_SMALL; }

/* FNV-1a of a channel name (0 never: it marks no subscription). */
uint32_t shm_chan_hash(const char *channel);

/* Whether a subscription table (a slot's, possibly being changed by its owner) wants a
   datagram: a subscription of that hash, and the sender wanted where it is narrowed (a
   datagram naming no sender always is, as hal_host_net.c's own filter has it). A table
   changing meanwhile: wanted. */
int shm_slot_wants(shm_slot_t *slot, uint32_t hash, int64_t sender);

/* The slot's owner: subscription i is `hash`, narrowed to the senders set in wanted
   (HAL_HOST_NET_SENDER_BYTES bytes, hal_host_net_transport.h's bit order) or not (NULL); n_subs
   becomes at least i + 1. Under the seqlock: writers never act on half of it. */
void shm_slot_set_sub(shm_slot_t *slot, uint32_t i, uint32_t hash, const uint8_t *wanted);

/* The slot's owner: no subscription (open and close). */
void shm_slot_clear_subs(shm_slot_t *slot);

/* The writer: e (its len, hash, sender, channel) and e->len bytes of data into ring cls of
   its slot, at offset `ring` of the segment's descriptor fd. The entry's stream position into
   *at: 0, or -EIO (the write failed: /dev/shm full; nothing published). */
int shm_ring_write(shm_ring_ctl_t *ctl, int fd, uint64_t ring, int cls, const shm_entry_t *e, const void *data,
                   uint64_t *at);

typedef enum {
    SHM_READ_OK = 0,     /* *e (and the datagram, when asked) read whole */
    SHM_READ_SKIP,       /* padding: the next entry is at the next multiple of the ring's size */
    SHM_READ_LAPPED,     /* the writer overwrote it: resume at shm_ring_resume() */
    SHM_READ_INVALID,    /* not an entry: a header out of bounds */
    SHM_READ_FAILED      /* the descriptor refused the read */
} shm_read_t;

/* Reads the entry at stream position pos (< head) of ring cls: its header into *e and, when
   data != NULL, its datagram into data (SHM_DATAGRAM_MAX bytes); checked against the writer's
   reserve after the copy. */
shm_read_t shm_ring_read(shm_ring_ctl_t *ctl, int fd, uint64_t ring, int cls, uint64_t pos, shm_entry_t *e, void *data);

/* Where a reader lapped at head resumes: the start of the writer's current lap. */
static inline uint64_t shm_ring_resume(uint64_t head, int cls) { return head - head % shm_ring_cap(cls); }

#endif /* HAL_HOST_NET_SHM_SEG_H */
