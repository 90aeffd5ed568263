/* The receiving side of hal_net on the host (hal_host_net.c has the rest; both share
 * hal_host_net_internal.h): the queue, how datagrams get into it, and the GP core's wait and
 * receive.
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
 * A receiver thread (started with the first subscription) runs the transport's handler all
 * along and moves every datagram into the queue at once, as a board's network interface
 * receives while its cores compute. Without it LCM's own buffer (about 1 MB in LCM 1.3) fills
 * whenever the process is busy, and a fleet of 14 robots lost chunks every round. The queue is
 * the one place both threads touch, under one mutex; what does not fit is dropped and counted.
 *
 * Inline receiving, where the transport offers it (hal_host_net_transport.h inline_fd: LCM's
 * udpm:// socket when it is all that is received and its kernel buffer holds at least the
 * queue's bytes): no receiver thread from the consumer's first wait or receive on (the thread
 * drains the socket until then, while the process starts). The socket's kernel buffer holds
 * what arrives while the process computes, and the thread that waits for messages (the GP
 * core) polls the socket and takes what is there itself, as does a receive that finds the queue
 * empty. Each datagram then
 * wakes one thread instead of two: with 64 robots on 2 cores, 37 % fewer context switches and
 * 5 % shorter rounds (docs/scaling.md). The kernel's buffer overflowing is counted by the
 * kernel alone (UdpRcvbufErrors in /proc/net/snmp, which tools/fleet reports), not here.
 *
 * Fault injection (hal_host_net_set_faults, hal_host_netfault.h) acts where a datagram enters
 * the queue, after the checks: receive side, so one robot's loss does not hide the datagram
 * from the others (a lossy radio, not a broken sender). Delayed and reordered datagrams wait
 * in a holding area allocated with the faults; the receiver thread, wait and receive move
 * what is due into the queue as time passes. */
#include "hal_host_net_internal.h"

#include <errno.h>
#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

uint64_t hal_host_net_mono_us(void)
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

int64_t hal_host_net_typed_sender(hal_host_msg_type_t type, const void *data, size_t len)
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
    const uint64_t now = hal_host_net_mono_us();
    release_due(n, now);
    const int32_t sender = (int32_t)hal_host_net_typed_sender(type, data, len);
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
        const uint64_t now = hal_host_net_mono_us();
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

void hal_host_net_on_lost(hal_host_net_t *n, uint32_t count)
{
    pthread_mutex_lock(&n->mu);
    n->stats.rx_dropped_full += count;
    pthread_mutex_unlock(&n->mu);
}

/* mu held (released around the tag check and held again): everything from the wire is checked
 * before anyone sees it: first who sent it (a keyed fleet's tag), then its shape (the bounds
 * check of a typed channel). A channel nobody subscribed to (a transport that filters by
 * prefix) is ignored; before any check, the node's own datagrams and those of senders it does
 * not want (hal_host_net_set_senders) are dropped on their sender field alone. Returns the
 * subscription index of a datagram that passed (*len: without the trailer; *type: its
 * channel's), else -1 (counted where it is a drop). */
static int admit(hal_host_net_t *n, const char *channel, const void *data, size_t *len, hal_host_msg_type_t *type)
{
    n->stats.rx_arrived_bytes += *len;
    const size_t trailer = n->keyed ? HAL_HOST_AUTH_TRAILER_BYTES : 0u;
    if (channel == NULL || !hal_net_channel_valid(channel) || *len > HAL_NET_MTU_BYTES + trailer ||
        (data == NULL && *len > 0)) {
        n->stats.rx_dropped_invalid++;
        return -1;
    }
    const uint32_t i = sub_index(n, channel);
    if (i == n->n_subs)
        return -1;
    *type = hal_host_net_channel_type(n, channel);
    const int64_t sender = hal_host_net_typed_sender(*type, data, *len);
    if (n->has_self && sender == (int64_t)n->self) {
        n->stats.rx_own++;
        return -1;
    }
    /* Not a wanted sender: gone before the tag check and the copy (sender -1: too short to
       name one, or the channel was made untyped; the checks below decide). */
    if (n->sub_filtered[i] && sender >= 0 &&
        (sender >= (int64_t)BOARD_MAX_FLEET || ((n->sub_wanted[i][sender >> 3] >> (sender & 7)) & 1u) == 0)) {
        n->stats.rx_unwanted++;
        return -1;
    }
    const int keyed = n->keyed;
    pthread_mutex_unlock(&n->mu);
    /* The tag and the bounds are checked outside the lock: the tag reads the whole datagram
       (Poly1305 over up to 60 KB) and the key, set once before any datagram (set_auth). Under the
       lock the GP core's receive waited for every check; with 64 robots on 2 cores a receiver
       preempted in one held it off for a time slice. */
    hal_host_auth_verdict_t v = HAL_HOST_AUTH_OK;
    if (keyed)
        v = hal_host_auth_open(&n->auth, channel, data, *len, len);
    const int well_formed = v == HAL_HOST_AUTH_OK && hal_host_msg_check(*type, data, *len) == HAL_HOST_MSG_OK;
    pthread_mutex_lock(&n->mu);
    if (v == HAL_HOST_AUTH_OTHER_RUN)
        n->stats.rx_dropped_replay++;
    else if (v != HAL_HOST_AUTH_OK)
        n->stats.rx_dropped_unauth++;
    else if (!well_formed) /* typed channels: checked before anything can decode them */
        n->stats.rx_dropped_malformed++;
    return v == HAL_HOST_AUTH_OK && well_formed ? (int)i : -1;
}

void hal_host_net_on_datagram(hal_host_net_t *n, const char *channel, const void *data, size_t len)
{
    pthread_mutex_lock(&n->mu);
    hal_host_msg_type_t type;
    if (admit(n, channel, data, &len, &type) >= 0) {
        if (n->faults_on)
            inject(n, type, channel, data, (uint32_t)len);
        else
            enqueue(n, channel, data, (uint32_t)len);
    }
    unlock_and_wake(n);
}

/* Waits (the mutex held) until a message is queued or timeout_ms passed. Held datagrams that
 * fall due meanwhile are released here too: the wait wakes for them, never past its end. */
static void wait_queued(hal_host_net_t *n, int timeout_ms)
{
    const uint64_t end = hal_host_net_mono_us() + (uint64_t)timeout_ms * 1000u;
    for (;;) {
        uint64_t now = hal_host_net_mono_us();
        release_due(n, now);
        if (n->fill != 0 || atomic_load(&n->rx_failed) || now >= end)
            return;
        const uint64_t wake = hal_host_netfault_hold_wake_us(&n->hold);
        const uint64_t until = wake > now && wake < end ? wake : end;
        const struct timespec dl = {(time_t)(until / 1000000u), (long)(until % 1000000u) * 1000L};
        (void)pthread_cond_timedwait(&n->cv, &n->mu, &dl); /* the loop checks the end */
    }
}

/* Direct receiving: the transport takes a datagram straight into the GP core's buffer
   (take_into) when the queue is empty and no fault is injected (the injector holds datagrams
   in the queue's way) nor tag checked (a keyed datagram's trailer needs room the caller's
   buffer may not have). The queue then only holds the one a wait took to say something came. */
static int direct(const hal_host_net_t *n)
{
    return n->tp->take_into != NULL && !n->faults_on && !n->keyed;
}

/* Inline receiving (no receiver thread): what waits on the transport's descriptor, taken into
   an empty queue, as much as it surely holds (MTU-sized entries, the message cap; at most 64 at
   a time). The kernel's buffer keeps the rest: nothing is dropped for a queue that is only full
   until the GP core reads it. Its callers take only when the queue is empty (wait_inline
   returns as soon as it holds anything), so the ring's free space is its size. */
static void take_inline(hal_host_net_t *n)
{
    pthread_mutex_lock(&n->mu);
    const int empty = n->fill == 0;
    pthread_mutex_unlock(&n->mu);
    if (!empty)
        return;
    const size_t fit = n->ring_cap / HAL_HOST_NET_ENTRY_BYTES(HAL_NET_MTU_BYTES);
    const size_t room = direct(n) ? 1u : fit < n->depth ? fit : n->depth;
    if (room > 0 && n->tp->take(n->tp_ctx, room < 64u ? (uint32_t)room : 64u) < 0)
        atomic_store(&n->rx_failed, 1);
}

/* Inline receiving: polls the transport's descriptor until a message is queued or timeout_ms
   passed, taking what arrives (a zero timeout still takes what waits); held datagrams that
   fall due end the wait too. */
static void wait_inline(hal_host_net_t *n, int timeout_ms)
{
    const uint64_t end = hal_host_net_mono_us() + (uint64_t)timeout_ms * 1000u;
    if (direct(n)) /* what a receive left waiting rings no doorbell: look before sleeping */
        take_inline(n);
    for (int last = 0;;) {
        const uint64_t now = hal_host_net_mono_us();
        pthread_mutex_lock(&n->mu);
        release_due(n, now);
        const int queued = n->fill != 0;
        const uint64_t wake = hal_host_netfault_hold_wake_us(&n->hold);
        pthread_mutex_unlock(&n->mu);
        if (queued || last || atomic_load(&n->rx_failed))
            return;
        last = now >= end;
        const uint64_t until = last ? now : wake > now && wake < end ? wake : end;
        struct pollfd p = {.fd = n->inline_fd, .events = POLLIN};
        const int r = poll(&p, 1, (int)((until - now + 999u) / 1000u));
        if (r > 0)
            take_inline(n);
        else if (r < 0 && errno != EINTR)
            atomic_store(&n->rx_failed, 1);
    }
}

/* The consumer's thread: whether it receives inline, taking over from the receiver thread at
   its first call (the thread stopped and joined: at most one poll of 50 ms). Until then the
   thread drains the socket: a process still starting (seconds, with 256 robots on 2 cores)
   would otherwise leave everything to the kernel's buffer. */
static int receiving_inline(hal_host_net_t *n)
{
    if (n->inline_next >= 0) {
        hal_host_net_rx_stop(n);
        pthread_mutex_lock(&n->mu); /* get_stats reads it from any thread */
        n->inline_fd = n->inline_next;
        pthread_mutex_unlock(&n->mu);
        n->inline_next = -1;
    }
    return n->inline_fd >= 0;
}

int hal_host_net_wait(hal_host_net_t *n, uint64_t stamp_us, int timeout_ms)
{
    if (n == NULL || timeout_ms < 0)
        return -EINVAL;
    if (receiving_inline(n)) {
        pthread_mutex_lock(&n->mu);
        n->pump_stamp_us = stamp_us;
        pthread_mutex_unlock(&n->mu);
        wait_inline(n, timeout_ms);
        return atomic_load(&n->rx_failed) ? -EIO : 0;
    }
    pthread_mutex_lock(&n->mu);
    n->pump_stamp_us = stamp_us;
    if (n->rx_started)
        wait_queued(n, timeout_ms);
    pthread_mutex_unlock(&n->mu);
    return atomic_load(&n->rx_failed) ? -EIO : 0;
}

/* Direct receiving (the queue empty): the next datagram that passes the checks, taken by the
   transport into buf and checked there. */
static int receive_direct(hal_host_net_t *n, uint64_t stamp_us, hal_net_rx_info_t *info, void *buf, size_t cap)
{
    for (;;) {
        char channel[HAL_NET_CHANNEL_MAX];
        size_t len = 0;
        const int r = n->tp->take_into(n->tp_ctx, channel, buf, cap, &len);
        if (r == 0)
            return -EAGAIN;
        if (r < 0 && r != -EMSGSIZE) {
            atomic_store(&n->rx_failed, 1);
            return -EIO;
        }
        pthread_mutex_lock(&n->mu);
        if (r == -EMSGSIZE) {
            n->stats.rx_arrived_bytes += len;
            n->stats.rx_dropped_small++;
            pthread_mutex_unlock(&n->mu);
            return -EMSGSIZE;
        }
        hal_host_msg_type_t type;
        const int i = admit(n, channel, buf, &len, &type);
        if (i >= 0) {
            memset(info, 0, sizeof(*info));
            memcpy(info->channel, n->sub_channel[i], strlen(n->sub_channel[i]) + 1u);
            info->len = (uint32_t)len;
            info->stamp_us = stamp_us;
            n->stats.rx_messages++;
            n->stats.rx_bytes += len;
        }
        pthread_mutex_unlock(&n->mu);
        if (i >= 0)
            return 0;
    }
}

int hal_host_net_receive(hal_host_net_t *n, uint64_t stamp_us, hal_net_rx_info_t *info,
                         void *buf, size_t cap)
{
    if (n == NULL || info == NULL || (buf == NULL && cap > 0))
        return -EINVAL;
    if (receiving_inline(n)) {
        if (direct(n)) {
            pthread_mutex_lock(&n->mu);
            n->pump_stamp_us = stamp_us;
            const int empty = n->fill == 0;
            pthread_mutex_unlock(&n->mu);
            if (empty)
                return receive_direct(n, stamp_us, info, buf, cap);
        } else {
            take_inline(n); /* into an empty queue only */
        }
    }
    pthread_mutex_lock(&n->mu);
    n->pump_stamp_us = stamp_us;
    if (n->hold.fill > 0)
        release_due(n, hal_host_net_mono_us());
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

int hal_host_net_rx_start(hal_host_net_t *n)
{
    n->inline_next = n->tp->inline_fd != NULL ? n->tp->inline_fd(n->tp_ctx, n->ring_cap) : -1;
    if (pthread_create(&n->rx_thread, NULL, rx_main, n) != 0)
        return -EIO;
    n->rx_thread_on = 1;
    n->rx_started = 1;
    return 0;
}

void hal_host_net_rx_stop(hal_host_net_t *n)
{
    if (n->rx_thread_on) {
        atomic_store(&n->rx_stop, 1);
        pthread_join(n->rx_thread, NULL);
        n->rx_thread_on = 0;
    }
}
