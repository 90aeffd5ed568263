/* Sample pool with reservoir replacement: see ai_pool.h. */
#include "ai/ai_pool.h"

#include <errno.h>
#include <string.h>

#include "ai/ai_rng.h"

int ai_pool_init(ai_pool_t *p, ai_sample_t *data, uint32_t capacity, ai_pool_policy_t policy,
                 uint64_t seed)
{
    if (p == NULL || data == NULL || capacity == 0 ||
        (policy != AI_POOL_CDR && policy != AI_POOL_DR))
        return -EINVAL;
    memset(p, 0, sizeof *p);
    p->data = data;
    p->capacity = capacity;
    p->policy = policy;
    p->seed = seed;
    return 0;
}

/* Uniform integer in [0, n] from a 64-bit Philox draw keyed by (seed, index). The modulo
 * bias is below (n + 1) / 2^64: negligible. */
static uint64_t draw_upto(uint64_t seed, uint64_t index, uint64_t n)
{
    uint32_t key[2] = {(uint32_t)seed, (uint32_t)(seed >> 32) ^ 0x9E3779B9u};
    uint32_t ctr[4] = {(uint32_t)index, (uint32_t)(index >> 32), 0x504F4F4Cu /* "POOL" */, 0u};
    uint32_t out[4];
    ai_rng_philox4x32(key, ctr, out);
    uint64_t u = ((uint64_t)out[0] << 32) | out[1];
    return u % (n + 1u);
}

int ai_pool_offer(ai_pool_t *p, const ai_sample_t *s)
{
    uint64_t n = p->seen++;
    p->offered++;
    if (p->fill < p->capacity) {
        p->data[p->fill++] = *s;
        return 1;
    }
    uint64_t j = draw_upto(p->seed, p->offered - 1u, n);
    if (j < p->capacity) {
        p->data[j] = *s;
        p->replaced++;
        return 1;
    }
    return 0;
}

void ai_pool_clear(ai_pool_t *p)
{
    p->fill = 0;
    p->seen = 0;
    p->clears++;
}

void ai_pool_boundary(ai_pool_t *p)
{
    if (p->policy == AI_POOL_DR)
        ai_pool_clear(p);
}

const char *ai_pool_policy_name(ai_pool_policy_t p)
{
    return p == AI_POOL_CDR ? "cdr" : p == AI_POOL_DR ? "dr" : "?";
}

int ai_pool_policy_parse(const char *s, ai_pool_policy_t *out)
{
    if (s == NULL || out == NULL)
        return -EINVAL;
    if (strcmp(s, "cdr") == 0)
        *out = AI_POOL_CDR;
    else if (strcmp(s, "dr") == 0)
        *out = AI_POOL_DR;
    else
        return -EINVAL;
    return 0;
}
