/* What the model knows: the epistemic uncertainty of the AI core's map in ONE forward pass,
 * from a Gaussian posterior over a Bayesian linear read-out of the network's SIREN features
 * at initialisation (docs/uncertainty.md has the method, why these features, and the figures).
 *
 *   phi(x) = [h0(x); 1]   the SIREN layer's output (bnn.h) under the weights the posterior was
 *                         made with (bnn_post_init copies them: the model's initial ones, which
 *                         every robot of a fleet shares through the model seed), D = S + 1
 *   f(x)   = w . phi(x),  w ~ N(0, I / lambda0)                    the read-out's prior
 *   each observation x_i adds beta phi(x_i) phi(x_i)^T to the precision:
 *   A      = lambda0 I + beta P,   P = sum_i phi(x_i) phi(x_i)^T   (the data precision)
 *   var(x) = phi(x)^T A^-1 phi(x) = |L^-1 phi(x)|^2,  A = L L^T   (Cholesky)
 *   known(x) = var(x) / prior(x),  prior(x) = |phi(x)|^2 / lambda0 (the share left, in (0, 1])
 * This is the Bayesian Hilbert map (Senanayake & Ramos 2017: a Bayesian linear model on random
 * Fourier features) built on the features the network itself learned: a SIREN layer is a
 * Fourier feature map, so the posterior variance grows away from the data (distance aware,
 * as SNGP asks), where the deeper ReLU layers' features collapse and do not (measured in
 * docs/uncertainty.md). The features stay those of the initial SIREN layer: the trained ones
 * differ from robot to robot (consensus is never exact), and a posterior is only additive over
 * one feature map; the fixed one also lets the robot sum each sample in as it arrives.
 *
 * P is a sum over the data, so it is additive over robots and over time: a fleet's posterior
 * is the sum of the robots' P (bnn_post_add), reachable by average consensus (bnn_post_scale
 * and bnn_post_add with mixing weights) without exchanging a single sample.
 *
 * Storage: P in double (sums over ~10^6 points keep their digits), packed lower triangle,
 * row-major (element (i, j), j <= i, at i (i + 1) / 2 + j); the factor's inverse L^-1 in float,
 * packed the same way, so a query costs D (D + 1) / 2 multiply-adds per point after the
 * forward pass, on every board (BNN_POST_BYTES, checked against the AI RAM). No allocation;
 * one thread at a time, like bnn_model_t. */
#ifndef AI_BNN_POST_H
#define AI_BNN_POST_H

#include <stddef.h>
#include <stdint.h>

#include "ai/bnn.h"

#define BNN_POST_DIM_MAX (BNN_SIREN_MAX + 1u)
#define BNN_POST_PACKED(d) ((size_t)(d) * ((size_t)(d) + 1u) / 2u)
#define BNN_POST_PACKED_MAX BNN_POST_PACKED(BNN_POST_DIM_MAX)
#define BNN_POST_LAMBDA0 1.0  /* prior precision of the read-out's weights */
#define BNN_POST_BETA 1.0     /* precision of one observation */

typedef struct bnn_post {
    uint32_t dim;      /* D = S + 1 of the model it was made for */
    uint32_t factored; /* 1: linv matches prec (bnn_post_factor since the last change) */
    double n_obs;      /* observations summed into prec (a fleet estimate may be fractional) */
    double robots;     /* how many robots' data prec stands for: 1 its own, N a fleet's sum */
    float w0;          /* the features: SIREN frequency, W0 [S x 2] and b0 [S] (bnn.h layout) */
    float siren[3u * BNN_SIREN_MAX];
    double prec[BNN_POST_PACKED_MAX];  /* P, packed lower */
    double work[BNN_POST_PACKED_MAX];  /* the Cholesky factor while factoring */
    float linv[BNN_POST_PACKED_MAX];   /* L^-1, packed lower */
} bnn_post_t;

#define BNN_POST_BYTES sizeof(bnn_post_t)
_Static_assert(BNN_POST_PACKED_MAX * (2u * sizeof(double) + sizeof(float)) + 64u <= BOARD_RAM_AI_BYTES / 8u,
               "the posterior must stay a small part of the board's AI RAM");

/* Empty posterior (P = 0, nothing known) over model m's CURRENT SIREN layer (call it on the
 * freshly initialised model). Any model of the same configuration then serves the other
 * calls as scratch. 0 or -EINVAL. */
FS_MUST_CHECK int bnn_post_init(bnn_post_t *p, const bnn_model_t *m);

/* P += phi phi^T of the n points xy (interleaved x, y, normalised like samples); any n >= 0
 * (chunks of max_batch). m: a model of the same configuration, whose activation scratch is
 * clobbered (as inference does), not theta. 0 or -EINVAL (non-finite input, wrong dimension). */
FS_MUST_CHECK int bnn_post_observe(bnn_post_t *p, bnn_model_t *m, const float *xy, size_t n);
/* P += w phi phi^T (and n_obs += w n), w > 0 finite: a robot whose posterior stands for a
 * fleet's N robots (average consensus, ai_core.h) adds its new points N times. */
FS_MUST_CHECK int bnn_post_observe_weighted(bnn_post_t *p, bnn_model_t *m, const float *xy, size_t n, double w);
/* The same from training samples (their labels play no part: what was observed, not what). */
FS_MUST_CHECK int bnn_post_observe_samples(bnn_post_t *p, bnn_model_t *m, const ai_sample_t *s, size_t n);

/* p = a p (P, n_obs and robots scaled), and p += a q: average consensus and fleet sums.
 * Same features (dimension and SIREN weights, bit for bit) or -EINVAL; a finite, >= 0. */
FS_MUST_CHECK int bnn_post_scale(bnn_post_t *p, double a);
FS_MUST_CHECK int bnn_post_add(bnn_post_t *p, const bnn_post_t *q, double a);

/* A = lambda0 I + beta P, its Cholesky factor and L^-1 (in double, kept as float). 0, or
 * -EDOM when A is not numerically positive definite (P corrupt). */
FS_MUST_CHECK int bnn_post_factor(bnn_post_t *p);

/* At n points: the model's logits with the mean weights (one forward pass; logit may be NULL,
 * then none) and, for each point, the share of the read-out's prior variance left, var /
 * prior in (0, 1] (1 = nothing known): the posterior's features (one SIREN layer) and
 * D (D + 1) / 2 multiply-adds. Factors first when needed. Any n >= 1. Clobbers m's activation
 * scratch. 0, -EINVAL or -EDOM. */
FS_MUST_CHECK int bnn_post_predict(bnn_post_t *p, bnn_model_t *m, const float *xy, size_t n, float *logit,
                                   float *unknown);

/* ---- over the fleet's state exchange ------------------------------------------------------
 * A posterior travels as a robot's state does (fp32 words, n_params of them): floats
 *   [0] dim, [1] w0, [2 .. 2 + 3S) W0 and b0, then n_obs, robots and the packed P, each double
 *   d as two floats hi = (float)d, lo = (float)(d - hi) (48 bits of it), then zeros.
 * Mixing (average consensus with the max-degree weights w = 1/N, N the fleet's size, doubly
 * stochastic on any undirected graph): p = (1 - c w) p + w sum of the c neighbours' states that
 * are over p's features. */
#define BNN_POST_STATE_FLOATS(d) (2u + 3u * ((size_t)(d)-1u) + 4u + 2u * BNN_POST_PACKED(d))
_Static_assert(BNN_POST_STATE_FLOATS(BNN_POST_DIM_MAX) <= BNN_N_PARAMS,
               "a posterior must fit a state of the fleet's exchange");
/* Writes the state form into out (cap floats, >= BNN_POST_STATE_FLOATS(dim); the rest zeroed).
 * 0, -EINVAL or -ENOSPC. */
FS_MUST_CHECK int bnn_post_to_state(const bnn_post_t *p, float *out, size_t cap);
/* Mixes the n <= DINNO_MAX_PEERS neighbour states (each cap floats) into p with weight w each
 * (0 < n w <= 1);
 * a state of another dimension or other features, or with a bad value, is left out. *used
 * (may be NULL): how many were mixed in. 0 or -EINVAL. */
FS_MUST_CHECK int bnn_post_mix(bnn_post_t *p, const float *const *states, size_t n, size_t cap, double w,
                               uint32_t *used);

/* ---- storage (checkpoints) --------------------------------------------------------------- */
/* Bytes of the serialised posterior of dimension d: u32 d, f64 n_obs, f64 robots, f32 w0,
 * f32 W0 and b0 (3 (d - 1)), then the packed P as f64, little-endian. */
#define BNN_POST_WIRE_BYTES(d) (4u + 16u + 4u + 12u * ((size_t)(d)-1u) + 8u * BNN_POST_PACKED(d))
#define BNN_POST_WIRE_MAX BNN_POST_WIRE_BYTES(BNN_POST_DIM_MAX)
size_t bnn_post_wire_size(const bnn_post_t *p);
/* Writes bnn_post_wire_size(p) bytes; -ENOSPC when cap is smaller. */
FS_MUST_CHECK int bnn_post_write(const bnn_post_t *p, uint8_t *buf, size_t cap, size_t *written);
/* Parses and validates (dimension = model's S + 1, finite, n_obs and robots >= 0, P's diagonal
 * >= 0, w0 > 0) before touching p. 0, -ENODATA (short), -EBADMSG (bad values), -ENOEXEC (dimension). */
FS_MUST_CHECK int bnn_post_read(bnn_post_t *p, const bnn_model_t *m, const uint8_t *buf, size_t len,
                                const char **reason);

#endif /* AI_BNN_POST_H */
