/* host_sim valset: DiNNO-style validation set (random free poses, noise-free labelled scans). */
#include <stdio.h>
#include <string.h>

#include "commands.h"
#include "cli.h"
#include "sim_plan.h"
#include "sim_valset.h"

static void valset_usage(FILE *out)
{
    sim_valset_cfg_t d = sim_valset_default_cfg();
    fprintf(out,
            "usage: host_sim valset --plan FILE.svg --out VAL.bin [options]\n"
            "\n"
            "Draws N random poses inside the plan's rooms, clear of walls, takes a noise-free\n"
            "lidar scan at each against the ground truth and labels it (per beam, K points evenly\n"
            "spaced to the hit; the hit 1, the rest 0; no hit: free points to the max range).\n"
            "Writes the samples format (sim_samples.h). Default: 500 poses x 20 beams x 25 points.\n"
            "\n"
            "options:\n"
            "  --poses N       number of poses (default %d)\n"
            "  --seed S        seed (default %llu)\n"
            "  --beams B       beams per pose (default %d)\n"
            "  --points K      points per beam (default %d)\n"
            "  --clearance M   minimum distance of a pose from any wall (default %g)\n"
            "  --range M       lidar max range (default %g)\n"
            "  --scale S       plan metres per pixel (default %g)\n",
            d.n_poses, (unsigned long long)d.seed, d.n_beams, d.points_per_beam, d.clearance_m,
            d.range_max, SIM_PLAN_DEFAULT_SCALE);
}

int cmd_valset(int argc, char **argv)
{
    const char *plan_file = NULL, *out = NULL;
    sim_valset_cfg_t c = sim_valset_default_cfg();
    double scale = SIM_PLAN_DEFAULT_SCALE;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        long long ll = 0; // set by the parsers on success; 0 keeps -O1 -Wmaybe-uninitialized quiet
        double d;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            valset_usage(stdout);
            return 0;
        }
        if (strncmp(a, "--", 2) != 0) {
            fprintf(stderr, "host_sim valset: unexpected argument '%s' (see --help)\n", a);
            return 2;
        }
        if (cmd_need_value(argc, argv, i, "valset", valset_usage) < 0)
            return 2;
        const char *v = argv[++i];
        int bad = 0;
        if (strcmp(a, "--plan") == 0)
            plan_file = v;
        else if (strcmp(a, "--out") == 0)
            out = v;
        else if (strcmp(a, "--poses") == 0)
            bad = cmd_parse_ll(v, a, 1, 1000000, &ll) < 0 || (c.n_poses = (int)ll, 0);
        else if (strcmp(a, "--seed") == 0)
            bad = cmd_parse_ll(v, a, 0, 9223372036854775807LL, &ll) < 0 || (c.seed = (uint64_t)ll, 0);
        else if (strcmp(a, "--beams") == 0)
            bad = cmd_parse_ll(v, a, 1, 4096, &ll) < 0 || (c.n_beams = (int)ll, 0);
        else if (strcmp(a, "--points") == 0)
            bad = cmd_parse_ll(v, a, 1, 1024, &ll) < 0 || (c.points_per_beam = (int)ll, 0);
        else if (strcmp(a, "--clearance") == 0)
            bad = cmd_parse_double(v, a, 0, 10, &d) < 0 || (c.clearance_m = d, 0);
        else if (strcmp(a, "--range") == 0)
            bad = cmd_parse_double(v, a, 0.01, 100, &d) < 0 || (c.range_max = d, 0);
        else if (strcmp(a, "--scale") == 0)
            bad = cmd_parse_double(v, a, 1e-6, 1e3, &scale) < 0;
        else {
            fprintf(stderr, "host_sim valset: unknown option '%s' (see --help)\n", a);
            return 2;
        }
        if (bad)
            return 2;
    }
    if (plan_file == NULL || out == NULL) {
        fprintf(stderr, "host_sim valset: --plan and --out are required (see --help)\n");
        return 2;
    }
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
