/* The AI core of the robot image: drains the RT -> AI sample ring into a fixed-capacity
 * sample pool and learns online by communication rounds (paper section 6.2).
 *
 * The path is split into C rounds of equal path progress (rt_status_t.progress_m, published
 * by the RT core): boundary k (0 <= k < C) is reached when progress >= (k + 1) * L / C, or
 * when the RT core reports the path finished (then every remaining round runs). At each
 * boundary the core takes part in DiNNO round k (fw_link.h protocol): it publishes its
 * state, waits (without blocking: a state machine over its ticks) for the GP core's
 * ready(k), hands the neighbour view (fw_link_t.nbrs: pointers into the GP core's buffers) to
 * its dinno_node_t and runs dinno_node_round() on the pool: B = steps_per_round optimiser steps (a node without
 * neighbours trains locally, as DiNNO does). Then it publishes the checkpoint of round k and
 * applies the pool policy (ai_pool.h: CDR keeps, DR clears).
 * Rounds per boundary R (default 1): each boundary runs R DiNNO rounds in a row (the paper's
 * online mode: C = rounds / R communication rounds, each of R DiNNO rounds with the peers);
 * the pool policy applies after the last of them.
 * Offline mode (paper section 6.3): no boundary before the tour is finished; then all rounds
 * run on the samples of the whole tour, and the pool is never cleared.
 * Resuming (start_round, resume_ckpt): the core starts at round start_round instead of 0:
 * next_round, status.round and the DiNNO node's round counter, which keys the learning rate,
 * the ADMM penalty rho_k, the minibatch draws and the BNN noise, so round k trains as it would
 * have in the run that wrote the checkpoint. theta comes from resume_ckpt (bnn_ckpt format,
 * validated in full by bnn_ckpt_load; read during ai_core_init only, not kept). A checkpoint
 * holds theta and nothing else of the node: the DiNNO duals restart at zero, and so do the
 * Adam moments (the image writes its checkpoints without them; with the default fresh Adam
 * state per round that loses nothing, with persistent_adam the moments rebuild). A robot that
 * had neighbours therefore continues close to, not exactly on, its old trajectory; a lone
 * robot resumed offline trains bit for bit as the run that wrote the checkpoint. Offline, the
 * robot still drives its whole tour first (the same samples: the world is deterministic), then
 * publishes state(start_round). Online the pool would be empty: the host refuses to resume
 * there (the pose and the pool are not in a checkpoint).
 * Option train_between: on every tick between boundaries with a non-empty pool, one more
 * optimiser step (bnn_train_step, lr of the coming round) on a minibatch drawn from the pool.
 *
 * Every checkpoint also carries the robot's epistemic posterior (bnn_post.h): every sample
 * drained from the ring so far (kept by the pool or not), summed in AI_POST_STAGE at a time
 * (and the rest at each checkpoint) over the initial SIREN layer's features.
 * Posterior rounds: after the last DiNNO round, post_rounds more rounds of the same protocol
 * (state(k), ready(k), ckpt(k)) in which the state is the posterior (bnn_post_to_state) and
 * the round mixes the neighbours' in (bnn_post_mix, weights 1/N): average consensus on the
 * robots' estimates of the fleet's posterior, each starting at N times its own (robots = N),
 * so that every robot's map comes to know what any robot observed. theta does not change; the
 * last of these rounds is the final one.
 * Exploring in a fleet (explore_share_post): the posterior is shared while the robots explore,
 * so that each robot's belief, and the goals its GP core draws from it, are the fleet's: every
 * odd round below rounds is a posterior round (the DiNNO node skips it, as it skips rounds it
 * missed), and the estimate follows the robots' growing data by dynamic average consensus:
 * from the first such round on, the robot's new points go in with weight N (bnn_post_observe_
 * weighted), so the mean of the estimates stays the sum of the robots' posteriors while each
 * one is mixed towards it. The posterior rounds after the DiNNO rounds continue the same.
 * Exploring, the AI core also counts what the lidar covered (ai_seen.h: the posterior's global
 * features alone come to say they know rooms no ray entered); the belief it sends holds the
 * posterior's layer, which the goal choice reads first, and as its fallback the same with the
 * cells no ray reached beyond the reached ones unknown (ai_link.h, ai_seen_t.unreached_only;
 * with explore_counts the first layer is the larger of the posterior's and the counts' shares,
 * and the fallback too). In a fleet the counts are reached by the same consensus, in the same
 * rounds, after the posterior in the state when the state has room for both (not in the `mcu`
 * preset: there each robot counts its own).
 * Storage: ai_core_t is static (the image declares it): the DiNNO node (model, duals, the
 * view of the neighbours), the pool of AI_POOL_CAPACITY samples and a minibatch buffer, checked with the
 * AI core's links against BOARD_RAM_AI_BYTES. No allocation. One AI core per image. */
#ifndef AI_AI_CORE_H
#define AI_AI_CORE_H

#include <stdint.h>

#include "ai/ai_belief.h"
#include "ai/ai_seen.h"
#include "ai/ai_link.h"
#include "ai/ai_pool.h"
#include "ai/bnn_post.h"
#include "ai/dinno.h"
#include "common/fw_core.h"
#include "fw_link.h"
#include "gp/gp_link.h"
#include "rt/rt_link.h"

/* AI_POOL_CAPACITY (samples) comes from the build configuration, common/fw_config.h. */

#define AI_CORE_MAX_ROUNDS 100000u
#define AI_CORE_MAX_POST_ROUNDS 1000u /* posterior rounds, beyond the DiNNO rounds */
#define AI_POST_STAGE 256u /* samples summed into the posterior at once */

typedef struct ai_core_cfg {
    uint32_t rounds;          /* DiNNO rounds in all, 1 .. AI_CORE_MAX_ROUNDS */
    uint32_t rounds_per_boundary; /* R >= 1 dividing rounds (0 is taken as 1) */
    int offline;              /* 0/1: every round after the tour */
    ai_pool_policy_t policy;
    dinno_cfg_t dinno;        /* primal_steps = B; total_rounds is set to C */
    uint64_t model_seed;      /* initial weights */
    uint64_t seed;            /* minibatches, BNN noise, reservoir */
    uint32_t node_id;
    uint32_t pool_samples;    /* the pool's capacity: 0 (AI_POOL_CAPACITY) or 1 .. AI_POOL_CAPACITY; a
                                 host robot given a board's capacity keeps what that board keeps */
    int train_between;        /* 0/1 */
    uint32_t start_round;     /* first round to run, 0 .. rounds + post_rounds - 1 (0: fresh) */
    uint32_t post_rounds;     /* rounds after the DiNNO rounds in which the fleet's epistemic
                                 posterior is reached by average consensus (0: none) */
    uint32_t fleet_size;      /* N, the weights 1/N of that consensus; >= 1 when post_rounds > 0 */
    const uint8_t *resume_ckpt; /* NULL (theta from model_seed), or the checkpoint to start from */
    uint32_t resume_ckpt_bytes;
    /* Exploration (docs/exploration.md): no tour, so the rounds are cut by simulated time,
       boundary k at (k + 1) x explore_budget_us / C (or when the RT core says it finished);
       every belief_period_us the coarse belief grid (ai_belief.h) of the current model and
       posterior goes to the GP core (fw_link_t.ai_belief). 0: a tour, cut by path progress. */
    uint64_t explore_budget_us;
    const ai_belief_cfg_t *belief;  /* with explore_budget_us: the grid's geometry (copied) */
    uint64_t belief_period_us;      /* > 0 with explore_budget_us */
    int explore_share_post;         /* 0/1, with explore_budget_us and fleet_size >= 1: every odd
                                       round shares the posterior (above) */
    int explore_counts;             /* 0/1, with explore_budget_us: the belief's first layer also
                                       counts where the rays went (ai_seen.h; above); 0: the
                                       posterior's alone, the counts in its fallback layer */
} ai_core_cfg_t;

/* The seeds of robot `robot` of a run seeded `run_seed`: the model's initial weights (the same
 * for every robot: one network) and the robot's own (minibatches, BNN noise, reservoir). Every
 * program that starts a robot (host_sim's fleets of threads or processes, a board's image) takes
 * them from here, so they train the same models. */
void ai_core_seeds(uint64_t run_seed, uint32_t robot, uint64_t *model_seed, uint64_t *node_seed);

typedef enum ai_core_phase {
    AI_PHASE_COLLECT = 0,     /* between boundaries */
    AI_PHASE_WAIT_SLOTS = 1,  /* state published, waiting for the GP core's ready(k) */
    AI_PHASE_DONE = 2,        /* all C rounds done */
} ai_core_phase_t;

typedef struct ai_core {
    ai_core_cfg_t cfg;
    const fw_link_t *link;
    ai_core_phase_t phase;
    uint32_t next_round;      /* k of the next boundary */
    rt_status_t rt;           /* latest RT status */
    ai_status_t status;
    ai_round_info_t pending;  /* the boundary being processed */
    uint64_t ticks;
    uint64_t empty_rounds;    /* boundaries reached with an empty pool (no update) */
    ai_pool_t pool;
    dinno_node_t node;
    ai_sample_t batch[BNN_MAX_BATCH];
    ai_sample_t pool_data[AI_POOL_CAPACITY];
    bnn_post_t post;          /* every sample the robot took, summed in as they come */
    float post_xy[2u * AI_POST_STAGE]; /* samples not yet summed in */
    uint32_t post_staged;
    int post_fleet;           /* 1: post holds this robot's estimate of the fleet's posterior */
    ai_belief_cfg_t belief_cfg;
    ai_belief_t belief;       /* exploring: the grid last published */
    ai_seen_t seen;           /* explore_counts: samples per belief cell (the fleet's estimate when shared) */
    int seen_shared;          /* 1: the count grid rides in the posterior rounds' state */
    uint64_t belief_next_us;  /* the next belief update is due then */
    uint64_t belief_errors;
} ai_core_t;

#define AI_CORE_BYTES (sizeof(ai_core_t))

/* The default configuration: C = 8, CDR, dinno_default_cfg() (B = 5), seeds 1. */
ai_core_cfg_t ai_core_default_cfg(void);

/* Validates cfg and initialises the core (model from model_seed, then theta from resume_ckpt
 * when given; start_round). Before the cores start. 0, -EINVAL, or bnn_ckpt_load's code for a
 * checkpoint it refuses (another preset, torn, corrupt). */
FS_MUST_CHECK int ai_core_init(ai_core_t *ai, const ai_core_cfg_t *cfg,
                                                     const fw_link_t *link);

/* fw_core_t tick function: arg is the ai_core_t. */
int ai_core_tick(void *arg, const fw_tick_t *tick);

#endif /* AI_AI_CORE_H */
