/* Which kernel la_bf16_gemm runs: the AVX512_BF16 one when this is an x86-64 build of the fast
 * back end and the CPU has the instruction (cpuid with the OS's zmm-state check, through
 * __builtin_cpu_supports), else the pure-C reference. Chosen once, like la_packed.c. */
#include "ai/kernels/la_bf16.h"

#include <errno.h>
#include <stdatomic.h>
#include <stddef.h>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) && defined(LA_BACKEND_EIGEN)
#define LA_BF16_X86 1
#endif

int la_bf16_cpu_has(int id)
{
    if (id == LA_BF16_REF)
        return 1;
#if defined(LA_BF16_X86)
    if (id == LA_BF16_AVX512) {
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
               __builtin_cpu_supports("avx512bf16");
    }
#endif
    return 0;
}

/* -2: not chosen yet. Relaxed: every thread computes the same value, and la_bf16_force is
 * documented as not concurrent with la_bf16_gemm. */
static _Atomic int g_active = LA_BF16_AUTO;

static int choose(void)
{
    return la_bf16_cpu_has(LA_BF16_AVX512) ? LA_BF16_AVX512 : LA_BF16_REF;
}

static int active(void)
{
    int id = atomic_load_explicit(&g_active, memory_order_relaxed);
    if (id == LA_BF16_AUTO) {
        id = choose();
        atomic_store_explicit(&g_active, id, memory_order_relaxed);
    }
    return id;
}

int la_bf16_force(int id)
{
    if (id == LA_BF16_AUTO) {
        atomic_store_explicit(&g_active, choose(), memory_order_relaxed);
        return 0;
    }
    if (!la_bf16_cpu_has(id))
        return -ENOTSUP;
    atomic_store_explicit(&g_active, id, memory_order_relaxed);
    return 0;
}

const char *la_bf16_kernel_name(void)
{
    return active() == LA_BF16_AVX512 ? "avx512bf16-12x32" : "ref-c";
}

void la_bf16_gemm(la_trans_t ta, la_trans_t tb, int M, int N, int K, const float *A, int lda,
                  const float *B, int ldb, float *C, int ldc, const la_epilogue_t *ep)
{
#if defined(LA_BF16_X86)
    if (active() == LA_BF16_AVX512) {
        la_bf16_gemm_avx512(ta, tb, M, N, K, A, lda, B, ldb, C, ldc, ep);
        return;
    }
#endif
    la_bf16_gemm_ref(ta, tb, M, N, K, A, lda, B, ldb, C, ldc, ep);
}
