/* BNN trainer, the model: configuration, arena layout, initialisation, parameter access and
 * the tensor list. See bnn.h for the contract and the parameter layout, bnn_int.h for the
 * other files of the trainer and why it looks the way it does.
 */
#include "ai/bnn.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "ai/ai_rng.h"
#include "ai/bnn_int.h"

_Static_assert(BNN_SIREN_MAX >= 1 && BNN_HIDDEN_MAX >= 1 && BNN_LAYERS_MAX >= 1, "preset dims");
_Static_assert(BNN_MAX_BATCH >= 1 && BNN_MAX_BATCH <= (1u << 20), "preset batch");

#define INIT_STREAM 0x1A17ull     /* stream of the initialisation uniforms */

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

/* theta[off .. off+len) = U(-a, a) from the init stream, numbers [first, first+len). */
static void init_uniform(bnn_model_t *m, size_t off, size_t len, float a)
{
    float *t = m->arena + off;
    ai_rng_uniform_fill(bnn_philox_key(m), INIT_STREAM, off, t, len);
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
    bnn_layout_t y;
    bnn_make_layout(&c, &y);
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
    bnn_layout_t y;
    bnn_make_layout(cfg, &y);
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
