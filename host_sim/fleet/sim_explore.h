/* Exploration settings of one robot image, from the plan (docs/exploration.md): the grids'
 * geometry shared by the three cores and their configurations.
 *
 * Geometry. The RT core's fine grid covers the plan's bounding box from its lower corner at
 * the finest resolution of 0.05 m, 0.01 m steps, that fits RT_GRID_MAX_CELLS; the coarse grid
 * of the GP core's goals, the AI core's belief and the RT core's seen grid groups factor x
 * factor fine cells, factor the smallest that keeps it within 64 x 64. */
#ifndef SIM_EXPLORE_H
#define SIM_EXPLORE_H

#include <stdint.h>
#include <stdio.h>

#include "ai/ai_belief.h"
#include "gp/gp_core.h"
#include "gp/gp_explore.h"
#include "gp/gp_fleet.h"
#include "rt/rt_core.h"
#include "rt/rt_explore.h"
#include "sim_paths.h"
#include "sim_plan.h"

typedef struct sim_explore_opts {
    gp_explore_policy_t policy;
    double budget_s;        /* simulated seconds of exploration (the rounds are cut over it) */
    double belief_period_s; /* the AI core's belief grid this often */
    int own_posterior;      /* 1: in a fleet, each robot's belief from its own posterior only (the
                               ablation); 0: the posterior shared every other round (ai_core.h) */
    int counts;             /* 1: the belief also counts where the rays went (ai/ai_seen.h) */
    int no_fence;           /* 1: no keep-in fence (the ablation); 0: the RT core is fenced into
                               the building's outline (sim_explore_keep_in) */
} sim_explore_opts_t;

#define SIM_EXPLORE_BUDGET_S_DEFAULT 300.0
#define SIM_EXPLORE_BELIEF_PERIOD_S_DEFAULT 5.0

typedef struct sim_explore_geom {
    float fine_res_m;
    int32_t fine_w, fine_h;
    uint32_t factor;
    uint32_t w, h;          /* coarse */
    float origin_x_m, origin_y_m;
} sim_explore_geom_t;

/* 0, or -EINVAL (a plan box too large for the grids even at their coarsest). */
int sim_explore_geometry(const sim_plan_t *plan, sim_explore_geom_t *g);

/* The path weight of the goal's utility (gp_goal.h: lambda, m^2 of unknown one metre of path is
 * worth), the same for every policy (they differ in what they count as unknown): the side of a
 * robot's share of the plan's box, sqrt(box / n_robots), over SIM_EXPLORE_LAMBDA_SIDE_M, at most
 * SIM_EXPLORE_LAMBDA_MAX. Where a robot's share is large there is unknown near it, and a goal
 * across the building is worth little: 0.5 sent 3 robots across office64 (a 509 m^2 share each)
 * past rooms nobody had seen, towards each other's wings. Where it is small, what is near it its
 * peers see too: 1 and 0.5 did better than 2 on the apartment and the generated plans (36-56 m^2
 * a robot) and with 7 robots (15 m^2). The rule gives 0.8-1.0 there, 0.52 for 7 robots and 3 on
 * office64, where 4 did worse (docs/exploration.md, "A path weight from the robot's share"). */
#define SIM_EXPLORE_LAMBDA_SIDE_M 7.5
#define SIM_EXPLORE_LAMBDA_MAX 3.0
double sim_explore_lambda(const sim_explore_geom_t *g, uint32_t n_robots);

/* The GP core's and the AI core's exploration configurations for robot `self` of n_peers,
 * with `boundaries` communication rounds over the budget (claims travel once per round: they
 * live a round and a half, at most 50 s). */
int sim_explore_gp_cfg(const sim_explore_geom_t *g, const sim_explore_opts_t *o, uint32_t self, uint32_t n_peers,
                       uint32_t boundaries, gp_explore_cfg_t *out);
/* The RT core's (rt/rt_explore.h): the fine grid, the seen view aligned with the goal grid,
 * the budget; rc->explore points at *out, rc's tour is cleared. */
int sim_explore_rt_cfg(const sim_explore_geom_t *g, const sim_explore_opts_t *o, rt_core_cfg_t *rc,
                       rt_explore_cfg_t *out);
void sim_explore_belief_cfg(const sim_plan_t *plan, const sim_explore_geom_t *g, ai_belief_cfg_t *out);

/* The RT core's keep-in fence (rt_explore.h): one byte per fine cell, 1 when the cell's centre
 * is in the building (a room, a door opening or a wall: sim_grid.h's rule), 0 outside it, where
 * the yards and courtyards a robot could drive to through the entrance are. The building's
 * outline is what a site gives a deployed robot as its geofence; the walls inside it stay the
 * robot's to find. inside: at least fine_w * fine_h bytes (n). 0, or -EINVAL. */
int sim_explore_keep_in(const sim_plan_t *plan, const sim_explore_geom_t *g, uint8_t *inside, size_t n);

/* Where robot `robot` of n_robots starts: the start of the tour `host_sim paths gen` would give
 * it (a room of its own while there are rooms enough), as a two-point path (the start and the
 * point it faces) for the world. 0, or a negative code with err filled. */
int sim_explore_start(const sim_plan_t *plan, uint64_t seed, int robot, int n_robots, sim_path_t *out, char *err,
                      size_t errlen);

/* explore.csv in a run's folder, a row per simulated second:
 *   sim_time_s,x_m,y_m,heading_rad,distance_m,goal_seq,goal_x_m,goal_y_m,goals_reached,goals_failed,
 *   stuck_events,plans,plan_failures,avoid_stops,finished,belief_unknown_mean,belief_unknown_max
 * (goal_* the GP core's current goal; NaN before the first; belief_*: the AI core's latest
 * belief grid, the mean unknown share in [0, 1] and the largest cell byte, 0 .. 255). A stuck event or a goal given up
 * is also said on stdout as it happens. */
typedef struct sim_explore_trace {
    FILE *f;
    int robot;
    uint32_t stuck_seen, failed_seen;
} sim_explore_trace_t;

int sim_explore_trace_open(sim_explore_trace_t *t, const char *dir, int robot);
/* sim_image_second_fn: user is the sim_explore_trace_t. */
void sim_explore_trace_row(uint64_t now_us, const rt_status_t *rt, const gp_core_t *gp, void *user);
/* 0, or -EIO when a row could not be written. */
int sim_explore_trace_close(sim_explore_trace_t *t);

/* summary.txt's exploration lines. */
void sim_explore_summary(FILE *f, const sim_explore_opts_t *o, const rt_status_t *rt, const gp_explore_stats_t *x,
                         const gp_goal_stats_t *claims, const gp_fleet_stats_t *fleet);

#endif /* SIM_EXPLORE_H */
