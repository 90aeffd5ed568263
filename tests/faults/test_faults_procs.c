/* The fleet under loss, as real processes (issue 26, "the fleet never hangs"): 3 `host_sim run
 * --fleet` processes over LCM UDP multicast, offline, ROUNDS rounds, preset of the build.
 *   - the injector: every robot loses 20 % of what it receives (--net-faults drop=0.2, its own
 *     seed per robot); the final models equal the lossless in-process reference's
 *     (`host_sim fleet --inproc`, which tests/fleet/test_fleet_procs.c proves equal to the
 *     lossless process fleet) bit for bit: loss only delays, it never changes what is trained
 *     on. summary.txt must count the injected drops.
 *   - the kernel: the same fleet in a network namespace of its own whose OUTPUT chain drops
 *     20 % of the multicast datagrams (iptables statistic), the same models. Needs root, `ip`
 *     and `iptables` (tools/install-deps.sh installs iproute2 and iptables); SKIPPED with the
 *     reason otherwise. The namespace is deleted in every path: the test's teardown (also
 *     after a failure) and a handler of SIGINT/SIGTERM/SIGHUP.
 *     Note: a DROP in OUTPUT makes the sender's sendmsg() fail with EPERM, so the kernel's
 *     drops show as "sends refused" in summary.txt; the receiver-side loss is the injector's.
 * Bounded: each fleet has FLEET_DEADLINE_S seconds (it takes a few); then every robot is
 * killed and the test FAILS (a hang is a failure), naming the robots still running and
 * showing their logs. Robots also get --peer-timeout, so a lost peer cannot stall them.
 * Run by `make test-faults`, not by `make test`. */
#define _XOPEN_SOURCE 700
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
#define ROUNDS "20"
#define PEER_TIMEOUT "10"
#ifndef FLEET_DEADLINE_S
#define FLEET_DEADLINE_S 90 /* a passing fleet takes a few seconds */
#endif
#define REF_DEADLINE_S 120 /* the in-process reference: about 3 s */
#define CMD_DEADLINE_S 15
#define DROP_P "0.2"

#define SHORT_PATH 1024
static char g_bin[PATH_MAX];
static char g_root[SHORT_PATH];
static char g_dir[SHORT_PATH];
static char g_plan[PATH_MAX], g_paths[PATH_MAX];
static unsigned g_fleet_id;
static int g_have_ref;

/* What the signal handler and the teardown clean up. */
static volatile sig_atomic_t g_nkids;
static pid_t g_kids[NPROC + 1];
static char g_ip[PATH_MAX];  /* the `ip` program */
static char g_ns[64];         /* the namespace we made ("" when none) */

static void sleep_ms(long ms)
{
    struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* A program by name in PATH, /usr/sbin or /sbin (root's tools are often outside a user's
 * PATH). 0 and its path in out, or -1. */
static int find_program(const char *name, char *out, size_t cap)
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

/* Starts argv in a process group of its own (so that a kill reaches whatever it runs), its
 * stdout and stderr into `log`. */
static pid_t spawn(const char *const *argv, const char *log)
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
        execv(argv[0], (char *const *)argv);
        _exit(127);
    }
    setpgid(pid, pid); /* also here: no race with a kill before the child ran */
    return pid;
}

static void kill_group(pid_t pid)
{
    if (pid > 0) {
        kill(-pid, SIGKILL);
        kill(pid, SIGKILL);
    }
}

/* Waits for pid until deadline (monotonic seconds): its status (128 + signal when killed),
 * or -1 when it still runs then. */
static int wait_until(pid_t pid, double deadline)
{
    for (;;) {
        int st = 0;
        pid_t r = waitpid(pid, &st, WNOHANG);
        if (r == pid)
            return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
        if (r < 0)
            return 127;
        if (now_s() >= deadline)
            return -1;
        sleep_ms(20);
    }
}

/* Runs argv to its end within CMD_DEADLINE_S (killed after): its status, output into out. */
static int run_cmd(const char *const *argv, char *out, size_t cap)
{
    char log[SHORT_PATH + 32];
    snprintf(log, sizeof log, "%s/cmd.txt", g_dir);
    pid_t pid = spawn(argv, log);
    int rc = wait_until(pid, now_s() + CMD_DEADLINE_S);
    if (rc < 0) {
        kill_group(pid);
        waitpid(pid, NULL, 0);
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

/* Deletes the namespace we made, if any (after its processes are gone). Async-signal-safe:
 * the signal handler calls it too. */
static void delete_ns(void)
{
    if (g_ns[0] == '\0')
        return;
    pid_t pid = fork();
    if (pid == 0) {
        int fd = open("/dev/null", O_WRONLY);
        if (fd >= 0) {
            dup2(fd, 1);
            dup2(fd, 2);
        }
        char *const argv[] = {g_ip, (char *)"netns", (char *)"del", g_ns, NULL};
        execv(g_ip, argv);
        _exit(127);
    }
    if (pid > 0)
        waitpid(pid, NULL, 0);
    g_ns[0] = '\0';
}

/* Kills and reaps the robots not reaped yet (0 marks a reaped one: its pid may be reused). */
static void kill_kids(void)
{
    for (int i = 0; i < g_nkids; i++) {
        if (g_kids[i] > 0) {
            kill_group(g_kids[i]);
            waitpid(g_kids[i], NULL, 0);
            g_kids[i] = 0;
        }
    }
    g_nkids = 0;
}

static void on_signal(int sig)
{
    kill_kids();
    delete_ns();
    signal(sig, SIG_DFL);
    raise(sig);
}

static void show_log(const char *path)
{
    size_t n = 0;
    char *b = (char *)test_slurp(path, &n);
    if (b) {
        print_error("---- %s ----\n%s\n", path, n > 3000 ? b + n - 3000 : b);
        free(b);
    }
}

/* The lossless reference: the in-process fleet with the same settings, into DIR/inproc. */
static void need_reference(void)
{
    if (g_have_ref)
        return;
    char out[PATH_MAX + 16], log[PATH_MAX + 16];
    snprintf(out, sizeof out, "%s/inproc", g_dir);
    snprintf(log, sizeof log, "%s/inproc.txt", g_dir);
    const char *argv[] = {g_bin, "fleet", "--inproc", "--plan", g_plan, "--paths", g_paths, "--robots", "3",
                          "--rounds", ROUNDS, "--strategy", "kl", "--graph", "disk", "--radius", "6", "--seed", "3",
                          "--out", out, "--val-poses", "5", "--mc", "1", "--map-res", "0.5", NULL};
    pid_t pid = spawn(argv, log);
    g_kids[0] = pid; /* the signal handler's to kill too */
    g_nkids = 1;
    int rc = wait_until(pid, now_s() + REF_DEADLINE_S);
    if (rc >= 0)
        g_kids[0] = 0;
    kill_kids();
    if (rc != 0) {
        show_log(log);
        fail_msg("host_sim fleet --inproc (the reference) %s", rc < 0 ? "did not finish in time" : "failed");
    }
    g_have_ref = 1;
}

/* The fleet: NPROC `host_sim run --fleet` into DIR/<tag>/robot_<i>, inside namespace `ns`
 * (NULL: this one), with --net-faults `faults` (NULL: none). Fails the test when a robot
 * fails or the fleet is not done within FLEET_DEADLINE_S. Returns its wall time. */
static double run_fleet(const char *tag, const char *ns, const char *faults)
{
    char out[NPROC][PATH_MAX + 64], log[NPROC][PATH_MAX + 64], path[NPROC][PATH_MAX + 32], id[NPROC][16];
    char fid[16], dir[PATH_MAX + 32];
    snprintf(fid, sizeof fid, "%u", g_fleet_id++);
    snprintf(dir, sizeof dir, "%s/%s", g_dir, tag);
    assert_int_equal(mkdir(dir, 0755), 0);
    const double t0 = now_s();
    for (int i = 0; i < NPROC; i++) {
        snprintf(out[i], sizeof out[i], "%s/%s/robot_%d", g_dir, tag, i);
        snprintf(log[i], sizeof log[i], "%s/%s/log_%d.txt", g_dir, tag, i);
        snprintf(path[i], sizeof path[i], "%s/robot_%d.csv", g_paths, i);
        snprintf(id[i], sizeof id[i], "%d", i);
        const char *argv[48];
        int k = 0;
        if (ns != NULL) {
            argv[k++] = g_ip;
            argv[k++] = "netns";
            argv[k++] = "exec";
            argv[k++] = ns;
        }
        const char *run[] = {g_bin, "run", "--plan", g_plan, "--path", path[i], "--out", out[i], "--offline",
                             "--rounds", ROUNDS, "--seed", "3", "--fleet", "3", "--id", id[i], "--fleet-id", fid,
                             "--transport", "lcm", "--radius", "6", "--encoding", "fp32", "--val-poses", "5",
                             "--no-maps", "--quiet", "--peer-timeout", PEER_TIMEOUT, NULL};
        for (const char *const *a = run; *a; a++)
            argv[k++] = *a;
        if (faults != NULL) {
            argv[k++] = "--net-faults";
            argv[k++] = faults;
        }
        argv[k] = NULL;
        g_kids[g_nkids] = spawn(argv, log[i]);
        g_nkids++;
    }
    const double deadline = t0 + FLEET_DEADLINE_S;
    int rc[NPROC], late = 0, bad = 0;
    for (int i = 0; i < NPROC; i++)
        if ((rc[i] = wait_until(g_kids[i], deadline)) >= 0)
            g_kids[i] = 0;
    for (int i = 0; i < NPROC; i++) {
        if (rc[i] < 0) {
            late = 1;
            print_error("robot %d still running after %d s: killed\n", i, FLEET_DEADLINE_S);
        }
    }
    kill_kids(); /* the late ones; the others are reaped already (a no-op for them) */
    for (int i = 0; i < NPROC; i++)
        if (rc[i] != 0) {
            show_log(log[i]);
            bad = 1;
        }
    if (late)
        fail_msg("fleet '%s' hung: not done within %d s (a hang is a failure)", tag, FLEET_DEADLINE_S);
    if (bad)
        fail_msg("fleet '%s': a robot failed (exit statuses %d %d %d)", tag, rc[0], rc[1], rc[2]);
    return now_s() - t0;
}

static int same_file(const char *a, const char *b)
{
    size_t na = 0, nb = 0;
    uint8_t *x = test_slurp(a, &na), *y = test_slurp(b, &nb);
    int same = x && y && na == nb && memcmp(x, y, na) == 0;
    free(x);
    free(y);
    return same;
}

static void expect_reference_models(const char *tag)
{
    for (int i = 0; i < NPROC; i++) {
        char a[PATH_MAX + 64], b[PATH_MAX + 64];
        snprintf(a, sizeof a, "%s/%s/robot_%d/final.bnn", g_dir, tag, i);
        snprintf(b, sizeof b, "%s/inproc/models/robot_%d.bnn", g_dir, i);
        if (!same_file(a, b))
            fail_msg("robot %d (%s): %s differs from the lossless reference %s", i, tag, a, b);
    }
}

/* A counter of DIR/<tag>/robot_<i>/summary.txt: the number before (after, when `after`)
 * `what` on the line that starts with `line`, summed over the robots. */
static unsigned long long summary_sum(const char *tag, const char *line, const char *what, int after)
{
    unsigned long long total = 0;
    for (int i = 0; i < NPROC; i++) {
        char p[PATH_MAX + 64];
        snprintf(p, sizeof p, "%s/%s/robot_%d/summary.txt", g_dir, tag, i);
        size_t n = 0;
        char *b = (char *)test_slurp(p, &n);
        assert_non_null(b);
        char *l = strstr(b, line);
        if (l == NULL)
            fail_msg("%s: no line '%s'", p, line);
        char *end = strchr(l, '\n');
        if (end)
            *end = '\0';
        char *w = strstr(l, what);
        if (w == NULL)
            fail_msg("%s: '%s' not on the line '%s'", p, what, l);
        if (after) {
            w += strlen(what);
        } else {
            while (w > l && w[-1] == ' ')
                w--;
            while (w > l && w[-1] >= '0' && w[-1] <= '9')
                w--;
        }
        total += strtoull(w, NULL, 10);
        free(b);
    }
    return total;
}

static void test_injected_drops(void **st)
{
    (void)st;
    need_reference();
    const double wall = run_fleet("injected", NULL, "drop=" DROP_P ",seed=26");
    expect_reference_models("injected");
    const unsigned long long dropped = summary_sum("injected", "network faults injected", " dropped", 0);
    printf("# injector drop=%s: 3 robots, %s rounds in %.1f s, %llu datagrams dropped on receipt; models equal "
           "the lossless reference\n",
           DROP_P, ROUNDS, wall, dropped);
    assert_true(dropped > 0);
}

/* Skips the test with the reason (cmocka prints SKIPPED; tools/run-tests.sh counts it). */
#define SKIP_BECAUSE(...)                                                                                     \
    do {                                                                                                      \
        printf("# skipped: ");                                                                                \
        printf(__VA_ARGS__);                                                                                  \
        printf("\n");                                                                                         \
        fflush(stdout);                                                                                       \
        skip();                                                                                               \
    } while (0)

static void test_kernel_drops(void **st)
{
    (void)st;
    char ipt[PATH_MAX], out[4096];
    if (geteuid() != 0)
        SKIP_BECAUSE("not root (a network namespace and iptables need root)");
    if (find_program("ip", g_ip, sizeof g_ip) != 0)
        SKIP_BECAUSE("'ip' (iproute2) not found; tools/install-deps.sh installs it");
    if (find_program("iptables", ipt, sizeof ipt) != 0)
        SKIP_BECAUSE("'iptables' not found; tools/install-deps.sh installs it");
    char ns[64];
    snprintf(ns, sizeof ns, "fleetsim-drop-%d", (int)getpid());
    const char *add[] = {g_ip, "netns", "add", ns, NULL};
    if (run_cmd(add, out, sizeof out) != 0)
        SKIP_BECAUSE("cannot create network namespace %s: %s", ns, out);
    snprintf(g_ns, sizeof g_ns, "%s", ns); /* from here on the teardown deletes it */
    need_reference();
    /* Loopback up with multicast and a route for it: what LCM's udpm:// needs (test_net.c). */
    const char *lo_up[] = {g_ip, "-n", ns, "link", "set", "lo", "up", "multicast", "on", NULL};
    const char *route[] = {g_ip, "-n", ns, "route", "add", "224.0.0.0/4", "dev", "lo", NULL};
    const char *drop[] = {g_ip, "netns", "exec", ns, ipt, "-A", "OUTPUT", "-d", "224.0.0.0/4", "-p", "udp",
                          "-m", "statistic", "--mode", "random", "--probability", DROP_P, "-j", "DROP", NULL};
    const char *const *setup[] = {lo_up, route};
    for (size_t i = 0; i < sizeof setup / sizeof setup[0]; i++)
        if (run_cmd(setup[i], out, sizeof out) != 0)
            fail_msg("in namespace %s, '%s %s %s %s' failed: %s", ns, setup[i][3], setup[i][4], setup[i][5],
                     setup[i][6], out);
    if (run_cmd(drop, out, sizeof out) != 0)
        SKIP_BECAUSE("iptables cannot add a random-drop rule here (no xt_statistic?): %s", out);
    const double wall = run_fleet("kernel", ns, NULL);
    expect_reference_models("kernel");
    /* The rule did drop: its packet counter. */
    const char *list[] = {g_ip, "netns", "exec", ns, ipt, "-L", "OUTPUT", "-v", "-n", "-x", NULL};
    assert_int_equal(run_cmd(list, out, sizeof out), 0);
    char *l = strstr(out, "DROP");
    while (l && l > out && l[-1] != '\n')
        l--;
    unsigned long long pkts = l ? strtoull(l, NULL, 10) : 0;
    const unsigned long long refused = summary_sum("kernel", "waiting for peers", " sends refused", 1);
    printf("# kernel drops (iptables, p = %s, namespace %s): 3 robots, %s rounds in %.1f s, %llu datagrams "
           "dropped, %llu sends refused; models equal the lossless reference\n",
           DROP_P, ns, ROUNDS, wall, pkts, refused);
    assert_true(pkts > 0);
}

static int teardown_ns(void **st)
{
    (void)st;
    kill_kids();
    delete_ns();
    return 0;
}

static int setup(void **st)
{
    (void)st;
    char self[SHORT_PATH];
    ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    if (n <= 0)
        return -1;
    self[n] = '\0';
    /* build/<config>/tests/faults/test_faults_procs -> build/<config>/bin/host_sim */
    char *cut = strstr(self, "/tests/faults/");
    if (!cut)
        return -1;
    *cut = '\0';
    snprintf(g_bin, sizeof g_bin, "%s/bin/host_sim", self);
    if (!getcwd(g_root, sizeof g_root))
        return -1;
    snprintf(g_plan, sizeof g_plan, "%s/host_sim/plans/apartment.svg", g_root);
    snprintf(g_paths, sizeof g_paths, "%s/host_sim/plans/apartment", g_root);
    const char *tmp = getenv("TMPDIR");
    snprintf(g_dir, sizeof g_dir, "%s/fleetsim_faults_XXXXXX", tmp ? tmp : "/tmp");
    if (!mkdtemp(g_dir))
        return -1;
    g_fleet_id = 200000u + (unsigned)getpid() % 10000u * 10u;
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGHUP, &sa, NULL);
    return access(g_bin, X_OK);
}

static int teardown(void **st)
{
    (void)st;
    kill_kids();
    delete_ns();
    char cmd[PATH_MAX + 16];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", g_dir);
    return system(cmd) == 0 ? 0 : -1;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_injected_drops, teardown_ns),
        cmocka_unit_test_teardown(test_kernel_drops, teardown_ns),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
