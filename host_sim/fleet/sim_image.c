/* Host driver of one robot's firmware image: see sim_image.h. */
#include "sim_image.h"

#include "sim_explore.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ai/ai_rng.h"
#include "hal_host_msg.h"
#include "hal_host_stop.h"
#include "sim_fleet.h"

void sim_image_cfg_default(sim_image_cfg_t *cfg)
{
    memset(cfg, 0, sizeof *cfg);
    cfg->seed = 1;
    cfg->rounds = 8;
    cfg->policy = AI_POOL_CDR;
    cfg->dinno = dinno_default_cfg();
    cfg->steps_per_round = cfg->dinno.primal_steps;
    cfg->kl_weight = cfg->dinno.kl_weight;
    cfg->time_limit_s = 3600.0;
    cfg->sched = HAL_HOST_SCHED_SERIAL;
    cfg->log_level = HAL_LOG_INFO;
    cfg->ckpt_every = 1;
    cfg->ckpt_keep = GP_CORE_CKPT_KEEP_DEFAULT;
    cfg->ckpt_keep_every = GP_CORE_CKPT_KEEP_EVERY_DEFAULT;
}

static double wall_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The fleet's channels typed on the host's network (hal_host_msg bounds checks) and, with
   `groups`, carried on LCM's per-sender and per-robot groups; then the image made a member
   (fw_robot_join_fleet). */
static int join_fleet(hal_host_t *h, const gp_fleet_cfg_t *fc, int groups, fw_robot_cfg_t *robot, char *err,
                      size_t errlen)
{
    static const int types[GP_FLEET_CHANNELS] = {HAL_HOST_MSG_STATE_CHUNK,    HAL_HOST_MSG_ROUND_COMPLETE,
                                                 HAL_HOST_MSG_CHUNK_REQUEST,  HAL_HOST_MSG_GOAL_CLAIM,
                                                 HAL_HOST_MSG_STATE_CHUNK,    HAL_HOST_MSG_CHUNK_REQUEST};
    hal_host_net_t *net = hal_host_get_net(h);
    for (int c = 0; c < GP_FLEET_CHANNELS; c++) { /* the channels we receive (we only publish on
                                                    the other robots' own) */
        char ch[HAL_NET_CHANNEL_MAX];
        int rc = gp_fleet_channel_of(fc, (gp_fleet_channel_t)c, ch, sizeof ch);
        if (rc == -ENOENT)
            continue;
        if (rc == 0)
            rc = hal_host_net_expect_type(net, ch, types[c]);
        if (rc < 0) {
            snprintf(err, errlen, "image: fleet channels not set up (%d)", rc);
            return rc;
        }
    }
    if (groups) { /* LCM: before the first subscription (fw_robot_join_fleet subscribes) */
        char ch[HAL_NET_CHANNEL_MAX];
        int rc = fc->addressed ? gp_fleet_channel_of(fc, GP_FLEET_CH_STATE, ch, sizeof ch) : -EINVAL;
        if (rc == 0)
            rc = hal_host_net_group_by_sender(net, ch);
        /* A robot's own channels are PREFIX<robot>: robot 0's without its "0". */
        for (int c = GP_FLEET_CH_RESEND; c <= GP_FLEET_CH_ASK && rc == 0; c++) {
            rc = gp_fleet_robot_channel(fc->fleet_id, (gp_fleet_channel_t)c, 0, ch, sizeof ch);
            if (rc == 0) {
                ch[strlen(ch) - 1u] = '\0';
                rc = hal_host_net_group_by_receiver(net, ch);
            }
        }
        if (rc < 0) {
            snprintf(err, errlen, "image: LCM groups refused (%d): they need an addressed fleet on a udpm:// URL", rc);
            return rc;
        }
    }
    int r = fw_robot_join_fleet(robot, fc);
    if (r < 0)
        snprintf(err, errlen, "image: fleet membership refused (%d): robot %u of %u, %u rounds", r, fc->self,
                 fc->n_peers, fc->rounds);
    return r;
}

int sim_image_run(const sim_plan_t *plan, const sim_path_t *path, const sim_image_cfg_t *cfg,
                  sim_image_result_t *res, char *err, size_t errlen)
{
    char dummy[2];
    if (err == NULL || errlen == 0) {
        err = dummy;
        errlen = sizeof dummy;
    }
    if (plan == NULL || path == NULL || cfg == NULL || res == NULL) {
        snprintf(err, errlen, "image: NULL argument");
        return -EINVAL;
    }
    memset(res, 0, sizeof *res);
    if (path->n < 2 || path->n > RT_CORE_MAX_WAYPOINTS) {
        snprintf(err, errlen, "image: the path needs 2 .. %d waypoints (has %d)", RT_CORE_MAX_WAYPOINTS,
                 path->n);
        return -EINVAL;
    }
    if (cfg->rounds < 1 || cfg->rounds > AI_CORE_MAX_ROUNDS || cfg->steps_per_round < 1 ||
        (cfg->rounds_per_boundary > 1 && cfg->rounds % cfg->rounds_per_boundary != 0) ||
        (cfg->fleet != NULL && cfg->net_url == NULL) ||
        !(cfg->time_limit_s > 0) || !isfinite(cfg->time_limit_s) || !(cfg->kl_weight >= 0) ||
        !isfinite(cfg->kl_weight) || cfg->start_round >= cfg->rounds + (cfg->fleet ? cfg->fleet->post_rounds : 0u) ||
        cfg->resume_ckpt_bytes > UINT32_MAX) {
        snprintf(err, errlen, "image: need 1 <= rounds <= %u, steps per round >= 1, a positive time "
                              "limit, a finite kl weight >= 0 and a start round below rounds", AI_CORE_MAX_ROUNDS);
        return -EINVAL;
    }
    int rc;
    sim_hal_world_t *hw = NULL;
    hal_host_t *h = NULL;
    rt_waypoint_t *wps = malloc(sizeof(rt_waypoint_t) * (size_t)path->n);
    if (wps == NULL) {
        snprintf(err, errlen, "image: out of memory");
        return -ENOMEM;
    }
    sim_hal_world_cfg_t wc = sim_hal_world_default_cfg();
    wc.robot = cfg->robot;
    wc.seed = cfg->seed;
    wc.coverage = cfg->coverage;
    rc = sim_hal_world_create(plan, path, &wc, &hw, err, errlen);
    if (rc < 0)
        goto out;

    hal_host_config_t hc = hal_host_config_default();
    hc.sched = cfg->sched;
    hc.net_url = cfg->net_url;
    hc.net_faults = cfg->net_faults;
    hc.net_faults_seed = cfg->seed;
    hc.net_auth = cfg->net_auth;
    hc.storage_dir = cfg->storage_dir;
    hc.log_level = cfg->log_level;
    if (cfg->fleet != NULL) {
        /* The receive ring (hal_host_net.c), sized by the neighbour slots, not the fleet. State
           chunks come only from the peers a robot may keep (hal_net_set_senders drops the others
           before they are queued): at most K = min(n_peers - 1, GP_PSE_MAX_NEIGHBOURS + 8) of
           them (the kept neighbours and some room for the set changing as robots move). Room
           for four rounds of their states: the GP core drains the queue only when it runs, and
           on a host with more robots than cores a robot can stay off the CPU while its peers
           send; a peer is at most one round ahead of the slowest one it waits for, so two
           rounds are in flight, and resends of lost chunks come on top (four rounds covers
           both). A chunk costs its datagram header and the ring entry's header and alignment
           besides its share of the state. Small messages (requests, beacons, completions:
           45 .. 300 B, 128 B with the tag and the entry for most) come from the whole fleet: 64
           per peer of 128 B. 64 KB of slack on top. The message cap counts the same way: four
           rounds of K peers' chunks, the 64 small messages per peer the bytes allow, 64 more (a
           message costs only its bytes in the ring, so the cap need not be tighter than the
           bytes; beacons and requests of the whole fleet pile up while a robot is off the CPU:
           a cap of 16 per peer dropped thousands of them in a 16-robot run on a loaded host,
           32 still hundreds). The ring's pages are touched only up to its high-water mark (it
           goes back to offset 0 whenever it empties), so unused room costs address space, not
           memory. */
        const uint32_t chunks = (gp_fleet_state_bytes(cfg->fleet->encoding) + GP_PSE_MAX_CHUNK_BYTES - 1u) /
                                GP_PSE_MAX_CHUNK_BYTES;
        const uint32_t n_peers = cfg->fleet->n_peers;
        const uint32_t k_max = GP_PSE_MAX_NEIGHBOURS + 8u;
        const uint32_t k = n_peers > 1u ? (n_peers - 1u < k_max ? n_peers - 1u : k_max) : 0u;
        const size_t chunk_room = GP_PSE_CHUNK_HEADER_ROOM + HAL_HOST_NET_ENTRY_HEADER + 8u;
        size_t bytes = 4u * (size_t)k * ((size_t)gp_fleet_state_bytes(cfg->fleet->encoding) + chunks * chunk_room) +
                       64u * (size_t)n_peers * 128u + 64u * 1024u;
        if (bytes < HAL_HOST_NET_QUEUE_BYTES_MIN)
            bytes = HAL_HOST_NET_QUEUE_BYTES_MIN;
        if (bytes > HAL_HOST_NET_QUEUE_BYTES_MAX)
            bytes = HAL_HOST_NET_QUEUE_BYTES_MAX;
        hc.net_queue_bytes = bytes;
        const uint32_t want = 4u * k * chunks + 64u * n_peers + 64u;
        hc.net_queue_depth = want > HAL_HOST_NET_QUEUE_MAX ? HAL_HOST_NET_QUEUE_MAX : want;
    }
    if ((rc = sim_hal_world_host(hw, cfg->robot, hc, &h, err, errlen)) < 0)
        goto out;
    fw_robot_cfg_t fc = fw_robot_default_cfg();
    sim_hal_world_rt_cfg(plan, path, wps, &fc.rt);
    fc.ai.rounds = cfg->rounds;
    fc.ai.rounds_per_boundary = cfg->rounds_per_boundary ? cfg->rounds_per_boundary : 1u;
    fc.ai.offline = cfg->offline;
    fc.ai.policy = cfg->policy;
    fc.ai.dinno = cfg->dinno;
    fc.ai.dinno.primal_steps = cfg->steps_per_round;
    fc.ai.dinno.kl_weight = cfg->kl_weight;
    ai_core_seeds(cfg->seed, cfg->robot, &fc.ai.model_seed, &fc.ai.seed);
    fc.ai.node_id = cfg->robot;
    fc.ai.train_between = cfg->train_between;
    fc.ai.pool_samples = cfg->pool_samples;
    fc.ai.start_round = cfg->start_round;
    fc.ai.resume_ckpt = cfg->resume_ckpt;
    fc.ai.resume_ckpt_bytes = (uint32_t)cfg->resume_ckpt_bytes;
    fc.gp.robot_id = cfg->robot;
    fc.gp.ckpt_every = cfg->ckpt_every;
    fc.gp.ckpt_keep = cfg->ckpt_keep;
    fc.gp.ckpt_keep_every = cfg->ckpt_keep_every;
    if (cfg->fleet != NULL) {
        gp_fleet_cfg_t fleet_cfg = *cfg->fleet;
        /* exploring fleets claim their goals, but for the frontier policy (each on its own) */
        fleet_cfg.claims = cfg->explore != NULL && cfg->explore->policy != GP_EXPLORE_FRONTIER;
        if ((rc = join_fleet(h, &fleet_cfg, cfg->net_groups, &fc, err, errlen)) < 0)
            goto out;
    }
    /* Exploring: the three cores' grids over the plan (sim_explore.h); the path is only the start. */
    static gp_explore_cfg_t gx;     /* read by the cores' init only: copied there */
    static ai_belief_cfg_t bx;
    static rt_explore_cfg_t rx;
    static uint8_t keep_in[RT_GRID_MAX_CELLS]; /* the fence, read by the RT core's init */
    if (cfg->explore != NULL) {
        sim_explore_geom_t geom;
        const uint32_t n_peers = cfg->fleet != NULL ? cfg->fleet->n_peers : 1u;
        if (sim_explore_geometry(plan, &geom) != 0 ||
            sim_explore_gp_cfg(&geom, cfg->explore, cfg->robot, n_peers,
                               cfg->rounds / (cfg->rounds_per_boundary ? cfg->rounds_per_boundary : 1u), &gx) != 0 ||
            sim_explore_rt_cfg(&geom, cfg->explore, &fc.rt, &rx) != 0 ||
            (!cfg->explore->no_fence && sim_explore_keep_in(plan, &geom, keep_in, sizeof keep_in) != 0)) {
            snprintf(err, errlen, "image: the plan's box is too large for the exploration grids");
            rc = -EINVAL;
            goto out;
        }
        rx.keep_in = cfg->explore->no_fence ? NULL : keep_in;
        sim_explore_belief_cfg(plan, &geom, &bx);
        fc.gp.explore = &gx;
        fc.ai.explore_budget_us = (uint64_t)llround(cfg->explore->budget_s * 1e6);
        fc.ai.belief = &bx;
        fc.ai.belief_period_us = (uint64_t)llround(cfg->explore->belief_period_s * 1e6);
        /* a posterior crosses the exchange only as fp32 words (bnn_post.h), as after the rounds */
        fc.ai.explore_share_post = !cfg->explore->own_posterior && cfg->fleet != NULL && cfg->fleet->n_peers > 1u &&
                                   cfg->fleet->encoding == DINNO_CODEC_FP32;
        fc.ai.explore_counts = cfg->explore->counts;
    }
    rc = fw_robot_start(&fc);
    if (rc < 0) {
        snprintf(err, errlen, "image: firmware not started (%d): check the options", rc);
        goto out;
    }
    res->path_length_m = rt_core_path_length(fw_robot_rt());

    gp_core_t *gp = fw_robot_gp();
    const uint64_t slice = 1000000u;
    const uint64_t limit = (uint64_t)llround(cfg->time_limit_s * 1e6);
    uint32_t seen = 0, fleet_seen = 0;
    double t0 = wall_now();
    for (uint64_t t = 0; t < limit;) {
        t = t + slice < limit ? t + slice : limit;
        rc = hal_host_run_until(h, t);
        if (rc < 0 && rc != -EINTR) {
            snprintf(err, errlen, "image: simulation failed at t = %.2f s (%d)", (double)t * 1e-6, rc);
            goto out;
        }
        /* Every core is blocked in the lockstep now: the round log is stable. */
        for (const gp_fleet_round_t *r; cfg->fleet && (r = gp_fleet_round(fw_robot_fleet(), fleet_seen)) != NULL;
             fleet_seen++)
            if (cfg->on_fleet_round)
                cfg->on_fleet_round(r, cfg->user);
        for (const ai_round_info_t *r; (r = gp_core_round(gp, seen)) != NULL; seen++) {
            if (r->ckpt_status != 0 && res->ckpt_error == 0) {
                res->ckpt_error = r->ckpt_status;
                res->ckpt_error_round = r->round;
            }
            if (cfg->on_round)
                cfg->on_round(r, cfg->user);
        }
        if (cfg->on_second)
            cfg->on_second(hal_host_now_us(h), &fw_robot_rt()->status, gp, cfg->second_user);
        if (gp_core_done(gp))
            res->completed = 1;
        res->stop_signal = hal_host_stop_signal();
        if (res->completed || res->stop_signal != 0 || res->ckpt_error != 0)
            break;
    }
    res->sim_time_us = hal_host_now_us(h);
    hal_host_stop(h);
    res->wall_s = wall_now() - t0;
    for (int i = 0; i < HAL_CORE_COUNT; i++) {
        if (hal_host_core_stats(h, (hal_core_id_t)i, &res->core[i]) != 0)
            memset(&res->core[i], 0, sizeof res->core[i]);
        res->fw[i] = fw_robot_image()->stats[i];
    }
    res->host_world_steps = hal_host_world_steps(h);
    sim_hal_world_get_stats(hw, &res->world);
    res->rt = fw_robot_rt()->stats;
    res->rt_status = fw_robot_rt()->status;
    res->ai_status = fw_robot_ai()->status;
    res->ai_empty_rounds = fw_robot_ai()->empty_rounds;
    res->gp = gp->stats;
    res->explore = gp->explore.stats;
    res->claims = gp->explore.goal.stats;
    res->final_ckpt_status = gp->final_ckpt_status;
    res->rounds_done = fw_robot_ai()->next_round;
    fw_robot_memory(&res->mem);
    if (cfg->fleet != NULL) {
        res->fleet = fw_robot_fleet()->stats;
        res->pse = fw_robot_fleet()->drv.pse.stats;
        const hal_board_t *b = hal_host_board(h);
        if (b != NULL && b->net != NULL && b->net->stats != NULL)
            (void)b->net->stats(b->ctx, &res->net);
    }
    rc = 0;
out:
    hal_host_destroy(h);
    sim_hal_world_destroy(hw);
    free(wps);
    return rc;
}

int sim_image_occ_near_path(const sim_plan_t *plan, const sim_path_t *path, bnn_model_t *m,
                            double res, double radius_m, double *mse, size_t *n_cells)
{
    if (plan == NULL || path == NULL || m == NULL || mse == NULL || n_cells == NULL ||
        path->n < 1 || !(res > 0) || !(radius_m >= 0))
        return -EINVAL;
    sim_occ_eval_t ev;
    memset(&ev, 0, sizeof ev);
    int rc = sim_occ_eval_build(plan, res, &ev);
    if (rc != 0)
        return rc;
    /* Keep the cells near the path (in place), then score them like the fleet does. */
    size_t k = 0;
    for (size_t i = 0; i < ev.n; i++) {
        double x, y;
        sim_plan_denormalise(plan, ev.xy[2 * i], ev.xy[2 * i + 1], &x, &y);
        if (sim_path_distance(path, x, y) > radius_m)
            continue;
        ev.xy[2 * k] = ev.xy[2 * i];
        ev.xy[2 * k + 1] = ev.xy[2 * i + 1];
        ev.truth[k] = ev.truth[i];
        ev.cell[k] = ev.cell[i];
        k++;
    }
    ev.n = k;
    *n_cells = k;
    *mse = NAN;
    double iou;
    if (k > 0)
        rc = sim_occ_eval_run(&ev, m, mse, &iou);
    sim_occ_eval_free(&ev);
    return rc;
}
