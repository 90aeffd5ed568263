/* Int8 GEMM kernels of the int8 inference path (bnn_quant_forward_mean, ai/bnn_quant.h):
 *     C[j * ldc + p] = sum_{k < in} A(p, k) * W[j * in + k]      (int32, exact)
 * for the points p < np of a chunk and the output rows j < out of a layer, where W is the
 * layer's int8 weights as packed ([out x in], row-major, no padding) and A the chunk's
 * quantised activations in a "point-interleaved quad" layout:
 *     A(p, k) = A[(k / 4) * 4 * lda + 4 * p + k % 4]        (int8)
 * i.e. for every quad of 4 consecutive inputs, the 4 bytes of point 0, then of point 1, ...:
 * one 32-bit lane per point, the operand shape of vpdpbusd with the points across the lanes.
 * Sums are exact in int32 (|sum| <= 128 * 128 * in; in <= 65536 also for the VNNI kernels'
 * biased sums), so every kernel gives the same C.
 *
 * Kernels, fastest first (enum below); the first one the running CPU can execute is used,
 * chosen once (q8_active), as la_packed does for the fp32 GEMM. Points across the lanes, the
 * weights broadcast 4 bytes at a time; tile = rows x vectors of points (ai/q8_x86_impl.h):
 *   avx512vnni-zmm  vpdpbusd on zmm, 16 points per vector, 8 x 2 tile (32 points);
 *                   needs avx512f + avx512bw + avx512vnni
 *   avx512vnni-ymm  the same on ymm (the AVX512VL encoding), 8 points per vector, 8 x 2 tile;
 *                   needs avx512f + avx512vl + avx512vnni
 *   avxvnni-ymm     the VEX encoding (_mm256_dpbusd_avx_epi32: Alder Lake and later cores
 *                   without AVX-512), 4 x 2 tile in the 16 ymm registers; needs avxvnni + avx2
 *   avx2-sign       vpsignb + vpmaddubsw + vpmaddwd, 4 x 2 tile: |w| (u8) x a * sign(w) (s8),
 *                   a pair sum <= 2 * 128 * 127 = 32512 never saturates the int16 as long as
 *                   A holds no -128 (the quantiser gives |a| <= 127); needs avx2
 *   ref             the pure-C reference, always built (the only kernel off x86-64)
 * vpdpbusd multiplies UNSIGNED bytes by SIGNED bytes: the VNNI kernels feed a_u8 = a + 128
 * (a XOR 0x80) and subtract 128 * wsum[j], wsum[j] = sum_k W[j * in + k] (the caller computes
 * it once per call: q8_row_sums). The x86 kernels (ai/q8_x86.c) are compiled on every x86-64
 * build whatever its baseline (region target pragmas, ai/la_packed_isa.h) and chosen from
 * cpuid (__builtin_cpu_supports, which also checks that the OS saves the register state; an
 * explicit cpuid for avxvnni, which clang 14's builtin does not know).
 *
 * Contract of every kernel: 1 <= np <= lda, ldc; out >= 1; in >= 1; wsum may be NULL for a
 * kernel without needs_wsum. A kernel may compute up to Q8_PAD_POINTS(np) points (the x86
 * kernels work on whole vectors of points), so A must hold initialised bytes for those points
 * and every byte of the last quad (any value: the kernels pad W's last quad with zeros and
 * never read past a row), and C room for them: lda, ldc >= Q8_PAD_POINTS(np). Exact for any
 * bytes of A and W but -128 in A for avx2-sign. No allocation, about 1 KB of stack at most,
 * thread-safe. */
#ifndef AI_Q8_GEMM_H
#define AI_Q8_GEMM_H

#include <stddef.h>
#include <stdint.h>

/* -DQ8_NO_SIMD (for measurements): no x86 kernel, and chunks of 1 point (ai/bnn_quant.h). */
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) && !defined(Q8_NO_SIMD)
#define Q8_X86 1
#define Q8_PAD 16u /* the x86 kernels compute whole groups of 16 points */
#else
#define Q8_PAD 1u
#endif
#define Q8_PAD_POINTS(np) (((np) + Q8_PAD - 1u) / Q8_PAD * Q8_PAD)

typedef void (*q8_gemm_fn)(size_t np, size_t out, size_t in, const int8_t *A, size_t lda,
                           const int8_t *W, const int32_t *wsum, int32_t *C, size_t ldc);

typedef struct q8_kernel {
    const char *name; /* "avx512vnni-zmm", ..., "ref" */
    q8_gemm_fn fn;    /* NULL when this build has no code for the instruction set */
    int needs_wsum;   /* 1: the kernel reads wsum (the VNNI ones); else it may be NULL */
    const char *isa;  /* what the CPU must have, for messages */
} q8_kernel_t;

/* Every kernel known to the build, fastest first; Q8_REF is always there. */
enum {
    Q8_AVX512VNNI = 0,
    Q8_AVX512VNNI_YMM = 1,
    Q8_AVXVNNI = 2,
    Q8_AVX2 = 3,
    Q8_REF = 4,
    Q8_N = 5,
};
#define Q8_AUTO (-1) /* q8_force: back to the automatic choice */

extern const q8_kernel_t q8_kernels[Q8_N];

/* 1 when this build has kernel id and the CPU running it can execute it. */
int q8_cpu_has(int id);

/* The kernel bnn_quant_forward_mean uses: the first of the list the CPU can run. */
const q8_kernel_t *q8_active(void);

/* Its name ("avx512vnni-zmm", ..., "ref"). */
const char *q8_kernel_name(void);

/* For tests and benchmarks: make the int8 path use kernel id (Q8_REF: the pure-C reference;
 * Q8_AUTO: back to the automatic choice). Returns 0, -EINVAL for an unknown id, or -ENOTSUP
 * when the build or the CPU lacks it. Not to be called while another thread is inside
 * bnn_quant_forward_mean. */
int q8_force(int id);

/* wsum[j] = sum_k W[j * in + k] for j < out (the VNNI kernels' correction term). */
void q8_row_sums(const int8_t *W, size_t out, size_t in, int32_t *wsum);

void q8_gemm_ref(size_t np, size_t out, size_t in, const int8_t *A, size_t lda, const int8_t *W,
                 const int32_t *wsum, int32_t *C, size_t ldc);
void q8_gemm_avx512vnni(size_t np, size_t out, size_t in, const int8_t *A, size_t lda,
                        const int8_t *W, const int32_t *wsum, int32_t *C, size_t ldc);
void q8_gemm_avx512vnni_ymm(size_t np, size_t out, size_t in, const int8_t *A, size_t lda,
                            const int8_t *W, const int32_t *wsum, int32_t *C, size_t ldc);
void q8_gemm_avxvnni(size_t np, size_t out, size_t in, const int8_t *A, size_t lda,
                     const int8_t *W, const int32_t *wsum, int32_t *C, size_t ldc);
void q8_gemm_avx2(size_t np, size_t out, size_t in, const int8_t *A, size_t lda, const int8_t *W,
                  const int32_t *wsum, int32_t *C, size_t ldc);

#endif /* AI_Q8_GEMM_H */
