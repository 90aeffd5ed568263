/* Static storage of the links between the cores (see fw_link.h). */
#include "fw_link.h"

#include "ai/ai_link.h"
#include "gp/gp_link.h"
#include "rt/rt_link.h"
#include "ai/ai_belief.h"
#include "gp/gp_goal.h"

#include <string.h>

RING_DEFINE(fw_samples_ring, sizeof(ai_sample_t), FW_LINK_RING_CAPACITY);
MBOX_DEFINE(fw_rt_to_ai, sizeof(rt_status_t));
MBOX_DEFINE(fw_rt_to_gp, sizeof(rt_status_t));
MBOX_DEFINE(fw_ai_status, sizeof(ai_status_t));
MBOX_DEFINE(fw_ai_state, sizeof(ai_state_msg_t));
MBOX_DEFINE(fw_ai_ckpt, sizeof(ai_ckpt_msg_t));
MBOX_DEFINE(fw_gp_ready, sizeof(gp_ready_t));
static dinno_nbrs_t fw_nbrs;
MBOX_DEFINE(fw_ai_belief, sizeof(ai_belief_msg_t));
MBOX_DEFINE(fw_rt_seen, sizeof(rt_seen_t));
MBOX_DEFINE(fw_gp_goal, sizeof(gp_goal_msg_t));

_Static_assert(RT_SEEN_MAX_CELLS == GP_GOAL_MAX_CELLS && AI_BELIEF_MSG_MAX_CELLS == GP_GOAL_MAX_CELLS &&
                   AI_BELIEF_MSG_MAX_CELLS == AI_BELIEF_MAX_CELLS,
               "the seen grid, the belief message and the goal grid have one geometry");
_Static_assert(RT_LINK_BYTES <= BOARD_RAM_RT_BYTES, "RT links exceed the board's RT RAM");
_Static_assert(GP_LINK_BYTES <= BOARD_RAM_GP_BYTES, "GP links exceed the board's GP RAM");
_Static_assert(AI_LINK_BYTES <= BOARD_RAM_AI_BYTES, "AI links exceed the board's AI RAM");

static const fw_link_t fw_link = {
    .samples = &fw_samples_ring,
    .rt_to_ai = &fw_rt_to_ai,
    .rt_to_gp = &fw_rt_to_gp,
    .ai_status = &fw_ai_status,
    .ai_state = &fw_ai_state,
    .ai_ckpt = &fw_ai_ckpt,
    .gp_ready = &fw_gp_ready,
    .nbrs = &fw_nbrs,
    .ai_belief = &fw_ai_belief,
    .rt_seen = &fw_rt_seen,
    .gp_goal = &fw_gp_goal,
};

const fw_link_t *fw_link_get(void)
{
    return &fw_link;
}

void fw_link_reset(void)
{
    ring_reset(&fw_samples_ring);
    mbox_reset(&fw_rt_to_ai);
    mbox_reset(&fw_rt_to_gp);
    mbox_reset(&fw_ai_status);
    mbox_reset(&fw_ai_state);
    mbox_reset(&fw_ai_ckpt);
    mbox_reset(&fw_gp_ready);
    memset(&fw_nbrs, 0, sizeof fw_nbrs);
    mbox_reset(&fw_ai_belief);
    mbox_reset(&fw_rt_seen);
    mbox_reset(&fw_gp_goal);
}

size_t fw_link_bytes_rt(void)
{
    return RT_LINK_BYTES;
}

size_t fw_link_bytes_ai(void)
{
    return AI_LINK_BYTES;
}

size_t fw_link_bytes_gp(void)
{
    return GP_LINK_BYTES;
}
