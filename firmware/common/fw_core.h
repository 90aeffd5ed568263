/* A firmware core's periodic loop, as the image runs it.
 *
 * The image's runner calls init(arg) once on the core at start, then tick(arg, &tick) at
 * simulated times start + k * period_us (k = 0, 1, 2, ...; no drift: the times are computed
 * from k, not accumulated). Every sub_divider-th tick (k % sub_divider == 0) has tick.sub =
 * 1, e.g. the RT core's 10 Hz scan processing inside its 50 Hz control loop.
 *
 * tick() returns 0 to continue, FW_CORE_DONE to end the core, or a negative errno code: the
 * error is counted (fw_core_stats_t) and logged (the first FW_CORE_LOG_ERRORS of them), and
 * the loop continues, since a robot should keep driving when one tick fails.
 * init() returning a negative code ends the core before its first tick.
 * Functions run on the core's own thread and stack; they must not block (except the RT-safe
 * HAL calls the HAL headers allow).
 */
#ifndef COMMON_FW_CORE_H
#define COMMON_FW_CORE_H

#include <stdint.h>

#include "hal/hal_board.h"

#define FW_CORE_DONE 1
#define FW_CORE_LOG_ERRORS 8u

typedef struct fw_tick {
    uint64_t now_us; /* simulated time of this tick = start + index * period */
    uint64_t index;  /* 0, 1, 2, ... */
    uint32_t sub;    /* 1 on sub-rate ticks (index % sub_divider == 0), else 0 */
} fw_tick_t;

typedef int (*fw_core_init_fn)(void *arg);
typedef int (*fw_core_tick_fn)(void *arg, const fw_tick_t *tick);

typedef struct fw_core {
    const char *name;      /* for logs; NULL: hal_core_name(id) */
    uint32_t period_us;    /* > 0 */
    uint32_t sub_divider;  /* >= 1 */
    fw_core_init_fn init;  /* optional */
    fw_core_tick_fn tick;  /* NULL: the core is not started */
    void *arg;
    /* Optional: work in real time while the core sleeps and the board's clock stands still
       (hal_clock_while_asleep), every asleep_every_us: the GP core's network. */
    void (*asleep)(void *arg);
    uint32_t asleep_every_us;
} fw_core_t;

typedef struct fw_core_stats {
    uint64_t ticks;       /* tick() calls */
    uint64_t errors;      /* tick() calls that returned < 0 */
    int32_t last_error;   /* the latest negative code, 0 if none */
    int32_t init_error;   /* what init() returned if negative, else 0 */
    int32_t done;         /* 1 once the loop ended */
    uint64_t start_us;    /* simulated time the core started */
} fw_core_stats_t;

#endif /* COMMON_FW_CORE_H */
