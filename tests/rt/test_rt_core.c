/* The RT core, one tick at a time on the fake board (no world, no threads): it follows the
 * scripted pose with wheel commands, turns a new scan into labelled samples in the RT -> AI
 * ring (and an old one into nothing), counts a full ring apart from other failures, survives
 * failing HAL calls, publishes its status every tick, stops at the last waypoint, and
 * allocates nothing. */
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

#define PI_F 3.14159265358979f

static fake_board_t fb;
static rt_core_t rt;
static const fw_link_t *link_;
static const rt_waypoint_t WPS[3] = {{1.0f, 1.0f}, {3.0f, 1.0f}, {3.0f, 3.0f}};
#define PERIOD_US 20000u

static int setup(void **st)
{
    (void)st;
    fake_board_init(&fb);
    fake_board_install(&fb);
    fw_link_reset();
    link_ = fw_link_get();
    rt_core_cfg_t c;
    memset(&c, 0, sizeof c);
    c.waypoints = WPS;
    c.n_waypoints = 3;
    c.follow = rt_follow_default_cfg();
    c.samples = (rt_samples_cfg_t){RT_SAMPLES_DEFAULT_BEAMS, RT_SAMPLES_DEFAULT_POINTS, 0.0f, 0.0f, 4.0f, 4.0f};
    c.period_us = PERIOD_US;
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

static rt_status_t status(void)
{
    rt_status_t s;
    assert_int_equal(mbox_get(link_->rt_to_gp, &s, NULL), 1);
    return s;
}

static void test_follows_the_scripted_pose(void **st)
{
    (void)st;
    /* No fix yet: nothing commanded, not an error. */
    assert_int_equal(tick(0, 0), 0);
    assert_int_equal(fb.n_motor, 0);
    assert_int_equal(status().errors, 0);
    /* At the first waypoint facing the second: straight ahead, both wheels forward. */
    set_pose(1.0f, 1.0f, 0.0f);
    assert_int_equal(tick(1, 0), 0);
    const fake_motor_cmd_t *m = fake_board_motor(&fb, 0);
    assert_non_null(m);
    assert_true(m->left > 0.0f && fabsf(m->left - m->right) < 1e-4f);
    rt_status_t s = status();
    assert_int_equal(s.waypoint, 1);
    assert_true(s.distance_m > 0.0f);
    /* Half-way, facing away from the target (heading pi): it turns in place. */
    set_pose(2.0f, 1.0f, PI_F);
    assert_int_equal(tick(2, 0), 0);
    m = fake_board_motor(&fb, 0);
    assert_true(m->left * m->right < 0.0f);
    s = status();
    assert_true(fabsf(s.progress_m - 1.0f) < 1e-3f); /* 1 m of the 4 m tour */
    assert_true(fabsf(s.path_length_m - 4.0f) < 1e-5f);
    /* At the last waypoint: finished, wheels stopped, no more commands needed. */
    set_pose(3.0f, 3.0f, (PI_F / 2));
    for (uint64_t k = 3; k < 8; k++)
        assert_int_equal(tick(k, 0), 0);
    s = status();
    if (!s.finished) { /* reaching the second waypoint first, then the third */
        set_pose(3.0f, 1.0f, (PI_F / 2));
        assert_int_equal(tick(8, 0), 0);
        set_pose(3.0f, 3.0f, (PI_F / 2));
        assert_int_equal(tick(9, 0), 0);
        s = status();
    }
    assert_int_equal(s.finished, 1);
    m = fake_board_motor(&fb, 0);
    assert_true(m->left == 0.0f && m->right == 0.0f);
    assert_true(fabsf(s.progress_m - 4.0f) < 1e-5f);
    assert_int_equal(rt.stats.tick_gaps, 0);
    assert_int_equal(rt.stats.clock_mismatch, 0);
}

static void test_scans_become_samples_once(void **st)
{
    (void)st;
    set_pose(2.0f, 2.0f, 0.0f); /* the centre of the 4 x 4 m box: every point stays inside */
    set_scan(100, 1.5f);
    assert_int_equal(tick(0, 1), 0);
    const uint32_t per_scan = RT_SAMPLES_DEFAULT_BEAMS * RT_SAMPLES_DEFAULT_POINTS;
    assert_int_equal(ring_count(link_->samples), per_scan);
    rt_status_t s = status();
    assert_int_equal(s.scans, 1);
    assert_int_equal(s.samples, per_scan);
    /* Every sample is inside the normalised box; the hits (one per beam) are labelled 1. */
    uint32_t hits = 0;
    for (uint32_t i = 0; i < per_scan; i++) {
        ai_sample_t a;
        assert_int_equal(ring_get(link_->samples, &a), 0);
        assert_true(a.x >= -1.0f && a.x <= 1.0f && a.y >= -1.0f && a.y <= 1.0f);
        hits += a.occ > 0.5f;
    }
    assert_int_equal(hits, RT_SAMPLES_DEFAULT_BEAMS);
    /* The same scan (same stamp) on the next scan tick gives nothing; a non-scan tick neither. */
    assert_int_equal(tick(1, 0), 0);
    assert_int_equal(tick(5, 1), 0);
    assert_int_equal(ring_count(link_->samples), 0);
    assert_int_equal(status().scans, 1);
    /* No scan yet (-EAGAIN) is not an error; a failing lidar is counted and the core goes on. */
    fb.lidar_rc = -EIO;
    assert_int_equal(tick(10, 1), 0);
    s = status();
    assert_int_equal(s.errors, 1);
    assert_int_equal(s.sample_errors, 0);
}

static void test_full_ring_drops_and_counts(void **st)
{
    (void)st;
    set_pose(2.0f, 2.0f, 0.0f);
    const uint32_t per_scan = RT_SAMPLES_DEFAULT_BEAMS * RT_SAMPLES_DEFAULT_POINTS;
    const uint32_t scans = FW_LINK_RING_CAPACITY / per_scan + 2; /* more than the ring holds */
    alloc_count_reset();
    for (uint32_t k = 0; k < scans; k++) {
        set_scan(1000 + k, 1.5f);
        assert_int_equal(tick(5 * k, 1), 0);
    }
    assert_int_equal(alloc_count_allocations(), 0); /* the RT core never allocates */
    rt_status_t s = status();
    assert_int_equal(s.scans, scans);
    assert_int_equal(s.samples, FW_LINK_RING_CAPACITY);
    assert_int_equal(s.ring_drops, scans * per_scan - FW_LINK_RING_CAPACITY);
    assert_int_equal(s.ring_drops, ring_drops(link_->samples));
    assert_int_equal(s.sample_errors, 0); /* a full ring is overload, not a broken contract */
}

static void test_failing_hal_calls_do_not_stop_it(void **st)
{
    (void)st;
    fb.pose_rc = -EIO;
    assert_int_equal(tick(0, 1), -EIO); /* reported to the runner, which keeps ticking */
    set_pose(1.0f, 1.0f, 0.0f);
    fb.motor_rc = -EIO;
    assert_int_equal(tick(1, 0), 0);
    rt_status_t s = status();
    assert_int_equal(s.errors, 2);
    fb.motor_rc = 0;
    assert_int_equal(tick(2, 0), 0);
    assert_non_null(fake_board_motor(&fb, 0));
    assert_int_equal(status().stamp_us, 2 * PERIOD_US);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_follows_the_scripted_pose, setup, teardown),
        cmocka_unit_test_setup_teardown(test_scans_become_samples_once, setup, teardown),
        cmocka_unit_test_setup_teardown(test_full_ring_drops_and_counts, setup, teardown),
        cmocka_unit_test_setup_teardown(test_failing_hal_calls_do_not_stop_it, setup, teardown),
    };
    return cmocka_run_group_tests_name("rt/core", tests, NULL, NULL);
}
