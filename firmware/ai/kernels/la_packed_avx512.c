/* The packed GEMM for AVX-512F: a 12 x 32 tile in 24 of the 32 zmm registers (the shape BLIS and
 * OpenBLAS use on AVX-512 cores). Compiled on every x86-64 build whatever its baseline; called
 * only when the CPU has AVX-512F (la_packed.c). Blocking measured in firmware/ai/README.md. */
#include "ai/kernels/la_packed.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>

#include "ai/kernels/la_packed_isa.h"

LA_ISA_BEGIN("avx512f,avx2,fma")
typedef __m512 lap_vec;
#define LAP_VL 16
#define LAP_MR 12
/* blocking: -D overrides for measurements only */
#ifndef LA_AVX512_KC
#define LA_AVX512_KC 256
#endif
#ifndef LA_AVX512_MC
#define LA_AVX512_MC 96
#endif
#define LAP_KC LA_AVX512_KC
#define LAP_MC LA_AVX512_MC
#define LAP_NC 256
#define LAP_FN la_packed_sgemm_avx512
static inline lap_vec lap_zero(void) { return _mm512_setzero_ps(); }
static inline lap_vec lap_load(const float *p) { return _mm512_load_ps(p); }
static inline lap_vec lap_loadu(const float *p) { return _mm512_loadu_ps(p); }
static inline void lap_store(float *p, lap_vec v) { _mm512_store_ps(p, v); }
static inline void lap_storeu(float *p, lap_vec v) { _mm512_storeu_ps(p, v); }
static inline lap_vec lap_bcast(const float *p) { return _mm512_set1_ps(*p); }
static inline lap_vec lap_set1(float x) { return _mm512_set1_ps(x); }
static inline lap_vec lap_fma(lap_vec a, lap_vec b, lap_vec c) { return _mm512_fmadd_ps(a, b, c); }
static inline lap_vec lap_mul(lap_vec a, lap_vec b) { return _mm512_mul_ps(a, b); }
static inline lap_vec lap_add(lap_vec a, lap_vec b) { return _mm512_add_ps(a, b); }
/* max returns its second operand when one is NaN: NaN gives 0, as in the plain loop */
static inline lap_vec lap_relu(lap_vec v) { return _mm512_max_ps(v, _mm512_setzero_ps()); }
static inline lap_vec lap_gate(lap_vec g, lap_vec v)
{
    return _mm512_maskz_mov_ps(_mm512_cmp_ps_mask(g, _mm512_setzero_ps(), _CMP_GT_OQ), v);
}
#include "ai/kernels/la_packed_t4_sse.h"
#include "ai/kernels/la_packed_impl.h"
LA_ISA_END
#endif
