/* host_sim scan: drive one robot along its path in the ODE world and write the samples its
 * lidar produced (firmware follower and scan-to-samples, simulated time). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "commands.h"
#include "cli.h"
#include "sim_paths.h"
#include "sim_plan.h"
#include "sim_scan.h"

static void scan_usage(FILE *out)
{
    sim_scan_cfg_t d = sim_scan_default_cfg();
    fprintf(out,
            "usage: host_sim scan --plan FILE.svg --path ROBOT.csv --out SAMPLES.bin [options]\n"
            "\n"
            "Drives one robot along the waypoints of ROBOT.csv in the ODE world with the firmware's\n"
            "own RT core on the host HAL (waypoint follower -> wheel motors -> physics, as in\n"
            "`host_sim run`), takes a lidar scan every 1/scan-hz simulated seconds, turns each into\n"
            "labelled samples (per beam, K points evenly spaced to the hit; the hit 1, the rest 0)\n"
            "and writes what the RT core produced in the samples format (sim_samples.h).\n"
            "\n"
            "options:\n"
            "  --seed S          run seed for every noise stream (default %llu)\n"
            "  --robot I         robot index, keys the noise streams (default %u)\n"
            "  --beams B         beams per scan used for samples (default %d)\n"
            "  --points K        points per beam (default %d)\n"
            "  --lidar-beams N   beams of the simulated sensor (default %d)\n"
            "  --scan-hz F       scans per simulated second (default %g)\n"
            "  --control-hz F    follower rate (default %g)\n"
            "  --dt S            physics step in seconds (default %g)\n"
            "  --noise M         lidar range noise sigma in metres (default %g)\n"
            "  --dropout P       lidar dropout probability (default %g)\n"
            "  --gps-sigma M     GPS position noise in metres (default %g)\n"
            "  --compass-sigma R compass noise in radians (default %g)\n"
            "  --max-time S      give up after S simulated seconds (default %g)\n"
            "  --scale S         plan metres per pixel (default %g)\n"
            "  -q, --quiet       no progress lines\n",
            (unsigned long long)d.seed, d.robot, d.beams, d.points, d.sensor_beams, d.scan_hz,
            d.control_hz, d.dt, d.noise_sigma, d.dropout_p, d.gps_sigma_xy, d.gps_sigma_theta,
            d.max_time_s, SIM_PLAN_DEFAULT_SCALE);
}

static void progress(const sim_scan_stats_t *st, int n_wp, void *user)
{
    (void)user;
    fprintf(stderr, "scan: t=%7.1f s  waypoint %d/%d  scans %llu  samples %llu  distance %.2f m\n",
            st->sim_time_s, st->waypoints_reached, n_wp, (unsigned long long)st->scans,
            (unsigned long long)st->samples, st->distance_m);
}

int cmd_scan(int argc, char **argv)
{
    const char *plan_file = NULL, *path_file = NULL, *out = NULL;
    sim_scan_cfg_t c = sim_scan_default_cfg();
    double scale = SIM_PLAN_DEFAULT_SCALE;
    int quiet = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        long long ll = 0; // set by the parsers on success; 0 keeps -O1 -Wmaybe-uninitialized quiet
        double d;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            scan_usage(stdout);
            return 0;
        } else if (strcmp(a, "-q") == 0 || strcmp(a, "--quiet") == 0) {
            quiet = 1;
            continue;
        }
        if (strncmp(a, "--", 2) != 0) {
            fprintf(stderr, "host_sim scan: unexpected argument '%s' (see --help)\n", a);
            return 2;
        }
        if (cmd_need_value(argc, argv, i, "scan", scan_usage) < 0)
            return 2;
        const char *v = argv[++i];
        int bad = 0;
        if (strcmp(a, "--plan") == 0)
            plan_file = v;
        else if (strcmp(a, "--path") == 0)
            path_file = v;
        else if (strcmp(a, "--out") == 0)
            out = v;
        else if (strcmp(a, "--seed") == 0)
            bad = cmd_parse_ll(v, a, 0, 9223372036854775807LL, &ll) < 0 || (c.seed = (uint64_t)ll, 0);
        else if (strcmp(a, "--robot") == 0)
            bad = cmd_parse_ll(v, a, 0, 1000000, &ll) < 0 || (c.robot = (uint32_t)ll, 0);
        else if (strcmp(a, "--beams") == 0)
            bad = cmd_parse_ll(v, a, 1, 4096, &ll) < 0 || (c.beams = (int)ll, 0);
        else if (strcmp(a, "--points") == 0)
            bad = cmd_parse_ll(v, a, 1, 1024, &ll) < 0 || (c.points = (int)ll, 0);
        else if (strcmp(a, "--lidar-beams") == 0)
            bad = cmd_parse_ll(v, a, 1, 4096, &ll) < 0 || (c.sensor_beams = (int)ll, 0);
        else if (strcmp(a, "--scan-hz") == 0)
            bad = cmd_parse_double(v, a, 0.01, 1000, &d) < 0 || (c.scan_hz = d, 0);
        else if (strcmp(a, "--control-hz") == 0)
            bad = cmd_parse_double(v, a, 0.01, 1000, &d) < 0 || (c.control_hz = d, 0);
        else if (strcmp(a, "--dt") == 0)
            bad = cmd_parse_double(v, a, 1e-4, 0.05, &d) < 0 || (c.dt = d, 0);
        else if (strcmp(a, "--noise") == 0)
            bad = cmd_parse_double(v, a, 0, 1, &d) < 0 || (c.noise_sigma = d, 0);
        else if (strcmp(a, "--dropout") == 0)
            bad = cmd_parse_double(v, a, 0, 0.99, &d) < 0 || (c.dropout_p = d, 0);
        else if (strcmp(a, "--gps-sigma") == 0)
            bad = cmd_parse_double(v, a, 0, 1, &d) < 0 || (c.gps_sigma_xy = d, 0);
        else if (strcmp(a, "--compass-sigma") == 0)
            bad = cmd_parse_double(v, a, 0, 1, &d) < 0 || (c.gps_sigma_theta = d, 0);
        else if (strcmp(a, "--max-time") == 0)
            bad = cmd_parse_double(v, a, 0.01, 1e7, &d) < 0 || (c.max_time_s = d, 0);
        else if (strcmp(a, "--scale") == 0)
            bad = cmd_parse_double(v, a, 1e-6, 1e3, &scale) < 0;
        else {
            fprintf(stderr, "host_sim scan: unknown option '%s' (see --help)\n", a);
            return 2;
        }
        if (bad)
            return 2;
    }
    if (plan_file == NULL || path_file == NULL || out == NULL) {
        fprintf(stderr, "host_sim scan: --plan, --path and --out are required (see --help)\n");
        return 2;
    }
    if (c.beams > c.sensor_beams) {
        fprintf(stderr, "host_sim scan: --beams %d exceeds --lidar-beams %d\n", c.beams, c.sensor_beams);
        return 2;
    }
    char err[8192];
    sim_plan_t plan;
    if (sim_plan_load(plan_file, scale, &plan, err, sizeof err) < 0) {
        fprintf(stderr, "host_sim scan: %s\n", err);
        return 1;
    }
    sim_path_t path;
    if (sim_path_read_csv(path_file, &plan, &path, err, sizeof err) < 0) {
        fprintf(stderr, "host_sim scan: %s\n", err);
        sim_plan_free(&plan);
        return 1;
    }
    char source[160];
    snprintf(source, sizeof source, "scan plan=%s path=%s robot=%u beams=%d points=%d hz=%g",
             plan_file, path_file, c.robot, c.beams, c.points, c.scan_hz);
    printf("scan: plan %s, path %s (%d waypoints), seed %llu, %d of %d beams x %d points, "
           "%g Hz, dt %g s\n",
           plan_file, path_file, path.n, (unsigned long long)c.seed, c.beams, c.sensor_beams,
           c.points, c.scan_hz, c.dt);
    fflush(stdout);
    sim_scan_stats_t st;
    int rc = sim_scan_run(&plan, &path, &c, out, source, &st, quiet ? NULL : progress, NULL, err,
                          sizeof err);
    printf("scan: simulated %.1f s, %llu scans, %llu samples (%llu occupied), distance %.2f m, "
           "%d/%d waypoints, %llu collisions, seed %llu\n",
           st.sim_time_s, (unsigned long long)st.scans, (unsigned long long)st.samples,
           (unsigned long long)st.samples_occupied, st.distance_m, st.waypoints_reached, path.n,
           (unsigned long long)st.collisions, (unsigned long long)c.seed);
    if (rc < 0)
        fprintf(stderr, "host_sim scan: %s\n", err);
    else
        printf("scan: wrote %s\n", out);
    sim_path_free(&path);
    sim_plan_free(&plan);
    return rc < 0 ? 1 : 0;
}
