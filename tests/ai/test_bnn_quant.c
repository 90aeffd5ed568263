/* Int8 quantisation: per-element round-trip bound |x - deq(q(x))| <= scale/2 for every
 * group, packed sizes and bytes saved, rejection of bad buffers, and the validation-loss
 * change of (a) the dequantised fp32 model and (b) the int8 x int8 inference path, on the
 * learning test's room data after a short training run. */
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
#include "ai/bnn_quant.h"

#ifdef __SANITIZE_ADDRESS__
#define STEPS 200
#else
#define STEPS 800
#endif
#define N_TRAIN 4096
#define N_VAL 2048
#define BATCH 256

static bnn_model_t m, mq;
static ai_sample_t train[N_TRAIN], val[N_VAL], batch[BATCH];
static uint8_t packed[BNN_QUANT_MAX_BYTES];
static float xy[2 * N_VAL], lg[N_VAL];

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

static void sample_region(ai_sample_t *out, size_t n, uint64_t stream)
{
    static float u[2 * N_TRAIN];
    ai_rng_uniform_fill(2024, stream, 0, u, 2 * n);
    for (size_t i = 0; i < n; i++) {
        out[i].x = -1.0f + 1.1f * u[2 * i];
        out[i].y = -1.0f + 2.0f * u[2 * i + 1];
        out[i].occ = room_label(out[i].x, out[i].y);
    }
}

static bnn_config_t cfg(void)
{
    bnn_config_t c = bnn_default_config();
    c.siren_width = c.siren_width < 128 ? c.siren_width : 128;
    c.hidden_width = c.hidden_width < 64 ? c.hidden_width : 64;
    c.n_bayes = c.n_bayes < 3 ? c.n_bayes : 3;
    c.max_batch = c.max_batch < BATCH ? c.max_batch : BATCH;
    return c;
}

static void test_round_trip_bound(void **state)
{
    (void)state;
    bnn_config_t c = cfg();
    assert_int_equal(bnn_init(&m, &c, 4), 0);
    /* spread the rho values so their rows are not constant */
    float *rho = bnn_params(&m) + bnn_group_offset(&m, BNN_GROUP_RHO);
    for (size_t j = 0; j < bnn_group_len(&m, BNN_GROUP_RHO); j++)
        rho[j] = -3.0f + 0.001f * (float)(j % 997);
    const bnn_group_t groups[] = {BNN_GROUP_MU, BNN_GROUP_RHO, BNN_GROUP_ALL};
    for (int gi = 0; gi < 3; gi++) {
        const bnn_group_t g = groups[gi];
        size_t n = 0;
        alloc_count_reset();
        assert_int_equal(bnn_quant_pack(&m, g, packed, sizeof packed, &n), 0);
        assert_int_equal(n, bnn_quant_packed_size(&m, g));
        assert_int_equal(bnn_init(&mq, &c, 4), 0);
        assert_int_equal(bnn_quant_unpack(&mq, g, packed, n), 0);
        assert_int_equal(alloc_count_allocations(), 0);
        bnn_tensor_t T[BNN_MAX_TENSORS];
        size_t nt = bnn_tensors(&m, T, BNN_MAX_TENSORS);
        double worst = 0.0;
        for (size_t t = 0; t < nt; t++) {
            if (g != BNN_GROUP_ALL && T[t].group != g)
                continue;
            size_t R = T[t].is_bias ? 1 : T[t].rows, C = T[t].is_bias ? T[t].cols : T[t].cols;
            for (size_t r = 0; r < R; r++) {
                const float *x = bnn_params(&m) + T[t].offset + r * C;
                const float *y = bnn_params(&mq) + T[t].offset + r * C;
                float amax = 0.0f;
                for (size_t k = 0; k < C; k++)
                    amax = fmaxf(amax, fabsf(x[k]));
                const float scale = amax / 127.0f;
                for (size_t k = 0; k < C; k++) {
                    double e = fabs((double)x[k] - y[k]);
                    assert_true(e <= 0.5 * scale * (1.0 + 1e-5) + 1e-30);
                    worst = e / (amax > 0 ? amax : 1) > worst ? e / (amax > 0 ? amax : 1) : worst;
                }
            }
        }
        size_t len = bnn_group_len(&m, g);
        print_message("group %d: %zu params, fp32 %zu B, int8 packed %zu B (saves %zu B, %.1f%%), "
                      "worst |err|/row max %.4f\n",
                      g, len, 4 * len, n, 4 * len - n, 100.0 * (4.0 * len - n) / (4.0 * len), worst);
        assert_true(worst <= 0.5 / 127.0 + 1e-6);
        /* bad buffers */
        assert_int_equal(bnn_quant_unpack(&mq, g, packed, n - 1), -EBADMSG);
        uint8_t keep[4];
        memcpy(keep, packed, 4);
        const float bad = NAN;
        memcpy(packed, &bad, 4);
        assert_int_equal(bnn_quant_unpack(&mq, g, packed, n), -EBADMSG);
        memcpy(packed, keep, 4);
        assert_int_equal(bnn_quant_pack(&m, g, packed, n - 1, &n), -ENOSPC);
    }
}

/* The in-place unpack (the GP core's, into its reassembly buffer) gives bnn_quant_unpack_theta's
 * floats bit for bit, refuses what it refuses before moving anything, and needs room for the
 * scales only. */
static void test_unpack_in_place(void **state)
{
    (void)state;
    bnn_config_t c = cfg();
    assert_int_equal(bnn_init(&m, &c, 5), 0);
    float *th = bnn_params(&m);
    const size_t P = bnn_n_params(&m);
    for (size_t j = 0; j < P; j++)
        th[j] += 0.01f * (float)((int)(j % 251) - 125);
    size_t n = 0;
    assert_int_equal(bnn_quant_pack(&m, BNN_GROUP_ALL, packed, sizeof packed, &n), 0);
    static float want[BNN_N_PARAMS], buf[BNN_N_PARAMS], scales[BNN_QUANT_MAX_ROWS];
    assert_int_equal(bnn_quant_unpack_theta(&c, BNN_GROUP_ALL, packed, n, want), 0);
    memcpy(buf, packed, n);
    alloc_count_reset();
    assert_int_equal(bnn_quant_unpack_theta_inplace(&c, buf, n, scales, BNN_QUANT_MAX_ROWS), 0);
    assert_int_equal(alloc_count_allocations(), 0);
    assert_memory_equal(buf, want, P * sizeof(float));
    /* refused, untouched: a bad length, a bad scale, too few scales */
    memcpy(buf, packed, n);
    assert_int_equal(bnn_quant_unpack_theta_inplace(&c, buf, n - 1, scales, BNN_QUANT_MAX_ROWS), -EBADMSG);
    const float bad = -1.0f;
    memcpy((uint8_t *)buf + 4, &bad, 4);
    assert_int_equal(bnn_quant_unpack_theta_inplace(&c, buf, n, scales, BNN_QUANT_MAX_ROWS), -EBADMSG);
    memcpy(buf, packed, n);
    assert_int_equal(bnn_quant_unpack_theta_inplace(&c, buf, n, scales, 3), -EINVAL);
    assert_memory_equal(buf, packed, n);
}

static void test_validation_loss_change(void **state)
{
    (void)state;
    sample_region(train, N_TRAIN, 1);
    sample_region(val, N_VAL, 2);
    bnn_config_t c = cfg();
    assert_int_equal(bnn_init(&m, &c, 6), 0);
    float u[BATCH];
    for (int s = 0; s < STEPS; s++) {
        ai_rng_uniform_fill(6, 100 + (uint64_t)s, 0, u, c.max_batch);
        for (size_t i = 0; i < c.max_batch; i++)
            batch[i] = train[(size_t)(u[i] * N_TRAIN) % N_TRAIN];
        assert_int_equal(bnn_train_step(&m, batch, c.max_batch, 1e-4f, (uint64_t)s, 3e-3f, NULL), 0);
    }
    float bce32, bceq;
    assert_int_equal(bnn_eval_bce(&m, val, N_VAL, 0, 0, &bce32), 0);
    size_t n = 0;
    assert_int_equal(bnn_quant_pack(&m, BNN_GROUP_MU, packed, sizeof packed, &n), 0);
    memcpy(&mq, &m, sizeof m);
    assert_int_equal(bnn_quant_unpack(&mq, BNN_GROUP_MU, packed, n), 0);
    assert_int_equal(bnn_eval_bce(&mq, val, N_VAL, 0, 0, &bceq), 0);
    for (size_t i = 0; i < N_VAL; i++) {
        xy[2 * i] = val[i].x;
        xy[2 * i + 1] = val[i].y;
    }
    alloc_count_reset();
    assert_int_equal(bnn_quant_forward_mean(&c, BNN_GROUP_MU, packed, n, xy, N_VAL, lg), 0);
    assert_int_equal(alloc_count_allocations(), 0);
    double s8 = 0.0;
    for (size_t i = 0; i < N_VAL; i++) {
        double l = lg[i], t = val[i].occ;
        s8 += (l > 0 ? l : 0) - l * t + log1p(exp(-fabs(l)));
    }
    const float bce8 = (float)(s8 / N_VAL);
    const size_t fp = 4 * bnn_group_len(&m, BNN_GROUP_MU);
    print_message("validation BCE (mean weights, %d points): fp32 %.5f, dequantised int8 %.5f "
                  "(change %+.5f), int8 x int8 path %.5f (change %+.5f); mu group %zu B -> %zu B "
                  "(saves %zu B)\n",
                  N_VAL, bce32, bceq, bceq - bce32, bce8, bce8 - bce32, fp, n, fp - n);
    assert_true(fabsf(bceq - bce32) < 0.02f);
    assert_true(fabsf(bce8 - bce32) < 0.03f);
    assert_int_equal(bnn_quant_forward_mean(&c, BNN_GROUP_MU, packed, n - 1, xy, 1, lg), -EBADMSG);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip_bound),
        cmocka_unit_test(test_unpack_in_place),
        cmocka_unit_test(test_validation_loss_change),
    };
    return cmocka_run_group_tests_name("ai/bnn_quant", tests, NULL, NULL);
}
