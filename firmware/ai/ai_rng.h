/* Counter-based random numbers for the AI core (Philox4x32-10, Salmon et al. SC'11).
 *
 * A draw is a pure function of (key, stream, index): no state, so the same seed gives the same
 * numbers on every LA back end, in any order, from any thread, and any sub-range of a stream
 * can be regenerated without the rest. Block b of stream s under key k is
 *     Philox4x32-10(key = {k lo, k hi}, counter = {b lo, b hi, s lo, s hi}) -> 4 x uint32.
 * Number i of a stream is lane (i % 4) of block (i / 4).
 * Uniforms: (u >> 8) * 2^-24 + 2^-25, in (0, 1) (never 0 or 1).
 * Normals: Box-Muller on lanes (0,1) -> normals (0,1) and on lanes (2,3) -> normals (2,3):
 *     r = sqrt(-2 ln u_a), z_a = r cos(2 pi u_b), z_b = r sin(2 pi u_b).
 * Thread-safe (no state). No allocation. */
#ifndef AI_AI_RNG_H
#define AI_AI_RNG_H

#include <stddef.h>
#include <stdint.h>

/* One Philox4x32-10 block. */
void ai_rng_philox4x32(const uint32_t key[2], const uint32_t ctr[4], uint32_t out[4]);

/* SplitMix64 finaliser: a bijective 64-bit mix, for deriving keys and stream ids. */
uint64_t ai_rng_mix64(uint64_t x);

/* out[i] = standard normal number (first + i) of stream `stream` under `key`. */
void ai_rng_normal_fill(uint64_t key, uint64_t stream, uint64_t first, float *out, size_t n);

/* out[i] = uniform (0,1) number (first + i) of the stream (same lanes as the normals use). */
void ai_rng_uniform_fill(uint64_t key, uint64_t stream, uint64_t first, float *out, size_t n);

#endif /* AI_AI_RNG_H */
