/* The real-time core of the robot image: a fixed-rate loop (fw_image runner; default 50 Hz
 * control with every 5th tick a 10 Hz scan tick) that
 *   - reads GPS + compass (hal_pose_read) every tick and follows the waypoint path
 *     (rt_follow_step -> hal_motor_set_wheels);
 *   - on scan ticks reads the lidar (hal_lidar_read_scan) and, for a scan it has not seen
 *     before, turns it into samples at the GPS pose (rt_samples_from_scan) and pushes them
 *     into the RT -> AI ring (never blocks: a full ring drops and counts);
 *   - tracks the odometry distance (integral of |commanded v| over the tick) and the path
 *     progress (arc length up to the waypoint aimed at, minus the distance still to go to it,
 *     clamped to that segment and never decreasing), and publishes both with the pose in an
 *     rt_status_t to the AI and GP cores every tick (fw_link.h). Communication rounds are
 *     cut by path progress, so a path split into C rounds gives C segments of equal length.
 * After the last waypoint the wheels are stopped and no more samples are produced.
 *
 * Exploration mode (cfg.explore set, rt_explore.h): no tour. Every tick the core reads the GP's
 * goal mailbox (link->gp_goal, this core its one reader) and the pose; on a scan tick with a
 * new scan it makes the samples exactly as on a tour and also integrates the scan into its own
 * fine grid; rt_explore_step plans to the goal, follows, avoids and recovers; at most once per
 * second of simulated time, when the grid changed, it publishes the coarse rt_seen_t
 * (link->rt_seen). path_length_m and progress_m stay 0 (rounds are cut by time then).
 * finished = 1 once the GP sends GP_GOAL_MSG_DONE or budget_us passed since the first tick:
 * the wheels are stopped once, no more samples are produced.
 *
 * Storage: rt_core_t is static (declared by the image); the waypoint table and the scan and
 * sample buffers are inline. No allocation. One RT core per image. */
#ifndef RT_RT_CORE_H
#define RT_RT_CORE_H

#include <stdint.h>

#include "common/fw_core.h"
#include "fw_link.h"
#include "gp/gp_link.h"
#include "rt/rt_link.h"
#include "hal/hal_lidar.h"
#include "rt/rt_explore.h"
#include "rt/rt_follow.h"
#include "rt/rt_samples.h"

/* RT_CORE_MAX_WAYPOINTS and RT_CORE_MAX_SCAN_SAMPLES come from common/fw_config.h. */

typedef struct rt_core_cfg {
    const rt_waypoint_t *waypoints; /* copied at init; ignored (may be NULL) when exploring */
    int32_t n_waypoints;            /* 2 .. RT_CORE_MAX_WAYPOINTS on a tour */
    rt_follow_cfg_t follow;
    rt_samples_cfg_t samples;       /* beams, points per beam, plan bounding box */
    uint32_t period_us;             /* the core's tick period (for odometry), > 0 */
    const rt_explore_cfg_t *explore; /* NULL: the waypoint tour; else exploration (copied at
                                        init, rt_explore_check_cfg) */
} rt_core_cfg_t;

typedef struct rt_core_stats {
    uint64_t ticks;
    uint64_t scan_ticks;
    uint64_t tick_gaps;      /* ticks whose time was not previous + period (must stay 0) */
    uint64_t clock_mismatch; /* ticks whose time differed from hal_clock_now_us (must stay 0) */
    uint64_t last_tick_us;
} rt_core_stats_t;

typedef struct rt_core {
    rt_core_cfg_t cfg;
    rt_follow_t follow;
    rt_waypoint_t wps[RT_CORE_MAX_WAYPOINTS];
    float cum[RT_CORE_MAX_WAYPOINTS];   /* arc length from waypoint 0 to waypoint i */
    const fw_link_t *link;
    rt_status_t status;
    rt_core_stats_t stats;
    uint64_t last_scan_stamp;
    int have_scan;
    hal_lidar_scan_t scan;
    ai_sample_t out[RT_CORE_MAX_SCAN_SAMPLES];
    /* Exploration only. Last: a tour never touches it, so its pages of the static image stay
     * untouched (not resident) on a tour. */
    gp_goal_msg_t goal;             /* latest GP goal (seq 0: none yet) */
    int32_t have_goal;
    rt_explore_t explore;
} rt_core_t;

/* Validates cfg and resets rt (before the cores start). 0 or -EINVAL (-ENOSPC: an
 * exploration grid larger than RT_GRID_MAX_CELLS). */
FS_MUST_CHECK int rt_core_init(rt_core_t *rt, const rt_core_cfg_t *cfg,
                                                     const fw_link_t *link);

/* fw_core_t tick function: arg is the rt_core_t. */
int rt_core_tick(void *arg, const fw_tick_t *tick);

/* Total arc length of the configured path, metres (0 when exploring). */
float rt_core_path_length(const rt_core_t *rt);

#endif /* RT_RT_CORE_H */
