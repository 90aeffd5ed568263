/* ODE world: creation/validation, wheel kinematics against the differential-drive formula,
 * twist limits, wall collisions, the firmware waypoint follower driving a robot in the world,
 * and determinism of the physics. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "rt/rt_follow.h"
#include "sim_test_util.h"
#include "sim_world.h"

static sim_world_t *box_world_cfg(double W, double H, int as_mesh, const sim_world_cfg_t *cfg)
{
    static sim_solid_t s[4];
    sim_plan_t p;
    tu_box_room(&p, s, NULL, W, H, as_mesh);
    sim_world_t *w = NULL;
    char err[128];
    assert_int_equal(sim_world_create(&p, cfg, &w, err, sizeof err), 0);
    return w;
}

static sim_world_t *box_world(double W, double H, int as_mesh)
{
    return box_world_cfg(W, H, as_mesh, NULL);
}

static void test_create_validation(void **st)
{
    (void)st;
    sim_plan_t p;
    sim_solid_t s[4];
    tu_box_room(&p, s, NULL, 2, 2, 0);
    sim_world_t *w = NULL;
    char err[128];
    assert_int_equal(sim_world_thread_init(), 0);
    assert_int_equal(sim_world_thread_init(), 0); /* idempotent */
    sim_world_cfg_t c = sim_world_default_cfg();
    c.dt = 0;
    assert_int_equal(sim_world_create(&p, &c, &w, err, sizeof err), -EINVAL);
    assert_null(w);
    p.max.x = p.min.x; /* empty bounding box */
    assert_int_equal(sim_world_create(&p, NULL, &w, err, sizeof err), -EINVAL);
    tu_box_room(&p, s, NULL, 2, 2, 0);
    s[1].outline.n = 2;
    assert_int_equal(sim_world_create(&p, NULL, &w, err, sizeof err), -EINVAL);
    tu_box_room(&p, s, NULL, 2, 2, 0);
    assert_int_equal(sim_world_create(&p, NULL, &w, err, sizeof err), 0);
    int id;
    sim_robot_params_t rp = sim_robot_default_params();
    rp.wheel_radius = -1;
    assert_int_equal(sim_world_add_robot(w, &rp, (sim_pose_t){1, 1, 0}, &id), -EINVAL);
    assert_int_equal(sim_world_add_robot(w, NULL, (sim_pose_t){1, 1, 0}, &id), 0);
    assert_int_equal(id, 0);
    assert_int_equal(sim_world_set_wheels(w, 1, 0, 0), -EINVAL);
    assert_int_equal(sim_world_set_wheels(w, 0, NAN, 0), -EINVAL);
    sim_pose_t q;
    assert_int_equal(sim_world_pose(w, 0, &q), 0);
    assert_float_equal(q.x, 1.0, 1e-12);
    assert_float_equal(q.y, 1.0, 1e-12);
    assert_float_equal(q.theta, 0.0, 1e-12);
    sim_world_destroy(w);
}

/* Pose after time T on the arc of constant (v, omega) from p. */
static sim_pose_t arc(sim_pose_t p, double v, double om, double T)
{
    sim_pose_t q;
    q.theta = p.theta + om * T;
    if (fabs(om) < 1e-12) {
        q.x = p.x + v * T * cos(p.theta);
        q.y = p.y + v * T * sin(p.theta);
    } else {
        q.x = p.x + v / om * (sin(q.theta) - sin(p.theta));
        q.y = p.y - v / om * (cos(q.theta) - cos(p.theta));
    }
    return q;
}

static void wheel_kinematics(double mu_wheel)
{
    sim_world_cfg_t wc = sim_world_default_cfg();
    wc.mu_wheel = mu_wheel;
    sim_world_t *w = box_world_cfg(8, 8, 0, &wc);
    int id;
    assert_int_equal(sim_world_add_robot(w, NULL, (sim_pose_t){3.0, 3.0, 0.4}, &id), 0);
    const sim_robot_params_t *rp = sim_world_robot_params(w, id);
    const double wl = 3.0, wr = 5.0; /* rad/s: v = 0.132 m/s, omega = 0.4125 rad/s */
    assert_int_equal(sim_world_set_wheels(w, id, wl, wr), 0);
    /* Let the motors spin up (they reach the set speed within a few steps) and the
     * contacts settle for 0.5 s, then compare 6 s of motion to the formula. */
    assert_int_equal(sim_world_step(w, (int)lround(0.5 / sim_world_dt(w))), 0);
    sim_pose_t p0, p1;
    assert_int_equal(sim_world_pose(w, id, &p0), 0);
    const double T = 6.0;
    assert_int_equal(sim_world_step(w, (int)lround(T / sim_world_dt(w))), 0);
    assert_int_equal(sim_world_pose(w, id, &p1), 0);
    double v = rp->wheel_radius * (wl + wr) / 2, om = rp->wheel_radius * (wr - wl) / rp->wheel_separation;
    sim_pose_t e = arc(p0, v, om, T);
    double pos_err = hypot(p1.x - e.x, p1.y - e.y);
    double th_err = fabs(rt_wrap_angle((float)(p1.theta - e.theta)));
    print_message("arc (mu_wheel %g): travelled %.3f m, position error %.5f m, heading error %.5f rad\n",
                  mu_wheel, v * T, pos_err, th_err);
    /* Tolerance: with the exact solver the motors hold their speed, and what remains is
     * the soft contact (each sphere wheel sinks a fraction of a millimetre, changing the
     * rolling radius by < 0.1%) and, with Coulomb friction, creep on the turn; measured
     * 0.2 mm / 1.1e-4 rad (no slip) and 0.5 mm / 1.3e-4 rad (mu 1) at dt = 0.01 s.
     * 0.5% of the 0.79 m travelled (4 mm) and 0.005 rad (0.2% of the 2.5 rad turned) keep
     * margin while catching any error in radius, separation or sign (>= 3% errors), and
     * catch the ~1% drift of an under-converged iterative solver. */
    assert_true(pos_err < 0.005 * v * T);
    assert_true(th_err < 0.005);
    double l, r;
    assert_int_equal(sim_world_wheel_rates(w, id, &l, &r), 0);
    assert_float_equal(l, wl, 0.05);
    assert_float_equal(r, wr, 0.05);
    assert_int_equal((int)sim_world_collisions(w, id), 0);
    sim_world_destroy(w);
}

static void test_wheel_kinematics(void **st)
{
    (void)st;
    wheel_kinematics(1.0);      /* the default: Coulomb friction, mu = 1 */
    wheel_kinematics(INFINITY); /* no-slip wheels */
}

static void test_twist_limits(void **st)
{
    (void)st;
    sim_world_t *w = box_world(8, 8, 0);
    int id;
    assert_int_equal(sim_world_add_robot(w, NULL, (sim_pose_t){1.0, 4.0, 0.0}, &id), 0);
    /* Asking for 1 m/s gets the 0.22 m/s limit. */
    const int per_s = (int)lround(1.0 / sim_world_dt(w));
    assert_int_equal(sim_world_set_twist(w, id, 1.0, 0.0), 0);
    assert_int_equal(sim_world_step(w, per_s / 2), 0);
    sim_pose_t a, b;
    assert_int_equal(sim_world_pose(w, id, &a), 0);
    assert_int_equal(sim_world_step(w, 2 * per_s), 0); /* 2 s */
    assert_int_equal(sim_world_pose(w, id, &b), 0);
    assert_float_equal((b.x - a.x) / 2.0, 0.22, 0.22 * 0.01);
    /* Turning in place at the limit: 2.84 rad/s requested 10. */
    assert_int_equal(sim_world_set_twist(w, id, 0.0, 10.0), 0);
    assert_int_equal(sim_world_step(w, per_s / 2), 0);
    assert_int_equal(sim_world_pose(w, id, &a), 0);
    assert_int_equal(sim_world_step(w, per_s / 2), 0); /* 0.5 s */
    assert_int_equal(sim_world_pose(w, id, &b), 0);
    double dth = rt_wrap_angle((float)(b.theta - a.theta));
    assert_float_equal(dth / 0.5, 0.22 / 0.08, 0.05); /* wheel-limited: v_max / (sep / 2) */
    sim_world_destroy(w);
}

static void test_wall_collision(void **st)
{
    (void)st;
    for (int mesh = 0; mesh < 2; mesh++) {
        sim_world_t *w = box_world(2, 2, mesh);
        int id;
        assert_int_equal(sim_world_add_robot(w, NULL, (sim_pose_t){1.0, 1.0, 0.0}, &id), 0);
        assert_int_equal(sim_world_set_twist(w, id, 0.22, 0.0), 0);
        assert_int_equal(sim_world_step(w, (int)lround(10.0 / sim_world_dt(w))), 0); /* 10 s: 2.2 m */
        sim_pose_t p;
        assert_int_equal(sim_world_pose(w, id, &p), 0);
        /* Stopped by the east wall at x = 2: the chassis front is 0.038 m ahead of the axis. */
        assert_true(p.x < 2.0 - 0.03);
        assert_true(p.x > 1.8);
        assert_int_equal((int)sim_world_collisions(w, id), 1); /* pressing = one episode */
        sim_world_destroy(w);
    }
}

static void test_follower_reaches_waypoints(void **st)
{
    (void)st;
    sim_world_t *w = box_world(5, 4, 0);
    int id;
    assert_int_equal(sim_world_add_robot(w, NULL, (sim_pose_t){0.5, 0.5, 0.0}, &id), 0);
    const rt_waypoint_t wps[] = {{2.5, 0.6}, {2.5, 2.5}, {4.0, 3.2}, {1.0, 3.0}, {0.8, 1.0}};
    const int n = 5;
    rt_follow_t f;
    rt_follow_cfg_t fc = rt_follow_default_cfg();
    assert_int_equal(rt_follow_init(&f, &fc), 0);
    int reached = 0, steps = 0;
    double min_d[5] = {1e9, 1e9, 1e9, 1e9, 1e9};
    rt_follow_cmd_t cmd = {0};
    /* Control at 20 Hz, at most 120 simulated seconds. */
    const int ctl = (int)lround(0.05 / sim_world_dt(w));
    while (!cmd.finished && sim_world_time(w) < 120.0) {
        sim_pose_t p;
        assert_int_equal(sim_world_pose(w, id, &p), 0);
        for (int i = 0; i < n; i++)
            min_d[i] = fmin(min_d[i], hypot(p.x - wps[i].x, p.y - wps[i].y));
        alloc_count_reset();
        assert_int_equal(rt_follow_step(&f, wps, n, (float)p.x, (float)p.y, (float)p.theta, &cmd), 0);
        assert_int_equal(alloc_count_allocations(), 0);
        reached += cmd.reached;
        assert_int_equal(sim_world_set_wheels(w, id, cmd.wheel_left, cmd.wheel_right), 0);
        assert_int_equal(sim_world_step(w, ctl), 0);
        steps++;
    }
    print_message("follower: finished=%d after %.1f s\n", cmd.finished, sim_world_time(w));
    assert_int_equal(cmd.finished, 1);
    assert_int_equal(reached, n);
    for (int i = 0; i < n; i++)
        assert_true(min_d[i] <= fc.reach_tol_m + 0.02); /* + one control period at 0.22 m/s */
    assert_int_equal((int)sim_world_collisions(w, id), 0);
    /* The path is about 10 m: at 0.22 m/s plus turns it takes well under 120 s. */
    assert_true(sim_world_time(w) < 90.0);
    sim_world_destroy(w);
}

static void test_physics_deterministic(void **st)
{
    (void)st;
    sim_pose_t out[2];
    for (int k = 0; k < 2; k++) {
        sim_world_t *w = box_world(3, 3, 1);
        int a, b;
        assert_int_equal(sim_world_add_robot(w, NULL, (sim_pose_t){1.0, 1.5, 0.0}, &a), 0);
        assert_int_equal(sim_world_add_robot(w, NULL, (sim_pose_t){2.0, 1.5, 3.14159}, &b), 0);
        assert_int_equal(sim_world_set_twist(w, a, 0.2, 0.1), 0);
        assert_int_equal(sim_world_set_twist(w, b, 0.2, -0.3), 0);
        assert_int_equal(sim_world_step(w, (int)lround(5.0 / sim_world_dt(w))), 0); /* meet, push */
        assert_int_equal(sim_world_pose(w, a, &out[k]), 0);
        sim_world_destroy(w);
    }
    assert_memory_equal(&out[0], &out[1], sizeof out[0]);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_create_validation),
        cmocka_unit_test(test_wheel_kinematics),
        cmocka_unit_test(test_twist_limits),
        cmocka_unit_test(test_wall_collision),
        cmocka_unit_test(test_follower_reaches_waypoints),
        cmocka_unit_test(test_physics_deterministic),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
