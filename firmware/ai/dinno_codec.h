/* How a robot's DiNNO state travels: the codecs of the exchange (fp32, int8, and the compressed
 * exchanges with error feedback), shared by the GP core (which packs what the AI core hands it
 * and expands what arrives, in place) and the AI core / the in-process fleet (which need, bit
 * for bit, the floats a receiver will hold: dinno_codec_channel).
 *
 *   DINNO_CODEC_FP32     the state as it is (4 bytes per parameter).
 *   DINNO_CODEC_INT8     the state quantised, int8 per element with one float scale per row
 *                        (bnn_quant's packing): the receivers hold Q(theta).
 *   DINNO_CODEC_INT8_EF  the same packing, but of a DIFFERENCE against the sender's public copy
 *                        (CHOCO-style error feedback, dinno.h "Compressed exchange"): what the
 *                        GP core is handed is theta - public copy (or, on a key round, theta).
 *   DINNO_CODEC_INT4_EF  as INT8_EF with 4-bit values (-7..7, two per byte) and one float scale
 *                        per row: the aggressive setting (bnn_quant's 4-bit packing: the same
 *                        rows, scale = row max |v| / 7, low nibble first, an odd row padded with
 *                        a zero nibble; the layout in ai/bnn_quant.h).
 * The GP core does not care which vector it is handed: encode packs it, decode expands it.
 *
 * Pure functions; no allocation; the buffers are the caller's. */
#ifndef AI_DINNO_CODEC_H
#define AI_DINNO_CODEC_H

#include <stddef.h>
#include <stdint.h>

#include "ai/bnn.h"

typedef enum dinno_codec {
    DINNO_CODEC_FP32 = 0,
    DINNO_CODEC_INT8 = 1,
    DINNO_CODEC_INT8_EF = 2,
    DINNO_CODEC_INT4_EF = 3,
} dinno_codec_t;

#define DINNO_CODEC_COUNT 4u

/* 1 for the codecs that send differences against a public copy (INT8_EF, INT4_EF). */
int dinno_codec_is_ef(dinno_codec_t c);

/* "fp32" | "int8" | "int8-ef" | "int4-ef" <-> codec; parse returns 0 or -EINVAL. */
const char *dinno_codec_name(dinno_codec_t c);
FS_MUST_CHECK int dinno_codec_parse(const char *name, dinno_codec_t *out);

/* Bytes of one encoded whole state (BNN_GROUP_ALL) of configuration cfg. 0 for a bad codec. */
size_t dinno_codec_bytes(const bnn_config_t *cfg, dinno_codec_t c);

/* The largest of dinno_codec_bytes over the codecs, for the preset (compile-time bound): the
 * fp32 state's (dinno_codec.c asserts that the packings' bounds, BNN_QUANT_MAX_BYTES and
 * BNN_QUANT4_MAX_BYTES, are below it). */
#define DINNO_CODEC_MAX_BYTES (BNN_N_PARAMS * 4u)

/* Encodes v (n_params floats of cfg) into buf (cap bytes); *written = dinno_codec_bytes.
 * 0, -EINVAL (NULL, bad codec or cfg, a non-finite value for the quantised codecs: buf then
 * holds nothing usable) or -ENOSPC. fp32 copies any value: its receivers refuse the state. */
FS_MUST_CHECK int dinno_codec_encode(const bnn_config_t *cfg, dinno_codec_t c, const float *v, uint8_t *buf,
                                     size_t cap, size_t *written);

/* Decodes in place: th holds the len encoded bytes at its start and has room for n_params
 * floats; they become the floats. scales: room for BNN_QUANT_MAX_ROWS floats (work space; fp32
 * does not use it: NULL is fine there). Validates everything (length, finite fp32 values,
 * finite scales >= 0) before anything moves. 0, -EINVAL (NULL, bad codec or cfg, too few
 * scales) or -EBADMSG (what arrived). */
FS_MUST_CHECK int dinno_codec_decode_inplace(const bnn_config_t *cfg, dinno_codec_t c, float *th, size_t len,
                                             float *scales, size_t n_scales);

/* out = what a receiver holds after encode + decode of in (n_params floats), bit for bit,
 * without the bytes (out may equal in; fp32: a copy). 0 or -EINVAL (NULL, bad codec or cfg,
 * or a non-finite value, for every codec: no receiver would hold such a state; out then
 * holds nothing usable). */
FS_MUST_CHECK int dinno_codec_channel(const bnn_config_t *cfg, dinno_codec_t c, const float *in, float *out);

#endif /* AI_DINNO_CODEC_H */
