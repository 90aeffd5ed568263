/* host_sim render: offscreen OSMesa picture of the plan, robots at their path starts, the
 * paths and one lidar sweep, written as PNG. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "commands.h"
#include "cli.h"
#include "sim_lidar.h"
#include "sim_paths.h"
#include "sim_plan.h"
#include "sim_render.h"
#include "sim_valset.h"
#include "sim_world.h"

#define MAX_PATHS 64

static void render_usage(FILE *out)
{
    sim_render_cfg_t d = sim_render_default_cfg();
    fprintf(out,
            "usage: host_sim render --plan FILE.svg [--path ROBOT.csv ...] --out SCENE.png [options]\n"
            "\n"
            "Renders the plan's walls extruded to 2.5 m, the floor, one robot at the start of each\n"
            "path (facing its second waypoint), the paths as coloured lines and one noise-free lidar\n"
            "sweep from the first robot (or from a free pose when no path is given), offscreen\n"
            "(OSMesa, no display), from a perspective camera above the plan.\n"
            "\n"
            "options:\n"
            "  --path FILE       a waypoint CSV (x_m,y_m); repeat for several robots (max %d)\n"
            "  --width W         image width (default %d)\n"
            "  --height H        image height (default %d)\n"
            "  --azimuth DEG     camera azimuth, -90 = from the south (default %g)\n"
            "  --elevation DEG   camera elevation above the floor (default %g)\n"
            "  --fov DEG         vertical field of view (default %g)\n"
            "  --wall-height M   height the walls are drawn at, e.g. 1.0 for a cut-away view\n"
            "                    that shows robots next to walls (default 2.5, the simulated height)\n"
            "  --sweep-beams N   beams drawn in the lidar sweep, 0 = none (default 180)\n"
            "  --seed S          seed of the free pose used when no path is given (default 1)\n"
            "  --scale S         plan metres per pixel (default %g)\n",
            MAX_PATHS, d.width, d.height, d.azimuth_deg, d.elevation_deg, d.fov_deg,
            SIM_PLAN_DEFAULT_SCALE);
}

int cmd_render(int argc, char **argv)
{
    const char *plan_file = NULL, *out = NULL, *path_files[MAX_PATHS];
    int n_paths = 0;
    long long sweep_beams = 180, seed = 1;
    sim_render_cfg_t rc_cfg = sim_render_default_cfg();
    double scale = SIM_PLAN_DEFAULT_SCALE, wall_h = 2.5;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        long long ll = 0; // set by the parsers on success; 0 keeps -O1 -Wmaybe-uninitialized quiet
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            render_usage(stdout);
            return 0;
        }
        if (strncmp(a, "--", 2) != 0) {
            fprintf(stderr, "host_sim render: unexpected argument '%s' (see --help)\n", a);
            return 2;
        }
        if (cmd_need_value(argc, argv, i, "render", render_usage) < 0)
            return 2;
        const char *v = argv[++i];
        int bad = 0;
        if (strcmp(a, "--plan") == 0)
            plan_file = v;
        else if (strcmp(a, "--out") == 0)
            out = v;
        else if (strcmp(a, "--path") == 0) {
            if (n_paths == MAX_PATHS) {
                fprintf(stderr, "host_sim render: at most %d --path options\n", MAX_PATHS);
                return 2;
            }
            path_files[n_paths++] = v;
        } else if (strcmp(a, "--width") == 0)
            bad = cmd_parse_ll(v, a, 16, SIM_RENDER_MAX_SIDE, &ll) < 0 || (rc_cfg.width = (int)ll, 0);
        else if (strcmp(a, "--height") == 0)
            bad = cmd_parse_ll(v, a, 16, SIM_RENDER_MAX_SIDE, &ll) < 0 || (rc_cfg.height = (int)ll, 0);
        else if (strcmp(a, "--azimuth") == 0)
            bad = cmd_parse_double(v, a, -360, 360, &rc_cfg.azimuth_deg) < 0;
        else if (strcmp(a, "--elevation") == 0)
            bad = cmd_parse_double(v, a, 5.01, 90, &rc_cfg.elevation_deg) < 0;
        else if (strcmp(a, "--fov") == 0)
            bad = cmd_parse_double(v, a, 5.01, 119.9, &rc_cfg.fov_deg) < 0;
        else if (strcmp(a, "--wall-height") == 0)
            bad = cmd_parse_double(v, a, 0.01, 10, &wall_h) < 0;
        else if (strcmp(a, "--sweep-beams") == 0)
            bad = cmd_parse_ll(v, a, 0, SIM_LIDAR_MAX_BEAMS, &sweep_beams) < 0;
        else if (strcmp(a, "--seed") == 0)
            bad = cmd_parse_ll(v, a, 0, 9223372036854775807LL, &seed) < 0;
        else if (strcmp(a, "--scale") == 0)
            bad = cmd_parse_double(v, a, 1e-6, 1e3, &scale) < 0;
        else {
            fprintf(stderr, "host_sim render: unknown option '%s' (see --help)\n", a);
            return 2;
        }
        if (bad)
            return 2;
    }
    if (plan_file == NULL || out == NULL) {
        fprintf(stderr, "host_sim render: --plan and --out are required (see --help)\n");
        return 2;
    }
    char err[8192];
    int status = 1;
    sim_plan_t plan;
    if (sim_plan_load(plan_file, scale, &plan, err, sizeof err) < 0) {
        fprintf(stderr, "host_sim render: %s\n", err);
        return 1;
    }
    sim_path_t paths[MAX_PATHS];
    sim_pose_t robots[MAX_PATHS];
    memset(paths, 0, sizeof paths);
    int loaded = 0;
    sim_world_t *w = NULL;
    sim_lidar_t *lid = NULL;
    double *ranges = NULL;
    float *franges = NULL;
    for (; loaded < n_paths; loaded++) {
        if (sim_path_read_csv(path_files[loaded], &plan, &paths[loaded], err, sizeof err) < 0) {
            fprintf(stderr, "host_sim render: %s\n", err);
            goto out;
        }
        const sim_path_t *p = &paths[loaded];
        robots[loaded].x = p->p[0].x;
        robots[loaded].y = p->p[0].y;
        robots[loaded].theta = atan2(p->p[1].y - p->p[0].y, p->p[1].x - p->p[0].x);
    }
    sim_render_sweep_t sweep;
    sim_render_sweep_t *sw = NULL;
    if (sweep_beams > 0) {
        sim_pose_t at;
        if (n_paths > 0) {
            at = robots[0];
        } else {
            sim_valset_cfg_t vc = sim_valset_default_cfg();
            vc.n_poses = 1;
            vc.seed = (uint64_t)seed;
            if (sim_valset_poses(&plan, &vc, &at, err, sizeof err) < 0) {
                fprintf(stderr, "host_sim render: %s\n", err);
                goto out;
            }
        }
        sim_lidar_cfg_t lc = sim_lidar_default_cfg();
        lc.n_beams = (int)sweep_beams;
        lc.noise_sigma = 0;
        lc.range_min = 0;
        ranges = malloc(sizeof(double) * (size_t)sweep_beams);
        franges = malloc(sizeof(float) * (size_t)sweep_beams);
        if (ranges == NULL || franges == NULL || sim_world_create(&plan, NULL, &w, err, sizeof err) < 0 ||
            sim_lidar_create(&lc, &lid) < 0 ||
            sim_lidar_scan(lid, w, at.x, at.y, at.theta, 0, 0, franges, ranges) < 0) {
            fprintf(stderr, "host_sim render: lidar sweep failed: %s\n", ranges ? err : "out of memory");
            goto out;
        }
        sweep.pose = at;
        sweep.ranges = ranges;
        sweep.n = (int)sweep_beams;
        sweep.range_max = lc.range_max;
        sweep.height = lc.mount_height;
        sw = &sweep;
    }
    sim_render_scene_t scene = {&plan, paths, n_paths, robots, n_paths, sw, wall_h};
    if (sim_render_png(&scene, &rc_cfg, out, err, sizeof err) < 0) {
        fprintf(stderr, "host_sim render: %s\n", err);
        goto out;
    }
    printf("render: %s, %d path(s), %lld-beam sweep, %dx%d -> %s\n", plan_file, n_paths, sweep_beams,
           rc_cfg.width, rc_cfg.height, out);
    status = 0;
out:
    for (int i = 0; i < loaded; i++)
        sim_path_free(&paths[i]);
    sim_lidar_destroy(lid);
    sim_world_destroy(w);
    free(ranges);
    free(franges);
    sim_plan_free(&plan);
    return status;
}
