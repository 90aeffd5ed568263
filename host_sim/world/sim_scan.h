/* One robot drives its waypoint path in the ODE world and turns its lidar scans into
 * training samples: the loop behind `host_sim scan`.
 *
 * It runs the firmware's own RT core (rt_core_tick, alone in a firmware image) on the host
 * HAL in lockstep with the world (sim_hal_world), exactly as `host_sim run` does: every
 * control tick (control_hz, default the firmware's 50 Hz) the GPS/compass fix goes to the
 * waypoint follower, whose wheel commands drive the robot; every scan tick (scan_hz) a lidar
 * scan (sensor_beams beams with noise and dropout) becomes beams x points labelled samples at
 * the GPS pose in the RT -> AI ring, which this loop drains into the samples file in place of
 * the AI core. So the file holds what the firmware produces, sample for sample.
 * The robot starts at the first waypoint facing the second. The run ends when the RT core
 * reports the path finished, or fails at max_time_s simulated seconds.
 * Everything is simulated time and keyed noise: same inputs and seed -> identical file. */
#ifndef SIM_SCAN_H
#define SIM_SCAN_H

#include <stddef.h>
#include <stdint.h>

#include "sim_paths.h"
#include "sim_plan.h"

typedef struct sim_scan_cfg {
    uint64_t seed;
    uint32_t robot;        /* robot index: keys the noise streams; default 0 */
    int beams;             /* beams used for samples, default 20 */
    int points;            /* points per beam, default 25 */
    int sensor_beams;      /* lidar beams per scan, default 360 (a multiple is not required) */
    double scan_hz;        /* default 10 */
    double control_hz;     /* default 50 (the firmware's RT rate); 1/scan_hz a multiple of it */
    double dt;             /* physics step, default 0.01 */
    double noise_sigma;    /* lidar range noise, default 0.01 m */
    double dropout_p;      /* lidar dropout, default 0 */
    double gps_sigma_xy;   /* default 0.01 m */
    double gps_sigma_theta;/* default 0.005 rad */
    double max_time_s;     /* default 3600 */
    struct sim_coverage *coverage; /* NULL (default), or every scan is added to it (sim_coverage.h) */
} sim_scan_cfg_t;

typedef struct sim_scan_stats {
    double sim_time_s;
    uint64_t scans;
    uint64_t samples;
    uint64_t samples_occupied;
    double distance_m;     /* travelled by the true pose */
    uint64_t collisions;   /* wall contact events */
    int waypoints_reached;
    int finished;
} sim_scan_stats_t;

/* Called every ~10 simulated seconds (may be NULL). */
typedef void (*sim_scan_progress_fn)(const sim_scan_stats_t *st, int n_waypoints, void *user);

sim_scan_cfg_t sim_scan_default_cfg(void);

/* Runs the loop and writes `out` (samples format, `source` in its header), whole or not at
 * all. Returns 0 when the path was finished; -ETIMEDOUT when max_time_s passed first (an
 * earlier `out` stays as it was); other negative codes with a message in err. stats is
 * filled either way. Uses the process's one host board and firmware link: not re-entrant. */
FS_MUST_CHECK
int sim_scan_run(const sim_plan_t *plan, const sim_path_t *path, const sim_scan_cfg_t *cfg,
                 const char *out, const char *source, sim_scan_stats_t *stats,
                 sim_scan_progress_fn progress, void *user, char *err, size_t errlen);

#endif /* SIM_SCAN_H */
