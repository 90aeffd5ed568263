/* Pure-C reference GEMM, written so GCC vectorises it without intrinsics (any target).
 *
 * Blocking (Goto style, sized for small stacks): for each KC-slice of k and NC-slice of j,
 * op(B) is packed into Bp[k][j] (KC x NC, scaled by alpha); for each MC-slice of i, op(A) is
 * packed into Ap[i][k] (MC x KC). The micro-kernel computes a MR x NR (4 x 16) block of C with
 * its accumulators in a fixed-size local array that the compiler keeps in vector registers:
 * per k, 4 broadcasts of Ap and 2 vector loads of Bp feed 8 FMAs. Edges use the same kernel
 * on zero-padded packs. Packing handles the four transpose cases, so the kernel sees one
 * layout. Stack use: (MC*KC + KC*NC) floats, 32 KB with the default blocks; the blocks are
 * build settings (LA_REF_KC, LA_REF_MC, LA_REF_NC in common/fw_config.h), so a board with small
 * stacks takes smaller ones. The blocking fixes the order of the sums: one blocking, one result
 * bit for bit. */
#include "ai/kernels/la.h"

#include <stddef.h>

#define MR 4
#define NR 16
#define KC LA_REF_KC
#define MC LA_REF_MC
#define NC LA_REF_NC

_Static_assert(KC >= 1 && MC % MR == 0 && NC % NR == 0 && MC >= MR && NC >= NR,
               "LA_REF_MC must be a multiple of 4 and LA_REF_NC of 16");
_Static_assert((size_t)(MC + NC) * KC * sizeof(float) <= BOARD_STACK_AI_BYTES / 2,
               "the GEMM's packed panels take more than half the AI core's stack: smaller LA_REF_* blocks");

static inline void micro_kernel(int kc, const float *restrict ap, const float *restrict bp,
                                float *restrict c, int ldc, int mr, int nr)
{
    float acc[MR][NR];
    for (int r = 0; r < MR; r++)
        for (int j = 0; j < NR; j++)
            acc[r][j] = 0.0f;
    for (int k = 0; k < kc; k++) {
        const float *b = bp + (size_t)k * NC;
        const float *a = ap + (size_t)k;
        for (int r = 0; r < MR; r++) {
            const float av = a[(size_t)r * KC];
            for (int j = 0; j < NR; j++)
                acc[r][j] += av * b[j];
        }
    }
    for (int r = 0; r < mr; r++)
        for (int j = 0; j < nr; j++)
            c[(size_t)r * ldc + j] += acc[r][j];
}

void la_ref_sgemm(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha,
                  const float *A, int lda, const float *B, int ldb, float beta, float *C,
                  int ldc)
{
    if (M <= 0 || N <= 0)
        return;
    /* C = beta * C first (beta == 0 writes zeros without reading C). */
    for (int i = 0; i < M; i++) {
        float *c = C + (size_t)i * ldc;
        if (beta == 0.0f)
            for (int j = 0; j < N; j++)
                c[j] = 0.0f;
        else if (beta != 1.0f)
            for (int j = 0; j < N; j++)
                c[j] *= beta;
    }
    if (K <= 0 || alpha == 0.0f)
        return;

    float Bp[KC * NC];
    float Ap[MC * KC];
    for (int k0 = 0; k0 < K; k0 += KC) {
        const int kc = K - k0 < KC ? K - k0 : KC;
        for (int j0 = 0; j0 < N; j0 += NC) {
            const int nc = N - j0 < NC ? N - j0 : NC;
            for (int k = 0; k < kc; k++) {
                float *t = Bp + (size_t)k * NC;
                if (tb == LA_NO_TRANS) {
                    const float *b = B + (size_t)(k0 + k) * ldb + j0;
                    for (int j = 0; j < nc; j++)
                        t[j] = alpha * b[j];
                } else {
                    const float *b = B + (size_t)j0 * ldb + (k0 + k);
                    for (int j = 0; j < nc; j++)
                        t[j] = alpha * b[(size_t)j * ldb];
                }
                for (int j = nc; j < NC; j++)
                    t[j] = 0.0f;
            }
            for (int i0 = 0; i0 < M; i0 += MC) {
                const int mc = M - i0 < MC ? M - i0 : MC;
                for (int i = 0; i < MC; i++) {
                    float *t = Ap + (size_t)i * KC;
                    if (i >= mc) {
                        for (int k = 0; k < kc; k++)
                            t[k] = 0.0f;
                    } else if (ta == LA_NO_TRANS) {
                        const float *a = A + (size_t)(i0 + i) * lda + k0;
                        for (int k = 0; k < kc; k++)
                            t[k] = a[k];
                    } else {
                        const float *a = A + (size_t)k0 * lda + (i0 + i);
                        for (int k = 0; k < kc; k++)
                            t[k] = a[(size_t)k * lda];
                    }
                }
                for (int i = 0; i < mc; i += MR)
                    for (int j = 0; j < nc; j += NR)
                        micro_kernel(kc, Ap + (size_t)i * KC, Bp + j,
                                     C + (size_t)(i0 + i) * ldc + (j0 + j), ldc,
                                     mc - i < MR ? mc - i : MR, nc - j < NR ? nc - j : NR);
            }
        }
    }
}
