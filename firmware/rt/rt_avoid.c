/* Reactive avoidance: see rt_avoid.h for the rule. */
#include "rt/rt_avoid.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>

#define RT_PI 3.14159265358979323846f

rt_avoid_cfg_t rt_avoid_default_cfg(void)
{
    rt_avoid_cfg_t c = {.stop_dist_m = 0.25f, .slow_dist_m = 0.6f, .half_angle_rad = 0.5f};
    return c;
}

static int pos_finite(float v) { return isfinite(v) && v > 0.0f; }

int rt_avoid_apply(const rt_avoid_cfg_t *cfg, const rt_follow_cfg_t *follow,
                   const rt_scan_view_t *scan, rt_follow_cmd_t *cmd, float *nearest_m)
{
    if (cfg == NULL || follow == NULL || scan == NULL || cmd == NULL || scan->ranges == NULL)
        return -EINVAL;
    if (!pos_finite(cfg->stop_dist_m) || !isfinite(cfg->slow_dist_m) ||
        !(cfg->slow_dist_m > cfg->stop_dist_m) || !pos_finite(cfg->half_angle_rad) ||
        cfg->half_angle_rad > RT_PI)
        return -EINVAL;
    if (!pos_finite(follow->v_max) || !pos_finite(follow->wheel_radius) ||
        !pos_finite(follow->wheel_separation))
        return -EINVAL;
    if (scan->n_scan < 1 || !isfinite(scan->angle_min) || !isfinite(scan->angle_inc) ||
        !pos_finite(scan->range_max) || !isfinite(cmd->v) || !isfinite(cmd->omega))
        return -EINVAL;
    if (nearest_m != NULL)
        *nearest_m = INFINITY;
    /* Turning in place (or standing) moves the footprint nowhere new: never block it, or a
     * robot stopped in front of a wall could not turn away. */
    if (cmd->v == 0.0f)
        return 0;
    float travel = cmd->v > 0.0f ? 0.0f : RT_PI;
    float d = INFINITY;
    for (int32_t i = 0; i < scan->n_scan; i++) {
        float r = scan->ranges[i];
        if (isnan(r) || r >= scan->range_max)
            continue; /* dropout, or nothing within range */
        float a = rt_wrap_angle(scan->angle_min + (float)i * scan->angle_inc - travel);
        if (fabsf(a) <= cfg->half_angle_rad && r < d)
            d = r;
    }
    if (nearest_m != NULL)
        *nearest_m = d;
    if (!(d < cfg->slow_dist_m))
        return 0;
    float scale = d <= cfg->stop_dist_m
                      ? 0.0f
                      : (d - cfg->stop_dist_m) / (cfg->slow_dist_m - cfg->stop_dist_m);
    cmd->v *= scale;
    int r = rt_follow_wheels(cmd->v, cmd->omega, follow->wheel_radius, follow->wheel_separation,
                             follow->v_max / follow->wheel_radius, &cmd->wheel_left,
                             &cmd->wheel_right);
    return r != 0 ? r : 1;
}
