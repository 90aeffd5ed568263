/* Drive-and-scan loop: see sim_scan.h. */
#include "sim_scan.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rt/rt_follow.h"
#include "rt/rt_samples.h"
#include "sim_lidar.h"
#include "sim_samples.h"
#include "sim_world.h"

sim_scan_cfg_t sim_scan_default_cfg(void)
{
    sim_scan_cfg_t c = {
        .seed = 1,
        .robot = 0,
        .beams = RT_SAMPLES_DEFAULT_BEAMS,
        .points = RT_SAMPLES_DEFAULT_POINTS,
        .sensor_beams = 360,
        .scan_hz = 10.0,
        .control_hz = 20.0,
        .dt = 0.01,
        .noise_sigma = 0.01,
        .dropout_p = 0.0,
        .gps_sigma_xy = 0.01,
        .gps_sigma_theta = 0.005,
        .max_time_s = 3600.0,
    };
    return c;
}

/* Number of physics steps in one period of `hz`, at least 1; the period must be a whole
 * number of steps so ticks stay exact in simulated time. */
static int period_steps(double hz, double dt, int *steps)
{
    double s = 1.0 / (hz * dt);
    long r = lround(s);
    if (r < 1 || fabs(s - (double)r) > 1e-6 * s)
        return -EINVAL;
    *steps = (int)r;
    return 0;
}

int sim_scan_run(const sim_plan_t *plan, const sim_path_t *path, const sim_scan_cfg_t *cfg,
                 const char *out, const char *source, sim_scan_stats_t *stats,
                 sim_scan_progress_fn progress, void *user, char *err, size_t errlen)
{
    char dummy[2];
    if (err == NULL || errlen == 0) {
        err = dummy;
        errlen = sizeof dummy;
    }
    sim_scan_stats_t st;
    memset(&st, 0, sizeof st);
    if (stats)
        *stats = st;
    if (plan == NULL || path == NULL || cfg == NULL || out == NULL || path->n < 2 ||
        path->p == NULL) {
        snprintf(err, errlen, "scan: a plan, a path of at least 2 waypoints and an output are needed");
        return -EINVAL;
    }
    const sim_scan_cfg_t *c = cfg;
    int scan_steps, ctl_steps;
    if (!(c->dt > 0 && c->dt <= 0.05) || !(c->scan_hz > 0) || !(c->control_hz > 0) ||
        period_steps(c->scan_hz, c->dt, &scan_steps) < 0 ||
        period_steps(c->control_hz, c->dt, &ctl_steps) < 0) {
        snprintf(err, errlen, "scan: dt must be in (0, 0.05] and 1/scan_hz, 1/control_hz whole "
                              "multiples of dt (dt %g, scan %g Hz, control %g Hz)",
                 c->dt, c->scan_hz, c->control_hz);
        return -EINVAL;
    }
    if (c->beams < 1 || c->beams > c->sensor_beams || c->points < 1 ||
        c->points > RT_SAMPLES_MAX_POINTS || c->beams > RT_SAMPLES_MAX_BEAMS ||
        !(c->max_time_s > 0) || !isfinite(c->max_time_s)) {
        snprintf(err, errlen, "scan: need 1 <= beams <= sensor beams (%d), 1 <= points <= %d, "
                              "a positive max time", c->sensor_beams, RT_SAMPLES_MAX_POINTS);
        return -EINVAL;
    }

    int rc;
    sim_world_t *w = NULL;
    sim_lidar_t *lid = NULL;
    rt_waypoint_t *wps = NULL;
    float *ranges = NULL;
    ai_sample_t *buf = NULL;
    sim_samples_writer_t wr = {0};
    int opened = 0;
    const int max_out = RT_SAMPLES_MAX_OUT(c->beams, c->points);

    sim_world_cfg_t wc = sim_world_default_cfg();
    wc.dt = c->dt;
    rc = sim_world_create(plan, &wc, &w, err, errlen);
    if (rc < 0)
        goto out;
    sim_lidar_cfg_t lc = sim_lidar_default_cfg();
    lc.n_beams = c->sensor_beams;
    lc.noise_sigma = c->noise_sigma;
    lc.dropout_p = c->dropout_p;
    lc.seed = c->seed;
    rc = sim_lidar_create(&lc, &lid);
    if (rc < 0) {
        snprintf(err, errlen, "scan: invalid lidar settings (beams 1..%d, noise >= 0, dropout in [0, 1))",
                 SIM_LIDAR_MAX_BEAMS);
        goto out;
    }
    sim_gps_cfg_t gc = {c->gps_sigma_xy, c->gps_sigma_theta, c->seed};
    wps = malloc(sizeof(rt_waypoint_t) * (size_t)path->n);
    ranges = malloc(sizeof(float) * (size_t)c->sensor_beams);
    buf = malloc(sizeof(ai_sample_t) * (size_t)max_out);
    if (wps == NULL || ranges == NULL || buf == NULL) {
        snprintf(err, errlen, "scan: out of memory");
        rc = -ENOMEM;
        goto out;
    }
    for (int i = 0; i < path->n; i++) {
        wps[i].x = (float)path->p[i].x;
        wps[i].y = (float)path->p[i].y;
    }
    sim_pose_t start = {path->p[0].x, path->p[0].y,
                        atan2(path->p[1].y - path->p[0].y, path->p[1].x - path->p[0].x)};
    int id;
    rc = sim_world_add_robot(w, NULL, start, &id);
    if (rc < 0) {
        snprintf(err, errlen, "scan: cannot place the robot at the first waypoint");
        goto out;
    }
    const sim_robot_params_t *rp = sim_world_robot_params(w, id);
    rt_follow_cfg_t fc = rt_follow_default_cfg();
    fc.v_max = (float)rp->v_max;
    fc.w_max = (float)rp->w_max;
    fc.wheel_radius = (float)rp->wheel_radius;
    fc.wheel_separation = (float)rp->wheel_separation;
    rt_follow_t fol;
    rc = rt_follow_init(&fol, &fc);
    if (rc < 0) {
        snprintf(err, errlen, "scan: follower configuration rejected");
        goto out;
    }
    rc = sim_samples_open(&wr, out, plan->min.x, plan->min.y, plan->max.x, plan->max.y, c->seed,
                          source);
    if (rc < 0) {
        snprintf(err, errlen, "%s: %s", out, hal_host_file_strerror(rc));
        goto out;
    }
    opened = 1;
    rt_samples_cfg_t sc = {c->beams, c->points, (float)plan->min.x, (float)plan->min.y,
                           (float)plan->max.x, (float)plan->max.y};
    rt_scan_view_t view = {ranges, c->sensor_beams, (float)lc.angle_min,
                           (float)sim_lidar_angle_inc(lid), (float)lc.range_max};

    uint64_t step = 0, ctl_index = 0;
    long max_steps = lround(c->max_time_s / c->dt);
    sim_pose_t prev = start;
    double next_progress = 10.0;
    while (!st.finished && (long)step < max_steps) {
        sim_pose_t truth, gps;
        if ((rc = sim_world_pose(w, id, &truth)) < 0)
            goto out;
        if (step % (uint64_t)ctl_steps == 0) {
            rt_follow_cmd_t cmd;
            if ((rc = sim_gps_read(&gc, c->robot, ctl_index++, &truth, &gps)) < 0 ||
                (rc = rt_follow_step(&fol, wps, path->n, (float)gps.x, (float)gps.y,
                                     (float)gps.theta, &cmd)) < 0 ||
                (rc = sim_world_set_wheels(w, id, cmd.wheel_left, cmd.wheel_right)) < 0) {
                snprintf(err, errlen, "scan: control step failed (%d)", rc);
                goto out;
            }
            st.waypoints_reached = cmd.target;
            st.finished = cmd.finished;
        }
        if (step % (uint64_t)scan_steps == 0) {
            /* GPS keyed apart from the control readings (index offset by 2^40). */
            int32_t n = 0;
            if ((rc = sim_gps_read(&gc, c->robot, (1ull << 40) + st.scans, &truth, &gps)) < 0 ||
                (rc = sim_lidar_scan(lid, w, truth.x, truth.y, truth.theta, c->robot, st.scans,
                                     ranges, NULL)) < 0 ||
                (rc = rt_samples_from_scan(&sc, &view, (float)gps.x, (float)gps.y,
                                           (float)gps.theta, buf, max_out, &n, NULL)) < 0) {
                snprintf(err, errlen, "scan: scan %llu failed (%d)", (unsigned long long)st.scans, rc);
                goto out;
            }
            if ((rc = sim_samples_append(&wr, buf, (size_t)n)) < 0) {
                snprintf(err, errlen, "%s: %s", out, hal_host_file_strerror(rc));
                goto out;
            }
            for (int32_t i = 0; i < n; i++)
                st.samples_occupied += buf[i].occ > 0.5f;
            st.samples += (uint64_t)n;
            st.scans++;
        }
        if (st.finished)
            break;
        if ((rc = sim_world_step(w, 1)) < 0) {
            snprintf(err, errlen, "scan: physics diverged at t = %.2f s", sim_world_time(w));
            goto out;
        }
        step++;
        if ((rc = sim_world_pose(w, id, &truth)) < 0)
            goto out;
        st.distance_m += hypot(truth.x - prev.x, truth.y - prev.y);
        prev = truth;
        st.sim_time_s = sim_world_time(w);
        st.collisions = sim_world_collisions(w, id);
        if (progress && st.sim_time_s >= next_progress) {
            progress(&st, path->n, user);
            next_progress += 10.0;
        }
    }
    st.sim_time_s = sim_world_time(w);
    st.collisions = sim_world_collisions(w, id);
    if (!st.finished) {
        snprintf(err, errlen, "scan: path not finished after %.1f simulated s (%d of %d waypoints)",
                 c->max_time_s, st.waypoints_reached, path->n);
        rc = -ETIMEDOUT;
        goto out;
    }
    opened = 0;
    rc = sim_samples_close(&wr);
    if (rc < 0)
        snprintf(err, errlen, "%s: %s", out, hal_host_file_strerror(rc));
out:
    if (opened) /* a failed or stopped run leaves the previous `out` as it was */
        sim_samples_abort(&wr);
    if (stats)
        *stats = st;
    sim_lidar_destroy(lid);
    sim_world_destroy(w);
    free(wps);
    free(ranges);
    free(buf);
    return rc;
}
