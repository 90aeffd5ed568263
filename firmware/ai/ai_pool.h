/* The AI core's sample pool: fixed capacity, caller-owned storage, two policies of the
 * paper's online experiment (section 6.2):
 *   AI_POOL_CDR  cumulative data retention: keep every sample; once full, reservoir
 *                replacement (Vitter's algorithm R) over everything offered since the last
 *                clear, so the pool stays a uniform random subset of it: the n-th offered
 *                sample (n >= capacity, 0-based) replaces slot j = U{0..n} when j < capacity.
 *                j is a Philox draw keyed by (seed, n): a pure function, so the pool's
 *                content depends only on (seed, the sequence offered).
 *   AI_POOL_DR   data refresh: the same reservoir within one round, and ai_pool_boundary()
 *                clears it (only the model weights carry the past).
 * ai_pool_boundary() is a no-op for CDR. No allocation; one thread. */
#ifndef AI_AI_POOL_H
#define AI_AI_POOL_H

#include <stddef.h>
#include <stdint.h>

#include "ai/ai_sample.h"

typedef enum ai_pool_policy {
    AI_POOL_CDR = 0,
    AI_POOL_DR = 1,
} ai_pool_policy_t;

typedef struct ai_pool {
    ai_sample_t *data;     /* capacity records, caller-owned */
    uint32_t capacity;
    uint32_t fill;
    ai_pool_policy_t policy;
    uint64_t seed;
    uint64_t seen;         /* offered since the last clear (the reservoir's n) */
    uint64_t offered;      /* offered since init */
    uint64_t replaced;     /* reservoir replacements since init */
    uint64_t clears;
} ai_pool_t;

/* 0 or -EINVAL (NULL data, capacity 0, bad policy). */
FS_MUST_CHECK int ai_pool_init(ai_pool_t *p, ai_sample_t *data,
                                                     uint32_t capacity, ai_pool_policy_t policy,
                                                     uint64_t seed);
/* Offers one sample. Returns 1 when it was stored, 0 when the reservoir rejected it. */
int ai_pool_offer(ai_pool_t *p, const ai_sample_t *s);
/* End of a communication round: DR clears (fill = 0, reservoir restarts), CDR keeps. */
void ai_pool_boundary(ai_pool_t *p);
void ai_pool_clear(ai_pool_t *p);

const char *ai_pool_policy_name(ai_pool_policy_t p);
/* "cdr" | "dr" -> policy. 0 or -EINVAL. */
FS_MUST_CHECK int ai_pool_policy_parse(const char *s, ai_pool_policy_t *out);

#endif /* AI_AI_POOL_H */
