/* The RT core's reactive avoidance on synthetic scans of a straight wall: it stops the robot in
 * front of the wall, slows it on approach, never blocks a turn in place, lets a robot facing
 * the wall turn away and leave, watches behind when reversing, ignores dropouts and far
 * returns, and rejects bad input. A closed loop (follower -> avoidance -> unicycle) drives at
 * a wall and must stop short of it. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "rt/rt_avoid.h"

#define N_BEAMS 360
#define PI_F 3.14159265358979f
static float ranges[N_BEAMS];

/* A 360-beam scan (beam 0 at -pi, like host_sim's lidar) at pose (x, y, theta) of the wall
 * x = wall_x (infinite in y); +INF where a beam misses it or it is beyond range_max. */
static rt_scan_view_t wall_scan(float x, float theta, float wall_x)
{
    rt_scan_view_t s = {ranges, N_BEAMS, -PI_F, 2.0f * PI_F / N_BEAMS, 3.5f};
    for (int i = 0; i < N_BEAMS; i++) {
        float c = cosf(theta + s.angle_min + (float)i * s.angle_inc);
        float r = c > 1e-6f ? (wall_x - x) / c : INFINITY;
        ranges[i] = r < s.range_max ? r : INFINITY;
    }
    return s;
}

static void test_stop_slow_turn(void **st)
{
    (void)st;
    rt_follow_cfg_t fc = rt_follow_default_cfg();
    rt_avoid_cfg_t ac = rt_avoid_default_cfg();
    rt_follow_t f;
    rt_follow_cmd_t cmd;
    rt_waypoint_t ahead[1] = {{2.0f, 0.0f}}, behind[1] = {{-2.0f, 0.0f}};
    float d;
    alloc_count_reset();
    /* Wall 0.2 m ahead: stop. */
    rt_scan_view_t s = wall_scan(0.0f, 0.0f, 0.2f);
    assert_int_equal(rt_follow_init(&f, &fc), 0);
    assert_int_equal(rt_follow_step(&f, ahead, 1, 0, 0, 0, &cmd), 0);
    assert_true(cmd.v > 0.2f);
    assert_int_equal(rt_avoid_apply(&ac, &fc, &s, &cmd, &d), 1);
    assert_float_equal(d, 0.2f, 1e-5);
    assert_float_equal(cmd.v, 0.0f, 0.0f);
    assert_float_equal(cmd.wheel_left, cmd.wheel_right, 1e-6); /* omega 0: both wheels still */
    assert_float_equal(cmd.wheel_left, 0.0f, 1e-6);
    /* Wall 0.4 m ahead: slowed by (0.4 - 0.25) / (0.6 - 0.25). */
    s = wall_scan(0.0f, 0.0f, 0.4f);
    assert_int_equal(rt_follow_step(&f, ahead, 1, 0, 0, 0, &cmd), 0);
    float v0 = cmd.v;
    assert_int_equal(rt_avoid_apply(&ac, &fc, &s, &cmd, NULL), 1);
    assert_float_equal(cmd.v, v0 * 0.15f / 0.35f, 1e-5);
    assert_float_equal(cmd.wheel_left, cmd.v / fc.wheel_radius, 1e-3);
    /* Wall 1 m ahead: untouched. */
    s = wall_scan(0.0f, 0.0f, 1.0f);
    assert_int_equal(rt_follow_step(&f, ahead, 1, 0, 0, 0, &cmd), 0);
    rt_follow_cmd_t before = cmd;
    assert_int_equal(rt_avoid_apply(&ac, &fc, &s, &cmd, &d), 0);
    assert_memory_equal(&before, &cmd, sizeof cmd);
    /* Facing the wall at 0.2 m with the goal behind: the follower turns in place, allowed. */
    s = wall_scan(0.0f, 0.0f, 0.2f);
    assert_int_equal(rt_follow_init(&f, &fc), 0);
    assert_int_equal(rt_follow_step(&f, behind, 1, 0, 0, 0, &cmd), 0);
    assert_float_equal(cmd.v, 0.0f, 0.0f);
    assert_true(fabsf(cmd.omega) > 1.0f);
    before = cmd;
    assert_int_equal(rt_avoid_apply(&ac, &fc, &s, &cmd, NULL), 0);
    assert_memory_equal(&before, &cmd, sizeof cmd);
    /* Turned away (wall behind): free to drive. */
    s = wall_scan(0.0f, PI_F, 0.2f);
    assert_int_equal(rt_follow_step(&f, behind, 1, 0, 0, PI_F, &cmd), 0);
    assert_true(cmd.v > 0.2f);
    assert_int_equal(rt_avoid_apply(&ac, &fc, &s, &cmd, &d), 0);
    assert_true(isinf(d));
    /* Reversing towards the wall: the cone looks behind. */
    s = wall_scan(0.0f, PI_F, 0.2f);
    cmd.v = -0.1f;
    assert_int_equal(rt_avoid_apply(&ac, &fc, &s, &cmd, &d), 1);
    assert_float_equal(cmd.v, 0.0f, 0.0f);
    assert_int_equal(alloc_count_allocations(), 0);
}

static void test_dropouts_and_bad_input(void **st)
{
    (void)st;
    rt_follow_cfg_t fc = rt_follow_default_cfg();
    rt_avoid_cfg_t ac = rt_avoid_default_cfg();
    rt_scan_view_t s = wall_scan(0.0f, 0.0f, 0.2f);
    for (int i = 0; i < N_BEAMS; i++) /* the wall's returns dropped out: nothing seen */
        if (isfinite(ranges[i]))
            ranges[i] = NAN;
    rt_follow_cmd_t cmd = {.v = 0.2f, .omega = 0.0f};
    assert_int_equal(rt_avoid_apply(&ac, &fc, &s, &cmd, NULL), 0);
    assert_float_equal(cmd.v, 0.2f, 0.0f);
    ranges[N_BEAMS / 2 + 80] = 0.1f; /* a close return 80 degrees left: outside the cone */
    assert_int_equal(rt_avoid_apply(&ac, &fc, &s, &cmd, NULL), 0);
    ranges[N_BEAMS / 2 + 20] = 0.1f; /* 20 degrees left: inside */
    assert_int_equal(rt_avoid_apply(&ac, &fc, &s, &cmd, NULL), 1);
    cmd.v = 0.2f;
    assert_int_equal(rt_avoid_apply(NULL, &fc, &s, &cmd, NULL), -EINVAL);
    assert_int_equal(rt_avoid_apply(&ac, NULL, &s, &cmd, NULL), -EINVAL);
    assert_int_equal(rt_avoid_apply(&ac, &fc, NULL, &cmd, NULL), -EINVAL);
    assert_int_equal(rt_avoid_apply(&ac, &fc, &s, NULL, NULL), -EINVAL);
    rt_avoid_cfg_t bad = ac;
    bad.slow_dist_m = bad.stop_dist_m;
    assert_int_equal(rt_avoid_apply(&bad, &fc, &s, &cmd, NULL), -EINVAL);
    bad = ac;
    bad.half_angle_rad = 4.0f;
    assert_int_equal(rt_avoid_apply(&bad, &fc, &s, &cmd, NULL), -EINVAL);
    rt_scan_view_t bs = s;
    bs.n_scan = 0;
    assert_int_equal(rt_avoid_apply(&ac, &fc, &bs, &cmd, NULL), -EINVAL);
    bs = s;
    bs.range_max = 0.0f;
    assert_int_equal(rt_avoid_apply(&ac, &fc, &bs, &cmd, NULL), -EINVAL);
    cmd.v = NAN;
    assert_int_equal(rt_avoid_apply(&ac, &fc, &s, &cmd, NULL), -EINVAL);
}

/* Closed loop: follower -> avoidance -> unicycle at 50 Hz. A goal beyond a wall at x = 1 m:
 * the robot comes to rest at the stopping distance; then the goal moves behind it and the robot turns and
 * leaves, reaching it. */
static void test_closed_loop(void **st)
{
    (void)st;
    rt_follow_cfg_t fc = rt_follow_default_cfg();
    rt_avoid_cfg_t ac = rt_avoid_default_cfg();
    rt_follow_t f;
    rt_follow_cmd_t cmd;
    assert_int_equal(rt_follow_init(&f, &fc), 0);
    rt_waypoint_t goal[1] = {{2.0f, 0.0f}};
    float x = 0.0f, y = 0.0f, th = 0.0f, dt = 0.02f, closest = 9.0f;
    int intervened = 0;
    for (int k = 0; k < 1000; k++) {
        rt_scan_view_t s = wall_scan(x, th, 1.0f);
        assert_int_equal(rt_follow_step(&f, goal, 1, x, y, th, &cmd), 0);
        intervened += rt_avoid_apply(&ac, &fc, &s, &cmd, NULL) == 1;
        x += cmd.v * cosf(th) * dt;
        y += cmd.v * sinf(th) * dt;
        th += cmd.omega * dt;
        closest = fminf(closest, 1.0f - x);
    }
    /* The slow-down is proportional to the gap left: the robot creeps up to the stopping
     * distance and is at rest there, never closer. */
    assert_true(intervened > 100);
    assert_true(fabsf(cmd.v) < 0.005f);
    assert_true(closest >= ac.stop_dist_m - 0.005f);
    assert_true(closest <= ac.stop_dist_m + 0.02f);
    goal[0] = (rt_waypoint_t){-1.0f, 0.0f};
    assert_int_equal(rt_follow_init(&f, &fc), 0);
    for (int k = 0; k < 1500 && !cmd.finished; k++) {
        rt_scan_view_t s = wall_scan(x, th, 1.0f);
        assert_int_equal(rt_follow_step(&f, goal, 1, x, y, th, &cmd), 0);
        assert_true(rt_avoid_apply(&ac, &fc, &s, &cmd, NULL) >= 0);
        x += cmd.v * cosf(th) * dt;
        y += cmd.v * sinf(th) * dt;
        th += cmd.omega * dt;
    }
    assert_int_equal(cmd.finished, 1);
    assert_true(fabsf(x + 1.0f) < fc.reach_tol_m + 0.01f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_stop_slow_turn),
        cmocka_unit_test(test_dropouts_and_bad_input),
        cmocka_unit_test(test_closed_loop),
    };
    return cmocka_run_group_tests_name("rt/avoid", tests, NULL, NULL);
}
