/* Private to the files of the BNN trainer, not part of its API (bnn.h):
 *   bnn.c          the model: configuration, arena layout, initialisation, parameter access,
 *                  the tensor list;
 *   bnn_forward.c  weight sampling and the forward pass (of the training step and of
 *                  inference); inference: logits, MC prediction, validation BCE;
 *   bnn_train.c    the training step: backward, loss and gradients, Adam, bnn_train_step;
 *   bnn_kl.c       the KL prior term: its figures (bnn_kl_loss) and the pass that turns dL/dw
 *                  into mu and rho gradients with the KL term (Adam fused in for the step).
 * The hot loops of each pass stay in one file: the helpers several files share are static
 * inline below, so each file inlines them as it did when the trainer was one file.
 *
 * Implementation notes (why it looks the way it does):
 * - Activations are row-major [n x width]; a Bayesian layer's forward is ONE GEMM
 *   h_l = h_{l-1} W^T (la_sgemm N,T), its backward two GEMMs: dW = da^T h_{l-1} (T,N) and
 *   dh_{l-1} = da W (N,N). Everything else is a fused elementwise pass written so GCC
 *   vectorises it (ai_fastmath.h instead of libm calls in hot loops).
 * - The Bayesian mu block of theta (after the SIREN tensors) and the rho group have the same
 *   element order, so rho element j pairs with theta[3S + j]; the sampled weights, eps and
 *   sigma buffers use that order too, and one pass over j does sampling (forward) or the
 *   reparameterisation + KL gradient (backward).
 * - d total / d rho = (dL/dw * eps + c * (sigma/p^2 - 1/sigma)) * sigmoid(rho),
 *   d total / d mu   =  dL/dw + c * mu / p^2,     c = kl_weight / (elements of the tensor),
 *   using KL = log(p/s) + (s^2 + mu^2)/(2p^2) - 1/2 and d softplus / d rho = sigmoid(rho).
 */
#ifndef AI_BNN_INT_H
#define AI_BNN_INT_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "ai/ai_fastmath.h"
#include "ai/ai_rng.h"
#include "ai/ai_sample.h"
#include "ai/bnn.h"
#include "ai/kernels/la.h"
#include "ai/kernels/la_bf16.h"

#define BNN_SEED_SALT 0xB4B1ull /* model seed -> Philox key */

/* Where everything of a model of config c lives: in theta (the Bayesian block, each layer's
 * W within it, the output layer) and in the arena (floats). */
typedef struct bnn_layout {
    size_t S, H, L, B, W;            /* widths, layers, max batch, max(S,H) */
    size_t lay_off[BNN_LAYERS_MAX];  /* layer l's W within the Bayesian block / rho group */
    size_t lay_in[BNN_LAYERS_MAX];
    size_t R;                        /* Bayesian block length = n_rho */
    size_t bay;                      /* theta offset of the Bayesian mu block (3S) */
    size_t wout, bout, n_mu, P;
    /* arena regions (floats) */
    size_t grads, am, av, wsamp, eps, sigma, xy, cos0, h0, h, g1, g2, logit, dlogit;
} bnn_layout_t;

static inline void bnn_make_layout(const bnn_config_t *c, bnn_layout_t *y)
{
    y->S = c->siren_width;
    y->H = c->hidden_width;
    y->L = c->n_bayes;
    y->B = c->max_batch;
    y->W = y->S > y->H ? y->S : y->H;
    size_t off = 0;
    for (size_t l = 0; l < y->L; l++) {
        y->lay_off[l] = off;
        y->lay_in[l] = l == 0 ? y->S : y->H;
        off += y->lay_in[l] * y->H + y->H;
    }
    y->R = off;
    y->bay = 3 * y->S;
    y->wout = y->bay + y->R;
    y->bout = y->wout + y->H;
    y->n_mu = y->bout + 1;
    y->P = y->n_mu + y->R;
    y->grads = y->P;
    y->am = 2 * y->P;
    y->av = 3 * y->P;
    y->wsamp = 4 * y->P;
    y->eps = y->wsamp + y->R;
    y->sigma = y->eps + y->R;
    /* Activations are sized for the preset batch so a smaller runtime config never overlaps. */
    const size_t B = BNN_MAX_BATCH;
    y->xy = y->sigma + y->R;
    y->cos0 = y->xy + 2 * B;
    y->h0 = y->cos0 + B * y->S;
    y->h = y->h0 + B * y->S;
    y->g1 = y->h + B * y->L * y->H;
    y->g2 = y->g1 + B * y->W;
    y->logit = y->g2 + B * y->W;
    y->dlogit = y->logit + B;
}

/* The SIREN layer of n points xy (interleaved): h0 = sin(w0 (W0 x + b0)) and its cosine c0
 * (for the backward pass), rows of S. Inline, so the forward pass and the posterior's
 * features (bnn_post.c) are one expression. */
static inline void bnn_siren_rows(const float *restrict W0, const float *restrict b0, float w0, size_t S,
                                  const float *restrict xy, size_t n, float *restrict h0, float *restrict c0)
{
    for (size_t i = 0; i < n; i++) {
        const float px = xy[2 * i], py = xy[2 * i + 1];
        float *hr = h0 + i * S, *cr = c0 + i * S;
        for (size_t j = 0; j < S; j++) {
            float t = w0 * (W0[2 * j] * px + W0[2 * j + 1] * py + b0[j]);
            float s, c;
            ai_fm_sincosf(t, &s, &c);
            hr[j] = s;
            cr[j] = c;
        }
    }
}

static inline uint64_t bnn_philox_key(const bnn_model_t *m)
{
    return ai_rng_mix64(m->seed ^ BNN_SEED_SALT);
}

/* The large products of the training step (a Bayesian layer's forward, dX, dW): bf16 products
 * with fp32 sums when the model asks for them and `step` says this is the step, not an
 * inference pass (la_bf16.h); else la_sgemm_ep. alpha 1, beta 0 both ways. */
static inline void bnn_step_gemm(const bnn_model_t *m, int step, la_trans_t ta, la_trans_t tb,
                                 size_t M, size_t N, size_t K, const float *A, size_t lda,
                                 const float *B, size_t ldb, float *C, size_t ldc,
                                 const la_epilogue_t *ep)
{
    if (step && m->cfg.precision == BNN_PRECISION_BF16)
        la_bf16_gemm(ta, tb, (int)M, (int)N, (int)K, A, (int)lda, B, (int)ldb, C, (int)ldc, ep);
    else
        la_sgemm_ep(ta, tb, (int)M, (int)N, (int)K, 1.0f, A, (int)lda, B, (int)ldb, 0.0f, C,
                    (int)ldc, ep);
}

static inline double bnn_bce_logit(double l, double t)
{
    /* max(l,0) - l t + log(1 + e^-|l|): never overflows */
    return (l > 0.0 ? l : 0.0) - l * t + log1p(exp(-fabs(l)));
}

static inline int bnn_samples_ok(const ai_sample_t *s, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(s[i].x) || !isfinite(s[i].y) || !(s[i].occ >= 0.0f && s[i].occ <= 1.0f))
            return 0;
    return 1;
}

/* ---- across the files (bnn_forward.c, bnn_kl.c) ----------------------------------------- */

/* bnn_forward.c */
void bnn_sample_weights(bnn_model_t *m, const bnn_layout_t *y, uint64_t noise_key,
                        int sigma_ready);
void bnn_forward_pass(bnn_model_t *m, const bnn_layout_t *y, const float *wb, size_t n,
                      int step);

/* bnn_kl.c. Adam on both groups (bnn_adam_step), done inside the KL pass by bnn_train_step:
 * the pass already holds each Bayesian element's mu, rho and both gradients in registers, so
 * the separate Adam passes' reads of theta and the gradients over the block (2 x 4 streams of
 * the block's length) go. Pointers are at the block's element 0. */
typedef struct bnn_adam_fused {
    float *am_mu, *av_mu, *am_rho, *av_rho;
    float b1, b2, ep, step_mu, isb2_mu, step_rho, isb2_rho;
} bnn_adam_fused_t;

double bnn_kl_tensor_grad(bnn_model_t *m, const bnn_layout_t *y, size_t j0, size_t cnt,
                          float kl_weight, const bnn_adam_fused_t *af, int want_kl);

#endif /* AI_BNN_INT_H */
