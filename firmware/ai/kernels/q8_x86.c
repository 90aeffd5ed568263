/* The x86-64 kernels of the int8 GEMM (contract in ai/q8_gemm.h): AVX-512 VNNI on zmm and on
 * ymm, AVX-VNNI on ymm, and an exact AVX2 one, each the body of ai/q8_x86_impl.h on its
 * instruction set. Compiled on every x86-64 build whatever its baseline (LA_ISA_BEGIN regions,
 * ai/la_packed_isa.h); q8_gemm.c calls one only when the CPU has its instruction set.
 *
 * Shape: the points of the chunk across the lanes (one 32-bit lane = the 4 bytes of one quad
 * of inputs of one point), the weights broadcast: per quad of inputs, a tile of RB rows x NV
 * vectors of points takes NV loads of A, RB 4-byte broadcasts of W and RB * NV dot-product
 * instructions into RB * NV int32 accumulators (zmm: 8 x 2, 16 of the 32 registers; ymm: 4 x 2
 * on the 16-register AVX2/AVX-VNNI, 8 x 2 with AVX512VL). W's last, partial quad of a row is
 * read byte by byte and zero-padded, so no byte past a row is read and A's padding bytes do
 * not count. */
#include "ai/kernels/q8_gemm.h"

#if defined(Q8_X86)
#include <immintrin.h>

#include "ai/kernels/la_packed_isa.h"

#define Q8_INLINE static inline __attribute__((always_inline))

/* Bytes 4q..4q+3 of a row (little-endian int32, the layout of a broadcast lane). */
Q8_INLINE int32_t w_quad(const int8_t *p)
{
    return (int32_t)((uint32_t)(uint8_t)p[0] | (uint32_t)(uint8_t)p[1] << 8 |
                     (uint32_t)(uint8_t)p[2] << 16 | (uint32_t)(uint8_t)p[3] << 24);
}

/* The last 1..3 bytes of a row, zero-padded to a quad. */
Q8_INLINE int32_t w_tail(const int8_t *p, size_t rem)
{
    uint32_t v = 0;
    for (size_t r = 0; r < rem; r++)
        v |= (uint32_t)(uint8_t)p[r] << (8 * r);
    return (int32_t)v;
}

/* ---- AVX-512 VNNI on zmm: 16 points per vector, 8 x 2 tile (16 of the 32 registers) ------ */
/* vpdpbusd multiplies unsigned bytes by signed ones: A goes in as a + 128 (a XOR 0x80) and
 * 128 * sum_k w_k comes off at the end. */
LA_ISA_BEGIN("avx512f,avx512bw,avx512vnni")
#define Q8_FN q8_gemm_avx512vnni
#define Q8V __m512i
#define Q8VL 16
#define Q8_RB 8
#define Q8_ZERO() _mm512_setzero_si512()
#define Q8_LOADA(p) _mm512_xor_si512(_mm512_loadu_si512((const void *)(p)), _mm512_set1_epi8(-128))
#define Q8_BCAST(x) _mm512_set1_epi32(x)
#define Q8_PREPW(wb) (wb)
#define Q8_DOT(c, a, wb, wp) _mm512_dpbusd_epi32((c), (a), (wb))
#define Q8_FIX(c, ws) _mm512_sub_epi32((c), _mm512_set1_epi32((ws) * 128))
#define Q8_STORE(p, v) _mm512_storeu_si512((void *)(p), (v))
#include "ai/kernels/q8_x86_impl.h"
LA_ISA_END

/* ---- AVX-512 VNNI on ymm (the AVX512VL encoding): 8 points per vector, 8 x 2 tile ---------- */
LA_ISA_BEGIN("avx512f,avx512vl,avx512bw,avx512vnni,avx2")
#define Q8_FN q8_gemm_avx512vnni_ymm
#define Q8V __m256i
#define Q8VL 8
#define Q8_RB 8
#define Q8_ZERO() _mm256_setzero_si256()
#define Q8_LOADA(p)                                                                            \
    _mm256_xor_si256(_mm256_loadu_si256((const __m256i *)(const void *)(p)), _mm256_set1_epi8(-128))
#define Q8_BCAST(x) _mm256_set1_epi32(x)
#define Q8_PREPW(wb) (wb)
#define Q8_DOT(c, a, wb, wp) _mm256_dpbusd_epi32((c), (a), (wb))
#define Q8_FIX(c, ws) _mm256_sub_epi32((c), _mm256_set1_epi32((ws) * 128))
#define Q8_STORE(p, v) _mm256_storeu_si256((__m256i *)(void *)(p), (v))
#include "ai/kernels/q8_x86_impl.h"
LA_ISA_END

/* ---- AVX-VNNI (VEX, no AVX-512): 8 points per vector, 4 x 2 tile (16 registers) ------------ */
LA_ISA_BEGIN("avxvnni,avx2")
#define Q8_FN q8_gemm_avxvnni
#define Q8V __m256i
#define Q8VL 8
#define Q8_RB 4
#define Q8_ZERO() _mm256_setzero_si256()
#define Q8_LOADA(p)                                                                            \
    _mm256_xor_si256(_mm256_loadu_si256((const __m256i *)(const void *)(p)), _mm256_set1_epi8(-128))
#define Q8_BCAST(x) _mm256_set1_epi32(x)
#define Q8_PREPW(wb) (wb)
#define Q8_DOT(c, a, wb, wp) _mm256_dpbusd_avx_epi32((c), (a), (wb))
#define Q8_FIX(c, ws) _mm256_sub_epi32((c), _mm256_set1_epi32((ws) * 128))
#define Q8_STORE(p, v) _mm256_storeu_si256((__m256i *)(void *)(p), (v))
#include "ai/kernels/q8_x86_impl.h"
LA_ISA_END

/* ---- AVX2: 8 points per vector, 4 x 2 tile -------------------------------------------------
 * |w| (u8) x a * sign(w) (s8) by vpmaddubsw: a pair sums to at most 2 * 128 * 127 = 32512 in
 * magnitude, so the int16 never saturates as long as a != -128 (the quantiser gives |a| <= 127;
 * any w, -128 too); then vpmaddwd by 1s adds the pairs into the int32 lanes. No correction. */
LA_ISA_BEGIN("avx2")
#define Q8_FN q8_gemm_avx2
#define Q8V __m256i
#define Q8VL 8
#define Q8_RB 4
#define Q8_ZERO() _mm256_setzero_si256()
#define Q8_LOADA(p) _mm256_loadu_si256((const __m256i *)(const void *)(p))
#define Q8_BCAST(x) _mm256_set1_epi32(x)
#define Q8_PREPW(wb) _mm256_abs_epi8(wb)
#define Q8_DOT(c, a, wb, wp)                                                                   \
    _mm256_add_epi32((c), _mm256_madd_epi16(                                                   \
                              _mm256_maddubs_epi16((wp), _mm256_sign_epi8((a), (wb))),         \
                              _mm256_set1_epi16(1)))
#define Q8_FIX(c, ws) ((void)(ws), (c))
#define Q8_STORE(p, v) _mm256_storeu_si256((__m256i *)(void *)(p), (v))
#include "ai/kernels/q8_x86_impl.h"
LA_ISA_END

#endif /* Q8_X86 */
