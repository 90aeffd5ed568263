/* A keyed fleet under attack, as real processes (issue 27, "a fleet only its members can
 * join"): 3 `host_sim run --fleet` processes over LCM UDP multicast with one fleet key, and an
 * attacker on the same multicast group as a process of its own.
 *   - a forger without the key: every 20 ms a forged state_chunk_t of robot 1 (chunk 0, CRC
 *     0xdeadbeef, a newer incarnation, half of them with a made-up trailer) and a whole state of
 *     robot 1 scaled to 1e6 with a correct CRC, for the rounds in turn. Before the key, one such
 *     chunk per round hung the fleet at its start, and the scaled state was trained on;
 *   - a replay: lcm-logger records a keyed run, lcm-logplayer plays it back (Debian's own
 *     tools) into a new run with the same key and the same fleet id but another run id.
 * Each attacked fleet's final models equal the in-process reference's (the clean run) bit for
 * bit, and summary.txt counts what was dropped: datagrams without a valid tag, datagrams of
 * another run. Every wait is bounded: a fleet that is not done in FLEET_DEADLINE_S is killed
 * and the test FAILS. Run by `make test-faults`. */
#define _XOPEN_SOURCE 700
#include <limits.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmocka.h>
#include <lcm/lcm.h>

#include "common/crc32.h"
#include "fleet_procs.h"
#include "gp/gp_fleet.h"
#include "gp/gp_wire.h"
#include "hal_host.h"

#define NPROC 3
#define ROUNDS "20"
#ifndef FLEET_DEADLINE_S
#define FLEET_DEADLINE_S 120 /* a passing fleet takes a few seconds */
#endif
#define REF_DEADLINE_S 120

static char g_key[PATH_MAX];
static volatile pid_t g_attacker; /* killed on every path: the teardown and the signal handler */

static void kill_attacker(void)
{
    if (g_attacker > 0) {
        kill(g_attacker, SIGKILL);
        waitpid(g_attacker, NULL, 0);
        g_attacker = 0;
    }
}

/* NPROC keyed robots, run id `run_id` (NULL: unkeyed), fleet id `fid` (NULL: a new one) into
 * DIR/<tag>. */
static fp_fleet_t *start_fleet(const char *tag, const char *run_id, const char *fid)
{
    static fp_fleet_t f;
    const char *args[] = {"--rounds", ROUNDS, "--radius", "6", "--peer-timeout", "2", fid ? "--fleet-id" : "--quiet",
                          fid ? fid : "--quiet", run_id ? "--key-file" : NULL, g_key, "--run-id", run_id, NULL};
    fp_fleet_init(&f, tag, NPROC, NULL, args);
    fp_fleet_start(&f, NULL, NULL);
    return &f;
}

/* The attacker: a process of its own on the fleet's multicast group, holding no key. */
static void attacker_main(unsigned fleet_id, int rounds)
{
    lcm_t *l = lcm_create(HAL_HOST_NET_URL_DEFAULT);
    char ch[64];
    if (l == NULL || gp_fleet_channel_name(fleet_id, GP_FLEET_CH_STATE, ch, sizeof ch) != 0)
        _exit(3);
    const uint32_t sb = gp_fleet_state_bytes(DINNO_CODEC_FP32);
    const uint32_t nc = (sb + GP_PSE_MAX_CHUNK_BYTES - 1u) / GP_PSE_MAX_CHUNK_BYTES;
    static uint8_t state[GP_PSE_MAX_CHUNKS * GP_PSE_MAX_CHUNK_BYTES], junk[GP_PSE_MAX_CHUNK_BYTES];
    static uint8_t buf[HAL_NET_MTU_BYTES + HAL_HOST_AUTH_TRAILER_BYTES];
    const float big = 1e6f; /* every parameter: a state scaled far out */
    for (uint32_t i = 0; i + 4u <= sb; i += 4u)
        memcpy(state + i, &big, 4);
    memset(junk, 0xA5, sizeof junk);
    const uint32_t crc = crc32_ieee(state, sb);
    /* Until the test kills it; a test that was itself killed cannot, so the attack also ends
       by itself once no fleet of the test can still run. */
    const double end = fp_now() + 2.0 * FLEET_DEADLINE_S;
    for (uint64_t it = 0; fp_now() < end; it++) {
        const uint32_t r = (uint32_t)(it % (uint64_t)rounds);
        gp_pse_chunk_t forged = {.sender = 1, .round = r, .chunk = 0, .n_chunks = nc, .state_bytes = sb,
                                 .crc32 = 0xdeadbeefu, .x_m = 0.0, .y_m = 0.0, .n_bytes = nc > 1 ? GP_PSE_MAX_CHUNK_BYTES : sb,
                                 .data = junk, .encoding = 0, .incarnation = 7};
        int len = gp_wire_encode_chunk(&forged, buf, sizeof buf);
        if (len < 0)
            _exit(4);
        if (it % 2 == 1) { /* a made-up trailer: it looks keyed */
            memset(buf + len, (int)(it & 0xff), HAL_HOST_AUTH_TRAILER_BYTES);
            len += (int)HAL_HOST_AUTH_TRAILER_BYTES;
        }
        (void)lcm_publish(l, ch, buf, (unsigned)len);
        for (uint32_t c = 0; c < nc; c++) {
            const uint32_t n = c + 1u < nc ? GP_PSE_MAX_CHUNK_BYTES : sb - c * GP_PSE_MAX_CHUNK_BYTES;
            gp_pse_chunk_t scaled = forged;
            scaled.chunk = c;
            scaled.crc32 = crc;
            scaled.n_bytes = n;
            scaled.data = state + (size_t)c * GP_PSE_MAX_CHUNK_BYTES;
            gp_pse_chunk_t check;
            len = gp_wire_encode_chunk(&scaled, buf, sizeof buf);
            if (len < 0 || gp_wire_decode_chunk(buf, (size_t)len, &check) != 0) /* well-formed, or no test */
                _exit(5);
            (void)lcm_publish(l, ch, buf, (unsigned)len);
        }
        fp_sleep_ms(20);
    }
    _exit(0);
}

static pid_t start_attacker(unsigned fleet_id)
{
    fflush(NULL);
    const pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0)
        attacker_main(fleet_id, atoi(ROUNDS));
    g_attacker = pid;
    return pid;
}

static void stop_attacker(pid_t pid)
{
    int status = 0;
    const pid_t gone = waitpid(pid, &status, WNOHANG);
    kill_attacker();
    assert_int_equal(gone, 0); /* it was still attacking: it did not give up on the way */
}

static void test_forger_without_the_key(void **st)
{
    (void)st;
    fp_inproc_reference(NPROC, ROUNDS, REF_DEADLINE_S);
    fp_fleet_t *f = start_fleet("forged", "3", NULL);
    const pid_t att = start_attacker((unsigned)atoi(f->fid));
    const double wall = fp_fleet_wait_ok(f, FLEET_DEADLINE_S);
    stop_attacker(att);
    fp_expect_reference_models("forged", NPROC);
    const unsigned long long unauth = fp_summary_sum("forged", NPROC, "keyed fleet", " datagrams without a valid tag", 0);
    const unsigned long long bad = fp_summary_sum("forged", NPROC, "malformed datagrams dropped", "malformed datagrams dropped", 1);
    printf("# forger without the key (a forged chunk and a state x1e6 of robot 1 every 20 ms): 3 robots, %s rounds "
           "in %.1f s, %llu datagrams without a valid tag dropped, %llu malformed; models equal the clean run's\n",
           ROUNDS, wall, unauth, bad);
    assert_true(unauth > 0);
    assert_int_equal(bad, 0); /* refused by the tag, before the bounds check */
}

/* The same attacker against an UNKEYED fleet: what the key is for. The forged states reach the
 * protocol (a newer incarnation of robot 1 makes its genuine messages look old) and the node
 * update (the screen leaves the x1e6 states out); the fleet still ends, without robot 1's
 * genuine states, instead of hanging. */
static void test_forger_against_an_unkeyed_fleet(void **st)
{
    (void)st;
    fp_fleet_t *f = start_fleet("unkeyed", NULL, NULL);
    const pid_t att = start_attacker((unsigned)atoi(f->fid));
    const double wall = fp_fleet_wait_ok(f, FLEET_DEADLINE_S);
    stop_attacker(att);
    unsigned long long old = 0, out = 0;
    for (int i = 0; i < NPROC; i += 2) { /* robots 0 and 2, the ones robot 1's forgeries are sent to */
        char p[PATH_MAX + 64];
        snprintf(p, sizeof p, "%s/unkeyed/robot_%d/summary.txt", fp_env.dir, i);
        old += (unsigned long long)fp_summary_number(p, "faults survived", " messages of an earlier incarnation", 0);
        out += (unsigned long long)fp_summary_number(p, "screen:", " neighbour states left out", 0);
    }
    printf("# the same forger against an unkeyed fleet: done in %.1f s; robots 0 and 2 dropped %llu genuine messages "
           "of robot 1 as older than a forged incarnation, the screen left %llu forged states out\n",
           wall, old, out);
    assert_true(old + out > 0);
}

static void test_replayed_recording(void **st)
{
    (void)st;
    char logger[PATH_MAX], player[PATH_MAX], log[PATH_MAX + 32], chan[64], url[300], fid[16];
    if (fp_find_program("lcm-logger", logger, sizeof logger) != 0 ||
        fp_find_program("lcm-logplayer", player, sizeof player) != 0)
        fail_msg("lcm-logger / lcm-logplayer not found (Debian liblcm-bin; tools/install-deps.sh installs it)");
    fp_inproc_reference(NPROC, ROUNDS, REF_DEADLINE_S);
    snprintf(fid, sizeof fid, "%u", fp_env.fleet_id++);
    snprintf(log, sizeof log, "%s/earlier.lcmlog", fp_env.dir);
    snprintf(chan, sizeof chan, "--channel=fleetsim/%s/.*", fid);
    snprintf(url, sizeof url, "--lcm-url=%s", HAL_HOST_NET_URL_DEFAULT);
    /* The earlier run, recorded. */
    const char *rec_argv[] = {logger, "--quiet", url, chan, log, NULL};
    const pid_t rec = fp_spawn(rec_argv, NULL, NULL, NULL);
    fp_sleep_ms(300); /* the logger subscribed */
    fp_fleet_t *f = start_fleet("earlier", "1", fid);
    fp_fleet_wait_ok(f, FLEET_DEADLINE_S);
    fp_sleep_ms(200);
    kill(-rec, SIGINT); /* lcm-logger closes its file */
    if (fp_wait(rec, fp_now() + 10) < 0)
        fp_kill(rec);
    fp_expect_reference_models("earlier", NPROC);
    /* The new run, same key, same fleet id, another run id: the recording played into it. */
    const char *play_argv[] = {player, url, log, NULL};
    f = start_fleet("replayed", "2", fid);
    const pid_t play = fp_spawn(play_argv, NULL, NULL, NULL);
    const double wall = fp_fleet_wait_ok(f, FLEET_DEADLINE_S);
    fp_kill(play);
    fp_expect_reference_models("replayed", NPROC);
    const unsigned long long replayed = fp_summary_sum("replayed", NPROC, "keyed fleet", " of another run dropped", 0);
    printf("# a recording of an earlier run with the same key, played back by lcm-logplayer: 3 robots, %s rounds in "
           "%.1f s, %llu datagrams of another run dropped; models equal the clean run's\n",
           ROUNDS, wall, replayed);
    assert_true(replayed > 0);
}

static int setup(void **st)
{
    (void)st;
    if (fp_setup("fleetsim_attack", 300000u, kill_attacker) != 0)
        return -1;
    snprintf(g_key, sizeof g_key, "%s/fleet.key", fp_env.dir);
    const char *argv[] = {fp_env.bin, "key", "new", g_key, NULL};
    char out[512];
    return fp_run_cmd(argv, out, sizeof out) == 0 ? 0 : -1;
}

static int teardown(void **st)
{
    (void)st;
    kill_attacker();
    return fp_teardown();
}

static int teardown_test(void **st)
{
    (void)st;
    kill_attacker();
    fp_kill_all();
    return 0;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_forger_without_the_key, teardown_test),
        cmocka_unit_test_teardown(test_replayed_recording, teardown_test),
        cmocka_unit_test_teardown(test_forger_against_an_unkeyed_fleet, teardown_test),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
