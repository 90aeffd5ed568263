/* Packed GEMM kernels of the AI core: one Goto/BLIS driver (la_packed_impl.h) instantiated per
 * instruction set in its own file, and the choice among them made once, at run time, from what
 * the CPU has. Internal to firmware/ai; callers use la_sgemm (la.h), which sends the large
 * products here and the thin ones to Eigen.
 *
 * Every kernel computes the whole la_sgemm_ep contract (any shape, transposes, strides, alpha,
 * beta, the epilogue; beta == 0 never reads C) with one FMA per k per output element in the same order, so
 * the kernels of one build give bit-identical products whatever their vector width. Buffers
 * are on the stack (LA_PACKED_STACK_BYTES at most); nothing allocates. */
#ifndef AI_LA_PACKED_H
#define AI_LA_PACKED_H

#include <stddef.h>

#include "ai/kernels/la.h"

typedef void (*la_packed_fn)(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha,
                             const float *A, int lda, const float *B, int ldb, float beta,
                             float *C, int ldc, const la_epilogue_t *ep);

typedef struct la_packed_kernel {
    const char *name;  /* "avx512-12x32", "avx2-fma-6x16", "neon-8x8" */
    const char *with_eigen; /* the same + "+eigen": what la_kernel_name() reports */
    la_packed_fn fn;   /* NULL when this build has no code for the instruction set */
    int mr, nr;        /* register tile; la_sgemm packs a product when M >= 2 mr, N >= nr */
    const char *isa;   /* what the CPU must have, for messages ("avx512f", "avx2+fma", "neon") */
} la_packed_kernel_t;

/* Every kernel known to the build, fastest first; check la_packed_cpu_has() before calling. */
enum { LA_PACKED_AVX512 = 0, LA_PACKED_AVX2 = 1, LA_PACKED_NEON = 2, LA_PACKED_N = 3 };
extern const la_packed_kernel_t la_packed_kernels[LA_PACKED_N];

/* 1 when this build has kernel id and the CPU running it can execute it. */
int la_packed_cpu_has(int id);

/* The kernel la_sgemm uses: the fastest one the CPU can run, or NULL (then Eigen does all). */
const la_packed_kernel_t *la_packed_active(void);

/* For tests and benchmarks: make la_sgemm use kernel id (-1: none, Eigen everywhere; -2: back to
 * the automatic choice). Returns 0, or -ENOTSUP when the build or the CPU lacks it. Not to be
 * called while another thread is inside la_*. */
int la_packed_force(int id);

/* The epilogue (la.h) on one finished element v of row i, column j: bias, ReLU, gate, then the
 * column sum. One definition for the kernels' edge tiles and the plain pass after Eigen or the
 * reference (la.c), so they agree bit for bit. */
static inline float la_epilogue_elem(const la_epilogue_t *ep, size_t i, int j, float v)
{
    if (ep->bias)
        v += ep->bias[j];
    if (ep->relu)
        v = v > 0.0f ? v : 0.0f;
    if (ep->gate)
        v = ep->gate[i * (size_t)ep->ldg + (size_t)j] > 0.0f ? v : 0.0f;
    if (ep->colsum)
        ep->colsum[j] += v;
    return v;
}

/* The epilogue of the tile whose first element is row i, column j: ep's pointers moved there
 * (what a kernel's micro-tile applies; the fp32 and bf16 drivers both take it). */
static inline la_epilogue_t la_epilogue_at(const la_epilogue_t *ep, size_t i, int j)
{
    return (la_epilogue_t){ep->bias ? ep->bias + j : NULL, ep->relu,
                           ep->gate ? ep->gate + i * (size_t)ep->ldg + (size_t)j : NULL, ep->ldg,
                           ep->colsum ? ep->colsum + j : NULL};
}

/* Largest stack use of one call (packed panels). */
#define LA_PACKED_STACK_BYTES (400u * 1024u)

void la_packed_sgemm_avx512(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha,
                            const float *A, int lda, const float *B, int ldb, float beta, float *C,
                            int ldc, const la_epilogue_t *ep);
void la_packed_sgemm_avx2(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha,
                          const float *A, int lda, const float *B, int ldb, float beta, float *C,
                          int ldc, const la_epilogue_t *ep);
void la_packed_sgemm_neon(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha,
                          const float *A, int lda, const float *B, int ldb, float beta, float *C,
                          int ldc, const la_epilogue_t *ep);

#endif /* AI_LA_PACKED_H */
