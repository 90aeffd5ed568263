/* The fleet through crashes, pauses and partitions, as real processes: 3 `host_sim run --fleet`
 * processes over LCM UDP multicast, offline, every peer a neighbour (--radius 0), preset of
 * the build, a short --peer-timeout so that each case takes seconds (docs/faults.md).
 *   - SIGKILL and --resume: robot 1 is killed with SIGKILL mid-run, after it wrote a round
 *     checkpoint (--val-every 10), and started again with the same command plus --resume.
 *     Every robot exits 0; robot 1 says it resumed ("resuming robot 1 from round_..."), its
 *     incarnation file says 2, its final.bnn loads (finite); the survivors' summary.txt count
 *     the peer restart.
 *   - SIGSTOP until both survivors have timed robot 1 out (their logs say so), then SIGCONT:
 *     every robot exits 0; the survivors count the timeout (summary.txt "peer timeouts"); robot
 *     1 skipped rounds to catch up with them, and its final validation loss is finite and within
 *     2x of each survivor's.
 *   - a partition and its heal (--net-faults partition=0/1.2,from=T1,until=T2 on every robot):
 *     every robot exits 0; inside the window robot 0 trains with no neighbour while robots 1
 *     and 2 stay each other's (metrics.csv `neighbours`), outside it every robot has both; the
 *     side behind skipped ahead after the heal; in the last 10 % of the rounds every robot
 *     has both neighbours again and robot 0's consensus error (`disagreement`) falls after the
 *     heal (every robot steps to the mean of the round's states when a neighbour returns after a
 *     long absence, and the link duals of the cut restart, dinno.h) and ends back at its level
 *     before the cut, within PART_BACK_FACTOR (docs/faults.md, "Bad and cheap links").
 * Bounded: every wait has a deadline (a checkpoint awaited, a killed robot's end, each
 * fleet); when it passes every robot is killed and the test FAILS, naming the robot and what
 * it waited for. Every child is killed on every path (tests/support/fleet_procs.[ch]: the
 * teardown, and a handler of SIGINT/SIGTERM/SIGHUP). Run by `make test-faults`, not by `make
 * test`. */
#define _XOPEN_SOURCE 700
#include <limits.h>
#include <math.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "ai/bnn.h"
#include "ai/bnn_ckpt.h"
#include "fleet_procs.h"
#include "run_outputs.h"

#define NPROC 3
#define PEER_TIMEOUT_S 2
#define PEER_TIMEOUT "2"
#define KILL_ROUNDS "200"
/* Robot 1 stays stopped until both survivors have timed it out (their logs say so), and
   STOP_AFTER_MS more, so that they are a few rounds ahead when it wakes: woken at a fixed time
   instead (3 peer timeouts), the survivors of a fast CI machine ran all 700 rounds while it slept.
   Alone they run 100-200 rounds a second on 2 shared cores. */
#define STOP_ROUNDS "700"
#define STOP_AFTER_MS 300
#define STOP_DEADLINE_S (10 * PEER_TIMEOUT_S) /* a timeout is said PEER_TIMEOUT_S after the stop */
#define TIMED_OUT "peer(s) timed out and left the round"
/* The partition: 3 peer timeouts of 1 s, from 2 s to 5 s of each robot's network clock (its
   metrics.csv wall_s; the robots start some 50 ms apart); robot 0 may stay alone PART_SLACK_S
   after the heal, until robots 1 and 2 have caught up. Robot 0 alone runs 100-250 rounds a
   second (the fleet about 40 on a slow machine), so it is in round 350-1000 at the heal, and
   PART_ROUNDS leaves it 500 rounds or more after it: the disagreement needs about 200 to fall
   back to its level before the cut, and the last 10 % of the rounds are the ones measured (a
   2-core Zen 5 healed in round 817 of 1000 and ended 1.6x above the level). */
#define PART_ROUNDS 1500
#define PART_TIMEOUT_S 1.0
#define PART_FROM_S 2.0
#define PART_UNTIL_S 5.0
#define PART_SPEC "partition=0/1.2,from=2,until=5"
#define PART_SLACK_S 1.5
/* How far above its level before the cut robot 0's disagreement may end: the rounds left after
   the heal, and so how far it has fallen, depend on the CPU (CI machines healed in round 506 of
   700 and 702 of 1000 and ended 7 % and 3 % above the level, a Zen 5 in round 817 of 1000 and
   60 % above); without the rejoin it ended 19x above. */
#define PART_BACK_FACTOR 1.5
#ifndef FLEET_DEADLINE_S
#define FLEET_DEADLINE_S 120 /* a passing fleet takes 5-15 s */
#endif
#define CKPT_DEADLINE_S 60 /* the first round checkpoint comes about 1 s after the start */
#define KILL_DEADLINE_S 10 /* a SIGKILLed robot is gone at once */
#define MAX_ROWS 4096

static void test_path(char *out, size_t cap, const fp_robot_t *r, const char *name)
{
    snprintf(out, cap, "%.3000s/%s", r->out, name);
}

/* 1 when the robot is not running (any more): its status then in r->status. */
static int exited(fp_robot_t *r)
{
    if (r->pid == 0)
        return 1;
    const int rc = fp_wait(r->pid, 0.0);
    if (rc < 0)
        return 0;
    r->status = rc;
    r->pid = 0;
    return 1;
}

/* SIGKILL to a robot and its end, within KILL_DEADLINE_S. */
static void kill_robot(fp_robot_t *r)
{
    assert_int_equal(kill(r->pid, SIGKILL), 0);
    const int rc = fp_wait(r->pid, fp_now() + KILL_DEADLINE_S);
    if (rc < 0)
        fail_msg("robot %d still running %d s after SIGKILL", r->id, KILL_DEADLINE_S);
    if (rc != 128 + SIGKILL)
        fail_msg("robot %d ended with status %d before the SIGKILL reached it", r->id, rc);
    r->pid = 0;
    r->status = rc;
}

static double robot_summary(const fp_robot_t *r, const char *line, const char *what, int after)
{
    char p[PATH_MAX + 32];
    test_path(p, sizeof p, r, "summary.txt");
    return fp_summary_number(p, line, what, after);
}

/* The model in `file` loads (bnn_ckpt_load checks its CRC, its shape and that every value is
 * finite) and its parameters are finite. */
static void expect_model_loads(const char *file)
{
    size_t n = 0;
    uint8_t *b = test_slurp(file, &n);
    if (b == NULL)
        fail_msg("%s: missing", file);
    bnn_model_t *m = aligned_alloc(_Alignof(bnn_model_t), (sizeof *m + 63) / 64 * 64);
    assert_non_null(m);
    assert_int_equal(bnn_init(m, NULL, 1), 0);
    const char *why = NULL;
    if (bnn_ckpt_load(m, b, n, &why) != 0)
        fail_msg("%s does not load: %s", file, why ? why : "?");
    const float *p = bnn_params_const(m);
    for (size_t i = 0; i < bnn_n_params(m); i++)
        if (!isfinite(p[i]))
            fail_msg("%s: parameter %zu is %g", file, i, (double)p[i]);
    free(m);
    free(b);
}

static void test_sigkill_and_resume(void **st)
{
    (void)st;
    static fp_fleet_t f;
    const char *args[] = {"--rounds", KILL_ROUNDS, "--radius", "0", "--peer-timeout", PEER_TIMEOUT, "--val-every",
                          "10", NULL};
    fp_fleet_init(&f, "killed", NPROC, NULL, args);
    fp_fleet_start(&f, NULL, NULL);
    fp_robot_t *r1 = &f.r[1];
    fp_wait_for_file(r1, "round_", ".bnn", fp_now() + CKPT_DEADLINE_S);
    fp_sleep_ms(300); /* between two checkpoints */
    kill_robot(r1);
    const double killed_at = fp_now() - f.t0;
    for (int i = 0; i < NPROC; i++)
        if (i != 1 && exited(&f.r[i]))
            fail_msg("robot %d ended (status %d) before robot 1 could be started again: raise KILL_ROUNDS", i,
                     f.r[i].status);
    snprintf(r1->log, sizeof r1->log, "%.3000s/log_1_resumed.txt", f.dir);
    fp_robot_add_arg(r1, "--resume");
    fp_robot_start(r1, NULL, NULL);
    const double wall = fp_fleet_wait_ok(&f, FLEET_DEADLINE_S);

    size_t n = 0;
    char *log = (char *)test_slurp(r1->log, &n), *said = log ? strstr(log, "resuming robot 1 from round_") : NULL;
    if (said == NULL)
        fail_msg("robot 1 restarted with --resume does not say 'resuming robot 1 from round_...':\n%s",
                 log ? log : "(no output)");
    unsigned from = 0, at = 0;
    assert_int_equal(sscanf(said, "resuming robot 1 from round_%*u.bnn (round %u); continuing at round %u", &from, &at),
                     2);
    free(log);
    char p[PATH_MAX + 32];
    test_path(p, sizeof p, r1, "incarnation");
    char *inc = (char *)test_slurp(p, &n);
    if (inc == NULL || atoi(inc) != 2)
        fail_msg("%s says '%s', not 2 (a restart is the robot's second incarnation)", p, inc ? inc : "(missing)");
    free(inc);
    test_path(p, sizeof p, r1, "final.bnn");
    expect_model_loads(p);
    double seen[NPROC] = {0};
    for (int i = 0; i < NPROC; i++) {
        if (i == 1)
            continue;
        seen[i] = robot_summary(&f.r[i], "faults survived:", " peer restarts seen", 0);
        if (seen[i] < 1)
            fail_msg("robot %d's summary.txt counts no peer restart (robot 1 was killed and started again)", i);
    }
    printf("# SIGKILL: robot 1 killed at %.1f s, resumed from its round %u checkpoint at round %u; every robot "
           "exited 0 after %.1f s (%s rounds); peer restarts seen by robots 0 and 2: %.0f, %.0f\n",
           killed_at, from, at, wall, KILL_ROUNDS, seen[0], seen[2]);
}

static void test_sigstop_and_sigcont(void **st)
{
    (void)st;
    static fp_fleet_t f;
    const char *args[] = {"--rounds", STOP_ROUNDS, "--radius", "0", "--peer-timeout", PEER_TIMEOUT, "--val-every",
                          "10", NULL};
    fp_fleet_init(&f, "paused", NPROC, NULL, args);
    fp_fleet_start(&f, NULL, NULL);
    fp_robot_t *r1 = &f.r[1];
    fp_wait_for_file(r1, "round_", ".bnn", fp_now() + CKPT_DEADLINE_S);
    assert_int_equal(kill(r1->pid, SIGSTOP), 0);
    const double stopped_at = fp_now() - f.t0;
    for (int i = 0; i < NPROC; i++)
        if (i != 1)
            fp_wait_for_log(&f.r[i], TIMED_OUT, fp_now() + STOP_DEADLINE_S);
    fp_sleep_ms(STOP_AFTER_MS);
    const double stopped_for = fp_now() - f.t0 - stopped_at;
    assert_int_equal(kill(r1->pid, SIGCONT), 0);
    int early = 0;
    for (int i = 0; i < NPROC; i++)
        if (i != 1 && exited(&f.r[i]))
            early = 1;
    const double wall = fp_fleet_wait_ok(&f, FLEET_DEADLINE_S);
    if (early)
        fail_msg("the survivors finished all %s rounds while robot 1 was stopped: nothing left to catch up with "
                 "(raise STOP_ROUNDS)", STOP_ROUNDS);

    double timeouts[NPROC] = {0}, val[NPROC];
    for (int i = 0; i < NPROC; i++) {
        val[i] = robot_summary(&f.r[i], "final val loss:", "final val loss: ", 1);
        if (i == 1)
            continue;
        timeouts[i] = robot_summary(&f.r[i], "losses:", " peer timeouts", 0);
        if (timeouts[i] < 1)
            fail_msg("robot %d's summary.txt counts no peer timeout (robot 1 was stopped for %.1f s, the peer "
                     "timeout is %s s)", i, stopped_for, PEER_TIMEOUT);
    }
    const double skipped = robot_summary(r1, "faults survived:", " rounds skipped to catch up", 0);
    if (skipped < 1)
        fail_msg("robot 1 skipped no round to catch up after its pause (summary.txt 'rounds skipped to catch up')");
    for (int i = 0; i < NPROC; i++) {
        if (!isfinite(val[i]))
            fail_msg("robot %d's final val loss is %g", i, val[i]);
        if (i != 1 && (val[1] > 2.0 * val[i] || val[i] > 2.0 * val[1]))
            fail_msg("robot 1's final val loss %.5f is not within 2x of robot %d's %.5f", val[1], i, val[i]);
    }
    printf("# SIGSTOP: robot 1 stopped at %.1f s for %.1f s; peer timeouts of robots 0 and 2: %.0f, %.0f; robot 1 "
           "skipped %.0f rounds; final val loss %.4f (robots 0 and 2: %.4f, %.4f); every robot exited 0 after "
           "%.1f s (%s rounds)\n",
           stopped_at, stopped_for, timeouts[0], timeouts[2], skipped, val[1], val[0], val[2], wall, STOP_ROUNDS);
}

/* metrics.csv of one robot: the columns the partition case reads. */
typedef struct rows {
    int n;
    double round[MAX_ROWS], nbrs[MAX_ROWS], dis[MAX_ROWS], wall[MAX_ROWS];
} rows_t;

static void read_rows(const fp_robot_t *r, rows_t *m)
{
    char p[PATH_MAX + 32];
    test_path(p, sizeof p, r, "metrics.csv");
    m->n = fp_csv_column(p, "round", m->round, MAX_ROWS);
    if (m->n < 1 || fp_csv_column(p, "neighbours", m->nbrs, MAX_ROWS) != m->n ||
        fp_csv_column(p, "disagreement", m->dis, MAX_ROWS) != m->n ||
        fp_csv_column(p, "wall_s", m->wall, MAX_ROWS) != m->n)
        fail_msg("%s: ragged or empty", p);
}

static void test_partition_and_heal(void **st)
{
    (void)st;
    static fp_fleet_t f;
    static rows_t m[NPROC];
    static char rounds[16], timeout[16]; /* in the robots' commands */
    snprintf(rounds, sizeof rounds, "%d", PART_ROUNDS);
    snprintf(timeout, sizeof timeout, "%g", PART_TIMEOUT_S);
    const char *args[] = {"--rounds", rounds, "--radius", "0", "--peer-timeout", timeout, "--net-faults", PART_SPEC,
                          NULL};
    fp_fleet_init(&f, "partition", NPROC, NULL, args);
    fp_fleet_start(&f, NULL, NULL);
    const double wall = fp_fleet_wait_ok(&f, FLEET_DEADLINE_S);

    double skipped = 0;
    for (int i = 0; i < NPROC; i++) {
        read_rows(&f.r[i], &m[i]);
        if (robot_summary(&f.r[i], "network faults injected", " partitioned", 0) < 1)
            fail_msg("robot %d's summary.txt counts no datagram lost to the partition", i);
        if (robot_summary(&f.r[i], "losses:", " peer timeouts", 0) < 1)
            fail_msg("robot %d's summary.txt counts no peer timeout (the partition lasted %g peer timeouts)", i,
                     (PART_UNTIL_S - PART_FROM_S) / PART_TIMEOUT_S);
        skipped += robot_summary(&f.r[i], "faults survived:", " rounds skipped to catch up", 0);
    }
    /* Inside the window (after the peer timeouts it costs, at most two, and before the heal)
       robot 0 has no neighbour and robots 1 and 2 have each other; before it all have both;
       robot 0 is alone nowhere else (up to the slack after the heal). */
    const double in_from = PART_FROM_S + 2.0 * PART_TIMEOUT_S + 0.5, in_until = PART_UNTIL_S - 0.3;
    int alone = 0, pair[NPROC] = {0}, first0 = -1, last0 = -1;
    for (int i = 0; i < NPROC; i++)
        for (int k = 0; k < m[i].n; k++) {
            const double t = m[i].wall[k], nb = m[i].nbrs[k];
            const int want_in = i == 0 ? 0 : 1;
            if (t < PART_FROM_S && nb != NPROC - 1)
                fail_msg("robot %d: %g neighbours in round %.0f at %.2f s, before the partition", i, nb,
                         m[i].round[k], t);
            if (t >= in_from && t <= in_until && nb != want_in)
                fail_msg("robot %d: %g neighbours in round %.0f at %.2f s, inside the partition (expected %d)", i,
                         nb, m[i].round[k], t, want_in);
            if (i == 0 && nb == 0) {
                if (t < PART_FROM_S || t > PART_UNTIL_S + PART_SLACK_S)
                    fail_msg("robot 0 had no neighbour in round %.0f at %.2f s, outside the partition "
                             "(%g s to %g s)", m[i].round[k], t, PART_FROM_S, PART_UNTIL_S);
                alone++;
                if (first0 < 0)
                    first0 = k;
                last0 = k;
            }
            if (i > 0 && nb == 1 && t >= PART_FROM_S && t <= PART_UNTIL_S + PART_SLACK_S)
                pair[i]++;
        }
    if (alone < 10)
        fail_msg("robot 0 trained only %d rounds without neighbours during the partition", alone);
    for (int i = 1; i < NPROC; i++)
        if (pair[i] < 5)
            fail_msg("robot %d had its partner as its only neighbour in only %d rounds of the partition", i,
                     pair[i]);
    if (last0 + 1 >= m[0].n)
        fail_msg("robot 0 finished its %d rounds before the heal (%g s): raise PART_ROUNDS", PART_ROUNDS,
                 PART_UNTIL_S);
    /* The side behind skips ahead after the heal. How far apart the sides were then depends on
       the CPU (robot 0 alone is not faster than the pair when all three wait for cores): two
       rounds or more apart, someone must have skipped; closer, nobody needs to. */
    double at_heal[NPROC];
    for (int i = 0; i < NPROC; i++) {
        at_heal[i] = -1;
        for (int k = 0; k < m[i].n && m[i].wall[k] <= PART_UNTIL_S; k++)
            at_heal[i] = m[i].round[k];
    }
    const double apart = fabs(at_heal[0] - fmax(at_heal[1], at_heal[2]));
    if (apart >= 2 && skipped < 1)
        fail_msg("no robot skipped a round after the heal, with the sides %.0f rounds apart (robot 0 in round %.0f, "
                 "robots 1 and 2 in %.0f and %.0f)", apart, at_heal[0], at_heal[1], at_heal[2]);
    /* After the heal: everyone back, the consensus error falling. */
    double before = 0, after = 0, tail = 0, during = 0;
    int nb_before = 0, nb_after = 0, nb_tail = 0, nb_during = 0;
    for (int i = 0; i < NPROC; i++)
        for (int k = 0; k < m[i].n; k++) {
            if (m[i].round[k] < 0.9 * PART_ROUNDS)
                continue;
            if (m[i].nbrs[k] != NPROC - 1 || !isfinite(m[i].dis[k]))
                fail_msg("robot %d: %g neighbours and disagreement %g in round %.0f, in the last 10 %% of the "
                         "rounds (long after the heal)", i, m[i].nbrs[k], m[i].dis[k], m[i].round[k]);
            if (i == 0) {
                tail += m[i].dis[k];
                nb_tail++;
            }
        }
    for (int k = 1; k < m[0].n && m[0].wall[k] < PART_FROM_S; k++, nb_before++)
        before += m[0].dis[k];
    for (int k = last0 + 1; k < m[0].n && k <= last0 + 10; k++, nb_after++)
        after += m[0].dis[k];
    /* Back within 10 rounds: the first round after the heal measures the states the neighbours
       sent before they met (every robot rejoins in it, dinno.h), the next ten how far apart the
       models are after they met. */
    double back = 0;
    int nb_back = 0;
    for (int k = last0 + 2; k < m[0].n && k <= last0 + 11; k++, nb_back++)
        back += m[0].dis[k];
    for (int i = 1; i < NPROC; i++)
        for (int k = 0; k < m[i].n; k++)
            if (m[i].nbrs[k] == 1 && isfinite(m[i].dis[k])) {
                during += m[i].dis[k];
                nb_during++;
            }
    assert_true(nb_tail > 0 && nb_after > 0);
    before /= nb_before > 0 ? nb_before : 1;
    during /= nb_during > 0 ? nb_during : 1;
    after /= nb_after;
    tail /= nb_tail;
    back /= nb_back > 0 ? nb_back : 1;
    printf("# partition %s, peer timeout %g s, %d rounds: robot 0 alone in rounds %.0f..%.0f (%d rounds), robots 1 "
           "and 2 together in %d and %d rounds; %.0f rounds apart at the heal, %.0f skipped after it; robot 0's "
           "disagreement: %.2g before, %.2g in the first 10 rounds after the heal, %.2g in the 10 after its first, "
           "%.2g in the last 10 %% (robots 1 and 2 during: %.2g); every robot exited 0 after %.1f s\n",
           PART_SPEC, PART_TIMEOUT_S, PART_ROUNDS, m[0].round[first0], m[0].round[last0], alone, pair[1], pair[2],
           apart, skipped, before, after, back, tail, during, wall);
    /* The recovery (docs/faults.md, "Bad and cheap links"): falling from the first rounds after
       the heal on, and below the level before the cut at the end (the disagreement falls as the
       learning rate decays). Before one dual per link and the rejoin it was 19x the level before
       the cut at the end of this test. Not asked: back at that level within 10 rounds (about 8x
       here: the duals take tens of rounds to be re-learned). */
    if (!(nb_back > 0 && back < after))
        fail_msg("robot 0's disagreement did not fall after the heal: %.3g in rounds 2-11 after it, %.3g in the "
                 "first 10", back, after);
    /* The level to fall below: robot 0's before the cut, or, when the cut came before its first
       round with neighbours (a slow start: the tour took the first 2 s; nb_before 0 made the
       level 0, which no disagreement is below), that of robots 1 and 2 together during it. */
    const double level = nb_before > 0 ? before : during;
    if (!(tail <= PART_BACK_FACTOR * level))
        fail_msg("robot 0's disagreement stayed up after the heal: %.3g in the last 10 %% of the rounds, more than "
                 "%.2gx the %.3g %s", tail, PART_BACK_FACTOR, level,
                 nb_before > 0 ? "before the partition" : "between robots 1 and 2 during it");
}

static int teardown_case(void **st)
{
    (void)st;
    fp_kill_all();
    return 0;
}

static int setup(void **st)
{
    (void)st;
    return fp_setup("fleetsim_crash", 300000u, NULL);
}

static int teardown(void **st)
{
    (void)st;
    return fp_teardown();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_sigkill_and_resume, teardown_case),
        cmocka_unit_test_teardown(test_sigstop_and_sigcont, teardown_case),
        cmocka_unit_test_teardown(test_partition_and_heal, teardown_case),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
