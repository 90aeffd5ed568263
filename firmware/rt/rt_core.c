/* The RT core loop: see rt_core.h. */
#include "rt/rt_core.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "hal/hal.h"

_Static_assert(sizeof(rt_core_t) <= BOARD_RAM_RT_BYTES, "RT core state exceeds the board's RT RAM");
/* With the links it writes (sample ring, status and seen mailboxes), as the GP core's check. */
_Static_assert(sizeof(rt_core_t) + RT_LINK_BYTES <= BOARD_RAM_RT_BYTES,
               "RT core state and links exceed the board's RT RAM");

static int samples_cfg_ok(const rt_samples_cfg_t *s)
{
    return s->n_beams >= 1 && s->points_per_beam >= 1 &&
           RT_SAMPLES_MAX_OUT(s->n_beams, s->points_per_beam) <= RT_CORE_MAX_SCAN_SAMPLES &&
           s->max_x > s->min_x && s->max_y > s->min_y;
}

/* Exploration: no waypoints; the explore cfg is copied into the core's own rt_explore_t. */
static int init_explore(rt_core_t *rt, const rt_core_cfg_t *cfg, const fw_link_t *link)
{
    if (link->gp_goal == NULL || link->rt_seen == NULL)
        return -EINVAL;
    /* Everything before the exploration state (which rt_explore_init resets itself: its
     * planner workspace is scratch and is never cleared). */
    memset(rt, 0, offsetof(rt_core_t, explore));
    rt->cfg = *cfg;
    rt->link = link;
    int r = rt_explore_init(&rt->explore, cfg->explore);
    if (r != 0)
        return r;
    rt->cfg.explore = &rt->explore.cfg;
    rt->cfg.waypoints = NULL;
    rt->cfg.n_waypoints = 0;
    return rt_follow_init(&rt->follow, &cfg->follow);
}

int rt_core_init(rt_core_t *rt, const rt_core_cfg_t *cfg, const fw_link_t *link)
{
    if (rt == NULL || cfg == NULL || link == NULL || cfg->period_us == 0 ||
        !samples_cfg_ok(&cfg->samples))
        return -EINVAL;
    if (cfg->explore != NULL)
        return init_explore(rt, cfg, link);
    if (cfg->waypoints == NULL || cfg->n_waypoints < 2 || cfg->n_waypoints > RT_CORE_MAX_WAYPOINTS)
        return -EINVAL;
    /* A tour leaves the exploration state alone: its pages are never touched. */
    memset(rt, 0, offsetof(rt_core_t, explore));
    rt->cfg = *cfg;
    rt->link = link;
    for (int32_t i = 0; i < cfg->n_waypoints; i++) {
        if (!isfinite(cfg->waypoints[i].x) || !isfinite(cfg->waypoints[i].y))
            return -EINVAL;
        rt->wps[i] = cfg->waypoints[i];
        rt->cum[i] = i == 0 ? 0.0f
                            : rt->cum[i - 1] + hypotf(rt->wps[i].x - rt->wps[i - 1].x,
                                                      rt->wps[i].y - rt->wps[i - 1].y);
    }
    rt->cfg.waypoints = rt->wps;
    int r = rt_follow_init(&rt->follow, &cfg->follow);
    if (r != 0)
        return r;
    rt->status.path_length_m = rt->cum[cfg->n_waypoints - 1];
    return 0;
}

float rt_core_path_length(const rt_core_t *rt)
{
    if (rt->cfg.explore != NULL)
        return 0.0f;
    return rt->cum[rt->cfg.n_waypoints - 1];
}

/* Arc length covered: up to the waypoint aimed at minus what is left to it, clamped to the
 * current segment, never decreasing (GPS noise must not move the round boundaries back). */
static void update_progress(rt_core_t *rt, float x, float y, int32_t target, int finished)
{
    const int32_t n = rt->cfg.n_waypoints;
    float p;
    if (finished || target >= n) {
        p = rt->cum[n - 1];
    } else if (target <= 0) {
        p = 0.0f;
    } else {
        float left = hypotf(rt->wps[target].x - x, rt->wps[target].y - y);
        p = rt->cum[target] - left;
        if (p < rt->cum[target - 1])
            p = rt->cum[target - 1];
        if (p > rt->cum[target])
            p = rt->cum[target];
    }
    if (p > rt->status.progress_m)
        rt->status.progress_m = p;
}

static void process_scan(rt_core_t *rt, const hal_pose_t *pose)
{
    int r = hal_lidar_read_scan(&rt->scan);
    if (r == -EAGAIN)
        return;
    if (r != 0) {
        rt->status.errors++;
        return;
    }
    if (rt->have_scan && rt->scan.stamp_us == rt->last_scan_stamp)
        return; /* nothing new since the previous scan tick */
    rt->have_scan = 1;
    rt->last_scan_stamp = rt->scan.stamp_us;
    rt_scan_view_t view = {rt->scan.ranges_m, (int32_t)rt->scan.count, rt->scan.angle_min_rad,
                           rt->scan.angle_step_rad, rt->scan.range_max_m};
    int32_t n = 0;
    r = rt_samples_from_scan(&rt->cfg.samples, &view, pose->x_m, pose->y_m, pose->heading_rad,
                             rt->out, RT_CORE_MAX_SCAN_SAMPLES, &n, NULL);
    if (r != 0) {
        rt->status.sample_errors++;
        return;
    }
    rt->status.scans++;
    for (int32_t i = 0; i < n; i++) {
        /* A full ring is the expected overload (dropped and counted); anything else is not. */
        r = ring_put(rt->link->samples, &rt->out[i]);
        if (r == 0)
            rt->status.samples++;
        else if (r == -ENOSPC)
            rt->status.ring_drops++;
        else
            rt->status.sample_errors++;
    }
}

/* ---- exploration -------------------------------------------------------------------------- */

static rt_scan_view_t scan_view(const rt_core_t *rt)
{
    rt_scan_view_t v = {rt->scan.ranges_m, (int32_t)rt->scan.count, rt->scan.angle_min_rad,
                        rt->scan.angle_step_rad, rt->scan.range_max_m};
    return v;
}

static int publish_status(rt_core_t *rt, uint64_t now_us)
{
    rt->status.stamp_us = now_us;
    if (mbox_put(rt->link->rt_to_ai, &rt->status) != 0 ||
        mbox_put(rt->link->rt_to_gp, &rt->status) != 0)
        return -EINVAL;
    return 0;
}

/* One tick of exploration mode (rt_core.h): goal, pose, scan (samples as on a tour, then the
 * grid), the explore step, the seen view, the status. */
static int explore_tick(rt_core_t *rt, const fw_tick_t *tick)
{
    rt_explore_t *x = &rt->explore;
    rt_core_stats_t *st = &rt->stats;
    int rc = 0;
    int over = rt_explore_clock(x, tick->now_us) == 1;
    if (mbox_get(rt->link->gp_goal, &rt->goal, NULL) == 1)
        rt->have_goal = 1;
    hal_pose_t pose;
    int r = hal_pose_read(&pose);
    if (r == 0) {
        rt->status.x_m = pose.x_m;
        rt->status.y_m = pose.y_m;
        rt->status.heading_rad = pose.heading_rad;
    } else if (r != -EAGAIN) {
        rt->status.errors++;
        rc = r;
    }
    if (!rt->status.finished) {
        if (r == 0 && !over) {
            if (tick->sub) {
                st->scan_ticks++;
                const int had = rt->have_scan;
                const uint64_t before = rt->last_scan_stamp;
                process_scan(rt, &pose);
                if (rt->have_scan && (!had || rt->last_scan_stamp != before)) {
                    rt_scan_view_t v = scan_view(rt);
                    /* Only a malformed scan fails here; it then adds nothing to the grid. */
                    if (rt_explore_integrate_scan(x, &v, pose.x_m, pose.y_m, pose.heading_rad,
                                                  rt->scan.stamp_us) < 0)
                        rt->status.sample_errors++;
                }
            }
            rt_scan_view_t v = scan_view(rt);
            rt_follow_cmd_t cmd;
            r = rt_explore_step(x, rt->have_goal ? &rt->goal : NULL, pose.x_m, pose.y_m,
                                pose.heading_rad, rt->have_scan ? &v : NULL, tick->now_us,
                                &rt->cfg.follow, &cmd);
            if (r != 0) {
                rt->status.errors++;
                rc = r;
            } else if (cmd.finished) {
                over = 1;
            } else {
                if (hal_motor_set_wheels(cmd.wheel_left, cmd.wheel_right) != 0)
                    rt->status.errors++;
                rt->status.distance_m += fabsf(cmd.v) * (float)rt->cfg.period_us * 1e-6f;
                rt->status.waypoint = (uint32_t)cmd.target;
            }
        }
        if (over) {
            /* The end of exploration: the wheels stopped once, then nothing more. */
            if (hal_motor_set_wheels(0.0f, 0.0f) != 0)
                rt->status.errors++;
            rt->status.finished = 1;
        }
    }
    rt_seen_t *seen = mbox_write_buffer(rt->link->rt_seen);
    if (rt_explore_seen(x, tick->now_us, seen) == 1)
        (void)mbox_publish(rt->link->rt_seen);
    rt_explore_status(x, &rt->status);
    rt->status.path_length_m = 0.0f; /* no fixed path: rounds are cut by time */
    rt->status.progress_m = 0.0f;
    if (publish_status(rt, tick->now_us) != 0)
        rc = -EINVAL;
    return rc;
}

int rt_core_tick(void *arg, const fw_tick_t *tick)
{
    rt_core_t *rt = arg;
    rt_core_stats_t *st = &rt->stats;
    if (st->ticks > 0 && tick->now_us != st->last_tick_us + rt->cfg.period_us)
        st->tick_gaps++;
    uint64_t now = 0;
    if (hal_clock_now_us(&now) != 0 || now != tick->now_us)
        st->clock_mismatch++;
    st->last_tick_us = tick->now_us;
    st->ticks++;
    if (rt->cfg.explore != NULL)
        return explore_tick(rt, tick);

    hal_pose_t pose;
    int r = hal_pose_read(&pose);
    int rc = 0;
    if (r == 0) {
        rt->status.x_m = pose.x_m;
        rt->status.y_m = pose.y_m;
        rt->status.heading_rad = pose.heading_rad;
        if (!rt->follow.finished) {
            rt_follow_cmd_t cmd;
            r = rt_follow_step(&rt->follow, rt->wps, rt->cfg.n_waypoints, pose.x_m, pose.y_m,
                               pose.heading_rad, &cmd);
            if (r == 0) {
                float wl = cmd.finished ? 0.0f : cmd.wheel_left;
                float wr = cmd.finished ? 0.0f : cmd.wheel_right;
                if (hal_motor_set_wheels(wl, wr) != 0)
                    rt->status.errors++;
                /* Odometry from the command held until the next tick. */
                rt->status.distance_m +=
                    fabsf(cmd.finished ? 0.0f : cmd.v) * (float)rt->cfg.period_us * 1e-6f;
                rt->status.waypoint = (uint32_t)cmd.target;
                rt->status.finished = (uint32_t)cmd.finished;
                update_progress(rt, pose.x_m, pose.y_m, cmd.target, cmd.finished);
            } else {
                rt->status.errors++;
                rc = r;
            }
        }
        if (tick->sub && !rt->follow.finished) {
            st->scan_ticks++;
            process_scan(rt, &pose);
        }
    } else if (r != -EAGAIN) {
        rt->status.errors++;
        rc = r;
    }
    rt->status.stamp_us = tick->now_us;
    if (mbox_put(rt->link->rt_to_ai, &rt->status) != 0 ||
        mbox_put(rt->link->rt_to_gp, &rt->status) != 0)
        rc = -EINVAL;
    return rc;
}
