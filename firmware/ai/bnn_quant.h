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
 * ALL-or-MU state: SIREN layer in fp32 from the dequantised W0, b0 (2 inputs: negligible);
 * every Bayesian layer (mean weights) and the output layer as int8 weights x int8 activations
 * with int32 accumulation: each point's input activation row is quantised symmetrically
 * (scale_a = max |a| / 127), y_j = scale_a * scale_w[j] * sum_k qa_k qw_jk + b_j (bias dequantised
 * to fp32). Points are processed one at a time, so the only scratch is a few KB of stack.
 * Thread-safe, no allocation. */
#ifndef AI_BNN_QUANT_H
#define AI_BNN_QUANT_H

#include <stddef.h>
#include <stdint.h>

#include "ai/bnn.h"

/* Packed bytes of group g of this model. */
size_t bnn_quant_packed_size(const bnn_model_t *m, bnn_group_t g);

/* Largest packed size of the preset (whole theta). */
#define BNN_QUANT_MAX_ROWS_                                                                    \
    (BNN_SIREN_MAX + 2u + BNN_LAYERS_MAX * 2u * (BNN_HIDDEN_MAX + 1u) + 2u)
#define BNN_QUANT_MAX_BYTES (BNN_N_PARAMS + 4u * BNN_QUANT_MAX_ROWS_)

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

#endif /* AI_BNN_QUANT_H */
