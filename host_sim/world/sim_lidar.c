/* Lidar on ODE rays and GPS/compass. Contract in sim_lidar.h. */
#include "sim_lidar.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>

#include "rt/rt_follow.h"
#include "sim_rng.h"

/* Noise streams (sim_rng keys). */
enum { STREAM_DROPOUT = 1, STREAM_RANGE = 2 /* and 3 */, STREAM_GPS = 10 /* .. 15 */ };

struct sim_lidar {
    sim_lidar_cfg_t cfg;
    double *dir; /* cos, sin of each beam's offset angle (angle_min + b * inc) */
    dGeomID ray;
    double best; /* closest hit of the current cast */
};

sim_lidar_cfg_t sim_lidar_default_cfg(void)
{
    sim_lidar_cfg_t c = {
        .n_beams = 360,
        .range_min = 0.12,
        .range_max = 3.5,
        .noise_sigma = 0.01,
        .dropout_p = 0.0,
        .mount_height = 0.17,
        .angle_min = 0.0,
        .seed = 1,
    };
    return c;
}

int sim_lidar_create(const sim_lidar_cfg_t *cfg, sim_lidar_t **out)
{
    if (cfg == NULL || out == NULL)
        return -EINVAL;
    *out = NULL;
    const sim_lidar_cfg_t *c = cfg;
    if (c->n_beams < 1 || c->n_beams > SIM_LIDAR_MAX_BEAMS || !isfinite(c->range_min) ||
        c->range_min < 0 || !isfinite(c->range_max) || !(c->range_max > c->range_min) ||
        !isfinite(c->noise_sigma) || c->noise_sigma < 0 || !isfinite(c->dropout_p) ||
        c->dropout_p < 0 || c->dropout_p >= 1 || !isfinite(c->mount_height) ||
        !(c->mount_height > 0) || !isfinite(c->angle_min))
        return -EINVAL;
    sim_lidar_t *l = calloc(1, sizeof *l);
    if (l == NULL)
        return -ENOMEM;
    l->cfg = *c;
    l->dir = malloc(sizeof(double) * 2 * (size_t)c->n_beams);
    if (l->dir == NULL) {
        free(l);
        return -ENOMEM;
    }
    for (int b = 0; b < c->n_beams; b++) {
        double a = c->angle_min + b * (6.283185307179586 / (double)c->n_beams);
        l->dir[2 * b] = cos(a);
        l->dir[2 * b + 1] = sin(a);
    }
    /* Not in any space: it is collided explicitly against the walls' space. */
    l->ray = dCreateRay(0, c->range_max);
    dGeomRaySetClosestHit(l->ray, 1);
    dGeomRaySetFirstContact(l->ray, 0);
    dGeomRaySetBackfaceCull(l->ray, 1);
    dGeomSetData(l->ray, l);
    *out = l;
    return 0;
}

void sim_lidar_destroy(sim_lidar_t *l)
{
    if (l == NULL)
        return;
    dGeomDestroy(l->ray);
    free(l->dir);
    free(l);
}

const sim_lidar_cfg_t *sim_lidar_cfg(const sim_lidar_t *l) { return l ? &l->cfg : NULL; }

double sim_lidar_angle_inc(const sim_lidar_t *l)
{
    return 6.283185307179586 / (double)l->cfg.n_beams;
}

static void ray_cb(void *data, dGeomID a, dGeomID b)
{
    sim_lidar_t *l = data;
    dContactGeom cg;
    /* dCollide wants the ray first to report depth as the distance along it. */
    dGeomID ray = a == l->ray ? a : b, other = a == l->ray ? b : a;
    if (dCollide(ray, other, 1, &cg, sizeof cg) == 1 && cg.depth < l->best)
        l->best = cg.depth;
}

static double cast_dir(sim_lidar_t *l, dSpaceID walls, double x, double y, double dx, double dy)
{
    l->best = INFINITY;
    dGeomRaySet(l->ray, x, y, l->cfg.mount_height, dx, dy, 0.0);
    dSpaceCollide2(l->ray, (dGeomID)walls, l, ray_cb);
    return l->best < l->cfg.range_max ? l->best : INFINITY;
}

double sim_lidar_cast(sim_lidar_t *l, const sim_world_t *w, double x, double y, double angle)
{
    if (l == NULL || w == NULL)
        return NAN;
    return cast_dir(l, sim_world_walls(w), x, y, cos(angle), sin(angle));
}

int sim_lidar_scan(sim_lidar_t *l, const sim_world_t *w, double x, double y, double theta,
                   uint32_t robot, uint64_t scan_index, float *ranges, double *truth)
{
    if (l == NULL || w == NULL || ranges == NULL || !isfinite(x) || !isfinite(y) ||
        !isfinite(theta))
        return -EINVAL;
    const sim_lidar_cfg_t *c = &l->cfg;
    dSpaceID walls = sim_world_walls(w);
    /* Beam directions: the precomputed offsets rotated by theta (no trig per beam). */
    double ct = cos(theta), st = sin(theta);
    for (int b = 0; b < c->n_beams; b++) {
        double ob = l->dir[2 * b], sb = l->dir[2 * b + 1];
        double d = cast_dir(l, walls, x, y, ct * ob - st * sb, st * ob + ct * sb);
        if (truth)
            truth[b] = d;
        float r;
        if (c->dropout_p > 0 &&
            sim_rng_uniform(c->seed, STREAM_DROPOUT, robot, scan_index, (uint64_t)b) < c->dropout_p) {
            r = NAN;
        } else if (isinf(d)) {
            r = INFINITY;
        } else if (d < c->range_min) {
            r = NAN; /* too close for the sensor: it reports nothing usable */
        } else {
            double n = c->noise_sigma > 0
                           ? c->noise_sigma * sim_rng_normal(c->seed, STREAM_RANGE, robot,
                                                             scan_index, (uint64_t)b)
                           : 0.0;
            double v = d + n;
            if (v >= c->range_max)
                r = INFINITY;
            else
                r = (float)fmax(v, c->range_min);
        }
        ranges[b] = r;
    }
    return 0;
}

sim_gps_cfg_t sim_gps_default_cfg(void)
{
    sim_gps_cfg_t c = {.sigma_xy = 0.02, .sigma_theta = 0.01, .seed = 1};
    return c;
}

int sim_gps_read(const sim_gps_cfg_t *cfg, uint32_t robot, uint64_t index,
                 const sim_pose_t *truth, sim_pose_t *out)
{
    if (cfg == NULL || truth == NULL || out == NULL || !isfinite(cfg->sigma_xy) ||
        cfg->sigma_xy < 0 || !isfinite(cfg->sigma_theta) || cfg->sigma_theta < 0 ||
        !isfinite(truth->x) || !isfinite(truth->y) || !isfinite(truth->theta))
        return -EINVAL;
    out->x = truth->x + cfg->sigma_xy * sim_rng_normal(cfg->seed, STREAM_GPS, robot, index, 0);
    out->y = truth->y + cfg->sigma_xy * sim_rng_normal(cfg->seed, STREAM_GPS + 2, robot, index, 0);
    out->theta = rt_wrap_angle((float)(truth->theta + cfg->sigma_theta *
                                                          sim_rng_normal(cfg->seed, STREAM_GPS + 4,
                                                                         robot, index, 0)));
    return 0;
}
