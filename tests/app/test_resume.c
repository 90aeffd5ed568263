/* `host_sim run` when it is stopped and started again, tested on the real program:
 *   - --resume: a lone robot ran 6 rounds; its last checkpoints and final.bnn are deleted,
 *     round_0003.bnn is torn, and the killed run's temporary metrics file is there with rows
 *     0 .. 3 and half a row: the run resumes from round_0002.bnn (warning about round_0003),
 *     carries rows 0 .. 2 over, removes the temporary, finishes with exit 0 and the same
 *     final.bnn as the uninterrupted run, and counts the incarnation up; resumed again without
 *     a temporary, its summary says which rows are missing;
 *   - refused: --resume online, a malformed incarnation file, nothing left to resume; in an
 *     empty folder it starts from round 0;
 *   - SIGTERM / SIGINT after the first round: exit 143 / 130 with "stopped by SIG... at round
 *     k", no temporary file left, an earlier run's results in the folder untouched; also while
 *     the robot waits inside one tick for a peer that never comes (fleet of 2 over LCM); and
 *     another command (valset) stopped while writing: 143, its temporary file removed;
 *   - a checkpoint that cannot be written (the disk-full seam) stops the run at once;
 *   - a run stopped by --time-limit keeps its rows and round checkpoints and says how to go
 *     on; --resume then finishes it with the uninterrupted run's final.bnn; only the newest 5
 *     round checkpoints (and every 100th) are kept.
 * Every child runs under alarm(): a hang ends as a failure, not as a stuck test. */
#define _XOPEN_SOURCE 700 /* realpath, kill */
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <poll.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>
#include <cmocka.h>

#include "run_outputs.h"

#define SHORT_PATH 1024
#define CHILD_SECONDS 120 /* the longest any child may run */

static char g_bin[SHORT_PATH];
static char g_dir[SHORT_PATH];
static char g_plan[PATH_MAX];
static char g_tour[PATH_MAX + 32];
static char g_err[1 << 16], g_out[1 << 16];

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Starts host_sim with args (NULL-terminated, args[0] ignored): stderr into DIR/.err, stdout
 * into a pipe (*out_fd) or DIR/.out, env NAME=VALUE when name != NULL, and alarm(CHILD_SECONDS)
 * (kept across exec) so that it cannot outlive a hang. */
static pid_t spawn(const char *const *args, int *out_fd, const char *name, const char *value)
{
    char err[SHORT_PATH + 16], out[SHORT_PATH + 16];
    snprintf(err, sizeof err, "%s/.err", g_dir);
    snprintf(out, sizeof out, "%s/.out", g_dir);
    int p[2] = {-1, -1};
    if (out_fd != NULL)
        assert_int_equal(pipe(p), 0);
    fflush(NULL);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        int fe = open(err, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        int fo = out_fd != NULL ? p[1] : open(out, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fe < 0 || fo < 0)
            _exit(127);
        dup2(fe, 2);
        dup2(fo, 1);
        if (out_fd != NULL)
            close(p[0]);
        if (name != NULL)
            setenv(name, value, 1);
        alarm(CHILD_SECONDS);
        execv(g_bin, (char *const *)args);
        _exit(127);
    }
    if (out_fd != NULL) {
        close(p[1]);
        *out_fd = p[0];
    }
    return pid;
}

/* Waits at most `seconds` for pid (then kills it and fails). Its exit status, 128 + signal when
 * killed; stderr into g_err, and stdout into g_out unless it went to a pipe. */
static int wait_bounded(pid_t pid, double seconds, int had_pipe)
{
    int st = 0;
    const double until = now_s() + seconds;
    pid_t got;
    while ((got = waitpid(pid, &st, WNOHANG)) == 0 && now_s() < until) {
        struct timespec ts = {0, 20000000L};
        nanosleep(&ts, NULL);
    }
    if (got != pid) {
        kill(pid, SIGKILL);
        waitpid(pid, &st, 0);
        fail_msg("host_sim did not end within %.0f s", seconds);
    }
    char f[SHORT_PATH + 16];
    size_t n = 0;
    snprintf(f, sizeof f, "%s/.err", g_dir);
    char *e = (char *)test_slurp(f, &n);
    snprintf(g_err, sizeof g_err, "%s", e ? e : "");
    free(e);
    if (!had_pipe) {
        snprintf(f, sizeof f, "%s/.out", g_dir);
        char *o = (char *)test_slurp(f, &n);
        snprintf(g_out, sizeof g_out, "%s", o ? o : "");
        free(o);
    }
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

static int hs_env(const char *name, const char *value, const char *const *args)
{
    return wait_bounded(spawn(args, NULL, name, value), CHILD_SECONDS + 5, 0);
}

#define HS(...) hs_env(NULL, NULL, (const char *const[]){"host_sim", __VA_ARGS__, NULL})
#define HS_OK(...)                                                                                  \
    do {                                                                                            \
        int rc_ = HS(__VA_ARGS__);                                                                  \
        if (rc_ != 0)                                                                               \
            fail_msg("host_sim exited %d:\n%s", rc_, g_err);                                        \
    } while (0)
/* The options every run of this file shares: a lone robot, offline, small and quick. */
#define RUN(out, rounds) "run", "--plan", g_plan, "--path", g_tour, "--out", (out), "--offline", "--rounds", \
                         (rounds), "--steps-per-round", "5", "--val-poses", "2", "--no-maps", "--quiet"

static void expect(const char *text, const char *what, const char *needle)
{
    if (strstr(text, needle) == NULL)
        fail_msg("%s lacks '%s':\n%s", what, needle, text);
}

static void path_in(char *out, const char *name)
{
    snprintf(out, PATH_MAX, "%.1000s/%.60s", g_dir, name);
}

static char *slurp_in(const char *dir, const char *name, size_t *n)
{
    char p[PATH_MAX + 64];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    return (char *)test_slurp(p, n);
}

static void write_in(const char *dir, const char *name, const char *data, size_t n)
{
    char p[PATH_MAX + 64];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    FILE *f = fopen(p, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, n, f), n);
    fclose(f);
}

static void remove_in(const char *dir, const char *name)
{
    char p[PATH_MAX + 64];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    assert_int_equal(unlink(p), 0);
}

static int exists_in(const char *dir, const char *name)
{
    char p[PATH_MAX + 64];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    return access(p, F_OK) == 0;
}

static int setup(void **st)
{
    (void)st;
    test_build_program("host_sim", g_bin, sizeof g_bin);
    snprintf(g_dir, sizeof g_dir, "/tmp/fleetsim-resume-XXXXXX");
    assert_non_null(mkdtemp(g_dir));
    assert_non_null(realpath("host_sim/plans/apartment.svg", g_plan));
    char tours[PATH_MAX];
    assert_non_null(realpath("host_sim/plans/apartment", tours));
    snprintf(g_tour, sizeof g_tour, "%s/robot_2.csv", tours);
    return 0;
}

static int teardown(void **st)
{
    (void)st;
    return test_remove_tree(g_dir);
}

/* The rows of a metrics.csv: their round and train_loss columns, as text ("k,loss"). */
static int rows_of(const char *csv, char rows[][64], int cap)
{
    int n = 0;
    const char *p = strchr(csv, '\n');
    for (; p != NULL && p[1] != '\0' && n < cap; p = strchr(p + 1, '\n')) {
        const char *row = p + 1;
        const char *c = row;
        for (int k = 0; k < 7; k++) /* train_loss is the 8th column */
            c = strchr(c, ',') + 1;
        const char *ce = strchr(c, ',');
        snprintf(rows[n++], 64, "%.*s|%.*s", (int)strcspn(row, ","), row, (int)(ce - c), c);
    }
    return n;
}

static void test_resume_from_last_good_checkpoint(void **st)
{
    (void)st;
    char full[PATH_MAX], out[PATH_MAX];
    path_in(full, "full");
    path_in(out, "resumed");
    HS_OK(RUN(full, "6"), "--val-every", "1");
    char cmd[3 * PATH_MAX];
    snprintf(cmd, sizeof cmd, "cp -r '%s' '%s'", full, out);
    assert_int_equal(system(cmd), 0);
    /* What a run killed after round 4 leaves: no final.bnn, no metrics.csv, its temporary with
       rows 0 .. 3 and half of row 4; round_0003.bnn torn (written by another tool, say). */
    size_t n = 0;
    char *m = slurp_in(full, "metrics.csv", &n);
    assert_non_null(m);
    const char *row4 = m;
    for (int k = 0; k < 5; k++)
        row4 = strchr(row4, '\n') + 1;
    write_in(out, ".metrics.csv.2147483646.fstmp", m, (size_t)(row4 - m) + 20);
    remove_in(out, "metrics.csv");
    remove_in(out, "final.bnn");
    remove_in(out, "round_0004.bnn");
    remove_in(out, "round_0005.bnn");
    size_t nc = 0;
    char *r3 = slurp_in(out, "round_0003.bnn", &nc);
    write_in(out, "round_0003.bnn", r3, nc / 2);
    free(r3);
    const int rc = HS(RUN(out, "6"), "--val-every", "1", "--resume");
    if (rc != 0)
        fail_msg("resume exited %d:\n%s", rc, g_err);
    expect(g_out, "stdout", "resuming robot 0 from round_0002.bnn (round 2); continuing at round 3 of 6");
    expect(g_out, "stdout", "removed 1 temporary file(s)");
    expect(g_out, "stdout", "incarnation 2");
    expect(g_err, "stderr", "round_0003.bnn: truncated");
    expect(g_err, "stderr", "skipped");
    size_t na = 0, nb = 0;
    char *a = slurp_in(full, "final.bnn", &na), *b = slurp_in(out, "final.bnn", &nb);
    assert_non_null(b);
    assert_int_equal(na, nb);
    assert_memory_equal(a, b, na); /* alone and offline: bit for bit the uninterrupted run */
    free(a);
    free(b);
    /* Rows 0 .. 2 carried over, 3 .. 5 new: every round once, the same losses. */
    char *m2 = slurp_in(out, "metrics.csv", &n);
    assert_non_null(m2);
    char want[8][64], got[8][64];
    assert_int_equal(rows_of(m, want, 8), 6);
    assert_int_equal(rows_of(m2, got, 8), 6);
    for (int k = 0; k < 6; k++)
        assert_string_equal(got[k], want[k]);
    free(m2);
    char *inc = slurp_in(out, "incarnation", &n);
    assert_string_equal(inc, "2\n");
    free(inc);
    snap_t s;
    snap_take(&s, out);
    snap_check(&s, out); /* no temporary file left */
    snap_free(&s);
    /* summary.txt names the file by its name in the folder, never the folder (absolute here). */
    char *sum0 = slurp_in(out, "summary.txt", &n);
    assert_non_null(sum0);
    expect(sum0, "summary.txt", "carried over from .metrics.csv.2147483646.fstmp\n");
    if (strstr(sum0, out) != NULL)
        fail_msg("summary.txt names the output folder %s:\n%s", out, sum0);
    free(sum0);

    /* Again, killed after round 4 without a temporary: the summary names the missing rows. */
    remove_in(out, "final.bnn");
    remove_in(out, "round_0005.bnn");
    HS_OK(RUN(out, "6"), "--val-every", "1", "--resume");
    expect(g_out, "stdout", "continuing at round 5 of 6");
    char *sum = slurp_in(out, "summary.txt", &n);
    assert_non_null(sum);
    expect(sum, "summary.txt", "metrics.csv: the rows of rounds 0 .. 4 are missing");
    expect(sum, "summary.txt", "incarnation: 3");
    free(sum);
    free(m);
}

static void test_resume_refused_or_from_zero(void **st)
{
    (void)st;
    char out[PATH_MAX];
    path_in(out, "refused");
    HS_OK(RUN(out, "2"), "--val-every", "1");
    snap_t s;
    snap_take(&s, out);
    /* Every round done: nothing to resume. */
    assert_int_equal(HS(RUN(out, "2"), "--resume"), 1);
    expect(g_err, "stderr", "round_0001.bnn is the last round's checkpoint");
    /* Online: the pose and the pool are not in a checkpoint. */
    assert_int_equal(HS("run", "--plan", g_plan, "--path", g_tour, "--out", out, "--online", "--rounds", "2",
                        "--resume"),
                     2);
    expect(g_err, "stderr", "--resume needs --offline");
    expect(g_err, "stderr", "pose and sample pool are not in a checkpoint");
    snap_check(&s, out);
    snap_free(&s);
    /* A malformed incarnation file is refused, not overwritten. */
    remove_in(out, "round_0001.bnn");
    write_in(out, "incarnation", "two\n", 4);
    snap_take(&s, out);
    assert_int_equal(HS(RUN(out, "2"), "--resume"), 1);
    expect(g_err, "stderr", "incarnation: malformed");
    expect(g_err, "stderr", "'two'");
    snap_check(&s, out);
    snap_free(&s);
    /* An empty folder: round 0, incarnation 1. */
    char empty[PATH_MAX];
    path_in(empty, "empty");
    HS_OK(RUN(empty, "2"), "--resume");
    expect(g_out, "stdout", "no complete round checkpoint");
    expect(g_out, "stdout", "starting from round 0");
    size_t n = 0;
    char *inc = slurp_in(empty, "incarnation", &n);
    assert_string_equal(inc, "1\n");
    free(inc);
}

/* Reads the child's stdout until `needle` shows (at most `seconds`). */
static void read_until(int fd, const char *needle, double seconds)
{
    size_t len = 0;
    g_out[0] = '\0';
    const double until = now_s() + seconds;
    while (strstr(g_out, needle) == NULL) {
        const double left = until - now_s();
        struct pollfd p = {fd, POLLIN, 0};
        if (left <= 0 || poll(&p, 1, (int)(left * 1000) + 1) <= 0)
            fail_msg("'%s' not printed within %.0f s; stdout:\n%s", needle, seconds, g_out);
        ssize_t got = read(fd, g_out + len, sizeof g_out - 1 - len);
        if (got <= 0)
            fail_msg("stdout ended before '%s':\n%s", needle, g_out);
        len += (size_t)got;
        g_out[len] = '\0';
    }
}

/* Starts `args`, waits for `ready` on its stdout (plus settle_ms), sends sig; the exit status
 * and how long it took to stop. */
static int stop_with(const char *const *args, const char *ready, long settle_ms, int sig, double *took)
{
    int fd = -1;
    pid_t pid = spawn(args, &fd, NULL, NULL);
    read_until(fd, ready, 60);
    struct timespec ts = {settle_ms / 1000, (settle_ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
    const double t0 = now_s();
    assert_int_equal(kill(pid, sig), 0);
    /* The pipe must not fill while it stops: it keeps printing rounds until then. */
    int flags = fcntl(fd, F_GETFL);
    fcntl(fd, F_SETFL, flags | O_NONBLOCK);
    int st = 0;
    pid_t got;
    while ((got = waitpid(pid, &st, WNOHANG)) == 0 && now_s() < t0 + 30) {
        char sink[4096];
        while (read(fd, sink, sizeof sink) > 0)
            ;
        struct timespec d = {0, 10000000L};
        nanosleep(&d, NULL);
    }
    *took = now_s() - t0;
    close(fd);
    if (got != pid) {
        kill(pid, SIGKILL);
        waitpid(pid, &st, 0);
        fail_msg("host_sim did not stop within 30 s of the signal");
    }
    char f[SHORT_PATH + 16];
    snprintf(f, sizeof f, "%s/.err", g_dir);
    size_t n = 0;
    char *e = (char *)test_slurp(f, &n);
    snprintf(g_err, sizeof g_err, "%s", e ? e : "");
    free(e);
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

static void test_signals_stop_cleanly(void **st)
{
    (void)st;
    char out[PATH_MAX];
    path_in(out, "signalled");
    /* An earlier good run in the folder: what a stopped run must leave as it was. The stopped
       runs below write no checkpoint before round 1000 and the same validation set. */
    HS_OK(RUN(out, "2"), "--val-every", "1000");
    snap_t s;
    snap_take(&s, out);
    static const int sigs[2] = {SIGTERM, SIGINT};
    for (int k = 0; k < 2; k++) {
        const char *args[] = {"host_sim", "run", "--plan", g_plan, "--path", g_tour, "--out", out, "--online",
                              "--rounds", "2000", "--val-every", "1000", "--steps-per-round", "5", "--val-poses",
                              "2", "--no-maps", "--quiet", NULL};
        double took = 0;
        const int rc = stop_with(args, "\nround ", 0, sigs[k], &took);
        const int want = 128 + sigs[k];
        if (rc != want)
            fail_msg("exit %d (expected %d):\n%s", rc, want, g_err);
        expect(g_err, "stderr", sigs[k] == SIGTERM ? "host_sim run: stopped by SIGTERM at round "
                                                   : "host_sim run: stopped by SIGINT at round ");
        print_message("stopped by signal %d in %.2f s\n", sigs[k], took);
        assert_true(took < 10);
        snap_check(&s, out); /* earlier results byte for byte, no temporary file */
    }
    snap_free(&s);
}

/* Another command, with no clean point to stop at: the handler removes the temporary file of
 * its open writer and exits 143 at once. */
static void test_sigterm_stops_other_commands(void **st)
{
    (void)st;
    char dir[PATH_MAX], out[PATH_MAX + 16];
    path_in(dir, "valset");
    assert_int_equal(mkdir(dir, 0755), 0);
    snprintf(out, sizeof out, "%s/v.samples", dir);
    const char *args[] = {"host_sim", "valset", "--plan", g_plan, "--out", out, "--poses", "1000000", NULL};
    pid_t pid = spawn(args, NULL, NULL, NULL);
    snap_t s;
    int writing = 0;
    for (double until = now_s() + 30; !writing && now_s() < until;) {
        char cmd[PATH_MAX + 64];
        snprintf(cmd, sizeof cmd, "ls -A '%s' | grep -q 'fstmp$'", dir);
        writing = system(cmd) == 0;
        struct timespec ts = {0, 20000000L};
        nanosleep(&ts, NULL);
    }
    assert_true(writing);
    assert_int_equal(kill(pid, SIGTERM), 0);
    const int rc = wait_bounded(pid, 10, 0);
    if (rc != 143)
        fail_msg("exit %d (expected 143):\n%s", rc, g_err);
    expect(g_err, "stderr", "host_sim valset: stopped by SIGTERM");
    snap_take(&s, dir);
    assert_int_equal(s.n, 0);
    snap_check(&s, dir); /* its temporary file is gone */
    snap_free(&s);
}

static void test_sigterm_while_waiting_for_peers(void **st)
{
    (void)st;
    char out[PATH_MAX], fid[16];
    path_in(out, "waiting");
    snprintf(fid, sizeof fid, "%d", 50000 + (int)(getpid() % 40000));
    /* Robot 0 of a fleet of 2 whose peer never starts: after its tour, its GP core waits inside
       one tick (join timeout 10 minutes) for a state that never comes. */
    const char *args[] = {"host_sim", "run", "--plan", g_plan, "--path", g_tour, "--out", out, "--offline",
                          "--rounds", "20", "--fleet", "2", "--id", "0", "--fleet-id", fid, "--join-timeout",
                          "600", "--peer-timeout", "600", "--steps-per-round", "5", "--val-poses", "2",
                          "--no-maps", "--quiet", NULL};
    double took = 0;
    const int rc = stop_with(args, "validation set", 3000, SIGTERM, &took);
    if (rc != 143)
        fail_msg("exit %d (expected 143):\n%s", rc, g_err);
    expect(g_err, "stderr", "host_sim run: stopped by SIGTERM at round 0");
    print_message("stopped while waiting for its peer in %.2f s\n", took);
    assert_true(took < 5);
    assert_false(exists_in(out, "metrics.csv"));
    snap_t s;
    snap_take(&s, out);
    snap_check(&s, out); /* no temporary file */
    snap_free(&s);
}

static void test_failed_checkpoint_stops_at_once(void **st)
{
    (void)st;
    char good[PATH_MAX], out[PATH_MAX];
    path_in(good, "sizes");
    path_in(out, "full_disk");
    HS_OK(RUN(good, "1"), "--val-every", "1");
    struct stat a, b;
    char f[PATH_MAX + 64];
    snprintf(f, sizeof f, "%s/valset.samples", good);
    assert_int_equal(stat(f, &a), 0);
    snprintf(f, sizeof f, "%s/round_0000.bnn", good);
    assert_int_equal(stat(f, &b), 0);
    /* Room for the incarnation file, the validation set and one checkpoint, then no more. */
    char room[32];
    snprintf(room, sizeof room, "%lld", (long long)(2 + a.st_size + b.st_size + 100));
    const double t0 = now_s();
    const int rc = hs_env("FLEETSIM_FAIL_WRITE_AFTER", room,
                          (const char *const[]){"host_sim", RUN(out, "200"), "--val-every", "1", NULL});
    const double took = now_s() - t0;
    if (rc != 1)
        fail_msg("exit %d (expected 1):\n%s", rc, g_err);
    snprintf(f, sizeof f, "%s/round_0001.bnn: No space left on device; stopping at round 1", out);
    expect(g_err, "stderr", f);
    /* It stopped within the slice of the failure, long before round 200. */
    int rounds = 0;
    for (const char *p = g_out; (p = strstr(p, "\nround ")) != NULL; p++)
        rounds++;
    print_message("stopped after %d round lines in %.2f s\n", rounds, took);
    assert_true(rounds >= 1 && rounds < 20);
    assert_true(exists_in(out, "round_0000.bnn"));
    assert_false(exists_in(out, "final.bnn"));
    assert_false(exists_in(out, "metrics.csv"));
    snap_t s;
    snap_take(&s, out);
    snap_check(&s, out);
    snap_free(&s);
}

/* Round checkpoints in dir, as a bit set of rounds 0 .. 63. */
static uint64_t ckpts_in(const char *dir)
{
    uint64_t set = 0;
    char name[32];
    for (unsigned k = 0; k < 64; k++) {
        snprintf(name, sizeof name, "round_%04u.bnn", k);
        if (exists_in(dir, name))
            set |= 1ull << k;
    }
    return set;
}

static void test_time_limit_keeps_what_was_done(void **st)
{
    (void)st;
    char out[PATH_MAX], full[PATH_MAX];
    path_in(out, "limited");
    path_in(full, "unlimited");
    HS_OK(RUN(full, "40"), "--val-every", "1");
    assert_int_equal(ckpts_in(full), 0x1full << 35); /* rounds 35 .. 39: the newest 5 */
    /* The tour of robot_2 takes 71 s of simulated time, then a round every 0.2 s. */
    assert_int_equal(HS(RUN(out, "40"), "--val-every", "1", "--time-limit", "75"), 1);
    expect(g_err, "stderr", "stopped by --time-limit 75.0 s after ");
    expect(g_err, "stderr", "run the same command with --resume and a larger --time-limit");
    size_t n = 0;
    char *m = slurp_in(out, "metrics.csv", &n);
    assert_non_null(m);
    int rows = -1;
    for (size_t i = 0; i < n; i++)
        rows += m[i] == '\n';
    free(m);
    assert_true(rows >= 6 && rows < 40);
    const uint64_t kept = ckpts_in(out);
    assert_int_equal(kept, 0x1full << (rows - 5)); /* the newest 5 of the rounds done */
    assert_false(exists_in(out, "final.bnn"));
    HS_OK(RUN(out, "40"), "--val-every", "1", "--resume");
    char want[64];
    snprintf(want, sizeof want, "continuing at round %d of 40", rows);
    expect(g_out, "stdout", want);
    size_t na = 0, nb = 0;
    char *a = slurp_in(full, "final.bnn", &na), *b = slurp_in(out, "final.bnn", &nb);
    assert_true(a != NULL && b != NULL && na == nb && memcmp(a, b, na) == 0);
    free(a);
    free(b);
    char *m1 = slurp_in(full, "metrics.csv", &na), *m2 = slurp_in(out, "metrics.csv", &nb);
    char r1[8][64], r2[8][64];
    assert_int_equal(rows_of(m1, r1, 8), 8); /* the first 8 rows carried over as they were */
    assert_int_equal(rows_of(m2, r2, 8), 8);
    for (int k = 0; k < 8; k++)
        assert_string_equal(r1[k], r2[k]);
    free(m1);
    free(m2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_resume_from_last_good_checkpoint),
        cmocka_unit_test(test_resume_refused_or_from_zero),
        cmocka_unit_test(test_signals_stop_cleanly),
        cmocka_unit_test(test_sigterm_stops_other_commands),
        cmocka_unit_test(test_sigterm_while_waiting_for_peers),
        cmocka_unit_test(test_failed_checkpoint_stops_at_once),
        cmocka_unit_test(test_time_limit_keeps_what_was_done),
    };
    return cmocka_run_group_tests_name("app/resume", tests, setup, teardown);
}
