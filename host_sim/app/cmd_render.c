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

#define MAX_PATHS SIM_PATHS_MAX_ROBOTS /* a whole fleet's tours, as tools/fleet passes them */
#define CLI_STR__(x) #x
#define CLI_STR_(x) CLI_STR__(x)

typedef struct render_opts {
    const char *plan, *out, *path_files[MAX_PATHS];
    int n_paths;
    long long sweep_beams, seed;
    sim_render_cfg_t cfg;
    double scale, wall_h;
} render_opts_t;

static render_opts_t render_defaults(void)
{
    return (render_opts_t){.sweep_beams = 180, .seed = 1, .cfg = sim_render_default_cfg(),
                           .scale = SIM_PLAN_DEFAULT_SCALE, .wall_h = 2.5};
}

/* --path, repeated: one robot each. */
static int add_path(const char *cmd, const char *opt, const char *v, void *field, void *opts)
{
    (void)field;
    render_opts_t *o = opts;
    if (o->n_paths == MAX_PATHS) {
        fprintf(stderr, "host_sim %s: at most %d %s options\n", cmd, MAX_PATHS, opt);
        return -1;
    }
    o->path_files[o->n_paths++] = v;
    return 0;
}

static const cli_opt_t render_opts[] = {
    {.names = "--plan", .meta = "FILE.svg", CLI_STRING(render_opts_t, plan), .required = 1, .help = "the floor plan"},
    {.names = "--out", .meta = "SCENE.png", CLI_STRING(render_opts_t, out), .required = 1, .help = "the image written (PNG: the name must end in .png)"},
    {.names = "--path", .meta = "FILE", CLI_CUSTOM(render_opts_t, path_files, add_path),
     .help = "a waypoint CSV (x_m,y_m); repeat for several robots (max " CLI_STR_(MAX_PATHS) ")"},
    {.names = "--width", .meta = "W", CLI_INT(render_opts_t, cfg.width, 16, SIM_RENDER_MAX_SIDE), .help = "image width"},
    {.names = "--height", .meta = "H", CLI_INT(render_opts_t, cfg.height, 16, SIM_RENDER_MAX_SIDE), .help = "image height"},
    {.names = "--azimuth", .meta = "DEG", CLI_DOUBLE(render_opts_t, cfg.azimuth_deg, -360, 360),
     .help = "camera azimuth, -90 = from the south"},
    {.names = "--elevation", .meta = "DEG", CLI_DOUBLE(render_opts_t, cfg.elevation_deg, 5.01, 90),
     .help = "camera elevation above the floor"},
    {.names = "--fov", .meta = "DEG", CLI_DOUBLE(render_opts_t, cfg.fov_deg, 5.01, 119.9), .help = "vertical field of view"},
    {.names = "--wall-height", .meta = "M", CLI_DOUBLE(render_opts_t, wall_h, 0.01, 10),
     .help = "height the walls are drawn at, e.g. 1.0 for a cut-away view that shows robots next to walls "
             "(the default is the simulated height)"},
    {.names = "--sweep-beams", .meta = "N", CLI_INT(render_opts_t, sweep_beams, 0, SIM_LIDAR_MAX_BEAMS),
     .help = "beams drawn in the lidar sweep, 0 = none"},
    {.names = "--seed", .meta = "S", CLI_INT(render_opts_t, seed, 0, INT64_MAX),
     .help = "seed of the free pose used when no path is given"},
    {.names = "--scale", .meta = "S", CLI_DOUBLE(render_opts_t, scale, 1e-6, 1e3), .help = "plan metres per pixel"},
    CLI_OPT_END,
};

static void render_usage(FILE *out)
{
    const render_opts_t d = render_defaults();
    fprintf(out,
            "usage: host_sim render --plan FILE.svg [--path ROBOT.csv ...] --out SCENE.png [options]\n"
            "\n"
            "Renders the plan's walls extruded to 2.5 m, the floor, one robot at the start of each\n"
            "path (facing its second waypoint), the paths as coloured lines and one noise-free lidar\n"
            "sweep from the first robot (or from a free pose when no path is given), offscreen\n"
            "(OSMesa, no display), from a perspective camera above the plan.\n"
            "\n"
            "options:\n");
    cli_opts_help(out, render_opts, &d);
}

int cmd_render(int argc, char **argv)
{
    render_opts_t o = render_defaults();
    const cli_parser_t parser = {.cmd = "render", .opts = render_opts, .usage = render_usage};
    const int pr = cli_opts_parse(&parser, argc, argv, &o, NULL, NULL);
    if (pr != 0)
        return pr > 0 ? 0 : 2;
    if (cmd_check_out_ext("render", "--out", o.out, ".png", "a PNG image") != 0)
        return 2;
    const char *plan_file = o.plan, *out = o.out, *const *path_files = o.path_files;
    const int n_paths = o.n_paths;
    const long long sweep_beams = o.sweep_beams, seed = o.seed;
    const sim_render_cfg_t rc_cfg = o.cfg;
    const double scale = o.scale, wall_h = o.wall_h;
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
