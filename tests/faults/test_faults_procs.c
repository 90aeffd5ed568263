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
 * Crashes, pauses and partitions are tests/faults/test_crash_procs.c; the process helpers both
 * use (bounded waits, every child killed on every path) are tests/support/fleet_procs.[ch].
 * Run by `make test-faults`, not by `make test`. */
#define _XOPEN_SOURCE 700
#include <fcntl.h>
#include <limits.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmocka.h>

#include "fleet_procs.h"

#define NPROC 3
#define ROUNDS "20"
#define PEER_TIMEOUT "10"
#ifndef FLEET_DEADLINE_S
#define FLEET_DEADLINE_S 90 /* a passing fleet takes a few seconds */
#endif
#define REF_DEADLINE_S 120 /* the in-process reference: about 3 s */
#define DROP_P "0.2"

static char g_ip[PATH_MAX]; /* the `ip` program */
static char g_ns[64];       /* the namespace we made ("" when none) */

/* Deletes the namespace we made, if any (after its processes are gone). Async-signal-safe:
 * the signal handler calls it too. */
static void delete_ns(void)
{
    if (g_ns[0] == '\0')
        return;
    fp_netns_delete(g_ip, g_ns);
    g_ns[0] = '\0';
}

/* The fleet: NPROC `host_sim run --fleet` into DIR/<tag>/robot_<i>, inside namespace `ns`
 * (NULL: this one), with --net-faults `faults` (NULL: none). Fails the test when a robot
 * fails or the fleet is not done within FLEET_DEADLINE_S. Returns its wall time. */
static double run_fleet(const char *tag, const char *ns, const char *faults)
{
    static fp_fleet_t f;
    const char *prefix[] = {g_ip, "netns", "exec", ns, NULL};
    const char *args[] = {"--rounds", ROUNDS, "--radius", "6", "--encoding", "fp32", "--peer-timeout", PEER_TIMEOUT,
                          faults ? "--net-faults" : NULL, faults, NULL};
    fp_fleet_init(&f, tag, NPROC, ns ? prefix : NULL, args);
    fp_fleet_start(&f, NULL, NULL);
    return fp_fleet_wait_ok(&f, FLEET_DEADLINE_S);
}

static void test_injected_drops(void **st)
{
    (void)st;
    fp_inproc_reference(NPROC, ROUNDS, REF_DEADLINE_S);
    const double wall = run_fleet("injected", NULL, "drop=" DROP_P ",seed=26");
    fp_expect_reference_models("injected", NPROC);
    const unsigned long long dropped = fp_summary_sum("injected", NPROC, "network faults injected", " dropped", 0);
    printf("# injector drop=%s: 3 robots, %s rounds in %.1f s, %llu datagrams dropped on receipt; models equal "
           "the lossless reference\n",
           DROP_P, ROUNDS, wall, dropped);
    assert_true(dropped > 0);
}

static void test_kernel_drops(void **st)
{
    (void)st;
    char ipt[PATH_MAX], out[4096];
    if (geteuid() != 0)
        FP_SKIP_BECAUSE("not root (a network namespace and iptables need root)");
    if (fp_find_program("ip", g_ip, sizeof g_ip) != 0)
        FP_SKIP_BECAUSE("'ip' (iproute2) not found; tools/install-deps.sh installs it");
    if (fp_find_program("iptables", ipt, sizeof ipt) != 0)
        FP_SKIP_BECAUSE("'iptables' not found; tools/install-deps.sh installs it");
    char ns[64];
    snprintf(ns, sizeof ns, "fleetsim-drop-%d", (int)getpid());
    const char *add[] = {g_ip, "netns", "add", ns, NULL};
    if (fp_run_cmd(add, out, sizeof out) != 0)
        FP_SKIP_BECAUSE("cannot create network namespace %s: %s", ns, out);
    snprintf(g_ns, sizeof g_ns, "%s", ns); /* from here on the teardown deletes it */
    fp_inproc_reference(NPROC, ROUNDS, REF_DEADLINE_S);
    /* Loopback up with multicast and a route for it: what LCM's udpm:// needs (test_net.c). */
    const char *lo_up[] = {g_ip, "-n", ns, "link", "set", "lo", "up", "multicast", "on", NULL};
    const char *route[] = {g_ip, "-n", ns, "route", "add", "224.0.0.0/4", "dev", "lo", NULL};
    const char *drop[] = {g_ip, "netns", "exec", ns, ipt, "-A", "OUTPUT", "-d", "224.0.0.0/4", "-p", "udp",
                          "-m", "statistic", "--mode", "random", "--probability", DROP_P, "-j", "DROP", NULL};
    const char *const *setup[] = {lo_up, route};
    for (size_t i = 0; i < sizeof setup / sizeof setup[0]; i++)
        if (fp_run_cmd(setup[i], out, sizeof out) != 0)
            fail_msg("in namespace %s, '%s %s %s %s' failed: %s", ns, setup[i][3], setup[i][4], setup[i][5],
                     setup[i][6], out);
    if (fp_run_cmd(drop, out, sizeof out) != 0)
        FP_SKIP_BECAUSE("iptables cannot add a random-drop rule here (no xt_statistic?): %s", out);
    const double wall = run_fleet("kernel", ns, NULL);
    fp_expect_reference_models("kernel", NPROC);
    /* The rule did drop: its packet counter. */
    const char *list[] = {g_ip, "netns", "exec", ns, ipt, "-L", "OUTPUT", "-v", "-n", "-x", NULL};
    assert_int_equal(fp_run_cmd(list, out, sizeof out), 0);
    char *l = strstr(out, "DROP");
    while (l && l > out && l[-1] != '\n')
        l--;
    unsigned long long pkts = l ? strtoull(l, NULL, 10) : 0;
    const unsigned long long refused = fp_summary_sum("kernel", NPROC, "waiting for peers", " sends refused", 1);
    printf("# kernel drops (iptables, p = %s, namespace %s): 3 robots, %s rounds in %.1f s, %llu datagrams "
           "dropped, %llu sends refused; models equal the lossless reference\n",
           DROP_P, ns, ROUNDS, wall, pkts, refused);
    assert_true(pkts > 0);
}

static int teardown_ns(void **st)
{
    (void)st;
    fp_kill_all();
    delete_ns();
    return 0;
}

static int setup(void **st)
{
    (void)st;
    return fp_setup("fleetsim_faults", 200000u, delete_ns);
}

static int teardown(void **st)
{
    (void)st;
    fp_kill_all();
    delete_ns();
    return fp_teardown();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_injected_drops, teardown_ns),
        cmocka_unit_test_teardown(test_kernel_drops, teardown_ns),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
