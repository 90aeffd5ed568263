/* What hal_host_net.c (set-up, publishing, the filters) and hal_host_net_rx.c (the queue and
 * receiving) share: the network's state and a few helpers. Not part of any API. */
#ifndef HAL_HOST_NET_INTERNAL_H
#define HAL_HOST_NET_INTERNAL_H

#include "hal_host.h"
#include "hal_host_auth.h"
#include "hal_host_msg.h"
#include "hal_host_net_transport.h"
#include "hal_host_netfault.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>

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
    const hal_host_net_transport_t *tp; /* LCM, ZeroMQ or shm (hal_host_net_transport.h) */
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
    int rx_started;        /* receiving: the receiver thread, or inline (inline_fd) */
    int rx_thread_on;
    int inline_fd;         /* >= 0: no receiver thread; wait and receive take from this */
    int inline_next;       /* the transport's inline descriptor, taken over from the receiver
                              thread at the first wait or receive; -1: none */
    atomic_int rx_stop;
    atomic_int rx_failed;  /* the transport's handle failed: it is gone */
};

/* CLOCK_MONOTONIC in microseconds. */
uint64_t hal_host_net_mono_us(void);

/* mu held: the message type channel was declared with (HAL_HOST_MSG_ANY: untyped). */
hal_host_msg_type_t hal_host_net_channel_type(const hal_host_net_t *n, const char *channel);

/* The sender a datagram of a typed channel names (its first field, after the fingerprint), or
   -1 (untyped, too short). Not checked: a hint until the tag is. */
int64_t hal_host_net_typed_sender(hal_host_msg_type_t type, const void *data, size_t len);

/* Receiving begins (the first subscription): the transport's inline descriptor, or else the
   receiver thread. 0 or -EIO. */
int hal_host_net_rx_start(hal_host_net_t *n);

/* The receiver thread stopped and joined, when one runs (close). */
void hal_host_net_rx_stop(hal_host_net_t *n);

#endif /* HAL_HOST_NET_INTERNAL_H */
