/* The RT core in exploration mode, one tick at a time on the fake board: it validates its cfg,
 * takes the GP's goal from the mailbox and drives towards it, makes the same samples from a
 * new scan as on a tour and integrates the scan into its grid, publishes the coarse seen view
 * at most once a second and only after a change, reports the exploration fields with no path
 * length or progress, stops (wheels at 0 once, no more samples) on GP_GOAL_MSG_DONE and when
 * the budget ran out, and allocates nothing. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "fake_board.h"
#include "rt_core_test_util.h"
#include "fw_link.h"
#include "rt/rt_core.h"

#define PERIOD_US 20000u

static fake_board_t fb;
static rt_core_t rt;
static const fw_link_t *link_;
static rt_explore_cfg_t xcfg;

static rt_core_cfg_t core_cfg(void)
{
    rt_core_cfg_t c;
    memset(&c, 0, sizeof c);
    c.follow = rt_follow_default_cfg();
    c.samples = (rt_samples_cfg_t){RT_SAMPLES_DEFAULT_BEAMS, RT_SAMPLES_DEFAULT_POINTS, 0.0f, 0.0f, 4.0f, 4.0f};
    c.period_us = PERIOD_US;
    xcfg = rt_explore_default_cfg();
    xcfg.res_m = 0.1f;
    xcfg.w = xcfg.h = 40; /* the 4 x 4 m box */
    xcfg.seen_factor = 4;
    xcfg.seen_w = xcfg.seen_h = 10;
    xcfg.budget_us = 10000000; /* 10 s */
    c.explore = &xcfg;
    return c;
}

static int setup(void **st)
{
    (void)st;
    fake_board_init(&fb);
    fake_board_install(&fb);
    fw_link_reset();
    link_ = fw_link_get();
    rt_core_cfg_t c = core_cfg();
    assert_int_equal(rt_core_init(&rt, &c, link_), 0);
    return 0;
}

static int teardown(void **st)
{
    (void)st;
    assert_int_equal(hal_board_install(NULL), 0);
    return 0;
}

static int tick(uint64_t k, int sub)
{
    return rt_test_tick(&rt, &fb, PERIOD_US, k, sub);
}

static void set_pose(float x, float y, float heading)
{
    rt_test_set_pose(&fb, x, y, heading);
}

/* A round room of radius `range` around the robot (beyond range_max: no return). */
static void set_scan(uint64_t stamp, float range)
{
    rt_test_set_scan(&fb, stamp, range);
}

static void send_goal(uint32_t seq, uint32_t mode, float x, float y)
{
    gp_goal_msg_t g = {.stamp_us = fb.now_us, .seq = seq, .mode = mode, .x_m = x, .y_m = y};
    assert_int_equal(mbox_put(link_->gp_goal, &g), 0);
}

static rt_status_t status(void)
{
    rt_status_t s;
    assert_int_equal(mbox_get(link_->rt_to_gp, &s, NULL), 1);
    return s;
}

static void test_init_checks_the_explore_cfg(void **st)
{
    (void)st;
    rt_core_cfg_t c = core_cfg();
    c.waypoints = NULL; /* no tour needed */
    c.n_waypoints = 0;
    assert_int_equal(rt_core_init(&rt, &c, link_), 0);
    assert_true(rt_core_path_length(&rt) == 0.0f);
    xcfg.seen_w = 65;
    assert_int_equal(rt_core_init(&rt, &c, link_), -EINVAL);
    xcfg.seen_w = 10;
    xcfg.w = RT_GRID_MAX_SIDE + 1;
    assert_int_equal(rt_core_init(&rt, &c, link_), -ENOSPC);
    xcfg.w = 40;
    c.period_us = 0;
    assert_int_equal(rt_core_init(&rt, &c, link_), -EINVAL);
    /* A tour still needs its waypoints. */
    c = core_cfg();
    c.explore = NULL;
    assert_int_equal(rt_core_init(&rt, &c, link_), -EINVAL);
}

static void test_drives_to_the_goal_and_reports(void **st)
{
    (void)st;
    alloc_count_reset();
    /* No goal yet: the wheels are held at 0; the scan still becomes samples and grid. */
    set_pose(1.0f, 1.0f, 0.0f);
    set_scan(100, 1.0f);
    assert_int_equal(tick(0, 1), 0);
    const uint32_t per_scan = RT_SAMPLES_DEFAULT_BEAMS * RT_SAMPLES_DEFAULT_POINTS;
    assert_int_equal(ring_count(link_->samples), per_scan);
    const fake_motor_cmd_t *m = fake_board_motor(&fb, 0);
    assert_non_null(m);
    assert_true(m->left == 0.0f && m->right == 0.0f);
    rt_status_t s = status();
    assert_int_equal(s.scans, 1);
    assert_int_equal(s.samples, per_scan);
    assert_int_equal(s.goal_seq, 0);
    assert_true(s.path_length_m == 0.0f && s.progress_m == 0.0f);
    /* The seen view: published after the first scan changed the grid. */
    rt_seen_t seen;
    uint64_t seq = 0;
    assert_int_equal(mbox_get(link_->rt_seen, &seen, &seq), 1);
    assert_int_equal(seq, 1);
    assert_int_equal(seen.w, 10);
    assert_int_equal(seen.updates, 1);
    assert_int_equal(seen.stamp_us, 100);
    assert_true(seen.unknown[2 * 10 + 2] < 255); /* around the robot: seen */
    assert_int_equal(seen.unknown[9 * 10 + 9], 255); /* the far corner: 3.6 m away */
    /* A goal 1 m ahead: planned, driven forward. */
    send_goal(1, GP_GOAL_MSG_GO, 1.9f, 1.0f);
    assert_int_equal(tick(1, 0), 0);
    m = fake_board_motor(&fb, 0);
    assert_true(m->left > 0.0f && m->right > 0.0f);
    s = status();
    assert_int_equal(s.goal_seq, 1);
    assert_int_equal(s.plans, 1);
    assert_true(s.distance_m > 0.0f);
    /* A new scan from a new pose: samples as on a tour; the view waits for its second. */
    set_pose(1.2f, 1.0f, 0.0f);
    set_scan(200, 0.9f); /* every point inside the box */
    assert_int_equal(tick(5, 1), 0);
    assert_int_equal(ring_count(link_->samples), 2 * per_scan);
    assert_int_equal(mbox_get(link_->rt_seen, &seen, NULL), 0);
    set_scan(300, 1.3f);
    assert_int_equal(tick(50, 1), 0); /* 1 s after the first view */
    assert_int_equal(mbox_get(link_->rt_seen, &seen, NULL), 1);
    assert_int_equal(seen.updates, 2);
    assert_int_equal(seen.stamp_us, 300);
    /* At the goal: reached, stopped. */
    set_pose(1.85f, 1.0f, 0.0f);
    assert_int_equal(tick(51, 0), 0);
    s = status();
    assert_int_equal(s.goal_reached, 1);
    assert_int_equal(s.finished, 0);
    m = fake_board_motor(&fb, 0);
    assert_true(m->left == 0.0f && m->right == 0.0f);
    assert_int_equal(alloc_count_allocations(), 0); /* the RT core never allocates */
    assert_int_equal(rt.stats.clock_mismatch, 0);
}

static void test_done_stops_wheels_and_samples(void **st)
{
    (void)st;
    set_pose(1.0f, 1.0f, 0.0f);
    send_goal(1, GP_GOAL_MSG_GO, 3.0f, 1.0f);
    assert_int_equal(tick(0, 0), 0);
    assert_true(fake_board_motor(&fb, 0)->left > 0.0f);
    send_goal(2, GP_GOAL_MSG_DONE, 0.0f, 0.0f);
    assert_int_equal(tick(1, 0), 0);
    assert_int_equal(status().finished, 1);
    const fake_motor_cmd_t *m = fake_board_motor(&fb, 0);
    assert_true(m->left == 0.0f && m->right == 0.0f);
    uint64_t n_motor = fb.n_motor;
    /* Finished: no command, no scan read into samples. */
    set_scan(500, 1.0f);
    assert_int_equal(tick(5, 1), 0);
    assert_int_equal(ring_count(link_->samples), 0);
    assert_int_equal(fb.n_motor, n_motor);
    rt_status_t s = status();
    assert_int_equal(s.scans, 0);
    assert_int_equal(s.stamp_us, 5 * PERIOD_US);
}

static void test_budget_ends_exploration(void **st)
{
    (void)st;
    set_pose(1.0f, 1.0f, 0.0f);
    send_goal(1, GP_GOAL_MSG_GO, 3.0f, 3.0f);
    assert_int_equal(tick(0, 0), 0);
    assert_int_equal(tick(499, 0), 0); /* 9.98 s: still exploring */
    assert_int_equal(status().finished, 0);
    assert_true(fake_board_motor(&fb, 0)->left != 0.0f || fake_board_motor(&fb, 0)->right != 0.0f);
    assert_int_equal(tick(500, 1), 0); /* 10 s since the first tick */
    rt_status_t s = status();
    assert_int_equal(s.finished, 1);
    assert_int_equal(s.scans, 0);
    const fake_motor_cmd_t *m = fake_board_motor(&fb, 0);
    assert_true(m->left == 0.0f && m->right == 0.0f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_init_checks_the_explore_cfg, setup, teardown),
        cmocka_unit_test_setup_teardown(test_drives_to_the_goal_and_reports, setup, teardown),
        cmocka_unit_test_setup_teardown(test_done_stops_wheels_and_samples, setup, teardown),
        cmocka_unit_test_setup_teardown(test_budget_ends_exploration, setup, teardown),
    };
    return cmocka_run_group_tests_name("rt/core_explore", tests, NULL, NULL);
}
