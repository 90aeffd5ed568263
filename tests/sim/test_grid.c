/* Ground-truth raster: a tiny plan with every cell known, conversions, image writers. */
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
    assert_int_equal(px[0], 0);            /* wall corner */
    assert_int_equal(px[4], 255);          /* door */
    assert_int_equal(px[5 * 20 + 5], 255); /* room */
    assert_int_equal(px[5 * 20 + 15], 160);/* outside */
    f = fopen(png, "rb");
    assert_non_null(f);
    n = fread(buf, 1, 8, f);
    fclose(f);
    assert_int_equal(n, 8);
    assert_memory_equal(buf, "\x89PNG\r\n\x1a\n", 8);
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

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tiny_plan_cells),
        cmocka_unit_test(test_conversions),
        cmocka_unit_test(test_images),
        cmocka_unit_test(test_default_plan_grid),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
