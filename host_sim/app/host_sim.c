/* host_sim: the world that stands in for hardware. Dispatches to sub-commands. */
#include <stdio.h>
#include <string.h>

#include "cli_opts.h"
#include "commands.h"
#include "hal_host_stop.h"

int cmd_plan(int argc, char **argv);  /* cmd_plan.c */
int cmd_paths(int argc, char **argv); /* cmd_paths.c */
int cmd_scan(int argc, char **argv);   /* cmd_scan.c */
int cmd_valset(int argc, char **argv); /* cmd_valset.c */
int cmd_render(int argc, char **argv); /* cmd_render.c */
int cmd_fleet(int argc, char **argv); /* cmd_fleet.c */
int cmd_run(int argc, char **argv);   /* cmd_run.c */
int cmd_maps(int argc, char **argv);  /* cmd_maps.c */
int cmd_key(int argc, char **argv);   /* cmd_key.c */
int cmd_defaults(int argc, char **argv); /* cmd_defaults.c */
int cmd_coverage(int argc, char **argv); /* cmd_coverage.c */
int cmd_hil(int argc, char **argv);      /* cmd_hil.c */
int cmd_zmq_proxy(int argc, char **argv); /* cmd_zmq_proxy.c */

/* One row per sub-command, in the order `--help` lists them. */
static const host_sim_cmd_t commands[] = {
    {"plan", cmd_plan, "floor plans: check an SVG plan, generate one, rasterise the ground truth"},
    {"paths", cmd_paths, "robot waypoint tours: generate for N robots, check CSV files"},
    {"scan", cmd_scan, "drive one robot along its path in the ODE world, write its lidar samples"},
    {"valset", cmd_valset, "validation set: random free poses x noise-free labelled scans"},
    {"render", cmd_render, "offscreen 3D image (PNG) of the plan, robots, paths and a lidar sweep"},
    {"fleet", cmd_fleet, "DiNNO fleet in one process (--inproc): train N BNNs, baselines, metrics, maps"},
    {"run", cmd_run, "one robot's firmware image (RT/AI/GP cores) in lockstep with the world, online learning"},
    {"hil", cmd_hil, "one robot's world served over the hardware-in-the-loop link to firmware running elsewhere"},
    {"zmq-proxy", cmd_zmq_proxy, "the forwarder of a ZeroMQ fleet too large for the full mesh (run --zmq-proxy)"},
    {"key", cmd_key, "the fleet key of a keyed fleet: write a new one, check one"},
    {"maps", cmd_maps, "consensus of a fleet's final models: consensus.bnn, maps as .npy, ROS map (PGM+YAML), PNGs"},
    {"coverage", cmd_coverage, "unite robots' coverage.bin files: the fleet's coverage.csv (share of free space seen)"},
    {"defaults", cmd_defaults, "this build's defaults as key=value lines (what tools/fleet and run-fleet.sh read)"},
    {NULL, NULL, NULL},
};

static void usage(FILE *out)
{
    fprintf(out, "usage: host_sim <command> [options]   (host_sim <command> --help for details)\n"
                 "       host_sim --version               (the commit and the build's configuration)\n\n"
                 "commands:\n");
    for (const host_sim_cmd_t *c = commands; c->name != NULL; c++)
        fprintf(out, "  %-10s %s\n", c->name, c->summary);
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return 2;
    }
    if (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "help") == 0) {
        usage(stdout);
        return 0;
    }
    if (strcmp(argv[1], "--version") == 0 || strcmp(argv[1], "version") == 0) {
        cli_version(stdout);
        return fflush(stdout) == 0 ? 0 : 1;
    }
    for (const host_sim_cmd_t *c = commands; c->name != NULL; c++) {
        if (strcmp(argv[1], c->name) != 0)
            continue;
        /* SIGINT / SIGTERM: every command removes its temporary files and exits 130 / 143
           (hal_host_stop.h); `run` switches to stopping at its next lockstep instant. */
        char prefix[64];
        snprintf(prefix, sizeof prefix, "host_sim %s", c->name);
        if (hal_host_stop_install(prefix) != 0)
            fprintf(stderr, "host_sim: warning: SIGINT/SIGTERM handlers not installed: a stopped run may "
                            "leave temporary files (the next run in that folder removes them)\n");
        return c->run(argc - 1, argv + 1);
    }
    fprintf(stderr, "host_sim: unknown command '%s'\n\n", argv[1]);
    usage(stderr);
    return 2;
}
