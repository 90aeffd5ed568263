/* Counter-based random numbers for host_sim: a value is a pure function of its key
 * (seed, stream, a, b, c), so any sample of any sensor can be regenerated independently of
 * the order in which things were computed (deterministic for a run seed, whatever the
 * thread or step schedule). The mixer is SplitMix64's finaliser applied to a chained key. */
#ifndef SIM_RNG_H
#define SIM_RNG_H

#include <math.h>
#include <stdint.h>

static inline uint64_t sim_rng_mix(uint64_t z)
{
    z += 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* A sequential SplitMix64 stream, for choices made in order (plan layouts, tour start rooms):
 * the same numbers on every platform. */
typedef struct sim_rng_seq {
    uint64_t s;
} sim_rng_seq_t;

static inline uint64_t sim_rng_next(sim_rng_seq_t *r)
{
    const uint64_t z = r->s;
    r->s += 0x9E3779B97F4A7C15ull;
    return sim_rng_mix(z); /* SplitMix64: the finaliser of the advanced state */
}

/* 64 random bits for the key. `stream` separates independent uses (noise, dropout, ...). */
static inline uint64_t sim_rng_u64(uint64_t seed, uint32_t stream, uint64_t a, uint64_t b,
                                   uint64_t c)
{
    uint64_t h = sim_rng_mix(seed ^ ((uint64_t)stream << 32));
    h = sim_rng_mix(h ^ a);
    h = sim_rng_mix(h ^ b);
    return sim_rng_mix(h ^ c);
}

/* Uniform in [0, 1) with 53 bits. */
static inline double sim_rng_uniform(uint64_t seed, uint32_t stream, uint64_t a, uint64_t b,
                                     uint64_t c)
{
    return (double)(sim_rng_u64(seed, stream, a, b, c) >> 11) * 0x1.0p-53;
}

/* Standard normal (Box-Muller on two keyed uniforms; streams `stream` and `stream + 1`). */
static inline double sim_rng_normal(uint64_t seed, uint32_t stream, uint64_t a, uint64_t b,
                                    uint64_t c)
{
    double u1 = sim_rng_uniform(seed, stream, a, b, c);
    double u2 = sim_rng_uniform(seed, stream + 1u, a, b, c);
    /* 1 - u1 is in (0, 1]: the log is finite. */
    return sqrt(-2.0 * log(1.0 - u1)) * cos(6.283185307179586 * u2);
}

#endif /* SIM_RNG_H */
