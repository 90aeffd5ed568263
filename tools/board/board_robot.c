/* board_robot: the whole robot on a board, in the loop with `host_sim hil`. The firmware image
 * of the host's robots (fw_robot: the RT, GP and AI cores with their links) runs on the board's
 * own cores (on a Cortex-M the stdc back end's scheduler: RT > GP > AI > this program); its
 * lidar, pose and wheels are the world's, and its network is the fleet's, both over the
 * hardware-in-the-loop link (hal_stdc_install_hil with a network: the world bridges the fleet's
 * datagrams to LCM). It drives its tour, trains its DiNNO node on what it saw and takes part in
 * the fleet's rounds, as `host_sim run --fleet N --id I` does on the host, and its checkpoints
 * (final.bnn) go to --out through the board's storage (semihosting on a Cortex-M).
 *
 * Its seeds, configuration and protocol are the host robot's, so robot I on the board trains
 * the model robot I trains as a host process given the board's pool (`host_sim run
 * --pool-samples`, printed by --help) and chunk size (--chunk-bytes), up to the rounding of the
 * board's C library and math.
 *
 * The main program runs below the three cores: it reports the rounds as the GP core logs them
 * and ends when the GP core handled the final checkpoint, when --time ran out, or when the
 * world stopped answering (the HAL's link_down). Built for the Cortex-M boards (`make hil
 * BOARD=...`, boards/cross.mk). */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "board_args.h"
#include "board_world.h"
#include "fw_robot.h"
#include "gp/gp_pse.h"
#include "hal_stdc.h"
#include "hal_stdc_hil.h"
#include "hal_stdc_target.h"

/* The fleet's state chunks: a DATAGRAM frame of one must fit an Ethernet frame (1,500 bytes of
   payload; the board's MTU is that of a UDP datagram in one, the link's framing is on top). Every
   member of the fleet uses the same (its host robots: --chunk-bytes). */
#define ROBOT_CHUNK_BYTES (HAL_HIL_DATAGRAM_FITS(1500u) - GP_PSE_CHUNK_HEADER_ROOM)
_Static_assert(ROBOT_CHUNK_BYTES >= GP_PSE_MIN_CHUNK_BYTES && ROBOT_CHUNK_BYTES <= GP_PSE_MAX_CHUNK_BYTES,
               "the link's chunks must be ones the protocol takes");

typedef struct robot_opts {
    const char *connect, *tour, *out;
    uint32_t robot, fleet, fleet_id, rounds, post_rounds, seed, online, ckpt_every, timeout_ms, tries;
    double radius_m, peer_timeout_s, join_timeout_s, resend_ms, time_s;
} robot_opts_t;

static void usage(FILE *to)
{
    fprintf(to,
            "usage: board_robot --connect WHERE --tour ROBOT.csv [options]\n"
            "The robot's firmware image (RT, GP and AI cores) on this board, against the world and the\n"
            "fleet `host_sim hil --fleet-lcm URL` serves: it drives ROBOT.csv, trains its DiNNO node and\n"
            "takes part in the fleet's rounds as `host_sim run --fleet N --id I` does, writes\n"
            "OUT/final.bnn, then prints `result <key> <value>` lines. Exit 0 when every round was done\n"
            "and final.bnn written, 1 otherwise (the link down among them), 2 on bad options.\n\n"
            "  --connect WHERE      the link: eth0 (Ethernet) or uart0..uart3 (serial)\n"
            "  --tour ROBOT.csv     the robot's waypoints (those host_sim hil was given)\n"
            "  --out DIR            where checkpoints go (default: the current directory)\n"
            "  --robot I            the robot's id in the fleet (default 0)\n"
            "  --fleet N            robots in the fleet, 1 .. %u (default 1: alone)\n"
            "  --fleet-id F         the fleet's id, as its host robots' --fleet-id (default 0)\n"
            "  --rounds C           DiNNO rounds (default 8)\n"
            "  --post-rounds K      then the fleet posterior's rounds (default 3; 0 alone)\n"
            "  --online 0|1         1: rounds while driving; 0: after the tour (default 0)\n"
            "  --seed S             the run seed, as the host robots' (default 1)\n"
            "  --radius M           neighbours within M metres (default 6)\n"
            "  --peer-timeout S     a silent peer leaves the round after S s (default 10)\n"
            "  --join-timeout S     the same before it was ever heard (default 120)\n"
            "  --resend-ms MS       ask again for missing chunks after MS ms (default 50)\n"
            "  --ckpt-every N       round checkpoints every N rounds (default 0: final.bnn only)\n"
            "  --time S             stop after S seconds of the board's time (default 3600)\n"
            "  --timeout-ms MS      wait for the world's answer to a TICK (default 200)\n"
            "  --tries N            TICKs sent before an exchange fails (default 5); the link is\n"
            "                       down, and the program ends, after %u failed in a row\n\n"
            "This board (%s): pool of %u samples, state chunks of %u bytes; give its host peers\n"
            "--pool-samples %u --chunk-bytes %u to train what this board trains.\n",
            (unsigned)GP_PSE_MAX_FLEET, (unsigned)HAL_STDC_HIL_DOWN_AFTER, BOARD_NAME, (unsigned)AI_POOL_CAPACITY,
            (unsigned)ROBOT_CHUNK_BYTES, (unsigned)AI_POOL_CAPACITY, (unsigned)ROBOT_CHUNK_BYTES);
}

static int parse_opts(int argc, char **argv, robot_opts_t *o)
{
    *o = (robot_opts_t){.out = "", .fleet = 1, .rounds = 8, .post_rounds = 3, .seed = 1, .timeout_ms = 200,
                        .tries = 5, .radius_m = 6.0, .peer_timeout_s = 10.0, .join_timeout_s = 120.0,
                        .resend_ms = 50.0, .time_s = 3600.0};
    for (int i = 1; i < argc; i += 2) { /* every option takes a value (--help ends here) */
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        int r = 0;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            exit(0);
        } else if (strcmp(a, "--connect") == 0 && v != NULL) {
            o->connect = v;
        } else if (strcmp(a, "--tour") == 0 && v != NULL) {
            o->tour = v;
        } else if (strcmp(a, "--out") == 0 && v != NULL) {
            o->out = v;
            r = strlen(v) < HAL_STDC_DIR_MAX ? 0 : -EINVAL;
        } else if (strcmp(a, "--robot") == 0) {
            r = board_parse_u32(v, 0, GP_PSE_MAX_FLEET - 1u, &o->robot);
        } else if (strcmp(a, "--fleet") == 0) {
            r = board_parse_u32(v, 1, GP_PSE_MAX_FLEET, &o->fleet);
        } else if (strcmp(a, "--fleet-id") == 0) {
            r = board_parse_u32(v, 0, UINT32_MAX, &o->fleet_id);
        } else if (strcmp(a, "--rounds") == 0) {
            r = board_parse_u32(v, 1, AI_CORE_MAX_ROUNDS, &o->rounds);
        } else if (strcmp(a, "--post-rounds") == 0) {
            r = board_parse_u32(v, 0, AI_CORE_MAX_POST_ROUNDS, &o->post_rounds);
        } else if (strcmp(a, "--online") == 0) {
            r = board_parse_u32(v, 0, 1, &o->online);
        } else if (strcmp(a, "--seed") == 0) {
            r = board_parse_u32(v, 0, UINT32_MAX, &o->seed);
        } else if (strcmp(a, "--ckpt-every") == 0) {
            r = board_parse_u32(v, 0, AI_CORE_MAX_ROUNDS, &o->ckpt_every);
        } else if (strcmp(a, "--timeout-ms") == 0) {
            r = board_parse_u32(v, 1, 60000, &o->timeout_ms);
        } else if (strcmp(a, "--tries") == 0) {
            r = board_parse_u32(v, 1, 1000, &o->tries);
        } else if (strcmp(a, "--radius") == 0) {
            r = board_parse_double(v, -1.0, 1e6, &o->radius_m);
        } else if (strcmp(a, "--peer-timeout") == 0) {
            r = board_parse_double(v, 0.2, 4000.0, &o->peer_timeout_s);
        } else if (strcmp(a, "--join-timeout") == 0) {
            r = board_parse_double(v, 0.2, 4000.0, &o->join_timeout_s);
        } else if (strcmp(a, "--resend-ms") == 0) {
            r = board_parse_double(v, 1.0, 60000.0, &o->resend_ms);
        } else if (strcmp(a, "--time") == 0) {
            r = board_parse_double(v, 1.0, 1e6, &o->time_s);
        } else {
            return board_bad_option("board_robot", a, v, 0);
        }
        if (r != 0)
            return board_bad_option("board_robot", a, v, 1);
    }
    if (o->connect == NULL || o->tour == NULL) {
        fprintf(stderr, "board_robot: --connect and --tour are required (see --help)\n");
        return -EINVAL;
    }
    if (o->robot >= o->fleet) {
        fprintf(stderr, "board_robot: --robot %u is not a member of a fleet of %u\n", (unsigned)o->robot,
                (unsigned)o->fleet);
        return -EINVAL;
    }
    if (o->peer_timeout_s * 1e3 <= 2.0 * o->resend_ms || o->join_timeout_s < o->peer_timeout_s) {
        fprintf(stderr, "board_robot: need --peer-timeout above two --resend-ms and --join-timeout >= "
                        "--peer-timeout\n");
        return -EINVAL;
    }
    return 0;
}

static double mean_us(const hal_stdc_timing_t *t)
{
    return t->count > 0 ? (double)t->sum_ns * 1e-3 / (double)t->count : 0.0;
}

/* The program's static storage (nothing is allocated): the link, its network's rings. */
static rt_waypoint_t wps[RT_CORE_MAX_WAYPOINTS];
static hal_hil_client_t client;
static hal_stdc_hil_net_t net;

/* The configuration of `host_sim run` for the same robot (its defaults, these options). */
static int configure(const robot_opts_t *o, int n_wps, fw_robot_cfg_t *fc)
{
    const hal_hil_world_t *w = &client.world;
    *fc = fw_robot_default_cfg();
    fc->rt.waypoints = wps;
    fc->rt.n_waypoints = n_wps;
    fc->rt.samples.min_x = w->min_x;
    fc->rt.samples.min_y = w->min_y;
    fc->rt.samples.max_x = w->max_x;
    fc->rt.samples.max_y = w->max_y;
    fc->ai.rounds = o->rounds;
    fc->ai.rounds_per_boundary = 1;
    fc->ai.offline = !o->online;
    fc->ai.policy = AI_POOL_CDR;
    fc->ai.dinno = dinno_default_cfg();
    ai_core_seeds(o->seed, o->robot, &fc->ai.model_seed, &fc->ai.seed);
    fc->ai.node_id = o->robot;
    fc->gp.robot_id = o->robot;
    fc->gp.ckpt_every = o->ckpt_every;
    if (o->fleet < 2)
        return 0;
    gp_fleet_cfg_t f = gp_fleet_default_cfg();
    f.fleet_id = o->fleet_id;
    f.self = o->robot;
    f.n_peers = o->fleet;
    f.rounds = o->rounds;
    f.radius_m = o->radius_m;
    f.encoding = DINNO_CODEC_FP32;
    f.chunk_bytes = ROBOT_CHUNK_BYTES;
    f.incarnation = 1;
    f.peer_timeout_us = (uint32_t)llround(o->peer_timeout_s * 1e6);
    f.join_timeout_us = (uint32_t)llround(o->join_timeout_s * 1e6);
    f.resend_after_us = (uint32_t)llround(o->resend_ms * 1e3);
    f.positions_from_tour = !o->online;
    f.post_rounds = o->post_rounds;
    f.tour = wps;
    f.n_tour = n_wps;
    return fw_robot_join_fleet(fc, &f);
}

static void print_round(const ai_round_info_t *r, uint32_t total)
{
    if (isnan(r->loss_train)) { /* a posterior round: no training, the fleet's posterior summed */
        printf("board_robot: round %u/%u  posterior  neighbours %u  t=%.1f s%s\n", (unsigned)r->round + 1u,
               (unsigned)total, (unsigned)r->neighbours, (double)r->stamp_us * 1e-6,
               r->ckpt_status != 0 ? "  (checkpoint not written)" : "");
        fflush(stdout);
        return;
    }
    printf("board_robot: round %u/%u  loss %.6f  bce %.6f  kl %.2f  neighbours %u  pool %u  t=%.1f s%s\n",
           (unsigned)r->round + 1u, (unsigned)total, (double)r->loss_train, (double)r->bce, (double)r->kl,
           (unsigned)r->neighbours, (unsigned)r->pool_fill, (double)r->stamp_us * 1e-6,
           r->ckpt_status != 0 ? "  (checkpoint not written)" : "");
    fflush(stdout);
}

static void print_results(const robot_opts_t *o, int done)
{
    const rt_core_t *rt = fw_robot_rt();
    const ai_core_t *ai = fw_robot_ai();
    gp_core_t *gp = fw_robot_gp();
    hal_stdc_hil_stats_t hs;
    hal_stdc_hil_stats(&hs);
    hal_net_stats_t ns;
    if (hal_net_get_stats(&ns) != 0)
        memset(&ns, 0, sizeof ns);
    printf("result completed %d\n", done);
    printf("result rounds_done %u\n", (unsigned)ai->next_round);
    printf("result final_ckpt_status %d\n", (int)gp->final_ckpt_status);
    printf("result board_time_s %.3f\n", (double)hal_stdc_target_now_us() * 1e-6);
    printf("result rt_ticks %llu\n", (unsigned long long)rt->stats.ticks);
    /* a deadline missed: a period without its TICK, or a command after the next release */
    printf("result rt_deadline_misses %llu\n", (unsigned long long)hs.tick_gaps);
    printf("result rt_late_ticks %llu\n", (unsigned long long)rt->stats.clock_mismatch); /* not run at release */
    printf("result sense_to_command_mean_us %.2f\n", mean_us(&hs.response));
    printf("result sense_to_command_max_us %.2f\n", (double)hs.response.max_ns * 1e-3);
    printf("result release_to_command_mean_us %.2f\n", mean_us(&hs.release));
    printf("result release_to_command_max_us %.2f\n", (double)hs.release.max_ns * 1e-3);
    printf("result link_round_trip_mean_us %.1f\n", mean_us(&hs.exchange));
    printf("result link_errors %llu\n", (unsigned long long)hs.link_errors);
    printf("result link_down %d\n", hs.link_down);
    printf("result link_datagrams_in %llu\n", (unsigned long long)client.stats.datagrams_in);
    printf("result link_datagrams_out %llu\n", (unsigned long long)client.stats.datagrams_out);
    printf("result tour_finished %u\n", (unsigned)rt->status.finished);
    printf("result distance_m %.3f\n", (double)rt->status.distance_m);
    printf("result scans %u\n", (unsigned)rt->status.scans);
    printf("result ring_drops %u\n", (unsigned)rt->status.ring_drops);
    printf("result pool_fill %u\n", (unsigned)ai->pool.fill);
    printf("result pool_offered %llu\n", (unsigned long long)ai->pool.offered);
    printf("result net_tx %llu\n", (unsigned long long)ns.tx_messages);
    printf("result net_tx_rejected %llu\n", (unsigned long long)ns.tx_rejected);
    printf("result net_rx %llu\n", (unsigned long long)ns.rx_messages);
    printf("result net_rx_dropped %llu\n", (unsigned long long)(ns.rx_dropped_full + ns.rx_dropped_small));
    if (o->fleet > 1) {
        const gp_fleet_t *f = fw_robot_fleet();
        const gp_pse_stats_t *p = &f->drv.pse.stats;
        printf("result states_missed %llu\n", (unsigned long long)p->states_missed);
        printf("result peer_timeouts %llu\n", (unsigned long long)p->timeouts);
        printf("result chunks_resent %llu\n", (unsigned long long)p->chunks_resent);
        printf("result chunks_requested %llu\n", (unsigned long long)p->chunks_requested);
    }
    for (int id = 0; id < HAL_CORE_COUNT; id++) {
        size_t used = 0, size = 0;
        if (hal_core_stack_high_water((hal_core_id_t)id, &used, &size) == 0)
            printf("result stack_%s_bytes %lu of %lu\n", hal_core_name((hal_core_id_t)id), (unsigned long)used,
                   (unsigned long)size);
    }
}

int main(int argc, char **argv)
{
    robot_opts_t o;
    if (parse_opts(argc, argv, &o) != 0)
        return 2;
    int n_wps;
    hal_hil_port_t port;
    const int c = board_start_world("board_robot", o.tour, o.connect, o.robot, o.timeout_ms, o.tries, wps, &n_wps, &client,
                                    &port);
    if (c != 0)
        return c;
    const hal_hil_world_t *w = &client.world;
    printf("board_robot: board %s, robot %u of %u, world on %s %s: plan box (%.2f, %.2f)-(%.2f, %.2f) m\n",
           BOARD_NAME, (unsigned)o.robot, (unsigned)o.fleet, hal_stdc_hil_kind(), o.connect, (double)w->min_x,
           (double)w->min_y, (double)w->max_x, (double)w->max_y);
    int r = hal_stdc_install_hil(o.out, &client, 1, o.fleet > 1 ? &net : NULL);
    if (r != 0) {
        fprintf(stderr, "board_robot: cannot install the board (%d)\n", r);
        return 1;
    }
    fw_robot_cfg_t fc;
    if ((r = configure(&o, n_wps, &fc)) != 0) {
        fprintf(stderr, "board_robot: the fleet refused its configuration (%d)\n", r);
        return 1;
    }
    if ((r = fw_robot_start(&fc)) != 0) {
        fprintf(stderr, "board_robot: the firmware did not start (%d)%s\n", r,
                r == -ENOTSUP ? ": this board has no cores" : "");
        return 1;
    }
    /* Below the cores: it runs when they all wait. */
    gp_core_t *gp = fw_robot_gp();
    const uint32_t total = o.rounds + (o.fleet > 1 ? o.post_rounds : 0u);
    const uint64_t end = hal_stdc_target_now_us() + (uint64_t)(o.time_s * 1e6);
    uint32_t seen = 0;
    int done = 0, down = 0;
    while (!done && !down && hal_stdc_target_now_us() < end) {
        hal_stdc_target_sleep_until(hal_stdc_target_now_us() + 500000u);
        for (const ai_round_info_t *ri; (ri = gp_core_round(gp, seen)) != NULL; seen++)
            print_round(ri, total);
        done = gp_core_done(gp);
        hal_stdc_hil_stats_t hs;
        hal_stdc_hil_stats(&hs);
        down = hs.link_down;
    }
    if (down)
        fprintf(stderr, "board_robot: the world on %s %s stopped answering (%u exchanges of %u TICKs in a row, "
                        "%u ms each): the link is down, stopped after %u of %u rounds\n",
                hal_stdc_hil_kind(), o.connect, (unsigned)HAL_STDC_HIL_DOWN_AFTER, (unsigned)o.tries,
                (unsigned)o.timeout_ms, (unsigned)seen, (unsigned)total);
    else if (!done)
        printf("board_robot: stopped by --time %.0f s after %u of %u rounds\n", o.time_s, (unsigned)seen,
               (unsigned)total);
    print_results(&o, done);
    fflush(stdout);
    return done && gp->final_ckpt_status == 0 ? 0 : 1;
}
