/* The picture convention (host_sim/maps/sim_figure.h): every figure in metres with y up, and one
 * colour per robot (host_sim/maps/sim_palette.h). An asymmetric plan with a pillar near the plan's
 * top-left in metres (small x, LARGE y: the bottom of the SVG drawing) must show the pillar in
 * the top-left of the grid PNG, and a tour there must land top-left in the paths PNG, in robot
 * 0's colour, while robot 1's tour near (large x, small y) lands bottom-right. A writer that
 * draws y down (the SVG's way) or mirrors x fails here. The map PNGs are checked the same way
 * in tests/app/test_maps.c, the 3D scene in tests/sim/test_render.c. */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>

#include "png_read.h"
#include "sim_figure.h"
#include "sim_grid.h"
#include "sim_palette.h"
#include "sim_plan.h"

/* A 4 x 3 m room (SVG px, 0.01 m/px) with 10 cm walls and a 0.4 m pillar at x 0.4..0.8 m,
 * y 2.2..2.6 m. */
static const char *const PLAN =
    "<svg>\n"
    "<g class=\"Wall\"><polygon points=\"-10,-10 410,-10 410,0 -10,0\"/></g>\n"
    "<g class=\"Wall\"><polygon points=\"-10,300 410,300 410,310 -10,310\"/></g>\n"
    "<g class=\"Wall\"><polygon points=\"-10,0 0,0 0,300 -10,300\"/></g>\n"
    "<g class=\"Wall\"><polygon points=\"400,0 410,0 410,300 400,300\"/></g>\n"
    "<g class=\"Wall\"><polygon points=\"40,220 80,220 80,260 40,260\"/></g>\n"
    "<g class=\"Space Room\"><polygon points=\"0,0 400,0 400,300 0,300\"/></g>\n"
    "</svg>\n";

static void tmp_name(char *out, size_t n, const char *what)
{
    snprintf(out, n, "/tmp/test_figure_%d_%s.png", (int)getpid(), what);
}

static void test_grid_png_y_up(void **state)
{
    (void)state;
    sim_plan_t p;
    char err[256], out[96];
    assert_int_equal(sim_plan_parse(PLAN, "figure.svg", 0.0, &p, err, sizeof err), 0);
    sim_grid_t g;
    assert_int_equal(sim_grid_from_plan(&p, 0.05, &g), 0);
    tmp_name(out, sizeof out, "grid");
    assert_int_equal(sim_grid_write_image(&g, out, err, sizeof err), 0);
    int w = 0, h = 0;
    uint8_t *rgb = tpng_read_rgb(out, &w, &h);
    assert_non_null(rgb);
    assert_int_equal(w, g.w);
    assert_int_equal(h, g.h);
    /* Black inside the outer walls (2 px each) is the pillar alone. */
    long n = 0;
    double sx = 0.0, sy = 0.0;
    for (int y = 3; y < h - 3; y++)
        for (int x = 3; x < w - 3; x++)
            if (rgb[3 * ((size_t)y * w + x)] == 0) {
                n++;
                sx += x + 0.5;
                sy += y + 0.5;
            }
    assert_int_equal(n, 8 * 8);
    /* Pillar centre (0.6, 2.4) m: 0.7 m from the left edge (x = -0.1), 0.7 m below the top
     * edge (y = 3.1) of a 4.2 x 3.2 m picture. */
    assert_true(fabs(sx / n / w - 0.7 / 4.2) < 0.02);
    assert_true(fabs(sy / n / h - 0.7 / 3.2) < 0.02);
    free(rgb);
    unlink(out);
    sim_grid_free(&g);
    sim_plan_free(&p);
}

static void test_paths_png_y_up_and_colours(void **state)
{
    (void)state;
    sim_plan_t p;
    char err[256], out[96];
    assert_int_equal(sim_plan_parse(PLAN, "figure.svg", 0.0, &p, err, sizeof err), 0);
    sim_grid_t g;
    assert_int_equal(sim_grid_from_plan(&p, 0.05, &g), 0);
    sim_vec2_t top_left[2] = {{1.0, 2.8}, {1.6, 2.8}}, bottom_right[2] = {{3.6, 0.3}, {3.0, 0.3}};
    sim_path_t paths[2] = {{2, top_left, -1, NULL}, {2, bottom_right, -1, NULL}};
    tmp_name(out, sizeof out, "paths");
    assert_int_equal(sim_figure_paths_png(&g, paths, 2, out, err, sizeof err), 0);
    int W = 0, H = 0;
    uint8_t *pic = tpng_read_rgb(out, &W, &H);
    assert_non_null(pic);
    /* The frame: the map inside a white margin with ticks, labels and the legend below. */
    int fw, fh, x0, y0, k;
    sim_figure_paths_frame(&g, 2, &fw, &fh, &x0, &y0, &k);
    assert_int_equal(W, fw);
    assert_int_equal(H, fh);
    const int w = g.w * k, h = g.h * k;
    assert_true(x0 > 10 && y0 > 10 && x0 + w < W && y0 + h + 40 < H);
    /* Below the map: black tick marks and labels, and each robot's legend square. */
    const uint8_t ink[3] = {0, 0, 0};
    long below = 0;
    for (int y = y0 + h + 1; y < H; y++)
        for (int x = 0; x < W; x++)
            below += memcmp(pic + 3 * ((size_t)y * W + x), ink, 3) == 0;
    assert_true(below > 100);
    for (int r = 0; r < 2; r++) {
        double lx = -1.0, ly = -1.0;
        assert_true(tpng_find(pic + 3 * (size_t)(y0 + h + 1) * W, W, H - (y0 + h + 1), sim_palette_rgb(r), 0, &lx, &ly)
                    >= 9);
    }
    /* The map alone, for the orientation checks. */
    uint8_t *rgb = malloc((size_t)w * h * 3);
    assert_non_null(rgb);
    for (int y = 0; y < h; y++)
        memcpy(rgb + 3 * (size_t)y * w, pic + 3 * ((size_t)(y0 + y) * W + x0), 3 * (size_t)w);
    free(pic);
    double fx = -1.0, fy = -1.0;
    assert_true(tpng_find(rgb, w, h, sim_palette_rgb(0), 0, &fx, &fy) > 50);
    assert_true(fx < 0.5 && fy < 0.25);
    assert_true(tpng_find(rgb, w, h, sim_palette_rgb(1), 0, &fx, &fy) > 50);
    assert_true(fx > 0.6 && fy > 0.75);
    /* The pillar (black, top-left) is in the same picture the same way round as in the grid PNG. */
    const uint8_t black[3] = {0, 0, 0};
    const int x = (int)(0.7 / 4.2 * w), y = (int)(0.7 / 3.2 * h);
    assert_memory_equal(rgb + 3 * ((size_t)y * w + x), black, 3);
    assert_memory_not_equal(rgb + 3 * ((size_t)(h - 1 - y) * w + x), black, 3);
    free(rgb);
    unlink(out);
    assert_int_equal(sim_figure_paths_png(&g, NULL, 1, out, err, sizeof err), -EINVAL);
    sim_grid_free(&g);
    sim_plan_free(&p);
}

static void test_palette(void **state)
{
    (void)state;
    /* Distinct colours, none the white/black/grey of the ground truth, wrapping around. */
    for (int i = 0; i < SIM_PALETTE_N; i++) {
        const uint8_t *a = sim_palette_rgb(i);
        assert_false(a[0] == a[1] && a[1] == a[2] && (a[0] == 0 || a[0] == 255 || a[0] == 160 || a[0] == 190));
        for (int j = i + 1; j < SIM_PALETTE_N; j++)
            assert_memory_not_equal(a, sim_palette_rgb(j), 3);
        assert_ptr_equal(sim_palette_rgb(i + SIM_PALETTE_N), a);
    }
    assert_ptr_equal(sim_palette_rgb(-3), sim_palette_rgb(3));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_grid_png_y_up),
        cmocka_unit_test(test_paths_png_y_up_and_colours),
        cmocka_unit_test(test_palette),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
