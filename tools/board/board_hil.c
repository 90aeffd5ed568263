/* board_hil: the firmware's RT core on a board, in the loop with a world served by `host_sim
 * hil`. The RT core (rt/rt_core.h: the waypoint follower, the scan -> samples step) runs at its
 * rate on the board's clock; its pose, its lidar and its wheels are the world's, over the
 * hardware-in-the-loop link (hal_stdc_install_hil). It drives its tour until the tour ends or
 * --time runs out, and reports what a board's RT core is judged by: deadlines missed, the link's
 * round trip, the time from the sensors' arrival to the wheel command. The samples it makes go
 * to the AI core's ring, which nothing drains here (they are counted).
 *
 * Built for the host (make: build/<config>/bin/board_hil, a Linux board's stand-in: UDP), for
 * rpi3 (UDP under qemu-aarch64) and for the Cortex-M boards (Ethernet or a UART under
 * qemu-system-arm):
 * `make hil-rt BOARD=...`. */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "board_args.h"
#include "board_world.h"
#include "fw_image.h"
#include "fw_link.h"
#include "hal_stdc.h"
#include "hal_stdc_hil.h"
#include "hal_stdc_target.h"
#include "rt/rt_core.h"

typedef struct hil_opts {
    const char *connect, *tour;
    uint32_t robot, timeout_ms, tries, lockstep;
    double time_s;
} hil_opts_t;

static void usage(FILE *to)
{
    fprintf(to,
            "usage: board_hil --connect WHERE --tour ROBOT.csv [options]\n"
            "Runs the firmware's RT core on this board against the world `host_sim hil` serves: it\n"
            "drives ROBOT.csv (x_m,y_m per line, the tour host_sim hil was given) until the tour ends\n"
            "or --time runs out, then prints `result <key> <value>` lines.\n\n"
            "  --connect WHERE      the link: A.B.C.D:PORT on a Linux board (UDP, host_sim hil\n"
            "                       --listen); eth0 (Ethernet) or uart0..uart3 (serial) on a\n"
            "                       Cortex-M board\n"
            "  --tour ROBOT.csv     the robot's waypoints\n"
            "  --robot I            the robot's id, as host_sim hil serves it (default 0)\n"
            "  --time S             stop after S seconds of the board's time (default 600)\n"
            "  --timeout-ms MS      wait for the world's answer to a TICK (default 200)\n"
            "  --tries N            TICKs sent before an exchange fails (default 5); the link is\n"
            "                       down, and the program ends, after %u failed in a row\n"
            "  --lockstep 0|1       1: the board's clock stands still while it waits for the world\n"
            "                       (the link's time is not the board's; default 1)\n",
            (unsigned)HAL_STDC_HIL_DOWN_AFTER);
}

static int parse_opts(int argc, char **argv, hil_opts_t *o)
{
    *o = (hil_opts_t){.timeout_ms = 200, .tries = 5, .lockstep = 1, .time_s = 600.0};
    for (int i = 1; i < argc; i += 2) { /* every option takes a value (--help ends here) */
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        int r = 0;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            exit(0);
        } else if (strcmp(a, "--connect") == 0 && v != NULL) {
            o->connect = v;
        } else if (strcmp(a, "--tour") == 0 && v != NULL) {
            o->tour = v;
        } else if (strcmp(a, "--robot") == 0) {
            r = board_parse_u32(v, 0, BOARD_MAX_FLEET - 1u, &o->robot);
        } else if (strcmp(a, "--timeout-ms") == 0) {
            r = board_parse_u32(v, 1, 60000, &o->timeout_ms);
        } else if (strcmp(a, "--lockstep") == 0) {
            r = board_parse_u32(v, 0, 1, &o->lockstep);
        } else if (strcmp(a, "--tries") == 0) {
            r = board_parse_u32(v, 1, 1000, &o->tries);
        } else if (strcmp(a, "--time") == 0) {
            r = board_parse_double(v, 1e-3, 1e6, &o->time_s);
        } else {
            return board_bad_option("board_hil", a, v, 0);
        }
        if (r != 0)
            return board_bad_option("board_hil", a, v, 1);
    }
    if (o->connect == NULL || o->tour == NULL) {
        fprintf(stderr, "board_hil: --connect and --tour are required (see --help)\n");
        return -EINVAL;
    }
    return 0;
}

static rt_waypoint_t wps[RT_CORE_MAX_WAYPOINTS];

static double mean_us(const hal_stdc_timing_t *t)
{
    return t->count > 0 ? (double)t->sum_ns * 1e-3 / (double)t->count : 0.0;
}

static hal_hil_client_t client;
static rt_core_t rt;

int main(int argc, char **argv)
{
    hil_opts_t o;
    if (parse_opts(argc, argv, &o) != 0)
        return 2;
    int n_wps;
    hal_hil_port_t port;
    const int c = board_start_world("board_hil", o.tour, o.connect, o.robot, o.timeout_ms, o.tries, wps, &n_wps, &client,
                                    &port);
    if (c != 0)
        return c;
    int r;
    const hal_hil_world_t *w = &client.world;
    printf("board_hil: board %s, robot %u, world on %s %s: plan box (%.2f, %.2f)-(%.2f, %.2f) m, physics step %u us, "
           "scan every %u us\n",
           BOARD_NAME, (unsigned)o.robot, hal_stdc_hil_kind(), o.connect, (double)w->min_x, (double)w->min_y,
           (double)w->max_x, (double)w->max_y, (unsigned)w->step_us, (unsigned)w->scan_period_us);
    if ((r = hal_stdc_install_hil("", &client, (int)o.lockstep, NULL)) != 0) {
        fprintf(stderr, "board_hil: cannot install the board (%d)\n", r);
        return 1;
    }
    rt_core_cfg_t rc = {
        .waypoints = wps,
        .n_waypoints = n_wps,
        .follow = rt_follow_default_cfg(),
        .samples = {RT_SAMPLES_DEFAULT_BEAMS, RT_SAMPLES_DEFAULT_POINTS, w->min_x, w->min_y, w->max_x, w->max_y},
        .period_us = FW_RT_PERIOD_US,
    };
    fw_link_reset();
    if ((r = rt_core_init(&rt, &rc, fw_link_get())) != 0) {
        fprintf(stderr, "board_hil: the RT core refused its configuration (%d)\n", r);
        return 1;
    }
    /* Released at whole periods of the board's time, as the world's physics steps fall: a tick's
       readings then belong to its own step whatever the link took. */
    uint64_t start = hal_stdc_target_now_us();
    start += FW_RT_PERIOD_US - start % FW_RT_PERIOD_US;
    const uint64_t end = start + (uint64_t)(o.time_s * 1e6);
    uint64_t misses = 0, overrun_max = 0, busy_max_ns = 0, compute_max_ns = 0, k = 0;
    uint64_t next_print = start + 10000000u;
    rt_status_t st = {0};
    for (;; k++) {
        const uint64_t t = start + k * FW_RT_PERIOD_US;
        if (t >= end)
            break;
        if (hal_sleep_until_us(t) != 0)
            break;
        const fw_tick_t tick = {.now_us = t, .index = k, .sub = k % FW_RT_SCAN_DIVIDER == 0};
        hal_stdc_hil_stats_t before, after;
        hal_stdc_hil_stats(&before);
        const uint64_t begin_ns = hal_stdc_target_now_ns();
        r = rt_core_tick(&rt, &tick);
        const uint64_t done_ns = hal_stdc_target_now_ns(), done = done_ns / 1000u;
        hal_stdc_hil_stats(&after);
        if (done_ns - t * 1000u > busy_max_ns)
            busy_max_ns = done_ns - t * 1000u;
        /* The core's own work: the tick without the link's wait (held already in lockstep). */
        const uint64_t compute_ns =
            done_ns - begin_ns - (o.lockstep ? 0u : after.exchange.sum_ns - before.exchange.sum_ns);
        if (compute_ns > compute_max_ns)
            compute_max_ns = compute_ns;
        if (done > t + FW_RT_PERIOD_US) { /* the next tick's release went by */
            misses++;
            if (done - t - FW_RT_PERIOD_US > overrun_max)
                overrun_max = done - t - FW_RT_PERIOD_US;
        }
        st = rt.status;
        if (after.link_down) {
            fprintf(stderr, "board_hil: the world on %s %s stopped answering (%u exchanges in a row): the link is "
                            "down\n", hal_stdc_hil_kind(), o.connect, (unsigned)HAL_STDC_HIL_DOWN_AFTER);
            break;
        }
        if (st.finished)
            break;
        if (t >= next_print) {
            printf("board_hil: t=%6.1f s  waypoint %u/%d  progress %.1f of %.1f m  scans %u  samples %u\n",
                   (double)(t - start) * 1e-6, (unsigned)st.waypoint, n_wps, (double)st.progress_m,
                   (double)st.path_length_m, (unsigned)st.scans, (unsigned)st.samples);
            fflush(stdout);
            next_print += 10000000u;
        }
    }
    hal_stdc_hil_stats_t hs;
    hal_stdc_hil_stats(&hs);
    printf("board_hil: %s after %.1f s: waypoint %u/%d, progress %.2f of %.2f m\n",
           st.finished ? "tour finished" : "stopped", (double)(k * FW_RT_PERIOD_US) * 1e-6, (unsigned)st.waypoint, n_wps,
           (double)st.progress_m, (double)st.path_length_m);
    printf("result lockstep %u\n", (unsigned)o.lockstep);
    printf("result rt_ticks %llu\n", (unsigned long long)rt.stats.ticks);
    printf("result rt_deadline_misses %llu\n", (unsigned long long)misses);
    printf("result rt_overrun_max_us %llu\n", (unsigned long long)overrun_max);
    printf("result rt_tick_max_us %.1f\n", (double)busy_max_ns * 1e-3); /* release to done, link included */
    printf("result rt_compute_max_us %.1f\n", (double)compute_max_ns * 1e-3); /* the core's work, no link */
    printf("result tour_finished %u\n", (unsigned)st.finished);
    printf("result waypoints_reached %u\n", (unsigned)st.waypoint);
    printf("result progress_m %.3f\n", (double)st.progress_m);
    printf("result distance_m %.3f\n", (double)st.distance_m);
    printf("result scans %u\n", (unsigned)st.scans);
    printf("result samples %u\n", (unsigned)(st.samples + st.ring_drops));
    printf("result hal_errors %u\n", (unsigned)st.errors);
    printf("result link_exchanges %llu\n", (unsigned long long)hs.exchange.count);
    printf("result link_round_trip_mean_us %.1f\n", mean_us(&hs.exchange));
    printf("result link_round_trip_max_us %.1f\n", (double)hs.exchange.max_ns * 1e-3);
    printf("result sense_to_command_mean_us %.2f\n", mean_us(&hs.response));
    printf("result sense_to_command_max_us %.2f\n", (double)hs.response.max_ns * 1e-3);
    printf("result link_errors %llu\n", (unsigned long long)hs.link_errors);
    printf("result link_resent_ticks %llu\n", (unsigned long long)client.stats.resent_ticks);
    printf("result link_refused %llu\n", (unsigned long long)(client.stats.refused + client.stats.replayed +
                                                              client.stats.unopened + client.stats.bad_payload));
    hal_stdc_uninstall();
    return hs.link_errors > 0 && !st.finished ? 1 : 0;
}
