/* Validation set like DiNNO's reference: N random free poses, each with a full noise-free
 * scan against the ground-truth walls, labelled like the training samples (rt_samples:
 * per beam K points evenly spaced to the hit, the hit 1, the rest 0; no hit -> free points
 * to range_max). Default 500 poses x (20 beams x 25 points) = 500 x 500 points.
 *
 * Poses: x, y uniform over the plan's bounding box, kept when the point is FREE
 * (sim_plan_classify_point), inside a room of the plan (when the plan has rooms), and at
 * least clearance_m from every solid; heading uniform in [0, 2 pi). Each coordinate is a
 * counter-based draw keyed by (seed, pose index, attempt), so the set is deterministic.
 * Thread-safe per call (it builds its own ODE world); allocates. */
#ifndef SIM_VALSET_H
#define SIM_VALSET_H

#include <stddef.h>
#include <stdint.h>

#include "ai/ai_sample.h"
#include "sim_plan.h"
#include "sim_world.h"

typedef struct sim_valset_cfg {
    int n_poses;         /* 1 .. 1000000; default 500 */
    int n_beams;         /* 1 .. 4096; default 20 */
    int points_per_beam; /* 1 .. 1024; default 25 */
    double clearance_m;  /* >= 0; default 0.2 */
    double range_max;    /* m, > 0; default 3.5 */
    uint64_t seed;
} sim_valset_cfg_t;

sim_valset_cfg_t sim_valset_default_cfg(void);

/* Draws the poses only (poses[cfg->n_poses]). Returns 0, -EINVAL, or -ENOENT when no free
 * pose was found within 100000 attempts for some pose (the plan has no free room space). */
FS_MUST_CHECK
int sim_valset_poses(const sim_plan_t *plan, const sim_valset_cfg_t *cfg, sim_pose_t *poses,
                     char *err, size_t errlen);

/* Generates the set and writes it to `path` in the samples format (sim_samples.h), with
 * `source` in the header. *n_samples (optional) receives the record count.
 * Returns 0 or a negative code with a message in err. */
FS_MUST_CHECK
int sim_valset_write(const sim_plan_t *plan, const sim_valset_cfg_t *cfg, const char *path,
                     const char *source, uint64_t *n_samples, char *err, size_t errlen);

#endif /* SIM_VALSET_H */
