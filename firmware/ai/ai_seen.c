/* The count grid of what the lidar covered (ai_seen.h has the contract). */
#include "ai/ai_seen.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "ai/dinno.h"

int ai_seen_init(ai_seen_t *s, const ai_belief_cfg_t *cfg)
{
    if (!s || !ai_belief_cfg_ok(cfg))
        return -EINVAL;
    memset(s, 0, sizeof *s);
    s->cfg = *cfg;
    s->dirty = 1;
    return 0;
}

/* The cell of a normalised model input (ai_sample.h), or -1 outside the grid. */
static int32_t cell_of(const ai_belief_cfg_t *c, float xn, float yn)
{
    const double x = (double)c->min_x + 0.5 * ((double)xn + 1.0) * ((double)c->max_x - (double)c->min_x);
    const double y = (double)c->min_y + 0.5 * ((double)yn + 1.0) * ((double)c->max_y - (double)c->min_y);
    const double col = floor((x - (double)c->origin_x_m) / (double)c->res_m);
    const double row = floor((y - (double)c->origin_y_m) / (double)c->res_m);
    if (!(col >= 0.0 && col < (double)c->w && row >= 0.0 && row < (double)c->h))
        return -1; /* NaN too */
    return (int32_t)row * (int32_t)c->w + (int32_t)col;
}

int ai_seen_add(ai_seen_t *s, const ai_sample_t *smp, size_t n, double w)
{
    if (!s || (n > 0 && !smp) || !isfinite(w) || w < 0.0 || !ai_belief_cfg_ok(&s->cfg))
        return -EINVAL;
    for (size_t k = 0; k < n; k++) {
        const int32_t i = cell_of(&s->cfg, smp[k].x, smp[k].y);
        if (i < 0)
            continue;
        s->n[i] = (float)((double)s->n[i] + w);
        if (smp[k].occ >= 0.5f)
            s->hits[i] = (float)((double)s->hits[i] + w);
        s->dirty = 1;
    }
    return 0;
}

int ai_seen_scale(ai_seen_t *s, double a)
{
    if (!s || !isfinite(a) || a < 0.0 || !ai_belief_cfg_ok(&s->cfg))
        return -EINVAL;
    const uint32_t cells = s->cfg.w * s->cfg.h;
    for (uint32_t i = 0; i < cells; i++) {
        s->n[i] = (float)((double)s->n[i] * a);
        s->hits[i] = (float)((double)s->hits[i] * a);
    }
    s->dirty = 1;
    return 0;
}

static int open_cell(const ai_seen_t *s, uint32_t i)
{
    return s->n[i] > 0.0f && (double)s->hits[i] * AI_SEEN_OPEN_HITS < (double)s->n[i];
}

double ai_seen_share(const ai_seen_t *s, uint32_t i)
{
    if (!s || i >= s->cfg.w * s->cfg.h)
        return 0.0;
    if (s->n[i] > 0.0f && s->unreached_only)
        return 0.0;
    if (s->n[i] > 0.0f) { /* exp(-n / m), m spots of AI_SEEN_SPOT_M in the cell */
        const double spots = ((double)s->cfg.res_m / AI_SEEN_SPOT_M) * ((double)s->cfg.res_m / AI_SEEN_SPOT_M);
        return exp(-(double)s->n[i] / (spots > 1.0 ? spots : 1.0));
    }
    return s->beyond[i] ? 1.0 : 0.0;
}

int ai_seen_flood(ai_seen_t *s)
{
    if (!s || !ai_belief_cfg_ok(&s->cfg))
        return -EINVAL;
    if (!s->dirty)
        return 0;
    const uint32_t w = s->cfg.w, h = s->cfg.h, cells = w * h;
    uint32_t tail = 0;
    for (uint32_t i = 0; i < cells; i++) { /* the seeds: unreached cells beside an open one */
        const uint32_t col = i % w, row = i / w;
        s->beyond[i] = !(s->n[i] > 0.0f) &&
                       ((col > 0u && open_cell(s, i - 1u)) || (col + 1u < w && open_cell(s, i + 1u)) ||
                        (row > 0u && open_cell(s, i - w)) || (row + 1u < h && open_cell(s, i + w)));
        if (s->beyond[i])
            s->queue[tail++] = (uint16_t)i;
    }
    for (uint32_t head = 0; head < tail; head++) { /* then every unreached cell joined to them */
        const uint32_t c = s->queue[head], col = c % w, row = c / w;
        const uint32_t nb[4] = {col > 0u ? c - 1u : UINT32_MAX, col + 1u < w ? c + 1u : UINT32_MAX,
                                row > 0u ? c - w : UINT32_MAX, row + 1u < h ? c + w : UINT32_MAX};
        for (int k = 0; k < 4; k++)
            if (nb[k] != UINT32_MAX && !s->beyond[nb[k]] && !(s->n[nb[k]] > 0.0f)) {
                s->beyond[nb[k]] = 1u;
                s->queue[tail++] = (uint16_t)nb[k];
            }
    }
    s->dirty = 0;
    return 0;
}

int ai_seen_to_state(const ai_seen_t *s, float *out, size_t cap)
{
    if (!s || !out || !ai_belief_cfg_ok(&s->cfg))
        return -EINVAL;
    const uint32_t cells = s->cfg.w * s->cfg.h;
    if (cap < AI_SEEN_STATE_FLOATS(cells))
        return -ENOSPC;
    out[0] = (float)s->cfg.w;
    out[1] = (float)s->cfg.h;
    memcpy(out + 2, s->n, cells * sizeof(float));
    memcpy(out + 2 + cells, s->hits, cells * sizeof(float));
    return 0;
}

/* A neighbour's grid of our size with counts finite, >= 0 and at least their hits. */
static int grid_ok(const ai_seen_t *s, const float *g, size_t cap)
{
    const uint32_t cells = s->cfg.w * s->cfg.h;
    if (cap < AI_SEEN_STATE_FLOATS(cells) || g[0] != (float)s->cfg.w || g[1] != (float)s->cfg.h)
        return 0;
    for (uint32_t i = 0; i < cells; i++) {
        const float n = g[2 + i], h = g[2 + cells + i];
        if (!isfinite(n) || !isfinite(h) || !(h >= 0.0f) || !(n >= h))
            return 0;
    }
    return 1;
}

int ai_seen_mix(ai_seen_t *s, const float *const *states, size_t n, size_t off, size_t cap, double w,
                uint32_t *used)
{
    if (used)
        *used = 0;
    if (!s || (n > 0 && !states) || n > DINNO_MAX_PEERS || off > cap || !isfinite(w) || w <= 0.0 ||
        (double)n * w > 1.0 || !ai_belief_cfg_ok(&s->cfg))
        return -EINVAL;
    uint8_t ok[DINNO_MAX_PEERS];
    uint32_t c = 0;
    for (size_t k = 0; k < n; k++) { /* checked once: the count sets our own weight */
        ok[k] = states[k] != NULL && grid_ok(s, states[k] + off, cap - off);
        c += ok[k];
    }
    const double self = 1.0 - (double)c * w;
    const uint32_t cells = s->cfg.w * s->cfg.h;
    for (uint32_t i = 0; i < cells; i++) {
        double v = self * (double)s->n[i], h = self * (double)s->hits[i];
        for (size_t k = 0; k < n; k++)
            if (ok[k]) {
                v += w * (double)states[k][off + 2 + i];
                h += w * (double)states[k][off + 2 + cells + i];
            }
        s->n[i] = (float)v;
        s->hits[i] = (float)h;
    }
    s->dirty = 1;
    if (used)
        *used = c;
    return 0;
}
