/* lap_t4 for the x86-64 packed kernels (la_packed_impl.h's contract): a 4 x 4 transpose in xmm
 * registers, SSE (part of every x86-64), the same for the AVX2 and the AVX-512 kernel. Included
 * by la_packed_avx2.c and la_packed_avx512.c inside their instruction-set regions, after
 * <immintrin.h>. Not a public header. */
static inline void lap_t4(const float *src, int ld, float *dst, int ldd)
{
    __m128 r0 = _mm_loadu_ps(src), r1 = _mm_loadu_ps(src + ld);
    __m128 r2 = _mm_loadu_ps(src + 2 * (size_t)ld), r3 = _mm_loadu_ps(src + 3 * (size_t)ld);
    _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
    _mm_storeu_ps(dst, r0);
    _mm_storeu_ps(dst + ldd, r1);
    _mm_storeu_ps(dst + 2 * (size_t)ldd, r2);
    _mm_storeu_ps(dst + 3 * (size_t)ldd, r3);
}
