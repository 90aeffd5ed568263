/* Branch-free single-precision exp, log, log1p and sincos for the AI core's hot loops.
 *
 * Why: glibc's scalar expf/logf/sinf calls stop GCC from vectorising the loops that draw
 * Gaussians, evaluate the SIREN layer and softplus; these inline versions are plain C
 * (bit manipulation through memcpy, selects instead of branches) so the loops vectorise
 * at -O3 on any target, and they give bit-identical results whatever the LA back end.
 * Accuracy (Cephes polynomials): a few ulp over the ranges used here:
 *   ai_fm_expf: x in [-87, 88];  ai_fm_logf: x > 0 normal;  ai_fm_sincosf: |x| < 8192.
 */
#ifndef AI_FASTMATH_H
#define AI_FASTMATH_H

#include <stdint.h>
#include <string.h>

/* AI_WIDE: put before a function whose loops are the trainer's element-wise passes (sampling,
 * softplus, the KL and reparameterisation gradients, Adam, the Gaussians). A build whose
 * baseline lacks AVX2 (ARCH=portable: x86-64-v2) then carries the function three times, for
 * x86-64-v4 (AVX-512), v3 (AVX2+FMA) and the baseline, and the loader picks the one the CPU
 * runs (GNU ifunc; GCC and clang). Native builds and other CPUs compile it once, as is. The
 * clones vectorise differently, so results are bit-identical per binary and CPU. */
#if defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define AI_TSAN_ 1
#endif
#endif
#if defined(__SANITIZE_THREAD__)
#define AI_TSAN_ 1
#endif
/* Not under ThreadSanitizer: the loader runs ifunc resolvers before the TSan runtime is up. */
#if defined(__x86_64__) && defined(__linux__) && !defined(__AVX2__) &&                           \
    (defined(__GNUC__) || defined(__clang__)) && !defined(AI_TSAN_)
#define AI_WIDE __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#define AI_WIDE_CLONES 1 /* AI_WIDE functions are reached through an ifunc: never inlined */
#else
#define AI_WIDE
#endif

static inline float ai_fm_bits2f(uint32_t u)
{
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

static inline uint32_t ai_fm_f2bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

/* c ? a : b on the bit patterns. Both values are computed before the choice, so GCC's
 * if-conversion never has to speculate a floating-point operation (which it refuses under the
 * default -ftrapping-math, and then does not vectorise the loop). */
static inline float ai_fm_sel(int c, float a, float b)
{
    const uint32_t mask = (uint32_t)0 - (uint32_t)(c != 0);
    return ai_fm_bits2f((ai_fm_f2bits(a) & mask) | (ai_fm_f2bits(b) & ~mask));
}

static inline float ai_fm_expf(float x)
{
    x = ai_fm_sel(x < -87.0f, -87.0f, x);
    x = ai_fm_sel(x > 88.0f, 88.0f, x);
    float fx = x * 1.44269504088896341f;
    /* round to nearest without lrintf (keeps the loop vectorisable) */
    float n = (float)(int32_t)(fx + ai_fm_sel(fx >= 0.0f, 0.5f, -0.5f));
    float r = x - n * 0.693359375f;
    r = r - n * -2.12194440e-4f;
    float z = r * r;
    float y = ((((( 1.9875691500E-4f * r + 1.3981999507E-3f) * r + 8.3334519073E-3f) * r
                 + 4.1665795894E-2f) * r + 1.6666665459E-1f) * r + 5.0000001201E-1f);
    y = y * z + r + 1.0f;
    int32_t e = (int32_t)n + 127;
    return y * ai_fm_bits2f((uint32_t)e << 23);
}

/* x > 0, finite, normal. */
static inline float ai_fm_logf(float x)
{
    uint32_t u = ai_fm_f2bits(x);
    int32_t e = (int32_t)(u >> 23) - 127;
    float m = ai_fm_bits2f((u & 0x007fffffu) | 0x3f800000u); /* [1, 2) */
    int big = m > 1.41421356f;
    m = ai_fm_sel(big, m * 0.5f, m);
    e += big;
    float fe = (float)e;
    float t = m - 1.0f;
    float z = t * t;
    float y = ((((((((7.0376836292E-2f * t - 1.1514610310E-1f) * t + 1.1676998740E-1f) * t
                   - 1.2420140846E-1f) * t + 1.4249322787E-1f) * t - 1.6668057665E-1f) * t
                + 2.0000714765E-1f) * t - 2.4999993993E-1f) * t + 3.3333331174E-1f) * t * z;
    y += fe * -2.12194440e-4f;
    y += -0.5f * z;
    t = t + y;
    return t + fe * 0.693359375f;
}

/* sqrt(x) for x >= 0 (x < 1e-30 gives 0): inverse square root by the bit trick and three
 * Newton steps (libm's sqrtf keeps errno handling, which stops vectorisation). */
static inline float ai_fm_sqrtf(float x)
{
    const float xs = ai_fm_sel(x > 1e-30f, x, 1e-30f);
    float y = ai_fm_bits2f(0x5f3759dfu - (ai_fm_f2bits(xs) >> 1));
    y = y * (1.5f - 0.5f * xs * y * y);
    y = y * (1.5f - 0.5f * xs * y * y);
    y = y * (1.5f - 0.5f * xs * y * y);
    const float r = xs * y;
    return ai_fm_sel(x > 1e-30f, r, 0.0f);
}

/* log(1 + u) for u >= 0 (Kahan's trick keeps it accurate for tiny u). */
static inline float ai_fm_log1pf(float u)
{
    float w = 1.0f + u;
    float d = w - 1.0f;
    float l = ai_fm_logf(w);
    float r = l * (u / ai_fm_sel(d == 0.0f, 1.0f, d));
    return ai_fm_sel(d == 0.0f, u, r);
}

/* softplus(r) = log(1 + e^r), as max(r, 0) + log1p(e^-|r|): the sigma of a Bayesian weight
 * from its rho. Inline so that the loops over every rho of a neighbour's state (dinno.c) run
 * it vectorised; out of line (bnn_softplus) each call cost about 40 ns in a 64-robot fleet,
 * a quarter of its CPU. */
static inline float ai_fm_softplusf(float r)
{
    const float e = ai_fm_expf(-ai_fm_bits2f(ai_fm_f2bits(r) & 0x7fffffffu)); /* -|r| */
    return ai_fm_sel(r > 0.0f, r, 0.0f) + ai_fm_log1pf(e);
}

static inline void ai_fm_sincosf(float x, float *s, float *c)
{
    float ax = x < 0.0f ? -x : x;
    int32_t j = (int32_t)(ax * 1.27323954473516f);
    j = (j + 1) & ~1;
    float y = (float)j;
    float r = ((ax - y * 0.78515625f) - y * 2.4187564849853515625e-4f) - y * 3.77489497744594108e-8f;
    float z = r * r;
    float ps = ((-1.9515295891E-4f * z + 8.3321608736E-3f) * z - 1.6666654611E-1f) * z * r + r;
    float pc = ((2.443315711809948E-5f * z - 1.388731625493765E-3f) * z + 4.166664568298827E-2f) * z * z
               - 0.5f * z + 1.0f;
    int32_t q = (j >> 1) & 3;
    float sv = (q & 1) ? pc : ps;
    float cv = (q & 1) ? ps : pc;
    sv = (q & 2) ? -sv : sv;
    cv = ((q + 1) & 2) ? -cv : cv;
    *s = x < 0.0f ? -sv : sv;
    *c = cv;
}

/* sin x alone, for the int8 inference's SIREN layer (no cosine is needed there): reduced by
 * the nearest multiple k of pi (Cody-Waite, pi in three parts: Cephes' pi/4 split times 4, so
 * k * 3.140625 is exact for |k| < 2^16), r in [-pi/2, pi/2], one odd polynomial of degree 9
 * (SLEEF's sinf_u35 coefficients), the sign of (-1)^k: 16 operations where the two
 * polynomials of ai_fm_sincosf take 28. Max abs error 1.3e-7 over |x| < 8192 (ai_fm_sincosf:
 * 7.7e-8), with or without FMA contraction; the int8 path quantises it to 1/127 of its max.
 * Selects are bit selects (ai_fm_sel): with `c ? a : b` GCC sank the arms' arithmetic into
 * branches and vectorised it as masked operations under -ftrapping-math. */
static inline float ai_fm_sinf(float x)
{
    const float ax = ai_fm_sel(x < 0.0f, -x, x);
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
    const float sk = ai_fm_sel(k & 1, -s, s);
    return ai_fm_sel(x < 0.0f, -sk, sk);
}

#endif /* AI_FASTMATH_H */
