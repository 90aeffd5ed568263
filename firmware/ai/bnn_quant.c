/* Per-row symmetric int8 quantisation and an int8 x int8 -> int32 inference path. */
#include "ai/bnn_quant.h"

#include <errno.h>
#include <math.h>
#include <string.h>

static void put32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

static float getf(const uint8_t *p)
{
    uint32_t u = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
    float f;
    memcpy(&f, &u, 4);
    return f;
}

static int in_group(const bnn_tensor_t *t, bnn_group_t g)
{
    return g == BNN_GROUP_ALL || t->group == g;
}

static size_t tensor_rows(const bnn_tensor_t *t)
{
    return t->is_bias ? 1u : t->rows;
}

static size_t tensor_cols(const bnn_tensor_t *t)
{
    return t->is_bias ? (size_t)t->rows * t->cols : t->cols;
}

static size_t packed_size_of(const bnn_tensor_t *T, size_t nt, bnn_group_t g)
{
    size_t s = 0;
    for (size_t i = 0; i < nt; i++)
        if (in_group(&T[i], g))
            s += 4u * tensor_rows(&T[i]) + tensor_rows(&T[i]) * tensor_cols(&T[i]);
    return s;
}

size_t bnn_quant_packed_size(const bnn_model_t *m, bnn_group_t g)
{
    return m ? bnn_quant_packed_size_cfg(&m->cfg, g) : 0;
}

size_t bnn_quant_packed_size_cfg(const bnn_config_t *cfg, bnn_group_t g)
{
    if (!cfg)
        return 0;
    bnn_tensor_t T[BNN_MAX_TENSORS];
    size_t nt = bnn_tensors_cfg(cfg, T, BNN_MAX_TENSORS);
    return packed_size_of(T, nt, g);
}

int bnn_quant_pack(const bnn_model_t *m, bnn_group_t g, uint8_t *buf, size_t cap, size_t *written)
{
    if (!m)
        return -EINVAL;
    return bnn_quant_pack_theta(&m->cfg, g, bnn_params_const(m), buf, cap, written);
}

int bnn_quant_pack_theta(const bnn_config_t *cfg, bnn_group_t g, const float *th, uint8_t *buf, size_t cap,
                         size_t *written)
{
    if (!cfg || !th || !buf || !written || (g != BNN_GROUP_MU && g != BNN_GROUP_RHO && g != BNN_GROUP_ALL))
        return -EINVAL;
    bnn_tensor_t T[BNN_MAX_TENSORS];
    size_t nt = bnn_tensors_cfg(cfg, T, BNN_MAX_TENSORS);
    const size_t need = packed_size_of(T, nt, g);
    if (cap < need)
        return -ENOSPC;
    uint8_t *p = buf;
    for (size_t t = 0; t < nt; t++) {
        if (!in_group(&T[t], g))
            continue;
        const size_t R = tensor_rows(&T[t]), C = tensor_cols(&T[t]);
        uint8_t *scales = p, *q = p + 4 * R;
        for (size_t r = 0; r < R; r++) {
            const float *x = th + T[t].offset + r * C;
            float amax = 0.0f;
            for (size_t k = 0; k < C; k++)
                amax = fabsf(x[k]) > amax ? fabsf(x[k]) : amax;
            const float scale = amax / 127.0f;
            const float inv = scale > 0.0f ? 1.0f / scale : 0.0f;
            uint32_t u;
            memcpy(&u, &scale, 4);
            put32(scales + 4 * r, u);
            for (size_t k = 0; k < C; k++) {
                float v = roundf(x[k] * inv);
                v = v > 127.0f ? 127.0f : (v < -127.0f ? -127.0f : v);
                q[r * C + k] = (uint8_t)(int8_t)v;
            }
        }
        p += 4 * R + R * C;
    }
    *written = need;
    return 0;
}

int bnn_quant_unpack(bnn_model_t *m, bnn_group_t g, const uint8_t *buf, size_t len)
{
    if (!m)
        return -EINVAL;
    return bnn_quant_unpack_theta(&m->cfg, g, buf, len, bnn_params(m));
}

int bnn_quant_unpack_theta(const bnn_config_t *cfg, bnn_group_t g, const uint8_t *buf, size_t len, float *th)
{
    if (!cfg || !th || !buf || (g != BNN_GROUP_MU && g != BNN_GROUP_RHO && g != BNN_GROUP_ALL))
        return -EINVAL;
    bnn_tensor_t T[BNN_MAX_TENSORS];
    size_t nt = bnn_tensors_cfg(cfg, T, BNN_MAX_TENSORS);
    if (len != packed_size_of(T, nt, g))
        return -EBADMSG;
    /* validate every scale first */
    const uint8_t *p = buf;
    for (size_t t = 0; t < nt; t++) {
        if (!in_group(&T[t], g))
            continue;
        const size_t R = tensor_rows(&T[t]), C = tensor_cols(&T[t]);
        for (size_t r = 0; r < R; r++) {
            float s = getf(p + 4 * r);
            if (!isfinite(s) || s < 0.0f)
                return -EBADMSG;
        }
        p += 4 * R + R * C;
    }
    p = buf;
    for (size_t t = 0; t < nt; t++) {
        if (!in_group(&T[t], g))
            continue;
        const size_t R = tensor_rows(&T[t]), C = tensor_cols(&T[t]);
        const uint8_t *q = p + 4 * R;
        for (size_t r = 0; r < R; r++) {
            const float s = getf(p + 4 * r);
            float *x = th + T[t].offset + r * C;
            for (size_t k = 0; k < C; k++)
                x[k] = s * (float)(int8_t)q[r * C + k];
        }
        p += 4 * R + R * C;
    }
    return 0;
}

/* Where each tensor of the packed stream starts (scales pointer) for the inference path. */
typedef struct qtensor {
    const uint8_t *scales;
    const int8_t *q;
    size_t rows, cols;
} qtensor_t;

/* y[j] = bias[j] + scale_a * scale_w[j] * sum_k qa[k] qw[j,k], the int8 layer. */
static void int8_layer(const qtensor_t *W, const qtensor_t *b, const float *a, size_t in, float *y)
{
    int8_t qa[BNN_SIREN_MAX > BNN_HIDDEN_MAX ? BNN_SIREN_MAX : BNN_HIDDEN_MAX];
    float amax = 0.0f;
    for (size_t k = 0; k < in; k++)
        amax = fabsf(a[k]) > amax ? fabsf(a[k]) : amax;
    const float sa = amax / 127.0f, inv = sa > 0.0f ? 1.0f / sa : 0.0f;
    for (size_t k = 0; k < in; k++)
        qa[k] = (int8_t)roundf(a[k] * inv);
    const float sb = getf(b->scales);
    for (size_t j = 0; j < W->rows; j++) {
        const int8_t *w = W->q + j * in;
        int32_t acc = 0;
        for (size_t k = 0; k < in; k++)
            acc += (int32_t)w[k] * (int32_t)qa[k];
        y[j] = sa * getf(W->scales + 4 * j) * (float)acc + sb * (float)b->q[j];
    }
}

int bnn_quant_forward_mean(const bnn_config_t *cfg, bnn_group_t g, const uint8_t *packed,
                           size_t len, const float *xy, size_t n, float *logits)
{
    if (!cfg || !packed || !xy || !logits || (g != BNN_GROUP_ALL && g != BNN_GROUP_MU))
        return -EINVAL;
    if (cfg->siren_width < 1 || cfg->siren_width > BNN_SIREN_MAX || cfg->hidden_width < 1 ||
        cfg->hidden_width > BNN_HIDDEN_MAX || cfg->n_bayes < 1 || cfg->n_bayes > BNN_LAYERS_MAX ||
        !(cfg->w0 > 0.0f))
        return -EINVAL;
    const size_t S = cfg->siren_width, H = cfg->hidden_width, L = cfg->n_bayes;
    /* Walk the packed stream in theta order: W0, b0, (W_mu, b_mu) x L, w_out, b_out. */
    qtensor_t Q[2 + 2 * BNN_LAYERS_MAX + 2];
    const size_t shapes[][2] = {{S, BNN_IN}, {1, S}};
    const uint8_t *p = packed;
    size_t nq = 0;
    for (size_t t = 0; t < 2 + 2 * L + 2; t++) {
        size_t R, C;
        if (t < 2) {
            R = shapes[t][0];
            C = shapes[t][1];
        } else if (t < 2 + 2 * L) {
            const size_t l = (t - 2) / 2, in = l == 0 ? S : H;
            R = (t % 2 == 0) ? H : 1;
            C = (t % 2 == 0) ? in : H;
        } else {
            R = 1;
            C = t == 2 + 2 * L ? H : 1;
        }
        if ((size_t)(p - packed) + 4 * R + R * C > len)
            return -EBADMSG;
        Q[nq++] = (qtensor_t){p, (const int8_t *)(p + 4 * R), R, C};
        for (size_t r = 0; r < R; r++) {
            float s = getf(p + 4 * r);
            if (!isfinite(s) || s < 0.0f)
                return -EBADMSG;
        }
        p += 4 * R + R * C;
    }
    float a[BNN_SIREN_MAX > BNN_HIDDEN_MAX ? BNN_SIREN_MAX : BNN_HIDDEN_MAX];
    float b[BNN_SIREN_MAX > BNN_HIDDEN_MAX ? BNN_SIREN_MAX : BNN_HIDDEN_MAX];
    const float sb0 = getf(Q[1].scales);
    for (size_t i = 0; i < n; i++) {
        const float x = xy[2 * i], y = xy[2 * i + 1];
        if (!isfinite(x) || !isfinite(y))
            return -EINVAL;
        for (size_t j = 0; j < S; j++) {
            const float s = getf(Q[0].scales + 4 * j);
            const float z = s * (float)Q[0].q[2 * j] * x + s * (float)Q[0].q[2 * j + 1] * y +
                            sb0 * (float)Q[1].q[j];
            a[j] = sinf(cfg->w0 * z);
        }
        size_t in = S;
        for (size_t l = 0; l < L; l++) {
            int8_layer(&Q[2 + 2 * l], &Q[3 + 2 * l], a, in, b);
            for (size_t j = 0; j < H; j++)
                a[j] = b[j] > 0.0f ? b[j] : 0.0f;
            in = H;
        }
        float out;
        int8_layer(&Q[2 + 2 * L], &Q[3 + 2 * L], a, H, &out);
        logits[i] = out;
    }
    return 0;
}
