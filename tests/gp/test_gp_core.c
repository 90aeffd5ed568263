/* The GP core, one tick at a time on the fake board: telemetry every N ticks on the robot's
 * channel (no network is counted, not an error), the round hand-over with the AI core through
 * the links and the exchange hook (-EAGAIN waits for the next tick, an error makes a local
 * round), checkpoints through the storage HAL with a failing write reported, and the round
 * log and done flag the host reads. */
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
#include "fw_link.h"
#include "gp/gp_core.h"
#include "gp/gp_telemetry.h"

static fake_board_t fb;
static gp_core_t gp;
static const fw_link_t *link_;
static ai_state_msg_t state_msg;
static ai_ckpt_msg_t ckpt_msg;

/* The exchange hook: scripted answers, and what it was called with. */
static struct {
    int answers[4];
    int n_answers, calls;
    uint32_t round;
    float theta0;
} hook;

static const float peer_state[4] = {1.0f, 2.0f, 3.0f, 4.0f}; /* where the "peers' states" stay */

static int exchange(void *ctx, const gp_exchange_req_t *req, dinno_nbrs_t *nbrs)
{
    (void)ctx;
    assert_true(req->n_params > 0);
    const uint32_t round = req->round;
    hook.round = round;
    hook.theta0 = req->theta[0];
    int a = hook.answers[hook.calls < hook.n_answers ? hook.calls : hook.n_answers - 1];
    hook.calls++;
    for (int s = 0; s < a; s++) {
        nbrs->id[s] = (uint32_t)s;
        nbrs->theta[s] = &peer_state[s];
    }
    nbrs->round = round;
    nbrs->count = a > 0 ? (uint32_t)a : 0u;
    return a;
}

static void start_keep(int with_hook, int telemetry_every, uint32_t keep)
{
    fake_board_init(&fb);
    fake_board_install(&fb);
    fw_link_reset();
    link_ = fw_link_get();
    gp_core_cfg_t c = gp_core_default_cfg();
    c.robot_id = 3;
    c.telemetry_every = (uint32_t)telemetry_every;
    static const gp_peers_ops_t peers = {.exchange = exchange};
    c.peers = with_hook ? &peers : NULL;
    if (keep > 0) {
        c.ckpt_keep = keep;
        c.ckpt_keep_every = 0;
    }
    assert_int_equal(gp_core_init(&gp, &c, link_), 0);
    memset(&hook, 0, sizeof hook);
}

static void start(int with_hook, int telemetry_every) { start_keep(with_hook, telemetry_every, 0); }

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
    assert_int_equal(gp_core_tick(&gp, &t), 0);
}

static void test_telemetry_every_n_ticks(void **st)
{
    (void)st;
    start(0, 5);
    for (uint64_t k = 0; k < 10; k++)
        tick(k);
    assert_int_equal(fb.n_pub, 2);
    const fake_publish_t *p = fake_board_publish(&fb, 0);
    assert_string_equal(p->channel, "fleetsim/telemetry/3");
    assert_int_equal(p->len, GP_TELEMETRY_WIRE_BYTES);
    gp_telemetry_t t;
    assert_int_equal(gp_telemetry_decode(p->data, p->len, &t), 0);
    assert_int_equal(t.robot_id, 3);
    assert_int_equal(t.stamp_us, 500000u);
    assert_int_equal(gp.stats.telemetry_sent, 2);
    /* Without a network the record is counted as not sent; the core goes on. */
    start(0, 1);
    fb.board.net = NULL;
    fake_board_install(&fb);
    tick(0);
    tick(1);
    assert_int_equal(gp.stats.telemetry_failed, 2);
}

static void publish_state(uint32_t round)
{
    state_msg.round = round;
    state_msg.n_params = 8;
    state_msg.theta[0] = 0.25f + (float)round;
    assert_int_equal(mbox_put(link_->ai_state, &state_msg), 0);
}

static void test_round_hand_over_and_exchange(void **st)
{
    (void)st;
    start(1, 1000);
    hook.answers[0] = -EAGAIN; /* the peers' states are not all there yet */
    hook.answers[1] = 2;
    hook.n_answers = 2;
    gp_ready_t r;
    tick(0);
    assert_int_equal(mbox_get(link_->gp_ready, &r, NULL), 0); /* nothing published yet */
    publish_state(0);
    tick(1);
    assert_int_equal(hook.calls, 1);
    assert_int_equal(mbox_get(link_->gp_ready, &r, NULL), 0); /* -EAGAIN: wait */
    tick(2);
    assert_int_equal(hook.calls, 2);
    assert_int_equal(hook.round, 0);
    assert_true(hook.theta0 == 0.25f);
    assert_int_equal(mbox_get(link_->gp_ready, &r, NULL), 1);
    assert_int_equal(r.round, 0);
    assert_int_equal(r.neighbours, 2);
    assert_int_equal(link_->nbrs->count, 2);
    assert_int_equal(link_->nbrs->round, 0);
    assert_ptr_equal(link_->nbrs->theta[1], &peer_state[1]);
    assert_int_equal(gp.stats.rounds_coordinated, 1);
    /* A failing exchange makes a local round: counted, logged, an empty neighbour view. */
    hook.answers[0] = -EIO;
    hook.n_answers = 1;
    hook.calls = 0;
    publish_state(1);
    alloc_count_reset();
    tick(3);
    assert_int_equal(alloc_count_allocations(), 0);
    assert_int_equal(mbox_get(link_->gp_ready, &r, NULL), 1);
    assert_int_equal(r.round, 1);
    assert_int_equal(r.neighbours, 0);
    assert_int_equal(link_->nbrs->count, 0);
    assert_int_equal(gp.stats.exchange_errors, 1);
    assert_true(fake_board_logged(&fb, "state exchange failed"));
}

static void publish_ckpt(uint32_t round, int final)
{
    memset(&ckpt_msg.info, 0, sizeof ckpt_msg.info);
    ckpt_msg.info.round = round;
    ckpt_msg.flags = final ? AI_CKPT_FLAG_FINAL : 0u;
    ckpt_msg.n_bytes = 100;
    for (uint32_t i = 0; i < ckpt_msg.n_bytes; i++)
        ckpt_msg.bytes[i] = (uint8_t)(i + round);
    assert_int_equal(mbox_put(link_->ai_ckpt, &ckpt_msg), 0);
}

static void test_checkpoints_and_round_log(void **st)
{
    (void)st;
    start(0, 1000);
    publish_ckpt(0, 0);
    tick(0);
    const fake_file_t *f = fake_board_file(&fb, "round_0000.bnn");
    assert_non_null(f);
    assert_int_equal(f->len, 100);
    assert_int_equal(f->data[7], 7);
    assert_int_equal(gp_core_rounds_logged(&gp), 1);
    assert_int_equal(gp_core_round(&gp, 0)->round, 0);
    assert_null(gp_core_round(&gp, 1));
    assert_false(gp_core_done(&gp));
    /* The last round: its checkpoint and final.bnn; a full disk fails the first write. */
    fb.storage_fail_count = 1;
    fb.storage_fail_rc = -ENOSPC;
    publish_ckpt(1, 1);
    tick(1);
    assert_null(fake_board_file(&fb, "round_0001.bnn"));
    assert_null(fake_board_file(&fb, "final.bnn"));
    assert_int_equal(gp.stats.ckpt_failed, 1);
    assert_int_equal(gp.stats.ckpt_written, 1);
    assert_true(gp_core_done(&gp));
    assert_int_equal(gp.final_ckpt_status, -ENOSPC);
    assert_true(fake_board_logged(&fb, "FAILED"));
    assert_int_equal(gp_core_rounds_logged(&gp), 2);
    /* The round log says which checkpoints this run wrote, so the host never reads a file
       of that name left by an earlier run as this run's. */
    assert_int_equal(gp_core_round(&gp, 0)->ckpt_status, 0);
    assert_int_equal(gp_core_round(&gp, 1)->ckpt_status, -ENOSPC);
}

/* Only the newest ckpt_keep checkpoints stay; but a robot that skips rounds writes the next
   one at once, before the host read the one of the round it skipped from (its validation), so
   the checkpoints before a skip stay. */
static void test_checkpoints_kept_across_a_skip(void **st)
{
    (void)st;
    start_keep(0, 1000, 2);
    const uint32_t rounds[] = {0, 1, 2, 3, 5, 6, 7, 8};
    for (uint32_t i = 0; i < sizeof rounds / sizeof rounds[0]; i++) {
        publish_ckpt(rounds[i], 0);
        tick(i);
    }
    /* 0 and 1 went when 2 and 3 were written; 3 stays although 5 is two rounds after it (it
       came just before the skip to 5), and so does 2; 5 and 6 went when 7 and 8 were written. */
    assert_null(fake_board_file(&fb, "round_0000.bnn"));
    assert_null(fake_board_file(&fb, "round_0001.bnn"));
    assert_non_null(fake_board_file(&fb, "round_0002.bnn"));
    assert_non_null(fake_board_file(&fb, "round_0003.bnn"));
    assert_null(fake_board_file(&fb, "round_0005.bnn"));
    assert_null(fake_board_file(&fb, "round_0006.bnn"));
    assert_non_null(fake_board_file(&fb, "round_0007.bnn"));
    assert_non_null(fake_board_file(&fb, "round_0008.bnn"));
    assert_int_equal(gp.stats.ckpt_removed, 4);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_telemetry_every_n_ticks, teardown),
        cmocka_unit_test_teardown(test_round_hand_over_and_exchange, teardown),
        cmocka_unit_test_teardown(test_checkpoints_and_round_log, teardown),
        cmocka_unit_test_teardown(test_checkpoints_kept_across_a_skip, teardown),
    };
    return cmocka_run_group_tests_name("gp/core", tests, NULL, NULL);
}
