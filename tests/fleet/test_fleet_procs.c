/* The multi-process fleet, started the way users start it: real host_sim processes exchanging
 * over LCM UDP multicast on this host (udpm://, ttl 0).
 *   - 3 processes, offline, no loss: their final models equal `host_sim fleet --inproc`'s bit
 *     for bit (same seed, same positions, same node updates);
 *   - the same with every 7th datagram lost (the FLEETSIM_NET_DROP_EVERY seam of
 *     hal/host/hal_host_net.c): the protocol asks again for what is missing, so the models are
 *     still the reference's, and the traffic logs show the chunks requested and re-sent;
 *   - the same over shared memory (--transport shm), lossy: the reference's models;
 *   - int8 and int4-ef states: a smaller state on the wire, the run completes; int4-ef's models
 *     equal the in-process fleet's with the same codec, bit for bit;
 *   - tools/fleet: a robot killed with SIGKILL makes the launcher stop the fleet, name the
 *     robot and the signal, and exit 1; Ctrl-C (SIGINT) stops it with status 130; neither
 *     leaves a host_sim process of that fleet behind.
 * Each test uses its own fleet id (from the pid), so parallel runs on one host do not mix.
 * Bounded: every process has a deadline (FLEET_DEADLINE_S for a fleet, REF_DEADLINE_S for the
 * reference, LAUNCHER_DEADLINE_S for tools/fleet to stop); when it passes the process is
 * killed and the test FAILS, naming what it waited for (a hang is a failure, not a blocked
 * `make test`). Every child is killed on every path (tests/support/fleet_procs.[ch]). */
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

#include "fleet_procs.h"
#include "run_outputs.h"

#define NPROC 3
#define ROUNDS "4"
/* Generous (a passing fleet takes a few seconds, several times that under AddressSanitizer):
   they only turn a hang into a failure. */
#define FLEET_DEADLINE_S 300
#define REF_DEADLINE_S 300
#define LAUNCHER_DEADLINE_S 60 /* tools/fleet stops its robots within seconds */

static char *slurp(const char *path, size_t *len)
{
    return (char *)test_slurp(path, len);
}

static int g_zmq;    /* the next fleet over ZeroMQ/TCP on loopback instead of LCM */
static char g_proxy[32]; /* with g_zmq: "HOST:PORT" of a host_sim zmq-proxy instead of --peers */
static int g_groups; /* the next fleet over LCM with per-sender groups and inboxes */
static int g_addressed; /* the next fleet over LCM's one group, addressed (--lcm-addressed) */
static int g_shm;       /* the next fleet over shared memory (--transport shm) */

/* The fleet: NPROC `host_sim run --fleet` processes into DIR/<tag>/robot_<i>. */
static void run_fleet(const char *tag, const char *encoding, const char *drop_every)
{
    static fp_fleet_t f;
    static char peers[128];
    const unsigned port = 24000u + (unsigned)(getpid() % 1000) * 8u;
    snprintf(peers, sizeof peers, "127.0.0.1:%u,127.0.0.1:%u,127.0.0.1:%u", port, port + 1u, port + 2u);
    const char *args[16] = {"--rounds", ROUNDS, "--radius", "6", "--encoding", encoding, "--peer-timeout", "20"};
    int n = 8;
    if (g_zmq) {
        args[n++] = "--transport";
        args[n++] = "zmq";
        args[n++] = g_proxy[0] ? "--zmq-proxy" : "--peers";
        args[n++] = g_proxy[0] ? g_proxy : peers;
    }
    if (g_groups)
        args[n++] = "--lcm-groups";
    if (g_addressed)
        args[n++] = "--lcm-addressed";
    if (g_shm) {
        args[n++] = "--transport";
        args[n++] = "shm";
    }
    args[n] = NULL;
    fp_fleet_init(&f, tag, NPROC, NULL, args);
    fp_fleet_start(&f, drop_every ? "FLEETSIM_NET_DROP_EVERY" : NULL, drop_every);
    fp_fleet_wait_ok(&f, FLEET_DEADLINE_S);
    if (g_shm) { /* its segment, as tools/fleet removes it */
        char seg[64];
        snprintf(seg, sizeof seg, "/dev/shm/fleetsim.fleet-%s", f.fid);
        assert_int_equal(unlink(seg), 0);
    }
}

/* Sums a column of DIR/<tag>/robot_<i>/traffic.csv over rounds and robots. */
static unsigned long long traffic_sum(const char *tag, const char *column)
{
    unsigned long long total = 0;
    for (int i = 0; i < NPROC; i++) {
        char p[PATH_MAX + 64];
        snprintf(p, sizeof p, "%s/%s/robot_%d/traffic.csv", fp_env.dir, tag, i);
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
    fp_inproc_reference(NPROC, ROUNDS, REF_DEADLINE_S);
    fp_expect_reference_models("fp32", NPROC);
    assert_int_equal(traffic_sum("fp32", "timeouts"), 0);
    assert_int_equal(traffic_sum("fp32", "crc_failures"), 0);
}

static void test_lost_datagrams_are_recovered(void **st)
{
    (void)st;
    run_fleet("lossy", "fp32", "7");
    fp_inproc_reference(NPROC, ROUNDS, REF_DEADLINE_S);
    fp_expect_reference_models("lossy", NPROC);
    assert_true(traffic_sum("lossy", "chunks_requested") > 0);
    assert_true(traffic_sum("lossy", "chunks_resent") > 0);
    assert_int_equal(traffic_sum("lossy", "timeouts"), 0);
}

/* Both transports pass the same protocol cases: ZeroMQ/TCP gives the reference's models, also
 * when every 7th datagram is lost at the sender. Over ZeroMQ a lost chunk comes back on its
 * requester's own resend channel only, so the lossy fleet's models prove that channel works. */
static void test_zmq_equals_inproc(void **st)
{
    (void)st;
    g_zmq = 1;
    run_fleet("zmq", "fp32", NULL);
    run_fleet("zmq-lossy", "fp32", "7");
    g_zmq = 0;
    fp_inproc_reference(NPROC, ROUNDS, REF_DEADLINE_S);
    fp_expect_reference_models("zmq", NPROC);
    fp_expect_reference_models("zmq-lossy", NPROC);
    assert_true(traffic_sum("zmq-lossy", "chunks_requested") > 0);
    assert_true(traffic_sum("zmq-lossy", "chunks_resent") > 0);
    assert_int_equal(traffic_sum("zmq-lossy", "timeouts"), 0);
    assert_int_equal(traffic_sum("zmq", "timeouts"), 0);
}

/* The same lossy fleet through one `host_sim zmq-proxy` process instead of the full mesh:
 * every robot's two connections to it carry the protocol as the mesh did (the addressed
 * resends included: the proxy sends them to the one robot subscribed), the models are the
 * reference's, and the proxy stops on SIGTERM with exit 0, having forwarded datagrams. */
static void test_zmq_proxy_equals_inproc(void **st)
{
    (void)st;
    const unsigned port = 24000u + (unsigned)(getpid() % 1000) * 8u + 4u; /* beside run_fleet's 3 */
    char port_s[16], log[PATH_MAX + 32];
    snprintf(port_s, sizeof port_s, "%u", port);
    snprintf(g_proxy, sizeof g_proxy, "127.0.0.1:%u", port);
    snprintf(log, sizeof log, "%s/zmq_proxy.log", fp_env.dir);
    const char *argv[] = {fp_env.bin, "zmq-proxy", "--port", port_s, "--every", "1", NULL};
    const pid_t proxy = fp_spawn(argv, log, NULL, NULL);
    assert_true(proxy > 0);
    g_zmq = 1;
    run_fleet("zmq-proxy", "fp32", "7");
    g_zmq = 0;
    g_proxy[0] = '\0';
    assert_int_equal(kill(proxy, SIGTERM), 0);
    const int rc = fp_wait(proxy, fp_now() + 10.0);
    if (rc != 0)
        fp_show_log(log);
    assert_int_equal(rc, 0);
    size_t len = 0;
    char *text = slurp(log, &len);
    assert_non_null(text);
    assert_non_null(strstr(text, "stopped by SIGTERM"));
    unsigned long long frames = 0;
    const char *last = NULL;
    for (const char *t = strstr(text, "datagrams"); t != NULL; t = strstr(t + 1, "datagrams"))
        last = t;
    assert_non_null(last);
    while (last > text && last[-1] != ':')
        last--;
    frames = strtoull(last, NULL, 10);
    free(text);
    printf("# zmq proxy: %llu datagrams forwarded for %d robots\n", frames, NPROC);
    assert_true(frames > 0);
    fp_inproc_reference(NPROC, ROUNDS, REF_DEADLINE_S);
    fp_expect_reference_models("zmq-proxy", NPROC);
    assert_true(traffic_sum("zmq-proxy", "chunks_resent") > 0);
    assert_int_equal(traffic_sum("zmq-proxy", "timeouts"), 0);
}

/* LCM with per-sender groups and inboxes (--lcm-groups: the states on a multicast group per
 * sender, requests and the chunks sent again on the robot's own inbox group), every 7th
 * datagram lost at the sender: the lost chunks come back through the inboxes, and the models
 * are the in-process reference's. */
/* A fleet with *mode set, every 7th datagram lost at the sender: chunks were asked for and
   sent again, nobody timed out, and the models are the in-process reference's. */
static void lossy_fleet_equals_inproc(const char *tag, int *mode)
{
    *mode = 1;
    run_fleet(tag, "fp32", "7");
    *mode = 0;
    fp_inproc_reference(NPROC, ROUNDS, REF_DEADLINE_S);
    fp_expect_reference_models(tag, NPROC);
    assert_true(traffic_sum(tag, "chunks_requested") > 0);
    assert_true(traffic_sum(tag, "chunks_resent") > 0);
    assert_int_equal(traffic_sum(tag, "timeouts"), 0);
}

static void test_lcm_groups_equal_inproc(void **st)
{
    (void)st;
    lossy_fleet_equals_inproc("groups-lossy", &g_groups);
}

/* LCM's one group, addressed (--lcm-addressed: requests and the chunks sent again on the
 * robot's own channels, which the others' kernel filters drop), every 7th datagram lost at the
 * sender: the lost chunks come back on the requesters' channels, and the models are the
 * in-process reference's. */
static void test_lcm_addressed_equals_inproc(void **st)
{
    (void)st;
    lossy_fleet_equals_inproc("addressed-lossy", &g_addressed);
}

/* Shared memory between the processes (--transport shm), every 7th datagram lost at the
 * sender: the lost chunks come back on the requesters' own channels, the models are the
 * in-process reference's, and the segment was there to remove. */
static void test_shm_equals_inproc(void **st)
{
    (void)st;
    lossy_fleet_equals_inproc("shm-lossy", &g_shm);
}

static void test_int8_states(void **st)
{
    (void)st;
    run_fleet("int8", "int8", NULL);
    const unsigned long long b8 = traffic_sum("int8", "bytes_sent"), b32 = traffic_sum("fp32", "bytes_sent");
    assert_true(b8 > 0 && b8 * 3 < b32); /* about a quarter */
    /* 4-bit states (the AI core may hand over theta or a difference: the same to the wire) */
    run_fleet("int4-ef", "int4-ef", NULL);
    const unsigned long long b4 = traffic_sum("int4-ef", "bytes_sent");
    assert_true(b4 > 0 && b4 * 10 < b8 * 6); /* about half of int8's (the row scales are the same) */
    assert_int_equal(traffic_sum("int4-ef", "invalid"), 0);
    assert_int_equal(traffic_sum("int4-ef", "states_missed"), 0);
    /* The differences against the public copies (dinno.h): the receivers' copies are the
       senders', so the process fleet trains the in-process fleet's models with the same codec,
       bit for bit. */
    const char *const int4_ef[] = {"--encoding", "int4-ef", NULL};
    fp_inproc_run(NPROC, ROUNDS, "6", "inproc-int4-ef", int4_ef, REF_DEADLINE_S);
    fp_expect_models_of("int4-ef", NPROC, "inproc-int4-ef");
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
    snprintf(tool, sizeof tool, "%s/tools/fleet", fp_env.root);
    snprintf(res, sizeof res, "%s/results", fp_env.dir);
    snprintf(log, cap, "%s/launcher_%d.txt", fp_env.dir, stop);
    snprintf(fid, sizeof fid, "%u", fp_env.fleet_id++);
    const char *argv[] = {"/usr/bin/python3", tool, "--bin", fp_env.bin, "--robots", "3", "--rounds", "100000",
                          "--fleet-id", fid, "--results", res, "--name", stop == 1 ? "killed" : "interrupted",
                          "--no-report", "--val-poses", "1", "--force", NULL};
    const pid_t launcher = fp_spawn(argv, log, NULL, NULL);
    pid_t robots[8];
    int n = 0;
    for (int t = 0; t < 600 && (n = fleet_pids(fid, robots, 8)) < NPROC; t++)
        fp_sleep_ms(100);
    if (n != NPROC) {
        fp_show_log(log);
        kill(launcher, SIGTERM);
        if (fp_wait(launcher, fp_now() + LAUNCHER_DEADLINE_S) < 0)
            print_error("the launcher still running %d s after SIGTERM: killed\n", LAUNCHER_DEADLINE_S);
        fp_kill(launcher);
        fail_msg("the launcher did not start %d robots within 60 s (%d running)", NPROC, n);
    }
    fp_sleep_ms(1500); /* the tours and a few rounds */
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
    const int rc = fp_wait(launcher, fp_now() + LAUNCHER_DEADLINE_S);
    if (rc < 0) {
        fp_kill(launcher);
        fp_show_log(log);
        fail_msg("tools/fleet still running %d s after %s: killed (it must stop the fleet)", LAUNCHER_DEADLINE_S,
                 stop == 1 ? "robot 1 was killed" : "SIGINT");
    }
    fp_sleep_ms(200);
    pid_t left[8];
    const int nleft = fleet_pids(fid, left, 8);
    for (int i = 0; i < nleft; i++)
        kill(left[i], SIGKILL); /* not ours to reap: the launcher's, reparented to init */
    if (nleft != 0)
        fail_msg("%d host_sim process(es) of fleet %s left behind by tools/fleet (killed now)", nleft, fid);
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

/* After each test, also a failed one: nothing of it keeps running into the next. */
static int teardown_case(void **st)
{
    (void)st;
    g_zmq = 0;
    fp_kill_all();
    return 0;
}

static int setup(void **st)
{
    (void)st;
    return fp_setup("fleetsim_procs", 100000u, NULL);
}

static int teardown(void **st)
{
    (void)st;
    return fp_teardown();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_three_processes_equal_inproc, teardown_case),
        cmocka_unit_test_teardown(test_lost_datagrams_are_recovered, teardown_case),
        cmocka_unit_test_teardown(test_zmq_equals_inproc, teardown_case),
        cmocka_unit_test_teardown(test_zmq_proxy_equals_inproc, teardown_case),
        cmocka_unit_test_teardown(test_lcm_groups_equal_inproc, teardown_case),
        cmocka_unit_test_teardown(test_lcm_addressed_equals_inproc, teardown_case),
        cmocka_unit_test_teardown(test_shm_equals_inproc, teardown_case),
        cmocka_unit_test_teardown(test_int8_states, teardown_case),
        cmocka_unit_test_teardown(test_killed_robot_stops_the_fleet, teardown_case),
        cmocka_unit_test_teardown(test_ctrl_c_stops_the_fleet, teardown_case),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
