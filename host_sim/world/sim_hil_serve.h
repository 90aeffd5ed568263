/* host_sim's end of the hardware-in-the-loop link (hal/hal_hil_frame.h, hal_hil_msg.h): one
 * robot's ODE world served to firmware that runs elsewhere (a board, QEMU, another process),
 * over one of three links:
 *   udp     one frame per datagram;
 *   serial  a byte stream, frames back to back: a serial line carried over TCP (QEMU's
 *           `-serial tcp:HOST:PORT`, or a real board's USB serial port through socat). One
 *           board connection at a time; another is refused while it lasts, and when it ends
 *           (the board hung up, or read nothing for 1 s) the server waits for the next;
 *   ether   Ethernet frames, one per UDP datagram (QEMU's `-nic dgram`/`-nic socket,udp=`:
 *           the board's own network interface), of EtherType SIM_HIL_ETHERTYPE, a frame in
 *           each (after the 14-byte header; the padding of short frames is skipped).
 *
 * The board keeps the time. It opens a session (HELLO: the server answers with its own HELLO
 * and WORLD, and from then on talks only to that address), then, each control tick:
 *   TICK t      the server steps the world to t (sim_hal_world's advance: never back, so a TICK
 *               sent again after a lost answer steps nothing) and answers with the latest scan
 *               at t when the board does not hold it (the TICK names the one it holds), then
 *               the latest fix, POSE, which ends the answer;
 *   WHEELS      the command, held from the next step on (zero-order hold, as on the host HAL).
 * So a run's world depends only on the ticks' times and the commands, not on how long the
 * board or the link took: the same firmware gives the same trajectory here as in `host_sim
 * run`, as long as each command reaches the server before the next TICK.
 * Every datagram is checked (frame, session and sequence guard, payload) before anything acts
 * on it; what is refused is counted, and the server goes on. A second HELLO of another session
 * (the board restarted) is taken, from its address.
 * The fleet's datagrams (DATAGRAM, SUBSCRIBE) go through a bridge (sim_hil_bridge_t: the board's
 * network interface on the fleet's transport), when one is given: the board's to the fleet as
 * they come, the fleet's to the board inside TICK answers, up to the room the TICK names.
 * Without one they are counted, not bridged.
 * Every wait is bounded: the server ends when no frame came for idle_timeout_s (0: it served
 * a session and the board went quiet; 1: no board ever said HELLO), or within 100 ms of a stop
 * request (hal_host_stop.h, in its ASK mode). */
#ifndef SIM_HIL_SERVE_H
#define SIM_HIL_SERVE_H

#include <stddef.h>
#include <stdint.h>

#include "hal/hal_hil_msg.h"
#include "sim_hal_world.h"

typedef enum sim_hil_link { SIM_HIL_UDP, SIM_HIL_SERIAL, SIM_HIL_ETHER } sim_hil_link_t;

/* IEEE 802's local experimental EtherType: the link's frames on an Ethernet. */
#define SIM_HIL_ETHERTYPE 0x88B5u

/* The board's network interface on the fleet's transport (sim_hil_bridge.h opens one on LCM). */
typedef struct sim_hil_bridge {
    void *ctx;
    /* The board's datagram to the fleet. 0 or a negative code (counted, the serving goes on). */
    int (*publish)(void *ctx, const char *channel, const void *data, size_t len);
    /* The board listens to `channel` from now on. 0 or a negative code (counted). */
    int (*subscribe)(void *ctx, const char *channel);
    /* The oldest datagram the fleet sent the board, without waiting: its length, its channel
       into channel, the bytes into buf; -EAGAIN when none, or another negative code. */
    int (*receive)(void *ctx, char channel[HAL_NET_CHANNEL_MAX], uint8_t *buf, size_t cap);
} sim_hil_bridge_t;

typedef struct sim_hil_serve_cfg {
    uint32_t robot;           /* the id the board must give in its HELLO */
    sim_hil_link_t link;      /* what fd is: sim_hil_listen's socket for this link */
    hal_hil_world_t world;    /* sent after the HELLO: the plan's box, the physics step, the scan period */
    double idle_timeout_s;    /* > 0 */
    int quiet;                /* no progress lines */
    const sim_hil_bridge_t *bridge; /* NULL: the fleet's datagrams are counted, not bridged */
} sim_hil_serve_cfg_t;

typedef struct sim_hil_serve_stats {
    uint64_t frames_in, frames_out;
    uint64_t ticks, scans, wheels, hellos, datagrams_not_bridged;
    uint64_t to_fleet, to_board, subscriptions, bridge_errors; /* through the bridge */
    uint64_t refused[HAL_HIL_VERDICTS]; /* frames refused by the frame check, by verdict */
    uint64_t replayed, unopened, lost;  /* the session guard's */
    uint64_t bad_payload, wrong_robot, other_sender; /* other_sender: a second stream connection too */
    uint64_t noise_bytes;               /* serial, ether: bytes skipped looking for a frame's start */
    uint64_t not_ours;                  /* ether: datagrams not an Ethernet frame of our EtherType */
    uint64_t t_us;                      /* the world's time */
} sim_hil_serve_stats_t;

/* A UDP socket bound to "HOST:PORT", or (serial) a TCP socket listening there (port 0: any
 * free one); the port it got into *port. The descriptor, or -1 with a message in err. */
int sim_hil_listen(const char *host_port, sim_hil_link_t link, uint16_t *port, char *err, size_t errlen);

/* Serves hw's robot on the bound socket fd until the board goes quiet or a stop is requested.
 * 0 (a session was served), 1 (no board said HELLO), -EINTR (stopped), or another negative
 * code with a message in err (the world failed, the socket failed). */
int sim_hil_serve(sim_hal_world_t *hw, int fd, const sim_hil_serve_cfg_t *cfg, sim_hil_serve_stats_t *st, char *err,
                  size_t errlen);

#endif /* SIM_HIL_SERVE_H */
