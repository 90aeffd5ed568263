/* Dispatch to the board's LA back end. With LA_BACKEND=eigen the large products go to the
 * packed kernel the CPU runs fastest (la_packed.c) and the thin ones, or all of them when there
 * is none, to Eigen. With LA_BACKEND=ref the Eigen shim is not compiled, so nothing here may
 * name la_eigen_* in that configuration. */
#include "ai/kernels/la.h"

#if defined(LA_BACKEND_EIGEN) && defined(LA_BACKEND_REF)
#error "define only one of LA_BACKEND_EIGEN, LA_BACKEND_REF"
#endif

#include <stdatomic.h>
#include <stddef.h>

#include "ai/kernels/la_packed.h"

static _Atomic int g_force_ref; /* relaxed: a benchmark switch, not a synchronisation point */

void la_force_ref(int ref)
{
    atomic_store_explicit(&g_force_ref, ref != 0, memory_order_relaxed);
}

#if defined(LA_BACKEND_EIGEN)
/* Packing pays off from two register tiles of rows and one of columns up, and a k of 16. */
static int packed_worth(const la_packed_kernel_t *k, int M, int N, int K)
{
    return k && M >= 2 * k->mr && N >= k->nr && K >= 16;
}
#endif

/* The epilogue as a plain pass over C, after a back end without one. */
static void epilogue(int M, int N, float *C, int ldc, const la_epilogue_t *ep)
{
    for (int i = 0; i < M; i++) {
        float *restrict c = C + (size_t)i * ldc;
        for (int j = 0; j < N; j++)
            c[j] = la_epilogue_elem(ep, (size_t)i, j, c[j]);
    }
}

void la_sgemm_ep(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha, const float *A,
                 int lda, const float *B, int ldb, float beta, float *C, int ldc,
                 const la_epilogue_t *ep)
{
    if (M <= 0 || N <= 0)
        return;
#if defined(LA_BACKEND_EIGEN)
    if (!atomic_load_explicit(&g_force_ref, memory_order_relaxed)) {
        const la_packed_kernel_t *k = la_packed_active();
        if (packed_worth(k, M, N, K)) {
            k->fn(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, C, ldc, ep);
            return;
        }
        la_eigen_sgemm(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, C, ldc);
    } else {
        la_ref_sgemm(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, C, ldc);
    }
#else
    la_ref_sgemm(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, C, ldc);
#endif
    if (ep)
        epilogue(M, N, C, ldc, ep);
}

void la_sgemm(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha, const float *A,
              int lda, const float *B, int ldb, float beta, float *C, int ldc)
{
    la_sgemm_ep(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, C, ldc, NULL);
}

const char *la_backend_name(void)
{
#if defined(LA_BACKEND_EIGEN)
    if (!atomic_load_explicit(&g_force_ref, memory_order_relaxed))
        return "eigen";
#endif
    return "ref";
}

const char *la_kernel_name(void)
{
#if defined(LA_BACKEND_EIGEN)
    if (!atomic_load_explicit(&g_force_ref, memory_order_relaxed)) {
        const la_packed_kernel_t *k = la_packed_active();
        return k ? k->with_eigen : la_eigen_kernel_name();
    }
#endif
    return "ref-c";
}
