/* FMA throughput probe (fma_probe.h). Inline assembly, so the compiler can neither fold the
 * chains nor spill them: each iteration issues 12 independent vector FMAs. */
#include "fma_probe.h"

#include <string.h>
#include <time.h>

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

#define ITERS 4000000L
#define CHAINS 12

#if defined(__x86_64__)
#define FMA12(op, r)                                                                           \
    op " %%" r "12, %%" r "13, %%" r "0\n\t" op " %%" r "12, %%" r "13, %%" r "1\n\t"             \
    op " %%" r "12, %%" r "13, %%" r "2\n\t" op " %%" r "12, %%" r "13, %%" r "3\n\t"             \
    op " %%" r "12, %%" r "13, %%" r "4\n\t" op " %%" r "12, %%" r "13, %%" r "5\n\t"             \
    op " %%" r "12, %%" r "13, %%" r "6\n\t" op " %%" r "12, %%" r "13, %%" r "7\n\t"             \
    op " %%" r "12, %%" r "13, %%" r "8\n\t" op " %%" r "12, %%" r "13, %%" r "9\n\t"             \
    op " %%" r "12, %%" r "13, %%" r "10\n\t" op " %%" r "12, %%" r "13, %%" r "11\n\t"
#define CLOB "xmm0", "xmm1", "xmm2", "xmm3", "xmm4", "xmm5", "xmm6", "xmm7", "xmm8", "xmm9", \
             "xmm10", "xmm11", "xmm12", "xmm13"

static double run_zmm(void)
{
    /* the registers start as zero: zmm12 * zmm13 + zmm_i stays 0, no denormals */
    __asm__ volatile("vzeroall" ::: CLOB);
    const double t0 = now_s();
    for (long i = 0; i < ITERS; i++)
        __asm__ volatile(FMA12("vfmadd231ps", "zmm") ::: CLOB);
    const double t = now_s() - t0;
    __asm__ volatile("vzeroupper" ::: CLOB);
    return (double)ITERS * CHAINS * 16 * 2 / t * 1e-9;
}

static double run_ymm(void)
{
    __asm__ volatile("vzeroall" ::: CLOB);
    const double t0 = now_s();
    for (long i = 0; i < ITERS; i++)
        __asm__ volatile(FMA12("vfmadd231ps", "ymm") ::: CLOB);
    const double t = now_s() - t0;
    __asm__ volatile("vzeroupper" ::: CLOB);
    return (double)ITERS * CHAINS * 8 * 2 / t * 1e-9;
}
#endif

#if defined(__aarch64__)
static double run_neon(void)
{
    __asm__ volatile("movi v0.4s, #0\n\tmovi v1.4s, #0\n\tmovi v2.4s, #0\n\tmovi v3.4s, #0\n\t"
                     "movi v4.4s, #0\n\tmovi v5.4s, #0\n\tmovi v6.4s, #0\n\tmovi v7.4s, #0\n\t"
                     "movi v8.4s, #0\n\tmovi v9.4s, #0\n\tmovi v10.4s, #0\n\tmovi v11.4s, #0\n\t"
                     "movi v12.4s, #0\n\tmovi v13.4s, #0" ::: "v0", "v1", "v2", "v3", "v4", "v5",
                     "v6", "v7", "v8", "v9", "v10", "v11", "v12", "v13");
    const double t0 = now_s();
    for (long i = 0; i < ITERS; i++)
        __asm__ volatile("fmla v0.4s, v12.4s, v13.4s\n\tfmla v1.4s, v12.4s, v13.4s\n\t"
                         "fmla v2.4s, v12.4s, v13.4s\n\tfmla v3.4s, v12.4s, v13.4s\n\t"
                         "fmla v4.4s, v12.4s, v13.4s\n\tfmla v5.4s, v12.4s, v13.4s\n\t"
                         "fmla v6.4s, v12.4s, v13.4s\n\tfmla v7.4s, v12.4s, v13.4s\n\t"
                         "fmla v8.4s, v12.4s, v13.4s\n\tfmla v9.4s, v12.4s, v13.4s\n\t"
                         "fmla v10.4s, v12.4s, v13.4s\n\tfmla v11.4s, v12.4s, v13.4s" ::: "v0",
                         "v1", "v2", "v3", "v4", "v5", "v6", "v7", "v8", "v9", "v10", "v11");
    const double t = now_s() - t0;
    return (double)ITERS * CHAINS * 4 * 2 / t * 1e-9;
}
#endif

double fma_probe_gflops(const char *isa)
{
    double (*run)(void) = NULL;
#if defined(__x86_64__)
    if (!strcmp(isa, "avx512f"))
        run = run_zmm;
    else if (!strcmp(isa, "avx2+fma"))
        run = run_ymm;
#endif
#if defined(__aarch64__)
    if (!strcmp(isa, "neon"))
        run = run_neon;
#endif
    if (!run)
        return 0.0;
    double best = 0.0;
    for (int r = 0; r < 7; r++) {
        const double g = run();
        best = g > best ? g : best;
    }
    return best;
}
