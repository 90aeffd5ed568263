/* host_sim's end of the hardware-in-the-loop link: see sim_hil_serve.h. */
#define _DEFAULT_SOURCE 1 /* getaddrinfo */
#include "sim_hil_serve.h"

#include <arpa/inet.h>
#include <errno.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "hal/hal_hil_msg.h"
#include "hal_host_stop.h"

#define PROGRESS_EVERY_US 10000000u /* a progress line per 10 simulated seconds */

int sim_hil_listen(const char *host_port, uint16_t *port, char *err, size_t errlen)
{
    char host[256];
    uint32_t p = 0;
    if (hal_hil_split_address(host_port, host, sizeof host, &p) != 0) {
        snprintf(err, errlen, "'%s' is not HOST:PORT (e.g. 127.0.0.1:7800, port 0 for any free one)",
                 host_port != NULL ? host_port : "");
        return -1;
    }
    struct addrinfo hints = {.ai_family = AF_INET, .ai_socktype = SOCK_DGRAM, .ai_flags = AI_PASSIVE}, *ai = NULL;
    const int g = getaddrinfo(host, NULL, &hints, &ai);
    if (g != 0) {
        snprintf(err, errlen, "cannot resolve '%s': %s", host, gai_strerror(g));
        return -1;
    }
    struct sockaddr_in a;
    memcpy(&a, ai->ai_addr, sizeof a);
    freeaddrinfo(ai);
    a.sin_port = htons((uint16_t)p);
    const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    socklen_t al = sizeof a;
    if (fd < 0 || bind(fd, (const struct sockaddr *)&a, sizeof a) != 0 ||
        getsockname(fd, (struct sockaddr *)&a, &al) != 0) {
        snprintf(err, errlen, "cannot bind udp %s: %s", host_port, strerror(errno));
        if (fd >= 0)
            close(fd);
        return -1;
    }
    *port = ntohs(a.sin_port);
    return fd;
}

/* One server: the socket, the board's address and session, the frames it sends. */
typedef struct server {
    int fd;
    sim_hal_world_t *hw;
    const hal_host_world_t *ops;
    const sim_hil_serve_cfg_t *cfg;
    sim_hil_serve_stats_t *st;
    hal_hil_guard_t guard;
    struct sockaddr_in peer;
    int have_peer;
    uint32_t session, seq;
    uint64_t world_us, next_progress_us;
    uint8_t payload[HAL_HIL_PAYLOAD_MAX];
    uint8_t out[HAL_HIL_FRAME_MAX];
    uint8_t in[HAL_HIL_FRAME_MAX + 1]; /* one more: a datagram longer than any frame is seen */
    hal_lidar_scan_t scan;
} server_t;

static int send_frame(server_t *s, hal_hil_type_t type, int len)
{
    if (len < 0)
        return len;
    const int n = hal_hil_encode(s->out, sizeof s->out, type, s->session, ++s->seq, s->payload, (size_t)len);
    if (n < 0)
        return n;
    if (sendto(s->fd, s->out, (size_t)n, 0, (const struct sockaddr *)&s->peer, sizeof s->peer) != n)
        return -errno;
    s->st->frames_out++;
    return 0;
}

/* The world to t (never back), then the latest fix and scan to the board. */
static int on_tick(server_t *s, uint64_t t_us, char *err, size_t errlen)
{
    if (t_us > s->world_us) {
        const int r = s->ops->advance_to_us(s->ops->ctx, t_us);
        if (r != 0) {
            snprintf(err, errlen, "the world failed stepping to %.3f s (%d)", (double)t_us * 1e-6, r);
            return r;
        }
        s->world_us = t_us;
    }
    hal_pose_t pose;
    int r = s->ops->read_pose(s->ops->ctx, s->cfg->robot, &pose);
    if (r == 0)
        r = send_frame(s, HAL_HIL_POSE, hal_hil_put_pose(s->payload, sizeof s->payload, &pose));
    if (r == 0)
        r = s->ops->read_scan(s->ops->ctx, s->cfg->robot, &s->scan);
    if (r == 0)
        r = send_frame(s, HAL_HIL_SCAN, hal_hil_put_scan(s->payload, sizeof s->payload, &s->scan));
    if (r != 0)
        snprintf(err, errlen, "cannot send the sensors at %.3f s (%d)", (double)t_us * 1e-6, r);
    s->st->ticks++;
    s->st->t_us = s->world_us;
    if (!s->cfg->quiet && s->world_us >= s->next_progress_us) {
        sim_hal_world_stats_t ws;
        sim_hal_world_get_stats(s->hw, &ws);
        fprintf(stderr, "hil: t=%7.1f s  ticks %llu  wheel commands %llu  distance %.2f m  frames in %llu out %llu\n",
                (double)s->world_us * 1e-6, (unsigned long long)s->st->ticks, (unsigned long long)s->st->wheels,
                ws.distance_m, (unsigned long long)s->st->frames_in, (unsigned long long)s->st->frames_out);
        s->next_progress_us = s->world_us + PROGRESS_EVERY_US;
    }
    return r;
}

static int on_hello(server_t *s, const hal_hil_frame_t *f, const struct sockaddr_in *from)
{
    hal_hil_hello_t h;
    if (hal_hil_get_hello(f, &h) != 0) {
        s->st->bad_payload++;
        return 0;
    }
    if (h.robot != s->cfg->robot) {
        s->st->wrong_robot++;
        return 0;
    }
    if (hal_hil_guard_accept(&s->guard, f) != 0)
        return 0; /* this session's HELLO again: counted by the guard */
    s->peer = *from;
    s->have_peer = 1;
    s->st->hellos++;
    if (!s->cfg->quiet)
        fprintf(stderr, "hil: board '%s' (robot %u, session %08x) at %s:%u\n", h.board, h.robot, f->session,
                inet_ntoa(from->sin_addr), (unsigned)ntohs(from->sin_port));
    const hal_hil_hello_t mine = {s->cfg->robot, 1, "host_sim"};
    const int r = send_frame(s, HAL_HIL_HELLO, hal_hil_put_hello(s->payload, sizeof s->payload, &mine));
    return r != 0 ? r : send_frame(s, HAL_HIL_WORLD, hal_hil_put_world(s->payload, sizeof s->payload, &s->cfg->world));
}

/* One datagram: checked, then acted on. 0, or a negative code that ends the server. */
static int on_datagram(server_t *s, size_t n, const struct sockaddr_in *from, char *err, size_t errlen)
{
    hal_hil_frame_t f;
    const hal_hil_verdict_t v = hal_hil_parse(s->in, n, &f);
    if (v != HAL_HIL_OK) {
        s->st->refused[v]++;
        return 0;
    }
    s->st->frames_in++;
    if (f.type == HAL_HIL_HELLO)
        return on_hello(s, &f, from);
    if (!s->have_peer || from->sin_addr.s_addr != s->peer.sin_addr.s_addr || from->sin_port != s->peer.sin_port) {
        s->st->other_sender++;
        return 0;
    }
    if (hal_hil_guard_accept(&s->guard, &f) != 0)
        return 0;
    switch (f.type) {
    case HAL_HIL_TICK: {
        uint64_t t = 0;
        if (hal_hil_get_tick(&f, &t) != 0) {
            s->st->bad_payload++;
            return 0;
        }
        return on_tick(s, t, err, errlen);
    }
    case HAL_HIL_WHEELS: {
        hal_hil_wheels_t w;
        if (hal_hil_get_wheels(&f, &w) != 0) {
            s->st->bad_payload++;
            return 0;
        }
        s->st->wheels++;
        const int r = s->ops->set_wheels(s->ops->ctx, s->cfg->robot, w.left_rad_s, w.right_rad_s);
        if (r != 0)
            snprintf(err, errlen, "the world refused a wheel command (%d)", r);
        return r;
    }
    case HAL_HIL_DATAGRAM:
        s->st->datagrams_not_bridged++;
        return 0;
    default: /* SCAN, POSE: the board has none to send */
        s->st->bad_payload++;
        return 0;
    }
}

static uint32_t session_id(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint32_t)ts.tv_nsec ^ (uint32_t)ts.tv_sec * 2654435761u ^ (uint32_t)getpid();
}

int sim_hil_serve(sim_hal_world_t *hw, int fd, const sim_hil_serve_cfg_t *cfg, sim_hil_serve_stats_t *st, char *err,
                  size_t errlen)
{
    static server_t s; /* 120 KB of frames: not on the stack */
    memset(&s, 0, sizeof s);
    memset(st, 0, sizeof *st);
    s.fd = fd;
    s.hw = hw;
    s.ops = sim_hal_world_ops(hw);
    s.cfg = cfg;
    s.st = st;
    s.session = session_id();
    hal_hil_guard_init(&s.guard);
    const int idle_ms = (int)(cfg->idle_timeout_s * 1000.0);
    for (;;) {
        struct pollfd p = {.fd = fd, .events = POLLIN};
        int waited = 0, r = 0;
        /* Wait in slices, so a stop request is seen within 100 ms. */
        while ((r = poll(&p, 1, 100)) == 0 && waited < idle_ms && hal_host_stop_signal() == 0)
            waited += 100;
        if (r < 0 && errno != EINTR) {
            snprintf(err, errlen, "waiting on the socket: %s", strerror(errno));
            return -EIO;
        }
        if (hal_host_stop_signal() != 0)
            return -EINTR;
        if (r == 0) {
            if (!cfg->quiet)
                fprintf(stderr, "hil: no frame for %g s: %s\n", cfg->idle_timeout_s,
                        st->hellos > 0 ? "the board went quiet, done" : "no board said HELLO");
            return st->hellos > 0 ? 0 : 1;
        }
        if (r < 0)
            continue;
        struct sockaddr_in from;
        socklen_t fl = sizeof from;
        const ssize_t n = recvfrom(fd, s.in, sizeof s.in, 0, (struct sockaddr *)&from, &fl);
        if (n < 0) {
            if (errno == EINTR || errno == EAGAIN)
                continue;
            snprintf(err, errlen, "receiving: %s", strerror(errno));
            return -EIO;
        }
        if (fl != sizeof from || from.sin_family != AF_INET)
            continue;
        if ((size_t)n > HAL_HIL_FRAME_MAX) {
            st->refused[HAL_HIL_OVERSIZED]++;
            continue;
        }
        const int rc = on_datagram(&s, (size_t)n, &from, err, errlen);
        st->replayed = s.guard.replayed;
        st->unopened = s.guard.unopened;
        st->lost = s.guard.lost;
        if (rc != 0)
            return rc;
    }
}
