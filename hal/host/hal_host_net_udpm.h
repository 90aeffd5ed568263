/* The receiving side of LCM's udpm:// provider, read by the host network's receiver thread
 * itself (hal_host_net_lcm.c publishes through LCM as before; this only receives).
 *
 * Why not LCM's own: LCM 1.3 receives on a thread of its own that copies each datagram into its
 * ring and writes a byte to a pipe; the receiver thread then selects on the pipe, reads the byte
 * and dispatches one message per lcm_handle call. Every datagram crossed two threads and four
 * system calls before our queue saw it: in a 64-robot fleet on 2 cores that thread took 15 % of
 * the CPU, most of it switching and signalling rather than copying. Here one socket, joined to
 * the URL's group and port as LCM joins it, is read in batches (recvmmsg) by the thread that
 * checks and queues the datagrams.
 *
 * What it reads is LCM's wire format (LCM's "UDP multicast protocol"): a short message is the
 * magic "LC02", a 32-bit sequence number, the channel name and its NUL, then the payload. A
 * fragment of a long message ("LC03") carries more than the network's MTU (hal_net.h), which no
 * subscribed channel may: its first fragment, the one naming the channel, is reported as
 * invalid, the others are ignored. So is anything else that is not LCM's (another magic, no
 * NUL within the datagram): LCM drops those too. Which channels are kept is decided above
 * (hal_host_net_on_datagram: the subscriptions), and the kernel filter
 * (hal_host_net_kfilter.h) goes on this socket. Linux only (recvmmsg). */
#ifndef HAL_HOST_NET_UDPM_H
#define HAL_HOST_NET_UDPM_H

#include <stddef.h>
#include <stdint.h>

/* Datagrams one system call may take (a buffer of 64 KB each, touched only when used). */
#define UDPM_RX_BATCH 8u
/* A UDP datagram's largest payload, and so a receive buffer. */
#define UDPM_RX_DATAGRAM_MAX 65536u

typedef enum udpm_kind {
    UDPM_MESSAGE = 0, /* a short message: channel and payload */
    UDPM_TOO_LONG,    /* the first fragment of a long message: its channel, no payload */
    UDPM_IGNORED,     /* a later fragment: names nothing */
    UDPM_INVALID,     /* not LCM's: too short, another magic, a channel without its NUL */
} udpm_kind_t;

typedef struct udpm_datagram {
    udpm_kind_t kind;
    const char *channel;    /* UDPM_MESSAGE, UDPM_TOO_LONG: inside the datagram, NUL-terminated */
    const uint8_t *payload; /* UDPM_MESSAGE */
    size_t len;
} udpm_datagram_t;

/* What one datagram of len bytes at d is (pure: no state, never reads past d + len). */
udpm_datagram_t udpm_parse(const uint8_t *d, size_t len);

typedef struct udpm_rx udpm_rx_t;

/* Called for each datagram a batch brought, in arrival order. */
typedef void (*udpm_rx_fn)(void *user, const udpm_datagram_t *dg);

/* A socket bound to `port` (SO_REUSEADDR, as LCM's: every robot of the host binds it) and
   joined to the IPv4 multicast group `group` (host order), with a kernel receive buffer of
   rcvbuf bytes when rcvbuf > 0. 0, -EINVAL or -errno (said on stderr). */
int udpm_rx_open(uint32_t group, uint32_t port, int rcvbuf, udpm_rx_t **out);
void udpm_rx_close(udpm_rx_t *r);
int udpm_rx_fd(const udpm_rx_t *r);
/* The socket's kernel receive buffer in bytes, as the kernel accounts it (Linux doubles what
   SO_RCVBUF asked, within net.core.rmem_max); 0 when unknown. */
size_t udpm_rx_rcvbuf(const udpm_rx_t *r);

/* Takes what is queued on the socket without waiting, a batch at a time, up to max datagrams,
   handing each to fn: the number taken (0 when none was there), or -EIO. What is left waits in
   the kernel's buffer. For a caller that polled the descriptor itself (udpm_rx_fd). */
int udpm_rx_take(udpm_rx_t *r, uint32_t max, udpm_rx_fn fn, void *user);

/* udpm_rx_take of at most 8 batches. */
int udpm_rx_drain(udpm_rx_t *r, udpm_rx_fn fn, void *user);

/* Waits up to timeout_ms for the socket, then udpm_rx_drain. */
int udpm_rx_handle(udpm_rx_t *r, int timeout_ms, udpm_rx_fn fn, void *user);

#endif /* HAL_HOST_NET_UDPM_H */
