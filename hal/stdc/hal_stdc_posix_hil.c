/* The hardware-in-the-loop link's UDP port on a Linux board (hal_stdc_hil.h): one connected
 * datagram socket, one frame per datagram. The address is numeric (IPv4): a board's image is
 * linked statically, and name lookup would need the C library's shared modules at run time. */
#define _DEFAULT_SOURCE 1
#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdio.h>
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

const char *hal_stdc_hil_kind(void)
{
    return "udp";
}

int hal_stdc_hil_open(const char *host_port, hal_hil_port_t *port)
{
    static int fd_held; /* the port's context: one link per board */
    char host[INET_ADDRSTRLEN];
    uint32_t p = 0;
    struct sockaddr_in a = {.sin_family = AF_INET};
    if (hal_hil_split_address(host_port, host, sizeof host, &p) != 0 || p == 0) {
        fprintf(stderr, "hil: '%s' is not A.B.C.D:PORT (the address `host_sim hil --listen` gives)\n",
                host_port != NULL ? host_port : "");
        return -EINVAL;
    }
    if (inet_pton(AF_INET, host, &a.sin_addr) != 1) {
        fprintf(stderr, "hil: '%s' is not an IPv4 address (a board connects to a number, not a name)\n", host);
        return -EINVAL;
    }
    a.sin_port = htons((uint16_t)p);
    const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    if (fd < 0 || connect(fd, (const struct sockaddr *)&a, sizeof a) != 0) {
        fprintf(stderr, "hil: cannot reach udp %s: %s\n", host_port, strerror(errno));
        if (fd >= 0)
            close(fd);
        return -EIO;
    }
    fd_held = fd;
    *port = (hal_hil_port_t){.ctx = &fd_held, .stream = 0, .send = udp_send, .recv = udp_recv};
    return 0;
}
