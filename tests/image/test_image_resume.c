/* The robot image resumed, stopped and failing, against the world in lockstep (sim_image):
 *   - started at round 2 from round 1's checkpoint (offline, alone): the GP core's round log
 *     begins at round 2, checkpoints follow ckpt_every counted from round 0 (round_0003.bnn
 *     with ckpt_every 2, never round_0002 or round_0004), final.bnn is written, and it equals
 *     the final model of the run that did every round, byte for byte;
 *   - a stop request (what SIGTERM does, hal_host_stop.h) ends the run at the end of the
 *     slice: not completed, stop_signal set, no final checkpoint;
 *   - a checkpoint that cannot be written (its folder replaced by a file) stops the run at
 *     the end of that slice, long before the last round, with the error and its round. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <cmocka.h>

#include "hal_host_stop.h"
#include "run_outputs.h"
#include "sim_image.h"
#include "sim_paths.h"
#include "sim_plan.h"

#define PLAN "host_sim/plans/apartment.svg"
#define PATH2 "host_sim/plans/apartment/robot_2.csv"

static sim_plan_t g_plan;
static sim_path_t g_path;
static char g_dir[] = "/tmp/fleetsim_resume_XXXXXX";

static int setup(void **st)
{
    (void)st;
    char err[512];
    if (sim_plan_load(PLAN, 0, &g_plan, err, sizeof err) != 0 ||
        sim_path_read_csv(PATH2, &g_plan, &g_path, err, sizeof err) != 0) {
        fprintf(stderr, "%s\n", err);
        return -1;
    }
    return mkdtemp(g_dir) != NULL ? 0 : -1;
}

static int teardown(void **st)
{
    (void)st;
    sim_path_free(&g_path);
    sim_plan_free(&g_plan);
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf %s", g_dir);
    return system(cmd) == 0 ? 0 : -1;
}

static void base_cfg(sim_image_cfg_t *c, uint32_t rounds, const char *dir)
{
    sim_image_cfg_default(c);
    c->seed = 5;
    c->rounds = rounds;
    c->offline = 1;
    c->steps_per_round = 3;
    c->dinno.batch = 128;
    c->time_limit_s = 300;
    c->log_level = HAL_LOG_WARN;
    c->storage_dir = dir;
}

static void sub(char *out, size_t cap, const char *name)
{
    snprintf(out, cap, "%s/%s", g_dir, name);
}

static int exists(const char *dir, const char *name)
{
    char p[256];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    return access(p, F_OK) == 0;
}

static uint8_t *file(const char *dir, const char *name, size_t *n)
{
    char p[256];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    uint8_t *b = test_slurp(p, n);
    assert_non_null(b);
    return b;
}

typedef struct log_probe {
    uint32_t n, first;
} log_probe_t;

static void note_round(const ai_round_info_t *in, void *user)
{
    log_probe_t *p = user;
    if (p->n++ == 0)
        p->first = in->round;
}

static void test_resumed_run_equals_full_run(void **st)
{
    (void)st;
    char full[200], resumed[200];
    sub(full, sizeof full, "full");
    sub(resumed, sizeof resumed, "resumed");
    static sim_image_result_t r;
    char err[512];
    sim_image_cfg_t c;
    base_cfg(&c, 5, full);
    assert_int_equal(sim_image_run(&g_plan, &g_path, &c, &r, err, sizeof err), 0);
    assert_true(r.completed);

    size_t n1 = 0;
    uint8_t *ck1 = file(full, "round_0001.bnn", &n1);
    base_cfg(&c, 5, resumed);
    c.start_round = 2;
    c.resume_ckpt = ck1;
    c.resume_ckpt_bytes = n1;
    c.ckpt_every = 2;
    log_probe_t probe = {0};
    c.on_round = note_round;
    c.user = &probe;
    assert_int_equal(sim_image_run(&g_plan, &g_path, &c, &r, err, sizeof err), 0);
    free(ck1);
    assert_true(r.completed);
    assert_int_equal(r.rounds_done, 5);
    assert_int_equal(probe.n, 3); /* rounds 2, 3, 4 */
    assert_int_equal(probe.first, 2);
    assert_int_equal(r.gp.ckpt_written, 3);
    assert_int_equal(r.gp.ckpt_failed, 0);
    assert_int_equal(r.ckpt_error, 0);
    assert_int_equal(r.stop_signal, 0);
    assert_true(r.rt_status.finished); /* the whole tour was driven again */
    assert_false(exists(resumed, "round_0001.bnn"));
    assert_false(exists(resumed, "round_0002.bnn"));
    assert_true(exists(resumed, "round_0003.bnn"));
    assert_false(exists(resumed, "round_0004.bnn"));
    const char *same[] = {"round_0003.bnn", "final.bnn"};
    for (int i = 0; i < 2; i++) {
        size_t na = 0, nb = 0;
        uint8_t *a = file(full, same[i], &na), *b = file(resumed, same[i], &nb);
        assert_int_equal(na, nb);
        assert_memory_equal(a, b, na);
        free(a);
        free(b);
    }
}

/* What the SIGTERM handler does, from the host's callback after the first round. */
static void stop_after_first(const ai_round_info_t *in, void *user)
{
    (void)in;
    (void)user;
    hal_host_request_stop(SIGTERM);
}

static void test_stop_request_ends_the_run(void **st)
{
    (void)st;
    char dir[200];
    sub(dir, sizeof dir, "stopped");
    sim_image_cfg_t c;
    base_cfg(&c, 60, dir);
    c.on_round = stop_after_first;
    static sim_image_result_t r;
    char err[512];
    const int rc = sim_image_run(&g_plan, &g_path, &c, &r, err, sizeof err);
    const int sig = hal_host_stop_signal();
    hal_host_stop_clear();
    assert_int_equal(rc, 0);
    assert_int_equal(sig, SIGTERM);
    assert_int_equal(r.stop_signal, SIGTERM);
    assert_false(r.completed);
    assert_true(r.rounds_done >= 1 && r.rounds_done < 60);
    assert_false(exists(dir, "final.bnn"));
    /* A request made before the run ends it before the first slice. */
    hal_host_request_stop(SIGINT);
    c.on_round = NULL;
    const int rc2 = sim_image_run(&g_plan, &g_path, &c, &r, err, sizeof err);
    hal_host_stop_clear();
    assert_int_equal(rc2, 0);
    assert_int_equal(r.stop_signal, SIGINT);
    assert_int_equal(r.rounds_done, 0);
    assert_true(r.sim_time_us < 1000000u);
}

/* After the first round, the storage folder becomes a file: every later write fails. */
static const char *g_break_dir;
static void break_storage(const ai_round_info_t *in, void *user)
{
    (void)in;
    (void)user;
    if (g_break_dir == NULL)
        return;
    char cmd[512];
    snprintf(cmd, sizeof cmd, "rm -rf '%s' && touch '%s'", g_break_dir, g_break_dir);
    assert_int_equal(system(cmd), 0);
    g_break_dir = NULL;
}

static void test_failed_checkpoint_stops_the_run(void **st)
{
    (void)st;
    char dir[200];
    sub(dir, sizeof dir, "broken");
    sim_image_cfg_t c;
    base_cfg(&c, 60, dir);
    g_break_dir = dir;
    c.on_round = break_storage;
    static sim_image_result_t r;
    char err[512];
    assert_int_equal(sim_image_run(&g_plan, &g_path, &c, &r, err, sizeof err), 0);
    assert_false(r.completed);
    assert_true(r.ckpt_error < 0);
    assert_true(r.ckpt_error_round >= 1);
    assert_true(r.gp.ckpt_written >= 1);
    assert_true(r.rounds_done < 30); /* stopped at the end of the slice, not at round 60 */
    assert_int_equal(r.stop_signal, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_resumed_run_equals_full_run),
        cmocka_unit_test(test_stop_request_ends_the_run),
        cmocka_unit_test(test_failed_checkpoint_stops_the_run),
    };
    return cmocka_run_group_tests_name("image/resume", tests, setup, teardown);
}
