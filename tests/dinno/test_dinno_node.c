/* DiNNO node update on a tiny BNN: the dual update and the midpoint (L2) terms against
 * hand-computed values, the KL strategy's rho gradient against finite differences, uniform ==
 * separate at unit weights, the same models without the regulariser values, a node without
 * neighbours trains alone, no allocation. */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "ai/ai_rng.h"
#include "ai/bnn.h"
#include "ai/dinno.h"

static dinno_node_t node, other;

/* Neighbour views for the tests, one per node, filled as the GP core fills its view (entries
 * appended in call order; a new round or a fresh node starts it over). The states stay where
 * the test keeps them: the node reads them in place. */
static dinno_nbrs_t view_node, view_other, view_big;

static dinno_nbrs_t *view_of(const dinno_node_t *n)
{
    return n == &node ? &view_node : n == &other ? &view_other : &view_big;
}

static int nb_put(dinno_node_t *n, uint32_t peer, uint32_t round, const float *theta, size_t np)
{
    dinno_nbrs_t *v = view_of(n);
    if (np != bnn_n_params(&n->model))
        return -EINVAL;
    if (n->nb != v || v->round != round)
        v->count = 0;
    if (v->count >= DINNO_MAX_PEERS)
        return -EINVAL;
    v->round = round;
    v->id[v->count] = peer;
    v->theta[v->count++] = theta;
    return dinno_node_set_nbrs(n, v);
}

static void nb_clear(dinno_node_t *n)
{
    view_of(n)->count = 0;
    assert_int_equal(dinno_node_set_nbrs(n, NULL), 0);
}
static ai_sample_t data[256];

/* S = 3, H = 2, L = 1: mu-group 3*2+3 + (3*2+2) + 2+1 = 20, rho-group 8. */
static bnn_config_t tiny(void)
{
    bnn_config_t c = bnn_default_config();
    c.siren_width = 3;
    c.hidden_width = 2;
    c.n_bayes = 1;
    c.max_batch = 16;
    return c;
}

static void make_data(void)
{
    float u[3 * 256];
    ai_rng_uniform_fill(11, 3, 0, u, 3 * 256);
    for (int i = 0; i < 256; i++) {
        data[i].x = 2 * u[3 * i] - 1;
        data[i].y = 2 * u[3 * i + 1] - 1;
        data[i].occ = (data[i].x * data[i].x + data[i].y * data[i].y) < 0.3f ? 1.0f : 0.0f;
    }
}

static dinno_cfg_t cfg_of(dinno_strategy_t s)
{
    dinno_cfg_t c = dinno_default_cfg();
    c.strategy = s;
    c.batch = 16;
    c.total_rounds = 10;
    return c;
}

static void test_sizes_and_layout(void **st)
{
    (void)st;
    bnn_config_t b = tiny();
    dinno_cfg_t c = cfg_of(DINNO_KL);
    assert_int_equal(dinno_node_init(&node, &c, &b, 1, 2, 0), 0);
    assert_int_equal(bnn_n_params(&node.model), 28);
    assert_int_equal(node.model.n_mu, 20);
    assert_int_equal(node.model.n_rho, 8);
    /* The model and its per-parameter vectors (duals, theta0, aux1, the KL sums, the public copy
       and our state as sent), one dual and one public copy per link slot, but no copy of any
       neighbour's state of the round: the node reads those in place. */
    const size_t vec = BNN_N_PARAMS * sizeof(float);
    assert_true(dinno_get_buffer_size() >= sizeof(bnn_model_t) + (5u + 2u * DINNO_MAX_PEERS) * vec);
    assert_true(dinno_get_buffer_size() < sizeof(bnn_model_t) + (6u + 2u * DINNO_MAX_PEERS) * vec +
                                              sizeof(ai_sample_t) * BNN_MAX_BATCH + 4u * BNN_MAX_BATCH + 8192u);
    /* bad configs */
    c.batch = 17;
    assert_int_equal(dinno_node_init(&node, &c, &b, 1, 2, 0), -EINVAL);
    c = cfg_of(DINNO_KL);
    c.rho0 = 0;
    assert_int_equal(dinno_node_init(&node, &c, &b, 1, 2, 0), -EINVAL);
    c = cfg_of(DINNO_KL);
    c.w_rho = -1;
    assert_int_equal(dinno_node_init(&node, &c, &b, 1, 2, 0), -EINVAL);
    c = cfg_of((dinno_strategy_t)7);
    assert_int_equal(dinno_node_init(&node, &c, &b, 1, 2, 0), -EINVAL);
    dinno_strategy_t s;
    assert_int_equal(dinno_strategy_parse("kl", &s), 0);
    assert_int_equal(s, DINNO_KL);
    assert_int_equal(dinno_strategy_parse("KL", &s), -EINVAL);
}

static void test_schedules(void **st)
{
    (void)st;
    dinno_cfg_t c = dinno_default_cfg();
    c.total_rounds = 101;
    assert_float_equal(dinno_rho_at(&c, 0), 0.3f, 1e-7);
    assert_float_equal(dinno_rho_at(&c, 1000), (double)0.3f * pow((double)1.0004f, 1000), 1e-5);
    assert_float_equal(dinno_lr_at(&c, 0), 1e-3f, 1e-9);
    assert_float_equal(dinno_lr_at(&c, 50), sqrt(1e-3 * 1e-4), 1e-8); /* log-midpoint */
    assert_float_equal(dinno_lr_at(&c, 100), 1e-4f, 1e-9);
    assert_float_equal(dinno_lr_at(&c, 5000), 1e-4f, 1e-9);
}

/* theta = 0.1 * (i + 1) (i < 20) and -3 + 0.05 i on the rho group; neighbours a, b. */
static void set_known(dinno_node_t *n, float *ta, float *tb)
{
    float *th = bnn_params(&n->model);
    for (int i = 0; i < 28; i++) {
        th[i] = i < 20 ? 0.1f * (float)(i + 1) : -3.0f + 0.05f * (float)(i - 20);
        ta[i] = i < 20 ? 0.5f - 0.02f * (float)i : -2.5f - 0.1f * (float)(i - 20);
        tb[i] = i < 20 ? -0.3f + 0.01f * (float)i : -3.5f + 0.02f * (float)(i - 20);
    }
}

static void test_dual_and_l2_midpoints_by_hand(void **st)
{
    (void)st;
    bnn_config_t b = tiny();
    dinno_cfg_t c = cfg_of(DINNO_SEPARATE);
    c.w_mu = 2.0f;
    c.w_rho = 0.5f;
    assert_int_equal(dinno_node_init(&node, &c, &b, 1, 2, 0), 0);
    float ta[28], tb[28], th0[28];
    set_known(&node, ta, tb);
    memcpy(th0, bnn_params(&node.model), sizeof th0);
    for (int i = 0; i < 28; i++)
        node.dual[i] = 0.01f * (float)i; /* a previous dual */
    assert_int_equal(nb_put(&node, 3, 0, ta, 28), 0);
    assert_int_equal(nb_put(&node, 9, 0, tb, 28), 0);
    dinno_nbrs_t bad = view_node;
    bad.count = DINNO_MAX_PEERS + 1u;
    assert_int_equal(dinno_node_set_nbrs(&node, &bad), -EINVAL); /* refused, the view kept */
    bad.count = 2;
    bad.theta[1] = NULL;
    assert_int_equal(dinno_node_set_nbrs(&node, &bad), -EINVAL);
    const float rho = 0.4f;
    assert_int_equal(dinno_dual_update(&node, rho), 2);
    for (int i = 0; i < 28; i++) {
        const double want = 0.01 * i + 0.4 * ((th0[i] - ta[i]) + (th0[i] - tb[i]));
        assert_float_equal(node.dual[i], want, 1e-6);
    }
    /* element 0 by hand: theta0 = 0.1, a = 0.5, b = -0.3: dual = 0 + 0.4*(-0.4 + 0.4) = 0;
       element 5: theta0 = 0.6, a = 0.4, b = -0.25: dual = 0.05 + 0.4*(0.2 + 0.85) = 0.47 */
    assert_float_equal(node.dual[0], 0.0, 1e-6);
    assert_float_equal(node.dual[5], 0.47, 1e-6);
    dinno_prepare(&node);
    /* Move theta away from theta0 (as during the primal steps), then check the gradient. */
    float *th = bnn_params(&node.model);
    for (int i = 0; i < 28; i++)
        th[i] += 0.03f * (float)((i % 5) - 2);
    memset(bnn_grads(&node.model), 0, 28 * sizeof(float));
    float reg_mu, reg_rho, dd;
    dinno_add_reg_grad(&node, rho, &reg_mu, &reg_rho, &dd);
    double want_mu = 0, want_rho = 0, want_dd = 0;
    for (int i = 0; i < 28; i++) {
        const double ma = 0.5 * (th0[i] + ta[i]), mb = 0.5 * (th0[i] + tb[i]);
        const double w = i < 20 ? 2.0 : 0.5;
        const double g = node.dual[i] + 2.0 * rho * w * ((th[i] - ma) + (th[i] - mb));
        assert_float_equal(bnn_grads(&node.model)[i], g, 1e-5);
        const double r = (th[i] - ma) * (th[i] - ma) + (th[i] - mb) * (th[i] - mb);
        if (i < 20)
            want_mu += r;
        else
            want_rho += r;
        want_dd += (double)th[i] * node.dual[i];
    }
    assert_float_equal(reg_mu, want_mu, 1e-4 * (1 + want_mu));
    assert_float_equal(reg_rho, want_rho, 1e-4 * (1 + want_rho));
    assert_float_equal(dd, want_dd, 1e-4 * (1 + fabs(want_dd)));
    /* element 0 by hand: theta = 0.1 - 0.06 = 0.04, midpoints 0.3 and -0.1, dual 0:
       g = 2 * 0.4 * 2 * ((0.04 - 0.3) + (0.04 + 0.1)) = 1.6 * (-0.12) = -0.192 */
    assert_float_equal(bnn_grads(&node.model)[0], -0.192, 1e-5);
    /* the value used for finite differences agrees */
    const double v = dinno_reg_value(&node, rho);
    assert_float_equal(v, want_dd + rho * (2.0 * want_mu + 0.5 * want_rho), 1e-4);
}

/* The KL term of one element by hand, in double: own sigma s, midpoint sigma r, the paired
 * own mean mu and midpoint mean mj. */
static double kl_by_hand(dinno_kl_form_t form, double s, double r, double mu, double mj)
{
    switch (form) {
    case DINNO_KL_OWN_MEAN:
        return log(r / s) + s * s / (2 * r * r) - 0.5;
    case DINNO_KL_REVERSE:
        return log(s / r) + r * r / (2 * s * s) - 0.5;
    case DINNO_KL_FULL:
        return log(s / r) + (r * r + (mj - mu) * (mj - mu)) / (2 * s * s) - 0.5;
    }
    return NAN;
}

/* One KL reading: its value against the closed form by hand, its gradient against finite
 * differences of dinno_reg_value (FULL: the rho group only; its means keep the L2 gradient),
 * and zero at agreement. */
static void check_kl_reading(dinno_kl_form_t form, dinno_kl_reduce_t reduce)
{
    bnn_config_t b = tiny();
    dinno_cfg_t c = cfg_of(DINNO_KL);
    c.w_mu = 1.5f;
    c.w_rho = 0.7f;
    c.kl_form = form;
    c.kl_reduce = reduce;
    assert_int_equal(dinno_node_init(&node, &c, &b, 1, 2, 0), 0);
    float ta[28], tb[28];
    set_known(&node, ta, tb);
    assert_int_equal(nb_put(&node, 0, 0, ta, 28), 0);
    assert_int_equal(nb_put(&node, 15, 0, tb, 28), 0);
    const float rho = 0.3f;
    assert_int_equal(dinno_dual_update(&node, rho), 2);
    dinno_prepare(&node);
    float *th = bnn_params(&node.model);
    for (int i = 0; i < 28; i++) /* off the midpoints, both signs of rho - rho_reg */
        th[i] += 0.2f * (float)((i % 7) - 3) / 3.0f;
    memset(bnn_grads(&node.model), 0, 28 * sizeof(float));
    float reg_mu, reg_rho;
    dinno_add_reg_grad(&node, rho, &reg_mu, &reg_rho, NULL);
    double kl = 0; /* rho e (index 20 + e) pairs with the mean at 9 + e (S = 3) */
    assert_int_equal(bnn_rho_to_mu(&node.model, 0), 9);
    for (int e = 0; e < 8; e++) {
        const double s = log1p(exp((double)th[20 + e]));
        for (int j = 0; j < 2; j++) {
            const float *tj = j ? tb : ta;
            const double r = log1p(exp(0.5 * ((double)node.theta0[20 + e] + tj[20 + e])));
            const double mj = 0.5 * ((double)node.theta0[9 + e] + tj[9 + e]);
            kl += kl_by_hand(form, s, r, th[9 + e], mj);
        }
    }
    if (reduce == DINNO_REDUCE_MEAN)
        kl /= 8.0;
    assert_float_equal(reg_rho, kl, 1e-4 * (1 + kl));
    assert_true(kl > 0);
    static float g_own_mu[20];
    if (form == DINNO_KL_OWN_MEAN)
        memcpy(g_own_mu, bnn_grads(&node.model), sizeof g_own_mu);
    for (int i = 0; i < 28; i++) {
        if (form == DINNO_KL_FULL && i < 20) {
            assert_float_equal(bnn_grads(&node.model)[i], g_own_mu[i], 1e-6);
            continue;
        }
        const float keep = th[i];
        const float h = 1e-3f;
        th[i] = keep + h;
        const double up = dinno_reg_value(&node, rho);
        th[i] = keep - h;
        const double dn = dinno_reg_value(&node, rho);
        th[i] = keep;
        const double fd = (up - dn) / (2.0 * ((double)(keep + h) - (double)keep));
        const double an = bnn_grads(&node.model)[i];
        assert_float_equal(an, fd, 2e-3 * (1 + fabs(fd)));
    }
    /* At agreement (theta = every midpoint) the KL term and its gradient vanish. */
    assert_int_equal(dinno_node_init(&node, &c, &b, 1, 2, 0), 0);
    const float *t0 = bnn_params(&node.model);
    assert_int_equal(nb_put(&node, 0, 0, t0, 28), 0);
    (void)dinno_dual_update(&node, rho);
    dinno_prepare(&node);
    memset(bnn_grads(&node.model), 0, 28 * sizeof(float));
    dinno_add_reg_grad(&node, rho, &reg_mu, &reg_rho, NULL);
    assert_float_equal(reg_rho, 0.0, 1e-5);
    for (int i = 20; i < 28; i++)
        assert_float_equal(bnn_grads(&node.model)[i], 0.0, 1e-5);
}

static void test_kl_rho_gradient_finite_differences(void **st)
{
    (void)st;
    for (int r = DINNO_REDUCE_SUM; r <= DINNO_REDUCE_MEAN; r++)
        for (int f = DINNO_KL_OWN_MEAN; f <= DINNO_KL_FULL; f++)
            check_kl_reading((dinno_kl_form_t)f, (dinno_kl_reduce_t)r);
    dinno_kl_form_t f;
    dinno_kl_reduce_t red;
    assert_int_equal(dinno_kl_form_parse("full", &f), 0);
    assert_int_equal(f, DINNO_KL_FULL);
    assert_string_equal(dinno_kl_form_name(DINNO_KL_REVERSE), "reverse");
    assert_int_equal(dinno_kl_form_parse("forward", &f), -EINVAL);
    assert_int_equal(dinno_kl_reduce_parse("mean", &red), 0);
    assert_int_equal(red, DINNO_REDUCE_MEAN);
    assert_int_equal(dinno_kl_reduce_parse("avg", &red), -EINVAL);
    bnn_config_t b = tiny();
    dinno_cfg_t c = cfg_of(DINNO_KL);
    c.kl_form = (dinno_kl_form_t)3;
    assert_int_equal(dinno_node_init(&node, &c, &b, 1, 2, 0), -EINVAL);
    c = cfg_of(DINNO_KL);
    c.rho_pred_grad = 2;
    assert_int_equal(dinno_node_init(&node, &c, &b, 1, 2, 0), -EINVAL);
}

/* Algorithm 2 read literally (rho_pred_grad = 0): with no neighbour the rho group has no
 * gradient at all, so it never moves, while the means learn; uniform ignores the setting. */
static void test_literal_rho_loss_moves_rho_only_by_consensus(void **st)
{
    (void)st;
    bnn_config_t b = tiny();
    for (int s = DINNO_SEPARATE; s <= DINNO_KL; s++) {
        dinno_cfg_t c = cfg_of((dinno_strategy_t)s);
        c.rho_pred_grad = 0;
        assert_int_equal(dinno_node_init(&node, &c, &b, 3, 4, 0), 0);
        float t0[28];
        memcpy(t0, bnn_params(&node.model), sizeof t0);
        for (int k = 0; k < 5; k++)
            assert_int_equal(dinno_node_round(&node, data, 256, NULL), 0);
        assert_memory_equal(bnn_params(&node.model) + 20, t0 + 20, 8 * sizeof(float));
        assert_memory_not_equal(bnn_params(&node.model), t0, 20 * sizeof(float));
        /* with a neighbour, the rho group follows its dual and regulariser */
        float other_state[28];
        for (int i = 0; i < 28; i++)
            other_state[i] = bnn_params(&node.model)[i] + (i >= 20 ? 0.5f : 0.0f);
        assert_int_equal(nb_put(&node, 1, 5, other_state, 28), 0);
        memcpy(t0, bnn_params(&node.model), sizeof t0);
        assert_int_equal(dinno_node_round(&node, data, 256, NULL), 0);
        for (int i = 20; i < 28; i++)
            assert_true(bnn_params(&node.model)[i] > t0[i]); /* pulled up towards the neighbour */
    }
    float u[28];
    for (int literal = 0; literal < 2; literal++) {
        dinno_cfg_t c = cfg_of(DINNO_UNIFORM);
        c.rho_pred_grad = !literal;
        assert_int_equal(dinno_node_init(&node, &c, &b, 5, 100, 0), 0);
        for (int k = 0; k < 3; k++)
            assert_int_equal(dinno_node_round(&node, data, 256, NULL), 0);
        if (!literal)
            memcpy(u, bnn_params(&node.model), sizeof u);
        else
            assert_memory_equal(u, bnn_params(&node.model), sizeof u);
    }
}

/* Two nodes, each the other's neighbour, for `rounds` rounds; node's final parameters to out and
   its last round's stats to *last (when non-NULL). */
static void run_pair_cfg(const dinno_cfg_t *c, float *out, int rounds, dinno_round_stats_t *last)
{
    bnn_config_t b = tiny();
    assert_int_equal(dinno_node_init(&node, c, &b, 5, 100, 0), 0);
    assert_int_equal(dinno_node_init(&other, c, &b, 5, 101, 1), 0);
    float tn[28], to[28];
    for (int k = 0; k < rounds; k++) {
        memcpy(tn, bnn_params(&node.model), sizeof tn);
        memcpy(to, bnn_params(&other.model), sizeof to);
        nb_clear(&node);
        nb_clear(&other);
        assert_int_equal(nb_put(&node, 1, (uint32_t)k, to, 28), 0);
        assert_int_equal(nb_put(&other, 0, (uint32_t)k, tn, 28), 0);
        assert_int_equal(dinno_node_round(&node, data, 128, last), 0);
        assert_int_equal(dinno_node_round(&other, data + 128, 128, NULL), 0);
    }
    memcpy(out, bnn_params(&node.model), 28 * sizeof(float));
}

static void run_pair(dinno_strategy_t s, float w_rho, float *out, int rounds)
{
    dinno_cfg_t c = cfg_of(s);
    c.w_rho = w_rho;
    run_pair_cfg(&c, out, rounds, NULL);
}

static void test_uniform_equals_separate_at_unit_weights(void **st)
{
    (void)st;
    float u[28], s[28], s2[28];
    run_pair(DINNO_UNIFORM, 5.0f /* ignored by uniform */, u, 6);
    run_pair(DINNO_SEPARATE, 1.0f, s, 6);
    assert_memory_equal(u, s, sizeof u);
    run_pair(DINNO_SEPARATE, 5.0f, s2, 6);
    assert_memory_not_equal(u, s2, sizeof u);
}

/* reg_values 0 (the image's setting) skips the values' sums and logs: the same parameters, bit
   for bit, for every strategy and KL form, and NaN where the values would be. */
static void test_reg_values_off_same_models(void **st)
{
    (void)st;
    static const struct {
        dinno_strategy_t s;
        dinno_kl_form_t form;
    } cases[] = {{DINNO_UNIFORM, DINNO_KL_OWN_MEAN}, {DINNO_SEPARATE, DINNO_KL_OWN_MEAN},
                 {DINNO_KL, DINNO_KL_OWN_MEAN},      {DINNO_KL, DINNO_KL_REVERSE},
                 {DINNO_KL, DINNO_KL_FULL}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        dinno_cfg_t c = cfg_of(cases[i].s);
        c.kl_form = cases[i].form;
        float on[28], off[28];
        dinno_round_stats_t st_on, st_off;
        run_pair_cfg(&c, on, 6, &st_on);
        c.reg_values = 0;
        run_pair_cfg(&c, off, 6, &st_off);
        assert_memory_equal(on, off, sizeof on);
        assert_true(isfinite(st_on.reg_mu) && isfinite(st_on.reg_rho) && isfinite(st_on.dual_dot));
        assert_true(st_on.reg_mu > 0.0f);
        assert_true(isnan(st_off.reg_mu) && isnan(st_off.reg_rho) && isnan(st_off.dual_dot));
        assert_true(st_on.pred_total == st_off.pred_total && st_on.neighbours == st_off.neighbours);
    }
    dinno_cfg_t bad = cfg_of(DINNO_KL);
    bnn_config_t b = tiny();
    bad.reg_values = 2;
    assert_int_equal(dinno_node_init(&node, &bad, &b, 1, 2, 0), -EINVAL);
}

static void test_slot_round_mismatch_rejected(void **st)
{
    (void)st;
    bnn_config_t b = tiny();
    dinno_cfg_t c = cfg_of(DINNO_KL);
    assert_int_equal(dinno_node_init(&node, &c, &b, 1, 2, 0), 0);
    float t[28];
    memcpy(t, bnn_params(&node.model), sizeof t);
    assert_int_equal(nb_put(&node, 2, 1, t, 28), 0); /* round 1 state in round 0 */
    assert_int_equal(dinno_node_round(&node, data, 256, NULL), -EINVAL);
    assert_memory_equal(t, bnn_params(&node.model), sizeof t);
    assert_int_equal(node.round, 0);
    assert_int_equal(dinno_node_round(&node, data, 0, NULL), -EINVAL);
    assert_int_equal(dinno_node_round(NULL, data, 5, NULL), -EINVAL);
}

static void test_no_neighbours_trains_alone(void **st)
{
    (void)st;
    bnn_config_t b = tiny();
    dinno_cfg_t c = cfg_of(DINNO_SEPARATE);
    c.total_rounds = 40;
    /* A: never a neighbour. B: a neighbour every round whose state equals B's own, with zero
       weights: its dual stays 0 and every consensus term adds exactly 0, so B is "local
       training" computed through the consensus path. A must match it bit for bit. */
    assert_int_equal(dinno_node_init(&node, &c, &b, 9, 10, 0), 0);
    c.w_mu = 0.0f;
    c.w_rho = 0.0f;
    assert_int_equal(dinno_node_init(&other, &c, &b, 9, 10, 0), 0);
    dinno_round_stats_t sa, sb, first = {0};
    for (int k = 0; k < 40; k++) {
        nb_clear(&other);
        assert_int_equal(nb_put(&other, 4, (uint32_t)k, bnn_params(&other.model), 28), 0);
        assert_int_equal(dinno_node_round(&node, data, 256, &sa), 0);
        assert_int_equal(dinno_node_round(&other, data, 256, &sb), 0);
        if (k == 0)
            first = sa;
        assert_int_equal(sa.neighbours, 0);
        assert_int_equal(sb.neighbours, 1);
    }
    assert_memory_equal(bnn_params(&node.model), bnn_params(&other.model), 28 * sizeof(float));
    for (int i = 0; i < 28; i++)
        assert_true(node.dual[i] == 0.0f);
    assert_true(sa.pred_total < first.pred_total); /* it learned */
}

/* The screen: a non-finite state, a scaled one, a sign-flipped one are left out and counted;
 * one within the radius is used; and a round whose neighbour is left out equals, bit for bit,
 * a round that never had it. */
static void test_screen_leaves_out_bad_states(void **st)
{
    (void)st;
    bnn_config_t b = tiny();
    dinno_cfg_t c = cfg_of(DINNO_KL);
    assert_int_equal(dinno_node_init(&node, &c, &b, 1, 2, 0), 0);
    assert_int_equal(dinno_node_init(&other, &c, &b, 1, 2, 0), 0);
    float own[28];
    memcpy(own, bnn_params(&node.model), sizeof own);
    double norm = 0.0;
    for (int e = 0; e < 28; e++)
        norm += (double)own[e] * own[e];
    norm = sqrt(norm);
    assert_true(norm > 1.0);
    /* neighbour 1: close (a tenth of the radius); 2: NaN; 3: x1000; 4: -theta; 5: +inf (each its
       own array: the node reads them in place) */
    static float t1[28], t2[28], t3[28], t4[28], t5[28];
    for (int e = 0; e < 28; e++)
        t1[e] = own[e] + (float)(0.05 * norm / sqrt(28.0));
    assert_int_equal(nb_put(&node, 1, 0, t1, 28), 0);
    assert_int_equal(nb_put(&other, 1, 0, t1, 28), 0); /* `other` never sees the bad ones */
    memcpy(t2, own, sizeof t2);
    t2[7] = NAN;
    assert_int_equal(nb_put(&node, 2, 0, t2, 28), 0);
    for (int e = 0; e < 28; e++)
        t3[e] = own[e] * 1000.0f;
    assert_int_equal(nb_put(&node, 3, 0, t3, 28), 0);
    for (int e = 0; e < 28; e++)
        t4[e] = -own[e];
    assert_int_equal(nb_put(&node, 4, 0, t4, 28), 0);
    memcpy(t5, own, sizeof t5);
    t5[0] = INFINITY;
    assert_int_equal(nb_put(&node, 5, 0, t5, 28), 0);
    float keep1[28];
    memcpy(keep1, t1, sizeof keep1);
    dinno_round_stats_t sa, sb;
    assert_int_equal(dinno_node_round(&node, data, 256, &sa), 0);
    assert_int_equal(dinno_node_round(&other, data, 256, &sb), 0);
    assert_int_equal(sa.excluded, 4);
    assert_int_equal(sa.neighbours, 1);
    assert_true(isinf(sa.nb_dist_max));
    assert_int_equal(sb.excluded, 0);
    assert_true(fabs(sb.nb_dist_max - 0.05) < 1e-3);
    assert_memory_equal(bnn_params(&node.model), bnn_params(&other.model), sizeof own);
    assert_memory_equal(node.dual, other.dual, sizeof own);
    /* The screen wrote nothing shared: the states are as they were handed over. */
    assert_memory_equal(t1, keep1, sizeof keep1);
    assert_true(isnan(t2[7]) && isinf(t5[0]));
    /* Radius 0: no distance screen, only non-finite states are left out. */
    c.screen_radius = 0.0f;
    assert_int_equal(dinno_node_init(&node, &c, &b, 1, 2, 0), 0);
    for (int e = 0; e < 28; e++)
        t4[e] = -own[e];
    assert_int_equal(nb_put(&node, 4, 0, t4, 28), 0);
    memcpy(t2, t4, sizeof t2);
    t2[3] = NAN;
    assert_int_equal(nb_put(&node, 2, 0, t2, 28), 0);
    float dmax = 0.0f;
    assert_int_equal(dinno_screen_slots(&node, &dmax), 1);
    assert_true(node.use[0] && !node.use[1]); /* robot 4's state used, robot 2's left out */
    c.screen_radius = -1.0f;
    assert_int_equal(dinno_node_init(&node, &c, &b, 1, 2, 0), -EINVAL);
}

static void test_round_allocates_nothing(void **st)
{
    (void)st;
    /* Preset-sized node (static storage), full set of neighbour slots, batch drawn from data. */
    static dinno_node_t big;
    static ai_sample_t many[2048];
    for (int i = 0; i < 2048; i++)
        many[i] = data[i % 256];
    dinno_cfg_t c = dinno_default_cfg();
    c.batch = 64;
    c.primal_steps = 2;
    alloc_count_reset();
    assert_int_equal(dinno_node_init(&big, &c, NULL, 1, 2, 0), 0);
    for (uint32_t s = 0; s < DINNO_MAX_PEERS; s++)
        assert_int_equal(nb_put(&big, s, 0, bnn_params(&big.model), bnn_n_params(&big.model)), 0);
    dinno_round_stats_t rs;
    assert_int_equal(dinno_node_round(&big, many, 2048, &rs), 0);
    assert_int_equal(rs.neighbours, DINNO_MAX_PEERS);
    big.cfg.strategy = DINNO_UNIFORM;
    for (uint32_t s = 0; s < DINNO_MAX_PEERS; s++)
        assert_int_equal(nb_put(&big, s, 1, bnn_params(&big.model), bnn_n_params(&big.model)), 0);
    assert_int_equal(dinno_node_round(&big, many, 2048, &rs), 0);
    print_message("node %zu bytes: %llu allocations\n", dinno_get_buffer_size(),
                  (unsigned long long)alloc_count_allocations());
    assert_int_equal(alloc_count_allocations(), 0);
    assert_int_equal(alloc_count_frees(), 0);
}

int main(void)
{
    make_data();
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sizes_and_layout),
        cmocka_unit_test(test_schedules),
        cmocka_unit_test(test_dual_and_l2_midpoints_by_hand),
        cmocka_unit_test(test_kl_rho_gradient_finite_differences),
        cmocka_unit_test(test_literal_rho_loss_moves_rho_only_by_consensus),
        cmocka_unit_test(test_uniform_equals_separate_at_unit_weights),
        cmocka_unit_test(test_slot_round_mismatch_rejected),
        cmocka_unit_test(test_reg_values_off_same_models),
        cmocka_unit_test(test_no_neighbours_trains_alone),
        cmocka_unit_test(test_screen_leaves_out_bad_states),
        cmocka_unit_test(test_round_allocates_nothing),
    };
    return cmocka_run_group_tests_name("dinno/node", tests, NULL, NULL);
}
