/* BNN checkpoints in a caller-provided byte buffer (the firmware has no files; the host side
 * writes the bytes to disk).
 *
 * Format (all integers and floats little-endian, floats IEEE-754 binary32):
 *   off  size  field
 *     0     4  magic "BNNC"
 *     4     4  version (BNN_CKPT_VERSION)
 *     8     4  header length (BNN_CKPT_HEADER_BYTES)
 *    12    16  fingerprint: input dim (2), SIREN width S, hidden width H, Bayesian layers L
 *    28     4  n_params
 *    32     8  model seed
 *    40     4  Adam step count of the mu group
 *    44     4  Adam step count of the rho group
 *    48     4  flags: bit 0 = payload includes the Adam moments,
 *                 bit 1 = payload ends with the epistemic posterior (bnn_post.h's stored form)
 *    52     4  payload length in bytes
 *    56     4  CRC-32 (IEEE) of bytes [0, 56) followed by the payload
 *    60        payload: theta (n_params floats, bnn.h layout), then if flag bit 0 the Adam
 *              first moments and second moments (n_params floats each), then if flag bit 1
 *              the posterior (BNN_POST_WIRE_BYTES(S + 1) bytes)
 * Loading parses and validates everything (length, magic, version, fingerprint against the
 * model's configuration, payload length, CRC, finite values) before copying anything: on any
 * error the model is untouched. No allocation; thread-safety as bnn.h. */
#ifndef AI_BNN_CKPT_H
#define AI_BNN_CKPT_H

#include <stddef.h>
#include <stdint.h>

#include "ai/bnn.h"
#include "ai/bnn_post.h"

#define BNN_CKPT_VERSION 1u
#define BNN_CKPT_HEADER_BYTES 60u
#define BNN_CKPT_FLAG_ADAM 1u
#define BNN_CKPT_FLAG_POST 2u
/* Largest checkpoint of this preset (with Adam moments and a posterior). */
#define BNN_CKPT_MAX_BYTES (BNN_CKPT_HEADER_BYTES + 3u * BNN_N_PARAMS * 4u + BNN_POST_WIRE_MAX)

/* Bytes bnn_ckpt_save() writes for this model (with_adam: include the Adam moments). */
size_t bnn_ckpt_size(const bnn_model_t *m, int with_adam);

/* Serialise into buf (cap bytes). *written = bytes used. Returns 0, -EINVAL, or -ENOSPC
 * when cap < bnn_ckpt_size(). */
FS_MUST_CHECK int bnn_ckpt_save(const bnn_model_t *m, int with_adam, uint8_t *buf, size_t cap,
                          size_t *written);

/* The same with the model's epistemic posterior appended (post may be NULL: none). */
size_t bnn_ckpt_size_post(const bnn_model_t *m, int with_adam, const bnn_post_t *post);
FS_MUST_CHECK int bnn_ckpt_save_post(const bnn_model_t *m, int with_adam, const bnn_post_t *post, uint8_t *buf,
                                     size_t cap, size_t *written);

/* Parse buf (len bytes) into m, whose configuration (bnn_init) must match the checkpoint's
 * fingerprint. Restores theta, the model seed and, if present, the Adam moments and step
 * counts (otherwise the Adam state is reset). Returns 0 or a negative code, with *reason (if
 * reason != NULL) set to a static human-readable string:
 *   -EINVAL   NULL arguments
 *   -ENODATA  truncated (shorter than its header or than header + payload length)
 *   -EBADMSG  bad magic, bad header length, inconsistent lengths, or non-finite values
 *   -EPROTONOSUPPORT  unknown version
 *   -ENOEXEC  fingerprint (dimensions) differ from the model's: another preset/config
 *   -EILSEQ   CRC mismatch (corrupt)
 * On error m is unchanged. */
FS_MUST_CHECK int bnn_ckpt_load(bnn_model_t *m, const uint8_t *buf, size_t len, const char **reason);

/* bnn_ckpt_load, and the posterior into *post when post != NULL: the stored one (validated
 * with the rest, before anything is copied), or an empty one (robots == 0) when the
 * checkpoint holds none. */
FS_MUST_CHECK int bnn_ckpt_load_post(bnn_model_t *m, bnn_post_t *post, const uint8_t *buf, size_t len,
                                     const char **reason);

#endif /* AI_BNN_CKPT_H */
