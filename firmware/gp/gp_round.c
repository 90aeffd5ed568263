/* The round driver: see gp_round.h. */
#include "gp/gp_round.h"

#include <errno.h>

int gp_round_init(gp_round_t *d, const gp_pse_cfg_t *pse_cfg, uint32_t rounds)
{
    if (d == NULL || pse_cfg == NULL || rounds < 1)
        return -EINVAL;
    int r = gp_pse_init(&d->pse, pse_cfg);
    if (r != 0)
        return r;
    d->rounds = rounds;
    d->phase = GP_ROUND_IDLE;
    d->want = 0;
    d->grace_us = d->cap_us = 0;
    return 0;
}

int gp_round_want(gp_round_t *d, uint32_t k, uint64_t now_us)
{
    gp_pse_t *p = &d->pse;
    if (k >= d->rounds || d->phase >= GP_ROUND_FINISHING)
        return -EINVAL;
    if (d->phase == GP_ROUND_CLOSING || d->phase == GP_ROUND_BEGINNING) {
        if (k < d->want)
            return -EINVAL;
        /* A later round: the wanted one was never begun (the caller could not encode it and
           ran it alone); the later one waits for the same end of the round before. */
        if (k > d->want) {
            d->want = k;
            d->phase = GP_ROUND_CLOSING;
        }
        return 0;
    }
    if (p->in_round && p->round >= k) {
        if (p->round != k)
            return -EINVAL;
        /* Asked again for the round begun (a wait came back without hal_net_wait): its states
           are awaited, or there already. */
        d->phase = GP_ROUND_STATES;
        d->want = k;
        return 0;
    }
    /* The node update of the round before is over even if nobody said so (an error on the
       way): the peers still waiting for our RoundComplete must hear it. */
    if (p->in_round && !p->completed && gp_pse_complete(p, NULL, now_us) != 0)
        return -EINVAL;
    d->want = k;
    d->phase = GP_ROUND_CLOSING;
    return 0;
}

gp_round_event_t gp_round_step(gp_round_t *d, uint64_t now_us)
{
    gp_pse_t *p = &d->pse;
    gp_pse_poll(p, now_us);
    switch (d->phase) {
    case GP_ROUND_CLOSING:
        /* Our state of the round before may still be asked for until every peer is past it. */
        if (p->in_round && !gp_pse_round_finished(p))
            return GP_ROUND_WAIT;
        d->phase = GP_ROUND_BEGINNING;
        return GP_ROUND_BEGIN;
    case GP_ROUND_BEGINNING:
        return GP_ROUND_BEGIN;
    case GP_ROUND_STATES:
        if (!gp_pse_states_ready(p))
            return GP_ROUND_WAIT;
        d->phase = GP_ROUND_UPDATING;
        return GP_ROUND_READY;
    case GP_ROUND_FINISHING:
        if (p->in_round && !gp_pse_round_finished(p))
            return GP_ROUND_WAIT;
        /* Linger: a peer that missed our RoundComplete still waits for us, and our beacons
           ("past the last round") end its wait; stay until every peer was heard leaving and
           two resend periods passed (for them to hear ours), one peer timeout at most; at once
           when every peer was heard past the round (gp_pse_all_past: nobody waits for us). */
        gp_pse_leave(p, now_us);
        d->grace_us = now_us + 2u * p->cfg.resend_after_us;
        d->cap_us = now_us + p->cfg.peer_timeout_us;
        d->phase = GP_ROUND_LEAVING;
        return GP_ROUND_WAIT;
    case GP_ROUND_LEAVING:
        if (now_us < d->cap_us && !gp_pse_all_past(p) && (now_us < d->grace_us || !gp_pse_all_left(p, now_us)))
            return GP_ROUND_WAIT;
        d->phase = GP_ROUND_LEFT;
        return GP_ROUND_DONE;
    default:
        return GP_ROUND_WAIT;
    }
}

int gp_round_begin(gp_round_t *d, const uint8_t *state, double x_m, double y_m, uint64_t now_us)
{
    if (d->phase != GP_ROUND_BEGINNING)
        return -EINVAL;
    int r = gp_pse_begin_round(&d->pse, d->want, state, x_m, y_m, now_us);
    if (r == 0)
        d->phase = GP_ROUND_STATES;
    return r;
}

uint32_t gp_round_next_round(const gp_round_t *d, uint32_t k, uint64_t now_us)
{
    const uint32_t next = gp_pse_next_round(&d->pse, now_us);
    const uint32_t last = d->rounds - 1u;
    if (next <= k + 1u || k >= last)
        return k + 1u;
    return next > last ? last : next;
}

int gp_round_node_done(gp_round_t *d, uint32_t k, int final, const double next_xy[2], uint64_t now_us)
{
    gp_pse_t *p = &d->pse;
    if (d->phase >= GP_ROUND_FINISHING || !p->in_round || p->round != k || p->completed)
        return -EINVAL;
    int r = gp_pse_complete(p, final ? NULL : next_xy, now_us);
    if (r != 0)
        return r;
    d->phase = final ? GP_ROUND_FINISHING : GP_ROUND_IDLE;
    return 0;
}
