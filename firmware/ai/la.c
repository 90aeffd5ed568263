/* Dispatch to the board's LA back end. With LA_BACKEND=ref the Eigen shim is not compiled,
 * so nothing here may name la_eigen_* in that configuration. */
#include "ai/la.h"

#if defined(LA_BACKEND_EIGEN) && defined(LA_BACKEND_REF)
#error "define only one of LA_BACKEND_EIGEN, LA_BACKEND_REF"
#endif

#include <stdatomic.h>

static _Atomic int g_force_ref; /* relaxed: a benchmark switch, not a synchronisation point */

void la_force_ref(int ref)
{
    atomic_store_explicit(&g_force_ref, ref != 0, memory_order_relaxed);
}

void la_sgemm(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha, const float *A,
              int lda, const float *B, int ldb, float beta, float *C, int ldc)
{
#if defined(LA_BACKEND_EIGEN)
    if (!atomic_load_explicit(&g_force_ref, memory_order_relaxed)) {
        la_eigen_sgemm(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, C, ldc);
        return;
    }
    la_ref_sgemm(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, C, ldc);
#else
    la_ref_sgemm(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, C, ldc);
#endif
}

const char *la_backend_name(void)
{
#if defined(LA_BACKEND_EIGEN)
    if (!atomic_load_explicit(&g_force_ref, memory_order_relaxed))
        return "eigen";
    return "ref";
#else
    return "ref";
#endif
}

const char *la_kernel_name(void)
{
#if defined(LA_BACKEND_EIGEN)
    if (!atomic_load_explicit(&g_force_ref, memory_order_relaxed))
        return la_eigen_kernel_name();
#endif
    return "ref-c";
}
