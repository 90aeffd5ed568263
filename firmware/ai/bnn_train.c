/* BNN trainer, the training step: the backward of a sampled forward (data term), the loss and
 * its gradients (bnn_loss_grad), Adam per group, and bnn_train_step, which fuses Adam into the
 * KL pass (bnn_kl.c). bnn_int.h: the layout and the notes (the gradients).
 */
#include "ai/bnn.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "ai/ai_fastmath.h"
#include "ai/bnn_int.h"

/* The two column-sum passes of the backward go over the batch COL_BLOCK columns at a time, so
 * that the sums stay in registers instead of being loaded and stored for every row; each
 * column still sums its rows in ascending order, the same bits as row by row. */
#define COL_BLOCK 64u

/* Columns [k0, k0 + kn) of the output layer's delta, cur = (h_L > 0) dl w_out, its column sums
 * into gb (the last Bayesian layer's bias gradient) and dL/dw_out = sum_i dl_i h_L,i into gwo. */
static inline __attribute__((always_inline)) void
out_delta_cols(const size_t kn, size_t k0, size_t n, size_t H, const float *hL, const float *dl,
               const float *wout, float *cur, float *gb, float *gwo)
{
    float sb[COL_BLOCK] = {0}, sw[COL_BLOCK] = {0};
    const float *restrict wo = wout + k0;
    for (size_t i = 0; i < n; i++) {
        const float *restrict hr = hL + i * H + k0;
        float *restrict cr = cur + i * H + k0;
        const float d = dl[i];
        for (size_t k = 0; k < kn; k++) {
            const float v = ai_fm_sel(hr[k] > 0.0f, d * wo[k], 0.0f);
            cr[k] = v;
            sb[k] += v;
            sw[k] += d * hr[k];
        }
    }
    for (size_t k = 0; k < kn; k++) {
        gb[k0 + k] = sb[k];
        gwo[k0 + k] = sw[k];
    }
}

/* Columns [k0, k0 + kn) of the SIREN layer's gradients: dz = dh0 w0 cos(z) summed into the
 * bias gradient gb0, and dW0 = dz^T xy into g[2k], g[2k + 1] (per input coordinate, so the loop
 * stays unit-stride). */
static inline __attribute__((always_inline)) void
siren_grad_cols(const size_t kn, size_t k0, size_t n, size_t S, float w0, const float *xy,
                const float *cos0, const float *dh0, float *gb0, float *g)
{
    float sb[COL_BLOCK] = {0}, gx[COL_BLOCK] = {0}, gy[COL_BLOCK] = {0};
    for (size_t i = 0; i < n; i++) {
        const float *restrict cr0 = cos0 + i * S + k0;
        const float *restrict orow = dh0 + i * S + k0;
        const float px = xy[2 * i], py = xy[2 * i + 1];
        for (size_t k = 0; k < kn; k++) {
            const float v = orow[k] * (w0 * cr0[k]);
            sb[k] += v;
            gx[k] += v * px;
            gy[k] += v * py;
        }
    }
    for (size_t k = 0; k < kn; k++) {
        gb0[k0 + k] = sb[k];
        g[2 * (k0 + k)] = gx[k];
        g[2 * (k0 + k) + 1] = gy[k];
    }
}

/* Backward of the last forward (sampled weights), data term only: fills every gradient of
 * the mu group (the Bayesian entries hold dL/dw) from dlogit. */
AI_WIDE static void backward(bnn_model_t *m, const bnn_layout_t *y, size_t n)
{
    float *a = m->arena;
    float *g = a + y->grads;
    const size_t S = y->S, H = y->H;
    const float *restrict dl = a + y->dlogit;
    const float *restrict wout = a + y->wout;
    const float *hL = a + y->h + (y->L - 1) * BNN_MAX_BATCH * H;

    double sb = 0.0;
    for (size_t i = 0; i < n; i++)
        sb += dl[i];
    g[y->bout] = (float)sb;

    /* Each pass that produces a layer's delta (d total / d pre-activation) also sums its
     * columns into that layer's bias gradient, so the delta is read once less. */
    float *cur = a + y->g1, *oth = a + y->g2;
    {
        /* also the output layer's weight gradient, dL/dw_out = sum_i dl_i h_L,i */
        float *gb = g + y->bay + y->lay_off[y->L - 1] + H * y->lay_in[y->L - 1];
        size_t k0 = 0;
        for (; k0 + COL_BLOCK <= H; k0 += COL_BLOCK)
            out_delta_cols(COL_BLOCK, k0, n, H, hL, dl, wout, cur, gb, g + y->wout);
        if (k0 < H)
            out_delta_cols(H - k0, k0, n, H, hL, dl, wout, cur, gb, g + y->wout);
    }
    for (size_t l = y->L; l-- > 0;) {
        const size_t in = y->lay_in[l];
        const float *prev = l == 0 ? a + y->h0 : a + y->h + (l - 1) * BNN_MAX_BATCH * H;
        const float *Wl = a + y->wsamp + y->lay_off[l];
        float *gW = g + y->bay + y->lay_off[l];
        bnn_step_gemm(m, 1, LA_TRANS, LA_NO_TRANS, H, in, n, cur, H, prev, in, gW, in,
                      NULL);
        /* bias gradient of the layer below: layer l-1's b, or the SIREN b0 */
        float *restrict gbp = l > 0 ? g + y->bay + y->lay_off[l - 1] + H * y->lay_in[l - 1]
                                    : g + 2 * S;
        for (size_t k = 0; k < in; k++)
            gbp[k] = 0.0f;
        if (l > 0) {
            /* the delta of layer l-1: (da W) gated by its ReLU (h_{l-1} > 0), its columns
             * summed into the bias gradient, on the tiles */
            const la_epilogue_t ep = {.gate = prev, .ldg = (int)in, .colsum = gbp};
            bnn_step_gemm(m, 1, LA_NO_TRANS, LA_NO_TRANS, n, in, H, cur, H, Wl, in, oth, in,
                          &ep);
        } else {
            bnn_step_gemm(m, 1, LA_NO_TRANS, LA_NO_TRANS, n, in, H, cur, H, Wl, in, oth, in,
                          NULL);
            /* SIREN: dz = dh0 * w0 cos(z) is the bias gradient's summand, and dW0 [S x 2] =
             * dz^T xy is summed in the same pass, per input coordinate (gx, gy, so the loop
             * stays unit-stride) */
            const float w0 = m->cfg.w0;
            size_t k0 = 0;
            for (; k0 + COL_BLOCK <= in; k0 += COL_BLOCK)
                siren_grad_cols(COL_BLOCK, k0, n, in, w0, a + y->xy, a + y->cos0, oth, gbp, g);
            if (k0 < in)
                siren_grad_cols(in - k0, k0, n, in, w0, a + y->xy, a + y->cos0, oth, gbp, g);
        }
        float *t = cur;
        cur = oth;
        oth = t;
    }
}

/* bnn_loss_grad; with af, Adam on the Bayesian block inside the KL pass (bnn_train_step).
 * Without out (and with af) the loss figures are not computed: the gradients do not need the
 * BCE and KL sums, only their derivatives. */
static int loss_grad(bnn_model_t *m, const ai_sample_t *batch, size_t n, float kl_weight,
                     uint64_t noise_key, bnn_loss_t *out, const bnn_adam_fused_t *af)
{
    if (!m || !batch || n == 0 || n > m->cfg.max_batch || !isfinite(kl_weight) || kl_weight < 0.0f)
        return -EINVAL;
    if (!bnn_samples_ok(batch, n))
        return -EINVAL;
    bnn_layout_t y;
    bnn_make_layout(&m->cfg, &y);
    float *a = m->arena;
    float *xy = a + y.xy;
    for (size_t i = 0; i < n; i++) {
        xy[2 * i] = batch[i].x;
        xy[2 * i + 1] = batch[i].y;
    }
    bnn_sample_weights(m, &y, noise_key, 0);
    bnn_forward_pass(m, &y, a + y.wsamp, n, 1);
    const float *logit = a + y.logit;
    float *dl = a + y.dlogit;
    double bce = 0.0;
    const float inv_n = 1.0f / (float)n;
    for (size_t i = 0; i < n; i++) {
        const double l = logit[i], t = batch[i].occ;
        if (out)
            bce += bnn_bce_logit(l, t);
        const double p = 1.0 / (1.0 + exp(-l));
        dl[i] = (float)(p - t) * inv_n;
    }
    bce /= (double)n;
    m->batch_n = n;
    backward(m, &y, n);
    double kl = 0.0;
    for (size_t l = 0; l < y.L; l++) {
        const size_t nw = y.H * y.lay_in[l];
        const double klw =
            bnn_kl_tensor_grad(m, &y, y.lay_off[l], nw, kl_weight, af, out != NULL);
        const double klb =
            bnn_kl_tensor_grad(m, &y, y.lay_off[l] + nw, y.H, kl_weight, af, out != NULL);
        kl += klw / (double)nw + klb / (double)y.H;
    }
    if (out) {
        out->bce = (float)bce;
        out->kl = (float)kl;
        out->total = (float)(bce + (double)kl_weight * kl);
    }
    return 0;
}

int bnn_loss_grad(bnn_model_t *m, const ai_sample_t *batch, size_t n, float kl_weight,
                  uint64_t noise_key, bnn_loss_t *out)
{
    return loss_grad(m, batch, n, kl_weight, noise_key, out, NULL);
}

AI_WIDE static void adam_update(float *restrict th, const float *restrict gr, float *restrict am,
                                float *restrict av, size_t len, float b1, float b2, float ep,
                                float step, float isb2)
{
    const float c1 = 1.0f - b1, c2 = 1.0f - b2;
    for (size_t i = 0; i < len; i++) {
        const float gi = gr[i];
        const float mi = b1 * am[i] + c1 * gi;
        const float vi = b2 * av[i] + c2 * gi * gi;
        am[i] = mi;
        av[i] = vi;
        th[i] -= step * mi / (ai_fm_sqrtf(vi) * isb2 + ep);
    }
}

/* The next Adam step of group g: its counter advanced, the bias-corrected step and
 * 1/sqrt(1 - beta2^t). */
static void adam_next(bnn_model_t *m, bnn_group_t g, float lr, float *step, float *isb2)
{
    bnn_adam_t *st = &m->adam[g];
    st->t++;
    const double bc1 = 1.0 - pow((double)st->beta1, (double)st->t);
    const double bc2 = 1.0 - pow((double)st->beta2, (double)st->t);
    *step = (float)((double)lr / bc1);
    *isb2 = (float)(1.0 / sqrt(bc2));
}

int bnn_adam_step(bnn_model_t *m, bnn_group_t g, float lr)
{
    if (!m || (g != BNN_GROUP_MU && g != BNN_GROUP_RHO) || !isfinite(lr) || lr < 0.0f)
        return -EINVAL;
    const bnn_adam_t *st = &m->adam[g];
    const size_t off = bnn_group_offset(m, g), len = bnn_group_len(m, g), P = m->n_params;
    float *restrict th = m->arena + off;
    const float *restrict gr = m->arena + P + off;
    float *restrict am = m->arena + 2 * P + off;
    float *restrict av = m->arena + 3 * P + off;
    float step, isb2;
    adam_next(m, g, lr, &step, &isb2);
    adam_update(th, gr, am, av, len, st->beta1, st->beta2, st->eps, step, isb2);
    return 0;
}

void bnn_adam_reset(bnn_model_t *m, bnn_group_t g)
{
    if (!m || (g != BNN_GROUP_MU && g != BNN_GROUP_RHO))
        return;
    const size_t off = bnn_group_offset(m, g), len = bnn_group_len(m, g), P = m->n_params;
    memset(m->arena + 2 * P + off, 0, len * sizeof(float));
    memset(m->arena + 3 * P + off, 0, len * sizeof(float));
    m->adam[g].t = 0;
}

int bnn_train_step(bnn_model_t *m, const ai_sample_t *batch, size_t n, float kl_weight,
                   uint64_t noise_key, float lr, bnn_loss_t *out)
{
    /* Adam inside the KL pass when both groups share their hyper-parameters (always, unless a
     * caller changed one group's): the same arithmetic per element, so the same bits as
     * bnn_loss_grad and two bnn_adam_step; the mu entries outside the Bayesian block (SIREN,
     * output layer) after it. Anything invalid takes the plain path and its error codes. */
    const bnn_adam_t *s0 = m ? &m->adam[BNN_GROUP_MU] : NULL, *s1 = m ? &m->adam[BNN_GROUP_RHO] : NULL;
    if (m && isfinite(lr) && lr >= 0.0f && s0->beta1 == s1->beta1 && s0->beta2 == s1->beta2 &&
        s0->eps == s1->eps) {
        const size_t P = m->n_params, nmu = m->n_mu, bay = 3u * (size_t)m->cfg.siren_width;
        const bnn_adam_t st0 = *s0, st1 = *s1;
        bnn_adam_fused_t af = {m->arena + 2 * P + bay, m->arena + 3 * P + bay,
                               m->arena + 2 * P + nmu, m->arena + 3 * P + nmu, s0->beta1,
                               s0->beta2, s0->eps, 0, 0, 0, 0};
        adam_next(m, BNN_GROUP_MU, lr, &af.step_mu, &af.isb2_mu);
        adam_next(m, BNN_GROUP_RHO, lr, &af.step_rho, &af.isb2_rho);
        int rc = loss_grad(m, batch, n, kl_weight, noise_key, out, &af);
        if (rc) { /* nothing was changed but the counters */
            m->adam[BNN_GROUP_MU] = st0;
            m->adam[BNN_GROUP_RHO] = st1;
            return rc;
        }
        /* the mu group around the Bayesian block: SIREN [0, bay), output layer [bay + R, n_mu) */
        const size_t rest = bay + m->n_rho;
        float *a = m->arena;
        adam_update(a, a + P, a + 2 * P, a + 3 * P, bay, af.b1, af.b2, af.ep, af.step_mu,
                    af.isb2_mu);
        adam_update(a + rest, a + P + rest, a + 2 * P + rest, a + 3 * P + rest, nmu - rest, af.b1,
                    af.b2, af.ep, af.step_mu, af.isb2_mu);
        return 0;
    }
    int rc = bnn_loss_grad(m, batch, n, kl_weight, noise_key, out);
    if (rc)
        return rc;
    rc = bnn_adam_step(m, BNN_GROUP_MU, lr);
    if (rc)
        return rc;
    return bnn_adam_step(m, BNN_GROUP_RHO, lr);
}
