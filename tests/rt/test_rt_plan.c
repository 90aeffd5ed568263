/* The RT core's planner on hand-made belief grids: the clearance transform against brute force,
 * a corridor, a wall with a door (wide and too narrow), the tight band through a door the
 * grid narrowed, a U-trap, a sealed room, a start
 * inside the forbidden band, unknown cells both ways, the soft clearance cost, determinism,
 * too many waypoints, bad arguments, and no allocation. Every path is checked point by point
 * (every 1 cm) against the obstacle squares, not against the planner's own transform. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "rt_plan_test_util.h"

static rt_grid_t grid;
static rt_plan_workspace_t ws;
static rt_plan_result_t res;
static uint8_t obst[RT_GRID_MAX_CELLS];

/* Plans between cell centres; on success checks the path on the grid's own obstacles. */
static int plan_cells(const rt_plan_cfg_t *cfg, int sc, int sr, int gc, int gr)
{
    float sx, sy, gx, gy;
    rt_grid_cell_centre(&grid, sc, sr, &sx, &sy);
    rt_grid_cell_centre(&grid, gc, gr, &gx, &gy);
    alloc_count_reset();
    int r = rt_plan_path(&grid, cfg, sx, sy, gx, gy, &ws, &res);
    assert_int_equal(alloc_count_allocations(), 0);
    if (r == 0) {
        pt_obstacles(&grid, cfg, obst);
        pt_truth_t t = {grid.w, grid.h, grid.res, grid.origin_x, grid.origin_y, obst};
        /* the tight band's guarantee diagonally (rt_plan.h) */
        const double loss = (cfg->flags & RT_PLAN_TIGHT) != 0 ? (sqrt(2.0) - 1.0) * grid.res : 0.0;
        double lowest = pt_check_path(&grid, &res, res.start_col, res.start_row, res.goal_col,
                                      res.goal_row, &t, cfg->robot_radius_m + cfg->margin_m - loss);
        if (lowest < 0)
            fail_msg("path (%d,%d)->(%d,%d) breaks the clearance or its ends", sc, sr, gc, gr);
    }
    return r;
}

/* The exact transform equals the brute-force squared distance on a random grid. */
static void test_clearance_exact(void **st)
{
    (void)st;
    assert_int_equal(rt_grid_init(&grid, 0.1f, -1.0f, 2.0f, 53, 37), 0);
    uint32_t s = 12345u;
    for (int i = 0; i < 53 * 37; i++) {
        s = s * 1664525u + 1013904223u;
        grid.known[i] = (s >> 28) != 0;      /* 1 / 16 unknown */
        grid.occ[i] = (s >> 8) % 23 == 0 ? 200 : 10;
    }
    rt_plan_cfg_t cfg = rt_plan_default_cfg();
    for (int unknown = 0; unknown <= 1; unknown++) {
        cfg.unknown_is_obstacle = (uint8_t)unknown;
        assert_int_equal(rt_plan_clearance(&grid, &cfg, &ws), 0);
        pt_obstacles(&grid, &cfg, obst);
        for (int r = 0; r < grid.h; r++)
            for (int c = 0; c < grid.w; c++) {
                long best = -1;
                for (int i = 0; i < grid.w * grid.h; i++)
                    if (obst[i]) {
                        long d = (long)(i % grid.w - c) * (i % grid.w - c) +
                                 (long)(i / grid.w - r) * (i / grid.w - r);
                        if (best < 0 || d < best)
                            best = d;
                    }
                assert_true(best >= 0);
                assert_true(ws.clear2[r * grid.w + c] == (float)best);
            }
    }
    /* No obstacle at all: infinite clearance. */
    assert_int_equal(rt_grid_init(&grid, 0.1f, 0, 0, 5, 4), 0);
    memset(grid.known, 1, 20);
    assert_int_equal(rt_plan_clearance(&grid, &cfg, &ws), 0);
    for (int i = 0; i < 20; i++)
        assert_true(ws.clear2[i] >= RT_PLAN_CLEAR_INF);
}

/* A straight corridor 0.9 m wide (res 0.1 m): one segment along its middle. */
static void test_corridor(void **st)
{
    (void)st;
    static const char *const rows[] = {
        "##############################", "#............................#",
        "#............................#", "#............................#",
        "#............................#", "#............................#",
        "#............................#", "#............................#",
        "#............................#", "#............................#",
        "##############################",
    };
    pt_grid_ascii(&grid, rows, 11, 0.1f);
    rt_plan_cfg_t cfg = rt_plan_default_cfg(); /* band 1.55 + 1.41 cells: rows 3..7 allowed */
    assert_int_equal(plan_cells(&cfg, 4, 5, 25, 5), 0);
    assert_int_equal(res.n_wps, 2);
    assert_int_equal(res.flags, 0);
    assert_int_equal(res.path_cells, 22);
    assert_float_equal(res.length_m, 2.1f, 1e-5);
    assert_true(res.cost > 2.1f && res.cost < 2.1f * 1.3f); /* 1 + 0.1 / 0.5 at the middle */
    /* Along the band's edge (row 3): allowed. */
    assert_int_equal(plan_cells(&cfg, 4, 3, 25, 3), 0);
    /* Row 2 is forbidden: the start moves to the nearest allowed cell, (4, 3). */
    assert_int_equal(plan_cells(&cfg, 4, 2, 25, 5), 0);
    assert_int_equal(res.flags, RT_PLAN_START_MOVED);
    assert_int_equal(res.start_col, 4);
    assert_int_equal(res.start_row, 3);
    /* A goal in the band: -ENOENT, or the nearest reached cell when asked. */
    assert_int_equal(plan_cells(&cfg, 4, 5, 25, 1), -ENOENT);
    assert_int_equal(res.n_wps, 0);
    cfg.flags = RT_PLAN_NEAREST_GOAL;
    assert_int_equal(plan_cells(&cfg, 4, 5, 25, 1), 0);
    assert_int_equal(res.flags, RT_PLAN_GOAL_MOVED);
    assert_int_equal(res.goal_col, 25);
    assert_int_equal(res.goal_row, 3);
    /* A radius nothing fits: no allowed cell anywhere. */
    cfg.robot_radius_m = 1.0f;
    assert_int_equal(plan_cells(&cfg, 4, 5, 25, 5), -ENOENT);
}

/* A wall across a room with a door: through the door when it is wide enough, else no path. */
static void test_wall_with_door(void **st)
{
    (void)st;
    char rows[30][31];
    for (int r = 0; r < 30; r++) {
        for (int c = 0; c < 30; c++)
            rows[r][c] = (r == 0 || r == 29 || c == 0 || c == 29 || c == 15) ? '#' : '.';
        rows[r][30] = 0;
    }
    for (int r = 11; r <= 18; r++) /* an 8-cell door (0.8 m) */
        rows[r][15] = '.';
    const char *p[30];
    for (int r = 0; r < 30; r++)
        p[r] = rows[r];
    pt_grid_ascii(&grid, p, 30, 0.1f);
    rt_plan_cfg_t cfg = rt_plan_default_cfg();
    assert_int_equal(plan_cells(&cfg, 5, 4, 25, 24), 0);
    int through = 0;
    for (int i = 1; i < res.n_wps; i++) { /* the segment crossing x = 1.55 does it in the door */
        float ax = res.wps[i - 1].x, bx = res.wps[i].x;
        if ((ax - 1.55f) * (bx - 1.55f) <= 0.0f) {
            float y = res.wps[i - 1].y + (1.55f - ax) / (bx - ax) * (res.wps[i].y - res.wps[i - 1].y);
            through = y > 1.1f && y < 1.9f;
        }
    }
    assert_true(through);
    /* A 0.4 m door: the robot (0.155 m + the band) does not fit. */
    for (int r = 11; r <= 18; r++)
        assert_int_equal(rt_grid_set(&grid, 15, r, (r >= 13 && r <= 16) ? 0 : 255, 255), 0);
    assert_int_equal(plan_cells(&cfg, 5, 4, 25, 24), -ENOENT);
    cfg.flags = RT_PLAN_NEAREST_GOAL;
    assert_int_equal(plan_cells(&cfg, 5, 4, 25, 24), 0);
    assert_int_equal(res.flags, RT_PLAN_GOAL_MOVED);
    assert_true(res.goal_col < 15); /* stays on the start's side, as near the door as it may */
    /* Unknown door cells: open when optimistic, closed when unknown is an obstacle. */
    for (int r = 11; r <= 18; r++)
        assert_int_equal(rt_grid_set(&grid, 15, r, 0, 0), 0);
    cfg.flags = 0;
    assert_int_equal(plan_cells(&cfg, 5, 4, 25, 24), 0);
    cfg.unknown_is_obstacle = 1;
    assert_int_equal(plan_cells(&cfg, 5, 4, 25, 24), -ENOENT);
}

/* The door of a 64-room office as a robot's 0.16 m grid holds it: a wall two cells thick, the
 * door 4 cells (0.64 m) where narrowest. The full band (0.97 + 1.41 cells) closes it; the tight
 * band (0.97 + 1) passes it, the door's cells at least R from its sides. */
static void test_tight_band_passes_a_grid_narrowed_door(void **st)
{
    (void)st;
    char rows[20][21];
    for (int r = 0; r < 20; r++) {
        for (int c = 0; c < 20; c++)
            rows[r][c] = (r == 0 || r == 19 || c == 0 || c == 19 || r == 9 || r == 10) ? '#' : '.';
        rows[r][20] = 0;
    }
    for (int c = 8; c <= 11; c++)
        rows[10][c] = '.';
    for (int c = 7; c <= 13; c++)
        rows[9][c] = '.';
    const char *p[20];
    for (int r = 0; r < 20; r++)
        p[r] = rows[r];
    pt_grid_ascii(&grid, p, 20, 0.16f);
    rt_plan_cfg_t cfg = rt_plan_default_cfg();
    cfg.flags = RT_PLAN_NEAREST_GOAL;
    assert_int_equal(plan_cells(&cfg, 10, 15, 10, 4), 0);
    assert_int_equal(res.flags, RT_PLAN_GOAL_MOVED);
    assert_true(res.goal_row > 10); /* kept on the start's side */
    cfg.flags = RT_PLAN_NEAREST_GOAL | RT_PLAN_TIGHT;
    assert_int_equal(plan_cells(&cfg, 10, 15, 10, 4), 0);
    assert_int_equal(res.flags, 0);
    pt_obstacles(&grid, &cfg, obst);
    pt_truth_t t = {grid.w, grid.h, grid.res, grid.origin_x, grid.origin_y, obst};
    for (int i = 1; i < res.n_wps; i++) /* through the door, every point R from its sides */
        for (int k = 0; k <= 100; k++) {
            const double s = k / 100.0;
            const double x = res.wps[i - 1].x + s * (res.wps[i].x - res.wps[i - 1].x);
            const double y = res.wps[i - 1].y + s * (res.wps[i].y - res.wps[i - 1].y);
            if (y > 9 * 0.16 && y < 11 * 0.16)
                assert_true(pt_clearance(&t, x, y, 1.0) >= cfg.robot_radius_m + cfg.margin_m - 1e-4);
        }
    /* Three cells (0.48 m) still pass the tight band, two do not. */
    assert_int_equal(rt_grid_set(&grid, 11, 10, 255, 255), 0);
    assert_int_equal(plan_cells(&cfg, 10, 15, 10, 4), 0);
    assert_int_equal(res.flags, 0);
    assert_int_equal(rt_grid_set(&grid, 10, 10, 255, 255), 0);
    assert_int_equal(plan_cells(&cfg, 10, 15, 10, 4), 0);
    assert_int_equal(res.flags, RT_PLAN_GOAL_MOVED);
}

/* A U open to the left with the start inside and the goal behind its base: the path leaves
 * the U the way it is open and goes around. */
static void test_u_trap(void **st)
{
    (void)st;
    char rows[40][41];
    for (int r = 0; r < 40; r++) {
        for (int c = 0; c < 40; c++)
            rows[r][c] = (r == 0 || r == 39 || c == 0 || c == 39) ? '#' : '.';
        rows[r][40] = 0;
    }
    for (int c = 10; c <= 25; c++)
        rows[10][c] = rows[29][c] = '#';
    for (int r = 10; r <= 29; r++)
        rows[r][25] = '#';
    const char *p[40];
    for (int r = 0; r < 40; r++)
        p[r] = rows[r];
    pt_grid_ascii(&grid, p, 40, 0.1f);
    rt_plan_cfg_t cfg = rt_plan_default_cfg();
    assert_int_equal(plan_cells(&cfg, 20, 20, 33, 20), 0);
    assert_true(res.n_wps >= 4);
    assert_true(res.length_m > 2.0f * 1.3f); /* straight would be 1.3 m */
    float min_x = 99.0f;
    for (int i = 0; i < res.n_wps; i++)
        min_x = fminf(min_x, res.wps[i].x);
    assert_true(min_x < 2.0f); /* went out through the opening */
}

/* A sealed room: its inside is unreachable from outside, both ways. */
static void test_no_path(void **st)
{
    (void)st;
    char rows[30][31];
    for (int r = 0; r < 30; r++) {
        for (int c = 0; c < 30; c++) {
            int box = (r == 12 || r == 24) && c >= 12 && c <= 24;
            box |= (c == 12 || c == 24) && r >= 12 && r <= 24;
            rows[r][c] = (r == 0 || r == 29 || c == 0 || c == 29 || box) ? '#' : '.';
        }
        rows[r][30] = 0;
    }
    const char *p[30];
    for (int r = 0; r < 30; r++)
        p[r] = rows[r];
    pt_grid_ascii(&grid, p, 30, 0.1f);
    rt_plan_cfg_t cfg = rt_plan_default_cfg();
    assert_int_equal(plan_cells(&cfg, 5, 5, 18, 18), -ENOENT);
    assert_int_equal(plan_cells(&cfg, 18, 18, 5, 5), -ENOENT);
    assert_int_equal(plan_cells(&cfg, 5, 5, 12, 12), -ENOENT); /* goal on the wall itself */
    assert_int_equal(plan_cells(&cfg, 5, 5, 5, 25), 0);
    assert_int_equal(plan_cells(&cfg, 17, 17, 19, 20), 0);      /* inside, fine */
}

/* The soft cost: near a wall, a high k trades length for clearance. */
static void test_clearance_cost(void **st)
{
    (void)st;
    char rows[30][61];
    for (int r = 0; r < 30; r++) {
        for (int c = 0; c < 60; c++)
            rows[r][c] = (r == 0 || r == 29 || c == 0 || c == 59) ? '#' : '.';
        rows[r][60] = 0;
    }
    const char *p[30];
    for (int r = 0; r < 30; r++)
        p[r] = rows[r];
    pt_grid_ascii(&grid, p, 30, 0.1f);
    rt_plan_cfg_t cfg = rt_plan_default_cfg();
    pt_obstacles(&grid, &cfg, obst);
    pt_truth_t t = {grid.w, grid.h, grid.res, 0, 0, obst};
    cfg.k_clear_m = 0.0f;
    assert_int_equal(plan_cells(&cfg, 5, 4, 54, 4), 0);
    float len0 = res.length_m;
    double low0 = pt_check_path(&grid, &res, 5, 4, 54, 4, &t, 0.155);
    cfg.k_clear_m = 2.0f;
    assert_int_equal(plan_cells(&cfg, 5, 4, 54, 4), 0);
    double low2 = pt_check_path(&grid, &res, 5, 4, 54, 4, &t, 0.155);
    assert_float_equal(len0, 4.9f, 1e-5);
    assert_true(res.length_m > len0);
    assert_true(low0 > 0 && low2 > 0);
    float max_y = 0.0f;
    for (int i = 0; i < res.n_wps; i++)
        max_y = fmaxf(max_y, res.wps[i].y);
    assert_true(max_y > 0.45f + 0.5f); /* moved at least 5 cells away from the wall */
}

/* Same inputs, same result, whatever ran in the workspace before. */
static void test_deterministic(void **st)
{
    (void)st;
    static rt_plan_result_t first;
    assert_int_equal(rt_grid_init(&grid, 0.05f, 0, 0, 120, 90), 0);
    uint32_t s = 99u;
    for (int i = 0; i < 120 * 90; i++) {
        s = s * 1664525u + 1013904223u;
        grid.known[i] = 1;
        grid.occ[i] = (s >> 8) % 97 == 0 ? 255 : 0; /* scattered posts: many equal-cost paths */
    }
    rt_plan_cfg_t cfg = rt_plan_default_cfg();
    cfg.robot_radius_m = 0.02f;
    cfg.margin_m = 0.0f;
    cfg.flags = RT_PLAN_NEAREST_GOAL; /* a goal next to a post still gives a path */
    assert_int_equal(rt_plan_path(&grid, &cfg, 0.3f, 0.3f, 5.7f, 4.2f, &ws, &first), 0);
    assert_int_equal(rt_plan_path(&grid, &cfg, 5.0f, 0.5f, 0.5f, 4.0f, &ws, &res), 0);
    memset(&res, 0xA5, sizeof res);
    memset(&ws, 0x5A, sizeof ws);
    assert_int_equal(rt_plan_path(&grid, &cfg, 0.3f, 0.3f, 5.7f, 4.2f, &ws, &res), 0);
    assert_int_equal(res.n_wps, first.n_wps);
    assert_int_equal(res.path_cells, first.path_cells);
    assert_int_equal(res.expanded, first.expanded);
    assert_true(res.cost == first.cost);
    assert_memory_equal(res.wps, first.wps, (size_t)first.n_wps * sizeof(rt_waypoint_t));
}

/* A serpentine needing hundreds of waypoints: -ENOSPC, not a truncated path. */
static void test_too_many_waypoints(void **st)
{
    (void)st;
    assert_int_equal(rt_grid_init(&grid, 1.0f, 0, 0, 64, 1024), 0);
    for (int r = 0; r < 1024; r++)
        for (int c = 0; c < 64; c++) {
            int wall = c == 0 || c == 63;
            if (r % 4 == 0) /* a wall row, with a gap at alternating ends */
                wall = !(r > 0 && ((r / 4) % 2 ? (c >= 1 && c <= 3) : (c >= 60 && c <= 62)));
            assert_int_equal(rt_grid_set(&grid, c, r, wall ? 255 : 0, 255), 0);
        }
    rt_plan_cfg_t cfg = rt_plan_default_cfg();
    cfg.robot_radius_m = 0.001f;
    cfg.margin_m = 0.0f;
    assert_int_equal(plan_cells(&cfg, 31, 2, 31, 6), 0); /* one bend is fine */
    assert_int_equal(plan_cells(&cfg, 31, 2, 31, 1022), -ENOSPC);
    assert_int_equal(res.n_wps, 0);
}

static void test_bad_arguments(void **st)
{
    (void)st;
    rt_plan_cfg_t cfg = rt_plan_default_cfg();
    assert_int_equal(rt_grid_init(&grid, 0.1f, 0, 0, 20, 20), 0);
    memset(grid.known, 1, 400);
    assert_int_equal(rt_plan_path(&grid, &cfg, 1, 1, 1.5f, 1.5f, &ws, &res), 0);
    assert_int_equal(rt_plan_path(NULL, &cfg, 1, 1, 1.5f, 1.5f, &ws, &res), -EINVAL);
    assert_int_equal(rt_plan_path(&grid, NULL, 1, 1, 1.5f, 1.5f, &ws, &res), -EINVAL);
    assert_int_equal(rt_plan_path(&grid, &cfg, 1, 1, 1.5f, 1.5f, NULL, &res), -EINVAL);
    assert_int_equal(rt_plan_path(&grid, &cfg, 1, 1, 1.5f, 1.5f, &ws, NULL), -EINVAL);
    assert_int_equal(rt_plan_path(&grid, &cfg, NAN, 1, 1.5f, 1.5f, &ws, &res), -EINVAL);
    assert_int_equal(rt_plan_path(&grid, &cfg, 1, 1, 2.5f, 1.5f, &ws, &res), -EINVAL);
    assert_int_equal(rt_plan_path(&grid, &cfg, 1, 1, 1.5f, -0.01f, &ws, &res), -EINVAL);
    assert_int_equal(rt_plan_path(&grid, &cfg, -5, 1, 1.5f, 1.5f, &ws, &res), -EINVAL);
    rt_plan_cfg_t bad[6] = {cfg, cfg, cfg, cfg, cfg, cfg};
    bad[0].robot_radius_m = 0.0f;
    bad[1].margin_m = -0.1f;
    bad[2].k_clear_m = INFINITY;
    bad[3].occ_threshold = 0;
    bad[4].unknown_is_obstacle = 2;
    bad[5].flags = 8;
    for (int i = 0; i < 6; i++) {
        assert_int_equal(rt_plan_path(&grid, &bad[i], 1, 1, 1.5f, 1.5f, &ws, &res), -EINVAL);
        assert_int_equal(rt_plan_clearance(&grid, &bad[i], &ws), -EINVAL);
    }
    assert_int_equal(rt_plan_clearance(&grid, &cfg, NULL), -EINVAL);
    /* Grid geometry: too large for the storage, or nonsense. */
    assert_int_equal(rt_grid_init(&grid, 0.1f, 0, 0, 257, 256), -ENOSPC);
    assert_int_equal(rt_grid_init(&grid, 0.1f, 0, 0, RT_GRID_MAX_SIDE + 1, 1), -ENOSPC);
    assert_int_equal(rt_grid_init(&grid, 0.0f, 0, 0, 10, 10), -EINVAL);
    assert_int_equal(rt_grid_init(&grid, 0.1f, NAN, 0, 10, 10), -EINVAL);
    assert_int_equal(rt_grid_init(&grid, 0.1f, 0, 0, 0, 10), -EINVAL);
    assert_int_equal(rt_grid_init(NULL, 0.1f, 0, 0, 10, 10), -EINVAL);
    assert_int_equal(grid.w, 20); /* untouched by the failed inits */
    grid.w = 1000;
    grid.h = 1000;
    assert_int_equal(rt_plan_path(&grid, &cfg, 1, 1, 1.5f, 1.5f, &ws, &res), -ENOSPC);
    grid.w = grid.h = 20;
    grid.res = -1.0f;
    assert_int_equal(rt_plan_path(&grid, &cfg, 1, 1, 1.5f, 1.5f, &ws, &res), -EINVAL);
    grid.res = 0.1f;
    int32_t c, r;
    assert_int_equal(rt_grid_world_to_cell(&grid, 1.99f, 0.0f, &c, &r), 0);
    assert_int_equal(c, 19);
    assert_int_equal(r, 0);
    assert_int_equal(rt_grid_world_to_cell(&grid, -0.001f, 0.5f, &c, &r), -EINVAL);
    assert_int_equal(rt_grid_world_to_cell(&grid, 0.5f, INFINITY, &c, &r), -EINVAL);
    assert_int_equal(rt_grid_world_to_cell(&grid, 0.5f, 0.5f, NULL, &r), -EINVAL);
    assert_int_equal(rt_grid_set(&grid, 20, 0, 0, 1), -EINVAL);
    assert_int_equal(rt_grid_set(&grid, 0, -1, 0, 1), -EINVAL);
    assert_int_equal(rt_grid_set(NULL, 0, 0, 0, 1), -EINVAL);
    /* Start == goal: a one-waypoint path at the cell centre. */
    assert_int_equal(rt_plan_path(&grid, &cfg, 1.01f, 1.02f, 1.04f, 1.03f, &ws, &res), 0);
    assert_int_equal(res.n_wps, 1);
    assert_float_equal(res.wps[0].x, 1.05f, 1e-6);
    assert_float_equal(res.length_m, 0.0f, 0.0f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_clearance_exact),  cmocka_unit_test(test_corridor),
        cmocka_unit_test(test_wall_with_door),   cmocka_unit_test(test_tight_band_passes_a_grid_narrowed_door),
        cmocka_unit_test(test_u_trap),
        cmocka_unit_test(test_no_path),          cmocka_unit_test(test_clearance_cost),
        cmocka_unit_test(test_deterministic),    cmocka_unit_test(test_too_many_waypoints),
        cmocka_unit_test(test_bad_arguments),
    };
    return cmocka_run_group_tests_name("rt/plan", tests, NULL, NULL);
}
