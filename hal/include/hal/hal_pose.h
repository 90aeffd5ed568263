/* GPS + compass: the robot's pose in the world frame.
 *
 * Units: metres, radians; heading is the robot's +x axis measured counter-clockwise from
 * the world +x axis, in (-pi, pi]. The host back end reports the simulated ground truth.
 *
 * Who may call: any core (the RT core for control, the GP core for telemetry).
 * Non-blocking.
 */
#ifndef HAL_POSE_H
#define HAL_POSE_H

#include "hal/hal_board.h"

typedef struct hal_pose {
    uint64_t stamp_us; /* simulated time of the fix */
    float x_m;
    float y_m;
    float heading_rad;
} hal_pose_t;

typedef struct hal_pose_ops {
    /* Required. Latest fix into *pose. 0, -EAGAIN when there is no fix yet, -EIO. */
    int (*read_pose)(void *ctx, hal_pose_t *pose);
} hal_pose_ops_t;

FS_MUST_CHECK static inline int hal_pose_read(hal_pose_t *pose)
{
    const hal_board_t *b = hal_board_current;
    if (pose == NULL)
        return -EINVAL;
    if (b == NULL || b->pose == NULL)
        return -ENODEV;
    return b->pose->read_pose(b->ctx, pose);
}

#endif /* HAL_POSE_H */
