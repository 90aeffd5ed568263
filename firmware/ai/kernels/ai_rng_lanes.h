/* The raw Philox4x32-10 lanes behind ai_rng.h's fills, per instruction set. Not a public header.
 *
 * ai_rng_lanes_*(key, stream, b0, nb, l0..l3): lane j of block b0 + i into l_j[i], i < nb. The
 * pure-C reference runs anywhere; the x86-64 ones (ai_rng_x86.c, compiled on every x86-64
 * build whatever its baseline) take 16 (AVX-512F) or 8 (AVX2) blocks per vector, the 32 x 32 ->
 * 64-bit products as even/odd vpmuludq pairs (GCC vectorised the reference with 64 x 64-bit
 * multiplies), and write whole vectors: up to nb rounded up to 16 entries. All give the same
 * numbers; ai_rng.c takes the widest the CPU has. */
#ifndef AI_AI_RNG_LANES_H
#define AI_AI_RNG_LANES_H

#include <stdint.h>

#define AI_RNG_LANES_PAD 16u /* the wide kernels write nb rounded up to this many entries */

typedef void (*ai_rng_lanes_fn)(uint64_t key, uint64_t stream, uint64_t b0, uint32_t nb,
                                uint32_t *l0, uint32_t *l1, uint32_t *l2, uint32_t *l3);

void ai_rng_lanes_ref(uint64_t key, uint64_t stream, uint64_t b0, uint32_t nb, uint32_t *l0,
                      uint32_t *l1, uint32_t *l2, uint32_t *l3);

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define AI_RNG_X86 1
void ai_rng_lanes_avx512(uint64_t key, uint64_t stream, uint64_t b0, uint32_t nb, uint32_t *l0,
                         uint32_t *l1, uint32_t *l2, uint32_t *l3);
void ai_rng_lanes_avx2(uint64_t key, uint64_t stream, uint64_t b0, uint32_t nb, uint32_t *l0,
                       uint32_t *l1, uint32_t *l2, uint32_t *l3);
#endif

/* The kernel ai_rng.c uses on this CPU, and its name ("avx512f", "avx2" or "c"). */
ai_rng_lanes_fn ai_rng_lanes_active(const char **name);

#endif /* AI_AI_RNG_LANES_H */
