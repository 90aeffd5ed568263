/* Counter-based RNG: Philox4x32-10 known-answer vectors (Random123), determinism,
 * sub-range consistency, moments of the normals and uniforms, fast-math accuracy. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "ai/ai_fastmath.h"
#include "ai/ai_rng.h"
#include "ai/kernels/ai_rng_lanes.h"

static void test_philox_kat(void **state)
{
    (void)state;
    /* Random123 kat_vectors: philox4x32 10 rounds */
    uint32_t out[4];
    const uint32_t k0[2] = {0, 0}, c0[4] = {0, 0, 0, 0};
    ai_rng_philox4x32(k0, c0, out);
    assert_int_equal(out[0], 0x6627e8d5u);
    assert_int_equal(out[1], 0xe169c58du);
    assert_int_equal(out[2], 0xbc57ac4cu);
    assert_int_equal(out[3], 0x9b00dbd8u);
    const uint32_t k1[2] = {0xffffffffu, 0xffffffffu};
    const uint32_t c1[4] = {0xffffffffu, 0xffffffffu, 0xffffffffu, 0xffffffffu};
    ai_rng_philox4x32(k1, c1, out);
    assert_int_equal(out[0], 0x408f276du);
    assert_int_equal(out[1], 0x41c83b0eu);
    assert_int_equal(out[2], 0xa20bc7c6u);
    assert_int_equal(out[3], 0x6d5451fdu);
    const uint32_t k2[2] = {0xa4093822u, 0x299f31d0u};
    const uint32_t c2[4] = {0x243f6a88u, 0x85a308d3u, 0x13198a2eu, 0x03707344u};
    ai_rng_philox4x32(k2, c2, out);
    assert_int_equal(out[0], 0xd16cfe09u);
    assert_int_equal(out[1], 0x94fdccebu);
    assert_int_equal(out[2], 0x5001e420u);
    assert_int_equal(out[3], 0x24126ea1u);
}

#define N 200000
static float a[N], b[N];

static void test_normals(void **state)
{
    (void)state;
    ai_rng_normal_fill(42, 7, 0, a, N);
    ai_rng_normal_fill(42, 7, 0, b, N);
    assert_memory_equal(a, b, sizeof a);
    /* any sub-range regenerates identically (counter-based) */
    ai_rng_normal_fill(42, 7, 12345, b, 1001);
    assert_memory_equal(a + 12345, b, 1001 * sizeof(float));
    ai_rng_normal_fill(42, 7, 3, b, 1);
    assert_true(a[3] == b[0]);
    /* another stream or key differs */
    ai_rng_normal_fill(42, 8, 0, b, 16);
    int same = 0;
    for (int i = 0; i < 16; i++)
        same += a[i] == b[i];
    assert_true(same < 2);
    double m1 = 0, m2 = 0, m4 = 0;
    for (int i = 0; i < N; i++) {
        double x = a[i];
        assert_true(isfinite(a[i]));
        m1 += x;
        m2 += x * x;
        m4 += x * x * x * x;
    }
    m1 /= N;
    m2 /= N;
    m4 /= N;
    print_message("normals: mean %.4f var %.4f kurtosis %.3f\n", m1, m2, m4 / (m2 * m2));
    assert_true(fabs(m1) < 0.01);
    assert_true(fabs(m2 - 1.0) < 0.015);
    assert_true(fabs(m4 / (m2 * m2) - 3.0) < 0.06);
}

static void test_uniforms(void **state)
{
    (void)state;
    ai_rng_uniform_fill(1, 2, 0, a, N);
    double m = 0;
    for (int i = 0; i < N; i++) {
        assert_true(a[i] > 0.0f && a[i] < 1.0f);
        m += a[i];
    }
    m /= N;
    assert_true(fabs(m - 0.5) < 0.005);
}

static void test_fastmath(void **state)
{
    (void)state;
    double emax = 0, lmax = 0, smax = 0, l1max = 0;
    for (int i = 0; i < 200000; i++) {
        float x = -80.0f + 160.0f * (float)i / 200000.0f;
        double e = fabs(ai_fm_expf(x) / exp(x) - 1.0);
        emax = e > emax ? e : emax;
        float p = ldexpf(1.0f + (float)i / 200000.0f, (i % 60) - 30);
        double l = fabs(ai_fm_logf(p) - log(p)) / (fabs(log(p)) + 1e-30);
        if (fabs(log(p)) > 1e-3)
            lmax = l > lmax ? l : lmax;
        float u = ldexpf((float)i / 200000.0f, -(i % 40));
        double l1 = fabs(ai_fm_log1pf(u) - log1p(u)) / (log1p(u) + 1e-300);
        if (u > 0)
            l1max = l1 > l1max ? l1 : l1max;
        float t = -300.0f + 600.0f * (float)i / 200000.0f;
        float s, c;
        ai_fm_sincosf(t, &s, &c);
        double d = fmax(fabs(s - sin(t)), fabs(c - cos(t)));
        smax = d > smax ? d : smax;
    }
    /* ai_fm_sinf (the int8 SIREN layer's sine) over its whole domain |x| < 8192, every
     * 0.00731: 1.3e-7 measured (with and without FMA contraction); odd, and 0 at 0 */
    double s1max = 0;
    for (double x = -8191.9; x < 8191.9; x += 0.00731) {
        const float f = (float)x;
        const double d = fabs(ai_fm_sinf(f) - sin((double)f));
        s1max = d > s1max ? d : s1max;
        assert_true(ai_fm_sinf(-f) == -ai_fm_sinf(f));
    }
    assert_true(ai_fm_sinf(0.0f) == 0.0f);
    print_message("fast math max errors: exp rel %.2e log rel %.2e log1p rel %.2e sincos abs %.2e "
                  "sin abs %.2e\n",
                  emax, lmax, l1max, smax, s1max);
    assert_true(s1max < 2.5e-7);
    assert_true(emax < 5e-7);
    assert_true(lmax < 5e-7);
    assert_true(l1max < 5e-7);
    assert_true(smax < 5e-7);
}

/* Every wide Philox kernel this CPU runs gives the reference's lanes: keys and streams of all
 * bits, counters whose low word wraps inside a vector (the carry into the high word), block
 * counts that are not whole vectors; and no entry beyond nb rounded up to AI_RNG_LANES_PAD is
 * written. */
static void test_lanes_kernels_equal_reference(void **state)
{
    (void)state;
    const char *name = NULL;
    const ai_rng_lanes_fn active = ai_rng_lanes_active(&name);
    assert_non_null(active);
    assert_non_null(name);
    ai_rng_lanes_fn kern[3] = {ai_rng_lanes_ref, NULL, NULL};
#if defined(AI_RNG_X86)
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f"))
        kern[1] = ai_rng_lanes_avx512;
    if (__builtin_cpu_supports("avx2"))
        kern[2] = ai_rng_lanes_avx2;
#endif
    const uint64_t keys[] = {0, 0xffffffffffffffffull, 0x299f31d0a4093822ull, 42};
    const uint64_t streams[] = {0, 7, 0xffffffff00000001ull, 0x0123456789abcdefull};
    const uint64_t firsts[] = {0, 5, 0xfffffff7ull, 0x1fffffffaull, 0xfffffffffffffff0ull};
    const uint32_t counts[] = {1, 7, 8, 15, 16, 17, 33, 64};
    enum { CAP = 64 + AI_RNG_LANES_PAD };
    for (size_t ki = 0; ki < 4; ki++)
        for (size_t si = 0; si < 4; si++)
            for (size_t fi = 0; fi < 5; fi++)
                for (size_t ci = 0; ci < 8; ci++) {
                    uint32_t ref[4][CAP], got[4][CAP];
                    const uint32_t nb = counts[ci];
                    ai_rng_lanes_ref(keys[ki], streams[si], firsts[fi], nb, ref[0], ref[1],
                                     ref[2], ref[3]);
                    for (int k = 1; k < 3; k++) {
                        if (!kern[k])
                            continue;
                        memset(got, 0xA5, sizeof got);
                        kern[k](keys[ki], streams[si], firsts[fi], nb, got[0], got[1], got[2],
                                got[3]);
                        const uint32_t pad = (nb + AI_RNG_LANES_PAD - 1) / AI_RNG_LANES_PAD *
                                             AI_RNG_LANES_PAD;
                        for (int l = 0; l < 4; l++) {
                            assert_memory_equal(got[l], ref[l], nb * sizeof(uint32_t));
                            for (uint32_t i = pad; i < CAP; i++)
                                assert_int_equal(got[l][i], 0xA5A5A5A5u);
                        }
                    }
                }
    /* the block {b lo, b hi, s lo, s hi} of the known-answer vector, through the kernels */
    uint32_t l[4][AI_RNG_LANES_PAD];
    for (int k = 0; k < 3; k++) {
        if (!kern[k])
            continue;
        kern[k](0x299f31d0a4093822ull, 0x0370734413198a2eull, 0x85a308d3243f6a88ull, 1, l[0], l[1],
                l[2], l[3]);
        assert_int_equal(l[0][0], 0xd16cfe09u);
        assert_int_equal(l[1][0], 0x94fdccebu);
        assert_int_equal(l[2][0], 0x5001e420u);
        assert_int_equal(l[3][0], 0x24126ea1u);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_philox_kat),
        cmocka_unit_test(test_lanes_kernels_equal_reference),
        cmocka_unit_test(test_normals),
        cmocka_unit_test(test_uniforms),
        cmocka_unit_test(test_fastmath),
    };
    return cmocka_run_group_tests_name("ai/ai_rng", tests, NULL, NULL);
}
