/* Pure-C reference GEMM. Blocking: op(B) is packed, KC x NC at a time, into a 16 KB stack
 * tile laid out row-major [k][j]; every row i of C then accumulates
 *     acc[j] += op(A)(i, k) * tile[k][j]
 * over the tile's k, an axpy over contiguous j that vectorises whatever the transposes are.
 * acc (NC floats) lives in L1 across the k loop and is added to C once per tile, so C is
 * touched K/KC times instead of K times. */
#include "ai/la.h"

#include <stddef.h>

#define KC 64
#define NC 64

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

    float tile[KC * NC];
    float acc[NC];
    for (int j0 = 0; j0 < N; j0 += NC) {
        const int nc = N - j0 < NC ? N - j0 : NC;
        for (int k0 = 0; k0 < K; k0 += KC) {
            const int kc = K - k0 < KC ? K - k0 : KC;
            /* pack op(B)[k0:k0+kc, j0:j0+nc], scaled by alpha */
            for (int k = 0; k < kc; k++) {
                float *t = tile + (size_t)k * NC;
                if (tb == LA_NO_TRANS) {
                    const float *b = B + (size_t)(k0 + k) * ldb + j0;
                    for (int j = 0; j < nc; j++)
                        t[j] = alpha * b[j];
                } else {
                    const float *b = B + (size_t)j0 * ldb + (k0 + k);
                    for (int j = 0; j < nc; j++)
                        t[j] = alpha * b[(size_t)j * ldb];
                }
            }
            for (int i = 0; i < M; i++) {
                for (int j = 0; j < nc; j++)
                    acc[j] = 0.0f;
                for (int k = 0; k < kc; k++) {
                    const float a = ta == LA_NO_TRANS ? A[(size_t)i * lda + (k0 + k)]
                                                      : A[(size_t)(k0 + k) * lda + i];
                    const float *t = tile + (size_t)k * NC;
                    for (int j = 0; j < nc; j++)
                        acc[j] += a * t[j];
                }
                float *c = C + (size_t)i * ldc + j0;
                for (int j = 0; j < nc; j++)
                    c[j] += acc[j];
            }
        }
    }
}
