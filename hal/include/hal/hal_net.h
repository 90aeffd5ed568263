/* Network: publish / subscribe of fixed-size byte messages on named channels.
 *
 * Contract
 * - A message is 0 .. BOARD_NET_MTU_BYTES bytes (the board's largest datagram); longer ones
 *   are rejected with -EMSGSIZE, never fragmented by the HAL (fragmenting is the caller's
 *   business, see docs/architecture.md section 4).
 * - Channel names: 1 .. HAL_NET_CHANNEL_MAX-1 characters from [A-Za-z0-9_./-]; -EINVAL
 *   otherwise.
 * - Delivery is best effort (datagrams: loss, duplication and reordering are possible).
 *   Every received message is length-checked by the back end; its content is the
 *   caller's to validate.
 * - Received messages of subscribed channels wait in ONE bounded queue of the board (depth
 *   fixed at start-up). When it is full a new message is dropped and counted
 *   (hal_net_stats_t.rx_dropped_full). A board may also deliver the node's own publishes
 *   back to it (LCM does); filter by content if that matters.
 * - hal_net_receive() polls: it never blocks. It returns -EAGAIN when nothing waits.
 * - The network runs in REAL time, whatever the core's clock: hal_net_clock_us() is the clock
 *   its timeouts are measured on (on a board the same as hal_clock; on the host the wall
 *   clock, because the peers are other processes that run at their own speed while the
 *   lockstep's simulated time does not), and hal_net_wait() blocks the caller until a message
 *   waits or that much real time passed. Both are optional (-ENOTSUP).
 * - Neighbour-scoped delivery (optional, -ENOTSUP): hal_net_set_senders() narrows a channel
 *   whose datagrams name their sender (the fleet's typed channels: an 8-byte fingerprint, then
 *   the big-endian 32-bit sender id) to a set of senders; the others are dropped as early as
 *   the board can, before any check or copy into the queue, and counted
 *   (hal_net_stats_t.rx_unwanted). A board without it delivers every sender, as before.
 *
 * Who may call: the GP core only (the operations are not thread-safe).
 */
#ifndef HAL_NET_H
#define HAL_NET_H

#include "hal/hal_board.h"

#ifndef BOARD_NET_MTU_BYTES
#error "BOARD_NET_MTU_BYTES is not set: build with the board configuration (see the Makefile)"
#endif

#define HAL_NET_MTU_BYTES ((size_t)BOARD_NET_MTU_BYTES)
#define HAL_NET_CHANNEL_MAX 64u /* bytes of a channel name, terminating NUL included */

typedef struct hal_net_rx_info {
    char channel[HAL_NET_CHANNEL_MAX]; /* NUL-terminated channel the message came on */
    uint32_t len;                       /* message length in bytes */
    uint64_t stamp_us;                  /* simulated time it was queued */
} hal_net_rx_info_t;

typedef struct hal_net_stats {
    uint64_t tx_messages;       /* published */
    uint64_t tx_bytes;
    uint64_t tx_rejected;       /* publishes refused (-EMSGSIZE, -EINVAL, -EIO) */
    uint64_t tx_overflows;      /* publishes that found a receiver's queue full on the way (the
                                   host's ZeroMQ: a high-water mark): its copy was dropped, and so
                                   are its next ones, uncounted, until that queue drains */
    uint64_t rx_messages;       /* handed to the caller */
    uint64_t rx_bytes;
    uint64_t rx_dropped_full;   /* dropped because the queue was full */
    uint64_t rx_dropped_invalid;/* dropped because length or channel was invalid */
    uint64_t rx_dropped_small;  /* dropped because the caller's buffer was too small */
    uint64_t rx_dropped_malformed; /* dropped by the bounds check of a typed channel: wrong
                                      type, lengths out of range or past the datagram's end */
    /* A keyed fleet (the host's --key-file): refused before the bounds check. */
    uint64_t rx_dropped_unauth; /* no valid tag: forged, damaged, another key (not a member) */
    uint64_t rx_dropped_replay; /* a member's tag of another run: a recording played back */
    uint64_t rx_own;            /* the node's own publishes delivered back (LCM multicast loops
                                   them), dropped before the tag check (a host told its id) */
    uint64_t rx_unwanted;       /* dropped because their sender is not in the channel's wanted
                                   set (hal_net_set_senders), before the tag check; a board that
                                   filters at the sender (ZeroMQ) never sees most of them */
    uint64_t rx_arrived_bytes;  /* every byte the network was handed, whatever became of it
                                   (own echoes, unwanted senders and drops included): what
                                   reached this node at all (the host; 0 elsewhere) */
    /* Faults a board injected on purpose (the host's --net-faults; 0 elsewhere). */
    uint64_t fault_dropped;     /* lost at random */
    uint64_t fault_duplicated;  /* delivered twice */
    uint64_t fault_reordered;   /* held back until later ones passed it */
    uint64_t fault_delayed;     /* copies held back for a delay */
    uint64_t fault_partitioned; /* lost because sender and receiver were partitioned */
    uint32_t queue_fill;        /* messages waiting now */
    uint32_t queue_depth;       /* capacity of the queue */
    /* A board whose queue is a byte ring (the host; 0 elsewhere): the messages above share
       queue_bytes_cap bytes, and a datagram that does not fit them is dropped as full too. */
    uint64_t queue_bytes;       /* bytes in use now (headers and padding included) */
    uint64_t queue_bytes_max;   /* high-water mark of queue_bytes since start */
    uint64_t queue_bytes_cap;   /* the ring's size */
    uint32_t queue_fill_max;    /* high-water mark of queue_fill since start (the host) */
    uint32_t rx_inline;         /* the host: 1 when no receiver thread fills the queue, the
                                   socket's kernel buffer holding what waits (0 elsewhere) */
} hal_net_stats_t;

typedef struct hal_net_ops {
    /* Required. See the wrappers. */
    int (*publish)(void *ctx, const char *channel, const void *data, size_t len);
    int (*subscribe)(void *ctx, const char *channel);
    int (*receive)(void *ctx, hal_net_rx_info_t *info, void *buf, size_t cap);
    /* Optional. */
    int (*stats)(void *ctx, hal_net_stats_t *stats);
    int (*wait)(void *ctx, uint32_t timeout_us);
    int (*clock_us)(void *ctx, uint64_t *now_us);
    int (*senders)(void *ctx, const char *channel, const uint8_t *wanted, uint32_t n_ids);
} hal_net_ops_t;

/* 1 when `channel` is a valid channel name, else 0. */
static inline int hal_net_channel_valid(const char *channel)
{
    if (channel == NULL)
        return 0;
    size_t n = 0;
    for (; channel[n] != '\0'; n++) {
        char c = channel[n];
        int ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                 c == '_' || c == '.' || c == '/' || c == '-';
        if (!ok || n + 1u >= HAL_NET_CHANNEL_MAX)
            return 0;
    }
    return n > 0;
}

/* Sends `len` bytes on `channel`. 0, -EINVAL (bad channel, NULL data with len > 0),
 * -EMSGSIZE (len > HAL_NET_MTU_BYTES), -EIO (transport failure), -ENODEV. */
FS_MUST_CHECK static inline int hal_net_publish(const char *channel, const void *data, size_t len)
{
    const hal_board_t *b = hal_board_current;
    if (!hal_net_channel_valid(channel) || (data == NULL && len > 0))
        return -EINVAL;
    if (len > HAL_NET_MTU_BYTES)
        return -EMSGSIZE;
    if (b == NULL || b->net == NULL)
        return -ENODEV;
    return b->net->publish(b->ctx, channel, data, len);
}

/* Starts queueing messages of `channel`. Subscribing twice to one channel is a no-op.
 * 0, -EINVAL, -ENOSPC (the board's subscription table is full), -EIO, -ENODEV. */
FS_MUST_CHECK static inline int hal_net_subscribe(const char *channel)
{
    const hal_board_t *b = hal_board_current;
    if (!hal_net_channel_valid(channel))
        return -EINVAL;
    if (b == NULL || b->net == NULL)
        return -ENODEV;
    return b->net->subscribe(b->ctx, channel);
}

/* Takes the oldest queued message: copies it into buf (cap bytes) and fills *info.
 * 0 when a message was taken, -EAGAIN when none waits, -EMSGSIZE when it is longer than
 * cap (it is dropped and counted; info->len tells its length), -EINVAL, -ENODEV.
 * Never blocks. */
FS_MUST_CHECK static inline int hal_net_receive(hal_net_rx_info_t *info, void *buf, size_t cap)
{
    const hal_board_t *b = hal_board_current;
    if (info == NULL || (buf == NULL && cap > 0))
        return -EINVAL;
    if (b == NULL || b->net == NULL)
        return -ENODEV;
    return b->net->receive(b->ctx, info, buf, cap);
}

/* Counters since start. 0, -EINVAL, -ENOTSUP, -ENODEV. */
FS_MUST_CHECK static inline int hal_net_get_stats(hal_net_stats_t *stats)
{
    const hal_board_t *b = hal_board_current;
    if (stats == NULL)
        return -EINVAL;
    if (b == NULL || b->net == NULL)
        return -ENODEV;
    if (b->net->stats == NULL)
        return -ENOTSUP;
    return b->net->stats(b->ctx, stats);
}

/* Blocks until a message waits in the queue or timeout_us of real time passed. 0 when one
 * waits, -EAGAIN on timeout, -EIO, -ENOTSUP, -ENODEV. */
FS_MUST_CHECK static inline int hal_net_wait(uint32_t timeout_us)
{
    const hal_board_t *b = hal_board_current;
    if (b == NULL || b->net == NULL)
        return -ENODEV;
    if (b->net->wait == NULL)
        return -ENOTSUP;
    return b->net->wait(b->ctx, timeout_us);
}

/* The network's clock (real time, microseconds, monotonic). 0, -EINVAL, -ENOTSUP, -ENODEV. */
FS_MUST_CHECK static inline int hal_net_clock_us(uint64_t *now_us)
{
    const hal_board_t *b = hal_board_current;
    if (now_us == NULL)
        return -EINVAL;
    if (b == NULL || b->net == NULL)
        return -ENODEV;
    if (b->net->clock_us == NULL)
        return -ENOTSUP;
    return b->net->clock_us(b->ctx, now_us);
}

/* From now on delivers only the datagrams of `channel` whose sender is in `wanted`: bit i
 * (wanted[i / 8] >> (i % 8) & 1) for sender id i, n_ids bits (ids >= n_ids are unwanted;
 * n_ids == 0 wants nobody). wanted == NULL delivers every sender again (the default; n_ids is
 * then ignored). The others are dropped as early as the board can (before any tag check or
 * copy into the queue) and counted in hal_net_stats_t.rx_unwanted. The set is copied; it
 * applies to datagrams that arrive after the call (ones already queued stay), and setting the
 * same set again costs no transport work. A datagram too short to name its sender passes (the
 * checks after refuse it). A board that filters at the publisher may lose a newly wanted
 * sender's datagrams in flight while the change propagates (best effort, as any loss).
 * 0; -EINVAL: bad channel, n_ids > BOARD_MAX_FLEET, or (board-specific) a channel not
 * subscribed or whose datagrams do not name a sender (the host: not typed,
 * hal_host_net_expect_type); -ENOTSUP: the board cannot filter (everything is delivered, as
 * before); -ENODEV. */
FS_MUST_CHECK static inline int hal_net_set_senders(const char *channel, const uint8_t *wanted, uint32_t n_ids)
{
    const hal_board_t *b = hal_board_current;
    if (!hal_net_channel_valid(channel) || (wanted != NULL && n_ids > (uint32_t)BOARD_MAX_FLEET))
        return -EINVAL;
    if (b == NULL || b->net == NULL)
        return -ENODEV;
    if (b->net->senders == NULL)
        return -ENOTSUP;
    return b->net->senders(b->ctx, channel, wanted, n_ids);
}

#endif /* HAL_NET_H */
