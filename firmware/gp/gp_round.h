/* The round driver: what a robot does around the exchange protocol (gp_pse) in each DiNNO
 * round, as a state machine with no I/O and no clock of its own. The image's GP core runs it
 * through gp_fleet (which receives datagrams, feeds them to the protocol, waits with a bound
 * and calls gp_round_step again); the protocol simulation (tests/gp/test_pse_sim.c) runs N of
 * these same drivers over its simulated network. So the seeded schedules test the code the
 * image ships, not a copy of it.
 *
 * Round k as the robot lives it:
 *   gp_round_want(k)      the AI core published its state of round k;
 *   step -> BEGIN         round k - 1 is over for everyone (every peer still in it completed
 *                         it, or a later round was heard): our buffer of round k - 1 is free,
 *                         so the caller encodes the state of round k into it now, and calls
 *   gp_round_begin(...)   which sends it (gp_pse_begin_round);
 *   step -> READY         every peer's state of round k arrived or the peer left the round:
 *                         the caller reads the neighbours (gp_pse_neighbours, in place) and
 *                         asks gp_round_next_round for the round the AI core runs after k;
 *   gp_round_node_done(k) the node update of round k is over: RoundComplete(k) goes out (with
 *                         our position of k + 1 when known ahead);
 *                         after the last round the driver stays until every peer finished it
 *                         (one of them may still need our state), then lingers as a leaver
 *                         (gp_pse_leave) until every peer was heard leaving and two resend
 *                         periods passed, or one peer timeout at most:
 *   step -> DONE          nothing of ours is needed any more; the robot may stop.
 * Between these, every step polls the protocol (resends, requests, beacons, timeouts) and
 * returns WAIT. The protocol's timeouts end every wait (gp_pse.h, "Liveness").
 *
 * Skip-ahead: a robot behind its fleet (paused, restarted, cut off) runs next the round the
 * live peers are in (gp_pse_next_round), never past its last round; when nothing failed a peer
 * is at most one round ahead, so a lossless run never skips and its models stay the in-process
 * reference's.
 *
 * Memory: the gp_pse_t inside (static with its owner); no allocation. One thread. */
#ifndef GP_GP_ROUND_H
#define GP_GP_ROUND_H

#include <stdint.h>

#include "gp/gp_pse.h"

typedef enum gp_round_event {
    GP_ROUND_WAIT = 0,  /* nothing to do yet: feed messages, come back later */
    GP_ROUND_BEGIN = 1, /* encode the state of the wanted round and call gp_round_begin */
    GP_ROUND_READY = 2, /* the neighbours' states of the round are there */
    GP_ROUND_DONE = 3,  /* the last round is over for the fleet and we left */
} gp_round_event_t;

typedef enum gp_round_phase {
    GP_ROUND_IDLE = 0,  /* between rounds (or before the first), nothing wanted */
    GP_ROUND_CLOSING,   /* round k wanted: waiting until round k - 1 finished */
    GP_ROUND_BEGINNING, /* BEGIN returned: waiting for gp_round_begin */
    GP_ROUND_STATES,    /* round k begun: waiting for the neighbours' states */
    GP_ROUND_UPDATING,  /* READY returned: the node update runs */
    GP_ROUND_FINISHING, /* the last round completed: waiting until every peer finished it */
    GP_ROUND_LEAVING,   /* lingering as a leaver */
    GP_ROUND_LEFT,      /* DONE returned */
} gp_round_phase_t;

typedef struct gp_round {
    gp_pse_t pse;
    uint32_t rounds;        /* of the run: rounds 0 .. rounds - 1 */
    gp_round_phase_t phase;
    uint32_t want;          /* the round wanted (CLOSING .. UPDATING) */
    uint64_t grace_us, cap_us; /* LEAVING: stay until grace (and all left), never past cap */
} gp_round_t;

/* Validates, resets d and the protocol inside it (gp_pse_init). 0 or -EINVAL. */
FS_MUST_CHECK int gp_round_init(gp_round_t *d, const gp_pse_cfg_t *pse_cfg, uint32_t rounds);

/* The AI core wants round k exchanged. Round k must be after the last round begun, or that
 * same round (asked again: nothing changes); a round wanted but never begun gives way to a
 * later one. An unfinished round before k is completed first (its node update is over). 0,
 * or -EINVAL (k out of order, past the last round, after the last round was completed). */
FS_MUST_CHECK int gp_round_want(gp_round_t *d, uint32_t k, uint64_t now_us);

/* Polls the protocol and moves on when the phase's condition holds: see gp_round_event_t.
 * Returns BEGIN and READY once each per round, DONE once. */
gp_round_event_t gp_round_step(gp_round_t *d, uint64_t now_us);

/* After BEGIN: sends our encoded state of the wanted round (kept unchanged by the caller until
 * the next BEGIN, for resends) from position (x_m, y_m). 0 or the protocol's error. */
FS_MUST_CHECK int gp_round_begin(gp_round_t *d, const uint8_t *state, double x_m, double y_m, uint64_t now_us);

/* After READY for round k: the round to run after k (skip-ahead, see above). */
uint32_t gp_round_next_round(const gp_round_t *d, uint32_t k, uint64_t now_us);

/* The node update of round k is over: RoundComplete(k), carrying our position of round k + 1
 * when next_xy is not NULL (gp_pse_complete: known ahead, the peers place us without our
 * beacon). With final (k is the last round) the driver goes on to leave; step says DONE when
 * it may stop. 0, or -EINVAL (not the round being updated, a position not finite). */
FS_MUST_CHECK int gp_round_node_done(gp_round_t *d, uint32_t k, int final, const double next_xy[2], uint64_t now_us);

#endif /* GP_GP_ROUND_H */
