/* hal_net on the host, over LCM or ZeroMQ (the transports: hal_host_net_transport.h; the URL
 * chooses). Subscriptions deliver into one bounded queue that the GP core polls: a byte ring
 * allocated once at open, so receiving never allocates in our code (the transports' own
 * buffers are their business).
 *
 * The queue is a byte ring, not a table of MTU-sized slots: most datagrams are small
 * (requests, beacons, completions: tens to hundreds of bytes) while a state chunk may take a
 * whole MTU (~60 KB), and a ring of slots is touched slot by slot until every slot is resident
 * (depth x MTU of RSS). An entry is a 16-byte header (length, subscription index, queue stamp:
 * the hal_net_rx_info_t fields; the channel name is the subscription's, kept once in the
 * table) and the datagram's bytes, rounded up to 8 bytes. An entry never straddles the end:
 * when it does not fit in the tail, the tail becomes padding (a skip marker where the next
 * header would be) and the entry starts at offset 0. The queue is full when the bytes do not
 * fit OR it holds `depth` messages (the message cap, hal_net_stats_t.queue_depth); a datagram
 * that does not fit is dropped and counted (rx_dropped_full). When the queue empties both ends
 * go back to offset 0, so a queue drained as fast as it fills keeps using the ring's first
 * bytes and the pages past its high-water mark (queue_bytes_max) are never touched.
 *
 * A receiver thread (started with the first subscription) runs the transport's handler all along and
 * moves every datagram into the queue at once, as a board's network interface receives while
 * its cores compute. Without it LCM's own buffer (about 1 MB in LCM 1.3) fills whenever the
 * process is busy, and a fleet of 14 robots lost chunks every round. The queue is the one
 * place both threads touch, under one mutex; what does not fit is dropped and counted.
 *
 * Fault injection (hal_host_net_set_faults, hal_host_netfault.h) acts where a datagram enters
 * the queue, after the checks: receive side, so one robot's loss does not hide the datagram
 * from the others (a lossy radio, not a broken sender). Delayed and reordered datagrams wait
 * in a holding area allocated with the faults; the receiver thread, wait and receive move
 * what is due into the queue as time passes.
 *
 * Neighbour-scoped delivery (hal_host_net_set_senders): each subscription of a typed channel
 * may carry a fixed bitmap of wanted senders (BOARD_MAX_FLEET bits, in this struct, nothing
 * allocated). hal_host_net_on_datagram checks it right after the subscription match and the
 * own-echo check, before the tag check, the bounds check and any copy: an unwanted sender's
 * datagram costs the channel lookup and a read of its sender field (rx_unwanted). A datagram
 * too short to name a sender passes, and the checks after refuse it. The transport is told
 * too (its optional `senders`): ZeroMQ then filters at the publisher, so most unwanted bytes
 * never arrive at all; LCM with a kernel filter on its socket (hal_host_net_kfilter.h) or
 * per-sender groups (hal_host_net_group_by_sender); where neither could be had, this check is
 * the filter. */
#include "hal_host.h"
#include "hal_host_auth.h"
#include "hal_host_msg.h"
#include "hal_host_net_transport.h"
#include "hal_host_netfault.h"

#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <time.h>
#include <stdlib.h>
#include <string.h>

/* The message cap: no storage is sized by it (a message costs its entry in the ring), so it
 * may be high. */
#define NET_QUEUE_MAX HAL_HOST_NET_QUEUE_MAX
/* Most datagrams held back at once (MTU-sized slots): a deeper holding area would only move
 * the overflow into the queue; when it is full the one due first is released early. */
#define NET_HOLD_MAX 512u

/* An entry's header in the ring (HAL_HOST_NET_ENTRY_HEADER bytes, 8-byte aligned), its
 * datagram's bytes right after it. len == NET_SKIP marks padding from here to the end of the
 * ring: the next entry is at offset 0 (only its first 4 bytes are written: the padding may be
 * just 8 bytes). */
typedef struct net_entry {
    uint32_t len;      /* datagram bytes, or NET_SKIP */
    uint32_t sub;      /* index in sub_channel: the channel it came on */
    uint64_t stamp_us; /* queue time (hal_net_rx_info_t.stamp_us) */
} net_entry_t;
#define NET_SKIP UINT32_MAX
_Static_assert(sizeof(net_entry_t) == HAL_HOST_NET_ENTRY_HEADER, "ring entry header");

struct hal_host_net {
    const hal_host_net_transport_t *tp; /* LCM or ZeroMQ (hal_host_net_transport.h) */
    void *tp_ctx;
    /* The queue (under mu): a byte ring of ring_cap bytes (a multiple of 8). Entries from
       offset head (the oldest) to tail (where the next goes), possibly wrapped; head == tail
       with fill > 0 is a full ring. used: bytes taken, padding included. Empty: head = tail = 0. */
    uint32_t depth;    /* message cap */
    uint32_t fill;     /* messages queued */
    size_t ring_cap, head, tail, used;
    uint8_t *ring;
    uint32_t n_subs;
    char sub_channel[HAL_HOST_NET_MAX_SUBS][HAL_NET_CHANNEL_MAX]; /* under mu */
    /* hal_host_net_set_senders, per subscription (under mu): filtered, and then the wanted
       senders' bits (ids >= BOARD_MAX_FLEET never wanted). */
    uint8_t sub_filtered[HAL_HOST_NET_MAX_SUBS];
    uint8_t sub_wanted[HAL_HOST_NET_MAX_SUBS][HAL_HOST_NET_SENDER_BYTES];
    uint32_t n_typed;
    char typed_channel[HAL_HOST_NET_MAX_SUBS][HAL_NET_CHANNEL_MAX];
    hal_host_msg_type_t typed[HAL_HOST_NET_MAX_SUBS];
    uint64_t pump_stamp_us;
    hal_net_stats_t stats;
    uint64_t drop_every;   /* test seam FLEETSIM_NET_DROP_EVERY: lose every N-th publish */
    uint64_t publishes;
    uint64_t t0_us;        /* CLOCK_MONOTONIC at open: the partition's time origin */
    int faults_on;         /* the rest only when set (under mu) */
    hal_host_netfault_cfg_t fault;
    uint64_t fault_seed;
    uint32_t fault_self;
    uint64_t fault_seq;    /* datagrams decided on so far */
    hal_host_netfault_hold_t hold; /* cap 0 without delay or reorder */
    int has_self;          /* hal_host_net_set_self: own datagrams dropped on arrival */
    uint32_t self;
    int keyed;             /* hal_host_net_set_auth: every datagram sealed and checked */
    hal_host_auth_t auth;
    uint8_t *tx_wire;      /* keyed: message + trailer, HAL_NET_MTU_BYTES + trailer (under tx_mu) */
    pthread_mutex_t tx_mu;
    pthread_mutex_t mu;    /* the queue, its stats, the typed table, pump_stamp_us */
    pthread_cond_t cv;     /* signalled when a message is queued (CLOCK_MONOTONIC) */
    int wake_waiter;       /* a message was queued: broadcast cv once mu is released */
    pthread_t rx_thread;
    int rx_started;
    atomic_int rx_stop;
    atomic_int rx_failed;  /* the transport's handle failed: it is gone */
};

static uint64_t mono_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

/* mu held: the offset where an entry of `esize` bytes goes, setting *pad to the padding it
 * leaves at the end of the ring (wrapping); SIZE_MAX when it does not fit. */
static size_t ring_place(const hal_host_net_t *n, size_t esize, size_t *pad)
{
    *pad = 0;
    if (n->fill == 0) /* empty: head = tail = 0 */
        return esize <= n->ring_cap ? 0u : SIZE_MAX;
    if (n->tail > n->head) { /* [head, tail) taken: room at the end, then before head */
        if (esize <= n->ring_cap - n->tail)
            return n->tail;
        if (esize <= n->head) {
            *pad = n->ring_cap - n->tail;
            return 0;
        }
        return SIZE_MAX;
    }
    /* wrapped: [head, end) and [0, tail) taken (tail == head: full) */
    return esize <= n->head - n->tail ? n->tail : SIZE_MAX;
}

/* mu held: the ring's entry at head, past a skip marker (fill > 0). */
static net_entry_t *ring_front(hal_host_net_t *n)
{
    uint32_t len;
    memcpy(&len, n->ring + n->head, sizeof len);
    if (len == NET_SKIP) {
        n->used -= n->ring_cap - n->head;
        n->head = 0;
    }
    return (net_entry_t *)(void *)(n->ring + n->head);
}

/* mu held: the entry at head leaves the ring. */
static void ring_pop(hal_host_net_t *n, const net_entry_t *e)
{
    const size_t esize = HAL_HOST_NET_ENTRY_BYTES(e->len);
    n->head += esize;
    n->used -= esize;
    if (n->head == n->ring_cap)
        n->head = 0;
    if (--n->fill == 0)
        n->head = n->tail = n->used = 0; /* back to the start: the low pages stay the hot ones */
}

/* mu held: the index of a subscribed channel (every queued datagram is of one), or n_subs. */
static uint32_t sub_index(const hal_host_net_t *n, const char *channel)
{
    uint32_t i = 0;
    while (i < n->n_subs && strcmp(n->sub_channel[i], channel) != 0)
        i++;
    return i;
}

/* mu held: one datagram into the queue, or counted as a queue-full drop (the message cap
 * reached, or its bytes do not fit the ring). */
static void enqueue(hal_host_net_t *n, const char *channel, const void *data, uint32_t len)
{
    const uint32_t sub = sub_index(n, channel);
    if (sub == n->n_subs || len > HAL_NET_MTU_BYTES) { /* not expected: checked before */
        n->stats.rx_dropped_invalid++;
        return;
    }
    const size_t esize = HAL_HOST_NET_ENTRY_BYTES(len);
    size_t pad, at;
    if (n->fill == n->depth || (at = ring_place(n, esize, &pad)) == SIZE_MAX) {
        n->stats.rx_dropped_full++;
        return;
    }
    if (pad > 0) {
        const uint32_t skip = NET_SKIP;
        memcpy(n->ring + n->tail, &skip, sizeof skip);
    }
    net_entry_t *e = (net_entry_t *)(void *)(n->ring + at);
    e->len = len;
    e->sub = sub;
    e->stamp_us = n->pump_stamp_us;
    if (len > 0)
        memcpy(e + 1, data, len);
    n->tail = at + esize;
    if (n->tail == n->ring_cap)
        n->tail = 0;
    n->used += pad + esize;
    n->fill++;
    if (n->fill > n->stats.queue_fill_max)
        n->stats.queue_fill_max = n->fill;
    n->stats.queue_bytes = n->used;
    if (n->used > n->stats.queue_bytes_max)
        n->stats.queue_bytes_max = n->used;
    n->wake_waiter = 1;
}

/* Unlocks mu, then wakes the waiter when something was queued meanwhile. After the unlock, not
 * before: a waiter woken under the lock only blocks again on the mutex (two more futex calls per
 * datagram, and on a busy CPU the woken core waited for the receiver's next time slice). */
static void unlock_and_wake(hal_host_net_t *n)
{
    const int wake = n->wake_waiter;
    n->wake_waiter = 0;
    pthread_mutex_unlock(&n->mu);
    if (wake)
        pthread_cond_broadcast(&n->cv);
}

/* mu held: a datagram the injector let through reaches the queue; what waits for later ones
 * to pass it (reorder) counts it. */
static void deliver(hal_host_net_t *n, const char *channel, const void *data, uint32_t len)
{
    enqueue(n, channel, data, len);
    hal_host_netfault_hold_passed(&n->hold);
}

/* mu held: a held datagram leaves the holding area for the queue. */
static void release_held(hal_host_net_t *n, hal_host_netfault_held_t *e)
{
    enqueue(n, e->info.channel, e->data, e->info.len);
    hal_host_netfault_hold_release(&n->hold, e); /* before _passed: it does not pass itself */
    hal_host_netfault_hold_passed(&n->hold);
}

/* mu held: everything due by now into the queue, the one due first first. */
static void release_due(hal_host_net_t *n, uint64_t now_us)
{
    for (hal_host_netfault_held_t *e; (e = hal_host_netfault_hold_next(&n->hold, now_us)) != NULL;)
        release_held(n, e);
}

/* The sender of a datagram on a typed (fleet) channel: its first field, a big-endian 32-bit
 * id after the 8-byte fingerprint (a keyed fleet's trailer rides at the end); -1 for untyped
 * channels and datagrams too short to have one. Not checked: a hint until the tag is. */
static int64_t typed_sender(hal_host_msg_type_t type, const void *data, size_t len)
{
    const uint8_t *d = data;
    if (type == HAL_HOST_MSG_ANY || len < 12u)
        return -1;
    return (int64_t)((uint32_t)d[8] << 24 | (uint32_t)d[9] << 16 | (uint32_t)d[10] << 8 | (uint32_t)d[11]);
}

/* mu held: a checked datagram meets the injector, which decides by its sender (typed_sender;
 * signed like the injector's ids). */
static void inject(hal_host_net_t *n, hal_host_msg_type_t type, const char *channel, const uint8_t *data,
                   uint32_t len)
{
    const uint64_t now = mono_us();
    release_due(n, now);
    const int32_t sender = (int32_t)typed_sender(type, data, len);
    hal_host_netfault_decision_t d;
    hal_host_netfault_decide(&n->fault, n->fault_seed, n->fault_seq++, sender, n->fault_self, now - n->t0_us, &d);
    if (d.partitioned) {
        n->stats.fault_partitioned++;
        return;
    }
    if (d.dropped) {
        n->stats.fault_dropped++;
        return;
    }
    n->stats.fault_duplicated += d.copies > 1u;
    n->stats.fault_reordered += d.reordered != 0;
    const uint64_t hold_us = (uint64_t)n->fault.hold_ms * 1000u;
    for (uint32_t c = 0; c < d.copies; c++) {
        const uint32_t passes = c == 0 ? d.passes : 0u;
        if ((d.delay_us[c] == 0 && passes == 0) || n->hold.cap == 0) {
            deliver(n, channel, data, len);
            continue;
        }
        n->stats.fault_delayed += d.delay_us[c] > 0;
        const uint64_t due = now + d.delay_us[c];
        int rc = hal_host_netfault_hold_put(&n->hold, channel, data, len, due, passes,
                                            due + hold_us);
        if (rc == -ENOSPC) {
            /* Full: the one due first goes now, so nothing is lost to the holding area. */
            release_held(n, hal_host_netfault_hold_oldest(&n->hold));
            rc = hal_host_netfault_hold_put(&n->hold, channel, data, len, due, passes,
                                            due + hold_us);
        }
        if (rc != 0) /* not expected (checked datagram, room made): deliver rather than lose */
            deliver(n, channel, data, len);
    }
    release_due(n, now); /* a reordered one may have been passed just now */
}

/* How long the receiver may block in LCM: until the next held datagram is due, at most 50 ms. */
static int rx_timeout_ms(hal_host_net_t *n)
{
    int ms = 50;
    pthread_mutex_lock(&n->mu);
    if (n->hold.fill > 0) {
        const uint64_t now = mono_us();
        release_due(n, now);
        const uint64_t wake = hal_host_netfault_hold_wake_us(&n->hold);
        if (wake != UINT64_MAX)
            ms = wake <= now ? 1 : wake - now >= 50000u ? 50 : (int)((wake - now + 999u) / 1000u);
    }
    unlock_and_wake(n);
    return ms;
}

/* The receiver: the transport's handler all along (hal_host_net_on_datagram queues under the
 * mutex). */
static void *rx_main(void *arg)
{
    hal_host_net_t *n = arg;
    hal_host_name_thread("net-rx");
    while (!atomic_load(&n->rx_stop)) {
        if (n->tp->handle(n->tp_ctx, rx_timeout_ms(n)) < 0) {
            atomic_store(&n->rx_failed, 1);
            pthread_mutex_lock(&n->mu);
            pthread_cond_broadcast(&n->cv);
            pthread_mutex_unlock(&n->mu);
            break;
        }
    }
    return NULL;
}

static hal_host_msg_type_t channel_type(const hal_host_net_t *n, const char *channel)
{
    for (uint32_t i = 0; i < n->n_typed; i++)
        if (strcmp(n->typed_channel[i], channel) == 0)
            return n->typed[i];
    return HAL_HOST_MSG_ANY;
}

int hal_host_net_expect_type(hal_host_net_t *n, const char *channel, int type)
{
    if (n == NULL || !hal_net_channel_valid(channel) || type < 0 || type >= HAL_HOST_MSG_TYPE_COUNT)
        return -EINVAL;
    int rc = 0;
    pthread_mutex_lock(&n->mu);
    uint32_t i = 0;
    while (i < n->n_typed && strcmp(n->typed_channel[i], channel) != 0)
        i++;
    if (i < n->n_typed) {
        n->typed[i] = (hal_host_msg_type_t)type;
    } else if (n->n_typed == HAL_HOST_NET_MAX_SUBS) {
        rc = -ENOSPC;
    } else {
        memcpy(n->typed_channel[n->n_typed], channel, strlen(channel) + 1u);
        n->typed[n->n_typed++] = (hal_host_msg_type_t)type;
    }
    pthread_mutex_unlock(&n->mu);
    return rc;
}

size_t hal_host_net_queue_bytes_default(uint32_t queue_depth)
{
    const size_t want = (size_t)queue_depth * 4096u, least = 4u * HAL_HOST_NET_ENTRY_BYTES(HAL_NET_MTU_BYTES);
    return want > least ? want : least;
}

int hal_host_net_open(const char *url, uint32_t queue_depth, size_t queue_bytes, hal_host_net_t **out)
{
    if (url == NULL || out == NULL || queue_depth == 0 || queue_depth > NET_QUEUE_MAX)
        return -EINVAL;
    if (queue_bytes == 0)
        queue_bytes = hal_host_net_queue_bytes_default(queue_depth);
    queue_bytes = (queue_bytes + 7u) & ~(size_t)7u;
    if (queue_bytes < HAL_HOST_NET_ENTRY_BYTES(HAL_NET_MTU_BYTES) || queue_bytes > HAL_HOST_NET_QUEUE_BYTES_MAX)
        return -EINVAL;
    *out = NULL;
    hal_host_net_t *n = calloc(1, sizeof(*n));
    if (n == NULL)
        return -ENOMEM;
    /* calloc: the pages are mapped when first written, so the ring costs RSS only up to the
       high-water mark of what it held. */
    n->ring = calloc(1, queue_bytes);
    if (n->ring == NULL) {
        free(n);
        return -ENOMEM;
    }
    n->ring_cap = queue_bytes;
    n->depth = queue_depth;
    n->stats.queue_depth = queue_depth;
    n->stats.queue_bytes_cap = queue_bytes;
    n->t0_us = mono_us();
    pthread_condattr_t ca;
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
    pthread_mutex_init(&n->mu, NULL);
    pthread_mutex_init(&n->tx_mu, NULL);
    pthread_cond_init(&n->cv, &ca);
    pthread_condattr_destroy(&ca);
    /* The loss seam of the fleet tests: every N-th datagram "sent" is silently lost, as UDP
       may lose it, so the protocol's recovery runs between real processes. */
    const char *drop = getenv("FLEETSIM_NET_DROP_EVERY");
    if (drop != NULL) {
        char *end = NULL;
        unsigned long long v = strtoull(drop, &end, 10);
        if (end != drop && *end == '\0' && v >= 2)
            n->drop_every = v;
        else
            fprintf(stderr, "hal_host_net: FLEETSIM_NET_DROP_EVERY='%s' ignored (a whole number >= 2)\n", drop);
    }
    /* "zmq://..." is ZeroMQ over TCP; anything else an LCM URL ("" for the default). */
    n->tp = strncmp(url, "zmq://", 6) == 0 ? &hal_host_net_zmq : &hal_host_net_lcm;
    const int rc = n->tp->open(n, url, &n->tp_ctx);
    if (rc != 0) {
        pthread_cond_destroy(&n->cv);
        pthread_mutex_destroy(&n->tx_mu);
        pthread_mutex_destroy(&n->mu);
        free(n->ring);
        free(n);
        return rc;
    }
    *out = n;
    return 0;
}

void hal_host_net_close(hal_host_net_t *n)
{
    if (n == NULL)
        return;
    if (n->rx_started) {
        atomic_store(&n->rx_stop, 1);
        pthread_join(n->rx_thread, NULL);
    }
    n->tp->close(n->tp_ctx);
    pthread_cond_destroy(&n->cv);
    pthread_mutex_destroy(&n->tx_mu);
    pthread_mutex_destroy(&n->mu);
    hal_host_netfault_hold_free(&n->hold); /* what is still held is lost with the process */
    hal_host_auth_wipe(&n->auth);
    free(n->tx_wire);
    free(n->ring);
    free(n);
}

int hal_host_net_set_faults(hal_host_net_t *n, const hal_host_netfault_cfg_t *cfg, uint64_t seed, uint32_t self)
{
    if (n == NULL || cfg == NULL)
        return -EINVAL;
    /* Before the receiver thread exists, so the holding area is in place before any datagram. */
    if (n->rx_started || n->faults_on)
        return -EBUSY;
    if (!hal_host_netfault_active(cfg))
        return 0;
    if (cfg->delay_ms > 0 || cfg->reorder > 0.0) {
        int rc = hal_host_netfault_hold_init(&n->hold, n->depth < NET_HOLD_MAX ? n->depth : NET_HOLD_MAX);
        if (rc != 0)
            return rc;
    }
    pthread_mutex_lock(&n->mu);
    n->fault = *cfg;
    n->fault_seed = seed;
    n->fault_self = self;
    n->faults_on = 1;
    pthread_mutex_unlock(&n->mu);
    return 0;
}

int hal_host_net_set_self(hal_host_net_t *n, uint32_t self)
{
    if (n == NULL)
        return -EINVAL;
    pthread_mutex_lock(&n->mu);
    const int busy = n->rx_started;
    if (!busy) {
        n->self = self;
        n->has_self = 1;
    }
    pthread_mutex_unlock(&n->mu);
    return busy ? -EBUSY : 0;
}

int hal_host_net_set_auth(hal_host_net_t *n, const hal_host_auth_t *auth)
{
    if (n == NULL || auth == NULL)
        return -EINVAL;
    if (n->rx_started || n->keyed) /* before the first datagram can arrive, once */
        return -EBUSY;
    if (hal_host_auth_init() != 0)
        return -EIO;
    n->tx_wire = malloc(HAL_NET_MTU_BYTES + HAL_HOST_AUTH_TRAILER_BYTES);
    if (n->tx_wire == NULL)
        return -ENOMEM;
    pthread_mutex_lock(&n->mu);
    n->auth = *auth;
    n->keyed = 1;
    pthread_mutex_unlock(&n->mu);
    return 0;
}

/* Counts a publish outcome (the receiver thread reads nothing of it, but the stats are one
 * record under the mutex). */
static int tx_count(hal_host_net_t *n, int rc, size_t len)
{
    pthread_mutex_lock(&n->mu);
    if (rc >= 0) {
        n->stats.tx_messages++;
        n->stats.tx_bytes += len;
        n->stats.tx_overflows += rc > 0; /* sent, but a receiver's queue overflowed */
        rc = 0;
    } else {
        n->stats.tx_rejected++;
    }
    pthread_mutex_unlock(&n->mu);
    return rc;
}

/* The sender a datagram names, for a transport that filters by it (-1 for the others: no
 * lookup under the mutex). */
static int64_t publish_sender(hal_host_net_t *n, const char *channel, const void *data, size_t len)
{
    if (n->tp->senders == NULL)
        return -1;
    pthread_mutex_lock(&n->mu);
    const hal_host_msg_type_t type = channel_type(n, channel);
    pthread_mutex_unlock(&n->mu);
    return typed_sender(type, data, len);
}

int hal_host_net_publish(hal_host_net_t *n, const char *channel, const void *data, size_t len)
{
    if (n == NULL)
        return -EINVAL;
    if (!hal_net_channel_valid(channel) || (data == NULL && len > 0))
        return tx_count(n, -EINVAL, len);
    if (len > HAL_NET_MTU_BYTES)
        return tx_count(n, -EMSGSIZE, len);
    if (n->drop_every != 0 && ++n->publishes % n->drop_every == 0)
        return tx_count(n, 0, len); /* lost on the way: the sender cannot tell */
    const int64_t sender = publish_sender(n, channel, data, len);
    if (n->keyed) {
        /* The message and its trailer in one datagram (the wire buffer is the one copy). */
        pthread_mutex_lock(&n->tx_mu);
        if (len > 0)
            memcpy(n->tx_wire, data, len);
        hal_host_auth_seal(&n->auth, channel, n->tx_wire, len);
        const size_t wire = len + HAL_HOST_AUTH_TRAILER_BYTES;
        const int rc = n->tp->publish(n->tp_ctx, channel, n->tx_wire, wire, sender);
        pthread_mutex_unlock(&n->tx_mu);
        return tx_count(n, rc, wire);
    }
    pthread_mutex_lock(&n->tx_mu); /* a transport's sending side is one thread's at a time */
    const int rc = n->tp->publish(n->tp_ctx, channel, data, len, sender);
    pthread_mutex_unlock(&n->tx_mu);
    return tx_count(n, rc, len);
}

/* A datagram from the transport: everything from the wire is checked before it is queued:
 * first who sent it (a keyed fleet's tag), then its shape (the bounds check of a typed
 * channel). A channel nobody subscribed to (a transport that filters by prefix) is ignored;
 * before any check, the node's own datagrams and those of senders it does not want
 * (hal_host_net_set_senders) are dropped on their sender field alone. */
void hal_host_net_on_datagram(hal_host_net_t *n, const char *channel, const void *data, size_t len)
{
    pthread_mutex_lock(&n->mu);
    n->stats.rx_arrived_bytes += len;
    const size_t trailer = n->keyed ? HAL_HOST_AUTH_TRAILER_BYTES : 0u;
    if (channel == NULL || !hal_net_channel_valid(channel) || len > HAL_NET_MTU_BYTES + trailer ||
        (data == NULL && len > 0)) {
        n->stats.rx_dropped_invalid++;
        pthread_mutex_unlock(&n->mu);
        return;
    }
    uint32_t i = 0;
    while (i < n->n_subs && strcmp(n->sub_channel[i], channel) != 0)
        i++;
    if (i == n->n_subs) {
        pthread_mutex_unlock(&n->mu);
        return;
    }
    const hal_host_msg_type_t type = channel_type(n, channel);
    const int64_t sender = typed_sender(type, data, len);
    if (n->has_self && sender == (int64_t)n->self) {
        n->stats.rx_own++;
        pthread_mutex_unlock(&n->mu);
        return;
    }
    /* Not a wanted sender: gone before the tag check and the copy (sender -1: too short to
       name one, or the channel was made untyped; the checks below decide). */
    if (n->sub_filtered[i] && sender >= 0 &&
        (sender >= (int64_t)BOARD_MAX_FLEET || ((n->sub_wanted[i][sender >> 3] >> (sender & 7)) & 1u) == 0)) {
        n->stats.rx_unwanted++;
        pthread_mutex_unlock(&n->mu);
        return;
    }
    const int keyed = n->keyed;
    pthread_mutex_unlock(&n->mu);
    /* The tag and the bounds are checked outside the lock: the tag reads the whole datagram
       (Poly1305 over up to 60 KB) and the key, set once before any datagram (set_auth). Under the
       lock the GP core's receive waited for every check; with 64 robots on 2 cores a receiver
       preempted in one held it off for a time slice. */
    hal_host_auth_verdict_t v = HAL_HOST_AUTH_OK;
    if (keyed)
        v = hal_host_auth_open(&n->auth, channel, data, len, &len);
    const int well_formed = v == HAL_HOST_AUTH_OK && hal_host_msg_check(type, data, len) == HAL_HOST_MSG_OK;
    pthread_mutex_lock(&n->mu);
    if (v == HAL_HOST_AUTH_OTHER_RUN)
        n->stats.rx_dropped_replay++;
    else if (v != HAL_HOST_AUTH_OK)
        n->stats.rx_dropped_unauth++;
    else if (!well_formed) /* typed channels: checked before anything can decode them */
        n->stats.rx_dropped_malformed++;
    else if (n->faults_on)
        inject(n, type, channel, data, (uint32_t)len);
    else
        enqueue(n, channel, data, (uint32_t)len);
    unlock_and_wake(n);
}

int hal_host_net_subscribe(hal_host_net_t *n, const char *channel)
{
    if (n == NULL || !hal_net_channel_valid(channel))
        return -EINVAL;
    pthread_mutex_lock(&n->mu);
    uint32_t i = 0;
    while (i < n->n_subs && strcmp(n->sub_channel[i], channel) != 0)
        i++;
    const int known = i < n->n_subs, full = n->n_subs == HAL_HOST_NET_MAX_SUBS;
    pthread_mutex_unlock(&n->mu);
    if (known)
        return 0;
    if (full)
        return -ENOSPC;
    const int rc = n->tp->subscribe(n->tp_ctx, channel);
    if (rc != 0)
        return rc;
    pthread_mutex_lock(&n->mu);
    memcpy(n->sub_channel[n->n_subs], channel, strlen(channel) + 1u);
    n->n_subs++;
    pthread_mutex_unlock(&n->mu);
    if (!n->rx_started) {
        if (pthread_create(&n->rx_thread, NULL, rx_main, n) != 0)
            return -EIO;
        n->rx_started = 1;
    }
    return 0;
}

int hal_host_net_set_senders(hal_host_net_t *n, const char *channel, const uint8_t *wanted, uint32_t n_ids)
{
    if (n == NULL || !hal_net_channel_valid(channel) || (wanted != NULL && n_ids > (uint32_t)BOARD_MAX_FLEET))
        return -EINVAL;
    uint8_t map[HAL_HOST_NET_SENDER_BYTES];
    memset(map, 0, sizeof map);
    if (wanted != NULL) {
        memcpy(map, wanted, n_ids / 8u);
        if (n_ids % 8u != 0)
            map[n_ids / 8u] = (uint8_t)(wanted[n_ids / 8u] & ((1u << (n_ids % 8u)) - 1u));
    }
    pthread_mutex_lock(&n->mu);
    uint32_t i = 0;
    while (i < n->n_subs && strcmp(n->sub_channel[i], channel) != 0)
        i++;
    if (i == n->n_subs || channel_type(n, channel) == HAL_HOST_MSG_ANY) {
        pthread_mutex_unlock(&n->mu); /* not subscribed, or its datagrams name no sender */
        return -EINVAL;
    }
    const uint8_t filtered = wanted != NULL;
    const int same = n->sub_filtered[i] == filtered && (!filtered || memcmp(n->sub_wanted[i], map, sizeof map) == 0);
    if (!same) {
        n->sub_filtered[i] = filtered;
        memcpy(n->sub_wanted[i], map, sizeof map);
    }
    pthread_mutex_unlock(&n->mu);
    /* The same set again: nothing for the transport to do. Otherwise this node's filter holds
       from now on, and the transport narrows what it carries as soon as it can. */
    if (same || n->tp->senders == NULL)
        return 0;
    return n->tp->senders(n->tp_ctx, channel, filtered ? map : NULL, n_ids);
}

int hal_host_net_group_by_sender(hal_host_net_t *n, const char *channel)
{
    if (n == NULL || !hal_net_channel_valid(channel))
        return -EINVAL;
    pthread_mutex_lock(&n->mu);
    const int typed = channel_type(n, channel) != HAL_HOST_MSG_ANY;
    pthread_mutex_unlock(&n->mu);
    if (!typed)
        return -EINVAL; /* its datagrams must name their sender */
    if (n->rx_started)
        return -EBUSY;
    return n->tp->group != NULL ? n->tp->group(n->tp_ctx, channel, 0) : -ENOTSUP;
}

int hal_host_net_group_by_receiver(hal_host_net_t *n, const char *prefix)
{
    if (n == NULL || !hal_net_channel_valid(prefix))
        return -EINVAL;
    if (n->rx_started)
        return -EBUSY;
    return n->tp->group != NULL ? n->tp->group(n->tp_ctx, prefix, 1) : -ENOTSUP;
}

/* Waits (the mutex held) until a message is queued or timeout_ms passed. Held datagrams that
 * fall due meanwhile are released here too: the wait wakes for them, never past its end. */
static void wait_queued(hal_host_net_t *n, int timeout_ms)
{
    const uint64_t end = mono_us() + (uint64_t)timeout_ms * 1000u;
    for (;;) {
        uint64_t now = mono_us();
        release_due(n, now);
        if (n->fill != 0 || atomic_load(&n->rx_failed) || now >= end)
            return;
        const uint64_t wake = hal_host_netfault_hold_wake_us(&n->hold);
        const uint64_t until = wake > now && wake < end ? wake : end;
        const struct timespec dl = {(time_t)(until / 1000000u), (long)(until % 1000000u) * 1000L};
        (void)pthread_cond_timedwait(&n->cv, &n->mu, &dl); /* the loop checks the end */
    }
}

int hal_host_net_wait(hal_host_net_t *n, uint64_t stamp_us, int timeout_ms)
{
    if (n == NULL || timeout_ms < 0)
        return -EINVAL;
    pthread_mutex_lock(&n->mu);
    n->pump_stamp_us = stamp_us;
    if (n->rx_started)
        wait_queued(n, timeout_ms);
    pthread_mutex_unlock(&n->mu);
    return atomic_load(&n->rx_failed) ? -EIO : 0;
}

int hal_host_net_receive(hal_host_net_t *n, uint64_t stamp_us, hal_net_rx_info_t *info,
                         void *buf, size_t cap)
{
    if (n == NULL || info == NULL || (buf == NULL && cap > 0))
        return -EINVAL;
    pthread_mutex_lock(&n->mu);
    n->pump_stamp_us = stamp_us;
    if (n->hold.fill > 0)
        release_due(n, mono_us());
    if (n->fill == 0) {
        pthread_mutex_unlock(&n->mu);
        return atomic_load(&n->rx_failed) ? -EIO : -EAGAIN;
    }
    const net_entry_t *e = ring_front(n);
    memset(info, 0, sizeof(*info));
    memcpy(info->channel, n->sub_channel[e->sub], strlen(n->sub_channel[e->sub]) + 1u);
    info->len = e->len;
    info->stamp_us = e->stamp_us;
    int rc = 0;
    if (info->len > cap) {
        n->stats.rx_dropped_small++;
        rc = -EMSGSIZE;
    } else {
        if (info->len > 0)
            memcpy(buf, e + 1, info->len);
        n->stats.rx_messages++;
        n->stats.rx_bytes += info->len;
    }
    ring_pop(n, e);
    n->stats.queue_bytes = n->used;
    pthread_mutex_unlock(&n->mu);
    return rc;
}

uint32_t hal_host_net_queued(const hal_host_net_t *n)
{
    if (n == NULL)
        return 0u;
    hal_host_net_t *m = (hal_host_net_t *)n; /* the mutex is not part of the value */
    pthread_mutex_lock(&m->mu);
    const uint32_t f = m->fill;
    pthread_mutex_unlock(&m->mu);
    return f;
}

void hal_host_net_get_stats(const hal_host_net_t *n, hal_net_stats_t *stats)
{
    if (n == NULL || stats == NULL)
        return;
    hal_host_net_t *m = (hal_host_net_t *)n;
    pthread_mutex_lock(&m->mu);
    *stats = m->stats;
    stats->queue_fill = m->fill;
    stats->queue_bytes = m->used;
    pthread_mutex_unlock(&m->mu);
}
