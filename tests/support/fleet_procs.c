/* Helpers of the tests that run fleets of host_sim processes: see fleet_procs.h. */
#define _XOPEN_SOURCE 700
#include "fleet_procs.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
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
#include "ai/bnn_ckpt.h"
#include "ai/bnn_post.h"

fp_env_t fp_env;

/* The children not reaped yet (0: a free slot; a reaped pid may be reused by the system). */
static volatile sig_atomic_t g_nkids;
static pid_t g_kids[FP_MAX_KIDS];
static void (*g_cleanup)(void);

double fp_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void fp_sleep_ms(long ms)
{
    struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}

static void remember(pid_t pid)
{
    for (int i = 0; i < g_nkids; i++)
        if (g_kids[i] == 0) {
            g_kids[i] = pid;
            return;
        }
    assert_true(g_nkids < FP_MAX_KIDS);
    g_kids[g_nkids] = pid;
    g_nkids++;
}

/* 1 when pid is a child of ours not reaped yet, and forgets it. */
static int forget(pid_t pid)
{
    int found = 0;
    for (int i = 0; i < g_nkids; i++)
        if (pid > 0 && g_kids[i] == pid) {
            g_kids[i] = 0;
            found = 1;
        }
    return found;
}

pid_t fp_spawn(const char *const *argv, const char *log, const char *env_name, const char *env_value)
{
    fflush(NULL);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        setpgid(0, 0);
        int fd = open(log ? log : "/dev/null", O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd < 0)
            _exit(127);
        dup2(fd, 1);
        dup2(fd, 2);
        if (env_name)
            setenv(env_name, env_value, 1);
        execv(argv[0], (char *const *)argv);
        _exit(127);
    }
    setpgid(pid, pid); /* also here: no race with a kill before the child ran */
    remember(pid);
    return pid;
}

int fp_wait(pid_t pid, double deadline)
{
    for (;;) {
        int st = 0;
        pid_t r = waitpid(pid, &st, WNOHANG);
        if (r == pid) {
            forget(pid);
            return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
        }
        if (r < 0) {
            forget(pid);
            return 127;
        }
        if (fp_now() >= deadline)
            return -1;
        fp_sleep_ms(20);
    }
}

/* Async-signal-safe (the handler calls it too). */
static void kill_reap(pid_t pid)
{
    if (pid > 0) {
        kill(-pid, SIGKILL);
        kill(pid, SIGKILL); /* SIGKILL ends a stopped process too */
        waitpid(pid, NULL, 0);
    }
}

void fp_kill(pid_t pid)
{
    if (forget(pid)) /* never a reaped pid: the system may have given it to another process */
        kill_reap(pid);
}

void fp_kill_all(void)
{
    for (int i = 0; i < g_nkids; i++) {
        kill_reap(g_kids[i]);
        g_kids[i] = 0;
    }
    g_nkids = 0;
}

static void on_signal(int sig)
{
    fp_kill_all();
    if (g_cleanup)
        g_cleanup();
    signal(sig, SIG_DFL);
    raise(sig);
}

int fp_run_cmd(const char *const *argv, char *out, size_t cap)
{
    char log[PATH_MAX + 32];
    snprintf(log, sizeof log, "%s/cmd.txt", fp_env.dir);
    pid_t pid = fp_spawn(argv, log, NULL, NULL);
    int rc = fp_wait(pid, fp_now() + FP_CMD_DEADLINE_S);
    if (rc < 0) {
        fp_kill(pid);
        rc = 124;
    }
    if (out != NULL && cap > 0) {
        size_t n = 0;
        uint8_t *b = test_slurp(log, &n);
        snprintf(out, cap, "%s", b ? (char *)b : "");
        free(b);
    }
    return rc;
}

int fp_find_program(const char *name, char *out, size_t cap)
{
    const char *path = getenv("PATH");
    char dirs[4096];
    snprintf(dirs, sizeof dirs, "%s:/usr/sbin:/sbin:/usr/bin:/bin", path ? path : "");
    for (char *save = NULL, *d = strtok_r(dirs, ":", &save); d; d = strtok_r(NULL, ":", &save)) {
        snprintf(out, cap, "%s/%s", d, name);
        if (access(out, X_OK) == 0)
            return 0;
    }
    return -1;
}

void fp_show_log(const char *path)
{
    size_t n = 0;
    char *b = (char *)test_slurp(path, &n);
    if (b) {
        /* Not print_error: cmocka cuts its messages at 1024 bytes. */
        const char *tail = n > 3000 ? b + n - 3000 : b;
        fflush(stdout);
        fprintf(stderr, "---- %s ----\n%s%s", path, tail, n > 0 && b[n - 1] != '\n' ? "\n" : "");
        fprintf(stderr, "---- end of %s ----\n", path);
        fflush(stderr);
        free(b);
    }
}

unsigned long long fp_summary_sum(const char *tag, int n, const char *line, const char *what, int after)
{
    unsigned long long total = 0;
    for (int i = 0; i < n; i++) {
        char p[PATH_MAX + 64];
        snprintf(p, sizeof p, "%s/%s/robot_%d/summary.txt", fp_env.dir, tag, i);
        total += (unsigned long long)fp_summary_number(p, line, what, after);
    }
    return total;
}

void fp_netns_delete(const char *ip, const char *name)
{
    pid_t pid = fork();
    if (pid == 0) {
        int fd = open("/dev/null", O_WRONLY);
        if (fd >= 0) {
            dup2(fd, 1);
            dup2(fd, 2);
        }
        char *const argv[] = {(char *)ip, (char *)"netns", (char *)"del", (char *)name, NULL};
        execv(ip, argv);
        _exit(127);
    }
    if (pid > 0)
        waitpid(pid, NULL, 0);
}

static int g_have_ref;

void fp_inproc_reference(int n, const char *rounds, int deadline_s)
{
    fp_inproc_reference_radius(n, rounds, "6", deadline_s);
}

void fp_inproc_reference_radius(int n, const char *rounds, const char *radius, int deadline_s)
{
    if (g_have_ref)
        return;
    fp_inproc_run(n, rounds, radius, "inproc", NULL, deadline_s);
    g_have_ref = 1;
}

void fp_inproc_run(int n, const char *rounds, const char *radius, const char *name, const char *const *extra,
                   int deadline_s)
{
    char out[PATH_MAX + 16], log[PATH_MAX + 16], robots[16];
    snprintf(out, sizeof out, "%s/%s", fp_env.dir, name);
    snprintf(log, sizeof log, "%s/%s.txt", fp_env.dir, name);
    snprintf(robots, sizeof robots, "%d", n);
    const char *argv[40] = {fp_env.bin, "fleet", "--inproc", "--plan", fp_env.plan, "--paths", fp_env.paths,
                            "--robots", robots, "--rounds", rounds, "--strategy", "kl", "--graph", "disk", "--radius",
                            radius, "--seed", "3", "--out", out, "--val-poses", "5", "--mc", "1", "--map-res", "0.5"};
    int argc = 27;
    for (int i = 0; extra != NULL && extra[i] != NULL && argc < 39; i++)
        argv[argc++] = extra[i];
    argv[argc] = NULL;
    const pid_t pid = fp_spawn(argv, log, NULL, NULL);
    const int rc = fp_wait(pid, fp_now() + deadline_s);
    fp_kill(pid); /* when late; a no-op for a reaped one */
    if (rc != 0) {
        fp_show_log(log);
        if (rc < 0)
            fail_msg("host_sim fleet --inproc (%s) still running after %d s: killed", name, deadline_s);
        fail_msg("host_sim fleet --inproc (%s) failed (status %d)", name, rc);
    }
}

/* The model of two checkpoints, bit for bit: the header's network and seed and theta (bytes
 * [12, 40) and [60, 60 + 4 n_params)). What follows theta may differ: a robot's final.bnn
 * carries its own epistemic posterior, the in-process reference's the fleet's after their
 * consensus (bnn_post.h). */
static int same_model(const char *a, const char *b)
{
    size_t na = 0, nb = 0;
    uint8_t *x = test_slurp(a, &na), *y = test_slurp(b, &nb);
    int same = x && y && na >= 60 && nb >= 60 && memcmp(x + 12, y + 12, 28) == 0;
    if (same) {
        const size_t end = 60 + 4 * (size_t)((uint32_t)x[28] | (uint32_t)x[29] << 8 | (uint32_t)x[30] << 16 |
                                             (uint32_t)x[31] << 24);
        same = na >= end && nb >= end && memcmp(x + 60, y + 60, end - 60) == 0;
    }
    free(x);
    free(y);
    return same;
}

/* The epistemic posterior a checkpoint carries (fails the test when it has none). */
static void load_post(const char *file, bnn_post_t *post)
{
    static bnn_model_t m;
    size_t n = 0;
    uint8_t *x = test_slurp(file, &n);
    const char *why = NULL;
    assert_non_null(x);
    assert_int_equal(bnn_init(&m, NULL, 0), 0);
    if (bnn_ckpt_load_post(&m, post, x, n, &why) != 0)
        fail_msg("%s: %s", file, why);
    free(x);
    if (post->robots <= 0.0)
        fail_msg("%s: no epistemic posterior", file);
}

void fp_expect_reference_models(const char *tag, int n)
{
    static bnn_post_t pa, pb;
    for (int i = 0; i < n; i++) {
        char a[PATH_MAX + 64], b[PATH_MAX + 64];
        snprintf(a, sizeof a, "%s/%s/robot_%d/final.bnn", fp_env.dir, tag, i);
        snprintf(b, sizeof b, "%s/inproc/models/robot_%d.bnn", fp_env.dir, i);
        if (!same_model(a, b))
            fail_msg("robot %d (%s): the model in %s differs from the in-process reference %s", i, tag, a, b);
        /* after the posterior rounds, every robot holds the fleet's posterior, as in the reference
           (the sums' chunks differ: equal to float rounding, not bit for bit) */
        load_post(a, &pa);
        load_post(b, &pb);
        double big = 0.0, dev = 0.0;
        for (size_t e = 0; e < BNN_POST_PACKED(pa.dim); e++) {
            big = fmax(big, fabs(pb.prec[e]));
            dev = fmax(dev, fabs(pa.prec[e] - pb.prec[e]));
        }
        if (fabs(pa.robots - n) > 1e-9 || fabs(pb.robots - n) > 1e-9 || fabs(pa.n_obs - pb.n_obs) > 1e-6 * pb.n_obs ||
            dev > 1e-5 * big)
            fail_msg("robot %d (%s): its posterior (%g robots, %g observations) is not the fleet's of the reference "
                     "(%g robots, %g observations; largest difference %g of %g)",
                     i, tag, pa.robots, pa.n_obs, pb.robots, pb.n_obs, dev, big);
    }
}

void fp_expect_models_of(const char *tag, int n, const char *name)
{
    for (int i = 0; i < n; i++) {
        char a[PATH_MAX + 64], b[PATH_MAX + 64];
        snprintf(a, sizeof a, "%s/%s/robot_%d/final.bnn", fp_env.dir, tag, i);
        snprintf(b, sizeof b, "%s/%s/models/robot_%d.bnn", fp_env.dir, name, i);
        if (!same_model(a, b))
            fail_msg("robot %d (%s): the model in %s differs from the in-process run's %s", i, tag, a, b);
    }
}

int fp_setup(const char *scratch, unsigned fleet_base, void (*cleanup)(void))
{
    char self[FP_SHORT_PATH];
    ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    if (n <= 0)
        return -1;
    self[n] = '\0';
    /* build/<config>/tests/<module>/test_x -> build/<config>/bin/host_sim */
    char *cut = strstr(self, "/tests/");
    if (!cut)
        return -1;
    *cut = '\0';
    snprintf(fp_env.bin, sizeof fp_env.bin, "%.900s/bin/host_sim", self);
    if (!getcwd(fp_env.root, sizeof fp_env.root))
        return -1;
    snprintf(fp_env.plan, sizeof fp_env.plan, "%.900s/host_sim/plans/apartment.svg", fp_env.root);
    snprintf(fp_env.paths, sizeof fp_env.paths, "%.900s/host_sim/plans/apartment", fp_env.root);
    const char *tmp = getenv("TMPDIR");
    snprintf(fp_env.dir, sizeof fp_env.dir, "%.800s/%.64s_XXXXXX", tmp ? tmp : "/tmp", scratch);
    if (!mkdtemp(fp_env.dir))
        return -1;
    fp_env.fleet_id = fleet_base + (unsigned)getpid() % 10000u * 10u;
    g_cleanup = cleanup;
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGHUP, &sa, NULL);
    if (access(fp_env.bin, X_OK) != 0) {
        fprintf(stderr, "fleet_procs: %s is not there or not executable: build it first (make all)\n", fp_env.bin);
        return -1;
    }
    return 0;
}

int fp_teardown(void)
{
    fp_kill_all();
    if (fp_env.dir[0] == '\0')
        return 0;
    return test_remove_tree(fp_env.dir);
}

void fp_robot_add_arg(fp_robot_t *r, const char *arg)
{
    assert_true(r->argc + 1 < FP_MAX_ARGS);
    r->argv[r->argc++] = arg;
    r->argv[r->argc] = NULL;
}

void fp_fleet_init(fp_fleet_t *f, const char *tag, int n, const char *const *prefix, const char *const *args)
{
    assert_true(n >= 1 && n <= FP_MAX_ROBOTS);
    memset(f, 0, sizeof *f);
    snprintf(f->tag, sizeof f->tag, "%s", tag);
    snprintf(f->dir, sizeof f->dir, "%s/%s", fp_env.dir, tag);
    snprintf(f->fid, sizeof f->fid, "%u", fp_env.fleet_id++);
    f->n = n;
    assert_int_equal(mkdir(f->dir, 0755), 0);
    snprintf(f->ntxt, sizeof f->ntxt, "%d", n);
    for (int i = 0; i < n; i++) {
        fp_robot_t *r = &f->r[i];
        r->id = i;
        r->status = -1;
        snprintf(r->out, sizeof r->out, "%s/%s/robot_%d", fp_env.dir, tag, i);
        snprintf(r->log, sizeof r->log, "%s/%s/log_%d.txt", fp_env.dir, tag, i);
        snprintf(r->path, sizeof r->path, "%s/robot_%d.csv", fp_env.paths, i);
        snprintf(r->idtxt, sizeof r->idtxt, "%d", i);
        for (const char *const *a = prefix; a && *a; a++)
            fp_robot_add_arg(r, *a);
        const char *run[] = {fp_env.bin, "run", "--plan", fp_env.plan, "--path", r->path, "--out", r->out,
                             "--offline", "--seed", "3", "--fleet", f->ntxt, "--id", r->idtxt, "--fleet-id", f->fid,
                             "--transport", "lcm", "--val-poses", "5", "--no-maps", "--quiet", NULL};
        for (const char *const *a = run; *a; a++)
            fp_robot_add_arg(r, *a);
        for (const char *const *a = args; a && *a; a++)
            fp_robot_add_arg(r, *a);
    }
}

void fp_robot_start(fp_robot_t *r, const char *env_name, const char *env_value)
{
    assert_int_equal(r->pid, 0);
    r->status = -1;
    r->pid = fp_spawn(r->argv, r->log, env_name, env_value);
}

void fp_fleet_start(fp_fleet_t *f, const char *env_name, const char *env_value)
{
    f->t0 = fp_now();
    for (int i = 0; i < f->n; i++)
        fp_robot_start(&f->r[i], env_name, env_value);
}

double fp_fleet_wait_ok(fp_fleet_t *f, double deadline_s)
{
    const double deadline = f->t0 + deadline_s;
    int late = 0, bad = 0;
    for (int i = 0; i < f->n; i++) {
        fp_robot_t *r = &f->r[i];
        if (r->pid == 0)
            continue;
        if ((r->status = fp_wait(r->pid, deadline)) >= 0)
            r->pid = 0;
    }
    const double wall = fp_now() - f->t0;
    for (int i = 0; i < f->n; i++)
        if (f->r[i].pid != 0) {
            late = 1;
            print_error("fleet '%s': robot %d still running after %g s: killed\n", f->tag, i, deadline_s);
        }
    if (late)
        for (int i = 0; i < f->n; i++) {
            fp_kill(f->r[i].pid); /* every robot: the others may be waiting for it */
            f->r[i].pid = 0;
        }
    for (int i = 0; i < f->n; i++)
        if (f->r[i].status != 0) {
            fp_show_log(f->r[i].log);
            bad = 1;
        }
    if (late)
        fail_msg("fleet '%s' hung: not done within %g s (a hang is a failure)", f->tag, deadline_s);
    if (bad) {
        char st[128] = "";
        for (int i = 0; i < f->n; i++)
            snprintf(st + strlen(st), sizeof st - strlen(st), " %d", f->r[i].status);
        fail_msg("fleet '%s': a robot failed (exit statuses%s)", f->tag, st);
    }
    return wall;
}

/* 1 when dir holds a file named prefix...suffix (not a temporary of the writer). */
static int has_file(const char *dir, const char *prefix, const char *suffix)
{
    DIR *d = opendir(dir);
    if (d == NULL)
        return 0;
    int hit = 0;
    const size_t np = strlen(prefix), ns = strlen(suffix);
    for (struct dirent *e; !hit && (e = readdir(d)) != NULL;) {
        const size_t n = strlen(e->d_name);
        hit = n >= np + ns && strncmp(e->d_name, prefix, np) == 0 && strcmp(e->d_name + n - ns, suffix) == 0;
    }
    closedir(d);
    return hit;
}

void fp_wait_for_file(const fp_robot_t *r, const char *prefix, const char *suffix, double deadline)
{
    const double t0 = fp_now();
    while (!has_file(r->out, prefix, suffix)) {
        int st = 0;
        if (r->pid > 0 && waitpid(r->pid, &st, WNOHANG) == r->pid) {
            forget(r->pid);
            fp_show_log(r->log);
            fail_msg("robot %d exited (status %d) before it wrote %s*%s into %s", r->id,
                     WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st), prefix, suffix, r->out);
        }
        if (fp_now() >= deadline) {
            fp_show_log(r->log);
            fail_msg("robot %d wrote no %s*%s into %s within %.0f s (it hangs or is too slow)", r->id, prefix, suffix,
                     r->out, deadline - t0);
        }
        fp_sleep_ms(20);
    }
}

/* 1 when the log at `path` holds `text`. */
static int log_has(const char *path, const char *text)
{
    size_t n = 0;
    char *b = (char *)test_slurp(path, &n);
    const int yes = b != NULL && strstr(b, text) != NULL;
    free(b);
    return yes;
}

void fp_wait_for_log(const fp_robot_t *r, const char *text, double deadline)
{
    const double t0 = fp_now();
    while (!log_has(r->log, text)) {
        int st = 0;
        if (r->pid > 0 && waitpid(r->pid, &st, WNOHANG) == r->pid) {
            forget(r->pid);
            fp_show_log(r->log);
            fail_msg("robot %d exited (status %d) before it said '%s'", r->id,
                     WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st), text);
        }
        if (fp_now() >= deadline) {
            fp_show_log(r->log);
            fail_msg("robot %d did not say '%s' within %.0f s (it hangs or is too slow)", r->id, text,
                     deadline - t0);
        }
        fp_sleep_ms(20);
    }
}

double fp_summary_number(const char *file, const char *line, const char *what, int after)
{
    size_t n = 0;
    char *b = (char *)test_slurp(file, &n);
    if (b == NULL)
        fail_msg("%s: cannot be read", file);
    char *l = strstr(b, line);
    if (l == NULL)
        fail_msg("%s: no line with '%s'", file, line);
    while (l > b && l[-1] != '\n')
        l--;
    char *end = strchr(l, '\n');
    if (end)
        *end = '\0';
    char *w = strstr(l, what);
    if (w == NULL)
        fail_msg("%s: '%s' not on the line '%s'", file, what, l);
    if (after) {
        w += strlen(what);
    } else {
        while (w > l && w[-1] == ' ')
            w--;
        while (w > l && ((w[-1] >= '0' && w[-1] <= '9') || w[-1] == '.'))
            w--;
    }
    char *stop = NULL;
    const double v = strtod(w, &stop);
    if (stop == w)
        fail_msg("%s: no number %s '%s' on the line '%s'", file, after ? "after" : "before", what, l);
    free(b);
    return v;
}

int fp_csv_column(const char *file, const char *column, double *out, int cap)
{
    size_t n = 0;
    char *b = (char *)test_slurp(file, &n);
    if (b == NULL)
        fail_msg("%s: cannot be read", file);
    char *save = NULL, *line = strtok_r(b, "\n", &save);
    int col = -1, c = 0;
    for (char *t = line; t && *t; c++) {
        const size_t w = strcspn(t, ",");
        if (strlen(column) == w && strncmp(t, column, w) == 0)
            col = c;
        t += w + (t[w] == ',');
    }
    if (col < 0)
        fail_msg("%s: no column '%s'", file, column);
    int rows = 0;
    while ((line = strtok_r(NULL, "\n", &save)) != NULL && rows < cap) {
        char *t = line;
        for (int k = 0; k < col && t; k++) {
            t = strchr(t, ',');
            t = t ? t + 1 : NULL;
        }
        if (t == NULL)
            fail_msg("%s: row %d has no column %d ('%s')", file, rows + 1, col, column);
        char *stop = NULL;
        const double v = strtod(t, &stop);
        out[rows++] = stop == t ? NAN : v; /* strtod reads "nan" itself */
    }
    free(b);
    return rows;
}
