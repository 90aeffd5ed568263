/* The in-process fleet on a synthetic occupancy field split between two agents (disjoint
 * halves): DiNNO reaches consensus and a validation loss close to centralised training on
 * the whole field; an isolated agent is clearly worse on the half it never saw; the same
 * seed gives bit-identical parameters; worker threads do not change a bit. */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "ai/ai_rng.h"
#include "sim_fleet.h"

#if defined(__SANITIZE_ADDRESS__)
#define ROUNDS 150u
#else
#define ROUNDS 300u
#endif
#define N_HALF 3000
#define N_VAL 4000

static ai_sample_t half[2][N_HALF], val_all[N_VAL], val_b[N_VAL];
static size_t n_val_b;

/* Walls: two vertical bands, one horizontal band, a ring; everything else free. */
static float field(float x, float y)
{
    const float r = sqrtf((x - 0.45f) * (x - 0.45f) + (y - 0.4f) * (y - 0.4f));
    int wall = fabsf(x + 0.55f) < 0.06f || fabsf(x - 0.7f) < 0.06f || fabsf(y + 0.3f) < 0.06f ||
               fabsf(r - 0.25f) < 0.05f;
    return wall ? 1.0f : 0.0f;
}

static void make_data(void)
{
    float u[2 * N_VAL];
    for (int h = 0; h < 2; h++) {
        ai_rng_uniform_fill(77, (uint64_t)h, 0, u, 2 * N_HALF);
        for (int i = 0; i < N_HALF; i++) {
            const float x = h == 0 ? -u[2 * i] : u[2 * i]; /* agent 0: x < 0, agent 1: x > 0 */
            const float y = 2 * u[2 * i + 1] - 1;
            half[h][i] = (ai_sample_t){x, y, field(x, y)};
        }
    }
    ai_rng_uniform_fill(78, 0, 0, u, 2 * N_VAL);
    for (int i = 0; i < N_VAL; i++) {
        const float x = 2 * u[2 * i] - 1, y = 2 * u[2 * i + 1] - 1;
        val_all[i] = (ai_sample_t){x, y, field(x, y)};
        if (x > 0)
            val_b[n_val_b++] = val_all[i];
    }
}

static bnn_config_t small_cfg(void)
{
    bnn_config_t b = bnn_default_config();
    b.siren_width = 32;
    b.hidden_width = 32;
    b.n_bayes = 2;
    b.max_batch = 128;
    return b;
}

static sim_fleet_t *run(sim_fleet_mode_t mode, dinno_strategy_t s, int threads, uint64_t seed)
{
    sim_fleet_cfg_t c;
    sim_fleet_cfg_default(&c);
    c.n_agents = 2;
    c.rounds = ROUNDS;
    c.mode = mode;
    c.graph = DINNO_GRAPH_FULL;
    c.seed = seed;
    c.threads = threads;
    c.dinno.strategy = s;
    c.dinno.batch = 128;
    c.dinno.lr_start = 3e-3f;
    c.dinno.lr_end = 3e-4f;
    bnn_config_t b = small_cfg();
    const ai_sample_t *data[2] = {half[0], half[1]};
    const size_t n[2] = {N_HALF, N_HALF};
    sim_fleet_t *f = NULL;
    char err[256];
    assert_int_equal(sim_fleet_create(&c, &b, data, n, NULL, &f, err, sizeof err), 0);
    for (uint32_t k = 0; k < ROUNDS; k++) {
        dinno_graph_report_t rep;
        assert_int_equal(sim_fleet_round(f, &rep), 0);
        if (mode == SIM_FLEET_DINNO)
            assert_int_equal(rep.edges, 1);
    }
    assert_int_equal(sim_fleet_rounds_done(f), ROUNDS);
    return f;
}

static double bce(sim_fleet_t *f, int i, const ai_sample_t *v, size_t n)
{
    float b;
    assert_int_equal(bnn_eval_bce(&sim_fleet_node(f, i)->model, v, n, 0, 0, &b), 0);
    return b;
}

static void test_consensus_close_to_central_isolated_worse(void **st)
{
    (void)st;
    sim_fleet_t *d = run(SIM_FLEET_DINNO, DINNO_KL, 1, 5);
    sim_fleet_t *c = run(SIM_FLEET_CENTRAL, DINNO_KL, 1, 5);
    sim_fleet_t *iso = run(SIM_FLEET_ISOLATED, DINNO_KL, 1, 5);
    assert_int_equal(sim_fleet_models(c), 1);
    const double ce0 = sim_fleet_consensus_error(d, 0), ce1 = sim_fleet_consensus_error(d, 1);
    const double vd0 = bce(d, 0, val_all, N_VAL), vd1 = bce(d, 1, val_all, N_VAL);
    const double vc = bce(c, 0, val_all, N_VAL);
    const double vi = bce(iso, 0, val_all, N_VAL);
    const double bd = bce(d, 0, val_b, n_val_b), bi = bce(iso, 0, val_b, n_val_b);
    const double ci = sim_fleet_consensus_error(iso, 0);
    print_message("rounds %u: consensus %.5f %.5f (isolated %.4f); val all: dinno %.4f %.4f, central %.4f, "
                  "isolated %.4f; unseen half: dinno %.4f, isolated %.4f\n",
                  ROUNDS, ce0, ce1, ci, vd0, vd1, vc, vi, bd, bi);
    assert_true(ce0 < 0.02 && ce1 < 0.02);
    assert_true(ci > 5 * ce0);
    /* "Close to central", stated so that it holds on every kernel (AVX2, AVX-512, pure C):
       floating-point summation order changes each agent's trajectory, and a sharp SIREN
       moves the loss by tens of percent between them (measured per agent 1.5x-2.1x of
       central across kernels), while isolation costs a factor of ~40. So each DiNNO agent
       must close at least 90 % of the isolated-to-central gap and stay within 3x of
       central; the isolated agent must stay 10x worse. */
    for (int a = 0; a < 2; a++) {
        const double vd = a == 0 ? vd0 : vd1;
        assert_true((vi - vd) / (vi - vc) > 0.9);
        assert_true(vd < 3.0 * vc + 0.02);
        assert_true(vi > 10.0 * vd);
    }
    assert_true(bi > 2.0 * bd);
    assert_true(vi > vd0);
    sim_fleet_destroy(d);
    sim_fleet_destroy(c);
    sim_fleet_destroy(iso);
}

static void test_same_seed_bit_identical(void **st)
{
    (void)st;
    sim_fleet_t *a = run(SIM_FLEET_DINNO, DINNO_KL, 1, 11);
    sim_fleet_t *b = run(SIM_FLEET_DINNO, DINNO_KL, 2, 11); /* threads must not matter */
    sim_fleet_t *c = run(SIM_FLEET_DINNO, DINNO_KL, 1, 12);
    const size_t bytes = bnn_n_params(&sim_fleet_node(a, 0)->model) * sizeof(float);
    for (int i = 0; i < 2; i++) {
        assert_memory_equal(bnn_params(&sim_fleet_node(a, i)->model), bnn_params(&sim_fleet_node(b, i)->model),
                            bytes);
        assert_memory_equal(sim_fleet_node(a, i)->dual, sim_fleet_node(b, i)->dual, bytes);
    }
    assert_memory_not_equal(bnn_params(&sim_fleet_node(a, 0)->model), bnn_params(&sim_fleet_node(c, 0)->model),
                            bytes);
    sim_fleet_destroy(a);
    sim_fleet_destroy(b);
    sim_fleet_destroy(c);
}


/* The fleet's epistemic posterior (sim_fleet_posteriors, the image's posterior rounds): on a
 * ring of 4 (whose DiNNO rounds never join robots 0 and 2), every robot reaches the sum of the
 * 4 robots' own posteriors, computed here directly; robots that never talk keep their own. */
static bnn_post_t posts[4], own;
static void test_posteriors_reach_the_fleets_sum(void **st)
{
    (void)st;
    for (int iso = 0; iso < 2; iso++) {
        sim_fleet_cfg_t c;
        sim_fleet_cfg_default(&c);
        c.n_agents = 4;
        c.rounds = 1;
        c.mode = iso ? SIM_FLEET_ISOLATED : SIM_FLEET_DINNO;
        c.graph = DINNO_GRAPH_RING;
        c.dinno.batch = 128;
        bnn_config_t b = small_cfg();
        const ai_sample_t *data[4] = {half[0], half[0] + N_HALF / 2, half[1], half[1] + N_HALF / 2};
        const size_t n[4] = {N_HALF / 2, N_HALF / 2, N_HALF / 2, N_HALF / 2};
        sim_fleet_t *f = NULL;
        char err[256];
        assert_int_equal(sim_fleet_create(&c, &b, data, n, NULL, &f, err, sizeof err), 0);
        dinno_graph_report_t rep;
        assert_int_equal(sim_fleet_round(f, &rep), 0);
        sim_fleet_post_report_t pr;
        assert_int_equal(sim_fleet_posteriors(f, posts, 2, &pr), 0);
        /* each robot's own posterior over the initial SIREN layer, and their sum */
        static bnn_model_t init;
        bnn_model_t *scratch = &sim_fleet_node(f, 0)->model;
        assert_int_equal(bnn_init(&init, &scratch->cfg, scratch->seed), 0);
        assert_int_equal(bnn_post_init(&own, &init), 0);
        for (int i = 0; i < 4; i++) {
            static bnn_post_t one;
            assert_int_equal(bnn_post_init(&one, &init), 0);
            assert_int_equal(bnn_post_observe_samples(&one, scratch, data[i], n[i]), 0);
            if (iso) { /* isolated: its own, untouched */
                assert_true(posts[i].robots == 1.0);
                assert_memory_equal(posts[i].prec, one.prec, BNN_POST_PACKED(one.dim) * sizeof(double));
            }
            assert_int_equal(bnn_post_add(&own, &one, 1.0), 0);
        }
        if (!iso) {
            assert_int_equal(pr.iterations, 2);
            for (int i = 0; i < 4; i++) {
                assert_true(fabs(posts[i].robots - 4.0) < 1e-6);
                assert_true(fabs(posts[i].n_obs - 2.0 * N_HALF) < 1e-3);
                for (size_t e = 0; e < BNN_POST_PACKED(own.dim); e++)
                    assert_true(fabs(posts[i].prec[e] - own.prec[e]) <= 1e-6 * 2.0 * N_HALF);
            }
        }
        sim_fleet_destroy(f);
    }
}

static void test_bad_arguments(void **st)
{
    (void)st;
    sim_fleet_cfg_t c;
    sim_fleet_cfg_default(&c);
    c.n_agents = 2;
    const ai_sample_t *data[2] = {half[0], NULL};
    const size_t n[2] = {N_HALF, 0};
    sim_fleet_t *f = NULL;
    char err[256];
    c.graph = DINNO_GRAPH_FULL;
    assert_int_equal(sim_fleet_create(&c, NULL, data, n, NULL, &f, err, sizeof err), -EINVAL);
    assert_non_null(strstr(err, "agent 1"));
    data[1] = half[1];
    const size_t n2[2] = {N_HALF, N_HALF};
    c.graph = DINNO_GRAPH_DISK; /* needs paths */
    assert_int_equal(sim_fleet_create(&c, NULL, data, n2, NULL, &f, err, sizeof err), -EINVAL);
    c.graph = DINNO_GRAPH_FULL;
    c.n_agents = SIM_FLEET_MAX_AGENTS + 1;
    assert_int_equal(sim_fleet_create(&c, NULL, data, n2, NULL, &f, err, sizeof err), -EINVAL);
    assert_null(f);
}

int main(void)
{
    make_data();
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_consensus_close_to_central_isolated_worse),
        cmocka_unit_test(test_same_seed_bit_identical),
        cmocka_unit_test(test_bad_arguments),
        cmocka_unit_test(test_posteriors_reach_the_fleets_sum),
    };
    return cmocka_run_group_tests_name("dinno/fleet", tests, NULL, NULL);
}
