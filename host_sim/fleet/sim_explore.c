/* Exploration settings from the plan: see sim_explore.h. */
#include "sim_explore.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sim_grid.h"

int sim_explore_geometry(const sim_plan_t *plan, sim_explore_geom_t *g)
{
    if (plan == NULL || g == NULL)
        return -EINVAL;
    const double wx = plan->max.x - plan->min.x, wy = plan->max.y - plan->min.y;
    if (!(wx > 0) || !(wy > 0) || !isfinite(wx) || !isfinite(wy))
        return -EINVAL;
    memset(g, 0, sizeof *g);
    for (int cm = 5; cm <= 100; cm++) { /* 0.05 m .. 1 m in centimetre steps */
        const double res = cm * 0.01;
        const double fw = ceil(wx / res), fh = ceil(wy / res);
        if (fw > RT_GRID_MAX_SIDE || fh > RT_GRID_MAX_SIDE || fw * fh > RT_GRID_MAX_CELLS)
            continue;
        g->fine_res_m = (float)res;
        g->fine_w = (int32_t)fw;
        g->fine_h = (int32_t)fh;
        const uint32_t side = (uint32_t)(fw > fh ? fw : fh);
        g->factor = (side + GP_GOAL_MAX_W - 1u) / GP_GOAL_MAX_W;
        g->w = ((uint32_t)fw + g->factor - 1u) / g->factor;
        g->h = ((uint32_t)fh + g->factor - 1u) / g->factor;
        g->origin_x_m = (float)plan->min.x;
        g->origin_y_m = (float)plan->min.y;
        return 0;
    }
    return -EINVAL;
}

double sim_explore_lambda(const sim_explore_geom_t *g, uint32_t n_robots)
{
    const double side_m = sqrt((double)g->fine_w * g->fine_h / (n_robots > 0 ? n_robots : 1u)) * g->fine_res_m;
    return fmin(side_m / SIM_EXPLORE_LAMBDA_SIDE_M, SIM_EXPLORE_LAMBDA_MAX);
}

int sim_explore_gp_cfg(const sim_explore_geom_t *g, const sim_explore_opts_t *o, uint32_t self, uint32_t n_peers,
                       uint32_t boundaries, gp_explore_cfg_t *out)
{
    if (g == NULL || o == NULL || out == NULL || boundaries < 1 || !(o->budget_s > 0))
        return -EINVAL;
    memset(out, 0, sizeof *out);
    gp_goal_cfg_t *c = &out->goal;
    c->self = self;
    c->n_peers = n_peers;
    c->w = g->w;
    c->h = g->h;
    c->res_m = (double)g->fine_res_m * g->factor;
    c->origin_x_m = g->origin_x_m;
    c->origin_y_m = g->origin_y_m;
    c->occ_max = 128;           /* more than half of what the lidar saw there was wall */
    c->sensor_radius_m = 2.5;   /* what a visit reveals: inside the 3.5 m lidar's reach, walls aside */
    c->lambda = sim_explore_lambda(g, n_peers);
    /* The goal held counts 8 m nearer: the coarse search's cost to it can grow while the robot
       follows the RT core's finer path round a wall the 0.8 m cells do not hold, and another goal
       then won at the next reselect. On office64 a robot drove back and forth in one corridor for
       1,600 s between two goals it never reached (docs/exploration.md, "A path weight from the
       robot's share, and the goal held"). */
    c->keep_m = 8.0;
    /* The uncertainty policy on the fleet's posterior: what is left late is small pockets
       (0.5 m^2 stopped 7 robots at 0.93 coverage, 0.2 m^2 at 0.997), and robots sharing one
       belief would follow a kept claim at x 0.1, so its cells are removed for the others. */
    c->min_info_m2 = o->policy == GP_EXPLORE_UNCERTAINTY ? 0.2 : 0.5;
    c->claim_radius_m = 2.0;
    c->claim_discount = o->policy == GP_EXPLORE_UNCERTAINTY ? 0.0 : 0.1;
    /* What a kept claim's robot will see is not the others' to learn: robots sharing one belief
       otherwise chose goals just beyond the claim radius and drove in a pack. Measured with 3
       robots on the apartment and three generated plans, 6 seeds each (docs/explore_window.csv):
       2, 3 and 4 m all helped the uncertainty policy; 3 m, inside the lidar's 3.5 m, was the one
       good on all four plans. Coordinated frontier gains from it too (Burgard's utility
       reduction of what the assigned robot sees), so its baseline has it as well. */
    c->claim_window_m = 3.0;
    /* What a look from a cell takes in is what lies on its side of the walls the robot has seen:
       summed over the square alone, the cells beside a wall looked into the room behind it,
       whose door was elsewhere, and robots went to stand there again and again while their
       peers waited on their claims (docs/exploration.md: 3 robots, six seeds on four plans,
       24 to 40 % fewer robot-seconds to 95 % with every policy). */
    c->info_by_path = 1;
    c->claim_tie_m = 1.0;       /* the claims' costs are path lengths on 0.2-0.5 m cells */
    c->claim_speed_mps = 0.2;   /* a robot heading for its goal, a little under v_max (0.22) */
    const double life_s = fmin(1.5 * o->budget_s / boundaries, 50.0);
    c->claim_lifetime_us = (uint64_t)llround(fmax(life_s, 2.0) * 1e6);
    c->claim_period_us = c->claim_lifetime_us / 2u; /* gp_goal's own resend; the fleet sends per round */
    c->claim_max_lifetime_us = GP_GOAL_MAX_LIFETIME_US;
    out->policy = o->policy;
    out->reselect_us = 10000000u; /* between goals reached: new information may make another better */
    return 0;
}

int sim_explore_rt_cfg(const sim_explore_geom_t *g, const sim_explore_opts_t *o, rt_core_cfg_t *rc,
                       rt_explore_cfg_t *out)
{
    if (g == NULL || o == NULL || rc == NULL || out == NULL || !(o->budget_s > 0))
        return -EINVAL;
    *out = rt_explore_default_cfg();
    out->res_m = g->fine_res_m;
    out->origin_x_m = g->origin_x_m;
    out->origin_y_m = g->origin_y_m;
    out->w = g->fine_w;
    out->h = g->fine_h;
    out->seen_factor = g->factor;
    out->seen_w = g->w;
    out->seen_h = g->h;
    out->budget_us = (uint64_t)llround(o->budget_s * 1e6);
    rc->explore = out;
    rc->waypoints = NULL;
    rc->n_waypoints = 0;
    return rt_explore_check_cfg(out);
}

void sim_explore_belief_cfg(const sim_plan_t *plan, const sim_explore_geom_t *g, ai_belief_cfg_t *out)
{
    memset(out, 0, sizeof *out);
    out->w = g->w;
    out->h = g->h;
    out->res_m = g->fine_res_m * (float)g->factor;
    out->origin_x_m = g->origin_x_m;
    out->origin_y_m = g->origin_y_m;
    out->min_x = (float)plan->min.x;
    out->min_y = (float)plan->min.y;
    out->max_x = (float)plan->max.x;
    out->max_y = (float)plan->max.y;
}

/* While sim_explore_keep_in works: a wall cell (1 in what it returns, unless an outer wall's),
 * and one going outside in this sweep. */
#define WALL 2u
#define GOING 3u
/* How deep into the walls the outside goes: a little over the thickest outer wall of the plans
 * (CubiCasa5K's 0.2-0.3 m). */
#define OUTER_WALL_M 0.4

int sim_explore_keep_in(const sim_plan_t *plan, const sim_explore_geom_t *g, uint8_t *inside, size_t n)
{
    if (plan == NULL || g == NULL || inside == NULL || g->fine_w < 1 || g->fine_h < 1 ||
        (size_t)g->fine_w * (size_t)g->fine_h > n)
        return -EINVAL;
    const int32_t w = g->fine_w, h = g->fine_h;
    for (int32_t r = 0; r < h; r++)
        for (int32_t c = 0; c < w; c++) {
            const double x = g->origin_x_m + ((double)c + 0.5) * g->fine_res_m;
            const double y = g->origin_y_m + ((double)r + 0.5) * g->fine_res_m;
            const int k = sim_plan_classify_point(plan, x, y);
            inside[(size_t)r * (size_t)w + (size_t)c] = k == SIM_CELL_OUTSIDE ? 0u : k == SIM_CELL_WALL ? WALL : 1u;
        }
    /* The outer walls go outside too: the wall cells within OUTER_WALL_M of the outside (or the
       grid's edge) through wall cells. A lidar sees a wall's face, never its inside, so an outer
       wall's cells would stay unobserved for ever and look like the edge of something unexplored
       to every policy (robots drove along office64's outer walls for minutes to look at them).
       Each sweep moves the outside one cell into the walls (GOING, then out once the sweep is
       done, so the depth is counted in cells); an inner wall joining the outer one loses its end. */
    const int sweeps = (int)ceil(OUTER_WALL_M / g->fine_res_m);
    for (int s = 0; s < sweeps; s++) {
        for (int32_t r = 0; r < h; r++)
            for (int32_t c = 0; c < w; c++) {
                uint8_t *v = &inside[(size_t)r * (size_t)w + (size_t)c];
                if (*v != WALL)
                    continue;
                int out = 0;
                for (int32_t dr = -1; dr <= 1 && !out; dr++)
                    for (int32_t dc = -1; dc <= 1 && !out; dc++) {
                        const int32_t rr = r + dr, cc = c + dc;
                        out = rr < 0 || rr >= h || cc < 0 || cc >= w || inside[(size_t)rr * (size_t)w + (size_t)cc] == 0u;
                    }
                if (out)
                    *v = GOING;
            }
        for (size_t i = 0; i < (size_t)w * (size_t)h; i++)
            inside[i] = inside[i] == GOING ? 0u : inside[i];
    }
    for (size_t i = 0; i < (size_t)w * (size_t)h; i++)
        inside[i] = inside[i] != 0u;
    return 0;
}

int sim_explore_start(const sim_plan_t *plan, uint64_t seed, int robot, int n_robots, sim_path_t *out, char *err,
                      size_t errlen)
{
    if (plan == NULL || out == NULL || robot < 0 || n_robots < 1 || robot >= n_robots ||
        n_robots > SIM_PATHS_MAX_ROBOTS) {
        snprintf(err, errlen, "explore: robot %d of %d: bad arguments", robot, n_robots);
        return -EINVAL;
    }
    sim_paths_cfg_t pc;
    sim_paths_cfg_default(&pc);
    pc.n_robots = n_robots;
    pc.seed = seed;
    sim_path_t *all = calloc((size_t)n_robots, sizeof *all);
    if (all == NULL) {
        snprintf(err, errlen, "explore: out of memory");
        return -ENOMEM;
    }
    int rc = sim_paths_generate(plan, &pc, all, err, errlen);
    if (rc == 0 && all[robot].n < 2) {
        snprintf(err, errlen, "explore: robot %d has no start pose in this plan", robot);
        rc = -ENOENT;
    }
    if (rc == 0) {
        *out = all[robot];
        out->n = 2; /* the start and the point it faces; the rest of the tour is not driven */
        sim_path_init(&all[robot]);
    }
    for (int i = 0; i < n_robots; i++)
        sim_path_free(&all[i]);
    free(all);
    return rc;
}

int sim_explore_trace_open(sim_explore_trace_t *t, const char *dir, int robot)
{
    memset(t, 0, sizeof *t);
    t->robot = robot;
    char file[4096];
    int n = snprintf(file, sizeof file, "%s/explore.csv", dir);
    if (n < 0 || (size_t)n >= sizeof file)
        return -ENAMETOOLONG;
    t->f = fopen(file, "w");
    if (t->f == NULL)
        return -errno;
    fprintf(t->f, "sim_time_s,x_m,y_m,heading_rad,distance_m,goal_seq,goal_x_m,goal_y_m,goals_reached,goals_failed,"
                  "stuck_events,plans,plan_failures,avoid_stops,finished,belief_unknown_mean,belief_unknown_max\n");
    return 0;
}

void sim_explore_trace_row(uint64_t now_us, const rt_status_t *rt, const gp_core_t *gp, void *user)
{
    sim_explore_trace_t *t = user;
    if (t == NULL || t->f == NULL)
        return;
    const gp_explore_t *x = &gp->explore;
    const int has = x->goal.has_goal;
    const double t_s = (double)now_us * 1e-6;
    uint32_t umax = 0;
    for (uint32_t i = 0; x->have_belief && i < x->belief.w * x->belief.h; i++)
        umax = x->belief.unknown[i] > umax ? x->belief.unknown[i] : umax;
    fprintf(t->f, "%.1f,%.4f,%.4f,%.4f,%.3f,%u,%.3f,%.3f,%llu,%llu,%u,%u,%u,%u,%u,%.4f,%u\n", t_s, (double)rt->x_m,
            (double)rt->y_m, (double)rt->heading_rad, (double)rt->distance_m, x->seq,
            has ? x->goal.goal.x_m : NAN, has ? x->goal.goal.y_m : NAN, (unsigned long long)x->stats.reached,
            (unsigned long long)x->stats.failed, rt->stuck_events, rt->plans, rt->plan_failures, rt->avoid_stops,
            rt->finished, x->have_belief ? (double)x->belief.unknown_mean : NAN, umax);
    if (rt->stuck_events > t->stuck_seen)
        printf("explore: robot %d stuck near (%.2f, %.2f) at %.0f s (%u so far): backing off and re-planning\n",
               t->robot, (double)rt->x_m, (double)rt->y_m, t_s, rt->stuck_events);
    if (x->stats.failed > t->failed_seen)
        printf("explore: robot %d gave up goal %u (unreachable or stuck there) at %.0f s; choosing another\n",
               t->robot, rt->goal_failed, t_s);
    t->stuck_seen = rt->stuck_events;
    t->failed_seen = (uint32_t)x->stats.failed;
}

int sim_explore_trace_close(sim_explore_trace_t *t)
{
    if (t->f == NULL)
        return 0;
    const int bad = ferror(t->f);
    const int rc = fclose(t->f);
    t->f = NULL;
    return bad || rc != 0 ? -EIO : 0;
}

void sim_explore_summary(FILE *f, const sim_explore_opts_t *o, const rt_status_t *rt, const gp_explore_stats_t *x,
                         const gp_goal_stats_t *claims, const gp_fleet_stats_t *fleet)
{
    char fell[96] = "";
    char tight[64] = "";
    if (rt->tight_plans > 0)
        snprintf(tight, sizeof tight, ", %u through a door only the tight band passes", rt->tight_plans);
    if (x->fallbacks > 0)
        snprintf(fell, sizeof fell, ", %llu chosen on the counts when the posterior had nothing left",
                 (unsigned long long)x->fallbacks);
    fprintf(f, "explore: policy %s, %.0f s budget, %s, belief from %s%s; %llu goals (%llu reached, %llu given up)%s%s; "
               "%u plans (%u failed%s); %u stuck events; %u avoidance stops\n",
            gp_explore_policy_name(o->policy), o->budget_s, o->no_fence ? "no fence" : "fenced into the building",
            fleet != NULL && !o->own_posterior ? "the fleet's posterior" : "its own posterior",
            !o->counts ? "" : fleet != NULL && !o->own_posterior ? " and counts" : " and its own counts",
            (unsigned long long)x->goals,
            (unsigned long long)x->reached, (unsigned long long)x->failed, fell,
            x->done ? ", then nothing left to learn within reach" : "", rt->plans, rt->plan_failures, tight,
            rt->stuck_events, rt->avoid_stops);
    if (fleet != NULL && o->policy != GP_EXPLORE_FRONTIER)
        fprintf(f, "claims: %llu sent, %llu received, %llu taken; refused: %llu invalid, %llu late, %llu reordered, "
                   "%llu duplicates, %llu table full; %llu expired\n",
                (unsigned long long)fleet->claims_sent, (unsigned long long)fleet->claims_received,
                (unsigned long long)claims->claims_taken, (unsigned long long)claims->claims_invalid,
                (unsigned long long)claims->claims_late, (unsigned long long)claims->claims_reordered,
                (unsigned long long)claims->claims_duplicate, (unsigned long long)claims->claims_full,
                (unsigned long long)claims->claims_expired);
}
