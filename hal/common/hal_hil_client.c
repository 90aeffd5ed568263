/* The board's end of the hardware-in-the-loop link (hal/hal_hil_client.h). */
#include "hal/hal_hil_client.h"

#include "common/le_bytes.h"

#include <errno.h>
#include <string.h>

int hal_hil_client_init(hal_hil_client_t *c, const hal_hil_port_t *port, uint32_t robot, uint32_t rt_period_us,
                        uint32_t session, const char *board, uint32_t timeout_us, uint32_t tries)
{
    if (c == NULL || port == NULL || port->send == NULL || port->recv == NULL || board == NULL ||
        rt_period_us == 0 || timeout_us == 0 || tries == 0)
        return -EINVAL;
    size_t n = 0;
    while (n <= HAL_HIL_BOARD_NAME_BYTES && board[n] != '\0')
        n++;
    if (n == 0 || n > HAL_HIL_BOARD_NAME_BYTES)
        return -EINVAL;
    memset(c, 0, offsetof(hal_hil_client_t, rx));
    c->port = *port;
    c->robot = robot;
    c->rt_period_us = rt_period_us;
    c->session = session;
    c->timeout_us = timeout_us;
    c->tries = tries;
    memcpy(c->board, board, n);
    hal_hil_guard_init(&c->guard);
    hal_hil_stream_init(&c->rx);
    return 0;
}

static int send_frame(hal_hil_client_t *c, hal_hil_type_t type, int len)
{
    if (len < 0)
        return len;
    const int n = hal_hil_encode(c->out, sizeof c->out, type, c->session, ++c->seq, c->payload, (size_t)len);
    if (n < 0)
        return n;
    const int r = c->port.send(c->port.ctx, c->out, (size_t)n);
    if (r == 0)
        c->stats.frames_out++;
    return r;
}

/* The next frame from the world that passes the frame check, within the timeout: 1 and *f
   (valid until the next call), 0 when none came. A port that keeps sending what is refused
   (noise on a serial line) ends the wait after READS_MAX reads, as a timeout. */
#define READS_MAX 64
static int next_frame(hal_hil_client_t *c, hal_hil_frame_t *f)
{
    for (int reads = 0; reads < READS_MAX; reads++) {
        if (c->port.stream) {
            int got = 0;
            c->in_at += hal_hil_stream_feed(&c->rx, c->in + c->in_at, c->in_n - c->in_at, f, &got);
            if (got)
                return 1;
        }
        const int n = c->port.recv(c->port.ctx, c->in, sizeof c->in, c->timeout_us);
        if (n <= 0)
            return n;
        if (c->port.stream) {
            c->in_at = 0;
            c->in_n = (size_t)n;
            continue;
        }
        if (hal_hil_parse(c->in, (size_t)n, f) == HAL_HIL_OK)
            return 1;
        c->stats.refused++;
    }
    return 0;
}

/* A frame from the world that the guard lets through and that is not ours to ignore. */
static int next_accepted(hal_hil_client_t *c, hal_hil_frame_t *f)
{
    for (int k = 0; k < READS_MAX; k++) {
        const int r = next_frame(c, f);
        if (r <= 0)
            return r;
        c->stats.frames_in++;
        const int g = hal_hil_guard_accept(&c->guard, f);
        if (g == 0)
            return 1;
        if (g == -EALREADY)
            c->stats.replayed++;
        else
            c->stats.unopened++;
    }
    return 0;
}

int hal_hil_client_connect(hal_hil_client_t *c)
{
    hal_hil_hello_t h = {.robot = c->robot, .rt_period_us = c->rt_period_us};
    memcpy(h.board, c->board, sizeof h.board);
    for (uint32_t t = 0; t < c->tries; t++) {
        int r = send_frame(c, HAL_HIL_HELLO, hal_hil_put_hello(c->payload, sizeof c->payload, &h));
        if (r != 0)
            return r;
        hal_hil_frame_t f;
        int hello = 0;
        while ((r = next_accepted(c, &f)) == 1) {
            hal_hil_hello_t w;
            if (f.type == HAL_HIL_HELLO && hal_hil_get_hello(&f, &w) == 0 && w.robot == c->robot)
                hello = 1;
            else if (hello && f.type == HAL_HIL_WORLD && hal_hil_get_world(&f, &c->world) == 0)
                return 0;
            else
                c->stats.bad_payload++;
        }
        if (r < 0)
            return r;
    }
    return -ETIMEDOUT;
}

int hal_hil_client_tick(hal_hil_client_t *c, uint64_t t_us)
{
    for (uint32_t t = 0; t < c->tries; t++) {
        if (t > 0)
            c->stats.resent_ticks++;
        const uint32_t most = c->port.answer_datagrams_max;
        const uint32_t room = most != 0 && c->datagram_room > most ? most : c->datagram_room;
        const hal_hil_tick_t tk = {t_us, c->have_scan ? c->scan.stamp_us + 1u : 0u, room};
        int r = send_frame(c, HAL_HIL_TICK, hal_hil_put_tick(c->payload, sizeof c->payload, &tk));
        if (r != 0)
            return r;
        int pose = 0;
        hal_hil_frame_t f;
        /* The answer: a SCAN when the world has a newer one, the fleet's DATAGRAMs, then the
           POSE that ends it (a session's first answer must bring a scan). */
        while (!(pose && c->have_scan) && (r = next_accepted(c, &f)) == 1) {
            if (f.type == HAL_HIL_POSE) {
                hal_pose_t p;
                if (hal_hil_get_pose(&f, &p) != 0)
                    c->stats.bad_payload++;
                else if (p.stamp_us > t_us || (c->have_pose && p.stamp_us < c->pose.stamp_us))
                    c->stats.stale++; /* the answer to another TICK */
                else {
                    c->pose = p;
                    c->have_pose = pose = 1;
                }
            } else if (f.type == HAL_HIL_SCAN) {
                /* its stamp (the first field) read before the whole is decoded */
                if (c->have_scan && f.len >= 8u && le_get_u64(f.payload) <= c->scan.stamp_us)
                    c->stats.stale++; /* one held already: a late answer's */
                else if (hal_hil_get_scan(&f, &c->scan) != 0) /* refused: c->scan untouched */
                    c->stats.bad_payload++;
                else
                    c->have_scan = 1;
            } else if (f.type == HAL_HIL_DATAGRAM) {
                hal_hil_datagram_t d;
                if (hal_hil_get_datagram(&f, &d) != 0) {
                    c->stats.bad_payload++;
                } else {
                    c->stats.datagrams_in++;
                    if (c->on_datagram != NULL)
                        c->on_datagram(c->datagram_ctx, &d);
                }
            } else {
                c->stats.bad_payload++;
            }
        }
        if (r < 0)
            return r;
        if (pose && c->have_scan) {
            c->stats.ticks++;
            return 0;
        }
    }
    return -ETIMEDOUT;
}

int hal_hil_client_wheels(hal_hil_client_t *c, uint64_t t_us, float left_rad_s, float right_rad_s)
{
    const hal_hil_wheels_t w = {t_us, left_rad_s, right_rad_s};
    const int r = send_frame(c, HAL_HIL_WHEELS, hal_hil_put_wheels(c->payload, sizeof c->payload, &w));
    if (r == 0)
        c->stats.wheels++;
    return r;
}

int hal_hil_client_datagram(hal_hil_client_t *c, const char *channel, const void *data, size_t len)
{
    const int n = hal_hil_put_datagram(c->payload, sizeof c->payload, channel, data, len);
    const int r = send_frame(c, HAL_HIL_DATAGRAM, n);
    if (r == 0)
        c->stats.datagrams_out++;
    return r;
}

int hal_hil_client_subscribe(hal_hil_client_t *c, const char *channel)
{
    return send_frame(c, HAL_HIL_SUBSCRIBE, hal_hil_put_subscribe(c->payload, sizeof c->payload, channel));
}
