/* The RT core's planner on grids rasterised from real floor plans (host_sim/plans/apartment.svg,
 * a generated plan, the 64-room office pooled to 0.2 m cells): for many start/goal pairs of
 * allowed cells, a path exists exactly when a brute-force flood fill of the allowed cells
 * connects them (else -ENOENT); every path keeps the required clearance at every 1 cm from
 * the FINE ground-truth raster (walls and outside, 0.05 m), starts and ends at the asked cells,
 * and comes out the same twice. */
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

#include "rt_plan_test_util.h"
#include "sim_grid.h"
#include "sim_plan.h"
#include "sim_plangen.h"

static rt_grid_t grid;
static rt_plan_workspace_t ws;
static rt_plan_result_t res, again;
static uint8_t obst[RT_GRID_MAX_CELLS], allow[RT_GRID_MAX_CELLS];
static int32_t label[RT_GRID_MAX_CELLS], queue[RT_GRID_MAX_CELLS], cells[RT_GRID_MAX_CELLS];

/* The belief grid a perfect map would give: k x k fine cells per cell (the smallest k that
 * fits RT_GRID_MAX_CELLS), occupied when any of them is a wall or outside. Pooling only grows
 * obstacles, so clearance on this grid is clearance on the fine one. */
static int grid_from_sim(const sim_grid_t *sg)
{
    int k = 1;
    while (((sg->w + k - 1) / k) * ((sg->h + k - 1) / k) > RT_GRID_MAX_CELLS)
        k++;
    int w = (sg->w + k - 1) / k, h = (sg->h + k - 1) / k;
    assert_int_equal(rt_grid_init(&grid, (float)(sg->res * k), (float)sg->origin.x,
                                  (float)sg->origin.y, w, h),
                     0);
    for (int r = 0; r < h; r++)
        for (int c = 0; c < w; c++) {
            int occ = 0;
            for (int rr = r * k; rr < r * k + k; rr++)
                for (int cc = c * k; cc < c * k + k; cc++)
                    occ |= sim_grid_at(sg, cc, rr) != SIM_CELL_FREE;
            assert_int_equal(rt_grid_set(&grid, c, r, occ ? 255 : 0, 255), 0);
        }
    return k;
}

static void check_plan(const char *name, const sim_plan_t *plan, int pairs, int min_found)
{
    sim_grid_t fine;
    assert_int_equal(sim_grid_from_plan(plan, 0.05, &fine), 0);
    int k = grid_from_sim(&fine);
    uint8_t *fine_obst = malloc((size_t)fine.w * fine.h);
    assert_non_null(fine_obst);
    for (int i = 0; i < fine.w * fine.h; i++)
        fine_obst[i] = fine.cells[i] != SIM_CELL_FREE;
    pt_truth_t truth = {fine.w, fine.h, fine.res, fine.origin.x, fine.origin.y, fine_obst};

    rt_plan_cfg_t cfg = rt_plan_default_cfg();
    const double R = cfg.robot_radius_m + cfg.margin_m;
    pt_obstacles(&grid, &cfg, obst);
    pt_allowed(&grid, &cfg, obst, allow);
    pt_components(grid.w, grid.h, allow, label, queue);
    /* The planner's transform agrees with the brute-force rule on every cell. */
    assert_int_equal(rt_plan_clearance(&grid, &cfg, &ws), 0);
    double band = R / grid.res + 1.41421356237309504880;
    int n_allowed = 0;
    for (int i = 0; i < grid.w * grid.h; i++) {
        assert_int_equal((double)ws.clear2[i] >= band * band, allow[i]);
        if (allow[i])
            cells[n_allowed++] = i;
    }
    assert_true(n_allowed > 100);

    uint32_t s = 2024u;
    int found = 0, refused = 0, max_wps = 0;
    long expanded = 0;
    for (int i = 0; i < pairs; i++) {
        s = s * 1664525u + 1013904223u;
        int a = cells[(s >> 8) % (uint32_t)n_allowed];
        s = s * 1664525u + 1013904223u;
        int b = cells[(s >> 8) % (uint32_t)n_allowed];
        float sx, sy, gx, gy;
        rt_grid_cell_centre(&grid, a % grid.w, a / grid.w, &sx, &sy);
        rt_grid_cell_centre(&grid, b % grid.w, b / grid.w, &gx, &gy);
        int r = rt_plan_path(&grid, &cfg, sx, sy, gx, gy, &ws, &res);
        if (label[a] != label[b]) {
            assert_int_equal(r, -ENOENT);
            refused++;
            continue;
        }
        if (r != 0)
            fail_msg("%s: no path (%d) between connected cells %d and %d", name, r, a, b);
        assert_int_equal(res.flags, 0);
        double lowest = pt_check_path(&grid, &res, a % grid.w, a / grid.w, b % grid.w,
                                      b / grid.w, &truth, R);
        if (lowest < 0)
            fail_msg("%s: path %d -> %d breaks the clearance or its ends", name, a, b);
        assert_int_equal(rt_plan_path(&grid, &cfg, sx, sy, gx, gy, &ws, &again), 0);
        assert_int_equal(again.n_wps, res.n_wps);
        assert_true(again.cost == res.cost);
        assert_memory_equal(again.wps, res.wps, (size_t)res.n_wps * sizeof(rt_waypoint_t));
        found++;
        expanded += res.expanded;
        max_wps = res.n_wps > max_wps ? res.n_wps : max_wps;
    }
    /* A goal on a wall cell, and in the forbidden band next to one: -ENOENT. */
    float sx, sy, gx, gy;
    rt_grid_cell_centre(&grid, cells[0] % grid.w, cells[0] / grid.w, &sx, &sy);
    int wall = -1;
    for (int i = 0; i < grid.w * grid.h && wall < 0; i++)
        if (obst[i] && i % grid.w > 0 && !obst[i - 1])
            wall = i;
    assert_true(wall > 0);
    rt_grid_cell_centre(&grid, wall % grid.w, wall / grid.w, &gx, &gy);
    assert_int_equal(rt_plan_path(&grid, &cfg, sx, sy, gx, gy, &ws, &res), -ENOENT);
    rt_grid_cell_centre(&grid, wall % grid.w - 1, wall / grid.w, &gx, &gy);
    assert_int_equal(rt_plan_path(&grid, &cfg, sx, sy, gx, gy, &ws, &res), -ENOENT);

    print_message("%s: %d x %d cells of %.2f m (pooled %d), %d allowed, %d pairs: %d paths "
                  "(at most %d waypoints, %ld cells expanded on average), %d refused\n",
                  name, grid.w, grid.h, (double)grid.res, k, n_allowed, pairs, found, max_wps,
                  found ? expanded / found : 0L, refused);
    assert_true(found >= min_found);
    free(fine_obst);
    sim_grid_free(&fine);
}

static void test_apartment(void **st)
{
    (void)st;
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_load("host_sim/plans/apartment.svg", 0.0, &p, err, sizeof err), 0);
    check_plan("apartment", &p, 60, 30);
    sim_plan_free(&p);
}

static void test_generated_plan(void **st)
{
    (void)st;
    char *svg = NULL, err[256];
    assert_int_equal(sim_plangen_svg(5, 8, &svg), 0);
    sim_plan_t p;
    assert_int_equal(sim_plan_parse(svg, "gen5.svg", 0.0, &p, err, sizeof err), 0);
    free(svg);
    check_plan("generated seed 5, 8 rooms", &p, 60, 20);
    sim_plan_free(&p);
}

static void test_office64(void **st)
{
    (void)st;
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_load("host_sim/plans/office64.svg", 0.0, &p, err, sizeof err), 0);
    /* At 0.2 m the pooled walls close most doors for a 0.155 m robot: mostly refusals,
     * each one checked against the flood fill. */
    check_plan("office64", &p, 40, 2);
    sim_plan_free(&p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_apartment),
        cmocka_unit_test(test_generated_plan),
        cmocka_unit_test(test_office64),
    };
    return cmocka_run_group_tests_name("rt/plan_maps", tests, NULL, NULL);
}
