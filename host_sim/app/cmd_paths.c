/* host_sim paths: waypoint tours for N robots (gen, check). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "commands.h"
#include "cli.h"
#include "sim_grid.h"
#include "sim_paths.h"
#include "sim_plan.h"

static void paths_usage(FILE *out)
{
    fprintf(out,
            "usage: host_sim paths <gen|check> ...\n"
            "\n"
            "  host_sim paths gen --plan FILE --robots N --seed S --out DIR\n"
            "                     [--clearance M] [--res M] [--sweep M] [--scale S] [--png FILE.png]\n"
            "      plan collision-free coverage tours from N different start rooms and write\n"
            "      DIR/robot_<i>.csv (header x_m,y_m); prints waypoints, length and start room per\n"
            "      robot, the clearance kept and the coverage of the free cells (line of sight\n"
            "      within 1.5 m and 3.5 m); --png draws the ground truth with the tours\n"
            "  host_sim paths check --plan FILE [--clearance M] [--scale S] [--png FILE.png] CSV...\n"
            "      validate waypoint files against the plan and print the same figures; exit 1 with\n"
            "      FILE:LINE: reason when a waypoint is not free or a segment comes closer than\n"
            "      --clearance to a wall (LINE: the waypoint the segment ends at)\n"
            "\n"
            "  defaults: --clearance 0.2 (TurtleBot3 burger radius 0.105 m + margin), --res 0.05,\n"
            "            --sweep 1.0 (spacing of the sweep goals in each room), --scale %g\n",
            SIM_PLAN_DEFAULT_SCALE);
}

/* The picture: K x K pixels per grid cell (K chosen so the long side is about 1000 px). */
typedef struct {
    uint8_t *rgb;
    int w, h, k;
} canvas_t;

static void put_px(canvas_t *cv, int x, int y, const uint8_t *col)
{
    if (x < 0 || y < 0 || x >= cv->w || y >= cv->h)
        return;
    uint8_t *p = cv->rgb + 3 * ((size_t)y * (size_t)cv->w + (size_t)x);
    p[0] = col[0];
    p[1] = col[1];
    p[2] = col[2];
}

static void world_px(const sim_grid_t *g, const canvas_t *cv, double x, double y, int *px, int *py)
{
    *px = (int)floor((x - g->origin.x) / g->res * cv->k);
    *py = (int)floor((y - g->origin.y) / g->res * cv->k);
}

static int draw_png(const sim_grid_t *g, const sim_path_t *paths, int n, const char *file)
{
    canvas_t cv;
    int side = g->w > g->h ? g->w : g->h;
    cv.k = side >= 1000 ? 1 : 1000 / side;
    cv.w = g->w * cv.k;
    cv.h = g->h * cv.k;
    cv.rgb = malloc((size_t)cv.w * (size_t)cv.h * 3);
    if (cv.rgb == NULL)
        return -ENOMEM;
    for (int y = 0; y < cv.h; y++)
        for (int x = 0; x < cv.w; x++) {
            int c = g->cells[(size_t)(y / cv.k) * (size_t)g->w + (size_t)(x / cv.k)];
            uint8_t v = c == SIM_CELL_FREE ? 255 : (c == SIM_CELL_WALL ? 0 : 190);
            uint8_t col[3] = {v, v, v};
            put_px(&cv, x, y, col);
        }
    for (int k = 0; k < n; k++) {
        const uint8_t *col = SIM_PATH_COLOURS[k % 8];
        for (int i = 0; i + 1 < paths[k].n; i++) {
            double x0 = paths[k].p[i].x, y0 = paths[k].p[i].y, x1 = paths[k].p[i + 1].x, y1 = paths[k].p[i + 1].y;
            int steps = (int)ceil(hypot(x1 - x0, y1 - y0) / g->res * cv.k) + 1;
            for (int s = 0; s <= steps; s++) {
                double t = (double)s / steps;
                int px, py;
                world_px(g, &cv, x0 + t * (x1 - x0), y0 + t * (y1 - y0), &px, &py);
                for (int d = 0; d < (cv.k > 2 ? 2 : 1); d++) {
                    put_px(&cv, px + d, py, col);
                    put_px(&cv, px, py + d, col);
                }
            }
        }
        /* Waypoints as small crosses, the start as a filled square. */
        for (int i = 0; i < paths[k].n; i++) {
            int px, py;
            world_px(g, &cv, paths[k].p[i].x, paths[k].p[i].y, &px, &py);
            int rad = i == 0 ? 3 * cv.k : cv.k;
            for (int d = -rad; d <= rad; d++)
                for (int e = -rad; e <= rad; e++)
                    if (i == 0 || d == 0 || e == 0)
                        put_px(&cv, px + d, py + e, col);
        }
    }
    char err[256];
    int rc = sim_png_write_rgb(file, cv.w, cv.h, cv.rgb, err, sizeof err);
    if (rc != 0)
        fprintf(stderr, "host_sim paths: %s\n", err);
    free(cv.rgb);
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
    const char *plan_file = NULL, *out = NULL, *png = NULL;
    double scale = SIM_PLAN_DEFAULT_SCALE;
    long long robots = -1, seed = -1;
    sim_paths_cfg_t cfg;
    sim_paths_cfg_default(&cfg);
    for (int i = 1; i < argc; i++) {
        const char *o = argv[i];
        if (strcmp(o, "--help") == 0 || strcmp(o, "-h") == 0) {
            paths_usage(stdout);
            return 0;
        }
        if (o[0] != '-' || strncmp(o, "--", 2) != 0) {
            fprintf(stderr, "host_sim paths gen: unexpected argument '%s'\n", o);
            return 2;
        }
        if (cmd_need_value(argc, argv, i, "paths gen", paths_usage) != 0)
            return 2;
        const char *v = argv[++i];
        int bad = 0;
        if (strcmp(o, "--plan") == 0)
            plan_file = v;
        else if (strcmp(o, "--out") == 0)
            out = v;
        else if (strcmp(o, "--png") == 0)
            png = v;
        else if (strcmp(o, "--robots") == 0)
            bad = cmd_parse_ll(v, o, 1, SIM_PATHS_MAX_ROBOTS, &robots);
        else if (strcmp(o, "--seed") == 0)
            bad = cmd_parse_ll(v, o, 0, 0x7FFFFFFFFFFFFFFFLL, &seed);
        else if (strcmp(o, "--clearance") == 0)
            bad = cmd_parse_double(v, o, 0.0, 5.0, &cfg.clearance_m);
        else if (strcmp(o, "--res") == 0)
            bad = cmd_parse_double(v, o, 0.005, 1.0, &cfg.res_m);
        else if (strcmp(o, "--sweep") == 0)
            bad = cmd_parse_double(v, o, 0.1, 100.0, &cfg.sweep_m);
        else if (strcmp(o, "--scale") == 0)
            bad = cmd_parse_double(v, o, 1e-6, 100.0, &scale);
        else {
            fprintf(stderr, "host_sim paths gen: unknown option '%s'\n", o);
            return 2;
        }
        if (bad)
            return 2;
    }
    if (plan_file == NULL || out == NULL || robots < 0 || seed < 0) {
        fprintf(stderr, "host_sim paths gen: --plan, --robots, --seed and --out are required\n");
        paths_usage(stderr);
        return 2;
    }
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
    printf("plan %s, %d robots, seed %lld, clearance %g m, grid %g m, sweep %g m -> %s/robot_*.csv\n", plan_file,
           cfg.n_robots, seed, cfg.clearance_m, cfg.res_m, cfg.sweep_m, out);
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
    const char *plan_file = NULL, *png = NULL;
    double scale = SIM_PLAN_DEFAULT_SCALE;
    sim_paths_cfg_t defaults;
    sim_paths_cfg_default(&defaults);
    double clearance = defaults.clearance_m;
    int first_csv = -1;
    for (int i = 1; i < argc; i++) {
        const char *o = argv[i];
        if (strcmp(o, "--help") == 0 || strcmp(o, "-h") == 0) {
            paths_usage(stdout);
            return 0;
        }
        if (o[0] != '-') {
            if (first_csv < 0)
                first_csv = i;
            continue;
        }
        if (first_csv >= 0) {
            fprintf(stderr, "host_sim paths check: options must come before the CSV files ('%s')\n", o);
            return 2;
        }
        if (cmd_need_value(argc, argv, i, "paths check", paths_usage) != 0)
            return 2;
        const char *v = argv[++i];
        if (strcmp(o, "--plan") == 0)
            plan_file = v;
        else if (strcmp(o, "--png") == 0)
            png = v;
        else if (strcmp(o, "--scale") == 0) {
            if (cmd_parse_double(v, o, 1e-6, 100.0, &scale) != 0)
                return 2;
        } else if (strcmp(o, "--clearance") == 0) {
            if (cmd_parse_double(v, o, 0.0, 10.0, &clearance) != 0)
                return 2;
        } else {
            fprintf(stderr, "host_sim paths check: unknown option '%s'\n", o);
            return 2;
        }
    }
    if (plan_file == NULL || first_csv < 0) {
        fprintf(stderr, "host_sim paths check: --plan and at least one CSV are required\n");
        paths_usage(stderr);
        return 2;
    }
    int n = argc - first_csv;
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
        if (sim_path_read_csv(argv[first_csv + loaded], &plan, &paths[loaded], err, sizeof err) != 0) {
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
                    argv[first_csv + k], p->line ? p->line[seg + 1] : 0, p->p[seg].x, p->p[seg].y,
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
    if (strcmp(sub, "gen") == 0)
        return paths_gen(argc - 1, argv + 1);
    if (strcmp(sub, "check") == 0)
        return paths_check(argc - 1, argv + 1);
    fprintf(stderr, "host_sim paths: unknown sub-command '%s'\n\n", sub);
    paths_usage(stderr);
    return 2;
}
