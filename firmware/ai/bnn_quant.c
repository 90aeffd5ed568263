/* Per-row symmetric int8 quantisation and an int8 x int8 -> int32 inference path. */
#include "ai/bnn_quant.h"

#include "ai/ai_fastmath.h"
#include "ai/kernels/q8_gemm.h"

#include <errno.h>
#include <float.h>
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

/* ---- the row quantiser of both packings (int8: qmax 127, 4-bit: qmax 7) ------------------
 * One code for the packers and bnn_quant_round_trip_theta, so that the floats a receiver
 * expands are the round trip's, bit for bit. */

/* max |x_k| / qmax; *bad |= 1 for a non-finite element (on the bits: the loop vectorises). */
static inline float row_scale(const float *x, size_t C, float qmax, uint32_t *bad)
{
    float amax = 0.0f;
    uint32_t nf = 0;
    for (size_t k = 0; k < C; k++) {
        uint32_t w;
        memcpy(&w, &x[k], sizeof w);
        nf |= (w & 0x7f800000u) == 0x7f800000u;
        amax = fabsf(x[k]) > amax ? fabsf(x[k]) : amax;
    }
    *bad |= nf;
    return amax / qmax;
}

/* 1 / scale, 0 for a zero scale, and 0 where it overflows (a scale below ~2.9e-39: a row of
 * subnormals, quantised to 0 rather than to inf * 0 = NaN, whose conversion is undefined). */
static inline float row_inv(float scale)
{
    const float inv = scale > 0.0f ? 1.0f / scale : 0.0f;
    return inv <= FLT_MAX ? inv : 0.0f;
}

/* round(x / scale) clamped to [-qmax, qmax] (x finite, so x * inv is). */
static inline int row_q(float x, float inv, float qmax)
{
    float v = roundf(x * inv);
    v = v > qmax ? qmax : (v < -qmax ? -qmax : v);
    return (int)v;
}

#define QMAX8_ 127.0f
#define QMAX4_ 7.0f

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
    uint32_t bad = 0;
    for (size_t t = 0; t < nt; t++) {
        if (!in_group(&T[t], g))
            continue;
        const size_t R = tensor_rows(&T[t]), C = tensor_cols(&T[t]);
        uint8_t *scales = p, *q = p + 4 * R;
        for (size_t r = 0; r < R; r++) {
            const float *x = th + T[t].offset + r * C;
            const float scale = row_scale(x, C, QMAX8_, &bad);
            const float inv = row_inv(scale);
            uint32_t u;
            memcpy(&u, &scale, 4);
            put32(scales + 4 * r, u);
            for (size_t k = 0; k < C; k++)
                q[r * C + k] = (uint8_t)(int8_t)row_q(x[k], inv, QMAX8_);
        }
        p += 4 * R + R * C;
    }
    if (bad)
        return -EINVAL;
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

/* Bytes of one row of C 4-bit values (two per byte, an odd row padded). */
static size_t row_bytes4(size_t C)
{
    return (C + 1u) / 2u;
}

/* The row scales of a packed whole theta (int8: rows of 4 + C bytes; 4-bit: 4 + ceil(C / 2))
   into scales[0 .. *rows), each checked (finite, >= 0) before the caller moves anything; the
   tensors must tile theta in order. 0, -EINVAL (scales too small, a gap) or -EBADMSG. */
static int load_scales(const bnn_tensor_t *T, size_t nt, const uint8_t *buf, int bits, float *scales,
                       size_t n_scales, size_t *rows_out)
{
    const uint8_t *p = buf;
    size_t rows = 0, at = 0;
    for (size_t t = 0; t < nt; t++) {
        const size_t R = tensor_rows(&T[t]), C = tensor_cols(&T[t]);
        if (T[t].offset != at || rows + R > n_scales)
            return -EINVAL;
        for (size_t r = 0; r < R; r++) {
            const float s = getf(p + 4 * r);
            if (!isfinite(s) || s < 0.0f)
                return -EBADMSG;
            scales[rows + r] = s;
        }
        rows += R;
        at += R * C;
        p += R * (4u + (bits == 8 ? C : row_bytes4(C)));
    }
    *rows_out = rows;
    return 0;
}

int bnn_quant_unpack_theta_inplace(const bnn_config_t *cfg, float *th, size_t len, float *scales, size_t n_scales)
{
    if (!cfg || !th || !scales)
        return -EINVAL;
    bnn_tensor_t T[BNN_MAX_TENSORS];
    const size_t nt = bnn_tensors_cfg(cfg, T, BNN_MAX_TENSORS);
    if (len != packed_size_of(T, nt, BNN_GROUP_ALL))
        return -EBADMSG;
    uint8_t *buf = (uint8_t *)th; /* character access: may alias the floats */
    /* The scales, checked before anything moves; the tensors must tile theta in order (the
       int8 values then move to their element's index). */
    size_t rows = 0;
    int rc = load_scales(T, nt, buf, 8, scales, n_scales, &rows);
    if (rc != 0)
        return rc;
    const uint8_t *p;
    /* q of element i to byte i: every destination is at or below its source. */
    p = buf;
    for (size_t t = 0; t < nt; t++) {
        const size_t R = tensor_rows(&T[t]), C = tensor_cols(&T[t]);
        memmove(buf + T[t].offset, p + 4 * R, R * C);
        p += 4 * R + R * C;
    }
    /* Backwards: float i covers bytes 4i..4i+3, values of elements >= i, already read. */
    for (size_t t = nt; t-- > 0;) {
        const size_t R = tensor_rows(&T[t]), C = tensor_cols(&T[t]);
        rows -= R;
        for (size_t r = R; r-- > 0;) {
            const float s = scales[rows + r];
            for (size_t k = C; k-- > 0;) {
                const size_t i = T[t].offset + r * C + k;
                const int8_t q = (int8_t)buf[i];
                th[i] = s * (float)q;
            }
        }
    }
    return 0;
}

/* ---- 4-bit packing ----------------------------------------------------------------------- */

static size_t packed_size4_of(const bnn_tensor_t *T, size_t nt, bnn_group_t g)
{
    size_t s = 0;
    for (size_t i = 0; i < nt; i++)
        if (in_group(&T[i], g))
            s += tensor_rows(&T[i]) * (4u + row_bytes4(tensor_cols(&T[i])));
    return s;
}

/* The signed value of the nibble n (0..15). */
static inline int nibble_value(unsigned n)
{
    return (int)(n ^ 8u) - 8;
}

size_t bnn_quant_packed_size4_cfg(const bnn_config_t *cfg, bnn_group_t g)
{
    if (!cfg)
        return 0;
    bnn_tensor_t T[BNN_MAX_TENSORS];
    const size_t nt = bnn_tensors_cfg(cfg, T, BNN_MAX_TENSORS);
    return packed_size4_of(T, nt, g);
}

int bnn_quant_pack_theta4(const bnn_config_t *cfg, bnn_group_t g, const float *th, uint8_t *buf, size_t cap,
                          size_t *written)
{
    if (!cfg || !th || !buf || !written || (g != BNN_GROUP_MU && g != BNN_GROUP_RHO && g != BNN_GROUP_ALL))
        return -EINVAL;
    bnn_tensor_t T[BNN_MAX_TENSORS];
    const size_t nt = bnn_tensors_cfg(cfg, T, BNN_MAX_TENSORS);
    const size_t need = packed_size4_of(T, nt, g);
    if (cap < need)
        return -ENOSPC;
    uint8_t *p = buf;
    uint32_t bad = 0;
    for (size_t t = 0; t < nt; t++) {
        if (!in_group(&T[t], g))
            continue;
        const size_t R = tensor_rows(&T[t]), C = tensor_cols(&T[t]), RB = row_bytes4(C);
        uint8_t *scales = p, *q = p + 4 * R;
        for (size_t r = 0; r < R; r++) {
            const float *x = th + T[t].offset + r * C;
            const float scale = row_scale(x, C, QMAX4_, &bad);
            const float inv = row_inv(scale);
            uint32_t u;
            memcpy(&u, &scale, 4);
            put32(scales + 4 * r, u);
            uint8_t *qr = q + r * RB;
            for (size_t k = 0; k + 1 < C; k += 2)
                qr[k / 2] = (uint8_t)(((unsigned)row_q(x[k], inv, QMAX4_) & 15u) |
                                      ((unsigned)row_q(x[k + 1], inv, QMAX4_) & 15u) << 4);
            if (C % 2u) /* the odd row's last value, a zero high nibble */
                qr[C / 2] = (uint8_t)((unsigned)row_q(x[C - 1], inv, QMAX4_) & 15u);
        }
        p += R * (4u + RB);
    }
    if (bad)
        return -EINVAL;
    *written = need;
    return 0;
}

int bnn_quant_unpack_theta4(const bnn_config_t *cfg, bnn_group_t g, const uint8_t *buf, size_t len, float *th)
{
    if (!cfg || !th || !buf || (g != BNN_GROUP_MU && g != BNN_GROUP_RHO && g != BNN_GROUP_ALL))
        return -EINVAL;
    bnn_tensor_t T[BNN_MAX_TENSORS];
    const size_t nt = bnn_tensors_cfg(cfg, T, BNN_MAX_TENSORS);
    if (len != packed_size4_of(T, nt, g))
        return -EBADMSG;
    const uint8_t *p = buf;
    for (size_t t = 0; t < nt; t++) { /* every scale first */
        if (!in_group(&T[t], g))
            continue;
        const size_t R = tensor_rows(&T[t]), C = tensor_cols(&T[t]);
        for (size_t r = 0; r < R; r++) {
            const float s = getf(p + 4 * r);
            if (!isfinite(s) || s < 0.0f)
                return -EBADMSG;
        }
        p += R * (4u + row_bytes4(C));
    }
    p = buf;
    for (size_t t = 0; t < nt; t++) {
        if (!in_group(&T[t], g))
            continue;
        const size_t R = tensor_rows(&T[t]), C = tensor_cols(&T[t]), RB = row_bytes4(C);
        const uint8_t *q = p + 4 * R;
        for (size_t r = 0; r < R; r++) {
            const float s = getf(p + 4 * r);
            float *x = th + T[t].offset + r * C;
            for (size_t k = 0; k < C; k++) {
                const unsigned b = q[r * RB + k / 2];
                x[k] = s * (float)nibble_value(k % 2u ? b >> 4 : b & 15u);
            }
        }
        p += R * (4u + RB);
    }
    return 0;
}

int bnn_quant_unpack_theta4_inplace(const bnn_config_t *cfg, float *th, size_t len, float *scales, size_t n_scales)
{
    if (!cfg || !th || !scales)
        return -EINVAL;
    bnn_tensor_t T[BNN_MAX_TENSORS];
    const size_t nt = bnn_tensors_cfg(cfg, T, BNN_MAX_TENSORS);
    if (len != packed_size4_of(T, nt, BNN_GROUP_ALL))
        return -EBADMSG;
    uint8_t *buf = (uint8_t *)th; /* character access: may alias the floats */
    /* The scales, checked before anything moves (the tensors must tile theta in order). */
    size_t rows = 0;
    int rc = load_scales(T, nt, buf, 4, scales, n_scales, &rows);
    if (rc != 0)
        return rc;
    const uint8_t *p;
    /* The values of every tensor to the front, in order: each lands at or below where it was. */
    p = buf;
    size_t d = 0;
    for (size_t t = 0; t < nt; t++) {
        const size_t R = tensor_rows(&T[t]), D = R * row_bytes4(tensor_cols(&T[t]));
        memmove(buf + d, p + 4 * R, D);
        d += D;
        p += 4 * R + D;
    }
    /* Backwards. The byte of element i is at b(i) <= i (every byte before it holds at least one
       element before i), so the bytes 4i..4i+3 of float i hold only values of elements >= i:
       already read. */
    for (size_t t = nt; t-- > 0;) {
        const size_t R = tensor_rows(&T[t]), C = tensor_cols(&T[t]), RB = row_bytes4(C);
        rows -= R;
        d -= R * RB;
        for (size_t r = R; r-- > 0;) {
            const float s = scales[rows + r];
            const uint8_t *qr = buf + d + r * RB;
            float *x = th + T[t].offset + r * C;
            for (size_t k = C; k-- > 0;) {
                const unsigned b = qr[k / 2];
                const int q = nibble_value(k % 2u ? b >> 4 : b & 15u);
                x[k] = s * (float)q;
            }
        }
    }
    return 0;
}

int bnn_quant_round_trip_theta(const bnn_config_t *cfg, unsigned bits, const float *in, float *out)
{
    if (!cfg || !in || !out || (bits != 8u && bits != 4u))
        return -EINVAL;
    const float qmax = bits == 8u ? QMAX8_ : QMAX4_;
    bnn_tensor_t T[BNN_MAX_TENSORS];
    const size_t nt = bnn_tensors_cfg(cfg, T, BNN_MAX_TENSORS);
    uint32_t bad = 0;
    for (size_t t = 0; t < nt; t++) {
        const size_t R = tensor_rows(&T[t]), C = tensor_cols(&T[t]);
        for (size_t r = 0; r < R; r++) {
            const float *x = in + T[t].offset + r * C;
            float *y = out + T[t].offset + r * C;
            /* the scale as the packer writes it and the unpacker reads it back (the same bits),
               then the unpacker's product: the whole row is read before any of it is written */
            const float scale = row_scale(x, C, qmax, &bad);
            const float inv = row_inv(scale);
            for (size_t k = 0; k < C; k++)
                y[k] = scale * (float)row_q(x[k], inv, qmax);
        }
    }
    return bad ? -EINVAL : 0;
}

/* ---- int8 inference ----------------------------------------------------------------------
 * Chunks of up to BNN_QUANT_CHUNK points go through each layer together: the SIREN layer row
 * by row over the chunk's points (fp32, into Y, then each point's activations are quantised
 * into column p of A), then per layer one int8 GEMM C = A x W^T (ai/q8_gemm.h: the kernel
 * chosen at run time, or the pure-C reference), then the scaling, bias and ReLU per element
 * into Y and the next layer's per-point quantisation back into A. Every loop over the chunk
 * runs over all its QCH_ columns (whole vectors of points), padding points included. Every
 * float operation is the one the per-point path does, on the same operands and in the same
 * order (the int32 sums are exact whatever the kernel), so the logits are bit-identical to it
 * and across kernels.
 * Where the time went (perf, Zen 4): before, libm's sinf (one call per SIREN element) was
 * ~55-70 % of the pass; the per-point maxima's scalar reductions and the byte-wise scatter of
 * quads most of the rest outside the GEMM. Now (small) the GEMM ~37 %, the sine ~20 %, the
 * requantisation passes the rest. */

/* Where each tensor of the packed stream starts (scales pointer) for the inference path. */
typedef struct qtensor {
    const uint8_t *scales;
    const int8_t *q;
    size_t rows, cols;
} qtensor_t;

#define QW_ BNN_QUANT_WMAX_          /* widest layer */
#define QQ_ ((QW_ + 3u) / 4u)        /* its quads of inputs */
#define QCH_ BNN_QUANT_CHUNK_PADDED  /* points per chunk, padded to the kernels' granularity */
#if defined(Q8_X86)
#define QWSUM_ ((BNN_LAYERS_MAX + 1u) * QW_) /* the VNNI kernels' row sums, every layer */
#else
#define QWSUM_ 1u                            /* no kernel of this build reads them */
#endif
_Static_assert(QCH_ == Q8_PAD_POINTS(BNN_QUANT_CHUNK), "bnn_quant.h and q8_gemm.h disagree");
_Static_assert(BNN_QUANT_CHUNK >= 1u, "BNN_QUANT_CHUNK must be >= 1");
/* the arrays of bnn_quant_forward_mean (A, C, Y, wsum, a, wx, wy, bq0, sa, sa_next),
 * relu_requant (amax, inv, word, bq, bt, sw) and quantise_point (m, q), and 1 KB for the rest */
_Static_assert(QQ_ * 4u * QCH_ + 4u * (2u * QW_ * QCH_ + 5u * QCH_ + QWSUM_ + 7u * QW_) +
                       QQ_ * 4u + 64u + 1024u <=
                   BNN_QUANT_STACK_BYTES,
               "BNN_QUANT_STACK_BYTES understates the stack of bnn_quant_forward_mean");

/* (int8_t)roundf(v), without the libm call so that the loops vectorise. i = trunc(v) (the
 * conversion) and d = v - i is exact (Sterbenz), so rounding half away from zero is
 * i + (d >= 0.5) - (d <= -0.5): the same value as roundf for every float |v| < 2^31 (checked
 * once over all 2.65e9 of them; tests/ai/test_q8.c checks every float of 0.25 <= |v| < 128;
 * the quantiser's arguments are within +-127.0001). Non-finite v: undefined, as roundf's
 * conversion to int8_t was. */
static inline int8_t round_q8(float v)
{
    const int32_t i = (int32_t)v;
    const float d = v - (float)i;
    return (int8_t)(i + (d >= 0.5f) - (d <= -0.5f));
}

/* round_q8 of v >= 0 (a ReLU output times a positive scale): the same value, d >= 0. */
static inline int8_t round_q8_pos(float v)
{
    const int32_t i = (int32_t)v;
    const float d = v - (float)i;
    return (int8_t)(i + (d >= 0.5f));
}

/* y = scale_a * scale_w * acc + scale_b * bq, the output of a layer before the ReLU, contracted
 * exactly as the per-point path was. The firmware is built with -ffp-contract=fast (Makefile,
 * FW_FP), so where the CPU has FMA the compilers fused one of the two products into the sum of
 * that one statement: GCC the first, fma(sa * sw, acc, sb * bq), clang the bias,
 * fma(sb, bq, (sa * sw) * acc); without FMA (x86-64-v2, contraction off) neither. In the chunk
 * loops the compilers would be free to choose otherwise (the bias product is loop-invariant
 * there, and vectorised or unrolled across rows GCC has fused it), so the choice is made here:
 * t = (sa * sw) * acc is written out by the caller, the bias term bt = sb * bq comes from an
 * array (GCC: only t can be fused into t + bt, as before), or clang's fma is written out. */
#if defined(__clang__) && (defined(__FMA__) || defined(__ARM_FEATURE_FMA))
#define Q8_FUSE_BIAS 1
#else
#define Q8_FUSE_BIAS 0
#endif
static inline float affine(float t, float sb, float bq, float bt)
{
#if Q8_FUSE_BIAS
    (void)bt;
    return fmaf(sb, bq, t);
#else
    (void)sb;
    (void)bq;
    return t + bt;
#endif
}

/* Rows Y[j * QCH_ + p] (j < out) of a layer's outputs quantised per point into A as the next
 * layer's input: sa[p] = amax[p] / 127 (amax: max_j |Y(j, p)|), q = round(Y / sa); each quad
 * of rows of a point is packed into one 32-bit word of A (the byte of row j0 + r at bit 8r,
 * little-endian: A's layout), so all of it runs on whole vectors of points, the QCH_ columns
 * of the chunk (the padding points' values are finite: the kernels never read more of A than
 * its padding, and those columns' logits are not written). nonneg: Y >= 0 (ReLU outputs). */
static inline void requant_rows(const float *Y, size_t out, const float *amax, float *sa,
                                int8_t *A, const int nonneg)
{
    float inv[QCH_];
    for (size_t p = 0; p < QCH_; p++) {
        sa[p] = amax[p] / 127.0f;
        inv[p] = sa[p] > 0.0f ? 1.0f / sa[p] : 0.0f;
    }
#define Q8_RQ_(v) ((uint32_t)(uint8_t)(nonneg ? round_q8_pos(v) : round_q8(v)))
    for (size_t j0 = 0; j0 < out; j0 += 4) {
        uint32_t word[QCH_];
        const float *y = Y + j0 * QCH_;
        if (j0 + 4 <= out) {
            for (size_t p = 0; p < QCH_; p++)
                word[p] = Q8_RQ_(y[p] * inv[p]) | Q8_RQ_(y[QCH_ + p] * inv[p]) << 8 |
                          Q8_RQ_(y[2 * QCH_ + p] * inv[p]) << 16 |
                          Q8_RQ_(y[3 * QCH_ + p] * inv[p]) << 24;
        } else { /* the last, partial quad: zero bytes past the last row */
            for (size_t p = 0; p < QCH_; p++)
                word[p] = 0;
            for (size_t r = 0; j0 + r < out; r++)
                for (size_t p = 0; p < QCH_; p++)
                    word[p] |= Q8_RQ_(y[r * QCH_ + p] * inv[p]) << (8 * r);
        }
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
        memcpy(A + j0 * QCH_, word, sizeof word);
#else
        for (size_t p = 0; p < QCH_; p++) /* the bytes in A's order, whatever the host's */
            for (size_t r = 0; r < 4; r++)
                A[j0 * QCH_ + 4 * p + r] = (int8_t)(uint8_t)(word[p] >> (8 * r));
#endif
    }
#undef Q8_RQ_
}

/* The chunk's passes in a build for an older baseline (ARCH=portable: x86-64-v2) also as an
 * AVX2 clone, chosen at load time like AI_WIDE's (ai/ai_fastmath.h), 8 points per vector
 * instead of 4: measured 1.0x fp32 for `small` without. AI_WIDE's clones would not do: they
 * have FMA, so the compilers would contract there and not in the baseline, and the logits
 * would depend on the CPU; "avx2" has no FMA, so every clone rounds alike. */
#if defined(__x86_64__) && defined(__linux__) && !defined(__AVX2__) &&                           \
    (defined(__GNUC__) || defined(__clang__)) && !defined(AI_TSAN_) && !defined(Q8_NO_SIMD)
#define Q8_WIDE __attribute__((target_clones("avx2", "default")))
#else
#define Q8_WIDE
#endif

/* The SIREN layer of the chunk's points (xs, ys: QCH_ of them, padding points at 0) into Y,
 * quantised into A; sa: the points' scales. Per element the statement of the per-point path,
 * z = (s q_x) x + ((s q_y) y + s_b q_b), each product in parentheses a float taken once per
 * call (so no product is loop-invariant here: the compilers contract this loop as they do
 * the per-point one, fma(sx, x, fma(sy, y, bb)) with FMA, as tested), then ai_fm_sinf (libm's
 * sinf, one call per element, was most of the int8 pass). Rows outer, points inner: the
 * maxima per point are vector maxima, no reduction across lanes. */
Q8_WIDE static void siren_chunk(const float *xs, const float *ys, const float *sx, const float *sy,
                        const float *bb, float w0, size_t S, float *Y, float *sa, int8_t *A)
{
    float amax[QCH_];
    for (size_t p = 0; p < QCH_; p++)
        amax[p] = 0.0f;
    for (size_t j = 0; j < S; j++) {
        const float sxj = sx[j], syj = sy[j], bbj = bb[j];
        float *y = Y + j * QCH_;
        for (size_t p = 0; p < QCH_; p++) {
            const float v = ai_fm_sinf(w0 * (sxj * xs[p] + (syj * ys[p] + bbj)));
            y[p] = v;
            amax[p] = fabsf(v) > amax[p] ? fabsf(v) : amax[p];
        }
    }
    requant_rows(Y, S, amax, sa, A, 0);
}

/* A hidden layer's outputs y(p, j) = relu(sa[p] * scale_w[j] * C[j, p] + b_j) into Y, then
 * quantised into A as the next layer's input (sa_next: the points' new scales). */
Q8_WIDE static void relu_layer(const qtensor_t *W, const qtensor_t *b, const int32_t *C, size_t out,
                       const float *sa, float *sa_next, float *Y, int8_t *A)
{
    float amax[QCH_], bq[QW_], bt[QW_], sw[QW_];
    const float sb = getf(b->scales);
    for (size_t j = 0; j < out; j++) {
        bq[j] = (float)b->q[j];
        bt[j] = sb * bq[j];
        sw[j] = getf(W->scales + 4 * j);
    }
    for (size_t p = 0; p < QCH_; p++)
        amax[p] = 0.0f;
    for (size_t j = 0; j < out; j++) {
        const float swj = sw[j], bqj = bq[j], btj = bt[j];
        const int32_t *c = C + j * QCH_;
        float *y = Y + j * QCH_;
        for (size_t p = 0; p < QCH_; p++) {
            float v = affine(sa[p] * swj * (float)c[p], sb, bqj, btj);
            v = v > 0.0f ? v : 0.0f;
            y[p] = v;
            amax[p] = v > amax[p] ? v : amax[p]; /* v >= 0: |v| */
        }
    }
    requant_rows(Y, out, amax, sa_next, A, 1);
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
    const q8_kernel_t *K = q8_active();
    int32_t wsum[QWSUM_];
    if (K->needs_wsum && QWSUM_ > 1u)
        for (size_t l = 0; l <= L; l++)
            q8_row_sums(Q[2 + 2 * l].q, l < L ? H : 1, l == 0 ? S : H, wsum + l * QW_);
    int8_t A[QQ_ * 4u * QCH_]; /* the chunk's activations, A(p, k) = A[k/4 * 4 QCH_ + 4p + k%4] */
    int32_t C[QW_ * QCH_];     /* a layer's int32 sums, C[j * QCH_ + p] */
    float Y[QW_ * QCH_];       /* a hidden layer's outputs, Y[j * QCH_ + p] */
    float sa[QCH_], sa_next[QCH_];
    const float w0 = cfg->w0;
    /* Every byte a kernel may read is initialised (padding points, the last quad's tail). */
    memset(A, 0, sizeof A);
    memset(C, 0, sizeof C); /* the padding points' sums where a kernel does not write them */
    const float sb0 = getf(Q[1].scales);
    float sx[QW_], sy[QW_], bb[QW_]; /* the SIREN layer's products s q of W0 and b0 */
    for (size_t j = 0; j < S; j++) {
        const float s = getf(Q[0].scales + 4 * j);
        sx[j] = s * (float)Q[0].q[2 * j];
        sy[j] = s * (float)Q[0].q[2 * j + 1];
        bb[j] = sb0 * (float)Q[1].q[j];
    }
    float xs[QCH_], ys[QCH_]; /* the chunk's points, the padding ones at the origin */
    /* the output layer's bias: sb * bq, apart (see affine) */
    const float sbo = getf(Q[3 + 2 * L].scales), bqo = (float)Q[3 + 2 * L].q[0], bto = sbo * bqo;
    for (size_t i0 = 0; i0 < n;) {
        const size_t want = n - i0 < BNN_QUANT_CHUNK ? n - i0 : BNN_QUANT_CHUNK;
        size_t np = 0; /* the chunk stops before a non-finite point */
        while (np < want && isfinite(xy[2 * (i0 + np)]) && isfinite(xy[2 * (i0 + np) + 1]))
            np++;
        if (np == 0)
            return -EINVAL;
        for (size_t i = 0; i < QCH_; i++) {
            xs[i] = i < np ? xy[2 * (i0 + i)] : 0.0f;
            ys[i] = i < np ? xy[2 * (i0 + i) + 1] : 0.0f;
        }
        siren_chunk(xs, ys, sx, sy, bb, w0, S, Y, sa, A);
        size_t in = S;
        for (size_t l = 0; l < L; l++) {
            K->fn(np, H, in, A, QCH_, Q[2 + 2 * l].q, K->needs_wsum ? wsum + l * QW_ : NULL, C,
                  QCH_);
            relu_layer(&Q[2 + 2 * l], &Q[3 + 2 * l], C, H, sa, sa_next, Y, A);
            memcpy(sa, sa_next, sizeof sa);
            in = H;
        }
        K->fn(np, 1, H, A, QCH_, Q[2 + 2 * L].q, K->needs_wsum ? wsum + L * QW_ : NULL, C, QCH_);
        const float sw = getf(Q[2 + 2 * L].scales);
        for (size_t i = 0; i < np; i++)
            logits[i0 + i] = affine(sa[i] * sw * (float)C[i], sbo, bqo, bto);
        i0 += np;
        if (np < want)
            return -EINVAL; /* xy[i0] is not finite; the logits before it are written */
    }
    return 0;
}
