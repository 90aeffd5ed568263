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

typedef struct scan_opts {
    const char *plan, *path, *out;
    sim_scan_cfg_t c;
    double scale;
    int quiet;
} scan_opts_t;

static scan_opts_t scan_defaults(void)
{
    return (scan_opts_t){.c = sim_scan_default_cfg(), .scale = SIM_PLAN_DEFAULT_SCALE};
}

static const cli_opt_t scan_opts[] = {
    {.names = "--plan", .meta = "FILE.svg", CLI_STRING(scan_opts_t, plan), .required = 1, .help = "the floor plan"},
    {.names = "--path", .meta = "ROBOT.csv", CLI_STRING(scan_opts_t, path), .required = 1,
     .help = "the robot's waypoints"},
    {.names = "--out", .meta = "FILE.samples", CLI_STRING(scan_opts_t, out), .required = 1,
     .help = "the samples file written (.samples, as every samples file of the project)"},
    {.names = "--seed", .meta = "S", CLI_INT(scan_opts_t, c.seed, 0, INT64_MAX), .help = "run seed for every noise stream"},
    {.names = "--robot", .meta = "I", CLI_INT(scan_opts_t, c.robot, 0, 1000000), .help = "robot index, keys the noise streams"},
    {.names = "--beams", .meta = "B", CLI_INT(scan_opts_t, c.beams, 1, 4096), .help = "beams per scan used for samples"},
    {.names = "--points", .meta = "K", CLI_INT(scan_opts_t, c.points, 1, 1024), .help = "points per beam"},
    {.names = "--lidar-beams", .meta = "N", CLI_INT(scan_opts_t, c.sensor_beams, 1, 4096),
     .help = "beams of the simulated sensor"},
    {.names = "--scan-hz", .meta = "F", CLI_DOUBLE(scan_opts_t, c.scan_hz, 0.01, 1000), .help = "scans per simulated second"},
    {.names = "--control-hz", .meta = "F", CLI_DOUBLE(scan_opts_t, c.control_hz, 0.01, 1000), .help = "follower rate"},
    {.names = "--dt", .meta = "S", CLI_DOUBLE(scan_opts_t, c.dt, 1e-4, 0.05), .help = "physics step in seconds"},
    {.names = "--noise", .meta = "M", CLI_DOUBLE(scan_opts_t, c.noise_sigma, 0, 1), .help = "lidar range noise sigma in metres"},
    {.names = "--dropout", .meta = "P", CLI_DOUBLE(scan_opts_t, c.dropout_p, 0, 0.99), .help = "lidar dropout probability"},
    {.names = "--gps-sigma", .meta = "M", CLI_DOUBLE(scan_opts_t, c.gps_sigma_xy, 0, 1), .help = "GPS position noise in metres"},
    {.names = "--compass-sigma", .meta = "R", CLI_DOUBLE(scan_opts_t, c.gps_sigma_theta, 0, 1), .help = "compass noise in radians"},
    {.names = "--max-time", .meta = "S", CLI_DOUBLE(scan_opts_t, c.max_time_s, 0.01, 1e7),
     .help = "give up after S simulated seconds"},
    {.names = "--scale", .meta = "S", CLI_DOUBLE(scan_opts_t, scale, 1e-6, 1e3), .help = "plan metres per pixel"},
    {.names = "-q|--quiet", CLI_FLAG(scan_opts_t, quiet, 1), .help = "no progress lines"},
    CLI_OPT_END,
};

static void scan_usage(FILE *out)
{
    const scan_opts_t d = scan_defaults();
    fprintf(out,
            "usage: host_sim scan --plan FILE.svg --path ROBOT.csv --out FILE.samples [options]\n"
            "\n"
            "Drives one robot along the waypoints of ROBOT.csv in the ODE world with the firmware's\n"
            "own RT core on the host HAL (waypoint follower -> wheel motors -> physics, as in\n"
            "`host_sim run`), takes a lidar scan every 1/scan-hz simulated seconds, turns each into\n"
            "labelled samples (per beam, K points evenly spaced to the hit; the hit 1, the rest 0)\n"
            "and writes what the RT core produced in the samples format (sim_samples.h) to FILE.samples\n"
            "(`host_sim fleet --samples DIR` reads DIR/robot_<i>.samples; tools/samples.py reads any).\n"
            "\n"
            "options:\n");
    cli_opts_help(out, scan_opts, &d);
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
    scan_opts_t o = scan_defaults();
    const cli_parser_t parser = {.cmd = "scan", .opts = scan_opts, .usage = scan_usage};
    const int pr = cli_opts_parse(&parser, argc, argv, &o, NULL, NULL);
    if (pr != 0)
        return pr > 0 ? 0 : 2;
    const char *plan_file = o.plan, *path_file = o.path, *out = o.out;
    const sim_scan_cfg_t c = o.c;
    const double scale = o.scale;
    const int quiet = o.quiet;
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
