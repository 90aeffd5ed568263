/* Drive-and-scan loop and validation set: the firmware follower drives a robot through a
 * small path in the ODE world, the samples are consistent with the room, the same seed gives
 * byte-identical files (and another seed does not), and the validation set has the expected
 * size and labels. */
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
#include "sim_samples.h"
#include "sim_image.h"
#include "sim_scan.h"
#include "sim_test_util.h"
#include "sim_valset.h"

static char *slurp(const char *p, long *len)
{
    FILE *f = fopen(p, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    *len = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *b = malloc((size_t)*len);
    assert_non_null(b);
    assert_int_equal(fread(b, 1, (size_t)*len, f), (size_t)*len);
    fclose(f);
    return b;
}

/* Room [0, 4] x [0, 3]; a 4-waypoint loop. */
static sim_vec2_t wp[4] = {{0.6, 0.6}, {3.2, 0.7}, {3.0, 2.3}, {1.0, 2.2}};

static void run(uint64_t seed, const char *out, sim_scan_stats_t *st, int expect_rc)
{
    sim_plan_t p;
    sim_solid_t s[4];
    sim_room_t room;
    tu_box_room(&p, s, &room, 4.0, 3.0, 0);
    sim_path_t path = {4, wp, -1, NULL};
    sim_scan_cfg_t c = sim_scan_default_cfg();
    c.seed = seed;
    c.dropout_p = 0.05;
    char err[256] = "";
    int rc = sim_scan_run(&p, &path, &c, out, "unit test", st, NULL, NULL, err, sizeof err);
    if (rc != expect_rc)
        fail_msg("sim_scan_run: %d (%s)", rc, err);
}

static void test_scan_follows_path_and_labels(void **state)
{
    (void)state;
    char out[64];
    snprintf(out, sizeof out, "/tmp/test_scan_%d_a.bin", (int)getpid());
    sim_scan_stats_t st;
    run(11, out, &st, 0);
    print_message("scan: %.1f s, %llu scans, %llu samples, %.2f m, %llu collisions\n", st.sim_time_s,
                  (unsigned long long)st.scans, (unsigned long long)st.samples, st.distance_m,
                  (unsigned long long)st.collisions);
    assert_int_equal(st.finished, 1);
    assert_int_equal(st.waypoints_reached, 4);
    assert_int_equal((int)st.collisions, 0);
    /* The polyline is 6.22 m long; the robot stops within 0.08 m (reach tolerance) of each
     * waypoint and turns in place, so it drives a little less: 5.8 .. 6.5 m. */
    assert_true(st.distance_m > 5.8 && st.distance_m < 6.5);
    /* 10 Hz: scans = time * 10 (+1 for the scan at t = 0). */
    assert_true(llabs((long long)st.scans - (long long)lround(st.sim_time_s * 10)) <= 1);
    sim_samples_header_t h;
    ai_sample_t *r;
    char err[256];
    assert_int_equal(sim_samples_read(out, &h, &r, err, sizeof err), 0);
    assert_int_equal(h.count, st.samples);
    assert_int_equal(h.seed, 11);
    /* In a closed 4 x 3 m room every beam hits (the far corner is 5 m away, but at most
     * 3.5 m is seen; beams are lost only to dropout (5%) or range). Occupied samples lie on
     * the walls: within noise (0.01 m) plus GPS error of the boundary. */
    uint64_t occ = 0;
    for (uint64_t i = 0; i < h.count; i++) {
        double x = h.min_x + (r[i].x + 1.0) * 0.5 * (h.max_x - h.min_x);
        double y = h.min_y + (r[i].y + 1.0) * 0.5 * (h.max_y - h.min_y);
        if (r[i].occ > 0.5) {
            occ++;
            double d = fmin(fmin(fabs(x), fabs(x - 4.0)), fmin(fabs(y), fabs(y - 3.0)));
            assert_true(d < 0.12);
        } else {
            assert_true(x > -0.12 && x < 4.12 && y > -0.12 && y < 3.12);
        }
    }
    assert_true(occ > st.scans * 20 * 6 / 10);
    free(r);
    remove(out);
}

static void test_scan_deterministic(void **state)
{
    (void)state;
    char a[64], b[64], c[64];
    snprintf(a, sizeof a, "/tmp/test_scan_%d_1.bin", (int)getpid());
    snprintf(b, sizeof b, "/tmp/test_scan_%d_2.bin", (int)getpid());
    snprintf(c, sizeof c, "/tmp/test_scan_%d_3.bin", (int)getpid());
    sim_scan_stats_t s1, s2, s3;
    run(5, a, &s1, 0);
    run(5, b, &s2, 0);
    run(6, c, &s3, 0);
    long la, lb, lc;
    char *ba = slurp(a, &la), *bb = slurp(b, &lb), *bc = slurp(c, &lc);
    assert_int_equal(la, lb);
    assert_memory_equal(ba, bb, (size_t)la);
    assert_true(la != lc || memcmp(ba, bc, (size_t)la) != 0);
    free(ba);
    free(bb);
    free(bc);
    remove(a);
    remove(b);
    remove(c);
}

static void test_scan_errors(void **state)
{
    (void)state;
    sim_plan_t p;
    sim_solid_t s[4];
    tu_box_room(&p, s, NULL, 4.0, 3.0, 0);
    sim_path_t path = {4, wp, -1, NULL};
    sim_scan_cfg_t c = sim_scan_default_cfg();
    sim_scan_stats_t st;
    char err[256];
    c.scan_hz = 30; /* 1/30 s is not a whole number of 0.01 s steps */
    assert_int_equal(sim_scan_run(&p, &path, &c, "/tmp/x.bin", "", &st, NULL, NULL, err, sizeof err), -EINVAL);
    c = sim_scan_default_cfg();
    c.beams = 400; /* more than the 360 sensor beams */
    assert_int_equal(sim_scan_run(&p, &path, &c, "/tmp/x.bin", "", &st, NULL, NULL, err, sizeof err), -EINVAL);
    c = sim_scan_default_cfg();
    c.max_time_s = 2.0; /* far too short: times out, removes the file */
    char out[64];
    snprintf(out, sizeof out, "/tmp/test_scan_%d_t.bin", (int)getpid());
    assert_int_equal(sim_scan_run(&p, &path, &c, out, "", &st, NULL, NULL, err, sizeof err), -ETIMEDOUT);
    assert_int_equal(access(out, F_OK), -1);
    assert_non_null(strstr(err, "not finished"));
}

/* One path per job: `host_sim scan` records what the firmware image's RT core produces. The
 * same path, seed and robot through the whole image (RT, GP, AI cores) offers its AI core
 * exactly the samples the scan wrote, scan for scan. */
static void test_scan_is_the_firmware_rt_core(void **state)
{
    (void)state;
    sim_plan_t p;
    sim_solid_t s[4];
    sim_room_t room;
    tu_box_room(&p, s, &room, 4.0, 3.0, 0);
    sim_path_t path = {4, wp, -1, NULL};
    char out[64], err[256] = "";
    snprintf(out, sizeof out, "/tmp/test_scan_%d_img.bin", (int)getpid());
    sim_scan_cfg_t c = sim_scan_default_cfg();
    c.seed = 5;
    c.robot = 2;
    sim_scan_stats_t st;
    assert_int_equal(sim_scan_run(&p, &path, &c, out, "unit test", &st, NULL, NULL, err, sizeof err), 0);
    unlink(out);
    sim_image_cfg_t ic;
    sim_image_cfg_default(&ic);
    ic.seed = 5;
    ic.robot = 2;
    ic.rounds = 1;
    ic.steps_per_round = 1;
    ic.log_level = HAL_LOG_WARN;
    static sim_image_result_t res;
    assert_int_equal(sim_image_run(&p, &path, &ic, &res, err, sizeof err), 0);
    print_message("scan: %llu scans, %llu samples; image RT core: %u scans, %u samples\n",
                  (unsigned long long)st.scans, (unsigned long long)st.samples, res.rt_status.scans,
                  res.rt_status.samples);
    assert_int_equal(st.scans, res.rt_status.scans);
    assert_int_equal(st.samples, res.rt_status.samples);
    assert_int_equal(st.samples, res.ai_status.pool_offered);
}

static void test_valset(void **state)
{
    (void)state;
    sim_plan_t p;
    sim_solid_t s[4];
    sim_room_t room;
    tu_box_room(&p, s, &room, 3.0, 2.0, 0);
    sim_valset_cfg_t c = sim_valset_default_cfg();
    c.n_poses = 50;
    c.seed = 3;
    sim_pose_t poses[50];
    char err[256];
    assert_int_equal(sim_valset_poses(&p, &c, poses, err, sizeof err), 0);
    for (int i = 0; i < 50; i++) {
        assert_true(poses[i].x >= 0.2 - 1e-9 && poses[i].x <= 2.8 + 1e-9);
        assert_true(poses[i].y >= 0.2 - 1e-9 && poses[i].y <= 1.8 + 1e-9);
    }
    char out[64];
    snprintf(out, sizeof out, "/tmp/test_valset_%d.bin", (int)getpid());
    uint64_t n = 0;
    assert_int_equal(sim_valset_write(&p, &c, out, "valset test", &n, err, sizeof err), 0);
    /* A 3 x 2 m room: every beam hits within 3.5 m, so exactly 50 x 20 x 25 samples with
     * one occupied point per beam, each on the room boundary (noise-free). */
    assert_int_equal(n, 50 * 20 * 25);
    sim_samples_header_t h;
    ai_sample_t *r;
    assert_int_equal(sim_samples_read(out, &h, &r, err, sizeof err), 0);
    assert_int_equal(h.count, n);
    uint64_t occ = 0;
    for (uint64_t i = 0; i < n; i++) {
        if (r[i].occ > 0.5) {
            occ++;
            double x = h.min_x + (r[i].x + 1.0) * 0.5 * (h.max_x - h.min_x);
            double y = h.min_y + (r[i].y + 1.0) * 0.5 * (h.max_y - h.min_y);
            double d = fmin(fmin(fabs(x), fabs(x - 3.0)), fmin(fabs(y), fabs(y - 2.0)));
            assert_true(d < 1e-5);
            assert_int_equal(i % 25, 24); /* the hit is the last point of its beam */
        }
    }
    assert_int_equal(occ, 50 * 20);
    free(r);
    remove(out);
    /* A plan whose only room is filled by a solid has no free pose. */
    sim_solid_t s5[5];
    memcpy(s5, s, sizeof s);
    tu_rect(&s5[4], 0, 0, 3, 2);
    p.solids = s5;
    p.n_solids = 5;
    c.n_poses = 1;
    assert_int_equal(sim_valset_poses(&p, &c, poses, err, sizeof err), -ENOENT);
}

int main(void)
{
    alloc_count_reset(); /* links the allocation counter the test programs are wrapped with */
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_scan_follows_path_and_labels),
        cmocka_unit_test(test_scan_deterministic),
        cmocka_unit_test(test_scan_errors),
        cmocka_unit_test(test_scan_is_the_firmware_rt_core),
        cmocka_unit_test(test_valset),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
