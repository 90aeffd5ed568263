/* The packed GEMM for AArch64 NEON: an 8 x 8 tile in 16 of the 32 q registers (Cortex-A53 and
 * every other aarch64 core; NEON is part of the baseline there, so there is no run-time test).
 * Eight rows divide the board's batch of 64 and the widths 64 and 256 (no edge tiles); with
 * the row loops unrolled it takes as few instructions per step as Eigen's NEON path under
 * qemu-aarch64 (docs/boards.md). */
#include "ai/kernels/la_packed.h"

#if defined(__aarch64__) && defined(__ARM_NEON)
#include <arm_neon.h>

typedef float32x4_t lap_vec;
#define LAP_VL 4
#define LAP_MR 8
#define LAP_KC 256
#define LAP_MC 96
#define LAP_NC 256
#define LAP_FN la_packed_sgemm_neon
static inline lap_vec lap_zero(void) { return vdupq_n_f32(0.0f); }
static inline lap_vec lap_load(const float *p) { return vld1q_f32(p); }
static inline lap_vec lap_loadu(const float *p) { return vld1q_f32(p); }
static inline void lap_store(float *p, lap_vec v) { vst1q_f32(p, v); }
static inline void lap_storeu(float *p, lap_vec v) { vst1q_f32(p, v); }
static inline lap_vec lap_bcast(const float *p) { return vld1q_dup_f32(p); }
static inline lap_vec lap_set1(float x) { return vdupq_n_f32(x); }
static inline lap_vec lap_fma(lap_vec a, lap_vec b, lap_vec c) { return vfmaq_f32(c, a, b); }
static inline lap_vec lap_mul(lap_vec a, lap_vec b) { return vmulq_f32(a, b); }
static inline lap_vec lap_add(lap_vec a, lap_vec b) { return vaddq_f32(a, b); }
static inline lap_vec lap_relu(lap_vec v) /* a select, not fmax: NaN must give 0 */
{
    return vbslq_f32(vcgtq_f32(v, vdupq_n_f32(0.0f)), v, vdupq_n_f32(0.0f));
}
static inline lap_vec lap_gate(lap_vec g, lap_vec v)
{
    return vreinterpretq_f32_u32(vandq_u32(vcgtq_f32(g, vdupq_n_f32(0.0f)), vreinterpretq_u32_f32(v)));
}
/* 4 x 4 transpose in q registers: vtrn on pairs of rows, then the 64-bit halves swapped */
static inline void lap_t4(const float *src, int ld, float *dst, int ldd)
{
    const float32x4x2_t t01 = vtrnq_f32(vld1q_f32(src), vld1q_f32(src + ld));
    const float32x4x2_t t23 = vtrnq_f32(vld1q_f32(src + 2 * (size_t)ld), vld1q_f32(src + 3 * (size_t)ld));
    vst1q_f32(dst, vcombine_f32(vget_low_f32(t01.val[0]), vget_low_f32(t23.val[0])));
    vst1q_f32(dst + ldd, vcombine_f32(vget_low_f32(t01.val[1]), vget_low_f32(t23.val[1])));
    vst1q_f32(dst + 2 * (size_t)ldd, vcombine_f32(vget_high_f32(t01.val[0]), vget_high_f32(t23.val[0])));
    vst1q_f32(dst + 3 * (size_t)ldd, vcombine_f32(vget_high_f32(t01.val[1]), vget_high_f32(t23.val[1])));
}
#include "ai/kernels/la_packed_impl.h"
#endif
