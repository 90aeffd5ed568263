/* The AI core's coarse belief grid (ai_belief.h has the contract). */
#include "ai/ai_belief.h"
#include "ai/ai_seen.h"

#include <errno.h>
#include <math.h>
#include <string.h>

/* Normalised model input of a world coordinate, in double so that the cell centre the update
 * evaluates and the one ai_belief_cell_xy reports are the same float bit for bit. */
static float norm_coord(double v, double lo, double hi)
{
    return (float)(2.0 * (v - lo) / (hi - lo) - 1.0);
}

static double centre(float origin, float res, uint32_t i)
{
    return (double)origin + ((double)i + 0.5) * (double)res;
}

static int finite_f(float v)
{
    return isfinite(v) != 0;
}

int ai_belief_cfg_ok(const ai_belief_cfg_t *c)
{
    if (c == NULL)
        return 0;
    if (c->w < 1u || c->w > AI_BELIEF_MAX_W || c->h < 1u || c->h > AI_BELIEF_MAX_H)
        return 0;
    if (!finite_f(c->res_m) || !(c->res_m > 0.0f) || !finite_f(c->origin_x_m) || !finite_f(c->origin_y_m))
        return 0;
    if (!finite_f(c->min_x) || !finite_f(c->max_x) || !finite_f(c->min_y) || !finite_f(c->max_y) ||
        !(c->max_x > c->min_x) || !(c->max_y > c->min_y))
        return 0;
    /* The extreme centres bound every other one: all must stay finite model inputs (a huge
     * res or a tiny box would send +-inf into the SIREN layer, which refuses it). */
    const float corners[4] = {
        norm_coord(centre(c->origin_x_m, c->res_m, 0), c->min_x, c->max_x),
        norm_coord(centre(c->origin_x_m, c->res_m, c->w - 1u), c->min_x, c->max_x),
        norm_coord(centre(c->origin_y_m, c->res_m, 0), c->min_y, c->max_y),
        norm_coord(centre(c->origin_y_m, c->res_m, c->h - 1u), c->min_y, c->max_y),
    };
    for (int i = 0; i < 4; i++)
        if (!finite_f(corners[i]))
            return 0;
    return 1;
}

int ai_belief_init(ai_belief_t *b, const ai_belief_cfg_t *cfg)
{
    if (!b || !cfg || !ai_belief_cfg_ok(cfg))
        return -EINVAL;
    memset(b, 0, sizeof *b);
    b->cfg = *cfg;
    /* Before any update the grid says "no opinion, never seen": 128 is the occupancy of a
     * logit of 0, and 255 is what a fresh posterior gives everywhere. */
    memset(b->occ, 128, sizeof b->occ);
    memset(b->unknown, 255, sizeof b->unknown);
    memset(b->post_unknown, 255, sizeof b->post_unknown);
    b->unknown_mean = b->post_unknown_mean = 1.0;
    return 0;
}

/* round(255 v) of a share v, clamped to 0 .. 255; a NaN share (cannot come from a valid
 * posterior, whose shares are in (0, 1]) counts as nothing known. */
static uint8_t quant_share(double v)
{
    if (!(v >= 0.0))
        return v < 0.0 ? 0u : 255u;
    if (v >= 1.0)
        return 255u;
    return (uint8_t)lround(255.0 * v);
}

/* The information a look at the cell could still give, on the byte scale (ai_belief.h):
 * 0.5 log(1 + S u) nats for a read-out whose prior variance is S times the observation's, over
 * its largest, 0.5 log(1 + S). Shares far below 1/255 keep their order (a linear byte would
 * round every well-seen cell to 0 and drop the contrast that says where to look next). */
static uint8_t quant_info(double u)
{
    if (!(u >= 0.0))
        return u < 0.0 ? 0u : 255u;
    if (u >= 1.0)
        return 255u;
    return (uint8_t)lround(255.0 * log1p(AI_BELIEF_INFO_SNR * u) / log1p(AI_BELIEF_INFO_SNR));
}

/* sigmoid in double: exp of a large -logit saturates to inf and the share to 0, no NaN. */
static double sigmoid(double z)
{
    return z >= 0.0 ? 1.0 / (1.0 + exp(-z)) : exp(z) / (1.0 + exp(z));
}

int ai_belief_update(ai_belief_t *b, bnn_model_t *m, bnn_post_t *post, ai_seen_t *seen)
{
    if (!b || !m || !post || !ai_belief_cfg_ok(&b->cfg) || post->dim != m->cfg.siren_width + 1u ||
        (seen && (seen->cfg.w != b->cfg.w || seen->cfg.h != b->cfg.h)))
        return -EINVAL;
    const ai_belief_cfg_t *c = &b->cfg;
    const uint32_t n = c->w * c->h;
    b->valid = 0;
    b->unknown_mean = b->post_unknown_mean = 1.0;
    if (seen && ai_seen_flood(seen) != 0)
        return -EINVAL;
    /* The sum in double over at most 4096 floats in (0, 1] in cell order: exact enough, and
     * the same order every time, so the same bits. */
    double sum = 0.0, post_sum = 0.0;
    for (uint32_t i0 = 0; i0 < n; i0 += AI_BELIEF_BATCH) {
        const uint32_t nb = n - i0 < AI_BELIEF_BATCH ? n - i0 : AI_BELIEF_BATCH;
        for (uint32_t k = 0; k < nb; k++) {
            const uint32_t i = i0 + k, col = i % c->w, row = i / c->w;
            b->xy[2u * k] = norm_coord(centre(c->origin_x_m, c->res_m, col), c->min_x, c->max_x);
            b->xy[2u * k + 1u] = norm_coord(centre(c->origin_y_m, c->res_m, row), c->min_y, c->max_y);
        }
        const int rc = bnn_post_predict(post, m, b->xy, nb, b->logit, b->share);
        if (rc != 0)
            return rc;
        for (uint32_t k = 0; k < nb; k++) {
            /* A NaN logit means NaN weights: refuse rather than paint a plausible map. */
            if (isnan(b->logit[k]))
                return -EDOM;
            b->occ[i0 + k] = quant_share(sigmoid((double)b->logit[k]));
            /* whichever says more is left: the posterior, or the counts (ai_seen.h) */
            const double u_post = (double)b->share[k], u_seen = seen ? ai_seen_share(seen, i0 + k) : 0.0;
            const double u = u_post > u_seen ? u_post : u_seen;
            b->unknown[i0 + k] = quant_info(u);
            b->post_unknown[i0 + k] = quant_info(u_post);
            sum += u;
            post_sum += u_post;
        }
    }
    b->unknown_mean = sum / (double)n;
    b->post_unknown_mean = post_sum / (double)n;
    b->valid = 1;
    b->updates++;
    return 0;
}

int ai_belief_cell_xy(const ai_belief_t *b, uint32_t col, uint32_t row, float xy[2])
{
    if (!b || !xy || col >= b->cfg.w || row >= b->cfg.h)
        return -EINVAL;
    const ai_belief_cfg_t *c = &b->cfg;
    xy[0] = norm_coord(centre(c->origin_x_m, c->res_m, col), c->min_x, c->max_x);
    xy[1] = norm_coord(centre(c->origin_y_m, c->res_m, row), c->min_y, c->max_y);
    return 0;
}

double ai_belief_known_share(const ai_belief_t *b)
{
    if (!b)
        return -1.0;
    return b->valid ? b->unknown_mean : 1.0;
}

int ai_belief_to_goal_grid(const ai_belief_t *b, const gp_goal_cfg_t *gcfg, gp_goal_grid_t *g)
{
    if (!b || !gcfg || !g || !b->valid)
        return -EINVAL;
    /* gp_goal keeps its geometry in double; the belief's floats are what the cells were
     * evaluated at, so the goal's geometry must round to exactly them. */
    if (gcfg->w != b->cfg.w || gcfg->h != b->cfg.h || (float)gcfg->res_m != b->cfg.res_m ||
        (float)gcfg->origin_x_m != b->cfg.origin_x_m || (float)gcfg->origin_y_m != b->cfg.origin_y_m)
        return -EINVAL;
    const size_t n = (size_t)b->cfg.w * b->cfg.h;
    memcpy(g->occ, b->occ, n);
    memcpy(g->unknown, b->unknown, n);
    return 0;
}

int ai_belief_to_rt_grid(const ai_belief_t *b, uint8_t seen_max, rt_grid_t *g)
{
    if (!b || !g || !b->valid)
        return -EINVAL;
    const int rc = rt_grid_init(g, b->cfg.res_m, b->cfg.origin_x_m, b->cfg.origin_y_m, (int32_t)b->cfg.w,
                                (int32_t)b->cfg.h);
    if (rc != 0)
        return rc;
    const size_t n = (size_t)b->cfg.w * b->cfg.h;
    memcpy(g->occ, b->occ, n);
    /* rt counts observation up from 0 (0 = never observed), the belief counts what is left
     * down to 0: invert, and keep a barely seen cell unknown to the planner. */
    for (size_t i = 0; i < n; i++) {
        const uint8_t k = b->unknown[i];
        g->known[i] = k > seen_max ? 0u : (k == 255u ? 1u : (uint8_t)(255u - k));
    }
    return 0;
}
