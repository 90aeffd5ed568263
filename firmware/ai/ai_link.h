/* What the AI core publishes on its links (fw_link.h): its status, its model state entering a
 * DiNNO round (for the peers) and its checkpoint after the round, with the round's record.
 * The AI core owns this header: it writes these links. */
#ifndef AI_AI_LINK_H
#define AI_AI_LINK_H

#include <stdint.h>

#include "ai/bnn.h"
#include "ai/bnn_ckpt.h"
#include "common/mbox.h"

/* The GP core sizes its state buffers from the build configuration (FW_STATE_MAX_BYTES,
 * common/fw_config.h) without knowing the network: it must be the preset's fp32 state. */
_Static_assert(FW_STATE_MAX_BYTES == BNN_N_PARAMS * 4u, "FW_STATE_MAX_BYTES (fw_config.h) is not BNN_N_PARAMS * 4");
_Static_assert(FW_STATE_MAX_PARAMS == BNN_N_PARAMS, "FW_STATE_MAX_PARAMS (fw_config.h) is not BNN_N_PARAMS");

/* Checkpoint bytes carried by a ckpt message: theta (no Adam moments) and the robot's
 * epistemic posterior (bnn_post.h). */
#define AI_LINK_CKPT_BYTES (BNN_CKPT_HEADER_BYTES + BNN_N_PARAMS * 4u + BNN_POST_WIRE_MAX)

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
    uint64_t links_rejoined;  /* neighbours back after >= rejoin_gap missed rounds (dinno.h) */
    uint64_t states_stale;    /* EF codecs: differences without their public copy, left out */
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
    uint8_t bytes[AI_LINK_CKPT_BYTES];
} ai_ckpt_msg_t;

typedef struct ai_state_msg {
    uint32_t round;          /* k */
    uint32_t n_params;
    _Alignas(64) float theta[BNN_N_PARAMS];
} ai_state_msg_t;

/* AI -> GP: the coarse belief grid (ai/ai_belief.h), every belief period while exploring: the
 * model's occupancy and how much is left to learn, per cell of the GP goal grid, in two layers:
 * unknown, the one the goal choice reads (the posterior's share, or with explore_counts the
 * larger of it and the counts'), and fallback, the one it reads when unknown has nothing left
 * within reach (gp/gp_explore.h): 255 on the cells no ray reached beyond the cells rays did
 * (ai_seen.h's `beyond`: the unseen rest of the building), elsewhere the posterior's (with
 * explore_counts: unknown itself). */
#define AI_BELIEF_MSG_MAX_CELLS 4096u
typedef struct ai_belief_msg {
    uint64_t stamp_us;
    uint32_t round;          /* the round whose model it shows */
    uint32_t w, h;
    float unknown_mean;      /* mean share of unknown over the cells, [0, 1] */
    uint8_t occ[AI_BELIEF_MSG_MAX_CELLS];
    uint8_t unknown[AI_BELIEF_MSG_MAX_CELLS];
    uint8_t fallback[AI_BELIEF_MSG_MAX_CELLS];
} ai_belief_msg_t;

/* Static bytes of the AI core's links: its status, state, ckpt and belief mailboxes. */
#define AI_LINK_BYTES                                                                         \
    (MBOX_STORAGE_BYTES(sizeof(ai_status_t)) + MBOX_STORAGE_BYTES(sizeof(ai_state_msg_t)) +    \
     MBOX_STORAGE_BYTES(sizeof(ai_ckpt_msg_t)) + MBOX_STORAGE_BYTES(sizeof(ai_belief_msg_t)))

#endif /* AI_AI_LINK_H */
