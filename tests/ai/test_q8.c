/* The int8 GEMM kernels (firmware/ai/kernels/q8_gemm.h) and the chunked int8 inference path
 * (bnn_quant_forward_mean) that runs on them.
 *   - every kernel against a plain triple loop (int32 sums are exact, so bit for bit), on
 *     shapes at the edges of the tiles: 1 point, point counts around the 8/16/32 vectors,
 *     1 or odd rows, inputs that leave a partial quad (1, 2, 3, 37, 45), extreme bytes;
 *   - bnn_quant_forward_mean on each kernel (q8_force) against the per-point int8 path it
 *     replaced (the oracle, at the end: the definition of the int8 network, with its own copy
 *     of the SIREN layer's sine, ai_fm_sinf): logits bit-identical on the preset network and on
 *     small odd configurations (37/45 widths, one layer), for n = 1, n around the vectors of
 *     16 points and the chunk and n not a multiple of them, points near and far (the sine's
 *     range reduction), with all-zero weight rows and an all-zero (ReLU-dead) layer;
 *   - a non-finite point stops the call after the logits before it, as before;
 *   - the rounding the path uses in place of roundf, over every float of 0.25 <= |v| < 128;
 *   - nothing allocates.
 * A kernel this build or this CPU cannot run is reported as skipped, with the reason. */
#ifndef Q8_ORACLE /* the test program; the oracle at the end of the file is included twice */
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
#include "ai/bnn_quant.h"
#include "ai/kernels/q8_gemm.h"

/* ---- the per-point int8 path as it was (the oracle), compiled twice ----------------------
 * The firmware is compiled with -ffp-contract=fast by the Makefile (FW_FP) and with the ISO
 * default (no contraction) by the cross builds, the tests with neither: the oracle is the end
 * of this file, included once with contraction (oracle_forward_fast: what the per-point path
 * computed in the Makefile's builds, wherever the CPU has FMA) and once without
 * (oracle_forward_off). Every result of the firmware must be bit-identical to one of them,
 * always the same one (they agree where the CPU has no FMA). */
static float getf(const uint8_t *p)
{
    uint32_t u = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
    float f;
    memcpy(&f, &u, 4);
    return f;
}

typedef struct qtensor {
    const uint8_t *scales;
    const int8_t *q;
    size_t rows, cols;
} qtensor_t;

#define WMAX (BNN_SIREN_MAX > BNN_HIDDEN_MAX ? BNN_SIREN_MAX : BNN_HIDDEN_MAX)

#define Q8_ORACLE(name) name##_fast
#if defined(__clang__)
#pragma clang fp contract(fast)
#elif defined(__GNUC__)
#pragma GCC push_options
#pragma GCC optimize("fp-contract=fast")
#endif
#include "test_q8.c"
#if defined(__clang__)
#pragma clang fp contract(off)
#elif defined(__GNUC__)
#pragma GCC pop_options
#pragma GCC push_options
#pragma GCC optimize("fp-contract=off")
#endif
#undef Q8_ORACLE
#define Q8_ORACLE(name) name##_off
#include "test_q8.c"
#if defined(__clang__)
#pragma clang fp contract(on)
#elif defined(__GNUC__)
#pragma GCC pop_options
#endif
#undef Q8_ORACLE

/* ---- helpers ------------------------------------------------------------------------------ */
static int kernel_or_skip(int id)
{
    const q8_kernel_t *k = &q8_kernels[id];
    if (!k->fn) {
        print_message("%s: not compiled for this target (needs %s)\n", k->name, k->isa);
        return 0;
    }
    if (!q8_cpu_has(id)) {
        print_message("%s: this CPU lacks %s\n", k->name, k->isa);
        return 0;
    }
    return 1;
}

static uint64_t g_rng = 0x9E3779B97F4A7C15ull;
static uint32_t rnd(void)
{
    g_rng ^= g_rng << 13;
    g_rng ^= g_rng >> 7;
    g_rng ^= g_rng << 17;
    return (uint32_t)(g_rng >> 16);
}

/* ---- the kernels against a triple loop ------------------------------------------------- */
#define KLD 64  /* lda = ldc of the kernel cases (>= the padded point count) */
#define KIN 260 /* largest in */
#define KOUT 70 /* largest out */
static int8_t KA[((KIN + 3) / 4) * 4 * KLD], KW[KOUT * KIN];
static int32_t KC[KOUT * KLD], KC0[KOUT * KLD], Kws[KOUT];

static void kernel_case(int id, size_t np, size_t out, size_t in, size_t lda, int extreme)
{
    for (size_t i = 0; i < sizeof KA; i++) /* activations: the quantiser's range, -127..127 */
        KA[i] = (int8_t)(extreme ? ((rnd() & 1) ? 127 : -127) : (int)(rnd() % 255) - 127);
    for (size_t i = 0; i < out * in; i++) /* weights: any byte, -128 too */
        KW[i] = (int8_t)(extreme ? ((rnd() & 1) ? 127 : -128) : (int)(rnd() % 256) - 128);
    if (out > 2) /* an all-zero row */
        memset(KW + in, 0, in);
    q8_row_sums(KW, out, in, Kws);
    for (size_t j = 0; j < out; j++)
        for (size_t p = 0; p < np; p++) {
            int32_t s = 0;
            for (size_t k = 0; k < in; k++)
                s += (int32_t)KA[(k / 4) * 4 * lda + 4 * p + k % 4] * (int32_t)KW[j * in + k];
            KC0[j * lda + p] = s;
        }
    for (size_t i = 0; i < sizeof KC / sizeof KC[0]; i++)
        KC[i] = INT32_MIN;
    alloc_count_reset();
    q8_kernels[id].fn(np, out, in, KA, lda, KW, Kws, KC, lda);
    assert_int_equal(alloc_count_allocations(), 0);
    for (size_t j = 0; j < out; j++)
        for (size_t p = 0; p < np; p++)
            if (KC[j * lda + p] != KC0[j * lda + p]) {
                print_message("%s: np %zu out %zu in %zu: C[%zu][%zu] = %d, want %d\n",
                              q8_kernels[id].name, np, out, in, j, p, KC[j * lda + p],
                              KC0[j * lda + p]);
                fail();
            }
    /* nothing past the padded points of a row */
    for (size_t j = 0; j < out; j++)
        for (size_t p = Q8_PAD_POINTS(np); p < lda; p++)
            assert_int_equal(KC[j * lda + p], INT32_MIN);
}

static void test_kernel(void **state)
{
    const int id = (int)(intptr_t)*state;
    if (!kernel_or_skip(id))
        skip();
    static const size_t nps[] = {1, 2, 7, 8, 9, 15, 16, 17, 31, 32, 33, 47, 48, 63, 64};
    static const size_t outs[] = {1, 2, 3, 4, 7, 8, 9, 17, 45, 64, 70};
    static const size_t ins[] = {1, 2, 3, 4, 5, 7, 8, 37, 45, 64, 128, 256, 257, 260};
    size_t cases = 0;
    for (size_t a = 0; a < sizeof nps / sizeof nps[0]; a++)
        for (size_t b = 0; b < sizeof outs / sizeof outs[0]; b++)
            for (size_t c = 0; c < sizeof ins / sizeof ins[0]; c++) {
                if ((a + b + c) % 3 != 0 && !(nps[a] == 1 || outs[b] == 1 || ins[c] % 4 != 0))
                    continue; /* a third of the grid, and every edge case */
                kernel_case(id, nps[a], outs[b], ins[c], KLD, 0);
                cases++;
            }
    for (size_t c = 0; c < sizeof ins / sizeof ins[0]; c++, cases++)
        kernel_case(id, 33, 45, ins[c], KLD, 1); /* extreme bytes: the int16 pairs of avx2 */
    if (id == Q8_REF) /* the one-point layout (chunks of 1, off x86) */
        for (size_t c = 0; c < sizeof ins / sizeof ins[0]; c++, cases++)
            kernel_case(id, 1, 9, ins[c], 1, 0);
    print_message("%s: %zu shapes bit-exact against the triple loop\n", q8_kernels[id].name, cases);
}

/* ---- bnn_quant_forward_mean on each kernel against the oracle -------------------------- */
#define NMAX 1000
static bnn_model_t m;
static uint8_t packed[BNN_QUANT_MAX_BYTES];
static float xy[2 * NMAX], lg[NMAX + 1], lo[NMAX + 1];

static bnn_config_t odd_config(size_t S, size_t H, size_t L)
{
    bnn_config_t c = bnn_default_config();
    c.siren_width = (uint32_t)(S < BNN_SIREN_MAX ? S : BNN_SIREN_MAX);
    c.hidden_width = (uint32_t)(H < BNN_HIDDEN_MAX ? H : BNN_HIDDEN_MAX);
    c.n_bayes = (uint32_t)(L < BNN_LAYERS_MAX ? L : BNN_LAYERS_MAX);
    return c;
}

/* kind 0: initial weights; 1: some all-zero weight rows (scale 0) in every layer; 2: the first
 * Bayesian layer dead (zero weights, negative biases), so the next layer's input is all 0. */
static size_t make_state(const bnn_config_t *c, uint64_t seed, int kind)
{
    assert_int_equal(bnn_init(&m, c, seed), 0);
    bnn_tensor_t T[BNN_MAX_TENSORS];
    const size_t nt = bnn_tensors(&m, T, BNN_MAX_TENSORS);
    float *th = bnn_params(&m);
    for (size_t t = 0; t < nt; t++) {
        if (T[t].group != BNN_GROUP_MU)
            continue;
        const size_t len = (size_t)T[t].rows * T[t].cols;
        if (kind >= 1 && T[t].is_bias) /* non-zero biases, so that they count */
            for (size_t k = 0; k < len; k++)
                th[T[t].offset + k] = 0.1f * (float)((int)(k % 7) - 3);
        if (kind == 1 && !T[t].is_bias && T[t].rows > 2)
            for (size_t r = 1; r < T[t].rows; r += 3)
                memset(th + T[t].offset + r * T[t].cols, 0, sizeof(float) * T[t].cols);
        if (kind == 2 && T[t].bayes_layer == 1) {
            if (T[t].is_bias)
                for (size_t k = 0; k < len; k++)
                    th[T[t].offset + k] = -1.0f;
            else
                memset(th + T[t].offset, 0, sizeof(float) * len);
        }
    }
    size_t n = 0;
    assert_int_equal(bnn_quant_pack(&m, BNN_GROUP_ALL, packed, sizeof packed, &n), 0);
    return n;
}

/* n points in [-1.2, 1.2]^2, every 7th of them (from the 4th on) far out in [-60, 60]^2, so that
 * the sine's range reduction meets large multiples of pi (w0 * z up to a few thousand) */
static void fill_points(size_t n, uint64_t s)
{
    ai_rng_uniform_fill(77, s, 0, xy, 2 * n);
    for (size_t i = 0; i < 2 * n; i++)
        xy[i] = (i / 2 % 7 == 3 ? 120.0f : 2.4f) * xy[i] - (i / 2 % 7 == 3 ? 60.0f : 1.2f);
    xy[0] = 0.0f; /* the origin, and a point on an axis */
    if (n > 1)
        xy[2] = 0.0f;
}

/* Which oracle the firmware matches: 1 contracted, 0 not, -1 not told apart yet (the two agree
 * on every run so far). */
static int g_contracted = -1;
static float lo2[NMAX + 1];

/* The per-point logits of n points into want[], as this build of the firmware must give them:
 * from the oracle it matched so far, or from the one got[] matches when they differ. */
static void oracle_logits(const bnn_config_t *c, size_t len, size_t n, const float *got,
                          float *want)
{
    assert_int_equal(oracle_forward_fast(c, packed, len, xy, n, want), 0);
    assert_int_equal(oracle_forward_off(c, packed, len, xy, n, lo2), 0);
    if (memcmp(want, lo2, n * sizeof(float)) == 0)
        return;
    if (g_contracted < 0) /* the first run that tells them apart decides */
        g_contracted = memcmp(got, want, n * sizeof(float)) == 0 ? 1
                       : memcmp(got, lo2, n * sizeof(float)) == 0 ? 0
                                                                  : -1;
    if (g_contracted == 0)
        memcpy(want, lo2, n * sizeof(float));
}

/* Logits of kernel id for n points against the oracle, bit for bit. */
static void same_as_oracle(int id, const bnn_config_t *c, size_t len, size_t n)
{
    lg[n] = lo[n] = 12345.0f; /* nothing written past n */
    assert_int_equal(q8_force(id), 0);
    alloc_count_reset();
    assert_int_equal(bnn_quant_forward_mean(c, BNN_GROUP_ALL, packed, len, xy, n, lg), 0);
    assert_int_equal(alloc_count_allocations(), 0);
    oracle_logits(c, len, n, lg, lo);
    for (size_t i = 0; i <= n; i++)
        if (memcmp(&lg[i], &lo[i], sizeof(float)) != 0) {
            print_message("%s: S %u H %u L %u n %zu: logit %zu = %.9g, per-point path %.9g "
                          "(%s)\n",
                          q8_kernels[id].name, c->siren_width, c->hidden_width, c->n_bayes, n, i,
                          (double)lg[i], (double)lo[i],
                          g_contracted == 1 ? "contracted" : g_contracted == 0 ? "not contracted"
                                                                               : "neither");
            fail();
        }
}

static void test_forward(void **state)
{
    const int id = (int)(intptr_t)*state;
    if (!kernel_or_skip(id))
        skip();
    const bnn_config_t cfgs[] = {
        bnn_default_config(),  odd_config(37, 45, 2), odd_config(45, 37, BNN_LAYERS_MAX),
        odd_config(5, 3, 1),   odd_config(1, 1, 1),   odd_config(BNN_SIREN_MAX, 17, 3),
    };
    static const size_t ns[] = {1,   2, 15, 16, 17, BNN_QUANT_CHUNK - 1 ? BNN_QUANT_CHUNK - 1 : 1,
                                BNN_QUANT_CHUNK, BNN_QUANT_CHUNK + 1, 3 * BNN_QUANT_CHUNK + 5,
                                257, NMAX};
    size_t runs = 0;
    for (size_t ci = 0; ci < sizeof cfgs / sizeof cfgs[0]; ci++)
        for (int kind = 0; kind < 3; kind++) {
            const size_t len = make_state(&cfgs[ci], 11 + ci, kind);
            for (size_t ni = 0; ni < sizeof ns / sizeof ns[0]; ni++) {
                if (ci > 0 && ns[ni] > 300)
                    continue;
                fill_points(ns[ni], 100 * ci + ni);
                same_as_oracle(id, &cfgs[ci], len, ns[ni]);
                runs++;
            }
        }
    assert_int_equal(q8_force(Q8_AUTO), 0);
    print_message("%s: %zu runs (6 configurations x 3 weight sets x n = 1..%d, near and far "
                  "points) bit-identical to "
                  "the per-point path (%s)\n",
                  q8_kernels[id].name, runs, NMAX,
                  g_contracted == 1   ? "as compiled with FMA contraction"
                  : g_contracted == 0 ? "as compiled without FMA contraction"
                                      : "with or without FMA contraction: the same here");
}

/* A non-finite point: the logits before it are written, the call says -EINVAL. */
static void test_nonfinite_point(void **state)
{
    (void)state;
    const bnn_config_t c = odd_config(37, 45, 2);
    const size_t len = make_state(&c, 5, 0);
    const size_t n = 3 * BNN_QUANT_CHUNK + 5, bad = BNN_QUANT_CHUNK + 3; /* in the 2nd chunk */
    fill_points(n, 9);
    xy[2 * bad + 1] = NAN;
    for (size_t i = 0; i < n; i++)
        lg[i] = -7.0f;
    assert_int_equal(bnn_quant_forward_mean(&c, BNN_GROUP_ALL, packed, len, xy, n, lg), -EINVAL);
    oracle_logits(&c, len, bad, lg, lo);
    assert_memory_equal(lg, lo, bad * sizeof(float));
    for (size_t i = bad; i < n; i++)
        assert_true(lg[i] == -7.0f);
    xy[2 * bad + 1] = INFINITY;
    xy[0] = INFINITY;
    assert_int_equal(bnn_quant_forward_mean(&c, BNN_GROUP_ALL, packed, len, xy, n, lg), -EINVAL);
    /* the mean network's tensors cut short: the stream is rejected before any point */
    const size_t mu = bnn_quant_packed_size_cfg(&c, BNN_GROUP_MU);
    assert_int_equal(bnn_quant_forward_mean(&c, BNN_GROUP_ALL, packed, mu - 1, xy, 1, lg),
                     -EBADMSG);
}

/* The rounding of the quantiser: i + (d >= 0.5) - (d <= -0.5), i = trunc(v), d = v - i (the
 * formula of bnn_quant.c), equals roundf over every float of 0.25 <= |v| < 128 (below 0.25 both
 * give 0; the quantiser's arguments stay within 127.0001). */
static void test_rounding(void **state)
{
    (void)state;
    uint32_t lo_bits, hi_bits;
    const float lo_v = 0.25f, hi_v = 128.0f;
    memcpy(&lo_bits, &lo_v, 4);
    memcpy(&hi_bits, &hi_v, 4);
    size_t bad = 0;
    for (uint32_t u = lo_bits; u < hi_bits; u++)
        for (int s = 0; s < 2; s++) {
            const uint32_t b = u | (uint32_t)s << 31;
            float v;
            memcpy(&v, &b, 4);
            const int32_t i = (int32_t)v;
            const float d = v - (float)i;
            const int32_t r = i + (d >= 0.5f) - (d <= -0.5f);
            bad += r != (int32_t)roundf(v);
        }
    assert_int_equal(bad, 0);
    print_message("rounding: %u floats of 0.25 <= |v| < 128 give roundf's value\n",
                  2u * (hi_bits - lo_bits));
}

static void test_force_and_name(void **state)
{
    (void)state;
    assert_int_equal(q8_force(Q8_AUTO), 0);
    const q8_kernel_t *k = q8_active();
    assert_string_equal(q8_kernel_name(), k->name);
    assert_true(q8_cpu_has((int)(k - q8_kernels)));
    for (int id = 0; id < (int)(k - q8_kernels); id++) /* nothing faster than the choice */
        assert_false(q8_cpu_has(id));
    assert_int_equal(q8_force(Q8_REF), 0);
    assert_string_equal(q8_kernel_name(), "ref");
    for (int id = 0; id < Q8_N; id++)
        assert_int_equal(q8_force(id), q8_cpu_has(id) ? 0 : -ENOTSUP);
    assert_int_equal(q8_force(Q8_N), -EINVAL);
    assert_int_equal(q8_force(-5), -EINVAL);
    assert_int_equal(q8_force(Q8_AUTO), 0);
    print_message("int8 kernel in use: %s (chunk %u points, stack <= %u B)\n", q8_kernel_name(),
                  (unsigned)BNN_QUANT_CHUNK, (unsigned)BNN_QUANT_STACK_BYTES);
}

#define PER_KERNEL(fn, id) cmocka_unit_test_prestate(fn, (void *)(intptr_t)(id))

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_force_and_name),
        cmocka_unit_test(test_rounding),
        PER_KERNEL(test_kernel, Q8_REF),
        PER_KERNEL(test_kernel, Q8_AVX512VNNI),
        PER_KERNEL(test_kernel, Q8_AVX512VNNI_YMM),
        PER_KERNEL(test_kernel, Q8_AVXVNNI),
        PER_KERNEL(test_kernel, Q8_AVX2),
        PER_KERNEL(test_forward, Q8_REF),
        PER_KERNEL(test_forward, Q8_AVX512VNNI),
        PER_KERNEL(test_forward, Q8_AVX512VNNI_YMM),
        PER_KERNEL(test_forward, Q8_AVXVNNI),
        PER_KERNEL(test_forward, Q8_AVX2),
        cmocka_unit_test(test_nonfinite_point),
    };
    return cmocka_run_group_tests_name("ai/q8", tests, NULL, NULL);
}

#else /* Q8_ORACLE: the per-point path, included twice by the program above --------------- */

/* ai_fm_sinf (ai/ai_fastmath.h), the sine of the SIREN layer, copied here (with plain
 * selects: the same values) so that it is compiled with the oracle's contraction (the
 * header's copy would take the file's). */
static float Q8_ORACLE(sin)(float x)
{
    const float ax = x < 0.0f ? -x : x;
    const int32_t k = ((int32_t)(ax * 0.636619772367581343076f) + 1) >> 1;
    const float kf = (float)k;
    const float r = ((ax - kf * 3.140625f) - kf * 9.67502593994140625e-4f) -
                    kf * 1.509957990978376432e-7f;
    const float z = r * r;
    float u = 2.6083159809786593541503e-06f;
    u = u * z + -0.0001981069071916863322258f;
    u = u * z + 0.00833307858556509017944336f;
    u = u * z + -0.166666597127914428710938f;
    const float s = z * (u * r) + r;
    const float sk = (k & 1) ? -s : s;
    return x < 0.0f ? -sk : sk;
}

static void Q8_ORACLE(int8_layer)(const qtensor_t *W, const qtensor_t *b, const float *a,
                                   size_t in, float *y)
{
    int8_t qa[WMAX];
    float amax = 0.0f;
    for (size_t k = 0; k < in; k++)
        amax = fabsf(a[k]) > amax ? fabsf(a[k]) : amax;
    const float sa = amax / 127.0f, inv = sa > 0.0f ? 1.0f / sa : 0.0f;
    for (size_t k = 0; k < in; k++)
        qa[k] = (int8_t)roundf(a[k] * inv);
    const float sb = getf(b->scales);
    for (size_t j = 0; j < W->rows; j++) {
        const int8_t *w = W->q + j * in;
        int32_t acc = 0;
        for (size_t k = 0; k < in; k++)
            acc += (int32_t)w[k] * (int32_t)qa[k];
        y[j] = sa * getf(W->scales + 4 * j) * (float)acc + sb * (float)b->q[j];
    }
}

static int Q8_ORACLE(oracle_forward)(const bnn_config_t *cfg, const uint8_t *packed, size_t len,
                                     const float *xy, size_t n, float *logits)
{
    const size_t S = cfg->siren_width, H = cfg->hidden_width, L = cfg->n_bayes;
    qtensor_t Q[2 + 2 * BNN_LAYERS_MAX + 2];
    const size_t shapes[][2] = {{S, BNN_IN}, {1, S}};
    const uint8_t *p = packed;
    size_t nq = 0;
    for (size_t t = 0; t < 2 + 2 * L + 2; t++) {
        size_t R, C;
        if (t < 2) {
            R = shapes[t][0];
            C = shapes[t][1];
        } else if (t < 2 + 2 * L) {
            const size_t l = (t - 2) / 2, in = l == 0 ? S : H;
            R = (t % 2 == 0) ? H : 1;
            C = (t % 2 == 0) ? in : H;
        } else {
            R = 1;
            C = t == 2 + 2 * L ? H : 1;
        }
        if ((size_t)(p - packed) + 4 * R + R * C > len)
            return -EBADMSG;
        Q[nq++] = (qtensor_t){p, (const int8_t *)(p + 4 * R), R, C};
        p += 4 * R + R * C;
    }
    float a[WMAX], b[WMAX];
    /* the SIREN layer's products s q, each one float (rounded once, fused into nothing) */
    float sx[WMAX], sy[WMAX], bb[WMAX];
    const float sb0 = getf(Q[1].scales);
    for (size_t j = 0; j < S; j++) {
        const float s = getf(Q[0].scales + 4 * j);
        sx[j] = s * (float)Q[0].q[2 * j];
        sy[j] = s * (float)Q[0].q[2 * j + 1];
        bb[j] = sb0 * (float)Q[1].q[j];
    }
    for (size_t i = 0; i < n; i++) {
        const float x = xy[2 * i], y = xy[2 * i + 1];
        if (!isfinite(x) || !isfinite(y))
            return -EINVAL;
        for (size_t j = 0; j < S; j++)
            a[j] = Q8_ORACLE(sin)(cfg->w0 * (sx[j] * x + (sy[j] * y + bb[j])));
        size_t in = S;
        for (size_t l = 0; l < L; l++) {
            Q8_ORACLE(int8_layer)(&Q[2 + 2 * l], &Q[3 + 2 * l], a, in, b);
            for (size_t j = 0; j < H; j++)
                a[j] = b[j] > 0.0f ? b[j] : 0.0f;
            in = H;
        }
        float out;
        Q8_ORACLE(int8_layer)(&Q[2 + 2 * L], &Q[3 + 2 * L], a, H, &out);
        logits[i] = out;
    }
    return 0;
}

#endif /* Q8_ORACLE */
