/* The bf16 product (firmware/ai/kernels/la_bf16.h) and the bf16 training step.
 *
 * - la_bf16_round: nearest-even, subnormals to signed zero, NaN quiet, overflow to inf.
 * - the reference's rounding chain on hand-made cases whose result tells the orders apart
 *   (odd element first, each add rounded, FTZ), and on random cases within the bound of its
 *   fp32 summation around the exact sum of the bf16-rounded products.
 * - every fast kernel this CPU runs against the reference, bit for bit, on odd shapes (M, N, K
 *   not multiples of the tile, the k blocks or a pair; K = 0, 1; one row, one column), all
 *   four transposes, padded strides, every epilogue, operands over 2^-70 .. 2^20 (so products
 *   underflow and FTZ matters), C poisoned with NaN (never read); no allocation.
 * - the bf16 step: with the fast kernel and with the reference the same bits; its loss falls;
 *   it tracks the fp32 step; inference of a bf16 model is fp32's bit for bit.
 * A kernel this build or CPU lacks is reported as skipped. */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <float.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "ai/ai_rng.h"
#include "ai/bnn.h"
#include "ai/kernels/la.h"
#include "ai/kernels/la_bf16.h"

static uint32_t bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

static float from_bits(uint32_t u)
{
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

static void test_round(void **state)
{
    (void)state;
    assert_int_equal(la_bf16_round(1.0f), 0x3F80);
    assert_int_equal(la_bf16_round(from_bits(0x3F808000u)), 0x3F80); /* tie, even below */
    assert_int_equal(la_bf16_round(from_bits(0x3F818000u)), 0x3F82); /* tie, even above */
    assert_int_equal(la_bf16_round(from_bits(0x3F808001u)), 0x3F81);
    assert_int_equal(la_bf16_round(from_bits(0xBF807FFFu)), 0xBF80);
    assert_int_equal(la_bf16_round(from_bits(0x00400000u)), 0x0000); /* subnormal */
    assert_int_equal(la_bf16_round(from_bits(0x80000001u)), 0x8000);
    assert_int_equal(la_bf16_round(from_bits(0x00800000u)), 0x0080); /* FLT_MIN stays */
    assert_int_equal(la_bf16_round(from_bits(0x7F7FFFFFu)), 0x7F80); /* FLT_MAX rounds to inf */
    assert_int_equal(la_bf16_round(INFINITY), 0x7F80);
    assert_int_equal(la_bf16_round(from_bits(0x7F800001u)), 0x7FC0); /* sNaN -> qNaN */
    assert_true(la_bf16_widen(0x3F82) == 1.015625f);
}

/* One element by the reference: C = A[1 x K] B[K x 1]. */
static float dot_ref(const float *a, const float *b, int K)
{
    float c = NAN;
    la_bf16_gemm_ref(LA_NO_TRANS, LA_NO_TRANS, 1, 1, K, a, K, b, 1, &c, 1, NULL);
    return c;
}

static void test_ref_chain(void **state)
{
    (void)state;
    /* products 1, 0, 2^-23, 2^-24: pair 1 adds 2^-24 (a tie: stays 1) before 2^-23, which
     * gives 1 + 2^-23. Even first would give 1 + 2^-22, one rounding per pair 1 + 2^-23 + 2^-24
     * rounded (1 + 2^-22) */
    const float a[4] = {1.0f, 0.0f, ldexpf(1, -12), ldexpf(1, -12)};
    const float b[4] = {1.0f, 0.0f, ldexpf(1, -11), ldexpf(1, -12)};
    assert_true(dot_ref(a, b, 4) == 1.0f + ldexpf(1, -23));
    /* products below FLT_MIN flush to a zero of their sign */
    const float t[2] = {ldexpf(1, -70), ldexpf(-1, -70)};
    float c = dot_ref(t, t, 1);
    assert_true(c == 0.0f && !signbit(c));
    c = dot_ref(t, t + 1, 1);
    assert_true(c == 0.0f && signbit(c));
    /* operands are rounded first: (1 + 2^-9)^2 would be exact in fp32, bf16 takes 1 */
    const float r[1] = {1.0f + ldexpf(1, -9)};
    assert_true(dot_ref(r, r, 1) == 1.0f);
    /* odd K: the missing element adds nothing */
    const float o[3] = {2.0f, 3.0f, 5.0f};
    assert_true(dot_ref(o, o, 3) == 38.0f);
}

#define MAXE (1100 * 600)
static float A[MAXE], B[MAXE], Cr[MAXE], Ck[MAXE];
static float bias_[2048], gate_[MAXE], cs_r[2048], cs_k[2048];

/* Uniform in [-1, 1]; with wide != 0 every 8th value scaled by 2^-70 .. 2^20, so that products
 * cover FTZ, cancellation and large ranges. */
static void fill(float *x, size_t n, uint64_t s, int wide)
{
    ai_rng_uniform_fill(29, s, 0, x, n);
    for (size_t i = 0; i < n; i++) {
        float v = 2.0f * x[i] - 1.0f;
        if (wide && (i * 2654435761u >> 7) % 8 == 0)
            v = ldexpf(v, (int)((i * 40503u + s) % 91) - 70);
        x[i] = v;
    }
}

/* The reference within its bound: |C - sum bf(a) bf(b)| <= (K + 1) u sum |bf(a) bf(b)|. */
static void test_ref_bound(void **state)
{
    (void)state;
    const int M = 13, N = 37, K = 301;
    fill(A, (size_t)M * K, 1, 0);
    fill(B, (size_t)K * N, 2, 0);
    la_bf16_gemm_ref(LA_NO_TRANS, LA_NO_TRANS, M, N, K, A, K, B, N, Cr, N, NULL);
    const double u = ldexp(1.0, -24);
    for (int i = 0; i < M; i++)
        for (int j = 0; j < N; j++) {
            double s = 0.0, mag = 0.0;
            for (int k = 0; k < K; k++) {
                const double p = (double)la_bf16_widen(la_bf16_round(A[i * K + k])) *
                                 la_bf16_widen(la_bf16_round(B[k * N + j]));
                s += p;
                mag += fabs(p);
            }
            assert_true(fabs(Cr[i * N + j] - s) <= (K + 1) * u * mag);
        }
}

typedef struct shape {
    int M, N, K;
} shape_t;

/* The tile is 12 x 32, the k blocks 256 (128 pairs), the row blocks 96, the column blocks 256. */
static const shape_t shapes[] = {
    {1, 1, 1},      {1, 1, 0},      {2, 3, 1},       {12, 32, 2},     {13, 33, 3},
    {11, 31, 17},   {24, 64, 16},   {25, 65, 255},   {96, 96, 256},   {97, 97, 257},
    {100, 40, 513}, {37, 300, 33},  {5, 257, 64},    {192, 31, 31},   {7, 1, 129},
    {1, 70, 1024},  {130, 129, 127}, {64, 128, 1024}, {1024, 64, 128}, {1024, 128, 64},
    {49, 17, 511},  {12, 288, 258},
};

/* kernel id on one case against the reference, bit for bit; ep kind 0 none, 1 bias + ReLU,
 * 2 gate + column sums, 3 all four. */
static void one_case(int id, int ta, int tb, shape_t s, int kind, uint64_t seed)
{
    const int M = s.M, N = s.N, K = s.K;
    const int lda = (ta ? M : K) + (int)(seed % 3), ldb = (tb ? K : N) + (int)(seed % 2);
    const int ldc = N + (int)(seed % 4), ldg = N + 1;
    const size_t na = (size_t)(ta ? K : M) * lda + 1, nb = (size_t)(tb ? N : K) * ldb + 1;
    assert_true(na <= MAXE && nb <= MAXE && (size_t)M * ldc <= MAXE && (size_t)M * ldg <= MAXE &&
                N <= 2048);
    fill(A, na, 7 * seed, 1);
    fill(B, nb, 7 * seed + 1, 1);
    fill(bias_, (size_t)N, 7 * seed + 2, 0);
    fill(gate_, (size_t)M * ldg, 7 * seed + 3, 0);
    fill(cs_r, (size_t)N, 7 * seed + 4, 0);
    memcpy(cs_k, cs_r, sizeof(float) * (size_t)N);
    for (size_t i = 0; i < (size_t)M * ldc; i++)
        Cr[i] = Ck[i] = NAN; /* beta is 0: C must not be read */
    la_epilogue_t er = {kind & 1 ? bias_ : NULL, kind & 1, kind & 2 ? gate_ : NULL, ldg,
                        kind & 2 ? cs_r : NULL};
    la_epilogue_t ek = er;
    ek.colsum = kind & 2 ? cs_k : NULL;
    la_bf16_gemm_ref(ta, tb, M, N, K, A, lda, B, ldb, Cr, ldc, kind ? &er : NULL);
    assert_int_equal(la_bf16_force(id), 0);
    alloc_count_reset();
    la_bf16_gemm(ta, tb, M, N, K, A, lda, B, ldb, Ck, ldc, kind ? &ek : NULL);
    assert_int_equal(alloc_count_allocations(), 0);
    for (int i = 0; i < M; i++)
        for (int j = 0; j < N; j++) {
            const uint32_t r = bits(Cr[(size_t)i * ldc + j]), k = bits(Ck[(size_t)i * ldc + j]);
            if (r != k)
                print_message("ta %d tb %d M %d N %d K %d ep %d (%d,%d): %08x vs ref %08x\n", ta,
                              tb, M, N, K, kind, i, j, (unsigned)k, (unsigned)r);
            assert_int_equal(k, r);
        }
    assert_memory_equal(cs_k, cs_r, sizeof(float) * (size_t)N);
}

static void test_kernels_vs_ref(void **state)
{
    (void)state;
    for (int id = 0; id < LA_BF16_N; id++) {
        if (id == LA_BF16_REF)
            continue;
        if (!la_bf16_cpu_has(id)) {
            print_message("bf16 kernel %d: skipped (this build or CPU lacks AVX512_BF16)\n", id);
            assert_int_equal(la_bf16_force(id), -ENOTSUP);
            continue;
        }
        int n = 0;
        for (size_t s = 0; s < sizeof shapes / sizeof shapes[0]; s++)
            for (int t = 0; t < 4; t++, n++)
                one_case(id, t & 1, t >> 1, shapes[s], (int)((s + (size_t)t) % 4),
                         (uint64_t)(100 + n));
        print_message("%s: %d cases bit-identical to the reference\n", la_bf16_kernel_name(), n);
    }
    assert_int_equal(la_bf16_force(LA_BF16_AUTO), 0);
}

static void test_choice(void **state)
{
    (void)state;
    assert_int_equal(la_bf16_force(LA_BF16_REF), 0);
    assert_string_equal(la_bf16_kernel_name(), "ref-c");
    assert_int_equal(la_bf16_force(LA_BF16_AUTO), 0);
    assert_string_equal(la_bf16_kernel_name(),
                        la_bf16_cpu_has(LA_BF16_AVX512) ? "avx512bf16-12x32" : "ref-c");
    print_message("bf16 kernel in use: %s\n", la_bf16_kernel_name());
}

/* ---- the training step ------------------------------------------------------------------- */
static bnn_model_t m1, m2;
#define NB 256
static ai_sample_t batch[NB];

/* a disc of occupied points in the square: learnable, not trivial */
static void make_batch(uint64_t seed)
{
    float u[2 * NB];
    ai_rng_uniform_fill(seed, 11, 0, u, 2 * NB);
    for (int i = 0; i < NB; i++) {
        const float x = 2.0f * u[2 * i] - 1.0f, y = 2.0f * u[2 * i + 1] - 1.0f;
        batch[i] = (ai_sample_t){x, y, x * x + y * y < 0.3f ? 1.0f : 0.0f};
    }
}

static bnn_config_t step_config(uint32_t precision)
{
    bnn_config_t c = bnn_default_config();
    c.siren_width = c.siren_width < 48 ? c.siren_width : 48; /* odd multiples of nothing */
    c.hidden_width = c.hidden_width < 40 ? c.hidden_width : 40;
    c.n_bayes = 2;
    c.max_batch = NB < c.max_batch ? NB : c.max_batch;
    c.w0 = 3.0f;
    c.precision = precision;
    return c;
}

static void test_step_kernel_equals_ref(void **state)
{
    (void)state;
    if (!la_bf16_cpu_has(LA_BF16_AVX512)) {
        print_message("skipped: no fast bf16 kernel here\n");
        return;
    }
    const bnn_config_t c = step_config(BNN_PRECISION_BF16);
    const size_t n = c.max_batch;
    assert_int_equal(bnn_init(&m1, &c, 5), 0);
    assert_int_equal(bnn_init(&m2, &c, 5), 0);
    for (int s = 0; s < 5; s++) {
        make_batch((uint64_t)s);
        assert_int_equal(la_bf16_force(LA_BF16_AVX512), 0);
        assert_int_equal(bnn_train_step(&m1, batch, n, 1e-3f, (uint64_t)s, 3e-3f, NULL), 0);
        assert_int_equal(la_bf16_force(LA_BF16_REF), 0);
        assert_int_equal(bnn_train_step(&m2, batch, n, 1e-3f, (uint64_t)s, 3e-3f, NULL), 0);
    }
    assert_int_equal(la_bf16_force(LA_BF16_AUTO), 0);
    assert_memory_equal(bnn_params(&m1), bnn_params(&m2), sizeof(float) * bnn_n_params(&m1));
    assert_memory_equal(bnn_grads(&m1), bnn_grads(&m2), sizeof(float) * bnn_n_params(&m1));
}

/* train 300 steps at each precision from the same start: bf16's loss falls like fp32's */
static void test_step_learns(void **state)
{
    (void)state;
    const int steps = 300;
    float first[2] = {0}, last[2] = {0}, val[2] = {0};
    for (int p = 0; p < 2; p++) {
        const bnn_config_t c = step_config(p ? BNN_PRECISION_BF16 : BNN_PRECISION_FP32);
        const size_t n = c.max_batch;
        assert_int_equal(bnn_init(&m1, &c, 9), 0);
        for (int s = 0; s < steps; s++) {
            bnn_loss_t L;
            make_batch((uint64_t)s);
            assert_int_equal(bnn_train_step(&m1, batch, n, 1e-3f, (uint64_t)s, 3e-3f, &L), 0);
            assert_true(isfinite(L.total));
            if (s < 10)
                first[p] += L.bce / 10.0f;
            if (s >= steps - 10)
                last[p] += L.bce / 10.0f;
        }
        make_batch(999);
        assert_int_equal(bnn_eval_bce(&m1, batch, n, 0, 0, &val[p]), 0);
    }
    print_message("bce first/last 10 steps: fp32 %.4f -> %.4f, bf16 %.4f -> %.4f; held-out fp32 "
                  "%.4f bf16 %.4f\n",
                  first[0], last[0], first[1], last[1], val[0], val[1]);
    assert_true(last[1] < 0.5f * first[1]);
    assert_true(fabsf(val[1] - val[0]) <= 0.1f * val[0] + 0.01f);
}

/* inference ignores the precision: the same weights give the same logits */
static void test_inference_fp32(void **state)
{
    (void)state;
    bnn_config_t c = step_config(BNN_PRECISION_BF16);
    assert_int_equal(bnn_init(&m1, &c, 3), 0);
    c.precision = BNN_PRECISION_FP32;
    assert_int_equal(bnn_init(&m2, &c, 3), 0);
    make_batch(1);
    assert_int_equal(bnn_train_step(&m1, batch, c.max_batch, 1e-3f, 1, 3e-3f, NULL), 0);
    memcpy(bnn_params(&m2), bnn_params(&m1), sizeof(float) * bnn_n_params(&m1));
    float xy[2 * 64], l1[64], l2[64], e1, e2;
    for (int i = 0; i < 64; i++) {
        xy[2 * i] = batch[i].x;
        xy[2 * i + 1] = batch[i].y;
    }
    assert_int_equal(bnn_forward_logits(&m1, xy, 64, 0, 4, l1), 0);
    assert_int_equal(bnn_forward_logits(&m2, xy, 64, 0, 4, l2), 0);
    assert_memory_equal(l1, l2, sizeof l1);
    assert_int_equal(bnn_eval_bce(&m1, batch, 64, 0, 0, &e1), 0);
    assert_int_equal(bnn_eval_bce(&m2, batch, 64, 0, 0, &e2), 0);
    assert_true(bits(e1) == bits(e2));
    c.precision = 7;
    assert_int_equal(bnn_init(&m2, &c, 3), -EINVAL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round),
        cmocka_unit_test(test_ref_chain),
        cmocka_unit_test(test_ref_bound),
        cmocka_unit_test(test_kernels_vs_ref),
        cmocka_unit_test(test_choice),
        cmocka_unit_test(test_step_kernel_equals_ref),
        cmocka_unit_test(test_step_learns),
        cmocka_unit_test(test_inference_fp32),
    };
    return cmocka_run_group_tests_name("ai/la_bf16", tests, NULL, NULL);
}
