/* Checkpoint (de)serialisation: explicit little-endian byte order so a checkpoint written on
 * the host loads on any board; validate-then-copy so a bad buffer never half-loads. */
#include "ai/bnn_ckpt.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "common/crc32.h"

static void put32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

static uint32_t get32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static void put_floats(uint8_t *p, const float *x, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        uint32_t u;
        memcpy(&u, &x[i], 4);
        put32(p + 4 * i, u);
    }
}

static float get_float(const uint8_t *p)
{
    uint32_t u = get32(p);
    float f;
    memcpy(&f, &u, 4);
    return f;
}

size_t bnn_ckpt_size(const bnn_model_t *m, int with_adam)
{
    if (!m)
        return 0;
    return BNN_CKPT_HEADER_BYTES + (with_adam ? 3u : 1u) * m->n_params * 4u;
}

size_t bnn_ckpt_size_post(const bnn_model_t *m, int with_adam, const bnn_post_t *post)
{
    return bnn_ckpt_size(m, with_adam) + (post ? bnn_post_wire_size(post) : 0u);
}

int bnn_ckpt_save(const bnn_model_t *m, int with_adam, uint8_t *buf, size_t cap, size_t *written)
{
    return bnn_ckpt_save_post(m, with_adam, NULL, buf, cap, written);
}

int bnn_ckpt_save_post(const bnn_model_t *m, int with_adam, const bnn_post_t *post, uint8_t *buf, size_t cap,
                       size_t *written)
{
    if (!m || !buf || !written || (post && post->dim != m->cfg.siren_width + 1u))
        return -EINVAL;
    const size_t need = bnn_ckpt_size_post(m, with_adam, post);
    if (cap < need)
        return -ENOSPC;
    const size_t P = m->n_params;
    const size_t payload = need - BNN_CKPT_HEADER_BYTES;
    memcpy(buf, "BNNC", 4);
    put32(buf + 4, BNN_CKPT_VERSION);
    put32(buf + 8, BNN_CKPT_HEADER_BYTES);
    put32(buf + 12, BNN_IN);
    put32(buf + 16, m->cfg.siren_width);
    put32(buf + 20, m->cfg.hidden_width);
    put32(buf + 24, m->cfg.n_bayes);
    put32(buf + 28, (uint32_t)P);
    put32(buf + 32, (uint32_t)m->seed);
    put32(buf + 36, (uint32_t)(m->seed >> 32));
    put32(buf + 40, with_adam ? m->adam[BNN_GROUP_MU].t : 0u);
    put32(buf + 44, with_adam ? m->adam[BNN_GROUP_RHO].t : 0u);
    put32(buf + 48, (with_adam ? BNN_CKPT_FLAG_ADAM : 0u) | (post ? BNN_CKPT_FLAG_POST : 0u));
    put32(buf + 52, (uint32_t)payload);
    uint8_t *pl = buf + BNN_CKPT_HEADER_BYTES;
    const float *th = bnn_params_const(m);
    put_floats(pl, th, P);
    if (with_adam) {
        put_floats(pl + 4 * P, th + 2 * P, P); /* arena: theta, grads, m, v (bnn_int.h layout) */
        put_floats(pl + 8 * P, th + 3 * P, P);
    }
    if (post) {
        const size_t model_bytes = bnn_ckpt_size(m, with_adam) - BNN_CKPT_HEADER_BYTES;
        const int rc = bnn_post_write(post, pl + model_bytes, payload - model_bytes, NULL);
        if (rc != 0)
            return rc;
    }
    uint32_t crc = crc32_ieee_update(0u, buf, 56);
    crc = crc32_ieee_update(crc, pl, payload);
    put32(buf + 56, crc);
    *written = need;
    return 0;
}

#define FAIL(code, why)                                                                        \
    do {                                                                                       \
        if (reason)                                                                            \
            *reason = (why);                                                                   \
        return (code);                                                                         \
    } while (0)

int bnn_ckpt_load(bnn_model_t *m, const uint8_t *buf, size_t len, const char **reason)
{
    return bnn_ckpt_load_post(m, NULL, buf, len, reason);
}

int bnn_ckpt_load_post(bnn_model_t *m, bnn_post_t *post, const uint8_t *buf, size_t len, const char **reason)
{
    if (reason)
        *reason = "ok";
    if (!m || !buf)
        FAIL(-EINVAL, "NULL model or buffer");
    if (len < BNN_CKPT_HEADER_BYTES)
        FAIL(-ENODATA, "truncated: shorter than the checkpoint header");
    if (memcmp(buf, "BNNC", 4) != 0)
        FAIL(-EBADMSG, "bad magic: not a BNN checkpoint");
    if (get32(buf + 4) != BNN_CKPT_VERSION)
        FAIL(-EPROTONOSUPPORT, "unsupported checkpoint version");
    if (get32(buf + 8) != BNN_CKPT_HEADER_BYTES)
        FAIL(-EBADMSG, "bad header length");
    const uint32_t flags = get32(buf + 48), payload = get32(buf + 52), P = get32(buf + 28);
    if ((uint64_t)len < (uint64_t)BNN_CKPT_HEADER_BYTES + payload)
        FAIL(-ENODATA, "truncated: payload shorter than the header says");
    if (get32(buf + 12) != BNN_IN || get32(buf + 16) != m->cfg.siren_width ||
        get32(buf + 20) != m->cfg.hidden_width || get32(buf + 24) != m->cfg.n_bayes ||
        P != m->n_params)
        FAIL(-ENOEXEC, "fingerprint mismatch: checkpoint of another preset or configuration");
    if ((flags & ~(BNN_CKPT_FLAG_ADAM | BNN_CKPT_FLAG_POST)) != 0)
        FAIL(-EBADMSG, "unknown flags");
    const int with_adam = (flags & BNN_CKPT_FLAG_ADAM) != 0, with_post = (flags & BNN_CKPT_FLAG_POST) != 0;
    const uint64_t model_bytes = (with_adam ? 3u : 1u) * (uint64_t)P * 4u;
    const uint64_t post_bytes = with_post ? BNN_POST_WIRE_BYTES(m->cfg.siren_width + 1u) : 0u;
    if ((uint64_t)payload != model_bytes + post_bytes)
        FAIL(-EBADMSG, "payload length inconsistent with n_params and flags");
    uint32_t crc = crc32_ieee_update(0u, buf, 56);
    crc = crc32_ieee_update(crc, buf + BNN_CKPT_HEADER_BYTES, payload);
    if (crc != get32(buf + 56))
        FAIL(-EILSEQ, "CRC mismatch: checkpoint is corrupt");
    const uint8_t *pl = buf + BNN_CKPT_HEADER_BYTES;
    for (size_t i = 0; i < (size_t)model_bytes / 4u; i++)
        if (!isfinite(get_float(pl + 4 * i)))
            FAIL(-EBADMSG, "non-finite value in the payload");
    if (with_adam)
        for (size_t i = 0; i < P; i++)
            if (get_float(pl + 8 * (size_t)P + 4 * i) < 0.0f)
                FAIL(-EBADMSG, "negative Adam second moment");
    if (post) { /* validated into post before the model is touched; none stored: an empty one */
        if (with_post) {
            const char *why = NULL;
            const int rc = bnn_post_read(post, m, pl + model_bytes, (size_t)post_bytes, &why);
            if (rc != 0)
                FAIL(rc, why);
        } else if (bnn_post_init(post, m) != 0) {
            FAIL(-EINVAL, "posterior of another configuration");
        }
    }
    /* valid: copy */
    float *th = bnn_params(m);
    for (size_t i = 0; i < P; i++)
        th[i] = get_float(pl + 4 * i);
    m->seed = (uint64_t)get32(buf + 32) | (uint64_t)get32(buf + 36) << 32;
    if (with_adam) {
        for (size_t i = 0; i < P; i++) {
            th[2 * (size_t)P + i] = get_float(pl + 4 * ((size_t)P + i));
            th[3 * (size_t)P + i] = get_float(pl + 4 * (2 * (size_t)P + i));
        }
        m->adam[BNN_GROUP_MU].t = get32(buf + 40);
        m->adam[BNN_GROUP_RHO].t = get32(buf + 44);
    } else {
        bnn_adam_reset(m, BNN_GROUP_MU);
        bnn_adam_reset(m, BNN_GROUP_RHO);
    }
    return 0;
}
