/* Ground-truth raster: a tiny plan with every cell known, conversions, image writers, and rooms
 * that share an edge through cell centres (no cell between them is outside; the tours go
 * through their doorway). */
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
#include "png_read.h"
#include "sim_grid.h"
#include "sim_paths.h"
#include "sim_plan.h"

/* A 1 m box (10 cm walls) with a 20 cm door in its top wall, plus a lone wall 1.5..2 m to
 * the right, so the grid (0.1 m cells, 20 x 10) also holds cells outside the building. */
static const char *const TINY =
    "<svg>\n"
    "<g class=\"Wall\"><polygon points=\"0,0 100,0 100,10 0,10\"/>\n"
    "  <g class=\"Door\"><polygon points=\"40,0 60,0 60,10 40,10\"/></g></g>\n"
    "<g class=\"Wall\"><polygon points=\"0,90 100,90 100,100 0,100\"/></g>\n"
    "<g class=\"Wall\"><polygon points=\"0,10 10,10 10,90 0,90\"/></g>\n"
    "<g class=\"Wall\"><polygon points=\"90,10 100,10 100,90 90,90\"/></g>\n"
    "<g class=\"Wall\"><polygon points=\"150,0 200,0 200,10 150,10\"/></g>\n"
    "<g class=\"Space Room\"><polygon points=\"10,10 90,10 90,90 10,90\"/></g>\n"
    "</svg>\n";

static int expected(int c, int r)
{
    if (c >= 10)
        return (r == 0 && c >= 15) ? SIM_CELL_WALL : SIM_CELL_OUTSIDE;
    if (r == 0)
        return (c == 4 || c == 5) ? SIM_CELL_FREE : SIM_CELL_WALL;
    if (r == 9 || c == 0 || c == 9)
        return SIM_CELL_WALL;
    return SIM_CELL_FREE;
}

static void test_tiny_plan_cells(void **state)
{
    (void)state;
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_parse(TINY, "tiny.svg", 0.0, &p, err, sizeof err), 0);
    sim_grid_t g;
    assert_int_equal(sim_grid_from_plan(&p, 0.1, &g), 0);
    alloc_count_reset();
    assert_int_equal(g.w, 20);
    assert_int_equal(g.h, 10);
    assert_true(g.res == 0.1);
    assert_true(g.origin.x == 0.0 && g.origin.y == 0.0);
    for (int r = 0; r < g.h; r++)
        for (int c = 0; c < g.w; c++) {
            if (sim_grid_at(&g, c, r) != expected(c, r))
                fail_msg("cell (%d, %d) is %d, expected %d", c, r, sim_grid_at(&g, c, r), expected(c, r));
            double x, y;
            sim_grid_cell_centre(&g, c, r, &x, &y);
            assert_int_equal(sim_plan_classify_point(&p, x, y), expected(c, r));
        }
    assert_int_equal(sim_grid_at(&g, -1, 0), SIM_CELL_OUTSIDE);
    assert_int_equal(sim_grid_at(&g, 0, 10), SIM_CELL_OUTSIDE);
    assert_int_equal(alloc_count_allocations(), 0); /* lookups and classification allocate nothing */
    sim_grid_free(&g);
    assert_null(g.cells);

    /* Finer grid: sizes round up to cover the bounding box. */
    assert_int_equal(sim_grid_from_plan(&p, 0.03, &g), 0);
    assert_int_equal(g.w, 67);
    assert_int_equal(g.h, 34);
    sim_grid_free(&g);
    assert_int_equal(sim_grid_from_plan(&p, 0.0, &g), -EINVAL);
    assert_int_equal(sim_grid_from_plan(&p, NAN, &g), -EINVAL);
    assert_int_equal(sim_grid_from_plan(&p, 1e-5, &g), -E2BIG);
    assert_null(g.cells);
    assert_int_equal(sim_grid_from_plan(NULL, 0.1, &g), -EINVAL);
    sim_plan_free(&p);
}

static void test_conversions(void **state)
{
    (void)state;
    sim_grid_t g;
    assert_int_equal(sim_grid_init(&g, 0.05, -1.0, 2.0, 40, 30), 0);
    int c, r;
    assert_int_equal(sim_grid_world_to_cell(&g, -1.0, 2.0, &c, &r), 0);
    assert_int_equal(c, 0);
    assert_int_equal(r, 0);
    assert_int_equal(sim_grid_world_to_cell(&g, -1.0 + 0.05 * 39.5, 2.0 + 0.05 * 29.5, &c, &r), 0);
    assert_int_equal(c, 39);
    assert_int_equal(r, 29);
    assert_int_equal(sim_grid_world_to_cell(&g, -1.001, 2.5, &c, &r), -ERANGE);
    assert_int_equal(c, -1);
    assert_int_equal(sim_grid_world_to_cell(&g, 1e300, NAN, &c, &r), -ERANGE);
    for (int rr = 0; rr < g.h; rr++)
        for (int cc = 0; cc < g.w; cc++) {
            double x, y;
            sim_grid_cell_centre(&g, cc, rr, &x, &y);
            assert_int_equal(sim_grid_world_to_cell(&g, x, y, &c, &r), 0);
            assert_int_equal(c, cc);
            assert_int_equal(r, rr);
            assert_int_equal(sim_grid_at(&g, cc, rr), SIM_CELL_OUTSIDE);
        }
    sim_grid_free(&g);
    assert_int_equal(sim_grid_init(&g, -1, 0, 0, 4, 4), -EINVAL);
    assert_int_equal(sim_grid_init(&g, 1, 0, 0, 0, 4), -EINVAL);
    assert_int_equal(sim_grid_init(&g, 1, 0, 0, SIM_GRID_MAX_SIDE + 1, 4), -E2BIG);
}

static void test_images(void **state)
{
    (void)state;
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_parse(TINY, "tiny.svg", 0.0, &p, err, sizeof err), 0);
    sim_grid_t g;
    assert_int_equal(sim_grid_from_plan(&p, 0.1, &g), 0);
    char dir[] = "/tmp/test_grid_XXXXXX", pgm[64], png[64];
    assert_non_null(mkdtemp(dir));
    snprintf(pgm, sizeof pgm, "%s/g.pgm", dir);
    snprintf(png, sizeof png, "%s/g.png", dir);
    assert_int_equal(sim_grid_write_image(&g, pgm, err, sizeof err), 0);
    assert_int_equal(sim_grid_write_image(&g, png, err, sizeof err), 0);
    uint8_t buf[512];
    FILE *f = fopen(pgm, "rb");
    assert_non_null(f);
    size_t n = fread(buf, 1, sizeof buf, f);
    fclose(f);
    const char *hdr = "P5\n20 10\n255\n";
    assert_int_equal(n, strlen(hdr) + 200);
    assert_memory_equal(buf, hdr, strlen(hdr));
    const uint8_t *px = buf + strlen(hdr);
    /* y up (sim_figure.h): image row R shows grid row 9 - R, so the door and the lone wall
     * piece at the plan's smallest y (the SVG's top) are on the image's LAST row. */
    assert_int_equal(px[9 * 20 + 0], 0);    /* wall corner */
    assert_int_equal(px[9 * 20 + 4], 255);  /* door */
    assert_int_equal(px[9 * 20 + 15], 0);   /* the lone wall piece, bottom right */
    assert_int_equal(px[0 * 20 + 15], 160); /* above it: outside */
    assert_int_equal(px[4 * 20 + 5], 255);  /* room */
    static const uint8_t shade[3] = {255, 0, 160};
    for (int R = 0; R < 10; R++)
        for (int c = 0; c < 20; c++)
            if (px[R * 20 + c] != shade[expected(c, 9 - R)])
                fail_msg("pgm pixel (%d, %d) is %d, expected %d", c, R, px[R * 20 + c], shade[expected(c, 9 - R)]);
    /* The PNG is the same picture. */
    int pw = 0, ph = 0;
    uint8_t *rgb = tpng_read_rgb(png, &pw, &ph);
    assert_non_null(rgb);
    assert_int_equal(pw, 20);
    assert_int_equal(ph, 10);
    for (int i = 0; i < 200; i++)
        if (rgb[3 * i] != px[i] || rgb[3 * i + 1] != px[i] || rgb[3 * i + 2] != px[i])
            fail_msg("png pixel %d differs from the pgm's", i);
    free(rgb);
    assert_int_equal(sim_grid_write_image(&g, "/tmp/x.bmp", err, sizeof err), -EINVAL);
    assert_non_null(strstr(err, "unknown image type"));
    assert_true(sim_grid_write_image(&g, "/dev/null/x.png", err, sizeof err) < 0);
    assert_non_null(strstr(err, "/dev/null/x.png: Not a directory"));
    unlink(pgm);
    unlink(png);
    rmdir(dir);
    sim_grid_free(&g);
    sim_plan_free(&p);
}

/* The default plan: closed walls (no FREE cell touches an OUTSIDE cell except through the
 * entrance door) and the expected bounding box. */
static void test_default_plan_grid(void **state)
{
    (void)state;
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_load("host_sim/plans/apartment.svg", 0.0, &p, err, sizeof err), 0);
    sim_grid_t g;
    assert_int_equal(sim_grid_from_plan(&p, 0.05, &g), 0);
    assert_int_equal(g.w, 240);
    assert_int_equal(g.h, 180);
    long n[3] = {0, 0, 0};
    for (int i = 0; i < g.w * g.h; i++)
        n[g.cells[i]]++;
    assert_int_equal(n[SIM_CELL_OUTSIDE], 0);
    assert_true(n[SIM_CELL_WALL] > 3000 && n[SIM_CELL_FREE] > 30000);
    sim_grid_free(&g);
    sim_plan_free(&p);
}

/* ---- shared edges through cell centres ----------------------------------------------------- */

/* A plan of rooms splitting the inner box [22.5, 977.5] x [22.5, 477.5] px of a walled
 * building along the line from (x_top, 22.5) to (x_bottom, 477.5): room A on its left, room B
 * on its right, or (t_junction) two rooms B1 above y = 250 px and B2 below, whose edges are
 * halves of A's. At 0.05 m per cell the faces run through cell centres, and so does the line
 * when its ends do. */
static void split_plan(char *svg, size_t n, double x_top, double x_bottom, int t_junction)
{
    double xm = 0.5 * (x_top + x_bottom);
    int k = snprintf(svg, n,
                     "<svg>"
                     "<g class=\"Wall\"><polygon points=\"0,0 1000,0 1000,22.5 0,22.5\"/></g>"
                     "<g class=\"Wall\"><polygon points=\"0,477.5 1000,477.5 1000,500 0,500\"/></g>"
                     "<g class=\"Wall\"><polygon points=\"0,22.5 22.5,22.5 22.5,477.5 0,477.5\"/></g>"
                     "<g class=\"Wall\"><polygon points=\"977.5,22.5 1000,22.5 1000,477.5 977.5,477.5\"/></g>"
                     "<g class=\"Space A\"><polygon points=\"22.5,22.5 %.17g,22.5 %.17g,477.5 22.5,477.5\"/></g>",
                     x_top, x_bottom);
    assert_true(k > 0 && (size_t)k < n);
    if (t_junction)
        k += snprintf(svg + k, n - (size_t)k,
                      "<g class=\"Space B1\"><polygon points=\"%.17g,22.5 977.5,22.5 977.5,250 %.17g,250\"/></g>"
                      "<g class=\"Space B2\"><polygon points=\"%.17g,250 977.5,250 977.5,477.5 %.17g,477.5\"/></g>",
                      x_top, xm, xm, x_bottom);
    else
        k += snprintf(svg + k, n - (size_t)k,
                      "<g class=\"Space B\"><polygon points=\"%.17g,22.5 977.5,22.5 977.5,477.5 %.17g,477.5\"/></g>",
                      x_top, x_bottom);
    assert_true(k > 0 && (size_t)k + 7 < n);
    strcat(svg, "</svg>");
}

static long count_cells(const sim_grid_t *g, int value)
{
    long n = 0;
    for (long i = 0; i < (long)g->w * g->h; i++)
        n += g->cells[i] == value;
    return n;
}

/* Every slope, every offset (the ends of the shared edge on cell centres), the edge shared
 * whole or in halves: not one cell is outside, and sim_plan_classify_point agrees with the
 * raster. A centre on the shared edge used to be claimed by neither room whenever the two
 * rooms, walking the edge in opposite directions, rounded its crossing differently; a half
 * edge rounds differently from the whole one, whichever way it is walked. */
static void test_shared_edges_leave_no_gap(void **state)
{
    (void)state;
    char svg[2048], err[256];
    int plans = 0;
    for (int top = 0; top < 190; top += 2)
        for (int run = -63; run <= 63; run += 7) {
            double x_top = 22.5 + 5 * top, x_bottom = x_top + 5 * run;
            if (x_bottom <= 22.5 || x_bottom >= 977.5)
                continue;
            split_plan(svg, sizeof svg, x_top, x_bottom, plans % 2);
            sim_plan_t p;
            assert_int_equal(sim_plan_parse(svg, "split.svg", 0.0, &p, err, sizeof err), 0);
            sim_grid_t g;
            assert_int_equal(sim_grid_from_plan(&p, 0.05, &g), 0);
            if (count_cells(&g, SIM_CELL_OUTSIDE) != 0)
                fail_msg("%ld outside cells with the shared edge from %g to %g px", count_cells(&g, SIM_CELL_OUTSIDE),
                         x_top, x_bottom);
            for (int r = 0; r < g.h; r += 7)
                for (int c = 0; c < g.w; c += 3) {
                    double x, y;
                    sim_grid_cell_centre(&g, c, r, &x, &y);
                    assert_int_equal(sim_plan_classify_point(&p, x, y), sim_grid_at(&g, c, r));
                }
            sim_grid_free(&g);
            sim_plan_free(&p);
            plans++;
        }
    assert_true(plans > 1000);
}

/* The point-in-polygon rule on a shared edge: a point on it (any rounding of it) is inside
 * exactly one of the two polygons, whichever way each walks the edge. */
static void test_shared_edge_point_in_one_polygon(void **state)
{
    (void)state;
    uint64_t s = 0x9E3779B97F4A7C15ull;
    int on_edge = 0;
    for (int it = 0; it < 20000; it++) {
        double v[4];
        for (int k = 0; k < 4; k++) {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            v[k] = (double)(s >> 11) / 9007199254740992.0 * 20.0 - 10.0;
        }
        sim_vec2_t a = {v[0], v[1]}, b = {v[2], v[3]};
        if (fabs(a.y - b.y) < 1e-3)
            continue;
        /* Left and right of the edge a-b: triangles sharing it, walking it in opposite
         * directions (a -> b in one, b -> a in the other). */
        double nx = -(b.y - a.y), ny = b.x - a.x;
        sim_poly_t p = {3, {a, b, {0.5 * (a.x + b.x) + nx, 0.5 * (a.y + b.y) + ny}}};
        sim_poly_t q = {3, {b, a, {0.5 * (a.x + b.x) - nx, 0.5 * (a.y + b.y) - ny}}};
        for (int k = 1; k < 8; k++) {
            double t = k / 8.0, x = a.x + t * (b.x - a.x), y = a.y + t * (b.y - a.y);
            if (sim_poly_contains(&p, x, y) + sim_poly_contains(&q, x, y) != 1)
                fail_msg("(%.17g, %.17g) on the edge (%.17g, %.17g)-(%.17g, %.17g): in %d and %d", x, y, a.x, a.y, b.x,
                         b.y, sim_poly_contains(&p, x, y), sim_poly_contains(&q, x, y));
            on_edge++;
        }
    }
    assert_true(on_edge > 100000);
    /* Covers: inside, or within tol of the boundary. */
    sim_poly_t sq = {4, {{0, 0}, {1, 0}, {1, 1}, {0, 1}}};
    assert_true(sim_poly_covers(&sq, 0.5, 0.5, 0.0));
    assert_true(sim_poly_covers(&sq, 1.0, 0.5, 0.0)); /* on the edge: not contained, covered */
    assert_false(sim_poly_contains(&sq, 1.0, 0.5));
    assert_true(sim_poly_covers(&sq, 1.0 + 1e-7, 0.5, 1e-6));
    assert_false(sim_poly_covers(&sq, 1.0 + 1e-5, 0.5, 1e-6));
}

/* tests/sim/plans/diagonal_doorway.svg: the rooms' doorway is their shared slanted edge, on
 * cell centres. Its cells are free, none outside, and the tour generator goes through it: one
 * robot tours both rooms, two robots start one in each. */
static void test_tours_through_doorway_on_cell_centres(void **state)
{
    (void)state;
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_load("tests/sim/plans/diagonal_doorway.svg", 0.0, &p, err, sizeof err), 0);
    sim_grid_t g;
    assert_int_equal(sim_grid_from_plan(&p, 0.05, &g), 0);
    assert_int_equal(count_cells(&g, SIM_CELL_OUTSIDE), 0);
    /* The doorway's cells on the shared edge x = y + 2 m, y from 4.0 to 4.775 m. */
    int on_edge = 0;
    for (int r = 0; r < g.h; r++)
        for (int c = 0; c < g.w; c++) {
            double x, y;
            sim_grid_cell_centre(&g, c, r, &x, &y);
            if (y > 4.0 && y < 4.77 && fabs(x - y - 2.0) < 1e-6) {
                assert_int_equal(sim_grid_at(&g, c, r), SIM_CELL_FREE);
                on_edge++;
            }
        }
    assert_int_equal(on_edge, 15);
    sim_grid_free(&g);

    sim_paths_cfg_t cfg;
    sim_paths_cfg_default(&cfg);
    sim_path_t one, two[2];
    cfg.n_robots = 1;
    if (sim_paths_generate(&p, &cfg, &one, err, sizeof err) != 0)
        fail_msg("%s", err);
    int crossings = 0;
    for (int i = 0; i + 1 < one.n; i++) {
        double s0 = one.p[i].x - one.p[i].y - 2.0, s1 = one.p[i + 1].x - one.p[i + 1].y - 2.0;
        if ((s0 < 0) != (s1 < 0)) {
            double t = s0 / (s0 - s1), y = one.p[i].y + t * (one.p[i + 1].y - one.p[i].y);
            assert_true(y > 4.0 + cfg.clearance_m - 1e-9 && y < 4.775 - cfg.clearance_m + 1e-9);
            crossings++;
        }
    }
    assert_true(crossings >= 1);
    assert_true(sim_path_min_clearance(&p, &one) >= cfg.clearance_m - 1e-9);
    sim_path_free(&one);
    cfg.n_robots = 2;
    if (sim_paths_generate(&p, &cfg, two, err, sizeof err) != 0)
        fail_msg("%s", err);
    assert_int_not_equal(two[0].start_room, two[1].start_room);
    sim_path_free(&two[0]);
    sim_path_free(&two[1]);
    sim_plan_free(&p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tiny_plan_cells),
        cmocka_unit_test(test_conversions),
        cmocka_unit_test(test_images),
        cmocka_unit_test(test_default_plan_grid),
        cmocka_unit_test(test_shared_edges_leave_no_gap),
        cmocka_unit_test(test_shared_edge_point_in_one_polygon),
        cmocka_unit_test(test_tours_through_doorway_on_cell_centres),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
