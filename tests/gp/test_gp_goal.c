/* Exploration goals and claims (firmware/gp/gp_goal.h): one robot's choice, two robots with and
 * without each other's claims (lost, late, reordered, forged), expiry, periodic claims, the
 * wire codec of fleetsim.goal_claim_t against lcm-gen's, determinism, and the end of
 * exploration. Scenario: a 16 x 8 grid of 1 m cells, all free and known but for two unknown
 * 3 x 3 patches: G around cell (8, 4) (known 255: 9 m^2 of info) and H around (13, 1) (known
 * 128: about 4.5 m^2); robot A at cell (6, 4) (2 m from G), robot B at (11, 4) (3 m from G). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "gp/gp_goal.h"
#include "gp/gp_wire.h"
#include "lcm/fleetsim_goal_claim_t.h"

#define S 1000000ull /* one second of simulated time, us */

typedef struct outbox {
    gp_goal_claim_t sent[16];
    int n;
} outbox_t;

static int capture(void *ctx, const gp_goal_claim_t *c)
{
    outbox_t *o = ctx;
    if (o->n < 16)
        o->sent[o->n++] = *c;
    return 0;
}

static gp_goal_grid_t grid;
static gp_goal_t ga, gb;
static outbox_t oa, ob;

static void patch(uint32_t cx, uint32_t cy, uint8_t known)
{
    for (uint32_t y = cy - 1u; y <= cy + 1u; y++)
        for (uint32_t x = cx - 1u; x <= cx + 1u; x++)
            grid.unknown[y * 16u + x] = known;
}

static gp_goal_cfg_t config(uint32_t self, outbox_t *o)
{
    gp_goal_cfg_t c = {0};
    c.self = self;
    c.n_peers = 4;
    c.w = 16;
    c.h = 8;
    c.res_m = 1.0;
    c.occ_max = 128;
    c.sensor_radius_m = 1.0;
    c.lambda = 0.1;
    c.min_info_m2 = 0.5;
    c.claim_radius_m = 2.5;
    c.claim_discount = 0.0;
    c.claim_period_us = 1 * S;
    c.claim_lifetime_us = 5 * S;
    c.claim_max_lifetime_us = 10 * S;
    c.send = capture;
    c.send_ctx = o;
    return c;
}

/* The scenario: A is robot 0, B robot 1. */
static int setup(void **st)
{
    (void)st;
    memset(&grid, 0, sizeof grid);
    patch(8, 4, 255);
    patch(13, 1, 128);
    memset(&oa, 0, sizeof oa);
    memset(&ob, 0, sizeof ob);
    gp_goal_cfg_t ca = config(0, &oa), cb = config(1, &ob);
    return gp_goal_init(&ga, &ca) == 0 && gp_goal_init(&gb, &cb) == 0 ? 0 : -1;
}

#define AX 6.5
#define BX 11.5
#define Y 4.5
#define CELL(x, y) ((uint32_t)(y) * 16u + (uint32_t)(x))

static uint32_t pick(gp_goal_t *g, double x, double y, uint64_t now)
{
    gp_goal_pick_t p;
    assert_int_equal(gp_goal_select(g, &grid, x, y, now, &p), 0);
    return p.cell;
}

static void test_single_robot_picks_the_most_information_near_it(void **st)
{
    (void)st;
    gp_goal_pick_t p;
    assert_int_equal(gp_goal_select(&ga, &grid, AX, Y, 0, &p), 0);
    assert_int_equal(p.cell, CELL(8, 4));
    assert_true(p.x_m == 8.5 && p.y_m == 4.5);
    assert_true(fabs(p.info_m2 - 9.0) < 1e-9 && p.cost_m == 2.0 && fabs(p.utility - 8.8) < 1e-9);
    /* From (14, 3) the richer G (7 m) still beats H (3 m, 4.5 m^2: 4.2 against 8.3); once H
     * is as rich as G, the nearer wins. */
    assert_int_equal(pick(&ga, 14.5, 3.5, 0), CELL(8, 4));
    patch(13, 1, 255);
    assert_int_equal(pick(&ga, 14.5, 3.5, 0), CELL(13, 1));
    assert_int_equal(pick(&ga, AX, Y, 0), CELL(8, 4));
    /* A wall at x = 5 (every row), robot at (3, 4): nothing to learn on its side. */
    for (uint32_t y = 0; y < 8u; y++)
        grid.occ[CELL(5, y)] = 255;
    assert_int_equal(gp_goal_select(&ga, &grid, 3.5, Y, 0, &p), -ENOENT);
    /* A door at row 0: G costs the way round, (3,4) -> (3,0) -> (8,0) -> (8,4), 13 m. */
    grid.occ[CELL(5, 0)] = 0;
    assert_int_equal(gp_goal_select(&ga, &grid, 3.5, Y, 0, &p), 0);
    assert_int_equal(p.cell, CELL(8, 4));
    assert_true(p.cost_m == 13.0);
}

/* The goal held counts keep_m nearer (hysteresis against the coarse search's cost, which grows
 * while the robot follows the RT core's finer path round a wall): from (14, 3) an H as rich as
 * G is 3 m away and G 7 m. Held, G is kept with keep_m 5 (7 - 5 < 3), not with 3; a robot
 * holding no goal takes H. */
static void test_the_goal_held_is_counted_keep_m_nearer(void **st)
{
    (void)st;
    patch(13, 1, 255);
    const double keeps[] = {0.0, 3.0, 5.0};
    const uint32_t from_h_side[] = {CELL(13, 1), CELL(13, 1), CELL(8, 4)};
    for (size_t k = 0; k < 3; k++) {
        gp_goal_cfg_t c = config(0, &oa);
        c.keep_m = keeps[k];
        assert_int_equal(gp_goal_init(&ga, &c), 0);
        assert_int_equal(pick(&ga, 14.5, 3.5, 0), CELL(13, 1)); /* nothing held: the nearer */
        assert_int_equal(gp_goal_init(&ga, &c), 0);
        assert_int_equal(pick(&ga, AX, Y, 0), CELL(8, 4));
        assert_int_equal(pick(&ga, 14.5, 3.5, 1), from_h_side[k]);
    }
}

static void test_two_robots_without_claims_pick_the_same_goal(void **st)
{
    (void)st;
    assert_int_equal(pick(&ga, AX, Y, 0), CELL(8, 4));
    assert_int_equal(pick(&gb, BX, Y, 0), CELL(8, 4));
    /* Each sent its claim: seq 0, the goal's centre, its cost, now + lifetime. */
    assert_int_equal(oa.n, 1);
    assert_int_equal(ob.n, 1);
    assert_true(oa.sent[0].sender == 0 && oa.sent[0].seq == 0 && oa.sent[0].cost_m == 2.0 &&
                oa.sent[0].x_m == 8.5 && oa.sent[0].expiry_us == 5 * S);
    assert_true(ob.sent[0].sender == 1 && ob.sent[0].cost_m == 3.0);
}

static void test_with_claims_the_nearer_keeps_the_goal(void **st)
{
    (void)st;
    assert_int_equal(pick(&ga, AX, Y, 0), CELL(8, 4));
    assert_int_equal(pick(&gb, BX, Y, 0), CELL(8, 4));
    /* Both claims are delivered: A (nearer) keeps G, B moves to H and claims it. */
    assert_int_equal(gp_goal_on_claim(&ga, &ob.sent[0], 100), 0);
    assert_int_equal(gp_goal_on_claim(&gb, &oa.sent[0], 100), 0);
    assert_int_equal(pick(&ga, AX, Y, 200), CELL(8, 4));
    assert_int_equal(pick(&gb, BX, Y, 200), CELL(13, 1));
    assert_int_equal(ob.n, 2);
    assert_true(ob.sent[1].seq == 1 && ob.sent[1].x_m == 13.5 && ob.sent[1].y_m == 1.5);
    /* B's new claim reaches A: nothing changes for A. */
    assert_int_equal(gp_goal_on_claim(&ga, &ob.sent[1], 300), 0);
    assert_int_equal(pick(&ga, AX, Y, 300), CELL(8, 4));
}

static void test_tie_goes_to_the_lower_id(void **st)
{
    (void)st;
    /* B at (10, 4): 2 m from G as A is. A's claim (cost 2) holds against B, B's not against A. */
    assert_int_equal(pick(&ga, AX, Y, 0), CELL(8, 4));
    assert_int_equal(pick(&gb, 10.5, Y, 0), CELL(8, 4));
    assert_int_equal(ob.sent[0].cost_m, 2.0);
    assert_int_equal(gp_goal_on_claim(&ga, &ob.sent[0], 1), 0);
    assert_int_equal(gp_goal_on_claim(&gb, &oa.sent[0], 1), 0);
    assert_int_equal(pick(&ga, AX, Y, 2), CELL(8, 4));
    assert_int_not_equal(pick(&gb, 10.5, Y, 2), CELL(8, 4));
}

/* Costs within claim_tie_m are a tie (claims' costs are as old as the claims): robot 0 at 3 m
 * keeps G against robot 1 at 2 m, on both sides; with no tie margin the nearer one would. And a
 * claimant's cost falls with its claim's age at claim_speed_mps. */
static void test_costs_within_the_tie_margin_go_to_the_lower_id(void **st)
{
    (void)st;
    gp_goal_cfg_t ca = config(0, &oa), cb = config(1, &ob);
    ca.claim_tie_m = cb.claim_tie_m = 1.5;
    assert_int_equal(gp_goal_init(&ga, &ca), 0);
    assert_int_equal(gp_goal_init(&gb, &cb), 0);
    assert_int_equal(pick(&ga, BX, Y, 0), CELL(8, 4));
    assert_int_equal(pick(&gb, AX, Y, 0), CELL(8, 4));
    assert_true(oa.sent[0].cost_m == 3.0 && ob.sent[0].cost_m == 2.0);
    assert_int_equal(gp_goal_on_claim(&ga, &ob.sent[0], 1), 0);
    assert_int_equal(gp_goal_on_claim(&gb, &oa.sent[0], 1), 0);
    assert_int_equal(pick(&ga, BX, Y, 2), CELL(8, 4));
    assert_int_not_equal(pick(&gb, AX, Y, 2), CELL(8, 4));
    /* A claim's cost falls with its age at 0.5 m/s: robot 1's claim (cost 2 when sent at 0) is
       1.5 m 1 s later, still a tie with robot 0's 3 m; 4 s later it is 0 and holds. */
    ca.claim_speed_mps = 0.5;
    assert_int_equal(gp_goal_init(&ga, &ca), 0);
    assert_int_equal(gp_goal_on_claim(&ga, &ob.sent[0], 1), 0);
    assert_int_equal(pick(&ga, BX, Y, 1 * S), CELL(8, 4));
    assert_int_not_equal(pick(&ga, BX, Y, 4 * S), CELL(8, 4));
    ca.claim_speed_mps = -1.0;
    assert_int_equal(gp_goal_init(&ga, &ca), -EINVAL);
    ca.claim_speed_mps = 0.0;
    ca.claim_tie_m = -1.0;
    assert_int_equal(gp_goal_init(&ga, &ca), -EINVAL);
    ca.claim_tie_m = NAN;
    assert_int_equal(gp_goal_init(&ga, &ca), -EINVAL);
}

/* A claim that holds against our goal makes it contested (the caller chooses again); when every
 * candidate worth a look is a nearer peer's, the choice is -EBUSY (wait), not -ENOENT (done). */
static void test_contested_goal_and_all_claimed(void **st)
{
    (void)st;
    gp_goal_cfg_t cb = config(1, &ob);
    cb.claim_radius_m = 4.0; /* beyond every cell whose window reaches G */
    assert_int_equal(gp_goal_init(&gb, &cb), 0);
    assert_int_equal(gp_goal_contested(&ga, 0), 0); /* no goal yet */
    assert_int_equal(pick(&ga, AX, Y, 0), CELL(8, 4));
    assert_int_equal(pick(&gb, BX, Y, 0), CELL(8, 4));
    assert_int_equal(gp_goal_on_claim(&ga, &ob.sent[0], 1), 0);
    assert_int_equal(gp_goal_on_claim(&gb, &oa.sent[0], 1), 0);
    assert_int_equal(gp_goal_contested(&ga, 2), 0); /* B is farther */
    assert_int_equal(gp_goal_contested(&gb, 2), 1);
    /* only G is left: B waits, A keeps it */
    patch(13, 1, 0);
    gp_goal_pick_t p;
    assert_int_equal(gp_goal_select(&gb, &grid, BX, Y, 3, &p), -EBUSY);
    assert_int_equal(gp_goal_contested(&gb, 3), 0); /* no goal of its own now */
    assert_int_equal(pick(&ga, AX, Y, 3), CELL(8, 4));
    /* once A's claim has expired, G is B's again; with nothing worth a look, done */
    assert_int_equal(pick(&gb, BX, Y, 6 * S), CELL(8, 4));
    patch(8, 4, 0);
    assert_int_equal(gp_goal_select(&gb, &grid, BX, Y, 6 * S, &p), -ENOENT);
}

/* A kept claim's window (claim_window_m) takes what its claimant will see out of every
 * candidate's info: B, whose claim radius covers only G's own cell, goes to a cell beside G
 * (two thirds of G in its window) without the window, and to H with it; when G is all that is
 * left, B waits (-EBUSY), it is not done. */
static void test_a_claims_window_is_not_ours_to_learn(void **st)
{
    (void)st;
    gp_goal_cfg_t cb = config(1, &ob);
    cb.claim_radius_m = 0.5;
    assert_int_equal(gp_goal_init(&gb, &cb), 0);
    assert_int_equal(pick(&ga, AX, Y, 0), CELL(8, 4));
    assert_int_equal(gp_goal_on_claim(&gb, &oa.sent[0], 1), 0);
    const uint32_t beside = pick(&gb, BX, Y, 2);
    assert_int_equal(beside, CELL(9, 4));
    cb.claim_window_m = 1.0; /* G's 3 x 3 patch, what A sees there */
    assert_int_equal(gp_goal_init(&gb, &cb), 0);
    assert_int_equal(gp_goal_on_claim(&gb, &oa.sent[0], 1), 0);
    assert_int_equal(pick(&gb, BX, Y, 2), CELL(13, 1));
    patch(13, 1, 0);
    gp_goal_pick_t p;
    assert_int_equal(gp_goal_select(&gb, &grid, BX, Y, 3, &p), -EBUSY);
    /* A's claim expired: G is B's to learn again. */
    assert_int_equal(pick(&gb, BX, Y, 6 * S), CELL(8, 4));
    cb.claim_window_m = -1.0;
    assert_int_equal(gp_goal_init(&gb, &cb), -EINVAL);
    cb.claim_window_m = NAN;
    assert_int_equal(gp_goal_init(&gb, &cb), -EINVAL);
}

static void test_lost_claim_then_delivered(void **st)
{
    (void)st;
    assert_int_equal(pick(&ga, AX, Y, 0), CELL(8, 4));
    assert_int_equal(pick(&gb, BX, Y, 0), CELL(8, 4));
    /* A's first claim is lost: B keeps G, as does A. */
    assert_int_equal(pick(&gb, BX, Y, S / 2), CELL(8, 4));
    /* A's periodic claim (a period later, seq 1) arrives: the farther one switches. */
    gp_goal_poll(&ga, S);
    assert_int_equal(oa.n, 2);
    assert_int_equal(oa.sent[1].seq, 1);
    assert_int_equal(gp_goal_on_claim(&gb, &oa.sent[1], S + 10), 0);
    assert_int_equal(pick(&gb, BX, Y, S + 20), CELL(13, 1));
    /* The lost seq 0 arriving after seq 1 (reordered) is ignored. */
    assert_int_equal(gp_goal_on_claim(&gb, &oa.sent[0], S + 30), -ESTALE);
    assert_int_equal(gp_goal_on_claim(&gb, &oa.sent[1], S + 30), -EALREADY);
    gp_goal_claim_t held;
    assert_int_equal(gp_goal_claim_of(&gb, 0, S + 30, &held), 0);
    assert_int_equal(held.seq, 1);
}

static void test_late_claims_change_nothing(void **st)
{
    (void)st;
    assert_int_equal(pick(&ga, AX, Y, 0), CELL(8, 4));
    assert_int_equal(pick(&gb, BX, Y, 0), CELL(8, 4));
    /* A's claim arrives after its expiry. */
    assert_int_equal(gp_goal_on_claim(&gb, &oa.sent[0], oa.sent[0].expiry_us), -ESTALE);
    assert_int_equal(pick(&gb, BX, Y, 6 * S), CELL(8, 4));
    /* A newer claim of A elsewhere (1 m from A, seq 5), then an older one on G (seq 4). */
    const gp_goal_claim_t newer = {0, 5, 1.5, 6.5, 1.0, 7 * S}, older = {0, 4, 8.5, 4.5, 2.0, 7 * S};
    assert_int_equal(gp_goal_on_claim(&gb, &newer, 6 * S), 0);
    assert_int_equal(gp_goal_on_claim(&gb, &older, 6 * S), -ESTALE);
    assert_int_equal(pick(&gb, BX, Y, 6 * S + 1), CELL(8, 4));
    assert_int_equal(gb.stats.claims_late, 1);
    assert_int_equal(gb.stats.claims_reordered, 1);
}

static void test_forged_claims_are_refused(void **st)
{
    (void)st;
    assert_int_equal(pick(&gb, BX, Y, 0), CELL(8, 4));
    const gp_goal_claim_t good = {0, 3, 8.5, 4.5, 2.0, 5 * S};
    gp_goal_claim_t bad[10];
    for (int i = 0; i < 10; i++)
        bad[i] = good;
    bad[0].sender = 4;                 /* outside the fleet of 4 */
    bad[1].sender = 1;                 /* B's own id */
    bad[2].x_m = NAN;
    bad[3].y_m = INFINITY;
    bad[4].x_m = 16.0;                 /* the map ends at 16 m */
    bad[5].y_m = -0.001;
    bad[6].cost_m = -1.0;
    bad[7].cost_m = NAN;
    bad[8].expiry_us = 10 * S + 1u;    /* more than the 10 s lifetime ahead */
    bad[9].seq = 0x80000000u;          /* a negative int32 */
    for (int i = 0; i < 10; i++)
        assert_int_equal(gp_goal_on_claim(&gb, &bad[i], 0), -EBADMSG);
    assert_int_equal(gb.stats.claims_invalid, 10);
    gp_goal_claim_t held;
    assert_int_equal(gp_goal_claim_of(&gb, 0, 0, &held), -ENOENT);
    assert_int_equal(pick(&gb, BX, Y, 1), CELL(8, 4));
    assert_int_equal(gp_goal_on_claim(&gb, NULL, 0), -EINVAL);
    /* The genuine one works, and a forged one of A after it does not replace it. */
    assert_int_equal(gp_goal_on_claim(&gb, &good, 2), 0);
    bad[2].seq = 9;
    assert_int_equal(gp_goal_on_claim(&gb, &bad[2], 3), -EBADMSG);
    assert_int_equal(gp_goal_claim_of(&gb, 0, 3, &held), 0);
    assert_int_equal(held.seq, 3);
}

static void test_claims_expire(void **st)
{
    (void)st;
    assert_int_equal(pick(&ga, AX, Y, 0), CELL(8, 4));
    assert_int_equal(gp_goal_on_claim(&gb, &oa.sent[0], 1), 0);
    assert_int_equal(pick(&gb, BX, Y, 2), CELL(13, 1));
    assert_int_equal(pick(&gb, BX, Y, 5 * S - 1u), CELL(13, 1));
    /* A is silent (its claims lost, or A gone): at the expiry G is free again for B. */
    assert_int_equal(pick(&gb, BX, Y, 5 * S), CELL(8, 4));
    gp_goal_claim_t held;
    assert_int_equal(gp_goal_claim_of(&gb, 0, 5 * S, &held), -ENOENT);
    assert_int_equal(gb.stats.claims_expired, 1);
}

static void test_claims_repeat_every_period_and_on_change(void **st)
{
    (void)st;
    assert_int_equal(pick(&ga, AX, Y, 0), CELL(8, 4));
    assert_int_equal(pick(&ga, AX, Y, S / 2), CELL(8, 4));
    assert_int_equal(oa.n, 1);
    assert_int_equal(pick(&ga, AX, Y, S), CELL(8, 4));
    gp_goal_poll(&ga, S + S / 2);
    gp_goal_poll(&ga, 2 * S);
    assert_int_equal(oa.n, 3);
    assert_true(oa.sent[1].seq == 1 && oa.sent[1].expiry_us == 6 * S);
    assert_true(oa.sent[2].seq == 2 && oa.sent[2].expiry_us == 7 * S);
    /* G is explored: the goal moves to H and is claimed at once. */
    patch(8, 4, 0);
    assert_int_equal(pick(&ga, AX, Y, 2 * S + 1u), CELL(13, 1));
    assert_int_equal(oa.n, 4);
    assert_true(oa.sent[3].seq == 3 && oa.sent[3].x_m == 13.5);
}

static void test_nothing_left_to_learn(void **st)
{
    (void)st;
    patch(8, 4, 0);
    patch(13, 1, 0);
    gp_goal_pick_t p = {0};
    assert_int_equal(gp_goal_select(&ga, &grid, AX, Y, 0, &p), -ENOENT);
    assert_int_equal(oa.n, 0);
    gp_goal_poll(&ga, 10 * S);
    assert_int_equal(oa.n, 0);
    /* Nothing is learnt either from a patch below min_info_m2 (0.5 m^2): 3 cells of 30/255. */
    grid.unknown[CELL(3, 3)] = grid.unknown[CELL(3, 4)] = grid.unknown[CELL(3, 5)] = 30;
    assert_int_equal(gp_goal_select(&ga, &grid, AX, Y, 0, &p), -ENOENT);
    /* Bad arguments. */
    assert_int_equal(gp_goal_select(&ga, &grid, -0.5, Y, 0, &p), -EINVAL);
    assert_int_equal(gp_goal_select(&ga, &grid, NAN, Y, 0, &p), -EINVAL);
    assert_int_equal(gp_goal_select(&ga, NULL, AX, Y, 0, &p), -EINVAL);
}

static void test_deterministic(void **st)
{
    (void)st;
    /* The same calls twice, from scratch: the same goals and the same claims, byte for byte.
     * A symmetric grid (H mirrored at the far left) makes the tie-break matter. */
    gp_goal_pick_t p[2][3];
    outbox_t sent[2];
    for (int run = 0; run < 2; run++) {
        assert_int_equal(setup(NULL), 0);
        patch(2, 1, 128);
        assert_int_equal(gp_goal_select(&ga, &grid, AX, Y, 0, &p[run][0]), 0);
        assert_int_equal(gp_goal_on_claim(&ga, &(gp_goal_claim_t){1, 0, 8.5, 4.5, 1.0, 5 * S}, 1), 0);
        assert_int_equal(gp_goal_select(&ga, &grid, AX, Y, 2, &p[run][1]), 0);
        assert_int_equal(gp_goal_select(&ga, &grid, 7.5, 1.5, 3, &p[run][2]), 0);
        sent[run] = oa;
    }
    for (int i = 0; i < 3; i++) /* field by field: the struct has padding */
        assert_true(p[0][i].cell == p[1][i].cell && p[0][i].x_m == p[1][i].x_m && p[0][i].y_m == p[1][i].y_m &&
                    p[0][i].info_m2 == p[1][i].info_m2 && p[0][i].cost_m == p[1][i].cost_m &&
                    p[0][i].utility == p[1][i].utility);
    assert_int_equal(sent[0].n, sent[1].n);
    assert_memory_equal(sent[0].sent, sent[1].sent, sizeof sent[0].sent[0] * (size_t)sent[0].n);
    /* The second goal: H at (2, 1) or (13, 1), 7 m and 10 m from A; then from (7, 1), 5 and 6. */
    assert_int_equal(p[0][1].cell, CELL(2, 1));
    assert_int_equal(p[0][2].cell, CELL(2, 1));
    /* An exact tie (all equal: one unknown cell at each end, robot in the middle): the lower index. */
    memset(&grid, 0, sizeof grid);
    grid.unknown[0] = grid.unknown[14] = 255; /* a 15 x 1 grid */
    gp_goal_cfg_t c = config(0, &oa);
    c.w = 15;
    c.h = 1;
    c.sensor_radius_m = 0.0;
    assert_int_equal(gp_goal_init(&ga, &c), 0);
    gp_goal_pick_t q;
    assert_int_equal(gp_goal_select(&ga, &grid, 7.9, 0.5, 0, &q), 0);
    assert_int_equal(q.cell, 0); /* 7 steps to either end */
}

static void test_claim_table_and_config(void **st)
{
    (void)st;
    gp_goal_cfg_t c = config(0, &oa);
    c.n_peers = 40;
    assert_int_equal(gp_goal_init(&ga, &c), 0);
    for (uint32_t i = 1; i <= GP_GOAL_MAX_CLAIMS; i++)
        assert_int_equal(gp_goal_on_claim(&ga, &(gp_goal_claim_t){i, 0, 1.5, 1.5, 1.0, 5 * S + i}, 0), 0);
    /* Full: a claim expiring before all of them is refused; a later one takes the soonest's place. */
    assert_int_equal(gp_goal_on_claim(&ga, &(gp_goal_claim_t){35, 0, 1.5, 1.5, 1.0, 5 * S}, 0), -ENOSPC);
    assert_int_equal(gp_goal_on_claim(&ga, &(gp_goal_claim_t){35, 0, 1.5, 1.5, 1.0, 6 * S}, 0), 0);
    gp_goal_claim_t held;
    assert_int_equal(gp_goal_claim_of(&ga, 1, 0, &held), -ENOENT);
    assert_int_equal(gp_goal_claim_of(&ga, 35, 0, &held), 0);
    /* Configurations out of range. */
    gp_goal_cfg_t bad[9];
    for (int i = 0; i < 9; i++)
        bad[i] = config(0, &oa);
    bad[0].self = 4;
    bad[1].w = GP_GOAL_MAX_W + 1u;
    bad[2].res_m = 0.0;
    bad[3].claim_discount = 1.5;
    bad[4].claim_lifetime_us = bad[4].claim_period_us;
    bad[5].claim_max_lifetime_us = GP_GOAL_MAX_LIFETIME_US + 1u;
    bad[6].min_info_m2 = 0.0;
    bad[7].origin_x_m = NAN;
    bad[8].keep_m = -1.0;
    for (int i = 0; i < 9; i++)
        assert_int_equal(gp_goal_init(&ga, &bad[i]), -EINVAL);
}

static void test_wire(void **st)
{
    (void)st;
    assert_int_equal((uint64_t)__fleetsim_goal_claim_t_get_hash(), GP_WIRE_FP_GOAL_CLAIM);
    assert_int_equal(GP_WIRE_CLAIM_BYTES, 48);
    const gp_goal_claim_t c = {3, 41, 8.5, -4.25, 2.0, 5 * S};
    uint8_t mine[64], theirs[64];
    assert_int_equal(gp_wire_encode_claim(&c, mine, GP_WIRE_CLAIM_BYTES - 1u), -EMSGSIZE);
    assert_int_equal(gp_wire_encode_claim(&c, mine, sizeof mine), 48);
    fleetsim_goal_claim_t l = {3, 41, 8.5, -4.25, 2.0, (int64_t)(5 * S)};
    assert_int_equal(fleetsim_goal_claim_t_encode(theirs, 0, (int)sizeof theirs, &l), 48);
    assert_memory_equal(mine, theirs, 48);
    gp_goal_claim_t back, untouched;
    memset(&untouched, 0xA5, sizeof untouched);
    assert_int_equal(gp_wire_decode_claim(theirs, 48, &back), 0);
    assert_memory_equal(&back, &c, sizeof c);
    /* Truncated, oversized, another type, a NaN, a negative cost or time: refused, output kept. */
    back = untouched;
    assert_int_equal(gp_wire_decode_claim(theirs, 47, &back), -EBADMSG);
    assert_int_equal(gp_wire_decode_claim(theirs, 49, &back), -EBADMSG);
    assert_int_equal(gp_wire_decode_claim(theirs, 0, &back), -EBADMSG);
    assert_int_equal(gp_wire_decode_claim(NULL, 48, &back), -EBADMSG);
    const gp_goal_claim_t nan_x = {3, 41, NAN, 1.0, 2.0, S}, neg = {3, 41, 1.0, 1.0, -2.0, S};
    const gp_goal_claim_t neg_t = {3, 41, 1.0, 1.0, 2.0, UINT64_MAX}, neg_id = {0x80000000u, 1, 1.0, 1.0, 2.0, S};
    const gp_goal_claim_t *bad[4] = {&nan_x, &neg, &neg_t, &neg_id};
    for (int i = 0; i < 4; i++) {
        assert_int_equal(gp_wire_encode_claim(bad[i], mine, sizeof mine), 48);
        assert_int_equal(gp_wire_decode_claim(mine, 48, &back), -EBADMSG);
    }
    theirs[0] ^= 1u;
    assert_int_equal(gp_wire_decode_claim(theirs, 48, &back), -EBADMSG);
    assert_memory_equal(&back, &untouched, sizeof back);
}

/* A peer a round ahead: its claim of round k + 1 comes before our round k ends. Both orders
 * of arrival hand the same claims at the same rounds (the fleet's determinism). */
static void test_inbox_hands_each_round_its_own_claim(void **st)
{
    (void)st;
    const gp_goal_claim_t k = {2, 7, 1.0, 1.0, 3.0, 5 * S}, k1 = {2, 8, 4.0, 1.0, 2.0, 6 * S};
    const gp_goal_claim_t k1_again = {2, 8, 4.5, 1.0, 2.0, 6 * S}, old = {2, 6, 9.0, 9.0, 1.0, 4 * S};
    for (int order = 0; order < 2; order++) {
        gp_goal_inbox_t in;
        memset(&in, 0, sizeof in);
        gp_goal_inbox_put(&in, order ? &k1 : &k);
        gp_goal_inbox_put(&in, order ? &k : &k1);
        gp_goal_claim_t out;
        assert_int_equal(gp_goal_inbox_take(&in, 6, &out), 0); /* nothing of round 6 or before */
        assert_int_equal(gp_goal_inbox_take(&in, 7, &out), 1);
        assert_memory_equal(&out, &k, sizeof out);
        assert_int_equal(gp_goal_inbox_take(&in, 7, &out), 0); /* handed once */
        gp_goal_inbox_put(&in, &k1_again);                    /* the same seq again: the later copy */
        assert_int_equal(gp_goal_inbox_take(&in, 8, &out), 1);
        assert_memory_equal(&out, &k1_again, sizeof out);
        assert_int_equal(in.held, 0);
    }
    /* Behind by more (a robot that skipped rounds): the newest of seq <= round, the rest dropped. */
    gp_goal_inbox_t in;
    memset(&in, 0, sizeof in);
    gp_goal_inbox_put(&in, &k);
    gp_goal_inbox_put(&in, &k1);
    gp_goal_claim_t out;
    assert_int_equal(gp_goal_inbox_take(&in, 20, &out), 1);
    assert_memory_equal(&out, &k1, sizeof out);
    assert_int_equal(in.held, 0);
    /* An older seq in a held slot's parity is dropped: k (7) is held, 5 would share its slot. */
    gp_goal_inbox_put(&in, &k);
    const gp_goal_claim_t older = {2, 5, 0.5, 0.5, 1.0, 3 * S};
    gp_goal_inbox_put(&in, &older);
    assert_int_equal(gp_goal_inbox_take(&in, 7, &out), 1);
    assert_memory_equal(&out, &k, sizeof out);
    gp_goal_inbox_put(&in, &old);
    assert_int_equal(gp_goal_inbox_take(&in, 6, &out), 1);
    assert_memory_equal(&out, &old, sizeof out);
}

/* info_by_path: a wall at x = 10 (rows 0-6, a door in row 7), the robot at (8, 1) beside it,
 * unknown only behind it (a 3 x 3 patch around (12, 1)). Summed over the square window, the
 * cells just this side of the wall look into the patch, though from there the lidar sees
 * the wall; counted only where the robot gets within the window's half side past the
 * candidate, the patch is worth a look only from its own side, through the door. */
static void test_info_by_path_sees_nothing_through_a_known_wall(void **st)
{
    (void)st;
    memset(&grid, 0, sizeof grid);
    patch(12, 1, 255);
    for (uint32_t y = 0; y < 7u; y++)
        grid.occ[CELL(10, y)] = 255;
    gp_goal_cfg_t c = config(0, &oa);
    c.sensor_radius_m = 2.0;
    c.lambda = 0.5;
    gp_goal_pick_t window, by_path;
    assert_int_equal(gp_goal_init(&ga, &c), 0);
    assert_int_equal(gp_goal_select(&ga, &grid, 8.5, 1.5, 0, &window), 0);
    assert_true(window.cell % 16u < 10u); /* this side of the wall: two steps away */
    c.info_by_path = 1;
    assert_int_equal(gp_goal_init(&ga, &c), 0);
    assert_int_equal(gp_goal_select(&ga, &grid, 8.5, 1.5, 0, &by_path), 0);
    assert_true(by_path.cell % 16u > 10u); /* the room's side, the long way round */
    assert_true(by_path.cost_m >= 13.0 && by_path.info_m2 >= 0.5);
    /* Nothing walled off: the patch is worth a look from this side, a few steps away. */
    memset(grid.occ, 0, sizeof grid.occ);
    assert_int_equal(gp_goal_select(&ga, &grid, 8.5, 1.5, 0, &by_path), 0);
    assert_true(by_path.cell % 16u >= 10u && by_path.cost_m <= 4.0 && by_path.info_m2 >= 4.0);
    c.info_by_path = 2;
    assert_int_equal(gp_goal_init(&ga, &c), -EINVAL);
}

/* What a look from a goal takes in (gp_goal_look): its window, without the cells behind a wall
 * the search from it does not reach within the window's steps; the whole window without
 * info_by_path. The wall at column 10 (rows 0-6) with a goal at (9, 1): the window's cells beyond
 * the wall are left out, those on this side in. */
static void test_a_look_stops_at_walls(void **st)
{
    (void)st;
    memset(&grid, 0, sizeof grid);
    for (uint32_t y = 0; y < 7u; y++)
        grid.occ[CELL(10, y)] = 255;
    gp_goal_cfg_t c = config(0, &oa);
    c.sensor_radius_m = 2.0;
    c.info_by_path = 1;
    assert_int_equal(gp_goal_init(&ga, &c), 0);
    static uint8_t mark[GP_GOAL_MAX_CELLS];
    memset(mark, 0, sizeof mark);
    assert_int_equal(gp_goal_look(&ga, &grid, CELL(9, 1), mark), 0);
    uint32_t marked = 0;
    for (uint32_t y = 0; y < 8u; y++)
        for (uint32_t x = 0; x < 16u; x++) {
            const int in_window = x >= 7u && x <= 11u && y <= 3u;
            if (!in_window || x >= 10u)
                assert_int_equal(mark[CELL(x, y)], 0); /* outside, the wall and behind it */
            else
                assert_int_equal(mark[CELL(x, y)], 1);
            marked += mark[CELL(x, y)];
        }
    assert_int_equal(marked, 3u * 4u);
    /* Marks already set stay, and the whole window without info_by_path. */
    c.info_by_path = 0;
    assert_int_equal(gp_goal_init(&ga, &c), 0);
    assert_int_equal(gp_goal_look(&ga, &grid, CELL(9, 1), mark), 0);
    for (uint32_t x = 7u; x <= 11u; x++)
        assert_int_equal(mark[CELL(x, 3)], 1);
    assert_int_equal(gp_goal_look(&ga, &grid, 16u * 8u, mark), -EINVAL);
    assert_int_equal(gp_goal_look(&ga, NULL, 0, mark), -EINVAL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_single_robot_picks_the_most_information_near_it, setup),
        cmocka_unit_test_setup(test_the_goal_held_is_counted_keep_m_nearer, setup),
        cmocka_unit_test_setup(test_two_robots_without_claims_pick_the_same_goal, setup),
        cmocka_unit_test_setup(test_with_claims_the_nearer_keeps_the_goal, setup),
        cmocka_unit_test_setup(test_costs_within_the_tie_margin_go_to_the_lower_id, setup),
        cmocka_unit_test_setup(test_contested_goal_and_all_claimed, setup),
        cmocka_unit_test_setup(test_tie_goes_to_the_lower_id, setup),
        cmocka_unit_test_setup(test_a_claims_window_is_not_ours_to_learn, setup),
        cmocka_unit_test_setup(test_lost_claim_then_delivered, setup),
        cmocka_unit_test_setup(test_late_claims_change_nothing, setup),
        cmocka_unit_test_setup(test_forged_claims_are_refused, setup),
        cmocka_unit_test_setup(test_claims_expire, setup),
        cmocka_unit_test_setup(test_claims_repeat_every_period_and_on_change, setup),
        cmocka_unit_test_setup(test_nothing_left_to_learn, setup),
        cmocka_unit_test_setup(test_deterministic, setup),
        cmocka_unit_test_setup(test_claim_table_and_config, setup),
        cmocka_unit_test_setup(test_wire, setup),
        cmocka_unit_test_setup(test_inbox_hands_each_round_its_own_claim, setup),
        cmocka_unit_test_setup(test_info_by_path_sees_nothing_through_a_known_wall, setup),
        cmocka_unit_test_setup(test_a_look_stops_at_walls, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
