/* The firmware image's start-up: three cores (RT, GP, AI) started through the HAL, each
 * running a fixed-period loop whose work is a function pointer supplied by the image (see
 * common/fw_core.h), so the real RT/GP/AI loops plug in without touching the runner.
 *
 * Defaults (fw_image_defaults): RT 50 Hz control with a 10 Hz scan sub-rate, GP 10 Hz,
 * AI 10 Hz (the AI core polls its sample ring; an event-driven AI core would need a HAL
 * wait primitive, which the HAL does not offer yet).
 *
 * Storage: an fw_image_t is owned by the caller (static storage in a firmware image); it
 * must outlive the cores. Stats are written by each core and may be read after the board
 * stopped the cores (on the host: after hal_host_stop()).
 */
#ifndef FW_IMAGE_H
#define FW_IMAGE_H

#include "common/fw_core.h"
#include "hal/hal_board.h"

#define FW_RT_PERIOD_US 20000u   /* 50 Hz */
#define FW_RT_SCAN_DIVIDER 5u    /* scan every 5th RT tick: 10 Hz */
#define FW_GP_PERIOD_US 100000u  /* 10 Hz */
#define FW_AI_PERIOD_US 100000u  /* 10 Hz */

/* When a core ticks: every period_us of simulated time, with every sub_divider-th tick a
 * sub-rate tick (common/fw_core.h). */
typedef struct fw_core_timing {
    uint32_t period_us;   /* > 0 */
    uint32_t sub_divider; /* >= 1 */
} fw_core_timing_t;

/* The one table of default core timings, indexed by hal_core_id_t (built from the macros
 * above): fw_image_defaults() and fw_robot_default_cfg() both take it from here. */
extern const fw_core_timing_t fw_core_timing_default[HAL_CORE_COUNT];

typedef struct fw_image fw_image_t;

typedef struct fw_image_slot {
    fw_image_t *image;
    hal_core_id_t id;
} fw_image_slot_t;

struct fw_image {
    fw_core_t core[HAL_CORE_COUNT];        /* filled by the image before fw_image_start() */
    fw_core_stats_t stats[HAL_CORE_COUNT]; /* written by the cores */
    fw_image_slot_t slot[HAL_CORE_COUNT];  /* runner's private argument per core */
};

/* Resets `img`: default periods and sub-rates, no loops (tick == NULL), zero stats. */
void fw_image_defaults(fw_image_t *img);

/* Validates the cores (period > 0, sub_divider >= 1, at least one tick) and starts every
 * core that has a tick function through hal_core_start(). Returns 0, -EINVAL, or the HAL's
 * error (cores already started stay started). */
FS_MUST_CHECK int fw_image_start(fw_image_t *img);

#endif /* FW_IMAGE_H */
