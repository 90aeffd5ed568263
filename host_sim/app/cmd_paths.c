/* host_sim paths: waypoint tours for N robots (gen, check). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "commands.h"
#include "cli.h"
#include "sim_figure.h"
#include "sim_grid.h"
#include "sim_paths.h"
#include "sim_plan.h"

typedef struct paths_opts {
    const char *plan, *out, *png;
    double scale, check_clearance;
    long long robots, seed;
    sim_paths_cfg_t cfg;
} paths_opts_t;

static paths_opts_t paths_defaults(void)
{
    paths_opts_t o = {.scale = SIM_PLAN_DEFAULT_SCALE, .robots = -1, .seed = -1};
    sim_paths_cfg_default(&o.cfg);
    o.check_clearance = o.cfg.clearance_m;
    return o;
}

#define PATHS_PLAN_OPT \
    {.names = "--plan", .meta = "FILE", CLI_STRING(paths_opts_t, plan), .required = 1, .help = "the floor plan"}
#define PATHS_PNG_OPT \
    {.names = "--png", .meta = "FILE.png", CLI_STRING(paths_opts_t, png), .help = "draw the ground truth with the tours"}
#define PATHS_SCALE_OPT \
    {.names = "--scale", .meta = "S", CLI_DOUBLE(paths_opts_t, scale, 1e-6, 100.0), .help = "metres per SVG pixel"}

static const cli_opt_t paths_gen_opts[] = {
    PATHS_PLAN_OPT,
    {.names = "--robots", .meta = "N", CLI_INT(paths_opts_t, robots, 1, SIM_PATHS_MAX_ROBOTS), .required = 1,
     .help = "robots: one tour each, from N different start rooms; more robots than rooms share them"},
    {.names = "--seed", .meta = "S", CLI_INT(paths_opts_t, seed, 0, INT64_MAX), .required = 1, .help = "seed"},
    {.names = "--out", .meta = "DIR", CLI_STRING(paths_opts_t, out), .required = 1,
     .help = "folder of the tours, DIR/robot_<i>.csv"},
    {.names = "--clearance", .meta = "M", CLI_DOUBLE(paths_opts_t, cfg.clearance_m, 0.0, 5.0),
     .help = "robot centre to any wall (TurtleBot3 burger radius 0.105 m + margin)"},
    {.names = "--res", .meta = "M", CLI_DOUBLE(paths_opts_t, cfg.res_m, 0.005, 1.0), .help = "planning grid"},
    {.names = "--sweep", .meta = "M", CLI_DOUBLE(paths_opts_t, cfg.sweep_m, 0.1, 100.0),
     .help = "spacing of the sweep goals in each room"},
    {.names = "--rooms", CLI_CHOICE(paths_opts_t, cfg.own_rooms, "all|own"),
     .help = "all: the tours together sweep every reachable room; own: each robot sweeps only its start room "
             "and the rooms nobody starts in stay unvisited (a fleet that leaves part of the building unseen)"},
    PATHS_SCALE_OPT,
    PATHS_PNG_OPT,
    CLI_OPT_END,
};

static const cli_opt_t paths_check_opts[] = {
    PATHS_PLAN_OPT,
    {.names = "--clearance", .meta = "M", CLI_DOUBLE(paths_opts_t, check_clearance, 0.0, 10.0),
     .help = "the least distance of every segment from the walls"},
    PATHS_SCALE_OPT,
    PATHS_PNG_OPT,
    CLI_OPT_END,
};

static void paths_usage(FILE *out)
{
    const paths_opts_t d = paths_defaults();
    fprintf(out,
            "usage: host_sim paths <gen|check> ...\n"
            "\n"
            "  host_sim paths gen --plan FILE --robots N --seed S --out DIR\n"
            "                     [--clearance M] [--res M] [--sweep M] [--rooms all|own] [--scale S]\n"
            "                     [--png FILE.png]\n"
            "      plan collision-free coverage tours from N different start rooms and write\n"
            "      DIR/robot_<i>.csv (header x_m,y_m); with more robots than reachable rooms every\n"
            "      room starts one and the rooms with the most sweep per robot take the others,\n"
            "      each robot sweeping its share of its room from a start cell of its own (up to %d\n"
            "      robots); prints waypoints, length and start room per robot, the clearance kept\n"
            "      and the coverage of the free cells (line of sight within 1.5 m and 3.5 m);\n"
            "      --png draws the ground truth with the tours, axes in metres and a legend.\n"
            "      --rooms own: each robot sweeps only its start room (same seeded start rooms), so\n"
            "      with fewer robots than rooms part of the building stays unvisited: the rooms\n"
            "      without a waypoint are listed and the coverage line says how much was seen\n"
            "  host_sim paths check --plan FILE [--clearance M] [--scale S] [--png FILE.png] CSV...\n"
            "      validate waypoint files against the plan and print the same figures; exit 1 with\n"
            "      FILE:LINE: reason when a waypoint is not free or a segment comes closer than\n"
            "      --clearance to a wall (LINE: the waypoint the segment ends at)\n"
            "\n"
            "options of paths gen:\n",
            SIM_PATHS_MAX_ROBOTS);
    cli_opts_help(out, paths_gen_opts, &d);
    fprintf(out, "options of paths check (before the CSV files):\n");
    cli_opts_help(out, paths_check_opts, &d);
}

/* The picture (ground truth + tours, y up, the robots' colours): sim_figure.h. */
static int draw_png(const sim_grid_t *g, const sim_path_t *paths, int n, const char *file)
{
    char err[256];
    int rc = sim_figure_paths_png(g, paths, n, file, err, sizeof err);
    if (rc != 0)
        fprintf(stderr, "host_sim paths: %s\n", err);
    return rc;
}

/* Prints per-robot and fleet figures; returns 0. */
static void report(const sim_plan_t *plan, const sim_grid_t *g, const sim_path_t *paths, int n)
{
    double min_clear = INFINITY;
    for (int k = 0; k < n; k++) {
        double len = sim_path_length(&paths[k]);
        double cl = sim_path_min_clearance(plan, &paths[k]);
        min_clear = fmin(min_clear, cl);
        int room = sim_plan_room_at(plan, paths[k].p[0].x, paths[k].p[0].y);
        printf("robot %d: %4d waypoints, %6.1f m, start (%.2f, %.2f) in room %d (%s), min clearance %.3f m\n", k,
               paths[k].n, len, paths[k].p[0].x, paths[k].p[0].y, room, room >= 0 ? plan->rooms[room].type : "-",
               cl);
    }
    printf("min clearance to walls: %.3f m\n", min_clear);
    /* Rooms with at least one waypoint: a room behind a door too narrow for the clearance
     * would be missing here. */
    int visited = 0;
    for (int room = 0; room < plan->n_rooms; room++) {
        int hit = 0;
        for (int k = 0; k < n && !hit; k++)
            for (int i = 0; i < paths[k].n && !hit; i++)
                hit = sim_poly_contains(&plan->rooms[room].outline, paths[k].p[i].x, paths[k].p[i].y);
        visited += hit;
        if (!hit)
            printf("room %d (%s) has no waypoint\n", room, plan->rooms[room].type);
    }
    printf("rooms with waypoints: %d of %d\n", visited, plan->n_rooms);
    printf("coverage of free cells (line of sight): %.1f%% within 1.5 m, %.1f%% within 3.5 m\n",
           100.0 * sim_paths_coverage(g, paths, n, 1.5), 100.0 * sim_paths_coverage(g, paths, n, 3.5));
}

static int paths_gen(int argc, char **argv)
{
    paths_opts_t o = paths_defaults();
    const cli_parser_t parser = {.cmd = "paths gen", .opts = paths_gen_opts, .usage = paths_usage};
    const int pr = cli_opts_parse(&parser, argc, argv, &o, NULL, NULL);
    if (pr != 0)
        return pr > 0 ? 0 : 2;
    if (o.png != NULL && cmd_check_out_ext("paths gen", "--png", o.png, ".png", "a PNG image") != 0)
        return 2;
    const char *plan_file = o.plan, *out = o.out, *png = o.png;
    const double scale = o.scale;
    const long long robots = o.robots, seed = o.seed;
    sim_paths_cfg_t cfg = o.cfg;
    cfg.n_robots = (int)robots;
    cfg.seed = (uint64_t)seed;
    sim_plan_t plan;
    char err[8192];
    if (sim_plan_load(plan_file, scale, &plan, err, sizeof err) != 0) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    int ret = 1;
    sim_path_t *paths = calloc((size_t)cfg.n_robots, sizeof *paths);
    sim_grid_t g = {0};
    if (paths == NULL) {
        fprintf(stderr, "host_sim paths gen: out of memory\n");
        goto done;
    }
    if (sim_paths_generate(&plan, &cfg, paths, err, sizeof err) != 0) {
        fprintf(stderr, "host_sim paths gen: %s: %s\n", plan_file, err);
        goto done;
    }
    if (cmd_prepare_out_dir("paths gen", out) != 0)
        goto done_paths;
    for (int k = 0; k < cfg.n_robots; k++) {
        char file[4096];
        if (snprintf(file, sizeof file, "%s/robot_%d.csv", out, k) >= (int)sizeof file) {
            fprintf(stderr, "host_sim paths gen: output path too long\n");
            goto done_paths;
        }
        if (sim_path_write_csv(&paths[k], file, err, sizeof err) != 0) {
            fprintf(stderr, "host_sim paths gen: %s\n", err);
            goto done_paths;
        }
    }
    /* "rooms own" only when given: the default's output stays what it was. */
    printf("plan %s, %d robots, seed %lld, clearance %g m, grid %g m, sweep %g m%s -> %s/robot_*.csv\n", plan_file,
           cfg.n_robots, seed, cfg.clearance_m, cfg.res_m, cfg.sweep_m, cfg.own_rooms ? ", rooms own" : "", out);
    if (sim_grid_from_plan(&plan, cfg.res_m, &g) != 0) {
        fprintf(stderr, "host_sim paths gen: cannot rasterise the plan\n");
        goto done_paths;
    }
    report(&plan, &g, paths, cfg.n_robots);
    if (png != NULL && draw_png(&g, paths, cfg.n_robots, png) != 0)
        goto done_paths;
    if (png != NULL)
        printf("wrote %s\n", png);
    ret = 0;
done_paths:
    for (int k = 0; k < cfg.n_robots; k++)
        sim_path_free(&paths[k]);
done:
    sim_grid_free(&g);
    free(paths);
    sim_plan_free(&plan);
    return ret;
}

static int paths_check(int argc, char **argv)
{
    paths_opts_t o = paths_defaults();
    char *csv[argc > 0 ? argc : 1];
    int n = 0;
    const cli_parser_t parser = {.cmd = "paths check", .opts = paths_check_opts, .usage = paths_usage,
                                 .operands = "CSV files", .options_first = 1};
    const int pr = cli_opts_parse(&parser, argc, argv, &o, csv, &n);
    if (pr != 0)
        return pr > 0 ? 0 : 2;
    const char *plan_file = o.plan, *png = o.png;
    const double scale = o.scale, clearance = o.check_clearance;
    if (n == 0) {
        fprintf(stderr, "host_sim paths check: at least one CSV is required (see --help)\n");
        return 2;
    }
    if (n > SIM_PATHS_MAX_ROBOTS) {
        fprintf(stderr, "host_sim paths check: at most %d files\n", SIM_PATHS_MAX_ROBOTS);
        return 2;
    }
    sim_plan_t plan;
    char err[8192];
    if (sim_plan_load(plan_file, scale, &plan, err, sizeof err) != 0) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    int ret = 1, loaded = 0;
    sim_path_t paths[SIM_PATHS_MAX_ROBOTS];
    sim_grid_t g = {0};
    for (; loaded < n; loaded++)
        if (sim_path_read_csv(csv[loaded], &plan, &paths[loaded], err, sizeof err) != 0) {
            fprintf(stderr, "%s\n", err);
            goto done;
        }
    /* Every point of every segment, not only the waypoints: the robot drives the segments. */
    for (int k = 0; k < n; k++) {
        int seg = -1;
        double d = 0.0;
        if (sim_path_first_tight_segment(&plan, &paths[k], clearance, &seg, &d)) {
            const sim_path_t *p = &paths[k];
            fprintf(stderr,
                    "%s:%d: the segment (%.3f, %.3f) -> (%.3f, %.3f) passes %.3f m from a wall; the robot "
                    "needs %.3f m (--clearance)\n",
                    csv[k], p->line ? p->line[seg + 1] : 0, p->p[seg].x, p->p[seg].y,
                    p->p[seg + 1].x, p->p[seg + 1].y, d, clearance);
            goto done;
        }
    }
    if (sim_grid_from_plan(&plan, 0.05, &g) != 0) {
        fprintf(stderr, "host_sim paths check: cannot rasterise the plan\n");
        goto done;
    }
    report(&plan, &g, paths, n);
    if (png != NULL && draw_png(&g, paths, n, png) != 0)
        goto done;
    ret = 0;
done:
    for (int k = 0; k < loaded; k++)
        sim_path_free(&paths[k]);
    sim_grid_free(&g);
    sim_plan_free(&plan);
    return ret;
}

int cmd_paths(int argc, char **argv)
{
    if (argc < 2) {
        paths_usage(stderr);
        return 2;
    }
    const char *sub = argv[1];
    if (strcmp(sub, "--help") == 0 || strcmp(sub, "-h") == 0 || strcmp(sub, "help") == 0) {
        paths_usage(stdout);
        return 0;
    }
    if (strcmp(sub, "--version") == 0) {
        cli_version(stdout);
        return 0;
    }
    if (strcmp(sub, "gen") == 0)
        return paths_gen(argc - 1, argv + 1);
    if (strcmp(sub, "check") == 0)
        return paths_check(argc - 1, argv + 1);
    fprintf(stderr, "host_sim paths: unknown sub-command '%s'\n\n", sub);
    paths_usage(stderr);
    return 2;
}
