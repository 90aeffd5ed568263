/* Exploration mode of the RT core (pure C11, no I/O, no allocation, deterministic).
 *
 * Instead of a fixed waypoint tour the robot drives to goals the GP core picks (gp_link.h's
 * gp_goal_msg_t), planning on its OWN fine occupancy grid built from its lidar scans. The RT
 * core (rt_core.c) owns the HAL calls and the mailboxes and calls, per tick:
 *   rt_explore_clock      the time budget (counted from the first call);
 *   rt_explore_integrate_scan   on a scan tick with a new scan, at the GPS pose;
 *   rt_explore_step       the goal in the mailbox (or NULL: none yet) -> a wheel command;
 *   rt_explore_seen       at most once per RT_EXPLORE_SEEN_PERIOD_US and only when the grid
 *                         changed: the coarse rt_seen_t for the GP core;
 *   rt_explore_status     the exploration counters into the rt_status_t it publishes.
 *
 * Grid update (rt_explore_integrate_scan): every beam is traced through the cells of the
 * infinite lattice from the pose to its end (Amanatides & Woo voxel walk; only cells inside
 * the grid are written). Cells a beam passes through are "missed", the end cell of a beam that
 * hit (finite r < range_max) is "hit"; a beam with +INF or r >= range_max misses every cell up
 * to range_max, end cell included; NaN (dropout) and negative ranges are ignored. Each cell is
 * updated at most ONCE per scan however many beams touch it, and a hit wins over misses of the
 * same scan (so grazing beams next to a wall do not wear it away within one scan):
 *   first observation: occ = 128 (P = 0.5) before the update;
 *   hit:  occ = min(255, occ + occ_hit);   miss: occ = max(0, occ - occ_miss);
 *   known = min(255, known + 1)            (rt_grid.h: 0 = never observed).
 * Saturating counts in bytes: a bounded, integer form of log-odds (exact, no float drift).
 *
 * Driving (rt_explore_step), a state machine:
 *   IDLE      no goal yet, or the last one reached or given up: wheels at 0.
 *   DRIVE     a new goal seq (mode GO) plans with rt_plan_path (RT_PLAN_NEAREST_GOAL, unknown
 *             cells open) from the pose; the follower (rt_follow_step) drives the waypoints and
 *             every command goes through rt_avoid_apply with the latest scan (a stop there
 *             counts in avoid_stops). Reached when within reach_goal_m of the goal or when the
 *             follower finished the (possibly NEAREST_GOAL-moved) path: goal_reached = seq.
 *             Re-plan, checked once per new scan: the square of some obstacle cell (known,
 *             occ >= occ_threshold) may come within robot_radius_m + margin_m / 2 of the
 *             remaining path (from the waypoint before the one aimed at), i.e. its centre is
 *             within that plus half a cell diagonal. A fresh plan never triggers this (the
 *             planner keeps radius + margin + half a diagonal from every obstacle centre).
 *             Stuck: every stuck_window_s the pose is compared with the pose at the window's
 *             start; moved less than stuck_dist_m -> stuck_events++ and the goal's own count;
 *             below max_stuck: BACKOFF, else the goal is given up.
 *   BACKOFF   backoff_s of reverse at backoff_v_mps (< 0) turning at backoff_omega_rps (also
 *             through rt_avoid, which looks behind when v < 0), then a re-plan from the pose.
 *   A plan failure (no allowed cell, start or path trouble) gives the goal up at once:
 *   goal_failed = seq, then IDLE until a new seq.
 *   DONE      GP_GOAL_MSG_DONE arrived, or budget_us passed since the first rt_explore_clock:
 *             wheels at 0 for good (finished).
 * Goals outside the grid are clamped to its outermost cell centres (the planner's
 * NEAREST_GOAL then takes the reachable cell nearest to it).
 *
 * Keep-in fence (cfg.keep_in, optional): the area to explore, one byte per fine cell (0 =
 * outside it). rt_explore_init makes every outside cell an obstacle the robot has observed
 * (occ 255, known 255) that no scan changes, so the planner never routes through it, the path
 * check re-plans around it and the seen view tells the GP core it is wall, not frontier. What
 * a deployed robot gets as its site's geofence; host_sim gives the building's outline, so that
 * robots that leave by the entrance do not explore the yards around it (docs/exploration.md).
 *
 * Storage: rt_explore_t holds the fine grid, the planner's workspace (about 1.4 MB at the
 * default RT_GRID_MAX_CELLS: static storage only), the plan and a per-cell scan mark. */
#ifndef RT_RT_EXPLORE_H
#define RT_RT_EXPLORE_H

#include <stdint.h>

#include "gp/gp_link.h"
#include "rt/rt_avoid.h"
#include "rt/rt_follow.h"
#include "rt/rt_grid.h"
#include "rt/rt_link.h"
#include "rt/rt_plan.h"
#include "rt/rt_samples.h"

#define RT_EXPLORE_SEEN_MAX_SIDE 64u /* rt_seen_t's coarse grid: 64 x 64 = RT_SEEN_MAX_CELLS */
#define RT_EXPLORE_SEEN_PERIOD_US 1000000u /* at most one rt_seen_t per second of simulated time */
_Static_assert(RT_EXPLORE_SEEN_MAX_SIDE * RT_EXPLORE_SEEN_MAX_SIDE == RT_SEEN_MAX_CELLS,
               "the coarse grid's sides fill rt_seen_t");

typedef struct rt_explore_cfg {
    /* Fine grid (rt_grid.h): res > 0, 1 .. RT_GRID_MAX_SIDE per side, w * h <= RT_GRID_MAX_CELLS. */
    float res_m;
    float origin_x_m, origin_y_m;   /* outer corner of cell (0, 0) */
    int32_t w, h;
    /* Coarse view for the GP (rt_seen_t): seen_w x seen_h cells (1 .. 64 each), each
     * seen_factor x seen_factor fine cells from cell (0, 0) on; fine cells beyond the fine
     * grid count as never observed. Align it with the GP's goal grid (same origin, GP res =
     * seen_factor * res_m). */
    uint32_t seen_factor, seen_w, seen_h;
    rt_plan_cfg_t plan;             /* flags must be RT_PLAN_NEAREST_GOAL, unknown_is_obstacle 0 */
    rt_avoid_cfg_t avoid;
    float stuck_window_s;           /* > 0 */
    float stuck_dist_m;             /* > 0 */
    uint32_t max_stuck;             /* >= 1: stuck events of one goal before it is given up */
    float backoff_s;                /* > 0 */
    float backoff_v_mps;            /* < 0: reversing */
    float backoff_omega_rps;        /* finite */
    float reach_goal_m;             /* > 0 */
    uint64_t budget_us;             /* exploration time from the first tick; 0 = no limit */
    uint8_t occ_hit, occ_miss;      /* 1 .. 255 each: the saturating update steps */
    const uint8_t *keep_in;         /* NULL: no fence; else w * h bytes, 0 = outside (above);
                                       read by rt_explore_init only */
} rt_explore_cfg_t;

enum {
    RT_EXPLORE_IDLE = 0,
    RT_EXPLORE_DRIVE = 1,
    RT_EXPLORE_BACKOFF = 2,
    RT_EXPLORE_DONE = 3,
};

typedef struct rt_explore {
    rt_explore_cfg_t cfg;
    int32_t state;                  /* RT_EXPLORE_* */
    /* goal */
    uint32_t goal_seq;              /* seq of the goal being (or last) handled, 0: none */
    float goal_x, goal_y;           /* clamped into the grid */
    uint32_t goal_stuck;            /* stuck events of this goal */
    /* time */
    int32_t started;
    uint64_t first_us;
    uint64_t backoff_end_us;
    uint64_t window_us;             /* start of the stuck window */
    float window_x, window_y;       /* pose at its start */
    int32_t window_set;
    /* the path */
    rt_follow_t follow;
    int32_t path_check;             /* a new scan came since the last blocked-path check */
    /* the seen view */
    int32_t grid_dirty;             /* changed since the last rt_explore_seen publication */
    int32_t seen_published;
    uint64_t grid_stamp_us;         /* scan time of the last change */
    uint64_t seen_last_us;
    uint32_t seen_updates;
    /* counters (rt_status_t's exploration fields) */
    uint32_t goal_reached, goal_failed, plans, plan_failures, stuck_events, avoid_stops;
    uint32_t tight_plans;           /* plans through the tight band (plan_to_goal) */
    uint32_t scans_integrated;
    uint32_t fenced;                /* cells outside the keep-in fence */
    /* storage */
    rt_plan_result_t plan_res;
    int32_t tight;                  /* 1: plan_res is a tight plan (point_blocked's bound) */
    rt_grid_t grid;
    uint8_t mark[RT_GRID_MAX_CELLS]; /* per scan: 0 untouched, 1 missed, 2 hit; 3 fenced, for good */
    rt_plan_workspace_t ws;
} rt_explore_t;

/* Sensible values for everything but the fine grid's geometry and the seen view (left 0):
 * plan = rt_plan_default_cfg() with RT_PLAN_NEAREST_GOAL, avoid = rt_avoid_default_cfg(),
 * stuck 0.05 m in 4 s, 3 stuck events, back off 1 s at -0.05 m/s turning 0.3 rad/s, reached
 * within 0.3 m, no budget, hit +64, miss -16. */
rt_explore_cfg_t rt_explore_default_cfg(void);

/* 0 when cfg is usable (the ranges above), else -EINVAL (-ENOSPC: grid too large). */
FS_MUST_CHECK int rt_explore_check_cfg(const rt_explore_cfg_t *cfg);

/* Validates cfg and resets x: every cell unknown (but the fenced ones, above), IDLE, counters 0.
 * 0, -EINVAL or -ENOSPC. */
FS_MUST_CHECK int rt_explore_init(rt_explore_t *x, const rt_explore_cfg_t *cfg);

/* The time budget: the first call starts it. Returns 1 when exploration is over (budget
 * passed now, or DONE before), 0 otherwise, -EINVAL on NULL. */
FS_MUST_CHECK int rt_explore_clock(rt_explore_t *x, uint64_t now_us);

/* One new scan taken at pose (px, py, ptheta) into the grid (rules above); stamp_us = the
 * scan's time (rt_seen_t.stamp_us). Returns the number of cells whose bytes changed (>= 0), or
 * -EINVAL (NULL, non-finite pose, n_scan < 1, non-finite angles, range_max <= 0). */
FS_MUST_CHECK int rt_explore_integrate_scan(rt_explore_t *x, const rt_scan_view_t *scan, float px,
                                            float py, float ptheta, uint64_t stamp_us);

/* One control tick. goal: the latest GP goal message, NULL when none ever came; scan: the
 * latest scan (may be NULL: no avoidance then); follow: the follower's cfg (its wheel limits
 * are rt_avoid's too). Fills *cmd (v, omega, wheels; finished = 1 once DONE; target = the
 * waypoint aimed at). Returns 0, or -EINVAL (NULL x, follow or cmd, non-finite pose, bad
 * follow cfg). A planner error is not returned: the goal is given up and counted. */
FS_MUST_CHECK int rt_explore_step(rt_explore_t *x, const gp_goal_msg_t *goal, float px, float py,
                                  float ptheta, const rt_scan_view_t *scan, uint64_t now_us,
                                  const rt_follow_cfg_t *follow, rt_follow_cmd_t *cmd);

/* The coarse view, when due: the grid changed since the last publication and
 * RT_EXPLORE_SEEN_PERIOD_US passed since it (the first is due at the first change). Returns 1
 * and fills *out (stamp = the last changing scan's time, updates counted), 0 when not due
 * (*out untouched), -EINVAL on NULL. */
FS_MUST_CHECK int rt_explore_seen(rt_explore_t *x, uint64_t now_us, rt_seen_t *out);

/* Copies the exploration fields (goal_seq, goal_reached, goal_failed, plans, plan_failures,
 * stuck_events, avoid_stops, tight_plans) into *st. */
void rt_explore_status(const rt_explore_t *x, rt_status_t *st);

#endif /* RT_RT_EXPLORE_H */
