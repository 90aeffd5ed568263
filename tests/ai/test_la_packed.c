/* The packed GEMM kernels (firmware/ai/kernels/la_packed.h), each against a double-precision product
 * with the worst-case rounding bound of its summation: per element
 *   |C - C_exact| <= (K + 2) * u * (|alpha| * sum_k |a_ik b_kj| + |beta c_ij|),  u = 2^-24
 * (K FMAs in sequence, then the alpha scale and the beta term: Higham's gamma_n bound with
 * n = K + 2, first order). Shapes: random ones, the network's, and the edges of the tiles
 * (M, N, K not multiples of the tile or the blocks, one row, one column, K = 1), in all four
 * transpose cases with padded strides; beta = 0 must not read C (it is poisoned with NaN).
 * The kernels of one build must agree bit for bit (same summation order), and none allocates.
 * The epilogues (bias, ReLU, gate, column sums) must give the bits of a plain pass over the
 * product, la_sgemm_ep the same on whatever back end it takes.
 * A kernel this build or this CPU cannot run is reported as skipped, with the reason. */
#include <errno.h>
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
#include "ai/kernels/la_packed.h"

/* floats per operand: the largest case is 512 x 64 x 1024 (A is 512 x 1026 with its padding) */
#define MAXE (1100 * 600)
static float A[MAXE], B[MAXE], C0[MAXE], Ck[MAXE];
static float Cfirst[MAXE]; /* the first runnable kernel's result, for bit identity */

static void fill(float *x, size_t n, uint64_t s)
{
    ai_rng_uniform_fill(13, s, 0, x, n);
    for (size_t i = 0; i < n; i++)
        x[i] = 2.0f * x[i] - 1.0f;
}

/* Runs kernel fn on one case and checks every element against the bound. Returns the largest
 * error as a fraction of its bound (must be <= 1). */
static double one_case(la_packed_fn fn, int ta, int tb, int M, int N, int K, float alpha,
                       float beta, uint64_t s)
{
    const int lda = (ta ? M : K) + (int)(s % 3), ldb = (tb ? K : N) + (int)(s % 2);
    const int ldc = N + (int)(s % 4);
    assert_true((size_t)(ta ? K : M) * (size_t)lda <= MAXE && (size_t)(tb ? N : K) * (size_t)ldb <= MAXE &&
                (size_t)M * (size_t)ldc <= MAXE);
    fill(A, (size_t)(ta ? K : M) * (size_t)lda, 3 * s);
    fill(B, (size_t)(tb ? N : K) * (size_t)ldb, 3 * s + 1);
    fill(C0, (size_t)M * (size_t)ldc, 3 * s + 2);
    memcpy(Ck, C0, sizeof(float) * (size_t)M * (size_t)ldc);
    if (beta == 0.0f)
        for (int i = 0; i < M * ldc; i++)
            Ck[i] = NAN;
    alloc_count_reset();
    fn(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, Ck, ldc, NULL);
    assert_int_equal(alloc_count_allocations(), 0);
    const double u = ldexp(1.0, -24);
    double worst = 0.0;
    for (int i = 0; i < M; i++)
        for (int j = 0; j < N; j++) {
            double acc = 0.0, mag = 0.0;
            for (int k = 0; k < K; k++) {
                const double a = ta ? A[k * lda + i] : A[i * lda + k];
                const double b = tb ? B[j * ldb + k] : B[k * ldb + j];
                acc += a * b;
                mag += fabs(a * b);
            }
            const double c0 = beta != 0.0f ? (double)C0[i * ldc + j] : 0.0;
            const double exact = alpha * acc + beta * c0;
            const double bound = (K + 2) * u * (fabs(alpha) * mag + fabs(beta * c0)) + 1e-30;
            const double err = fabs((double)Ck[i * ldc + j] - exact);
            if (!(err <= bound))
                print_message("ta %d tb %d M %d N %d K %d (%d,%d): %.9g vs %.9g, bound %.3g\n", ta,
                              tb, M, N, K, i, j, Ck[i * ldc + j], exact, bound);
            assert_true(err <= bound);
            worst = err / bound > worst ? err / bound : worst;
        }
    return worst;
}

/* The epilogue as the plain loop la.h defines, on a finished product. */
static void epilogue_ref(int M, int N, float *C, int ldc, const la_epilogue_t *ep)
{
    for (int i = 0; i < M; i++)
        for (int j = 0; j < N; j++) {
            float v = C[i * ldc + j];
            if (ep->bias)
                v += ep->bias[j];
            if (ep->relu)
                v = v > 0.0f ? v : 0.0f;
            if (ep->gate)
                v = ep->gate[i * ep->ldg + j] > 0.0f ? v : 0.0f;
            if (ep->colsum)
                ep->colsum[j] += v;
            C[i * ldc + j] = v;
        }
}

static float bias_[MAXE / 100], gate_[MAXE], cs_ref[MAXE / 100], cs_k[MAXE / 100];
static float Cplain[MAXE];

/* fn with epilogue `kind` (0: bias + ReLU, 1: gate + column sums, 2: all four) against fn
 * without it followed by the plain loop: bit for bit. */
static void epilogue_case(la_packed_fn fn, int kind, int ta, int tb, int M, int N, int K,
                          uint64_t s)
{
    const int lda = ta ? M : K, ldb = tb ? K : N, ldc = N + 1, ldg = N + 2;
    assert_true((size_t)M * (size_t)ldg <= MAXE && (size_t)N <= MAXE / 100);
    fill(A, (size_t)(ta ? K : M) * (size_t)lda, 5 * s);
    fill(B, (size_t)(tb ? N : K) * (size_t)ldb, 5 * s + 1);
    fill(bias_, (size_t)N, 5 * s + 2);
    fill(gate_, (size_t)M * (size_t)ldg, 5 * s + 3);
    fill(cs_ref, (size_t)N, 5 * s + 4);
    memcpy(cs_k, cs_ref, sizeof(float) * (size_t)N);
    la_epilogue_t ep = {kind != 1 ? bias_ : NULL, kind != 1, kind != 0 ? gate_ : NULL, ldg,
                        NULL};
    fn(ta, tb, M, N, K, 1.0f, A, lda, B, ldb, 0.0f, Cplain, ldc, NULL);
    ep.colsum = kind != 0 ? cs_ref : NULL;
    epilogue_ref(M, N, Cplain, ldc, &ep);
    ep.colsum = kind != 0 ? cs_k : NULL;
    alloc_count_reset();
    fn(ta, tb, M, N, K, 1.0f, A, lda, B, ldb, 0.0f, Ck, ldc, &ep);
    assert_int_equal(alloc_count_allocations(), 0);
    for (int i = 0; i < M; i++)
        assert_memory_equal(Ck + (size_t)i * ldc, Cplain + (size_t)i * ldc, sizeof(float) * (size_t)N);
    if (kind != 0)
        assert_memory_equal(cs_k, cs_ref, sizeof(float) * (size_t)N);
}

/* The case list: every kernel runs exactly these. */
typedef struct { int M, N, K; float alpha, beta; } gcase_t;
#define NCASES 96
static gcase_t cases[NCASES];
static int n_cases;

static void make_cases(void)
{
    if (n_cases)
        return;
    /* edges of every tile (12x32, 6x16, 8x8) and block (KC = 256, MC = 96, NC = 256) */
    static const gcase_t fixed[] = {
        {1, 1, 1, 1.0f, 0.0f},      {1, 300, 257, 1.0f, 0.0f}, {300, 1, 257, 1.0f, 1.0f},
        {24, 32, 16, 1.0f, 0.0f},   {25, 33, 17, -0.5f, 0.25f}, {11, 31, 300, 1.0f, 1.0f},
        {97, 257, 513, 1.0f, 0.0f}, {193, 17, 255, 2.0f, 0.0f}, {13, 9, 1, 1.0f, 0.5f},
        {256, 256, 256, 1.0f, 0.0f}, {290, 280, 296, 1.0f, 0.0f}, {512, 64, 1024, 1.0f, 1.0f},
    };
    for (size_t i = 0; i < sizeof fixed / sizeof fixed[0]; i++)
        cases[n_cases++] = fixed[i];
    float r[3 * NCASES];
    ai_rng_uniform_fill(7, 7, 0, r, 3 * NCASES);
    for (int c = 0; n_cases < NCASES; c++) {
        const float alpha = c % 3 == 0 ? -0.5f : 1.0f;
        const float beta = c % 4 == 0 ? 0.0f : (c % 4 == 1 ? 1.0f : 0.25f);
        cases[n_cases++] = (gcase_t){1 + (int)(r[3 * c] * 140), 1 + (int)(r[3 * c + 1] * 140),
                                     1 + (int)(r[3 * c + 2] * 320), alpha, beta};
    }
}

static int first_kernel = -1; /* the first kernel that ran, whose results the others must match */

static void run_kernel(int id)
{
    const la_packed_kernel_t *k = &la_packed_kernels[id];
    if (!k->fn) {
        print_message("%s: not compiled for this target (needs %s)\n", k->name, k->isa);
        skip();
    }
    if (!la_packed_cpu_has(id)) {
        print_message("%s: this CPU lacks %s\n", k->name, k->isa);
        skip();
    }
    make_cases();
    double worst = 0.0;
    int identical = 1;
    for (int c = 0; c < n_cases; c++)
        for (int t = 0; t < 4; t++) {
            const gcase_t g = cases[c];
            const uint64_t s = (uint64_t)(c * 4 + t);
            const double w = one_case(k->fn, t >> 1, t & 1, g.M, g.N, g.K, g.alpha, g.beta, s);
            worst = w > worst ? w : worst;
            if (t == 0 || t == 3)
                epilogue_case(k->fn, c % 3, t >> 1, t & 1, cases[c].M, cases[c].N, cases[c].K,
                              (uint64_t)(c * 4 + t));
        }
    /* bit identity with the first kernel that ran, on a ragged case of several blocks */
    const gcase_t g = {290, 280, 296, 0.75f, 0.5f};
    one_case(k->fn, 1, 0, g.M, g.N, g.K, g.alpha, g.beta, 99); /* seed 99: ldc = N + 3 */
    if (first_kernel < 0) {
        first_kernel = id;
        memcpy(Cfirst, Ck, sizeof(float) * (size_t)g.M * (size_t)(g.N + 3));
    } else {
        identical = !memcmp(Cfirst, Ck, sizeof(float) * (size_t)g.M * (size_t)(g.N + 3));
        assert_true(identical);
    }
    print_message("%s: %d cases x 4 transposes within the bound (worst %.2f of it), epilogues "
                  "bit-exact%s\n", k->name,
                  n_cases, worst,
                  first_kernel == id ? "" : ", bit-identical to the first kernel");
}

static void test_avx512(void **state) { (void)state; run_kernel(LA_PACKED_AVX512); }
static void test_avx2(void **state) { (void)state; run_kernel(LA_PACKED_AVX2); }
static void test_neon(void **state) { (void)state; run_kernel(LA_PACKED_NEON); }

static void sgemm_ep_dispatch(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha,
                              const float *A_, int lda, const float *B_, int ldb, float beta,
                              float *C, int ldc, const la_epilogue_t *ep)
{
    la_sgemm_ep(ta, tb, M, N, K, alpha, A_, lda, B_, ldb, beta, C, ldc, ep);
}

/* la_sgemm_ep's epilogue on the back end without a packed kernel (a pass after Eigen or the
 * reference), thin and wide shapes: the same contract. */
static void test_epilogue_fallback(void **state)
{
    (void)state;
    make_cases();
    for (int pass = 0; pass < 2; pass++) {
        assert_int_equal(la_packed_force(pass == 0 ? -1 : -2), 0);
        for (int c = 0; c < 24; c++)
            epilogue_case(sgemm_ep_dispatch, c % 3, c & 1, (c >> 1) & 1, cases[c].M, cases[c].N,
                          cases[c].K, (uint64_t)(500 + c));
    }
    print_message("la_sgemm_ep: epilogues bit-exact on %s and %s\n", "the fallback", la_kernel_name());
}

/* la_sgemm takes the fastest kernel the CPU runs, and la_packed_force refuses what it lacks. */
static void test_choice(void **state)
{
    (void)state;
    const la_packed_kernel_t *k = la_packed_active();
    int best = -1;
    for (int id = LA_PACKED_N - 1; id >= 0; id--)
        if (la_packed_cpu_has(id))
            best = id;
    if (best < 0)
        assert_null(k);
    else
        assert_ptr_equal(k, &la_packed_kernels[best]);
    for (int id = 0; id < LA_PACKED_N; id++)
        assert_int_equal(la_packed_force(id), la_packed_cpu_has(id) ? 0 : -ENOTSUP);
    assert_int_equal(la_packed_force(-1), 0);
    assert_null(la_packed_active());
    assert_int_equal(la_packed_force(-2), 0);
    assert_ptr_equal(la_packed_active(), best < 0 ? NULL : &la_packed_kernels[best]);
    print_message("kernel in use: %s\n", la_kernel_name());
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_avx512),
        cmocka_unit_test(test_avx2),
        cmocka_unit_test(test_neon),
        cmocka_unit_test(test_choice),
        cmocka_unit_test(test_epilogue_fallback),
    };
    return cmocka_run_group_tests_name("ai/la_packed", tests, NULL, NULL);
}
