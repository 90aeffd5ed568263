// Eigen back end of ai/la.h (the only C++ file of the firmware): the thin products (the output
// layer, the SIREN weight gradient) and, on CPUs without a packed kernel of ours (la_packed.h),
// every product.
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
#include "ai/kernels/la.h"
}

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

extern "C" const char *la_eigen_kernel_name(void)
{
#if defined(EIGEN_VECTORIZE_AVX512)
    return "eigen-avx512";
#elif defined(EIGEN_VECTORIZE_AVX2)
    return "eigen-avx2";
#elif defined(EIGEN_VECTORIZE_AVX)
    return "eigen-avx";
#elif defined(EIGEN_VECTORIZE_SSE)
    return "eigen-sse";
#elif defined(EIGEN_VECTORIZE_NEON)
    return "eigen-neon";
#else
    return "eigen-scalar";
#endif
}
