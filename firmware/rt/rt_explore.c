/* Exploration mode of the RT core: see rt_explore.h for the rules. */
#include "rt/rt_explore.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <string.h>

#define OCC_FIRST 128u /* a cell's occ before its first update: P = 0.5 */
#define MARK_MISS 1u
#define MARK_HIT 2u
#define MARK_FENCE 3u /* outside the keep-in fence: above any scan's mark, never cleared */
/* Lattice coordinates beyond this (in cells) are not traced: far outside any grid, and
 * floorf of them would no longer fit an int32_t. */
#define LATTICE_LIMIT 1.0e6f

rt_explore_cfg_t rt_explore_default_cfg(void)
{
    rt_explore_cfg_t c;
    memset(&c, 0, sizeof c);
    c.plan = rt_plan_default_cfg();
    c.plan.flags = RT_PLAN_NEAREST_GOAL;
    c.plan.unknown_is_obstacle = 0;
    c.avoid = rt_avoid_default_cfg();
    c.stuck_window_s = 4.0f;
    c.stuck_dist_m = 0.05f;
    c.max_stuck = 3;
    c.backoff_s = 1.0f;
    c.backoff_v_mps = -0.05f;
    c.backoff_omega_rps = 0.3f;
    c.reach_goal_m = 0.3f;
    c.budget_us = 0;
    c.occ_hit = 64;
    c.occ_miss = 16;
    return c;
}

static int pos_finite(float v) { return isfinite(v) && v > 0.0f; }

int rt_explore_check_cfg(const rt_explore_cfg_t *c)
{
    if (c == NULL)
        return -EINVAL;
    if (!pos_finite(c->res_m) || !isfinite(c->origin_x_m) || !isfinite(c->origin_y_m) ||
        c->w < 1 || c->h < 1)
        return -EINVAL;
    if (c->w > RT_GRID_MAX_SIDE || c->h > RT_GRID_MAX_SIDE || c->w * c->h > RT_GRID_MAX_CELLS)
        return -ENOSPC;
    if (c->seen_factor < 1 || c->seen_factor > (uint32_t)RT_GRID_MAX_SIDE || c->seen_w < 1 ||
        c->seen_h < 1 || c->seen_w > RT_EXPLORE_SEEN_MAX_SIDE ||
        c->seen_h > RT_EXPLORE_SEEN_MAX_SIDE)
        return -EINVAL;
    const rt_plan_cfg_t *p = &c->plan;
    /* The planner validates the rest of its cfg on every call; exploration needs these two. */
    if (p->flags != RT_PLAN_NEAREST_GOAL || p->unknown_is_obstacle != 0 ||
        !pos_finite(p->robot_radius_m) || !isfinite(p->margin_m) || p->margin_m < 0.0f ||
        !isfinite(p->k_clear_m) || p->k_clear_m < 0.0f || p->occ_threshold == 0)
        return -EINVAL;
    const rt_avoid_cfg_t *a = &c->avoid;
    if (!pos_finite(a->stop_dist_m) || !isfinite(a->slow_dist_m) ||
        !(a->slow_dist_m > a->stop_dist_m) || !pos_finite(a->half_angle_rad) ||
        a->half_angle_rad > 3.14159265f)
        return -EINVAL;
    /* Windows are turned into microseconds: keep them below an hour. */
    if (!pos_finite(c->stuck_window_s) || c->stuck_window_s > 3600.0f ||
        !pos_finite(c->stuck_dist_m) || c->max_stuck < 1 || !pos_finite(c->backoff_s) ||
        c->backoff_s > 3600.0f || !isfinite(c->backoff_v_mps) || !(c->backoff_v_mps < 0.0f) ||
        !isfinite(c->backoff_omega_rps) || !pos_finite(c->reach_goal_m) || c->occ_hit == 0 ||
        c->occ_miss == 0)
        return -EINVAL;
    return 0;
}

int rt_explore_init(rt_explore_t *x, const rt_explore_cfg_t *cfg)
{
    if (x == NULL)
        return -EINVAL;
    int r = rt_explore_check_cfg(cfg);
    if (r != 0)
        return r;
    /* Only the small part is cleared: the workspace is scratch, the grid is reset below. */
    memset(x, 0, offsetof(rt_explore_t, grid));
    x->cfg = *cfg;
    x->state = RT_EXPLORE_IDLE;
    memset(x->mark, 0, sizeof x->mark);
    r = rt_grid_init(&x->grid, cfg->res_m, cfg->origin_x_m, cfg->origin_y_m, cfg->w, cfg->h);
    if (r != 0 || cfg->keep_in == NULL)
        return r;
    for (int32_t i = 0; i < cfg->w * cfg->h; i++)
        if (cfg->keep_in[i] == 0u) {
            x->grid.occ[i] = 255u;
            x->grid.known[i] = 255u;
            x->mark[i] = MARK_FENCE;
            x->fenced++;
        }
    x->grid_dirty = x->fenced > 0u; /* the GP core's first seen view has the fence */
    x->cfg.keep_in = NULL;           /* read here only: the caller's buffer may go */
    return 0;
}

int rt_explore_clock(rt_explore_t *x, uint64_t now_us)
{
    if (x == NULL)
        return -EINVAL;
    if (!x->started) {
        x->started = 1;
        x->first_us = now_us;
    }
    if (x->state == RT_EXPLORE_DONE)
        return 1;
    if (x->cfg.budget_us > 0 && now_us >= x->first_us && now_us - x->first_us >= x->cfg.budget_us) {
        x->state = RT_EXPLORE_DONE;
        return 1;
    }
    return 0;
}

/* ---- scan integration --------------------------------------------------------------------- */

static void mark_cell(rt_explore_t *x, int32_t c, int32_t r, uint8_t m)
{
    if (c < 0 || r < 0 || c >= x->grid.w || r >= x->grid.h)
        return;
    uint8_t *p = &x->mark[r * x->grid.w + c];
    if (m > *p)
        *p = m; /* a hit of this scan wins over its misses */
}

/* Amanatides & Woo: every lattice cell the segment from (px, py) along angle a for len metres
 * passes through, the end cell marked `end`, the others missed. */
static void trace_beam(rt_explore_t *x, float px, float py, float a, float len, uint8_t end)
{
    const rt_grid_t *g = &x->grid;
    float dx = cosf(a), dy = sinf(a);
    float fx = (px - g->origin_x) / g->res, fy = (py - g->origin_y) / g->res;
    float ex = fx + dx * len / g->res, ey = fy + dy * len / g->res;
    if (!(fabsf(fx) < LATTICE_LIMIT && fabsf(fy) < LATTICE_LIMIT && fabsf(ex) < LATTICE_LIMIT &&
          fabsf(ey) < LATTICE_LIMIT))
        return;
    int32_t cx = (int32_t)floorf(fx), cy = (int32_t)floorf(fy);
    const int32_t ecx = (int32_t)floorf(ex), ecy = (int32_t)floorf(ey);
    const int32_t sx = dx > 0.0f ? 1 : -1, sy = dy > 0.0f ? 1 : -1;
    /* Parameter t along the beam in cells; INFINITY on an axis the beam does not move along. */
    float tdx = dx != 0.0f ? 1.0f / fabsf(dx) : INFINITY;
    float tdy = dy != 0.0f ? 1.0f / fabsf(dy) : INFINITY;
    float tx = dx != 0.0f ? (dx > 0.0f ? ((float)cx + 1.0f - fx) : (fx - (float)cx)) * tdx : INFINITY;
    float ty = dy != 0.0f ? (dy > 0.0f ? ((float)cy + 1.0f - fy) : (fy - (float)cy)) * tdy : INFINITY;
    const float tend = len / g->res;
    /* A straight walk visits exactly |dcx| + |dcy| + 1 cells; the bound only guards against
     * rounding walking past the end cell. */
    int32_t steps = (ecx > cx ? ecx - cx : cx - ecx) + (ecy > cy ? ecy - cy : cy - ecy) + 2;
    while (steps-- > 0 && !(cx == ecx && cy == ecy)) {
        mark_cell(x, cx, cy, MARK_MISS);
        if (tx < ty) {
            if (tx > tend)
                break;
            cx += sx;
            tx += tdx;
        } else {
            if (ty > tend)
                break;
            cy += sy;
            ty += tdy;
        }
    }
    mark_cell(x, ecx, ecy, end);
}

int rt_explore_integrate_scan(rt_explore_t *x, const rt_scan_view_t *scan, float px, float py,
                              float ptheta, uint64_t stamp_us)
{
    if (x == NULL || scan == NULL || scan->ranges == NULL || !isfinite(px) || !isfinite(py) ||
        !isfinite(ptheta) || scan->n_scan < 1 || !isfinite(scan->angle_min) ||
        !isfinite(scan->angle_inc) || !pos_finite(scan->range_max))
        return -EINVAL;
    for (int32_t i = 0; i < scan->n_scan; i++) {
        float r = scan->ranges[i];
        if (isnan(r) || r < 0.0f)
            continue; /* dropout: the sensor said nothing */
        int hit = r < scan->range_max; /* +INF and r >= range_max: free up to range_max */
        float len = hit ? r : scan->range_max;
        float a = ptheta + scan->angle_min + (float)i * scan->angle_inc;
        trace_beam(x, px, py, a, len, hit ? MARK_HIT : MARK_MISS);
    }
    /* One update per touched cell: the count of beams through a cell (many near the robot)
     * must not weigh its evidence. */
    rt_grid_t *g = &x->grid;
    const int32_t n = g->w * g->h;
    const uint8_t hit_step = x->cfg.occ_hit, miss_step = x->cfg.occ_miss;
    int32_t changed = 0;
    for (int32_t i = 0; i < n; i++) {
        uint8_t m = x->mark[i];
        if (m == 0 || m == MARK_FENCE)
            continue;
        x->mark[i] = 0;
        unsigned occ = g->known[i] ? g->occ[i] : OCC_FIRST;
        if (m == MARK_HIT)
            occ = occ + hit_step > 255u ? 255u : occ + hit_step;
        else
            occ = occ < miss_step ? 0u : occ - miss_step;
        uint8_t known = g->known[i] == 255u ? 255u : (uint8_t)(g->known[i] + 1u);
        if ((uint8_t)occ != g->occ[i] || known != g->known[i])
            changed++;
        g->occ[i] = (uint8_t)occ;
        g->known[i] = known;
    }
    x->scans_integrated++;
    x->path_check = 1;
    if (changed > 0) {
        x->grid_dirty = 1;
        x->grid_stamp_us = stamp_us;
    }
    return changed;
}

/* ---- driving ------------------------------------------------------------------------------ */

static int is_obstacle(const rt_explore_t *x, int32_t i)
{
    return x->grid.known[i] != 0 && x->grid.occ[i] >= x->cfg.plan.occ_threshold;
}

/* 1 when an obstacle cell's centre lies within robot_radius_m + margin_m / 2 + half a cell
 * diagonal of (px, py): its square then comes closer than radius + margin / 2. A fresh plan
 * keeps every obstacle centre at least radius + margin + half a diagonal away (rt_plan.h), so
 * it never trips this, and a path that does trip it has lost half its margin. A tight plan
 * (RT_PLAN_TIGHT) keeps them radius + margin + (1 - 1/sqrt(2)) cells away, and is held to
 * radius + margin / 2 + that. */
static int point_blocked(const rt_explore_t *x, float px, float py)
{
    const rt_grid_t *g = &x->grid;
    const float rad = x->cfg.plan.robot_radius_m + 0.5f * x->cfg.plan.margin_m +
                      (x->tight ? 0.29289322f : 0.70710678f) * g->res;
    int32_t c0 = (int32_t)floorf((px - rad - g->origin_x) / g->res);
    int32_t c1 = (int32_t)floorf((px + rad - g->origin_x) / g->res);
    int32_t r0 = (int32_t)floorf((py - rad - g->origin_y) / g->res);
    int32_t r1 = (int32_t)floorf((py + rad - g->origin_y) / g->res);
    c0 = c0 < 0 ? 0 : c0;
    r0 = r0 < 0 ? 0 : r0;
    c1 = c1 >= g->w ? g->w - 1 : c1;
    r1 = r1 >= g->h ? g->h - 1 : r1;
    for (int32_t r = r0; r <= r1; r++)
        for (int32_t c = c0; c <= c1; c++) {
            if (!is_obstacle(x, r * g->w + c))
                continue;
            float cxm, cym;
            rt_grid_cell_centre(g, c, r, &cxm, &cym);
            if ((cxm - px) * (cxm - px) + (cym - py) * (cym - py) <= rad * rad)
                return 1;
        }
    return 0;
}

/* The remaining path, from the waypoint before the one aimed at, sampled every half cell. */
static int path_blocked(const rt_explore_t *x)
{
    const rt_plan_result_t *p = &x->plan_res;
    if (p->n_wps < 1)
        return 0;
    int32_t from = x->follow.index > 0 ? x->follow.index - 1 : 0;
    if (from >= p->n_wps)
        return 0;
    if (point_blocked(x, p->wps[from].x, p->wps[from].y))
        return 1;
    const float step = 0.5f * x->grid.res;
    for (int32_t s = from; s + 1 < p->n_wps; s++) {
        float ax = p->wps[s].x, ay = p->wps[s].y;
        float bx = p->wps[s + 1].x, by = p->wps[s + 1].y;
        float len = hypotf(bx - ax, by - ay);
        int32_t k = (int32_t)ceilf(len / step);
        for (int32_t j = 1; j <= k; j++) {
            float t = (float)j / (float)k;
            if (point_blocked(x, ax + t * (bx - ax), ay + t * (by - ay)))
                return 1;
        }
    }
    return 0;
}

static void give_up(rt_explore_t *x)
{
    x->goal_failed = x->goal_seq;
    x->state = RT_EXPLORE_IDLE;
}

/* The distance from the end of plan p to the goal, m. */
static float end_to_goal(const rt_explore_t *x, const rt_plan_result_t *p)
{
    return hypotf(p->wps[p->n_wps - 1].x - x->goal_x, p->wps[p->n_wps - 1].y - x->goal_y);
}

/* Plans from the pose to the goal: DRIVE on success, the goal given up on any failure. When
 * the band closes the way to the goal (RT_PLAN_GOAL_MOVED), the tight band is tried and taken
 * when it ends more than a cell nearer the goal: a door the robot came in through, narrower in
 * its grid than the full band passes, lets it out again (rt_plan.h). */
static void plan_to_goal(rt_explore_t *x, float px, float py, const rt_follow_cfg_t *follow)
{
    x->plans++;
    x->window_set = 0; /* a new path starts a new stuck window */
    x->path_check = 0;
    x->tight = 0;
    int r = rt_plan_path(&x->grid, &x->cfg.plan, px, py, x->goal_x, x->goal_y, &x->ws,
                         &x->plan_res);
    if (r == 0 && (x->plan_res.flags & RT_PLAN_GOAL_MOVED) != 0) {
        /* into plan_res itself (no second result in the RT core's RAM): the full band's plan
           again when the tight one is no better */
        const float full_end = end_to_goal(x, &x->plan_res);
        rt_plan_cfg_t tight = x->cfg.plan;
        tight.flags |= RT_PLAN_TIGHT;
        if (rt_plan_path(&x->grid, &tight, px, py, x->goal_x, x->goal_y, &x->ws, &x->plan_res) == 0 &&
            end_to_goal(x, &x->plan_res) < full_end - x->grid.res) {
            x->tight = 1;
            x->tight_plans++;
        } else {
            r = rt_plan_path(&x->grid, &x->cfg.plan, px, py, x->goal_x, x->goal_y, &x->ws, &x->plan_res);
        }
    }
    if (r == 0)
        r = rt_follow_init(&x->follow, follow);
    if (r != 0) {
        x->plan_failures++;
        x->plan_res.n_wps = 0;
        give_up(x);
        return;
    }
    x->state = RT_EXPLORE_DRIVE;
}

static float clampf(float v, float lo, float hi) { return v < lo ? lo : (v > hi ? hi : v); }

static void new_goal(rt_explore_t *x, const gp_goal_msg_t *goal, float px, float py,
                     const rt_follow_cfg_t *follow)
{
    x->goal_seq = goal->seq;
    x->goal_stuck = 0;
    if (!isfinite(goal->x_m) || !isfinite(goal->y_m)) {
        x->plan_failures++;
        give_up(x);
        return;
    }
    /* Inside the grid, so the planner's NEAREST_GOAL takes over from there. */
    const rt_grid_t *g = &x->grid;
    float lo_x, lo_y, hi_x, hi_y;
    rt_grid_cell_centre(g, 0, 0, &lo_x, &lo_y);
    rt_grid_cell_centre(g, g->w - 1, g->h - 1, &hi_x, &hi_y);
    x->goal_x = clampf(goal->x_m, lo_x, hi_x);
    x->goal_y = clampf(goal->y_m, lo_y, hi_y);
    plan_to_goal(x, px, py, follow);
}

/* Wheel rates of (v, omega) under the follower's limit, then the reactive filter. */
static int command(rt_explore_t *x, const rt_follow_cfg_t *follow, const rt_scan_view_t *scan,
                   rt_follow_cmd_t *cmd)
{
    int r = rt_follow_wheels(cmd->v, cmd->omega, follow->wheel_radius, follow->wheel_separation,
                             follow->v_max / follow->wheel_radius, &cmd->wheel_left,
                             &cmd->wheel_right);
    if (r != 0)
        return r;
    if (scan == NULL)
        return 0;
    r = rt_avoid_apply(&x->cfg.avoid, follow, scan, cmd, NULL);
    if (r == 1 && cmd->v == 0.0f)
        x->avoid_stops++;
    /* A malformed scan leaves the command as it was: never a reason to stop steering. */
    return 0;
}

static void stop(rt_follow_cmd_t *cmd)
{
    cmd->v = cmd->omega = cmd->wheel_left = cmd->wheel_right = 0.0f;
}

int rt_explore_step(rt_explore_t *x, const gp_goal_msg_t *goal, float px, float py, float ptheta,
                    const rt_scan_view_t *scan, uint64_t now_us, const rt_follow_cfg_t *follow,
                    rt_follow_cmd_t *cmd)
{
    if (x == NULL || follow == NULL || cmd == NULL || !isfinite(px) || !isfinite(py) ||
        !isfinite(ptheta) || !pos_finite(follow->v_max) || !pos_finite(follow->wheel_radius) ||
        !pos_finite(follow->wheel_separation))
        return -EINVAL;
    memset(cmd, 0, sizeof *cmd);
    cmd->target = x->follow.index;
    if (goal != NULL && x->state != RT_EXPLORE_DONE) {
        if (goal->mode == GP_GOAL_MSG_DONE)
            x->state = RT_EXPLORE_DONE;
        else if (goal->mode == GP_GOAL_MSG_GO && goal->seq != 0 && goal->seq != x->goal_seq)
            new_goal(x, goal, px, py, follow);
        /* any other mode is not ours to guess: ignored */
    }
    if (x->state == RT_EXPLORE_DONE) {
        cmd->finished = 1;
        return 0;
    }
    if (x->state == RT_EXPLORE_BACKOFF) {
        if (now_us < x->backoff_end_us) {
            cmd->v = x->cfg.backoff_v_mps;
            cmd->omega = x->cfg.backoff_omega_rps;
            return command(x, follow, scan, cmd);
        }
        plan_to_goal(x, px, py, follow);
    }
    if (x->state != RT_EXPLORE_DRIVE)
        return 0;
    if (hypotf(x->goal_x - px, x->goal_y - py) <= x->cfg.reach_goal_m) {
        x->goal_reached = x->goal_seq;
        x->state = RT_EXPLORE_IDLE;
        return 0;
    }
    if (x->path_check) {
        x->path_check = 0;
        if (path_blocked(x)) {
            plan_to_goal(x, px, py, follow);
            if (x->state != RT_EXPLORE_DRIVE)
                return 0;
        }
    }
    if (!x->window_set) {
        x->window_set = 1;
        x->window_us = now_us;
        x->window_x = px;
        x->window_y = py;
    } else if (now_us - x->window_us >= (uint64_t)(x->cfg.stuck_window_s * 1e6f)) {
        int stuck = hypotf(px - x->window_x, py - x->window_y) < x->cfg.stuck_dist_m;
        x->window_us = now_us;
        x->window_x = px;
        x->window_y = py;
        if (stuck) {
            x->stuck_events++;
            x->goal_stuck++;
            if (x->goal_stuck >= x->cfg.max_stuck) {
                give_up(x);
                return 0;
            }
            x->state = RT_EXPLORE_BACKOFF;
            x->backoff_end_us = now_us + (uint64_t)(x->cfg.backoff_s * 1e6f);
            cmd->v = x->cfg.backoff_v_mps;
            cmd->omega = x->cfg.backoff_omega_rps;
            return command(x, follow, scan, cmd);
        }
    }
    int r = rt_follow_step(&x->follow, x->plan_res.wps, x->plan_res.n_wps, px, py, ptheta, cmd);
    if (r != 0) {
        stop(cmd);
        return r;
    }
    if (cmd->finished) {
        /* The path's end: the goal, or the reachable cell nearest it (NEAREST_GOAL). */
        x->goal_reached = x->goal_seq;
        x->state = RT_EXPLORE_IDLE;
        stop(cmd);
        cmd->finished = 0; /* the path, not the exploration */
        return 0;
    }
    return command(x, follow, scan, cmd);
}

/* ---- the coarse view ---------------------------------------------------------------------- */

int rt_explore_seen(rt_explore_t *x, uint64_t now_us, rt_seen_t *out)
{
    if (x == NULL || out == NULL)
        return -EINVAL;
    if (!x->grid_dirty)
        return 0;
    if (x->seen_published &&
        (now_us < x->seen_last_us || now_us - x->seen_last_us < RT_EXPLORE_SEEN_PERIOD_US))
        return 0;
    const rt_grid_t *g = &x->grid;
    const uint32_t f = x->cfg.seen_factor, sw = x->cfg.seen_w, sh = x->cfg.seen_h;
    memset(out, 0, sizeof *out);
    out->w = sw;
    out->h = sh;
    const uint32_t all = f * f;
    for (uint32_t cy = 0; cy < sh; cy++)
        for (uint32_t cx = 0; cx < sw; cx++) {
            /* Fine cells beyond the fine grid are outside the map: nothing to see or drive on
               there, so they count as observed obstacles (never observed, the last row and
               column of coarse cells, mostly beyond the grid, looked unexplored for ever). */
            uint32_t observed = 0, occupied = 0, in_grid = 0;
            for (uint32_t fy = cy * f; fy < (cy + 1u) * f && fy < (uint32_t)g->h; fy++)
                for (uint32_t fx = cx * f; fx < (cx + 1u) * f && fx < (uint32_t)g->w; fx++) {
                    int32_t i = (int32_t)(fy * (uint32_t)g->w + fx);
                    in_grid++;
                    if (g->known[i] == 0)
                        continue;
                    observed++;
                    occupied += (uint32_t)is_obstacle(x, i);
                }
            observed += all - in_grid;
            occupied += all - in_grid;
            /* Rounded half up. */
            uint32_t k = cy * sw + cx;
            out->occ[k] = observed ? (uint8_t)((255u * occupied + observed / 2u) / observed) : 0u;
            out->unknown[k] = (uint8_t)((255u * (all - observed) + all / 2u) / all);
        }
    x->seen_published = 1;
    x->seen_last_us = now_us;
    x->grid_dirty = 0;
    x->seen_updates++;
    out->stamp_us = x->grid_stamp_us;
    out->updates = x->seen_updates;
    return 1;
}

void rt_explore_status(const rt_explore_t *x, rt_status_t *st)
{
    st->goal_seq = x->goal_seq;
    st->goal_reached = x->goal_reached;
    st->goal_failed = x->goal_failed;
    st->plans = x->plans;
    st->plan_failures = x->plan_failures;
    st->tight_plans = x->tight_plans;
    st->stuck_events = x->stuck_events;
    st->avoid_stops = x->avoid_stops;
}
