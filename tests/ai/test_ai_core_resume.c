/* The AI core started at a later round from a checkpoint (ai_core_cfg_t start_round,
 * resume_ckpt), one tick at a time on the fake board:
 *   - offline, the resumed core still waits for the whole tour, then publishes state(start)
 *     with the checkpoint's theta; status.round and the node's round counter start there;
 *   - a lone node resumed from round c's checkpoint ends with the same final checkpoint, byte
 *     for byte, as the core that ran every round (the counter keys lr, rho_k, minibatches and
 *     noise; the duals stay zero without neighbours; Adam is fresh every round);
 *   - bad configurations are refused: start_round >= rounds, bytes without a checkpoint, a
 *     torn or corrupt checkpoint (bnn_ckpt_load's code), and nothing is allocated. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "ai/ai_core.h"
#include "ai/bnn_ckpt.h"
#include "alloc_count.h"
#include "fake_board.h"
#include "fw_link.h"

#define ROUNDS 5u
#define SAMPLES 700u

static fake_board_t fb;
static ai_core_t ai;
static const fw_link_t *link_;
static rt_status_t rt;
static ai_ckpt_msg_t ckpt;
static uint64_t tick_no;

/* Checkpoints of the core that ran every round: after round 1 and the final one. */
static uint8_t ckpt_round1[AI_LINK_CKPT_BYTES], ckpt_final[AI_LINK_CKPT_BYTES];
static uint32_t ckpt_round1_len, ckpt_final_len;

static ai_core_cfg_t cfg_for(uint32_t start_round, const uint8_t *ck, uint32_t ck_len)
{
    ai_core_cfg_t c = ai_core_default_cfg();
    c.rounds = ROUNDS;
    c.offline = 1;
    c.dinno.primal_steps = 3;
    c.dinno.batch = 64;
    c.model_seed = 11;
    c.seed = 12;
    c.start_round = start_round;
    c.resume_ckpt = ck;
    c.resume_ckpt_bytes = ck_len;
    return c;
}

static void board(void)
{
    fake_board_init(&fb);
    fake_board_install(&fb);
    fw_link_reset();
    link_ = fw_link_get();
    memset(&rt, 0, sizeof rt);
    rt.path_length_m = 10.0f;
    tick_no = 0;
}

static int teardown(void **st)
{
    (void)st;
    assert_int_equal(hal_board_install(NULL), 0);
    return 0;
}

static void tick(void)
{
    fb.now_us = tick_no * 100000u;
    fw_tick_t t = {.now_us = fb.now_us, .index = tick_no, .sub = 1};
    tick_no++;
    assert_int_equal(ai_core_tick(&ai, &t), 0);
}

/* The same samples for every run (the world is deterministic), then the tour's end. */
static void drive_tour(void)
{
    for (uint32_t i = 0; i < SAMPLES; i++) {
        const float x = -0.9f + 1.8f * (float)(i % 97) / 97.0f, y = -0.9f + 1.8f * (float)(i % 89) / 89.0f;
        ai_sample_t s = {x, y, (i % 5 == 0) ? 1.0f : 0.0f};
        assert_int_equal(ring_put(link_->samples, &s), 0);
    }
    rt.progress_m = 5.0f;
    assert_int_equal(mbox_put(link_->rt_to_ai, &rt), 0);
    tick();
    /* Offline: no round before the tour is done, whatever round the core starts at. */
    assert_int_equal(ai.phase, AI_PHASE_COLLECT);
    assert_int_equal(mbox_fetch(link_->ai_state), 0);
    rt.progress_m = 10.0f;
    rt.finished = 1;
    assert_int_equal(mbox_put(link_->rt_to_ai, &rt), 0);
}

/* Plays the GP core for round k: the state goes out, ready(k) with no neighbours comes back. */
static void run_round(uint32_t k)
{
    tick();
    assert_int_equal(ai.phase, AI_PHASE_WAIT_SLOTS);
    assert_int_equal(mbox_fetch(link_->ai_state), 1);
    const ai_state_msg_t *st = mbox_read_buffer(link_->ai_state, NULL);
    assert_int_equal(st->round, k);
    gp_ready_t r;
    memset(&r, 0, sizeof r);
    r.round = k;
    assert_int_equal(mbox_put(link_->gp_ready, &r), 0);
    tick();
    assert_int_equal(mbox_get(link_->ai_ckpt, &ckpt, NULL), 1);
    assert_int_equal(ckpt.info.round, k);
    assert_true(ckpt.n_bytes > 0);
}

static void test_every_round(void **st)
{
    (void)st;
    board();
    ai_core_cfg_t c = cfg_for(0, NULL, 0);
    assert_int_equal(ai_core_init(&ai, &c, link_), 0);
    drive_tour();
    for (uint32_t k = 0; k < ROUNDS; k++) {
        run_round(k);
        if (k == 1) {
            memcpy(ckpt_round1, ckpt.bytes, ckpt.n_bytes);
            ckpt_round1_len = ckpt.n_bytes;
        }
    }
    assert_int_equal(ckpt.flags & AI_CKPT_FLAG_FINAL, AI_CKPT_FLAG_FINAL);
    memcpy(ckpt_final, ckpt.bytes, ckpt.n_bytes);
    ckpt_final_len = ckpt.n_bytes;
    assert_int_equal(ai.phase, AI_PHASE_DONE);
}

static void test_resumed_equals_every_round(void **st)
{
    (void)st;
    assert_true(ckpt_round1_len > 0 && ckpt_final_len > 0); /* test_every_round ran first */
    board();
    ai_core_cfg_t c = cfg_for(2, ckpt_round1, ckpt_round1_len);
    alloc_count_reset();
    assert_int_equal(ai_core_init(&ai, &c, link_), 0);
    assert_int_equal(ai.next_round, 2);
    assert_int_equal(ai.status.round, 2);
    assert_int_equal(ai.node.round, 2);
    assert_null(ai.cfg.resume_ckpt); /* the caller's buffer is not kept */
    /* theta is the checkpoint's: saving it again gives the same theta bytes (the checkpoint's
       epistemic posterior after them starts anew: the robot drives its tour again). */
    static uint8_t again[AI_LINK_CKPT_BYTES];
    size_t n = 0;
    assert_int_equal(bnn_ckpt_save(&ai.node.model, 0, again, sizeof again, &n), 0);
    assert_true(n < ckpt_round1_len);
    assert_memory_equal(again + BNN_CKPT_HEADER_BYTES, ckpt_round1 + BNN_CKPT_HEADER_BYTES, n - BNN_CKPT_HEADER_BYTES);
    drive_tour();
    tick();
    ai_status_t s;
    assert_int_equal(mbox_get(link_->ai_status, &s, NULL), 1);
    assert_int_equal(s.round, 2);
    /* state(2) carries the checkpoint's theta. */
    assert_int_equal(mbox_fetch(link_->ai_state), 1);
    const ai_state_msg_t *state = mbox_read_buffer(link_->ai_state, NULL);
    assert_int_equal(state->round, 2);
    assert_memory_equal(state->theta, bnn_params_const(&ai.node.model), sizeof(float) * state->n_params);
    gp_ready_t r;
    memset(&r, 0, sizeof r);
    r.round = 2;
    assert_int_equal(mbox_put(link_->gp_ready, &r), 0);
    tick();
    assert_int_equal(mbox_get(link_->ai_ckpt, &ckpt, NULL), 1);
    assert_int_equal(ckpt.info.round, 2);
    for (uint32_t k = 3; k < ROUNDS; k++)
        run_round(k);
    assert_int_equal(ckpt.flags & AI_CKPT_FLAG_FINAL, AI_CKPT_FLAG_FINAL);
    assert_int_equal(ai.phase, AI_PHASE_DONE);
    assert_int_equal(ckpt.n_bytes, ckpt_final_len);
    assert_memory_equal(ckpt.bytes, ckpt_final, ckpt_final_len);
    assert_int_equal(alloc_count_allocations(), 0);
}

static void test_refused(void **st)
{
    (void)st;
    board();
    ai_core_cfg_t c = cfg_for(ROUNDS, NULL, 0);
    assert_int_equal(ai_core_init(&ai, &c, link_), -EINVAL); /* nothing left to run */
    c = cfg_for(1, NULL, 100);
    assert_int_equal(ai_core_init(&ai, &c, link_), -EINVAL); /* bytes but no checkpoint */
    c = cfg_for(2, ckpt_round1, 40);
    assert_int_equal(ai_core_init(&ai, &c, link_), -ENODATA); /* torn */
    static uint8_t bad[AI_LINK_CKPT_BYTES];
    memcpy(bad, ckpt_round1, ckpt_round1_len);
    bad[ckpt_round1_len - 1] ^= 0x40u;
    c = cfg_for(2, bad, ckpt_round1_len);
    assert_int_equal(ai_core_init(&ai, &c, link_), -EILSEQ); /* corrupt: the CRC tells */
    /* A later start without a checkpoint is allowed: theta from model_seed. */
    c = cfg_for(4, NULL, 0);
    assert_int_equal(ai_core_init(&ai, &c, link_), 0);
    assert_int_equal(ai.next_round, 4);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_every_round, teardown),
        cmocka_unit_test_teardown(test_resumed_equals_every_round, teardown),
        cmocka_unit_test_teardown(test_refused, teardown),
    };
    return cmocka_run_group_tests_name("ai/core_resume", tests, NULL, NULL);
}
