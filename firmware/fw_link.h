/* The fixed-size links between the three cores of the robot firmware image, and the
 * messages they carry. Every link is a firmware/common buffer with static storage:
 *
 *   RT -> AI  samples   ring of ai_sample_t, FW_LINK_RING_CAPACITY records (never blocks:
 *                       a full ring drops and counts, ring_drops())
 *   RT -> AI  status    mbox of rt_status_t  (latest pose, distance, path progress, drops)
 *   RT -> GP  status    mbox of rt_status_t  (same record; a mailbox has one reader)
 *   AI -> GP  status    mbox of ai_status_t  (pool fill, last losses, round)
 *   AI -> GP  state     mbox of ai_state_msg_t: the model state entering DiNNO round k, for
 *                       the peers (theta, n_params floats)
 *   AI -> GP  ckpt      mbox of ai_ckpt_msg_t: the checkpoint (bnn_ckpt format, no Adam)
 *                       after round k, with the round's statistics
 *   GP -> AI  ready     mbox of gp_ready_t: "the neighbour view of round k is filled"
 *   GP -> AI  nbrs      dinno_nbrs_t in fixed storage: the view of round k's neighbour states
 *                       (round, count, ids ascending, one pointer per state). The states are
 *                       not copied: they stay where the GP core reassembled them (gp_pse's
 *                       buffers inside the image's gp_fleet_t; fp32 read as they arrived, int8
 *                       expanded once in place), and gp_pse does not write them until the GP
 *                       core begins round k+1 (gp_pse.h). The view and the states it points
 *                       to are OWNED BY GP from the AI's state publish of round k until GP's
 *                       ready(k), and by AI from ready(k) until AI's next state publish; the
 *                       GP core begins round k+1 only after it took that publish. The
 *                       ownership passes with the mailboxes' acquire/release exchanges, so the
 *                       bytes are never written and read at the same time.
 *
 * Round protocol (one communication round k, 0 <= k < C):
 *   1. AI: the path progress reached boundary k: publish state(k) = theta.
 *   2. GP: sees state(k): exchanges it with the peers (none configured: nothing to do), points
 *      the view at the neighbours' states of round k, publishes ready(k).
 *   3. AI: sees ready(k): hands the view to its DiNNO node, runs the node update
 *      (B optimiser steps on the sample pool), publishes ckpt(k) (FINAL flag for k = C-1),
 *      applies the pool policy (DR clears). The next state(k+1) comes only after this.
 *   4. GP: fetches ckpt(k) at the start of each tick and, at the latest, right after taking
 *      state(k+1) and BEFORE publishing ready(k+1) (the AI published ckpt(k) before state(k+1),
 *      and cannot publish ckpt(k+1) before ready(k+1), so no checkpoint is ever skipped);
 *      writes it through the storage HAL, logs and publishes telemetry.
 *
 * fw_link_reset() puts every link back to empty; call it before the cores start (never
 * while they run). Thread-safety: as ring.h and mbox.h (one writer, one reader each). */
#ifndef FW_LINK_H
#define FW_LINK_H

#include <stddef.h>
#include <stdint.h>

#include "ai/ai_sample.h"
#include "ai/bnn.h"
#include "ai/bnn_ckpt.h"
#include "ai/dinno.h"
#include "common/mbox.h"
#include "common/ring.h"

/* FW_LINK_RING_CAPACITY, the RT -> AI sample ring in samples, comes from common/fw_config.h:
 * 16 scans by default, so it never holds more than a few unless the AI core falls behind. */

/* Checkpoint bytes carried by a ckpt message: theta only (no Adam moments). */
#define FW_LINK_CKPT_BYTES (BNN_CKPT_HEADER_BYTES + BNN_N_PARAMS * 4u)

typedef struct rt_status {
    uint64_t stamp_us;       /* simulated time of the RT tick that wrote it */
    float x_m, y_m, heading_rad; /* latest GPS + compass fix */
    float distance_m;        /* odometry: integral of |commanded v| dt since start */
    float progress_m;        /* arc length of the path covered (monotone, <= path_length_m) */
    float path_length_m;     /* total arc length of the waypoint path */
    uint32_t waypoint;       /* index aimed at (== n when finished) */
    uint32_t finished;       /* 1 once the last waypoint was reached */
    uint32_t scans;          /* scans turned into samples */
    uint32_t samples;        /* samples pushed into the ring (accepted) */
    uint32_t ring_drops;     /* samples dropped because the ring was full */
    uint32_t errors;         /* HAL calls that failed (pose, lidar, motor) */
    uint32_t sample_errors;  /* scans rt_samples refused, and samples the ring refused for any
                                reason but full (a contract broken: never expected) */
} rt_status_t;

typedef struct ai_status {
    uint64_t stamp_us;
    uint32_t round;          /* rounds completed */
    uint32_t rounds_total;   /* C */
    uint32_t pool_fill, pool_capacity;
    uint64_t pool_offered;   /* samples offered to the pool since start */
    uint64_t between_steps;  /* optimiser steps taken between boundaries */
    float loss_train;        /* prediction loss of the last round (NaN before the first) */
    uint32_t done;           /* 1 after the last round */
    uint64_t states_excluded; /* neighbour states the screen left out so far (dinno.h) */
} ai_status_t;

#define AI_CKPT_FLAG_FINAL 1u

typedef struct ai_round_info {
    uint32_t round;          /* k */
    uint32_t neighbours;     /* neighbour states used */
    uint32_t excluded;       /* neighbour states the screen left out (dinno.h) */
    uint64_t stamp_us;       /* simulated time of the boundary */
    float progress_m;        /* path progress at the boundary */
    float distance_m;        /* odometry distance at the boundary */
    uint32_t pool_fill;      /* samples trained on */
    uint32_t pool_capacity;
    uint64_t pool_offered;   /* samples offered since start */
    uint32_t ring_drops;     /* RT ring drops so far */
    uint32_t steps;          /* optimiser steps of the node update */
    float loss_train;        /* mean prediction loss (BCE + kl_weight * kl) over the steps */
    float bce;
    float kl;                /* BNN prior kl_loss, unweighted */
    float lr, rho_k;
    int32_t ckpt_status;     /* filled by the GP core in its round log: 0, or the storage
                                error of this round's checkpoint (the AI core sends 0) */
} ai_round_info_t;

typedef struct ai_ckpt_msg {
    ai_round_info_t info;
    uint32_t flags;          /* AI_CKPT_FLAG_FINAL on the last round */
    uint32_t n_bytes;        /* checkpoint bytes used */
    uint8_t bytes[FW_LINK_CKPT_BYTES];
} ai_ckpt_msg_t;

typedef struct ai_state_msg {
    uint32_t round;          /* k */
    uint32_t n_params;
    _Alignas(64) float theta[BNN_N_PARAMS];
} ai_state_msg_t;

typedef struct gp_ready {
    uint32_t round;          /* k: the view holds neighbour states of round k */
    uint32_t neighbours;     /* states in the view */
    uint32_t next_round;     /* the round to run after k: k + 1, or further when the robot fell
                                behind its fleet and skips ahead (<= k + 1 or >= C: k + 1) */
} gp_ready_t;

typedef struct fw_link {
    ring_t *samples;
    mbox_t *rt_to_ai, *rt_to_gp;
    mbox_t *ai_status, *ai_state, *ai_ckpt;
    mbox_t *gp_ready;
    dinno_nbrs_t *nbrs;
} fw_link_t;

/* Static bytes of the links, by the core that writes them (compile-time, for budgets). */
#define FW_LINK_RT_BYTES                                                                      \
    (RING_STORAGE_BYTES(sizeof(ai_sample_t), FW_LINK_RING_CAPACITY) +                          \
     2u * MBOX_STORAGE_BYTES(sizeof(rt_status_t)))
#define FW_LINK_AI_BYTES                                                                      \
    (MBOX_STORAGE_BYTES(sizeof(ai_status_t)) + MBOX_STORAGE_BYTES(sizeof(ai_state_msg_t)) +    \
     MBOX_STORAGE_BYTES(sizeof(ai_ckpt_msg_t)))
#define FW_LINK_GP_BYTES (MBOX_STORAGE_BYTES(sizeof(gp_ready_t)) + sizeof(dinno_nbrs_t))

/* The image's links (static storage). */
const fw_link_t *fw_link_get(void);

/* Empties every link (rings, mailboxes back to "never published", an empty view). */
void fw_link_reset(void);

/* Static bytes of the links, by the core that owns (writes) them. */
size_t fw_link_bytes_rt(void);  /* sample ring + both RT status mailboxes */
size_t fw_link_bytes_ai(void);  /* AI status, state and ckpt mailboxes */
size_t fw_link_bytes_gp(void);  /* ready mailbox + neighbour view */

#endif /* FW_LINK_H */
