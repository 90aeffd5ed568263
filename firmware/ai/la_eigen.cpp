// Eigen back end of ai/la.h (the only C++ file of the firmware). With AVX2+FMA or AVX-512 the
// large products go to the packed kernel below (gemm_packed), the thin ones (the output layer,
// the SIREN weight gradient) and other targets to Eigen.
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

// The large products take a packed kernel of ours where it measured faster than Eigen's own:
// 6x16 with AVX2+FMA, 12x32 with AVX-512F (the same packing; measurements in
// firmware/ai/README.md). Everywhere else (SSE, NEON) Eigen is the fast path. LA_EIGEN_NO_PACKED
// (a -D for measurements) sends every product to Eigen.
#if !defined(LA_EIGEN_NO_PACKED) && defined(__AVX512F__)
#include <immintrin.h>
#define LA_PACKED_AVX512 1
#elif !defined(LA_EIGEN_NO_PACKED) && defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#define LA_PACKED_AVX2 1
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


#if defined(LA_PACKED_AVX2) || defined(LA_PACKED_AVX512)
// Packed GEMM for the large products of the BNN step (Eigen 3.4's gebp kernel reaches ~65
// GFLOP/s on the Zen 3 the AVX2 kernel was tuned on, MKL ~75). Goto/BLIS structure: the k
// dimension in blocks of KC, op(B) packed per block into NR-column micro-panels (KC x NR, one
// L1-resident panel at a time), op(A) packed per MC rows into MR-row micro-panels; an MR x NR
// register tile per micro-kernel call (AVX2: 6 x 16 in 12 ymm accumulators; AVX-512: 12 x 32
// in 24 of the 32 zmm registers). beta is applied on the first k block, so C is never zeroed
// beforehand and beta == 0 never reads C. Deterministic: the summation order depends only on
// the shape. Buffers are on the stack (KC*NC + MC*KC floats: 352 KB).
namespace {
#if defined(LA_PACKED_AVX512)
constexpr int MR = 12, NR = 32;
#else
constexpr int MR = 6, NR = 16;
#endif
constexpr int KC = 256, MC = 96, NC = 256;
static_assert(MC % MR == 0 && NC % NR == 0, "blocks hold whole micro-panels");
static_assert((KC * NC + MC * KC) * sizeof(float) < LA_EIGEN_STACK_BYTES, "within the stack budget");

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
                for (int j = 0; j < NR; j += 8)
                    _mm256_store_ps(dst + k * NR + j, _mm256_loadu_ps(src + j));
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

// Edge tiles (mr < MR or nr < NR) go through a stack copy of the accumulators.
inline void store_edge(const float *t, float *C, int ldc, int mr, int nr, float alpha, float beta,
                       bool first)
{
    for (int r = 0; r < mr; r++)
        for (int j = 0; j < nr; j++) {
            float *cv = C + (size_t)r * ldc + j;
            const float v = alpha * t[r * NR + j];
            *cv = !first ? *cv + v : (beta != 0.0f ? v + beta * *cv : v);
        }
}

#if defined(LA_PACKED_AVX512)
using vec = __m512;
constexpr int VL = 16;
inline vec vzero() { return _mm512_setzero_ps(); }
inline vec vload(const float *p) { return _mm512_load_ps(p); }
inline vec vloadu(const float *p) { return _mm512_loadu_ps(p); }
inline void vstore(float *p, vec v) { _mm512_store_ps(p, v); }
inline void vstoreu(float *p, vec v) { _mm512_storeu_ps(p, v); }
inline vec vbcast(const float *p) { return _mm512_set1_ps(*p); }
inline vec vset1(float x) { return _mm512_set1_ps(x); }
inline vec vfma(vec a, vec b, vec c) { return _mm512_fmadd_ps(a, b, c); }
inline vec vmul(vec a, vec b) { return _mm512_mul_ps(a, b); }
inline vec vadd(vec a, vec b) { return _mm512_add_ps(a, b); }
#else
using vec = __m256;
constexpr int VL = 8;
inline vec vzero() { return _mm256_setzero_ps(); }
inline vec vload(const float *p) { return _mm256_load_ps(p); }
inline vec vloadu(const float *p) { return _mm256_loadu_ps(p); }
inline void vstore(float *p, vec v) { _mm256_store_ps(p, v); }
inline void vstoreu(float *p, vec v) { _mm256_storeu_ps(p, v); }
inline vec vbcast(const float *p) { return _mm256_broadcast_ss(p); }
inline vec vset1(float x) { return _mm256_set1_ps(x); }
inline vec vfma(vec a, vec b, vec c) { return _mm256_fmadd_ps(a, b, c); }
inline vec vmul(vec a, vec b) { return _mm256_mul_ps(a, b); }
inline vec vadd(vec a, vec b) { return _mm256_add_ps(a, b); }
#endif
static_assert(NR == 2 * VL, "the tile is two vectors wide");

// C[mr x nr] (= or +=) alpha * Ap Bp (+ beta C on the first k block).
void micro(int kc, const float *__restrict Ap, const float *__restrict Bp, float *C, int ldc,
           int mr, int nr, float alpha, float beta, bool first)
{
    vec c[MR][2];
    for (int r = 0; r < MR; r++)
        c[r][0] = c[r][1] = vzero();
    for (int k = 0; k < kc; k++) {
        const vec b0 = vload(Bp + k * NR), b1 = vload(Bp + k * NR + VL);
        for (int r = 0; r < MR; r++) {
            const vec a = vbcast(Ap + k * MR + r);
            c[r][0] = vfma(a, b0, c[r][0]);
            c[r][1] = vfma(a, b1, c[r][1]);
        }
    }
    const vec va = vset1(alpha), vb = vset1(beta);
    if (mr == MR && nr == NR) {
        for (int r = 0; r < MR; r++) {
            float *cr = C + (size_t)r * ldc;
            for (int h = 0; h < 2; h++) {
                vec v = vmul(va, c[r][h]);
                if (!first)
                    v = vadd(vloadu(cr + VL * h), v);
                else if (beta != 0.0f)
                    v = vfma(vb, vloadu(cr + VL * h), v);
                vstoreu(cr + VL * h, v);
            }
        }
        return;
    }
    alignas(64) float t[MR * NR];
    for (int r = 0; r < MR; r++) {
        vstore(&t[r * NR], c[r][0]);
        vstore(&t[r * NR + VL], c[r][1]);
    }
    store_edge(t, C, ldc, mr, nr, alpha, beta, first);
}

void gemm_packed(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha, const float *A,
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
                        micro(kc, Ap + (size_t)is * kc, Bp + (size_t)js * kc,
                              C + (size_t)(i0 + is) * ldc + j0 + js, ldc,
                              mc - is < MR ? mc - is : MR, nc - js < NR ? nc - js : NR, alpha,
                              beta, p0 == 0);
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
#if defined(LA_PACKED_AVX2) || defined(LA_PACKED_AVX512)
    if (M >= 2 * MR && N >= NR && K >= 16) {
        gemm_packed(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, C, ldc);
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

extern "C" const char *la_eigen_kernel_name(void)
{
#if defined(LA_PACKED_AVX512)
    return "avx512-12x32+eigen";
#elif defined(LA_PACKED_AVX2)
    return "avx2-fma-6x16+eigen";
#elif defined(EIGEN_VECTORIZE_AVX512)
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
