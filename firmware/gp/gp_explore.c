/* Exploration goals in the GP core: see gp_explore.h. */
#include "gp/gp_explore.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "common/mbox.h"

static const char *const policy_names[] = {"uncertainty", "frontier", "coordinated"};

int gp_explore_policy_parse(const char *name, gp_explore_policy_t *out)
{
    if (name == NULL || out == NULL)
        return -EINVAL;
    for (int i = 0; i < 3; i++)
        if (strcmp(name, policy_names[i]) == 0) {
            *out = (gp_explore_policy_t)i;
            return 0;
        }
    return -EINVAL;
}

const char *gp_explore_policy_name(gp_explore_policy_t p)
{
    return (unsigned)p < 3u ? policy_names[p] : "?";
}

int gp_explore_init(gp_explore_t *x, const gp_explore_cfg_t *cfg)
{
    if (x == NULL || cfg == NULL || (unsigned)cfg->policy > 2u || cfg->reselect_us == 0u ||
        cfg->goal.w * cfg->goal.h > RT_SEEN_MAX_CELLS)
        return -EINVAL;
    memset(x, 0, sizeof *x);
    x->cfg = *cfg;
    if (cfg->policy == GP_EXPLORE_FRONTIER) { /* each robot on its own: no claims out */
        x->cfg.goal.send = NULL;
        x->cfg.goal.send_ctx = NULL;
    }
    return gp_goal_init(&x->goal, &x->cfg.goal);
}

int gp_explore_on_claim(gp_explore_t *x, const gp_goal_claim_t *c, uint64_t now_us)
{
    if (x == NULL || c == NULL)
        return -EINVAL;
    if (x->cfg.policy == GP_EXPLORE_FRONTIER)
        return 0;
    const int r = gp_goal_on_claim(&x->goal, c, now_us);
    if (r == 0)
        x->claims_new = 1;
    return r;
}

/* 1 when the goal is chosen on the AI core's belief (the uncertainty policy, once one came). */
static int uses_belief(const gp_explore_t *x)
{
    return x->cfg.policy == GP_EXPLORE_UNCERTAINTY && x->have_belief;
}

/* The grid gp_goal_select sees (gp_explore.h): occ from the robot's own scans, unknown by
 * policy (the belief's fallback layer with `fallback`), nothing to learn on the spent cells. */
static void build_grid(gp_explore_t *x, int fallback)
{
    const uint32_t n = x->cfg.goal.w * x->cfg.goal.h;
    memcpy(x->grid.occ, x->seen.occ, n);
    const uint8_t *u = !uses_belief(x) ? x->seen.unknown : fallback ? x->belief.fallback : x->belief.unknown;
    /* On the belief, no more than our own scans left: what our lidar observed (and the fence:
       outside the building, the outer walls, the map's edge) the fleet's belief cannot hold
       unknown, however its 0.8 m counts or global features put it. */
    const uint8_t *own = x->seen.unknown;
    for (uint32_t i = 0; i < n; i++)
        x->grid.unknown[i] = x->spent[i] ? 0u : u[i] < own[i] ? u[i] : own[i];
}

/* What a look from the goal took in (gp_goal_look: its window, the cells behind walls our own
 * scans saw left out) is spent. The whole square spent the unseen room behind a wall beside a
 * goal in the corridor, and the robots that had stood there never went in. */
static int spend(gp_explore_t *x, uint32_t goal_cell)
{
    memcpy(x->grid.occ, x->seen.occ, x->cfg.goal.w * x->cfg.goal.h);
    return gp_goal_look(&x->goal, &x->grid, goal_cell, x->spent);
}

static int send_goal(gp_explore_t *x, const fw_link_t *link, uint32_t mode, float gx, float gy, uint64_t now_us)
{
    gp_goal_msg_t m = {now_us, ++x->seq, mode, gx, gy};
    x->stats.goals++;
    return mbox_put(link->gp_goal, &m);
}

int gp_explore_tick(gp_explore_t *x, const fw_link_t *link, const rt_status_t *rt, uint64_t now_us)
{
    if (x == NULL || link == NULL)
        return -EINVAL;
    const uint32_t w = x->cfg.goal.w, h = x->cfg.goal.h;
    int r = mbox_get(link->rt_seen, &x->seen, NULL);
    if (r < 0)
        return r;
    if (r == 1) {
        if (x->seen.w != w || x->seen.h != h) {
            x->stats.bad_inputs++;
            return -EINVAL;
        }
        x->have_seen = 1;
        x->stats.seen_updates++;
    }
    r = mbox_get(link->ai_belief, &x->belief, NULL);
    if (r < 0)
        return r;
    if (r == 1) {
        if (x->belief.w != w || x->belief.h != h) {
            x->stats.bad_inputs++;
            x->have_belief = 0;
            return -EINVAL;
        }
        x->have_belief = 1;
        x->stats.belief_updates++;
    }
    if (!x->have_seen || rt == NULL || x->stats.done)
        return 0;
    /* again every reselect period, and at once when a peer's claim holds against our goal
       (claims come at rounds, so robots that chose one goal together part within a round) */
    int again = x->seq == 0 || now_us - x->selected_us >= x->cfg.reselect_us ||
                (x->claims_new && gp_goal_contested(&x->goal, now_us));
    x->claims_new = 0;
    /* A goal reached or given up is spent: its surroundings count as nothing left to learn
       (the belief lags the robot by up to a belief period; a wall-locked goal stays one). */
    int spent = 0;
    if (x->seq != 0 && rt->goal_reached == x->seq && x->last_reached != x->seq) {
        x->last_reached = x->seq;
        x->stats.reached++;
        spent = 1;
    }
    if (x->seq != 0 && rt->goal_failed == x->seq && x->last_failed != x->seq) {
        x->last_failed = x->seq;
        x->stats.failed++;
        spent = 1;
    }
    if (spent) {
        r = spend(x, x->goal.goal.cell);
        if (r != 0)
            return r;
        again = 1;
    }
    if (!again) {
        gp_goal_poll(&x->goal, now_us); /* our claim again every period */
        return 0;
    }
    build_grid(x, 0);
    x->selected_us = now_us;
    x->stats.selections++;
    /* the pose clamped into the map: GPS noise at a wall may put it a hair outside */
    const double x0 = x->cfg.goal.origin_x_m, y0 = x->cfg.goal.origin_y_m, res = x->cfg.goal.res_m;
    double px = fmin(fmax((double)rt->x_m, x0 + 1e-6), x0 + (double)w * res - 1e-6);
    double py = fmin(fmax((double)rt->y_m, y0 + 1e-6), y0 + (double)h * res - 1e-6);
    gp_goal_pick_t pick;
    r = gp_goal_select(&x->goal, &x->grid, px, py, now_us, &pick);
    if (r == -ENOENT && uses_belief(x)) { /* the first layer has nothing left: the fallback */
        build_grid(x, 1);
        r = gp_goal_select(&x->goal, &x->grid, px, py, now_us, &pick);
        if (r == 0)
            x->stats.fallbacks++;
    }
    if (r == -EBUSY) /* all that is left is claimed by nearer peers: wait for the next choice */
        return 0;
    if (r == -ENOENT) {
        x->stats.done = 1;
        return send_goal(x, link, GP_GOAL_MSG_DONE, 0.0f, 0.0f, now_us);
    }
    if (r != 0)
        return r;
    const int reached_or_failed = x->seq != 0 && (x->last_reached == x->seq || x->last_failed == x->seq);
    if (x->seq != 0 && pick.cell == x->cell && !reached_or_failed)
        return 0; /* the same goal stands: the RT core keeps its path */
    x->cell = pick.cell;
    return send_goal(x, link, GP_GOAL_MSG_GO, (float)pick.x_m, (float)pick.y_m, now_us);
}
