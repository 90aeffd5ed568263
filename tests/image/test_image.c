/* The robot firmware image (RT, AI, GP cores as threads) bound to the ODE world in lockstep:
 * pool policies, lockstep timing with the real world, no allocation across a round boundary,
 * bit-identical checkpoints on one or two CPUs, and learning along the path. */
#define _GNU_SOURCE
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>
#include <cmocka.h>

#include "ai/ai_pool.h"
#include "ai/ai_rng.h"
#include "alloc_count.h"
#include "sim_image.h"
#include "sim_paths.h"
#include "sim_plan.h"

#define PLAN "host_sim/plans/apartment.svg"
#define PATH5 "host_sim/plans/apartment/robot_5.csv"

#ifdef __SANITIZE_ADDRESS__
#define STEPS_LEARN 20u
#else
#define STEPS_LEARN 60u
#endif

static sim_plan_t g_plan;
static sim_path_t g_path;

static int setup(void **st)
{
    (void)st;
    char err[512];
    if (sim_plan_load(PLAN, 0, &g_plan, err, sizeof err) != 0 ||
        sim_path_read_csv(PATH5, &g_plan, &g_path, err, sizeof err) != 0) {
        fprintf(stderr, "%s\n", err);
        return -1;
    }
    return 0;
}

static int teardown(void **st)
{
    (void)st;
    sim_path_free(&g_path);
    sim_plan_free(&g_plan);
    return 0;
}

/* ---- pool policies ------------------------------------------------------------------------ */
static void test_pool_cdr_dr(void **st)
{
    (void)st;
    ai_sample_t buf[16];
    ai_pool_t p;
    assert_int_equal(ai_pool_init(&p, buf, 16, AI_POOL_CDR, 7), 0);
    for (int i = 0; i < 10; i++) {
        ai_sample_t s = {(float)i, 0, 0};
        assert_int_equal(ai_pool_offer(&p, &s), 1);
    }
    ai_pool_boundary(&p);
    assert_int_equal(p.fill, 10); /* CDR keeps */
    for (int i = 0; i < 10; i++)
        assert_true(buf[i].x == (float)i);
    assert_int_equal(ai_pool_init(&p, buf, 16, AI_POOL_DR, 7), 0);
    for (int i = 0; i < 40; i++) {
        ai_sample_t s = {(float)i, 0, 0};
        (void)ai_pool_offer(&p, &s);
    }
    assert_int_equal(p.fill, 16);
    ai_pool_boundary(&p);
    assert_int_equal(p.fill, 0); /* DR clears */
    assert_int_equal(p.seen, 0);
    ai_sample_t s = {1, 0, 0};
    assert_int_equal(ai_pool_offer(&p, &s), 1);
    assert_int_equal(p.fill, 1);
    ai_pool_policy_t pol;
    assert_int_equal(ai_pool_policy_parse("dr", &pol), 0);
    assert_int_equal(pol, AI_POOL_DR);
    assert_int_equal(ai_pool_policy_parse("x", &pol), -EINVAL);
    assert_int_equal(ai_pool_init(&p, NULL, 4, AI_POOL_CDR, 1), -EINVAL);
}

/* Reservoir: each of M offered items is kept with probability cap / M. Over R seeds, item i's
 * keep count is Binomial(R, cap/M): mean R*cap/M = 250, sd ~ 14.4; check every item within
 * 5 sd and the early/late halves within 2% of each other. */
static void test_pool_reservoir_stats(void **st)
{
    (void)st;
    enum { CAP = 50, M = 200, R = 1000 };
    static ai_sample_t buf[CAP];
    static unsigned kept[M];
    memset(kept, 0, sizeof kept);
    for (int r = 0; r < R; r++) {
        ai_pool_t p;
        assert_int_equal(ai_pool_init(&p, buf, CAP, AI_POOL_CDR, ai_rng_mix64((uint64_t)r + 1)), 0);
        for (int i = 0; i < M; i++) {
            ai_sample_t s = {(float)i, 0, 0};
            (void)ai_pool_offer(&p, &s);
        }
        assert_int_equal(p.fill, CAP);
        for (int j = 0; j < CAP; j++)
            kept[(int)buf[j].x]++;
    }
    const double mean = (double)R * CAP / M, sd = sqrt(mean * (1.0 - (double)CAP / M));
    double first = 0, second = 0;
    for (int i = 0; i < M; i++) {
        assert_true(fabs((double)kept[i] - mean) < 5.0 * sd);
        *(i < M / 2 ? &first : &second) += kept[i];
    }
    assert_true(fabs(first - second) / (first + second) < 0.02);
}

/* ---- the image against the world ---------------------------------------------------------- */
typedef struct round_probe {
    int n;
    uint64_t alloc_at[8];
} round_probe_t;

static void on_round(const ai_round_info_t *in, void *user)
{
    round_probe_t *p = user;
    (void)in;
    if (p->n < 8)
        p->alloc_at[p->n] = alloc_count_allocations();
    if (p->n == 0)
        alloc_count_reset();
    p->n++;
}

static void base_cfg(sim_image_cfg_t *c, uint32_t rounds, uint32_t steps)
{
    sim_image_cfg_default(c);
    c->seed = 11;
    c->rounds = rounds;
    c->steps_per_round = steps;
    c->dinno.batch = 256;
    c->time_limit_s = 200;
    c->log_level = HAL_LOG_WARN;
}

static void test_lockstep_and_noalloc(void **st)
{
    (void)st;
    sim_image_cfg_t c;
    base_cfg(&c, 3, 3);
    round_probe_t probe = {0};
    c.on_round = on_round;
    c.user = &probe;
    char dir[] = "/tmp/fleetsim_img_XXXXXX";
    assert_non_null(mkdtemp(dir));
    c.storage_dir = dir;
    static sim_image_result_t r;
    char err[512];
    assert_int_equal(sim_image_run(&g_plan, &g_path, &c, &r, err, sizeof err), 0);
    assert_true(r.completed);
    assert_int_equal(r.rounds_done, 3);
    assert_int_equal(probe.n, 3);
    /* Steady state across the boundary of round 1 (and its checkpoint write): nothing
     * allocated by our code between the callbacks of rounds 0 and 1. */
    assert_int_equal(probe.alloc_at[1], 0);
    /* Lockstep: every RT tick at exactly k * 20 ms, none skipped or repeated, lateness 0. */
    const uint64_t T = r.sim_time_us;
    assert_int_equal(r.rt.tick_gaps, 0);
    assert_int_equal(r.rt.clock_mismatch, 0);
    assert_int_equal(r.rt.ticks, T / FW_RT_PERIOD_US + 1u);
    assert_int_equal(r.rt.scan_ticks > 0, 1);
    for (int i = 0; i < HAL_CORE_COUNT; i++) {
        assert_int_equal(r.core[i].late_ticks, 0);
        assert_int_equal(r.core[i].lateness_max_us, 0);
        assert_true(r.core[i].stack_used_bytes > 0 && r.core[i].stack_used_bytes < r.core[i].stack_size_bytes);
    }
    assert_int_equal(r.core[HAL_CORE_GP].ticks, T / FW_GP_PERIOD_US + 1u);
    /* The physics ran exactly to T in 10 ms steps, one advance per lockstep instant. */
    assert_int_equal(r.world.steps, T / 10000u);
    assert_int_equal(r.world.t_us, T);
    assert_int_equal(r.world.advances, r.host_world_steps);
    assert_int_equal(r.rt_status.ring_drops, 0);
    assert_int_equal(r.ai_status.pool_offered, r.rt_status.samples);
    assert_int_equal(r.gp.ckpt_written, 3);
    assert_int_equal(r.final_ckpt_status, 0);
    assert_true(r.rt_status.finished);
    char cmd[256];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    assert_int_equal(system(cmd), 0);
}

/* ---- bit-identical checkpoint on one or two CPUs ------------------------------------------ */
static int run_child(const char *dir, int ncpu)
{
    cpu_set_t set;
    CPU_ZERO(&set);
    for (int i = 0; i < ncpu; i++)
        CPU_SET(i, &set);
    if (sched_setaffinity(0, sizeof set, &set) != 0)
        return 3;
    sim_image_cfg_t c;
    base_cfg(&c, 2, 4);
    c.storage_dir = dir;
    c.ckpt_every = 0;
    static sim_image_result_t r;
    char err[512];
    if (sim_image_run(&g_plan, &g_path, &c, &r, err, sizeof err) != 0 || !r.completed)
        return 4;
    return 0;
}

static size_t read_file(const char *path, uint8_t **out)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL)
        return 0;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    *out = malloc((size_t)n);
    size_t got = fread(*out, 1, (size_t)n, f);
    fclose(f);
    return got;
}

static void test_same_ckpt_one_or_two_cpus(void **st)
{
    (void)st;
    if (sysconf(_SC_NPROCESSORS_ONLN) < 2)
        skip();
    char d1[] = "/tmp/fleetsim_cpu1_XXXXXX", d2[] = "/tmp/fleetsim_cpu2_XXXXXX";
    assert_non_null(mkdtemp(d1));
    assert_non_null(mkdtemp(d2));
    const char *dirs[2] = {d1, d2};
    for (int k = 0; k < 2; k++) {
        fflush(NULL);
        pid_t pid = fork();
        assert_true(pid >= 0);
        if (pid == 0)
            _exit(run_child(dirs[k], k + 1));
        int status = 0;
        assert_int_equal(waitpid(pid, &status, 0), pid);
        assert_true(WIFEXITED(status));
        assert_int_equal(WEXITSTATUS(status), 0);
    }
    uint8_t *a = NULL, *b = NULL;
    char f1[128], f2[128];
    snprintf(f1, sizeof f1, "%s/final.bnn", d1);
    snprintf(f2, sizeof f2, "%s/final.bnn", d2);
    size_t na = read_file(f1, &a), nb = read_file(f2, &b);
    assert_true(na > BNN_CKPT_HEADER_BYTES);
    assert_int_equal(na, nb);
    assert_memory_equal(a, b, na);
    free(a);
    free(b);
    char cmd[256];
    snprintf(cmd, sizeof cmd, "rm -rf %s %s", d1, d2);
    assert_int_equal(system(cmd), 0);
}

/* ---- a single robot learns the map along its path ------------------------------------------ */
static void test_learns_map_along_path(void **st)
{
    (void)st;
    char dir[] = "/tmp/fleetsim_learn_XXXXXX";
    assert_non_null(mkdtemp(dir));
    sim_image_cfg_t c;
    base_cfg(&c, 4, STEPS_LEARN);
    c.dinno.batch = 512;
    c.storage_dir = dir;
    c.ckpt_every = 0;
    static sim_image_result_t r;
    char err[512];
    assert_int_equal(sim_image_run(&g_plan, &g_path, &c, &r, err, sizeof err), 0);
    assert_true(r.completed);
    static bnn_model_t m;
    assert_int_equal(bnn_init(&m, NULL, ai_rng_mix64(c.seed ^ 1u)), 0);
    double mse0 = 0, mse1 = 0;
    size_t n0 = 0, n1 = 0;
    assert_int_equal(sim_image_occ_near_path(&g_plan, &g_path, &m, 0.1, 1.0, &mse0, &n0), 0);
    uint8_t *buf = NULL;
    char f[128];
    snprintf(f, sizeof f, "%s/final.bnn", dir);
    size_t n = read_file(f, &buf);
    assert_true(n > 0);
    assert_int_equal(bnn_ckpt_load(&m, buf, n, NULL), 0);
    free(buf);
    assert_int_equal(sim_image_occ_near_path(&g_plan, &g_path, &m, 0.1, 1.0, &mse1, &n1), 0);
    printf("occupancy MSE within 1 m of the path (%zu cells): init %.4f, after %u rounds x %u steps %.4f\n",
           n1, mse0, c.rounds, c.steps_per_round, mse1);
    assert_int_equal(n0, n1);
    assert_true(n1 > 500);
    assert_true(mse1 < 0.6 * mse0);
    assert_true(mse1 < 0.16);
    char cmd[256];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    assert_int_equal(system(cmd), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pool_cdr_dr),
        cmocka_unit_test(test_pool_reservoir_stats),
        cmocka_unit_test(test_lockstep_and_noalloc),
        cmocka_unit_test(test_same_ckpt_one_or_two_cpus),
        cmocka_unit_test(test_learns_map_along_path),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
