/* The general-purpose core of the robot image: the round coordinator between the AI core and
 * the network, telemetry and checkpoints.
 *
 * Each tick (default 10 Hz):
 *   - takes the latest RT and AI status (mailboxes);
 *   - round coordination (fw_link.h protocol): when the AI core published its state of
 *     round k, the GP core obtains the neighbours' states of round k as a view (fw_link_t.nbrs:
 *     pointers to the states where they arrived, ascending id) and publishes ready(k). Who the neighbours are
 *     and how their states arrive is the `exchange` hook: NULL (no peers configured) means
 *     no neighbour, so the round completes locally at once; the multi-process fleet plugs in
 *     a hook that sends this robot's state over hal_net (Algorithm 1) and fills the view
 *     when every neighbour's state arrived (-EAGAIN until then; the GP core asks again on
 *     its next tick, the AI core keeps waiting without blocking anything);
 *   - the other peers hooks (gp_peers_ops_t, all optional): `service` every tick (the
 *     network is answered while the AI core trains or the robot drives), `round_done` when the
 *     checkpoint of round k shows the AI core's node update is over (Algorithm 1's
 *     RoundComplete; with final = 1 after the last round, before `done` is set);
 *   - when the AI core published the checkpoint of round k: writes it through the storage
 *     HAL as "round_<k>.bnn" (4 digits; every ckpt_every rounds; the newest ckpt_keep and every
 *     ckpt_keep_every-th kept, the one that falls out removed) and, after the last round, as "final.bnn"; appends
 *     the round's record to a fixed log (the host reads it for metrics); logs a line;
 *   - publishes a gp_telemetry_t on GP_TELEMETRY_CHANNEL_PREFIX<robot> every
 *     telemetry_every ticks and at every round (no network: counted, not an error).
 *
 * Storage: gp_core_t is static (declared by the image). No allocation. One GP core per image.
 * The round log and `done` may be read by the host between hal_host_run_until() calls (all
 * cores are then blocked in the lockstep) or after the cores stopped. */
#ifndef GP_GP_CORE_H
#define GP_GP_CORE_H

#include <stdatomic.h>
#include <stdint.h>

#include "ai/ai_link.h"
#include "common/fw_core.h"
#include "fw_link.h"
#include "gp/gp_explore.h"
#include "gp/gp_link.h"
#include "gp/gp_telemetry.h"
#include "rt/rt_link.h"

/* GP_CORE_LOG_ROUNDS (round records kept: a ring of the latest) comes from common/fw_config.h. */

/* This robot's side of round k: its state and where it is (latest RT pose). */
typedef struct gp_exchange_req {
    uint32_t round;
    const float *theta;        /* n_params floats, stable until the hook returned >= 0 */
    uint32_t n_params;
    double x_m, y_m;
    const gp_goal_claim_t *claim; /* exploring: our goal claim of this round (seq = round), sent
                                     before the state; NULL: none */
} gp_exchange_req_t;

/* How the GP core reaches its peers. Every hook is optional; ctx is gp_core_cfg_t.peers_ctx. */
typedef struct gp_peers_ops {
    /* Fills the view with the neighbour states of req->round (round, count, ascending ids, and
     * pointers to n_params floats each that stay unchanged until the hook is called for the
     * next round). Returns the number of neighbours (>= 0, == nbrs->count), -EAGAIN when the states are not all there yet (called again
     * next tick), or another negative code (the round then completes without neighbours and
     * the error is counted). NULL: no peers, every round is local. */
    int (*exchange)(void *ctx, const gp_exchange_req_t *req, dinno_nbrs_t *nbrs);
    /* The node update of `round` is over (its checkpoint arrived); final: it was the last. */
    void (*round_done)(void *ctx, uint32_t round, int final);
    /* Every tick: receive, answer the peers, resend. */
    void (*service)(void *ctx);
    /* After the exchange of `round`: the round the AI core runs next, round + 1 unless the
     * robot fell behind its fleet and skips ahead (a paused or restarted robot). NULL: + 1. */
    uint32_t (*next_round)(void *ctx, uint32_t round);
    /* After the exchange of `round`: the peers' goal claims of rounds <= round received since the
     * last call (at most max into out, the latest per peer), to hand to gp_explore. NULL: none. */
    uint32_t (*claims)(void *ctx, uint32_t round, gp_goal_claim_t *out, uint32_t max);
} gp_peers_ops_t;

typedef struct gp_core_cfg {
    uint32_t robot_id;
    uint32_t telemetry_every;  /* ticks between telemetry records, >= 1 (default 10) */
    const gp_peers_ops_t *peers; /* NULL: no peers */
    void *peers_ctx;
    uint32_t ckpt_every;       /* round k's checkpoint when (k + 1) % ckpt_every == 0: 1 (default)
                                  every round; 0: the final one only */
    uint32_t ckpt_keep;        /* round checkpoints kept: the newest ckpt_keep (default
                                  GP_CORE_CKPT_KEEP_DEFAULT; 0: all), plus ... */
    uint32_t ckpt_keep_every;  /* ... every round k with (k + 1) % ckpt_keep_every == 0 (default
                                  GP_CORE_CKPT_KEEP_EVERY_DEFAULT; 0: none of the older ones) */
    const gp_explore_cfg_t *explore; /* NULL: a fixed tour; else goals chosen each tick
                                        (gp_explore.h; copied at init) */
} gp_core_cfg_t;

/* Storage is finite on a board (and 3000 rounds of a lone run were 400 MB on the host): the
 * newest few checkpoints are what a resume needs (more than one, in case the newest is torn),
 * the sparse older ones what a look back at the training needs. */
#define GP_CORE_CKPT_KEEP_DEFAULT 5u
#define GP_CORE_CKPT_KEEP_EVERY_DEFAULT 100u

typedef struct gp_core_stats {
    uint64_t ticks;
    uint64_t telemetry_sent;
    uint64_t telemetry_failed;  /* publish refused (no network, ...) */
    uint64_t ckpt_written;
    uint64_t ckpt_removed;      /* older round checkpoints removed (ckpt_keep) */
    uint64_t ckpt_failed;
    uint64_t exchange_errors;
    uint64_t rounds_coordinated;
    uint64_t explore_errors;    /* gp_explore_tick failures */
} gp_core_stats_t;

typedef struct gp_core {
    gp_core_cfg_t cfg;
    const fw_link_t *link;
    rt_status_t rt;
    ai_status_t ai;
    int have_rt, have_ai;
    int exchange_pending;      /* a state was taken, ready not yet published */
    uint32_t exchange_round;
    uint32_t neighbours;
    gp_core_stats_t stats;
    _Atomic uint32_t n_log;    /* records written so far (log[] keeps the latest) */
    _Atomic uint32_t done;     /* 1 once the final checkpoint was handled */
    int32_t final_ckpt_status; /* 0 or the storage error of final.bnn */
    int ckpt_any;              /* a round checkpoint was written (the last: ckpt_last) */
    uint32_t ckpt_last;
    uint32_t ckpt_run_from;    /* the first round written after the last skip (0: none) */
    ai_round_info_t log[GP_CORE_LOG_ROUNDS];
    uint8_t tele[GP_TELEMETRY_WIRE_BYTES];
    char channel[64];
    int exploring;
    gp_explore_t explore;      /* used with cfg.explore */
    gp_goal_claim_t claim_out; /* our claim of the round being exchanged */
    gp_goal_claim_t claims_in[GP_GOAL_MAX_CLAIMS];
} gp_core_t;

gp_core_cfg_t gp_core_default_cfg(void);

/* Validates and resets (before the cores start). 0 or -EINVAL. */
FS_MUST_CHECK int gp_core_init(gp_core_t *gp, const gp_core_cfg_t *cfg,
                                                     const fw_link_t *link);

/* fw_core_t tick function: arg is the gp_core_t. */
int gp_core_tick(void *arg, const fw_tick_t *tick);

/* The GP core's work while it sleeps and the board's clock stands still (hal_clock_while_asleep,
 * the host's lockstep while another core computes): the peers' service (read the network,
 * answer it, say we are alive), as a board's GP core does between its ticks in real time. */
#define GP_CORE_ASLEEP_EVERY_US 25000u
void gp_core_asleep(void *arg);

/* For the host, while the cores are held (lockstep) or stopped; any thread. The round log
 * grows by release stores, so the records below gp_core_rounds_logged() are complete. */
uint32_t gp_core_rounds_logged(gp_core_t *gp);
/* Record i of the round log: NULL unless i < gp_core_rounds_logged() and it is still among
 * the latest GP_CORE_LOG_ROUNDS. */
const ai_round_info_t *gp_core_round(gp_core_t *gp, uint32_t i);
/* 1 once the final checkpoint was handled (its storage status in final_ckpt_status). */
int gp_core_done(gp_core_t *gp);

/* Storage name of round k's checkpoint into buf (>= HAL_STORAGE_NAME_MAX bytes). */
void gp_core_ckpt_name(uint32_t round, char *buf, size_t cap);

#endif /* GP_GP_CORE_H */
