/* The AI core loop: see ai_core.h. */
#include "ai/ai_core.h"

#include <inttypes.h>
#include <math.h>
#include <string.h>

#include "ai/ai_rng.h"
#include "ai/bnn_ckpt.h"
#include "hal/hal.h"

_Static_assert(AI_CORE_BYTES + AI_LINK_BYTES <= BOARD_RAM_AI_BYTES,
               "AI core (DiNNO node, pool, batch) and its links exceed the board's AI RAM");

ai_core_cfg_t ai_core_default_cfg(void)
{
    ai_core_cfg_t c;
    memset(&c, 0, sizeof c);
    c.rounds = 8;
    c.rounds_per_boundary = 1;
    c.policy = AI_POOL_CDR;
    c.dinno = dinno_default_cfg();
    c.model_seed = 1;
    c.seed = 1;
    return c;
}

/* A resumed run: theta from the checkpoint (the duals stay at the zero dinno_node_init gave
 * them, the Adam state is reset by the load), and the node's round counter at start_round,
 * because it keys the learning rate, rho_k, the minibatches and the noise of every round. */
static int resume_node(ai_core_t *ai, const ai_core_cfg_t *cfg)
{
    if (cfg->resume_ckpt != NULL) {
        int r = bnn_ckpt_load(&ai->node.model, cfg->resume_ckpt, cfg->resume_ckpt_bytes, NULL);
        if (r != 0)
            return r;
        memcpy(ai->node.theta0, bnn_params_const(&ai->node.model),
               sizeof(float) * bnn_n_params(&ai->node.model));
    }
    ai->node.round = cfg->start_round;
    return 0;
}

int ai_core_init(ai_core_t *ai, const ai_core_cfg_t *cfg, const fw_link_t *link)
{
    if (ai == NULL || cfg == NULL || link == NULL || cfg->rounds < 1 ||
        cfg->rounds > AI_CORE_MAX_ROUNDS || cfg->train_between < 0 || cfg->train_between > 1 ||
        cfg->offline < 0 || cfg->offline > 1 || cfg->post_rounds > AI_CORE_MAX_POST_ROUNDS ||
        cfg->start_round >= cfg->rounds + cfg->post_rounds || (cfg->post_rounds > 0 && cfg->fleet_size < 1) ||
        (cfg->resume_ckpt == NULL && cfg->resume_ckpt_bytes != 0) ||
        (cfg->rounds_per_boundary > 0 && cfg->rounds % cfg->rounds_per_boundary != 0) ||
        (cfg->explore_budget_us > 0 && (cfg->belief == NULL || cfg->belief_period_us == 0 || cfg->offline)) ||
        cfg->explore_share_post < 0 || cfg->explore_share_post > 1 || cfg->explore_counts < 0 ||
        cfg->explore_counts > 1 || (cfg->explore_counts && cfg->explore_budget_us == 0) ||
        (cfg->explore_share_post && (cfg->explore_budget_us == 0 || cfg->fleet_size < 1)))
        return -EINVAL;
    /* The big members are left as they are: dinno_node_init and the pool set what they use. */
    ai->cfg = *cfg;
    if (ai->cfg.rounds_per_boundary == 0)
        ai->cfg.rounds_per_boundary = 1;
    ai->cfg.dinno.total_rounds = cfg->rounds;
    ai->cfg.dinno.reg_values = 0; /* the image reports no regulariser values: their sums and logs
                                     cost a 64-robot fleet 10 % of its CPU, for the same models */
    ai->cfg.resume_ckpt = NULL; /* read below, never kept: the caller's buffer may go away */
    ai->cfg.resume_ckpt_bytes = 0;
    ai->link = link;
    ai->phase = AI_PHASE_COLLECT;
    ai->next_round = cfg->start_round;
    memset(&ai->rt, 0, sizeof ai->rt);
    memset(&ai->status, 0, sizeof ai->status);
    memset(&ai->pending, 0, sizeof ai->pending);
    ai->ticks = 0;
    ai->empty_rounds = 0;
    int r = dinno_node_init(&ai->node, &ai->cfg.dinno, NULL, cfg->model_seed, cfg->seed,
                            cfg->node_id);
    if (r == 0) /* over the initial SIREN layer, the fleet's common one (bnn_post.h) */
        r = bnn_post_init(&ai->post, &ai->node.model);
    ai->post_staged = 0;
    ai->post_fleet = 0;
    if (r == 0)
        r = resume_node(ai, cfg);
    if (r == 0 && cfg->explore_budget_us > 0) {
        ai->belief_cfg = *cfg->belief;
        ai->cfg.belief = &ai->belief_cfg;
        r = ai_belief_init(&ai->belief, &ai->belief_cfg);
        if (r == 0)
            r = ai_seen_init(&ai->seen, &ai->belief_cfg);
        /* without explore_counts the counts give the fallback layer: the unreached cells only */
        ai->seen.unreached_only = !cfg->explore_counts;
        ai->seen_shared = cfg->explore_share_post &&
                          BNN_POST_STATE_FLOATS(ai->post.dim) + AI_SEEN_STATE_FLOATS(cfg->belief->w * cfg->belief->h) <=
                              bnn_n_params(&ai->node.model);
    }
    ai->belief_next_us = 0;
    ai->belief_errors = 0;
    if (r != 0)
        return r;
    if (cfg->pool_samples > AI_POOL_CAPACITY)
        return -EINVAL;
    const uint32_t capacity = cfg->pool_samples != 0 ? cfg->pool_samples : AI_POOL_CAPACITY;
    r = ai_pool_init(&ai->pool, ai->pool_data, capacity, cfg->policy,
                     ai_rng_mix64(cfg->seed ^ 0x504F4F4C53454544ull));
    if (r != 0)
        return r;
    ai->status.round = cfg->start_round;
    ai->status.rounds_total = cfg->rounds;
    ai->status.pool_capacity = capacity;
    ai->status.loss_train = NAN;
    return 0;
}

static int observe_staged(ai_core_t *ai);

static uint32_t total_rounds(const ai_core_t *ai) /* DiNNO rounds, then the posterior's */
{
    return ai->cfg.rounds + ai->cfg.post_rounds;
}

/* Round k's state is the posterior: after the DiNNO rounds, or every odd round while a fleet
   explores with a shared posterior (ai_core.h). */
static int is_post_round(const ai_core_t *ai, uint32_t k)
{
    return k >= ai->cfg.rounds || (ai->cfg.explore_share_post && (k & 1u) != 0u);
}

static uint32_t rounds_due(const ai_core_t *ai)
{
    const uint32_t R = ai->cfg.rounds_per_boundary;
    const uint32_t C = ai->cfg.rounds / R; /* boundaries */
    if (ai->rt.finished)
        return total_rounds(ai);
    double f;
    if (ai->cfg.explore_budget_us > 0)
        f = (double)ai->rt.stamp_us / (double)ai->cfg.explore_budget_us * (double)C;
    else if (ai->cfg.offline || !(ai->rt.path_length_m > 0.0f))
        return 0;
    else
        f = (double)ai->rt.progress_m / (double)ai->rt.path_length_m * (double)C;
    uint32_t due = f >= (double)C ? C : (uint32_t)f;
    return due >= C ? total_rounds(ai) : due * R;
}

/* One optimiser step between boundaries on a minibatch drawn uniformly from the pool. */
static int train_between(ai_core_t *ai)
{
    const uint32_t B = ai->cfg.dinno.batch;
    const uint32_t fill = ai->pool.fill;
    const uint64_t step = ai->status.between_steps;
    size_t n;
    if (fill <= B) {
        n = fill;
        memcpy(ai->batch, ai->pool.data, sizeof(ai_sample_t) * n);
    } else {
        n = B;
        for (uint32_t i = 0; i < B; i += 4) {
            uint32_t key[2] = {(uint32_t)ai->cfg.seed, (uint32_t)(ai->cfg.seed >> 32) ^ 0x42455457u};
            uint32_t ctr[4] = {i, (uint32_t)step, (uint32_t)(step >> 32), 0x54524E42u};
            uint32_t out[4];
            ai_rng_philox4x32(key, ctr, out);
            for (uint32_t q = 0; q < 4 && i + q < B; q++)
                ai->batch[i + q] = ai->pool.data[out[q] % fill];
        }
    }
    float lr = dinno_lr_at(&ai->cfg.dinno, ai->next_round);
    uint64_t noise = ai_rng_mix64(ai->cfg.seed ^ 0x4245545745454E00ull ^ step);
    int r = bnn_train_step(&ai->node.model, ai->batch, n, ai->cfg.dinno.kl_weight, noise, lr, NULL);
    if (r == 0)
        ai->status.between_steps++;
    return r;
}

static void publish_state(ai_core_t *ai, uint64_t now_us)
{
    const uint32_t k = ai->next_round;
    ai_state_msg_t *st = mbox_write_buffer(ai->link->ai_state);
    st->round = k;
    st->n_params = (uint32_t)bnn_n_params(&ai->node.model);
    if (!is_post_round(ai, k)) {
        /* theta, or with an EF codec the difference against our public copy (dinno.h) */
        if (dinno_node_outgoing(&ai->node, st->theta) != 0) {
            hal_log(HAL_LOG_WARN, "round %" PRIu32 ": no state to send", k);
            memset(st->theta, 0, sizeof(float) * st->n_params); /* refused by every neighbour */
        }
    } else { /* a posterior round: the estimate of the fleet's posterior is the state */
        if (!ai->post_fleet) { /* the first this run: N times its own (ai_core.h) */
            if (observe_staged(ai) != 0 || bnn_post_scale(&ai->post, (double)ai->cfg.fleet_size) != 0 ||
                (ai->seen_shared && ai_seen_scale(&ai->seen, (double)ai->cfg.fleet_size) != 0))
                hal_log(HAL_LOG_WARN, "round %" PRIu32 ": the posterior could not be made the fleet's estimate", k);
            ai->post_fleet = 1;
        }
        const size_t off = BNN_POST_STATE_FLOATS(ai->post.dim);
        if (bnn_post_to_state(&ai->post, st->theta, st->n_params) != 0 ||
            (ai->seen_shared && ai_seen_to_state(&ai->seen, st->theta + off, st->n_params - off) != 0))
            memset(st->theta, 0, sizeof(float) * st->n_params); /* refused by every neighbour */
    }
    (void)mbox_publish(ai->link->ai_state);
    ai_round_info_t *p = &ai->pending;
    memset(p, 0, sizeof *p);
    p->round = k;
    p->stamp_us = now_us;
    p->progress_m = ai->rt.progress_m;
    p->distance_m = ai->rt.distance_m;
    p->ring_drops = ai->rt.ring_drops;
    ai->phase = AI_PHASE_WAIT_SLOTS;
}

/* The staged samples' points into the posterior (a chunk at a time: one GEMM, not a rank-1
 * update per sample). The arena's activations are scratch between training steps. */
static int observe_staged(ai_core_t *ai)
{
    const double w = ai->post_fleet ? (double)ai->cfg.fleet_size : 1.0; /* N: the fleet's estimate */
    const int rc = bnn_post_observe_weighted(&ai->post, &ai->node.model, ai->post_xy, ai->post_staged, w);
    ai->post_staged = 0;
    return rc;
}

/* Posterior round k: the neighbours' estimates mixed into ours (weights 1/N). */
static int post_round(ai_core_t *ai, const gp_ready_t *ready)
{
    const uint32_t k = ai->next_round;
    const dinno_nbrs_t *nbrs = ai->link->nbrs;
    const int have = ready->neighbours > 0 && nbrs->count > 0 && nbrs->round == k;
    uint32_t used = 0;
    const int rc = bnn_post_mix(&ai->post, have ? nbrs->theta : NULL, have ? nbrs->count : 0,
                                bnn_n_params(&ai->node.model), 1.0 / (double)ai->cfg.fleet_size, &used);
    if (have && used < nbrs->count)
        hal_log(HAL_LOG_WARN, "posterior round %" PRIu32 ": %" PRIu32 " of %" PRIu32 " neighbour posteriors left out "
                "(other features or bad values)", k, nbrs->count - used, nbrs->count);
    if (ai->seen_shared) { /* exploring: the counts of what was covered too */
        const size_t off = BNN_POST_STATE_FLOATS(ai->post.dim), cap = bnn_n_params(&ai->node.model);
        uint32_t used_seen = 0;
        if (ai_seen_mix(&ai->seen, have ? nbrs->theta : NULL, have ? nbrs->count : 0, off, cap,
                        1.0 / (double)ai->cfg.fleet_size, &used_seen) != 0 ||
            used_seen != used)
            hal_log(HAL_LOG_WARN, "posterior round %" PRIu32 ": %" PRIu32 " of %" PRIu32 " neighbour count grids mixed "
                    "in, %" PRIu32 " posteriors", k, used_seen, have ? nbrs->count : 0u, used);
    }
    ai_round_info_t *p = &ai->pending;
    p->neighbours = used;
    p->loss_train = p->bce = NAN;
    p->kl = (float)bnn_kl_loss(&ai->node.model);
    return rc;
}

static int run_round(ai_core_t *ai, const gp_ready_t *ready)
{
    const uint32_t k = ai->next_round;
    ai_round_info_t *p = &ai->pending;
    int rc = 0;
    p->pool_fill = ai->pool.fill;
    p->pool_capacity = ai->pool.capacity;
    p->pool_offered = ai->pool.offered;
    if (is_post_round(ai, k)) {
        rc = post_round(ai, ready);
        goto publish;
    }
    /* The neighbour states are read where the GP core left them (fw_link.h: ours from ready(k)
       until our next state publish), never copied. */
    const dinno_nbrs_t *nbrs = ai->link->nbrs;
    const int have_nbrs = ready->neighbours > 0 && nbrs->count > 0 && nbrs->round == k;
    int r0 = dinno_node_set_nbrs(&ai->node, have_nbrs ? nbrs : NULL);
    if (r0 != 0) { /* a malformed view: the round goes on alone, and says so */
        rc = r0;
        r0 = dinno_node_set_nbrs(&ai->node, NULL);
    }
    if (ai->pool.fill > 0) {
        dinno_round_stats_t st;
        int r = dinno_node_round(&ai->node, ai->pool.data, ai->pool.fill, &st);
        if (r == 0 && st.excluded > 0) {
            /* The screen left states out (dinno.h): say whose, each time; a bad member is news. */
            for (uint32_t s = 0; have_nbrs && s < nbrs->count; s++)
                if (!ai->node.use[s])
                    hal_log(HAL_LOG_WARN, "round %" PRIu32 ": robot %" PRIu32 "'s state left out (not finite, or "
                            "beyond %g x ||own state||; largest distance %g)", k, nbrs->id[s],
                            (double)ai->cfg.dinno.screen_radius, (double)st.nb_dist_max);
            ai->status.states_excluded += st.excluded;
        }
        if (r == 0) {
            if (st.rejoined > 0) /* a partition healed, a robot came back: say that the models met */
                hal_log(HAL_LOG_INFO, "round %" PRIu32 ": %" PRIu32 " neighbour(s) back after %" PRIu32
                        " or more missed rounds: stepped to the mean of the round's states",
                        k, st.rejoined, ai->cfg.dinno.rejoin_gap);
            ai->status.links_rejoined += st.rejoined;
            ai->status.states_stale += st.stale;
        }
        if (r == 0) {
            p->excluded = st.excluded;
            p->neighbours = st.neighbours;
            p->steps = ai->cfg.dinno.primal_steps;
            p->loss_train = st.pred_total;
            p->bce = st.bce;
            p->kl = st.kl_prior;
            p->lr = st.lr;
            p->rho_k = st.rho_k;
        } else {
            rc = r;
        }
    } else {
        ai->empty_rounds++;
        p->loss_train = p->bce = NAN;
        p->kl = (float)bnn_kl_loss(&ai->node.model);
        hal_log(HAL_LOG_WARN, "round %" PRIu32 ": empty pool, no update", k);
    }
    if (rc != 0) {
        p->loss_train = p->bce = NAN;
        p->steps = 0;
    }
publish:;
    ai_ckpt_msg_t *msg = mbox_write_buffer(ai->link->ai_ckpt);
    msg->info = *p;
    msg->flags = k + 1u == total_rounds(ai) ? AI_CKPT_FLAG_FINAL : 0u;
    size_t written = 0;
    /* every checkpoint carries what the robot has observed so far: online, an early round's
       map shows the building as far as the robot had seen it then */
    const bnn_post_t *post = &ai->post;
    const int rp = observe_staged(ai);
    if (rp != 0) {
        post = NULL;
        hal_log(HAL_LOG_WARN, "round %" PRIu32 ": no epistemic posterior (%d)", k, rp);
    }
    int r = bnn_ckpt_save_post(&ai->node.model, 0, post, msg->bytes, sizeof msg->bytes, &written);
    msg->n_bytes = r == 0 ? (uint32_t)written : 0u;
    if (r != 0)
        rc = r;
    (void)mbox_publish(ai->link->ai_ckpt);
    ai->status.loss_train = p->loss_train;
    if (!ai->cfg.offline && k < ai->cfg.rounds && (k + 1u) % ai->cfg.rounds_per_boundary == 0)
        ai_pool_boundary(&ai->pool);
    /* The GP core may say the fleet is further on (this robot was paused, restarted or cut
       off): the rounds between are skipped, not run alone, so the robot catches up. */
    ai->next_round = ready->next_round > k + 1u && ready->next_round < total_rounds(ai) ? ready->next_round : k + 1u;
    ai->node.round = ai->next_round; /* the node's schedule (lr, rho_k, noise) follows the skip */
    ai->status.round = ai->next_round;
    ai->phase = ai->next_round >= total_rounds(ai) ? AI_PHASE_DONE : AI_PHASE_COLLECT;
    return rc;
}

/* Exploring: the coarse belief of the model and posterior as they are now, for the GP core's
 * goal choice (the staged samples summed in first, so the belief knows what the robot saw). */
static int publish_belief(ai_core_t *ai, uint64_t now_us)
{
    int r = observe_staged(ai);
    if (r == 0)
        r = ai_belief_update(&ai->belief, &ai->node.model, &ai->post, &ai->seen);
    if (r != 0) {
        ai->belief_errors++;
        return r;
    }
    const uint32_t n = ai->belief_cfg.w * ai->belief_cfg.h;
    const ai_belief_t *b = &ai->belief;
    ai_belief_msg_t *m = mbox_write_buffer(ai->link->ai_belief);
    m->stamp_us = now_us;
    m->round = ai->next_round;
    m->w = ai->belief_cfg.w;
    m->h = ai->belief_cfg.h;
    /* the posterior first, the counts when it has nothing left; explore_counts: both at once */
    m->unknown_mean = (float)(ai->cfg.explore_counts ? b->unknown_mean : b->post_unknown_mean);
    memcpy(m->occ, b->occ, n);
    memcpy(m->unknown, ai->cfg.explore_counts ? b->unknown : b->post_unknown, n);
    memcpy(m->fallback, b->unknown, n); /* without explore_counts: 255 where no ray went */
    (void)mbox_publish(ai->link->ai_belief);
    return 0;
}

int ai_core_tick(void *arg, const fw_tick_t *tick)
{
    ai_core_t *ai = arg;
    ai->ticks++;
    int rc = 0;
    /* Drain at most one ring's worth: bounded work per tick even if the RT core keeps up. */
    ai_sample_t s;
    for (uint32_t i = 0; i < FW_LINK_RING_CAPACITY && ring_get(ai->link->samples, &s) == 0; i++) {
        if (ai->phase != AI_PHASE_DONE) {
            (void)ai_pool_offer(&ai->pool, &s);
            ai->post_xy[2 * ai->post_staged] = s.x;
            ai->post_xy[2 * ai->post_staged + 1] = s.y;
            if (++ai->post_staged == AI_POST_STAGE && observe_staged(ai) != 0)
                rc = -EINVAL;
            /* exploring: counted in the belief grid's cells at once, with the posterior's
               weight (N once the counts are the fleet's estimate) */
            const double w = ai->post_fleet && ai->seen_shared ? (double)ai->cfg.fleet_size : 1.0;
            if (ai->cfg.explore_budget_us > 0 && ai_seen_add(&ai->seen, &s, 1, w) != 0)
                rc = -EINVAL;
        }
    }
    if (mbox_get(ai->link->rt_to_ai, &ai->rt, NULL) < 0)
        rc = -EINVAL;
    if (ai->cfg.explore_budget_us > 0 && ai->phase == AI_PHASE_COLLECT && tick->now_us >= ai->belief_next_us) {
        ai->belief_next_us = tick->now_us + ai->cfg.belief_period_us;
        (void)publish_belief(ai, tick->now_us); /* counted; the GP core keeps the last one */
    }
    if (ai->phase == AI_PHASE_COLLECT) {
        if (ai->next_round < rounds_due(ai)) {
            publish_state(ai, tick->now_us);
        } else if (ai->cfg.train_between && ai->pool.fill > 0) {
            rc = train_between(ai);
        }
    } else if (ai->phase == AI_PHASE_WAIT_SLOTS) {
        gp_ready_t ready;
        if (mbox_get(ai->link->gp_ready, &ready, NULL) == 1 && ready.round == ai->next_round)
            rc = run_round(ai, &ready);
    }
    ai->status.stamp_us = tick->now_us;
    ai->status.pool_fill = ai->pool.fill;
    ai->status.pool_offered = ai->pool.offered;
    ai->status.done = ai->phase == AI_PHASE_DONE;
    if (mbox_put(ai->link->ai_status, &ai->status) != 0)
        rc = -EINVAL;
    return rc;
}

void ai_core_seeds(uint64_t run_seed, uint32_t robot, uint64_t *model_seed, uint64_t *node_seed)
{
    *model_seed = ai_rng_mix64(run_seed ^ 0x5EEDB4B1ull);
    *node_seed = ai_rng_mix64(run_seed ^ ai_rng_mix64(0xA6E7ull + (uint64_t)robot));
}
