/* Validation set generation: see sim_valset.h. */
#include "sim_valset.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "rt/rt_samples.h"
#include "sim_grid.h"
#include "sim_lidar.h"
#include "sim_rng.h"
#include "sim_samples.h"
#include "sim_shape.h"

enum { STREAM_POSE = 20 };
#define MAX_ATTEMPTS 100000

sim_valset_cfg_t sim_valset_default_cfg(void)
{
    sim_valset_cfg_t c = {.n_poses = 500,
                          .n_beams = RT_SAMPLES_DEFAULT_BEAMS,
                          .points_per_beam = RT_SAMPLES_DEFAULT_POINTS,
                          .clearance_m = 0.2,
                          .range_max = 3.5,
                          .seed = 1};
    return c;
}

static int cfg_ok(const sim_valset_cfg_t *c)
{
    return c->n_poses >= 1 && c->n_poses <= 1000000 && c->n_beams >= 1 &&
           c->n_beams <= RT_SAMPLES_MAX_BEAMS && c->points_per_beam >= 1 &&
           c->points_per_beam <= RT_SAMPLES_MAX_POINTS && isfinite(c->clearance_m) &&
           c->clearance_m >= 0 && isfinite(c->range_max) && c->range_max > 0;
}

static int pose_ok(const sim_plan_t *p, double x, double y, double clearance)
{
    if (sim_plan_classify_point(p, x, y) != SIM_CELL_FREE)
        return 0;
    int in_room = p->n_rooms == 0;
    for (int r = 0; r < p->n_rooms && !in_room; r++)
        in_room = sim_shape_contains(&p->rooms[r].outline, x, y);
    if (!in_room)
        return 0;
    for (int s = 0; s < p->n_solids; s++)
        if (sim_shape_contains(&p->solids[s].outline, x, y) ||
            sim_shape_edge_distance(&p->solids[s].outline, x, y) < clearance)
            return 0;
    return 1;
}

int sim_valset_poses(const sim_plan_t *plan, const sim_valset_cfg_t *cfg, sim_pose_t *poses,
                     char *err, size_t errlen)
{
    char dummy[2];
    if (err == NULL || errlen == 0) {
        err = dummy;
        errlen = sizeof dummy;
    }
    if (plan == NULL || cfg == NULL || poses == NULL || !cfg_ok(cfg)) {
        snprintf(err, errlen, "valset: invalid configuration");
        return -EINVAL;
    }
    double wx = plan->max.x - plan->min.x, wy = plan->max.y - plan->min.y;
    if (!(wx > 0 && wy > 0)) {
        snprintf(err, errlen, "valset: plan has an empty bounding box");
        return -EINVAL;
    }
    for (int i = 0; i < cfg->n_poses; i++) {
        int found = 0;
        for (uint64_t t = 0; t < MAX_ATTEMPTS && !found; t++) {
            double x = plan->min.x + wx * sim_rng_uniform(cfg->seed, STREAM_POSE, (uint64_t)i, t, 0);
            double y = plan->min.y + wy * sim_rng_uniform(cfg->seed, STREAM_POSE, (uint64_t)i, t, 1);
            if (pose_ok(plan, x, y, cfg->clearance_m)) {
                poses[i].x = x;
                poses[i].y = y;
                poses[i].theta =
                    6.283185307179586 * sim_rng_uniform(cfg->seed, STREAM_POSE, (uint64_t)i, t, 2);
                found = 1;
            }
        }
        if (!found) {
            snprintf(err, errlen,
                     "valset: no free pose (in a room, %.2f m from walls) found in %d attempts",
                     cfg->clearance_m, MAX_ATTEMPTS);
            return -ENOENT;
        }
    }
    return 0;
}

int sim_valset_write(const sim_plan_t *plan, const sim_valset_cfg_t *cfg, const char *path,
                     const char *source, uint64_t *n_samples, char *err, size_t errlen)
{
    char dummy[2];
    if (err == NULL || errlen == 0) {
        err = dummy;
        errlen = sizeof dummy;
    }
    if (plan == NULL || cfg == NULL || path == NULL || !cfg_ok(cfg)) {
        snprintf(err, errlen, "valset: invalid configuration");
        return -EINVAL;
    }
    int rc;
    sim_pose_t *poses = malloc(sizeof(sim_pose_t) * (size_t)cfg->n_poses);
    float *ranges = malloc(sizeof(float) * (size_t)cfg->n_beams);
    ai_sample_t *buf = malloc(sizeof(ai_sample_t) * (size_t)cfg->n_beams * (size_t)cfg->points_per_beam);
    sim_world_t *w = NULL;
    sim_lidar_t *lid = NULL;
    sim_samples_writer_t wr = {0};
    int opened = 0;
    if (poses == NULL || ranges == NULL || buf == NULL) {
        snprintf(err, errlen, "valset: out of memory");
        rc = -ENOMEM;
        goto out;
    }
    rc = sim_valset_poses(plan, cfg, poses, err, errlen);
    if (rc < 0)
        goto out;
    rc = sim_world_create(plan, NULL, &w, err, errlen);
    if (rc < 0)
        goto out;
    /* Ground truth: no noise, no dropout, no minimum range. */
    sim_lidar_cfg_t lc = sim_lidar_default_cfg();
    lc.n_beams = cfg->n_beams;
    lc.range_min = 0.0;
    lc.range_max = cfg->range_max;
    lc.noise_sigma = 0.0;
    lc.dropout_p = 0.0;
    rc = sim_lidar_create(&lc, &lid);
    if (rc < 0) {
        snprintf(err, errlen, "valset: lidar configuration rejected");
        goto out;
    }
    rc = sim_samples_open(&wr, path, plan->min.x, plan->min.y, plan->max.x, plan->max.y,
                          cfg->seed, source);
    if (rc < 0) {
        snprintf(err, errlen, "%s: %s", path, rc == -EINVAL ? "bad bounding box" : hal_host_file_strerror(rc));
        goto out;
    }
    opened = 1;
    rt_samples_cfg_t sc = {cfg->n_beams,       cfg->points_per_beam, (float)plan->min.x,
                           (float)plan->min.y, (float)plan->max.x,   (float)plan->max.y};
    rt_scan_view_t view = {ranges, cfg->n_beams, (float)lc.angle_min,
                           (float)sim_lidar_angle_inc(lid), (float)cfg->range_max};
    uint64_t total = 0;
    for (int i = 0; i < cfg->n_poses; i++) {
        rc = sim_lidar_scan(lid, w, poses[i].x, poses[i].y, poses[i].theta, 0, (uint64_t)i,
                            ranges, NULL);
        int32_t n = 0;
        if (rc == 0)
            rc = rt_samples_from_scan(&sc, &view, (float)poses[i].x, (float)poses[i].y,
                                      (float)poses[i].theta, buf,
                                      RT_SAMPLES_MAX_OUT(cfg->n_beams, cfg->points_per_beam), &n,
                                      NULL);
        if (rc < 0) {
            snprintf(err, errlen, "valset: pose %d: scan failed (%d)", i, rc);
            goto out;
        }
        rc = sim_samples_append(&wr, buf, (size_t)n);
        if (rc < 0) {
            snprintf(err, errlen, "%s: %s", path, hal_host_file_strerror(rc));
            goto out;
        }
        total += (uint64_t)n;
    }
    opened = 0;
    rc = sim_samples_close(&wr);
    if (rc < 0) {
        snprintf(err, errlen, "%s: %s", path, hal_host_file_strerror(rc));
        goto out;
    }
    if (n_samples)
        *n_samples = total;
out:
    if (opened)
        sim_samples_abort(&wr);
    sim_lidar_destroy(lid);
    sim_world_destroy(w);
    free(poses);
    free(ranges);
    free(buf);
    return rc;
}
