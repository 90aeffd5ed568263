/* Waypoint follower: see rt_follow.h for the control law. */
#include "rt/rt_follow.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>

#define RT_PI 3.14159265358979323846f

rt_follow_cfg_t rt_follow_default_cfg(void)
{
    rt_follow_cfg_t c = {
        .v_max = 0.22f,
        .w_max = 2.84f,
        .wheel_radius = 0.033f,
        .wheel_separation = 0.160f,
        .reach_tol_m = 0.08f,
        .turn_in_place_rad = 0.6f,
        .k_heading = 3.0f,
        .k_dist = 1.0f,
    };
    return c;
}

static int pos_finite(float v) { return isfinite(v) && v > 0.0f; }

int rt_follow_init(rt_follow_t *f, const rt_follow_cfg_t *cfg)
{
    if (f == NULL || cfg == NULL)
        return -EINVAL;
    if (!pos_finite(cfg->v_max) || !pos_finite(cfg->w_max) || !pos_finite(cfg->wheel_radius) ||
        !pos_finite(cfg->wheel_separation) || !pos_finite(cfg->reach_tol_m) ||
        !pos_finite(cfg->turn_in_place_rad) || cfg->turn_in_place_rad > RT_PI ||
        !pos_finite(cfg->k_heading) || !pos_finite(cfg->k_dist))
        return -EINVAL;
    f->cfg = *cfg;
    f->index = 0;
    f->finished = 0;
    return 0;
}

float rt_wrap_angle(float a)
{
    if (!isfinite(a))
        return a;
    a = fmodf(a, 2.0f * RT_PI);
    if (a > RT_PI)
        a -= 2.0f * RT_PI;
    else if (a <= -RT_PI)
        a += 2.0f * RT_PI;
    return a;
}

static float clampf(float v, float lo, float hi) { return v < lo ? lo : (v > hi ? hi : v); }

int rt_follow_wheels(float v, float omega, float wheel_radius, float wheel_separation,
                     float wheel_max, float *left, float *right)
{
    if (left == NULL || right == NULL || !isfinite(v) || !isfinite(omega) ||
        !pos_finite(wheel_radius) || !pos_finite(wheel_separation) || !pos_finite(wheel_max))
        return -EINVAL;
    float l = (v - omega * wheel_separation * 0.5f) / wheel_radius;
    float r = (v + omega * wheel_separation * 0.5f) / wheel_radius;
    float m = fmaxf(fabsf(l), fabsf(r));
    if (m > wheel_max) {
        /* Same factor on both wheels: the turn radius v/omega is preserved. */
        float s = wheel_max / m;
        l *= s;
        r *= s;
    }
    *left = l;
    *right = r;
    return 0;
}

int rt_follow_step(rt_follow_t *f, const rt_waypoint_t *wps, int32_t n, float x, float y,
                   float theta, rt_follow_cmd_t *cmd)
{
    if (f == NULL || wps == NULL || cmd == NULL || n < 1 || !isfinite(x) || !isfinite(y) ||
        !isfinite(theta))
        return -EINVAL;
    const rt_follow_cfg_t *c = &f->cfg;
    cmd->reached = 0;
    /* Skip every waypoint already within tolerance (several may be, e.g. duplicates). */
    while (!f->finished && f->index < n) {
        float dx = wps[f->index].x - x, dy = wps[f->index].y - y;
        if (!isfinite(dx) || !isfinite(dy))
            return -EINVAL;
        if (sqrtf(dx * dx + dy * dy) > c->reach_tol_m)
            break;
        f->index++;
        cmd->reached++;
    }
    if (f->index >= n)
        f->finished = 1;
    cmd->finished = f->finished;
    cmd->target = f->finished ? n : f->index;
    if (f->finished) {
        cmd->v = cmd->omega = cmd->wheel_left = cmd->wheel_right = 0.0f;
        return 0;
    }
    float dx = wps[f->index].x - x, dy = wps[f->index].y - y;
    float dist = sqrtf(dx * dx + dy * dy);
    float err = rt_wrap_angle(atan2f(dy, dx) - theta);
    float omega = clampf(c->k_heading * err, -c->w_max, c->w_max);
    float v = 0.0f;
    if (fabsf(err) <= c->turn_in_place_rad) {
        v = c->v_max * cosf(err);
        if (f->index == n - 1)
            v = fminf(v, c->k_dist * dist);
        v = clampf(v, 0.0f, c->v_max);
    }
    cmd->v = v;
    cmd->omega = omega;
    /* Wheel limit = the speed limit at the rim, v_max / r (burger: 6.67 rad/s). */
    return rt_follow_wheels(v, omega, c->wheel_radius, c->wheel_separation,
                            c->v_max / c->wheel_radius, &cmd->wheel_left, &cmd->wheel_right);
}
