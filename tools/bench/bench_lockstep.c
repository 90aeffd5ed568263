/* Cost of the host HAL's lockstep scheduler: three cores at the image's default rates
 * (RT 50 Hz, GP 10 Hz, AI 10 Hz) with empty ticks and a world whose physics step does
 * nothing, run for N simulated seconds. What remains is the price of the hand-offs between
 * threads, per tick and as a real-time factor (simulated seconds per wall second).
 *
 *   bench_lockstep [--seconds N] [--help]      (N: 1 .. 100000, default 600)
 * Prints `BENCH <name> <value> <unit>` lines. The cost depends on where the threads may run:
 * pinned to one core (`taskset -c 1`) every hand-off is a context switch on that core, across
 * cores it is a wake-up on another one. So the first line says which (from the process's CPU
 * affinity), and every figure's name ends in `_pinned` (one CPU allowed) or `_across_<N>cpus`. */
#define _GNU_SOURCE /* sched_getaffinity, CPU_COUNT */
#include <errno.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fw_image.h"
#include "hal/hal.h"
#include "hal_host.h"

static int empty_advance(void *ctx, uint64_t t)
{
    (void)ctx;
    (void)t;
    return 0;
}

static int empty_tick(void *arg, const fw_tick_t *t)
{
    (void)arg;
    (void)t;
    return 0;
}

static fw_image_t img;

static double run(hal_host_sched_t sched, uint64_t seconds, uint64_t *ticks)
{
    hal_host_world_t w = {.advance_to_us = empty_advance};
    hal_host_config_t cfg = hal_host_config_default();
    cfg.world = &w;
    cfg.sched = sched;
    hal_host_t *h = NULL;
    if (hal_host_create(&cfg, &h) != 0 || hal_board_install(hal_host_board(h)) != 0) {
        fprintf(stderr, "bench_lockstep: cannot create the host board\n");
        exit(1);
    }
    fw_image_defaults(&img);
    for (int c = 0; c < HAL_CORE_COUNT; c++)
        img.core[c].tick = empty_tick;
    if (fw_image_start(&img) != 0) {
        fprintf(stderr, "bench_lockstep: cannot start the cores\n");
        exit(1);
    }
    struct timespec a, b;
    clock_gettime(CLOCK_MONOTONIC, &a);
    int r = hal_host_run_until(h, seconds * 1000000u);
    clock_gettime(CLOCK_MONOTONIC, &b);
    hal_host_stop(h);
    *ticks = 0;
    for (int c = 0; c < HAL_CORE_COUNT; c++)
        *ticks += img.stats[c].ticks;
    hal_host_destroy(h);
    if (r != 0) {
        fprintf(stderr, "bench_lockstep: run failed (%d)\n", r);
        exit(1);
    }
    return (double)(b.tv_sec - a.tv_sec) + 1e-9 * (double)(b.tv_nsec - a.tv_nsec);
}

int main(int argc, char **argv)
{
    uint64_t seconds = 600;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            printf("usage: %s [--seconds N]\n"
                   "  Runs three empty cores (50/10/10 Hz) in lockstep for N simulated seconds\n"
                   "  (1..100000, default 600) and prints the scheduler's cost per tick.\n",
                   argv[0]);
            return 0;
        }
        if (strcmp(argv[i], "--seconds") == 0 && i + 1 < argc) {
            char *end = NULL;
            errno = 0;
            unsigned long long v = strtoull(argv[++i], &end, 10);
            if (errno != 0 || end == argv[i] || *end != '\0' || v < 1 || v > 100000) {
                fprintf(stderr, "bench_lockstep: --seconds wants an integer in 1..100000\n");
                return 2;
            }
            seconds = v;
            continue;
        }
        fprintf(stderr, "bench_lockstep: unknown argument '%s' (see --help)\n", argv[i]);
        return 2;
    }
    /* where the threads may run: the suffix of every figure's name */
    char where[32] = "_across_?cpus";
    cpu_set_t set;
    CPU_ZERO(&set);
    if (sched_getaffinity(0, sizeof set, &set) == 0) {
        const int ncpu = CPU_COUNT(&set);
        if (ncpu == 1) {
            int cpu = 0;
            while (!CPU_ISSET(cpu, &set))
                cpu++;
            printf("# bench_lockstep: pinned to one core (cpu %d): hand-offs are context switches\n", cpu);
            snprintf(where, sizeof where, "_pinned");
        } else {
            printf("# bench_lockstep: across %d cpus (not pinned): hand-offs wake threads on other cores\n",
                   ncpu);
            snprintf(where, sizeof where, "_across_%dcpus", ncpu);
        }
    }
    const struct { hal_host_sched_t s; const char *name; } modes[] = {
        {HAL_HOST_SCHED_SERIAL, "serial"}, {HAL_HOST_SCHED_PARALLEL, "parallel"}};
    for (size_t m = 0; m < 2; m++) {
        uint64_t ticks = 0;
        double wall = run(modes[m].s, seconds, &ticks);
        printf("BENCH lockstep_%s_tick_cost%s %.2f us\n", modes[m].name, where,
               1e6 * wall / (double)ticks);
        printf("BENCH lockstep_%s_realtime_factor%s %.0f x\n", modes[m].name, where,
               (double)seconds / wall);
    }
    return 0;
}
