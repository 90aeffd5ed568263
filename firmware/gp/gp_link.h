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

/* Static bytes of the GP core's links: the ready mailbox and the neighbour view (pointers). */
#define GP_LINK_BYTES (MBOX_STORAGE_BYTES(sizeof(gp_ready_t)) + sizeof(dinno_nbrs_t))

#endif /* GP_GP_LINK_H */
