/* Waypoint follower for a differential-drive robot (RT core, pure C11, no allocation).
 *
 * Strategy: turn-then-drive with a proportional heading loop.
 *   - heading error e = wrap(atan2(wp - pos) - theta) in (-pi, pi].
 *   - |e| > turn_in_place_rad: rotate in place, omega = clamp(k_heading * e, +-w_max), v = 0.
 *   - otherwise drive: v = v_max * cos(e), slowed near the LAST waypoint
 *     (v <= k_dist * distance so the robot does not overshoot the end of the path),
 *     omega = clamp(k_heading * e).
 *   - a waypoint counts as reached when the distance to it is <= reach_tol_m; the follower
 *     then moves on to the next one. After the last one it reports finished and commands 0.
 * The (v, omega) command is converted to wheel angular velocities with rt_follow_wheels(),
 * which scales both wheels down together when one would exceed the wheel limit, so the
 * path curvature is kept.
 *
 * Units: metres, radians, seconds; theta is the heading of the robot's +x axis, CCW from
 * the world +x axis. Not thread-safe per follower; followers are independent. */
#ifndef RT_FOLLOW_H
#define RT_FOLLOW_H

#include <stdint.h>

typedef struct rt_waypoint {
    float x, y; /* metres, world frame */
} rt_waypoint_t;

typedef struct rt_follow_cfg {
    float v_max;             /* m/s, > 0 (TurtleBot3 burger: 0.22) */
    float w_max;             /* rad/s, > 0 (burger: 2.84) */
    float wheel_radius;      /* m, > 0 (burger: 0.033) */
    float wheel_separation;  /* m, > 0 (burger: 0.160) */
    float reach_tol_m;       /* m, > 0: distance at which a waypoint counts as reached */
    float turn_in_place_rad; /* rad in (0, pi]: heading error above which the robot only turns */
    float k_heading;         /* 1/s, > 0: proportional gain on the heading error */
    float k_dist;            /* 1/s, > 0: v <= k_dist * distance to the final waypoint */
} rt_follow_cfg_t;

typedef struct rt_follow {
    rt_follow_cfg_t cfg;
    int32_t index;    /* waypoint currently aimed at */
    int32_t finished; /* 1 once the last waypoint was reached */
} rt_follow_t;

typedef struct rt_follow_cmd {
    float v;          /* m/s */
    float omega;      /* rad/s, CCW positive */
    float wheel_left; /* rad/s, wheel angular velocity (positive drives forward) */
    float wheel_right;
    int32_t target;   /* waypoint index aimed at after this step (== n when finished) */
    int32_t reached;  /* waypoints reached during this step (0, 1, ...) */
    int32_t finished; /* 1 when the whole path is done */
} rt_follow_cmd_t;

/* The TurtleBot3-burger defaults described above (reach 0.08 m, turn above 0.6 rad,
 * k_heading 3/s, k_dist 1/s). */
rt_follow_cfg_t rt_follow_default_cfg(void);

/* Validates cfg (every field positive and finite, turn_in_place_rad <= pi) and resets the
 * follower to waypoint 0. Returns 0 or -EINVAL. */
FS_MUST_CHECK
int rt_follow_init(rt_follow_t *f, const rt_follow_cfg_t *cfg);

/* One control step from the pose (x, y, theta). wps: n >= 1 waypoints (the same list on
 * every call). Fills *cmd. Returns 0, or -EINVAL on a NULL pointer, n < 1 or a non-finite
 * pose. When n is smaller than the current index the follower reports finished. */
FS_MUST_CHECK
int rt_follow_step(rt_follow_t *f, const rt_waypoint_t *wps, int32_t n, float x, float y,
                   float theta, rt_follow_cmd_t *cmd);

/* Differential-drive inverse kinematics: wheel rates for (v, omega),
 *   left = (v - omega * sep / 2) / r,  right = (v + omega * sep / 2) / r,
 * both scaled by the same factor so that neither exceeds wheel_max (rad/s, > 0).
 * Returns 0 or -EINVAL. */
FS_MUST_CHECK
int rt_follow_wheels(float v, float omega, float wheel_radius, float wheel_separation,
                     float wheel_max, float *left, float *right);

/* Angle wrapped to (-pi, pi]. */
float rt_wrap_angle(float a);

#endif /* RT_FOLLOW_H */
