/* host_sim plan: floor-plan tools (check, gen, grid). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "commands.h"
#include "sim_grid.h"
#include "sim_plan.h"
#include "sim_plangen.h"

static void plan_usage(FILE *out)
{
    fprintf(out,
            "usage: host_sim plan <check|gen|grid> ... \n"
            "\n"
            "  host_sim plan check FILE [--scale S]\n"
            "      parse a floor plan (CubiCasa5K model.svg structure), print its size in metres,\n"
            "      walls, rooms with their types, openings and solids; exit 1 with FILE:LINE:COL: reason\n"
            "      (FILE: reason when the file cannot be read); an opening over no wall is a\n"
            "      FILE:LINE:COL: warning on stderr (the plan still loads)\n"
            "  host_sim plan gen --seed N --out FILE [--rooms R]\n"
            "      write a procedural floor plan (R rooms besides the corridor, %d..%d, default 6)\n"
            "  host_sim plan grid FILE --res M --out FILE.png|FILE.pgm [--scale S]\n"
            "      write the ground-truth occupancy raster (M metres per cell): free white,\n"
            "      wall black, outside the building grey\n"
            "\n"
            "  --scale S   metres per SVG pixel (default %g)\n",
            SIM_PLANGEN_MIN_ROOMS, SIM_PLANGEN_MAX_ROOMS, SIM_PLAN_DEFAULT_SCALE);
}

static int plan_check(int argc, char **argv)
{
    const char *file = NULL;
    double scale = SIM_PLAN_DEFAULT_SCALE;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            plan_usage(stdout);
            return 0;
        } else if (strcmp(argv[i], "--scale") == 0) {
            if (cmd_need_value(argc, argv, i, "plan check", plan_usage) != 0 ||
                cmd_parse_double(argv[i + 1], "--scale", 1e-6, 100.0, &scale) != 0)
                return 2;
            i++;
        } else if (argv[i][0] == '-') {
            fprintf(stderr, "host_sim plan check: unknown option '%s'\n", argv[i]);
            return 2;
        } else if (file == NULL) {
            file = argv[i];
        } else {
            fprintf(stderr, "host_sim plan check: more than one FILE ('%s')\n", argv[i]);
            return 2;
        }
    }
    if (file == NULL) {
        fprintf(stderr, "host_sim plan check: FILE missing\n");
        plan_usage(stderr);
        return 2;
    }
    sim_plan_t plan;
    char err[8192];
    if (sim_plan_load(file, scale, &plan, err, sizeof err) != 0) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    int doors = 0, windows = 0, rects = 0;
    for (int i = 0; i < plan.n_openings; i++)
        if (plan.openings[i].kind == SIM_OPENING_DOOR)
            doors++;
        else
            windows++;
    for (int i = 0; i < plan.n_solids; i++)
        rects += plan.solids[i].is_rect;
    printf("plan %s (scale %g m/px)\n", file, plan.scale);
    printf("size: %.2f x %.2f m (x %.2f..%.2f, y %.2f..%.2f)\n", plan.max.x - plan.min.x,
           plan.max.y - plan.min.y, plan.min.x, plan.max.x, plan.min.y, plan.max.y);
    printf("walls: %d\n", plan.n_walls);
    printf("rooms: %d\n", plan.n_rooms);
    for (int i = 0; i < plan.n_rooms; i++) {
        const sim_room_t *r = &plan.rooms[i];
        printf("  room %d: %-12s area %6.2f m^2 (at %d:%d%s%s%s)\n", i, r->type,
               fabs(sim_poly_signed_area(&r->outline)), r->line, r->col, r->id[0] ? ", id \"" : "", r->id,
               r->id[0] ? "\"" : "");
    }
    printf("openings: %d (doors %d, windows %d)\n", plan.n_openings, doors, windows);
    printf("solids: %d (rectangles %d)\n", plan.n_solids, rects);
    sim_plan_free(&plan);
    return 0;
}

static int plan_gen(int argc, char **argv)
{
    const char *out = NULL;
    long long seed = -1;
    int rooms = 6;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            plan_usage(stdout);
            return 0;
        } else if (strcmp(argv[i], "--seed") == 0) {
            if (cmd_need_value(argc, argv, i, "plan gen", plan_usage) != 0 ||
                cmd_parse_ll(argv[i + 1], "--seed", 0, 0xFFFFFFFFLL, &seed) != 0)
                return 2;
            i++;
        } else if (strcmp(argv[i], "--out") == 0) {
            if (cmd_need_value(argc, argv, i, "plan gen", plan_usage) != 0)
                return 2;
            out = argv[++i];
        } else if (strcmp(argv[i], "--rooms") == 0) {
            long long r;
            if (cmd_need_value(argc, argv, i, "plan gen", plan_usage) != 0 ||
                cmd_parse_ll(argv[i + 1], "--rooms", SIM_PLANGEN_MIN_ROOMS, SIM_PLANGEN_MAX_ROOMS, &r) != 0)
                return 2;
            rooms = (int)r;
            i++;
        } else {
            fprintf(stderr, "host_sim plan gen: unknown argument '%s'\n", argv[i]);
            return 2;
        }
    }
    if (seed < 0 || out == NULL) {
        fprintf(stderr, "host_sim plan gen: --seed and --out are required\n");
        plan_usage(stderr);
        return 2;
    }
    char err[8192];
    int rc = sim_plangen_write(out, (unsigned long)seed, rooms, err, sizeof err);
    if (rc != 0) {
        fprintf(stderr, "host_sim plan gen: %s\n", err);
        return 1;
    }
    printf("wrote %s (seed %lld, %d rooms + corridor)\n", out, seed, rooms);
    return 0;
}

static int plan_grid(int argc, char **argv)
{
    const char *file = NULL, *out = NULL;
    double scale = SIM_PLAN_DEFAULT_SCALE, res = -1.0;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            plan_usage(stdout);
            return 0;
        } else if (strcmp(argv[i], "--scale") == 0) {
            if (cmd_need_value(argc, argv, i, "plan grid", plan_usage) != 0 ||
                cmd_parse_double(argv[i + 1], "--scale", 1e-6, 100.0, &scale) != 0)
                return 2;
            i++;
        } else if (strcmp(argv[i], "--res") == 0) {
            if (cmd_need_value(argc, argv, i, "plan grid", plan_usage) != 0 ||
                cmd_parse_double(argv[i + 1], "--res", 0.005, 10.0, &res) != 0)
                return 2;
            i++;
        } else if (strcmp(argv[i], "--out") == 0) {
            if (cmd_need_value(argc, argv, i, "plan grid", plan_usage) != 0)
                return 2;
            out = argv[++i];
        } else if (argv[i][0] == '-') {
            fprintf(stderr, "host_sim plan grid: unknown option '%s'\n", argv[i]);
            return 2;
        } else if (file == NULL) {
            file = argv[i];
        } else {
            fprintf(stderr, "host_sim plan grid: more than one FILE ('%s')\n", argv[i]);
            return 2;
        }
    }
    if (file == NULL || out == NULL || res < 0) {
        fprintf(stderr, "host_sim plan grid: FILE, --res and --out are required\n");
        plan_usage(stderr);
        return 2;
    }
    sim_plan_t plan;
    char err[8192];
    if (sim_plan_load(file, scale, &plan, err, sizeof err) != 0) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    sim_grid_t grid;
    int rc = sim_grid_from_plan(&plan, res, &grid);
    sim_plan_free(&plan);
    if (rc != 0) {
        fprintf(stderr, "host_sim plan grid: cannot rasterise at %g m: %s\n", res, strerror(-rc));
        return 1;
    }
    rc = sim_grid_write_image(&grid, out, err, sizeof err);
    if (rc != 0) {
        fprintf(stderr, "host_sim plan grid: %s\n", err);
        sim_grid_free(&grid);
        return 1;
    }
    long counts[3] = {0, 0, 0};
    for (long i = 0; i < (long)grid.w * grid.h; i++)
        counts[grid.cells[i]]++;
    printf("wrote %s: %d x %d cells of %g m (free %ld, wall %ld, outside %ld)\n", out, grid.w, grid.h,
           grid.res, counts[SIM_CELL_FREE], counts[SIM_CELL_WALL], counts[SIM_CELL_OUTSIDE]);
    sim_grid_free(&grid);
    return 0;
}

int cmd_plan(int argc, char **argv)
{
    if (argc < 2) {
        plan_usage(stderr);
        return 2;
    }
    const char *sub = argv[1];
    if (strcmp(sub, "--help") == 0 || strcmp(sub, "-h") == 0 || strcmp(sub, "help") == 0) {
        plan_usage(stdout);
        return 0;
    }
    if (strcmp(sub, "check") == 0)
        return plan_check(argc - 1, argv + 1);
    if (strcmp(sub, "gen") == 0)
        return plan_gen(argc - 1, argv + 1);
    if (strcmp(sub, "grid") == 0)
        return plan_grid(argc - 1, argv + 1);
    fprintf(stderr, "host_sim plan: unknown sub-command '%s'\n\n", sub);
    plan_usage(stderr);
    return 2;
}
