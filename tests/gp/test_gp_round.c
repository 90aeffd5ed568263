/* The round driver (firmware/gp/gp_round.h) step by step: two drivers joined by a lossless
 * in-memory network, their events in the order the GP core relies on (BEGIN only once the
 * round before is over for both, READY once the peer's state is there, DONE after leaving),
 * skip-ahead capped at the last round, and every call out of order refused without changing
 * anything. The seeded simulation (test_pse_sim) runs the same driver under faults. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <string.h>
#include <cmocka.h>

#include "gp/gp_round.h"

#define STATE_BYTES 3000u
#define CHUNK 1024u
#define RESEND 10000u
#define TIMEOUT 500000u
#define ROUNDS 3u

static gp_round_t drv[2];
static uint8_t mine[2][STATE_BYTES];
static int ids[2] = {0, 1};

/* Lossless: every message is delivered to the other driver at once (unless its sender is
   muted: all it sends is lost). */
static uint64_t now;
static int muted[2];
static int net_send(void *ctx, gp_pse_kind_t kind, const void *m)
{
    if (muted[*(const int *)ctx])
        return 0;
    gp_pse_t *to = &drv[1 - *(const int *)ctx].pse;
    if (kind == GP_PSE_CHUNK)
        (void)gp_pse_on_chunk(to, m, now);
    else if (kind == GP_PSE_DONE)
        (void)gp_pse_on_done(to, m, now);
    else
        (void)gp_pse_on_request(to, m, now);
    return 0;
}

static int setup(void **st)
{
    (void)st;
    now = 1000;
    muted[0] = muted[1] = 0;
    for (int i = 0; i < 2; i++) {
        gp_pse_cfg_t c = {(uint32_t)i, 2u, STATE_BYTES, CHUNK, 0.0, RESEND, TIMEOUT, 0, net_send, &ids[i], 0, 1u, 0, 0, 0, 0};
        assert_int_equal(gp_round_init(&drv[i], &c, ROUNDS), 0);
        memset(mine[i], 0x10 + i, STATE_BYTES);
    }
    return 0;
}

static void begin(int i, uint32_t k)
{
    mine[i][0] = (uint8_t)k;
    assert_int_equal(gp_round_begin(&drv[i], mine[i], (double)i, 0.0, now), 0);
}

/* Steps robot i until it says something (time passes by ticks), at most `ticks` ticks. */
static gp_round_event_t step_until_event(int i, int ticks)
{
    for (int t = 0; t < ticks; t++, now += 1000u) {
        const gp_round_event_t ev = gp_round_step(&drv[i], now);
        if (ev != GP_ROUND_WAIT)
            return ev;
    }
    return GP_ROUND_WAIT;
}

static void test_lossless_rounds(void **st)
{
    (void)st;
    for (uint32_t k = 0; k < ROUNDS; k++) {
        for (int i = 0; i < 2; i++)
            assert_int_equal(gp_round_want(&drv[i], k, now), 0); /* again for robot 0: no change */
        assert_int_equal(gp_round_step(&drv[0], now), GP_ROUND_BEGIN);
        assert_int_equal(gp_round_step(&drv[0], now), GP_ROUND_BEGIN); /* until begun */
        begin(0, k);
        /* Robot 1 has not begun: robot 0's states are not there. */
        assert_int_equal(gp_round_step(&drv[0], now), GP_ROUND_WAIT);
        assert_int_equal(gp_round_step(&drv[1], now), GP_ROUND_BEGIN);
        begin(1, k);
        for (int i = 0; i < 2; i++) {
            assert_int_equal(step_until_event(i, 10), GP_ROUND_READY);
            uint32_t who[GP_PSE_MAX_NEIGHBOURS];
            const uint8_t *states[GP_PSE_MAX_NEIGHBOURS];
            assert_int_equal(gp_pse_neighbours(&drv[i].pse, who, states), 1);
            assert_int_equal(who[0], (uint32_t)(1 - i));
            assert_memory_equal(states[0], mine[1 - i], STATE_BYTES);
            assert_int_equal(gp_round_next_round(&drv[i], k, now), k + 1u);
        }
        const int final = k + 1u == ROUNDS;
        assert_int_equal(gp_round_node_done(&drv[0], k + 1u, final, NULL, now), -EINVAL); /* wrong round */
        assert_int_equal(gp_round_node_done(&drv[0], k, final, NULL, now), 0);
        assert_int_equal(gp_round_node_done(&drv[0], k, final, NULL, now), -EINVAL);     /* twice */
        if (!final) {
            /* Robot 1 has not completed k: robot 0 may not begin k + 1, its state of k may
               still be asked for. */
            assert_int_equal(gp_round_want(&drv[0], k + 1u, now), 0);
            assert_int_equal(step_until_event(0, 5), GP_ROUND_WAIT);
        }
        assert_int_equal(gp_round_node_done(&drv[1], k, final, NULL, now), 0);
    }
    /* Both completed the last round: each leaves as soon as it heard the other past it (nobody
       waits for a word of it then), well before the grace of two resend periods a robot keeps
       while a peer may still need its beacons (test_quiet_peer_taken_as_left). */
    assert_int_equal(gp_round_want(&drv[0], ROUNDS - 1u, now), -EINVAL);
    const uint64_t t0 = now;
    gp_round_event_t ev0 = GP_ROUND_WAIT, ev1 = GP_ROUND_WAIT;
    for (int t = 0; t < 200 && (ev0 != GP_ROUND_DONE || ev1 != GP_ROUND_DONE); t++, now += 1000u) {
        if (ev0 != GP_ROUND_DONE)
            ev0 = gp_round_step(&drv[0], now);
        if (ev1 != GP_ROUND_DONE)
            ev1 = gp_round_step(&drv[1], now);
    }
    assert_int_equal(ev0, GP_ROUND_DONE);
    assert_int_equal(ev1, GP_ROUND_DONE);
    assert_true(now - t0 < 2u * RESEND);
    assert_int_equal(gp_round_step(&drv[0], now), GP_ROUND_WAIT); /* DONE once */
}

/* Every "past the last round" beacon of robot 1 is lost: robot 1 hears robot 0 leave and goes,
 * and robot 0, which never hears it leave, takes its silence for leaving: it ends after saying
 * it is past the last round GP_PSE_LEAVE_SAID times and a few beacon periods of that silence,
 * not after the whole peer timeout. */
static void test_quiet_peer_taken_as_left(void **st)
{
    (void)st;
    for (uint32_t k = 0; k < ROUNDS; k++) {
        for (int i = 0; i < 2; i++) {
            assert_int_equal(gp_round_want(&drv[i], k, now), 0);
            assert_int_equal(step_until_event(i, 10), GP_ROUND_BEGIN);
            begin(i, k);
        }
        for (int i = 0; i < 2; i++) {
            assert_int_equal(step_until_event(i, 10), GP_ROUND_READY);
            assert_int_equal(gp_round_next_round(&drv[i], k, now), k + 1u);
        }
        for (int i = 0; i < 2; i++)
            assert_int_equal(gp_round_node_done(&drv[i], k, k + 1u == ROUNDS, NULL, now), 0);
    }
    const uint64_t beacons0 = drv[0].pse.stats.beacons_sent;
    muted[1] = 1; /* its RoundComplete arrived, nothing after it will */
    const uint64_t t0 = now;
    gp_round_event_t ev0 = GP_ROUND_WAIT, ev1 = GP_ROUND_WAIT;
    for (int t = 0; t < 1000 && ev0 != GP_ROUND_DONE; t++, now += 1000u) {
        if (ev1 != GP_ROUND_DONE)
            ev1 = gp_round_step(&drv[1], now); /* then gone: no more steps */
        ev0 = gp_round_step(&drv[0], now);
    }
    assert_int_equal(ev1, GP_ROUND_DONE);
    assert_int_equal(ev0, GP_ROUND_DONE);
    assert_true(drv[0].pse.stats.beacons_sent - beacons0 >= GP_PSE_LEAVE_SAID);
    assert_true(now - t0 >= 2u * RESEND);
    assert_true(now - t0 < TIMEOUT / 4u); /* before the silence rule: the whole TIMEOUT */
}

static void test_out_of_order_refused(void **st)
{
    (void)st;
    assert_int_equal(gp_round_want(&drv[0], ROUNDS, now), -EINVAL);    /* past the last */
    assert_int_equal(gp_round_begin(&drv[0], mine[0], 0, 0, now), -EINVAL); /* no BEGIN yet */
    assert_int_equal(gp_round_node_done(&drv[0], 0, 0, NULL, now), -EINVAL); /* nothing begun */
    assert_int_equal(gp_round_step(&drv[0], now), GP_ROUND_WAIT);      /* nothing wanted */
    assert_int_equal(gp_round_want(&drv[0], 1, now), 0);
    assert_int_equal(gp_round_want(&drv[0], 0, now), -EINVAL);         /* an earlier round */
    assert_int_equal(gp_round_step(&drv[0], now), GP_ROUND_BEGIN);
    begin(0, 1);
    assert_int_equal(gp_round_want(&drv[0], 0, now), -EINVAL);         /* behind the round begun */
    assert_int_equal(gp_round_want(&drv[0], 1, now), 0);               /* the same: fine */
    assert_int_equal(gp_round_init(NULL, NULL, 1), -EINVAL);
}

/* A round wanted but never begun (the caller failed to encode it and ran it alone) gives way to
   the next one, which begins as the first would have. */
static void test_unbegun_round_gives_way(void **st)
{
    (void)st;
    assert_int_equal(gp_round_want(&drv[0], 0, now), 0);
    assert_int_equal(gp_round_step(&drv[0], now), GP_ROUND_BEGIN);
    assert_int_equal(gp_round_node_done(&drv[0], 0, 0, NULL, now), -EINVAL); /* never begun */
    assert_int_equal(gp_round_want(&drv[0], 1, now), 0);
    assert_int_equal(gp_round_want(&drv[0], 0, now), -EINVAL);
    assert_int_equal(gp_round_step(&drv[0], now), GP_ROUND_BEGIN);
    begin(0, 1);
    assert_int_equal(drv[0].pse.round, 1u);
}

/* A robot behind its fleet skips to the round the live peer is in, never past its last. */
static void test_skip_ahead_capped(void **st)
{
    (void)st;
    assert_int_equal(gp_round_want(&drv[1], 2, now), 0);
    assert_int_equal(gp_round_step(&drv[1], now), GP_ROUND_BEGIN);
    begin(1, 2);
    assert_int_equal(gp_round_want(&drv[0], 0, now), 0);
    assert_int_equal(gp_round_step(&drv[0], now), GP_ROUND_BEGIN);
    begin(0, 0);
    /* Robot 1's chunks of round 2 reached robot 0: robot 0 in round 0 knows the fleet is on. */
    assert_int_equal(step_until_event(0, 10), GP_ROUND_READY);
    assert_int_equal(gp_round_next_round(&drv[0], 0, now), 2u);
    assert_int_equal(gp_round_next_round(&drv[0], ROUNDS - 1u, now), ROUNDS); /* the end */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_lossless_rounds, setup),
        cmocka_unit_test_setup(test_quiet_peer_taken_as_left, setup),
        cmocka_unit_test_setup(test_out_of_order_refused, setup),
        cmocka_unit_test_setup(test_unbegun_round_gives_way, setup),
        cmocka_unit_test_setup(test_skip_ahead_capped, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
