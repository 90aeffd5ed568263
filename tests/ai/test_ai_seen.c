/* The counts of what the lidar covered (ai/ai_seen.h): samples land in the cell of their
 * position and nowhere else; the share of a cell left to see (exp(-n / m) where rays went; 1
 * beyond an open cell; 0 behind hits); the state form and the consensus that keeps the
 * fleet's counts while data arrive; every refusal; no allocation. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "ai/ai_seen.h"

#define GW 8u
#define GH 6u
#define NROBOTS 3

static ai_seen_t s, r[NROBOTS];
static float st[NROBOTS][AI_SEEN_STATE_FLOATS(GW * GH) + 4u];

/* A plan box of [2, 10] x [1, 7] m, the grid on it at 0.5 m from (2, 1): 4 x 3 m. */
static ai_belief_cfg_t geometry(void)
{
    ai_belief_cfg_t c = {.w = GW, .h = GH, .res_m = 0.5f, .origin_x_m = 2.0f, .origin_y_m = 1.0f,
                         .min_x = 2.0f, .min_y = 1.0f, .max_x = 10.0f, .max_y = 7.0f};
    return c;
}

/* A sample at (x, y) m, normalised as ai_sample.h says; occ 1 a hit. */
static ai_sample_t at(double x, double y, float occ)
{
    ai_sample_t a = {(float)(2.0 * (x - 2.0) / 8.0 - 1.0), (float)(2.0 * (y - 1.0) / 6.0 - 1.0), occ};
    return a;
}

static uint32_t cell(uint32_t col, uint32_t row)
{
    return row * GW + col;
}

static void test_samples_land_in_their_cell(void **state)
{
    (void)state;
    const ai_belief_cfg_t c = geometry();
    assert_int_equal(ai_seen_init(&s, &c), 0);
    ai_sample_t smp[5] = {at(2.25, 1.25, 0.0f), at(5.9, 3.9, 1.0f), at(3.75, 2.1, 0.0f), at(9.0, 3.0, 0.0f),
                          {NAN, 0.0f, 0.0f}}; /* cells (0, 0), (7, 5), (3, 2); outside the grid; not finite */
    alloc_count_reset();
    assert_int_equal(ai_seen_add(&s, smp, 5, 2.0), 0);
    assert_int_equal(ai_seen_flood(&s), 0);
    assert_int_equal(alloc_count_allocations(), 0);
    double total = 0, hits = 0;
    for (uint32_t i = 0; i < GW * GH; i++) {
        total += s.n[i];
        hits += s.hits[i];
    }
    assert_true(total == 6.0 && hits == 2.0);
    assert_true(s.n[cell(0, 0)] == 2.0f && s.n[cell(7, 5)] == 2.0f && s.hits[cell(7, 5)] == 2.0f &&
                s.n[cell(3, 2)] == 2.0f);
    /* where samples fell: the share of the cell's 25 spots of 0.1 m none fell on */
    assert_true(fabs(ai_seen_share(&s, cell(0, 0)) - exp(-2.0 / 25.0)) < 1e-9);
    s.unreached_only = 1; /* the fallback layer's counts: a reached cell says nothing */
    assert_true(ai_seen_share(&s, cell(0, 0)) == 0.0);
    s.unreached_only = 0;
    assert_int_equal(ai_seen_scale(&s, 0.5), 0);
    assert_true(s.n[cell(0, 0)] == 1.0f && s.hits[cell(7, 5)] == 1.0f);
    assert_true(ai_seen_share(&s, GW * GH) == 0.0 && ai_seen_share(NULL, 0) == 0.0);
}

/* A room of 3 x 6 cells (columns 0-2) seen from inside, its wall (column 3) hit, and nothing
 * beyond the wall: the cells behind it say nothing (0). Then a door: rays through row 2 pass the
 * wall and end free in column 4, and everything beyond is unseen building (1). */
static void test_beyond_an_open_cell_not_behind_a_wall(void **state)
{
    (void)state;
    const ai_belief_cfg_t c = geometry();
    assert_int_equal(ai_seen_init(&s, &c), 0);
    for (uint32_t row = 0; row < GH; row++) {
        for (uint32_t col = 0; col < 3; col++) {
            const ai_sample_t a = at(2.25 + 0.5 * col, 1.25 + 0.5 * row, 0.0f);
            for (int k = 0; k < 40; k++)
                assert_int_equal(ai_seen_add(&s, &a, 1, 1.0), 0);
        }
        const ai_sample_t wall[2] = {at(3.75, 1.25 + 0.5 * row, 1.0f), at(3.6, 1.25 + 0.5 * row, 0.0f)};
        assert_int_equal(ai_seen_add(&s, wall, 2, 1.0), 0); /* a hit and a free point: not open */
    }
    assert_int_equal(ai_seen_flood(&s), 0);
    for (uint32_t row = 0; row < GH; row++)
        for (uint32_t col = 4; col < GW; col++)
            assert_true(ai_seen_share(&s, cell(col, row)) == 0.0);
    assert_true(ai_seen_share(&s, cell(1, 1)) < 0.25); /* 40 samples on 25 spots */
    assert_true(ai_seen_share(&s, cell(3, 1)) > 0.9);  /* the wall's 2 */
    const ai_sample_t door[3] = {at(3.75, 2.25, 0.0f), at(3.8, 2.25, 0.0f), at(4.25, 2.25, 0.0f)};
    for (int k = 0; k < 10; k++) /* many rays through the door: the wall cell there is open */
        assert_int_equal(ai_seen_add(&s, door, 3, 1.0), 0);
    assert_int_equal(ai_seen_flood(&s), 0);
    for (uint32_t row = 0; row < GH; row++)
        for (uint32_t col = 4; col < GW; col++)
            if (!(col == 4 && row == 2))
                assert_true(ai_seen_share(&s, cell(col, row)) == 1.0);
    /* the fallback layer's counts: the unseen building beyond as before, the reached cells 0 */
    s.unreached_only = 1;
    assert_true(ai_seen_share(&s, cell(6, 4)) == 1.0 && ai_seen_share(&s, cell(3, 1)) == 0.0 &&
                ai_seen_share(&s, cell(4, 2)) == 0.0);
}

/* Dynamic average consensus, as the AI core runs it: each robot's grid starts at N times its
 * own, new samples count N, each round mixes the others' in at 1/N. Every grid is the fleet's
 * count after each round on this complete graph. */
static void test_consensus_keeps_the_fleets_count(void **state)
{
    (void)state;
    const ai_belief_cfg_t c = geometry();
    double truth[GW * GH] = {0}, truth_hits[GW * GH] = {0};
    for (int k = 0; k < NROBOTS; k++)
        assert_int_equal(ai_seen_init(&r[k], &c), 0);
    for (uint32_t step = 0; step < 4; step++) {
        for (uint32_t k = 0; k < NROBOTS; k++) { /* robot k sees a room of its own, one sample a step */
            const ai_sample_t a = at(2.25 + 1.0 * k, 1.25 + 0.5 * step, (float)(step & 1u));
            const double w = step == 0 ? 1.0 : (double)NROBOTS;
            assert_int_equal(ai_seen_add(&r[k], &a, 1, w), 0);
            truth[cell(2u * k, step)] += 1.0;
            truth_hits[cell(2u * k, step)] += (double)(step & 1u);
            if (step == 0)
                assert_int_equal(ai_seen_scale(&r[k], NROBOTS), 0);
        }
        for (int k = 0; k < NROBOTS; k++)
            assert_int_equal(ai_seen_to_state(&r[k], st[k] + 4, AI_SEEN_STATE_FLOATS(GW * GH)), 0);
        for (int k = 0; k < NROBOTS; k++) {
            const float *nb[NROBOTS - 1];
            for (int j = 0, m = 0; j < NROBOTS; j++)
                if (j != k)
                    nb[m++] = st[j];
            uint32_t used = 0;
            assert_int_equal(ai_seen_mix(&r[k], nb, NROBOTS - 1, 4, sizeof st[0] / sizeof(float), 1.0 / NROBOTS,
                                         &used), 0);
            assert_int_equal(used, NROBOTS - 1);
        }
        for (uint32_t i = 0; i < GW * GH; i++)
            for (int k = 0; k < NROBOTS; k++)
                assert_true(fabs(r[k].n[i] - truth[i]) < 1e-5 && fabs(r[k].hits[i] - truth_hits[i]) < 1e-5);
    }
}

static void test_refusals(void **state)
{
    (void)state;
    ai_belief_cfg_t c = geometry();
    assert_int_equal(ai_seen_init(NULL, &c), -EINVAL);
    assert_int_equal(ai_seen_init(&s, NULL), -EINVAL);
    ai_belief_cfg_t bad = c;
    bad.w = AI_BELIEF_MAX_W + 1u;
    assert_int_equal(ai_seen_init(&s, &bad), -EINVAL);
    bad = c;
    bad.res_m = NAN;
    assert_int_equal(ai_seen_init(&s, &bad), -EINVAL);
    assert_int_equal(ai_seen_init(&s, &c), 0);
    const ai_sample_t a = at(3.0, 3.0, 0.0f);
    assert_int_equal(ai_seen_add(&s, &a, 1, -1.0), -EINVAL);
    assert_int_equal(ai_seen_add(&s, &a, 1, INFINITY), -EINVAL);
    assert_int_equal(ai_seen_add(&s, NULL, 1, 1.0), -EINVAL);
    assert_int_equal(ai_seen_scale(&s, NAN), -EINVAL);
    assert_int_equal(ai_seen_flood(NULL), -EINVAL);
    assert_int_equal(ai_seen_add(&s, &a, 1, 1.0), 0);
    const size_t cap = AI_SEEN_STATE_FLOATS(GW * GH);
    assert_int_equal(ai_seen_to_state(&s, st[0], cap - 1u), -ENOSPC);
    /* neighbours' grids: another size, a negative count, a NaN, more hits than samples: all
       left out, ours kept */
    float extra[AI_SEEN_STATE_FLOATS(GW * GH)];
    for (int k = 0; k < NROBOTS; k++)
        assert_int_equal(ai_seen_to_state(&s, st[k], cap), 0);
    assert_int_equal(ai_seen_to_state(&s, extra, cap), 0);
    st[0][0] = (float)(GW - 1u);
    st[1][2 + 5] = -1.0f;
    st[2][2 + 7] = NAN;
    extra[2 + GW * GH + 3] = extra[2 + 3] + 1.0f;
    const float *nb[NROBOTS + 1] = {st[0], st[1], st[2], extra};
    const ai_seen_t before = s;
    uint32_t used = 9;
    assert_int_equal(ai_seen_mix(&s, nb, NROBOTS + 1, 0, cap, 0.2, &used), 0);
    assert_int_equal(used, 0);
    assert_memory_equal(s.n, before.n, sizeof s.n);
    assert_memory_equal(s.hits, before.hits, sizeof s.hits);
    assert_int_equal(ai_seen_mix(&s, nb, NROBOTS, 0, cap, 0.5, &used), -EINVAL); /* n w > 1 */
    assert_int_equal(ai_seen_mix(&s, nb, NROBOTS, cap + 1u, cap, 0.25, &used), -EINVAL);
    assert_int_equal(ai_seen_mix(&s, NULL, 1, 0, cap, 0.25, &used), -EINVAL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_samples_land_in_their_cell),
        cmocka_unit_test(test_beyond_an_open_cell_not_behind_a_wall),
        cmocka_unit_test(test_consensus_keeps_the_fleets_count),
        cmocka_unit_test(test_refusals),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
