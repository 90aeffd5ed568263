/* 2D lidar scan.
 *
 * A scan is a fixed-size record (no pointer, copyable between cores): `count` ranges taken
 * at angles angle_min_rad + i * angle_step_rad (i = 0 .. count-1) in the ROBOT frame
 * (0 = the robot's +x axis, counter-clockwise positive). ranges_m[i] in
 * [range_min_m, range_max_m] is a return; any other value (the host writes +INFINITY)
 * means no return within range. Entries at index >= count are unspecified.
 *
 * Who may call: the RT core. Non-blocking: returns the latest complete scan.
 */
#ifndef HAL_LIDAR_H
#define HAL_LIDAR_H

#include "hal/hal_board.h"

/* HAL_LIDAR_MAX_BEAMS, the beams a scan record holds, is a board setting (its default is in
 * firmware/common/fw_config.h, which the build gives every file). */
#ifndef HAL_LIDAR_MAX_BEAMS
#error "HAL_LIDAR_MAX_BEAMS is not set: build with the board configuration (see the Makefile)"
#endif

typedef struct hal_lidar_scan {
    uint64_t stamp_us;     /* simulated time the scan was taken */
    float angle_min_rad;   /* angle of beam 0, robot frame */
    float angle_step_rad;  /* angle between beams (may be negative) */
    float range_min_m;     /* returns closer than this are invalid */
    float range_max_m;     /* returns farther than this are invalid */
    uint32_t count;        /* beams used, 1 .. HAL_LIDAR_MAX_BEAMS */
    float ranges_m[HAL_LIDAR_MAX_BEAMS];
} hal_lidar_scan_t;

typedef struct hal_lidar_ops {
    /* Required. Latest scan into *scan. 0, -EAGAIN when no scan exists yet, -EIO. */
    int (*read_scan)(void *ctx, hal_lidar_scan_t *scan);
} hal_lidar_ops_t;

FS_MUST_CHECK static inline int hal_lidar_read_scan(hal_lidar_scan_t *scan)
{
    const hal_board_t *b = hal_board_current;
    if (scan == NULL)
        return -EINVAL;
    if (b == NULL || b->lidar == NULL)
        return -ENODEV;
    return b->lidar->read_scan(b->ctx, scan);
}

#endif /* HAL_LIDAR_H */
