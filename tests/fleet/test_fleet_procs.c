/* The multi-process fleet, started the way users start it: real host_sim processes exchanging
 * over LCM UDP multicast on this host (udpm://, ttl 0).
 *   - 3 processes, offline, no loss: their final models equal `host_sim fleet --inproc`'s bit
 *     for bit (same seed, same positions, same node updates);
 *   - the same with every 7th datagram lost (the FLEETSIM_NET_DROP_EVERY seam of
 *     hal/host/hal_host_net.c): the protocol asks again for what is missing, so the models are
 *     still the reference's, and the traffic logs show the chunks requested and re-sent;
 *   - int8 states: a smaller state on the wire, the run completes;
 *   - tools/fleet: a robot killed with SIGKILL makes the launcher stop the fleet, name the
 *     robot and the signal, and exit 1; Ctrl-C (SIGINT) stops it with status 130; neither
 *     leaves a host_sim process of that fleet behind.
 * Each test uses its own fleet id (from the pid), so parallel runs on one host do not mix. */
#define _XOPEN_SOURCE 700
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
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

#define NPROC 3
#define ROUNDS "4"

#define SHORT_PATH 1024 /* our own paths; PATH_MAX-sized buffers hold them with a name added */
static char g_bin[PATH_MAX];      /* build/<config>/bin/host_sim */
static char g_root[SHORT_PATH];   /* the project */
static char g_dir[SHORT_PATH];    /* scratch folder */
static char g_plan[PATH_MAX], g_paths[PATH_MAX];
static unsigned g_fleet_id;

static void sleep_ms(long ms)
{
    struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}

/* Starts argv with stdout and stderr into `log` (NULL: /dev/null) and env NAME=VALUE pairs. */
static pid_t spawn(const char *const *argv, const char *log, const char *env_name, const char *env_value)
{
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
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
    return pid;
}

static int wait_status(pid_t pid)
{
    int st = 0;
    assert_int_equal(waitpid(pid, &st, 0), pid);
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

static char *slurp(const char *path, size_t *len)
{
    return (char *)test_slurp(path, len);
}

static void show_log(const char *path)
{
    size_t n = 0;
    char *b = slurp(path, &n);
    if (b) {
        print_error("---- %s ----\n%s\n", path, n > 4000 ? b + n - 4000 : b);
        free(b);
    }
}

/* The fleet: NPROC `host_sim run --fleet` processes into DIR/<tag>/robot_<i>. */
static void run_fleet(const char *tag, const char *encoding, const char *drop_every)
{
    pid_t pid[NPROC];
    char out[NPROC][PATH_MAX + 64], log[NPROC][PATH_MAX + 64], path[NPROC][PATH_MAX + 32], id[NPROC][16];
    char fid[16];
    snprintf(fid, sizeof fid, "%u", g_fleet_id++);
    for (int i = 0; i < NPROC; i++) {
        snprintf(out[i], sizeof out[i], "%s/%s/robot_%d", g_dir, tag, i);
        snprintf(log[i], sizeof log[i], "%s/%s/log_%d.txt", g_dir, tag, i);
        snprintf(path[i], sizeof path[i], "%s/robot_%d.csv", g_paths, i);
        snprintf(id[i], sizeof id[i], "%d", i);
    }
    char dir[PATH_MAX + 32];
    snprintf(dir, sizeof dir, "%s/%s", g_dir, tag);
    assert_int_equal(mkdir(dir, 0755), 0);
    for (int i = 0; i < NPROC; i++) {
        const char *argv[] = {g_bin, "run", "--plan", g_plan, "--path", path[i], "--out", out[i], "--offline",
                              "--rounds", ROUNDS, "--seed", "3", "--fleet", "3", "--id", id[i], "--fleet-id", fid,
                              "--transport", "lcm", "--radius", "6", "--encoding", encoding, "--val-poses", "5",
                              "--no-maps", "--quiet", "--peer-timeout", "20", NULL};
        pid[i] = spawn(argv, log[i], drop_every ? "FLEETSIM_NET_DROP_EVERY" : NULL, drop_every);
    }
    int bad = 0;
    for (int i = 0; i < NPROC; i++)
        if (wait_status(pid[i]) != 0) {
            show_log(log[i]);
            bad = 1;
        }
    assert_false(bad);
}

/* The reference: the in-process fleet with the same settings, into DIR/inproc. */
static void run_inproc(void)
{
    char out[PATH_MAX + 16], log[PATH_MAX + 16];
    snprintf(out, sizeof out, "%s/inproc", g_dir);
    snprintf(log, sizeof log, "%s/inproc.txt", g_dir);
    const char *argv[] = {g_bin, "fleet", "--inproc", "--plan", g_plan, "--paths", g_paths, "--robots", "3",
                          "--rounds", ROUNDS, "--strategy", "kl", "--graph", "disk", "--radius", "6", "--seed", "3",
                          "--out", out, "--val-poses", "5", "--mc", "1", "--map-res", "0.5", NULL};
    if (wait_status(spawn(argv, log, NULL, NULL)) != 0) {
        show_log(log);
        fail_msg("host_sim fleet --inproc failed");
    }
}

static int same_file(const char *a, const char *b)
{
    size_t na = 0, nb = 0;
    char *x = slurp(a, &na), *y = slurp(b, &nb);
    int same = x && y && na == nb && memcmp(x, y, na) == 0;
    free(x);
    free(y);
    return same;
}

/* Sums a column of DIR/<tag>/robot_<i>/traffic.csv over rounds and robots. */
static unsigned long long traffic_sum(const char *tag, const char *column)
{
    unsigned long long total = 0;
    for (int i = 0; i < NPROC; i++) {
        char p[PATH_MAX + 64];
        snprintf(p, sizeof p, "%s/%s/robot_%d/traffic.csv", g_dir, tag, i);
        size_t n = 0;
        char *b = slurp(p, &n);
        assert_non_null(b);
        int col = -1, c = 0;
        char *line = strtok(b, "\n");
        for (char *t = line; t && *t; c++) {
            size_t w = strcspn(t, ",");
            if (strncmp(t, column, w) == 0 && strlen(column) == w)
                col = c;
            t += w + (t[w] == ',');
        }
        assert_true(col >= 0);
        int rows = 0;
        while ((line = strtok(NULL, "\n")) != NULL) {
            char *t = line;
            for (int k = 0; k < col; k++)
                t = strchr(t, ',') + 1;
            total += strtoull(t, NULL, 10);
            rows++;
        }
        assert_int_equal(rows, atoi(ROUNDS));
        free(b);
    }
    return total;
}

static void test_three_processes_equal_inproc(void **st)
{
    (void)st;
    run_fleet("fp32", "fp32", NULL);
    run_inproc();
    for (int i = 0; i < NPROC; i++) {
        char a[PATH_MAX + 64], b[PATH_MAX + 64];
        snprintf(a, sizeof a, "%s/fp32/robot_%d/final.bnn", g_dir, i);
        snprintf(b, sizeof b, "%s/inproc/models/robot_%d.bnn", g_dir, i);
        if (!same_file(a, b))
            fail_msg("robot %d: %s differs from the in-process reference %s", i, a, b);
    }
    assert_int_equal(traffic_sum("fp32", "timeouts"), 0);
    assert_int_equal(traffic_sum("fp32", "crc_failures"), 0);
}

static void test_lost_datagrams_are_recovered(void **st)
{
    (void)st;
    run_fleet("lossy", "fp32", "7");
    for (int i = 0; i < NPROC; i++) {
        char a[PATH_MAX + 64], b[PATH_MAX + 64];
        snprintf(a, sizeof a, "%s/lossy/robot_%d/final.bnn", g_dir, i);
        snprintf(b, sizeof b, "%s/inproc/models/robot_%d.bnn", g_dir, i);
        if (!same_file(a, b))
            fail_msg("robot %d: with loss, %s differs from the reference %s", i, a, b);
    }
    assert_true(traffic_sum("lossy", "chunks_requested") > 0);
    assert_true(traffic_sum("lossy", "chunks_resent") > 0);
    assert_int_equal(traffic_sum("lossy", "timeouts"), 0);
}

static void test_int8_states(void **st)
{
    (void)st;
    run_fleet("int8", "int8", NULL);
    const unsigned long long b8 = traffic_sum("int8", "bytes_sent"), b32 = traffic_sum("fp32", "bytes_sent");
    assert_true(b8 > 0 && b8 * 3 < b32); /* about a quarter */
}

/* pids of host_sim processes whose command line holds "--fleet-id\0<fid>". */
static int fleet_pids(const char *fid, pid_t *out, int cap)
{
    int n = 0;
    DIR *d = opendir("/proc");
    assert_non_null(d);
    for (struct dirent *e; (e = readdir(d)) != NULL;) {
        char p[300];
        if (e->d_name[0] < '0' || e->d_name[0] > '9')
            continue;
        snprintf(p, sizeof p, "/proc/%s/cmdline", e->d_name);
        size_t len = 0;
        char *c = slurp(p, &len);
        if (!c)
            continue;
        int hit = 0, is_run = 0;
        for (size_t k = 0; k < len; k += strlen(c + k) + 1) {
            if (strcmp(c + k, "run") == 0)
                is_run = 1;
            if (strcmp(c + k, "--fleet-id") == 0 && k + strlen(c + k) + 1 < len &&
                strcmp(c + k + strlen(c + k) + 1, fid) == 0)
                hit = 1;
        }
        free(c);
        if (hit && is_run && n < cap)
            out[n++] = (pid_t)atoi(e->d_name);
    }
    closedir(d);
    return n;
}

/* tools/fleet with NPROC robots and many rounds; `stop` ends it: 1 kills robot 1, 2 sends
 * SIGINT to the launcher. Returns the launcher's status; its output goes to *log. */
static int launcher_stopped(int stop, char *log, size_t cap)
{
    char tool[PATH_MAX + 16], res[PATH_MAX + 16], fid[16];
    snprintf(tool, sizeof tool, "%s/tools/fleet", g_root);
    snprintf(res, sizeof res, "%s/results", g_dir);
    snprintf(log, cap, "%s/launcher_%d.txt", g_dir, stop);
    snprintf(fid, sizeof fid, "%u", g_fleet_id++);
    const char *argv[] = {"/usr/bin/python3", tool, "--bin", g_bin, "--robots", "3", "--rounds", "100000",
                          "--fleet-id", fid, "--results", res, "--name", stop == 1 ? "killed" : "interrupted",
                          "--no-report", "--val-poses", "1", "--force", NULL};
    pid_t launcher = spawn(argv, log, NULL, NULL);
    pid_t robots[8];
    int n = 0;
    for (int t = 0; t < 600 && (n = fleet_pids(fid, robots, 8)) < NPROC; t++)
        sleep_ms(100);
    if (n != NPROC) {
        show_log(log);
        kill(launcher, SIGTERM);
        wait_status(launcher);
        fail_msg("the launcher did not start %d robots", NPROC);
    }
    sleep_ms(1500); /* the tours and a few rounds */
    if (stop == 1) {
        pid_t victim = 0;
        for (int i = 0; i < n; i++) {
            char p[64];
            snprintf(p, sizeof p, "/proc/%d/cmdline", (int)robots[i]);
            size_t len = 0;
            char *c = slurp(p, &len);
            for (size_t k = 0; c && k < len; k += strlen(c + k) + 1)
                if (strcmp(c + k, "--id") == 0 && k + 5 < len && strcmp(c + k + 5, "1") == 0)
                    victim = robots[i];
            free(c);
        }
        assert_true(victim > 0);
        assert_int_equal(kill(victim, SIGKILL), 0);
    } else {
        assert_int_equal(kill(launcher, SIGINT), 0);
    }
    const int rc = wait_status(launcher);
    sleep_ms(200);
    pid_t left[8];
    assert_int_equal(fleet_pids(fid, left, 8), 0);
    return rc;
}

static void test_killed_robot_stops_the_fleet(void **st)
{
    (void)st;
    char log[PATH_MAX + 32];
    int rc = launcher_stopped(1, log, sizeof log);
    size_t n = 0;
    char *out = slurp(log, &n);
    assert_non_null(out);
    if (rc != 1 || !strstr(out, "robot 1 failed") || !strstr(out, "SIGKILL"))
        fail_msg("launcher exit %d, output:\n%s", rc, out);
    free(out);
}

static void test_ctrl_c_stops_the_fleet(void **st)
{
    (void)st;
    char log[PATH_MAX + 32];
    int rc = launcher_stopped(2, log, sizeof log);
    size_t n = 0;
    char *out = slurp(log, &n);
    if (rc != 130 || !strstr(out, "interrupted"))
        fail_msg("launcher exit %d, output:\n%s", rc, out);
    free(out);
}

static int setup(void **st)
{
    (void)st;
    char self[SHORT_PATH];
    ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    if (n <= 0)
        return -1;
    self[n] = '\0';
    /* build/<config>/tests/fleet/test_fleet_procs -> build/<config>/bin/host_sim */
    char *cut = strstr(self, "/tests/fleet/");
    if (!cut)
        return -1;
    *cut = '\0';
    snprintf(g_bin, sizeof g_bin, "%s/bin/host_sim", self);
    if (!getcwd(g_root, sizeof g_root))
        return -1;
    snprintf(g_plan, sizeof g_plan, "%s/host_sim/plans/apartment.svg", g_root);
    snprintf(g_paths, sizeof g_paths, "%s/host_sim/plans/apartment", g_root);
    const char *tmp = getenv("TMPDIR");
    snprintf(g_dir, sizeof g_dir, "%s/fleetsim_procs_XXXXXX", tmp ? tmp : "/tmp");
    if (!mkdtemp(g_dir))
        return -1;
    g_fleet_id = 100000u + (unsigned)getpid() % 10000u * 10u;
    return access(g_bin, X_OK);
}

static int teardown(void **st)
{
    (void)st;
    char cmd[PATH_MAX + 16];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", g_dir);
    return system(cmd) == 0 ? 0 : -1;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_three_processes_equal_inproc),
        cmocka_unit_test(test_lost_datagrams_are_recovered),
        cmocka_unit_test(test_int8_states),
        cmocka_unit_test(test_killed_robot_stops_the_fleet),
        cmocka_unit_test(test_ctrl_c_stops_the_fleet),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
