/* BNN trainer: see bnn.h for the contract and the parameter layout.
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
#include "ai/bnn.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "ai/ai_fastmath.h"
#include "ai/ai_rng.h"
#include "ai/la.h"
#include "ai/la_bf16.h"

_Static_assert(BNN_SIREN_MAX >= 1 && BNN_HIDDEN_MAX >= 1 && BNN_LAYERS_MAX >= 1, "preset dims");
_Static_assert(BNN_MAX_BATCH >= 1 && BNN_MAX_BATCH <= (1u << 20), "preset batch");

#define INIT_STREAM 0x1A17ull     /* stream of the initialisation uniforms */
#define SEED_SALT 0xB4B1ull      /* model seed -> Philox key */

typedef struct layout {
    size_t S, H, L, B, W;            /* widths, layers, max batch, max(S,H) */
    size_t lay_off[BNN_LAYERS_MAX];  /* layer l's W within the Bayesian block / rho group */
    size_t lay_in[BNN_LAYERS_MAX];
    size_t R;                        /* Bayesian block length = n_rho */
    size_t bay;                      /* theta offset of the Bayesian mu block (3S) */
    size_t wout, bout, n_mu, P;
    /* arena regions (floats) */
    size_t grads, am, av, wsamp, eps, sigma, xy, cos0, h0, h, g1, g2, logit, dlogit;
} layout_t;

static void make_layout(const bnn_config_t *c, layout_t *y)
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

bnn_config_t bnn_default_config(void)
{
    bnn_config_t c = {
        .siren_width = BNN_SIREN_MAX,
        .hidden_width = BNN_HIDDEN_MAX,
        .n_bayes = BNN_LAYERS_MAX,
        .max_batch = BNN_MAX_BATCH,
        .w0 = BNN_W0,
        .rho_init = BNN_RHO_INIT,
        .prior_sigma = BNN_PRIOR_SIGMA,
        .precision = BNN_PRECISION_DEFAULT,
    };
    return c;
}

size_t bnn_get_buffer_size(void)
{
    return BNN_ARENA_BYTES;
}

static int config_ok(const bnn_config_t *c)
{
    return c->siren_width >= 1 && c->siren_width <= BNN_SIREN_MAX && c->hidden_width >= 1 &&
           c->hidden_width <= BNN_HIDDEN_MAX && c->n_bayes >= 1 && c->n_bayes <= BNN_LAYERS_MAX &&
           c->max_batch >= 1 && c->max_batch <= BNN_MAX_BATCH && isfinite(c->w0) && c->w0 > 0.0f &&
           isfinite(c->rho_init) && isfinite(c->prior_sigma) && c->prior_sigma > 0.0f &&
           (c->precision == BNN_PRECISION_FP32 || c->precision == BNN_PRECISION_BF16);
}

static uint64_t philox_key(const bnn_model_t *m)
{
    return ai_rng_mix64(m->seed ^ SEED_SALT);
}

/* theta[off .. off+len) = U(-a, a) from the init stream, numbers [first, first+len). */
static void init_uniform(bnn_model_t *m, size_t off, size_t len, float a)
{
    float *t = m->arena + off;
    ai_rng_uniform_fill(philox_key(m), INIT_STREAM, off, t, len);
    for (size_t i = 0; i < len; i++)
        t[i] = a * (2.0f * t[i] - 1.0f);
}

int bnn_init(bnn_model_t *m, const bnn_config_t *cfg, uint64_t seed)
{
    if (!m)
        return -EINVAL;
    bnn_config_t c = cfg ? *cfg : bnn_default_config();
    if (!config_ok(&c))
        return -EINVAL;
    layout_t y;
    make_layout(&c, &y);
    if (y.dlogit + BNN_MAX_BATCH > BNN_ARENA_FLOATS)
        return -EINVAL; /* cannot happen for valid configs; kept as a guard */
    memset(m, 0, offsetof(bnn_model_t, arena));
    m->cfg = c;
    m->seed = seed;
    m->n_params = y.P;
    m->n_mu = y.n_mu;
    m->n_rho = y.R;
    for (int g = 0; g < 2; g++) {
        m->adam[g].beta1 = 0.9f;
        m->adam[g].beta2 = 0.999f;
        m->adam[g].eps = 1e-8f;
        m->adam[g].t = 0;
    }
    memset(m->arena, 0, 4 * y.P * sizeof(float)); /* theta, grads, Adam moments */
    init_uniform(m, 0, 3 * y.S, 1.0f / (float)BNN_IN);
    for (size_t l = 0; l < y.L; l++) {
        size_t n = y.lay_in[l] * y.H + y.H;
        init_uniform(m, y.bay + y.lay_off[l], n, 1.0f / sqrtf((float)y.lay_in[l]));
        float *rho = m->arena + y.n_mu + y.lay_off[l];
        for (size_t i = 0; i < n; i++)
            rho[i] = c.rho_init;
    }
    init_uniform(m, y.wout, y.H + 1, 1.0f / sqrtf((float)y.H));
    return 0;
}

float *bnn_params(bnn_model_t *m)
{
    return m ? m->arena : NULL;
}

const float *bnn_params_const(const bnn_model_t *m)
{
    return m ? m->arena : NULL;
}

float *bnn_grads(bnn_model_t *m)
{
    return m ? m->arena + m->n_params : NULL;
}

size_t bnn_n_params(const bnn_model_t *m)
{
    return m ? m->n_params : 0;
}

size_t bnn_group_offset(const bnn_model_t *m, bnn_group_t g)
{
    return (m && g == BNN_GROUP_RHO) ? m->n_mu : 0;
}

size_t bnn_group_len(const bnn_model_t *m, bnn_group_t g)
{
    if (!m)
        return 0;
    switch (g) {
    case BNN_GROUP_MU:
        return m->n_mu;
    case BNN_GROUP_RHO:
        return m->n_rho;
    case BNN_GROUP_ALL:
        return m->n_params;
    }
    return 0;
}

size_t bnn_rho_to_mu(const bnn_model_t *m, size_t j)
{
    return 3u * (size_t)m->cfg.siren_width + j;
}

size_t bnn_tensors(const bnn_model_t *m, bnn_tensor_t *out, size_t max_out)
{
    return m ? bnn_tensors_cfg(&m->cfg, out, max_out) : 0;
}

size_t bnn_tensors_cfg(const bnn_config_t *cfg, bnn_tensor_t *out, size_t max_out)
{
    if (!cfg || !out)
        return 0;
    layout_t y;
    make_layout(cfg, &y);
    size_t k = 0;
#define PUT(off_, rows_, cols_, grp_, lay_, bias_)                                               \
    do {                                                                                       \
        if (k < max_out)                                                                       \
            out[k] = (bnn_tensor_t){(off_), (uint32_t)(rows_), (uint32_t)(cols_), (grp_),      \
                                    (lay_), (bias_)};                                          \
        k++;                                                                                   \
    } while (0)
    PUT(0, y.S, BNN_IN, BNN_GROUP_MU, 0, 0);
    PUT(2 * y.S, 1, y.S, BNN_GROUP_MU, 0, 1);
    for (size_t l = 0; l < y.L; l++) {
        size_t o = y.bay + y.lay_off[l];
        PUT(o, y.H, y.lay_in[l], BNN_GROUP_MU, (int)l + 1, 0);
        PUT(o + y.H * y.lay_in[l], 1, y.H, BNN_GROUP_MU, (int)l + 1, 1);
    }
    PUT(y.wout, 1, y.H, BNN_GROUP_MU, -1, 0);
    PUT(y.bout, 1, 1, BNN_GROUP_MU, -1, 1);
    for (size_t l = 0; l < y.L; l++) {
        size_t o = y.n_mu + y.lay_off[l];
        PUT(o, y.H, y.lay_in[l], BNN_GROUP_RHO, (int)l + 1, 0);
        PUT(o + y.H * y.lay_in[l], 1, y.H, BNN_GROUP_RHO, (int)l + 1, 1);
    }
#undef PUT
    return k < max_out ? k : max_out;
}

/* ---- math helpers ----------------------------------------------------------------------- */
float bnn_softplus(float r)
{
    float e = ai_fm_expf(-fabsf(r));
    return ai_fm_sel(r > 0.0f, r, 0.0f) + ai_fm_log1pf(e);
}

double bnn_kl_normal(double mu, double s, double p)
{
    return log(p / s) + (s * s + mu * mu) / (2.0 * p * p) - 0.5;
}

double bnn_kl_loss(const bnn_model_t *m)
{
    if (!m)
        return 0.0;
    layout_t y;
    make_layout(&m->cfg, &y);
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

/* sigma = softplus(rho), w = mu + sigma * eps over the Bayesian block, in ONE pass: the
 * Gaussians are drawn a tile at a time (Philox is counter-based, so drawing numbers
 * [j0, j0 + tile) separately gives exactly the numbers of one fill of the whole block) and
 * each tile is consumed while it is still in L1. sigma_ready: the sigma buffer already holds
 * softplus(rho) of the current rho (the 2nd..Kth pass of an MC inference), only w is drawn. */
#define SAMPLE_TILE 2048u
/* partial sums of the output layer's dot products (one 512-bit vector, or two 256-bit ones) */
#define OUT_LANES 16u
AI_WIDE static void sample_weights(bnn_model_t *m, const layout_t *y, uint64_t noise_key,
                                   int sigma_ready)
{
    float *restrict eps = m->arena + y->eps;
    float *restrict sig = m->arena + y->sigma;
    float *restrict w = m->arena + y->wsamp;
    const float *restrict mu = m->arena + y->bay;
    const float *restrict rho = m->arena + y->n_mu;
    const uint64_t key = philox_key(m);
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

/* The large products of the training step (a Bayesian layer's forward, dX, dW): bf16 products
 * with fp32 sums when the model asks for them and `step` says this is the step, not an
 * inference pass (la_bf16.h); else la_sgemm_ep. alpha 1, beta 0 both ways. */
static void step_gemm(const bnn_model_t *m, int step, la_trans_t ta, la_trans_t tb, size_t M,
                      size_t N, size_t K, const float *A, size_t lda, const float *B, size_t ldb,
                      float *C, size_t ldc, const la_epilogue_t *ep)
{
    if (step && m->cfg.precision == BNN_PRECISION_BF16)
        la_bf16_gemm(ta, tb, (int)M, (int)N, (int)K, A, (int)lda, B, (int)ldb, C, (int)ldc, ep);
    else
        la_sgemm_ep(ta, tb, (int)M, (int)N, (int)K, 1.0f, A, (int)lda, B, (int)ldb, 0.0f, C,
                    (int)ldc, ep);
}

/* Forward of n points whose inputs are in the arena's xy buffer; wb = Bayesian block of the
 * weights to use (sampled or mu); step: a training step's forward (its precision applies).
 * Leaves cos0, h0, h_l and logits in the arena. */
AI_WIDE static void forward(bnn_model_t *m, const layout_t *y, const float *wb, size_t n,
                            int step)
{
    float *a = m->arena;
    const size_t S = y->S, H = y->H;
    const float w0 = m->cfg.w0;
    const float *restrict W0 = a, *restrict b0 = a + 2 * S;
    const float *restrict xy = a + y->xy;
    float *restrict h0 = a + y->h0, *restrict c0 = a + y->cos0;
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
            step_gemm(m, step, LA_NO_TRANS, LA_TRANS, n, H, in, prev, in, Wl, in, hl, H, &ep);
        } else {
            step_gemm(m, step, LA_NO_TRANS, LA_TRANS, n, H, in, prev, in, Wl, in, hl, H, NULL);
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

static double bce_logit(double l, double t)
{
    /* max(l,0) - l t + log(1 + e^-|l|): never overflows */
    return (l > 0.0 ? l : 0.0) - l * t + log1p(exp(-fabs(l)));
}

static int samples_ok(const ai_sample_t *s, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(s[i].x) || !isfinite(s[i].y) || !(s[i].occ >= 0.0f && s[i].occ <= 1.0f))
            return 0;
    return 1;
}

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
AI_WIDE static void backward(bnn_model_t *m, const layout_t *y, size_t n)
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
        step_gemm(m, 1, LA_TRANS, LA_NO_TRANS, H, in, n, cur, H, prev, in, gW, in, NULL);
        /* bias gradient of the layer below: layer l-1's b, or the SIREN b0 */
        float *restrict gbp = l > 0 ? g + y->bay + y->lay_off[l - 1] + H * y->lay_in[l - 1]
                                    : g + 2 * S;
        for (size_t k = 0; k < in; k++)
            gbp[k] = 0.0f;
        if (l > 0) {
            /* the delta of layer l-1: (da W) gated by its ReLU (h_{l-1} > 0), its columns
             * summed into the bias gradient, on the tiles */
            const la_epilogue_t ep = {.gate = prev, .ldg = (int)in, .colsum = gbp};
            step_gemm(m, 1, LA_NO_TRANS, LA_NO_TRANS, n, in, H, cur, H, Wl, in, oth, in, &ep);
        } else {
            step_gemm(m, 1, LA_NO_TRANS, LA_NO_TRANS, n, in, H, cur, H, Wl, in, oth, in, NULL);
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

/* Adam on both groups (bnn_adam_step), done inside the KL pass by bnn_train_step: the pass
 * already holds each Bayesian element's mu, rho and both gradients in registers, so the
 * separate Adam passes' reads of theta and the gradients over the block (2 x 4 streams of the
 * block's length) go. Pointers are at the block's element 0. */
typedef struct adam_fused {
    float *am_mu, *av_mu, *am_rho, *av_rho;
    float b1, b2, ep, step_mu, isb2_mu, step_rho, isb2_rho;
} adam_fused_t;

/* One Adam update, the same arithmetic as adam_update's loop body (so the same bits). */
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
                                                           const adam_fused_t *af)
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
                                                            const adam_fused_t *af)
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
                                               float logp, const adam_fused_t *af)
{
    return kl_pass(cnt, KL_STREAM_ARGS, c, ip2, logp, KL_ADAM, af);
}

AI_WIDE KL_NOINLINE static double kl_pass_adam_quiet(size_t cnt, KL_STREAMS, float c, float ip2,
                                                     float logp, const adam_fused_t *af)
{
    return kl_pass(cnt, KL_STREAM_ARGS, c, ip2, logp, KL_ADAM_QUIET, af);
}

/* The pass over the tensor [j0, j0 + cnt) of the Bayesian block; af: Adam fused (or NULL);
 * want_kl: the KL sum is wanted (else 0 is returned; only with af). */
static double bayes_tensor_grad(bnn_model_t *m, const layout_t *y, size_t j0, size_t cnt,
                                float kl_weight, const adam_fused_t *af, int want_kl)
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

/* bnn_loss_grad; with af, Adam on the Bayesian block inside the KL pass (bnn_train_step).
 * Without out (and with af) the loss figures are not computed: the gradients do not need the
 * BCE and KL sums, only their derivatives. */
static int loss_grad(bnn_model_t *m, const ai_sample_t *batch, size_t n, float kl_weight,
                     uint64_t noise_key, bnn_loss_t *out, const adam_fused_t *af)
{
    if (!m || !batch || n == 0 || n > m->cfg.max_batch || !isfinite(kl_weight) || kl_weight < 0.0f)
        return -EINVAL;
    if (!samples_ok(batch, n))
        return -EINVAL;
    layout_t y;
    make_layout(&m->cfg, &y);
    float *a = m->arena;
    float *xy = a + y.xy;
    for (size_t i = 0; i < n; i++) {
        xy[2 * i] = batch[i].x;
        xy[2 * i + 1] = batch[i].y;
    }
    sample_weights(m, &y, noise_key, 0);
    forward(m, &y, a + y.wsamp, n, 1);
    const float *logit = a + y.logit;
    float *dl = a + y.dlogit;
    double bce = 0.0;
    const float inv_n = 1.0f / (float)n;
    for (size_t i = 0; i < n; i++) {
        const double l = logit[i], t = batch[i].occ;
        if (out)
            bce += bce_logit(l, t);
        const double p = 1.0 / (1.0 + exp(-l));
        dl[i] = (float)(p - t) * inv_n;
    }
    bce /= (double)n;
    m->batch_n = n;
    backward(m, &y, n);
    double kl = 0.0;
    for (size_t l = 0; l < y.L; l++) {
        const size_t nw = y.H * y.lay_in[l];
        const double klw = bayes_tensor_grad(m, &y, y.lay_off[l], nw, kl_weight, af, out != NULL);
        const double klb = bayes_tensor_grad(m, &y, y.lay_off[l] + nw, y.H, kl_weight, af,
                                             out != NULL);
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
        adam_fused_t af = {m->arena + 2 * P + bay, m->arena + 3 * P + bay, m->arena + 2 * P + nmu,
                           m->arena + 3 * P + nmu, s0->beta1, s0->beta2, s0->eps, 0, 0, 0, 0};
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
    layout_t y;
    make_layout(&m->cfg, &y);
    memcpy(m->arena + y.xy, xy, 2 * n * sizeof(float));
    if (!use_mean)
        sample_weights(m, &y, noise_key, 0);
    forward(m, &y, use_mean ? m->arena + y.bay : m->arena + y.wsamp, n, 0);
    memcpy(logits, m->arena + y.logit, n * sizeof(float));
    return 0;
}

int bnn_predict_mc(bnn_model_t *m, const float *xy, size_t n, uint32_t K,
                                  uint64_t seed, float *mean, float *std)
{
    if (!m || !xy || !mean || n == 0 || K == 0 || !xy_ok(xy, n))
        return -EINVAL;
    layout_t y;
    make_layout(&m->cfg, &y);
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
            forward(m, &y, a + y.wsamp, nc, 0);
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
    if (!m || !samples || !bce || n == 0 || !samples_ok(samples, n))
        return -EINVAL;
    layout_t y;
    make_layout(&m->cfg, &y);
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
            forward(m, &y, a + y.bay, nc, 0);
            for (size_t i = 0; i < nc; i++)
                sum += bce_logit(a[y.logit + i], samples[c0 + i].occ);
            continue;
        }
        float *pm = a + y.dlogit; /* MC-mean probability of the chunk */
        for (size_t i = 0; i < nc; i++)
            pm[i] = 0.0f;
        for (uint32_t k = 0; k < K; k++) {
            sample_weights(m, &y, mc_key(seed, k), k > 0 || c0 > 0);
            forward(m, &y, a + y.wsamp, nc, 0);
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
