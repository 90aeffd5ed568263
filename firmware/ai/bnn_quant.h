/* Int8 symmetric per-row quantisation of the BNN parameter state (docs/architecture.md section 2):
 * for exchanged states (DiNNO) and for inference; training keeps fp32 master weights.
 *
 * Packing of one group (BNN_GROUP_MU, BNN_GROUP_RHO or BNN_GROUP_ALL) of theta: its tensors
 * in theta order (bnn_tensors()); for each tensor, one "row" is one row of a weight matrix
 * ([out x in]: out rows of `in` values) or a whole bias vector (1 row). Per row:
 *     scale = max_k |x_k| / 127 (fp32, little-endian; 0 for an all-zero row),
 *     q_k = round(x_k / scale) in [-127, 127] (int8),  x_k ~ scale * q_k,
 * so |x_k - scale * q_k| <= scale / 2 for every element. The packed bytes are, per tensor,
 * all its row scales (4 bytes each) then all its int8 values row-major. No header: both sides
 * know the configuration (DiNNO peers share the preset).
 *
 * Int8 inference (bnn_quant_forward_mean): the mean-weight network computed from a packed
 * ALL-or-MU state: SIREN layer in fp32 from the dequantised W0, b0 (2 inputs: negligible
 * products), z_j = (s_j qx_j) x + ((s_j qy_j) y + s_b qb_j) with each parenthesised product one
 * float, a_j = ai_fm_sinf(w0 z_j) (ai/ai_fastmath.h: max abs error 1.3e-7); every Bayesian layer
 * (mean weights) and the output layer as int8 weights x int8 activations with int32
 * accumulation: each point's input activation row is quantised symmetrically (scale_a = max
 * |a| / 127, qa_k = roundf(a_k / scale_a)), y_j = scale_a * scale_w[j] * sum_k qa_k qw_jk + b_j
 * (bias dequantised to fp32), ReLU between the Bayesian layers.
 *
 * Chunked path: the points go through the network BNN_QUANT_CHUNK at a time (32 on x86-64, 1
 * elsewhere; a board may define it). Per chunk, the SIREN layer runs row by row over the
 * chunk's points (vectors of points: the per-point maxima are vector maxima) into a float
 * matrix Y [rows x points], quantised per point into the chunk's activation matrix A, four
 * rows of a point packed per 32-bit word (A's layout, ai/q8_gemm.h); each following layer is
 * then one int8 GEMM, A x W^T -> int32 [points x out] (ai/q8_gemm.h), and one pass of
 * scaling, bias and ReLU into Y and the same requantisation back into A. The int32 sums are
 * exact, and every float operation is the per-point one on the same operands (roundf by an
 * exact equivalent that vectorises; the one FMA the compiler fused into y_j under the
 * firmware's -ffp-contract=fast made explicit, bnn_quant.c), so the logits are bit-identical
 * to the per-point computation for every n, and across kernels (tests/ai/test_q8.c).
 *
 * GEMM kernels (ai/q8_gemm.h), chosen once at run time from what the CPU has (q8_active):
 * AVX-512 VNNI on zmm (vpdpbusd, 16 points per vector), AVX-512 VNNI on ymm, AVX-VNNI (ymm),
 * an exact AVX2 one, else the pure-C reference, which is the only one off x86-64 and the
 * reference of the others. The x86 ones are compiled into every x86-64 build whatever its
 * baseline. q8_force() pins one (tests, benchmarks); q8_kernel_name() names the one in use.
 * A chunk that meets a non-finite point stops before it: the logits of the points before it
 * are written and the call returns -EINVAL, as the per-point path did.
 *
 * Stack: A (the chunk's activations, int8), one layer's int32 sums and float outputs [out x
 * chunk], the VNNI kernels' per-row weight sums of every layer and a few vectors: at most
 * BNN_QUANT_STACK_BYTES (x86-64, chunk 32: ~87 KB for the paper preset, ~44 KB for small,
 * ~23 KB for mcu; chunk 1 off x86: < 5 KB for mcu). Thread-safe, no allocation. */
#ifndef AI_BNN_QUANT_H
#define AI_BNN_QUANT_H

#include <stddef.h>
#include <stdint.h>

#include "ai/bnn.h"

/* Points per chunk of the int8 inference path; the x86-64 kernels compute whole groups of 16
 * points, so the buffers hold BNN_QUANT_CHUNK_PADDED (a multiple of 16 there). */
#ifndef BNN_QUANT_CHUNK
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) && !defined(Q8_NO_SIMD)
#define BNN_QUANT_CHUNK 32u
#else
#define BNN_QUANT_CHUNK 1u
#endif
#endif
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) && !defined(Q8_NO_SIMD)
#define BNN_QUANT_CHUNK_PADDED ((BNN_QUANT_CHUNK + 15u) / 16u * 16u)
#else
#define BNN_QUANT_CHUNK_PADDED (BNN_QUANT_CHUNK)
#endif
#define BNN_QUANT_WMAX_ (BNN_SIREN_MAX > BNN_HIDDEN_MAX ? BNN_SIREN_MAX : BNN_HIDDEN_MAX)
/* Largest stack of one bnn_quant_forward_mean call (its buffers, with margin for the rest). */
#define BNN_QUANT_STACK_BYTES                                                                  \
    (BNN_QUANT_CHUNK_PADDED * (9u * BNN_QUANT_WMAX_ + 24u) +                                   \
     4u * (BNN_LAYERS_MAX + 9u) * BNN_QUANT_WMAX_ + 1088u)

/* Packed bytes of group g of this model. */
size_t bnn_quant_packed_size(const bnn_model_t *m, bnn_group_t g);

/* Largest packed size of the preset (whole theta). */
#define BNN_QUANT_MAX_ROWS_                                                                    \
    (BNN_SIREN_MAX + 2u + BNN_LAYERS_MAX * 2u * (BNN_HIDDEN_MAX + 1u) + 2u)
#define BNN_QUANT_MAX_BYTES (BNN_N_PARAMS + 4u * BNN_QUANT_MAX_ROWS_)
/* Largest number of rows (scales) of a packed whole theta of the preset. */
#define BNN_QUANT_MAX_ROWS (BNN_QUANT_MAX_ROWS_)

/* Quantise group g of theta into buf. *written = bytes. Returns 0, -EINVAL or -ENOSPC. */
FS_MUST_CHECK int bnn_quant_pack(const bnn_model_t *m, bnn_group_t g, uint8_t *buf, size_t cap,
                           size_t *written);

/* Dequantise buf (exactly bnn_quant_packed_size(m, g) bytes) into group g of theta.
 * Validates the length and that every scale is finite and >= 0 before writing anything.
 * Returns 0, -EINVAL or -EBADMSG. */
FS_MUST_CHECK int bnn_quant_unpack(bnn_model_t *m, bnn_group_t g, const uint8_t *buf, size_t len);

/* Int8 inference with the mean weights from a packed state of group BNN_GROUP_ALL or
 * BNN_GROUP_MU (the rho group is not needed) of a model with configuration cfg.
 * xy: n interleaved points; logits: n outputs. Returns 0, -EINVAL or -EBADMSG. */
FS_MUST_CHECK int bnn_quant_forward_mean(const bnn_config_t *cfg, bnn_group_t g, const uint8_t *packed,
                                   size_t len, const float *xy, size_t n, float *logits);

/* The same on a bare parameter vector theta (n_params floats of configuration cfg), for code
 * that holds states but no model (the GP core packs and unpacks the peers' states). */
size_t bnn_quant_packed_size_cfg(const bnn_config_t *cfg, bnn_group_t g);
FS_MUST_CHECK int bnn_quant_pack_theta(const bnn_config_t *cfg, bnn_group_t g, const float *theta, uint8_t *buf,
                                       size_t cap, size_t *written);
FS_MUST_CHECK int bnn_quant_unpack_theta(const bnn_config_t *cfg, bnn_group_t g, const uint8_t *buf, size_t len,
                                         float *theta);
/* The same for a whole theta (BNN_GROUP_ALL), in place: th holds the len packed bytes at its
 * start and has room for n_params floats; they become theta. The row scales are first copied
 * to scales (n_scales >= the rows; BNN_QUANT_MAX_ROWS is enough for the preset) and checked as
 * bnn_quant_unpack_theta does, before anything moves; then the int8 values move to the front
 * and expand backwards, element i (bytes 4i..4i+3) written after every value it overwrites
 * was read. The values are bnn_quant_unpack_theta's, bit for bit. Used by the GP core, which
 * decodes the peers' states in its reassembly buffers instead of a second copy. Returns 0,
 * -EINVAL (NULL, or scales too small) or -EBADMSG (length, a scale). */
FS_MUST_CHECK int bnn_quant_unpack_theta_inplace(const bnn_config_t *cfg, float *th, size_t len, float *scales,
                                                 size_t n_scales);

/* ---- 4-bit packing (the compressed exchange, ai/dinno_codec.h's DINNO_CODEC_INT4_EF) ----
 * The rows of the int8 packing, in the same order, with
 *     scale = max_k |x_k| / 7 (fp32, little-endian; 0 for an all-zero row),
 *     q_k = round(x_k / scale) in [-7, 7],  x_k ~ scale * q_k,
 * so |x_k - scale * q_k| <= scale / 2. The packed bytes are, per tensor, all its row scales (4
 * bytes each) then its rows, each in ceil(C / 2) bytes: element 2j of the row in the low nibble
 * of byte j, element 2j + 1 in the high nibble (4-bit two's complement); a row of odd length ends
 * with a zero high nibble. The nibble 8 (-8) is never written; a receiver takes it as -8.
 * About an eighth of the fp32 state, plus the scales. Both packers (int8 and 4-bit) refuse a
 * non-finite element (-EINVAL; buf then holds nothing usable): its row has no scale. */
size_t bnn_quant_packed_size4_cfg(const bnn_config_t *cfg, bnn_group_t g);
/* Largest 4-bit packed size of the preset (whole theta): a row of C values takes at most
 * (C + 1) / 2 bytes. */
#define BNN_QUANT4_MAX_BYTES ((BNN_N_PARAMS + BNN_QUANT_MAX_ROWS_ + 1u) / 2u + 4u * BNN_QUANT_MAX_ROWS_)
FS_MUST_CHECK int bnn_quant_pack_theta4(const bnn_config_t *cfg, bnn_group_t g, const float *theta, uint8_t *buf,
                                        size_t cap, size_t *written);
/* Validates the length and every scale (finite, >= 0) before writing anything. 0, -EINVAL or
 * -EBADMSG. */
FS_MUST_CHECK int bnn_quant_unpack_theta4(const bnn_config_t *cfg, bnn_group_t g, const uint8_t *buf, size_t len,
                                          float *theta);
/* As bnn_quant_unpack_theta_inplace, for the 4-bit packing of a whole theta: the values'
 * bytes move to the front, then expand backwards (the byte of element i is at or below i, so
 * float i overwrites only values already read); bnn_quant_unpack_theta4's floats, bit for bit. */
FS_MUST_CHECK int bnn_quant_unpack_theta4_inplace(const bnn_config_t *cfg, float *th, size_t len, float *scales,
                                                  size_t n_scales);

/* out = what unpacking the packing of the whole theta `in` gives, bit for bit, without the
 * bytes: bits 8 (bnn_quant_pack_theta + bnn_quant_unpack_theta) or 4 (..._theta4). The rows'
 * scales and values are computed by the packers' own code. out may equal in. 0, or -EINVAL
 * (NULL, bits, a non-finite element: out then holds nothing usable). */
FS_MUST_CHECK int bnn_quant_round_trip_theta(const bnn_config_t *cfg, unsigned bits, const float *in, float *out);

#endif /* AI_BNN_QUANT_H */
