/* DiNNO consensus for the BNN (docs/architecture.md section 2, paper Algorithm 2): one node's state and
 * its round update (dual ascent, then B primal optimiser steps).
 *
 * Round k at node i, neighbour states theta_j (j in N(i), read from the FIXED SLOTS below):
 *   1. rho_k = rho0 * rho_scaling^k
 *   2. dual:  p_i += rho_k * sum_j (theta_i - theta_j)          (theta_i = theta at round start)
 *   3. primal: B Adam steps, lr_k = lr_start * (lr_end / lr_start)^(k / (total_rounds - 1))
 *      (log-decay, the reference's logspace), on
 *        loss_i(theta) + <theta, p_i> + REG(theta)
 *      where loss_i = BCE + kl_weight * kl_loss on a minibatch of the node's own data
 *      (bnn_loss_grad) and REG depends on the strategy. mid_j = (theta_i + theta_j) / 2:
 *      - DINNO_UNIFORM : REG = rho_k * sum_j ||theta - mid_j||^2 over the whole vector
 *                        (plain DiNNO; both Adam groups stepped with the same lr, which is
 *                        exactly one Adam over the whole vector since Adam is elementwise).
 *      - DINNO_SEPARATE: REG = rho_k * W_mu  * sum_j ||theta_mu  - mid_j,mu ||^2
 *                            + rho_k * W_rho * sum_j ||theta_rho - mid_j,rho||^2
 *      - DINNO_KL      : REG = rho_k * W_mu  * sum_j ||theta_mu - mid_j,mu||^2
 *                            + rho_k * W_rho * sum_j sum_e KL(N(mu_e, s_e) || N(mu_e, r_je))
 *                        with s_e = softplus(rho_e), r_je = softplus(mid_j,rho,e) and, equal
 *                        means, KL = log(r/s) + s^2 / (2 r^2) - 1/2 (paper eq. 6).
 *   The regulariser weight is rho_k * W (W_mu, W_rho default 1), so the penalty grows with
 *   rho_k like plain DiNNO's. With W_mu = W_rho = 1, SEPARATE is the same computation as
 *   UNIFORM (bit for bit): the strategies only differ when the weights differ.
 *   The KL term is SUMMED over elements (and neighbours), like the L2 term: near agreement
 *   KL(d) with d = rho - rho_reg is ~ (sigmoid(rho)/softplus(rho))^2 * d^2, and that ratio is
 *   ~1 for rho << 0 (0.95 at the initial rho = -3), so the summed KL has the same local
 *   curvature as the summed squared L2 and rho_k means the same for both. (A mean would divide
 *   it by n_rho, ~1.7e4 in the small preset, and switch the consensus on rho off.) Away from
 *   agreement it is asymmetric: exponential when sigma exceeds the midpoint's, linear below.
 *   The dual step uses rho_k for both groups (Algorithm 2 has no W on the duals).
 *
 *   The paper leaves three choices open; each reading is selectable (defaults first), and
 *   docs/paper/REPORT.md measures them:
 *   - kl_form: which KL acts on the rho group, per element e and neighbour j (s = own sigma,
 *       r_j = softplus(mid_j,rho), m_j = mid_j,mu of the paired mean, mu = own mean):
 *       DINNO_KL_OWN_MEAN  KL(N(mu, s) || N(mu, r_j))   = log(r_j/s) + s^2/(2 r_j^2) - 1/2
 *       DINNO_KL_REVERSE   KL(N(mu, r_j) || N(mu, s))   = log(s/r_j) + r_j^2/(2 s^2) - 1/2
 *       DINNO_KL_FULL      KL(N(m_j, r_j) || N(mu, s))  = log(s/r_j) + (r_j^2 + (m_j - mu)^2)/(2 s^2) - 1/2
 *     FULL is eq. 6 between the neighbours' midpoint Gaussian and the own one: a disagreement
 *     in the means raises the own sigma. Its gradient is taken with respect to rho only (the
 *     term is Reg_rho, stepped by the rho optimiser; the means keep their L2 term).
 *   - kl_reduce: SUM over elements (default, same curvature as the L2 term) or MEAN (divided
 *     by n_rho, like torch's default reduction); always summed over neighbours.
 *   - rho_pred_grad: 1 (default) both groups get the prediction-loss gradient; 0 reads
 *     Algorithm 2 literally: Loss_rho = <theta_rho, p_rho> + W_rho Reg_rho has no PredLoss, so
 *     the rho group moves only by its dual and its regulariser (SEPARATE and KL; UNIFORM is
 *     plain DiNNO with one loss and ignores it).
 *   A node with no neighbour state in use skips steps 2 and the REG terms: pure local training.
 *
 * The screen (a member that goes bad: a stolen key, a bug, a sensor fault). Before step 2 a
 * neighbour's state is left out of the round (its entry of node->use cleared, counted in
 * stats->excluded) when it is not finite, or when
 *     ||theta_j - theta_i|| > screen_radius * max(||theta_i||, 1)          (L2, whole vector)
 * A neighbour left out is what a lost state is to the protocol: the node trains on with the
 * others. The radius is relative because the state's norm is set by the preset (the rho
 * group's softplus parameters dominate it), and its default 0.5 sits far from both sides:
 * honest neighbours of the paper's fleets stay within a few percent of ||theta_i|| at every
 * round (docs/faults.md, "a member that goes bad"), while a state scaled x1e3 is ~1e3 away,
 * a sign-flipped one 2 and a random one of theta's own scale ~1.4. Up to the radius a bad
 * member still pulls (as ClippedGossip's clipped neighbours do): what the screen bounds is
 * how far one round can drag a node, not whether it is dragged. When it never triggers, the
 * round is bit-identical to one without it.
 *
 * Links that come and go (docs/faults.md, "Bad and cheap links"). A neighbour whose state does
 * not arrive in a round (lost, out of reach, cut off, screened out) is absent from that round.
 *   DINNO_DUAL_NODE (the original rule): p_i collects every term it ever received and keeps it.
 *     When a link delivers one way only, or a group is cut off for many rounds, the fleet's duals
 *     no longer sum to zero and a healed node carries hundreds of rounds of one-sided terms.
 *   DINNO_DUAL_LINK (default; after UDON, arXiv 2509.12702): each link j keeps its own dual
 *     lambda_ij += rho_k (theta_i - theta_j) over the rounds it delivers, and p_i = sum of
 *     lambda_ij over the links that are there: a link missing for rejoin_gap rounds (G) has its
 *     lambda taken out of p_i, so a neighbour gone for long (cut off, away, out of reach) no
 *     longer pulls; one missing for fewer keeps it there, frozen (a brief loss does not make it
 *     out of date, and taking it out and back each round made the dual term flicker); back after
 *     G or more missed rounds it restarts at zero. G = 0: only the links of the round count
 *     (UDON's rule as written), each coming back with its lambda, and no rejoin. Links are
 *     symmetric in a round (both states cross or neither, the protocol's resends see to it), so
 *     lambda_ij = -lambda_ji and the fleet's duals keep summing to zero whatever the links do.
 *     p_i itself is updated exactly as the NODE rule does while the links stay (the same
 *     increments, in the same order), so a run in which every link always delivers is
 *     bit-identical under both rules.
 *   Rejoin: when a link comes back after missing >= rejoin_gap rounds (a healed partition, a
 *     robot back from away), the node first steps to the mean of its own round-start state and
 *     the round's neighbour states (summed in ascending robot id, its own at its place, so every
 *     node of a full graph steps to the same bits), after the dual update and before the primal
 *     steps: models that trained apart for long meet at once instead of being pulled together
 *     at the optimiser's pace (the learning rate bounds every Adam step).
 *   The dual step uses our state as the neighbours hold it (`mine`: theta0 for FP32, what the
 *   codec delivers otherwise), so both ends of a link add opposite terms even when the states
 *   travel quantised.
 *
 * Compressed exchange (codec, dinno_codec.h). INT8 sends Q(theta) each round: its error is
 * nearly the same every round and accumulates in the duals (the fleet diverged after ~300
 * rounds). The EF codecs (CHOCO-SGD's error feedback, Koloskova et al. 2019) keep a public copy
 * of every state, the same bits at the sender (pub_own) and at every receiver (pub[link]): each
 * round the sender sends d = Q(theta - pub_own) and both sides add d to the copy, so the copy's
 * error is the quantisation error of a DIFFERENCE that shrinks as the models settle. Key
 * rounds (k % key_every == 0) send Q(theta) whole, so a receiver that missed a round (its copy
 * is not of round k - 1: `stale`) leaves that peer out until the next key round and then
 * continues. Neighbours' states are their public copies; the wire format is the same.
 *
 * Neighbour states are read IN PLACE, never copied: the caller hands the node a view
 * (dinno_nbrs_t: count pointers to n_params floats, the robots' ids in ascending order, the
 * round) with dinno_node_set_nbrs() before dinno_node_round(). The view and the states it
 * points to must stay unchanged until the round returned (the GP core's reassembly buffers,
 * gp/gp_pse.h, or the in-process fleet's round-start snapshots); the node keeps only the
 * pointer and its own per-round use mask (node->use: the screen clears a neighbour's entry
 * there, the shared states are never written). Every state must be of the same round k (the
 * caller's job; the view's round is checked).
 *
 * Minibatches: step b of round k draws `batch` indices uniformly with replacement from the
 * node's data, keyed by (node seed, k, b) with Philox (a pure function), or uses the whole
 * data when it has at most `batch` samples. BNN noise keys are derived from (seed, k, b) too,
 * so a node's trajectory is a pure function of (seed, data, neighbour states).
 *
 * Memory: a dinno_node_t holds everything inline (the bnn_model_t, duals, one dual and one
 * public copy per link slot, the round-start snapshot, auxiliary vectors, the view of the
 * neighbours, a batch buffer): DINNO_NODE_BYTES,
 * checked against the board's AI RAM. Declare it static. No function allocates.
 * Thread-safety: one thread per node at a time; nodes are independent. */
#ifndef AI_DINNO_H
#define AI_DINNO_H

#include <stddef.h>
#include <stdint.h>

#include "ai/ai_sample.h"
#include "ai/bnn.h"
#include "ai/dinno_codec.h"


#define DINNO_MAX_PEERS BOARD_MAX_PEERS
#define DINNO_SCREEN_RADIUS_DEFAULT 0.5f

typedef enum dinno_strategy {
    DINNO_UNIFORM = 0,
    DINNO_SEPARATE = 1,
    DINNO_KL = 2,
} dinno_strategy_t;

typedef enum dinno_kl_form {
    DINNO_KL_OWN_MEAN = 0, /* KL(N(mu, s) || N(mu, r)) */
    DINNO_KL_REVERSE = 1,  /* KL(N(mu, r) || N(mu, s)) */
    DINNO_KL_FULL = 2,     /* KL(N(mid_mu, r) || N(mu, s)) */
} dinno_kl_form_t;

typedef enum dinno_kl_reduce {
    DINNO_REDUCE_SUM = 0,
    DINNO_REDUCE_MEAN = 1,
} dinno_kl_reduce_t;

/* Which duals the node keeps (see "Links that come and go" above). */
typedef enum dinno_dual_rule {
    DINNO_DUAL_NODE = 0, /* one dual per node, every delivered neighbour's term added for good */
    DINNO_DUAL_LINK = 1, /* one dual per link; the node's dual is the sum over the links of the round */
} dinno_dual_rule_t;

#define DINNO_REJOIN_GAP_DEFAULT 10u
#define DINNO_KEY_EVERY_DEFAULT 25u
#define DINNO_NO_ROUND UINT32_MAX
#define DINNO_NO_PEER UINT32_MAX

typedef struct dinno_cfg {
    dinno_strategy_t strategy;
    float rho0;            /* > 0, default 0.3 */
    float rho_scaling;     /* >= 1 (finite), default 1.0004 */
    uint32_t primal_steps; /* B >= 1, default 5 */
    float lr_start;        /* > 0, default 1e-3 */
    float lr_end;          /* > 0, default 1e-4 */
    uint32_t total_rounds; /* >= 1: rounds of the lr decay (after it lr stays at lr_end) */
    int persistent_adam;   /* 0 (default): fresh Adam state each round; 1: keep it */
    float w_mu;            /* >= 0, default 1 (SEPARATE, KL) */
    float w_rho;           /* >= 0, default 1 (SEPARATE, KL) */
    float kl_weight;       /* >= 0, weight of the BNN prior KL in loss_i, default 1e-4 */
    uint32_t batch;        /* 1..bnn max_batch, default min(512, max_batch) */
    dinno_kl_form_t kl_form;     /* KL strategy: which KL (default OWN_MEAN) */
    dinno_kl_reduce_t kl_reduce; /* KL strategy: SUM (default) or MEAN over the rho elements */
    int rho_pred_grad;     /* 1 (default) or 0: prediction-loss gradient on the rho group */
    float screen_radius;   /* >= 0, default DINNO_SCREEN_RADIUS_DEFAULT; 0: no distance screen */
    dinno_dual_rule_t dual_rule; /* default DINNO_DUAL_LINK */
    uint32_t rejoin_gap;   /* a link back after missing >= this many rounds restarts fresh and the
                              node steps to the mean first; 0: never (default DINNO_REJOIN_GAP_DEFAULT) */
    dinno_codec_t codec;   /* how states travel (default FP32); the EF codecs keep public copies */
    uint32_t key_every;    /* EF codecs: rounds k with k % key_every == 0 send the whole state (>= 1,
                              default DINNO_KEY_EVERY_DEFAULT) */
    int reg_values;        /* 1 (default): the round stats carry reg_mu, reg_rho and dual_dot; 0:
                              they are NaN, and the sums and logs only they need are skipped (the
                              gradients, so the models, are the same bytes). The image reports
                              none of them and turns them off. */
} dinno_cfg_t;

/* The neighbour states of one round, read in place: entries 0 .. count-1, in ascending robot
 * id (so every sum over them runs in the same order in every fleet). A few hundred bytes of
 * pointers: the states stay where they arrived. */
typedef struct dinno_nbrs {
    uint32_t round;                        /* the round every state belongs to */
    uint32_t count;                        /* entries used, <= DINNO_MAX_PEERS */
    uint32_t id[DINNO_MAX_PEERS];          /* whose state it is (the robot id) */
    const float *theta[DINNO_MAX_PEERS];   /* n_params floats each, unchanged during the round */
    uint32_t inc[DINNO_MAX_PEERS];         /* the sender's incarnation (its restart count; 0 in the
                                              in-process fleet): a new one is a new link */
} dinno_nbrs_t;

/* What one round did (means over its B primal steps unless said otherwise). */
typedef struct dinno_round_stats {
    uint32_t round;        /* k of the round just done */
    uint32_t neighbours;   /* neighbour states used (after the screen) */
    float rho_k, lr;
    float pred_total;      /* BCE + kl_weight * kl_loss (the prediction loss) */
    float bce;
    float kl_prior;        /* BNN kl_loss (unweighted) */
    float reg_mu;          /* sum_j ||theta_mu - mid_j,mu||^2 (unweighted; UNIFORM: mu part) */
    float reg_rho;         /* rho-group term (unweighted): squared L2 or the summed KL */
    float dual_dot;        /* <theta, p_i> */
    uint32_t excluded;     /* neighbour states the screen left out (not finite, too far) */
    float nb_dist_max;     /* largest ||theta_j - theta_i|| / max(||theta_i||, 1) seen this round
                              (screened or not; 0 without neighbours; +inf for a non-finite one) */
    uint32_t rejoined;     /* links back after >= rejoin_gap missed rounds (> 0: the node stepped to
                              the mean of its own and the round's states first) */
    uint32_t stale;        /* EF codecs: differences that arrived without the public copy they
                              refine (a round of that peer was missed): left out until a key round */
} dinno_round_stats_t;

/* One link of the node: a peer whose state it has used, its dual and its public copy. */
typedef struct dinno_link {
    uint32_t peer;         /* robot id, DINNO_NO_PEER: free */
    uint32_t seen;         /* last round its state took part (DINNO_NO_ROUND: never) */
    uint32_t pub_round;    /* EF: pub[] is the peer's public copy of this round (or DINNO_NO_ROUND) */
    uint32_t active;       /* DINNO_DUAL_LINK: its lambda is part of dual (it took part last round) */
    uint32_t inc;          /* the peer's incarnation: a restarted peer starts a new link (its public
                              copy and its dual start afresh) */
} dinno_link_t;

typedef struct dinno_node {
    dinno_cfg_t cfg;
    uint64_t seed;
    uint32_t id;
    uint32_t round;        /* rounds done */
    uint32_t n_nb;         /* neighbours of the round being run (set by dinno_dual_update) */
    double mid_sq[2];      /* sum_j ||mid_j||^2 of the mu and the rho group (L2 values) */
    bnn_model_t model;
    const dinno_nbrs_t *nb;              /* the view of the round (dinno_node_set_nbrs), or NULL */
    uint8_t use[DINNO_MAX_PEERS];        /* 1: view slot s takes part in this round (screen, EF) */
    uint8_t slot_link[DINNO_MAX_PEERS];  /* view slot s -> its link, this round */
    const float *src[DINNO_MAX_PEERS];   /* view slot s -> the state used (the view's, or the public copy) */
    dinno_link_t link[DINNO_MAX_PEERS];
    uint32_t pub_own_round;              /* EF: pub_own is ours as of this round (DINNO_NO_ROUND: none) */
    _Alignas(64) float dual[BNN_N_PARAMS];  /* p_i: [mu-group duals | rho-group duals] */
    _Alignas(64) float lambda[DINNO_MAX_PEERS][BNN_N_PARAMS]; /* DINNO_DUAL_LINK: each link's dual */
    _Alignas(64) float pub[DINNO_MAX_PEERS][BNN_N_PARAMS];    /* EF: the peers' public copies */
    _Alignas(64) float pub_own[BNN_N_PARAMS];  /* EF: ours, as every receiver holds it */
    _Alignas(64) float mine[BNN_N_PARAMS];     /* our round-start state as the neighbours hold it */
    _Alignas(64) float theta0[BNN_N_PARAMS]; /* theta_i at the start of the round */
    _Alignas(64) float aux1[BNN_N_PARAMS];   /* L2: sum_j mid_j; KL rho part: sum_j 1/r_j^2 */
    _Alignas(64) float aux2[BNN_N_RHO];      /* KL: sum_j log r_j */
    _Alignas(64) float aux3[BNN_N_RHO];      /* KL_FULL: sum_j mid_j,mu^2 of the paired means */
    ai_sample_t batch[BNN_MAX_BATCH];
    float draw[BNN_MAX_BATCH];
} dinno_node_t;

#define DINNO_NODE_BYTES (sizeof(dinno_node_t))
_Static_assert(sizeof(dinno_node_t) <= BOARD_RAM_AI_BYTES, "DiNNO node exceeds the board's AI RAM");

/* Defaults above; total_rounds = 1000. */
dinno_cfg_t dinno_default_cfg(void);

/* The vector to hand to the exchange for the node's next round (k = n->round), n_params floats:
 * theta for FP32 and INT8; for the EF codecs theta on a key round, else theta minus our public
 * copy, which is then advanced by what the receivers will hold (dinno_codec_channel), so call it
 * exactly once per round, before dinno_node_round of that round. 0, -EINVAL, or -EALREADY when
 * called twice for one round with an EF codec. */
FS_MUST_CHECK int dinno_node_outgoing(dinno_node_t *n, float *out);

/* Bytes of storage a node holds (the module's buffer size). */
size_t dinno_get_buffer_size(void);

/* Validates cfg (NULL = defaults) against bcfg (NULL = the preset), initialises the model
 * from model_seed (nodes of one fleet share model_seed for a common start, as the reference
 * does), zeroes duals, no neighbours; `seed` keys this node's minibatches and BNN noise (give
 * each node its own). Returns 0 or -EINVAL. */
FS_MUST_CHECK int dinno_node_init(dinno_node_t *n, const dinno_cfg_t *cfg, const bnn_config_t *bcfg,
                              uint64_t model_seed, uint64_t seed, uint32_t id);

/* Hands the node the neighbour states of its next round (NULL or count 0: none). Only the
 * pointer is kept: *nb and the states stay unchanged until dinno_node_round() returned. Every
 * entry starts in use. Returns 0 or -EINVAL (count > DINNO_MAX_PEERS, a NULL state). */
FS_MUST_CHECK int dinno_node_set_nbrs(dinno_node_t *n, const dinno_nbrs_t *nb);

/* rho_k and lr_k of round k under cfg. */
float dinno_rho_at(const dinno_cfg_t *cfg, uint32_t k);
float dinno_lr_at(const dinno_cfg_t *cfg, uint32_t k);

/* One round (k = n->round): dual update from the neighbour states in use, then B primal steps
 * on data[0..n_data). A view with states must carry round k (else -EINVAL, nothing changed).
 * Increments n->round. stats may be NULL. Returns 0 or -EINVAL (NULL, n_data == 0, bad
 * samples). Allocates nothing. */
FS_MUST_CHECK int dinno_node_round(dinno_node_t *n, const ai_sample_t *data, size_t n_data,
                               dinno_round_stats_t *stats);

/* Building blocks, exposed for tests ------------------------------------------------------- */
/* The screen alone (see above): clears node->use for the states to leave out. Returns how
 * many it left out; *dist_max as nb_dist_max. dinno_node_round runs it first. */
uint32_t dinno_screen_slots(dinno_node_t *n, float *dist_max);

/* Dual update only: p += rho_k * sum_{s in use} (theta - theta_s); also snapshots theta0.
 * The link duals move with it only inside dinno_node_round (which maps the view to the links
 * first). Returns the number of neighbours used. */
uint32_t dinno_dual_update(dinno_node_t *n, float rho_k);

/* Adds the gradient of <theta, p> + REG(theta) (strategy terms, weight rho_k) to the model's
 * gradient buffer, using theta0 and the neighbour sums as prepared by dinno_prepare(). Writes the
 * unweighted term values to reg_mu/reg_rho/dual_dot when non-NULL. */
void dinno_prepare(dinno_node_t *n);
void dinno_add_reg_grad(dinno_node_t *n, float rho_k, float *reg_mu, float *reg_rho,
                        float *dual_dot);

/* The value of <theta, p> + REG(theta) at the current theta (double, for finite differences). */
double dinno_reg_value(const dinno_node_t *n, float rho_k);

/* "node" | "link" <-> dual rule. */
const char *dinno_dual_rule_name(dinno_dual_rule_t r);
FS_MUST_CHECK int dinno_dual_rule_parse(const char *name, dinno_dual_rule_t *out);

const char *dinno_strategy_name(dinno_strategy_t s);
/* "uniform" | "separate" | "kl" -> strategy; returns 0 or -EINVAL. */
FS_MUST_CHECK int dinno_strategy_parse(const char *name, dinno_strategy_t *out);
/* "own" | "reverse" | "full" <-> kl_form; "sum" | "mean" <-> kl_reduce. */
const char *dinno_kl_form_name(dinno_kl_form_t f);
FS_MUST_CHECK int dinno_kl_form_parse(const char *name, dinno_kl_form_t *out);
const char *dinno_kl_reduce_name(dinno_kl_reduce_t r);
FS_MUST_CHECK int dinno_kl_reduce_parse(const char *name, dinno_kl_reduce_t *out);

#endif /* AI_DINNO_H */
