/* bf16 products with fp32 sums for the large GEMMs of the training step (bnn_forward.c and
 * bnn_train.c, when the model's config asks for BNN_PRECISION_BF16; firmware/ai/README.md,
 * "bf16 training step").
 *
 *   C[M x N] = epilogue( sum_k bf16(op(A)[i][k]) * bf16(op(B)[k][j]) )
 *
 * with the shapes, transposes and strides of la_sgemm (la.h), alpha = 1 and beta = 0 (C is
 * never read: the step needs nothing else, and one contract is easier to make exact), and the
 * epilogue of la_sgemm_ep (bias, ReLU, gate, column sums; ep may be NULL).
 *
 * The rounding is defined exactly, so that every kernel gives the reference's bits:
 *   - bf16(x): x rounded to nearest, ties to even, to the upper 16 bits of its fp32 pattern;
 *     a subnormal x becomes a zero of its sign; NaN stays a (quiet) NaN. This is what
 *     VCVTNE2PS2BF16 does.
 *   - k is taken in pairs (2p, 2p + 1), p ascending, a missing k = K (odd K) as 0 * 0; per
 *     output element one fp32 accumulator, starting at +0:
 *         acc = ftz(fma(a[2p+1], b[2p+1], acc));  acc = ftz(fma(a[2p], b[2p], acc));
 *     fma is one rounding to nearest even (the product of two bf16 values is exact), and
 *     ftz(v) turns a subnormal result into a zero of its sign. This is VDPBF16PS's order
 *     (odd element first) and its DAZ/FTZ, checked against the Zen 4 instruction on 2 M random
 *     triples including subnormal ranges (tests/ai/test_la_bf16.c keeps checking it).
 *   - then the epilogue in fp32, as la_sgemm_ep's.
 * So the products lose the operands' low 16 bits (relative error <= 2^-9 per factor) but the
 * sums keep fp32's; K-blocking inside a kernel carries the fp32 accumulator through C, which
 * changes nothing.
 *
 * Kernels: la_bf16_gemm_ref (pure C11, always built: what every CPU without the instruction
 * runs, and LA_BACKEND=ref) and la_bf16_gemm_avx512 (AVX512_BF16 `vdpbf16ps`, 12 x 32 tile,
 * compiled into every x86-64 build whatever its baseline, chosen at run time from cpuid like
 * the fp32 kernels). No function allocates; the fast kernel's panels are on the stack
 * (LA_BF16_STACK_BYTES). Deterministic; thread-safe (no shared state but the choice). */
#ifndef AI_LA_BF16_H
#define AI_LA_BF16_H

#include <stdint.h>

#include "ai/kernels/la.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The rounding above, one value at a time (the reference and the fast kernels' edges use it). */
uint16_t la_bf16_round(float x);
float la_bf16_widen(uint16_t h);

/* The product above on the kernel the CPU runs (la_bf16_kernel_name). */
void la_bf16_gemm(la_trans_t ta, la_trans_t tb, int M, int N, int K, const float *A, int lda,
                  const float *B, int ldb, float *C, int ldc, const la_epilogue_t *ep);

/* The pure-C reference. */
void la_bf16_gemm_ref(la_trans_t ta, la_trans_t tb, int M, int N, int K, const float *A, int lda,
                      const float *B, int ldb, float *C, int ldc, const la_epilogue_t *ep);

/* Kernels by id; LA_BF16_REF always runs. */
enum { LA_BF16_AUTO = -2, LA_BF16_AVX512 = 0, LA_BF16_REF = 1, LA_BF16_N = 2 };

/* 1 when this build has kernel id and the running CPU executes it. */
int la_bf16_cpu_has(int id);

/* "avx512bf16-12x32" or "ref-c": what la_bf16_gemm runs now. */
const char *la_bf16_kernel_name(void);

/* For tests and benchmarks: make la_bf16_gemm use kernel id (LA_BF16_AUTO: the fastest the CPU
 * runs). Returns 0, or -ENOTSUP when the build or the CPU lacks it. Not to be called while
 * another thread is inside la_bf16_gemm. */
int la_bf16_force(int id);

/* Largest stack use of one call of the fast kernel (its packed panels). */
#define LA_BF16_STACK_BYTES (256u * 1024u)

/* Internal: the AVX512_BF16 kernel (la_bf16_avx512.c); call only when la_bf16_cpu_has says so. */
void la_bf16_gemm_avx512(la_trans_t ta, la_trans_t tb, int M, int N, int K, const float *A,
                         int lda, const float *B, int ldb, float *C, int ldc,
                         const la_epilogue_t *ep);

#ifdef __cplusplus
}
#endif

#endif /* AI_LA_BF16_H */
