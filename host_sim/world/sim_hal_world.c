/* host_sim world -> hal_host_world_t adapter: see sim_hal_world.h. */
#include "sim_hal_world.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct sim_hal_world {
    sim_hal_world_cfg_t cfg;
    sim_world_t *w;
    sim_lidar_t *lidar;
    sim_gps_cfg_t gps;
    int id;
    uint64_t dt_us;
    uint64_t next_scan_us;
    double wl, wr;         /* command to apply at the next advance */
    int wheels_dirty;
    hal_pose_t fix;
    hal_lidar_scan_t scan; /* the latest scan (n_beams <= HAL_LIDAR_MAX_BEAMS is checked at create) */
    int have_scan;
    sim_hal_world_stats_t st;
    hal_host_world_t ops;
};

sim_hal_world_cfg_t sim_hal_world_default_cfg(void)
{
    sim_hal_world_cfg_t c;
    memset(&c, 0, sizeof c);
    c.seed = 1;
    c.world = sim_world_default_cfg();
    c.lidar = sim_lidar_default_cfg();
    c.gps_sigma_xy = 0.01;
    c.gps_sigma_theta = 0.005;
    c.scan_period_us = 100000u;
    return c;
}

static int refresh_fix(sim_hal_world_t *hw)
{
    sim_pose_t truth, gps;
    int rc = sim_world_pose(hw->w, hw->id, &truth);
    if (rc < 0)
        return rc;
    rc = sim_gps_read(&hw->gps, hw->cfg.robot, hw->st.steps, &truth, &gps);
    if (rc < 0)
        return rc;
    hw->st.distance_m += hypot(truth.x - hw->st.truth.x, truth.y - hw->st.truth.y);
    hw->st.truth = truth;
    hw->fix.stamp_us = hw->st.t_us;
    hw->fix.x_m = (float)gps.x;
    hw->fix.y_m = (float)gps.y;
    hw->fix.heading_rad = (float)gps.theta;
    return 0;
}

static int take_scan(sim_hal_world_t *hw)
{
    const sim_pose_t *p = &hw->st.truth;
    hal_lidar_scan_t *s = &hw->scan;
    int rc = sim_lidar_scan(hw->lidar, hw->w, p->x, p->y, p->theta, hw->cfg.robot, hw->st.scans,
                            s->ranges_m, NULL);
    if (rc < 0)
        return rc;
    const sim_lidar_cfg_t *lc = sim_lidar_cfg(hw->lidar);
    s->stamp_us = hw->st.t_us;
    s->angle_min_rad = (float)lc->angle_min;
    s->angle_step_rad = (float)sim_lidar_angle_inc(hw->lidar);
    s->range_min_m = (float)lc->range_min;
    s->range_max_m = (float)lc->range_max;
    s->count = (uint32_t)lc->n_beams;
    hw->have_scan = 1;
    hw->st.scans++;
    /* After the scan and its noise are fixed: coverage only reads them (no stream changes). */
    if (hw->cfg.coverage != NULL)
        return sim_coverage_add_scan(hw->cfg.coverage, (double)s->stamp_us * 1e-6, p->x, p->y, p->theta, s);
    return 0;
}

static int cb_advance(void *ctx, uint64_t t_us)
{
    sim_hal_world_t *hw = ctx;
    hw->st.advances++;
    if (t_us <= hw->st.t_us)
        return -EINVAL;
    if (hw->wheels_dirty) {
        int rc = sim_world_set_wheels(hw->w, hw->id, hw->wl, hw->wr);
        if (rc < 0)
            return rc;
        hw->wheels_dirty = 0;
    }
    uint64_t target = t_us / hw->dt_us;
    if (target > hw->st.steps) {
        int rc = sim_world_step(hw->w, (int)(target - hw->st.steps));
        if (rc < 0)
            return rc;
        hw->st.steps = target;
    }
    hw->st.t_us = t_us;
    hw->st.collisions = sim_world_collisions(hw->w, hw->id);
    int rc = refresh_fix(hw);
    if (rc < 0)
        return rc;
    if (t_us >= hw->next_scan_us) {
        rc = take_scan(hw);
        if (rc < 0)
            return rc;
        while (hw->next_scan_us <= t_us)
            hw->next_scan_us += hw->cfg.scan_period_us;
    }
    return 0;
}

static int cb_read_scan(void *ctx, uint32_t robot, hal_lidar_scan_t *scan)
{
    sim_hal_world_t *hw = ctx;
    if (robot != hw->cfg.robot)
        return -EINVAL;
    if (!hw->have_scan)
        return -EAGAIN;
    hw->st.scan_reads++;
    /* Copy only the used beams: the record is fixed-size, the tail is unspecified. */
    memcpy(scan, &hw->scan, offsetof(hal_lidar_scan_t, ranges_m));
    memcpy(scan->ranges_m, hw->scan.ranges_m, sizeof(float) * hw->scan.count);
    return 0;
}

static int cb_read_pose(void *ctx, uint32_t robot, hal_pose_t *pose)
{
    sim_hal_world_t *hw = ctx;
    if (robot != hw->cfg.robot)
        return -EINVAL;
    hw->st.pose_reads++;
    *pose = hw->fix;
    return 0;
}

static int cb_set_wheels(void *ctx, uint32_t robot, float l, float r)
{
    sim_hal_world_t *hw = ctx;
    if (robot != hw->cfg.robot || !isfinite(l) || !isfinite(r))
        return -EINVAL;
    hw->st.wheel_cmds++;
    hw->wl = l;
    hw->wr = r;
    hw->wheels_dirty = 1;
    return 0;
}

int sim_hal_world_create(const sim_plan_t *plan, const sim_path_t *path,
                         const sim_hal_world_cfg_t *cfg, sim_hal_world_t **out, char *err,
                         size_t errlen)
{
    char dummy[2];
    if (err == NULL || errlen == 0) {
        err = dummy;
        errlen = sizeof dummy;
    }
    if (out == NULL || plan == NULL || path == NULL || cfg == NULL || path->n < 2 ||
        path->p == NULL) {
        snprintf(err, errlen, "world binding: a plan, a path of >= 2 waypoints and a config are needed");
        return -EINVAL;
    }
    *out = NULL;
    const double dt = cfg->world.dt;
    uint64_t dt_us = (uint64_t)llround(dt * 1e6);
    if (!(dt > 0) || dt_us == 0 || fabs((double)dt_us - dt * 1e6) > 1e-6 ||
        cfg->scan_period_us == 0 || cfg->scan_period_us % dt_us != 0 ||
        cfg->lidar.n_beams < 1 || cfg->lidar.n_beams > (int)HAL_LIDAR_MAX_BEAMS ||
        !(cfg->gps_sigma_xy >= 0) || !(cfg->gps_sigma_theta >= 0)) {
        snprintf(err, errlen,
                 "world binding: need a whole-microsecond dt, a scan period that is a multiple of it, "
                 "1..%u lidar beams and GPS sigmas >= 0",
                 (unsigned)HAL_LIDAR_MAX_BEAMS);
        return -EINVAL;
    }
    sim_hal_world_t *hw = calloc(1, sizeof *hw);
    if (hw == NULL) {
        snprintf(err, errlen, "world binding: out of memory");
        return -ENOMEM;
    }
    hw->cfg = *cfg;
    hw->cfg.lidar.seed = cfg->seed;
    hw->dt_us = dt_us;
    hw->gps = (sim_gps_cfg_t){cfg->gps_sigma_xy, cfg->gps_sigma_theta, cfg->seed};
    int rc = sim_world_create(plan, &hw->cfg.world, &hw->w, err, errlen);
    if (rc < 0)
        goto fail;
    rc = sim_lidar_create(&hw->cfg.lidar, &hw->lidar);
    if (rc < 0) {
        snprintf(err, errlen, "world binding: invalid lidar settings");
        goto fail;
    }
    sim_pose_t start = {path->p[0].x, path->p[0].y,
                        atan2(path->p[1].y - path->p[0].y, path->p[1].x - path->p[0].x)};
    rc = sim_world_add_robot(hw->w, NULL, start, &hw->id);
    if (rc < 0) {
        snprintf(err, errlen, "world binding: cannot place the robot at the first waypoint");
        goto fail;
    }
    if ((rc = sim_world_pose(hw->w, hw->id, &hw->st.truth)) < 0 || (rc = refresh_fix(hw)) < 0 ||
        (rc = take_scan(hw)) < 0) {
        snprintf(err, errlen, "world binding: first fix or scan failed (%d)", rc);
        goto fail;
    }
    hw->next_scan_us = cfg->scan_period_us;
    hw->ops = (hal_host_world_t){hw, cb_advance, cb_read_scan, cb_read_pose, cb_set_wheels};
    *out = hw;
    return 0;
fail:
    sim_hal_world_destroy(hw);
    return rc < 0 ? rc : -EINVAL;
}

void sim_hal_world_destroy(sim_hal_world_t *hw)
{
    if (hw == NULL)
        return;
    sim_lidar_destroy(hw->lidar);
    sim_world_destroy(hw->w);
    free(hw);
}

const hal_host_world_t *sim_hal_world_ops(sim_hal_world_t *hw)
{
    return &hw->ops;
}

void sim_hal_world_get_stats(const sim_hal_world_t *hw, sim_hal_world_stats_t *st)
{
    *st = hw->st;
}

void sim_hal_world_wheels(const sim_hal_world_t *hw, float *radius_m, float *separation_m)
{
    const sim_robot_params_t *p = sim_world_robot_params(hw->w, hw->id);
    *radius_m = (float)p->wheel_radius;
    *separation_m = (float)p->wheel_separation;
}

int sim_hal_world_host(sim_hal_world_t *hw, uint32_t robot, hal_host_config_t base, hal_host_t **out, char *err,
                       size_t errlen)
{
    base.robot_id = robot;
    base.world = sim_hal_world_ops(hw);
    sim_hal_world_wheels(hw, &base.wheel_radius_m, &base.wheel_separation_m);
    int rc = hal_host_create(&base, out);
    if (rc < 0) {
        snprintf(err, errlen, "host board not created (%d: %s)", rc, strerror(-rc));
        return rc;
    }
    rc = hal_board_install(hal_host_board(*out));
    if (rc < 0)
        snprintf(err, errlen, "board not installed (%d)", rc);
    return rc;
}

void sim_hal_world_rt_cfg(const sim_plan_t *plan, const sim_path_t *path, rt_waypoint_t *wps, rt_core_cfg_t *rc)
{
    for (int i = 0; i < path->n; i++)
        wps[i] = (rt_waypoint_t){(float)path->p[i].x, (float)path->p[i].y};
    const sim_robot_params_t rp = sim_robot_default_params();
    memset(rc, 0, sizeof *rc);
    rc->waypoints = wps;
    rc->n_waypoints = path->n;
    rc->follow = rt_follow_default_cfg();
    rc->follow.v_max = (float)rp.v_max;
    rc->follow.w_max = (float)rp.w_max;
    rc->follow.wheel_radius = (float)rp.wheel_radius;
    rc->follow.wheel_separation = (float)rp.wheel_separation;
    rc->samples = (rt_samples_cfg_t){RT_SAMPLES_DEFAULT_BEAMS, RT_SAMPLES_DEFAULT_POINTS, (float)plan->min.x,
                                     (float)plan->min.y, (float)plan->max.x, (float)plan->max.y};
}
