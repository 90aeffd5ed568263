/* The pure-C reference of la_bf16.h: the rounding written out one step at a time. Compiled
 * without FMA contraction (Makefile), so every rounding below is the one written: fmaf is the
 * one rounding of acc + a * b (exact for bf16 factors), whatever the target. */
#include "ai/kernels/la_bf16.h"

#include <float.h>
#include <math.h>
#include <stddef.h>

#include "ai/ai_fastmath.h"
#include "ai/kernels/la_packed.h"

uint16_t la_bf16_round(float x)
{
    uint32_t u = ai_fm_f2bits(x);
    if ((u & 0x7F800000u) == 0)
        return (uint16_t)((u >> 16) & 0x8000u); /* zero or subnormal: a zero of its sign */
    if ((u & 0x7FFFFFFFu) > 0x7F800000u)
        return (uint16_t)((u >> 16) | 0x0040u); /* NaN: quiet, payload's top bits kept */
    u += 0x7FFFu + ((u >> 16) & 1u);             /* nearest, ties to even; may carry into inf */
    return (uint16_t)(u >> 16);
}

float la_bf16_widen(uint16_t h)
{
    return ai_fm_bits2f((uint32_t)h << 16);
}

/* A subnormal result becomes a zero of its sign; in bits, so that the loop below vectorises
 * (a float comparison there would keep GCC from if-converting it under -ftrapping-math). */
static inline float ftz(float v)
{
    const uint32_t u = ai_fm_f2bits(v);
    return ai_fm_bits2f((u & 0x7F800000u) ? u : (u & 0x80000000u));
}

static inline float rounded(float x)
{
    return la_bf16_widen(la_bf16_round(x));
}

/* Blocking (the fp32 reference's build settings LA_REF_KC, LA_REF_NC, so small stacks stay
 * small): op(B) is rounded once per KB x JB block into a stack panel (zero rows past K, so
 * an odd K's missing element is 0 * 0), and each row of C runs JB independent accumulator
 * chains over it, which the compiler may put in vectors. A k block past the first continues
 * the accumulators from C, where the previous block left them: the chain of roundings is the
 * one of la_bf16.h whatever the blocking. */
#define JB LA_REF_NC
#define IR 4 /* rows of C at a time: independent chains, so the FMA latency is hidden */
#define KB (LA_REF_KC >= 2 ? LA_REF_KC & ~1 : 2) /* whole pairs */
_Static_assert((size_t)(KB + IR) * (JB + IR) * sizeof(float) <= BOARD_STACK_AI_BYTES / 2,
               "the bf16 panel takes more than half the AI core's stack: smaller LA_REF_* blocks");

void la_bf16_gemm_ref(la_trans_t ta, la_trans_t tb, int M, int N, int K, const float *A, int lda,
                      const float *B, int ldb, float *C, int ldc, const la_epilogue_t *ep)
{
    if (M <= 0 || N <= 0)
        return;
    float bp[KB][JB];
    for (int j0 = 0; j0 < N; j0 += JB) {
        const int nb = N - j0 < JB ? N - j0 : JB;
        for (int k0 = 0; k0 < K || k0 == 0; k0 += KB) {
            const int kb = K - k0 < KB ? K - k0 : KB, kp = (kb + 1) / 2;
            const int first = k0 == 0, last = k0 + KB >= K;
            for (int k = 0; k < 2 * kp; k++)
                for (int j = 0; j < JB; j++)
                    bp[k][j] = k < kb && j < nb
                                   ? rounded(tb == LA_NO_TRANS ? B[(size_t)(k0 + k) * ldb + j0 + j]
                                                               : B[(size_t)(j0 + j) * ldb + k0 + k])
                                   : 0.0f;
            for (int i0 = 0; i0 < M; i0 += IR) {
                const int ni = M - i0 < IR ? M - i0 : IR;
                float acc[IR][JB], ar[IR][KB]; /* rows of C; rows of op(A), rounded, 0 past K */
                for (int r = 0; r < IR; r++) {
                    const int i = i0 + (r < ni ? r : 0);
                    for (int j = 0; j < JB; j++)
                        acc[r][j] = first || j >= nb ? 0.0f : C[(size_t)i * ldc + j0 + j];
                    for (int k = 0; k < 2 * kp; k++) {
                        const size_t at = ta == LA_NO_TRANS ? (size_t)i * lda + (size_t)(k0 + k)
                                                            : (size_t)(k0 + k) * lda + (size_t)i;
                        ar[r][k] = k < kb ? rounded(A[at]) : 0.0f;
                    }
                }
                for (int p = 0; p < kp; p++) {
                    const float *restrict be = bp[2 * p], *restrict bo = bp[2 * p + 1];
                    for (int r = 0; r < IR; r++) {
                        const float ae = ar[r][2 * p], ao = ar[r][2 * p + 1];
                        for (int j = 0; j < JB; j++) /* the odd element first */
                            acc[r][j] = ftz(fmaf(ae, be[j], ftz(fmaf(ao, bo[j], acc[r][j]))));
                    }
                }
                for (int r = 0; r < ni; r++) {
                    float *c = C + (size_t)(i0 + r) * ldc + j0;
                    for (int j = 0; j < nb; j++)
                        c[j] = last && ep
                                   ? la_epilogue_elem(ep, (size_t)(i0 + r), j0 + j, acc[r][j])
                                   : acc[r][j];
                }
            }
        }
    }
}
