/* Peers state exchange, where the fleet is (see gp_pse.h): whether round k is over for every
   peer, whether every peer is past our last round, and which round to begin next. Read-only
   queries over the peer table, split from gp_pse.c to keep each file under the house limit of
   800 lines; they share gp_pse_internal.h. */
#include "gp/gp_pse.h"
#include "gp/gp_pse_internal.h"

#include <stdint.h>

int gp_pse_round_finished(const gp_pse_t *p)
{
    if (!p->in_round || !p->completed)
        return 0;
    if (p->later_heard)
        return 1;
    for (uint32_t i = 0; i < p->cfg.n_peers; i++) {
        const gp_pse_peer_t *q = &p->peer[i];
        if (i != p->cfg.self && !q->absent && !(q->has_done && q->done_round >= p->round))
            return 0;
    }
    return 1;
}

int gp_pse_all_past(const gp_pse_t *p)
{
    if (!p->leaving)
        return 0;
    for (uint32_t i = 0; i < p->cfg.n_peers; i++) {
        const gp_pse_peer_t *q = &p->peer[i];
        if (i != p->cfg.self && !(q->has_round && q->at_round > p->round))
            return 0;
    }
    return 1;
}

uint32_t gp_pse_next_round(const gp_pse_t *p, uint64_t now_us)
{
    uint32_t next = p->in_round ? p->round + 1u : 0u;
    for (uint32_t i = 0; i < p->cfg.n_peers; i++) {
        const gp_pse_peer_t *q = &p->peer[i];
        if (i == p->cfg.self || !q->has_round || !gp_pse_heard_within(p, q, now_us))
            continue;
        /* A peer that completed round j is on its way to j + 1: the round to catch up with. Its
           next round opens without a beacon when its RoundComplete said where (gp_pse_complete),
           so that beacon no longer tells us first; a robot alone after a partition, running a
           round every few ms, was otherwise caught up one round late again and again. (A
           lossless run never skips for it: a peer completes j only after our RoundComplete of
           j - 1.) */
        const uint32_t at = q->has_done && q->done_round >= q->at_round && q->done_round < UINT32_MAX
                                ? q->done_round + 1u
                                : q->at_round;
        if (at > next)
            next = at;
    }
    return next;
}
