/* la_bf16.h's product with AVX512_BF16: VDPBF16PS adds two bf16 products per fp32 lane (the odd
 * element's first, DAZ/FTZ, nearest-even: the reference's rounding), so a zmm instruction does
 * 32 multiply-adds where an fp32 FMA does 16. Compiled on every x86-64 build whatever its
 * baseline (la_packed_isa.h); called only when the CPU has the instruction (la_bf16.c).
 *
 * The Goto/BLIS structure of la_packed_impl.h, with operands converted to bf16 while packed:
 *   op(B) per KC x NC block into 32-column micro-panels, Bp[strip][p][j] = the dword
 *         (bf16(b[2p][j]) | bf16(b[2p+1][j]) << 16);
 *   op(A) per MC rows into 12-row micro-panels, Ap[strip][p][r] = (bf16(a[r][2p]) |
 *         bf16(a[r][2p+1]) << 16), broadcast as one dword per row;
 *   a 12 x 32 fp32 tile in 24 zmm accumulators, one VDPBF16PS per row and half-tile per pair.
 * A k block past the first continues the fp32 accumulators from C (where the previous block
 * left them, unscaled: alpha is 1, beta 0), so K-blocking does not change the chain of
 * roundings. The epilogue runs on the last k block, on the tile in registers, as in the fp32
 * driver (rows ascending for the column sums). Edge tiles and edge packing go through the
 * reference's scalar rounding (la_bf16_round). */
#include "ai/kernels/la_bf16.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#include <stddef.h>
#include <stdint.h>

#include "ai/kernels/la_packed.h"
#include "ai/kernels/la_packed_isa.h"

#define MR 12
#define NR 32
_Static_assert(MR <= NR, "pairs_across holds up to NR rows");
#ifndef LA_BF16_KC /* k elements per block (even): -D for measurements only */
#define LA_BF16_KC 256
#endif
#ifndef LA_BF16_MC
#define LA_BF16_MC 96
#endif
#define KC LA_BF16_KC
#define KP (KC / 2) /* pairs per block */
#define MC LA_BF16_MC
#define NC 256
_Static_assert(KC % 2 == 0 && MC % MR == 0 && NC % NR == 0, "blocks hold whole pairs and panels");
_Static_assert((size_t)KP * NC * 4 + (size_t)MC * KP * 4 + (size_t)MR * KP * 4 + 64u * MR * NR <=
                   LA_BF16_STACK_BYTES,
               "the packed panels exceed LA_BF16_STACK_BYTES");

static inline uint32_t pair(float e, float o)
{
    return (uint32_t)la_bf16_round(e) | (uint32_t)la_bf16_round(o) << 16;
}

static inline float op_at(la_trans_t t, const float *X, int ld, int r, int c)
{
    return t == LA_NO_TRANS ? X[(size_t)r * ld + c] : X[(size_t)c * ld + r];
}

LA_ISA_BEGIN("avx512f,avx512bw,avx512vl,avx512bf16,avx2,fma")

/* [e0 .. e15 | o0 .. o15] (16-bit lanes) -> [e0 o0 e1 o1 ...]: 16 dwords, one pair each */
static inline __m512i interleave_pairs(__m512 e, __m512 o)
{
    const __m512i idx = _mm512_set_epi16(31, 15, 30, 14, 29, 13, 28, 12, 27, 11, 26, 10, 25, 9,
                                         24, 8, 23, 7, 22, 6, 21, 5, 20, 4, 19, 3, 18, 2, 17, 1,
                                         16, 0);
    return _mm512_permutexvar_epi16(idx, (__m512i)_mm512_cvtne2ps_pbh(o, e));
}

/* 16 pairs of each of `lines` (<= NR) rows of an operand read across its rows, row l at
 * src + l * ld: each row converted 16 pairs at a time (rounded in order, so its dwords are the
 * pairs), then transposed: dst[q * lines + l] = pair q of row l. */
static inline void pairs_across(const float *src, size_t ld, int lines, uint32_t *restrict dst)
{
    _Alignas(64) uint32_t t[NR][16];
    for (int l = 0; l < lines; l++) {
        const float *row = src + (size_t)l * ld;
        _mm512_store_si512(t[l], (__m512i)_mm512_cvtne2ps_pbh(_mm512_loadu_ps(row + 16),
                                                               _mm512_loadu_ps(row)));
    }
    for (int q = 0; q < 16; q++)
        for (int l = 0; l < lines; l++)
            dst[q * lines + l] = t[l][q];
}

/* Bp[strip][p][j]: columns j0.., k from k0 (even), kc of them (odd only in the last block),
 * zero padded to NR columns and to whole pairs. */
static void pack_b(la_trans_t tb, const float *B, int ldb, int j0, int nc, int k0, int kc,
                   uint32_t *restrict Bp)
{
    const int kp = (kc + 1) / 2, kfull = kc / 2;
    for (int s = 0; s < nc; s += NR) {
        const int nr = nc - s < NR ? nc - s : NR;
        uint32_t *restrict dst = Bp + (size_t)s * kp;
        int p = 0;
        if (tb == LA_TRANS && nr == NR) {
            /* a pair is two neighbours in a row of B (= a column of op(B)): the 32 rows 16
             * pairs at a time */
            for (; p + 16 <= kfull; p += 16)
                pairs_across(B + (size_t)(j0 + s) * ldb + k0 + 2 * p, (size_t)ldb, NR,
                             dst + p * NR);
        }
        for (; p < kp; p++) {
            const int k = k0 + 2 * p, odd = 2 * p + 1 < kc;
            if (tb == LA_NO_TRANS && nr == NR && odd) {
                const float *re = B + (size_t)k * ldb + j0 + s, *ro = re + ldb;
                for (int h = 0; h < 2; h++)
                    _mm512_store_si512(dst + p * NR + 16 * h,
                                       interleave_pairs(_mm512_loadu_ps(re + 16 * h),
                                                        _mm512_loadu_ps(ro + 16 * h)));
                continue;
            }
            for (int j = 0; j < NR; j++)
                dst[p * NR + j] =
                    j < nr ? pair(op_at(tb, B, ldb, k, j0 + s + j),
                                  odd ? op_at(tb, B, ldb, k + 1, j0 + s + j) : 0.0f)
                           : 0u;
        }
    }
}

/* Ap[strip][p][r]: rows i0.., k from k0, zero padded to MR rows and to whole pairs. */
static void pack_a(la_trans_t ta, const float *A, int lda, int i0, int mc, int k0, int kc,
                   uint32_t *restrict Ap)
{
    const int kp = (kc + 1) / 2, kfull = kc / 2; /* pairs, and pairs with both elements */
    for (int s = 0; s < mc; s += MR) {
        const int mr = mc - s < MR ? mc - s : MR;
        uint32_t *restrict dst = Ap + (size_t)s * kp;
        if (mr < MR) {
            for (int p = 0; p < kp; p++)
                for (int r = 0; r < MR; r++) {
                    const int k = k0 + 2 * p, i = i0 + s + r;
                    dst[p * MR + r] =
                        r < mr ? pair(op_at(ta, A, lda, i, k),
                                      2 * p + 1 < kc ? op_at(ta, A, lda, i, k + 1) : 0.0f)
                               : 0u;
                }
            continue;
        }
        int p = 0;
        if (ta == LA_TRANS) {
            /* a pair is two rows of A at the same column: 12 columns side by side */
            const __mmask16 m12 = 0x0FFF;
            for (; p < kfull; p++) {
                const float *re = A + (size_t)(k0 + 2 * p) * lda + i0 + s, *ro = re + lda;
                _mm512_mask_storeu_epi32(dst + p * MR, m12,
                                         interleave_pairs(_mm512_maskz_loadu_ps(m12, re),
                                                          _mm512_maskz_loadu_ps(m12, ro)));
            }
        } else {
            /* a pair is two neighbours in a row of A: the 12 rows 16 pairs at a time */
            for (; p + 16 <= kfull; p += 16)
                pairs_across(A + (size_t)(i0 + s) * lda + k0 + 2 * p, (size_t)lda, MR,
                             dst + p * MR);
        }
        for (; p < kp; p++)
            for (int r = 0; r < MR; r++) {
                const int k = k0 + 2 * p, i = i0 + s + r;
                dst[p * MR + r] = pair(op_at(ta, A, lda, i, k),
                                       2 * p + 1 < kc ? op_at(ta, A, lda, i, k + 1) : 0.0f);
            }
    }
}

static inline __m512 gate(__m512 g, __m512 v)
{
    return _mm512_maskz_mov_ps(_mm512_cmp_ps_mask(g, _mm512_setzero_ps(), _CMP_GT_OQ), v);
}

/* One mr x nr tile of C over kp pairs: from +0 on the first k block, from C after it; the
 * epilogue e (pointers at the tile) on the last. The loops are unrolled explicitly so the 24
 * accumulators stay in registers. */
static void micro(int kp, const uint32_t *restrict Ap, const uint32_t *restrict Bp, float *C,
                  int ldc, int mr, int nr, int first, int last, const la_epilogue_t *e)
{
    const int full = mr == MR && nr == NR;
    _Alignas(64) float t[MR * NR];
    __m512 c[MR][2];
    if (first) {
#pragma GCC unroll 16
        for (int r = 0; r < MR; r++)
            c[r][0] = c[r][1] = _mm512_setzero_ps();
    } else if (full) {
#pragma GCC unroll 16
        for (int r = 0; r < MR; r++) {
            c[r][0] = _mm512_loadu_ps(C + (size_t)r * ldc);
            c[r][1] = _mm512_loadu_ps(C + (size_t)r * ldc + 16);
        }
    } else {
        for (int r = 0; r < MR; r++)
            for (int j = 0; j < NR; j++)
                t[r * NR + j] = r < mr && j < nr ? C[(size_t)r * ldc + j] : 0.0f;
#pragma GCC unroll 16
        for (int r = 0; r < MR; r++) {
            c[r][0] = _mm512_load_ps(&t[r * NR]);
            c[r][1] = _mm512_load_ps(&t[r * NR + 16]);
        }
    }
    for (int p = 0; p < kp; p++) {
        const __m512bh b0 = (__m512bh)_mm512_load_si512(Bp + p * NR);
        const __m512bh b1 = (__m512bh)_mm512_load_si512(Bp + p * NR + 16);
#pragma GCC unroll 16
        for (int r = 0; r < MR; r++) {
            const __m512bh a = (__m512bh)_mm512_set1_epi32((int)Ap[p * MR + r]);
            c[r][0] = _mm512_dpbf16_ps(c[r][0], a, b0);
            c[r][1] = _mm512_dpbf16_ps(c[r][1], a, b1);
        }
    }
    if (full) {
        __m512 cs[2] = {_mm512_setzero_ps(), _mm512_setzero_ps()};
        const la_epilogue_t *ee = last ? e : NULL;
        if (ee && ee->colsum)
            for (int h = 0; h < 2; h++)
                cs[h] = _mm512_loadu_ps(ee->colsum + 16 * h);
#pragma GCC unroll 16
        for (int r = 0; r < MR; r++) {
            float *cr = C + (size_t)r * ldc;
#pragma GCC unroll 2
            for (int h = 0; h < 2; h++) {
                __m512 v = c[r][h];
                if (ee) {
                    if (ee->bias)
                        v = _mm512_add_ps(v, _mm512_loadu_ps(ee->bias + 16 * h));
                    if (ee->relu) /* max gives its 2nd operand for NaN: NaN -> 0, as the loop */
                        v = _mm512_max_ps(v, _mm512_setzero_ps());
                    if (ee->gate)
                        v = gate(_mm512_loadu_ps(ee->gate + (size_t)r * ee->ldg + 16 * h), v);
                    if (ee->colsum)
                        cs[h] = _mm512_add_ps(cs[h], v);
                }
                _mm512_storeu_ps(cr + 16 * h, v);
            }
        }
        if (ee && ee->colsum)
            for (int h = 0; h < 2; h++)
                _mm512_storeu_ps(ee->colsum + 16 * h, cs[h]);
        return;
    }
#pragma GCC unroll 16
    for (int r = 0; r < MR; r++) {
        _mm512_store_ps(&t[r * NR], c[r][0]);
        _mm512_store_ps(&t[r * NR + 16], c[r][1]);
    }
    for (int r = 0; r < mr; r++)
        for (int j = 0; j < nr; j++) {
            const float v = t[r * NR + j];
            C[(size_t)r * ldc + j] = last && e ? la_epilogue_elem(e, (size_t)r, j, v) : v;
        }
}

void la_bf16_gemm_avx512(la_trans_t ta, la_trans_t tb, int M, int N, int K, const float *A,
                         int lda, const float *B, int ldb, float *C, int ldc,
                         const la_epilogue_t *ep)
{
    if (M <= 0 || N <= 0)
        return;
    if (K <= 0) {
        for (int i = 0; i < M; i++)
            for (int j = 0; j < N; j++)
                C[(size_t)i * ldc + j] = ep ? la_epilogue_elem(ep, (size_t)i, j, 0.0f) : 0.0f;
        return;
    }
    _Alignas(64) uint32_t Bp[KP * NC];
    _Alignas(64) uint32_t Ap[MC * KP];
    for (int j0 = 0; j0 < N; j0 += NC) {
        const int nc = N - j0 < NC ? N - j0 : NC;
        for (int k0 = 0; k0 < K; k0 += KC) {
            const int kc = K - k0 < KC ? K - k0 : KC, kp = (kc + 1) / 2;
            const int last = k0 + kc >= K;
            pack_b(tb, B, ldb, j0, nc, k0, kc, Bp);
            for (int i0 = 0; i0 < M; i0 += MC) {
                const int mc = M - i0 < MC ? M - i0 : MC;
                pack_a(ta, A, lda, i0, mc, k0, kc, Ap);
                for (int js = 0; js < nc; js += NR)
                    for (int is = 0; is < mc; is += MR) {
                        const int j = j0 + js, i = i0 + is;
                        la_epilogue_t e;
                        if (ep && last)
                            e = la_epilogue_at(ep, (size_t)i, j);
                        micro(kp, Ap + (size_t)is * kp, Bp + (size_t)js * kp,
                              C + (size_t)i * ldc + j, ldc, mc - is < MR ? mc - is : MR,
                              nc - js < NR ? nc - js : NR, k0 == 0, last,
                              ep && last ? &e : NULL);
                    }
            }
        }
    }
}

LA_ISA_END
#endif
