/* Railings (CubiCasa5K's <g class="Railing">) on tests/sim/plans/balcony.svg, a room with a
 * balcony bounded by railings only: they are read, become solids of their own height, bring
 * the balcony into the bounding box and the ground truth (their cells walls), stop a lidar
 * ray below their top and not one above it, and the tour planner keeps clear of them. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "sim_grid.h"
#include "sim_lidar.h"
#include "sim_paths.h"
#include "sim_plan.h"
#include "sim_world.h"

#define BALCONY "tests/sim/plans/balcony.svg"
#define PI 3.14159265358979323846

static void load(sim_plan_t *p)
{
    char err[256];
    if (sim_plan_load(BALCONY, 0.0, p, err, sizeof err) != 0)
        fail_msg("%s", err);
}

static int cell_at(const sim_grid_t *g, double x, double y)
{
    int c, r;
    assert_int_equal(sim_grid_world_to_cell(g, x, y, &c, &r), 0);
    return sim_grid_at(g, c, r);
}

static void test_railings_read_as_low_solids(void **state)
{
    (void)state;
    sim_plan_t p;
    load(&p);
    assert_int_equal(p.n_walls, 4);
    assert_int_equal(p.n_railings, 3);
    assert_string_equal(p.railings[0].id, "Railing_W");
    assert_string_equal(p.railings[2].id, "Railing_S");
    assert_int_equal(p.railings[2].line, 25);
    assert_int_equal(p.railings[2].col, 39);
    assert_int_equal(p.n_rooms, 2);
    assert_string_equal(p.rooms[1].type, "Outdoor");
    /* The walls end at y = 3.2 m; the railings take the box to the balcony's edge. */
    assert_true(fabs(p.min.x) < 1e-12 && fabs(p.min.y) < 1e-12);
    assert_true(fabs(p.max.x - 4.2) < 1e-12 && fabs(p.max.y - 5.0) < 1e-12);
    /* 4 walls, the south one cut by its door into 2, then the 3 railings, whole. */
    assert_int_equal(p.n_solids, 5 + 3);
    for (int i = 0; i < p.n_solids; i++) {
        assert_int_equal(p.solids[i].is_rect, 1);
        assert_true(p.solids[i].height == (i < 5 ? 0.0 : SIM_PLAN_RAILING_HEIGHT));
    }
    assert_memory_equal(&p.solids[7].outline, &p.railings[2].outline, sizeof p.railings[2].outline);
    assert_int_equal(sim_plan_classify_point(&p, 2.0, 4.975), SIM_CELL_WALL);
    assert_int_equal(sim_plan_classify_point(&p, 2.0, 4.0), SIM_CELL_FREE);
    sim_plan_free(&p);
    assert_null(p.railings);
    assert_int_equal(p.n_railings, 0);

    /* A railing group must have its polygon, like any group we read. */
    sim_plan_t q;
    char err[256];
    const char *t = "<svg>\n<g class=\"Wall\"><polygon points=\"0,0 100,0 100,10 0,10\"/></g>\n"
                    "<g id=\"R\" class=\"Railing\"/>\n</svg>\n";
    assert_int_equal(sim_plan_parse(t, "r.svg", 0.0, &q, err, sizeof err), -EINVAL);
    assert_string_equal(err, "r.svg:3:1: g id=\"R\": Railing group has no polygon");
    /* Railings alone are no plan. */
    t = "<svg>\n<g class=\"Railing\"><polygon points=\"0,0 100,0 100,10 0,10\"/></g>\n</svg>\n";
    assert_int_equal(sim_plan_parse(t, "r.svg", 0.0, &q, err, sizeof err), -EINVAL);
    assert_non_null(strstr(err, "no walls"));
}

/* The balcony is in the ground truth, free, bounded by wall cells; without its railings (the
 * same file with their class renamed) it falls outside the walls' box and out of the grid. */
static void test_balcony_in_ground_truth(void **state)
{
    (void)state;
    sim_plan_t p;
    load(&p);
    sim_grid_t g;
    assert_int_equal(sim_grid_from_plan(&p, 0.025, &g), 0); /* half the railings' 5 cm */
    assert_int_equal(g.h, 200);
    assert_int_equal(cell_at(&g, 2.0, 4.0), SIM_CELL_FREE);  /* balcony */
    assert_int_equal(cell_at(&g, 1.9, 3.1), SIM_CELL_FREE);  /* its door */
    assert_int_equal(cell_at(&g, 2.0, 4.97), SIM_CELL_WALL); /* south railing */
    assert_int_equal(cell_at(&g, 0.17, 4.0), SIM_CELL_WALL); /* west railing */
    assert_int_equal(cell_at(&g, 4.03, 4.0), SIM_CELL_WALL); /* east railing */
    /* Closed: along every column across the balcony the last row is a railing. */
    for (int c = 0; c < g.w; c++) {
        double x, y;
        sim_grid_cell_centre(&g, c, g.h - 1, &x, &y);
        if (x > 0.15 && x < 4.05)
            assert_int_equal(sim_grid_at(&g, c, g.h - 1), SIM_CELL_WALL);
    }
    sim_grid_free(&g);
    sim_plan_free(&p);

    FILE *f = fopen(BALCONY, "rb");
    assert_non_null(f);
    static char text[1 << 14];
    size_t len = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    text[len] = '\0';
    int renamed = 0;
    for (char *r = text; (r = strstr(r, "class=\"Railing\"")) != NULL; renamed++)
        memcpy(r, "class=\"Fencing\"", 15);
    assert_int_equal(renamed, 3);
    char err[256];
    assert_int_equal(sim_plan_parse(text, "fence.svg", 0.0, &p, err, sizeof err), 0);
    assert_int_equal(p.n_railings, 0);
    assert_true(fabs(p.max.y - 3.2) < 1e-12);
    assert_int_equal(sim_grid_from_plan(&p, 0.025, &g), 0);
    int c, r;
    assert_int_equal(sim_grid_world_to_cell(&g, 2.0, 4.0, &c, &r), -ERANGE);
    sim_grid_free(&g);
    sim_plan_free(&p);
}

/* In the ODE world a railing is a 1 m solid: a ray at the lidar's 0.17 m hits it, a ray at
 * 1.5 m passes over it (and still hits the 2.5 m walls). */
static void test_lidar_hits_railing_below_its_top(void **state)
{
    (void)state;
    sim_plan_t p;
    load(&p);
    sim_world_t *w;
    char err[256];
    assert_int_equal(sim_world_create(&p, NULL, &w, err, sizeof err), 0);
    sim_lidar_cfg_t low = sim_lidar_default_cfg(), high = low;
    assert_true(low.mount_height < SIM_PLAN_RAILING_HEIGHT);
    high.mount_height = 1.5;
    sim_lidar_t *ll, *lh;
    assert_int_equal(sim_lidar_create(&low, &ll), 0);
    assert_int_equal(sim_lidar_create(&high, &lh), 0);
    /* South (+y) to the south railing's face at y = 4.95, east to the east railing at 4.0. */
    assert_true(fabs(sim_lidar_cast(ll, w, 2.1, 4.0, PI / 2) - 0.95) < 1e-9);
    assert_true(fabs(sim_lidar_cast(ll, w, 3.0, 4.0, 0.0) - 1.0) < 1e-9);
    assert_true(isinf(sim_lidar_cast(lh, w, 2.1, 4.0, PI / 2)));
    assert_true(isinf(sim_lidar_cast(lh, w, 3.0, 4.0, 0.0)));
    /* North (-y), beside the door, to the room's south wall at y = 3.2: at both heights. */
    assert_true(fabs(sim_lidar_cast(ll, w, 3.0, 4.0, -PI / 2) - 0.8) < 1e-9);
    assert_true(fabs(sim_lidar_cast(lh, w, 3.0, 4.0, -PI / 2) - 0.8) < 1e-9);
    /* Walls lower than the railings (a cut-away world): the railings are no higher. */
    sim_world_cfg_t cut = sim_world_default_cfg();
    cut.wall_height = 0.5;
    sim_world_t *w2;
    assert_int_equal(sim_world_create(&p, &cut, &w2, err, sizeof err), 0);
    sim_lidar_cfg_t mid = low;
    mid.mount_height = 0.7;
    sim_lidar_t *lm;
    assert_int_equal(sim_lidar_create(&mid, &lm), 0);
    assert_true(isinf(sim_lidar_cast(lm, w2, 2.1, 4.0, PI / 2)));
    sim_lidar_destroy(lm);
    sim_world_destroy(w2);
    sim_lidar_destroy(ll);
    sim_lidar_destroy(lh);
    sim_world_destroy(w);
    sim_plan_free(&p);
}

/* Two robots, one starting on the balcony: every tour keeps its clearance from the railings
 * as from the walls, and the balcony is toured. */
static void test_tours_keep_clear_of_railings(void **state)
{
    (void)state;
    sim_plan_t p;
    load(&p);
    sim_paths_cfg_t cfg;
    sim_paths_cfg_default(&cfg);
    cfg.n_robots = 2;
    cfg.seed = 1;
    sim_path_t paths[2];
    char err[256];
    if (sim_paths_generate(&p, &cfg, paths, err, sizeof err) != 0)
        fail_msg("%s", err);
    int on_balcony = 0;
    for (int k = 0; k < 2; k++) {
        assert_true(sim_path_min_clearance(&p, &paths[k]) >= cfg.clearance_m - 1e-9);
        for (int i = 0; i < paths[k].n; i++)
            on_balcony += paths[k].p[i].y > 3.2;
    }
    assert_true(on_balcony > 0);
    for (int k = 0; k < 2; k++)
        sim_path_free(&paths[k]);
    sim_plan_free(&p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_railings_read_as_low_solids),
        cmocka_unit_test(test_balcony_in_ground_truth),
        cmocka_unit_test(test_lidar_hits_railing_below_its_top),
        cmocka_unit_test(test_tours_keep_clear_of_railings),
    };
    return cmocka_run_group_tests_name("sim/railing", tests, NULL, NULL);
}
