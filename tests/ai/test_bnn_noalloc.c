/* Steady state allocates nothing: a full training step at the preset's maximum batch (the
 * largest GEMMs, so Eigen's blocking buffers are at their biggest), DiNNO-style
 * loss_grad + adam steps, MC inference, validation and the int8 pass, counted with the wrapped
 * allocator, on every GEMM kernel this CPU runs (each packed kernel, Eigen alone, the pure-C
 * reference) and every int8 kernel. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "ai/ai_rng.h"
#include "ai/bnn.h"
#include "ai/bnn_quant.h"
#include "ai/kernels/la.h"
#include "ai/kernels/la_packed.h"
#include "ai/kernels/q8_gemm.h"

static bnn_model_t model;
static ai_sample_t batch[BNN_MAX_BATCH];
static float xy[2 * (BNN_MAX_BATCH + 17)], mean[BNN_MAX_BATCH + 17], sd[BNN_MAX_BATCH + 17];
static uint8_t qstate[BNN_QUANT_MAX_BYTES];

/* One steady-state round on the math the process is set to; returns its allocations. */
static void steady_state(const char *what)
{
    float u[3 * BNN_MAX_BATCH];
    ai_rng_uniform_fill(1, 1, 0, u, 3 * BNN_MAX_BATCH);
    for (size_t i = 0; i < BNN_MAX_BATCH; i++) {
        batch[i] = (ai_sample_t){2 * u[3 * i] - 1, 2 * u[3 * i + 1] - 1, u[3 * i + 2] > 0.5f};
        xy[2 * i] = batch[i].x;
        xy[2 * i + 1] = batch[i].y;
    }
    for (size_t i = BNN_MAX_BATCH; i < BNN_MAX_BATCH + 17; i++)
        xy[2 * i] = xy[2 * i + 1] = 0.25f;
    size_t qlen = 0;
    alloc_count_reset();
    assert_int_equal(bnn_init(&model, NULL, 3), 0);
    bnn_loss_t L;
    assert_int_equal(bnn_train_step(&model, batch, BNN_MAX_BATCH, 1e-4f, 1, 1e-3f, &L), 0);
    assert_int_equal(bnn_loss_grad(&model, batch, BNN_MAX_BATCH, 1e-4f, 2, &L), 0);
    bnn_grads(&model)[0] += 1.0f; /* the caller adds its own terms */
    assert_int_equal(bnn_adam_step(&model, BNN_GROUP_MU, 1e-3f), 0);
    assert_int_equal(bnn_adam_step(&model, BNN_GROUP_RHO, 1e-3f), 0);
    bnn_adam_reset(&model, BNN_GROUP_MU);
    /* more points than a batch: chunked inference */
    assert_int_equal(bnn_predict_mc(&model, xy, BNN_MAX_BATCH + 17, 3, 5, mean, sd), 0);
    float bce;
    assert_int_equal(bnn_eval_bce(&model, batch, BNN_MAX_BATCH, 0, 0, &bce), 0);
    assert_int_equal(bnn_eval_bce(&model, batch, BNN_MAX_BATCH, 2, 0, &bce), 0);
    assert_int_equal(bnn_quant_pack(&model, BNN_GROUP_ALL, qstate, sizeof qstate, &qlen), 0);
    assert_int_equal(bnn_quant_forward_mean(&model.cfg, BNN_GROUP_ALL, qstate, qlen, xy,
                                            BNN_MAX_BATCH, mean),
                     0);
    print_message("preset %s, %s (kernel %s, int8 %s), batch %u: %llu allocations, %llu frees\n",
                  BNN_PRESET_NAME, what, la_kernel_name(), q8_kernel_name(), BNN_MAX_BATCH,
                  (unsigned long long)alloc_count_allocations(),
                  (unsigned long long)alloc_count_frees());
    assert_int_equal(alloc_count_allocations(), 0);
    assert_int_equal(alloc_count_frees(), 0);
}

static void test_no_allocation_in_steady_state(void **state)
{
    (void)state;
    steady_state("default choice");
    assert_true(bnn_get_buffer_size() == BNN_ARENA_BYTES);
    assert_true(sizeof(bnn_model_t) >= BNN_ARENA_BYTES);
}

/* The same on every kernel the CPU can run, fp32 and int8 alike. */
static void test_every_kernel(void **state)
{
    (void)state;
    int ran = 0;
    for (int id = 0; id < LA_PACKED_N; id++) {
        if (!la_packed_cpu_has(id) || la_packed_force(id) != 0)
            continue;
        steady_state(la_packed_kernels[id].name);
        ran++;
    }
    assert_int_equal(la_packed_force(-1), 0); /* no packed kernel: Eigen or the reference */
    steady_state("no packed kernel");
    la_force_ref(1);
    steady_state("pure-C reference");
    la_force_ref(0);
    assert_int_equal(la_packed_force(-2), 0);
    for (int id = 0; id < Q8_N; id++) {
        if (!q8_cpu_has(id) || q8_force(id) != 0)
            continue;
        steady_state(q8_kernels[id].name);
        ran++;
    }
    assert_int_equal(q8_force(Q8_AUTO), 0);
    print_message("%d kernels of this CPU checked\n", ran);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_no_allocation_in_steady_state),
        cmocka_unit_test(test_every_kernel),
    };
    return cmocka_run_group_tests_name("ai/bnn_noalloc", tests, NULL, NULL);
}
