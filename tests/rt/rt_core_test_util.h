/* What the RT core's tests share: ticks at their simulated time on the fake board, and the
 * pose and the scan the board returns. */
#ifndef TESTS_RT_CORE_TEST_UTIL_H
#define TESTS_RT_CORE_TEST_UTIL_H

#include <stdint.h>
#include <string.h>

#include "fake_board.h"
#include "rt/rt_core.h"

#define RT_TEST_PI_F 3.14159265358979f

/* Tick k (period_us apart) at its simulated time; sub = a scan tick. */
static inline int rt_test_tick(rt_core_t *rt, fake_board_t *fb, uint32_t period_us, uint64_t k, int sub)
{
    fb->now_us = k * period_us;
    fw_tick_t t = {.now_us = fb->now_us, .index = k, .sub = (uint32_t)sub};
    return rt_core_tick(rt, &t);
}

static inline void rt_test_set_pose(fake_board_t *fb, float x, float y, float heading)
{
    fb->pose = (hal_pose_t){fb->now_us, x, y, heading};
    fb->pose_rc = 0;
}

/* 360 beams all round, every one reading `range` (beyond 3.5 m: no return): a round room. */
static inline void rt_test_set_scan(fake_board_t *fb, uint64_t stamp, float range)
{
    memset(&fb->scan, 0, sizeof fb->scan);
    fb->scan.stamp_us = stamp;
    fb->scan.angle_min_rad = -RT_TEST_PI_F;
    fb->scan.angle_step_rad = (2.0f * RT_TEST_PI_F / 360.0f);
    fb->scan.range_min_m = 0.12f;
    fb->scan.range_max_m = 3.5f;
    fb->scan.count = 360;
    for (int i = 0; i < 360; i++)
        fb->scan.ranges_m[i] = range;
    fb->lidar_rc = 0;
}

#endif /* TESTS_RT_CORE_TEST_UTIL_H */
