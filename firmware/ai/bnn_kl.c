/* BNN trainer, the KL prior term: sigma = softplus(rho), the KL of one weight's posterior
 * against the prior, the model's KL figure (bnn_kl_loss), and the training step's pass over
 * the Bayesian block that turns dL/dw into mu and rho gradients with the KL term, with Adam
 * fused into it for bnn_train_step. bnn_int.h: the layout and the notes (the gradients).
 */
#include "ai/bnn.h"

#include <math.h>

#include "ai/ai_fastmath.h"
#include "ai/bnn_int.h"

/* ---- math helpers ----------------------------------------------------------------------- */
float bnn_softplus(float r)
{
    return ai_fm_softplusf(r);
}

double bnn_kl_normal(double mu, double s, double p)
{
    return log(p / s) + (s * s + mu * mu) / (2.0 * p * p) - 0.5;
}

double bnn_kl_loss(const bnn_model_t *m)
{
    if (!m)
        return 0.0;
    bnn_layout_t y;
    bnn_make_layout(&m->cfg, &y);
    const float *mu = m->arena + y.bay, *rho = m->arena + y.n_mu;
    const double p = m->cfg.prior_sigma;
    double total = 0.0;
    for (size_t l = 0; l < y.L; l++) {
        size_t o = y.lay_off[l], nw = y.H * y.lay_in[l];
        size_t seg[2][2] = {{o, nw}, {o + nw, y.H}};
        for (int t = 0; t < 2; t++) {
            double s = 0.0;
            for (size_t j = seg[t][0]; j < seg[t][0] + seg[t][1]; j++)
                s += bnn_kl_normal(mu[j], bnn_softplus(rho[j]), p);
            total += s / (double)seg[t][1];
        }
    }
    return total;
}

/* One Adam update, the same arithmetic as adam_update's loop body (bnn_train.c; so the
 * same bits). */
static inline __attribute__((always_inline)) void adam_elem(float *th, float gi, float *am,
                                                            float *av, float b1, float b2,
                                                            float ep, float step, float isb2)
{
    const float c1 = 1.0f - b1, c2 = 1.0f - b2;
    const float mi = b1 * *am + c1 * gi;
    const float vi = b2 * *av + c2 * gi * gi;
    *am = mi;
    *av = vi;
    *th -= step * mi / (ai_fm_sqrtf(vi) * isb2 + ep);
}

/* Element k of the pass below: its mu and rho gradients (from dL/dw in gmu), Adam on both with
 * af's constants when fuse (a constant in every caller, so the loops stay branch-free: 0, or
 * KL_ADAM, or KL_ADAM_QUIET), and its KL term (0 with KL_ADAM_QUIET: no caller wants the
 * figure, and its logarithm is the pass's costliest function). */
enum { KL_ADAM = 1, KL_ADAM_QUIET = 2 };
#define KL_STREAMS                                                                             \
    float *restrict mu, float *restrict rho, float *restrict gmu, float *restrict grho,       \
        const float *restrict eps, const float *restrict sig, float *restrict am_mu,          \
        float *restrict av_mu, float *restrict am_rho, float *restrict av_rho
#define KL_STREAM_ARGS mu, rho, gmu, grho, eps, sig, am_mu, av_mu, am_rho, av_rho
static inline __attribute__((always_inline)) float kl_elem(size_t k, KL_STREAMS, float c,
                                                           float ip2, float logp, const int fuse,
                                                           const bnn_adam_fused_t *af)
{
    const float r = rho[k], s = sig[k], u = mu[k];
    const float e = ai_fm_expf(-fabsf(r));
    const float iv = 1.0f / ((1.0f + e) * s); /* one division for 1/s and sigmoid */
    const float sg = ai_fm_sel(r >= 0.0f, 1.0f, e) * (iv * s);
    const float gw = gmu[k];
    const float gr = (gw * eps[k] + c * (s * ip2 - iv * (1.0f + e))) * sg;
    const float gm = gw + c * u * ip2;
    grho[k] = gr;
    gmu[k] = gm;
    if (fuse) {
        adam_elem(&mu[k], gm, &am_mu[k], &av_mu[k], af->b1, af->b2, af->ep, af->step_mu,
                  af->isb2_mu);
        adam_elem(&rho[k], gr, &am_rho[k], &av_rho[k], af->b1, af->b2, af->ep, af->step_rho,
                  af->isb2_rho);
    }
    if (fuse == KL_ADAM_QUIET)
        return 0.0f;
    return logp - ai_fm_logf(s) + 0.5f * (s * s + u * u) * ip2 - 0.5f;
}

/* Reparameterisation and KL over one Bayesian tensor of cnt elements (the streams at its first
 * one): turns dL/dw (in the mu gradient) into mu and rho gradients with the KL term, and with
 * fuse (bnn_train_step) applies Adam to the tensor's mu and rho at once. Returns the tensor's
 * KL sum. */
static inline __attribute__((always_inline)) double kl_pass(size_t cnt, KL_STREAMS, float c,
                                                            float ip2, float logp, const int fuse,
                                                            const bnn_adam_fused_t *af)
{
    size_t j = 0;
    if (fuse == KL_ADAM_QUIET) { /* the same elements, no sums (16 a time: see below) */
        for (; j + 16 <= cnt; j += 16)
            for (size_t q = 0; q < 16; q++)
                (void)kl_elem(j + q, KL_STREAM_ARGS, c, ip2, logp, fuse, af);
        for (; j < cnt; j++)
            (void)kl_elem(j, KL_STREAM_ARGS, c, ip2, logp, fuse, af);
        return 0.0;
    }
    float acc[8] = {0};
    /* 16 elements per iteration so the pass runs in 512-bit vectors where there are some (at 8
     * GCC took ymm and spilled); the KL terms still go into the 8 partial sums in the order of
     * the 8-wide loop below, so the KL figure keeps its bits */
    for (; j + 16 <= cnt; j += 16) {
        float t[16];
        for (size_t q = 0; q < 16; q++)
            t[q] = kl_elem(j + q, KL_STREAM_ARGS, c, ip2, logp, fuse, af);
        for (size_t q = 0; q < 8; q++)
            acc[q] += t[q];
        for (size_t q = 0; q < 8; q++)
            acc[q] += t[8 + q];
    }
    for (; j + 8 <= cnt; j += 8)
        for (size_t q = 0; q < 8; q++)
            acc[q] += kl_elem(j + q, KL_STREAM_ARGS, c, ip2, logp, fuse, af);
    double kl = 0.0;
    for (; j < cnt; j++)
        kl += kl_elem(j, KL_STREAM_ARGS, c, ip2, logp, fuse, af);
    for (int q = 0; q < 8; q++)
        kl += acc[q];
    return kl;
}

/* Not inlined: the restrict parameters are what lets GCC vectorise 10 streams without a
 * run-time alias check per pair (inlined, it gave up on the fused one). Clones are never
 * inlined, and clang refuses noinline beside target_clones. */
#if defined(AI_WIDE_CLONES) || !defined(__GNUC__)
#define KL_NOINLINE
#else
#define KL_NOINLINE __attribute__((noinline))
#endif
AI_WIDE KL_NOINLINE static double kl_pass_plain(size_t cnt, KL_STREAMS, float c, float ip2,
                                                float logp)
{
    return kl_pass(cnt, KL_STREAM_ARGS, c, ip2, logp, 0, NULL);
}

AI_WIDE KL_NOINLINE static double kl_pass_adam(size_t cnt, KL_STREAMS, float c, float ip2,
                                               float logp, const bnn_adam_fused_t *af)
{
    return kl_pass(cnt, KL_STREAM_ARGS, c, ip2, logp, KL_ADAM, af);
}

AI_WIDE KL_NOINLINE static double kl_pass_adam_quiet(size_t cnt, KL_STREAMS, float c, float ip2,
                                                     float logp, const bnn_adam_fused_t *af)
{
    return kl_pass(cnt, KL_STREAM_ARGS, c, ip2, logp, KL_ADAM_QUIET, af);
}

/* The pass over the tensor [j0, j0 + cnt) of the Bayesian block; af: Adam fused (or NULL);
 * want_kl: the KL sum is wanted (else 0 is returned; only with af). */
double bnn_kl_tensor_grad(bnn_model_t *m, const bnn_layout_t *y, size_t j0, size_t cnt,
                          float kl_weight, const bnn_adam_fused_t *af, int want_kl)
{
    float *a = m->arena;
    const float p = m->cfg.prior_sigma, ip2 = 1.0f / (p * p), logp = logf(p);
    const float c = kl_weight / (float)cnt;
    float *mu = a + y->bay + j0, *rho = a + y->n_mu + j0;
    float *gmu = a + y->grads + y->bay + j0, *grho = a + y->grads + y->n_mu + j0;
    const float *eps = a + y->eps + j0, *sig = a + y->sigma + j0;
    if (!af)
        return kl_pass_plain(cnt, mu, rho, gmu, grho, eps, sig, NULL, NULL, NULL, NULL, c, ip2,
                             logp);
    if (!want_kl)
        return kl_pass_adam_quiet(cnt, mu, rho, gmu, grho, eps, sig, af->am_mu + j0,
                                  af->av_mu + j0, af->am_rho + j0, af->av_rho + j0, c, ip2, logp,
                                  af);
    return kl_pass_adam(cnt, mu, rho, gmu, grho, eps, sig, af->am_mu + j0, af->av_mu + j0,
                        af->am_rho + j0, af->av_rho + j0, c, ip2, logp, af);
}
