/* OSMesa renderer: an image of the requested size, not one colour, lidar rays visible, the
 * plan framed in a top view, the PNG written and readable, bad arguments rejected. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "png_read.h"
#include "sim_palette.h"
#include "sim_render.h"
#include "sim_test_util.h"

/* LeakSanitizer: libOSMesa (Mesa 22.3) leaks ~170 bytes per destroyed context inside the
 * library (measured: 1 render 5 allocations, 4 renders 11); tests/lsan.supp suppresses
 * exactly those, for this test and for `host_sim render` run by tests/app. */

/* A library that is not there: a clear message naming it and the package, no crash; the
 * renders after it still load the real one (a failure is not remembered). First in main():
 * once libOSMesa is loaded, sim_render_load returns 0 whatever it is given. */
static void test_render_missing_library(void **st)
{
    (void)st;
    static const char *const names[] = {"libOSMesa-fleetsim-absent.so.8", NULL};
    char err[512] = "";
    assert_int_equal(sim_render_load(names, err, sizeof err), -ENOENT);
    printf("# %s\n", err);
    assert_non_null(strstr(err, "render: cannot load libOSMesa-fleetsim-absent.so.8 (install libosmesa6): "));
    assert_non_null(strstr(err, "libOSMesa-fleetsim-absent.so.8: cannot open shared object file"));
    assert_int_equal(sim_render_load(NULL, err, sizeof err), 0);
    assert_int_equal(sim_render_load(names, err, sizeof err), 0); /* loaded: nothing to do */
}

static void scene_box(sim_plan_t *p, sim_solid_t s[4], sim_room_t *room)
{
    tu_box_room(p, s, room, 4.0, 3.0, 0);
}

static void test_render_image(void **st)
{
    (void)st;
    sim_plan_t p;
    sim_solid_t s[4];
    sim_room_t room;
    scene_box(&p, s, &room);
    sim_vec2_t pts[3] = {{0.5, 0.5}, {3.5, 0.5}, {3.5, 2.5}};
    sim_path_t path = {3, pts, -1, NULL};
    sim_pose_t robot = {0.5, 0.5, 0.0};
    double ranges[36];
    for (int i = 0; i < 36; i++)
        ranges[i] = 1.0;
    sim_render_sweep_t sw = {robot, ranges, 36, 3.5, 0.17};
    sim_render_scene_t sc = {&p, &path, 1, &robot, 1, &sw, 2.5};
    sim_render_cfg_t c = sim_render_default_cfg();
    c.width = 160;
    c.height = 120;
    uint8_t *rgb = malloc(160 * 120 * 3);
    char err[256];
    assert_int_equal(sim_render_rgb(&sc, &c, rgb, err, sizeof err), 0);
    /* Not one colour: count distinct colours (coarsely). */
    int seen[512] = {0}, distinct = 0;
    for (int i = 0; i < 160 * 120; i++) {
        int k = (rgb[3 * i] >> 5) << 6 | (rgb[3 * i + 1] >> 5) << 3 | (rgb[3 * i + 2] >> 5);
        if (!seen[k]++)
            distinct++;
    }
    assert_true(distinct >= 4);
    /* The lidar rays are present in their neutral grey (sim_palette.h; unlit: the exact colour)
     * and no pixel is red (the rays were once robot 3's red). */
    const uint8_t ray[3] = {SIM_LIDAR_HIT_RGB};
    int grey = 0, red = 0;
    for (int i = 0; i < 160 * 120; i++) {
        grey += abs(rgb[3 * i] - ray[0]) <= 2 && abs(rgb[3 * i + 1] - ray[1]) <= 2 && abs(rgb[3 * i + 2] - ray[2]) <= 2;
        red += rgb[3 * i] > 200 && rgb[3 * i + 1] < 80 && rgb[3 * i + 2] < 80;
    }
    assert_true(grey > 10);
    assert_int_equal(red, 0);
    /* Every lidar colour is far from every robot colour (at least 60 of 255 in some channel sum). */
    const uint8_t lidar[3][3] = {{SIM_LIDAR_HIT_RGB}, {SIM_LIDAR_MISS_RGB}, {SIM_LIDAR_DOT_RGB}};
    for (int l = 0; l < 3; l++)
        for (int k = 0; k < SIM_PALETTE_N; k++) {
            const uint8_t *r = sim_palette_rgb(k);
            const int d = abs(r[0] - lidar[l][0]) + abs(r[1] - lidar[l][1]) + abs(r[2] - lidar[l][2]);
            if (d < 60)
                fail_msg("lidar colour %d is close to robot %d's (%d)", l, k, d);
        }

    /* Top view, no overlays: the image centre shows the room's floor, a different colour
     * from the background in the corner (the camera framed the plan). */
    c.elevation_deg = 90;
    sim_render_scene_t bare = {&p, NULL, 0, NULL, 0, NULL, 2.5};
    assert_int_equal(sim_render_rgb(&bare, &c, rgb, err, sizeof err), 0);
    const uint8_t *centre = rgb + 3 * (60 * 160 + 80), *corner = rgb;
    assert_true(memcmp(centre, corner, 3) != 0);
    free(rgb);
}

/* The picture convention (host_sim/maps/sim_figure.h): the scene is viewed with the plan's +y up
 * the image and +x to the right, like the maps, whatever the elevation: robot 0's tour near
 * (small x, large y) lands top-left, robot 1's near (large x, small y) bottom-right, each in
 * its sim_palette.h colour (the tours are drawn unlit, so the colour is exact). */
static void test_render_y_up_and_colours(void **st)
{
    (void)st;
    sim_plan_t p;
    sim_solid_t s[4];
    sim_room_t room;
    scene_box(&p, s, &room);
    sim_vec2_t a[2] = {{0.4, 2.6}, {1.4, 2.6}}, b[2] = {{3.6, 0.4}, {2.6, 0.4}};
    sim_path_t paths[2] = {{2, a, -1, NULL}, {2, b, -1, NULL}};
    sim_render_scene_t sc = {&p, paths, 2, NULL, 0, NULL, 1.0};
    const double elevations[2] = {72.0, 90.0};
    for (int e = 0; e < 2; e++) {
        sim_render_cfg_t c = sim_render_default_cfg();
        c.width = 320;
        c.height = 240;
        c.elevation_deg = elevations[e];
        uint8_t *rgb = malloc(320 * 240 * 3);
        assert_non_null(rgb);
        char err[256];
        assert_int_equal(sim_render_rgb(&sc, &c, rgb, err, sizeof err), 0);
        double fx = -1.0, fy = -1.0;
        assert_true(tpng_find(rgb, 320, 240, sim_palette_rgb(0), 2, &fx, &fy) > 20);
        if (!(fx < 0.45 && fy < 0.45))
            fail_msg("elevation %g: robot 0's tour at (%.2f, %.2f) of the image, expected top-left",
                     elevations[e], fx, fy);
        assert_true(tpng_find(rgb, 320, 240, sim_palette_rgb(1), 2, &fx, &fy) > 20);
        if (!(fx > 0.55 && fy > 0.55))
            fail_msg("elevation %g: robot 1's tour at (%.2f, %.2f) of the image, expected bottom-right",
                     elevations[e], fx, fy);
        free(rgb);
    }
}

static void test_render_png(void **st)
{
    (void)st;
    sim_plan_t p;
    sim_solid_t s[4];
    sim_room_t room;
    scene_box(&p, s, &room);
    sim_render_scene_t sc = {&p, NULL, 0, NULL, 0, NULL, 0};
    sim_render_cfg_t c = sim_render_default_cfg();
    c.width = 200;
    c.height = 100;
    char out[64], err[256];
    snprintf(out, sizeof out, "/tmp/test_render_%d.png", (int)getpid());
    assert_int_equal(sim_render_png(&sc, &c, out, err, sizeof err), 0);
    png_image img;
    memset(&img, 0, sizeof img);
    img.version = PNG_IMAGE_VERSION;
    assert_true(png_image_begin_read_from_file(&img, out));
    assert_int_equal(img.width, 200);
    assert_int_equal(img.height, 100);
    png_image_free(&img);
    remove(out);
}

static void test_render_errors(void **st)
{
    (void)st;
    sim_plan_t p;
    sim_solid_t s[4];
    sim_room_t room;
    scene_box(&p, s, &room);
    sim_render_scene_t sc = {&p, NULL, 0, NULL, 0, NULL, 0};
    sim_render_cfg_t c = sim_render_default_cfg();
    uint8_t px[3 * 16 * 16];
    char err[256];
    c.width = 8;
    assert_int_equal(sim_render_rgb(&sc, &c, px, err, sizeof err), -EINVAL);
    c = sim_render_default_cfg();
    c.width = c.height = 16;
    c.elevation_deg = 0;
    assert_int_equal(sim_render_rgb(&sc, &c, px, err, sizeof err), -EINVAL);
    c.elevation_deg = 45;
    sc.n_paths = 1; /* paths NULL */
    assert_int_equal(sim_render_rgb(&sc, &c, px, err, sizeof err), -EINVAL);
    sc.n_paths = 0;
    assert_int_equal(sim_render_rgb(&sc, &c, px, err, sizeof err), 0);
    assert_int_equal(sim_render_png(&sc, &c, "/dev/null/x.png", err, sizeof err) < 0, 1);
}

int main(void)
{
    alloc_count_reset();
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_render_missing_library),
        cmocka_unit_test(test_render_image),
        cmocka_unit_test(test_render_y_up_and_colours),
        cmocka_unit_test(test_render_png),
        cmocka_unit_test(test_render_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
