// Eigen back end of ai/la.h (the only C++ file of the firmware). With AVX2+FMA the large
// products go to the packed kernel below (gemm_avx2), the thin ones (the output layer, the
// SIREN weight gradient) and other targets to Eigen.
//
// No heap: Eigen's GEMM packs its operands into blocking buffers that it places on the stack
// (alloca) when they fit EIGEN_STACK_ALLOCATION_LIMIT, and on the heap otherwise. The limit is
// raised to LA_EIGEN_STACK_BYTES, above the largest blocking Eigen chooses for our shapes
// (its kc x mc and kc x nc panels are bounded by the cache sizes, not by the matrix size), and
// EIGEN_RUNTIME_NO_MALLOC makes any heap request an assertion failure in debug builds.
// tests/ai/test_bnn_noalloc.c proves the zero-allocation property with the wrapped allocator.
#define EIGEN_STACK_ALLOCATION_LIMIT (2 * 1024 * 1024)
#define EIGEN_DONT_PARALLELIZE 1
// Eigen is third-party code: its AVX-512 packet code, once inlined into our functions, trips
// GCC 12's -Wmaybe-uninitialized (a _mm512_undefined_ps() operand in ptranspose/ploadquad)
// even though the header is included as a system header. The fence covers exactly the
// headers included inside it (GCC and clang apply diagnostic pragmas by source location), so
// our own code below keeps every warning.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#if !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <Eigen/Core>
#pragma GCC diagnostic pop

extern "C" {
#include "ai/la.h"
}

#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#define LA_HAVE_AVX2_KERNEL 1
#endif

static_assert(EIGEN_STACK_ALLOCATION_LIMIT == LA_EIGEN_STACK_BYTES, "keep la.h in sync");

namespace {
using RowMat = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using CMap = Eigen::Map<const RowMat, Eigen::Unaligned, Eigen::OuterStride<>>;
using MMap = Eigen::Map<RowMat, Eigen::Unaligned, Eigen::OuterStride<>>;

template <typename OA, typename OB>
void gemm_into(MMap &c, const OA &a, const OB &b, float alpha, float beta)
{
    if (beta == 0.0f)
        c.setZero();
    else if (beta != 1.0f)
        c *= beta;
    if (c.rows() == 1) {
        // Row-vector result: Eigen's GEMV path would copy the scaled operand into a heap
        // temporary, so accumulate rows of op(B) lazily instead (no temporary).
        for (Eigen::Index k = 0; k < a.cols(); k++)
            c.row(0) += (alpha * a(0, k)) * b.row(k);
    } else if (c.cols() == 1) {
        for (Eigen::Index i = 0; i < c.rows(); i++)
            c(i, 0) += alpha * a.row(i).dot(b.col(0));
    } else {
        c.noalias() += alpha * (a * b);
    }
}
} // namespace


#if defined(LA_HAVE_AVX2_KERNEL)
// Packed AVX2/FMA GEMM for the large products of the BNN step (Eigen 3.4's gebp kernel reaches
// ~65 GFLOP/s on the Zen 3 this was tuned on, MKL ~75). Goto/BLIS structure: the k dimension in
// blocks of KC, op(B) packed per block into 16-column micro-panels (KC x 16, one L1-resident
// panel at a time), op(A) packed per MC rows into 6-row micro-panels; a 6 x 16 register tile
// (12 ymm accumulators) per micro-kernel call. beta is applied on the first k block, so C is
// never zeroed beforehand and beta == 0 never reads C. Deterministic: the summation order
// depends only on the shape. Buffers are on the stack (KC*NC + MC*KC floats = 352 KB).
namespace {
constexpr int MR = 6, NR = 16, KC = 256, MC = 96, NC = 256;

inline float opA(la_trans_t ta, const float *A, int lda, int i, int k)
{
    return ta == LA_NO_TRANS ? A[(size_t)i * lda + k] : A[(size_t)k * lda + i];
}

// Ap[strip][k][r], rows i0.., k p0.., zero padded to MR rows.
void pack_a(la_trans_t ta, const float *A, int lda, int i0, int mc, int p0, int kc, float *Ap)
{
    for (int s = 0; s < mc; s += MR) {
        const int mr = mc - s < MR ? mc - s : MR;
        float *dst = Ap + (size_t)s * kc;
        if (ta == LA_TRANS && mr == MR) {
            for (int k = 0; k < kc; k++) {
                const float *src = A + (size_t)(p0 + k) * lda + i0 + s;
                for (int r = 0; r < MR; r++)
                    dst[k * MR + r] = src[r];
            }
        } else if (mr == MR) {
            const float *src = A + (size_t)(i0 + s) * lda + p0;
            for (int k = 0; k < kc; k++)
                for (int r = 0; r < MR; r++)
                    dst[k * MR + r] = src[(size_t)r * lda + k];
        } else {
            for (int r = 0; r < MR; r++)
                for (int k = 0; k < kc; k++)
                    dst[k * MR + r] = r < mr ? opA(ta, A, lda, i0 + s + r, p0 + k) : 0.0f;
        }
    }
}

// Bp[strip][k][j], columns j0.., k p0.., zero padded to NR columns.
void pack_b(la_trans_t tb, const float *B, int ldb, int j0, int nc, int p0, int kc, float *Bp)
{
    for (int s = 0; s < nc; s += NR) {
        const int nr = nc - s < NR ? nc - s : NR;
        float *dst = Bp + (size_t)s * kc;
        if (tb == LA_NO_TRANS && nr == NR) {
            for (int k = 0; k < kc; k++) {
                const float *src = B + (size_t)(p0 + k) * ldb + j0 + s;
                _mm256_store_ps(dst + k * NR, _mm256_loadu_ps(src));
                _mm256_store_ps(dst + k * NR + 8, _mm256_loadu_ps(src + 8));
            }
        } else if (tb == LA_NO_TRANS) {
            for (int k = 0; k < kc; k++)
                for (int j = 0; j < NR; j++)
                    dst[k * NR + j] = j < nr ? B[(size_t)(p0 + k) * ldb + j0 + s + j] : 0.0f;
        } else {
            for (int j = 0; j < NR; j++) {
                if (j < nr) {
                    const float *src = B + (size_t)(j0 + s + j) * ldb + p0;
                    for (int k = 0; k < kc; k++)
                        dst[k * NR + j] = src[k];
                } else {
                    for (int k = 0; k < kc; k++)
                        dst[k * NR + j] = 0.0f;
                }
            }
        }
    }
}

// C[mr x nr] (= or +=) alpha * Ap Bp (+ beta C on the first k block).
void micro_6x16(int kc, const float *__restrict Ap, const float *__restrict Bp, float *C, int ldc,
                int mr, int nr, float alpha, float beta, bool first)
{
    __m256 c[MR][2];
    for (int r = 0; r < MR; r++)
        c[r][0] = c[r][1] = _mm256_setzero_ps();
    for (int k = 0; k < kc; k++) {
        const __m256 b0 = _mm256_load_ps(Bp + k * NR), b1 = _mm256_load_ps(Bp + k * NR + 8);
        for (int r = 0; r < MR; r++) {
            const __m256 a = _mm256_broadcast_ss(Ap + k * MR + r);
            c[r][0] = _mm256_fmadd_ps(a, b0, c[r][0]);
            c[r][1] = _mm256_fmadd_ps(a, b1, c[r][1]);
        }
    }
    const __m256 va = _mm256_set1_ps(alpha), vb = _mm256_set1_ps(beta);
    if (mr == MR && nr == NR) {
        for (int r = 0; r < MR; r++) {
            float *cr = C + (size_t)r * ldc;
            for (int h = 0; h < 2; h++) {
                __m256 v = _mm256_mul_ps(va, c[r][h]);
                if (!first)
                    v = _mm256_add_ps(_mm256_loadu_ps(cr + 8 * h), v);
                else if (beta != 0.0f)
                    v = _mm256_fmadd_ps(vb, _mm256_loadu_ps(cr + 8 * h), v);
                _mm256_storeu_ps(cr + 8 * h, v);
            }
        }
        return;
    }
    alignas(32) float t[MR][NR];
    for (int r = 0; r < MR; r++) {
        _mm256_store_ps(&t[r][0], c[r][0]);
        _mm256_store_ps(&t[r][8], c[r][1]);
    }
    for (int r = 0; r < mr; r++)
        for (int j = 0; j < nr; j++) {
            float *cv = C + (size_t)r * ldc + j;
            const float v = alpha * t[r][j];
            *cv = !first ? *cv + v : (beta != 0.0f ? v + beta * *cv : v);
        }
}

void gemm_avx2(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha, const float *A,
               int lda, const float *B, int ldb, float beta, float *C, int ldc)
{
    alignas(64) float Bp[KC * NC];
    alignas(64) float Ap[MC * KC];
    for (int j0 = 0; j0 < N; j0 += NC) {
        const int nc = N - j0 < NC ? N - j0 : NC;
        for (int p0 = 0; p0 < K; p0 += KC) {
            const int kc = K - p0 < KC ? K - p0 : KC;
            pack_b(tb, B, ldb, j0, nc, p0, kc, Bp);
            for (int i0 = 0; i0 < M; i0 += MC) {
                const int mc = M - i0 < MC ? M - i0 : MC;
                pack_a(ta, A, lda, i0, mc, p0, kc, Ap);
                for (int js = 0; js < nc; js += NR)
                    for (int is = 0; is < mc; is += MR)
                        micro_6x16(kc, Ap + (size_t)is * kc, Bp + (size_t)js * kc,
                                   C + (size_t)(i0 + is) * ldc + j0 + js, ldc,
                                   mc - is < MR ? mc - is : MR, nc - js < NR ? nc - js : NR,
                                   alpha, beta, p0 == 0);
            }
        }
    }
}
} // namespace
#endif

extern "C" void la_eigen_sgemm(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha,
                               const float *A, int lda, const float *B, int ldb, float beta,
                               float *C, int ldc)
{
    if (M <= 0 || N <= 0)
        return;
    MMap c(C, M, N, Eigen::OuterStride<>(ldc));
    if (K <= 0 || alpha == 0.0f) {
        if (beta == 0.0f)
            c.setZero();
        else if (beta != 1.0f)
            c *= beta;
        return;
    }
#if defined(LA_HAVE_AVX2_KERNEL)
    if (M >= 2 * MR && N >= NR && K >= 16) {
        gemm_avx2(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, C, ldc);
        return;
    }
#endif
    if (ta == LA_NO_TRANS) {
        CMap a(A, M, K, Eigen::OuterStride<>(lda));
        if (tb == LA_NO_TRANS)
            gemm_into(c, a, CMap(B, K, N, Eigen::OuterStride<>(ldb)), alpha, beta);
        else
            gemm_into(c, a, CMap(B, N, K, Eigen::OuterStride<>(ldb)).transpose(), alpha, beta);
    } else {
        CMap a(A, K, M, Eigen::OuterStride<>(lda));
        if (tb == LA_NO_TRANS)
            gemm_into(c, a.transpose(), CMap(B, K, N, Eigen::OuterStride<>(ldb)), alpha, beta);
        else
            gemm_into(c, a.transpose(), CMap(B, N, K, Eigen::OuterStride<>(ldb)).transpose(),
                      alpha, beta);
    }
}
