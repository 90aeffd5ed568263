/* The fixed-size links between the three cores of the robot firmware image: the link table.
 * The messages they carry are declared by the core that writes them: rt/rt_link.h (RT),
 * ai/ai_link.h (AI), gp/gp_link.h (GP), each with its links' static bytes (RT_LINK_BYTES,
 * AI_LINK_BYTES, GP_LINK_BYTES). Every link is a firmware/common buffer with static storage:
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
 * Exploration (docs/exploration.md), unused on a fixed tour:
 *   AI -> GP  belief    mbox of ai_belief_msg_t: the model's coarse occupancy and unknown share
 *   RT -> GP  seen      mbox of rt_seen_t: the robot's own lidar grid, coarse
 *   GP -> RT  goal      mbox of gp_goal_msg_t: the goal to plan to (or: done, stop)
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

#include "common/mbox.h"
#include "common/ring.h"

struct dinno_nbrs; /* ai/dinno.h; the GP core's link (gp/gp_link.h) */

/* FW_LINK_RING_CAPACITY, the RT -> AI sample ring in samples, comes from common/fw_config.h:
 * 16 scans by default, so it never holds more than a few unless the AI core falls behind. */

typedef struct fw_link {
    ring_t *samples;
    mbox_t *rt_to_ai, *rt_to_gp;
    mbox_t *ai_status, *ai_state, *ai_ckpt;
    mbox_t *gp_ready;
    struct dinno_nbrs *nbrs;
    mbox_t *ai_belief, *rt_seen, *gp_goal;
} fw_link_t;

/* The image's links (static storage). */
const fw_link_t *fw_link_get(void);

/* Empties every link (rings, mailboxes back to "never published", an empty view). */
void fw_link_reset(void);

/* Static bytes of the links, by the core that owns (writes) them. */
size_t fw_link_bytes_rt(void);  /* sample ring + both RT status mailboxes (RT_LINK_BYTES) */
size_t fw_link_bytes_ai(void);  /* AI status, state and ckpt mailboxes (AI_LINK_BYTES) */
size_t fw_link_bytes_gp(void);  /* ready mailbox + neighbour view (GP_LINK_BYTES) */

#endif /* FW_LINK_H */
