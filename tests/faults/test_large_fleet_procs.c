/* A fleet larger than the board's neighbour slots, starved of CPU, as real processes: 40
 * `host_sim run` processes over LCM multicast on this host, all on ONE core (the launcher's
 * affinity, inherited), every robot within reach of every other (a 1 km radius), so each keeps
 * the states of its 32 nearest (ties by id) out of 39 and tells its network to drop the other
 * peers' chunks (hal_net_set_senders). As tools/fleet starts a fleet beyond the neighbour slots,
 * what is for one robot (requests for its chunks, the chunks it asked for) travels on its own
 * channels, which the others' kernels drop (--lcm-addressed): multicast resends reached every
 * robot, and a robot off the core while 39 peers re-sent chunks for one another filled its
 * queue with copies it did not need (569 dropped in one CI run). Their tours come from
 * `host_sim paths gen --robots 40` (five robots per room of the default plan). With the default
 * peer timeout (10 s) a robot waiting for the core must not be taken for a crashed one: no peer
 * timeout, no state given up, no datagram dropped by a full queue, and the final models equal
 * `host_sim fleet --inproc`'s bit for bit (the protocol engine and the in-process graph
 * choose the same nearest, and the DiNNO slots sum them in the same order). Bounded like every
 * fleet test (tests/support/fleet_procs.h): a hang is a failure. About 45 s on this machine. */
#define _GNU_SOURCE /* sched_setaffinity */
#include <limits.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <sched.h>

#include "fleet_procs.h"
#include "run_outputs.h"
#include "gp/gp_pse.h"

#define NPROC 40
#define ROUNDS "3"
#define RADIUS "1000"
#define DEADLINE_S 600

_Static_assert(NPROC <= FP_MAX_ROBOTS && NPROC - 1 > GP_PSE_MAX_NEIGHBOURS,
               "more robots in reach than neighbour slots");

/* What a failure needs to be read: the network lines of the robot that dropped the most (or
   of robot 0), whose queue's high-water marks tell which of its two limits was reached. */
static void print_worst_robot(unsigned long long full)
{
    int worst = 0;
    double most = -1.0;
    for (int i = 0; full > 0 && i < NPROC; i++) {
        char p[PATH_MAX + 64];
        snprintf(p, sizeof p, "%s/forty/robot_%d/summary.txt", fp_env.dir, i);
        const double d = fp_summary_number(p, "waiting for peers", "(queue full", 1);
        if (d > most) {
            most = d;
            worst = i;
        }
    }
    char p[PATH_MAX + 64];
    snprintf(p, sizeof p, "%s/forty/robot_%d/summary.txt", fp_env.dir, worst);
    size_t len = 0;
    char *text = (char *)test_slurp(p, &len);
    if (text == NULL)
        return;
    static const char *const keys[] = {"traffic:", "network:", "losses:", "liveness:", "waiting for peers:",
                                       "network queue:"};
    for (size_t k = 0; k < sizeof keys / sizeof keys[0]; k++) {
        const char *l = strstr(text, keys[k]);
        if (l != NULL)
            print_message("# robot %d: %.*s\n", worst, (int)strcspn(l, "\n"), l);
    }
    free(text);
}

static void test_nearest_of_forty_equal_inproc(void **st)
{
    (void)st;
    /* Tours of its own for each robot: the default plan's 7 do not go round 40. */
    char tours[FP_SHORT_PATH + 8], robots[8], out[4096];
    snprintf(tours, sizeof tours, "%s/tours", fp_env.dir);
    assert_true(strlen(tours) < sizeof fp_env.paths);
    snprintf(robots, sizeof robots, "%d", NPROC);
    const char *gen[] = {fp_env.bin, "paths", "gen", "--plan", fp_env.plan, "--robots", robots, "--seed", "3",
                         "--out", tours, NULL};
    if (fp_run_cmd(gen, out, sizeof out) != 0)
        fail_msg("host_sim paths gen --robots %d failed:\n%s", NPROC, out);
    memcpy(fp_env.paths, tours, strlen(tours) + 1u);

    /* One core for the whole fleet: its robots inherit the affinity. */
    cpu_set_t all, one;
    assert_int_equal(sched_getaffinity(0, sizeof all, &all), 0);
    CPU_ZERO(&one);
    for (int c = 0; c < CPU_SETSIZE; c++)
        if (CPU_ISSET(c, &all)) {
            CPU_SET(c, &one);
            break;
        }
    assert_int_equal(sched_setaffinity(0, sizeof one, &one), 0);
    static fp_fleet_t f;
    const char *args[] = {"--rounds", ROUNDS, "--radius", RADIUS, "--resend-ms", "200", "--lcm-addressed", NULL};
    fp_fleet_init(&f, "forty", NPROC, NULL, args);
    fp_fleet_start(&f, NULL, NULL);
    const double wall = fp_fleet_wait_ok(&f, DEADLINE_S);
    assert_int_equal(sched_setaffinity(0, sizeof all, &all), 0);
    const unsigned long long timeouts = fp_summary_sum("forty", NPROC, "losses:", " peer timeouts", 0);
    const unsigned long long missed = fp_summary_sum("forty", NPROC, "faults survived", " peer states gone without", 0);
    const unsigned long long full = fp_summary_sum("forty", NPROC, "waiting for peers", "(queue full", 1);
    const unsigned long long unwanted =
        fp_summary_sum("forty", NPROC, "network:", " datagrams of senders not asked for", 0);
    if (timeouts != 0 || missed != 0 || full != 0) {
        print_worst_robot(full);
        fail_msg("on one core: %llu peer timeouts, %llu states given up, %llu datagrams dropped by full queues "
                 "(all must be 0)", timeouts, missed, full);
    }
    /* The posterior rounds of a fleet beyond the neighbour slots do not reach the fleet's sum
       (docs/uncertainty.md): the summary says so rather than letting it pass. */
    char sp[PATH_MAX + 64];
    snprintf(sp, sizeof sp, "%s/forty/robot_0/summary.txt", fp_env.dir);
    size_t len = 0;
    char *text = (char *)test_slurp(sp, &len);
    assert_non_null(text);
    const char *line = strstr(text, "posterior rounds:");
    if (line == NULL || strstr(line, "NOT the fleet's") == NULL)
        fail_msg("%s does not say that the posterior rounds of %d robots are not the fleet's: %.300s", sp, NPROC,
                 line != NULL ? line : "(no posterior rounds line)");
    free(text);
    fp_inproc_reference_radius(NPROC, ROUNDS, RADIUS, DEADLINE_S);
    fp_expect_reference_models("forty", NPROC);
    print_message("%d processes on one core, %s rounds, each keeping its %u nearest of %d: %.1f s, no timeout, "
                  "no state given up, no queue drop, %llu unwanted datagrams dropped on arrival; models equal to "
                  "the in-process reference\n", NPROC, ROUNDS, (unsigned)GP_PSE_MAX_NEIGHBOURS, NPROC - 1, wall,
                  unwanted);
}

static int setup(void **st)
{
    (void)st;
    return fp_setup("fleetsim_large", 500000u, NULL);
}

static int teardown(void **st)
{
    (void)st;
    return fp_teardown();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_nearest_of_forty_equal_inproc),
    };
    return cmocka_run_group_tests_name("faults/large_fleet", tests, setup, teardown);
}
