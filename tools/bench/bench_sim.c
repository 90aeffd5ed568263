/* host_sim benchmarks on the default plan (host_sim/plans/apartment.svg):
 *   BENCH lidar_rays_per_s <n> rays/s          single-thread ODE ray casts (360-beam scans
 *                                              from random free-ish poses)
 *   BENCH sim_realtime_factor_1robot <x> x     physics + a 360-beam scan at 10 Hz simulated,
 *                                              one robot following host_sim/plans/apartment/
 *                                              robot_1.csv (firmware follower at 20 Hz, the
 *                                              tour driven forth and back), simulated s / wall s
 *   BENCH paths_check_100k_waypoints_s <s> s   what `host_sim paths check` does (CSV parse with
 *                                              the per-segment wall check, the 0.2 m clearance
 *                                              check, min clearance, coverage within 1.5 and
 *                                              3.5 m) for robot_1's tour driven forth and back
 *                                              to 100,000 waypoints
 * The monotonic wall clock is used here only (never inside the simulation).
 * Usage: bench_sim [--plan P] [--path F] [--seconds S]   (S = simulated seconds, 2nd figure)
 * Comment lines (#) add the same figures on process CPU time, which other load on the core
 * disturbs less than the wall clock. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "rt/rt_follow.h"
#include "sim_grid.h"
#include "sim_lidar.h"
#include "sim_paths.h"
#include "sim_plan.h"
#include "sim_rng.h"
#include "sim_shape.h"
#include "sim_world.h"

static double cpu_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* A pose inside some room and not inside a solid (rooms may be absent: bounding box). */
static sim_pose_t pick_pose(const sim_plan_t *p, uint64_t i)
{
    for (uint64_t t = 0;; t++) {
        double x = p->min.x + sim_rng_uniform(7, 0, i, t, 0) * (p->max.x - p->min.x);
        double y = p->min.y + sim_rng_uniform(7, 1, i, t, 0) * (p->max.y - p->min.y);
        int ok = p->n_rooms == 0;
        for (int r = 0; r < p->n_rooms && !ok; r++)
            ok = sim_shape_contains(&p->rooms[r].outline, x, y);
        for (int s = 0; s < p->n_solids && ok; s++)
            if (sim_shape_contains(&p->solids[s].outline, x, y) ||
                sim_shape_edge_distance(&p->solids[s].outline, x, y) < 0.25)
                ok = 0;
        if (ok || t > 1000) {
            sim_pose_t q = {x, y, 6.283185307179586 * sim_rng_uniform(7, 2, i, t, 0)};
            return q;
        }
    }
}

int main(int argc, char **argv)
{
    const char *plan_path = "host_sim/plans/apartment.svg";
    const char *path_file = "host_sim/plans/apartment/robot_1.csv";
    double sim_seconds = 60.0;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--plan") == 0 && i + 1 < argc)
            plan_path = argv[++i];
        else if (strcmp(argv[i], "--path") == 0 && i + 1 < argc)
            path_file = argv[++i];
        else if (strcmp(argv[i], "--seconds") == 0 && i + 1 < argc)
            sim_seconds = atof(argv[++i]);
        else if (strcmp(argv[i], "--help") == 0) {
            printf("usage: bench_sim [--plan FILE.svg] [--path ROBOT.csv] [--seconds SIMULATED_S]\n");
            return 0;
        } else {
            fprintf(stderr, "bench_sim: bad argument '%s' (see --help)\n", argv[i]);
            return 2;
        }
    }
    if (!(sim_seconds > 0 && sim_seconds < 1e6)) {
        fprintf(stderr, "bench_sim: --seconds must be in (0, 1e6)\n");
        return 2;
    }
    char err[256];
    sim_plan_t plan;
    if (sim_plan_load(plan_path, 0, &plan, err, sizeof err) < 0) {
        fprintf(stderr, "bench_sim: %s\n", err);
        return 1;
    }
    sim_world_t *w;
    sim_world_cfg_t wc = sim_world_default_cfg();
    if (sim_world_create(&plan, &wc, &w, err, sizeof err) < 0) {
        fprintf(stderr, "bench_sim: %s\n", err);
        return 1;
    }
    sim_lidar_cfg_t lc = sim_lidar_default_cfg();
    sim_lidar_t *lid;
    if (sim_lidar_create(&lc, &lid) < 0)
        return 1;
    float ranges[360];

    /* 1. rays per second. */
    enum { NPOSE = 64 };
    sim_pose_t poses[NPOSE];
    for (int i = 0; i < NPOSE; i++)
        poses[i] = pick_pose(&plan, (uint64_t)i);
    long rays = 0;
    double hits = 0;
    double c_start = cpu_s();
    double t0 = now_s(), t1 = t0;
    for (int rep = 0; t1 - t0 < 1.0; rep++) {
        for (int i = 0; i < NPOSE; i++) {
            if (sim_lidar_scan(lid, w, poses[i].x, poses[i].y, poses[i].theta, 0, (uint64_t)rep,
                               ranges, NULL) < 0)
                return 1;
            for (int b = 0; b < 360; b++)
                hits += isfinite(ranges[b]);
        }
        rays += NPOSE * 360;
        t1 = now_s();
    }
    printf("# %ld rays in %.3f s, %.1f%% hits, %d solids; %.0f rays/s on process CPU time\n", rays,
           t1 - t0, 100.0 * hits / rays, plan.n_solids, (double)rays / (cpu_s() - c_start));
    printf("BENCH lidar_rays_per_s %.0f rays/s\n", (double)rays / (t1 - t0));

    /* 2. one robot: physics at dt plus a 360-beam scan every 0.1 simulated seconds, driven
     * by the firmware follower along a real path. */
    sim_path_t path;
    if (sim_path_read_csv(path_file, &plan, &path, err, sizeof err) < 0) {
        fprintf(stderr, "bench_sim: %s\n", err);
        return 1;
    }
    rt_waypoint_t *wps = malloc(sizeof(rt_waypoint_t) * (size_t)path.n);
    if (wps == NULL)
        return 1;
    for (int i = 0; i < path.n; i++) {
        wps[i].x = (float)path.p[i].x;
        wps[i].y = (float)path.p[i].y;
    }
    int id;
    sim_pose_t start = {path.p[0].x, path.p[0].y,
                        atan2(path.p[1].y - path.p[0].y, path.p[1].x - path.p[0].x)};
    if (sim_world_add_robot(w, NULL, start, &id) < 0)
        return 1;
    rt_follow_t fol;
    rt_follow_cfg_t fc = rt_follow_default_cfg();
    if (rt_follow_init(&fol, &fc) < 0)
        return 1;
    int steps_per_scan = (int)lround(0.1 / sim_world_dt(w));
    int steps_per_ctl = steps_per_scan / 2; /* 20 Hz */
    int laps = 0;
    int n_scans = (int)ceil(sim_seconds * 10.0);
    double t_scan = 0.0, c0 = cpu_s();
    t0 = now_s();
    for (int s = 0; s < n_scans; s++) {
        sim_pose_t p;
        for (int half = 0; half < 2; half++) {
            rt_follow_cmd_t cmd;
            if (sim_world_pose(w, id, &p) < 0 ||
                rt_follow_step(&fol, wps, path.n, (float)p.x, (float)p.y, (float)p.theta, &cmd) < 0)
                return 1;
            if (cmd.finished) { /* drive the tour back, from its end to its start */
                laps++;
                for (int i = 0; i < path.n / 2; i++) {
                    rt_waypoint_t t = wps[i];
                    wps[i] = wps[path.n - 1 - i];
                    wps[path.n - 1 - i] = t;
                }
                if (rt_follow_init(&fol, &fc) < 0)
                    return 1;
            }
            if (sim_world_set_wheels(w, id, cmd.wheel_left, cmd.wheel_right) < 0 ||
                sim_world_step(w, steps_per_ctl) < 0)
                return 1;
        }
        double ts = now_s();
        if (sim_world_pose(w, id, &p) < 0 ||
            sim_lidar_scan(lid, w, p.x, p.y, p.theta, 0, (uint64_t)s, ranges, NULL) < 0)
            return 1;
        t_scan += now_s() - ts;
    }
    t1 = now_s();
    double cpu = cpu_s() - c0;
    double simulated = sim_world_time(w);
    printf("# %.1f simulated s (%d steps of %.4f s, %d scans, %d laps of %s) in %.3f wall s, "
           "%llu collisions\n",
           simulated, n_scans * steps_per_scan, sim_world_dt(w), n_scans, laps, path_file, t1 - t0,
           (unsigned long long)sim_world_collisions(w, id));
    printf("# of which lidar %.3f s, physics %.1f us per step; %.1f x on process CPU time "
           "(insensitive to other load on the core)\n",
           t_scan, 1e6 * (t1 - t0 - t_scan) / (n_scans * steps_per_scan), simulated / cpu);
    printf("BENCH sim_realtime_factor_1robot %.1f x\n", simulated / (t1 - t0));

    /* paths check on a long tour: 100,000 waypoints of the tour forth and back, as CSV. */
    {
        const int n_target = 100000;
        size_t cap = (size_t)n_target * 32 + 64, len = 0;
        char *csv = malloc(cap);
        if (csv == NULL)
            return 1;
        len += (size_t)snprintf(csv, cap, "x_m,y_m\n");
        for (int k = 0; k < n_target; k++) {
            const int lap = k / (path.n - 1), j = k % (path.n - 1);
            const int idx = lap % 2 == 0 ? j : path.n - 1 - j;
            len += (size_t)snprintf(csv + len, cap - len, "%.3f,%.3f\n", path.p[idx].x, path.p[idx].y);
        }
        sim_grid_t g = {0};
        if (sim_grid_from_plan(&plan, 0.05, &g) != 0)
            return 1;
        char perr[256];
        sim_path_t big;
        const double c0 = now_s();
        if (sim_path_parse_csv(csv, "bench.csv", &plan, &big, perr, sizeof perr) != 0) {
            fprintf(stderr, "bench_sim: %s\n", perr);
            return 1;
        }
        int seg;
        double dist;
        const int tight = sim_path_first_tight_segment(&plan, &big, 0.2, &seg, &dist);
        const double mc = sim_path_min_clearance(&plan, &big);
        const double cov15 = sim_paths_coverage(&g, &big, 1, 1.5), cov35 = sim_paths_coverage(&g, &big, 1, 3.5);
        const double c1 = now_s();
        printf("# paths check: %d waypoints (%.0f m), tight segments %d, min clearance %.3f m, coverage "
               "%.1f%% / %.1f%% within 1.5 / 3.5 m\n",
               big.n, sim_path_length(&big), tight, mc, 100 * cov15, 100 * cov35);
        printf("BENCH paths_check_100k_waypoints_s %.3f s\n", c1 - c0);
        sim_path_free(&big);
        sim_grid_free(&g);
        free(csv);
    }
    free(wps);
    sim_path_free(&path);
    sim_lidar_destroy(lid);
    sim_world_destroy(w);
    sim_plan_free(&plan);
    return 0;
}
