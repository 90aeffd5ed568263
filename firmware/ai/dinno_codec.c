/* The exchange codecs of DiNNO states: see dinno_codec.h. The packings are bnn_quant's (int8
 * and 4-bit, per-row scales); fp32 is the state's own words. */
#include "ai/dinno_codec.h"

#include <errno.h>
#include <string.h>

#include "ai/bnn_quant.h"

_Static_assert(BNN_QUANT_MAX_BYTES <= DINNO_CODEC_MAX_BYTES, "an int8 state fits DINNO_CODEC_MAX_BYTES");
_Static_assert(BNN_QUANT4_MAX_BYTES <= DINNO_CODEC_MAX_BYTES, "a 4-bit state fits DINNO_CODEC_MAX_BYTES");
_Static_assert(DINNO_CODEC_COUNT == (unsigned)DINNO_CODEC_INT4_EF + 1u, "DINNO_CODEC_COUNT: the last codec + 1");

static const char *const codec_names[DINNO_CODEC_COUNT] = {"fp32", "int8", "int8-ef", "int4-ef"};

static int codec_ok(dinno_codec_t c)
{
    return (unsigned)c < DINNO_CODEC_COUNT;
}

/* Parameters of configuration cfg; 0 for NULL or dimensions outside the preset's (the packers'
   tensor walk assumes a valid configuration). */
static size_t n_params_of(const bnn_config_t *cfg)
{
    if (cfg == NULL || cfg->siren_width < 1 || cfg->siren_width > BNN_SIREN_MAX || cfg->hidden_width < 1 ||
        cfg->hidden_width > BNN_HIDDEN_MAX || cfg->n_bayes < 1 || cfg->n_bayes > BNN_LAYERS_MAX)
        return 0;
    return BNN_N_MU_OF(cfg->siren_width, cfg->hidden_width, cfg->n_bayes) +
           BNN_N_RHO_OF(cfg->siren_width, cfg->hidden_width, cfg->n_bayes);
}

/* 1 if a float of v[0..n) is not finite: all exponent bits set. On the bits, so the pass
   vectorises (a branch per float did not) and takes exactly the words isfinite refuses. */
static int any_nonfinite(const float *v, size_t n)
{
    uint32_t bad = 0;
    for (size_t i = 0; i < n; i++) {
        uint32_t w;
        memcpy(&w, &v[i], sizeof w);
        bad |= (w & 0x7f800000u) == 0x7f800000u;
    }
    return bad != 0;
}

int dinno_codec_is_ef(dinno_codec_t c)
{
    return c == DINNO_CODEC_INT8_EF || c == DINNO_CODEC_INT4_EF;
}

const char *dinno_codec_name(dinno_codec_t c)
{
    return codec_ok(c) ? codec_names[c] : "?";
}

int dinno_codec_parse(const char *name, dinno_codec_t *out)
{
    if (name == NULL || out == NULL)
        return -EINVAL;
    for (unsigned i = 0; i < DINNO_CODEC_COUNT; i++)
        if (strcmp(name, codec_names[i]) == 0) {
            *out = (dinno_codec_t)i;
            return 0;
        }
    return -EINVAL;
}

size_t dinno_codec_bytes(const bnn_config_t *cfg, dinno_codec_t c)
{
    const size_t n = n_params_of(cfg);
    if (n == 0)
        return 0;
    switch (c) {
    case DINNO_CODEC_FP32:
        return n * sizeof(float);
    case DINNO_CODEC_INT8:
    case DINNO_CODEC_INT8_EF:
        return bnn_quant_packed_size_cfg(cfg, BNN_GROUP_ALL);
    case DINNO_CODEC_INT4_EF:
        return bnn_quant_packed_size4_cfg(cfg, BNN_GROUP_ALL);
    }
    return 0;
}

int dinno_codec_encode(const bnn_config_t *cfg, dinno_codec_t c, const float *v, uint8_t *buf, size_t cap,
                       size_t *written)
{
    const size_t n = n_params_of(cfg);
    if (n == 0 || !codec_ok(c) || v == NULL || buf == NULL || written == NULL)
        return -EINVAL;
    switch (c) {
    case DINNO_CODEC_FP32: /* the receiver refuses a non-finite word (decode) */
        if (cap < n * sizeof(float))
            return -ENOSPC;
        memcpy(buf, v, n * sizeof(float));
        *written = n * sizeof(float);
        return 0;
    case DINNO_CODEC_INT8:
    case DINNO_CODEC_INT8_EF:
        return bnn_quant_pack_theta(cfg, BNN_GROUP_ALL, v, buf, cap, written);
    case DINNO_CODEC_INT4_EF:
        return bnn_quant_pack_theta4(cfg, BNN_GROUP_ALL, v, buf, cap, written);
    }
    return -EINVAL;
}

int dinno_codec_decode_inplace(const bnn_config_t *cfg, dinno_codec_t c, float *th, size_t len, float *scales,
                               size_t n_scales)
{
    const size_t n = n_params_of(cfg);
    if (n == 0 || !codec_ok(c) || th == NULL)
        return -EINVAL;
    switch (c) {
    case DINNO_CODEC_FP32: /* read where it is: only checked */
        if (len != n * sizeof(float))
            return -EBADMSG;
        return any_nonfinite(th, n) ? -EBADMSG : 0;
    case DINNO_CODEC_INT8:
    case DINNO_CODEC_INT8_EF:
        return bnn_quant_unpack_theta_inplace(cfg, th, len, scales, n_scales);
    case DINNO_CODEC_INT4_EF:
        return bnn_quant_unpack_theta4_inplace(cfg, th, len, scales, n_scales);
    }
    return -EINVAL;
}

int dinno_codec_channel(const bnn_config_t *cfg, dinno_codec_t c, const float *in, float *out)
{
    const size_t n = n_params_of(cfg);
    if (n == 0 || !codec_ok(c) || in == NULL || out == NULL)
        return -EINVAL;
    switch (c) {
    case DINNO_CODEC_FP32: /* a receiver refuses a non-finite state: so does the channel */
        if (any_nonfinite(in, n))
            return -EINVAL;
        if (out != in)
            memmove(out, in, n * sizeof(float));
        return 0;
    case DINNO_CODEC_INT8:
    case DINNO_CODEC_INT8_EF:
        return bnn_quant_round_trip_theta(cfg, 8u, in, out);
    case DINNO_CODEC_INT4_EF:
        return bnn_quant_round_trip_theta(cfg, 4u, in, out);
    }
    return -EINVAL;
}
