/* host_sim run's options (cmd_run_opts.h). */
#include "cmd_run_opts.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ai/ai_core.h"
#include "ai/bnn.h"
#include "cli.h"
#include "cli_opts.h"
#include "gp/gp_core.h"
#include "gp/gp_pse.h"
#include "sim_defaults.h"
#include "sim_explore.h"
#include "sim_plan.h"

void run_defaults(run_opts_t *o)
{
    memset(o, 0, sizeof *o);
    o->d = dinno_default_cfg();
    o->rounds = SIM_DEF_RUN_ROUNDS;
    o->per_comm = 1;
    o->seed = SIM_DEF_SEED;
    o->fleet = 1;
    o->post_rounds = SIM_DEF_POST_ROUNDS;
    o->time_limit = SIM_DEF_TIME_LIMIT_S;
    o->val_poses = SIM_DEF_VAL_POSES;
    o->mc = SIM_DEF_MC;
    o->map_res = SIM_DEF_MAP_RES_M;
    o->scale = SIM_PLAN_DEFAULT_SCALE;
    o->radius = SIM_DEF_RADIUS_M;
    o->peer_timeout = GP_FLEET_PEER_TIMEOUT_US_DEFAULT / 1e6;
    o->resend_ms = GP_FLEET_RESEND_AFTER_US_DEFAULT / 1e3;
    o->join_timeout = GP_FLEET_JOIN_TIMEOUT_US_DEFAULT / 1e6;
    o->chunk_bytes = GP_FLEET_CHUNK_BYTES_DEFAULT;
    o->net = "memq://";
    o->pool = AI_POOL_CDR;
    o->sched = HAL_HOST_SCHED_SERIAL;
    o->encoding = GP_FLEET_ENCODING_DEFAULT;
    o->ckpt_keep = GP_CORE_CKPT_KEEP_DEFAULT;
    o->ckpt_keep_every = GP_CORE_CKPT_KEEP_EVERY_DEFAULT;
    o->explore_policy = GP_EXPLORE_UNCERTAINTY;
    o->explore_time = SIM_EXPLORE_BUDGET_S_DEFAULT;
}

/* --net-faults SPEC: checked now, applied when the network opens. */
static int parse_net_faults(const char *cmd, const char *opt, const char *v, void *field, void *opts)
{
    (void)opts;
    hal_host_netfault_cfg_t fc;
    char why[200];
    if (hal_host_netfault_parse(v, &fc, why, sizeof why) != 0) {
        fprintf(stderr, "host_sim %s: %s: %s\n", cmd, opt, why);
        return -1;
    }
    memcpy(field, &v, sizeof v);
    return 0;
}

static const cli_opt_t run_opts[] = {
    {.names = "--plan", .meta = "FILE.svg", CLI_STRING(run_opts_t, plan), .required = 1, .help = "the floor plan"},
    {.names = "--path", .meta = "FILE.csv", CLI_STRING(run_opts_t, path), .help = "the robot's tour (not with --explore)"},
    {.names = "--explore", CLI_FLAG(run_opts_t, explore, 1),
     .help = "no tour: the robot starts in a room of its own (as `paths gen` places it) and chooses its goals itself "
             "(docs/exploration.md); the rounds are cut by simulated time over --explore-time"},
    {.names = "--explore-policy", CLI_CHOICE(run_opts_t, explore_policy, "uncertainty|frontier|coordinated"),
     .values = (const int[]){GP_EXPLORE_UNCERTAINTY, GP_EXPLORE_FRONTIER, GP_EXPLORE_COORDINATED},
     .help = "explore: goals where the model's epistemic uncertainty is, or at the nearest frontier of the robot's own "
             "scans, or at frontiers coordinated by claims"},
    {.names = "--explore-time", .meta = "S", CLI_DOUBLE(run_opts_t, explore_time, 1.0, 1e6),
     .help = "explore: simulated seconds of exploration"},
    {.names = "--explore-own-posterior", CLI_FLAG(run_opts_t, explore_own_posterior, 1),
     .help = "explore in a fleet: each robot's belief from its own data alone (the ablation); by default every other "
             "round shares the epistemic posterior, so the belief is the fleet's (needs --encoding fp32)"},
    {.names = "--explore-no-fence", CLI_FLAG(run_opts_t, explore_no_fence, 1),
     .help = "explore: no keep-in fence (the ablation); by default the robot plans only inside the building's "
             "outline, its site's geofence, so that it does not explore the yards beyond the entrance"},
    {.names = "--explore-posterior-first", CLI_FLAG(run_opts_t, explore_posterior_first, 1),
     .help = "explore (uncertainty): goals from the posterior alone while it has any, then from where the rays went "
             "(the ablation); by default the belief is the larger of the posterior's share and the counts' of where "
             "the rays went from the start (the posterior's features are global: alone it calls rooms no ray entered "
             "known)"},
    {.names = "--out", .meta = "DIR", CLI_STRING(run_opts_t, out), .required = 1, .help = "output folder"},
    {.names = "--online", CLI_FLAG(run_opts_t, offline, 0), CLI_GIVEN(run_opts_t, online_given),
     .help = "rounds at distance boundaries (default)"},
    {.names = "--offline", CLI_FLAG(run_opts_t, offline, 1), CLI_GIVEN(run_opts_t, offline_given),
     .help = "the whole tour first, then every round (not with --online)"},
    {.names = "--resume", CLI_FLAG(run_opts_t, resume, 1),
     .help = "offline: continue from the last complete round_NNNN.bnn in DIR (invalid ones skipped), keeping the "
             "stopped run's rows of metrics.csv and traffic.csv; the tour is driven again (same samples), duals "
             "and Adam moments restart at 0"},
    {.names = "--rounds", .meta = "N", CLI_INT(run_opts_t, rounds, 1, AI_CORE_MAX_ROUNDS), .help = "DiNNO rounds in all"},
    {.names = "--rounds-per-comm", .meta = "R", CLI_INT(run_opts_t, per_comm, 1, AI_CORE_MAX_ROUNDS),
     .help = "online: DiNNO rounds per communication round (divides N)"},
    {.names = "--pool", CLI_CHOICE(run_opts_t, pool, "cdr|dr"), .values = (const int[]){AI_POOL_CDR, AI_POOL_DR},
     .help = "online: cumulative data retention or data refresh per round"},
    {.names = "--pool-samples", .meta = "N", CLI_INT(run_opts_t, pool_samples, 1, AI_POOL_CAPACITY),
     .help = "the pool keeps N samples at most instead of this build's capacity: a board's (board_robot "
             "--help prints it), so this robot keeps what that board keeps"},
    {.names = "--seed", .meta = "S", CLI_INT(run_opts_t, seed, 0, INT64_MAX),
     .help = "run seed: noise, weights, minibatches, reservoir"},
    {.names = "--strategy", CLI_CHOICE(run_opts_t, d.strategy, "kl|separate|uniform"),
     .values = (const int[]){DINNO_KL, DINNO_SEPARATE, DINNO_UNIFORM}, .help = "DiNNO regulariser"},
    {CLI_INCLUDE(run_opts_t, d, cmd_dinno_opts)},
    {.names = "--train-between", CLI_FLAG(run_opts_t, train_between, 1),
     .help = "one more optimiser step per AI tick between boundaries"},
    {.names = "--time-limit", .meta = "S", CLI_DOUBLE(run_opts_t, time_limit, 0.1, 1e6),
     .help = "simulated seconds before giving up"},
    {.names = "--robot|--id", .meta = "I", CLI_INT(run_opts_t, robot, 0, 1000000), CLI_GIVEN(run_opts_t, robot_given),
     .help = "robot index: noise streams, seeds, telemetry, fleet member id"},
    {.names = "--fleet", .meta = "N", CLI_INT(run_opts_t, fleet, 1, GP_PSE_MAX_FLEET), CLI_GIVEN(run_opts_t, fleet_given),
     .help = "fleet size (1: alone); needs the network"},
    {.names = "--fleet-id", .meta = "F", CLI_INT(run_opts_t, fleet_id, 0, 1000000),
     .help = "fleet number: its LCM channels fleetsim/F/..."},
    {.names = "--transport", CLI_CHOICE(run_opts_t, transport, "lcm|zmq|shm"),
     .values = (const int[]){RUN_TRANSPORT_LCM, RUN_TRANSPORT_ZMQ, RUN_TRANSPORT_SHM},
     .help = "the fleet's transport: LCM (UDP multicast), ZeroMQ over TCP, peer to peer, or shared memory between "
             "the processes of one host (the segment /dev/shm/fleetsim.fleet-F of --fleet-id F)"},
    {.names = "--peers", .meta = "H:P,...", CLI_STRING(run_opts_t, peers),
     .help = "zmq: every member's HOST:PORT in id order, this robot's own included (it binds *:PORT of its "
             "entry and connects to the others)"},
    {.names = "--zmq-proxy", .meta = "H:P", CLI_STRING(run_opts_t, zmq_proxy),
     .help = "zmq: through the proxy at HOST:PORT (host_sim zmq-proxy) instead of --peers' full mesh: two TCP "
             "connections per robot instead of 2 (N - 1); for fleets of hundreds"},
    {.names = "--lcm-url", .meta = "URL", CLI_STRING(run_opts_t, net), CLI_GIVEN(run_opts_t, net_given),
     .def = HAL_HOST_NET_URL_DEFAULT, .help = "LCM URL"},
    {.names = "--lcm-groups", CLI_FLAG(run_opts_t, lcm_groups, 1),
     .help = "lcm: each robot's state chunks on a multicast group and port of its own (the URL's + 1 + its id), "
             "and what is for one robot (requests for its chunks, chunks it asked for) on its inbox group (+ 1025 + "
             "its id); a robot joins its neighbours' groups and its inbox only, so the others' states never reach "
             "it; every member alike"},
    {.names = "--lcm-addressed", CLI_FLAG(run_opts_t, lcm_addressed, 1),
     .help = "lcm: what is for one robot (requests for its chunks, chunks it asked for) on its own channels on the "
             "URL's group, which the others' kernels drop (a filter on their sockets, Linux), and no state taken "
             "from a peer before it is placed; every member alike (--lcm-groups implies it)"},
    {.names = "--net", .meta = "URL", CLI_STRING(run_opts_t, net), CLI_GIVEN(run_opts_t, net_given),
     .help = "the same (alone: default memq://, in-process; 'none' for no network)", .def = ""},
    {.names = "--radius", .meta = "M", CLI_DOUBLE(run_opts_t, radius, 0.0, 1e6),
     .help = "fleet: neighbours within M metres (0: every peer)"},
    {.names = "--post-rounds", .meta = "K", CLI_INT(run_opts_t, post_rounds, 0, AI_CORE_MAX_POST_ROUNDS),
     .help = "fleet: after the last round, K rounds in which the robots' epistemic posteriors reach the fleet's "
             "by average consensus over every peer (docs/uncertainty.md); 0: each keeps its own; fp32 states only"},
    {.names = "--encoding", CLI_CHOICE(run_opts_t, encoding, "fp32|int8|int8-ef|int4-ef"),
     .values = (const int[]){DINNO_CODEC_FP32, DINNO_CODEC_INT8, DINNO_CODEC_INT8_EF, DINNO_CODEC_INT4_EF},
     .help = "fleet: states as fp32, int8 with per-row scales, or compressed with error feedback (the difference "
             "against the sender's public copy, int8 or 4-bit with per-row scales; ai/dinno_codec.h)"},
    {.names = "--peer-timeout", .meta = "S", CLI_DOUBLE(run_opts_t, peer_timeout, 0.1, 3600.0),
     .help = "fleet: a peer silent S seconds leaves the round"},
    {.names = "--join-timeout", .meta = "S", CLI_DOUBLE(run_opts_t, join_timeout, 0.1, 3600.0),
     .help = "fleet: the same for a peer never heard yet"},
    {.names = "--resend-ms", .meta = "MS", CLI_DOUBLE(run_opts_t, resend_ms, 1.0, 60000.0),
     .help = "fleet: ask again for missing chunks after MS without progress (every live robot speaks at least "
             "this often); more on a host with many more robots than cores, where a robot waits its turn"},
    {.names = "--chunk-bytes", .meta = "B", CLI_INT(run_opts_t, chunk_bytes, GP_PSE_MIN_CHUNK_BYTES, GP_PSE_MAX_CHUNK_BYTES),
     .def = "the most, 60 KB or less on a small MTU", .help = "fleet: state bytes per datagram"},
    {.names = "--key-file", .meta = "F", CLI_STRING(run_opts_t, key_file),
     .help = "fleet: a keyed fleet (F from `host_sim key new`, mode 0600): every datagram carries an "
             "XChaCha20-Poly1305 tag under the key; others are dropped and counted"},
    {.names = "--run-id", .meta = "X", CLI_HEX64(run_opts_t, run_id), CLI_GIVEN(run_opts_t, run_id_given),
     .help = "keyed fleet: this launch's id, 1-16 hex digits, the same for every member (tools/fleet draws one per "
             "run): recordings of other runs are refused"},
    {.names = "--net-faults", .meta = "SPEC", CLI_CUSTOM(run_opts_t, net_faults, parse_net_faults),
     .help = "inject faults into what this robot receives, comma-separated: drop=P, dup=P, reorder=P "
             "(probabilities; a reordered one is held at most hold_ms=H, default 20), delay_ms=D (uniform 0..D), seed=S (default: the run seed; each robot mixes in its "
             "id), partition=A/B (robot ids '.'-separated, e.g. 0.1/2.3) with from=T1, until=T2 (seconds since the "
             "network opened); counted in summary.txt"},
    {.names = "--sched", CLI_CHOICE(run_opts_t, sched, "serial|parallel"),
     .values = (const int[]){HAL_HOST_SCHED_SERIAL, HAL_HOST_SCHED_PARALLEL},
     .help = "lockstep release order (serial: bit-reproducible)"},
    {.names = "--val-poses", .meta = "N", CLI_INT(run_opts_t, val_poses, 0, 100000),
     .help = "validation poses x 500 points (0: no validation)"},
    {.names = "--val-every", .meta = "M", CLI_INT(run_opts_t, val_every, 1, AI_CORE_MAX_ROUNDS),
     .def = "1 alone, rounds/" SIM_DEF_STR(SIM_DEF_FLEET_VAL_CHECKS) " in a fleet",
     .help = "validation loss (and a round checkpoint) every M rounds and at the end"},
    {.names = "--keep-ckpt", .meta = "K", CLI_INT(run_opts_t, ckpt_keep, 0, AI_CORE_MAX_ROUNDS),
     .help = "round checkpoints kept: the newest K (0: every one written)"},
    {.names = "--keep-ckpt-every", .meta = "M", CLI_INT(run_opts_t, ckpt_keep_every, 0, AI_CORE_MAX_ROUNDS),
     .help = "and, of the older ones, round k when (k + 1) % M == 0 (0: none)"},
    {.names = "--map-res", .meta = "M", CLI_DOUBLE(run_opts_t, map_res, 0.01, 10.0), .help = "map grid in metres"},
    {.names = "--mc", .meta = "K", CLI_INT(run_opts_t, mc, 1, 1000), .help = "MC passes of the maps"},
    {.names = "--no-maps", CLI_FLAG(run_opts_t, no_maps, 1), .help = "skip the PNG maps"},
    {.names = "--quiet", CLI_FLAG(run_opts_t, quiet, 1), .help = "firmware log at WARN (default INFO: a line per round)"},
    {.names = "--scale", .meta = "S", CLI_DOUBLE(run_opts_t, scale, 1e-6, 100.0), .help = "plan metres per pixel"},
    CLI_OPT_END,
};

static void run_usage(FILE *out)
{
    fprintf(out,
            "usage: host_sim run --plan FILE.svg --path FILE.csv --out DIR [options]\n"
            "       host_sim run --plan FILE.svg --explore [--explore-policy P] --out DIR [options]\n"
            "       host_sim run ... --fleet N --id I [--fleet-id F] [--transport lcm] [--lcm-url URL]\n"
            "       host_sim run ... --fleet N --id I --transport zmq --peers HOST:PORT,HOST:PORT,...\n"
            "       host_sim run ... --fleet N --id I --transport zmq --zmq-proxy HOST:PORT\n"
            "       host_sim run ... --fleet N --id I [--fleet-id F] --transport shm\n"
            "\n"
            "Runs ONE robot's firmware image in this process: the RT core (50 Hz control, 10 Hz scans\n"
            "-> samples -> ring), the AI core (sample pool, BNN preset '%s', DiNNO node update) and the\n"
            "GP core (round coordination, telemetry, checkpoints) as three threads on the host HAL, in\n"
            "lockstep with the ODE world.\n"
            "Online (default, paper 6.2): the path is split into C = rounds / R communication rounds of\n"
            "equal length; at each boundary the robot runs R DiNNO rounds of B optimiser steps on its pool.\n"
            "Offline (--offline, paper 6.3): the robot drives its whole tour collecting samples, then runs\n"
            "every round on all of them.\n"
            "Alone (default) every round is local. With --fleet N the robot is member I of a fleet of N\n"
            "processes (started with the same seed and settings, e.g. by tools/fleet) that exchange their\n"
            "states over LCM (UDP multicast) or ZeroMQ (TCP, one PUB per robot, every robot subscribed to\n"
            "every other) every round: Algorithm 1 with chunking, CRC, resend requests,\n"
            "timeouts. Neighbours: within --radius of each other (positions carried in the states;\n"
            "offline: the point at fraction k/rounds of each tour, as `host_sim fleet --inproc`), or all.\n"
            "With the same seed and no loss the fleet's models equal `host_sim fleet --inproc`'s bit for bit.\n"
            "Simulated time stands still while the robot waits for its peers.\n"
            "Under SLURM (srun) the member id and the fleet size come from SLURM_PROCID and SLURM_NTASKS\n"
            "unless --id / --fleet are given.\n"
            "SIGINT or SIGTERM stops the run at the next lockstep instant (also while it waits for its peers):\n"
            "it removes its temporary files, keeps every finished file, and exits 130 or 143. A checkpoint that\n"
            "cannot be written stops the run at once (exit 1). DIR/incarnation counts the starts with this DIR.\n"
            "\n"
            "Writes into DIR: metrics.csv (round,sim_time_s,distance_m,progress_m,pool_fill,pool_capacity,\n"
            "ring_drops,train_loss,bce,val_loss,kl,neighbours,disagreement,wall_s), traffic.csv (fleet: per\n"
            "round wall_ms,wait_ms,bytes_sent,bytes_received,chunks_sent,chunks_received,chunks_resent,\n"
            "chunks_requested,duplicates,stale,timeouts,rejoins,crc_failures,invalid,chunks_recovered,chunks_lost,\n"
            "states_missed,rounds_skipped,beacons_sent,peer_restarts,old_incarnation), round_NNNN.bnn (every\n"
            "--val-every rounds; the newest --keep-ckpt and every --keep-ckpt-every-th kept), final.bnn,\n"
            "train.samples (the pool trained on), valset.samples, map_mean.png and map_std.png (MC mean / std of the final model, path on top), profile.txt and\n"
            "profile.csv (per core: ticks, lateness, wall time per tick, stack high-water; static memory),\n"
            "coverage.csv (sim_time_s,robot_seconds,coverage: the share of the plan's free 0.1 m cells some\n"
            "lidar ray crossed, every simulated second) and coverage.bin (each free cell's first-seen time,\n"
            "for host_sim coverage merge), summary.txt.\n"
            "\n"
            "options:\n",
            BNN_PRESET_NAME);
    run_opts_t d;
    run_defaults(&d);
    cli_opts_help(out, run_opts, &d);
}


/* --peers: N entries HOST:PORT; this robot binds *:PORT of its own and connects to the others.
 * The URL (hal_host_net_zmq.c) into url. */
static int zmq_url(const run_opts_t *o, char *url)
{
    if ((o->peers == NULL) == (o->zmq_proxy == NULL)) {
        fprintf(stderr, "host_sim run: --transport zmq needs either --peers HOST:PORT,... (every member in id order, "
                        "this one's included; tools/fleet --transport zmq makes the list) or --zmq-proxy HOST:PORT\n");
        return -1;
    }
    if (o->zmq_proxy != NULL) { /* the transport checks HOST:PORT */
        const int w = snprintf(url, RUN_NET_URL_MAX, "zmq://?proxy=%s", o->zmq_proxy);
        if (w < 0 || w >= RUN_NET_URL_MAX) {
            fprintf(stderr, "host_sim run: --zmq-proxy is too long\n");
            return -1;
        }
        return 0;
    }
    const char *own = NULL;
    size_t own_len = 0, k = (size_t)snprintf(url, RUN_NET_URL_MAX, "zmq://*:");
    long long n = 0;
    char others[RUN_NET_URL_MAX] = "";
    size_t ko = 0;
    for (const char *p = o->peers;; n++) {
        const size_t len = strcspn(p, ",");
        const char *colon = memchr(p, ':', len);
        if (len == 0 || colon == NULL) {
            fprintf(stderr, "host_sim run: --peers: entry %lld '%.*s' is not HOST:PORT\n", n, (int)len, p);
            return -1;
        }
        if (n == o->robot) {
            own = colon + 1;
            own_len = len - (size_t)(colon + 1 - p);
        } else {
            const int w = snprintf(others + ko, sizeof others - ko, "%s%.*s", ko ? "," : "", (int)len, p);
            if (w < 0 || (size_t)w >= sizeof others - ko) {
                fprintf(stderr, "host_sim run: --peers is too long\n");
                return -1;
            }
            ko += (size_t)w;
        }
        if (p[len] == '\0')
            break;
        p += len + 1;
    }
    if (n + 1 != o->fleet) {
        fprintf(stderr, "host_sim run: --peers names %lld members for a fleet of %lld: one HOST:PORT per member, "
                        "in id order\n", n + 1, o->fleet);
        return -1;
    }
    const int w = snprintf(url + k, RUN_NET_URL_MAX - k, "%.*s?peers=%s", (int)own_len, own, others);
    if (w < 0 || (size_t)w >= RUN_NET_URL_MAX - k) {
        fprintf(stderr, "host_sim run: --peers is too long\n");
        return -1;
    }
    return 0;
}

/* Under srun: SLURM_PROCID and SLURM_NTASKS name the member and the fleet's size, unless the
 * command line does. Their values are checked like the options'. */
static int slurm_member(run_opts_t *o)
{
    const char *id = getenv("SLURM_PROCID"), *ntasks = getenv("SLURM_NTASKS");
    if (id != NULL && !o->robot_given && cmd_parse_ll(id, "SLURM_PROCID", 0, 1000000, &o->robot) != 0)
        return -1;
    if (ntasks != NULL && !o->fleet_given && cmd_parse_ll(ntasks, "SLURM_NTASKS", 1, GP_PSE_MAX_FLEET, &o->fleet) != 0)
        return -1;
    return 0;
}

int run_parse(int argc, char **argv, run_opts_t *o, char *url)
{
    run_defaults(o);
    const cli_parser_t parser = {.cmd = "run", .opts = run_opts, .usage = run_usage};
    const int pr = cli_opts_parse(&parser, argc, argv, o, NULL, NULL);
    if (pr != 0)
        return pr;
    /* Two modes on one command line is a mistake in the command, not a choice: no last-wins. */
    if (o->online_given && o->offline_given) {
        fprintf(stderr, "host_sim run: --online and --offline are two modes: give one of them\n");
        return -1;
    }
    if (o->net_given && strcmp(o->net, "none") == 0)
        o->net = NULL;
    if (o->explore ? o->path != NULL : o->path == NULL) {
        fprintf(stderr, "host_sim run: %s\n", o->explore ? "--explore chooses its own goals: give no --path"
                                                          : "--path FILE.csv (the tour) is needed, or --explore");
        return -1;
    }
    if (o->explore && (o->offline || o->resume)) {
        fprintf(stderr, "host_sim run: --explore learns online: not with --offline or --resume\n");
        return -1;
    }
    if (o->explore_own_posterior && !o->explore) {
        fprintf(stderr, "host_sim run: --explore-own-posterior is an option of --explore\n");
        return -1;
    }
    if (o->explore_no_fence && !o->explore) {
        fprintf(stderr, "host_sim run: --explore-no-fence is an option of --explore\n");
        return -1;
    }
    if (o->explore_posterior_first && (!o->explore || o->explore_policy != GP_EXPLORE_UNCERTAINTY)) {
        fprintf(stderr, "host_sim run: --explore-posterior-first is an option of --explore with --explore-policy uncertainty "
                        "(the only policy that reads the belief)\n");
        return -1;
    }
    if (o->explore && o->time_limit <= o->explore_time) {
        fprintf(stderr, "host_sim run: --time-limit %g must exceed --explore-time %g (the last rounds come after it)\n",
                o->time_limit, o->explore_time);
        return -1;
    }
    if (o->resume && !o->offline) {
        fprintf(stderr, "host_sim run: --resume needs --offline: an online robot's pose and sample pool are not "
                        "in a checkpoint, so it cannot continue where it stopped (start it again without --resume)\n");
        return -1;
    }
    if (o->rounds % o->per_comm != 0) {
        fprintf(stderr, "host_sim run: --rounds-per-comm %lld does not divide --rounds %lld\n", o->per_comm, o->rounds);
        return -1;
    }
    if (slurm_member(o) != 0)
        return -1;
    if (o->fleet > 1) {
        if (o->robot >= o->fleet) {
            fprintf(stderr, "host_sim run: --id %lld is not a member of a fleet of %lld (0 .. %lld)\n", o->robot,
                    o->fleet, o->fleet - 1);
            return -1;
        }
        if (o->transport == RUN_TRANSPORT_ZMQ) {
            if (o->net_given) {
                fprintf(stderr, "host_sim run: --lcm-url / --net are for --transport lcm; zmq takes --peers\n");
                return -1;
            }
            if (zmq_url(o, url) != 0)
                return -1;
            o->net = url;
            o->net_given = 1;
        } else if (o->transport == RUN_TRANSPORT_SHM) {
            if (o->net_given) {
                fprintf(stderr, "host_sim run: --lcm-url / --net are for --transport lcm; shm names its segment "
                                "after --fleet-id\n");
                return -1;
            }
            snprintf(url, RUN_NET_URL_MAX, "shm://fleet-%lld", o->fleet_id);
            o->net = url;
            o->net_given = 1;
        }
        if (!o->net_given)
            o->net = ""; /* the default LCM URL: UDP multicast on this host */
        if (o->net == NULL || strncmp(o->net, "memq", 4) == 0) {
            fprintf(stderr, "host_sim run: a fleet needs a network between processes: --lcm-url udpm://... "
                            "(not 'none' or memq://)\n");
            return -1;
        }
        if (o->join_timeout < o->peer_timeout)
            o->join_timeout = o->peer_timeout;
        if (o->peer_timeout * 1e3 <= 2.0 * o->resend_ms) {
            fprintf(stderr, "host_sim run: --peer-timeout %g s must exceed twice --resend-ms %g: a live robot "
                            "speaks once per resend period\n", o->peer_timeout, o->resend_ms);
            return -1;
        }
    }
    if ((o->transport != RUN_TRANSPORT_LCM || o->peers != NULL || o->zmq_proxy != NULL) && o->fleet < 2) {
        fprintf(stderr, "host_sim run: --transport zmq or shm, --peers and --zmq-proxy are for a fleet (--fleet N, "
                        "N >= 2)\n");
        return -1;
    }
    if (o->lcm_groups && (o->fleet < 2 || o->transport != RUN_TRANSPORT_LCM ||
                          (o->net[0] != '\0' && strncmp(o->net, "udpm://", 7) != 0))) {
        fprintf(stderr, "host_sim run: --lcm-groups is for a fleet over LCM multicast (--fleet N, --lcm-url udpm://...)\n");
        return -1;
    }
    if (o->lcm_addressed && (o->fleet < 2 || o->transport != RUN_TRANSPORT_LCM)) {
        fprintf(stderr, "host_sim run: --lcm-addressed is for a fleet over LCM (--fleet N; ZeroMQ is addressed)\n");
        return -1;
    }
    if ((o->peers != NULL || o->zmq_proxy != NULL) && o->transport != RUN_TRANSPORT_ZMQ) {
        fprintf(stderr, "host_sim run: --peers and --zmq-proxy are for --transport zmq (LCM finds its peers by "
                        "multicast)\n");
        return -1;
    }
    if (o->key_file != NULL && o->fleet < 2) {
        fprintf(stderr, "host_sim run: --key-file is for a fleet (--fleet N, N >= 2): a robot alone sends nothing\n");
        return -1;
    }
    if ((o->key_file != NULL) != o->run_id_given) {
        fprintf(stderr, "host_sim run: %s\n", o->key_file != NULL
                ? "--key-file needs --run-id X, the same for every member of this launch (tools/fleet draws one): "
                  "without it a recording of an earlier run with the same key would be accepted"
                : "--run-id is for a keyed fleet: give --key-file too");
        return -1;
    }
    if (o->net_faults != NULL && o->net_faults[0] != '\0' && o->net == NULL) {
        fprintf(stderr, "host_sim run: --net-faults needs a network (not --net none)\n");
        return -1;
    }
    if (o->val_every == 0)
        o->val_every = o->fleet > 1 && o->rounds >= SIM_DEF_FLEET_VAL_CHECKS ? o->rounds / SIM_DEF_FLEET_VAL_CHECKS : 1;
    return 0;
}

