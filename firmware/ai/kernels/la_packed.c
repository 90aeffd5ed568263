/* Which packed kernel la_sgemm uses: the fastest one the running CPU can execute, chosen once
 * (the CPU does not change under a running program). x86-64 builds carry the AVX-512 and AVX2
 * kernels whatever their baseline and ask the CPU (cpuid, with the OS's register-state check,
 * through __builtin_cpu_supports); aarch64 builds carry the NEON kernel; other targets (the
 * Cortex-M boards) none, and la_sgemm stays on Eigen or the pure-C reference. */
#include "ai/kernels/la_packed.h"

#include <errno.h>
#include <stdatomic.h>
#include <stddef.h>

/* -DLA_PACKED_NONE (for measurements): no packed kernel, Eigen does every product. */
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) && !defined(LA_PACKED_NONE)
#define LA_PACKED_X86 1
#endif
#if defined(__aarch64__) && defined(__ARM_NEON) && !defined(LA_PACKED_NONE)
#define LA_PACKED_ARM 1
#endif

const la_packed_kernel_t la_packed_kernels[LA_PACKED_N] = {
#if defined(LA_PACKED_X86)
    [LA_PACKED_AVX512] = {"avx512-12x32", "avx512-12x32+eigen", la_packed_sgemm_avx512, 12, 32, "avx512f"},
    [LA_PACKED_AVX2] = {"avx2-fma-6x16", "avx2-fma-6x16+eigen", la_packed_sgemm_avx2, 6, 16, "avx2+fma"},
#else
    [LA_PACKED_AVX512] = {"avx512-12x32", "avx512-12x32+eigen", NULL, 12, 32, "avx512f"},
    [LA_PACKED_AVX2] = {"avx2-fma-6x16", "avx2-fma-6x16+eigen", NULL, 6, 16, "avx2+fma"},
#endif
#if defined(LA_PACKED_ARM)
    [LA_PACKED_NEON] = {"neon-8x8", "neon-8x8+eigen", la_packed_sgemm_neon, 8, 8, "neon"},
#else
    [LA_PACKED_NEON] = {"neon-8x8", "neon-8x8+eigen", NULL, 8, 8, "neon"},
#endif
};

int la_packed_cpu_has(int id)
{
    if (id < 0 || id >= LA_PACKED_N || !la_packed_kernels[id].fn)
        return 0;
#if defined(LA_PACKED_X86)
    __builtin_cpu_init();
    if (id == LA_PACKED_AVX512)
        return __builtin_cpu_supports("avx512f") != 0;
    if (id == LA_PACKED_AVX2)
        return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#endif
    return id == LA_PACKED_NEON;
}

/* -2: not chosen yet; -1: none; else the kernel's id. Relaxed: every thread computes the same
 * value, and la_packed_force is documented as not concurrent with la_*. */
static _Atomic int g_active = -2;

static int choose(void)
{
    for (int id = 0; id < LA_PACKED_N; id++)
        if (la_packed_cpu_has(id))
            return id;
    return -1;
}

const la_packed_kernel_t *la_packed_active(void)
{
    int id = atomic_load_explicit(&g_active, memory_order_relaxed);
    if (id == -2) {
        id = choose();
        atomic_store_explicit(&g_active, id, memory_order_relaxed);
    }
    return id >= 0 ? &la_packed_kernels[id] : NULL;
}

int la_packed_force(int id)
{
    if (id == -2 || id == -1) {
        atomic_store_explicit(&g_active, id == -2 ? choose() : -1, memory_order_relaxed);
        return 0;
    }
    if (!la_packed_cpu_has(id))
        return -ENOTSUP;
    atomic_store_explicit(&g_active, id, memory_order_relaxed);
    return 0;
}
