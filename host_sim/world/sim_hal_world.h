/* Binding of host_sim's world to the host HAL: an adapter that fills a hal_host_world_t so
 * hal_host runs the firmware image in lockstep against the ODE world (sim_world + sim_lidar,
 * same process). One robot per binding.
 *
 *   advance_to_us(t)  applies the latest wheel command, steps the physics to
 *                     floor(t / dt) steps (the physics never runs ahead of the cores: the
 *                     back end calls it only when every core sleeps until >= t), then
 *                     refreshes the cached GPS + compass fix and, when a scan is due
 *                     (every scan_period_us), takes a lidar scan at the true pose.
 *   read_pose         the cached fix: true pose + GPS/compass noise keyed by
 *                     (seed, robot, physics step), so a reading depends only on the time
 *                     it was taken, never on who reads it or how often.
 *   read_scan         the cached latest scan (stamp = the time it was taken; noise keyed
 *                     by (seed, robot, scan index)).
 *   set_wheels        stores the command; the next advance applies it (zero-order hold).
 * Every ODE call therefore runs on the thread that drives hal_host_run_until() (the
 * creator's thread), never on a core thread. A first scan and fix exist at t = 0.
 * The robot starts at the path's first waypoint facing the second.
 *
 * Host side: create allocates; the callbacks allocate nothing. */
#ifndef SIM_HAL_WORLD_H
#define SIM_HAL_WORLD_H

#include <stddef.h>
#include <stdint.h>

#include "hal_host.h"
#include "rt/rt_core.h"
#include "sim_coverage.h"
#include "sim_lidar.h"
#include "sim_paths.h"
#include "sim_plan.h"
#include "sim_world.h"

typedef struct sim_hal_world_cfg {
    uint32_t robot;           /* keys the noise streams */
    uint64_t seed;            /* lidar and GPS noise */
    sim_world_cfg_t world;
    sim_lidar_cfg_t lidar;    /* n_beams <= HAL_LIDAR_MAX_BEAMS; its seed is replaced by `seed` */
    double gps_sigma_xy;      /* m, default 0.01 (as host_sim scan) */
    double gps_sigma_theta;   /* rad, default 0.005 */
    uint32_t scan_period_us;  /* default 100000 (10 Hz); a multiple of the physics step */
    sim_coverage_t *coverage; /* NULL (default), or every scan taken is added to it at the true
                                 pose and its time (the caller owns it; read it after the run) */
} sim_hal_world_cfg_t;

typedef struct sim_hal_world_stats {
    uint64_t steps;           /* physics steps */
    uint64_t advances;        /* advance_to_us calls */
    uint64_t scans;
    uint64_t pose_reads, scan_reads, wheel_cmds;
    uint64_t t_us;            /* time simulated up to */
    double distance_m;        /* travelled by the true pose */
    uint64_t collisions;
    sim_pose_t truth;
} sim_hal_world_stats_t;

typedef struct sim_hal_world sim_hal_world_t;

sim_hal_world_cfg_t sim_hal_world_default_cfg(void);

/* Builds the world for plan, a robot at the start of path. Returns 0 or a negative code with
 * a message in err. */
FS_MUST_CHECK int sim_hal_world_create(const sim_plan_t *plan,
                                                             const sim_path_t *path,
                                                             const sim_hal_world_cfg_t *cfg,
                                                             sim_hal_world_t **out, char *err,
                                                             size_t errlen);
void sim_hal_world_destroy(sim_hal_world_t *hw);

/* The callbacks to put in hal_host_config_t.world (valid until destroy). */
const hal_host_world_t *sim_hal_world_ops(sim_hal_world_t *hw);

/* Figures so far (read between hal_host_run_until calls or after the cores stopped). */
void sim_hal_world_get_stats(const sim_hal_world_t *hw, sim_hal_world_stats_t *st);

/* The robot's wheel geometry (for hal_host_config_t's twist support). */
void sim_hal_world_wheels(const sim_hal_world_t *hw, float *radius_m, float *separation_m);

/* The host board on this world, as every firmware run in host_sim uses it: `base` (sched,
 * log, net, storage) with the robot id, the world callbacks and the wheel geometry set;
 * created and installed. 0 or a negative code with a message in err. */
FS_MUST_CHECK int sim_hal_world_host(sim_hal_world_t *hw, uint32_t robot, hal_host_config_t base, hal_host_t **out,
                                     char *err, size_t errlen);

/* The RT core's configuration for a robot of this world driving `path` on `plan`: the
 * waypoints (written to wps, path->n of them), the follower at the robot's speed limits and
 * wheel geometry, the default beams and points over the plan's box. period_us is left 0. */
void sim_hal_world_rt_cfg(const sim_plan_t *plan, const sim_path_t *path, rt_waypoint_t *wps, rt_core_cfg_t *rc);

#endif /* SIM_HAL_WORLD_H */
