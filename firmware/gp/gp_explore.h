/* The GP core's part of exploration: where the robot goes next (docs/exploration.md).
 *
 * Each GP tick, gp_explore_tick takes the newest inputs from the other cores (fw_link.h):
 *   seen    rt_seen_t from the RT core: its own lidar grid, coarse (occupancy of what it
 *           observed, and the share of each cell it never observed);
 *   belief  ai_belief_msg_t from the AI core: the model's coarse occupancy and the share of its
 *           prior (epistemic) variance left, the fleet's model as DiNNO made it;
 * and picks a goal with gp_goal_select (gp/gp_goal.h) on a grid made of
 *   occ      the seen grid's (what the robot's own lidar observed is what it can drive on;
 *            cells it never observed are open, as the planner takes them);
 *   unknown  by policy: GP_EXPLORE_UNCERTAINTY the belief's (the model's epistemic share, by
 *            default the larger of the posterior's and the counts' of where the fleet's rays
 *            went: ai/ai_seen.h; the seen grid's until the first belief arrives), and when that
 *            leaves nothing within reach, the belief's fallback layer (with the posterior
 *            first, where the first layer is the posterior's alone, the cells no ray reached;
 *            else the same layer again); either at most the seen grid's never-observed share,
 *            cell by cell: what our own lidar observed, and the fence and the map's edge, is
 *            not unknown whatever the coarse belief says;
 *            GP_EXPLORE_FRONTIER and GP_EXPLORE_COORDINATED the seen grid's never-observed
 *            share (frontier exploration on the robot's own scans, Yamauchi 1997;
 *            coordinated: with the peers' claims, Burgard et al. 2005);
 * and unknown 0 on every spent cell: what a look from each goal the RT core reached or gave up
 * takes in (gp_goal_look: the goal's window, less the cells behind walls the search from it
 * does not reach; rt_status_t.goal_reached, goal_failed: unreachable, or stuck there). A spent
 * goal is not chosen again: the belief lags the robot by a belief period, and a
 * goal the robot cannot get near (outside the building, inside a wall block: the coarse grid's
 * search may leak there, the RT core's planner then stops at the nearest reachable cell and
 * says reached) would otherwise be chosen again and again. A mask, not a list: however many
 * goals are spent, none comes back.
 * A goal is chosen again when the RT core reached or gave up the current one, when none is set,
 * every reselect_us (new information may make another goal better), and at once when a claim
 * taken holds against it (gp_goal_contested: robots that chose one goal together, as robots
 * sharing one belief do, part within a round instead of driving on side by side); a different
 * cell goes out to the RT core as a new goal (gp_goal_msg_t, seq + 1), the same cell does not.
 * Only goals nearer peers claimed (gp_goal_select's -EBUSY): the robot keeps its course and
 * chooses again later. Nothing left to learn within reach (-ENOENT, on the fallback too):
 * GP_GOAL_MSG_DONE.
 *
 * No I/O of its own besides the mailboxes; claims go out through gp_goal's send callback.
 * Storage: gp_explore_t (about 120 KB, inside gp_core_t), no allocation. One thread. */
#ifndef GP_GP_EXPLORE_H
#define GP_GP_EXPLORE_H

#include <stdint.h>

#include "ai/ai_link.h"
#include "fw_link.h"
#include "gp/gp_goal.h"
#include "gp/gp_link.h"
#include "rt/rt_link.h"

typedef enum gp_explore_policy {
    GP_EXPLORE_UNCERTAINTY = 0,
    GP_EXPLORE_FRONTIER = 1,
    GP_EXPLORE_COORDINATED = 2,
} gp_explore_policy_t;

typedef struct gp_explore_cfg {
    gp_goal_cfg_t goal;              /* geometry = the seen grid's and the belief's */
    gp_explore_policy_t policy;
    uint64_t reselect_us;            /* > 0: choose again this often */
} gp_explore_cfg_t;

typedef struct gp_explore_stats {
    uint64_t selections;             /* gp_goal_select calls */
    uint64_t goals;                  /* goals sent (seq) */
    uint64_t reached, failed;        /* reported by the RT core */
    uint64_t fallbacks;              /* goals chosen on the belief's fallback layer */
    uint64_t belief_updates, seen_updates;
    uint64_t bad_inputs;             /* a seen grid or belief of another geometry (never expected) */
    uint32_t done;                   /* 1: nothing left, GP_GOAL_MSG_DONE sent */
} gp_explore_stats_t;

typedef struct gp_explore {
    gp_explore_cfg_t cfg;
    gp_goal_t goal;
    gp_goal_grid_t grid;
    rt_seen_t seen;
    ai_belief_msg_t belief;
    int have_seen, have_belief;
    uint32_t seq;                    /* of the goal last sent (0: none) */
    uint32_t cell;                   /* its cell */
    uint64_t selected_us;
    int claims_new;                  /* 1: a claim was taken since the last choice */
    uint32_t last_reached, last_failed;
    uint8_t spent[GP_GOAL_MAX_CELLS]; /* 1: nothing left to learn there for us (above) */
    gp_explore_stats_t stats;
} gp_explore_t;

/* "uncertainty", "frontier", "coordinated" -> policy; 0 or -EINVAL. */
FS_MUST_CHECK int gp_explore_policy_parse(const char *name, gp_explore_policy_t *out);
const char *gp_explore_policy_name(gp_explore_policy_t p);

/* Validates cfg (gp_goal_init's checks, the geometry within RT_SEEN_MAX_CELLS) and resets x.
 * The frontier policy sends no claims (cfg->goal.send is ignored). 0 or -EINVAL. */
FS_MUST_CHECK int gp_explore_init(gp_explore_t *x, const gp_explore_cfg_t *cfg);

/* One GP tick (above). rt: the latest RT status (the pose, the goal reached or given up), or
 * NULL before the first. 0, or a negative code counted by the caller (a mailbox broken). */
FS_MUST_CHECK int gp_explore_tick(gp_explore_t *x, const fw_link_t *link, const rt_status_t *rt, uint64_t now_us);

/* A peer's claim (coordinated and uncertainty policies): gp_goal_on_claim's codes; the
 * frontier policy ignores claims (0). */
FS_MUST_CHECK int gp_explore_on_claim(gp_explore_t *x, const gp_goal_claim_t *c, uint64_t now_us);

#endif /* GP_GP_EXPLORE_H */
