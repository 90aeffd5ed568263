/* Reactive obstacle avoidance on one lidar scan (RT core, pure C11, no allocation).
 *
 * Applied to a follower command (rt_follow_step's output) before it reaches the motors:
 *   - the direction of travel is the heading when cmd->v > 0, the heading + pi when v < 0;
 *     a command with v == 0 (turning in place, or stopped) is never changed, so the robot
 *     may always turn away from what is in front of it;
 *   - d = the nearest return among the beams within half_angle_rad of that direction
 *     (NaN beams are ignored, +INF or r >= range_max mean nothing in range);
 *   - d <= stop_dist_m: v = 0 (omega kept: the follower may still turn);
 *     stop_dist_m < d < slow_dist_m: v scaled by (d - stop) / (slow - stop);
 *     otherwise the command is untouched;
 *   - after a change the wheel rates are recomputed with rt_follow_wheels under the same wheel
 *     limit rt_follow_step uses (v_max / wheel_radius of the follower's cfg).
 * Ranges are measured from the lidar, taken at the robot's centre: stop_dist_m should cover
 * the robot's radius plus its braking distance (burger: 0.105 + 0.22^2 / (2 * 1 m/s^2) ~ 0.13
 * m, default 0.25 m).
 *
 * The scan is rt_samples.h's rt_scan_view_t: beam i at angle_min + i * angle_inc relative to
 * the heading, CCW. Pure function: thread-safe, deterministic. */
#ifndef RT_AVOID_H
#define RT_AVOID_H

#include <stdint.h>

#include "rt/rt_follow.h"
#include "rt/rt_samples.h"

typedef struct rt_avoid_cfg {
    float stop_dist_m;    /* > 0: stop when something is this close in the cone */
    float slow_dist_m;    /* > stop_dist_m: start slowing down at this range */
    float half_angle_rad; /* (0, pi]: half width of the cone around the direction of travel */
} rt_avoid_cfg_t;

/* stop 0.25 m, slow 0.6 m, half angle 0.5 rad (a 57 degree cone). */
rt_avoid_cfg_t rt_avoid_default_cfg(void);

/* Adjusts *cmd for the scan. Returns 1 when it changed the command (slowed or stopped), 0
 * when it left it alone, -EINVAL on a NULL pointer, a bad cfg, a follower cfg whose wheel
 * fields are not positive, a non-finite command, or a scan with n_scan < 1, non-finite angles
 * or range_max <= 0 (the command is untouched then). *nearest_m (may be NULL) receives d
 * (+INF when the cone is clear). */
FS_MUST_CHECK
int rt_avoid_apply(const rt_avoid_cfg_t *cfg, const rt_follow_cfg_t *follow,
                   const rt_scan_view_t *scan, rt_follow_cmd_t *cmd, float *nearest_m);

#endif /* RT_AVOID_H */
