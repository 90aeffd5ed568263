/* "A failed run never replaces or removes an earlier result", tested on the real program:
 * every host_sim command that writes files is run as a subprocess over the outputs of an
 * earlier good run, through each way a run can fail (a full disk, through the
 * FLEETSIM_FAIL_WRITE_AFTER seam of hal/host/hal_host_file.h; a run stopped early; input
 * rejected half-way; an --out that is a directory, a device or too long). Each time: the exit
 * status is non-zero, the message names the path and the real reason, the earlier files are
 * byte-identical, no temporary file is left and nothing else in the folder was removed.
 * Also: inputs that are directories, an unknown last option, a validation set of another
 * plan (once a heap corruption), --out parents created, stale temporary files cleared. */
#define _XOPEN_SOURCE 700 /* realpath */
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <cmocka.h>

#include "run_outputs.h"

#define SHORT_PATH 1024 /* our own paths; PATH_MAX-sized buffers hold them with a name added */
static char g_bin[SHORT_PATH];   /* build/<config>/bin/host_sim */
static char g_dir[SHORT_PATH];   /* scratch folder of this test */
static char g_plan[PATH_MAX];    /* host_sim/plans/apartment.svg */
static char g_paths[PATH_MAX];
static char g_err[1 << 16];   /* stderr of the last run */

/* Runs host_sim with argv (NULL-terminated; argv[0] is ignored) and optionally the disk-full
 * seam; returns the exit status (128 + signal when killed) and keeps stderr in g_err. */
static int hs(long fail_after, const char *const *args)
{
    return test_run(g_bin, args, fail_after, g_dir, g_err, NULL, sizeof g_err);
}

#define HS(fail, ...) hs((fail), (const char *const[]){"host_sim", __VA_ARGS__, NULL})
/* A run that must succeed; on failure its stderr is shown. */
#define HS_OK(...)                                                                           \
    do {                                                                                     \
        int rc_ = HS(-1, __VA_ARGS__);                                                       \
        if (rc_ != 0)                                                                        \
            fail_msg("host_sim exited %d:\n%s", rc_, g_err);                                 \
    } while (0)

static void path_in(char *out, const char *name)
{
    assert_true(strlen(name) < 64);
    snprintf(out, PATH_MAX, "%.1023s/%.63s", g_dir, name);
}

static void expect_err(const char *a, const char *b)
{
    if (strstr(g_err, a) == NULL || (b != NULL && strstr(g_err, b) == NULL))
        fail_msg("stderr lacks '%s'%s%s:\n%s", a, b ? " / " : "", b ? b : "", g_err);
}

static int setup(void **st)
{
    (void)st;
    test_build_program("host_sim", g_bin, sizeof g_bin);
    snprintf(g_dir, sizeof g_dir, "/tmp/fleetsim-outputs-XXXXXX");
    assert_non_null(mkdtemp(g_dir));
    assert_non_null(realpath("host_sim/plans/apartment.svg", g_plan));
    assert_non_null(realpath("host_sim/plans/apartment", g_paths));
    assert_true(strlen(g_plan) < SHORT_PATH && strlen(g_paths) < SHORT_PATH);
    return 0;
}

static int teardown(void **st)
{
    (void)st;
    return test_remove_tree(g_dir);
}

/* The files commands write into g_dir, from one good run each. */
static void good_outputs(void)
{
    char p[PATH_MAX], q[PATH_MAX];
    path_in(p, "good.samples");
    char r2[PATH_MAX + 32];
    snprintf(r2, sizeof r2, "%s/robot_2.csv", g_paths);
    HS_OK("scan", "--plan", g_plan, "--path", r2, "--out", p, "-q");
    path_in(p, "v.samples");
    HS_OK("valset", "--plan", g_plan, "--out", p, "--poses", "3");
    path_in(p, "p.svg");
    HS_OK("plan", "gen", "--seed", "3", "--out", p);
    path_in(p, "g.png");
    HS_OK("plan", "grid", g_plan, "--res", "0.2", "--out", p);
    path_in(p, "scene.png");
    HS_OK("render", "--plan", g_plan, "--out", p);
    path_in(p, "tours");
    HS_OK("paths", "gen", "--plan", g_plan, "--robots", "2", "--seed", "1", "--out", p);
    path_in(p, "fleet");
    path_in(q, "v.samples");
    HS_OK("fleet", "--inproc", "--plan", g_plan, "--paths", g_paths, "--robots", "2",
                        "--rounds", "2", "--strategy", "kl", "--graph", "full", "--seed", "1", "--out", p,
                        "--valset", q, "--mc", "2", "--map-res", "0.2");
    path_in(p, "run");
    HS_OK("run", "--plan", g_plan, "--path", r2, "--out", p, "--online", "--rounds", "2",
                        "--steps-per-round", "5", "--val-poses", "2", "--mc", "2", "--map-res", "0.2", "--quiet");
}

static void test_full_disk_keeps_every_earlier_output(void **st)
{
    (void)st;
    good_outputs();
    char p[PATH_MAX], q[PATH_MAX], fleet[PATH_MAX], run[PATH_MAX], tours[PATH_MAX], r2[PATH_MAX + 32];
    snprintf(r2, sizeof r2, "%s/robot_2.csv", g_paths);
    path_in(fleet, "fleet");
    path_in(run, "run");
    path_in(tours, "tours");
    snap_t top, sf, sr, st2;
    snap_take(&top, g_dir);
    snap_take(&sf, fleet);
    snap_take(&sr, run);
    snap_take(&st2, tours);
    /* what good_outputs() wrote (the fleet and the run: with coverage.csv and coverage.bin) */
    assert_true(top.n == 5 && sf.n == 7 && sr.n == 14 && st2.n == 2);
    /* A disk that takes 100 more bytes, then no more: every writer must fail whole. */
    const long room = 100;
    path_in(p, "good.samples");
    assert_int_equal(HS(room, "scan", "--plan", g_plan, "--path", r2, "--out", p, "-q"), 1);
    expect_err(p, "No space left on device");
    path_in(p, "v.samples");
    assert_int_equal(HS(room, "valset", "--plan", g_plan, "--out", p, "--poses", "3"), 1);
    expect_err(p, "No space left on device");
    path_in(p, "p.svg");
    assert_int_equal(HS(room, "plan", "gen", "--seed", "4", "--out", p), 1);
    expect_err(p, "No space left on device");
    path_in(p, "g.png");
    assert_true(HS(room, "plan", "grid", g_plan, "--res", "0.1", "--out", p) != 0);
    expect_err(p, "No space left on device");
    path_in(p, "scene.png");
    assert_true(HS(room, "render", "--plan", g_plan, "--out", p) != 0);
    expect_err(p, "No space left on device");
    assert_true(HS(room, "paths", "gen", "--plan", g_plan, "--robots", "2", "--seed", "2", "--out", tours) != 0);
    expect_err(tours, "No space left on device");
    path_in(q, "v.samples");
    assert_true(HS(room, "fleet", "--inproc", "--plan", g_plan, "--paths", g_paths, "--robots", "2", "--rounds",
                   "3", "--strategy", "kl", "--graph", "full", "--seed", "2", "--out", fleet, "--valset", q,
                   "--mc", "2", "--map-res", "0.2") != 0);
    expect_err(fleet, "No space left on device");
    assert_true(HS(room, "run", "--plan", g_plan, "--path", r2, "--out", run, "--online", "--rounds", "2",
                   "--steps-per-round", "5", "--val-poses", "2", "--mc", "2", "--map-res", "0.2", "--seed", "2",
                   "--quiet") != 0);
    expect_err(run, "No space left on device");
    snap_check(&top, g_dir);
    snap_check(&sf, fleet);
    snap_check(&sr, run);
    snap_check(&st2, tours);
    snap_free(&top);
    snap_free(&sf);
    snap_free(&sr);
    snap_free(&st2);
}

static void test_stopped_or_rejected_run_keeps_earlier_output(void **st)
{
    (void)st;
    good_outputs();
    char p[PATH_MAX], fleet[PATH_MAX], r2[PATH_MAX + 32], bad[PATH_MAX + 32], sdir[PATH_MAX];
    snprintf(r2, sizeof r2, "%s/robot_2.csv", g_paths);
    snap_t top;
    snap_take(&top, g_dir);
    /* Stopped early: the path is not finished within --max-time. */
    path_in(p, "good.samples");
    assert_int_equal(HS(-1, "scan", "--plan", g_plan, "--path", r2, "--out", p, "--max-time", "1", "-q"), 1);
    expect_err("path not finished", NULL);
    /* Input rejected half-way: robot 1's training samples are corrupt after robot 0's were read. */
    path_in(sdir, "bad_samples");
    assert_int_equal(mkdir(sdir, 0755), 0);
    path_in(p, "good.samples");
    snprintf(bad, sizeof bad, "%s/robot_0.samples", sdir);
    assert_int_equal(link(p, bad), 0);
    snprintf(bad, sizeof bad, "%s/robot_1.samples", sdir);
    FILE *f = fopen(bad, "wb");
    fputs("FLEETSMP but not really", f);
    fclose(f);
    path_in(fleet, "fleet");
    snap_t sf;
    snap_take(&sf, fleet);
    assert_int_equal(HS(-1, "fleet", "--inproc", "--plan", g_plan, "--paths", g_paths, "--robots", "2", "--rounds",
                        "2", "--strategy", "kl", "--graph", "full", "--seed", "1", "--out", fleet, "--samples",
                        sdir),
                     1);
    expect_err(bad, NULL);
    snap_check(&top, g_dir);
    snap_check(&sf, fleet);
    snap_free(&top);
    snap_free(&sf);
}

static void test_out_that_is_not_ours(void **st)
{
    (void)st;
    char p[PATH_MAX], r2[PATH_MAX + 32];
    snprintf(r2, sizeof r2, "%s/robot_2.csv", g_paths);
    /* A directory where a file is written. */
    path_in(p, "a_dir");
    assert_int_equal(mkdir(p, 0755), 0);
    assert_int_equal(HS(-1, "scan", "--plan", g_plan, "--path", r2, "--out", p, "-q"), 1);
    expect_err(p, "Is a directory");
    assert_int_equal(HS(-1, "plan", "gen", "--seed", "3", "--out", p), 1);
    expect_err(p, "Is a directory");
    /* A regular file where a directory is written. */
    path_in(p, "a_file");
    FILE *f = fopen(p, "w");
    fputs("mine\n", f);
    fclose(f);
    assert_true(HS(-1, "paths", "gen", "--plan", g_plan, "--robots", "2", "--seed", "1", "--out", p) != 0);
    expect_err(p, "Not a directory");
    size_t n = 0;
    uint8_t *b = test_slurp(p, &n);
    assert_true(b != NULL && n == 5 && memcmp(b, "mine\n", 5) == 0);
    free(b);
    /* A device: refused, and still there afterwards (running as root must not remove it). */
    const char *dev = access("/dev/full", F_OK) == 0 ? "/dev/full" : "/dev/null";
    assert_int_equal(HS(-1, "scan", "--plan", g_plan, "--path", r2, "--out", dev, "-q"), 1);
    expect_err(dev, "exists and is not a regular file");
    assert_int_equal(HS(-1, "valset", "--plan", g_plan, "--out", dev, "--poses", "2"), 1);
    expect_err(dev, "exists and is not a regular file");
    struct stat sb;
    assert_int_equal(stat(dev, &sb), 0);
    assert_true(S_ISCHR(sb.st_mode));
    /* A path too long for the system. */
    char longp[5200];
    int k = snprintf(longp, sizeof longp, "%s/", g_dir);
    memset(longp + k, 'x', 5000);
    longp[k + 5000] = '\0';
    assert_int_equal(HS(-1, "scan", "--plan", g_plan, "--path", r2, "--out", longp, "-q"), 1);
    expect_err("File name too long", NULL);
    assert_true(HS(-1, "fleet", "--inproc", "--plan", g_plan, "--paths", g_paths, "--robots", "1", "--rounds", "1",
                   "--strategy", "kl", "--graph", "full", "--seed", "1", "--out", longp) != 0);
    expect_err("File name too long", NULL);
}

static void test_inputs_and_options(void **st)
{
    (void)st;
    char p[PATH_MAX], q[PATH_MAX], r2[PATH_MAX + 32];
    snprintf(r2, sizeof r2, "%s/robot_2.csv", g_paths);
    /* Directories given as input files. */
    assert_int_equal(HS(-1, "scan", "--plan", g_dir, "--path", r2, "--out", "x.samples"), 1);
    expect_err(g_dir, "Is a directory");
    assert_int_equal(HS(-1, "paths", "check", "--plan", g_plan, g_dir), 1);
    expect_err(g_dir, "Is a directory");
    path_in(p, "f");
    assert_true(HS(-1, "fleet", "--inproc", "--plan", g_plan, "--paths", g_paths, "--robots", "1", "--rounds", "1",
                   "--strategy", "kl", "--graph", "full", "--seed", "1", "--out", p, "--valset", g_dir) != 0);
    expect_err(g_dir, "Is a directory");
    /* A plan that is not there: its path and the reason, no line (there is no text). */
    assert_int_equal(HS(-1, "plan", "check", "/nonexistent.svg"), 1);
    expect_err("/nonexistent.svg: cannot open: No such file or directory\n", NULL);
    /* An unknown option given last is unknown, not "needs a value". */
    assert_int_equal(HS(-1, "scan", "--plan", g_plan, "--bogus"), 2);
    expect_err("unknown option '--bogus'", NULL);
    assert_int_equal(HS(-1, "fleet", "--inproc", "--bogus"), 2);
    expect_err("unknown option '--bogus'", NULL);
    assert_int_equal(HS(-1, "scan", "--plan", g_plan, "--out"), 2);
    expect_err("option --out needs a value", NULL);
    /* A validation set of another plan: a clear error, no crash (was a double free). */
    path_in(p, "other.svg");
    HS_OK("plan", "gen", "--seed", "3", "--out", p);
    path_in(q, "other.samples");
    HS_OK("valset", "--plan", p, "--out", q, "--poses", "5");
    path_in(p, "f2");
    assert_int_equal(HS(-1, "fleet", "--inproc", "--plan", g_plan, "--paths", g_paths, "--robots", "1", "--rounds",
                        "1", "--strategy", "kl", "--graph", "full", "--seed", "1", "--out", p, "--valset", q),
                     1);
    expect_err(q, "its bounding box is not the plan's");
    /* A full graph beyond the neighbour slots: refused before any tour is read. */
    path_in(p, "f3");
    assert_int_equal(HS(-1, "fleet", "--inproc", "--plan", g_plan, "--paths", g_paths, "--robots", "40", "--rounds",
                        "1", "--graph", "full", "--seed", "1", "--out", p),
                     2);
    expect_err("--graph full of 40 robots needs 39 neighbour slots", NULL);
}

static void test_out_parents_and_stale_temporaries(void **st)
{
    (void)st;
    char p[PATH_MAX], f[PATH_MAX + 64], r2[PATH_MAX + 32];
    snprintf(r2, sizeof r2, "%s/robot_2.csv", g_paths);
    path_in(p, "a/b/c");
    HS_OK("paths", "gen", "--plan", g_plan, "--robots", "2", "--seed", "1", "--out", p);
    snprintf(f, sizeof f, "%s/robot_1.csv", p);
    assert_int_equal(access(f, R_OK), 0);
    path_in(p, "d/e/scan.samples");
    HS_OK("scan", "--plan", g_plan, "--path", r2, "--out", p, "--max-time", "1000", "-q");
    assert_int_equal(access(p, R_OK), 0);
    /* A killed run's temporary files (a PID that cannot be alive) are cleared by the next run
       in that folder; files that are not ours stay. */
    path_in(p, "r");
    assert_int_equal(mkdir(p, 0755), 0);
    const char *names[] = {".metrics.csv.2147483646.fstmp", ".round_0001.bnn.tmp", "notes.txt", ".hidden"};
    for (int i = 0; i < 4; i++) {
        snprintf(f, sizeof f, "%s/%s", p, names[i]);
        FILE *o = fopen(f, "w");
        fputs("x", o);
        fclose(o);
    }
    HS_OK("run", "--plan", g_plan, "--path", r2, "--out", p, "--online", "--rounds", "1",
                        "--steps-per-round", "2", "--val-poses", "2", "--mc", "2", "--map-res", "0.2", "--quiet");
    for (int i = 0; i < 4; i++) {
        snprintf(f, sizeof f, "%s/%s", p, names[i]);
        assert_int_equal(access(f, F_OK) == 0, i >= 2);
    }
}

/* The readings of the KL strategy, the validation modes and the link model as options: bad values
 * refused with the reason (exit 2); good ones recorded in summary.txt (--strategy left out: kl by default), and --val-mode mc makes val_loss the
 * MC column on every row, beside val_mean, val_sample and sigma_mean. */
static void test_fleet_readings_and_val_modes(void **st)
{
    (void)st;
    char p[PATH_MAX], q[PATH_MAX], f[PATH_MAX + 32];
    path_in(p, "readings");
    static const char *const bad[][3] = {{"--kl-form", "forward", "is not own, reverse or full"},
                                         {"--kl-reduce", "avg", "is not sum or mean"},
                                         {"--rho-pred-grad", "2", "is not an integer in [0, 1]"},
                                         {"--val-mode", "best", "is not mean, sample or mc"},
                                         {"--link-success", "1.5", "is not a number in [0, 1]"},
                                         {"--link-faults", "away=1,from=3,until=2", "until=2 is not after from=3"},
                                         {"--link-faults", "away=2", "agent 2 is not one of the 1 agents"}};
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        assert_int_equal(HS(-1, "fleet", "--inproc", "--plan", g_plan, "--paths", g_paths, "--robots", "1",
                            "--rounds", "1", "--strategy", "kl", "--graph", "full", "--seed", "1", "--out", p,
                            bad[k][0], bad[k][1]),
                         2);
        expect_err(bad[k][0], bad[k][2]);
    }
    path_in(q, "rv.samples");
    HS_OK("valset", "--plan", g_plan, "--out", q, "--poses", "2");
    /* No --strategy: kl by default, as tools/fleet's. */
    HS_OK("fleet", "--inproc", "--plan", g_plan, "--paths", g_paths, "--robots", "2", "--rounds", "2",
          "--graph", "full", "--seed", "1", "--out", p, "--valset", q, "--mc", "2", "--map-res", "0.2",
          "--kl-form", "full", "--kl-reduce", "mean", "--rho-pred-grad", "0", "--val-mode", "mc", "--val-mc", "3",
          "--metrics-every", "1", "--link-faults", "away=1,from=1");
    snprintf(f, sizeof f, "%s/summary.txt", p);
    size_t n = 0;
    char *sum = (char *)test_slurp(f, &n);
    assert_non_null(sum);
    assert_non_null(strstr(sum, "kl_form: full\nkl_reduce: mean\nrho_pred_grad: 0\nval_mode: mc\n"));
    assert_non_null(strstr(sum, "strategy: kl\n"));
    /* Paths as given or by their names in the output folder, never made absolute (this
       --out is absolute: it would show). */
    assert_non_null(strstr(sum, ": map_mean.png map_std.png\n"));
    if (strstr(sum, g_dir) != NULL)
        fail_msg("summary.txt names the output folder %s:\n%s", g_dir, sum);
    /* robot 1 away in round 1: both neighbour entries of that round dropped */
    assert_non_null(strstr(sum, "links: success 1; away=1 rounds [1, end); 2 of 4 neighbour states dropped\n"));
    free(sum);
    snprintf(f, sizeof f, "%s/metrics.csv", p);
    char *csv = (char *)test_slurp(f, &n);
    assert_non_null(csv);
    const char *head = "round,agent,train_loss,val_loss,kl_loss,consensus_error,occ_mse,occ_iou,reg_mu,reg_rho,"
                       "neighbours,val_mean,val_sample,val_mc,sigma_mean\n";
    assert_true(strncmp(csv, head, strlen(head)) == 0);
    int rows = 0;
    for (char *line = strtok(csv + strlen(head), "\n"); line; line = strtok(NULL, "\n"), rows++) {
        double v[15];
        char *c = line;
        for (int i = 0; i < 15; i++) {
            v[i] = strtod(c, &c);
            assert_true(i == 14 ? *c == '\0' : *c == ',');
            c++;
        }
        assert_true(v[3] == v[13]);                       /* val_loss is the MC column */
        assert_true(v[11] > 0 && v[12] > 0 && v[13] > 0); /* every mode measured on every row */
        assert_true(v[14] > 0.04 && v[14] < 0.06);        /* sigma near softplus(-3) after 2 rounds */
    }
    assert_int_equal(rows, 3 * 2); /* rounds 0, 1, 2 x 2 agents */
    free(csv);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_full_disk_keeps_every_earlier_output),
        cmocka_unit_test(test_stopped_or_rejected_run_keeps_earlier_output),
        cmocka_unit_test(test_out_that_is_not_ours),
        cmocka_unit_test(test_inputs_and_options),
        cmocka_unit_test(test_out_parents_and_stale_temporaries),
        cmocka_unit_test(test_fleet_readings_and_val_modes),
    };
    return cmocka_run_group_tests_name("app/outputs", tests, setup, teardown);
}
