/* host_sim defaults: every default the launchers need, as key=value lines, read from where
 * the programs take them (host_sim run's option defaults, sim_defaults.h, gp_fleet.h,
 * dinno_default_cfg), so that tools/fleet and tools/run-fleet.sh restate none of them. */
#include <stdio.h>
#include <stdlib.h>

#include "ai/ai_core.h"
#include "ai/ai_pool.h"
#include "ai/bnn.h"
#include "ai/dinno.h"
#include "cli_opts.h"
#include "cmd_run_opts.h"
#include "commands.h"
#include "gp/gp_fleet.h"
#include "gp/gp_pse.h"
#include "hal_host.h"
#include "sim_defaults.h"
#include "sim_paths.h"

/* The key list with what each means, for --help; defaults_print prints them in this order. */
static const char *const keys_help =
    "  seed              run seed (host_sim run, maps, the launchers; fleet --inproc requires --seed)\n"
    "  strategy          DiNNO regulariser (dinno_default_cfg)\n"
    "  rho0, rho_scaling, primal_steps, batch, lr_start, lr_end, kl_weight   DiNNO (dinno_default_cfg)\n"
    "  radius_m          disk graph radius (run, fleet --inproc, tools/fleet, tools/run-fleet.sh)\n"
    "  encoding          fleet states: fp32, int8, int8-ef or int4-ef (ai/dinno_codec.h)\n"
    "  pool              online pool policy (cdr or dr)\n"
    "  rounds_per_comm   online: DiNNO rounds per communication round\n"
    "  run_rounds        host_sim run's rounds\n"
    "  time_limit_s      host_sim run: simulated seconds before giving up\n"
    "  val_poses         validation poses (run, fleet --inproc)\n"
    "  mc                MC passes of a map (run, fleet --inproc, maps, tools/fleet)\n"
    "  map_res_m         a robot's maps (run) and fleet --inproc's\n"
    "  occ_res_m         fleet --inproc: grid of the occupancy metrics\n"
    "  fleet_val_checks  a fleet member validates every rounds/N rounds (run --fleet, tools/fleet)\n"
    "  metrics_rows      fleet --inproc: a metrics row every rounds/N rounds (tools/run-fleet.sh)\n"
    "  resend_ms         fleet: ask again for missing chunks after this (gp_fleet.h)\n"
    "  peer_timeout_s    fleet: a peer silent this long leaves the round\n"
    "  join_timeout_s    fleet: the same before a peer was ever heard\n"
    "  poll_ms           fleet: longest single wait for the network\n"
    "  chunk_bytes_max   fleet: state bytes per datagram (the default: as many as fit)\n"
    "  lcm_url           the LCM URL of a fleet (UDP multicast on this host)\n"
    "  max_fleet         the largest fleet this build runs (board and host_sim paths gen)\n"
    "  max_neighbours    the neighbour states a robot keeps per round (its nearest; the board's slots)\n"
    "  max_rounds        the most DiNNO rounds a run takes (--rounds)\n"
    "  fleet_robots      the launchers' fleet: robots (the default plan's tours)\n"
    "  fleet_rounds      its DiNNO rounds\n"
    "  fleet_mode        offline or online\n"
    "  fleet_val_poses   each robot's validation poses (tools/fleet)\n"
    "  fleet_map_res_m   the fleet's final maps: tools/fleet's consensus map (host_sim maps --res),\n"
    "                    make run-inproc's\n"
    "  preset, precision the build's network (PRESET=) and the training step's products (PRECISION=);\n"
    "                    host_sim --version adds the commit and the kernels\n";

static void defaults_usage(FILE *out)
{
    fprintf(out, "usage: host_sim defaults\n"
                 "\n"
                 "Prints the defaults of this build, one key=value per line (numbers in the unit the key's\n"
                 "ending names: _m metres, _s seconds, _ms milliseconds): the launchers (tools/fleet,\n"
                 "tools/run-fleet.sh, tools/slurm/fleet.sbatch) read them from the host_sim they start\n"
                 "instead of restating them. Keys:\n%s",
            keys_help);
}

/* v as %.15g (what a person would write: 0.1, 1800) unless that does not read back as v. */
static void put_double(const char *key, double v)
{
    char buf[40];
    snprintf(buf, sizeof buf, "%.15g", v);
    if (strtod(buf, NULL) != v)
        snprintf(buf, sizeof buf, "%.17g", v);
    printf("%s=%s\n", key, buf);
}

/* A float option's value: the fewest digits that read back as the same float (0.3, 1e-04). */
static void put_float(const char *key, float v)
{
    char buf[40];
    for (int prec = 1; prec <= 9; prec++) {
        snprintf(buf, sizeof buf, "%.*g", prec, (double)v);
        if ((float)strtod(buf, NULL) == v)
            break;
    }
    printf("%s=%s\n", key, buf);
}

static void defaults_print(void)
{
    run_opts_t r;
    run_defaults(&r);
    const dinno_cfg_t *d = &r.d;
    printf("seed=%lld\n", r.seed);
    printf("strategy=%s\n", dinno_strategy_name(d->strategy));
    put_float("rho0", d->rho0);
    put_float("rho_scaling", d->rho_scaling);
    printf("primal_steps=%u\nbatch=%u\n", (unsigned)d->primal_steps, (unsigned)d->batch);
    put_float("lr_start", d->lr_start);
    put_float("lr_end", d->lr_end);
    put_float("kl_weight", d->kl_weight);
    put_double("radius_m", r.radius);
    printf("encoding=%s\n", dinno_codec_name(r.encoding));
    printf("pool=%s\n", ai_pool_policy_name(r.pool));
    printf("rounds_per_comm=%lld\nrun_rounds=%lld\n", r.per_comm, r.rounds);
    put_double("time_limit_s", r.time_limit);
    printf("val_poses=%lld\nmc=%lld\n", r.val_poses, r.mc);
    put_double("map_res_m", r.map_res);
    put_double("occ_res_m", SIM_DEF_OCC_RES_M);
    printf("fleet_val_checks=%d\nmetrics_rows=%d\n", SIM_DEF_FLEET_VAL_CHECKS, SIM_DEF_METRICS_ROWS);
    put_double("resend_ms", r.resend_ms);
    put_double("peer_timeout_s", r.peer_timeout);
    put_double("join_timeout_s", r.join_timeout);
    put_double("poll_ms", GP_FLEET_POLL_US_DEFAULT / 1e3);
    printf("chunk_bytes_max=%u\n", (unsigned)GP_PSE_MAX_CHUNK_BYTES);
    printf("lcm_url=%s\n", HAL_HOST_NET_URL_DEFAULT);
    printf("max_fleet=%d\n", (int)GP_PSE_MAX_FLEET < SIM_PATHS_MAX_ROBOTS ? (int)GP_PSE_MAX_FLEET : SIM_PATHS_MAX_ROBOTS);
    printf("max_neighbours=%u\n", (unsigned)GP_PSE_MAX_NEIGHBOURS);
    printf("max_rounds=%u\n", (unsigned)AI_CORE_MAX_ROUNDS);
    printf("fleet_robots=%d\nfleet_rounds=%d\nfleet_mode=%s\nfleet_val_poses=%d\n", SIM_DEF_FLEET_ROBOTS,
           SIM_DEF_FLEET_ROUNDS, SIM_DEF_FLEET_MODE, SIM_DEF_FLEET_VAL_POSES);
    put_double("fleet_map_res_m", SIM_DEF_FLEET_MAP_RES_M);
    printf("preset=%s\nprecision=%s\n", BNN_PRESET_NAME, BNN_PRECISION_NAME);
}

static const cli_opt_t defaults_opts[] = {CLI_OPT_END};

int cmd_defaults(int argc, char **argv)
{
    const cli_parser_t parser = {.cmd = "defaults", .opts = defaults_opts, .usage = defaults_usage};
    const int pr = cli_opts_parse(&parser, argc, argv, NULL, NULL, NULL);
    if (pr != 0)
        return pr > 0 ? 0 : 2;
    defaults_print();
    return fflush(stdout) == 0 ? 0 : 1;
}
