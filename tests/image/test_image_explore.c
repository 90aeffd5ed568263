/* The robot image exploring (docs/exploration.md): no tour, the three cores choose, plan and
 * drive to goals against the ODE world. A minute of the default plan per run: the robot reaches
 * goals and sees more of the building, never touches a wall, allocates nothing across a round,
 * and the same seed gives the same trajectory and model; the frontier policy works as well.
 * The keep-in fence host_sim gives the RT core keeps office64's courtyards out. */
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

#include "alloc_count.h"
#include "sim_coverage.h"
#include "sim_explore.h"
#include "sim_image.h"
#include "sim_paths.h"
#include "sim_plan.h"

#define PLAN "host_sim/plans/apartment.svg"
#define BUDGET_S 60.0

static sim_plan_t g_plan;
static sim_path_t g_start;

static int setup(void **st)
{
    (void)st;
    char err[512];
    sim_path_init(&g_start);
    if (sim_plan_load(PLAN, 0, &g_plan, err, sizeof err) != 0 ||
        sim_explore_start(&g_plan, 11, 0, 1, &g_start, err, sizeof err) != 0) {
        fprintf(stderr, "%s\n", err);
        return -1;
    }
    return 0;
}

static int teardown(void **st)
{
    (void)st;
    sim_path_free(&g_start);
    sim_plan_free(&g_plan);
    return 0;
}

/* A hash of the pose every simulated second, and the allocations across round 1. */
typedef struct probe {
    uint64_t hash;
    uint32_t seconds;
    int rounds;
    uint64_t alloc_at_round[4];
} probe_t;

static void on_second(uint64_t now_us, const rt_status_t *rt, const gp_core_t *gp, void *user)
{
    probe_t *p = user;
    const float v[3] = {rt->x_m, rt->y_m, rt->heading_rad};
    uint32_t w[3];
    memcpy(w, v, sizeof w);
    for (int i = 0; i < 3; i++)
        p->hash = (p->hash ^ w[i]) * 0x100000001B3ull;
    p->hash ^= now_us + gp->explore.seq;
    p->seconds++;
}

static void on_round(const ai_round_info_t *in, void *user)
{
    probe_t *p = user;
    (void)in;
    if (p->rounds < 4)
        p->alloc_at_round[p->rounds] = alloc_count_allocations();
    if (p->rounds == 0)
        alloc_count_reset();
    p->rounds++;
}

static void run_with(gp_explore_policy_t policy, int counts, sim_image_result_t *r, probe_t *p, double *coverage)
{
    static sim_coverage_t cov;
    assert_int_equal(sim_coverage_from_plan(&cov, &g_plan, SIM_COVERAGE_RES_M), 0);
    const sim_explore_opts_t xo = {policy, BUDGET_S, SIM_EXPLORE_BELIEF_PERIOD_S_DEFAULT, 0, counts, 0};
    sim_image_cfg_t c;
    sim_image_cfg_default(&c);
    c.seed = 11;
    c.rounds = 3;
    c.steps_per_round = 3;
    c.dinno.batch = 256;
    c.time_limit_s = BUDGET_S + 60.0;
    c.log_level = HAL_LOG_WARN;
    c.explore = &xo;
    char dir[] = "/tmp/fleetsim_explore_XXXXXX";
    assert_non_null(mkdtemp(dir));
    c.storage_dir = dir; /* the checkpoints: a robot whose storage fails stops */
    c.coverage = &cov;
    c.on_second = on_second;
    c.second_user = p;
    c.on_round = on_round;
    c.user = p;
    memset(p, 0, sizeof *p);
    char err[512];
    const int rc = sim_image_run(&g_plan, &g_start, &c, r, err, sizeof err);
    if (rc != 0)
        fprintf(stderr, "%s\n", err);
    assert_int_equal(rc, 0);
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    assert_int_equal(system(cmd), 0);
    coverage[0] = sim_coverage_at(&cov, 0.0);
    coverage[1] = sim_coverage_at(&cov, BUDGET_S);
    sim_coverage_free(&cov);
}

/* The fence's byte of the fine cell holding (x, y). */
static uint8_t fence_at(const sim_explore_geom_t *g, const uint8_t *inside, double x, double y)
{
    const int c = (int)floor((x - g->origin_x_m) / g->fine_res_m);
    const int r = (int)floor((y - g->origin_y_m) / g->fine_res_m);
    assert_true(c >= 0 && c < g->fine_w && r >= 0 && r < g->fine_h);
    return inside[r * g->fine_w + c];
}

/* The keep-in fence of office64 (sim_explore_keep_in): its courtyards, which a robot reaches
 * through the entrance, are outside; its rooms, corridors and the robots' starts inside. */
static void test_keep_in_fence_of_office64(void **st)
{
    (void)st;
    static sim_plan_t plan;
    static uint8_t inside[RT_GRID_MAX_CELLS];
    char err[512];
    assert_int_equal(sim_plan_load("host_sim/plans/office64.svg", 0, &plan, err, sizeof err), 0);
    sim_explore_geom_t g;
    assert_int_equal(sim_explore_geometry(&plan, &g), 0);
    const size_t n = (size_t)g.fine_w * (size_t)g.fine_h;
    assert_int_equal(sim_explore_keep_in(&plan, &g, inside, n - 1), -EINVAL); /* too small */
    assert_int_equal(sim_explore_keep_in(&plan, &g, inside, sizeof inside), 0);
    size_t out = 0;
    for (size_t i = 0; i < n; i++) {
        assert_true(inside[i] <= 1u);
        out += inside[i] == 0u;
    }
    print_message("office64: %zu of %zu fine cells outside the building\n", out, n);
    assert_true(out > n / 10 && out < n / 3); /* the courtyards and the margins: about a fifth */
    for (int robot = 0; robot < 7; robot++) { /* every start is inside */
        sim_path_t start;
        sim_path_init(&start);
        assert_int_equal(sim_explore_start(&plan, 1, robot, 7, &start, err, sizeof err), 0);
        assert_int_equal(fence_at(&g, inside, start.p[0].x, start.p[0].y), 1);
        sim_path_free(&start);
    }
    /* Rooms in, the outside out; the outer walls out (a lidar never sees inside them), the
       walls within the building in (they stay the robot's to find). */
    size_t inner_walls = 0;
    const int sweeps = (int)ceil(0.4 / g.fine_res_m);
    for (int r = 0; r < g.fine_h; r++)
        for (int c = 0; c < g.fine_w; c++) {
            const double x = g.origin_x_m + (c + 0.5) * g.fine_res_m, y = g.origin_y_m + (r + 0.5) * g.fine_res_m;
            const int k = sim_plan_classify_point(&plan, x, y), v = inside[r * g.fine_w + c];
            if (k != SIM_CELL_WALL) {
                assert_int_equal(v, k == SIM_CELL_FREE);
                continue;
            }
            int near_out = 0, touches_out = 0; /* an outside cell within `sweeps` cells, and next to it */
            for (int dr = -sweeps - 1; dr <= sweeps + 1; dr++)
                for (int dc = -sweeps - 1; dc <= sweeps + 1; dc++) {
                    const int rr = r + dr, cc = c + dc;
                    const double xx = g.origin_x_m + (cc + 0.5) * g.fine_res_m, yy = g.origin_y_m + (rr + 0.5) * g.fine_res_m;
                    const int out = rr < 0 || rr >= g.fine_h || cc < 0 || cc >= g.fine_w ||
                                    sim_plan_classify_point(&plan, xx, yy) == SIM_CELL_OUTSIDE;
                    near_out |= out;
                    touches_out |= out && abs(dr) <= 1 && abs(dc) <= 1;
                }
            if (touches_out)
                assert_int_equal(v, 0);
            if (!near_out) {
                assert_int_equal(v, 1);
                inner_walls++;
            }
        }
    print_message("office64: %zu fine cells of walls inside the building kept in\n", inner_walls);
    assert_true(inner_walls > 1000);
    /* two courtyards (between the wings), two corridors */
    const double probe[][3] = {{15.0, 38.0, 0}, {15.0, 11.0, 0}, {15.0, 30.5, 1}, {15.0, 17.0, 1}};
    for (size_t k = 0; k < sizeof probe / sizeof probe[0]; k++)
        assert_int_equal(fence_at(&g, inside, probe[k][0], probe[k][1]), (int)probe[k][2]);
    sim_plan_free(&plan);
}

/* The path weight follows a robot's share of the plan's box (sim_explore_lambda): heavier on
 * office64 than on the apartment, lighter with more robots, capped, and what the GP core gets
 * whatever the policy. */
static void test_path_weight_from_share(void **st)
{
    (void)st;
    static sim_plan_t office;
    char err[512];
    assert_int_equal(sim_plan_load("host_sim/plans/office64.svg", 0, &office, err, sizeof err), 0);
    sim_explore_geom_t apt, off;
    assert_int_equal(sim_explore_geometry(&g_plan, &apt), 0);
    assert_int_equal(sim_explore_geometry(&office, &off), 0);
    const double apt3 = sim_explore_lambda(&apt, 3), apt7 = sim_explore_lambda(&apt, 7);
    const double off3 = sim_explore_lambda(&off, 3), off1 = sim_explore_lambda(&off, 1);
    print_message("lambda: apartment 3 robots %.2f, 7 robots %.2f; office64 3 robots %.2f\n", apt3, apt7, off3);
    /* the apartment's box is 12 x 9 m, office64's 32 x 48 m */
    assert_true(fabs(apt3 - sqrt(12.0 * 9.0 / 3.0) / SIM_EXPLORE_LAMBDA_SIDE_M) < 0.05);
    assert_true(apt7 < apt3 && apt3 < off3);
    assert_true(fabs(apt7 / apt3 - sqrt(3.0 / 7.0)) < 1e-9);
    assert_true(off3 <= SIM_EXPLORE_LAMBDA_MAX && off1 == SIM_EXPLORE_LAMBDA_MAX);
    const gp_explore_policy_t policies[] = {GP_EXPLORE_UNCERTAINTY, GP_EXPLORE_FRONTIER, GP_EXPLORE_COORDINATED};
    for (size_t k = 0; k < sizeof policies / sizeof policies[0]; k++) {
        sim_explore_opts_t o = {.policy = policies[k], .budget_s = 150.0};
        gp_explore_cfg_t c;
        assert_int_equal(sim_explore_gp_cfg(&apt, &o, 0, 7, 750, &c), 0);
        assert_true(c.goal.lambda == apt7);
    }
    sim_plan_free(&office);
}

static void run(gp_explore_policy_t policy, sim_image_result_t *r, probe_t *p, double *coverage)
{
    run_with(policy, 0, r, p, coverage);
}

static void test_explores_without_touching_a_wall(void **st)
{
    (void)st;
    static sim_image_result_t r;
    probe_t p;
    double cov[2];
    run(GP_EXPLORE_UNCERTAINTY, &r, &p, cov);
    print_message("uncertainty: coverage %.3f -> %.3f in %.0f s; %llu goals, %u reached, %u plans, %u stuck; "
                  "%.2f m driven\n", cov[0], cov[1], BUDGET_S, (unsigned long long)r.explore.goals,
                  r.rt_status.goal_reached, r.rt_status.plans, r.rt_status.stuck_events, r.world.distance_m);
    assert_true(r.completed);
    assert_int_equal(r.rounds_done, 3);
    assert_true(r.rt_status.finished);
    assert_true(r.explore.goals >= 3); /* chosen again as the belief changes (reached: the frontier test) */
    assert_true(r.rt_status.plans >= r.explore.goals);
    assert_int_equal(r.rt_status.plan_failures, 0);
    assert_int_equal(r.world.collisions, 0); /* the ODE world saw no contact with a wall */
    assert_true(r.world.distance_m > 5.0);
    assert_true(cov[1] > cov[0] + 0.2);
    assert_int_equal(r.rt_status.ring_drops, 0);
    /* the belief, the goal choice and the planner allocate nothing in the steady state */
    assert_true(p.rounds >= 2);
    assert_int_equal(p.alloc_at_round[1], 0);
}

static void test_same_seed_same_exploration(void **st)
{
    (void)st;
    static sim_image_result_t a, b;
    probe_t pa, pb;
    double ca[2], cb[2];
    run(GP_EXPLORE_UNCERTAINTY, &a, &pa, ca);
    run(GP_EXPLORE_UNCERTAINTY, &b, &pb, cb);
    assert_int_equal(pa.seconds, pb.seconds);
    assert_true(pa.hash == pb.hash);
    assert_true(ca[1] == cb[1]);
    assert_int_equal(a.rt_status.plans, b.rt_status.plans);
    assert_true(a.ai_status.loss_train == b.ai_status.loss_train);
}

/* The belief that also counts where the rays went (ai/ai_seen.h): the same safety, still
 * nothing allocated once running, and the counts change where the robot goes. */
static void test_explores_with_counts(void **st)
{
    (void)st;
    static sim_image_result_t r;
    probe_t p, plain;
    double cov[2], cov_plain[2];
    run_with(GP_EXPLORE_UNCERTAINTY, 1, &r, &p, cov);
    print_message("uncertainty with counts: coverage %.3f -> %.3f; %llu goals, %u reached; %.2f m driven\n", cov[0],
                  cov[1], (unsigned long long)r.explore.goals, r.rt_status.goal_reached, r.world.distance_m);
    assert_true(r.completed);
    assert_int_equal(r.world.collisions, 0);
    assert_int_equal(r.rt_status.plan_failures, 0);
    assert_true(cov[1] > cov[0] + 0.2);
    assert_true(p.rounds >= 2);
    assert_int_equal(p.alloc_at_round[1], 0);
    static sim_image_result_t q;
    run(GP_EXPLORE_UNCERTAINTY, &q, &plain, cov_plain);
    assert_true(p.hash != plain.hash);
}

static void test_frontier_policy(void **st)
{
    (void)st;
    static sim_image_result_t r;
    probe_t p;
    double cov[2];
    run(GP_EXPLORE_FRONTIER, &r, &p, cov);
    print_message("frontier: coverage %.3f -> %.3f; %llu goals, %u reached\n", cov[0], cov[1],
                  (unsigned long long)r.explore.goals, r.rt_status.goal_reached);
    assert_true(r.completed);
    /* goals chosen on the robot's own scans and driven to (reaching one is the RT core's tests';
       in 60 s the nearest frontier recedes as the robot comes and the goal moves on with it) */
    assert_true(r.explore.goals >= 2 && r.rt_status.plans >= r.explore.goals);
    assert_int_equal(r.world.collisions, 0);
    assert_true(cov[1] > cov[0] + 0.2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_keep_in_fence_of_office64),
        cmocka_unit_test(test_path_weight_from_share),
        cmocka_unit_test(test_explores_without_touching_a_wall),
        cmocka_unit_test(test_same_seed_same_exploration),
        cmocka_unit_test(test_explores_with_counts),
        cmocka_unit_test(test_frontier_policy),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
