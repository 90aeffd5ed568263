/* The hardware-in-the-loop link's UDP port on a Linux board (hal_stdc_hil.h): one connected
 * datagram socket, one frame per datagram. */
#define _DEFAULT_SOURCE 1 /* getaddrinfo */
#include <errno.h>
#include <netdb.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "hal_stdc_hil.h"

static int udp_send(void *ctx, const uint8_t *bytes, size_t n)
{
    const int fd = *(const int *)ctx;
    const ssize_t w = send(fd, bytes, n, 0);
    if (w == (ssize_t)n)
        return 0;
    /* The world not listening (yet, or any more): a lost datagram, which the TICK's retry
       covers, not a broken board. */
    return w < 0 && errno == ECONNREFUSED ? 0 : -EIO;
}

static int udp_recv(void *ctx, uint8_t *buf, size_t cap, uint32_t timeout_us)
{
    const int fd = *(const int *)ctx;
    struct pollfd p = {.fd = fd, .events = POLLIN};
    const int r = poll(&p, 1, (int)((timeout_us + 999u) / 1000u));
    if (r == 0)
        return 0;
    if (r < 0)
        return errno == EINTR ? 0 : -EIO;
    const ssize_t n = recv(fd, buf, cap, 0);
    if (n < 0)
        return errno == ECONNREFUSED || errno == EINTR || errno == EAGAIN ? 0 : -EIO;
    return (int)n;
}

int hal_stdc_hil_udp_open(const char *host_port, hal_hil_port_t *port, int *fd_out)
{
    char host[256];
    const char *colon = host_port != NULL ? strrchr(host_port, ':') : NULL;
    if (colon == NULL || colon == host_port || (size_t)(colon - host_port) >= sizeof host || colon[1] == '\0') {
        fprintf(stderr, "hil: '%s' is not HOST:PORT (the address `host_sim hil --listen` gives)\n",
                host_port != NULL ? host_port : "");
        return -EINVAL;
    }
    memcpy(host, host_port, (size_t)(colon - host_port));
    host[colon - host_port] = '\0';
    struct addrinfo hints = {.ai_family = AF_INET, .ai_socktype = SOCK_DGRAM}, *ai = NULL;
    const int g = getaddrinfo(host, colon + 1, &hints, &ai);
    if (g != 0) {
        fprintf(stderr, "hil: cannot resolve '%s': %s\n", host_port, gai_strerror(g));
        return -EINVAL;
    }
    const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    if (fd < 0 || connect(fd, ai->ai_addr, ai->ai_addrlen) != 0) {
        fprintf(stderr, "hil: cannot reach udp %s: %s\n", host_port, strerror(errno));
        if (fd >= 0)
            close(fd);
        freeaddrinfo(ai);
        return -EIO;
    }
    freeaddrinfo(ai);
    *fd_out = fd;
    *port = (hal_hil_port_t){.ctx = fd_out, .stream = 0, .send = udp_send, .recv = udp_recv};
    return 0;
}
