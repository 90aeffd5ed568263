/* DiNNO node update: see dinno.h for the contract and the choice of weights and reductions.
 *
 * Why it is organised this way:
 * - Every regulariser is separable per element and its per-neighbour sums can be collected
 *   once per round (theta_i and the neighbour states do not change during the primal steps), so each
 *   primal step costs one pass over theta whatever the number of neighbours:
 *     L2:  sum_j ||t - mid_j||^2 = m ||t||^2 - 2 t . (sum_j mid_j) + sum_j ||mid_j||^2,
 *          gradient 2 (m t - sum_j mid_j);
 *     KL:  sum_j [log r_j - log s + s^2 / (2 r_j^2) - 1/2]
 *          = (sum_j log r_j) - m log s + (s^2 / 2) (sum_j 1/r_j^2) - m/2,
 *          d/drho = sigmoid(rho) * (-m / s + s * sum_j 1/r_j^2)   (s = softplus(rho)).
 *   aux1 holds sum_j mid_j (or sum_j 1/r_j^2 on the rho group for KL), aux2 sum_j log r_j.
 *   The other KL forms collect the same way, with c = sigmoid(rho) and Q = the per-element
 *   sum of r_j^2 (+ (m_j - mu)^2 for FULL):
 *     REVERSE/FULL: sum_j [log s - log r_j + q_j / (2 s^2) - 1/2], d/drho = c (m / s - Q / s^3);
 *     FULL's sum_j (m_j - mu)^2 = sum_j m_j^2 - 2 mu sum_j m_j + m mu^2, from aux3 (sum m_j^2)
 *     and the mu group's aux1 (sum m_j). aux1 then holds sum_j r_j^2 on the rho group.
 * - Sums are accumulated in the view's order (ascending id), so the result does not depend
 *   on timing. Neighbour states are only read (in place, where they arrived).
 * - Values use double accumulators (they are diagnostics and the finite-difference reference);
 *   gradients are float, elementwise.
 */
#include "ai/dinno.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "ai/ai_fastmath.h"
#include "ai/ai_rng.h"

#define DRAW_SALT 0xD1A0B47Cull  /* minibatch index stream */
#define NOISE_SALT 0xD1A0E95Eull /* BNN weight-noise keys */

dinno_cfg_t dinno_default_cfg(void)
{
    dinno_cfg_t c = {
        .strategy = DINNO_KL,
        .rho0 = 0.3f,
        .rho_scaling = 1.0004f,
        .primal_steps = 5,
        .lr_start = 1e-3f,
        .lr_end = 1e-4f,
        .total_rounds = 1000,
        .persistent_adam = 0,
        .w_mu = 1.0f,
        .w_rho = 1.0f,
        .kl_weight = 1e-4f,
        .batch = BNN_MAX_BATCH < 512u ? BNN_MAX_BATCH : 512u,
        .kl_form = DINNO_KL_OWN_MEAN,
        .kl_reduce = DINNO_REDUCE_SUM,
        .rho_pred_grad = 1,
        .screen_radius = DINNO_SCREEN_RADIUS_DEFAULT,
        .dual_rule = DINNO_DUAL_LINK,
        .rejoin_gap = DINNO_REJOIN_GAP_DEFAULT,
        .codec = DINNO_CODEC_FP32,
        .key_every = DINNO_KEY_EVERY_DEFAULT,
        .reg_values = 1,
    };
    return c;
}

size_t dinno_get_buffer_size(void)
{
    return DINNO_NODE_BYTES;
}

static int finite_pos(float v)
{
    return isfinite(v) && v > 0.0f;
}

static int cfg_ok(const dinno_cfg_t *c, const bnn_config_t *b)
{
    return (c->strategy == DINNO_UNIFORM || c->strategy == DINNO_SEPARATE || c->strategy == DINNO_KL) &&
           finite_pos(c->rho0) && finite_pos(c->rho_scaling) && c->primal_steps >= 1 &&
           c->primal_steps <= 100000u && finite_pos(c->lr_start) && finite_pos(c->lr_end) &&
           c->total_rounds >= 1 && (c->persistent_adam == 0 || c->persistent_adam == 1) &&
           isfinite(c->w_mu) && c->w_mu >= 0.0f && isfinite(c->w_rho) && c->w_rho >= 0.0f &&
           isfinite(c->kl_weight) && c->kl_weight >= 0.0f && c->batch >= 1 && c->batch <= b->max_batch &&
           (c->kl_form == DINNO_KL_OWN_MEAN || c->kl_form == DINNO_KL_REVERSE || c->kl_form == DINNO_KL_FULL) &&
           (c->kl_reduce == DINNO_REDUCE_SUM || c->kl_reduce == DINNO_REDUCE_MEAN) &&
           (c->rho_pred_grad == 0 || c->rho_pred_grad == 1) && isfinite(c->screen_radius) &&
           c->screen_radius >= 0.0f && (c->dual_rule == DINNO_DUAL_NODE || c->dual_rule == DINNO_DUAL_LINK) &&
           (unsigned)c->codec < DINNO_CODEC_COUNT && c->key_every >= 1 &&
           (c->reg_values == 0 || c->reg_values == 1);
}

int dinno_node_init(dinno_node_t *n, const dinno_cfg_t *cfg, const bnn_config_t *bcfg,
                    uint64_t model_seed, uint64_t seed, uint32_t id)
{
    if (!n)
        return -EINVAL;
    const dinno_cfg_t c = cfg ? *cfg : dinno_default_cfg();
    const bnn_config_t b = bcfg ? *bcfg : bnn_default_config();
    if (!cfg_ok(&c, &b))
        return -EINVAL;
    int rc = bnn_init(&n->model, &b, model_seed);
    if (rc)
        return rc;
    n->cfg = c;
    n->seed = seed;
    n->id = id;
    n->round = 0;
    n->n_nb = 0;
    n->mid_sq[0] = n->mid_sq[1] = 0.0;
    const size_t P = bnn_n_params(&n->model);
    memset(n->dual, 0, P * sizeof(float));
    memcpy(n->theta0, bnn_params(&n->model), P * sizeof(float));
    memset(n->aux1, 0, P * sizeof(float));
    memset(n->aux2, 0, n->model.n_rho * sizeof(float));
    memset(n->aux3, 0, n->model.n_rho * sizeof(float));
    n->nb = NULL;
    memset(n->use, 0, sizeof n->use);
    for (uint32_t l = 0; l < DINNO_MAX_PEERS; l++)
        n->link[l] = (dinno_link_t){DINNO_NO_PEER, DINNO_NO_ROUND, DINNO_NO_ROUND, 0, 0};
    n->pub_own_round = DINNO_NO_ROUND;
    memset(n->pub_own, 0, P * sizeof(float));
    return 0;
}

int dinno_node_set_nbrs(dinno_node_t *n, const dinno_nbrs_t *nb)
{
    if (!n || (nb && nb->count > DINNO_MAX_PEERS))
        return -EINVAL;
    const uint32_t m = nb ? nb->count : 0u;
    for (uint32_t s = 0; s < m; s++) {
        if (!nb->theta[s] || nb->id[s] == DINNO_NO_PEER)
            return -EINVAL;
        for (uint32_t t = 0; t < s; t++)
            if (nb->id[t] == nb->id[s])
                return -EINVAL; /* the links are keyed by the ids */
    }
    n->nb = m > 0 ? nb : NULL;
    memset(n->use, 0, sizeof n->use);
    memset(n->use, 1, m);
    for (uint32_t s = 0; s < m; s++) {
        n->src[s] = nb->theta[s];
        n->slot_link[s] = DINNO_MAX_PEERS;
    }
    return 0;
}

/* Neighbour s's state when it takes part in the round, else NULL. */
static const float *nb_in_use(const dinno_node_t *n, uint32_t s)
{
    return n->nb != NULL && s < n->nb->count && n->use[s] ? n->src[s] : NULL;
}

static int is_key_round(const dinno_cfg_t *c, uint32_t k)
{
    return k % c->key_every == 0;
}

int dinno_node_outgoing(dinno_node_t *n, float *out)
{
    if (n == NULL || out == NULL)
        return -EINVAL;
    const size_t P = bnn_n_params(&n->model);
    const float *th = bnn_params_const(&n->model);
    const uint32_t k = n->round;
    if (!dinno_codec_is_ef(n->cfg.codec)) {
        memcpy(out, th, P * sizeof(float));
        return 0;
    }
    if (n->pub_own_round == k)
        return -EALREADY; /* the copy moved on already: a second difference would not match it */
    const bnn_config_t *bc = &n->model.cfg;
    if (is_key_round(&n->cfg, k)) {
        memcpy(out, th, P * sizeof(float));
        int r = dinno_codec_channel(bc, n->cfg.codec, out, n->pub_own);
        if (r != 0)
            return r;
    } else {
        for (size_t i = 0; i < P; i++)
            out[i] = th[i] - n->pub_own[i];
        /* aux1 is scratch between rounds (dinno_prepare fills it afresh) */
        int r = dinno_codec_channel(bc, n->cfg.codec, out, n->aux1);
        if (r != 0)
            return r;
        for (size_t i = 0; i < P; i++)
            n->pub_own[i] += n->aux1[i];
    }
    n->pub_own_round = k;
    return 0;
}

/* The link of peer `id`, or DINNO_MAX_PEERS. */
static uint32_t find_link(const dinno_node_t *n, uint32_t id)
{
    for (uint32_t l = 0; l < DINNO_MAX_PEERS; l++)
        if (n->link[l].peer == id)
            return l;
    return DINNO_MAX_PEERS;
}

/* Forgets link l and gives it to (id, inc): out of the dual first when it is in it. */
static void reset_link(dinno_node_t *n, uint32_t l, uint32_t id, uint32_t inc)
{
    if (n->link[l].active) {
        const size_t P = bnn_n_params(&n->model);
        for (size_t i = 0; i < P; i++)
            n->dual[i] -= n->lambda[l][i];
    }
    n->link[l] = (dinno_link_t){id, DINNO_NO_ROUND, DINNO_NO_ROUND, 0, inc};
}

/* A slot for a new peer: a free one, else the one seen longest ago (never seen first) among those
   not mapped this round; there always is one, a round has at most DINNO_MAX_PEERS states. An
   evicted link still in the dual (LINK rule) is taken out of it first. */
static uint32_t new_link(dinno_node_t *n, const uint8_t *mapped, uint32_t id, uint32_t inc)
{
    uint32_t best = DINNO_MAX_PEERS;
    int64_t best_key = INT64_MAX;
    for (uint32_t l = 0; l < DINNO_MAX_PEERS; l++) {
        if (mapped[l])
            continue;
        const dinno_link_t *lk = &n->link[l];
        const int64_t key = lk->peer == DINNO_NO_PEER ? -2 : lk->seen == DINNO_NO_ROUND ? -1 : (int64_t)lk->seen;
        if (key < best_key) {
            best_key = key;
            best = l;
        }
    }
    if (best < DINNO_MAX_PEERS)
        reset_link(n, best, id, inc);
    return best;
}

/* Maps the view's slots to links (new peers get a slot) and, with an EF codec, turns each
   arrived difference into the peer's public copy; a difference without the copy it refines is
   left out (stale). Sets src[] and clears use[] of the stale. Returns how many were stale. */
static uint32_t receive_links(dinno_node_t *n, uint32_t k)
{
    uint8_t mapped[DINNO_MAX_PEERS] = {0};
    const uint32_t m = n->nb != NULL ? n->nb->count : 0u;
    for (uint32_t s = 0; s < m; s++) {
        const uint32_t l = find_link(n, n->nb->id[s]);
        n->slot_link[s] = (uint8_t)l;
        if (l < DINNO_MAX_PEERS) {
            mapped[l] = 1;
            if (n->link[l].inc != n->nb->inc[s]) /* restarted: nothing of the old one holds */
                reset_link(n, l, n->nb->id[s], n->nb->inc[s]);
        }
    }
    for (uint32_t s = 0; s < m; s++)
        if (n->slot_link[s] >= DINNO_MAX_PEERS) {
            const uint32_t l = new_link(n, mapped, n->nb->id[s], n->nb->inc[s]);
            n->slot_link[s] = (uint8_t)l;
            mapped[l] = 1;
        }
    const size_t P = bnn_n_params(&n->model);
    const int ef = dinno_codec_is_ef(n->cfg.codec);
    uint32_t stale = 0;
    for (uint32_t s = 0; s < m; s++) {
        const uint32_t l = n->slot_link[s];
        dinno_link_t *lk = &n->link[l];
        const float *in = n->nb->theta[s];
        n->src[s] = in;
        if (!ef)
            continue;
        float *pub = n->pub[l];
        if (is_key_round(&n->cfg, k)) {
            memcpy(pub, in, P * sizeof(float));
            lk->pub_round = k;
        } else if (lk->pub_round != DINNO_NO_ROUND && lk->pub_round + 1u == k) {
            for (size_t i = 0; i < P; i++)
                pub[i] += in[i];
            lk->pub_round = k;
        } else {
            n->use[s] = 0;
            stale++;
        }
        n->src[s] = pub;
    }
    return stale;
}

/* Before the dual update of round k: the links of the round in use take part, the others not.
   LINK rule (G = rejoin_gap): a link absent for G rounds (G = 0: at once) has its lambda taken
   out of the dual; one absent for fewer keeps it there, frozen, as a brief loss does not make
   a neighbour's dual out of date (taking it out and back every round at 50 % link success made
   the dual term flicker: 6x the consensus error of keeping it). A link back after G or more
   missed rounds (or new) starts at zero; with G = 0 it comes back with its lambda. Returns how
   many links came back after >= G missed rounds (G > 0). */
static uint32_t update_links(dinno_node_t *n, uint32_t k)
{
    const size_t P = bnn_n_params(&n->model);
    const int link_rule = n->cfg.dual_rule == DINNO_DUAL_LINK;
    uint8_t now[DINNO_MAX_PEERS] = {0};
    const uint32_t m = n->nb != NULL ? n->nb->count : 0u;
    for (uint32_t s = 0; s < m; s++)
        if (n->use[s])
            now[n->slot_link[s]] = 1;
    const uint32_t gap = n->cfg.rejoin_gap;
    for (uint32_t l = 0; l < DINNO_MAX_PEERS; l++)
        if (link_rule && n->link[l].active && !now[l] && (gap == 0 || k - n->link[l].seen >= gap)) {
            for (size_t i = 0; i < P; i++)
                n->dual[i] -= n->lambda[l][i];
            n->link[l].active = 0;
        }
    uint32_t rejoined = 0;
    for (uint32_t l = 0; l < DINNO_MAX_PEERS; l++) {
        if (!now[l])
            continue;
        dinno_link_t *lk = &n->link[l];
        const int known = lk->seen != DINNO_NO_ROUND && lk->seen < k;
        const uint32_t missed = known ? k - lk->seen - 1u : 0u;
        const int long_gone = known && n->cfg.rejoin_gap > 0 && missed >= n->cfg.rejoin_gap;
        rejoined += (uint32_t)long_gone;
        if (link_rule && !lk->active) {
            if (!known || long_gone)
                memset(n->lambda[l], 0, P * sizeof(float));
            else
                for (size_t i = 0; i < P; i++)
                    n->dual[i] += n->lambda[l][i];
            lk->active = 1;
        }
        lk->seen = k;
    }
    return rejoined;
}

/* Rejoin: theta and theta0 become the mean of the own round-start state and the states in use,
   summed in ascending robot id with the own at its place. */
static void step_to_mean(dinno_node_t *n, uint32_t m)
{
    const size_t P = bnn_n_params(&n->model);
    float *th = bnn_params(&n->model);
    const float inv = 1.0f / (float)(m + 1u);
    for (size_t i = 0; i < P; i++) {
        float sum = 0.0f;
        int own_done = 0;
        for (uint32_t s = 0; s < DINNO_MAX_PEERS; s++) {
            const float *tj = nb_in_use(n, s);
            if (!tj)
                continue;
            if (!own_done && n->nb->id[s] > n->id) {
                sum += n->theta0[i];
                own_done = 1;
            }
            sum += tj[i];
        }
        if (!own_done)
            sum += n->theta0[i];
        th[i] = sum * inv;
    }
    memcpy(n->theta0, th, P * sizeof(float));
}

float dinno_rho_at(const dinno_cfg_t *cfg, uint32_t k)
{
    return (float)((double)cfg->rho0 * pow((double)cfg->rho_scaling, (double)k));
}

float dinno_lr_at(const dinno_cfg_t *cfg, uint32_t k)
{
    if (cfg->total_rounds <= 1)
        return cfg->lr_start;
    const double t = (double)(k < cfg->total_rounds - 1 ? k : cfg->total_rounds - 1) /
                     (double)(cfg->total_rounds - 1);
    return (float)((double)cfg->lr_start * pow((double)cfg->lr_end / (double)cfg->lr_start, t));
}

uint32_t dinno_dual_update(dinno_node_t *n, float rho_k)
{
    const size_t P = bnn_n_params(&n->model);
    float *th = bnn_params(&n->model);
    memcpy(n->theta0, th, P * sizeof(float));
    /* Our state as the neighbours hold it: both ends of a link then add opposite terms. */
    const float *me = n->theta0;
    if (n->cfg.codec == DINNO_CODEC_INT8 && dinno_codec_channel(&n->model.cfg, n->cfg.codec, th, n->mine) == 0)
        me = n->mine;
    else if (dinno_codec_is_ef(n->cfg.codec) && n->pub_own_round == n->round)
        me = n->pub_own;
    const int link_rule = n->cfg.dual_rule == DINNO_DUAL_LINK;
    uint32_t m = 0;
    for (uint32_t s = 0; s < DINNO_MAX_PEERS; s++) {
        const float *tj = nb_in_use(n, s);
        if (!tj)
            continue;
        m++;
        for (size_t i = 0; i < P; i++)
            n->dual[i] += rho_k * (me[i] - tj[i]);
        if (link_rule && n->slot_link[s] < DINNO_MAX_PEERS) { /* mapped: inside dinno_node_round */
            float *lam = n->lambda[n->slot_link[s]];
            for (size_t i = 0; i < P; i++)
                lam[i] += rho_k * (me[i] - tj[i]);
        }
    }
    n->n_nb = m;
    return m;
}

static float sigmoidf_(float r)
{
    if (r >= 0.0f)
        return 1.0f / (1.0f + expf(-r));
    const float e = expf(r);
    return e / (1.0f + e);
}

/* rho entries per block of the loops over the rho group (a 256-byte array on the AI core's
   stack, small enough for the Cortex-M boards): 4 AVX-512 vectors of 16 */
#define RHO_BLOCK 64u

void dinno_prepare(dinno_node_t *n)
{
    const size_t P = bnn_n_params(&n->model), M = n->model.n_mu, R = n->model.n_rho;
    const int kl = n->cfg.strategy == DINNO_KL;
    const dinno_kl_form_t form = n->cfg.kl_form;
    const int values = n->cfg.reg_values; /* mid_sq and aux2 serve the reported values only */
    const size_t mu0 = R ? bnn_rho_to_mu(&n->model, 0) : 0; /* rho e pairs with mean mu0 + e */
    memset(n->aux1, 0, P * sizeof(float));
    memset(n->aux2, 0, R * sizeof(float));
    memset(n->aux3, 0, R * sizeof(float));
    double sq[2] = {0.0, 0.0};
    for (uint32_t s = 0; s < DINNO_MAX_PEERS; s++) {
        const float *tj = nb_in_use(n, s);
        if (!tj)
            continue;
        /* One loop per group with its own accumulator: clang 14 vectorised the former
           single loop's `sq[i < M ? 0 : 1] +=` wrongly (AVX2 and AVX-512 builds lost terms).
           Same summation order as before, so GCC's results are unchanged. */
        for (size_t i = 0; i < M; i++) {
            const float mid = 0.5f * (n->theta0[i] + tj[i]);
            n->aux1[i] += mid;
            if (values) /* a chain of dependent adds: without it the loop vectorises */
                sq[0] += (double)mid * mid;
        }
        for (size_t i = M; !kl && i < P; i++) {
            const float mid = 0.5f * (n->theta0[i] + tj[i]);
            n->aux1[i] += mid;
            if (values)
                sq[1] += (double)mid * mid;
        }
        /* The rho group a block at a time: the softplus in a loop of its own, which vectorises,
           and libm's logf (scalar) after it; the same operations per element as one loop. */
        for (size_t e0 = 0; kl && e0 < R; e0 += RHO_BLOCK) {
            float sp[RHO_BLOCK];
            const size_t ne = R - e0 < RHO_BLOCK ? R - e0 : RHO_BLOCK;
            const float *t0 = n->theta0 + M + e0, *t1 = tj + M + e0;
            for (size_t e = 0; e < ne; e++)
                sp[e] = ai_fm_softplusf(0.5f * (t0[e] + t1[e]));
            float *a1 = n->aux1 + M + e0, *a2 = n->aux2 + e0;
            if (form == DINNO_KL_OWN_MEAN) {
                for (size_t e = 0; e < ne; e++)
                    a1[e] += 1.0f / (sp[e] * sp[e]);
            } else {
                const float *m0 = n->theta0 + mu0 + e0, *m1 = tj + mu0 + e0;
                float *a3 = n->aux3 + e0;
                for (size_t e = 0; e < ne; e++) {
                    const float mj = 0.5f * (m0[e] + m1[e]);
                    a1[e] += sp[e] * sp[e];
                    a3[e] += mj * mj;
                }
            }
            for (size_t e = 0; values && e < ne; e++)
                a2[e] += logf(sp[e]);
        }
    }
    n->mid_sq[0] = sq[0];
    n->mid_sq[1] = sq[1];
}

/* Weights of the mu and rho regularisers for the strategy (before rho_k). */
static void weights(const dinno_node_t *n, float *wm, float *wr)
{
    if (n->cfg.strategy == DINNO_UNIFORM) {
        *wm = 1.0f;
        *wr = 1.0f;
    } else {
        *wm = n->cfg.w_mu;
        *wr = n->cfg.w_rho;
    }
}

/* sp[i] = softplus(rho[i]) for the next min(left, RHO_BLOCK) entries: a loop of its own,
   which vectorises, where the loop that uses them calls libm (sigmoidf_, log) and does not. */
static void softplus_block(const float *rho, size_t left, float *sp)
{
    const size_t ne = left < RHO_BLOCK ? left : RHO_BLOCK;
    for (size_t i = 0; i < ne; i++)
        sp[i] = ai_fm_softplusf(rho[i]);
}

void dinno_add_reg_grad(dinno_node_t *n, float rho_k, float *reg_mu, float *reg_rho, float *dual_dot)
{
    const size_t P = bnn_n_params(&n->model), M = n->model.n_mu, R = n->model.n_rho;
    const float *th = bnn_params(&n->model);
    float *g = bnn_grads(&n->model);
    const float m = (float)n->n_nb;
    float wm, wr;
    weights(n, &wm, &wr);
    const float cm = 2.0f * rho_k * wm, cr = 2.0f * rho_k * wr;
    /* The values (reg_mu, reg_rho, dual_dot) are chains of dependent double adds and a log per
       rho entry; without them (cfg.reg_values 0) the gradient loops vectorise. */
    const int values = n->cfg.reg_values;
    double dd = 0.0, tsq = 0.0, tdot = 0.0;
    for (size_t i = 0; i < M; i++) {
        const float t = th[i];
        g[i] += n->dual[i] + cm * (m * t - n->aux1[i]);
        if (values) {
            dd += (double)t * n->dual[i];
            tsq += (double)t * t;
            tdot += (double)t * n->aux1[i];
        }
    }
    const double rmu = (double)m * tsq - 2.0 * tdot + n->mid_sq[0];
    double rr = 0.0;
    if (n->cfg.strategy == DINNO_KL && n->cfg.kl_form != DINNO_KL_OWN_MEAN) {
        const int full = n->cfg.kl_form == DINNO_KL_FULL;
        const size_t mu0 = bnn_rho_to_mu(&n->model, 0);
        const double red = n->cfg.kl_reduce == DINNO_REDUCE_MEAN ? 1.0 / (double)R : 1.0;
        const float kr = (float)((double)rho_k * wr * red);
        float sp[RHO_BLOCK];
        for (size_t e = 0; e < R; e++) {
            if (e % RHO_BLOCK == 0)
                softplus_block(th + M + e, R - e, sp);
            const float r = th[M + e];
            const double s = sp[e % RHO_BLOCK], s2 = s * s;
            double q = n->aux1[M + e];
            if (full) {
                const double mu = th[mu0 + e];
                const double dm = (double)n->aux3[e] - 2.0 * mu * n->aux1[mu0 + e] + (double)m * mu * mu;
                q += dm > 0.0 ? dm : 0.0; /* a sum of squares; cancellation must not make it negative */
            }
            g[M + e] += n->dual[M + e] + kr * sigmoidf_(r) * (float)((double)m / s - q / (s2 * s));
            if (values) {
                dd += (double)r * n->dual[M + e];
                rr += (double)m * log(s) - (double)n->aux2[e] + 0.5 * q / s2 - 0.5 * m;
            }
        }
        rr *= red;
    } else if (n->cfg.strategy == DINNO_KL) {
        const double red = n->cfg.kl_reduce == DINNO_REDUCE_MEAN ? 1.0 / (double)R : 1.0;
        const float kr = n->cfg.kl_reduce == DINNO_REDUCE_MEAN ? (float)((double)rho_k * wr * red) : rho_k * wr;
        float sp[RHO_BLOCK];
        for (size_t e = 0; e < R; e++) {
            if (e % RHO_BLOCK == 0)
                softplus_block(th + M + e, R - e, sp);
            const float r = th[M + e];
            const float s = sp[e % RHO_BLOCK], inv2 = n->aux1[M + e];
            g[M + e] += n->dual[M + e] + kr * sigmoidf_(r) * (s * inv2 - m / s);
            if (values) {
                dd += (double)r * n->dual[M + e];
                rr += (double)n->aux2[e] - (double)m * log((double)s) + 0.5 * (double)s * s * inv2 - 0.5 * m;
            }
        }
        rr *= red;
    } else {
        tsq = tdot = 0.0;
        for (size_t i = M; i < P; i++) {
            const float t = th[i];
            g[i] += n->dual[i] + cr * (m * t - n->aux1[i]);
            if (values) {
                dd += (double)t * n->dual[i];
                tsq += (double)t * t;
                tdot += (double)t * n->aux1[i];
            }
        }
        rr = (double)m * tsq - 2.0 * tdot + n->mid_sq[1];
    }
    if (reg_mu)
        *reg_mu = values ? (float)rmu : NAN;
    if (reg_rho)
        *reg_rho = values ? (float)rr : NAN;
    if (dual_dot)
        *dual_dot = values ? (float)dd : NAN;
}

double dinno_reg_value(const dinno_node_t *n, float rho_k)
{
    const size_t P = bnn_n_params(&n->model), M = n->model.n_mu, R = n->model.n_rho;
    const float *th = bnn_params_const(&n->model);
    float wm, wr;
    weights(n, &wm, &wr);
    double dd = 0.0, l2mu = 0.0, l2rho = 0.0, kl = 0.0;
    for (size_t i = 0; i < P; i++)
        dd += (double)th[i] * n->dual[i];
    /* Direct per-neighbour evaluation (independent of the aux sums), in double. */
    for (uint32_t s = 0; s < DINNO_MAX_PEERS; s++) {
        const float *tj = nb_in_use(n, s);
        if (!tj)
            continue;
        for (size_t i = 0; i < P; i++) {
            const double mid = 0.5 * ((double)n->theta0[i] + tj[i]);
            const double d = (double)th[i] - mid;
            if (i < M)
                l2mu += d * d;
            else
                l2rho += d * d;
        }
        const size_t mu0 = bnn_rho_to_mu(&n->model, 0);
        for (size_t e = 0; e < R; e++) {
            const double r = log1p(exp(0.5 * ((double)n->theta0[M + e] + tj[M + e])));
            const double sg = log1p(exp((double)th[M + e]));
            const double mj = 0.5 * ((double)n->theta0[mu0 + e] + tj[mu0 + e]);
            const double dm = mj - (double)th[mu0 + e];
            switch (n->cfg.kl_form) {
            case DINNO_KL_OWN_MEAN:
                kl += log(r / sg) + sg * sg / (2.0 * r * r) - 0.5;
                break;
            case DINNO_KL_REVERSE:
                kl += log(sg / r) + r * r / (2.0 * sg * sg) - 0.5;
                break;
            case DINNO_KL_FULL:
                kl += log(sg / r) + (r * r + dm * dm) / (2.0 * sg * sg) - 0.5;
                break;
            }
        }
    }
    if (n->cfg.kl_reduce == DINNO_REDUCE_MEAN && R > 0)
        kl /= (double)R;
    const double rhoterm = n->cfg.strategy == DINNO_KL ? kl : l2rho;
    return dd + (double)rho_k * ((double)wm * l2mu + (double)wr * rhoterm);
}

/* ||a - b||^2 in double, in eight partial sums added at the end: lanes a vector unit keeps
   apart, where one running sum is a chain of dependent adds the compiler may not reorder
   (a 64-robot fleet spent 5 % of its CPU here, once per neighbour and round). */
static double dist2(const float *a, const float *b, size_t n)
{
    enum { LANES = 8 };
    double part[LANES] = {0.0};
    size_t e = 0;
    for (; e + LANES <= n; e += LANES)
        for (size_t l = 0; l < LANES; l++) {
            const double d = (double)a[e + l] - (double)b[e + l];
            part[l] += d * d;
        }
    double sum = 0.0;
    for (; e < n; e++) {
        const double d = (double)a[e] - (double)b[e];
        sum += d * d;
    }
    for (size_t l = 0; l < LANES; l++)
        sum += part[l];
    return sum;
}

uint32_t dinno_screen_slots(dinno_node_t *n, float *dist_max)
{
    const size_t P = bnn_n_params(&n->model);
    const float *th = bnn_params_const(&n->model);
    double own = 0.0;
    for (size_t e = 0; e < P; e++)
        own += (double)th[e] * (double)th[e];
    const double scale = sqrt(own) > 1.0 ? sqrt(own) : 1.0;
    const double radius = (double)n->cfg.screen_radius * scale;
    uint32_t out = 0;
    double worst = 0.0;
    for (uint32_t s = 0; s < DINNO_MAX_PEERS; s++) {
        const float *nb = nb_in_use(n, s);
        if (!nb)
            continue;
        const double d2 = dist2(nb, th, P); /* a NaN or inf element makes the sum non-finite */
        const double dist = isfinite(d2) ? sqrt(d2) / scale : INFINITY;
        worst = dist > worst ? dist : worst;
        if (!isfinite(d2) || (n->cfg.screen_radius > 0.0f && sqrt(d2) > radius)) {
            n->use[s] = 0; /* the node's own mask: the state itself is not ours to write */
            out++;
        }
    }
    if (dist_max != NULL)
        *dist_max = (float)worst;
    return out;
}

int dinno_node_round(dinno_node_t *n, const ai_sample_t *data, size_t n_data, dinno_round_stats_t *stats)
{
    if (!n || !data || n_data == 0)
        return -EINVAL;
    const uint32_t k = n->round;
    if (n->nb != NULL && n->nb->count > 0 && n->nb->round != k)
        return -EINVAL;
    const dinno_cfg_t *c = &n->cfg;
    const float rho_k = dinno_rho_at(c, k), lr = dinno_lr_at(c, k);
    float dist_max = 0.0f;
    const uint32_t stale = receive_links(n, k);
    const uint32_t excluded = dinno_screen_slots(n, &dist_max);
    const uint32_t rejoined = update_links(n, k);
    const uint32_t m = dinno_dual_update(n, rho_k);
    if (m > 0 && rejoined > 0)
        step_to_mean(n, m);
    if (m > 0)
        dinno_prepare(n);
    if (!c->persistent_adam) {
        bnn_adam_reset(&n->model, BNN_GROUP_MU);
        bnn_adam_reset(&n->model, BNN_GROUP_RHO);
    }
    const uint64_t draw_key = ai_rng_mix64(n->seed ^ DRAW_SALT);
    const uint64_t noise_base = ai_rng_mix64(n->seed ^ NOISE_SALT);
    const size_t nb = n_data <= c->batch ? n_data : c->batch;
    double acc[6] = {0};
    for (uint32_t b = 0; b < c->primal_steps; b++) {
        const uint64_t step = (uint64_t)k * c->primal_steps + b;
        const ai_sample_t *batch = data;
        if (n_data > c->batch) {
            ai_rng_uniform_fill(draw_key, 0, step * c->batch, n->draw, nb);
            for (size_t i = 0; i < nb; i++) {
                size_t idx = (size_t)((double)n->draw[i] * (double)n_data);
                n->batch[i] = data[idx < n_data ? idx : n_data - 1];
            }
            batch = n->batch;
        }
        bnn_loss_t loss;
        int rc = bnn_loss_grad(&n->model, batch, nb, c->kl_weight, noise_base + step, &loss);
        if (rc)
            return rc;
        if (!c->rho_pred_grad && c->strategy != DINNO_UNIFORM) /* Algorithm 2 read literally */
            memset(bnn_grads(&n->model) + n->model.n_mu, 0, n->model.n_rho * sizeof(float));
        float rm = 0.0f, rr = 0.0f, dd = 0.0f;
        if (m > 0)
            dinno_add_reg_grad(n, rho_k, &rm, &rr, &dd);
        rc = bnn_adam_step(&n->model, BNN_GROUP_MU, lr);
        if (!rc)
            rc = bnn_adam_step(&n->model, BNN_GROUP_RHO, lr);
        if (rc)
            return rc;
        acc[0] += loss.total;
        acc[1] += loss.bce;
        acc[2] += loss.kl;
        acc[3] += rm;
        acc[4] += rr;
        acc[5] += dd;
    }
    n->round = k + 1;
    if (stats) {
        const double B = (double)c->primal_steps;
        stats->round = k;
        stats->neighbours = m;
        stats->rho_k = rho_k;
        stats->lr = lr;
        stats->pred_total = (float)(acc[0] / B);
        stats->bce = (float)(acc[1] / B);
        stats->kl_prior = (float)(acc[2] / B);
        stats->reg_mu = (float)(acc[3] / B);
        stats->reg_rho = (float)(acc[4] / B);
        stats->dual_dot = (float)(acc[5] / B);
        stats->excluded = excluded;
        stats->nb_dist_max = dist_max;
        stats->rejoined = rejoined;
        stats->stale = stale;
    }
    return 0;
}
