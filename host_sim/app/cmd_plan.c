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

typedef struct plan_opts {
    const char *out;
    double scale, res;
    long long seed, rooms;
} plan_opts_t;

static plan_opts_t plan_defaults(void)
{
    return (plan_opts_t){.scale = SIM_PLAN_DEFAULT_SCALE, .res = -1.0, .seed = -1, .rooms = 6};
}

#define PLAN_SCALE_OPT \
    {.names = "--scale", .meta = "S", CLI_DOUBLE(plan_opts_t, scale, 1e-6, 100.0), .help = "metres per SVG pixel"}

static const cli_opt_t plan_check_opts[] = {PLAN_SCALE_OPT, CLI_OPT_END};

static const cli_opt_t plan_gen_opts[] = {
    {.names = "--seed", .meta = "N", CLI_INT(plan_opts_t, seed, 0, 0xFFFFFFFFLL), .required = 1,
     .help = "the plan's seed"},
    {.names = "--out", .meta = "FILE", CLI_STRING(plan_opts_t, out), .required = 1, .help = "the SVG written"},
    {.names = "--rooms", .meta = "R", CLI_INT(plan_opts_t, rooms, SIM_PLANGEN_MIN_ROOMS, SIM_PLANGEN_MAX_ROOMS),
     .help = "rooms besides the corridors (more than 16: wings off a spine)"},
    CLI_OPT_END,
};

static const cli_opt_t plan_grid_opts[] = {
    {.names = "--res", .meta = "M", CLI_DOUBLE(plan_opts_t, res, 0.005, 10.0), .required = 1,
     .help = "metres per cell"},
    {.names = "--out", .meta = "FILE.png|FILE.pgm", CLI_STRING(plan_opts_t, out), .required = 1,
     .help = "the raster written"},
    PLAN_SCALE_OPT,
    CLI_OPT_END,
};

static void plan_usage(FILE *out)
{
    const plan_opts_t d = plan_defaults();
    fprintf(out,
            "usage: host_sim plan <check|gen|grid> ... \n"
            "\n"
            "  host_sim plan check FILE [--scale S]\n"
            "      parse a floor plan (CubiCasa5K model.svg structure), print its size in metres,\n"
            "      walls, rooms with their types, openings and solids; exit 1 with FILE:LINE:COL: reason\n"
            "      (FILE: reason when the file cannot be read); an opening over no wall is a\n"
            "      FILE:LINE:COL: warning on stderr (the plan still loads)\n"
            "  host_sim plan gen --seed N --out FILE [--rooms R]\n"
            "      write a procedural floor plan (R rooms besides the corridors, %d..%d): one\n"
            "      corridor with a row of rooms on each side, or, beyond %d rooms, such bands as the\n"
            "      wings of an office, their corridors joined by a spine corridor\n"
            "  host_sim plan grid FILE --res M --out FILE.png|FILE.pgm [--scale S]\n"
            "      write the ground-truth occupancy raster (M metres per cell): free white,\n"
            "      wall black, outside the building grey\n"
            "\n"
            "options of plan check:\n",
            SIM_PLANGEN_MIN_ROOMS, SIM_PLANGEN_MAX_ROOMS, SIM_PLANGEN_BAND_ROOMS);
    cli_opts_help(out, plan_check_opts, &d);
    fprintf(out, "options of plan gen:\n");
    cli_opts_help(out, plan_gen_opts, &d);
    fprintf(out, "options of plan grid:\n");
    cli_opts_help(out, plan_grid_opts, &d);
}

/* FILE, the one operand of check and grid. */
static int one_file(const char *cmd, char **ops, int n, const char **file)
{
    if (n > 1) {
        fprintf(stderr, "host_sim %s: more than one FILE ('%s')\n", cmd, ops[1]);
        return -1;
    }
    if (n == 0) {
        fprintf(stderr, "host_sim %s: FILE missing (see --help)\n", cmd);
        return -1;
    }
    *file = ops[0];
    return 0;
}

static int plan_check(int argc, char **argv)
{
    plan_opts_t o = plan_defaults();
    char *ops[argc > 0 ? argc : 1];
    int n_ops = 0;
    const cli_parser_t parser = {.cmd = "plan check", .opts = plan_check_opts, .usage = plan_usage, .operands = "FILE"};
    const int pr = cli_opts_parse(&parser, argc, argv, &o, ops, &n_ops);
    if (pr != 0)
        return pr > 0 ? 0 : 2;
    const char *file = NULL;
    if (one_file("plan check", ops, n_ops, &file) != 0)
        return 2;
    const double scale = o.scale;
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
    plan_opts_t o = plan_defaults();
    const cli_parser_t parser = {.cmd = "plan gen", .opts = plan_gen_opts, .usage = plan_usage};
    const int pr = cli_opts_parse(&parser, argc, argv, &o, NULL, NULL);
    if (pr != 0)
        return pr > 0 ? 0 : 2;
    const char *out = o.out;
    const long long seed = o.seed;
    const int rooms = (int)o.rooms;
    char err[8192];
    int rc = sim_plangen_write(out, (unsigned long)seed, rooms, err, sizeof err);
    if (rc != 0) {
        fprintf(stderr, "host_sim plan gen: %s\n", err);
        return 1;
    }
    if (rooms <= SIM_PLANGEN_BAND_ROOMS)
        printf("wrote %s (seed %lld, %d rooms + corridor)\n", out, seed, rooms);
    else
        printf("wrote %s (seed %lld, %d rooms in %d wings + their corridors and a spine)\n", out, seed, rooms,
               (rooms + SIM_PLANGEN_BAND_ROOMS - 1) / SIM_PLANGEN_BAND_ROOMS);
    return 0;
}

static int plan_grid(int argc, char **argv)
{
    plan_opts_t o = plan_defaults();
    char *ops[argc > 0 ? argc : 1];
    int n_ops = 0;
    const cli_parser_t parser = {.cmd = "plan grid", .opts = plan_grid_opts, .usage = plan_usage, .operands = "FILE"};
    const int pr = cli_opts_parse(&parser, argc, argv, &o, ops, &n_ops);
    if (pr != 0)
        return pr > 0 ? 0 : 2;
    const char *file = NULL, *out = o.out;
    if (one_file("plan grid", ops, n_ops, &file) != 0)
        return 2;
    if (cmd_check_out_ext("plan grid", "--out", out, ".png|.pgm", "a PNG or PGM image") != 0)
        return 2;
    const double scale = o.scale, res = o.res;
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
    if (strcmp(sub, "--version") == 0) {
        cli_version(stdout);
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
