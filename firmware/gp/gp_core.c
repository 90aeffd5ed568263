/* The GP core loop: see gp_core.h. */
#include "gp/gp_core.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "hal/hal.h"

_Static_assert(sizeof(gp_core_t) + GP_LINK_BYTES <= BOARD_RAM_GP_BYTES,
               "GP core state and its links exceed the board's GP RAM");

gp_core_cfg_t gp_core_default_cfg(void)
{
    gp_core_cfg_t c;
    memset(&c, 0, sizeof c);
    c.telemetry_every = 10;
    c.ckpt_every = 1;
    c.ckpt_keep = GP_CORE_CKPT_KEEP_DEFAULT;
    c.ckpt_keep_every = GP_CORE_CKPT_KEEP_EVERY_DEFAULT;
    return c;
}

int gp_core_init(gp_core_t *gp, const gp_core_cfg_t *cfg, const fw_link_t *link)
{
    if (gp == NULL || cfg == NULL || link == NULL || cfg->telemetry_every < 1)
        return -EINVAL;
    memset(gp, 0, sizeof *gp);
    gp->cfg = *cfg;
    gp->link = link;
    int n = snprintf(gp->channel, sizeof gp->channel, "%s%" PRIu32, GP_TELEMETRY_CHANNEL_PREFIX,
                     cfg->robot_id);
    if (n < 0 || (size_t)n >= sizeof gp->channel || !hal_net_channel_valid(gp->channel))
        return -EINVAL;
    atomic_store(&gp->n_log, 0u);
    atomic_store(&gp->done, 0u);
    if (cfg->explore != NULL) {
        int r = gp_explore_init(&gp->explore, cfg->explore);
        if (r != 0)
            return r;
        gp->exploring = 1;
        gp->cfg.explore = &gp->explore.cfg;
    }
    return 0;
}

void gp_core_ckpt_name(uint32_t round, char *buf, size_t cap)
{
    snprintf(buf, cap, "round_%04" PRIu32 ".bnn", round);
}

static void send_telemetry(gp_core_t *gp, uint64_t now_us)
{
    gp_telemetry_t t;
    memset(&t, 0, sizeof t);
    t.robot_id = gp->cfg.robot_id;
    t.round = gp->have_ai ? gp->ai.round : 0u;
    t.stamp_us = now_us;
    t.x_m = gp->rt.x_m;
    t.y_m = gp->rt.y_m;
    t.heading_rad = gp->rt.heading_rad;
    t.loss_train = gp->have_ai ? gp->ai.loss_train : NAN;
    t.loss_val = NAN; /* the robot has no validation data; the host computes it */
    t.pool_fill = gp->have_ai ? gp->ai.pool_fill : 0u;
    t.pool_capacity = gp->have_ai ? gp->ai.pool_capacity : 0u;
    t.ring_drops = gp->rt.ring_drops;
    hal_net_stats_t ns;
    if (hal_net_get_stats(&ns) == 0) {
        uint64_t d = ns.rx_dropped_full + ns.rx_dropped_invalid + ns.rx_dropped_small + ns.rx_dropped_malformed +
                     ns.rx_dropped_unauth + ns.rx_dropped_replay;
        t.net_drops = d > 0xFFFFFFFFu ? 0xFFFFFFFFu : (uint32_t)d;
    }
    t.neighbours = gp->neighbours > 255u ? 255u : gp->neighbours;
    if (gp_telemetry_encode(&t, gp->tele, sizeof gp->tele) == 0 &&
        hal_net_publish(gp->channel, gp->tele, sizeof gp->tele) == 0)
        gp->stats.telemetry_sent++;
    else
        gp->stats.telemetry_failed++;
}

static void handle_ckpt(gp_core_t *gp, uint64_t now_us);

/* Exploring with claims: our goal goes to the peers with the round's state, its seq the round
 * (so a receiver takes the claims of rounds up to its own at its round, the same ones on every
 * run), alive until a round and a half later at most (gp_goal's limit). */
static const gp_goal_claim_t *our_claim(gp_core_t *gp, uint64_t now_us)
{
    const gp_explore_t *x = &gp->explore;
    if (!gp->exploring || x->cfg.policy == GP_EXPLORE_FRONTIER ||
        gp_goal_our_claim(&x->goal, gp->exchange_round, now_us, &gp->claim_out) != 0)
        return NULL;
    return &gp->claim_out;
}

static void take_claims(gp_core_t *gp, uint64_t now_us)
{
    if (!gp->exploring || gp->cfg.peers == NULL || gp->cfg.peers->claims == NULL)
        return;
    const uint32_t n = gp->cfg.peers->claims(gp->cfg.peers_ctx, gp->exchange_round, gp->claims_in, GP_GOAL_MAX_CLAIMS);
    for (uint32_t i = 0; i < n; i++) {
        const int r = gp_explore_on_claim(&gp->explore, &gp->claims_in[i], now_us);
        if (r != 0 && r != -EALREADY && r != -ESTALE)
            hal_log(HAL_LOG_WARN, "round %" PRIu32 ": robot %" PRIu32 "'s goal claim refused (%d)", gp->exchange_round,
                    gp->claims_in[i].sender, r);
    }
}

static void coordinate(gp_core_t *gp, uint64_t now_us)
{
    if (!gp->exchange_pending) {
        if (mbox_fetch(gp->link->ai_state) != 1)
            return;
        const ai_state_msg_t *st = mbox_read_buffer(gp->link->ai_state, NULL);
        gp->exchange_pending = 1;
        gp->exchange_round = st->round;
        /* ckpt(k-1) was published before state(k): take it now, before ready(k) lets the
         * AI core publish ckpt(k) over it (a mailbox keeps only the latest). */
        handle_ckpt(gp, now_us);
    }
    /* The neighbour view is the GP core's until ready(k) is published. */
    dinno_nbrs_t *nbrs = gp->link->nbrs;
    int n = 0;
    if (gp->cfg.peers != NULL && gp->cfg.peers->exchange != NULL) {
        const ai_state_msg_t *st = mbox_read_buffer(gp->link->ai_state, NULL);
        const gp_exchange_req_t req = {gp->exchange_round, st->theta, st->n_params, gp->rt.x_m, gp->rt.y_m,
                                       our_claim(gp, now_us)};
        n = gp->cfg.peers->exchange(gp->cfg.peers_ctx, &req, nbrs);
        if (n == -EAGAIN)
            return;
        if (n < 0) {
            gp->stats.exchange_errors++;
            hal_log(HAL_LOG_WARN, "round %" PRIu32 ": state exchange failed (%d), local round",
                    gp->exchange_round, n);
            n = 0;
        }
    }
    if (n == 0) {
        nbrs->count = 0;
        nbrs->round = gp->exchange_round;
    }
    take_claims(gp, now_us);
    uint32_t next = gp->exchange_round + 1u;
    if (gp->cfg.peers != NULL && gp->cfg.peers->next_round != NULL) {
        next = gp->cfg.peers->next_round(gp->cfg.peers_ctx, gp->exchange_round);
        if (next > gp->exchange_round + 1u)
            hal_log(HAL_LOG_WARN, "round %" PRIu32 ": behind the fleet, skipping to round %" PRIu32,
                    gp->exchange_round, next);
    }
    gp_ready_t ready = {gp->exchange_round, (uint32_t)n, next};
    gp->neighbours = (uint32_t)n;
    if (mbox_put(gp->link->gp_ready, &ready) != 0)
        return;
    gp->exchange_pending = 0;
    gp->stats.rounds_coordinated++;
}

/* Round k's checkpoint is written: the one ckpt_keep checkpoints before it falls out of the
 * newest, and goes unless it is one of the every-ckpt_keep_every kept for good. A robot that
 * skipped rounds leaves the ones before the skip behind (never more than ckpt_keep per skip):
 * the host reads a round's checkpoint after the round's record (a slice of simulated time
 * later, host_sim run's validation), and a skip writes the next checkpoint at once, so
 * "ckpt_keep rounds ago" would be the one just written and not yet read (a 256-robot fleet
 * lost a robot to that). */
static void drop_old_ckpt(gp_core_t *gp, uint32_t k)
{
    if (gp->ckpt_any && k != gp->ckpt_last + gp->cfg.ckpt_every)
        gp->ckpt_run_from = k; /* rounds were skipped (a resume's first write is none) */
    gp->ckpt_any = 1;
    gp->ckpt_last = k;
    const uint64_t span = (uint64_t)gp->cfg.ckpt_keep * gp->cfg.ckpt_every;
    if (gp->cfg.ckpt_keep == 0 || k < span || k - (uint32_t)span < gp->ckpt_run_from)
        return;
    const uint32_t old = k - (uint32_t)span;
    if (gp->cfg.ckpt_keep_every > 0 && (old + 1u) % gp->cfg.ckpt_keep_every == 0)
        return;
    char name[HAL_STORAGE_NAME_MAX];
    gp_core_ckpt_name(old, name, sizeof name);
    const int r = hal_storage_remove(name);
    if (r == 0)
        gp->stats.ckpt_removed++;
    else if (r != -ENOENT) /* not written (skipped, resumed past it): nothing to do */
        hal_log(HAL_LOG_WARN, "cannot remove %s: %d", name, r);
}

static void handle_ckpt(gp_core_t *gp, uint64_t now_us)
{
    if (mbox_fetch(gp->link->ai_ckpt) != 1)
        return;
    const ai_ckpt_msg_t *m = mbox_read_buffer(gp->link->ai_ckpt, NULL);
    const ai_round_info_t *in = &m->info;
    const int final = (m->flags & AI_CKPT_FLAG_FINAL) != 0;
    char name[HAL_STORAGE_NAME_MAX];
    int r = 0;
    /* RoundComplete(k) goes out before the checkpoint is written: the write ends in an fsync,
       milliseconds on a disk, which then overlaps the peers' last node updates instead of
       lengthening every round of the whole fleet. A robot that dies in between resumes from
       the checkpoint before, as after any crash. The final model is written first (round_done
       then lingers for the peers). */
    if (!final && gp->cfg.peers != NULL && gp->cfg.peers->round_done != NULL)
        gp->cfg.peers->round_done(gp->cfg.peers_ctx, in->round, 0);
    if (m->n_bytes == 0) {
        r = -EINVAL;
    } else {
        if (gp->cfg.ckpt_every > 0 && (in->round + 1u) % gp->cfg.ckpt_every == 0) {
            gp_core_ckpt_name(in->round, name, sizeof name);
            r = hal_storage_write(name, m->bytes, m->n_bytes);
            if (r == 0)
                drop_old_ckpt(gp, in->round);
        }
        if (r == 0 && final)
            r = hal_storage_write("final.bnn", m->bytes, m->n_bytes);
    }
    if (r == 0)
        gp->stats.ckpt_written++;
    else
        gp->stats.ckpt_failed++;
    /* A ring: the host reads the new records after every slice of simulated time. */
    uint32_t n = atomic_load_explicit(&gp->n_log, memory_order_relaxed);
    gp->log[n % GP_CORE_LOG_ROUNDS] = *in;
    gp->log[n % GP_CORE_LOG_ROUNDS].ckpt_status = r;
    atomic_store_explicit(&gp->n_log, n + 1u, memory_order_release);
    hal_log(HAL_LOG_INFO,
            "round %" PRIu32 " done: progress %.2f m, pool %" PRIu32 "/%" PRIu32 ", drops %" PRIu32
            ", loss %.4f (bce %.4f, kl %.2f), %" PRIu32 " neighbours, ckpt %s",
            in->round, (double)in->progress_m, in->pool_fill, in->pool_capacity, in->ring_drops,
            (double)in->loss_train, (double)in->bce, (double)in->kl, in->neighbours,
            r == 0 ? "written" : "FAILED");
    if (final && gp->cfg.peers != NULL && gp->cfg.peers->round_done != NULL)
        gp->cfg.peers->round_done(gp->cfg.peers_ctx, in->round, 1);
    send_telemetry(gp, now_us);
    if (final) {
        gp->final_ckpt_status = r;
        atomic_store_explicit(&gp->done, 1u, memory_order_release);
    }
}

void gp_core_asleep(void *arg)
{
    gp_core_t *gp = arg;
    if (gp->cfg.peers != NULL && gp->cfg.peers->service != NULL)
        gp->cfg.peers->service(gp->cfg.peers_ctx);
}

int gp_core_tick(void *arg, const fw_tick_t *tick)
{
    gp_core_t *gp = arg;
    gp->stats.ticks++;
    if (mbox_get(gp->link->rt_to_gp, &gp->rt, NULL) == 1)
        gp->have_rt = 1;
    if (mbox_get(gp->link->ai_status, &gp->ai, NULL) == 1)
        gp->have_ai = 1;
    if (gp->cfg.peers != NULL && gp->cfg.peers->service != NULL)
        gp->cfg.peers->service(gp->cfg.peers_ctx);
    handle_ckpt(gp, tick->now_us);
    coordinate(gp, tick->now_us);
    if (gp->exploring && gp_explore_tick(&gp->explore, gp->link, gp->have_rt ? &gp->rt : NULL, tick->now_us) != 0)
        gp->stats.explore_errors++;
    if (tick->index % gp->cfg.telemetry_every == 0)
        send_telemetry(gp, tick->now_us);
    return 0;
}

uint32_t gp_core_rounds_logged(gp_core_t *gp)
{
    return atomic_load_explicit(&gp->n_log, memory_order_acquire);
}

const ai_round_info_t *gp_core_round(gp_core_t *gp, uint32_t i)
{
    const uint32_t n = gp_core_rounds_logged(gp);
    return i < n && n - i <= GP_CORE_LOG_ROUNDS ? &gp->log[i % GP_CORE_LOG_ROUNDS] : NULL;
}

int gp_core_done(gp_core_t *gp)
{
    return atomic_load_explicit(&gp->done, memory_order_acquire) != 0u;
}
