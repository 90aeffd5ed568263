/* Link models of the in-process DiNNO fleet: see sim_links.h. */
#include "sim_links.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "sim_rng.h"

#define SPEC_MAX 4096u
static const char *const KEYS = "partition, away, from, until";

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

void sim_links_default(sim_links_t *l)
{
    memset(l, 0, sizeof *l);
    l->success = 1.0;
}

int sim_links_active(const sim_links_t *l)
{
    return l != NULL && (l->success < 1.0 || l->n_cuts > 0);
}

/* Decimal digits only, <= max (strtoul would take a sign and spaces, and wrap around). */
static int parse_u32(const char *v, uint32_t max, uint32_t *out)
{
    if (v[0] == '\0')
        return -1;
    uint64_t x = 0;
    for (const char *c = v; *c != '\0'; c++) {
        if (*c < '0' || *c > '9')
            return -1;
        x = x * 10u + (uint64_t)(*c - '0');
        if (x > max)
            return -1;
    }
    *out = (uint32_t)x;
    return 0;
}

/* "0.1.2/3.4/5" into c->group (c zeroed by the caller). Empty groups and ids are refused
 * here: strtok would skip them silently. */
static int parse_groups(const char *v, sim_links_cut_t *c, char *err, size_t errlen)
{
    c->groups = 1;
    const char *p = v;
    for (;;) {
        const char *end = p;
        while (*end != '\0' && *end != '.' && *end != '/')
            end++;
        const size_t len = (size_t)(end - p);
        if (len == 0)
            return fail(err, errlen, "partition=%s: an empty group or id (groups are '/'-separated, ids "
                                     "'.'-separated, e.g. partition=0.1/2.3)", v);
        char id[16];
        uint32_t a = 0;
        if (len < sizeof id) {
            memcpy(id, p, len);
            id[len] = '\0';
        }
        if (len >= sizeof id || parse_u32(id, SIM_LINKS_MAX_AGENTS - 1, &a) != 0)
            return fail(err, errlen, "partition=%s: '%.*s' is not an agent id 0 .. %d", v, (int)len, p,
                        SIM_LINKS_MAX_AGENTS - 1);
        if (c->group[a] != 0)
            return fail(err, errlen, "partition=%s: agent %u is %s", v, a,
                        c->group[a] == c->groups ? "named twice" : "in two groups");
        c->group[a] = (uint16_t)c->groups;
        if (*end == '\0')
            return 0;
        if (*end == '/')
            c->groups++;
        p = end + 1;
    }
}

/* One cut: comma-separated key=value (the text is modified). */
static int parse_cut(char *text, sim_links_cut_t *c, char *err, size_t errlen)
{
    static const char *const names[] = {"partition", "away", "from", "until"};
    memset(c, 0, sizeof *c);
    c->until = SIM_LINKS_FOREVER;
    unsigned seen = 0;
    for (char *item = text;;) {
        char *comma = strchr(item, ',');
        if (comma != NULL)
            *comma = '\0';
        char *eq = strchr(item, '=');
        if (item[0] == '\0')
            return fail(err, errlen, "an empty item (items are key=value separated by single ',')");
        if (eq == NULL)
            return fail(err, errlen, "'%s' is not key=value (keys: %s)", item, KEYS);
        *eq = '\0';
        const char *k = item, *v = eq + 1;
        unsigned which = 0;
        while (which < sizeof names / sizeof names[0] && strcmp(names[which], k) != 0)
            which++;
        if (which == sizeof names / sizeof names[0])
            return fail(err, errlen, "unknown key '%s' (keys: %s)", k, KEYS);
        if (seen & (1u << which))
            return fail(err, errlen, "%s given twice", k);
        if (which < 2 && (seen & 3u))
            return fail(err, errlen, "a cut is one partition= or one away=, not both");
        seen |= 1u << which;
        if (v[0] == '\0')
            return fail(err, errlen, "%s=: no value", k);
        uint32_t u = 0;
        switch (which) {
        case 0:
            if (parse_groups(v, c, err, errlen) != 0)
                return -EINVAL;
            break;
        case 1:
            if (parse_u32(v, SIM_LINKS_MAX_AGENTS - 1, &u) != 0)
                return fail(err, errlen, "away=%s: not an agent id 0 .. %d", v, SIM_LINKS_MAX_AGENTS - 1);
            c->groups = 1;
            c->group[u] = 1;
            break;
        default:
            /* SIM_LINKS_FOREVER stays the "never ends" of an until= not given. */
            if (parse_u32(v, SIM_LINKS_FOREVER - 1u, &u) != 0)
                return fail(err, errlen, "%s=%s: not a round 0 .. %u", k, v, SIM_LINKS_FOREVER - 1u);
            *(which == 2 ? &c->from : &c->until) = u;
            break;
        }
        if (comma == NULL)
            break;
        item = comma + 1;
    }
    if (!(seen & 3u))
        return fail(err, errlen, "a cut needs partition=A/B or away=I");
    if (c->from >= c->until)
        return fail(err, errlen, "until=%u is not after from=%u", c->until, c->from);
    return 0;
}

int sim_links_parse(const char *spec, sim_links_t *l, char *err, size_t errlen)
{
    if (err != NULL && errlen > 0)
        err[0] = '\0';
    if (spec == NULL || l == NULL)
        return fail(err, errlen, "NULL argument");
    if (spec[0] == '\0')
        return fail(err, errlen, "an empty spec (e.g. away=2,from=10,until=20 or partition=0.1/2.3,from=5)");
    if (strlen(spec) >= SPEC_MAX)
        return fail(err, errlen, "the spec is longer than %u characters", SPEC_MAX - 1u);
    char buf[SPEC_MAX];
    sim_links_t next; /* filled aside: l changes only when the whole spec is good */
    memcpy(buf, spec, strlen(spec) + 1u);
    next = *l;
    for (char *cut = buf;;) {
        char *semi = strchr(cut, ';');
        if (semi != NULL)
            *semi = '\0';
        if (cut[0] == '\0')
            return fail(err, errlen, "an empty cut (cuts are separated by single ';')");
        if (next.n_cuts >= SIM_LINKS_MAX_CUTS) {
            fail(err, errlen, "more than %d cuts", SIM_LINKS_MAX_CUTS);
            return -E2BIG;
        }
        char why[256];
        if (parse_cut(cut, &next.cut[next.n_cuts], why, sizeof why) != 0)
            return fail(err, errlen, "cut %d: %s", next.n_cuts + 1, why);
        next.n_cuts++;
        if (semi == NULL)
            break;
        cut = semi + 1;
    }
    *l = next;
    return 0;
}

int sim_links_check(const sim_links_t *l, int n_agents, char *err, size_t errlen)
{
    if (l == NULL || n_agents < 1 || n_agents > SIM_LINKS_MAX_AGENTS)
        return fail(err, errlen, "NULL link model or agents not 1 .. %d", SIM_LINKS_MAX_AGENTS);
    if (!(l->success >= 0.0 && l->success <= 1.0)) /* NaN fails too */
        return fail(err, errlen, "link success %g is not a probability 0 .. 1", l->success);
    if (l->n_cuts < 0 || l->n_cuts > SIM_LINKS_MAX_CUTS)
        return fail(err, errlen, "%d cuts (at most %d)", l->n_cuts, SIM_LINKS_MAX_CUTS);
    for (int c = 0; c < l->n_cuts; c++) {
        const sim_links_cut_t *cut = &l->cut[c];
        if (cut->from >= cut->until)
            return fail(err, errlen, "cut %d: until=%u is not after from=%u", c + 1, cut->until, cut->from);
        for (int i = n_agents; i < SIM_LINKS_MAX_AGENTS; i++)
            if (cut->group[i] != 0)
                return fail(err, errlen, "cut %d: agent %d is not one of the %d agents (0 .. %d)", c + 1, i, n_agents,
                            n_agents - 1);
        int split = 0;
        for (int i = 1; i < n_agents && !split; i++)
            split = cut->group[i] != cut->group[0];
        if (!split)
            return fail(err, errlen, "cut %d splits nothing: all %d agents are in one group", c + 1, n_agents);
    }
    return 0;
}

int sim_links_deliver(const sim_links_t *l, uint64_t seed, uint32_t k, uint32_t i, uint32_t j)
{
    const uint32_t a = i < j ? i : j, b = i < j ? j : i;
    for (int c = 0; c < l->n_cuts; c++) {
        const sim_links_cut_t *cut = &l->cut[c];
        if (k >= cut->from && k < cut->until && cut->group[a] != cut->group[b])
            return 0;
    }
    if (l->success >= 1.0)
        return 1;
    if (l->success <= 0.0)
        return 0;
    return sim_rng_uniform(seed, SIM_LINKS_STREAM, k, a, b) < l->success;
}

void sim_links_describe(const sim_links_t *l, char *out, size_t cap)
{
    if (out == NULL || cap == 0)
        return;
    out[0] = '\0';
    size_t n = 0;
#define PUT(...)                                                                                 \
    do {                                                                                         \
        if (n < cap) {                                                                           \
            const int w_ = snprintf(out + n, cap - n, __VA_ARGS__);                             \
            n = w_ < 0 ? cap : n + (size_t)w_;                                                   \
        }                                                                                        \
    } while (0)
    if (!sim_links_active(l)) {
        PUT("every link delivers");
        return;
    }
    PUT("success %g", l->success);
    for (int c = 0; c < l->n_cuts; c++) {
        const sim_links_cut_t *cut = &l->cut[c];
        int named = 0, last = -1;
        for (int i = 0; i < SIM_LINKS_MAX_AGENTS; i++)
            if (cut->group[i] != 0) {
                named++;
                last = i;
            }
        if (cut->groups == 1 && named == 1) {
            PUT("; away=%d", last);
        } else {
            PUT("; partition=");
            for (uint32_t g = 1; g <= cut->groups; g++) {
                int first = 1;
                PUT("%s", g > 1 ? "/" : "");
                for (int i = 0; i < SIM_LINKS_MAX_AGENTS; i++)
                    if (cut->group[i] == g) {
                        PUT("%s%d", first ? "" : ".", i);
                        first = 0;
                    }
            }
        }
        if (cut->until == SIM_LINKS_FOREVER)
            PUT(" rounds [%u, end)", cut->from);
        else
            PUT(" rounds [%u, %u)", cut->from, cut->until);
    }
#undef PUT
}
