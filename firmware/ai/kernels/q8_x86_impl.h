/* The body of one x86 kernel of the int8 GEMM, included by ai/q8_x86.c once per instruction
 * set inside its LA_ISA_BEGIN region, with (all #undef'd at the end):
 *   Q8_FN           the kernel's name (q8_gemm_<isa>, declared in ai/q8_gemm.h)
 *   Q8V, Q8VL       the vector type and its points (16 for zmm, 8 for ymm)
 *   Q8_RB           rows of the main tile (8 with 32 registers, 4 with 16)
 *   Q8_ZERO()       a zero vector
 *   Q8_LOADA(p)     NV = 1 vector of A (unaligned), prepared for Q8_DOT (VNNI: XOR 0x80)
 *   Q8_BCAST(x)     a 32-bit word (4 weights) in every lane
 *   Q8_PREPW(wb)    what Q8_DOT needs of the broadcast once per row (AVX2: |w|)
 *   Q8_DOT(c,a,w,p) c + the 4-byte dot products of a and w in every lane, exactly
 *   Q8_FIX(c, ws)   the finished sum of a row of row sum ws (VNNI: c - 128 ws)
 *   Q8_STORE(p, v)  store (unaligned)
 * Layout and contract: ai/q8_gemm.h. Points across the lanes; per quad of inputs a tile of RB
 * rows x NV vectors takes NV loads of A, RB broadcasts of 4 weights and RB * NV dot products. */

#define Q8_CAT_(a, b) a##b
#define Q8_CAT(a, b) Q8_CAT_(a, b)
#define Q8_EDGE Q8_CAT(Q8_FN, _edge)
#define Q8_MAIN Q8_CAT(Q8_FN, _main)

/* Any tile of RB <= 8 rows x NV <= 2 vectors: the edges (last rows, last points). */
Q8_INLINE void Q8_EDGE(const int RB, const int NV, size_t in, const int8_t *A, size_t lda,
                       const int8_t *W, const int32_t *wsum, int32_t *C, size_t ldc)
{
    Q8V acc[8][2];
    for (int r = 0; r < RB; r++)
        for (int v = 0; v < NV; v++)
            acc[r][v] = Q8_ZERO();
    const size_t nq = in / 4, rem = in % 4;
    /* the partial quad first (the sums are exact in any order): no live range of the
     * accumulators after the loop, which GCC would pay for with copies inside it */
    for (size_t i = 0; i < nq + (rem != 0); i++) {
        const size_t q = rem ? (i == 0 ? nq : i - 1) : i;
        const int8_t *a = A + q * 4 * lda;
        Q8V av[2];
        for (int v = 0; v < NV; v++)
            av[v] = Q8_LOADA(a + 4 * Q8VL * v);
        for (int r = 0; r < RB; r++) {
            const int8_t *w = W + (size_t)r * in + 4 * q;
            const Q8V wb = Q8_BCAST(q < nq ? w_quad(w) : w_tail(w, rem));
            const Q8V wp = Q8_PREPW(wb);
            (void)wp;
            for (int v = 0; v < NV; v++)
                acc[r][v] = Q8_DOT(acc[r][v], av[v], wb, wp);
        }
    }
    for (int r = 0; r < RB; r++)
        for (int v = 0; v < NV; v++)
            Q8_STORE(C + (size_t)r * ldc + Q8VL * v, Q8_FIX(acc[r][v], wsum ? wsum[r] : 0));
}

/* The main tile, Q8_RB rows x 2 vectors, with the accumulators named one by one (GCC keeps an
 * array of vectors in registers badly here: copies and spills in the inner loop). */
#if Q8_RB == 8
#define Q8_ROWS(X) X(0) X(1) X(2) X(3) X(4) X(5) X(6) X(7)
#elif Q8_RB == 4
#define Q8_ROWS(X) X(0) X(1) X(2) X(3)
#else
#error "Q8_RB must be 4 or 8"
#endif
#define Q8_DECL(r)                                                                             \
    Q8V c##r##0 = Q8_ZERO(), c##r##1 = Q8_ZERO();                                              \
    const int8_t *w##r = W + (size_t)(r) * in;
#define Q8_STEP(r, word)                                                                       \
    {                                                                                          \
        const Q8V wb = Q8_BCAST(word), wp = Q8_PREPW(wb);                                      \
        (void)wp;                                                                              \
        c##r##0 = Q8_DOT(c##r##0, a0, wb, wp);                                                 \
        c##r##1 = Q8_DOT(c##r##1, a1, wb, wp);                                                 \
    }
#define Q8_QUAD(r) Q8_STEP(r, w_quad(w##r + 4 * q))
#define Q8_TAIL(r) Q8_STEP(r, w_tail(w##r + 4 * nq, rem))
#define Q8_OUT(r)                                                                              \
    Q8_STORE(C + (size_t)(r) * ldc, Q8_FIX(c##r##0, wsum ? wsum[r] : 0));                      \
    Q8_STORE(C + (size_t)(r) * ldc + Q8VL, Q8_FIX(c##r##1, wsum ? wsum[r] : 0));

Q8_INLINE void Q8_MAIN(size_t in, const int8_t *A, size_t lda, const int8_t *W,
                       const int32_t *wsum, int32_t *C, size_t ldc)
{
    Q8_ROWS(Q8_DECL)
    const size_t nq = in / 4, rem = in % 4;
    if (rem) { /* the partial quad first (see Q8_EDGE) */
        const int8_t *a = A + nq * 4 * lda;
        const Q8V a0 = Q8_LOADA(a), a1 = Q8_LOADA(a + 4 * Q8VL);
        Q8_ROWS(Q8_TAIL)
    }
    const int8_t *a = A;
    for (size_t q = 0; q < nq; q++, a += 4 * lda) {
        const Q8V a0 = Q8_LOADA(a), a1 = Q8_LOADA(a + 4 * Q8VL);
        Q8_ROWS(Q8_QUAD)
    }
    Q8_ROWS(Q8_OUT)
}

/* The kernel: panels of 2 vectors of points (the last may be 1), Q8_RB rows at a time. */
void Q8_FN(size_t np, size_t out, size_t in, const int8_t *A, size_t lda, const int8_t *W,
           const int32_t *wsum, int32_t *C, size_t ldc)
{
    for (size_t p = 0; p < np; p += 2 * Q8VL) {
        const int8_t *a = A + 4 * p;
        int32_t *c = C + p;
        const int nv = np - p > Q8VL ? 2 : 1;
        size_t j = 0;
        for (; j + Q8_RB <= out; j += Q8_RB) {
            const int32_t *ws = wsum ? wsum + j : NULL;
            if (nv == 2)
                Q8_MAIN(in, a, lda, W + j * in, ws, c + j * ldc, ldc);
            else
                Q8_EDGE(Q8_RB, 1, in, a, lda, W + j * in, ws, c + j * ldc, ldc);
        }
        for (; j < out; j++) {
            const int32_t *ws = wsum ? wsum + j : NULL;
            if (nv == 2)
                Q8_EDGE(1, 2, in, a, lda, W + j * in, ws, c + j * ldc, ldc);
            else
                Q8_EDGE(1, 1, in, a, lda, W + j * in, ws, c + j * ldc, ldc);
        }
    }
}

#undef Q8_ROWS
#undef Q8_DECL
#undef Q8_STEP
#undef Q8_QUAD
#undef Q8_TAIL
#undef Q8_OUT
#undef Q8_EDGE
#undef Q8_MAIN
#undef Q8_FN
#undef Q8V
#undef Q8VL
#undef Q8_RB
#undef Q8_ZERO
#undef Q8_LOADA
#undef Q8_BCAST
#undef Q8_PREPW
#undef Q8_DOT
#undef Q8_FIX
#undef Q8_STORE
