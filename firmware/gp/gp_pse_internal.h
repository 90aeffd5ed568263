/* Private to gp_pse.c and gp_pse_near.c (the peers state exchange split in two files): what
   the protocol's core needs of the nearest peers of a round and their buffers. Not part of the
   API: that is gp_pse.h. */
#ifndef GP_GP_PSE_INTERNAL_H
#define GP_GP_PSE_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "gp/gp_pse.h"

/* Peer i's buffer of round `round` (parity round & 1), or NULL. */
static inline gp_pse_buf_t *gp_pse_buf_of(gp_pse_t *p, uint32_t i, uint32_t round)
{
    const uint32_t par = round & 1u, s = p->peer[i].buf[par];
    if (s == GP_PSE_NO_BUF || p->pool[par][s].round != round)
        return NULL;
    return &p->pool[par][s];
}

static inline const gp_pse_buf_t *gp_pse_cbuf_of(const gp_pse_t *p, uint32_t i, uint32_t round)
{
    return gp_pse_buf_of((gp_pse_t *)p, i, round);
}

static inline int gp_pse_pos_known(const gp_pse_peer_t *q, uint32_t round)
{
    return q->has_pos[round & 1u] && q->pos_round[round & 1u] == round;
}

/* Peer q was heard within the peer timeout. */
static inline int gp_pse_heard_within(const gp_pse_t *p, const gp_pse_peer_t *q, uint64_t now_us)
{
    return q->heard && now_us - q->heard_us < p->cfg.peer_timeout_us;
}

/* How long a state's buffer waits without progress before its chunks are asked for, after
   `backoff` requests that brought nothing. */
uint64_t gp_pse_ask_after(const gp_pse_t *p, uint32_t backoff);
/* Buffer b starts afresh for `round` (used, nothing received, no backoff). */
void gp_pse_buf_reset(gp_pse_buf_t *b, uint32_t round, uint32_t n_chunks, uint64_t now_us);
/* Starts the list of `round` afresh (an older round's list and buffers are free). */
void gp_pse_near_reset(gp_pse_t *p, uint32_t round);
/* Ranks the list of `round` again from every known position (ours moved, or a peer's). */
void gp_pse_near_rank(gp_pse_t *p, uint32_t round, uint64_t now_us);
/* Peer i's position of `round` (par = its parity), without ranking anything. */
void gp_pse_set_position(gp_pse_peer_t *q, uint32_t par, uint32_t round, double x_m, double y_m);
/* Peer i said where it is in `round`: placed among the nearest, or the round ranked again when
   it disagrees with the round's earlier word (counted invalid). 1 when it moved, else 0. */
int gp_pse_note_position(gp_pse_t *p, uint32_t i, uint32_t round, double x_m, double y_m, uint64_t now_us);
/* Peer i said where it is in `round` (a beacon, a request, or its RoundComplete of the round
   before): placed when the round is k or k + 1. 1 when it was placed or its position kept. */
int gp_pse_place(gp_pse_t *p, uint32_t i, uint32_t round, double x_m, double y_m, uint64_t now_us);
/* A beacon or request with its sender's position of round k or k + 1 places it. */
void gp_pse_request_position(gp_pse_t *p, const gp_pse_request_t *r, uint64_t now_us);

#endif /* GP_GP_PSE_INTERNAL_H */
