/* The transports under the host network (hal_host_net.c): what moves datagrams between
 * processes. hal_host_net.c owns everything above them (the bounded queue, the keyed fleet's
 * tag check, the bounds check, fault injection, the counters) and runs one receiver thread
 * that calls the transport's `handle`, or none where the transport receives inline
 * (`inline_fd`, hal_host_net_rx.c); the transport hands each datagram it receives to
 * hal_host_net_on_datagram(), or straight into the GP core's buffer (`take_into`). Three exist:
 *   - LCM (any LCM URL: udpm:// multicast on one host or a routed segment, memq:// in one
 *     process): hal_host_net_lcm.c;
 *   - ZeroMQ over TCP ("zmq://BIND?peers=EP,EP,...", hal_host_net_zmq.c): peer to peer, each
 *     process binds one PUB endpoint and connects its SUB to every peer's; or
 *     "zmq://?proxy=HOST:PORT", every process through one forwarder (host_sim zmq-proxy);
 *   - shared memory between the processes of one host ("shm://NAME", hal_host_net_shm.c).
 * Neighbour-scoped delivery (hal_host_net_set_senders): hal_host_net.c drops an unwanted
 * sender's datagram on arrival whatever the transport; a transport that can do better (ZeroMQ:
 * at the publisher, so the bytes never cross TCP; LCM with per-sender groups: the kernel never
 * copies them) offers `senders`, and its `publish` is told each datagram's sender for that.
 * Not part of the board's API. */
#ifndef HAL_HOST_NET_TRANSPORT_H
#define HAL_HOST_NET_TRANSPORT_H

#include <stddef.h>
#include <stdint.h>

/* Bytes of a sender bitmap: one bit per possible robot id (0 .. BOARD_MAX_FLEET - 1). */
#define HAL_HOST_NET_SENDER_BYTES (((size_t)BOARD_MAX_FLEET + 7u) / 8u)

typedef struct hal_host_net hal_host_net_t;

typedef struct hal_host_net_transport {
    const char *name;
    /* Opens the transport for url; on failure prints why on stderr and returns -EINVAL (a bad
       URL) or -EIO. */
    int (*open)(hal_host_net_t *n, const char *url, void **ctx);
    void (*close)(void *ctx);
    /* Sends one datagram (any thread, one at a time: hal_host_net.c serialises). `sender` is the
       robot id the datagram names (a typed channel's sender field, 0 .. UINT32_MAX), -1 when it
       names none (an untyped channel, too short) or the transport has no `senders`. 0, 1 (sent,
       but some receiver's queue overflowed and lost its copy: ZeroMQ's high-water mark), -EIO. */
    int (*publish)(void *ctx, const char *channel, const void *data, size_t len, int64_t sender);
    /* Adds a channel (the caller's thread, before or while the receiver runs). 0, -EIO. */
    int (*subscribe)(void *ctx, const char *channel);
    /* The receiver thread: waits up to timeout_ms, delivering what arrives through
       hal_host_net_on_datagram(). 0, or < 0 when the transport is gone. */
    int (*handle)(void *ctx, int timeout_ms);
    /* Optional (NULL: the transport delivers every sender; hal_host_net.c's filter is all).
       Narrows what arrives on a subscribed `channel` to the senders whose bit is set in
       `wanted` (HAL_HOST_NET_SENDER_BYTES bytes, bit i = wanted[i / 8] >> (i % 8) & 1), or
       every sender again (wanted NULL). Called from the caller's thread while the receiver
       runs, only when the set changed; best effort (what passes is filtered above). 0, -EINVAL
       (not subscribed), -EIO. `n_ids`: the fleet's size (the ids "every sender" means). */
    int (*senders)(void *ctx, const char *channel, const uint8_t *wanted, uint32_t n_ids);
    /* Optional (NULL: -ENOTSUP). by_receiver 0: carries `channel` per sender from now on, for
       publishing and receiving alike (LCM's per-sender groups); receiving it then takes
       `senders`. by_receiver 1: `channel` is a prefix, and the channels PREFIX<id> are carried
       to robot id alone (its inbox). Called before the first subscription, at every member of
       the fleet alike. 0, -ENOTSUP (the URL cannot), -ENOSPC (no room for another), -EIO. */
    int (*group)(void *ctx, const char *channel, int by_receiver);
    /* Optional (NULL: never). A descriptor that is readable when datagrams wait, when
       everything this transport receives arrives through it and its kernel buffer holds at
       least queue_bytes (the queue's), else -1. Asked once, at the first subscription; from
       the first wait or receive on no receiver thread runs: the thread that waits for messages
       polls it and calls `take`. */
    int (*inline_fd)(void *ctx, size_t queue_bytes);
    /* With inline_fd: delivers up to max datagrams of what waits on it now, without blocking;
       the rest stays in the kernel's buffer. >= 0, or < 0 when the transport is gone. */
    int (*take)(void *ctx, uint32_t max);
    /* Optional, with inline_fd (NULL: never). Takes the next datagram waiting (the first
       wanted one, as take would deliver it) straight into buf, its channel into channel
       (HAL_NET_CHANNEL_MAX bytes) and its length into *len, without blocking: 1, 0 (none
       waits), -EMSGSIZE (one longer than cap, gone; *len its length), or < 0 when the
       transport is gone. hal_host_net.c then checks it there, and a datagram taken this way is
       copied once on its way to the GP core instead of three times (hal_host_net_rx.c). */
    int (*take_into)(void *ctx, char *channel, void *buf, size_t cap, size_t *len);
    /* 1: only processes of this user on this host can put a datagram in (shm://, a 0600
       segment, as the fleet key's file is): a keyed fleet's datagrams go without the trailer
       and its check, which would only tell what the key's file mode already does. */
    int trusted_host;
} hal_host_net_transport_t;

extern const hal_host_net_transport_t hal_host_net_lcm;
extern const hal_host_net_transport_t hal_host_net_zmq;
extern const hal_host_net_transport_t hal_host_net_shm;

/* One datagram received on `channel` (any transport, the receiver thread). */
void hal_host_net_on_datagram(hal_host_net_t *n, const char *channel, const void *data, size_t len);

/* Datagrams the transport lost before they could be handed over (a shm:// reader its writer
   lapped): counted with the queue's drops, where a socket's full buffer would lose them. */
void hal_host_net_on_lost(hal_host_net_t *n, uint32_t count);

#endif /* HAL_HOST_NET_TRANSPORT_H */
