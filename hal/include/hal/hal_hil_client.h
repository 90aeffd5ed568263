/* The board's end of the hardware-in-the-loop link (the world's end: host_sim hil): a robot
 * whose RT core runs on a board reads its lidar and pose from, and sends its wheel commands
 * to, the world of a host_sim on the other end of a UDP socket or a serial line.
 *
 * The board keeps the time. hal_hil_client_tick(t) sends TICK t, naming the scan it holds; the
 * world steps to t, and the client waits for the answer (a SCAN when the world has a newer one,
 * then the POSE), sending TICK again (a new frame) when it does not come within the timeout, up
 * to `tries` times. Wheel commands go out as they are given.
 * Every frame that comes in passes the frame check, the session and sequence guard and its
 * payload's check before it is used; a pose older than the one held is stale (a late answer to
 * an earlier TICK) and dropped.
 * Pure C, no allocation: the I/O is the port's (hal_hil_port_t), the time the caller's. */
#ifndef HAL_HIL_CLIENT_H
#define HAL_HIL_CLIENT_H

#include "hal/hal_hil_msg.h"

/* How the bytes move: a datagram socket (one frame per call) or a byte stream. */
typedef struct hal_hil_port {
    void *ctx;
    int stream; /* 1: recv returns any bytes of a stream; 0: one datagram (a whole frame) */
    /* Sends one whole frame. 0 or a negative errno code. */
    int (*send)(void *ctx, const uint8_t *bytes, size_t n);
    /* What arrives within timeout_us, into buf: the count, 0 when nothing came, or a negative
       errno code. */
    int (*recv)(void *ctx, uint8_t *buf, size_t cap, uint32_t timeout_us);
    /* The most fleet datagrams one answer may bring beside its SCAN and POSE (0: no limit): a
       receiver that drops what overflows its buffer before the board reads it (an Ethernet
       controller's receive FIFO) names what it holds, and every TICK asks for no more. */
    uint32_t answer_datagrams_max;
} hal_hil_port_t;

typedef struct hal_hil_client_stats {
    uint64_t ticks, resent_ticks, wheels, frames_in, frames_out;
    uint64_t datagrams_in, datagrams_out;
    uint64_t refused, replayed, unopened, bad_payload, stale;
} hal_hil_client_stats_t;

typedef struct hal_hil_client {
    hal_hil_port_t port;
    uint32_t robot, rt_period_us, session, seq;
    uint32_t timeout_us, tries;
    char board[HAL_HIL_BOARD_NAME_BYTES + 1u];
    hal_hil_guard_t guard;
    hal_hil_world_t world;              /* from the world's WORLD frame (connect) */
    /* The fleet's datagrams in a TICK's answer go to on_datagram (the data valid during the
       call); datagram_room, sent in each TICK (never above the port's answer_datagrams_max),
       says how many the board can take (0: none). */
    void (*on_datagram)(void *ctx, const hal_hil_datagram_t *d);
    void *datagram_ctx;
    uint32_t datagram_room;
    int have_pose, have_scan;
    hal_pose_t pose;
    hal_lidar_scan_t scan;
    hal_hil_client_stats_t stats;
    hal_hil_stream_t rx;                /* a stream port's reader */
    size_t in_at, in_n;                 /* a stream's bytes received, not yet read: in[in_at..in_n) */
    uint8_t in[HAL_HIL_FRAME_MAX];      /* a datagram port's frame, or a stream's bytes */
    uint8_t out[HAL_HIL_FRAME_MAX];
    uint8_t payload[HAL_HIL_PAYLOAD_MAX];
} hal_hil_client_t;

/* Sets the client up (nothing sent). session: this run's (a restarted board must choose
 * another); board: its name for the HELLO (printable, 1..16 characters). 0 or -EINVAL. */
int hal_hil_client_init(hal_hil_client_t *c, const hal_hil_port_t *port, uint32_t robot, uint32_t rt_period_us,
                        uint32_t session, const char *board, uint32_t timeout_us, uint32_t tries);

/* HELLO, until the world answers with its HELLO and WORLD (into c->world), tries x timeout at
 * most. 0, -ETIMEDOUT, or the port's error. */
int hal_hil_client_connect(hal_hil_client_t *c);

/* TICK t_us, and the answer into c->pose and (when the world has a newer one) c->scan. 0, -ETIMEDOUT (no
 * answer after `tries` TICKs), or the port's error. */
int hal_hil_client_tick(hal_hil_client_t *c, uint64_t t_us);

/* A wheel command (rad/s), stamped t_us. 0, -EINVAL (not finite), or the port's error. */
int hal_hil_client_wheels(hal_hil_client_t *c, uint64_t t_us, float left_rad_s, float right_rad_s);

/* A datagram to the fleet on `channel`, through the world. 0, -EINVAL (a bad channel),
 * -EMSGSIZE (over HAL_NET_MTU_BYTES), or the port's error. */
int hal_hil_client_datagram(hal_hil_client_t *c, const char *channel, const void *data, size_t len);

/* Asks the world to bring this fleet channel's datagrams to the board. 0, -EINVAL, or the
 * port's error. */
int hal_hil_client_subscribe(hal_hil_client_t *c, const char *channel);

#endif /* HAL_HIL_CLIENT_H */
