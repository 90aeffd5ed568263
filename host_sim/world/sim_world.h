/* The ODE world of host_sim: static walls extruded from a floor plan, a floor, and
 * differential-drive robots with TurtleBot3-burger-like sizes.
 *
 * Frames and units: metres, radians, seconds, kilograms; world z is up, the floor is z = 0.
 * A robot's pose (x, y, theta) is its base frame: the midpoint of the wheel axis on the
 * floor, theta = heading of its +x (forward) axis, CCW from world +x.
 *
 * Geometry (see sim_world.c for the why):
 *   - every plan->solids[i] becomes a static geom from z = 0 to wall_height (to its own
 *     height when it has one, e.g. a railing's 1 m, capped at wall_height): a dBox when the
 *     solid is a rectangle, otherwise an extruded-polygon trimesh (ear-clipped caps + side
 *     quads); all walls live in one quadtree space sized to the plan (sim_world_walls());
 *   - a robot: chassis box (base_length x base_width x base_height) whose centre is
 *     chassis_offset_x behind the wheel axis, two sphere wheels (radius wheel_radius) on
 *     hinge joints along the robot's y axis, driven by velocity motors (dParamVel, with
 *     torque limit dParamFMax = motor_fmax), and a frictionless sphere caster fixed to
 *     the chassis at caster_offset_x;
 *   - contacts: wheel/floor Coulomb friction mu_wheel (friction pyramid, dContactApprox1;
 *     or no slip),
 *     caster/floor mu = 0, anything/wall mu_wall; contacts are rebuilt every step.
 * Time is simulated only: sim_world_step() advances a fixed dt with dWorldStep (or
 * dWorldQuickStep when configured).
 *
 * ODE is initialised once per process (dInitODE2 on the first create, dCloseODE at exit).
 * Thread-safety: a world must be used by one thread at a time, and sim_world_step() of two
 * worlds must not run concurrently (ODE's solver draws from one process-global random
 * generator, whose state each world saves and restores for determinism). Each thread that
 * uses ODE gets its per-thread data on create. Distinct worlds are otherwise independent:
 * a world's trajectory depends only on its own inputs (deterministic). */
#ifndef SIM_WORLD_H
#define SIM_WORLD_H

#include <stddef.h>
#include <stdint.h>

#include <ode/ode.h>

#include "sim_plan.h"

typedef struct sim_world_cfg {
    double dt;              /* s, fixed step, (0, 0.05]; default 0.01 */
    double wall_height;     /* m, > 0; default 2.5 */
    double gravity;         /* m/s^2 downwards, >= 0; default 9.81 */
    int solver_iterations;  /* 0 = exact dWorldStep (default); 1..1000 = dWorldQuickStep iterations */
    double mu_wheel;        /* wheel/floor Coulomb friction coefficient >= 0 (default 1.0), or
                             * INFINITY for no-slip wheels (unbounded friction rows: faster, but
                             * ODE's LCP degenerates when a robot presses on a wall) */
    double mu_wall;         /* friction against walls; default 0.3 */
} sim_world_cfg_t;

typedef struct sim_robot_params {
    double base_length, base_width, base_height; /* m: 0.14 x 0.18 x 0.14 */
    double chassis_offset_x;                     /* m, chassis centre ahead (+) of the axis: -0.032 */
    double chassis_mass;                         /* kg: 0.8 */
    double wheel_radius;                         /* m: 0.033 */
    double wheel_separation;                     /* m: 0.160 */
    double wheel_mass;                           /* kg each: 0.1 */
    double caster_radius;                        /* m: 0.02 */
    double caster_offset_x;                      /* m: -0.081 */
    double v_max;                                /* m/s: 0.22 */
    double w_max;                                /* rad/s: 2.84 */
    double motor_fmax;                           /* N m per wheel motor: 1.0 */
} sim_robot_params_t;

typedef struct sim_pose {
    double x, y, theta;
} sim_pose_t;

typedef struct sim_world sim_world_t;

sim_world_cfg_t sim_world_default_cfg(void);

/* Initialises ODE for the process (once) and ODE's per-thread data for the calling thread.
 * sim_world_create() does this for its caller; a thread that steps a world or casts rays in a
 * world created by another thread calls this first. Returns 0 or a negative code. */
FS_MUST_CHECK
int sim_world_thread_init(void);
sim_robot_params_t sim_robot_default_params(void);

/* Builds the world for `plan` (not retained; the world copies what it needs).
 * cfg NULL = defaults. On failure returns a negative code and a message in err. */
FS_MUST_CHECK
int sim_world_create(const sim_plan_t *plan, const sim_world_cfg_t *cfg, sim_world_t **out,
                     char *err, size_t errlen);
void sim_world_destroy(sim_world_t *w);

/* Adds a robot at pose (the robot rests on the floor). params NULL = defaults.
 * *id receives its index (0, 1, ...). Returns 0, -EINVAL or -ENOMEM. */
FS_MUST_CHECK
int sim_world_add_robot(sim_world_t *w, const sim_robot_params_t *params, sim_pose_t pose,
                        int *id);

/* Wheel angular velocity targets, rad/s (positive = forward), each clamped to
 * +-v_max / wheel_radius. Held until changed. Returns 0 or -EINVAL. */
FS_MUST_CHECK
int sim_world_set_wheels(sim_world_t *w, int id, double left, double right);

/* Same from a body twist: v (m/s) and omega (rad/s) through the differential-drive
 * inverse kinematics (rt_follow_wheels), with the same wheel clamp. */
FS_MUST_CHECK
int sim_world_set_twist(sim_world_t *w, int id, double v, double omega);

/* Advances n_steps fixed steps. Returns 0, -EINVAL, or -EIO if the simulation produced
 * a non-finite state (the world is unusable then). */
FS_MUST_CHECK
int sim_world_step(sim_world_t *w, int n_steps);

FS_MUST_CHECK
int sim_world_pose(const sim_world_t *w, int id, sim_pose_t *pose);

/* Wheel angular velocities actually reached (rad/s), for odometry. */
FS_MUST_CHECK
int sim_world_wheel_rates(const sim_world_t *w, int id, double *left, double *right);

/* Number of wall contact episodes since the robot was added: a contact between any robot geom
 * and a wall counts as a new collision when the robot had no wall contact during the previous
 * SIM_WORLD_COLLISION_GAP_S simulated seconds (pressing on a wall is one collision). */
#define SIM_WORLD_COLLISION_GAP_S 0.5
uint64_t sim_world_collisions(const sim_world_t *w, int id);

double sim_world_time(const sim_world_t *w);  /* simulated seconds since create */
double sim_world_dt(const sim_world_t *w);
int sim_world_robot_count(const sim_world_t *w);
const sim_robot_params_t *sim_world_robot_params(const sim_world_t *w, int id);

/* The space holding every wall geom and nothing else (for the lidar's rays). */
dSpaceID sim_world_walls(const sim_world_t *w);

/* Bounding box of the plan the world was built from. */
void sim_world_bounds(const sim_world_t *w, sim_vec2_t *min, sim_vec2_t *max);

#endif /* SIM_WORLD_H */
