/* Philox4x32-10 and Box-Muller over tiles of blocks: the raw lanes from the widest kernel the
 * CPU has (ai_rng_lanes.h), the transcendental functions as plain loops GCC vectorises
 * (ai_fastmath.h). */
#include "ai/ai_rng.h"

#include <string.h>

#include "ai/ai_fastmath.h"
#include "ai/kernels/ai_rng_lanes.h"

#define PHILOX_M0 0xD2511F53u
#define PHILOX_M1 0xCD9E8D57u
#define PHILOX_W0 0x9E3779B9u
#define PHILOX_W1 0xBB67AE85u

#define TILE_BLOCKS 64u /* blocks per tile: 256 numbers */

static inline void philox_round(uint32_t *c0, uint32_t *c1, uint32_t *c2, uint32_t *c3, uint32_t k0,
                                uint32_t k1)
{
    uint64_t p0 = (uint64_t)PHILOX_M0 * *c0;
    uint64_t p1 = (uint64_t)PHILOX_M1 * *c2;
    uint32_t hi0 = (uint32_t)(p0 >> 32), lo0 = (uint32_t)p0;
    uint32_t hi1 = (uint32_t)(p1 >> 32), lo1 = (uint32_t)p1;
    uint32_t n0 = hi1 ^ *c1 ^ k0;
    uint32_t n2 = hi0 ^ *c3 ^ k1;
    *c0 = n0;
    *c1 = lo1;
    *c2 = n2;
    *c3 = lo0;
}

static inline void philox10(uint32_t k0, uint32_t k1, uint32_t *c0, uint32_t *c1, uint32_t *c2,
                            uint32_t *c3)
{
    for (int r = 0; r < 10; r++) {
        philox_round(c0, c1, c2, c3, k0, k1);
        k0 += PHILOX_W0;
        k1 += PHILOX_W1;
    }
}

void ai_rng_philox4x32(const uint32_t key[2], const uint32_t ctr[4], uint32_t out[4])
{
    uint32_t c0 = ctr[0], c1 = ctr[1], c2 = ctr[2], c3 = ctr[3];
    philox10(key[0], key[1], &c0, &c1, &c2, &c3);
    out[0] = c0;
    out[1] = c1;
    out[2] = c2;
    out[3] = c3;
}

uint64_t ai_rng_mix64(uint64_t x)
{
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

/* Raw lanes of blocks [b0, b0 + nb), de-interleaved per lane: the pure-C reference of the
 * kernels in ai_rng_lanes.h. */
void ai_rng_lanes_ref(uint64_t key, uint64_t stream, uint64_t b0, uint32_t nb, uint32_t *l0,
                      uint32_t *l1, uint32_t *l2, uint32_t *l3)
{
    uint32_t k0 = (uint32_t)key, k1 = (uint32_t)(key >> 32);
    uint32_t s0 = (uint32_t)stream, s1 = (uint32_t)(stream >> 32);
    for (uint32_t i = 0; i < nb; i++) {
        uint64_t b = b0 + i;
        uint32_t c0 = (uint32_t)b, c1 = (uint32_t)(b >> 32), c2 = s0, c3 = s1;
        philox10(k0, k1, &c0, &c1, &c2, &c3);
        l0[i] = c0;
        l1[i] = c1;
        l2[i] = c2;
        l3[i] = c3;
    }
}

ai_rng_lanes_fn ai_rng_lanes_active(const char **name)
{
#if defined(AI_RNG_X86)
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f")) {
        if (name)
            *name = "avx512f";
        return ai_rng_lanes_avx512;
    }
    if (__builtin_cpu_supports("avx2")) {
        if (name)
            *name = "avx2";
        return ai_rng_lanes_avx2;
    }
#endif
    if (name)
        *name = "c";
    return ai_rng_lanes_ref;
}

static inline float u01(uint32_t u)
{
    return (float)(u >> 8) * (1.0f / 16777216.0f) + (1.0f / 33554432.0f);
}

AI_WIDE static void fill(uint64_t key, uint64_t stream, uint64_t first, float *out, size_t n, int normal)
{
    _Static_assert(TILE_BLOCKS % AI_RNG_LANES_PAD == 0, "the wide kernels fill whole vectors");
    uint32_t l0[TILE_BLOCKS], l1[TILE_BLOCKS], l2[TILE_BLOCKS], l3[TILE_BLOCKS];
    const ai_rng_lanes_fn lanes = ai_rng_lanes_active(NULL);
    float z[4 * TILE_BLOCKS];
    uint64_t pos = first;
    const uint64_t end = first + n;
    while (pos < end) {
        uint64_t b0 = pos / 4u;
        uint64_t bend = (end + 3u) / 4u;
        uint32_t nb = (uint32_t)(bend - b0 > TILE_BLOCKS ? TILE_BLOCKS : bend - b0);
        lanes(key, stream, b0, nb, l0, l1, l2, l3);
        if (normal) {
            for (uint32_t i = 0; i < nb; i++) {
                float ua = u01(l0[i]), ub = u01(l1[i]);
                float uc = u01(l2[i]), ud = u01(l3[i]);
                float r1 = ai_fm_sqrtf(-2.0f * ai_fm_logf(ua));
                float r2 = ai_fm_sqrtf(-2.0f * ai_fm_logf(uc));
                float s1, c1, s2, c2;
                ai_fm_sincosf(6.28318530717958648f * ub, &s1, &c1);
                ai_fm_sincosf(6.28318530717958648f * ud, &s2, &c2);
                z[4 * i + 0] = r1 * c1;
                z[4 * i + 1] = r1 * s1;
                z[4 * i + 2] = r2 * c2;
                z[4 * i + 3] = r2 * s2;
            }
        } else {
            for (uint32_t i = 0; i < nb; i++) {
                z[4 * i + 0] = u01(l0[i]);
                z[4 * i + 1] = u01(l1[i]);
                z[4 * i + 2] = u01(l2[i]);
                z[4 * i + 3] = u01(l3[i]);
            }
        }
        uint64_t tile_first = b0 * 4u;
        uint64_t tile_end = (b0 + nb) * 4u;
        uint64_t copy_end = tile_end < end ? tile_end : end;
        memcpy(out + (pos - first), z + (pos - tile_first), (size_t)(copy_end - pos) * sizeof(float));
        pos = copy_end;
    }
}

void ai_rng_normal_fill(uint64_t key, uint64_t stream, uint64_t first, float *out, size_t n)
{
    if (!out || n == 0)
        return;
    fill(key, stream, first, out, n, 1);
}

void ai_rng_uniform_fill(uint64_t key, uint64_t stream, uint64_t first, float *out, size_t n)
{
    if (!out || n == 0)
        return;
    fill(key, stream, first, out, n, 0);
}
