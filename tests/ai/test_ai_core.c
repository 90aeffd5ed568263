/* The AI core, one tick at a time on the fake board with scripted RT status and samples: the
 * ring drains into the pool, a path-progress boundary publishes the state and waits for the
 * GP core's ready without blocking, the round then trains and publishes its checkpoint, DR
 * clears the pool where CDR keeps it, and the last round sets done; an exploring fleet shares
 * its posterior every other round. No allocation. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "ai/ai_core.h"
#include "alloc_count.h"
#include "fake_board.h"
#include "fw_link.h"

static fake_board_t fb;
static ai_core_t ai;
static const fw_link_t *link_;
static rt_status_t rt;
static ai_ckpt_msg_t ckpt;

/* The fake board installed and the links empty. */
static void board_up(void)
{
    fake_board_init(&fb);
    fake_board_install(&fb);
    fw_link_reset();
    link_ = fw_link_get();
}

static void start(ai_pool_policy_t policy)
{
    board_up();
    ai_core_cfg_t c = ai_core_default_cfg();
    c.rounds = 2;
    c.policy = policy;
    c.dinno.primal_steps = 2;
    c.dinno.batch = 64;
    assert_int_equal(ai_core_init(&ai, &c, link_), 0);
    memset(&rt, 0, sizeof rt);
    rt.path_length_m = 10.0f;
}

static int teardown(void **st)
{
    (void)st;
    assert_int_equal(hal_board_install(NULL), 0);
    return 0;
}

static void tick(uint64_t k)
{
    fb.now_us = k * 100000u;
    fw_tick_t t = {.now_us = fb.now_us, .index = k, .sub = 1};
    assert_int_equal(ai_core_tick(&ai, &t), 0);
}

/* The RT core's part: n samples into the ring and the status with this path progress. */
static void rt_publishes(uint32_t n, float progress)
{
    for (uint32_t i = 0; i < n; i++) {
        const float x = -0.9f + 1.8f * (float)(i % 97) / 97.0f, y = -0.9f + 1.8f * (float)(i % 89) / 89.0f;
        ai_sample_t s = {x, y, (i % 5 == 0) ? 1.0f : 0.0f};
        assert_int_equal(ring_put(link_->samples, &s), 0);
    }
    rt.progress_m = progress;
    rt.samples += n;
    assert_int_equal(mbox_put(link_->rt_to_ai, &rt), 0);
}

static void test_round_cycle(void **st)
{
    (void)st;
    start(AI_POOL_DR);
    rt_publishes(500, 1.0f);
    tick(0);
    assert_int_equal(ai.phase, AI_PHASE_COLLECT);
    assert_int_equal(ai.pool.fill, 500);
    assert_int_equal(ring_count(link_->samples), 0);
    /* Boundary 0 at half the path: the state of round 0 goes to the GP core. */
    rt_publishes(500, 5.0f);
    alloc_count_reset();
    tick(1);
    assert_int_equal(ai.phase, AI_PHASE_WAIT_SLOTS);
    assert_int_equal(mbox_fetch(link_->ai_state), 1);
    const ai_state_msg_t *state = mbox_read_buffer(link_->ai_state, NULL);
    assert_int_equal(state->round, 0);
    assert_int_equal(state->n_params, bnn_n_params(&ai.node.model));
    /* No ready yet: the core waits over its ticks, never blocking. */
    tick(2);
    tick(3);
    assert_int_equal(ai.phase, AI_PHASE_WAIT_SLOTS);
    assert_int_equal(mbox_get(link_->ai_ckpt, &ckpt, NULL), 0);
    /* ready(0) with no neighbours: a local round, then checkpoint 0, and DR clears the pool. */
    gp_ready_t r = {0, 0, 0};
    assert_int_equal(mbox_put(link_->gp_ready, &r), 0);
    tick(4);
    assert_int_equal(alloc_count_allocations(), 0);
    assert_int_equal(mbox_get(link_->ai_ckpt, &ckpt, NULL), 1);
    assert_int_equal(ckpt.info.round, 0);
    assert_int_equal(ckpt.info.pool_fill, 1000);
    assert_int_equal(ckpt.info.steps, 2);
    assert_true(isfinite(ckpt.info.loss_train));
    assert_int_equal(ckpt.flags & AI_CKPT_FLAG_FINAL, 0);
    assert_true(ckpt.n_bytes > 0);
    assert_int_equal(ai.pool.fill, 0); /* DR */
    assert_int_equal(ai.phase, AI_PHASE_COLLECT);
    /* The path finished: the last round runs and sets done. */
    rt_publishes(300, 10.0f);
    rt.finished = 1;
    assert_int_equal(mbox_put(link_->rt_to_ai, &rt), 0);
    tick(5);
    assert_int_equal(ai.phase, AI_PHASE_WAIT_SLOTS);
    r.round = 1;
    assert_int_equal(mbox_put(link_->gp_ready, &r), 0);
    tick(6);
    assert_int_equal(mbox_get(link_->ai_ckpt, &ckpt, NULL), 1);
    assert_int_equal(ckpt.info.round, 1);
    assert_int_equal(ckpt.flags & AI_CKPT_FLAG_FINAL, AI_CKPT_FLAG_FINAL);
    assert_int_equal(ai.phase, AI_PHASE_DONE);
    ai_status_t s;
    assert_int_equal(mbox_get(link_->ai_status, &s, NULL), 1);
    assert_int_equal(s.done, 1);
    assert_int_equal(s.round, 2);
}

static void test_cdr_keeps_the_pool(void **st)
{
    (void)st;
    start(AI_POOL_CDR);
    rt_publishes(800, 6.0f);
    tick(0);
    gp_ready_t r = {0, 0, 0};
    assert_int_equal(mbox_put(link_->gp_ready, &r), 0);
    tick(1);
    assert_int_equal(mbox_get(link_->ai_ckpt, &ckpt, NULL), 1);
    assert_int_equal(ckpt.info.round, 0);
    assert_int_equal(ai.pool.fill, 800); /* CDR keeps what it learnt from */
}

/* pool_samples: a host robot given a board's smaller pool keeps what that board keeps (the
 * reservoir over the first pool_samples slots); above the build's capacity it is refused. */
static void test_pool_samples_caps_the_pool(void **st)
{
    (void)st;
    board_up();
    ai_core_cfg_t c = ai_core_default_cfg();
    c.rounds = 2;
    c.policy = AI_POOL_CDR;
    c.pool_samples = (uint32_t)AI_POOL_CAPACITY + 1u;
    assert_int_equal(ai_core_init(&ai, &c, link_), -EINVAL);
    c.pool_samples = 300;
    assert_int_equal(ai_core_init(&ai, &c, link_), 0);
    memset(&rt, 0, sizeof rt);
    rt.path_length_m = 10.0f;
    rt_publishes(800, 1.0f);
    tick(0);
    assert_int_equal(ai.pool.capacity, 300);
    assert_int_equal(ai.pool.fill, 300);
    assert_int_equal(ai.pool.offered, 800);
    ai_status_t s;
    assert_int_equal(mbox_get(link_->ai_status, &s, NULL), 1);
    assert_int_equal(s.pool_capacity, 300);
}

/* A robot behind its fleet: ready(0) says the fleet is at round 5, so the AI core runs round 5
 * next (state, node schedule and checkpoint of round 5), not rounds 1 .. 4; a skip past the
 * last round is ignored. */
static void test_skip_ahead(void **st)
{
    (void)st;
    board_up();
    ai_core_cfg_t c = ai_core_default_cfg();
    c.rounds = 8;
    c.offline = 1;
    c.dinno.primal_steps = 2;
    c.dinno.batch = 64;
    assert_int_equal(ai_core_init(&ai, &c, link_), 0);
    memset(&rt, 0, sizeof rt);
    rt.path_length_m = 10.0f;
    rt.finished = 1;
    rt_publishes(500, 10.0f);
    tick(0);
    gp_ready_t r = {0, 0, 5};
    assert_int_equal(mbox_put(link_->gp_ready, &r), 0);
    tick(1);
    assert_int_equal(mbox_get(link_->ai_ckpt, &ckpt, NULL), 1);
    assert_int_equal(ckpt.info.round, 0);
    assert_int_equal(ai.next_round, 5);
    assert_int_equal(ai.node.round, 5);
    tick(2);
    assert_int_equal(mbox_fetch(link_->ai_state), 1);
    assert_int_equal(((const ai_state_msg_t *)mbox_read_buffer(link_->ai_state, NULL))->round, 5);
    r = (gp_ready_t){5, 0, 99};
    assert_int_equal(mbox_put(link_->gp_ready, &r), 0);
    tick(3);
    assert_int_equal(mbox_get(link_->ai_ckpt, &ckpt, NULL), 1);
    assert_int_equal(ckpt.info.round, 5);
    assert_true(isfinite(ckpt.info.loss_train));
    assert_int_equal(ai.next_round, 6);
}

/* Exploring in a fleet of N = 2 with the shared posterior (ai_core.h): round 0 exchanges theta,
 * round 1 the posterior, made the fleet's estimate (N times its own) on the way out; the points
 * after it go in N times; a posterior round trains nothing. Sharing needs exploring. */
/* Samples counted in the belief grid's cells (every test sample falls inside it). */
static double seen_total(void)
{
    double t = 0;
    for (uint32_t i = 0; i < ai.seen.cfg.w * ai.seen.cfg.h; i++)
        t += ai.seen.n[i];
    return t;
}

static void test_explore_shares_the_posterior(void **st)
{
    (void)st;
    board_up();
    static const ai_belief_cfg_t belief = {.w = 8, .h = 8, .res_m = 0.5f, .max_x = 4.0f, .max_y = 4.0f};
    ai_core_cfg_t c = ai_core_default_cfg();
    c.rounds = 4;
    c.dinno.primal_steps = 2;
    c.dinno.batch = 64;
    c.fleet_size = 2;
    c.explore_share_post = 1;
    assert_int_equal(ai_core_init(&ai, &c, link_), -EINVAL); /* not exploring */
    c.explore_share_post = 0;
    c.explore_counts = 1;
    assert_int_equal(ai_core_init(&ai, &c, link_), -EINVAL); /* counts, not exploring */
    c.explore_share_post = 1;
    c.explore_budget_us = 4000000u;
    c.belief = &belief;
    c.belief_period_us = 1000000u;
    c.fleet_size = 0;
    assert_int_equal(ai_core_init(&ai, &c, link_), -EINVAL); /* no fleet size */
    c.fleet_size = 2;
    c.explore_counts = 2;
    assert_int_equal(ai_core_init(&ai, &c, link_), -EINVAL);
    c.explore_counts = 1;
    assert_int_equal(ai_core_init(&ai, &c, link_), 0);
    memset(&rt, 0, sizeof rt);
    const uint32_t P = (uint32_t)bnn_n_params(&ai.node.model);
    for (uint32_t k = 0; k < 2; k++) {
        rt.stamp_us = (k + 1u) * 1000000u; /* boundary k */
        rt_publishes(300, 0.0f);
        tick(10u * k + 1u);
        assert_int_equal(ai.phase, AI_PHASE_WAIT_SLOTS);
        assert_int_equal(mbox_fetch(link_->ai_state), 1);
        const ai_state_msg_t *state = mbox_read_buffer(link_->ai_state, NULL);
        assert_int_equal(state->round, k);
        assert_int_equal(state->n_params, P);
        if (k == 1) { /* the posterior's state form: its dimension first, then the fleet's estimate */
            assert_true(state->theta[0] == (float)ai.post.dim);
            assert_true(ai.post_fleet);
            assert_true(fabs(ai.post.robots - 2.0) < 1e-12 && fabs(ai.post.n_obs - 2.0 * 600) < 1e-9);
            /* then the count grid (ai_seen.h): its size, and N times the robot's own counts */
            const size_t off = BNN_POST_STATE_FLOATS(ai.post.dim);
            assert_true(ai.seen_shared);
            assert_true(state->theta[off] == 8.0f && state->theta[off + 1] == 8.0f);
            assert_memory_equal(state->theta + off + 2, ai.seen.n, 64 * sizeof(float));
            assert_true(fabs(seen_total() - 2.0 * 600) < 1e-3);
        }
        gp_ready_t r = {k, 0, 0};
        assert_int_equal(mbox_put(link_->gp_ready, &r), 0);
        tick(10u * k + 2u);
        assert_int_equal(mbox_get(link_->ai_ckpt, &ckpt, NULL), 1);
        assert_int_equal(ckpt.info.round, k);
        assert_int_equal(ckpt.info.steps, k == 0 ? 2 : 0); /* a posterior round trains nothing */
        assert_true(k == 0 ? isfinite(ckpt.info.loss_train) : isnan(ckpt.info.loss_train));
        assert_int_equal(ckpt.info.pool_fill, 300u * (k + 1u));
    }
    rt_publishes(300, 0.0f); /* after the first shared round: N times each new point */
    alloc_count_reset();
    tick(30);
    rt.stamp_us = 3000000u;
    rt_publishes(0, 0.0f);
    tick(31);
    assert_int_equal(alloc_count_allocations(), 0);
    assert_int_equal(ai.post_staged, 0); /* summed in for the belief of that tick */
    assert_true(fabs(ai.post.n_obs - 2.0 * 900) < 1e-9);
    assert_true(fabs(seen_total() - 2.0 * 900) < 1e-3); /* the counts the same */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_round_cycle, teardown),
        cmocka_unit_test_teardown(test_cdr_keeps_the_pool, teardown),
        cmocka_unit_test_teardown(test_pool_samples_caps_the_pool, teardown),
        cmocka_unit_test_teardown(test_skip_ahead, teardown),
        cmocka_unit_test_teardown(test_explore_shares_the_posterior, teardown),
    };
    return cmocka_run_group_tests_name("ai/core", tests, NULL, NULL);
}
