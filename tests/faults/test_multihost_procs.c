/* A fleet spread over several hosts, for real, on one machine: three network namespaces (the
 * "hosts" h0, h1, h2, each with its own address 10.251.0.1 .. .3 on a veth) joined by a Linux
 * bridge in a fourth namespace (the "switch"), nothing of it on the machine's own network.
 * One robot per host, 3 robots, offline, ROUNDS rounds:
 *   - over ZeroMQ/TCP: every robot binds port 7700 on its own host and connects to the
 *     others' addresses (--transport zmq --peers 10.251.0.1:7700,...);
 *   - over LCM: UDP multicast with ttl=1, routed on each host's veth and flooded by the bridge
 *     (IGMP snooping off: there is no querier on this segment).
 * Each run's final models equal the single-host in-process reference's bit for bit.
 * Needs root and `ip` (iproute2); SKIPPED with the reason otherwise. The namespaces are deleted
 * on every path (the teardown, also after a failure, and a handler of SIGINT/SIGTERM/SIGHUP).
 * Every fleet has a deadline: a hang fails the test naming the robots still running.
 * Run by `make test-faults`. */
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
#ifndef FLEET_DEADLINE_S
#define FLEET_DEADLINE_S 120
#endif
#define REF_DEADLINE_S 120
#define LCM_URL "udpm://239.255.76.68:7667?ttl=1&recv_buf_size=4194304"

static char g_ip[PATH_MAX];
static char g_ns[NPROC + 1][32]; /* h0 .. h2, then the switch; "" when not made */
static int g_made;

/* Deletes the namespaces we made (their veths and the bridge go with them). Async-signal-safe:
 * the signal handler calls it too. */
static void delete_ns(void)
{
    for (int i = 0; i < g_made; i++)
        fp_netns_delete(g_ip, g_ns[i]);
    g_made = 0;
}

static void ip_cmd(const char *const *argv)
{
    char out[2048];
    if (fp_run_cmd(argv, out, sizeof out) != 0) {
        char line[512] = "";
        for (int k = 1; argv[k] != NULL; k++)
            snprintf(line + strlen(line), sizeof line - strlen(line), " %s", argv[k]);
        fail_msg("'ip%s' failed: %s", line, out);
    }
}

/* The hosts and the switch: h_i's veth "eth0" (10.251.0.<i+1>/24) to port "p<i>" of bridge
 * "br0" in the switch namespace. Skips when this machine cannot. */
static void make_hosts(void)
{
    if (g_made > 0)
        return;
    if (geteuid() != 0)
        FP_SKIP_BECAUSE("not root (network namespaces need root)");
    if (fp_find_program("ip", g_ip, sizeof g_ip) != 0)
        FP_SKIP_BECAUSE("no `ip` program (iproute2; tools/install-deps.sh installs it)");
    const unsigned tag = (unsigned)getpid() % 100000u;
    for (int i = 0; i <= NPROC; i++)
        snprintf(g_ns[i], sizeof g_ns[i], i < NPROC ? "fsh%d-%u" : "fsw-%u", i, tag);
    snprintf(g_ns[NPROC], sizeof g_ns[NPROC], "fsw-%u", tag);
    char out[2048];
    for (int i = 0; i <= NPROC; i++) {
        const char *add[] = {g_ip, "netns", "add", g_ns[i], NULL};
        if (fp_run_cmd(add, out, sizeof out) != 0) {
            delete_ns();
            FP_SKIP_BECAUSE("cannot make a network namespace here: %s", out);
        }
        g_made = i + 1;
        const char *lo[] = {g_ip, "-n", g_ns[i], "link", "set", "lo", "up", NULL};
        ip_cmd(lo);
    }
    const char *sw = g_ns[NPROC];
    const char *br[] = {g_ip, "-n", sw, "link", "add", "br0", "type", "bridge", "mcast_snooping", "0", NULL};
    const char *br_up[] = {g_ip, "-n", sw, "link", "set", "br0", "up", NULL};
    ip_cmd(br);
    ip_cmd(br_up);
    for (int i = 0; i < NPROC; i++) {
        char port[16], addr[32];
        snprintf(port, sizeof port, "p%d", i);
        snprintf(addr, sizeof addr, "10.251.0.%d/24", i + 1);
        const char *veth[] = {g_ip, "-n", g_ns[i], "link", "add", "eth0", "type", "veth", "peer", "name", port,
                              "netns", sw, NULL};
        const char *master[] = {g_ip, "-n", sw, "link", "set", port, "master", "br0", "up", NULL};
        const char *up[] = {g_ip, "-n", g_ns[i], "link", "set", "eth0", "up", "multicast", "on", NULL};
        const char *a[] = {g_ip, "-n", g_ns[i], "addr", "add", addr, "dev", "eth0", NULL};
        const char *mroute[] = {g_ip, "-n", g_ns[i], "route", "add", "224.0.0.0/4", "dev", "eth0", NULL};
        ip_cmd(veth);
        ip_cmd(master);
        ip_cmd(up);
        ip_cmd(a);
        ip_cmd(mroute);
    }
}

/* NPROC robots, robot i in host h_i, with `transport` arguments; DIR/<tag>. Its wall time. */
static double run_spread(const char *tag, const char *const *transport)
{
    static fp_fleet_t f;
    const char *prefix[] = {g_ip, "netns", "exec", "HOST", NULL};
    const char *args[16] = {"--rounds", ROUNDS, "--radius", "6", "--peer-timeout", "10"};
    int k = 6;
    for (int j = 0; transport[j] != NULL && k < 15; j++)
        args[k++] = transport[j];
    args[k] = NULL;
    fp_fleet_init(&f, tag, NPROC, prefix, args);
    for (int i = 0; i < NPROC; i++)
        f.r[i].argv[3] = g_ns[i]; /* each robot on a host of its own */
    fp_fleet_start(&f, NULL, NULL);
    return fp_fleet_wait_ok(&f, FLEET_DEADLINE_S);
}

static void test_zmq_over_three_hosts(void **st)
{
    (void)st;
    make_hosts();
    fp_inproc_reference(NPROC, ROUNDS, REF_DEADLINE_S);
    const char *transport[] = {"--transport", "zmq", "--peers", "10.251.0.1:7700,10.251.0.2:7700,10.251.0.3:7700",
                               NULL};
    const double wall = run_spread("zmq", transport);
    fp_expect_reference_models("zmq", NPROC);
    printf("# ZeroMQ/TCP, 3 robots on 3 hosts (namespaces %s .. %s, a bridge between): %s rounds in %.1f s; "
           "models equal the single-host reference\n", g_ns[0], g_ns[NPROC - 1], ROUNDS, wall);
}

static void test_lcm_multicast_over_three_hosts(void **st)
{
    (void)st;
    make_hosts();
    fp_inproc_reference(NPROC, ROUNDS, REF_DEADLINE_S);
    const char *transport[] = {"--transport", "lcm", "--lcm-url", LCM_URL, NULL};
    const double wall = run_spread("lcm", transport);
    fp_expect_reference_models("lcm", NPROC);
    printf("# LCM multicast (ttl 1, flooded by the bridge), 3 robots on 3 hosts: %s rounds in %.1f s; models "
           "equal the single-host reference\n", ROUNDS, wall);
}

static int setup(void **st)
{
    (void)st;
    return fp_setup("fleetsim_multihost", 400000u, delete_ns);
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
        cmocka_unit_test(test_zmq_over_three_hosts),
        cmocka_unit_test(test_lcm_multicast_over_three_hosts),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
