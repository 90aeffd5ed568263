/* Drive-and-scan loop: see sim_scan.h. */
#include "sim_scan.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fw_image.h"
#include "fw_link.h"
#include "rt/rt_core.h"
#include "sim_hal_world.h"
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
        .control_hz = 1e6 / FW_RT_PERIOD_US, /* the firmware's RT rate, 50 Hz */
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

/* The RT core and its image: static, as on a board (one scan at a time per process). */
static rt_core_t scan_rt;
static fw_image_t scan_img;

/* Drains the RT -> AI ring into the samples file (the host stands in for the AI core). */
static int drain(const fw_link_t *link, sim_samples_writer_t *wr, sim_scan_stats_t *st)
{
    ai_sample_t buf[512];
    for (;;) {
        size_t n = 0;
        while (n < sizeof buf / sizeof buf[0] && ring_get(link->samples, &buf[n]) == 0)
            n++;
        if (n == 0)
            return 0;
        int rc = sim_samples_append(wr, buf, n);
        if (rc < 0)
            return rc;
        for (size_t i = 0; i < n; i++)
            st->samples_occupied += buf[i].occ > 0.5f;
        st->samples += n;
    }
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
        path->p == NULL || path->n > RT_CORE_MAX_WAYPOINTS) {
        snprintf(err, errlen, "scan: a plan, a path of 2 .. %d waypoints and an output are needed",
                 RT_CORE_MAX_WAYPOINTS);
        return -EINVAL;
    }
    const sim_scan_cfg_t *c = cfg;
    int scan_steps, ctl_steps;
    if (!(c->dt > 0 && c->dt <= 0.05) || !(c->scan_hz > 0) || !(c->control_hz > 0) ||
        period_steps(c->scan_hz, c->dt, &scan_steps) < 0 ||
        period_steps(c->control_hz, c->dt, &ctl_steps) < 0 || scan_steps % ctl_steps != 0) {
        snprintf(err, errlen, "scan: dt must be in (0, 0.05] and 1/scan_hz, 1/control_hz whole "
                              "multiples of dt, the scan period a multiple of the control period "
                              "(dt %g, scan %g Hz, control %g Hz)",
                 c->dt, c->scan_hz, c->control_hz);
        return -EINVAL;
    }
    if (c->beams < 1 || c->beams > c->sensor_beams || c->points < 1 ||
        c->points > RT_SAMPLES_MAX_POINTS || c->beams > RT_SAMPLES_MAX_BEAMS ||
        c->sensor_beams > (int)HAL_LIDAR_MAX_BEAMS ||
        RT_SAMPLES_MAX_OUT(c->beams, c->points) > RT_CORE_MAX_SCAN_SAMPLES ||
        !(c->max_time_s > 0) || !isfinite(c->max_time_s)) {
        snprintf(err, errlen, "scan: need 1 <= beams <= sensor beams <= %u, 1 <= points <= %d, "
                              "beams x points <= %d, a positive max time", (unsigned)HAL_LIDAR_MAX_BEAMS,
                 RT_SAMPLES_MAX_POINTS, RT_CORE_MAX_SCAN_SAMPLES);
        return -EINVAL;
    }

    int rc;
    sim_hal_world_t *hw = NULL;
    hal_host_t *h = NULL;
    sim_samples_writer_t wr = {0};
    int opened = 0;
    rt_waypoint_t *wps = malloc(sizeof(rt_waypoint_t) * (size_t)path->n);
    if (wps == NULL) {
        snprintf(err, errlen, "scan: out of memory");
        return -ENOMEM;
    }
    /* The world behind the host HAL, as the firmware image sees it. */
    sim_hal_world_cfg_t wc = sim_hal_world_default_cfg();
    wc.robot = c->robot;
    wc.seed = c->seed;
    wc.world.dt = c->dt;
    wc.lidar.n_beams = c->sensor_beams;
    wc.lidar.noise_sigma = c->noise_sigma;
    wc.lidar.dropout_p = c->dropout_p;
    wc.gps_sigma_xy = c->gps_sigma_xy;
    wc.gps_sigma_theta = c->gps_sigma_theta;
    wc.scan_period_us = (uint32_t)scan_steps * (uint32_t)llround(c->dt * 1e6);
    wc.coverage = c->coverage;
    rc = sim_hal_world_create(plan, path, &wc, &hw, err, errlen);
    if (rc < 0)
        goto out;
    hal_host_config_t hc = hal_host_config_default();
    hc.log_level = HAL_LOG_WARN;
    if ((rc = sim_hal_world_host(hw, c->robot, hc, &h, err, errlen)) < 0)
        goto out;

    /* The firmware's RT core alone: it follows the tour and turns scans into samples in the
       RT -> AI ring, which this loop drains in place of the AI core. */
    fw_link_reset();
    const fw_link_t *link = fw_link_get();
    rt_core_cfg_t rcfg;
    sim_hal_world_rt_cfg(plan, path, wps, &rcfg);
    rcfg.samples.n_beams = c->beams;
    rcfg.samples.points_per_beam = c->points;
    rcfg.period_us = (uint32_t)ctl_steps * (uint32_t)llround(c->dt * 1e6);
    if ((rc = rt_core_init(&scan_rt, &rcfg, link)) < 0) {
        snprintf(err, errlen, "scan: RT core configuration rejected (%d)", rc);
        goto out;
    }
    fw_image_defaults(&scan_img);
    scan_img.core[HAL_CORE_RT] = (fw_core_t){.name = "RT",
                                             .period_us = rcfg.period_us,
                                             .sub_divider = (uint32_t)(scan_steps / ctl_steps),
                                             .tick = rt_core_tick,
                                             .arg = &scan_rt};
    if ((rc = fw_image_start(&scan_img)) < 0) {
        snprintf(err, errlen, "scan: RT core not started (%d)", rc);
        goto out;
    }
    rc = sim_samples_open(&wr, out, plan->min.x, plan->min.y, plan->max.x, plan->max.y, c->seed, source);
    if (rc < 0) {
        snprintf(err, errlen, "%s: %s", out, hal_host_file_strerror(rc));
        goto out;
    }
    opened = 1;

    /* One scan period per slice: the ring (FW_LINK_RING_CAPACITY samples) holds several scans. */
    const uint64_t slice = wc.scan_period_us;
    const uint64_t limit = (uint64_t)llround(c->max_time_s * 1e6);
    double next_progress = 10.0;
    rt_status_t status;
    memset(&status, 0, sizeof status);
    for (uint64_t t = 0; t < limit && !status.finished;) {
        t = t + slice < limit ? t + slice : limit;
        if ((rc = hal_host_run_until(h, t)) < 0) {
            snprintf(err, errlen, "scan: simulation failed at t = %.2f s (%d)", (double)t * 1e-6, rc);
            goto out;
        }
        /* Every core is blocked in the lockstep now: the ring and the status are stable. */
        if ((rc = drain(link, &wr, &st)) < 0) {
            snprintf(err, errlen, "%s: %s", out, hal_host_file_strerror(rc));
            goto out;
        }
        (void)!mbox_get(link->rt_to_gp, &status, NULL);
        sim_hal_world_stats_t ws;
        sim_hal_world_get_stats(hw, &ws);
        st.sim_time_s = (double)hal_host_now_us(h) * 1e-6;
        st.scans = status.scans;
        st.waypoints_reached = (int)status.waypoint;
        st.finished = (int)status.finished;
        st.distance_m = ws.distance_m;
        st.collisions = ws.collisions;
        if (progress && st.sim_time_s >= next_progress) {
            progress(&st, path->n, user);
            next_progress += 10.0;
        }
    }
    if (status.ring_drops > 0 || status.sample_errors > 0) {
        snprintf(err, errlen, "scan: %u samples dropped by the RT core (ring full) and %u refused",
                 status.ring_drops, status.sample_errors);
        rc = -EOVERFLOW;
        goto out;
    }
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
    hal_host_destroy(h); /* stops the core first; uninstalls the board */
    sim_hal_world_destroy(hw);
    free(wps);
    return rc;
}
