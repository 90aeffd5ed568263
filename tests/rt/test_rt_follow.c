/* The RT core's waypoint follower alone (no world): full speed towards a waypoint ahead,
 * turning in place when facing away, reaching and advancing, ramping down to the last one,
 * bad input, and the wheel-speed limit keeping the curvature. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <cmocka.h>

#include "rt/rt_follow.h"

static void test_follower_unit(void **st)
{
    (void)st;
    rt_follow_t f;
    rt_follow_cfg_t c = rt_follow_default_cfg();
    assert_int_equal(rt_follow_init(&f, &c), 0);
    rt_waypoint_t wp[2] = {{1, 0}, {1, 1}};
    rt_follow_cmd_t cmd;
    /* Facing the first waypoint: full speed, no turn. */
    assert_int_equal(rt_follow_step(&f, wp, 2, 0, 0, 0, &cmd), 0);
    assert_float_equal(cmd.v, c.v_max, 1e-6);
    assert_float_equal(cmd.omega, 0, 1e-6);
    assert_float_equal(cmd.wheel_left, c.v_max / c.wheel_radius, 1e-4);
    /* Facing away: turn in place, clamped to w_max. */
    assert_int_equal(rt_follow_step(&f, wp, 2, 0, 0, 3.0f, &cmd), 0);
    assert_float_equal(cmd.v, 0, 1e-6);
    assert_true(fabsf(cmd.omega) <= c.w_max + 1e-6f);
    assert_float_equal(cmd.wheel_left, -cmd.wheel_right, 1e-4);
    /* At the first waypoint: reached, aims at the second. */
    assert_int_equal(rt_follow_step(&f, wp, 2, 1.0f, 0.01f, 1.57f, &cmd), 0);
    assert_int_equal(cmd.reached, 1);
    assert_int_equal(cmd.target, 1);
    /* Near the last one the speed ramps down with distance. */
    assert_int_equal(rt_follow_step(&f, wp, 2, 1.0f, 0.9f, 1.5708f, &cmd), 0);
    assert_true(cmd.v <= c.k_dist * 0.1f + 1e-5f);
    assert_int_equal(rt_follow_step(&f, wp, 2, 1.0f, 1.0f, 1.5708f, &cmd), 0);
    assert_int_equal(cmd.finished, 1);
    assert_float_equal(cmd.v, 0, 0);
    /* Bad input. */
    assert_int_equal(rt_follow_step(&f, wp, 0, 0, 0, 0, &cmd), -EINVAL);
    assert_int_equal(rt_follow_step(&f, wp, 2, NAN, 0, 0, &cmd), -EINVAL);
    c.v_max = -1;
    assert_int_equal(rt_follow_init(&f, &c), -EINVAL);
    float l, r;
    assert_int_equal(rt_follow_wheels(0.22f, 2.84f, 0.033f, 0.16f, 6.6667f, &l, &r), 0);
    /* Over the wheel limit: both scaled, ratio (curvature) kept. */
    assert_true(fabsf(r) <= 6.6668f);
    assert_float_equal((r - l) / (r + l), (2.84f * 0.08f) / 0.22f, 1e-4);
    assert_float_equal(rt_wrap_angle(3.0f * 3.14159265f), 3.14159265f, 1e-5);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_follower_unit),
    };
    return cmocka_run_group_tests_name("rt/follow", tests, NULL, NULL);
}
