/* The one-pass epistemic posterior of the AI core (bnn_post.h). */
#include "ai/bnn_post.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "ai/bnn_int.h"
#include "ai/dinno.h"
#include "ai/kernels/la.h"
#include "common/le_bytes.h"

/* P's S x S block is summed a chunk at a time as one float GEMM, phi^T phi, in the backward
 * buffers of the arena (free outside a training step, B x max(S, H) floats each, B >= S), then
 * added to the double sums: a chunk's float sum has at most max_batch terms. */
_Static_assert(BNN_MAX_BATCH >= BNN_SIREN_MAX, "the chunk's S x S product must fit a backward buffer");
#define POST_GRAM_BLOCKS 4u /* row blocks of phi^T phi: block row b computes columns 0 .. its end */

static size_t pk(size_t i, size_t j) /* (i, j), j <= i, in a packed lower triangle */
{
    return i * (i + 1u) / 2u + j;
}

int bnn_post_init(bnn_post_t *p, const bnn_model_t *m)
{
    if (!p || !m || m->cfg.siren_width == 0 || m->cfg.siren_width + 1u > BNN_POST_DIM_MAX)
        return -EINVAL;
    memset(p, 0, sizeof *p);
    p->dim = m->cfg.siren_width + 1u;
    p->w0 = m->cfg.w0;
    memcpy(p->siren, bnn_params_const(m), 3u * m->cfg.siren_width * sizeof(float)); /* W0, b0 */
    return 0;
}

static int same_features(const bnn_post_t *p, const bnn_post_t *q)
{
    return p->dim == q->dim && p->w0 == q->w0 && memcmp(p->siren, q->siren, 3u * (p->dim - 1u) * sizeof(float)) == 0;
}

static int xy_finite(const float *xy, size_t n)
{
    for (size_t i = 0; i < 2 * n; i++)
        if (!isfinite(xy[i]))
            return 0;
    return 1;
}

/* The posterior's features of nc <= max_batch points, into the arena's h0 rows. */
static const float *features(const bnn_post_t *p, bnn_model_t *m, const bnn_layout_t *y, const float *xy, size_t nc)
{
    float *a = m->arena;
    bnn_siren_rows(p->siren, p->siren + 2 * y->S, p->w0, y->S, xy, nc, a + y->h0, a + y->cos0);
    return a + y->h0;
}

int bnn_post_observe(bnn_post_t *p, bnn_model_t *m, const float *xy, size_t n)
{
    return bnn_post_observe_weighted(p, m, xy, n, 1.0);
}

int bnn_post_observe_weighted(bnn_post_t *p, bnn_model_t *m, const float *xy, size_t n, double w)
{
    if (!p || !m || (n > 0 && !xy) || p->dim != m->cfg.siren_width + 1u || !xy_finite(xy, n) || !isfinite(w) ||
        w <= 0.0)
        return -EINVAL;
    bnn_layout_t y;
    bnn_make_layout(&m->cfg, &y);
    const size_t S = y.S, B = m->cfg.max_batch;
    float *gram = m->arena + y.g1;
    for (size_t c0 = 0; c0 < n; c0 += B) {
        const size_t nc = n - c0 < B ? n - c0 : B;
        const float *phi = features(p, m, &y, xy + 2 * c0, nc);
        /* phi^T phi on the blocks at or below the diagonal only (P is symmetric): 10 of the
           16 blocks' work, one GEMM each */
        const size_t bs = (S + POST_GRAM_BLOCKS - 1u) / POST_GRAM_BLOCKS;
        for (size_t i0 = 0; i0 < S; i0 += bs) {
            const size_t mi = S - i0 < bs ? S - i0 : bs;
            la_sgemm(LA_TRANS, LA_NO_TRANS, (int)mi, (int)(i0 + mi), (int)nc, 1.0f, phi + i0, (int)S, phi, (int)S,
                     0.0f, gram + i0 * S, (int)S);
        }
        for (size_t i = 0; i < S; i++)
            for (size_t j = 0; j <= i; j++)
                p->prec[pk(i, j)] += w * (double)gram[i * S + j];
        /* the constant feature: its row is the column sums, its diagonal the count */
        for (size_t j = 0; j < S; j++) {
            double s = 0.0;
            for (size_t k = 0; k < nc; k++)
                s += phi[k * S + j];
            p->prec[pk(S, j)] += w * s;
        }
        p->prec[pk(S, S)] += w * (double)nc;
    }
    p->n_obs += w * (double)n;
    if (n > 0 && p->robots == 0.0)
        p->robots = 1.0;
    p->factored = 0;
    return 0;
}

int bnn_post_observe_samples(bnn_post_t *p, bnn_model_t *m, const ai_sample_t *s, size_t n)
{
    if (!p || !m || (n > 0 && !s))
        return -EINVAL;
    float xy[2 * 256];
    for (size_t c0 = 0; c0 < n; c0 += 256) {
        const size_t nc = n - c0 < 256 ? n - c0 : 256;
        for (size_t k = 0; k < nc; k++) {
            xy[2 * k] = s[c0 + k].x;
            xy[2 * k + 1] = s[c0 + k].y;
        }
        const int rc = bnn_post_observe(p, m, xy, nc);
        if (rc != 0)
            return rc;
    }
    return 0;
}

int bnn_post_scale(bnn_post_t *p, double a)
{
    if (!p || !isfinite(a) || a < 0.0)
        return -EINVAL;
    const size_t np = BNN_POST_PACKED(p->dim);
    for (size_t i = 0; i < np; i++)
        p->prec[i] *= a;
    p->n_obs *= a;
    p->robots *= a;
    p->factored = 0;
    return 0;
}

int bnn_post_add(bnn_post_t *p, const bnn_post_t *q, double a)
{
    if (!p || !q || !same_features(p, q) || !isfinite(a) || a < 0.0)
        return -EINVAL;
    const size_t np = BNN_POST_PACKED(p->dim);
    for (size_t i = 0; i < np; i++)
        p->prec[i] += a * q->prec[i];
    p->n_obs += a * q->n_obs;
    p->robots += a * q->robots;
    p->factored = 0;
    return 0;
}

int bnn_post_factor(bnn_post_t *p)
{
    if (!p || p->dim == 0)
        return -EINVAL;
    const size_t D = p->dim;
    double *L = p->work;
    for (size_t i = 0; i < BNN_POST_PACKED(D); i++)
        L[i] = BNN_POST_BETA * p->prec[i];
    for (size_t i = 0; i < D; i++)
        L[pk(i, i)] += BNN_POST_LAMBDA0;
    /* Cholesky, row by row (Cholesky-Banachiewicz) */
    for (size_t i = 0; i < D; i++) {
        for (size_t j = 0; j <= i; j++) {
            double s = L[pk(i, j)];
            for (size_t k = 0; k < j; k++)
                s -= L[pk(i, k)] * L[pk(j, k)];
            if (i == j) {
                if (!(s > 0.0) || !isfinite(s))
                    return -EDOM;
                L[pk(i, i)] = sqrt(s);
            } else {
                L[pk(i, j)] = s / L[pk(j, j)];
            }
        }
    }
    /* L^-1, lower triangular, a column at a time: L x = e_j by forward substitution */
    double x[BNN_POST_DIM_MAX];
    for (size_t j = 0; j < D; j++) {
        x[j] = 1.0 / L[pk(j, j)];
        p->linv[pk(j, j)] = (float)x[j];
        for (size_t i = j + 1; i < D; i++) {
            double s = 0.0;
            for (size_t k = j; k < i; k++)
                s += L[pk(i, k)] * x[k];
            x[i] = -s / L[pk(i, i)];
            p->linv[pk(i, j)] = (float)x[i];
        }
    }
    p->factored = 1;
    return 0;
}

/* var_k = |L^-1 phi_k|^2 for nc points at once (phi_k = [h_k; 1]): the features transposed to
 * columns (hT[j * nc + k]) so that each row of L^-1 is applied to all the points in one
 * contiguous, vectorisable sweep; D (D + 1) / 2 multiply-adds per point either way. */
static void variances(const float *restrict linv, const float *restrict h0, size_t S, size_t nc, float *restrict hT,
                      float *restrict dot, float *restrict var)
{
    for (size_t k = 0; k < nc; k++)
        for (size_t j = 0; j < S; j++)
            hT[j * nc + k] = h0[k * S + j];
    for (size_t k = 0; k < nc; k++)
        var[k] = 0.0f;
    for (size_t i = 0; i <= S; i++) {
        const float *restrict row = linv + pk(i, 0);
        const size_t nj = i < S ? i + 1 : S;
        const float c = i == S ? row[S] : 0.0f; /* the constant feature's column */
        for (size_t k = 0; k < nc; k++)
            dot[k] = c;
        for (size_t j = 0; j < nj; j++) {
            const float l = row[j];
            const float *restrict col = hT + j * nc;
            for (size_t k = 0; k < nc; k++)
                dot[k] += l * col[k];
        }
        for (size_t k = 0; k < nc; k++)
            var[k] += dot[k] * dot[k];
    }
}

int bnn_post_predict(bnn_post_t *p, bnn_model_t *m, const float *xy, size_t n, float *logit, float *unknown)
{
    if (!p || !m || !xy || !unknown || n == 0 || p->dim != m->cfg.siren_width + 1u)
        return -EINVAL;
    if (!p->factored) {
        const int rc = bnn_post_factor(p);
        if (rc != 0)
            return rc;
    }
    bnn_layout_t y;
    bnn_make_layout(&m->cfg, &y);
    const size_t S = y.S, B = m->cfg.max_batch;
    for (size_t c0 = 0; c0 < n; c0 += B) {
        const size_t nc = n - c0 < B ? n - c0 : B;
        if (logit) {
            const int rc = bnn_forward_logits(m, xy + 2 * c0, nc, 1, 0, logit + c0);
            if (rc != 0)
                return rc;
        } else if (!xy_finite(xy + 2 * c0, nc)) {
            return -EINVAL;
        }
        const float *h0 = features(p, m, &y, xy + 2 * c0, nc);
        float *var = unknown + c0;
        variances(p->linv, h0, S, nc, m->arena + y.g1, m->arena + y.g2, var);
        for (size_t k = 0; k < nc; k++) {
            const float *h = h0 + k * S;
            float prior = 1.0f;
            for (size_t j = 0; j < S; j++)
                prior += h[j] * h[j];
            prior *= (float)(1.0 / BNN_POST_LAMBDA0);
            const float r = var[k] / prior;
            var[k] = r > 1.0f ? 1.0f : r;
        }
    }
    return 0;
}

/* ---- over the fleet's state exchange ------------------------------------------------------ */
static void put_hilo(float *o, double d)
{
    o[0] = (float)d;
    o[1] = (float)(d - (double)o[0]);
}

static double get_hilo(const float *o)
{
    return (double)o[0] + (double)o[1];
}

int bnn_post_to_state(const bnn_post_t *p, float *out, size_t cap)
{
    if (!p || !out || p->dim == 0)
        return -EINVAL;
    const size_t D = p->dim, S = D - 1u, np = BNN_POST_PACKED(D);
    if (cap < BNN_POST_STATE_FLOATS(D))
        return -ENOSPC;
    out[0] = (float)D;
    out[1] = p->w0;
    memcpy(out + 2, p->siren, 3u * S * sizeof(float));
    float *o = out + 2 + 3u * S;
    put_hilo(o, p->n_obs);
    put_hilo(o + 2, p->robots);
    for (size_t i = 0; i < np; i++)
        put_hilo(o + 4 + 2 * i, p->prec[i]);
    for (size_t i = BNN_POST_STATE_FLOATS(D); i < cap; i++)
        out[i] = 0.0f;
    return 0;
}

/* A neighbour's state over p's features, with finite and sensible values. */
static int state_ok(const bnn_post_t *p, const float *st, size_t cap)
{
    const size_t D = p->dim, S = D - 1u;
    if (cap < BNN_POST_STATE_FLOATS(D) || st[0] != (float)D || st[1] != p->w0 ||
        memcmp(st + 2, p->siren, 3u * S * sizeof(float)) != 0)
        return 0;
    const float *o = st + 2 + 3u * S;
    for (size_t i = 0; i < 4u + 2u * BNN_POST_PACKED(D); i++)
        if (!isfinite(o[i]))
            return 0;
    if (get_hilo(o) < 0.0 || get_hilo(o + 2) < 0.0)
        return 0;
    for (size_t i = 0; i < D; i++)
        if (get_hilo(o + 4 + 2 * pk(i, i)) < 0.0)
            return 0;
    return 1;
}

int bnn_post_mix(bnn_post_t *p, const float *const *states, size_t n, size_t cap, double w, uint32_t *used)
{
    if (used)
        *used = 0;
    if (!p || p->dim == 0 || (n > 0 && !states) || !isfinite(w) || w <= 0.0 || (double)n * w > 1.0)
        return -EINVAL;
    const size_t D = p->dim, S = D - 1u, np = BNN_POST_PACKED(D);
    if (n > DINNO_MAX_PEERS)
        return -EINVAL;
    uint8_t ok[DINNO_MAX_PEERS];
    uint32_t c = 0;
    for (size_t k = 0; k < n; k++) { /* checked once: the count sets our own weight */
        ok[k] = states[k] != NULL && state_ok(p, states[k], cap);
        c += ok[k];
    }
    const double self = 1.0 - (double)c * w;
    double n_obs = self * p->n_obs, robots = self * p->robots;
    for (size_t i = 0; i < np; i++)
        p->work[i] = self * p->prec[i];
    for (size_t k = 0; k < n; k++) {
        if (!ok[k])
            continue;
        const float *o = states[k] + 2 + 3u * S;
        n_obs += w * get_hilo(o);
        robots += w * get_hilo(o + 2);
        for (size_t i = 0; i < np; i++)
            p->work[i] += w * get_hilo(o + 4 + 2 * i);
    }
    memcpy(p->prec, p->work, np * sizeof(double));
    p->n_obs = n_obs;
    p->robots = robots;
    p->factored = 0;
    if (used)
        *used = c;
    return 0;
}

/* ---- storage ---------------------------------------------------------------------------- */
size_t bnn_post_wire_size(const bnn_post_t *p)
{
    return p ? BNN_POST_WIRE_BYTES(p->dim) : 0;
}

int bnn_post_write(const bnn_post_t *p, uint8_t *buf, size_t cap, size_t *written)
{
    if (!p || !buf || p->dim == 0)
        return -EINVAL;
    const size_t need = bnn_post_wire_size(p);
    if (cap < need)
        return -ENOSPC;
    le_put_u32(buf, p->dim);
    le_put_f64(buf + 4, p->n_obs);
    le_put_f64(buf + 12, p->robots);
    uint8_t *at = buf + 20;
    const size_t nf = 3u * (p->dim - 1u);
    for (size_t i = 0; i <= nf; i++, at += 4) {
        uint32_t u;
        memcpy(&u, i == 0 ? &p->w0 : &p->siren[i - 1], 4);
        le_put_u32(at, u);
    }
    for (size_t i = 0; i < BNN_POST_PACKED(p->dim); i++)
        le_put_f64(at + 8 * i, p->prec[i]);
    if (written)
        *written = need;
    return 0;
}

int bnn_post_read(bnn_post_t *p, const bnn_model_t *m, const uint8_t *buf, size_t len, const char **reason)
{
    const char *why = NULL;
    int rc = 0;
    if (!p || !m || !buf)
        return -EINVAL;
    const uint32_t want = m->cfg.siren_width + 1u;
    if (len < 20u) {
        why = "posterior truncated (no header)", rc = -ENODATA;
    } else if (le_get_u32(buf) != want) {
        why = "posterior of another network (dimension != SIREN width + 1)", rc = -ENOEXEC;
    } else if (len < BNN_POST_WIRE_BYTES(want)) {
        why = "posterior truncated", rc = -ENODATA;
    } else {
        const double n_obs = le_get_f64(buf + 4), robots = le_get_f64(buf + 12);
        const size_t nf = 3u * (want - 1u);
        const uint8_t *pr = buf + 20 + 4 * (nf + 1);
        if (!isfinite(n_obs) || n_obs < 0.0 || !isfinite(robots) || robots < 0.0)
            why = "posterior's counts not finite or negative", rc = -EBADMSG;
        for (size_t i = 0; rc == 0 && i <= nf; i++) {
            const uint32_t u = le_get_u32(buf + 20 + 4 * i);
            float f;
            memcpy(&f, &u, 4);
            if (!isfinite(f) || (i == 0 && !(f > 0.0f)))
                why = "posterior's features not finite (or w0 <= 0)", rc = -EBADMSG;
        }
        for (size_t i = 0; rc == 0 && i < BNN_POST_PACKED(want); i++)
            if (!isfinite(le_get_f64(pr + 8 * i)))
                why = "posterior holds a non-finite value", rc = -EBADMSG;
        for (size_t i = 0; rc == 0 && i < want; i++)
            if (le_get_f64(pr + 8 * pk(i, i)) < 0.0)
                why = "posterior's precision has a negative diagonal", rc = -EBADMSG;
        if (rc == 0) {
            memset(p, 0, sizeof *p);
            p->dim = want;
            p->n_obs = n_obs;
            p->robots = robots;
            for (size_t i = 0; i <= nf; i++) {
                const uint32_t u = le_get_u32(buf + 20 + 4 * i);
                memcpy(i == 0 ? &p->w0 : &p->siren[i - 1], &u, 4);
            }
            for (size_t i = 0; i < BNN_POST_PACKED(want); i++)
                p->prec[i] = le_get_f64(pr + 8 * i);
        }
    }
    if (reason)
        *reason = why;
    return rc;
}
