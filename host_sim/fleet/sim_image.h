/* One robot's firmware image (fw_robot: RT, AI, GP cores as threads) run by the host HAL in
 * lockstep against the ODE world (sim_hal_world), in this process: the engine behind
 * `host_sim run` and the tests in tests/image.
 *
 * sim_image_run() builds the world binding and the host board (serial lockstep by default,
 * storage in cfg->storage_dir, network cfg->net_url), starts the image, and advances
 * simulated time in slices of one second until the GP core handled the final checkpoint
 * (all C rounds done) or time_limit_s passed. After each slice it hands every new round
 * record (the GP core's log) to the callback, which may read the checkpoint the GP core wrote
 * and print. Then it stops the cores and fills *res with every figure (profiling included).
 * Static firmware state: one run at a time per process.
 * It also stops early, in good order, at the end of a slice:
 *   - when a round record comes back with a checkpoint that could not be written
 *     (res->ckpt_error, ->ckpt_error_round: the first one): a robot whose storage fails
 *     stops at once instead of training on to the last round;
 *   - when a stop was requested (SIGINT/SIGTERM, hal_host_stop.h; res->stop_signal): the
 *     lockstep ends before its next instant, and a GP core waiting for its peers ends its
 *     wait (hal_net_wait returns -ECANCELED).
 * Resuming: cfg->start_round and cfg->resume_ckpt go to the AI core (ai_core.h: the run
 * continues at round start_round with theta from the checkpoint; duals and Adam moments
 * restart at zero); the GP core's round log then begins at start_round.
 *
 * Seeds (all from cfg->seed): lidar and GPS noise = seed; model weights, minibatches, BNN
 * noise and reservoir as agent `robot` of the in-process fleet (ai_core_seeds), so a fleet
 * of processes and `host_sim fleet --inproc` train the same models.
 * With cfg->fleet the robot is a member of a fleet over the network (gp_fleet): the host
 * types the fleet's channels (hal_host_msg bounds check) and sizes the receive queue. Same seed, same inputs ->
 * bit-identical checkpoints (serial lockstep), whatever the CPU count or load. */
#ifndef SIM_IMAGE_H
#define SIM_IMAGE_H

#include <stddef.h>
#include <stdint.h>

#include "fw_robot.h"
#include "gp/gp_fleet.h"
#include "hal_host.h"
#include "sim_hal_world.h"
#include "sim_paths.h"
#include "sim_plan.h"

typedef void (*sim_image_round_fn)(const ai_round_info_t *info, void *user);
typedef void (*sim_image_fleet_round_fn)(const gp_fleet_round_t *r, void *user);
/* After every simulated second: the RT core's status and the GP core's (exploration state). */
typedef void (*sim_image_second_fn)(uint64_t now_us, const rt_status_t *rt, const gp_core_t *gp, void *user);

typedef struct sim_image_cfg {
    uint64_t seed;
    uint32_t robot;
    uint32_t rounds;             /* DiNNO rounds in all */
    uint32_t rounds_per_boundary; /* online: DiNNO rounds per communication round (0 = 1) */
    int offline;                 /* every round after the tour (paper section 6.3) */
    ai_pool_policy_t policy;
    uint32_t steps_per_round;    /* B (DiNNO primal steps) */
    float kl_weight;
    int train_between;
    uint32_t pool_samples;       /* the pool's capacity (ai_core_cfg_t; 0: AI_POOL_CAPACITY) */
    dinno_cfg_t dinno;           /* other optimiser settings (primal_steps, kl_weight overridden) */
    double time_limit_s;         /* simulated seconds, > 0 */
    const char *storage_dir;     /* checkpoints go here (created); NULL: no storage */
    const char *net_url;         /* NULL: no network; "memq://" in-process */
    const char *net_faults;      /* NULL: none; else faults injected on receive (hal_host_netfault.h),
                                    seeded from seed and robot unless the spec has seed= */
    const hal_host_auth_t *net_auth; /* NULL: unkeyed; else a keyed fleet (hal_host_auth.h) */
    int net_groups;              /* LCM: the fleet's states on a group per sender and what is for
                                    one robot on its inbox group (hal_host_net_group_by_*); needs
                                    fleet->addressed, every member alike */
    hal_host_sched_t sched;
    hal_log_level_t log_level;
    uint32_t ckpt_every;         /* round checkpoints every N rounds (1: all; 0: final only) */
    uint32_t ckpt_keep;          /* the newest K kept (0: all) ... */
    uint32_t ckpt_keep_every;    /* ... and every M-th (gp_core_cfg_t; defaults 5 and 100) */
    uint32_t start_round;        /* first round to run (0: a fresh run; < rounds) */
    const uint8_t *resume_ckpt;  /* NULL, or the checkpoint (bnn_ckpt) the model starts from */
    size_t resume_ckpt_bytes;
    const gp_fleet_cfg_t *fleet; /* NULL: no peers; else a fleet member over net_url */
    sim_image_round_fn on_round;  /* may be NULL */
    sim_image_fleet_round_fn on_fleet_round; /* may be NULL: each round's traffic record */
    sim_image_second_fn on_second; /* may be NULL */
    void *second_user;
    void *user;
    sim_coverage_t *coverage;    /* NULL, or every scan the world takes is added to it (sim_hal_world.h) */
    const struct sim_explore_opts *explore; /* NULL: follow the path; else explore from its start
                                               (sim_explore.h; the path's first point) */
} sim_image_cfg_t;

typedef struct sim_image_result {
    int completed;                /* 1 when all C rounds were done before the time limit */
    int stop_signal;              /* the signal that stopped the run early (hal_host_stop.h), or 0 */
    int32_t ckpt_error;           /* first checkpoint write that failed (negative errno), or 0:
                                     the run stopped at the end of that slice */
    uint32_t ckpt_error_round;    /* its round */
    uint64_t sim_time_us;
    double wall_s;
    uint32_t rounds_done;
    sim_hal_world_stats_t world;
    uint64_t host_world_steps;    /* hal_host_world_steps */
    hal_host_core_stats_t core[HAL_CORE_COUNT];
    fw_core_stats_t fw[HAL_CORE_COUNT];
    rt_core_stats_t rt;
    rt_status_t rt_status;
    ai_status_t ai_status;
    uint64_t ai_empty_rounds;
    gp_core_stats_t gp;
    gp_explore_stats_t explore;   /* exploring: the GP core's goal counters */
    gp_goal_stats_t claims;       /* exploring: the peers' claims taken, refused, expired */
    int32_t final_ckpt_status;
    fw_robot_memory_t mem;
    gp_fleet_stats_t fleet;       /* with cfg->fleet */
    gp_pse_stats_t pse;
    hal_net_stats_t net;
    float path_length_m;
} sim_image_result_t;

void sim_image_cfg_default(sim_image_cfg_t *cfg);

/* Runs the image. Returns 0 when it ran (check res->completed), or a negative code with a
 * message in err (bad configuration, world or board creation failed, physics failed). */
FS_MUST_CHECK int sim_image_run(const sim_plan_t *plan,
                                                      const sim_path_t *path,
                                                      const sim_image_cfg_t *cfg,
                                                      sim_image_result_t *res, char *err,
                                                      size_t errlen);

/* Occupancy MSE of the mean-weight map of m against the plan's ground truth, over the known
 * cells of a res-metre grid (sim_occ_eval) whose centre lies within radius_m of the path
 * polyline. *n_cells receives how many cells counted. Returns 0 or a negative code. */
FS_MUST_CHECK int sim_image_occ_near_path(const sim_plan_t *plan,
                                                                const sim_path_t *path,
                                                                bnn_model_t *m, double res,
                                                                double radius_m, double *mse,
                                                                size_t *n_cells);

#endif /* SIM_IMAGE_H */
