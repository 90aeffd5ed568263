/* BNN trainer, the forward side: the sampled weights (w = mu + softplus(rho) eps), the forward
 * pass of the training step and of inference, and inference itself (logits, the MC predictive
 * mean and std, the validation BCE). bnn_int.h: the layout and the notes.
 */
#include "ai/bnn.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "ai/ai_fastmath.h"
#include "ai/ai_rng.h"
#include "ai/bnn_int.h"

/* sigma = softplus(rho), w = mu + sigma * eps over the Bayesian block, in ONE pass: the
 * Gaussians are drawn a tile at a time (Philox is counter-based, so drawing numbers
 * [j0, j0 + tile) separately gives exactly the numbers of one fill of the whole block) and
 * each tile is consumed while it is still in L1. sigma_ready: the sigma buffer already holds
 * softplus(rho) of the current rho (the 2nd..Kth pass of an MC inference), only w is drawn. */
#define SAMPLE_TILE 2048u
/* partial sums of the output layer's dot products (one 512-bit vector, or two 256-bit ones) */
#define OUT_LANES 16u
AI_WIDE static void sample_weights(bnn_model_t *m, const bnn_layout_t *y, uint64_t noise_key,
                               int sigma_ready)
{
    float *restrict eps = m->arena + y->eps;
    float *restrict sig = m->arena + y->sigma;
    float *restrict w = m->arena + y->wsamp;
    const float *restrict mu = m->arena + y->bay;
    const float *restrict rho = m->arena + y->n_mu;
    const uint64_t key = bnn_philox_key(m);
    const size_t R = y->R;
    for (size_t j0 = 0; j0 < R; j0 += SAMPLE_TILE) {
        const size_t j1 = R - j0 < SAMPLE_TILE ? R : j0 + SAMPLE_TILE;
        ai_rng_normal_fill(key, noise_key, j0, eps + j0, j1 - j0);
        if (sigma_ready) {
            for (size_t j = j0; j < j1; j++)
                w[j] = mu[j] + sig[j] * eps[j];
            continue;
        }
        for (size_t j = j0; j < j1; j++) {
            float r = rho[j];
            float e = ai_fm_expf(-fabsf(r));
            float s = ai_fm_sel(r > 0.0f, r, 0.0f) + ai_fm_log1pf(e);
            sig[j] = s;
            w[j] = mu[j] + s * eps[j];
        }
    }
}

/* Forward of n points whose inputs are in the arena's xy buffer; wb = Bayesian block of the
 * weights to use (sampled or mu); step: a training step's forward (its precision applies).
 * Leaves cos0, h0, h_l and logits in the arena. */
AI_WIDE static void forward_pass(bnn_model_t *m, const bnn_layout_t *y, const float *wb, size_t n,
                             int step)
{
    float *a = m->arena;
    const size_t S = y->S, H = y->H;
    const float w0 = m->cfg.w0;
    const float *restrict W0 = a, *restrict b0 = a + 2 * S;
    float *restrict h0 = a + y->h0;
    bnn_siren_rows(W0, b0, w0, S, a + y->xy, n, h0, a + y->cos0);
    const float *prev = h0;
    float *restrict logit = a + y->logit;
    const float *restrict wout = a + y->wout;
    const float bo = a[y->bout];
    for (size_t l = 0; l < y->L; l++) {
        const size_t in = y->lay_in[l];
        const float *Wl = wb + y->lay_off[l];
        const float *restrict bl = Wl + H * in;
        float *restrict hl = a + y->h + l * BNN_MAX_BATCH * H;
        if (l + 1 < y->L) { /* h_l = relu(h_{l-1} W^T + b), bias and ReLU on the tiles */
            const la_epilogue_t ep = {.bias = bl, .relu = 1};
            bnn_step_gemm(m, step, LA_NO_TRANS, LA_TRANS, n, H, in, prev, in, Wl, in, hl, H, &ep);
        } else {
            bnn_step_gemm(m, step, LA_NO_TRANS, LA_TRANS, n, H, in, prev, in, Wl, in, hl, H,
                          NULL);
            /* the last layer's bias + ReLU pass also computes the output layer, logit =
             * h_L . w_out + b_out, in OUT_LANES partial sums (so it vectorises) */
            for (size_t i = 0; i < n; i++) {
                float *r = hl + i * H;
                float acc[OUT_LANES] = {0};
                size_t j = 0;
                for (; j + OUT_LANES <= H; j += OUT_LANES)
                    for (size_t q = 0; q < OUT_LANES; q++) {
                        float v = r[j + q] + bl[j + q];
                        v = v > 0.0f ? v : 0.0f;
                        r[j + q] = v;
                        acc[q] += v * wout[j + q];
                    }
                float dot = 0.0f;
                for (; j < H; j++) {
                    float v = r[j] + bl[j];
                    v = v > 0.0f ? v : 0.0f;
                    r[j] = v;
                    dot += v * wout[j];
                }
                for (size_t q = 0; q < OUT_LANES; q++)
                    dot += acc[q];
                logit[i] = dot + bo;
            }
        }
        prev = hl;
    }
}

/* ---- inference ---------------------------------------------------------------------------- */
static uint64_t mc_key(uint64_t seed, uint32_t k)
{
    return ai_rng_mix64(seed) + (uint64_t)k;
}

static int xy_ok(const float *xy, size_t n)
{
    for (size_t i = 0; i < 2 * n; i++)
        if (!isfinite(xy[i]))
            return 0;
    return 1;
}

int bnn_forward_logits(bnn_model_t *m, const float *xy, size_t n, int use_mean, uint64_t noise_key,
                       float *logits)
{
    if (!m || !xy || !logits || n == 0 || n > m->cfg.max_batch || !xy_ok(xy, n))
        return -EINVAL;
    bnn_layout_t y;
    bnn_make_layout(&m->cfg, &y);
    memcpy(m->arena + y.xy, xy, 2 * n * sizeof(float));
    if (!use_mean)
        sample_weights(m, &y, noise_key, 0);
    forward_pass(m, &y, use_mean ? m->arena + y.bay : m->arena + y.wsamp, n, 0);
    memcpy(logits, m->arena + y.logit, n * sizeof(float));
    return 0;
}

int bnn_predict_mc(bnn_model_t *m, const float *xy, size_t n, uint32_t K,
                                  uint64_t seed, float *mean, float *std)
{
    if (!m || !xy || !mean || n == 0 || K == 0 || !xy_ok(xy, n))
        return -EINVAL;
    bnn_layout_t y;
    bnn_make_layout(&m->cfg, &y);
    float *a = m->arena;
    for (size_t i = 0; i < n; i++)
        mean[i] = 0.0f;
    if (std)
        for (size_t i = 0; i < n; i++)
            std[i] = 0.0f; /* holds Welford's M2 until the end */
    const size_t B = m->cfg.max_batch;
    for (uint32_t k = 0; k < K; k++) {
        sample_weights(m, &y, mc_key(seed, k), k > 0);
        const float inv = 1.0f / (float)(k + 1);
        for (size_t c0 = 0; c0 < n; c0 += B) {
            const size_t nc = n - c0 < B ? n - c0 : B;
            memcpy(a + y.xy, xy + 2 * c0, 2 * nc * sizeof(float));
            forward_pass(m, &y, a + y.wsamp, nc, 0);
            const float *restrict lg = a + y.logit;
            float *restrict mu = mean + c0;
            float *restrict m2 = std ? std + c0 : a + y.dlogit; /* scratch when std == NULL */
            for (size_t i = 0; i < nc; i++) {
                const float l = lg[i];
                const float e = ai_fm_expf(-fabsf(l));
                const float p = ai_fm_sel(l >= 0.0f, 1.0f, e) / (1.0f + e);
                const float d = p - mu[i];
                const float mn = mu[i] + d * inv;
                mu[i] = mn;
                m2[i] += d * (p - mn);
            }
        }
    }
    if (std)
        for (size_t i = 0; i < n; i++)
            std[i] = ai_fm_sqrtf(std[i] / (float)K);
    return 0;
}

int bnn_eval_bce(bnn_model_t *m, const ai_sample_t *samples, size_t n, uint32_t K, uint64_t seed,
                 float *bce)
{
    if (!m || !samples || !bce || n == 0 || !bnn_samples_ok(samples, n))
        return -EINVAL;
    bnn_layout_t y;
    bnn_make_layout(&m->cfg, &y);
    float *a = m->arena;
    const size_t B = m->cfg.max_batch;
    double sum = 0.0;
    for (size_t c0 = 0; c0 < n; c0 += B) {
        const size_t nc = n - c0 < B ? n - c0 : B;
        for (size_t i = 0; i < nc; i++) {
            a[y.xy + 2 * i] = samples[c0 + i].x;
            a[y.xy + 2 * i + 1] = samples[c0 + i].y;
        }
        if (K == 0) {
            forward_pass(m, &y, a + y.bay, nc, 0);
            for (size_t i = 0; i < nc; i++)
                sum += bnn_bce_logit(a[y.logit + i], samples[c0 + i].occ);
            continue;
        }
        float *pm = a + y.dlogit; /* MC-mean probability of the chunk */
        for (size_t i = 0; i < nc; i++)
            pm[i] = 0.0f;
        for (uint32_t k = 0; k < K; k++) {
            sample_weights(m, &y, mc_key(seed, k), k > 0 || c0 > 0);
            forward_pass(m, &y, a + y.wsamp, nc, 0);
            for (size_t i = 0; i < nc; i++)
                pm[i] += (float)(1.0 / (1.0 + exp(-(double)a[y.logit + i])));
        }
        for (size_t i = 0; i < nc; i++) {
            double p = pm[i] / (double)K, t = samples[c0 + i].occ;
            p = p < 1e-7 ? 1e-7 : (p > 1.0 - 1e-7 ? 1.0 - 1e-7 : p);
            sum += -(t * log(p) + (1.0 - t) * log(1.0 - p));
        }
    }
    *bce = (float)(sum / (double)n);
    return 0;
}

/* For bnn_train.c: plain functions around the cloned ones. A function with clones is reached
 * through an ifunc whose symbol the compilers name differently (GCC: the function's own name,
 * clang: "<name>.ifunc"), so no cloned function is called across files. */
void bnn_sample_weights(bnn_model_t *m, const bnn_layout_t *y, uint64_t noise_key, int sigma_ready)
{
    sample_weights(m, y, noise_key, sigma_ready);
}

void bnn_forward_pass(bnn_model_t *m, const bnn_layout_t *y, const float *wb, size_t n, int step)
{
    forward_pass(m, y, wb, n, step);
}
