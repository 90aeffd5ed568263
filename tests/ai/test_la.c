/* LA back ends: la_ref_sgemm against a double-precision triple loop, and (when the Eigen
 * shim is built) la_eigen_sgemm against la_ref_sgemm, relative 1e-5, on random shapes, all
 * four transpose combinations, padded leading dimensions, alpha/beta cases. Neither
 * allocates. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "ai/ai_rng.h"
#include "ai/kernels/la.h"

#define MAXD 300
static float A[MAXD * (MAXD + 3)], B[MAXD * (MAXD + 3)], C0[MAXD * (MAXD + 5)];
static float Cr[MAXD * (MAXD + 5)], Ce[MAXD * (MAXD + 5)];
static double Cd[MAXD * (MAXD + 5)];

static void fill(float *x, size_t n, uint64_t s)
{
    ai_rng_uniform_fill(11, s, 0, x, n);
    for (size_t i = 0; i < n; i++)
        x[i] = 2.0f * x[i] - 1.0f;
}

/* max |x - y| / (max |y| over the matrix) */
static double rel_err_f(const float *x, const float *y, int M, int N, int ld)
{
    double num = 0.0, den = 0.0;
    for (int i = 0; i < M; i++)
        for (int j = 0; j < N; j++) {
            double d = fabs((double)x[i * ld + j] - y[i * ld + j]);
            num = d > num ? d : num;
            den = fabs(y[i * ld + j]) > den ? fabs(y[i * ld + j]) : den;
        }
    return num / (den > 0 ? den : 1.0);
}

static void one_case(int ta, int tb, int M, int N, int K, float alpha, float beta, uint64_t s)
{
    const int lda = (ta ? M : K) + (int)(s % 3), ldb = (tb ? K : N) + (int)(s % 2);
    const int ldc = N + (int)(s % 4);
    fill(A, (size_t)(ta ? K : M) * lda, 3 * s);
    fill(B, (size_t)(tb ? N : K) * ldb, 3 * s + 1);
    fill(C0, (size_t)M * ldc, 3 * s + 2);
    double dmax = 0.0;
    for (int i = 0; i < M; i++)
        for (int j = 0; j < N; j++) {
            double acc = 0.0;
            for (int k = 0; k < K; k++) {
                double a = ta ? A[k * lda + i] : A[i * lda + k];
                double b = tb ? B[j * ldb + k] : B[k * ldb + j];
                acc += a * b;
            }
            Cd[i * ldc + j] = alpha * acc + (beta != 0.0f ? beta * (double)C0[i * ldc + j] : 0.0);
            dmax = fabs(Cd[i * ldc + j]) > dmax ? fabs(Cd[i * ldc + j]) : dmax;
        }
    memcpy(Cr, C0, sizeof(float) * (size_t)M * ldc);
    if (beta == 0.0f) /* beta == 0 must not read C: poison it */
        for (int i = 0; i < M * ldc; i++)
            Cr[i] = NAN;
    memcpy(Ce, Cr, sizeof(float) * (size_t)M * ldc);
    alloc_count_reset();
    la_ref_sgemm(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, Cr, ldc);
    double e_ref = 0.0;
    for (int i = 0; i < M; i++)
        for (int j = 0; j < N; j++) {
            double d = fabs(Cr[i * ldc + j] - Cd[i * ldc + j]);
            e_ref = d > e_ref ? d : e_ref;
        }
    e_ref /= (dmax > 0 ? dmax : 1.0);
    assert_true(e_ref < 1e-5 * (1.0 + sqrt((double)K) / 4.0));
#if defined(LA_BACKEND_EIGEN)
    la_eigen_sgemm(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, Ce, ldc);
    double e = rel_err_f(Ce, Cr, M, N, ldc);
    if (e >= 1e-5)
        print_message("ta %d tb %d M %d N %d K %d: eigen vs ref %.3e\n", ta, tb, M, N, K, e);
    assert_true(e < 1e-5);
#else
    (void)Ce;
    (void)rel_err_f;
#endif
    assert_int_equal(alloc_count_allocations(), 0);
}

static void test_backends_agree(void **state)
{
    (void)state;
    float u[3 * 64];
    ai_rng_uniform_fill(5, 5, 0, u, 3 * 64);
    int cases = 0;
    for (int c = 0; c < 64; c++) {
        int M = 1 + (int)(u[3 * c] * 130), N = 1 + (int)(u[3 * c + 1] * 130);
        int K = 1 + (int)(u[3 * c + 2] * 300);
        for (int ta = 0; ta < 2; ta++)
            for (int tb = 0; tb < 2; tb++) {
                float alpha = (c % 3 == 0) ? -0.5f : 1.0f;
                float beta = (c % 4 == 0) ? 0.0f : ((c % 4 == 1) ? 1.0f : 0.25f);
                one_case(ta, tb, M, N, K, alpha, beta, (uint64_t)(c * 4 + ta * 2 + tb));
                cases++;
            }
    }
    /* the network's own shapes, including the big ones */
    /* 290 x 280 x 296: several row, column and depth blocks of the AVX2 kernel, ragged edges */
    const int shapes[][3] = {{256, 256, 256}, {290, 280, 296}, {1, 256, 300}, {256, 1, 256},
                             {7, 1, 1}, {300, 2, 1}};
    for (size_t s = 0; s < sizeof shapes / sizeof shapes[0]; s++)
        for (int ta = 0; ta < 2; ta++)
            for (int tb = 0; tb < 2; tb++) {
                one_case(ta, tb, shapes[s][0], shapes[s][1], shapes[s][2], 1.0f, 0.0f,
                         (uint64_t)(1000 + s * 4 + ta * 2 + tb));
                cases++;
            }
    print_message("%d GEMM cases checked (back end in use: %s)\n", cases, la_backend_name());
}

static void test_degenerate(void **state)
{
    (void)state;
    float c[4] = {1, 2, 3, 4};
    la_sgemm(LA_NO_TRANS, LA_NO_TRANS, 2, 2, 0, 1.0f, A, 1, B, 2, 0.5f, c, 2);
    assert_true(c[0] == 0.5f && c[3] == 2.0f);
    la_ref_sgemm(LA_NO_TRANS, LA_NO_TRANS, 2, 2, 0, 1.0f, A, 1, B, 2, 0.0f, c, 2);
    assert_true(c[0] == 0.0f && c[3] == 0.0f);
    la_sgemm(LA_NO_TRANS, LA_NO_TRANS, 0, 2, 3, 1.0f, A, 3, B, 2, 0.0f, c, 2); /* no-op */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_backends_agree),
        cmocka_unit_test(test_degenerate),
    };
    return cmocka_run_group_tests_name("ai/la", tests, NULL, NULL);
}
