/* Lidar: ranges against analytic walls (box geoms and trimesh walls), range limits, seeded
 * noise (deterministic, right spread), dropout, GPS/compass noise. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "sim_grid.h"
#include "sim_lidar.h"
#include "sim_shape.h"
#include "sim_valset.h"
#include "sim_test_util.h"

static void check_box_ranges(int as_mesh)
{
    sim_plan_t p;
    sim_solid_t s[4];
    tu_box_room(&p, s, NULL, 3.0, 2.0, as_mesh);
    sim_world_t *w;
    char err[128];
    assert_int_equal(sim_world_create(&p, NULL, &w, err, sizeof err), 0);
    sim_lidar_cfg_t c = sim_lidar_default_cfg();
    c.noise_sigma = 0;
    sim_lidar_t *l;
    assert_int_equal(sim_lidar_create(&c, &l), 0);
    float r[360];
    double truth[360];
    /* A scan allocates nothing on our side (ODE's internals are not counted). */
    alloc_count_reset();
    assert_int_equal(sim_lidar_scan(l, w, 1.0, 1.0, 0.0, 0, 0, r, truth), 0);
    assert_int_equal(alloc_count_allocations(), 0);
    const double poses[3][3] = {{1.0, 1.0, 0.0}, {2.2, 0.7, 0.9}, {0.5, 1.6, -2.0}};
    int hits = 0, misses = 0;
    const double tol = as_mesh ? 1e-5 : 1e-9;
    for (int k = 0; k < 3; k++) {
        double x = poses[k][0], y = poses[k][1], th = poses[k][2];
        assert_int_equal(sim_lidar_scan(l, w, x, y, th, 0, (uint64_t)k, r, truth), 0);
        for (int b = 0; b < 360; b++) {
            double a = th + b * sim_lidar_angle_inc(l);
            double d = tu_box_distance(3.0, 2.0, x, y, a);
            if (d < c.range_max) {
                /* Noise-free: ODE's ray/box distance is exact to double rounding; ray/trimesh
                 * goes through OPCODE in single precision (measured error ~4e-8 m at 2 m),
                 * hence 1e-5 m there. +1e-6 m for the float conversion of ranges. */
                assert_true(fabs(truth[b] - d) < tol);
                assert_true(fabs(r[b] - d) < tol + 1e-6);
                hits++;
            } else {
                assert_true(isinf(truth[b]));
                assert_true(isinf(r[b]) && r[b] > 0);
                misses++;
            }
        }
    }
    assert_true(hits > 500);
    sim_lidar_destroy(l);
    sim_world_destroy(w);
    (void)misses;
}

static void test_box_walls_analytic(void **st) { (void)st; check_box_ranges(0); }
static void test_mesh_walls_analytic(void **st) { (void)st; check_box_ranges(1); }

static void test_range_limits_and_misses(void **st)
{
    (void)st;
    /* A long corridor: the east wall is 10 m away (beyond 3.5 m): +inf there. */
    sim_plan_t p;
    sim_solid_t s[4];
    tu_box_room(&p, s, NULL, 10.0, 1.0, 0);
    sim_world_t *w;
    assert_int_equal(sim_world_create(&p, NULL, &w, NULL, 0), 0);
    sim_lidar_cfg_t c = sim_lidar_default_cfg();
    c.noise_sigma = 0;
    c.n_beams = 4; /* 0, 90, 180, 270 degrees */
    sim_lidar_t *l;
    assert_int_equal(sim_lidar_create(&c, &l), 0);
    float r[4];
    assert_int_equal(sim_lidar_scan(l, w, 1.0, 0.5, 0.0, 0, 0, r, NULL), 0);
    assert_true(isinf(r[0]));
    assert_float_equal(r[1], 0.5, 1e-6);
    assert_float_equal(r[2], 1.0, 1e-6);
    assert_float_equal(r[3], 0.5, 1e-6);
    /* Closer than range_min (0.12): NaN. */
    assert_int_equal(sim_lidar_scan(l, w, 1.0, 0.05, 0.0, 0, 0, r, NULL), 0);
    assert_true(isnan(r[3]));
    assert_float_equal(r[1], 0.95, 1e-6);
    /* Robots are not seen: the lidar only collides with the walls' space. */
    int id;
    assert_int_equal(sim_world_add_robot(w, NULL, (sim_pose_t){2.0, 0.5, 0.0}, &id), 0);
    assert_int_equal(sim_lidar_scan(l, w, 1.0, 0.5, 0.0, 0, 0, r, NULL), 0);
    assert_true(isinf(r[0]));
    sim_lidar_destroy(l);
    sim_world_destroy(w);
}

static void test_noise_deterministic_and_spread(void **st)
{
    (void)st;
    sim_plan_t p;
    sim_solid_t s[4];
    tu_box_room(&p, s, NULL, 3.0, 3.0, 0);
    sim_world_t *w;
    assert_int_equal(sim_world_create(&p, NULL, &w, NULL, 0), 0);
    sim_lidar_cfg_t c = sim_lidar_default_cfg();
    c.seed = 42;
    sim_lidar_t *l;
    assert_int_equal(sim_lidar_create(&c, &l), 0);
    float a[360], b[360];
    double truth[360];
    double sum = 0, sum2 = 0;
    int n = 0;
    for (uint64_t scan = 0; scan < 20; scan++) {
        assert_int_equal(sim_lidar_scan(l, w, 1.5, 1.5, 0.3, 3, scan, a, truth), 0);
        assert_int_equal(sim_lidar_scan(l, w, 1.5, 1.5, 0.3, 3, scan, b, NULL), 0);
        assert_memory_equal(a, b, sizeof a); /* same key -> same noise */
        for (int i = 0; i < 360; i++) {
            double e = a[i] - truth[i];
            sum += e;
            sum2 += e * e;
            n++;
        }
    }
    double mean = sum / n, sd = sqrt(sum2 / n - mean * mean);
    /* 7200 draws of N(0, 0.01^2): the mean's standard error is 1.2e-4; sd within 5%. */
    assert_true(fabs(mean) < 6e-4);
    assert_true(fabs(sd - 0.01) < 5e-4);
    /* Another robot index or scan index gives different noise. */
    assert_int_equal(sim_lidar_scan(l, w, 1.5, 1.5, 0.3, 4, 0, b, NULL), 0);
    assert_int_equal(sim_lidar_scan(l, w, 1.5, 1.5, 0.3, 3, 0, a, NULL), 0);
    assert_memory_not_equal(a, b, sizeof a);
    sim_lidar_destroy(l);

    /* Dropout: about the requested fraction of NaN. */
    c.dropout_p = 0.2;
    assert_int_equal(sim_lidar_create(&c, &l), 0);
    int nan = 0;
    for (uint64_t scan = 0; scan < 10; scan++) {
        assert_int_equal(sim_lidar_scan(l, w, 1.5, 1.5, 0.0, 0, scan, a, NULL), 0);
        for (int i = 0; i < 360; i++)
            nan += isnan(a[i]);
    }
    /* 3600 Bernoulli(0.2): sd 24; accept +-5 sd. */
    assert_in_range(nan, 720 - 120, 720 + 120);
    sim_lidar_destroy(l);
    sim_world_destroy(w);
}

static void test_bad_config(void **st)
{
    (void)st;
    sim_lidar_cfg_t c = sim_lidar_default_cfg();
    sim_lidar_t *l;
    c.n_beams = 0;
    assert_int_equal(sim_lidar_create(&c, &l), -EINVAL);
    c = sim_lidar_default_cfg();
    c.range_max = c.range_min;
    assert_int_equal(sim_lidar_create(&c, &l), -EINVAL);
    c = sim_lidar_default_cfg();
    c.dropout_p = 1.0;
    assert_int_equal(sim_lidar_create(&c, &l), -EINVAL);
    c = sim_lidar_default_cfg();
    c.noise_sigma = NAN;
    assert_int_equal(sim_lidar_create(&c, &l), -EINVAL);
}

static void test_gps(void **st)
{
    (void)st;
    sim_gps_cfg_t g = sim_gps_default_cfg();
    g.seed = 5;
    sim_pose_t t = {1.0, 2.0, 3.1}, a, b;
    double sx = 0, sx2 = 0;
    for (uint64_t i = 0; i < 4000; i++) {
        assert_int_equal(sim_gps_read(&g, 1, i, &t, &a), 0);
        assert_int_equal(sim_gps_read(&g, 1, i, &t, &b), 0);
        assert_memory_equal(&a, &b, sizeof a);
        assert_true(a.theta > -M_PI && a.theta <= M_PI);
        sx += a.x - t.x;
        sx2 += (a.x - t.x) * (a.x - t.x);
    }
    double sd = sqrt(sx2 / 4000 - (sx / 4000) * (sx / 4000));
    assert_true(fabs(sd - g.sigma_xy) < 0.1 * g.sigma_xy);
    g.sigma_xy = -1;
    assert_int_equal(sim_gps_read(&g, 1, 0, &t, &a), -EINVAL);
}

/* The default apartment (rectangles as boxes, cut walls as trimeshes): every noise-free hit
 * lies on the boundary of a plan solid, and 4 mm before it the plan's own point classifier
 * says "not a wall" (the ray did not pass through a wall first). */
static void test_apartment_hits_on_solids(void **st)
{
    (void)st;
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_load("host_sim/plans/apartment.svg", 0.0, &p, err, sizeof err), 0);
    sim_world_t *w;
    assert_int_equal(sim_world_create(&p, NULL, &w, err, sizeof err), 0);
    sim_valset_cfg_t vc = sim_valset_default_cfg();
    vc.n_poses = 20;
    sim_pose_t poses[20];
    assert_int_equal(sim_valset_poses(&p, &vc, poses, err, sizeof err), 0);
    sim_lidar_cfg_t c = sim_lidar_default_cfg();
    c.noise_sigma = 0;
    sim_lidar_t *l;
    assert_int_equal(sim_lidar_create(&c, &l), 0);
    float r[360];
    double truth[360];
    int hits = 0;
    for (int k = 0; k < 20; k++) {
        assert_int_equal(sim_lidar_scan(l, w, poses[k].x, poses[k].y, poses[k].theta, 0, 0, r, truth), 0);
        for (int b = 0; b < 360; b++) {
            if (!isfinite(truth[b]))
                continue;
            double a = poses[k].theta + b * sim_lidar_angle_inc(l);
            double hx = poses[k].x + truth[b] * cos(a), hy = poses[k].y + truth[b] * sin(a);
            double qx = poses[k].x + (truth[b] - 0.004) * cos(a);
            double qy = poses[k].y + (truth[b] - 0.004) * sin(a);
            double dmin = INFINITY;
            for (int i = 0; i < p.n_solids; i++)
                dmin = fmin(dmin, sim_shape_edge_distance(&p.solids[i].outline, hx, hy));
            assert_true(dmin < 1e-5); /* trimesh hits are single precision (OPCODE) */
            assert_int_not_equal(sim_plan_classify_point(&p, qx, qy), SIM_CELL_WALL);
            hits++;
        }
    }
    assert_true(hits > 20 * 360 / 2);
    sim_lidar_destroy(l);
    sim_world_destroy(w);
    sim_plan_free(&p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_box_walls_analytic),
        cmocka_unit_test(test_mesh_walls_analytic),
        cmocka_unit_test(test_range_limits_and_misses),
        cmocka_unit_test(test_noise_deterministic_and_spread),
        cmocka_unit_test(test_bad_config),
        cmocka_unit_test(test_gps),
        cmocka_unit_test(test_apartment_hits_on_solids),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
