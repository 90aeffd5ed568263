/* The in-process DiNNO fleet: see sim_fleet.h.
 *
 * Why it looks like this:
 * - A round is two phases. Phase 1 copies every node's round-start theta into the slots of
 *   its neighbours (all copies are made before any node moves, so every node sees the
 *   states of round k exactly, as Algorithm 1 delivers them). Phase 2 runs the node updates,
 *   which touch only their own node, so they can run on worker threads in any order without
 *   changing a bit of the result.
 * - Positions for the disk graph come from the paths' arc length, not from the ODE robots:
 *   the training data is collected offline, and the positions only decide who talks. They are
 *   computed by the firmware's rt_path on the float waypoints the robots hold, so the
 *   multi-process fleet builds the same graph.
 */
#include "sim_fleet.h"

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ai/ai_core.h"
#include "rt/rt_path.h"
#include "sim_rng.h"

struct sim_fleet {
    sim_fleet_cfg_t cfg;
    int n_models;
    dinno_node_t **nodes;
    ai_sample_t **data;
    size_t *n_data;
    rt_waypoint_t **tours; /* the paths as the firmware holds them (float), or NULL */
    int32_t *tour_n;
    dinno_round_stats_t *stats;
    dinno_graph_t graph;     /* the round's graph (geometry, or full / ring) */
    dinno_graph_t live;      /* its links that delivered this round (cfg.links) */
    uint32_t rounds_done;
    float *bad_theta;        /* the bad agent's state as its neighbours get it (cfg.bad) */
    float *snap;             /* n_models round-start states (BNN_N_PARAMS floats each): what
                                the neighbours read while every node trains its own model */
    dinno_nbrs_t *views;     /* n_models views of the round, pointing into snap / bad_theta */
    uint64_t excluded;       /* sim_fleet_screen_totals */
    double honest_dist_max;
    uint32_t last_dropped, last_offered; /* sim_fleet_last_links */
    uint64_t dropped, offered;           /* sim_fleet_link_totals */
};

void sim_fleet_cfg_default(sim_fleet_cfg_t *cfg)
{
    memset(cfg, 0, sizeof *cfg);
    cfg->n_agents = 7;
    cfg->rounds = 1000;
    cfg->mode = SIM_FLEET_DINNO;
    cfg->dinno = dinno_default_cfg();
    cfg->graph = DINNO_GRAPH_DISK;
    cfg->radius = 4.0;
    cfg->seed = 1;
    cfg->threads = 1;
    sim_links_default(&cfg->links);
}

static void free_fleet(sim_fleet_t *f)
{
    if (!f)
        return;
    if (f->nodes)
        for (int i = 0; i < f->n_models; i++)
            free(f->nodes[i]);
    if (f->data)
        for (int i = 0; i < f->n_models; i++)
            free(f->data[i]);
    if (f->tours)
        for (int i = 0; i < f->cfg.n_agents; i++)
            free(f->tours[i]);
    free(f->nodes);
    free(f->data);
    free(f->n_data);
    free(f->tours);
    free(f->tour_n);
    free(f->stats);
    free(f->bad_theta);
    free(f->snap);
    free(f->views);
    free(f);
}

void sim_fleet_destroy(sim_fleet_t *f)
{
    free_fleet(f);
}

int sim_fleet_create(const sim_fleet_cfg_t *cfg, const bnn_config_t *bcfg, const ai_sample_t *const *data,
                     const size_t *n_data, const sim_path_t *paths, sim_fleet_t **out, char *err, size_t errlen)
{
    if (err && errlen)
        err[0] = '\0';
    if (!cfg || !data || !n_data || !out) {
        snprintf(err, errlen, "NULL argument");
        return -EINVAL;
    }
    *out = NULL;
    if (cfg->n_agents < 1 || cfg->n_agents > SIM_FLEET_MAX_AGENTS) {
        snprintf(err, errlen, "agents must be 1..%d", SIM_FLEET_MAX_AGENTS);
        return -EINVAL;
    }
    if (cfg->rounds < 1 || cfg->mode < SIM_FLEET_DINNO || cfg->mode > SIM_FLEET_ISOLATED ||
        cfg->threads < 1 || cfg->threads > 16) {
        snprintf(err, errlen, "bad rounds, mode or threads");
        return -EINVAL;
    }
    if (cfg->mode == SIM_FLEET_DINNO && cfg->graph == DINNO_GRAPH_DISK &&
        (!paths || !isfinite(cfg->radius) || cfg->radius <= 0.0)) {
        snprintf(err, errlen, "the disk graph needs the agents' paths and a radius > 0");
        return -EINVAL;
    }
    if (cfg->mode == SIM_FLEET_DINNO && cfg->graph == DINNO_GRAPH_FULL &&
        (uint32_t)cfg->n_agents - 1u > DINNO_GRAPH_MAX_DEGREE) {
        snprintf(err, errlen, "the full graph of %d agents needs %d neighbour slots, the board has %u: use the disk "
                 "graph (each agent takes its %u nearest in reach)", cfg->n_agents, cfg->n_agents - 1,
                 (unsigned)DINNO_GRAPH_MAX_DEGREE, (unsigned)DINNO_GRAPH_MAX_DEGREE);
        return -E2BIG;
    }
    if (cfg->bad != SIM_FLEET_BAD_NONE &&
        (cfg->mode != SIM_FLEET_DINNO || cfg->bad < SIM_FLEET_BAD_SCALE || cfg->bad > SIM_FLEET_BAD_SILENT ||
         cfg->bad_agent < 0 || cfg->bad_agent >= cfg->n_agents || !isfinite(cfg->bad_scale))) {
        snprintf(err, errlen, "a bad member needs a DiNNO fleet and an agent 0..%d", cfg->n_agents - 1);
        return -EINVAL;
    }
    if (sim_links_check(&cfg->links, cfg->n_agents, err, errlen) != 0)
        return -EINVAL;
    if (sim_links_active(&cfg->links) && cfg->mode != SIM_FLEET_DINNO) {
        snprintf(err, errlen, "a link model needs a DiNNO fleet (the baselines do not communicate)");
        return -EINVAL;
    }
    for (int i = 0; i < cfg->n_agents; i++) {
        if (!data[i] || n_data[i] == 0) {
            snprintf(err, errlen, "agent %d has no samples", i);
            return -EINVAL;
        }
        if (paths && paths[i].n < 1) {
            snprintf(err, errlen, "agent %d has an empty path", i);
            return -EINVAL;
        }
    }
    sim_fleet_t *f = calloc(1, sizeof *f);
    if (!f)
        return -ENOMEM;
    f->cfg = *cfg;
    f->cfg.dinno.total_rounds = cfg->rounds;
    f->n_models = cfg->mode == SIM_FLEET_CENTRAL ? 1 : cfg->n_agents;
    f->nodes = calloc((size_t)f->n_models, sizeof *f->nodes);
    f->data = calloc((size_t)f->n_models, sizeof *f->data);
    f->n_data = calloc((size_t)f->n_models, sizeof *f->n_data);
    f->stats = calloc((size_t)f->n_models, sizeof *f->stats);
    f->views = calloc((size_t)f->n_models, sizeof *f->views);
    f->snap = aligned_alloc(64, ((size_t)f->n_models * BNN_N_PARAMS * sizeof(float) + 63u) / 64u * 64u);
    if (!f->nodes || !f->data || !f->n_data || !f->stats || !f->views || !f->snap)
        goto oom;
    if (cfg->bad != SIM_FLEET_BAD_NONE && cfg->bad != SIM_FLEET_BAD_SILENT && (f->bad_theta = malloc(BNN_N_PARAMS * sizeof(float))) == NULL)
        goto oom;
    if (paths) {
        f->tours = calloc((size_t)cfg->n_agents, sizeof *f->tours);
        f->tour_n = calloc((size_t)cfg->n_agents, sizeof *f->tour_n);
        if (!f->tours || !f->tour_n)
            goto oom;
        for (int i = 0; i < cfg->n_agents; i++) {
            f->tours[i] = malloc((size_t)paths[i].n * sizeof(rt_waypoint_t));
            if (!f->tours[i])
                goto oom;
            for (int k = 0; k < paths[i].n; k++)
                f->tours[i][k] = (rt_waypoint_t){(float)paths[i].p[k].x, (float)paths[i].p[k].y};
            f->tour_n[i] = paths[i].n;
        }
    }
    if (cfg->mode == SIM_FLEET_CENTRAL) {
        size_t total = 0;
        for (int i = 0; i < cfg->n_agents; i++)
            total += n_data[i];
        f->data[0] = malloc(total * sizeof(ai_sample_t));
        if (!f->data[0])
            goto oom;
        size_t o = 0;
        for (int i = 0; i < cfg->n_agents; i++) {
            memcpy(f->data[0] + o, data[i], n_data[i] * sizeof(ai_sample_t));
            o += n_data[i];
        }
        f->n_data[0] = total;
    } else {
        for (int i = 0; i < cfg->n_agents; i++) {
            f->data[i] = malloc(n_data[i] * sizeof(ai_sample_t));
            if (!f->data[i])
                goto oom;
            memcpy(f->data[i], data[i], n_data[i] * sizeof(ai_sample_t));
            f->n_data[i] = n_data[i];
        }
    }
    for (int i = 0; i < f->n_models; i++) {
        f->nodes[i] = aligned_alloc(64, (sizeof(dinno_node_t) + 63) / 64 * 64);
        if (!f->nodes[i])
            goto oom;
        uint64_t model_seed, node_seed;
        ai_core_seeds(cfg->seed, (uint32_t)i, &model_seed, &node_seed);
        int rc = dinno_node_init(f->nodes[i], &f->cfg.dinno, bcfg, model_seed, node_seed, (uint32_t)i);
        if (rc) {
            snprintf(err, errlen, "invalid DiNNO/BNN configuration");
            free_fleet(f);
            return rc;
        }
    }
    *out = f;
    return 0;
oom:
    snprintf(err, errlen, "out of memory");
    free_fleet(f);
    return -ENOMEM;
}

int sim_fleet_position(const sim_fleet_t *f, int i, uint32_t k, double *x, double *y)
{
    if (!f || !f->tours || i < 0 || i >= f->cfg.n_agents || !x || !y)
        return -EINVAL;
    return rt_path_point_frac(f->tours[i], f->tour_n[i], k, f->cfg.rounds, x, y);
}

static int build_graph(sim_fleet_t *f, uint32_t k)
{
    const uint32_t n = (uint32_t)f->cfg.n_agents;
    switch (f->cfg.graph) {
    case DINNO_GRAPH_FULL:
        return dinno_graph_full(&f->graph, n);
    case DINNO_GRAPH_RING:
        return dinno_graph_ring(&f->graph, n);
    case DINNO_GRAPH_DISK: {
        double xy[2 * SIM_FLEET_MAX_AGENTS];
        for (uint32_t i = 0; i < n; i++) {
            int rc = sim_fleet_position(f, (int)i, k, &xy[2 * i], &xy[2 * i + 1]);
            if (rc)
                return rc;
        }
        return dinno_graph_disk(&f->graph, n, xy, f->cfg.radius);
    }
    }
    return -EINVAL;
}

int sim_fleet_bad_parse(const char *text, sim_fleet_bad_t *kind, double *scale)
{
    if (text == NULL || kind == NULL || scale == NULL)
        return -EINVAL;
    char *end = NULL;
    if (strcmp(text, "flip") == 0)
        *kind = SIM_FLEET_BAD_FLIP;
    else if (strcmp(text, "random") == 0)
        *kind = SIM_FLEET_BAD_RANDOM;
    else if (strcmp(text, "silent") == 0)
        *kind = SIM_FLEET_BAD_SILENT;
    else if (strncmp(text, "scale=", 6) == 0 && (*scale = strtod(text + 6, &end), end != text + 6) && *end == '\0' &&
             isfinite(*scale))
        *kind = SIM_FLEET_BAD_SCALE;
    else
        return -EINVAL;
    return 0;
}

/* What the bad agent sends this round, from its honest theta. */
static void make_bad_state(sim_fleet_t *f, uint32_t k, const float *theta, size_t P)
{
    double ss = 0.0;
    for (size_t e = 0; e < P; e++)
        ss += (double)theta[e] * (double)theta[e];
    const double rms = sqrt(ss / (double)P);
    for (size_t e = 0; e < P; e++) {
        switch (f->cfg.bad) {
        case SIM_FLEET_BAD_SCALE:
            f->bad_theta[e] = (float)(theta[e] * f->cfg.bad_scale);
            break;
        case SIM_FLEET_BAD_FLIP:
            f->bad_theta[e] = -theta[e];
            break;
        default:
            f->bad_theta[e] = (float)(rms * sim_rng_normal(f->cfg.seed, 0xBAD0u, k, e, 0));
            break;
        }
    }
}

typedef struct worker {
    sim_fleet_t *f;
    int first, stride;
    int rc;
} worker_t;

static void *run_worker(void *arg)
{
    worker_t *w = arg;
    w->rc = 0;
    for (int i = w->first; i < w->f->n_models; i += w->stride) {
        int rc = dinno_node_round(w->f->nodes[i], w->f->data[i], w->f->n_data[i], &w->f->stats[i]);
        if (rc && !w->rc)
            w->rc = rc;
    }
    return NULL;
}

int sim_fleet_round(sim_fleet_t *f, dinno_graph_report_t *rep)
{
    if (!f)
        return -EINVAL;
    const uint32_t k = f->rounds_done;
    if (f->cfg.mode == SIM_FLEET_DINNO) {
        int rc = build_graph(f, k);
        if (rc)
            return rc;
        const size_t P = bnn_n_params(&f->nodes[0]->model);
        if (f->bad_theta != NULL)
            make_bad_state(f, k, bnn_params_const(&f->nodes[f->cfg.bad_agent]->model), P);
        /* One round-start snapshot per node (the nodes' models change while their neighbours
           still read them); the views point into it, as the GP core's point into its buffers. */
        for (int j = 0; j < f->n_models; j++) {
            /* what node j hands the exchange, as its neighbours will hold it (dinno_codec.h) */
            float *sj = f->snap + (size_t)j * P;
            rc = dinno_node_outgoing(f->nodes[j], sj);
            if (rc == 0)
                rc = dinno_codec_channel(&f->nodes[j]->model.cfg, f->cfg.dinno.codec, sj, sj);
            if (rc)
                return rc;
        }
        /* The links of the round first (the graph's pairs that deliver, both ways or neither:
           sim_links.h), then each view from them. */
        f->live.n = f->graph.n;
        f->last_dropped = f->last_offered = 0;
        for (int i = 0; i < f->n_models; i++) {
            f->live.deg[i] = 0;
            for (uint32_t e = 0; e < f->graph.deg[i]; e++) {
                const uint16_t j = f->graph.nb[i][e];
                f->last_offered++;
                if (sim_links_deliver(&f->cfg.links, f->cfg.seed, k, (uint32_t)i, j))
                    f->live.nb[i][f->live.deg[i]++] = j;
                else
                    f->last_dropped++;
            }
        }
        f->offered += f->last_offered;
        f->dropped += f->last_dropped;
        for (int i = 0; i < f->n_models; i++) {
            dinno_nbrs_t *v = &f->views[i];
            v->round = k;
            v->count = 0;
            /* Ascending neighbour id, as the GP core's view. */
            for (uint32_t e = 0; e < f->live.deg[i]; e++) {
                const int j = f->live.nb[i][e];
                if (f->cfg.bad == SIM_FLEET_BAD_SILENT && j == f->cfg.bad_agent)
                    continue;
                if (v->count >= DINNO_MAX_PEERS)
                    return -EINVAL;
                v->id[v->count] = (uint32_t)j;
                v->theta[v->count++] = f->bad_theta != NULL && j == f->cfg.bad_agent ? f->bad_theta
                                                                                      : f->snap + (size_t)j * P;
            }
            rc = dinno_node_set_nbrs(f->nodes[i], v);
            if (rc)
                return rc;
        }
        if (rep)
            dinno_graph_report(&f->live, rep);
    } else {
        f->graph.n = f->live.n = (uint32_t)f->n_models;
        memset(f->graph.deg, 0, sizeof f->graph.deg);
        memset(f->live.deg, 0, sizeof f->live.deg);
        if (rep)
            dinno_graph_report(&f->graph, rep);
    }
    int nt = f->cfg.threads < f->n_models ? f->cfg.threads : f->n_models;
    worker_t w[16];
    pthread_t th[16];
    for (int t = 0; t < nt; t++)
        w[t] = (worker_t){.f = f, .first = t, .stride = nt, .rc = 0};
    int started = 0;
    for (int t = 1; t < nt; t++) {
        if (pthread_create(&th[t], NULL, run_worker, &w[t]) != 0)
            break;
        started = t;
    }
    /* Threads that failed to start: run their share here (same results, just slower). */
    run_worker(&w[0]);
    for (int t = started + 1; t < nt; t++)
        run_worker(&w[t]);
    for (int t = 1; t <= started; t++)
        pthread_join(th[t], NULL);
    for (int t = 0; t < nt; t++)
        if (w[t].rc)
            return w[t].rc;
    for (int i = 0; i < f->n_models; i++) {
        f->excluded += f->stats[i].excluded;
        /* A bad agent's own neighbours are honest, but an honest agent next to it sees it:
           with a bad agent, only rounds of honest agents that did not hear it say what honest
           distances are (the live graph: a dropped link brought nothing). */
        const int near_bad = f->cfg.bad != SIM_FLEET_BAD_NONE &&
                             (i == f->cfg.bad_agent ||
                              dinno_graph_has_edge(&f->live, (uint32_t)i, (uint32_t)f->cfg.bad_agent));
        if (!near_bad && f->stats[i].nb_dist_max > f->honest_dist_max)
            f->honest_dist_max = f->stats[i].nb_dist_max;
    }
    f->rounds_done = k + 1;
    return 0;
}

void sim_fleet_screen_totals(const sim_fleet_t *f, uint64_t *excluded, double *honest_dist_max)
{
    if (excluded)
        *excluded = f ? f->excluded : 0;
    if (honest_dist_max)
        *honest_dist_max = f ? f->honest_dist_max : 0.0;
}

uint32_t sim_fleet_rounds_done(const sim_fleet_t *f)
{
    return f ? f->rounds_done : 0;
}

int sim_fleet_models(const sim_fleet_t *f)
{
    return f ? f->n_models : 0;
}

dinno_node_t *sim_fleet_node(sim_fleet_t *f, int i)
{
    return f && i >= 0 && i < f->n_models ? f->nodes[i] : NULL;
}

const dinno_round_stats_t *sim_fleet_last_stats(const sim_fleet_t *f, int i)
{
    return f && i >= 0 && i < f->n_models ? &f->stats[i] : NULL;
}

const dinno_graph_t *sim_fleet_graph(const sim_fleet_t *f)
{
    return f ? &f->graph : NULL;
}

const dinno_nbrs_t *sim_fleet_view(const sim_fleet_t *f, int i)
{
    if (!f || f->cfg.mode != SIM_FLEET_DINNO || f->rounds_done == 0 || i < 0 || i >= f->n_models)
        return NULL;
    return &f->views[i];
}

void sim_fleet_last_links(const sim_fleet_t *f, uint32_t *dropped, uint32_t *offered)
{
    if (dropped)
        *dropped = f ? f->last_dropped : 0;
    if (offered)
        *offered = f ? f->last_offered : 0;
}

void sim_fleet_link_totals(const sim_fleet_t *f, uint64_t *dropped, uint64_t *offered)
{
    if (dropped)
        *dropped = f ? f->dropped : 0;
    if (offered)
        *offered = f ? f->offered : 0;
}

double sim_fleet_consensus_error(const sim_fleet_t *f, int i)
{
    if (!f || i < 0 || i >= f->n_models || f->n_models < 2)
        return 0.0;
    const size_t P = bnn_n_params(&f->nodes[0]->model);
    double num = 0.0, den = 0.0;
    const double inv = 1.0 / f->n_models;
    for (size_t p = 0; p < P; p++) {
        double mean = 0.0;
        for (int j = 0; j < f->n_models; j++)
            mean += bnn_params_const(&f->nodes[j]->model)[p];
        mean *= inv;
        const double d = bnn_params_const(&f->nodes[i]->model)[p] - mean;
        num += d * d;
        den += mean * mean;
    }
    return den > 0.0 ? sqrt(num / den) : 0.0;
}

/* ---- per-agent metrics --------------------------------------------------------------------- */
int sim_fleet_metrics(sim_fleet_t *f, int i, const ai_sample_t *val, size_t n_val, const sim_occ_eval_t *ev,
                      uint32_t mc_k, sim_fleet_metrics_t *out)
{
    if (!f || i < 0 || i >= f->n_models || !out)
        return -EINVAL;
    bnn_model_t *m = &f->nodes[i]->model;
    const dinno_round_stats_t *st = &f->stats[i];
    out->train_loss = f->rounds_done ? st->pred_total : NAN;
    out->reg_mu = f->rounds_done ? st->reg_mu : NAN;
    out->reg_rho = f->rounds_done ? st->reg_rho : NAN;
    out->kl_loss = bnn_kl_loss(m);
    const float *rho = bnn_params_const(m) + m->n_mu;
    double ssum = 0.0;
    for (size_t e = 0; e < m->n_rho; e++)
        ssum += bnn_softplus(rho[e]);
    out->sigma_mean = m->n_rho ? ssum / (double)m->n_rho : NAN;
    out->consensus_error = sim_fleet_consensus_error(f, i);
    out->val_loss = out->val_sample = out->val_mc = NAN;
    if (val && n_val) {
        const uint64_t key = sim_rng_mix(f->cfg.seed ^ 0x7A15E7ull ^ ((uint64_t)f->rounds_done << 20));
        float b, bs, bm = NAN;
        int rc = bnn_eval_bce(m, val, n_val, 0, 0, &b);
        if (!rc)
            rc = bnn_eval_bce(m, val, n_val, 1, key, &bs);
        if (!rc && mc_k > 0)
            rc = bnn_eval_bce(m, val, n_val, mc_k, key, &bm);
        if (rc)
            return rc;
        out->val_loss = b;
        out->val_sample = bs;
        out->val_mc = bm;
    }
    out->occ_mse = out->occ_iou = NAN;
    if (ev) {
        int rc = sim_occ_eval_run(ev, m, &out->occ_mse, &out->occ_iou);
        if (rc)
            return rc;
    }
    return 0;
}

/* ---- the fleet's epistemic posterior ------------------------------------------------------ */
int sim_fleet_posteriors(sim_fleet_t *f, bnn_post_t *posts, uint32_t rounds, sim_fleet_post_report_t *rep)
{
    if (!f || !posts || !rep)
        return -EINVAL;
    memset(rep, 0, sizeof *rep);
    const int M = f->n_models;
    /* over the initial SIREN layer, as the image makes it (ai_core.c): every robot's the same */
    bnn_model_t *init = aligned_alloc(_Alignof(bnn_model_t), (sizeof(bnn_model_t) + 63) / 64 * 64);
    if (!init)
        return -ENOMEM;
    int rc = bnn_init(init, &f->nodes[0]->model.cfg, f->nodes[0]->model.seed);
    for (int i = 0; i < M && rc == 0; i++) {
        bnn_model_t *m = &f->nodes[i]->model;
        rc = bnn_post_init(&posts[i], init);
        if (rc == 0)
            rc = bnn_post_observe_samples(&posts[i], m, f->data[i], f->n_data[i]);
    }
    free(init);
    if (rc != 0)
        return rc;
    if (f->cfg.mode != SIM_FLEET_DINNO || M < 2 || rounds == 0)
        return 0; /* one model, or robots that never talk: each keeps what it saw */
    /* The image's posterior rounds (ai_core.h), with its own code: each robot starts at M times
       its own and mixes in, at weight 1/M, the states of its neighbours, which in these rounds
       are every other robot up to DINNO_MAX_PEERS of them, the lowest ids first (gp_fleet puts
       every robot at one position, and gp_pse keeps the nearest by distance, then id). */
    float *states = malloc((size_t)M * BNN_N_PARAMS * sizeof *states);
    if (!states)
        return -ENOMEM;
    for (int i = 0; i < M && rc == 0; i++)
        rc = bnn_post_scale(&posts[i], (double)M);
    for (uint32_t r = 0; r < rounds && rc == 0; r++) {
        for (int i = 0; i < M && rc == 0; i++)
            rc = bnn_post_to_state(&posts[i], states + (size_t)i * BNN_N_PARAMS, BNN_N_PARAMS);
        for (int i = 0; i < M && rc == 0; i++) {
            const float *nb[DINNO_MAX_PEERS];
            size_t n = 0;
            for (int k = 0; k < M && n < DINNO_MAX_PEERS; k++)
                if (k != i)
                    nb[n++] = states + (size_t)k * BNN_N_PARAMS;
            uint32_t used = 0;
            rc = bnn_post_mix(&posts[i], nb, n, BNN_N_PARAMS, 1.0 / M, &used);
            if (rc == 0 && used != n)
                rc = -EINVAL; /* one feature map for the whole fleet: never expected */
        }
        rep->iterations = (int)r + 1;
    }
    free(states);
    return rc;
}
