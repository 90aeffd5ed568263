/* The packed GEMM driver, instantiated once per instruction set: a file defines the vector
 * type and operations below, then includes this header (la_packed_avx512.c, _avx2.c, _neon.c).
 * Not a public header.
 *
 * Goto/BLIS structure: the k dimension in blocks of KC; op(B) packed per block into NR-column
 * micro-panels (KC x NR, each one L1-resident while the MR-row micro-panels of op(A) stream past
 * it); op(A) packed per MC rows; an MR x NR register tile per micro-kernel call (two vectors
 * wide). beta is applied in the first k block, so C is never zeroed first and beta == 0 never
 * reads C. Each output element gets one FMA per k, k ascending within a block and blocks in
 * order, and the same explicit FMAs when a block is scaled into C (tiles of full width in
 * vectors, whatever their row count; tiles of fewer columns in scalars: fmaf, which the
 * kernel's instruction set makes one instruction), so the
 * result depends on the shape only, not on the vector width, nor on what the compiler
 * contracts.
 *
 * The including file defines:
 *   LAP_FN        the function's name
 *   LAP_VL        floats per vector; LAP_MR rows of the tile; NR = 2 * LAP_VL
 *   LAP_KC, LAP_MC, LAP_NC   the blocking (MC % MR == 0, NC % NR == 0)
 *   lap_vec       the vector type, and static inline functions
 *   lap_zero(), lap_load(p) (aligned), lap_loadu(p), lap_store(p, v) (aligned), lap_storeu(p, v),
 *   lap_bcast(p) (all lanes = *p), lap_set1(x), lap_fma(a, b, c) (a * b + c), lap_mul, lap_add,
 *   lap_relu(v) (v > 0 ? v : 0, NaN gives 0), lap_gate(g, v) (g > 0 ? v : 0 per lane),
 *   lap_t4(src, ld, dst, ldd): dst[c * ldd + r] = src[r * ld + c] for r, c < 4 (a 4 x 4
 *   transpose in 128-bit registers, for the packing of the operands read across their rows).
 *
 * The epilogue (la.h) is applied on the last k block, to the tile in registers: bias, ReLU,
 * gate, then the tile's rows are added to colsum one after the other, in ascending row order
 * (the js loop is outside the is loop and the MC blocks ascend, so each column's sum runs over
 * the rows in order: the same bits as a plain loop after the product).
 */
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "ai/kernels/la.h"
#include "ai/kernels/la_packed.h"

#define LAP_NR (2 * LAP_VL)
_Static_assert(LAP_MC % LAP_MR == 0 && LAP_NC % LAP_NR == 0, "blocks hold whole micro-panels");
_Static_assert((LAP_KC * LAP_NC + LAP_MC * LAP_KC) * sizeof(float) + 64 * LAP_MR * LAP_NR <=
                   LA_PACKED_STACK_BYTES,
               "the packed panels exceed LA_PACKED_STACK_BYTES");

/* dst[k * ldd + r] = src[r * ld + k] for r < rows, k < kc: `rows` lines of a row-major
 * operand turned k-major, in 4 x 4 transposes where whole ones fit. A scalar gather of one
 * float per line and k took 3-5 % of the forward and dX products (scalar loads and stores
 * from 12 lines at once). */
static void lap_pack_across(const float *src, int ld, int rows, int kc, float *restrict dst,
                            int ldd)
{
    const int k4 = kc & ~3, r4 = rows & ~3;
    for (int k = 0; k < k4; k += 4) {
        for (int r = 0; r < r4; r += 4)
            lap_t4(src + (size_t)r * ld + k, ld, dst + (size_t)k * ldd + r, ldd);
        for (int r = r4; r < rows; r++)
            for (int q = 0; q < 4; q++)
                dst[(size_t)(k + q) * ldd + r] = src[(size_t)r * ld + k + q];
    }
    for (int k = k4; k < kc; k++)
        for (int r = 0; r < rows; r++)
            dst[(size_t)k * ldd + r] = src[(size_t)r * ld + k];
}

/* Ap[strip][k][r]: rows i0.., k from p0, zero padded to MR rows. */
static void lap_pack_a(la_trans_t ta, const float *A, int lda, int i0, int mc, int p0, int kc,
                       float *restrict Ap)
{
    const int full = mc / LAP_MR * LAP_MR, mr = mc - full;
    if (ta == LA_TRANS) {
        /* op(A)'s columns are A's rows: each row of A read once, in order, its MR-float runs
         * copied into every strip (fixed-size copies: vector moves), the last strip's rows
         * beyond mc zeroed */
        for (int k = 0; k < kc; k++) {
            const float *src = A + (size_t)(p0 + k) * lda + i0;
            for (int s = 0; s < full; s += LAP_MR)
                memcpy(Ap + (size_t)s * kc + k * LAP_MR, src + s, LAP_MR * sizeof(float));
            if (mr) {
                float *restrict dst = Ap + (size_t)full * kc + k * LAP_MR;
                for (int r = 0; r < LAP_MR; r++)
                    dst[r] = r < mr ? src[full + r] : 0.0f;
            }
        }
        return;
    }
    for (int s = 0; s < full; s += LAP_MR)
        lap_pack_across(A + (size_t)(i0 + s) * lda + p0, lda, LAP_MR, kc, Ap + (size_t)s * kc,
                        LAP_MR);
    if (mr) {
        float *restrict dst = Ap + (size_t)full * kc;
        lap_pack_across(A + (size_t)(i0 + full) * lda + p0, lda, mr, kc, dst, LAP_MR);
        for (int k = 0; k < kc; k++)
            for (int r = mr; r < LAP_MR; r++)
                dst[k * LAP_MR + r] = 0.0f;
    }
}

/* Bp[strip][k][j]: columns j0.., k from p0, zero padded to NR columns. */
static void lap_pack_b(la_trans_t tb, const float *B, int ldb, int j0, int nc, int p0, int kc,
                       float *restrict Bp)
{
    const int full = tb == LA_NO_TRANS ? nc / LAP_NR * LAP_NR : 0;
    /* the whole micro-panels of a row-major op(B): row by row, so that B is read in order (a
     * panel at a time strode through it and missed the cache on every row) */
    for (int k = 0; k < kc; k++) {
        const float *src = B + (size_t)(p0 + k) * ldb + j0;
        for (int s = 0; s < full; s += LAP_NR) {
            float *restrict dst = Bp + (size_t)s * kc + k * LAP_NR;
            lap_store(dst, lap_loadu(src + s));
            lap_store(dst + LAP_VL, lap_loadu(src + s + LAP_VL));
        }
    }
    for (int s = full; s < nc; s += LAP_NR) {
        const int nr = nc - s < LAP_NR ? nc - s : LAP_NR;
        float *restrict dst = Bp + (size_t)s * kc;
        if (tb == LA_NO_TRANS) {
            for (int k = 0; k < kc; k++)
                for (int j = 0; j < LAP_NR; j++)
                    dst[k * LAP_NR + j] = j < nr ? B[(size_t)(p0 + k) * ldb + j0 + s + j] : 0.0f;
        } else if (nr == LAP_NR) {
            lap_pack_across(B + (size_t)(j0 + s) * ldb + p0, ldb, LAP_NR, kc, dst, LAP_NR);
        } else {
            for (int j = 0; j < LAP_NR; j++) {
                if (j < nr) {
                    const float *src = B + (size_t)(j0 + s + j) * ldb + p0;
                    for (int k = 0; k < kc; k++)
                        dst[k * LAP_NR + j] = src[k];
                } else {
                    for (int k = 0; k < kc; k++)
                        dst[k * LAP_NR + j] = 0.0f;
                }
            }
        }
    }
}

/* The row loops below are unrolled explicitly: GCC does not do it at -O2 (the cross builds),
 * and then keeps the accumulators in memory. */

/* C[rows x nr] = alpha * Ap Bp (+ beta C) on the first k block, += alpha * Ap Bp after it; the
 * epilogue e (or NULL) on the last block, its pointers already offset to the tile's first row
 * and column. `rows` is a constant in every call (lap_micro below): the loops over it unroll
 * and the accumulators of the rows beyond it vanish, so a strip of fewer than MR rows (the last
 * one of M = 64 or 1024 for MR = 12) costs its own rows' FMAs, not a whole tile's, and is stored
 * from the vectors. Each element's FMAs and its scaling into C are the same whatever `rows`. */
static inline __attribute__((always_inline)) void
lap_micro_rows(const int rows, int kc, const float *restrict Ap, const float *restrict Bp,
               float *C, int ldc, int nr, float alpha, float beta, int first,
               const la_epilogue_t *e)
{
    lap_vec c[LAP_MR][2];
#pragma GCC unroll 16
    for (int r = 0; r < rows; r++)
        c[r][0] = c[r][1] = lap_zero();
    if (nr == LAP_NR)
#pragma GCC unroll 16
        for (int r = 0; r < rows; r++) {
            __builtin_prefetch(C + (size_t)r * ldc, 1, 2);
            __builtin_prefetch(C + (size_t)r * ldc + LAP_NR - 1, 1, 2);
        }
    if (e && e->gate && nr == LAP_NR)
#pragma GCC unroll 16
        for (int r = 0; r < rows; r++) {
            __builtin_prefetch(e->gate + (size_t)r * e->ldg, 0, 2);
            __builtin_prefetch(e->gate + (size_t)r * e->ldg + LAP_NR - 1, 0, 2);
        }
    for (int k = 0; k < kc; k++) {
        const lap_vec b0 = lap_load(Bp + k * LAP_NR), b1 = lap_load(Bp + k * LAP_NR + LAP_VL);
#pragma GCC unroll 16
        for (int r = 0; r < rows; r++) {
            const lap_vec a = lap_bcast(Ap + k * LAP_MR + r);
            c[r][0] = lap_fma(a, b0, c[r][0]);
            c[r][1] = lap_fma(a, b1, c[r][1]);
        }
    }
    const lap_vec va = lap_set1(alpha), vb = lap_set1(beta);
    if (nr == LAP_NR) {
        lap_vec cs[2] = {lap_zero(), lap_zero()};
        if (e && e->colsum)
            for (int h = 0; h < 2; h++)
                cs[h] = lap_loadu(e->colsum + LAP_VL * h);
#pragma GCC unroll 16
        for (int r = 0; r < rows; r++) {
            float *cr = C + (size_t)r * ldc;
#pragma GCC unroll 2
            for (int h = 0; h < 2; h++) {
                lap_vec v;
                if (!first)
                    v = lap_fma(va, c[r][h], lap_loadu(cr + LAP_VL * h));
                else if (beta != 0.0f)
                    v = lap_fma(vb, lap_loadu(cr + LAP_VL * h), lap_mul(va, c[r][h]));
                else
                    v = lap_mul(va, c[r][h]);
                if (e) {
                    if (e->bias)
                        v = lap_add(v, lap_loadu(e->bias + LAP_VL * h));
                    if (e->relu)
                        v = lap_relu(v);
                    if (e->gate)
                        v = lap_gate(lap_loadu(e->gate + (size_t)r * e->ldg + LAP_VL * h), v);
                    if (e->colsum)
                        cs[h] = lap_add(cs[h], v);
                }
                lap_storeu(cr + LAP_VL * h, v);
            }
        }
        if (e && e->colsum)
            for (int h = 0; h < 2; h++)
                lap_storeu(e->colsum + LAP_VL * h, cs[h]);
        return;
    }
    /* fewer columns than NR: through a stack copy of the accumulators, element by element
     * (fmaf, one instruction on these instruction sets, rounds as the vector FMA does) */
    _Alignas(64) float t[LAP_MR * LAP_NR];
#pragma GCC unroll 16
    for (int r = 0; r < rows; r++) {
        lap_store(&t[r * LAP_NR], c[r][0]);
        lap_store(&t[r * LAP_NR + LAP_VL], c[r][1]);
    }
    for (int r = 0; r < rows; r++)
        for (int j = 0; j < nr; j++) {
            float *cv = C + (size_t)r * ldc + j;
            const float acc = t[r * LAP_NR + j];
            float o;
            if (!first)
                o = fmaf(alpha, acc, *cv);
            else if (beta != 0.0f)
                o = fmaf(beta, *cv, alpha * acc);
            else
                o = alpha * acc;
            *cv = e ? la_epilogue_elem(e, (size_t)r, j, o) : o;
        }
}

/* One instantiation of lap_micro_rows per row count 1..MR (the #if keeps counts above MR from
 * being compiled at all: each is a whole unrolled kernel). */
static void lap_micro(int kc, const float *restrict Ap, const float *restrict Bp, float *C, int ldc,
                      int mr, int nr, float alpha, float beta, int first,
                      const la_epilogue_t *e)
{
#define LAP_ROWS_CASE(n)                                                                       \
    case n:                                                                                    \
        lap_micro_rows(n, kc, Ap, Bp, C, ldc, nr, alpha, beta, first, e);                      \
        return;
    _Static_assert(LAP_MR >= 1 && LAP_MR <= 16, "lap_micro instantiates row counts 1..16");
    switch (mr) {
    LAP_ROWS_CASE(1)
#if LAP_MR >= 2
    LAP_ROWS_CASE(2)
#endif
#if LAP_MR >= 3
    LAP_ROWS_CASE(3)
#endif
#if LAP_MR >= 4
    LAP_ROWS_CASE(4)
#endif
#if LAP_MR >= 5
    LAP_ROWS_CASE(5)
#endif
#if LAP_MR >= 6
    LAP_ROWS_CASE(6)
#endif
#if LAP_MR >= 7
    LAP_ROWS_CASE(7)
#endif
#if LAP_MR >= 8
    LAP_ROWS_CASE(8)
#endif
#if LAP_MR >= 9
    LAP_ROWS_CASE(9)
#endif
#if LAP_MR >= 10
    LAP_ROWS_CASE(10)
#endif
#if LAP_MR >= 11
    LAP_ROWS_CASE(11)
#endif
#if LAP_MR >= 12
    LAP_ROWS_CASE(12)
#endif
#if LAP_MR >= 13
    LAP_ROWS_CASE(13)
#endif
#if LAP_MR >= 14
    LAP_ROWS_CASE(14)
#endif
#if LAP_MR >= 15
    LAP_ROWS_CASE(15)
#endif
#if LAP_MR >= 16
    LAP_ROWS_CASE(16)
#endif
    default:
        return;
    }
#undef LAP_ROWS_CASE
}

void LAP_FN(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha, const float *A,
            int lda, const float *B, int ldb, float beta, float *C, int ldc,
            const la_epilogue_t *ep)
{
    if (M <= 0 || N <= 0)
        return;
    if (K <= 0 || alpha == 0.0f) {
        for (int i = 0; i < M; i++)
            for (int j = 0; j < N; j++) {
                float *cv = C + (size_t)i * ldc + j;
                const float v = beta == 0.0f ? 0.0f : beta * *cv;
                *cv = ep ? la_epilogue_elem(ep, (size_t)i, j, v) : v;
            }
        return;
    }
    _Alignas(64) float Bp[LAP_KC * LAP_NC];
    _Alignas(64) float Ap[LAP_MC * LAP_KC];
    for (int j0 = 0; j0 < N; j0 += LAP_NC) {
        const int nc = N - j0 < LAP_NC ? N - j0 : LAP_NC;
        for (int p0 = 0; p0 < K; p0 += LAP_KC) {
            const int kc = K - p0 < LAP_KC ? K - p0 : LAP_KC;
            const int last = p0 + kc >= K;
            lap_pack_b(tb, B, ldb, j0, nc, p0, kc, Bp);
            for (int i0 = 0; i0 < M; i0 += LAP_MC) {
                const int mc = M - i0 < LAP_MC ? M - i0 : LAP_MC;
                lap_pack_a(ta, A, lda, i0, mc, p0, kc, Ap);
                for (int js = 0; js < nc; js += LAP_NR)
                    for (int is = 0; is < mc; is += LAP_MR) {
                        const int j = j0 + js, i = i0 + is;
                        la_epilogue_t e;
                        if (ep && last)
                            e = la_epilogue_at(ep, (size_t)i, j);
                        lap_micro(kc, Ap + (size_t)is * kc, Bp + (size_t)js * kc,
                                  C + (size_t)i * ldc + j, ldc, mc - is < LAP_MR ? mc - is : LAP_MR,
                                  nc - js < LAP_NR ? nc - js : LAP_NR, alpha, beta, p0 == 0,
                                  ep && last ? &e : NULL);
                    }
            }
        }
    }
}
