/* LCM's udpm:// wire, received in batches (hal_host_net_udpm.h). */
#define _GNU_SOURCE /* recvmmsg */
#include "hal_host_net_udpm.h"

#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#define MAGIC_SHORT 0x4c433032u /* "LC02" */
#define MAGIC_LONG 0x4c433033u  /* "LC03" */
#define SHORT_HEADER 8u         /* magic, sequence number */
#define LONG_HEADER 20u         /* + message size, fragment offset, fragment number, fragments */

static uint32_t be32(const uint8_t *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | (uint32_t)p[3];
}

/* The NUL-terminated name at d (n bytes available), or NULL when the NUL is not there. */
static const char *name_at(const uint8_t *d, size_t n, size_t *name_bytes)
{
    const uint8_t *nul = n > 0 ? memchr(d, 0, n) : NULL;
    if (nul == NULL || nul == d)
        return NULL;
    *name_bytes = (size_t)(nul - d) + 1u;
    return (const char *)d;
}

udpm_datagram_t udpm_parse(const uint8_t *d, size_t len)
{
    udpm_datagram_t g = {UDPM_INVALID, NULL, NULL, 0};
    if (d == NULL || len < SHORT_HEADER)
        return g;
    size_t nb = 0;
    const uint32_t magic = be32(d);
    if (magic == MAGIC_SHORT) {
        const char *ch = name_at(d + SHORT_HEADER, len - SHORT_HEADER, &nb);
        if (ch != NULL)
            g = (udpm_datagram_t){UDPM_MESSAGE, ch, d + SHORT_HEADER + nb, len - SHORT_HEADER - nb};
    } else if (magic == MAGIC_LONG && len >= LONG_HEADER) {
        const uint32_t fragment_no = (uint32_t)d[16] << 8 | d[17];
        if (fragment_no != 0) {
            g.kind = UDPM_IGNORED;
        } else {
            const char *ch = name_at(d + LONG_HEADER, len - LONG_HEADER, &nb);
            if (ch != NULL)
                g = (udpm_datagram_t){UDPM_TOO_LONG, ch, NULL, 0};
        }
    }
    return g;
}

struct udpm_rx {
    int fd;
    uint8_t (*buf)[UDPM_RX_DATAGRAM_MAX]; /* UDPM_RX_BATCH of them */
#if defined(__linux__)
    struct mmsghdr msg[UDPM_RX_BATCH];
    struct iovec iov[UDPM_RX_BATCH];
#endif
};

int udpm_rx_open(uint32_t group, uint32_t port, int rcvbuf, udpm_rx_t **out)
{
    if (out == NULL || port == 0 || port > 65535u || rcvbuf < 0)
        return -EINVAL;
    *out = NULL;
    if ((group >> 28) != 0xEu) {
        fprintf(stderr, "hal_host_net: udpm: %u.%u.%u.%u is not a multicast group (224.0.0.0 to 239.255.255.255)\n",
                (unsigned)(group >> 24), (unsigned)(group >> 16) & 255u, (unsigned)(group >> 8) & 255u,
                (unsigned)group & 255u);
        return -EINVAL;
    }
    udpm_rx_t *r = calloc(1, sizeof *r);
    /* calloc: a buffer's pages are mapped when a datagram first fills them */
    uint8_t(*buf)[UDPM_RX_DATAGRAM_MAX] = calloc(UDPM_RX_BATCH, UDPM_RX_DATAGRAM_MAX);
    if (r == NULL || buf == NULL) {
        free(r);
        free(buf);
        return -ENOMEM;
    }
    r->buf = buf;
    const char *step = "socket";
    const int one = 1;
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port),
                            .sin_addr.s_addr = htonl(INADDR_ANY)};
    struct ip_mreq m = {.imr_multiaddr.s_addr = htonl(group), .imr_interface.s_addr = htonl(INADDR_ANY)};
    r->fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    int ok = r->fd >= 0;
    /* The buffer before the bind: once bound to the port the socket receives the group (Linux
       delivers a group joined by any socket of the host to every socket on its port), and a
       process descheduled between bind and SO_RCVBUF (256 starting on 2 cores) overflowed the
       default 208 KB with the fleet's chunks: the kernel's receive-buffer drops of round 0. */
    if (ok && rcvbuf > 0 && !(ok = setsockopt(r->fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf) == 0))
        step = "SO_RCVBUF";
    if (ok && !(ok = setsockopt(r->fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) == 0))
        step = "SO_REUSEADDR";
    if (ok && !(ok = bind(r->fd, (struct sockaddr *)&a, sizeof a) == 0))
        step = "bind";
    if (ok && !(ok = setsockopt(r->fd, IPPROTO_IP, IP_ADD_MEMBERSHIP, &m, sizeof m) == 0))
        step = "IP_ADD_MEMBERSHIP";
    if (!ok) {
        const int e = errno;
        fprintf(stderr, "hal_host_net: udpm: cannot receive on group %u.%u.%u.%u port %u (%s: %s)\n",
                (unsigned)(group >> 24), (unsigned)(group >> 16) & 255u, (unsigned)(group >> 8) & 255u,
                (unsigned)group & 255u, (unsigned)port, step, strerror(e));
        if (r->fd >= 0)
            close(r->fd);
        free(r->buf);
        free(r);
        return -(e != 0 ? e : EIO);
    }
#if defined(__linux__)
    for (uint32_t i = 0; i < UDPM_RX_BATCH; i++) {
        r->iov[i] = (struct iovec){r->buf[i], UDPM_RX_DATAGRAM_MAX};
        r->msg[i].msg_hdr = (struct msghdr){.msg_iov = &r->iov[i], .msg_iovlen = 1};
    }
#endif
    *out = r;
    return 0;
}

void udpm_rx_close(udpm_rx_t *r)
{
    if (r == NULL)
        return;
    close(r->fd);
    free(r->buf);
    free(r);
}

int udpm_rx_fd(const udpm_rx_t *r)
{
    return r != NULL ? r->fd : -1;
}

size_t udpm_rx_rcvbuf(const udpm_rx_t *r)
{
    int v = 0;
    socklen_t l = sizeof v;
    return r != NULL && getsockopt(r->fd, SOL_SOCKET, SO_RCVBUF, &v, &l) == 0 && v > 0 ? (size_t)v : 0u;
}

/* Up to `want` (<= UDPM_RX_BATCH) datagrams queued on the socket, without waiting: how many, 0
   when none is there, -1 on an error of the socket. Their lengths into len[]. */
static int take_batch(udpm_rx_t *r, size_t *len, uint32_t want)
{
#if defined(__linux__)
    const int got = recvmmsg(r->fd, r->msg, want, MSG_DONTWAIT, NULL);
    for (int i = 0; i < got; i++)
        len[i] = r->msg[i].msg_len;
#else
    int got = 0;
    ssize_t n;
    while (got < (int)want && (n = recv(r->fd, r->buf[got], UDPM_RX_DATAGRAM_MAX, MSG_DONTWAIT)) >= 0)
        len[got++] = (size_t)n;
    if (got == 0)
        got = -1; /* errno is recv's */
#endif
    if (got < 0)
        return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR ? 0 : -1;
    return got;
}

int udpm_rx_take(udpm_rx_t *r, uint32_t max, udpm_rx_fn fn, void *user)
{
    if (r == NULL || fn == NULL)
        return -EINVAL;
    uint32_t total = 0;
    size_t len[UDPM_RX_BATCH];
    while (total < max) {
        const uint32_t want = max - total < UDPM_RX_BATCH ? max - total : UDPM_RX_BATCH;
        const int got = take_batch(r, len, want);
        if (got < 0)
            return -EIO;
        for (int i = 0; i < got; i++) {
            const udpm_datagram_t g = udpm_parse(r->buf[i], len[i]);
            fn(user, &g);
        }
        total += (uint32_t)got;
        if ((uint32_t)got < want) /* nothing more waits */
            break;
    }
    return (int)total;
}

int udpm_rx_drain(udpm_rx_t *r, udpm_rx_fn fn, void *user)
{
    /* Bounded, so that the caller's timers still run. */
    return udpm_rx_take(r, 8u * UDPM_RX_BATCH, fn, user);
}

int udpm_rx_handle(udpm_rx_t *r, int timeout_ms, udpm_rx_fn fn, void *user)
{
    if (r == NULL || fn == NULL)
        return -EINVAL;
    struct pollfd p = {.fd = r->fd, .events = POLLIN};
    const int ready = poll(&p, 1, timeout_ms);
    if (ready < 0)
        return errno == EINTR ? 0 : -EIO;
    return ready == 0 ? 0 : udpm_rx_drain(r, fn, user);
}
