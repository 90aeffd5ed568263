/* The "stdc" HAL back end: a board built on the C standard library alone, for targets where
 * the firmware runs as one program on one thread: a bare-metal microcontroller with
 * semihosting (newlib's rdimon under QEMU, or a debug probe on a real board) and a Linux board
 * running the image as a plain process.
 *
 *   clock    the target's time base (hal_stdc_target.h: SysTick on Cortex-M, CLOCK_MONOTONIC
 *            on Linux); sleep_until lets the other cores run, or waits on it
 *   log      one line per message on stderr: "[   1.234567] LEVEL message"
 *   storage  one file per blob, <dir>/<name>, written to <name>.tmp then renamed (atomic where
 *            the file system renames atomically; semihosting passes it to the host)
 *   net      a RAM loopback: what the image publishes on a subscribed channel comes back to
 *            it through a queue of HAL_STDC_NET_QUEUE messages (one node, no radio); or the
 *            fleet's, over the hardware-in-the-loop link (hal_stdc_install_hil with a net)
 *   cores    the target's (hal_stdc_target.h): on Cortex-M a small preemptive scheduler,
 *            fixed priorities RT > GP > AI > the main program, sleeping on the SysTick
 *            (hal_stdc_cortex_m_cores.c); on Linux none (-ENOTSUP: a Linux board runs the
 *            host HAL's threads), and the program runs a core's work from its own main().
 *
 *   sensors  none, or a world's over the hardware-in-the-loop link (hal_stdc_install_hil)
 *
 * Storage is static (one board per program). No allocation. */
#ifndef HAL_STDC_H
#define HAL_STDC_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#include "hal/hal.h"
#include "hal/hal_hil_client.h"

#define HAL_STDC_NET_QUEUE 4u     /* loopback messages waiting at most */
#define HAL_STDC_NET_CHANNELS 8u  /* subscriptions */
#define HAL_STDC_DIR_MAX 128u     /* bytes of the storage directory, NUL included */

#define HAL_STDC_HIL_QUEUE 16u    /* fleet datagrams each way between the GP core and the link */

/* One fleet datagram (or subscription) waiting between the GP core and the link. */
typedef struct hal_stdc_hil_msg {
    char channel[HAL_NET_CHANNEL_MAX];
    uint32_t len;
    uint32_t subscribe; /* out only: a SUBSCRIBE to the channel, no bytes */
    uint64_t stamp_us;  /* in only: the board's time it was queued */
    uint8_t data[HAL_NET_MTU_BYTES];
} hal_stdc_hil_msg_t;

/* A ring of one writer and one reader on different cores: put and take run free (the fill is
 * their difference), each written by its own side only. */
typedef struct hal_stdc_hil_ring {
    hal_stdc_hil_msg_t msg[HAL_STDC_HIL_QUEUE];
    _Atomic uint32_t put, take;
} hal_stdc_hil_ring_t;

/* The network over the link: the GP core publishes and subscribes into `out` and receives
 * from `in`; the RT core, which owns the link, sends `out` before each TICK and fills `in`
 * from the TICK's answer (the room it names is in's free slots). The program owns it (static
 * storage: only a program on the link pays its RAM). */
typedef struct hal_stdc_hil_net {
    hal_stdc_hil_ring_t out, in;
} hal_stdc_hil_net_t;

/* Installs the board. storage_dir: where blobs live ("" or NULL: the current directory).
 * Returns 0, -EINVAL (directory name too long) or hal_board_install()'s error. */
FS_MUST_CHECK int hal_stdc_install(const char *storage_dir);

/* Removes the board (hal_board_install(NULL)). */
void hal_stdc_uninstall(void);

/* The same board, with a lidar, a pose and wheel motors: those of a world served over the
 * hardware-in-the-loop link (hal/hal_hil_client.h; `host_sim hil` at the other end), through
 * `client`, connected already. The first reading of an RT tick sends TICK t, t the board's
 * time floored to the client's RT period (the tick's release when the core keeps its rate)
 * less that of the first TICK (the world's time starts at the RT core's first tick, as a host
 * robot's lockstep does), and waits for the answer; the tick's other readings are the same TICK's. A wheel command
 * goes out at once. A link that does not answer makes the reading -EIO; after
 * HAL_STDC_HIL_DOWN_AFTER exchanges in a row went unanswered the world is gone (link_down in
 * hal_stdc_hil_stats): every reading fails at once from then on, so the board's clock runs again
 * and its program can see it and end (a dead world would otherwise hold a lockstep board's
 * clock a whole exchange per reading). lockstep: the board's
 * clock stands still while it waits for the answer (hal_stdc_target_hold), so the world's and
 * the link's time are not the board's. net: NULL (the network stays the RAM loopback), or the
 * fleet's network through the link (hal_stdc_hil_net_t; a full out ring refuses a publish,
 * -EIO and tx_rejected; a datagram the in ring cannot take is never sent: the TICK names its
 * room). 0, -EINVAL or install's error. */
FS_MUST_CHECK int hal_stdc_install_hil(const char *storage_dir, hal_hil_client_t *client, int lockstep,
                                       hal_stdc_hil_net_t *net);

/* Durations in the board's time (ns: under -icount a Cortex-M's are instructions): how many,
 * their sum and the longest. */
typedef struct hal_stdc_timing {
    uint64_t count, sum_ns, max_ns;
} hal_stdc_timing_t;

/* Exchanges in a row without an answer (each of the client's `tries` TICKs, timeout each: 10 s
   at board_robot's defaults) after which the link is down. A world paused for less comes back. */
#define HAL_STDC_HIL_DOWN_AFTER 10u

typedef struct hal_stdc_hil_stats {
    hal_stdc_timing_t exchange; /* TICK sent to its answer read, in the link's time (held or not) */
    hal_stdc_timing_t response; /* sensors read to the wheel command */
    hal_stdc_timing_t release;  /* the TICK's time (the RT tick's release) to the wheel command:
                                   the core's wake-up and its work, preempting the others (in
                                   lockstep the link's wait is not the board's time) */
    uint64_t link_errors;
    uint64_t unanswered_in_row; /* TICK exchanges in a row the world did not answer */
    int link_down;              /* HAL_STDC_HIL_DOWN_AFTER of them: the world is gone for good */
    uint64_t tick_gaps;         /* TICKs that were not one RT period after the last: an RT tick
                                   released so late (or not at all) that a period went by */
} hal_stdc_hil_stats_t;

void hal_stdc_hil_stats(hal_stdc_hil_stats_t *st);

#endif /* HAL_STDC_H */
