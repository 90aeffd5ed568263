/* Learning test: a synthetic room outline (label 1 within a thin band around a rectangle's
 * boundary, 0 elsewhere), sampled only on the left part of the square (x <= 0.1).
 *
 * 1. Learning (paper settings, w0 = 30, kl_weight 1e-4): the `small`-sized network (or the
 *    preset's own, if smaller) reaches a mean-weight BCE < 0.15 on the training points and on
 *    held-out points of the same region.
 * 2. Uncertainty: for EACH of UNC_SEEDS seeds, the mean MC standard deviation (K = 50) of the
 *    predicted probability far from the data (x >= 0.7) is more than twice the one on held-out
 *    points of the training region. Set-up: kl_weight 5e-3 (the paper's middle value), SIREN
 *    w0 = 3 instead of 30.
 * 3. Two runs with the same seed give bit-identical parameters.
 *
 * Why w0 = 3 for the uncertainty check (measured with this data, 1500 steps, batch 512, Eigen
 * GEMM; ratio = far/near mean MC std of the probability; "logit" = the same ratio for the std
 * of the logits; with the AVX2 GEMM kernel seeds 1-5 give 3.07 2.75 4.11 2.65 3.45):
 *   w0 = 30, kl 1e-4 (seeds 1-6):  ratio 0.88 1.50 1.38 2.04 7.15 5.57   logit 0.79-0.91
 *   w0 = 30, kl 5e-3 (seeds 1-6):  ratio 0.55 0.55 3.09 2.65 6.21 3.28   logit 0.78-0.88
 *   w0 = 30, kl 5e-1 (5 seeds):    ratio 0.66-1.49 ("noise everywhere", BCE ~0.1)
 *   w0 = 3,  kl 5e-3 (seeds 1-10): ratio 3.22 2.77 3.93 2.59 3.47 2.71 3.79 3.47 3.50 3.30
 *                                  logit 0.86-1.02
 *   w0 = 3,  kl 1e-4 (seeds 1-4):  ratio 3.88 2.71 4.60 3.07;  kl 5e-1: 3.89-4.31 (but the std
 *                                  on the data is 3x higher: "noise everywhere")
 *   w0 = 1,  kl 5e-3 (seeds 1-6):  ratio 1.87-3.06, logit 1.23-1.63
 * At w0 = 30 the SIREN features sin(30 (w.x + b)) are periodic over the whole square, so every
 * weight acts everywhere and the data constrain all of them alike: the logit spread is NOT
 * higher far away (0.8-0.9x for every seed). What contrast there is in probability space comes
 * from the mean prediction being less saturated where the network happens to hallucinate
 * structure, which depends on the seed. With smooth features (w0 = 3) the network extrapolates
 * smoothly and less confidently off the data (mean |p - 0.5| 0.45-0.46 far vs 0.48-0.49 near)
 * for every seed tried, so the probability spread is 2.6-3.9x higher there; the logit spread
 * is still about the same (0.86-1.02x). Only at w0 = 1 is the logit spread itself higher far. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "ai/ai_rng.h"
#include "ai/bnn.h"

#ifdef __SANITIZE_ADDRESS__
#define STEPS 700
#define N_TRAIN 2048
#define BATCH 256
#else
#define STEPS 1500
#define N_TRAIN 8192
#define BATCH 512
#endif
#define N_FAR 512
#define UNC_W0 3.0f
#define UNC_KL 5e-3f
#ifdef __SANITIZE_ADDRESS__
#define UNC_SEEDS 3 /* keeps the ASan run under 2 minutes; seeds 1-3 there: 3.02x 2.20x 4.31x */
#else
#define UNC_SEEDS 5
#endif

static bnn_model_t model;
static ai_sample_t train[N_TRAIN], held[N_TRAIN / 4];
static ai_sample_t batch[BATCH];

/* Rectangle [-0.6, 0.6] x [-0.5, 0.5]; band half-width 0.06. */
static float room_label(float x, float y)
{
    const float ax = fabsf(x), ay = fabsf(y), hx = 0.6f, hy = 0.5f, band = 0.06f;
    float d;
    if (ax <= hx && ay <= hy)
        d = fminf(hx - ax, hy - ay);
    else {
        float dx = fmaxf(ax - hx, 0.0f), dy = fmaxf(ay - hy, 0.0f);
        d = sqrtf(dx * dx + dy * dy);
    }
    return d <= band ? 1.0f : 0.0f;
}

static void sample_region(ai_sample_t *out, size_t n, uint64_t stream, float xmin, float xmax)
{
    static float u[2 * N_TRAIN];
    ai_rng_uniform_fill(2024, stream, 0, u, 2 * n);
    for (size_t i = 0; i < n; i++) {
        out[i].x = xmin + (xmax - xmin) * u[2 * i];
        out[i].y = -1.0f + 2.0f * u[2 * i + 1];
        out[i].occ = room_label(out[i].x, out[i].y);
    }
}

static bnn_config_t learn_config(float w0)
{
    bnn_config_t c = bnn_default_config();
    c.w0 = w0;
    c.siren_width = c.siren_width < 128 ? c.siren_width : 128;
    c.hidden_width = c.hidden_width < 64 ? c.hidden_width : 64;
    c.n_bayes = c.n_bayes < 3 ? c.n_bayes : 3;
    c.max_batch = c.max_batch < BATCH ? c.max_batch : BATCH;
    return c;
}

static void train_model(uint64_t seed, float w0, float kl_weight, bnn_loss_t *last)
{
    bnn_config_t c = learn_config(w0);
    assert_int_equal(bnn_init(&model, &c, seed), 0);
    const size_t nb = c.max_batch;
    /* a preset with a smaller batch (mcu) sees as many points in total */
    const int steps = STEPS * (int)(BATCH / nb > 4 ? 4 : BATCH / nb);
    float u[BATCH];
    for (int s = 0; s < steps; s++) {
        ai_rng_uniform_fill(seed, 1000 + (uint64_t)s, 0, u, nb);
        for (size_t i = 0; i < nb; i++)
            batch[i] = train[(size_t)(u[i] * N_TRAIN) % N_TRAIN];
        float lr = s < steps * 2 / 3 ? 3e-3f : 1e-3f;
        assert_int_equal(bnn_train_step(&model, batch, nb, kl_weight, (uint64_t)s, lr, last), 0);
    }
}

static void test_learns_room(void **state)
{
    (void)state;
    sample_region(train, N_TRAIN, 1, -1.0f, 0.1f);
    sample_region(held, N_TRAIN / 4, 2, -1.0f, 0.1f);
    size_t ones = 0;
    for (size_t i = 0; i < N_TRAIN; i++)
        ones += train[i].occ > 0.5f;
    print_message("training points: %d (%zu occupied), steps %d, batch %d\n", N_TRAIN, ones,
                  STEPS, BATCH);
    bnn_loss_t last;
    train_model(77, BNN_W0, 1e-4f, &last);
    float bce_train, bce_held, bce_mc;
    assert_int_equal(bnn_eval_bce(&model, train, N_TRAIN, 0, 0, &bce_train), 0);
    assert_int_equal(bnn_eval_bce(&model, held, N_TRAIN / 4, 0, 0, &bce_held), 0);
    assert_int_equal(bnn_eval_bce(&model, held, N_TRAIN / 4, 10, 5, &bce_mc), 0);
    print_message("last step: bce %.4f kl %.3f; mean-weight BCE train %.4f held-out %.4f; "
                  "MC-mean(K=10) BCE held-out %.4f\n",
                  last.bce, last.kl, bce_train, bce_held, bce_mc);
    assert_true(bce_train < 0.15f);
    assert_true(bce_held < 0.15f);
}

/* mean over the points of the MC std (K = 50) of the predicted probability */
static double mean_mc_std(const ai_sample_t *pts, size_t n)
{
    static float xy[2 * N_FAR], mean[N_FAR], sd[N_FAR];
    assert_true(n <= N_FAR);
    for (size_t i = 0; i < n; i++) {
        xy[2 * i] = pts[i].x;
        xy[2 * i + 1] = pts[i].y;
    }
    assert_int_equal(bnn_predict_mc(&model, xy, n, BNN_MC_DEFAULT_K, 9, mean, sd), 0);
    double s = 0.0;
    for (size_t i = 0; i < n; i++)
        s += sd[i];
    return s / (double)n;
}

static void test_uncertainty_far_from_data(void **state)
{
    (void)state;
    static ai_sample_t near[N_FAR], far[N_FAR];
    sample_region(train, N_TRAIN, 1, -1.0f, 0.1f);
    sample_region(near, N_FAR, 2, -1.0f, 0.1f); /* held out, same region as the data */
    sample_region(far, N_FAR, 3, 0.7f, 1.0f);
    double min_ratio = 1e30;
    for (uint64_t seed = 1; seed <= UNC_SEEDS; seed++) {
        bnn_loss_t last;
        train_model(seed, UNC_W0, UNC_KL, &last);
        float bce_held;
        assert_int_equal(bnn_eval_bce(&model, near, N_FAR, 0, 0, &bce_held), 0);
        const double s_near = mean_mc_std(near, N_FAR), s_far = mean_mc_std(far, N_FAR);
        const double r = s_far / s_near;
        print_message("seed %d: held-out BCE %.4f, MC std (K=50) near %.4f far (x >= 0.7) %.4f, "
                      "ratio %.2f\n",
                      (int)seed, bce_held, s_near, s_far, r);
        assert_true(bce_held < 0.15f);
        min_ratio = r < min_ratio ? r : min_ratio;
    }
    print_message("minimum far/near ratio over %d seeds: %.2f (asserted > 2)\n", UNC_SEEDS,
                  min_ratio);
    assert_true(min_ratio > 2.0);
}

static void test_same_seed_same_model(void **state)
{
    (void)state;
    static float first[BNN_N_PARAMS];
    sample_region(train, N_TRAIN, 1, -1.0f, 0.1f);
    bnn_config_t c = learn_config(BNN_W0);
    c.max_batch = c.max_batch < 64 ? c.max_batch : 64;
    for (int run = 0; run < 2; run++) {
        assert_int_equal(bnn_init(&model, &c, 5), 0);
        for (int s = 0; s < 20; s++)
            assert_int_equal(
                bnn_train_step(&model, train + 64 * s, c.max_batch, 1e-3f, (uint64_t)s, 1e-3f, NULL),
                0);
        if (run == 0)
            memcpy(first, bnn_params(&model), bnn_n_params(&model) * sizeof(float));
        else
            assert_memory_equal(first, bnn_params(&model), bnn_n_params(&model) * sizeof(float));
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_learns_room),
        cmocka_unit_test(test_uncertainty_far_from_data),
        cmocka_unit_test(test_same_seed_same_model),
    };
    return cmocka_run_group_tests_name("ai/bnn_learn", tests, NULL, NULL);
}
