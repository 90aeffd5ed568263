/* One robot drives its waypoint path in the ODE world and turns its lidar scans into
 * training samples: the loop behind `host_sim scan`.
 *
 * Each simulated control tick (control_hz): the GPS/compass reading (sim_gps_read) goes to
 * the firmware waypoint follower (rt_follow_step), whose wheel speeds drive the hinge motors.
 * Each scan tick (scan_hz): a full lidar scan (sim_lidar_scan, sensor_beams beams with
 * noise and dropout) is converted by the firmware rt_samples_from_scan at the GPS pose (what
 * the robot believes) into beams x points samples, appended to the samples file.
 * The robot starts at the first waypoint facing the second. The run ends when the follower
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
    double control_hz;     /* default 20 */
    double dt;             /* physics step, default 0.01 */
    double noise_sigma;    /* lidar range noise, default 0.01 m */
    double dropout_p;      /* lidar dropout, default 0 */
    double gps_sigma_xy;   /* default 0.01 m */
    double gps_sigma_theta;/* default 0.005 rad */
    double max_time_s;     /* default 3600 */
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

/* Runs the loop and writes `out` (samples format, `source` in its header).
 * Returns 0 when the path was finished; -ETIMEDOUT when max_time_s passed first (the file
 * is removed); other negative codes with a message in err. stats is filled either way. */
FS_MUST_CHECK
int sim_scan_run(const sim_plan_t *plan, const sim_path_t *path, const sim_scan_cfg_t *cfg,
                 const char *out, const char *source, sim_scan_stats_t *stats,
                 sim_scan_progress_fn progress, void *user, char *err, size_t errlen);

#endif /* SIM_SCAN_H */
