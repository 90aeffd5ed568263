/* Sensors of a simulated robot: a planar 2D lidar cast with ODE rays against the walls, and
 * GPS position plus compass heading (the paper assumes global positioning).
 *
 * Lidar: n_beams beams over a full turn; beam i points at theta + angle_min + i * 2 pi /
 * n_beams (CCW), from the robot's (x, y) at height mount_height. Each beam is one ODE ray
 * geom repositioned with dGeomRaySet and collided with the walls' space only (dSpaceCollide2
 * of the ray against sim_world_walls()), so the robot's own body and other robots are never
 * seen. Ray flags: closest hit, backface culling (walls are closed solids).
 * Range encoding (what rt_samples_from_scan() expects):
 *   finite r: a hit at r metres, range_min <= r < range_max (true distance + N(0, sigma^2));
 *   +INFINITY: nothing within range_max;
 *   NaN: a dropout (probability dropout_p) or a surface closer than range_min.
 * Noise is counter-based: the value of beam b of scan s of robot k is a pure function of
 * (seed, k, s, b), so runs are reproducible and scans can be regenerated in any order.
 *
 * A sim_lidar_t holds one ray geom: one thread at a time per lidar; create one per thread. */
#ifndef SIM_LIDAR_H
#define SIM_LIDAR_H

#include <stdint.h>

#include "sim_world.h"

#define SIM_LIDAR_MAX_BEAMS 4096

typedef struct sim_lidar_cfg {
    int n_beams;         /* 1 .. SIM_LIDAR_MAX_BEAMS; default 360 */
    double range_min;    /* m, >= 0; default 0.12 */
    double range_max;    /* m, > range_min; default 3.5 */
    double noise_sigma;  /* m, >= 0; default 0.01 */
    double dropout_p;    /* [0, 1); default 0 */
    double mount_height; /* m, > 0; default 0.17 (below the 2.5 m walls) */
    double angle_min;    /* rad, beam 0 relative to the heading; default 0 */
    uint64_t seed;
} sim_lidar_cfg_t;

typedef struct sim_lidar sim_lidar_t;

sim_lidar_cfg_t sim_lidar_default_cfg(void);

/* Returns 0, -EINVAL (bad cfg) or -ENOMEM. */
FS_MUST_CHECK
int sim_lidar_create(const sim_lidar_cfg_t *cfg, sim_lidar_t **out);
void sim_lidar_destroy(sim_lidar_t *l);
const sim_lidar_cfg_t *sim_lidar_cfg(const sim_lidar_t *l);

/* Angle increment between beams, 2 pi / n_beams. */
double sim_lidar_angle_inc(const sim_lidar_t *l);

/* Noise-free distance along one horizontal ray from (x, y) at heading `angle` to the first
 * wall, or +INFINITY when none is within range_max. */
double sim_lidar_cast(sim_lidar_t *l, const sim_world_t *w, double x, double y, double angle);

/* One full scan from pose (x, y, theta) into ranges[n_beams] with the noise model above.
 * robot and scan_index key the noise. When `truth` is non-NULL it receives the noise-free
 * distances (+INFINITY for no hit). Returns 0 or -EINVAL. */
FS_MUST_CHECK
int sim_lidar_scan(sim_lidar_t *l, const sim_world_t *w, double x, double y, double theta,
                   uint32_t robot, uint64_t scan_index, float *ranges, double *truth);

/* GPS + compass. */
typedef struct sim_gps_cfg {
    double sigma_xy;    /* m, >= 0; default 0.02 */
    double sigma_theta; /* rad, >= 0; default 0.01 */
    uint64_t seed;
} sim_gps_cfg_t;

sim_gps_cfg_t sim_gps_default_cfg(void);

/* Noisy reading of the true pose; noise keyed by (seed, robot, index).
 * Returns 0 or -EINVAL. theta is wrapped to (-pi, pi]. */
FS_MUST_CHECK
int sim_gps_read(const sim_gps_cfg_t *cfg, uint32_t robot, uint64_t index,
                 const sim_pose_t *truth, sim_pose_t *out);

#endif /* SIM_LIDAR_H */
