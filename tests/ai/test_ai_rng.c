/* Counter-based RNG: Philox4x32-10 known-answer vectors (Random123), determinism,
 * sub-range consistency, moments of the normals and uniforms, fast-math accuracy. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <math.h>
#include <cmocka.h>

#include "ai/ai_fastmath.h"
#include "ai/ai_rng.h"

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

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_philox_kat),
        cmocka_unit_test(test_normals),
        cmocka_unit_test(test_uniforms),
        cmocka_unit_test(test_fastmath),
    };
    return cmocka_run_group_tests_name("ai/ai_rng", tests, NULL, NULL);
}
