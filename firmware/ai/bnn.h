/* Bayesian neural network of the AI core: SIREN input layer, L Bayesian linear layers with
 * ReLU, a deterministic linear output with a sigmoid (docs/architecture.md section 2, paper section 5).
 *
 *   (x, y) in [-1, 1]^2
 *   h0 = sin(w0 * (W0 [x y]^T + b0))                  SIREN, w0 = 30, W0,b0 ~ U(-1/2, 1/2)
 *   h_l = relu(W_l h_{l-1} + b_l),  l = 1..L          W_l = W_mu + softplus(W_rho) * eps
 *   logit = w_out . h_L + b_out;  p = sigmoid(logit)
 *
 * Parameter vector theta: ONE flat float array, [mu-group | rho-group], each group contiguous:
 *   mu-group  = W0 [S x 2], b0 [S],
 *               for l = 1..L: W_mu_l [out x in], b_mu_l [out],
 *               w_out [1 x H], b_out [1]
 *   rho-group = for l = 1..L: W_rho_l [out x in], b_rho_l [out]
 * Matrices are row-major [out x in] (row = one output unit). Layer 1 has in = S, out = H;
 * layers 2..L have in = out = H. The gradient buffer (bnn_grads) has exactly this layout.
 * Offsets/lengths of each group: bnn_group_offset()/bnn_group_len() (runtime dimensions), or
 * BNN_N_MU / BNN_N_RHO / BNN_N_PARAMS for the compile-time preset (= the default config).
 * Within the mu-group, the Bayesian means of layer l start at bnn_tensor(...) offsets; the
 * rho of element j of the rho group belongs to the mu at bnn_rho_to_mu(model, j).
 *
 * Loss (paper eq. 7, bayesian-torch reduction):
 *   total = BCE (mean over the batch, from logits, numerically stable)
 *         + kl_weight * sum over Bayesian tensors T (each W and each b separately) of
 *           mean_{i in T} KL(N(mu_i, sigma_i) || N(0, sigma_p)),  sigma_p = 1.
 *
 * Randomness: eps of element j of the rho-group (j = its index within the rho-group) in the
 * draw keyed by (model seed, noise_key) is a pure function of (seed, noise_key, j): Philox
 * counter-based, see ai/ai_rng.h. So a draw is reproducible on any back end and thread.
 * One draw is shared by the whole batch of a forward pass.
 *
 * Memory: a bnn_model_t holds all its storage inline (parameters, gradients, two Adam moments
 * per parameter, the sampled weights, eps, sigma, and activations for BNN_MAX_BATCH points),
 * BNN_ARENA_BYTES in total, sized from the preset at compile time and checked against the
 * board's AI RAM. Declare models with static storage duration (`static bnn_model_t m;`); they
 * are too large for a stack. No function allocates.
 *
 * Thread-safety: a model is used by one thread at a time (the AI core). Distinct models are
 * independent. All functions are deterministic given their inputs.
 */
#ifndef AI_BNN_H
#define AI_BNN_H

#include <stddef.h>
#include <stdint.h>

#include "ai/ai_sample.h"


/* ---- compile-time presets (Makefile defines exactly one BNN_PRESET_*) ------------------- */
#if defined(BNN_PRESET_PAPER)
#define BNN_PRESET_NAME "paper"
#define BNN_SIREN_MAX 256u  /* SIREN width S */
#define BNN_HIDDEN_MAX 256u /* Bayesian layer width H */
#define BNN_LAYERS_MAX 4u   /* number of Bayesian layers L */
#define BNN_MAX_BATCH 1024u /* points per forward/backward pass */
#elif defined(BNN_PRESET_MCU)
#define BNN_PRESET_NAME "mcu"
#define BNN_SIREN_MAX 64u
#define BNN_HIDDEN_MAX 48u
#define BNN_LAYERS_MAX 3u
#define BNN_MAX_BATCH 64u
#elif defined(BNN_PRESET_SMALL)
#define BNN_PRESET_NAME "small"
#define BNN_SIREN_MAX 128u
#define BNN_HIDDEN_MAX 64u
#define BNN_LAYERS_MAX 3u
#define BNN_MAX_BATCH 1024u
#else
#error "define one of BNN_PRESET_SMALL, BNN_PRESET_PAPER, BNN_PRESET_MCU (the Makefile does)"
#endif

#define BNN_IN 2u         /* input dimension (x, y) */
#define BNN_W0 30.0f      /* SIREN frequency */
#define BNN_RHO_INIT -3.0f /* initial rho of every Bayesian weight (sigma ~ 0.0486) */
#define BNN_PRIOR_SIGMA 1.0f
#define BNN_MC_DEFAULT_K 50u

/* Parameter counts of the preset (the default config). */
#define BNN_LAYER_BAYES_N(in, out) ((size_t)(in) * (out) + (out)) /* one of W_mu+b_mu or W_rho+b_rho */
#define BNN_N_RHO_OF(S, H, L) (BNN_LAYER_BAYES_N(S, H) + ((size_t)(L)-1u) * BNN_LAYER_BAYES_N(H, H))
#define BNN_N_MU_OF(S, H, L) ((size_t)(S) * BNN_IN + (S) + BNN_N_RHO_OF(S, H, L) + (H) + 1u)
#define BNN_N_MU BNN_N_MU_OF(BNN_SIREN_MAX, BNN_HIDDEN_MAX, BNN_LAYERS_MAX)
#define BNN_N_RHO BNN_N_RHO_OF(BNN_SIREN_MAX, BNN_HIDDEN_MAX, BNN_LAYERS_MAX)
#define BNN_N_PARAMS (BNN_N_MU + BNN_N_RHO)

#if defined(BNN_PRESET_PAPER)
_Static_assert(BNN_N_PARAMS == 527361u, "paper preset must have exactly 527,361 parameters");
#endif

/* Arena layout, in floats (see bnn_int.h): params, grads, Adam m and v (4 x N_PARAMS); sampled
 * Bayesian weights, eps, sigma (3 x N_RHO); activations per batch point: SIREN pre-activation
 * and output (2S), every Bayesian layer's output (L*H), two back-propagation buffers
 * (2*max(S,H)), the input and logit/dlogit (4). */
#define BNN_WMAX_ (BNN_SIREN_MAX > BNN_HIDDEN_MAX ? BNN_SIREN_MAX : BNN_HIDDEN_MAX)
#define BNN_ACT_FLOATS_PER_POINT                                                               \
    (2u * BNN_SIREN_MAX + BNN_LAYERS_MAX * BNN_HIDDEN_MAX + 2u * BNN_WMAX_ + 4u)
#define BNN_ARENA_FLOATS                                                                       \
    (4u * BNN_N_PARAMS + 3u * BNN_N_RHO + (size_t)BNN_MAX_BATCH * BNN_ACT_FLOATS_PER_POINT + 64u)
#define BNN_ARENA_BYTES (BNN_ARENA_FLOATS * sizeof(float))

_Static_assert(BNN_ARENA_BYTES <= BOARD_RAM_AI_BYTES, "BNN arena exceeds the board's AI RAM");
#if defined(BNN_PRESET_MCU)
_Static_assert(BNN_ARENA_BYTES <= 512u * 1024u, "mcu preset arena must fit 512 KB");
#endif

/* ---- types ------------------------------------------------------------------------------ */
typedef enum bnn_group {
    BNN_GROUP_MU = 0,  /* SIREN, Bayesian means, output layer */
    BNN_GROUP_RHO = 1, /* Bayesian rho (sigma = softplus(rho)) */
    BNN_GROUP_ALL = 2, /* whole vector (offset 0, length n_params); not an Adam group */
} bnn_group_t;

/* Arithmetic of the training step's large GEMMs (each Bayesian layer's forward, dX and dW;
 * firmware/ai/README.md): fp32, or bf16 products with fp32 sums (ai/la_bf16.h). Master
 * weights, Adam, KL, the element-wise passes and every inference pass (validation, MC) stay
 * fp32 either way. The build's default is PRECISION= in the Makefile. */
typedef enum bnn_precision {
    BNN_PRECISION_FP32 = 0,
    BNN_PRECISION_BF16 = 1,
} bnn_precision_t;

#if defined(BNN_PRECISION_DEFAULT_BF16)
#define BNN_PRECISION_DEFAULT BNN_PRECISION_BF16
#define BNN_PRECISION_NAME "bf16"
#else
#define BNN_PRECISION_DEFAULT BNN_PRECISION_FP32
#define BNN_PRECISION_NAME "fp32"
#endif

/* Runtime dimensions, each bounded by the preset maxima. bnn_default_config() = the preset. */
typedef struct bnn_config {
    uint32_t siren_width;  /* S, 1..BNN_SIREN_MAX */
    uint32_t hidden_width; /* H, 1..BNN_HIDDEN_MAX */
    uint32_t n_bayes;      /* L, 1..BNN_LAYERS_MAX */
    uint32_t max_batch;    /* 1..BNN_MAX_BATCH: largest n accepted by bnn_loss_grad */
    float w0;              /* SIREN frequency, default 30 */
    float rho_init;        /* default -3 */
    float prior_sigma;     /* sigma_p of the KL term, default 1 */
    uint32_t precision;    /* bnn_precision_t of the training step, default BNN_PRECISION_DEFAULT;
                              not part of a checkpoint's fingerprint (the weights are fp32) */
} bnn_config_t;

typedef struct bnn_loss {
    float bce;   /* mean binary cross-entropy over the batch */
    float kl;    /* kl_loss (sum over tensors of the mean KL), not yet weighted */
    float total; /* bce + kl_weight * kl */
} bnn_loss_t;

typedef struct bnn_adam {
    float beta1, beta2, eps; /* 0.9, 0.999, 1e-8 */
    uint32_t t;              /* steps taken since the last reset */
} bnn_adam_t;

/* One tensor of the parameter vector (for checkpoints, quantisation, DiNNO bookkeeping). */
typedef struct bnn_tensor {
    size_t offset;     /* into the flat parameter vector */
    uint32_t rows;     /* out (1 for a bias) */
    uint32_t cols;     /* in (length for a bias) */
    bnn_group_t group; /* BNN_GROUP_MU or BNN_GROUP_RHO */
    int bayes_layer;   /* 1..L for Bayesian tensors (mu and rho), 0 SIREN, -1 output */
    int is_bias;
} bnn_tensor_t;

#define BNN_MAX_TENSORS (4u + 4u * BNN_LAYERS_MAX)

typedef struct bnn_model {
    bnn_config_t cfg;
    uint64_t seed;
    size_t n_params, n_mu, n_rho;
    size_t batch_n;      /* points of the last forward pass (internal) */
    bnn_adam_t adam[2];  /* per group */
    _Alignas(64) float arena[BNN_ARENA_FLOATS];
} bnn_model_t;

/* ---- set-up ----------------------------------------------------------------------------- */
bnn_config_t bnn_default_config(void);

/* Bytes of storage a model holds (BNN_ARENA_BYTES): the "buffer size" of this module. */
size_t bnn_get_buffer_size(void);

/* Validates cfg (NULL = default), lays out the arena, initialises theta from `seed`
 * (SIREN U(-1/in,1/in); Bayesian mu U(+-1/sqrt(fan_in)), rho = rho_init; output layer
 * U(+-1/sqrt(H))), zeroes gradients and both Adam states. Returns 0 or -EINVAL. */
FS_MUST_CHECK int bnn_init(bnn_model_t *m, const bnn_config_t *cfg, uint64_t seed);

/* ---- the parameter vector --------------------------------------------------------------- */
float *bnn_params(bnn_model_t *m);              /* n_params floats, layout above */
const float *bnn_params_const(const bnn_model_t *m);
float *bnn_grads(bnn_model_t *m);               /* same layout */
size_t bnn_n_params(const bnn_model_t *m);
size_t bnn_group_offset(const bnn_model_t *m, bnn_group_t g); /* MU: 0, RHO: n_mu, ALL: 0 */
size_t bnn_group_len(const bnn_model_t *m, bnn_group_t g);
/* Index in theta of the mu paired with rho-group element j (0 <= j < n_rho). */
size_t bnn_rho_to_mu(const bnn_model_t *m, size_t j);
/* Tensors in theta order; returns how many were written (<= BNN_MAX_TENSORS). */
size_t bnn_tensors(const bnn_model_t *m, bnn_tensor_t *out, size_t max_out);
/* The same from a configuration alone (a valid one: bnn_default_config() or a model's cfg). */
size_t bnn_tensors_cfg(const bnn_config_t *cfg, bnn_tensor_t *out, size_t max_out);

/* ---- training ----------------------------------------------------------------------------- */
/* Forward with weights freshly drawn under (seed, noise_key), BCE + kl_weight * KL, backward.
 * OVERWRITES the gradient buffer with d total / d theta (every element, both groups); the
 * caller may then add its own terms into bnn_grads() before bnn_adam_step.
 * 1 <= n <= cfg.max_batch; labels outside [0,1] or non-finite inputs give -EINVAL.
 * out may be NULL. Returns 0 or -EINVAL. */
FS_MUST_CHECK int bnn_loss_grad(bnn_model_t *m, const ai_sample_t *batch, size_t n, float kl_weight,
                          uint64_t noise_key, bnn_loss_t *out);

/* One Adam step (bias-corrected, beta1 0.9, beta2 0.999, eps 1e-8) of one group
 * (BNN_GROUP_MU or BNN_GROUP_RHO) with that group's own moments, using the current
 * gradient buffer. Returns 0 or -EINVAL. */
FS_MUST_CHECK int bnn_adam_step(bnn_model_t *m, bnn_group_t g, float lr);

/* Zero a group's Adam moments and step count (DiNNO: fresh optimiser each round). */
void bnn_adam_reset(bnn_model_t *m, bnn_group_t g);

/* bnn_loss_grad then bnn_adam_step on MU and on RHO with the same lr. */
FS_MUST_CHECK int bnn_train_step(bnn_model_t *m, const ai_sample_t *batch, size_t n, float kl_weight,
                           uint64_t noise_key, float lr, bnn_loss_t *out);

/* ---- inference ---------------------------------------------------------------------------- */
/* Monte-Carlo prediction: K forward passes (K >= 1; BNN_MC_DEFAULT_K = 50), pass k drawing its
 * weights under (seed, noise_key = seed ^ mixing of k) -- draws depend only on (model seed,
 * `seed`, k). xy: n interleaved points (x0,y0,x1,y1,...). mean[i]: mean of the K sigmoid
 * outputs; std[i]: their population standard deviation (std may be NULL). Any n >= 1 (the
 * points are processed in chunks of max_batch). Clobbers the activation scratch and the
 * sampled weights, not theta or the gradients. Returns 0 or -EINVAL. */
FS_MUST_CHECK int bnn_predict_mc(bnn_model_t *m, const float *xy, size_t n, uint32_t K, uint64_t seed,
                           float *mean, float *std);

/* Validation loss: mean per-point BCE over n samples (any n >= 1).
 * K == 0: ONE forward pass with the mean weights (eps = 0, w = mu): deterministic; this is
 *         what DiNNO's validation uses here (the reference validates with a single pass).
 * K >= 1: BCE of the MC-mean probability of K sampled passes (keyed like bnn_predict_mc),
 *         with p clamped to [1e-7, 1-1e-7].
 * Returns 0 or -EINVAL. */
FS_MUST_CHECK int bnn_eval_bce(bnn_model_t *m, const ai_sample_t *samples, size_t n, uint32_t K,
                         uint64_t seed, float *bce);

/* ---- building blocks exposed for tests and for DiNNO ---------------------------------- */
/* softplus(r) = log(1 + e^r), stable for any r. */
float bnn_softplus(float r);
/* Closed-form KL(N(mu, s) || N(0, p)) = log(p/s) + (s^2 + mu^2) / (2 p^2) - 1/2. */
double bnn_kl_normal(double mu, double s, double p);
/* kl_loss of the current theta (sum over Bayesian tensors of the mean KL), in double. */
double bnn_kl_loss(const bnn_model_t *m);

/* Forward pass only (no gradient) with the weights of the draw (seed, noise_key), or with
 * the mean weights when use_mean != 0. logits: n floats. 1 <= n <= max_batch. */
FS_MUST_CHECK int bnn_forward_logits(bnn_model_t *m, const float *xy, size_t n, int use_mean,
                               uint64_t noise_key, float *logits);

#endif /* AI_BNN_H */
