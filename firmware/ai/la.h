/* Small linear-algebra API of the AI core: row-major single-precision GEMM.
 *
 *   C[M x N] = alpha * op(A) * op(B) + beta * C
 *   op(A) is M x K: A itself (ta == LA_NO_TRANS, A is M x K, row stride lda >= K) or A^T
 *   (ta == LA_TRANS, A is K x M, lda >= M); likewise op(B) is K x N (tb: B is K x N with
 *   ldb >= N, or N x K with ldb >= K). C has row stride ldc >= N. beta == 0 never reads C
 *   (NaN in C does not propagate). M, N, K >= 0; K == 0 gives C = beta * C.
 *
 * Back ends: la_ref_* (pure C11, cache-blocked, always built) and la_eigen_* (la_eigen.cpp,
 * extern "C", built only when LA_BACKEND=eigen: when compiled with AVX2+FMA but not AVX-512,
 * products with M >= 12, N >= 16, K >= 16 use a packed 6x16 AVX2/FMA kernel, everything else
 * Eigen 3.4 with the widest vectors the target has).
 * la_* dispatches to the board's back end (LA_BACKEND_EIGEN or LA_BACKEND_REF). No function
 * allocates: the Eigen shim keeps its packing/blocking buffers on the stack (at most
 * LA_EIGEN_STACK_BYTES per call; the AVX2 kernel uses 352 KB), the reference path uses a
 * fixed 16 KB stack tile. Results are deterministic for a given back end and build (the
 * summation order depends only on the shape). Thread-safe (no shared state).
 */
#ifndef AI_LA_H
#define AI_LA_H

#ifdef __cplusplus
extern "C" {
#endif

typedef enum la_trans { LA_NO_TRANS = 0, LA_TRANS = 1 } la_trans_t;

/* Stack bytes the Eigen back end may use per GEMM call for its packing buffers. */
#define LA_EIGEN_STACK_BYTES (2u * 1024u * 1024u)

void la_sgemm(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha, const float *A,
              int lda, const float *B, int ldb, float beta, float *C, int ldc);

void la_ref_sgemm(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha,
                  const float *A, int lda, const float *B, int ldb, float beta, float *C,
                  int ldc);

void la_eigen_sgemm(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha,
                    const float *A, int lda, const float *B, int ldb, float beta, float *C,
                    int ldc);

/* Name of the back end la_* dispatches to ("eigen" or "ref"). */
const char *la_backend_name(void);

/* Name of the kernel the large products of la_sgemm take in this build, so that figures can
 * be compared across machines: "avx2-fma-6x16+eigen" (the packed AVX2 kernel, Eigen for thin
 * shapes), "eigen-avx512", "eigen-avx2", "eigen-avx", "eigen-sse", "eigen-neon",
 * "eigen-scalar", or "ref-c" (pure C). Follows la_force_ref. */
const char *la_kernel_name(void);
const char *la_eigen_kernel_name(void);

/* For benchmarks and tests only: make la_* use the reference back end (ref != 0) or the
 * board's back end (ref == 0), process-wide. Not to be called while another thread is inside
 * la_*. Default: the board's back end. */
void la_force_ref(int ref);

#ifdef __cplusplus
}
#endif

#endif /* AI_LA_H */
