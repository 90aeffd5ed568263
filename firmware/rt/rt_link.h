/* What the RT core publishes on its links (fw_link.h): its status record, and the samples of
 * its sample ring (ai/ai_sample.h). The RT core owns this header: it writes these links. */
#ifndef RT_RT_LINK_H
#define RT_RT_LINK_H

#include <stdint.h>

#include "ai/ai_sample.h"
#include "common/mbox.h"
#include "common/ring.h"

typedef struct rt_status {
    uint64_t stamp_us;       /* simulated time of the RT tick that wrote it */
    float x_m, y_m, heading_rad; /* latest GPS + compass fix */
    float distance_m;        /* odometry: integral of |commanded v| dt since start */
    float progress_m;        /* arc length of the path covered (monotone, <= path_length_m) */
    float path_length_m;     /* total arc length of the waypoint path */
    uint32_t waypoint;       /* index aimed at (== n when finished) */
    uint32_t finished;       /* 1 once the last waypoint was reached */
    uint32_t scans;          /* scans turned into samples */
    uint32_t samples;        /* samples pushed into the ring (accepted) */
    uint32_t ring_drops;     /* samples dropped because the ring was full */
    uint32_t errors;         /* HAL calls that failed (pose, lidar, motor) */
    uint32_t sample_errors;  /* scans rt_samples refused, and samples the ring refused for any
                                reason but full (a contract broken: never expected) */
    /* Exploration (rt_core_cfg_t.explore set; all 0 otherwise). */
    uint32_t goal_seq;       /* seq of the GP goal being driven to (0: none yet) */
    uint32_t goal_reached;   /* seq of the last goal reached (0: none) */
    uint32_t goal_failed;    /* seq of the last goal given up (unreachable, or stuck too often) */
    uint32_t plans, plan_failures; /* A* runs, and runs that found no path */
    uint32_t stuck_events;   /* no progress for the stuck window: backed off and re-planned */
    uint32_t avoid_stops;    /* ticks the reactive avoidance stopped the robot */
    uint32_t tight_plans;    /* plans through a door the full clearance band closes (rt_plan.h) */
} rt_status_t;

/* RT -> GP: a coarse view of the robot's own lidar grid, for goal selection (the frontier
 * policies' information, and every policy's traversability). Geometry: the GP goal grid's
 * (gp/gp_goal.h): w x h cells, row-major, each covering factor x factor cells of the RT grid.
 *   occ      round(255 x occupied / observed) over the cell's observed fine cells (0 if none);
 *   unknown  round(255 x never observed / all) over its fine cells (255: never seen);
 * a coarse cell of the last row or column may reach past the fine grid: its fine cells there
 * count as observed and occupied (outside the map). */
#define RT_SEEN_MAX_CELLS 4096u
typedef struct rt_seen {
    uint64_t stamp_us;       /* simulated time of the scan that last changed it */
    uint32_t w, h;
    uint32_t updates;        /* publications so far */
    uint8_t occ[RT_SEEN_MAX_CELLS];
    uint8_t unknown[RT_SEEN_MAX_CELLS];
} rt_seen_t;

/* Static bytes of the RT core's links: the sample ring, both status mailboxes, the seen grid. */
#define RT_LINK_BYTES                                                                         \
    (RING_STORAGE_BYTES(sizeof(ai_sample_t), FW_LINK_RING_CAPACITY) +                          \
     2u * MBOX_STORAGE_BYTES(sizeof(rt_status_t)) + MBOX_STORAGE_BYTES(sizeof(rt_seen_t)))

#endif /* RT_RT_LINK_H */
