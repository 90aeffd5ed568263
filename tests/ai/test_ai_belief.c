/* The AI core's coarse belief grid (ai/ai_belief.h): a fresh posterior knows nothing anywhere;
 * data in one corner lowers known there and not far away; occ is the mean weights' forward
 * pass at each cell centre; the same inputs give the same bytes; the copies into the GP and RT
 * grids; a count grid keeps the cells no ray reached unknown, beside the posterior's own layer;
 * every refusal; and no allocation during an update. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "ai/ai_belief.h"
#include "ai/ai_seen.h"
#include "ai/ai_rng.h"

#define NOBS 2000
#define GW 30u /* 900 cells: neither a multiple of the batch nor of the model's max_batch */
#define GH 30u

static bnn_model_t model, other;
static bnn_post_t post, post_other;
static ai_belief_t bel, bel2;
static ai_seen_t seen;
static gp_goal_grid_t ggrid;
static rt_grid_t rgrid;
static float obs[2 * NOBS];

/* The plan's box is [0, 7.5] m square, the grid covers it at 0.25 m. */
static ai_belief_cfg_t geometry(void)
{
    ai_belief_cfg_t c = {.w = GW, .h = GH, .res_m = 0.25f, .origin_x_m = 0.0f, .origin_y_m = 0.0f,
                         .min_x = 0.0f, .min_y = 0.0f, .max_x = 7.5f, .max_y = 7.5f};
    return c;
}

static void setup_model(bnn_model_t *m, uint32_t siren)
{
    bnn_config_t c = bnn_default_config();
    c.siren_width = siren;
    c.hidden_width = c.hidden_width < 16 ? c.hidden_width : 16;
    c.n_bayes = 2;
    c.max_batch = 64; /* a belief batch spans several of the model's chunks */
    assert_int_equal(bnn_init(m, &c, 7), 0);
}

/* Points uniform in the corner [0, 2] m square of the plan, normalised. */
static void corner_points(void)
{
    ai_rng_uniform_fill(13, 1, 0, obs, 2 * NOBS);
    for (int i = 0; i < 2 * NOBS; i++)
        obs[i] = 2.0f * (2.0f * obs[i] / 7.5f) - 1.0f;
}

static double mean_known(const ai_belief_t *b, uint32_t c0, uint32_t c1, uint32_t r0, uint32_t r1)
{
    double s = 0.0;
    for (uint32_t r = r0; r < r1; r++)
        for (uint32_t c = c0; c < c1; c++)
            s += b->unknown[r * b->cfg.w + c];
    return s / (double)((c1 - c0) * (r1 - r0));
}

static void test_fresh_posterior_knows_nothing(void **state)
{
    (void)state;
    setup_model(&model, BNN_SIREN_MAX);
    assert_int_equal(bnn_post_init(&post, &model), 0);
    const ai_belief_cfg_t c = geometry();
    assert_int_equal(ai_belief_init(&bel, &c), 0);
    assert_true(ai_belief_known_share(&bel) == 1.0);
    assert_int_equal(ai_belief_update(&bel, &model, &post, NULL), 0);
    assert_int_equal(bel.updates, 1);
    for (uint32_t i = 0; i < GW * GH; i++)
        assert_true(bel.unknown[i] >= 254);
    assert_true(ai_belief_known_share(&bel) > 0.995 && ai_belief_known_share(&bel) <= 1.0);
}

static void test_observed_corner_is_known_far_cells_are_not(void **state)
{
    (void)state;
    setup_model(&model, BNN_SIREN_MAX);
    assert_int_equal(bnn_post_init(&post, &model), 0);
    corner_points();
    assert_int_equal(bnn_post_observe(&post, &model, obs, NOBS), 0);
    const ai_belief_cfg_t c = geometry();
    assert_int_equal(ai_belief_init(&bel, &c), 0);
    assert_int_equal(ai_belief_update(&bel, &model, &post, NULL), 0);
    /* cells 0..7 lie inside the observed [0, 2] m square; 22..29 are 3.5 m and more away */
    const double near = mean_known(&bel, 0, 8, 0, 8), far = mean_known(&bel, 22, GW, 22, GH);
    const double share = ai_belief_known_share(&bel);
    print_message("known: observed corner %.1f, far corner %.1f; mean unknown share %.4f\n", near, far, share);
    assert_true(near < 0.25 * far);
    assert_true(far > 150.0);
    assert_true(share < 0.99 && share > 0.5);
    /* distance aware: every cell of the far corner is less known than the observed corner's mean */
    for (uint32_t r = 22; r < GH; r++)
        for (uint32_t col = 22; col < GW; col++)
            assert_true(bel.unknown[r * GW + col] > near);
}

static void test_occ_is_the_mean_forward_pass(void **state)
{
    (void)state;
    setup_model(&model, BNN_SIREN_MAX);
    assert_int_equal(bnn_post_init(&post, &model), 0);
    /* train a little on the corner (occupied where x < 1 m) so the map is not flat */
    corner_points();
    static ai_sample_t s[64];
    for (int it = 0; it < 30; it++) {
        for (int k = 0; k < 64; k++) {
            const int j = (it * 64 + k) % NOBS;
            s[k].x = obs[2 * j];
            s[k].y = obs[2 * j + 1];
            s[k].occ = s[k].x < 2.0f * (1.0f / 7.5f) - 1.0f ? 1.0f : 0.0f;
        }
        assert_int_equal(bnn_train_step(&model, s, 64, 1e-3f, (uint64_t)it, 1e-2f, NULL), 0);
    }
    assert_int_equal(bnn_post_observe(&post, &model, obs, NOBS), 0);
    const ai_belief_cfg_t c = geometry();
    assert_int_equal(ai_belief_init(&bel, &c), 0);
    assert_int_equal(ai_belief_update(&bel, &model, &post, NULL), 0);
    float xy[2 * GW], logit[GW];
    int lo = 255, hi = 0;
    for (uint32_t r = 0; r < GH; r++) {
        for (uint32_t col = 0; col < GW; col++)
            assert_int_equal(ai_belief_cell_xy(&bel, col, r, xy + 2 * col), 0);
        assert_int_equal(bnn_forward_logits(&model, xy, GW, 1, 0, logit), 0);
        for (uint32_t col = 0; col < GW; col++) {
            const double want = 255.0 / (1.0 + exp(-(double)logit[col]));
            const int got = bel.occ[r * GW + col];
            assert_true(fabs((double)got - want) <= 1.0);
            lo = got < lo ? got : lo;
            hi = got > hi ? got : hi;
        }
    }
    print_message("occ spans %d .. %d\n", lo, hi);
    assert_true(hi - lo >= 2); /* the comparison saw more than one value */
}

static void test_deterministic_and_copies(void **state)
{
    (void)state;
    setup_model(&model, BNN_SIREN_MAX);
    assert_int_equal(bnn_post_init(&post, &model), 0);
    corner_points();
    assert_int_equal(bnn_post_observe(&post, &model, obs, NOBS), 0);
    const ai_belief_cfg_t c = geometry();
    assert_int_equal(ai_belief_init(&bel, &c), 0);
    assert_int_equal(ai_belief_init(&bel2, &c), 0);
    assert_int_equal(ai_belief_update(&bel, &model, &post, NULL), 0);
    static uint8_t occ[AI_BELIEF_MAX_CELLS], known[AI_BELIEF_MAX_CELLS];
    memcpy(occ, bel.occ, sizeof occ);
    memcpy(known, bel.unknown, sizeof known);
    const double share = bel.unknown_mean;
    assert_int_equal(ai_belief_update(&bel, &model, &post, NULL), 0);
    assert_int_equal(ai_belief_update(&bel2, &model, &post, NULL), 0);
    assert_memory_equal(occ, bel.occ, sizeof occ);
    assert_memory_equal(known, bel.unknown, sizeof known);
    assert_memory_equal(occ, bel2.occ, sizeof occ);
    assert_memory_equal(known, bel2.unknown, sizeof known);
    assert_memory_equal(&share, &bel.unknown_mean, sizeof share);
    assert_int_equal(bel.updates, 2);

    /* the GP core's grid: the same bytes */
    gp_goal_cfg_t g;
    memset(&g, 0, sizeof g);
    g.w = GW, g.h = GH, g.res_m = 0.25, g.origin_x_m = 0.0, g.origin_y_m = 0.0;
    memset(&ggrid, 0xA5, sizeof ggrid);
    assert_int_equal(ai_belief_to_goal_grid(&bel, &g, &ggrid), 0);
    assert_memory_equal(ggrid.occ, bel.occ, GW * GH);
    assert_memory_equal(ggrid.unknown, bel.unknown, GW * GH);
    g.res_m = 0.26;
    assert_int_equal(ai_belief_to_goal_grid(&bel, &g, &ggrid), -EINVAL);
    g.res_m = 0.25, g.w = GW + 1;
    assert_int_equal(ai_belief_to_goal_grid(&bel, &g, &ggrid), -EINVAL);
    g.w = GW;
    assert_int_equal(ai_belief_to_goal_grid(NULL, &g, &ggrid), -EINVAL);
    assert_int_equal(ai_belief_to_goal_grid(&bel, NULL, &ggrid), -EINVAL);
    assert_int_equal(ai_belief_to_goal_grid(&bel, &g, NULL), -EINVAL);

    /* the RT core's grid: its geometry, occ as is, known inverted above the threshold */
    assert_int_equal(ai_belief_to_rt_grid(&bel, 128, &rgrid), 0);
    assert_int_equal(rgrid.w, (int32_t)GW);
    assert_int_equal(rgrid.h, (int32_t)GH);
    assert_true(rgrid.res == 0.25f && rgrid.origin_x == 0.0f && rgrid.origin_y == 0.0f);
    assert_memory_equal(rgrid.occ, bel.occ, GW * GH);
    uint32_t seen = 0;
    for (uint32_t i = 0; i < GW * GH; i++) {
        const uint8_t k = bel.unknown[i];
        assert_int_equal(rgrid.known[i], k > 128 ? 0 : 255 - k);
        seen += rgrid.known[i] != 0;
    }
    print_message("seen (known <= 128): %u of %u cells\n", (unsigned)seen, GW * GH);
    assert_true(seen >= 64 && seen < GW * GH); /* the observed corner, not the far one */
    for (uint32_t r = 0; r < 8; r++) /* every cell of the observed square counts as seen */
        for (uint32_t col = 0; col < 8; col++)
            assert_true(rgrid.known[r * GW + col] != 0);
    assert_int_equal(ai_belief_to_rt_grid(&bel, 255, &rgrid), 0);
    for (uint32_t i = 0; i < GW * GH; i++)
        assert_true(rgrid.known[i] >= 1);
    assert_int_equal(ai_belief_to_rt_grid(NULL, 230, &rgrid), -EINVAL);
    assert_int_equal(ai_belief_to_rt_grid(&bel, 230, NULL), -EINVAL);
}

static void test_refusals(void **state)
{
    (void)state;
    setup_model(&model, BNN_SIREN_MAX);
    setup_model(&other, BNN_SIREN_MAX / 2u);
    assert_int_equal(bnn_post_init(&post, &model), 0);
    assert_int_equal(bnn_post_init(&post_other, &other), 0);
    const ai_belief_cfg_t good = geometry();
    ai_belief_cfg_t c;
    assert_int_equal(ai_belief_init(NULL, &good), -EINVAL);
    assert_int_equal(ai_belief_init(&bel, NULL), -EINVAL);
    memset(&bel, 0, sizeof bel);
    const float bad_res[] = {0.0f, -0.25f, NAN, INFINITY, 1e38f};
    for (size_t i = 0; i < sizeof bad_res / sizeof bad_res[0]; i++) {
        c = good, c.res_m = bad_res[i];
        assert_int_equal(ai_belief_init(&bel, &c), -EINVAL);
    }
    const uint32_t bad_side[] = {0u, AI_BELIEF_MAX_W + 1u, 1000000u};
    for (size_t i = 0; i < sizeof bad_side / sizeof bad_side[0]; i++) {
        c = good, c.w = bad_side[i];
        assert_int_equal(ai_belief_init(&bel, &c), -EINVAL);
        c = good, c.h = bad_side[i];
        assert_int_equal(ai_belief_init(&bel, &c), -EINVAL);
    }
    c = good, c.origin_x_m = NAN;
    assert_int_equal(ai_belief_init(&bel, &c), -EINVAL);
    c = good, c.origin_y_m = -INFINITY;
    assert_int_equal(ai_belief_init(&bel, &c), -EINVAL);
    c = good, c.max_x = c.min_x;
    assert_int_equal(ai_belief_init(&bel, &c), -EINVAL);
    c = good, c.min_y = 8.0f;
    assert_int_equal(ai_belief_init(&bel, &c), -EINVAL);
    c = good, c.max_y = NAN;
    assert_int_equal(ai_belief_init(&bel, &c), -EINVAL);
    /* a refused init leaves the belief untouched (all zero here) */
    assert_int_equal(bel.cfg.w, 0);
    /* update: a belief never initialised, NULLs, a posterior of another dimension */
    assert_int_equal(ai_belief_update(&bel, &model, &post, NULL), -EINVAL);
    assert_true(ai_belief_known_share(&bel) == 1.0);
    assert_int_equal(ai_belief_init(&bel, &good), 0);
    assert_int_equal(ai_belief_update(NULL, &model, &post, NULL), -EINVAL);
    assert_int_equal(ai_belief_update(&bel, NULL, &post, NULL), -EINVAL);
    assert_int_equal(ai_belief_update(&bel, &model, NULL, NULL), -EINVAL);
    assert_int_equal(ai_belief_update(&bel, &model, &post_other, NULL), -EINVAL);
    assert_int_equal(bel.updates, 0);
    /* no copy before a valid update */
    gp_goal_cfg_t g;
    memset(&g, 0, sizeof g);
    g.w = GW, g.h = GH, g.res_m = 0.25;
    assert_int_equal(ai_belief_to_goal_grid(&bel, &g, &ggrid), -EINVAL);
    assert_int_equal(ai_belief_to_rt_grid(&bel, 230, &rgrid), -EINVAL);
    /* cell_xy: outside, NULL */
    float xy[2];
    assert_int_equal(ai_belief_cell_xy(&bel, GW, 0, xy), -EINVAL);
    assert_int_equal(ai_belief_cell_xy(&bel, 0, GH, xy), -EINVAL);
    assert_int_equal(ai_belief_cell_xy(&bel, 0, 0, NULL), -EINVAL);
    assert_int_equal(ai_belief_cell_xy(NULL, 0, 0, xy), -EINVAL);
    assert_int_equal(ai_belief_cell_xy(&bel, GW - 1, GH - 1, xy), 0);
    assert_true(fabsf(xy[0] - (2.0f * 7.375f / 7.5f - 1.0f)) < 1e-6f);
    assert_true(ai_belief_known_share(NULL) < 0.0);
}

/* The posterior's features are global: points spread over the box make it say it knows the
 * whole box, rays or not. With the counts, a cell no point fell in, beyond the free ones, is
 * unknown (255), and no cell is less unknown than the posterior alone says. */
static void test_count_grid_keeps_unreached_cells_unknown(void **state)
{
    (void)state;
    setup_model(&model, BNN_SIREN_MAX);
    assert_int_equal(bnn_post_init(&post, &model), 0);
    ai_rng_uniform_fill(17, 1, 0, obs, 2 * NOBS); /* uniform over the whole box, normalised */
    for (int i = 0; i < 2 * NOBS; i++)
        obs[i] = 2.0f * obs[i] - 1.0f;
    assert_int_equal(bnn_post_observe(&post, &model, obs, NOBS), 0);
    const ai_belief_cfg_t c = geometry();
    assert_int_equal(ai_belief_init(&bel, &c), 0);
    assert_int_equal(ai_belief_update(&bel, &model, &post, NULL), 0);
    /* the counts leave out the points in the far corner, x and y above 5.5 m */
    assert_int_equal(ai_seen_init(&seen, &c), 0);
    uint32_t kept = 0;
    for (int i = 0; i < NOBS; i++) {
        const float x = 3.75f * (obs[2 * i] + 1.0f), y = 3.75f * (obs[2 * i + 1] + 1.0f);
        if (x > 5.5f && y > 5.5f)
            continue;
        const ai_sample_t free_point = {obs[2 * i], obs[2 * i + 1], 0.0f};
        assert_int_equal(ai_seen_add(&seen, &free_point, 1, 1.0), 0);
        kept++;
    }
    assert_int_equal(ai_belief_init(&bel2, &c), 0);
    assert_int_equal(ai_belief_update(&bel2, &model, &post, &seen), 0);
    uint32_t unreached = 0, far_post = 0;
    for (uint32_t i = 0; i < GW * GH; i++) {
        assert_true(bel2.unknown[i] >= bel.unknown[i]);
        assert_int_equal(bel2.occ[i], bel.occ[i]);
        /* the posterior's layer is the posterior's alone, counts or not (and without counts
           the same as unknown) */
        assert_int_equal(bel2.post_unknown[i], bel.unknown[i]);
        assert_int_equal(bel.post_unknown[i], bel.unknown[i]);
        if (seen.n[i] == 0.0f) {
            assert_int_equal(bel2.unknown[i], 255);
            unreached++;
        }
    }
    for (uint32_t r = 24; r < GH; r++) /* inside the corner left out: 6 .. 7.5 m */
        for (uint32_t col = 24; col < GW; col++) {
            assert_int_equal(bel2.unknown[r * GW + col], 255);
            far_post += bel.unknown[r * GW + col];
        }
    print_message("%u of %u points counted; %u cells unreached; the posterior alone: %.1f of 255 in the corner "
                  "left out\n", kept, NOBS, unreached, far_post / 36.0);
    assert_true(far_post / 36.0 < 200.0); /* the posterior alone does think it knows the corner */
    assert_true(ai_belief_known_share(&bel2) > ai_belief_known_share(&bel));
    assert_true(bel2.post_unknown_mean == bel.unknown_mean && bel.post_unknown_mean == bel.unknown_mean);
    /* a count grid of another size is refused */
    ai_belief_cfg_t small = c;
    small.w = GW - 1u;
    assert_int_equal(ai_seen_init(&seen, &small), 0);
    assert_int_equal(ai_belief_update(&bel2, &model, &post, &seen), -EINVAL);
}

static void test_full_grid_no_allocation(void **state)
{
    (void)state;
    setup_model(&model, BNN_SIREN_MAX);
    assert_int_equal(bnn_post_init(&post, &model), 0);
    corner_points();
    assert_int_equal(bnn_post_observe(&post, &model, obs, NOBS), 0);
    ai_belief_cfg_t c = geometry();
    c.w = AI_BELIEF_MAX_W, c.h = AI_BELIEF_MAX_H, c.res_m = 7.5f / (float)AI_BELIEF_MAX_W;
    assert_int_equal(ai_belief_init(&bel, &c), 0);
    assert_int_equal(ai_belief_update(&bel, &model, &post, NULL), 0); /* factors the posterior */
    alloc_count_reset();
    assert_int_equal(ai_belief_update(&bel, &model, &post, NULL), 0);
    assert_int_equal(alloc_count_allocations(), 0);
    assert_true(bel.unknown[0] < bel.unknown[AI_BELIEF_MAX_CELLS - 1u]);
    print_message("ai_belief_t: %zu bytes\n", (size_t)AI_BELIEF_BYTES);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fresh_posterior_knows_nothing),
        cmocka_unit_test(test_observed_corner_is_known_far_cells_are_not),
        cmocka_unit_test(test_occ_is_the_mean_forward_pass),
        cmocka_unit_test(test_deterministic_and_copies),
        cmocka_unit_test(test_refusals),
        cmocka_unit_test(test_count_grid_keeps_unreached_cells_unknown),
        cmocka_unit_test(test_full_grid_no_allocation),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
