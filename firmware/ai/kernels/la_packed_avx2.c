/* The packed GEMM for AVX2 + FMA: a 6 x 16 tile in 12 of the 16 ymm registers (Zen 2/3,
 * Haswell .. Alder Lake; on Zen 3 it measured ~75-80 GFLOP/s where Eigen 3.4 reached ~65).
 * Compiled on every x86-64 build; called only when the CPU has AVX2 and FMA (la_packed.c). */
#include "ai/kernels/la_packed.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>

#include "ai/kernels/la_packed_isa.h"

LA_ISA_BEGIN("avx2,fma")
typedef __m256 lap_vec;
#define LAP_VL 8
#define LAP_MR 6
#define LAP_KC 256
#define LAP_MC 96
#define LAP_NC 256
#define LAP_FN la_packed_sgemm_avx2
static inline lap_vec lap_zero(void) { return _mm256_setzero_ps(); }
static inline lap_vec lap_load(const float *p) { return _mm256_load_ps(p); }
static inline lap_vec lap_loadu(const float *p) { return _mm256_loadu_ps(p); }
static inline void lap_store(float *p, lap_vec v) { _mm256_store_ps(p, v); }
static inline void lap_storeu(float *p, lap_vec v) { _mm256_storeu_ps(p, v); }
static inline lap_vec lap_bcast(const float *p) { return _mm256_broadcast_ss(p); }
static inline lap_vec lap_set1(float x) { return _mm256_set1_ps(x); }
static inline lap_vec lap_fma(lap_vec a, lap_vec b, lap_vec c) { return _mm256_fmadd_ps(a, b, c); }
static inline lap_vec lap_mul(lap_vec a, lap_vec b) { return _mm256_mul_ps(a, b); }
static inline lap_vec lap_add(lap_vec a, lap_vec b) { return _mm256_add_ps(a, b); }
/* max returns its second operand when one is NaN: NaN gives 0, as in the plain loop */
static inline lap_vec lap_relu(lap_vec v) { return _mm256_max_ps(v, _mm256_setzero_ps()); }
static inline lap_vec lap_gate(lap_vec g, lap_vec v)
{
    return _mm256_and_ps(_mm256_cmp_ps(g, _mm256_setzero_ps(), _CMP_GT_OQ), v);
}
#include "ai/kernels/la_packed_t4_sse.h"
#include "ai/kernels/la_packed_impl.h"
LA_ISA_END
#endif
