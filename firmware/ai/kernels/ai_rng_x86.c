/* The x86-64 Philox lanes kernels (ai_rng_lanes.h): the body of ai_rng_x86_impl.h on AVX-512F
 * (16 blocks per zmm) and on AVX2 (8 per ymm). Compiled on every x86-64 build whatever its
 * baseline (LA_ISA_BEGIN regions); ai_rng.c calls one only when the CPU has its instruction
 * set. */
#include "ai/kernels/ai_rng_lanes.h"

#if defined(AI_RNG_X86)
#include <immintrin.h>

#include "ai/kernels/la_packed_isa.h"

LA_ISA_BEGIN("avx512f,avx2")
typedef __m512i rv;
#define RV_W 16u
#define RV_FN ai_rng_lanes_avx512
static inline rv rv_set1(uint32_t x) { return _mm512_set1_epi32((int)x); }
static inline rv rv_iota(void)
{
    return _mm512_set_epi32(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0);
}
static inline rv rv_add(rv a, rv b) { return _mm512_add_epi32(a, b); }
static inline rv rv_xor3(rv a, rv b, rv c) { return _mm512_ternarylogic_epi32(a, b, c, 0x96); }
static inline rv rv_carry(rv c, rv lo)
{
    return _mm512_maskz_set1_epi32(_mm512_cmplt_epu32_mask(c, lo), 1);
}
static inline rv rv_mul_even(rv a, rv b) { return _mm512_mul_epu32(a, b); }
static inline rv rv_srl64(rv a) { return _mm512_srli_epi64(a, 32); }
static inline rv rv_sll64(rv a) { return _mm512_slli_epi64(a, 32); }
static inline rv rv_blend_odd(rv a, rv b) { return _mm512_mask_blend_epi32(0xAAAA, a, b); }
static inline void rv_storeu(uint32_t *p, rv v) { _mm512_storeu_si512((void *)p, v); }
#include "ai/kernels/ai_rng_x86_impl.h"
LA_ISA_END
#undef RV_W
#undef RV_FN

LA_ISA_BEGIN("avx2")
#define rv rv2
#define rv_set1 rv2_set1
#define rv_iota rv2_iota
#define rv_add rv2_add
#define rv_xor3 rv2_xor3
#define rv_carry rv2_carry
#define rv_mul_even rv2_mul_even
#define rv_srl64 rv2_srl64
#define rv_sll64 rv2_sll64
#define rv_blend_odd rv2_blend_odd
#define rv_storeu rv2_storeu
#define rv_mulhilo rv2_mulhilo
typedef __m256i rv;
#define RV_W 8u
#define RV_FN ai_rng_lanes_avx2
static inline rv rv_set1(uint32_t x) { return _mm256_set1_epi32((int)x); }
static inline rv rv_iota(void) { return _mm256_set_epi32(7, 6, 5, 4, 3, 2, 1, 0); }
static inline rv rv_add(rv a, rv b) { return _mm256_add_epi32(a, b); }
static inline rv rv_xor3(rv a, rv b, rv c) { return _mm256_xor_si256(_mm256_xor_si256(a, b), c); }
/* unsigned c < lo as a signed compare of both with the sign bit flipped: -1 there, so negated */
static inline rv rv_carry(rv c, rv lo)
{
    const rv s = _mm256_set1_epi32((int)0x80000000u);
    return _mm256_sub_epi32(_mm256_setzero_si256(),
                            _mm256_cmpgt_epi32(_mm256_xor_si256(lo, s), _mm256_xor_si256(c, s)));
}
static inline rv rv_mul_even(rv a, rv b) { return _mm256_mul_epu32(a, b); }
static inline rv rv_srl64(rv a) { return _mm256_srli_epi64(a, 32); }
static inline rv rv_sll64(rv a) { return _mm256_slli_epi64(a, 32); }
static inline rv rv_blend_odd(rv a, rv b) { return _mm256_blend_epi32(a, b, 0xAA); }
static inline void rv_storeu(uint32_t *p, rv v) { _mm256_storeu_si256((void *)p, v); }
#include "ai/kernels/ai_rng_x86_impl.h"
LA_ISA_END
#endif
