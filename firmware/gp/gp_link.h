/* What the GP core publishes on its links (fw_link.h): ready(k), and the view of round k's
 * neighbour states (ai/dinno.h's dinno_nbrs_t: pointers into the GP core's reassembly buffers,
 * never copies). The GP core owns this header: it writes these links. */
#ifndef GP_GP_LINK_H
#define GP_GP_LINK_H

#include <stdint.h>

#include "ai/dinno.h"
#include "common/mbox.h"

typedef struct gp_ready {
    uint32_t round;          /* k: the view holds neighbour states of round k */
    uint32_t neighbours;     /* states in the view */
    uint32_t next_round;     /* the round to run after k: k + 1, or further when the robot fell
                                behind its fleet and skips ahead (<= k + 1 or >= C: k + 1) */
} gp_ready_t;

/* GP -> RT: where to explore next (gp/gp_goal.h picks it). A new seq is a new goal; the RT
 * core plans to it on its own grid and reports the seq back reached or given up (rt_status_t). */
#define GP_GOAL_MSG_GO 1u   /* drive to (x_m, y_m) */
#define GP_GOAL_MSG_DONE 2u /* nothing left to learn within reach: stop */
typedef struct gp_goal_msg {
    uint64_t stamp_us;
    uint32_t seq;            /* 1, 2, ...: one per new goal */
    uint32_t mode;           /* GP_GOAL_MSG_GO or GP_GOAL_MSG_DONE */
    float x_m, y_m;          /* the goal, metres (GO) */
} gp_goal_msg_t;

/* Static bytes of the GP core's links: the ready and goal mailboxes and the neighbour view. */
#define GP_LINK_BYTES                                                                          \
    (MBOX_STORAGE_BYTES(sizeof(gp_ready_t)) + MBOX_STORAGE_BYTES(sizeof(gp_goal_msg_t)) +      \
     sizeof(dinno_nbrs_t))

#endif /* GP_GP_LINK_H */
