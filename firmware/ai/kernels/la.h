/* Small linear-algebra API of the AI core: row-major single-precision GEMM.
 *
 *   C[M x N] = alpha * op(A) * op(B) + beta * C
 *   op(A) is M x K: A itself (ta == LA_NO_TRANS, A is M x K, row stride lda >= K) or A^T
 *   (ta == LA_TRANS, A is K x M, lda >= M); likewise op(B) is K x N (tb: B is K x N with
 *   ldb >= N, or N x K with ldb >= K). C has row stride ldc >= N. beta == 0 never reads C
 *   (NaN in C does not propagate). M, N, K >= 0; K == 0 gives C = beta * C.
 *
 * Back ends: la_ref_* (pure C11, cache-blocked, always built) and, with LA_BACKEND=eigen, the
 * packed kernels of la_packed.h (AVX-512 12x32, AVX2+FMA 6x16, NEON 8x8: the one the running
 * CPU executes fastest, chosen at run time, takes the products with M >= 2 tile rows, N >= one
 * tile of columns, K >= 16) and la_eigen_* (la_eigen.cpp, extern "C": Eigen 3.4 for the thin
 * products, and for all of them where no packed kernel runs).
 * la_* dispatches to the board's back end (LA_BACKEND_EIGEN or LA_BACKEND_REF). No function
 * allocates: the Eigen shim keeps its packing/blocking buffers on the stack (at most
 * LA_EIGEN_STACK_BYTES per call), a packed kernel its panels (LA_PACKED_STACK_BYTES), the
 * reference path a fixed stack tile (LA_REF_* blocks). Results are deterministic for a given
 * back end, build and CPU (the summation order depends only on the shape, and the packed
 * kernels agree bit for bit). Thread-safe (no shared state but the kernel chosen once).
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

/* What la_sgemm_ep does to each finished element of C, in this order, so that the pass a
 * layer needs after its product happens while the tile is still in registers:
 *   bias:   c += bias[j]                     (NULL: none)
 *   relu:   c = c > 0 ? c : 0                (NaN gives 0)
 *   gate:   c = gate[i * ldg + j] > 0 ? c : 0 (NULL: none; ReLU's derivative in a backward pass)
 *   colsum: colsum[j] += c, rows in ascending order (NULL: none; colsum is not cleared)
 * Every back end gives the same bits for these as a plain loop over C after the product. */
typedef struct la_epilogue {
    const float *bias;
    int relu;
    const float *gate;
    int ldg;
    float *colsum;
} la_epilogue_t;

/* la_sgemm, then the epilogue (ep may be NULL). */
void la_sgemm_ep(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha, const float *A,
                 int lda, const float *B, int ldb, float beta, float *C, int ldc,
                 const la_epilogue_t *ep);

void la_ref_sgemm(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha,
                  const float *A, int lda, const float *B, int ldb, float beta, float *C,
                  int ldc);

void la_eigen_sgemm(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha,
                    const float *A, int lda, const float *B, int ldb, float beta, float *C,
                    int ldc);

/* Name of the back end la_* dispatches to ("eigen" or "ref"). */
const char *la_backend_name(void);

/* Name of the kernel the large products of la_sgemm take in this build on this CPU, so that
 * figures can be compared across machines: "avx512-12x32+eigen", "avx2-fma-6x16+eigen",
 * "neon-8x8+eigen" (a packed kernel, Eigen for thin shapes), "eigen-avx512", "eigen-avx2", "eigen-avx", "eigen-sse", "eigen-neon",
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
