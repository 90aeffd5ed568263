/* Seeded network fault injection: parser, decisions, holding area. See hal_host_netfault.h. */
#include "hal_host_netfault.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SPEC_MAX 512u
#define GOLDEN 0x9E3779B97F4A7C15ull

static const char *const KEYS = "drop, dup, reorder, delay_ms, seed, partition, from, until, hold_ms";

static int fail(char *err, size_t errlen, const char *fmt, ...)
{
    if (err != NULL && errlen > 0) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return -EINVAL;
}

/* A whole C double, finite: strtod alone accepts "1.5x" and "nan". */
static int parse_double(const char *v, double *out)
{
    char *end = NULL;
    if (v[0] == '\0')
        return -1;
    double d = strtod(v, &end);
    if (end == v || *end != '\0' || !isfinite(d))
        return -1;
    *out = d;
    return 0;
}

/* Decimal digits only (strtoull would take a sign, spaces and wrap around). */
static int parse_u64(const char *v, uint64_t max, uint64_t *out)
{
    if (v[0] == '\0')
        return -1;
    uint64_t x = 0;
    for (const char *c = v; *c != '\0'; c++) {
        if (*c < '0' || *c > '9')
            return -1;
        const uint64_t d = (uint64_t)(*c - '0');
        if (x > (max - d) / 10u)
            return -1;
        x = x * 10u + d;
    }
    *out = x;
    return 0;
}

/* One group of '.'-separated robot ids into a bit set (empty ids were refused before:
 * strtok_r would skip them silently). */
static int parse_group(const char *whole, char *g, uint64_t *bits, char *err, size_t errlen)
{
    if (g[0] == '\0')
        return fail(err, errlen, "partition=%s: a group is empty (e.g. partition=0.1/2.3)", whole);
    for (char *save = NULL, *id = strtok_r(g, ".", &save); id != NULL; id = strtok_r(NULL, ".", &save)) {
        uint64_t v = 0;
        if (parse_u64(id, HAL_HOST_NETFAULT_MAX_ID - 1u, &v) != 0)
            return fail(err, errlen, "partition=%s: '%s' is not a robot id 0 .. %u", whole, id,
                        HAL_HOST_NETFAULT_MAX_ID - 1u);
        bits[v / 64u] |= 1ull << (v % 64u);
    }
    return 0;
}

static int parse_partition(const char *v, hal_host_netfault_cfg_t *cfg, char *err, size_t errlen)
{
    char buf[SPEC_MAX];
    snprintf(buf, sizeof buf, "%s", v);
    char *slash = strchr(buf, '/');
    if (slash == NULL || strchr(slash + 1, '/') != NULL)
        return fail(err, errlen, "partition=%s: not two groups A/B of robot ids (e.g. partition=0.1/2.3)", v);
    for (const char *c = buf; *c != '\0'; c++)
        if ((*c == '.' && (c == buf || c[1] == '\0' || c[1] == '.' || c[1] == '/' || c[-1] == '/')))
            return fail(err, errlen, "partition=%s: an empty robot id (ids are separated by single '.')", v);
    *slash = '\0';
    if (parse_group(v, buf, cfg->group[0], err, errlen) != 0 ||
        parse_group(v, slash + 1, cfg->group[1], err, errlen) != 0)
        return -EINVAL;
    for (uint32_t i = 0; i < HAL_HOST_NETFAULT_MAX_ID; i++)
        if ((cfg->group[0][i / 64u] & cfg->group[1][i / 64u]) >> (i % 64u) & 1u)
            return fail(err, errlen, "partition=%s: robot %u is in both groups", v, i);
    cfg->has_partition = 1;
    return 0;
}

/* One key=value; `seen` marks the keys already given. */
static int parse_item(char *item, hal_host_netfault_cfg_t *cfg, unsigned *seen, char *err, size_t errlen)
{
    static const char *const names[] = {"drop", "dup", "reorder", "delay_ms", "seed", "partition", "from", "until", "hold_ms"};
    char *eq = strchr(item, '=');
    if (eq == NULL)
        return fail(err, errlen, "'%s' is not key=value (keys: %s)", item, KEYS);
    *eq = '\0';
    const char *k = item, *v = eq + 1;
    unsigned which = 0;
    while (which < sizeof names / sizeof names[0] && strcmp(names[which], k) != 0)
        which++;
    if (which == sizeof names / sizeof names[0])
        return fail(err, errlen, "unknown key '%s' (keys: %s)", k, KEYS);
    if (*seen & (1u << which))
        return fail(err, errlen, "%s given twice", k);
    *seen |= 1u << which;
    if (v[0] == '\0')
        return fail(err, errlen, "%s=: no value", k);
    double d = 0;
    uint64_t u = 0;
    switch (which) {
    case 0: case 1: case 2: {
        if (parse_double(v, &d) != 0 || d < 0.0 || d > 1.0)
            return fail(err, errlen, "%s=%s: a probability is a number 0 .. 1", k, v);
        double *p = which == 0 ? &cfg->drop : which == 1 ? &cfg->dup : &cfg->reorder;
        *p = d;
        return 0;
    }
    case 3:
        if (parse_u64(v, HAL_HOST_NETFAULT_MAX_DELAY_MS, &u) != 0)
            return fail(err, errlen, "delay_ms=%s: not a whole number of milliseconds 0 .. %u", v,
                        HAL_HOST_NETFAULT_MAX_DELAY_MS);
        cfg->delay_ms = (uint32_t)u;
        return 0;
    case 4:
        if (parse_u64(v, UINT64_MAX, &u) != 0)
            return fail(err, errlen, "seed=%s: not a whole number 0 .. %llu", v, (unsigned long long)UINT64_MAX);
        cfg->seed = u;
        cfg->has_seed = 1;
        return 0;
    case 5:
        return parse_partition(v, cfg, err, errlen);
    case 8:
        if (parse_u64(v, HAL_HOST_NETFAULT_MAX_DELAY_MS, &u) != 0 || u == 0)
            return fail(err, errlen, "hold_ms=%s: not a whole number of milliseconds 1 .. %u", v,
                        HAL_HOST_NETFAULT_MAX_DELAY_MS);
        cfg->hold_ms = (uint32_t)u;
        return 0;
    default:
        if (parse_double(v, &d) != 0 || d < 0.0)
            return fail(err, errlen, "%s=%s: not a time in seconds >= 0", k, v);
        *(which == 6 ? &cfg->from_s : &cfg->until_s) = d;
        return 0;
    }
}

int hal_host_netfault_parse(const char *spec, hal_host_netfault_cfg_t *cfg, char *err, size_t errlen)
{
    if (cfg == NULL)
        return -EINVAL;
    memset(cfg, 0, sizeof *cfg);
    cfg->until_s = INFINITY;
    cfg->hold_ms = HAL_HOST_NETFAULT_REORDER_HOLD_MS;
    if (err != NULL && errlen > 0)
        err[0] = '\0';
    if (spec == NULL || spec[0] == '\0')
        return 0;
    if (strlen(spec) >= SPEC_MAX)
        return fail(err, errlen, "the spec is longer than %u characters", SPEC_MAX - 1u);
    char buf[SPEC_MAX];
    memcpy(buf, spec, strlen(spec) + 1u);
    unsigned seen = 0;
    for (char *item = buf;;) {
        char *comma = strchr(item, ',');
        if (comma != NULL)
            *comma = '\0';
        if (item[0] == '\0')
            return fail(err, errlen, "'%s': an empty item (items are key=value separated by single ',')", spec);
        if (parse_item(item, cfg, &seen, err, errlen) != 0)
            return -EINVAL;
        if (comma == NULL)
            break;
        item = comma + 1;
    }
    const unsigned window = (1u << 6) | (1u << 7);
    if ((seen & window) && !cfg->has_partition)
        return fail(err, errlen, "from= and until= need partition=");
    if ((seen & (1u << 8)) && !(cfg->reorder > 0.0))
        return fail(err, errlen, "hold_ms= needs reorder=");
    if (!(cfg->until_s > cfg->from_s))
        return fail(err, errlen, "until=%g is not after from=%g", cfg->until_s, cfg->from_s);
    return 0;
}

int hal_host_netfault_active(const hal_host_netfault_cfg_t *cfg)
{
    return cfg != NULL && (cfg->drop > 0.0 || cfg->dup > 0.0 || cfg->reorder > 0.0 || cfg->delay_ms > 0 ||
                           cfg->has_partition);
}

/* splitmix64's output function: its n-th output is mix(seed + n * GOLDEN). */
static uint64_t mix(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

uint64_t hal_host_netfault_seed(uint64_t base, uint32_t self)
{
    return mix(mix(base) ^ ((uint64_t)self + 1u) * 0xD1B54A32D192ED03ull);
}

uint64_t hal_host_netfault_draw(uint64_t seed, uint64_t seq, uint32_t k)
{
    return mix(seed + (seq * HAL_HOST_NETFAULT_DRAWS + k + 1u) * GOLDEN);
}

/* [0, 1) from the top 53 bits. */
static double unit(uint64_t x)
{
    return (double)(x >> 11) * 0x1.0p-53;
}

static int in_group(const hal_host_netfault_cfg_t *cfg, int g, uint32_t id)
{
    return id < HAL_HOST_NETFAULT_MAX_ID && (cfg->group[g][id / 64u] >> (id % 64u) & 1u);
}

void hal_host_netfault_decide(const hal_host_netfault_cfg_t *cfg, uint64_t seed, uint64_t seq, int32_t sender,
                              uint32_t self, uint64_t t_us, hal_host_netfault_decision_t *d)
{
    memset(d, 0, sizeof *d);
    if (cfg->has_partition && sender >= 0) {
        const double t = (double)t_us * 1e-6;
        const uint32_t s = (uint32_t)sender;
        if (t >= cfg->from_s && t < cfg->until_s &&
            ((in_group(cfg, 0, s) && in_group(cfg, 1, self)) || (in_group(cfg, 1, s) && in_group(cfg, 0, self)))) {
            d->partitioned = 1;
            return;
        }
    }
    /* Every datagram uses its own fixed draws, whatever the settings, so turning one fault
       on does not change the decisions of another for the same seed. */
    if (unit(hal_host_netfault_draw(seed, seq, 0)) < cfg->drop) {
        d->dropped = 1;
        return;
    }
    d->copies = unit(hal_host_netfault_draw(seed, seq, 1)) < cfg->dup ? 2u : 1u;
    if (unit(hal_host_netfault_draw(seed, seq, 2)) < cfg->reorder) {
        d->reordered = 1;
        d->passes = 1u + (uint32_t)(hal_host_netfault_draw(seed, seq, 3) % HAL_HOST_NETFAULT_REORDER_MAX);
    }
    if (cfg->delay_ms > 0) {
        const double span = (double)cfg->delay_ms * 1000.0 + 1.0; /* 0 .. D ms inclusive */
        for (uint32_t c = 0; c < d->copies; c++) {
            double us = floor(unit(hal_host_netfault_draw(seed, seq, 4u + c)) * span);
            d->delay_us[c] = (uint32_t)(us < span - 1.0 ? us : span - 1.0);
        }
    }
}

/* ---- holding area ----------------------------------------------------------------------- */
int hal_host_netfault_hold_init(hal_host_netfault_hold_t *h, uint32_t cap)
{
    if (h == NULL || cap == 0 || cap > 4096u)
        return -EINVAL;
    memset(h, 0, sizeof *h);
    h->e = calloc(cap, sizeof *h->e);
    h->bytes = malloc((size_t)cap * HAL_NET_MTU_BYTES);
    if (h->e == NULL || h->bytes == NULL) {
        hal_host_netfault_hold_free(h);
        return -ENOMEM;
    }
    for (uint32_t i = 0; i < cap; i++)
        h->e[i].data = h->bytes + (size_t)i * HAL_NET_MTU_BYTES;
    h->cap = cap;
    return 0;
}

void hal_host_netfault_hold_free(hal_host_netfault_hold_t *h)
{
    if (h == NULL)
        return;
    free(h->e);
    free(h->bytes);
    memset(h, 0, sizeof *h);
}

int hal_host_netfault_hold_put(hal_host_netfault_hold_t *h, const char *channel, const void *data, uint32_t len,
                               uint64_t due_us, uint32_t passes, uint64_t deadline_us)
{
    if (h == NULL || !hal_net_channel_valid(channel) || len > HAL_NET_MTU_BYTES || (data == NULL && len > 0))
        return -EINVAL;
    if (h->fill == h->cap)
        return -ENOSPC;
    hal_host_netfault_held_t *e = h->e;
    while (e->used)
        e++;
    e->used = 1;
    e->seq = h->next_seq++;
    e->due_us = due_us;
    e->passes = passes;
    e->deadline_us = deadline_us > due_us ? deadline_us : due_us;
    memset(&e->info, 0, sizeof e->info);
    memcpy(e->info.channel, channel, strlen(channel) + 1u);
    e->info.len = len;
    if (len > 0)
        memcpy(e->data, data, len);
    h->fill++;
    return 0;
}

/* When time alone makes e releasable. */
static uint64_t wake_of(const hal_host_netfault_held_t *e)
{
    return e->passes == 0 ? e->due_us : e->deadline_us;
}

static int before(const hal_host_netfault_held_t *a, uint64_t ta, const hal_host_netfault_held_t *b, uint64_t tb)
{
    return b == NULL || ta < tb || (ta == tb && a->seq < b->seq);
}

hal_host_netfault_held_t *hal_host_netfault_hold_next(hal_host_netfault_hold_t *h, uint64_t now_us)
{
    hal_host_netfault_held_t *best = NULL;
    for (uint32_t i = 0; h != NULL && h->fill > 0 && i < h->cap; i++) {
        hal_host_netfault_held_t *e = &h->e[i];
        if (e->used && now_us >= e->due_us && (e->passes == 0 || now_us >= e->deadline_us) &&
            before(e, e->due_us, best, best ? best->due_us : 0))
            best = e;
    }
    return best;
}

hal_host_netfault_held_t *hal_host_netfault_hold_oldest(hal_host_netfault_hold_t *h)
{
    hal_host_netfault_held_t *best = NULL;
    for (uint32_t i = 0; h != NULL && h->fill > 0 && i < h->cap; i++) {
        hal_host_netfault_held_t *e = &h->e[i];
        if (e->used && before(e, wake_of(e), best, best ? wake_of(best) : 0))
            best = e;
    }
    return best;
}

void hal_host_netfault_hold_release(hal_host_netfault_hold_t *h, hal_host_netfault_held_t *e)
{
    if (h == NULL || e == NULL || !e->used)
        return;
    e->used = 0;
    h->fill--;
}

void hal_host_netfault_hold_passed(hal_host_netfault_hold_t *h)
{
    for (uint32_t i = 0; h != NULL && h->fill > 0 && i < h->cap; i++)
        if (h->e[i].used && h->e[i].passes > 0)
            h->e[i].passes--;
}

uint64_t hal_host_netfault_hold_wake_us(const hal_host_netfault_hold_t *h)
{
    uint64_t w = UINT64_MAX;
    for (uint32_t i = 0; h != NULL && h->fill > 0 && i < h->cap; i++)
        if (h->e[i].used && wake_of(&h->e[i]) < w)
            w = wake_of(&h->e[i]);
    return w;
}
