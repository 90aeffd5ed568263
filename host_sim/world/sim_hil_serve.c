/* host_sim's end of the hardware-in-the-loop link: see sim_hil_serve.h. */
#define _GNU_SOURCE 1 /* getaddrinfo, accept4 */
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

int sim_hil_listen(const char *host_port, sim_hil_link_t link, uint16_t *port, char *err, size_t errlen)
{
    const int stream = link == SIM_HIL_SERIAL;
    char host[256];
    uint32_t p = 0;
    if (hal_hil_split_address(host_port, host, sizeof host, &p) != 0) {
        snprintf(err, errlen, "'%s' is not HOST:PORT (e.g. 127.0.0.1:7800, port 0 for any free one)",
                 host_port != NULL ? host_port : "");
        return -1;
    }
    const int type = stream ? SOCK_STREAM : SOCK_DGRAM;
    struct addrinfo hints = {.ai_family = AF_INET, .ai_socktype = type, .ai_flags = AI_PASSIVE}, *ai = NULL;
    const int g = getaddrinfo(host, NULL, &hints, &ai);
    if (g != 0) {
        snprintf(err, errlen, "cannot resolve '%s': %s", host, gai_strerror(g));
        return -1;
    }
    struct sockaddr_in a;
    memcpy(&a, ai->ai_addr, sizeof a);
    freeaddrinfo(ai);
    a.sin_port = htons((uint16_t)p);
    const int fd = socket(AF_INET, type | SOCK_CLOEXEC, 0);
    const int one = 1;
    socklen_t al = sizeof a;
    if (fd < 0 || (stream && setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) != 0) ||
        bind(fd, (const struct sockaddr *)&a, sizeof a) != 0 || (stream && listen(fd, 1) != 0) ||
        getsockname(fd, (struct sockaddr *)&a, &al) != 0) {
        snprintf(err, errlen, "cannot %s %s %s: %s", stream ? "listen on" : "bind", stream ? "tcp" : "udp", host_port,
                 strerror(errno));
        if (fd >= 0)
            close(fd);
        return -1;
    }
    *port = ntohs(a.sin_port);
    return fd;
}

#define ETHER_HEADER 14u
#define ETHER_MIN_FRAME 60u /* without the FCS: shorter frames are padded */

/* One server: the socket, the board's address and session, the frames it sends. On a stream
   link, the board's connection and the reader that cuts its bytes into frames. */
typedef struct server {
    int fd, conn;
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
    uint8_t in[ETHER_HEADER + HAL_HIL_FRAME_MAX + 1]; /* one more: a datagram longer than any frame is seen */
    hal_lidar_scan_t scan;
    hal_hil_stream_t rx;
    uint8_t board_mac[6];              /* ether: the board's interface, the answers' destination */
    uint8_t sender_mac[6];             /* ether: the source of the frame being read */
} server_t;

/* ether: the world's own address (locally administered). */
static const uint8_t world_mac[6] = {0x02, 0x00, 0x00, 0x00, 0x00, 0x01};

#define STREAM_SEND_TIMEOUT_MS 1000 /* a board that reads nothing for this long has gone */

/* The board's connection is gone (it hung up, or stopped reading): the server waits for the
   next one. A frame begun and not finished is counted truncated. */
static void drop_connection(server_t *s, const char *why)
{
    if (s->conn < 0)
        return;
    close(s->conn);
    s->conn = -1;
    s->have_peer = 0;
    hal_hil_stream_idle(&s->rx);
    if (!s->cfg->quiet)
        fprintf(stderr, "hil: the board's connection closed (%s)\n", why);
}

/* A whole frame onto the stream, within STREAM_SEND_TIMEOUT_MS. 0, or -EPIPE (dropped). */
static int stream_write(server_t *s, const uint8_t *b, size_t n)
{
    while (n > 0 && s->conn >= 0) {
        struct pollfd p = {.fd = s->conn, .events = POLLOUT};
        const int r = poll(&p, 1, STREAM_SEND_TIMEOUT_MS);
        if (r < 0 && errno == EINTR)
            continue;
        const ssize_t w = r > 0 ? send(s->conn, b, n, MSG_NOSIGNAL) : -1;
        if (w < 0 && (errno == EINTR || errno == EAGAIN))
            continue;
        if (w <= 0) {
            drop_connection(s, r == 0 ? "it read nothing for 1 s" : strerror(errno));
            return -EPIPE;
        }
        b += w;
        n -= (size_t)w;
    }
    return s->conn >= 0 ? 0 : -EPIPE;
}

static int send_frame(server_t *s, hal_hil_type_t type, int len)
{
    if (len < 0)
        return len;
    const int n = hal_hil_encode(s->out, sizeof s->out, type, s->session, ++s->seq, s->payload, (size_t)len);
    if (n < 0)
        return n;
    if (s->cfg->link == SIM_HIL_SERIAL) {
        if (stream_write(s, s->out, (size_t)n) != 0)
            return 0; /* the board is gone, not the world: the next connection goes on */
    } else if (s->cfg->link == SIM_HIL_ETHER) {
        static uint8_t eth[ETHER_HEADER + HAL_HIL_FRAME_MAX + ETHER_MIN_FRAME];
        memcpy(eth, s->board_mac, 6);
        memcpy(eth + 6, world_mac, 6);
        eth[12] = (uint8_t)(SIM_HIL_ETHERTYPE >> 8);
        eth[13] = (uint8_t)SIM_HIL_ETHERTYPE;
        memcpy(eth + ETHER_HEADER, s->out, (size_t)n);
        size_t len = ETHER_HEADER + (size_t)n;
        for (; len < ETHER_MIN_FRAME; len++)
            eth[len] = 0;
        if (sendto(s->fd, eth, len, 0, (const struct sockaddr *)&s->peer, sizeof s->peer) != (ssize_t)len)
            return -errno;
    } else if (sendto(s->fd, s->out, (size_t)n, 0, (const struct sockaddr *)&s->peer, sizeof s->peer) != n) {
        return -errno;
    }
    s->st->frames_out++;
    return 0;
}

/* The world to t (never back), then the latest scan when the board does not hold it, then the
   latest fix, which ends the answer. */
static int on_tick(server_t *s, uint64_t t_us, uint64_t scan_held, uint32_t room, char *err, size_t errlen)
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
    int r = s->ops->read_scan(s->ops->ctx, s->cfg->robot, &s->scan);
    if (r == 0 && s->scan.stamp_us + 1u != scan_held) {
        r = send_frame(s, HAL_HIL_SCAN, hal_hil_put_scan(s->payload, sizeof s->payload, &s->scan));
        s->st->scans++;
    }
    /* The fleet's datagrams for the board, as many as it has room for. */
    const sim_hil_bridge_t *br = s->cfg->bridge;
    for (uint32_t k = 0; r == 0 && br != NULL && k < room; k++) {
        static char ch[HAL_NET_CHANNEL_MAX];
        static uint8_t data[HAL_NET_MTU_BYTES];
        const int n = br->receive(br->ctx, ch, data, sizeof data);
        if (n < 0) {
            if (n != -EAGAIN)
                s->st->bridge_errors++;
            break;
        }
        r = send_frame(s, HAL_HIL_DATAGRAM, hal_hil_put_datagram(s->payload, sizeof s->payload, ch, data, (size_t)n));
        s->st->to_board++;
    }
    if (r == 0)
        r = s->ops->read_pose(s->ops->ctx, s->cfg->robot, &pose);
    if (r == 0)
        r = send_frame(s, HAL_HIL_POSE, hal_hil_put_pose(s->payload, sizeof s->payload, &pose));
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
    memcpy(s->board_mac, s->sender_mac, 6);
    s->st->hellos++;
    if (!s->cfg->quiet)
        fprintf(stderr, "hil: board '%s' (robot %u, session %08x) at %s:%u\n", h.board, h.robot, f->session,
                inet_ntoa(from->sin_addr), (unsigned)ntohs(from->sin_port));
    const hal_hil_hello_t mine = {s->cfg->robot, 1, "host_sim"};
    const int r = send_frame(s, HAL_HIL_HELLO, hal_hil_put_hello(s->payload, sizeof s->payload, &mine));
    return r != 0 ? r : send_frame(s, HAL_HIL_WORLD, hal_hil_put_world(s->payload, sizeof s->payload, &s->cfg->world));
}

/* One frame that passed the frame check, from `from`: acted on. 0, or a negative code that ends
   the server. */
static int on_frame(server_t *s, const hal_hil_frame_t *fp, const struct sockaddr_in *from, char *err, size_t errlen)
{
    const hal_hil_frame_t f = *fp;
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
        hal_hil_tick_t tk;
        if (hal_hil_get_tick(&f, &tk) != 0) {
            s->st->bad_payload++;
            return 0;
        }
        return on_tick(s, tk.stamp_us, tk.scan_held, tk.datagram_room, err, errlen);
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
    case HAL_HIL_DATAGRAM: {
        hal_hil_datagram_t d;
        if (hal_hil_get_datagram(&f, &d) != 0)
            s->st->bad_payload++;
        else if (s->cfg->bridge == NULL)
            s->st->datagrams_not_bridged++;
        else if (s->cfg->bridge->publish(s->cfg->bridge->ctx, d.channel, d.data, d.len) != 0)
            s->st->bridge_errors++;
        else
            s->st->to_fleet++;
        return 0;
    }
    case HAL_HIL_SUBSCRIBE: {
        char ch[HAL_NET_CHANNEL_MAX];
        if (hal_hil_get_subscribe(&f, ch) != 0)
            s->st->bad_payload++;
        else if (s->cfg->bridge == NULL)
            s->st->datagrams_not_bridged++;
        else if (s->cfg->bridge->subscribe(s->cfg->bridge->ctx, ch) != 0)
            s->st->bridge_errors++;
        else
            s->st->subscriptions++;
        return 0;
    }
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

/* A datagram: the frame check, then the frame. */
static int on_datagram(server_t *s, size_t n, const struct sockaddr_in *from, char *err, size_t errlen)
{
    if (n > HAL_HIL_FRAME_MAX) {
        s->st->refused[HAL_HIL_OVERSIZED]++;
        return 0;
    }
    hal_hil_frame_t f;
    const hal_hil_verdict_t v = hal_hil_parse(s->in, n, &f);
    if (v != HAL_HIL_OK) {
        s->st->refused[v]++;
        return 0;
    }
    return on_frame(s, &f, from, err, errlen);
}

/* A stream's bytes (or an Ethernet frame's payload): every frame they finish (the reader counts
   what it refuses). */
static int on_bytes(server_t *s, const uint8_t *bytes, size_t n, const struct sockaddr_in *from, char *err,
                    size_t errlen)
{
    size_t at = 0;
    int r = 0;
    while (at < n && r == 0 && (s->conn >= 0 || s->cfg->link != SIM_HIL_SERIAL)) {
        hal_hil_frame_t f;
        int got = 0;
        at += hal_hil_stream_feed(&s->rx, bytes + at, n - at, &f, &got);
        if (got)
            r = on_frame(s, &f, from, err, errlen);
    }
    memcpy(s->st->refused, s->rx.refused, sizeof s->st->refused);
    s->st->noise_bytes = s->rx.skipped;
    return r;
}

/* An Ethernet frame in a datagram: ours (our EtherType, from a board's unicast address) goes
   to the reader; the board's address is kept for the answers once its HELLO is taken. */
static int on_ether(server_t *s, size_t n, const struct sockaddr_in *from, char *err, size_t errlen)
{
    const uint8_t *e = s->in;
    if (n < ETHER_HEADER || (((unsigned)e[12] << 8) | e[13]) != SIM_HIL_ETHERTYPE || (e[6] & 1u)) {
        s->st->not_ours++;
        return 0;
    }
    memcpy(s->sender_mac, e + 6, 6); /* a HELLO in it makes it the board's */
    size_t len = n - ETHER_HEADER;
    const uint8_t *p = e + ETHER_HEADER;
    if (len >= HAL_HIL_HEADER_BYTES && p[0] == HAL_HIL_MAGIC0 && p[1] == HAL_HIL_MAGIC1) {
        const size_t whole = HAL_HIL_OVERHEAD_BYTES + ((size_t)p[12] | (size_t)p[13] << 8);
        if (whole < len)
            len = whole; /* a short frame's padding is not noise */
    }
    const int r = on_bytes(s, p, len, from, err, errlen);
    hal_hil_stream_idle(&s->rx); /* a frame never spans two Ethernet frames */
    return r;
}

/* A board connects (stream link): taken when none is connected; a second one is refused. */
static void on_connect(server_t *s, struct sockaddr_in *board)
{
    struct sockaddr_in a;
    socklen_t al = sizeof a;
    const int c = accept4(s->fd, (struct sockaddr *)&a, &al, SOCK_CLOEXEC);
    if (c < 0)
        return;
    if (s->conn >= 0) {
        close(c);
        s->st->other_sender++;
        return;
    }
    s->conn = c;
    *board = a;
    s->have_peer = 0; /* until its HELLO */
    if (!s->cfg->quiet)
        fprintf(stderr, "hil: a board connected from %s:%u\n", inet_ntoa(board->sin_addr),
                (unsigned)ntohs(board->sin_port));
}

int sim_hil_serve(sim_hal_world_t *hw, int fd, const sim_hil_serve_cfg_t *cfg, sim_hil_serve_stats_t *st, char *err,
                  size_t errlen)
{
    static server_t s; /* 120 KB of frames: not on the stack */
    memset(&s, 0, sizeof s);
    memset(st, 0, sizeof *st);
    s.fd = fd;
    s.conn = -1;
    s.hw = hw;
    s.ops = sim_hal_world_ops(hw);
    s.cfg = cfg;
    s.st = st;
    s.session = session_id();
    hal_hil_guard_init(&s.guard);
    hal_hil_stream_init(&s.rx);
    struct sockaddr_in board = {0}; /* a stream's board: its frames' sender */
    const int idle_ms = (int)(cfg->idle_timeout_s * 1000.0);
    int rc = 0;
    while (rc == 0) {
        struct pollfd p[2] = {{.fd = fd, .events = POLLIN}, {.fd = s.conn, .events = POLLIN}};
        const nfds_t np = s.conn >= 0 ? 2 : 1;
        int waited = 0, r = 0;
        /* Wait in slices, so a stop request is seen within 100 ms. */
        while ((r = poll(p, np, 100)) == 0 && waited < idle_ms && hal_host_stop_signal() == 0)
            waited += 100;
        if (r < 0 && errno != EINTR) {
            snprintf(err, errlen, "waiting on the socket: %s", strerror(errno));
            rc = -EIO;
            break;
        }
        if (hal_host_stop_signal() != 0) {
            rc = -EINTR;
            break;
        }
        if (r == 0) {
            if (!cfg->quiet)
                fprintf(stderr, "hil: no frame for %g s: %s\n", cfg->idle_timeout_s,
                        st->hellos > 0 ? "the board went quiet, done" : "no board said HELLO");
            rc = st->hellos > 0 ? 0 : 1;
            break;
        }
        if (r < 0)
            continue;
        const int serial = cfg->link == SIM_HIL_SERIAL;
        if (serial && np == 2 && (p[1].revents & (POLLIN | POLLHUP | POLLERR))) {
            const ssize_t n = recv(s.conn, s.in, sizeof s.in, 0);
            if (n > 0)
                rc = on_bytes(&s, s.in, (size_t)n, &board, err, errlen);
            else if (n == 0 || (errno != EINTR && errno != EAGAIN))
                drop_connection(&s, n == 0 ? "it hung up" : strerror(errno));
        }
        if (serial && (p[0].revents & POLLIN)) /* after a hang-up seen in the same wait */
            on_connect(&s, &board);
        if (!serial && (p[0].revents & POLLIN)) {
            struct sockaddr_in from;
            socklen_t fl = sizeof from;
            const ssize_t n = recvfrom(fd, s.in, sizeof s.in, 0, (struct sockaddr *)&from, &fl);
            if (n < 0 && errno != EINTR && errno != EAGAIN) {
                snprintf(err, errlen, "receiving: %s", strerror(errno));
                rc = -EIO;
            } else if (n >= 0 && fl == sizeof from && from.sin_family == AF_INET) {
                rc = cfg->link == SIM_HIL_ETHER ? on_ether(&s, (size_t)n, &from, err, errlen)
                                                : on_datagram(&s, (size_t)n, &from, err, errlen);
            }
        }
        st->replayed = s.guard.replayed;
        st->unopened = s.guard.unopened;
        st->lost = s.guard.lost;
    }
    if (s.conn >= 0)
        close(s.conn);
    return rc;
}
