/* The deterministic in-process DiNNO fleet: N agents (firmware dinno_node_t each) trained in
 * synchronous rounds in one process, plus the baselines, the data they train on, and the
 * metrics. The multi-process fleet over LCM (gp_fleet, docs/architecture.md section 4) trains the
 * same models from the same seed: this driver is its reference (same node update, same seeds,
 * same positions).
 *
 * Modes:
 *   SIM_FLEET_DINNO    N nodes, each round every node receives the round-start states of its
 *                      graph neighbours in its slots, ascending neighbour id (at most the board's
 *                      DINNO_MAX_PEERS nearest, dinno_graph.h), then runs dinno_node_round.
 *   SIM_FLEET_CENTRAL  one node on the pooled data of all agents, no neighbours.
 *   SIM_FLEET_ISOLATED N nodes on their own data, never any neighbour.
 * Every model makes rounds x primal_steps optimiser steps of `batch` samples with the same
 * lr schedule and Adam resets, so the baselines have the same step budget per model.
 * All nodes start from the same model seed (like the reference's copies of one base model);
 * node i's minibatch/noise seed is a mix of (run seed, i).
 * Graph positions (disk graph): agent i at round k is at arc-length fraction k / rounds of
 * its path (rt_path_point_frac on the path's float waypoints, as the robot's firmware).
 *
 * Links (DINNO mode, cfg.links, sim_links.h): each round every graph link {i, j} delivers both
 * ways or neither; node i's view holds only the neighbours whose link delivers (none: it trains
 * alone that round). The default model delivers everything and draws nothing.
 *
 * Data (offline mode, the paper's main experiments): each agent trains on the samples of its
 * whole path (host_sim scan / sim_scan_run) from round 0; the caller passes them in.
 *
 * Host side: allocates. Not thread-safe per fleet. Deterministic for (inputs, seed). */
#ifndef SIM_FLEET_H
#define SIM_FLEET_H

#include <stddef.h>
#include <stdint.h>

#include "ai/ai_sample.h"
#include "ai/bnn.h"
#include "ai/bnn_post.h"
#include "ai/dinno.h"
#include "ai/dinno_graph.h"
#include "sim_grid.h"
#include "sim_links.h"
#include "sim_paths.h"
#include "sim_occ_eval.h"
#include "sim_plan.h"

#define SIM_FLEET_MAX_AGENTS ((int)DINNO_GRAPH_MAX_NODES)

typedef enum sim_fleet_mode {
    SIM_FLEET_DINNO = 0,
    SIM_FLEET_CENTRAL = 1,
    SIM_FLEET_ISOLATED = 2,
} sim_fleet_mode_t;

/* A member that goes bad (docs/faults.md): it trains honestly but every state it sends is
 * replaced, every round, before its neighbours see it. */
typedef enum sim_fleet_bad {
    SIM_FLEET_BAD_NONE = 0,
    SIM_FLEET_BAD_SCALE,  /* theta x bad_scale */
    SIM_FLEET_BAD_FLIP,   /* -theta */
    SIM_FLEET_BAD_RANDOM, /* i.i.d. normal elements of theta's own rms, new every round */
    SIM_FLEET_BAD_SILENT, /* sends nothing (the baseline: what the others can do without it) */
} sim_fleet_bad_t;

typedef struct sim_fleet_cfg {
    int n_agents;               /* 1 .. SIM_FLEET_MAX_AGENTS */
    uint32_t rounds;            /* >= 1 (also dinno.total_rounds for the lr decay) */
    sim_fleet_mode_t mode;
    dinno_cfg_t dinno;          /* strategy and optimiser settings (strategy unused by baselines) */
    dinno_graph_kind_t graph;
    double radius;              /* disk graph radius, metres (> 0) */
    uint64_t seed;              /* run seed */
    int threads;                /* worker threads for the node updates, 1 .. 16 (results do
                                   not depend on it) */
    sim_fleet_bad_t bad;        /* DINNO mode: agent bad_agent sends bad states (NONE: all honest) */
    int bad_agent;
    double bad_scale;           /* SIM_FLEET_BAD_SCALE's factor */
    sim_links_t links;          /* DINNO mode: which links deliver each round (default: every one;
                                   anything else needs a DiNNO fleet) */
} sim_fleet_cfg_t;

/* "scale=S" | "flip" | "random" | "silent" -> kind (and scale); 0 or -EINVAL. */
int sim_fleet_bad_parse(const char *text, sim_fleet_bad_t *kind, double *scale);

void sim_fleet_cfg_default(sim_fleet_cfg_t *cfg);
/* Agent i's seeds are robot i's (ai_core_seeds): the robots' images train the same models. */

typedef struct sim_fleet sim_fleet_t;

/* data[i], n_data[i]: agent i's samples (copied). paths: n_agents paths (needed for the disk
 * graph, may be NULL otherwise; copied). bcfg NULL = preset. Returns 0, -EINVAL (bad cfg, an
 * agent without data, a disk graph without paths) or -ENOMEM; err says why. */
FS_MUST_CHECK
int sim_fleet_create(const sim_fleet_cfg_t *cfg, const bnn_config_t *bcfg, const ai_sample_t *const *data,
                     const size_t *n_data, const sim_path_t *paths, sim_fleet_t **out, char *err, size_t errlen);
void sim_fleet_destroy(sim_fleet_t *f);

/* One synchronous round for every model. rep (may be NULL) receives the connectivity of the
 * round's graph as the links delivered it (DINNO mode: the pairs that exchanged states, so the
 * graph itself without a link model; baselines report n isolated nodes). Returns 0 or a
 * negative code. */
FS_MUST_CHECK
int sim_fleet_round(sim_fleet_t *f, dinno_graph_report_t *rep);

uint32_t sim_fleet_rounds_done(const sim_fleet_t *f);
int sim_fleet_models(const sim_fleet_t *f); /* 1 for CENTRAL, n_agents otherwise */
dinno_node_t *sim_fleet_node(sim_fleet_t *f, int i);
const dinno_round_stats_t *sim_fleet_last_stats(const sim_fleet_t *f, int i);
/* The screen over the rounds so far (dinno.h): neighbour states left out, by every model, and
 * the largest relative neighbour distance any model saw (of the honest agents' neighbours
 * only when a bad agent is set: what the radius must stay clear of). */
void sim_fleet_screen_totals(const sim_fleet_t *f, uint64_t *excluded, double *honest_dist_max);
/* The graph of the last round (DINNO mode), before the link model. */
const dinno_graph_t *sim_fleet_graph(const sim_fleet_t *f);
/* The neighbour states node i received in the last round (DINNO mode: its graph neighbours
 * whose link delivered, ascending id, a silent bad member left out), or NULL (baselines, no
 * round yet). Valid until the next round. */
const dinno_nbrs_t *sim_fleet_view(const sim_fleet_t *f, int i);
/* Neighbour entries of the graph (node i taking node j counts once for i) in the last round
 * and in all rounds so far: how many the graph offered and how many the link model dropped.
 * Any pointer may be NULL; all 0 outside DINNO mode. */
void sim_fleet_last_links(const sim_fleet_t *f, uint32_t *dropped, uint32_t *offered);
void sim_fleet_link_totals(const sim_fleet_t *f, uint64_t *dropped, uint64_t *offered);

/* The epistemic posterior of every model (ai/bnn_post.h): each robot's from its own training
 * samples over the initial SIREN layer, then, in DiNNO mode, `rounds` posterior rounds as the
 * image runs them after its last DiNNO round (ai_core.h: from M times its own, the states of
 * every other robot mixed in at weight 1/M; one round gives every robot the fleet's sum,
 * robots = M). CENTRAL: the one model on the pooled data; ISOLATED or rounds 0: each its own.
 * posts: sim_fleet_models() entries. 0 or a negative code. */
typedef struct sim_fleet_post_report {
    int iterations; /* posterior rounds run */
} sim_fleet_post_report_t;
FS_MUST_CHECK int sim_fleet_posteriors(sim_fleet_t *f, bnn_post_t *posts, uint32_t rounds,
                                       sim_fleet_post_report_t *rep);
/* Position of agent i at round k (arc-length fraction k / rounds of its path); -EINVAL
 * without paths. */
FS_MUST_CHECK
int sim_fleet_position(const sim_fleet_t *f, int i, uint32_t k, double *x, double *y);

/* ||theta_i - mean|| / ||mean|| over the fleet's models (0 for one model). */
double sim_fleet_consensus_error(const sim_fleet_t *f, int i);

/* ---- per-agent metrics --------------------------------------------------------------------- */
typedef struct sim_fleet_metrics {
    double train_loss;      /* prediction loss of the last round (mean over its steps) */
    double val_loss;        /* mean per-point BCE on the validation set, mean weights */
    double val_sample;      /* the same with ONE sampled forward pass (what a BNN's model(x) does) */
    double val_mc;          /* BCE of the predictive mean of mc_k sampled passes (NaN when mc_k = 0) */
    double kl_loss;         /* the BNN's prior kl_loss */
    double sigma_mean;      /* mean softplus(rho) over the Bayesian weights: how far sigma moved */
    double consensus_error;
    double occ_mse, occ_iou;
    double reg_mu, reg_rho; /* unweighted consensus terms of the last round */
} sim_fleet_metrics_t;

/* val may be NULL (val_* = NaN), ev may be NULL (occ_* = NaN). The sampled passes are keyed by
 * (run seed, rounds done), so a row is reproducible and differs from round to round.
 * mc_k = 0 skips the (mc_k times dearer) predictive-mean loss. */
FS_MUST_CHECK
int sim_fleet_metrics(sim_fleet_t *f, int i, const ai_sample_t *val, size_t n_val, const sim_occ_eval_t *ev,
                      uint32_t mc_k, sim_fleet_metrics_t *out);

#endif /* SIM_FLEET_H */
