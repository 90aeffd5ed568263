/* The pure-C reference of la_bf16.h: the rounding written out one step at a time. Compiled
 * without FMA contraction (Makefile), so every rounding below is the one written: fmaf is the
 * one rounding of acc + a * b (exact for bf16 factors), whatever the target. */
#include "ai/la_bf16.h"

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "ai/la_packed.h"

uint16_t la_bf16_round(float x)
{
    uint32_t u;
    memcpy(&u, &x, sizeof u);
    if ((u & 0x7F800000u) == 0)
        return (uint16_t)((u >> 16) & 0x8000u); /* zero or subnormal: a zero of its sign */
    if ((u & 0x7FFFFFFFu) > 0x7F800000u)
        return (uint16_t)((u >> 16) | 0x0040u); /* NaN: quiet, payload's top bits kept */
    u += 0x7FFFu + ((u >> 16) & 1u);             /* nearest, ties to even; may carry into inf */
    return (uint16_t)(u >> 16);
}

float la_bf16_widen(uint16_t h)
{
    const uint32_t u = (uint32_t)h << 16;
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

static inline float ftz(float v)
{
    return fabsf(v) < FLT_MIN ? copysignf(0.0f, v) : v;
}

static inline float op_bf(la_trans_t t, const float *X, int ld, int r, int c)
{
    return la_bf16_widen(la_bf16_round(t == LA_NO_TRANS ? X[(size_t)r * ld + c]
                                                        : X[(size_t)c * ld + r]));
}

/* Columns per pass: the accumulators of one row's JB columns are independent chains, so the
 * loop over them can run in vectors (and the rounding of op(A)'s element is done once per
 * JB columns). */
#define JB 32

void la_bf16_gemm_ref(la_trans_t ta, la_trans_t tb, int M, int N, int K, const float *A, int lda,
                      const float *B, int ldb, float *C, int ldc, const la_epilogue_t *ep)
{
    if (M <= 0 || N <= 0)
        return;
    for (int i = 0; i < M; i++) {
        for (int j0 = 0; j0 < N; j0 += JB) {
            const int nb = N - j0 < JB ? N - j0 : JB;
            float acc[JB], bo[JB], be[JB];
            for (int j = 0; j < nb; j++)
                acc[j] = 0.0f;
            for (int k = 0; k < K; k += 2) {
                const float ae = op_bf(ta, A, lda, i, k);
                const float ao = k + 1 < K ? op_bf(ta, A, lda, i, k + 1) : 0.0f;
                for (int j = 0; j < nb; j++) {
                    be[j] = op_bf(tb, B, ldb, k, j0 + j);
                    bo[j] = k + 1 < K ? op_bf(tb, B, ldb, k + 1, j0 + j) : 0.0f;
                }
                for (int j = 0; j < nb; j++) {
                    float v = ftz(fmaf(ao, bo[j], acc[j])); /* odd element first */
                    acc[j] = ftz(fmaf(ae, be[j], v));
                }
            }
            float *c = C + (size_t)i * ldc + j0;
            for (int j = 0; j < nb; j++)
                c[j] = ep ? la_epilogue_elem(ep, (size_t)i, j0 + j, acc[j]) : acc[j];
        }
    }
}
