/* The GP core's exploration step (firmware/gp/gp_explore.h) through the image's real mailboxes
 * (fw_link): no goal before the RT core's first seen grid; a goal where the unknown share is;
 * a reached or given-up goal is spent and the next one follows; nothing left: DONE; the
 * uncertainty policy reads the AI core's belief, and its counts' layer when the posterior's has
 * nothing left; the frontier policy the robot's own scans and ignores claims; a grid of another
 * geometry is refused. Grid: 16 x 8 cells of 1 m, all free and observed but two unknown 3 x 3
 * patches, P around (3, 4) and Q around (12, 4); the robot at (1.5, 4.5). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "fw_link.h"
#include "gp/gp_explore.h"

#define S 1000000ull
#define W 16u
#define H 8u

static gp_explore_t ex;
static rt_seen_t seen;
static ai_belief_msg_t belief;

static void patch(uint8_t *unknown, uint32_t cx, uint32_t cy, uint8_t v)
{
    for (uint32_t y = cy - 1u; y <= cy + 1u; y++)
        for (uint32_t x = cx - 1u; x <= cx + 1u; x++)
            unknown[y * W + x] = v;
}

static gp_explore_cfg_t config(gp_explore_policy_t policy)
{
    gp_explore_cfg_t c;
    memset(&c, 0, sizeof c);
    c.goal.self = 0;
    c.goal.n_peers = 2;
    c.goal.w = W;
    c.goal.h = H;
    c.goal.res_m = 1.0;
    c.goal.occ_max = 128;
    c.goal.sensor_radius_m = 1.0;
    c.goal.lambda = 0.1;
    c.goal.min_info_m2 = 0.5;
    c.goal.claim_radius_m = 2.0;
    c.goal.claim_discount = 0.0;
    c.goal.claim_period_us = 1 * S;
    c.goal.claim_lifetime_us = 5 * S;
    c.goal.claim_max_lifetime_us = 30 * S;
    c.policy = policy;
    c.reselect_us = 5 * S;
    return c;
}

static void setup_grids(void)
{
    fw_link_reset();
    memset(&seen, 0, sizeof seen);
    seen.w = W;
    seen.h = H;
    patch(seen.unknown, 3, 4, 255);
    patch(seen.unknown, 12, 4, 255);
    memset(&belief, 0, sizeof belief);
    belief.w = W;
    belief.h = H;
}

static rt_status_t pose(void)
{
    rt_status_t st;
    memset(&st, 0, sizeof st);
    st.x_m = 1.5f;
    st.y_m = 4.5f;
    return st;
}

/* The goal message the RT core would read: 1 with *m, 0 none new. */
static int take_goal(gp_goal_msg_t *m)
{
    int r = mbox_get(fw_link_get()->gp_goal, m, NULL);
    assert_true(r >= 0);
    return r;
}

static void test_goal_then_next_then_done(void **state)
{
    (void)state;
    setup_grids();
    const gp_explore_cfg_t cfg = config(GP_EXPLORE_FRONTIER);
    assert_int_equal(gp_explore_init(&ex, &cfg), 0);
    const fw_link_t *link = fw_link_get();
    rt_status_t st = pose();
    gp_goal_msg_t m;
    assert_int_equal(gp_explore_tick(&ex, link, &st, 0), 0);
    assert_int_equal(take_goal(&m), 0); /* no seen grid yet: no goal */

    assert_int_equal(mbox_put(link->rt_seen, &seen), 0);
    assert_int_equal(gp_explore_tick(&ex, link, &st, 1 * S), 0);
    assert_int_equal(take_goal(&m), 1);
    assert_int_equal(m.mode, GP_GOAL_MSG_GO);
    assert_int_equal(m.seq, 1);
    assert_true(fabsf(m.x_m - 3.5f) < 1e-6f && fabsf(m.y_m - 4.5f) < 1e-6f); /* the nearer patch, P */

    /* The same grid a tick later: the goal stands, nothing new goes out. */
    assert_int_equal(gp_explore_tick(&ex, link, &st, 1 * S + 100000u), 0);
    assert_int_equal(take_goal(&m), 0);

    /* Reached (the seen grid has not caught up yet): P is spent, Q is next. */
    st.goal_seq = 1;
    st.goal_reached = 1;
    assert_int_equal(gp_explore_tick(&ex, link, &st, 2 * S), 0);
    assert_int_equal(take_goal(&m), 1);
    assert_int_equal(m.seq, 2);
    assert_true(fabsf(m.x_m - 12.5f) < 1e-6f);
    assert_int_equal(ex.stats.reached, 1);

    /* Q given up (unreachable): nothing left to learn within reach. */
    st.goal_seq = 2;
    st.goal_failed = 2;
    assert_int_equal(gp_explore_tick(&ex, link, &st, 3 * S), 0);
    assert_int_equal(take_goal(&m), 1);
    assert_int_equal(m.mode, GP_GOAL_MSG_DONE);
    assert_int_equal(ex.stats.failed, 1);
    assert_int_equal(ex.stats.done, 1);
    assert_int_equal(gp_explore_tick(&ex, link, &st, 20 * S), 0);
    assert_int_equal(take_goal(&m), 0); /* done stays done */
}

/* A fresh explorer of `policy` given the seen grid and the belief as they are (after
 * setup_grids and the caller's patches) and ticked once, at 1 s: the goal it sends. */
static gp_goal_msg_t first_goal(gp_explore_policy_t policy)
{
    const gp_explore_cfg_t cfg = config(policy);
    assert_int_equal(gp_explore_init(&ex, &cfg), 0);
    const fw_link_t *link = fw_link_get();
    rt_status_t st = pose();
    gp_goal_msg_t m;
    assert_int_equal(mbox_put(link->rt_seen, &seen), 0);
    assert_int_equal(mbox_put(link->ai_belief, &belief), 0);
    assert_int_equal(gp_explore_tick(&ex, link, &st, 1 * S), 0);
    assert_int_equal(take_goal(&m), 1);
    return m;
}

static void test_uncertainty_reads_the_belief(void **state)
{
    (void)state;
    /* The model knows P (a peer mapped it) but not Q. */
    setup_grids();
    patch(belief.unknown, 12, 4, 255);
    gp_goal_msg_t m = first_goal(GP_EXPLORE_UNCERTAINTY);
    assert_true(fabsf(m.x_m - 12.5f) < 1e-6f);
    assert_int_equal(ex.stats.belief_updates, 1);

    /* The frontier policy, same inputs: its own scans say P. */
    setup_grids();
    patch(belief.unknown, 12, 4, 255);
    m = first_goal(GP_EXPLORE_FRONTIER);
    assert_true(fabsf(m.x_m - 3.5f) < 1e-6f);
}

/* The posterior has nothing left (its features are global: a room glimpsed through a door
 * counts as known), the counts say Q was never reached: the robot goes to Q instead of calling
 * itself done; with nothing left on either layer it is done. */
static void test_uncertainty_falls_back_to_the_counts(void **state)
{
    (void)state;
    setup_grids();
    patch(belief.fallback, 12, 4, 255); /* belief.unknown: 0 everywhere */
    gp_goal_msg_t m = first_goal(GP_EXPLORE_UNCERTAINTY);
    const fw_link_t *link = fw_link_get();
    rt_status_t st = pose();
    assert_int_equal(m.mode, GP_GOAL_MSG_GO);
    assert_true(fabsf(m.x_m - 12.5f) < 1e-6f);
    assert_int_equal(ex.stats.fallbacks, 1);
    assert_int_equal(ex.stats.done, 0);

    /* The posterior sees P again: it comes first, the fallback is not used. */
    patch(belief.unknown, 3, 4, 255);
    assert_int_equal(mbox_put(link->ai_belief, &belief), 0);
    assert_int_equal(gp_explore_tick(&ex, link, &st, 7 * S), 0);
    assert_int_equal(take_goal(&m), 1);
    assert_true(fabsf(m.x_m - 3.5f) < 1e-6f);
    assert_int_equal(ex.stats.fallbacks, 1);

    /* Nothing left on either layer: done. */
    memset(belief.unknown, 0, sizeof belief.unknown);
    memset(belief.fallback, 0, sizeof belief.fallback);
    assert_int_equal(mbox_put(link->ai_belief, &belief), 0);
    assert_int_equal(gp_explore_tick(&ex, link, &st, 13 * S), 0);
    assert_int_equal(take_goal(&m), 1);
    assert_int_equal(m.mode, GP_GOAL_MSG_DONE);
    assert_int_equal(ex.stats.done, 1);

    /* The frontier policy never reads the belief, so it has no fallback either. */
    setup_grids();
    patch(belief.fallback, 12, 4, 255);
    m = first_goal(GP_EXPLORE_FRONTIER);
    assert_true(fabsf(m.x_m - 3.5f) < 1e-6f);
    assert_int_equal(ex.stats.fallbacks, 0);
}

/* The belief is bounded by the robot's own scans: P, which our lidar observed, is not unknown
 * however the belief puts it (its 1 m counts, the posterior's global features), on either
 * layer; Q, which neither saw, is the goal. */
static void test_belief_bounded_by_own_scans(void **state)
{
    (void)state;
    gp_goal_msg_t m;
    for (int fallback = 0; fallback <= 1; fallback++) {
        setup_grids();
        uint8_t *layer = fallback ? belief.fallback : belief.unknown;
        patch(seen.unknown, 3, 4, 0);
        patch(layer, 3, 4, 255);
        patch(layer, 12, 4, 255);
        m = first_goal(GP_EXPLORE_UNCERTAINTY);
        assert_true(fabsf(m.x_m - 12.5f) < 1e-6f);
        assert_int_equal(ex.stats.fallbacks, (uint64_t)fallback);
    }

    /* Our scans say Q is unknown, the belief that a peer saw it: it is the belief's. */
    setup_grids();
    patch(seen.unknown, 3, 4, 0);
    patch(belief.unknown, 12, 4, 255);
    memcpy(belief.fallback, belief.unknown, sizeof belief.fallback);
    patch(belief.unknown, 12, 4, 0);
    patch(belief.fallback, 12, 4, 0);
    const gp_explore_cfg_t cfg = config(GP_EXPLORE_UNCERTAINTY);
    assert_int_equal(gp_explore_init(&ex, &cfg), 0);
    const fw_link_t *link = fw_link_get();
    rt_status_t st = pose();
    assert_int_equal(mbox_put(link->rt_seen, &seen), 0);
    assert_int_equal(mbox_put(link->ai_belief, &belief), 0);
    assert_int_equal(gp_explore_tick(&ex, link, &st, 1 * S), 0);
    assert_int_equal(take_goal(&m), 1);
    assert_int_equal(m.mode, GP_GOAL_MSG_DONE);
}

static void test_claims_by_policy(void **state)
{
    (void)state;
    /* Robot 1 at P's centre claims P (cost 0: nearer than us). */
    const gp_goal_claim_t c = {1, 1, 3.5, 4.5, 0.0, 4 * S};
    const fw_link_t *link = fw_link_get();
    rt_status_t st = pose();
    gp_goal_msg_t m;

    setup_grids();
    gp_explore_cfg_t cfg = config(GP_EXPLORE_FRONTIER);
    assert_int_equal(gp_explore_init(&ex, &cfg), 0);
    assert_int_equal(gp_explore_on_claim(&ex, &c, 1 * S), 0);
    assert_int_equal(ex.goal.stats.claims_taken, 0); /* each robot on its own */

    setup_grids();
    cfg = config(GP_EXPLORE_COORDINATED);
    assert_int_equal(gp_explore_init(&ex, &cfg), 0);
    assert_int_equal(gp_explore_on_claim(&ex, &c, 1 * S), 0);
    assert_int_equal(mbox_put(link->rt_seen, &seen), 0);
    assert_int_equal(gp_explore_tick(&ex, link, &st, 1 * S), 0);
    assert_int_equal(take_goal(&m), 1);
    assert_true(fabsf(m.x_m - 12.5f) < 1e-6f); /* P is the peer's: Q */

    /* A forged claim (expiry beyond the accepted lifetime) changes nothing. */
    const gp_goal_claim_t forged = {1, 2, 12.5, 4.5, 0.0, 100 * S};
    assert_int_equal(gp_explore_on_claim(&ex, &forged, 1 * S), -EBADMSG);
}

/* A claim taken that holds against our goal makes the robot choose again at once, before the
 * reselect period; a claim that does not, changes nothing. And with only claimed goals left
 * the robot waits (no DONE). */
static void test_contested_goal_chosen_again(void **state)
{
    (void)state;
    const fw_link_t *link = fw_link_get();
    rt_status_t st = pose();
    gp_goal_msg_t m;
    setup_grids();
    gp_explore_cfg_t cfg = config(GP_EXPLORE_COORDINATED);
    cfg.goal.n_peers = 3;
    cfg.goal.claim_radius_m = 3.5; /* beyond every cell whose window reaches the claimed patch */
    assert_int_equal(gp_explore_init(&ex, &cfg), 0);
    assert_int_equal(mbox_put(link->rt_seen, &seen), 0);
    assert_int_equal(gp_explore_tick(&ex, link, &st, 1 * S), 0);
    assert_int_equal(take_goal(&m), 1);
    assert_true(fabsf(m.x_m - 3.5f) < 1e-6f); /* P, the nearer */
    const gp_goal_claim_t q = {1, 1, 12.5, 4.5, 0.0, 5 * S}; /* robot 1 at Q: not our goal */
    assert_int_equal(gp_explore_on_claim(&ex, &q, 1 * S + 1u), 0);
    assert_int_equal(gp_explore_tick(&ex, link, &st, 1 * S + 100000u), 0);
    assert_int_equal(take_goal(&m), 0);
    assert_int_equal(ex.stats.selections, 1);
    const gp_goal_claim_t p = {2, 1, 3.5, 4.5, 0.0, 5 * S}; /* robot 2 at P: ours is contested */
    assert_int_equal(gp_explore_on_claim(&ex, &p, 1 * S + 200000u), 0);
    assert_int_equal(gp_explore_tick(&ex, link, &st, 1 * S + 300000u), 0); /* well within 5 s */
    assert_int_equal(ex.stats.selections, 2);
    assert_int_equal(take_goal(&m), 0); /* P and Q both claimed: wait, not done */
    assert_int_equal(ex.stats.done, 0);
}

static void test_bad_inputs(void **state)
{
    (void)state;
    setup_grids();
    gp_explore_cfg_t cfg = config(GP_EXPLORE_UNCERTAINTY);
    assert_int_equal(gp_explore_init(&ex, &cfg), 0);
    const fw_link_t *link = fw_link_get();
    rt_status_t st = pose();
    seen.w = W - 1u; /* another geometry than the goal grid's */
    assert_int_equal(mbox_put(link->rt_seen, &seen), 0);
    assert_int_equal(gp_explore_tick(&ex, link, &st, 1 * S), -EINVAL);
    assert_int_equal(ex.stats.bad_inputs, 1);
    gp_goal_msg_t m;
    assert_int_equal(take_goal(&m), 0);

    cfg.reselect_us = 0;
    assert_int_equal(gp_explore_init(&ex, &cfg), -EINVAL);
    cfg = config((gp_explore_policy_t)7);
    assert_int_equal(gp_explore_init(&ex, &cfg), -EINVAL);
    gp_explore_policy_t p;
    assert_int_equal(gp_explore_policy_parse("coordinated", &p), 0);
    assert_int_equal(p, GP_EXPLORE_COORDINATED);
    assert_int_equal(gp_explore_policy_parse("random", &p), -EINVAL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_goal_then_next_then_done),
        cmocka_unit_test(test_uncertainty_reads_the_belief),
        cmocka_unit_test(test_uncertainty_falls_back_to_the_counts),
        cmocka_unit_test(test_belief_bounded_by_own_scans),
        cmocka_unit_test(test_claims_by_policy),
        cmocka_unit_test(test_contested_goal_chosen_again),
        cmocka_unit_test(test_bad_inputs),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
