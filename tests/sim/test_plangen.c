/* Procedural plans: every generated file parses with the expected structure, is
 * deterministic per seed, and many of them admit collision-free tours. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "sim_grid.h"
#include "sim_paths.h"
#include "sim_plan.h"
#include "sim_plangen.h"

static int in_door(const sim_plan_t *p, const sim_grid_t *g, int c, int r)
{
    double x, y;
    sim_grid_cell_centre(g, c, r, &x, &y);
    for (int i = 0; i < p->n_openings; i++)
        if (p->openings[i].kind == SIM_OPENING_DOOR && sim_poly_contains(&p->openings[i].outline, x, y))
            return 1;
    return 0;
}

static void test_round_trip_many_seeds(void **state)
{
    (void)state;
    for (unsigned long seed = 0; seed < 300; seed++) {
        int rooms = SIM_PLANGEN_MIN_ROOMS + (int)(seed % (SIM_PLANGEN_MAX_ROOMS - SIM_PLANGEN_MIN_ROOMS + 1));
        char *svg = NULL;
        assert_int_equal(sim_plangen_svg(seed, rooms, &svg), 0);
        sim_plan_t p;
        char err[256];
        if (sim_plan_parse(svg, "gen.svg", 0.0, &p, err, sizeof err) != 0)
            fail_msg("seed %lu rooms %d: %s", seed, rooms, err);
        assert_int_equal(p.n_rooms, rooms + 1);
        int doors = 0, windows = 0, halls = 0;
        for (int i = 0; i < p.n_openings; i++) {
            const sim_poly_t *o = &p.openings[i].outline;
            double a = fabs(o->p[1].x - o->p[0].x) + fabs(o->p[1].y - o->p[0].y);
            double b = fabs(o->p[2].x - o->p[1].x) + fabs(o->p[2].y - o->p[1].y);
            if (p.openings[i].kind == SIM_OPENING_DOOR) {
                doors++;
                assert_true(fmax(a, b) >= 0.8 - 1e-9);
            } else {
                windows++;
            }
        }
        for (int i = 0; i < p.n_rooms; i++)
            halls += strcmp(p.rooms[i].type, "Hall") == 0;
        assert_int_equal(halls, 1);
        assert_true(doors >= rooms + 1); /* one per room and the entrance */
        assert_int_equal(windows, rooms);
        for (int i = 0; i < p.n_solids; i++)
            assert_int_equal(p.solids[i].is_rect, 1);
        /* The building is closed: no FREE cell next to an OUTSIDE cell except at the entrance. */
        sim_grid_t g;
        assert_int_equal(sim_grid_from_plan(&p, 0.05, &g), 0);
        int leaks = 0;
        for (int r = 0; r < g.h; r++)
            for (int c = 0; c < g.w; c++)
                if (sim_grid_at(&g, c, r) == SIM_CELL_FREE && !in_door(&p, &g, c, r))
                    for (int k = 0; k < 4; k++)
                        leaks += sim_grid_at(&g, c + (k == 0) - (k == 1), r + (k == 2) - (k == 3)) == SIM_CELL_OUTSIDE;
        assert_int_equal(leaks, 0);
        sim_grid_free(&g);
        sim_plan_free(&p);
        free(svg);
    }
}

static void test_deterministic(void **state)
{
    (void)state;
    char *a = NULL, *b = NULL, *c = NULL;
    assert_int_equal(sim_plangen_svg(42, 6, &a), 0);
    assert_int_equal(sim_plangen_svg(42, 6, &b), 0);
    assert_int_equal(sim_plangen_svg(43, 6, &c), 0);
    assert_string_equal(a, b);
    assert_true(strcmp(a, c) != 0);
    free(a);
    free(b);
    free(c);
    alloc_count_reset();
    assert_int_equal(sim_plangen_svg(1, SIM_PLANGEN_MIN_ROOMS - 1, &a), -EINVAL);
    assert_null(a);
    assert_int_equal(sim_plangen_svg(1, SIM_PLANGEN_MAX_ROOMS + 1, &a), -EINVAL);
    assert_int_equal(sim_plangen_svg(1, 4, NULL), -EINVAL);
    assert_int_equal(alloc_count_allocations(), 0); /* rejected before any allocation */
}

static void test_write_file(void **state)
{
    (void)state;
    char dir[] = "/tmp/test_plangen_XXXXXX", file[64], err[256];
    assert_non_null(mkdtemp(dir));
    snprintf(file, sizeof file, "%s/p.svg", dir);
    assert_int_equal(sim_plangen_write(file, 7, 5, err, sizeof err), 0);
    sim_plan_t p;
    assert_int_equal(sim_plan_load(file, 0.0, &p, err, sizeof err), 0);
    assert_int_equal(p.n_rooms, 6);
    sim_plan_free(&p);
    unlink(file);
    rmdir(dir);
    assert_true(sim_plangen_write("/dev/null/p.svg", 7, 5, err, sizeof err) < 0);
    assert_non_null(strstr(err, "/dev/null/p.svg: Not a directory"));
}

/* Generated plans are navigable: tours for several robots with clearance and coverage. */
static void test_generated_plans_have_tours(void **state)
{
    (void)state;
    for (unsigned long seed = 100; seed < 108; seed++) {
        int rooms = 3 + (int)(seed % 6);
        char *svg = NULL;
        assert_int_equal(sim_plangen_svg(seed, rooms, &svg), 0);
        sim_plan_t p;
        char err[256];
        assert_int_equal(sim_plan_parse(svg, "gen.svg", 0.0, &p, err, sizeof err), 0);
        free(svg);
        sim_paths_cfg_t cfg;
        sim_paths_cfg_default(&cfg);
        cfg.n_robots = 3;
        cfg.seed = seed;
        sim_path_t paths[3];
        if (sim_paths_generate(&p, &cfg, paths, err, sizeof err) != 0)
            fail_msg("seed %lu: %s", seed, err);
        sim_grid_t g;
        assert_int_equal(sim_grid_from_plan(&p, 0.05, &g), 0);
        double cov = sim_paths_coverage(&g, paths, 3, 1.5);
        if (cov < 0.9)
            fail_msg("seed %lu: coverage %.3f", seed, cov);
        for (int r = 0; r < 3; r++) {
            assert_true(sim_path_min_clearance(&p, &paths[r]) >= cfg.clearance_m);
            sim_path_free(&paths[r]);
        }
        sim_grid_free(&g);
        sim_plan_free(&p);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip_many_seeds),
        cmocka_unit_test(test_deterministic),
        cmocka_unit_test(test_write_file),
        cmocka_unit_test(test_generated_plans_have_tours),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
