/* host_sim valset: DiNNO-style validation set (random free poses, noise-free labelled scans). */
#include <stdio.h>
#include <string.h>

#include "commands.h"
#include "cli.h"
#include "sim_plan.h"
#include "sim_valset.h"

typedef struct valset_opts {
    const char *plan, *out;
    sim_valset_cfg_t c;
    double scale;
} valset_opts_t;

static valset_opts_t valset_defaults(void)
{
    return (valset_opts_t){.c = sim_valset_default_cfg(), .scale = SIM_PLAN_DEFAULT_SCALE};
}

static const cli_opt_t valset_opts[] = {
    {.names = "--plan", .meta = "FILE.svg", CLI_STRING(valset_opts_t, plan), .required = 1, .help = "the floor plan"},
    {.names = "--out", .meta = "VAL.samples", CLI_STRING(valset_opts_t, out), .required = 1, .help = "the samples file written"},
    {.names = "--poses", .meta = "N", CLI_INT(valset_opts_t, c.n_poses, 1, 1000000), .help = "number of poses"},
    {.names = "--seed", .meta = "S", CLI_INT(valset_opts_t, c.seed, 0, INT64_MAX), .help = "seed"},
    {.names = "--beams", .meta = "B", CLI_INT(valset_opts_t, c.n_beams, 1, 4096), .help = "beams per pose"},
    {.names = "--points", .meta = "K", CLI_INT(valset_opts_t, c.points_per_beam, 1, 1024), .help = "points per beam"},
    {.names = "--clearance", .meta = "M", CLI_DOUBLE(valset_opts_t, c.clearance_m, 0, 10),
     .help = "minimum distance of a pose from any wall"},
    {.names = "--range", .meta = "M", CLI_DOUBLE(valset_opts_t, c.range_max, 0.01, 100), .help = "lidar max range"},
    {.names = "--scale", .meta = "S", CLI_DOUBLE(valset_opts_t, scale, 1e-6, 1e3), .help = "plan metres per pixel"},
    CLI_OPT_END,
};

static void valset_usage(FILE *out)
{
    const valset_opts_t d = valset_defaults();
    fprintf(out,
            "usage: host_sim valset --plan FILE.svg --out VAL.samples [options]\n"
            "\n"
            "Draws N random poses inside the plan's rooms, clear of walls, takes a noise-free\n"
            "lidar scan at each against the ground truth and labels it (per beam, K points evenly\n"
            "spaced to the hit; the hit 1, the rest 0; no hit: free points to the max range).\n"
            "Writes the samples format (sim_samples.h). Default: %d poses x %d beams x %d points.\n"
            "\n"
            "options:\n",
            d.c.n_poses, d.c.n_beams, d.c.points_per_beam);
    cli_opts_help(out, valset_opts, &d);
}

int cmd_valset(int argc, char **argv)
{
    valset_opts_t o = valset_defaults();
    const cli_parser_t parser = {.cmd = "valset", .opts = valset_opts, .usage = valset_usage};
    const int pr = cli_opts_parse(&parser, argc, argv, &o, NULL, NULL);
    if (pr != 0)
        return pr > 0 ? 0 : 2;
    const char *plan_file = o.plan, *out = o.out;
    const sim_valset_cfg_t c = o.c;
    const double scale = o.scale;
    char err[8192];
    sim_plan_t plan;
    if (sim_plan_load(plan_file, scale, &plan, err, sizeof err) < 0) {
        fprintf(stderr, "host_sim valset: %s\n", err);
        return 1;
    }
    char source[160];
    snprintf(source, sizeof source, "valset plan=%s poses=%d beams=%d points=%d clearance=%g",
             plan_file, c.n_poses, c.n_beams, c.points_per_beam, c.clearance_m);
    uint64_t n = 0;
    int rc = sim_valset_write(&plan, &c, out, source, &n, err, sizeof err);
    sim_plan_free(&plan);
    if (rc < 0) {
        fprintf(stderr, "host_sim valset: %s\n", err);
        return 1;
    }
    printf("valset: %d poses x %d beams x %d points -> %llu samples, seed %llu, wrote %s\n",
           c.n_poses, c.n_beams, c.points_per_beam, (unsigned long long)n,
           (unsigned long long)c.seed, out);
    return 0;
}
