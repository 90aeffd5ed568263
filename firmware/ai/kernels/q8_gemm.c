/* The int8 GEMM of the int8 inference path: the pure-C reference kernel and the run-time
 * choice among the kernels (the x86 ones live in ai/q8_x86.c). See ai/q8_gemm.h. */
#include "ai/kernels/q8_gemm.h"

#include <errno.h>
#include <stdatomic.h>

const q8_kernel_t q8_kernels[Q8_N] = {
#if defined(Q8_X86)
    [Q8_AVX512VNNI] = {"avx512vnni-zmm", q8_gemm_avx512vnni, 1, "avx512f+avx512bw+avx512vnni"},
    [Q8_AVX512VNNI_YMM] = {"avx512vnni-ymm", q8_gemm_avx512vnni_ymm, 1,
                           "avx512f+avx512vl+avx512vnni"},
    [Q8_AVXVNNI] = {"avxvnni-ymm", q8_gemm_avxvnni, 1, "avxvnni+avx2"},
    [Q8_AVX2] = {"avx2-sign", q8_gemm_avx2, 0, "avx2"},
#else
    [Q8_AVX512VNNI] = {"avx512vnni-zmm", NULL, 1, "avx512f+avx512bw+avx512vnni"},
    [Q8_AVX512VNNI_YMM] = {"avx512vnni-ymm", NULL, 1, "avx512f+avx512vl+avx512vnni"},
    [Q8_AVXVNNI] = {"avxvnni-ymm", NULL, 1, "avxvnni+avx2"},
    [Q8_AVX2] = {"avx2-sign", NULL, 0, "avx2"},
#endif
    [Q8_REF] = {"ref", q8_gemm_ref, 0, "none (pure C)"},
};

void q8_row_sums(const int8_t *W, size_t out, size_t in, int32_t *wsum)
{
    for (size_t j = 0; j < out; j++) {
        int32_t s = 0;
        for (size_t k = 0; k < in; k++)
            s += W[j * in + k];
        wsum[j] = s;
    }
}

void q8_gemm_ref(size_t np, size_t out, size_t in, const int8_t *A, size_t lda, const int8_t *W,
                 const int32_t *wsum, int32_t *C, size_t ldc)
{
    (void)wsum;
    if (lda == 1) {
        /* one point (np <= lda): A(0, k) = A[k], the dot products of the per-point path */
        for (size_t j = 0; j < out; j++) {
            const int8_t *w = W + j * in;
            int32_t acc = 0;
            for (size_t k = 0; k < in; k++)
                acc += (int32_t)w[k] * (int32_t)A[k];
            C[j * ldc] = acc;
        }
        return;
    }
    const size_t nq = in / 4, rem = in % 4;
    for (size_t j = 0; j < out; j++) {
        const int8_t *w = W + j * in;
        int32_t *c = C + j * ldc;
        for (size_t p = 0; p < np; p++)
            c[p] = 0;
        for (size_t q = 0; q < nq; q++) {
            const int32_t w0 = w[4 * q], w1 = w[4 * q + 1], w2 = w[4 * q + 2], w3 = w[4 * q + 3];
            const int8_t *a = A + q * 4 * lda;
            for (size_t p = 0; p < np; p++)
                c[p] += a[4 * p] * w0 + a[4 * p + 1] * w1 + a[4 * p + 2] * w2 + a[4 * p + 3] * w3;
        }
        for (size_t r = 0; r < rem; r++) {
            const int32_t wr = w[4 * nq + r];
            const int8_t *a = A + nq * 4 * lda + r;
            for (size_t p = 0; p < np; p++)
                c[p] += a[4 * p] * wr;
        }
    }
}

#if defined(Q8_X86)
/* AVX-VNNI (VEX) is CPUID.(EAX=7,ECX=1):EAX bit 4; not every compiler's
 * __builtin_cpu_supports knows the name (clang 14 does not), so ask cpuid. The register state
 * it needs (ymm) is the one AVX2 needs, which __builtin_cpu_supports("avx2") checks. */
static int cpu_avxvnni(void)
{
    unsigned a, b, c, d;
    __asm__ volatile("cpuid" : "=a"(a), "=b"(b), "=c"(c), "=d"(d) : "a"(0u), "c"(0u));
    if (a < 7u)
        return 0;
    __asm__ volatile("cpuid" : "=a"(a), "=b"(b), "=c"(c), "=d"(d) : "a"(7u), "c"(1u));
    return (a >> 4) & 1u;
}
#endif

int q8_cpu_has(int id)
{
    if (id < 0 || id >= Q8_N || !q8_kernels[id].fn)
        return 0;
    if (id == Q8_REF)
        return 1;
#if defined(Q8_X86)
    __builtin_cpu_init();
    const int avx512vnni =
        __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vnni");
    switch (id) {
    case Q8_AVX512VNNI:
        return avx512vnni && __builtin_cpu_supports("avx512bw");
    case Q8_AVX512VNNI_YMM:
        return avx512vnni && __builtin_cpu_supports("avx512vl");
    case Q8_AVXVNNI:
        return __builtin_cpu_supports("avx2") && cpu_avxvnni();
    case Q8_AVX2:
        return __builtin_cpu_supports("avx2") != 0;
    default:
        break;
    }
#endif
    return 0;
}

/* -2: not chosen yet; else the kernel's id. Relaxed: every thread computes the same value, and
 * q8_force is documented as not concurrent with the inference. */
static _Atomic int g_active = -2;

static int choose(void)
{
    for (int id = 0; id < Q8_N; id++)
        if (q8_cpu_has(id))
            return id;
    return Q8_REF;
}

const q8_kernel_t *q8_active(void)
{
    int id = atomic_load_explicit(&g_active, memory_order_relaxed);
    if (id == -2) {
        id = choose();
        atomic_store_explicit(&g_active, id, memory_order_relaxed);
    }
    return &q8_kernels[id];
}

const char *q8_kernel_name(void)
{
    return q8_active()->name;
}

int q8_force(int id)
{
    if (id == Q8_AUTO) {
        atomic_store_explicit(&g_active, choose(), memory_order_relaxed);
        return 0;
    }
    if (id < 0 || id >= Q8_N)
        return -EINVAL;
    if (!q8_cpu_has(id))
        return -ENOTSUP;
    atomic_store_explicit(&g_active, id, memory_order_relaxed);
    return 0;
}
