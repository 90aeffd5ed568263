/* Simulated clock.
 *
 * Units: microseconds of SIMULATED time since the image started (t = 0 at start-up). On a
 * real board this is the monotonic hardware clock; on the host it is the lockstep clock,
 * which only advances when every core is asleep (see hal/host/hal_host.h).
 *
 * Who may call: any core. hal_clock_sleep_until_us() only from a core's own thread (it
 * suspends the calling core); from any other thread it returns -EPERM.
 */
#ifndef HAL_CLOCK_H
#define HAL_CLOCK_H

#include "hal/hal_board.h"

typedef struct hal_clock_ops {
    /* Required. Current simulated time. Never fails on a started board. */
    int (*now_us)(void *ctx, uint64_t *now_us);
    /* Required. Suspends the calling core until the clock reads >= wake_us.
     * Returns 0 when woken at wake_us (or at once when wake_us <= now), -ECANCELED when the
     * board is stopping (the core must return from its entry function), -EPERM when not
     * called from a core. */
    int (*sleep_until_us)(void *ctx, uint64_t wake_us);
    /* Optional. See hal_clock_while_asleep(). */
    int (*while_asleep)(void *ctx, void (*fn)(void *arg), void *arg, uint32_t every_us);
} hal_clock_ops_t;

/* Current simulated time in microseconds into *now_us. 0 or -EINVAL/-ENODEV. */
FS_MUST_CHECK static inline int hal_clock_now_us(uint64_t *now_us)
{
    const hal_board_t *b = hal_board_current;
    if (now_us == NULL)
        return -EINVAL;
    if (b == NULL || b->clock == NULL)
        return -ENODEV;
    return b->clock->now_us(b->ctx, now_us);
}

/* Blocks the calling core until simulated time wake_us. See hal_clock_ops_t for returns.
 * The only blocking call of the HAL besides what a back end documents. */
FS_MUST_CHECK static inline int hal_sleep_until_us(uint64_t wake_us)
{
    const hal_board_t *b = hal_board_current;
    if (b == NULL || b->clock == NULL)
        return -ENODEV;
    return b->clock->sleep_until_us(b->ctx, wake_us);
}

/* Work the calling core does in REAL time while it sleeps in hal_sleep_until_us() and the
 * board's clock stands still for it: fn(arg) runs on the core's own thread every every_us of
 * real time until the sleep ends. Only a board whose clock is not real time needs it (the host's
 * lockstep, where simulated time waits for the slowest core: while the AI core trains, the GP
 * core would otherwise neither read nor answer the network, which runs in real time). fn must
 * not use the clock or sleep. NULL fn: none. 0, -EINVAL (every_us 0), -EPERM (not a core),
 * -ENOTSUP where the clock is real time (a board: the core's own ticks do the work). */
static inline int hal_clock_while_asleep(void (*fn)(void *arg), void *arg, uint32_t every_us)
{
    const hal_board_t *b = hal_board_current;
    if (b == NULL || b->clock == NULL)
        return -ENODEV;
    if (b->clock->while_asleep == NULL)
        return -ENOTSUP;
    return b->clock->while_asleep(b->ctx, fn, arg, every_us);
}

#endif /* HAL_CLOCK_H */
