/* The one-pass epistemic posterior (ai/bnn_post.h): its data precision and variances against
 * a dense double reference (libm sin, Gaussian elimination), additivity over robots and its
 * average consensus (also while the data grow), distance awareness, the stored form (round trip and every refusal
 * leaving the posterior untouched), and no allocation. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "ai/ai_rng.h"
#include "ai/bnn_post.h"

#define NPTS 2000
#define NQ 40

static bnn_model_t model;
static bnn_post_t pa, pb, pab, tmp;
static float pts[2 * NPTS], qry[2 * NQ];
static uint8_t wire[BNN_POST_WIRE_MAX];

static void setup_model(void)
{
    bnn_config_t c = bnn_default_config();
    c.hidden_width = c.hidden_width < 16 ? c.hidden_width : 16;
    c.n_bayes = 2;
    c.max_batch = 64; /* NPTS spans several chunks */
    assert_int_equal(bnn_init(&model, &c, 7), 0);
    ai_rng_uniform_fill(11, 1, 0, pts, 2 * NPTS);
    ai_rng_uniform_fill(11, 2, 0, qry, 2 * NQ);
    for (int i = 0; i < 2 * NPTS; i++)
        pts[i] = 2.0f * pts[i] - 1.0f;
    for (int i = 0; i < 2 * NQ; i++)
        qry[i] = 2.0f * qry[i] - 1.0f;
}

/* phi(x) = [sin(w0 (W0 x + b0)); 1] in double, from theta directly. */
static void ref_phi(const float *xy, double *phi)
{
    const size_t S = model.cfg.siren_width;
    const float *th = bnn_params_const(&model);
    for (size_t j = 0; j < S; j++)
        phi[j] = sin((double)model.cfg.w0 * ((double)th[2 * j] * xy[0] + (double)th[2 * j + 1] * xy[1] +
                                             (double)th[2 * S + j]));
    phi[S] = 1.0;
}

static size_t pk(size_t i, size_t j)
{
    return i * (i + 1) / 2 + j;
}

static void test_precision_and_variance_match_dense_reference(void **state)
{
    (void)state;
    setup_model();
    const size_t D = model.cfg.siren_width + 1u;
    assert_int_equal(bnn_post_init(&pa, &model), 0);
    assert_int_equal(pa.dim, D);
    assert_int_equal(bnn_post_observe(&pa, &model, pts, NPTS), 0);
    static double P[BNN_POST_DIM_MAX][BNN_POST_DIM_MAX], A[BNN_POST_DIM_MAX][BNN_POST_DIM_MAX + 1];
    double phi[BNN_POST_DIM_MAX];
    memset(P, 0, sizeof P);
    for (int k = 0; k < NPTS; k++) {
        ref_phi(pts + 2 * k, phi);
        for (size_t i = 0; i < D; i++)
            for (size_t j = 0; j < D; j++)
                P[i][j] += phi[i] * phi[j];
    }
    for (size_t i = 0; i < D; i++)
        for (size_t j = 0; j <= i; j++)
            assert_true(fabs(pa.prec[pk(i, j)] - P[i][j]) <= 1e-4 * (1.0 + fabs(P[i][j])));
    assert_true(pa.n_obs == NPTS && pa.robots == 1.0);

    float unknown[NQ];
    assert_int_equal(bnn_post_predict(&pa, &model, qry, NQ, NULL, unknown), 0);
    for (int q = 0; q < NQ; q++) {
        /* var = phi^T (lambda0 I + beta P)^-1 phi by Gaussian elimination with partial pivoting */
        ref_phi(qry + 2 * q, phi);
        for (size_t i = 0; i < D; i++) {
            for (size_t j = 0; j < D; j++)
                A[i][j] = BNN_POST_BETA * P[i][j] + (i == j ? BNN_POST_LAMBDA0 : 0.0);
            A[i][D] = phi[i];
        }
        for (size_t c = 0; c < D; c++) {
            size_t piv = c;
            for (size_t r = c + 1; r < D; r++)
                if (fabs(A[r][c]) > fabs(A[piv][c]))
                    piv = r;
            for (size_t j = 0; j <= D; j++) {
                double t = A[c][j];
                A[c][j] = A[piv][j];
                A[piv][j] = t;
            }
            for (size_t r = c + 1; r < D; r++) {
                const double f = A[r][c] / A[c][c];
                for (size_t j = c; j <= D; j++)
                    A[r][j] -= f * A[c][j];
            }
        }
        double x[BNN_POST_DIM_MAX], var = 0.0, prior = 0.0;
        for (size_t i = D; i-- > 0;) {
            double s = A[i][D];
            for (size_t j = i + 1; j < D; j++)
                s -= A[i][j] * x[j];
            x[i] = s / A[i][i];
        }
        for (size_t i = 0; i < D; i++) {
            var += phi[i] * x[i];
            prior += phi[i] * phi[i] / BNN_POST_LAMBDA0;
        }
        const double want = var / prior;
        assert_true(unknown[q] > 0.0f && unknown[q] <= 1.0f);
        assert_true(fabs(unknown[q] - want) <= 2e-3 * want + 1e-6);
    }
}

/* A robot that saw the left half and one that saw the right half: the sum of their posteriors
 * is the posterior of all the data, and average consensus (mix to the mean, times N) reaches it. */
static void test_fleet_sum_and_consensus(void **state)
{
    (void)state;
    setup_model();
    static float left[2 * NPTS], right[2 * NPTS];
    size_t nl = 0, nr = 0;
    for (int k = 0; k < NPTS; k++) {
        float *dst = pts[2 * k] < 0.0f ? left + 2 * nl++ : right + 2 * nr++;
        dst[0] = pts[2 * k];
        dst[1] = pts[2 * k + 1];
    }
    assert_true(nl > 50 && nr > 50);
    assert_int_equal(bnn_post_init(&pa, &model), 0);
    assert_int_equal(bnn_post_init(&pb, &model), 0);
    assert_int_equal(bnn_post_init(&pab, &model), 0);
    assert_int_equal(bnn_post_observe(&pa, &model, left, nl), 0);
    assert_int_equal(bnn_post_observe(&pb, &model, right, nr), 0);
    assert_int_equal(bnn_post_observe(&pab, &model, pts, NPTS), 0);

    /* distance awareness: robot a knows the left half, not the right */
    float ul[NQ], ur[NQ];
    static float ql[2 * NQ], qr[2 * NQ];
    for (int q = 0; q < NQ; q++) {
        ql[2 * q] = -0.5f - 0.4f * fabsf(qry[2 * q]);
        qr[2 * q] = 0.5f + 0.4f * fabsf(qry[2 * q]);
        ql[2 * q + 1] = qr[2 * q + 1] = qry[2 * q + 1];
    }
    assert_int_equal(bnn_post_predict(&pa, &model, ql, NQ, NULL, ul), 0);
    assert_int_equal(bnn_post_predict(&pa, &model, qr, NQ, NULL, ur), 0);
    double sl = 0, sr = 0;
    for (int q = 0; q < NQ; q++)
        sl += ul[q], sr += ur[q];
    assert_true(sr > 20.0 * sl);

    /* two robots, two rounds of mixing with weight 1/2 (a full graph), then times N = 2 */
    tmp = pa;
    assert_int_equal(bnn_post_scale(&pa, 0.5), 0);
    assert_int_equal(bnn_post_add(&pa, &pb, 0.5), 0);
    assert_int_equal(bnn_post_scale(&pb, 0.5), 0);
    assert_int_equal(bnn_post_add(&pb, &tmp, 0.5), 0);
    assert_int_equal(bnn_post_scale(&pa, 2.0), 0);
    assert_int_equal(bnn_post_scale(&pb, 2.0), 0);
    for (size_t i = 0; i < BNN_POST_PACKED(pa.dim); i++) {
        assert_true(fabs(pa.prec[i] - pab.prec[i]) <= 1e-6 * NPTS);
        assert_true(fabs(pb.prec[i] - pab.prec[i]) <= 1e-6 * NPTS);
    }
    assert_true(fabs(pa.robots - 2.0) < 1e-12 && fabs(pa.n_obs - NPTS) < 1e-6);
    /* after consensus robot a knows the right half too */
    assert_int_equal(bnn_post_predict(&pa, &model, qr, NQ, NULL, ur), 0);
    double sr2 = 0;
    for (int q = 0; q < NQ; q++)
        sr2 += ur[q];
    assert_true(sr2 < 0.2 * sr);
    /* refusals: a negative weight, posteriors over other features (another SIREN layer) */
    assert_int_equal(bnn_post_add(&pa, &pb, -1.0), -EINVAL);
    tmp = pb;
    tmp.siren[0] += 1e-3f;
    assert_int_equal(bnn_post_add(&pa, &tmp, 1.0), -EINVAL);
    assert_int_equal(bnn_post_scale(&pa, NAN), -EINVAL);
}

/* Exploring fleets (ai_core.h): dynamic average consensus while the data grow. Two robots each
 * see half their points, mix (weights 1/2) from N = 2 times their own, then add the rest with
 * weight N = 2 and mix again: the mean of the two estimates is the fleet's sum all along, and
 * after the last mix (a full graph) each one is. */
static void test_consensus_while_the_data_grow(void **state)
{
    (void)state;
    setup_model();
    const size_t h = NPTS / 4; /* robot a: pts[0, 2h), robot b: pts[2h, 4h), each in two halves */
    assert_int_equal(bnn_post_init(&pa, &model), 0);
    assert_int_equal(bnn_post_init(&pb, &model), 0);
    assert_int_equal(bnn_post_init(&pab, &model), 0);
    assert_int_equal(bnn_post_observe(&pab, &model, pts, NPTS), 0);
    assert_int_equal(bnn_post_observe(&pa, &model, pts, h), 0);
    assert_int_equal(bnn_post_observe(&pb, &model, pts + 2 * 2 * h, h), 0);
    assert_int_equal(bnn_post_scale(&pa, 2.0), 0);
    assert_int_equal(bnn_post_scale(&pb, 2.0), 0);
    for (int pass = 0; pass < 2; pass++) {
        tmp = pa; /* one mixing round on both, from the states before it */
        assert_int_equal(bnn_post_scale(&pa, 0.5), 0);
        assert_int_equal(bnn_post_add(&pa, &pb, 0.5), 0);
        assert_int_equal(bnn_post_scale(&pb, 0.5), 0);
        assert_int_equal(bnn_post_add(&pb, &tmp, 0.5), 0);
        if (pass == 0) { /* the second halves, each robot's new points N times */
            assert_int_equal(bnn_post_observe_weighted(&pa, &model, pts + 2 * h, h, 2.0), 0);
            assert_int_equal(bnn_post_observe_weighted(&pb, &model, pts + 2 * 3 * h, h, 2.0), 0);
            for (size_t i = 0; i < BNN_POST_PACKED(pa.dim); i++) /* the mean is the fleet's sum */
                assert_true(fabs(0.5 * (pa.prec[i] + pb.prec[i]) - pab.prec[i]) <= 1e-6 * NPTS);
        }
    }
    for (size_t i = 0; i < BNN_POST_PACKED(pa.dim); i++) {
        assert_true(fabs(pa.prec[i] - pab.prec[i]) <= 1e-6 * NPTS);
        assert_true(fabs(pb.prec[i] - pab.prec[i]) <= 1e-6 * NPTS);
    }
    assert_true(fabs(pa.n_obs - NPTS) < 1e-6 && fabs(pa.robots - 2.0) < 1e-12);
    /* weight 1 is bnn_post_observe bit for bit; a weight that is not finite and > 0 is refused */
    assert_int_equal(bnn_post_init(&pa, &model), 0);
    assert_int_equal(bnn_post_init(&pb, &model), 0);
    assert_int_equal(bnn_post_observe(&pa, &model, pts, NPTS), 0);
    assert_int_equal(bnn_post_observe_weighted(&pb, &model, pts, NPTS, 1.0), 0);
    assert_memory_equal(pa.prec, pb.prec, BNN_POST_PACKED(pa.dim) * sizeof(double));
    tmp = pb;
    assert_int_equal(bnn_post_observe_weighted(&pb, &model, pts, 1, 0.0), -EINVAL);
    assert_int_equal(bnn_post_observe_weighted(&pb, &model, pts, 1, -1.0), -EINVAL);
    assert_int_equal(bnn_post_observe_weighted(&pb, &model, pts, 1, INFINITY), -EINVAL);
    assert_memory_equal(pb.prec, tmp.prec, BNN_POST_PACKED(pb.dim) * sizeof(double));
}

static void test_wire_round_trip_and_refusals(void **state)
{
    (void)state;
    setup_model();
    assert_int_equal(bnn_post_init(&pa, &model), 0);
    assert_int_equal(bnn_post_observe(&pa, &model, pts, NPTS), 0);
    size_t n = 0;
    assert_int_equal(bnn_post_write(&pa, wire, 10, &n), -ENOSPC);
    assert_int_equal(bnn_post_write(&pa, wire, sizeof wire, &n), 0);
    assert_int_equal(n, BNN_POST_WIRE_BYTES(pa.dim));
    const char *why = NULL;
    assert_int_equal(bnn_post_read(&pb, &model, wire, n, &why), 0);
    assert_null(why);
    assert_memory_equal(pa.prec, pb.prec, BNN_POST_PACKED(pa.dim) * sizeof(double));
    assert_true(pb.n_obs == pa.n_obs && pb.robots == pa.robots && pb.dim == pa.dim && pb.w0 == pa.w0);
    assert_memory_equal(pa.siren, pb.siren, 3 * (pa.dim - 1) * sizeof(float));

    tmp = pb;
    assert_int_equal(bnn_post_read(&pb, &model, wire, n - 1, &why), -ENODATA);
    assert_non_null(why);
    assert_int_equal(bnn_post_read(&pb, &model, wire, 8, &why), -ENODATA);
    wire[0] ^= 1u; /* another dimension */
    assert_int_equal(bnn_post_read(&pb, &model, wire, n, &why), -ENOEXEC);
    wire[0] ^= 1u;
    const double nan = NAN, neg = -1.0;
    const float fnan = NAN;
    const size_t prec_at = 20 + 4 * (3 * (pa.dim - 1) + 1); /* after n_obs, robots, w0, W0, b0 */
    memcpy(wire + 20 + 4 * 7, &fnan, 4); /* a feature weight */
    assert_int_equal(bnn_post_read(&pb, &model, wire, n, &why), -EBADMSG);
    assert_int_equal(bnn_post_write(&pa, wire, sizeof wire, &n), 0);
    memcpy(wire + prec_at + 8 * 5, &nan, 8);
    assert_int_equal(bnn_post_read(&pb, &model, wire, n, &why), -EBADMSG);
    assert_int_equal(bnn_post_write(&pa, wire, sizeof wire, &n), 0);
    memcpy(wire + prec_at + 8 * pk(3, 3), &neg, 8);
    assert_int_equal(bnn_post_read(&pb, &model, wire, n, &why), -EBADMSG);
    assert_memory_equal(&tmp, &pb, sizeof pb);
}


/* The state form a posterior travels in: mixing a neighbour's gives the weighted mean to 48
 * bits; a state over other features or with a non-finite value is left out. */
static float st_b[BNN_N_PARAMS], st_bad[BNN_N_PARAMS];
static void test_state_form_and_mixing(void **state)
{
    (void)state;
    setup_model();
    assert_int_equal(bnn_post_init(&pa, &model), 0);
    assert_int_equal(bnn_post_init(&pb, &model), 0);
    assert_int_equal(bnn_post_observe(&pa, &model, pts, NPTS / 2), 0);
    assert_int_equal(bnn_post_observe(&pb, &model, pts + NPTS, NPTS / 2), 0);
    assert_int_equal(bnn_post_to_state(&pb, st_b, 10), -ENOSPC);
    assert_int_equal(bnn_post_to_state(&pb, st_b, BNN_N_PARAMS), 0);
    for (size_t i = BNN_POST_STATE_FLOATS(pb.dim); i < BNN_N_PARAMS; i++)
        assert_true(st_b[i] == 0.0f);
    tmp = pa;
    const float *sts[3] = {st_b, NULL, st_bad};
    memcpy(st_bad, st_b, sizeof st_b);
    st_bad[3] += 1e-3f; /* another SIREN layer */
    uint32_t used = 9;
    assert_int_equal(bnn_post_mix(&pa, sts, 3, BNN_N_PARAMS, 0.5, &used), -EINVAL); /* 3 x 0.5 > 1 */
    assert_int_equal(bnn_post_mix(&pa, sts, 3, BNN_N_PARAMS, 1.0 / 3.0, &used), 0);
    assert_int_equal(used, 1);
    for (size_t i = 0; i < BNN_POST_PACKED(pa.dim); i++) {
        const double want = (2.0 / 3.0) * tmp.prec[i] + (1.0 / 3.0) * pb.prec[i];
        assert_true(fabs(pa.prec[i] - want) <= 1e-12 * (1.0 + fabs(want)));
    }
    assert_true(fabs(pa.n_obs - NPTS / 2.0) < 1e-9 && fabs(pa.robots - 1.0) < 1e-12);
    memcpy(st_bad, st_b, sizeof st_b);
    st_bad[BNN_POST_STATE_FLOATS(pb.dim) - 1] = NAN;
    const float *bad[1] = {st_bad};
    tmp = pa;
    assert_int_equal(bnn_post_mix(&pa, bad, 1, BNN_N_PARAMS, 0.5, &used), 0);
    assert_int_equal(used, 0);
    assert_memory_equal(pa.prec, tmp.prec, BNN_POST_PACKED(pa.dim) * sizeof(double));
}

static void test_no_allocation(void **state)
{
    (void)state;
    setup_model();
    assert_int_equal(bnn_post_init(&pa, &model), 0);
    float unknown[NQ];
    alloc_count_reset();
    assert_int_equal(bnn_post_observe(&pa, &model, pts, NPTS), 0);
    assert_int_equal(bnn_post_predict(&pa, &model, qry, NQ, NULL, unknown), 0);
    assert_int_equal(alloc_count_allocations(), 0);
    float bad[2] = {NAN, 0.0f};
    assert_int_equal(bnn_post_observe(&pa, &model, bad, 1), -EINVAL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_precision_and_variance_match_dense_reference),
        cmocka_unit_test(test_fleet_sum_and_consensus),
        cmocka_unit_test(test_consensus_while_the_data_grow),
        cmocka_unit_test(test_wire_round_trip_and_refusals),
        cmocka_unit_test(test_state_form_and_mixing),
        cmocka_unit_test(test_no_allocation),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
